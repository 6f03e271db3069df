"""tilesynth: small tile sets from one example texture, and seamless non-periodic textures of any size.

Quick start::

    import tilesynth as ts
    img, bits = ts.load_image("gravel.png")            # float32 (H, W, C) in [0, 1]
    tiles = ts.build_omega(img, tileset="16a", seed=1)   # 16 ω-tiles with provenance
    tiles.save("gravel.tiles")
    texture, index_map = ts.synthesize(tiles, 1024, 1024, seed=7)
    ts.save_image("gravel-1024.png", texture)

Kernels (Rust, GIL released, thread-count independent): :func:`patch_ssd`, :func:`best_matches`,
:func:`grid_mincut`, :func:`kwatra_weights`, :func:`omega_cuts`, :func:`tile_copy`,
:class:`PopulationEvaluator` / :func:`evaluate_population` (the ω-tile objective E for GA populations),
:func:`poisson_smooth` (guided interpolation inside the cutting curve, exact to a stated residual).
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tilesynth")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    from ._core import __version__

from .errors import ParameterError, ShapeError, TileSetFormatError, TilesynthError
from .io import load_image, save_image
from .kernels import (
    PoissonInfo,
    PopulationEvaluator,
    SsdIndex,
    best_matches,
    evaluate_population,
    grid_mincut,
    kwatra_weights,
    omega_cuts,
    patch_ssd,
    poisson_smooth,
    tile_copy,
)
from .omega import build_omega, energy
from .render import contact_sheet
from .synthesis import source_map, synthesize
from .tilefile import TileSet
from .tilesets import TILESET_NAMES, get_tileset
from .tiling import scanline_index_map, validate_index_map

load = TileSet.load
"""Load a ``.tiles`` file (alias of :meth:`TileSet.load`)."""

__all__ = [
    "TILESET_NAMES",
    "ParameterError",
    "PoissonInfo",
    "PopulationEvaluator",
    "ShapeError",
    "SsdIndex",
    "TileSet",
    "TileSetFormatError",
    "TilesynthError",
    "__version__",
    "best_matches",
    "build_omega",
    "contact_sheet",
    "energy",
    "evaluate_population",
    "get_tileset",
    "grid_mincut",
    "kwatra_weights",
    "load",
    "load_image",
    "omega_cuts",
    "patch_ssd",
    "poisson_smooth",
    "save_image",
    "scanline_index_map",
    "source_map",
    "synthesize",
    "tile_copy",
    "validate_index_map",
]
