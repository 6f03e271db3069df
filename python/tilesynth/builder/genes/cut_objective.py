"""Selection by the real cut cost: objectives, the re-ranking of a selection's best candidates and the
cut polish.

**Objectives** (``objective=``, ``--objective``):

``cut``
    The visible one: the robust cut score :func:`tilesynth.measure.quality.cut_score` (geometric mean of the real min-cut
    costs of the tiles) of the finished tiles. A cut evaluation is a whole matching and cut stage (one build
    without the file), far too dear for a population search, so it is used where it is affordable: the method
    (best-of, GA, AIS) runs on the cheap first stage ΣD (λ = 1, exact, FFT-evaluated populations), the
    ``rerank`` best distinct gene vectors it evaluated are built and the one with the lowest cut score is kept;
    ``polish`` then moves one patch at a time to the best of its ``polish_candidates`` best positions by ΣD if
    that lowers the cut score.
``visible``
    The visible measures themselves on a proxy synthesis (:mod:`tilesynth.builder.genes.visible_objective`): the best ``rerank``
    (default 8) candidates by ΣD are built and measured (cut seam, coherence, texture statistics of a small
    synthesis with its own seed), the smallest rank sum kept. It gains the most on the three target measures
    (+10.6 / +9.0 / +25.3 % vs +7.3 / +7.0 / +11.7 % for the default, n2, six textures, six seeds) but costs
    3-12 x the default's CPU and still misses 10 % in coherence, so it is an option, not the default.
``sum-d``
    ΣD_j alone (λ = 1): what the issue's measurements found to follow coherence best of the cheap objectives
    (Spearman +0.56, vs +0.2 to +0.4 for E).
``E``
    The papers' E = 0.8·ΣD_j + 0.2·Var(D_j) (000, 003), kept under its name for their GA and AIS.

*Why not E by default:* Var(D) is anti-correlated with quality (−0.36 with coherence, −0.50 with cut cost on the
16a set), and GA/AIS on E improve the visible measures by 4-11 % over the random median where the best of the
same random draws by the real cut cost improves them by 10-13 % (the issue's measurement). Here
(``benches/selection-results.md``, n2, six textures) the default gains +6 % cut seam, +5 % coherence, +8 %
texture statistics over the random median, the cut polish +8 / +9 / +10 %, best-of by E +6 / +6 / +1 %.

Re-ranking reads the candidates through :class:`TopK`, a wrapper of the population evaluator that remembers the
best distinct gene vectors seen, so every method gets re-ranked without knowing about it: for best-of the K
draws, for GA and AIS every individual of every generation (the final population's best among them).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ...errors import ParameterError
from ...measure.quality import CUT_SCORE_EPS, cut_score
from .draws import _region
from .draws import int_param as _int_param

__all__ = [
    "COMPLETE_DEFAULT",
    "DEFAULT_COUNT",
    "DEFAULT_RERANK",
    "OBJECTIVES",
    "POLISH_CANDIDATES",
    "TopK",
    "cut_polish",
    "rerank",
    "resolve_objective",
]

OBJECTIVES = ("visible", "cut", "sum-d", "E", "window")
"""The selection objectives (see the module docstring)."""

DEFAULT_COUNT = 32
"""Random gene vectors of the default selection (best-of by ΣD, then re-ranked by the cut score)."""

DEFAULT_RERANK = 4
"""Candidates re-ranked by the real cut score (the best distinct ones by the first stage).

Why the cut score and not a cheap visible re-ranking (``benches/selection-results.md``, "Cheap visible
selection"): rank sums of the tiles' cut seam with a sampled proxy coherence (and cropped texture statistics),
chosen on six textures outside the bench, gain +9.5 / +6.5 / +13.9 % (cut seam / coherence / texture
statistics) on the bench's textures against this default's +7.3 / +7.0 / +11.7 %, for 1.9-2.4 x its CPU: worse
in coherence, and no cheaper than 1.5 x. Even the best of 4 candidates by the evaluation itself gains only
+10.0 % in coherence (+4.0 % on the tuning textures), so no re-ranking of these candidates meets 10 % there."""

COMPLETE_DEFAULT = "random"
"""The default selection of the complete sets (c4, c3x2, ...): one random draw. Measured with
``benches/selection.py --only visible`` (c4, six 96²-144² textures, ``benches/selection-results.md``): the cut
re-ranking raised coherence (+10.6 % mean) and the cut score (+10.5 %) but made the texture statistics (−22 %)
and the histograms (−14 %) worse (it prefers flat, low-contrast patches), for 4 x the build time (26 s instead
of 6 s on a 512² exemplar with 128-px tiles). ``objective="cut"`` (``--objective cut``) asks for it."""

POLISH_CANDIDATES = 3
"""Positions per patch the cut polish builds (the best by ΣD among every valid position)."""

POLISH_SWEEPS = 2
"""At most this many sweeps of the cut polish over the patches."""


def check_objective(objective: Any) -> str:
    if not isinstance(objective, str) or objective.strip().lower().replace("_", "-") not in (
        "visible",
        "cut",
        "sum-d",
        "e",
        "window",
    ):
        raise ParameterError(f"objective = {objective!r}: must be one of {', '.join(OBJECTIVES)}")
    o = objective.strip().lower().replace("_", "-")
    return "E" if o == "e" else o


def resolve_objective(
    select: Any,
    objective: Any,
    genes: Any,
    polish: bool,
    params: dict[str, Any] | None,
    population: Any = None,
    *,
    complete: bool = False,
) -> tuple[Any, str | None, dict[str, Any], int]:
    """``(select, objective, select_params, rerank)`` of a build's options.

    * ``genes`` given: nothing is selected, ``objective`` must be None.
    * ``select`` None on a complete set (``complete``: c4, c3x2, ...) without ``objective``, ``polish`` or
      ``rerank``: one random draw (see :data:`COMPLETE_DEFAULT`).
    * ``select`` None (the default) otherwise: best-of :data:`DEFAULT_COUNT` by ΣD, the best :data:`DEFAULT_RERANK`
      re-ranked by the cut score (``objective`` None or "cut"; another objective runs best-of on it);
      ``population`` sets the count.
    * ``select`` given: ``objective`` None means the papers' "E" (their methods, unchanged), else as given.

    ``rerank`` (a ``select_params`` key, popped) overrides the number of re-ranked candidates ("cut" only).
    """
    params = dict(params or {})
    rerank_k = params.pop("rerank", None)
    if genes is not None:
        if objective is not None:
            raise ParameterError("genes and objective: give one (the objective chooses the genes)")
        if rerank_k is not None:
            raise ParameterError("rerank: only when genes are selected")
        return select, None, params, 0
    if objective is not None and check_objective(objective) == "window":  # complete sets only (winselect)
        from .window_objective import WINDOW_COUNT

        if not complete:
            raise ParameterError(
                "objective 'window': only for the complete corner sets (c4, c5, ...: their hashed tiling has "
                "windows); the papers' sets have 'cut' (the default) and 'visible'"
            )
        if select is not None or polish or population is not None or params:
            raise ParameterError(
                "objective 'window' chooses among random draws itself: no select, polish, population or "
                "select parameters besides rerank"
            )
        return None, "window", params, WINDOW_COUNT if rerank_k is None else _int_param("rerank", rerank_k, 1)
    if (
        select is None
        and complete
        and objective is None
        and rerank_k is None
        and population is None
        and not polish
        and not params
    ):
        return None, None, params, 0
    if select is None:
        obj = "cut" if objective is None else check_objective(objective)
        if "count" not in params and population is None:
            params["count"] = DEFAULT_COUNT
        select = "best-of"
    else:
        obj = "E" if objective is None else check_objective(objective)
        if isinstance(select, str) and select.strip().lower() == "random" and obj != "E" and not polish:
            obj = "E"  # one random draw: there is nothing to rank
    from .visible_objective import VISIBLE_RERANK

    default_k = VISIBLE_RERANK if obj == "visible" else DEFAULT_RERANK
    k = default_k if rerank_k is None else _int_param("rerank", rerank_k, 1)
    if obj not in ("cut", "visible") and rerank_k is not None:
        raise ParameterError(f"rerank = {rerank_k!r}: only with objective 'cut' or 'visible'")
    if obj == "visible" and polish:
        raise ParameterError("polish with objective 'visible': the polishes follow ΣD or the cut score; use "
                             "objective 'cut' for the cut polish")  # fmt: skip
    return select, obj, params, (k if obj in ("cut", "visible") else 0)


class TopK:
    """Wraps a population evaluator ``genes[P, n, 2] -> (E[P], D[P, m])`` and remembers the ``keep`` best
    distinct gene vectors it evaluated (ties: the first seen first)."""

    def __init__(self, keep: int) -> None:
        self.keep = keep
        self._seen: dict[bytes, tuple[float, int, np.ndarray]] = {}
        self._order = 0

    def wrap(self, evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]) -> Callable:
        def recorded(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            E, D = evaluate(genes)
            g = np.asarray(genes, dtype=np.int64)
            for i in range(g.shape[0]):
                key = g[i].tobytes()
                if key not in self._seen:
                    self._seen[key] = (float(E[i]), self._order, g[i].copy())
                    self._order += 1
            if len(self._seen) > 8 * self.keep + 64:
                self._trim()
            return E, D

        return recorded

    def _trim(self) -> None:
        best = sorted(self._seen.items(), key=lambda kv: kv[1][:2])[: self.keep]
        self._seen = dict(best)

    def best(self) -> list[np.ndarray]:
        """The best distinct gene vectors, best first."""
        return [v[2] for v in sorted(self._seen.values(), key=lambda v: v[:2])[: self.keep]]


def rerank(
    candidates: list[np.ndarray],
    build: Callable[[np.ndarray], Any],
    tile_size: int,
    progress: Callable[[str, int, int], None] | None = None,
) -> tuple[int, list[float], Any]:
    """Build every candidate (``build(genes)`` returns a result with ``.costs``, the cut costs of its tiles) and
    return ``(index of the lowest cut score, the scores, that result)``; ties keep the earlier candidate (the
    better one by the first stage)."""
    scores: list[float] = []
    best_i, best_res = -1, None
    for i, g in enumerate(candidates):
        res = build(g)
        s = cut_score(res.costs, tile_size)
        scores.append(s)
        if best_i < 0 or s < scores[best_i]:
            best_i, best_res = i, res
        # Drop a losing result before the next build: at most the best one and the one being built are
        # alive (each holds the tiles, their provenance and masks: ~50 MB for 38 tiles of 256 px).
        res = None
        if progress is not None:
            progress("cut re-ranking", i + 1, len(candidates))
    return best_i, scores, best_res


def cut_polish(
    genes: np.ndarray,
    score: float,
    result: Any,
    stage1: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    build: Callable[[np.ndarray], Any],
    shape: tuple[int, ...],
    tile_size: int,
    *,
    candidates: int = POLISH_CANDIDATES,
    max_sweeps: int = POLISH_SWEEPS,
    batch: int = 256,
    progress: Callable[[str, int, int], None] | None = None,
    allowed: np.ndarray | None = None,
) -> tuple[np.ndarray, float, Any, dict[str, Any]]:
    """Coordinate descent on the cut score with ΣD as the cheap first stage.

    ``allowed`` (bool over the top-left positions, e.g. :meth:`tilesynth.builder.masking.ExemplarMask.valid`): only
    those positions are tried (a mask's clear windows).

    For patch k (the others fixed), every valid position at Chebyshev distance >= N/4 from the other patches
    (the rule of :func:`tilesynth.builder.genes.select.polish_genes`) is evaluated by ``stage1`` (ΣD, whole populations);
    the ``candidates`` best are built and the patch moves to the one with the lowest cut score if that is
    strictly lower than the current. Sweeps over k = 0 .. n−1 repeat until one makes no move, at most
    ``max_sweeps``. Returns ``(genes, score, result, info)``.
    """
    shp, n, t, region = _region(shape, genes.shape[0], tile_size)
    cur = np.asarray(genes, dtype=np.int64).copy()
    min_distance = t // 4
    flat_all = np.arange(region.size, dtype=np.int64)
    all_pos = region.unflat(flat_all)
    score_before = score
    sweeps = moves = built = 0
    converged = False
    for _ in range(max_sweeps):
        sweeps += 1
        moved = False
        for k in range(n):
            others = np.delete(cur, k, axis=0)
            ok = ~np.isin(flat_all, region.flat(cur))
            if min_distance > 1 and others.size:
                ok &= np.abs(all_pos[:, None, :] - others[None]).max(axis=2).min(axis=1) >= min_distance
            if allowed is not None:
                ok &= allowed[all_pos[:, 0], all_pos[:, 1]]
            cand = flat_all[ok]
            vals = np.empty(cand.size)
            for s in range(0, cand.size, batch):
                chunk = cand[s : s + batch]
                pop = np.repeat(cur[None], chunk.size, axis=0)
                pop[:, k] = region.unflat(chunk)
                vals[s : s + chunk.size] = stage1(pop)[0]
            for f in cand[np.argsort(vals, kind="stable")[:candidates]]:
                trial = cur.copy()
                trial[k] = region.unflat([int(f)])[0]
                res = build(trial)
                built += 1
                s_new = cut_score(res.costs, tile_size)
                if s_new < score:
                    cur, score, result = trial, s_new, res
                    moves += 1
                    moved = True
            if progress is not None:
                progress("cut polish", k + 1 + (sweeps - 1) * n, n * max_sweeps)
        if not moved:
            converged = True
            break
    info = {
        "score_before": float(score_before) if np.isfinite(score_before) else None,
        "sweeps": sweeps,
        "moves": moves,
        "builds": built,
        "candidates": int(candidates),
        "converged": converged,
    }
    return cur, float(score), result, info


def selection_record(scores: list[float], chosen: int, tile_size: int) -> dict[str, Any]:
    """What the re-ranking stores in ``params["selection"]["cut"]``."""

    def fin(v: float) -> float | None:
        return float(v) if np.isfinite(v) else None

    return {
        "score": fin(scores[chosen]),
        "eps": CUT_SCORE_EPS * float(tile_size),
        "rerank": len(scores),
        "chosen": int(chosen),
        "scores": [fin(s) for s in scores],
    }
