"""The schema of a tile set's ``manifest.json``, and the check of every ``.npy`` member's header against it.

:func:`validate_manifest` checks types, ranges and nesting of every field a reader uses (``info``, ``report``,
``metrics``, ``synth``, ``sheet`` and any later reader all load through :meth:`TileSet.load`, so they apply the
same rules); :func:`check_member_headers` reads only the header of each ``.npy`` member (shape, dtype, order)
and compares it with the manifest and with the other members, *before* any array is allocated: a header that
declares a huge shape, a ``tiles`` array of rank 3 or 5, or a member whose data is shorter or longer than its
header says is refused with :class:`~tilesynth.errors.TileSetFormatError` (exit status 2 in the CLI) naming the
field, never an internal error.

Why a small declarative validator and not the ``jsonschema`` library: ``jsonschema`` would be a runtime
dependency of every install (with ``referencing``, ``rpds-py`` — a compiled extension — ``attrs`` and
``jsonschema-specifications``) for one ~100-line schema; its messages name a JSON pointer but not in the
``manifest.json field params.selection.history.best[3]`` form the rest of tilesynth uses; and it has no notion of
"a float that Python can convert without overflow" or "an integer that fits the arrays". The classes below are
the subset of JSON Schema that the manifest needs (objects with required and optional keys, typed lists,
enumerations, bounded numbers), and the schema is data (:data:`MANIFEST`), so it is read like one.

Unknown keys are allowed where the format allows extension (``params`` holds scheme-specific keys; future
versions may add fields without bumping ``format_version``), and refused nowhere; every *known* key must have
its documented type wherever it appears.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import IO, Any

import numpy as np

from ..errors import TileSetFormatError

#: Integers in the manifest must fit an int64 (shapes, seeds, offsets, counts).
INT_MAX = (1 << 63) - 1
#: Floats must convert to a finite Python float (a JSON integer of 400 digits does not).
FLOAT_MAX = 1.7976931348623157e308


class Schema:
    """A node of the schema: ``check(value, where)`` raises :class:`TileSetFormatError` or returns."""

    def describe(self) -> str:
        raise NotImplementedError

    def check(self, value: Any, where: str) -> None:
        raise NotImplementedError


def _fail(where: str, value: Any, expected: str) -> None:
    shown = repr(value)
    if len(shown) > 60:
        shown = shown[:57] + "..."
    raise TileSetFormatError(f"manifest.json field {where} = {shown}: expected {expected}")


@dataclass(frozen=True)
class Int(Schema):
    lo: int = -INT_MAX
    hi: int = INT_MAX

    def describe(self) -> str:
        return f"an integer in [{self.lo}, {self.hi}]"

    def check(self, value: Any, where: str) -> None:
        if type(value) is not int or not self.lo <= value <= self.hi:
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Num(Schema):
    """A finite number (int or float) in [lo, hi]; ``nan_ok`` also accepts NaN (written for "no value")."""

    lo: float = -FLOAT_MAX
    hi: float = FLOAT_MAX
    nan_ok: bool = False

    def describe(self) -> str:
        return f"a finite number in [{self.lo:g}, {self.hi:g}]" + (" or NaN" if self.nan_ok else "")

    def check(self, value: Any, where: str) -> None:
        if type(value) not in (int, float) or (type(value) is int and abs(value) > INT_MAX):
            # integers must fit an int64 even where a float is meant (numpy refuses larger Python ints)
            _fail(where, value, self.describe())
        try:
            f = float(value)
        except OverflowError:
            _fail(where, value, self.describe())
        if math.isnan(f) and self.nan_ok:
            return
        if not math.isfinite(f) or not self.lo <= f <= self.hi:
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Str(Schema):
    enum: tuple[str, ...] | None = None
    max_len: int = 4096

    def describe(self) -> str:
        return f"one of {', '.join(map(repr, self.enum))}" if self.enum else "a string"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, str) or len(value) > self.max_len or (self.enum and value not in self.enum):
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Bool(Schema):
    def describe(self) -> str:
        return "true or false"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, bool):
            _fail(where, value, self.describe())


@dataclass(frozen=True)
class Null(Schema):
    def describe(self) -> str:
        return "null"

    def check(self, value: Any, where: str) -> None:
        if value is not None:
            _fail(where, value, "null")


@dataclass(frozen=True)
class AnyOf(Schema):
    options: tuple[Schema, ...]

    def describe(self) -> str:
        return " or ".join(o.describe() for o in self.options)

    def check(self, value: Any, where: str) -> None:
        errors = []
        for o in self.options:
            try:
                o.check(value, where)
                return
            except TileSetFormatError as exc:
                errors.append((o, exc))
        # an object or a list of the right kind but wrong content: the inner message names the inner field
        for o, exc in errors:
            if (isinstance(o, (Obj, Map)) and isinstance(value, dict)) or (
                isinstance(o, List) and isinstance(value, list)
            ):
                raise exc
        _fail(where, value, self.describe())


def Optional(s: Schema) -> Schema:
    return AnyOf((Null(), s))


@dataclass(frozen=True)
class List(Schema):
    item: Schema
    min_len: int = 0
    max_len: int = 1 << 24
    length: int | None = None

    def describe(self) -> str:
        n = f"of {self.length} " if self.length is not None else ""
        return f"a list {n}of {self.item.describe()}"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, list):
            _fail(where, value, self.describe())
        if self.length is not None and len(value) != self.length:
            _fail(where, value, self.describe())
        if not self.min_len <= len(value) <= self.max_len:
            _fail(where, value, f"{self.describe()} with {self.min_len} to {self.max_len} items")
        for k, v in enumerate(value):
            self.item.check(v, f"{where}[{k}]")


@dataclass(frozen=True)
class Obj(Schema):
    """An object; ``required`` and ``optional`` map keys to schemas; other keys: ``extra`` (None = any value)."""

    required: Mapping[str, Schema] = field(default_factory=dict)
    optional: Mapping[str, Schema] = field(default_factory=dict)
    extra: Schema | None = None

    def describe(self) -> str:
        return "an object"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, dict):
            _fail(where, value, "an object")
        for k, s in self.required.items():
            if k not in value:
                raise TileSetFormatError(f"manifest.json field {where}.{k}: missing")
            s.check(value[k], f"{where}.{k}")
        for k, s in self.optional.items():
            if k in value:
                s.check(value[k], f"{where}.{k}")
        if self.extra is not None:
            for k, v in value.items():
                if k not in self.required and k not in self.optional:
                    self.extra.check(v, f"{where}.{k}")


@dataclass(frozen=True)
class Map(Schema):
    """An object whose keys are free and whose values all follow ``value``."""

    value: Schema

    def describe(self) -> str:
        return f"an object of {self.value.describe()}"

    def check(self, value: Any, where: str) -> None:
        if not isinstance(value, dict):
            _fail(where, value, self.describe())
        for k, v in value.items():
            self.value.check(v, f"{where}.{k}")


# ----------------------------------------------------------------------------------------------- the schema
SCHEME_LAYOUTS = {"omega": "corner", "wang": "wang", "swang": "wang", "patch": "corner"}
"""The layout kind (in the file's spelling) of each registered scheme: the registry's names and layouts
(:data:`tilesynth.schemes.REGISTRY`), written out here because the registry imports the builders, which import
this module (tests/test_manifest.py keeps the two equal)."""
SCHEMES = tuple(SCHEME_LAYOUTS)
_NUM = Num()
_COUNT = Int(0, INT_MAX)
_POS = Int(1, INT_MAX)
_PAIR = List(Int(), length=2)

_HISTORY = Obj(optional={"best": List(Num(nan_ok=True)), "mean": List(Num(nan_ok=True))})
_POLISH = Obj(
    optional={
        "E_before": Num(nan_ok=True),
        "moves": _COUNT,
        "sweeps": _COUNT,
        "evaluations": _COUNT,
        "converged": Bool(),
        "min_distance": _COUNT,
    }
)

#: params.selection.cut: the re-ranking by the cut score and the cut polish (tilesynth.builder.genes.cut_objective).
_CUT_RERANK = Obj(
    optional={
        "score": Optional(Num(0.0)),
        "eps": Num(0.0),
        "rerank": _POS,
        "chosen": _COUNT,
        "scores": List(Optional(Num(0.0))),
        "polish": Optional(
            Obj(
                optional={
                    "score_before": Optional(Num(0.0)),
                    "sweeps": _COUNT,
                    "moves": _COUNT,
                    "builds": _COUNT,
                    "candidates": _COUNT,
                    "converged": Bool(),
                }
            )
        ),
    }
)

#: params.selection.visible: the re-ranking by the visible measures on a proxy synthesis (tilesynth.builder.genes.visible_objective).
_VISIBLE_RERANK = Obj(
    optional={
        "rerank": _POS,
        "chosen": _COUNT,
        "proxy_side": _POS,
        "proxy_seed": _COUNT,
        "cut_seam": List(Optional(Num(0.0))),
        "coherence": List(Optional(Num(0.0))),
        "texstats": List(Optional(Num(0.0))),
    }
)

#: params.selection.window: the window choice of the complete sets (tilesynth.builder.genes.window_objective).
_WINDOW_CHOICE = Obj(
    optional={
        "count": _POS,
        "chosen": _COUNT,
        "cells": _POS,
        "window_tiles": _POS,
        "proxy_seed": _COUNT,
        "cut_seam": List(Optional(Num(0.0))),
        "coherence": List(Optional(Num(0.0))),
        "texstats": List(Optional(Num(0.0))),
    }
)

#: params.selection: the method, its parameters (numbers and flags) and its result.
SELECTION = Obj(
    optional={
        "method": Str(),
        "params": Obj(
            optional={
                "polish": Bool(),
                "population": _POS,
                "generations": _POS,
                "stagnation": Optional(_COUNT),
            },
            extra=AnyOf((Num(), Bool(), Str(), Null())),
        ),
        "evaluations": _COUNT,
        "generations": _COUNT,
        "stop_reason": Str(),
        "objective_E": Num(nan_ok=True),
        "objective_D": List(Num(nan_ok=True)),
        "normalise": Bool(),
        "history": Optional(_HISTORY),
        "polish": Optional(_POLISH),
        # the border-aware random draws of the Wang schemes (issue 14, tilesynth.builder.genes.wang_borders)
        "border_tries": _POS,
        "border_seam_first": Num(nan_ok=True),
        "border_seam_predicted": Num(nan_ok=True),
        # issue 15: the objective and the cut re-ranking (tilesynth.builder.genes.cut_objective)
        "objective": Str(("visible", "cut", "sum-d", "E", "window")),
        "cut": Optional(_CUT_RERANK),
        "visible": Optional(_VISIBLE_RERANK),
        "window": Optional(_WINDOW_CHOICE),
        "border_criterion": Str(
            ("cap", "log", "min", "stats")
        ),  # ω and patch (tilesynth.builder.genes.omega_borders)
        # issue 12: the "stats" criterion's distance and the periodic-exemplar rule (tilesynth.builder.periodic)
        "sample_stats_predicted": Num(nan_ok=True),
        "sample_colour_predicted": Num(nan_ok=True),
        "vertex_saliency_predicted": Num(nan_ok=True),
        "vertex_moves": _COUNT,
        "periodic": Obj(
            required={
                "tile_size": _POS,
                "shift_correlation": Num(nan_ok=True),
                "mode": Str(("auto", "lock")),
            }
        ),
    },
)

#: params.smooth of an omega set built with --smooth (statistics of the Poisson solve).
SMOOTH = Obj(
    optional={
        "unknowns": _COUNT,
        "iterations_max": _COUNT,
        "residual_max": Num(nan_ok=True),
        "tol": Num(0.0),
        "clipped": _COUNT,
    },
)

#: One map of a material build (issue 14, :mod:`tilesynth.builder.materials`): the top-level ``maps`` entries.
MAP = Obj(
    required={
        "name": Str(max_len=64),
        "kind": Str(("colour", "scalar", "normal", "label")),
        "weight": Num(0.0),
        "dtype": Str(("uint8", "uint16", "float32")),
        "channels": Int(1, 4),
    },
    optional={
        "suffix": Str(
            (".png", ".exr", ".npy", ".tif", ".tiff")
        ),  # makes output file names: the suffixes check_maps writes
        "normal_y": Optional(Str(("up", "down"))),
        "encoding": Optional(Str(("unorm", "snorm"))),
    },
)
#: params.material: the feature image a material set was built on.
MATERIAL = Obj(
    optional={
        "feature_channels": Int(1, 4),
        "variance_kept": Num(0.0, 1.0),
        "feature_scale": Num(0.0),
        "albedo_weight": Num(0.0),
        "joint": Bool(),
        "units": Str(),
    }
)
#: params.quality: the cheap visible measures stored at build time (issue 15, :mod:`tilesynth.measure.quality`);
#: null where a value is not finite (a cut score of a non-finite cost) or does not exist (no cut seam).
QUALITY = Obj(
    optional={
        "cut_score": Optional(Num(0.0)),
        "cut_score_eps": Num(0.0),
        "cut_seam": Optional(Num(0.0)),
        "tile_coverage": Num(0.0, 1.0),
    },
)

PARAMS = Obj(
    optional={
        "set": Str(),
        "seed": Optional(Int(0, (1 << 64) - 1)),
        "tile_size": _POS,
        "lambda": Num(0.0, 1.0),
        "omega": Num(0.0, 1.0),
        "eps": Num(),
        "selection": SELECTION,
        "smooth": AnyOf((Bool(), Null(), SMOOTH)),
        "match": Str(("ssd", "circle", "midpoints", "best-cut")),
        "match_k": AnyOf((Null(), _POS, Str(("all",)))),
        "metric": Str(("color", "eq2", "eq3")),
        "mu": Optional(Num()),
        "second_match_exclude_radius": Optional(_COUNT),
        "candidates": Optional(_POS),
        "keep_border": Bool(),
        "gradients": Str(("patch", "tile")),
        "cut": Str(("dp", "graph")),
        "overlap": Optional(_POS),
        "corners": Optional(Str(("free", "pinned"))),
        "samples": Str(("diamond", "square")),
        "supplementary": Str(("ssd", "cut")),
        "sample_size": Optional(_POS),
        "threads": Optional(_POS),
        # the levers of the complete sets (issue 12, tilesynth.builder.matching.levers)
        "cut_region": Str(("circle", "free", "free8", "ring")),
        "cut_bias": Num(0.0),
        "diversity": _POS,
        "augment": Str(("none", "flip", "rotate", "all")),  # issue 12: tilesynth.builder.matching.augment
        "match_transforms": List(Int(0, 7)),
        "border_tries": _POS,  # the Wang schemes (issue 14)
        "material": MATERIAL,  # issue 14
        # issue 14: the exemplar's mask and the input warnings of the build (tilesynth.builder.masking, .diagnose)
        "mask": Obj(
            optional={
                "source": Str(),
                "file": Str(),
                "sha256": Str(max_len=64),
                "masked_fraction": Num(0.0, 1.0),
                "masked_pixels": _COUNT,
                "largest_valid_window": _COUNT,
                "threshold": Num(0.0, 1.0),
            }
        ),
        "warnings": List(
            Obj(optional={"code": Str(max_len=64), "message": Str(), "value": Num(), "threshold": Num()})
        ),
        # the cheap visible measures of the build (issue 15, tilesynth.measure.quality.build_measures)
        "quality": QUALITY,
    },
)

EXEMPLAR = Obj(
    required={"shape": List(Int(1, 1 << 20), length=3)},
    optional={"file": Optional(Str()), "bits": Int(8, 16), "sha256": Str()},
)

_TILE = AnyOf((Str(), List(AnyOf((Str(), Num(), Bool(), Null()))), Obj(), Num(), Bool(), Null()))
"""A tile of the layout: its form is the tile-set definition's business (checked by ``tileset_from_dict``)."""
LAYOUT = Obj(
    required={"tiles": List(_TILE, min_len=1)},
    optional={
        "kind": Str(("corner", "wang")),
        "name": Str(),
        "colours": List(Str(max_len=64)),
        "horizontal": List(Str(max_len=64)),
        "vertical": List(Str(max_len=64)),
        "variants": List(_COUNT),
    },
)

ARRAYS = Map(Obj(required={"dtype": Str(), "shape": List(_COUNT, max_len=8)}))

#: The whole manifest.json.
MANIFEST = Obj(
    required={
        "format": Str(),
        "format_version": Int(),
        "tilesynth_version": Str(),
        "scheme": Str(SCHEMES),
        "layout": LAYOUT,
        "params": PARAMS,
        "E": Num(),
        "exemplar": EXEMPLAR,
    },
    optional={
        "per_tile": List(Obj()),
        "arrays": ARRAYS,
        "maps": List(MAP, max_len=64),  # issue 14: material maps
        "storage": Obj(  # format version 2: how the tiles are stored (tilesynth.tileset.provenance)
            required={"kind": Str(("provenance",)), "exemplar_dtype": Str(("float32", "uint8", "uint16"))},
        ),
    },
)


TOP_LEVEL_KINDS: dict[str, type | tuple[type, ...]] = {
    "scheme": str,
    "layout": dict,
    "params": dict,
    "exemplar": dict,
    "tilesynth_version": str,
    "E": (int, float),
}
"""The kind of every top-level field a reader needs."""


def check_top_level(m: Mapping[str, Any]) -> None:
    """Each field of :data:`TOP_LEVEL_KINDS` present, of its kind (no bool for a number), and ``E`` finite."""
    for key, t in TOP_LEVEL_KINDS.items():
        if key not in m:
            raise TileSetFormatError(f"manifest.json lacks {key!r}")
        if not isinstance(m[key], t) or isinstance(m[key], bool):
            raise TileSetFormatError(f"manifest.json field {key!r} = {m[key]!r:.60}: wrong type")
    if isinstance(m["E"], float) and not math.isfinite(m["E"]):
        raise TileSetFormatError(f"manifest.json field 'E' = {m['E']!r}: must be finite")


def validate_manifest(m: Any) -> None:
    """Check ``m`` (the parsed ``manifest.json``) against :data:`MANIFEST` and the scheme/layout pairing;
    raises :class:`TileSetFormatError` naming the first bad field."""
    if not isinstance(m, dict):
        raise TileSetFormatError(
            f"not a tilesynth tile set (manifest.json is a {type(m).__name__}, not an object)"
        )
    if not _is_known(m):
        return  # not a tile set of this version: the loader's magic and version check says so
    check_top_level(m)  # the top-level kinds first, in the loader's established wording
    for k, s in MANIFEST.required.items():
        if k not in m:
            raise TileSetFormatError(f"manifest.json lacks {k!r}")
        s.check(m[k], k)
    for k, s in MANIFEST.optional.items():
        if k in m:
            s.check(m[k], k)
    kind = m["layout"].get("kind", "corner")
    want = SCHEME_LAYOUTS[m["scheme"]]
    if kind != want:
        raise TileSetFormatError(
            f"layout is not a tile-set definition for scheme {m['scheme']!r} (manifest.json field layout.kind = "
            f"{kind!r}, expected {want!r})"
        )


def _is_known(m: Mapping[str, Any]) -> bool:
    """A tile-set manifest of a version this reader knows (1: pixels, 2: provenance)."""
    return (
        m.get("format") == "tilesynth-tileset"
        and type(m.get("format_version")) is int
        and m["format_version"] in (1, 2)
    )


# ------------------------------------------------------------------------------------------ member headers
def read_npy_header(fh: IO[bytes], name: str) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """``(shape, fortran_order, dtype, header length)`` of an ``.npy`` stream, reading only its header."""
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh, max_header_size=1 << 16)
        elif version in ((2, 0), (3, 0)):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh, max_header_size=1 << 16)
        else:
            raise ValueError(f"unknown .npy version {version}")
    except (ValueError, SyntaxError, TypeError, OverflowError, EOFError) as exc:
        raise TileSetFormatError(f"member {name}.npy: not a .npy array ({exc})") from None
    return tuple(shape), bool(fortran), np.dtype(dtype), fh.tell()


def check_member_headers(
    headers: Mapping[str, tuple[tuple[int, ...], np.dtype, int, int]],
    dtypes: Mapping[str, str],
    manifest: Mapping[str, Any],
) -> None:
    """Compare each member's header with its expected dtype, with the other members and with the manifest.

    ``headers`` maps a member name to ``(shape, dtype, header length, unpacked member size)``. Raises
    :class:`TileSetFormatError` naming the member before anything is allocated: the data a header declares
    must be exactly what the member holds, so a header cannot make the loader allocate more than the file
    (itself bounded by ``MAX_UNPACKED_BYTES``) contains.
    """
    for name, (shape, dtype, hlen, size) in headers.items():
        want = np.dtype(dtypes[name])
        if dtype.hasobject:
            raise TileSetFormatError(
                f"not a tilesynth tile set (member {name}.npy is a pickled object array; refused, allow_pickle=False)"
            )
        if dtype != want:
            raise TileSetFormatError(f"array {name} must be {want}, got {dtype}")
        n_items = 1
        for d in shape:
            n_items *= d
        if n_items * want.itemsize != size - hlen:
            raise TileSetFormatError(
                f"not a tilesynth tile set (member {name}.npy: header declares shape {shape} "
                f"({n_items * want.itemsize} bytes) but the member holds {size - hlen} bytes of data)"
            )
    ranks = {
        "tiles": 4,
        "source": 4,
        "cut_masks": 3,
        "genes": 2,
        "tile_patches": 2,
        "match_offsets": 2,
        "D": 1,
        "cut_costs": 1,
        "exemplar": 3,
        "labels": 3,
        "cut_stats": 3,
        "prov_labels": 3,
        "prov_table": 3,
        "cut_masks_packed": 3,
    }
    for name, (shape, *_rest) in headers.items():
        if name in ranks and len(shape) != ranks[name]:
            raise TileSetFormatError(
                f"array {name} has shape {shape} (rank {len(shape)}), expected rank {ranks[name]}"
            )
    if "tiles" in headers:  # the other members follow from the tiles (K, N, N, C), as TileSet._check says
        k, n, _, _ = headers["tiles"][0]
        expect = {
            "source": (k, n, n, 2),
            "cut_masks": (k, n, n),
            "tile_patches": (k, 4),
            "match_offsets": (k, 2),
            "D": (k,),
            "cut_costs": (k,),
            "labels": (k, n, n),
            "cut_stats": (k, 4, 6),
        }
        for name, shape in expect.items():
            if name in headers and headers[name][0] != shape:
                raise TileSetFormatError(f"array {name} has shape {headers[name][0]}, expected {shape}")
    if "prov_labels" in headers:  # format version 2: the members follow from the labels (K, N, N)
        k, n, _ = headers["prov_labels"][0]
        expect = {
            "cut_masks_packed": (k, n, -(-n // 8)),
            "tile_patches": (k, 4),
            "match_offsets": (k, 2),
            "D": (k,),
            "cut_costs": (k,),
            "labels": (k, n, n),
            "cut_stats": (k, 4, 6),
        }
        for name, shape in expect.items():
            if name in headers and headers[name][0] != shape:
                raise TileSetFormatError(f"array {name} has shape {headers[name][0]}, expected {shape}")
        table = headers.get("prov_table")
        if table is not None and (table[0][0] != k or table[0][2] != 3):
            raise TileSetFormatError(f"array prov_table has shape {table[0]}, expected ({k}, L, 3)")
        if k != len(manifest["layout"]["tiles"]):
            raise TileSetFormatError(
                f"member prov_labels.npy: {k} tiles, but manifest.json field layout.tiles lists "
                f"{len(manifest['layout']['tiles'])}"
            )
    declared = manifest.get("arrays")
    if isinstance(declared, dict):
        for name, (shape, *_rest) in headers.items():
            d = declared.get(name)
            if d is not None and d["dtype"] != dtypes[name]:
                raise TileSetFormatError(
                    f"manifest.json field arrays.{name}.dtype = {d['dtype']!r:.40}: expected {dtypes[name]!r}"
                )
            if d is not None and tuple(d["shape"]) != shape:
                raise TileSetFormatError(
                    f"member {name}.npy: shape {shape} disagrees with manifest.json field arrays.{name}.shape = "
                    f"{d['shape']}"
                )
    ex_shape = tuple(manifest["exemplar"]["shape"])
    if "exemplar" in headers and headers["exemplar"][0] != ex_shape:
        raise TileSetFormatError(
            f"member exemplar.npy: shape {headers['exemplar'][0]} disagrees with manifest.json field "
            f"exemplar.shape = {list(ex_shape)}"
        )
    n_layout = len(manifest["layout"]["tiles"])
    if "tiles" in headers and headers["tiles"][0][0] != n_layout:
        raise TileSetFormatError(
            f"member tiles.npy: {headers['tiles'][0][0]} tiles, but manifest.json field layout.tiles lists "
            f"{n_layout}"
        )


def check_archive(zf: Any, manifest: Any, dtypes: Mapping[str, str]) -> None:
    """The one call of :meth:`TileSet.load`: validate ``manifest`` (:func:`validate_manifest`), then read the
    header of every member of ``dtypes`` present in the open ZIP ``zf`` and check them
    (:func:`check_member_headers`), before any array is read."""
    validate_manifest(manifest)
    if not _is_known(manifest):
        return
    headers = {}
    names = set(zf.namelist())
    for name in dtypes:
        member = f"{name}.npy"
        if member not in names:
            continue
        info = zf.getinfo(member)
        with zf.open(member) as fh:
            shape, _fortran, dtype, hlen = read_npy_header(fh, name)
        headers[name] = (shape, dtype, hlen, info.file_size)
    check_member_headers(headers, dtypes, manifest)


__all__ = [
    "MANIFEST",
    "TOP_LEVEL_KINDS",
    "check_archive",
    "check_top_level",
    "check_member_headers",
    "read_npy_header",
    "validate_manifest",
]
