"""Image files in and out (Pillow), with atomic writes.

``load_image`` returns float32 ``(H, W, C)`` in [0, 1] and the file's bit depth; 16-bit PNGs keep their
precision (grey through Pillow; RGB, RGBA and grey+alpha through :func:`read_png`, because Pillow decodes those
to 8 bits). ``load_raster`` returns an image in its own dtype (uint8, uint16 or float32: PNG, TIFF, ``.npy``),
for maps that must be carried through synthesis without any conversion. ``save_image`` writes 8- or 16-bit PNG
(or any format Pillow knows by extension) through a temporary file and ``os.replace``, so an error or Ctrl-C
never leaves a partial file behind.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

import numpy as np

from ._validate import as_image, to_uint
from .errors import ParameterError


_PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def read_png(path: str | os.PathLike[str]) -> np.ndarray | None:
    """Decode a non-interlaced 8- or 16-bit grey / grey+alpha / RGB / RGBA PNG exactly.

    Returns ``(H, W, C)`` uint8 or uint16 (big-endian samples converted to native order), or ``None`` for a PNG
    this reader leaves to Pillow (palette, bit depths below 8, interlaced). Raises :class:`ParameterError` for
    a damaged file (bad signature, truncated chunks, CRC or inflate errors, wrong data length). Chunks are
    checked by CRC; the scanline filters are undone by the Rust kernel ``_core.png_unfilter``.
    """
    import struct
    import zlib

    from . import _core

    p = Path(path)
    data = p.read_bytes()
    name = str(p)
    if data[:8] != _PNG_MAGIC:
        raise ParameterError(f"input = {name!r}: not a PNG file")
    pos, idat, ihdr = 8, [], None
    while True:
        if pos + 8 > len(data):
            raise ParameterError(f"input = {name!r}: truncated PNG (no IEND chunk)")
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        tag = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        crc = data[pos + 8 + length : pos + 12 + length]
        if len(body) != length or len(crc) != 4:
            raise ParameterError(f"input = {name!r}: truncated PNG chunk {tag!r}")
        if struct.unpack(">I", crc)[0] != zlib.crc32(tag + body) & 0xFFFFFFFF:
            raise ParameterError(f"input = {name!r}: PNG chunk {tag!r} fails its CRC check (damaged file)")
        pos += 12 + length
        if tag == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat.append(body)
        elif tag == b"IEND":
            break
    if ihdr is None:
        raise ParameterError(f"input = {name!r}: PNG without IHDR")
    w, h, depth, colour, _, _, interlace = ihdr
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour)
    if channels is None or depth not in (8, 16) or interlace != 0:
        return None
    if w == 0 or h == 0:
        raise ParameterError(f"input = {name!r}: the image is {w}x{h} pixels")
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error as exc:
        raise ParameterError(f"input = {name!r}: corrupt PNG image data ({exc})") from None
    bpp = channels * depth // 8
    try:
        flat = _core.png_unfilter(raw, h, w * bpp, bpp)
    except ValueError as exc:
        raise ParameterError(f"input = {name!r}: corrupt PNG image data ({exc})") from None
    dtype = np.dtype(">u2") if depth == 16 else np.dtype(np.uint8)
    arr = np.frombuffer(flat, dtype=dtype).reshape(h, w, channels)
    return arr.astype(np.uint16 if depth == 16 else np.uint8)


def _png_header(p: Path) -> tuple[int, int] | None:
    """(bit depth, colour type) of a PNG file, or None if ``p`` is not a PNG."""
    with open(p, "rb") as fh:
        head = fh.read(33)
    if head[:8] != _PNG_MAGIC or head[12:16] != b"IHDR" or len(head) < 26:
        return None
    return head[24], head[25]


def load_raster(path: str | os.PathLike[str]) -> np.ndarray:
    """Read an image or array file in its own sample type, without any conversion.

    ``.npy`` files (no pickles) must hold a 2-d or 3-d uint8, uint16 or float32 array; PNGs are decoded
    exactly (8/16-bit, :func:`read_png`); other formats through Pillow, keeping 16-bit integer and 32-bit float
    modes ("I;16", "F"). Returns ``(H, W, C)``.
    """
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    name = str(p)
    if not p.is_file():
        raise ParameterError(f"map = {name!r}: no such file")
    if p.suffix.lower() == ".npy":
        try:
            arr = np.load(p, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise ParameterError(f"map = {name!r}: not a readable .npy array ({exc})") from None
        if arr.dtype not in (np.uint8, np.uint16, np.float32) or arr.ndim not in (2, 3) or arr.size == 0:
            raise ParameterError(
                f"map = {name!r}: array of shape {arr.shape} and dtype {arr.dtype}; expected a non-empty 2-d or "
                "3-d uint8, uint16 or float32 array"
            )
    else:
        hdr = _png_header(p)
        arr = read_png(p) if hdr is not None else None
        if arr is None:
            try:
                with Image.open(p) as im:
                    im.load()
                    if im.mode in ("I;16", "I;16B", "I;16L"):
                        arr = np.asarray(im).astype(np.uint16)
                    elif im.mode == "F":
                        arr = np.asarray(im, dtype=np.float32)
                    else:
                        if im.mode not in ("L", "LA", "RGB", "RGBA"):
                            im = im.convert("RGBA" if "A" in im.mode or "transparency" in im.info else "RGB")
                        arr = np.asarray(im)
            except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
                raise ParameterError(f"map = {name!r}: not a readable image ({exc})") from None
    if arr.ndim == 2:
        arr = arr[:, :, None]
    return np.ascontiguousarray(arr)


def load_image(path: str | os.PathLike[str]) -> tuple[np.ndarray, int]:
    """Read an image file.

    Returns
    -------
    image : ndarray
        float32 ``(H, W, C)`` in [0, 1], C = 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA).
    bits : int
        8 or 16, the precision of the file.

    Raises
    ------
    ParameterError
        If the file does not exist, is not an image, or cannot be decoded (the message names the path).
    """
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    if not p.is_file():
        raise ParameterError(f"input = {str(p)!r}: no such file")
    hdr = _png_header(p)
    if hdr is not None and hdr[0] == 16:
        arr16 = read_png(p)
        if arr16 is not None:
            return as_image(arr16, "input"), 16
    try:
        with Image.open(p) as im:
            im.load()
            mode = im.mode
            if mode in ("I;16", "I;16B", "I;16L", "I"):
                arr = np.asarray(im, dtype=np.int64)
                if arr.min() < 0 or arr.max() > 65535:
                    raise ParameterError(f"input = {str(p)!r}: 32-bit integer images are not supported")
                return as_image(arr.astype(np.uint16), "input"), 16
            if mode == "F":
                raise ParameterError(f"input = {str(p)!r}: floating-point image files are not supported")
            if mode not in ("L", "LA", "RGB", "RGBA"):
                im = im.convert("RGBA" if "A" in mode or "transparency" in im.info else "RGB")
            arr = np.asarray(im)
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        if isinstance(exc, ParameterError):
            raise
        raise ParameterError(f"input = {str(p)!r}: not a readable image ({exc})") from None
    return as_image(arr, "input"), 8


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success move it into place, on any error remove it."""
    target = Path(path)
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"output = {str(target)!r}: directory {str(parent)!r} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates 0600 files; give the result the permissions a plain open() would have
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        os.replace(tmp_path, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        raise


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; it replaces ``path`` only if the block succeeds."""
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        yield fh


def save_image(path: str | os.PathLike[str], image: np.ndarray, bits: int = 8) -> None:
    """Write ``image`` (float in [0, 1], or uint8/uint16 as is) to ``path`` atomically.

    ``bits=16`` writes 16-bit PNG (greyscale and RGB; Pillow cannot write 16-bit RGB, so RGB(A) 16-bit data is
    written with the ``png`` writer of :func:`_write_png16`).
    """
    arr = np.asarray(image)
    if arr.dtype not in (np.uint8, np.uint16):
        arr = to_uint(as_image(arr, "image"), bits)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    target = Path(path)
    fmt = _format_for(target)
    with atomic_path(target) as tmp:
        if arr.dtype == np.uint16:
            if fmt != "PNG":
                raise ParameterError(f"output = {str(target)!r}: 16-bit output needs a .png file")
            _write_png16(tmp, arr)
        else:
            from PIL import Image

            Image.fromarray(np.ascontiguousarray(arr)).save(tmp, format=fmt)


def _format_for(path: Path) -> str:
    from PIL import Image

    Image.init()
    ext = path.suffix.lower()
    fmt = Image.EXTENSION.get(ext)
    if fmt is None:
        raise ParameterError(
            f"output = {str(path)!r}: unknown image extension {ext or '(none)'!r}; use .png, .jpg, .tif, ..."
        )
    return fmt


def _write_png16(path: Path, arr: np.ndarray) -> None:
    """Minimal lossless 16-bit PNG writer (grey, grey+alpha, RGB, RGBA) using zlib; Pillow lacks 16-bit RGB."""
    import struct
    import zlib

    h, w = arr.shape[:2]
    channels = 1 if arr.ndim == 2 else arr.shape[2]
    colour_type = {1: 0, 2: 4, 3: 2, 4: 6}[channels]
    raw = np.ascontiguousarray(arr.reshape(h, w * channels).astype(">u2")).view(np.uint8)
    rows = np.concatenate([np.zeros((h, 1), np.uint8), raw.reshape(h, -1)], axis=1)

    def chunk(tag: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", w, h, 16, colour_type, 0, 0, 0)
    with open(path, "wb") as fh:
        fh.write(b"\x89PNG\r\n\x1a\n")
        fh.write(chunk(b"IHDR", ihdr))
        fh.write(chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)))
        fh.write(chunk(b"IEND", b""))
