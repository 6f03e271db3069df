"""Whether a job is up to date: its key (a SHA-256 over the content of its inputs, its effective parameters
and the tilesynth version) against the stamp its last build wrote."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from .schema import Job


def _file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def job_key(job: Job) -> tuple[str, dict[str, Any]]:
    """The up-to-date key of ``job`` and what went into it (input digests, parameter hash, version)."""
    from ..._version import __version__

    inputs = {"exemplar": _file_sha256(job.exemplar)}
    inputs.update({f"map:{k}": _file_sha256(p) for k, (p, _) in sorted(job.maps.items())})
    inputs.update({f"material:{k}": _file_sha256(m["path"]) for k, m in sorted(job.material.items())})
    if job.mask is not None:
        inputs["mask"] = _file_sha256(job.mask)
    params_sha = hashlib.sha256(json.dumps(job.params(), sort_keys=True).encode()).hexdigest()
    parts = {"inputs": inputs, "params_sha256": params_sha, "tilesynth_version": __version__}
    key = hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()
    return key, parts


def _up_to_date(job: Job, key: str) -> bool:
    try:
        stamp = json.loads(job.stamp.read_text("utf-8"))
        if stamp.get("key") != key:
            return False
        for rec in stamp["outputs"].values():
            p = job.stamp.parent / rec["path"]
            if rec["size"] is None:
                if not p.is_dir():
                    return False
            elif not p.is_file() or p.stat().st_size != rec["size"]:
                return False
        return set(stamp["outputs"]) == set(job.outputs)
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False
