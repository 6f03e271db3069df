"""Fuzzing the public Python API (``tilesynth.__all__``) with careless arrays, parameters and files.

Like ``test_fuzz_core.py`` one level up: every public function is called with random shapes, dtypes, layouts,
values and parameters and must return or raise ``ValueError`` / ``TypeError`` (tilesynth's own errors subclass
them) with a message; ``OverflowError``, a Rust panic or ``InternalError`` fails, and no argument array may
change. The file readers (``load_image``, ``TileSet.load``) get real files cut short or with flipped bytes.
:func:`test_every_public_callable_is_fuzzed` keeps the registry complete.
"""

from __future__ import annotations

import io
import os
import tempfile
import zipfile
from pathlib import Path

import fuzzing
import numpy as np
import pytest
from fuzzing import API_ERRORS, arrays, call_checked, floats, sizes, threads
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

import tilesynth as ts
from tilesynth._validate import as_image

F32, F64, I64, B = "float32", "float64", "int64", "bool"

_CACHE: dict[str, object] = {}


def small_set() -> ts.TileSet:
    """One small tile set, built once (the synthesis and rendering fuzzers draw around it)."""
    if "set" not in _CACHE:
        r = np.random.default_rng(7)
        _CACHE["set"] = ts.build_omega(r.random((24, 24, 3), dtype=np.float32), tileset="8", tile_size=8, seed=1,
                                       exemplar_info={"file": "ex.png", "bits": 8})
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
    return ts.patch_ssd, (img, t), {"mask": d(st.none() | arrays(2, B, t.shape[-3:-1] if t.ndim >= 3 else None)),
                                     "threads": d(threads())}, ()


@st.composite
def best_matches(d: st.DrawFn):
    img = d(exemplars())
    t = d(arrays(d(st.sampled_from([3, 4])), F32, None, max_side=8))
    kw = {"k": d(sizes(-1, 20)), "exclude_radius": d(sizes(-1, 5)), "threads": d(threads()),
          "mask": d(st.none() | arrays(2, B, t.shape[-3:-1] if t.ndim >= 3 else None))}
    return ts.best_matches, (img, t), kw, ()


@st.composite
def ssd_index(d: st.DrawFn):
    return ts.SsdIndex, (d(exemplars()),), {"threads": d(threads())}, ()


@st.composite
def ssd_index_methods(d: st.DrawFn):
    idx = ts.SsdIndex(np.random.default_rng(d(st.integers(0, 9))).random((d(st.integers(1, 20)), 12, 3), dtype=np.float32))
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
    kw = {"source_cap": d(st.none() | arrays(2, F64, hw, hi=5.0)), "sink_cap": d(st.none() | arrays(2, F64, hw))}
    return ts.grid_mincut, (*caps, *masks), kw, ()


@st.composite
def kwatra_weights(d: st.DrawFn):
    shp = (d(st.integers(0, 8)), d(st.integers(0, 8)), d(st.integers(0, 4)))
    a, b = d(arrays(3, F32, shp)), d(arrays(3, "uint8", shp))
    kw = {"region": d(st.none() | arrays(2, B, shp[:2])), "eps": d(floats()),
          "a_grad": d(st.none() | arrays(3, F64, (shp[0], shp[1], 2)))}
    return ts.kwatra_weights, (a, b), kw, ()


@st.composite
def omega_cuts(d: st.DrawFn):
    n = d(st.integers(0, 14))
    shp = (d(st.integers(0, 3)), n, n, d(st.integers(1, 3)))
    kw = {"eps": d(st.just(1e-6) | floats()), "threads": d(threads()), "keep_border": d(st.booleans()),
          "intermediate_grad": d(st.none() | arrays(4, F64, shp[:3] + (2,)))}
    return ts.omega_cuts, (d(arrays(4, F32, shp)), d(arrays(4, F32, shp))), kw, ()


@st.composite
def poisson_smooth(d: st.DrawFn):
    stack = d(st.booleans())
    n, m, c = d(st.integers(0, 14)), d(st.integers(0, 14)), d(st.integers(0, 3))
    shp = ((d(st.integers(0, 3)),) if stack else ()) + (n, m)
    dt = d(st.sampled_from([F32, F64, "uint8", "uint16", "float16", "int32"]))
    dst, src = d(arrays(len(shp) + 1, dt, shp + (c,))), d(arrays(len(shp) + 1, dt, shp + (c,)))
    region = d(arrays(d(st.sampled_from([len(shp), len(shp), 1, 4])), d(st.sampled_from([B, B, "int32", F64])),
                      shp if d(st.booleans()) else (None,) * len(shp)))
    kw = {"tol": d(st.just(1e-6) | floats() | st.sampled_from([1e-13, 1.0, "x", True])), "threads": d(threads()),
          "info": d(st.booleans())}
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
    kw = {"lam": d(st.floats(0, 1) | floats()), "normalise": d(st.booleans()),
          "cache_bytes": d(st.sampled_from([0, 1 << 16]) | sizes(-1, 9))}
    return ts.PopulationEvaluator, (ex, d(st.sampled_from([2, 4, 6]) | sizes()), tp, d(sizes(-1, 5))), kw, ()


@st.composite
def population_evaluate(d: st.DrawFn):
    r = np.random.default_rng(d(st.integers(0, 9)))
    ev = ts.PopulationEvaluator(r.random((16, 15, 2), dtype=np.float32), 4, r.integers(0, 3, (3, 4)), 3)
    genes = d(arrays(3, d(st.sampled_from([I64, "int32", "uint64", F64])), (None, 3, 2), max_side=3, lo=-1, hi=13))
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
    broken = d(st.sampled_from(["none"] * 4 + ["exemplar", "tileset", "tile_size", "seed", "threads", "gradients",
                                               "eps", "select", "genes"]))
    ex = d(exemplars()) if broken == "exemplar" else good_exemplar(d)
    kw = {
        "tileset": d(st.sampled_from(["4", "8", "16a", "32", "B", "n1", "n2"])),
        "tile_size": d(st.sampled_from([None, 4, 6, 8])),
        "seed": d(st.integers(0, 2**64)),
        "threads": d(st.sampled_from([None, 1, 2])),
        "gradients": d(st.sampled_from(["patch", "tile"])),
        "keep_border": d(st.booleans()),
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
            kw["generations"], kw["population"] = d(st.integers(1, 2) if broken != "select" else sizes(-1, 3)), d(small)
        elif method == "best-of":
            kw["population"] = d(small)
        if broken == "select" and d(st.booleans()):
            kw["select"] = d(st.sampled_from(["nope", "", None, 3]))
    if broken == "genes":
        kw.pop("select", None), kw.pop("generations", None), kw.pop("population", None)
        kw["genes"] = d(arrays(2, I64, (None, 2), max_side=6, lo=-1, hi=24))
    return ts.build_omega, (ex,), kw, ()


@st.composite
def synthesize(d: st.DrawFn):
    tset = small_set()
    broken = d(st.sampled_from(["none"] * 4 + ["size", "seed", "dtype", "threads", "max_bytes", "index_map", "out"]))
    w, h = d(st.integers(1, 70)), d(st.integers(1, 70))
    kw: dict = {"seed": d(st.none() | st.integers(0, 2**64)), "dtype": d(st.sampled_from([np.float32, np.uint8,
                                                                                       np.uint16, "uint8"]))}
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
        kw["index_map"] = ts.scanline_index_map(tset.definition, -(-max(h, 1) // n) if isinstance(h, int) and
                                                0 < h < 10**5 else 1, -(-max(w, 1) // n) if isinstance(w, int)
                                                and 0 < w < 10**5 else 1, 3)
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
    name = d(st.sampled_from(["4", "8", "16a", "16b", "32", "B", "n1", "n3", "n16", "n17", "n0", "n01", "", "x"])
             | st.text(max_size=6))
    return ts.get_tileset, (name,), {}, ()


@st.composite
def scanline_index_map(d: st.DrawFn):
    return ts.scanline_index_map, (small_set().definition, d(sizes(-1, 30)), d(sizes(-1, 30))), \
        {"seed": d(st.none() | st.integers(0, 2**32) | st.sampled_from([-1, 0.5]))}, ()


@st.composite
def validate_index_map(d: st.DrawFn):
    tset = small_set()
    return ts.validate_index_map, (tset.definition, d(arrays(2, I64, lo=-1, hi=tset.n_tiles + 1))), {}, ()


def _png_bytes(d: st.DrawFn) -> bytes:
    """A real PNG (8- or 16-bit, several modes), to be cut short or corrupted."""
    h, w = d(st.integers(1, 12)), d(st.integers(1, 12))
    arr = fuzzing.fill((h, w, d(st.sampled_from([1, 2, 3, 4]))), d(st.sampled_from(["uint8", "uint16"])), "unit",
                       d(st.integers(0, 999)))
    buf = io.BytesIO()
    if arr.dtype == np.uint16:
        with tempfile.TemporaryDirectory() as tmp:
            ts.save_image(os.path.join(tmp, "x.png"), arr)
            return Path(tmp, "x.png").read_bytes()
    sq = arr[..., 0] if arr.shape[2] == 1 else arr
    Image.fromarray(sq).save(buf, format=d(st.sampled_from(["PNG", "JPEG", "GIF", "BMP", "TIFF"]))
                             if arr.shape[2] in (1, 3) else "PNG")
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
    arr = d(arrays(d(st.sampled_from([2, 3])), d(st.sampled_from([F32, "uint8", "uint16", F64, "int32"])),
                   (None, None, None), max_side=10))
    name = d(st.sampled_from(["x.png", "x.jpg", "x.tif", "x.bmp", "x.nope", "x", "nodir/x.png"]))
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
                    body = d(st.sampled_from([b"", b"{}", b"[]", b"null", b'{"format": 1}', body[: len(body) // 2],
                                              body.replace(b"0", b"9"), body.replace(b"true", b"false")]))
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


API = {
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
}

NOT_FUZZED = {
    "ParameterError", "ShapeError", "TileSetFormatError", "TilesynthError", "InternalError",  # exception classes
    "TileSet",  # the dataclass; its load and save are fuzzed
    "PoissonInfo",  # a frozen dataclass of results
    "load",  # alias of TileSet.load
}


NOT_YET_FUZZED = {
    # Merged after this harness was written (Wang schemes, metrics and report, maps, 16-bit rasters). Their Rust
    # entry points are fuzzed in test_fuzz_core.py and their bad inputs have tests of their own; a Python-level
    # fuzz strategy for each is still to be written (listed as left out in the issue note).
    "WangEvaluator", "WangTileSet", "build", "build_swang", "build_wang", "coherence_energy", "get_wang_tileset",
    "image_metrics", "load_raster", "seam_score", "swang_cuts", "synthesize_map", "tileset_metrics", "wang_tiles",
    "write_report",
}


def test_every_public_callable_is_fuzzed():
    public = {n for n in ts.__all__ if callable(getattr(ts, n))}
    assert public - NOT_FUZZED - NOT_YET_FUZZED - set(API) == set()
    assert NOT_YET_FUZZED <= public and not NOT_YET_FUZZED & set(API)


@pytest.mark.parametrize("name", sorted(API))
@given(data=st.data())
@settings(max_examples=max(25, settings().max_examples // 2))
def test_public_call_gives_clear_error_or_result_and_mutates_nothing(name, data):
    fuzzing.MODE["tame"] = data.draw(st.booleans(), label="tame")
    fn, args, kwargs, mutable = data.draw(API[name](), label="call")
    call_checked(fn, args, kwargs, API_ERRORS, mutable)
    if name in ("save_image", "TileSet.save"):  # atomic writes: never a partial file left behind
        assert not [f for f in os.listdir(_tmpdir()) if f.endswith(".part")]


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

    from tilesynth.cli import main

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
        for value, command in ((BAD_VALUES[j % len(BAD_VALUES)], "synth"),
                               (BAD_VALUES[(3 * j + 4) % len(BAD_VALUES)], CLI_COMMANDS[j % 3])):
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
