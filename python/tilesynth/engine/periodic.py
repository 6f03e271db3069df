"""Toroidal (periodic) index maps for sets that need the scan-line tiler.

A shader samples ``index.png`` with REPEAT (or, equivalently, takes the cell coordinates modulo the map's size),
so the map must be a valid tiling *of the torus*: the right keys of the last column match the left keys of the
first, and the bottom keys of the last row the top keys of the first. The scan-line tiler does not know that
constraint, and a greedy fill can dead-end in the last column or row (set 16a has no tile for some corner tuples).

We solve it as a constraint search in scan order: each cell takes, in a seeded random order, a tile whose left
and top keys match the cells already placed, and which in the last column also matches the first column's left
key and in the last row the first row's top key (both at the last cell); on a dead end the search backtracks.
The random order makes the map as varied as a scan-line tiling, and the search is complete (it fails only if
no toroidal tiling of that size exists). Some sets only tile tori of particular periods (measured: 4, 8: even
sizes; 16b: multiples of 4; B, n1, n2: multiples of 3; 16a, 32: any size >= 2), and chronological backtracking
can thrash on large ones; after :data:`MAX_NODES` steps we solve a small torus whose size divides the requested
one, repeat it, and randomise the result with recolouring moves that keep every tile in the set (a lattice
vertex of a corner set, an edge of a Wang set, takes a random colour when its cells stay tiles of the set). The
default size (:func:`default_index_size`) is the multiple of the set's period nearest 32. The result is checked with :func:`tilesynth.layouts.scanline.validate_index_map` on the map extended by its first
row and column, which is exactly the torus condition.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any

import numpy as np

from ..errors import ParameterError

MAX_NODES = 200_000
"""Search steps of the direct search before falling back to the periodic seed and recolouring moves."""


SMALL_NODES = 200_000
"""Search steps for each small torus of the fallback."""


class _Budget(Exception):
    pass


class _Impossible(Exception):
    pass


def _search(
    tileset: Any, rows: int, cols: int, rng: np.random.Generator, max_nodes: int, progress: Any = None
) -> np.ndarray:
    n = len(tileset)
    lk = [tileset.left_key(t) for t in range(n)]
    rk = [tileset.right_key(t) for t in range(n)]
    tk = [tileset.top_key(t) for t in range(n)]
    bk = [tileset.bottom_key(t) for t in range(n)]
    by_lt: dict[tuple[Hashable | None, Hashable | None], list[int]] = {}
    for t in range(n):
        for key in ((None, None), (lk[t], None), (None, tk[t]), (lk[t], tk[t])):
            by_lt.setdefault(key, []).append(t)
    grid = np.full((rows, cols), -1, np.int64)
    cells = rows * cols
    options: list[list[int]] = [[] for _ in range(cells)]
    pos = [0] * cells

    def candidates(i: int) -> list[int]:
        r, c = divmod(i, cols)
        left = rk[grid[r, c - 1]] if c > 0 else None
        up = bk[grid[r - 1, c]] if r > 0 else None
        cand = by_lt.get((left, up), [])
        if c == cols - 1:  # the right neighbour is column 0 (the cell itself when cols == 1)
            cand = [t for t in cand if rk[t] == (lk[t] if cols == 1 else lk[grid[r, 0]])]
        if r == rows - 1:
            cand = [t for t in cand if bk[t] == (tk[t] if rows == 1 else tk[grid[0, c]])]
        if len(cand) > 1:
            cand = [cand[j] for j in rng.permutation(len(cand))]
        return cand

    i = 0
    nodes = 0
    options[0] = candidates(0)
    while True:
        nodes += 1
        if nodes > max_nodes:
            raise _Budget
        if progress is not None and nodes % 16384 == 0:
            progress("index map: search", i, cells)
        r, c = divmod(i, cols)
        if pos[i] >= len(options[i]):
            grid[r, c] = -1
            pos[i] = 0
            i -= 1
            if i < 0:
                raise _Impossible
            pos[i] += 1
            continue
        grid[r, c] = options[i][pos[i]]
        if i == cells - 1:
            if progress is not None:
                progress("index map: search", cells, cells)
            return grid.astype(np.int32)
        i += 1
        options[i] = candidates(i)
        pos[i] = 0


def torus_period(tileset: Any, limit: int = 8) -> int | None:
    """The smallest p <= ``limit`` such that the p x p torus has a tiling (then every multiple of p does)."""
    rng = np.random.default_rng(0)
    for p in range(1, limit + 1):
        try:
            _search(tileset, p, p, rng, SMALL_NODES)
            return p
        except (_Impossible, _Budget):
            continue
    return None


def default_index_size(tileset: Any, target: int = 32) -> tuple[int, int]:
    """(cols, rows) of the default index map: the multiple of :func:`torus_period` nearest ``target``."""
    p = torus_period(tileset) or 1
    q = p * max(1, round(target / p))
    return q, q


def _recolour(
    tileset: Any, grid: np.ndarray, rng: np.random.Generator, sweeps: int = 20, progress: Any = None
) -> np.ndarray:
    """Randomise a toroidal tiling by Metropolis-free recolouring moves that keep it valid: for corner sets a
    lattice vertex takes a random colour when the four cells around it stay tiles of the set; for Wang sets an
    edge does, when its two cells stay tiles. Tiles sharing a tuple (variants) are then drawn uniformly."""
    rows, cols = grid.shape
    kind = type(tileset).__name__
    if kind == "CornerTileSet":
        colours = list(tileset.colours)
        cid = {c: i for i, c in enumerate(colours)}
        k = len(colours)
        by_tuple: dict[tuple[int, int, int, int], list[int]] = {}
        for t, tup in enumerate(tileset.tiles):
            by_tuple.setdefault(tuple(cid[c] for c in tup), []).append(t)  # type: ignore[arg-type]
        vert = np.array([[cid[tileset.tiles[grid[r, c]][0]] for c in range(cols)] for r in range(rows)])

        def tup(r: int, c: int) -> tuple[int, int, int, int]:
            r1, c1 = (r + 1) % rows, (c + 1) % cols
            return (vert[r, c], vert[r1, c], vert[r, c1], vert[r1, c1])  # TL, BL, TR, BR

        for step in range(sweeps * rows * cols):
            if progress is not None and step % (rows * cols) == 0:
                progress("index map: recolouring", step // (rows * cols), sweeps)
            r, c = int(rng.integers(rows)), int(rng.integers(cols))
            old = vert[r, c]
            vert[r, c] = int(rng.integers(k))
            around = ((r - 1) % rows, (c - 1) % cols), ((r - 1) % rows, c), (r, (c - 1) % cols), (r, c)
            if not all(tup(a, b) in by_tuple for a, b in around):
                vert[r, c] = old
        if progress is not None:
            progress("index map: recolouring", sweeps, sweeps)
        out = np.empty_like(grid)
        for r in range(rows):
            for c in range(cols):
                cand = by_tuple[tup(r, c)]
                out[r, c] = cand[int(rng.integers(len(cand)))]
        return out
    if kind == "WangTileSet":
        hz = {c: i for i, c in enumerate(tileset.horizontal)}
        vt = {c: i for i, c in enumerate(tileset.vertical)}
        index = {(hz[nn], vt[e], hz[s], vt[w]): t for t, (nn, e, s, w) in enumerate(tileset.tiles)}
        hor = np.array(
            [[hz[tileset.tiles[grid[r, c]][0]] for c in range(cols)] for r in range(rows)]
        )  # N edges
        ver = np.array(
            [[vt[tileset.tiles[grid[r, c]][3]] for c in range(cols)] for r in range(rows)]
        )  # W edges

        def cell(r: int, c: int) -> tuple[int, int, int, int]:
            return (hor[r, c], ver[r, (c + 1) % cols], hor[(r + 1) % rows, c], ver[r, c])

        for step in range(sweeps * rows * cols):
            if progress is not None and step % (rows * cols) == 0:
                progress("index map: recolouring", step // (rows * cols), sweeps)
            r, c = int(rng.integers(rows)), int(rng.integers(cols))
            if rng.integers(2):
                arr, kk, around = hor, len(hz), (((r - 1) % rows, c), (r, c))
            else:
                arr, kk, around = ver, len(vt), ((r, (c - 1) % cols), (r, c))
            old = arr[r, c]
            arr[r, c] = int(rng.integers(kk))
            if not all(cell(a, b) in index for a, b in around):
                arr[r, c] = old
        if progress is not None:
            progress("index map: recolouring", sweeps, sweeps)
        return np.array([[index[cell(r, c)] for c in range(cols)] for r in range(rows)], np.int32)
    return grid


def toroidal_index_map(
    tileset: Any, rows: int, cols: int, seed: int | None = 0, progress: Any = None
) -> np.ndarray:
    """int32 ``(rows, cols)`` tile indices forming a valid tiling of the ``rows x cols`` torus.

    First a direct randomised search (scan order with backtracking, :data:`MAX_NODES` steps). If it runs out of
    steps, a small torus (p x q with p | rows, q | cols) is solved, repeated, and randomised by recolouring
    moves that keep the tiling valid (:func:`_recolour`). Raises :class:`ParameterError` (naming
    ``index_size``) when no toroidal tiling of that size exists, with the sizes that work. ``progress`` (a
    :class:`tilesynth.base.progress.Progress`) is told how far the search and the recolouring sweeps are: a
    2048 x 2048 map takes minutes.
    """
    name = getattr(tileset, "name", "?")
    rng = np.random.default_rng(seed)
    try:
        out = _search(tileset, rows, cols, rng, MAX_NODES, progress)
    except _Impossible:
        p = torus_period(tileset)
        hint = f"multiples of {p} work" if p else "no square torus up to 8 x 8 has one either"
        raise ParameterError(
            f"index_size = {cols}x{rows}: tile set {name!r} has no tiling of the {cols}x{rows} torus ({hint})"
        ) from None
    except _Budget:
        out = None
        # the largest small torus first (the most varied base), then recolouring moves
        for pr in sorted((d for d in range(1, min(rows, 8) + 1) if rows % d == 0), reverse=True):
            for pc in sorted((d for d in range(1, min(cols, 8) + 1) if cols % d == 0), reverse=True):
                try:
                    small = _search(tileset, pr, pc, rng, SMALL_NODES)
                except (_Impossible, _Budget):
                    continue
                out = _recolour(tileset, np.tile(small, (rows // pr, cols // pc)), rng, progress=progress)
                break
            if out is not None:
                break
        if out is None:
            raise ParameterError(
                f"index_size = {cols}x{rows}: no toroidal tiling of tile set {name!r} found; try a multiple of "
                f"{torus_period(tileset) or '?'}"
            ) from None
    from ..layouts.scanline import validate_index_map

    ext = np.concatenate([out, out[:1]], axis=0)
    validate_index_map(tileset, np.concatenate([ext, ext[:, :1]], axis=1))
    return out
