"""The genetic algorithm of 000 §4.2 (and 001 §4) for the sample patches: rank-based roulette selection,
crossover with repair, segment mutation (:func:`run_ga`)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ...errors import ParameterError
from .draws import Region, _region
from .draws import int_param as _int_param
from .population import (
    MAX_GENERATIONS,
    MAX_POPULATION,
    Evaluate,
    Progress,
    SelectionResult,
    _bool_param,
    _draw_excluding,
    _Evaluator,
    _float_param,
    _random_population,
    _result,
    _Run,
    as_generator,
)

# --------------------------------------------------------------------------------------------------------------
# GA operators (000 §4.2)


def rank_probabilities(size: int, alpha: float) -> np.ndarray:
    """Selection probabilities of the rank-based roulette of 000 §4.2.

    eval(A_i) = α(1−α)^(i−1) for the population sorted best first (i = 1 .. size); the wheel is spun with
    γ uniform in (0, q_size], so individual i is drawn with probability eval(A_i) / Σ_k eval(A_k).
    """
    size = _int_param("size", size, 1)
    alpha = _float_param("alpha", alpha, 0.0, 1.0, lo_open=True, hi_open=True)
    w = alpha * (1.0 - alpha) ** np.arange(size, dtype=np.float64)
    return w / w.sum()


def roulette_select(rng: np.random.Generator, size: int, alpha: float, draws: int) -> np.ndarray:
    """Indices (into the population sorted best first) of ``draws`` spins of the rank-based roulette wheel.

    Literal steps of 000: q_0 = 0, q_i = Σ_{k<=i} eval(A_k); γ uniform in (0, q_size]; pick i with
    q_{i−1} < γ <= q_i.
    """
    size = _int_param("size", size, 1)
    alpha = _float_param("alpha", alpha, 0.0, 1.0, lo_open=True, hi_open=True)
    q = np.cumsum(alpha * (1.0 - alpha) ** np.arange(size, dtype=np.float64))
    gamma = q[-1] * (1.0 - rng.random(draws))  # (0, q_size]
    return np.minimum(np.searchsorted(q, gamma, side="left"), size - 1).astype(np.int64)


def crossover_repair(
    rng: np.random.Generator, first: np.ndarray, second: np.ndarray, c: int, region: Region
) -> tuple[np.ndarray, np.ndarray]:
    """One-point crossover of two gene vectors at 1-based position ``c`` ∈ [2, n], with repair.

    The children are X = (g_1^1 .. g_1^{c−1}, g_2^c .. g_2^n) and Y = (g_2^1 .. g_2^{c−1}, g_1^c .. g_1^n)
    (000 §4.2). A child can then hold the same position twice (a head gene of one parent equal to a tail gene of
    the other). **Repair**: scanning the tail from position c, a gene that already occurs earlier in the child
    is replaced by the gene its own head-parent had at that position (the gene the crossover displaced) when that
    one is not in the child; otherwise by a uniformly random position not in the child. Parents without
    duplicates yield children without duplicates; a child is unchanged when no duplicate occurs.
    """
    n = first.shape[0]
    if not 2 <= c <= n:
        raise ParameterError(f"c = {c}: crossover position must be in [2, {n}]")
    k = c - 1  # 0-based start of the swapped tail
    f1, f2 = region.flat(first).tolist(), region.flat(second).tolist()
    children = []
    for head, tail in ((f1, f2), (f2, f1)):
        child = head[:k] + tail[k:]
        seen = set(child[:k])
        for j in range(k, n):
            if child[j] in seen:
                cand = head[j]
                if cand in seen or cand in child[j + 1 :]:
                    cand = _draw_excluding(rng, region.size, seen | set(child[j:]), 1)[0]
                child[j] = cand
            seen.add(child[j])
        children.append(region.unflat(child))
    return children[0], children[1]


def ga_crossover(
    rng: np.random.Generator, mothers: np.ndarray, p_crossover: float, region: Region
) -> tuple[np.ndarray, int]:
    """Crossover step of 000 §4.2 on the mother chromosomes (P, n, 2); returns (new generation, pairs).

    Mother i enters the parent list when a uniform γ < P_c, else the non-parent list; an odd last parent is moved
    to the non-parents; parents are paired in order ((1, 2), (3, 4), ...). One c ∈ [2, n] is drawn per generation
    and applied to every pair (000: "a random natural number c ∈ [2, n] is generated and applied to the
    crossover operation to each parent pair"). Children take their parents' slots, so the new generation is
    children plus non-parents. With n = 1 there is no valid c and the generation is unchanged.
    """
    out = mothers.copy()
    size, n = mothers.shape[0], mothers.shape[1]
    parents = np.nonzero(rng.random((size,)) < p_crossover)[0]
    if parents.size % 2:
        parents = parents[:-1]
    if parents.size == 0 or n < 2:
        return out, 0
    c = int(rng.integers(2, n + 1))
    for a, b in parents.reshape(-1, 2):
        out[a], out[b] = crossover_repair(rng, mothers[a], mothers[b], c, region)
    return out, parents.size // 2


def segment_mutation(rng: np.random.Generator, genes: np.ndarray, region: Region) -> np.ndarray:
    """Segment mutation of 000 §4.2: every gene from position n1 to n2 (n1 < n2) becomes a new random position.

    (n1, n2) is uniform over the pairs 1 <= n1 < n2 <= n (1-based), i.e. any segment of two or more genes. The
    new genes are distinct from each other and from every gene the chromosome holds before the mutation, the
    replaced ones included ("a random patch ... which does not equal to any of the existing genes"); if the
    region is too small for that, only from the genes kept. With n = 1 the single gene is replaced.
    """
    n = genes.shape[0]
    if n == 1:
        i1, i2 = 0, 0
    else:
        i1, i2 = sorted(int(v) for v in rng.choice(n, size=2, replace=False))
    flat = region.flat(genes).tolist()
    seg = i2 - i1 + 1
    kept = set(flat[:i1] + flat[i2 + 1 :])
    forbidden = set(flat) if region.size - n >= seg else kept
    new = _draw_excluding(rng, region.size, forbidden, seg)
    flat[i1 : i2 + 1] = new
    return region.unflat(flat)


# Length: 94 lines, of which 43 are the docstring (000's operators and stop rules); the body is 51.
def run_ga(
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    population: int = 40,
    alpha: float = 0.05,
    p_crossover: float = 0.3,
    p_mutation: float = 0.2,
    generations: int = 50,
    stagnation: int = 5,
    elitism: bool = False,
    progress: Progress | None = None,
) -> SelectionResult:
    """Genetic algorithm of 000 §4.2 (Dong et al.), minimising E.

    Each generation:

    1. **Evaluation**: E of every chromosome (one call); the population is sorted from high fitness F = 1/E to
       low, i.e. by increasing E (stable sort, so ties keep their order).
    2. **Selection**: ``population`` spins of the rank-based roulette eval(A_i) = α(1−α)^(i−1)
       (:func:`roulette_select`) give the mother chromosomes.
    3. **Crossover**: parent list by P_c, odd member moved to the non-parents, one-point crossover at
       c ∈ [2, n] with repair (:func:`ga_crossover`, :func:`crossover_repair`).
    4. **Mutation**: each chromosome of the new generation, with probability P_m, gets a segment mutation
       (:func:`segment_mutation`).

    The initial population (``population`` random chromosomes) is generation 1. The run stops after
    ``generations`` generations (N_g) or when the best E ever seen has not decreased for ``stagnation``
    consecutive generations (N_o), so a constant objective stops after N_o + 1 generations.

    Interpretation choices
    ----------------------
    * **Mutation segment**: 000 and 001 print 1 <= n1 < n2 <= n − 1. Read literally with 1-based genes, the
      last gene could never mutate and n = 2 (the smallest sets) could not mutate at all; nothing in the paper
      motivates that asymmetry, so we take 1 <= n1 < n2 <= n (the "n − 1" read as the last 0-based index).
    * **Crossover point**: one c per generation shared by all pairs, as written.
    * **Repair**: the paper's genes must be distinct patches but its crossover can duplicate one; see
      :func:`crossover_repair` (put back the displaced gene, else a random unused position).
    * **Elitism**: 000 returns "the best solution among all these generations", i.e. a best-ever record; it does
      not say the best chromosome survives in the population (and 003 §4 criticises this GA because it
      "sometimes looses the best solution"). So by default the best is only recorded, and the result is the
      best ever evaluated. ``elitism=True`` additionally puts the best-ever chromosome back in place of the
      worst of each new generation when no chromosome of that generation is as good.
    * **Cache**: unchanged chromosomes (non-parents not mutated, ~56 % with the defaults) are not re-evaluated.

    Parameters
    ----------
    evaluate : ``genes[P, n, 2] -> (E[P], D[P, m])``.
    shape : exemplar shape (H, W[, C]).
    n : number of genes (sample patches).
    tile_size : N.
    rng : seed or Generator.
    population, alpha, p_crossover, p_mutation, generations, stagnation : pop_size, α, P_c, P_m, N_g, N_o.
    elitism : keep the best-ever chromosome in the population (see above).
    progress : ``progress("ga", generation, generations)`` once per generation.
    """
    t0 = time.perf_counter()
    shp, n, t, region = _region(shape, n, tile_size)
    params: dict[str, Any] = {
        "population": _int_param("population", population, 2, MAX_POPULATION),
        "alpha": _float_param("alpha", alpha, 0.0, 1.0, lo_open=True, hi_open=True),
        "p_crossover": _float_param("p_crossover", p_crossover, 0.0, 1.0),
        "p_mutation": _float_param("p_mutation", p_mutation, 0.0, 1.0),
        "generations": _int_param("generations", generations, 1, MAX_GENERATIONS),
        "stagnation": _int_param("stagnation", stagnation, 1),
        "elitism": _bool_param("elitism", elitism),
    }
    size = params["population"]
    g = as_generator(rng)
    ev = _Evaluator(evaluate, n)
    run = _Run("ga", params["generations"], params["stagnation"], progress)

    pop = _random_population(g, size, shp, n, t)
    E, _ = ev(pop)
    run.generation(E, ev.best_E)
    while (stop := run.stop_reason()) is None:
        order = np.argsort(E, kind="stable")
        pop = pop[order]
        mothers = pop[roulette_select(g, size, params["alpha"], size)]
        children, _ = ga_crossover(g, mothers, params["p_crossover"], region)
        for i in np.nonzero(g.random(size) < params["p_mutation"])[0]:
            children[i] = segment_mutation(g, children[i], region)
        pop = children
        E, _ = ev(pop)
        if params["elitism"] and ev.best_E < E.min():
            worst = int(np.argmax(E))
            assert ev.best_genes is not None
            pop[worst] = ev.best_genes
            E[worst] = ev.best_E
        run.generation(E, ev.best_E)
    return _result("ga", ev, params, run, t0, stop)
