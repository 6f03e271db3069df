"""No output of a batch may be an input or another output: the rule of :mod:`tilesynth.io.paths` over every
job of a batch and its log, with messages that name the jobs."""

from __future__ import annotations

import os
from pathlib import Path

from .schema import BatchError, Job


def _job_inputs(j: Job) -> list[tuple[str, Path]]:
    """Every file a job reads: its exemplar, maps, material maps and mask."""
    ins = [("exemplar", j.exemplar)]
    ins += [(f"map {k!r}", mp) for k, (mp, _) in j.maps.items()]
    ins += [(f"material map {k!r}", m["path"]) for k, m in j.material.items()]
    if j.mask is not None:
        ins.append(("mask", j.mask))
    return ins


def _check_collisions(jobs: list[Job], log: Path, source: str) -> None:
    """No output of the batch (a job's, or the log) may be an input (a job's exemplar, map or mask, or the batch
    file itself) or another output: the rule of :mod:`tilesynth.io.paths` (same inode, or same resolved path
    for a file not there yet), with messages that name the jobs."""
    from ...io.paths import file_identity

    names: dict[str, Job] = {}
    for j in jobs:
        key = os.path.normcase(j.name)
        if key in names:
            o = names[key]
            raise BatchError(
                f"{j.where}: field 'name': duplicate output name {j.name!r} (also {o.where}, "
                f"exemplar {o.exemplar.name}); give one of them another name"
            )
        names[key] = j
    inputs: dict[tuple, str] = {}
    if Path(source).is_file():
        inputs[file_identity(source)] = "the batch file"
    for j in jobs:
        for role, p in _job_inputs(j):
            inputs.setdefault(file_identity(p), f"{j.where} ({role})")
    log_id = file_identity(log)
    if log_id in inputs:
        raise BatchError(
            f"{source}: the log {str(log)!r} is an input: {inputs[log_id]}; choose another log file"
        )
    writers: dict[tuple, tuple[Job, str]] = {log_id: (None, "the log")}  # type: ignore[dict-item]
    by_path: dict[str, tuple[Job, str]] = {os.path.normcase(str(log.resolve())): (None, "the log")}  # type: ignore[dict-item]
    for j in jobs:
        for role, p in [*j.outputs.items(), ("stamp", j.stamp)]:
            key = file_identity(p)
            if key in writers:
                oj, orole = writers[key]
                other = "the batch log" if oj is None else f"{oj.where} ({orole})"
                raise BatchError(
                    f"{j.where}: field 'name': its {role} output {str(p)!r} is also written by {other}"
                )
            if key in inputs:
                raise BatchError(
                    f"{j.where}: field 'name': its {role} output {str(p)!r} would overwrite an input "
                    f"of {inputs[key]}"
                )
            writers[key] = (j, role)
            by_path[os.path.normcase(str(p.resolve()))] = (j, role)
    for key, (j, role) in by_path.items():  # a file where another job needs a directory
        for parent in Path(key).parents:
            pk = str(parent)
            if pk in by_path:
                oj, orole = by_path[pk]
                raise BatchError(
                    f"{j.where if j else source}: field 'name': its {role} output lies inside "
                    f"{orole} output {pk!r} of {oj.where if oj else 'the batch'}"
                )
