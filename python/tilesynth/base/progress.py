"""A small progress display on stderr (no dependency).

On a terminal it redraws one line per stage (``\\r``); otherwise it prints one line when a stage ends, and only for
stages that took over a second, so logs stay short. ``quiet=True`` silences it.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


class Progress:
    """Callable ``(stage, done, total)`` progress reporter."""

    def __init__(self, quiet: bool = False, stream: TextIO | None = None, width: int = 30) -> None:
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.width = width
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._stage: str | None = None
        self._start = 0.0

    def __call__(self, stage: str, done: int, total: int) -> None:
        if self.quiet:
            return
        now = time.perf_counter()
        if stage != self._stage:
            self._stage, self._start = stage, now
        total = max(total, 1)
        elapsed = now - self._start
        if self.tty:
            fill = int(self.width * done / total)
            bar = "#" * fill + "." * (self.width - fill)
            end = "\n" if done >= total else ""
            self.stream.write(f"\r{stage:<22} [{bar}] {done}/{total} {elapsed:6.1f}s{end}")
            self.stream.flush()
        elif done >= total and elapsed >= 1.0:
            self.stream.write(f"{stage}: done in {elapsed:.1f}s\n")
            self.stream.flush()

    def finish(self, stage: str, note: str) -> None:
        """End ``stage`` early with a reason (e.g. "converged at generation 9 of 50"): the bar is completed and
        the note shown, instead of a bar left at 9/50."""
        if self.quiet:
            return
        elapsed = time.perf_counter() - self._start if stage == self._stage else 0.0
        if self.tty:
            self.stream.write(f"\r{stage:<22} [{'#' * self.width}] {note} {elapsed:6.1f}s\n")
        else:
            self.stream.write(f"{stage}: {note}, {elapsed:.1f}s\n")
        self.stream.flush()
        self._stage = None

    def message(self, text: str) -> None:
        """Print an informational line (suppressed when quiet)."""
        if not self.quiet:
            self.stream.write(text + "\n")
            self.stream.flush()
