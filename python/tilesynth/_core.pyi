"""Type stubs of the compiled extension ``tilesynth._core`` (see rust/py/mod.rs)."""

from typing import final

import numpy as np
import numpy.typing as npt
from typing_extensions import Self

__all__ = [
    "__version__",
    "DEFAULT_EPS",
    "DEFAULT_POISSON_TOL",
    "DEFAULT_LAMBDA",
    "DEFAULT_OMEGA",
    "DEFAULT_CACHE_BYTES",
    "MAX_THREADS",
    "THREADS_ENV",
    "WANG_SIDES",
    "SsdIndex",
    "PopulationEvaluator",
    "WangEvaluator",
    "grid_mincut",
    "grid_mincut8",
    "grid_mincuts",
    "kwatra_weights",
    "omega_cuts",
    "poisson_smooth",
    "tile_copy",
    "wang_tiles",
    "swang_cuts",
    "resolve_threads",
    "png_unfilter",
    "edge_weight_sums",
    "weighted_ssd_map",
    "_raise_panic",
    # the hashed lookup (rust/py/hash.rs)
    "HASH_NAME",
    "HASH_PCG_MUL",
    "HASH_PCG_INC",
    "HASH_ROLE_MUL",
    "HASH_ROLES",
    "ts_hash",
    "hashed_index_map",
    "tile_copy_window",
    # image files (rust/py/io.rs)
    "png_decode",
    "png_encode",
    "exr_decode",
    "exr_encode",
    # gradients (rust/py/gradients.rs) and the bench baseline of the matching (rust/py/ssd.rs)
    "patch_gradients",
    "_best_matches_sorting",
    # tile sets as provenance (rust/py/provenance.rs)
    "provenance_factorise",
    "provenance_gather",
    # the seam blend of smooth material maps (rust/py/blend.rs)
    "seam_blend",
    # matching from shared quadrants (rust/py/ssd.rs)
    "quadrant_map",
    "best_matches_quadrants",
]

__version__: str
DEFAULT_EPS: float
DEFAULT_POISSON_TOL: float
DEFAULT_LAMBDA: float
DEFAULT_OMEGA: float
DEFAULT_CACHE_BYTES: int
MAX_THREADS: int
THREADS_ENV: str
WANG_SIDES: tuple[int, int, int, int]

@final
class SsdIndex:
    def __new__(cls, image: npt.NDArray[np.float32], threads: int | None = None) -> Self: ...
    @property
    def shape(self) -> tuple[int, int, int]: ...
    def ssd_maps(
        self,
        templates: npt.NDArray[np.float32],
        mask: npt.NDArray[np.bool_] | None = None,
        threads: int | None = None,
    ) -> npt.NDArray[np.float32]: ...
    def best_matches(
        self,
        templates: npt.NDArray[np.float32],
        k: int = 1,
        exclude_radius: int = 0,
        mask: npt.NDArray[np.bool_] | None = None,
        threads: int | None = None,
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...

@final
class PopulationEvaluator:
    def __new__(
        cls,
        exemplar: npt.NDArray[np.float32],
        tile_size: int,
        tile_patches: npt.NDArray[np.int64],
        n_patches: int,
        lam: float = ...,
        normalise: bool = False,
        cache_bytes: int = ...,
    ) -> Self: ...
    @property
    def dims(self) -> tuple[int, int, int]: ...
    def evaluate(
        self, genes: npt.NDArray[np.int64], threads: int | None = None
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    def cache_stats(self) -> dict[str, int]: ...
    def clear_cache(self) -> None: ...

def grid_mincut(
    wx: npt.NDArray[np.float64],
    wy: npt.NDArray[np.float64],
    source_hard: npt.NDArray[np.bool_],
    sink_hard: npt.NDArray[np.bool_],
    source_cap: npt.NDArray[np.float64] | None = None,
    sink_cap: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.bool_], float]: ...
def grid_mincut8(
    wx: npt.NDArray[np.float64],
    wy: npt.NDArray[np.float64],
    wd: npt.NDArray[np.float64],
    wa: npt.NDArray[np.float64],
    source_hard: npt.NDArray[np.bool_],
    sink_hard: npt.NDArray[np.bool_],
    source_cap: npt.NDArray[np.float64] | None = None,
    sink_cap: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.bool_], float]: ...
def grid_mincuts(
    wx: npt.NDArray[np.float64],
    wy: npt.NDArray[np.float64],
    source_hard: npt.NDArray[np.bool_],
    sink_hard: npt.NDArray[np.bool_],
    sink_cap: npt.NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]]: ...
def kwatra_weights(
    a: npt.NDArray[np.float32],
    b: npt.NDArray[np.float32],
    region: npt.NDArray[np.bool_] | None = None,
    eps: float = ...,
    a_grad: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def omega_cuts(
    intermediate: npt.NDArray[np.float32],
    matching: npt.NDArray[np.float32],
    eps: float = ...,
    threads: int | None = None,
    intermediate_grad: npt.NDArray[np.float64] | None = None,
    keep_border: bool = True,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]]: ...
def poisson_smooth(
    dst: npt.NDArray[np.float32],
    src: npt.NDArray[np.float32],
    region: npt.NDArray[np.bool_],
    tol: float = ...,
    threads: int | None = None,
) -> tuple[
    npt.NDArray[np.float32], npt.NDArray[np.int64], npt.NDArray[np.float64], npt.NDArray[np.int64]
]: ...
def tile_copy(
    atlas: npt.NDArray[np.generic],
    index_map: npt.NDArray[np.int32],
    out: npt.NDArray[np.generic],
    threads: int | None = None,
) -> None: ...
def resolve_threads(threads: int | None = None) -> int: ...
def _raise_panic(message: str) -> None: ...
def png_unfilter(
    data: npt.NDArray[np.uint8], rows: int, row_bytes: int, bpp: int
) -> npt.NDArray[np.uint8]: ...
def edge_weight_sums(
    template: npt.NDArray[np.float32],
    image: npt.NDArray[np.float32],
    wx_mask: npt.NDArray[np.bool_],
    wy_mask: npt.NDArray[np.bool_],
    eps: float = ...,
    template_grad: npt.NDArray[np.float64] | None = None,
    threads: int | None = None,
) -> npt.NDArray[np.float64]: ...
def weighted_ssd_map(
    image: npt.NDArray[np.float32],
    image_grad: npt.NDArray[np.float64],
    template: npt.NDArray[np.float32],
    template_grad: npt.NDArray[np.float64],
    mu: float,
    eps: float,
    threads: int | None = None,
) -> npt.NDArray[np.float64]: ...

@final
class WangEvaluator:
    def __new__(
        cls,
        exemplar: npt.NDArray[np.float32],
        tile_samples: npt.NDArray[np.int64],
        n_samples: int,
        tile_size: int,
        overlap: int,
        corners: str = "free",
        samples: str = "diamond",
        cut: str = "dp",
        omega: float = ...,
        eps: float = ...,
    ) -> Self: ...
    @property
    def dims(self) -> tuple[int, int, int]: ...
    def evaluate(
        self, genes: npt.NDArray[np.int64], threads: int | None = None
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...

def wang_tiles(
    exemplar: npt.NDArray[np.float32],
    genes: npt.NDArray[np.int64],
    tile_samples: npt.NDArray[np.int64],
    tile_size: int,
    overlap: int,
    corners: str = "free",
    samples: str = "diamond",
    cut: str = "dp",
    omega: float = ...,
    eps: float = ...,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float64]]: ...
def swang_cuts(
    initial: npt.NDArray[np.float32],
    supplementary: npt.NDArray[np.float32],
    eps: float = ...,
    threads: int | None = None,
    initial_grad: npt.NDArray[np.float64] | None = None,
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.float64]]: ...

# The hashed lookup (rust/hash.rs, HASH-SPEC.md).
HASH_NAME: str
HASH_PCG_MUL: int
HASH_PCG_INC: int
HASH_ROLE_MUL: int
HASH_ROLES: tuple[int, int, int, int]

def ts_hash(
    x: npt.NDArray[np.int32], y: npt.NDArray[np.int32], seed: int, role: int
) -> npt.NDArray[np.uint32]: ...
def hashed_index_map(
    kind: str,
    colours: list[int],
    variants: int,
    seed: int,
    origin: tuple[int, int],
    size: tuple[int, int],
    wrap: tuple[int, int] | None = None,
    threads: int | None = None,
) -> npt.NDArray[np.int32]: ...
def tile_copy_window(
    atlas: npt.NDArray[np.generic],
    index_map: npt.NDArray[np.int32],
    offset: tuple[int, int],
    out: npt.NDArray[np.generic],
    threads: int | None = None,
) -> None: ...

# image files (rust/py/io.rs)
def png_decode(data: bytes, max_pixels: int) -> tuple[np.ndarray, bytes | None]: ...
def png_encode(image: np.ndarray, compression: str = "default", threads: int | None = None) -> bytes: ...
def exr_decode(data: bytes, max_pixels: int) -> tuple[np.ndarray, list[str], bool]: ...
def exr_encode(image: np.ndarray, half: bool = False) -> bytes: ...
def patch_gradients(exemplar: np.ndarray, source: np.ndarray) -> np.ndarray: ...
def _best_matches_sorting(
    index: SsdIndex,
    templates: np.ndarray,
    k: int = 1,
    exclude_radius: int = 0,
    mask: np.ndarray | None = None,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]: ...

# tile sets as provenance (rust/py/provenance.rs)
def provenance_factorise(
    source: npt.NDArray[np.int32], threads: int | None = None, orient: npt.NDArray[np.uint8] | None = None
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.int32]] | None: ...
def provenance_gather(
    exemplar: np.ndarray,
    labels: npt.NDArray[np.uint8],
    table: npt.NDArray[np.int32],
    index_map: npt.NDArray[np.int32],
    offset: tuple[int, int],
    out: np.ndarray,
    threads: int | None = None,
    turns: npt.NDArray[np.int8] | None = None,
    snorm: bool = False,
) -> None: ...

# the seam blend of smooth material maps (rust/py/blend.rs)
def seam_blend(
    maps: list[
        tuple[
            str,
            npt.NDArray[np.float64] | None,
            npt.NDArray[np.float64] | None,
            list[float],
            np.ndarray,
            np.ndarray,
        ]
    ],
    labels: npt.NDArray[np.uint8],
    table: npt.NDArray[np.int32],
    index_map: npt.NDArray[np.int32],
    offset: tuple[int, int],
    high: float,
    low_level: float | None,
    reach: int,
    threads: int | None = None,
    turns: list[npt.NDArray[np.int8] | None] | None = None,
) -> None: ...

# matching from shared quadrants (rust/py/ssd.rs)
def quadrant_map(
    index: SsdIndex, quad: npt.NDArray[np.float32], threads: int | None = None
) -> tuple[npt.NDArray[np.float32], float, float]: ...
def best_matches_quadrants(
    index: SsdIndex,
    quads: npt.NDArray[np.float32],
    maps: npt.NDArray[np.float32],
    bounds: list[float],
    maxes: list[float],
    templates: npt.NDArray[np.float32],
    assign: npt.NDArray[np.int64],
    k: int = 1,
    exclude_radius: int = 0,
    threads: int | None = None,
) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]: ...
