"""The maps of a material set (:mod:`tilesynth.builder.materials`): which maps are smoothed, their levels, the
fused and blended tiles, the seam treatment and the map atlases."""

from __future__ import annotations

import weakref
from typing import Any

import numpy as np

from ..errors import ParameterError
from .materials_inputs import MapSpec, renormalise_image

#: The kinds whose maps are smoothed (blended across the seams, :func:`blended_tiles`, or fused,
#: :func:`fuse_map_atlas`: :func:`seams_method`) by default, even when the albedo is not.
SMOOTH_KINDS: tuple[str, ...] = ("scalar", "normal")


def smooths(tileset: Any, spec: MapSpec, smooth: bool | None = None) -> bool:
    """Whether map ``spec`` of ``tileset`` is smoothed (scalar and normal maps: their seams blended or fused,
    :func:`seams_method`; colour maps: the colour's Poisson smoothing): never for labels; for ``smooth=None``
    (the default) when the colour tiles were smoothed, and for every scalar and normal map (:data:`SMOOTH_KINDS`)
    of every scheme (the fusion reads only the provenance's seams, so Cohen's Wang sets, without matching patches,
    are fused too). Why the maps without the albedo: the cuts of the joint build make the maps
    agree along the cut as well as the matching allows, but a smooth map (a height field) still shows the *level*
    offset between the two patches as a cliff along the curve (measured: ``benches/materials.py``, cut seam 4-15
    as copies), while the albedo, whose pixel steps are large, hides the same offset; the seam blend spreads the
    offset over the blend's width and keeps the relief (``benches/relief-results.md``), the gradient-domain
    fusion removes it (cut seam 0.85-1.34) but flattens the relief; both keep tilings seamless.
    ``smooth=False`` gives pure copies."""
    from ..synth.synthesis import is_smoothed

    if spec.kind == "label":
        return False
    if spec.kind in SMOOTH_KINDS:  # the fusion needs only the provenance's seams: every scheme (measured:
        return True if smooth is None else bool(smooth)  # Wang maps' seams were 4-43 as copies, 0.9-3.3 fused
    if smooth is None:  # a colour map: as the colour tiles were
        return bool(is_smoothed(tileset))
    if smooth and (np.asarray(tileset.match_offsets) == -1).all():  # no matching patches
        raise ParameterError(
            f"map {spec.name!r}: the tile set has no matching patches (scheme {tileset.scheme!r}), so there is "
            "no smoothing to follow; use map smoothing off"
        )
    return bool(smooth)


def _scale(arr: np.ndarray) -> float | None:
    return {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype)


def _used(tileset: Any) -> np.ndarray:
    """bool ``(H, W)``: the exemplar pixels some tile shows (the continued steps of the fusion read only those);
    found once per set, from the provenance a chunk of tiles at a time."""
    cache = _cache(tileset)
    if "used" not in cache:
        h, w = tileset.exemplar.shape[:2]
        used = np.zeros((h, w), bool)
        for part in _chunks(tileset.n_tiles, tileset.tile_size):
            src = tile_sources(tileset, part)
            used[src[..., 0], src[..., 1]] = True
        cache["used"] = used
    return cache["used"]


def _chunks(k: int, n: int) -> list[np.ndarray]:
    from ..tileset.provenance import CHUNK_PIXELS

    step = max(1, CHUNK_PIXELS // 4 // max(1, n * n))
    return [np.arange(lo, min(k, lo + step)) for lo in range(0, k, step)]


def tile_sources(tileset: Any, tiles: np.ndarray) -> np.ndarray:
    """int32 ``(k, N, N, 2)`` provenance of the tiles ``tiles`` (indices): from ``source`` when the set holds it,
    else gathered from its provenance (a version-2 set), without materialising the other tiles."""
    if tileset.provenance is not None and not tileset.has_pixels():
        from ..tileset.provenance import coordinate_grid, materialise

        cache = _cache(tileset)
        if "grid" not in cache:
            cache["grid"] = coordinate_grid(*tileset.exemplar.shape[:2])
        return materialise(cache["grid"], tileset.provenance, tiles)
    return tileset.source[np.asarray(tiles)]


_CACHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _cache(tileset: Any) -> dict[str, Any]:
    """The per-set cache of map synthesis (the used pixels, each map's levelled values, fused tiles): computed
    once per set, never per call; kept beside the set object (a shallow copy of a set gets its own)."""
    cache = _CACHES.get(tileset)
    if cache is None:
        cache = _CACHES[tileset] = {}
    return cache


def map_levels(tileset: Any, names: list[str] | None = None) -> dict[str, np.ndarray]:
    """The first stage of the seam treatment of every fused map (scalar and normal kinds) of ``tileset``: the
    solved block and corner levels of :func:`~tilesynth.builder.fusion.level_solution` per map, and the corner
    pixels (``"corners"``, shared by every map), as a set keeps them (:attr:`TileSet.map_levels`).
    The solve needs the whole set (every tile's provenance and copies); it is done once per set, on the first
    fused synthesis (``seams="fuse"``, not the default), and every later window reads the result
    (:func:`synthesize_maps`)."""
    from .fusion import LEVEL_BLOCK, level_solution

    out: dict[str, np.ndarray] = {}
    for d in tileset.map_specs or []:
        spec = MapSpec.from_dict(d)
        if spec.kind not in SMOOTH_KINDS or (names is not None and spec.name not in names):
            continue
        arr = tileset.maps[spec.name]
        if arr.dtype == np.float32 and not np.isfinite(arr).all():
            continue  # not fusable (synthesize_maps refuses it with smoothing on)
        scale = _scale(arr)
        f = arr.astype(np.float64) / (scale or 1.0)
        src = tileset.source
        copies = arr[src[..., 0], src[..., 1]].astype(np.float64) / (scale or 1.0)
        x, own = level_solution(f, copies, src, _used(tileset), LEVEL_BLOCK)
        out[spec.name] = x
        out["corners"] = own
    return out


def _levelled(tileset: Any, spec: MapSpec, arr: np.ndarray) -> np.ndarray:
    """The map's values in [0, 1] float64 plus its level correction ``φ`` (the fusion's first stage), once per
    set: from the stored levels (:attr:`TileSet.map_levels`), else solved now and kept with the set."""
    from .fusion import LEVEL_BLOCK, level_field

    cache = _cache(tileset)
    key = ("levelled", spec.name)
    if (
        key not in cache or cache[key][0] is not arr
    ):  # the map itself, kept alive: a replaced map is not reused
        levels = tileset.map_levels or {}
        if spec.name not in levels:
            levels = {**levels, **map_levels(tileset, [spec.name])}
            tileset.map_levels = levels
        f = arr.astype(np.float64) / (_scale(arr) or 1.0)
        cache[key] = (arr, f + level_field(levels[spec.name], levels["corners"], f.shape, LEVEL_BLOCK))
        lru = cache.get("fused")
        for k in [k for k in (lru or {}) if len(k) == 2 and k[0] == spec.name]:
            cache["fused_bytes"] -= lru.pop(k).nbytes
    return cache[key][1]


FUSED_CACHE_BYTES = 64 << 20
"""Bytes of fused map tiles kept per set (least recently used first out): a window's tiles are fused once,
then reused by every window that shows them."""

FUSE_CHUNK = 32
"""Tiles fused at once (:func:`fused_tiles`): the solve holds about 10 float64 copies of a chunk."""


def fused_tiles(tileset: Any, spec: MapSpec, arr: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """The tiles ``tiles`` of map ``arr`` fused across their seams (:func:`fuse_map_atlas`, the same bytes) in the
    map's sample type, computed for those tiles only (the fusion of one tile reads the levelled map and that
    tile's provenance), normal maps renormalised; recently fused tiles come from the set's cache."""
    from collections import OrderedDict

    from ..synth.synthesis import check_smoothable
    from .fusion import fuse_tiles

    check_smoothable(arr)
    cache = _cache(tileset)
    lru: OrderedDict = cache.setdefault("fused", OrderedDict())
    tiles = np.asarray(tiles, np.int64).reshape(-1)
    levelled = _levelled(tileset, spec, arr)  # first: a replaced map drops its fused tiles
    missing = [int(t) for t in tiles if (spec.name, int(t)) not in lru]
    if missing:
        used = _used(tileset)
        scale = _scale(arr)
        for lo in range(0, len(missing), FUSE_CHUNK):
            part = np.array(missing[lo : lo + FUSE_CHUNK])
            src = tile_sources(tileset, part)
            fused = fuse_tiles(levelled, levelled[src[..., 0], src[..., 1]], src, used)
            if scale:
                fused = np.rint(np.clip(fused, 0.0, 1.0) * scale).astype(arr.dtype)
            else:
                fused = fused.astype(np.float32)
            if spec.kind == "normal":
                fused = renormalise_image(fused, spec.encoding or "unorm")
            for t, tile in zip(part, fused):
                lru[(spec.name, int(t))] = np.ascontiguousarray(tile)
                cache["fused_bytes"] = cache.get("fused_bytes", 0) + tile.nbytes
    out = np.stack([lru[(spec.name, int(t))] for t in tiles]) if tiles.size else np.zeros((0,) + arr.shape)
    for t in tiles:
        lru.move_to_end((spec.name, int(t)))
    while cache.get("fused_bytes", 0) > FUSED_CACHE_BYTES and len(lru) > tiles.size:
        _, old = lru.popitem(last=False)
        cache["fused_bytes"] -= old.nbytes
    return out


SEAMS: tuple[str, ...] = ("blend", "fuse")
"""How the seams of smoothed scalar and normal maps are treated (:func:`seams_method`)."""

DEFAULT_SEAMS = "blend"
"""The default seam treatment: the blend from the labels' coverage (:mod:`tilesynth.synth.seams`), which keeps the
relief (measured, ``benches/relief-results.md``: height std 0.9-1.0x of the exemplar's, cliffs at or below the
exemplar's own) where the fusion flattens it (0.2-0.8x); and it is local, so the GPU can do the same."""


def seams_method(seams: Any) -> str:
    """The seam treatment ``seams`` names: None (:data:`DEFAULT_SEAMS`), "blend" or "fuse"."""
    if seams is None:
        return DEFAULT_SEAMS
    if not isinstance(seams, str) or seams not in SEAMS:
        raise ParameterError(f"seams = {seams!r}: expected None, {' or '.join(repr(v) for v in SEAMS)}")
    return seams


def map_provenance(tileset: Any) -> Any:
    """The labels and source table the seam blend reads: the set's provenance, or for a set held as pixels the
    factorisation of its ``source`` (also for Poisson-smoothed sets, whose maps are laid out from the same
    sources), found once per set; None when some tile has more than 255 pieces (the fusion is used then)."""
    if tileset.provenance is not None:
        return tileset.provenance
    cache = _cache(tileset)
    src = tileset.source
    if "prov" not in cache or cache["prov"][0] is not src:
        from ..tileset.provenance import factorise
        from .matching.augment import pixel_transforms

        cache["prov"] = (src, factorise(src, orient=pixel_transforms(tileset)))
    return cache["prov"][1]


def _blend_sources(tileset: Any, spec: MapSpec, arr: np.ndarray) -> tuple:
    """What the seam blend of a map reads, once per set: ``(codes, values, low, mu, bands)``: the map's samples
    as the copies read them (normal maps renormalised), a normal map's slopes (float64; None for a scalar map,
    whose samples over their maximum the kernel blends from the codes), the low band's mip (or None), the map's
    mean, the bands for the set's tile size (:func:`tilesynth.synth.seams.tile_bands`)."""
    from ..synth import seams

    cache = _cache(tileset)
    key = ("blend", spec.name)
    if key not in cache or cache[key][0] is not arr:
        codes = _copied_map(tileset, spec, arr)
        bands = seams.tile_bands(seams.check_bands(None, spec.kind), tileset.tile_size)
        if spec.kind == "normal":
            values = np.ascontiguousarray(seams.normal_slopes(codes, spec.encoding or "unorm"))
        else:
            values = codes.astype(np.float64) / (_scale(arr) or 1.0)
        low = None
        if "low" in bands:  # the low band at every exemplar pixel: the kernel reads one value per entry
            split = int(bands["split"])
            grid = np.mgrid[0 : values.shape[0], 0 : values.shape[1]].transpose(1, 2, 0)
            low = np.ascontiguousarray(seams.sample_mip(seams.box_mip(values, split), split, grid))
        mu = values.reshape(-1, values.shape[2]).mean(axis=0)
        if (
            spec.kind != "normal"
        ):  # the kernel reads a scalar map's codes, its low band and mean, not the values
            values = None  # (float64: 8 bytes a sample kept per set for nothing, 100 MB for a 2K RGB map)
        cache[key] = (arr, (codes, values, low, mu, bands))
    return cache[key][1]


def blend_windows(
    tileset: Any,
    items: list[tuple[MapSpec, np.ndarray]],
    index_map: np.ndarray,
    height: int,
    width: int,
    offset: tuple[int, int] = (0, 0),
    threads: int | None = None,
) -> dict[str, np.ndarray] | None:
    """The windows ``{name: (height, width, C)}`` of maps ``items`` (``[(spec, array)]``, scalar and normal maps
    whose bands share the high band, and the scalar ones the low band) laid out by ``index_map`` at ``offset``
    with their seams blended (:mod:`tilesynth.synth.seams`; the Rust kernel ``seam_blend``, whose oracle is
    :func:`tilesynth.synth.seams.blend_tiles`), each in its sample type. All the maps are blended in one call:
    the weights of a pixel are found once for every map, the copies and the encoding (the normals' unit-length
    codes too) written by the kernel straight into the windows; the vectors of a normal map's rotated or
    mirrored entries (``--augment``) turned with them. None when the set has no provenance or ``items`` is
    empty."""
    from .. import _core
    from ..io.normal_codes import vector_turns

    prov = map_provenance(tileset)
    if prov is None or not items:
        return None
    turned = bool((prov.table[..., 0] > 0).any())
    srcs = [_blend_sources(tileset, spec, arr) for spec, arr in items]
    high = {x[4]["high"] for x in srcs}
    low = {(x[4].get("low"), x[4].get("reach")) for (spec, _), x in zip(items, srcs) if spec.kind == "scalar"}
    if len(high) > 1 or len(low) > 1:
        raise ValueError("blend_windows: the maps' bands differ; blend them apart")
    low_level, reach = low.pop() if low else (None, None)
    imap = np.ascontiguousarray(index_map, dtype=np.int32)
    result, maps, turns = {}, [], []
    for (spec, arr), (codes, values, lows, mu, _) in zip(items, srcs):
        turn = vector_turns(spec.normal_y == "down") if spec.kind == "normal" and turned else None
        turns.append(None if turn is None else np.ascontiguousarray(turn, np.int8))
        kind = "scalar" if spec.kind == "scalar" else "normal-snorm" if spec.encoding == "snorm" else "normal"
        img = np.empty((height, width, arr.shape[2]), arr.dtype)
        scalar = kind == "scalar"  # the kernel blends a scalar map's samples over their maximum (its values)
        maps.append(
            (kind, None if scalar else values, lows if scalar else None, [float(m) for m in mu], codes, img)
        )
        result[spec.name] = img
    _core.seam_blend(
        maps, prov.labels, prov.table, imap, offset, float(high.pop()),
        None if low_level is None else float(low_level), int(reach or 1), threads, turns,
    )  # fmt: skip
    return result


def blend_window(
    tileset: Any,
    spec: MapSpec,
    arr: np.ndarray,
    index_map: np.ndarray,
    height: int,
    width: int,
    offset: tuple[int, int] = (0, 0),
    threads: int | None = None,
) -> np.ndarray | None:
    """:func:`blend_windows` of one map: its window ``(height, width, C)``, or None."""
    got = blend_windows(tileset, [(spec, arr)], index_map, height, width, offset, threads)
    return None if got is None else got[spec.name]


def blended_tiles(tileset: Any, spec: MapSpec, arr: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """The tiles ``tiles`` ``(k, N, N, C)`` of map ``arr`` (scalar or normal kind) of a set with a provenance,
    with their seams blended, in the map's sample type: :func:`blend_window` of a one-column index map, a
    bounded chunk of tiles at a time."""
    n = tileset.tile_size
    idx = np.asarray(tiles, np.int64).reshape(-1)
    out = np.empty((idx.size, n, n, arr.shape[2]), arr.dtype)
    step = max(1, (1 << 20) // (n * n))  # a bounded chunk: about 1 Mi pixels per call
    for lo in range(0, idx.size, step):
        part = idx[lo : lo + step]
        got = blend_window(tileset, spec, arr, part.reshape(-1, 1), part.size * n, n)
        if got is None:
            raise ValueError("blended_tiles: the tile set has no provenance (a version-1 set; use map_atlas)")
        out[lo : lo + part.size] = got.reshape(part.size, n, n, arr.shape[2])
    return out


def fuse_map_atlas(
    tileset: Any, arr: np.ndarray, atlas: np.ndarray, level: bool = True, spec: MapSpec | None = None
) -> np.ndarray:
    """The tiles ``atlas`` of map ``arr`` fused across their seams in the gradient domain, in the map's own
    sample type (:mod:`tilesynth.builder.fusion`), in two stages: ``level=True`` (the default) first adds the
    exemplar's smooth level correction (:func:`~tilesynth.builder.fusion.exemplar_levels`: every copy of an
    exemplar pixel moves alike, so tilings stay seamless and tile borders do not crease), then each tile's
    interior is fused with its border ring kept (:func:`~tilesynth.builder.fusion.fuse_tiles`); ``level=False``:
    the second stage alone (the border ring as copied, bit for bit). The continued steps across a seam only
    read exemplar pixels the tile set uses somewhere (so never a masked one).

    With rotated or mirrored matching patches (``--augment``,
    :func:`~tilesynth.builder.matching.augment.pixel_transforms`) the steps follow each patch's orientation, and
    for a normal map (``spec`` of kind normal; ``atlas`` already turned, :func:`map_atlas`) the continued steps
    are turned into the tile's frame too; the level stage is then left out for normal maps, since one level of
    an exemplar pixel would have to be turned differently in each of its copies."""
    from ..synth.synthesis import check_smoothable
    from .fusion import LEVEL_BLOCK, exemplar_levels, fuse_tiles
    from .matching.augment import pixel_transforms, transform_vectors

    check_smoothable(arr)
    src = tileset.source
    used = np.zeros(arr.shape[:2], bool)
    used[src[..., 0], src[..., 1]] = True
    turns = pixel_transforms(tileset)
    turn = None
    if turns is not None and spec is not None and spec.kind == "normal":
        y_down = spec.normal_y == "down"

        def turn(step: np.ndarray, t: np.ndarray) -> np.ndarray:
            return transform_vectors(step, t, y_down)

        level = False
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(arr.dtype)
    f = arr.astype(np.float64) / (scale or 1.0)
    copies = atlas.astype(np.float64) / (scale or 1.0)
    if level:  # the exemplar's smooth level correction first (ring included), then each tile's interior
        phi = exemplar_levels(f, copies, src, used, LEVEL_BLOCK, turns=turns)
        f = f + phi
        copies = copies + phi[src[..., 0], src[..., 1]]
    fused = fuse_tiles(f, copies, src, used, turns=turns, turn=turn)
    if scale:
        return np.ascontiguousarray(np.rint(np.clip(fused, 0.0, 1.0) * scale).astype(arr.dtype))
    return np.ascontiguousarray(fused, dtype=np.float32)


def map_atlas(
    tileset: Any,
    spec: MapSpec,
    arr: np.ndarray,
    smooth: bool | None = None,
    threads: int | None = None,
    tiles: np.ndarray | None = None,
    seams: str | None = None,
) -> np.ndarray:
    """The tiles ``(k, N, N, C)`` of one map of ``tileset`` (``tiles``: their indices; None: every tile): copied
    through the provenance, or where :func:`smooths` says so (never for labels) scalar and normal maps with
    their seams treated by ``seams`` (:func:`seams_method`: "blend", the default, :func:`blended_tiles`;
    "fuse", the gradient-domain fusion below) and colour maps Poisson-smoothed in the cut regions, normal
    vectors renormalised. With ``seams="fuse"`` scalar and normal maps are fused for the tiles
    asked only (:func:`fused_tiles`, the bytes of :func:`fuse_map_atlas`); a colour map of a Poisson-smoothed set
    needs the whole set. The vectors of a normal map are turned with their pixels where a matching patch was
    rotated or mirrored (``--augment``: :func:`~tilesynth.builder.matching.augment.transform_normal_codes`, exact
    in the map's sample type; the blend and the copies turn them per entry), so a bump keeps its light side; fused
    (``seams="fuse"``), such sets take the whole-set path, whose fusion follows each patch's orientation (the
    per-tile path does not turn steps)."""
    from ..synth.synthesis import _smooth_map_atlas
    from .matching.augment import pixel_transforms, transform_normal_codes

    idx = np.arange(tileset.n_tiles) if tiles is None else np.asarray(tiles, np.int64).reshape(-1)
    if (
        spec.kind in SMOOTH_KINDS
        and smooths(tileset, spec, smooth)
        and seams_method(seams) == "blend"
        and map_provenance(tileset) is not None
    ):  # the default: the seam blend from the labels (rotated or mirrored entries are turned by the blend)
        return blended_tiles(tileset, spec, arr, idx)
    turns = pixel_transforms(tileset)
    if not smooths(tileset, spec, smooth):  # copies: of the map with its vectors renormalised once per set
        src = tile_sources(tileset, idx)
        copies = np.ascontiguousarray(_copied_map(tileset, spec, arr)[src[..., 0], src[..., 1]])
        if turns is not None and spec.kind == "normal":  # as the gather turns them: with their patch
            copies = transform_normal_codes(
                copies, turns[idx], spec.encoding or "unorm", spec.normal_y == "down"
            )
        return copies
    if turns is not None:  # rotated or mirrored patches: every step and vector turns with its patch
        src = tileset.source
        atlas = np.ascontiguousarray(arr[src[..., 0], src[..., 1]])
        if spec.kind == "normal":
            atlas = transform_normal_codes(atlas, turns, spec.encoding or "unorm", spec.normal_y == "down")
        if spec.kind in SMOOTH_KINDS:
            atlas = fuse_map_atlas(tileset, arr, atlas, spec=spec)
        else:  # colour maps follow the colour's own smoothing
            atlas = _smooth_map_atlas(tileset, arr, atlas, threads)
        atlas = atlas if tiles is None else atlas[idx]
    elif spec.kind in SMOOTH_KINDS:
        return fused_tiles(tileset, spec, arr, idx)
    else:  # colour maps follow the colour's own smoothing (version-1 sets only)
        src = tileset.source
        atlas = _smooth_map_atlas(tileset, arr, np.ascontiguousarray(arr[src[..., 0], src[..., 1]]), threads)
        atlas = atlas if tiles is None else atlas[idx]
    if spec.kind == "normal":  # every vector, copies too: unit length after decoding (normal_codes)
        atlas = renormalise_image(atlas, spec.encoding or "unorm")
    return atlas


def _copied_map(tileset: Any, spec: MapSpec, arr: np.ndarray) -> np.ndarray:
    """What the copies of a map read: the map itself, or for a normal map the map with every vector renormalised
    (:func:`renormalise_image`, the same bytes as renormalising the copies), once per set."""
    if spec.kind != "normal":
        return arr
    cache = _cache(tileset)
    key = ("unit", spec.name)
    if key not in cache or cache[key][0] is not arr:
        cache[key] = (arr, np.ascontiguousarray(renormalise_image(arr, spec.encoding or "unorm")))
    return cache[key][1]
