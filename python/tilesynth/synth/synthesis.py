"""Synthesis: lay the tiles of a :class:`~tilesynth.tileset.tilefile.TileSet` into an image of any size.

The tiling rule (scan-line, seeded, see :mod:`tilesynth.layouts.scanline`) fills an index map of ⌈H/N⌉ x ⌈W/N⌉ cells; the
Rust kernel copies tile rows into a preallocated output (the last row and column of tiles are cropped).

**Output size guard.** The output is one array in memory, so a size that cannot fit is refused *up front* with
the estimate (:func:`synthesis_bytes`), instead of dying in numpy or, worse, being killed by the kernel's OOM
killer halfway through (``np.empty`` of 120 GB succeeds on Linux: memory is only committed when written).
The limit (:func:`memory_limit`) is half the physical memory by default, or ``max_bytes`` /
``TILESYNTH_MAX_BYTES``. We refuse rather than stream to disk: the API returns an array, and a texture that
does not fit in memory is better produced in pieces with explicit index maps (``index_map`` of any window of
a bigger map gives the matching piece).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..base import kernels
from ..base.validate import (
    MAX_BYTES_ENV,
    fmt_bytes,
    memory_limit,
    positive_int,
    seed_int,
    threads_arg,
    to_uint,
)
from ..builder.smoothing import smooth_tiles
from ..errors import ParameterError, ShapeError
from ..layouts.scanline import scanline_index_map, validate_index_map

if TYPE_CHECKING:  # synthesis reads tile sets, the file format does not concern it (and TileSet.synthesize
    from ..tileset.tilefile import TileSet  # calls here: a runtime import would be a cycle)

#: The fields synthesis reads: anything with them is a tile set here (a :class:`~tilesynth.tileset.tilefile.TileSet`).
_TILESET_FIELDS = ("tiles", "source", "cut_masks", "match_offsets", "layout", "params", "exemplar")


def _require_tileset(tileset: Any) -> None:
    names = set(dir(tileset))  # not hasattr: reading ``tiles`` would materialise a provenance set's atlas
    if not all(f in names for f in _TILESET_FIELDS):
        raise TypeError(f"tileset is a {type(tileset).__name__}, expected a TileSet (tilesynth.load(path))")


def synthesis_bytes(
    tileset: TileSet, width: int, height: int, dtype: Any = np.float32, out: bool = True
) -> int:
    """Estimated peak bytes of :func:`synthesize`: the output ``height x width x C`` of ``dtype`` (unless the
    caller gives ``out``), the index map with the tiler's working memory
    (:data:`tilesynth.layouts.scanline.TILER_BYTES_PER_CELL` a cell), and the atlas converted to ``dtype``."""
    from ..layouts.scanline import TILER_BYTES_PER_CELL

    n = tileset.tile_size
    cells = -(-int(height) // n) * -(-int(width) // n)
    item = np.dtype(dtype).itemsize
    total = cells * TILER_BYTES_PER_CELL + _atlas_size(tileset) * item
    if out:
        total += int(height) * int(width) * tileset.channels * item
    return total


def _from_provenance(tileset: TileSet) -> bool:
    """Whether synthesis gathers from the exemplar through the provenance (a version-2 set whose tiles are not
    in memory) instead of copying tiles."""
    return getattr(tileset, "provenance", None) is not None and not tileset.has_pixels()


def _atlas_size(tileset: TileSet) -> int:
    """Elements of what a synthesis reads: the exemplar for a provenance set, else the tiles."""
    return int(tileset.exemplar.size) if _from_provenance(tileset) else int(tileset.tiles.size)


def check_size(
    tileset: TileSet,
    width: int,
    height: int,
    dtype: Any = np.float32,
    out: bool = True,
    max_bytes: int | None = None,
    copies: int = 1,
) -> int:
    """Refuse (:class:`ParameterError`) a synthesis whose estimate times ``copies`` exceeds the memory limit.

    Returns the estimate. ``copies`` counts whole extra copies of the output the caller will make (the CLI's
    PNG encoder makes one)."""
    est = synthesis_bytes(tileset, width, height, dtype, out)
    est += (copies - 1) * int(height) * int(width) * tileset.channels * np.dtype(dtype).itemsize
    limit = memory_limit(max_bytes)
    if est > limit:
        raise ParameterError(
            f"width x height = {width}x{height}: the output needs about {fmt_bytes(est)} ({width}x{height}x"
            f"{tileset.channels} {np.dtype(dtype)} and the tile index map), more than the limit of "
            f"{fmt_bytes(limit)} (max_bytes / {MAX_BYTES_ENV}; default half the physical memory). "
            "Synthesize smaller pieces with explicit index maps"
        )
    return est


# Length: 80 lines, of which 20 are the docstring; the code is 60.
def synthesize(
    tileset: TileSet,
    width: int,
    height: int,
    seed: int | None = None,
    index_map: np.ndarray | None = None,
    dtype: Any = np.float32,
    threads: int | None = None,
    out: np.ndarray | None = None,
    max_bytes: int | None = None,
    origin: tuple[int, int] = (0, 0),
    wrap: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Synthesize a ``height`` x ``width`` texture.

    Parameters
    ----------
    tileset : the tile set.
    width, height : output size in pixels (any positive size; tiles at the right and bottom are cropped).
    seed : seed of the scan-line tiler (None draws one). Ignored when ``index_map`` is given.
    index_map : optional int ``(rows, cols)`` map of tile indices to use instead of the tiler; it is checked
        against the tile set's matching rule and must cover the output.
    dtype : ``numpy.float32`` (values in [0, 1]), ``numpy.uint8`` or ``numpy.uint16``.
    threads : copy threads (None: ``TILESYNTH_NUM_THREADS`` or all cores).
    out : optional preallocated C-contiguous ``(height, width, C)`` array of ``dtype`` to write into.
    max_bytes : refuse (:class:`ParameterError`, with the estimate) if the synthesis would need more memory
        than this; default :func:`memory_limit` (see the module docstring).
    origin : ``(x0, y0)``, any integers: the top-left pixel of the window of the infinite texture to return.
        Complete sets (``c3x2``, ``wc2``, ...: :mod:`tilesynth.layouts.complete`) are laid by the hashed lookup
        (:mod:`tilesynth.layouts.hashed`): every window is the same crop of one infinite texture, computed in time
        proportional to the window. Other sets only take ``(0, 0)`` (:class:`ParameterError` otherwise).
    wrap : complete sets: make the output periodic with its own size (a multiple of the tile size), for a
        REPEAT sampler. Seeds of the hashed lookup are in [0, 2^32).

    Returns
    -------
    image : ``(height, width, C)`` of ``dtype``.
    index_map : int32 ``(rows, cols)``, the tile of every cell.
    """
    _require_tileset(tileset)
    w = positive_int(width, "width")
    h = positive_int(height, "height")
    threads = threads_arg(threads)
    try:
        dt = np.dtype(dtype)
    except TypeError:
        raise ParameterError(f"dtype = {dtype!r}: must be float32, uint8 or uint16") from None
    if dt not in (np.float32, np.uint8, np.uint16):
        raise ParameterError(f"dtype = {dt}: must be float32, uint8 or uint16")
    check_size(tileset, w, h, dt, out is None, max_bytes)
    from ..layouts.hashed import hashed_scheme

    scheme = hashed_scheme(tileset, origin, wrap, index_map)  # complete sets: the hashed lookup
    n = tileset.tile_size
    rows, cols = -(-h // n), -(-w // n)
    defn = tileset.definition
    if scheme is not None:
        imap = None
    elif index_map is None:
        imap = scanline_index_map(defn, rows, cols, seed_int(seed))
    else:
        imap = np.asarray(index_map)
        if imap.ndim != 2 or not np.issubdtype(imap.dtype, np.integer):
            raise ShapeError(
                f"index_map has shape {imap.shape} and dtype {imap.dtype}, expected an integer 2-d map"
            )
        if imap.shape[0] < rows or imap.shape[1] < cols:
            raise ShapeError(
                f"index_map has shape {imap.shape}, expected at least ({rows}, {cols}) to cover {w}x{h} "
                f"pixels with {n}x{n} tiles"
            )
        try:
            validate_index_map(defn, imap)
        except ValueError as exc:
            raise ParameterError(f"index_map: {exc}") from None
    if imap is not None:
        imap = np.ascontiguousarray(imap, dtype=np.int32)
    lazy = _from_provenance(tileset)
    image = tileset.exemplar if lazy else tileset.tiles  # to_uint is per pixel: converting either is the same
    if dt == np.float32:
        atlas = image
    elif dt == np.uint8:
        atlas = to_uint(image, 8)
    else:
        atlas = to_uint(image, 16)
    shape = (h, w, tileset.channels)
    if out is None:
        out = np.empty(shape, dt)
    elif (
        not isinstance(out, np.ndarray)
        or out.shape != shape
        or out.dtype != dt
        or not out.flags.c_contiguous
        or not out.flags.writeable
    ):
        raise ShapeError(
            f"out has shape {np.shape(out)} and dtype {getattr(out, 'dtype', type(out).__name__)}, expected a "
            f"writeable C-contiguous {shape} {dt} array"
        )
    if scheme is not None:
        from ..layouts.hashed import synthesize_hashed

        copy = _gatherer(tileset, atlas, threads) if lazy else None
        return out, synthesize_hashed(
            tileset, scheme, w, h, seed, origin, wrap, atlas, out, threads, copy=copy
        )
    if lazy:
        _gatherer(tileset, atlas, threads)(imap, (0, 0), out)
    else:
        kernels.tile_copy(atlas, imap, out, threads=threads)
    return out, imap


def _gatherer(tileset: TileSet, image: np.ndarray, threads: int | None) -> Any:
    """``copy(index_map, (oy, ox), out)`` laying a window from ``image`` (the exemplar in the output's dtype)
    through the set's provenance (:func:`tilesynth.tileset.provenance.gather`)."""
    from ..tileset.provenance import gather

    def copy(imap: np.ndarray, offset: tuple[int, int], out: np.ndarray) -> None:
        gather(image, tileset.provenance, imap, out, offset, threads=threads)

    return copy


def source_map(
    tileset: TileSet, index_map: np.ndarray, width: int, height: int, max_bytes: int | None = None
) -> np.ndarray:
    """Exemplar (row, col) of every output pixel: int32 ``(height, width, 2)`` (provenance of a synthesis).

    Refused up front, like :func:`synthesize`, when the ``height x width x 8`` bytes exceed the memory limit.
    """
    _require_tileset(tileset)
    w = positive_int(width, "width")
    h = positive_int(height, "height")
    need, limit = h * w * 8, memory_limit(max_bytes)
    if need > limit:
        raise ParameterError(
            f"width x height = {w}x{h}: the source map needs {fmt_bytes(need)}, more than the limit of "
            f"{fmt_bytes(limit)} (max_bytes / {MAX_BYTES_ENV})"
        )
    out = np.empty((h, w, 2), np.int32)
    if _from_provenance(tileset):
        from ..tileset.provenance import coordinate_grid, gather

        gather(
            coordinate_grid(*tileset.exemplar.shape[:2]),
            tileset.provenance,
            kernels._index_map(index_map),
            out,
        )
        return out
    kernels.tile_copy(tileset.source, kernels._index_map(index_map), out)
    return out


def is_smoothed(tileset: TileSet) -> bool:
    """Whether the tile set's colour tiles were Poisson-smoothed (built with ``smooth=True``: the solver's record
    is in ``params["smooth"]``, whatever the scheme)."""
    return isinstance(tileset.params.get("smooth"), dict)


def synthesize_map(
    tileset: TileSet,
    aligned: np.ndarray,
    index_map: np.ndarray,
    width: int,
    height: int,
    threads: int | None = None,
    smooth: bool | None = None,
    max_bytes: int | None = None,
) -> np.ndarray:
    """Synthesize a map aligned with the exemplar (normal, height, roughness, a second photo, ...) with exactly
    the cuts and layout of a colour synthesis.

    Every tile pixel came from one exemplar pixel (the provenance ``tileset.source``); the map's tile atlas
    takes the map's value at that pixel, and the index map of the colour output lays it out. So output pixel
    (y, x) of the map is ``aligned[source_map(...)[y, x]]``: pixel-aligned with the colour output, and a pure
    copy of map values (no resampling, no conversion: uint8, uint16 and float32 stay what they are).

    **Smoothed tile sets.** If the colour tiles were Poisson-smoothed (``build_omega(smooth=True)``), the map's
    tiles get the same treatment by default (``smooth=None``): the region inside each cut is the guided
    interpolation of the map's matching patch, with the map's pixels next to the cut as the boundary, so the
    map has no seam where the colour has none. The map's values inside the regions are then computed (in
    float32: uint8 / uint16 scaled to [0, 1], solved, clipped to [0, 1] and rounded back; float32 maps solved as
    they are, not clipped), and outside the regions they are still pure copies. Each channel is interpolated
    on its own: a normal map comes out approximately, not exactly, unit-length inside the regions. Pass
    ``smooth=False`` for maps that must never be blended (labels, masks, IDs), or for float maps with NaN or
    infinity. ``smooth=True`` on a set that was not smoothed is an error (there is nothing to follow).

    Parameters
    ----------
    tileset : the tile set the colour output was synthesized with.
    aligned : ``(H, W)`` or ``(H, W, C)`` uint8, uint16 or float32 array with the exemplar's H x W.
    index_map : the tile index map of the colour output (as returned by :func:`synthesize`).
    width, height : the output size (that of the colour output).
    threads : copy (and smoothing) threads.
    smooth : None (default: smooth if and only if the tile set's colour tiles were smoothed), True or False.
    max_bytes : refuse (:class:`ParameterError`) an output larger than this, as :func:`synthesize` does.

    Returns
    -------
    ``(height, width, C)`` array of ``aligned``'s dtype.
    """
    _require_tileset(tileset)
    a = np.asarray(aligned)
    if a.ndim == 2:
        a = a[:, :, None]
    eh, ew = tileset.exemplar.shape[:2]
    if a.ndim != 3 or a.shape[:2] != (eh, ew) or a.shape[2] < 1:
        raise ShapeError(
            f"map has shape {np.asarray(aligned).shape}, expected ({eh}, {ew}) or ({eh}, {ew}, C): it must be "
            "pixel-aligned with the exemplar"
        )
    if a.dtype not in (np.uint8, np.uint16, np.float32):
        raise ParameterError(f"map has dtype {a.dtype}, expected uint8, uint16 or float32")
    smoothed_set = is_smoothed(tileset)
    if smooth is None:
        smooth = smoothed_set
    elif not isinstance(smooth, (bool, np.bool_)):
        raise ParameterError(f"smooth = {smooth!r}: must be None, True or False")
    elif smooth and not smoothed_set:
        raise ParameterError(
            "smooth = True: the tile set was not Poisson-smoothed (build it with smooth=True / --smooth), so "
            "there is no smoothing for the map to follow"
        )
    w = positive_int(width, "width")
    h = positive_int(height, "height")
    need, limit = h * w * a.shape[2] * a.dtype.itemsize, memory_limit(max_bytes)
    if need > limit:
        raise ParameterError(
            f"width x height = {w}x{h}: the map needs {fmt_bytes(need)}, more than the limit of {fmt_bytes(limit)} "
            f"(max_bytes / {MAX_BYTES_ENV})"
        )
    imap = kernels._index_map(index_map)  # integers only, no silent int32 wrap-around
    if not smooth and _from_provenance(tileset):  # copies, straight from the map: no atlas of the whole set
        from ..tileset.provenance import gather

        out = np.empty((h, w, a.shape[2]), a.dtype)
        return gather(np.ascontiguousarray(a), tileset.provenance, imap, out, threads=threads)
    src = tileset.source
    atlas = np.ascontiguousarray(a[src[..., 0], src[..., 1]])
    if smooth:
        atlas = _smooth_map_atlas(tileset, a, atlas, threads)
    out = np.empty((h, w, a.shape[2]), a.dtype)
    kernels.tile_copy(atlas, imap, out, threads=threads)
    return out


def check_smoothable(a: np.ndarray, where: str = "map") -> None:
    """Refuse a float map with NaN or infinity for smoothing (:func:`synthesize_map`), naming the way out."""
    if a.dtype == np.float32 and not np.isfinite(a).all():
        raise ParameterError(
            f"{where} has NaN or infinite values: it cannot be Poisson-smoothed; pass smooth=False (--map-smooth "
            "off) to copy it through the cuts unchanged"
        )


def _smooth_map_atlas(tileset: TileSet, a: np.ndarray, atlas: np.ndarray, threads: int | None) -> np.ndarray:
    """The map's tiles Poisson-smoothed inside the same regions as the colour tiles (see :func:`synthesize_map`)."""
    check_smoothable(a)
    scale = {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(a.dtype)
    f = a.astype(np.float32) / np.float32(scale) if scale else a
    from ..builder.matching.augment import (
        matching_patches,  # transformed matching patches (augment)
    )

    matching = matching_patches(f, tileset)
    composed = atlas.astype(np.float32) / np.float32(scale) if scale else atlas
    tiles, _ = smooth_tiles(composed, matching, tileset.cut_masks, threads=threads, clip=scale is not None)
    if scale:
        return np.ascontiguousarray(np.rint(tiles * np.float32(scale)).astype(a.dtype))
    return np.ascontiguousarray(tiles, dtype=np.float32)
