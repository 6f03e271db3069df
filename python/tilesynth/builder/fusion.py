"""Seam-free gradient-domain fusion of composed tiles: the smoothing of the scalar and normal maps of a
material set.

Why not the colour's Poisson smoothing. :func:`tilesynth.builder.smoothing.smooth_tiles` (002 §3.3, Pérez et al.
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
the border is bit for bit as copied, or as :func:`exemplar_levels` corrected it), and the guidance field is

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

from collections.abc import Callable

import numpy as np

from ..errors import ParameterError

__all__ = [
    "CLAMP_WIDTH",
    "LEVEL_BLOCK",
    "LEVEL_CORNER",
    "exemplar_levels",
    "fuse_tiles",
    "seam_guidance",
    "seam_steps",
]


def _dst1(x: np.ndarray, axis: int) -> np.ndarray:
    """The DST-I ``X_k = Σ_{n=1..M} x_n sin(π k n / (M + 1))`` along ``axis`` (through an FFT of the odd
    extension of length 2(M + 1))."""
    x = np.moveaxis(x, axis, -1)
    m = x.shape[-1]
    z = np.zeros((*x.shape[:-1], 1), x.dtype)
    y = np.concatenate([z, x, z, -x[..., ::-1]], axis=-1)
    out = -np.fft.rfft(y, axis=-1).imag[..., 1 : m + 1] * 0.5
    return np.moveaxis(out, -1, axis)


def _turn_steps() -> np.ndarray:
    """``STEPS[t, axis]``: the exemplar step ``(dr, dc)`` under one tile step down (axis 0) or right (axis 1) in a
    patch transformed by ``T_t`` (:mod:`tilesynth.builder.matching.augment`: ``F^f(R^k(P))``)."""
    g = np.stack(np.mgrid[0:3, 0:3], axis=-1)
    out = np.zeros((8, 2, 2), np.int64)
    for t in range(8):
        a = np.rot90(g, t % 4, axes=(0, 1))
        a = a[:, ::-1] if t >= 4 else a
        out[t, 0], out[t, 1] = a[2, 1] - a[1, 1], a[1, 2] - a[1, 1]
    return out


_STEPS = _turn_steps()


def seam_steps(
    values: np.ndarray,
    copies: np.ndarray,
    source: np.ndarray,
    valid: np.ndarray | None = None,
    turns: np.ndarray | None = None,
    turn: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """``s`` on every edge of every tile: the seam-free guidance minus the copies' own steps (module docstring),
    the wanted ``g_q − g_p`` of the correction ``g`` on the edge from ``p`` to its neighbour ``q`` below
    (``(K, N − 1, N, C)``) and to its right (``(K, N, N − 1, C)``), float64, 0 off the seams. Arguments as
    :func:`seam_guidance`.

    ``turns`` ``(K, N, N)`` (None: every pixel 0): the transform of each tile pixel's patch (a rotated or
    mirrored matching patch, :func:`tilesynth.builder.matching.augment.pixel_transforms`). A tile step then
    follows its pixel's exemplar step (a step right in a patch turned by 180° is a step left in the exemplar),
    so the pixels of one turned patch are not taken for a seam and the continued steps go the patch's way;
    ``turn(step, t)`` (vector maps: :func:`tilesynth.builder.matching.augment.turn_steps`) turns a continued step
    of the exemplar into the tile's frame."""
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
        if turns is None:
            seam = (rq != rp + dr) | (cq != cp + dc)
        else:
            tp, tq = turns[tuple(lo)].astype(np.int64), turns[tuple(hi)].astype(np.int64)
            dp, dq = _STEPS[tp, ax - 1], _STEPS[tq, ax - 1]
            seam = (tp != tq) | (rq != rp + dp[..., 0]) | (cq != cp + dp[..., 1])
        at = np.nonzero(seam)  # the steps are computed on the seam edges only (a few per cent of the edges)
        rp, cp, rq, cq = rp[at], cp[at], rq[at], cq[at]
        if turns is None:
            ep, fp = rp + dr, cp + dc  # p's patch continued one step
            eq, fq = rq - dr, cq - dc  # q's patch continued one step back
        else:
            tp, tq, dp, dq = tp[at], tq[at], dp[at], dq[at]
            ep, fp = rp + dp[..., 0], cp + dp[..., 1]
            eq, fq = rq - dq[..., 0], cq - dq[..., 1]
        okp = (ep >= 0) & (ep < h) & (fp >= 0) & (fp < w)
        okq = (eq >= 0) & (eq < h) & (fq >= 0) & (fq < w)
        ep, fp = np.clip(ep, 0, h - 1), np.clip(fp, 0, w - 1)
        eq, fq = np.clip(eq, 0, h - 1), np.clip(fq, 0, w - 1)
        if valid is not None:
            okp &= valid[ep, fp]
            okq &= valid[eq, fq]
        wp, wq = okp[..., None].astype(np.float64), okq[..., None].astype(np.float64)
        step_p = values[ep, fp] - values[rp, cp]
        step_q = values[rq, cq] - values[eq, fq]
        if turns is not None and turn is not None:
            step_p, step_q = turn(step_p, tp), turn(step_q, tq)
        guide = (step_p * wp + step_q * wq) / np.maximum(wp + wq, 1.0)
        own = copies[tuple(hi)][at] - copies[tuple(lo)][at]
        steps = np.zeros((*seam.shape, values.shape[2]), np.float64)
        steps[at] = guide - own
        out.append(steps)
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
    turns: np.ndarray | None = None,
    turn: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> np.ndarray:
    """The tiles of one map fused across their seams (module docstring): float64 ``(K, N, N, C)``, equal to
    ``copies`` on the one-pixel tile border ring. Arguments as :func:`seam_guidance`, ``turns`` and ``turn`` as
    :func:`seam_steps`; tiles smaller than 3x3 (no interior) are returned as they are.

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
    sv, sh = seam_steps(values, copies, source, valid, turns, turn)
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


#: The block side (exemplar pixels) of :func:`exemplar_levels`, the first stage of the maps' fusion
#: (:func:`tilesynth.builder.materials.fuse_map_atlas`).
LEVEL_BLOCK: int = 4
#: The reach (pixels along the border ring from a tile corner) of the corner pixels that get a level of their own in
#: :func:`exemplar_levels` (those that touch a seam of their tile: the Wang corners).
LEVEL_CORNER: int = 2
_LEVEL_TOL = 1e-10
_LEVEL_MAXIT = 20000
_LEVEL_GRID = 1e-3


def _border_pairs(
    values: np.ndarray, source: np.ndarray, valid: np.ndarray | None
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, float]]:
    """The pixel pairs *across* tile borders: for every two tiles that may lie side by side (their facing
    border columns, or rows, are exemplar neighbours at a quarter and at three quarters of the side: the same
    sample continues, as in any valid tiling), every facing pair, as ``[(s_p, s_q, s, weight)]``: the sources
    of both ends ``(E, 2)`` int64, the wanted correction step ``s`` ``(E, C)`` (0 where the pair is an exemplar
    neighbour pair; elsewhere, at the Wang corners, the guidance of :func:`seam_steps` minus the copies' step)
    and the weight of each pair, ``K / (number of such tile pairs)`` per direction (a tiling has about one
    right and one lower neighbour per tile)."""
    h, w = values.shape[:2]
    src = np.asarray(source).astype(np.int64)
    n = src.shape[1]
    probe = sorted({n // 4, (3 * n) // 4})
    out = []
    for d in ((0, 1), (1, 0)):
        first = src[:, :, -1] if d == (0, 1) else src[:, -1, :]  # (K, N, 2): the right column / bottom row
        second = src[:, :, 0] if d == (0, 1) else src[:, 0, :]
        step = np.array(d)
        cand = np.ones((src.shape[0], src.shape[0]), bool)
        for i in probe:  # (K_first, K_second)
            cand &= ((first[:, None, i] + step) == second[None, :, i]).all(axis=-1)
        pi, qi = np.nonzero(cand)
        if pi.size == 0:
            continue
        sp = first[pi].reshape(-1, 2)
        sq = second[qi].reshape(-1, 2)
        r = np.zeros((sp.shape[0], values.shape[2]))
        seam = (sq != sp + step).any(axis=-1)
        if seam.any():
            a, b = sp[seam], sq[seam]
            ep, eq = a + step, b - step
            okp = (ep[:, 0] < h) & (ep[:, 1] < w)
            okq = (eq[:, 0] >= 0) & (eq[:, 1] >= 0)
            ep = np.minimum(ep, [h - 1, w - 1])
            eq = np.maximum(eq, 0)
            if valid is not None:
                okp &= valid[ep[:, 0], ep[:, 1]]
                okq &= valid[eq[:, 0], eq[:, 1]]
            vp, vq = values[a[:, 0], a[:, 1]], values[b[:, 0], b[:, 1]]
            wp, wq = okp[:, None].astype(np.float64), okq[:, None].astype(np.float64)
            cont = (values[ep[:, 0], ep[:, 1]] - vp) * wp + (vq - values[eq[:, 0], eq[:, 1]]) * wq
            r[seam] = cont / np.maximum(wp + wq, 1.0) - (vq - vp)
        out.append((sp, sq, r, src.shape[0] / pi.size))
    return out


def _corner_pixels(source: np.ndarray, reach: int, width: int) -> np.ndarray:
    """The exemplar pixels (flat indices ``row · width + col``, sorted, unique) that some tile shows on its border
    ring within ``reach`` pixels of one of its corners, at a tile pixel that touches a seam of that tile (an edge to
    a neighbour whose source is not the exemplar neighbour): where the Wang cuts end (:func:`exemplar_levels`)."""
    src = np.asarray(source).astype(np.int64)
    n = src.shape[1]
    if reach <= 0 or n < 2 or src.shape[0] == 0:
        return np.zeros(0, np.int64)
    near = np.zeros((n, n), bool)
    for y in (0, n - 1):
        for x in (0, n - 1):
            near[y, max(0, x - reach) : x + reach + 1] = True  # along the ring row
            near[max(0, y - reach) : y + reach + 1, x] = True  # along the ring column
    touch = np.zeros(src.shape[:3], bool)
    for ax, (dr, dc) in ((1, (1, 0)), (2, (0, 1))):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[ax], hi[ax] = slice(0, n - 1), slice(1, n)
        a, b = src[tuple(lo)], src[tuple(hi)]
        seam = (b[..., 0] != a[..., 0] + dr) | (b[..., 1] != a[..., 1] + dc)
        touch[tuple(lo)] |= seam
        touch[tuple(hi)] |= seam
    p = src[touch & near[None]]
    return np.unique(p[:, 0] * width + p[:, 1])


def exemplar_levels(
    values: np.ndarray,
    copies: np.ndarray,
    source: np.ndarray,
    valid: np.ndarray | None = None,
    block: int = LEVEL_BLOCK,
    corner: int = LEVEL_CORNER,
    turns: np.ndarray | None = None,
) -> np.ndarray:
    """A smooth correction ``φ`` ``(H, W, C)`` float64 *of the exemplar* such that the tiles copied from
    ``values + φ`` through ``source`` have the least seams: the first stage of the maps' fusion,
    before :func:`fuse_tiles` fuses what is left inside each tile. Arguments as :func:`seam_guidance`; ``turns``
    as :func:`seam_steps` (scalar maps only: a level of the exemplar is the same in every orientation).

    Why. :func:`fuse_tiles` keeps every tile's border ring, so the level offset of two patches that meet near the
    ring (the Wang tiles' cuts end *at* the tile corners, where the ring holds both samples) cannot be taken
    there, and the correction bends back to zero at the ring (a crease in shaded heights). A correction of the
    exemplar moves every copy of an exemplar pixel alike, the ring's too: two pixels of different tiles that
    are neighbours in the exemplar (every border pair of a tiling, which is what makes it seamless) stay
    neighbours of one smooth field, so tilings stay seamless and the border does not crease, while patches from
    different places of the exemplar can be levelled against each other.

    What. The least-squares ``Σ_e (φ(s_q) − φ(s_p) − s_e)²`` over every edge ``e = (p, q)`` of every tile
    (:func:`seam_steps`' ``s``: the seam-free guidance minus the copies' steps, 0 inside a patch, so there the
    term asks ``φ`` to be smooth) and over the pairs across tile borders (:func:`_border_pairs`: without them
    the two halves of a sample, which meet only across a border, and the Wang corners, where two samples meet
    across a border, would drift apart), ``φ`` constant on ``block x block`` blocks of the exemplar (edges inside one
    block drop out), plus ``1e-3`` x the mean edge weight times the squared steps between every two
    neighbouring blocks (blocks no tile reads get the harmonic extension, the system is regular). Solved by
    Jacobi-preconditioned conjugate gradients to a relative residual of 1e-10 (sparse sums by ``np.bincount``:
    the same bytes on any number of threads), the use-weighted mean of ``φ`` removed (the map's mean level is
    kept), then interpolated bilinearly between the block centres (a field without steps). Where the paper
    and Agarwala et al. are silent: the block size 4 is a measured compromise (``benches/materials-results.md``,
    "exemplar levels": blocks of 2 leave lower cut seams but sharper level changes, shaded creases on the flat
    tile faces of pbr:tiles; 8-16 leave higher seams); interpolated blocks rather than a per-pixel field keep
    the unknowns at 1/16 of the exemplar's pixels.

    **Corner pixels** (``corner``, default :data:`LEVEL_CORNER` = 2). The exemplar pixels that a tile shows on its
    border ring within ``corner`` pixels of a tile corner, where they touch a seam of the tile
    (:func:`_corner_pixels`), are unknowns of their own, outside the blocks (tied to their block by the same
    weak term as the blocks to each other), and keep their own value after the interpolation. Why: the Wang
    cuts end *at* the tile corners, where the border ring holds two samples side by side (and the pixels across
    the border a third and a fourth); those pixel pairs are fixed for :func:`fuse_tiles` and a 4-px block field
    can only take their mean offset, so the ring pairs there were most of the rest of the Wang maps' cut seams
    (roof-tiles ``wang`` roughness: 5 % of the cut pairs, 0.36 of the score 1.33). Every copy of such a pixel
    still moves alike, so tilings stay seamless. Measured (``benches/materials-results.md``, "Material cuts with a
    capped gradient normalisation, and the Wang corners' own levels"): roof-tiles ``wang`` roughness 1.33 → 1.12
    with a reach of 2 (1: 1.15, 3: 1.11), no Wang map higher, ring kinks and border seams within +0.01 or lower.
    ω's rings have no seam near their corners (the corners lie inside one sample patch; checked on ``c5`` sets),
    so ω has no such pixels and its output is unchanged; ``corner=0`` gives the block model alone.
    """
    values = np.asarray(values, np.float64)
    x, own = level_solution(values, copies, source, valid, block, corner, turns)
    return level_field(x, own, values.shape, block)


def level_solution(
    values: np.ndarray,
    copies: np.ndarray,
    source: np.ndarray,
    valid: np.ndarray | None = None,
    block: int = LEVEL_BLOCK,
    corner: int = LEVEL_CORNER,
    turns: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The unknowns of :func:`exemplar_levels` as solved: ``(x, own)``, ``x`` float64 ``(B + M, C)`` the level
    of every ``block x block`` block (row-major) then of every corner pixel, and ``own`` int64 ``(M,)`` the
    corner pixels' flat indices. :func:`level_field` turns them into ``φ``: a set stores these (1/16 of the
    exemplar's pixels) instead of ``φ``, and a synthesis of any window reads them (the solve needs the whole
    set; the field does not). ``turns`` as :func:`exemplar_levels`."""
    values = np.asarray(values, np.float64)
    h, w, ch = values.shape
    k, n = np.asarray(copies).shape[:2]
    s = int(block)
    if k == 0 or n < 2:
        return np.zeros((-(-h // max(s, 1)) * -(-w // max(s, 1)), ch)), np.zeros(0, np.int64)
    if s < 1:
        raise ParameterError(f"block = {block!r}: must be a positive number of pixels")
    if int(corner) < 0:
        raise ParameterError(f"corner = {corner!r}: must be a number of pixels >= 0")
    hb, wb = -(-h // s), -(-w // s)
    nblocks = hb * wb
    src = np.asarray(source)
    own = _corner_pixels(src, int(corner), w)  # the corner pixels: unknowns nblocks, nblocks + 1, ...
    nb = nblocks + own.size
    rows, cols = np.divmod(np.arange(h * w, dtype=np.int64), w)
    unknown = (rows // s) * wb + cols // s  # every exemplar pixel's unknown: its block, or its own
    unknown[own] = nblocks + np.arange(own.size)
    blk = unknown[src[..., 0].astype(np.int64) * w + src[..., 1].astype(np.int64)]
    ends_a, ends_b, wanted, weights = [], [], [], []

    def add(a: np.ndarray, b: np.ndarray, r: np.ndarray, wt: float) -> None:
        """Block pairs ``a -> b`` wanting the step ``r``: pairs inside one block drop out, and each pair is
        kept in one orientation, ``(a, b)`` with ``a < b`` wanting ``φ_b − φ_a = r``."""
        keep = a != b
        a, b, r = a[keep], b[keep], r[keep]
        flip = a > b
        r[flip] = -r[flip]
        ends_a.append(np.where(flip, b, a))
        ends_b.append(np.where(flip, a, b))
        wanted.append(r)
        weights.append(np.full(a.size, wt))

    for ax, step in zip((1, 2), seam_steps(values, copies, src, valid, turns)):
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[ax], hi[ax] = slice(0, n - 1), slice(1, n)
        add(blk[tuple(lo)].ravel(), blk[tuple(hi)].ravel(), step.reshape(-1, ch), 1.0)
    for sp, sq, r, wt in _border_pairs(values, src, valid):  # across tile borders: the tilings' own pairs
        add(unknown[sp[:, 0] * w + sp[:, 1]], unknown[sq[:, 0] * w + sq[:, 1]], r, wt)
    a, b, r = np.concatenate(ends_a), np.concatenate(ends_b), np.concatenate(wanted)
    ew_all = np.concatenate(weights)
    if a.size == 0:
        return np.zeros((nb, ch)), own
    pair, inv = np.unique(a * nb + b, return_inverse=True)
    inv = inv.reshape(-1)
    weight = np.bincount(inv, ew_all, minlength=pair.size)
    rhs = np.stack([np.bincount(inv, r[:, c] * ew_all, minlength=pair.size) for c in range(ch)], axis=1)
    grid = np.arange(nblocks).reshape(hb, wb)
    # the weak term: between neighbouring blocks, and between every corner pixel and its block
    ga = np.concatenate([grid[:-1].ravel(), grid[:, :-1].ravel(), (rows[own] // s) * wb + cols[own] // s])
    gb = np.concatenate([grid[1:].ravel(), grid[:, 1:].ravel(), nblocks + np.arange(own.size)])
    ea = np.concatenate([pair // nb, ga])
    eb = np.concatenate([pair % nb, gb])
    ew = np.concatenate([weight, np.full(ga.size, _LEVEL_GRID * float(weight.mean()))])
    er = np.concatenate([rhs, np.zeros((ga.size, ch))])

    def scatter(d: np.ndarray) -> np.ndarray:  # Σ over edges of d at b minus d at a
        return np.stack(
            [
                np.bincount(eb, d[:, c], minlength=nb) - np.bincount(ea, d[:, c], minlength=nb)
                for c in range(ch)
            ],
            axis=1,
        )

    rhs_b = scatter(er)
    diag = (np.bincount(ea, ew, minlength=nb) + np.bincount(eb, ew, minlength=nb))[:, None]
    x = np.zeros((nb, ch))
    res = rhs_b.copy()
    z = res / diag
    p = z.copy()
    rz = (res * z).sum(axis=0)
    stop = _LEVEL_TOL * np.sqrt((rhs_b * rhs_b).sum(axis=0))
    for _ in range(_LEVEL_MAXIT):
        if (np.sqrt((res * res).sum(axis=0)) <= stop).all():
            break
        ap = scatter(ew[:, None] * (p[eb] - p[ea]))
        alpha = rz / np.where(rz > 0, (p * ap).sum(axis=0), 1.0)
        x += alpha * p
        res -= alpha * ap
        z = res / diag
        rz_next = (res * z).sum(axis=0)
        p = z + (rz_next / np.where(rz > 0, rz, 1.0)) * p
        rz = rz_next
    use = np.bincount(blk.ravel(), minlength=nb).astype(np.float64)
    x -= (use[:, None] * x).sum(axis=0) / use.sum()
    return x, own


def level_field(
    x: np.ndarray, own: np.ndarray, shape: tuple[int, ...], block: int = LEVEL_BLOCK
) -> np.ndarray:
    """``φ`` ``(H, W, C)`` float64 of :func:`level_solution`'s ``(x, own)`` for an exemplar of ``shape``: the
    block levels interpolated bilinearly between the block centres, the corner pixels their own level."""
    h, w, ch = shape
    s = int(block)
    hb, wb = -(-h // s), -(-w // s)
    nblocks = hb * wb
    if x.shape[0] < nblocks or own.size != x.shape[0] - nblocks:
        raise ParameterError(
            f"levels: {x.shape[0]} unknowns for {nblocks} blocks and {own.size} corner pixels of a {w}x{h} map"
        )
    levels = x[:nblocks].reshape(hb, wb, ch)
    ys = np.clip((np.arange(h) + 0.5) / s - 0.5, 0.0, hb - 1.0)
    xs = np.clip((np.arange(w) + 0.5) / s - 0.5, 0.0, wb - 1.0)
    y0, x0 = np.floor(ys).astype(np.int64), np.floor(xs).astype(np.int64)
    y1, x1 = np.minimum(y0 + 1, hb - 1), np.minimum(x0 + 1, wb - 1)
    fy, fx = (ys - y0)[:, None, None], (xs - x0)[None, :, None]
    top = levels[y0][:, x0] * (1 - fx) + levels[y0][:, x1] * fx
    bottom = levels[y1][:, x0] * (1 - fx) + levels[y1][:, x1] * fx
    phi = np.ascontiguousarray(top * (1 - fy) + bottom * fy).reshape(h * w, ch)
    phi[own] = x[nblocks:]  # the corner pixels keep their own level
    return phi.reshape(h, w, ch)
