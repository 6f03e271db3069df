"""The exact polish of a gene vector: coordinate descent, one gene at a time moved to its best position over
every valid position, until no single-gene move improves E (:func:`polish_genes`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .draws import _region, check_genes
from .draws import int_param as _int_param
from .population import (
    Evaluate,
    Progress,
    _Evaluator,
)

# --------------------------------------------------------------------------------------------------------------
# Polish


# Length: 103 lines, of which 32 are the docstring; the body is one coordinate-descent loop.
def polish_genes(
    evaluate: Evaluate,
    genes: np.ndarray,
    shape: tuple[int, ...],
    tile_size: int,
    *,
    E: float | None = None,
    D: np.ndarray | None = None,
    max_sweeps: int | None = None,
    batch_size: int = 256,
    min_distance: int | None = None,
    progress: Progress | None = None,
) -> tuple[np.ndarray, float, np.ndarray, dict[str, Any]]:
    """Exact coordinate descent: move one gene at a time to its best position.

    For gene k, every valid position at Chebyshev distance >= ``min_distance`` from every other gene is tried
    (the other genes fixed): the candidates
    are evaluated as populations of at most ``batch_size`` individuals, and the gene moves to the best one if
    that is strictly better than the current E (ties: the current position stays; among equal candidates the
    first in row-major order wins). A sweep visits k = 0 .. n−1; sweeps repeat until one makes no move (the
    genes are then a coordinate-wise local optimum: no single-gene move improves E) or ``max_sweeps`` sweeps
    were made. Genes stay distinct.

    Parameters
    ----------
    evaluate : ``genes[P, n, 2] -> (E[P], D[P, m])``.
    genes : int64 ``(n, 2)`` start.
    shape, tile_size : exemplar shape and N.
    E, D : the evaluator's E and D of ``genes`` if known (otherwise ``genes`` is evaluated first).
    max_sweeps : maximum number of sweeps, None for no limit (the descent always terminates: E strictly
        decreases over a finite set).
    batch_size : individuals per evaluation call.
    min_distance : smallest Chebyshev distance, in pixels, a moved gene keeps from every other gene; None means
        ``tile_size // 4``, 0 or 1 only keeps genes distinct. *Why:* E rewards patches that show the same content
        (their seams vanish), and an unconstrained descent on gravel (N2, 80x80 tiles, 128x128 exemplar) moved
        three of six patches to within one pixel of each other: a lower E, but a nearly periodic tile set, which
        defeats the purpose of having six patches. A patch shifted by less than N/4 shares over 56% of its pixels
        with the other (the same rule the 32-set uses for its second matching patch). The current position of a
        gene always stays allowed, so the polish never makes E worse.
    progress : ``progress("polish", gene steps done, n · max_sweeps or n · (sweep + 1))`` after each gene.

    Returns
    -------
    (genes, E, D, info) with info = {"sweeps", "moves", "evaluations", "converged", "E_before"}.
    """
    shp, n, t, region = _region(shape, np.asarray(genes).shape[0], tile_size)
    cur = check_genes(genes, n, shp, t).copy()
    batch_size = _int_param("polish_batch", batch_size, 1)
    if max_sweeps is not None:
        max_sweeps = _int_param("polish_sweeps", max_sweeps, 1)
    min_distance = t // 4 if min_distance is None else _int_param("polish_min_distance", min_distance, 0)
    ev = _Evaluator(evaluate, n, cache=False)
    if E is None or D is None:
        E0, D0 = ev(cur[None])
        cur_E, cur_D = float(E0[0]), D0[0].copy()
    else:
        cur_E, cur_D = float(E), np.asarray(D, dtype=np.float64).copy()
    E_before = cur_E
    flat_all = np.arange(region.size, dtype=np.int64)
    all_pos = region.unflat(flat_all)
    sweeps = moves = steps = 0
    converged = False
    while max_sweeps is None or sweeps < max_sweeps:
        sweeps += 1
        moved = False
        for k in range(n):
            held = region.flat(cur)
            ok = ~np.isin(flat_all, held)
            others = np.delete(cur, k, axis=0)
            if min_distance > 1 and others.size:
                cheb = np.abs(all_pos[:, None, :] - others[None, :, :]).max(axis=2).min(axis=1)
                ok &= cheb >= min_distance
            cand = flat_all[ok]
            best_E, best_pos, best_D = cur_E, -1, cur_D
            for s in range(0, cand.size, batch_size):
                chunk = cand[s : s + batch_size]
                pop = np.repeat(cur[None], chunk.size, axis=0)
                pop[:, k] = region.unflat(chunk)
                Eb, Db = ev(pop)
                j = int(np.argmin(Eb))
                if Eb[j] < best_E:
                    best_E, best_pos, best_D = float(Eb[j]), int(chunk[j]), Db[j].copy()
            if best_pos >= 0:
                cur[k] = region.unflat([best_pos])[0]
                cur_E, cur_D = best_E, best_D
                moves += 1
                moved = True
            steps += 1
            if progress is not None:
                total = n * (max_sweeps if max_sweeps is not None else sweeps + 1)
                progress("polish", steps, total)
        if not moved:
            converged = True
            break
    info = {
        "E_before": E_before,
        "min_distance": int(min_distance),
        "sweeps": sweeps,
        "moves": moves,
        "evaluations": ev.count,
        "converged": converged,
    }
    return cur, cur_E, cur_D, info
