"""Seam-free gradient-domain fusion of composed tiles (issue 14): the smoothing of the scalar and normal maps of a
material set.

Why not the colour's Poisson smoothing. :func:`tilesynth.stages.smoothing.smooth_tiles` (002 §3.3, Pérez et al.
2003) solves only *inside* the cutting curve, with the intermediate tile's pixels next to it as a fixed (Dirichlet)
boundary. The two patches' mismatch along the curve is then spread over the inside only, and wherever it varies
along the curve (it changes at every sample-patch boundary of the intermediate tile the curve crosses) its
correction is steep right at the curve. A photo hides that in its own pixel noise; a smooth map does not. Measured
(``benches/materials.py``, 4 derived materials): the cut seam score of Pérez-smoothed height, normal and roughness
maps was 1.57-2.41, while the same pixel pairs *inside* either source patch (the steps the two patches would have
had without a cut) score 0.5-1.3. The cut itself is not the cause: normalising the maps by their gradient energy
instead of their variance, or weighting them more, moved the scores by less than 0.2.

What this module does instead (the gradient-domain compositing of Agarwala et al. 2004, "Interactive digital
photomontage", §3.3, restricted to the tile interior): every pixel of the tile interior is unknown, the one-pixel
tile border ring is the Dirichlet boundary (it is shared with the neighbouring tiles, so tilings stay seamless and
the border is bit for bit as copied), and the guidance field is

* the map's own step ``m[s(q)] − m[s(p)]`` between two neighbouring tile pixels p, q whose sources are neighbours
  in the exemplar too (the pixels of one patch), and
* across every seam of the composed tile (the cut, and the sample-patch boundaries of the intermediate tile that
  the matching patch does not cover), the mean of the two *continued* steps ``m[s(p) + d] − m[s(p)]`` and
  ``m[s(q)] − m[s(q) − d]``: the step each side's own patch has there (a continuation outside the exemplar or on
  a masked pixel is left out; with neither, the step is 0).

The least-squares solution ``f = C + g`` (C the copies) has ``Δg = div s`` in the interior and ``g = 0`` on the
ring, ``s`` the guidance minus C's steps (non-zero only on seam edges). The interior of an ``N x N`` tile is a
rectangle, so the 5-point Dirichlet Laplacian is diagonalised by the discrete sine transform (DST-I) on both axes,
and the system is solved exactly, all tiles and channels at once, with numpy's FFT (an odd extension): no
iteration, no tolerance, the same bytes on any number of threads.
"""

from __future__ import annotations

import numpy as np

__all__ = ["fuse_tiles", "seam_guidance"]


def _dst1(x: np.ndarray, axis: int) -> np.ndarray:
    """The DST-I ``X_k = Σ_{n=1..M} x_n sin(π k n / (M + 1))`` along ``axis`` (through an FFT of the odd
    extension of length 2(M + 1))."""
    x = np.moveaxis(x, axis, -1)
    m = x.shape[-1]
    z = np.zeros((*x.shape[:-1], 1), x.dtype)
    y = np.concatenate([z, x, z, -x[..., ::-1]], axis=-1)
    out = -np.fft.rfft(y, axis=-1).imag[..., 1 : m + 1] * 0.5
    return np.moveaxis(out, -1, axis)


def seam_guidance(
    values: np.ndarray, copies: np.ndarray, source: np.ndarray, valid: np.ndarray | None = None
) -> np.ndarray:
    """``div s`` on every tile pixel: ``(K, N, N, C)`` float64, where ``s`` is the seam-free guidance minus the
    copies' own steps (module docstring). ``values``: the map on the exemplar grid ``(H, W, C)`` float64;
    ``copies``: its tiles ``(K, N, N, C)`` as copied through ``source`` ``(K, N, N, 2)``; ``valid``: bool
    ``(H, W)`` of the exemplar pixels a continuation may read (None: all)."""
    h, w = values.shape[:2]
    k, n = copies.shape[:2]
    sr = source[..., 0].astype(np.int64)
    sc = source[..., 1].astype(np.int64)
    div = np.zeros(copies.shape, np.float64)
    for ax, (dr, dc) in ((1, (1, 0)), (2, (0, 1))):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[ax], hi[ax] = slice(0, n - 1), slice(1, n)
        rp, cp, rq, cq = sr[tuple(lo)], sc[tuple(lo)], sr[tuple(hi)], sc[tuple(hi)]
        seam = (rq != rp + dr) | (cq != cp + dc)
        ep, fp = rp + dr, cp + dc  # p's patch continued one step
        eq, fq = rq - dr, cq - dc  # q's patch continued one step back
        okp = seam & (ep < h) & (fp < w)
        okq = seam & (eq >= 0) & (fq >= 0)
        ep, fp = np.minimum(ep, h - 1), np.minimum(fp, w - 1)
        eq, fq = np.maximum(eq, 0), np.maximum(fq, 0)
        if valid is not None:
            okp &= valid[ep, fp]
            okq &= valid[eq, fq]
        wp, wq = okp[..., None].astype(np.float64), okq[..., None].astype(np.float64)
        step_p = values[ep, fp] - values[rp, cp]
        step_q = values[rq, cq] - values[eq, fq]
        guide = (step_p * wp + step_q * wq) / np.maximum(wp + wq, 1.0)
        own = copies[tuple(hi)] - copies[tuple(lo)]
        s = np.where(seam[..., None], guide - own, 0.0)  # wanted g_q − g_p on the edge (p, q)
        div[tuple(lo)] += s
        div[tuple(hi)] -= s
    return div


def fuse_tiles(
    values: np.ndarray, copies: np.ndarray, source: np.ndarray, valid: np.ndarray | None = None
) -> np.ndarray:
    """The tiles of one map fused across their seams (module docstring): float64 ``(K, N, N, C)``, equal to
    ``copies`` on the one-pixel tile border ring. Arguments as :func:`seam_guidance`; tiles smaller than 3x3
    (no interior) are returned as they are."""
    copies = np.asarray(copies, np.float64)
    n = copies.shape[1]
    if n < 3 or copies.shape[0] == 0:
        return copies.copy()
    # A g = b with A the 5-point Laplacian (4 g_p − Σ neighbours): the normal equations of Σ (g_q − g_p − s)²
    # give A g = −div s (div as accumulated by seam_guidance: +s at p, −s at q).
    b = -seam_guidance(np.asarray(values, np.float64), copies, source, valid)[:, 1:-1, 1:-1]
    m = n - 2
    lam = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, m + 1) / (m + 1))
    eig = (lam[:, None] + lam[None, :])[None, :, :, None]
    coef = _dst1(_dst1(b, 1), 2) / eig
    g = _dst1(_dst1(coef, 1), 2) * (2.0 / (m + 1)) ** 2  # DST-I is its own inverse up to 2 / (M + 1)
    out = copies.copy()
    out[:, 1:-1, 1:-1] += g
    return out
