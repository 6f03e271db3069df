"""tilesynth: small tile sets from one example texture, and seamless non-periodic textures of any size.

Quick start::

    import tilesynth as ts
    img, bits = ts.load_image("gravel.png")            # float32 (H, W, C) in [0, 1]
    tiles = ts.build_omega(img, tileset="16a", seed=1)   # 16 ω-tiles with provenance
    tiles.save("gravel.tiles")
    texture, index_map = ts.synthesize(tiles, 1024, 1024, seed=7)
    ts.save_image("gravel-1024.png", texture)

Wang tiles: :func:`build_wang` (Cohen et al. with 001's match and GA, Burke's variant) and :func:`build_swang`
(strict Wang tiles, 004) with the edge-coloured sets ``wang8`` / ``wang18`` (:func:`get_wang_tileset`);
:func:`build` dispatches on ``scheme="omega" | "wang" | "swang"``.

Kernels (Rust, GIL released, thread-count independent): :func:`patch_ssd`, :func:`best_matches`,
:func:`grid_mincut`, :func:`kwatra_weights`, :func:`omega_cuts`, :func:`tile_copy`,
:class:`PopulationEvaluator` / :func:`evaluate_population` (the ω-tile objective E for GA populations),
:func:`poisson_smooth` (guided interpolation inside the cutting curve, exact to a stated residual).
"""

from __future__ import annotations

from . import data  # noqa: F401 - tilesynth.data.example_path(): the bundled exemplar
from ._version import __version__
from .base.kernels import (
    PoissonInfo,
    PopulationEvaluator,
    SsdIndex,
    WangEvaluator,
    best_matches,
    evaluate_population,
    grid_mincut,
    kwatra_weights,
    omega_cuts,
    patch_ssd,
    poisson_smooth,
    swang_cuts,
    tile_copy,
    wang_tiles,
)
from .builder.omega import build_omega, energy
from .builder.swang import build_swang
from .builder.wang import build_wang
from .errors import InternalError, ParameterError, ShapeError, TileSetFormatError, TilesynthError
from .io.images import load_image, load_raster, save_image
from .layouts.omega_sets import TILESET_NAMES, get_tileset
from .layouts.scanline import scanline_index_map, validate_index_map
from .layouts.wang_sets import WANG_TILESET_NAMES, WangTileSet, get_wang_tileset
from .measure.metrics import coherence_energy, image_metrics, seam_score, tileset_metrics
from .measure.render import contact_sheet
from .measure.report import write_report
from .schemes import SCHEMES, build
from .schemes.patch import build_patch
from .synth.synthesis import source_map, synthesize, synthesize_map
from .tileset.tilefile import TileSet

load = TileSet.load
"""Load a ``.tiles`` file (alias of :meth:`TileSet.load`)."""

from .engine import export  # noqa: E402 - engine export (atlases, index map / hash, shaders, viewer)

__all__ = [
    "SCHEMES",
    "TILESET_NAMES",
    "InternalError",
    "WANG_TILESET_NAMES",
    "ParameterError",
    "PoissonInfo",
    "PopulationEvaluator",
    "ShapeError",
    "SsdIndex",
    "TileSet",
    "TileSetFormatError",
    "TilesynthError",
    "WangEvaluator",
    "WangTileSet",
    "__version__",
    "best_matches",
    "build",
    "build_omega",
    "coherence_energy",
    "build_swang",
    "build_wang",
    "contact_sheet",
    "energy",
    "evaluate_population",
    "get_tileset",
    "get_wang_tileset",
    "grid_mincut",
    "image_metrics",
    "kwatra_weights",
    "load",
    "load_image",
    "load_raster",
    "omega_cuts",
    "patch_ssd",
    "poisson_smooth",
    "save_image",
    "scanline_index_map",
    "seam_score",
    "source_map",
    "swang_cuts",
    "synthesize",
    "synthesize_map",
    "tile_copy",
    "tileset_metrics",
    "validate_index_map",
    "write_report",
    "wang_tiles",
    "export",
    "LookupScheme",
    "ts_hash",
    "hashed_index_map",
    "periodic_copies",
    "repeated_patches",
    "detail_repetition",
    "histogram_distance",
    "build_patch",
    "build_material",
    "synthesize_maps",
    "inner_seam_score",
    "InputWarning",
    "lattice_gradient",
    "lattice_folded",
    "objects_intact",
]

from .builder.materials import synthesize_maps  # noqa: E402 - material builds
from .layouts.hashed import LookupScheme, ts_hash  # noqa: E402 - the hashed lookup
from .layouts.hashed import index_map as hashed_index_map  # noqa: E402
from .measure.diagnose import InputWarning  # noqa: E402 - warnings for suspicious inputs
from .measure.lattice import lattice_folded, lattice_gradient, objects_intact  # noqa: E402
from .measure.metrics import (  # noqa: E402
    detail_repetition,
    histogram_distance,
    inner_seam_score,
    periodic_copies,
    repeated_patches,
)
from .schemes import build_material  # noqa: E402
