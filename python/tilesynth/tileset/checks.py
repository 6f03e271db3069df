"""The consistency checks of a tile set: dtypes and shapes of its arrays, then their values and the layout.

:meth:`tilesynth.tileset.tilefile.TileSet.save` runs :func:`check_shapes`, :meth:`~tilesynth.tileset.tilefile.TileSet.load`
both (raising :class:`TileSetFormatError`, which ``load`` prefixes with the file's path).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import TileSetFormatError
from .members import _check_levels, _check_map_shapes

__all__ = ["CUT_STAT_NAMES", "check_shapes", "check_values"]

#: The six values per cut in ``cut_stats``.
CUT_STAT_NAMES: tuple[str, ...] = ("D_overlap", "n_overlap", "D_path", "n_path", "D_boundary", "cost")


def check_shapes(ts: Any, values: bool) -> None:
    """Dtypes and shapes of the arrays, and (with ``values``) the manifest's exemplar shape."""
    for name, dt in ts._arrays().items():
        a = ts._member(name)
        if not isinstance(a, np.ndarray) or a.dtype != np.dtype(dt):
            raise TileSetFormatError(f"array {name} must be {dt}, got {getattr(a, 'dtype', type(a))}")
    lazy = not ts.has_pixels() and ts.provenance is not None
    if lazy:  # a version-2 set: the tiles are the provenance's (checked at load), not in memory
        k, n, n2, c = ts.n_tiles, ts.tile_size, ts.tile_size, ts.channels
    else:
        k, n, n2, c = ts.tiles.shape
    expect = {
        **({} if lazy else {"source": (k, n, n, 2)}),
        "cut_masks": (k, n, n),
        "tile_patches": (k, 4),
        "match_offsets": (k, 2),
        "D": (k,),
        "cut_costs": (k,),
    }
    if ts.labels is not None:
        expect["labels"] = (k, n, n)
    if ts.cut_stats is not None:
        expect["cut_stats"] = (k, 4, len(CUT_STAT_NAMES))
    if n != n2:
        raise TileSetFormatError(f"tiles must be square, got shape {(k, n, n2, c)}")
    for name, shape in expect.items():
        if getattr(ts, name).shape != shape:
            raise TileSetFormatError(f"array {name} has shape {getattr(ts, name).shape}, expected {shape}")
    if len(ts.layout.get("tiles", [])) != k:
        raise TileSetFormatError(f"layout lists {len(ts.layout.get('tiles', []))} tiles, the arrays {k}")
    if ts.exemplar.ndim != 3 or ts.exemplar.shape[2] != c:
        raise TileSetFormatError(f"exemplar has shape {ts.exemplar.shape}, expected (H, W, {c})")
    if values and list(ts.exemplar_info.get("shape", [])) != list(ts.exemplar.shape):
        raise TileSetFormatError(
            f"manifest exemplar.shape {ts.exemplar_info.get('shape')} disagrees with the exemplar array "
            f"{list(ts.exemplar.shape)}"
        )
    _check_map_shapes(ts.maps, ts.map_specs, ts.exemplar.shape[:2])
    _check_levels(ts.map_levels, ts.maps, ts.exemplar.shape[:2])
    if k == 0 or n == 0 or not 1 <= c <= 4 or 0 in ts.exemplar.shape:
        raise TileSetFormatError(
            f"tiles have shape {(k, n, n, c)}, expected (K, N, N, C) with K, N >= 1 and C in 1..4"
        )
    if ts.genes.ndim != 2 or ts.genes.shape[1] != 2 or ts.genes.shape[0] == 0:
        raise TileSetFormatError(f"array genes has shape {ts.genes.shape}, expected (n, 2) with n >= 1")


def check_values(ts: Any) -> None:
    """The array contents and the layout: values in range, positions inside the exemplar."""
    lazy = not ts.has_pixels() and ts.provenance is not None
    k = ts.n_tiles
    try:
        from ..layouts.omega_sets import tileset_from_dict

        defn = tileset_from_dict(ts.layout)
    except Exception as exc:  # noqa: BLE001 - tampered content may fail in any way; it is a format error
        raise TileSetFormatError(
            f"layout is not a tile-set definition ({type(exc).__name__}: {exc})"
        ) from None
    if len(defn.tiles) != k:
        raise TileSetFormatError(f"layout lists {len(defn.tiles)} tiles, the arrays {k}")
    h, w = ts.exemplar.shape[:2]
    for name in ("exemplar",) if lazy else ("tiles", "exemplar"):
        a = getattr(ts, name)
        if not np.isfinite(a).all() or a.min() < 0 or a.max() > 1:
            raise TileSetFormatError(f"array {name} has values outside [0, 1] (or NaN)")
    for name, m in (ts.maps or {}).items():
        if m.dtype == np.float32 and not np.isfinite(m).all():
            raise TileSetFormatError(f"map {name!r} has NaN or infinite values")
    for name in ("D", "cut_costs"):
        if not np.isfinite(getattr(ts, name)).all():
            raise TileSetFormatError(f"array {name} has non-finite values")
    if lazy:
        from .provenance import check_inside

        if not check_inside(ts.provenance, h, w):
            raise TileSetFormatError(f"array prov_table points outside the {w}x{h} exemplar")
    else:
        src = ts.source
        if src.size and (src.min() < 0 or src[..., 0].max() >= h or src[..., 1].max() >= w):
            raise TileSetFormatError(f"array source points outside the {w}x{h} exemplar")
    n = ts.tile_size
    for name in ("genes", "match_offsets"):
        g = getattr(ts, name)
        if name == "match_offsets" and (g == -1).any():
            # a scheme without a matching patch (Cohen's Wang tiles) stores (-1, -1) for every tile; the
            # format asks no scheme which: all -1, or all valid positions
            if not (g == -1).all():
                raise TileSetFormatError(
                    "array match_offsets must be all -1 (a scheme without matching patches) or patch positions"
                )
            if isinstance(ts.params.get("smooth"), dict):  # smoothing follows the matching patches
                raise TileSetFormatError(
                    "array match_offsets of a smoothed tile set must hold patch positions"
                )
            continue
        if (g < 0).any() or (g[:, 0] > h - n).any() or (g[:, 1] > w - n).any():
            raise TileSetFormatError(f"array {name} has patch positions outside the {w}x{h} exemplar")
    if (ts.tile_patches < 0).any() or (ts.tile_patches >= ts.genes.shape[0]).any():
        raise TileSetFormatError(f"array tile_patches has indices outside [0, {ts.genes.shape[0]})")
