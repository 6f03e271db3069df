"""Cheap selection for the complete corner sets (c5, the default set): the ``window`` objective.

A complete set's default is one border-aware random draw (:mod:`tilesynth.builder.genes.omega_borders`). Its tiles are many
(625 for c5) and one candidate build costs as much as the whole default, so the re-rankings of the papers' sets
(:mod:`tilesynth.builder.genes.cut_objective`, :mod:`tilesynth.builder.genes.visible_objective`) cost K builds. The ``window`` objective measures a
candidate on a **window** of the hashed tiling instead: the tiles of :data:`WINDOW_CELLS` x
:data:`WINDOW_CELLS` cells of the tiling with tiler seed :data:`tilesynth.builder.genes.visible_objective.PROXY_SEED` (not any seed a
user lays: the selection never sees the image that is scored). The hashed lookup decides which tuple each
cell takes from the cell's position alone, so every candidate builds the same <= WINDOW_CELLS² tiles (about a
tenth of c5's) and lays them into the same window image. Measured on it, as the ``visible`` objective does on
its proxy synthesis: the cut seam of the window's tiles, the coherence energy of the window image (a fixed
sample of :data:`WINDOW_COHERENCE_SAMPLE` patches) and its texture-statistics distance.

1. ``draws`` random gene vectors (the first is the build's own random draw), of which the ``count`` best by the
   border criterion of :mod:`tilesynth.builder.genes.omega_borders` (free: a few reductions per draw) are candidates;
2. each candidate's window is built (intermediate tiles, diverse matching patches among the window's tiles,
   cuts) and measured; the smallest sum of ranks (:func:`tilesynth.builder.genes.visible_objective.pick_by_ranks`) is kept;
3. the winner is built in full.

Measured in ``benches/selection-results.md`` ("c5: the ceiling of random draws, and a cheap window rule",
``benches/selection_c5_cheap.py``; c5, six 96²-144² bench textures, 16 random draws each, gains over their
median): the rule chosen on four other textures (4 of 8 draws) gains +3.8 % cut seam, +7.2 % coherence, +5.6 %
texture statistics, against the default's −1.4 / +1.8 / +11.3 %, at 2.4x its CPU; with 8 candidates
(``rerank=8``) +5.1 / +9.0 / +20.8 % at 3.1x. Even a perfect judge of the evaluation, picking the best of 16
draws in all three measures together, gains only +5.4 % cut seam (+10.0 / +30.1 %): among random c5 draws the
cut seam varies little (625 tiles average it) and trades against the texture statistics. So it is an option
(``objective="window"``, ``--objective window``), not the default.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = [
    "WINDOW_CELLS",
    "WINDOW_COHERENCE_SAMPLE",
    "WINDOW_COUNT",
    "WINDOW_DRAWS",
    "WINDOW_MEASURES",
    "window_candidates",
    "window_cells_map",
    "window_choice",
    "window_image",
    "window_measures",
]

WINDOW_COUNT = 4
"""Candidates whose windows are built and measured (``rerank`` overrides it). 4 of :data:`WINDOW_DRAWS`: the best
min of the three targets on the tuning textures among the rules whose windows cost at most about one build
(+1.5 % there; 8 of 8 was the best at any cost, +3.7 %)."""

WINDOW_DRAWS = 8
"""Random gene vectors drawn; the :data:`WINDOW_COUNT` best by the border criterion are the candidates."""

WINDOW_CELLS = 8
"""Side of the window in cells (tiles)."""

WINDOW_COHERENCE_SAMPLE = 400
"""Patches of the window image whose coherence is searched (a fixed random sample; the estimate of
:func:`tilesynth.builder.genes.visible_objective.coherence_estimate`)."""

WINDOW_MEASURES = ("cut_seam", "coherence", "texstats")
"""The window measures whose ranks are summed."""


def window_candidates(
    exemplar: np.ndarray,
    tile_size: int,
    rng: np.random.Generator,
    first: np.ndarray,
    count: int = WINDOW_COUNT,
    draws: int = WINDOW_DRAWS,
) -> list[np.ndarray]:
    """``first`` (the build's random draw) and ``max(draws, count) - 1`` more random gene vectors from ``rng``;
    the ``count`` best by the border criterion of :mod:`tilesynth.builder.genes.omega_borders` (``"cap"``), in draw order
    among equals."""
    from .draws import random_genes
    from .omega_borders import DEFAULT_CRITERION, _predict, _rank
    from .wang_borders import _steps

    g0 = np.asarray(first, dtype=np.int64)
    cands = [g0] + [
        random_genes(exemplar.shape, g0.shape[0], tile_size, rng) for _ in range(max(draws, count) - 1)
    ]
    if len(cands) <= count:
        return cands
    steps = _steps(np.asarray(exemplar, dtype=np.float64))
    rank = [_rank(_predict(steps, g, tile_size), DEFAULT_CRITERION) for g in cands]
    keep = np.sort(np.argsort(rank, kind="stable")[:count])
    return [cands[i] for i in keep]


def window_cells_map(scheme: Any, cells: int = WINDOW_CELLS) -> np.ndarray:
    """int32 ``(cells, cells)`` tile indices of the window (tiler seed :data:`tilesynth.builder.genes.visible_objective.PROXY_SEED`,
    origin 0): the same for every gene vector."""
    from ...layouts.hashed import index_map
    from .visible_objective import PROXY_SEED

    return np.asarray(index_map(scheme, PROXY_SEED, (cells, cells)))


def window_image(tiles: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """The window's image: ``tiles[positions[r, c]]`` at cell (r, c) (``tiles`` ``(k, N, N, C)``)."""
    t = np.asarray(tiles)
    n = t.shape[1]
    r, c = positions.shape
    return t[positions].transpose(0, 2, 1, 3, 4).reshape(r * n, c * n, t.shape[-1])


def window_measures(
    tiles: np.ndarray,
    masks: np.ndarray,
    positions: np.ndarray,
    judge: Any,
    sample: int | None = WINDOW_COHERENCE_SAMPLE,
) -> dict[str, float]:
    """``{"cut_seam", "coherence", "texstats"}`` of one candidate's window: ``tiles`` / ``masks`` ``(k, N, N[, C])``
    the window's distinct tiles, ``positions`` ``(r, c)`` the row of ``tiles`` at each cell; ``judge`` a
    :class:`tilesynth.builder.genes.visible_objective.ProxyJudge` of the exemplar (its SSD index and Gram matrices)."""
    from ...measure.metrics import cut_seam_score
    from .visible_objective import coherence_estimate, texture_stats_estimate

    t = np.asarray(tiles)
    img = window_image(t, positions)

    class _Window:  # what cut_seam_score reads
        pass

    w = _Window()
    w.tiles, w.cut_masks = t, masks  # type: ignore[attr-defined]
    seam = cut_seam_score(w)
    return {
        "cut_seam": float("nan") if seam is None else float(seam["score"]),
        "coherence": coherence_estimate(img, judge.index.image, judge.index, judge.threads, sample),
        "texstats": texture_stats_estimate(img.astype(np.float64), judge.grams),
    }


def window_choice(
    candidates: list[np.ndarray],
    build_window: Callable[[np.ndarray, np.ndarray], Any],
    scheme: Any,
    exemplar: np.ndarray,
    tile_size: int,
    threads: int | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    cells: int = WINDOW_CELLS,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The ``window`` choice among ``candidates``: ``build_window(genes, tile_indices)`` returns the stage
    result (``tiles``, ``masks``) of those tiles only. Returns ``(the kept genes, the record stored in
    params["selection"]["window"])``."""
    from .visible_objective import PROXY_SEED, ProxyJudge, pick_by_ranks

    imap = window_cells_map(scheme, cells)
    uniq, pos = np.unique(imap, return_inverse=True)
    pos = pos.reshape(imap.shape)
    judge = ProxyJudge(exemplar, tile_size, threads)
    rows = []
    for i, g in enumerate(candidates):
        res = build_window(g, uniq)
        rows.append(window_measures(res.tiles, res.masks, pos, judge))
        if progress is not None:
            progress("window selection", i + 1, len(candidates))
    best = pick_by_ranks(rows, WINDOW_MEASURES)

    def fin(v: float) -> float | None:
        return float(v) if math.isfinite(v) else None

    record = {
        "count": len(rows),
        "chosen": int(best),
        "cells": int(cells),
        "window_tiles": int(uniq.size),
        "proxy_seed": PROXY_SEED,
        **{key: [fin(r[key]) for r in rows] for key in WINDOW_MEASURES},
    }
    return np.asarray(candidates[best]), record
