"""Input conversion, following scikit-image's data-type rules.

Images inside tilesynth are C-contiguous ``float32`` arrays of shape ``(H, W, C)`` with values in [0, 1].
Integer images are scaled by their type's maximum (uint8 / 255, uint16 / 65535), never cast blindly; float32
input is kept as is; float64 is converted to float32 after the range check. Grey ``(H, W)`` images become
``(H, W, 1)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import ParameterError, ShapeError


def as_image(image: Any, name: str = "image") -> np.ndarray:
    """Return ``image`` as a C-contiguous float32 ``(H, W, C)`` array in [0, 1].

    Raises
    ------
    TypeError
        For dtypes that are not images (complex, object, signed integers other than via float).
    ShapeError
        For arrays that are not 2-d or 3-d, or that are empty.
    ParameterError
        For float input with NaN, infinity or values outside [0, 1].
    """
    arr = np.asarray(image)
    if arr.ndim == 2:
        arr = arr[:, :, None]
    if arr.ndim != 3:
        raise ShapeError(f"{name} has shape {arr.shape}, expected (H, W) or (H, W, C)")
    if 0 in arr.shape:
        raise ShapeError(f"{name} has shape {arr.shape}, expected non-empty (H, W, C)")
    if arr.shape[2] > 4:
        raise ShapeError(
            f"{name} has {arr.shape[2]} channels, expected 1 to 4 (channels last: (H, W, C))"
        )
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
    else:
        raise TypeError(
            f"{name} has dtype {arr.dtype}, expected uint8, uint16, bool or float in [0, 1]"
        )
    return np.ascontiguousarray(out)


def as_features(image: Any, name: str = "image") -> np.ndarray:
    """Return a feature image (any channel count, any finite values) as C-contiguous float32 ``(H, W, C)``.

    For images that are not colours, e.g. the gradient-augmented exemplar of 000's eq. 3 (colour, then √μ times
    the signed x and y differences of every channel): only the shape and finiteness are checked.
    """
    arr = np.asarray(image)
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


def to_uint(image: np.ndarray, bits: int = 8) -> np.ndarray:
    """Quantise a float image in [0, 1] to uint8 or uint16 with rounding (inverse of :func:`as_image`)."""
    if bits not in (8, 16):
        raise ParameterError(f"bits = {bits}: must be 8 or 16")
    top = 255 if bits == 8 else 65535
    dtype = np.uint8 if bits == 8 else np.uint16
    return np.clip(np.rint(np.asarray(image, np.float32) * top), 0, top).astype(dtype)


def positive_int(value: Any, name: str, *, minimum: int = 1) -> int:
    """Return ``value`` as an int >= ``minimum`` or raise :class:`ParameterError` naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} = {value!r}: must be an integer")
    if value < minimum:
        raise ParameterError(f"{name} = {value}: must be >= {minimum}")
    return int(value)


def seed_int(seed: Any) -> int:
    """Resolve a user seed: None draws a fresh one (recorded by callers so runs can be repeated)."""
    if seed is None:
        return int(np.random.SeedSequence().entropy % (2**63))
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed = {seed!r}: must be a non-negative integer or None")
    return int(seed)
