"""Builds that scale: the exemplar-sized work of the default build done in bounded pieces or on shared
structure, with the results of the whole-array computations."""

from __future__ import annotations

import numpy as np
import pytest

from tilesynth.builder.genes import omega_borders as ob
from tilesynth.measure import quality as q


def _image(h: int, w: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.random((h, w, 3))


@pytest.mark.parametrize("block", [5, 17, 250])
def test_blocked_gram_is_the_whole_gram(block):
    img = _image(61, 47)
    want = q._rectified_gram(q._responses(img))
    np.testing.assert_allclose(q.blocked_gram(img, block), want, rtol=1e-12, atol=1e-15)


def test_sample_stats_distance_is_the_sliced_formula():
    """Each window's own valid responses and the exemplar's Gram matrix give the distance that slicing the
    whole exemplar's responses gave."""
    ex = _image(80, 72, 1).astype(np.float32).astype(np.float64)  # the build's float32 values
    n, k = 32, q.TEXSTATS_SIZE
    genes = np.array([[0, 0], [10, 40], [48, 3], [20, 20]])
    out = []
    for f in q.TEXSTATS_SCALES:
        e = q._down(ex, f)
        rmap = q._responses(e).reshape(-1, e.shape[0] - k + 1, e.shape[1] - k + 1)
        m = n // f
        full = q._rectified_gram(rmap.reshape(rmap.shape[0], -1))
        parts = [rmap[:, r // f : r // f + m - k + 1, c // f : c // f + m - k + 1] for r, c in genes]
        win = q._rectified_gram(np.concatenate([p.reshape(p.shape[0], -1) for p in parts], axis=1))
        out.append(np.linalg.norm(win - full) / np.linalg.norm(full))
    assert ob.sample_stats_distance(ex, genes, n) == pytest.approx(float(np.mean(out)), rel=1e-12)
