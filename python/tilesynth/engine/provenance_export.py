"""Export version 2: a pure-copy tile set as its provenance on the GPU (the exemplar maps once, with full mips).

A tile set stored as provenance (:mod:`tilesynth.tileset.provenance`) says for every tile pixel ``p`` of tile ``t``:
``pixel = map[D_s(p) + (by, bx)]`` for the entry ``(s, by, bx)`` of the tile's source table that its label picks.
The GPU does the same: hash -> tile -> label -> ``textureGrad`` of each exemplar map at the continuous-uv
derivatives, so the maps' own mip chains give full mips and every map shares one lookup.

**The label in one bit.** An ω tile is its intermediate tile (four quadrants of ``N/2``, each a translation of a
sample patch) overlaid with the matching patch inside the cut: so within each quadrant a pixel comes from one of
two entries, the quadrant's own (``A_q``) or the tile's matching patch (``B``, the same for all four quadrants).
:func:`quadrant_form` finds ``A_q`` and ``B`` from any factorised provenance (it does not ask which scheme made
the set) and gives a bit per pixel (1: entry ``B``); sets that do not fit (Wang tiles' triangles, more than two
sources in a quadrant) return None and are exported as an atlas (version 1). The *coverage* of ``B`` (the share
of 1 bits) is what weights the two sources where a filter footprint straddles a cut.

**Textures** (all of them for M maps; the sizes are :func:`gpu_bytes`):

=========================  ==============================================================================
``map_<name>.png`` + mips  each exemplar map once, its full mip chain to 1 x 1 (``H >> L``, ``W >> L``
                           rounded down, a 2 x 2 box over the even part: an odd last row or column is left
                           out of the next level); colour maps reduced in linear light, normals renormalised
``map_<name>_low.png``     a one-channel scalar map blended with a low band: that band at every pixel
+ mips                     (:func:`low_band_image`), bound with the map as one two-channel texture (value,
                           low band): one fetch per entry serves both (``low_band`` in the map's entry)
``labels_bits.png``        R8UI (an 8-bit grey PNG): tile ``t``'s bits in an ``N/8 x N`` cell at column
                           ``t % bits_columns``, row ``t // bits_columns``; bit ``i`` of texel (x, y) of the
                           cell is pixel (8x + i, y) of the tile (least significant bit first)
``labels_coverage.png``    R8 UNORM: coverage of ``B`` at label level 2 (4 x 4 pixel blocks), tile ``t`` in
+ ``_mip<j>``              an ``N/4`` cell at column ``t % coverage_columns``; level j = label level j + 2,
                           reduced per tile (a cell never bleeds into its neighbour) down to one texel a tile
``labels_blend.png``       when a map is blended: a 16-bit grey PNG of counts, uploaded as R16F ``count / 4^l``
                           (:func:`blend_coverage`): B's pixels in each 2^3 block of every tile's labels and,
                           with a low band, in each 2^l block of the labels extended ``reach`` px from the border
``table.bin``              int32 little-endian ``(ceil(4K / 256), 256, 4)``: an RGBA32I texture of width
                           256, texel ``i = 4t + q`` (q = quadrant: 2·(y >= N/2) + (x >= N/2)) holds
                           ``(code_A, bx_A, code_B, bx_B)``, ``code = (r << 19) | ((by + 32768) << 3) | s``
                           with ``r`` = ``r_in`` in ``code_A``, ``r_out`` in ``code_B`` (:func:`quadrant_radii`)
=========================  ==============================================================================

**The seam blend.** Maps of kind "scalar" and "normal" get the seam blend of :func:`tilesynth.synthesize_maps`
(:mod:`tilesynth.synth.seams`) in the shaders (:func:`seam_plans`, :func:`blend_plan`): the manifest's map entry
says ``seam`` ("blend"; "coverage" or "cut" for the coverage weighting of ``blend_level``), and a blended map has
``bands`` (``high``; scalar maps also ``low``, ``split``, ``reach``) and, if scalar, ``mean`` (per channel, in the
values the shaders read); ``labels.blend`` describes ``labels_blend.png`` (``high_level``, ``reach``,
``reach_levels``, its cell layout).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError
from . import atlas as _atlas
from .seam_textures import (  # noqa: F401 - blend_plan, blend_shares, reach_span, seam_plans stay importable here
    blend_cell,
    blend_coverage,
    blend_layout,
    blend_plan,
    blend_shares,
    low_band_image,
    map_mean,
    packs_low_band,
    reach_span,
    seam_plans,
)

__all__ = [
    "BIAS",
    "RADIUS_MAX",
    "TABLE_WIDTH",
    "QuadrantForm",
    "blend_plan",
    "coverage_levels",
    "full_mip_chain",
    "gpu_bytes",
    "pack_bits",
    "pack_table",
    "quadrant_form",
    "quadrant_of",
    "quadrant_radii",
    "blend_coverage",
]

TABLE_WIDTH = 256
"""Width of the source-table texture (texels); texel ``4t + q`` is at (i % 256, i // 256)."""
BIAS = 32768
"""Added to ``by`` before it is packed with the symmetry (``code = ((by + BIAS) << 3) | s``)."""

LOW_BAND_RULE = (
    "the seam blend's low band of this map (tilesynth.synth.seams step 4) at every exemplar pixel: the bilinear "
    "sample of the map's 2^split box mip (a partial last block averages its own pixels, indices mirrored) at the "
    "pixel centre, in the map's sample type, with its own full mip chain; bind level l of the map and level l of "
    "this as one two-channel texture (value, low band) and pass normal = -1 to ts_smooth_map: one fetch per entry "
    "then serves both (a reader that does not bind it passes the map alone with normal = 0, one more fetch per "
    "entry)"
)
"""The manifest's ``low_band`` rule (a one-channel scalar map blended with a low band)."""


class QuadrantForm:
    """The one-bit label form of a provenance: ``bits`` bool ``(K, N, N)`` and ``entries`` int32 ``(K, 4, 2, 3)``
    (per tile, quadrant and bit: ``(s, by, bx)``)."""

    def __init__(self, bits: np.ndarray, entries: np.ndarray):
        self.bits = bits
        self.entries = entries

    @property
    def n_tiles(self) -> int:
        return int(self.bits.shape[0])

    @property
    def tile_size(self) -> int:
        return int(self.bits.shape[1])

    def source(self, tiles: np.ndarray | None = None) -> np.ndarray:
        """int64 ``(k, N, N, 2)`` exemplar (row, col) of every pixel (the check against the provenance)."""
        from ..tileset.provenance import dihedral_grid

        idx = np.arange(self.n_tiles) if tiles is None else np.asarray(tiles, np.int64)
        n = self.tile_size
        grids = np.stack([dihedral_grid(s, n) for s in range(8)])
        q = quadrant_of(n)
        yy, xx = np.mgrid[0:n, 0:n]
        out = np.empty((idx.size, n, n, 2), np.int64)
        for j, t in enumerate(idx):
            e = self.entries[t][q, self.bits[t].astype(np.int64)]  # (N, N, 3)
            out[j] = grids[e[..., 0], yy, xx] + e[..., 1:]
        return out


def quadrant_of(n: int) -> np.ndarray:
    """int64 ``(N, N)``: quadrant of every tile pixel, ``2·(y >= N/2) + (x >= N/2)`` (``N/2`` rounded down)."""
    h = n // 2
    yy, xx = np.mgrid[0:n, 0:n]
    return (2 * (yy >= h) + (xx >= h)).astype(np.int64)


def quadrant_form(prov: Any) -> QuadrantForm | None:
    """The one-bit form of a :class:`~tilesynth.tileset.provenance.Provenance`, or None when some quadrant of some
    tile has more than two sources or no single second source serves all its quadrants (module docstring)."""
    lab = np.asarray(prov.labels)
    tab = np.asarray(prov.table)
    k, n = lab.shape[:2]
    if n < 2:
        return None
    width = tab.shape[1]
    q = quadrant_of(n)
    key = (np.arange(k)[:, None, None] * 4 + q[None]) * width + lab.astype(np.int64)
    counts = np.bincount(key.reshape(-1), minlength=k * 4 * width).reshape(k, 4, width)
    present = counts > 0
    bits = np.zeros((k, n, n), bool)
    entries = np.zeros((k, 4, 2, 3), np.int32)
    for t in range(k):
        sets = [np.flatnonzero(present[t, j]) for j in range(4)]
        if max(len(s) for s in sets) > 2:
            return None
        multi = [set(s.tolist()) for s in sets if len(s) == 2]
        if multi:
            cand = set.intersection(*multi)
            if not cand:
                return None
            # the label in most quadrants (the matching patch), ties by pixel count
            b = max(cand, key=lambda c: (int(present[t, :, c].sum()), int(counts[t, :, c].sum()), -c))
        else:
            b = -1
        for j, s in enumerate(sets):
            rest = [int(v) for v in s if v != b]
            a = rest[0] if rest else b
            entries[t, j, 0] = tab[t, a]
            entries[t, j, 1] = tab[t, b if b >= 0 else a]
        if b >= 0:
            bits[t] = lab[t] == b
    return QuadrantForm(bits, entries)


RADIUS_MAX = 4095
"""Largest radius field (half pixels): 2047.5 px, tiles up to 4094 px."""


def quadrant_radii(form: QuadrantForm) -> tuple[np.ndarray, np.ndarray]:
    """int64 ``(K, 4)`` each: ``r_in`` and ``r_out`` of every tile quadrant in half pixels, distances of pixel
    centres from the tile's centre: every pixel of the quadrant nearer than ``r_in / 2`` px has bit 1 (entry B),
    every one farther than ``r_out / 2`` px bit 0 (entry A), each with half a pixel to spare (so float rounding
    in a shader can never flip a pixel). The shaders skip the label fetch outside that band: an ω cut region is
    a blob about the tile's centre."""
    k, n = form.n_tiles, form.tile_size
    yy, xx = np.mgrid[0:n, 0:n]
    dist2 = 2.0 * np.hypot(xx + 0.5 - n / 2, yy + 0.5 - n / 2)  # half pixels
    q = quadrant_of(n)
    r_in = np.full((k, 4), RADIUS_MAX, np.int64)
    r_out = np.zeros((k, 4), np.int64)
    for j in range(4):
        d = dist2[q == j]
        b = form.bits[:, q == j]  # (K, P)
        a_min = np.where(~b, d[None], np.inf).min(axis=1)
        b_max = np.where(b, d[None], -np.inf).max(axis=1)
        r_in[:, j] = np.where(np.isfinite(a_min), np.clip(np.floor(a_min) - 1, 0, RADIUS_MAX), RADIUS_MAX)
        r_out[:, j] = np.where(np.isfinite(b_max), np.clip(np.ceil(b_max) + 1, 0, RADIUS_MAX), 0)
    return r_in, r_out


def pack_table(form: QuadrantForm) -> np.ndarray:
    """int32 ``(rows, TABLE_WIDTH, 4)``: the RGBA32I source-table texture (module docstring)."""
    e = form.entries.astype(np.int64)  # (K, 4, 2, 3)
    if (e[..., 1] + BIAS < 0).any() or (e[..., 1] + BIAS >= 1 << 16).any():
        raise ParameterError("a source row lies outside [-32768, 32768): cannot be packed")
    if form.tile_size > 2048:  # a corner is 0.71 N from the centre: 1.42 N half pixels, within RADIUS_MAX
        raise ParameterError(f"tile size {form.tile_size}: at most 2048 for the table's radii")
    r_in, r_out = quadrant_radii(form)
    code = ((e[..., 1] + BIAS) << 3) | e[..., 0]
    code[..., 0] |= r_in << 19
    code[..., 1] |= r_out << 19
    texel = np.stack([code[..., 0], e[..., 0, 2], code[..., 1], e[..., 1, 2]], axis=-1).reshape(-1, 4)
    rows = -(-texel.shape[0] // TABLE_WIDTH)
    out = np.zeros((rows * TABLE_WIDTH, 4), np.int32)
    out[: texel.shape[0]] = texel
    return out.reshape(rows, TABLE_WIDTH, 4)


def bits_columns(n_tiles: int, tile_size: int) -> int:
    """Cells per row of the bits texture (cells ``N/8`` wide, ``N`` high): about as wide as high."""
    import math

    return max(1, min(n_tiles, math.ceil(math.sqrt(8 * n_tiles))))


def pack_bits(form: QuadrantForm) -> tuple[np.ndarray, int]:
    """uint8 ``(rows·N, cols·N/8)`` R8UI bits texture and its cell columns (``N`` a multiple of 8)."""
    k, n = form.n_tiles, form.tile_size
    if n % 8:
        raise ParameterError(f"tile size {n}: the bit labels need a multiple of 8")
    packed = np.packbits(form.bits, axis=2, bitorder="little")  # (K, N, N/8)
    cols = bits_columns(k, n)
    rows = -(-k // cols)
    out = np.zeros((rows * n, cols * (n // 8)), np.uint8)
    for t in range(k):
        r, c = divmod(t, cols)
        out[r * n : (r + 1) * n, c * (n // 8) : (c + 1) * (n // 8)] = packed[t]
    return out, cols


def coverage_levels(form: QuadrantForm) -> tuple[list[np.ndarray], int]:
    """The coverage texture's levels (uint8, level j = label level j + 2, per-tile box reduction of the exact
    share of 1 bits, rounded once) and its cell columns. Needs ``N`` a multiple of 4; the chain stops where a
    cell side becomes odd (one texel a tile for ``N`` a power of two)."""
    k, n = form.n_tiles, form.tile_size
    if n % 4:
        raise ParameterError(f"tile size {n}: the coverage needs a multiple of 4")
    cols, rows = _atlas.grid_for(k)
    counts = (
        form.bits.reshape(k, n // 4, 4, n // 4, 4).sum(axis=(2, 4)).astype(np.int64)
    )  # (K, N/4, N/4) of 16
    block = 16
    out = []
    while True:
        side = counts.shape[1]
        cov = np.rint(counts * (255.0 / block)).astype(np.uint8)
        level = np.zeros((rows * side, cols * side), np.uint8)
        for t in range(k):
            r, c = divmod(t, cols)
            level[r * side : (r + 1) * side, c * side : (c + 1) * side] = cov[t]
        out.append(level)
        if side % 2 or side == 1:
            break
        counts = counts.reshape(k, side // 2, 2, side // 2, 2).sum(axis=(2, 4))
        block *= 4
    return out, cols


def reduce_any(level: np.ndarray, srgb: bool) -> np.ndarray:
    """One full-chain reduction: ``(H >> 1, W >> 1)`` by a 2 x 2 box over the even part (an odd last row or
    column is left out), sRGB in linear light (:func:`tilesynth.engine.atlas.reduce2`); a side of 1 stays 1."""
    h, w = level.shape[:2]
    a = level
    if h == 1:
        a = np.concatenate([a, a], axis=0)
    if w == 1:
        a = np.concatenate([a, a], axis=1)
    a = a[: a.shape[0] // 2 * 2, : a.shape[1] // 2 * 2]
    return _atlas.reduce2(np.ascontiguousarray(a), srgb)


def full_mip_chain(arr: np.ndarray, srgb: bool, normal_encoding: str | None = None) -> list[np.ndarray]:
    """Level 0 .. the 1 x 1 level of an exemplar map (:func:`reduce_any`); normals renormalised at levels >= 1."""
    chain = [arr]
    while chain[-1].shape[0] > 1 or chain[-1].shape[1] > 1:
        nxt = reduce_any(chain[-1], srgb)
        if normal_encoding is not None:
            from ..builder.materials import renormalise_image

            nxt = renormalise_image(nxt, normal_encoding)
        chain.append(nxt)
    return chain


def _chain_bytes(shapes: list[tuple[int, int, int, int]]) -> int:
    total = 0
    for h, w, c, b in shapes:
        c = 4 if c == 3 else c
        while True:
            total += h * w * c * b
            if h == 1 and w == 1:
                break
            h, w = max(1, h // 2), max(1, w // 2)
    return total


def gpu_bytes(
    map_shapes: list[tuple[int, int, int, int]],
    n_tiles: int,
    tile_size: int,
    blend: tuple[int, tuple[int, int] | None] | None = None,
    low_shapes: list[tuple[int, int, int, int]] | None = None,
) -> dict[str, int]:
    """Uncompressed GPU bytes of a version-2 export: ``map_shapes`` = ``(H, W, channels, bytes per sample)``;
    3-channel maps count as RGBA (no RGB8 render format on most GPUs); every map with its full chain;
    ``blend`` ``(high level, reach levels or None)``: the seam blend's coverage (R16F, :func:`blend_coverage`),
    None without it; ``low_shapes``: the low bands carried beside their maps (the second channel of a
    two-channel texture, :func:`packs_low_band`), counted apart as ``low_band``."""
    maps = _chain_bytes(map_shapes)
    low = _chain_bytes(low_shapes or [])
    n = tile_size
    bits = n_tiles * n * n // 8
    cov = 0
    side = n // 4
    while True:
        cov += n_tiles * side * side
        if side % 2 or side == 1:
            break
        side //= 2
    table = -(-4 * n_tiles // TABLE_WIDTH) * TABLE_WIDTH * 16
    blend_b = 0
    if blend is not None:
        cols, rows = _atlas.grid_for(n_tiles)
        w, h = blend_cell(n, *blend)
        blend_b = cols * w * rows * h * 2
    total = maps + low + bits + cov + table + blend_b
    return {"maps": maps, "low_band": low, "bits": bits, "coverage": cov, "table": table, "blend": blend_b,
            "total": total}  # fmt: skip


# ------------------------------------------------------------------------------------------------ the maps
def exemplar_maps(
    tileset: Any, maps: dict[str, Any] | None, bits: int, normal_y: str, check_map: Any
) -> list[dict[str, Any]]:
    """Every map of a version-2 export, level 0 as exported: ``[{"name", "array", "kind", "srgb", "encoding",
    "normal_y"}]``, the albedo (the exemplar at ``bits``) first, then the tile set's material maps, then ``maps``.
    ``normal_y`` is the export's convention (``+y`` / ``-y``): normal maps are converted to it. ``check_map(name,
    value, exemplar_shape)`` checks an extra map and returns it as ``(H, W, C)`` (the exporter's, shared with the
    atlas)."""
    from ..builder.materials import (
        MapSpec,
        _with_normal_encoding,
        convert_normal_y,
        infer_kind,
        renormalise_image,
    )
    from ..cli.argtypes import normal_y_value

    want = normal_y_value(normal_y)
    out: list[dict[str, Any]] = [
        {
            "name": "albedo",
            "array": _atlas.quantise(np.ascontiguousarray(tileset.exemplar), bits),
            "kind": "colour",
            "srgb": True,
            "encoding": None,
        }
    ]
    for d in getattr(tileset, "map_specs", None) or []:
        spec = MapSpec.from_dict(d)
        arr = np.asarray(tileset.maps[spec.name])
        if arr.ndim == 2:
            arr = arr[:, :, None]
        entry = {"name": spec.name, "array": arr, "kind": spec.kind, "encoding": spec.encoding}
        entry["srgb"] = spec.kind == "colour" and arr.dtype != np.float32
        if spec.kind == "normal":
            if normal_y_value(spec.normal_y) != want:
                entry["array"] = convert_normal_y(arr, spec.encoding or "unorm")
            # what synthesize_maps copies and blends: every vector renormalised once
            entry["array"] = renormalise_image(entry["array"], spec.encoding or "unorm")
        out.append(entry)
    for name, value in (maps or {}).items():
        if any(e["name"] == name for e in out):
            raise ParameterError(
                f"map name {name!r}: the tile set stores a map of that name (or it is the tile set's own "
                "colour, 'albedo'); give another name"
            )
        if not isinstance(name, str) or not name or not all(ch.isalnum() or ch in "-_" for ch in name):
            raise ParameterError(f"map name {name!r}: letters, digits, '-' and '_' only")
        a = check_map(name, value, tileset.exemplar.shape[:2])
        enc = _with_normal_encoding(name, a)
        kind = "normal" if enc is not None else infer_kind(name)
        kind = "scalar" if kind == "normal" and enc is None else kind
        if kind == "normal":
            a = renormalise_image(a, enc)
        out.append(
            {
                "name": name,
                "array": a,
                "kind": kind,
                "encoding": enc,
                "srgb": kind == "colour" and a.dtype != np.float32,
            }
        )
    return out


def normal_code(entry: dict[str, Any], normal_y: str) -> int:
    """The shaders' ``normal`` argument of a map: 0 not a normal map; 1 / 2 unsigned codes +y / -y; 3 / 4 signed."""
    if entry["kind"] != "normal":
        return 0
    signed = entry.get("encoding") == "snorm"
    return (3 if signed else 1) + (1 if normal_y == "-y" else 0)


def check_blend_levels(blend_levels: Any, names: list[str]) -> dict[str, float]:
    """``{name: L}`` for every map (0 unless given); raises ParameterError for an unknown name or a bad level."""
    given = {} if blend_levels is None else blend_levels
    if not isinstance(given, dict):
        raise ParameterError(f"blend_levels = {blend_levels!r}: expected a dict {{map name: level}}")
    out = {}
    for name, v in given.items():
        if name not in names:
            raise ParameterError(
                f"blend_levels: no map named {name!r} in this export (maps: {', '.join(names)})"
            )
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float, np.integer, np.floating))
            or not 0 <= v <= 16
        ):
            raise ParameterError(f"blend_levels[{name!r}] = {v!r}: must be a number in [0, 16]")
        out[name] = float(v)
    return {n: out.get(n, 0.0) for n in names}


def export_files_v2(
    entries: list[dict[str, Any]],
    n_coverage: int,
    blend: bool = False,
    plans: dict[str, dict[str, float] | None] | None = None,
) -> list[str]:
    """The level files of the maps and labels of a version-2 export (no shaders, viewer or manifest);
    ``blend``: with the seam blend's coverage; ``plans`` (:func:`seam_plans`): with the low bands of the maps
    that carry one (:func:`packs_low_band`)."""
    names = []
    plans = plans or {}
    for e in entries:
        ext = "exr" if e["array"].dtype == np.float32 else "png"
        stems = [f"map_{e['name']}"]
        if packs_low_band(e["kind"], int(e["array"].shape[2]), plans.get(e["name"])):
            stems.append(f"map_{e['name']}_low")
        for stem in stems:
            h, w = e["array"].shape[:2]
            lv = 0
            while True:
                names.append(f"{stem}.{ext}" if lv == 0 else f"{stem}_mip{lv}.{ext}")
                if h == 1 and w == 1:
                    break
                h, w, lv = max(1, h // 2), max(1, w // 2), lv + 1
    names += ["labels_bits.png", "labels_coverage.png"]
    names += [f"labels_coverage_mip{j}.png" for j in range(1, n_coverage)]
    if blend:
        names.append("labels_blend.png")
    names.append("table.bin")
    return names


def coverage_count(tile_size: int) -> int:
    """Levels of the coverage texture of tiles of ``tile_size``."""
    side, n = tile_size // 4, 1
    while side % 2 == 0 and side > 1:
        side //= 2
        n += 1
    return n


def write_textures(
    form: QuadrantForm,
    entries: list[dict[str, Any]],
    blend: dict[str, float],
    normal_y: str,
    out: Any,
    files: list[str],
    write_level: Any,
    progress: Any = None,
    plans: dict[str, dict[str, float] | None] | None = None,
) -> dict[str, Any]:
    """Write the maps (full chains, each level by ``write_level(path, array)``: the exporter's, PNG or OpenEXR),
    the bits, the coverage levels, the blend coverage (when a map is blended) and the table
    into ``out``; the manifest's ``maps`` and ``labels`` entries. ``plans``: :func:`seam_plans` (None: no map
    blended)."""
    from ..builder.materials import infer_kind

    plans = plans or {}

    map_entries = []
    for k, e in enumerate(entries):
        if progress is not None:
            progress("maps", k, len(entries))
        arr = e["array"]
        enc = (e.get("encoding") or "unorm") if e["kind"] == "normal" else None
        chain = full_mip_chain(arr, e["srgb"], enc)
        ext = "exr" if arr.dtype == np.float32 else "png"
        levels = []
        for lv, a in enumerate(chain):
            fname = f"map_{e['name']}.{ext}" if lv == 0 else f"map_{e['name']}_mip{lv}.{ext}"
            write_level(out / fname, a)
            files.append(fname)
            levels.append({"level": lv, "file": fname, "width": int(a.shape[1]), "height": int(a.shape[0])})
        bands = plans.get(e["name"])
        low_levels = []
        if packs_low_band(e["kind"], int(arr.shape[2]), bands):
            for lv, a in enumerate(full_mip_chain(low_band_image(arr, int(bands["split"])), False)):
                fname = f"map_{e['name']}_low.{ext}" if lv == 0 else f"map_{e['name']}_low_mip{lv}.{ext}"
                write_level(out / fname, a)
                files.append(fname)
                low_levels.append(
                    {"level": lv, "file": fname, "width": int(a.shape[1]), "height": int(a.shape[0])}
                )
        me: dict[str, Any] = {
            "name": e["name"],
            "kind": e["kind"],
            "levels": levels,
            "channels": int(arr.shape[2]),
            "sample_type": {np.dtype(np.uint8): "uint8", np.dtype(np.uint16): "uint16"}.get(
                arr.dtype, "float32"
            ),
            "colour_space": "srgb" if e["srgb"] else "linear",
            "mips_reduced_in": "linear light" if e["srgb"] else "stored values",
            "blend_level": blend[e["name"]],
            "normal": normal_code(e, normal_y),
        }
        if bands is not None:
            me["seam"] = "blend"
            me["bands"] = {k: float(v) for k, v in bands.items()}
            if e["kind"] == "scalar":
                me["mean"] = map_mean(arr)
            if low_levels:
                me["low_band"] = {
                    "levels": low_levels,
                    "channel": 1,
                    "rule": LOW_BAND_RULE,
                }
        else:
            me["seam"] = "coverage" if blend[e["name"]] > 0 else "cut"
        if e["kind"] == "normal" or infer_kind(e["name"]) == "normal":  # as version 1: by name too
            me["normal_y"] = normal_y
        map_entries.append(me)
    if progress is not None:
        progress("maps", len(entries), len(entries))
    from ..io.images import atomic_open, save_image

    bits, bcols = pack_bits(form)
    save_image(out / "labels_bits.png", bits[:, :, None], bits=8)
    files.append("labels_bits.png")
    cov, ccols = coverage_levels(form)
    cov_levels = []
    for j, a in enumerate(cov):
        fname = "labels_coverage.png" if j == 0 else f"labels_coverage_mip{j}.png"
        save_image(out / fname, a[:, :, None], bits=8)
        files.append(fname)
        cov_levels.append({"level": j, "file": fname, "width": int(a.shape[1]), "height": int(a.shape[0])})
    blend_entry = None
    layout = blend_layout(plans, form.tile_size)
    if layout is not None:
        high, span, reach = layout
        bc, blend_cols = blend_coverage(form, high, reach, span)
        save_image(out / "labels_blend.png", bc[:, :, None], bits=16)
        files.append("labels_blend.png")
        cw, ch = blend_cell(form.tile_size, high, span)
        blend_entry = {
            "file": "labels_blend.png",
            "format": "R16F",
            "stored_as": "16-bit grey PNG of counts: upload texel = count / 4^l (l its level), exact in R16F",
            "width": int(bc.shape[1]),
            "height": int(bc.shape[0]),
            "columns": blend_cols,
            "cell": [cw, ch],
            "high_level": high,
            "reach": reach,
            "reach_levels": list(span) if span is not None else None,
            "rule": "tile t's cell at x = (t % columns) * cell[0], y = (t // columns) * cell[1]; in it, at (0, 0), "
            "the number of pixels of entry B in each 2^high_level block of the tile's labels ((N >> high_level) "
            "texels square); with reach_levels, at x = N >> high_level, level l of reach_levels[0] .. [1] stacked "
            "from y = 0 (each at y = sum of N >> k for k < l): the same of the labels with every pixel nearer than "
            "reach to the tile border given the bit of its nearest border pixel (the row's end where the row and "
            "the column are as near)",
        }
    table = pack_table(form)
    with atomic_open(out / "table.bin", "wb") as fh:
        fh.write(table.astype("<i4").tobytes())
    files.append("table.bin")
    n = form.tile_size
    labels = {
        "form": "quadrant-bit",
        "rule": "quadrant q = 2*(y >= N/2) + (x >= N/2) of tile pixel (x, y); bit b of the pixel picks entry A (0) "
        "or B (1) of the texel 4t + q of the table; pixel = map[D_s(y, x) + (by, bx)] of that entry",
        "bits": {
            "file": "labels_bits.png",
            "format": "R8UI",
            "width": int(bits.shape[1]),
            "height": int(bits.shape[0]),
            "columns": bcols,
            "cell": [n // 8, n],
            "rule": "tile t's cell at x = (t % columns) * N/8, y = (t // columns) * N; bit i of texel (x, y) of "
            "the cell is tile pixel (8x + i, y), least significant bit first",
        },
        "coverage": {
            "format": "R8",
            "columns": ccols,
            "cell": n // 4,
            "label_level_of_level_0": 2,
            "max_level": len(cov) - 1,
            "levels": cov_levels,
            "rule": "share of bit-1 pixels of tile t's 2^(j+2) blocks at level j, in a (N/4 >> j) cell at column "
            "t % columns, row t // columns; reduced per tile",
        },
        "table": {
            "file": "table.bin",
            "format": "RGBA32I",
            "width": TABLE_WIDTH,
            "height": int(table.shape[0]),
            "encoding": "int32 little-endian, rows of width texels of (code_A, bx_A, code_B, bx_B), texel 4t + q; "
            "code = (r << 19) | ((by + 32768) << 3) | s, s the symmetry D_s (tilesynth.tileset.provenance); r in "
            "half pixels from the tile centre: in code_A r_in (pixels nearer are entry B), in code_B r_out "
            "(pixels farther are entry A)",
            "bias": BIAS,
        },
    }
    if blend_entry is not None:
        labels["blend"] = blend_entry
    return {"maps": map_entries, "labels": labels}
