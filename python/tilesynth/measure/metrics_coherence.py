"""Coherence energy of :mod:`tilesynth.measure.metrics` (see its module docstring): the exact minimum patch
SSD of an output against its exemplar, bit-identical copies found by hashing, the rest searched by FFT."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..base.validate import as_image, positive_int
from ..errors import ParameterError, ShapeError
from .metrics_common import _HASH_SEED, _finite

DEFAULT_PATCH = 8
"""Side p of the coherence patches."""
DEFAULT_STRIDE = 4
"""Stride s between coherence patches."""


COHERENCE_BATCH = 64
"""Templates per :meth:`SsdIndex.best_matches` call (bounds the memory of the SSD maps)."""


# ----------------------------------------------------------------------------------------- coherence energy
@dataclass(frozen=True)
class Coherence:
    """Coherence energy (see the module docstring) with the per-patch minima and where they are.

    ``values`` float64 ``(rows, cols)``: e of the patch at (i·stride, j·stride); ``offsets`` int64
    ``(rows, cols, 2)``: top-left (row, col) of an exemplar patch reaching it (for ties, the smallest (row, col)
    among exact copies, otherwise the one :meth:`SsdIndex.best_matches` ranks first). ``exact_copies`` patches
    were bit-identical copies (e = 0), ``searched`` were matched exhaustively.
    """

    energy: float
    rms: float
    max: float
    patch: int
    stride: int
    n_patches: int
    exact_copies: int
    searched: int
    seconds: float
    values: np.ndarray = field(repr=False)
    offsets: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        d = {
            k: getattr(self, k)
            for k in (
                "energy",
                "rms",
                "max",
                "patch",
                "stride",
                "n_patches",
                "exact_copies",
                "searched",
                "seconds",
            )
        }
        return _finite(d)


def _patch_keys(bits: np.ndarray, p: int, rows: int, cols: int, step: int, weights: np.ndarray) -> np.ndarray:
    """Σ_{i,j,c} w[i,j,c]·bits[y+i, x+j, c] mod 2^64 at y = 0, step, ..., x likewise: uint64 ``(rows, cols)``."""
    key = np.zeros((rows, cols), np.uint64)
    ylen, xlen = step * (rows - 1) + 1, step * (cols - 1) + 1
    for i in range(p):
        for j in range(p):
            for c in range(bits.shape[2]):
                key += bits[i : i + ylen : step, j : j + xlen : step, c] * weights[i, j, c]
    return key


def _float_bits(img: np.ndarray) -> np.ndarray:
    # + 0.0 turns −0.0 into +0.0, so equal values have equal bits (images hold no NaN: as_image refuses them)
    return np.ascontiguousarray(img + np.float32(0.0)).view(np.uint32).astype(np.uint64)


def coherence_energy(
    image: np.ndarray,
    exemplar: np.ndarray,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    index: Any = None,
) -> Coherence:
    """Exact coherence energy of ``image`` against ``exemplar`` (see the module docstring).

    ``index``: optionally a prebuilt :class:`tilesynth.SsdIndex` of ``exemplar`` (reused across calls).
    """
    t0 = time.perf_counter()
    img, ex, p, s = _coherence_args(image, exemplar, patch, stride, index)
    h, w, c = img.shape
    rows, cols = (h - p) // s + 1, (w - p) // s + 1
    rx = ex.shape[1] - p + 1
    m = rows * cols
    values = np.full(m, np.nan)
    offsets = np.zeros((m, 2), np.int64)
    out_patches, ex_patches = _patch_gatherers(img, ex, p, s, m, cols, rx)
    _exact_copies(img, ex, p, s, rows, cols, values, offsets, out_patches, ex_patches)
    todo = _search_the_rest(ex, values, offsets, out_patches, index, threads)
    energy = float(values.mean())
    return Coherence(
        energy=energy,
        rms=math.sqrt(energy / (p * p * c)),
        max=float(values.max()),
        patch=p,
        stride=s,
        n_patches=m,
        exact_copies=int(m - todo.size),
        searched=int(todo.size),
        seconds=time.perf_counter() - t0,
        values=values.reshape(rows, cols),
        offsets=offsets.reshape(rows, cols, 2),
    )


def _coherence_args(
    image: np.ndarray, exemplar: np.ndarray, patch: int, stride: int, index: Any
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The checked arguments of :func:`coherence_energy`: image, exemplar, patch, stride."""
    from ..base.kernels import SsdIndex

    img = as_image(image)
    ex = as_image(exemplar, "exemplar")
    p = positive_int(patch, "patch")
    s = positive_int(stride, "stride")
    if img.shape[2] != ex.shape[2]:
        raise ShapeError(f"exemplar has {ex.shape[2]} channel(s), the image {img.shape[2]}")
    if index is not None and not (isinstance(index, SsdIndex) and np.array_equal(index.image, ex)):
        what = f"an SsdIndex of another {index.shape} image" if isinstance(index, SsdIndex) else repr(index)
        raise ParameterError(f"index is {what}, expected an SsdIndex of the exemplar {ex.shape} (or None)")
    for name, a in (("image", img), ("exemplar", ex)):
        if p > a.shape[0] or p > a.shape[1]:
            raise ParameterError(f"patch = {p}: larger than the {a.shape[1]}x{a.shape[0]} {name}")
    return img, ex, p, s


def _patch_gatherers(
    img: np.ndarray, ex: np.ndarray, p: int, s: int, m: int, cols: int, rx: int
) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray]]:
    """``out_patches(i)``: the p x p output patches of grid indices ``i``; ``ex_patches(k)``: the exemplar
    patches at flat offsets ``k`` (row * rx + col)."""
    py, px = np.divmod(np.arange(m), cols)
    py, px = py * s, px * s
    ii, jj = np.mgrid[0:p, 0:p]

    def out_patches(idx: np.ndarray) -> np.ndarray:
        return img[py[idx, None, None] + ii, px[idx, None, None] + jj]

    def ex_patches(flat: np.ndarray) -> np.ndarray:
        r, q = np.divmod(flat, rx)
        return ex[r[:, None, None] + ii, q[:, None, None] + jj]

    return out_patches, ex_patches


def _exact_copies(
    img: np.ndarray,
    ex: np.ndarray,
    p: int,
    s: int,
    rows: int,
    cols: int,
    values: np.ndarray,
    offsets: np.ndarray,
    out_patches: Callable[[np.ndarray], np.ndarray],
    ex_patches: Callable[[np.ndarray], np.ndarray],
) -> None:
    """Mark every output patch that is a bit-for-bit copy of an exemplar patch (value 0, its offset): a hash of
    the float bits of every patch, confirmed by the pixels."""
    c = img.shape[2]
    ry, rx = ex.shape[0] - p + 1, ex.shape[1] - p + 1
    weights = np.random.default_rng(_HASH_SEED).integers(0, 2**63, size=(p, p, c), dtype=np.uint64) * 2 + 1
    ex_keys = _patch_keys(_float_bits(ex), p, ry, rx, 1, weights).ravel()
    out_keys = _patch_keys(_float_bits(img), p, rows, cols, s, weights).ravel()
    order = np.argsort(ex_keys, kind="stable")  # equal keys stay in increasing (row, col) order
    sorted_keys = ex_keys[order]
    lo = np.searchsorted(sorted_keys, out_keys, side="left")
    hi = np.searchsorted(sorted_keys, out_keys, side="right")

    # exact copies: confirm the first key match by the pixels; on a (never seen) collision try the others
    hits = np.nonzero(hi > lo)[0]
    for b0 in range(0, hits.size, 4096):  # in chunks: bounded memory for large outputs
        hit = hits[b0 : b0 + 4096]
        cand = order[lo[hit]]
        same = (out_patches(hit) == ex_patches(cand)).all(axis=(1, 2, 3))
        values[hit[same]] = 0.0
        offsets[hit[same]] = np.stack(np.divmod(cand[same], rx), axis=1)
        for q in hit[~same]:
            for k in order[lo[q] + 1 : hi[q]]:
                if np.array_equal(out_patches(np.array([q]))[0], ex_patches(np.array([k]))[0]):
                    values[q] = 0.0
                    offsets[q] = divmod(int(k), rx)
                    break


def _search_the_rest(
    ex: np.ndarray,
    values: np.ndarray,
    offsets: np.ndarray,
    out_patches: Callable[[np.ndarray], np.ndarray],
    index: Any,
    threads: int | None,
) -> np.ndarray:
    """The exhaustive nearest-patch search of every patch that is not an exact copy; returns their indices."""
    from ..base.kernels import SsdIndex

    todo = np.nonzero(np.isnan(values))[0]
    if todo.size:
        idx = index if index is not None else SsdIndex(ex, threads)
        for b in range(0, todo.size, COHERENCE_BATCH):
            sel = todo[b : b + COHERENCE_BATCH]
            off, val = idx.best_matches(np.ascontiguousarray(out_patches(sel)), k=1, threads=threads)
            values[sel] = np.maximum(val[:, 0], 0.0)
            offsets[sel] = off[:, 0]
    return todo
