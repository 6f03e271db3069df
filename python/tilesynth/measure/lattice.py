"""Is the tile grid visible? Measures of a lattice and of cut objects in a synthesized texture.

A tile-based output can be seamless by the border seam score and still show its grid: cut outlines that run
at a fixed depth inside every tile, a motif that sits at the same place of every tile, objects chopped at the
tile rows. The three measures of this module look for exactly that, on the output image alone (no tile set,
no provenance), so they apply alike to tile sets, hex tiling and image quilting evaluated on the same grid of
N x N cells laid from the top-left corner (the grid :func:`tilesynth.synthesize` uses).

**Lattice (gradient)** (:func:`lattice_gradient`). With d²(p, q) = Σ_c (I_c(p) − I_c(q))² the squared colour
step of a neighbour pair, the *phase* of the horizontal pair (y, x)–(y, x+1) is (x + 1) mod N and that of the
vertical pair (y, x)–(y+1, x) is (y + 1) mod N: phase 0 is the pair across a tile border (as in
:func:`tilesynth.measure.metrics.seam_score`), phase k the line k pixels after it. P_x(k) is the mean d² of
the horizontal pairs of phase k, over the whole image; P_y(k) likewise. Per direction, r_x = max_k P_x(k) /
median_k P_x(k) (and r_y); the score is max(r_x, r_y). 1 means no phase is preferred: the steps of the
texture fall anywhere. A seam, a cut run or a stair step that recurs at the same depth of every tile (in
any direction) raises its phase above the others; the median, not the mean, is the reference so that a few
bad phases (a cut band two or three pixels wide) cannot lift the reference with them. Directions are not
pooled: a lattice of vertical seams alone is as visible as a square grid, and pooling with the clean
direction would halve its score. A direction with fewer than two tiles across (no repeated phase) is left
out. The max over N noisy phase means is biased a little above 1 (about 1 + 2.5·cv/√(pairs per phase)):
≈ 1.01-1.05 on a 1024² stochastic texture with N = 128. Cost O(H·W·C).

**Lattice (folded)** (:func:`lattice_folded`). The luminance L (Rec. 709) is cropped to the M = ⌊H/N⌋·⌊W/N⌋
whole cells and folded: F(u, v) = mean over the cells (i, j) of L(i·N + u, j·N + v). The score is std_uv(F)
/ (std(L) / √M): the spread of the folded mean against what M independent samples of the texture would give.
~1 when nothing sits at fixed tile positions (each F(u, v) is then a mean of M unrelated pixels); a motif,
a bright vertex disc or a dark border band at the same place of every cell adds a deterministic pattern to
F and raises it (a motif present in a share s of the cells with contrast c against σ_L scores about
√(1 + s²·c²·M·a / σ_L²) for a motif area share a). Luminance only: a lattice that is a pure hue change
is not seen (rare; the gradient measure sees its edges). Texture correlations longer than N make cells
depend on each other and move the score a little off 1 either way; a linear luminance ramp across the whole
image scores ≈ 1. ``peak`` is the cell position (row, col) of the largest |F − mean F| and ``peak_z`` that
deviation in units of std(L)/√M, for pictures and diagnosis. Cost O(H·W).

**Objects intact** (:func:`objects_intact`), for exemplars of separate objects on a background (discs,
coins, beans, letters). Segmentation: the exemplar's luminance is split at its Otsu threshold; the
foreground is the side with fewer pixels (objects on a background) unless ``polarity`` says "bright" or
"dark"; the output is split at the *exemplar's* threshold (so a synthesis that shifts the grey levels is not
re-segmented in its favour). Components are 4-connected. *Reference objects*: the exemplar's components that
do not touch its border with an area within [½, 2] x the area-weighted median area of those components (the
size at which half of their pixels lie in smaller ones: one object, not a cluster of touching objects or a
speck; a plain median would be decided by the threshold specks, which far outnumber the objects of a photo). An output component is *intact* when, aligned at its centroid
(rounded to a pixel), its mask has an intersection over union ≥ ``iou`` (default 0.75) with some reference
object's mask in one of the 8 orientations of the square (flips, quarter turns: an object mirrored is still
whole). The score is Σ area of the intact output components / Σ area of the counted output components, where
the counted components are those that do not touch the image border (the crop of the output cuts objects that
no synthesis cut) and are larger than a speck (area ≥ 0.1 x the median reference area: threshold noise, and
slivers too small to see). A half disc fails (IoU ≤ ½), and so does a disc grown together with a fragment of
its neighbour; two halves of equally sized discs joined along their cut pass (their outline is a whole disc:
the measure is about shapes, not colours). ``exemplar_share`` is the same score on the exemplar itself (below
1 where the exemplar holds clusters of touching objects): compare outputs against it. ``applies`` is true when
the exemplar has at least 4 reference objects of a typical area of at least 16 pixels and its own score is at
least ½; otherwise the exemplar is not
one of separate objects and the score means little. Cost O(H·W) for the labelling plus one small matrix
product per batch of candidate components.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..base.validate import as_image, positive_int
from ..errors import ParameterError, ShapeError
from .metrics_common import _finite, _ratio
from .metrics_repetition import luminance

OBJECT_IOU = 0.75
"""Intersection over union at or above which an output component counts as one intact exemplar object."""
MIN_OBJECT_AREA = 16
"""Typical object area (pixels) below which an exemplar is not one of separate objects (``applies`` False):
a 4x4 blob is texture grain, not an object a tile cut could visibly chop."""
FEATURES_PER_TILE = 4
"""Tile side in units of the typical object's diameter that :func:`object_tile_size` asks for (the reasoning:
:mod:`tilesynth.builder.tile_scale`)."""
MAX_OBJECT_TILE = 256
"""Largest tile side :func:`object_tile_size` asks for (the complete sets' default cap)."""
MAX_REFERENCES = 256
"""Reference objects compared at most (evenly spaced in label order): bounds the cost on busy exemplars."""


# ------------------------------------------------------------------------------------------ gradient
@dataclass(frozen=True)
class LatticeGradient:
    """Lattice (gradient) of an image on an N x N grid (:func:`lattice_gradient`; module docstring).

    ``ratio_x`` (vertical lattice lines: horizontal pairs) and ``ratio_y`` are None for a direction with under
    two tiles; ``phase_x`` / ``phase_y`` are the phases of their maxima (0 = across the tile border);
    ``profile_x`` / ``profile_y`` the per-phase means divided by their median."""

    score: float
    ratio_x: float | None
    ratio_y: float | None
    phase_x: int | None
    phase_y: int | None
    profile_x: list[float] | None
    profile_y: list[float] | None
    tile_size: int

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def _phase_means(d2: np.ndarray, n: int) -> np.ndarray:
    """Mean of ``d2`` ``(lines, pairs)`` per phase (j + 1) mod n of its pair index j."""
    cls = np.arange(1, d2.shape[1] + 1) % n
    sums = np.bincount(cls, weights=d2.sum(axis=0), minlength=n)
    counts = np.bincount(cls, minlength=n) * d2.shape[0]
    return sums / np.maximum(counts, 1)


def lattice_gradient(image: np.ndarray, tile_size: int) -> LatticeGradient:
    """Lattice (gradient) of ``image`` on the grid of ``tile_size`` x ``tile_size`` cells from its top-left.

    Raises ShapeError when the image is under two tiles in both directions."""
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    h, w = img.shape[:2]
    if h < 2 * n and w < 2 * n:
        raise ShapeError(f"tile_size = {n}: the {w}x{h} image is under two tiles in both directions")
    x = img.astype(np.float64)
    parts: dict[str, Any] = {}
    ratios = []
    for axis, length in (("x", w), ("y", h)):
        if length < 2 * n:
            parts.update({f"ratio_{axis}": None, f"phase_{axis}": None, f"profile_{axis}": None})
            continue
        if axis == "x":
            d2 = ((x[:, 1:] - x[:, :-1]) ** 2).sum(axis=2)
        else:
            d2 = ((x[1:] - x[:-1]) ** 2).sum(axis=2).T
        prof = _phase_means(d2, n)
        med = float(np.median(prof))
        r = _ratio(float(prof.max()), med)
        ratios.append(r)
        parts.update(
            {
                f"ratio_{axis}": r,
                f"phase_{axis}": int(np.argmax(prof)),
                f"profile_{axis}": [float(v) for v in (prof / med if med > 0 else prof)],
            }
        )
    return LatticeGradient(score=float(max(ratios)), tile_size=n, **parts)


# ------------------------------------------------------------------------------------------ folded
@dataclass(frozen=True)
class LatticeFolded:
    """Lattice (folded) of an image on an N x N grid (:func:`lattice_folded`; module docstring)."""

    score: float
    peak: tuple[int, int]
    peak_z: float
    cells: int
    tile_size: int

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def folded_mean(image: np.ndarray, tile_size: int) -> np.ndarray:
    """``(N, N)`` float64: the luminance averaged over the whole N x N cells of ``image`` (F of the module
    docstring), for pictures of what sits at fixed tile positions."""
    y = luminance(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    rows, cols = y.shape[0] // n, y.shape[1] // n
    if rows * cols < 2:
        raise ShapeError(f"tile_size = {n}: the {y.shape[1]}x{y.shape[0]} image holds under two whole cells")
    return y[: rows * n, : cols * n].reshape(rows, n, cols, n).mean(axis=(0, 2))


def lattice_folded(image: np.ndarray, tile_size: int) -> LatticeFolded:
    """Lattice (folded) of ``image`` on the grid of ``tile_size`` x ``tile_size`` cells from its top-left.

    Raises ShapeError when the image holds under two whole cells; a flat image scores NaN."""
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    f = folded_mean(img, n)
    rows, cols = img.shape[0] // n, img.shape[1] // n
    m = rows * cols
    y = luminance(img)[: rows * n, : cols * n]
    unit = float(y.std()) / math.sqrt(m)
    dev = np.abs(f - f.mean())
    pk = np.unravel_index(int(np.argmax(dev)), dev.shape)
    return LatticeFolded(
        score=_ratio(float(f.std()), unit),
        peak=(int(pk[0]), int(pk[1])),
        peak_z=_ratio(float(dev[pk]), unit),
        cells=m,
        tile_size=n,
    )


# ------------------------------------------------------------------------------------------ objects
def label_components(mask: np.ndarray) -> tuple[np.ndarray, int]:
    """4-connected components of a 2-d bool mask: ``(labels int32 (H, W), count)``, 0 = background, the
    components numbered 1..count in the order of their first pixel (row-major). Union-find by hooking roots
    to the smaller root over every foreground edge and pointer jumping, vectorised (a handful of rounds)."""
    m = np.asarray(mask, bool)
    if m.ndim != 2:
        raise ShapeError(f"mask must be 2-d, got shape {m.shape}")
    h, w = m.shape
    idx = np.arange(h * w, dtype=np.int64).reshape(h, w)
    ex, ey = m[:, :-1] & m[:, 1:], m[:-1] & m[1:]
    a = np.concatenate([idx[:, :-1][ex], idx[:-1][ey]])
    b = np.concatenate([idx[:, 1:][ex], idx[1:][ey]])
    parent = idx.ravel().copy()
    while a.size:
        pa, pb = parent[a], parent[b]
        diff = pa != pb
        if not diff.any():
            break
        pa, pb = pa[diff], pb[diff]
        np.minimum.at(parent, np.maximum(pa, pb), np.minimum(pa, pb))
        while True:  # full path compression: every pixel points at its root
            nxt = parent[parent]
            if np.array_equal(nxt, parent):
                break
            parent = nxt
        a, b = a[diff], b[diff]
    roots = parent[m.ravel()]
    uniq, inv = np.unique(roots, return_inverse=True)  # roots are the smallest index: row-major first pixel
    labels = np.zeros(h * w, np.int32)
    labels[np.flatnonzero(m.ravel())] = inv.astype(np.int32) + 1
    return labels.reshape(h, w), int(uniq.size)


def otsu_threshold(values: np.ndarray, bins: int = 256) -> float:
    """Otsu's threshold of values in [0, 1] (largest between-class variance over ``bins`` levels)."""
    hist, edges = np.histogram(np.clip(values, 0, 1), bins=bins, range=(0.0, 1.0))
    p = hist.astype(np.float64) / max(hist.sum(), 1)
    centres = (edges[:-1] + edges[1:]) / 2
    w0 = np.cumsum(p)
    mu = np.cumsum(p * centres)
    mu_t = mu[-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        between = (mu_t * w0 - mu) ** 2 / (w0 * (1 - w0))
    between[~np.isfinite(between)] = -1
    return float(edges[int(np.argmax(between)) + 1])


@dataclass
class _Components:
    labels: np.ndarray
    areas: np.ndarray  # index 0 = background
    border: np.ndarray  # bool per label: touches the image border


def _components(fg: np.ndarray) -> _Components:
    labels, k = label_components(fg)
    areas = np.bincount(labels.ravel(), minlength=k + 1)
    border = np.zeros(k + 1, bool)
    for edge in (labels[0], labels[-1], labels[:, 0], labels[:, -1]):
        border[edge] = True
    border[0] = True
    return _Components(labels, areas, border)


def _canvases(comp: _Components, which: np.ndarray, side: int) -> tuple[np.ndarray, np.ndarray]:
    """Centroid-aligned masks of the components ``which`` on ``side`` x ``side`` canvases (side odd, the
    rounded centroid at the centre), flattened: ``(len(which), side²)`` float32, and a bool per component
    saying whether it fitted (a component reaching past the canvas cannot match)."""
    out = np.zeros((len(which), side * side), np.float32)
    fits = np.zeros(len(which), bool)
    if not len(which):
        return out, fits
    lab = comp.labels
    pos = np.full(int(lab.max()) + 1, -1, np.int64)
    pos[which] = np.arange(len(which))
    ys, xs = np.nonzero(lab)
    sel = pos[lab[ys, xs]]
    keep = sel >= 0
    ys, xs, sel = ys[keep], xs[keep], sel[keep]
    cnt = np.bincount(sel, minlength=len(which)).astype(np.float64)
    cy = np.rint(np.bincount(sel, weights=ys, minlength=len(which)) / np.maximum(cnt, 1)).astype(np.int64)
    cx = np.rint(np.bincount(sel, weights=xs, minlength=len(which)) / np.maximum(cnt, 1)).astype(np.int64)
    c = side // 2
    oy, ox = ys - cy[sel] + c, xs - cx[sel] + c
    inside = (oy >= 0) & (oy < side) & (ox >= 0) & (ox < side)
    fits[:] = True
    fits[np.unique(sel[~inside])] = False
    out[sel[inside], oy[inside] * side + ox[inside]] = 1.0
    return out, fits


@dataclass(frozen=True)
class ObjectsIntact:
    """Share of object pixels in intact objects (:func:`objects_intact`; module docstring)."""

    share: float
    exemplar_share: float
    applies: bool
    n_reference: int
    reference_area: float
    n_counted: int
    n_intact: int
    threshold: float
    polarity: str

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def objects_intact(
    image: np.ndarray, exemplar: np.ndarray, polarity: str = "auto", iou: float = OBJECT_IOU
) -> ObjectsIntact:
    """Objects intact: the share of the output's object pixels that lie in whole exemplar objects.

    ``polarity``: "auto" (the foreground is the smaller side of the exemplar's Otsu threshold), "bright" or
    "dark"; ``iou`` in (0, 1]: the overlap an output component needs with a reference object. An exemplar
    without reference objects gives share NaN and ``applies`` False."""
    img, ex = as_image(image), as_image(exemplar, "exemplar")
    if polarity not in ("auto", "bright", "dark"):
        raise ParameterError(f"polarity = {polarity!r}: must be 'auto', 'bright' or 'dark'")
    if not (isinstance(iou, (int, float)) and 0 < iou <= 1):
        raise ParameterError(f"iou = {iou!r}: must be in (0, 1]")
    # the exemplar against itself (its own share; object_tile_size, which every build's objects check runs):
    # one luminance and one labelling, not two of the same
    same = img is ex
    ye = luminance(ex)
    yi = ye if same else luminance(img)
    t = otsu_threshold(ye)
    if polarity == "auto":
        polarity = "bright" if (ye > t).mean() <= 0.5 else "dark"
    fg_ex, fg_img = (ye > t, yi > t) if polarity == "bright" else (ye <= t, yi <= t)
    ce = _components(fg_ex)
    ci = ce if same else _components(fg_img)
    interior = np.flatnonzero(~ce.border)
    nan_result = ObjectsIntact(math.nan, math.nan, False, 0, math.nan, 0, 0, t, polarity)
    if not interior.size:
        return nan_result
    # the typical object: the area-weighted median (half the interior foreground pixels lie in components at
    # most this large), so that threshold specks, however many, do not decide what one object is
    areas = np.sort(ce.areas[interior]).astype(np.float64)
    med = float(areas[np.searchsorted(np.cumsum(areas), areas.sum() / 2)])
    ref = interior[(ce.areas[interior] >= med / 2) & (ce.areas[interior] <= med * 2)]
    if ref.size > MAX_REFERENCES:
        ref = ref[np.linspace(0, ref.size - 1, MAX_REFERENCES).round().astype(np.int64)]
    ref_area = float(np.median(ce.areas[ref]))
    speck = 0.1 * ref_area
    # canvas: room for the farthest reference pixel from its centroid (+2 for rounding and tolerance)
    ys, xs = np.nonzero(np.isin(ce.labels, ref))
    lab = ce.labels[ys, xs]
    cnt = np.bincount(lab, minlength=ce.areas.size).astype(np.float64)
    cy = np.bincount(lab, weights=ys, minlength=ce.areas.size) / np.maximum(cnt, 1)
    cx = np.bincount(lab, weights=xs, minlength=ce.areas.size) / np.maximum(cnt, 1)
    reach = float(np.max(np.maximum(np.abs(ys - cy[lab]), np.abs(xs - cx[lab])))) if ys.size else 0.0
    side = 2 * int(math.ceil(reach)) + 5
    refs, _ = _canvases(ce, ref, side)
    sq = refs.reshape(-1, side, side)
    orient = [sq, sq[:, ::-1], sq[:, :, ::-1], sq[:, ::-1, ::-1]]
    orient += [o.transpose(0, 2, 1) for o in orient]
    bank = np.concatenate([o.reshape(len(ref), -1) for o in orient])  # (8·R, side²)
    bank_area = bank.sum(axis=1)
    lo_area, hi_area = float(bank_area.min()) * iou, float(bank_area.max()) / iou

    def share(comp: _Components) -> tuple[float, int, int]:
        counted = np.flatnonzero(~comp.border & (comp.areas >= speck))
        if not counted.size:
            return math.nan, 0, 0
        areas = comp.areas[counted]
        cand = counted[(areas >= lo_area) & (areas <= hi_area)]
        intact_area, n_intact = 0.0, 0
        for s in range(0, cand.size, 512):
            batch = cand[s : s + 512]
            masks, fits = _canvases(comp, batch, side)
            inter = bank @ masks.T  # (8·R, B)
            union = bank_area[:, None] + masks.sum(axis=1)[None, :] - inter
            ok = fits & ((inter / np.maximum(union, 1)) >= iou - 1e-9).any(axis=0)
            intact_area += float(comp.areas[batch][ok].sum())
            n_intact += int(ok.sum())
        return intact_area / float(areas.sum()), int(counted.size), n_intact

    ex_share, n_counted, n_intact = share(ce)
    out_share = ex_share
    if not same:
        out_share, n_counted, n_intact = share(ci)
    return ObjectsIntact(
        share=out_share,
        exemplar_share=ex_share,
        applies=bool(ref.size >= 4 and ex_share >= 0.5 and ref_area >= MIN_OBJECT_AREA),
        n_reference=int(ref.size),
        reference_area=ref_area,
        n_counted=n_counted,
        n_intact=n_intact,
        threshold=t,
        polarity=polarity,
    )


def object_tile_size(exemplar: np.ndarray) -> tuple[int | None, float]:
    """The tile side an exemplar of separate objects asks for, and the objects' scale: ``(size, d)`` with ``d =
    2·√(A/π)`` the equivalent diameter of the typical object (``A`` the reference area of
    :func:`objects_intact`) and ``size`` = :data:`FEATURES_PER_TILE`·d rounded up to a multiple of 8, at most
    half the shorter side (rounded down to a multiple of 8) and :data:`MAX_OBJECT_TILE`; ``(None, 0.0)`` where
    the exemplar is not one of separate objects. What :func:`tilesynth.builder.tile_scale.feature_tile_size`
    builds with and the ``objects-cut`` warning (:mod:`tilesynth.measure.diagnose`) compares a build's tiles
    with."""
    ex = as_image(exemplar, "exemplar")
    obj = objects_intact(ex, ex)
    if not obj.applies:
        return None, 0.0
    scale = 2 * math.sqrt(obj.reference_area / math.pi)
    cap = min(MAX_OBJECT_TILE, 8 * (min(ex.shape[:2]) // 2 // 8))
    return min(cap, 8 * math.ceil(FEATURES_PER_TILE * scale / 8)), scale
