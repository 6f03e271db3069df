"""Input conversion, image files, thread settings, and the public API surface."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import tilesynth
from tilesynth import _core
from tilesynth.base.validate import as_image, to_uint


def test_as_image_conversions():
    u8 = np.array([[0, 255], [128, 1]], np.uint8)
    out = as_image(u8)
    assert out.shape == (2, 2, 1) and out.dtype == np.float32 and out.flags.c_contiguous
    assert out[0, 1, 0] == 1.0 and out[1, 0, 0] == pytest.approx(128 / 255)
    u16 = np.full((2, 3, 3), 65535, np.uint16)
    assert as_image(u16).max() == 1.0
    f64 = np.linspace(0, 1, 12).reshape(2, 2, 3)
    assert as_image(f64).dtype == np.float32
    f32 = np.zeros((4, 4, 3), np.float32)
    assert as_image(f32) is f32 or np.shares_memory(as_image(f32), f32)
    with pytest.raises(tilesynth.ParameterError, match=r"\[0, 2\]"):
        as_image(np.array([[0.0, 2.0]]))
    with pytest.raises(tilesynth.ParameterError, match="NaN"):
        as_image(np.array([[np.nan]]))
    with pytest.raises(tilesynth.ShapeError, match="channels"):
        as_image(np.zeros((3, 3, 7)))
    with pytest.raises(tilesynth.ShapeError):
        as_image(np.zeros(5))
    with pytest.raises(TypeError, match="int64"):
        as_image(np.zeros((3, 3), np.int64))


def test_to_uint_round_trip():
    r = np.random.default_rng(0)
    u8 = r.integers(0, 256, (5, 6, 3), dtype=np.uint8)
    np.testing.assert_array_equal(to_uint(as_image(u8), 8), u8)
    u16 = r.integers(0, 65536, (5, 6, 1), dtype=np.uint16)
    np.testing.assert_array_equal(to_uint(as_image(u16), 16), u16)


@pytest.mark.parametrize("mode", ["L", "RGB", "RGBA", "P"])
def test_load_image_modes(tmp_path, mode):
    r = np.random.default_rng(1)
    rgb = r.integers(0, 256, (9, 7, 3), dtype=np.uint8)
    im = Image.fromarray(rgb).convert(mode)
    p = tmp_path / f"x-{mode}.png"
    im.save(p)
    img, bits = tilesynth.load_image(p)
    assert bits == 8 and img.dtype == np.float32 and img.shape[:2] == (9, 7)
    assert img.shape[2] == {"L": 1, "RGB": 3, "RGBA": 4, "P": 3}[mode]


def test_16_bit_png_round_trip(tmp_path):
    r = np.random.default_rng(2)
    for channels in (1, 3):
        u16 = r.integers(0, 65536, (6, 5, channels), dtype=np.uint16)
        p = tmp_path / f"g{channels}.png"
        tilesynth.save_image(p, u16)
        if channels == 1:
            img, bits = tilesynth.load_image(p)
            assert bits == 16
            np.testing.assert_array_equal(to_uint(img, 16), u16)
        with Image.open(p) as im:
            assert im.size == (5, 6)
            if channels == 1:
                np.testing.assert_array_equal(np.asarray(im).astype(np.uint16), u16[..., 0])


def test_save_image_errors(tmp_path):
    with pytest.raises(tilesynth.ParameterError, match="extension"):
        tilesynth.save_image(tmp_path / "x.unknownext", np.zeros((2, 2, 3), np.uint8))
    with pytest.raises(tilesynth.ParameterError, match="does not exist"):
        tilesynth.save_image(tmp_path / "nodir" / "x.png", np.zeros((2, 2, 3), np.uint8))
    assert list(tmp_path.iterdir()) == []


def test_thread_environment_variable():
    code = "import tilesynth._core as c; print(c.resolve_threads(None), c.resolve_threads(3))"
    env = {"TILESYNTH_NUM_THREADS": "1", "PATH": ""}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.stdout.split() == ["1", "3"], r.stderr
    env["TILESYNTH_NUM_THREADS"] = "many"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode != 0 and "TILESYNTH_NUM_THREADS" in r.stderr
    with pytest.raises(tilesynth.ParameterError, match="threads"):
        _core.resolve_threads(0)


def test_synthesis_options(small_exemplar):
    ts = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=16, seed=3)
    f, m = tilesynth.synthesize(ts, 50, 33, seed=1)
    u8, m2 = tilesynth.synthesize(ts, 50, 33, seed=1, dtype=np.uint8)
    np.testing.assert_array_equal(m, m2)
    np.testing.assert_array_equal(to_uint(f, 8), u8)
    out = np.empty((33, 50, 3), np.uint16)
    got, _ = tilesynth.synthesize(ts, 50, 33, seed=1, dtype=np.uint16, out=out)
    assert got is out
    a, _ = tilesynth.synthesize(ts, 64, 64, seed=5, threads=1)
    b, _ = tilesynth.synthesize(ts, 64, 64, seed=5, threads=2)
    assert a.tobytes() == b.tobytes()
    with pytest.raises(tilesynth.ParameterError, match="width"):
        tilesynth.synthesize(ts, 0, 10)
    with pytest.raises(tilesynth.ShapeError, match="index_map"):
        tilesynth.synthesize(ts, 64, 64, index_map=np.zeros((2, 2), np.int32))
    with pytest.raises(tilesynth.ParameterError, match="dtype"):
        tilesynth.synthesize(ts, 8, 8, dtype=np.int8)
    with pytest.raises(tilesynth.ShapeError, match="out"):
        tilesynth.synthesize(ts, 8, 8, out=np.empty((8, 8, 3), np.uint8))


def test_tile_copy_rejects_mismatched_dtypes():
    with pytest.raises(TypeError, match="same dtype"):
        tilesynth.tile_copy(
            np.zeros((1, 2, 2, 3), np.uint8), np.zeros((1, 1), np.int32), np.zeros((2, 2, 3), np.float32)
        )


def test_public_api():
    for name in tilesynth.__all__:
        assert hasattr(tilesynth, name), name
    assert tilesynth.__version__ == _core.__version__
