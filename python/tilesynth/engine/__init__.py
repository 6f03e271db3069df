"""Engine export: a toroidal index map or the hashed lookup, a manifest with a JSON Schema, lookup shaders
(GLSL ES 3.00 / 4.x, WGSL, HLSL, Godot) and an offline WebGL2 viewer, with the tiles in one of two forms:

* **version 2** (the default for pure-copy ω sets, ``format="provenance"``): each exemplar map once with its full
  mip chain, one-bit labels with their coverage and a per-tile source table; shaders for M maps, smooth maps
  drawn with the seam blend of :func:`tilesynth.synthesize_maps` (:mod:`.provenance_export`, :mod:`.viewer_v2`,
  ``shaders/tilesynth_v2.*``, ``docs/engine.md``);
* **version 1** (``format="atlas"``; Poisson-smoothed and version-1 pixel sets, Wang tiles, ``map_smooth="on"``):
  padded atlases with per-tile mips, described below.

For version 1, ``tilesynth export X.tiles -o DIR --format atlas`` / :func:`export` writes into DIR:

=========================  ========================================================================================
file                       content
=========================  ========================================================================================
``atlas_<map>.png``        level 0 of each map's atlas (8 or 16 bit; ``albedo`` is the tile set's own colour);
                           ``.exr`` (float32 OpenEXR, :func:`tilesynth.io.images.save_image`) for float maps
``atlas_<map>_mip<L>.*``   level L = 1 .. ``max_level`` of the per-tile mip chains (see :mod:`.atlas`)
``index.png``              index-map lookup only: R16 (16-bit grey PNG) tile index of every cell of a toroidal
                           tiling, so it can be sampled with REPEAT (see :mod:`.periodic`)
``manifest.json``          everything a loader needs; validated against ``manifest.schema.json`` (shipped in
                           this package, :func:`manifest_schema`) before it is written
``shaders/``               ``tilesynth.glsl``, ``tilesynth.wgsl``, ``tilesynth.hlsl``, ``tilesynth.gdshader``
``viewer.html``            with ``viewer=True`` (``--viewer``): the offline WebGL2 viewer (:mod:`.viewer`)
=========================  ========================================================================================

**Lookup modes.** ``hash``: the tile of cell (cx, cy) is computed from the pcg3d hash of its lattice vertices
/ edges (``HASH-SPEC``, :mod:`tilesynth.layouts.hashed`), for *complete* sets whose tiles are stored in the hash's index
order; no index texture, an infinite non-periodic plane (or periodic with ``wrap``). ``index_map``: every other
set (the scan-line sets 16a, n2, wang18, ...): the tiling is precomputed as a toroidal index map of
``index_size`` cells. ``lookup="auto"`` (default) picks ``hash`` when the set allows it.

KTX2 is not written: no maintained, permissively licensed KTX2 *encoder* is installable from PyPI or crates.io
(the Khronos KTX-Software has no PyPI wheel; the ``ktx2`` crate only reads), and a hand-written container writer
is what the issue rules out. The level PNGs carry the same data.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..cli.argtypes import normal_y_value
from ..errors import ParameterError
from . import atlas as _atlas
from .atlas_export import _manifest, _write_atlases, _write_shaders, build_maps
from .format import (  # noqa: F401 - EXPORT_VERSION and HASH_* stay importable from tilesynth.engine
    EXPORT_FORMAT,
    EXPORT_VERSION,
    HASH_CONSTANTS,
    HASH_NAME,
    _check_choice,
    _index_size,
    _map_array,
    _version,
    manifest_schema,
    validate_manifest,
)
from .output import (  # noqa: F401 - MAX_MANIFEST_BYTES stays importable from tilesynth.engine
    MAX_MANIFEST_BYTES,
    _file_digest,
    _prepare_output,
    _remove_stale,
    _write_level,
    _write_manifest,
    _write_text,
    export_files,
    previous_export_files,
    shader_entry,
    source_entry,
)
from .periodic import toroidal_index_map
from .sources import shader_source

__all__ = ["EXPORT_FORMAT", "export", "hash_layout", "manifest_schema", "shader_source", "validate_manifest"]


def hash_layout(definition: Any) -> dict[str, int] | None:
    """``{"kind": "corner", "K", "V"}`` / ``{"kind": "edge", "Kh", "Kv", "V"}`` if the tiles are a complete
    set stored in the hash's index order (``HASH-SPEC``), else None."""
    kind = type(definition).__name__
    n = len(definition)
    if kind == "CornerTileSet":
        cols = list(definition.colours)
        k = len(cols)
        if k < 1 or n % (k**4):
            return None
        v = n // k**4
        for t in range(n):
            rest, var = divmod(t, v)
            rest, br = divmod(rest, k)
            rest, tr = divmod(rest, k)
            tl, bl = divmod(rest, k)
            want = (cols[tl], cols[bl], cols[tr], cols[br])
            if tuple(definition.tiles[t]) != want or int(definition.variants[t]) != var:
                return None
        return {"kind": "corner", "K": k, "V": v}
    if kind == "WangTileSet":
        hz, vt = list(definition.horizontal), list(definition.vertical)
        kh, kv = len(hz), len(vt)
        if n % (kh * kh * kv * kv):
            return None
        v = n // (kh * kh * kv * kv)
        variants = (
            getattr(definition, "variants", None) or (0,) * n
        )  # the variants of a complete edge set (wc<K>x<V>)
        for t in range(n):
            rest, var = divmod(t, v)
            rest, w = divmod(rest, kv)
            rest, s = divmod(rest, kh)
            nn, e = divmod(rest, kv)
            if tuple(definition.tiles[t]) != (hz[nn], vt[e], hz[s], vt[w]) or int(variants[t]) != var:
                return None
        return {"kind": "edge", "Kh": kh, "Kv": kv, "V": v}
    return None


def export(
    tileset: Any,
    out_dir: str | os.PathLike[str],
    *,
    maps: dict[str, Any] | None = None,
    padding: int = 8,
    bits: int = 8,
    lookup: str = "auto",
    seed: int = 0,
    wrap: tuple[int, int] | None = None,
    index_size: tuple[int, int] | None = None,
    index_seed: int = 0,
    normal_y: str = "+y",
    map_smooth: str = "auto",
    viewer: bool = False,
    source_path: str | os.PathLike[str] | None = None,
    inputs: list[tuple[str, Any]] | None = None,
    progress: Any = None,
    format: str = "auto",
    blend_levels: dict[str, float] | None = None,
) -> dict[str, Any]:
    """Export a tile set for real-time use (see the module docstring); returns the manifest.

    Parameters
    ----------
    tileset : a :class:`~tilesynth.TileSet`.
    out_dir : directory to write (created; the files of a previous export are replaced).
    maps : extra maps pixel-aligned with the exemplar, ``{name: (H, W[, C]) uint8 | uint16 | float32}``;
        laid out through exactly the same cuts as the colour (as ``synthesize_map``). A name containing
        ``normal`` is a normal map (linear, with ``normal_y``); every other extra map is linear data.
    padding : gutter P in texels on every side of every tile (default 8: mips down to level 3 when N is a
        multiple of 8). 0 writes a gutter-less atlas without mips (bilinear then bleeds across tiles).
    bits : 8 or 16, the PNG depth of the colour atlas (uint maps keep their own depth; float maps go to EXR).
    lookup : ``"auto"``, ``"hash"`` or ``"index_map"``.
    seed : hash seed in [0, 2^32) (hash mode).
    wrap : hash mode: make the plane periodic with (Tx, Ty) tiles (default: infinite, non-periodic).
    index_size : (cols, rows) of the toroidal index map (index-map mode); default: the multiple of the set's
        torus period nearest 32 x 32 (:func:`~tilesynth.engine.periodic.default_index_size`).
    index_seed : seed of the toroidal index map.
    normal_y : ``"up"`` or ``"+y"`` (OpenGL convention, green up), ``"down"`` or ``"-y"`` (DirectX): recorded
        for normal maps (as ``+y`` / ``-y``, the manifest's spelling); the
        values are not changed (the exemplar's normal map is what it is).
    map_smooth : ``"auto"`` / ``"on"`` / ``"off"``, as ``synth --map-smooth``.
    viewer : also write ``viewer.html``.
    source_path : the ``.tiles`` file, recorded in the manifest (its file digest) when given.
    inputs : other input files, ``[(label, path)]``: with ``source_path``, none may be among the files written
        (:func:`tilesynth.io.paths.check_paths`, before anything is written).
    progress : a :class:`tilesynth.base.progress.Progress` (the atlases and the index map), or None.
    format : ``"auto"`` (default): version 2 (:mod:`.provenance_export`: the exemplar maps with full mips, one-bit
        labels and a source table) for a pure-copy set whose labels fit the one-bit quadrant form, else the
        atlas (version 1); ``"provenance"``: version 2 or a ParameterError saying why not; ``"atlas"``: version 1.
    blend_levels : version 2: ``{map name: L}``, the level from which each named map's two sources are weighted
        by the label coverage across a cut (0: a hard cut at level 0, coverage-weighted minification only).
        Unnamed maps: colour maps are cut (L = 0); smooth maps (scalar and normal kinds) get the seam blend of
        :func:`tilesynth.synthesize_maps` in the shaders (manifest ``seam`` "blend",
        :func:`.provenance_export.seam_plans`) unless ``map_smooth`` is "off" or the tile size is not whole
        blocks of the blend's levels. Ignored by the atlas.

    The files are written as a unit (:func:`tilesynth.io.images.file_set`): an error, Ctrl-C or SIGTERM leaves
    the previous export in ``out_dir`` as it was; a re-export removes the previous export's files that the new
    manifest does not list.
    """
    normal_y = {"up": "+y", "down": "-y"}[normal_y_value(normal_y)]  # the manifest's spelling
    padding, lookup, hl = _check_export_args(
        tileset, maps, padding, bits, lookup, seed, wrap, index_size, index_seed, normal_y, map_smooth
    )
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise ParameterError(f"out_dir = {str(out_dir)!r}: exists and is not a directory")
    _check_choice(format, "format", ("auto", "provenance", "atlas"))
    if format != "atlas":
        form, why = provenance_form(tileset, map_smooth)
        if form is None and format == "provenance":
            raise ParameterError(f"format = 'provenance': {why}; use format='atlas'")
        if form is not None:
            return _export_v2(
                tileset, out, form, maps, bits, lookup, hl, seed, wrap, index_size, index_seed, normal_y,
                blend_levels, viewer, source_path, inputs, progress, map_smooth,
            )  # fmt: skip
    if blend_levels:
        raise ParameterError("blend_levels: only for the provenance export (format='provenance')")

    levels = _atlas.max_mip_level(tileset.tile_size, padding)
    cols, rows = _atlas.grid_for(tileset.n_tiles)
    built = build_maps(tileset, maps, padding, bits, map_smooth, normal_y)
    names = export_files(built, levels, lookup == "index_map", viewer)
    previous = _prepare_output(
        out, names, [("tileset", source_path), *(inputs or [])], tileset, lookup, index_size
    )
    from ..io.images import file_set

    # the whole set is committed as a unit: the previous export stays whole until every new file is written
    with file_set():
        files: list[str] = []
        tiles_q = _atlas.quantise(tileset.tiles, bits)
        exact = _atlas.gutter_exactness(tileset, built["albedo"]["cells"], padding, tiles_q)
        map_entries = _write_atlases(built, out, cols, rows, levels, normal_y, files, progress)
        if lookup == "hash":
            lookup_entry = _hash_lookup(hl, seed, wrap)
        else:
            lookup_entry = _write_index_map(tileset.definition, out, index_size, index_seed, files, progress)
        _write_shaders(out, files)
        manifest = _manifest(
            tileset, padding, cols, rows, levels, exact, map_entries, lookup_entry, source_path
        )
        if viewer:
            from .viewer import write_viewer

            write_viewer(tileset, out / "viewer.html", manifest, built, out)
            files.append("viewer.html")
        _write_manifest(out, manifest, files)
    _remove_stale(out, previous, files)
    return manifest


def _check_export_args(
    tileset: Any,
    maps: Any,
    padding: Any,
    bits: Any,
    lookup: str,
    seed: Any,
    wrap: Any,
    index_size: Any,
    index_seed: Any,
    normal_y: str,
    map_smooth: str,
) -> tuple[int, str, dict[str, Any] | None]:
    """Check the arguments of :func:`export` before anything is written; returns (padding, lookup mode, hash
    layout)."""
    from ..tileset.tilefile import TileSet

    if not isinstance(tileset, TileSet):
        raise TypeError(f"tileset is a {type(tileset).__name__}, expected a TileSet (tilesynth.load(path))")
    if isinstance(padding, bool) or not isinstance(padding, (int, np.integer)) or not 0 <= padding <= 256:
        raise ParameterError(f"padding = {padding!r}: must be an integer in [0, 256]")
    padding = int(padding)
    if (
        padding > tileset.tile_size
    ):  # the gutter continues the tile's own border pixels: at most one tile wide
        raise ParameterError(
            f"padding = {padding}: must be at most the tile size ({tileset.tile_size}) of this tile set"
        )
    _check_choice(bits, "bits", (8, 16))
    _check_choice(lookup, "lookup", ("auto", "hash", "index_map"))
    normal_y_value(normal_y)  # up/+y or down/-y (tilesynth.cli.argtypes); the manifest records +y or -y
    _check_choice(map_smooth, "map_smooth", ("auto", "on", "off"))
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**32:
        raise ParameterError(f"seed = {seed!r}: must be an integer in [0, 2^32)")
    defn = tileset.definition
    n = tileset.tile_size
    if n > 65535 or tileset.n_tiles > 65535:
        raise ParameterError(
            f"{tileset.n_tiles} tiles of {n} px: the R16 index map holds at most 65535 tiles"
        )
    hl = hash_layout(defn)
    if lookup == "auto":
        lookup = "hash" if hl is not None else "index_map"
    if lookup == "hash" and hl is None:
        raise ParameterError(
            "lookup = 'hash': the hash needs a complete set stored in the hash's index order (HASH-SPEC); "
            f"set {getattr(defn, 'name', '?')!r} is not one: use lookup='index_map'"
        )
    if maps is not None and not isinstance(maps, dict):
        raise TypeError(f"maps is a {type(maps).__name__}, expected a dict {{name: array}}")
    if index_size is not None and (
        not isinstance(index_size, (tuple, list))
        or len(index_size) != 2
        or any(isinstance(v, bool) or not isinstance(v, (int, np.integer)) for v in index_size)
    ):
        raise ParameterError(f"index_size = {index_size!r}: expected (cols, rows) positive integers")
    if isinstance(index_seed, bool) or not isinstance(index_seed, (int, np.integer)) or index_seed < 0:
        raise ParameterError(f"index_seed = {index_seed!r}: must be a non-negative integer")
    if wrap is not None:
        if lookup != "hash":
            raise ParameterError("wrap: only for lookup='hash' (an index map is periodic with its own size)")
        if (
            not isinstance(wrap, (tuple, list))
            or len(wrap) != 2
            or any(
                isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v < 2**31
                for v in wrap
            )
        ):
            raise ParameterError(f"wrap = {wrap!r}: expected (Tx, Ty) integers in [1, 2^31)")
    return padding, lookup, hl


def _hash_lookup(hl: dict[str, Any] | None, seed: int, wrap: tuple[int, int] | None) -> dict[str, Any]:
    """The manifest's ``lookup`` entry of the hash mode."""
    return {
        "mode": "hash",
        "hash": HASH_NAME,
        "constants": HASH_CONSTANTS,
        "seed": int(seed),
        "wrap": [int(wrap[0]), int(wrap[1])] if wrap is not None else None,
        "roles": {"vertex": 0, "horizontal_edge": 1, "vertical_edge": 2, "variant": 3},
        **hl,  # type: ignore[dict-item]
    }


def _write_index_map(
    defn: Any,
    out: Path,
    index_size: tuple[int, int] | None,
    index_seed: int,
    files: list[str],
    progress: Any = None,
) -> dict[str, Any]:
    """Write ``index.png`` (a toroidal tiling) and return the manifest's ``lookup`` entry of the index-map mode."""
    icols, irows = _index_size(defn, index_size)
    imap = toroidal_index_map(defn, irows, icols, index_seed, progress=progress)
    from ..io.images import save_image

    save_image(out / "index.png", imap.astype(np.uint16), bits=16)
    files.append("index.png")
    return {
        "mode": "index_map",
        "file": "index.png",
        "width": icols,
        "height": irows,
        "format": "R16_UINT",
        "wrap": "repeat",
        "seed": int(index_seed),
        "periodic": "toroidal tiling found by backtracking scan-line search (tilesynth.engine.periodic)",
    }


# ------------------------------------------------------------------------------- version 2 (provenance)
def provenance_form(tileset: Any, map_smooth: str = "auto") -> tuple[Any, str]:
    """``(QuadrantForm, "")`` when the set can be exported as version 2 (:mod:`.provenance_export`), else
    ``(None, why not)``."""
    from .provenance_export import quadrant_form

    if map_smooth == "on":
        return None, "map_smooth = 'on' asks for the CPU fusion of the maps, which only the atlas stores"
    if tileset.storage() != 2:
        return None, "the tile set is not a pure copy of its exemplar (Poisson-smoothed or version-1 pixels)"
    if tileset.tile_size % 8:
        return None, f"tile size {tileset.tile_size} is not a multiple of 8 (the one-bit label texture)"
    form = quadrant_form(tileset._provenance())
    if form is None:
        return None, (
            "its labels do not fit the one-bit quadrant form (at most two sources per tile quadrant, the "
            "second shared by the tile: omega sets); Wang tiles and others are exported as an atlas"
        )
    return form, ""


def _export_v2(
    tileset: Any,
    out: Path,
    form: Any,
    maps: dict[str, Any] | None,
    bits: int,
    lookup: str,
    hl: dict[str, Any] | None,
    seed: int,
    wrap: tuple[int, int] | None,
    index_size: tuple[int, int] | None,
    index_seed: int,
    normal_y: str,
    blend_levels: dict[str, float] | None,
    viewer: bool,
    source_path: str | os.PathLike[str] | None,
    inputs: list[tuple[str, Any]] | None,
    progress: Any,
    map_smooth: str = "auto",
) -> dict[str, Any]:
    """:func:`export` of version 2 (the arguments already checked, but the maps and blend levels)."""
    from . import provenance_export as pe
    from .sources import SHADER_FILES_V2

    entries = pe.exemplar_maps(tileset, maps, bits, normal_y, _map_array)
    blend = pe.check_blend_levels(blend_levels, [e["name"] for e in entries])
    plans = pe.seam_plans(entries, tileset.tile_size, blend_levels, map_smooth)
    layout = pe.blend_layout(plans, tileset.tile_size)
    n_cov = pe.coverage_count(tileset.tile_size)
    names = pe.export_files_v2(entries, n_cov, blend=layout is not None, plans=plans)
    if lookup == "index_map":
        names.append("index.png")
    names += [f"shaders/{s}" for s in SHADER_FILES_V2]
    if viewer:
        names.append("viewer.html")
    names.append("manifest.json")
    previous = _prepare_output(
        out, names, [("tileset", source_path), *(inputs or [])], tileset, lookup, index_size
    )
    from ..io.images import file_set

    with file_set():
        files: list[str] = []
        written = pe.write_textures(form, entries, blend, normal_y, out, files, _write_level, progress, plans)
        if lookup == "hash":
            lookup_entry = _hash_lookup(hl, seed, wrap)
        else:
            lookup_entry = _write_index_map(tileset.definition, out, index_size, index_seed, files, progress)
        for s in SHADER_FILES_V2:
            _write_text(out / "shaders" / s, shader_source(s))
            files.append(f"shaders/{s}")
        shapes = [(*e["array"].shape, e["array"].dtype.itemsize) for e in entries]
        lows = [
            (*e["array"].shape[:2], 1, e["array"].dtype.itemsize)
            for e in entries
            if pe.packs_low_band(e["kind"], int(e["array"].shape[2]), plans.get(e["name"]))
        ]
        mem = pe.gpu_bytes(
            shapes, tileset.n_tiles, tileset.tile_size, None if layout is None else layout[:2], lows
        )
        manifest = {
            "format": EXPORT_FORMAT,
            "format_version": 2,
            "tilesynth_version": tileset.version or _version(),
            "scheme": tileset.scheme,
            "tile_set": getattr(tileset.definition, "name", ""),
            "tile_size": tileset.tile_size,
            "tile_count": tileset.n_tiles,
            "exemplar": {"width": int(tileset.exemplar.shape[1]), "height": int(tileset.exemplar.shape[0])},
            "maps": written["maps"],
            "labels": written["labels"],
            "lookup": lookup_entry,
            "coordinates": "uv in tile units, pixel (x, y) of the texture covers [x/N, (x+1)/N) x [y/N, (y+1)/N), "
            "y down",
            "filter": "maps LINEAR_MIPMAP_LINEAR, MIRRORED_REPEAT (the seam blend reads an entry past its piece, "
            "mirrored at the exemplar's edge), every level; coverage LINEAR_MIPMAP_LINEAR, CLAMP_TO_EDGE; bits, "
            "table and index NEAREST (texelFetch); blend coverage LINEAR, CLAMP_TO_EDGE, one level",
            "gpu_bytes": {**mem, "ratio_to_maps": mem["total"] / mem["maps"]},
            "source": source_entry(tileset, source_path),
            "shaders": shader_entry("tilesynth_v2"),
            "files": None,
        }
        if viewer:
            from .viewer_v2 import write_viewer

            write_viewer(tileset, out / "viewer.html", manifest, out)
            files.append("viewer.html")
        _write_manifest(out, manifest, files)
    _remove_stale(out, previous, files)
    return manifest
