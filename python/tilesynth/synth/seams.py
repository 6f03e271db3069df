"""The seam blend of smooth material maps: weights from each tile's label coverage, the sources read across the cut.

A tile of a pure-copy set is pieces of the exemplar (:mod:`tilesynth.tileset.provenance`): pixel ``p`` of tile
``t`` shows entry ``e = λ_t(p)`` of the tile's source table, i.e. ``M[D_{s_e}(p) + b_e]`` for every map ``M``
aligned with the exemplar. Copied as they are, smooth maps (height, roughness, normals) show each cut as a cliff
(the level offset of two patches); a gradient-domain fusion removes the cliffs but flattens the relief
(:mod:`tilesynth.builder.fusion`: height std 0.2-0.8x of the exemplar's). This module blends instead: near a
cut, every entry that covers some of the pixel's neighbourhood is read *at the pixel* (the piece of the
exemplar continued past the cut) and the values are averaged with the share of the neighbourhood each entry
covers. Local, defined from the labels and the sources only, and the same on CPU and GPU.

**The exact formula** (for one map; every float in float64 on the CPU; the GPU may use float32). Its
parameters per map kind are :data:`BANDS` (for tiles of ``N`` >= 128 px; :func:`tile_bands` for smaller ones):
scalar maps ``high = 3``, ``low = 5``, ``split = 4``, ``reach = 16``; normal maps ``high = 3`` only.

1. *Coverage mips.* For tile ``t`` with ``E`` entries and a label plane ``λ`` (``N x N``), level ``l`` has
   ``n_l = ceil(N / 2^l)`` texels per side; texel ``(i, j)`` of entry ``e`` is the share of pixels labelled ``e``
   in the block rows ``[i·2^l, min((i+1)·2^l, N))`` x columns ``[j·2^l, min((j+1)·2^l, N))`` (a box filter;
   a partial last block averages its own pixels). Level 0 is the indicator ``[λ = e]``.
2. *Labels and level per pixel.* ``d(p) = min(y, x, N−1−y, N−1−x)``, the distance to the tile border. A band
   with reach ``R`` (a power of two; ``R = 1`` for the high band) reads the labels ``λ_R``: ``λ`` with every pixel
   of ``d < R`` given the label of its nearest border pixel (``(0 or N−1, x)`` where ``min(y, N−1−y) <= min(x,
   N−1−x)``, else ``(y, 0 or N−1)``; ``λ_1 = λ``), at ``lod(p) = min(L, log2(R + d(p)))``, ``L`` the band's
   level. On the border row ``lod = log2 R``, whose texels cover only the extended border labels: the weights
   there depend only on the border ring, which two neighbouring tiles share (the same pieces, split at the
   same places), so the two sides of every tile border blend the same sources with the same weights and
   tilings stay seamless without reading a neighbour's labels. For ``R = 1`` the border ring is the plain copy.
3. *Weights.* ``C_e^l(p)``: the bilinear sample of level ``l`` of ``λ_R``'s coverage at the pixel centre:
   ``u = (x + 0.5) / 2^l − 0.5``, ``j0 = floor(u)``, ``fx = u − j0``, texel indices ``j0`` and ``j0 + 1``
   clamped to ``[0, n_l − 1]`` (clamp to the tile's own edge), likewise rows. Then ``w_e(p) = (1 − f)·C_e^{l0}(p)
   + f·C_e^{l0+1}(p)``, ``l0 = floor(lod)``, ``f = lod − l0`` (trilinear; ``f = 0`` reads ``l0`` only). The
   weights are non-negative and sum to 1; on the GPU a ``textureLod`` of the band's coverage texture at
   ``lod`` with linear filtering, clamped per tile. ``h_e``: the weights of the high band, ``g_e``: the low
   band's.
4. *Sources.* ``v_e(p) = M[m_H(r), m_W(c)]`` with ``(r, c) = D_{s_e}(p) + b_e``, for every entry with a
   non-zero weight, ``m_S`` the mirrored repeat (GL ``MIRRORED_REPEAT``: ``i mod 2S``, then ``2S − 1 − i`` past
   ``S``): near a cut an entry is read beyond its own piece, which may leave the exemplar where a piece touches
   the exemplar's edge; mirroring continues the texture without a step (clamping would smear one row into
   streaks, wrapping would jump to the opposite edge of a non-tileable exemplar). The low band of an entry,
   ``a_e(p)``, is the bilinear sample of the map's box mip at level ``split`` (step 1's rule on ``M``) at the
   centre of pixel ``(r, c)``: ``u = (c + 0.5) / 2^split − 0.5`` etc., texel indices mirrored as ``m``.
5. *Blend.* Scalar maps (height, roughness, any linear data), per channel, ``μ`` the map's mean over the
   exemplar: ``out = μ + (Σ_e g_e a_e − μ) / √(Σ_e g_e²) + Σ_e h_e (v_e − a_e)``: the low band (level offsets,
   large shapes) blended wide and variance-preserving (Heitz & Neyret 2018: a mix of independent fields keeps
   the exemplar's variance), the detail blended linearly over ``2^high`` px (a variance-preserving detail
   blend amplified the grout of a tiled floor into new cliffs; Burt & Adelson's multi-band blend). Without a
   low band (tiles under 64 px): ``out = Σ_e h_e v_e``. Normal maps: each entry's decoded vector ``n_e``
   becomes a slope ``σ_e = (n_x, n_y) / max(n_z, 1/16)``, turned with the entry's symmetry ``s_e`` (x and y
   swapped and negated exactly in floats; a copy's codes are turned in the codes), ``σ = Σ_e h_e σ_e`` and
   ``n = normalise(σ_x, σ_y, 1)`` (the normal of the blended height field when the heights are blended with
   the same weights: derivative blending). A pixel whose weights are
   1 for one entry in every band is that entry's copy, byte for byte (the copies of ``smooth=False``).
6. *Encoding.* Unsigned scalar maps: ``rint(clip(out, 0, 1) · S)`` (round half to even, ``S`` = 255 or 65535,
   values read as ``code / S``); float maps: float32 (no clip). Normal maps: the unit-length code of
   :func:`tilesynth.io.normal_codes.encode_unit` (every vector within 1 ± 0.005 after decoding; a GPU writing
   floats renormalises instead).

Fetches (GPU): a pixel reads every entry whose weight is non-zero in some band: the value (level 0) and, for
scalar maps, the low band (level ``split``) of each; away from cuts and the border zone one entry, one fetch.
Measured relief, cliffs and speed: ``benches/relief.py``, ``benches/relief-results.md``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = [
    "BANDS",
    "box_mip",
    "check_bands",
    "tile_bands",
    "sample_mip",
    "ZMIN",
    "blend_tiles",
    "blend_weights",
    "border_lod",
    "coverage",
    "entry_coords",
    "mirror",
    "normal_slopes",
    "sample_coverage",
]

BANDS: dict[str, dict[str, float]] = {
    "scalar": {"low": 5.0, "high": 3.0, "split": 4.0, "reach": 16.0},
    "normal": {"high": 3.0},
}
"""The blend of each smooth map kind (module docstring, step 5): ``high``, the level ``L`` of the weights of the
detail (transitions about ``2^L`` = 8 px wide); scalar maps also have a low band, the exemplar's box mip at level
``split`` (16 px), blended variance-preservingly with the weights of level ``low`` (32 px) computed from the
labels extended ``reach`` px in from the tile border. Chosen on the tuning materials (pypbr's rocks and tiles,
ambientCG Rock053 and Ground048; ``benches/relief.py``, ``benches/relief-results.md``, 768² syntheses):

* one linear band at level 3: the height's std 0.86-1.00x (4-6 % below the copies': a blend of two independent
  fields has less variance), cliffs 0.6-0.9 (tiles 2.25); level 2 left cliffs up to 5.4, levels 4-5 cost 3-8 %
  more std;
* one variance-preserving band: the tiles' grout amplified into cliffs of 13-17;
* two bands, the low one narrowed to the plain label at the tile border: std 0.96-1.03x, but the low band's
  level offsets squeezed into the last pixels before the border (Rock053: cliffs 1.27, normal-x correlation
  0.73 of the exemplar's; within 1 px of a border the cliffs were 3.5);
* two bands with the low band's labels extended from the border ring (this): std 0.99-1.05x, cliffs 0.54-0.83
  (tiles 1.70), correlation 0.84-0.99 of the exemplar's; low 6 / split 5 / reach 32: std 0.94-1.05x, tiles
  cliffs 1.92; a high band at level 2: tiles cliffs 3.6."""

ZMIN = 1.0 / 16.0
"""The smallest ``n_z`` a normal's slope divides by (slopes up to 16: 86°)."""

CHUNK_TILES = 16
"""Tiles blended at once (about 40 float64 copies of a tile's pixels per entry)."""


def mirror(i: np.ndarray, size: int) -> np.ndarray:
    """GL ``MIRRORED_REPEAT`` of integer texel indices: ``-1 -> 0``, ``size -> size - 1``, period ``2·size``."""
    m = np.mod(i, 2 * size)
    return np.where(m >= size, 2 * size - 1 - m, m)


def _border_distance(n: int) -> np.ndarray:
    i = np.arange(n)
    d1 = np.minimum(i, n - 1 - i)
    return np.minimum(d1[:, None], d1[None, :])


def border_lod(n: int, level: float, reach: int = 1) -> np.ndarray:
    """float64 ``(n, n)``: ``min(level, log2(reach + d))``, ``d`` every pixel's distance to the tile border."""
    return np.minimum(float(level), np.log2(float(reach) + _border_distance(n)))


def border_labels(labels: np.ndarray, reach: int) -> np.ndarray:
    """``labels`` ``(k, N, N)`` with every pixel closer than ``reach`` to the tile border given the label of the
    nearest border pixel (the row's or column's end; the row's where both are as near)."""
    k, n = labels.shape[:2]
    if reach <= 1:
        return labels
    yy, xx = np.mgrid[0:n, 0:n]
    dy, dx = np.minimum(yy, n - 1 - yy), np.minimum(xx, n - 1 - xx)
    py = np.where(dy <= dx, np.where(yy < n - 1 - yy, 0, n - 1), yy)
    px = np.where(dy <= dx, xx, np.where(xx < n - 1 - xx, 0, n - 1))
    near = np.minimum(dy, dx) < reach
    out = labels.copy()
    out[:, near] = labels[:, py[near], px[near]]
    return out


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


def blend_weights(labels: np.ndarray, n_entries: int, level: float, reach: int = 1) -> np.ndarray:
    """float64 ``(k, E, N, N)``: the weight of every entry at every pixel of tiles with labels ``(k, N, N)``
    (steps 1-3)."""
    labels = border_labels(np.asarray(labels), reach)
    n = labels.shape[1]
    lod = border_lod(n, level, reach)
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


def normal_slopes(codes: np.ndarray, encoding: str) -> np.ndarray:
    """float64 ``(..., 2)``: the slopes ``(n_x, n_y) / max(n_z, ZMIN)`` of normal samples ``(..., 3)``."""
    from ..io.normal_codes import decode

    v = decode(codes, encoding)
    return v[..., :2] / np.maximum(v[..., 2:3], ZMIN)


def box_mip(f: np.ndarray, level: int) -> np.ndarray:
    """float64 ``(ceil(H / 2^l), ceil(W / 2^l), C)``: the box mip of ``f`` ``(H, W, C)`` at ``level`` (a partial
    last block averages its own pixels, as :func:`coverage`)."""
    h, w, c = f.shape
    s = 1 << int(level)
    mh, mw = -(-h // s), -(-w // s)
    pad = ((0, mh * s - h), (0, mw * s - w), (0, 0))
    sums = np.pad(f.astype(np.float64), pad).reshape(mh, s, mw, s, c).sum(axis=(1, 3))
    counts = np.pad(np.ones((h, w, 1)), pad).reshape(mh, s, mw, s, 1).sum(axis=(1, 3))
    return sums / counts


def sample_mip(mip: np.ndarray, level: int, coords: np.ndarray) -> np.ndarray:
    """Bilinear samples ``(..., C)`` of a level-``level`` mip at the centres of level-0 pixels ``coords``
    ``(..., 2)`` (row, col), texel indices mirrored (GL ``MIRRORED_REPEAT``)."""
    s = float(1 << int(level))
    u = (coords[..., 0] + 0.5) / s - 0.5
    v = (coords[..., 1] + 0.5) / s - 0.5
    i0, j0 = np.floor(u).astype(np.int64), np.floor(v).astype(np.int64)
    fu, fv = (u - i0)[..., None], (v - j0)[..., None]
    mh, mw = mip.shape[:2]
    a, b = mirror(i0, mh), mirror(i0 + 1, mh)
    c, d = mirror(j0, mw), mirror(j0 + 1, mw)
    return (1 - fu) * ((1 - fv) * mip[a, c] + fv * mip[a, d]) + fu * ((1 - fv) * mip[b, c] + fv * mip[b, d])


def check_bands(bands: Any, kind: str) -> dict[str, float]:
    """The bands of a blend of a ``kind`` map: :data:`BANDS` ``[kind]`` for None, else ``bands``, a dict of levels
    in [0, 8]: ``high``, and for scalar maps ``low`` with its ``split`` and ``reach`` (a power of two, at most
    128); missing ones from :data:`BANDS`; a scalar map without ``low`` is blended in one linear band."""
    if kind not in BANDS:
        raise ParameterError(f"kind = {kind!r}: expected one of {', '.join(BANDS)}")
    if bands is None:
        return dict(BANDS[kind])
    allowed = {"high"} if kind == "normal" else {"low", "high", "split", "reach"}
    if not isinstance(bands, dict) or not bands or not set(bands) <= allowed:
        raise ParameterError(
            f"bands = {bands!r}: expected a dict with keys among {', '.join(sorted(allowed))} ({kind} maps)"
        )
    got = {k: check_level(v, f"bands[{k!r}]") for k, v in bands.items() if k != "reach"}
    out = {"high": got.get("high", BANDS[kind]["high"])}
    if "low" in got:
        out["low"] = got["low"]
        out["split"] = got.get("split", BANDS["scalar"]["split"])
        reach = bands.get("reach", BANDS["scalar"]["reach"])
        if isinstance(reach, (bool, np.bool_)) or not isinstance(
            reach, (int, float, np.integer, np.floating)
        ):
            reach = 0
        if reach not in (1, 2, 4, 8, 16, 32, 64, 128):
            raise ParameterError(
                f"bands['reach'] = {bands.get('reach')!r}: expected a power of two in [1, 128]"
            )
        out["reach"] = float(reach)
    elif set(bands) & {"split", "reach"}:
        raise ParameterError(f"bands = {bands!r}: 'split' and 'reach' need a 'low' band")
    return out


def tile_bands(bands: dict[str, float], n: int) -> dict[str, float]:
    """The bands used on tiles of ``n`` px: :data:`BANDS` are for tiles of 128 px and more; on smaller tiles the
    low band's ``low`` is at most ``log2(n) − 2``, its ``split`` at most ``floor(low) − 1`` and its ``reach`` at
    most the largest power of two not above ``n / 8`` (so the low band never spans the whole tile); below 64 px
    (``low`` < 4) a scalar map is blended in the one linear band ``high``."""
    if "low" not in bands:
        return dict(bands)
    low = min(bands["low"], np.log2(n) - 2.0)
    if low < 4.0:
        return {"high": bands["high"]}
    reach = min(bands["reach"], 2.0 ** np.floor(np.log2(n / 8.0)))
    return {"high": bands["high"], "low": float(low), "split": float(min(bands["split"], np.floor(low) - 1.0)),
            "reach": float(reach)}  # fmt: skip


def blend_tiles(
    image: np.ndarray,
    prov: Any,
    tiles: np.ndarray,
    kind: str = "scalar",
    bands: dict[str, float] | None = None,
    encoding: str = "unorm",
    y_down: bool = False,
) -> np.ndarray:
    """The tiles ``tiles`` (indices) of the map ``image`` ``(H, W, C)`` (uint8, uint16 or float32, aligned with
    the exemplar; for normal maps unit vectors, e.g. renormalised once) with their seams blended (module
    docstring): ``(k, N, N, C)`` in the map's sample type. ``kind``: "scalar" or "normal" (``encoding``
    "unorm" / "snorm", ``y_down`` the DirectX convention, for turning the vectors of rotated or mirrored
    entries); ``bands``: None for :data:`BANDS` ``[kind]``, or levels replacing them (:func:`check_bands`;
    ``{"high": L}`` alone is one linear band)."""
    from ..io.normal_codes import encode_unit, transform_normal_codes, transform_vectors

    img = np.asarray(image)
    h, w, c = img.shape
    idx = np.asarray(tiles, np.int64).reshape(-1)
    n = prov.tile_size
    bd = tile_bands(check_bands(bands, kind), n)
    out = np.empty((idx.size, n, n, c), img.dtype)
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(img.dtype)
    low = "low" in bd and kind == "scalar"
    if low:
        f_all = img.astype(np.float64) / (scale or 1.0)
        split = int(bd["split"])
        mip = box_mip(f_all, split)
        mu = f_all.reshape(-1, c).mean(axis=0)
    for lo in range(0, idx.size, CHUNK_TILES):
        part = idx[lo : lo + CHUNK_TILES]
        lab, tab = prov.labels[part], prov.table[part]
        e = tab.shape[1]
        used = tab[:, :, 0, None, None] >= 0
        wts = blend_weights(lab, e, bd["high"]) * used
        single = wts.max(axis=1) >= 1.0
        if low:
            wlo = blend_weights(lab, e, bd["low"], int(bd["reach"])) * used
            single &= wlo.max(axis=1) >= 1.0
        coords = entry_coords(tab, n, h, w)
        vals = img[coords[..., 0], coords[..., 1]]  # (k, E, N, N, C)
        sym = np.broadcast_to(np.maximum(tab[..., 0], 0)[:, :, None, None], vals.shape[:-1])
        turned = kind == "normal" and bool((sym != 0).any())
        copies = transform_normal_codes(vals, sym, encoding, y_down) if turned else vals
        # a pixel whose weights are 1 for one entry is that entry's copy, byte for byte
        own = np.take_along_axis(copies, lab[:, None, :, :, None].astype(np.int64), axis=1)[:, 0]
        if kind == "normal":
            s = normal_slopes(vals, encoding)
            s = transform_vectors(s, sym, y_down) if turned else s
            sl = (wts[..., None] * s).sum(axis=1)
            nv = np.concatenate([sl, np.ones(sl.shape[:-1] + (1,))], axis=-1)
            blended = encode_unit(nv[~single], img.dtype, encoding)
        else:
            f = vals.astype(np.float64) / (scale or 1.0)
            if low:
                lows = sample_mip(mip, split, coords)  # (k, E, N, N, C)
                base = (wlo[..., None] * lows).sum(axis=1)
                base = mu + (base - mu) / np.sqrt((wlo * wlo).sum(axis=1))[..., None]
                b = base + (wts[..., None] * (f - lows)).sum(axis=1)
            else:
                b = (wts[..., None] * f).sum(axis=1)
            b = b[~single]
            if scale:
                blended = np.rint(np.clip(b, 0.0, 1.0) * scale).astype(img.dtype)
            else:
                blended = b.astype(np.float32)
        own[~single] = blended
        out[lo : lo + part.size] = own
    return out
