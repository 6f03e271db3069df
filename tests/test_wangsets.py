"""Edge-coloured (Wang) tile sets and the scan-line tiler serving them: complete choice, no dead ends, every
shared edge matches, seeded."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tilesynth.layouts.omega_sets import (
    TileSetLike,
    choices_summary,
    dead_ends,
    reachable_situations,
    tileset_from_dict,
)
from tilesynth.layouts.scanline import scanline_index_map, validate_index_map
from tilesynth.layouts.wang_sets import (
    WANG_TILESET_NAMES,
    WangTileSet,
    complete_choice_set,
    get_wang_tileset,
    is_wang_set_name,
)

NAMES = [*WANG_TILESET_NAMES, "wang32"]


def edge_mismatches(tiles, index_map) -> list:
    """Neighbouring pairs whose shared edge colours differ, straight from ⟨N, E, S, W⟩ (no side-key code)."""
    rows, cols = index_map.shape
    bad = []
    for i in range(rows):
        for j in range(cols):
            n, e, s, w = tiles[index_map[i, j]]
            if j + 1 < cols and tiles[index_map[i, j + 1]][3] != e:
                bad.append(((i, j), (i, j + 1)))
            if i + 1 < rows and tiles[index_map[i + 1, j]][0] != s:
                bad.append(((i, j), (i + 1, j)))
    return bad


@pytest.mark.parametrize(("name", "k"), [("wang8", 2), ("wang18", 3), ("wang32", 4)])
def test_complete_choice_structure(name, k):
    ts = get_wang_tileset(name)
    assert isinstance(ts, TileSetLike)
    assert len(ts) == 2 * k * k and ts.n_samples == 2 * k
    assert len(ts.horizontal) == k and len(ts.vertical) == k
    # two tiles for every (N, W) pair, differing in both S and E
    for n, w in itertools.product(ts.horizontal, ts.vertical):
        pair = [t for t in ts.tiles if t[0] == n and t[3] == w]
        assert len(pair) == 2
        assert pair[0][1] != pair[1][1] and pair[0][2] != pair[1][2]
    # every (S, E) pair produced by exactly two tiles: colours stay equally likely
    for s, e in itertools.product(ts.horizontal, ts.vertical):
        assert sum(1 for t in ts.tiles if t[2] == s and t[1] == e) == 2
    # horizontal colours only on N/S, vertical only on E/W
    assert {t[0] for t in ts.tiles} | {t[2] for t in ts.tiles} == set(ts.horizontal)
    assert {t[1] for t in ts.tiles} | {t[3] for t in ts.tiles} == set(ts.vertical)


def test_wang8_contains_the_tiles_004_names():
    """004 names T_yrbg, T_bgyr, T_bgbg (edges anticlockwise from the top: N, W, S, E; horizontal y, b; vertical
    r, g). With y=R, b=G (horizontal) and r=Y, g=C (vertical) they are ⟨N, E, S, W⟩ = RCGY, GYRC, GCGC."""
    tiles = set(get_wang_tileset("wang8").tiles)
    for nwse in ("yrbg", "bgyr", "bgbg"):
        n, w, s, e = nwse
        hmap, vmap = {"y": "R", "b": "G"}, {"r": "Y", "g": "C"}
        assert (hmap[n], vmap[e], hmap[s], vmap[w]) in tiles, nwse
    # T_bgbg and T_bgyr are the two choices of the same (N, W) pair, as in 004's Figure 5(b)
    assert ("G", "C", "G", "C") in tiles and ("G", "Y", "R", "C") in tiles


@pytest.mark.parametrize("name", NAMES)
def test_no_dead_ends_and_two_choices_inside(name):
    ts = get_wang_tileset(name)
    assert dead_ends(ts) == []
    summary = choices_summary(ts)
    k = len(ts.horizontal)
    assert summary["interior"] == (2, 2)
    assert summary["first_row"] == (2 * k, 2 * k)
    assert summary["first_column"] == (2 * k, 2 * k)
    assert summary["first_tile"] == (len(ts), len(ts))
    # every (W, N) pair is a reachable interior situation
    assert len(reachable_situations(ts)["interior"]) == k * k


@pytest.mark.parametrize("name", NAMES)
@settings(max_examples=30, deadline=None)
@given(rows=st.integers(1, 48), cols=st.integers(1, 48), seed=st.integers(0, 2**63 - 1))
@example(rows=48, cols=48, seed=0)
@example(rows=1, cols=48, seed=1)
@example(rows=48, cols=1, seed=2)
def test_random_tilings_are_valid(name, rows, cols, seed):
    ts = get_wang_tileset(name)
    m = scanline_index_map(ts, rows, cols, seed)
    assert m.shape == (rows, cols) and m.dtype == np.int32
    assert m.min() >= 0 and m.max() < len(ts)
    assert edge_mismatches(ts.tiles, m) == []
    validate_index_map(ts, m)


@pytest.mark.parametrize("name", NAMES)
def test_seeded(name):
    ts = get_wang_tileset(name)
    a = scanline_index_map(ts, 20, 30, 7)
    np.testing.assert_array_equal(a, scanline_index_map(ts, 20, 30, 7))
    assert not np.array_equal(a, scanline_index_map(ts, 20, 30, 8))
    # uses every tile, and both choices of the interior
    big = scanline_index_map(ts, 60, 60, 1)
    assert set(np.unique(big).tolist()) == set(range(len(ts)))


def test_choices_are_uniform_in_the_interior():
    ts = get_wang_tileset("wang8")
    m = scanline_index_map(ts, 200, 200, 3)
    counts = np.bincount(m[1:, 1:].ravel(), minlength=8)
    assert counts.min() > 0.9 * counts.mean() and counts.max() < 1.1 * counts.mean()


def test_validate_index_map_names_the_edges():
    ts = get_wang_tileset("wang8")
    m = scanline_index_map(ts, 4, 4, 5)
    bad = m.copy()
    t = int(m[2, 2])
    bad[2, 2] = next(k for k in range(8) if ts.left_key(k) != ts.left_key(t))
    with pytest.raises(ValueError, match=r"\(2, 1\) and its right neighbour \(2, 2\).*right key"):
        validate_index_map(ts, bad)


def test_round_trip_and_dispatch():
    ts = get_wang_tileset("wang18")
    d = ts.to_dict()
    assert d["kind"] == "wang" and len(d["tiles"]) == 18
    back = tileset_from_dict(d)
    assert back == ts and isinstance(back, WangTileSet)
    assert (
        tileset_from_dict({"kind": "corner", "name": "x", "colours": ["R"], "tiles": [["R"] * 4]}).name == "x"
    )
    with pytest.raises(ValueError, match="known kinds: 'corner', 'wang'"):
        tileset_from_dict({"kind": "hex"})
    assert ts.sample_indices().shape == (18, 4)
    # genes: horizontal colours first, N and S columns index them, E and W the vertical ones
    idx = ts.sample_indices()
    assert idx[:, [0, 2]].max() < 3 and idx[:, [1, 3]].min() >= 3
    assert ts.tile_label(0) == "<N=R,E=Y,S=R,W=Y>"


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        (dict(horizontal=(), vertical=("Y",), tiles=()), "horizontal colours"),
        (dict(horizontal=("R", "R"), vertical=("Y",), tiles=()), "distinct"),
        (dict(horizontal=("R",), vertical=("Y",), tiles=()), "at least one tile"),
        (dict(horizontal=("R",), vertical=("Y",), tiles=(("R", "Y", "R"),)), "four edges"),
        (dict(horizontal=("R",), vertical=("Y",), tiles=(("R", "R", "R", "Y"),)), "E colour 'R'"),
        (dict(horizontal=("R",), vertical=("Y",), tiles=(("R", "Y", "R", "Y"),) * 2), "distinct"),
        # not sequences at all: named (was TypeError "'NoneType' object is not iterable")
        (dict(horizontal=None, vertical=("Y",), tiles=()), "horizontal colours must be a sequence"),
        (dict(horizontal=("R",), vertical=5, tiles=()), "vertical colours must be a sequence"),
        (dict(horizontal=("R",), vertical=("Y",), tiles=None), "tiles must be a sequence"),
        (
            dict(horizontal=("R",), vertical=("Y",), tiles=(("R", "Y", "R", "Y"), 7)),
            "tile 1 must be a sequence",
        ),
    ],
)
def test_bad_sets_are_rejected(kwargs, words):
    with pytest.raises(ValueError, match=words):
        WangTileSet(name="x", **kwargs)


def test_names():
    assert is_wang_set_name("wang8") and is_wang_set_name("wang18") and is_wang_set_name("wang128")
    for bad in ("wang9", "wang2", "wang", "16a", "wang08", "wang200"):
        assert not is_wang_set_name(bad), bad
    with pytest.raises(ValueError, match="wang8, wang18"):
        get_wang_tileset("wang10")
    with pytest.raises(ValueError, match="k = 1"):
        complete_choice_set(1)
    # found by the fuzzers: a long number overflowed the float of the size check (OverflowError), a longer one
    # hit Python's int-from-string limit (a ValueError about sys.set_int_max_str_digits), and a list was
    # unhashable for the cache (TypeError)
    for bad in ("wang" + "1" * 400, "wang" + "9" * 5000, ["wang8"], None):
        assert not is_wang_set_name(bad)
        with pytest.raises(ValueError, match="unknown Wang tile set"):
            get_wang_tileset(bad)
    assert get_wang_tileset("wang18") is get_wang_tileset("wang18")  # still cached


def test_from_dict_checks_the_alphabets():
    with pytest.raises(ValueError, match="horizontal colours must be a sequence"):
        WangTileSet.from_dict(
            {"kind": "wang", "name": "x", "horizontal": 3, "vertical": "Y", "tiles": ["RYRY"]}
        )
