"""The seam blend of smooth maps in export version 2 (:mod:`tilesynth.engine.provenance_export`): which maps
are blended and with which bands (:func:`seam_plans`), and the texture of exact label shares the shaders' blend
weights read (:func:`blend_coverage`, laid out by :func:`blend_layout`): the formula of
:mod:`tilesynth.synth.seams` on the GPU."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError
from . import atlas as _atlas

if TYPE_CHECKING:
    from .provenance_export import QuadrantForm

__all__ = [
    "blend_coverage",
    "blend_layout",
    "blend_plan",
    "blend_shares",
    "low_band_image",
    "packs_low_band",
    "seam_plans",
]


# ------------------------------------------------------------------------------------------ the seam blend
def blend_plan(tile_size: int, kind: str) -> dict[str, float] | None:
    """The bands of the seam blend of a ``kind`` map on tiles of ``tile_size`` (those of ``synthesize_maps``:
    :func:`tilesynth.synth.seams.tile_bands` of the defaults), or None when the GPU cannot blend it: not a
    scalar or normal map, or tiles whose quadrants are not whole blocks of every level the bands read
    (``N`` a multiple of ``2^(L + 1)``, ``L`` the band's highest level: 16 for the detail band, 64 with the
    low band), or a detail band above level 3 (its coverage counts must be exact in 8 bits)."""
    from ..synth import seams

    if kind not in ("scalar", "normal"):
        return None
    bands = seams.tile_bands(seams.check_bands(None, kind), tile_size)
    top = max(bands["high"], bands.get("low", 0.0))
    if bands["high"] > 3.0 or tile_size % (1 << (int(np.ceil(top)) + 1)):
        return None
    return bands


def blend_shares(counts: np.ndarray, tile_size: int, high: int, span: tuple[int, int] | None) -> np.ndarray:
    """float32 shares ``count / 4^l`` of a blend coverage texture of counts (:func:`blend_coverage`): what a
    renderer uploads as R16F (exact in half floats)."""
    n = tile_size
    cw, ch = blend_cell(n, high, span)
    div = np.ones((ch, cw))
    div[: n >> high, : n >> high] = 4.0**high
    if span is not None:
        y = 0
        for lv in range(span[0], span[1] + 1):
            div[y : y + (n >> lv), n >> high : (n >> high) + (n >> lv)] = 4.0**lv
            y += n >> lv
    rows, cols = counts.shape[0] // ch, counts.shape[1] // cw
    return (counts / np.tile(div, (rows, cols))).astype(np.float32)


def blend_layout(
    plans: dict[str, dict[str, float] | None], tile_size: int
) -> tuple[int, tuple[int, int] | None, int] | None:
    """``(high level, reach levels or None, reach)`` of the blend coverage the maps ``plans`` (:func:`seam_plans`)
    read, or None when no map is blended; one coverage serves every map, so their bands must agree."""
    got = [b for b in plans.values() if b is not None]
    if not got:
        return None
    highs = {int(np.ceil(b["high"])) for b in got}
    lows = {(reach_span(b), int(b["reach"])) for b in got if "low" in b}
    if len(highs) > 1 or len(lows) > 1:
        raise ParameterError("the blended maps' bands differ: one blend coverage serves them all")
    span, reach = lows.pop() if lows else (None, 1)
    return highs.pop(), span, reach


def reach_span(bands: dict[str, float]) -> tuple[int, int]:
    """``(first, last)``: the levels of the reach-extended labels the low band reads (``log2 R`` to
    ``ceil(low)``)."""
    first = int(np.log2(bands["reach"]))
    return first, max(first, int(np.ceil(bands["low"])))


def blend_cell(tile_size: int, high: int, span: tuple[int, int] | None) -> tuple[int, int]:
    """``(width, height)`` of a tile's cell in the blend coverage: the labels' level ``high`` (``N >> high``
    square) at the left; with ``span`` ``(first, last)``, the reach-extended levels stacked at its right (the
    first at the top)."""
    n = tile_size
    if span is None:
        return n >> high, n >> high
    ext = [n >> lv for lv in range(span[0], span[1] + 1)]
    return (n >> high) + ext[0], max(n >> high, sum(ext))


def blend_coverage(
    form: QuadrantForm, high: int, reach: int, span: tuple[int, int] | None
) -> tuple[np.ndarray, int]:
    """uint16 ``(rows·h, cols·w)`` texture of counts and its cell columns: for every tile, the number of pixels of
    entry B in each ``2^high`` block of its labels, and with ``span`` ``(first, last)`` in each ``2^l`` block
    (``l`` in first..last) of its labels extended ``reach`` px from the tile border
    (:func:`tilesynth.synth.seams.border_labels`: every pixel nearer than ``reach`` to the border takes the bit
    of its nearest border pixel, which lies in its own quadrant); laid out by :func:`blend_cell`, cells as the
    coverage's (:func:`tilesynth.engine.atlas.grid_for`). A renderer uploads it as R16F, ``count / 4^l``: exact
    shares, bilinear-filtered by the sampler."""
    from ..synth.seams import border_labels

    k, n = form.n_tiles, form.tile_size
    cols, rows = _atlas.grid_for(k)
    cw, ch = blend_cell(n, high, span)
    out = np.zeros((rows * ch, cols * cw), np.uint16)

    def put(counts: np.ndarray, x: int, y: int) -> None:
        side = counts.shape[1]
        for t in range(k):
            r, c = divmod(t, cols)
            out[r * ch + y : r * ch + y + side, c * cw + x : c * cw + x + side] = counts[t]

    def block_counts(lab: np.ndarray, lv: int) -> np.ndarray:
        s, side = 1 << lv, n >> lv
        return lab.reshape(k, side, s, side, s).sum(axis=(2, 4))

    bits = form.bits.astype(np.int64)
    put(block_counts(bits, high), 0, 0)
    if span is not None:
        ext = border_labels(form.bits.astype(np.uint8), int(reach)).astype(np.int64)
        y = 0
        for lv in range(span[0], span[1] + 1):
            put(block_counts(ext, lv), n >> high, y)
            y += n >> lv
    return out, cols


def seam_plans(
    entries: list[dict[str, Any]], tile_size: int, given: dict[str, Any] | None, map_smooth: str
) -> dict[str, dict[str, float] | None]:
    """``{name: bands or None}``: the maps the shaders blend with the seam blend of ``synthesize_maps``
    (:func:`blend_plan`): every scalar and normal map unless ``map_smooth`` is "off" (copies, as ``synth
    --map-smooth off``) or ``given`` (the ``blend_levels``) names it (the coverage weighting at that level)."""
    given = given or {}
    return {
        e["name"]: None if map_smooth == "off" or e["name"] in given else blend_plan(tile_size, e["kind"])
        for e in entries
    }


def map_mean(arr: np.ndarray) -> list[float]:
    """The mean of every channel of a map over the exemplar, in the values the shaders read (codes over their
    maximum; float maps as they are): the ``μ`` of the low band's variance-preserving blend."""
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype, 1.0)
    return [float(v) for v in (arr.reshape(-1, arr.shape[2]).astype(np.float64) / scale).mean(axis=0)]


def packs_low_band(kind: str, channels: int, bands: dict[str, float] | None) -> bool:
    """Whether a map's texture carries its low band beside its value (:func:`low_band_image`): a one-channel
    scalar map blended with a low band. Then one fetch per entry serves the value and the low band."""
    return bands is not None and "low" in bands and kind == "scalar" and channels == 1


def low_band_image(arr: np.ndarray, split: int) -> np.ndarray:
    """The low band of the seam blend at every pixel of a map ``(H, W, C)``, in its sample type: the bilinear
    sample of its ``2^split`` box mip at the pixel centre (:func:`tilesynth.synth.seams.box_mip`,
    :func:`~tilesynth.synth.seams.sample_mip`: a partial last block averages its own pixels, indices mirrored),
    rounded half to even to the map's codes (float maps: float32). The texel the shaders read at a pixel centre
    is the CPU's ``a_e`` there, for any exemplar side (the map's own mip chain drops an odd row instead)."""
    from ..synth.seams import box_mip, sample_mip

    h, w, c = arr.shape
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype)
    mip = box_mip(arr.astype(np.float64) / (scale or 1.0), int(split))
    out = np.empty(arr.shape, arr.dtype)
    for r0 in range(0, h, 256):  # bounded memory: rows of 256 at a time
        rr, cc = np.mgrid[r0 : min(h, r0 + 256), 0:w]
        low = sample_mip(mip, int(split), np.stack([rr, cc], axis=-1))
        out[r0 : r0 + rr.shape[0]] = (
            np.rint(np.clip(low, 0.0, 1.0) * scale).astype(arr.dtype) if scale else low.astype(np.float32)
        )
    return out
