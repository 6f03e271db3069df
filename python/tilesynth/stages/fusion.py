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

__all__ = ["CLAMP_WIDTH", "fuse_tiles", "seam_guidance", "seam_steps"]


def _dst1(x: np.ndarray, axis: int) -> np.ndarray:
    """The DST-I ``X_k = Σ_{n=1..M} x_n sin(π k n / (M + 1))`` along ``axis`` (through an FFT of the odd
    extension of length 2(M + 1))."""
    x = np.moveaxis(x, axis, -1)
    m = x.shape[-1]
    z = np.zeros((*x.shape[:-1], 1), x.dtype)
    y = np.concatenate([z, x, z, -x[..., ::-1]], axis=-1)
    out = -np.fft.rfft(y, axis=-1).imag[..., 1 : m + 1] * 0.5
    return np.moveaxis(out, -1, axis)


def seam_steps(
    values: np.ndarray, copies: np.ndarray, source: np.ndarray, valid: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``s`` on every edge of every tile: the seam-free guidance minus the copies' own steps (module docstring),
    the wanted ``g_q − g_p`` of the correction ``g`` on the edge from ``p`` to its neighbour ``q`` below
    (``(K, N − 1, N, C)``) and to its right (``(K, N, N − 1, C)``), float64, 0 off the seams. Arguments as
    :func:`seam_guidance`."""
    h, w = values.shape[:2]
    k, n = copies.shape[:2]
    sr = source[..., 0].astype(np.int64)
    sc = source[..., 1].astype(np.int64)
    out = []
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
        out.append(np.where(seam[..., None], guide - own, 0.0))
    return out[0], out[1]


def seam_guidance(
    values: np.ndarray, copies: np.ndarray, source: np.ndarray, valid: np.ndarray | None = None
) -> np.ndarray:
    """``div s`` on every tile pixel: ``(K, N, N, C)`` float64, where ``s`` is the seam-free guidance minus the
    copies' own steps (module docstring, :func:`seam_steps`). ``values``: the map on the exemplar grid
    ``(H, W, C)`` float64; ``copies``: its tiles ``(K, N, N, C)`` as copied through ``source`` ``(K, N, N, 2)``;
    ``valid``: bool ``(H, W)`` of the exemplar pixels a continuation may read (None: all)."""
    return _divergence(*seam_steps(values, copies, source, valid), copies.shape)


def _divergence(sv: np.ndarray, sh: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``div s`` of the vertical and horizontal steps ``sv`` / ``sh`` on tiles of ``shape``: +s at the first
    pixel of each step, −s at the second."""
    div = np.zeros(shape, np.float64)
    div[:, :-1] += sv
    div[:, 1:] -= sv
    div[:, :, :-1] += sh
    div[:, :, 1:] -= sh
    return div


def _sine(x: np.ndarray) -> np.ndarray:
    """The orthonormal 2-D DST-I ``S`` over axes 1 and 2 of ``(B, M, M, C)``: symmetric, ``S(S(x)) = x``."""
    m = x.shape[1]
    return _dst1(_dst1(x, 1), 2) * (2.0 / (m + 1))


def _laplacian_eigenvalues(m: int) -> np.ndarray:
    """The eigenvalues ``(M, M)`` of the 5-point Dirichlet Laplacian of an ``M x M`` grid in the DST-I basis."""
    lam = 2.0 - 2.0 * np.cos(np.pi * np.arange(1, m + 1) / (m + 1))
    return lam[:, None] + lam[None, :]


def _next_to_ring(m: int) -> np.ndarray:
    """The interior pixels next to the tile border ring: the outer ring of the ``M x M`` interior, bool."""
    out = np.ones((m, m), bool)
    out[1:-1, 1:-1] = False
    return out


def _ring_targets(sv: np.ndarray, sh: np.ndarray, m: int) -> np.ndarray:
    """``t`` ``(B, 4M − 4, C)``: for every interior pixel next to the ring (row-major, :func:`_next_to_ring`), the
    mean wanted correction ``s`` of its edges into the ring (signed towards the interior pixel; 2 edges at the
    interior corners, 1 elsewhere). 0 unless a seam crosses the ring there."""
    acc = np.zeros((sv.shape[0], m, m, sv.shape[3]), np.float64)
    cnt = np.zeros((m, m), np.float64)
    acc[:, 0] += sv[:, 0, 1:-1]  # ring row 0 -> interior row 1: the correction rises by s
    acc[:, -1] -= sv[:, -1, 1:-1]  # interior row N-2 -> ring row N-1: it falls by s
    acc[:, :, 0] += sh[:, 1:-1, 0]
    acc[:, :, -1] -= sh[:, 1:-1, -1]
    cnt[0] += 1
    cnt[-1] += 1
    cnt[:, 0] += 1
    cnt[:, -1] += 1
    near = _next_to_ring(m)
    return acc[:, near] / cnt[near][None, :, None]


def _pinned(source: np.ndarray) -> np.ndarray:
    """``(K, 4M − 4)`` bool: which interior pixels next to the ring (:func:`_next_to_ring`) the clamp pins, all but
    those on a seam *along* the ring (an edge to another pixel next to the ring whose sources are not neighbours:
    where a seam crosses the border, as the ω tiles' central cross does at the four side midpoints). Pinning
    those would keep the seam's step at the second pixel row as copied; left free, it is fused as in the
    membrane, and the border bends there only."""
    sr = source[:, 1:-1, 1:-1, 0].astype(np.int64)
    sc = source[:, 1:-1, 1:-1, 1].astype(np.int64)
    near = _next_to_ring(sr.shape[1])
    on_seam = np.zeros(sr.shape, bool)
    for ax, (dr, dc) in ((1, (1, 0)), (2, (0, 1))):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[ax], hi[ax] = slice(0, -1), slice(1, None)
        seam = (sr[tuple(hi)] != sr[tuple(lo)] + dr) | (sc[tuple(hi)] != sc[tuple(lo)] + dc)
        both = near[tuple(lo)[1:]] & near[tuple(hi)[1:]]
        seam &= both[None]
        on_seam[tuple(lo)] |= seam
        on_seam[tuple(hi)] |= seam
    return ~on_seam[:, near]


_CAPACITANCE: dict[tuple[int, float], np.ndarray] = {}


def _capacitance(m: int, eps: float) -> np.ndarray:
    """``Uᵀ A⁻¹ U`` ``(4M − 4, 4M − 4)`` for ``A = ε L + L²`` and ``U`` the interior pixels next to the ring
    (the Schur complement of the clamped solve, :func:`fuse_tiles`; a subset of pins takes its principal
    submatrix); the same for every tile of one size, computed once per ``(M, ε)``."""
    key = (m, eps)
    if key not in _CAPACITANCE:
        near = _next_to_ring(m)
        a = (eps * _laplacian_eigenvalues(m) + _laplacian_eigenvalues(m) ** 2)[None, :, :, None]
        count = int(near.sum())
        units = np.zeros((count, m, m, 1))
        rr, cc = np.nonzero(near)
        units[np.arange(count), rr, cc, 0] = 1.0  # U's columns as images
        cap = _sine(_sine(units) / a)[:, near, 0]  # symmetric positive definite
        _CAPACITANCE[key] = 0.5 * (cap + cap.T)
    return _CAPACITANCE[key]


#: A width for :func:`fuse_tiles` ``clamp`` (pixels; the boundary layer of the clamped correction). Not the
#: default: see ``fuse_tiles``.
CLAMP_WIDTH: float = 4.0


def fuse_tiles(
    values: np.ndarray,
    copies: np.ndarray,
    source: np.ndarray,
    valid: np.ndarray | None = None,
    clamp: float | None = None,
) -> np.ndarray:
    """The tiles of one map fused across their seams (module docstring): float64 ``(K, N, N, C)``, equal to
    ``copies`` on the one-pixel tile border ring. Arguments as :func:`seam_guidance`; tiles smaller than 3x3
    (no interior) are returned as they are.

    ``clamp`` (default None: off): a *clamped* correction, so that the correction ``g = f − C`` leaves the border
    ring with zero slope as well as zero value (a clamped plate rather than a pinned membrane) and shaded heights
    show no crease along the tile grid. Every interior pixel ``p₁`` next to the ring is pinned at the mean, over
    its edges into the ring, of the wanted step ``s`` (0 unless a seam crosses the ring there), except where a
    seam runs *along* the ring (:func:`_pinned`), and the energy over the rest of the interior is

        ``Σ_e r_e² + w² Σ_p (Σ_{e ∋ p} ±r_e)²``,   ``r_e = g_q − g_p − s_e``,   ``w = clamp``,

    over the edges ``e = (p, q)`` with an interior end and the interior pixels ``p``: the membrane energy plus
    ``w²`` times the squared divergence of its residual flux (the Poisson residual ``Δg − div s``, which the
    membrane makes 0); ``clamp=float("inf")``: the divergence term alone (the discrete clamped plate). Without
    the divergence term the pins would only move the crease one pixel inwards. Solved exactly: the membrane
    solution ``g_m`` (DST), then ``g = g_m − A⁻¹ U λ`` with ``A = ε L + L²`` (``ε = 1 / w²``, diagonal in the DST
    basis), ``U`` the pinned pixels and ``λ`` from their Schur complement ``Uᵀ A⁻¹ U`` (one per tile size and pin
    pattern): no iteration.

    Why it is off by default (``benches/materials-results.md``, "clamped correction"): it removes the ring crease
    (border kink of the derived heights 1.29 → 1.00, pbr:tiles 5.3 → 1.6) but a correction that may not bend at
    the ring cannot absorb a cut's level offset near the border, and the cut seam score of the heights rises
    (0.99 → 1.15 on rust, 1.26 → 1.63 on pbr:tiles), against the issue's target of ≤ 1.3; the width ``w``
    changes almost nothing (2 to ∞). Freeing the pins within 4 pixels of any seam brings the seams back (1.01,
    1.30) and the crease too (1.24, 3.9): the trade-off is in the constraint, not in the solver."""
    copies = np.asarray(copies, np.float64)
    n = copies.shape[1]
    if n < 3 or copies.shape[0] == 0:
        return copies.copy()
    if clamp is not None and not clamp >= 0:
        raise ValueError(f"clamp = {clamp!r}: must be None, 0 or a positive width in pixels")
    values = np.asarray(values, np.float64)
    sv, sh = seam_steps(values, copies, source, valid)
    div = _divergence(sv, sh, copies.shape)
    # A g = b with A the 5-point Laplacian (4 g_p − Σ neighbours): the normal equations of Σ (g_q − g_p − s)²
    # give A g = −div s (div as accumulated above: +s at p, −s at q).
    b = -div[:, 1:-1, 1:-1]
    m = n - 2
    lam = _laplacian_eigenvalues(m)[None, :, :, None]
    if not clamp:
        g = _sine(_sine(b) / lam)
    else:
        eps = 0.0 if np.isinf(clamp) else 1.0 / (float(clamp) ** 2)
        a = eps * lam + lam * lam
        near = _next_to_ring(m)
        g = _sine(_sine(b) / lam)  # the membrane solution: the minimiser without the constraint
        miss = g[:, near] - _ring_targets(sv, sh, m)
        pins = _pinned(np.asarray(source))
        cap = _capacitance(m, eps)
        y = np.zeros_like(miss)
        patterns, which = np.unique(pins, axis=0, return_inverse=True)
        for i, pat in enumerate(patterns):  # the tiles that pin the same pixels share one factorisation
            tiles = np.flatnonzero(which.reshape(-1) == i)
            if pat.any():
                inv = np.linalg.inv(cap[np.ix_(pat, pat)])
                y[np.ix_(tiles, np.flatnonzero(pat))] = np.einsum("ij,bjc->bic", inv, miss[tiles][:, pat])
        lift = np.zeros_like(g)
        lift[:, near] = y
        g = g - _sine(_sine(lift) / a)  # g − A⁻¹ U λ: the constraint met, the energy otherwise least
    out = copies.copy()
    out[:, 1:-1, 1:-1] += g
    return out
