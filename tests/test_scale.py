"""Builds that scale: the exemplar-sized work of the default build done in bounded pieces or on shared
structure, with the results of the whole-array computations."""

from __future__ import annotations

import numpy as np
import pytest

from tilesynth import _core
from tilesynth.base import kernels
from tilesynth.builder.genes import omega_borders as ob
from tilesynth.errors import ParameterError
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


def _quadrant_tiles(ex: np.ndarray, n: int, seed: int) -> np.ndarray:
    """Templates made of the quadrants of 3 sample patches, in every combination (as intermediate tiles)."""
    rng = np.random.default_rng(seed)
    h = n // 2
    pos = rng.integers(0, np.array(ex.shape[:2]) - n, (3, 2))
    quads = [ex[r + y : r + y + h, c + x : c + x + h] for r, c in pos for y in (0, h) for x in (0, h)]
    tiles = []
    for _ in range(24):
        a, b, c, d = rng.integers(0, len(quads), 4)
        top, bottom = np.concatenate([quads[a], quads[b]], 1), np.concatenate([quads[c], quads[d]], 1)
        tiles.append(np.concatenate([top, bottom], 0))
    return np.ascontiguousarray(np.stack(tiles), dtype=np.float32)


@pytest.mark.parametrize("k, radius", [(1, 0), (3, 4), (8, 6)])
@pytest.mark.parametrize("threads", [1, 2])
def test_quadrant_matches_are_the_plain_matches(k, radius, threads):
    """The sum of quadrant maps gives the exact greedy matches of one map per template, bit for bit."""
    ex = _image(70, 66, 2).astype(np.float32)
    t = _quadrant_tiles(ex, 16, 3)
    assert kernels._shared_quadrants(t) is not None
    index = kernels.SsdIndex(ex)
    want = index._index.best_matches(t, k, radius, None, threads)  # one FFT map per template
    got = index.best_matches(t, k=k, exclude_radius=radius, threads=threads)
    np.testing.assert_array_equal(got[0], want[0])
    assert got[1].tobytes() == want[1].tobytes()


@pytest.mark.parametrize(
    "h, w, q, k, radius", [(170, 150, 12, 20, 5), (200, 190, 32, 12, 9), (131, 140, 8, 40, 0)]
)
def test_quadrant_matches_on_many_blocks(h, w, q, k, radius):
    """Maps of several 32 x 32 blocks, quadrant shifts aligned (32) and not (8, 12) with the blocks, many
    matches whose exclusion windows cross blocks: the blocks summed lazily give the plain matches, bit for
    bit."""
    ex = _image(h, w, 3).astype(np.float32)
    t = _quadrant_tiles(ex, q, 4)
    index = kernels.SsdIndex(ex)
    want = index._index.best_matches(t, k, radius, None, 2)
    got = index.best_matches(t, k=k, exclude_radius=radius, threads=2)
    np.testing.assert_array_equal(got[0], want[0])
    assert got[1].tobytes() == want[1].tobytes()


def test_unshared_templates_take_the_plain_path():
    t = np.ascontiguousarray(_image(4 * 16, 16, 4).reshape(4, 16, 16, 3), dtype=np.float32)
    assert kernels._shared_quadrants(t) is None
    assert kernels._shared_quadrants(t[:, :15, :15]) is None  # odd sides have no quadrants


def test_quadrants_must_be_the_templates_quadrants():
    ex = _image(40, 40, 5).astype(np.float32)
    t = _quadrant_tiles(ex, 8, 6)
    quads, assign = kernels._shared_quadrants(t)
    index = kernels.SsdIndex(ex)
    bad = assign.copy()
    bad[0, 0] = (bad[0, 0] + 1) % len(quads)
    if (quads[bad[0, 0]] == quads[assign[0, 0]]).all():
        pytest.skip("two equal quadrants")
    got = [_core.quadrant_map(index._index, q, None) for q in quads]
    maps = np.stack([m for m, _, _ in got])
    bounds, maxes = [b for _, b, _ in got], [x for _, _, x in got]
    with pytest.raises(ParameterError, match="assign"):
        _core.best_matches_quadrants(index._index, quads, maps, bounds, maxes, t, bad, 1, 0, None)
