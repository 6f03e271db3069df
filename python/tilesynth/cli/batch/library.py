"""Reading a batch file: TOML in, a validated :class:`~tilesynth.cli.batch.schema.Library` out. Every job is
expanded (its glob, ``{stem}``, its preset), its outputs are named, and what would fail it only after its
build is refused up front."""

from __future__ import annotations

import fnmatch
import glob
import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ...errors import ParameterError
from .collisions import _check_collisions
from .materials import parse_material_keys as _material_keys
from .materials import split_maps as _split_maps
from .schema import (
    _BUILD_OPTIONS,
    _JOB_KEYS,
    _MAP_KINDS,
    _OUTPUT_OPTIONS,
    _PRESET_KEYS,
    _TOP_KEYS,
    DEFAULT_LOG,
    DEFAULT_OUTPUT_DIR,
    FORMAT_VERSION,
    STAMP_SUFFIX,
    BatchError,
    Job,
    Library,
    _check_name,
    _effective,
    _export,
    _previews,
    _report,
    _typed,
    _unknown,
)


def load_library(path: str | os.PathLike[str]) -> Library:
    """Read and validate a batch file (see :mod:`tilesynth.cli.batch`); raises :class:`BatchError` naming the
    problem."""
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
    try:  # table entries are material maps
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
    from ...base.validate import MAX_BYTES_ENV, fmt_bytes, memory_limit
    from ...builder.genes.draws import default_tile_size

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
            for mname, m in (material or {}).items():  # the material set's stored maps
                suffix = ".exr" if m["path"].suffix.lower() == ".exr" else _map_suffix(m["path"])
                o[f"{role}-{mname}"] = out_dir / f"{name}-{role}-{mname}{suffix}"
    if report is not None:
        o["report"] = out_dir / f"{name}-report"
    if export is not None:
        o["export"] = out_dir / f"{name}-export"
    return o
