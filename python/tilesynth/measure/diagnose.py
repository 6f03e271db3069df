"""Warnings for suspicious inputs: what a build noticed about its exemplar and its result.

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
``non-stationary``     the luminance drifts across the exemplar: a plane fitted to  crop a uniform part,
                       the means of an 8 x 8 block grid spans >=                    flatten the lighting, or
                       :data:`NONSTATIONARY_MEAN` (1.5) global standard             mask what differs
                       deviations and explains >= :data:`NONSTATIONARY_R2` (70 %)
                       of their variance, or one fitted to the log block contrast spans
                       a ratio >= :data:`NONSTATIONARY_CONTRAST` (3)
                       (:func:`stationarity`)
``objects-cut``        the exemplar is one of separate objects (coins, fruit, floor   the ``objects`` recipe
                       tiles) whose size asks for tiles larger than the build's:     (``--recipe objects``:
                       :func:`tilesynth.measure.lattice.object_tile_size` > N       tiles about four objects
                       (the cuts will chop most objects and the grid may show)      wide), or larger tiles
``orientation-drift``  the structure turns across the exemplar (a photo taken at   rectify the photo
                       an angle, a curved surface): the dominant orientation of     (perspective
                       the gradients, fitted as a smooth field over the block       correction) or crop a
                       grid, turns by >= :data:`ORIENTATION_TURN` (15°) between     part where the
                       two corners, the field explains >= :data:`ORIENTATION_R2`    structure runs one way
                       (30 %) of the blocks' orientations and is clearly oriented
                       (coherence >= :data:`ORIENTED` (0.35)) at every corner
=====================  ==========================================================  =========================

**Robust outliers.** Costs are compared on a log scale (cut costs and SSDs are products of contrast and length,
spread over orders of magnitude on one set), with the median and the median absolute deviation (scaled by
1.4826 to the standard deviation of a normal law), so one bad tile does not hide itself by inflating the spread.
The extra ratio test keeps sets with a very tight spread (MAD near 0) from flagging a tile 20 % above the rest.

**The thresholds of the non-stationarity test** were measured on the 24 textures of ``/work/shared/textures``
(stochastic and structured photos: bark, bricks, gravel, grass, ...): the largest brightness trend there was
2.02 (rust.png, R² 0.54), every other is below 1.2 with R² <= 0.23, and the largest contrast trend is 2.44
(school-fish.png); small crops of large-featured textures have large but random trends (a 64 x 64 crop of the
bundled lettuce: 2.59 with R² 0.49), which the R² condition leaves alone. The thresholds fire on an exemplar
with a strong lighting gradient (noise plus a ramp of its own amplitude: 2.89, R² 1.0) or a darker half (2.37,
R² 0.76, contrast 6.4); the tests build such inputs synthetically. A radial vignette is not caught (a plane
does not follow it). The figures of every texture: ``benches/masks-results.md``.

**Orientation drift.** A brick wall photographed at an angle (scikit-image's ``brick.png``: courses that lean
one way on the left and the other on the right, narrowing upwards) keeps its brightness and contrast, so the
tests above stay silent, yet tiles cut from different parts meet at different angles and the default output
shows the whole tile grid. Per block of the same grid, the gradient structure tensor (sums of gx², gy², gx·gy)
gives a doubled-angle vector ((Jxx − Jyy), 2 Jxy) / (Jxx + Jyy): its direction is twice the dominant
orientation, its length the coherence (0 isotropic, 1 one orientation). A plane is fitted to each component (as
above: a perspective or a bend is a smooth trend, random orientations of an isotropic texture are not); the
turn is the largest difference of the fitted field's orientation between two corners of the image. *Why the
coherence condition:* where the fitted field is short (isotropic textures: gravel, caustics, crackers), its
direction is noise and turns of 45-90° are meaningless. Measured on the 24 shared textures: no texture meets
all three conditions (the nearest: school-fish, turn 45°, R² 0.39, but coherence 0.29 at a corner; grass-straw,
turn 31°, coherence 0.44, but R² 0.20; roof-tiles 18°, R² 0.17); scikit-image's ``brick.png`` gives a turn of
29°, R² 0.49, coherence >= 0.60, and its centre 256² crop 14° (the advice works). A grating whose orientation
turns by 15° across the image measures 19° (the fitted field is read at the corners), one that turns by 30°
measures 34°; a uniformly rotated brick wall 1°.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..base.validate import validated_image
from .lattice import object_tile_size

__all__ = [
    "LOW_COVERAGE",
    "MASKED_AREA",
    "NONSTATIONARY_CONTRAST",
    "NONSTATIONARY_MEAN",
    "NONSTATIONARY_R2",
    "ORIENTATION_R2",
    "ORIENTATION_TURN",
    "ORIENTED",
    "OUTLIER_RATIO",
    "OUTLIER_Z",
    "VALID_WINDOWS",
    "InputWarning",
    "diagnose_exemplar",
    "colour_of_build",
    "diagnose_objects",
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
NONSTATIONARY_R2 = 0.7
NONSTATIONARY_CONTRAST = 3.0
ORIENTATION_TURN = 15.0
"""Degrees the fitted orientation field must turn between two corners for ``orientation-drift``."""
ORIENTATION_R2 = 0.3
"""Share of the blocks' doubled-angle vectors' variance the fitted field must explain."""
ORIENTED = 0.35
"""Coherence (length of the fitted doubled-angle vector) the field must reach at every corner."""
GRID = 8
MIN_BLOCK = 8


class InputWarning(UserWarning):
    """A suspicious input or result of a build (:mod:`tilesynth.measure.diagnose`); the build itself succeeded."""


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
    """``{"mean_trend", "trend_r2", "contrast_trend", "orientation_turn", "orientation_r2", "orientation_coherence"}``:
    how much the local statistics of the luminance drift across the image.

    The image is cut into a ``grid x grid`` block grid; a plane a + b·u + c·v (u, v in [−½, ½] the block centre)
    is fitted by least squares to the block means and another to the log of the block standard deviations.
    mean_trend = the range of the first plane over the image (|b| + |c|) in units of the global standard
    deviation, trend_r2 the share of the block means' variance the plane explains (R²); contrast_trend = exp(|b| + |c|) of the second, the ratio of the contrast at one corner to the
    opposite one. *Why a plane and not the spread of the block means:* the block means of a stationary texture
    with large features (leaves, stones) spread widely but at random, which a plane does not follow; a lighting
    gradient, a darker half or a change of material is what a plane catches. Masked pixels are left out; blocks
    with less than half their pixels usable are skipped; blocks are at least :data:`MIN_BLOCK` (8) pixels a side
    (a smaller image gets a coarser grid, and one under 24 pixels a side is not judged), and block standard
    deviations are floored at 1 % of the global one (a flat block is not an infinite contrast). A flat image, or
    fewer than 4 usable blocks, gives 0 and 1.

    orientation_turn (degrees), orientation_r2 and orientation_coherence describe the smooth field fitted to the
    blocks' doubled-angle structure-tensor vectors (module docstring, *Orientation drift*): the largest turn of its
    orientation between two image corners, the share of the vectors' variance it explains, and its smallest
    length (coherence) at the four corners. Gradients are central differences; a gradient that reaches a masked
    pixel is left out."""
    y = luminance(image)
    h, w = y.shape
    ok = np.ones((h, w), bool) if masked is None else ~np.asarray(masked, bool)
    flat = {
        "mean_trend": 0.0,
        "trend_r2": 0.0,
        "contrast_trend": 1.0,
        "orientation_turn": 0.0,
        "orientation_r2": 0.0,
        "orientation_coherence": 0.0,
    }
    if ok.sum() < 2:
        return flat
    sd = float(y[ok].std())
    grid = min(grid, h // MIN_BLOCK, w // MIN_BLOCK)  # blocks of at least MIN_BLOCK pixels a side
    if grid < 3:
        return flat
    jxx, jyy, jxy = _structure_tensor(y.astype(np.float64), ok)
    means, sds, pos, dbl = [], [], [], []
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
            pos.append(((i + 0.5) / grid - 0.5, (j + 0.5) / grid - 0.5))
            a, b, c = float(jxx[ys, xs].sum()), float(jyy[ys, xs].sum()), float(jxy[ys, xs].sum())
            dbl.append(((a - b) / (a + b), 2.0 * c / (a + b)) if a + b > 0 else (0.0, 0.0))
    if len(means) < 4 or sd <= 1e-12:
        return flat
    A = np.c_[np.ones(len(pos)), np.asarray(pos)]
    mv = np.asarray(means)
    cm = np.linalg.lstsq(A, mv, rcond=None)[0]
    r2 = _r2(A, mv, cm)
    cs = np.linalg.lstsq(A, np.log(np.maximum(np.asarray(sds), 1e-2 * sd)), rcond=None)[0]
    vd = np.asarray(dbl)
    co = np.linalg.lstsq(A, vd, rcond=None)[0]  # (3, 2): the doubled-angle field's two planes
    corners = np.array([[1.0, u, v] for u in (-0.5, 0.5) for v in (-0.5, 0.5)]) @ co
    angle = 0.5 * np.degrees(np.arctan2(corners[:, 1], corners[:, 0]))  # orientation in [-90, 90)
    turn = max(abs((angle[p] - angle[q] + 90.0) % 180.0 - 90.0) for p in range(4) for q in range(p + 1, 4))
    return {
        "mean_trend": float(abs(cm[1]) + abs(cm[2])) / sd,
        "trend_r2": r2,
        "contrast_trend": float(math.exp(min(abs(cs[1]) + abs(cs[2]), 700.0))),
        "orientation_turn": float(turn),
        "orientation_r2": _r2(A, vd, co),
        "orientation_coherence": float(np.hypot(corners[:, 0], corners[:, 1]).min()),
    }


def _r2(A: np.ndarray, values: np.ndarray, coef: np.ndarray) -> float:
    """The share of the variance of ``values`` (over rows; summed over columns) the fit ``A @ coef`` explains."""
    tot = float(((values - values.mean(axis=0)) ** 2).sum())
    return 1.0 - float(((values - A @ coef) ** 2).sum()) / tot if tot > 0 else 0.0


def _structure_tensor(y: np.ndarray, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per pixel gx², gy², gx·gy of the central differences of ``y`` (``np.gradient``, one-sided at the image
    edges), zero where a difference reaches a pixel that ``ok`` excludes."""
    gy, gx = np.gradient(y)
    use = ok.copy()
    use[1:, :] &= ok[:-1, :]
    use[:-1, :] &= ok[1:, :]
    use[:, 1:] &= ok[:, :-1]
    use[:, :-1] &= ok[:, 1:]
    gx, gy = np.where(use, gx, 0.0), np.where(use, gy, 0.0)
    return gx * gx, gy * gy, gx * gy


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
    """The findings about an exemplar (and its :class:`~tilesynth.builder.masking.ExemplarMask`) alone."""
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
            win = (
                ""
                if share is None
                else f"; {100 * share:.0f} % of the {tile_size}x{tile_size} windows are clear of it"
            )
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
    trend = st["mean_trend"] >= NONSTATIONARY_MEAN and st["trend_r2"] >= NONSTATIONARY_R2
    if trend or st["contrast_trend"] >= NONSTATIONARY_CONTRAST:
        found.append(
            _finding(
                "non-stationary",
                f"the exemplar looks non-stationary: its luminance drifts across it (a brightness trend of "
                f"{st['mean_trend']:.2f} standard deviations explaining {100 * st['trend_r2']:.0f} % of the "
                f"block means, limits {NONSTATIONARY_MEAN} and {100 * NONSTATIONARY_R2:.0f} %; a contrast trend of "
                f"{st['contrast_trend']:.2f}x, limit {NONSTATIONARY_CONTRAST}), so tiles from different "
                "parts will not match and the seams or the lighting will show. Crop a uniform part, flatten the "
                "lighting, or mask the region that differs",
                max(st["mean_trend"] / NONSTATIONARY_MEAN, st["contrast_trend"] / NONSTATIONARY_CONTRAST),
                1.0,
            )
        )
    if (
        st["orientation_turn"] >= ORIENTATION_TURN
        and st["orientation_r2"] >= ORIENTATION_R2
        and st["orientation_coherence"] >= ORIENTED
    ):
        found.append(
            _finding(
                "orientation-drift",
                f"the exemplar's structure turns by {st['orientation_turn']:.0f}° across it (a smooth orientation "
                f"field explaining {100 * st['orientation_r2']:.0f} % of the block orientations; limits "
                f"{ORIENTATION_TURN:.0f}° and {100 * ORIENTATION_R2:.0f} %): a photo taken at an angle or of a "
                "curved surface? Tiles cut from different parts meet at different angles, so the tile grid will "
                "show. Rectify the photo (a perspective correction), or crop a part where the structure runs one "
                "way",
                st["orientation_turn"],
                ORIENTATION_TURN,
            )
        )
    return found


_COLOUR: contextvars.ContextVar[np.ndarray | None] = contextvars.ContextVar("tilesynth_colour", default=None)


@contextlib.contextmanager
def colour_of_build(colour: np.ndarray) -> Iterator[None]:
    """Within the block, :func:`finish_build` checks ``colour`` for objects instead of the build's exemplar: a
    material is built on a feature image (:func:`tilesynth.builder.materials_inputs.feature_image`), whose
    channels are not what the user sees. ``colour`` must be validated (:func:`tilesynth.base.validate.as_image`)."""
    token = _COLOUR.set(colour)
    try:
        yield
    finally:
        _COLOUR.reset(token)


def diagnose_objects(colour: np.ndarray, mask: Any = None, tile_size: int | None = None) -> list[dict]:
    """The ``objects-cut`` finding: the colour exemplar (a material's albedo, not its feature image) is one of
    separate objects whose size asks for tiles larger than ``tile_size``
    (:func:`tilesynth.measure.lattice.object_tile_size`); none with a mask (its holes are not objects)."""
    if tile_size is None or not (mask is None or mask.empty):
        return []
    want, scale = object_tile_size(colour)
    if want is None or want <= tile_size:
        return []
    return [
        _finding(
            "objects-cut",
            f"the exemplar shows separate objects about {scale:.0f} px across, large against tiles of "
            f"{tile_size} px: the tile cuts will chop most of them and the tile grid may show. Tiles of "
            f"{want} px, about four objects wide (--tile-size {want}; the 'objects' recipe, --recipe objects, "
            "picks that size for ω sets), kept more of them whole on 6 object photos (object pixels in whole "
            "objects 0.28 -> 0.37, lattice (folded) 7.1 -> 3.8) at about 2x the periodic copies and 1.8x the "
            "build time; 'tilesynth metrics' shows the lattice and objects intact of a sample",
            want / tile_size,
            1.0,
        )
    ]


def _coverage(ts: Any, mask: Any) -> float:
    h, w = ts.exemplar.shape[:2]
    used = np.zeros((h, w), bool)
    src = np.asarray(ts.source)
    step = max(1, (1 << 20) // max(1, src[:1, ..., 0].size))  # chunks of tiles: no 10 M-entry index copies
    for lo in range(0, src.shape[0], step):
        used[src[lo : lo + step, ..., 0].ravel(), src[lo : lo + step, ..., 1].ravel()] = True
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
    # the objects check reads the colour (a material's albedo, not the feature image it was built on), which the
    # build validated once: it must not scan it again (tests/test_exemplar.py counts the scans)
    over, source = _COLOUR.get(), getattr(b, "source", None)
    colour = over if over is not None else (b.exemplar if source is None else source.image)
    with validated_image(colour):
        found = (
            diagnose_exemplar(ts.exemplar, m, b.tile_size)
            + diagnose_objects(colour, m, b.tile_size)
            + diagnose_tileset(ts, m)
        )
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
