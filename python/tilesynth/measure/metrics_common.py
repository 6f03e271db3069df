"""Helpers shared by the metric modules of :mod:`tilesynth.measure.metrics`: JSON-able values, ratios, the
hash seed of the patch keys."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

_HASH_SEED = 0x5EED_C0DE


def _finite(v: Any) -> Any:
    """JSON-able copy: numpy scalars to Python, non-finite floats to None, arrays dropped by the callers."""
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else None
    return v


def _ratio(num: float, den: float) -> float:
    if den > 0:
        return num / den
    return math.inf if num > 0 else math.nan
