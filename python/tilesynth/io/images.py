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
- **PNG** (every PNG, 8- and 16-bit, any colour type) is decoded by the Rust ``png`` crate of image-rs
  (maintained and fuzzed upstream; :func:`read_png`), not by Pillow, so both bit depths get the same checks:
  a file whose compressed data ends before the last row, a chunk that fails its CRC, a second IHDR, a
  missing IEND or corrupt deflate data is refused (Pillow zero-fills truncated 8-bit data). 16-bit PNGs keep
  their full precision (``bits = 16``); palettes and bit depths below 8 become 8-bit, and a ``tRNS`` chunk
  becomes an alpha channel at every bit depth.
- **OpenEXR** (``.exr``, half or float, through the Rust ``exr`` crate; :func:`read_exr`): the first layer,
  channels R, G, B, A (or Y, A). ``load_image`` needs 1 to 4 channels of finite values in [0, 1] (an HDR
  exemplar is refused with its range, NaN and infinity are refused) and reports ``bits = 16`` (the precision
  its PNG outputs get); ``load_raster`` returns any channel count and any values as float32.
- **TIFF** 16-bit greyscale keeps its precision; 16-bit colour TIFF is reduced to 8 bits by Pillow
  (``bits = 8``; convert it to a 16-bit PNG to keep the precision).
- **Animated** files (GIF, APNG, WebP, multi-page TIFF): the first frame, as a viewer shows it before
  playing.
- **EXIF orientation** is applied (``ImageOps.exif_transpose``): the exemplar is upright as a viewer shows
  it, so "the texture" is what the user sees.
- **Refused** with :class:`ParameterError` naming the path: missing files, directories, unreadable files, files
  that are not images, truncated or corrupt data, 0-pixel images, 32-bit integer and floating-point image
  files, and images of more than :data:`MAX_PIXELS` pixels (see :func:`pixel_limit`).

``load_raster`` returns an image in its own sample type (uint8, uint16 or float32: PNG, EXR, TIFF, ``.npy``),
for maps that must be carried through synthesis without any conversion (``synth --with``).

``save_image`` writes 8- or 16-bit PNG through one fast encoder (:func:`encode_png`: adaptive filters, deflate
in parallel over row bands, ``compression`` fast / default / best), OpenEXR (half or float, any channel
count), or any other format Pillow knows by extension, through a temporary file and ``os.replace``, so an
error or Ctrl-C never leaves a partial file behind.
"""

from __future__ import annotations

import os
import struct
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..base.validate import as_image, to_uint
from ..errors import ParameterError, ShapeError
from .atomic import (  # noqa: F401 - check_writable, file_set, pending_path re-exported
    atomic_open,
    atomic_path,
    check_writable,
    file_set,
    pending_path,
)
from .codecs import (  # noqa: F401 - PNG_COMPRESSIONS and the compression setting re-exported
    _PNG_SIGNATURE,
    PNG_COMPRESSIONS,
    _compression,
    _core_reason,
    _decode_png,
    _encode_exr,
    _is_exr,
    _is_png,
    _png_compression,
    add_png_compression_argument,
    encode_png,
    set_png_compression,
)

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


def read_png(path: str | os.PathLike[str], max_pixels: int | None = None) -> np.ndarray:
    """Decode any PNG exactly: ``(H, W, C)`` uint8 or uint16 (native byte order).

    Through the ``png`` crate (``_core.png_decode``): grey, grey+alpha, RGB, RGBA at 8 or 16 bits as stored;
    palettes become RGB (RGBA with ``tRNS``), bit depths 1, 2, 4 become 8-bit, a ``tRNS`` colour key becomes
    an alpha channel; Adam7 is handled. Raises :class:`ParameterError` for a damaged file (bad signature,
    truncated chunks or image data, CRC or inflate errors, a second IHDR, no IEND) and for more than
    ``max_pixels`` pixels (checked on the declared size, before decoding).
    """
    p = Path(path)
    where = f"input = {str(p)!r}"
    data = _read_bytes(p, where)
    _check_png_header(data, where, pixel_limit(max_pixels))
    return _decode_png(data, where, pixel_limit(max_pixels))[0]


def read_exr(
    path: str | os.PathLike[str], max_pixels: int | None = None
) -> tuple[np.ndarray, list[str], bool]:
    """Decode the first layer of an OpenEXR file: float32 ``(H, W, C)``, the channel names, and whether every
    channel is stored as half floats.

    Through the ``exr`` crate (``_core.exr_decode``): half and float channels exactly, 32-bit unsigned integer
    channels as float32; channels ordered R, G, B, A (or Y, A) when so named, else by name. Deep data,
    subsampled channels, damaged or truncated files and more than ``max_pixels`` pixels (on the declared
    size) are refused with :class:`ParameterError`. Values are returned as stored (NaN and infinity
    included): the consumer decides (:func:`load_image` refuses them).
    """
    from .. import _core

    p = Path(path)
    where = f"input = {str(p)!r}"
    data = _read_bytes(p, where)
    try:
        arr, names, half = _core.exr_decode(data, pixel_limit(max_pixels))
    except ParameterError as exc:
        reason = _core_reason(exc)
        if "exceeds the limit" in reason:
            raise ParameterError(f"{where}: {reason}") from None
        raise ParameterError(f"{where}: not a readable image ({reason})") from None
    return arr, list(names), bool(half)


def check_input_file(path: str | os.PathLike[str], where: str) -> Path:
    """Raise :class:`ParameterError` starting with ``where`` unless ``path`` is a regular file, saying what it
    is instead: missing, a directory, or a FIFO, device or socket (reading a FIFO would block, a device could
    be endless). The one check of every image, map, mask and array input."""
    p = Path(path)
    if not p.exists():
        raise ParameterError(f"{where}: no such file")
    if p.is_dir():
        raise ParameterError(f"{where}: is a directory, expected a file")
    if not p.is_file():
        raise ParameterError(f"{where}: is not a regular file (a FIFO, device or socket)")
    return p


def _read_bytes(p: Path, where: str) -> bytes:
    check_input_file(p, where)
    try:
        return p.read_bytes()
    except OSError as exc:
        raise ParameterError(f"{where}: cannot read ({exc.strerror or exc})") from None


def load_raster(path: str | os.PathLike[str], max_pixels: int | None = None) -> np.ndarray:
    """Read an image or array file in its own sample type, without any conversion.

    ``.npy`` files (no pickles) must hold a 2-d or 3-d uint8, uint16 or float32 array; PNGs are decoded
    exactly (8/16-bit, :func:`read_png`); OpenEXR as float32 with any channel count and any values
    (:func:`read_exr`); other formats through Pillow, keeping 16-bit integer and 32-bit float modes ("I;16",
    "F"). Returns ``(H, W, C)``. Image files of more than ``max_pixels`` pixels are refused on their declared
    size, before decoding, as by :func:`load_image`.
    """
    from PIL import Image, UnidentifiedImageError

    limit = pixel_limit(max_pixels)
    p = Path(path)
    name = str(p)
    where = f"map = {name!r}"
    check_input_file(p, where)
    if p.suffix.lower() == ".npy":
        arr = read_npy(p, where)
        if arr.dtype not in (np.uint8, np.uint16, np.float32) or arr.ndim not in (2, 3) or arr.size == 0:
            raise ParameterError(
                f"{where}: array of shape {arr.shape} and dtype {arr.dtype}; expected a non-empty 2-d or "
                "3-d uint8, uint16 or float32 array"
            )
    elif _is_png(p):
        data = _read_bytes(p, where)
        _check_png_header(data, where, limit)
        arr = _decode_png(data, where, limit)[0]
    elif _is_exr(p):
        arr = read_exr(p, limit)[0]
    else:
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
                raise ParameterError(
                    f"{where}: refused, {exc} (tilesynth's limit is {limit} pixels)"
                ) from None
            except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
                raise ParameterError(f"{where}: not a readable image ({exc})") from None
    if arr.ndim == 2:
        arr = arr[:, :, None]
    return np.ascontiguousarray(arr)


def read_npy(path: str | os.PathLike[str], where: str) -> np.ndarray:
    """The array of a ``.npy`` file (no pickles), or :class:`ParameterError` starting with ``where``.

    Memory-mapped first, so a header that declares more data than the file holds (100000 x 100000 in 128
    bytes) fails cheaply instead of allocating what it declares. numpy reports an empty file with
    ``EOFError``, some damaged headers with the ``tokenize.TokenError`` of its header parser, and a declared
    size of 2^63 bytes or more (e.g. shape (2^61, 1) of float32) with mmap's ``OverflowError``.
    """
    import tokenize

    check_input_file(path, where)
    try:
        with np.errstate(over="ignore"):  # numpy's size of an absurd declared shape overflows, then raises
            return np.array(np.load(path, mmap_mode="r", allow_pickle=False))
    except (OSError, ValueError, EOFError, SyntaxError, OverflowError, tokenize.TokenError) as exc:
        raise ParameterError(f"{where}: not a readable .npy array ({exc})") from None


def pixel_limit(value: int | None = None) -> int:
    """The pixel limit in force: ``value`` if given, else ``TILESYNTH_MAX_PIXELS``, else :data:`MAX_PIXELS`."""
    from ..base.validate import positive_int

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
    check_input_file(p, where)
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
            raise ParameterError(
                f"{where}: not a readable image (not an image format Pillow knows)"
            ) from None
        except PermissionError as exc:
            raise ParameterError(f"{where}: cannot read ({exc.strerror or exc})") from None
        except Exception as exc:  # noqa: BLE001
            # Pillow parses untrusted bytes: a corrupt or truncated file can fail with OSError, ValueError,
            # SyntaxError, struct.error, IndexError, ... all of which mean the same thing to the user.
            raise ParameterError(f"{where}: not a readable image ({type(exc).__name__}: {exc})") from None


def _load(p: Path, where: str, limit: int) -> tuple[np.ndarray, int]:
    """The body of :func:`load_image` (its errors are mapped by the caller)."""
    from PIL import Image, ImageOps

    if _is_png(p):  # every PNG through the png crate: the same checks at every bit depth
        data = _read_bytes(p, where)
        _check_png_header(data, where, limit)
        arr, exif = _decode_png(data, where, limit)
        arr = _exif_orient_bytes(exif, arr)
        return as_image(arr, "input"), 16 if arr.dtype == np.uint16 else 8
    if _is_exr(p):
        arr, names, _ = read_exr(p, limit)
        if arr.shape[2] > 4:
            raise ParameterError(
                f"{where}: an OpenEXR image with {arr.shape[2]} channels ({', '.join(names)}); an exemplar has 1 "
                "to 4 (grey, grey+alpha, RGB, RGBA). Pass extra channels as --with maps"
            )
        try:
            img = as_image(arr, "input")
        except ParameterError as exc:
            raise ParameterError(
                f"{where}: {str(exc).removeprefix('input ')}; an exemplar is a colour texture (a linear HDR image "
                "must be tone-mapped or scaled into [0, 1] first; maps of any range go through --with)"
            ) from None
        return img, 16
    im = Image.open(p)
    with im:
        _check_size(where, *im.size, limit)
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


def _check_png_header(data: bytes, where: str, limit: int) -> None:
    """The size checks of :func:`_check_size` on a PNG's first IHDR, for their clear messages, before any
    decoding; the decoder then reads the whole file (and refuses a second IHDR)."""
    if data[:8] == _PNG_SIGNATURE and len(data) >= 24 and data[12:16] == b"IHDR":
        w, h = struct.unpack(">II", data[16:24])
        _check_size(where, w, h, limit)


def _exif_orient_bytes(exif: bytes | None, arr: np.ndarray) -> np.ndarray:
    """Apply the orientation tag of a PNG's raw eXIf chunk (parsed by Pillow's ``Image.Exif``) to ``arr``."""
    if not exif:
        return arr
    from PIL import Image

    try:
        e = Image.Exif()
        e.load(exif if not exif.startswith(b"Exif\x00\x00") else exif[6:])
        orientation = int(e.get(0x0112, 1))
    except Exception:  # noqa: BLE001 - unreadable EXIF: like no EXIF
        orientation = 1
    return _orient(orientation, arr)


def _exif_orient(im: Any, arr: np.ndarray) -> np.ndarray:
    """Apply the EXIF orientation of ``im`` (a PNG may carry an eXIf chunk) to the array ``arr`` (H, W, C),
    as ``PIL.ImageOps.exif_transpose`` does for the images Pillow decodes (2 mirror, 3 rotate 180, 4 flip,
    5 transpose, 6 rotate 90 clockwise, 7 transverse, 8 rotate 90 counter-clockwise)."""
    try:
        orientation = int(im.getexif().get(0x0112, 1))
    except Exception:  # noqa: BLE001 - unreadable EXIF: like no EXIF
        orientation = 1
    return _orient(orientation, arr)


def _orient(orientation: int, arr: np.ndarray) -> np.ndarray:
    """``arr`` (H, W, C) as EXIF ``orientation`` says it is displayed."""
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


def save_image(
    path: str | os.PathLike[str],
    image: np.ndarray,
    bits: int = 8,
    compression: str | None = None,
    threads: int | None = None,
) -> None:
    """Write ``image`` to ``path`` atomically, in the format of its extension.

    - ``.png``: float images in [0, 1] are quantised to ``bits`` (8 or 16); uint8 / uint16 arrays are written
      as they are. 1 to 4 channels (grey, grey+alpha, RGB, RGBA). Encoded by :func:`encode_png` with
      ``compression`` (``"fast"``, ``"default"``, ``"best"``; default: :func:`set_png_compression`'s,
      normally ``"default"``) on ``threads`` workers; the bytes do not depend on ``threads``.
    - ``.exr``: OpenEXR with any channel count, float32 channels (half for a float16 array), values as they
      are (any range; NaN and infinity too, since EXR holds them); uint8 / uint16 become float32 in [0, 1].
    - anything else Pillow knows (``.jpg``, ``.tif``, ...): through Pillow, 8-bit.
    """
    if isinstance(bits, (bool, np.bool_)) or bits not in (8, 16):
        raise ParameterError(f"bits = {bits!r}: must be 8 or 16")
    level = _png_compression.get() if compression is None else _compression(compression)
    try:
        arr = np.asarray(image)
    except (ValueError, TypeError) as exc:
        raise ShapeError(f"image is not an array ({exc})") from None
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    target = Path(path)
    if target.suffix.lower() == ".exr":
        with atomic_open(target) as fh:
            fh.write(_encode_exr(arr))
        return
    if arr.dtype in (np.uint8, np.uint16):
        as_image(arr[:1, :1] if arr.ndim in (2, 3) else arr, "image")  # the shape rules of as_image
        if 0 in arr.shape:
            raise ShapeError(f"image has shape {arr.shape}, expected non-empty (H, W, C)")
    else:
        arr = to_uint(as_image(arr, "image"), bits)
    fmt = _format_for(target)
    channels = 1 if arr.ndim == 2 else arr.shape[2]
    if fmt == "PNG":
        with atomic_open(target) as fh:  # encoded inside: Ctrl-C while encoding leaves no partial file either
            fh.write(encode_png(arr, level, threads=threads))
        return
    if arr.dtype == np.uint16:
        raise ParameterError(f"output = {str(target)!r}: 16-bit output needs a .png (or .exr) file")
    if arr.ndim == 3 and arr.shape[2] == 1:
        arr = arr[:, :, 0]
    with atomic_path(target) as tmp:
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
            f"output = {str(path)!r}: unknown image extension {ext or '(none)'!r}; use .png, .exr, .jpg, .tif, ..."
        )
    return fmt
