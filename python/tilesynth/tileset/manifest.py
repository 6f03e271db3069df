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

The schema nodes are in :mod:`tilesynth.tileset.validator`, the ``.npy`` header checks in
:mod:`tilesynth.tileset.npy_headers`; both are re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..errors import TileSetFormatError
from .npy_headers import (  # noqa: F401 - re-exported: tilesynth.tileset.manifest.<name> stays the import path
    check_member_headers,
    read_npy_header,
)
from .validator import (  # noqa: F401 - re-exported: tilesynth.tileset.manifest.<name> stays the import path
    FLOAT_MAX,
    INT_MAX,
    AnyOf,
    Bool,
    Int,
    List,
    Map,
    Null,
    Num,
    Obj,
    Optional,
    Schema,
    Str,
    _fail,
)

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
        # the border-aware random draws of the Wang schemes (tilesynth.builder.genes.wang_borders)
        "border_tries": _POS,
        "border_seam_first": Num(nan_ok=True),
        "border_seam_predicted": Num(nan_ok=True),
        # the objective and the cut re-ranking (tilesynth.builder.genes.cut_objective)
        "objective": Str(("visible", "cut", "sum-d", "E", "window")),
        "cut": Optional(_CUT_RERANK),
        "visible": Optional(_VISIBLE_RERANK),
        "window": Optional(_WINDOW_CHOICE),
        "border_criterion": Str(
            ("cap", "log", "min", "stats")
        ),  # ω and patch (tilesynth.builder.genes.omega_borders)
        # the "stats" criterion's distance and the periodic-exemplar rule (tilesynth.builder.periodic)
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

#: One map of a material build (:mod:`tilesynth.builder.materials`): the top-level ``maps`` entries.
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
#: params.quality: the cheap visible measures stored at build time (:mod:`tilesynth.measure.quality`);
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
        # the levers of the complete sets (tilesynth.builder.matching.levers)
        "cut_region": Str(("circle", "free", "free8", "ring")),
        "cut_bias": Num(0.0),
        "diversity": _POS,
        "augment": Str(("none", "flip", "rotate", "all")),  # tilesynth.builder.matching.augment
        "match_transforms": List(Int(0, 7)),
        "border_tries": _POS,  # the Wang schemes
        "material": MATERIAL,  # a material build
        # the exemplar's mask and the input warnings of the build (tilesynth.builder.masking, .diagnose)
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
        # the cheap visible measures of the build (tilesynth.measure.quality.build_measures)
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
        "maps": List(MAP, max_len=64),  # the maps of a material build
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
