"""Oracles of the non-periodicity measures (issue 12): periodic copies, detail autocorrelation, histograms."""

from __future__ import annotations

import numpy as np
import pytest

from tilesynth.errors import ShapeError
from tilesynth.measure.metrics import (
    detail_layer,
    detail_repetition,
    histogram_distance,
    image_metrics,
    periodic_copies,
    repeated_patches,
)


def _noise(h, w, c=3, seed=0):
    return np.random.default_rng(seed).random((h, w, c)).astype(np.float32)


@pytest.mark.parametrize("period", [(37, 53), (64, 64), (23, 100)])
def test_periodic_image_is_all_copies(period):
    py, px = period
    img = np.tile(_noise(py, px, seed=py), (256 // py + 1, 256 // px + 1, 1))[:256, :256]
    pc = periodic_copies(img)
    assert pc.fraction == 1.0
    assert any(
        (abs(dy), abs(dx)) in ((py, px), (py, 0), (0, px)) or (dy % py == 0 and dx % px == 0)
        for dy, dx in pc.lags
    )
    dr = detail_repetition(img)
    assert dr.peak > 0.95


def test_noise_has_no_copies():
    img = _noise(256, 256, seed=5)
    assert periodic_copies(img).fraction == 0.0
    assert detail_repetition(img).peak < 0.1


def test_half_periodic_image():
    """Left half periodic (period 32 along y), right half noise: about half the patches are copies."""
    img = _noise(256, 256, seed=1)
    img[:, :128] = np.tile(_noise(32, 128, seed=2), (8, 1, 1))
    f = periodic_copies(img).fraction
    assert 0.4 <= f <= 0.55


def test_tolerance_is_two_levels():
    base = np.tile(_noise(32, 32, seed=3), (8, 8, 1))
    rng = np.random.default_rng(4)
    small = np.clip(base + rng.choice([-1, 1], base.shape) * (1.0 / 255), 0, 1).astype(np.float32)
    big = np.clip(base + rng.choice([-1, 1], base.shape) * (4.0 / 255), 0, 1).astype(np.float32)
    assert periodic_copies(small).fraction > 0.9  # differences of ~2/255 between partners: mse <= (2/255)^2
    assert periodic_copies(big).fraction < 0.1


def _repeated_oracle(img, p):
    """Brute force: every grid patch against every disjoint window, by the pixels."""
    h, w, _ = img.shape
    rows, cols = h // p, w // p
    hit = np.zeros((rows, cols), bool)
    for r in range(rows):
        for c in range(cols):
            y, x = r * p, c * p
            mine = img[y : y + p, x : x + p]
            hit[r, c] = any(
                max(abs(yy - y), abs(xx - x)) >= p and np.array_equal(img[yy : yy + p, xx : xx + p], mine)
                for yy in range(h - p + 1)
                for xx in range(w - p + 1)
            )
    return hit.mean()


@pytest.mark.parametrize("seed", range(4))
def test_repeated_patches_against_brute_force(seed):
    """Random pastes of exemplar-like blocks at arbitrary offsets (the vertex content of corner tiles recurs
    at lattice positions, a pasted block anywhere); the rolling-hash measure equals the brute-force count."""
    rng = np.random.default_rng(seed)
    p = int(rng.choice([4, 5, 8]))
    h, w = int(rng.integers(20, 40)), int(rng.integers(20, 40))
    img = rng.integers(0, 3, (h, w, 2)).astype(np.float32) / 2  # few values: partial matches are common
    src = rng.integers(0, 256, (12, 12, 2)).astype(np.float32) / 255
    for _ in range(3):
        y, x = int(rng.integers(0, h - 12)), int(rng.integers(0, w - 12))
        img[y : y + 12, x : x + 12] = src
    img[-1, -1, 0] = -0.0  # -0.0 and +0.0 are the same value
    got = repeated_patches(img, patch=p)
    assert got.fraction == pytest.approx(_repeated_oracle(img, p), abs=0)
    assert got.n_patches == (h // p) * (w // p)


def test_repeated_patches_copy_periodic_and_noise():
    img = _noise(128, 128, seed=7)
    assert repeated_patches(img).fraction == 0.0
    pasted = img.copy()
    pasted[70:102, 83:115] = img[16:48, 16:48]  # 4 grid patches inside the source, 1 inside the copy
    assert repeated_patches(pasted).fraction == 5 / 64
    assert repeated_patches(np.tile(img[:32, :32], (4, 4, 1))).fraction == 1.0
    shifted = pasted.copy()
    shifted[70:102, 83:115] += 1 / 255  # no longer bit-identical: not a repeat
    assert repeated_patches(np.clip(shifted, 0, 1)).fraction == 0.0
    with pytest.raises(ShapeError, match="at least one 16x16 patch"):
        repeated_patches(img[:8])


def test_detail_layer_removes_smooth_variation():
    y, x = np.mgrid[0:128, 0:128] / 128.0
    ramp = np.repeat(((x + y) / 2)[..., None], 3, axis=2).astype(np.float32)
    d = detail_layer(ramp)
    assert np.abs(d[36:-36, 36:-36]).max() < 1e-6  # beyond the kernel radius 4σ of the borders
    assert np.abs(detail_layer(_noise(128, 128))).max() > 0.3


def test_histogram_distance_oracles():
    ex = _noise(128, 128, seed=7)
    assert histogram_distance(ex, ex).distance == 0.0
    shuffled = np.random.default_rng(1).permutation(ex.reshape(-1, 3)).reshape(ex.shape)
    hd = histogram_distance(shuffled, ex)
    assert max(hd.colour) < 1e-3  # the same colours
    flat = np.full_like(ex, 0.5)
    assert histogram_distance(flat, ex).distance > 0.1
    # colour shift of 0.1 on every channel: W1 = 0.1 on each colour channel, gradients unchanged
    shifted = ex * 0.5 + 0.1
    ref = ex * 0.5
    hd = histogram_distance(shifted.astype(np.float32), ref.astype(np.float32))
    assert hd.colour == pytest.approx([0.1, 0.1, 0.1], abs=1e-3)
    assert max(hd.gradient) < 1e-6
    with pytest.raises(ShapeError):
        histogram_distance(ex, ex[..., :1])


def test_image_metrics_include_the_new_measures():
    img = np.tile(_noise(32, 32, seed=9), (4, 4, 1))
    m = image_metrics(img, exemplar=_noise(64, 64, seed=9))
    assert m["periodic_copies"]["fraction"] == 1.0
    assert m["detail_repetition"]["peak"] > 0.95
    assert m["histogram"]["distance"] >= 0.0
    small = image_metrics(_noise(8, 8))
    assert small["periodic_copies"] is None


# ------------------------------------------------------------------------------ inner-lattice seam (issue 12)
def test_inner_seam_score_finds_a_grid_inside_the_tiles():
    from tilesynth.measure.metrics import inner_seam_score

    rng = np.random.default_rng(5)
    n = 32
    noise = rng.random((256, 256, 3)).astype(np.float32) * 0.2 + 0.4
    clean = inner_seam_score(noise, n)
    assert set(clean.scores) == {1, -1, 2, -2, 3, -3, 4, -4}
    assert all(abs(v - 1) < 0.05 for v in clean.scores.values())  # i.i.d. noise: every line is interior-like
    # a square grid of seams 2 px inside every tile (the free cut pressed onto the ring): each tile's
    # pixels 2..N-3 shifted by a constant, so the steps across lines +2 and -2 grow and no other line's
    seamed = noise.copy()
    inner = (np.arange(256) % n >= 2) & (np.arange(256) % n <= n - 3)
    seamed[np.ix_(inner, inner)] += 0.3
    s = inner_seam_score(seamed, n)
    assert s.max > 3 and abs(s.depth_of_max) == 2
    assert s.scores[2] > 3 and s.scores[-2] > 3
    assert all(abs(s.scores[d] - 1) < 0.05 for d in (1, -1, 3, -3, 4, -4))
    assert s.mean == pytest.approx(np.mean(list(s.scores.values())))
    d = s.to_dict()
    assert d["scores"]["2"] == pytest.approx(s.scores[2]) and d["tile_size"] == n
    # the border seam score does not flag that grid (its interior mean even includes the grid lines)
    from tilesynth.measure.metrics import seam_score

    assert seam_score(seamed, n).score < 1.05


def test_inner_seam_score_errors_and_small_tiles():
    from tilesynth.errors import ParameterError, ShapeError
    from tilesynth.measure.metrics import inner_seam_score

    img = np.random.default_rng(1).random((64, 64, 1)).astype(np.float32)
    with pytest.raises(ShapeError):
        inner_seam_score(img, 64)  # one tile: no border
    with pytest.raises(ParameterError):
        inner_seam_score(img, 4, depths=(2, 3))  # no depth below N/2
    s = inner_seam_score(img, 6)  # depths 1 and 2 only (3 = N/2 is left out)
    assert set(s.scores) == {1, -1, 2, -2}
