"""Choosing the matching patch O of each intermediate tile (002 §3.2), and the distances it is measured with.

002 wants "the best C, from all possible candidates O": the candidate whose cutting curve has the least
prominent seam. Computing the real cut for every translation is the exhaustive answer; 002 itself used a
heuristic. The strategies (``match=`` of :func:`tilesynth.build_omega`, ``--match`` of ``tilesynth build``):

``ssd`` (default)
    The translation with the smallest SSD to the intermediate tile over the whole tile (exhaustive, exact).
``circle``
    002's heuristic, used for its experiments: the smallest sum of Kwatra weights "for the pixels around the
    circle". We read it as the edges with at least one end in the ring ``(R − 2)² < d² ≤ R²`` just inside the
    inscribed circle (R = N/2, d the distance to the tile centre), excluding edges whose ends are both sources
    (they are never cut): the ring is where the cutting curve runs when it hugs the circle.
``midpoints``
    002's alternative: the smallest sum of weights near the middle of the four sides, "to emphasize the
    importance of having matching contents at junctions": the edges with at least one end inside the circle
    and within distance ``max(2, N/8)`` of a side midpoint.
``best-cut``
    Beyond 002's heuristics: run the real min-cut for the ``k`` candidates with the smallest SSD (``k = "all"``:
    every translation) and keep the cheapest cut. Exact for its candidate set; with ``k = "all"`` it is the
    exhaustive answer 002 describes.

The heuristic maps are exact (direct sums over every translation, :func:`tilesynth.base.kernels.edge_weight_sums`).
When a set needs several matching patches per intermediate tile (the 32-set's two variants), the next one is the
best-scoring candidate more than N/4 pixels (Chebyshev) from those already chosen, for every strategy.

Distances for the SSD search (``metric=``; 000 §5, eq. 2 and 3, μ = 10):

``color``
    Σ_p ‖T(p) − O(p)‖², the plain SSD.
``eq3``
    Σ_p ‖T(p) − O(p)‖² + μ Σ_p (‖∇T(p) − ∇O(p)‖²): colour plus μ times the squared gradient difference, with
    ∇ the forward differences along x and y of every channel (0 past the exemplar's edge) taken at each pixel's
    exemplar position (its provenance, as the seam weights do). It is a plain SSD over an augmented image of
    3C channels ``[I, √μ·∂x I, √μ·∂y I]``, so the FFT search, the cached spectra and the quadrant structure of
    the population objective carry over unchanged: exact and as fast as ``color`` with 3x the channels.
``eq2``
    Σ_p ‖T(p) − O(p)‖² / (μ (‖∇T(p)‖ + ‖∇O(p)‖) + ε): the denominator couples the template pixel with the
    candidate pixel, so it is not a correlation and no FFT applies. We compute it exactly by direct summation
    over every translation (Rust, parallel): O(translations · N² · C) per tile, e.g. 2401 · 6400 · 3 ≈ 46 M
    multiply-adds per 80x80 tile on a 128x128 exemplar (tens of ms), 66 049 · 65 536 · 3 ≈ 13 G for 256x256
    tiles on 512x512 (tens of seconds). ε = 1e-6 guards flat regions (documented, as in the seam weight).
    ‖∇‖ is the L2 norm over channels and both axes of the forward differences.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import ParameterError

STRATEGIES: tuple[str, ...] = ("ssd", "circle", "midpoints", "best-cut")
"""Names accepted by ``match=``."""

METRICS: tuple[str, ...] = ("color", "eq2", "eq3")
"""Names accepted by ``metric=``."""

MU = 10.0
"""μ of 000's eq. 2 and 3."""

EQ2_EPS = 1e-6
"""ε in the denominator of eq. 2."""


def check_strategy(match: Any, k: Any) -> tuple[str, int | None]:
    """Validate ``match`` and ``match_k`` (``k``: an int >= 1 or "all"; only for "best-cut")."""
    if not isinstance(match, str) or match.strip().lower().replace("_", "-") not in STRATEGIES:
        raise ParameterError(f"match = {match!r}: expected one of {', '.join(STRATEGIES)}")
    name = match.strip().lower().replace("_", "-")
    if name != "best-cut":
        if k is not None:
            raise ParameterError(f"match_k = {k!r}: only used with match='best-cut'")
        return name, None
    if k is None:
        return name, 16
    if isinstance(k, str):
        if k.strip().lower() == "all":
            return name, -1
        raise ParameterError(f"match_k = {k!r}: expected a positive integer or 'all'")
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ParameterError(f"match_k = {k!r}: expected a positive integer or 'all'")
    return name, int(k)


def check_metric(metric: Any) -> str:
    if not isinstance(metric, str) or metric.strip().lower() not in METRICS:
        raise ParameterError(f"metric = {metric!r}: expected one of {', '.join(METRICS)}")
    return metric.strip().lower()


def circle_ring(n: int, width: float = 2.0) -> np.ndarray:
    """Pixels with ``(R − width)² < d² ≤ R²`` (R = n/2, d = distance of the pixel centre to the tile centre)."""
    c = (n - 1) / 2
    yy, xx = np.mgrid[0:n, 0:n]
    d2 = (yy - c) ** 2 + (xx - c) ** 2
    r = n / 2
    return (d2 <= r * r) & (d2 > (r - width) ** 2)


def midpoint_region(n: int) -> np.ndarray:
    """Pixels inside the inscribed circle within distance ``max(2, n/8)`` of a side midpoint."""
    c = (n - 1) / 2
    yy, xx = np.mgrid[0:n, 0:n]
    inside = (yy - c) ** 2 + (xx - c) ** 2 <= (n / 2) ** 2
    rad = max(2.0, n / 8)
    near = np.zeros((n, n), bool)
    for my, mx in ((c, 0), (c, n - 1), (0, c), (n - 1, c)):
        near |= (yy - my) ** 2 + (xx - mx) ** 2 <= rad * rad
    return inside & near


def _edge_masks(pixels: np.ndarray, sources: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edges with at least one end in ``pixels`` and not both ends in ``sources``."""
    wx = np.zeros_like(pixels)
    wy = np.zeros_like(pixels)
    wx[:, :-1] = (pixels[:, :-1] | pixels[:, 1:]) & ~(sources[:, :-1] & sources[:, 1:])
    wy[:-1] = (pixels[:-1] | pixels[1:]) & ~(sources[:-1] & sources[1:])
    return wx, wy


def strategy_edges(name: str, n: int, keep_border: bool) -> tuple[np.ndarray, np.ndarray]:
    """The edge masks ``(wx_mask, wy_mask)`` of the "circle" or "midpoints" heuristic for an n x n tile."""
    c = (n - 1) / 2
    yy, xx = np.mgrid[0:n, 0:n]
    sources = (yy - c) ** 2 + (xx - c) ** 2 > (n / 2) ** 2
    if keep_border:
        sources[[0, -1], :] = True
        sources[:, [0, -1]] = True
    pixels = circle_ring(n) if name == "circle" else midpoint_region(n)
    return _edge_masks(pixels & ~sources, sources)


def pick_distinct(order: np.ndarray, cols: int, count: int, radius: int) -> list[int]:
    """The first ``count`` flat translation indices of ``order`` pairwise more than ``radius`` apart (Chebyshev)."""
    chosen: list[tuple[int, int]] = []
    out: list[int] = []
    for f in order:
        r, c = divmod(int(f), cols)
        if all(max(abs(r - a), abs(c - b)) > radius for a, b in chosen):
            chosen.append((r, c))
            out.append(int(f))
            if len(out) == count:
                break
    return out


def augmented(exemplar: np.ndarray, mu: float = MU) -> np.ndarray:
    """``[I, √μ·∂x I, √μ·∂y I]`` (float32, 3C channels): plain SSD on it is 000's eq. 3 (forward differences,
    0 past the last column / row)."""
    e = exemplar.astype(np.float32)
    gx = np.zeros_like(e)
    gy = np.zeros_like(e)
    gx[:, :-1] = e[:, 1:] - e[:, :-1]
    gy[:-1] = e[1:] - e[:-1]
    s = np.float32(np.sqrt(mu))
    return np.ascontiguousarray(np.concatenate([e, s * gx, s * gy], axis=2))


def gradient_norm(exemplar: np.ndarray) -> np.ndarray:
    """‖∇I‖ at every pixel (L2 over channels and both forward differences), float64 ``(H, W)``."""
    e = exemplar.astype(np.float64)
    gx = np.zeros_like(e)
    gy = np.zeros_like(e)
    gx[:, :-1] = e[:, 1:] - e[:, :-1]
    gy[:-1] = e[1:] - e[:-1]
    return np.sqrt((gx * gx + gy * gy).sum(axis=2))


__all__ = [
    "EQ2_EPS",
    "METRICS",
    "MU",
    "STRATEGIES",
    "augmented",
    "check_metric",
    "check_strategy",
    "circle_ring",
    "gradient_norm",
    "midpoint_region",
    "pick_distinct",
    "strategy_edges",
]
