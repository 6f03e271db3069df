"""Geometry of the corner layout (tiles keyed by corner colours ⟨TL, BL, TR, BR⟩, one sample patch per colour).

Used by every corner scheme (ω-tiles, the patch baseline): which patch goes in which quadrant of a tile
(:func:`intermediate_tiles`), and the distinct corner tuples of a set with the variant of each tile
(:class:`CornerPlan`). The edge layout's geometry (⟨N, E, S, W⟩, diamonds) is in :mod:`tilesynth.builder.wang`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError
from .omega_sets import get_tileset

__all__ = ["CornerPlan", "IntermediateTiles", "corner_set", "intermediate_tiles"]


@dataclass(frozen=True)
class CornerPlan:
    """A corner set's tiles as gene indices, and the intermediate tiles they need.

    ``tile_patches`` ``(K, 4)``: the gene index of each tile's ⟨TL, BL, TR, BR⟩ patch; ``unique`` ``(U, 4)``: the
    distinct tuples in the order they first appear; ``inverse`` ``(K,)``: each tile's row of ``unique``;
    ``variants`` ``(K,)``: which of the tuple's tiles it is (0, 1, ...; the 32-set and the x2..x4 sets have
    several per tuple); ``n_variants`` the most variants of a tuple.
    """

    tile_patches: np.ndarray
    unique: np.ndarray
    inverse: np.ndarray
    variants: np.ndarray
    n_variants: int
    n_colours: int

    @classmethod
    def of(cls, definition: Any) -> CornerPlan:
        colours = list(definition.colours)
        index = {c: i for i, c in enumerate(colours)}
        tile_patches = np.array([[index[c] for c in t] for t in definition.tiles], dtype=np.int64)
        variants = np.asarray(definition.variants, dtype=np.int64)
        uniq, first, inverse = np.unique(tile_patches, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first)  # keep the order in which tuples first appear
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        return cls(
            tile_patches, uniq[order], rank[np.asarray(inverse).reshape(-1)], variants, int(variants.max()) + 1,
            len(colours),
        )  # fmt: skip

    def subset(self, tiles: np.ndarray) -> CornerPlan:
        """The plan of the tiles ``tiles`` (indices into :attr:`tile_patches`) alone, in that order: their
        distinct tuples in first-appearance order (:mod:`tilesynth.builder.genes.window_objective`)."""
        idx = np.asarray(tiles, dtype=np.int64).reshape(-1)
        rows = self.inverse[idx]
        _, first, inv = np.unique(rows, return_index=True, return_inverse=True)
        order = np.argsort(first)
        rank = np.empty_like(order)
        rank[order] = np.arange(order.size)
        return CornerPlan(
            self.tile_patches[idx], self.unique[rows[np.sort(first)]], rank[np.asarray(inv).reshape(-1)],
            self.variants[idx], self.n_variants, self.n_colours,
        )  # fmt: skip


def intermediate_tiles(
    exemplar: np.ndarray, genes: np.ndarray, tile_patches: np.ndarray, tile_size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Assemble intermediate tiles and their provenance.

    ``tile_patches`` is ``(K, 4)``: the gene index of each tile's ⟨TL, BL, TR, BR⟩ patch. Returns float32
    ``(K, N, N, C)`` tiles and int32 ``(K, N, N, 2)`` exemplar coordinates of every pixel.
    """
    h = tile_size // 2
    k = tile_patches.shape[0]
    c = exemplar.shape[2]
    tiles = np.empty((k, tile_size, tile_size, c), np.float32)
    src = np.empty((k, tile_size, tile_size, 2), np.int32)
    yy, xx = np.mgrid[0:h, 0:h].astype(np.int32)
    # quadrant (tile rows, tile cols) <- patch offset (rows, cols) inside the patch, for TL, BL, TR, BR
    quads = [
        ((slice(0, h), slice(0, h)), (h, h)),  # TL: bottom-right quarter of the TL patch
        ((slice(h, None), slice(0, h)), (0, h)),  # BL: top-right quarter of the BL patch
        ((slice(0, h), slice(h, None)), (h, 0)),  # TR: bottom-left quarter of the TR patch
        ((slice(h, None), slice(h, None)), (0, 0)),  # BR: top-left quarter of the BR patch
    ]
    for j in range(k):
        for q, ((rs, cs), (dy, dx)) in enumerate(quads):
            r0, c0 = genes[tile_patches[j, q]] + (dy, dx)
            tiles[j, rs, cs] = exemplar[r0 : r0 + h, c0 : c0 + h]
            src[j, rs, cs, 0] = yy + r0
            src[j, rs, cs, 1] = xx + c0
    return tiles, src


class IntermediateTiles:
    """The intermediate tiles of ``tile_patches`` ``(U, 4)``, assembled on demand: :meth:`take` returns what
    ``intermediate_tiles(...)`` rows ``ii`` hold (the same bytes: each tile is a copy of four exemplar
    quadrants). The cut stage takes them a chunk at a time (:func:`tilesynth.builder.compose.cut_and_compose`),
    so a 625-tile c5 set does not keep 205 MB of intermediate tiles and provenance after its matching search."""

    def __init__(self, exemplar: np.ndarray, genes: np.ndarray, tile_patches: np.ndarray, tile_size: int):
        self.exemplar, self.genes, self.tile_patches, self.tile_size = (
            exemplar,
            genes,
            tile_patches,
            tile_size,
        )
        self.shape = (tile_patches.shape[0], tile_size, tile_size, exemplar.shape[2])

    def take(self, ii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(tiles, src)`` of the intermediate tiles ``ii``, as :func:`intermediate_tiles` returns them."""
        return intermediate_tiles(
            self.exemplar, self.genes, self.tile_patches[np.asarray(ii)], self.tile_size
        )


def corner_set(tileset: Any) -> Any:
    """The corner tile-set definition named ``tileset``."""
    if not isinstance(tileset, str):
        raise ParameterError(f"tileset = {tileset!r}: expected a tile-set name such as '16a' or 'n2'")
    return get_tileset(tileset)
