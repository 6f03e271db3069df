"""Edge-coloured (Wang) tile sets.

A Wang tile is identified by the colours of its four edges, written ⟨N, E, S, W⟩ (north, east, south, west).
Horizontal edges (N, S) and vertical edges (W, E) use separate alphabets: a colour of a horizontal edge never
has to match a vertical one. Tiles laid in a grid must agree on every shared edge:

* right neighbour ``X`` of tile ``A``: ``X.W == A.E``;
* bottom neighbour ``X`` of tile ``A``: ``X.N == A.S``.

For the scan-line tiler (:mod:`tilesynth.layouts.scanline`) the side keys are ``left = W``, ``right = E``, ``top = N``,
``bottom = S``, so the same tiler and the same completeness checks (:func:`tilesynth.layouts.omega_sets.dead_ends`,
:func:`~tilesynth.layouts.omega_sets.choices_summary`) serve corner-coloured ω-tiles and edge-coloured Wang tiles: one
tiler, two matching rules (corner keys ``(TL, BL)`` … for ω-tiles, single edge colours here).

Named sets (:func:`get_wang_tileset`)
-------------------------------------
``"wang8"``
    2 horizontal-edge colours (``R``, ``G``) and 2 vertical-edge colours (``Y``, ``C``), two tiles for every
    (N, W) pair: 8 tiles, 4 samples (Cohen et al. 2003; the set of 004).
``"wang18"``
    3 + 3 colours (``R``, ``G``, ``B`` and ``Y``, ``C``, ``M``), two tiles for every (N, W) pair: 18 tiles,
    6 samples (the set 001 uses for all its results).
``"wang<2k²>"``
    the same construction with ``k`` colours per direction for any ``k >= 2`` (``"wang32"``: k = 4, ...).

The construction (:func:`complete_choice_set`): with colours indexed ``0 .. k-1`` in each alphabet, the tiles
of the pair (N = n, W = w) are, for j = 0 and 1,

    ⟨N, E, S, W⟩ = ⟨n, (w + j) mod k, (n + j) mod k, w⟩.

So in the interior the tiler always has exactly two candidates (Cohen's "complete choice": every (N, W) pair
has two tiles), and they differ in *both* the colour they pass to the right (E) and the one they pass down
(S); every (S, E) pair is produced by exactly two tiles, so all colours stay equally likely. It reproduces
every tile 004 names for its 8-set (T_yrbg, T_bgyr and T_bgbg, written anticlockwise from the top: N, W, S,
E, with horizontal colours y = 0, b = 1 and vertical colours r = 0, g = 1): T_bgbg is j = 0 of the pair
(b, g), T_bgyr is j = 1 of the same pair (004's example of "two choices") and T_yrbg is j = 1 of (y, r).
Cohen's paper gives its 8-tile set only as a picture; 001 gives none.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .complete import EDGE_NAME, MAX_COMPLETE_TILES, check_complete_size

__all__ = [
    "HORIZONTAL_COLOURS",
    "VERTICAL_COLOURS",
    "WANG_TILESET_NAMES",
    "WangTileSet",
    "complete_choice_set",
    "get_wang_tileset",
    "is_wang_set_name",
]

#: Colours of horizontal edges (N, S), in order; the first ``k`` are used.
HORIZONTAL_COLOURS: tuple[str, ...] = ("R", "G", "B", "K", "O", "P", "Q", "T")
#: Colours of vertical edges (W, E), in order; the first ``k`` are used.
VERTICAL_COLOURS: tuple[str, ...] = ("Y", "C", "M", "L", "U", "V", "X", "Z")

#: The named sets meant for listings (:func:`get_wang_tileset` accepts ``"wang<2k²>"`` for 2 <= k <= 8).
WANG_TILESET_NAMES: tuple[str, ...] = ("wang8", "wang18")

_NAME = re.compile(r"wang([1-9][0-9]*)")

EdgeTuple = tuple[str, str, str, str]


def _names(value: Any, what: str) -> tuple[str, ...]:
    """``value`` (a sequence of colour names, or a string of one-letter names) as a tuple of str."""
    if isinstance(value, bytes) or not isinstance(value, Iterable):
        raise ValueError(f"{what} must be a sequence of colour names, got {value!r}")
    return tuple(str(c) for c in value)


@dataclass(frozen=True)
class WangTileSet:
    """A set of Wang tiles identified by their edge colours ⟨N, E, S, W⟩.

    Parameters
    ----------
    name : str
    horizontal : sequence of str
        Colours of horizontal edges (N and S), distinct, non-empty.
    vertical : sequence of str
        Colours of vertical edges (W and E), distinct, non-empty. May share names with ``horizontal``: the two
        alphabets are separate.
    tiles : sequence of 4-sequences of str
        One ⟨N, E, S, W⟩ tuple per tile (a 4-letter string is accepted when colours are single letters).
    variants : sequence of int, optional
        Variant number of every tile (default all 0): tiles may share an edge tuple when their variants differ
        (the complete edge sets ``wc<K>x<V>``, whose variants have different content and are chosen
        per cell by the hashed lookup). Serialised only when some variant is not 0.

    Raises
    ------
    ValueError
        If an alphabet is empty or has repeated colours, a tile does not have four edges or uses a colour
        outside its alphabet, the set is empty, two tiles are equal (same tuple and variant), or ``variants``
        has the wrong length or a negative entry.
    """

    name: str
    horizontal: tuple[str, ...]
    vertical: tuple[str, ...]
    tiles: tuple[EdgeTuple, ...]
    variants: tuple[int, ...] = field(default=())

    def __post_init__(self) -> None:
        h = _names(self.horizontal, "horizontal colours")
        v = _names(self.vertical, "vertical colours")
        for label, alphabet in (("horizontal", h), ("vertical", v)):
            if not alphabet or any(c == "" for c in alphabet):
                raise ValueError(f"{label} colours must be non-empty strings, got {alphabet!r}")
            if len(set(alphabet)) != len(alphabet):
                raise ValueError(f"{label} colours must be distinct, got {alphabet!r}")
        tiles: list[EdgeTuple] = []
        if isinstance(self.tiles, (str, bytes)) or not isinstance(self.tiles, Iterable):
            raise ValueError(f"tiles must be a sequence of <N, E, S, W> tuples, got {self.tiles!r}")
        for k, tile in enumerate(self.tiles):
            edges = _names(tile, f"tile {k}")
            if len(edges) != 4:
                raise ValueError(f"tile {k} must have four edges <N, E, S, W>, got {tile!r}")
            n, e, s, w = edges
            for side, c, alphabet in (("N", n, h), ("E", e, v), ("S", s, h), ("W", w, v)):
                if c not in alphabet:
                    raise ValueError(f"tile {k} {tile!r}: {side} colour {c!r} is not one of {alphabet!r}")
            tiles.append((n, e, s, w))
        if not tiles:
            raise ValueError("a tile set needs at least one tile")
        raw = self.variants
        if isinstance(raw, (str, bytes)) or not isinstance(raw, Iterable):
            raise ValueError(f"variants must be a sequence of ints, got {raw!r}")
        raw = tuple(raw)
        if any(isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) for v in raw):
            raise ValueError(f"variants must be ints, got {raw!r}")
        variants = tuple(int(v) for v in raw) if raw else (0,) * len(tiles)
        if len(variants) != len(tiles):
            raise ValueError(f"variants has {len(variants)} entries but there are {len(tiles)} tiles")
        if any(v < 0 for v in variants):
            raise ValueError("variants must be non-negative")
        if len(set(zip(tiles, variants))) != len(tiles):
            raise ValueError("tiles must be distinct (tiles sharing an edge tuple need different variants)")
        object.__setattr__(self, "variants", variants)
        object.__setattr__(self, "name", str(self.name))
        object.__setattr__(self, "horizontal", h)
        object.__setattr__(self, "vertical", v)
        object.__setattr__(self, "tiles", tuple(tiles))

    # ------------------------------------------------------------------ basics
    def __len__(self) -> int:
        """Number of tiles."""
        return len(self.tiles)

    @property
    def colours(self) -> tuple[str, ...]:
        """All sample colours, horizontal first: the order of the genes (one sample per colour)."""
        return self.horizontal + self.vertical

    @property
    def n_samples(self) -> int:
        """Number of samples a construction needs (one per colour)."""
        return len(self.horizontal) + len(self.vertical)

    def edges(self, index: int) -> EdgeTuple:
        """Edge tuple ⟨N, E, S, W⟩ of tile ``index``."""
        return self.tiles[index]

    def tile_label(self, index: int) -> str:
        """Label such as ``"<N=R,E=Y,S=G,W=C>"`` (``"<N=R,E=Y,S=G,W=C>'1"`` for variant 1)."""
        n, e, s, w = self.tiles[index]
        v = self.variants[index]
        return f"<N={n},E={e},S={s},W={w}>" + (f"'{v}" if v else "")

    @property
    def n_variants(self) -> int:
        """Largest variant number + 1 (1 for a set without variants)."""
        return max(self.variants) + 1

    # --------------------------------------------------------------- side keys
    def left_key(self, index: int) -> str:
        """Left side key: the W colour."""
        return self.tiles[index][3]

    def right_key(self, index: int) -> str:
        """Right side key: the E colour."""
        return self.tiles[index][1]

    def top_key(self, index: int) -> str:
        """Top side key: the N colour."""
        return self.tiles[index][0]

    def bottom_key(self, index: int) -> str:
        """Bottom side key: the S colour."""
        return self.tiles[index][2]

    # ----------------------------------------------------------------- helpers
    def sample_indices(self) -> np.ndarray:
        """Gene index of every tile's ⟨N, E, S, W⟩ sample: int64 ``(K, 4)``.

        Genes are ordered as :attr:`colours`: horizontal colours ``0 .. kh-1``, then vertical colours.
        """
        hi = {c: i for i, c in enumerate(self.horizontal)}
        vi = {c: len(self.horizontal) + i for i, c in enumerate(self.vertical)}
        return np.array([[hi[n], vi[e], hi[s], vi[w]] for n, e, s, w in self.tiles], dtype=np.int64).reshape(
            len(self.tiles), 4
        )

    # ----------------------------------------------------------- serialisation
    def to_dict(self) -> dict[str, Any]:
        """JSON-able description: ``{"kind": "wang", "name", "horizontal", "vertical", "tiles": [[N, E, S, W],
        ...]}``, plus ``"variants": [int, ...]`` when some variant is not 0 (so sets without variants keep
        their old description and digests)."""
        out: dict[str, Any] = {
            "kind": "wang",
            "name": self.name,
            "horizontal": list(self.horizontal),
            "vertical": list(self.vertical),
            "tiles": [list(t) for t in self.tiles],
        }
        if any(self.variants):
            out["variants"] = list(self.variants)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> WangTileSet:
        """Rebuild a set written by :meth:`to_dict` (raises ValueError on a bad description)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"expected a mapping, got {type(data).__name__}")
        if data.get("kind") != "wang":
            raise ValueError(f"expected a Wang tile set (kind 'wang'), got kind {data.get('kind')!r}")
        missing = [k for k in ("name", "horizontal", "vertical", "tiles") if k not in data]
        if missing:
            raise ValueError(f"tile set description lacks {', '.join(missing)}")
        tiles_raw = data["tiles"]
        if isinstance(tiles_raw, (str, bytes)) or not isinstance(tiles_raw, Sequence):
            raise ValueError("'tiles' must be a list of [N, E, S, W] lists")
        tiles = []
        for t in tiles_raw:
            if isinstance(t, bytes) or not isinstance(t, Sequence):
                raise ValueError(f"bad tile entry {t!r}: expected [N, E, S, W]")
            tiles.append(tuple(str(c) for c in t))
        variants = data.get("variants", ()) or ()
        if isinstance(variants, (str, bytes)) or not isinstance(variants, Sequence):
            raise ValueError("'variants' must be a list of ints")
        return cls(
            name=str(data["name"]),
            horizontal=_names(data["horizontal"], "horizontal colours"),
            vertical=_names(data["vertical"], "vertical colours"),
            tiles=tuple(tiles),  # type: ignore[arg-type]
            variants=tuple(variants),
        )


def complete_choice_set(k: int, name: str | None = None) -> WangTileSet:
    """The complete-choice set with ``k`` colours per direction: 2k² tiles, two per (N, W) pair.

    Tiles are listed by N, then W, then j (see the module docstring for the rule and why).

    Raises
    ------
    ValueError
        If ``k`` is not an integer in [2, 8].
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 2 <= k <= len(HORIZONTAL_COLOURS):
        raise ValueError(f"k = {k!r}: must be an integer in [2, {len(HORIZONTAL_COLOURS)}]")
    k = int(k)
    h, v = HORIZONTAL_COLOURS[:k], VERTICAL_COLOURS[:k]
    tiles = [
        (h[n], v[(w + j) % k], h[(n + j) % k], v[w]) for n in range(k) for w in range(k) for j in range(2)
    ]
    return WangTileSet(name=name or f"wang{2 * k * k}", horizontal=h, vertical=v, tiles=tuple(tiles))


def is_wang_set_name(name: str) -> bool:
    """Whether ``name`` names a Wang set (``"wang<2k²>"``), without building it."""
    if is_complete_wang_name(name):
        return True
    m = _NAME.fullmatch(str(name))
    if m is None or len(m.group(1)) > 3:  # at most wang128 (k = 8); a longer number is no set (and no float)
        return False
    size = int(m.group(1))
    k = int(round((size / 2) ** 0.5))
    return 2 * k * k == size and 2 <= k <= len(HORIZONTAL_COLOURS)


def get_wang_tileset(name: str) -> WangTileSet:
    """Return a named Wang tile set: ``"wang8"``, ``"wang18"`` or ``"wang<2k²>"`` (2 <= k <= 8).

    Raises
    ------
    ValueError
        If ``name`` is not such a name; the message lists the valid names.
    """
    complete = complete_wang_tileset(name)
    if complete is not None:
        return complete
    if not is_wang_set_name(name):
        raise ValueError(
            f"unknown Wang tile set {name!r}; valid names are: {', '.join(WANG_TILESET_NAMES)} "
            "(and wang<2k²> for k = 2 .. 8: wang8, wang18, wang32, ...)"
        )
    return _named_set(str(name))


@functools.cache
def _named_set(name: str) -> WangTileSet:
    """The cached set of a valid name (keyed by the string: any object may be passed as a name)."""
    size = int(name[4:])
    return complete_choice_set(int(round((size / 2) ** 0.5)), name=name)


# ------------------------------------------------------------------ complete sets (tilesynth.layouts.complete)
@functools.cache
def complete_edge_set(kh: int, kv: int, v: int = 1):
    """The complete Wang set over ``kh`` horizontal and ``kv`` vertical edge colours with ``v`` variants per
    tuple, in the spec's order: ``index = (((N·Kv + E)·Kh + S)·Kv + W)·V + variant``."""
    name = (f"wc{kh}" if kh == kv else f"wc{kh}-{kv}") + (f"x{v}" if v > 1 else "")
    limit = len(HORIZONTAL_COLOURS)
    if not (2 <= kh <= limit and 2 <= kv <= limit):
        raise ValueError(f"tile set {name!r}: a complete edge set needs 2 .. {limit} colours per direction")
    if v < 1:
        raise ValueError(f"tile set {name!r}: at least 1 variant per tuple")
    check_complete_size(name, kh * kh * kv * kv * v, "Kh^2 * Kv^2 * V")
    h, vv = HORIZONTAL_COLOURS[:kh], VERTICAL_COLOURS[:kv]
    tuples = [
        (h[n], vv[e], h[s], vv[w]) for n in range(kh) for e in range(kv) for s in range(kh) for w in range(kv)
    ]
    tiles = [t for t in tuples for _ in range(v)]
    variants = tuple(j for _ in tuples for j in range(v)) if v > 1 else ()
    return WangTileSet(name=name, horizontal=h, vertical=vv, tiles=tuple(tiles), variants=variants)


def is_complete_wang_name(name: Any) -> bool:
    """True for ``wc<K>`` / ``wc<Kh>-<Kv>`` / ``wc<K>x<V>`` / ``wc<Kh>-<Kv>x<V>`` with a valid size."""
    m = EDGE_NAME.fullmatch(str(name))
    if m is None or len(m.group(1)) > 2 or len(m.group(2) or "") > 2 or len(m.group(3) or "") > 4:
        return False
    try:
        complete_wang_tileset(name)
    except ValueError:
        return False
    return True


def complete_wang_tileset(name: Any):
    """The complete Wang set named ``name``, or None if it is no such name (ValueError if too large)."""
    m = EDGE_NAME.fullmatch(str(name))
    if m is None:
        return None
    if len(m.group(1)) > 2 or len(m.group(2) or "") > 2:
        raise ValueError(f"tile set {name!r}: at most 8 colours per direction")
    if len(m.group(3) or "") > 4:
        raise ValueError(f"tile set {name!r}: more than {MAX_COMPLETE_TILES} tiles (MAX_COMPLETE_TILES)")
    kh = int(m.group(1))
    kv = int(m.group(2)) if m.group(2) else kh
    return complete_edge_set(kh, kv, int(m.group(3)) if m.group(3) else 1)
