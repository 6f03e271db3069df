"""The artificial immune system of 003 §4.2 (adaptive dynamic clonal selection) for the sample patches:
affinity, clones, BGA mutation, deaths (:func:`run_ais`)."""

from __future__ import annotations

import math
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
    _Evaluator,
    _float_param,
    _random_population,
    _result,
    _Run,
    as_generator,
)

BGA_TERMS = 16
"""Number of terms γ_i 2^−i (i = 0 .. 15) of the BGA mutation step δ (Mühlenbein's BGA, k = 16)."""


# --------------------------------------------------------------------------------------------------------------
# AIS operators (003 §4.2)


def stratified_genes(rng: np.random.Generator, region: Region, n: int) -> np.ndarray:
    """One antibody of 003's stratified half: the valid region cut into n parts, one random patch per part.

    The region is cut into an a x b grid of near-equal cells (a·b = n, a <= rows, b <= cols, the factorisation
    whose cells are closest to square); when no such grid exists (e.g. n prime and larger than both sides) the
    row-major list of positions is cut into n near-equal runs. The n patches are then randomly permuted
    ("randomly arranged to be the genes"). They are distinct because the parts are disjoint.
    """
    best: tuple[float, int, int] | None = None
    for a in range(1, n + 1):
        if n % a:
            continue
        b = n // a
        if a <= region.rows and b <= region.cols:
            score = abs(math.log((region.rows / a) / (region.cols / b)))
            if best is None or score < best[0]:
                best = (score, a, b)
    if best is not None:
        _, a, b = best
        er = (np.arange(a + 1) * region.rows) // a
        ec = (np.arange(b + 1) * region.cols) // b
        ia, ib = np.divmod(np.arange(n), b)
        rows = rng.integers(er[ia], er[ia + 1])
        cols = rng.integers(ec[ib], ec[ib + 1])
        genes = np.stack([rows, cols], axis=1).astype(np.int64)
    else:
        edges = (np.arange(n + 1) * region.size) // n
        genes = region.unflat(rng.integers(edges[:-1], edges[1:]))
    return genes[rng.permutation(n)]


def population_diversity(pop: np.ndarray, region: Region) -> float:
    """Diversity h of an antibody population (003 §4.2.3), in [0, 1].

    h = sqrt( Σ_{i≠j} Σ_k ‖g_ik − g_jk‖² / (N_p (N_p − 1) n) ) / ‖u − l‖: the root-mean-square Euclidean
    distance between corresponding genes of two antibodies, divided by the diagonal ‖u − l‖ of the valid region.

    Interpretation: 003 prints h = sqrt(ΣΣ H_ij / ((N_p − 1) N_p)) / |u − l| with H_ij = Σ_k ‖g_ik − g_jk‖ and
    states 0 < h < 1. With H_ij in pixels the printed h has units of pixel^−1/2, depends on the exemplar size
    and exceeds 1 for small regions, contradicting the stated range. Taking squared distances under the root (and
    the mean over the n genes) makes the formula the dimensionless RMS distance the sqrt suggests and keeps
    h in [0, 1). A random population has h ≈ 1/sqrt(6) ≈ 0.41, a converged one h → 0, so the memory unit
    ⌊N_p·min(s_min + h, s_max)⌋ spans its intended range s_min .. s_max.
    """
    size, n = pop.shape[0], pop.shape[1]
    diag = math.hypot(region.rows - 1, region.cols - 1)
    if size < 2 or diag == 0.0:
        return 0.0
    x = pop.astype(np.float64)
    # Σ_{i,j} ‖x_i − x_j‖² = 2 N Σ_i ‖x_i‖² − 2 ‖Σ_i x_i‖² per gene and coordinate
    s = 2.0 * size * (x**2).sum() - 2.0 * (x.sum(axis=0) ** 2).sum()
    return float(math.sqrt(max(s, 0.0) / (size * (size - 1) * n)) / diag)


def relative_affinity(E: np.ndarray) -> np.ndarray:
    """f_i / Σ_j f_j with the affinity f = 1/E (003 §4.2.2); every AIS formula only uses this ratio.

    E must be >= 0. Antibodies with E = 0 (infinite affinity) share the whole mass.
    """
    E = np.asarray(E, dtype=np.float64)
    if (E < 0).any():
        raise ParameterError(
            f"evaluate returned E = {float(E.min())!r} < 0: the AIS affinity 1/E needs E >= 0"
        )
    if (E == 0).any():
        f = (E == 0).astype(np.float64)
    else:
        f = E.min() / E
    return f / f.sum()


def mutation_probabilities(rel: np.ndarray, h: float, n_memory: int, n: int, s_min: float) -> np.ndarray:
    """Mutation probability of every antibody, sorted best first (003 §4.2.4).

    p_i = p_c + [1 + exp(n · f_i / Σ_j f_j)]^−1 with p_c = (s_min + h) / 2, then the unit correction: memory
    antibodies (i <= N_m) are capped at p_M = min(1.4 p_c, 0.3), generic ones raised to at least
    p_Ab = min(3 p_c, 0.8); finally clipped to [0, 1].

    Interpretation: the garbled text prints p_M = min(1.4·p_mu, 0.3) and p_Ab = min(3.0·p_mu, 0.8) with a stray
    "c" superscript next to each, so p_mu is read as p_c (the only un-indexed probability defined). The factor
    in the exponent is printed as n, the number of genes, and is used as such.
    """
    p_c = (s_min + h) / 2.0
    p = p_c + 1.0 / (1.0 + np.exp(n * rel))
    p_mem = min(1.4 * p_c, 0.3)
    p_gen = min(3.0 * p_c, 0.8)
    idx = np.arange(p.size)
    p = np.where(idx < n_memory, np.minimum(p, p_mem), np.maximum(p, p_gen))
    return np.clip(p, 0.0, 1.0)


def clone_counts(rel: np.ndarray, n_memory: int, alpha: float, beta: float) -> np.ndarray:
    """Number of clones of every antibody, sorted best first (003 §4.2.5).

    μ_i = β · N_p · f_i / Σ_j f_j, rounded; memory antibodies get at most ⌊max(α N_p, N_p/3)⌋ clones and
    generic ones at most ⌊min(α N_p, N_p/3)⌋; every antibody gets at least one.

    Interpretation: 003 defines μ and then prints N_c = max(α N_p, N_p/3) for the memory unit and
    min(α N_p, N_p/3) for the generic unit, constants that do not use μ, although the text says the clone count
    is proportional to affinity ("the antibody with the highest affinity will produce the most clones") and
    calls α "the threshold value for both memory unit and generic unit". We read the two expressions as those
    thresholds, i.e. caps on μ per unit (16 and 13 with the defaults), the memory unit having the larger one;
    μ averages β = 4 clones per antibody. The floor of one clone follows "all the antibodies will be applied to
    this operator".
    """
    size = rel.size
    mu = np.floor(beta * size * rel + 0.5)
    cap_mem = max(1, int(math.floor(max(alpha * size, size / 3.0) + 1e-9)))
    cap_gen = max(1, int(math.floor(min(alpha * size, size / 3.0) + 1e-9)))
    cap = np.where(np.arange(size) < n_memory, cap_mem, cap_gen)
    return np.clip(mu, 1, cap).astype(np.int64)


def bga_delta(rng: np.random.Generator, size: tuple[int, ...]) -> np.ndarray:
    """BGA step factors δ = Σ_{i=0}^{15} γ_i 2^−i, γ_i = 1 with probability 1/16 (so δ ∈ [0, 2), often 0)."""
    gamma = rng.random((*size, BGA_TERMS)) < 1.0 / 16.0
    return (gamma * 2.0 ** -np.arange(BGA_TERMS, dtype=np.float64)).sum(axis=-1)


def bga_fold(x: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """003's out-of-range correction with l = 0, u = ``hi``: x ↦ (x + 0.2·(u − l)) / 1.4 where x ∉ [l, u].

    For the BGA steps (|x − g| < 0.2 (u − l) with g ∈ [l, u]) the result is inside [l, u]: values above u land in
    (0.857 u, u], values below 0 in [0, 0.143 u).
    """
    x = np.asarray(x, dtype=np.float64)
    return np.where((x < 0.0) | (x > hi), (x + 0.2 * hi) / 1.4, x)


def bga_mutation(
    rng: np.random.Generator, genes: np.ndarray, which: np.ndarray, region: Region, tries: int = 32
) -> np.ndarray:
    """BGA-style mutation of one gene per row (003 §4.2.5 step 2), vectorised over rows.

    ``genes`` is (C, n, 2), ``which`` (C,) the gene to mutate in each row. Each coordinate x of the gene (row and
    column, with its own range u − l) becomes x ± 0.1·δ·(u − l), the sign with equal probability and
    δ = Σ_{i=0}^{15} γ_i 2^−i with γ_i = 1 with probability 1/16. A value outside [l, u] = [0, u] is folded back
    with (x' + 0.2 (u − l)) / 1.4 (003; one fold always suffices since |0.1 δ| < 0.2), then rounded to the
    nearest integer position. If the new position equals another gene of the same antibody it is drawn again
    (at most ``tries`` times, then the gene is left unchanged), so the genes stay distinct. δ is often 0, so a
    mutation may leave the antibody unchanged (BGA's preference for small steps).

    Returns the mutated copy of ``genes``.
    """
    out = genes.copy()
    c = genes.shape[0]
    if c == 0:
        return out
    hi = region.hi.astype(np.float64)
    rows = np.arange(c)
    old = genes[rows, which].astype(np.float64)
    pending = np.ones(c, dtype=bool)
    for _ in range(tries):
        idx = np.nonzero(pending)[0]
        if idx.size == 0:
            break
        delta = bga_delta(rng, (idx.size, 2))
        sign = np.where(rng.random((idx.size, 2)) < 0.5, -1.0, 1.0)
        x = bga_fold(old[idx] + sign * 0.1 * delta * hi, hi)
        new = np.clip(np.rint(x), 0.0, hi).astype(np.int64)
        trial = out[idx].copy()
        trial[np.arange(idx.size), which[idx]] = new
        same = (trial[:, :, None, :] == trial[:, None, :, :]).all(axis=-1)
        dup = same.sum(axis=(1, 2)) > trial.shape[1]
        ok = ~dup
        out[idx[ok]] = trial[ok]
        pending[idx[ok]] = False
    return out


def _ais_params(
    population: Any,
    s_min: Any,
    s_max: Any,
    alpha: Any,
    beta: Any,
    deaths: Any,
    generations: Any,
    stagnation: Any,
) -> dict[str, Any]:
    """:func:`run_ais`'s parameters, validated (the record stored with the result)."""
    size = _int_param("population", population, 2, MAX_POPULATION)
    params: dict[str, Any] = {
        "population": size,
        "s_min": _float_param("s_min", s_min, 0.0, 1.0, lo_open=True, hi_open=True),
        "s_max": _float_param("s_max", s_max, 0.0, 1.0, lo_open=True, hi_open=True),
        "alpha": _float_param("alpha", alpha, 0.0, math.inf, lo_open=True, hi_open=True),
        "beta": _float_param("beta", beta, 0.0, math.inf, lo_open=True, hi_open=True),
        "deaths": size // 4 if deaths is None else _int_param("deaths", deaths, 0, size - 1),
        "generations": _int_param("generations", generations, 1, MAX_GENERATIONS),
        "stagnation": _int_param("stagnation", stagnation, 1),
    }
    if params["s_min"] > params["s_max"]:
        raise ParameterError(f"s_min = {params['s_min']}: must not exceed s_max = {params['s_max']}")
    return params


def _replace_by_best_clone(
    pop: np.ndarray, E: np.ndarray, cand: np.ndarray, cand_parent: np.ndarray, E_cand: np.ndarray
) -> None:
    """In place: each parent is replaced by its best mutated clone (first on ties) if that is strictly better."""
    o = np.lexsort((E_cand, cand_parent))  # sort by (parent, E)
    first = np.ones(o.size, dtype=bool)
    first[1:] = cand_parent[o][1:] != cand_parent[o][:-1]
    best = o[first]
    win = best[E_cand[best] < E[cand_parent[best]]]
    pop[cand_parent[win]] = cand[win]
    E[cand_parent[win]] = E_cand[win]


# Length: 106 lines, of which 34 are the docstring (003's seven steps); the body is one generation loop.
def run_ais(
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    population: int = 40,
    s_min: float = 0.2,
    s_max: float = 0.4,
    alpha: float = 0.4,
    beta: float = 4.0,
    deaths: int | None = None,
    generations: int = 50,
    stagnation: int = 6,
    progress: Progress | None = None,
) -> SelectionResult:
    """Artificial immune system with adaptive dynamic clonal selection (003 §4.2, Dong et al.), minimising E.

    1. **Initialisation**: ⌊N_p/2⌋ random antibodies, the others stratified (:func:`stratified_genes`). This is
       generation 1, evaluated in one call.
    2. **Evaluation**: affinity f = 1/E; the population is sorted from high affinity to low (stable).
    3. **Partition**: diversity h (:func:`population_diversity`); memory unit = the best
       N_m = ⌊N_p · min(s_min + h, s_max)⌋ antibodies, generic unit = the rest.
    4. **Mutation regulation**: :func:`mutation_probabilities`.
    5. **Clonal selection**: antibody i gets N_c^i clones (:func:`clone_counts`); each clone is mutated with
       probability p_i by :func:`bga_mutation` on one random gene; the best mutated clone replaces its parent
       if its affinity is strictly larger (E strictly smaller).
    6. **Regulation**: sorted again, the N_d worst antibodies are replaced by new random ones.
    7. **Termination**: after N_g generations or N_o consecutive generations without improvement of the best.

    One evaluation call per generation: it holds the mutated clones that differ from their parent (a clone
    identical to its parent cannot beat it) and the N_d newcomers of step 6, which are random and independent
    of the clones, so drawing them before the call changes nothing but the number of calls. The best antibody
    is never lost (a parent is only replaced by a better clone, and N_d < N_p removes only the worst), so the
    returned best ever is the population's best.

    Interpretation choices are documented on the operator functions: h (:func:`population_diversity`),
    p_mu (:func:`mutation_probabilities`), the clone counts (:func:`clone_counts`), the BGA step and the
    fold per coordinate with rounding and collision redraw (:func:`bga_mutation`), the n parts of the
    stratified half (:func:`stratified_genes`). Further: the upper limit of the δ sum is lost in the text; we use
    BGA's 16 terms (i = 0 .. 15), the only value consistent with γ_i = 1 with probability 1/16.

    Parameters
    ----------
    evaluate : ``genes[P, n, 2] -> (E[P], D[P, m])``, E >= 0.
    shape, n, tile_size, rng : as :func:`run_ga`.
    population, s_min, s_max, alpha, beta, deaths, generations, stagnation :
        N_p, s^M_min, s^M_max, α, β, N_d, N_g, N_o. ``deaths=None``: ⌊N_p / 4⌋ (the paper's 10 of 40).
    progress : ``progress("ais", generation, generations)`` once per generation.
    """
    t0 = time.perf_counter()
    shp, n, t, region = _region(shape, n, tile_size)
    params = _ais_params(population, s_min, s_max, alpha, beta, deaths, generations, stagnation)
    size = params["population"]
    g = as_generator(rng)
    ev = _Evaluator(evaluate, n)
    run = _Run("ais", params["generations"], params["stagnation"], progress)

    half = size // 2
    pop = np.concatenate(
        [
            _random_population(g, half, shp, n, t),
            np.stack([stratified_genes(g, region, n) for _ in range(size - half)]),
        ]
    )
    E, _ = ev(pop)
    if (E < 0).any():
        raise ParameterError(
            f"evaluate returned E = {float(E.min())!r} < 0: the AIS affinity 1/E needs E >= 0"
        )
    run.generation(E, ev.best_E)
    while (stop := run.stop_reason()) is None:
        order = np.argsort(E, kind="stable")
        pop, E = pop[order], E[order]
        rel = relative_affinity(E)
        h = population_diversity(pop, region)
        n_memory = int(math.floor(size * min(params["s_min"] + h, params["s_max"]) + 1e-9))
        p_mu = mutation_probabilities(rel, h, n_memory, n, params["s_min"])
        counts = clone_counts(rel, n_memory, params["alpha"], params["beta"])

        parent = np.repeat(np.arange(size), counts)
        clones = pop[parent]
        mutate = g.random(parent.size) < p_mu[parent]
        which = g.integers(0, n, size=parent.size)
        mutated = bga_mutation(g, clones[mutate], which[mutate], region)
        changed = (mutated != clones[mutate]).any(axis=(1, 2))
        cand, cand_parent = mutated[changed], parent[mutate][changed]
        newcomers = _random_population(g, params["deaths"], shp, n, t)

        E_batch, _ = ev(np.concatenate([cand, newcomers]))
        E_cand, E_new = E_batch[: cand.shape[0]], E_batch[cand.shape[0] :]
        if (E_batch < 0).any():
            raise ParameterError(
                f"evaluate returned E = {float(E_batch.min())!r} < 0: the AIS affinity 1/E needs E >= 0"
            )
        if cand.shape[0]:
            _replace_by_best_clone(pop, E, cand, cand_parent, E_cand)

        if params["deaths"]:
            order = np.argsort(E, kind="stable")
            pop, E = pop[order], E[order]
            pop[size - params["deaths"] :] = newcomers
            E[size - params["deaths"] :] = E_new
        run.generation(E, ev.best_E)
    return _result("ais", ev, params, run, t0, stop)
