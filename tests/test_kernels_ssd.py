"""Exhaustive SSD kernel against a float64 brute-force oracle."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tilesynth
from tilesynth import _core


def ssd_oracle(image: np.ndarray, template: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
    I = image.astype(np.float64)
    T = template.astype(np.float64)
    h, w = T.shape[:2]
    m = np.ones((h, w)) if mask is None else mask.astype(np.float64)
    out = np.empty((I.shape[0] - h + 1, I.shape[1] - w + 1))
    for y in range(out.shape[0]):
        for x in range(out.shape[1]):
            out[y, x] = (m[:, :, None] * (T - I[y : y + h, x : x + w]) ** 2).sum()
    return out


@st.composite
def ssd_case(draw):
    H = draw(st.integers(1, 20))
    W = draw(st.integers(1, 20))
    C = draw(st.sampled_from([1, 3, 4]))
    h = draw(st.integers(1, H))
    w = draw(st.integers(1, W))
    seed = draw(st.integers(0, 2**32 - 1))
    use_mask = draw(st.booleans())
    r = np.random.default_rng(seed)
    image = r.random((H, W, C), dtype=np.float32)
    template = r.random((h, w, C), dtype=np.float32)
    mask = (r.random((h, w)) < 0.7) if use_mask else None
    return image, template, mask


@given(ssd_case())
def test_ssd_map_matches_oracle(case):
    image, template, mask = case
    got = tilesynth.patch_ssd(image, template, mask=mask)
    ref = ssd_oracle(image, template, mask)
    assert got.shape == ref.shape and got.dtype == np.float32
    scale = max(ref.max(), 1e-12)
    assert np.abs(got - ref).max() <= 1e-4 * scale


@given(ssd_case())
def test_best_match_is_exact(case):
    image, template, mask = case
    ref = ssd_oracle(image, template, mask)
    offsets, values = tilesynth.best_matches(image, template, k=1, mask=mask)
    assert offsets.shape == (1, 2) and values.shape == (1,)
    assert values[0] == pytest.approx(ref.min(), rel=1e-9, abs=1e-9)
    # exact re-ranking: the returned translation has the exact minimum (ties -> smallest (row, col))
    best = np.argwhere(np.isclose(ref, ref.min(), rtol=1e-12, atol=1e-12))[0]
    assert ref[tuple(offsets[0])] == pytest.approx(ref.min(), rel=1e-9, abs=1e-9)
    assert tuple(offsets[0]) == tuple(best)


def test_realistic_sizes_and_k_best(lettuce):
    image = lettuce[:128, :128]
    r = np.random.default_rng(3)
    templates = np.stack([lettuce[y : y + 80, x : x + 80] for y, x in r.integers(0, 200, (3, 2))])
    templates = templates + r.normal(0, 0.02, templates.shape).astype(np.float32)
    templates = np.clip(templates, 0, 1).astype(np.float32)
    maps = tilesynth.patch_ssd(image, templates)
    assert maps.shape == (3, 49, 49)
    offsets, values = tilesynth.best_matches(image, templates, k=3, exclude_radius=5)
    for t in range(3):
        ref = ssd_oracle(image, templates[t])
        assert np.abs(maps[t] - ref).max() <= 1e-4 * ref.max()
        order = np.argsort(ref, axis=None, kind="stable")
        assert tuple(offsets[t, 0]) == tuple(np.unravel_index(order[0], ref.shape))
        assert values[t, 0] == pytest.approx(ref.min(), rel=1e-9)
        # greedy exclusion: later matches are > 5 px (Chebyshev) from earlier ones and sorted
        assert np.all(np.diff(values[t]) >= 0)
        for a in range(3):
            for b in range(a):
                assert np.abs(offsets[t, a] - offsets[t, b]).max() > 5
            assert values[t, a] == pytest.approx(ref[tuple(offsets[t, a])], rel=1e-9)


def test_exact_copy_is_found_with_zero_cost(lettuce):
    image = lettuce[:150, :140]
    template = image[37 : 37 + 64, 51 : 51 + 64]
    offsets, values = tilesynth.best_matches(image, template)
    assert tuple(offsets[0]) == (37, 51)
    assert values[0] == 0.0


def test_uint8_input_is_scaled():
    r = np.random.default_rng(0)
    img8 = r.integers(0, 256, (20, 20, 3), dtype=np.uint8)
    t8 = img8[3:9, 4:12]
    m1 = tilesynth.patch_ssd(img8, t8)
    m2 = tilesynth.patch_ssd(img8.astype(np.float32) / 255, t8.astype(np.float32) / 255)
    np.testing.assert_allclose(m1, m2, atol=1e-5)


def test_thread_count_does_not_change_bits(lettuce):
    image = lettuce[:200, :200]
    templates = np.stack([lettuce[y : y + 64, y : y + 64] for y in (5, 90, 170)])
    a = tilesynth.patch_ssd(image, templates, threads=1)
    b = tilesynth.patch_ssd(image, templates, threads=2)
    assert a.tobytes() == b.tobytes()


@pytest.mark.parametrize(
    ("image", "template", "exc", "words"),
    [
        (
            np.zeros((10, 10, 3), np.float32),
            np.zeros((11, 4, 3), np.float32),
            tilesynth.ShapeError,
            "template",
        ),
        (
            np.zeros((10, 10, 3), np.float32),
            np.zeros((4, 4, 1), np.float32),
            tilesynth.ShapeError,
            "template",
        ),
        (np.zeros((0, 10, 3), np.float32), np.zeros((1, 1, 3), np.float32), tilesynth.ShapeError, "image"),
        (
            np.full((10, 10, 3), 2.0, np.float32),
            np.zeros((4, 4, 3), np.float32),
            tilesynth.ParameterError,
            "image",
        ),
        (np.zeros((10, 10, 3), np.complex64), np.zeros((4, 4, 3), np.float32), TypeError, "dtype"),
    ],
)
def test_errors_name_the_problem(image, template, exc, words):
    with pytest.raises(exc, match=words):
        tilesynth.patch_ssd(image, template)


def test_errors_are_value_errors_and_nan_rejected():
    t = np.zeros((4, 4, 3), np.float32)
    t[1, 1, 1] = np.nan
    with pytest.raises(ValueError, match="template"):
        tilesynth.patch_ssd(np.zeros((10, 10, 3), np.float32), t)
    with pytest.raises(tilesynth.ShapeError, match="mask"):
        tilesynth.patch_ssd(
            np.zeros((10, 10, 3), np.float32), np.zeros((4, 4, 3), np.float32), mask=np.ones((3, 4), bool)
        )


def test_core_rejects_non_contiguous_arrays():
    image = np.zeros((20, 20, 3), np.float32)[:, ::2]
    with pytest.raises(TypeError, match="contiguous"):
        _core.SsdIndex(image)
    with pytest.raises(TypeError, match="contiguous"):
        _core.SsdIndex(np.zeros((20, 20, 3), np.float32)).ssd_maps(np.zeros((2, 4, 4, 3), np.float32)[:, ::2])


def test_index_reuse_equals_one_shot(lettuce):
    image = lettuce[:160, :170]
    index = tilesynth.SsdIndex(image)
    assert index.shape == (160, 170, 3)
    t1 = lettuce[200:264, 10:74]
    t2 = np.stack([lettuce[5:37, 300:332], lettuce[100:132, 100:132]])
    np.testing.assert_array_equal(index.ssd(t1), tilesynth.patch_ssd(image, t1))
    np.testing.assert_array_equal(index.ssd(t2), tilesynth.patch_ssd(image, t2))
    o1, v1 = index.best_matches(t2, k=2, exclude_radius=3)
    o2, v2 = tilesynth.best_matches(image, t2, k=2, exclude_radius=3)
    np.testing.assert_array_equal(o1, o2)
    np.testing.assert_array_equal(v1, v2)
    with pytest.raises(tilesynth.ShapeError, match="template"):
        index.ssd(np.zeros((8, 8, 1), np.float32))


def greedy_oracle(ref: np.ndarray, k: int, r: int) -> tuple[np.ndarray, np.ndarray]:
    """The exact greedy definition: translations by (SSD, row, col), each taken if it lies more than ``r``
    (Chebyshev) from every one taken before, until ``k``."""
    order = np.lexsort((np.arange(ref.size), ref.ravel()))
    taken: list[tuple[int, int]] = []
    for i in order:
        y, x = divmod(int(i), ref.shape[1])
        if all(max(abs(y - a), abs(x - b)) > r for a, b in taken):
            taken.append((y, x))
            if len(taken) == k:
                break
    off = np.array(taken, np.int64).reshape(-1, 2)
    return off, ref[off[:, 0], off[:, 1]]


def _matching_cases():
    r = np.random.default_rng(15)
    image = r.random((40, 37, 3), dtype=np.float32)
    yield "random", image, r.random((3, 9, 8, 3), dtype=np.float32), False
    # quantised values (multiples of 1/2): every SSD is exact in any summation order, many exact ties
    q = (r.integers(0, 3, (45, 41, 3)) * 0.5).astype(np.float32)
    yield "quantised", q, (r.integers(0, 3, (3, 4, 4, 3)) * 0.5).astype(np.float32), True
    flat = np.full((30, 28, 3), 0.5, np.float32)
    yield "flat", flat, np.full((2, 5, 4, 3), 0.25, np.float32), True
    per = np.fromfunction(lambda y, x, c: ((y % 4) * 8 + (x % 6) * 4 + c) / 64.0, (48, 50, 3)).astype(
        np.float32
    )
    yield "periodic", per, np.stack([per[5:13, 7:16], per[2:10, 1:10]]), True
    # large enough for the parallel stages inside one call (>= 100 x 100 pixels, two threads)
    big = r.random((130, 120, 3), dtype=np.float32)
    yield (
        "large",
        big,
        np.stack([big[10:74, 30:70] * 0.9 + 0.05, r.random((64, 40, 3), dtype=np.float32)]),
        False,
    )


@pytest.mark.parametrize(
    "name,image,templates,exact_sums", list(_matching_cases()), ids=lambda v: v if isinstance(v, str) else ""
)
@pytest.mark.parametrize("k,radius", [(1, 0), (4, 0), (5, 2), (16, 3)])
@pytest.mark.parametrize("masked", [False, True])
def test_best_matches_equal_sorting_path_and_greedy_oracle(
    name, image, templates, exact_sums, k, radius, masked
):
    """The matching stage (its own map, the lazy scan) returns what the first implementation (every
    translation sorted by the map of ``ssd_map_f64``) returns, bit for bit, and what the exact greedy
    definition over brute-force sums gives: ties go to the smaller (row, col)."""
    h, w = templates.shape[1:3]
    mask = (np.random.default_rng(h * w).random((h, w)) < 0.7) if masked else None
    index = _core.SsdIndex(image)
    for threads in (1, 2):
        off, val = index.best_matches(templates, k, radius, mask, threads)
        off_s, val_s = _core._best_matches_sorting(index, templates, k, radius, mask, threads)
        np.testing.assert_array_equal(off, off_s)
        np.testing.assert_array_equal(val.view(np.int64), val_s.view(np.int64))
    for t in range(templates.shape[0]):
        ref = ssd_oracle(image, templates[t], mask)
        want_off, want_val = greedy_oracle(ref, k, radius)
        got = off[t, : len(want_off)]
        if exact_sums:
            np.testing.assert_array_equal(got, want_off)
            np.testing.assert_array_equal(val[t, : len(want_val)], want_val)
        else:
            np.testing.assert_array_equal(got, want_off)
            np.testing.assert_allclose(val[t, : len(want_val)], want_val, rtol=1e-9, atol=1e-9)
