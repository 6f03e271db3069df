"""Composing tiles with their provenance, and the one :class:`~tilesynth.tileset.tilefile.TileSet` ending of every builder.

Every scheme ends the same way: the composed tiles, the exemplar (row, col) of every tile pixel, the cut masks
and costs, the genes and the objective go into a :class:`~tilesynth.tileset.tilefile.TileSet` with the exemplar's
digest and the build's timing. :func:`finish_tileset` is that ending, written once.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np

from ..base import kernels
from ..base.gradients import patch_gradients as _rust_patch_gradients  # the numpy formula, in Rust
from ..tileset.tilefile import TileSet, exemplar_digest
from .smoothing import smooth_tiles

if TYPE_CHECKING:
    from .options import BuildOptions

__all__ = [
    "cut_and_compose",
    "exemplar_record",
    "finish_tileset",
    "offset_source",
    "patch_gradients",
    "patches_at",
]


def patch_gradients(exemplar: np.ndarray, source: np.ndarray) -> np.ndarray:
    """Gradient norms of the exemplar at the positions ``source`` (``(..., 2)`` row, col): ``(..., 2)`` float64.

    Index 0 is ‖E(r, c+1) − E(r, c)‖, index 1 is ‖E(r+1, c) − E(r, c)‖ (L2 over channels, 0 past the exemplar edge).
    These are the gradients "of the patch a pixel came from" that the Kwatra seam weights of the ω and s-Wang
    cuts use (``gradients="patch"``).
    """
    return _rust_patch_gradients(exemplar, source)


def patches_at(exemplar: np.ndarray, offsets: np.ndarray, n: int) -> np.ndarray:
    """The ``n x n`` exemplar patches at the top-left ``offsets`` ``(K, 2)``: ``(K, n, n, C)``."""
    return np.stack([exemplar[r : r + n, c : c + n] for r, c in offsets])


def offset_source(offsets: np.ndarray, n: int) -> np.ndarray:
    """Provenance ``(K, n, n, 2)`` int32 of the ``n x n`` patches at the top-left ``offsets`` ``(K, 2)``."""
    yy, xx = np.mgrid[0:n, 0:n]
    return (np.stack([yy, xx], axis=-1)[None] + np.asarray(offsets)[:, None, None, :]).astype(np.int32)


def exemplar_record(ex: np.ndarray, extra: dict[str, Any] | None) -> dict[str, Any]:
    """What the tile set records about its exemplar: shape, content digest, and the caller's facts (file, bits)."""
    info: dict[str, Any] = {"shape": list(ex.shape), "sha256": exemplar_digest(ex)}
    info.update(extra or {})
    return info


def finish_tileset(
    *,
    scheme: str,
    definition: Any,
    exemplar: np.ndarray,
    tiles: np.ndarray,
    source: np.ndarray,
    cut_masks: np.ndarray,
    genes: np.ndarray,
    tile_patches: np.ndarray,
    match_offsets: np.ndarray,
    D: np.ndarray,
    cut_costs: np.ndarray,
    E: float,
    params: dict[str, Any],
    exemplar_info: dict[str, Any] | None,
    timing: dict[str, float],
    started: float,
    labels: np.ndarray | None = None,
    cut_stats: np.ndarray | None = None,
) -> TileSet:
    """The :class:`TileSet` of a finished build: every array contiguous in its file dtype, the exemplar record,
    and ``timing`` completed with ``total_s`` (seconds since ``started``, a :func:`time.perf_counter` value)."""
    from .._version import __version__
    from ..measure.build_measures import (
        build_measures,  # the cheap visible measures, stored in the manifest
    )

    ts = TileSet(
        scheme=scheme,
        layout=definition.to_dict(),
        tiles=np.ascontiguousarray(tiles, dtype=np.float32),
        source=np.ascontiguousarray(source, dtype=np.int32),
        cut_masks=np.ascontiguousarray(cut_masks, dtype=bool),
        genes=np.ascontiguousarray(genes, dtype=np.int64),
        tile_patches=np.ascontiguousarray(tile_patches, dtype=np.int64),
        match_offsets=np.ascontiguousarray(match_offsets, dtype=np.int64),
        D=np.ascontiguousarray(D, dtype=np.float64),
        cut_costs=np.ascontiguousarray(cut_costs, dtype=np.float64),
        exemplar=exemplar,
        E=float(E),
        params=params,
        exemplar_info=exemplar_record(exemplar, exemplar_info),
        timing={**timing, "total_s": time.perf_counter() - started},
        version=__version__,
        labels=None if labels is None else np.ascontiguousarray(labels, dtype=np.uint8),
        cut_stats=None if cut_stats is None else np.ascontiguousarray(cut_stats, dtype=np.float64),
    )
    ts.params["quality"] = build_measures(ts)
    return ts


def _cut(
    b: BuildOptions,
    I_tiles: np.ndarray,
    I_src: np.ndarray,
    offsets: np.ndarray,
    transforms: np.ndarray | None,
    *,
    eps: float,
    grad_from_patches: bool,
    keep_border: bool,
    cut_region: str,
    cut_bias: float | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cut of intermediate tiles ``I_tiles`` (provenance ``I_src``) against their matching patches at
    ``offsets``: ``(patches, their provenance, masks, costs)``, for the whole set or one chunk of it. The seam
    gradients live only inside this call (they would dominate the peak RSS: ``K x n x n x 2`` float64)."""
    ex, n = b.exemplar, b.tile_size
    O_tiles = patches_at(ex, offsets, n)
    o_src = offset_source(offsets, n)
    if transforms is not None:  # mirrored / rotated matching patches
        from .matching.augment import transform_tiles

        O_tiles, o_src = transform_tiles(O_tiles, transforms), transform_tiles(o_src, transforms)
    grad = patch_gradients(ex, I_src) if grad_from_patches else None
    from .matching.levers import FREE_REGIONS, free_cuts  # the free cut regions

    if cut_region in FREE_REGIONS:
        masks, costs = free_cuts(
            I_tiles, O_tiles, eps, grad, bias=cut_bias, cut_region=cut_region, threads=b.threads
        )
    else:
        masks, costs = kernels.omega_cuts(
            I_tiles, O_tiles, eps=eps, threads=b.threads, intermediate_grad=grad, keep_border=keep_border
        )
    return O_tiles, o_src, masks, costs


def cut_and_compose(
    b: BuildOptions,
    I_tiles: Any,
    I_src: np.ndarray | None,
    offsets: np.ndarray,
    *,
    eps: float,
    grad_from_patches: bool,
    keep_border: bool,
    smooth: bool,
    cut_region: str = "circle",
    cut_bias: float | None = None,
    transforms: np.ndarray | None = None,
    index: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any] | None, dict[str, float]]:
    """The ω cut of each intermediate tile against the patch at ``offsets`` (``(K, 2)``), then the composed (or
    Poisson-smoothed) tiles and their provenance; the corner schemes' shared cut stage (ω, patch).

    ``cut_region="free"`` (or ``"ring"``) cuts in the free region of :func:`tilesynth.builder.matching.levers.free_cuts` (area
    reward ``cut_bias``, None: its default) instead of the inscribed circle. ``transforms`` ``(K,)``: the
    matching patch of tile j is its window transformed by ``transforms[j]`` (:mod:`tilesynth.builder.matching.augment`).

    ``index`` ``(K,)``: tile j cuts the intermediate tile ``I_tiles[index[j]]`` (so sets whose tiles share
    intermediate tiles need not copy them; None: tile j is ``I_tiles[j]``). Without smoothing, ``I_tiles`` may
    also be a :class:`tilesynth.layouts.corners.IntermediateTiles` (with ``I_src=None``), assembled a chunk at a time.

    Returns ``(tiles, source, masks, costs, smooth_info, timing)``.
    """
    if not smooth:  # tile chunks into preallocated outputs, the same bytes at a fraction of the RSS
        return _cut_and_compose_chunked(
            b, I_tiles, I_src, offsets, eps=eps, grad_from_patches=grad_from_patches, keep_border=keep_border,
            cut_region=cut_region, cut_bias=cut_bias, transforms=transforms, index=index,
        )  # fmt: skip
    if I_src is None:  # an IntermediateTiles
        I_tiles, I_src = I_tiles.take(np.arange(I_tiles.shape[0]) if index is None else index)
    elif index is not None:
        I_tiles, I_src = I_tiles[index], I_src[index]
    k = I_tiles.shape[0]
    t0 = time.perf_counter()
    b.report("cutting curves", 0, k)
    O_tiles, o_src, masks, costs = _cut(
        b, I_tiles, I_src, offsets, transforms, eps=eps, grad_from_patches=grad_from_patches,
        keep_border=keep_border, cut_region=cut_region, cut_bias=cut_bias,
    )  # fmt: skip
    t1 = time.perf_counter()
    b.report("cutting curves", k, k)
    smooth_info = None
    if smooth:
        b.report("poisson smoothing", 0, k)
        tiles, smooth_info = smooth_tiles(I_tiles, O_tiles, masks, threads=b.threads)
        b.report("poisson smoothing", k, k)
    else:
        tiles = np.where(masks[..., None], O_tiles, I_tiles).astype(np.float32, copy=False)
    del O_tiles
    source = np.where(masks[..., None], o_src, I_src).astype(np.int32, copy=False)
    timing = {"cutting_s": t1 - t0, **({"smoothing_s": time.perf_counter() - t1} if smooth else {})}
    return tiles, source, masks, costs, smooth_info, timing


CHUNK_BYTES = 32 << 20
"""Working memory per tile chunk of the unsmoothed cut stage (:func:`_cut_and_compose_chunked`): the chunk's
matching patches, their provenance and the seam-weight gradients."""


def _cut_and_compose_chunked(
    b: BuildOptions,
    I_tiles: Any,
    I_src: np.ndarray | None,
    offsets: np.ndarray,
    *,
    eps: float,
    grad_from_patches: bool,
    keep_border: bool,
    cut_region: str,
    cut_bias: float | None,
    transforms: np.ndarray | None,
    index: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, None, dict[str, float]]:
    """:func:`cut_and_compose` without smoothing, a chunk of tiles at a time (the c5 default's 625
    tiles held the matching patches, their int64 provenance, float64 gradients, a copy of the intermediate tiles
    and two casts of the composed tiles at once, a 1.1 GB peak for a 512² exemplar). Every cut is per tile
    (its own Kwatra weights, mean edge weight and min cut), so the masks, costs, tiles and provenance are the
    bytes of the whole-array version; only the peak memory differs."""
    n = b.tile_size
    index = np.arange(I_tiles.shape[0]) if index is None else np.asarray(index)
    k = index.shape[0]
    c = I_tiles.shape[3]
    per_tile = n * n * (4 * c + 4 * c + 8 + 8 + 16 + 8)  # I, O (float32), two provenances, gradients, weights
    step = max(1, 4 * max(1, b.threads or 1), CHUNK_BYTES // per_tile)
    tiles = np.empty((k, n, n, c), np.float32)
    source = np.empty((k, n, n, 2), np.int32)
    masks = np.empty((k, n, n), bool)
    costs = np.empty(k)
    t0 = time.perf_counter()
    b.report("cutting curves", 0, k)
    for lo in range(0, k, step):
        sl = slice(lo, min(k, lo + step))
        ii = index[sl]
        it, isrc = I_tiles.take(ii) if I_src is None else (I_tiles[ii], I_src[ii])
        O_tiles, o_src, m, cst = _cut(
            b, it, isrc, offsets[sl], None if transforms is None else transforms[sl], eps=eps,
            grad_from_patches=grad_from_patches, keep_border=keep_border, cut_region=cut_region, cut_bias=cut_bias,
        )  # fmt: skip
        masks[sl], costs[sl] = m, cst
        tiles[sl] = np.where(m[..., None], O_tiles, it)  # cast on assignment, as .astype(np.float32) did
        source[sl] = np.where(m[..., None], o_src, isrc)
        del it, isrc, O_tiles, o_src, m
        b.report("cutting curves", sl.stop, k)
    return tiles, source, masks, costs, None, {"cutting_s": time.perf_counter() - t0}
