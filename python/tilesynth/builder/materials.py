"""Material builds: an exemplar with pixel-aligned maps (normal, height, roughness, ...) cut as one material.

A colour-only build chooses its matching patches and cuts on the albedo alone; a height map sent through the
same cuts afterwards (``synth --with``) is discontinuous wherever the albedo hid a seam that the height does not
(height cliffs along every cut). A **material build** (:func:`tilesynth.build_material`, ``tilesynth.build(img,
maps={...})``, ``tilesynth build EX --map height=H.png``) chooses them on every map jointly:

1. **Features.** Each map (and the albedo) is centred and divided by its own standard deviation (the square
   root of the sum of its channels' variances), then multiplied by ``sqrt(weight)``: a map of weight w
   contributes w times the albedo's share of every SSD and every cut weight, whatever its range or channel
   count. A normal map enters as its decoded vectors (``2·v − 1`` for unsigned encodings), a constant map not at
   all (it has nothing to match).
2. **Projection.** The stacked channels (3 + 3 + 1 + 1 = 8 for albedo, normal, height, roughness) are projected
   on their first :data:`FEATURE_CHANNELS` principal components (exact when there are no more channels than
   that), and the result is mapped into [0, 1] by one affine map common to all channels. Why: the FFT matching
   search, the objective and the cut weights cost in proportion to the channel count; 4 components keep the
   build at 1.1-1.3x the CPU time of a colour-only build (target: at most 1.5x, ``benches/materials.py``)
   while keeping most of the joint variance (recorded as ``params["material"]["variance_kept"]``: 0.90-0.96 on
   the bench's materials). One affine map for every channel keeps SSD rankings exactly (a common scale and offset
   change every SSD by the same factor); the Kwatra ``eps`` is then relative to features of an image's range.
   The feature image reaches the builder as an ordinary 4-channel float image: its 4th channel is a feature,
   never an alpha channel or a mask.
3. **Build.** The scheme's own builder runs on the feature image, unchanged: genes, matching patches, D_j, E and
   cut costs are all in feature units (recorded as such). The tile set then gets the real albedo: the exemplar
   is the albedo, and the tiles are the albedo copied through the provenance (or Poisson-smoothed in the same
   regions, for ``smooth=True``).
4. **Maps travel with the set.** Every map is stored in the tile set (``map_<name>.npy`` in its own sample type,
   with its kind and weight in ``manifest.json`` ``maps``), and :func:`synthesize_maps` lays each out through the
   same provenance and cuts as the colour (``synth``, ``export`` and ``report`` write all of them). Scalar and
   normal maps are blended across their seams by default (:func:`smooths`, :mod:`tilesynth.synth.seams`: a
   smooth map shows the level offset of two patches as a cliff that no cut avoids; near a cut the pieces that
   cover the pixel's neighbourhood are read at the pixel and weighted by their share of the tile labels'
   coverage, the low frequencies of scalar maps over a wider band and variance-preserving, so the relief keeps
   its amplitude: ``benches/relief-results.md``). ``seams="fuse"`` / ``--map-seams fuse`` selects the former
   gradient-domain fusion (:mod:`tilesynth.builder.fusion`: a first stage moves the exemplar's levels by one
   smooth correction shared by every copy of a pixel, :func:`~tilesynth.builder.fusion.exemplar_levels`, then
   the tile interior is fused with the border ring kept; it leaves no level offset but flattens rocks' relief
   to 0.2-0.3x); ``smooth=False`` / ``--map-smooth off`` gives pure copies.

**Default weights** (0.5 for scalar and normal maps, :data:`DEFAULT_WEIGHTS`). Measured on the bench's 4 derived
materials with 2 seeds each (``benches/materials.py``): with the fusion, the maps' cut seams are 0.85-1.34 whatever
the weight (0, 0.25, 0.5, 1), since the cut no longer has to hide a level offset; the albedo's cut seam (copies)
grows with the maps' weight (weight 1: 5.0-10.5, 0.5: 4.4-9.6, colour-only 4.1-8.2), and at weight 1 the cut
follows the normal map's edges so closely (the Kwatra weight divides by the feature gradients) that the normal's
score rose to 1.48-1.57 on the brick material, though its seam itself is fused away (the *reference* column: the
patches' own steps there). 0.5 keeps the maps in the joint matching and cut at about a third of the features'
variance and costs the albedo less.

**The cut of a material build** (:data:`MATERIAL_CUT_EPS`). The cut weights of ω and s-Wang are
Kwatra's, ``(‖a − b‖(s) + ‖a − b‖(t)) / (Σ‖g‖ + eps)``: the gradient normalisation makes a step along an edge of
the exemplar cheap, because a colour seam there hides in the edge. In a joint build the gradients are those of the
feature image, so the cut is drawn along the *maps'* own edges too (a normal map's crease, a roughness step), and
there nothing hides it: the maps are fused across the cut afterwards, and where the cut follows an edge that one
patch has and the other does not, the fusion's guidance is not integrable. Measured (``benches/map_levels.py``):
with the default ``eps`` = 1e-6 the s-Wang normals of pbr:tiles and bricks-red scored 1.46 / 1.45 with a
*reference* (the patches' own steps where the cut runs) of 1.14 / 1.22, most of it more than 8 px from the tile
borders; ω ``c5``'s pbr:tiles maps scored 1.52-3.14 (roughness reference 3.15: the cut along the grout). A
joint ω or s-Wang build therefore uses ``eps`` = 1, the feature image's range (typical feature gradients are
0.02-0.1, so the denominator varies by tens of per cent instead of orders of magnitude: a capped normalisation,
close to the plain difference): on seeds 1-3 of the bench's six materials (``c5``: seeds 1-2) the s-Wang maps
fall to 0.4-1.2 and ω's to 0.5-1.1, their references with them (the cut leaves the maps' edges), and so does the
albedo's own cut seam, on nearly every material (``benches/materials-results.md``, "Material cuts with a capped
gradient normalisation"); eps = 0.03 / 0.1 / 0.3 / 3 were measured too (0.3 already helps, 3 is as good as 1).
A caller's ``eps`` is kept; colour-only builds are unchanged; so are Cohen's Wang tiles (their DP path has no
gradient term) and the patch baseline (not measured).

**Map kinds** (:data:`KINDS`), inferred from the name (:func:`infer_kind`) unless given:

=========  =====================================================  ==============  ====================================
kind       meaning                                                default weight  in synthesis
=========  =====================================================  ==============  ====================================
colour     sRGB colour (albedo, base colour, emissive)            1               copied; smoothed with the colour
scalar     linear data (height, roughness, metallic, AO, ...)     0.5             blended across the seams
normal     tangent-space normal, 3 channels, Y up or down         0.5             blended, unit codes
label      mask, material ID, segmentation (any integer value)    0               exact copies, never smoothed
=========  =====================================================  ==============  ====================================

Names containing ``normal``/``nrm``/``nor`` are normals; ``mask``, ``label``, ``id``, ``segment``, ``class`` labels;
``albedo``, ``color``/``colour``, ``diffuse``, ``base``, ``emissive`` colours; everything else (``height``,
``roughness``, ``ao``, ``metallic``, ``disp``, ...) linear scalars. Labels get weight 0 by default (their values are
categories, not distances); a positive ``map_weights`` entry makes them count numerically.

**What is left in smooth maps.** The ω construction keeps the tile border ring of the intermediate tile, whose
central cross (where two sample patches meet) reaches the border at the four side midpoints; a few pixels of that
cross are outside every cut region (in every scheme with a kept border). The fusion of scalar and normal maps
treats them as seams like the cut, so inside the tile they are fused too; what is left is the cross's one pixel
pair on the border ring itself (the ring is shared with the neighbouring tile and kept by the interior fusion),
about which the fused interior bends back within a few pixels; the first (level) stage lowers that pair's step,
since it corrects the exemplar itself, every copy of a ring pixel by the same amount. With the colour's Pérez smoothing (``synth --with`` on a
``--smooth`` set, and the albedo) they stay as they are: invisible in an albedo, a small dot at each tile side
midpoint in a smooth height map.

**Normal maps.** ``normal_y`` records the Y convention of the input normals: ``"up"`` (OpenGL, green up, the
default) or ``"down"`` (DirectX). Outputs can be converted (:func:`convert_normal_y`, ``synth --normal-y``): the
green channel is negated (``max − g`` for unsigned encodings: exact for 8- and 16-bit). A normal map is *unsigned*
(values in [0, 1] encode ``2·v − 1``; every PNG) unless it has negative values (a float map of signed vectors).
Inputs whose vectors are far from unit length are normalised as engines do (:func:`inspect_normal`): a
downscaled map's short vectors renormalised, a map with z on another scale gets z rebuilt from x and y; what was
done is recorded in ``params["material"]["normalised"]`` and shown by ``tilesynth info``. Only what no
normal-map tool writes is refused (a grey image, vectors near zero, x or y not centred, z not positive), with a
message that says how to pass it as a scalar map. After smoothing, every smoothed vector is
renormalised to unit length, and every vector of every output (copies too) is re-encoded by
:func:`tilesynth.io.normal_codes.encode_unit`: decoded as ``v = code / 255 · 2 − 1`` (16-bit: ``/ 65535``), each
8- or 16-bit pixel gets the code nearest its vector among the floor / ceiling combinations whose decoded length is
within 0.0049 of 1, so 100 % of output vectors are within 1 ± 0.005 (plain rounding leaves 0.1-0.8 % outside,
up to 0.007) while the direction moves no more than rounding may.

The map kinds, :class:`MapSpec` and the checks of the inputs live in :mod:`tilesynth.builder.materials_inputs`,
the smoothed maps and the map atlases in :mod:`tilesynth.builder.materials_atlas`; both are re-exported here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError, ShapeError
from ..measure.diagnose import colour_of_build
from .materials_atlas import (  # noqa: F401 - re-exported: tilesynth.builder.materials.<name> stays the import path
    _CACHES,
    DEFAULT_SEAMS,
    FUSE_CHUNK,
    FUSED_CACHE_BYTES,
    SEAMS,
    SMOOTH_KINDS,
    _blend_sources,
    _cache,
    _chunks,
    _copied_map,
    _levelled,
    _scale,
    _used,
    blend_window,
    blend_windows,
    blended_tiles,
    fuse_map_atlas,
    fused_tiles,
    map_atlas,
    map_levels,
    map_provenance,
    seams_method,
    smooths,
    tile_sources,
)
from .materials_inputs import (  # noqa: F401 - re-exported: tilesynth.builder.materials.<name> stays the import path
    _DTYPES,
    _NAME,
    DEFAULT_WEIGHTS,
    FEATURE_CHANNELS,
    KIND_ALIASES,
    KINDS,
    MATERIAL_CUT_EPS,
    NORMAL_BAD_SHARE,
    NORMAL_MAX_CORRELATION,
    NORMAL_MAX_MEAN,
    NORMAL_MIN_LENGTH,
    NORMAL_MIN_Z,
    NORMAL_TOLERANCE,
    NORMAL_Z_SCALE,
    NORMAL_Z_SPREAD,
    MapSpec,
    _as_map_array,
    _check_normal,
    _decoded_normals,
    _kind,
    _normalised,
    _refuse_normal,
    _renormalise,
    _weight,
    check_maps,
    convert_normal_y,
    feature_image,
    infer_kind,
    inspect_normal,
    normal_lengths,
    renormalise_image,
)

__all__ = [
    "DEFAULT_WEIGHTS",
    "FEATURE_CHANNELS",
    "KINDS",
    "MATERIAL_CUT_EPS",
    "MapSpec",
    "NORMAL_TOLERANCE",
    "build_with_maps",
    "check_maps",
    "convert_normal_y",
    "feature_image",
    "infer_kind",
    "inspect_normal",
    "normal_lengths",
    "renormalise_image",
    "smooths",
    "synthesize_maps",
]


def build_with_maps(
    build: Any,
    exemplar: Any,
    *,
    maps: Any,
    map_kinds: Any = None,
    map_weights: Any = None,
    normal_y: str = "up",
    map_suffixes: dict[str, str] | None = None,
    material_options: dict[str, Any] | None = None,
    **kwargs: Any,
) -> Any:
    """A material build with the scheme builder ``build`` (``Scheme.build``): the body of
    :func:`tilesynth.build_material` (which looks the scheme up; this module does not import the registry).
    ``material_options`` (``Scheme.material_options``): builder options a joint build uses unless ``kwargs``
    give them (ω, s-Wang: ``eps`` = :data:`MATERIAL_CUT_EPS`); a colour-only build (only weight-0 maps) ignores
    them."""
    from ..synth.synthesis import is_smoothed
    from .compose import exemplar_record
    from .exemplar import Exemplar
    from .smoothing import smooth_tiles

    # The albedo, its mask (an alpha channel or mask=) and the maps are checked once, here; the builder gets an
    # Exemplar and does not check them again. The mask goes to the builder as the Exemplar's ExemplarMask: the
    # feature image's 4th channel is a feature, never an alpha channel.
    ex = Exemplar.of(
        exemplar,
        mask=kwargs.pop("mask", None),
        alpha=kwargs.pop("alpha", "auto"),
        info=kwargs.pop("exemplar_info", None),
        maps=maps,
        map_kinds=map_kinds,
        map_weights=map_weights,
        normal_y=normal_y,
        map_suffixes=map_suffixes,
    )
    albedo, specs, joint = ex.image, ex.maps or [], ex.joint
    if joint:
        feats, record = ex.features()
        for key, value in (material_options or {}).items():  # the scheme's joint-build defaults
            kwargs.setdefault(key, value)
        # the feature image is derived from the checked albedo: float32, C-contiguous, in [0, 1]
        with colour_of_build(albedo):  # the objects warning reads the albedo, not the feature image
            ts = build(Exemplar(feats, ex.mask, ex.info), **kwargs)
    else:  # only weight-0 maps (labels): the colour-only build, plus the maps
        record = {"feature_channels": int(albedo.shape[2]), "variance_kept": 1.0,
                  "feature_scale": 1.0, "albedo_weight": ex.albedo_weight}  # fmt: skip
        ts = build(ex, **kwargs)  # the builder reads the image, mask and info; the maps are added below
    if joint:
        src = ts.source
        tiles = albedo[src[..., 0], src[..., 1]]
        if is_smoothed(ts):
            from .matching.augment import matching_patches  # transformed matching patches (augment)

            matching = matching_patches(albedo, ts)
            tiles, _ = smooth_tiles(tiles, matching, ts.cut_masks, threads=kwargs.get("threads"))
        ts.tiles = np.ascontiguousarray(tiles, dtype=np.float32)
        ts.exemplar = albedo
        ts.exemplar_info = exemplar_record(albedo, ex.info)
    record = {**record, "joint": bool(joint), "units": "feature"}
    fixed = {spec.name: spec.normalised for spec, _ in specs if spec.normalised}
    if fixed:
        record["normalised"] = fixed
    ts.params = {**ts.params, "material": record}
    ts.maps = {spec.name: arr for spec, arr in specs}
    ts.map_specs = [spec.to_dict() for spec, _ in specs]
    # The level correction of the fused maps (seams="fuse") needs the whole set. It is no longer solved here:
    # the default seam blend does not use it, and solving it took half of a 512² 4-map build's CPU time (7.6 of
    # 16 s) and most of its peak memory (1843 -> 496 MB without it); a "fuse" synthesis solves it on first use
    # and keeps it with the set (stored_levels), so a set saved after that carries it.
    return ts


def synthesize_maps(
    tileset: Any,
    index_map: np.ndarray,
    width: int,
    height: int,
    *,
    threads: int | None = None,
    smooth: bool | None = None,
    normal_y: str | None = None,
    offset: tuple[int, int] = (0, 0),
    seams: str | None = None,
) -> dict[str, np.ndarray]:
    """Every map stored in a material tile set, laid out like the colour output of ``index_map``:
    ``{name: (height, width, C)}`` in each map's own sample type. ``smooth``: None (:func:`smooths`: scalar and
    normal maps, and every map of a smoothed set), True or False (labels are never smoothed); ``normal_y``: "up" / "down" converts normal maps recorded in the other
    convention (None: as recorded); ``offset = (oy, ox)``: the window starts that many pixels into the first
    cell of ``index_map`` (as :func:`tilesynth.synthesize` lays a window at any ``origin``); ``seams``: how the
    seams of smoothed scalar and normal maps are treated (:func:`seams_method`): "blend" (None, the default:
    :mod:`tilesynth.synth.seams`, relief kept) or "fuse" (the gradient-domain fusion, flatter).

    **Per window.** Only the pixels the window shows are made: copied maps are gathered from the map through the
    provenance (:func:`tilesynth.tileset.provenance.gather`), blended maps are blended straight into the window
    (:func:`blend_window`, the Rust kernel ``seam_blend``), fused maps are fused for the tiles shown (the level
    correction is solved once per set, at build time, :func:`map_levels`; recently fused tiles are cached with
    the set, :data:`FUSED_CACHE_BYTES`). The bytes are those of laying out the whole set's map atlas."""
    from .. import _core
    from ..base import kernels
    from ..base.validate import MAX_BYTES_ENV, fmt_bytes, memory_limit, positive_int, threads_arg
    from ..tileset.tilefile import TileSet

    if not isinstance(tileset, TileSet):
        raise TypeError(f"tileset is a {type(tileset).__name__}, expected a TileSet")
    if normal_y not in (None, "up", "down"):
        raise ParameterError(f"normal_y = {normal_y!r}: must be None, 'up' or 'down'")
    if smooth is not None and not isinstance(smooth, (bool, np.bool_)):
        raise ParameterError(f"smooth = {smooth!r}: must be None, True or False")
    seams = seams_method(seams)
    threads = threads_arg(threads)
    w, h = positive_int(width, "width"), positive_int(height, "height")
    specs = tileset.map_specs or []
    need = sum(h * w * int(d["channels"]) * np.dtype(d["dtype"]).itemsize for d in specs)
    if need > memory_limit(None):
        raise ParameterError(
            f"width x height = {w}x{h}: the maps need {fmt_bytes(need)}, more than the limit of "
            f"{fmt_bytes(memory_limit(None))} ({MAX_BYTES_ENV})"
        )
    imap = kernels._index_map(index_map)
    n = tileset.tile_size
    try:
        oy, ox = (int(v) for v in offset)
    except (TypeError, ValueError):
        raise ParameterError(f"offset = {offset!r}: expected (oy, ox) pixels into the first cell") from None
    if not (0 <= oy < n and 0 <= ox < n):
        raise ParameterError(f"offset = {offset!r}: each must be in [0, {n}) (the tile size)")
    if imap.ndim != 2 or imap.shape[0] * n < h + oy or imap.shape[1] * n < w + ox:
        raise ShapeError(
            f"index_map has shape {imap.shape}, expected at least ({-(-(h + oy) // n)}, {-(-(w + ox) // n)}) to "
            f"cover {w}x{h} pixels with {n}x{n} tiles"
        )
    if imap.size and (imap.min() < 0 or imap.max() >= tileset.n_tiles):
        raise ParameterError(f"index_map has tile indices outside [0, {tileset.n_tiles})")
    imap = np.ascontiguousarray(imap[: -(-(h + oy) // n), : -(-(w + ox) // n)], dtype=np.int32)
    shown = np.unique(imap)  # the tiles of the window: the only ones made
    local = np.ascontiguousarray(np.searchsorted(shown, imap), dtype=np.int32)
    prov = tileset.provenance
    out = {}
    # blended maps straight into the window, all in one call (the weights of a pixel found once for every map)
    blend = [MapSpec.from_dict(d) for d in specs]
    blend = [s for s in blend if s.kind in SMOOTH_KINDS and smooths(tileset, s, smooth) and seams == "blend"]
    windows: dict[str, np.ndarray] = {}
    if blend:
        items = [(s, tileset.maps[s.name]) for s in blend]
        windows = blend_windows(tileset, items, imap, h, w, (oy, ox), threads) or {}
    for d in specs:
        spec = MapSpec.from_dict(d)
        arr = tileset.maps[spec.name]
        img = np.empty((h, w, arr.shape[2]), arr.dtype)
        if spec.name in windows:
            img = windows[spec.name]
        elif prov is not None and not smooths(tileset, spec, smooth):
            from ..tileset.provenance import gather

            turn = (spec.encoding or "unorm", spec.normal_y == "down") if spec.kind == "normal" else None
            gather(_copied_map(tileset, spec, arr), prov, imap, img, (oy, ox), threads, turn)  # copies
        else:
            atlas = np.ascontiguousarray(
                map_atlas(tileset, spec, arr, smooth, threads, tiles=shown, seams=seams)
            )
            _core.tile_copy_window(atlas, local, (oy, ox), img, threads)
        if spec.kind == "normal" and normal_y is not None and normal_y != spec.normal_y:
            img = convert_normal_y(img, spec.encoding or "unorm")
        out[spec.name] = img
    return out


def _float_atlas(tileset: Any, spec: MapSpec, atlas: np.ndarray) -> np.ndarray:
    """A map's tiles as float64 for measuring (normals decoded to vectors, uint scaled to [0, 1])."""
    if spec.kind == "normal":
        return _decoded_normals(atlas, spec.encoding or "unorm")
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(atlas.dtype, 1.0)
    return atlas.astype(np.float64) / scale


def map_cut_seams(tileset: Any, smooth: bool | None = None) -> dict[str, float | None]:
    """The cut seam score (:func:`tilesynth.measure.metrics.cut_seam_score`) of every stored map of ``tileset``, on its
    tiles as :func:`synthesize_maps` lays them out (normals as vectors): ``{name: score or None}``."""
    from types import SimpleNamespace

    from ..measure.metrics import cut_seam_score

    out: dict[str, float | None] = {}
    for d in getattr(tileset, "map_specs", None) or []:
        spec = MapSpec.from_dict(d)
        atlas = map_atlas(tileset, spec, tileset.maps[spec.name], smooth)
        cs = cut_seam_score(
            SimpleNamespace(tiles=_float_atlas(tileset, spec, atlas), cut_masks=tileset.cut_masks)
        )
        out[spec.name] = None if cs is None else cs["score"]
    return out


def report_maps(
    tileset: Any, index_map: np.ndarray, shape: tuple[int, ...]
) -> list[tuple[str, np.ndarray, str]]:
    """For ``tilesynth report``: ``[(map name, displayable image, caption)]`` of every stored map, laid out
    like the report's sample (float maps scaled to [0, 1] for display), captions with each map's cut seam."""
    maps = synthesize_maps(tileset, index_map, int(shape[1]), int(shape[0]))
    seams = map_cut_seams(tileset)
    out = []
    for d in tileset.map_specs or []:
        a = maps[d["name"]]
        if a.dtype == np.float32:
            lo, hi = float(a.min()), float(a.max())
            a = ((a - lo) / (hi - lo) if hi > lo else np.zeros_like(a)).astype(np.float32)
        if a.shape[2] == 2:
            a = np.concatenate([a, np.zeros_like(a[..., :1])], axis=2)
        s = seams[d["name"]]
        caption = (
            f"Map {d['name']} ({d['kind']}, weight {d['weight']:g}), laid out through the same cuts as the sample; "
            f"cut seam score {'n/a' if s is None else format(s, '.3f')} (≈ 1: the cuts do not show in it)."
        )
        out.append((d["name"], a, caption))
    return out


def _with_normal_encoding(name: str, a: np.ndarray) -> str | None:
    """The encoding of a ``synth --with`` map if its name says it is a normal map and it is one, else None."""
    if infer_kind(name) != "normal" or a.ndim != 3 or a.shape[2] != 3:
        return None
    try:
        return _check_normal(name, a)
    except ParameterError:
        return None  # not unit vectors: not ours to change


def requantise_with_map(name: str, aligned: np.ndarray) -> np.ndarray:
    """For ``synth --with``: a map whose name says it is a normal map (:func:`infer_kind`), with 3 channels and
    unit vectors, with every vector re-encoded at unit length (:mod:`tilesynth.io.normal_codes`) before it is sent
    through the cuts, so that its copied pixels are within 1 ± 0.005 too; any other map is returned as it is."""
    a = np.asarray(aligned)
    encoding = _with_normal_encoding(name, a)
    return a if encoding is None else renormalise_image(a, encoding)


def turn_with_tiles(tileset: Any, name: str, aligned: np.ndarray, tiles: np.ndarray) -> np.ndarray:
    """For ``synth --with`` / ``export --with``: the tiles ``(K, N, N, 3)`` of a map whose name says it is a normal
    map (3 channels, unit vectors, +y up) with its vectors turned where a matching patch was rotated or mirrored
    (``--augment``, :func:`map_atlas`); any other map, or a set without turned patches, as it is."""
    from .matching.augment import pixel_transforms, transform_normal_codes

    encoding = _with_normal_encoding(name, np.asarray(aligned))
    turns = None if encoding is None else pixel_transforms(tileset)
    if turns is None or tiles.shape[-1] != 3:
        return tiles
    return transform_normal_codes(tiles, turns, encoding)


def turn_with_map(
    tileset: Any, name: str, aligned: np.ndarray, out: np.ndarray, index_map: np.ndarray
) -> np.ndarray:
    """:func:`turn_with_tiles` for a synthesized ``--with`` map ``out`` laid out by ``index_map``."""
    from ..base import kernels
    from .matching.augment import pixel_transforms, transform_normal_codes

    encoding = _with_normal_encoding(name, np.asarray(aligned))
    turns = None if encoding is None else pixel_transforms(tileset)
    if turns is None or out.shape[2] != 3:
        return out
    img = np.empty((*out.shape[:2], 1), np.uint8)
    kernels.tile_copy(np.ascontiguousarray(turns[..., None]), kernels._index_map(index_map), img)
    return transform_normal_codes(out, img[..., 0], encoding)


def renormalise_with_map(
    tileset: Any, name: str, aligned: np.ndarray, out: np.ndarray, index_map: np.ndarray
) -> np.ndarray:
    """For ``synth --with``: a smoothed map whose name says it is a normal map (:func:`infer_kind`), with 3
    channels and unit vectors, gets its smoothed output vectors renormalised (the pixels inside the cuts);
    any other map is returned as it is."""
    from ..base import kernels

    a = np.asarray(aligned)
    encoding = _with_normal_encoding(name, a)
    if encoding is None or out.shape[2] != 3:
        return out
    masks = np.ascontiguousarray(np.asarray(tileset.cut_masks, np.uint8)[..., None])
    inside = np.empty((*out.shape[:2], 1), np.uint8)
    kernels.tile_copy(masks, kernels._index_map(index_map), inside)
    return _renormalise(out[None], inside[None, ..., 0] == 1, encoding)[0]
