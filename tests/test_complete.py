"""Complete corner / edge sets and their hashed synthesis: completeness, random access, wrap."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.errors import ParameterError
from tilesynth.layouts.hashed import lookup_scheme
from tilesynth.layouts.omega_sets import get_tileset
from tilesynth.layouts.wang_sets import complete_edge_set, get_wang_tileset, is_wang_set_name
from tilesynth.measure.metrics import seam_score


@pytest.mark.parametrize(
    "name,k,v", [("c2", 2, 1), ("c3", 3, 1), ("c3x2", 3, 2), ("c2x5", 2, 5), ("c4", 4, 1)]
)
def test_corner_sets_are_complete_in_spec_order(name, k, v):
    s = get_tileset(name)
    assert s.name == name and len(s) == k**4 * v
    assert len(s.colours) == k
    idx = {c: i for i, c in enumerate(s.colours)}
    # every tuple exactly V times, with variants 0..V-1
    seen = {}
    for t, var in zip(s.tiles, s.variants):
        seen.setdefault(t, set()).add(var)
    assert set(seen) == set(itertools.product(s.colours, repeat=4))
    assert all(vs == set(range(v)) for vs in seen.values())
    # spec order: index = (((TL*K + BL)*K + TR)*K + BR)*V + v
    for j, (t, var) in enumerate(zip(s.tiles, s.variants)):
        a, b, c, d = (idx[x] for x in t)
        assert (((a * k + b) * k + c) * k + d) * v + var == j
    sch = lookup_scheme(s)
    assert sch is not None and sch.kind == "corner" and sch.colours == (k,) and sch.variants == v


@pytest.mark.parametrize("name,kh,kv", [("wc2", 2, 2), ("wc3", 3, 3), ("wc2-3", 2, 3)])
def test_edge_sets_are_complete_in_spec_order(name, kh, kv):
    assert is_wang_set_name(name)
    s = get_wang_tileset(name)
    assert len(s) == kh * kh * kv * kv
    assert set(s.tiles) == set(itertools.product(s.horizontal, s.vertical, s.horizontal, s.vertical))
    hi = {c: i for i, c in enumerate(s.horizontal)}
    vi = {c: i for i, c in enumerate(s.vertical)}
    for j, (n, e, so, w) in enumerate(s.tiles):
        assert (((hi[n] * kv + vi[e]) * kh + hi[so]) * kv + vi[w]) == j
    assert lookup_scheme(s).colours == (kh, kv)


@pytest.mark.parametrize("name", ["4", "16a", "16b", "32", "B", "n1", "16bx2"])
def test_seed_sets_are_not_hashed(name):
    assert lookup_scheme(get_tileset(name)) is None


def test_wang_seed_sets_are_not_hashed():
    assert lookup_scheme(get_wang_tileset("wang8")) is None
    assert lookup_scheme(complete_edge_set(2, 2)) is not None


@pytest.mark.parametrize("bad", ["c1", "c9", "c4x17", "c0", "c03"])
def test_bad_complete_names(bad):
    with pytest.raises(ValueError):
        get_tileset(bad)


def test_bad_wang_complete_names():
    assert not is_wang_set_name("wc1") and not is_wang_set_name("wc9") and not is_wang_set_name("wc2-")


@pytest.fixture(scope="module")
def c2x2(lettuce):
    return ts.build_omega(lettuce[:160, :160], tileset="c2x2", tile_size=32, seed=4)


@pytest.fixture(scope="module")
def lettuce():
    from importlib import resources

    from tilesynth.io.images import load_image

    return load_image(resources.files("tilesynth") / "data" / "lettuce-leaves.png")[0]


def test_built_set_is_hashed_and_uses_every_tile(c2x2):
    assert c2x2.n_tiles == 32 and lookup_scheme(c2x2.definition) is not None
    _, imap = ts.synthesize(c2x2, 32 * 24, 32 * 24, seed=1)
    assert set(np.unique(imap).tolist()) == set(range(32))


@pytest.mark.parametrize("dtype", [np.uint8, np.float32])
def test_random_access_equals_crops(c2x2, dtype):
    big, _ = ts.synthesize(c2x2, 400, 360, seed=0xDEADBEEF, origin=(-200, -170), dtype=dtype)
    for (x0, y0), (w, h) in [
        ((-200, -170), (400, 360)),
        ((-1, -1), (3, 2)),
        ((-33, 31), (70, 40)),
        ((0, 0), (1, 1)),
        ((-64, -64), (64, 64)),
        ((17, -170), (1, 360)),
        ((-5, 100), (205, 1)),
    ]:
        win, imap = ts.synthesize(c2x2, w, h, seed=0xDEADBEEF, origin=(x0, y0), dtype=dtype)
        np.testing.assert_array_equal(win, big[y0 + 170 : y0 + 170 + h, x0 + 200 : x0 + 200 + w])
        assert imap.shape == (-(-((y0 % 32) + h) // 32), -(-((x0 % 32) + w) // 32))


def test_far_origin(c2x2):
    x0, y0 = 32 * (2**31 - 3) + 5, -32 * (2**31) + 7
    a, _ = ts.synthesize(c2x2, 100, 50, seed=3, origin=(x0, y0))
    b, _ = ts.synthesize(c2x2, 40, 20, seed=3, origin=(x0 + 30, y0 + 10))
    np.testing.assert_array_equal(a[10:30, 30:70], b)
    with pytest.raises(ParameterError, match="origin"):
        ts.synthesize(c2x2, 10, 10, seed=3, origin=(32 * 2**31, 0))


def test_wrap_is_periodic_and_seamless(c2x2):
    w, h = 32 * 7, 32 * 5
    img, imap = ts.synthesize(c2x2, w, h, seed=9, wrap=True, dtype=np.uint8)
    assert imap.shape == (5, 7)
    # the periodic texture: every window of it is the matching roll of the output
    for x0, y0 in [(w // 2, 0), (-37, 61), (3 * w + 5, -2 * h - 1)]:
        win, _ = ts.synthesize(c2x2, w, h, seed=9, wrap=True, origin=(x0, y0), dtype=np.uint8)
        np.testing.assert_array_equal(win, np.roll(img, (-(y0 % h), -(x0 % w)), axis=(0, 1)))
    # the output laid twice over is seamless at the wrap like inside: same seam score as one output
    assert seam_score(np.tile(img, (2, 2, 1)), 32).score < 2.0
    # wrap with a size that is not a multiple of the tile size
    with pytest.raises(ParameterError, match="multiple of the tile size"):
        ts.synthesize(c2x2, w + 1, h, seed=9, wrap=True)


def test_wrap_seam_equals_inside(c2x2):
    """Mean squared step across the wrap border == its value as an interior border of the rolled output."""
    w, h = 32 * 6, 32 * 6
    img = ts.synthesize(c2x2, w, h, seed=2, wrap=True)[0].astype(np.float64)
    across = ((img[:, -1] - img[:, 0]) ** 2).sum(-1).mean()
    rolled = np.roll(img, -w // 2, axis=1)
    inside = ((rolled[:, w // 2 - 1] - rolled[:, w // 2]) ** 2).sum(-1).mean()
    assert across == inside
    borders = [((img[:, x - 1] - img[:, x]) ** 2).sum(-1).mean() for x in range(32, w, 32)]
    assert min(borders) / 4 <= across <= max(borders) * 4


def test_seed_range_for_hashed(c2x2):
    with pytest.raises(ParameterError, match="seed"):
        ts.synthesize(c2x2, 32, 32, seed=2**32)


def test_unhashable_sets_refuse_origin_and_wrap(lettuce):
    s = ts.build_omega(lettuce[:128, :128], tileset="16a", tile_size=32, seed=1)
    with pytest.raises(ParameterError, match="not complete"):
        ts.synthesize(s, 64, 64, seed=1, origin=(1, 0))
    with pytest.raises(ParameterError, match="not complete"):
        ts.synthesize(s, 64, 64, seed=1, wrap=True)
    ts.synthesize(s, 64, 64, seed=1, origin=(0, 0))  # the scan-line tiler as before


def test_explicit_map_with_origin_is_refused(c2x2):
    _, imap = ts.synthesize(c2x2, 64, 64, seed=1)
    out, _ = ts.synthesize(c2x2, 64, 64, index_map=imap)
    np.testing.assert_array_equal(out, ts.synthesize(c2x2, 64, 64, seed=1)[0])
    with pytest.raises(ParameterError, match="index_map"):
        ts.synthesize(c2x2, 64, 64, index_map=imap, origin=(1, 1))


def test_wang_complete_set_builds_and_hashes(lettuce):
    s = ts.build_wang(lettuce[:160, :160], tileset="wc2", tile_size=32, seed=2)
    assert s.n_tiles == 16 and lookup_scheme(s.definition) is not None
    big, _ = ts.synthesize(s, 200, 200, seed=5, origin=(-100, -100))
    win, _ = ts.synthesize(s, 50, 60, seed=5, origin=(-17, 3))
    np.testing.assert_array_equal(win, big[103:163, 83:133])
