"""A tile size from the exemplar's feature scale (opt-in): larger tiles where the exemplar's objects are
large against the default tile.

The complete sets' default tile size is a quarter of the exemplar's shorter side
(:func:`tilesynth.layouts.complete.default_complete_tile_size`), whatever the exemplar shows. Cuts of an
ω-tile run near its borders and through its middle, so content larger than about a quarter of a tile is cut
in most tiles: coins, tiles of a floor, squares of a carpet. :func:`feature_tile_size` measures the feature
scale and asks for a tile about four features wide. The feature is the equivalent diameter d = 2·√(A/π) of
the typical object (A the reference area of :func:`tilesynth.measure.lattice.objects_intact`), where the
exemplar is one of separate objects; other exemplars keep the default. (A structure scale from the
luminance autocorrelation, the lag where it falls below ½, was tried: 2-9 px on the structured textures, so
no change there, and 20-25 px on the stochastic rust and sea foam, whose broad shading it read as structure:
left out.)

N = 4·d, rounded up to a multiple of 8 (the engine export's mip levels, as
the default), never below the default and at most half the shorter side (a c5 set needs room for its five
sample patches) and 256. Factor 4: an object of diameter d survives a grid of cuts of spacing s with
probability about (1 − d/s)² (two families of lines); the cuts of an ω-tile come at about s ≈ N/2 (borders and
the intermediate tile's cross seam), so N = 4·d keeps about a quarter of the objects whole (N = 2·d none).
More would be better for objects and worse for repetition (fewer, larger sample patches: more copies); the
cap keeps it within what the exemplar can feed. Exemplars that are not of separate objects, or whose objects
ask for no more than the default, get None (the build's own default, periodic rule included), so their builds
are unchanged byte for byte.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..base.validate import as_image
from ..layouts.complete import default_complete_tile_size
from ..measure.lattice import FEATURES_PER_TILE, object_tile_size
from ..measure.lattice import MAX_OBJECT_TILE as MAX_TILE

__all__ = ["FEATURES_PER_TILE", "MAX_TILE", "feature_tile_size"]


def feature_tile_size(exemplar: np.ndarray) -> tuple[int | None, dict[str, Any]]:
    """Tile size for ``build_omega(..., tile_size=...)`` from the exemplar's feature scale (module docstring),
    and how it was chosen: ``{"default", "kind" ("objects" or None), "scale", "size"}``.

    None where the objects ask for no more than the default (or there are none): an explicit tile size turns
    off the build's own choices (the periodic-exemplar rule of :mod:`tilesynth.builder.periodic`), so the
    default is left to the build rather than passed back."""
    ex = as_image(exemplar, "exemplar")
    n0 = default_complete_tile_size(ex.shape)
    # the size formula lives beside the measure: the build's objects-cut warning uses it too
    want, scale = object_tile_size(ex)
    kind = None if want is None else "objects"
    n = want if want is not None and want > n0 else None
    return n, {"default": n0, "kind": kind, "scale": scale, "size": n0 if n is None else n}
