"""Warnings for suspicious inputs (issue 14): what a build noticed about its exemplar and its result.

Every build ends with :func:`finish_build`, which runs the checks below, stores what they found in the tile set
(``params["warnings"]``: a list of ``{"code", "message", "value", "threshold"}``, shown by ``tilesynth info`` and
the report) and emits each as a :class:`InputWarning` (``warnings.warn``; the command line prints them on stderr
with a ``warning:`` prefix). A build without findings stores nothing (its file is what it was before).

=====================  ==========================================================  =========================
code                   fires when                                                  what the user can do
=====================  ==========================================================  =========================
``masked-area``        >= :data:`MASKED_AREA` (10 %) of the exemplar is masked or   crop to the usable part,
                       transparent, or fewer than :data:`VALID_WINDOWS` (50 %) of   smaller tiles
                       the tile-size windows are clear of the mask
``cut-cost-outlier``   a tile's cut cost is far above the set's median: robust z   mask or crop the region,
                       of log(cost) >= :data:`OUTLIER_Z` (3.5) *and* cost >=        smaller tiles, select
                       :data:`OUTLIER_RATIO` (4) x the median (sets of >= 8 tiles)
``objective-outlier``  the same test on D_j (the distance of each tile to its      the same
                       matching patch, the objective's terms)
``low-coverage``       the tiles show less than :data:`LOW_COVERAGE` (5 %) of the   larger tiles, a larger
                       usable exemplar pixels                                       set, or crop
``non-stationary``     the luminance of the exemplar varies across it much more     crop a uniform part,
                       than inside it: over a 4 x 4 grid of blocks, the range of    flatten the lighting, or
                       block means is >= :data:`NONSTATIONARY_MEAN` (1.5) global    mask what differs
                       standard deviations, or the largest block standard
                       deviation is >= :data:`NONSTATIONARY_CONTRAST` (4) x the
                       smallest
=====================  ==========================================================  =========================

**Robust outliers.** Costs are compared on a log scale (cut costs and SSDs are products of contrast and length,
spread over orders of magnitude on one set), with the median and the median absolute deviation (scaled by
1.4826 to the standard deviation of a normal law), so one bad tile does not hide itself by inflating the spread.
The extra ratio test keeps sets with a very tight spread (MAD near 0) from flagging a tile 20 % above the rest.

**The thresholds of the non-stationarity test** were measured on the 24 textures of ``/work/shared/textures``
(stochastic and structured photos: bark, bricks, gravel, grass, ...): the largest mean range there was 1.09 and
the largest contrast ratio 3.0 (:func:`stationarity`; the figures of every texture are in
``benches/masks-results.md``), so 1.5 and 4 leave a margin and fire on exemplars with a lighting gradient, a
vignette, or a region of another material (the tests build such inputs synthetically).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

__all__ = [
    "LOW_COVERAGE",
    "MASKED_AREA",
    "NONSTATIONARY_CONTRAST",
    "NONSTATIONARY_MEAN",
    "OUTLIER_RATIO",
    "OUTLIER_Z",
    "VALID_WINDOWS",
    "InputWarning",
    "diagnose_exemplar",
    "diagnose_tileset",
    "finish_build",
    "outliers",
    "stationarity",
]

MASKED_AREA = 0.10
VALID_WINDOWS = 0.50
OUTLIER_Z = 3.5
OUTLIER_RATIO = 4.0
OUTLIER_MIN_TILES = 8
LOW_COVERAGE = 0.05
NONSTATIONARY_MEAN = 1.5
NONSTATIONARY_CONTRAST = 4.0
GRID = 4


class InputWarning(UserWarning):
    """A suspicious input or result of a build (:mod:`tilesynth.diagnose`); the build itself succeeded."""


def _finding(code: str, message: str, value: float, threshold: float) -> dict[str, Any]:
    v = float(value) if math.isfinite(float(value)) else 1e300  # JSON has no inf
    return {"code": code, "message": message, "value": round(v, 6), "threshold": float(threshold)}


def luminance(image: np.ndarray) -> np.ndarray:
    """Rec. 601 luma of RGB(A); the mean of the channels otherwise (grey: itself)."""
    x = np.asarray(image, dtype=np.float64)
    if x.ndim == 2:
        return x
    if x.shape[2] in (3, 4):
        return x[..., 0] * 0.299 + x[..., 1] * 0.587 + x[..., 2] * 0.114
    return x[..., : max(1, x.shape[2])].mean(axis=2)


def stationarity(image: np.ndarray, masked: np.ndarray | None = None, grid: int = GRID) -> dict[str, float]:
    """``{"mean_range", "contrast_ratio"}`` of the luminance over a ``grid x grid`` block grid.

    mean_range = (largest − smallest block mean) / global standard deviation; contrast_ratio = largest / smallest
    block standard deviation. Masked pixels are left out; blocks with less than half their pixels usable are
    skipped. A flat image (standard deviation 0) gives 0 and 1."""
    y = luminance(image)
    h, w = y.shape
    ok = np.ones((h, w), bool) if masked is None else ~np.asarray(masked, bool)
    if ok.sum() < 2:
        return {"mean_range": 0.0, "contrast_ratio": 1.0}
    sd = float(y[ok].std())
    means, sds = [], []
    for i in range(grid):
        for j in range(grid):
            ys = slice(i * h // grid, (i + 1) * h // grid)
            xs = slice(j * w // grid, (j + 1) * w // grid)
            blk, bok = y[ys, xs], ok[ys, xs]
            if bok.size == 0 or bok.mean() < 0.5:
                continue
            v = blk[bok]
            means.append(float(v.mean()))
            sds.append(float(v.std()))
    if len(means) < 2 or sd <= 1e-12:
        return {"mean_range": 0.0, "contrast_ratio": 1.0}
    lo = min(sds)
    return {
        "mean_range": (max(means) - min(means)) / sd,
        "contrast_ratio": max(sds) / lo if lo > 1e-12 else math.inf,
    }


def outliers(values: np.ndarray) -> tuple[np.ndarray, float]:
    """Indices of the robust high outliers of ``values`` (see the module docstring) and the median."""
    v = np.asarray(values, dtype=np.float64).ravel()
    fin = np.isfinite(v)
    if v.size < OUTLIER_MIN_TILES or fin.sum() < OUTLIER_MIN_TILES:
        return np.zeros(0, np.int64), float("nan")
    med = float(np.median(v[fin]))
    if med <= 0:
        return np.zeros(0, np.int64), med
    tiny = 1e-6 * med
    x = np.log(np.maximum(v, 0) + tiny)
    xm = float(np.median(x[fin]))
    mad = 1.4826 * float(np.median(np.abs(x[fin] - xm)))
    z = (x - xm) / max(mad, 1e-12)
    idx = np.nonzero(fin & (z >= OUTLIER_Z) & (v >= OUTLIER_RATIO * med))[0]
    return idx.astype(np.int64), med


def diagnose_exemplar(exemplar: np.ndarray, mask: Any = None, tile_size: int | None = None) -> list[dict]:
    """The findings about an exemplar (and its :class:`~tilesynth.masking.ExemplarMask`) alone."""
    found = []
    masked = None if mask is None else mask.masked
    if mask is not None and not mask.empty:
        frac = mask.fraction
        share = None
        if tile_size is not None:
            v = mask.valid(tile_size)
            share = float(v.mean()) if v.size else 0.0
        if frac >= MASKED_AREA or (share is not None and share < VALID_WINDOWS):
            what = "transparent" if mask.source.startswith("alpha") else "masked"
            win = "" if share is None else f"; {100 * share:.0f} % of the {tile_size}x{tile_size} windows are clear of it"
            found.append(
                _finding(
                    "masked-area",
                    f"{100 * frac:.1f} % of the exemplar is {what}{win}: the tiles draw on the rest only (no "
                    "masked pixel is copied). Crop the exemplar to the usable part or use smaller tiles for "
                    "more variety",
                    frac,
                    MASKED_AREA,
                )
            )
    st = stationarity(exemplar, masked)
    if st["mean_range"] >= NONSTATIONARY_MEAN or st["contrast_ratio"] >= NONSTATIONARY_CONTRAST:
        found.append(
            _finding(
                "non-stationary",
                f"the exemplar looks non-stationary: its luminance differs across it (block means span "
                f"{st['mean_range']:.2f} standard deviations, limit {NONSTATIONARY_MEAN}; block contrast "
                f"ratio {st['contrast_ratio']:.2f}, limit {NONSTATIONARY_CONTRAST}), so tiles from different "
                "parts will not match and the seams or the lighting will show. Crop a uniform part, flatten the "
                "lighting, or mask the region that differs",
                max(st["mean_range"] / NONSTATIONARY_MEAN, st["contrast_ratio"] / NONSTATIONARY_CONTRAST),
                1.0,
            )
        )
    return found


def _coverage(ts: Any, mask: Any) -> float:
    h, w = ts.exemplar.shape[:2]
    used = np.zeros((h, w), bool)
    src = np.asarray(ts.source)
    used[src[..., 0].ravel(), src[..., 1].ravel()] = True
    usable = h * w if mask is None else int((~mask.masked).sum())
    return float(used.sum()) / max(usable, 1)


def diagnose_tileset(ts: Any, mask: Any = None) -> list[dict]:
    """The findings about a built tile set: cut-cost and objective outliers, low exemplar coverage."""
    found = []
    for code, values, what in (
        ("cut-cost-outlier", ts.cut_costs, "cut cost"),
        ("objective-outlier", ts.D, "distance D_j to its matching patch"),
    ):
        idx, med = outliers(values)
        if idx.size:
            worst = int(idx[np.argmax(np.asarray(values)[idx])])
            shown = ", ".join(str(int(i)) for i in idx[:8]) + (", ..." if idx.size > 8 else "")
            found.append(
                _finding(
                    code,
                    f"{idx.size} tile(s) ({shown}) have a {what} far above the set's median (tile {worst}: "
                    f"{float(np.asarray(values)[worst]):.4g}, {float(np.asarray(values)[worst]) / med:.1f}x the "
                    f"median {med:.4g}): a part of the exemplar matches nothing else and its seams may show. Mask "
                    "or crop that part, use smaller tiles, or select the sample patches (--select ga)",
                    float(np.asarray(values)[worst]) / med,
                    OUTLIER_RATIO,
                )
            )
    cov = _coverage(ts, mask)
    if cov < LOW_COVERAGE:
        found.append(
            _finding(
                "low-coverage",
                f"the tiles show only {100 * cov:.1f} % of the usable exemplar pixels (limit "
                f"{100 * LOW_COVERAGE:.0f} %): most of the exemplar never appears in an output. Use larger tiles "
                "or a larger set, or crop the exemplar",
                cov,
                LOW_COVERAGE,
            )
        )
    return found


def finish_build(ts: Any, b: Any) -> Any:
    """The last stage of every builder: record the mask (``params["mask"]``), check the provenance against it,
    and store and emit the findings (``params["warnings"]``, :class:`InputWarning`). Returns ``ts``."""
    m = b.mask
    if m is not None:
        ts.params["mask"] = m.record()
        if not m.empty:
            m.check_provenance(ts.source)
    found = diagnose_exemplar(ts.exemplar, m, b.tile_size) + diagnose_tileset(ts, m)
    if found:
        ts.params["warnings"] = found
        for f in found:
            warnings.warn(f"{f['message']} [{f['code']}]", InputWarning, stacklevel=3)
    return ts


def info_lines(params: dict) -> list[str]:
    """The lines ``tilesynth info`` and the report show for ``params["mask"]`` and ``params["warnings"]``
    (values shown as stored; a tampered field prints as "?")."""
    out = []
    m = params.get("mask")
    if isinstance(m, dict):
        frac = m.get("masked_fraction")
        pct = f"{100 * frac:.1f} %" if isinstance(frac, (int, float)) and not isinstance(frac, bool) else "?"
        sha = m.get("sha256")
        out.append(
            f"mask          {m.get('source', '?')}{' ' + str(m['file']) if m.get('file') else ''}: {pct} masked "
            f"({m.get('masked_pixels', '?')} pixels), largest valid window {m.get('largest_valid_window', '?')} px, "
            f"sha256 {sha[:16] if isinstance(sha, str) else '?'}"
        )
    ws = params.get("warnings")
    if isinstance(ws, list):
        for w in ws:
            if isinstance(w, dict):
                out.append(f"warning       {w.get('code', '?')}: {w.get('message', '?')}")
    return out
