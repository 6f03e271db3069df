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

This module names the sets and re-exports the rest, which lives in three modules: the data model and the sets
of Ng et al. (:mod:`tilesynth.layouts.corner_tiles`), the extendable rule (:mod:`tilesynth.layouts.extendable`)
and the appendix's properties with the completeness check (:mod:`tilesynth.layouts.completeness`).
"""

from __future__ import annotations

import functools
import itertools
import re
from typing import Any

from .complete import CORNER_NAME, MAX_COMPLETE_TILES, check_complete_size, corner_colours
from .completeness import (
    DeadEnd,
    candidate_counts,
    check_properties,
    choices_summary,
    dead_ends,
    forbidden_pairs,
    reachable_situations,
)
from .corner_tiles import (
    _FACTORIES,
    BL,
    BR,
    PATCH_COLOURS,
    TILESET_NAMES,
    TL,
    TR,
    CornerTileSet,
    TileSetLike,
    tileset_from_dict,
)
from .extendable import (
    _NK_PATTERN,
    BASIC_SET_NAME,
    EXTENDABLE_TILESET_NAMES,
    MAX_EXTENSION,
    BasicSetCandidate,
    candidate_basic_sets,
    choose_basic_set,
    extend_tileset,
    extendable_tileset,
    extension_step,
)

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


@functools.cache
def get_tileset(name: str) -> CornerTileSet:
    """Return a named ω-tile set.

    Parameters
    ----------
    name : str
        ``"4"``, ``"8"``, ``"16a"``, ``"16b"``, ``"32"`` (the sets of Ng et al.),
        ``"B"`` (the basic 8-set 𝔹 of the extendable rule, see :func:`tilesynth.layouts.extendable._set_basic`) or
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


# ------------------------------------------------------------------ complete sets (tilesynth.layouts.complete)
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
