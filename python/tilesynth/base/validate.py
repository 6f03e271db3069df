"""Input conversion, following scikit-image's data-type rules.

Images inside tilesynth are C-contiguous ``float32`` arrays of shape ``(H, W, C)`` with values in [0, 1]: the
Rust core only ever receives such arrays (or other validated, contiguous, native-endian arrays). The rules:

- **uint8 / uint16** are scaled by their type's maximum (/ 255, / 65535), never cast blindly; **bool** gives
  0 and 1.
- **float16 / float32 / float64** must be finite and in [0, 1] (else :class:`ParameterError` with the range
  found); float32 is kept as is, the others are converted after the check.
- **Other integer types** (int8..int64, uint32, uint64: e.g. ``np.array([[0, 255]])``, whose dtype is int64)
  are refused with a ``TypeError``: their range says nothing about the data's (is int64 data 0..255 or
  0..65535?), so guessing would silently give a black or a white image. The message says how to convert.
- **Complex, object, string** dtypes are refused (``TypeError``).
- **Any memory layout** is accepted: Fortran order, strided views, negative strides, read-only and
  non-native byte order (big-endian) arrays are copied into a C-contiguous native array. The input is never
  modified (a C-contiguous float32 input in range is passed through without a copy).
- **Shapes**: ``(H, W)`` becomes ``(H, W, 1)``; ``(H, W, C)`` with C in 1..4; anything else, or an empty array,
  is a :class:`ShapeError`.
"""

from __future__ import annotations

import contextvars
import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from .. import _core
from ..errors import ParameterError, ShapeError


def asarray_aligned(value: Any) -> np.ndarray:
    """``numpy.asarray(value)``, copied when its data is not aligned for its dtype (a buffer at an odd offset, a
    field of a packed structured array): the Rust core refuses misaligned arrays (a view of one is undefined
    behaviour there), and every public function takes them like any other layout."""
    a = np.asarray(value)
    # the pointer too: numpy may flag an empty array at an odd address aligned, and the core checks both
    aligned = a.flags.aligned and a.__array_interface__["data"][0] % max(a.dtype.alignment, 1) == 0
    return a if aligned else a.copy()


_TRUSTED: contextvars.ContextVar[tuple[np.ndarray, ...]] = contextvars.ContextVar(
    "tilesynth_trusted", default=()
)


@contextmanager
def validated_image(image: np.ndarray) -> Iterator[None]:
    """Within the block, :func:`as_image` returns ``image`` itself at once (it is the object, not a copy)
    instead of checking it again: for a build, which validates its exemplar once
    (:class:`tilesynth.builder.exemplar.Exemplar`) and then hands the same array to kernels and measures that
    each check what they are given. ``image`` must be what :func:`as_image` returned (C-contiguous float32 in
    [0, 1], which :func:`as_image` passes through uncopied), owned by the caller and not written to in the
    block; the promise holds for this thread (or task) only."""
    token = _TRUSTED.set((*_TRUSTED.get(), image))
    try:
        yield
    finally:
        _TRUSTED.reset(token)


def as_image(image: Any, name: str = "image") -> np.ndarray:
    """Return ``image`` as a C-contiguous float32 ``(H, W, C)`` array in [0, 1] (``image`` itself, unchecked,
    inside a :func:`validated_image` block of it).

    Raises
    ------
    TypeError
        For dtypes that are not images (complex, object, signed integers other than via float).
    ShapeError
        For arrays that are not 2-d or 3-d, or that are empty.
    ParameterError
        For float input with NaN, infinity or values outside [0, 1].
    """
    for trusted in _TRUSTED.get():
        if image is trusted:
            return trusted
    return _check_image(image, name)


def _check_image(image: Any, name: str) -> np.ndarray:
    """:func:`as_image`'s conversion and checks."""
    try:
        arr = asarray_aligned(image)
    except (ValueError, TypeError) as exc:  # ragged nested lists and the like
        raise ShapeError(f"{name} is not an array ({exc})") from None
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3:
        raise ShapeError(f"{name} has shape {arr.shape}, expected (H, W) or (H, W, C)")
    if 0 in arr.shape:
        raise ShapeError(f"{name} has shape {arr.shape}, expected non-empty (H, W, C)")
    if arr.shape[2] > 4:
        raise ShapeError(f"{name} has {arr.shape[2]} channels, expected 1 to 4 (channels last: (H, W, C))")
    if arr.dtype.kind == "V" or arr.dtype.names:
        raise TypeError(f"{name} has dtype {arr.dtype}, expected uint8, uint16, bool or float in [0, 1]")
    if arr.dtype == np.bool_:
        out = arr.astype(np.float32)
    elif arr.dtype == np.uint8:
        out = arr.astype(np.float32) / np.float32(255)
    elif arr.dtype == np.uint16:
        out = arr.astype(np.float32) / np.float32(65535)
    elif arr.dtype in (np.float32, np.float64, np.float16):
        if not np.isfinite(arr).all():
            raise ParameterError(f"{name} contains NaN or infinity")
        lo, hi = float(arr.min()), float(arr.max())
        if lo < 0.0 or hi > 1.0:
            raise ParameterError(
                f"{name} has values in [{lo:g}, {hi:g}], expected floats in [0, 1] "
                "(divide integer data by its maximum first)"
            )
        out = arr.astype(np.float32, copy=False)
    elif arr.dtype.kind in "iu":
        raise TypeError(
            f"{name} has dtype {arr.dtype}, expected uint8, uint16, bool or float in [0, 1] (convert "
            "explicitly: arr.astype(np.uint8) for data in [0, 255], arr / arr_max for any other range)"
        )
    else:
        raise TypeError(f"{name} has dtype {arr.dtype}, expected uint8, uint16, bool or float in [0, 1]")
    return np.ascontiguousarray(out)


def as_features(image: Any, name: str = "image") -> np.ndarray:
    """Return a feature image (any channel count, any finite values) as C-contiguous float32 ``(H, W, C)``.

    For images that are not colours, e.g. the gradient-augmented exemplar of 000's eq. 3 (colour, then √μ times
    the signed x and y differences of every channel): only the shape and finiteness are checked.
    """
    arr = asarray_aligned(image)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3 or 0 in arr.shape:
        raise ShapeError(f"{name} has shape {arr.shape}, expected non-empty (H, W) or (H, W, C)")
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"{name} has dtype {arr.dtype}, expected a real number type")
    out = np.ascontiguousarray(arr, dtype=np.float32)
    if not np.isfinite(out).all():
        raise ParameterError(f"{name} contains NaN or infinity (or values beyond float32)")
    return out


def as_image_stack(images: Any, name: str = "templates") -> tuple[np.ndarray, bool]:
    """``(h, w[, C])`` or ``(K, h, w, C)`` images as one C-contiguous float32 ``(K, h, w, C)`` stack, each
    image converted and checked by :func:`as_image`. Returns the stack and whether a single image was given.
    ``K = 0`` is allowed (an empty stack)."""
    try:
        t = asarray_aligned(images)
    except (ValueError, TypeError) as exc:
        raise ShapeError(f"{name} is not an array ({exc})") from None
    single = t.ndim in (2, 3)
    if t.ndim == 2:
        t = t[:, :, None]
    if single:
        t = t[None]
    if t.ndim != 4:
        raise ShapeError(f"{name} has shape {t.shape}, expected (h, w, C) or (K, h, w, C)")
    if t.shape[0] == 0:
        if 0 in t.shape[1:] or t.shape[3] > 4:
            raise ShapeError(f"{name} has shape {t.shape}, expected (K, h, w, C) with h, w >= 1, C in 1..4")
        if t.dtype.kind not in "fbu" or t.dtype.kind == "u" and t.dtype.itemsize > 2:
            raise TypeError(f"{name} has dtype {t.dtype}, expected uint8, uint16, bool or float in [0, 1]")
        return np.zeros(t.shape, np.float32), single
    # one conversion for the whole stack (same rules as as_image, on the (K*h, w, C) view)
    k, h, w, c = t.shape
    flat = as_image(t.reshape(k * h, w, c), name)
    return flat.reshape(k, h, w, c), single


def threads_arg(threads: Any) -> int | None:
    """``None`` or a thread count in [1, MAX_THREADS] (the core's cap, 1024)."""
    if threads is None:
        return None
    n = positive_int(threads, "threads")
    if n > MAX_THREADS:
        raise ParameterError(f"threads = {n}: must be at most {MAX_THREADS}")
    return n


MAX_THREADS: int = _core.MAX_THREADS
"""The largest thread count the Rust core accepts (``rust/parallel.rs``, ``MAX_THREADS``, exported by the core)."""


def nonneg_int(value: Any, name: str) -> int:
    """``value`` as an int >= 0 (see :func:`positive_int`)."""
    return positive_int(value, name, minimum=0)


def finite_float(value: Any, name: str, *, positive: bool = False) -> float:
    """``value`` as a finite float (> 0 with ``positive``) or raise :class:`ParameterError` naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} = {value!r}: must be a number")
    v = float(value)
    if not np.isfinite(v) or (positive and v <= 0):
        raise ParameterError(f"{name} = {v!r}: must be finite{' and > 0' if positive else ''}")
    return v


def to_uint(image: np.ndarray, bits: int = 8) -> np.ndarray:
    """Quantise a float image in [0, 1] to uint8 or uint16 with rounding (inverse of :func:`as_image`)."""
    if bits not in (8, 16):
        raise ParameterError(f"bits = {bits}: must be 8 or 16")
    top = 255 if bits == 8 else 65535
    dtype = np.uint8 if bits == 8 else np.uint16
    return np.clip(np.rint(np.asarray(image, np.float32) * top), 0, top).astype(dtype)


INT_MAX = 2**63 - 1
"""The largest integer parameter accepted anywhere (the Rust core takes ``usize`` / ``i64``; a larger value
is a mistake, and pyo3 would reject it with an ``OverflowError`` that names nothing)."""


def positive_int(value: Any, name: str, *, minimum: int = 1, maximum: int = INT_MAX) -> int:
    """Return ``value`` as an int in [``minimum``, ``maximum``] or raise :class:`ParameterError` naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} = {value!r}: must be an integer")
    if value < minimum:
        raise ParameterError(f"{name} = {value}: must be >= {minimum}")
    if value > maximum:
        raise ParameterError(f"{name} = {value}: must be <= {maximum}")
    return int(value)


MAX_BYTES_ENV = "TILESYNTH_MAX_BYTES"
"""Environment variable overriding the memory limit of large outputs (bytes, a positive integer)."""


def memory_limit(max_bytes: Any = None) -> int:
    """The memory one large output (a synthesis, an index map, a source map) may take: ``max_bytes`` if
    given, else ``TILESYNTH_MAX_BYTES``, else half the physical memory (8 GiB where it cannot be read). Half,
    because the output usually has to be encoded or copied once more, and the machine has other work."""
    if max_bytes is not None:
        return positive_int(max_bytes, "max_bytes")
    env = os.environ.get(MAX_BYTES_ENV, "").strip()
    if env:
        try:
            n = int(env)
        except ValueError:
            n = 0
        if n < 1:
            raise ParameterError(f"{MAX_BYTES_ENV} = {env!r}: must be a positive integer (bytes)")
        return n
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not Linux/macOS
        return 8 << 30


def fmt_bytes(n: int) -> str:
    """``n`` bytes for people: ``"1.5 GiB"``."""
    for unit, size in (("TiB", 1 << 40), ("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n} bytes"


SEED_RANGE = 10**9
"""Fresh seeds are drawn from ``range(SEED_RANGE)``."""


def seed_int(seed: Any) -> int:
    """Resolve a user seed: None draws a fresh one (recorded by callers so runs can be repeated).

    A fresh seed has at most 9 digits (uniform in [0, 10^9)): short enough to be read off the terminal and
    retyped (``--seed 483920117``), and 10^9 values make two equal draws in a batch of a thousand builds
    unlikely (about 0.05 %). It only seeds numpy's generator, which mixes it, so a small seed is not a weak one.
    """
    if seed is None:
        return int(np.random.SeedSequence().entropy % SEED_RANGE)
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed = {seed!r}: must be a non-negative integer or None")
    return int(seed)
