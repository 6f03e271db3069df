"""Maps that follow the cuts (`synth --with`), and exact PNG decoding of 16-bit colour images."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from PIL import Image

import tilesynth
from tilesynth.cli.main import main
from tilesynth.io.images import load_raster, read_png


def _paeth(a: int, b: int, c: int) -> int:
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def write_png_filtered(path, arr: np.ndarray, kinds=(0, 1, 2, 3, 4)) -> None:
    """A PNG encoder written from the specification, cycling through every filter type row by row."""
    h, w = arr.shape[:2]
    ch = 1 if arr.ndim == 2 else arr.shape[2]
    depth = 16 if arr.dtype == np.uint16 else 8
    raw = np.ascontiguousarray(arr.astype(">u2") if depth == 16 else arr).view(np.uint8).reshape(h, -1)
    bpp = ch * depth // 8
    out = bytearray()
    for y in range(h):
        k = kinds[y % len(kinds)]
        out.append(k)
        cur = raw[y].astype(int)
        prev = raw[y - 1].astype(int) if y else np.zeros_like(cur)
        for i in range(cur.size):
            a = cur[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            pred = [0, a, b, (a + b) // 2, _paeth(a, b, c)][k]
            out.append((cur[i] - pred) & 0xFF)
    colour = {1: 0, 2: 4, 3: 2, 4: 6}[ch]

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
        )

    with open(path, "wb") as fh:
        fh.write(b"\x89PNG\r\n\x1a\n")
        fh.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, 0)))
        fh.write(chunk(b"IDAT", zlib.compress(bytes(out))))
        fh.write(chunk(b"IEND", b""))


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16])
def test_read_png_every_filter(tmp_path, rng, channels, dtype):
    hi = 256 if dtype == np.uint8 else 65536
    arr = rng.integers(0, hi, (6, 9, channels)).astype(dtype)
    # smooth content too, so predictions matter
    arr[3:] = (np.arange(9)[None, :, None] * (hi // 16) + np.arange(3)[:, None, None] * 7).astype(dtype)
    p = tmp_path / "f.png"
    write_png_filtered(p, arr[..., 0] if channels == 1 else arr)
    got = read_png(p)
    assert got.dtype == dtype
    np.testing.assert_array_equal(got, arr)


@pytest.mark.parametrize("mode", ["L", "LA", "RGB", "RGBA"])
def test_read_png_agrees_with_pillow_on_8_bit(tmp_path, small_exemplar, mode):
    img = Image.fromarray((small_exemplar * 255).round().astype(np.uint8)).convert(mode)
    p = tmp_path / "p.png"
    img.save(p, optimize=True)  # Pillow picks filters per row
    want = np.asarray(Image.open(p))
    got = read_png(p)
    np.testing.assert_array_equal(got, want.reshape(got.shape))


def test_16_bit_rgb_exemplar_keeps_full_precision(tmp_path, rng):
    a = rng.integers(0, 65536, (20, 24, 3)).astype(np.uint16)
    p = tmp_path / "e16.png"
    write_png_filtered(p, a)
    img, bits = tilesynth.load_image(p)
    assert bits == 16 and img.dtype == np.float32
    np.testing.assert_array_equal(np.round(img * 65535).astype(np.uint16), a)
    # Pillow alone would have truncated it to 8 bits
    assert np.asarray(Image.open(p)).dtype == np.uint8


def test_damaged_png_is_a_clear_error(tmp_path, rng):
    a = rng.integers(0, 65536, (8, 8, 3)).astype(np.uint16)
    p = tmp_path / "d.png"
    write_png_filtered(p, a)
    data = bytearray(p.read_bytes())
    data[60] ^= 0xFF
    p.write_bytes(bytes(data))
    with pytest.raises(tilesynth.ParameterError, match="d.png"):
        tilesynth.load_image(p)
    p.write_bytes(bytes(data[:40]))
    with pytest.raises(tilesynth.ParameterError, match="d.png.*(truncated|not a readable)"):
        tilesynth.load_image(p)
    with pytest.raises(tilesynth.ParameterError, match="truncated"):
        read_png(p)


@pytest.fixture(scope="module")
def tiles(small_exemplar):
    return tilesynth.build_omega(small_exemplar, tileset="32", tile_size=24, seed=3)


def test_map_follows_the_cuts(tiles, small_exemplar, rng):
    W, H = 101, 77
    img, imap = tilesynth.synthesize(tiles, W, H, seed=4, dtype=np.uint8)
    # the exemplar itself as a map reproduces the colour output exactly
    ex8 = (small_exemplar * 255).round().astype(np.uint8)
    np.testing.assert_array_equal(tilesynth.synthesize_map(tiles, ex8, imap, W, H), img)
    # any map: output pixel = map value at the output pixel's provenance, in the map's own dtype
    src = tilesynth.source_map(tiles, imap, W, H)
    for dtype, hi in ((np.uint16, 65536), (np.float32, None)):
        m = (rng.random((96, 96, 2)) if hi is None else rng.integers(0, hi, (96, 96, 2))).astype(dtype)
        before = m.copy()
        out = tilesynth.synthesize_map(tiles, m, imap, W, H)
        assert out.dtype == dtype and out.shape == (H, W, 2)
        np.testing.assert_array_equal(out, m[src[..., 0], src[..., 1]])
        np.testing.assert_array_equal(m, before)
    grey = rng.random((96, 96)).astype(np.float32)
    assert tilesynth.synthesize_map(tiles, grey, imap, W, H).shape == (H, W, 1)
    with pytest.raises(tilesynth.ShapeError, match="pixel-aligned"):
        tilesynth.synthesize_map(tiles, grey[:90], imap, W, H)
    with pytest.raises(tilesynth.ParameterError, match="dtype"):
        tilesynth.synthesize_map(tiles, grey.astype(np.float64), imap, W, H)


def test_cli_with_maps(tiles, tmp_path, rng, capsys):
    tf = tmp_path / "t.tiles"
    tiles.save(tf)
    normal = rng.integers(0, 65536, (96, 96, 3)).astype(np.uint16)
    write_png_filtered(tmp_path / "normal.png", normal)
    height = rng.random((96, 96)).astype(np.float32)
    np.save(tmp_path / "height.npy", height)
    out = tmp_path / "out.png"
    mp = tmp_path / "m.npy"
    assert (
        main(
            [
                "synth",
                str(tf),
                "-o",
                str(out),
                "--size",
                "90x60",
                "--seed",
                "2",
                "--save-map",
                str(mp),
                "--with",
                str(tmp_path / "normal.png"),
                "--with",
                str(tmp_path / "height.npy"),
                "-q",
            ]
        )
        == 0
    )
    imap = np.load(mp)
    src = tilesynth.source_map(tiles, imap, 90, 60)
    n_out = load_raster(tmp_path / "out-normal.png")
    assert n_out.dtype == np.uint16
    np.testing.assert_array_equal(n_out, normal[src[..., 0], src[..., 1]])
    h_out = np.load(tmp_path / "out-height.npy")
    assert h_out.dtype == np.float32
    np.testing.assert_array_equal(h_out[..., 0], height[src[..., 0], src[..., 1]])


def test_cli_with_misaligned_map_fails_before_writing(tiles, tmp_path, capsys):
    tf = tmp_path / "t.tiles"
    tiles.save(tf)
    np.save(tmp_path / "small.npy", np.zeros((50, 50), np.float32))
    out = tmp_path / "o.png"
    assert (
        main(
            ["synth", str(tf), "-o", str(out), "--size", "40x40", "--with", str(tmp_path / "small.npy"), "-q"]
        )
        == 2
    )
    err = capsys.readouterr().err
    assert "pixel-aligned" in err and len(err.strip().splitlines()) == 1
    assert not out.exists() and not (tmp_path / "o-small.npy").exists()


@pytest.fixture(scope="module")
def smoothed(small_exemplar):
    return tilesynth.build_omega(small_exemplar, tileset="32", tile_size=24, seed=3, smooth=True)


def test_maps_follow_the_smoothing(smoothed, small_exemplar, rng):
    W, H = 101, 77
    img, imap = tilesynth.synthesize(smoothed, W, H, seed=4, dtype=np.float32)
    src = tilesynth.source_map(smoothed, imap, W, H)
    # the exemplar as a 16-bit map follows the colour smoothing to the solver's accuracy and the 16-bit step
    ex16 = (small_exemplar.astype(np.float64) * 65535).round().astype(np.uint16)
    m16 = tilesynth.synthesize_map(smoothed, ex16, imap, W, H)
    assert m16.dtype == np.uint16
    np.testing.assert_allclose(m16 / 65535.0, img, atol=2e-5 + 0.5 / 65535, rtol=0)
    # outside the smoothed regions, and with smooth=False everywhere, maps are pure copies
    m = rng.random((96, 96, 2)).astype(np.float32)
    before = m.copy()
    raw = tilesynth.synthesize_map(smoothed, m, imap, W, H, smooth=False)
    np.testing.assert_array_equal(raw, m[src[..., 0], src[..., 1]])
    out = tilesynth.synthesize_map(smoothed, m, imap, W, H)
    np.testing.assert_array_equal(m, before)
    region = smoothed.cut_masks.copy()
    region[:, [0, -1], :] = region[:, :, [0, -1]] = False
    n = smoothed.tile_size
    inside = np.zeros((H, W), bool)
    for r in range(imap.shape[0]):
        for c in range(imap.shape[1]):
            blk = region[imap[r, c]][: H - r * n, : W - c * n]
            inside[r * n : r * n + blk.shape[0], c * n : c * n + blk.shape[1]] = blk
    np.testing.assert_array_equal(out[~inside], raw[~inside])
    assert np.abs(out[inside] - raw[inside]).max() > 1e-3
    # float maps are solved as they are (any range, no clipping): a scaled map gives the scaled result
    big = (m * 1000).astype(np.float32)
    np.testing.assert_allclose(
        tilesynth.synthesize_map(smoothed, big, imap, W, H), out * 1000, rtol=0, atol=0.05
    )


def test_map_smoothing_errors(smoothed, tiles):
    m = np.zeros((96, 96), np.float32)
    _, imap = tilesynth.synthesize(tiles, 48, 48, seed=1)
    with pytest.raises(tilesynth.ParameterError, match="was not Poisson-smoothed"):
        tilesynth.synthesize_map(tiles, m, imap, 48, 48, smooth=True)
    with pytest.raises(tilesynth.ParameterError, match="smooth = 'yes'"):
        tilesynth.synthesize_map(tiles, m, imap, 48, 48, smooth="yes")
    m[3, 4] = np.nan
    with pytest.raises(tilesynth.ParameterError, match="NaN or infinite.*smooth=False"):
        tilesynth.synthesize_map(smoothed, m, imap, 48, 48)
    src = tilesynth.source_map(smoothed, imap, 48, 48)
    np.testing.assert_array_equal(
        tilesynth.synthesize_map(smoothed, m, imap, 48, 48, smooth=False)[..., 0], m[src[..., 0], src[..., 1]]
    )  # NaN where the map has NaN: a pure copy


def test_cli_map_smooth(smoothed, tiles, tmp_path, capsys):
    sf, tf = tmp_path / "s.tiles", tmp_path / "t.tiles"
    smoothed.save(sf)
    tiles.save(tf)
    height = np.linspace(0, 1, 96 * 96, dtype=np.float32).reshape(96, 96)
    np.save(tmp_path / "height.npy", height)
    out = tmp_path / "out.png"
    args = [
        "synth",
        str(sf),
        "-o",
        str(out),
        "--size",
        "60x50",
        "--seed",
        "2",
        "--with",
        str(tmp_path / "height.npy"),
    ]
    assert main(args) == 0
    assert "Poisson-smoothed" in capsys.readouterr().err
    smooth = np.load(tmp_path / "out-height.npy")
    assert main(args + ["--map-smooth", "off", "-q"]) == 0
    raw = np.load(tmp_path / "out-height.npy")
    assert not np.array_equal(smooth, raw)
    assert (
        main(
            [
                "synth",
                str(tf),
                "-o",
                str(out),
                "--size",
                "60x50",
                "--with",
                str(tmp_path / "height.npy"),
                "--map-smooth",
                "on",
                "-q",
            ]
        )
        == 2
    )
    assert "was not built with --smooth" in capsys.readouterr().err
    assert main(["synth", str(sf), "-o", str(out), "--size", "60x50", "--map-smooth", "off", "-q"]) == 2
    assert "only used with --with" in capsys.readouterr().err
    height[0, 0] = np.inf
    np.save(tmp_path / "height.npy", height)
    out.unlink()
    assert main(args + ["-q"]) == 2
    assert "--map-smooth off" in capsys.readouterr().err and not out.exists()


def test_synthesize_map_checks_its_arguments(tiles, small_exemplar):
    """Found by the fuzzers: a non-TileSet raised AttributeError, index maps were cast to int32 without a
    check (2^32 + k wrapped to the valid index k, floats were truncated), and an output of any size was
    allocated (ValueError from numpy for 2^31 x 2^31; a merely huge one would be committed while copying)."""
    ex8 = (small_exemplar * 255).round().astype(np.uint8)
    _, imap = tilesynth.synthesize(tiles, 60, 50, seed=4)
    with pytest.raises(TypeError, match="tileset is a NoneType, expected a TileSet"):
        tilesynth.synthesize_map(None, ex8, imap, 60, 50)
    with pytest.raises(tilesynth.ParameterError, match="index_map has values in"):
        tilesynth.synthesize_map(tiles, ex8, imap.astype(np.int64) + 2**32, 60, 50)
    with pytest.raises(TypeError, match="index_map has dtype float64, expected integers"):
        tilesynth.synthesize_map(tiles, ex8, imap + 0.5, 60, 50)
    with pytest.raises(
        tilesynth.ParameterError, match="width x height = 2147483648x2147483648: the map needs"
    ):
        tilesynth.synthesize_map(tiles, ex8, imap, 2**31, 2**31)
    with pytest.raises(tilesynth.ParameterError, match="more than the limit of 1000 bytes"):
        tilesynth.synthesize_map(tiles, ex8, imap, 60, 50, max_bytes=1000)
    assert tilesynth.synthesize_map(tiles, ex8, imap, 60, 50, max_bytes=60 * 50 * 3).shape == (50, 60, 3)


def _npy_header(shape, descr="|u1") -> bytes:
    import io

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": descr, "fortran_order": False, "shape": shape})
    return buf.getvalue()


@pytest.mark.parametrize(
    ("data", "words"),
    [
        (b"", "No data left in file"),  # was EOFError
        (_npy_header((2**31, 2**31)), "not a readable .npy array"),  # was MemoryError (4 EiB)
        (_npy_header((100000, 100000)), "not a readable .npy array"),  # allocated 10 GB, then failed
        (_npy_header((2**40, 2**40, 3)), "not a readable .npy array"),  # numpy warned of an overflow
        (_npy_header((2**31, 2**31), "<u2"), "not a readable .npy array"),  # 2^63 bytes: mmap's OverflowError
        (_npy_header((2**61, 1), "<f4"), "not a readable .npy array"),  # the same, found by test_fuzz_api
        (
            b"\x93NUMPY\x01\x00\x10\x00{'descr': '|u1'\n",
            "not a readable .npy array",
        ),  # was tokenize.TokenError
    ],
)
def test_load_raster_refuses_damaged_npy(tmp_path, data, words):
    p = tmp_path / "m.npy"
    p.write_bytes(data)
    with pytest.raises(tilesynth.ParameterError, match=words):
        load_raster(p)


def test_cli_map_of_an_empty_npy_is_exit_2(tiles, tmp_path, capsys):
    tf = tmp_path / "t.tiles"
    tiles.save(tf)
    (tmp_path / "empty.npy").write_bytes(b"")
    assert (
        main(
            [
                "synth",
                str(tf),
                "-o",
                str(tmp_path / "o.png"),
                "--size",
                "40x40",
                "--map",
                str(tmp_path / "empty.npy"),
                "-q",
            ]
        )
        == 2
    )  # was 1 (internal error: EOFError)
    err = capsys.readouterr().err
    assert "--map" in err and "not a readable .npy array" in err and len(err.strip().splitlines()) == 1


def test_load_raster_pixel_limit(tmp_path, rng):
    """Image maps are checked on their declared size like exemplars (a decompression bomb is refused before
    decoding; Pillow's DecompressionBombError / warning never escapes)."""
    write_png_filtered(tmp_path / "m.png", rng.integers(0, 256, (20, 30, 3)).astype(np.uint8))
    Image.fromarray(rng.integers(0, 65536, (20, 30)).astype(np.uint16)).save(tmp_path / "m.tif")
    for name in ("m.png", "m.tif"):
        assert load_raster(tmp_path / name).shape[:2] == (20, 30)
        with pytest.raises(tilesynth.ParameterError, match="600 pixels exceeds the limit of 599 pixels"):
            load_raster(tmp_path / name, max_pixels=599)
    # TIFFs declaring 10^4 x 10^4 pixels (over tilesynth's limit) and 2^31 x 2^31 (over Pillow's own)
    data = bytearray((tmp_path / "m.tif").read_bytes())
    ifd = struct.unpack_from("<I", data, 4)[0]
    for side, words in (
        (10_000, "100000000 pixels exceeds the limit"),
        (2**31 - 1, "refused, .* decompression bomb"),
    ):
        for i in range(struct.unpack_from("<H", data, ifd)[0]):
            tag = struct.unpack_from("<H", data, ifd + 2 + 12 * i)[0]
            if tag in (256, 257):  # ImageWidth, ImageLength: one LONG each
                struct.pack_into("<HHII", data, ifd + 2 + 12 * i, tag, 4, 1, side)
        (tmp_path / "bomb.tif").write_bytes(bytes(data))
        with pytest.raises(tilesynth.ParameterError, match=f"map = .*bomb.tif.*{words}"):
            load_raster(tmp_path / "bomb.tif")
