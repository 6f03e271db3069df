"""PNG and OpenEXR bytes to and from arrays, through the Rust core (the ``png`` and ``exr`` crates of
image-rs): the PNG encoder and its compression levels, the decoders' error messages, the file signatures.

The files themselves (limits, checks, EXIF, atomic writes) are :mod:`tilesynth.io.images`'s business.
"""

from __future__ import annotations

import contextvars
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError, ShapeError

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


PNG_COMPRESSIONS = ("fast", "default", "best")
"""The PNG compression levels of :func:`~tilesynth.io.images.save_image` and ``--png-compression``: deflate
level 1, 2 and 9 (zlib-rs) after libpng's adaptive row filters (scored on samples of long rows for ``fast``
and ``default``, on every byte for ``best``). ``default`` writes files within about 10 % of Pillow's
default ``save`` (zlib level 6) at a fifth of its CPU time or less; ``best`` about Pillow's size, still
faster; ``fast`` the quickest, about 1.3x Pillow's size (static Huffman codes). The pixels are identical at
every level. See ``benches/png_write.py``."""


_png_compression: contextvars.ContextVar[str] = contextvars.ContextVar("png_compression", default="default")


def set_png_compression(level: str | None) -> None:
    """Set the PNG compression that :func:`~tilesynth.io.images.save_image` uses when it is not given one (the
    CLI's ``--png-compression``; in the current context, so threads and async tasks that set their own keep
    theirs). ``None`` leaves it unchanged."""
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


def _is_png(p: Path) -> bool:
    with open(p, "rb") as fh:
        return fh.read(8) == _PNG_SIGNATURE


def _is_exr(p: Path) -> bool:
    with open(p, "rb") as fh:
        return fh.read(4) == b"v/1\x01"


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
