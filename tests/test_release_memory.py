"""tilesynth.base.memory (issue 15): returning freed heap memory between build stages (issue 15, peak RSS)."""

from __future__ import annotations

import platform
import sys

import numpy as np

from tilesynth.base import memory as _memory


def test_release_freed_memory_returns_memory_and_keeps_live_data():
    live = np.arange(1_000_000, dtype=np.float64)
    garbage = [np.ones(200_000) for _ in range(20)]
    del garbage
    available = _memory.release_freed_memory()
    assert isinstance(available, bool)
    if sys.platform.startswith("linux") and platform.libc_ver()[0] == "glibc":
        assert available
    assert live[-1] == 999_999.0 and live.sum() == 999_999 * 1_000_000 / 2
    assert _memory.release_freed_memory() == available  # looked up once, callable again
