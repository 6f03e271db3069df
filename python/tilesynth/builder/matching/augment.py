"""Flip / rotate augmentation of the matching candidates of ω-tiles (``--augment``).

For an isotropic texture a mirrored or rotated exemplar window is as good a piece of texture as the window
itself. ``augment`` lets the matching patch O of every intermediate tile be a *transformed* exemplar window:

``"none"`` (default)
    the plain translations (byte-identical to a build without the option);
``"flip"``
    also the window mirrored left-right, up-down and both (= rotated by 180°): 4 orientations;
``"rotate"``
    also the window rotated by 90°, 180° and 270°: 4 orientations;
``"all"``
    the 8 symmetries of the square (rotations, and rotations followed by a left-right mirror).

**Transform numbers** (stored per tile in ``params["match_transforms"]``): t in 0..7, k = t mod 4, f = t ≥ 4;
``T_t(P) = F^f(R^k(P))`` with R = :func:`numpy.rot90` (anticlockwise by 90° in the (row, col) plane) and F the
left-right mirror (``P[:, ::-1]``). t = 0 is the identity; "flip" is {0, 2, 4, 6} (6 = up-down mirror).

**Search.** The SSD of the intermediate tile I against T(W) equals the SSD of T⁻¹(I) against the window W, so
each orientation is one more exact exhaustive search of the *original* exemplar (:class:`tilesynth.base.kernels.SsdIndex`,
one index for all), with T⁻¹(I) as the template: no enlarged exemplar, the offsets stay exemplar top-left
corners, and the provenance of a transformed patch is the transformed grid of its window
(:func:`transformed_source`), so coverage, map synthesis and materials follow the real exemplar pixels. The cost is
one search per orientation (4x or 8x the matching time).

**Diversity.** Under the diversity lever (:func:`tilesynth.builder.matching.levers.diverse_matches`) a region counts as used
*per orientation*: a window mirrored is different content for the measures of repetition (no translation maps
it onto the original: the periodic-copy fraction and the autocorrelation peak do not see it), and that is the
point of the option; self-matches are excluded only unrotated (a rotated quadrant of the tile's own sample
patch does not copy it back in place). The papers' E keeps the best *untransformed* distance (comparable with
builds without augmentation, and the selection evaluators do not augment).

**Not augmented: the sample patches.** Every vertex of colour c shows c's sample patch in all four tiles that
meet there; rotating it would change the content at every such vertex the same way, not add variety (K
patches still sit on the lattice), and the border-aware draw (:mod:`tilesynth.builder.genes.omega_borders`) ranks windows, not
orientations. The lever against the lattice content is the share of the tile given to O (the free cut region).

Only with the plain match (``match="ssd"``, ``metric="color"``) and without a mask (the masked search and the
other match strategies take untransformed windows): other combinations are a :class:`ParameterError`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...base import kernels
from ...errors import ParameterError
from ...io.normal_codes import (  # the vector turns are normal-code semantics (io); importable from here too
    transform_normal_codes,
    transform_vectors,
    vector_turns,
)
from ...tileset.provenance import turned_pixels

__all__ = [
    "AUGMENT_MODES",
    "check_augment",
    "inverse_transform",
    "matching_patches",
    "mode_transforms",
    "pixel_transforms",
    "transform",
    "transform_tiles",
    "transform_normal_codes",
    "transform_vectors",
    "vector_turns",
    "transformed_source",
]

AUGMENT_MODES: dict[str, tuple[int, ...]] = {
    "none": (0,),
    "flip": (0, 2, 4, 6),
    "rotate": (0, 1, 2, 3),
    "all": (0, 1, 2, 3, 4, 5, 6, 7),
}
"""The transforms of each ``augment`` mode (see the module docstring)."""


def check_augment(value: Any) -> str:
    """``value`` as one of :data:`AUGMENT_MODES`, else ParameterError naming ``augment``."""
    if not isinstance(value, str) or value not in AUGMENT_MODES:
        raise ParameterError(f"augment = {value!r}: must be one of {', '.join(AUGMENT_MODES)}")
    return value


def mode_transforms(mode: str) -> tuple[int, ...]:
    """The transform numbers of ``mode``."""
    return AUGMENT_MODES[check_augment(mode)]


def _check_t(t: Any) -> tuple[int, bool]:
    if isinstance(t, (bool, np.bool_)) or not isinstance(t, (int, np.integer)) or not 0 <= int(t) <= 7:
        raise ParameterError(f"transform = {t!r}: must be an int in 0..7")
    return int(t) % 4, int(t) >= 4


def transform(a: np.ndarray, t: int) -> np.ndarray:
    """``T_t`` of a square array ``(N, N, ...)`` (rows, columns first): ``F^f(R^k(a))``."""
    k, f = _check_t(t)
    a = np.asarray(a)
    if a.ndim < 2 or a.shape[0] != a.shape[1]:
        raise ParameterError(f"transform of shape {a.shape}: needs a square (N, N, ...) array")
    out = np.rot90(a, k, axes=(0, 1))
    return out[:, ::-1] if f else out


def inverse_transform(t: int) -> int:
    """The number of ``T_t⁻¹``: rotations invert to the opposite rotation, reflections are their own inverse."""
    k, f = _check_t(t)
    return int(t) if f else (4 - k) % 4


def transform_tiles(tiles: np.ndarray, transforms: np.ndarray) -> np.ndarray:
    """Every ``tiles[j]`` ``(K, N, N, ...)`` transformed by ``transforms[j]`` (a contiguous copy)."""
    tiles = np.asarray(tiles)
    ts = np.asarray(transforms).reshape(-1)
    if ts.shape[0] != tiles.shape[0]:
        raise ParameterError(f"transforms has {ts.shape[0]} entries for {tiles.shape[0]} tiles")
    if (ts == 0).all():
        return np.ascontiguousarray(tiles)
    out = np.empty_like(tiles)
    for j, t in enumerate(ts):
        out[j] = transform(tiles[j], int(t))
    return out


def transformed_source(offsets: np.ndarray, transforms: np.ndarray, n: int) -> np.ndarray:
    """Provenance ``(K, n, n, 2)`` int32 of the transformed windows at ``offsets`` ``(K, 2)``."""
    yy, xx = np.mgrid[0:n, 0:n]
    grid = (np.stack([yy, xx], axis=-1)[None] + np.asarray(offsets)[:, None, None, :]).astype(np.int32)
    return transform_tiles(grid, transforms)


def matching_patches(image: np.ndarray, tileset: Any) -> np.ndarray:
    """The matching patches ``(K, N, N, C)`` of ``tileset`` read from ``image`` (the exemplar or a map of the
    same size), each transformed as ``params["match_transforms"]`` records (identity when absent)."""
    n = tileset.tile_size
    o = np.stack([image[r : r + n, c : c + n] for r, c in np.asarray(tileset.match_offsets)])
    t = tileset.params.get("match_transforms")
    return o if t is None else transform_tiles(o, np.asarray(t, dtype=np.int64))


def candidates(
    ex: np.ndarray,
    inter: np.ndarray,
    k: int,
    exclude_radius: int,
    transforms: tuple[int, ...],
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ``k`` best translations of every intermediate tile in every orientation, merged per tile by SSD
    (stable: ties keep the orientation order): offsets ``(U, T·J, 2)``, SSD ``(U, T·J)``, transform ``(U, T·J)``.

    Within one orientation the candidates are ``exclude_radius`` apart (as :meth:`SsdIndex.best_matches`);
    with ``transforms == (0,)`` this is exactly ``best_matches(ex, inter, k, exclude_radius)``."""
    if tuple(transforms) == (0,):
        off, ssd = kernels.best_matches(ex, inter, k=k, exclude_radius=exclude_radius, threads=threads)
        return off, ssd, np.zeros(ssd.shape, np.int64)
    u = inter.shape[0]
    tpl = np.concatenate([transform_tiles(inter, np.full(u, inverse_transform(t))) for t in transforms])
    off, ssd = kernels.SsdIndex(ex, threads).best_matches(
        np.ascontiguousarray(tpl), k=k, exclude_radius=exclude_radius, threads=threads
    )
    nt, j = len(transforms), off.shape[1]
    off = off.reshape(nt, u, j, 2).transpose(1, 0, 2, 3).reshape(u, nt * j, 2)
    ssd = ssd.reshape(nt, u, j).transpose(1, 0, 2).reshape(u, nt * j)
    tid = np.broadcast_to(np.asarray(transforms, np.int64)[None, :, None], (u, nt, j)).reshape(u, nt * j)
    order = np.argsort(ssd, axis=1, kind="stable")
    rows = np.arange(u)[:, None]
    return off[rows, order], ssd[rows, order], np.ascontiguousarray(tid[rows, order])


def best_augmented(
    ex: np.ndarray,
    inter: np.ndarray,
    n_variants: int,
    transforms: tuple[int, ...],
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The plain match with augmentation (no diversity): each tile's ``n_variants`` best (offset, orientation)
    candidates (variants in one orientation more than N/4 apart). Returns offsets ``(U, V, 2)``, SSD ``(U, V)``,
    transforms ``(U, V)`` and the best untransformed SSD ``(U,)`` (for E)."""
    n = inter.shape[1]
    off, ssd, tid = candidates(ex, inter, n_variants, n // 4 if n_variants > 1 else 0, transforms, threads)
    if off.shape[1] < n_variants:
        raise ParameterError(
            f"tile_size = {n}: the exemplar has too few distinct translations for {n_variants} matching patches"
        )
    best0 = np.where(tid == 0, ssd, np.inf).min(axis=1)
    return off[:, :n_variants], ssd[:, :n_variants], tid[:, :n_variants], best0


def pixel_transforms(tileset: Any) -> np.ndarray | None:
    """The transform of every tile pixel ``(K, N, N)`` uint8: ``params["match_transforms"][j]`` where tile j shows
    its (transformed) matching patch, 0 where it shows an untransformed sample patch; None when no matching patch
    is transformed. A pixel shows the matching patch when its provenance is the transformed window's
    (:func:`~tilesynth.tileset.provenance.turned_pixels`)."""
    t = tileset.params.get("match_transforms")
    return turned_pixels(tileset.source, tileset.match_offsets, t)
