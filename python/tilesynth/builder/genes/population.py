"""What every gene-selection method shares (:mod:`tilesynth.builder.genes.select`): the result record, the
parameter checks, the population evaluator with its cache of vectors already evaluated, and the run's
bookkeeping (history, stagnation, the best vector ever evaluated).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...base.chunks import ChunkSizer, call_in_chunks
from ...errors import ParameterError, ShapeError
from .draws import random_genes

Evaluate = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
"""``evaluate(genes[P, n, 2] int64) -> (E[P] float64, D[P, m] float64)``."""

Progress = Callable[[str, int, int], None]
"""Progress callback ``(stage, done, total)``, called once per generation."""

# --------------------------------------------------------------------------------------------------------------
# Result


@dataclass
class SelectionResult:
    """Outcome of a gene selection.

    Attributes
    ----------
    genes : int64 ``(n, 2)``, the best gene vector found (distinct, in range).
    E : its objective value (exactly the evaluator's value for ``genes``).
    D : float64 ``(m,)``, the evaluator's per-tile errors for ``genes``.
    method : "random", "best-of", "ga" or "ais".
    params : every parameter used (JSON-able), including ``polish`` and the polish parameters.
    history : ``{"best": [...], "mean": [...]}``, best and mean E of the population of every generation of the
        method (not of the polish), as Python floats.
    evaluations : number of individuals evaluated (method and polish).
    generations : generations of the method run (``len(history["best"])``).
    wall_time : seconds, method and polish.
    stop_reason : "generations" (N_g reached), "stagnation" (N_o generations without improvement) or "done"
        (random, best-of).
    polish : ``None`` without polish, otherwise ``{"E_before", "sweeps", "moves", "evaluations", "converged"}``.
    """

    genes: np.ndarray
    E: float
    D: np.ndarray
    method: str
    params: dict[str, Any]
    history: dict[str, list[float]]
    evaluations: int
    generations: int
    wall_time: float
    stop_reason: str = "done"
    polish: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-able summary (genes as nested lists, D as a list)."""
        return {
            "method": self.method,
            "genes": self.genes.tolist(),
            "E": float(self.E),
            "D": [float(v) for v in self.D],
            "params": dict(self.params),
            "history": {k: list(v) for k, v in self.history.items()},
            "evaluations": int(self.evaluations),
            "generations": int(self.generations),
            "wall_time": float(self.wall_time),
            "stop_reason": self.stop_reason,
            "polish": None if self.polish is None else dict(self.polish),
        }


# --------------------------------------------------------------------------------------------------------------
# Small helpers


MAX_POPULATION = 10_000
"""Largest population (GA, AIS) or count (best-of): every generation evaluates the whole population exactly
(four SSD maps per new patch position), so 10^4 individuals already take minutes a generation on a 512-pixel
exemplar; a larger value is a mistake that would exhaust memory (a population is P x n x 2 int64 genes plus
P x m float64 D values, and the evaluator's working set)."""

MAX_GENERATIONS = 100_000
"""Largest number of generations: far beyond the papers' 50 (and the stop after 5 without improvement);
bounds the run time and the stored convergence history."""


def _float_param(
    name: str, value: Any, lo: float, hi: float, *, lo_open: bool = False, hi_open: bool = False
) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ParameterError(f"{name} = {value!r}: must be a number")
    v = float(value)
    ok = math.isfinite(v) and (v > lo if lo_open else v >= lo) and (v < hi if hi_open else v <= hi)
    if not ok:
        interval = f"{'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
        raise ParameterError(f"{name} = {value!r}: must be in {interval}")
    return v


def _bool_param(name: str, value: Any) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise ParameterError(f"{name} = {value!r}: must be True or False")
    return bool(value)


def as_generator(rng: Any) -> np.random.Generator:
    """A :class:`numpy.random.Generator` from a seed (int), a Generator (used as is) or None (fresh entropy)."""
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None:
        return np.random.default_rng()
    if isinstance(rng, (bool, np.bool_)) or not isinstance(rng, (int, np.integer)) or int(rng) < 0:
        raise ParameterError(f"rng = {rng!r}: expected a non-negative integer seed or a numpy Generator")
    return np.random.default_rng(int(rng))


def _draw_excluding(rng: np.random.Generator, total: int, forbidden: set[int], k: int) -> list[int]:
    """``k`` distinct flat positions in ``[0, total)`` outside ``forbidden`` (uniformly, without replacement)."""
    free = total - len(forbidden)
    if free < k:
        raise ParameterError(f"only {free} free patch positions, {k} needed")
    if total <= 4 * (len(forbidden) + k) + 64:
        pool = np.setdiff1d(
            np.arange(total, dtype=np.int64), np.fromiter(forbidden, np.int64, len(forbidden))
        )
        return [int(v) for v in rng.choice(pool, size=k, replace=False)]
    out: list[int] = []
    taken = set(forbidden)
    while len(out) < k:
        v = int(rng.integers(total))
        if v not in taken:
            taken.add(v)
            out.append(v)
    return out


def _random_population(
    rng: np.random.Generator, size: int, shape: tuple[int, int], n: int, t: int
) -> np.ndarray:
    if size == 0:
        return np.empty((0, n, 2), dtype=np.int64)
    return np.stack([random_genes(shape, n, t, rng) for _ in range(size)]).astype(np.int64)


class _Evaluator:
    """Wraps the user's ``evaluate``: one call per batch (tilesynth's own evaluators: chunks of about 0.1 s,
    see :mod:`tilesynth.base.chunks`), validation, cache of known vectors, best-ever record."""

    def __init__(self, evaluate: Evaluate, n: int, cache: bool = True) -> None:
        if not callable(evaluate):
            raise ParameterError(
                f"evaluate = {evaluate!r}: must be callable genes[P, n, 2] -> (E[P], D[P, m])"
            )
        self.fn = evaluate
        self.n = n
        self.cache: dict[bytes, tuple[float, np.ndarray]] | None = {} if cache else None
        self.count = 0
        self.m: int | None = None
        self.best_genes: np.ndarray | None = None
        self.best_E = math.inf
        self.best_D: np.ndarray | None = None
        # tilesynth's own evaluators: batches in chunks of ~0.1 s, so Ctrl-C acts within ~1 s
        self.sizer = ChunkSizer() if getattr(evaluate, "_tilesynth_chunkable", False) else None

    def _call(self, genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        p = genes.shape[0]
        out = self.fn(np.ascontiguousarray(genes, dtype=np.int64))
        try:
            E_raw, D_raw = out
        except (TypeError, ValueError) as exc:
            raise ShapeError("evaluate must return a pair (E[P], D[P, m])") from exc
        E = np.array(E_raw, dtype=np.float64).reshape(-1)  # copies: the caller's arrays are never modified
        D = np.array(D_raw, dtype=np.float64)
        if E.shape != (p,) or D.ndim != 2 or D.shape[0] != p:
            raise ShapeError(f"evaluate returned E {E.shape} and D {D.shape} for {p} individuals")
        if self.m is None:
            self.m = D.shape[1]
        elif D.shape[1] != self.m:
            raise ShapeError(f"evaluate returned D with {D.shape[1]} columns, earlier {self.m}")
        if not np.isfinite(E).all():
            raise ParameterError("evaluate returned a non-finite E")
        self.count += p
        return E, D

    def __call__(self, genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """E and D of every row of ``genes`` (P, n, 2); updates the best-ever record."""
        genes = np.ascontiguousarray(genes, dtype=np.int64)
        p = genes.shape[0]
        if p == 0:
            return np.empty(0), np.empty((0, self.m or 0))
        if self.cache is None:
            E, D = call_in_chunks(self._call, genes, self.sizer)
        else:
            keys = [g.tobytes() for g in genes]
            todo: dict[bytes, int] = {}
            for i, k in enumerate(keys):
                if k not in self.cache and k not in todo:
                    todo[k] = i
            if todo:
                idx = np.fromiter(todo.values(), np.int64, len(todo))
                E_new, D_new = call_in_chunks(self._call, genes[idx], self.sizer)
                for j, k in enumerate(todo):
                    self.cache[k] = (float(E_new[j]), D_new[j].copy())
            E = np.array([self.cache[k][0] for k in keys], dtype=np.float64)
            D = np.stack([self.cache[k][1] for k in keys])
        i = int(np.argmin(E))
        if E[i] < self.best_E:
            self.best_E = float(E[i])
            self.best_genes = genes[i].copy()
            self.best_D = D[i].copy()
        return E, D


class _Run:
    """Per-generation bookkeeping: history, stagnation counter, progress."""

    def __init__(self, stage: str, total: int, stagnation: int | None, progress: Progress | None) -> None:
        self.stage = stage
        self.total = total
        self.stagnation = stagnation
        self.progress = progress
        self.best: list[float] = []
        self.mean: list[float] = []
        self.stall = 0
        self.record = math.inf

    def generation(self, E_population: np.ndarray, best_ever: float) -> None:
        self.best.append(float(np.min(E_population)))
        self.mean.append(float(np.mean(E_population)))
        if best_ever < self.record:
            self.record = best_ever
            self.stall = 0
        else:
            self.stall += 1
        if self.progress is not None:
            self.progress(self.stage, len(self.best), self.total)
            if (
                self.stop_reason() == "stagnation" and self.generations < self.total
            ):  # a run cut short says so
                note = f"converged at generation {self.generations} of {self.total} (stagnation rule)"
                finish = getattr(self.progress, "finish", None)  # a plain callable gets no extra call
                if finish is not None:
                    finish(self.stage, note)

    @property
    def generations(self) -> int:
        return len(self.best)

    def stop_reason(self) -> str | None:
        if self.stagnation is not None and self.stall >= self.stagnation:
            return "stagnation"
        if self.generations >= self.total:
            return "generations"
        return None


def _result(
    method: str, ev: _Evaluator, params: dict[str, Any], run: _Run, t0: float, stop: str
) -> SelectionResult:
    assert ev.best_genes is not None and ev.best_D is not None
    return SelectionResult(
        genes=ev.best_genes.copy(),
        E=float(ev.best_E),
        D=ev.best_D.copy(),
        method=method,
        params=params,
        history={"best": list(run.best), "mean": list(run.mean)},
        evaluations=ev.count,
        generations=run.generations,
        wall_time=time.perf_counter() - t0,
        stop_reason=stop,
    )
