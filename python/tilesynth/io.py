"""Image files in and out (Pillow), with atomic writes.

``load_image`` returns float32 ``(H, W, C)`` in [0, 1] and the file's bit depth. What it does with each kind of
file (every case is tested, see ``docs/failure-modes.md``):

- **Greyscale** (``L``, 1-bit) is one channel, C = 1; grey+alpha C = 2. Nothing is expanded to RGB: every
  kernel works on any C in 1..4, and a grey exemplar gives grey tiles.
- **RGBA / LA**: the alpha channel is kept as one more channel (C = 4 / 2) and matched like the colours (SSD
  and seam weights over all channels), so tiles reproduce the exemplar's transparency and ``save_image`` writes
  it back. Premultiplied modes (``RGBa``, ``La``) are converted to straight alpha first.
- **Palette** (``P``, ``PA``) becomes RGB, or RGBA when the palette has transparency.
- **CMYK, YCbCr, LAB, HSV** become RGB (Pillow's conversion).
- **16-bit PNG** keeps its full precision (``bits = 16``): greyscale through Pillow, grey+alpha / RGB / RGBA
  (which Pillow reduces to 8 bits) through :func:`_read_png16`, our own reader (:func:`_decode_png`: chunks and
  zlib here, the scanline filters in Rust). 16-bit greyscale TIFF too; other 16-bit colour formats are reduced to 8 bits by
  Pillow (``bits = 8``).
- **Animated** files (GIF, APNG, WebP, multi-page TIFF): the first frame, as a viewer shows it before
  playing.
- **EXIF orientation** is applied (``ImageOps.exif_transpose``): the exemplar is upright as a viewer shows
  it, so "the texture" is what the user sees.
- **Refused** with :class:`ParameterError` naming the path: missing files, directories, unreadable files, files
  that are not images, truncated or corrupt data, 0-pixel images, 32-bit integer and floating-point image
  files, and images of more than :data:`MAX_PIXELS` pixels (see :func:`pixel_limit`).

``load_raster`` returns an image in its own sample type (uint8, uint16 or float32: PNG, TIFF, ``.npy``), for
maps that must be carried through synthesis without any conversion (``synth --with``); :func:`read_png` is its
exact 8/16-bit PNG decoder.

``save_image`` writes 8- or 16-bit PNG (or any format Pillow knows by extension) through a temporary file and
``os.replace``, so an error or Ctrl-C never leaves a partial file behind.
"""

from __future__ import annotations

import contextlib
import os
import struct
import tempfile
import warnings
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from ._validate import as_image, to_uint
from .errors import ParameterError, ShapeError

MAX_PIXELS = 1 << 26
"""Default limit on the pixel count of an image file, 2^26 = 67,108,864 (64 Mpx, e.g. 8192 x 8192).

An exemplar is small (the papers use 128 to 512 pixels a side; the exhaustive search costs O(HW log HW) per
tile), so a larger file is almost surely a mistake or a *decompression bomb*: a few hundred bytes of PNG that
declare 100000 x 100000 pixels and would need 40 GB once decoded. The check is on the declared size, before
any pixel is decoded. At the limit, decoding takes at most about 1.3 GB (RGBA: 256 MB of bytes and 1 GB of
float32). Raise it with ``load_image(..., max_pixels=N)`` or the environment variable
:data:`MAX_PIXELS_ENV`; Pillow's own guard (``PIL.Image.MAX_IMAGE_PIXELS``, which refuses about 179 Mpx) still
applies above that.
"""

MAX_PIXELS_ENV = "TILESYNTH_MAX_PIXELS"
"""Environment variable overriding :data:`MAX_PIXELS` (a positive integer)."""

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_png(path: str | os.PathLike[str]) -> np.ndarray | None:
    """Decode a non-interlaced 8- or 16-bit grey / grey+alpha / RGB / RGBA PNG exactly.

    Returns ``(H, W, C)`` uint8 or uint16 (big-endian samples converted to native order), or ``None`` for a PNG
    this reader leaves to Pillow (palette, bit depths below 8, interlaced). Raises :class:`ParameterError` for
    a damaged file (bad signature, truncated chunks, CRC or inflate errors, wrong data length). Chunks are
    checked by CRC; the scanline filters are undone by the Rust kernel ``_core.png_unfilter``.
    """
    p = Path(path)
    # our reader for 8- and 16-bit grey, grey+alpha, RGB and RGBA without interlacing; Pillow does the rest
    return _decode_png(p.read_bytes(), f"input = {str(p)!r}", lambda depth, ctype, interlace: depth in (8, 16)
                       and ctype in (0, 2, 4, 6) and interlace == 0)


def load_raster(path: str | os.PathLike[str], max_pixels: int | None = None) -> np.ndarray:
    """Read an image or array file in its own sample type, without any conversion.

    ``.npy`` files (no pickles) must hold a 2-d or 3-d uint8, uint16 or float32 array; PNGs are decoded
    exactly (8/16-bit, :func:`read_png`); other formats through Pillow, keeping 16-bit integer and 32-bit float
    modes ("I;16", "F"). Returns ``(H, W, C)``. Image files of more than ``max_pixels`` pixels are refused on
    their declared size, before decoding, as by :func:`load_image`.
    """
    from PIL import Image, UnidentifiedImageError

    limit = pixel_limit(max_pixels)
    p = Path(path)
    name = str(p)
    where = f"map = {name!r}"
    if not p.is_file():
        raise ParameterError(f"{where}: no such file")
    if p.suffix.lower() == ".npy":
        arr = read_npy(p, where)
        if arr.dtype not in (np.uint8, np.uint16, np.float32) or arr.ndim not in (2, 3) or arr.size == 0:
            raise ParameterError(
                f"{where}: array of shape {arr.shape} and dtype {arr.dtype}; expected a non-empty 2-d or "
                "3-d uint8, uint16 or float32 array"
            )
    else:
        hdr = _png_header(p)
        if hdr is not None:
            _check_size(where, hdr[0], hdr[1], limit)
        arr = read_png(p) if hdr is not None else None
        if arr is None:
            with warnings.catch_warnings():
                # our own pixel limit applies; Pillow's other warnings are about odd metadata (see load_image)
                warnings.filterwarnings("ignore", module=r"PIL(\.|$)")
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                try:
                    with Image.open(p) as im:
                        _check_size(where, *im.size, limit)
                        im.load()
                        if im.mode in ("I;16", "I;16B", "I;16L"):
                            arr = np.asarray(im).astype(np.uint16)
                        elif im.mode == "F":
                            arr = np.asarray(im, dtype=np.float32)
                        else:
                            if im.mode not in ("L", "LA", "RGB", "RGBA"):
                                im = im.convert("RGBA" if "A" in im.mode or "transparency" in im.info else "RGB")
                            arr = np.asarray(im)
                except Image.DecompressionBombError as exc:
                    raise ParameterError(f"{where}: refused, {exc} (tilesynth's limit is {limit} pixels)") from None
                except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
                    raise ParameterError(f"{where}: not a readable image ({exc})") from None
    if arr.ndim == 2:
        arr = arr[:, :, None]
    return np.ascontiguousarray(arr)


def read_npy(path: str | os.PathLike[str], where: str) -> np.ndarray:
    """The array of a ``.npy`` file (no pickles), or :class:`ParameterError` starting with ``where``.

    Memory-mapped first, so a header that declares more data than the file holds (100000 x 100000 in 128
    bytes) fails cheaply instead of allocating what it declares. numpy reports an empty file with
    ``EOFError`` and some damaged headers with the ``tokenize.TokenError`` of its header parser.
    """
    import tokenize

    try:
        with np.errstate(over="ignore"):  # numpy's size of an absurd declared shape overflows, then raises
            return np.array(np.load(path, mmap_mode="r", allow_pickle=False))
    except (OSError, ValueError, EOFError, SyntaxError, tokenize.TokenError) as exc:
        raise ParameterError(f"{where}: not a readable .npy array ({exc})") from None


def pixel_limit(value: int | None = None) -> int:
    """The pixel limit in force: ``value`` if given, else ``TILESYNTH_MAX_PIXELS``, else :data:`MAX_PIXELS`."""
    from ._validate import positive_int

    if value is not None:
        return positive_int(value, "max_pixels")
    env = os.environ.get(MAX_PIXELS_ENV, "").strip()
    if not env:
        return MAX_PIXELS
    try:
        n = int(env)
    except ValueError:
        n = 0
    if n < 1:
        raise ParameterError(f"{MAX_PIXELS_ENV} = {env!r}: must be a positive integer (a pixel count)")
    return n


def load_image(path: str | os.PathLike[str], max_pixels: int | None = None) -> tuple[np.ndarray, int]:
    """Read an image file (see the module docstring for how each kind of file is treated).

    Parameters
    ----------
    path : the file.
    max_pixels : refuse images with more pixels than this (default :data:`MAX_PIXELS` or
        ``TILESYNTH_MAX_PIXELS``), checked on the declared size before decoding.

    Returns
    -------
    image : ndarray
        float32 ``(H, W, C)`` in [0, 1], C = 1 (grey), 2 (grey+alpha), 3 (RGB) or 4 (RGBA).
    bits : int
        8 or 16, the precision of the file.

    Raises
    ------
    ParameterError
        If the file does not exist, cannot be read, is not an image, cannot be decoded (truncated, corrupt),
        has zero pixels or too many, or holds 32-bit / floating-point samples (the message names the path).
    """
    from PIL import Image, UnidentifiedImageError

    limit = pixel_limit(max_pixels)
    p = Path(path)
    where = f"input = {str(p)!r}"
    if not p.exists():
        raise ParameterError(f"{where}: no such file")
    if p.is_dir():
        raise ParameterError(f"{where}: is a directory, expected an image file")
    if not p.is_file():
        raise ParameterError(f"{where}: not a regular file")
    if not os.access(p, os.R_OK):
        raise ParameterError(f"{where}: cannot read (permission denied)")
    with warnings.catch_warnings():
        # We apply our own pixel limit; Pillow's other warnings are about odd but decodable metadata of real
        # files (camera EXIF, TIFF tags): what decodes is returned, what does not raises below.
        warnings.filterwarnings("ignore", module=r"PIL(\.|$)")
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        try:
            return _load(p, where, limit)
        except (ParameterError, ShapeError, MemoryError):
            raise
        except Image.DecompressionBombError as exc:
            raise ParameterError(
                f"{where}: refused, {exc} (tilesynth's limit is {limit} pixels; see max_pixels / {MAX_PIXELS_ENV})"
            ) from None
        except UnidentifiedImageError:
            raise ParameterError(f"{where}: not a readable image (not an image format Pillow knows)") from None
        except PermissionError as exc:
            raise ParameterError(f"{where}: cannot read ({exc.strerror or exc})") from None
        except Exception as exc:  # noqa: BLE001
            # Pillow parses untrusted bytes: a corrupt or truncated file can fail with OSError, ValueError,
            # SyntaxError, struct.error, IndexError, ... all of which mean the same thing to the user.
            raise ParameterError(f"{where}: not a readable image ({type(exc).__name__}: {exc})") from None


def _load(p: Path, where: str, limit: int) -> tuple[np.ndarray, int]:
    """The body of :func:`load_image` (its errors are mapped by the caller)."""
    from PIL import Image, ImageOps

    header = _png_header(p)
    if header is not None:  # a PNG: size checks on its header, before Pillow's own (clearer messages)
        _check_size(where, header[0], header[1], limit)
    im = Image.open(p)
    with im:
        _check_size(where, *im.size, limit)
        if im.format == "PNG":
            arr16 = _read_png16(p, limit)
            if arr16 is not None:
                return as_image(_exif_orient(im, arr16), "input"), 16
        if getattr(im, "n_frames", 1) > 1:
            im.seek(0)  # animated / multi-page: the first frame
        im.load()
        im = ImageOps.exif_transpose(im)
        mode = im.mode
        if mode in ("I;16", "I;16B", "I;16L", "I"):
            arr = np.asarray(im, dtype=np.int64)
            if arr.min() < 0 or arr.max() > 65535:
                raise ParameterError(f"{where}: 32-bit integer images are not supported")
            return as_image(arr.astype(np.uint16), "input"), 16
        if mode == "F":
            raise ParameterError(f"{where}: floating-point image files are not supported")
        if mode == "1":
            im = im.convert("L")
        elif mode in ("RGBa", "PA") or (mode == "P" and "transparency" in im.info):
            im = im.convert("RGBA")
        elif mode == "La":
            im = im.convert("LA")
        elif mode not in ("L", "LA", "RGB", "RGBA"):
            im = im.convert("RGBA" if "A" in mode or "transparency" in im.info else "RGB")
        arr = np.asarray(im)
    return as_image(arr, "input"), 8


def _check_size(where: str, w: int, h: int, limit: int) -> None:
    if w * h > limit:
        raise ParameterError(
            f"{where}: {w}x{h} = {w * h} pixels exceeds the limit of {limit} pixels (an exemplar is small; a "
            f"tiny file declaring a huge size is a decompression bomb). Raise it with max_pixels or "
            f"{MAX_PIXELS_ENV} if you mean it"
        )
    if w == 0 or h == 0:
        raise ShapeError(f"{where}: the image is {w}x{h} pixels, expected at least 1x1")


def _png_header(path: Path) -> tuple[int, int, int, int, int] | None:
    """(width, height, bit depth, colour type, interlace) from a PNG's IHDR, None if not a PNG."""
    with open(path, "rb") as fh:
        head = fh.read(33)
    if head[:8] != _PNG_SIGNATURE or len(head) < 29 or head[12:16] != b"IHDR":
        return None
    w, h, depth, ctype, _, _, interlace = struct.unpack(">IIBBBBB", head[16:29])
    return w, h, depth, ctype, interlace


def _exif_orient(im: Any, arr: np.ndarray) -> np.ndarray:
    """Apply the EXIF orientation of ``im`` (a PNG may carry an eXIf chunk) to the array ``arr`` (H, W, C),
    as ``PIL.ImageOps.exif_transpose`` does for the images Pillow decodes (2 mirror, 3 rotate 180, 4 flip,
    5 transpose, 6 rotate 90 clockwise, 7 transverse, 8 rotate 90 counter-clockwise)."""
    try:
        orientation = int(im.getexif().get(0x0112, 1))
    except Exception:  # noqa: BLE001 - unreadable EXIF: like no EXIF
        orientation = 1
    ops = {
        2: lambda a: a[:, ::-1],
        3: lambda a: a[::-1, ::-1],
        4: lambda a: a[::-1],
        5: lambda a: a.transpose(1, 0, 2),
        6: lambda a: np.rot90(a, -1),
        7: lambda a: np.rot90(a, 2).transpose(1, 0, 2),
        8: lambda a: np.rot90(a, 1),
    }
    op = ops.get(orientation)
    return np.ascontiguousarray(op(arr)) if op else arr


def _read_png16(path: Path, limit: int) -> np.ndarray | None:
    """Decode a 16-bit grey+alpha / RGB / RGBA PNG at full precision: uint16 ``(H, W, C)``.

    Returns None for every other PNG (8-bit, palette, 16-bit grey: Pillow reads those exactly). Adam7
    interlacing is handled, and a ``tRNS`` colour key becomes an alpha channel (as Pillow does for 8 bits).
    """
    return _decode_png(path.read_bytes(), f"input = {str(path)!r}",
                       lambda depth, ctype, interlace: depth == 16 and ctype in (2, 4, 6), limit=limit, trns=True)


def _decode_png(
    data: bytes,
    where: str,
    accept: Callable[[int, int, int], bool],
    limit: int | None = None,
    trns: bool = False,
) -> np.ndarray | None:
    """The one PNG decoder behind :func:`read_png` and :func:`_read_png16` (chunks and zlib here, the scanline
    filters in the Rust kernel ``_core.png_unfilter``).

    Returns ``(H, W, C)`` uint8 / uint16 (native order), or None when ``accept(bit depth, colour type,
    interlace)`` is false (the caller leaves that file to Pillow). Checks every chunk's length and CRC,
    handles Adam7, applies a 16-bit RGB ``tRNS`` colour key as an alpha channel when ``trns``, and inflates at
    most the number of bytes the header implies (no decompression bomb). Raises :class:`ParameterError`
    starting with ``where`` on anything damaged, and on more than ``limit`` pixels.
    """
    from . import _core

    if data[:8] != _PNG_SIGNATURE:
        raise ParameterError(f"{where}: not a PNG file")
    ihdr, idat, key = None, [], None
    pos = 8
    while True:
        if pos + 8 > len(data):
            raise ParameterError(f"{where}: not a readable image (truncated PNG: no IEND chunk)")
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        tag = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        crc = data[pos + 8 + length : pos + 12 + length]
        if len(body) != length or len(crc) != 4:
            raise ParameterError(f"{where}: not a readable image (truncated PNG chunk {tag!r})")
        if struct.unpack(">I", crc)[0] != zlib.crc32(tag + body) & 0xFFFFFFFF:
            raise ParameterError(f"{where}: not a readable image (PNG chunk {tag!r} fails its CRC check)")
        pos += 12 + length
        if tag == b"IHDR" and length == 13:
            ihdr = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat.append(body)
        elif tag == b"tRNS" and length == 6:
            key = struct.unpack(">HHH", body)
        elif tag == b"IEND":
            break
    if ihdr is None:
        raise ParameterError(f"{where}: not a readable image (PNG without IHDR)")
    w, h, depth, ctype, comp, filt, interlace = ihdr
    if not accept(depth, ctype, interlace):
        return None
    if comp != 0 or filt != 0 or interlace not in (0, 1):
        raise ParameterError(f"{where}: unknown PNG compression, filter or interlace method")
    if w == 0 or h == 0:
        raise ParameterError(f"{where}: the image is {w}x{h} pixels")
    if limit is not None and w * h > limit:
        raise ParameterError(f"{where}: {w}x{h} pixels, more than the limit of {limit}")
    channels = {0: 1, 2: 3, 4: 2, 6: 4}[ctype]
    bpp = channels * depth // 8
    passes = _adam7(w, h) if interlace else [(0, 0, 1, 1, w, h)]
    expected = sum(ph * (pw * bpp + 1) for *_, pw, ph in passes if pw and ph)
    try:
        raw = zlib.decompressobj().decompress(b"".join(idat), expected + 1)
    except zlib.error as exc:
        raise ParameterError(f"{where}: not a readable image (corrupt PNG data: {exc})") from None
    if len(raw) < expected:
        raise ParameterError(f"{where}: not a readable image (truncated PNG data: {len(raw)} of {expected} bytes)")
    sample = np.dtype(">u2") if depth == 16 else np.dtype(np.uint8)
    out = np.empty((h, w, channels), np.uint16 if depth == 16 else np.uint8)
    off = 0
    for x0, y0, dx, dy, pw, ph in passes:
        if not (pw and ph):
            continue
        n = ph * (pw * bpp + 1)
        try:
            rows = _core.png_unfilter(np.frombuffer(raw, np.uint8, count=n, offset=off), ph, pw * bpp, bpp)
        except ValueError as exc:  # an unknown filter type byte
            raise ParameterError(f"{where}: not a readable image (corrupt PNG data: {exc})") from None
        off += n
        out[y0::dy, x0::dx] = rows.view(sample).reshape(ph, pw, channels)
    if trns and key is not None and ctype == 2 and depth == 16:
        alpha = np.where((out == np.array(key, np.uint16)).all(axis=2), 0, 65535).astype(np.uint16)
        out = np.concatenate([out, alpha[..., None]], axis=2)
    return out


def _adam7(w: int, h: int) -> list[tuple[int, int, int, int, int, int]]:
    """The seven Adam7 passes: (x0, y0, dx, dy, pass width, pass height)."""
    spec = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2), (0, 1, 1, 2)]
    return [(x0, y0, dx, dy, -(-(w - x0) // dx) if w > x0 else 0, -(-(h - y0) // dy) if h > y0 else 0)
            for x0, y0, dx, dy in spec]


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success move it into place, on any error remove it."""
    target = Path(path)
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"output = {str(target)!r}: directory {str(parent)!r} does not exist")
    if target.is_dir():
        raise ParameterError(f"output = {str(target)!r}: is a directory, expected a file name")
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
    if isinstance(bits, (bool, np.bool_)) or bits not in (8, 16):
        raise ParameterError(f"bits = {bits!r}: must be 8 or 16")
    try:
        arr = np.asarray(image)
    except (ValueError, TypeError) as exc:
        raise ShapeError(f"image is not an array ({exc})") from None
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    if arr.dtype in (np.uint8, np.uint16):
        as_image(arr[:1, :1] if arr.ndim in (2, 3) else arr, "image")  # the shape rules of as_image
        if 0 in arr.shape:
            raise ShapeError(f"image has shape {arr.shape}, expected non-empty (H, W, C)")
    else:
        arr = to_uint(as_image(arr, "image"), bits)
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    target = Path(path)
    fmt = _format_for(target)
    channels = 1 if arr.ndim == 2 else arr.shape[2]
    with atomic_path(target) as tmp:
        if arr.dtype == np.uint16:
            if fmt != "PNG":
                raise ParameterError(f"output = {str(target)!r}: 16-bit output needs a .png file")
            _write_png16(tmp, arr)
        else:
            from PIL import Image

            try:
                Image.fromarray(np.ascontiguousarray(arr)).save(tmp, format=fmt)
            except (OSError, ValueError, KeyError) as exc:
                if isinstance(exc, OSError) and exc.errno is not None:
                    raise  # a real I/O error (disk full, permissions): the caller's business
                # Pillow cannot write this mode in this format (e.g. RGBA or grey+alpha as JPEG)
                raise ParameterError(
                    f"output = {str(target)!r}: cannot write a {channels}-channel image as {fmt} ({exc}); "
                    "use .png"
                ) from None


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
