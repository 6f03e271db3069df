"""The keys of a batch file and the checks of their values, and what a valid file becomes: a :class:`Library`
of :class:`Job` (the format is documented in :mod:`tilesynth.cli.batch`)."""

from __future__ import annotations

import dataclasses
import os
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from ...builder.recipe import NAMED_RECIPES, NAMED_SETS
from ...errors import ParameterError
from .materials import params as _material_params  # material maps, mask, alpha

FORMAT_VERSION = 1


STAMP_SUFFIX = ".batch.json"


TMP_PREFIX = ".tilesynth-batch-"


DEFAULT_OUTPUT_DIR = "tilesynth-library"


DEFAULT_LOG = "batch-log.jsonl"


DEFAULT_SEED = 1


class BatchError(ParameterError):
    """A batch file (or a job list) that is wrong: raised before any work starts; the message names the job and
    the field."""


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
    "recipe": ("str", tuple(NAMED_RECIPES), ("omega",), None),
}


_OUTPUT_OPTIONS = ("sheet", "previews", "report", "map_kinds", "export")


_MATERIAL_KEYS = ("mask", "alpha", "normal_y")  # checked by tilesynth.cli.batch.materials


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
    # material builds (tilesynth.cli.batch.materials): material maps {name: {path, kind, weight}}, mask, alpha, normal_y
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
    from ...layouts.omega_sets import get_tileset
    from ...layouts.wang_sets import get_wang_tileset, is_wang_set_name

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
    from ...schemes import DEFAULT_SETS  # the same default set as `tilesynth build`

    # as `tilesynth build`: without a set, the named recipe's (recipe = "fast": c4), else the scheme's default
    opts["set"] = opts["set"] or NAMED_SETS.get(opts.get("recipe"), DEFAULT_SETS[scheme])
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
    from ...measure.metrics import DEFAULT_SAMPLE_SEED, DEFAULT_SAMPLE_SIZE

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
