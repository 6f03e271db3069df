"""Poisson smoothing (guided interpolation): scipy sparse direct solution as the oracle, on random small regions
and on real ω regions; pixels outside the region untouched bit for bit; inputs never modified."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp  # the oracle: a test dependency (pyproject [test]), never skipped
import scipy.sparse.linalg as spla
from hypothesis import given
from hypothesis import strategies as st

import tilesynth
from tilesynth import PoissonInfo, poisson_smooth

DIRS = ((0, 1), (0, -1), (1, 0), (-1, 0))


def scipy_system(dst: np.ndarray, src: np.ndarray, region: np.ndarray):
    """The discrete Poisson system of the region, assembled independently of the kernel: ``(A, b, ys, xs)``.

    For p in Ω: Σ_{q ∈ N(p)} (f_p − f_q) = Σ_{q ∈ N(p)} (src_p − src_q), f_q = dst_q for q ∉ Ω, N(p) the
    4-neighbours inside the image.
    """
    n, m, c = dst.shape
    s, d = src.astype(np.float64), dst.astype(np.float64)
    ys, xs = np.nonzero(region)
    k = len(ys)
    index = -np.ones((n, m), np.int64)
    index[ys, xs] = np.arange(k)
    deg = np.zeros(k)
    b = np.zeros((k, c))
    rows, cols = [], []
    for dy, dx in DIRS:
        qy, qx = ys + dy, xs + dx
        ok = (qy >= 0) & (qy < n) & (qx >= 0) & (qx < m)
        p, qy, qx = np.nonzero(ok)[0], qy[ok], qx[ok]
        deg[p] += 1
        b[p] += s[ys[p], xs[p]] - s[qy, qx]
        qi = index[qy, qx]
        inner = qi >= 0
        rows.append(p[inner])
        cols.append(qi[inner])
        b[p[~inner]] += d[qy[~inner], qx[~inner]]
    rows.append(np.arange(k))
    cols.append(np.arange(k))
    vals = np.concatenate([-np.ones(len(r)) for r in rows[:-1]] + [deg])
    a = sp.csc_matrix((vals, (np.concatenate(rows), np.concatenate(cols))), shape=(k, k))
    return a, b, ys, xs


def scipy_solution(dst: np.ndarray, src: np.ndarray, region: np.ndarray) -> np.ndarray:
    """dst outside the region, the spsolve solution (float64) inside."""
    a, b, ys, xs = scipy_system(dst, src, region)
    out = dst.astype(np.float64).copy()
    if len(ys):
        x = spla.spsolve(a, b)
        out[ys, xs] = x.reshape(len(ys), -1)
    return out


def rel_residual(dst, src, region, out) -> np.ndarray:
    """‖b − A f‖ / ‖b‖ per channel for the (float32) result ``out``."""
    a, b, ys, xs = scipy_system(dst, src, region)
    f = out[ys, xs].astype(np.float64)
    return np.linalg.norm(b - a @ f, axis=0) / np.linalg.norm(b, axis=0)


def disc(n: int, r: float) -> np.ndarray:
    c = (n - 1) / 2
    yy, xx = np.mgrid[:n, :n]
    return (yy - c) ** 2 + (xx - c) ** 2 <= r * r


@st.composite
def small_case(draw):
    n = draw(st.integers(1, 12))
    m = draw(st.integers(1, 12))
    c = draw(st.integers(1, 4))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    density = draw(st.sampled_from([0.2, 0.5, 0.8, 0.95]))
    region = rng.random((n, m)) < density
    if region.all():
        region[rng.integers(n), rng.integers(m)] = False
    # values well outside [0, 1] are allowed: the kernel is linear and takes any finite float
    scale = draw(st.sampled_from([1.0, 1.0, 100.0]))
    dst = (rng.random((n, m, c)) * scale).astype(np.float32)
    src = (rng.random((n, m, c)) * scale).astype(np.float32)
    return dst, src, region


@given(small_case())
def test_matches_scipy_on_random_small_regions(case):
    dst, src, region = case
    out, info = poisson_smooth(dst, src, region, threads=1, tol=1e-10, info=True)
    ref = scipy_solution(dst, src, region)
    scale = max(1.0, float(np.abs(ref).max()))
    np.testing.assert_allclose(out, ref, rtol=0, atol=2e-6 * scale)
    assert out.dtype == np.float32 and out.shape == dst.shape
    # outside the region: dst, bit for bit
    assert np.array_equal(out[~region].view(np.uint32), dst[~region].view(np.uint32))
    assert info.unknowns == int(region.sum())
    assert info.residual.shape == (dst.shape[2],)
    assert (info.residual <= 1e-10).all()


@given(small_case())
def test_reported_residual_holds_at_default_tol(case):
    dst, src, region = case
    out, info = poisson_smooth(dst, src, region, info=True)
    assert (info.residual <= 1e-6).all()
    if region.any():
        # the float32 output: the f64 solution's residual plus rounding
        assert (rel_residual(dst, src, region, out) <= 1e-6 + 1e-5).all()


def test_disc_region_at_tile_sizes_against_scipy():
    rng = np.random.default_rng(3)
    for n in (32, 80):
        dst = rng.random((n, n, 3), dtype=np.float32)
        src = rng.random((n, n, 3), dtype=np.float32)
        region = disc(n, n / 2 - 2)
        out, info = poisson_smooth(dst, src, region, threads=2, info=True)
        ref = scipy_solution(dst, src, region)
        # tol 1e-6 on the residual; the error in f is at most cond(A) times that, in practice ~1e-6
        np.testing.assert_allclose(out, ref, rtol=0, atol=2e-5)
        assert 1 <= info.iterations <= 20
        assert (info.residual <= 1e-6).all()
        assert (rel_residual(dst, src, region, out) <= 2e-6).all()


@pytest.fixture(scope="module")
def omega_masks(small_exemplar):
    return tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=1, threads=2).cut_masks


def test_real_omega_regions_against_scipy(omega_masks, small_exemplar):
    ex = small_exemplar
    k, n, _ = omega_masks.shape
    dst = np.stack([ex[(3 * t) % 60 : (3 * t) % 60 + n, t : t + n] for t in range(k)])
    src = np.stack([ex[40 + t : 40 + t + n, 60 - t : 60 - t + n] for t in range(k)])
    out, info = poisson_smooth(dst, src, omega_masks, tol=1e-9, info=True)
    assert out.shape == dst.shape and info.iterations.shape == (k,) and info.residual.shape == (k, 3)
    for t in range(k):
        ref = scipy_solution(dst[t], src[t], omega_masks[t])
        np.testing.assert_allclose(out[t], ref, rtol=0, atol=2e-6)
    assert (info.residual <= 1e-9).all()
    np.testing.assert_array_equal(info.unknowns, omega_masks.sum(axis=(1, 2)))
    # the ω regions never touch the border ring, so the tile border is the intermediate tile's
    assert np.array_equal(out[:, [0, -1]], dst[:, [0, -1]])
    assert np.array_equal(out[:, :, [0, -1]], dst[:, :, [0, -1]])
    assert np.array_equal(out[~omega_masks], dst[~omega_masks])
    # smoothing removes the seam: the jump across the curve is smaller than with the plain composition
    composed = np.where(omega_masks[..., None], src, dst)
    jump = lambda img: np.abs(np.diff(img, axis=2))[(omega_masks[:, :, 1:] != omega_masks[:, :, :-1])].mean()
    assert jump(out) < jump(composed)


def test_stack_equals_single_tiles_and_threads_do_not_matter(omega_masks, small_exemplar):
    ex = small_exemplar
    k, n, _ = omega_masks.shape
    dst = np.stack([ex[t : t + n, 2 * t : 2 * t + n] for t in range(k)])
    src = np.stack([ex[50 - t : 50 - t + n, 30 + t : 30 + t + n] for t in range(k)])
    one, i1 = poisson_smooth(dst, src, omega_masks, threads=1, info=True)
    two, i2 = poisson_smooth(dst, src, omega_masks, threads=2, info=True)
    assert np.array_equal(one.view(np.uint32), two.view(np.uint32))
    np.testing.assert_array_equal(i1.iterations, i2.iterations)
    np.testing.assert_array_equal(i1.residual, i2.residual)
    for t in (0, 7, k - 1):
        single, info = poisson_smooth(dst[t], src[t], omega_masks[t], threads=2, info=True)
        assert np.array_equal(single, one[t])
        assert isinstance(info, PoissonInfo) and info.iterations == i1.iterations[t]
        np.testing.assert_array_equal(info.residual, i1.residual[t])


def test_inputs_are_never_modified():
    rng = np.random.default_rng(9)
    n = 40
    base_dst = rng.random((n, n, 3), dtype=np.float32)
    base_src = rng.random((n, n, 3), dtype=np.float32)
    region = disc(n, 15)
    cases = [
        (base_dst, base_src, region),  # float32 C-contiguous: passed through without a copy
        (base_dst.astype(np.float64), base_src.astype(np.float64), region),
        (np.asfortranarray(base_dst), base_src[:, ::-1].copy()[:, ::-1], region.astype(np.uint8)),
        (base_dst[None], base_src[None], region[None]),
    ]
    for dst, src, reg in cases:
        keep = [a.copy() for a in (dst, src, reg)]
        flags = [a.flags.writeable for a in (dst, src, reg)]
        out = poisson_smooth(dst, src, reg)
        for a, b, w in zip((dst, src, reg), keep, flags):
            assert a.dtype == b.dtype and np.array_equal(a, b) and a.flags.writeable == w
        assert out is not dst and not np.shares_memory(out, dst) and not np.shares_memory(out, src)
    # read-only inputs are fine
    ro = [a.copy() for a in (base_dst, base_src, region)]
    for a in ro:
        a.setflags(write=False)
    poisson_smooth(*ro)


def test_trivial_regions_and_special_channels():
    rng = np.random.default_rng(1)
    dst = rng.random((9, 11, 2), dtype=np.float32)
    src = rng.random((9, 11, 2), dtype=np.float32)
    out, info = poisson_smooth(dst, src, np.zeros((9, 11), bool), info=True)
    assert np.array_equal(out, dst) and info.iterations == 0 and info.unknowns == 0
    # no Dirichlet pixel: f = src (the solution with the mean of src)
    out, info = poisson_smooth(dst, src, np.ones((9, 11), bool), info=True)
    assert np.array_equal(out, src) and info.iterations == 0 and info.unknowns == 99
    # src == dst: the solution is src itself
    region = disc(11, 4)[:9]
    out = poisson_smooth(dst, dst, region)
    np.testing.assert_allclose(out, dst, atol=1e-6)
    # constant src, zero boundary: b = 0, the exact solution is 0
    out, info = poisson_smooth(np.zeros_like(dst), np.full_like(src, 0.3), region, info=True)
    assert (out == 0).all() and (info.residual == 0).all()
    # uint8 inputs are scaled like images
    d8, s8 = (dst * 255).round().astype(np.uint8), (src * 255).round().astype(np.uint8)
    np.testing.assert_allclose(
        poisson_smooth(d8, s8, region), poisson_smooth(d8 / 255.0, s8 / 255.0, region), atol=1e-6
    )


def test_region_touching_the_image_border_is_neumann():
    # A region that covers the left half of the image: the image border is a zero-normal-derivative boundary
    # for f − src, so with dst = src + 0.5 on the right the solution is src + 0.5 everywhere in the region.
    rng = np.random.default_rng(5)
    src = rng.random((12, 10, 1), dtype=np.float32)
    dst = src + np.float32(0.5)
    region = np.zeros((12, 10), bool)
    region[:, :5] = True
    out = poisson_smooth(dst, src, region, tol=1e-10)
    np.testing.assert_allclose(out, dst, atol=1e-6)
    np.testing.assert_allclose(out, scipy_solution(dst, src, region), atol=1e-6)


def test_overshoot_is_not_clipped():
    n = 24
    src = np.zeros((n, n, 1), np.float32)
    src[n // 2 - 2 : n // 2 + 2, n // 2 - 2 : n // 2 + 2] = 1.0  # a bright square inside the region
    dst = np.full((n, n, 1), 0.9, np.float32)
    out = poisson_smooth(dst, src, disc(n, 8), tol=1e-9)
    assert out.max() > 1.0
    np.testing.assert_allclose(out, scipy_solution(dst, src, disc(n, 8)), atol=2e-6)


def test_errors_name_the_parameter():
    a = np.zeros((6, 6, 3), np.float32)
    r = disc(6, 2)
    with pytest.raises(tilesynth.ShapeError, match="^src has shape"):
        poisson_smooth(a, a[:, :5], r)
    with pytest.raises(tilesynth.ShapeError, match="^dst has shape"):
        poisson_smooth(a, a, r[:5])
    with pytest.raises(tilesynth.ShapeError, match="^region has shape"):
        poisson_smooth(a, a, np.zeros(6, bool))
    with pytest.raises(tilesynth.ShapeError, match="^dst has shape"):
        poisson_smooth(a[None], a[None], r)
    with pytest.raises(TypeError, match="region has dtype"):
        poisson_smooth(a, a, r.astype(float))
    with pytest.raises(TypeError, match="dst has dtype"):
        poisson_smooth(a.astype(np.complex64), a, r)
    for bad in (0.0, 1.0, -1e-3, 1e-13, float("nan")):
        with pytest.raises(tilesynth.ParameterError, match="^tol = "):
            poisson_smooth(a, a, r, tol=bad)
    with pytest.raises(tilesynth.ParameterError, match="^tol = "):
        poisson_smooth(a, a, r, tol="small")
    nan = a.copy()
    nan[2, 2, 1] = np.nan
    with pytest.raises(tilesynth.ParameterError, match="^dst = non-finite"):
        poisson_smooth(nan, a, r)
    with pytest.raises(tilesynth.ParameterError, match="^src = non-finite"):
        poisson_smooth(a, np.where(np.isnan(nan), np.inf, a).astype(np.float32), r)
    with pytest.raises(tilesynth.ParameterError, match="threads"):
        poisson_smooth(a, a, r, threads=0)
