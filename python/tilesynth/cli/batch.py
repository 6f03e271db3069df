"""Batch builds: a whole texture library from one TOML file, on this machine or on a Dask cluster.

``tilesynth batch library.toml`` (or :func:`build_many`) builds a tile set for every job of the file, with
optional contact sheets, synthesized previews (with the job's aligned maps) and reports; it skips the jobs whose
outputs are up to date, keeps going when one job fails, logs every job as one JSON line and shows progress over
the jobs on stderr.

The batch file
==============

Paths are relative to the batch file. Every key is checked before any work starts (unknown keys, wrong types,
bad values, unknown presets, missing exemplars or maps, globs that match nothing, two jobs with the same output
name or writing the same file): the error names the job (its number in the file and its exemplar) and the field.

.. code-block:: toml

    version = 1                       # format version (optional; only 1 exists)
    output_dir = "library"            # where the outputs go (default "tilesynth-library")
    log = "library/batch-log.jsonl"   # JSON-lines log, appended (default <output_dir>/batch-log.jsonl)

    [presets.ground]                  # any name; every key optional
    scheme = "omega"                  # omega | wang | swang (default omega)
    set = "16a"                       # default: c5 for omega (as tilesynth build), wang8 for wang / swang
    tile_size = 64                    # even; default as `tilesynth build` (c5: a quarter side, multiple of 8)
    select = "ga"                     # random | best-of | ga | ais (default: as tilesynth build)
    polish = true
    generations = 20                  # ga / ais
    population = 30                   # ga / ais / best-of
    smooth = true                     # omega: Poisson smoothing inside the cuts
    sheet = true                      # <name>-sheet.png, the contact sheet (default true)
    previews = [{ size = "1024x1024", seed = 7 }]   # <name>-preview.png (+ one file per map); default none
    report = { size = "512x512", seed = 1 }          # <name>-report/index.html; or true; default false
    map_kinds = { id = "copy" }       # how each named map is synthesized: auto | smooth | copy (default auto)

    [presets.wang]
    scheme = "wang"
    set = "wang18"
    cut = "graph"

    [[jobs]]
    exemplar = "textures/gravel.png"  # one image ...
    preset = "ground"
    seed = 3                          # default 1: every job is reproducible
    maps = { normal = "textures/gravel-normal.png", height = "textures/gravel-height.npy" }

    [[jobs]]
    exemplar = "textures/rock/*.png"  # ... or a glob: one job per file, in sorted order
    exclude = ["*-normal.png"]        # globs (file names) left out
    name = "rock/{stem}"              # output name, {stem} = the exemplar's file name without suffix
    maps = { normal = "textures/rock/{stem}-normal.png" }
    preset = "ground"
    tile_size = 48                    # any preset key can be overridden per job

Build options (preset or job): ``scheme``, ``set``, ``tile_size``, ``select``, ``polish``, ``generations``,
``population``, ``seed``; ω only: ``normalise``, ``match`` (ssd | circle | midpoints | best-cut), ``match_k`` (int
or "all", best-cut only), ``metric`` (color | eq2 | eq3), ``smooth``, ``literal_border``; ω and swang:
``gradients`` (patch | tile); wang only: ``cut`` (dp | graph), ``overlap``, ``corners`` (free | pinned),
``samples`` (diamond | square); swang only: ``supplementary`` (ssd | cut); wang, swang and omega: ``border_tries``
(int >= 1). They mean what the ``tilesynth build``
options of the same name mean, and a batch build is byte-identical to ``tilesynth build`` with the same options
and seed (the ``.tiles`` file differs only in its ``timing.json`` member). An option the scheme does not use is
an error. Output options: ``sheet``, ``previews`` (a list of ``{size = "WxH" or [W, H], seed = 1, bits = 8|16,
maps = true}``, each one the ``tilesynth synth`` command with ``--with`` for every map of the job), ``report``
(``true`` or ``{size, seed, borders}``, as ``tilesynth report``) and ``map_kinds``: ``auto`` smooths a map where
the colour tiles were smoothed, ``smooth`` requires it (the preset must set ``smooth = true``), ``copy`` never
blends (labels, masks, IDs). ``export`` (default ``false``; ``true`` or a table ``{bits = 8|16, padding = 8,
lookup = "auto"|"hash"|"index_map", seed = 0, index_seed = 0, normal_y = "up"|"down" (or "+y"|"-y"), map_smooth =
"auto"|"on"|"off", viewer = false, maps = true}``) writes the engine export of the tile set, as ``tilesynth
export NAME.tiles -o NAME-export/`` with ``--with`` for every map of the job (``maps = false``: the colour only);
the options mean what the options of :func:`tilesynth.engine.export` of the same name mean (defaults the same).

Material builds and masks (issue 14, :mod:`tilesynth.cli.batch_materials`): a ``maps`` entry given as a table
``{ file = "...", kind = "normal", weight = 0.5 }`` is a map of the material (``tilesynth build --map``; ``kind``
and ``weight`` optional), a string stays a map sent through the cuts afterwards (``--with``); the preset or job
keys ``mask`` (a file, ``{stem}`` filled in), ``alpha`` (auto | mask | colour) and ``normal_y`` (up | down) are the
``build`` options of the same names.

Outputs of job ``NAME`` (relative to ``output_dir``): ``NAME.tiles``, ``NAME-sheet.png``, ``NAME-preview.png``
(``NAME-preview2.png``, ... for more previews) and ``NAME-preview-<map>.png`` (``.npy`` for float maps),
``NAME-report/``, ``NAME-export/`` (the engine export: atlases, index, ``manifest.json``, shaders, the viewer),
and the stamp ``NAME.batch.json``.

Up to date, atomic, resumable
=============================

A job is *up to date* when its stamp holds the same key and every output it lists is there (same size). The key
is a SHA-256 over the **content** of the exemplar and the maps (a ``touch`` alone rebuilds nothing; a changed
pixel rebuilds that job), the effective parameters (defaults resolved, output names, map kinds) and the
tilesynth version. ``force=True`` (``--force``) rebuilds everything. The thread count is not part of the key:
results are identical at any thread count.

A job writes all its outputs into a hidden temporary directory beside them, deletes its old stamp, moves every
output into place (``os.replace``, atomic on one file system) and writes the new stamp last. An interrupted batch
therefore leaves whole outputs, never partial ones, and a job without a valid stamp is simply built again: run
the same command to resume. Leftover temporary directories are removed when the job next runs.

Failures, log and exit status
=============================

A failing job (unreadable exemplar, tile size too large, ...) is recorded with its message and the batch goes on.
Each job appends one line to the log: ``run`` (id of this run), ``job``, ``index``, ``exemplar``, ``status``
(``built`` | ``skipped`` | ``failed``), ``outputs``, ``timings`` (seconds per stage), ``peak_rss_mb`` (the peak
resident memory of the worker during this job, from ``/proc/self/status`` after resetting it; elsewhere the
process's lifetime peak, ``peak_rss_scope`` says which), ``warnings``, ``error``, ``worker`` and ``threads``.
A summary table goes to stdout. ``tilesynth batch`` exits with 0 when every job was built or skipped, **1 when any
job failed** (how many is in the summary and the log: a count in the exit status would clash with 2, the status
of a bad batch file, and wraps at 256), 2 for a bad batch file or option (before any work), 130 on Ctrl-C.

Executors
=========

By default jobs run in a local process pool (``concurrent.futures.ProcessPoolExecutor``) whose workers start by
``forkserver`` (POSIX) or ``spawn``, never ``fork``: a forked child of a process that already ran a kernel would
inherit its thread pool's state. ``workers`` defaults to the number of usable cores (at most the number of jobs
to build) and each job's kernels get ``threads = cores // workers`` threads, so the Rust thread pools do not
oversubscribe the machine (each job also sets ``TILESYNTH_NUM_THREADS`` to its thread count while it runs, so
a kernel call that is not handed ``threads`` keeps to it too). ``executor="serial"`` runs the jobs one after
another in this process (debugging). As with any ``spawn``/``forkserver`` pool, a script that calls
:func:`build_many` needs the ``if __name__ == "__main__":`` guard (the workers import the main module); without
it every job fails with the executor's message. ``workers`` is only for the local pool.

Any ``concurrent.futures.Executor`` works: a Dask cluster (``executor=client.get_executor()``, or
``scheduler="tcp://host:8786"`` / ``--scheduler``, which needs ``pip install tilesynth[dask]``), Ray's, or a
``ThreadPoolExecutor`` (the warnings module is process-wide: with threads, a job's ``warnings`` may hold
another's). The outputs are written by the workers straight into ``output_dir``, so a cluster needs a
shared file system with the same paths; a worker returns the paths and a small record, never arrays. With a
foreign executor the batch cannot know how many jobs share a machine: ``threads`` (``--threads``) then defaults to
``None`` (the kernels use every core of the worker); set it to cores / jobs-per-host on a busy cluster.

Kernel objects (:class:`~tilesynth.SsdIndex`, :class:`~tilesynth.PopulationEvaluator`,
:class:`~tilesynth.WangEvaluator`) pickle by rebuilding from their inputs, so they can be sent to workers too,
but batch jobs do not need that: each job builds its own.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import contextlib
import dataclasses
import datetime
import fnmatch
import glob
import hashlib
import json
import multiprocessing
import os
import re
import shutil
import socket
import sys
import time
import traceback
import uuid
import warnings
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any, TextIO

from ..base.signals import Terminated
from ..errors import ParameterError, TilesynthError
from .batch_materials import params as _material_params  # issue 14: material maps, mask, alpha
from .batch_materials import parse_material_keys as _material_keys
from .batch_materials import split_maps as _split_maps

__all__ = [
    "BatchError",
    "BatchResult",
    "Job",
    "Library",
    "build_many",
    "load_library",
    "parse_library",
    "run_job",
]

FORMAT_VERSION = 1
STAMP_SUFFIX = ".batch.json"
TMP_PREFIX = ".tilesynth-batch-"
DEFAULT_OUTPUT_DIR = "tilesynth-library"
DEFAULT_LOG = "batch-log.jsonl"
DEFAULT_SEED = 1


class BatchError(ParameterError):
    """A batch file (or a job list) that is wrong: raised before any work starts; the message names the job and
    the field."""


# ------------------------------------------------------------------------------------------------ the format
_SCHEMES = ("omega", "wang", "swang")
_ALL = _SCHEMES

# option -> (kind, allowed values or None, schemes using it, the CLI default passed to the builder)
_BUILD_OPTIONS: dict[str, tuple[str, tuple | None, tuple[str, ...], Any]] = {
    "scheme": ("str", _SCHEMES, _ALL, "omega"),
    "set": ("str", None, _ALL, None),
    "tile_size": ("int", None, _ALL, None),
    "seed": ("int", None, _ALL, DEFAULT_SEED),
    "select": (
        "str",
        ("random", "best-of", "ga", "ais"),
        _ALL,
        None,
    ),  # None: the default of `tilesynth build`
    "polish": ("bool", None, _ALL, False),
    "generations": ("int", None, _ALL, None),
    "population": ("int", None, _ALL, None),
    "normalise": ("bool", None, ("omega",), False),
    "match": ("str", ("ssd", "circle", "midpoints", "best-cut"), ("omega",), "ssd"),
    "match_k": ("int|all", None, ("omega",), None),
    "metric": ("str", ("color", "eq2", "eq3"), ("omega",), "color"),
    "smooth": ("bool", None, ("omega",), False),
    "literal_border": ("bool", None, ("omega",), False),
    "gradients": ("str", ("patch", "tile"), ("omega", "swang"), "patch"),
    "cut": ("str", ("dp", "graph"), ("wang",), "dp"),
    "overlap": ("int", None, ("wang",), None),
    "corners": ("str", ("free", "pinned"), ("wang",), None),
    "samples": ("str", ("diamond", "square"), ("wang",), "diamond"),
    "supplementary": ("str", ("ssd", "cut"), ("swang",), "ssd"),
    "border_tries": ("int", None, ("wang", "swang", "omega"), None),
}
_OUTPUT_OPTIONS = ("sheet", "previews", "report", "map_kinds", "export")
_MATERIAL_KEYS = ("mask", "alpha", "normal_y")  # issue 14: tilesynth.cli.batch_materials
_PRESET_KEYS = (*_BUILD_OPTIONS, *_OUTPUT_OPTIONS, *_MATERIAL_KEYS)
_JOB_KEYS = ("exemplar", "name", "preset", "maps", "exclude", *_PRESET_KEYS)
_TOP_KEYS = ("version", "output_dir", "log", "presets", "jobs")
_PREVIEW_KEYS = ("size", "seed", "bits", "maps")
_REPORT_KEYS = ("size", "seed", "borders")
_MAP_KINDS = ("auto", "smooth", "copy")
# the options of tilesynth.engine.export a batch job may set, and `maps` (pass the job's maps or not)
_EXPORT_KEYS = ("bits", "padding", "lookup", "seed", "index_seed", "normal_y", "map_smooth", "viewer", "maps")
_NAME_RE = re.compile(r"^[A-Za-z0-9_.+\-/]+$")


@dataclasses.dataclass(frozen=True)
class Job:
    """One build of a batch, fully resolved: absolute paths, effective options, output paths.

    ``options`` holds every build option with its default resolved (``set``, ``seed``, ...); ``maps`` maps a map
    name to ``(path, kind)``; ``outputs`` maps a role (``tiles``, ``sheet``, ``preview``, ``preview2``,
    ``preview-<map>``, ``report``) to the output path, and ``stamp`` is the up-to-date record beside them.
    """

    index: int
    name: str
    exemplar: Path
    options: dict[str, Any]
    maps: dict[str, tuple[Path, str]]
    sheet: bool
    previews: tuple[dict[str, Any], ...]
    report: dict[str, Any] | None
    outputs: dict[str, Path]
    stamp: Path
    where: str  # "job 3 ('textures/*.png' -> gravel)" for messages
    export: dict[str, Any] | None = None  # the engine export options, None for no export
    # issue 14 (tilesynth.cli.batch_materials): material maps {name: {path, kind, weight}}, mask, alpha, normal_y
    material: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    mask: Path | None = None
    alpha: str | None = None
    normal_y: str | None = None

    def params(self) -> dict[str, Any]:
        """The effective parameters that define the outputs (hashed into the key; no paths, no threads)."""
        out_dir = self.stamp.parent
        return {
            "format_version": FORMAT_VERSION,
            "options": self.options,
            "maps": {k: kind for k, (_, kind) in sorted(self.maps.items())},
            "sheet": self.sheet,
            "previews": list(self.previews),
            "report": self.report,
            "export": self.export,
            "outputs": {k: os.path.relpath(v, out_dir) for k, v in sorted(self.outputs.items())},
            **_material_params(self.material, self.mask, self.alpha, self.normal_y),
        }


@dataclasses.dataclass
class Library:
    """A parsed, validated batch file: its jobs, where they write and where the log goes."""

    source: str
    output_dir: Path
    log: Path
    jobs: list[Job]


def load_library(path: str | os.PathLike[str]) -> Library:
    """Read and validate a batch file (see the module docstring); raises :class:`BatchError` naming the problem."""
    p = Path(path)
    if not p.is_file():
        raise BatchError(f"{p}: no such batch file")
    tomllib = _tomllib()
    try:
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise BatchError(f"{p}: not valid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise BatchError(f"{p}: not valid TOML: {exc}") from None
    except RecursionError:  # the TOML parser recurses once per level of nested arrays / inline tables
        raise BatchError(f"{p}: not a batch file: its values are nested too deeply to read") from None
    depth = _nesting(data)
    if depth > MAX_NESTING:
        raise BatchError(
            f"{p}: not a batch file: a value is nested {depth} levels deep (at most {MAX_NESTING})"
        )
    return parse_library(data, p.resolve().parent, source=str(p))


#: The deepest nesting of tables and arrays a batch file may have (a real one has 3-4: jobs, maps, a map's table).
MAX_NESTING = 16


def _nesting(data: Any) -> int:
    """The depth of nested dicts and lists in ``data`` (iterative: no recursion to run out of), counted up to
    MAX_NESTING + 1."""
    deepest, stack = 0, [(data, 1)]
    while stack:
        value, d = stack.pop()
        deepest = max(deepest, d)
        if d > MAX_NESTING:
            break
        items = value.values() if isinstance(value, dict) else value if isinstance(value, list) else ()
        stack.extend((v, d + 1) for v in items if isinstance(v, (dict, list)))
    return deepest


def _tomllib():  # noqa: ANN202
    if sys.version_info >= (3, 11):
        import tomllib

        return tomllib
    try:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    except ImportError:  # pragma: no cover
        raise BatchError(
            "reading batch files on Python 3.10 needs the 'tomli' package (pip install tomli)"
        ) from None
    return tomllib  # pragma: no cover


def parse_library(
    data: Mapping[str, Any], base_dir: str | os.PathLike[str], source: str = "<batch>"
) -> Library:
    """Validate the content of a batch file (a dict, as ``tomllib`` gives it); paths are relative to ``base_dir``."""
    base = Path(base_dir).resolve()
    if not isinstance(data, Mapping):
        raise BatchError(f"{source}: expected a table at the top level, got {type(data).__name__}")
    _unknown(data, _TOP_KEYS, f"{source}: top level")
    version = data.get("version", FORMAT_VERSION)
    if isinstance(version, bool) or version != FORMAT_VERSION:
        raise BatchError(f"{source}: field 'version' = {version!r}: only version {FORMAT_VERSION} exists")
    out_dir = base / _typed(data.get("output_dir", DEFAULT_OUTPUT_DIR), str, f"{source}: field 'output_dir'")
    log = data.get("log")
    log_path = out_dir / DEFAULT_LOG if log is None else base / _typed(log, str, f"{source}: field 'log'")
    presets_raw = _typed(data.get("presets", {}), dict, f"{source}: field 'presets'")
    presets: dict[str, dict[str, Any]] = {}
    for pname, body in presets_raw.items():
        where = f"{source}: preset {pname!r}"
        body = _typed(body, dict, where)
        _unknown(body, _PRESET_KEYS, where)
        presets[pname] = dict(body)
    jobs_raw = data.get("jobs")
    if jobs_raw is None:
        raise BatchError(f"{source}: no jobs (add [[jobs]] tables with an 'exemplar' each)")
    jobs_raw = _typed(jobs_raw, list, f"{source}: field 'jobs'")
    jobs: list[Job] = []
    globbed: set[int] = set()
    failed: list[tuple[Path, BatchError]] = []
    for k, body in enumerate(jobs_raw, start=1):
        expanded, is_glob, bad = _expand_job(k, body, presets, base, out_dir, source)
        jobs.extend(expanded)
        failed.extend(bad)
        if is_glob:
            globbed.update(id(j) for j in expanded)
    jobs = _without_outputs(jobs, globbed, failed)
    if not jobs:
        raise BatchError(f"{source}: no jobs (add [[jobs]] tables with an 'exemplar' each)")
    _check_collisions(jobs, log_path, source)
    return Library(source, out_dir, log_path, jobs)


def _unknown(table: Mapping[str, Any], known: Iterable[str], where: str) -> None:
    known = tuple(known)
    for key in table:
        if key not in known:
            close = [k for k in known if k.replace("_", "") == key.replace("_", "").replace("-", "")]
            hint = f" (did you mean {close[0]!r}?)" if close else f"; known keys: {', '.join(known)}"
            raise BatchError(f"{where}: unknown field {key!r}{hint}")


_TYPE_NAMES = {str: "a string", dict: "a table", list: "an array", bool: "true or false", int: "an integer"}


def _typed(value: Any, kind: type, where: str) -> Any:
    ok = isinstance(value, kind) and not (kind is int and isinstance(value, bool))
    if not ok:
        raise BatchError(f"{where} = {value!r}: expected {_TYPE_NAMES[kind]}, got {type(value).__name__}")
    return value


def _size(value: Any, where: str) -> list[int]:
    if isinstance(value, str):
        m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", value)
        if m:
            value = [int(m.group(1)), int(m.group(2))]
    if (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
        and min(value) >= 1
    ):
        return [int(value[0]), int(value[1])]
    raise BatchError(
        f'{where} = {value!r}: expected "WIDTHxHEIGHT" or [WIDTH, HEIGHT] with positive integers'
    )


def _check_option(key: str, value: Any, where: str) -> Any:
    kind, allowed, _, _ = _BUILD_OPTIONS[key]
    w = f"{where}: field {key!r}"
    if kind == "bool":
        return _typed(value, bool, w)
    if kind == "int|all":
        if value == "all":
            return value
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise BatchError(f'{w} = {value!r}: expected a positive integer or "all"')
        return value
    if kind == "int":
        _typed(value, int, w)
        if value < (0 if key == "seed" else 1):
            raise BatchError(f"{w} = {value!r}: must be >= {0 if key == 'seed' else 1}")
        if key == "tile_size" and (value < 4 or value % 2):
            raise BatchError(f"{w} = {value!r}: must be even and >= 4 (the tile is cut from a 2x2 block)")
        if key == "seed" and value >= 2**63:
            raise BatchError(f"{w} = {value!r}: must be below 2**63")
        return value
    _typed(value, str, w)
    if allowed is not None and value not in allowed:
        raise BatchError(f"{w} = {value!r}: expected one of {', '.join(allowed)}")
    return value


def _check_set(name: str, scheme: str, where: str) -> None:
    from ..layouts.omega_sets import get_tileset
    from ..layouts.wang_sets import get_wang_tileset, is_wang_set_name

    wang = is_wang_set_name(name)
    if wang != (scheme != "omega"):
        want = (
            "a corner set (4, 8, 16a, ...)" if scheme == "omega" else "an edge-coloured set (wang8, wang18)"
        )
        raise BatchError(f"{where}: field 'set' = {name!r}: scheme {scheme!r} needs {want}")
    try:
        get_wang_tileset(name) if wang else get_tileset(name)
    except (ValueError, KeyError) as exc:
        raise BatchError(f"{where}: field 'set' = {name!r}: {str(exc).strip(chr(39) + chr(34))}") from None


def _effective(
    preset: dict[str, Any], job: dict[str, Any], where: str
) -> tuple[dict[str, Any], dict[str, str]]:
    """Build options with defaults resolved; also which layer set each option (for messages)."""
    merged = {**preset, **job}
    origin = {k: "job" for k in job} | {k: "preset" for k in preset if k not in job}
    given = {k: _check_option(k, merged[k], where) for k in _BUILD_OPTIONS if k in merged}
    scheme = given.get("scheme", "omega")
    for key in given:
        schemes = _BUILD_OPTIONS[key][2]
        if scheme not in schemes:
            raise BatchError(
                f"{where}: field {key!r} (from the {origin[key]}): not used with scheme {scheme!r} "
                f"(only with {' or '.join(schemes)})"
            )
    opts = {k: given.get(k, d) for k, (_, _, schemes, d) in _BUILD_OPTIONS.items() if scheme in schemes}
    from ..schemes import DEFAULT_SETS  # the same default set as `tilesynth build`

    opts["set"] = opts["set"] or DEFAULT_SETS[scheme]
    _check_set(opts["set"], scheme, where)
    if opts["select"] in (None, "random", "best-of") and opts["generations"] is not None:
        raise BatchError(f'{where}: field \'generations\': only used with select = "ga" or "ais"')
    if opts["select"] == "random" and opts["population"] is not None:
        raise BatchError(f"{where}: field 'population': not used with select = \"random\"")
    if scheme == "omega" and opts["match_k"] is not None and opts["match"] != "best-cut":
        raise BatchError(f"{where}: field 'match_k': only used with match = \"best-cut\"")
    if scheme == "omega" and opts["metric"] == "eq2" and opts["select"] not in (None, "random"):
        raise BatchError(
            f"{where}: field 'metric' = \"eq2\": computed by direct sums, not usable with select"
        )
    return opts, origin


def _without_outputs(
    jobs: list[Job], globbed: set[int], failed: list[tuple[Path, BatchError]] = ()
) -> list[Job]:
    """The jobs without those a glob made of another job's output (a sheet, a preview, a file inside a report
    or export folder): a glob over a folder that also receives the outputs (``exemplar = "tex/*.png"``,
    ``output_dir = "tex"``) would otherwise make the second run build the first run's outputs, and collide.
    ``failed``: glob matches whose job could not be made (``(file, error)``): the first that is not an output
    is raised."""
    written = {os.path.normcase(str(p.resolve())) for j in jobs for p in (*j.outputs.values(), j.stamp)}

    def is_output(ex: Path) -> bool:
        ex = ex.resolve()
        return os.path.normcase(str(ex)) in written or any(
            os.path.normcase(str(d)) in written for d in ex.parents
        )

    for ex, exc in failed:
        if not is_output(ex):
            raise exc
    return [j for j in jobs if id(j) not in globbed or not is_output(j.exemplar)]


def _glob_root(base: Path, pattern: str) -> Path:
    """The folder a glob starts from: its leading components without wildcards."""
    parts = Path(pattern).parts
    fixed = []
    for part in parts[:-1]:
        if glob.has_magic(part):
            break
        fixed.append(part)
    return (base.joinpath(*fixed) if fixed else base).resolve()


def _expand_job(
    k: int, body: Any, presets: dict[str, dict[str, Any]], base: Path, out_dir: Path, source: str
) -> tuple[list[Job], bool, list[tuple[Path, BatchError]]]:
    where = f"{source}: job {k}"
    body = _typed(body, dict, where)
    if "exemplar" in body and isinstance(body["exemplar"], str):
        where = f"{source}: job {k} ({body['exemplar']!r})"
    _unknown(body, _JOB_KEYS, where)
    if "exemplar" not in body:
        raise BatchError(
            f"{where}: field 'exemplar' is missing (an image path or a glob, relative to the file)"
        )
    pattern = _typed(body["exemplar"], str, f"{where}: field 'exemplar'")
    preset, where_p = _job_preset(body, presets, where, source)
    own = {k2: v for k2, v in body.items() if k2 in _PRESET_KEYS}
    options, _ = _effective(
        {k2: v for k2, v in preset.items() if k2 in _BUILD_OPTIONS},
        {k2: v for k2, v in own.items() if k2 in _BUILD_OPTIONS},
        where,
    )
    sheet, previews, report, export, kinds = _output_options(preset, own, options, where, where_p)
    maps_raw = _typed(body.get("maps", {}), dict, f"{where}: field 'maps'")
    try:  # issue 14: table entries are material maps
        maps_raw, material_raw = _split_maps(maps_raw, where)
    except ParameterError as exc:
        raise BatchError(str(exc)) from None
    exclude = _typed(body.get("exclude", []), list, f"{where}: field 'exclude'")
    for e in exclude:
        _typed(e, str, f"{where}: field 'exclude' entry")
    name_t = _typed(body.get("name", "{stem}"), str, f"{where}: field 'name'")
    found, is_glob = _exemplars(base, pattern, exclude, name_t, where, out_dir)
    jobs: list[Job] = []
    failed: list[tuple[Path, BatchError]] = []
    for ex in found:
        try:
            job = _job_of(
                k, ex, name_t, where, is_glob, options, preset, own, sheet, previews, report, export,
                maps_raw, material_raw, kinds, base, out_dir,
            )  # fmt: skip
            jobs.append(job)
        except BatchError as exc:
            if not is_glob:
                raise
            failed.append((ex, exc))  # raised unless the file turns out to be an output (_without_outputs)
    return jobs, is_glob, failed


def _job_of(
    k: int,
    ex: Path,
    name_t: str,
    where: str,
    is_glob: bool,
    options: dict[str, Any],
    preset: dict[str, Any],
    own: dict[str, Any],
    sheet: bool,
    previews: list[dict[str, Any]],
    report: dict[str, Any] | None,
    export: dict[str, Any] | None,
    maps_raw: dict[str, Any],
    material_raw: dict[str, Any],
    kinds: dict[str, Any],
    base: Path,
    out_dir: Path,
) -> Job:
    """The job of one exemplar file of a ``[[jobs]]`` table."""
    stem = ex.stem
    try:
        name = name_t.format(stem=stem)
    except (KeyError, IndexError, ValueError, AttributeError) as exc:
        raise BatchError(
            f"{where}: field 'name' = {name_t!r}: bad placeholder ({exc}); only {{stem}} exists"
        ) from None
    wj = f"{where} -> {name!r}" if is_glob else where
    _check_name(name, f"{wj}: field 'name'")
    maps = _job_maps(maps_raw, stem, base, kinds, wj)
    try:
        mat = _material_keys({**preset, **own}, material_raw, kinds, stem, base, wj)
    except ParameterError as exc:
        raise BatchError(str(exc)) from None
    if export is not None and export["maps"] and "albedo" in maps:
        raise BatchError(
            f"{wj}: field 'maps' entry 'albedo': the engine export names the colour atlas 'albedo'; "
            "rename the map (or set export.maps = false)"
        )
    outputs = _outputs(out_dir, name, sheet, previews, report, maps, export, mat["material"])
    _preflight(ex, name, outputs, options, previews, report, export, wj)
    return Job(
        k,
        name,
        ex.resolve(),
        options,
        maps,
        sheet,
        tuple(previews),
        report,
        outputs,
        out_dir / (name + STAMP_SUFFIX),
        wj,
        export,
        **mat,
    )


#: The longest file name (bytes) a job's outputs may have: 255 (NAME_MAX of common file systems) less room for
#: the temporary names the outputs pass through (``.NAME.XXXXXXXX.part``, the job's staging folder).
MAX_OUTPUT_NAME = 200


def _image_shape(path: Path) -> tuple[int, int, int] | None:
    """(height, width, bands) of an image from its header (PIL, no decoding), None when it cannot be read so
    (EXR, .npy, a broken file: the job reports it when it runs)."""
    try:
        from PIL import Image

        with Image.open(path) as im:
            return im.height, im.width, len(im.getbands())
    except Exception:  # noqa: BLE001 - only a pre-check: the loader gives the real message
        return None


def _preflight(
    exemplar: Path,
    name: str,
    outputs: dict[str, Path],
    options: dict[str, Any],
    previews: list[dict[str, Any]],
    report: dict[str, Any] | None,
    export: dict[str, Any] | None,
    where: str,
) -> None:
    """Refuse before any work the values that could only fail a job after its build: an output file name too
    long for the file system, an export padding wider than any tile the job can have, a preview or report
    sample larger than the memory limit."""
    from ..base.validate import MAX_BYTES_ENV, fmt_bytes, memory_limit
    from ..builder.genes.draws import default_tile_size

    for role, path in outputs.items():
        size = len(os.fsencode(path.name))
        if size > MAX_OUTPUT_NAME:
            raise BatchError(
                f"{where}: field 'name' = {name[:40] + '...' if len(name) > 40 else name!r} ({len(name)} characters): "
                f"its {role} output {path.name[:40]!r}... would be a file name of {size} bytes, more than the "
                f"{MAX_OUTPUT_NAME} a job's output may have (file systems take 255, less the temporary names)"
            )
    shape = _image_shape(exemplar)
    if export is not None:
        tile = options.get("tile_size")
        largest = int(tile) if tile is not None else default_tile_size(shape) if shape else None
        if export["padding"] > 256 or (largest is not None and export["padding"] > largest):
            raise BatchError(
                f"{where}: field 'export' entry 'padding' = {export['padding']}: must be at most the tile size "
                f"({largest if largest is not None else 'at most 256'}"
                f"{'' if tile is not None else ', the largest this exemplar gets'}) and at most 256"
            )
    limit = memory_limit(None)
    bands = min(shape[2], 3) if shape else 1
    samples = [(f"'previews' entry {i}", pv["size"], pv["bits"] or 8) for i, pv in enumerate(previews, 1)]
    if report is not None:
        samples.append(("'report'", report["size"], 8))
    for what, (w, h), bits in samples:
        need = int(w) * int(h) * bands * (2 if bits == 16 else 1)
        if need > limit:
            raise BatchError(
                f"{where}: field {what} size = {w}x{h}: the image alone needs {fmt_bytes(need)}, more than the "
                f"limit of {fmt_bytes(limit)} ({MAX_BYTES_ENV}; default half the physical memory)"
            )


def _job_preset(
    body: dict[str, Any], presets: dict[str, dict[str, Any]], where: str, source: str
) -> tuple[dict[str, Any], str]:
    """The preset a job names (empty when none) and where its keys are reported from."""
    preset_name = body.get("preset")
    preset: dict[str, Any] = {}
    if preset_name is not None:
        _typed(preset_name, str, f"{where}: field 'preset'")
        if preset_name not in presets:
            known = ", ".join(presets) or "none defined"
            raise BatchError(f"{where}: field 'preset' = {preset_name!r}: unknown preset (presets: {known})")
        preset = presets[preset_name]
        where_p = f"{source}: preset {preset_name!r}"
    else:
        where_p = where
    return preset, where_p


def _output_options(
    preset: dict[str, Any], own: dict[str, Any], options: dict[str, Any], where: str, where_p: str
) -> tuple[bool, list[dict[str, Any]], dict[str, Any] | None, dict[str, Any] | None, dict[str, Any]]:
    """The output options of a job (its own over its preset's): sheet, previews, report, export, map kinds."""
    out = {**preset, **own}
    w_out = where if any(k2 in own for k2 in _OUTPUT_OPTIONS) else where_p
    sheet = _typed(out.get("sheet", True), bool, f"{w_out}: field 'sheet'")
    previews = _previews(out.get("previews", []), f"{w_out}: field 'previews'")
    report = _report(out.get("report", False), f"{w_out}: field 'report'")
    export = _export(out.get("export", False), f"{w_out}: field 'export'")
    kinds = _typed(out.get("map_kinds", {}), dict, f"{w_out}: field 'map_kinds'")
    for mname, kind in kinds.items():
        if not isinstance(kind, str) or kind not in _MAP_KINDS:
            raise BatchError(
                f"{w_out}: field 'map_kinds' entry {mname!r} = {kind!r}: expected one of "
                f"{', '.join(_MAP_KINDS)}"
            )
        if kind == "smooth" and not options.get("smooth"):
            raise BatchError(
                f"{w_out}: field 'map_kinds' entry {mname!r} = \"smooth\": the tile set is not "
                "smoothed (set smooth = true), there is nothing to follow"
            )
    return sheet, previews, report, export, kinds


def _exemplars(
    base: Path, pattern: str, exclude: list[str], name_t: str, where: str, out_dir: Path | None = None
) -> tuple[list[Path], bool]:
    """The exemplar files of a job (its glob expanded, sorted, without the excluded) and whether it is a glob.

    A glob never reaches into the output folder when that folder lies below where the glob starts
    (``exemplar = "tex/**/*.png"``, ``output_dir = "tex/out"``): its files are this batch's outputs. (When the
    outputs share the exemplars' folder, :func:`_without_outputs` drops the outputs by name.)"""
    is_glob = glob.has_magic(pattern)
    if is_glob:
        found = sorted(Path(p) for p in glob.glob(str(base / pattern), recursive=True) if Path(p).is_file())
        found = [p for p in found if not any(fnmatch.fnmatch(p.name, e) for e in exclude)]
        if out_dir is not None:
            out_r, root = out_dir.resolve(), _glob_root(base, pattern)
            if out_r != root and root in out_r.parents:
                found = [p for p in found if out_r not in p.resolve().parents]
        if not found:
            raise BatchError(f"{where}: field 'exemplar' = {pattern!r}: the glob matches no file (in {base})")
        if "{stem}" not in name_t and len(found) > 1:
            raise BatchError(
                f"{where}: field 'name' = {name_t!r}: the glob matches {len(found)} files; the name "
                "needs {stem} so that each gets its own outputs"
            )
    else:
        if exclude:
            raise BatchError(f"{where}: field 'exclude': only used when 'exemplar' is a glob")
        p = base / pattern
        if not p.is_file():
            raise BatchError(f"{where}: field 'exemplar' = {pattern!r}: {_not_a_file(p)} ({p})")
        found = [p]
    return found, is_glob


def _job_maps(
    maps_raw: dict[str, Any], stem: str, base: Path, kinds: dict[str, Any], wj: str
) -> dict[str, tuple[Path, str]]:
    """The maps of one expanded job, ``{name: (absolute path, kind)}``, ``{stem}`` filled in."""
    maps: dict[str, tuple[Path, str]] = {}
    for mname, mval in maps_raw.items():
        wm = f"{wj}: field 'maps' entry {mname!r}"
        _check_name(mname, wm, slash=False)
        mpath = _typed(mval, str, wm)
        try:
            mpath = mpath.format(stem=stem)
        except (KeyError, IndexError, ValueError, AttributeError) as exc:
            raise BatchError(f"{wm} = {mval!r}: bad placeholder ({exc}); only {{stem}} exists") from None
        mp = (base / mpath).resolve()
        if not mp.is_file():
            raise BatchError(f"{wm} = {mpath!r}: {_not_a_file(mp)} ({mp})")
        maps[mname] = (mp, kinds.get(mname, "auto"))
    return maps


def _not_a_file(p: Path) -> str:
    """What an input path that is not a regular file is (as :func:`tilesynth.io.images.check_input_file`)."""
    if not p.exists():
        return "no such file"
    return (
        "is a directory, expected a file"
        if p.is_dir()
        else "is not a regular file (a FIFO, device or socket)"
    )


def _check_name(name: str, where: str, slash: bool = True) -> None:
    parts = name.split("/")
    ok = (
        bool(_NAME_RE.match(name))
        and (slash or len(parts) == 1)
        and all(p not in ("", ".", "..") for p in parts)
    )
    if not ok or parts[-1].startswith("."):
        what = "letters, digits, '_', '-', '.', '+'" + (" and '/' between non-empty parts" if slash else "")
        raise BatchError(f"{where} = {name!r}: expected a relative name of {what}, not starting with '.'")


def _previews(value: Any, where: str) -> list[dict[str, Any]]:
    if isinstance(value, dict):
        value = [value]
    _typed(value, list, where)
    out = []
    for i, pv in enumerate(value, start=1):
        w = f"{where} entry {i}"
        _typed(pv, dict, w)
        _unknown(pv, _PREVIEW_KEYS, w)
        if "size" not in pv:
            raise BatchError(f"{w}: field 'size' is missing (e.g. size = \"1024x1024\")")
        seed = _typed(pv.get("seed", DEFAULT_SEED), int, f"{w}: field 'seed'")
        if not 0 <= seed < 2**63:
            raise BatchError(f"{w}: field 'seed' = {seed!r}: must be in [0, 2**63)")
        bits = pv.get("bits")
        if bits is not None and (isinstance(bits, bool) or bits not in (8, 16)):
            raise BatchError(f"{w}: field 'bits' = {bits!r}: expected 8 or 16")
        out.append(
            {
                "size": _size(pv["size"], f"{w}: field 'size'"),
                "seed": seed,
                "bits": bits,
                "maps": _typed(pv.get("maps", True), bool, f"{w}: field 'maps'"),
            }
        )
    return out


def _report(value: Any, where: str) -> dict[str, Any] | None:
    from ..measure.metrics import DEFAULT_SAMPLE_SEED, DEFAULT_SAMPLE_SIZE

    if value is False:
        return None
    if value is True:
        value = {}
    _typed(value, dict, where)
    _unknown(value, _REPORT_KEYS, where)
    seed = _typed(value.get("seed", DEFAULT_SAMPLE_SEED), int, f"{where}: field 'seed'")
    if seed < 0:
        raise BatchError(f"{where}: field 'seed' = {seed}: must be >= 0")
    return {
        "size": _size(value.get("size", list(DEFAULT_SAMPLE_SIZE)), f"{where}: field 'size'"),
        "seed": seed,
        "borders": _typed(value.get("borders", True), bool, f"{where}: field 'borders'"),
    }


def _export(value: Any, where: str) -> dict[str, Any] | None:
    """The engine export options of a job (every one resolved to its default), or None for no export."""
    if value is False:
        return None
    if value is True:
        value = {}
    _typed(value, dict, where)
    _unknown(value, _EXPORT_KEYS, where)
    bits = value.get("bits", 8)
    if isinstance(bits, bool) or bits not in (8, 16):
        raise BatchError(f"{where}: field 'bits' = {bits!r}: expected 8 or 16")
    padding = _typed(value.get("padding", 8), int, f"{where}: field 'padding'")
    if not 0 <= padding <= 256:
        raise BatchError(
            f"{where}: field 'padding' = {padding}: must be in [0, 256] and at most the tile size"
        )
    seed = _typed(value.get("seed", 0), int, f"{where}: field 'seed'")
    if not 0 <= seed < 2**32:
        raise BatchError(f"{where}: field 'seed' = {seed}: must be in [0, 2**32)")
    index_seed = _typed(value.get("index_seed", 0), int, f"{where}: field 'index_seed'")
    if not 0 <= index_seed < 2**63:
        raise BatchError(f"{where}: field 'index_seed' = {index_seed}: must be in [0, 2**63)")
    choices = {
        "lookup": ("auto", "hash", "index_map"),
        "normal_y": ("+y", "-y", "up", "down"),  # both spellings, as everywhere (tilesynth.cli.argtypes)
        "map_smooth": ("auto", "on", "off"),
    }
    out: dict[str, Any] = {"bits": bits, "padding": padding, "seed": seed, "index_seed": index_seed}
    for key, allowed in choices.items():
        v = _typed(value.get(key, allowed[0]), str, f"{where}: field {key!r}")
        if v not in allowed:
            raise BatchError(f"{where}: field {key!r} = {v!r}: expected one of {', '.join(allowed)}")
        out[key] = v
    out["viewer"] = _typed(value.get("viewer", False), bool, f"{where}: field 'viewer'")
    out["maps"] = _typed(value.get("maps", True), bool, f"{where}: field 'maps'")
    return out


def _map_suffix(path: Path) -> str:
    """``.npy`` for a float map, ``.png`` otherwise (as ``tilesynth synth --with``), from the header only."""
    try:
        if path.suffix.lower() == ".npy":
            import numpy as np

            arr = np.load(path, mmap_mode="r", allow_pickle=False)
            return ".npy" if arr.dtype == np.float32 else ".png"
        from PIL import Image

        with Image.open(path) as im:
            return ".npy" if im.mode == "F" else ".png"
    except Exception:  # noqa: BLE001 - a broken map fails its job later, with the loader's message
        return ".png"


def _outputs(
    out_dir: Path,
    name: str,
    sheet: bool,
    previews: list[dict[str, Any]],
    report: dict[str, Any] | None,
    maps: dict[str, tuple[Path, str]],
    export: dict[str, Any] | None = None,
    material: dict[str, dict[str, Any]] | None = None,
) -> dict[str, Path]:
    o = {"tiles": out_dir / f"{name}.tiles"}
    if sheet:
        o["sheet"] = out_dir / f"{name}-sheet.png"
    for i, pv in enumerate(previews, start=1):
        role = "preview" if i == 1 else f"preview{i}"
        o[role] = out_dir / f"{name}-{role}.png"
        if pv["maps"]:
            for mname, (mp, _) in maps.items():
                o[f"{role}-{mname}"] = out_dir / f"{name}-{role}-{mname}{_map_suffix(mp)}"
            for mname, m in (material or {}).items():  # issue 14: the material set's stored maps
                suffix = ".exr" if m["path"].suffix.lower() == ".exr" else _map_suffix(m["path"])
                o[f"{role}-{mname}"] = out_dir / f"{name}-{role}-{mname}{suffix}"
    if report is not None:
        o["report"] = out_dir / f"{name}-report"
    if export is not None:
        o["export"] = out_dir / f"{name}-export"
    return o


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
    from ..io.paths import file_identity

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


# ------------------------------------------------------------------------------------------------ keys
def _file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def job_key(job: Job) -> tuple[str, dict[str, Any]]:
    """The up-to-date key of ``job`` and what went into it (input digests, parameter hash, version)."""
    from .._version import __version__

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


# ------------------------------------------------------------------------------------------------ the worker
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
    """Run one job described by ``spec`` (a small dict of paths and options, see :func:`build_many`) and return
    its record. Never raises for a job's own failure: the error is in the record."""
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
    from ..io.images import save_image
    from ..measure.render import contact_sheet

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
    from ..io.images import load_image, load_raster

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
    from ..builder.materials import check_maps
    from .batch_materials import build_keywords

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
    from ..schemes import build

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
    if scheme in ("wang", "swang", "omega") and o["border_tries"] is not None:
        extra["border_tries"] = o["border_tries"]
    from .batch_materials import build_keywords  # issue 14: material maps, mask, alpha

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

    from ..io.images import atomic_open, save_image
    from ..synth.synthesis import check_smoothable, is_smoothed, synthesize, synthesize_map

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
            from .batch_materials import write_previews as material_previews  # issue 14

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
    from ..measure.report import write_report

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
    from ..engine import export

    e = dict(spec["export"])
    # the staged .tiles file: the same bytes and file name as the final one (the manifest records both)
    export(ts, staged["export"], maps=maps if e.pop("maps") else None, source_path=staged["tiles"], **e)


def _commit(spec: dict[str, Any], tmp: Path, stamp: dict[str, Any]) -> None:
    """Move the staged outputs into place, then write the stamp (last: a job without it is built again)."""
    from ..io.images import atomic_open

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


# ------------------------------------------------------------------------------------------------ the driver
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
        """0 when nothing failed, 1 when any job failed (see the module docstring)."""
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
    executor : ``None`` (a local process pool, see the module docstring), ``"serial"`` (this process), or any
        ``concurrent.futures.Executor`` (``client.get_executor()`` of Dask, Ray's, ...). Not shut down here.
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


# ------------------------------------------------------------------------------------------------ command line
def add_parser(sub: Any) -> None:
    """Register ``tilesynth batch`` on the subparsers ``sub`` of the main parser."""
    from ..schemes.base import positive_int_text

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
