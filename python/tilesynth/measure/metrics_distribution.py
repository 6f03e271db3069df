"""Distribution metrics of :mod:`tilesynth.measure.metrics`: the exemplar coverage of a provenance map and the
histogram distance of colours and gradient magnitudes to the exemplar."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..base.validate import as_image
from ..errors import ParameterError, ShapeError
from .metrics_common import _finite
from .metrics_repetition import luminance


# ------------------------------------------------------------------------------------------------- coverage
@dataclass(frozen=True)
class Coverage:
    """Exemplar coverage of one output (see the module docstring); ``counts`` int64 ``(H_e, W_e)`` = n(q)."""

    fraction: float
    evenness: float
    cv: float
    used: int
    pixels: int
    output_pixels: int
    counts: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        return _finite(
            {k: getattr(self, k) for k in ("fraction", "evenness", "cv", "used", "pixels", "output_pixels")}
        )


def coverage(source: np.ndarray, exemplar_shape: tuple[int, ...]) -> Coverage:
    """Coverage of an exemplar of ``exemplar_shape`` by an output whose provenance is ``source`` ``(H, W, 2)``."""
    src = np.asarray(source)
    if src.ndim != 3 or src.shape[2] != 2 or not np.issubdtype(src.dtype, np.integer):
        raise ShapeError(f"source has shape {src.shape} and dtype {src.dtype}, expected integer (H, W, 2)")
    he, we = int(exemplar_shape[0]), int(exemplar_shape[1])
    r, c = src[..., 0].ravel(), src[..., 1].ravel()
    if r.size == 0:
        raise ShapeError("source is empty")
    lo_r, hi_r, lo_c, hi_c = (
        int(r.min()),
        int(r.max()),
        int(c.min()),
        int(c.max()),
    )  # before any cast can wrap
    if lo_r < 0 or lo_c < 0 or hi_r >= he or hi_c >= we:
        raise ParameterError(
            f"source: positions in rows [{lo_r}, {hi_r}], cols [{lo_c}, {hi_c}] outside the {we}x{he} exemplar"
        )
    r, c = r.astype(np.int64), c.astype(np.int64)
    counts = np.bincount(r * we + c, minlength=he * we).astype(np.int64)
    total = counts.sum()
    pr = counts[counts > 0] / total
    entropy = float(-(pr * np.log(pr)).sum())
    evenness = entropy / math.log(he * we) if he * we > 1 else 1.0
    return Coverage(
        fraction=float((counts > 0).mean()),
        evenness=evenness,
        cv=float(counts.std() / counts.mean()),
        used=int((counts > 0).sum()),
        pixels=he * we,
        output_pixels=int(total),
        counts=counts.reshape(he, we),
    )


HISTOGRAM_SCALES = (1, 2, 4)
"""Scales (box downsampling factors) of the gradient-magnitude histograms of :func:`histogram_distance`."""


def _wasserstein1(a: np.ndarray, b: np.ndarray, n: int = 512) -> float:
    """1-D Wasserstein-1 distance of two samples: mean |Q_a(u) − Q_b(u)| over n mid-point quantiles."""
    u = (np.arange(n) + 0.5) / n
    return float(np.abs(np.quantile(a.ravel(), u) - np.quantile(b.ravel(), u)).mean())


def _downsample(x: np.ndarray, f: int) -> np.ndarray:
    h, w = (x.shape[0] // f) * f, (x.shape[1] // f) * f
    return x[:h, :w].reshape(h // f, f, w // f, f, *x.shape[2:]).mean(axis=(1, 3))


def _gradient_magnitude(y: np.ndarray) -> np.ndarray:
    gy = np.diff(y, axis=0)[:, :-1]
    gx = np.diff(y, axis=1)[:-1, :]
    return np.sqrt(gx * gx + gy * gy)


@dataclass(frozen=True)
class HistogramDistance:
    """Colour and gradient histogram distance to the exemplar (:func:`histogram_distance`)."""

    distance: float
    colour: list[float]
    gradient: list[float]
    scales: list[int]

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def histogram_distance(
    image: np.ndarray, exemplar: np.ndarray, scales: tuple[int, ...] = HISTOGRAM_SCALES
) -> HistogramDistance:
    """Colour/gradient histogram distance: the mean of the 1-D Wasserstein-1 distances between ``image`` and
    ``exemplar`` of every colour channel (values in [0, 1]) and of the luminance gradient magnitude (forward
    differences) at each scale of ``scales`` (box downsampling by 1, 2, 4). 0 = the same distributions; it
    grows when a synthesis drops part of the exemplar (a vanished stone colour) or blurs its edges."""
    img, ex = as_image(image), as_image(exemplar, "exemplar")
    if img.shape[2] != ex.shape[2]:
        raise ShapeError(f"image has {img.shape[2]} channels, exemplar {ex.shape[2]}")
    colour = [_wasserstein1(img[..., c], ex[..., c]) for c in range(img.shape[2])]
    grad = []
    yi, ye = luminance(img), luminance(ex)
    used = []
    for f in scales:
        a, b = _downsample(yi, f), _downsample(ye, f)
        if min(a.shape + b.shape) < 2:
            continue
        grad.append(_wasserstein1(_gradient_magnitude(a), _gradient_magnitude(b)))
        used.append(int(f))
    parts = colour + grad
    return HistogramDistance(distance=float(np.mean(parts)), colour=colour, gradient=grad, scales=used)
