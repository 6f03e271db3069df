"""Complete tile sets: every corner (or edge) tuple over K colours, for the hashed lookup.

The seed papers' sets (4 .. 32, B, N1, N2) constrain the scan-line tiler: a 16a tiling has a 3-tile period in
its interior, and every vertex of colour c shows the same sample patch, so the outputs repeat visibly. A
*complete* set has a tile for every tuple, so every lattice vertex (edge) colour can be drawn independently —
from a hash of its coordinates (:mod:`tilesynth.layouts.hashed`): random access, any window, periodic outputs on request.

Names (accepted by :func:`tilesynth.get_tileset` and ``tilesynth build --set``):

``c<K>`` (``c2``, ``c3``, ``c4``, ...)
    ω-tiles (Lagae & Dutré's corner tiles built by the ω construction): every ⟨TL, BL, TR, BR⟩ over K vertex
    colours, K⁴ tiles, one sample patch per colour.
``c<K>x<V>`` (``c3x2``, ``c2x4``, ...)
    the same with V variants per tuple: variant v is cut from the (v+1)-th best matching patch of the
    tuple's intermediate tile, each more than N/4 pixels (Chebyshev) from the others, so the variants are not
    near-copies (:func:`tilesynth.builder.omega.build_omega`). The lookup picks a variant per cell.
``wc<K>`` and ``wc<Kh>-<Kv>`` (``wc2``, ``wc3``, ``wc2-3``)
    Wang tiles (``--scheme wang`` / ``swang``): every ⟨N, E, S, W⟩ over Kh horizontal-edge and Kv
    vertical-edge colours, Kh²·Kv² tiles (``wc<K>``: Kh = Kv = K).
``wc<K>x<V>`` and ``wc<Kh>-<Kv>x<V>`` (``wc2x2``, ``wc2-3x3``)
    the same with V variants per tuple (Kh²·Kv²·V tiles), strict Wang tiles only (``--scheme swang``): variant
    v takes the (v+1)-th best supplementary patch of the tuple's initial tile, each more than N/4 pixels
    (Chebyshev) from the others (with ``supplementary="cut"``: the (v+1)-th cheapest closed cut among the
    candidates), so the variants differ in the middle of the tile and share its edges. Cohen's Wang tiles
    (``--scheme wang``) are made from their four edge samples alone, so their variants would be copies: refused.
    The lookup picks a variant per cell.

Tiles are stored in the index order of ``HASH-SPEC.md`` (colour numbers in the order of the set's alphabet):
corner ``index = (((TL·K + BL)·K + TR)·K + BR)·V + v``, edge ``index = (((N·Kv + E)·Kh + S)·Kv + W)·V + v``, so the
lookup needs no table. :func:`lookup_scheme` recognises a complete set by its tiles (not by its name), so a
loaded or custom-defined set in that order is hashed too.

Where the code is (so that no module imports back into this one): the corner sets are built by
:func:`tilesynth.layouts.omega_sets.complete_corner_set` / ``complete_tileset``, the edge sets by
:func:`tilesynth.layouts.wang_sets.complete_edge_set` / ``complete_wang_tileset``, and a set is recognised by
:func:`tilesynth.layouts.hashed.lookup_scheme`; this module holds the names, sizes and build defaults.

Colours: ``R, G, B, Y, C, M`` then ``P6, P7, ...`` (corner); the Wang alphabets of :mod:`tilesynth.layouts.wang_sets`.
At most :data:`MAX_COMPLETE_TILES` tiles (``c8`` has 4096; larger sets would take minutes to build and
gigabytes to hold at usual tile sizes).
"""

from __future__ import annotations

import re
from typing import Any

from .hashed import lookup_scheme
from .tile_size import default_tile_size

__all__ = [
    "COMPLETE_COLOURS",
    "CORNER_NAME",
    "EDGE_NAME",
    "MAX_COMPLETE_TILES",
    "check_complete_size",
    "complete_defaults",
    "corner_colours",
    "default_complete_tile_size",
]

MAX_COMPLETE_TILES = 4096
"""Largest complete set built by name (K⁴·V or Kh²·Kv² tiles)."""

COMPLETE_COLOURS: tuple[str, ...] = ("R", "G", "B", "Y", "C", "M")
"""The first corner colours of a complete set (then ``P6``, ``P7``, ...)."""

CORNER_NAME = re.compile(r"c([1-9][0-9]*)(?:x([1-9][0-9]*))?")
EDGE_NAME = re.compile(r"wc([1-9][0-9]*)(?:-([1-9][0-9]*))?(?:x([1-9][0-9]*))?")


def corner_colours(k: int) -> tuple[str, ...]:
    """The K colour names of a complete corner set."""
    return tuple(COMPLETE_COLOURS[i] if i < len(COMPLETE_COLOURS) else f"P{i}" for i in range(k))


def check_complete_size(name: str, tiles: int, what: str) -> None:
    if tiles > MAX_COMPLETE_TILES:
        raise ValueError(
            f"tile set {name!r}: {what} = {tiles} tiles, more than {MAX_COMPLETE_TILES} (MAX_COMPLETE_TILES); "
            "use fewer colours or variants"
        )


def default_complete_tile_size(shape: tuple[int, ...]) -> int:
    """Default tile size of a complete set: a quarter of the exemplar's shorter side rounded down to a multiple
    of 8, capped at 256; exemplars under 32 pixels a side get the half-side default.

    A multiple of 8 halves three times to a whole number, so the engine export's per-tile mip chains reach
    level 3 with its default 8-texel gutter (:func:`tilesynth.engine.atlas.max_mip_level`; the 94-px tiles of
    the demo reached level 1). Down rather than to the nearest: measured on the bench textures whose quarter
    side is not a multiple of 8 (c4, 1024², seed 1), lettuce 88 / 94 / 96 px gave border seam scores 0.75 /
    0.94 / 0.98 and pebbles 56 / 60 / 64 px 0.62 / 0.78 / 2.33 (copies 0.09 / 0.10 / 0.15), the other measures
    within the spread between textures."""
    side = min(shape[0], shape[1])
    if side < 32:
        return default_tile_size(shape)
    return min(256, 8 * (side // 32))


def complete_defaults(defn: Any, shape: tuple[int, ...], match: Any, metric: Any) -> dict[str, Any] | None:
    """The build defaults of a complete corner set (None for other sets): tile size, the free cut region and
    diversity 1 (only with the plain SSD match, which :func:`tilesynth.builder.matching.levers.diverse_matches` reassigns)."""
    if lookup_scheme(defn) is None:
        return None
    return {
        "tile_size": default_complete_tile_size(shape),
        "cut_region": "free",
        "diversity": 1 if (match, metric) == ("ssd", "color") else 0,
    }
