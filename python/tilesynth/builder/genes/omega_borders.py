r"""Where the tile borders of corner tiles (ω, patch) fall in the exemplar: the predicted border seam of a gene vector.

A corner tile ⟨TL, BL, TR, BR⟩ starts from its intermediate tile, the N x N centre of the 2N x 2N block of its
corner colours' sample patches (:mod:`tilesynth.builder.omega`). Around every vertex of a tiling, the four tiles that
meet there show the four quarters of the vertex colour's N x N patch, *whole and in place*: the patch is centred
on the vertex. So the tile borders through a vertex of colour k run along the **middle column pair** (patch
columns h − 1, h; h = N/2) and the **middle row pair** (rows h − 1, h) of k's patch, half a patch on either side
of the vertex.

The default cuts never reach the border: ``keep_border=True`` ties the one-pixel border ring to the
intermediate tile for the inscribed-circle cut region, and the free cut region (:mod:`tilesynth.builder.matching.levers`) ties a
ring (:data:`tilesynth.builder.matching.levers.RING`, 1 pixel) and the corner discs to it. Every pixel pair across a tile border is therefore a pair of
neighbouring exemplar pixels on one of those lines (benches/seams.py measures 0.0 % discontinuous border pairs
for ω and patch), and the border seam score of a tiling (:func:`tilesynth.measure.metrics.seam_score`) is decided by the
genes alone, before any matching or cut (``keep_border=False`` lets the matching patch reach the border near the
side midpoints; S_pred ignores that):

    S_pred = (B_x + B_y) / (I_x + I_y),
    B_x = mean over the colours of the mean squared step across the patch's middle column pair (N rows),
    B_y = mean over the colours of the mean squared step across its middle row pair (N columns),

with I_x, I_y the exemplar's mean squared step along x and y (as for the Wang schemes,
:mod:`tilesynth.builder.genes.wang_borders`, whose step arrays this module shares; the tiles' cuts raise the measured interior
mean, so S_pred is a little above the measured S: measured / predicted 0.94 (ω) and 0.96 (patch) in the median
over the rows of ``benches/seams.py --corner``, Pearson r 0.95 and 0.90 against the measured score). Every colour counts equally: the hashed lookup of the
complete sets and the stochastic tilers of the papers' sets give every vertex colour about equally often.

**Border-aware draws** (``border_tries``, the default of ω and patch): of ``border_tries`` random gene
vectors from the build's generator (the first is the single draw of ``border_tries=1``), the one whose S_pred
is closest to 0.8 on a log scale among those with S_pred <= 1 is kept (criterion ``"cap"``; the smallest S_pred
when no draw is at or below 1). Why not the smallest S_pred, as the Wang schemes do: a border grid far flatter
than its surroundings (every vertex cross on flat mortar or a tile face) is itself a lattice of quiet lines, and
the smallest of 32 draws also tends to take the exemplar's quietest, least typical patches. Why not the closest
to 1 (``"log"``, smallest ``|log S_pred|``): the tiling's mix of colours scatters the measured score around
S_pred, so a target of 1 leaves some tilings above it (a synthetic brick wall in ``tests/test_omega_seams.py``:
1.07). The figures behind the choice are in ``benches/seams-results.md`` (``benches/seams.py --corner``). The
patch baseline draws the same sample patches with the same seed, so it stays ω's baseline. Cost: a few array
reductions per try, nothing next to the matching.

**Vertex saliency** (the ``"stats"`` criterion of complete sets): every vertex of colour k shows the
centre disc of sample patch k whole (radius about 0.22·N, :func:`tilesynth.measure.metrics.vertex_disc_radius`), at a fifth
of the vertices of a c5 tiling. After the most representative admissible draw is kept, each of its patches whose
centre disc, or a disc half a radius from it, is a salient outlier among the exemplar's discs of that size
(percentile above :data:`VERTEX_SALIENCY_CAP` of :class:`tilesynth.measure.metrics.DiscSaliency`: mean colour,
luminance contrast, detail energy) is moved by at most N/4 to the nearest position where none is, keeping the
predicted border seam within :data:`VERTEX_SEAM_SLACK` of the draw's and at or below :data:`STATS_SEAM_CAP`
(:func:`_calm_vertices`). What it removed and what it cost: ``benches/repetition-results.md``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...base.validate import as_image
from ...errors import ParameterError
from ...measure import quality as q
from ...measure.metrics import DiscSaliency, vertex_disc_radius
from ..exemplar import Exemplar
from .draws import check_genes, check_tile_size
from .wang_borders import _steps, best_of_draws, check_border_tries, random_genes

__all__ = [
    "CRITERIA",
    "DEFAULT_BORDER_TRIES",
    "DEFAULT_CRITERION",
    "border_aware_corner_genes",
    "check_criterion",
    "corner_border_draws",
    "predicted_corner_border_seam",
    "sample_colour_distance",
    "sample_stats_distance",
]

DEFAULT_BORDER_TRIES = 32
"""Random gene vectors drawn by the ω and patch defaults (see benches/seams-results.md)."""

CRITERIA = ("cap", "log", "min", "stats")
"""How a draw is ranked: ``"min"`` smallest S_pred; ``"log"`` smallest ``|log S_pred|`` (closest to 1);
``"cap"`` (the default) closest to :data:`CAP_TARGET` on a log scale among the draws with S_pred <= 1 (the
smallest S_pred when there is none); ``"stats"`` (the default of complete sets) the smallest
:func:`sample_stats_distance` + :func:`sample_colour_distance` among the draws with S_pred <=
:data:`STATS_SEAM_CAP` (``"cap"``'s choice when there is none), its salient vertex content then moved off
the vertices (:func:`_calm_vertices`)."""

DEFAULT_CRITERION = "cap"

CAP_TARGET = 0.8
"""The target of the ``"cap"`` criterion."""


def predicted_corner_border_seam(exemplar: np.ndarray, genes: np.ndarray, tile_size: int) -> float:
    """S_pred of ``genes`` (``(n, 2)`` top-left corners of the ``tile_size`` sample patches, one per corner
    colour) for a corner tile set (ω, patch) with tiles of ``tile_size`` (see the module docstring).

    Raises ParameterError / ShapeError for a tile size that is odd, below the minimum or larger than the
    exemplar, or genes that are not n >= 1 distinct positions of patches inside the exemplar.
    """
    img = as_image(exemplar, "exemplar")
    n = check_tile_size(tile_size, img.shape)
    g = np.asarray(genes)
    if g.ndim != 2 or g.shape[0] < 1:
        raise ParameterError(f"genes of shape {g.shape}: need (n, 2) top-left corners, n >= 1")
    g = check_genes(g, g.shape[0], img.shape, n)
    ex = img.astype(np.float64)
    return _predict(_steps(ex), g, n)


def _predict(steps: tuple[np.ndarray, np.ndarray, float, float], genes: np.ndarray, n: int) -> float:
    dx2, dy2, ix, iy = steps
    h = n // 2
    g = genes.astype(np.int64)
    bx = float(np.mean([dx2[r : r + n, c + h - 1].mean() for r, c in g]))  # pair (c+h-1, c+h), N rows
    by = float(np.mean([dy2[r + h - 1, c : c + n].mean() for r, c in g]))  # pair (r+h-1, r+h), N columns
    den = ix + iy
    return (bx + by) / den if den > 0 else 1.0


def _rank(s: float, criterion: str) -> float:
    if criterion == "min":
        return s
    if s <= 0:
        return math.inf
    if criterion == "log":
        return abs(math.log(s))
    return abs(math.log(s / CAP_TARGET)) if s <= 1.0 else 1e6 + s  # "cap": above 1 only as a last resort


class _SampleStats:
    """The texture statistics of an exemplar for :func:`sample_stats_distance`, per scale of
    :func:`tilesynth.measure.quality.texture_stats_distance`: the exemplar's Gram matrix (computed once, a block at
    a time: :func:`tilesynth.measure.quality.blocked_gram`) and each sample window's Gram sum (of its own
    'valid' responses, those of the window's pixels alone; computed on first use and kept, as the kept draw is
    measured again after its vertex moves). The Gram matrix of several windows' responses together is the sum
    of their Gram sums over their count, so the responses themselves are never kept (at 2048² the 120
    windows' responses were 0.9 GB).

    Why not the responses of the whole exemplar, sliced per window: at 2048² they and their FFT temporaries
    were the build's 5.6 GB peak, and the exemplar's Gram matrix was recomputed for every admissible draw (about
    45 s CPU)."""

    def __init__(self, ex: np.ndarray) -> None:
        k = q.TEXSTATS_SIZE
        self.scales = {f: q._down(ex, f) for f in q.TEXSTATS_SCALES}
        self.scales = {f: e for f, e in self.scales.items() if min(e.shape[:2]) >= k}
        self.full = {f: q.blocked_gram(e) for f, e in self.scales.items()}
        self._windows: dict[tuple[int, int, int, int], tuple[np.ndarray, int]] = {}

    def window(self, f: int, y: int, x: int, m: int) -> tuple[np.ndarray, int]:
        """The Gram sum of the window's rectified responses and their count."""
        key = (f, y, x, m)
        if key not in self._windows:
            resp = q._responses(self.scales[f][y : y + m, x : x + m])
            self._windows[key] = (q._rectified_gram(resp) * resp.shape[1], resp.shape[1])
        return self._windows[key]

    def distance(self, genes: np.ndarray, n: int) -> float:
        k = q.TEXSTATS_SIZE
        out = []
        for f, full in self.full.items():
            m = n // f
            if m < k:
                continue
            parts = [self.window(f, int(r0) // f, int(c0) // f, m) for r0, c0 in np.asarray(genes, np.int64)]
            win = sum(g for g, _ in parts) / sum(p for _, p in parts)
            out.append(float(np.linalg.norm(win - full) / max(float(np.linalg.norm(full)), 1e-300)))
        return float(np.mean(out)) if out else 0.0


def sample_stats_distance(exemplar: np.ndarray, genes: np.ndarray, tile_size: int) -> float:
    """How far the sample patches of ``genes`` are from the whole exemplar in texture statistics: the
    :func:`tilesynth.measure.quality.texture_stats_distance` formula (relative Frobenius distance of the Gram matrices
    of the rectified filter responses, mean over scales 1 and 2) between the union of the patches' own valid
    responses and the exemplar's.

    Why: with a complete set every vertex shows its colour's sample patch, and that vertex content
    is a third or more of the output; on a non-stationary exemplar (grass with clover on one side and straw on
    the other) five randomly drawn patches often over-represent one kind of content, and the output's texture
    statistics follow them (the texture-statistics distance of c5 outputs varied 2-3x between seeds, more than
    between c5 and 16a). Drawing the patches so that together they look like the exemplar removes that."""
    img = as_image(exemplar, "exemplar")
    n = check_tile_size(tile_size, img.shape)
    g = check_genes(np.asarray(genes), np.asarray(genes).shape[0], img.shape, n)
    ex = img.astype(np.float64)
    if ex.ndim == 2:
        ex = ex[..., None]
    return _SampleStats(ex).distance(g, n)


STATS_SEAM_CAP = 0.9
"""The predicted border seam at or below which a draw is admissible for the ``"stats"`` criterion. At 1 (the
``"cap"`` criterion's bound) the measured border seam of c5 outputs reached 1.002 (dry soil, seed 2): the
criterion does not aim at 0.8 as ``"cap"`` does, so it takes draws near the bound, and the measured score
scatters around S_pred."""

COLOUR_QUANTILES = 512
"""Quantiles of :func:`sample_colour_distance` (those of :func:`tilesynth.measure.metrics.histogram_distance`)."""


def _quantiles(x: np.ndarray) -> np.ndarray:
    u = (np.arange(COLOUR_QUANTILES) + 0.5) / COLOUR_QUANTILES
    return np.quantile(x, u, axis=0)  # (Q, C)


def _colour_distance(unit: np.ndarray, ref: np.ndarray, genes: np.ndarray, n: int) -> float:
    pix = np.concatenate(
        [unit[int(r) : int(r) + n, int(c) : int(c) + n].reshape(-1, unit.shape[2]) for r, c in genes]
    )
    return float(np.abs(_quantiles(pix) - ref).mean())


def sample_colour_distance(exemplar: np.ndarray, genes: np.ndarray, tile_size: int) -> float:
    """The colour part of :func:`tilesynth.measure.metrics.histogram_distance` (mean over the channels of the 1-D
    Wasserstein-1 distance, values in [0, 1]) between the pixels of the sample patches of ``genes`` together and
    the exemplar's. The texture statistics' filters are zero-mean and blind to colour: drawn by
    :func:`sample_stats_distance` alone, the patches of sea foam were the darker water, and the output's
    histogram distance rose from 0.021 to 0.067 (``benches/repetition-results.md``)."""
    img = as_image(exemplar, "exemplar")
    n = check_tile_size(tile_size, img.shape)
    g = check_genes(np.asarray(genes), np.asarray(genes).shape[0], img.shape, n)
    unit = img.astype(np.float64)
    if unit.ndim == 2:
        unit = unit[..., None]
    return _colour_distance(unit, _quantiles(unit.reshape(-1, unit.shape[2])), g, n)


def check_criterion(criterion: Any) -> str:
    """``criterion`` as one of :data:`CRITERIA`, or ParameterError naming it."""
    if criterion not in CRITERIA:
        raise ParameterError(f"border criterion = {criterion!r}: must be one of {', '.join(CRITERIA)}")
    return str(criterion)


def border_aware_corner_genes(
    exemplar: np.ndarray,
    first: np.ndarray,
    tile_size: int,
    rng: np.random.Generator,
    tries: int,
    criterion: str = DEFAULT_CRITERION,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Of ``first`` (the build's random draw) and ``tries − 1`` more random draws from ``rng``, the gene vector
    whose :func:`predicted_corner_border_seam` ranks best by ``criterion``, and what to record
    (``border_tries``, ``border_criterion``, the predicted score of the first draw and of the kept one)."""
    tries = check_border_tries(tries)
    criterion = check_criterion(criterion)
    source = exemplar if isinstance(exemplar, Exemplar) else None
    ex = np.asarray(exemplar.image if source is not None else exemplar, dtype=np.float64)
    steps = _steps(ex)
    if criterion == "stats":
        return _stats_draws(exemplar, ex, steps, np.asarray(first), tile_size, rng, tries)
    genes, rec = best_of_draws(
        ex.shape,
        np.asarray(first),
        tile_size,
        rng,
        tries,
        lambda g: _predict(steps, g, tile_size),
        lambda s: _rank(s, criterion),
    )
    return genes, {**rec, "border_criterion": criterion}


def _stats_draws(
    exemplar: np.ndarray,
    ex: np.ndarray,
    steps: tuple[np.ndarray, np.ndarray, float, float],
    first: np.ndarray,
    tile_size: int,
    rng: np.random.Generator,
    tries: int,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The ``"stats"`` criterion of :func:`border_aware_corner_genes`: the same draws from ``rng`` as the other
    criteria, the admissible one (S_pred <= :data:`STATS_SEAM_CAP`) of smallest :func:`sample_stats_distance` +
    :func:`sample_colour_distance` kept (the first of equals), else ``"cap"``'s choice."""
    cands = [first] + [random_genes(ex.shape, len(first), tile_size, rng) for _ in range(int(tries) - 1)]
    scores = [_predict(steps, g, tile_size) for g in cands]
    ok = [i for i, v in enumerate(scores) if v <= STATS_SEAM_CAP]
    rec: dict[str, Any] = {}
    if ok:  # the statistics on the [0, 1] scale of the builds, whatever the caller's dtype
        if isinstance(exemplar, Exemplar):  # validated float32 already: its float64 copy is ``ex``
            unit, saliency = ex, exemplar.saliency
        else:
            unit = as_image(exemplar, "exemplar").astype(np.float64)
            saliency = None
        unit = unit if unit.ndim == 3 else unit[..., None]
        maps = _SampleStats(unit)
        ref = _quantiles(unit.reshape(-1, unit.shape[2]))
        stats = {i: maps.distance(cands[i], tile_size) for i in ok}
        colour = {i: _colour_distance(unit, ref, cands[i], tile_size) for i in ok}
        best = min(ok, key=lambda i: (stats[i] + colour[i], i))
        kept, moved, vsal = _calm_vertices(unit, steps, cands[best], tile_size, saliency)
        if moved:
            cands[best] = kept
            scores[best] = _predict(steps, kept, tile_size)
            stats[best] = maps.distance(kept, tile_size)
            colour[best] = _colour_distance(unit, ref, kept, tile_size)
        rec = {
            "sample_stats_predicted": stats[best],
            "sample_colour_predicted": colour[best],
            "vertex_saliency_predicted": vsal,
            "vertex_moves": moved,
        }
        del maps
        # the filter spectra cached for this exemplar's FFT size (~200 MB at 512²) would otherwise stay
        # through the build's heavier stages (the smoothed c5 build measured 953 MB against a 928 MB estimate)
        q._filter_spectra.cache_clear()
    else:
        best = int(np.argmin([_rank(v, "cap") for v in scores]))
    return cands[best], {
        "border_tries": int(tries),
        "border_seam_first": float(scores[0]),
        "border_seam_predicted": float(scores[best]),
        **rec,
        "border_criterion": "stats",
    }


VERTEX_SALIENCY_CAP = 0.9
"""The largest saliency percentile (:class:`tilesynth.measure.metrics.DiscSaliency`) of a sample patch's centre disc that
the ``"stats"`` criterion leaves at the vertices (see :func:`_calm_vertices`)."""
VERTEX_SEAM_SLACK = 0.05
"""How much :func:`_calm_vertices` may raise the kept draw's predicted border seam (never above
:data:`STATS_SEAM_CAP`)."""
VERTEX_MOVE = 4
"""The largest move of a sample patch by :func:`_calm_vertices`, as a fraction of the tile size: N/4 (22 px at
N = 88, 32 at N = 128), in steps of 2 px."""


def _calm_vertices(
    unit: np.ndarray,
    steps: tuple[np.ndarray, np.ndarray, float, float],
    genes: np.ndarray,
    tile_size: int,
    saliency: Any = None,
) -> tuple[np.ndarray, int, float]:
    """Move each sample patch of ``genes`` whose vertex content is salient to the nearest position (Chebyshev
    distance up to N / :data:`VERTEX_MOVE` in steps of 2 px, then Euclidean, then row-major) where it is not,
    keeping the draw's predicted border seam within :data:`VERTEX_SEAM_SLACK` of the draw's own and at or below
    :data:`STATS_SEAM_CAP`; a patch with no such position stays. The vertex content is salient when its centre
    disc (radius r = :func:`tilesynth.measure.metrics.vertex_disc_radius`, 0.22·N) or one of the 8 discs r/2 away
    along the axes and diagonals is above the :data:`VERTEX_SALIENCY_CAP` percentile of the exemplar's discs
    (:class:`tilesynth.measure.metrics.DiscSaliency`). Returns (genes, patches moved, largest percentile left).

    Why: every vertex of colour k shows the centre disc of sample patch k, at a fifth of the vertices
    of a c5 tiling, and the cut never reaches it. When that disc is one of the exemplar's outliers (a bright
    curled lettuce leaf, a cluster of grey stones on dry soil) the eye finds it again at every such vertex,
    although the periodic copies and the autocorrelation peak stay low. Three versions were tried on lettuce
    (seed 1; ``benches/repetition-results.md``): (1) excluding the draws with a salient centre disc from the 32
    left the "stats" criterion a much worse choice (sample statistics 0.015 -> 0.032, output texture statistics
    0.005 -> 0.020: the most representative draws hold the texture's striking pieces too); (2) moving only the
    centre disc below the cap, by at most N/8, moved the leaf 14 px and left it at every vertex of its colour,
    plainly visible; (3) this one: the 9 discs keep the motif out of the whole vertex content, and a move of at
    most N/4 keeps at least 3/4 of the patch along each axis (its statistics) while the content at its centre
    changes. Cost: five FFT correlations of the exemplar for the discs' features, then look-ups."""
    n = int(tile_size)
    g = np.asarray(genes, dtype=np.int64).copy()
    r = vertex_disc_radius(n)
    h, w = unit.shape[:2]
    if 2 * r > min(h, w):
        return g, 0, 0.0
    sal = DiscSaliency(unit, r) if saliency is None else saliency(r)  # the build's Exemplar caches its own
    hy, hx = sal.shape
    half = max(1, r // 2)

    def vertex_pct(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        # the largest percentile of the centre disc and the 8 discs half a radius away: the motif must leave
        # the vertex content, not only its exact centre
        y0, x0 = np.asarray(rows) + n // 2 - r, np.asarray(cols) + n // 2 - r
        out = np.zeros(np.shape(y0))
        for oy in (-half, 0, half):
            for ox in (-half, 0, half):
                out = np.maximum(out, sal.at(np.clip(y0 + oy, 0, hy - 1), np.clip(x0 + ox, 0, hx - 1))[1])
        return out

    pct = vertex_pct(g[:, 0], g[:, 1])
    m = max(1, n // VERTEX_MOVE)
    dy, dx = np.mgrid[-m : m + 1 : 2, -m : m + 1 : 2]
    order = np.lexsort(
        (dx.ravel(), dy.ravel(), (dy**2 + dx**2).ravel(), np.maximum(abs(dy), abs(dx)).ravel())
    )
    dy, dx = dy.ravel()[order], dx.ravel()[order]
    moved = 0
    bound = min(STATS_SEAM_CAP, _predict(steps, g, n) + VERTEX_SEAM_SLACK)
    for k in np.argsort(-pct, kind="stable"):  # the most salient first
        if pct[k] <= VERTEX_SALIENCY_CAP:
            continue
        ry, rx = g[k, 0] + dy, g[k, 1] + dx
        inside = (ry >= 0) & (rx >= 0) & (ry <= h - n) & (rx <= w - n)
        ry, rx = ry[inside], rx[inside]
        cand_pct = vertex_pct(ry, rx)
        taken = {tuple(v) for i, v in enumerate(g.tolist()) if i != k}
        for y, x, p in zip(ry.tolist(), rx.tolist(), cand_pct.tolist()):
            if p > VERTEX_SALIENCY_CAP or (y, x) in taken:
                continue
            trial = g.copy()
            trial[k] = (y, x)
            if _predict(steps, trial, n) <= bound:
                g, pct[k] = trial, p
                moved += 1
                break
    return g, moved, float(pct.max())


def corner_border_draws(
    exemplar: np.ndarray,
    tile_size: int,
    rng: np.random.Generator,
    genes_arr: np.ndarray,
    sel: dict[str, Any],
    tries: int,
    random_draw: bool,
    criterion: str = DEFAULT_CRITERION,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The border-aware draw of the ω and patch builders: only when the genes were one random draw
    (``random_draw``: no given genes, no selection); ``tries`` = 1 keeps that draw and records nothing, so a
    ``border_tries=1`` build is byte-identical to the single draw of before. ``criterion``: see
    :data:`CRITERIA` (the ω builder passes ``"stats"`` for complete sets)."""
    if not random_draw or tries == 1:
        return genes_arr, sel
    g, rec = border_aware_corner_genes(exemplar, genes_arr, tile_size, rng, tries, criterion)
    return g, {**sel, **rec}
