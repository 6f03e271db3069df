"""The ω-tile data model and the sets of Ng et al.: corner tuples ⟨TL, BL, TR, BR⟩, the :class:`TileSetLike`
protocol the tiler and the completeness checks rely on, :class:`CornerTileSet`, and the named sets "4", "8",
"16a", "16b", "32" (their figures decoded in ``/work/shared/papers/INDEX.md``).

:mod:`tilesynth.layouts.omega_sets` is the entry that names every set (:func:`~tilesynth.layouts.omega_sets.get_tileset`);
see its docstring for the corner rules.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

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
