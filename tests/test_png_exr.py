"""The image codecs: PNG through the png crate (read: every bad input refused at every bit depth; write: one
parallel band-deflate encoder, checked against Pillow and an independent zlib + unfilter oracle) and
OpenEXR through the exr crate. The bad inputs are listed in docs/failure-modes.md."""

from __future__ import annotations

import io
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

import tilesynth as ts
from tilesynth import _core
from tilesynth.io.images import PNG_COMPRESSIONS, encode_png, load_raster, read_exr, read_png

SIG = b"\x89PNG\r\n\x1a\n"


def chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def ihdr(w: int, h: int, depth: int = 8, ctype: int = 2) -> bytes:
    return chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, 0))


def chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    """(tag, body) of every chunk of a PNG."""
    out, pos = [], 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        out.append((data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]))
        pos += 12 + n
    return out


def oracle_decode(data: bytes) -> np.ndarray:
    """An independent decoder for what encode_png writes: Python's zlib and the unfilter kernel."""
    parts = chunks(data)
    w, h, depth, ctype = struct.unpack(">IIBB", parts[0][1][:10])
    c = {0: 1, 4: 2, 2: 3, 6: 4}[ctype]
    raw = zlib.decompress(b"".join(b for t, b in parts if t == b"IDAT"))
    bpp = c * depth // 8
    rows = _core.png_unfilter(np.frombuffer(raw, np.uint8), h, w * bpp, bpp)
    if depth == 16:
        return rows.view(">u2").reshape(h, w, c).astype(np.uint16)
    return rows.reshape(h, w, c)


def rng_image(h: int, w: int, c: int, dtype, seed: int = 0) -> np.ndarray:
    r = np.random.default_rng(seed)
    hi = 256 if dtype == np.uint8 else 65536
    a = r.integers(0, hi, (h, w, c)).astype(dtype)
    a[h // 2 :] = (np.arange(w)[None, :, None] * 7 + np.arange(c)).astype(
        dtype
    )  # smooth half: filters matter
    return a


# ------------------------------------------------------------------------------------------------ writing
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("hw", [(1, 1), (1, 7), (7, 1), (13, 29), (300, 257)])
def test_every_written_png_decodes_to_the_exact_array(tmp_path, dtype, channels, hw):
    a = rng_image(*hw, channels, dtype, seed=channels)
    for level in PNG_COMPRESSIONS:
        data = encode_png(a, level)
        np.testing.assert_array_equal(oracle_decode(data), a)
        np.testing.assert_array_equal(_core.png_decode(data, 1 << 40)[0], a)
        im = Image.open(io.BytesIO(data))
        if dtype == np.uint8:
            np.testing.assert_array_equal(np.asarray(im).reshape(a.shape), a)
        elif channels == 1:  # Pillow reads 16-bit grey exactly (16-bit colour it reduces to 8 bits)
            np.testing.assert_array_equal(np.asarray(im).astype(np.uint16).reshape(a.shape), a)
        else:
            im.load()  # decodes without error
    p = tmp_path / "x.png"
    ts.save_image(p, a)
    np.testing.assert_array_equal(read_png(p), a)


def test_bands_are_joined_into_one_stream_and_threads_do_not_change_bytes():
    a = rng_image(1200, 1000, 3, np.uint8)  # 3.6 MB raw: 4 bands of 1 MiB
    one = encode_png(a, "default", threads=1)
    assert encode_png(a, "default", threads=2) == one
    idat = b"".join(b for t, b in chunks(one) if t == b"IDAT")
    z = zlib.decompressobj()
    z.decompress(idat)
    assert z.eof and not z.unused_data  # one complete zlib stream, Adler-32 checked by zlib
    assert chunks(one)[0][0] == b"IHDR" and chunks(one)[-1] == (b"IEND", b"")


def test_compression_levels_order_file_sizes():
    a = rng_image(256, 256, 3, np.uint8)
    a[:128] = np.tile(a[128:129], (128, 1, 1))  # repetitive content
    sizes = [len(encode_png(a, level)) for level in PNG_COMPRESSIONS]
    assert sizes[0] >= sizes[1] >= sizes[2]


def test_bad_write_arguments():
    with pytest.raises(ts.ParameterError, match="compression = 'max'"):
        encode_png(np.zeros((2, 2, 3), np.uint8), "max")
    with pytest.raises(TypeError, match="uint8 or uint16"):
        encode_png(np.zeros((2, 2, 3), np.float32))
    with pytest.raises(ts.ShapeError):
        encode_png(np.zeros((2, 2, 5), np.uint8))
    with pytest.raises(ts.ShapeError):
        encode_png(np.zeros((0, 2, 3), np.uint8))
    with pytest.raises(ts.ParameterError, match="compression = 'max'"):
        ts.save_image("/tmp/never-written.png", np.zeros((2, 2, 3), np.uint8), compression="max")


def test_set_png_compression_is_the_default_of_save_image(tmp_path):
    import contextvars

    from tilesynth.io.images import set_png_compression

    a = rng_image(64, 64, 3, np.uint8)

    def in_context(level):
        set_png_compression(level)
        ts.save_image(tmp_path / f"{level}.png", a)

    for level in ("fast", "best"):
        contextvars.copy_context().run(in_context, level)
        assert (tmp_path / f"{level}.png").read_bytes() == encode_png(a, level)
    ts.save_image(tmp_path / "d.png", a)  # the context of this test kept "default"
    assert (tmp_path / "d.png").read_bytes() == encode_png(a, "default")


# ------------------------------------------------------------------------------------------------ reading
def pillow_png(a: np.ndarray, **kw) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(a[..., 0] if a.shape[2] == 1 else a).save(buf, format="PNG", **kw)
    return buf.getvalue()


def write(tmp_path: Path, name: str, data: bytes) -> Path:
    p = tmp_path / name
    p.write_bytes(data)
    return p


@pytest.mark.parametrize("mode", ["1", "L", "LA", "RGB", "RGBA", "P", "PA"])
def test_8_bit_and_palette_pngs_read_as_pillow_does(tmp_path, mode):
    base = Image.fromarray(rng_image(9, 11, 4, np.uint8))
    if mode == "PA":  # a palette with a tRNS chunk
        src = base.convert("RGB").quantize(16)
    else:
        src = (base if "A" in mode else base.convert("RGB")).convert(mode)
    p = tmp_path / "x.png"
    src.save(p, **({"transparency": 3} if mode == "PA" else {}))
    with Image.open(p) as im:
        want = np.asarray(
            im.convert("RGBA" if mode == "PA" else "RGB" if mode == "P" else "L" if mode == "1" else mode)
        )
    got = read_png(p)
    np.testing.assert_array_equal(got, want.reshape(got.shape))


def test_truncated_8_bit_image_data_is_refused_not_zero_filled(tmp_path):
    """Issue 16: an 8-bit PNG whose compressed data ends after half the rows. Pillow loads it half black; every
    PNG now goes through the png crate, which refuses it like the 16-bit path always did."""
    a = rng_image(40, 30, 3, np.uint8)
    raw = b"".join(b"\x00" + a[y].tobytes() for y in range(20))  # 20 of 40 rows, a complete zlib stream
    data = SIG + ihdr(30, 40) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    p = write(tmp_path, "half.png", data)
    with pytest.raises(
        ts.ParameterError, match=r"half\.png.*not a readable image \(corrupt or truncated PNG image"
    ):
        ts.load_image(p)
    with pytest.raises(ts.ParameterError, match="not a readable image"):
        load_raster(p)
    # the same cut short at 16 bits
    a16 = a.astype(np.uint16) * 257
    raw16 = b"".join(b"\x00" + a16[y].astype(">u2").tobytes() for y in range(20))
    p16 = write(
        tmp_path,
        "half16.png",
        SIG + ihdr(30, 40, 16) + chunk(b"IDAT", zlib.compress(raw16)) + chunk(b"IEND", b""),
    )
    with pytest.raises(ts.ParameterError, match="truncated PNG image"):
        ts.load_image(p16)


@pytest.mark.parametrize("depth", [8, 16])
def test_two_ihdr_chunks_are_refused(tmp_path, depth):
    """Issue 16: a PNG with two IHDR chunks was checked with the first and decoded with the last."""
    a = rng_image(4, 4, 3, np.uint8 if depth == 8 else np.uint16)
    good = encode_png(a)
    second = ihdr(4, 4, depth) if depth == 8 else ihdr(9000, 9000, depth)
    data = good[:33] + second + good[33:]
    with pytest.raises(ts.ParameterError, match=r"not a readable image .*IHDR"):
        ts.load_image(write(tmp_path, "two.png", data))
    with pytest.raises(ts.ParameterError, match="IHDR"):
        load_raster(write(tmp_path, "two2.png", data))


@pytest.mark.parametrize("depth", [8, 16])
def test_bad_crc_is_refused_at_every_bit_depth(tmp_path, depth):
    a = rng_image(8, 8, 3, np.uint8 if depth == 8 else np.uint16)
    data = bytearray(encode_png(a))
    data[45] ^= 0x10  # inside the IDAT data
    with pytest.raises(ts.ParameterError, match="(?i)crc"):
        ts.load_image(write(tmp_path, "crc.png", bytes(data)))


@pytest.mark.parametrize("depth,ctype", [(12, 2), (16, 3), (3, 0), (8, 5), (8, 1)])
def test_impossible_bit_depth_or_colour_type(tmp_path, depth, ctype):
    data = SIG + ihdr(4, 4, depth, ctype) + chunk(b"IDAT", zlib.compress(b"\x00" * 100)) + chunk(b"IEND", b"")
    with pytest.raises(ts.ParameterError, match="not a readable image"):
        ts.load_image(write(tmp_path, "d.png", data))


def test_missing_iend_and_trailing_damage(tmp_path):
    good = encode_png(rng_image(8, 8, 3, np.uint8))
    with pytest.raises(ts.ParameterError, match="not a readable image"):
        ts.load_image(write(tmp_path, "noend.png", good[:-12]))
    with pytest.raises(ts.ParameterError, match="not a readable image"):
        ts.load_image(write(tmp_path, "badend.png", good[:-4] + b"\x00\x00\x00\x00"))


def test_huge_declared_size_is_refused_before_decoding(tmp_path):
    data = SIG + ihdr(200_000, 200_000) + chunk(b"IDAT", zlib.compress(b"")) + chunk(b"IEND", b"")
    with pytest.raises(ts.ParameterError, match="200000x200000 = 40000000000 pixels exceeds the limit"):
        ts.load_image(write(tmp_path, "bomb.png", data))
    with pytest.raises(ts.ParameterError, match="exceeds the limit"):
        read_png(write(tmp_path, "bomb2.png", data))
    with pytest.raises(ts.ParameterError, match="exceeds the limit"):
        load_raster(write(tmp_path, "bomb3.png", data))


def test_inflate_is_bounded_by_the_declared_size(tmp_path):
    """A 4x4 image followed by megabytes of extra zeros in its stream: the decoder stops at the image."""
    raw = b"".join(b"\x00" + bytes(12) for _ in range(4)) + bytes(50_000_000)
    data = SIG + ihdr(4, 4) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    assert len(data) < 100_000
    try:
        got = read_png(write(tmp_path, "z.png", data))
    except ts.ParameterError as exc:  # refusing the surplus data is as good
        assert "not a readable image" in str(exc)
    else:
        assert got.shape == (4, 4, 3) and not got.any()


GOOD = encode_png(rng_image(6, 5, 3, np.uint8, seed=3))
GOOD_ARRAY = rng_image(6, 5, 3, np.uint8, seed=3)


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_fuzz_mutated_png_bytes(data):
    """Mutated PNG bytes: never a panic or an internal error; a ParameterError or exactly the right array."""
    b = bytearray(GOOD)
    how = data.draw(st.sampled_from(["flip", "cut", "insert", "delete"]))
    if how == "flip":
        for _ in range(data.draw(st.integers(1, 3))):
            b[data.draw(st.integers(0, len(b) - 1))] = data.draw(st.integers(0, 255))
    elif how == "cut":
        del b[data.draw(st.integers(0, len(b) - 1)) :]
    elif how == "insert":
        i = data.draw(st.integers(0, len(b)))
        b[i:i] = data.draw(st.binary(min_size=1, max_size=8))
    else:
        i = data.draw(st.integers(0, len(b) - 1))
        del b[i : i + data.draw(st.integers(1, 8))]
    try:
        got, _ = _core.png_decode(bytes(b), 1 << 30)
    except ts.ParameterError:
        return
    np.testing.assert_array_equal(got, GOOD_ARRAY)


# ------------------------------------------------------------------------------------------------ OpenEXR
@pytest.mark.parametrize("channels", [1, 2, 3, 4, 7])
@pytest.mark.parametrize("dtype", [np.float32, np.float16])
def test_exr_round_trip(tmp_path, channels, dtype):
    a = (np.random.default_rng(channels).standard_normal((9, 13, channels)) * 10).astype(dtype)
    p = tmp_path / "x.exr"
    ts.save_image(p, a)
    got, names, half = read_exr(p)
    assert got.dtype == np.float32 and half == (dtype == np.float16) and len(names) == channels
    np.testing.assert_array_equal(got, a.astype(np.float32))
    np.testing.assert_array_equal(load_raster(p), a.astype(np.float32))


def test_exr_exemplar_and_its_refusals(tmp_path):
    a = np.random.default_rng(0).random((16, 16, 3)).astype(np.float32)
    ts.save_image(tmp_path / "ok.exr", a)
    img, bits = ts.load_image(tmp_path / "ok.exr")
    assert bits == 16
    np.testing.assert_array_equal(img, a)
    nan = a.copy()
    nan[3, 4, 1] = np.nan
    ts.save_image(tmp_path / "nan.exr", nan)  # EXR holds NaN; the exemplar reader refuses it
    with pytest.raises(ts.ParameterError, match=r"nan\.exr.*NaN or infinity"):
        ts.load_image(tmp_path / "nan.exr")
    assert np.isnan(load_raster(tmp_path / "nan.exr")).sum() == 1  # a map keeps it (smoothing refuses later)
    ts.save_image(tmp_path / "hdr.exr", a * 8)
    with pytest.raises(
        ts.ParameterError, match=r"hdr\.exr.*values in \[.*expected floats in \[0, 1\].*tone-mapped"
    ):
        ts.load_image(tmp_path / "hdr.exr")
    ts.save_image(tmp_path / "six.exr", np.zeros((4, 4, 6), np.float32))
    with pytest.raises(ts.ParameterError, match="6 channels"):
        ts.load_image(tmp_path / "six.exr")
    with pytest.raises(ts.ParameterError, match="exceeds the limit of 100 pixels"):
        ts.load_image(tmp_path / "ok.exr", max_pixels=100)
    data = (tmp_path / "ok.exr").read_bytes()
    for cut in (4, 40, len(data) // 2, len(data) - 3):
        with pytest.raises(ts.ParameterError, match="not a readable image"):
            ts.load_image(write(tmp_path, f"cut{cut}.exr", data[:cut]))


def test_uint_arrays_to_exr_are_scaled(tmp_path):
    a = np.array([[[0, 255, 51]]], np.uint8)
    ts.save_image(tmp_path / "u.exr", a)
    np.testing.assert_allclose(read_exr(tmp_path / "u.exr")[0], a / 255, rtol=1e-7)


# ------------------------------------------------------------------------------------------------ the CLI
def run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "tilesynth", *args], capture_output=True, text=True, check=False
    )


def test_cli_png_compression_and_exr_output(tmp_path):
    ex = tmp_path / "ex.png"
    ts.save_image(ex, rng_image(64, 64, 3, np.uint8))
    tiles = tmp_path / "t.tiles"
    r = run(
        [
            "build",
            str(ex),
            "-o",
            str(tiles),
            "--set",
            "4",
            "--tile-size",
            "32",
            "--seed",
            "1",
            "-q",
            "--sheet",
            str(tmp_path / "sheet.png"),
            "--png-compression",
            "fast",
        ]
    )
    assert r.returncode == 0, r.stderr
    outs = {}
    for level in PNG_COMPRESSIONS:
        out = tmp_path / f"{level}.png"
        r = run(
            [
                "synth",
                str(tiles),
                "-o",
                str(out),
                "--size",
                "100x80",
                "--seed",
                "2",
                "-q",
                "--png-compression",
                level,
            ]
        )
        assert r.returncode == 0, r.stderr
        outs[level] = read_png(out)
    np.testing.assert_array_equal(outs["fast"], outs["best"])
    np.testing.assert_array_equal(outs["fast"], outs["default"])
    r = run(["synth", str(tiles), "-o", str(tmp_path / "x.png"), "--size", "8x8", "--png-compression", "max"])
    assert r.returncode == 2 and "--png-compression" in r.stderr
    # float colour output, and an EXR map through the same cuts
    ts.save_image(tmp_path / "h.exr", np.random.default_rng(1).random((64, 64, 1)).astype(np.float32) * 5)
    r = run(
        [
            "synth",
            str(tiles),
            "-o",
            str(tmp_path / "o.exr"),
            "--size",
            "100x80",
            "--seed",
            "2",
            "-q",
            "--with",
            str(tmp_path / "h.exr"),
        ]
    )
    assert r.returncode == 0, r.stderr
    colour, names, half = read_exr(tmp_path / "o.exr")
    assert names == ["R", "G", "B"] and not half and colour.shape == (80, 100, 3)
    np.testing.assert_allclose(colour, outs["default"] / 255, atol=1e-6)
    height = read_exr(tmp_path / "o-h.exr")[0]
    assert height.shape == (80, 100, 1) and height.max() > 1  # any range, as stored
