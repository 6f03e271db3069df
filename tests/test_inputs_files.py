"""Image files as users have them: every case of the "Files" table in docs/failure-modes.md.

Each test makes its file (nothing downloaded): broken files are built byte by byte, real ones with Pillow or
with tilesynth's own 16-bit PNG writer.
"""

from __future__ import annotations

import io
import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageOps

import tilesynth as ts
from tilesynth.base.validate import to_uint
from tilesynth.io.images import MAX_PIXELS, MAX_PIXELS_ENV, _exif_orient


def chunk(tag: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)


def png_bytes(
    w: int,
    h: int,
    depth: int = 8,
    ctype: int = 2,
    raw: bytes = b"",
    interlace: int = 0,
    extra: tuple[bytes, ...] = (),
) -> bytes:
    ihdr = struct.pack(">IIBBBBB", w, h, depth, ctype, 0, 0, interlace)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + b"".join(extra)
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )


def png16(arr: np.ndarray, interlace: bool = False, extra: tuple[bytes, ...] = ()) -> bytes:
    """A 16-bit PNG of ``arr`` (H, W, C) uint16, filter type 0, optionally Adam7-interlaced."""
    h, w, c = arr.shape
    ctype = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    be = arr.astype(">u2")

    def rows(a: np.ndarray) -> bytes:
        return b"".join(b"\x00" + a[y].tobytes() for y in range(a.shape[0])) if a.size else b""

    if not interlace:
        raw = rows(be)
    else:
        raw = b"".join(
            rows(be[y0::dy, x0::dx])
            for x0, y0, dx, dy in [
                (0, 0, 8, 8),
                (4, 0, 8, 8),
                (0, 4, 4, 8),
                (2, 0, 4, 4),
                (0, 2, 2, 4),
                (1, 0, 2, 2),
                (0, 1, 1, 2),
            ]
        )
    return png_bytes(w, h, 16, ctype, raw, int(interlace), extra)


def write(tmp_path, name: str, data: bytes):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def rgb(h: int = 24, w: int = 20, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8)


# ----------------------------------------------------------------------------------------------- refused
def test_missing_file(tmp_path):
    with pytest.raises(ts.ParameterError, match=r"input = .*missing\.png': no such file"):
        ts.load_image(tmp_path / "missing.png")


def test_directory(tmp_path):
    with pytest.raises(ts.ParameterError, match="is a directory"):
        ts.load_image(tmp_path)


@pytest.mark.skipif(
    hasattr(os, "geteuid") and os.geteuid() == 0, reason="root reads files without permission"
)
def test_unreadable_file_permissions(tmp_path):
    p = tmp_path / "secret.png"
    Image.fromarray(rgb()).save(p)
    p.chmod(0)
    with pytest.raises(ts.ParameterError, match="cannot read"):
        ts.load_image(p)


def test_unreadable_file(tmp_path, monkeypatch):
    """The permission error path, also where the tests run as root (which may read anything): the OS is made
    to deny the read."""
    p = tmp_path / "secret.png"
    Image.fromarray(rgb()).save(p)
    b = tmp_path / "secret.bmp"  # a format Pillow reads
    Image.fromarray(rgb()).save(b)
    real_open, real_read = Image.open, Path.read_bytes

    def deny(fp, *a, **k):
        raise PermissionError(13, "Permission denied", str(fp))

    monkeypatch.setattr(Image, "open", deny)
    with pytest.raises(ts.ParameterError, match=r"secret\.bmp': cannot read \(Permission denied\)"):
        ts.load_image(b)
    monkeypatch.setattr(Image, "open", real_open)
    monkeypatch.setattr(Path, "read_bytes", deny)  # PNGs are read as bytes for the png crate
    with pytest.raises(ts.ParameterError, match=r"secret\.png': cannot read \(Permission denied\)"):
        ts.load_image(p)
    monkeypatch.setattr(Path, "read_bytes", real_read)
    monkeypatch.setattr(os, "access", lambda *a, **k: False)
    with pytest.raises(ts.ParameterError, match="cannot read"):
        ts.load_image(p)


@pytest.mark.parametrize(
    "content", [b"this is not a PNG", b"", b"\x89PNG\r\n\x1a\n", b"GIF89a" + b"\x00" * 3]
)
def test_not_an_image(tmp_path, content):
    with pytest.raises(ts.ParameterError, match="not a readable image"):
        ts.load_image(write(tmp_path, "x.png", content))


@pytest.mark.parametrize("fmt", ["PNG", "JPEG", "PNG16"])
def test_truncated_files(tmp_path, fmt):
    """Cut a real file at many points: every cut is refused with the path named, none crashes or hangs."""
    if fmt == "PNG16":
        data = png16(np.random.default_rng(1).integers(0, 65536, (30, 25, 3), dtype=np.uint16))
    else:
        buf = io.BytesIO()
        Image.fromarray(rgb(40, 36)).save(buf, format=fmt)
        data = buf.getvalue()
    # the whole file loads; a cut of the last bytes (JPEG's EOI marker) may still decode, earlier cuts never
    ts.load_image(write(tmp_path, "whole", data))
    for cut in sorted({8, 16, 33, 40, len(data) // 3, len(data) // 2, len(data) - 40}):
        with pytest.raises(ts.ParameterError, match=r"input = .*: not a readable image"):
            ts.load_image(write(tmp_path, f"cut{cut}", data[:cut]))


def test_corrupt_png_crc(tmp_path):
    data = bytearray(png16(np.zeros((4, 4, 3), np.uint16)))
    data[-20] ^= 0xFF  # inside the IDAT chunk
    with pytest.raises(ts.ParameterError, match="not a readable image"):
        ts.load_image(write(tmp_path, "crc.png", bytes(data)))


def test_zero_pixels(tmp_path):
    for w, h in [(0, 0), (0, 5), (5, 0)]:
        with pytest.raises(ts.ShapeError, match=f"the image is {w}x{h} pixels, expected at least 1x1"):
            ts.load_image(write(tmp_path, f"z{w}{h}.png", png_bytes(w, h)))


def test_one_pixel_loads_but_is_too_small_to_build(tmp_path):
    p = tmp_path / "one.png"
    Image.fromarray(np.full((1, 1, 3), 200, np.uint8)).save(p)
    img, bits = ts.load_image(p)
    assert img.shape == (1, 1, 3) and bits == 8
    with pytest.raises(ts.ParameterError, match=r"exemplar has shape \(1, 1, 3\): too small, at least 4x4"):
        ts.build_omega(img)


def test_decompression_bomb_png(tmp_path):
    """A 100-byte PNG declaring 100000 x 100000 pixels: refused on the header, nothing decoded."""
    p = write(tmp_path, "bomb.png", png_bytes(100_000, 100_000))
    assert p.stat().st_size < 200
    with pytest.raises(
        ts.ParameterError, match=r"100000x100000 = 10000000000 pixels exceeds the limit of 67108864"
    ):
        ts.load_image(p)
    # above tilesynth's limit but below Pillow's: still refused, by tilesynth's limit
    with pytest.raises(ts.ParameterError, match="9000x9000 = 81000000 pixels exceeds the limit"):
        ts.load_image(write(tmp_path, "big.png", png_bytes(9000, 9000)))


def test_decompression_bomb_other_formats(tmp_path):
    """Formats whose header tilesynth does not read itself go through Pillow's guard, then tilesynth's."""
    buf = io.BytesIO()
    Image.fromarray(rgb(4, 4)).save(buf, format="BMP")
    data = bytearray(buf.getvalue())
    for (w, h), words in [
        ((20000, 20000), "refused, Image size"),
        ((9000, 9000), "9000x9000 = 81000000 pixels"),
    ]:
        data[18:26] = struct.pack("<ii", w, h)
        with pytest.raises(ts.ParameterError, match=words):
            ts.load_image(write(tmp_path, f"bomb{w}.bmp", bytes(data)))


def test_pixel_limit_is_documented_and_overridable(tmp_path, monkeypatch):
    assert MAX_PIXELS == 64 * 2**20
    p = tmp_path / "20x20.png"
    Image.fromarray(rgb(20, 20)).save(p)
    with pytest.raises(ts.ParameterError, match="20x20 = 400 pixels exceeds the limit of 399 pixels"):
        ts.load_image(p, max_pixels=399)
    assert ts.load_image(p, max_pixels=400)[0].shape == (20, 20, 3)
    monkeypatch.setenv(MAX_PIXELS_ENV, "100")
    with pytest.raises(ts.ParameterError, match="limit of 100 pixels"):
        ts.load_image(p)
    monkeypatch.setenv(MAX_PIXELS_ENV, "lots")
    with pytest.raises(ts.ParameterError, match="TILESYNTH_MAX_PIXELS = 'lots'"):
        ts.load_image(p)
    with pytest.raises(ts.ParameterError, match="max_pixels = 0"):
        ts.load_image(p, max_pixels=0)


# ----------------------------------------------------------------------------------------------- accepted
def test_animated_gif_gives_the_first_frame(tmp_path):
    frames = [np.full((8, 10), v, np.uint8) for v in (30, 200, 90)]
    p = tmp_path / "anim.gif"
    ims = [Image.fromarray(f).convert("P") for f in frames]
    ims[0].save(p, save_all=True, append_images=ims[1:], duration=100, loop=0)
    with Image.open(p) as im:
        assert im.n_frames == 3
    img, bits = ts.load_image(p)
    assert img.shape == (8, 10, 3) and bits == 8
    np.testing.assert_array_equal(to_uint(img, 8), np.repeat(frames[0][..., None], 3, axis=2))


def test_cmyk_becomes_rgb(tmp_path):
    src = rgb(16, 12)
    for fmt in ("JPEG", "TIFF"):
        p = tmp_path / f"cmyk.{fmt.lower()}"
        Image.fromarray(src).convert("CMYK").save(p, format=fmt)
        img, bits = ts.load_image(p)
        assert img.shape == (16, 12, 3) and bits == 8
        want = np.asarray(Image.fromarray(src).convert("CMYK").convert("RGB"))
        tol = 0 if fmt == "TIFF" else 40  # JPEG is lossy
        assert np.abs(to_uint(img, 8).astype(int) - want).max() <= tol


def test_palette_with_and_without_transparency(tmp_path):
    src = rgb(9, 7, seed=3)
    p = tmp_path / "p.png"
    Image.fromarray(src).convert("P").save(p)
    assert ts.load_image(p)[0].shape == (9, 7, 3)
    pt = tmp_path / "pt.png"
    im = Image.fromarray(src).convert("P")
    im.info["transparency"] = 0
    im.save(pt, transparency=0)
    img, _ = ts.load_image(pt)
    assert img.shape == (9, 7, 4)
    idx = np.asarray(Image.open(pt))
    np.testing.assert_array_equal(img[..., 3] == 0, idx == 0)


def test_grayscale_is_one_channel(tmp_path):
    g = rgb(10, 11)[..., 0]
    for mode, channels in [("L", 1), ("LA", 2), ("1", 1)]:
        p = tmp_path / f"g{mode}.png"
        Image.fromarray(g).convert(mode).save(p)
        img, bits = ts.load_image(p)
        assert img.shape == (10, 11, channels) and bits == 8, mode
    # and a grey exemplar builds grey tiles
    tiles = ts.build_omega(np.tile(g, (3, 3))[:, :, None], tileset="4", tile_size=8, seed=1)
    assert tiles.channels == 1


def test_rgba_alpha_is_kept_as_a_channel(tmp_path):
    a = np.random.default_rng(4).integers(0, 256, (12, 13, 4), dtype=np.uint8)
    p = tmp_path / "a.png"
    Image.fromarray(a, "RGBA").save(p)
    img, _ = ts.load_image(p)
    np.testing.assert_array_equal(to_uint(img, 8), a)
    # with alpha="colour" the alpha channel goes through the build and back out (the default, "auto", reads
    # an alpha that is not opaque everywhere as a mask: tests/test_masks.py, issue 14)
    tiles = ts.build_omega(np.tile(img, (3, 3, 1)), tileset="4", tile_size=8, seed=2, alpha="colour")
    out, _ = ts.synthesize(tiles, 20, 20, seed=1, dtype=np.uint8)
    q = tmp_path / "out.png"
    ts.save_image(q, out)
    with Image.open(q) as im:
        assert im.mode == "RGBA"


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
@pytest.mark.parametrize("interlace", [False, True])
def test_16_bit_png_keeps_full_precision(tmp_path, channels, interlace):
    a = np.random.default_rng(channels).integers(0, 65536, (13, 11, channels), dtype=np.uint16)
    p = write(tmp_path, "x16.png", png16(a, interlace))
    img, bits = ts.load_image(p)
    assert bits == 16 and img.shape == a.shape
    np.testing.assert_array_equal(to_uint(img, 16), a)
    # and save_image writes it back losslessly
    q = tmp_path / "back.png"
    ts.save_image(q, to_uint(img, 16))
    np.testing.assert_array_equal(to_uint(ts.load_image(q)[0], 16), a)


def test_16_bit_png_filters_and_colour_key(tmp_path):
    """Every PNG filter type (our unfiltering against a real encoder's output: zlib + the spec's filters in
    Rust), and a tRNS colour key, which becomes an alpha channel as Pillow does for 8-bit files."""
    a = np.random.default_rng(9).integers(0, 65536, (6, 5, 3), dtype=np.uint16)
    a[2, 3] = (1, 2, 3)
    be = a.astype(">u2").view(np.uint8).reshape(6, 5 * 6).astype(np.int64)
    raw = b""
    for y in range(6):
        kind = y % 5
        prev = be[y - 1] if y else np.zeros(30, np.int64)
        cur = be[y]
        out = []
        for i in range(30):
            left = cur[i - 6] if i >= 6 else 0
            ul = prev[i - 6] if i >= 6 else 0
            p = left + prev[i] - ul
            paeth = min((abs(p - left), 0, left), (abs(p - prev[i]), 1, prev[i]), (abs(p - ul), 2, ul))[2]
            pred = [0, left, prev[i], (left + prev[i]) // 2, paeth][kind]
            out.append((cur[i] - pred) % 256)
        raw += bytes([kind]) + bytes(out)
    trns = chunk(b"tRNS", struct.pack(">HHH", 1, 2, 3))
    p = write(tmp_path, "f.png", png_bytes(5, 6, 16, 2, raw, 0, (trns,)))
    img, bits = ts.load_image(p)
    assert bits == 16 and img.shape == (6, 5, 4)
    np.testing.assert_array_equal(to_uint(img, 16)[..., :3], a)
    alpha = to_uint(img, 16)[..., 3]
    assert alpha[2, 3] == 0 and (np.delete(alpha.ravel(), 2 * 5 + 3) == 65535).all()


def test_16_bit_grey_png_through_pillow(tmp_path):
    a = np.random.default_rng(5).integers(0, 65536, (7, 9), dtype=np.uint16)
    p = tmp_path / "g16.png"
    Image.fromarray(a).save(p)  # Pillow writes I;16 greyscale itself
    img, bits = ts.load_image(p)
    assert bits == 16
    np.testing.assert_array_equal(to_uint(img, 16)[..., 0], a)


def exif(orientation: int) -> bytes:
    e = Image.Exif()
    e[0x0112] = orientation
    return e.tobytes()


def test_exif_rotated_jpeg_is_upright(tmp_path):
    """A camera JPEG stored landscape with "rotate 90 CW" in its EXIF loads as the viewer shows it."""
    src = np.zeros((40, 64, 3), np.uint8)
    src[:20, :32] = (250, 10, 10)  # red block top-left of the stored pixels
    p = tmp_path / "cam.jpg"
    Image.fromarray(src).save(p, exif=exif(6), quality=95)
    img, _ = ts.load_image(p)
    assert img.shape == (64, 40, 3)
    up = np.rot90(src, -1)  # orientation 6: rotate 90 degrees clockwise to display
    assert np.abs(to_uint(img, 8).astype(int) - up).mean() < 4


@pytest.mark.parametrize("orientation", range(1, 9))
def test_exif_orientations_match_pillow(tmp_path, orientation):
    """Our orientation table (used for 16-bit PNGs, which Pillow cannot rotate) against Pillow's
    exif_transpose on an 8-bit image, for all eight EXIF orientations; then a 16-bit PNG with an eXIf chunk."""
    src = rgb(5, 7, seed=orientation)
    p = tmp_path / "o.png"
    Image.fromarray(src).save(p, exif=exif(orientation))
    with Image.open(p) as im:
        want = np.asarray(ImageOps.exif_transpose(im))
        np.testing.assert_array_equal(_exif_orient(im, src), want)
    np.testing.assert_array_equal(to_uint(ts.load_image(p)[0], 8), want)
    a16 = src.astype(np.uint16) * 257
    q = write(
        tmp_path,
        "o16.png",
        png16(
            a16,
            extra=(
                chunk(
                    b"eXIf",
                    exif(orientation)[6:] if exif(orientation).startswith(b"Exif") else exif(orientation),
                ),
            ),
        ),
    )
    img, bits = ts.load_image(q)
    assert bits == 16
    np.testing.assert_array_equal(to_uint(img, 16), want.astype(np.uint16) * 257)


@pytest.mark.parametrize("mode", ["F", "I"])
def test_float_and_32_bit_files_are_refused(tmp_path, mode):
    p = tmp_path / f"{mode}.tif"
    data = np.full((4, 4), 1e6 if mode == "F" else 70000, np.float32 if mode == "F" else np.int32)
    Image.fromarray(data, mode).save(p)
    with pytest.raises(ts.ParameterError, match="floating-point|32-bit integer"):
        ts.load_image(p)
