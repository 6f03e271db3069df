"""The extendable rule of Dong et al. (§3 of papers 000 and 003): the basic 8-set 𝔹 and its extensions N1, N2,
... (``"n<K>"``), and the exhaustive search that re-derives 𝔹 (its figure is lost).
"""

from __future__ import annotations

import functools
import itertools
import re
from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from .completeness import choices_summary, dead_ends
from .corner_tiles import BL, BR, PATCH_COLOURS, TL, TR, CornerTileSet, CornerTuple, _make

# ---------------------------------------------------------------------------
# The extendable rule (Dong et al., §3 of papers 000 and 003)
# ---------------------------------------------------------------------------

#: Name of the basic 8-set 𝔹 of the extendable rule in :func:`get_tileset`.
BASIC_SET_NAME = "B"

#: Names of the sets of the extendable rule meant for listings (e.g. command-line
#: choices, together with :data:`TILESET_NAMES`): the basic set and ``N1`` .. ``N4``.
#: :func:`get_tileset` accepts ``"n<K>"`` for every ``K >= 1``, not only these.
EXTENDABLE_TILESET_NAMES: tuple[str, ...] = ("B", "n1", "n2", "n3", "n4")

#: The basic 8-set 𝔹 as ⟨TL, BL, TR, BR⟩ strings, sorted; see :func:`_set_basic`.
_SET_BASIC = "BYYR GBBY RBBY RGGB RRYG YGGB YGRB YRRB".split()

#: The only tile of 𝔹 with two Y and the only tile without Y (fixed by the text).
_BASIC_TWO_Y: CornerTuple = ("B", "Y", "Y", "R")
_BASIC_NO_Y: CornerTuple = ("R", "G", "G", "B")

#: Sizes the text gives for the first two extensions of 𝔹.
_N1_SIZE = 17
_N2_SIZE = 38

_NK_PATTERN = re.compile(r"n([1-9][0-9]*)")

MAX_EXTENSION = 16
"""Largest K of the name ``n<K>`` that :func:`get_tileset` accepts: |N16| = 5000 tiles already holds 5000 tiles
of N x N pixels (3.7 GiB of float32 RGB at N = 256), and the size grows as K^4; a larger K is a typo or a
mistake, which would otherwise run for hours (the extension is computed step by step)."""


def extension_step(k: int) -> tuple[str, str]:
    """Reference colour and new colour of step ``k`` of the extendable rule.

    Step ``k`` turns ``N(k-1)`` into ``Nk`` (``N0`` is the basic set 𝔹).  The paper
    fixes the first two steps (Y → C for N1, R → M for N2) and says one "can keep on
    increasing the sample patches ... by following this rule" without naming further
    references.  Choice made here:

    * **reference colours cycle through the four original patches** in the order
      Y, R, G, B, Y, R, ... (that is ``PATCH_COLOURS[(k + 2) % 4]``; the first two
      are the paper's).  The paper's second step takes an *original* patch (R), not the
      newest one (C), as reference; cycling through the originals keeps doing that and
      spreads the new patches evenly: after ``4c`` steps every original patch has been
      split into ``c + 1`` patches and ``|N(4c)| = 8 (c + 1)^4`` (``|N4| = 128``),
      whereas always splitting the newest patch would keep piling variants on one
      corner colour while the other three stay single;
    * **new colours** are ``"C"`` (cyan) and ``"M"`` (magenta) as in the paper, then
      ``"P3"``, ``"P4"``, ... (``"P<k>"``, "patch added at step k"): unique, never equal
      to an earlier colour, and readable in tile labels such as ``<B,P3,Y,R>``.

    Parameters
    ----------
    k : int
        Step number, ``k >= 1``.

    Returns
    -------
    (str, str)
        ``(reference, new_colour)``.

    Raises
    ------
    ValueError
        If ``k`` is not an integer >= 1.
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"extension step must be an integer >= 1, got {k!r}")
    k = int(k)
    reference = PATCH_COLOURS[(k + 2) % len(PATCH_COLOURS)]
    new = {1: "C", 2: "M"}.get(k, f"P{k}")
    return reference, new


def _replace_corners(tile: CornerTuple, positions: Iterable[int], colour: str) -> CornerTuple:
    """``tile`` with the corners at ``positions`` set to ``colour``."""
    chosen = set(positions)
    t = tuple(colour if i in chosen else c for i, c in enumerate(tile))
    return (t[0], t[1], t[2], t[3])


def extend_tileset(
    tileset: CornerTileSet, reference: str, new_colour: str, name: str | None = None
) -> CornerTileSet:
    """Apply one step of the extendable rule (000 / 003 §3.2).

    Every tile that contains the reference colour gets a copy with *all* its reference
    corners replaced by the new colour; a tile with two reference corners also gets
    the two "additional" tiles in which only one of them is replaced.  In general a
    tile with ``m`` reference corners gets ``2**m - 1`` new tiles, one for every
    non-empty subset of those corners (for ``m <= 2``, the only case in the named
    sets, this is exactly the paper's rule).

    Order of the result: the tiles of ``tileset`` unchanged, then the all-replaced
    copies in the order of their source tiles, then the partial replacements (by
    source tile, then by number of replaced corners, then by corner positions) —
    like the paper's Figure 2(c), whose last two tiles are the additional ones.
    A copy keeps the variant number of its source tile.

    Why the result is complete whenever ``tileset`` is.  Let ``π`` map the new colour
    back to the reference colour.  The result is exactly the set of tiles ``t`` with
    ``π(t)`` in ``tileset`` (every tile and all of its lifts).  A situation the
    scan-line tiler reaches with the result is realised by a valid partial tiling;
    ``π`` applied to every corner keeps it valid (it only merges colours), so the
    projected situation is reached with ``tileset`` and has a candidate ``u``.  The
    required corners of the situation (TL, BL from the left neighbour, TL, TR from
    the top neighbour) project onto those of ``u``, and ``u``'s lifts realise every
    choice of colour for each of its reference corners, so one lift of ``u`` matches.
    The same argument shows that a situation never has fewer candidates than its
    projection: the rule never removes a choice.  This is the paper's Figure 3
    argument in general form: without the partial replacements, a place whose left
    neighbour brings a new-colour corner and whose top neighbour brings a
    reference-colour corner (or vice versa) has no tile.

    Parameters
    ----------
    tileset : CornerTileSet
        The set to extend (``N(k-1)``).
    reference : str
        The reference colour, one of ``tileset.colours``.
    new_colour : str
        The new patch colour; must not be in ``tileset.colours``.
    name : str, optional
        Name of the result; defaults to ``"<name>+<new_colour>"``.

    Returns
    -------
    CornerTileSet
        Colours ``tileset.colours + (new_colour,)``.

    Raises
    ------
    ValueError
        If ``reference`` is not a colour of the set or ``new_colour`` already is one
        (or is empty).
    """
    reference = str(reference)
    new_colour = str(new_colour)
    if reference not in tileset.colours:
        raise ValueError(f"reference colour {reference!r} is not one of {tileset.colours!r}")
    if new_colour in tileset.colours:
        raise ValueError(f"new colour {new_colour!r} is already one of {tileset.colours!r}")
    full: list[tuple[CornerTuple, int]] = []
    partial: list[tuple[CornerTuple, int]] = []
    for tile, variant in zip(tileset.tiles, tileset.variants):
        positions = [i for i, c in enumerate(tile) if c == reference]
        if not positions:
            continue
        full.append((_replace_corners(tile, positions, new_colour), variant))
        for r in range(1, len(positions)):
            for subset in itertools.combinations(positions, r):
                partial.append((_replace_corners(tile, subset, new_colour), variant))
    added = full + partial
    return CornerTileSet(
        name=name if name is not None else f"{tileset.name}+{new_colour}",
        colours=tileset.colours + (new_colour,),
        tiles=tileset.tiles + tuple(t for t, _v in added),
        variants=tileset.variants + tuple(v for _t, v in added),
    )


@functools.cache
def extendable_tileset(k: int) -> CornerTileSet:
    """The set ``Nk`` of the extendable rule (``N0`` is the basic set 𝔹).

    ``Nk = extend_tileset(N(k-1), *extension_step(k))``, named ``"n<k>"``; each
    ``Nk`` contains ``N(k-1)`` as its first tiles.  With the chosen 𝔹: ``|N1| = 17``
    (5 patches R, G, B, Y, C), ``|N2| = 38`` (6 patches, + M), ``|N3| = 64``,
    ``|N4| = 128``, and ``|N(4c)| = 8 (c + 1)^4`` in general (all lifts of 𝔹 once
    every original colour has been split into ``c + 1``; ``|N8| = 648``).  Every ``Nk``
    is complete for scan-line tiling (see :func:`extend_tileset`), and every situation
    has at least as many candidates as its projection onto 𝔹 (so the minima of
    :func:`choices_summary` never fall below 𝔹's).

    Parameters
    ----------
    k : int
        Number of extension steps, ``k >= 0``.

    Returns
    -------
    CornerTileSet

    Raises
    ------
    ValueError
        If ``k`` is not an integer >= 0.
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
        raise ValueError(f"number of extension steps must be an integer >= 0, got {k!r}")
    k = int(k)
    if k == 0:
        return _set_basic()
    previous = extendable_tileset(k - 1)
    reference, new = extension_step(k)
    return extend_tileset(previous, reference, new, name=f"n{k}")


def _set_basic() -> CornerTileSet:
    """The basic 8-set 𝔹 of the extendable rule (000 / 003 §3, Figure 2(a), lost).

    Tiles (sorted): ⟨B,Y,Y,R⟩, ⟨G,B,B,Y⟩, ⟨R,B,B,Y⟩, ⟨R,G,G,B⟩, ⟨R,R,Y,G⟩, ⟨Y,G,G,B⟩,
    ⟨Y,G,R,B⟩, ⟨Y,R,R,B⟩.

    How it was found.  The text fixes: 8 tiles over R, G, B, Y; ⟨B,Y,Y,R⟩ is the only
    tile with two Y and ⟨R,G,G,B⟩ the only tile without Y (so the other six have
    exactly one Y, which is what makes ``|N1| = 8 + 7 + 2 = 17``); the set tiles any
    area by scan-line tiling; ``|N2| = 38``; like the 8-set of 002 it gives "an
    additional choice of an ω-tile at the leftmost column"; and both additional
    tiles of N1 are needed (Figure 3 shows the cases without a matching tile).
    :func:`candidate_basic_sets` enumerates, exactly, every complete 8-set meeting
    the first four constraints: 28 sets.  None satisfies Property 1 (the largest
    ``|N2|`` of a complete Property-1 set of this shape is 36, as INDEX.md reports;
    its "about forty" came from a random-tiling check, the exact check finds 28).  In
    all 28 both additional tiles of N1 are necessary; 6 have a choice at the leftmost
    column.  :func:`choose_basic_set` ranks those 6 by:

    1. **fewest Property-1 violations** (corner pairs sharing a tile side with the
       same patch).  Property 1 keeps a patch from touching itself across a
       quadrant boundary, the most visible repetition an ω-tile can carry, and the
       text says N1 "maintains all the properties of the ω-tile set"; as no candidate
       has it, come as close as possible.  Five candidates have one violation; the
       sixth has three, with the tile ⟨B,B,B,Y⟩ that is three quarters one patch.
    2. **most choices**: the largest number of distinct valid 8x8 scan-line tilings
       (a measure of how repetitive tilings are).  This set and its mirror image
       under the diagonal reflection ⟨TL,BL,TR,BR⟩ → ⟨TL,TR,BL,BR⟩ have 40, the
       other candidates 36 or 28: they are the only ones with a choice both at the
       leftmost column and in the first row (``choices_summary`` ``(1, 2)`` for
       both).  The two criteria agree: the two sets with most choices are also
       among those with fewest violations, so swapping their order changes nothing.
    3. **lexicographic** order of the sorted tile strings breaks the remaining tie
       between the two mirror images, which are equivalent up to swapping rows and
       columns: this one has ⟨R,R,Y,G⟩ and ⟨Y,G,R,B⟩ where the mirror has ⟨R,Y,R,G⟩
       and ⟨Y,R,G,B⟩.

    ``choices_summary``: first tile (8, 8), first row (1, 2), first column (1, 2),
    interior (1, 1); no dead end (:func:`dead_ends`).  The only Property-1
    violation is ⟨R,R,Y,G⟩ (R above R on the left side).
    """
    return _make(BASIC_SET_NAME, _SET_BASIC)


def _property1_violations(tile: CornerTuple) -> int:
    """Number of side-sharing corner pairs of ``tile`` with equal colours."""
    return int(
        (tile[TL] == tile[BL]) + (tile[TL] == tile[TR]) + (tile[BL] == tile[BR]) + (tile[TR] == tile[BR])
    )


def _count_tilings(tileset: CornerTileSet, rows: int, cols: int) -> int:
    """Number of valid ``rows x cols`` tilings (for a complete set: exactly the
    tilings the scan-line tiler can produce).

    Dynamic programming over the frontier (the last ``cols`` placed tiles).  Exact,
    but only meant for small, nearly deterministic sets.
    """
    tiles = tileset.tiles
    counts: dict[tuple[int, ...], int] = {(): 1}
    for i in range(rows):
        for j in range(cols):
            nxt: dict[tuple[int, ...], int] = defaultdict(int)
            for frontier, c in counts.items():
                left = tiles[frontier[-1]] if j > 0 else None
                top = tiles[frontier[-cols]] if i > 0 else None
                for k, t in enumerate(tiles):
                    if left is not None and (t[TL] != left[TR] or t[BL] != left[BR]):
                        continue
                    if top is not None and (t[TL] != top[BL] or t[TR] != top[BR]):
                        continue
                    nxt[(frontier + (k,))[-cols:]] += c
            counts = nxt
    return sum(counts.values())


Requirement = tuple[str, tuple[str, ...]]


def _requirements(tiles: Iterable[CornerTuple]) -> set[Requirement]:
    """What a set needs to be complete, as a function of the tiles it holds.

    ``("left", (a, b))``: some tile ⟨a, b, -, -⟩ (a first-row situation);
    ``("top", (a, c))``: some tile ⟨a, -, c, -⟩ (a first-column situation);
    ``("ltr", (a, b, c))``: some tile ⟨a, b, c, -⟩ (an interior situation).  These are
    exactly the reachable situations of :func:`reachable_situations` rewritten in
    corners, so a set is complete iff it holds a tile for each of its requirements.
    Requirements only grow when tiles are added.
    """
    tiles = list(tiles)
    reqs: set[Requirement] = set()
    for t in tiles:
        reqs.add(("left", (t[TR], t[BR])))
        reqs.add(("top", (t[BL], t[BR])))
    for d in tiles:
        below = [u for u in tiles if u[TL] == d[BL] and u[TR] == d[BR]]
        right = [u for u in tiles if u[TL] == d[TR] and u[BL] == d[BR]]
        for lt in below:
            for tp in right:
                reqs.add(("ltr", (lt[TR], lt[BR], tp[BR])))
    return reqs


def _provided(tile: CornerTuple) -> tuple[Requirement, Requirement, Requirement]:
    """The requirements (see :func:`_requirements`) that ``tile`` meets."""
    return (
        ("left", (tile[TL], tile[BL])),
        ("top", (tile[TL], tile[TR])),
        ("ltr", (tile[TL], tile[BL], tile[TR])),
    )


def _complete_supersets(
    seed: Iterable[CornerTuple], pool: Sequence[CornerTuple], size: int
) -> set[frozenset[CornerTuple]]:
    """Every complete set of ``size`` tiles made of ``seed`` plus tiles of ``pool``.

    Requirement-driven search: if a set misses a requirement, every complete superset
    holds one of the pool tiles meeting it (requirements only grow, see
    :func:`_requirements`), so branching on those tiles — for the missed requirement
    with the fewest of them — loses no solution; a set that misses nothing branches
    on every pool tile.  Visited sets are remembered, so each is expanded once.
    """
    meeting: dict[Requirement, list[CornerTuple]] = defaultdict(list)
    for t in pool:
        for r in _provided(t):
            meeting[r].append(t)
    found: set[frozenset[CornerTuple]] = set()
    seen: set[frozenset[CornerTuple]] = set()
    stack = [frozenset(seed)]
    while stack:
        current = stack.pop()
        if current in seen or len(current) > size:
            continue
        seen.add(current)
        met = {r for t in current for r in _provided(t)}
        missing = _requirements(current) - met
        if len(current) == size:
            if not missing:
                found.add(current)
            continue
        if missing:
            options = min(([t for t in meeting.get(r, ()) if t not in current] for r in missing), key=len)
        else:
            options = [t for t in pool if t not in current]
        stack.extend(current | {t} for t in options)
    return found


@dataclass(frozen=True)
class BasicSetCandidate:
    """A candidate for the basic set 𝔹 and the measures :func:`choose_basic_set` uses.

    Attributes
    ----------
    tiles : tuple of corner tuples
        The 8 tiles ⟨TL, BL, TR, BR⟩, sorted.
    leftmost_choice : bool
        Some reachable first-column situation has two or more candidate tiles.
    extras_necessary : bool
        Removing either of N1's two additional tiles (⟨B,C,Y,R⟩, ⟨B,Y,C,R⟩) leaves a
        dead end (the paper's Figure 3).
    property1_violations : int
        Side-sharing corner pairs with equal colours, summed over the tiles.
    square_tilings : int
        Number of distinct valid 8x8 scan-line tilings.
    """

    tiles: tuple[CornerTuple, ...]
    leftmost_choice: bool
    extras_necessary: bool
    property1_violations: int
    square_tilings: int

    def tileset(self, name: str = "candidate") -> CornerTileSet:
        """The candidate as a :class:`CornerTileSet` over ``PATCH_COLOURS``."""
        return CornerTileSet(name=name, colours=PATCH_COLOURS, tiles=self.tiles)

    def label(self) -> str:
        """The tiles as space-separated strings, e.g. ``"BYYR GBBY ..."``."""
        return " ".join("".join(t) for t in self.tiles)


def candidate_basic_sets() -> tuple[BasicSetCandidate, ...]:
    """Re-run the search for the basic set 𝔹 (the derivation of :func:`_set_basic`).

    Enumerates, exactly, every set of 8 distinct tiles over R, G, B, Y that

    * contains ⟨B,Y,Y,R⟩ and ⟨R,G,G,B⟩, its other six tiles having exactly one Y;
    * is complete for scan-line tiling (no dead end, exact);
    * gives ``|N1| = 17`` and ``|N2| = 38`` under the rule (:func:`extend_tileset`
      with Y → C, then R → M).

    and records for each the measures :func:`choose_basic_set` ranks by.  There are
    28 such sets; the search takes about a second (it is exhaustive: see
    :func:`_complete_supersets`).

    Returns
    -------
    tuple of BasicSetCandidate
        Sorted by tile strings.
    """
    pool = [
        (a, b, c, d)
        for a, b, c, d in itertools.product(PATCH_COLOURS, repeat=4)
        if (a, b, c, d).count("Y") == 1 and (a, b, c, d) != _BASIC_NO_Y
    ]
    complete = _complete_supersets((_BASIC_TWO_Y, _BASIC_NO_Y), pool, 8)
    out: list[BasicSetCandidate] = []
    for tiles in sorted(tuple(sorted(s)) for s in complete):
        base = CornerTileSet(name="candidate", colours=PATCH_COLOURS, tiles=tiles)
        n1 = extend_tileset(base, *extension_step(1))
        n2 = extend_tileset(n1, *extension_step(2))
        if len(n1) != _N1_SIZE or len(n2) != _N2_SIZE:
            continue
        extras = range(len(n1) - 2, len(n1))
        necessary = all(dead_ends(n1.subset(k for k in range(len(n1)) if k != e)) for e in extras)
        out.append(
            BasicSetCandidate(
                tiles=tiles,
                leftmost_choice=choices_summary(base)["first_column"][1] >= 2,
                extras_necessary=necessary,
                property1_violations=sum(_property1_violations(t) for t in tiles),
                square_tilings=_count_tilings(base, 8, 8),
            )
        )
    return tuple(out)


def choose_basic_set(candidates: Iterable[BasicSetCandidate]) -> BasicSetCandidate:
    """Apply the documented criterion (see :func:`_set_basic`) to the candidates.

    Keeps the candidates with a choice at the leftmost column and both additional
    tiles of N1 necessary, then takes the one with the fewest Property-1 violations,
    then the most 8x8 tilings, then the lexicographically smallest tile strings.

    Parameters
    ----------
    candidates : iterable of BasicSetCandidate
        Usually :func:`candidate_basic_sets`.

    Returns
    -------
    BasicSetCandidate

    Raises
    ------
    ValueError
        If no candidate passes the two filters.
    """
    eligible = [c for c in candidates if c.leftmost_choice and c.extras_necessary]
    if not eligible:
        raise ValueError("no candidate has a leftmost-column choice and needs both N1 extras")
    return min(
        eligible,
        key=lambda c: (c.property1_violations, -c.square_tilings, ["".join(t) for t in c.tiles]),
    )
