"""patch_gradients in Rust: bit-identical to the NumPy reference (oracle), edges, errors."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.base.gradients import patch_gradients, patch_gradients_numpy
from tilesynth.builder.omega import patch_gradients as omega_patch_gradients


@pytest.mark.parametrize("channels", [1, 2, 3, 4, 7])
@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (8, 1), (17, 23), (64, 40)])
def test_bit_identical_to_numpy(channels: int, shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(channels * 100 + shape[0])
    h, w = shape
    ex = rng.random((h, w, channels), dtype=np.float32)
    if channels == 3:  # quantised values, as from 8-bit images: many equal neighbours (zero gradients)
        ex = (np.round(ex * 4) / 4).astype(np.float32)
    src = np.stack([rng.integers(0, h, (5, 6, 7)), rng.integers(0, w, (5, 6, 7))], axis=-1).astype(np.int32)
    src[0, 0, 0] = (h - 1, w - 1)  # both past-the-edge zeros
    got = patch_gradients(ex, src)
    want = patch_gradients_numpy(ex, src)
    assert got.shape == (5, 6, 7, 2) and got.dtype == np.float64
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    assert np.array_equal(omega_patch_gradients(ex, src), want)
    assert got[0, 0, 0].tolist() == [0.0, 0.0]


def test_fallbacks_and_errors() -> None:
    rng = np.random.default_rng(3)
    ex64 = rng.random((6, 5, 3))
    src = np.array([[0, 0], [5, 4], [2, 3]])
    assert np.array_equal(patch_gradients(ex64, src), patch_gradients_numpy(ex64, src))  # float64: NumPy path
    wide = rng.random((6, 5, 9), dtype=np.float32)
    assert np.array_equal(patch_gradients(wide, src), patch_gradients_numpy(wide, src))  # 9 channels: NumPy
    ex = rng.random((6, 5, 3), dtype=np.float32)
    assert patch_gradients(ex, np.zeros((0, 2), np.int64)).shape == (0, 2)
    for bad in ([6, 0], [0, 5], [-1, 0]):
        with pytest.raises(ts.ParameterError, match="source"):
            patch_gradients(ex, np.array([[0, 0], bad]))
