"""Selection by the visible measures themselves, on a proxy synthesis: the ``visible`` objective.

The cheap objectives (ΣD, the papers' E, the cut score) follow what users see only weakly: over random gene
vectors the best by each of the visible measures is 12-28 % better than the median, but the best by ΣD or the cut
score gains only 5-8 % on cut seam, coherence and texture statistics (``benches/selection-results.md``). The
``visible`` objective therefore measures those three directly, on the candidates the cheap first stage keeps:

1. best-of ``count`` random gene vectors by ΣD (λ = 1, whole FFT-evaluated populations), as for ``cut``;
2. the ``rerank`` best distinct ones are built (tiles, matching patches, cuts: one build without the file each);
3. each candidate's tiles are laid into a **proxy synthesis** (:func:`proxy_side` pixels square, tiler seed
   :data:`PROXY_SEED`) and measured: the cut seam of its tiles (:func:`tilesynth.measure.metrics.cut_seam_score`, no
   synthesis needed), the coherence energy of the proxy against the exemplar (:func:`coherence_estimate`) and
   its texture-statistics distance (:func:`texture_stats_estimate`);
4. the candidate with the smallest **sum of ranks** over the three measures is kept (ties: the better one by
   ΣD). Ranks, not a weighted sum: the three measures have unrelated units and spreads, and a rank sum needs no
   weights to tune; every measure counts the same, as the target of the issue does.

*Why a proxy and not the user's synthesis.* The tile set is built once and laid many times with seeds the build
never sees; the proxy is one such layout, with its own seed and size, so the selection optimises what any layout
shows, not one particular image. The bench (``benches/selection.py``) scores a 512² synthesis with seed 1: the
proxy never is that image (other seed, other size), so the gains it reports are out of sample.

*Cost.* At the bench's scale (128² exemplars, 80-px tiles) the proxy of 256² is measured exactly. For large
exemplars the exhaustive coherence search (every patch that is not an exact exemplar copy searched over every
translation) would cost seconds per candidate, so :func:`coherence_estimate` searches a fixed random sample of
at most :func:`coherence_sample` of those patches (an unbiased estimate of the same mean), and the texture
statistics use a crop of at most :data:`TEXSTATS_SIDE`² and at most :data:`GRAM_PIXELS` pixels per scale for
the image's Gram matrix; the exemplar's index
and Gram matrices are computed once per build (:class:`ProxyJudge`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = [
    "COHERENCE_WORK",
    "GRAM_PIXELS",
    "PROXY_SEED",
    "PROXY_TILES",
    "TEXSTATS_SIDE",
    "VISIBLE_MEASURES",
    "VISIBLE_RERANK",
    "ProxyJudge",
    "coherence_estimate",
    "coherence_sample",
    "pick_by_ranks",
    "proxy_side",
    "visible_choice",
    "texture_stats_estimate",
]

VISIBLE_RERANK = 8
"""Candidates the ``visible`` objective builds and measures (the best distinct ones by ΣD)."""

VISIBLE_MEASURES = ("cut_seam", "coherence", "texstats")
"""The measures whose ranks are summed (smaller is better for each)."""

PROXY_SEED = 7919
"""Tiler seed of the proxy synthesis (any fixed seed; not 1, the seed ``benches/selection.py`` scores)."""

PROXY_TILES = 3.2
"""Side of the proxy synthesis in tiles (at least 256 pixels): about ten whole tiles and their borders."""

COHERENCE_WORK = 6.0e7
"""Budget of the coherence estimate in searched patches x exemplar translations (see :func:`coherence_sample`)."""

GRAM_PIXELS = 65_536
"""Largest number of pixels per scale whose filter responses enter the image's Gram matrix."""

TEXSTATS_SIDE = 384
"""The texture statistics of a proxy larger than this are taken on its top-left ``TEXSTATS_SIDE``² crop: the
filter spectra (cached per image size by :mod:`tilesynth.measure.quality`, 24 filters x C channels) of an 820² proxy
took 0.4 GB; a 384² crop holds 147,456 pixels, more than :data:`GRAM_PIXELS` samples."""

_MIN_SAMPLE = 256


def proxy_side(tile_size: int) -> int:
    """Side in pixels of the proxy synthesis: ``max(256, ceil(PROXY_TILES · N))``."""
    return max(256, math.ceil(PROXY_TILES * int(tile_size)))


def coherence_sample(exemplar_shape: tuple[int, ...], patch: int = 8) -> int:
    """Most patches :func:`coherence_estimate` searches: ``max(256, COHERENCE_WORK / translations)``, i.e. about
    4,000 on a 128² exemplar (the whole 256² proxy is searched exactly) and 256 on a 512² one."""
    t = (int(exemplar_shape[0]) - patch + 1) * (int(exemplar_shape[1]) - patch + 1)
    return max(_MIN_SAMPLE, int(COHERENCE_WORK // max(t, 1)))


def coherence_estimate(
    image: np.ndarray, exemplar: np.ndarray, index: Any, threads: int | None = None, sample: int | None = None
) -> float:
    """The coherence energy of :func:`tilesynth.measure.metrics.coherence_energy` (8 x 8 patches, stride 4), exact when
    at most ``sample`` patches are not exact exemplar copies; otherwise those are a fixed random sample (seed
    :data:`PROXY_SEED`) of them and the energy is the unbiased estimate ``Σ sampled e · (searched / sampled) /
    patches``. ``index``: a :class:`tilesynth.SsdIndex` of ``exemplar``."""
    from ...measure.metrics import (
        COHERENCE_BATCH,
        DEFAULT_PATCH,
        DEFAULT_STRIDE,
        _coherence_args,
        _exact_copies,
        _patch_gatherers,
    )

    img, ex, p, s = _coherence_args(image, exemplar, DEFAULT_PATCH, DEFAULT_STRIDE, index)
    h, w, _ = img.shape
    rows, cols = (h - p) // s + 1, (w - p) // s + 1
    m = rows * cols
    values = np.full(m, np.nan)
    offsets = np.zeros((m, 2), np.int64)
    out_patches, ex_patches = _patch_gatherers(img, ex, p, s, m, cols, ex.shape[1] - p + 1)
    _exact_copies(img, ex, p, s, rows, cols, values, offsets, out_patches, ex_patches)
    todo = np.nonzero(np.isnan(values))[0]
    if todo.size == 0:
        return 0.0
    k = coherence_sample(ex.shape, p) if sample is None else int(sample)
    pick = (
        todo if todo.size <= k else np.sort(np.random.default_rng(PROXY_SEED).choice(todo, k, replace=False))
    )
    total = 0.0
    for b in range(0, pick.size, COHERENCE_BATCH):
        sel = pick[b : b + COHERENCE_BATCH]
        _, val = index.best_matches(np.ascontiguousarray(out_patches(sel)), k=1, threads=threads)
        total += float(np.maximum(val[:, 0], 0.0).sum())
    return total * (todo.size / pick.size) / m


def _gram_sampled(img: np.ndarray, max_pixels: int) -> np.ndarray:
    """:func:`tilesynth.measure.quality._gram` over at most ``max_pixels`` of the valid response pixels (a fixed random
    subset, seed :data:`PROXY_SEED`; all of them when there are fewer)."""
    from ...measure.quality import _rectified_gram, _responses

    resp = _responses(img)
    if resp.shape[1] > max_pixels:
        idx = np.sort(np.random.default_rng(PROXY_SEED).choice(resp.shape[1], max_pixels, replace=False))
        resp = resp[:, idx]
    return _rectified_gram(resp)


def texture_stats_estimate(image: np.ndarray, exemplar_grams: list[np.ndarray | None]) -> float:
    """:func:`tilesynth.measure.quality.texture_stats_distance` of ``image`` against precomputed exemplar Gram matrices
    (:meth:`ProxyJudge.__init__`), the image's over its top-left :data:`TEXSTATS_SIDE`² crop and at most
    :data:`GRAM_PIXELS` pixels per scale (exact for images up to 256²)."""
    from ...measure.quality import TEXSTATS_SCALES, TEXSTATS_SIZE, _down

    out = []
    image = image[:TEXSTATS_SIDE, :TEXSTATS_SIDE]
    for f, gb in zip(TEXSTATS_SCALES, exemplar_grams):
        a = _down(image, f)
        if gb is None or min(a.shape[:2]) < TEXSTATS_SIZE:
            continue
        ga = _gram_sampled(a, GRAM_PIXELS)
        out.append(float(np.linalg.norm(ga - gb) / max(np.linalg.norm(gb), 1e-300)))
    return float(np.mean(out)) if out else float("nan")


class ProxyJudge:
    """The visible measures of candidate tile sets of one build, on the proxy synthesis; the exemplar's SSD
    index and Gram matrices are computed once."""

    def __init__(self, exemplar: np.ndarray, tile_size: int, threads: int | None = None) -> None:
        from ...base.kernels import SsdIndex
        from ...measure.quality import TEXSTATS_SCALES, TEXSTATS_SIZE, _down, _gram

        self.exemplar = np.asarray(exemplar, dtype=np.float64)
        self.threads = threads
        self.side = proxy_side(tile_size)
        self.index = SsdIndex(np.asarray(exemplar), threads)
        self.grams: list[np.ndarray | None] = []
        for f in TEXSTATS_SCALES:
            e = _down(self.exemplar, f)
            self.grams.append(_gram(e) if min(e.shape[:2]) >= TEXSTATS_SIZE else None)

    def measures(self, tileset: Any) -> dict[str, float]:
        """``{"cut_seam", "coherence", "texstats"}`` of ``tileset`` (smaller is better; NaN if undefined)."""
        from ...measure.metrics import cut_seam_score
        from ...synth.synthesis import synthesize

        seam = cut_seam_score(tileset)
        img, _ = synthesize(tileset, self.side, self.side, seed=PROXY_SEED, threads=self.threads)
        img = np.asarray(img)
        return {
            "cut_seam": float("nan") if seam is None else float(seam["score"]),
            "coherence": coherence_estimate(img, self.index.image, self.index, self.threads),
            "texstats": texture_stats_estimate(img.astype(np.float64), self.grams),
        }


def pick_by_ranks(rows: list[dict[str, float]], keys: tuple[str, ...] = VISIBLE_MEASURES) -> int:
    """Index of the row with the smallest sum of ranks over ``keys`` (rank 0 = smallest value; NaN ranks last;
    equal values share the lower rank); ties go to the earlier row."""
    n = len(rows)
    total = np.zeros(n)
    for key in keys:
        v = np.array([r[key] for r in rows], dtype=np.float64)
        v = np.where(np.isfinite(v), v, np.inf)
        total += np.searchsorted(np.sort(v), v, side="left")
    return int(np.argmin(total))


KEEP_BYTES = 64 * 2**20
"""Candidates' stage results are kept for the winner while they total at most this many bytes; past that the
winner is built again (one more build instead of holding K large tile atlases)."""


def _nbytes(res: Any) -> int:
    return sum(int(getattr(v, "nbytes", 0)) for v in vars(res).values())


def visible_choice(
    candidates: list[np.ndarray],
    build: Callable[[np.ndarray], Any],
    trial: Callable[[np.ndarray, Any], Any],
    exemplar: np.ndarray,
    tile_size: int,
    threads: int | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> tuple[np.ndarray, Any, dict[str, Any]]:
    """The ``visible`` re-ranking of a build: every candidate is built (``build(genes)``: the stage result),
    made a tile set (``trial(genes, result)``) and measured on the proxy (:class:`ProxyJudge`); the one with
    the smallest rank sum (:func:`pick_by_ranks`) is kept. Returns ``(its genes, its stage result, the record
    stored in params["selection"]["visible"])``."""
    judge = ProxyJudge(exemplar, tile_size, threads)
    rows: list[dict[str, float]] = []
    kept: list[Any] = []
    held = 0
    for i, g in enumerate(candidates):
        res = build(g)
        rows.append(judge.measures(trial(g, res)))
        held += _nbytes(res)
        kept.append(res if held <= KEEP_BYTES else None)
        if progress is not None:
            progress("visible re-ranking", i + 1, len(candidates))
    best = pick_by_ranks(rows)
    res = kept[best] if kept[best] is not None else build(candidates[best])

    def fin(v: float) -> float | None:
        return float(v) if math.isfinite(v) else None

    record = {
        "rerank": len(rows),
        "chosen": int(best),
        "proxy_side": judge.side,
        "proxy_seed": PROXY_SEED,
        **{key: [fin(r[key]) for r in rows] for key in VISIBLE_MEASURES},
    }
    return np.asarray(candidates[best]), res, record
