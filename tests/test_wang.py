"""Wang tiles (Cohen et al. with 001's match) and strict Wang tiles (004): the Rust kernels against slow
obvious oracles, provenance, continuity across tile edges through the provenance maps, energy, selection."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from test_kernels_ssd import ssd_oracle

import tilesynth
from tilesynth.builder.wang import (
    EAST,
    NORTH,
    SOUTH,
    SUPPLEMENTARY,
    WEST,
    corner_mismatch,
    initial_labels,
    sample_size,
    wang_energy,
)
from tilesynth.layouts.wang_sets import get_wang_tileset

# --------------------------------------------------------------------------------------------------------------
# A slow, obvious oracle of the Cohen construction, written from the geometry of tilesynth.builder.wang's docstring.

CUT_ROLES = [(NORTH, EAST), (SOUTH, EAST), (SOUTH, WEST), (NORTH, WEST)]  # NE, ES, SW, WN
OFFSETS = {NORTH: (1, 0), EAST: (0, -1), SOUTH: (-1, 0), WEST: (0, 1)}  # in units of h
CENTRES = {NORTH: (0.0, 0.5), EAST: (0.5, 1.0), SOUTH: (1.0, 0.5), WEST: (0.5, 0.0)}  # in units of N


class Oracle:
    def __init__(self, ex, n, overlap, corners, samples):
        self.ex = ex.astype(np.float64)
        self.n, self.h, self.w = n, n // 2, overlap // 2
        self.corners, self.samples = corners, samples
        self.p = sample_size(n, overlap, corners, samples)
        self.m = (self.p - n) // 2

    def flip(self, q, y, x):
        n1 = self.n - 1
        return [(y, x), (n1 - y, x), (n1 - y, n1 - x), (y, n1 - x)][q]

    def support(self, role, y, x):
        cy, cx = (v * self.n for v in CENTRES[role])
        dy, dx = abs(y + 0.5 - cy), abs(x + 0.5 - cx)
        if self.samples == "diamond":
            return dy + dx <= self.h + self.w
        return max(dy, dx) <= self.h

    def pixel(self, role, gene, y, x):
        oy, ox = OFFSETS[role]
        r = gene[0] + self.m + oy * self.h + y
        c = gene[1] + self.m + ox * self.h + x
        assert 0 <= r < self.ex.shape[0] and 0 <= c < self.ex.shape[1]
        return self.ex[r, c]

    @staticmethod
    def lum(p):
        return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2] if p.size >= 3 else p[0]

    def band(self):
        """{s: sorted list of d} in the NE frame."""
        n = self.n
        out = {}
        for s in range(1, 3 * n):
            ds = []
            for d in range(-(s - 1), s, 2):
                y, x = (d - s + n - 1) // 2, (d + s + n - 1) // 2
                if not (self.support(NORTH, y, x) and self.support(EAST, y, x)):
                    continue
                if self.corners == "pinned" and (y < 0 or x > n - 1 or (x == n - 1 and y > 0)):
                    continue
                ds.append(d)
            if not ds:
                break
            if self.corners == "pinned" and s > n - 1:
                break
            out[s] = ds
        return out

    def cut(self, q, ga, gb):
        """(path {s: d}, D_overlap, n_overlap, D_path, n_path)."""
        n = self.n
        ra, rb = CUT_ROLES[q]
        band = self.band()
        e_rgb, e_y = {}, {}
        for s, ds in band.items():
            for d in ds:
                y, x = self.flip(q, (d - s + n - 1) // 2, (d + s + n - 1) // 2)
                a, b = self.pixel(ra, ga, y, x), self.pixel(rb, gb, y, x)
                e_rgb[s, d] = float(((a - b) ** 2).sum())
                e_y[s, d] = (self.lum(a) - self.lum(b)) ** 2
        best = {(1, 0): (e_y[1, 0], None)}
        last = max(band)
        for s in range(2, last + 1):
            for d in band[s]:
                cands = [(best[s - 1, pd][0], pd) for pd in (d - 1, d + 1) if (s - 1, pd) in best]
                if cands:
                    v, pd = min(cands)
                    best[s, d] = (e_y[s, d] + v, pd)
        ends = [(best[last, d][0], d) for d in band[last] if (last, d) in best]
        if self.corners == "pinned":
            ends = [e for e in ends if e[1] == 0]
        total, d = min(ends)
        path = {}
        for s in range(last, 0, -1):
            path[s] = d
            d = best[s, d][1]
        return path, sum(e_rgb.values()), len(e_rgb), total, len(path)

    def labels(self, paths):
        """Tile labels from the four paths."""
        n, h = self.n, self.h
        lab = np.full((n, n), -1)
        for q, path in enumerate(paths):
            ra, rb = CUT_ROLES[q]
            for yc in range(h):
                for xc in range(h, n):
                    s, d = xc - yc, xc + yc - (n - 1)
                    y, x = self.flip(q, yc, xc)
                    lab[y, x] = ra if d <= path[s] else rb
        assert (lab >= 0).all()
        return lab


def oracle_tiles(ex, genes, tile_patches, n, overlap, corners="free", samples="diamond", omega=0.8):
    o = Oracle(ex, n, overlap, corners, samples)
    labels, stats = [], []
    for t in tile_patches:
        paths, row = [], []
        for q, (ra, rb) in enumerate(CUT_ROLES):
            path, dov, nov, dpa, npa = o.cut(q, genes[t[ra]], genes[t[rb]])
            paths.append(path)
            db = omega * dov / nov + ex.shape[2] * (1 - omega) * dpa / npa
            row.append([dov, nov, dpa, npa, db, dpa])
        labels.append(o.labels(paths))
        stats.append(row)
    return np.array(labels), np.array(stats)


def random_genes(rng, ex, n_samples, p):
    return np.stack(
        [rng.integers(0, ex.shape[0] - p + 1, n_samples), rng.integers(0, ex.shape[1] - p + 1, n_samples)],
        axis=1,
    ).astype(np.int64)


CONFIGS = [
    (8, 2, "free", "diamond"),
    (8, 4, "pinned", "diamond"),
    (12, 4, "free", "diamond"),
    (16, 6, "free", "diamond"),
    (16, 4, "pinned", "diamond"),
    (12, 12, "pinned", "square"),
]


@pytest.mark.parametrize(("n", "overlap", "corners", "samples"), CONFIGS)
def test_dp_cuts_match_the_oracle(n, overlap, corners, samples, small_exemplar, rng):
    ex = small_exemplar[:48, :48]
    ts = get_wang_tileset("wang8")
    tp = ts.sample_indices()
    p = sample_size(n, overlap, corners, samples)
    for _ in range(2):
        genes = random_genes(rng, ex, 4, p)
        labels, stats = tilesynth.wang_tiles(ex, genes, tp, n, overlap, corners=corners, samples=samples)
        o_labels, o_stats = oracle_tiles(ex, genes, tp, n, overlap, corners, samples)
        np.testing.assert_array_equal(labels, o_labels)
        np.testing.assert_allclose(stats, o_stats, rtol=1e-10, atol=1e-12)


def test_dp_path_is_the_minimum_over_every_staircase(small_exemplar, rng):
    """Brute force over every 4-connected staircase of the band (N = 8: at most 2^10 paths)."""
    ex = small_exemplar[:40, :40]
    for corners in ("free", "pinned"):
        o = Oracle(ex, 8, 4, corners, "diamond")
        band = o.band()
        last = max(band)
        ga, gb = random_genes(rng, ex, 2, o.p)
        for q in range(4):
            _, _, _, d_path, _ = o.cut(q, ga, gb)
            ra, rb = CUT_ROLES[q]

            def err(s, d):
                y, x = o.flip(q, (d - s + 7) // 2, (d + s + 7) // 2)
                return (o.lum(o.pixel(ra, ga, y, x)) - o.lum(o.pixel(rb, gb, y, x))) ** 2

            best = np.inf
            for steps in itertools.product((-1, 1), repeat=last - 1):
                d, acc, ok = 0, err(1, 0), True
                for s, step in enumerate(steps, start=2):
                    d += step
                    if d not in band[s]:
                        ok = False
                        break
                    acc += err(s, d)
                if ok and (corners == "free" or d == 0):
                    best = min(best, acc)
            assert d_path == pytest.approx(best, rel=1e-12, abs=1e-15)
            _, stats = tilesynth.wang_tiles(
                ex, np.stack([ga, gb, ga, gb]), np.array([[0, 1, 2, 3]]), 8, 4, corners=corners
            )
            assert stats[0, q, 2] == pytest.approx(best, rel=1e-10, abs=1e-15)


def graph_cut_oracle(ex, q, ga, gb, n, overlap, corners, eps=1e-6):
    """The graph-cut option rebuilt from its definition with networkx: returns (flow, NE-frame box labels)."""
    import networkx as nx

    o = Oracle(ex, n, overlap, corners, "diamond")
    band = o.band()
    h, m = n // 2, o.m
    side = h + m
    ra, rb = CUT_ROLES[q]
    cls = np.zeros((side, side), int)  # 0 free, 1 A, 2 B, 3 out
    a = np.zeros((side, side, ex.shape[2]), np.float32)
    b = np.zeros_like(a)
    for r in range(side):
        for c in range(side):
            yc, xc = r - m, h + c
            s, d = xc - yc, xc + yc - (n - 1)
            if c == 0 and yc >= 0:
                k = 1
            elif yc == h - 1:
                k = 2
            elif corners == "pinned" and yc == 0:
                k = 1
            elif corners == "pinned" and xc == n - 1:
                k = 2
            elif s in band and d in band[s]:
                k = 0
            elif s in band:
                k = 1 if d < band[s][0] else 2
            else:
                k = 3
            cls[r, c] = k
            y, x = o.flip(q, yc, xc)
            a[r, c], b[r, c] = o.pixel(ra, ga, y, x), o.pixel(rb, gb, y, x)
    wx, wy = tilesynth.kwatra_weights(a, b, eps=eps)
    g = nx.DiGraph()
    for r in range(side):
        for c in range(side):
            if cls[r, c] == 3:
                continue
            if cls[r, c] == 1:
                g.add_edge("s", (r, c), capacity=float("inf"))
            if cls[r, c] == 2:
                g.add_edge((r, c), "t", capacity=float("inf"))
            for rr, cc, wgt in (
                (r, c + 1, wx[r, c] if c + 1 < side else 0),
                (r + 1, c, wy[r, c] if r + 1 < side else 0),
            ):
                if rr < side and cc < side and cls[rr, cc] != 3 and wgt > 0:
                    g.add_edge((r, c), (rr, cc), capacity=float(wgt))
                    g.add_edge((rr, cc), (r, c), capacity=float(wgt))
    flow, (s_side, _) = nx.minimum_cut(g, "s", "t")
    return flow, cls


@pytest.mark.parametrize(("n", "overlap", "corners"), [(8, 2, "free"), (12, 4, "pinned"), (12, 6, "free")])
def test_graph_cuts_are_minimum_cuts(n, overlap, corners, small_exemplar, rng):
    ex = small_exemplar[:48, :48]
    p = sample_size(n, overlap, corners)
    genes = random_genes(rng, ex, 4, p)
    tp = np.array([[0, 1, 2, 3]])
    labels, stats = tilesynth.wang_tiles(ex, genes, tp, n, overlap, corners=corners, cut="graph")
    _, dp_stats = tilesynth.wang_tiles(ex, genes, tp, n, overlap, corners=corners, cut="dp")
    for q, (ra, rb) in enumerate(CUT_ROLES):
        flow, _ = graph_cut_oracle(ex, q, genes[tp[0, ra]], genes[tp[0, rb]], n, overlap, corners)
        assert stats[0, q, 5] == pytest.approx(flow, rel=1e-9)
        # same overlap region as the DP
        assert stats[0, q, 1] == dp_stats[0, q, 1]
        assert stats[0, q, 0] == pytest.approx(dp_stats[0, q, 0], rel=1e-12)
    # the graph cut respects the hard pixels: quadrant left columns / bottom rows
    h = n // 2
    lab = labels[0]
    assert (lab[:h, h] == NORTH).all() and (lab[h - 1, h + 1 :] == EAST).all()
    assert (lab[h:, h - 1] == SOUTH).all() and (lab[h, : h - 1] == WEST).all()


def test_evaluator_matches_the_oracle_build_and_threads(small_exemplar, rng):
    ex = small_exemplar[:64, :64]
    ts = get_wang_tileset("wang18")
    tp = ts.sample_indices()
    n, overlap = 16, 4
    p = sample_size(n, overlap, "free")
    genes = np.stack([random_genes(rng, ex, 6, p) for _ in range(4)])
    ev = tilesynth.WangEvaluator(ex, tp, 6, n, overlap)
    assert (ev.sample_size, ev.n_samples, ev.n_tiles) == (p, 6, 18)
    E1, D1 = ev.evaluate(genes, threads=1)
    E2, D2 = ev.evaluate(genes, threads=2)
    assert E1.tobytes() == E2.tobytes() and D1.tobytes() == D2.tobytes()
    for i in range(2):
        _, o_stats = oracle_tiles(ex, genes[i], tp, n, overlap)
        o_D = o_stats[:, :, 4].sum(1)
        np.testing.assert_allclose(D1[i], o_D, rtol=1e-10)
        assert E1[i] == pytest.approx(0.8 * o_D.sum() + 0.2 * o_D.var(), rel=1e-10)
    for i in range(4):
        built = tilesynth.build_wang(
            ex, tileset=ts, tile_size=n, overlap=overlap, genes=genes[i], corners="free"
        )
        assert built.D.tobytes() == D1[i].tobytes()
        assert built.E == E1[i]
        assert wang_energy(built.D) == E1[i]
    with pytest.raises(tilesynth.ParameterError, match="genes"):
        ev.evaluate(np.full((1, 6, 2), ex.shape[0], np.int64))
    with pytest.raises(tilesynth.ShapeError, match="genes"):
        ev.evaluate(np.zeros((1, 5, 2), np.int64))


# --------------------------------------------------------------------------------------------------------------
# Built tile sets: provenance, continuity, corners


@pytest.fixture(scope="module")
def cohen(small_exemplar):
    """Cohen's literal construction (free corners, one random draw), no longer the default (issue 14)."""
    return tilesynth.build_wang(small_exemplar, tile_size=32, seed=5, corners="free", border_tries=1)


@pytest.fixture(scope="module")
def swang(small_exemplar):
    return tilesynth.build_swang(small_exemplar, tile_size=32, seed=5)


def test_provenance_of_wang_tiles(cohen, small_exemplar):
    ts, ex = cohen, small_exemplar
    assert ts.scheme == "wang" and ts.n_tiles == 8 and ts.tiles.shape == (8, 32, 32, 3)
    assert ts.params["overlap"] == 8 and ts.params["sample_size"] == 40 and ts.params["corners"] == "free"
    np.testing.assert_array_equal(ts.tiles, ex[ts.source[..., 0], ts.source[..., 1]])
    # every pixel comes from the sample its label names, at the documented offset
    n, h, m = 32, 16, 4
    yy, xx = np.mgrid[0:n, 0:n]
    off = {NORTH: (h, 0), EAST: (0, -h), SOUTH: (-h, 0), WEST: (0, h)}
    for k in range(8):
        for role, (oy, ox) in off.items():
            sel = ts.labels[k] == role
            r, c = ts.genes[ts.tile_patches[k, role]]
            np.testing.assert_array_equal(ts.source[k][sel][:, 0], (r + m + oy + yy)[sel])
            np.testing.assert_array_equal(ts.source[k][sel][:, 1], (c + m + ox + xx)[sel])
    np.testing.assert_array_equal(ts.cut_masks, (ts.labels == EAST) | (ts.labels == WEST))
    assert (ts.match_offsets == -1).all()
    np.testing.assert_allclose(ts.D, ts.cut_stats[:, :, 4].sum(1), rtol=1e-15)
    assert ts.E == pytest.approx(0.8 * ts.D.sum() + 0.2 * ts.D.var(), rel=1e-12)
    # the tiles' N/E/S/W genes are those of their edge colours
    defn = ts.definition
    colours = list(defn.colours)
    for k in range(8):
        assert [colours[i] for i in ts.tile_patches[k]] == list(defn.tiles[k])


def test_provenance_of_swang_tiles(swang, small_exemplar):
    ts, ex = swang, small_exemplar
    n = 32
    assert ts.scheme == "swang" and ts.params["sample_size"] == n
    np.testing.assert_array_equal(ts.tiles, ex[ts.source[..., 0], ts.source[..., 1]])
    lab0 = initial_labels(n)
    border = np.zeros((n, n), bool)
    border[[0, -1]] = True
    border[:, [0, -1]] = True
    diag = (np.eye(n, dtype=bool) | np.eye(n, dtype=bool)[::-1]) & ~border
    for k in range(ts.n_tiles):
        m = ts.cut_masks[k]
        assert not m[border].any(), "the border keeps the initial tile"
        assert m[diag].all(), "both diagonals take the supplementary patch"
        np.testing.assert_array_equal(ts.labels[k], np.where(m, SUPPLEMENTARY, lab0))
        r, c = ts.match_offsets[k]
        np.testing.assert_array_equal(ts.tiles[k][m], ex[r : r + n, c : c + n][m])
    # corners and diagonals of the initial tile go to the horizontal-edge samples
    assert lab0[0, 0] == NORTH and lab0[n - 1, n - 1] == SOUTH and lab0[0, n - 1] == NORTH
    assert lab0[n // 2, 0] == WEST and lab0[n // 2, n - 1] == EAST and lab0[3, 3] == NORTH


def test_swang_supplementary_is_the_exact_best_ssd(swang, small_exemplar):
    from tilesynth.builder.swang import _initial_tiles

    init, src, _ = _initial_tiles(small_exemplar, swang.genes, swang.tile_patches, 32)
    np.testing.assert_array_equal(init, small_exemplar[src[..., 0], src[..., 1]])
    for k in range(3):
        ref = ssd_oracle(small_exemplar, init[k])
        assert swang.D[k] == pytest.approx(ref.min(), rel=1e-9)
        assert ref[tuple(swang.match_offsets[k])] == pytest.approx(ref.min(), rel=1e-9)
    assert swang.E == pytest.approx(0.8 * swang.D.sum() + 0.2 * swang.D.var(), rel=1e-12)
    # the cut is swang_cuts with the sample gradients, as for ω-tiles
    from tilesynth.builder.omega import patch_gradients

    O = np.stack([small_exemplar[r : r + 32, c : c + 32] for r, c in swang.match_offsets])
    masks, costs = tilesynth.swang_cuts(init, O, initial_grad=patch_gradients(small_exemplar, src))
    np.testing.assert_array_equal(masks, swang.cut_masks)
    np.testing.assert_array_equal(costs, swang.cut_costs)


def swang_cut_oracle(a, b, eps=1e-6):
    import networkx as nx

    n = a.shape[0]
    wx, wy = tilesynth.kwatra_weights(a, b, eps=eps)
    g = nx.DiGraph()
    for y in range(n):
        for x in range(n):
            if y in (0, n - 1) or x in (0, n - 1):
                g.add_edge("s", (y, x), capacity=float("inf"))
            elif y == x or y + x == n - 1:
                g.add_edge((y, x), "t", capacity=float("inf"))
            if x + 1 < n:
                g.add_edge((y, x), (y, x + 1), capacity=float(wx[y, x]))
                g.add_edge((y, x + 1), (y, x), capacity=float(wx[y, x]))
            if y + 1 < n:
                g.add_edge((y, x), (y + 1, x), capacity=float(wy[y, x]))
                g.add_edge((y + 1, x), (y, x), capacity=float(wy[y, x]))
    return nx.minimum_cut(g, "s", "t")[0]


def test_swang_cut_is_the_minimum_closed_cut(small_exemplar):
    a = np.stack([small_exemplar[:14, :14], small_exemplar[20:34, 5:19]])
    b = np.stack([small_exemplar[40:54, 40:54], small_exemplar[60:74, 30:44]])
    masks, costs = tilesynth.swang_cuts(a, b)
    for k in range(2):
        assert costs[k] == pytest.approx(swang_cut_oracle(a[k], b[k]), rel=1e-9)


def continuity(ts, width, height, seed):
    """(horizontal-border, vertical-border) bool maps: True where the pixel pair across a tile border is
    continuous exemplar content, from the provenance of a synthesis."""
    img, imap = tilesynth.synthesize(ts, width, height, seed=seed)
    src = tilesynth.source_map(ts, imap, width, height)
    ex = ts.exemplar
    np.testing.assert_array_equal(img, ex[src[..., 0], src[..., 1]])
    n = ts.tile_size
    xs = np.arange(n, width, n)
    ys = np.arange(n, height, n)
    # vertical borders x-1 | x: same row, next column
    v_ok = (src[:, xs, 0] == src[:, xs - 1, 0]) & (src[:, xs, 1] == src[:, xs - 1, 1] + 1)
    # horizontal borders y-1 | y: next row, same column
    h_ok = (src[ys, :, 0] == src[ys - 1, :, 0] + 1) & (src[ys, :, 1] == src[ys - 1, :, 1])
    return h_ok, v_ok


@pytest.mark.parametrize("name", ["wang8", "wang18"])
def test_swang_is_continuous_across_every_shared_edge(name, small_exemplar):
    """s-Wang: every pixel pair across a horizontal border and every pair across a vertical border is continuous
    exemplar content, except the two pairs at the ends of each vertical border (the corner pixels, where the
    four samples of a tile corner meet: they belong to the horizontal edges)."""
    ts = tilesynth.build_swang(small_exemplar, tileset=name, tile_size=16, seed=11)
    n = 16
    W, H = n * 9 + 5, n * 7 + 3
    h_ok, v_ok = continuity(ts, W, H, seed=3)
    assert h_ok.all()
    rows = np.arange(H) % n
    inner = (rows != 0) & (rows != n - 1)
    assert v_ok[inner].all()
    assert not v_ok[~inner].all()  # the junction pairs are genuinely different samples
    assert v_ok.sum() + h_ok.sum() >= (1 - 2 / n) * (v_ok.size + h_ok.size)


@pytest.mark.parametrize(
    "kw", [dict(corners="pinned"), dict(samples="square"), dict(corners="pinned", cut="graph")]
)
def test_pinned_wang_tiles_are_continuous_like_swang(kw, small_exemplar):
    ts = tilesynth.build_wang(small_exemplar, tileset="wang18", tile_size=16, seed=4, **kw)
    assert (corner_mismatch(ts.labels) == 0).all()
    n = 16
    h_ok, v_ok = continuity(ts, n * 8, n * 6 + 7, seed=2)
    rows = np.arange(n * 6 + 7) % n
    assert h_ok.all()
    assert v_ok[(rows != 0) & (rows != n - 1)].all()


@pytest.mark.parametrize("cut", ["dp", "graph"])
def test_cohen_tiles_match_along_edges_except_near_corners(cut, small_exemplar):
    """Free corners (Cohen): discontinuities only within w = overlap/2 pixels of a tile corner (the cut may leave
    the tile, or run along its edge, on the last w lines of its band), and corner_mismatch counts exactly the
    wrong edge pixels."""
    n, overlap = 32, 8
    ts = tilesynth.build_wang(small_exemplar, tile_size=n, overlap=overlap, seed=3, cut=cut, corners="free")
    w = overlap // 2
    cm = corner_mismatch(ts.labels)
    assert cm.max() <= 2 * w + 1
    W, H = n * 6, n * 5
    h_ok, v_ok = continuity(ts, W, H, seed=8)
    cols, rows = np.arange(W) % n, np.arange(H) % n
    near_v = (cols <= w) | (cols >= n - 1 - w)
    near_h = (rows <= w) | (rows >= n - 1 - w)
    assert h_ok[:, ~near_v].all()
    assert v_ok[~near_h].all()
    # the edge pixels that show the wrong sample are exactly what corner_mismatch counts
    lab = ts.labels
    wrong = (
        (lab[:, 0] != NORTH).sum()
        + (lab[:, -1] != SOUTH).sum()
        + (lab[:, 1:-1, 0] != WEST).sum()
        + (lab[:, 1:-1, -1] != EAST).sum()
    )
    assert cm.sum() == wrong


def test_corner_mismatch_counts_by_corner():
    lab = np.zeros((1, 8, 8), np.uint8)
    lab[0] = initial_labels(8)
    assert corner_mismatch(lab).tolist() == [[0, 0, 0, 0]]
    lab[0, 0, 6] = EAST  # top edge near the top-right corner
    lab[0, 1, 7] = NORTH  # right edge near the top-right corner
    lab[0, 6, 0] = SOUTH  # left edge near the bottom-left corner
    lab[0, 7, 1] = WEST  # bottom edge near the bottom-left corner
    assert corner_mismatch(lab).tolist() == [[0, 2, 2, 0]]


def test_same_seed_same_tiles_any_threads(small_exemplar):
    for build in (tilesynth.build_wang, tilesynth.build_swang):
        a = build(small_exemplar, tile_size=24, seed=9, threads=1)
        b = build(small_exemplar, tile_size=24, seed=9, threads=2)
        assert a.content_digest() == b.content_digest()
        assert build(small_exemplar, tile_size=24, seed=10).content_digest() != a.content_digest()


def test_round_trip(cohen, swang, tmp_path):
    import json
    import zipfile

    for ts in (cohen, swang):
        p1, p2 = tmp_path / f"{ts.scheme}1.tiles", tmp_path / f"{ts.scheme}2.tiles"
        ts.save(p1)
        back = tilesynth.load(p1)
        assert back.content_digest() == ts.content_digest()
        assert back.scheme == ts.scheme and back.layout == ts.layout and back.params == ts.params
        np.testing.assert_array_equal(back.labels, ts.labels)
        back.save(p2)
        assert p1.read_bytes() == p2.read_bytes()
        with zipfile.ZipFile(p1) as zf:
            names = zf.namelist()
            manifest = json.loads(zf.read("manifest.json"))
        assert "labels.npy" in names
        assert ("cut_stats.npy" in names) == (ts.scheme == "wang")
        assert (
            manifest["format_version"] == 2 and manifest["layout"]["kind"] == "wang"
        )  # stored as provenance
        row = manifest["per_tile"][0]
        assert row["edges"] == "".join(ts.definition.tiles[0])
        if ts.scheme == "wang":
            assert set(row["cuts"]) == {"NE", "ES", "SW", "WN"}
            assert set(row["cuts"]["NE"]) == {
                "D_overlap",
                "n_overlap",
                "D_path",
                "n_path",
                "D_boundary",
                "cost",
            }
        # a synthesis from the loaded file equals the one from memory
        a, _ = tilesynth.synthesize(ts, 90, 70, seed=1)
        b, _ = tilesynth.synthesize(back, 90, 70, seed=1)
        np.testing.assert_array_equal(a, b)


def test_dispatcher(small_exemplar):
    for scheme in tilesynth.SCHEMES:
        ts = tilesynth.build(small_exemplar, scheme=scheme, tile_size=16, seed=1)
        assert ts.scheme == scheme
    with pytest.raises(tilesynth.ParameterError, match="scheme = 'hex'"):
        tilesynth.build(small_exemplar, scheme="hex")


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        (dict(overlap=3), "overlap = 3: must be even"),
        (dict(overlap=0), "overlap = 0"),
        (dict(corners="loose"), "corners = 'loose'"),
        (dict(samples="round"), "samples = 'round'"),
        (dict(cut="magic"), "cut = 'magic'"),
        (dict(samples="square", overlap=4), "square samples"),
        (dict(samples="square", corners="free"), "square samples"),
        (dict(tile_size=90, corners="free"), "sample squares"),
        (dict(tileset="16a"), "unknown Wang tile set"),
        (dict(omega=1.5), "omega"),
        (dict(genes=np.zeros((3, 2), int)), "genes"),
        (dict(genes=np.zeros((4, 2), int), select="ga"), "genes and select"),
        # found by the fuzzers: threads reached the Rust binding unchecked (a bare OverflowError), and eps was
        # converted with float() (ValueError "could not convert string to float", naming nothing)
        (dict(threads=-1), "threads = -1: must be >= 1"),
        (dict(threads=2**64), "threads = 18446744073709551616"),
        (dict(eps="x", cut="graph"), "eps = 'x': must be a number"),
        (dict(select=3), "select = 3: must be one of random, best-of, ga, ais or None"),  # was AttributeError
    ],
)
def test_build_wang_errors(kwargs, words, small_exemplar):
    with pytest.raises(tilesynth.ParameterError, match=words):
        tilesynth.build_wang(small_exemplar, **kwargs)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        (dict(supplementary="best"), "supplementary = 'best'"),
        (dict(supplementary=np.zeros((7, 2), int)), "supplementary has shape"),
        (dict(supplementary=np.full((8, 2), 90)), r"supplementary\[0\]"),
        (dict(gradients="sobel"), "gradients"),
        (dict(tile_size=31), "even"),
        (dict(eps="x"), "eps = 'x': must be a number"),
        (dict(eps=None), "eps = None: must be a number"),
        (dict(select=["ga"]), r"select = \['ga'\]: must be one of"),
    ],
)
def test_build_swang_errors(kwargs, words, small_exemplar):
    with pytest.raises(tilesynth.ParameterError, match=words):
        tilesynth.build_swang(small_exemplar, **kwargs)


def test_build_swang_on_a_tiny_exemplar():
    # found by the fuzzers: the default tile size (4 at least) was not checked against a 1x1 exemplar, and
    # random_genes counted (1 - 4 + 1)^2 = 4 patch positions, so the initial tiles indexed outside it (IndexError)
    from tilesynth.builder.omega import random_genes

    for shape in [(1, 1, 3), (3, 30, 1)]:
        with pytest.raises(tilesynth.ParameterError, match="too small, at least 4x4"):
            tilesynth.build_swang(np.zeros(shape, np.float32))
    with pytest.raises(tilesynth.ParameterError, match="only 0 patch positions, 4 needed"):
        random_genes((1, 1, 3), 4, 4, np.random.default_rng(0))


def test_wang_kernels_check_threads_and_eps():
    """``wang_tiles``, ``WangEvaluator`` (and its ``evaluate``) and ``swang_cuts`` name a bad thread count or eps
    (they passed threads to the binding as given: pyo3's OverflowError for -1, and eps through float())."""
    rng = np.random.default_rng(3)
    ex = rng.random((20, 20, 3), dtype=np.float32)
    wset = get_wang_tileset("wang8")
    genes = np.array([[0, 0], [2, 3], [5, 1], [8, 8]])
    args = (ex, genes, wset.sample_indices(), 8, 2)
    with pytest.raises(tilesynth.ParameterError, match="threads = -1"):
        tilesynth.wang_tiles(*args, threads=-1)
    with pytest.raises(tilesynth.ParameterError, match="threads = 2147483648: must be at most 1024"):
        tilesynth.wang_tiles(*args, threads=2**31)
    with pytest.raises(tilesynth.ParameterError, match="eps = 'x'"):
        tilesynth.wang_tiles(*args, eps="x")
    with pytest.raises(tilesynth.ParameterError, match="eps = None"):
        tilesynth.WangEvaluator(ex, wset.sample_indices(), 4, 8, 2, eps=None)
    ev = tilesynth.WangEvaluator(ex, wset.sample_indices(), 4, 8, 2)
    with pytest.raises(tilesynth.ParameterError, match="threads = -1"):
        ev.evaluate(genes[None], threads=-1)
    with pytest.raises(tilesynth.ParameterError, match="threads = 0"):
        ev.evaluate(genes[None], threads=0)
    tiles = ex[None, :8, :8]
    with pytest.raises(tilesynth.ParameterError, match="eps = '1e-6'"):
        tilesynth.swang_cuts(tiles, tiles, eps="1e-6")


def test_swang_given_and_cut_supplementary(small_exemplar, swang):
    given = tilesynth.build_swang(
        small_exemplar, tile_size=32, genes=swang.genes, supplementary=swang.match_offsets
    )
    np.testing.assert_array_equal(given.tiles, swang.tiles)
    np.testing.assert_allclose(given.D, swang.D, rtol=1e-9)
    assert given.params["supplementary"] == "given"
    by_cut = tilesynth.build_swang(small_exemplar, tile_size=32, genes=swang.genes, supplementary="cut")
    assert (by_cut.cut_costs <= swang.cut_costs + 1e-12).all()
    assert by_cut.params["candidates"] == 8


# --------------------------------------------------------------------------------------------------------------
# Selection


def test_ga_selection_lowers_E(small_exemplar):
    ex = small_exemplar
    rnd = [tilesynth.build_wang(ex, tile_size=32, seed=s).E for s in range(6)]
    ga = tilesynth.build_wang(ex, tile_size=32, seed=1, select="ga", generations=15)
    sel = ga.params["selection"]
    assert sel["method"] == "ga" and sel["params"]["population"] == 50 and sel["params"]["stagnation"] == 8
    assert (
        sel["params"]["alpha"] == 0.05
        and sel["params"]["p_crossover"] == 0.3
        and sel["params"]["p_mutation"] == 0.2
    )
    assert ga.E == pytest.approx(sel["objective_E"], rel=1e-12)
    assert ga.E < np.median(rnd)
    assert len(sel["history"]["best"]) <= 15
    # the default is 001's 200 generations
    from tilesynth.builder.wang import GA_001

    assert GA_001["generations"] == 200 and GA_001["population"] == 50
    best = tilesynth.build_wang(ex, tile_size=32, seed=1, select="best-of", population=20)
    assert best.params["selection"]["evaluations"] == 20
    ais = tilesynth.build_wang(ex, tile_size=32, seed=1, select="ais", generations=3, population=10)
    assert ais.params["selection"]["method"] == "ais"


def test_graph_cut_build_keeps_the_dp_objective(small_exemplar):
    ts = tilesynth.build_wang(
        small_exemplar, tile_size=32, seed=2, select="best-of", population=5, cut="graph"
    )
    dp = tilesynth.build_wang(small_exemplar, tile_size=32, genes=ts.genes)
    assert ts.params["selection"]["objective_E"] == pytest.approx(dp.E, rel=1e-12)
    assert ts.params["cut"] == "graph"


def test_swang_selection(small_exemplar):
    from tilesynth.builder.swang import SwangEvaluator

    ex = small_exemplar
    ts = tilesynth.build_swang(ex, tile_size=32, seed=3, select="best-of", population=6)
    assert ts.E == pytest.approx(ts.params["selection"]["objective_E"], rel=1e-9)
    ev = SwangEvaluator(ex, 32, ts.tile_patches)
    E, D = ev.evaluate(ts.genes[None])
    np.testing.assert_allclose(D[0], ts.D, rtol=1e-9)
