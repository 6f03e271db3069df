"""The memory a build needs, estimated and refused up front, like synthesis's
:func:`tilesynth.synth.synthesis.check_size`.

The estimate is a fixed interpreter/library share, a term linear in the exemplar's pixels (its float32 copy, the
FFT spectra of the SSD index, the integral images, one SSD map per template batch), one linear in the tile pixels
(tiles float32, provenance int32, masks, the cut stage's chunk; more with Poisson smoothing, whose path holds
the whole set's intermediate and matching patches) and, when the genes are selected by evaluating populations
(best-of, GA, AIS, the papers' sets' default), the population evaluator: its partial-map cache
(``_core.DEFAULT_CACHE_BYTES``) plus a working set linear in the exemplar's pixels, and a second set of tiles
(the cut re-ranking keeps the best build while the next is made).

The constants are measured peaks (VmHWM above the interpreter's, 2 threads, lettuce exemplar tiled to
size, this tree with the chunked cut stage), rounded up so the estimate stays above every one and
within about 1.5-2x of it (estimate / peak): c5 default 125 MB at 256² (1.5x), 359 MB at 512² (1.4x),
1371 MB at 1024² (1.5x), c5 smoothed 725 MB at 512² (1.3x); 16a at 128 px by the default selection 395 MB at
512², 582 MB at 1024², 1438 MB at 2048² (1.3-1.4x); 16a random 364 MB at 2048² (2.1x); n2 GA 378 MB at 512²,
AIS 608 MB at 1024² (1.4x). Refusing before the build beats an abort or the OOM killer an hour in; the limit is
:func:`tilesynth.base.validate.memory_limit` (``TILESYNTH_MAX_BYTES``, default half the physical memory). Extra
material maps are not counted (they add their channels to the tile term).
"""

from __future__ import annotations

from typing import Any

from ..errors import ParameterError
from .validate import MAX_BYTES_ENV, fmt_bytes, memory_limit

#: Fixed share of a build's peak (imports, thread pools, small arrays).
FIXED_BYTES = 64 << 20
#: Peak bytes per exemplar pixel (see the module docstring).
BYTES_PER_PIXEL = 160
#: Peak bytes per tile pixel, per channel and fixed: unsmoothed (the chunked cut stage) and Poisson-smoothed.
BYTES_PER_TILE_PIXEL = (10, 16)
BYTES_PER_TILE_PIXEL_SMOOTH = (18, 26)
#: The population evaluator of a selection: its working set per exemplar pixel and its fixed share beyond
#: the partial-map cache (:data:`tilesynth._core.DEFAULT_CACHE_BYTES`).
SELECT_BYTES_PER_PIXEL = 240
SELECT_FIXED_BYTES = 96 << 20


def build_bytes(
    h: int, w: int, c: int, tile_size: int, n_tiles: int, *, selection: bool = False, smooth: bool = False
) -> int:
    """Estimated peak memory of building ``n_tiles`` tiles of ``tile_size`` from an ``h x w x c`` exemplar;
    ``selection``: the genes are chosen by evaluating populations (best-of, GA, AIS, the papers' sets'
    default), ``smooth``: Poisson smoothing."""
    per_ch, fixed = BYTES_PER_TILE_PIXEL_SMOOTH if smooth else BYTES_PER_TILE_PIXEL
    tiles = n_tiles * tile_size * tile_size * (per_ch * c + fixed)
    need = FIXED_BYTES + BYTES_PER_PIXEL * h * w + tiles
    if selection:
        from .. import _core

        need += _core.DEFAULT_CACHE_BYTES + SELECT_FIXED_BYTES + SELECT_BYTES_PER_PIXEL * h * w + tiles
    return need


def _selects(kwargs: dict[str, Any], complete: bool) -> bool:
    """Whether the build evaluates populations to choose its genes (see :func:`build_bytes`): a named method
    other than "random", or the default (``select=None``, no ``genes``) of a set that is not complete."""
    if kwargs.get("genes") is not None:
        return False
    select = kwargs.get("select")
    if select is None:
        return not complete
    return select != "random"


def check_build_memory(
    shape: tuple[int, int, int], tile_size: int, n_tiles: int, complete: bool, kwargs: dict[str, Any]
) -> None:
    """Raise :class:`ParameterError` with the figures if building ``n_tiles`` tiles of ``tile_size`` from an
    exemplar of ``shape`` (h, w, c) would exceed the memory limit. ``complete``: the set is a complete one
    (its default is random genes, see :func:`_selects`); ``kwargs`` are the builder's (selection, smoothing,
    ``max_bytes``). The caller resolves the set and the tile size (:meth:`tilesynth.schemes.base.Scheme.build`):
    the budget knows figures, not tile sets."""
    h, w, c = shape
    selection, smooth = _selects(kwargs, complete), bool(kwargs.get("smooth"))
    need, limit = (
        build_bytes(h, w, c, tile_size, n_tiles, selection=selection, smooth=smooth),
        memory_limit(kwargs.get("max_bytes")),
    )
    if need > limit:
        raise ParameterError(
            f"exemplar = {w}x{h}x{c}: building {n_tiles} tiles of {tile_size}x{tile_size} needs about "
            f"{fmt_bytes(need)}, more than the limit of {fmt_bytes(limit)} ({MAX_BYTES_ENV}; default half the "
            "physical memory); use a smaller exemplar (crop or downscale it) or raise the limit"
        )
