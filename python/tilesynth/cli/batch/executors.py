"""Where the jobs of a batch run: the local process pool (its start method, its size from the usable cores,
each worker's thread count and its watch on the batch process) or a Dask cluster (its address checked, a
client opened)."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import multiprocessing
import os
import re
import time
from typing import Any

from ...errors import ParameterError


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def _start_method() -> str:
    methods = multiprocessing.get_all_start_methods()
    return "forkserver" if "forkserver" in methods else "spawn"


def _init_worker(threads: int, parent: int | None = None) -> None:
    os.environ["TILESYNTH_NUM_THREADS"] = str(threads)
    if parent is not None:
        _die_with(parent)


def _die_with(parent: int) -> None:
    """End this worker process as soon as ``parent`` (the process that runs the batch) is gone.

    Why: a pool's workers are children of the forkserver, not of the batch process; when the batch process is
    killed (SIGKILL, the OOM killer) nothing tells a worker busy with a job, and it ran on for minutes, keeping
    the forkserver and the resource tracker alive too. A thread waits on a pidfd of the parent (Linux >= 5.3;
    elsewhere it polls every half second) and ends the process at once; ``PR_SET_PDEATHSIG`` also covers the
    death of the forkserver."""
    import threading

    with contextlib.suppress(Exception):  # Linux only
        import ctypes
        import signal

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    try:
        fd = os.pidfd_open(parent)  # type: ignore[attr-defined]
    except ProcessLookupError:
        os._exit(1)
    except (AttributeError, OSError):
        fd = None

    def watch() -> None:
        if fd is not None:
            import select

            select.select([fd], [], [])  # readable when the process ends
            os._exit(1)
        while True:
            time.sleep(0.5)
            try:
                os.kill(parent, 0)
            except ProcessLookupError:
                os._exit(1)
            except OSError:
                pass

    threading.Thread(target=watch, name="tilesynth-parent-watch", daemon=True).start()


#: A Dask scheduler address: ``PROTOCOL://HOST[:PORT]`` with one of Dask's comm protocols, or ``HOST:PORT``.
_SCHEDULER = re.compile(r"(?:(?:tcp|tls|inproc|ucx|ws|wss)://[^\s/:]+(?::\d{1,5})?|[^\s/:]+:\d{1,5})/?")


def _check_scheduler(scheduler: Any) -> None:
    """Refuse before any work what cannot be a Dask scheduler address (a dashboard's http:// URL, a bare word,
    an empty string), naming ``scheduler``."""
    if not isinstance(scheduler, str) or not _SCHEDULER.fullmatch(scheduler):
        hint = (
            " (an http:// address is the dashboard's; the scheduler listens on tcp://HOST:8786)"
            if isinstance(scheduler, str) and scheduler.lower().startswith(("http://", "https://"))
            else ""
        )
        raise ParameterError(
            f"scheduler = {scheduler!r}: expected a Dask scheduler address such as tcp://HOST:8786 or "
            f"HOST:8786{hint}"
        )


def _start_executor(
    executor: Any,
    scheduler: str | None,
    to_run: list[dict[str, Any]],
    workers: int | None,
    threads: int | None,
) -> tuple[Any, int | None, cf.ProcessPoolExecutor | None, Any]:
    """The executor to submit to, how many jobs it runs at once (None: unknown), and the local pool or Dask
    client opened here (None otherwise; closed by the caller); sets the ``threads`` of every spec."""
    own_pool = own_client = None
    slots: int | None = None
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise ParameterError(
                f"scheduler = {scheduler!r}: Dask is not installed (pip install tilesynth[dask])"
            ) from None
        try:
            own_client = Client(scheduler)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ParameterError(f"scheduler = {scheduler!r}: cannot connect ({exc})") from None
        executor = own_client.get_executor(pure=False)
        slots = sum(w.get("nthreads", 1) for w in own_client.scheduler_info()["workers"].values()) or None
    elif executor is None and to_run:
        cores = _cores()
        n = min(workers or cores, len(to_run))
        per = threads or max(1, cores // n)
        for s in to_run:
            s["threads"] = per
        own_pool = cf.ProcessPoolExecutor(
            max_workers=n,
            mp_context=multiprocessing.get_context(_start_method()),
            initializer=_init_worker,
            initargs=(per, os.getpid()),
        )
        executor, slots = own_pool, n
    elif executor is not None and not isinstance(executor, str):
        client = getattr(executor, "_client", None)  # Dask's ClientExecutor: count the worker threads
        with contextlib.suppress(Exception):
            slots = sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values()) or None
    if threads is not None:
        for s in to_run:
            s["threads"] = threads
    return executor, slots, own_pool, own_client
