"""Quality metrics: each against a slow obvious oracle on small cases, and on constructed cases with known values."""

from __future__ import annotations

import math
import types

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.errors import ParameterError, ShapeError
from tilesynth.measure import metrics as M
from tilesynth.measure import metrics_coherence


@pytest.fixture(scope="module")
def omega16(small_exemplar):
    # one random draw (border_tries=1): a valid tiling of typical sample patches, whose border score is about 1;
    # the default border-aware draw (issue 14) aims the borders at 0.8 on purpose
    return ts.build_omega(
        small_exemplar, tileset="16a", tile_size=24, seed=3, select="random", border_tries=1
    )


@pytest.fixture(scope="module")
def omega_n2(small_exemplar):
    # one random draw (border_tries=1): a valid tiling of typical sample patches, whose border score is about 1;
    # the default border-aware draw (issue 14) aims the borders at 0.8 on purpose
    return ts.build_omega(small_exemplar, tileset="n2", tile_size=24, seed=3, select="random", border_tries=1)


# ------------------------------------------------------------------------------------------------ seam score
def seam_oracle(img: np.ndarray, n: int) -> dict:
    """Loop over every neighbour pair, sort it into border / interior by the tile it falls in."""
    h, w, _ = img.shape
    x = img.astype(np.float64)
    sums = {k: [0.0, 0] for k in ("bx", "ix", "by", "iy")}
    for y in range(h):
        for c in range(w - 1):
            d2 = float(((x[y, c + 1] - x[y, c]) ** 2).sum())
            key = "bx" if c // n != (c + 1) // n else "ix"
            sums[key][0] += d2
            sums[key][1] += 1
    for y in range(h - 1):
        for c in range(w):
            d2 = float(((x[y + 1, c] - x[y, c]) ** 2).sum())
            key = "by" if y // n != (y + 1) // n else "iy"
            sums[key][0] += d2
            sums[key][1] += 1
    mean = {k: (s / m if m else None) for k, (s, m) in sums.items()}
    num = sum(mean[k] for k in ("bx", "by") if mean[k] is not None)
    den = sum(mean["i" + k[1]] for k in ("bx", "by") if mean[k] is not None)
    return {"score": num / den, **mean}


@pytest.mark.parametrize("shape,n", [((17, 13, 3), 5), ((12, 30, 1), 4), ((9, 20, 2), 9), ((25, 8, 3), 6)])
def test_seam_score_matches_oracle(rng, shape, n):
    img = rng.random(shape, dtype=np.float32)
    got = M.seam_score(img, n)
    want = seam_oracle(img, n)
    assert got.score == pytest.approx(want["score"], rel=1e-12)
    for axis in ("x", "y"):
        if want["b" + axis] is None:  # no border across this direction: the direction is left out entirely
            assert getattr(got, f"border_{axis}") is None and getattr(got, f"interior_{axis}") is None
            continue
        assert getattr(got, f"border_{axis}") == pytest.approx(want["b" + axis], rel=1e-12)
        assert getattr(got, f"interior_{axis}") == pytest.approx(want["i" + axis], rel=1e-12)
    assert got.border_pairs + got.interior_pairs <= shape[0] * (shape[1] - 1) + (shape[0] - 1) * shape[1]


def test_seam_score_constructed_values():
    # a ramp continuing across every tile: all steps equal, S = 1 exactly
    yy, xx = np.mgrid[0:40, 0:40]
    ramp = ((xx + 2 * yy) / 120.0).astype(np.float32)
    assert M.seam_score(ramp, 8).score == pytest.approx(1.0, rel=1e-6)
    # a ramp restarting in every tile along x: interior step a, border step -(N-1)a, no step along y
    n, a = 8, 0.01
    saw = np.tile((a * (np.arange(40) % n))[None, :], (24, 1)).astype(np.float32)
    s = M.seam_score(saw, n)
    assert s.ratio_y is None or math.isnan(s.ratio_y) or s.border_y == 0.0
    assert s.score == pytest.approx((n - 1) ** 2, rel=1e-5)
    assert s.ratio_x == pytest.approx((n - 1) ** 2, rel=1e-5)


def test_seam_score_valid_tiling_about_one_random_placement_clearly_above(omega16, omega_n2):
    for tset in (omega16, omega_n2):
        n = tset.tile_size
        for seed in (1, 2):
            img, imap = ts.synthesize(tset, 192, 192, seed=seed)
            valid = M.seam_score(img, n).score
            r = np.random.default_rng(seed).integers(0, tset.n_tiles, imap.shape).astype(np.int32)
            unmatched = ts.tile_copy(tset.tiles, r, np.empty_like(img))
            bad = M.seam_score(unmatched, n).score
            assert 0.6 < valid < 1.5, (tset.params["set"], seed, valid)
            assert bad > 5.0 and bad > 4 * valid, (tset.params["set"], seed, bad, valid)


def test_seam_score_errors(rng):
    img = rng.random((10, 10, 3), dtype=np.float32)
    with pytest.raises(ShapeError, match="tile_size = 10"):
        M.seam_score(img, 10)
    with pytest.raises(ParameterError, match="tile_size = 1"):
        M.seam_score(img, 1)
    v, hz = M.seam_profiles(img, 4)
    assert v.shape == (10, 2) and hz.shape == (2, 10)
    s = M.seam_score(img, 4)
    assert v.mean() == pytest.approx(s.ratio_x) and hz.mean() == pytest.approx(s.ratio_y)


# ------------------------------------------------------------------------------------------ coherence energy
def coherence_oracle(img: np.ndarray, ex: np.ndarray, p: int, s: int) -> np.ndarray:
    x, e = img.astype(np.float64), ex.astype(np.float64)
    rows, cols = (img.shape[0] - p) // s + 1, (img.shape[1] - p) // s + 1
    out = np.empty((rows, cols))
    for i in range(rows):
        for j in range(cols):
            t = x[i * s : i * s + p, j * s : j * s + p]
            best = math.inf
            for r in range(ex.shape[0] - p + 1):
                for c in range(ex.shape[1] - p + 1):
                    best = min(best, float(((t - e[r : r + p, c : c + p]) ** 2).sum()))
            out[i, j] = best
    return out


def check_against_oracle(img, ex, p, s):
    got = M.coherence_energy(img, ex, patch=p, stride=s)
    want = coherence_oracle(img, ex, p, s)
    np.testing.assert_allclose(got.values, want, rtol=1e-9, atol=1e-12)
    assert got.energy == pytest.approx(want.mean(), rel=1e-9, abs=1e-15)
    assert got.rms == pytest.approx(math.sqrt(want.mean() / (p * p * img.shape[2])), rel=1e-9, abs=1e-12)
    # the reported offsets reach the reported minima
    for (i, j), v in np.ndenumerate(got.values):
        r, c = got.offsets[i, j]
        t = img[i * s : i * s + p, j * s : j * s + p].astype(np.float64)
        assert float(((t - ex[r : r + p, c : c + p]) ** 2).sum()) == pytest.approx(v, rel=1e-9, abs=1e-12)
    assert got.exact_copies + got.searched == got.n_patches == want.size
    return got


def test_coherence_matches_brute_force_on_noise(rng):
    ex = rng.random((14, 13, 3), dtype=np.float32)
    img = rng.random((17, 15, 3), dtype=np.float32)
    got = check_against_oracle(img, ex, 4, 3)
    assert got.exact_copies == 0 and got.energy > 0


def test_coherence_mixed_copies_and_search(rng):
    ex = rng.random((16, 16, 1), dtype=np.float32)
    img = rng.random((20, 18, 1), dtype=np.float32)
    img[0:8, 0:9] = ex[3:11, 5:14]  # patches inside this block are copies
    img[10:20, 8:18] = ex[6:16, 0:10]
    got = check_against_oracle(img, ex, 3, 2)
    assert got.exact_copies > 0 and got.searched > 0
    assert (got.values[got.values == 0].size) == got.exact_copies


def test_coherence_crop_of_exemplar_is_zero(small_exemplar):
    img = small_exemplar[10:60, 20:90]
    got = M.coherence_energy(img, small_exemplar)
    assert got.energy == 0.0 and got.max == 0.0 and got.searched == 0
    # the offsets found are the crop's own (the smallest (row, col) among identical patches)
    assert tuple(got.offsets[0, 0]) == (10, 20) and tuple(got.offsets[1, 2]) == (14, 28)


def test_coherence_hash_collisions_cannot_fake_a_zero(rng, monkeypatch):
    """With every key colliding, a patch only counts as a copy after its pixels are compared."""
    ex = rng.random((12, 12, 2), dtype=np.float32)
    img = rng.random((13, 11, 2), dtype=np.float32)
    img[2:9, 1:8] = ex[4:11, 3:10]
    monkeypatch.setattr(
        metrics_coherence,
        "_patch_keys",
        lambda bits, p, rows, cols, step, w: np.zeros((rows, cols), np.uint64),
    )
    got = check_against_oracle(img, ex, 3, 2)
    assert got.exact_copies > 0


def test_coherence_of_omega_output(omega16):
    img, _ = ts.synthesize(omega16, 96, 96, seed=2)
    got = M.coherence_energy(img, omega16.exemplar, patch=8, stride=8)
    # ω-tiles copy exemplar content except near the cutting curves
    assert 0 < got.searched < got.n_patches and got.exact_copies > 0
    assert got.energy > 0
    # exactness on a few searched patches, against a direct numpy minimum
    ex = omega16.exemplar.astype(np.float64)
    windows = np.lib.stride_tricks.sliding_window_view(ex, (8, 8, ex.shape[2]))[:, :, 0]
    for i, j in list(zip(*np.nonzero(got.values > 0)))[:5]:
        t = img[i * 8 : i * 8 + 8, j * 8 : j * 8 + 8].astype(np.float64)
        want = ((windows - t) ** 2).sum(axis=(2, 3, 4)).min()
        assert got.values[i, j] == pytest.approx(want, rel=1e-9)


def test_coherence_errors(rng):
    img = rng.random((10, 10, 3), dtype=np.float32)
    with pytest.raises(ShapeError, match="channel"):
        M.coherence_energy(img, rng.random((10, 10, 1), dtype=np.float32))
    with pytest.raises(ParameterError, match="patch = 11"):
        M.coherence_energy(img, img, patch=11)
    with pytest.raises(ParameterError, match="stride = 0"):
        M.coherence_energy(img, img, stride=0)
    # index: was used whatever it indexed (an index of another image gave wrong energies without a word), and
    # anything else raised AttributeError
    other = rng.random((10, 10, 3), dtype=np.float32)
    with pytest.raises(ParameterError, match="index is an SsdIndex of another"):
        M.coherence_energy(img, other, index=ts.SsdIndex(img))
    with pytest.raises(ParameterError, match="index is 5, expected an SsdIndex of the exemplar"):
        M.coherence_energy(img, other, index=5)
    assert (
        M.coherence_energy(img, other, index=ts.SsdIndex(other)).energy
        == M.coherence_energy(img, other).energy
    )


# ------------------------------------------------------------------------------------------------- coverage
def test_coverage_names_positions_beyond_int64():
    # uint64 positions were cast to int64 first, so the message showed wrapped negative values
    src = np.full((2, 2, 2), 2**63 + 5, np.uint64)
    with pytest.raises(ParameterError, match=r"rows \[9223372036854775813, 9223372036854775813\]"):
        M.coverage(src, (4, 4, 3))


def test_coverage_constructed():
    # exemplar 2x2, counts [2, 1, 1, 0]
    src = np.array([[[0, 0], [0, 0]], [[0, 1], [1, 0]]], dtype=np.int32)
    c = M.coverage(src, (2, 2, 3))
    assert c.fraction == 0.75 and c.used == 3 and c.pixels == 4 and c.output_pixels == 4
    want_entropy = -(0.5 * math.log(0.5) + 2 * 0.25 * math.log(0.25))
    assert c.evenness == pytest.approx(want_entropy / math.log(4))
    assert c.cv == pytest.approx(np.std([2, 1, 1, 0]) / 1.0)
    np.testing.assert_array_equal(c.counts, [[2, 1], [1, 0]])


def test_coverage_extremes():
    yy, xx = np.mgrid[0:6, 0:5]
    once = np.stack([yy, xx], axis=-1)
    c = M.coverage(once, (6, 5))
    assert c.fraction == 1.0 and c.evenness == pytest.approx(1.0) and c.cv == pytest.approx(0.0)
    one = np.zeros((4, 4, 2), np.int64)
    c = M.coverage(one, (6, 5))
    assert c.fraction == pytest.approx(1 / 30) and c.evenness == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(ParameterError, match="outside the 5x6 exemplar"):
        M.coverage(once + [0, 1], (6, 5))
    with pytest.raises(ShapeError):
        M.coverage(np.zeros((4, 4, 2), np.float32), (6, 5))


def test_coverage_of_synthesis_matches_source_map(omega16):
    img, imap = ts.synthesize(omega16, 120, 72, seed=4)
    src = ts.source_map(omega16, imap, 120, 72)
    c = M.coverage(src, omega16.exemplar.shape)
    # provenance is right: every output pixel equals the exemplar pixel it names
    np.testing.assert_array_equal(img, omega16.exemplar[src[..., 0], src[..., 1]])
    used = np.zeros(omega16.exemplar.shape[:2], bool)
    used[src[..., 0], src[..., 1]] = True
    assert c.fraction == pytest.approx(used.mean()) and c.counts.sum() == 120 * 72


# ----------------------------------------------------------------------------------------------- repetition
def pearson_oracle(x: np.ndarray, dy: int, dx: int) -> float:
    h, w, _ = x.shape
    a = x[max(0, -dy) : h - max(0, dy), max(0, -dx) : w - max(0, dx)].astype(np.float64)
    b = x[max(0, dy) : h + min(0, dy), max(0, dx) : w + min(0, dx)].astype(np.float64)
    a = a - a.mean(axis=(0, 1))
    b = b - b.mean(axis=(0, 1))
    return float((a * b).sum() / math.sqrt((a * a).sum() * (b * b).sum()))


def test_autocorrelation_matches_oracle(rng):
    x = rng.random((9, 11, 3), dtype=np.float32)
    r = M.autocorrelation(x, 5, 6)
    assert r.shape == (11, 13)
    for dy in range(-5, 6):
        for dx in range(-6, 7):
            assert r[dy + 5, dx + 6] == pytest.approx(pearson_oracle(x, dy, dx), abs=1e-9), (dy, dx)
    assert r[5, 6] == pytest.approx(1.0)


def test_repetition_of_periodic_image(rng):
    cell = rng.random((7, 5, 3), dtype=np.float32)
    img = np.tile(cell, (6, 9, 1))  # 42 x 45, periods 7 (rows) and 5 (cols)
    rep = M.repetition(img)
    assert rep.peak == pytest.approx(1.0, abs=1e-9)
    assert rep.offset == (0, 5)  # ties go to the shortest offset


def test_repetition_of_noise_is_low_and_central_lobe_is_skipped(rng):
    noise = rng.random((64, 64, 3), dtype=np.float32)
    rep = M.repetition(noise)
    assert rep.peak is not None and rep.peak < 0.2
    # a smooth (blurred) field: r(0, 1) is high, but the central lobe is never the reported peak
    k = np.ones(7) / 7
    smooth = np.apply_along_axis(lambda v: np.convolve(v, k, "same"), 0, noise)
    smooth = np.apply_along_axis(lambda v: np.convolve(v, k, "same"), 1, smooth).astype(np.float32)
    rep = M.repetition(smooth)
    r01 = pearson_oracle(smooth, 0, 1)
    assert r01 > 0.9 and rep.peak < r01 and max(abs(rep.offset[0]), abs(rep.offset[1])) > 3
    assert rep.offset[0] > 0 or (rep.offset[0] == 0 and rep.offset[1] > 0)
    assert M.repetition(np.full((8, 8, 1), 0.5, np.float32)).peak is None


def test_repetition_of_the_periodic_4_set(small_exemplar):
    """The 4-set is determined after its first tile: its tilings repeat with a period of two tiles."""
    tset = ts.build_omega(small_exemplar, tileset="4", tile_size=16, seed=1)
    img, imap = ts.synthesize(tset, 128, 128, seed=1)
    rep = M.repetition(img)
    assert rep.peak > 0.99
    assert rep.offset[0] % 16 == 0 and rep.offset[1] % 16 == 0
    assert imap[0, 0] == imap[rep.offset[0] // 16, abs(rep.offset[1]) // 16]


def test_repetition_small_image_error(rng):
    with pytest.raises(ShapeError, match="4x4"):
        M.repetition(rng.random((3, 10), dtype=np.float32))


# ------------------------------------------------------------------------------------------------ objective
def test_objective(omega_n2, omega16):
    for tset in (omega_n2, omega16):
        ob = M.objective(tset)
        assert ob["E"] == pytest.approx(tset.E, rel=1e-12) and ob["E_stored"] == tset.E
        assert ob["f"] == pytest.approx(1.0 / tset.E)
        d = tset.D.astype(np.float64)  # these sets have one variant per corner tuple
        assert ob["intermediate_tiles"] == tset.n_tiles
        dn = d / tset.tile_size**2
        assert ob["E_normalised"] == pytest.approx(0.8 * dn.sum() + 0.2 * dn.var(), rel=1e-12)
        assert ob["f_normalised"] == pytest.approx(1.0 / ob["E_normalised"])
        assert ob["D"]["min"] == d.min() and ob["D"]["max"] == d.max()
        assert ob["D"]["std"] == pytest.approx(d.std())
        assert ob["cut_costs"]["sum"] == pytest.approx(tset.cut_costs.sum())


def test_objective_32_set_counts_intermediate_tiles_once(small_exemplar):
    tset = ts.build_omega(small_exemplar, tileset="32", tile_size=24, seed=2)
    ob = M.objective(tset)
    assert ob["intermediate_tiles"] == 16 and ob["E"] == pytest.approx(tset.E, rel=1e-12)


# ----------------------------------------------------------------------------------------------- everything
def test_tileset_metrics_and_format(omega16):
    m = M.tileset_metrics(omega16, 96, 72, seed=5, stride=8)
    assert m["sample"] == {
        "width": 96,
        "height": 72,
        "seed": 5,
        "tiles": [4, 3],
        "distinct_tiles_used": m["sample"]["distinct_tiles_used"],
    }
    img, imap = ts.synthesize(omega16, 96, 72, seed=5)
    assert m["seam"]["score"] == pytest.approx(M.seam_score(img, 24).score)
    assert m["coherence"]["energy"] == pytest.approx(
        M.coherence_energy(img, omega16.exemplar, stride=8).energy
    )
    assert m["objective"]["E"] == pytest.approx(omega16.E)
    assert m["notes"] == []
    text = M.format_metrics(m)
    for word in (
        "seam score",
        "coherence",
        "coverage",
        "repetition",
        "objective",
        "D_j",
        "cut costs",
        "cut seam",
    ):
        assert word in text


def test_image_metrics_skips_what_it_cannot_compute(rng):
    img = rng.random((40, 40, 3), dtype=np.float32)
    m = M.image_metrics(img)
    assert m["seam"] is None and m["coherence"] is None and m["coverage"] is None
    assert m["repetition"]["peak"] is not None
    assert len(m["notes"]) == 3 and any("tile size" in n for n in m["notes"])
    m = M.image_metrics(img, tile_size=10, exemplar=img[:20, :20])
    assert m["seam"]["tile_size"] == 10 and m["coherence"]["n_patches"] == 81
    assert len(m["notes"]) == 1 and "provenance" in m["notes"][0]


def test_cut_seam_score_oracle_and_smoothing(small_exemplar):
    from tilesynth.measure.metrics import cut_seam_score

    # constructed: two flat halves split by a vertical cut; only the pairs across the cut differ
    tiles = np.zeros((1, 4, 4, 1), np.float32)
    tiles[0, :, 2:] = 0.5
    masks = np.zeros((1, 4, 4), bool)
    masks[0, :, 2:] = True
    fake = types.SimpleNamespace(tiles=tiles, cut_masks=masks)
    got = cut_seam_score(fake)
    # 4 cut pairs of 0.25 each; 24 pairs in all -> (0.25) / (1.0 / 24) = 6
    assert got["cut_pairs"] == 4 and got["pairs"] == 24 and got["score"] == pytest.approx(6.0)
    assert cut_seam_score(types.SimpleNamespace(tiles=tiles, cut_masks=np.zeros_like(masks))) is None
    # smoothing lowers it on a real set
    plain = ts.build_omega(small_exemplar, tileset="16a", tile_size=48, seed=2)
    smooth = ts.build_omega(small_exemplar, tileset="16a", tile_size=48, seed=2, smooth=True)
    assert cut_seam_score(smooth)["score"] < cut_seam_score(plain)["score"]
