"""Sample-patch selection (tilesynth.builder.genes.select): random, best-of, GA (000), AIS (003), polish.

The objectives here are cheap synthetic, exact and vectorised (a fixed landscape over patch positions), so the
tests do not depend on the Rust evaluator; one integration test uses ``tilesynth.PopulationEvaluator`` when the
installed package has it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tilesynth
from tilesynth.builder.genes.select import (
    AIS_DEFAULTS,
    GA_DEFAULTS,
    METHODS,
    Region,
    SelectionResult,
    bga_delta,
    bga_fold,
    bga_mutation,
    clone_counts,
    crossover_repair,
    ga_crossover,
    mutation_probabilities,
    polish_genes,
    population_diversity,
    rank_probabilities,
    relative_affinity,
    roulette_select,
    run_ais,
    run_ga,
    segment_mutation,
    select_genes,
    stratified_genes,
)
from tilesynth.builder.omega import check_genes, random_genes
from tilesynth.errors import ParameterError, ShapeError

LAM = 0.8


def energy_rows(D: np.ndarray) -> np.ndarray:
    return LAM * D.sum(axis=1) + (1.0 - LAM) * D.var(axis=1)


class Landscape:
    """Exact synthetic objective: D_j = weight_j · L[g_j] (+ optional coupling between neighbouring genes).

    Counts calls and individuals, and remembers the first population (to compare with the initial best).
    """

    def __init__(self, L: np.ndarray, n: int, coupling: float = 0.0) -> None:
        self.L = L
        self.n = n
        self.coupling = coupling
        self.w = 1.0 + 0.1 * np.arange(n)
        self.calls: list[int] = []
        self.first_E: np.ndarray | None = None

    def __call__(self, genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        assert genes.dtype == np.int64 and genes.ndim == 3 and genes.shape[1:] == (self.n, 2)
        v = self.L[genes[..., 0], genes[..., 1]]
        D = self.w * v
        if self.coupling:
            d = np.abs(genes - np.roll(genes, 1, axis=1)).sum(-1) / self.L.shape[0]
            D = D + self.coupling * np.abs(v - np.roll(v, 1, axis=1)) + 0.01 * d
        E = energy_rows(D)
        self.calls.append(genes.shape[0])
        if self.first_E is None:
            self.first_E = E.copy()
        return E, D


def smooth_landscape(rows: int, cols: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:rows, 0:cols]
    return 2.0 + np.sin(yy / 5.0) * np.cos(xx / 7.0) + 0.3 * rng.random((rows, cols))


def wells_landscape(rows: int, cols: int, n: int) -> tuple[np.ndarray, float]:
    """Distance to the nearest of n wells (value 0 at the wells): the optimum E = 0 puts one gene per well."""
    yy, xx = np.mgrid[0:rows, 0:cols]
    centres = [(rows * (i + 1) // (n + 1), cols * ((i * 3) % n + 1) // (n + 1)) for i in range(n)]
    d = np.min([np.hypot(yy - r, xx - c) for r, c in centres], axis=0)
    return d / d.max(), 0.0


SHAPE = (60, 70)
TILE = 20
N_GENES = 6
REGION = Region.of(SHAPE, TILE)


def make_objective(coupling: float = 0.0) -> Landscape:
    return Landscape(smooth_landscape(REGION.rows, REGION.cols), N_GENES, coupling)


def assert_valid(genes: np.ndarray, n: int, shape: tuple[int, int], tile: int) -> None:
    g = check_genes(genes, n, shape, tile)
    assert g.dtype == np.int64


# ---------------------------------------------------------------------------------------------------------------
# All methods: result contract


@pytest.mark.parametrize("method", METHODS)
def test_result_contract(method: str) -> None:
    obj = make_objective(coupling=0.5)
    stages: list[tuple[str, int, int]] = []
    res = select_genes(
        method, obj, SHAPE, N_GENES, TILE, 7, progress=lambda s, d, t: stages.append((s, d, t))
    )
    assert isinstance(res, SelectionResult)
    assert res.method == method
    assert_valid(res.genes, N_GENES, SHAPE, TILE)
    E, D = obj(res.genes[None])
    assert res.E == E[0]
    np.testing.assert_array_equal(res.D, D[0])
    assert len(res.history["best"]) == len(res.history["mean"]) == res.generations >= 1
    assert res.evaluations == sum(obj.calls[:-1])  # the last call is ours
    assert len(obj.calls) - 1 <= res.generations  # at most one evaluation call per generation
    assert obj.calls[0] == {"random": 1, "best-of": 100, "ga": 40, "ais": 40}[method]
    assert min(res.history["best"]) >= res.E
    assert [s for s, _, _ in stages] == [method] * res.generations
    assert [d for _, d, _ in stages] == list(range(1, res.generations + 1))
    assert res.wall_time >= 0.0
    json.dumps(res.to_dict())
    json.dumps(res.params)
    assert res.params["polish"] is False


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("polish", [False, True])
def test_reproducible_by_seed(method: str, polish: bool) -> None:
    region_shape, tile, n = (24, 26), 10, 4
    region = Region.of(region_shape, tile)
    L = smooth_landscape(region.rows, region.cols)

    def run(seed: int | np.random.Generator) -> SelectionResult:
        return select_genes(method, Landscape(L, n, 0.3), region_shape, n, tile, seed, polish=polish)

    a, b = run(3), run(np.random.default_rng(3))
    np.testing.assert_array_equal(a.genes, b.genes)
    assert a.E == b.E and a.history == b.history and a.evaluations == b.evaluations
    assert a.generations == b.generations and a.polish == b.polish
    if method != "random":
        others = [run(s) for s in (4, 5, 6)]
        assert any(o.history != a.history for o in others)


# ---------------------------------------------------------------------------------------------------------------
# Operators: genes always distinct and in range

shapes = st.tuples(st.integers(1, 8), st.integers(0, 10), st.integers(0, 10)).map(
    lambda t: ((t[0] + t[1], t[0] + t[2]), t[0])
)


@st.composite
def problems(draw: st.DrawFn, min_n: int = 1) -> tuple[tuple[int, int], int, int, np.random.Generator]:
    shape, tile = draw(shapes)
    region = Region.of(shape, tile)
    n = draw(st.integers(min_n, max(min_n, min(7, region.size))))
    if n > region.size:
        n = region.size
    seed = draw(st.integers(0, 2**32 - 1))
    return shape, tile, n, np.random.default_rng(seed)


@given(problems(min_n=2), st.data())
def test_crossover_repair_keeps_genes_distinct(problem, data) -> None:
    shape, tile, n, rng = problem
    if n < 2:
        return
    region = Region.of(shape, tile)
    p1, p2 = random_genes(shape, n, tile, rng), random_genes(shape, n, tile, rng)
    c = data.draw(st.integers(2, n))
    x, y = crossover_repair(rng, p1, p2, c, region)
    for child, head, tail in ((x, p1, p2), (y, p2, p1)):
        assert_valid(child, n, shape, tile)
        np.testing.assert_array_equal(child[: c - 1], head[: c - 1])  # repair only touches the tail
        heads = {tuple(g) for g in head[: c - 1].tolist()}
        for j in range(c - 1, n):
            if tuple(tail[j]) not in heads:
                # the other parent's gene is kept unless it collided with an earlier (repaired) gene
                assert tuple(child[j]) == tuple(tail[j]) or tuple(tail[j]) in {
                    tuple(g) for g in child[:j].tolist()
                }
            else:
                assert tuple(child[j]) != tuple(tail[j])


def test_crossover_without_conflict_is_plain_one_point() -> None:
    region = Region(10, 10)
    p1 = np.array([[0, 0], [0, 1], [0, 2], [0, 3]])
    p2 = np.array([[5, 0], [5, 1], [5, 2], [5, 3]])
    x, y = crossover_repair(np.random.default_rng(0), p1, p2, 3, region)
    np.testing.assert_array_equal(x, [[0, 0], [0, 1], [5, 2], [5, 3]])
    np.testing.assert_array_equal(y, [[5, 0], [5, 1], [0, 2], [0, 3]])
    # conflict: p2's tail holds p1's first gene; the displaced gene of p1 (position 3) is put back
    p2c = np.array([[5, 0], [5, 1], [0, 0], [5, 3]])
    x, _ = crossover_repair(np.random.default_rng(0), p1, p2c, 3, region)
    np.testing.assert_array_equal(x, [[0, 0], [0, 1], [0, 2], [5, 3]])
    with pytest.raises(ParameterError, match="c = 1"):
        crossover_repair(np.random.default_rng(0), p1, p2, 1, region)


@given(problems(), st.floats(0.0, 1.0))
def test_ga_crossover_population(problem, pc: float) -> None:
    shape, tile, n, rng = problem
    region = Region.of(shape, tile)
    mothers = np.stack([random_genes(shape, n, tile, rng) for _ in range(9)])
    out, pairs = ga_crossover(rng, mothers, pc, region)
    assert out.shape == mothers.shape
    for g in out:
        assert_valid(g, n, shape, tile)
    changed = int((out != mothers).any(axis=(1, 2)).sum())
    assert changed <= 2 * pairs <= 8  # an odd parent is moved to the non-parents
    if pc == 0.0 or n == 1:
        np.testing.assert_array_equal(out, mothers)


@given(problems())
def test_segment_mutation(problem) -> None:
    shape, tile, n, rng = problem
    region = Region.of(shape, tile)
    g = random_genes(shape, n, tile, rng)
    m = segment_mutation(rng, g, region)
    assert_valid(m, n, shape, tile)
    changed = np.nonzero((m != g).any(axis=1))[0]
    if region.size - n >= n:  # room for genes distinct from all old ones: the whole segment changes
        assert changed.size >= min(2, n)  # n1 < n2: at least two genes (the single one when n = 1)
        assert changed.size == changed[-1] - changed[0] + 1  # contiguous
        old = {tuple(v) for v in g.tolist()}
        assert not any(tuple(v) in old for v in m[changed].tolist())


@given(problems(), st.data())
def test_bga_mutation(problem, data) -> None:
    shape, tile, n, rng = problem
    region = Region.of(shape, tile)
    genes = np.stack([random_genes(shape, n, tile, rng) for _ in range(12)])
    which = rng.integers(0, n, size=12)
    out = bga_mutation(rng, genes, which, region)
    hi = region.hi
    for i in range(12):
        assert_valid(out[i], n, shape, tile)
        other = np.arange(n) != which[i]
        np.testing.assert_array_equal(out[i, other], genes[i, other])  # one gene only
        step = np.abs(out[i, which[i]] - genes[i, which[i]])
        assert (step <= np.ceil(0.2 * hi) + 1).all()  # |0.1·δ·(u − l)| < 0.2 (u − l), fold stays near


def test_bga_fold_and_step_distribution() -> None:
    region = Region(101, 201)  # u − l = (100, 200)
    rng = np.random.default_rng(1)
    c = 4000
    # genes at the upper corner: half the steps go outside and must be folded to (x + 0.2 (u − l)) / 1.4
    genes = np.zeros((c, 2, 2), np.int64)
    genes[:, 0] = region.hi
    genes[:, 1] = (0, 0)
    out = bga_mutation(rng, genes, np.zeros(c, np.int64), region)
    new = out[:, 0]
    assert (new >= 0).all() and (new <= region.hi).all()
    assert (new >= region.hi - np.ceil(0.2 * region.hi)).all()
    moved = new != region.hi
    assert 0.3 < moved.mean() < 0.9
    # the fold itself: (x + 0.2 (u − l)) / 1.4 outside [0, u], identity inside
    hi = np.array([100.0, 200.0])
    np.testing.assert_allclose(bga_fold(np.array([115.0, -30.0]), hi), [(115 + 20) / 1.4, (-30 + 40) / 1.4])
    np.testing.assert_allclose(bga_fold(np.array([100.0, 0.0]), hi), [100.0, 0.0])
    x = np.concatenate([np.linspace(-19.99, -0.01, 50), np.linspace(100.01, 119.99, 50)])
    folded = bga_fold(x, np.array(100.0))
    assert ((folded >= 0) & (folded <= 100)).all()
    assert (folded[50:] > 100 * 1.2 / 1.4).all() and (folded[:50] < 100 * 0.2 / 1.4).all()
    # δ = Σ_{i=0}^{15} γ_i 2^−i, P(γ_i = 1) = 1/16
    delta = bga_delta(np.random.default_rng(2), (200_000,))
    assert ((delta >= 0) & (delta < 2)).all()
    assert abs((delta == 0).mean() - (15 / 16) ** 16) < 0.005
    assert abs(delta.mean() - sum(2.0**-i for i in range(16)) / 16) < 0.002
    # steps are at most 0.1·δ·(u − l) < 0.2 (u − l) away, in both directions
    genes = np.tile(np.array([[50, 100], [0, 0]], np.int64), (c, 1, 1))
    out = bga_mutation(rng, genes, np.zeros(c, np.int64), region)
    step = out[:, 0] - genes[:, 0]
    assert (np.abs(step) <= 0.2 * region.hi).all()
    assert (step > 0).any() and (step < 0).any()
    assert abs((step[:, 0] > 0).mean() - (step[:, 0] < 0).mean()) < 0.05


@given(problems())
def test_stratified_genes(problem) -> None:
    shape, tile, n, rng = problem
    region = Region.of(shape, tile)
    g = stratified_genes(rng, region, n)
    assert_valid(g, n, shape, tile)


def test_stratified_genes_one_per_part() -> None:
    region = Region(40, 40)
    for seed in range(20):
        g = stratified_genes(np.random.default_rng(seed), region, 4)
        quads = sorted((int(r) // 20, int(c) // 20) for r, c in g)
        assert quads == [(0, 0), (0, 1), (1, 0), (1, 1)]
    g = stratified_genes(np.random.default_rng(0), Region(3, 3), 5)  # no 5-part grid fits: row-major runs
    assert len({tuple(v) for v in g.tolist()}) == 5


# ---------------------------------------------------------------------------------------------------------------
# Selection and AIS formulas


def test_rank_roulette_probabilities() -> None:
    alpha, size = 0.05, 40
    p = rank_probabilities(size, alpha)
    ev = alpha * (1 - alpha) ** np.arange(size)
    np.testing.assert_allclose(p, ev / ev.sum())
    assert (np.diff(p) < 0).all()
    draws = 400_000
    idx = roulette_select(np.random.default_rng(0), size, alpha, draws)
    assert idx.min() >= 0 and idx.max() < size
    freq = np.bincount(idx, minlength=size) / draws
    assert (np.abs(freq - p) <= 4.5 * np.sqrt(p * (1 - p) / draws) + 1e-4).all()
    with pytest.raises(ParameterError, match="alpha"):
        rank_probabilities(10, 1.0)


def test_relative_affinity_and_probabilities() -> None:
    E = np.array([1.0, 2.0, 4.0, 8.0])
    rel = relative_affinity(E)
    np.testing.assert_allclose(rel, (1 / E) / (1 / E).sum())
    np.testing.assert_allclose(relative_affinity(np.array([0.0, 0.0, 3.0])), [0.5, 0.5, 0.0])
    with pytest.raises(ParameterError, match="E >= 0"):
        relative_affinity(np.array([1.0, -1.0]))

    size, n, s_min = 40, 6, 0.2
    rel = relative_affinity(np.linspace(1.0, 5.0, size))
    for h in (0.0, 0.2, 0.41):
        nm = int(size * min(s_min + h, 0.4))
        p = mutation_probabilities(rel, h, nm, n, s_min)
        p_c = (s_min + h) / 2
        assert (p[:nm] <= min(1.4 * p_c, 0.3) + 1e-12).all()
        assert (p[nm:] >= min(3.0 * p_c, 0.8) - 1e-12).all()
        assert (p >= 0).all() and (p <= 1).all()
        counts = clone_counts(rel, nm, 0.4, 4.0)
        assert (counts >= 1).all()
        assert (counts[:nm] <= 16).all() and (counts[nm:] <= 13).all()
        assert (np.diff(counts[:nm]) <= 0).all()  # the better the affinity, the more clones
    # unbounded μ: β N_p f_i / Σf rounded
    rel = np.full(size, 1.0 / size)
    np.testing.assert_array_equal(clone_counts(rel, 10, 0.4, 4.0), np.full(size, 4))


def test_population_diversity() -> None:
    region = Region(51, 81)
    rng = np.random.default_rng(0)
    same = np.repeat(random_genes((100, 100), 6, 50, rng)[None], 10, axis=0)
    assert population_diversity(same, region) == 0.0
    pop = np.stack([random_genes((100, 130), 6, 50, rng) for _ in range(400)])
    h = population_diversity(pop, region)
    assert 0.0 < h < 1.0
    assert abs(h - 1 / math.sqrt(6)) < 0.03  # RMS distance of two uniform points / diagonal
    # brute force definition
    small = pop[:7].astype(float)
    tot = sum(((small[i] - small[j]) ** 2).sum() for i in range(7) for j in range(7) if i != j)
    np.testing.assert_allclose(
        population_diversity(pop[:7], region), math.sqrt(tot / (7 * 6 * 6)) / math.hypot(50, 80)
    )


# ---------------------------------------------------------------------------------------------------------------
# GA and AIS behaviour


@pytest.mark.parametrize("runner", [run_ga, run_ais])
def test_never_worse_than_initial_best(runner) -> None:
    for seed in range(5):
        obj = make_objective(coupling=0.5)
        res = runner(obj, SHAPE, N_GENES, TILE, seed, generations=15)
        assert obj.first_E is not None
        assert res.E <= obj.first_E.min()
        assert res.history["best"][0] == obj.first_E.min()
        assert res.generations <= 15


def test_ais_population_best_is_monotone() -> None:
    res = run_ais(make_objective(0.5), SHAPE, N_GENES, TILE, 2, generations=20, stagnation=20)
    assert (np.diff(res.history["best"]) <= 0).all()
    assert res.history["best"][-1] == res.E


def test_ga_elitism_keeps_best_in_population() -> None:
    res = run_ga(make_objective(0.5), SHAPE, N_GENES, TILE, 2, generations=20, stagnation=20, elitism=True)
    assert (np.diff(res.history["best"]) <= 0).all()
    assert res.history["best"][-1] == res.E
    assert res.params["elitism"] is True


@pytest.mark.parametrize("method", ["ga", "ais"])
def test_improves_on_random_with_known_optimum(method: str) -> None:
    L, optimum = wells_landscape(REGION.rows, REGION.cols, N_GENES)
    rand = [select_genes("random", Landscape(L, N_GENES), SHAPE, N_GENES, TILE, s).E for s in range(40)]
    opt = [select_genes(method, Landscape(L, N_GENES), SHAPE, N_GENES, TILE, s).E for s in range(6)]
    assert min(opt) >= optimum
    assert np.mean(opt) < 0.6 * np.mean(rand)


@pytest.mark.parametrize("method", ["ga", "ais"])
def test_stagnation_stop_on_constant_objective(method: str) -> None:
    def const(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.full(genes.shape[0], 3.0), np.ones((genes.shape[0], 5))

    res = select_genes(method, const, SHAPE, N_GENES, TILE, 0)
    n_o = {"ga": GA_DEFAULTS, "ais": AIS_DEFAULTS}[method]["stagnation"]
    assert res.generations == n_o + 1
    assert res.stop_reason == "stagnation"
    assert len(res.history["best"]) == n_o + 1
    res = select_genes(method, const, SHAPE, N_GENES, TILE, 0, stagnation=2)
    assert res.generations == 3


@pytest.mark.parametrize("method", ["ga", "ais"])
def test_generation_limit(method: str) -> None:
    res = select_genes(method, make_objective(0.5), SHAPE, N_GENES, TILE, 0, generations=4, stagnation=50)
    assert res.generations == 4 and res.stop_reason == "generations"
    assert res.params["generations"] == 4


def test_population_parameter() -> None:
    obj = make_objective()
    res = select_genes("ga", obj, SHAPE, N_GENES, TILE, 0, population=12, generations=2)
    assert obj.calls[0] == 12 and res.params["population"] == 12
    obj = make_objective()
    res = select_genes("ais", obj, SHAPE, N_GENES, TILE, 0, population=12, deaths=3, generations=2)
    assert obj.calls[0] == 12 and res.params["deaths"] == 3
    res = select_genes("ais", make_objective(), SHAPE, N_GENES, TILE, 0, population=8, generations=2)
    assert res.params["deaths"] == 2  # N_p / 4, the paper's 10 of 40
    assert (
        select_genes("ais", make_objective(), SHAPE, N_GENES, TILE, 0, generations=2).params["deaths"] == 10
    )


def test_best_of_evaluates_exactly_n() -> None:
    obj = make_objective()
    res = select_genes("best-of", obj, SHAPE, N_GENES, TILE, 0)
    assert obj.calls == [100] and res.evaluations == 100 and res.params == {"count": 100, "polish": False}
    assert obj.first_E is not None and res.E == obj.first_E.min()
    obj = make_objective()
    res = select_genes("best_of", obj, SHAPE, N_GENES, TILE, 0, population=17)
    assert obj.calls == [17] and res.evaluations == 17
    obj = make_objective()
    select_genes("best-of", obj, SHAPE, N_GENES, TILE, 0, count=5)
    assert obj.calls == [5]


def test_small_gene_counts() -> None:
    for n in (1, 2):
        for method in METHODS:
            extra: dict[str, Any] = {"generations": 5} if method in ("ga", "ais") else {}
            res = select_genes(method, Landscape(smooth_landscape(5, 6), n), (9, 10), n, 5, 1, **extra)
            assert_valid(res.genes, n, (9, 10), 5)


# ---------------------------------------------------------------------------------------------------------------
# Polish


def test_polish_reaches_coordinatewise_optimum() -> None:
    shape, tile, n = (16, 18), 8, 4
    region = Region.of(shape, tile)
    obj = Landscape(smooth_landscape(region.rows, region.cols, 3), n, coupling=1.0)
    res = select_genes("random", obj, shape, n, tile, 5, polish=True, polish_batch=7, polish_min_distance=0)
    assert_valid(res.genes, n, shape, tile)
    assert res.polish is not None and res.polish["converged"]
    assert res.E <= res.polish["E_before"]
    assert res.E == obj(res.genes[None])[0][0]
    # no single-gene move to any free position improves E
    held = {tuple(v) for v in res.genes.tolist()}
    free = [(r, c) for r in range(region.rows) for c in range(region.cols) if (r, c) not in held]
    for k in range(n):
        pop = np.repeat(res.genes[None], len(free), axis=0)
        pop[:, k] = free
        assert obj(pop)[0].min() >= res.E
    assert res.evaluations == 1 + res.polish["evaluations"]
    assert res.generations == 1 and len(res.history["best"]) == 1
    assert res.params["polish"] is True and res.params["polish_batch"] == 7


def test_polish_min_distance_keeps_patches_apart() -> None:
    """One deep well attracts every gene; the polish keeps moved genes min_distance apart (Chebyshev), and the
    result is a coordinate-wise optimum over the allowed positions."""
    shape, tile, n, d = (40, 40), 8, 4, 5
    region = Region.of(shape, tile)
    yy, xx = np.mgrid[0 : region.rows, 0 : region.cols]
    obj = Landscape(np.hypot(yy - 16.0, xx - 16.0) + 1.0, n)
    start = np.array([[0, 0], [0, 32], [32, 0], [32, 32]], dtype=np.int64)
    genes, E, _, info = polish_genes(obj, start, shape, tile, min_distance=d)
    assert info["min_distance"] == d and info["converged"] and info["moves"] > 0
    cheb = np.abs(genes[:, None] - genes[None]).max(-1)
    assert cheb[~np.eye(n, dtype=bool)].min() >= d
    for k in range(n):
        others = np.delete(genes, k, axis=0)
        pos = np.stack([yy.ravel(), xx.ravel()], -1)
        ok = np.abs(pos[:, None] - others[None]).max(-1).min(1) >= d
        pop = np.repeat(genes[None], ok.sum(), axis=0)
        pop[:, k] = pos[ok]
        assert obj(pop)[0].min() >= E
    # without the constraint the genes crowd into the well
    g0, E0, _, _ = polish_genes(obj, start, shape, tile, min_distance=0)
    assert E0 < E and np.abs(g0[:, None] - g0[None]).max(-1)[~np.eye(n, dtype=bool)].min() < d
    # the default is tile_size // 4
    assert polish_genes(obj, start, shape, tile, max_sweeps=1)[3]["min_distance"] == tile // 4


def test_polish_max_sweeps_and_direct_call() -> None:
    shape, tile, n = (16, 18), 8, 4
    region = Region.of(shape, tile)
    obj = Landscape(smooth_landscape(region.rows, region.cols, 3), n, coupling=1.0)
    start = random_genes(shape, n, tile, np.random.default_rng(0))
    genes, E, D, info = polish_genes(obj, start, shape, tile, max_sweeps=1, batch_size=1000)
    assert info["sweeps"] == 1
    assert_valid(genes, n, shape, tile)
    E2, D2 = obj(genes[None])
    assert E == E2[0]
    np.testing.assert_array_equal(D, D2[0])
    calls: list[int] = []
    polish_genes(obj, start, shape, tile, progress=lambda s, d, t: calls.append(d))
    assert calls == list(range(1, len(calls) + 1)) and len(calls) % n == 0


# ---------------------------------------------------------------------------------------------------------------
# Errors


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"method": "annealing"}, "method"),
        ({"method": "ga", "alpha": 1.5}, "alpha"),
        ({"method": "ga", "population": 1}, "population"),
        ({"method": "ga", "p_crossover": -0.1}, "p_crossover"),
        ({"method": "ga", "p_mutation": 2}, "p_mutation"),
        ({"method": "ga", "generations": 0}, "generations"),
        ({"method": "ga", "stagnation": 0}, "stagnation"),
        ({"method": "ga", "elitism": 1}, "elitism"),
        ({"method": "ga", "beta": 4}, "beta"),
        ({"method": "ga", "population": 2.5}, "population"),
        ({"method": "ais", "deaths": 40}, "deaths"),
        ({"method": "ais", "s_min": 0.5}, "s_min"),
        ({"method": "ais", "s_max": 1.0}, "s_max"),
        ({"method": "ais", "p_crossover": 0.3}, "p_crossover"),
        ({"method": "random", "generations": 5}, "generations"),
        ({"method": "random", "population": 5}, "population"),
        ({"method": "best-of", "count": 0}, "count"),
        ({"method": "best-of", "count": 5, "population": 5}, "count"),
        ({"method": "ga", "polish_sweeps": 2}, "polish_sweeps"),
        ({"method": "ga", "polish": True, "polish_sweeps": 0}, "polish_sweeps"),
        ({"method": "ga", "polish": "yes"}, "polish"),
        ({"method": "ga", "rng": "seed"}, "rng"),
        ({"method": "ga", "rng": -1}, "rng"),
        ({"method": "ga", "tile_size": 61}, "tile_size"),
        ({"method": "ga", "n": 0}, "n = 0"),
        ({"method": "ga", "shape": (5,)}, "shape"),
        ({"method": "ga", "tile_size": 60, "n": 200}, "tile_size"),
    ],
)
def test_errors(kwargs: dict[str, Any], match: str) -> None:
    args: dict[str, Any] = {
        "evaluate": make_objective(),
        "shape": SHAPE,
        "n": N_GENES,
        "tile_size": TILE,
        "rng": 0,
    }
    args.update(kwargs)
    with pytest.raises(ParameterError, match=match) as info:
        select_genes(**args)
    assert isinstance(info.value, ValueError)


def test_bad_evaluator_output() -> None:
    def wrong_shape(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.zeros(genes.shape[0] + 1), np.zeros((genes.shape[0], 3))

    def negative(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return -np.ones(genes.shape[0]), np.zeros((genes.shape[0], 3))

    def nan(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.full(genes.shape[0], np.nan), np.zeros((genes.shape[0], 3))

    with pytest.raises(ShapeError):
        select_genes("ga", wrong_shape, SHAPE, N_GENES, TILE, 0)
    with pytest.raises(ParameterError, match="E >= 0"):
        select_genes("ais", negative, SHAPE, N_GENES, TILE, 0)
    with pytest.raises(ParameterError, match="non-finite"):
        select_genes("random", nan, SHAPE, N_GENES, TILE, 0)
    with pytest.raises(ParameterError, match="evaluate"):
        select_genes("random", None, SHAPE, N_GENES, TILE, 0)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------------------------
# Integration with the Rust population evaluator


def test_with_population_evaluator(small_exemplar: np.ndarray) -> None:
    if not hasattr(tilesynth, "PopulationEvaluator"):
        pytest.skip("tilesynth.PopulationEvaluator is not available in this build")
    ex = np.ascontiguousarray(small_exemplar[:40, :44])
    tileset = tilesynth.get_tileset("8")
    colours = list(tileset.colours)
    index = {c: i for i, c in enumerate(colours)}
    tile_patches = np.array([[index[c] for c in t] for t in tileset.tiles], dtype=np.int64)
    n, tile = len(colours), 24
    evaluator = tilesynth.PopulationEvaluator(ex, tile, tile_patches, n)
    evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] = evaluator.evaluate
    for method in ("best-of", "ga", "ais"):
        extra: dict[str, Any] = {"generations": 3} if method != "best-of" else {}
        res = select_genes(method, evaluate, ex.shape, n, tile, 1, population=8, **extra)
        assert_valid(res.genes, n, ex.shape[:2], tile)
        E, D = evaluate(res.genes[None].astype(np.int64))
        assert res.E == float(E[0])
        np.testing.assert_array_equal(res.D, D[0])
        assert math.isclose(res.E, LAM * D[0].sum() + (1 - LAM) * D[0].var(), rel_tol=1e-9)
