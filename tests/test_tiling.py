"""Tests of scan-line tiling and index-map validation."""

from __future__ import annotations

import time

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tilesynth.layouts.omega_sets import PATCH_COLOURS, TILESET_NAMES, CornerTileSet, get_tileset
from tilesynth.layouts.scanline import candidate_table, scanline_index_map, validate_index_map

TL, BL, TR, BR = 0, 1, 2, 3

SETS_WITH_CHOICES = ["8", "16a", "16b", "32"]


def corner_mismatches(tiles: tuple[tuple[str, ...], ...], index_map: np.ndarray) -> list:
    """All neighbouring pairs that do not share their corners, straight from the
    corner rule (independent of the side-key code).  Pairs are ((i, j), (i2, j2))."""
    rows, cols = index_map.shape
    bad = []
    for i in range(rows):
        for j in range(cols):
            a = tiles[index_map[i, j]]
            if j + 1 < cols:
                x = tiles[index_map[i, j + 1]]
                if x[TL] != a[TR] or x[BL] != a[BR]:
                    bad.append(((i, j), (i, j + 1)))
            if i + 1 < rows:
                x = tiles[index_map[i + 1, j]]
                if x[TL] != a[BL] or x[TR] != a[BR]:
                    bad.append(((i, j), (i + 1, j)))
    return bad


# --------------------------------------------------------------------------
# Random tilings
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", TILESET_NAMES)
@settings(max_examples=40, deadline=None)
@given(
    rows=st.integers(1, 64),
    cols=st.integers(1, 64),
    seed=st.integers(0, 2**63 - 1),
)
@example(rows=64, cols=64, seed=0)
@example(rows=1, cols=64, seed=1)
@example(rows=64, cols=1, seed=2)
def test_random_tilings_are_valid(name: str, rows: int, cols: int, seed: int) -> None:
    ts = get_tileset(name)
    m = scanline_index_map(ts, rows, cols, seed)
    assert m.shape == (rows, cols)
    assert m.dtype == np.int32
    assert m.min() >= 0 and m.max() < len(ts)
    assert corner_mismatches(ts.tiles, m) == []
    assert validate_index_map(ts, m) is None


@pytest.mark.parametrize("name", TILESET_NAMES)
def test_same_seed_gives_same_map(name: str) -> None:
    ts = get_tileset(name)
    a = scanline_index_map(ts, 17, 23, seed=1234)
    b = scanline_index_map(ts, 17, 23, seed=1234)
    c = scanline_index_map(ts, 17, 23, seed=np.random.default_rng(1234))
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)


@pytest.mark.parametrize("name", SETS_WITH_CHOICES)
def test_different_seeds_give_different_maps(name: str) -> None:
    ts = get_tileset(name)
    maps = [scanline_index_map(ts, 16, 16, seed=s).tobytes() for s in range(8)]
    assert len(set(maps)) == len(maps)


def test_generator_is_advanced() -> None:
    rng = np.random.default_rng(5)
    ts = get_tileset("16a")
    a = scanline_index_map(ts, 8, 8, rng)
    b = scanline_index_map(ts, 8, 8, rng)
    assert not np.array_equal(a, b)


def test_4_set_tiling_is_fixed_by_the_first_tile() -> None:
    ts = get_tileset("4")
    by_first: dict[int, np.ndarray] = {}
    for seed in range(40):
        m = scanline_index_map(ts, 9, 11, seed)
        first = int(m[0, 0])
        if first in by_first:
            np.testing.assert_array_equal(m, by_first[first])
        by_first[first] = m
        # The corner lattice is 2x2-periodic, so the tiling is too.
        np.testing.assert_array_equal(m[2:, :], m[:-2, :])
        np.testing.assert_array_equal(m[:, 2:], m[:, :-2])
    assert sorted(by_first) == [0, 1, 2, 3]


def test_8_set_rows_are_fixed_by_their_first_tile() -> None:
    ts = get_tileset("8")
    row_of: dict[int, np.ndarray] = {}
    column_values: set[int] = set()
    for seed in range(20):
        m = scanline_index_map(ts, 12, 10, seed)
        for row in m:
            first = int(row[0])
            if first in row_of:
                np.testing.assert_array_equal(row, row_of[first])
            row_of[first] = row
        column_values.update(int(v) for v in m[1:, 0])
    # The leftmost column really has a choice: all eight tiles start some row.
    assert len(column_values) == 8


def test_32_set_uses_both_variants() -> None:
    ts = get_tileset("32")
    m = scanline_index_map(ts, 32, 32, seed=0)
    variants = {ts.variant(int(k)) for k in m.ravel()}
    assert variants == {0, 1}


def test_first_tile_is_uniform_over_the_set() -> None:
    ts = get_tileset("16a")
    counts = np.bincount([scanline_index_map(ts, 1, 1, seed=s)[0, 0] for s in range(1600)], minlength=16)
    # Expected 100 each; a 6-sigma band (sigma ~ 9.7) never fails by chance.
    assert counts.min() > 40 and counts.max() < 160


def test_128x128_is_fast() -> None:
    ts = get_tileset("32")
    scanline_index_map(ts, 128, 128, seed=0)  # build the cached candidate table
    best = float("inf")
    for seed in range(3):
        start = time.perf_counter()
        scanline_index_map(ts, 128, 128, seed=seed)
        best = min(best, time.perf_counter() - start)
    assert best < 0.1


# --------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------


@pytest.mark.parametrize("argument", ["rows", "cols"])
@pytest.mark.parametrize("value", [0, -3, 2.5, True, "4"])
def test_bad_grid_size_is_rejected(argument: str, value: object) -> None:
    sizes: dict[str, object] = {"rows": 4, "cols": 4, argument: value}
    with pytest.raises(ValueError, match=argument):
        scanline_index_map(get_tileset("16a"), sizes["rows"], sizes["cols"], seed=0)


def test_numpy_integer_sizes_are_accepted() -> None:
    m = scanline_index_map(get_tileset("8"), np.int64(3), np.int32(5), seed=np.int64(2))
    assert m.shape == (3, 5)


def test_bad_seed_is_rejected() -> None:
    with pytest.raises(TypeError, match="seed"):
        scanline_index_map(get_tileset("8"), 3, 3, seed="abc")  # type: ignore[arg-type]


def test_dead_end_raises_runtime_error_naming_the_cell() -> None:
    lonely = CornerTileSet("lonely", PATCH_COLOURS, (("R", "G", "B", "Y"),))
    assert scanline_index_map(lonely, 1, 1, seed=0).tolist() == [[0]]
    with pytest.raises(RuntimeError, match=r"\(0, 1\).*\('B', 'Y'\)"):
        scanline_index_map(lonely, 1, 2, seed=0)
    with pytest.raises(RuntimeError, match=r"\(1, 0\)"):
        scanline_index_map(lonely, 2, 1, seed=0)


# --------------------------------------------------------------------------
# validate_index_map
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", TILESET_NAMES)
@settings(max_examples=20, deadline=None)
@given(data=st.data())
def test_corrupted_map_is_rejected_naming_the_position(name: str, data: st.DataObject) -> None:
    ts = get_tileset(name)
    rows = data.draw(st.integers(1, 12), label="rows")
    cols = data.draw(st.integers(1, 12), label="cols")
    if rows * cols == 1:
        cols = 2
    m = scanline_index_map(ts, rows, cols, seed=data.draw(st.integers(0, 2**32 - 1)))
    i = data.draw(st.integers(0, rows - 1), label="i")
    j = data.draw(st.integers(0, cols - 1), label="j")
    corrupted = m.copy()
    options = []
    for k in range(len(ts)):
        corrupted[i, j] = k
        if corner_mismatches(ts.tiles, corrupted):
            options.append(k)
    assert options, "some tile must break a neighbour in a grid of two or more cells"
    corrupted[i, j] = data.draw(st.sampled_from(options), label="tile")
    first_bad = min(corner_mismatches(ts.tiles, corrupted), key=lambda p: (p[1], p[0][0] != p[1][0]))
    with pytest.raises(ValueError) as info:
        validate_index_map(ts, corrupted)
    message = str(info.value)
    assert "mismatch" in message
    (a_i, a_j), (b_i, b_j) = first_bad
    assert f"({a_i}, {a_j})" in message and f"({b_i}, {b_j})" in message
    assert f"({i}, {j})" in message


def test_mismatch_message_names_keys() -> None:
    ts = get_tileset("16a")
    # <B,R,Y,G> followed by <B,R,Y,G>: right key (Y, G) != left key (B, R).
    with pytest.raises(ValueError) as info:
        validate_index_map(ts, [[0, 0]])
    message = str(info.value)
    assert "(0, 0)" in message and "(0, 1)" in message
    assert "('Y', 'G')" in message and "('B', 'R')" in message
    # Vertically: <B,R,Y,G> above <B,R,Y,G>: bottom key (R, G) != top key (B, Y).
    with pytest.raises(ValueError, match=r"\(1, 0\).*\('R', 'G'\).*\('B', 'Y'\)"):
        validate_index_map(ts, [[0], [0]])


@pytest.mark.parametrize("bad_value", [-1, 16, 1000])
def test_out_of_range_index_is_rejected(bad_value: int) -> None:
    ts = get_tileset("16a")
    m = scanline_index_map(ts, 5, 6, seed=3)
    m[3, 4] = bad_value
    with pytest.raises(ValueError, match=r"\(3, 4\).*out of range"):
        validate_index_map(ts, m)


@pytest.mark.parametrize(
    "bad_map",
    [
        np.zeros((3,), dtype=np.int32),
        np.zeros((2, 2, 2), dtype=np.int32),
        np.zeros((0, 4), dtype=np.int32),
        np.zeros((2, 2), dtype=np.float64),
        np.zeros((2, 2), dtype=bool),
    ],
)
def test_malformed_maps_are_rejected(bad_map: np.ndarray) -> None:
    with pytest.raises(ValueError):
        validate_index_map(get_tileset("4"), bad_map)


def test_valid_map_as_nested_lists_is_accepted() -> None:
    ts = get_tileset("4")
    m = scanline_index_map(ts, 4, 4, seed=0)
    assert validate_index_map(ts, m.tolist()) is None


# --------------------------------------------------------------------------
# Candidate table
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", TILESET_NAMES)
def test_candidate_table(name: str) -> None:
    ts = get_tileset(name)
    table = candidate_table(ts)
    np.testing.assert_array_equal(table[(None, None)], np.arange(len(ts)))
    for (lk, tk), cands in table.items():
        assert cands.dtype == np.int32
        assert list(cands) == sorted(cands)
        expected = [
            k
            for k in range(len(ts))
            if (lk is None or ts.left_key(k) == lk) and (tk is None or ts.top_key(k) == tk)
        ]
        assert list(cands) == expected
