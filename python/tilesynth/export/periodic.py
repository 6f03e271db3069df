"""Toroidal (periodic) index maps for sets that need the scan-line tiler.

A shader samples ``index.png`` with REPEAT (or, equivalently, takes the cell coordinates modulo the map's size),
so the map must be a valid tiling *of the torus*: the right keys of the last column match the left keys of the
first, and the bottom keys of the last row the top keys of the first. The scan-line tiler does not know that
constraint, and a greedy fill can dead-end in the last column or row (set 16a has no tile for some corner tuples).

We solve it as a constraint search in scan order: each cell takes, in a seeded random order, a tile whose left
and top keys match the cells already placed, and which in the last column also matches the first column's left
key and in the last row the first row's top key (both at the last cell); on a dead end the search backtracks.
The random order makes the map as varied as a scan-line tiling (every tile is drawn uniformly among the
candidates that can still complete the torus, up to the backtracking), the search is complete (it fails only if
no toroidal tiling of that size exists), and a node budget turns a hopeless size into a clear error instead of
a hang. The result is checked with :func:`tilesynth.tiling.validate_index_map` on the map extended by its first
row and column, which is exactly the torus condition.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any

import numpy as np

from ..errors import ParameterError

MAX_NODES = 2_000_000


def toroidal_index_map(tileset: Any, rows: int, cols: int, seed: int | None = 0) -> np.ndarray:
    """int32 ``(rows, cols)`` tile indices forming a valid tiling of the ``rows x cols`` torus.

    Raises :class:`ParameterError` (naming ``index_size``) when no toroidal tiling of that size exists, or none
    is found within :data:`MAX_NODES` search steps.
    """
    n = len(tileset)
    lk = [tileset.left_key(t) for t in range(n)]
    rk = [tileset.right_key(t) for t in range(n)]
    tk = [tileset.top_key(t) for t in range(n)]
    bk = [tileset.bottom_key(t) for t in range(n)]
    by_lt: dict[tuple[Hashable | None, Hashable | None], list[int]] = {}
    for t in range(n):
        for key in ((None, None), (lk[t], None), (None, tk[t]), (lk[t], tk[t])):
            by_lt.setdefault(key, []).append(t)
    rng = np.random.default_rng(seed)
    grid = np.full((rows, cols), -1, np.int64)
    cells = rows * cols
    # stack of candidate lists (shuffled) and the position in each
    options: list[list[int]] = [[] for _ in range(cells)]
    pos = [0] * cells

    def candidates(i: int) -> list[int]:
        r, c = divmod(i, cols)
        left = rk[grid[r, c - 1]] if c > 0 else None
        up = bk[grid[r - 1, c]] if r > 0 else None
        cand = by_lt.get((left, up), [])
        if c == cols - 1:
            want = lk[grid[r, 0]]
            cand = [t for t in cand if rk[t] == want]
        if r == rows - 1:
            want = tk[grid[0, c]]
            cand = [t for t in cand if bk[t] == want]
        if len(cand) > 1:
            cand = [cand[j] for j in rng.permutation(len(cand))]
        return cand

    i = 0
    nodes = 0
    options[0] = candidates(0)
    while True:
        nodes += 1
        if nodes > MAX_NODES:
            raise ParameterError(
                f"index_size = {cols}x{rows}: no toroidal tiling of tile set {getattr(tileset, 'name', '?')!r} found "
                f"within {MAX_NODES} search steps; try another size (e.g. even sizes)"
            )
        r, c = divmod(i, cols)
        if pos[i] >= len(options[i]):
            grid[r, c] = -1
            pos[i] = 0
            i -= 1
            if i < 0:
                raise ParameterError(
                    f"index_size = {cols}x{rows}: tile set {getattr(tileset, 'name', '?')!r} has no tiling of the "
                    f"{cols}x{rows} torus; try another size (e.g. even sizes)"
                )
            pos[i] += 1
            continue
        grid[r, c] = options[i][pos[i]]
        if i == cells - 1:
            break
        i += 1
        options[i] = candidates(i)
        pos[i] = 0
    out = grid.astype(np.int32)
    from ..tiling import validate_index_map

    ext = np.concatenate([out, out[:1]], axis=0)
    validate_index_map(tileset, np.concatenate([ext, ext[:, :1]], axis=1))
    return out
