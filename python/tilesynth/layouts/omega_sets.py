"""Named ω-tile sets, their structural properties and an exact completeness check.

An ω-tile (Ng et al., *Generating an ω-tile set for texture synthesis*, CGI 2005;
``/work/shared/papers/002_*.txt``) is identified by the colours of its four corner
patches, written as the tuple ⟨TL, BL, TR, BR⟩ (top-left, bottom-left, top-right,
bottom-right; the order of the paper's appendix). Tiles laid in a grid must share
corners with their neighbours:

* right neighbour ``X`` of tile ``A``: ``X.TL == A.TR`` and ``X.BL == A.BR``;
* bottom neighbour ``X`` of tile ``A``: ``X.TL == A.BL`` and ``X.TR == A.BR``.

The tiler (:mod:`tilesynth.layouts.scanline`) never looks at corners directly.  It only uses four
*side keys* per tile and compares ``left_key(new) == right_key(left neighbour)`` and
``top_key(new) == bottom_key(top neighbour)``.  For corner tiles the keys are
``left = (TL, BL)``, ``right = (TR, BR)``, ``top = (TL, TR)``, ``bottom = (BL, BR)``.
Any class following the :class:`TileSetLike` protocol (for example a later
edge-coloured Wang tile set with ``left = W``, ``right = E``, ``top = N``,
``bottom = S``) works with the tiler and with :func:`dead_ends` /
:func:`choices_summary` unchanged.

Named sets (see :func:`get_tileset`): ``"4"``, ``"8"``, ``"16a"``, ``"16b"``, ``"32"``
(Ng et al.), and the sets of the extendable rule of Dong et al. (``papers/000``, ``003``
§3): the basic 8-set ``"B"`` and its extensions ``"n1"``, ``"n2"``, ... (``"n<K>"`` for
any ``K >= 1``; see :func:`extendable_tileset`).  The basic set's figure is lost; it is
derived by an exhaustive search that :func:`candidate_basic_sets` re-runs.
"""

from __future__ import annotations

import functools
import itertools
import re
from collections import defaultdict
from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .complete import CORNER_NAME, MAX_COMPLETE_TILES, check_complete_size, corner_colours

__all__ = [
    "TL",
    "BL",
    "TR",
    "BR",
    "PATCH_COLOURS",
    "TILESET_NAMES",
    "TileSetLike",
    "CornerTileSet",
    "DeadEnd",
    "get_tileset",
    "with_variants",
    "BASIC_SET_NAME",
    "EXTENDABLE_TILESET_NAMES",
    "BasicSetCandidate",
    "extension_step",
    "extend_tileset",
    "extendable_tileset",
    "candidate_basic_sets",
    "choose_basic_set",
    "tileset_from_dict",
    "forbidden_pairs",
    "check_properties",
    "reachable_situations",
    "candidate_counts",
    "dead_ends",
    "choices_summary",
]

#: Position of the top-left corner in a corner tuple ⟨TL, BL, TR, BR⟩.
TL = 0
#: Position of the bottom-left corner in a corner tuple.
BL = 1
#: Position of the top-right corner in a corner tuple.
TR = 2
#: Position of the bottom-right corner in a corner tuple.
BR = 3

#: The patch set F of the paper (§4): four patches cut from the input texture.
PATCH_COLOURS: tuple[str, ...] = ("R", "G", "B", "Y")

#: Names of the sets of Ng et al. accepted by :func:`get_tileset`, smallest set first.
#: The sets of the extendable rule (``"B"``, ``"n<K>"``) are listed separately in
#: :data:`EXTENDABLE_TILESET_NAMES`: every set named here uses exactly the four
#: :data:`PATCH_COLOURS`, which the extended sets (5, 6, ... patches) do not.
TILESET_NAMES: tuple[str, ...] = ("4", "8", "16a", "16b", "32")

#: Situation categories of the scan-line tiler, in scan order.
SITUATION_KINDS: tuple[str, ...] = ("first_tile", "first_row", "first_column", "interior")


@runtime_checkable
class TileSetLike(Protocol):
    """Interface the scan-line tiler and the completeness checks rely on.

    A tile set is a finite sequence of tiles, addressed by index ``0 .. len - 1``.
    Matching is expressed only through hashable side keys: a tile ``X`` may be placed
    to the right of ``A`` iff ``X.left_key == A.right_key`` and below ``A`` iff
    ``X.top_key == A.bottom_key``.  Implementations should be immutable and hashable
    (the tiler caches its candidate table per tile set).

    Attributes
    ----------
    name : str
        Human-readable name of the set.
    """

    name: str

    def __len__(self) -> int:
        """Number of tiles."""
        ...

    def left_key(self, index: int) -> Hashable:
        """Key of the left side of tile ``index``."""
        ...

    def right_key(self, index: int) -> Hashable:
        """Key of the right side of tile ``index``."""
        ...

    def top_key(self, index: int) -> Hashable:
        """Key of the top side of tile ``index``."""
        ...

    def bottom_key(self, index: int) -> Hashable:
        """Key of the bottom side of tile ``index``."""
        ...

    def tile_label(self, index: int) -> str:
        """Short human-readable label of tile ``index`` (used in error messages)."""
        ...


CornerTuple = tuple[str, str, str, str]


@dataclass(frozen=True)
class CornerTileSet:
    """A set of ω-tiles identified by their corner colours.

    Parameters
    ----------
    name : str
        Name of the set (e.g. ``"16a"``).
    colours : sequence of str
        The patch colours the tiles may use (distinct, non-empty strings; the named
        sets use single letters ``R, G, B, Y``).
    tiles : sequence of 4-sequences of str
        One ⟨TL, BL, TR, BR⟩ tuple per tile.  A string such as ``"BRYG"`` is accepted
        as shorthand for ``("B", "R", "Y", "G")`` when all colours are single letters.
        Duplicated tuples are allowed and meaningful: they are distinct ω-tiles cut
        from the same intermediate tile, told apart by ``variants``.
    variants : sequence of int, optional
        Variant number of each tile (``0`` if omitted).  In the 32-set tile ``k`` and
        ``k + 16`` share their corner tuple and have variants 0 and 1: the two ω-tiles
        the paper (§4.1, §4.2) keeps for every intermediate tile.

    Raises
    ------
    ValueError
        If the colours are not distinct, a tile does not have four corners, a corner
        uses a colour outside ``colours``, the set is empty, or ``variants`` has the
        wrong length or negative entries.
    """

    name: str
    colours: tuple[str, ...]
    tiles: tuple[CornerTuple, ...]
    variants: tuple[int, ...] = field(default=())

    def __post_init__(self) -> None:
        colours = tuple(str(c) for c in self.colours)
        if not colours:
            raise ValueError("a tile set needs at least one colour")
        if len(set(colours)) != len(colours):
            raise ValueError(f"colours must be distinct, got {colours!r}")
        if any(c == "" for c in colours):
            raise ValueError("colours must be non-empty strings")
        tiles: list[CornerTuple] = []
        for k, tile in enumerate(self.tiles):
            corners = tuple(tile)
            if len(corners) != 4:
                raise ValueError(f"tile {k} must have four corners <TL, BL, TR, BR>, got {tile!r}")
            for c in corners:
                if c not in colours:
                    raise ValueError(f"tile {k} {tile!r} uses colour {c!r}, not one of {colours!r}")
            tiles.append((corners[0], corners[1], corners[2], corners[3]))
        if not tiles:
            raise ValueError("a tile set needs at least one tile")
        variants = tuple(int(v) for v in self.variants) if self.variants else (0,) * len(tiles)
        if len(variants) != len(tiles):
            raise ValueError(f"variants has {len(variants)} entries but there are {len(tiles)} tiles")
        if any(v < 0 for v in variants):
            raise ValueError("variants must be non-negative")
        object.__setattr__(self, "name", str(self.name))
        object.__setattr__(self, "colours", colours)
        object.__setattr__(self, "tiles", tuple(tiles))
        object.__setattr__(self, "variants", variants)

    # ------------------------------------------------------------------ basics
    def __len__(self) -> int:
        """Number of tiles."""
        return len(self.tiles)

    def corners(self, index: int) -> CornerTuple:
        """Corner tuple ⟨TL, BL, TR, BR⟩ of tile ``index``."""
        return self.tiles[index]

    def variant(self, index: int) -> int:
        """Variant number of tile ``index`` (0 unless the set keeps several ω-tiles
        per intermediate tile)."""
        return self.variants[index]

    def tile_label(self, index: int) -> str:
        """Label such as ``"<B,R,Y,G>"`` or ``"<B,R,Y,G>#1"`` for variant 1."""
        text = "<" + ",".join(self.tiles[index]) + ">"
        v = self.variants[index]
        return text if v == 0 else f"{text}#{v}"

    # --------------------------------------------------------------- side keys
    def left_key(self, index: int) -> tuple[str, str]:
        """Left side key ``(TL, BL)`` of tile ``index``."""
        t = self.tiles[index]
        return (t[TL], t[BL])

    def right_key(self, index: int) -> tuple[str, str]:
        """Right side key ``(TR, BR)`` of tile ``index``."""
        t = self.tiles[index]
        return (t[TR], t[BR])

    def top_key(self, index: int) -> tuple[str, str]:
        """Top side key ``(TL, TR)`` of tile ``index``."""
        t = self.tiles[index]
        return (t[TL], t[TR])

    def bottom_key(self, index: int) -> tuple[str, str]:
        """Bottom side key ``(BL, BR)`` of tile ``index``."""
        t = self.tiles[index]
        return (t[BL], t[BR])

    # ----------------------------------------------------------------- helpers
    def corner_indices(self) -> np.ndarray:
        """Corner colours as indices into :attr:`colours`.

        Returns
        -------
        numpy.ndarray
            ``int32`` array of shape ``(len(self), 4)``, columns in the order
            TL, BL, TR, BR.
        """
        lookup = {c: i for i, c in enumerate(self.colours)}
        return np.array([[lookup[c] for c in tile] for tile in self.tiles], dtype=np.int32).reshape(
            len(self.tiles), 4
        )

    def distinct_tuples(self) -> tuple[CornerTuple, ...]:
        """The distinct corner tuples, in order of first appearance (the intermediate
        tiles the set needs)."""
        return tuple(dict.fromkeys(self.tiles))

    def subset(self, indices: Iterable[int], name: str | None = None) -> CornerTileSet:
        """A new set made of the tiles at ``indices`` (in that order).

        Parameters
        ----------
        indices : iterable of int
            Tile indices to keep.
        name : str, optional
            Name of the new set; defaults to ``"<name>-subset"``.

        Returns
        -------
        CornerTileSet
        """
        idx = list(indices)
        return CornerTileSet(
            name=name if name is not None else f"{self.name}-subset",
            colours=self.colours,
            tiles=tuple(self.tiles[i] for i in idx),
            variants=tuple(self.variants[i] for i in idx),
        )

    # ----------------------------------------------------------- serialisation
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description of the set (stored in tile-set files).

        Returns
        -------
        dict
            ``{"kind": "corner", "name": str, "colours": [str, ...],
            "tiles": [[TL, BL, TR, BR], ...], "variants": [int, ...]}``.
        """
        return {
            "kind": "corner",
            "name": self.name,
            "colours": list(self.colours),
            "tiles": [list(t) for t in self.tiles],
            "variants": list(self.variants),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> CornerTileSet:
        """Rebuild a set written by :meth:`to_dict`.

        Parameters
        ----------
        data : mapping
            Must have ``name``, ``colours`` and ``tiles``; ``variants`` is optional and
            ``kind``, if present, must be ``"corner"``.

        Returns
        -------
        CornerTileSet

        Raises
        ------
        ValueError
            If a key is missing, ``kind`` is not ``"corner"`` or the content is
            invalid.
        """
        if not isinstance(data, Mapping):
            raise ValueError(f"expected a mapping, got {type(data).__name__}")
        kind = data.get("kind", "corner")
        if kind != "corner":
            raise ValueError(f"expected a corner tile set (kind 'corner'), got kind {kind!r}")
        missing = [k for k in ("name", "colours", "tiles") if k not in data]
        if missing:
            raise ValueError(f"tile set description lacks {', '.join(missing)}")
        tiles_raw = data["tiles"]
        if isinstance(tiles_raw, (str, bytes)) or not isinstance(tiles_raw, Sequence):
            raise ValueError("'tiles' must be a list of [TL, BL, TR, BR] lists")
        tiles = []
        for t in tiles_raw:
            if isinstance(t, bytes) or not isinstance(t, Sequence):
                raise ValueError(f"bad tile entry {t!r}: expected [TL, BL, TR, BR]")
            tiles.append(tuple(str(c) for c in t))
        return cls(
            name=str(data["name"]),
            colours=tuple(str(c) for c in data["colours"]),
            tiles=tuple(tiles),  # type: ignore[arg-type]
            variants=tuple(int(v) for v in data.get("variants", ()) or ()),
        )


def tileset_from_dict(data: Mapping[str, Any]) -> TileSetLike:
    """Rebuild any known tile-set kind from its ``to_dict()`` description.

    Parameters
    ----------
    data : mapping
        A description with a ``kind`` entry (``"corner"`` assumed when absent; ``"wang"`` for the
        edge-coloured sets of :mod:`tilesynth.layouts.wang_sets`).

    Returns
    -------
    TileSetLike

    Raises
    ------
    ValueError
        If the kind is unknown or the description is invalid.
    """
    kind = data.get("kind", "corner") if isinstance(data, Mapping) else None
    if kind == "corner":
        return CornerTileSet.from_dict(data)
    if kind == "wang":
        from .wang_sets import WangTileSet

        return WangTileSet.from_dict(data)
    raise ValueError(f"unknown tile set kind {kind!r}; known kinds: 'corner', 'wang'")


# ---------------------------------------------------------------------------
# Named sets
# ---------------------------------------------------------------------------

#: Figure 8(a) of the paper, decoded in ``/work/shared/papers/INDEX.md``.
_SET_16A = ("BRYG BYRG BYYR BRRB YGRB YRGB YRRG YGGY RBGY RGBY RGGB RBBR GYBR GBYR GBBY GYYG").split()

#: Figure 8(b) of the paper, decoded in ``/work/shared/papers/INDEX.md``.
_SET_16B = ("BYRG BRYG BRRB BYYB GYRB GRYB GRRG GYYG RBBY RGBR RGGY RBGR YBGY YGBY YGGR YBBR").split()

#: The 4-set: the four tiles of the 2x2-periodic corner lattice [[B, Y], [R, G]].
_SET_4 = "BRYG YGBR RBGY GYRB".split()

#: The 8-set: the 4-set plus the four tiles whose bottom corner row is shifted by one.
_SET_8 = "BRYG YGBR RBGY GYRB BGYR YRBG RYGB GBRY".split()


def _make(name: str, tuples: Sequence[str], variants: Sequence[int] = ()) -> CornerTileSet:
    return CornerTileSet(
        name=name,
        colours=PATCH_COLOURS,
        tiles=tuple((t[0], t[1], t[2], t[3]) for t in tuples),
        variants=tuple(variants),
    )


def _set_4() -> CornerTileSet:
    """The 4-set (Figure 7(a) of the paper, whose picture is lost in extraction).

    Corner colours form the 2x2-periodic lattice ``[[B, Y], [R, G]]``: the corner at
    lattice point (row ``r``, column ``c``) has colour ``[[B, Y], [R, G]][r % 2][c % 2]``.
    The four tiles are the four cells of one period:
    ⟨B,R,Y,G⟩, ⟨Y,G,B,R⟩, ⟨R,B,G,Y⟩, ⟨G,Y,R,B⟩.

    Why this set: the paper says that with the 4-set "once the top-leftmost ω-tile is
    fixed, the rest of the ω-tiles in the tiling are decided".  Here every left key
    ``(TL, BL)`` and every top key ``(TL, TR)`` belongs to exactly one tile, so after the
    first tile every placement has exactly one candidate (the tiling is the lattice,
    shifted by the choice of the first tile), and it never dead-ends (checked
    exhaustively by :func:`dead_ends`).  It satisfies Property 1 (no two corners
    sharing a side have the same colour), so no tile equals a side neighbour.
    """
    return _make("4", _SET_4)


def _set_8() -> CornerTileSet:
    """The 8-set (Figure 7(b) of the paper, whose picture is lost in extraction).

    Every corner row of a tiling alternates the two colours of one *pair*, the pairs
    ``{B, Y}`` and ``{R, G}`` alternating from one corner row to the next; each tile
    has one pair on top and the other at the bottom, in either phase.  The 8 tiles are
    all such combinations: the 4-set ⟨B,R,Y,G⟩, ⟨Y,G,B,R⟩, ⟨R,B,G,Y⟩, ⟨G,Y,R,B⟩ plus
    ⟨B,G,Y,R⟩, ⟨Y,R,B,G⟩, ⟨R,Y,G,B⟩, ⟨G,B,R,Y⟩.

    Why this set: the paper says the 8-set gives "an additional choice of an ω-tile at
    the leftmost column" compared with the 4-set.  Here a left key ``(TL, BL)`` fixes
    the whole tile (one choice along the first row and in the interior, where the left
    key is known), while a top key ``(TL, TR)`` is shared by exactly two tiles (the
    two phases of the next corner row): at the start of every row there is one free
    binary choice, and the rest of the row follows.  It contains the 4-set, satisfies
    Property 1 (so no tile equals a side neighbour) and never dead-ends (checked
    exhaustively by :func:`dead_ends`): in the interior the known corners TL, BL, TR
    always come from an alternating top pair and an alternating bottom pair, and each
    such triple has exactly one tile.
    """
    return _make("8", _SET_8)


def _set_16a() -> CornerTileSet:
    """Figure 8(a) of the paper in the order of INDEX.md (forbidden pairs R↓Y, G↓R,
    B↓G, Y↓B)."""
    return _make("16a", _SET_16A)


def _set_16b() -> CornerTileSet:
    """Figure 8(b) of the paper in the order of INDEX.md (forbidden pairs R↓Y, Y↓R,
    B↓G, G↓B)."""
    return _make("16b", _SET_16B)


def _set_32() -> CornerTileSet:
    """The 32-set: every tuple of 16a twice.

    Tiles ``0..15`` are the tuples of 16a in order with variant 0 and tiles
    ``16..31`` the same tuples with variant 1, so tile ``k`` and ``k + 16`` are the two
    ω-tiles the paper (§4.1, §4.2) keeps for one intermediate tile, and every tiling
    step has at least two choices.

    Why 16a: the paper builds the 32-set "by generating two ω-tiles from an
    intermediate tile" of a 16-set without saying which one.  16a is Figure 8(a), the
    set the appendix uses as its running example; its forbidden-pair relation is a
    single 4-cycle (R↓Y, Y↓B, B↓G, G↓R), the first scenario of Property 2, and the
    set is invariant under the colour rotation R→G→B→Y→R, a symmetry that is
    transitive on the patches: all four patches play the same role, so none is
    favoured by the tiler.  The only colour permutations preserving 16b are the swaps
    R↔Y and G↔B, which keep {R, Y} and {G, B} as two distinct classes.  16b would be
    complete too (same four properties); the choice only fixes which 16 intermediate
    tiles have to be computed.
    """
    return _make("32", _SET_16A + _SET_16A, (0,) * 16 + (1,) * 16)


_FACTORIES = {
    "4": _set_4,
    "8": _set_8,
    "16a": _set_16a,
    "16b": _set_16b,
    "32": _set_32,
}


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


@functools.cache
def get_tileset(name: str) -> CornerTileSet:
    """Return a named ω-tile set.

    Parameters
    ----------
    name : str
        ``"4"``, ``"8"``, ``"16a"``, ``"16b"``, ``"32"`` (the sets of Ng et al.),
        ``"B"`` (the basic 8-set 𝔹 of the extendable rule, see :func:`_set_basic`) or
        ``"n<K>"`` for any ``K >= 1`` without leading zeros (the extended set ``NK``,
        see :func:`extendable_tileset`: ``"n1"`` has 17 tiles, ``"n2"`` 38).
        :data:`TILESET_NAMES` lists the first five, :data:`EXTENDABLE_TILESET_NAMES`
        ``"B"`` and ``"n1"`` .. ``"n4"``. Any of these followed by ``"x2"``, ``"x3"`` or
        ``"x4"`` (e.g. ``"16bx2"``, ``"n2x2"``) is that set with every tile repeated as
        variants 0 .. K−1: the ω construction gives variant v the (v+1)-th best matching
        patch, so every tiling step has at least K choices (002 §4.1–4.2 for any set;
        ``"32"`` is ``"16ax2"``), see :func:`with_variants`.

    Returns
    -------
    CornerTileSet
        The (immutable, shared) set.

    Raises
    ------
    ValueError
        If ``name`` is not a known set; the message lists the valid names.
    """
    key = str(name)
    complete = complete_tileset(key)
    if complete is not None:
        return complete
    times = _VARIANTS_PATTERN.fullmatch(key)
    if times is not None and times.group(1) not in ("", "32"):
        return with_variants(get_tileset(times.group(1)), int(times.group(2)))
    if key in _FACTORIES:
        return _FACTORIES[key]()
    if key == BASIC_SET_NAME:
        return extendable_tileset(0)
    match = _NK_PATTERN.fullmatch(key)
    if match is not None:
        k = int(match.group(1)) if len(match.group(1)) < 6 else MAX_EXTENSION + 1
        if k > MAX_EXTENSION:
            raise ValueError(
                f"tile set {name!r}: at most n{MAX_EXTENSION} ({8 * (MAX_EXTENSION // 4 + 1) ** 4} tiles); "
                "|N(4c)| = 8 (c + 1)^4 grows so fast that larger sets cannot be built in memory"
            )
        return extendable_tileset(k)
    raise ValueError(
        f"unknown tile set {name!r}; valid names are: "
        f"{', '.join(TILESET_NAMES + EXTENDABLE_TILESET_NAMES)} (and n<K> for any K >= 1; any of them "
        "with x2, x3 or x4 appended for 2-4 variants of every tile; complete sets c<K> and c<K>x<V>, "
        "see tilesynth.layouts.complete)"
    )


_VARIANTS_PATTERN = re.compile(r"(.*)x([234])")


@functools.cache
def with_variants(base: CornerTileSet, k: int) -> CornerTileSet:
    """``base`` with every tile repeated ``k`` times as variants 0 .. k−1 (tiles ``v·m + j``, m = len(base)).

    The variants share their corner tuple, so the tiling rule is that of ``base`` and every step that had c
    candidates has k·c; the ω construction makes variant v of a tuple from its (v+1)-th best matching patch
    (each more than N/4 pixels from the others), so the variants are different tiles with the same corners.
    """
    if base.variants and any(v != 0 for v in base.variants):
        raise ValueError(f"tile set {base.name!r} already has variants")
    m = len(base)
    return CornerTileSet(
        name=f"{base.name}x{k}",
        colours=base.colours,
        tiles=tuple(base.tiles) * k,
        variants=tuple(v for v in range(k) for _ in range(m)),
    )


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


# ------------------------------------------------------------------ complete sets (issue 12, tilesynth.layouts.complete)
@functools.cache
def complete_corner_set(k: int, v: int = 1):
    """The complete corner set over ``k`` colours with ``v`` variants per tuple, in the spec's index order."""
    if k < 2 or v < 1:
        raise ValueError(
            f"a complete corner set needs K >= 2 colours and V >= 1 variants, got K = {k}, V = {v}"
        )
    name = f"c{k}" if v == 1 else f"c{k}x{v}"
    check_complete_size(name, k**4 * v, "K^4 * V")
    cols = corner_colours(k)
    tiles, variants = [], []
    for t in itertools.product(range(k), repeat=4):  # TL, BL, TR, BR with BR fastest: the spec's order
        for var in range(v):
            tiles.append(tuple(cols[i] for i in t))
            variants.append(var)
    return CornerTileSet(name=name, colours=cols, tiles=tuple(tiles), variants=tuple(variants))


def complete_tileset(name: Any):
    """The complete corner set named ``name`` (``c<K>`` / ``c<K>x<V>``), or None if it is no such name."""
    m = CORNER_NAME.fullmatch(str(name))
    if m is None:
        return None
    if len(m.group(1)) > 3 or len(m.group(2) or "") > 5:
        raise ValueError(f"tile set {name!r}: more than {MAX_COMPLETE_TILES} tiles (MAX_COMPLETE_TILES)")
    return complete_corner_set(int(m.group(1)), int(m.group(2) or 1))
