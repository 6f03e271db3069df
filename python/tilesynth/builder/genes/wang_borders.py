r"""Where the tile borders of Wang tiles fall in the exemplar: the predicted border seam of a gene vector.

With pinned corners (and for s-Wang tiles) every pixel pair across a tile border is continuous exemplar content
except the two *junction* pairs at the ends of every vertical edge, where the samples of two horizontal edges
meet (:mod:`tilesynth.builder.wang`). So the border seam score of a tiling (:func:`tilesynth.measure.metrics.seam_score`) is
decided by the genes alone, before any cut is made:

* across a horizontal border of colour a, the pairs are the two exemplar rows at the middle of a's sample:
  rows ``r + m + h − 1`` and ``r + m + h``, columns ``c + m .. c + m + N − 1`` (gene (r, c), margin m = (P −
  N)/2, h = N/2);
* across a vertical border of colour b, the two exemplar columns at the middle of b's sample, rows ``r + m + 1 ..
  r + m + N − 2``;
* at the two ends of every vertical border, a junction pair: the right end of one horizontal sample's middle
  row against the left end of another's (any ordered pair of horizontal colours, the same one included).

Those lines are only a few exemplar rows and columns (one per colour), so the score of a random draw scatters
widely: on bricks it is above 2 when the horizontal borders land on mortar rows (the borders are continuous
there, but every tile border is then a mortar line at the tile period: a visible lattice), below 0.5 when they
land inside brick faces. :func:`predicted_border_seam` computes the score a tiling would have from those lines,

    S_pred = (B_x + B_y) / (I_x + I_y),
    B_y = mean squared step over the horizontal colours' middle rows,
    B_x = ((N − 2) · mean over the vertical colours' middle columns + 2 · mean over the junction pairs) / N,

with I_x, I_y the exemplar's mean squared step along x and y (the tiles' interior copies exemplar content; their
cuts, which raise the measured interior mean, are left out, so S_pred is a little above the measured S), every
colour and every ordered pair of horizontal colours weighted equally (the tilers use them about equally).

**Border-aware draws** (``border_tries``, the default of the Wang schemes): instead of one random gene
vector, :func:`border_aware_genes` draws ``border_tries`` random vectors from the build's generator (the first
is the one a single draw gives) and keeps the one with the smallest S_pred: the tile borders are put where the
exemplar is quiet and the samples' ends agree, as every cut of tilesynth is put where the error is smallest.
Cost: a few array reductions per try (about 70 µs), nothing next to the cuts. ``border_tries=1`` is Cohen's
single random draw. The selection methods (``select="ga"``, ...) optimise their own objective and do not use it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ...base.validate import as_image, positive_int
from ...errors import ParameterError
from .draws import check_genes, random_genes

__all__ = [
    "DEFAULT_BORDER_TRIES",
    "MAX_BORDER_TRIES",
    "border_aware_genes",
    "check_border_tries",
    "predicted_border_seam",
]

DEFAULT_BORDER_TRIES = 32
"""Random gene vectors drawn by the Wang schemes' default, the best S_pred kept. Measured (benches/seams.py and
12 seeds on a 96x96 lettuce crop with 32-pixel tiles): 16 tries left 1 seed of 12 above a border seam score of 1
(1.10 Wang, 1.20 s-Wang), 32 tries none (at most 0.63 / 0.71); more tries mostly make the borders flatter still.
Each try costs a few array reductions (about 70 µs)."""


def _steps(ex: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, float]:
    x = ex.astype(np.float64)
    dx2 = ((x[:, 1:] - x[:, :-1]) ** 2).sum(axis=2)  # (H, W-1): pair (y, x)-(y, x+1)
    dy2 = ((x[1:] - x[:-1]) ** 2).sum(axis=2)  # (H-1, W): pair (y, x)-(y+1, x)
    return dx2, dy2, float(dx2.mean()), float(dy2.mean())


def predicted_border_seam(
    exemplar: np.ndarray, genes: np.ndarray, n_horizontal: int, tile_size: int, sample_size: int
) -> float:
    """S_pred of ``genes`` (``(n, 2)`` top-left corners of the ``sample_size`` squares, the ``n_horizontal``
    horizontal-edge colours first) for tiles of ``tile_size`` (see the module docstring).

    Raises ParameterError / ShapeError for a tile size that is odd, below 2 or above the sample size, a sample
    larger than the exemplar, ``n_horizontal`` outside [1, n − 1], or genes that are not n distinct positions of
    the sample squares inside the exemplar.
    """
    img = as_image(exemplar, "exemplar")
    n = positive_int(tile_size, "tile_size", minimum=2)
    p = positive_int(sample_size, "sample_size", minimum=2)
    if n % 2 or n > p or (p - n) % 2:
        raise ParameterError(
            f"tile_size = {n}, sample_size = {p}: the tile size must be even and at most the sample size, "
            "with an even difference"
        )
    g = np.asarray(genes)
    nh = positive_int(n_horizontal, "n_horizontal")
    if g.ndim != 2 or not 2 <= g.shape[0] or not nh < g.shape[0]:
        raise ParameterError(
            f"n_horizontal = {nh} with genes of shape {g.shape}: need (n, 2) genes with 1 <= n_horizontal < n"
        )
    g = check_genes(g, g.shape[0], img.shape, p)
    ex = img.astype(np.float64)
    return _predict(_steps(ex), ex, g, nh, n, p)


def _predict(
    steps: tuple[np.ndarray, np.ndarray, float, float],
    x: np.ndarray,
    genes: np.ndarray,
    nh: int,
    n: int,
    p: int,
) -> float:
    dx2, dy2, ix, iy = steps
    m, h = (p - n) // 2, n // 2
    g = genes.astype(np.int64)
    rows = g[:nh, 0] + m + h - 1  # the pair (row, row + 1) across the horizontal border
    cols = g[:nh, 1] + m
    by = float(np.mean([dy2[r, c : c + n].mean() for r, c in zip(rows, cols)]))
    vr, vc = g[nh:, 0] + m, g[nh:, 1] + m + h - 1  # the pair (col, col + 1) across the vertical border
    bx_line = float(np.mean([dx2[r + 1 : r + n - 1, c].mean() for r, c in zip(vr, vc)])) if n > 2 else 0.0
    right = x[np.concatenate([rows, rows + 1]), np.concatenate([cols + n - 1, cols + n - 1])]  # (2·nh, C)
    left = x[np.concatenate([rows, rows + 1]), np.concatenate([cols, cols])]
    # every ordered pair (a, b) of horizontal colours, on the upper and on the lower row
    ru, rl = right[:nh], right[nh:]
    lu, ll = left[:nh], left[nh:]
    junc = 0.5 * (
        ((ru[:, None] - lu[None]) ** 2).sum(-1).mean() + ((rl[:, None] - ll[None]) ** 2).sum(-1).mean()
    )
    bx = ((n - 2) * bx_line + 2 * float(junc)) / n
    den = ix + iy
    return (bx + by) / den if den > 0 else 1.0


MAX_BORDER_TRIES = 4096
"""Upper bound of ``border_tries`` (a mistyped huge count would otherwise run for ever; 4096 tries cost about 0.3 s
of CPU on a 512x512 exemplar with 256-pixel tiles, 32 tries 17 ms, most of it the exemplar's steps)."""


def check_border_tries(tries: Any) -> int:
    """``border_tries`` as an int in [1, :data:`MAX_BORDER_TRIES`], or ParameterError naming it."""
    if (
        isinstance(tries, bool)
        or not isinstance(tries, (int, np.integer))
        or not 1 <= tries <= MAX_BORDER_TRIES
    ):
        raise ParameterError(f"border_tries = {tries!r}: must be an integer in [1, {MAX_BORDER_TRIES}]")
    return int(tries)


def border_aware_genes(
    exemplar: np.ndarray,
    first: np.ndarray,
    n_horizontal: int,
    tile_size: int,
    sample_size: int,
    rng: np.random.Generator,
    tries: int,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Of ``first`` (the build's random draw) and ``tries − 1`` more random draws from ``rng``, the gene vector
    with the smallest :func:`predicted_border_seam`, and what to record (``border_tries``, the predicted score
    of the first draw and of the kept one)."""
    tries = check_border_tries(tries)
    ex = np.asarray(exemplar, dtype=np.float64)
    steps = _steps(ex)
    return best_of_draws(
        ex.shape, np.asarray(first), sample_size, rng, tries,
        lambda g: _predict(steps, ex, g, n_horizontal, tile_size, sample_size), lambda s: s,
    )  # fmt: skip


def best_of_draws(
    shape: tuple[int, ...],
    first: np.ndarray,
    sample_size: int,
    rng: np.random.Generator,
    tries: int,
    predict: Callable[[np.ndarray], float],
    rank: Callable[[float], float],
) -> tuple[np.ndarray, dict[str, Any]]:
    """Of ``first`` and ``tries − 1`` more :func:`random_genes` draws from ``rng`` (``sample_size`` squares in
    an exemplar of ``shape``), the one whose ``rank(predict(genes))`` is smallest (the first of equals), and
    the record of :func:`border_aware_genes`. Shared with :mod:`tilesynth.builder.genes.omega_borders`."""
    cands = [first] + [random_genes(shape, len(first), sample_size, rng) for _ in range(int(tries) - 1)]
    scores = [predict(g) for g in cands]
    best = int(np.argmin([rank(s) for s in scores]))
    return cands[best], {
        "border_tries": int(tries),
        "border_seam_first": float(scores[0]),
        "border_seam_predicted": float(scores[best]),
    }
