"""Running a batch: :func:`build_many` plans the jobs (up to date, or to build), submits them to an executor,
collects and logs their records and shows the progress; :class:`BatchResult` is what it returns."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import datetime
import json
import os
import sys
import time
import uuid
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TextIO

from ...base.signals import Terminated
from ...errors import ParameterError
from .collisions import _check_collisions
from .executors import _check_scheduler, _start_executor
from .keys import _up_to_date, job_key
from .library import load_library, parse_library
from .schema import Job, Library
from .worker import _message, run_job


@dataclasses.dataclass
class BatchResult:
    """What :func:`build_many` did: one record per job (as in the log), in job order."""

    records: list[dict[str, Any]]
    log: Path | None
    wall_s: float
    #: ``plan_s`` (hashing the inputs, reading the stamps), ``start_s`` (starting the local pool or the Dask
    #: client), ``run_s`` (from the first submission to the last result)
    timings: dict[str, float] = dataclasses.field(default_factory=dict)

    @property
    def n_failed(self) -> int:
        return sum(r["status"] == "failed" for r in self.records)

    @property
    def n_built(self) -> int:
        return sum(r["status"] == "built" for r in self.records)

    @property
    def n_skipped(self) -> int:
        return sum(r["status"] == "skipped" for r in self.records)

    @property
    def exit_status(self) -> int:
        """0 when nothing failed, 1 when any job failed (see :mod:`tilesynth.cli.batch`)."""
        return 1 if self.n_failed else 0

    def summary(self) -> str:
        """A plain-text table: job, status, time, peak memory, and the error of failed jobs."""
        width = max([3, *(len(r["job"]) for r in self.records)])
        lines = [f"{'job':<{width}}  {'status':<7}  {'time':>7}  {'peak MB':>7}  note"]
        for r in self.records:
            t = r.get("timings", {}).get("total_s")
            mem = r.get("peak_rss_mb")
            note = r.get("error") or (f"{len(r['warnings'])} warning(s)" if r.get("warnings") else "")
            lines.append(
                f"{r['job']:<{width}}  {r['status']:<7}  {'' if t is None else f'{t:6.2f}s':>7}  "
                f"{'' if mem is None else f'{mem:7.0f}':>7}  {note}"
            )
        lines.append(
            f"{len(self.records)} jobs: {self.n_built} built, {self.n_skipped} up to date, "
            f"{self.n_failed} failed, {self.wall_s:.1f} s"
        )
        return "\n".join(lines)


class _JobProgress:
    """Progress over the jobs on stderr: one redrawn line on a terminal, a line per finished job otherwise."""

    def __init__(self, total: int, skipped: int, quiet: bool, stream: TextIO | None = None) -> None:
        self.total, self.skipped, self.quiet = total, skipped, quiet
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.done = self.failed = 0

    def _eta(self) -> str:
        finished = self.done + self.failed
        if not finished or finished >= self.total:
            return "?" if not finished else "0s"
        return _dur((time.perf_counter() - self.start) / finished * (self.total - finished))

    def line(self, running: int) -> str:
        return (
            f"batch: {self.done + self.failed}/{self.total} done ({self.failed} failed), {running} running, "
            f"{self.skipped} up to date, {_dur(time.perf_counter() - self.start)} elapsed, ETA {self._eta()}"
        )

    def finished(self, rec: dict[str, Any], running: int) -> None:
        if rec["status"] == "failed":
            self.failed += 1
        else:
            self.done += 1
        if self.quiet:
            return
        if self.tty:
            self.stream.write("\r\033[K")
        what = (
            f"failed: {rec['error']}"
            if rec["status"] == "failed"
            else f"built in {rec['timings'].get('total_s', 0.0):.1f} s"
        )
        self.stream.write(f"[{self.done + self.failed}/{self.total}] {rec['job']}: {what}\n")
        self.tick(running)

    def tick(self, running: int) -> None:
        if self.quiet:
            return
        if self.tty:
            self.stream.write("\r\033[K" + self.line(running))
        elif self.done + self.failed == self.total:
            self.stream.write(self.line(running) + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.tty and not self.quiet:
            self.stream.write("\n")
            self.stream.flush()


def _dur(s: float) -> str:
    s = round(s)
    return (
        f"{s // 3600}h{s % 3600 // 60:02d}m"
        if s >= 3600
        else f"{s // 60}m{s % 60:02d}s"
        if s >= 60
        else f"{s}s"
    )


def build_many(
    jobs: str | os.PathLike[str] | Library | Iterable[Job] | Mapping[str, Any],
    executor: cf.Executor | str | None = None,
    *,
    force: bool = False,
    workers: int | None = None,
    threads: int | None = None,
    scheduler: str | None = None,
    log: str | os.PathLike[str] | None = None,
    quiet: bool = False,
    stream: TextIO | None = None,
) -> BatchResult:
    """Run every job of a batch: build (+ sheet, previews, report), skipping the jobs that are up to date.

    Parameters
    ----------
    jobs : a batch file path, a :class:`Library` (:func:`load_library`), a list of :class:`Job`, or the content of
        a batch file as a dict (paths relative to the current directory). Validated before any work.
    executor : ``None`` (a local process pool, see :mod:`tilesynth.cli.batch`), ``"serial"`` (this process),
        or any ``concurrent.futures.Executor`` (``client.get_executor()`` of Dask, Ray's, ...). Not shut down
        here.
    force : rebuild jobs that are up to date.
    workers : processes of the local pool (default: usable cores, at most the jobs to build).
    threads : kernel threads per job (default: cores // workers for the local pool; None, i.e. every core,
        for another executor).
    scheduler : address of a Dask scheduler (``tcp://host:8786``); a client is opened and closed here.
    log : JSON-lines log to append to (default: the library's, ``<output_dir>/batch-log.jsonl``; for a list of
        jobs, none unless given).
    quiet : no progress on stderr.

    Returns a :class:`BatchResult`; a failing job is a record with ``status = "failed"``, never an exception.
    """
    start = time.perf_counter()
    lib = _as_library(jobs)
    _check_run_args(executor, workers, threads, scheduler)
    log_path = Path(log) if log is not None else lib.log
    if log is not None:  # the log given here goes through the same check as the batch file's own
        _check_collisions(lib.jobs, log_path, lib.source)
    run_id = (
        datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ") + f"-{uuid.uuid4().hex[:8]}"
    )

    phase = {"validate_s": time.perf_counter() - start}
    plan = _plan(lib.jobs, force, run_id)
    to_run = [spec for _, spec, _ in plan if spec is not None]
    phase["plan_s"] = time.perf_counter() - start - phase["validate_s"]
    t_exec = time.perf_counter()

    executor, slots, own_pool, own_client = _start_executor(executor, scheduler, to_run, workers, threads)
    phase["start_s"] = time.perf_counter() - t_exec
    t_run = time.perf_counter()

    if log_path is not None:
        log_path.parent.mkdir(parents=True, exist_ok=True)
    lib.output_dir.mkdir(parents=True, exist_ok=True)
    progress = _JobProgress(len(to_run), len(plan) - len(to_run), quiet, stream)
    results: dict[int, dict[str, Any]] = {}
    futures: dict[cf.Future, dict[str, Any]] = {}
    log_fh = open(log_path, "a", encoding="utf-8") if log_path is not None else None  # noqa: SIM115
    order: dict[int, int] = {}
    try:
        for k, (_, _unused, rec) in enumerate(plan):
            if rec is not None:
                results[k] = rec
                _log(log_fh, rec, run_id)
        order = {id(spec): k for k, (_, spec, _) in enumerate(plan) if spec is not None}
        if executor == "serial":
            _run_serial(to_run, order, results, log_fh, run_id, progress)
        elif to_run:
            _run_on_executor(executor, to_run, futures, slots, order, results, log_fh, run_id, progress)
    except (KeyboardInterrupt, Terminated):
        # stop now (Ctrl-C, or SIGTERM in the command line): cancel what has not started (Dask cancels on the
        # cluster too) and end the local workers, which would otherwise run the calls already queued to them; a
        # job cut short leaves only its temporary directory, removed when it next runs. Jobs that finished
        # before the signal but were not collected yet are logged.
        for f in futures:
            f.cancel()
        for f, spec in futures.items():
            k = order.get(id(spec))
            if (
                k is not None
                and k not in results
                and f.done()
                and not f.cancelled()
                and f.exception() is None
            ):
                results[k] = f.result()
                _log(log_fh, results[k], run_id)
        if own_pool is not None:
            procs = list((getattr(own_pool, "_processes", None) or {}).values())
            own_pool.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                with contextlib.suppress(Exception):
                    proc.terminate()
            own_pool = None
        raise
    finally:
        progress.close()
        if log_fh is not None:
            log_fh.close()
        if own_pool is not None:
            own_pool.shutdown(wait=True)
        if own_client is not None:
            own_client.close()
    phase["run_s"] = time.perf_counter() - t_run
    return BatchResult([results[k] for k in range(len(plan))], log_path, time.perf_counter() - start, phase)


def _check_run_args(executor: Any, workers: Any, threads: Any, scheduler: Any) -> None:
    """The argument checks of :func:`build_many` (before any work)."""
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ParameterError(f"workers = {workers!r}: must be a positive integer")
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, int) or threads < 1):
        raise ParameterError(f"threads = {threads!r}: must be a positive integer")
    if scheduler is not None and executor is not None:
        raise ParameterError("scheduler and executor: give one of them, not both")
    if scheduler is not None:
        _check_scheduler(scheduler)
    if workers is not None and (executor is not None or scheduler is not None):
        raise ParameterError(
            f"workers = {workers}: only used with the local process pool (no executor, no scheduler)"
        )
    if isinstance(executor, str) and executor != "serial":
        raise ParameterError(
            f"executor = {executor!r}: expected None, 'serial' or a concurrent.futures.Executor"
        )
    if executor is not None and not isinstance(executor, (str, cf.Executor)):
        raise TypeError(f"executor = {executor!r}: expected a concurrent.futures.Executor")


def _plan(
    jobs: list[Job], force: bool, run_id: str
) -> list[tuple[Job, dict[str, Any] | None, dict[str, Any] | None]]:
    """For every job, in order: ``(job, spec to run, None)``, or ``(job, None, record)`` when it is up to date
    (``skipped``) or an input cannot be read (``failed``)."""
    plan: list[tuple[Job, dict[str, Any] | None, dict[str, Any] | None]] = []  # job, spec to run, or record
    for job in jobs:
        try:
            key, parts = job_key(job)
        except OSError as exc:
            plan.append((job, None, _record(job, "failed", error=f"cannot read an input: {_message(exc)}")))
            continue
        if not force and _up_to_date(job, key):
            plan.append((job, None, _record(job, "skipped", outputs=[str(p) for p in job.outputs.values()])))
        else:
            plan.append((job, _spec(job, key, parts, run_id), None))
    return plan


def _run_serial(
    to_run: list[dict[str, Any]],
    order: dict[int, int],
    results: dict[int, dict[str, Any]],
    log_fh: TextIO | None,
    run_id: str,
    progress: _JobProgress,
) -> None:
    """``executor="serial"``: the jobs one after another in this process."""
    for spec in to_run:
        progress.tick(1)
        rec = run_job(spec)
        results[order[id(spec)]] = rec
        _log(log_fh, rec, run_id)
        progress.finished(rec, 0)


def _run_on_executor(
    executor: cf.Executor,
    to_run: list[dict[str, Any]],
    futures: dict[cf.Future, dict[str, Any]],
    slots: int | None,
    order: dict[int, int],
    results: dict[int, dict[str, Any]],
    log_fh: TextIO | None,
    run_id: str,
    progress: _JobProgress,
) -> None:
    """Submit every spec (filling ``futures``, which the caller cancels on Ctrl-C) and collect the records as
    they finish."""
    futures.update({executor.submit(run_job, spec): spec for spec in to_run})
    pending = set(futures)
    progress.tick(min(len(pending), slots or len(pending)))
    while pending:
        done, pending = cf.wait(pending, timeout=1.0, return_when=cf.FIRST_COMPLETED)
        running = min(len(pending), slots) if slots else sum(f.running() for f in pending)
        for f in done:
            spec = futures[f]
            try:
                rec = f.result()
            except Exception as exc:  # noqa: BLE001 - the executor lost the job (worker died, ...)
                rec = _record_spec(spec, "failed", error=f"executor: {type(exc).__name__}: {exc}")
            results[order[id(spec)]] = rec
            _log(log_fh, rec, run_id)
            progress.finished(rec, running)
        if not done:
            progress.tick(running)


def _as_library(jobs: Any) -> Library:
    if isinstance(jobs, Library):
        return jobs
    if isinstance(jobs, (str, os.PathLike)):
        return load_library(jobs)
    if isinstance(jobs, Mapping):
        return parse_library(jobs, Path.cwd(), source="<dict>")
    if isinstance(jobs, Iterable):
        items = list(jobs)
        if not items or not all(isinstance(j, Job) for j in items):
            raise TypeError("jobs: expected a batch file path, a Library, a dict or a non-empty list of Job")
        _check_collisions(items, Path(os.devnull), "<jobs>")
        return Library("<jobs>", items[0].stamp.parent, None, items)  # type: ignore[arg-type]
    raise TypeError(f"jobs = {jobs!r}: expected a batch file path, a Library, a dict or a list of Job")


def _spec(job: Job, key: str, parts: dict[str, Any], run_id: str) -> dict[str, Any]:
    return {
        "run": run_id,
        "nonce": uuid.uuid4().hex,
        "index": job.index,
        "name": job.name,
        "exemplar": str(job.exemplar),
        "maps": {k: [str(p), kind] for k, (p, kind) in job.maps.items()},
        "options": dict(job.options),
        "sheet": job.sheet,
        "previews": [dict(p) for p in job.previews],
        "report": job.report,
        "export": job.export,
        "material": {k: {**m, "path": str(m["path"])} for k, m in job.material.items()},
        "mask": None if job.mask is None else str(job.mask),
        "alpha": job.alpha,
        "normal_y": job.normal_y,
        "outputs": {k: str(v) for k, v in job.outputs.items()},
        "stamp": str(job.stamp),
        "key": key,
        "key_parts": parts,
        "threads": None,
    }


def _record(
    job: Job, status: str, outputs: list[str] | None = None, error: str | None = None
) -> dict[str, Any]:
    return {
        "job": job.name,
        "index": job.index,
        "exemplar": str(job.exemplar),
        "status": status,
        "outputs": outputs or [],
        "timings": {},
        "warnings": [],
        "error": error,
    }


def _record_spec(spec: dict[str, Any], status: str, error: str) -> dict[str, Any]:
    return {
        "job": spec["name"],
        "index": spec["index"],
        "exemplar": spec["exemplar"],
        "status": status,
        "outputs": [],
        "timings": {},
        "warnings": [],
        "error": error,
    }


def _log(fh: TextIO | None, rec: dict[str, Any], run_id: str) -> None:
    rec.setdefault("run", run_id)
    rec["run"] = run_id
    if fh is not None:
        fh.write(json.dumps(rec, sort_keys=True) + "\n")
        fh.flush()
