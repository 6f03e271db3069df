"""Scan-line tiling with a tile set, and validation of user-supplied index maps.

The tiler fills a grid left to right, top to bottom (Ng et al. 2005, §4).  At cell
(i, j) it picks, uniformly at random, one of the tiles whose left key equals the right
key of the tile at (i, j-1) and whose top key equals the bottom key of the tile at
(i-1, j) (no constraint in column 0 / row 0).  It only uses the side keys of the
:class:`~tilesynth.layouts.omega_sets.TileSetLike` protocol, so the same code serves corner
(ω-)tiles and edge-coloured Wang tiles.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .omega_sets import TileSetLike

__all__ = ["candidate_table", "scanline_index_map", "validate_index_map"]

SeedLike = None | int | np.integer | np.random.Generator

# Largest modulus used for batched draws: every candidate count must divide it so that
# ``draw % count`` is exactly uniform.
_MAX_BATCH_MODULUS = 1 << 62


def candidate_table(
    tileset: TileSetLike,
) -> dict[tuple[Hashable | None, Hashable | None], np.ndarray]:
    """Candidate tiles for every constraint pair that has at least one candidate.

    Parameters
    ----------
    tileset : TileSetLike

    Returns
    -------
    dict
        ``(left_key | None, top_key | None) -> sorted int32 array`` of tile indices
        whose left key (resp. top key) equals the given one; ``None`` means
        unconstrained.  Key pairs without any matching tile are absent.
    """
    table: dict[tuple[Hashable | None, Hashable | None], list[int]] = {}
    for k in range(len(tileset)):
        lk, tk = tileset.left_key(k), tileset.top_key(k)
        for key in ((None, None), (lk, None), (None, tk), (lk, tk)):
            table.setdefault(key, []).append(k)
    return {key: np.array(sorted(v), dtype=np.int32) for key, v in table.items()}


@dataclass(frozen=True)
class _Plan:
    """Integer-coded candidate table for the inner loop.

    Horizontal keys (left/right) and vertical keys (top/bottom) get separate dense
    ids; id 0 stands for "no constraint" and real keys are numbered from 1.  The
    candidates of a constraint pair live at ``table[lid * n_vertical + tid]``.
    """

    n_tiles: int
    left_id: np.ndarray
    right_id: np.ndarray
    top_id: np.ndarray
    bottom_id: np.ndarray
    right_list: tuple[int, ...]
    bottom_list: tuple[int, ...]
    n_vertical: int
    table: tuple[tuple[int, ...] | None, ...]
    horizontal_keys: tuple[Hashable | None, ...]
    vertical_keys: tuple[Hashable | None, ...]
    modulus: int | None


def _build_plan(tileset: TileSetLike) -> _Plan:
    n = len(tileset)
    if n < 1:
        raise ValueError("the tile set has no tiles")
    h_ids: dict[Hashable, int] = {}
    v_ids: dict[Hashable, int] = {}

    def hid(key: Hashable) -> int:
        return h_ids.setdefault(key, len(h_ids) + 1)

    def vid(key: Hashable) -> int:
        return v_ids.setdefault(key, len(v_ids) + 1)

    left = [hid(tileset.left_key(k)) for k in range(n)]
    right = [hid(tileset.right_key(k)) for k in range(n)]
    top = [vid(tileset.top_key(k)) for k in range(n)]
    bottom = [vid(tileset.bottom_key(k)) for k in range(n)]
    n_h = len(h_ids) + 1
    n_v = len(v_ids) + 1
    lists: list[list[int] | None] = [None] * (n_h * n_v)
    for k in range(n):
        for lid in (0, left[k]):
            for tid in (0, top[k]):
                slot = lid * n_v + tid
                if lists[slot] is None:
                    lists[slot] = []
                lists[slot].append(k)  # type: ignore[union-attr]
    table = tuple(None if c is None else tuple(sorted(c)) for c in lists)
    modulus = 1
    for size in {len(c) for c in table if c is not None}:
        modulus = math.lcm(modulus, size)
    h_keys: list[Hashable | None] = [None] * n_h
    for key, i in h_ids.items():
        h_keys[i] = key
    v_keys: list[Hashable | None] = [None] * n_v
    for key, i in v_ids.items():
        v_keys[i] = key
    return _Plan(
        n_tiles=n,
        left_id=np.array(left, dtype=np.int64),
        right_id=np.array(right, dtype=np.int64),
        top_id=np.array(top, dtype=np.int64),
        bottom_id=np.array(bottom, dtype=np.int64),
        right_list=tuple(right),
        bottom_list=tuple(bottom),
        n_vertical=n_v,
        table=table,
        horizontal_keys=tuple(h_keys),
        vertical_keys=tuple(v_keys),
        modulus=modulus if modulus <= _MAX_BATCH_MODULUS else None,
    )


@functools.lru_cache(maxsize=64)
def _cached_plan(tileset: TileSetLike) -> _Plan:
    return _build_plan(tileset)


def _plan(tileset: TileSetLike) -> _Plan:
    try:
        return _cached_plan(tileset)
    except TypeError:  # unhashable tile set: build without caching
        return _build_plan(tileset)


def _check_size(name: str, value: Any) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be a positive integer, got {value!r}")
    if value < 1:
        raise ValueError(f"{name} must be >= 1, got {int(value)}")
    return int(value)


TILER_BYTES_PER_CELL = 64
"""Peak bytes per cell of :func:`scanline_index_map`: the int32 map, the int64 draws and their list of Python
ints (about 40 bytes each), rounded up."""


def _check_memory(rows: int, cols: int) -> None:
    """Refuse grids whose tiling would not fit (see :func:`tilesynth.base.validate.memory_limit`)."""
    from ..base.validate import MAX_BYTES_ENV, fmt_bytes, memory_limit
    from ..errors import ParameterError

    need, limit = rows * cols * TILER_BYTES_PER_CELL, memory_limit()
    if need > limit:
        raise ParameterError(
            f"rows x cols = {rows}x{cols}: tiling needs about {fmt_bytes(need)}, more than the limit of "
            f"{fmt_bytes(limit)} ({MAX_BYTES_ENV}; default half the physical memory)"
        )


def _as_generator(seed: SeedLike) -> np.random.Generator:
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is not None and (isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer))):
        raise TypeError(f"seed must be None, an int or a numpy Generator, got {seed!r}")
    return np.random.default_rng(seed)


# Length: 89 lines, of which 38 are the docstring (the tiling rule and its guarantees); the code is 51.
def scanline_index_map(
    tileset: TileSetLike,
    rows: int,
    cols: int,
    seed: SeedLike = None,
) -> np.ndarray:
    """Tile a ``rows x cols`` grid by scan-line tiling.

    Cells are filled left to right, top to bottom; each cell gets a tile chosen
    uniformly among those matching the already placed left and top neighbours.

    Parameters
    ----------
    tileset : TileSetLike
        The tile set (e.g. ``get_tileset("16a")``).
    rows, cols : int
        Grid size in tiles, both >= 1.
    seed : None, int or numpy.random.Generator, optional
        Source of randomness.  With an int (or ``None`` for fresh entropy) a new
        ``numpy.random.default_rng(seed)`` is used, so equal seeds give equal maps; a
        Generator is used (and advanced) as given.

    Returns
    -------
    numpy.ndarray
        ``int32`` array of shape ``(rows, cols)`` with the tile index of every cell.

    Raises
    ------
    ValueError
        If ``rows`` or ``cols`` is not an integer >= 1 (the message names it).
    TypeError
        If ``seed`` is of an unsupported type.
    RuntimeError
        If no tile matches at some cell (cannot happen for the named sets, which
        :func:`tilesynth.layouts.omega_sets.dead_ends` proves complete).

    Notes
    -----
    The picks come from ``rng.integers``: one draw per cell from ``[0, M)``, where
    ``M`` is the least common multiple of all candidate-list lengths, reduced modulo
    the number of candidates, which is exactly uniform.  (If ``M`` would exceed
    2**62 the tiler draws ``rng.integers(count)`` per cell instead.)
    """
    tileset = _as_definition(tileset)
    rows = _check_size("rows", rows)
    cols = _check_size("cols", cols)
    _check_memory(rows, cols)
    rng = _as_generator(seed)
    plan = _plan(tileset)
    table = plan.table
    right = plan.right_list
    bottom = plan.bottom_list
    n_v = plan.n_vertical

    if plan.modulus is not None:
        draws: list[int] | None = rng.integers(0, plan.modulus, size=rows * cols, dtype=np.int64).tolist()
    else:
        draws = None

    out = np.empty((rows, cols), dtype=np.int32)
    above: list[int] = [0] * cols  # bottom-key ids of the previous row (0: none)
    k = 0
    for i in range(rows):
        current: list[int] = [0] * cols
        lid = 0
        for j in range(cols):
            cands = table[lid * n_v + above[j]]
            if cands is None:
                raise RuntimeError(
                    f"scan-line tiling dead end at cell ({i}, {j}) with tile set "
                    f"{getattr(tileset, 'name', '?')!r}: no tile has left key "
                    f"{plan.horizontal_keys[lid]!r} and top key "
                    f"{plan.vertical_keys[above[j]]!r}"
                )
            count = len(cands)
            if count == 1:
                t = cands[0]
            elif draws is not None:
                t = cands[draws[k] % count]
            else:
                t = cands[int(rng.integers(count))]
            k += 1
            current[j] = t
            lid = right[t]
        out[i] = current
        above = [bottom[t] for t in current]
    return out


def validate_index_map(tileset: TileSetLike, index_map: Any) -> None:
    """Check that an index map is a valid tiling with ``tileset``.

    Parameters
    ----------
    tileset : TileSetLike
    index_map : array_like of int
        2-D map of tile indices (e.g. read from a user file for ``tilesynth synth
        --map``).

    Returns
    -------
    None
        When the map is valid.

    Raises
    ------
    ValueError
        If the map is not a non-empty 2-D integer array, holds an index outside
        ``0 .. len(tileset) - 1`` (the first such cell in scan order is named), or two
        neighbouring tiles do not match (the first mismatch in scan order is
        described with both positions, tiles and keys).
    """
    tileset = _as_definition(tileset)
    arr = np.asarray(index_map)
    if arr.ndim != 2:
        raise ValueError(f"index map must be 2-D, got shape {arr.shape}")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ValueError(f"index map must not be empty, got shape {arr.shape}")
    if arr.dtype == np.bool_ or not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(f"index map must hold integers, got dtype {arr.dtype}")
    plan = _plan(tileset)
    n = plan.n_tiles
    bad = (arr < 0) | (arr >= n)
    if bad.any():
        i, j = (int(v) for v in np.argwhere(bad)[0])
        raise ValueError(
            f"index map entry at ({i}, {j}) is {int(arr[i, j])}, out of range for tile "
            f"set {getattr(tileset, 'name', '?')!r} with {n} tiles (valid: 0..{n - 1})"
        )
    idx = arr.astype(np.int64, copy=False)

    # Horizontal pairs (i, j) | (i, j+1), reported at the later cell (i, j+1);
    # vertical pairs (i, j) / (i+1, j), reported at (i+1, j). Left before top.
    first: tuple[int, int, int] | None = None  # (row, col, 0 = left pair, 1 = top pair)
    h_bad = plan.right_id[idx[:, :-1]] != plan.left_id[idx[:, 1:]]
    if h_bad.any():
        i, j = (int(v) for v in np.argwhere(h_bad)[0])
        first = (i, j + 1, 0)
    v_bad = plan.bottom_id[idx[:-1, :]] != plan.top_id[idx[1:, :]]
    if v_bad.any():
        i, j = (int(v) for v in np.argwhere(v_bad)[0])
        cand = (i + 1, j, 1)
        if first is None or cand < first:
            first = cand
    if first is None:
        return None

    label = getattr(tileset, "tile_label", lambda k: str(k))
    i, j, which = first
    new = int(idx[i, j])
    if which == 0:
        old = int(idx[i, j - 1])
        raise ValueError(
            f"index map mismatch between ({i}, {j - 1}) and its right neighbour "
            f"({i}, {j}): tile {old} {label(old)} has right key "
            f"{tileset.right_key(old)!r} but tile {new} {label(new)} has left key "
            f"{tileset.left_key(new)!r}"
        )
    old = int(idx[i - 1, j])
    raise ValueError(
        f"index map mismatch between ({i - 1}, {j}) and its bottom neighbour "
        f"({i}, {j}): tile {old} {label(old)} has bottom key "
        f"{tileset.bottom_key(old)!r} but tile {new} {label(new)} has top key "
        f"{tileset.top_key(new)!r}"
    )


def _as_definition(tileset: Any) -> Any:
    """A set name ("16a", "wang8", ...) as its definition, a built :class:`~tilesynth.TileSet` as its layout's
    definition; anything else as given (so that a name gives the set, not an ``AttributeError``)."""
    if isinstance(tileset, str):
        from .omega_sets import get_tileset
        from .wang_sets import get_wang_tileset, is_wang_set_name

        return get_wang_tileset(tileset) if is_wang_set_name(tileset) else get_tileset(tileset)
    if hasattr(tileset, "definition") and hasattr(tileset, "layout"):
        return tileset.definition
    if isinstance(tileset, (bytes, int, float, type(None))):
        raise TypeError(f"tileset = {tileset!r}: expected a tile-set name, definition or TileSet")
    return tileset
