"""The argument conversions the kernel wrappers share (:mod:`tilesynth.base.kernels`): template stacks, masks,
real and integer arrays, gradient fields, index maps and float tiles, each C-contiguous and native-endian in the
one dtype its kernel accepts, with a :class:`~tilesynth.errors.ShapeError` / ``TypeError`` naming the argument."""

from __future__ import annotations

import numpy as np

from .. import _core
from ..errors import ParameterError, ShapeError
from .validate import (
    as_features,
    as_image_stack,
    asarray_aligned,
)

DEFAULT_EPS: float = _core.DEFAULT_EPS
"""Epsilon in the denominator of the Kwatra edge weight (guards flat regions); defined in the core
(``rust/seams.rs``) and exported from there (re-exported by :mod:`tilesynth.base.kernels`)."""


def _templates(
    templates: np.ndarray, name: str = "templates", features: bool = False
) -> tuple[np.ndarray, bool]:
    if not features:
        return as_image_stack(templates, name)
    t = asarray_aligned(templates)
    single = t.ndim in (2, 3)
    if t.ndim == 2:
        t = t[:, :, None]
    if single:
        t = t[None]
    if t.ndim != 4:
        raise ShapeError(f"{name} has shape {np.shape(templates)}, expected (h, w, C) or (K, h, w, C)")
    return np.stack([as_features(x, name) for x in t]), single


def _asarray(value: object, name: str) -> np.ndarray:
    try:
        a = asarray_aligned(value)
    except (ValueError, TypeError) as exc:
        raise ShapeError(f"{name} is not an array ({exc})") from None
    return a


def _mask(mask: object, name: str = "mask") -> np.ndarray | None:
    """A bool ``(h, w)`` mask: bool arrays as they are, integer or float arrays only if every value is 0 or 1
    (anything else is more likely a weight map passed by mistake than a mask)."""
    if mask is None:
        return None
    m = _asarray(mask, name)
    if m.ndim != 2:
        raise ShapeError(f"{name} has shape {m.shape}, expected a 2-d (h, w) mask")
    if m.dtype != np.bool_:
        if m.dtype.kind not in "iuf":
            raise TypeError(f"{name} has dtype {m.dtype}, expected bool")
        if m.size and not np.isin(m, (0, 1)).all():
            raise ParameterError(
                f"{name} has dtype {m.dtype} with values other than 0 and 1, expected a bool mask"
            )
    return np.ascontiguousarray(m, dtype=bool)


def _real(value: object, name: str, ndim: int, shape_text: str) -> np.ndarray:
    """A C-contiguous float64 array of ``ndim`` dimensions from any real (bool, integer, float) input; the
    kernels check the values (finite, >= 0, ...)."""
    a = _asarray(value, name)
    if a.ndim != ndim:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape_text}")
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} has dtype {a.dtype}, expected real numbers (float64)")
    return np.ascontiguousarray(a, dtype=np.float64)


def _grad(g: np.ndarray | None, name: str, ndim: int, shape_text: str) -> np.ndarray | None:
    return None if g is None else _real(g, name, ndim, shape_text)


def _index_map(value: object) -> np.ndarray:
    """An int32 ``(rows, cols)`` tile index map; integers only, none beyond the int32 range (no silent wrap)."""
    m = _asarray(value, "index_map")
    if m.ndim != 2:
        raise ShapeError(f"index_map has shape {m.shape}, expected (rows, cols)")
    if m.dtype.kind not in "iu":
        if m.size or m.dtype.kind not in "bf":
            raise TypeError(f"index_map has dtype {m.dtype}, expected integers")
    if m.size and m.dtype.kind in "iu" and m.dtype.itemsize >= 4:
        lo, hi = int(m.min()), int(m.max())
        if lo < -(2**31) or hi >= 2**31:
            raise ParameterError(f"index_map has values in [{lo}, {hi}], expected tile indices")
    return np.ascontiguousarray(m, dtype=np.int32)


def _float_tiles(value: object, name: str) -> np.ndarray:
    """``value`` as C-contiguous float32: floats as they are (any finite values; the kernel checks), uint8 /
    uint16 scaled by their maximum, bool as 0 / 1."""
    a = _asarray(value, name)
    if a.dtype == np.uint8:
        a = a.astype(np.float32) / np.float32(255)
    elif a.dtype == np.uint16:
        a = a.astype(np.float32) / np.float32(65535)
    elif a.dtype == np.bool_:
        a = a.astype(np.float32)
    elif a.dtype in (np.float16, np.float32, np.float64):
        a = a.astype(np.float32, copy=False)
    else:
        raise TypeError(f"{name} has dtype {a.dtype}, expected float, uint8, uint16 or bool")
    return np.ascontiguousarray(a)


def _int_array(value: object, name: str, ndim: int, shape_text: str) -> np.ndarray:
    a = _asarray(value, name)
    if a.ndim != ndim:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape_text}")
    if a.size and not (np.issubdtype(a.dtype, np.integer) or a.dtype == np.bool_):
        raise ParameterError(f"{name} has dtype {a.dtype}, expected integers")
    if a.size == 0 and a.dtype.kind not in "biuf":
        raise ParameterError(f"{name} has dtype {a.dtype}, expected integers")
    if a.size and a.dtype.kind == "u" and a.dtype.itemsize == 8 and int(a.max()) >= 2**63:
        raise ParameterError(f"{name} has values up to {int(a.max())}, beyond int64")
    return np.ascontiguousarray(a, dtype=np.int64)
