"""Poisson smoothing (guided interpolation) of a region of tiles, exact to a stated residual: the wrapper of the
core's PCG solver (re-exported by :mod:`tilesynth.base.kernels`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from ..errors import ParameterError, ShapeError
from .kernel_args import _asarray, _float_tiles
from .validate import (
    threads_arg,
)

DEFAULT_POISSON_TOL: float = _core.DEFAULT_POISSON_TOL
"""Default relative residual ‖b − A f‖₂ / ‖b‖₂ at which :func:`poisson_smooth` stops."""


@dataclass(frozen=True)
class PoissonInfo:
    """What :func:`poisson_smooth` did, per tile (scalars / ``(C,)`` for a single tile, arrays for a stack).

    Attributes
    ----------
    iterations : PCG iterations, the largest over the channels (0 when nothing had to be solved); int or int64
        ``(K,)``.
    residual : the final relative residual ‖b − A f‖₂ / ‖b‖₂ of each channel, recomputed from the float64
        solution (≤ ``tol``; 0 for an empty or whole-image region and for a channel with b = 0); float64 ``(C,)``
        or ``(K, C)``.
    unknowns : the number of region pixels; int or int64 ``(K,)``.
    """

    iterations: int | np.ndarray
    residual: np.ndarray
    unknowns: int | np.ndarray


def poisson_smooth(
    dst: np.ndarray,
    src: np.ndarray,
    region: np.ndarray,
    threads: int | None = None,
    tol: float = DEFAULT_POISSON_TOL,
    *,
    info: bool = False,
) -> np.ndarray | tuple[np.ndarray, PoissonInfo]:
    """Poisson smoothing of the region of a tile: guided interpolation (Pérez, Gangnet and Blake 2003).

    ``dst`` is the destination (the intermediate tile I of an ω-tile), ``src`` the source whose gradients guide
    the interpolation (the matching patch O), ``region`` the unknown pixels Ω (inside the cutting curve). For every
    pixel p of Ω and every channel, the result f solves the discrete Poisson equation with guidance field
    v_pq = src_p − src_q (Pérez eqs. (7)–(11))::

        Σ_{q ∈ N(p)} (f_p − f_q) = Σ_{q ∈ N(p)} (src_p − src_q),   f_q = dst_q for q ∉ Ω,

    N(p) the 4-neighbours of p inside the image. Outside Ω the result is ``dst``, bit for bit: the pixels of
    ``dst`` next to Ω are the Dirichlet boundary, so the tile border (never in an ω region) is untouched and
    ω-tiles stay seamless with each other.

    - Where Ω touches the image border, the missing neighbours are simply absent: a zero-normal-derivative
      (Neumann) condition on ``f − src`` there.
    - Ω covering the whole image has no Dirichlet pixel and f is determined only up to a constant: the result is
      ``src`` (the solution with the mean of ``src``). An empty Ω returns ``dst``.
    - The result is **not clipped** to [0, 1]: guided interpolation can overshoot near strong seams, and the
      result is the exact solution (clip it before storing it as an image).

    Solver: conjugate gradients in float64 on f − src (initial guess f = src), preconditioned by one symmetric
    geometric-multigrid V-cycle (float32, red-black Gauss–Seidel, the pixels outside Ω held fixed) per
    iteration; each channel stops once its true relative residual ‖b − A f‖₂ / ‖b‖₂ is at most ``tol`` (about
    8–10 iterations at 1e-6 for ω regions), which is reported. Rounding the solution to float32 adds at most half
    an ulp per pixel. Channels and tiles are solved in parallel; the result does not depend on ``threads``.

    Parameters
    ----------
    dst, src : a tile ``(N, M, C)`` or a stack ``(K, N, M, C)``: float (converted to float32, any finite
        values), or uint8 / uint16 (scaled to [0, 1]).
    region : bool ``(N, M)`` or ``(K, N, M)`` (integers: nonzero = unknown); its number of axes decides
        between one tile and a stack.
    threads : worker threads (None: ``TILESYNTH_NUM_THREADS`` or all cores).
    tol : the relative residual to reach, in [1e-12, 1).
    info : also return a :class:`PoissonInfo`.

    Returns
    -------
    The smoothed float32 tile(s), shaped like ``dst``; with ``info=True``, ``(tiles, PoissonInfo)``. The inputs are
    never modified.
    """
    r = _asarray(region, "region")
    if r.dtype != np.bool_:
        if not np.issubdtype(r.dtype, np.integer):
            raise TypeError(f"region has dtype {r.dtype}, expected bool (or integers, nonzero = unknown)")
        r = r != 0
    if r.ndim not in (2, 3):
        raise ShapeError(f"region has shape {r.shape}, expected (N, M) or (K, N, M)")
    single = r.ndim == 2
    d = _float_tiles(dst, "dst")
    s = _float_tiles(src, "src")
    if d.ndim != r.ndim + 1 or d.shape[:-1] != r.shape:
        raise ShapeError(
            f"dst has shape {d.shape}, expected {r.shape} + (C,) (the shape of region, then channels)"
        )
    if s.shape != d.shape:
        raise ShapeError(f"src has shape {s.shape}, expected {d.shape} (the shape of dst)")
    if isinstance(tol, (bool, np.bool_)) or not isinstance(tol, (int, float, np.integer, np.floating)):
        raise ParameterError(f"tol = {tol!r}: must be a number in [1e-12, 1)")
    r = np.ascontiguousarray(r)
    if single:
        d, s, r = d[None], s[None], r[None]
    out, iterations, residual, unknowns = _core.poisson_smooth(d, s, r, float(tol), threads_arg(threads))
    if single:
        out = out[0]
    if not info:
        return out
    if single:
        return out, PoissonInfo(int(iterations[0]), residual[0], int(unknowns[0]))
    return out, PoissonInfo(iterations, residual, unknowns)
