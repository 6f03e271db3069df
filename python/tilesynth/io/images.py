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

import contextlib
import contextvars
import os
import stat
import struct
import tempfile
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from ..base.validate import as_image, to_uint
from ..errors import ParameterError, ShapeError

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


PNG_COMPRESSIONS = ("fast", "default", "best")
"""The PNG compression levels of :func:`save_image` and ``--png-compression``: deflate level 1, 2 and 9 (zlib-rs)
after libpng's adaptive row filters (scored on samples of long rows for ``fast`` and ``default``, on every byte
for ``best``). ``default`` writes files within about 10 % of Pillow's default ``save`` (zlib level 6) at a fifth
of its CPU time or less; ``best`` about Pillow's size, still faster; ``fast`` the quickest, about 1.3x Pillow's
size (static Huffman codes). The pixels are identical at every level. See ``benches/png_write.py``."""

_png_compression: contextvars.ContextVar[str] = contextvars.ContextVar("png_compression", default="default")


def set_png_compression(level: str | None) -> None:
    """Set the PNG compression that :func:`save_image` uses when it is not given one (the CLI's
    ``--png-compression``; in the current context, so threads and async tasks that set their own keep theirs).
    ``None`` leaves it unchanged."""
    if level is not None:
        _png_compression.set(_compression(level))


def add_png_compression_argument(parser: Any) -> None:
    """Add ``--png-compression fast|default|best`` to an argparse parser of a command that writes PNGs."""
    parser.add_argument(
        "--png-compression",
        choices=PNG_COMPRESSIONS,
        default=None,
        help="deflate effort of the PNGs written: fast, default (about Pillow's size, several times faster) or "
        "best (smallest, slowest); the pixels are the same",
    )


def _compression(level: Any) -> str:
    if level not in PNG_COMPRESSIONS:
        raise ParameterError(f"compression = {level!r}: must be one of {', '.join(PNG_COMPRESSIONS)}")
    return str(level)


def _core_reason(exc: Exception) -> str:
    """The reason of a codec error from the Rust core, without its ``png = file: `` prefix."""
    text = str(exc)
    for prefix in ("png = file: ", "exr = file: "):
        if text.startswith(prefix):
            return text[len(prefix) :]
    return text


def _decode_png(data: bytes, where: str, limit: int) -> tuple[np.ndarray, bytes | None]:
    """``(H, W, C)`` uint8 / uint16 and the raw eXIf chunk (or None) of PNG bytes, by ``_core.png_decode``.
    Raises :class:`ParameterError` starting with ``where`` for a damaged file or more than ``limit`` pixels."""
    from .. import _core

    try:
        return _core.png_decode(data, limit)
    except ParameterError as exc:
        reason = _core_reason(exc)
        if "exceeds the limit" in reason:
            raise ParameterError(f"{where}: {reason}") from None
        raise ParameterError(f"{where}: not a readable image ({reason})") from None


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


def _is_png(p: Path) -> bool:
    with open(p, "rb") as fh:
        return fh.read(8) == _PNG_SIGNATURE


def _is_exr(p: Path) -> bool:
    with open(p, "rb") as fh:
        return fh.read(4) == b"v/1\x01"


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


def _write_target(path: str | os.PathLike[str]) -> Path:
    """The file an output ``path`` names: ``path`` itself, or for a symbolic link the file it points to (so that
    writing through a link updates the linked file and keeps the link, as ``open(path, "w")`` would, instead of
    replacing the link by a file)."""
    target = Path(path)
    return Path(os.path.realpath(target)) if target.is_symlink() else target


def check_writable(path: str | os.PathLike[str], label: str = "output") -> Path:
    """Raise :class:`ParameterError` (naming ``label``) unless ``path`` can be written as a file: its directory
    exists, it is not a directory, and if it exists it is a regular file. Returns the directory.

    Not a regular file (issue 16: ``build in.png -o /dev/full`` replaced the device node with a ZIP when run as
    root): outputs are written to a temporary file renamed over the target, which would replace a device, FIFO
    or socket instead of writing into it, so they are refused with the reason."""
    shown = Path(path)
    target = _write_target(path)
    parent = target.parent if str(target.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"{label} = {str(shown)!r}: directory {str(parent)!r} does not exist")
    if target.is_dir():
        raise ParameterError(f"{label} = {str(shown)!r}: is a directory, expected a file name")
    try:
        mode = target.stat().st_mode
    except OSError:
        return parent  # does not exist yet (or cannot be examined: the write reports it)
    if not stat.S_ISREG(mode):
        raise ParameterError(
            f"{label} = {str(shown)!r}: is not a regular file (a device, FIFO or socket); tilesynth writes a "
            "temporary file and renames it over the output, which would replace it: name a file"
        )
    return parent


# The files written inside a file_set() block: [(temporary path, target)], renamed into place together at its end.
_file_set: contextvars.ContextVar[list[tuple[Path, Path]] | None] = contextvars.ContextVar(
    "file_set", default=None
)


@contextlib.contextmanager
def file_set() -> Iterator[None]:
    """Commit every atomic write inside the block as a unit: each file is written to its temporary name as
    usual, but renamed over its target only when the whole block succeeds, all at the end, with SIGINT and
    SIGTERM held back during the renames; on any error (Ctrl-C, SIGTERM, a full disk) every temporary file is
    removed and the previous files stay as they were.

    Why: a command that writes a set of files that belong together (an export: atlases, mips and the manifest
    that lists them; a material synth: the colour and its maps) must never leave new files beside old ones.
    The renames are quick metadata operations in one directory; only SIGKILL or a crash between two of them
    can leave a mixed set. A block inside another joins the outer one."""
    if _file_set.get() is not None:
        yield
        return
    pending: list[tuple[Path, Path]] = []
    token = _file_set.set(pending)
    try:
        yield
    except BaseException:
        _file_set.reset(token)
        _discard(pending)
        raise
    _file_set.reset(token)
    with _signals_held():
        for k, (tmp, target) in enumerate(pending):
            try:
                os.replace(tmp, target)
            except BaseException:
                _discard(pending[k:])
                raise


def pending_path(path: str | os.PathLike[str]) -> Path:
    """Where the content of ``path`` is now: its temporary file if it was written in the current
    :func:`file_set` block and not yet committed, else ``path`` itself (for a writer that reads back a file
    it wrote in the same set)."""
    target = _write_target(path)
    for tmp, t in _file_set.get() or []:
        if t == target:
            return tmp
    return Path(path)


def _discard(pending: list[tuple[Path, Path]]) -> None:
    for tmp, _ in pending:
        with contextlib.suppress(OSError):
            tmp.unlink()


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back (delivered when the block ends) in the main thread; elsewhere a no-op
    (signals are delivered to the main thread)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM}
    old = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success move it into place (at the end of the enclosing
    :func:`file_set` block, if any), on any error remove it.

    An ``OSError`` without a file name (``write`` on a full disk says only "No space left on device") gets the
    output's name, so that the message says which file could not be written."""
    parent = check_writable(path)
    target = _write_target(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates 0600 files; give the result the permissions a plain open() would have
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp_path, 0o666 & ~umask)
        pending = _file_set.get()
        if pending is None:
            os.replace(tmp_path, target)
        else:
            for k, (old, t) in enumerate(pending):
                if t == target:  # written twice in one set: the last write wins
                    with contextlib.suppress(OSError):
                        old.unlink()
                    del pending[k]
                    break
            pending.append((tmp_path, target))
    except BaseException as exc:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        if isinstance(exc, OSError) and exc.filename in (None, str(tmp_path)):
            exc.filename = str(path)
        raise


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "wb") -> Iterator[IO]:
    """Open a temporary file next to ``path`` for writing; it replaces ``path`` only if the block succeeds."""
    with atomic_path(path) as tmp, open(tmp, mode) as fh:
        yield fh


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


def encode_png(image: np.ndarray, compression: str = "default", threads: int | None = None) -> bytes:
    """The PNG file of a uint8 or uint16 ``(H, W)`` / ``(H, W, C)`` array (C = 1 to 4), as bytes.

    The rows get libpng's adaptive filter choice; the filtered data is cut into bands of about 1 MiB that are
    deflated independently on ``threads`` workers (level 1, 2 or 9 for ``compression`` fast, default, best)
    and joined into one zlib stream (sync-flush boundaries and a combined Adler-32, as pigz does), so the
    file is a single ordinary PNG that every decoder reads and its bytes do not depend on ``threads``.
    """
    from .. import _core

    arr = np.asarray(image)
    if arr.dtype not in (np.uint8, np.uint16):
        raise TypeError(f"image has dtype {arr.dtype}, expected uint8 or uint16 (see save_image for floats)")
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or 0 in arr.shape or arr.shape[2] > 4:
        raise ShapeError(
            f"image has shape {arr.shape}, expected non-empty (H, W) or (H, W, C) with C in 1..4"
        )
    return _core.png_encode(np.ascontiguousarray(arr), _compression(compression), threads)


def _encode_exr(arr: np.ndarray) -> bytes:
    from .. import _core

    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or 0 in arr.shape:
        raise ShapeError(f"image has shape {arr.shape}, expected non-empty (H, W) or (H, W, C)")
    if arr.dtype == np.uint8:
        data, half = arr.astype(np.float32) / np.float32(255), False
    elif arr.dtype == np.uint16:
        data, half = arr.astype(np.float32) / np.float32(65535), False
    elif arr.dtype.kind == "f":
        data, half = arr.astype(np.float32), arr.dtype == np.float16
    elif arr.dtype == np.bool_:
        data, half = arr.astype(np.float32), True
    else:
        raise TypeError(f"image has dtype {arr.dtype}, expected float, uint8, uint16 or bool for OpenEXR")
    return _interruptible(_core.exr_encode, np.ascontiguousarray(data), bool(half))


def _interruptible(fn: Any, *args: Any) -> Any:
    """``fn(*args)``, a Rust call that releases the GIL and runs for seconds without looking at signals (the
    OpenEXR encoder: 28 s for 9000 x 9000, one call of the exr crate), run so that Ctrl-C and SIGTERM take
    effect within a twentieth of a second: in the main thread, the call runs in a helper thread while the main
    thread waits in slices, where Python runs its signal handlers. On an interrupt the exception propagates at
    once (the atomic write removes its temporary file; a command exits); the abandoned call finishes in its
    daemon thread, or ends with the process, and its result is dropped. Elsewhere (not the main thread, which
    receives no signals) the call is made directly."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return fn(*args)
    box: dict[str, Any] = {}

    def run() -> None:
        try:
            box["value"] = fn(*args)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
            box["error"] = exc

    worker = threading.Thread(target=run, name="tilesynth-encode", daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.05)
    if "error" in box:
        raise box["error"]
    return box["value"]


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
