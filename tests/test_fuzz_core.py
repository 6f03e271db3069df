"""Fuzzing every entry point of the compiled extension ``tilesynth._core``.

Each entry of :data:`ENTRY_POINTS` is a hypothesis strategy that draws one call (the callable, its arguments and
which of them the call may write to) with careless inputs: random shapes, dtypes (including big-endian), memory
layouts (Fortran order, strided views, negative strides, read-only), values (NaN, infinities, huge, negative,
denormal) and parameters (zero, negative, beyond ``usize``, wrong type). Every call must either return or raise
``ValueError`` / ``TypeError`` / ``OverflowError`` with a message; a Rust panic (``PanicException`` or
``tilesynth.InternalError``) or a crash fails, and no argument array may change.

**Adding an entry point** to ``_core`` (a function, a class or a method) is one more entry here:
:func:`test_every_core_entry_point_is_fuzzed` fails until it has one. The example count is the hypothesis
profile's (``ci``: 40 per entry point; ``HYPOTHESIS_PROFILE=local`` for 200).
"""

from __future__ import annotations

import inspect
import warnings

import fuzzing
import numpy as np
import pytest
from fuzzing import CORE_ERRORS, arrays, call_checked, floats, sizes, threads
from hypothesis import given
from hypothesis import strategies as st

import tilesynth
from tilesynth import _core

F32, F64, I64, I32, B = "float32", "float64", "int64", "int32", "bool"


def image(max_side: int = 8, channels: int | None = None) -> st.SearchStrategy[np.ndarray]:
    return arrays(3, F32, (None, None, channels), max_side=max_side)


def side(lo: int, hi: int) -> st.SearchStrategy[int]:
    """Mostly small sides, sometimes past the kernels' 16-pixel blocks and the 100 x 100 pixels above which the
    SSD kernel runs in parallel."""
    return st.one_of(
        st.integers(lo, hi),
        st.integers(lo, hi),
        st.integers(lo, hi),
        st.integers(17, 40),
        st.integers(100, 120),
    )


def valid_image(max_side: int = 9, min_side: int = 1) -> st.SearchStrategy[np.ndarray]:
    """A valid float32 image (used where the fuzzing targets a later argument)."""

    @st.composite
    def draw(d: st.DrawFn) -> np.ndarray:
        h, w = d(side(min_side, max_side)), d(side(min_side, max_side))
        c = d(st.integers(1, 3))
        seed = d(st.integers(0, 2**32 - 1))
        return np.random.default_rng(seed).random((h, w, c), dtype=np.float32)

    return draw()


def maybe(strategy: st.SearchStrategy) -> st.SearchStrategy:
    return st.one_of(st.none(), strategy)


# ------------------------------------------------------------------------------------------- entry points
@st.composite
def ssd_index_new(d: st.DrawFn):
    return _core.SsdIndex, (d(image()),), {"threads": d(threads())}, ()


@st.composite
def ssd_index_ssd_maps(d: st.DrawFn):
    img = d(valid_image())
    h, w, c = img.shape
    idx = _core.SsdIndex(img)
    t = d(arrays(4, F32, (d(st.integers(0, 3)), None, None, c), max_side=max(h, w) + 1))
    mask = d(maybe(arrays(2, B, t.shape[1:3] if t.ndim == 4 else None, max_side=max(h, w) + 1)))
    return idx.ssd_maps, (t,), {"mask": mask, "threads": d(threads())}, ()


@st.composite
def ssd_index_best_matches(d: st.DrawFn):
    img = d(valid_image())
    h, w, c = img.shape
    idx = _core.SsdIndex(img)
    t = d(arrays(4, F32, (d(st.integers(0, 3)), None, None, c), max_side=max(h, w) + 1))
    mask = d(maybe(arrays(2, B, t.shape[1:3] if t.ndim == 4 else None, max_side=max(h, w) + 1)))
    kw = {"k": d(sizes(-1, 30)), "exclude_radius": d(sizes(-1, 10)), "mask": mask, "threads": d(threads())}
    return idx.best_matches, (t,), kw, ()


@st.composite
def ssd_index_shape(d: st.DrawFn):
    idx = _core.SsdIndex(d(valid_image()))
    return (lambda: idx.shape), (), {}, ()


@st.composite
def population_new(d: st.DrawFn):
    # one argument (or none) is drawn carelessly, the others are valid, so most calls reach the kernel
    broken = d(
        st.sampled_from(
            ["none", "none", "exemplar", "tile_size", "tile_patches", "n_patches", "lam", "cache"]
        )
    )
    ex = d(arrays(3, F32, (None, None, None), max_side=12)) if broken == "exemplar" else d(valid_image(12, 2))
    side = min(ex.shape[:2]) if ex.ndim == 3 else 2
    n = (
        d(sizes(-2, 14))
        if broken == "tile_size"
        else min(d(st.sampled_from([2, 4, 6])), max(2, side - side % 2))
    )
    n_patches = d(sizes(-1, 6)) if broken == "n_patches" else d(st.integers(1, 5))
    top = n_patches if isinstance(n_patches, int) and 0 < n_patches < 100 else 4
    if broken == "tile_patches":
        tp = d(arrays(2, I64, (None, 4), max_side=5, lo=-1, hi=top + 1))
    else:
        tp = (
            np.random.default_rng(d(st.integers(0, 99)))
            .integers(0, top, (d(st.integers(1, 4)), 4))
            .astype(np.int64)
        )
    lam = d(floats()) if broken == "lam" else d(st.floats(0, 1))
    cache = d(sizes(-1, 10)) if broken == "cache" else d(st.sampled_from([0, 1, 4096, 1 << 20]))
    kw = {"lam": lam, "normalise": d(st.booleans()), "cache_bytes": cache}
    return _core.PopulationEvaluator, (ex, n, tp, n_patches), kw, ()


@st.composite
def _evaluator(d: st.DrawFn):
    ex = d(valid_image(12, min_side=2))
    side = min(ex.shape[:2])
    n = min(d(st.sampled_from([2, 4, 6])), side - side % 2)
    n_patches = d(st.integers(1, 5))
    m = d(st.integers(1, 4))
    tp = np.random.default_rng(d(st.integers(0, 99))).integers(0, n_patches, (m, 4)).astype(np.int64)
    ev = _core.PopulationEvaluator(
        ex, n, tp, n_patches, 0.8, d(st.booleans()), d(st.sampled_from([0, 1 << 16]))
    )
    return ev, ex, n, n_patches


@st.composite
def population_evaluate(d: st.DrawFn):
    ev, ex, n, n_patches = d(_evaluator())
    hi = max(ex.shape[0], ex.shape[1]) - n + 2
    genes = d(arrays(3, I64, (None, n_patches, 2), max_side=4, lo=-1, hi=hi))
    return ev.evaluate, (genes,), {"threads": d(threads())}, ()


@st.composite
def population_cache_stats(d: st.DrawFn):
    ev = d(_evaluator())[0]
    return ev.cache_stats, (), {}, ()


@st.composite
def population_clear_cache(d: st.DrawFn):
    ev = d(_evaluator())[0]
    return ev.clear_cache, (), {}, ()


@st.composite
def population_dims(d: st.DrawFn):
    ev = d(_evaluator())[0]
    return (lambda: ev.dims), (), {}, ()


@st.composite
def grid_mincut(d: st.DrawFn):
    hw = (d(side(0, 7)), d(side(0, 7)))
    cap = st.sampled_from([(0.0, 10.0), (0.0, 1e300), (0.0, 1e-300)])
    lo, hi = d(cap)
    wx, wy = d(arrays(2, F64, hw, lo=lo, hi=hi)), d(arrays(2, F64, hw, lo=lo, hi=hi))
    src, snk = d(arrays(2, B, hw)), d(arrays(2, B, hw))
    if d(st.booleans()) and src.shape == snk.shape and src.dtype == snk.dtype == np.bool_:
        snk = snk & ~src  # mostly disjoint hard masks, so the solver runs
    kw = {
        "source_cap": d(maybe(arrays(2, F64, hw, lo=lo, hi=hi))),
        "sink_cap": d(maybe(arrays(2, F64, hw, lo=lo, hi=hi))),
    }
    return _core.grid_mincut, (wx, wy, src, snk), kw, ()


@st.composite
def grid_mincuts(d: st.DrawFn):
    """A stack of grids sharing one pair of hard masks (the batched free cuts of a chunk of tiles)."""
    khw = (d(side(0, 3)), d(side(0, 6)), d(side(0, 6)))
    lo, hi = d(st.sampled_from([(0.0, 10.0), (0.0, 1e300), (0.0, 1e-300)]))
    wx, wy = d(arrays(3, F64, khw, lo=lo, hi=hi)), d(arrays(3, F64, khw, lo=lo, hi=hi))
    src, snk = d(arrays(2, B, khw[1:])), d(arrays(2, B, khw[1:]))
    if d(st.booleans()) and src.shape == snk.shape and src.dtype == snk.dtype == np.bool_:
        snk = snk & ~src
    kw = {"sink_cap": d(maybe(arrays(3, F64, khw, lo=lo, hi=hi))), "threads": d(threads())}
    return _core.grid_mincuts, (wx, wy, src, snk), kw, ()


@st.composite
def grid_mincut8(d: st.DrawFn):
    """The 8-connected cut: the 4-connected strategy's arguments plus the two diagonal capacity arrays."""
    _, (wx, wy, src, snk), kw, _ = d(grid_mincut())
    hw = wx.shape if getattr(wx, "ndim", 0) == 2 else (d(side(0, 7)), d(side(0, 7)))
    wd = d(arrays(2, F64, hw, lo=0.0, hi=10.0))
    wa = d(arrays(2, F64, hw, lo=0.0, hi=10.0))
    return _core.grid_mincut8, (wx, wy, wd, wa, src, snk), kw, ()


@st.composite
def kwatra_weights(d: st.DrawFn):
    shp = (d(side(0, 7)), d(side(0, 7)), d(st.integers(0, 4)))
    a, b = d(arrays(3, F32, shp)), d(arrays(3, F32, shp))
    kw = {
        "region": d(maybe(arrays(2, B, shp[:2]))),
        "eps": d(floats()),
        "a_grad": d(maybe(arrays(3, F64, (shp[0], shp[1], 2), hi=3.0))),
    }
    return _core.kwatra_weights, (a, b), kw, ()


@st.composite
def omega_cuts(d: st.DrawFn):
    n = d(st.one_of(st.integers(0, 12), st.integers(0, 12), st.integers(13, 48)))
    shp = (d(st.integers(0, 3)), n, n, d(st.integers(1, 3)))
    i, o = d(arrays(4, F32, shp)), d(arrays(4, F32, shp))
    kw = {
        "eps": d(st.one_of(st.just(1e-6), floats())),
        "threads": d(threads()),
        "intermediate_grad": d(maybe(arrays(4, F64, shp[:3] + (2,), hi=3.0))),
        "keep_border": d(st.booleans()),
    }
    return _core.omega_cuts, (i, o), kw, ()


@st.composite
def tile_copy(d: st.DrawFn):
    broken = d(st.sampled_from(["none", "none", "atlas", "index_map", "out", "dtypes"]))
    dt = d(st.sampled_from(["uint8", "uint16", "float32", "int32"]))
    k, th, tw, c = d(st.integers(1, 4)), d(st.integers(1, 5)), d(st.integers(1, 5)), d(st.integers(1, 4))
    if broken == "atlas":
        k, th, tw, c = (d(st.integers(0, 4)) for _ in range(4))
        atlas = d(arrays(4, dt, (k, th, tw, c)))
    else:
        atlas = fuzzing.fill((k, th, tw, c), dt, "unit", d(st.integers(0, 99)))
    h, w = d(st.integers(0, 12)), d(st.integers(0, 12))
    rows, cols = -(-h // max(th, 1)) + d(st.integers(0, 1)), -(-w // max(tw, 1)) + d(st.integers(0, 1))
    if broken == "index_map":
        imap = d(arrays(2, I32, (None, None), lo=-1, hi=k + 1))
    else:
        imap = (
            np.random.default_rng(d(st.integers(0, 99))).integers(0, max(k, 1), (rows, cols)).astype(np.int32)
        )
    out_dt = d(st.sampled_from(["uint8", "float64", ">f4", "int64", "uint16"])) if broken == "dtypes" else dt
    if broken == "out":
        out = d(arrays(3, out_dt, (None, None, c), max_side=12))
    else:
        out = np.zeros((h, w, c), out_dt)
    return _core.tile_copy, (atlas, imap, out), {"threads": d(threads())}, (2,)


@st.composite
def ts_hash_core(d: st.DrawFn):
    n = d(st.integers(0, 6))
    x = d(arrays(1, I32, (n,)))
    y = d(arrays(1, I32, (d(st.sampled_from([n, n, n + 1])),)))
    seed = d(st.one_of(st.integers(0, 2**32 - 1), st.integers(-(2**70), 2**70), floats(), st.none()))
    return _core.ts_hash, (x, y, seed, d(st.integers(0, 2**32 - 1))), {}, ()


@st.composite
def hashed_index_map(d: st.DrawFn):
    kind = d(st.sampled_from(["corner", "edge", "hex"]))
    colours = d(st.lists(st.integers(0, 300), min_size=0, max_size=3))
    seed = d(st.one_of(st.integers(0, 2**32 - 1), st.integers(-(2**40), 2**40)))
    origin = (d(st.integers(-(2**33), 2**33)), d(st.integers(-(2**33), 2**33)))
    size = (d(st.integers(0, 9)), d(st.integers(0, 9)))
    wrap = d(st.one_of(st.none(), st.tuples(st.integers(0, 5), st.integers(0, 5))))
    kw = {"wrap": wrap, "threads": d(threads())}
    return _core.hashed_index_map, (kind, colours, d(st.integers(0, 5)), seed, origin, size), kw, ()


@st.composite
def tile_copy_window(d: st.DrawFn):
    fn, (atlas, imap, out), kw, mutable = d(tile_copy())
    offset = (d(st.integers(0, 6)), d(st.integers(0, 6)))
    return _core.tile_copy_window, (atlas, imap, offset, out), kw, (3,)


def _provenance_source(d: st.DrawFn, eh: int, ew: int) -> np.ndarray:
    """int32 ``(K, N, N, 2)``: tiles of one to three translated pieces inside an ``eh x ew`` exemplar (what a
    pure-copy set holds), or careless coordinates."""
    k, n = d(st.integers(1, 3)), d(st.integers(1, 4))
    yy, xx = np.mgrid[0:n, 0:n]
    src = np.zeros((k, n, n, 2), np.int32)
    rng = np.random.default_rng(d(st.integers(0, 99)))
    for t in range(k):
        for piece in range(d(st.integers(1, 3))):
            by, bx = rng.integers(0, max(eh - n, 0) + 1), rng.integers(0, max(ew - n, 0) + 1)
            part = (yy * n + xx) % (piece + 1) == 0
            src[t, part, 0], src[t, part, 1] = (yy + by)[part], (xx + bx)[part]
    if d(st.booleans()) and not fuzzing.MODE["tame"]:
        src = d(arrays(4, I32, (k, n, n, 2), lo=-3, hi=max(eh, ew) + 3))
    return src


@st.composite
def provenance_factorise(d: st.DrawFn):
    broken = d(st.sampled_from(["none", "none", "shape", "dtype", "orient"]))
    src = _provenance_source(d, 8, 8)
    orient = None
    if broken == "shape":
        src = d(arrays(d(st.integers(0, 5)), I32, None, lo=-2, hi=9))
    elif broken == "dtype":
        src = d(arrays(4, d(st.sampled_from(fuzzing.ALL_DTYPES)), (2, 3, 3, 2), lo=-2, hi=9))
    elif broken == "orient":  # any shape and values, or the right shape with symmetries 0..9
        shape = getattr(src, "shape", (1, 1, 1, 2))[:3] if d(st.booleans()) else None
        orient = d(arrays(3, "uint8", shape, lo=0, hi=9, max_side=5))
    elif d(st.booleans()) and getattr(src, "ndim", 0) == 4:
        orient = np.random.default_rng(d(st.integers(0, 99))).integers(0, 8, src.shape[:3]).astype(np.uint8)
    return _core.provenance_factorise, (src,), {"threads": d(threads()), "orient": orient}, ()


@st.composite
def provenance_gather(d: st.DrawFn):
    broken = d(st.sampled_from(["none", "none", "exemplar", "labels", "table", "index_map", "out", "dtypes"]))
    dt = d(st.sampled_from(["uint8", "uint16", "float32", "int32"]))
    eh, ew, c = d(st.integers(1, 8)), d(st.integers(1, 8)), d(st.integers(1, 3))
    exemplar = fuzzing.fill((eh, ew, c), dt, "unit", d(st.integers(0, 99)))
    src = _provenance_source(d, eh, ew)
    try:  # the careless sources of _provenance_source may not factorise: then a one-pixel set
        with warnings.catch_warnings():  # a careless source (NaN, complex) cast to int32: any value will do
            warnings.simplefilter("ignore")
            src32 = np.ascontiguousarray(src, np.int32)
        got = _core.provenance_factorise(src32)
    except CORE_ERRORS:
        got = None
    if got is None:
        k, n = 1, 1
        labels, table = np.zeros((1, 1, 1), np.uint8), np.zeros((1, 1, 3), np.int32)
    else:
        labels, table = got
        k, n = labels.shape[:2]
    if broken == "exemplar":
        exemplar = d(arrays(d(st.integers(0, 4)), dt, None, max_side=8))
    elif broken == "labels":
        labels = d(arrays(d(st.integers(2, 4)), "uint8", None, lo=0, hi=255, max_side=5))
    elif broken == "table":
        table = d(arrays(d(st.integers(2, 4)), I32, None, lo=-9, hi=12, max_side=5))
    h, w = d(st.integers(0, 9)), d(st.integers(0, 9))
    rows, cols = -(-h // n) + 1, -(-w // n) + 1
    if broken == "index_map":
        imap = d(arrays(2, I32, (None, None), lo=-1, hi=k + 1))
    else:
        imap = np.random.default_rng(d(st.integers(0, 99))).integers(0, k, (rows, cols)).astype(np.int32)
    offset = (d(st.integers(0, n)), d(st.integers(0, n)))
    out_dt = d(st.sampled_from(["uint8", "float64", ">f4", "int64"])) if broken == "dtypes" else dt
    out = (
        d(arrays(3, out_dt, (None, None, c), max_side=9)) if broken == "out" else np.zeros((h, w, c), out_dt)
    )
    kw = {"threads": d(threads()), "turns": _turns(d), "snorm": d(st.booleans())}
    return _core.provenance_gather, (exemplar, labels, table, imap, offset, out), kw, (5,)


def _turns(d: st.DrawFn) -> np.ndarray | None:
    """None, a normal map's vector turns ((8, 2, 2) int8), or careless ones (shape, values)."""
    from tilesynth.builder.matching.augment import vector_turns

    kind = d(st.sampled_from(["none", "up", "down", "bad"]))
    if kind == "none":
        return None
    if kind == "bad":
        return d(arrays(d(st.integers(2, 4)), "int8", None, lo=-2, hi=2, max_side=8))
    return np.ascontiguousarray(vector_turns(kind == "down"), np.int8)


def _seam_blend_call(maps, outs, *rest, **kw):
    """``_core.seam_blend`` with each map's ``out`` drawn apart (the only arrays it may write)."""
    return _core.seam_blend([tuple(m) + (o,) for m, o in zip(maps, outs)], *rest, **kw)


@st.composite
def seam_blend(d: st.DrawFn):
    broken = d(
        st.sampled_from(
            [
                "none",
                "none",
                "none",
                "values",
                "low",
                "mu",
                "table",
                "index_map",
                "out",
                "levels",
                "kind",
                "codes",
            ]
        )
    )
    eh, ew = d(st.integers(1, 8)), d(st.integers(1, 8))
    src = _provenance_source(d, eh, ew)
    try:
        with (
            warnings.catch_warnings()
        ):  # a careless source (NaN, complex, overflow) cast to int32: any value will do
            warnings.simplefilter("ignore")
            src = np.ascontiguousarray(src, np.int32)
        got = _core.provenance_factorise(src)
    except CORE_ERRORS:
        got = None
    labels, table = got if got is not None else (np.zeros((1, 1, 1), np.uint8), np.zeros((1, 1, 3), np.int32))
    k, n = labels.shape[:2]
    low_level = d(st.sampled_from([None, 1.0, 2.5]))
    high, reach = d(st.sampled_from([0.0, 1.0, 3.0])), d(st.sampled_from([1, 2, 4]))
    if broken == "levels":
        high = d(st.sampled_from([-1.0, 9.0, float("nan")]))
        reach = d(st.sampled_from([0, 3, 256, -1]))
        low_level = 2.0
    h, w = d(st.integers(0, 9)), d(st.integers(0, 9))
    maps, outs = [], []
    for _ in range(d(st.integers(0, 3))):
        kind = d(st.sampled_from(["scalar", "normal", "normal-snorm"]))
        c = 3 if kind != "scalar" else d(st.integers(1, 2))
        cv = 2 if kind != "scalar" else c
        dt = d(st.sampled_from(["uint8", "uint16", "float32"]))
        values = None  # a scalar map blends its codes
        if kind != "scalar":
            values = fuzzing.fill(
                (eh, ew, 2), "float64", d(st.sampled_from(fuzzing.VALUE_KINDS)), d(st.integers(0, 99))
            )
        low = None
        if kind == "scalar" and low_level is not None:
            low = fuzzing.fill((eh, ew, cv), "float64", "unit", d(st.integers(0, 99)))
        mu = [0.5] * cv
        codes = fuzzing.fill((eh, ew, c), dt, d(st.sampled_from(fuzzing.VALUE_KINDS)), d(st.integers(0, 99)))
        out = np.zeros((h, w, c), dt)
        if broken == "values":
            values = d(arrays(d(st.integers(0, 4)), "float64", None, max_side=8))
        elif broken == "low":
            low = d(arrays(d(st.integers(0, 4)), "float64", None, max_side=5))
        elif broken == "mu":
            mu = d(st.sampled_from([[], [0.1] * (cv + 1), "x"]))
        elif broken == "kind":
            kind = d(st.sampled_from(["", "Scalar", "normal-unorm", 3]))
        elif broken == "codes":
            codes = d(arrays(d(st.integers(2, 4)), d(st.sampled_from(fuzzing.ALL_DTYPES)), None, max_side=8))
        elif broken == "out":
            out = d(arrays(3, d(st.sampled_from([dt, "float64", ">u2"])), (None, None, None), max_side=9))
        maps.append((kind, values, low, mu, codes))
        outs.append(out)
    if broken == "table":
        table = d(arrays(d(st.integers(2, 4)), I32, None, lo=-9, hi=12, max_side=5))
    rows, cols = -(-h // n) + 1, -(-w // n) + 1
    if broken == "index_map":
        imap = d(arrays(2, I32, (None, None), lo=-1, hi=k + 1))
    else:
        imap = np.random.default_rng(d(st.integers(0, 99))).integers(0, k, (rows, cols)).astype(np.int32)
    most = n - 1 if broken == "none" else n  # an offset of a whole tile is refused
    offset = (d(st.integers(0, most)), d(st.integers(0, most)))
    args = (maps, outs, labels, table, imap, offset, high, low_level, reach)
    turns = d(st.sampled_from([None, "each", "wrong-count"]))
    turns = None if turns is None else [_turns(d) for _ in range(len(maps) + (turns == "wrong-count"))]
    return _seam_blend_call, args, {"threads": d(threads()), "turns": turns}, (1,)


@st.composite
def png_unfilter(d: st.DrawFn):
    rows, row_bytes = d(sizes(-1, 6)), d(sizes(-1, 12))
    bpp = d(st.one_of(st.integers(1, 8), st.integers(1, 8), sizes(-1, 9)))
    n = rows * (row_bytes + 1) if all(isinstance(v, int) and 0 <= v < 100 for v in (rows, row_bytes)) else 7
    n = n + d(st.sampled_from([0, 0, 0, -1, 1])) if n else n
    data = d(arrays(1, "uint8", (max(n, 0),), hi=255.0))
    if data.ndim == 1 and data.dtype == np.uint8 and data.size and d(st.booleans()):
        data = data.copy()
        data[:: max(1, row_bytes + 1 if isinstance(row_bytes, int) and row_bytes >= 0 else 1)] %= (
            5  # valid filter bytes
        )
    return _core.png_unfilter, (data, rows, row_bytes, bpp), {}, ()


@st.composite
def resolve_threads(d: st.DrawFn):
    return _core.resolve_threads, (), {"threads": d(threads())}, ()


@st.composite
def raise_panic(d: st.DrawFn):
    return _core._raise_panic, (d(st.text(max_size=20)),), {}, ()


@st.composite
def edge_weight_sums(d: st.DrawFn):
    shp = (d(side(0, 7)), d(side(0, 7)), d(st.integers(0, 4)))
    t = d(arrays(3, F32, shp))
    img = d(st.one_of(arrays(3, F32, (None, None, shp[2]), max_side=12), image(12)))
    wx, wy = d(arrays(2, B, shp[:2])), d(arrays(2, B, shp[:2]))
    kw = {
        "eps": d(st.one_of(st.just(1e-6), floats())),
        "threads": d(threads()),
        "template_grad": d(maybe(arrays(3, F64, (shp[0], shp[1], 2), hi=3.0))),
    }
    return _core.edge_weight_sums, (t, img, wx, wy), kw, ()


@st.composite
def weighted_ssd_map(d: st.DrawFn):
    img = d(st.one_of(valid_image(10), image(10)))
    hw = img.shape[:2] if img.ndim == 3 else (None, None)
    ig = d(arrays(2, F64, hw, hi=3.0))
    t = d(arrays(3, F32, (d(side(0, 6)), d(side(0, 6)), img.shape[2] if img.ndim == 3 else None)))
    tg = d(arrays(2, F64, t.shape[:2] if t.ndim == 3 else (None, None), hi=3.0))
    return _core.weighted_ssd_map, (img, ig, t, tg, d(floats()), d(floats())), {"threads": d(threads())}, ()


def _wang_options(d: st.DrawFn) -> dict:
    return {
        "corners": d(st.sampled_from(["free", "pinned", "bogus"])),
        "samples": d(st.sampled_from(["diamond", "square", ""])),
        "cut": d(st.sampled_from(["dp", "graph", "x"])),
        "omega": d(st.one_of(st.just(0.8), floats())),
        "eps": d(st.one_of(st.just(1e-6), floats())),
    }


@st.composite
def wang_tiles(d: st.DrawFn):
    ex = d(st.one_of(valid_image(30, 4), image(30)))
    n = d(st.integers(-1, 12))
    genes = d(arrays(2, I64, (None, 2), lo=-2, hi=20))
    tile_samples = d(arrays(2, I64, (None, 4), lo=-1, hi=4))
    kw = _wang_options(d) | {"threads": d(threads())}
    return _core.wang_tiles, (ex, genes, tile_samples, n, d(st.integers(-1, 6))), kw, ()


@st.composite
def wang_evaluator_new(d: st.DrawFn):
    ex = d(st.one_of(valid_image(30, 4), image(30)))
    tile_samples = d(arrays(2, I64, (None, 4), lo=-1, hi=4))
    args = (ex, tile_samples, d(st.integers(-1, 5)), d(st.integers(-1, 12)), d(st.integers(-1, 6)))
    return _core.WangEvaluator, args, _wang_options(d), ()


def _wang_evaluator(d: st.DrawFn):
    ex = np.random.default_rng(d(st.integers(0, 99))).random((24, 24, 3), dtype=np.float32)
    tile_samples = np.array([[0, 1, 2, 3], [1, 0, 3, 2]], np.int64)
    return _core.WangEvaluator(ex, tile_samples, 4, 8, 2)


@st.composite
def wang_evaluator_evaluate(d: st.DrawFn):
    ev = _wang_evaluator(d)
    genes = d(arrays(3, I64, (None, None, 2), lo=-2, hi=20, max_side=5))
    return ev.evaluate, (genes,), {"threads": d(threads())}, ()


@st.composite
def wang_evaluator_dims(d: st.DrawFn):
    return (lambda ev: ev.dims), (_wang_evaluator(d),), {}, ()


@st.composite
def swang_cuts(d: st.DrawFn):
    n = d(st.one_of(st.integers(0, 12), st.integers(13, 40)))
    shp = (d(st.integers(0, 3)), n, n, d(st.integers(1, 3)))
    i, o = d(arrays(4, F32, shp)), d(arrays(4, F32, shp))
    kw = {
        "eps": d(st.one_of(st.just(1e-6), floats())),
        "threads": d(threads()),
        "initial_grad": d(maybe(arrays(4, F64, shp[:3] + (2,), hi=3.0))),
    }
    return _core.swang_cuts, (i, o), kw, ()


@st.composite
def poisson_smooth(d: st.DrawFn):
    n = d(st.one_of(st.integers(0, 12), st.integers(0, 12), st.integers(13, 70)))
    m = d(st.one_of(st.just(n), st.integers(0, 40)))
    shp = (d(st.integers(0, 3)), n, m, d(st.integers(0, 3)))
    dst, src = d(arrays(4, F32, shp)), d(arrays(4, F32, shp))
    region = d(arrays(3, B, shp[:3]))
    kw = {"tol": d(st.one_of(st.just(1e-6), floats())), "threads": d(threads())}
    return _core.poisson_smooth, (dst, src, region), kw, ()


def _mutated(d: st.DrawFn, data: bytes) -> bytes:
    """``data`` intact, cut short, with a few bytes replaced, or garbage."""
    how = d(st.sampled_from(["intact", "cut", "flip", "flip", "garbage"]))
    if how == "cut":
        return data[: d(st.integers(0, len(data)))]
    if how == "flip" and data:
        b = bytearray(data)
        for _ in range(d(st.integers(1, 4))):
            b[d(st.integers(0, len(b) - 1))] = d(st.integers(0, 255))
        return bytes(b)
    if how == "garbage":
        return d(st.binary(max_size=80))
    return data


@st.composite
def png_encode(d: st.DrawFn):
    dt = d(st.sampled_from(["uint8", "uint16", "uint8", "float32", "int64"]))
    arr = d(arrays(d(st.sampled_from([3, 3, 2, 4])), dt, (None, None, None), max_side=9))
    level = d(st.sampled_from(["fast", "default", "best", "max", ""]))
    return _core.png_encode, (arr, level), {"threads": d(threads())}, ()


@st.composite
def png_decode(d: st.DrawFn):
    h, w, c = d(st.integers(1, 9)), d(st.integers(1, 9)), d(st.integers(1, 4))
    arr = np.random.default_rng(d(st.integers(0, 99))).integers(0, 256, (h, w, c)).astype(np.uint8)
    if d(st.booleans()):
        arr = arr.astype(np.uint16) * 257
    data = _mutated(d, _core.png_encode(arr))
    return _core.png_decode, (data, d(st.sampled_from([1 << 30, 1 << 30, 10, 0]))), {}, ()


@st.composite
def exr_encode(d: st.DrawFn):
    arr = d(
        arrays(
            d(st.sampled_from([3, 3, 2])),
            d(st.sampled_from([F32, F32, F64, "uint8"])),
            (None, None, None),
            max_side=7,
        )
    )
    return _core.exr_encode, (arr,), {"half": d(st.booleans())}, ()


@st.composite
def exr_decode(d: st.DrawFn):
    h, w, c = d(st.integers(1, 6)), d(st.integers(1, 6)), d(st.integers(1, 5))
    arr = np.random.default_rng(d(st.integers(0, 99))).random((h, w, c)).astype(np.float32)
    data = _mutated(d, _core.exr_encode(arr, d(st.booleans())))
    return _core.exr_decode, (data, d(st.sampled_from([1 << 30, 1 << 30, 4]))), {}, ()


@st.composite
def patch_gradients(d: st.DrawFn):
    img = d(image())
    src = d(arrays(2, I64, (None, d(st.sampled_from([2, 2, 2, 1, 3])))))
    tame = img.ndim == 3 and img.shape[0] and img.shape[1] and src.ndim == 2 and src.dtype == np.int64
    if d(st.booleans()) and tame and src.shape[1] == 2:
        src = np.abs(src) % np.array(img.shape[:2], np.int64)  # mostly in range: exercise the kernel itself
    return _core.patch_gradients, (img, src), {}, ()


def _quadrant_templates(d: st.DrawFn, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(quads, templates, assign)``: K templates made of a few distinct quadrants (as the intermediate tiles
    of a complete set are), each template's [TL, TR, BL, BR] among them."""
    nq, k = d(st.integers(1, 3)), d(st.integers(1, 4))
    hq, wq = d(st.integers(1, 3)), d(st.integers(1, 3))
    quads = fuzzing.fill((nq, hq, wq, c), F32, "unit", d(st.integers(0, 99)))
    assign = np.random.default_rng(d(st.integers(0, 99))).integers(0, nq, (k, 4)).astype(np.int64)
    t = np.zeros((k, 2 * hq, 2 * wq, c), np.float32)
    for u in range(k):
        for j, (y, x) in enumerate(((0, 0), (0, wq), (hq, 0), (hq, wq))):
            t[u, y : y + hq, x : x + wq] = quads[assign[u, j]]
    return quads, t, assign


@st.composite
def quadrant_map(d: st.DrawFn):
    img = d(valid_image())
    idx = _core.SsdIndex(img)
    c = img.shape[2]
    quad = d(arrays(3, F32, (None, None, c), max_side=max(img.shape[:2]) + 1))
    return _core.quadrant_map, (idx, quad), {"threads": d(threads())}, ()


@st.composite
def best_matches_quadrants(d: st.DrawFn):
    broken = d(st.sampled_from(["none", "none", "quads", "maps", "bounds", "templates", "assign", "k"]))
    img = d(valid_image())
    idx = _core.SsdIndex(img)
    quads, t, assign = _quadrant_templates(d, img.shape[2])
    try:  # the maps of valid quadrants (a quadrant larger than the image has none: a one-pixel stand-in)
        got = [_core.quadrant_map(idx, q) for q in quads]
        maps = np.stack([m for m, _, _ in got])
        bounds, maxes = [b for _, b, _ in got], [m for _, _, m in got]
    except CORE_ERRORS:
        maps, bounds, maxes = np.zeros((len(quads), 1, 1), np.float32), [0.0] * len(quads), [0.0] * len(quads)
    if broken == "quads":
        quads = d(arrays(4, F32, None, max_side=4))
    elif broken == "maps":
        maps = d(arrays(3, F32, None, max_side=6))
    elif broken == "bounds":
        bounds = d(st.lists(floats(), max_size=4))
    elif broken == "templates":
        t = d(arrays(4, F32, (None, None, None, img.shape[2]), max_side=6))
    elif broken == "assign":
        assign = d(arrays(2, I64, (None, 4), lo=-2, hi=len(quads) + 2))
    kw = {"k": d(sizes(-1, 6)) if broken == "k" else d(st.integers(1, 4)), "exclude_radius": d(sizes(-1, 3))}
    kw["threads"] = d(threads())
    return _core.best_matches_quadrants, (idx, quads, maps, bounds, maxes, t, assign), kw, ()


@st.composite
def best_matches_sorting(d: st.DrawFn):
    fn, (t,), kw, mut = d(ssd_index_best_matches())
    return _core._best_matches_sorting, (fn.__self__, t), kw, mut


ENTRY_POINTS = {
    "SsdIndex": ssd_index_new,
    "SsdIndex.shape": ssd_index_shape,
    "SsdIndex.ssd_maps": ssd_index_ssd_maps,
    "SsdIndex.best_matches": ssd_index_best_matches,
    "PopulationEvaluator": population_new,
    "PopulationEvaluator.evaluate": population_evaluate,
    "PopulationEvaluator.cache_stats": population_cache_stats,
    "PopulationEvaluator.clear_cache": population_clear_cache,
    "PopulationEvaluator.dims": population_dims,
    "grid_mincut": grid_mincut,
    "grid_mincut8": grid_mincut8,
    "grid_mincuts": grid_mincuts,
    "kwatra_weights": kwatra_weights,
    "omega_cuts": omega_cuts,
    "tile_copy": tile_copy,
    "png_unfilter": png_unfilter,
    "png_encode": png_encode,
    "png_decode": png_decode,
    "exr_encode": exr_encode,
    "exr_decode": exr_decode,
    "resolve_threads": resolve_threads,
    "edge_weight_sums": edge_weight_sums,
    "weighted_ssd_map": weighted_ssd_map,
    "wang_tiles": wang_tiles,
    "WangEvaluator": wang_evaluator_new,
    "WangEvaluator.evaluate": wang_evaluator_evaluate,
    "WangEvaluator.dims": wang_evaluator_dims,
    "swang_cuts": swang_cuts,
    "poisson_smooth": poisson_smooth,
    "ts_hash": ts_hash_core,
    "hashed_index_map": hashed_index_map,
    "tile_copy_window": tile_copy_window,
    "patch_gradients": patch_gradients,
    "_best_matches_sorting": best_matches_sorting,
    "provenance_factorise": provenance_factorise,
    "provenance_gather": provenance_gather,
    "seam_blend": seam_blend,
    "quadrant_map": quadrant_map,
    "best_matches_quadrants": best_matches_quadrants,
}
"""Entry point name -> strategy of one call ``(callable, args, kwargs, indices of writable args)``."""

NOT_FUZZED = {"_raise_panic"}
"""Tested on its own below: it panics on purpose."""


def core_entry_points() -> set[str]:
    """Every public function, class and method/property of ``_core``."""
    names: set[str] = set()
    for name, obj in vars(_core).items():
        if name.startswith("__") or not callable(obj):
            continue
        names.add(name)
        if inspect.isclass(obj):
            names.update(f"{name}.{m}" for m in vars(obj) if not m.startswith("__"))
    return names


def test_every_core_entry_point_is_fuzzed():
    assert core_entry_points() - NOT_FUZZED == set(ENTRY_POINTS)


@pytest.mark.parametrize("name", sorted(ENTRY_POINTS))
@given(data=st.data())
def test_core_entry_point_never_panics_nor_mutates(name, data):
    fuzzing.MODE["tame"] = data.draw(st.booleans(), label="tame")
    fn, args, kwargs, mutable = data.draw(ENTRY_POINTS[name](), label="call")
    call_checked(fn, args, kwargs, CORE_ERRORS, mutable)


def test_a_panic_becomes_internal_error():
    """Defence in depth: a panic anywhere under a binding comes out as a clear InternalError, not as
    ``pyo3_runtime.PanicException`` (a BaseException that ``except Exception`` would not catch)."""
    with pytest.raises(
        tilesynth.InternalError, match=r"internal error in _raise_panic: boom .*report"
    ) as info:
        _core._raise_panic("boom")
    assert isinstance(info.value, RuntimeError) and isinstance(info.value, tilesynth.TilesynthError)
    # the extension is still usable afterwards
    assert _core.resolve_threads(2) == 2
