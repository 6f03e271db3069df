"""Selection of the sample patches (the *genes*) of an ω-tile set.

A gene vector is an int64 ``(n, 2)`` array of distinct top-left (row, col) positions of N x N patches inside an
H x W exemplar (each in ``[0, H−N] x [0, W−N]``, see :func:`tilesynth.builder.genes.draws.random_genes`). Its quality is
E = λ·ΣD_j + (1−λ)·Var(D_j) (smaller is better), computed by an ``evaluate(genes[P, n, 2]) -> (E[P], D[P, m])``
callable, normally ``tilesynth.PopulationEvaluator(...).evaluate``. Every method here evaluates a whole
population per call (never one call per individual).

Methods (:func:`select_genes`):

``random``
    One random gene vector (the original ω-tile construction).
``best-of``
    The best of ``count`` (default 100) random gene vectors: the "semi-random" of 003 (§5, Table 2).
``ga``
    The genetic algorithm of 000 §4.2 (and 001 §4): :func:`run_ga`.
``ais``
    The artificial immune system (adaptive dynamic clonal selection) of 003 §4.2: :func:`run_ais`.

``polish=True`` follows any method with an exact coordinate descent (:func:`polish_genes`): one gene at a time
is moved to its best position over every valid position, until no single-gene move improves E.

All randomness comes from the given seed / :class:`numpy.random.Generator`: same seed, same evaluator → same
result. The returned genes are the best ever evaluated, and the returned E and D are the evaluator's values for
them. Gene vectors already evaluated during a run are not evaluated again (the evaluator is exact and
deterministic, so a cached value is the value); ``evaluations`` counts the individuals actually evaluated.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...base.chunks import ChunkSizer, call_in_chunks
from ...errors import ParameterError, ShapeError
from .draws import Region, _region, check_genes, random_genes
from .draws import int_param as _int_param

Evaluate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""``evaluate(genes[P, n, 2] int64) -> (E[P] float64, D[P, m] float64)``."""

Progress = Callable[[str, int, int], None]
"""Progress callback ``(stage, done, total)``, called once per generation."""

METHODS: tuple[str, ...] = ("random", "best-of", "ga", "ais")
"""Names accepted by :func:`select_genes`."""

GA_DEFAULTS: dict[str, Any] = {
    "population": 40,
    "alpha": 0.05,
    "p_crossover": 0.3,
    "p_mutation": 0.2,
    "generations": 50,
    "stagnation": 5,
    "elitism": False,
}
"""Defaults of :func:`run_ga`: 000 §5 {pop_size 40, α 0.05, P_c 0.3, P_m 0.2, N_g 50, N_o 5}."""

AIS_DEFAULTS: dict[str, Any] = {
    "population": 40,
    "s_min": 0.2,
    "s_max": 0.4,
    "alpha": 0.4,
    "beta": 4.0,
    "deaths": None,
    "generations": 50,
    "stagnation": 6,
}
"""Defaults of :func:`run_ais`: 003 §4.4 {N_p 40, s_min 0.2, s_max 0.4, α 0.4, β 4, N_d 10, N_g 50, N_o 6}.

``deaths=None`` means ⌊N_p / 4⌋: the paper's 10 for N_p = 40, kept in proportion for other population sizes.
"""

BEST_OF_DEFAULTS: dict[str, Any] = {"count": 100}
"""Default of :func:`run_best_of`: 003's semi-random takes the best of 100 random sets."""

POLISH_DEFAULTS: dict[str, Any] = {"polish_sweeps": None, "polish_batch": 256, "polish_min_distance": None}
"""Defaults of the polish step: sweep until converged; at most 256 individuals per evaluation call."""

BGA_TERMS = 16
"""Number of terms γ_i 2^−i (i = 0 .. 15) of the BGA mutation step δ (Mühlenbein's BGA, k = 16)."""


# --------------------------------------------------------------------------------------------------------------
# Result


@dataclass
class SelectionResult:
    """Outcome of a gene selection.

    Attributes
    ----------
    genes : int64 ``(n, 2)``, the best gene vector found (distinct, in range).
    E : its objective value (exactly the evaluator's value for ``genes``).
    D : float64 ``(m,)``, the evaluator's per-tile errors for ``genes``.
    method : "random", "best-of", "ga" or "ais".
    params : every parameter used (JSON-able), including ``polish`` and the polish parameters.
    history : ``{"best": [...], "mean": [...]}``, best and mean E of the population of every generation of the
        method (not of the polish), as Python floats.
    evaluations : number of individuals evaluated (method and polish).
    generations : generations of the method run (``len(history["best"])``).
    wall_time : seconds, method and polish.
    stop_reason : "generations" (N_g reached), "stagnation" (N_o generations without improvement) or "done"
        (random, best-of).
    polish : ``None`` without polish, otherwise ``{"E_before", "sweeps", "moves", "evaluations", "converged"}``.
    """

    genes: np.ndarray
    E: float
    D: np.ndarray
    method: str
    params: dict[str, Any]
    history: dict[str, list[float]]
    evaluations: int
    generations: int
    wall_time: float
    stop_reason: str = "done"
    polish: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (genes as nested lists, D as a list)."""
        return {
            "method": self.method,
            "genes": self.genes.tolist(),
            "E": float(self.E),
            "D": [float(v) for v in self.D],
            "params": dict(self.params),
            "history": {k: list(v) for k, v in self.history.items()},
            "evaluations": int(self.evaluations),
            "generations": int(self.generations),
            "wall_time": float(self.wall_time),
            "stop_reason": self.stop_reason,
            "polish": None if self.polish is None else dict(self.polish),
        }


# --------------------------------------------------------------------------------------------------------------
# Small helpers


MAX_POPULATION = 10_000
"""Largest population (GA, AIS) or count (best-of): every generation evaluates the whole population exactly
(four SSD maps per new patch position), so 10^4 individuals already take minutes a generation on a 512-pixel
exemplar; a larger value is a mistake that would exhaust memory (a population is P x n x 2 int64 genes plus
P x m float64 D values, and the evaluator's working set)."""

MAX_GENERATIONS = 100_000
"""Largest number of generations: far beyond the papers' 50 (and the stop after 5 without improvement);
bounds the run time and the stored convergence history."""


def _float_param(
    name: str, value: Any, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False
) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} = {value!r}: must be a number")
    v = float(value)
    ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise ParameterError(f"{name} = {value!r}: must be in {interval}")
    return v


def _bool_param(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} = {value!r}: must be True or False")
    return bool(value)


def as_generator(rng: Any) -> np.random.Generator:
    """A :class:`numpy.random.Generator` from a seed (int), a Generator (used as is) or None (fresh entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        return np.random.default_rng()
    if isinstance(rng, (bool, np.bool_)) or not isinstance(rng, (int, np.integer)) or int(rng) < 0:
        raise ParameterError(f"rng = {rng!r}: expected a non-negative integer seed or a numpy Generator")
    return np.random.default_rng(int(rng))


def _draw_excluding(rng: np.random.Generator, total: int, forbidden: set[int], k: int) -> list[int]:
    """``k`` distinct flat positions in ``[0, total)`` outside ``forbidden`` (uniformly, without replacement)."""
    free = total - len(forbidden)
    if free < k:
        raise ParameterError(f"only {free} free patch positions, {k} needed")
    if total <= 4 * (len(forbidden) + k) + 64:
        pool = np.setdiff1d(
            np.arange(total, dtype=np.int64), np.fromiter(forbidden, np.int64, len(forbidden))
        )
        return [int(v) for v in rng.choice(pool, size=k, replace=False)]
    out: list[int] = []
    taken = set(forbidden)
    while len(out) < k:
        v = int(rng.integers(total))
        if v not in taken:
            taken.add(v)
            out.append(v)
    return out


def _random_population(
    rng: np.random.Generator, size: int, shape: tuple[int, int], n: int, t: int
) -> np.ndarray:
    if size == 0:
        return np.empty((0, n, 2), dtype=np.int64)
    return np.stack([random_genes(shape, n, t, rng) for _ in range(size)]).astype(np.int64)


class _Evaluator:
    """Wraps the user's ``evaluate``: one call per batch (tilesynth's own evaluators: chunks of about 0.1 s,
    see :mod:`tilesynth.base.chunks`), validation, cache of known vectors, best-ever record."""

    def __init__(self, evaluate: Evaluate, n: int, cache: bool = True) -> None:
        if not callable(evaluate):
            raise ParameterError(
                f"evaluate = {evaluate!r}: must be callable genes[P, n, 2] -> (E[P], D[P, m])"
            )
        self.fn = evaluate
        self.n = n
        self.cache: dict[bytes, tuple[float, np.ndarray]] | None = {} if cache else None
        self.count = 0
        self.m: int | None = None
        self.best_genes: np.ndarray | None = None
        self.best_E = math.inf
        self.best_D: np.ndarray | None = None
        # tilesynth's own evaluators: batches in chunks of ~0.1 s, so Ctrl-C acts within ~1 s (issue 16)
        self.sizer = ChunkSizer() if getattr(evaluate, "_tilesynth_chunkable", False) else None

    def _call(self, genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = genes.shape[0]
        out = self.fn(np.ascontiguousarray(genes, dtype=np.int64))
        try:
            E_raw, D_raw = out
        except (TypeError, ValueError) as exc:
            raise ShapeError("evaluate must return a pair (E[P], D[P, m])") from exc
        E = np.array(E_raw, dtype=np.float64).reshape(-1)  # copies: the caller's arrays are never modified
        D = np.array(D_raw, dtype=np.float64)
        if E.shape != (p,) or D.ndim != 2 or D.shape[0] != p:
            raise ShapeError(f"evaluate returned E {E.shape} and D {D.shape} for {p} individuals")
        if self.m is None:
            self.m = D.shape[1]
        elif D.shape[1] != self.m:
            raise ShapeError(f"evaluate returned D with {D.shape[1]} columns, earlier {self.m}")
        if not np.isfinite(E).all():
            raise ParameterError("evaluate returned a non-finite E")
        self.count += p
        return E, D

    def __call__(self, genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """E and D of every row of ``genes`` (P, n, 2); updates the best-ever record."""
        genes = np.ascontiguousarray(genes, dtype=np.int64)
        p = genes.shape[0]
        if p == 0:
            return np.empty(0), np.empty((0, self.m or 0))
        if self.cache is None:
            E, D = call_in_chunks(self._call, genes, self.sizer)
        else:
            keys = [g.tobytes() for g in genes]
            todo: dict[bytes, int] = {}
            for i, k in enumerate(keys):
                if k not in self.cache and k not in todo:
                    todo[k] = i
            if todo:
                idx = np.fromiter(todo.values(), np.int64, len(todo))
                E_new, D_new = call_in_chunks(self._call, genes[idx], self.sizer)
                for j, k in enumerate(todo):
                    self.cache[k] = (float(E_new[j]), D_new[j].copy())
            E = np.array([self.cache[k][0] for k in keys], dtype=np.float64)
            D = np.stack([self.cache[k][1] for k in keys])
        i = int(np.argmin(E))
        if E[i] < self.best_E:
            self.best_E = float(E[i])
            self.best_genes = genes[i].copy()
            self.best_D = D[i].copy()
        return E, D


class _Run:
    """Per-generation bookkeeping: history, stagnation counter, progress."""

    def __init__(self, stage: str, total: int, stagnation: int | None, progress: Progress | None) -> None:
        self.stage = stage
        self.total = total
        self.stagnation = stagnation
        self.progress = progress
        self.best: list[float] = []
        self.mean: list[float] = []
        self.stall = 0
        self.record = math.inf

    def generation(self, E_population: np.ndarray, best_ever: float) -> None:
        self.best.append(float(np.min(E_population)))
        self.mean.append(float(np.mean(E_population)))
        if best_ever < self.record:
            self.record = best_ever
            self.stall = 0
        else:
            self.stall += 1
        if self.progress is not None:
            self.progress(self.stage, len(self.best), self.total)
            if self.stop_reason() == "stagnation" and self.generations < self.total:  # issue 16: say so
                note = f"converged at generation {self.generations} of {self.total} (stagnation rule)"
                finish = getattr(self.progress, "finish", None)  # a plain callable gets no extra call
                if finish is not None:
                    finish(self.stage, note)

    @property
    def generations(self) -> int:
        return len(self.best)

    def stop_reason(self) -> str | None:
        if self.stagnation is not None and self.stall >= self.stagnation:
            return "stagnation"
        if self.generations >= self.total:
            return "generations"
        return None


def _result(
    method: str, ev: _Evaluator, params: dict[str, Any], run: _Run, t0: float, stop: str
) -> SelectionResult:
    assert ev.best_genes is not None and ev.best_D is not None
    return SelectionResult(
        genes=ev.best_genes.copy(),
        E=float(ev.best_E),
        D=ev.best_D.copy(),
        method=method,
        params=params,
        history={"best": list(run.best), "mean": list(run.mean)},
        evaluations=ev.count,
        generations=run.generations,
        wall_time=time.perf_counter() - t0,
        stop_reason=stop,
    )


# --------------------------------------------------------------------------------------------------------------
# random, best-of


def run_random(
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    progress: Progress | None = None,
) -> SelectionResult:
    """One random gene vector (:func:`tilesynth.builder.omega.random_genes`), evaluated once."""
    t0 = time.perf_counter()
    shp, n, t, _ = _region(shape, n, tile_size)
    g = as_generator(rng)
    ev = _Evaluator(evaluate, n, cache=False)
    run = _Run("random", 1, None, progress)
    E, _ = ev(random_genes(shp, n, t, g)[None])
    run.generation(E, ev.best_E)
    return _result("random", ev, {}, run, t0, "done")


def run_best_of(
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    count: int = 100,
    progress: Progress | None = None,
) -> SelectionResult:
    """The best of ``count`` random gene vectors, evaluated in one call (003's "semi-random").

    Exactly ``count`` vectors are evaluated (no de-duplication), as one generation.
    """
    t0 = time.perf_counter()
    shp, n, t, _ = _region(shape, n, tile_size)
    count = _int_param("count", count, 1, MAX_POPULATION)
    g = as_generator(rng)
    ev = _Evaluator(evaluate, n, cache=False)
    run = _Run("best-of", 1, None, progress)
    E, _ = ev(_random_population(g, count, shp, n, t))
    run.generation(E, ev.best_E)
    return _result("best-of", ev, {"count": count}, run, t0, "done")


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


# --------------------------------------------------------------------------------------------------------------
# Polish


# Length: 103 lines, of which 32 are the docstring; the body is one coordinate-descent loop.
def polish_genes(
    evaluate: Evaluate,
    genes: np.ndarray,
    shape: tuple[int, ...],
    tile_size: int,
    *,
    E: float | None = None,
    D: np.ndarray | None = None,
    max_sweeps: int | None = None,
    batch_size: int = 256,
    min_distance: int | None = None,
    progress: Progress | None = None,
) -> tuple[np.ndarray, float, np.ndarray, dict[str, Any]]:
    """Exact coordinate descent: move one gene at a time to its best position.

    For gene k, every valid position at Chebyshev distance >= ``min_distance`` from every other gene is tried
    (the other genes fixed): the candidates
    are evaluated as populations of at most ``batch_size`` individuals, and the gene moves to the best one if
    that is strictly better than the current E (ties: the current position stays; among equal candidates the
    first in row-major order wins). A sweep visits k = 0 .. n−1; sweeps repeat until one makes no move (the
    genes are then a coordinate-wise local optimum: no single-gene move improves E) or ``max_sweeps`` sweeps
    were made. Genes stay distinct.

    Parameters
    ----------
    evaluate : ``genes[P, n, 2] -> (E[P], D[P, m])``.
    genes : int64 ``(n, 2)`` start.
    shape, tile_size : exemplar shape and N.
    E, D : the evaluator's E and D of ``genes`` if known (otherwise ``genes`` is evaluated first).
    max_sweeps : maximum number of sweeps, None for no limit (the descent always terminates: E strictly
        decreases over a finite set).
    batch_size : individuals per evaluation call.
    min_distance : smallest Chebyshev distance, in pixels, a moved gene keeps from every other gene; None means
        ``tile_size // 4``, 0 or 1 only keeps genes distinct. *Why:* E rewards patches that show the same content
        (their seams vanish), and an unconstrained descent on gravel (N2, 80x80 tiles, 128x128 exemplar) moved
        three of six patches to within one pixel of each other: a lower E, but a nearly periodic tile set, which
        defeats the purpose of having six patches. A patch shifted by less than N/4 shares over 56% of its pixels
        with the other (the same rule the 32-set uses for its second matching patch). The current position of a
        gene always stays allowed, so the polish never makes E worse.
    progress : ``progress("polish", gene steps done, n · max_sweeps or n · (sweep + 1))`` after each gene.

    Returns
    -------
    (genes, E, D, info) with info = {"sweeps", "moves", "evaluations", "converged", "E_before"}.
    """
    shp, n, t, region = _region(shape, np.asarray(genes).shape[0], tile_size)
    cur = check_genes(genes, n, shp, t).copy()
    batch_size = _int_param("polish_batch", batch_size, 1)
    if max_sweeps is not None:
        max_sweeps = _int_param("polish_sweeps", max_sweeps, 1)
    min_distance = t // 4 if min_distance is None else _int_param("polish_min_distance", min_distance, 0)
    ev = _Evaluator(evaluate, n, cache=False)
    if E is None or D is None:
        E0, D0 = ev(cur[None])
        cur_E, cur_D = float(E0[0]), D0[0].copy()
    else:
        cur_E, cur_D = float(E), np.asarray(D, dtype=np.float64).copy()
    E_before = cur_E
    flat_all = np.arange(region.size, dtype=np.int64)
    all_pos = region.unflat(flat_all)
    sweeps = moves = steps = 0
    converged = False
    while max_sweeps is None or sweeps < max_sweeps:
        sweeps += 1
        moved = False
        for k in range(n):
            held = region.flat(cur)
            ok = ~np.isin(flat_all, held)
            others = np.delete(cur, k, axis=0)
            if min_distance > 1 and others.size:
                cheb = np.abs(all_pos[:, None, :] - others[None, :, :]).max(axis=2).min(axis=1)
                ok &= cheb >= min_distance
            cand = flat_all[ok]
            best_E, best_pos, best_D = cur_E, -1, cur_D
            for s in range(0, cand.size, batch_size):
                chunk = cand[s : s + batch_size]
                pop = np.repeat(cur[None], chunk.size, axis=0)
                pop[:, k] = region.unflat(chunk)
                Eb, Db = ev(pop)
                j = int(np.argmin(Eb))
                if Eb[j] < best_E:
                    best_E, best_pos, best_D = float(Eb[j]), int(chunk[j]), Db[j].copy()
            if best_pos >= 0:
                cur[k] = region.unflat([best_pos])[0]
                cur_E, cur_D = best_E, best_D
                moves += 1
                moved = True
            steps += 1
            if progress is not None:
                total = n * (max_sweeps if max_sweeps is not None else sweeps + 1)
                progress("polish", steps, total)
        if not moved:
            converged = True
            break
    info = {
        "E_before": E_before,
        "min_distance": int(min_distance),
        "sweeps": sweeps,
        "moves": moves,
        "evaluations": ev.count,
        "converged": converged,
    }
    return cur, cur_E, cur_D, info


# --------------------------------------------------------------------------------------------------------------
# Entry point

_METHOD_PARAMS: dict[str, dict[str, Any]] = {
    "random": {},
    "best-of": BEST_OF_DEFAULTS,
    "ga": GA_DEFAULTS,
    "ais": AIS_DEFAULTS,
}


def _method_kwargs(
    name: str, params: dict[str, Any], generations: int | None, population: int | None
) -> dict[str, Any]:
    """The runner's keywords of method ``name``: its parameters checked against the method's known ones, with
    ``generations`` / ``population`` mapped onto it (``population`` is best-of's ``count``)."""
    allowed = _METHOD_PARAMS[name]
    for key in params:
        if key not in allowed or key in ("generations", "population"):
            known = sorted((set(allowed) - {"generations", "population"}) | set(POLISH_DEFAULTS))
            raise ParameterError(
                f"{key} = {params[key]!r}: not a parameter of method {name!r}"
                + (f" (known: {', '.join(known)})" if known else "")
            )
    kwargs = dict(params)
    if generations is not None:
        if "generations" not in allowed:
            raise ParameterError(f"generations = {generations!r}: method {name!r} has no generations")
        kwargs["generations"] = generations
    if population is not None:
        if name == "best-of":
            if "count" in kwargs:
                raise ParameterError("population and count: give one (both set the best-of count)")
            kwargs["count"] = population
        elif "population" in allowed:
            kwargs["population"] = population
        else:
            raise ParameterError(f"population = {population!r}: method {name!r} has no population")

    return kwargs


def _polish_settings(polish_opts: dict[str, Any]) -> tuple[int | None, int, int | None]:
    """``(polish_sweeps, polish_batch, polish_min_distance)`` from the given polish options and the defaults."""
    p_sweeps = polish_opts.get("polish_sweeps", POLISH_DEFAULTS["polish_sweeps"])
    p_batch = _int_param("polish_batch", polish_opts.get("polish_batch", POLISH_DEFAULTS["polish_batch"]), 1)
    if p_sweeps is not None:
        p_sweeps = _int_param("polish_sweeps", p_sweeps, 1)
    p_min = polish_opts.get("polish_min_distance", POLISH_DEFAULTS["polish_min_distance"])
    if p_min is not None:
        p_min = _int_param("polish_min_distance", p_min, 0)
    return p_sweeps, p_batch, p_min


# Length: 84 lines, of which 28 are the docstring; the body (56) dispatches to the methods.
def select_genes(
    method: str,
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    progress: Progress | None = None,
    **params: Any,
) -> SelectionResult:
    """Select n sample patches with ``method``, optionally followed by the exact polish.

    Parameters
    ----------
    method : "random", "best-of", "ga" or "ais" ("best_of" is accepted for "best-of").
    evaluate : ``genes[P, n, 2] int64 -> (E[P], D[P, m])``, called once per generation with the population.
    shape : exemplar shape (H, W[, C]).
    n : number of genes (colours of the tile set).
    tile_size : N.
    rng : seed (int) or :class:`numpy.random.Generator`; None draws fresh entropy.
    polish : follow the method with :func:`polish_genes`.
    generations : N_g of "ga" / "ais" (None: the paper's 50). Not accepted by "random" / "best-of".
    population : pop_size / N_p of "ga" / "ais", the count of "best-of" (None: 40, 40, 100). Not accepted by
        "random".
    progress : ``(stage, done, total)`` callback, once per generation (stage = method name, then "polish").
    **params : method parameters: "ga": alpha, p_crossover, p_mutation, stagnation, elitism (see
        :func:`run_ga`); "ais": s_min, s_max, alpha, beta, deaths, stagnation (:func:`run_ais`); "best-of":
        count. With ``polish``: polish_sweeps (None: until converged), polish_batch (256).

    Returns
    -------
    SelectionResult; with polish, genes / E / D are the polished ones, ``evaluations`` and ``wall_time``
    include the polish, ``history`` and ``generations`` are the method's, ``polish`` holds the polish facts.

    Raises
    ------
    ParameterError (a ValueError) naming the unknown method or the bad parameter.
    """
    t0 = time.perf_counter()
    if not isinstance(method, str):
        raise ParameterError(f"method = {method!r}: must be one of {', '.join(METHODS)}")
    name = method.strip().lower().replace("_", "-")
    if name not in _METHOD_PARAMS:
        raise ParameterError(f"method = {method!r}: unknown, expected one of {', '.join(METHODS)}")
    polish = _bool_param("polish", polish)
    polish_opts = {k: params.pop(k) for k in list(params) if k in POLISH_DEFAULTS}
    if polish_opts and not polish:
        raise ParameterError(f"{next(iter(polish_opts))}: only used with polish=True")
    kwargs = _method_kwargs(name, params, generations, population)
    runner: Callable[..., SelectionResult] = {
        "random": run_random,
        "best-of": run_best_of,
        "ga": run_ga,
        "ais": run_ais,
    }[name]
    # validate polish options before the (possibly long) run
    p_sweeps, p_batch, p_min = _polish_settings(polish_opts) if polish else (None, 0, None)
    res = runner(evaluate, shape, n, tile_size, rng, progress=progress, **kwargs)
    res.params = {**res.params, "polish": polish}
    if polish:
        genes, E, D, info = polish_genes(
            evaluate,
            res.genes,
            shape,
            tile_size,
            E=res.E,
            D=res.D,
            max_sweeps=p_sweeps,
            batch_size=p_batch,
            min_distance=p_min,
            progress=progress,
        )
        res.genes, res.E, res.D = genes, E, D
        res.evaluations += info["evaluations"]
        res.polish = info
        res.params.update(
            {"polish_sweeps": p_sweeps, "polish_batch": p_batch, "polish_min_distance": info["min_distance"]}
        )
    res.wall_time = time.perf_counter() - t0
    return res


# --------------------------------------------------------------------------------------------------------------
# The builders' one path to a gene vector


def wants_selection(select: Any, polish: bool, select_params: Any, *, extra: bool = False) -> bool:
    """Whether the options ask for an optimised gene vector (anything but one random draw)."""
    return (select is not None and select != "random") or bool(polish) or bool(extra) or bool(select_params)


def check_select(select: Any) -> None:
    """Refuse a ``select`` that is neither None nor a method name (a string)."""
    if select is not None and not isinstance(select, str):
        raise ParameterError(f"select = {select!r}: must be one of {', '.join(METHODS)} or None")


def choose_genes(
    genes: Any,
    *,
    n: int,
    size: int,
    shape: tuple[int, ...],
    rng: np.random.Generator,
    evaluator: Callable[[], Evaluate] | None,
    select: str | None = None,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    select_params: dict[str, Any] | None = None,
    selection: dict[str, Any] | None = None,
    ga_defaults: dict[str, Any] | None = None,
    optimise: bool = False,
    record: dict[str, Any] | None = None,
    progress: Progress | None = None,
    mask: Any = None,
    tile_size: int | None = None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Given, random or selected genes (``n`` top-left corners of ``size`` squares) and how they were chosen.

    * ``genes`` given: checked (:func:`check_genes`), recorded as ``selection`` (default ``{"method": "given"}``);
      giving ``select`` too is an error.
    * no selection asked for (``select`` None or "random", no ``polish``, no ``select_params``, ``optimise``
      false): one :func:`random_genes` draw from ``rng``, recorded as ``{"method": "random"}``.
    * otherwise :func:`select_genes` on ``evaluator()`` (called only then, so its cost is only
      paid when selecting). ``ga_defaults`` (a scheme's GA settings, e.g. 001's) fill the GA parameters the
      caller did not give. The record is the selection result without its genes and wall time, ``E`` / ``D``
      renamed ``objective_E`` / ``objective_D``, plus ``record``.

    ``optimise`` lets a scheme count one of its own options as a selection request (ω's ``normalise``).

    ``mask`` (a :class:`tilesynth.builder.masking.ExemplarMask`, issue 14): only windows clear of the mask are used
    (random genes drawn over them, given genes checked, a selection run on the projection onto them; see
    :mod:`tilesynth.builder.masking`); ``tile_size`` (default ``size``) names the build's tile size in its errors.
    """
    from ..masking import active

    m = active(mask)
    if m is not None:
        return _masked_genes(
            m, genes, n=n, size=size, shape=shape, rng=rng, evaluator=evaluator, select=select, polish=polish,
            generations=generations, population=population, select_params=select_params, selection=selection,
            ga_defaults=ga_defaults, optimise=optimise, record=record, progress=progress,
            tile_size=size if tile_size is None else tile_size,
        )  # fmt: skip
    check_select(select)
    optimise = wants_selection(select, polish, select_params, extra=optimise)
    if genes is not None and (select is not None or optimise):
        raise ParameterError("genes and select: give one (select chooses the genes)")
    if genes is not None:
        return check_genes(genes, n, shape, size), (
            {"method": "given"} if selection is None else dict(selection)
        )
    if not optimise:
        return random_genes(shape, n, size, rng), (
            {"method": "random"} if selection is None else dict(selection)
        )
    method = (select or "random").strip().lower().replace("_", "-")
    params = dict(select_params or {})
    if method == "ga" and ga_defaults:
        for key, value in ga_defaults.items():
            if key == "generations" and generations is None:
                generations = value
            elif key == "population" and population is None:
                population = value
            elif key not in ("generations", "population"):
                params.setdefault(key, value)
    if evaluator is None:
        raise ParameterError(f"select = {select!r}: this scheme has no objective to select genes by")
    from ...base.chunks import (
        chunkable,  # the scheme's own evaluator: safe to evaluate in chunks (Ctrl-C, issue 16)
    )

    res = select_genes(
        method, chunkable(evaluator()), shape, n, size, rng, polish=polish, generations=generations,
        population=population, progress=progress, **params,
    )  # fmt: skip
    info = res.to_dict()
    info.pop("genes")
    info.update(record or {})
    info["objective_E"] = info.pop("E")
    info["objective_D"] = info.pop("D")
    info.pop("wall_time")  # wall time goes in the tile set's timing (selection_s), not in its content
    return res.genes, info


def _masked_genes(m: Any, genes: Any, *, tile_size: int, **kw: Any) -> tuple[np.ndarray, dict[str, Any]]:
    """:func:`choose_genes` with a mask: the same three paths, on the windows clear of the mask."""
    size, n, rng = kw["size"], kw["n"], kw["rng"]
    m.require(size, n, "sample patches", tile_size)
    if genes is not None:
        g, sel = choose_genes(genes, **kw)
        m.check_genes(g, size)
        return g, sel
    evaluator = kw.pop("evaluator")
    if not wants_selection(kw["select"], kw["polish"], kw["select_params"], extra=kw["optimise"]):
        check_select(kw["select"])
        sel = {"method": "random"} if kw["selection"] is None else dict(kw["selection"])
        return m.random_genes(n, size, rng, tile_size), sel
    ev = None if evaluator is None else (lambda: m.penalised(evaluator(), size))
    g, sel = choose_genes(None, evaluator=ev, **kw)
    return m.final_genes(g, size, rng), sel


__all__ = [
    "AIS_DEFAULTS",
    "BEST_OF_DEFAULTS",
    "GA_DEFAULTS",
    "METHODS",
    "POLISH_DEFAULTS",
    "Region",
    "SelectionResult",
    "as_generator",
    "choose_genes",
    "bga_delta",
    "bga_fold",
    "bga_mutation",
    "clone_counts",
    "crossover_repair",
    "ga_crossover",
    "mutation_probabilities",
    "polish_genes",
    "population_diversity",
    "rank_probabilities",
    "relative_affinity",
    "roulette_select",
    "run_ais",
    "run_best_of",
    "run_ga",
    "run_random",
    "segment_mutation",
    "select_genes",
]
