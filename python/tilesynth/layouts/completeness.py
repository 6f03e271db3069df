"""The structural properties of an ω-tile set (the appendix of Ng et al.) and the exact completeness check of
scan-line tiling: every situation the tiler can reach, and whether a tile fits in each (:func:`dead_ends`).

Any :class:`~tilesynth.layouts.corner_tiles.TileSetLike` works (corner ω-tiles and edge-coloured Wang tiles).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Hashable
from dataclasses import dataclass

from .corner_tiles import BL, BR, SITUATION_KINDS, TL, TR, CornerTileSet, TileSetLike

# ---------------------------------------------------------------------------
# Properties of the appendix
# ---------------------------------------------------------------------------


def _left_columns(tileset: CornerTileSet) -> set[tuple[str, str]]:
    return {(t[TL], t[BL]) for t in tileset.tiles}


def forbidden_pairs(tileset: CornerTileSet) -> list[tuple[str, str]]:
    """The forbidden pairs a↓b of the appendix, for distinct colours.

    ``a↓b`` means that no tile has the form ⟨a, b, -, -⟩ (``a`` at the top-left and
    ``b`` at the bottom-left corner).  Pairs with ``a == b`` are left out: under
    Property 1 they are always forbidden and the appendix never lists them.

    Parameters
    ----------
    tileset : CornerTileSet

    Returns
    -------
    list of (str, str)
        The pairs ``(a, b)``, ``a != b``, sorted by the order of ``tileset.colours``.
    """
    present = _left_columns(tileset)
    return [(a, b) for a in tileset.colours for b in tileset.colours if a != b and (a, b) not in present]


def check_properties(tileset: CornerTileSet) -> dict[str, bool]:
    """Evaluate the four properties of the paper's appendix.

    1. Every tile ⟨a, b, c, d⟩ has a≠b, a≠c, b≠d and c≠d.
    2. (i) every colour ``a`` has exactly one ``a' != a`` with a↓a', and (ii) distinct
       colours have distinct forbidden counterparts ``a'``.
    3. For every tile ⟨a, b, -, -⟩ there is a tile ⟨-, -, a, b⟩ and vice versa (the
       set of left columns equals the set of right columns).
    4. For every tile ⟨a, b, c, d⟩ neither b↓d nor c↓d (here ↓ includes equal
       colours: x↓x holds when no tile is ⟨x, x, -, -⟩).

    Parameters
    ----------
    tileset : CornerTileSet

    Returns
    -------
    dict of str to bool
        Keys ``"property1"`` .. ``"property4"``.
    """
    tiles = tileset.tiles
    p1 = all(t[TL] != t[BL] and t[TL] != t[TR] and t[BL] != t[BR] and t[TR] != t[BR] for t in tiles)

    counterparts: dict[str, list[str]] = defaultdict(list)
    for a, b in forbidden_pairs(tileset):
        counterparts[a].append(b)
    p2i = all(len(counterparts[a]) == 1 for a in tileset.colours)
    p2ii = p2i and len({counterparts[a][0] for a in tileset.colours}) == len(tileset.colours)
    p2 = p2i and p2ii

    left = _left_columns(tileset)
    right = {(t[TR], t[BR]) for t in tiles}
    p3 = left == right

    def allowed(x: str, y: str) -> bool:
        return (x, y) in left

    p4 = all(allowed(t[BL], t[BR]) and allowed(t[TR], t[BR]) for t in tiles)
    return {"property1": p1, "property2": p2, "property3": p3, "property4": p4}


# ---------------------------------------------------------------------------
# Completeness of scan-line tiling
# ---------------------------------------------------------------------------

Situation = tuple[Hashable | None, Hashable | None]


@dataclass(frozen=True)
class DeadEnd:
    """A reachable scan-line situation in which no tile fits.

    Attributes
    ----------
    kind : str
        ``"first_tile"``, ``"first_row"``, ``"first_column"`` or ``"interior"``.
    left_key : hashable or None
        Required left key of the new tile (right key of the left neighbour), ``None``
        in column 0.
    top_key : hashable or None
        Required top key of the new tile (bottom key of the top neighbour), ``None``
        in row 0.
    left_tile, top_tile, diagonal_tile : int or None
        A witness: indices of a left neighbour, top neighbour and (interior only)
        top-left diagonal tile that realise the situation at cell (1, 1), (0, 1) or
        (1, 0) of a scan-line tiling.
    """

    kind: str
    left_key: Hashable | None
    top_key: Hashable | None
    left_tile: int | None
    top_tile: int | None
    diagonal_tile: int | None

    def __str__(self) -> str:
        parts = [f"{self.kind}: no tile with left key {self.left_key!r} and top key {self.top_key!r}"]
        wit = []
        if self.diagonal_tile is not None:
            wit.append(f"top-left tile {self.diagonal_tile}")
        if self.top_tile is not None:
            wit.append(f"top tile {self.top_tile}")
        if self.left_tile is not None:
            wit.append(f"left tile {self.left_tile}")
        if wit:
            parts.append(" (reached with " + ", ".join(wit) + ")")
        return "".join(parts)


# Length: 90 lines, of which 51 are the docstring (the derivation of the reachable states); the code is 39.
def reachable_situations(
    tileset: TileSetLike,
) -> dict[str, dict[Situation, tuple[int | None, int | None, int | None]]]:
    """All situations the scan-line tiler can meet, exactly.

    The tiler fills an ``rows x cols`` grid (any ``rows, cols >= 1``) left to right,
    top to bottom; at cell (i, j) it needs a tile whose left key equals the right key
    of tile (i, j-1) (no constraint when j = 0) and whose top key equals the bottom
    key of tile (i-1, j) (no constraint when i = 0).  A *situation* is that pair of
    required keys.  It is *reachable* if some run of the tiler, with some grid size
    and some sequence of choices, arrives at a cell with it.

    Exact characterisation:

    * ``(None, None)`` at (0, 0);
    * ``(right_key(L), None)`` for **every** tile L (row 0, j >= 1);
    * ``(None, bottom_key(T))`` for **every** tile T (column 0, i >= 1);
    * ``(right_key(L), bottom_key(T))`` for every pair (L, T) that has a common
      "diagonal" tile D with ``top_key(L) == bottom_key(D)`` (L can sit below D) and
      ``left_key(T) == right_key(D)`` (T can sit right of D) (interior, i, j >= 1).

    Proof.  The tiler picks among *all* matching tiles with positive probability, so
    the states it can reach at cell (i, j) are exactly the valid tilings of the
    already-placed region (rows ``0..i-1`` in full, row ``i`` up to column ``j-1``);
    a dead end anywhere before would contradict validity of that tiling.

    *Soundness* (nothing unreachable is listed): each listed situation is realised by
    a tiny valid prefix: tile L alone at (0, 0) before cell (0, 1) of a 1x2 grid; tile
    T alone at (0, 0) before cell (1, 0) of a 2x1 grid; row 0 = [D, T] and row 1 =
    [L] before cell (1, 1) of a 2x2 grid (valid because T fits right of D and L fits
    below D; the first row has no constraint from above, and L no constraint from the
    left).  *Completeness* (nothing reachable is missed): in row 0 the situation
    depends only on the left tile, and any tile is a possible left tile; likewise in
    column 0.  For i, j >= 1 the tile D at (i-1, j-1) of the placed region exists and,
    by validity, is matched by T = (i-1, j) on its right and L = (i, j-1) below it, so
    the situation is one listed for that (L, T).  Hence the fixpoint over "what rows
    can contain" that one might compute collapses after one step: the first row is
    unconstrained, so every horizontally adjacent pair (D, T) and every vertically
    adjacent pair (D, L) already occur at the top-left corner of the grid, and deeper
    rows or further columns can only restrict, never extend, the set of situations.
    The argument uses nothing but the side keys, so it holds for any
    :class:`TileSetLike` (corner or edge tiles).

    Parameters
    ----------
    tileset : TileSetLike

    Returns
    -------
    dict
        For each kind in ``("first_tile", "first_row", "first_column", "interior")``
        a mapping from situation ``(left_key | None, top_key | None)`` to one witness
        ``(left_tile, top_tile, diagonal_tile)`` (``None`` where not applicable).
    """
    n = len(tileset)
    left = [tileset.left_key(k) for k in range(n)]
    right = [tileset.right_key(k) for k in range(n)]
    top = [tileset.top_key(k) for k in range(n)]
    bottom = [tileset.bottom_key(k) for k in range(n)]

    by_left: dict[Hashable, list[int]] = defaultdict(list)
    by_top: dict[Hashable, list[int]] = defaultdict(list)
    for k in range(n):
        by_left[left[k]].append(k)
        by_top[top[k]].append(k)

    out: dict[str, dict[Situation, tuple[int | None, int | None, int | None]]] = {
        kind: {} for kind in SITUATION_KINDS
    }
    out["first_tile"][(None, None)] = (None, None, None)
    for k in range(n):
        out["first_row"].setdefault((right[k], None), (k, None, None))
        out["first_column"].setdefault((None, bottom[k]), (None, k, None))
    interior = out["interior"]
    for d in range(n):
        below_d = by_top.get(bottom[d], [])
        right_of_d = by_left.get(right[d], [])
        if not below_d or not right_of_d:
            continue
        # Group by key so the work is (#distinct keys)^2 per D, not (#tiles)^2.
        l_keys: dict[Hashable, int] = {}
        for l_tile in below_d:
            l_keys.setdefault(right[l_tile], l_tile)
        t_keys: dict[Hashable, int] = {}
        for t_tile in right_of_d:
            t_keys.setdefault(bottom[t_tile], t_tile)
        for lk, l_tile in l_keys.items():
            for tk, t_tile in t_keys.items():
                interior.setdefault((lk, tk), (l_tile, t_tile, d))
    return out


def candidate_counts(tileset: TileSetLike) -> dict[Situation, int]:
    """Number of tiles matching every *possible* situation key pair.

    Parameters
    ----------
    tileset : TileSetLike

    Returns
    -------
    dict
        ``(left_key | None, top_key | None) -> count`` for every key pair at least one
        tile matches (absent key pairs have no candidate).
    """
    counts: dict[Situation, int] = defaultdict(int)
    for k in range(len(tileset)):
        lk, tk = tileset.left_key(k), tileset.top_key(k)
        counts[(None, None)] += 1
        counts[(lk, None)] += 1
        counts[(None, tk)] += 1
        counts[(lk, tk)] += 1
    return dict(counts)


def dead_ends(tileset: TileSetLike) -> list[DeadEnd]:
    """Exhaustive completeness check of scan-line tiling.

    Enumerates every situation the scan-line tiler can reach (exactly; see
    :func:`reachable_situations` for the argument) and reports those with no
    matching tile.

    Parameters
    ----------
    tileset : TileSetLike

    Returns
    -------
    list of DeadEnd
        Empty iff the tiler can never get stuck, for any grid size and any choices.
    """
    counts = candidate_counts(tileset)
    found: list[DeadEnd] = []
    for kind, situations in reachable_situations(tileset).items():
        for (lk, tk), (l_tile, t_tile, d_tile) in situations.items():
            if counts.get((lk, tk), 0) == 0:
                found.append(DeadEnd(kind, lk, tk, l_tile, t_tile, d_tile))
    return found


def choices_summary(tileset: TileSetLike) -> dict[str, tuple[int, int]]:
    """Minimum and maximum number of candidate tiles over reachable situations.

    Parameters
    ----------
    tileset : TileSetLike

    Returns
    -------
    dict of str to (int, int)
        ``(min, max)`` for each of ``"first_tile"`` (cell (0, 0)), ``"first_row"``
        (row 0, j >= 1), ``"first_column"`` (column 0, i >= 1) and ``"interior"``
        (i, j >= 1).  A minimum of 0 means a dead end (see :func:`dead_ends`).
    """
    counts = candidate_counts(tileset)
    summary: dict[str, tuple[int, int]] = {}
    for kind, situations in reachable_situations(tileset).items():
        values = [counts.get(s, 0) for s in situations]
        summary[kind] = (min(values), max(values)) if values else (0, 0)
    return summary
