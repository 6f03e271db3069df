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
``population``, ``seed``; ω only: ``recipe`` (default | fast | objects, as ``tilesynth build --recipe``), ``normalise``, ``match`` (ssd | circle | midpoints | best-cut), ``match_k`` (int
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

Material builds and masks (:mod:`tilesynth.cli.batch.materials`): a ``maps`` entry given as a table
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

from .command import add_parser, cli_main  # noqa: F401 - the command, registered by tilesynth.cli.main
from .driver import BatchResult, build_many
from .keys import job_key  # noqa: F401 - re-exported
from .library import MAX_NESTING, MAX_OUTPUT_NAME, load_library, parse_library  # noqa: F401 - re-exported
from .schema import (  # noqa: F401 - the format's constants re-exported
    DEFAULT_LOG,
    DEFAULT_OUTPUT_DIR,
    DEFAULT_SEED,
    FORMAT_VERSION,
    STAMP_SUFFIX,
    TMP_PREFIX,
    BatchError,
    Job,
    Library,
)
from .worker import FOREIGN_TMP_AGE, check_inputs, run_job  # noqa: F401 - re-exported

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
