"""Careless arrays and parameters: the "Arrays" and "Parameters" tables of docs/failure-modes.md.

The random versions of all of these run in the fuzz tests; here each case is pinned down with its exact error
(type, and a message naming the parameter and the value).
"""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.base import kernels
from tilesynth.base.validate import as_image
from tilesynth.cli.main import main


@pytest.fixture(scope="module")
def ex(small_exemplar) -> np.ndarray:
    return small_exemplar[:48, :48]


# ------------------------------------------------------------------------------------------------- arrays
@pytest.mark.parametrize("shape", [(5,), (2, 3, 4, 5), (), (1, 2, 3, 4, 5)])
def test_wrong_ndim(shape):
    with pytest.raises(ts.ShapeError, match=r"image has shape .*expected \(H, W\) or \(H, W, C\)"):
        as_image(np.zeros(shape, np.float32))


@pytest.mark.parametrize("shape", [(0, 5, 3), (5, 0), (4, 4, 0)])
def test_zero_size(shape):
    with pytest.raises(ts.ShapeError, match=r"expected non-empty"):
        as_image(np.zeros(shape, np.float32))
    with pytest.raises(ts.ShapeError):
        ts.build_omega(np.zeros(shape, np.float32))


def layouts(a: np.ndarray) -> dict[str, np.ndarray]:
    big = np.zeros((a.shape[0], 2 * a.shape[1], a.shape[2]), a.dtype)
    big[:, ::2] = a
    ro = a.copy()
    ro.setflags(write=False)
    return {
        "fortran": np.asfortranarray(a),
        "strided": big[:, ::2],
        "negative strides": np.ascontiguousarray(a[::-1, ::-1])[::-1, ::-1],
        "transposed view": np.ascontiguousarray(a.transpose(1, 0, 2)).transpose(1, 0, 2),
        "big-endian": a.astype(a.dtype.newbyteorder(">")),
        "read-only": ro,
    }


@pytest.mark.parametrize(
    "layout", ["fortran", "strided", "negative strides", "transposed view", "big-endian", "read-only"]
)
def test_any_layout_gives_the_same_result(ex, layout):
    """Non-contiguous, negative-stride, Fortran-order, big-endian and read-only arrays are accepted, give the
    same tile set as the plain C-contiguous array, and are not modified."""
    a = layouts(ex)[layout]
    before = a.copy()
    assert not (a.flags.c_contiguous and a.dtype.isnative) or layout == "read-only"
    got = ts.build_omega(a, tileset="4", tile_size=16, seed=3)
    want = ts.build_omega(ex, tileset="4", tile_size=16, seed=3)
    assert got.content_digest() == want.content_digest()
    np.testing.assert_array_equal(a, before)
    out = as_image(a)
    assert out.flags.c_contiguous and out.dtype == np.float32 and out.dtype.isnative


def test_integer_and_float_dtypes():
    u8 = np.array([[0, 51, 255]], np.uint8)
    np.testing.assert_allclose(as_image(u8)[0, :, 0], [0, 0.2, 1])
    np.testing.assert_array_equal(as_image(np.array([[0, 65535]], np.uint16))[0, :, 0], [0, 1])
    np.testing.assert_array_equal(as_image(np.array([[True, False]]))[0, :, 0], [1, 0])
    for dt in (np.float16, np.float32, np.float64, ">f8"):
        out = as_image(np.array([[0.0, 0.5, 1.0]], dt))
        assert out.dtype == np.float32 and out.dtype.isnative
        np.testing.assert_array_equal(out[0, :, 0], [0, 0.5, 1])
    # int64 is what np.array([[0, 255]]) gives: refused, with the way out in the message
    for dt in (np.int8, np.int32, np.int64, np.uint32, np.uint64):
        with pytest.raises(TypeError, match=rf"image has dtype {np.dtype(dt)}, .*astype\(np.uint8\)"):
            as_image(np.zeros((2, 2), dt))
    for bad in (np.zeros((2, 2), np.complex64), np.array([["a", "b"]]), np.array([[None]], object)):
        with pytest.raises(TypeError, match="image has dtype"):
            as_image(bad)
    with pytest.raises(ts.ShapeError, match="not an array"):
        as_image([[0.1, 0.2], [0.3]])  # ragged


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_nan_and_inf(value):
    a = np.full((6, 6, 3), 0.5)
    a[2, 3, 1] = value
    with pytest.raises(ts.ParameterError, match="exemplar contains NaN or infinity"):
        ts.build_omega(a)
    with pytest.raises(ts.ParameterError, match="templates contains NaN or infinity"):
        ts.patch_ssd(np.full((6, 6, 3), 0.5, np.float32), a[1:4, 2:5].astype(np.float32))


@pytest.mark.parametrize("lo, hi", [(-0.25, 0.5), (0.0, 1.5), (0.0, 255.0)])
def test_values_outside_unit_range(lo, hi):
    a = np.linspace(lo, hi, 27).reshape(3, 3, 3).astype(np.float32)
    with pytest.raises(
        ts.ParameterError, match=rf"image has values in \[{lo:g}, {hi:g}\], expected floats in \[0, 1\]"
    ):
        as_image(a)
    # float32 templates are checked too (they used to reach the kernel unchecked)
    with pytest.raises(ts.ParameterError, match="templates has values in"):
        ts.patch_ssd(np.zeros((8, 8, 3), np.float32), a)


def test_rust_receives_only_validated_contiguous_arrays(ex, monkeypatch):
    """Every array that reaches tilesynth._core from a public call made with careless inputs is C-contiguous,
    native-endian, of a kernel dtype, and every float32 image is finite and in [0, 1]."""
    from tilesynth import _core as real

    seen: list[str] = []

    def check(name: str, i: int, v: object) -> None:
        if not isinstance(v, np.ndarray):
            return
        seen.append(name)
        assert v.flags.c_contiguous, (name, i)
        assert v.dtype.isnative, (name, i, v.dtype)
        assert v.dtype in (np.float32, np.float64, np.int64, np.int32, np.bool_, np.uint8, np.uint16), (
            name,
            v.dtype,
        )
        if name == "best_matches_quadrants" and i == 2:  # the quadrants' SSD maps (quadrant_map's output)
            assert np.isfinite(v).all() and v.min() >= 0, name
        elif v.dtype == np.float32 and not (name == "tile_copy" and i == 2):  # tile_copy's out is written
            assert np.isfinite(v).all() and v.min() >= 0 and v.max() <= 1, name

    class Spy:
        def __init__(self, obj: object) -> None:
            self._obj = obj

        def __getattr__(self, name: str) -> object:
            attr = getattr(self._obj, name)
            if not callable(attr):
                return attr

            def call(*args: object, **kwargs: object) -> object:
                for i, v in enumerate([*args, *kwargs.values()]):
                    check(name, i, v)
                # a wrapped core object handed back to the core (an SsdIndex to quadrant_map) goes in unwrapped
                args = tuple(a._obj if isinstance(a, Spy) else a for a in args)
                kwargs = {k: a._obj if isinstance(a, Spy) else a for k, a in kwargs.items()}
                r = attr(*args, **kwargs)
                return Spy(r) if type(r).__module__ == "tilesynth._core" else r

            return call

    monkeypatch.setattr(kernels, "_core", Spy(real))
    monkeypatch.setattr(ts, "_core", Spy(real))
    careless = layouts(ex.astype(np.float64))
    for a in careless.values():
        tiles = ts.build_omega(a, tileset="8", tile_size=16, seed=1)
    ts.build_omega(
        careless["fortran"], tileset="8", tile_size=16, seed=1, select="ga", generations=1, population=4
    )
    ts.synthesize(tiles, 50, 40, seed=2, dtype=np.uint16)
    ts.source_map(tiles, np.asfortranarray(ts.synthesize(tiles, 50, 40, seed=2)[1]), 50, 40)
    ts.patch_ssd(
        careless["big-endian"], careless["strided"][:5, :6], mask=np.asfortranarray(np.ones((5, 6), int))
    )
    assert {
        "SsdIndex",
        "quadrant_map",
        "best_matches_quadrants",  # the matching stage's kernels (SsdIndex.best_matches: other callers)
        "ssd_maps",
        "omega_cuts",
        "tile_copy",
        "PopulationEvaluator",
        "evaluate",
    } <= set(seen)


# --------------------------------------------------------------------------------------------- parameters
@pytest.mark.parametrize(
    ("tile_size", "words"),
    [
        (7, "tile_size = 7: must be even"),
        (0, "tile_size = 0: must be >= 4"),
        (-8, "tile_size = -8: must be >= 4"),
        (2, "tile_size = 2: must be >= 4"),
        (50, r"tile_size = 50: larger than the exemplar \(48x48 pixels\); use at most 48"),
        (8.0, "tile_size = 8.0: must be an integer"),
        (True, "tile_size = True: must be an integer"),
        (2**70, "tile_size = 1180591620717411303424: must be <= 9223372036854775807"),
    ],
)
def test_bad_tile_size(ex, tile_size, words):
    with pytest.raises(ts.ParameterError, match=words):
        ts.build_omega(ex, tile_size=tile_size)


def test_exemplar_too_small_for_the_set(ex):
    """A set needs distinct sample patches (n2: 6 of them); a tile as big as the exemplar has one position."""
    with pytest.raises(ts.ParameterError, match="the exemplar has only 1 patch positions, 6 needed"):
        ts.build_omega(ex, tileset="n2", tile_size=48)
    with pytest.raises(
        ts.ParameterError, match="tile_size = 46: the exemplar has only 9 patch positions, 20 needed"
    ):
        ts.build_omega(ex, tileset="n16", tile_size=46)
    for method in ("best-of", "ga", "ais"):
        with pytest.raises(ts.ParameterError, match="6 needed"):
            ts.build_omega(ex, tileset="n2", tile_size=48, select=method, population=4)
    # the 32-set needs a second matching patch N/4 away from the best one
    with pytest.raises(ts.ParameterError, match="too few distinct translations"):
        ts.build_omega(ex[:14, :14], tileset="32", tile_size=12, seed=1)


@pytest.mark.parametrize("param", ["population", "generations"])
@pytest.mark.parametrize("value", [0, -1, 2.5, 10**9])
def test_bad_population_and_generations(ex, param, value):
    kwargs = {"select": "ga", "tile_size": 16, param: value}
    with pytest.raises(ts.ParameterError, match=rf"{param} = {value!r}"):
        ts.build_omega(ex, **kwargs)


@pytest.mark.parametrize(
    ("flag", "value"), [("--population", "0"), ("--generations", "-3"), ("--population", "x")]
)
def test_bad_population_and_generations_cli(tmp_path, ex, flag, value, capsys):
    src = tmp_path / "ex.png"
    ts.save_image(src, ex)
    out = tmp_path / "o.tiles"
    code = main(["build", str(src), "-o", str(out), "--select", "ga", flag, value, "-q"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and flag in err[0] and not out.exists()


def test_huge_output_is_refused_up_front(ex):
    tiles = ts.build_omega(ex, tileset="8", tile_size=16, seed=1)
    with pytest.raises(
        ts.ParameterError,
        match=r"width x height = 100000x100000: the output needs about "
        r"114\.1 GiB \(100000x100000x3 float32",
    ):
        ts.synthesize(tiles, 100_000, 100_000, max_bytes=2**36)
    # the default limit (half the physical memory) refuses what cannot fit on any machine
    with pytest.raises(ts.ParameterError, match="1000000x1000000: the output needs about"):
        ts.synthesize(tiles, 10**6, 10**6)
    # the estimate is checked against the limit, and a small enough output passes the same limit
    need = ts.synth.synthesis.synthesis_bytes(tiles, 64, 64, np.uint8)
    with pytest.raises(ts.ParameterError, match="more than the limit"):
        ts.synthesize(tiles, 64, 64, dtype=np.uint8, max_bytes=need - 1)
    img, _ = ts.synthesize(tiles, 64, 64, dtype=np.uint8, max_bytes=need)
    assert img.shape == (64, 64, 3)
    with pytest.raises(ts.ParameterError, match="more than the limit"):
        ts.source_map(tiles, np.zeros((2, 2), np.int32), 10**6, 10**6)


def test_memory_limit_environment_variable(ex, monkeypatch):
    tiles = ts.build_omega(ex, tileset="8", tile_size=16, seed=1)
    monkeypatch.setenv("TILESYNTH_MAX_BYTES", "1000")
    with pytest.raises(ts.ParameterError, match=r"64x64: the output needs about .* limit of 1000 bytes"):
        ts.synthesize(tiles, 64, 64)
    monkeypatch.setenv("TILESYNTH_MAX_BYTES", "-5")
    with pytest.raises(ts.ParameterError, match="TILESYNTH_MAX_BYTES = '-5'"):
        ts.synthesize(tiles, 64, 64)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"threads": 0}, "threads = 0: must be >= 1"),
        ({"threads": 5000}, "threads = 5000: must be at most 1024"),
        ({"threads": -1}, "threads = -1: must be >= 1"),
        ({"eps": 0.0}, "eps = 0.0: must be finite and > 0"),
        ({"eps": float("nan")}, "eps = nan: must be finite"),
        ({"seed": -3}, "seed = -3: must be a non-negative integer"),
        ({"tileset": "n99"}, "at most n16"),
        ({"tileset": 16}, "tileset = 16: expected a tile-set name"),
        ({"gradients": "x"}, "gradients = 'x'"),
    ],
)
def test_other_bad_parameters(ex, kwargs, words):
    with pytest.raises(ValueError, match=words):
        ts.build_omega(ex, tile_size=16, **kwargs)


def test_kernel_parameters_are_named(ex):
    img = ex.astype(np.float32)
    t = img[:5, :5]
    for kw, words in [
        ({"k": -1}, "k = -1: must be >= 0"),
        ({"exclude_radius": 2**64}, "exclude_radius = "),
        ({"threads": 2**40}, "threads = 1099511627776: must be at most 1024"),
    ]:
        with pytest.raises(ts.ParameterError, match=words):
            ts.best_matches(img, t, **kw)
    with pytest.raises(ts.ParameterError, match="mask has dtype float64 with values other than 0 and 1"):
        ts.patch_ssd(img, t, mask=np.full((5, 5), 0.5))
    with pytest.raises(TypeError, match="wx has dtype complex128"):
        ts.grid_mincut(
            np.ones((3, 3), complex), np.ones((3, 3)), np.zeros((3, 3), bool), np.zeros((3, 3), bool)
        )
    with pytest.raises(ts.ParameterError, match=r"index_map has values in \[0, 4294967296\]"):
        ts.tile_copy(np.zeros((1, 2, 2, 3), np.uint8), np.array([[0, 2**32]]), np.zeros((2, 4, 3), np.uint8))
    a = np.zeros((1, 2, 2, 3), np.uint8)
    with pytest.raises(ts.ParameterError, match="out: must not share memory with atlas"):
        ts.tile_copy(a, np.zeros((1, 1), np.int32), a[0])
    ro = np.zeros((2, 2, 3), np.uint8)
    ro.setflags(write=False)
    with pytest.raises(TypeError, match="out: array must be C-contiguous, aligned and writeable"):
        ts.tile_copy(a, np.zeros((1, 1), np.int32), ro)


def test_tile_set_does_not_alias_the_exemplar(ex):
    """A C-contiguous float32 exemplar passes validation without a copy; the tile set keeps its own copy, so
    changing the caller's array afterwards changes nothing in the set."""
    a = np.ascontiguousarray(ex, dtype=np.float32)
    tiles = ts.build_omega(a, tileset="4", tile_size=16, seed=3)
    digest = tiles.content_digest()
    assert not np.shares_memory(tiles.exemplar, a)
    a[:] = 0
    assert tiles.content_digest() == digest
