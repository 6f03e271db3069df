"""Fuzzing the public Python API (``tilesynth.__all__``) with careless arrays, parameters and files.

Like ``test_fuzz_core.py`` one level up: every public function is called with random shapes, dtypes, layouts,
values and parameters and must return or raise ``ValueError`` / ``TypeError`` (tilesynth's own errors subclass
them) with a message; ``OverflowError``, a Rust panic or ``InternalError`` fails, and no argument array may
change. The file readers (``load_image``, ``load_raster``, ``TileSet.load``) get real files cut short or with
flipped bytes; the writers (``save_image``, ``TileSet.save``, ``write_report``) bad paths, and must leave no
temporary file. :func:`test_every_public_callable_is_fuzzed` keeps the registry complete: every public callable
is in ``API`` or, with its reason, in ``NOT_FUZZED``.
"""

from __future__ import annotations

import io
import os
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import fuzzing
import numpy as np
import pytest
from fuzzing import API_ERRORS, arrays, call_checked, choices, floats, sizes, threads
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

import tilesynth as ts
from tilesynth.base.validate import as_image
from tilesynth.cli import batch as ts_batch

F32, F64, I64, B = "float32", "float64", "int64", "bool"

_CACHE: dict[str, object] = {}


def small_set() -> ts.TileSet:
    """One small tile set, built once (the synthesis and rendering fuzzers draw around it)."""
    if "set" not in _CACHE:
        r = np.random.default_rng(7)
        _CACHE["set"] = ts.build_omega(
            r.random((24, 24, 3), dtype=np.float32),
            tileset="8",
            tile_size=8,
            seed=1,
            exemplar_info={"file": "ex.png", "bits": 8},
        )
    return _CACHE["set"]  # type: ignore[return-value]


def exemplars() -> st.SearchStrategy[np.ndarray]:
    """Exemplars: valid small images most of the time, careless arrays otherwise."""

    @st.composite
    def draw(d: st.DrawFn) -> np.ndarray:
        if d(st.integers(0, 3)):
            h, w, c = d(st.integers(1, 24)), d(st.integers(1, 24)), d(st.integers(1, 4))
            dt = d(st.sampled_from([F32, F64, "uint8", "uint16", ">f4", "float16", "bool"]))
            a = fuzzing.fill((h, w, c), dt, "unit", d(st.integers(0, 2**32 - 1)))
            return fuzzing.relayout(a, d(st.sampled_from(fuzzing.LAYOUTS)))
        return d(arrays(3, F32, (None, None, None), max_side=24))

    return draw()


# ------------------------------------------------------------------------------------------- entry points
@st.composite
def as_image_call(d: st.DrawFn):
    return as_image, (d(arrays(d(st.sampled_from([2, 3])), d(st.sampled_from(fuzzing.ALL_DTYPES)))),), {}, ()


@st.composite
def patch_ssd(d: st.DrawFn):
    img = d(exemplars())
    t = d(arrays(d(st.sampled_from([3, 4])), F32, None, max_side=8))
    return (
        ts.patch_ssd,
        (img, t),
        {
            "mask": d(st.none() | arrays(2, B, t.shape[-3:-1] if t.ndim >= 3 else None)),
            "threads": d(threads()),
        },
        (),
    )


@st.composite
def best_matches(d: st.DrawFn):
    img = d(exemplars())
    t = d(arrays(d(st.sampled_from([3, 4])), F32, None, max_side=8))
    kw = {
        "k": d(sizes(-1, 20)),
        "exclude_radius": d(sizes(-1, 5)),
        "threads": d(threads()),
        "mask": d(st.none() | arrays(2, B, t.shape[-3:-1] if t.ndim >= 3 else None)),
    }
    return ts.best_matches, (img, t), kw, ()


@st.composite
def ssd_index(d: st.DrawFn):
    return ts.SsdIndex, (d(exemplars()),), {"threads": d(threads())}, ()


@st.composite
def ssd_index_methods(d: st.DrawFn):
    idx = ts.SsdIndex(
        np.random.default_rng(d(st.integers(0, 9))).random((d(st.integers(1, 20)), 12, 3), dtype=np.float32)
    )
    t = d(arrays(d(st.sampled_from([2, 3, 4])), F32, None, max_side=10))
    if d(st.booleans()):
        return idx.ssd, (t,), {"mask": d(st.none() | arrays(2, B)), "threads": d(threads())}, ()
    return idx.best_matches, (t,), {"k": d(sizes(-1, 9)), "exclude_radius": d(sizes(-1, 4))}, ()


@st.composite
def grid_mincut(d: st.DrawFn):
    hw = (d(st.integers(0, 8)), d(st.integers(0, 8)))
    caps = [d(arrays(2, F64, hw, hi=5.0)) for _ in range(2)]
    masks = [d(arrays(2, B, hw)) for _ in range(2)]
    if masks[0].dtype == masks[1].dtype == np.bool_ and masks[0].shape == masks[1].shape and d(st.booleans()):
        masks[1] = masks[1] & ~masks[0]
    kw = {
        "source_cap": d(st.none() | arrays(2, F64, hw, hi=5.0)),
        "sink_cap": d(st.none() | arrays(2, F64, hw)),
    }
    return ts.grid_mincut, (*caps, *masks), kw, ()


@st.composite
def kwatra_weights(d: st.DrawFn):
    shp = (d(st.integers(0, 8)), d(st.integers(0, 8)), d(st.integers(0, 4)))
    a, b = d(arrays(3, F32, shp)), d(arrays(3, "uint8", shp))
    kw = {
        "region": d(st.none() | arrays(2, B, shp[:2])),
        "eps": d(floats()),
        "a_grad": d(st.none() | arrays(3, F64, (shp[0], shp[1], 2))),
    }
    return ts.kwatra_weights, (a, b), kw, ()


@st.composite
def omega_cuts(d: st.DrawFn):
    n = d(st.integers(0, 14))
    shp = (d(st.integers(0, 3)), n, n, d(st.integers(1, 3)))
    kw = {
        "eps": d(st.just(1e-6) | floats()),
        "threads": d(threads()),
        "keep_border": d(st.booleans()),
        "intermediate_grad": d(st.none() | arrays(4, F64, shp[:3] + (2,))),
    }
    return ts.omega_cuts, (d(arrays(4, F32, shp)), d(arrays(4, F32, shp))), kw, ()


@st.composite
def poisson_smooth(d: st.DrawFn):
    stack = d(st.booleans())
    n, m, c = d(st.integers(0, 14)), d(st.integers(0, 14)), d(st.integers(0, 3))
    shp = ((d(st.integers(0, 3)),) if stack else ()) + (n, m)
    dt = d(st.sampled_from([F32, F64, "uint8", "uint16", "float16", "int32"]))
    dst, src = d(arrays(len(shp) + 1, dt, shp + (c,))), d(arrays(len(shp) + 1, dt, shp + (c,)))
    region = d(
        arrays(
            d(st.sampled_from([len(shp), len(shp), 1, 4])),
            d(st.sampled_from([B, B, "int32", F64])),
            shp if d(st.booleans()) else (None,) * len(shp),
        )
    )
    kw = {
        "tol": d(st.just(1e-6) | floats() | st.sampled_from([1e-13, 1.0, "x", True])),
        "threads": d(threads()),
        "info": d(st.booleans()),
    }
    return ts.poisson_smooth, (dst, src, region), kw, ()


@st.composite
def tile_copy(d: st.DrawFn):
    dt = d(st.sampled_from(["uint8", "uint16", F32, "int32"]))
    k, th, tw, c = (d(st.integers(0, 4)) for _ in range(4))
    atlas = d(arrays(4, dt, (k, th, tw, c)))
    imap = d(arrays(2, d(st.sampled_from(["int32", I64, "uint64", F64])), (None, None), lo=-1, hi=k + 1))
    out = np.zeros((d(st.integers(0, 12)), d(st.integers(0, 12)), c), d(st.sampled_from([dt, dt, "float64"])))
    if d(st.integers(0, 4)) == 0:
        out = d(arrays(3, dt))
    return ts.tile_copy, (atlas, imap, out), {"threads": d(threads())}, (2,)


@st.composite
def population_evaluator(d: st.DrawFn):
    ex = d(exemplars())
    tp = d(arrays(2, I64, (None, 4), max_side=4, lo=0, hi=4))
    kw = {
        "lam": d(st.floats(0, 1) | floats()),
        "normalise": d(st.booleans()),
        "cache_bytes": d(st.sampled_from([0, 1 << 16]) | sizes(-1, 9)),
    }
    return ts.PopulationEvaluator, (ex, d(st.sampled_from([2, 4, 6]) | sizes()), tp, d(sizes(-1, 5))), kw, ()


@st.composite
def population_evaluate(d: st.DrawFn):
    r = np.random.default_rng(d(st.integers(0, 9)))
    ev = ts.PopulationEvaluator(r.random((16, 15, 2), dtype=np.float32), 4, r.integers(0, 3, (3, 4)), 3)
    genes = d(
        arrays(3, d(st.sampled_from([I64, "int32", "uint64", F64])), (None, 3, 2), max_side=3, lo=-1, hi=13)
    )
    return ev.evaluate, (genes,), {"threads": d(threads())}, ()


@st.composite
def evaluate_population(d: st.DrawFn):
    r = np.random.default_rng(d(st.integers(0, 9)))
    genes = d(arrays(3, I64, (None, None, 2), max_side=3, lo=0, hi=12))
    return ts.evaluate_population, (d(exemplars()), genes, r.integers(0, 3, (2, 4)), d(sizes(-1, 8))), {}, ()


def good_exemplar(d: st.DrawFn) -> np.ndarray:
    h, w, c = d(st.integers(8, 24)), d(st.integers(8, 24)), d(st.integers(1, 4))
    return np.random.default_rng(d(st.integers(0, 999))).random((h, w, c), dtype=np.float32)


@st.composite
def build_omega(d: st.DrawFn):
    # one argument (or none) drawn carelessly, the others valid, so that most calls build a set
    broken = d(
        st.sampled_from(
            ["none"] * 4
            + ["exemplar", "tileset", "tile_size", "seed", "threads", "gradients", "eps", "select", "genes"]
            + ["mask", "alpha"]
            + ["border_tries"]
            + ["augment"]
        )
    )
    ex = d(exemplars()) if broken == "exemplar" else good_exemplar(d)
    kw = {
        "tileset": d(st.sampled_from(["4", "8", "16a", "32", "B", "n1", "n2"])),
        "tile_size": d(st.sampled_from([None, 4, 6, 8])),
        "seed": d(st.integers(0, 2**64)),
        "threads": d(st.sampled_from([None, 1, 2])),
        "gradients": d(st.sampled_from(["patch", "tile"])),
        "keep_border": d(st.booleans()),
        "smooth": d(st.booleans()),
    }
    if broken == "tileset":
        kw["tileset"] = d(st.sampled_from(["17", "n0", "n999999", "", 8, None]) | st.text(max_size=4))
    elif broken == "tile_size":
        kw["tile_size"] = d(sizes(-2, 26))
    elif broken == "seed":
        kw["seed"] = d(st.sampled_from([-1, 1.5, "1", True]))
    elif broken == "threads":
        kw["threads"] = d(threads())
    elif broken == "gradients":
        kw["gradients"] = d(st.sampled_from(["x", "", None, 1]))
    elif broken == "eps":
        kw["eps"] = d(floats())
    method = d(st.sampled_from([None, "random", "best-of", "ga", "ais"]))
    if method is not None:
        kw["select"] = method
        small = st.integers(2, 4) if broken != "select" else sizes(-1, 4)
        if method in ("ga", "ais"):
            kw["generations"], kw["population"] = (
                d(st.integers(1, 2) if broken != "select" else sizes(-1, 3)),
                d(small),
            )
        elif method == "best-of":
            kw["population"] = d(small)
        if broken == "select" and d(st.booleans()):
            kw["select"] = d(st.sampled_from(["nope", "", None, 3]))
    if broken == "genes":
        kw.pop("select", None), kw.pop("generations", None), kw.pop("population", None)
        kw["genes"] = d(arrays(2, I64, (None, 2), max_side=6, lo=-1, hi=24))
    if broken == "mask":  # a mask of any coverage, sometimes of the wrong shape or dtype
        r = np.random.default_rng(d(st.integers(0, 999)))
        shape = ex.shape[:2] if d(st.booleans()) else (d(st.integers(0, 26)), d(st.integers(0, 26)))
        kw["mask"] = d(
            st.sampled_from(
                [
                    r.random(shape) < d(st.sampled_from([0.0, 0.02, 0.3, 1.0])),
                    r.random(shape).astype(np.float32),
                    np.full(shape, np.nan),
                    np.zeros(shape, np.uint16),
                    "no-such-mask.png",
                ]
            )
        )
    elif broken == "alpha":
        kw["alpha"] = d(st.sampled_from(["auto", "mask", "colour", "color", "", None, 1]))
    kw.update(border_tries_kwargs(d, broken == "border_tries"))
    if broken == "augment":  # flip / rotate augmentation, carelessly drawn
        kw["augment"] = d(st.sampled_from(["mirror", "", None, 1, "All", ["flip"]]))
    elif d(st.booleans()):
        kw["augment"] = d(st.sampled_from(["none", "flip", "rotate", "all"]))
    return ts.build_omega, (ex,), kw, ()


@st.composite
def synthesize(d: st.DrawFn):
    tset = small_set()
    broken = d(
        st.sampled_from(["none"] * 4 + ["size", "seed", "dtype", "threads", "max_bytes", "index_map", "out"])
    )
    w, h = d(st.integers(1, 70)), d(st.integers(1, 70))
    kw: dict = {
        "seed": d(st.none() | st.integers(0, 2**64)),
        "dtype": d(st.sampled_from([np.float32, np.uint8, np.uint16, "uint8"])),
    }
    if broken == "size":
        w, h = d(sizes(-1, 70) | st.just(10**6)), d(sizes(-1, 70) | st.just(10**6))
    elif broken == "seed":
        kw["seed"] = d(st.sampled_from([-1, 0.5, "1"]))
    elif broken == "dtype":
        kw["dtype"] = d(st.sampled_from([np.int8, "float64", "nonsense", None, object]))
    elif broken == "threads":
        kw["threads"] = d(threads())
    elif broken == "max_bytes":
        kw["max_bytes"] = d(sizes(-1, 10**5))
    elif broken == "index_map":
        kw["index_map"] = d(arrays(2, d(st.sampled_from(["int32", I64, F64])), lo=0, hi=tset.n_tiles))
    elif broken == "out":
        kw["out"] = d(arrays(3, d(st.sampled_from([F32, "uint8"])), (None, None, 3), max_side=20))
    if d(st.integers(0, 3)) == 0 and broken != "index_map":  # a valid map of the right size
        n = tset.tile_size
        kw["index_map"] = ts.scanline_index_map(
            tset.definition,
            -(-max(h, 1) // n) if isinstance(h, int) and 0 < h < 10**5 else 1,
            -(-max(w, 1) // n) if isinstance(w, int) and 0 < w < 10**5 else 1,
            3,
        )
    return ts.synthesize, (tset, w, h), kw, ()


@st.composite
def source_map(d: st.DrawFn):
    tset = small_set()
    imap = d(arrays(2, d(st.sampled_from(["int32", I64, F64])), lo=0, hi=tset.n_tiles, max_side=8))
    return ts.source_map, (tset, imap, d(sizes(-1, 40)), d(sizes(-1, 40))), {}, ()


@st.composite
def contact_sheet(d: st.DrawFn):
    kw = {"columns": d(st.none() | sizes(-1, 9)), "show_cuts": d(st.booleans()), "gap": d(sizes(-1, 8))}
    return ts.contact_sheet, (small_set(),), kw, ()


@st.composite
def energy(d: st.DrawFn):
    return ts.energy, (d(arrays(1, F64, lo=0, hi=10)),), {"lam": d(st.floats(0, 1) | floats())}, ()


@st.composite
def get_tileset(d: st.DrawFn):
    name = d(
        st.sampled_from(["4", "8", "16a", "16b", "32", "B", "n1", "n3", "n16", "n17", "n0", "n01", "", "x"])
        | st.text(max_size=6)
    )
    return ts.get_tileset, (name,), {}, ()


@st.composite
def scanline_index_map(d: st.DrawFn):
    # the tile set as a definition, a set name (a name once raised AttributeError), a TileSet or junk
    tset = d(
        st.sampled_from([small_set().definition, "16a", "wang8", "n1x2", "nope", "", None, 3, small_set()])
    )
    return (
        ts.scanline_index_map,
        (tset, d(sizes(-1, 30)), d(sizes(-1, 30))),
        {"seed": d(st.none() | st.integers(0, 2**32) | st.sampled_from([-1, 0.5]))},
        (),
    )


@st.composite
def validate_index_map(d: st.DrawFn):
    tset = small_set()
    which = d(st.sampled_from([tset.definition, tset, "8"]))  # a definition, a TileSet or its name
    return ts.validate_index_map, (which, d(arrays(2, I64, lo=-1, hi=tset.n_tiles + 1))), {}, ()


def _png_bytes(d: st.DrawFn) -> bytes:
    """A real PNG (8- or 16-bit, several modes), to be cut short or corrupted."""
    h, w = d(st.integers(1, 12)), d(st.integers(1, 12))
    arr = fuzzing.fill(
        (h, w, d(st.sampled_from([1, 2, 3, 4]))),
        d(st.sampled_from(["uint8", "uint16"])),
        "unit",
        d(st.integers(0, 999)),
    )
    buf = io.BytesIO()
    if arr.dtype == np.uint16:
        with tempfile.TemporaryDirectory() as tmp:
            ts.save_image(os.path.join(tmp, "x.png"), arr)
            return Path(tmp, "x.png").read_bytes()
    if d(st.integers(0, 5)) == 0:  # an OpenEXR file
        with tempfile.TemporaryDirectory() as tmp:
            ts.save_image(os.path.join(tmp, "x.exr"), arr.astype(np.float32) / 255)
            return Path(tmp, "x.exr").read_bytes()
    sq = arr[..., 0] if arr.shape[2] == 1 else arr
    Image.fromarray(sq).save(
        buf,
        format=d(st.sampled_from(["PNG", "JPEG", "GIF", "BMP", "TIFF"])) if arr.shape[2] in (1, 3) else "PNG",
    )
    return buf.getvalue()


@st.composite
def load_image(d: st.DrawFn):
    data = _png_bytes(d)
    how = d(st.sampled_from(["cut", "flip", "cut", "flip", "garbage", "intact"]))
    if how == "cut":
        data = data[: d(st.integers(0, len(data)))]
    elif how == "flip":
        b = bytearray(data)
        for _ in range(d(st.integers(1, 4))):
            b[d(st.integers(0, len(b) - 1))] = d(st.integers(0, 255))
        data = bytes(b)
    elif how == "garbage":
        data = d(st.binary(max_size=64))
    path = os.path.join(_tmpdir(), "in.img")
    with open(path, "wb") as fh:
        fh.write(data)
    return ts.load_image, (path,), {"max_pixels": d(st.sampled_from([None, None, None, 100, 1000, -1]))}, ()


@st.composite
def save_image(d: st.DrawFn):
    arr = d(
        arrays(
            d(st.sampled_from([2, 3])),
            d(st.sampled_from([F32, "uint8", "uint16", F64, "int32"])),
            (None, None, None),
            max_side=10,
        )
    )
    name = d(st.sampled_from(["x.png", "x.jpg", "x.tif", "x.bmp", "x.exr", "x.nope", "x", "nodir/x.png"]))
    return ts.save_image, (os.path.join(_tmpdir(), name), arr), {"bits": d(st.sampled_from([8, 16, 12]))}, ()


@st.composite
def tileset_load(d: st.DrawFn):
    if "tiles_bytes" not in _CACHE:
        p = os.path.join(_tmpdir(), "good.tiles")
        small_set().save(p)
        _CACHE["tiles_bytes"] = Path(p).read_bytes()
    data: bytes = _CACHE["tiles_bytes"]  # type: ignore[assignment]
    how = d(st.sampled_from(["cut", "flip", "member", "intact"]))
    if how == "cut":
        data = data[: d(st.integers(0, len(data)))]
    elif how == "flip":
        b = bytearray(data)
        for _ in range(d(st.integers(1, 4))):
            b[d(st.integers(0, len(b) - 1))] = d(st.integers(0, 255))
        data = bytes(b)
    elif how == "member":  # rewrite one member with other content (a valid zip, tampered inside)
        zin = zipfile.ZipFile(io.BytesIO(data))
        victim = d(st.sampled_from(zin.namelist()))
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as zout:
            for item in zin.infolist():
                body = zin.read(item)
                if item.filename == victim:
                    body = d(
                        st.sampled_from(
                            [
                                b"",
                                b"{}",
                                b"[]",
                                b"null",
                                b'{"format": 1}',
                                body[: len(body) // 2],
                                body.replace(b"0", b"9"),
                                body.replace(b"true", b"false"),
                            ]
                        )
                    )
                zout.writestr(item, body)
        data = buf.getvalue()
    path = os.path.join(_tmpdir(), "in.tiles")
    with open(path, "wb") as fh:
        fh.write(data)
    return ts.TileSet.load, (path,), {}, ()


@st.composite
def tileset_save(d: st.DrawFn):
    name = d(st.sampled_from(["a.tiles", "nodir/a.tiles", ""]))
    return small_set().save, (os.path.join(_tmpdir(), name),), {"include_timing": d(st.booleans())}, ()


# ------------------------------------------------------------------------------------ Wang schemes and sets
def one_in(d: st.DrawFn, k: int) -> bool:
    """True about once in ``k`` draws."""
    return d(st.sampled_from(range(k))) == 0


def small_sets() -> dict[str, ts.TileSet]:
    """One small set of each scheme (and an ω set with a GA history, for the report's convergence chart)."""
    if "sets" not in _CACHE:
        ex = np.random.default_rng(7).random((24, 24, 3), dtype=np.float32)
        _CACHE["sets"] = {
            "omega": small_set(),
            "omega-ga": ts.build_omega(
                ex, tileset="8", tile_size=8, seed=2, select="ga", generations=2, population=3
            ),
            "wang": ts.build_wang(ex, tile_size=8, seed=1),
            "swang": ts.build_swang(ex, tile_size=8, seed=1),
            "omega-smooth": ts.build_omega(ex, tileset="8", tile_size=8, seed=3, smooth=True),
        }
    return _CACHE["sets"]  # type: ignore[return-value]


def tilesets() -> st.SearchStrategy[Any]:
    """A small tile set of any scheme, sometimes something that is not a tile set."""
    kinds = ["omega", "omega-ga", "wang", "swang", "omega-smooth"]
    return st.sampled_from(kinds * 4 + [None, "x.tiles", 3]).map(
        lambda k: small_sets()[k] if k in kinds else k
    )


COLOURS = ["R", "G", "B", "Y", "C", "M", "", "RR"]


@st.composite
def wang_tileset(d: st.DrawFn):
    """A set from its alphabets and tiles (mostly valid: distinct colours, tiles of them), or from a dict."""
    h: Any = d(st.lists(st.sampled_from("RGB"), min_size=1, max_size=3, unique=True))
    v: Any = d(st.lists(st.sampled_from("YCM"), min_size=1, max_size=3, unique=True))
    edge = st.tuples(st.sampled_from(h), st.sampled_from(v), st.sampled_from(h), st.sampled_from(v)).map(list)
    tiles: Any = d(st.lists(edge, min_size=1, max_size=6, unique_by=tuple))
    broken = d(st.sampled_from(["none", "none", "horizontal", "vertical", "tiles", "tile"]))
    careless = st.sampled_from(["RG", "", [], None, 5, [1, 2], ("R", None), ["R", "R"], ["", "Y"], b"RG"])
    if broken == "horizontal":
        h = d(careless | st.lists(st.sampled_from(COLOURS), max_size=4))
    elif broken == "vertical":
        v = d(careless | st.lists(st.sampled_from(COLOURS), max_size=4))
    elif broken == "tiles":
        tiles = d(st.sampled_from([None, 3, "RYRY", (), [], tiles + tiles[:1]]))
    elif broken == "tile":
        tiles = tiles + [
            d(
                st.sampled_from(
                    [
                        "RYGC",
                        "RY",
                        7,
                        None,
                        b"RYGC",
                        ["R", "Y", "R"],
                        ["R", "Y", "R", "Q"],
                        ["Y", "R", "Y", "R"],
                        [],
                        ["R", "Y", "R", "Y", "R"],
                    ]
                )
            )
        ]
    name = d(st.sampled_from(["w", "", None, 3]))
    if d(st.booleans()):
        extra = (
            {"variants": d(st.sampled_from([(), (0,), (1, 0), (-1,), "0", None, (True,)]))}
            if one_in(d, 4)
            else {}
        )
        return ts.WangTileSet, (name, h, v, tiles), extra, ()
    desc: Any = {
        "kind": d(st.sampled_from(["wang", "wang", "wang", "corner", None])),
        "name": name,
        "horizontal": h,
        "vertical": v,
        "tiles": tiles,
    }
    if one_in(d, 4):  # edge sets with variants, sometimes carelessly drawn
        desc["variants"] = d(
            st.sampled_from(
                [list(range(len(tiles))) if isinstance(tiles, list) else [0], [0], [-1], "01", None, [True]]
            )
        )
    if one_in(d, 4):
        for key in d(st.lists(st.sampled_from(sorted(desc)), min_size=1, max_size=2)):
            desc.pop(key, None)
    if one_in(d, 10):
        desc = d(st.sampled_from([None, [], "wang8", 3]))
    return ts.WangTileSet.from_dict, (desc,), {}, ()


@st.composite
def get_wang_tileset(d: st.DrawFn):
    name = d(
        st.sampled_from(
            [
                "wang8",
                "wang18",
                "wang32",
                "wang128",
                "wang162",
                "wang2",
                "wang9",
                "wang0",
                "wang08",
                "wang",
                "Wang8",
                " wang8",
                "8",
                "",
                "wang" + "1" * 400,
                "wang" + "9" * 5000,
                "wc2x2",  # complete edge sets with variants
                "wc2-3x2",
                "wc2x0",
                "wc2x99999",
            ]
        )
        | st.text(max_size=8)
        | st.sampled_from([None, 8, 8.0, b"wang8", ["wang8"], {"wang8": 1}])
    )
    return ts.get_wang_tileset, (name,), {}, ()


def wang_exemplar(d: st.DrawFn) -> np.ndarray:
    h, w, c = d(st.integers(10, 20)), d(st.integers(10, 20)), d(st.integers(1, 4))
    return np.random.default_rng(d(st.integers(0, 999))).random((h, w, c), dtype=np.float32)


def select_kwargs(d: st.DrawFn, broken: bool) -> dict:
    """``select`` with tiny populations (any method), or careless selection parameters when ``broken``."""
    kw: dict = {}
    method = d(st.sampled_from([None, None, "random", "best-of", "ga", "ais"]))
    if method is None:
        return kw
    kw["select"] = method
    small = sizes(-1, 4) if broken else st.integers(2, 3)
    if method in ("ga", "ais"):
        kw["generations"], kw["population"] = d(sizes(-1, 3) if broken else st.integers(1, 2)), d(small)
    elif method == "best-of":
        kw["population"] = d(small)
    if broken and d(st.booleans()):
        kw["select"] = d(st.sampled_from(["nope", "", None, 3, "GA", "best_of"]))
    if broken and d(st.booleans()):
        kw["polish"] = d(st.booleans())
    return kw


@st.composite
def build_wang(d: st.DrawFn):
    # one argument (or none) drawn carelessly, the others valid, so that most calls build a set
    broken = d(
        st.sampled_from(
            ["none"] * 4
            + [
                "exemplar",
                "tileset",
                "tile_size",
                "overlap",
                "corners",
                "samples",
                "cut",
                "seed",
                "threads",
                "omega",
                "eps",
                "select",
                "genes",
                "border_tries",
            ]
        )
    )
    ex = d(exemplars()) if broken == "exemplar" else wang_exemplar(d)
    samples = d(st.sampled_from(["diamond", "diamond", "square"]))
    kw: dict = {
        "tileset": d(st.sampled_from(["wang8", "wang8", "wang18"])),
        "tile_size": d(st.sampled_from([None, 4, 6, 8])),
        "samples": samples,
        "cut": d(st.sampled_from(["dp", "graph"])),
        "seed": d(st.integers(0, 2**64)),
        "threads": d(st.sampled_from([None, 1, 2])),
    }
    if samples == "diamond":
        kw["overlap"] = d(st.sampled_from([None, 2]))
        kw["corners"] = d(st.sampled_from([None, "free", "pinned"]))
    if broken == "tileset":
        kw["tileset"] = d(
            st.sampled_from(
                ["wang9", "wang0", "", "8", "16a", 8, None, ["wang8"], "wang" + "1" * 400, "wc2x2"]
            )
            | st.text(max_size=5)
            | st.just(ts.get_wang_tileset("wang8"))
        )
    elif broken == "tile_size":
        kw["tile_size"] = d(sizes(-2, 26))
    elif broken == "overlap":
        kw["overlap"] = d(sizes(-2, 12))
    elif broken == "corners":
        kw["corners"] = d(st.sampled_from(["x", "", "FREE", 1, ["free"]]))
    elif broken == "samples":
        kw["samples"] = d(st.sampled_from(["x", "", "Square", None, 1]))
    elif broken == "cut":
        kw["cut"] = d(st.sampled_from(["x", "", "DP", None, 1]))
    elif broken == "seed":
        kw["seed"] = d(st.sampled_from([-1, 1.5, "1", True, 2**64 + 1]))
    elif broken == "threads":
        kw["threads"] = d(threads())
    elif broken == "omega":
        kw["omega"] = d(floats() | st.sampled_from([1.5, -0.1, True, np.float32(0.5)]))
    elif broken == "eps":
        kw["eps"] = d(floats())
        kw["cut"] = d(st.sampled_from(["graph", "graph", "dp"]))
    kw.update(select_kwargs(d, broken == "select"))
    if broken == "genes":
        for key in ("select", "generations", "population"):
            kw.pop(key, None)
        kw["genes"] = d(arrays(2, I64, (None, 2), max_side=8, lo=-1, hi=20))
    kw.update(border_tries_kwargs(d, broken == "border_tries"))
    return ts.build_wang, (ex,), kw, ()


@st.composite
def predicted_border_seam_call(d: st.DrawFn):
    """tilesynth.builder.genes.wang_borders.predicted_border_seam: valid genes of a small exemplar, or one argument careless."""
    from tilesynth.builder.genes.wang_borders import predicted_border_seam

    broken = d(
        st.sampled_from(["none", "none", "exemplar", "genes", "n_horizontal", "tile_size", "sample_size"])
    )
    ex = d(exemplars()) if broken == "exemplar" else wang_exemplar(d)
    n = d(st.sampled_from([2, 4, 6, 8]))
    p = n + d(st.sampled_from([0, 0, 2]))
    k = d(st.integers(2, 6))
    rng = np.random.default_rng(d(st.integers(0, 999)))
    shape = np.shape(ex)
    rows = max(shape[0] - p + 1, 1) if len(shape) >= 2 else 1
    cols = max(shape[1] - p + 1, 1) if len(shape) >= 2 else 1
    genes = np.stack([rng.integers(0, rows, k), rng.integers(0, cols, k)], axis=1).astype(np.int64)
    nh = d(st.integers(1, k - 1))
    if broken == "genes":
        genes = d(
            arrays(2, I64, (None, 2), max_side=8, lo=-1, hi=20) | st.sampled_from([None, "x", [[1, 2]]])
        )
    elif broken == "n_horizontal":
        nh = d(sizes(-2, 8))
    elif broken == "tile_size":
        n = d(sizes(-2, 12))
    elif broken == "sample_size":
        p = d(sizes(-2, 24))
    return predicted_border_seam, (ex, genes, nh, n, p), {}, ()


@st.composite
def predicted_corner_border_seam_call(d: st.DrawFn):
    """tilesynth.builder.genes.omega_borders.predicted_corner_border_seam: valid genes of a small exemplar, or one argument
    careless."""
    from tilesynth.builder.genes.omega_borders import predicted_corner_border_seam

    broken = d(st.sampled_from(["none", "none", "exemplar", "genes", "tile_size"]))
    ex = d(exemplars()) if broken == "exemplar" else good_exemplar(d)
    n = d(st.sampled_from([4, 6, 8]))
    k = d(st.integers(1, 5))
    rng = np.random.default_rng(d(st.integers(0, 999)))
    shape = np.shape(ex)
    rows = max(shape[0] - n + 1, 1) if len(shape) >= 2 else 1
    cols = max(shape[1] - n + 1, 1) if len(shape) >= 2 else 1
    genes = np.stack([rng.integers(0, rows, k), rng.integers(0, cols, k)], axis=1).astype(np.int64)
    if broken == "genes":
        genes = d(
            arrays(2, I64, (None, 2), max_side=8, lo=-1, hi=20) | st.sampled_from([None, "x", [[1, 2]]])
        )
    elif broken == "tile_size":
        n = d(sizes(-2, 12))
    return predicted_corner_border_seam, (ex, genes, n), {}, ()


def border_tries_kwargs(d: st.DrawFn, broken: bool) -> dict:
    """``border_tries`` of the Wang, ω and patch schemes: often left out, else valid, or carelessly drawn."""
    if broken:
        return {"border_tries": d(st.sampled_from([0, -1, 1.5, True, "8", None, 4097, 2**70, np.int64(0)]))}
    return d(st.sampled_from([{}, {}, {"border_tries": 1}, {"border_tries": d(st.integers(1, 40))}]))


@st.composite
def build_swang(d: st.DrawFn):
    broken = d(
        st.sampled_from(
            ["none"] * 4
            + [
                "exemplar",
                "tileset",
                "tile_size",
                "supplementary",
                "candidates",
                "seed",
                "threads",
                "eps",
                "gradients",
                "select",
                "genes",
                "border_tries",
            ]
        )
    )
    ex = d(exemplars()) if broken == "exemplar" else wang_exemplar(d)
    kw: dict = {
        "tileset": d(st.sampled_from(["wang8", "wang8", "wang18"])),
        "tile_size": d(st.sampled_from([None, 4, 6, 8])),
        "supplementary": d(st.sampled_from(["ssd", "ssd", "cut"])),
        "candidates": d(st.integers(1, 4)),
        "seed": d(st.integers(0, 2**64)),
        "threads": d(st.sampled_from([None, 1, 2])),
        "gradients": d(st.sampled_from(["patch", "tile"])),
    }
    if broken == "tileset":
        kw["tileset"] = d(
            st.sampled_from(["wang9", "", "16a", 8, None, ["wang8"], "wc2x2"]) | st.text(max_size=5)
        )
    elif broken == "tile_size":
        kw["tile_size"] = d(sizes(-2, 26))
    elif broken == "supplementary":
        k = 18 if kw["tileset"] == "wang18" else 8
        kw["supplementary"] = d(
            st.sampled_from(["x", "", "SSD", None, 3])
            | arrays(2, I64, (d(st.sampled_from([k, k, k - 1])), 2), lo=-1, hi=16)
            | arrays(2, F64, (k, 2), hi=8)
        )
    elif broken == "candidates":
        kw["supplementary"] = "cut"
        kw["candidates"] = d(sizes(-1, 600))
    elif broken == "seed":
        kw["seed"] = d(st.sampled_from([-1, 1.5, "1", True]))
    elif broken == "threads":
        kw["threads"] = d(threads())
    elif broken == "eps":
        kw["eps"] = d(floats())
    elif broken == "gradients":
        kw["gradients"] = d(st.sampled_from(["x", "", None, 1]))
    kw.update(select_kwargs(d, broken == "select"))
    if broken == "genes":
        for key in ("select", "generations", "population"):
            kw.pop(key, None)
        kw["genes"] = d(arrays(2, I64, (None, 2), max_side=8, lo=-1, hi=16))
    kw.update(border_tries_kwargs(d, broken == "border_tries"))
    return ts.build_swang, (ex,), kw, ()


@st.composite
def build_patch(d: st.DrawFn):
    """The patch baseline: valid calls (any SPEC 7 seed) or one careless argument; any select but random is refused."""
    broken = d(st.sampled_from(["none"] * 4 + ["exemplar", "tileset", "tile_size", "seed", "threads", "gradients",
                                               "eps", "select", "genes", "border_tries"]))  # fmt: skip
    ex = d(exemplars()) if broken == "exemplar" else good_exemplar(d)
    seed = d(st.integers(0, 2**64))
    kw: dict = {
        "tileset": d(st.sampled_from(["4", "8", "16a", "16bx2", "n1"])),
        "tile_size": d(st.sampled_from([None, 4, 6, 8])),
        "seed": d(st.sampled_from([seed, np.random.SeedSequence(seed), None])),
        "threads": d(st.sampled_from([None, 1, 2])),
        "gradients": d(st.sampled_from(["patch", "tile"])),
        "keep_border": d(st.booleans()),
    }
    if broken == "tileset":
        kw["tileset"] = d(st.sampled_from(["17", "wang8", "", 8, None]) | st.text(max_size=4))
    elif broken == "tile_size":
        kw["tile_size"] = d(sizes(-2, 26))
    elif broken == "seed":
        kw["seed"] = d(st.sampled_from([-1, 1.5, "1", True, np.random.PCG64(1)]))
    elif broken == "threads":
        kw["threads"] = d(threads())
    elif broken == "gradients":
        kw["gradients"] = d(st.sampled_from(["x", "", None, 1]))
    elif broken == "eps":
        kw["eps"] = d(floats())
    kw.update(select_kwargs(d, broken == "select"))
    if broken == "genes":
        for key in ("select", "generations", "population"):
            kw.pop(key, None)
        kw["genes"] = d(arrays(2, I64, (None, 2), max_side=6, lo=-1, hi=24))
    kw.update(border_tries_kwargs(d, broken == "border_tries"))
    return ts.build_patch, (ex,), kw, ()


@st.composite
def build(d: st.DrawFn):
    """The dispatcher: a call of one of the builders' strategies, through ``build(scheme=...)``."""
    strategies = {"omega": build_omega, "wang": build_wang, "swang": build_swang, "patch": build_patch}
    scheme = d(st.sampled_from(sorted(strategies)))
    _, args, kw, mutable = d(strategies[scheme]())
    if one_in(d, 5):  # an unknown scheme, or the kwargs of another scheme
        scheme = d(st.sampled_from(["Omega", "", None, 1, "wang", "swang", "omega"]))
    return ts.build, args, {"scheme": scheme, **kw}, mutable


def wang_kernel_args(d: st.DrawFn) -> tuple[np.ndarray, dict]:
    """An exemplar and the geometry / cut parameters of the Wang kernels, one of them (or none) careless."""
    broken = d(
        st.sampled_from(
            ["none"] * 3 + ["exemplar", "tile_size", "overlap", "corners", "samples", "cut", "omega", "eps"]
        )
    )
    ex = d(exemplars()) if broken == "exemplar" else wang_exemplar(d)
    samples = d(st.sampled_from(["diamond", "diamond", "square"]))
    kw = {
        "tile_size": d(st.sampled_from([4, 4, 6, 8])),
        "overlap": d(st.sampled_from([2, 2, 4])),
        "corners": d(st.sampled_from(["free", "pinned"])) if samples == "diamond" else "pinned",
        "samples": samples,
        "cut": d(st.sampled_from(["dp", "graph"])),
        "omega": d(st.floats(0, 1)),
        "eps": d(st.just(1e-6) | st.floats(1e-9, 1.0)),
    }
    if broken in ("tile_size", "overlap"):
        kw[broken] = d(st.sampled_from([0, 2, 3, 5, 30]) | sizes(-1, 12))
    elif broken in ("corners", "samples", "cut"):
        kw[broken] = d(
            choices(
                {"corners": ["free", "pinned"], "samples": ["square", "diamond"], "cut": ["graph", "dp"]}[
                    broken
                ]
            )
        )
    elif broken == "omega":
        kw["omega"] = d(floats() | st.sampled_from([1.5, -0.1, True, np.float32(0.5)]))
    elif broken == "eps":
        kw["eps"] = d(floats())
    return ex, kw


@st.composite
def wang_tiles(d: st.DrawFn):
    ex, kw = wang_kernel_args(d)
    n, ov = kw.pop("tile_size"), kw.pop("overlap")
    # genes mostly inside the exemplar (so that many calls reach the cuts), tile samples naming them
    side = min(ex.shape[:2]) if ex.ndim == 3 else 4
    reach = side - (n + ov if isinstance(n, int) and isinstance(ov, int) and 0 <= n + ov < 99 else 0)
    genes = d(arrays(2, I64, (None, 2), max_side=6, lo=d(st.sampled_from([0, 0, -1])), hi=max(reach, 1)))
    tile_samples = d(
        arrays(
            2,
            I64,
            (d(st.integers(0, 8)), 4),
            lo=d(st.sampled_from([0, 0, -1])),
            hi=max(genes.shape[0] - 1, 1) if genes.ndim else 2,
        )
    )
    return ts.wang_tiles, (ex, genes, tile_samples, n, ov), {**kw, "threads": d(threads())}, ()


@st.composite
def wang_evaluator(d: st.DrawFn):
    ex, kw = wang_kernel_args(d)
    n, ov = kw.pop("tile_size"), kw.pop("overlap")
    n_samples = d(st.integers(1, 6) | sizes(-1, 6))
    hi = n_samples - 1 if isinstance(n_samples, int) and 1 < n_samples < 99 else 1
    tile_samples = d(arrays(2, I64, (None, 4), max_side=8, lo=d(st.sampled_from([0, 0, -1])), hi=hi))
    return ts.WangEvaluator, (ex, tile_samples, n_samples, n, ov), kw, ()


@st.composite
def wang_evaluate(d: st.DrawFn):
    r = np.random.default_rng(d(st.integers(0, 9)))
    s = ts.get_wang_tileset("wang8")
    ev = ts.WangEvaluator(
        r.random((16, 15, 2), dtype=np.float32),
        s.sample_indices(),
        s.n_samples,
        8,
        2,
        corners=d(st.sampled_from(["free", "pinned"])),
        cut=d(st.sampled_from(["dp", "graph"])),
    )
    genes = d(
        arrays(
            3,
            d(st.sampled_from([I64, "int32", "uint64", F64])),
            (None, s.n_samples, 2),
            max_side=3,
            lo=-1,
            hi=8,
        )
    )
    return ev.evaluate, (genes,), {"threads": d(threads())}, ()


@st.composite
def swang_cuts(d: st.DrawFn):
    n = d(st.integers(0, 14))
    shp = (d(st.integers(0, 3)), n, n, d(st.integers(1, 3)))
    kw = {
        "eps": d(st.just(1e-6) | floats()),
        "threads": d(threads()),
        "initial_grad": d(st.none() | arrays(4, F64, shp[:3] + (2,))),
    }
    return ts.swang_cuts, (d(arrays(4, F32, shp)), d(arrays(4, F32, shp))), kw, ()


# ----------------------------------------------------------------------------------------------- metrics
@st.composite
def seam_score(d: st.DrawFn):
    return ts.seam_score, (d(exemplars()),), {"tile_size": d(sizes(-2, 30))}, ()


def coherence_kwargs(d: st.DrawFn) -> dict:
    return {
        "patch": d(st.sampled_from([2, 3, 4, 8]) | sizes(-1, 30)),
        "stride": d(st.sampled_from([1, 2, 4]) | sizes(-1, 30)),
        "threads": d(threads()),
    }


@st.composite
def coherence_energy(d: st.DrawFn):
    img, ex = d(exemplars()), d(exemplars())
    kw = coherence_kwargs(d)
    how = d(st.sampled_from(["none", "none", "none", "same", "other", "junk"]))
    if how == "same":  # a crop of the exemplar: exact copies, then searched patches
        if ex.ndim == 3 and 0 not in ex.shape and ex.dtype == np.float32 and d(st.booleans()):
            img = np.ascontiguousarray(ex[: max(1, ex.shape[0] - 3), 1:])
        try:
            kw["index"] = ts.SsdIndex(ex)
        except (ValueError, TypeError):  # not an image: no index (the call refuses the exemplar anyway)
            kw["index"] = None
    elif how == "other":
        kw["index"] = ts.SsdIndex(
            np.random.default_rng(1).random((12, 10, d(st.integers(1, 3))), dtype=np.float32)
        )
    elif how == "junk":
        kw["index"] = d(st.sampled_from([3, "index", ex]))
    return ts.coherence_energy, (img, ex), kw, ()


@st.composite
def image_metrics(d: st.DrawFn):
    img = d(exemplars())
    kw: dict = {
        "tile_size": d(st.none() | sizes(-2, 12)),
        "exemplar": d(st.none() | exemplars()),
        **coherence_kwargs(d),
    }
    if d(st.booleans()):
        sh = img.shape[:2] if img.ndim >= 2 and d(st.booleans()) else (None, None)
        kw["source"] = d(
            arrays(
                3,
                d(st.sampled_from(["int32", I64, "uint64", "int8", F64])),
                sh + (2,),
                lo=-1,
                hi=30,
                max_side=24,
            )
        )
    return ts.image_metrics, (img,), kw, ()


def sample_sizes(d: st.DrawFn, broken: bool) -> tuple[Any, Any]:
    """Sample sizes: small (the metrics cost O(W·H) patch searches), or careless (refused before any work)."""
    if broken:
        return d(sizes(-1, 70)), d(sizes(-1, 70))
    return d(st.integers(8, 40)), d(st.integers(8, 40))


@st.composite
def tileset_metrics(d: st.DrawFn):
    tset = d(tilesets())
    broken = d(st.sampled_from(["none"] * 3 + ["size", "seed", "patch", "threads", "index_map"]))
    w, h = sample_sizes(d, broken == "size")
    kw: dict = {
        "seed": d(st.integers(0, 2**64)) if broken != "seed" else d(st.sampled_from([-1, 0.5, "1", None])),
        "patch": d(st.sampled_from([4, 8])),
        "stride": d(st.sampled_from([4, 8])),
    }
    if broken == "patch":
        kw.update(coherence_kwargs(d))
    elif broken == "threads":
        kw["threads"] = d(threads())
    elif broken == "index_map":
        n_tiles = tset.n_tiles if isinstance(tset, ts.TileSet) else 8
        kw["index_map"] = d(arrays(2, d(st.sampled_from(["int32", I64, F64])), lo=0, hi=n_tiles, max_side=8))
    return ts.tileset_metrics, (tset, w, h), kw, ()


# ------------------------------------------------------------------------------------------------ report
REPORT_DIRS = ["rep", "rep", "rep/a/b", "existing-dir", "a-file", "a-file/sub", "nul\0dir"]


@st.composite
def write_report(d: st.DrawFn):
    tset = d(tilesets())
    broken = d(st.sampled_from(["none"] * 4 + ["size", "seed", "threads", "name", "out_dir"]))
    w, h = sample_sizes(d, True) if broken == "size" else (d(st.integers(8, 48)), d(st.integers(8, 48)))
    where = d(st.sampled_from(REPORT_DIRS)) if broken == "out_dir" else "rep"
    base = _tmpdir()
    os.makedirs(os.path.join(base, "existing-dir"), exist_ok=True)
    Path(base, "a-file").touch()
    out_dir: Any = os.path.join(base, where)
    if broken == "out_dir" and one_in(d, 4):
        out_dir = d(st.sampled_from([None, 3, Path(base, "rep-path")]))
    kw: dict = {
        "seed": d(st.integers(0, 2**64)) if broken != "seed" else d(st.sampled_from([-1, 0.5, "1", None])),
        "borders": d(st.booleans()),
    }
    if broken == "threads":
        kw["threads"] = d(threads())
    kw["name"] = (
        d(st.sampled_from([None, "x.tiles", "<b>&", 5, b"x", ["x"]]))
        if broken == "name"
        else d(st.sampled_from([None, "x.tiles"]))
    )
    return ts.write_report, (tset, out_dir, w, h), kw, ()


# -------------------------------------------------------------------------------------------------- maps
# ------------------------------------------------------------------------------------- hashed lookup (12)
def complete_set() -> ts.TileSet:
    """A small complete set (hashed lookup), built once."""
    if "complete" not in _CACHE:
        r = np.random.default_rng(8)
        _CACHE["complete"] = ts.build_omega(
            r.random((24, 24, 3), dtype=np.float32), tileset="c2x2", tile_size=8, seed=1
        )
    return _CACHE["complete"]  # type: ignore[return-value]


@st.composite
def synthesize_hashed(d: st.DrawFn):
    tset = d(st.sampled_from([complete_set(), small_set()]))
    w, h = d(st.integers(1, 40) | sizes(-1, 40)), d(st.integers(1, 40) | sizes(-1, 40))
    big = st.integers(-(2**40), 2**40)
    origin = d(
        st.tuples(big | st.integers(-100, 100), big | st.integers(-100, 100))
        | st.just((0, 0))
        | st.sampled_from([(1,), "0,0", (0.5, 0), None])
    )
    kw = {
        "seed": d(st.none() | st.integers(-1, 2**33)),
        "origin": origin,
        "wrap": d(st.booleans() | st.sampled_from([1, "yes", None])),
        "dtype": d(st.sampled_from([np.float32, np.uint8, np.uint16])),
    }
    return ts.synthesize, (tset, w, h), kw, ()


@st.composite
def lookup_scheme_call(d: st.DrawFn):
    kind = d(st.sampled_from(["corner", "edge", "hex", 3]))
    colours = d(st.lists(st.integers(-2, 300) | st.sampled_from([1.5, "2", True]), max_size=3))
    return (
        ts.LookupScheme,
        (kind, tuple(colours), d(st.integers(-1, 5) | st.sampled_from([2.5, None]))),
        {},
        (),
    )


@st.composite
def ts_hash_call(d: st.DrawFn):
    x = d(
        st.integers(-(2**32), 2**32)
        | arrays(d(st.integers(1, 2)), d(st.sampled_from([I64, "int32", F64, "uint64"])))
    )
    y = d(st.integers(-(2**32), 2**32) | arrays(1, d(st.sampled_from([I64, "int32"]))))
    seed = d(st.integers(-1, 2**33) | st.sampled_from([None, 1.0, "1"]))
    return ts.ts_hash, (x, y, seed, d(st.integers(-1, 2**33))), {}, ()


@st.composite
def hashed_index_map_call(d: st.DrawFn):
    scheme = d(
        st.sampled_from([ts.LookupScheme("corner", (3,), 2), ts.LookupScheme("edge", (2, 3)), "corner"])
    )
    size = d(
        st.tuples(sizes(-1, 12), sizes(-1, 12))
        | st.sampled_from([(3,), None, "3x3"])
        # no cells, one side numpy cannot make (these once crashed with SIGSEGV, seeds 114 / 118)
        | st.sampled_from([(0, 2**63 - 1), (2**62, 0), (0, 2**64), (2**31, 0)])
    )
    origin = d(st.tuples(st.integers(-(2**33), 2**33), st.integers(-(2**33), 2**33)) | st.just((0, 0)))
    wrap = d(st.none() | st.tuples(st.integers(-1, 5), st.integers(-1, 5)) | st.just(True))
    seed = d(st.integers(-1, 2**33))
    return (
        ts.hashed_index_map,
        (scheme, seed, size),
        {"origin": origin, "wrap": wrap, "threads": d(threads())},
        (),
    )


@st.composite
def repetition_measures(d: st.DrawFn):
    fn = d(st.sampled_from([ts.periodic_copies, ts.detail_repetition, ts.repeated_patches]))
    return fn, (d(exemplars()),), {}, ()


@st.composite
def inner_seam_call(d: st.DrawFn):
    kw = {"tile_size": d(sizes(-2, 30))}
    if d(st.booleans()):
        kw["depths"] = d(st.one_of(st.tuples(sizes(-1, 20)), st.lists(sizes(-1, 20), max_size=3).map(tuple)))
    return ts.inner_seam_score, (d(exemplars()),), kw, ()


@st.composite
def histogram_distance_call(d: st.DrawFn):
    return ts.histogram_distance, (d(exemplars()), d(exemplars())), {}, ()


@st.composite
def lattice_gradient_call(d: st.DrawFn):
    return ts.lattice_gradient, (d(exemplars()), d(sizes(-2, 12))), {}, ()


@st.composite
def lattice_folded_call(d: st.DrawFn):
    return ts.lattice_folded, (d(exemplars()), d(sizes(-2, 12))), {}, ()


@st.composite
def objects_intact_call(d: st.DrawFn):
    polarity = d(st.sampled_from(["auto", "bright", "dark", "grey", None]))
    iou = d(st.sampled_from([0.75, 1.0, 0.3, 0.0, -1, 1.5, float("nan"), "0.5"]))
    return ts.objects_intact, (d(exemplars()), d(exemplars())), {"polarity": polarity, "iou": iou}, ()


@st.composite
def synthesize_map(d: st.DrawFn):
    tset = d(tilesets())
    broken = d(st.sampled_from(["none"] * 3 + ["aligned", "index_map", "size", "threads"]))
    eh, ew = tset.exemplar.shape[:2] if isinstance(tset, ts.TileSet) else (24, 24)
    dt = d(st.sampled_from(["uint8", "uint16", F32]))
    shape = (eh, ew, d(st.integers(1, 4)))[: d(st.sampled_from([2, 3]))]
    aligned = d(arrays(len(shape), dt, shape, wild=0.0))
    if broken == "aligned":
        aligned = d(arrays(len(shape), d(st.sampled_from(fuzzing.ALL_DTYPES)), shape, max_side=24, wild=0.5))
    w, h = sample_sizes(d, broken == "size")
    imap = (
        ts.synthesize(small_set(), 40, 40, seed=1)[1]
        if not isinstance(tset, ts.TileSet)
        else ts.synthesize(tset, 40, 40, seed=d(st.integers(0, 9)))[1]
    )
    if broken == "index_map":
        n_tiles = tset.n_tiles if isinstance(tset, ts.TileSet) else 8
        imap = d(
            st.sampled_from(
                [
                    imap.astype(I64) + 2**32,
                    imap + 0.5,
                    imap - imap.max() - 1,
                    imap[:1, :1],
                    imap.astype("uint64") + 2**63,
                    imap.T.copy(),
                    imap.astype(">i8"),
                    None,
                ]
            )
            | arrays(2, d(st.sampled_from(["int32", I64, F64, "uint8"])), lo=0, hi=n_tiles + 1, max_side=8)
        )
    kw = {"threads": d(threads())} if broken == "threads" else {}
    if d(st.booleans()):
        kw["smooth"] = d(st.sampled_from([None, True, False, "yes", 1]))
    return ts.synthesize_map, (tset, aligned, imap, w, h), kw, ()


def _raster_bytes(d: st.DrawFn) -> tuple[bytes, str]:
    """A real raster file (PNG of any mode and depth, 16-bit / float TIFF, BMP, JPEG, or .npy) and its suffix."""
    kind = d(st.sampled_from(["png", "png16", "tif16", "tif-f", "jpg", "bmp", "npy", "npy", "npy-header"]))
    h, w = d(st.integers(1, 10)), d(st.integers(1, 10))
    seed = d(st.integers(0, 999))
    if kind == "png16":
        return _png_bytes(d), ".png"
    buf = io.BytesIO()
    if kind == "npy":
        a = fuzzing.fill(
            (h, w, d(st.integers(1, 4)))[: d(st.sampled_from([2, 3, 3, 1]))],
            d(st.sampled_from(["uint8", "uint16", F32, F32, F64, ">u2", I64, "bool"])),
            "unit",
            seed,
        )
        np.save(buf, a)
        return buf.getvalue(), ".npy"
    if kind == "npy-header":  # a header that declares more data than the file holds
        shape = d(st.sampled_from([(100000, 100000), (2**31, 2**31), (2**40, 2**40, 3), (5, 5), (0, 3), ()]))
        np.lib.format.write_array_header_1_0(
            buf,
            {
                "descr": d(st.sampled_from(["|u1", "<u2", "<f4", "|O"])),
                "fortran_order": d(st.booleans()),
                "shape": shape,
            },
        )
        return buf.getvalue() + d(st.binary(max_size=16)), ".npy"
    if kind in ("tif16", "tif-f"):
        a = fuzzing.fill((h, w), "uint16" if kind == "tif16" else F32, "unit", seed)
        Image.fromarray(a).save(buf, format="TIFF")
        return buf.getvalue(), ".tif"
    mode = d(st.sampled_from(["L", "RGB", "RGBA", "LA", "P", "1"]))
    fmt = {"png": "PNG", "jpg": "JPEG", "bmp": "BMP"}[kind]
    im = Image.fromarray(fuzzing.fill((h, w, 3), "uint8", "unit", seed)).convert(mode)
    if fmt != "PNG" and mode not in ("L", "RGB"):
        im = im.convert("RGB")
    im.save(buf, format=fmt)
    return buf.getvalue(), "." + kind


@st.composite
def load_raster(d: st.DrawFn):
    data, suffix = _raster_bytes(d)
    how = d(st.sampled_from(["cut", "flip", "cut", "flip", "garbage", "intact", "intact"]))
    if how == "cut":
        data = data[: d(st.integers(0, len(data)))]
    elif how == "flip" and data:
        b = bytearray(data)
        for _ in range(d(st.integers(1, 4))):
            b[d(st.integers(0, len(b) - 1))] = d(st.integers(0, 255))
        data = bytes(b)
    elif how == "garbage":
        data = d(st.binary(max_size=64))
    suffix = d(st.sampled_from([suffix] * 4 + [".npy", ".png", ".tif", ""]))
    path: Any = os.path.join(_tmpdir(), "map" + suffix)
    with open(path, "wb") as fh:
        fh.write(data)
    if one_in(d, 10):
        path = d(st.sampled_from([_tmpdir(), os.path.join(_tmpdir(), "missing.png"), None, 3, "nul\0.png"]))
    return (
        ts.load_raster,
        (path,),
        {"max_pixels": d(st.sampled_from([None, None, None, 30, 1000, -1, "9"]))},
        (),
    )


@pytest.fixture(scope="module", autouse=True)
def _remove_tmpdir():
    yield
    import shutil

    if "tmp" in _CACHE:
        shutil.rmtree(_CACHE.pop("tmp"), ignore_errors=True)


def _tmpdir() -> str:
    if "tmp" not in _CACHE:
        _CACHE["tmp"] = tempfile.mkdtemp(prefix="tilesynth-fuzz-")
    return _CACHE["tmp"]  # type: ignore[return-value]


@st.composite
def export_call(d: st.DrawFn):
    """``tilesynth.export`` on small sets of every scheme, careless parameters and maps."""
    tset = d(tilesets())
    kw: dict = {
        "padding": d(st.integers(0, 9) | st.sampled_from([-1, 300, 1.5, True, None])),
        "bits": d(st.sampled_from([8, 16, 8, 16, 12, None])),
        "lookup": d(st.sampled_from(["auto", "index_map", "hash", "x"])),
        "seed": d(st.integers(0, 2**32 - 1) | st.sampled_from([-1, 2**32, 0.5, "1"])),
        "index_size": d(
            st.none() | st.tuples(sizes(-1, 6), sizes(-1, 6)) | st.sampled_from([(1.5, 2), "4x4", 3])
        ),
        "index_seed": d(st.integers(0, 9) | st.sampled_from([-1, 0.5])),
        "viewer": one_in(d, 6),
    }
    if one_in(d, 4):
        kw["wrap"] = d(st.tuples(sizes(-1, 5), sizes(-1, 5)) | st.sampled_from([3, (2**31, 1)]))
    if one_in(d, 3) and isinstance(tset, ts.TileSet):
        h, w = tset.exemplar.shape[:2]
        shape = d(st.sampled_from([(h, w), (h, w, 1), (h, w, 3), (h, w, 5), (h + 1, w), (0, w)]))
        dtype = d(st.sampled_from(["uint8", "uint16", F32, F64, B]))
        kw["maps"] = {d(st.sampled_from(["normal", "h", "albedo", "bad name", ""])): np.zeros(shape, dtype)}
    elif one_in(d, 8):
        kw["maps"] = d(st.sampled_from(["x", [1], {"a": 3}]))
    return ts.export, (tset, os.path.join(_tmpdir(), "export")), kw, ()


def small_material() -> ts.TileSet:
    """One small material set, built once."""
    if "material" not in _CACHE:
        r = np.random.default_rng(8)
        ex = r.random((24, 24, 3), dtype=np.float32)
        v = r.standard_normal((24, 24, 3)) * 0.2 + [0, 0, 1]
        v /= np.linalg.norm(v, axis=-1, keepdims=True)
        maps = {
            "height": r.random((24, 24), dtype=np.float32),
            "normal": np.round((v * 0.5 + 0.5) * 255).astype(np.uint8),
            "mask": (r.random((24, 24)) > 0.5).astype(np.uint8),
        }
        _CACHE["material"] = ts.build(ex, maps=maps, tileset="8", tile_size=8, seed=1, smooth=True)
    return _CACHE["material"]  # type: ignore[return-value]


@st.composite
def build_material(d: st.DrawFn):
    """Material builds: good maps most of the time, then careless names, arrays, kinds, weights, conventions."""
    ex = d(exemplars()) if d(st.integers(0, 3)) == 0 else np.random.default_rng(1).random((24, 24, 3))
    shape = np.shape(ex)[:2] if np.ndim(ex) >= 2 else (24, 24)
    broken = d(
        st.sampled_from(["none"] * 3 + ["array", "name", "kind", "weight", "normal_y", "maps", "normal"])
    )
    maps: Any = {"height": d(arrays(2, d(st.sampled_from(["uint8", "uint16", F32])), shape, wild=0.0))}
    kw: dict = {"tileset": "8", "tile_size": 8, "seed": 1}
    if broken == "array":
        maps["height"] = d(arrays(d(st.sampled_from([2, 3])), d(st.sampled_from(fuzzing.ALL_DTYPES)), None,
                                  max_side=24, wild=0.5))  # fmt: skip
    elif broken == "name":
        maps[d(st.sampled_from(["", "a/b", "albedo", "Height", "x" * 70, 3, None]))] = maps["height"]
    elif broken == "kind":
        kw["map_kinds"] = d(
            st.sampled_from([{"height": "bump"}, {"height": 3}, {"other": "scalar"}, [1], None])
        )
    elif broken == "weight":
        kw["map_weights"] = d(st.sampled_from([{"height": -1}, {"height": float("nan")}, {"height": "2"},
                                               {"albedo": 0.0, "height": 0.0}, {"height": True}, "x"]))  # fmt: skip
    elif broken == "normal_y":
        kw["normal_y"] = d(st.sampled_from(["+y", None, 1, "UP"]))
    elif broken == "maps":
        maps = d(st.sampled_from([{}, [], "height", None, {"height": None}]))
    elif broken == "normal":
        maps["normal"] = d(
            arrays(3, d(st.sampled_from(["uint8", F32])), (*shape, d(st.integers(1, 4))), wild=0.2)
        )
    return ts.build_material, (ex,), {"maps": maps, **kw}, ()


@st.composite
def synthesize_maps(d: st.DrawFn):
    tset = small_material() if d(st.integers(0, 5)) else d(tilesets())
    broken = d(st.sampled_from(["none"] * 3 + ["index_map", "size", "normal_y", "smooth", "threads"]))
    w, h = d(st.integers(1, 40)), d(st.integers(1, 40))
    imap = ts.synthesize(small_material(), 40, 40, seed=d(st.integers(0, 9)))[1]
    kw: dict = {
        "normal_y": d(st.sampled_from([None, "up", "down"])),
        "smooth": d(st.sampled_from([None, True, False])),
    }
    if broken == "index_map":
        imap = d(st.sampled_from([imap + 0.5, imap - imap.max() - 1, imap[:1, :1], None, imap + 100]))
    elif broken == "size":
        w, h = d(sizes(-1, 70) | st.just(10**6)), d(sizes(-1, 70) | st.just(10**6))
    elif broken == "normal_y":
        kw["normal_y"] = d(st.sampled_from(["+y", 1, "UP"]))
    elif broken == "smooth":
        kw["smooth"] = d(st.sampled_from(["on", 1, 0.5]))
    elif broken == "threads":
        kw["threads"] = d(threads())
    return ts.synthesize_maps, (tset, imap, w, h), kw, ()


API = {
    "export": export_call,
    "as_image": as_image_call,
    "patch_ssd": patch_ssd,
    "best_matches": best_matches,
    "SsdIndex": ssd_index,
    "SsdIndex methods": ssd_index_methods,
    "grid_mincut": grid_mincut,
    "kwatra_weights": kwatra_weights,
    "omega_cuts": omega_cuts,
    "tile_copy": tile_copy,
    "poisson_smooth": poisson_smooth,
    "PopulationEvaluator": population_evaluator,
    "PopulationEvaluator.evaluate": population_evaluate,
    "evaluate_population": evaluate_population,
    "build_omega": build_omega,
    "synthesize": synthesize,
    "source_map": source_map,
    "contact_sheet": contact_sheet,
    "energy": energy,
    "get_tileset": get_tileset,
    "scanline_index_map": scanline_index_map,
    "validate_index_map": validate_index_map,
    "load_image": load_image,
    "save_image": save_image,
    "TileSet.load": tileset_load,
    "TileSet.save": tileset_save,
    "WangTileSet": wang_tileset,
    "get_wang_tileset": get_wang_tileset,
    "build_wang": build_wang,
    "build_swang": build_swang,
    "build_patch": build_patch,
    "build": build,
    "wang_tiles": wang_tiles,
    "WangEvaluator": wang_evaluator,
    "WangEvaluator.evaluate": wang_evaluate,
    "swang_cuts": swang_cuts,
    "seam_score": seam_score,
    "coherence_energy": coherence_energy,
    "image_metrics": image_metrics,
    "tileset_metrics": tileset_metrics,
    "write_report": write_report,
    "synthesize_map": synthesize_map,
    "load_raster": load_raster,
    "synthesize (hashed)": synthesize_hashed,
    "LookupScheme": lookup_scheme_call,
    "ts_hash": ts_hash_call,
    "hashed_index_map": hashed_index_map_call,
    "periodic_copies": repetition_measures,
    "repeated_patches": repetition_measures,
    "detail_repetition": repetition_measures,
    "histogram_distance": histogram_distance_call,
    "lattice_gradient": lattice_gradient_call,
    "lattice_folded": lattice_folded_call,
    "objects_intact": objects_intact_call,
    "predicted_border_seam": predicted_border_seam_call,
    "build_material": build_material,
    "synthesize_maps": synthesize_maps,
    "inner_seam_score": inner_seam_call,
    "predicted_corner_border_seam": predicted_corner_border_seam_call,
}

NOT_FUZZED = {
    "ParameterError",
    "ShapeError",
    "TileSetFormatError",
    "TilesynthError",
    "InternalError",  # exception classes
    "InputWarning",  # a warning class
    "TileSet",  # the dataclass; its load and save are fuzzed
    "PoissonInfo",  # a frozen dataclass of results
    "load",  # alias of TileSet.load
}


def test_every_public_callable_is_fuzzed():
    public = {n for n in ts.__all__ if callable(getattr(ts, n))}
    assert public - NOT_FUZZED - set(API) == set()
    assert NOT_FUZZED <= set(ts.__all__) and not NOT_FUZZED & set(API)


@pytest.mark.parametrize("name", sorted(API))
@given(data=st.data())
@settings(max_examples=max(25, settings().max_examples // 2))
def test_public_call_gives_clear_error_or_result_and_mutates_nothing(name, data):
    fuzzing.MODE["tame"] = data.draw(st.booleans(), label="tame")
    fn, args, kwargs, mutable = data.draw(API[name](), label="call")
    call_checked(fn, args, kwargs, API_ERRORS, mutable)
    if name in (
        "save_image",
        "TileSet.save",
        "write_report",
    ):  # atomic writes: never a partial file left behind
        assert not [f for _, _, files in os.walk(_tmpdir()) for f in files if f.endswith(".part")]


def _manifest_paths(o: object, pre: tuple = ()) -> list[tuple]:
    out = [pre]
    if isinstance(o, dict):
        for k, v in o.items():
            out += _manifest_paths(v, pre + (k,))
    elif isinstance(o, list):
        for i, v in enumerate(o[:3]):
            out += _manifest_paths(v, pre + (i,))
    return out


BAD_VALUES = [None, 1, -1, 1.5, "x", [], {}, [1, 2], {"a": 1}, True]
CLI_COMMANDS = ["info", "info --json", "sheet", "synth"]


def test_cli_on_a_tampered_manifest_exits_0_or_2():
    """Every field of manifest.json (every key, and the first items of lists) replaced in turn by values of
    other types: ``info``, ``info --json``, ``sheet`` and ``synth`` either work or fail as bad input (exit 2,
    one line), never as an internal error (exit 1)."""
    import contextlib
    import json

    from tilesynth.cli.main import main

    good = os.path.join(_tmpdir(), "cli-good.tiles")
    small_set().save(good)
    with zipfile.ZipFile(good) as zf:
        original = zf.read("manifest.json")
        members = {i.filename: zf.read(i) for i in zf.infolist()}
    paths = _manifest_paths(json.loads(original))[1:]
    bad = os.path.join(_tmpdir(), "cli-bad.tiles")
    failures = []
    for j, path in enumerate(paths):
        # every field through synth (which uses the most of the manifest) and through one of the others
        for value, command in (
            (BAD_VALUES[j % len(BAD_VALUES)], "synth"),
            (BAD_VALUES[(3 * j + 4) % len(BAD_VALUES)], CLI_COMMANDS[j % 3]),
        ):
            manifest = json.loads(original)
            o = manifest
            for key in path[:-1]:
                o = o[key]
            o[path[-1]] = value
            with zipfile.ZipFile(bad, "w") as zout:
                for name, data in members.items():
                    zout.writestr(name, json.dumps(manifest).encode() if name == "manifest.json" else data)
            cmd = command.split()
            argv = [cmd[0], bad, *cmd[1:]] + (["-o", bad + ".png"] if cmd[0] in ("sheet", "synth") else [])
            argv += ["--size", "20x20"] if cmd[0] == "synth" else []
            err = io.StringIO()
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                code = main(argv)
            lines = err.getvalue().strip().splitlines()
            if code not in (0, 2) or (code == 2 and len(lines) != 1):
                failures.append((path, value, cmd, code, err.getvalue().strip()[-200:]))
    assert not failures, failures[:5]


# ------------------------------------------------------------------------------------------------- batch files
_BATCH_LEAVES = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-3, 70),
    st.floats(allow_nan=True),
    st.text(max_size=10),
    st.sampled_from(
        [
            "ex.png",
            "*.png",
            "zz*.png",
            "16a",
            "8",
            "wang8",
            "ga",
            "omega",
            "wang",
            "swang",
            "all",
            "32x32",
            "{stem}",
            "{stem.x}",
            "{0}",
            "../x",
            "a/b",
            "best-cut",
            "copy",
            "smooth",
            "p",
        ]
    ),
)
_BATCH_VALUES = st.recursive(
    _BATCH_LEAVES,
    lambda c: (
        st.lists(c, max_size=3)
        | st.dictionaries(
            st.sampled_from(["size", "seed", "bits", "maps", "borders", "n", "p", "ex.png"]), c, max_size=3
        )
    ),
    max_leaves=6,
)


def _batch_table(keys: tuple[str, ...]) -> st.SearchStrategy[dict]:
    return st.dictionaries(st.sampled_from((*keys, "bogus")), _BATCH_VALUES, max_size=5)


@given(
    top=_batch_table(("version", "output_dir", "log")),
    presets=st.dictionaries(
        st.sampled_from(["p", "q"]), _batch_table(ts_batch.schema._PRESET_KEYS), max_size=2
    ),
    jobs=st.lists(
        _batch_table(ts_batch.schema._JOB_KEYS).map(lambda t: {"exemplar": "ex.png", **t}), max_size=3
    ),
    raw=st.booleans(),
)
@settings(max_examples=max(40, settings().max_examples))
def test_batch_file_is_a_library_or_one_batch_error(top, presets, jobs, raw):  # noqa: ANN001
    """Any content of a batch file: a validated Library or a BatchError with a message, nothing else, nothing
    written."""
    d = Path(_tmpdir()) / "batch"
    d.mkdir(exist_ok=True)
    if not (d / "ex.png").exists():
        Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(d / "ex.png")
    data = top if raw else {**top, "presets": presets, "jobs": jobs}
    before = sorted(os.listdir(d))
    try:
        lib = ts_batch.parse_library(data, d, source="fuzz.toml")
    except ts_batch.BatchError as exc:
        assert str(exc).startswith("fuzz.toml") and len(str(exc)) > 20
    else:
        assert lib.jobs and all(j.exemplar.name == "ex.png" for j in lib.jobs)
    assert sorted(os.listdir(d)) == before
