"""The seam blend of smooth material maps: weights from each tile's label coverage, the sources read across the cut.

A tile of a pure-copy set is pieces of the exemplar (:mod:`tilesynth.tileset.provenance`): pixel ``p`` of tile
``t`` shows entry ``e = λ_t(p)`` of the tile's source table, i.e. ``M[D_{s_e}(p) + b_e]`` for every map ``M``
aligned with the exemplar. Copied as they are, smooth maps (height, roughness, normals) show each cut as a cliff
(the level offset of two patches); a gradient-domain fusion removes the cliffs but flattens the relief
(:mod:`tilesynth.builder.fusion`: height std 0.2-0.8x of the exemplar's). This module blends instead: near a
cut, every entry that covers some of the pixel's neighbourhood is read *at the pixel* (the piece of the
exemplar continued past the cut) and the values are averaged with the share of the neighbourhood each entry
covers. Local, defined from the labels and the sources only, and the same on CPU and GPU.

**The exact formula** (for one map; every float in float64 on the CPU; the GPU may use float32).

1. *Coverage mips.* For tile ``t`` with ``E`` entries and labels ``λ`` (``N x N``), level ``l`` has
   ``n_l = ceil(N / 2^l)`` texels per side; texel ``(i, j)`` of entry ``e`` is the share of pixels labelled ``e``
   in the block rows ``[i·2^l, min((i+1)·2^l, N))`` x columns ``[j·2^l, min((j+1)·2^l, N))`` (a box filter;
   a partial last block averages its own pixels). Level 0 is the indicator ``[λ = e]``.
2. *Level per pixel.* ``d(p) = min(y, x, N−1−y, N−1−x)`` (distance to the tile border, pixels) and
   ``lod(p) = min(L, log2(1 + d(p)))``, ``L`` the map's blend level (:data:`LEVELS`). The blend narrows to the
   plain copy on the border ring (``lod = 0``), which is shared with the neighbouring tile, so tilings stay
   seamless without reading any neighbour's labels.
3. *Weights.* ``C_e^l(p)``: the bilinear sample of level ``l`` at the pixel centre: ``u = (x + 0.5) / 2^l − 0.5``,
   ``j0 = floor(u)``, ``fx = u − j0``, texel indices ``j0`` and ``j0 + 1`` clamped to ``[0, n_l − 1]`` (clamp to
   the tile's own edge), likewise rows. Then ``w_e(p) = (1 − f)·C_e^{l0}(p) + f·C_e^{l0+1}(p)``, ``l0 =
   floor(lod)``, ``f = lod − l0`` (trilinear). The weights are non-negative and sum to 1; on the GPU this is a
   ``textureLod`` of a coverage texture at ``lod`` with linear filtering, clamped per tile.
4. *Sources.* ``v_e(p) = M[m_H(r), m_W(c)]`` with ``(r, c) = D_{s_e}(p) + b_e``, for every entry with
   ``w_e(p) > 0``, ``m_S`` the mirrored repeat (GL ``MIRRORED_REPEAT``: ``i mod 2S``, then ``2S − 1 − i`` past
   ``S``): near a cut the other entry is read beyond its own piece, which may leave the exemplar by at most
   about ``1.5·2^L`` px where a piece touches the exemplar's edge; mirroring continues the texture without a
   step (clamping would smear one row into streaks, wrapping would jump to the opposite edge of a non-tileable
   exemplar).
5. *Blend.* Scalar maps (height, roughness, any linear data): ``out = Σ_e w_e v_e`` (a linear blend; measured
   against a variance-preserving ``μ + (Σ w v − μ)/√(Σ w²)``, which amplified structured maps' edges into 3x
   the copies' cliffs: ``benches/relief-results.md``). Normal maps: each entry's decoded vector ``n_e`` (its
   codes first turned with the entry's symmetry ``s_e``, as the copies are) becomes a slope ``σ_e = (n_x, n_y) /
   max(n_z, 1/16)``, the slopes are blended ``σ = Σ_e w_e σ_e`` and ``n = normalise(σ_x, σ_y, 1)`` (the
   normal of the blended height field when the heights are blended with the same weights: derivative
   blending). A pixel whose weight is 1 for one entry is that entry's copy, byte for byte (the copies of
   ``smooth=False``).
6. *Encoding.* Unsigned scalar maps: ``rint(clip(out, 0, 1) · S)`` (round half to even, ``S`` = 255 or 65535,
   values read as ``code / S``); float maps: float32 (no clip). Normal maps: the unit-length code of
   :func:`tilesynth.io.normal_codes.encode_unit` (every vector within 1 ± 0.005 after decoding).

Where a footprint straddles a cut the GPU reads the entries with non-zero weight: two on a plain cut, up to
five where the tile's quadrant cross meets the cut.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = [
    "LEVELS",
    "ZMIN",
    "blend_tiles",
    "blend_weights",
    "border_lod",
    "coverage",
    "entry_coords",
    "mirror",
    "sample_coverage",
]

LEVELS: dict[str, float] = {"scalar": 3.0, "normal": 3.0}
"""The blend level ``L`` of each smooth map kind: transitions about ``2^L`` = 8 px wide (module docstring, step 2).
Chosen on the tuning materials (pypbr's rocks and tiles, ambientCG Rock053 and Ground048,
``benches/relief.py``): level 2 leaves cliffs (measure 1.9-5.4 on three of four), level 3 brings the organic
ones to 0.6-0.9 with the height's std within 2-4 % of the copies', level 4-5 lowers cliffs further but costs
relief (std 3-8 % below the copies)."""

ZMIN = 1.0 / 16.0
"""The smallest ``n_z`` a normal's slope divides by (slopes up to 16: 86°)."""

CHUNK_TILES = 16
"""Tiles blended at once (about 40 float64 copies of a tile's pixels per entry)."""


def mirror(i: np.ndarray, size: int) -> np.ndarray:
    """GL ``MIRRORED_REPEAT`` of integer texel indices: ``-1 -> 0``, ``size -> size - 1``, period ``2·size``."""
    m = np.mod(i, 2 * size)
    return np.where(m >= size, 2 * size - 1 - m, m)


def border_lod(n: int, level: float) -> np.ndarray:
    """float64 ``(n, n)``: ``min(level, log2(1 + d))``, ``d`` every pixel's distance to the tile border."""
    i = np.arange(n)
    d1 = np.minimum(i, n - 1 - i)
    d = np.minimum(d1[:, None], d1[None, :]).astype(np.float64)
    return np.minimum(float(level), np.log2(1.0 + d))


def coverage(labels: np.ndarray, n_entries: int, level: int) -> np.ndarray:
    """float64 ``(k, E, n_l, n_l)``: the share of each entry's pixels in every ``2^level`` block of ``labels``
    ``(k, N, N)`` (step 1; a partial last block averages its own pixels)."""
    k, n = labels.shape[:2]
    s = 1 << int(level)
    nl = -(-n // s)
    pad = nl * s - n
    onehot = (labels[:, None] == np.arange(n_entries)[None, :, None, None]).astype(np.float64)
    ones = np.ones((n, n))
    if pad:
        onehot = np.pad(onehot, ((0, 0), (0, 0), (0, pad), (0, pad)))
        ones = np.pad(ones, ((0, pad), (0, pad)))
    sums = onehot.reshape(k, n_entries, nl, s, nl, s).sum(axis=(3, 5))
    return sums / ones.reshape(nl, s, nl, s).sum(axis=(1, 3))


def sample_coverage(cov: np.ndarray, level: int, n: int) -> np.ndarray:
    """float64 ``(k, E, n, n)``: bilinear samples of the level-``level`` coverage ``cov`` at every pixel centre,
    texel indices clamped to the tile (step 3)."""
    nl = cov.shape[-1]
    u = (np.arange(n) + 0.5) / float(1 << int(level)) - 0.5
    i0 = np.floor(u).astype(np.int64)
    f = u - i0
    a, b = np.clip(i0, 0, nl - 1), np.clip(i0 + 1, 0, nl - 1)
    rows = cov[:, :, a] * (1.0 - f)[:, None] + cov[:, :, b] * f[:, None]
    return rows[..., a] * (1.0 - f) + rows[..., b] * f


def blend_weights(labels: np.ndarray, n_entries: int, level: float) -> np.ndarray:
    """float64 ``(k, E, N, N)``: the weight of every entry at every pixel of tiles with labels ``(k, N, N)``
    (steps 1-3)."""
    labels = np.asarray(labels)
    n = labels.shape[1]
    lod = border_lod(n, level)
    l0 = np.floor(lod).astype(np.int64)
    f = lod - l0
    w = np.zeros((labels.shape[0], n_entries, n, n))
    for lv in range(int(np.ceil(level)) + 1):
        share = np.where(l0 == lv, 1.0 - f, 0.0) + np.where(l0 + 1 == lv, f, 0.0)
        if share.any():
            w += sample_coverage(coverage(labels, n_entries, lv), lv, n) * share
    return w


def entry_coords(table: np.ndarray, n: int, height: int, width: int) -> np.ndarray:
    """int64 ``(k, E, N, N, 2)``: the exemplar (row, col) each entry of ``table`` ``(k, E, 3)`` reads at every
    tile pixel, mirrored into a ``height x width`` exemplar (step 4; missing entries read as symmetry 0)."""
    from ..tileset.provenance import dihedral_grid

    grids = np.stack([dihedral_grid(s, n) for s in range(8)])
    tab = np.asarray(table, np.int64)
    c = grids[np.maximum(tab[..., 0], 0)] + tab[..., None, None, 1:]
    c[..., 0] = mirror(c[..., 0], height)
    c[..., 1] = mirror(c[..., 1], width)
    return c


def check_level(level: Any, name: str = "level") -> float:
    """A blend level: a finite number in [0, 8]."""
    number = isinstance(level, (int, float, np.integer, np.floating)) and not isinstance(
        level, (bool, np.bool_)
    )
    lv = float(level) if number else float("nan")
    if not (0.0 <= lv <= 8.0):
        raise ParameterError(f"{name} = {level!r}: expected a number in [0, 8] (the seam blend's mip level)")
    return lv


def _slopes(codes: np.ndarray, encoding: str) -> np.ndarray:
    from ..io.normal_codes import decode

    v = decode(codes, encoding)
    return v[..., :2] / np.maximum(v[..., 2:3], ZMIN)


def blend_tiles(
    image: np.ndarray,
    prov: Any,
    tiles: np.ndarray,
    kind: str = "scalar",
    level: float | None = None,
    encoding: str = "unorm",
    y_down: bool = False,
) -> np.ndarray:
    """The tiles ``tiles`` (indices) of the map ``image`` ``(H, W, C)`` (uint8, uint16 or float32, aligned with
    the exemplar; for normal maps unit vectors, e.g. renormalised once) with their seams blended (module
    docstring): ``(k, N, N, C)`` in the map's sample type. ``kind``: "scalar" or "normal" (``encoding``
    "unorm" / "snorm", ``y_down`` the DirectX convention, for turning the vectors of rotated or mirrored
    entries); ``level``: None for :data:`LEVELS`."""
    from ..builder.matching.augment import transform_normal_codes
    from ..io.normal_codes import encode_unit

    if kind not in LEVELS:
        raise ParameterError(f"kind = {kind!r}: expected one of {', '.join(LEVELS)}")
    lv = LEVELS[kind] if level is None else check_level(level)
    img = np.asarray(image)
    h, w, c = img.shape
    idx = np.asarray(tiles, np.int64).reshape(-1)
    n = prov.tile_size
    out = np.empty((idx.size, n, n, c), img.dtype)
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(img.dtype)
    for lo in range(0, idx.size, CHUNK_TILES):
        part = idx[lo : lo + CHUNK_TILES]
        lab, tab = prov.labels[part], prov.table[part]
        e = tab.shape[1]
        wts = blend_weights(lab, e, lv) * (tab[:, :, 0, None, None] >= 0)
        coords = entry_coords(tab, n, h, w)
        vals = img[coords[..., 0], coords[..., 1]]  # (k, E, N, N, C)
        if kind == "normal":
            sym = np.maximum(tab[..., 0], 0)[:, :, None, None]
            if (sym != 0).any():
                vals = transform_normal_codes(vals, np.broadcast_to(sym, vals.shape[:-1]), encoding, y_down)
        # a pixel whose weight is 1 for one entry is that entry's copy, byte for byte
        own = np.take_along_axis(vals, lab[:, None, :, :, None].astype(np.int64), axis=1)[:, 0]
        single = wts.max(axis=1) >= 1.0
        if kind == "normal":
            s = _slopes(vals, encoding)
            sl = (wts[..., None] * s).sum(axis=1)
            nv = np.concatenate([sl, np.ones(sl.shape[:-1] + (1,))], axis=-1)
            blended = encode_unit(nv[~single], img.dtype, encoding)
        else:
            f = vals.astype(np.float64) / (scale or 1.0)
            b = (wts[..., None] * f).sum(axis=1)[~single]
            if scale:
                blended = np.rint(np.clip(b, 0.0, 1.0) * scale).astype(img.dtype)
            else:
                blended = b.astype(np.float32)
        own[~single] = blended
        out[lo : lo + part.size] = own
    return out
