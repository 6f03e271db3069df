"""One job, as a worker process (or this one, serially) runs it: the build, its sheet, previews, report and
engine export, all written into a temporary folder beside the outputs and moved into place, the stamp last;
the record it returns; and the clean-up of the temporary folders that interrupted runs left behind."""

from __future__ import annotations

import contextlib
import datetime
import glob
import hashlib
import json
import os
import shutil
import socket
import sys
import time
import traceback
import uuid
import warnings
from pathlib import Path
from typing import Any

from ...errors import ParameterError, TilesynthError
from .schema import TMP_PREFIX


def _reset_peak() -> bool:
    """Reset the kernel's peak-RSS counter of this process (Linux >= 4.0); False where that is not possible."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        return True
    except OSError:
        return False


def _peak_rss_mb() -> float:
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    r = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return r / (1024.0 * 1024.0) if sys.platform == "darwin" else r / 1024.0


def run_job(spec: dict[str, Any]) -> dict[str, Any]:
    """Run one job described by ``spec`` (a small dict of paths and options, see
    :func:`~tilesynth.cli.batch.build_many`) and return its record. Never raises for a job's own failure: the
    error is in the record."""
    t_start, cpu_start, started = time.perf_counter(), time.process_time(), time.time()
    scoped = _reset_peak()
    rec: dict[str, Any] = {
        "job": spec["name"],
        "index": spec["index"],
        "exemplar": spec["exemplar"],
        "status": "failed",
        "outputs": [],
        "timings": {},
        "warnings": [],
        "error": None,
        "threads": spec.get("threads"),
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "started": started,
    }
    tmp = None
    env_before = os.environ.get("TILESYNTH_NUM_THREADS")
    if spec.get("threads") is not None:  # also caps any kernel call that is not given `threads` explicitly
        os.environ["TILESYNTH_NUM_THREADS"] = str(spec["threads"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            tmp = (
                Path(spec["stamp"]).parent
                / f"{TMP_PREFIX}{Path(spec['stamp']).name}.{uuid.uuid4().hex[:12]}-{_owner_tag(os.getpid())}"
            )
            _clean_stale(Path(spec["stamp"]))
            tmp.mkdir(parents=True)
            rec["outputs"], stamp = _build_job(spec, tmp, rec["timings"])
            t0 = time.perf_counter()
            _commit(spec, tmp, stamp)
            rec["timings"]["commit_s"] = time.perf_counter() - t0
            rec["status"] = "built"
        except (TilesynthError, OSError) as exc:
            rec["error"] = _message(exc)
        except MemoryError:
            rec["error"] = "out of memory"
        except Exception as exc:  # noqa: BLE001 - a bug in one job must not stop the batch
            rec["error"] = f"internal error: {type(exc).__name__}: {exc}"
            rec["traceback"] = traceback.format_exc(limit=8)
        finally:
            if tmp is not None:
                shutil.rmtree(tmp, ignore_errors=True)
            if spec.get("threads") is not None:
                if env_before is None:
                    os.environ.pop("TILESYNTH_NUM_THREADS", None)
                else:
                    os.environ["TILESYNTH_NUM_THREADS"] = env_before
        rec["warnings"] = [f"{w.category.__name__}: {w.message}" for w in caught]
    rec["timings"]["total_s"] = time.perf_counter() - t_start
    rec["timings"]["cpu_s"] = time.process_time() - cpu_start  # every thread of the worker process
    rec["worker_cpu_s"] = sum(os.times()[:2])  # the worker process so far, start-up included
    rec["peak_rss_mb"] = round(_peak_rss_mb(), 1)
    rec["peak_rss_scope"] = "job" if scoped else "process"
    return rec


def _message(exc: BaseException) -> str:
    if isinstance(exc, OSError) and not isinstance(exc, TilesynthError) and exc.strerror:
        return f"{exc.strerror}: {exc.filename}" if exc.filename else exc.strerror
    return str(exc)


#: A temporary directory of another machine (a cluster on a shared file system) is removed after this many
#: seconds without change: its owner cannot be asked whether it still runs.
FOREIGN_TMP_AGE = 24 * 3600


def _host_tag() -> str:
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


def _start_time(pid: int) -> str:
    """When process ``pid`` started (clock ticks since boot, from /proc), or "" where that is unknown: with the
    pid it names one process even after the pid is reused."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            return fh.read().rsplit(b")", 1)[1].split()[19].decode()
    except (OSError, IndexError):
        return ""


def _owner_tag(pid: int) -> str:
    """``<pid>-<start time>-<host hash>``: the process that owns a temporary directory."""
    return f"{pid}-{_start_time(pid) or 0}-{_host_tag()}"


def _owner_alive(name: str) -> bool:
    """Whether the process named in a temporary directory's name (:func:`_owner_tag`) may still be running:
    on this machine, a process of that pid and start time exists; on another machine, always (the caller
    decides by age). Names without an owner (made by an older version) have none alive."""
    tail = name.rsplit(".", 1)[-1].split("-")
    if len(tail) != 4 or not tail[1].isdigit():
        return False
    _, pid, start, host = tail
    if host != _host_tag():
        return True
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return False
    except OSError:
        pass  # exists, owned by another user
    now = _start_time(int(pid))
    return not now or start in ("0", now)


def _clean_stale(stamp: Path) -> None:
    """Remove the temporary directories an interrupted run of this job left behind, never one that a run still
    going (another ``tilesynth batch`` on the same library, another worker) is writing: a directory is stale
    when its owner process (pid and start time, in its name) has ended on this machine, or, made on another
    machine, when it has not changed for :data:`FOREIGN_TMP_AGE` seconds."""
    with contextlib.suppress(OSError):
        for p in stamp.parent.glob(f"{glob.escape(TMP_PREFIX + stamp.name)}.*"):
            if _owner_alive(p.name):
                foreign = p.name.rsplit("-", 1)[-1] != _host_tag()
                with contextlib.suppress(OSError):
                    if not foreign or time.time() - p.stat().st_mtime < FOREIGN_TMP_AGE:
                        continue
            shutil.rmtree(p, ignore_errors=True)


def _build_job(
    spec: dict[str, Any], tmp: Path, timings: dict[str, float]
) -> tuple[list[str], dict[str, Any]]:
    from ...io.images import save_image
    from ...measure.render import contact_sheet

    threads = spec.get("threads")
    outputs = {role: Path(p) for role, p in spec["outputs"].items()}
    staged = {role: tmp / p.name for role, p in outputs.items()}
    t0 = time.perf_counter()
    image, bits, maps = _load_inputs(spec)
    timings["load_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    ts = _build_tileset(spec, image, bits, threads)
    timings["build_s"] = time.perf_counter() - t0
    ts.save(staged["tiles"])
    if spec["sheet"]:
        t0 = time.perf_counter()
        save_image(staged["sheet"], contact_sheet(ts, show_cuts=True))
        timings["sheet_s"] = time.perf_counter() - t0
    _write_previews(ts, spec, staged, maps, bits, threads, timings)
    if spec["report"] is not None:
        t0 = time.perf_counter()
        _write_job_report(ts, spec, staged, outputs, threads)
        timings["report_s"] = time.perf_counter() - t0
    if spec.get("export") is not None:
        t0 = time.perf_counter()
        _export_job(ts, spec, staged, {k: a for k, (a, _) in maps.items()})
        timings["export_s"] = time.perf_counter() - t0
    return [str(outputs[r]) for r in staged], _job_stamp(spec, ts, staged, outputs)


def _load_inputs(spec: dict[str, Any]) -> tuple[Any, Any, dict[str, tuple[Any, str]]]:
    """The exemplar, its bit depth and the job's maps ``{name: (array, kind)}``, each checked to be
    pixel-aligned with the exemplar."""
    from ...io.images import load_image, load_raster

    image, bits = load_image(spec["exemplar"])
    maps = {}
    for mname, (mpath, kind) in spec["maps"].items():
        arr = load_raster(mpath)
        if arr.shape[:2] != image.shape[:2]:
            raise ParameterError(
                f"map {mname!r} = {mpath!r}: the map is {arr.shape[1]}x{arr.shape[0]}, the exemplar "
                f"{image.shape[1]}x{image.shape[0]}; a map must be pixel-aligned with the exemplar"
            )
        maps[mname] = (arr, kind)
    return image, bits, maps


def check_inputs(spec: dict[str, Any]) -> str | None:
    """What a job's build would refuse in its inputs' contents (``batch --dry-run``): the exemplar, its
    ``--with`` maps' alignment, and its material maps checked as the build checks them
    (:func:`tilesynth.builder.materials.check_maps`: alignment, NaN, kinds, normal maps); None when they pass."""
    from ...builder.materials import check_maps
    from .materials import build_keywords

    try:
        image, _, _ = _load_inputs(spec)
        kw = build_keywords(spec)
        if "maps" in kw:
            check_maps(image.shape, kw["maps"], kw["map_kinds"], kw["map_weights"], kw["normal_y"])
    except (TilesynthError, ValueError, TypeError, OSError) as exc:
        return _message(exc)
    return None


def _build_tileset(spec: dict[str, Any], image: Any, bits: Any, threads: int | None) -> Any:
    """The job's tile set, built with the keyword arguments of ``tilesynth build`` (``cli._build``), so that a
    batch build equals a CLI build."""
    from ...schemes import build

    o = dict(spec["options"])
    scheme = o.pop("scheme")
    common: dict[str, Any] = dict(
        tileset=o["set"],
        tile_size=o["tile_size"],
        seed=o["seed"],
        threads=threads,
        progress=None,
        exemplar_info={"file": os.path.basename(spec["exemplar"]), "bits": bits},
        select=o["select"],
        polish=o["polish"],
        generations=o["generations"],
        population=o["population"],
    )
    if scheme == "omega":
        extra: dict[str, Any] = dict(
            gradients=o["gradients"],
            keep_border=not o["literal_border"],
            normalise=o["normalise"],
            match=o["match"],
            match_k=o["match_k"],
            metric=o["metric"],
            smooth=o["smooth"],
        )
    elif scheme == "wang":
        extra = dict(cut=o["cut"], overlap=o["overlap"], corners=o["corners"], samples=o["samples"])
    else:
        extra = dict(gradients=o["gradients"], supplementary=o["supplementary"])
    if scheme == "omega" and o["recipe"] is not None:
        extra["recipe"] = o["recipe"]
    if scheme in ("wang", "swang", "omega") and o["border_tries"] is not None:
        extra["border_tries"] = o["border_tries"]
    from .materials import build_keywords  # material maps, mask, alpha

    return build(image, scheme=scheme, **common, **extra, **build_keywords(spec))


def _write_previews(
    ts: Any,
    spec: dict[str, Any],
    staged: dict[str, Path],
    maps: dict[str, tuple[Any, str]],
    bits: Any,
    threads: int | None,
    timings: dict[str, float],
) -> None:
    """Every preview of the job (as ``tilesynth synth``, with ``--with`` for each map when asked)."""
    import numpy as np

    from ...io.images import atomic_open, save_image
    from ...synth.synthesis import check_smoothable, is_smoothed, synthesize, synthesize_map

    smoothed = is_smoothed(ts)
    for i, pv in enumerate(spec["previews"], start=1):
        t0 = time.perf_counter()
        role = "preview" if i == 1 else f"preview{i}"
        w, h = pv["size"]
        pbits = pv["bits"] or int(bits)
        img, imap = synthesize(
            ts, w, h, seed=pv["seed"], dtype=np.uint16 if pbits == 16 else np.uint8, threads=threads
        )
        save_image(staged[role], img)
        del img
        if pv["maps"]:
            from .materials import write_previews as material_previews  # the set's own maps

            material_previews(ts, staged, role, imap, (w, h), threads)
            for mname, (arr, kind) in maps.items():
                smooth = smoothed if kind == "auto" else kind == "smooth"
                if smooth:
                    check_smoothable(arr, f"map {mname!r}")
                out_map = synthesize_map(ts, arr, imap, w, h, threads=threads, smooth=smooth)
                target = staged[f"{role}-{mname}"]
                if target.suffix == ".npy":
                    with atomic_open(target) as fh:
                        np.save(fh, out_map, allow_pickle=False)
                else:
                    save_image(target, out_map)
        timings[f"{role}_s"] = time.perf_counter() - t0


def _write_job_report(
    ts: Any, spec: dict[str, Any], staged: dict[str, Path], outputs: dict[str, Path], threads: int | None
) -> None:
    """The job's report directory (as ``tilesynth report``)."""
    from ...measure.report import write_report

    r = spec["report"]
    write_report(
        ts,
        staged["report"],
        r["size"][0],
        r["size"][1],
        r["seed"],
        r["borders"],
        threads,
        name=outputs["tiles"].name,
    )


def _job_stamp(
    spec: dict[str, Any], ts: Any, staged: dict[str, Path], outputs: dict[str, Path]
) -> dict[str, Any]:
    """The up-to-date record of the job: its key, what went into it, every output with its size."""
    out_dir = Path(spec["stamp"]).parent
    recs = {}
    for role, p in staged.items():
        size = None if p.is_dir() else p.stat().st_size
        recs[role] = {"path": os.path.relpath(outputs[role], out_dir), "size": size}
    stamp = {
        "key": spec["key"],
        **spec["key_parts"],
        "job": spec["name"],
        "exemplar": spec["exemplar"],
        "outputs": recs,
        "built_at": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "content_sha256": ts.content_digest(),
        "E": float(ts.E),
        "seed": int(ts.params["seed"]),
    }
    return stamp


def _export_job(ts: Any, spec: dict[str, Any], staged: dict[str, Path], maps: dict[str, Any]) -> None:
    """The engine export of the job's tile set into ``target`` (``tilesynth export`` with ``--with`` per map)."""
    from ...engine import export

    e = dict(spec["export"])
    # the staged .tiles file: the same bytes and file name as the final one (the manifest records both)
    export(ts, staged["export"], maps=maps if e.pop("maps") else None, source_path=staged["tiles"], **e)


def _commit(spec: dict[str, Any], tmp: Path, stamp: dict[str, Any]) -> None:
    """Move the staged outputs into place, then write the stamp (last: a job without it is built again)."""
    from ...io.images import atomic_open

    stamp_path = Path(spec["stamp"])
    with contextlib.suppress(FileNotFoundError):
        stamp_path.unlink()
    for final in map(Path, spec["outputs"].values()):
        src = tmp / final.name
        if src.is_dir():
            old = tmp / f"{final.name}.old"
            if final.exists():
                os.replace(final, old)
            os.replace(src, final)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(src, final)
    with atomic_open(stamp_path) as fh:
        fh.write(json.dumps(stamp, indent=1, sort_keys=True).encode("utf-8"))
