"""Max-flow / min-cut kernel and ω cutting curve: networkx oracle, brute force, and the shared reference."""

from __future__ import annotations

import itertools

import networkx as nx
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tilesynth

INF = float("inf")


def cut_cost(labels, wx, wy, src_cap=None, snk_cap=None):
    c = float(
        (wx[:, :-1] * (labels[:, :-1] != labels[:, 1:])).sum() + (wy[:-1] * (labels[:-1] != labels[1:])).sum()
    )
    if src_cap is not None:
        c += float(src_cap[labels].sum()) + float(snk_cap[~labels].sum())
    return c


def nx_mincut(wx, wy, source, sink, src_cap=None, snk_cap=None) -> float:
    h, w = wx.shape
    g = nx.DiGraph()
    g.add_node("s")
    g.add_node("t")

    def add(u, v, c):
        if c > 0:
            g.add_edge(u, v, capacity=c)

    for y in range(h):
        for x in range(w):
            if x + 1 < w:
                add((y, x), (y, x + 1), wx[y, x])
                add((y, x + 1), (y, x), wx[y, x])
            if y + 1 < h:
                add((y, x), (y + 1, x), wy[y, x])
                add((y + 1, x), (y, x), wy[y, x])
            # an edge without a capacity attribute is infinite in networkx; a hard link absorbs the soft one
            if source[y, x]:
                g.add_edge("s", (y, x))
            elif src_cap is not None:
                add("s", (y, x), src_cap[y, x])
            if sink[y, x]:
                g.add_edge((y, x), "t")
            elif snk_cap is not None:
                add((y, x), "t", snk_cap[y, x])
    return nx.minimum_cut_value(g, "s", "t") if g.number_of_edges() else 0.0


@st.composite
def grid_case(draw):
    h = draw(st.integers(1, 7))
    w = draw(st.integers(1, 7))
    r = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    wx = r.exponential(1.0, (h, w)) * (r.random((h, w)) < 0.9)
    wy = r.exponential(1.0, (h, w)) * (r.random((h, w)) < 0.9)
    wx[:, -1] = 0
    wy[-1] = 0
    lab = r.integers(0, 3, (h, w))
    source, sink = lab == 1, lab == 2
    soft = draw(st.booleans())
    sc = r.exponential(0.5, (h, w)) if soft else None
    kc = r.exponential(0.5, (h, w)) if soft else None
    return wx, wy, source, sink, sc, kc


@given(grid_case())
def test_grid_mincut_matches_networkx(case):
    wx, wy, source, sink, sc, kc = case
    labels, flow = tilesynth.grid_mincut(wx, wy, source, sink, sc, kc)
    ref = nx_mincut(wx, wy, source, sink, sc, kc)
    assert flow == pytest.approx(ref, rel=1e-9, abs=1e-12)
    assert labels.dtype == bool and labels.shape == wx.shape
    assert not labels[source].any() and labels[sink].all()
    assert cut_cost(labels, wx, wy, sc, kc) == pytest.approx(flow, rel=1e-9, abs=1e-12)


def test_grid_mincut_brute_force_tiny():
    r = np.random.default_rng(7)
    for _ in range(30):
        h, w = 3, 4
        wx, wy = r.random((h, w)), r.random((h, w))
        sc, kc = r.random((h, w)) * 0.8, r.random((h, w)) * 0.8
        no = np.zeros((h, w), bool)
        labels, flow = tilesynth.grid_mincut(wx, wy, no, no, sc, kc)
        best = min(
            cut_cost(np.array(bits, bool).reshape(h, w), wx, wy, sc, kc)
            for bits in itertools.product([False, True], repeat=h * w)
        )
        assert flow == pytest.approx(best, rel=1e-9)


def test_reference_flow_mincut80(mincut80):
    d = mincut80
    labels, flow = tilesynth.grid_mincut(d["wx"], d["wy"], ~d["inside"], d["sink_mask"])
    assert flow == pytest.approx(float(d["flow"]), rel=1e-9)
    assert cut_cost(labels, d["wx"], d["wy"]) == pytest.approx(float(d["flow"]), rel=1e-9)
    ref = d["label"].astype(bool)
    # Labels may differ only where minimum cuts tie: the reference labelling is a minimum cut too, and ours puts
    # on the source side exactly the pixels reachable from the source in the residual graph, which is the
    # smallest source set of all minimum cuts, so every pixel the reference gives to the sink is ours too.
    assert cut_cost(ref, d["wx"], d["wy"]) == pytest.approx(float(d["flow"]), rel=1e-9)
    assert not (ref & ~labels).any()


def test_reference_weights_mincut80(mincut80):
    d = mincut80
    wx, wy = tilesynth.kwatra_weights(d["A"], d["B"], region=d["inside"], eps=float(d["eps"]))
    np.testing.assert_allclose(wx, d["wx"], rtol=1e-12, atol=0)
    np.testing.assert_allclose(wy, d["wy"], rtol=1e-12, atol=0)


def test_omega_cut_reproduces_reference(mincut80):
    d = mincut80
    masks, costs = tilesynth.omega_cuts(d["A"][None], d["B"][None], keep_border=False)
    assert costs[0] == pytest.approx(float(d["flow"]), rel=1e-9)
    assert masks.shape == (1, 80, 80)
    assert not masks[0][~d["inside"]].any() and masks[0][d["sink_mask"]].all()


def test_omega_cut_keep_border(mincut80):
    """keep_border (the default): O never reaches the border ring; the cut costs at least the literal one."""
    d = mincut80
    masks, costs = tilesynth.omega_cuts(d["A"][None], d["B"][None])
    m = masks[0]
    assert not (m[0].any() or m[-1].any() or m[:, 0].any() or m[:, -1].any())
    inner_sinks = d["sink_mask"].copy()
    inner_sinks[[0, -1], :] = False
    inner_sinks[:, [0, -1]] = False
    assert m[inner_sinks].all() and not m[~d["inside"]].any()
    assert costs[0] >= float(d["flow"]) * (1 - 1e-9)


def test_maxflow_errors():
    z = np.zeros((3, 3))
    m = np.zeros((3, 3), bool)
    with pytest.raises(tilesynth.ShapeError, match="wy"):
        tilesynth.grid_mincut(z, np.zeros((3, 4)), m, m)
    bad = z.copy()
    bad[0, 0] = -1
    with pytest.raises(tilesynth.ParameterError, match="wx"):
        tilesynth.grid_mincut(bad, z, m, m)
    nan = z.copy()
    nan[1, 1] = np.nan
    with pytest.raises(ValueError, match="wy"):
        tilesynth.grid_mincut(z, nan, m, m)
    both = m.copy()
    both[1, 1] = True
    with pytest.raises(tilesynth.ParameterError):
        tilesynth.grid_mincut(z, z, both, both)


def test_omega_cut_errors():
    a = np.zeros((2, 6, 6, 3), np.float32)
    with pytest.raises(tilesynth.ShapeError, match="matching"):
        tilesynth.omega_cuts(a, np.zeros((2, 8, 8, 3), np.float32))
    with pytest.raises(tilesynth.ShapeError, match="intermediate"):
        tilesynth.omega_cuts(np.zeros((1, 5, 5, 3), np.float32), np.zeros((1, 5, 5, 3), np.float32))


def omega_terminals(n, keep_border):
    """The ω cut's hard pixels (see tilesynth.builder.omega): sources outside the circle (and on the border ring with
    keep_border), sinks on the central cross inside the circle (off the ring with keep_border)."""
    c = (n - 1) / 2.0
    yy, xx = np.mgrid[:n, :n]
    inside = (yy - c) ** 2 + (xx - c) ** 2 <= (n / 2.0) ** 2
    cross = np.zeros((n, n), bool)
    cross[n // 2 - 1 : n // 2 + 1] = True
    cross[:, n // 2 - 1 : n // 2 + 1] = True
    src, snk = ~inside, cross & inside
    if keep_border:
        ring = np.ones((n, n), bool)
        ring[1:-1, 1:-1] = False
        src, snk = src | ring, snk & ~ring
    return inside, src, snk


@pytest.mark.parametrize("seed", range(24))
def test_omega_cuts_are_minimum_cuts_networkx(seed):
    """The ω cut (a shortest path in the planar dual of each quadrant, issue 15) against networkx's max-flow on
    the same weights: equal value, hard constraints kept, and the mask's own cut cost equal to the value. Tiles
    with 8-bit values, flat areas and copied regions give exact ties of equal-cost cuts."""
    r = np.random.default_rng(seed)
    n = int(r.integers(2, 25)) * 2
    keep_border = bool(seed % 2)
    a = np.round(r.random((n, n, 3)) * 255) / 255
    b = np.round(r.random((n, n, 3)) * 255) / 255
    if seed % 3 == 1:
        b[n // 3 :] = a[n // 3 :]  # a copied region: weights exactly 0 there
    elif seed % 3 == 2:
        a[: n // 2, : n // 2] = 0.5  # a flat area: ties
    a, b = a.astype(np.float32), b.astype(np.float32)
    masks, costs = tilesynth.omega_cuts(a[None], b[None], threads=1, keep_border=keep_border)
    inside, src, snk = omega_terminals(n, keep_border)
    wx, wy = tilesynth.kwatra_weights(a, b, region=inside)
    ref = nx_mincut(wx, wy, src, snk)
    mask = masks[0]
    assert costs[0] == pytest.approx(ref, rel=1e-9, abs=1e-12)
    assert not mask[src].any() and mask[snk].all()
    assert cut_cost(mask, wx, wy) == pytest.approx(ref, rel=1e-9, abs=1e-12)


@given(st.integers(0, 4), st.integers(1, 9), st.integers(1, 9), st.integers(0, 2**32 - 1), st.booleans())
def test_grid_mincuts_is_every_grids_grid_mincut_at_any_thread_count(k, h, w, seed, soft):
    """The batched cuts of a chunk of tiles (one pair of hard masks, per-grid weights and sink capacities):
    each grid's labels and flow bit for bit as grid_mincut gives them, with 1 or 3 threads."""
    from tilesynth.base import kernels

    r = np.random.default_rng(seed)
    wx = r.exponential(1.0, (k, h, w)) * (r.random((k, h, w)) < 0.9)
    wy = r.exponential(1.0, (k, h, w)) * (r.random((k, h, w)) < 0.9)
    lab = r.integers(0, 3, (h, w))
    source, sink = lab == 1, lab == 2
    caps = r.exponential(0.5, (k, h, w)) if soft else None
    want = [
        tilesynth.grid_mincut(wx[j], wy[j], source, sink, sink_cap=None if caps is None else caps[j])
        for j in range(k)
    ]
    for threads in (1, 3):
        labels, flows = kernels.grid_mincuts(wx, wy, source, sink, sink_cap=caps, threads=threads)
        assert labels.shape == (k, h, w) and labels.dtype == np.bool_ and flows.shape == (k,)
        for j, (lab_j, flow_j) in enumerate(want):
            assert np.array_equal(labels[j], lab_j) and flows[j] == flow_j


def test_grid_mincuts_names_the_argument_whose_shape_is_wrong():
    from tilesynth.base import kernels

    w = np.ones((2, 4, 5))
    m = np.zeros((4, 5), bool)
    with pytest.raises(tilesynth.ShapeError, match="wy"):
        kernels.grid_mincuts(w, np.ones((2, 4, 4)), m, m)
    with pytest.raises(tilesynth.ShapeError, match="sink_cap"):
        kernels.grid_mincuts(w, w, m, m, sink_cap=np.ones((1, 4, 5)))
    with pytest.raises(tilesynth.ShapeError, match="source_hard"):
        kernels.grid_mincuts(w, w, np.zeros((4, 4), bool), m)
    with pytest.raises(tilesynth.ParameterError, match="wx"):
        kernels.grid_mincuts(-w, w, m, m)
