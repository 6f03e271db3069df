"""Evaluating a population in chunks, so that Ctrl-C takes effect promptly.

A kernel call releases the GIL and runs in Rust; Python runs its signal handlers (``KeyboardInterrupt``) only
between bytecodes, so a single call for the whole population of a GA/AIS generation (8-16 s on large
exemplars) delays Ctrl-C by that long. Rust must not call back into Python from its parallel loops, so the
population is split here instead: :func:`call_in_chunks` sizes the chunks so that each call takes about
:data:`TARGET_SECONDS`, and between two calls Python checks for signals. Every individual's E and D are
computed independently of the others, so the results are bit-identical to one call.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

#: Aimed duration of one evaluation call (the worst-case delay of Ctrl-C is about this).
TARGET_SECONDS = 0.1


def chunkable(fn: Callable) -> Callable:
    """Mark a population evaluator as safe to call on chunks of a batch (tilesynth's own evaluators: each
    individual independent). A user's ``evaluate`` passed to :func:`tilesynth.builder.genes.select.select_genes` is not
    marked and keeps one call per batch."""

    def chunked(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return fn(genes)

    chunked._tilesynth_chunkable = True  # type: ignore[attr-defined]
    return chunked


class ChunkSizer:
    """Remembers the time per individual of the last calls and proposes the next chunk size."""

    def __init__(self, first: int = 8) -> None:
        self.size = first

    def update(self, rows: int, seconds: float) -> None:
        if rows > 0 and seconds > 0:
            self.size = max(1, int(TARGET_SECONDS * rows / seconds))


def call_in_chunks(
    fn: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]], genes: np.ndarray, sizer: ChunkSizer | None
) -> tuple[np.ndarray, np.ndarray]:
    """``fn(genes)`` as the concatenation of ``fn`` over consecutive chunks of rows (``fn`` returns ``(E[P],
    D[P, m])`` as validated arrays); one call if ``sizer`` is None."""
    p = genes.shape[0]
    if sizer is None:
        return fn(genes)
    if p <= sizer.size:
        t0 = time.perf_counter()
        out = fn(genes)
        sizer.update(p, time.perf_counter() - t0)
        return out
    Es, Ds = [], []
    start = 0
    while start < p:
        stop = min(p, start + sizer.size)
        t0 = time.perf_counter()
        E, D = fn(genes[start:stop])
        sizer.update(stop - start, time.perf_counter() - t0)
        Es.append(E)
        Ds.append(D)
        start = stop
    return np.concatenate(Es), np.concatenate(Ds)
