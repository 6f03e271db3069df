"""Periodic exemplars in complete corner sets: a tile size from the exemplar's period and phase-locked sample
patches ("no loss in texture statistics against 16a").

A complete set's lookup draws every vertex colour independently, and every vertex of colour c shows sample
patch c centred on it (:mod:`tilesynth.builder.genes.omega_borders`). On a periodic exemplar (a brick wall) the c5 default
"reads as a wall whose courses break at almost every cut" (texture-statistics distance 0.018 against 16a's
0.005 on ``bricks-red``, ``benches/repetition-results.md``).

The content around vertex v of colour c is the exemplar at ``g_c + N/2 + (p - v)`` (p the output pixel, g_c
the patch's top-left). Two neighbouring vertices v, v + (N, 0) continue each other's period when
``g_c' - g_c ≡ (N, 0)`` modulo the exemplar's lattice L, for every pair of colours, c = c' included: so
(N, 0) and (0, N) must be (near) lattice vectors, and all sample patches must sit at one phase. Two rules, both
on the input only:

- :func:`periodic_tile_size` (``build_omega(periodic="auto")``, the default): among the multiples of 8 in
  [3/4, 3/2] of the default tile size (and at most half the exemplar's shorter side), the N whose weaker
  autocorrelation of the exemplar's detail layer (:func:`tilesynth.measure.metrics.detail_layer`) at the lags (N, 0)
  and (0, N) is largest; used when that value is at least :data:`PERIODIC_MIN_CORR` (the exemplar repeats at
  a shift of one tile in both directions). On a brick wall the horizontal mortar lines make every horizontal
  shift correlate, so the rule in effect picks a tile of whole courses. Measured on bricks-red (1024², seeds 1
  and 2): N 88 -> 104, texture statistics 0.0176 / 0.0126 -> 0.0086 / 0.0068 (16a: 0.0047 / 0.0041).
- :func:`phase_locked_genes` (``periodic="lock"``, opt-in): every sample patch but the first moves, within
  N/2 pixels (Chebyshev) of where it was drawn, to the window most similar (smallest SSD) to the first patch:
  the same phase, other content; windows stay more than N/4 apart. The courses then continue across every
  tile, but the phase-consistent windows are few (about 35 in bricks-red at N = 104), the tile lattice becomes
  the output's strongest period, and periodic copies rose to 0.31 / 0.22 with no gain in texture statistics
  (0.0088 / 0.0161); the move also undoes the border-aware draw's check (border seam 1.85 on seed 2).

Textures that do not repeat at a tile's shift (:data:`PERIODIC_MIN_CORR`) are built as before, byte for
byte.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..measure.metrics import autocorrelation, detail_layer

__all__ = ["PERIODIC_MIN_CORR", "periodic_tile_size", "phase_locked_genes", "tile_shift_correlation"]

PERIODIC_MIN_CORR = 0.5
"""Smallest autocorrelation of the exemplar's detail layer at both tile shifts (N, 0) and (0, N) for which
:func:`periodic_tile_size` takes N. At their best multiple of 8 up to half the shorter side, the textures of
``../shared/textures`` measured: bricks-red 0.655, text 0.24, roof-tiles 0.19, bricks-brown 0.12, the others
at most 0.06; only bricks-red is taken."""


def tile_shift_correlation(exemplar: np.ndarray, sizes: Any, detail: np.ndarray | None = None) -> np.ndarray:
    """``min(r(N, 0), r(0, N))`` for every N of ``sizes``: r the normalised autocorrelation
    (:func:`tilesynth.measure.metrics.autocorrelation`) of the exemplar's detail layer (``detail`` when the
    caller has it, :attr:`tilesynth.builder.exemplar.Exemplar.detail`). NaN where N is not below both sides of
    the exemplar."""
    d = detail_layer(np.asarray(exemplar)) if detail is None else detail
    h, w = d.shape
    sizes = np.asarray(list(sizes), dtype=np.int64)
    out = np.full(sizes.shape, np.nan)
    ok = (sizes > 0) & (sizes < h) & (sizes < w)
    if not ok.any():
        return out
    span = float(d.max() - d.min())
    if span <= 0:
        return out
    m = int(sizes[ok].max())
    r = autocorrelation(((d - d.min()) / span)[..., None], m, m)
    for i, n in enumerate(sizes):
        if ok[i]:
            out[i] = min(r[m + n, m], r[m, m + n])
    return out


def periodic_tile_size(
    exemplar: np.ndarray, default: int, detail: np.ndarray | None = None
) -> tuple[int, float] | None:
    """``(N, correlation)`` of the module docstring's rule, or None when no candidate reaches
    :data:`PERIODIC_MIN_CORR` (ties: the N nearest the default, then the smaller); ``detail``: see
    :func:`tile_shift_correlation`."""
    h, w = np.asarray(exemplar).shape[:2]
    lo, hi = -(-3 * default // 4), min(3 * default // 2, min(h, w) // 2)
    sizes = [n for n in range(8 * (-(-lo // 8)), hi + 1, 8) if n >= 16]
    if not sizes:
        return None
    corr = tile_shift_correlation(exemplar, sizes, detail)
    best = None
    for n, c in zip(sizes, corr):
        if not np.isfinite(c):
            continue
        key = (-round(float(c), 9), abs(n - default), n)
        if best is None or key < best[0]:
            best = (key, n, float(c))
    if best is None or best[2] < PERIODIC_MIN_CORR:
        return None
    return best[1], best[2]


def _window_ssd(ex: np.ndarray, template: np.ndarray) -> np.ndarray:
    """Σ (E[p + .] − T)² for every top-left p of an n x n window inside the exemplar (FFT, float64)."""
    h, w, _ = ex.shape
    n = template.shape[0]
    fh, fw = h + n, w + n
    fe = np.fft.rfft2(ex, s=(fh, fw), axes=(0, 1))
    ft = np.fft.rfft2(template[::-1, ::-1], s=(fh, fw), axes=(0, 1))
    cross = np.fft.irfft2((fe * ft).sum(axis=2), s=(fh, fw))[n - 1 : h, n - 1 : w]
    sq = (ex * ex).sum(axis=2)
    sat = np.zeros((h + 1, w + 1))
    sat[1:, 1:] = sq.cumsum(0).cumsum(1)
    win = sat[n:, n:] - sat[:-n, n:] - sat[n:, :-n] + sat[:-n, :-n]
    return np.maximum(win - 2 * cross + float((template * template).sum()), 0.0)


def phase_locked_genes(exemplar: np.ndarray, genes: np.ndarray, n: int) -> np.ndarray:
    """The genes of the module docstring's rule: gene 0 kept, gene c >= 1 moved within N/2 (Chebyshev) of
    where it was to the window of smallest SSD against gene 0's window, more than N/4 from the genes placed so
    far (kept where it was when no window qualifies)."""
    ex = np.asarray(exemplar, dtype=np.float64)
    if ex.ndim == 2:
        ex = ex[..., None]
    g = np.asarray(genes, dtype=np.int64).copy()
    r0, c0 = (int(v) for v in g[0])
    ssd = _window_ssd(ex, ex[r0 : r0 + n, c0 : c0 + n])
    rows, cols = ssd.shape
    yy, xx = np.mgrid[0:rows, 0:cols]
    rad, sep = n // 2, n // 4
    for k in range(1, g.shape[0]):
        r, c = (int(v) for v in g[k])
        ok = (np.abs(yy - r) <= rad) & (np.abs(xx - c) <= rad)
        for j in range(k):
            ok &= np.maximum(np.abs(yy - g[j, 0]), np.abs(xx - g[j, 1])) > sep
        if ok.any():
            flat = np.where(ok, ssd, np.inf).ravel()
            g[k] = np.unravel_index(int(np.argmin(flat)), ssd.shape)
    return g
