"""The genes stage: sample-patch positions in the exemplar, shared by every scheme.

A *gene vector* is an int64 ``(n, 2)`` array of distinct top-left (row, col) positions of ``size x size``
patches inside an H x W exemplar. This module holds what every scheme needs about them:

* the tile-size rules (:func:`default_tile_size`, :func:`check_tile_size`, :func:`check_exemplar_size`, defined
  in :mod:`tilesynth.layouts.tile_size`, which the complete sets' default builds on);
* :func:`random_genes` and :func:`check_genes`;
* the objective of the selection papers, :func:`energy` (E = λ·ΣD_j + (1−λ)·Var(D_j), λ = :data:`LAMBDA`,
  defined in :mod:`tilesynth.measure.energy`, which the measures report);
* :class:`Region`, the valid top-left positions of the patches.

Nothing here knows a scheme or a selection method: the one path every builder takes from its options to a
gene vector (given, random or selected) is :func:`tilesynth.builder.genes.select.choose_genes`, next to the methods it runs
(it lives there and not here so that the selection methods can use this module without an import cycle).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ParameterError
from ...layouts.tile_size import MIN_TILE_SIZE, check_exemplar_size, check_tile_size, default_tile_size
from ...measure.energy import LAMBDA, energy

__all__ = [
    "LAMBDA",
    "MIN_TILE_SIZE",
    "Region",
    "check_exemplar_size",
    "check_genes",
    "check_tile_size",
    "default_tile_size",
    "energy",
    "random_genes",
]


def int_param(name: str, value: Any, minimum: int, maximum: int | None = None) -> int:
    """``value`` as an int in [minimum, maximum] (bools refused), or a ParameterError naming ``name``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} = {value!r}: must be an integer")
    v = int(value)
    if v < minimum or (maximum is not None and v > maximum):
        rng = f">= {minimum}" if maximum is None else f"in [{minimum}, {maximum}]"
        raise ParameterError(f"{name} = {v}: must be {rng}")
    return v


@dataclass(frozen=True)
class Region:
    """The valid top-left positions of N x N patches: rows ``0 .. rows−1``, cols ``0 .. cols−1``.

    ``rows = H − N + 1``, ``cols = W − N + 1``; the flat index of (r, c) is ``r·cols + c``.
    """

    rows: int
    cols: int

    @classmethod
    def of(cls, shape: tuple[int, ...], tile_size: int) -> Region:
        """The region of an exemplar of ``shape`` (H, W[, C]) for tile size N (validated)."""
        return _region(shape, 1, tile_size)[3]

    @property
    def size(self) -> int:
        return self.rows * self.cols

    @property
    def hi(self) -> np.ndarray:
        """Upper limit u of a gene (the lower limit l is (0, 0))."""
        return np.array([self.rows - 1, self.cols - 1], dtype=np.int64)

    def flat(self, genes: np.ndarray) -> np.ndarray:
        return genes[..., 0] * self.cols + genes[..., 1]

    def unflat(self, idx: np.ndarray | Iterable[int]) -> np.ndarray:
        i = np.asarray(idx, dtype=np.int64)
        return np.stack([i // self.cols, i % self.cols], axis=-1)


def _region(shape: Any, n: Any, tile_size: Any) -> tuple[tuple[int, int], int, int, Region]:
    """Validate (shape, n, tile_size) and return them with the region of valid positions."""
    try:
        dims = tuple(int(s) for s in shape)
    except TypeError as exc:
        raise ParameterError(f"shape = {shape!r}: expected the exemplar shape (H, W[, C])") from exc
    if len(dims) < 2 or dims[0] < 1 or dims[1] < 1:
        raise ParameterError(f"shape = {shape!r}: expected the exemplar shape (H, W[, C]) with H, W >= 1")
    n_ = int_param("n", n, 1)
    t = int_param("tile_size", tile_size, 1)
    if t > dims[0] or t > dims[1]:
        raise ParameterError(f"tile_size = {t}: larger than the exemplar ({dims[1]}x{dims[0]} pixels)")
    reg = Region(dims[0] - t + 1, dims[1] - t + 1)
    if reg.size < n_:
        raise ParameterError(
            f"tile_size = {t}: the exemplar has only {reg.size} patch positions, {n_} needed"
        )
    return (dims[0], dims[1]), n_, t, reg


def random_genes(shape: tuple[int, ...], n: int, tile_size: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` distinct random top-left positions of ``tile_size`` patches inside an exemplar of ``shape``.

    Returns int64 ``(n, 2)`` (row, col). Positions are uniform over all valid translations.
    """
    rows, cols = max(shape[0] - tile_size + 1, 0), max(shape[1] - tile_size + 1, 0)  # (-2) x (-2) is not 4
    if rows * cols < n:
        raise ParameterError(
            f"tile_size = {tile_size}: the exemplar has only {rows * cols} patch positions, {n} needed"
        )
    flat = rng.choice(rows * cols, size=n, replace=False)
    return np.stack([flat // cols, flat % cols], axis=1).astype(np.int64)


def check_genes(genes: Any, n: int, shape: tuple[int, ...], tile_size: int) -> np.ndarray:
    """Validate a gene vector: ``n`` distinct (row, col) positions with the patch inside the exemplar."""
    g = np.asarray(genes)
    if g.shape != (n, 2) or not np.issubdtype(g.dtype, np.integer):
        raise ParameterError(f"genes has shape {g.shape} and dtype {g.dtype}, expected integer ({n}, 2)")
    g = g.astype(np.int64)
    hi = np.array([shape[0] - tile_size, shape[1] - tile_size])
    bad = np.nonzero((g < 0).any(axis=1) | (g > hi).any(axis=1))[0]
    if bad.size:
        i = int(bad[0])
        raise ParameterError(
            f"genes[{i}] = {tuple(int(v) for v in g[i])}: patch must lie inside the exemplar "
            f"(row in [0, {hi[0]}], col in [0, {hi[1]}])"
        )
    if len({tuple(r) for r in g.tolist()}) != n:
        raise ParameterError("genes: positions must be distinct")
    return g
