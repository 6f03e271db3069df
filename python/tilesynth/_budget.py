"""The memory a build needs, estimated and refused up front (issue 16), like synthesis's
:func:`tilesynth.synthesis.check_size`.

The estimate is linear in the exemplar's pixels (its float32 copy, the FFT spectra of the SSD index in both
precisions, the integral images, one SSD map per template batch) plus the tile arrays (tiles, provenance, cut
masks, labels and their intermediate copies). The constants are measured peaks (``ru_maxrss`` above the
interpreter's, default options, 2 threads, lettuce exemplar tiled to size): 28 MiB at 256², 131 MiB at 512²,
199 MiB at 1024² and 428 MiB at 2048² (256-pixel tiles); :data:`BYTES_PER_PIXEL` and
:data:`BYTES_PER_TILE_PIXEL` are rounded up from them so the estimate is above every measured peak (752 MiB
estimated for the 428 MiB at 2048²). Refusing before the build beats an abort or the OOM killer an hour in; the
limit is :func:`tilesynth._validate.memory_limit` (``TILESYNTH_MAX_BYTES``, default half the physical memory).
"""

from __future__ import annotations

from typing import Any

from ._validate import MAX_BYTES_ENV, fmt_bytes, memory_limit
from .errors import ParameterError

#: Peak bytes per exemplar pixel (see the module docstring).
BYTES_PER_PIXEL = 160
#: Peak bytes per tile pixel, per channel and fixed (tiles float32 per channel; provenance, masks, labels and
#: the intermediate copies).
BYTES_PER_TILE_PIXEL = (24, 40)


def build_bytes(h: int, w: int, c: int, tile_size: int, n_tiles: int) -> int:
    """Estimated peak memory of building ``n_tiles`` tiles of ``tile_size`` from an ``h x w x c`` exemplar."""
    per_ch, fixed = BYTES_PER_TILE_PIXEL
    return BYTES_PER_PIXEL * h * w + n_tiles * tile_size * tile_size * (per_ch * c + fixed)


def check_build_memory(exemplar: Any, default_set: str, layout: str, kwargs: dict[str, Any]) -> None:
    """Raise :class:`ParameterError` with the figures if the build of ``exemplar`` would exceed the memory
    limit. ``default_set`` is the set the builder takes when ``kwargs`` name none, ``layout`` "corner" or
    "edge" (:class:`tilesynth.schemes.Scheme`). Arguments it cannot interpret are left to the builder's own
    checks."""
    shape = getattr(exemplar, "shape", None)
    if shape is None or len(shape) not in (2, 3) or not all(isinstance(v, int) and v > 0 for v in shape):
        return
    h, w = int(shape[0]), int(shape[1])
    c = int(shape[2]) if len(shape) == 3 else 1
    n = kwargs.get("tile_size")
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        n = None
    try:
        name = kwargs.get("tileset") or default_set
        if layout == "corner":
            from .lookup import lookup_scheme
            from .tilesets import get_tileset

            defn = get_tileset(name)
            k = len(defn.tiles)
            if n is None and lookup_scheme(defn) is not None:  # complete sets default to quarter-side tiles
                from .complete import default_complete_tile_size

                n = default_complete_tile_size((h, w))
        else:
            from .wangsets import get_wang_tileset

            k = len(get_wang_tileset(name).tiles)
    except Exception:  # noqa: BLE001 - a bad name is the builder's to report, with its own message
        return
    n = min(256, min(h, w) // 2) if n is None else n
    if n > min(h, w):  # a tile larger than the exemplar is the builder's error to report (it names the size)
        return
    need, limit = build_bytes(h, w, c, n, k), memory_limit(kwargs.get("max_bytes"))
    if need > limit:
        raise ParameterError(
            f"exemplar = {w}x{h}x{c}: building {k} tiles of {n}x{n} needs about {fmt_bytes(need)}, more than the "
            f"limit of {fmt_bytes(limit)} ({MAX_BYTES_ENV}; default half the physical memory); use a smaller "
            "exemplar (crop or downscale it) or raise the limit"
        )
