"""Gradient norms of the exemplar at given pixel positions (the ω-tiles' gradient weights), in Rust.

:func:`patch_gradients` was a NumPy expression over the whole exemplar in float64 (about 10 temporaries of the
exemplar's size, and on 1024² exemplars one of the larger serial steps of a random build); it now runs in the
Rust core (``_core.patch_gradients``, GIL released) and gives bit-identical values: the squares are summed in
channel order in float64 exactly as NumPy does for fewer than 8 channels. Other inputs (more channels, other
dtypes) keep the NumPy reference :func:`patch_gradients_numpy`.
"""

from __future__ import annotations

import numpy as np

from .. import _core


def patch_gradients_numpy(exemplar: np.ndarray, source: np.ndarray) -> np.ndarray:
    """The NumPy reference of :func:`patch_gradients` (the oracle of the tests)."""
    e = exemplar.astype(np.float64)
    h, w = e.shape[:2]
    gx = np.zeros((h, w))
    gy = np.zeros((h, w))
    gx[:, :-1] = np.sqrt(((e[:, 1:] - e[:, :-1]) ** 2).sum(-1))
    gy[:-1] = np.sqrt(((e[1:] - e[:-1]) ** 2).sum(-1))
    r, c = source[..., 0], source[..., 1]
    return np.ascontiguousarray(np.stack([gx[r, c], gy[r, c]], axis=-1))


def patch_gradients(exemplar: np.ndarray, source: np.ndarray) -> np.ndarray:
    """Gradient norms of ``exemplar`` ``(H, W, C)`` at the positions ``source`` (``(..., 2)`` row, col):
    ``(..., 2)`` float64.

    Index 0 is ‖E(r, c+1) − E(r, c)‖, index 1 is ‖E(r+1, c) − E(r, c)‖ (L2 over channels, 0 past the exemplar
    edge). Positions must lie inside the exemplar (else :class:`tilesynth.ParameterError` naming ``source``).
    """
    source = np.asarray(source)
    if (
        exemplar.ndim != 3
        or exemplar.dtype != np.float32
        or not 1 <= exemplar.shape[2] < 8
        or source.ndim < 1
    ):
        return patch_gradients_numpy(exemplar, source)
    flat = np.ascontiguousarray(source.reshape(-1, source.shape[-1]), dtype=np.int64)
    g = _core.patch_gradients(np.ascontiguousarray(exemplar), flat)
    return g.reshape(source.shape[:-1] + (2,))
