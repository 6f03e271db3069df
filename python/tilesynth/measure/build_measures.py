"""The visible measures stored with every build: computed at build time into ``params["quality"]``
and shown by ``tilesynth info``. The measures themselves are :mod:`tilesynth.measure.quality`'s and
:mod:`tilesynth.measure.metrics`'s (this module joins them, so that neither imports the other)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .metrics import cut_seam_score
from .quality import CUT_SCORE_EPS, cut_score

__all__ = ["build_measures", "info_lines"]


def build_measures(tileset: Any) -> dict[str, Any]:
    """The cheap visible measures of a tile set, computed at build time and stored in its manifest
    (``params["quality"]``): the cut score (:func:`cut_score`), the cut seam score
    (:func:`tilesynth.measure.metrics.cut_seam_score`) and the share of exemplar pixels the tiles use (coverage of the
    tiles themselves, not of a synthesis). The costly ones (coherence, texture statistics and histograms of a
    synthesis) are ``tilesynth metrics``'s."""
    costs = np.asarray(tileset.cut_costs, dtype=np.float64)
    seam = cut_seam_score(tileset)
    src = np.asarray(tileset.source).reshape(-1, 2)
    h, w = tileset.exemplar.shape[:2]
    used = np.zeros((h, w), bool)
    for lo in range(0, src.shape[0], 1 << 20):  # chunks: the int64 index arrays of 10 M pixels were 160 MB
        used[src[lo : lo + (1 << 20), 0], src[lo : lo + (1 << 20), 1]] = True
    score = cut_score(costs, tileset.tile_size)
    seam_v = None if seam is None else seam.get("score")
    return {
        "cut_score": score if math.isfinite(score) else None,
        "cut_score_eps": CUT_SCORE_EPS * float(tileset.tile_size),
        "cut_seam": float(seam_v) if isinstance(seam_v, float) and math.isfinite(seam_v) else None,
        "tile_coverage": float(used.mean()),
    }


def info_lines(params: dict[str, Any]) -> list[str]:
    """The ``tilesynth info`` lines of the stored visible measures and of the cut re-ranking (none for a set
    built before they were stored)."""

    def num(v: Any, spec: str = ".4g") -> str:
        return format(v, spec) if isinstance(v, (int, float)) and not isinstance(v, bool) else "-"

    def _chosen_measures(rec: dict[str, Any], k: Any) -> str:
        """The measures of candidate ``k`` of a re-ranking record (visible or window), '-' where missing."""
        return ", ".join(
            f"{key.replace('_', ' ')} {num(vals[k]) if isinstance(k, int) and 0 <= k < len(vals) else '-'}"
            for key in ("cut_seam", "coherence", "texstats")
            for vals in [rec.get(key) if isinstance(rec.get(key), list) else []]
        )

    out = []
    q = params.get("quality")
    if isinstance(q, dict):
        out.append(
            f"quality       cut score {num(q.get('cut_score'))} (geometric mean of the cut costs + "
            f"{num(q.get('cut_score_eps'), '.3g')}), cut seam {num(q.get('cut_seam'))}, tiles use "
            f"{num(100 * q['tile_coverage'] if isinstance(q.get('tile_coverage'), float) else None, '.1f')} % "
            "of the exemplar"
        )
    sel = params.get("selection")
    cut = sel.get("cut") if isinstance(sel, dict) else None
    if isinstance(cut, dict):
        scores = cut.get("scores") if isinstance(cut.get("scores"), list) else []
        pol = cut.get("polish")
        out.append(
            f"objective     cut: {len(scores)} candidates re-ranked ({', '.join(num(s) for s in scores)}), "
            f"#{num(cut.get('chosen'), 'd')} kept"
            + (
                f"; cut polish {num(pol.get('score_before'))} -> {num(cut.get('score'))} in "
                f"{num(pol.get('moves'), 'd')} moves, {num(pol.get('builds'), 'd')} builds"
                if isinstance(pol, dict)
                else ""
            )
        )
    elif isinstance(sel, dict) and isinstance(
        sel.get("visible"), dict
    ):  # tilesynth.builder.genes.visible_objective
        vis = sel["visible"]
        k = vis.get("chosen")
        row = _chosen_measures(vis, k)
        out.append(
            f"objective     visible: {num(vis.get('rerank'), 'd')} candidates measured on a "
            f"{num(vis.get('proxy_side'), 'd')}² proxy synthesis (seed {num(vis.get('proxy_seed'), 'd')}), "
            f"#{num(k, 'd')} kept by the rank sum ({row})"
        )
    elif isinstance(sel, dict) and isinstance(
        sel.get("window"), dict
    ):  # tilesynth.builder.genes.window_objective
        win = sel["window"]
        k = win.get("chosen")
        row = _chosen_measures(win, k)
        out.append(
            f"objective     window: {num(win.get('count'), 'd')} random draws measured on a "
            f"{num(win.get('cells'), 'd')}x{num(win.get('cells'), 'd')}-tile window ({num(win.get('window_tiles'), 'd')} "
            f"tiles, seed {num(win.get('proxy_seed'), 'd')}), #{num(k, 'd')} kept by the rank sum ({row})"
        )
    elif isinstance(sel, dict) and isinstance(sel.get("objective"), str):
        out.append(f"objective     {sel['objective']}")
    return out
