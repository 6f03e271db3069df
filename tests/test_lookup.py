"""The hashed lookup (``tilesynth.layouts.hashed``, ``HASH-SPEC.md``): Rust against the plain-Python reference."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tilesynth import _core
from tilesynth.errors import ParameterError
from tilesynth.layouts.hashed import (
    HASH_NAME,
    PCG_INC,
    PCG_MUL,
    ROLE_MUL,
    LookupScheme,
    cell_index_reference,
    index_map,
    pcg3d_reference,
    ts_hash,
    ts_hash_reference,
    window_cells,
)

VECTORS = json.loads((Path(__file__).parent / "data" / "hash_vectors.json").read_text())
I32 = st.integers(-(2**31), 2**31 - 1)
SEED = st.integers(0, 2**32 - 1)
EDGES = [0, 1, -1, 2**31 - 1, -(2**31), 12345, -54321, 2**30, -(2**30) - 7]


def test_constants_are_exposed():
    assert HASH_NAME == "pcg3d"
    assert (PCG_MUL, PCG_INC, ROLE_MUL) == (1664525, 1013904223, 0x9E3779B9)
    assert VECTORS["constants"] == {"pcg_mul": PCG_MUL, "pcg_inc": PCG_INC, "role_mul": ROLE_MUL}


def test_reference_reproduces_committed_vectors():
    for v in VECTORS["pcg3d"]:
        assert list(pcg3d_reference(*v["in"])) == v["out"]
    for v in VECTORS["ts_hash"]:
        assert ts_hash_reference(v["x"], v["y"], v["seed"], v["role"]) == v["value"]
    assert len(VECTORS["ts_hash"]) >= 7 * 7 * 4 * 4


def test_reference_first_value_by_hand():
    # pcg3d(0, 0, 0): the LCG step gives c = 1013904223 in every component, then the two mixing rounds.
    m = 2**32
    c = 1013904223
    x = (c + c * c) % m
    y = (c + c * x) % m
    z = (c + x * y) % m
    x, y, z = x ^ (x >> 16), y ^ (y >> 16), z ^ (z >> 16)
    x = (x + y * z) % m
    assert ts_hash_reference(0, 0, 0, 0) == x


def test_rust_equals_vectors():
    by_key: dict[tuple[int, int], list[dict]] = {}
    for v in VECTORS["ts_hash"]:
        by_key.setdefault((v["seed"], v["role"]), []).append(v)
    for (seed, role), vs in by_key.items():
        got = ts_hash([v["x"] for v in vs], [v["y"] for v in vs], seed, role)
        assert got.dtype == np.uint32
        assert got.tolist() == [v["value"] for v in vs]


def test_cells_equal_vectors():
    for v in VECTORS["cells"]:
        scheme = LookupScheme(v["kind"], tuple(v["colours"]), v["variants"])
        m = index_map(scheme, v["seed"], (1, 1), (v["cx"], v["cy"]), v["wrap"])
        assert int(m[0, 0]) == v["index"], v


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(I32, I32), min_size=1, max_size=20), SEED, st.integers(0, 2**32 - 1))
def test_rust_equals_reference_random(points, seed, role):
    xs, ys = zip(*points)
    got = ts_hash(list(xs), list(ys), seed, role).tolist()
    assert got == [ts_hash_reference(x, y, seed, role) for x, y in points]


@pytest.mark.parametrize("seed", [0, 1, 2**31, 2**32 - 1, 0xDEADBEEF])
def test_rust_equals_reference_edges(seed):
    xs, ys = np.meshgrid(EDGES, EDGES)
    for role in range(4):
        got = ts_hash(xs, ys, seed, role)
        assert got.shape == xs.shape
        want = [
            [ts_hash_reference(int(x), int(y), seed, role) for x, y in zip(rx, ry)] for rx, ry in zip(xs, ys)
        ]
        assert got.tolist() == want


SCHEMES = [
    LookupScheme("corner", (2,)),
    LookupScheme("corner", (3,), 2),
    LookupScheme("edge", (2, 3), 2),
    LookupScheme("edge", (2, 2)),
]


@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: f"{s.kind}{s.colours}x{s.variants}")
@pytest.mark.parametrize("origin", [(0, 0), (-7, 3), (2**31 - 3, -(2**31)), (-(2**31), 2**31 - 2)])
def test_index_map_equals_reference(scheme, origin):
    m = index_map(scheme, 0xDEADBEEF, (5, 4), origin)
    assert m.shape == (4, 5) and m.dtype == np.int32
    for i in range(4):
        for j in range(5):
            assert m[i, j] == cell_index_reference(scheme, 0xDEADBEEF, origin[0] + j, origin[1] + i)


@pytest.mark.parametrize("scheme", SCHEMES, ids=lambda s: f"{s.kind}{s.colours}x{s.variants}")
def test_index_map_wrap_equals_reference_and_is_periodic(scheme):
    m = index_map(scheme, 11, (9, 8), (-4, -5), wrap=(3, 4))
    for i in range(8):
        for j in range(9):
            assert m[i, j] == cell_index_reference(scheme, 11, -4 + j, -5 + i, (3, 4))
    np.testing.assert_array_equal(m[:, :3], m[:, 3:6])
    np.testing.assert_array_equal(m[:4], m[4:])


def test_index_map_windows_are_crops():
    s = LookupScheme("corner", (3,), 2)
    big = index_map(s, 5, (40, 30), (-20, -15))
    small = index_map(s, 5, (7, 3), (-2, 1))
    np.testing.assert_array_equal(small, big[16:19, 18:25])


def test_corner_neighbours_share_vertices():
    s = LookupScheme("corner", (4,), 3)
    m = index_map(s, 99, (12, 10), (-6, -5))
    t = [[s.tuple_of(int(v))[0] for v in row] for row in m]
    for i in range(10):
        for j in range(11):
            assert t[i][j][2:] == t[i][j + 1][:2]  # (TR, BR) == right neighbour's (TL, BL)
    for i in range(9):
        for j in range(12):
            assert (t[i][j][1], t[i][j][3]) == (t[i + 1][j][0], t[i + 1][j][2])


def test_edge_neighbours_share_edges():
    s = LookupScheme("edge", (3, 2), 2)
    m = index_map(s, 7, (10, 10), (-3, -3))
    t = [[s.tuple_of(int(v))[0] for v in row] for row in m]  # (N, E, S, W)
    for i in range(10):
        for j in range(9):
            assert t[i][j][1] == t[i][j + 1][3]
    for i in range(9):
        for j in range(10):
            assert t[i][j][2] == t[i + 1][j][0]


def test_all_tuples_and_variants_occur():
    s = LookupScheme("corner", (2,), 2)
    m = index_map(s, 3, (64, 64))
    assert set(np.unique(m).tolist()) == set(range(s.n_tiles))


def test_scheme_index_roundtrip():
    for s in SCHEMES:
        assert sorted(s.index(*s.tuple_of(i)) for i in range(s.n_tiles)) == list(range(s.n_tiles))


@pytest.mark.parametrize("seed", [-1, 2**32, 2**64, 1.5, "3", True])
def test_bad_seed_is_parameter_error(seed):
    with pytest.raises(ParameterError, match="seed"):
        ts_hash([0], [0], seed, 0)
    with pytest.raises(ParameterError, match="seed"):
        index_map(SCHEMES[0], seed, (2, 2))


def test_core_rejects_bad_seed_too():
    with pytest.raises(ParameterError, match="seed"):
        _core.hashed_index_map("corner", [2], 1, 2**32, (0, 0), (1, 1))
    with pytest.raises(TypeError, match="seed"):
        _core.hashed_index_map("corner", [2], 1, 1.0, (0, 0), (1, 1))


def test_bad_parameters():
    with pytest.raises(ParameterError, match="colours"):
        LookupScheme("corner", (0,))
    with pytest.raises(ParameterError, match="colours"):
        LookupScheme("edge", (2,))
    with pytest.raises(ParameterError, match="int32"):
        LookupScheme("corner", (216,))
    with pytest.raises(ParameterError, match="kind"):
        LookupScheme("hex", (2,))
    with pytest.raises(ParameterError, match="wrap"):
        index_map(SCHEMES[0], 0, (2, 2), wrap=(0, 2))
    with pytest.raises(ParameterError, match="origin"):
        index_map(SCHEMES[0], 0, (2, 2), origin=(2**31, 0))
    with pytest.raises(ParameterError, match="x"):
        ts_hash([2**31], [0], 0, 0)
    with pytest.raises(ParameterError, match="role"):
        ts_hash([0], [0], 0, -1)


def test_window_cells_floor_division():
    assert window_cells((0, 0), 10, 10, 4) == (0, 0, 3, 3, 0, 0)
    assert window_cells((-1, -4), 2, 5, 4) == (-1, -1, 2, 2, 3, 0)
    assert window_cells((-1, -5), 2, 6, 4) == (-1, -2, 2, 3, 3, 3)
    assert window_cells((5, 7), 3, 1, 4) == (1, 1, 1, 1, 1, 3)


def test_huge_map_is_refused_not_aborted():
    with pytest.raises(ParameterError, match="cells"):
        index_map(SCHEMES[0], 0, (2**30, 12))
    with pytest.raises(ParameterError, match="cells"):
        _core.hashed_index_map("corner", [2], 1, 0, (0, 0), (2**30, 12))
