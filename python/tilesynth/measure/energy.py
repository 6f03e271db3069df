"""The objective of the selection papers, E = λ·ΣD_j + (1−λ)·Var(D_j) over the tiles' distances D_j.

A measure of a tile set (:func:`tilesynth.measure.metrics.objective` reports it) that the builders minimise
(:mod:`tilesynth.builder.genes`); it lives here, below the builder, so that the measures need not import a
build stage.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from ..base.validate import finite_float
from ..errors import ParameterError

__all__ = ["LAMBDA", "energy"]

LAMBDA: float = _core.DEFAULT_LAMBDA
"""Default λ of E = λ·ΣD + (1−λ)·Var(D) (paper 000: 0.8), defined in the core (``rust/population.rs``)."""


def energy(D: np.ndarray, lam: float = LAMBDA) -> float:
    """E = λ·ΣD_j + (1−λ)·Var(D_j) with the population variance."""
    try:
        d = np.asarray(D)
    except (ValueError, TypeError) as exc:
        raise ParameterError(f"D: expected real numbers ({exc})") from None
    if d.dtype.kind not in "biuf":
        raise TypeError(f"D has dtype {d.dtype}, expected real numbers")
    d = d.astype(np.float64)
    if d.ndim != 1 or d.size == 0 or not np.isfinite(d).all():
        raise ParameterError(f"D has shape {d.shape}: expected a non-empty 1-d array of finite values")
    lam = finite_float(lam, "lam")
    if not 0.0 <= lam <= 1.0:
        raise ParameterError(f"lam = {lam}: must be in [0, 1]")
    return float(lam * d.sum() + (1.0 - lam) * d.var())
