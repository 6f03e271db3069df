"""``tilesynth batch``: its options, and its main (the listing of ``--dry-run``, the summary, the exit
status)."""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from .driver import _spec, build_many
from .keys import _up_to_date, job_key
from .library import load_library
from .worker import check_inputs


def add_parser(sub: Any) -> None:
    """Register ``tilesynth batch`` on the subparsers ``sub`` of the main parser."""
    from ...schemes.base import positive_int_text

    b = sub.add_parser(
        "batch",
        help="build a texture library described by a TOML batch file",
        description="Build every job of a TOML batch file (format: python -m pydoc tilesynth.cli.batch). "
        "Exit status: 0 all built or up to date, 1 some job failed, 2 bad batch file.",
    )
    b.add_argument("library", help="batch file (.toml)")
    b.add_argument("--force", action="store_true", help="rebuild jobs that are up to date")
    b.add_argument(
        "--workers",
        type=positive_int_text,
        default=None,
        help="local worker processes (default: the usable cores, at most the jobs to build)",
    )
    b.add_argument(
        "--threads",
        type=positive_int_text,
        default=None,
        help="kernel threads per job (default: cores / workers locally; all cores with --scheduler)",
    )
    b.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on a Dask cluster, e.g. tcp://host:8786 (pip install tilesynth[dask]; the workers need "
        "the batch's files at the same paths)",
    )
    b.add_argument(
        "--log", default=None, help="JSON-lines log to append to (default <output_dir>/batch-log.jsonl)"
    )
    b.add_argument(
        "--dry-run", action="store_true", help="validate and list what would be built, build nothing"
    )
    b.add_argument(
        "--json", action="store_true", help="print the records as JSON instead of the summary table"
    )
    b.add_argument("-q", "--quiet", action="store_true", help="no progress output")


def cli_main(args: argparse.Namespace) -> int:
    """``tilesynth batch``: returns the exit status (errors of the batch file raise :class:`BatchError`)."""
    lib = load_library(args.library)
    if args.dry_run:
        failing = 0
        for job in lib.jobs:
            key, parts = job_key(job)
            state = "up to date" if not args.force and _up_to_date(job, key) else "to build"
            if state == "to build":
                problem = check_inputs(_spec(job, key, parts, "dry-run"))
                if problem is not None:
                    state, failing = f"would fail: {problem}", failing + 1
            print(
                f"{job.name}: {state} ({job.exemplar.name}, {job.options['scheme']} {job.options['set']}, "
                f"seed {job.options['seed']}) -> {', '.join(os.path.relpath(p) for p in job.outputs.values())}"
            )
        if failing:
            print(
                f"tilesynth: error: {failing} of {len(lib.jobs)} job(s) would fail (listed above)",
                file=sys.stderr,
            )
            return 2
        return 0
    res = build_many(
        lib,
        force=args.force,
        workers=args.workers,
        threads=args.threads,
        scheduler=args.scheduler,
        log=args.log,
        quiet=args.quiet,
    )
    if args.json:
        print(json.dumps(res.records, indent=1, sort_keys=True))
    else:
        print(res.summary())
        if res.log is not None:
            print(f"log: {res.log}")
    return res.exit_status
