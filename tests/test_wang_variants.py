"""Complete Wang edge sets with variants (issue 12, item 2 for edge sets): wc<K>x<V>, built as strict Wang tiles."""

from __future__ import annotations

import itertools
import subprocess
import sys
from importlib import resources

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.engine import hash_layout
from tilesynth.errors import ParameterError
from tilesynth.io.images import load_image
from tilesynth.layouts.hashed import cell_index_reference, hash_seed, lookup_scheme
from tilesynth.layouts.omega_sets import tileset_from_dict
from tilesynth.layouts.wang_sets import WangTileSet, get_wang_tileset, is_wang_set_name
from tilesynth.measure.metrics import seam_score


@pytest.fixture(scope="module")
def lettuce():
    return load_image(resources.files("tilesynth") / "data" / "lettuce-leaves.png")[0][:160, :160]


@pytest.fixture(scope="module")
def wc2x2(lettuce):
    return ts.build_swang(lettuce, tileset="wc2x2", tile_size=32, seed=2)


@pytest.mark.parametrize("name,kh,kv,v", [("wc2x2", 2, 2, 2), ("wc2-3x3", 2, 3, 3), ("wc3x1", 3, 3, 1)])
def test_edge_sets_with_variants_are_complete_in_spec_order(name, kh, kv, v):
    assert is_wang_set_name(name)
    s = get_wang_tileset(name)
    assert len(s) == kh * kh * kv * kv * v and s.n_variants == v
    seen: dict = {}
    for t, var in zip(s.tiles, s.variants):
        seen.setdefault(t, set()).add(var)
    assert set(seen) == set(itertools.product(s.horizontal, s.vertical, s.horizontal, s.vertical))
    assert all(vs == set(range(v)) for vs in seen.values())
    hi = {c: i for i, c in enumerate(s.horizontal)}
    vi = {c: i for i, c in enumerate(s.vertical)}
    for j, ((n, e, so, w), var) in enumerate(zip(s.tiles, s.variants)):
        assert ((((hi[n] * kv + vi[e]) * kh + hi[so]) * kv + vi[w]) * v + var) == j
    sch = lookup_scheme(s)
    assert sch.kind == "edge" and sch.colours == (kh, kv) and sch.variants == v
    assert hash_layout(s) == {"kind": "edge", "Kh": kh, "Kv": kv, "V": v}


def test_description_round_trip_and_old_sets_unchanged():
    s = get_wang_tileset("wc2x2")
    d = s.to_dict()
    assert d["variants"] == [j % 2 for j in range(32)]
    back = tileset_from_dict(d)
    assert back.tiles == s.tiles and back.variants == s.variants
    # a set without variants keeps its old description (its digests do not move)
    assert "variants" not in get_wang_tileset("wc2").to_dict()
    assert "variants" not in get_wang_tileset("wang8").to_dict()
    assert lookup_scheme(get_wang_tileset("wang8")) is None


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"tiles": ("RYRY", "RYRY")}, "distinct"),
        ({"tiles": ("RYRY", "RYRY"), "variants": (0, 0)}, "distinct"),
        ({"tiles": ("RYRY",), "variants": (0, 1)}, "variants has 2 entries"),
        ({"tiles": ("RYRY",), "variants": (-1,)}, "non-negative"),
        ({"tiles": ("RYRY",), "variants": ("a",)}, "ints"),
        ({"tiles": ("RYRY",), "variants": 3}, "sequence"),
    ],
)
def test_bad_variants(kwargs, match):
    with pytest.raises(ValueError, match=match):
        WangTileSet(name="x", horizontal="R", vertical="Y", **kwargs)


def test_two_tiles_of_one_tuple_with_different_variants():
    s = WangTileSet(name="x", horizontal="R", vertical="Y", tiles=("RYRY", "RYRY"), variants=(0, 1))
    assert lookup_scheme(s).variants == 2 and s.tile_label(1) == "<N=R,E=Y,S=R,W=Y>'1"


@pytest.mark.parametrize("bad", ["wc2x0", "wc2x99999", "wc1x2", "wc9x2", "wc2x", "wc2-x2"])
def test_bad_names(bad):
    assert not is_wang_set_name(bad)
    with pytest.raises(ValueError):
        get_wang_tileset(bad)


def test_variants_have_different_supplementary_patches(wc2x2):
    defn = wc2x2.definition
    n = wc2x2.tile_size
    assert wc2x2.n_tiles == 32
    for j in range(0, 32, 2):
        assert defn.tiles[j] == defn.tiles[j + 1] and defn.variants[j : j + 2] == (0, 1)
        a, b = wc2x2.match_offsets[j], wc2x2.match_offsets[j + 1]
        assert np.abs(a - b).max() > n // 4  # not near-copies
        assert not np.array_equal(wc2x2.tiles[j], wc2x2.tiles[j + 1])
        # the variants share their edges: the border ring is the initial tile's
        ring = ~np.pad(np.ones((n - 2, n - 2), bool), 1)
        np.testing.assert_array_equal(wc2x2.tiles[j][ring], wc2x2.tiles[j + 1][ring])


def test_hashed_lookup_picks_every_variant(wc2x2):
    seed = 77
    _, imap = ts.synthesize(wc2x2, 32 * 20, 32 * 20, seed=seed)
    assert set(np.unique(imap).tolist()) == set(range(32))
    sch = lookup_scheme(wc2x2.definition)
    for cy, cx in [(0, 0), (3, 7), (19, 19)]:
        assert imap[cy, cx] == cell_index_reference(sch, hash_seed(seed), cx, cy)


def test_random_access_equals_crops(wc2x2):
    big, _ = ts.synthesize(wc2x2, 300, 260, seed=0xDEADBEEF, origin=(-150, -131), dtype=np.uint8)
    for (x0, y0), (w, h) in [
        ((-150, -131), (300, 260)),
        ((-1, -1), (3, 2)),
        ((-33, 31), (70, 40)),
        ((31, -2), (2, 5)),
    ]:
        win, _ = ts.synthesize(wc2x2, w, h, seed=0xDEADBEEF, origin=(x0, y0), dtype=np.uint8)
        np.testing.assert_array_equal(win, big[y0 + 131 : y0 + 131 + h, x0 + 150 : x0 + 150 + w])


def test_wrap_is_periodic_and_seamless(wc2x2):
    w, h = 32 * 6, 32 * 5
    img, imap = ts.synthesize(wc2x2, w, h, seed=9, wrap=True, dtype=np.uint8)
    win, _ = ts.synthesize(wc2x2, w, h, seed=9, wrap=True, origin=(-37, 61), dtype=np.uint8)
    np.testing.assert_array_equal(win, np.roll(img, (-(61 % h), -(-37 % w)), axis=(0, 1)))
    inside = seam_score(img.astype(np.float32) / 255, 32).score
    twice = seam_score(np.tile(img, (2, 2, 1)).astype(np.float32) / 255, 32).score
    assert twice == pytest.approx(inside, rel=0.05)  # the wrap border like the ones inside


def test_cut_supplementary_takes_the_ranked_cuts(lettuce):
    s = ts.build_swang(lettuce, tileset="wc2x2", tile_size=32, seed=2, supplementary="cut", candidates=3)
    for j in range(0, 32, 2):
        assert not np.array_equal(s.match_offsets[j], s.match_offsets[j + 1])
        assert s.cut_costs[j] <= s.cut_costs[j + 1]  # variant 0 the cheapest cut, variant 1 the next
    with pytest.raises(ParameterError, match="fewer than the 2 variants"):
        ts.build_swang(lettuce, tileset="wc2x2", tile_size=32, seed=2, supplementary="cut", candidates=1)


def test_cohen_wang_refuses_variants(lettuce):
    with pytest.raises(ParameterError, match="--scheme swang"):
        ts.build_wang(lettuce, tileset="wc2x2", tile_size=32, seed=2)


def test_save_load_and_cli(wc2x2, tmp_path, lettuce):
    p = tmp_path / "w.tiles"
    wc2x2.save(p)
    back = ts.load(p)
    assert back.definition.variants == wc2x2.definition.variants
    a, _ = ts.synthesize(back, 64, 64, seed=3, origin=(-5, 9))
    b, _ = ts.synthesize(wc2x2, 64, 64, seed=3, origin=(-5, 9))
    np.testing.assert_array_equal(a, b)
    ex = tmp_path / "ex.png"
    ts.save_image(ex, lettuce)
    out = tmp_path / "c.tiles"
    r = subprocess.run(
        [sys.executable, "-m", "tilesynth", "build", str(ex), "-o", str(out), "--scheme", "swang",
         "--set", "wc2x2", "--tile-size", "32", "--seed", "1"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert ts.load(out).n_tiles == 32
    r = subprocess.run(
        [sys.executable, "-m", "tilesynth", "build", str(ex), "-o", str(out), "--scheme", "wang",
         "--set", "wc2x2", "--tile-size", "32"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert r.returncode == 2 and "swang" in r.stderr
