"""Poisson smoothing of composed tiles inside their cuts (002 §3.3), shared by the ω scheme and by map synthesis."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..base import kernels

__all__ = ["POISSON_TOL", "smooth_tiles"]

POISSON_TOL = kernels.DEFAULT_POISSON_TOL
"""Relative residual to which :func:`smooth_tiles` solves the Poisson equation: 1e-6, the core's default."""


def smooth_tiles(
    intermediate: np.ndarray,
    matching: np.ndarray,
    masks: np.ndarray,
    threads: int | None = None,
    tol: float = POISSON_TOL,
    clip: bool = True,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Poisson-smooth composed ω-tiles (002 §3.3): the region inside each cutting curve is the guided
    interpolation of the matching patch O, with the composed tile's pixels next to the region as the Dirichlet
    boundary (:func:`tilesynth.base.kernels.poisson_smooth`, exact to ``tol``).

    The region is the cut mask minus the one-pixel tile border. With the default ``keep_border`` the mask never
    reaches the border, so this is the mask itself. With 002's literal border, O reaches the border near the side
    midpoints; those border pixels are then kept as they are (O's values) and act as Dirichlet pixels too, so
    smoothing never changes a border pixel and never adds a seam between tiles. (Taking the tile border as a free
    Neumann boundary instead would move border pixels that the neighbouring tile does not share.)

    The interpolation can overshoot [0, 1] near strong seams; the returned tiles are clipped to [0, 1] (they are
    images), and the number of clipped values is reported. ``clip=False`` returns the solution as it is (float
    maps of any range, :func:`tilesynth.synthesize_map`); ``clipped`` then counts the values outside [0, 1].

    Parameters
    ----------
    intermediate, matching : ``(K, N, N, C)`` float32 intermediate tiles I and matching patches O.
    masks : ``(K, N, N)`` bool cut masks (True = the pixel comes from O).
    threads : worker threads (tiles and channels are solved in parallel; the result does not depend on it).
    tol : relative residual of the solve.

    Returns
    -------
    ``(tiles, info)``: the smoothed float32 tiles and ``{"tol", "iterations_max", "residual_max",
    "unknowns", "clipped"}`` (``unknowns`` and ``clipped`` summed over the tiles).
    """
    cut = np.asarray(masks, dtype=bool)
    m = cut.copy()
    m[:, 0, :] = m[:, -1, :] = False
    m[:, :, 0] = m[:, :, -1] = False
    composed = np.where(cut[..., None], matching, intermediate).astype(np.float32)
    out, pinfo = kernels.poisson_smooth(composed, matching, m, threads=threads, tol=tol, info=True)
    clipped = int(np.count_nonzero((out < 0) | (out > 1)))
    if clip:
        np.clip(out, 0.0, 1.0, out=out)
    info = {
        "tol": float(tol),
        "iterations_max": int(np.max(pinfo.iterations, initial=0)),
        "residual_max": float(np.max(pinfo.residual, initial=0.0)),
        "unknowns": int(np.sum(pinfo.unknowns)),
        "clipped": clipped,
    }
    return out, info
