"""Seam scores of :mod:`tilesynth.measure.metrics`: the border seam score and its profiles, the cut seam of a
tile set, the inner-lattice seam score (see the module docstring of :mod:`tilesynth.measure.metrics`)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..base.validate import as_image, positive_int
from ..errors import ParameterError, ShapeError
from .metrics_common import _finite, _ratio


# ---------------------------------------------------------------------------------------------- seam score
def _pair_differences(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d² of every horizontal pair ``(H, W-1)`` and every vertical pair ``(H-1, W)``, float64."""
    x = image.astype(np.float64)
    dx2 = ((x[:, 1:] - x[:, :-1]) ** 2).sum(axis=2)
    dy2 = ((x[1:] - x[:-1]) ** 2).sum(axis=2)
    return dx2, dy2


def _border_pairs(length: int, tile: int) -> np.ndarray:
    """bool ``(length-1,)``: pair (i, i+1) crosses a tile border."""
    return (np.arange(1, length) % tile) == 0


@dataclass(frozen=True)
class SeamScore:
    """Border seam score S (see the module docstring) and its parts.

    ``ratio_x`` = B_x / I_x is for the vertical borders (pairs of horizontal neighbours), ``ratio_y`` for the
    horizontal ones; a direction without border is ``None`` (its parts too).
    """

    score: float
    ratio_x: float | None
    ratio_y: float | None
    border_x: float | None
    border_y: float | None
    interior_x: float | None
    interior_y: float | None
    border_pairs: int
    interior_pairs: int
    tile_size: int

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def seam_score(image: np.ndarray, tile_size: int) -> SeamScore:
    """Border seam score of ``image`` tiled with ``tile_size`` x ``tile_size`` tiles from its top-left corner.

    Raises ShapeError when the image holds no tile border (at most one tile in each direction).
    """
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    h, w = img.shape[:2]
    if h <= n and w <= n:
        raise ShapeError(f"tile_size = {n}: the {w}x{h} image holds no tile border (one tile or less)")
    dx2, dy2 = _pair_differences(img)
    bx_mask, by_mask = _border_pairs(w, n), _border_pairs(h, n)
    parts: dict[str, float | None] = {}
    num = den = 0.0
    nb = ni = 0
    for axis, d2, mask in (("x", dx2, bx_mask), ("y", dy2.T, by_mask)):
        # d2 is (lines, pairs); mask selects the border pairs along the last axis
        if not mask.any():
            parts.update({f"border_{axis}": None, f"interior_{axis}": None, f"ratio_{axis}": None})
            continue
        b = float(d2[:, mask].mean())
        inner = d2[:, ~mask]
        i = float(inner.mean()) if inner.size else math.nan
        parts.update({f"border_{axis}": b, f"interior_{axis}": i, f"ratio_{axis}": _ratio(b, i)})
        num += b
        den += i if inner.size else 0.0
        nb += int(d2[:, mask].size)
        ni += int(inner.size)
    return SeamScore(score=_ratio(num, den), border_pairs=nb, interior_pairs=ni, tile_size=n, **parts)


def seam_profiles(image: np.ndarray, tile_size: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel border terms, for pictures: d² across each border divided by the interior mean of its direction.

    Returns ``vertical`` float64 ``(H, n_v)`` (column k: the pairs across the border between pixel columns
    (k+1)·N − 1 and (k+1)·N) and ``horizontal`` ``(n_h, W)``; their means are ``ratio_x`` and ``ratio_y`` of
    :func:`seam_score`.
    """
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    s = seam_score(img, n)
    dx2, dy2 = _pair_differences(img)
    bx, by = _border_pairs(img.shape[1], n), _border_pairs(img.shape[0], n)
    v = dx2[:, bx] / s.interior_x if s.interior_x else np.zeros((img.shape[0], int(bx.sum())))
    hz = dy2[by] / s.interior_y if s.interior_y else np.zeros((int(by.sum()), img.shape[1]))
    return v, hz


def cut_seam_score(tileset: Any) -> dict[str, Any] | None:
    """The cut seam of a tile set (see the module docstring): ``{"score", "cut_pairs", "pairs"}``, or None for
    a set whose cuts never separate two pixels."""
    masks = getattr(tileset, "cut_masks", None)
    if masks is None or np.asarray(masks).ndim != 3 or np.asarray(masks).size == 0:
        return None
    m = np.asarray(masks, dtype=np.int8)
    num = den = 0.0
    cut = pairs = 0
    for ax in (1, 2):
        d = _squared_steps(tileset.tiles, ax)
        across = np.diff(m, axis=ax) != 0
        num += float(d[across].sum())
        cut += int(across.sum())
        den += float(d.sum())
        pairs += int(d.size)
        del d, across  # one axis at a time (peak memory)
    if cut == 0:
        return None
    return _finite({"score": _ratio(num / cut, den / pairs), "cut_pairs": cut, "pairs": pairs})


def _squared_steps(tiles: Any, ax: int) -> np.ndarray:
    """``(np.diff(x, axis=ax) ** 2).sum(axis=-1)`` of ``x`` = the tiles as float64, computed a chunk of tiles
    at a time (every value is elementwise, so the same bytes): the whole float64 copy and its differences were
    most of a c5 build's peak memory."""
    t = np.asarray(tiles)
    shape = list(t.shape)
    shape[ax] -= 1
    d = np.empty(shape[:-1])
    step = max(1, (16 << 20) // max(1, 8 * int(np.prod(t.shape[1:]))))
    for lo in range(0, t.shape[0], step):
        x = np.asarray(t[lo : lo + step], dtype=np.float64)
        d[lo : lo + step] = (np.diff(x, axis=ax) ** 2).sum(axis=-1)
    return d


# ----------------------------------------------------------------------------------------- inner-lattice seam
INNER_DEPTHS = (1, 2, 3, 4)
"""Depths (pixels inside the tile borders) of the lines :func:`inner_seam_score` measures."""


@dataclass(frozen=True)
class InnerSeamScore:
    """Seam score on the lattice-parallel lines a few pixels inside the tile borders (:func:`inner_seam_score`).

    ``scores`` maps each signed depth to its score: +k is the line between pixels k−1 and k of every tile
    (k pixels after a border), −k the line between pixels N−k−1 and N−k (k pixels before the next one).
    ``max`` and ``mean`` are over those depths; ``depth_of_max`` says where the worst line is."""

    max: float
    mean: float
    depth_of_max: int
    scores: dict[int, float]
    tile_size: int

    def to_dict(self) -> dict[str, Any]:
        d = _finite(asdict(self))
        d["scores"] = {str(k): v for k, v in d["scores"].items()}
        return d


def inner_seam_score(
    image: np.ndarray, tile_size: int, depths: tuple[int, ...] = INNER_DEPTHS
) -> InnerSeamScore:
    """Seam score of the lines parallel to the tile lattice ``depths`` pixels inside every tile border.

    A cut that runs along the tile border at a fixed depth in every tile (for example a min cut pressed onto
    the border ring of the free cut region) draws a square grid of straight seams that the border seam score
    (:func:`seam_score`, depth 0) does not see. For each signed depth s (±k, k in ``depths``) the lattice pairs
    are the neighbour pairs (i, i+1) with (i + 1 − s) mod N = 0 along x and along y; as in :func:`seam_score`,
    S(s) = (B_x(s) + B_y(s)) / (I_x + I_y), where B is the mean squared colour step over those pairs and I the
    mean over the pairs on none of the measured lines (not the borders, no depth ±k): S ≈ 1 when the lines
    look like any other pixel step, a grid of seams gives S > 1. Depths of N/2 or more are left out (they
    would meet the lines of the opposite border). Cost O(H·W·C).

    Raises ShapeError when the image holds no tile border, ParameterError when no depth is below N/2.
    """
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    h, w = img.shape[:2]
    if h <= n and w <= n:
        raise ShapeError(f"tile_size = {n}: the {w}x{h} image holds no tile border (one tile or less)")
    ks = sorted({positive_int(k, "depth") for k in depths})
    ks = [k for k in ks if k < n / 2]
    if not ks:
        raise ParameterError(f"depths = {tuple(depths)}: none is below tile_size / 2 = {n / 2:g}")
    signed = [s for k in ks for s in (k, -k)]
    measured = {0} | {s % n for s in signed}
    dx2, dy2 = _pair_differences(img)
    num = {s: 0.0 for s in signed}
    den = 0.0
    used = 0
    for d2 in (dx2, dy2.T):  # (lines, pairs): pair j joins positions j and j + 1 along the last axis
        if d2.shape[1] + 1 < n + ks[-1] + 1:
            continue  # not every measured line crosses this direction
        used += 1
        cls = np.arange(1, d2.shape[1] + 1) % n
        sums = np.bincount(cls, weights=d2.sum(axis=0), minlength=n)
        counts = np.bincount(cls, minlength=n) * d2.shape[0]
        inner = np.array([c not in measured for c in range(n)])
        den += _ratio(float(sums[inner].sum()), float(counts[inner].sum()))
        for s in signed:
            c = s % n
            num[s] += _ratio(float(sums[c]), float(counts[c])) if counts[c] else 0.0
    if not used:
        raise ShapeError(
            f"tile_size = {n}: the {w}x{h} image is under N + {ks[-1] + 1} pixels in both directions "
            "(no full set of inner lines)"
        )
    scores = {s: _ratio(num[s], den) for s in signed}
    worst = max(signed, key=lambda s: (scores[s], -abs(s), s))
    return InnerSeamScore(
        max=float(scores[worst]),
        mean=float(np.mean(list(scores.values()))),
        depth_of_max=int(worst),
        scores=scores,
        tile_size=n,
    )
