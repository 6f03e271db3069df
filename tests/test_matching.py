"""Matching-patch strategies (002 §3.2) and the gradient-aware distances of 000 (eq. 2, eq. 3)."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.base import kernels
from tilesynth.builder.matching.choose import (
    MU,
    augmented,
    circle_ring,
    gradient_norm,
    midpoint_region,
    strategy_edges,
)
from tilesynth.builder.omega import energy, patch_gradients
from tilesynth.cli.main import main


@pytest.fixture(scope="module")
def ex(small_exemplar):
    return np.ascontiguousarray(small_exemplar[:40, :44])


N = 16


def candidates(ex, n):
    h, w = ex.shape[0] - n + 1, ex.shape[1] - n + 1
    return [(r, c) for r in range(h) for c in range(w)]


def test_edge_weight_sums_oracle(ex, rng):
    t = np.ascontiguousarray(ex[3 : 3 + N, 5 : 5 + N][::-1])
    g = rng.random((N, N, 2))
    wxm, wym = strategy_edges("circle", N, True)
    got = kernels.edge_weight_sums(t, ex, wxm, wym, template_grad=g)
    for r, c in [(0, 0), (7, 11), (24, 28), (13, 2)]:
        wx, wy = kernels.kwatra_weights(t, ex[r : r + N, c : c + N], a_grad=g)
        assert got[r, c] == pytest.approx(wx[wxm].sum() + wy[wym].sum(), rel=1e-12)


def test_heuristic_regions():
    ring = circle_ring(32)
    c = 15.5
    yy, xx = np.mgrid[:32, :32]
    d = np.sqrt((yy - c) ** 2 + (xx - c) ** 2)
    assert ring.any() and (d[ring] <= 16).all() and (d[ring] > 14).all()
    mid = midpoint_region(32)
    assert mid[15, 1] and mid[1, 16] and not mid[16, 16] and not mid[0, 0]
    wx, wy = strategy_edges("midpoints", 32, True)
    # no edge joins two source pixels; the border ring is source with keep_border
    assert not wx[0].any() and not wy[:, 0].any()


@pytest.mark.parametrize("strategy", ["circle", "midpoints"])
def test_heuristics_choose_the_argmin_of_their_score(strategy, ex):
    ts = tilesynth.build_omega(ex, tileset="8", tile_size=N, seed=2, match=strategy, select="random")
    assert ts.params["match"] == strategy
    inter, src = tilesynth.builder.omega.intermediate_tiles(ex, ts.genes, ts.tile_patches, N)
    grads = patch_gradients(ex, src)
    wxm, wym = strategy_edges(strategy, N, True)
    for j in range(ts.n_tiles):
        score = kernels.edge_weight_sums(inter[j], ex, wxm, wym, template_grad=grads[j])
        r, c = np.unravel_index(np.argmin(score), score.shape)
        assert tuple(ts.match_offsets[j]) == (r, c)
        # D_j is the SSD of the chosen patch; E still uses each tile's smallest SSD
        d = ((inter[j].astype(np.float64) - ex[r : r + N, c : c + N]) ** 2).sum()
        assert ts.D[j] == pytest.approx(d, rel=1e-9)
    plain = tilesynth.build_omega(ex, tileset="8", tile_size=N, seed=2, select="random")
    assert ts.E == pytest.approx(plain.E, rel=1e-12)


def test_best_cut_all_is_the_exhaustive_cheapest_cut(ex):
    small = np.ascontiguousarray(ex[:28, :30])
    n = 12
    ts = tilesynth.build_omega(
        small, tileset="4", tile_size=n, seed=1, match="best-cut", match_k="all", select="random"
    )
    inter, src = tilesynth.builder.omega.intermediate_tiles(small, ts.genes, ts.tile_patches, n)
    grads = patch_gradients(small, src)
    cands = candidates(small, n)
    for j in range(ts.n_tiles):
        O = np.stack([small[r : r + n, c : c + n] for r, c in cands])
        _, costs = tilesynth.omega_cuts(
            np.repeat(inter[j][None], len(cands), 0),
            O,
            intermediate_grad=np.repeat(grads[j][None], len(cands), 0),
        )
        assert ts.cut_costs[j] == pytest.approx(costs.min(), rel=1e-12)
    plain = tilesynth.build_omega(small, tileset="4", tile_size=n, seed=1, select="random")
    assert (ts.cut_costs <= plain.cut_costs * (1 + 1e-12)).all()
    assert ts.params["match_k"] == "all"


def test_best_cut_of_one_is_the_ssd_match(ex):
    a = tilesynth.build_omega(ex, tileset="16a", tile_size=N, seed=3, match="best-cut", match_k=1)
    b = tilesynth.build_omega(ex, tileset="16a", tile_size=N, seed=3)
    np.testing.assert_array_equal(a.match_offsets, b.match_offsets)
    np.testing.assert_array_equal(a.tiles, b.tiles)


@pytest.mark.parametrize("strategy", ["circle", "best-cut"])
def test_32_set_variants_are_far_apart_for_every_strategy(strategy, ex):
    ts = tilesynth.build_omega(ex, tileset="32", tile_size=N, seed=4, match=strategy)
    for k in range(16):
        assert np.abs(ts.match_offsets[k] - ts.match_offsets[k + 16]).max() > N // 4


def test_eq3_is_ssd_on_the_augmented_exemplar(ex):
    ts = tilesynth.build_omega(ex, tileset="8", tile_size=N, seed=5, metric="eq3")
    aug = augmented(ex)
    assert aug.shape[2] == 9
    inter, src = tilesynth.builder.omega.intermediate_tiles(ex, ts.genes, ts.tile_patches, N)
    best = []
    for j in range(ts.n_tiles):
        t = aug[src[j, ..., 0], src[j, ..., 1]].astype(np.float64)
        # eq. 3 written out: colour SSD + μ · squared gradient differences (gradients at the provenance)
        m = np.empty((ex.shape[0] - N + 1, ex.shape[1] - N + 1))
        for r, c in candidates(ex, N):
            o = aug[r : r + N, c : c + N].astype(np.float64)
            col = ((t[..., :3] - o[..., :3]) ** 2).sum()
            grad = ((t[..., 3:] - o[..., 3:]) ** 2).sum() / MU
            m[r, c] = col + MU * grad
        r, c = np.unravel_index(np.argmin(m), m.shape)
        assert tuple(ts.match_offsets[j]) == (r, c)
        assert ts.D[j] == pytest.approx(m.min(), rel=1e-6)
        best.append(m.min())
    assert ts.E == pytest.approx(energy(np.array(best)), rel=1e-6)
    assert ts.params["metric"] == "eq3"


def test_eq2_oracle_and_build(ex, rng):
    g = gradient_norm(ex)
    t = np.ascontiguousarray(ex[5 : 5 + N, 9 : 9 + N])
    tg = rng.random((N, N))
    got = kernels.weighted_ssd_map(ex, g, t, tg, MU, 1e-6)
    for r, c in [(0, 0), (3, 17), (24, 28)]:
        d2 = ((t.astype(np.float64) - ex[r : r + N, c : c + N]) ** 2).sum(axis=2)
        want = (d2 / (MU * (tg + g[r : r + N, c : c + N]) + 1e-6)).sum()
        assert got[r, c] == pytest.approx(want, rel=1e-12)
    ts = tilesynth.build_omega(ex, tileset="4", tile_size=N, seed=6, metric="eq2")
    inter, src = tilesynth.builder.omega.intermediate_tiles(ex, ts.genes, ts.tile_patches, N)
    for j in range(ts.n_tiles):
        m = kernels.weighted_ssd_map(ex, g, inter[j], g[src[j, ..., 0], src[j, ..., 1]], MU, 1e-6)
        assert tuple(ts.match_offsets[j]) == np.unravel_index(np.argmin(m), m.shape)
        assert ts.D[j] == pytest.approx(m.min(), rel=1e-12)
    with pytest.raises(tilesynth.ParameterError, match="eq2"):
        tilesynth.build_omega(ex, tileset="4", tile_size=N, seed=6, metric="eq2", select="ga")


def test_errors(ex):
    with pytest.raises(tilesynth.ParameterError, match="match"):
        tilesynth.build_omega(ex, tileset="4", tile_size=N, match="nearest")
    with pytest.raises(tilesynth.ParameterError, match="match_k"):
        tilesynth.build_omega(ex, tileset="4", tile_size=N, match="ssd", match_k=3)
    with pytest.raises(tilesynth.ParameterError, match="match_k"):
        tilesynth.build_omega(ex, tileset="4", tile_size=N, match="best-cut", match_k=0)
    with pytest.raises(tilesynth.ParameterError, match="metric"):
        tilesynth.build_omega(ex, tileset="4", tile_size=N, metric="l1")


def test_cli_match_and_metric(ex, tmp_path, capsys):
    png = tmp_path / "ex.png"
    tilesynth.save_image(png, ex)
    out = tmp_path / "m.tiles"
    assert (
        main(
            [
                "build",
                str(png),
                "-o",
                str(out),
                "--tile-size",
                "16",
                "--set",
                "8",
                "--match",
                "best-cut",
                "--match-k",
                "5",
                "--metric",
                "eq3",
                "--seed",
                "1",
                "-q",
            ]
        )
        == 0
    )
    ts = tilesynth.load(out)
    assert ts.params["match"] == "best-cut" and ts.params["match_k"] == 5 and ts.params["metric"] == "eq3"
    assert (
        main(
            [
                "build",
                str(png),
                "-o",
                str(tmp_path / "x.tiles"),
                "--tile-size",
                "16",
                "--match",
                "best-cut",
                "--match-k",
                "many",
                "-q",
            ]
        )
        == 2
    )
    assert "--match-k" in capsys.readouterr().err
