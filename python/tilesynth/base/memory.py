"""Returning freed heap memory to the operating system between the stages of a build, so that
the selection's freed buffers do not add to the peak RSS of the stages after it.

The selection stage's Rust kernels (the population evaluator, the matching maps) allocate and free hundreds of
megabytes of transient buffers from several threads. glibc keeps freed memory in its per-thread arenas for
reuse, so after the selection the process still holds it (measured: 375 MB resident, of which nothing is
live, after the best-of-32 selection of an n2 set with 256-px tiles on a 1024² exemplar), and every later
stage's allocations add to it: the build's peak RSS is then the sum. :func:`release_freed_memory` asks the
allocator to hand back what is free (``malloc_trim(0)``, which also releases free pages inside the arenas).
It frees nothing that is in use and changes no result; later stages fault their pages back in (a few tens of
milliseconds of system time for a build of several seconds). On a C library without ``malloc_trim`` (musl,
macOS, Windows) it does nothing.
"""

from __future__ import annotations

import ctypes
import sys
from typing import Any

_trim: Any = None
_looked_up = False


def release_freed_memory() -> bool:
    """Return the allocator's free memory to the OS; True if the C library offers ``malloc_trim``."""
    global _trim, _looked_up
    if not _looked_up:
        _looked_up = True
        if sys.platform.startswith("linux"):
            try:
                _trim = ctypes.CDLL(None).malloc_trim
                _trim.argtypes = [ctypes.c_size_t]
                _trim.restype = ctypes.c_int
            except (OSError, AttributeError):
                _trim = None
    if _trim is None:
        return False
    _trim(0)
    return True
