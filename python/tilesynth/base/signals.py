"""SIGTERM in the command line: raised as :class:`Terminated`, so that every atomic write in progress removes
its ``.part`` file (``tilesynth.io.images.atomic_path`` removes it on any exception) and a report's temporary
directory is deleted, as on Ctrl-C.

SIGKILL cannot be caught: a ``tilesynth`` killed with ``kill -9`` (or by the kernel's OOM killer) can leave a
``.NAME.XXXX.part`` file (or a ``.DIR.XXXX.part`` directory of a report) next to the output. Such files are
never mistaken for results (the real output is only ever created by an atomic rename) and can be deleted.
"""

from __future__ import annotations

import signal
import threading
from typing import Any

EXIT_TERMINATED = 128 + signal.SIGTERM


class Terminated(BaseException):
    """SIGTERM was received (a ``BaseException``, like ``KeyboardInterrupt``: ``except Exception`` does not
    swallow it)."""


def _raise(signum: int, frame: Any) -> None:
    raise Terminated(f"terminated by signal {signum}")


def install_sigterm() -> None:
    """Make SIGTERM raise :class:`Terminated` in the main thread (a no-op elsewhere, or if the embedding
    application installed its own handler)."""
    if threading.current_thread() is not threading.main_thread():
        return
    current = signal.getsignal(signal.SIGTERM)
    if current in (signal.SIG_DFL, None) or current is _raise:
        signal.signal(signal.SIGTERM, _raise)
