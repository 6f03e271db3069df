"""Export version 1: the tiles as padded atlases with mips to the gutter's reach, for every map (the sets that are
not pure copies, and ``format="atlas"``); the manifest of version 1."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..cli.argtypes import normal_y_value
from ..errors import ParameterError
from . import atlas as _atlas
from .format import EXPORT_FORMAT, EXPORT_VERSION, _map_array, _version
from .output import _write_level, _write_text, shader_entry, source_entry
from .sources import SHADER_FILES, shader_source


def build_maps(
    tileset: Any,
    maps: dict[str, Any] | None,
    padding: int,
    bits: int,
    map_smooth: str = "auto",
    normal_y: str = "+y",
) -> dict[str, dict[str, Any]]:
    """Level-0 padded cells of every map: ``{name: {"cells": (K, S, S, C), "source": "tileset"|"map"}}``."""
    from ..builder.materials import turn_with_tiles
    from ..synth.synthesis import _smooth_map_atlas, is_smoothed

    out: dict[str, dict[str, Any]] = {}
    src = tileset.source
    cells = _atlas.padded_tiles(tileset.tiles, tileset.exemplar, src, padding)
    out["albedo"] = {"cells": _atlas.quantise(cells, bits), "kind": "tileset"}
    out.update(_stored_maps(tileset, padding, map_smooth, normal_y))  # a material set's own maps
    for name, value in (maps or {}).items():
        if name in out and name != "albedo":
            raise ParameterError(
                f"map name {name!r}: the tile set stores a map of that name; give another name"
            )
        if not isinstance(name, str) or not name or not all(ch.isalnum() or ch in "-_" for ch in name):
            raise ParameterError(f"map name {name!r}: letters, digits, '-' and '_' only")
        if name == "albedo":
            raise ParameterError(
                "map name 'albedo' is the tile set's own colour; give the extra map another name"
            )
        a = _map_array(name, value, tileset.exemplar.shape[:2])
        tiles = np.ascontiguousarray(a[src[..., 0], src[..., 1]])
        smooth = {"auto": is_smoothed(tileset), "on": True, "off": False}[map_smooth]
        if smooth:
            if not is_smoothed(tileset):
                raise ParameterError("map_smooth = 'on': the tile set was not Poisson-smoothed")
            tiles = _smooth_map_atlas(tileset, a, tiles, None)
        tiles = turn_with_tiles(tileset, name, a, tiles)  # a normal map's vectors turn with their patches
        out[name] = {"cells": _atlas.padded_tiles(tiles, a, src, padding), "kind": "map"}
    return out


def _stored_maps(tileset: Any, padding: int, map_smooth: str, normal_y: str) -> dict[str, dict[str, Any]]:
    """The padded cells of the maps a material tile set stores (:mod:`tilesynth.builder.materials`): labels never
    smoothed, normals renormalised where smoothed and given in the export's ``normal_y`` convention."""
    from ..builder.materials import MapSpec, convert_normal_y, map_atlas

    out: dict[str, dict[str, Any]] = {}
    smooth = {"auto": None, "on": True, "off": False}[map_smooth]
    for d in getattr(tileset, "map_specs", None) or []:
        spec = MapSpec.from_dict(d)
        arr = tileset.maps[spec.name]
        cells = _atlas.padded_tiles(map_atlas(tileset, spec, arr, smooth), arr, tileset.source, padding)
        if spec.kind == "normal" and normal_y_value(normal_y) != spec.normal_y:
            cells = convert_normal_y(cells, spec.encoding or "unorm")
        out[spec.name] = {"cells": cells, "kind": "map", "map_kind": spec.kind, "encoding": spec.encoding}
    return out


def _write_atlases(
    built: dict[str, dict[str, Any]],
    out: Path,
    cols: int,
    rows: int,
    levels: int,
    normal_y: str,
    files: list[str],
    progress: Any = None,
) -> list[dict[str, Any]]:
    """Pack every map's cells, write its mip chain (appending the file names to ``files``); the manifest's
    ``maps`` entries."""
    map_entries = []
    for k, (name, info) in enumerate(built.items()):
        if progress is not None:
            progress("atlases", k, len(built))
        cells = info["cells"]
        srgb = (name == "albedo" or info.get("map_kind") == "colour") and cells.dtype != np.float32
        chain = _atlas.mip_chain(_atlas.pack(cells, cols, rows), levels, srgb)
        if info.get("map_kind") == "normal":  # filtered normals, renormalised
            from ..builder.materials import renormalise_image

            chain = [chain[0], *(renormalise_image(lv, info.get("encoding", "unorm")) for lv in chain[1:])]
        ext = "exr" if cells.dtype == np.float32 else "png"
        level_files = []
        for lv, arr in enumerate(chain):
            fname = f"atlas_{name}.{ext}" if lv == 0 else f"atlas_{name}_mip{lv}.{ext}"
            _write_level(out / fname, arr)
            level_files.append(
                {"level": lv, "file": fname, "width": int(arr.shape[1]), "height": int(arr.shape[0])}
            )
            files.append(fname)
        entry: dict[str, Any] = {
            "name": name,
            "levels": level_files,
            "channels": int(cells.shape[3]),
            "sample_type": {np.dtype(np.uint8): "uint8", np.dtype(np.uint16): "uint16"}.get(
                cells.dtype, "float32"
            ),
            "colour_space": "srgb" if srgb else "linear",
            "mips_reduced_in": "linear light" if srgb else "stored values",
        }
        if info.get("map_kind", "normal" if "normal" in name.lower() else None) == "normal":
            entry["normal_y"] = normal_y
        map_entries.append(entry)
    if progress is not None:
        progress("atlases", len(built), len(built))
    return map_entries


def _write_shaders(out: Path, files: list[str]) -> None:
    for s in SHADER_FILES:
        _write_text(out / "shaders" / s, shader_source(s))
        files.append(f"shaders/{s}")


def _manifest(
    tileset: Any,
    padding: int,
    cols: int,
    rows: int,
    levels: int,
    exact: dict[str, Any],
    map_entries: list[dict[str, Any]],
    lookup_entry: dict[str, Any],
    source_path: str | os.PathLike[str] | None,
) -> dict[str, Any]:
    """The manifest (``files`` still None: the caller fills it in once every file is written)."""
    defn = tileset.definition
    n = tileset.tile_size
    s = n + 2 * padding
    return {
        "format": EXPORT_FORMAT,
        "format_version": EXPORT_VERSION,
        "tilesynth_version": tileset.version or _version(),
        "scheme": tileset.scheme,
        "tile_set": getattr(defn, "name", ""),
        "tile_size": n,
        "tile_count": tileset.n_tiles,
        "padding": padding,
        "cell_size": s,
        "atlas": {
            "width": cols * s,
            "height": rows * s,
            "columns": cols,
            "rows": rows,
            "max_level": levels,
            "rule": "tile t interior at x = (t % columns) * cell_size + padding, y = (t // columns) * cell_size "
            "+ padding (level 0 texels, y down); level L divides everything by 2^L",
            "cells": _atlas.cell_rects(tileset.n_tiles, n, padding, cols),
            "filter": "LINEAR_MIPMAP_LINEAR, clamp to edge, max level = max_level",
        },
        "gutter": {
            "fill": "exemplar continuation of the nearest tile pixel's provenance (tilesynth.engine.atlas)",
            "exact_fraction_by_depth": exact["by_depth"],
            "exact_fraction": exact["overall"],
            "neighbour_pairs": exact["pairs"],
        },
        "maps": map_entries,
        "lookup": lookup_entry,
        "coordinates": "uv in tile units, pixel (x, y) of the texture covers [x/N, (x+1)/N) x [y/N, (y+1)/N), y down",
        "source": source_entry(tileset, source_path),
        "shaders": shader_entry("tilesynth"),
        "files": None,
    }
