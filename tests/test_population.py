"""Population evaluation of the ω-tile objective against a numpy brute-force oracle and build_omega."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.lib.stride_tricks import sliding_window_view

import tilesynth
from tilesynth.errors import ParameterError, ShapeError


def assemble(ex: np.ndarray, genes: np.ndarray, tile: np.ndarray, n: int) -> np.ndarray:
    """Intermediate tile of one ⟨TL, BL, TR, BR⟩ gene-index tuple (the rule of tilesynth.builder.omega)."""
    h = n // 2
    out = np.empty((n, n, ex.shape[2]), np.float64)
    (r0, c0), (r1, c1), (r2, c2), (r3, c3) = (genes[i] for i in tile)
    out[:h, :h] = ex[r0 + h : r0 + n, c0 + h : c0 + n]  # TL: bottom-right quarter
    out[h:, :h] = ex[r1 : r1 + h, c1 + h : c1 + n]  # BL: top-right quarter
    out[:h, h:] = ex[r2 + h : r2 + n, c2 : c2 + h]  # TR: bottom-left quarter
    out[h:, h:] = ex[r3 : r3 + h, c3 : c3 + h]  # BR: top-left quarter
    return out


def oracle(ex, genes, tile_patches, n, lam=0.8, normalise=False):
    """float64 brute force over every translation (numpy sliding windows)."""
    I = ex.astype(np.float64)
    win = sliding_window_view(I, (n, n), axis=(0, 1))  # (H-n+1, W-n+1, C, n, n)
    P, m = genes.shape[0], tile_patches.shape[0]
    D = np.empty((P, m))
    for p in range(P):
        for j in range(m):
            T = assemble(ex, genes[p], tile_patches[j], n).transpose(2, 0, 1)
            C = ((win - T) ** 2).sum(axis=(2, 3, 4))
            if normalise:
                C = C / (n * n)
            D[p, j] = C.min()
    E = lam * D.sum(axis=1) + (1 - lam) * D.var(axis=1)
    return E, D


def tileset_indices(name: str) -> tuple[np.ndarray, int]:
    defn = tilesynth.get_tileset(name)
    index = {c: i for i, c in enumerate(defn.colours)}
    return np.array([[index[c] for c in t] for t in defn.tiles], dtype=np.int64), len(defn.colours)


@st.composite
def case(draw):
    n = draw(st.sampled_from([2, 4, 6, 8]))
    H = draw(st.integers(n, 20))
    W = draw(st.integers(n, 20))
    C = draw(st.sampled_from([1, 3]))
    n_patches = draw(st.integers(1, 6))
    m = draw(st.integers(1, 10))
    P = draw(st.integers(0, 4))
    seed = draw(st.integers(0, 2**32 - 1))
    r = np.random.default_rng(seed)
    ex = r.random((H, W, C), dtype=np.float32)
    if draw(st.booleans()):
        ex = np.round(ex * 3) / 3  # few levels: many exact ties
        ex = ex.astype(np.float32)
    tp = r.integers(0, n_patches, (m, 4))
    genes = np.stack([r.integers(0, H - n + 1, (P, n_patches)), r.integers(0, W - n + 1, (P, n_patches))], -1)
    return ex, genes, tp, n, n_patches, draw(st.booleans()), draw(st.sampled_from([0.0, 0.3, 0.8, 1.0]))


@given(case())
def test_matches_oracle(c):
    ex, genes, tp, n, n_patches, normalise, lam = c
    ev = tilesynth.PopulationEvaluator(ex, n, tp, n_patches, lam=lam, normalise=normalise)
    E, D = ev.evaluate(genes)
    rE, rD = oracle(ex, genes, tp, n, lam, normalise)
    assert E.dtype == D.dtype == np.float64
    assert E.shape == (genes.shape[0],) and D.shape == (genes.shape[0], tp.shape[0])
    np.testing.assert_allclose(D, rD, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(E, rE, rtol=1e-9, atol=1e-12)
    # the same through the one-shot function, and again from the warm cache, at another thread count
    E2, D2 = tilesynth.evaluate_population(ex, genes, tp, n, lam=lam, normalise=normalise, threads=1)
    E3, D3 = ev.evaluate(genes, threads=2)
    assert np.array_equal(D, D2) and np.array_equal(E, E2)
    assert np.array_equal(D, D3) and np.array_equal(E, E3)


def test_16a_normalise_and_energy(rng):
    ex = rng.random((24, 20, 3), dtype=np.float32)
    tp, n_patches = tileset_indices("16a")
    n = 8
    genes = np.stack([rng.integers(0, 17, (5, n_patches)), rng.integers(0, 13, (5, n_patches))], -1)
    E, D = tilesynth.evaluate_population(ex, genes, tp, n)
    En, Dn = tilesynth.evaluate_population(ex, genes, tp, n, normalise=True)
    _, rD = oracle(ex, genes, tp, n)
    np.testing.assert_allclose(D, rD, rtol=1e-9)
    np.testing.assert_allclose(Dn, D / (n * n), rtol=1e-12)
    for e, d in zip(E, D):
        assert e == pytest.approx(0.8 * d.sum() + 0.2 * np.var(d), rel=1e-12)
        assert e == pytest.approx(tilesynth.energy(d), rel=1e-12)
    for e, d in zip(En, Dn):
        assert e == pytest.approx(tilesynth.energy(d), rel=1e-12)
    # lam = 1: plain sum; lam = 0: population variance (ddof = 0)
    E1, _ = tilesynth.evaluate_population(ex, genes, tp, n, lam=1.0)
    E0, _ = tilesynth.evaluate_population(ex, genes, tp, n, lam=0.0)
    np.testing.assert_allclose(E1, D.sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(E0, D.var(axis=1, ddof=0), rtol=1e-9)


@pytest.mark.parametrize("name", ["16a", "8"])
def test_agrees_with_build_omega(small_exemplar, name):
    tp, n_patches = tileset_indices(name)
    n = 32
    r = np.random.default_rng(7)
    ev = tilesynth.PopulationEvaluator(small_exemplar, n, tp, n_patches)
    pop = []
    for _ in range(3):
        flat = r.choice((96 - n + 1) ** 2, size=n_patches, replace=False)
        pop.append(np.stack([flat // (96 - n + 1), flat % (96 - n + 1)], 1))
    genes = np.stack(pop)
    E, D = ev.evaluate(genes)
    for p in range(len(pop)):
        ts = tilesynth.build_omega(small_exemplar, tileset=name, tile_size=n, genes=genes[p], seed=1)
        np.testing.assert_allclose(D[p], ts.D, rtol=1e-9)
        assert E[p] == pytest.approx(ts.E, rel=1e-9)


def test_cache_reuse_and_eviction(rng):
    ex = rng.random((40, 36, 3), dtype=np.float32)
    tp = rng.integers(0, 6, (38, 4))
    n = 16
    genes = np.stack([rng.integers(0, 25, (6, 6)), rng.integers(0, 21, (6, 6))], -1)
    big = tilesynth.PopulationEvaluator(ex, n, tp, 6)
    tiny = tilesynth.PopulationEvaluator(ex, n, tp, 6, cache_bytes=1000)
    none = tilesynth.PopulationEvaluator(ex, n, tp, 6, cache_bytes=0)
    ref = big.evaluate(genes)
    s = big.cache_stats()
    assert set(s) == {"entries", "bytes", "limit", "hits", "misses"}
    assert s["hits"] == 0 and s["misses"] == s["entries"] > 0 and s["limit"] == 256 << 20
    for gen in range(4):
        genes = genes.copy()
        genes[gen, gen % 6] = (gen, gen + 1)
        out = [ev.evaluate(genes, threads=t) for ev, t in ((big, 2), (tiny, 1), (none, None))]
        for E, D in out[1:]:
            assert np.array_equal(E, out[0][0]) and np.array_equal(D, out[0][1])
    s = big.cache_stats()
    assert s["hits"] > s["misses"]
    assert tiny.cache_stats()["bytes"] <= 1000
    assert none.cache_stats()["entries"] == 0
    big.clear_cache()
    assert big.cache_stats()["entries"] == 0
    assert ref[1].shape == (6, 38)


def test_errors(rng):
    ex = rng.random((20, 16, 3), dtype=np.float32)
    tp = np.array([[0, 1, 2, 3], [3, 2, 1, 0]])
    P = tilesynth.PopulationEvaluator
    with pytest.raises(ParameterError, match="tile_size"):
        P(ex, 7, tp, 4)
    with pytest.raises(ParameterError, match="tile_size"):
        P(ex, 18, tp, 4)
    with pytest.raises(ParameterError, match="tile_size"):
        P(ex, -2, tp, 4)
    with pytest.raises(ParameterError, match="tile_patches"):
        P(ex, 8, tp, 3)
    with pytest.raises(ParameterError, match="tile_patches"):
        P(ex, 8, -tp, 4)
    with pytest.raises(ShapeError, match="tile_patches"):
        P(ex, 8, tp[:, :3], 4)
    with pytest.raises(ShapeError, match="tile_patches"):
        P(ex, 8, tp[0], 4)
    with pytest.raises(ShapeError, match="tile_patches"):
        P(ex, 8, np.zeros((0, 4), int), 4)
    with pytest.raises(ParameterError, match="lam"):
        P(ex, 8, tp, 4, lam=1.5)
    with pytest.raises(ParameterError, match="lam"):
        P(ex, 8, tp, 4, lam=-0.01)
    with pytest.raises(ParameterError, match="n_patches"):
        P(ex, 8, tp, 0)
    with pytest.raises(ParameterError, match="exemplar"):
        P(ex * 2, 8, tp, 4)
    ev = P(ex, 8, tp, 4)
    ok = np.zeros((2, 4, 2), np.int64)
    ok[:, :, 0] = 12
    ok[:, :, 1] = 8
    ev.evaluate(ok)
    for bad_value in [(13, 0), (0, 9), (-1, 0)]:
        g = ok.copy()
        g[1, 2] = bad_value
        with pytest.raises(ParameterError, match="genes"):
            ev.evaluate(g)
    with pytest.raises(ShapeError, match="genes"):
        ev.evaluate(np.zeros((2, 3, 2), np.int64))
    with pytest.raises(ShapeError, match="genes"):
        ev.evaluate(np.zeros((2, 4, 3), np.int64))
    with pytest.raises(ShapeError, match="genes"):
        ev.evaluate(np.zeros((4, 2), np.int64))
    with pytest.raises(ParameterError, match="genes"):
        ev.evaluate(np.zeros((1, 4, 2)) + 0.5)
    with pytest.raises(ShapeError, match="genes"):
        tilesynth.evaluate_population(ex, np.zeros((3, 2), np.int64), tp, 8)
    E, D = ev.evaluate(np.zeros((0, 4, 2), np.int64))
    assert E.shape == (0,) and D.shape == (0, 2)
