"""Complete tile sets: every corner (or edge) tuple over K colours, for the hashed lookup.

The seed papers' sets (4 .. 32, B, N1, N2) constrain the scan-line tiler: a 16a tiling has a 3-tile period in
its interior, and every vertex of colour c shows the same sample patch, so the outputs repeat visibly. A
*complete* set has a tile for every tuple, so every lattice vertex (edge) colour can be drawn independently —
from a hash of its coordinates (:mod:`tilesynth.lookup`): random access, any window, periodic outputs on request.

Names (accepted by :func:`tilesynth.get_tileset` and ``tilesynth build --set``):

``c<K>`` (``c2``, ``c3``, ``c4``, ...)
    ω-tiles (Lagae & Dutré's corner tiles built by the ω construction): every ⟨TL, BL, TR, BR⟩ over K vertex
    colours, K⁴ tiles, one sample patch per colour.
``c<K>x<V>`` (``c3x2``, ``c2x4``, ...)
    the same with V variants per tuple: variant v is cut from the (v+1)-th best matching patch of the
    tuple's intermediate tile, each more than N/4 pixels (Chebyshev) from the others, so the variants are not
    near-copies (:func:`tilesynth.omega.build_omega`). The lookup picks a variant per cell.
``wc<K>`` and ``wc<Kh>-<Kv>`` (``wc2``, ``wc3``, ``wc2-3``)
    Wang tiles (``--scheme wang`` / ``swang``): every ⟨N, E, S, W⟩ over Kh horizontal-edge and Kv
    vertical-edge colours, Kh²·Kv² tiles (``wc<K>``: Kh = Kv = K). Edge sets have one tile per tuple (the
    Wang set definition has no variants).

Tiles are stored in the index order of ``HASH-SPEC.md`` (colour numbers in the order of the set's alphabet):
corner ``index = (((TL·K + BL)·K + TR)·K + BR)·V + v``, edge ``index = (((N·Kv + E)·Kh + S)·Kv + W)``, so the
lookup needs no table. :func:`lookup_scheme` recognises a complete set by its tiles (not by its name), so a
loaded or custom-defined set in that order is hashed too.

Colours: ``R, G, B, Y, C, M`` then ``P6, P7, ...`` (corner); the Wang alphabets of :mod:`tilesynth.wangsets`.
At most :data:`MAX_COMPLETE_TILES` tiles (``c8`` has 4096; larger sets would take minutes to build and
gigabytes to hold at usual tile sizes).
"""

from __future__ import annotations

import functools
import itertools
import re
from typing import Any

from .lookup import LookupScheme

__all__ = [
    "COMPLETE_COLOURS",
    "MAX_COMPLETE_TILES",
    "complete_corner_set",
    "complete_edge_set",
    "complete_tileset",
    "complete_wang_tileset",
    "is_complete_wang_name",
    "lookup_scheme",
]

MAX_COMPLETE_TILES = 4096
"""Largest complete set built by name (K⁴·V or Kh²·Kv² tiles)."""

COMPLETE_COLOURS: tuple[str, ...] = ("R", "G", "B", "Y", "C", "M")
"""The first corner colours of a complete set (then ``P6``, ``P7``, ...)."""

_CORNER_NAME = re.compile(r"c([1-9][0-9]*)(?:x([1-9][0-9]*))?")
_EDGE_NAME = re.compile(r"wc([1-9][0-9]*)(?:-([1-9][0-9]*))?")


def corner_colours(k: int) -> tuple[str, ...]:
    """The K colour names of a complete corner set."""
    return tuple(COMPLETE_COLOURS[i] if i < len(COMPLETE_COLOURS) else f"P{i}" for i in range(k))


def _check_size(name: str, tiles: int, what: str) -> None:
    if tiles > MAX_COMPLETE_TILES:
        raise ValueError(
            f"tile set {name!r}: {what} = {tiles} tiles, more than {MAX_COMPLETE_TILES} (MAX_COMPLETE_TILES); "
            "use fewer colours or variants"
        )


@functools.cache
def complete_corner_set(k: int, v: int = 1):
    """The complete corner set over ``k`` colours with ``v`` variants per tuple, in the spec's index order."""
    from .tilesets import CornerTileSet

    if k < 2 or v < 1:
        raise ValueError(
            f"a complete corner set needs K >= 2 colours and V >= 1 variants, got K = {k}, V = {v}"
        )
    name = f"c{k}" if v == 1 else f"c{k}x{v}"
    _check_size(name, k**4 * v, "K^4 * V")
    cols = corner_colours(k)
    tiles, variants = [], []
    for t in itertools.product(range(k), repeat=4):  # TL, BL, TR, BR with BR fastest: the spec's order
        for var in range(v):
            tiles.append(tuple(cols[i] for i in t))
            variants.append(var)
    return CornerTileSet(name=name, colours=cols, tiles=tuple(tiles), variants=tuple(variants))


@functools.cache
def complete_edge_set(kh: int, kv: int):
    """The complete Wang set over ``kh`` horizontal and ``kv`` vertical edge colours, in the spec's order."""
    from .wangsets import HORIZONTAL_COLOURS, VERTICAL_COLOURS, WangTileSet

    name = f"wc{kh}" if kh == kv else f"wc{kh}-{kv}"
    limit = len(HORIZONTAL_COLOURS)
    if not (2 <= kh <= limit and 2 <= kv <= limit):
        raise ValueError(f"tile set {name!r}: a complete edge set needs 2 .. {limit} colours per direction")
    _check_size(name, kh * kh * kv * kv, "Kh^2 * Kv^2")
    h, vv = HORIZONTAL_COLOURS[:kh], VERTICAL_COLOURS[:kv]
    tiles = [
        (h[n], vv[e], h[s], vv[w]) for n in range(kh) for e in range(kv) for s in range(kh) for w in range(kv)
    ]
    return WangTileSet(name=name, horizontal=h, vertical=vv, tiles=tuple(tiles))


def complete_tileset(name: Any):
    """The complete corner set named ``name`` (``c<K>`` / ``c<K>x<V>``), or None if it is no such name."""
    m = _CORNER_NAME.fullmatch(str(name))
    if m is None:
        return None
    if len(m.group(1)) > 3 or len(m.group(2) or "") > 5:
        raise ValueError(f"tile set {name!r}: more than {MAX_COMPLETE_TILES} tiles (MAX_COMPLETE_TILES)")
    return complete_corner_set(int(m.group(1)), int(m.group(2) or 1))


def is_complete_wang_name(name: Any) -> bool:
    """True for ``wc<K>`` / ``wc<Kh>-<Kv>`` with a valid size."""
    m = _EDGE_NAME.fullmatch(str(name))
    if m is None or len(m.group(1)) > 2 or len(m.group(2) or "") > 2:
        return False
    try:
        complete_wang_tileset(name)
    except ValueError:
        return False
    return True


def complete_wang_tileset(name: Any):
    """The complete Wang set named ``name``, or None if it is no such name (ValueError if too large)."""
    m = _EDGE_NAME.fullmatch(str(name))
    if m is None:
        return None
    if len(m.group(1)) > 2 or len(m.group(2) or "") > 2:
        raise ValueError(f"tile set {name!r}: at most 8 colours per direction")
    kh = int(m.group(1))
    kv = int(m.group(2)) if m.group(2) else kh
    return complete_edge_set(kh, kv)


def lookup_scheme(defn: Any) -> LookupScheme | None:
    """The hashed-lookup scheme of a tile-set definition if it is complete and in the spec's index order
    (whatever its name), else None (the scan-line tiler's sets)."""
    from .tilesets import CornerTileSet
    from .wangsets import WangTileSet

    if isinstance(defn, CornerTileSet):
        k = len(defn.colours)
        n = len(defn)
        if k < 1 or n % (k**4) != 0:
            return None
        v = n // k**4
        index = {c: i for i, c in enumerate(defn.colours)}
        scheme = LookupScheme("corner", (k,), v)
        for j, (t, var) in enumerate(zip(defn.tiles, defn.variants)):
            if var != j % v or scheme.index(tuple(index[c] for c in t), var) != j:  # type: ignore[arg-type]
                return None
        return scheme
    if isinstance(defn, WangTileSet):
        kh, kv = len(defn.horizontal), len(defn.vertical)
        if len(defn) != kh * kh * kv * kv:
            return None
        hi = {c: i for i, c in enumerate(defn.horizontal)}
        vi = {c: i for i, c in enumerate(defn.vertical)}
        scheme = LookupScheme("edge", (kh, kv), 1)
        for j, (n_, e, s, w) in enumerate(defn.tiles):
            if scheme.index((hi[n_], vi[e], hi[s], vi[w])) != j:
                return None
        return scheme
    return None


def default_complete_tile_size(shape: tuple[int, ...]) -> int:
    """Default tile size of a complete set: a quarter of the exemplar's shorter side, rounded down to even,
    capped at 256, at least 8 (or the half-side default of small exemplars)."""
    from .genes import default_tile_size

    n = min(shape[0], shape[1]) // 4
    n -= n % 2
    return min(256, n) if n >= 8 else default_tile_size(shape)


def complete_defaults(defn: Any, shape: tuple[int, ...], match: Any, metric: Any) -> dict[str, Any] | None:
    """The build defaults of a complete corner set (None for other sets): tile size, the free cut region and
    diversity 1 (only with the plain SSD match, which :func:`tilesynth.levers.diverse_matches` reassigns)."""
    if lookup_scheme(defn) is None:
        return None
    return {
        "tile_size": default_complete_tile_size(shape),
        "cut_region": "free",
        "diversity": 1 if (match, metric) == ("ssd", "color") else 0,
    }
