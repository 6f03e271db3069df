"""The tile-size rules every scheme shares: the default tile size, the smallest tile, and the checks of a tile
size and of an exemplar against it.

They live with the layouts (below the builder) because the complete sets' default tile size
(:func:`tilesynth.layouts.complete.default_complete_tile_size`) builds on them; the genes stage re-exports them
(:mod:`tilesynth.builder.genes.draws`).
"""

from __future__ import annotations

from typing import Any

from ..base.validate import positive_int
from ..errors import ParameterError

__all__ = ["MIN_TILE_SIZE", "check_exemplar_size", "check_tile_size", "default_tile_size"]

MIN_TILE_SIZE = 4
"""The smallest tile: 4 x 4 (2 x 2 quadrants; the cut needs a border ring and a cross inside it)."""


def default_tile_size(shape: tuple[int, ...]) -> int:
    """Half the exemplar's shorter side, rounded down to even, capped at 256 (002 used 64 on 128 inputs), and
    at least :data:`MIN_TILE_SIZE` (exemplars of 4 to 7 pixels a side get 4: the whole-side tile)."""
    n = min(shape[0], shape[1]) // 2
    n -= n % 2
    return max(MIN_TILE_SIZE, min(n, 256))


def check_exemplar_size(shape: tuple[int, ...]) -> None:
    """Refuse exemplars smaller than the smallest tile (a 1x1 image is a valid file, not a texture)."""
    if min(shape[0], shape[1]) < MIN_TILE_SIZE:
        raise ParameterError(
            f"exemplar has shape {tuple(shape)}: too small, at least {MIN_TILE_SIZE}x{MIN_TILE_SIZE} pixels are "
            f"needed (the smallest tile is {MIN_TILE_SIZE}x{MIN_TILE_SIZE})"
        )


def check_tile_size(tile_size: Any, shape: tuple[int, ...]) -> int:
    """Validate ``tile_size`` against an exemplar of ``shape`` (even, >= 4, fits inside the exemplar)."""
    n = positive_int(tile_size, "tile_size", minimum=MIN_TILE_SIZE)
    if n % 2:
        raise ParameterError(
            f"tile_size = {n}: must be even (the tile is cut from the centre of a 2x2 block)"
        )
    if n > shape[0] or n > shape[1]:
        raise ParameterError(
            f"tile_size = {n}: larger than the exemplar ({shape[1]}x{shape[0]} pixels); "
            f"use at most {min(shape[0], shape[1]) - min(shape[0], shape[1]) % 2}"
        )
    return n
