"""Oracles of the lattice measures: planted grids and motifs score high, noise and shifted phases about 1,
objects cut in halves score 0 and intact ones 1."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.errors import ParameterError, ShapeError
from tilesynth.measure.lattice import (
    folded_mean,
    label_components,
    lattice_folded,
    lattice_gradient,
    objects_intact,
    otsu_threshold,
)

N = 32


def _noise(h, w, c=3, seed=0, amp=1.0):
    return (np.random.default_rng(seed).random((h, w, c)) * amp).astype(np.float32)


def _cells(h, w, n, seed, amp=0.8, shear=False):
    """A random brightness per n x n cell (steps on the grid lines x ≡ 0, y ≡ 0 mod n), or with ``shear`` per
    cell of the same size on the diagonal lattice x ± y ≡ 0 mod n: the same steps, at every phase."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:h, 0:w]
    u, v = ((xx + yy) // n, (xx - yy + h) // n) if shear else (yy // n, xx // n)
    return (amp * rng.random((u.max() + 1, v.max() + 1))[u, v])[..., None].repeat(3, axis=2)


# ------------------------------------------------------------------------------------------ gradient
def test_gradient_noise_is_one():
    g = lattice_gradient(_noise(512, 512, seed=1), N)
    assert 1.0 <= g.score < 1.08
    assert g.ratio_x < 1.08 and g.ratio_y < 1.08


def test_gradient_planted_grid_is_high_at_phase_zero():
    img = _noise(512, 512, seed=2, amp=0.2) + _cells(512, 512, N, seed=3)
    g = lattice_gradient(img.clip(0, 1), N)
    assert g.score > 2.0
    assert g.phase_x == 0 and g.phase_y == 0
    # the same grid two pixels inside the tiles: found at its depth
    g2 = lattice_gradient(np.roll(img, (2, 2), axis=(0, 1)).clip(0, 1), N)
    assert g2.phase_x == 2 and g2.phase_y == 2 and g2.score > 2.0


def test_gradient_shifted_phase_is_one():
    img = _noise(512, 512, seed=5, amp=0.2) + _cells(512, 512, N, seed=6, shear=True)
    assert lattice_gradient(img.clip(0, 1), N).score < 1.15


def test_gradient_one_direction_is_not_diluted():
    img = _noise(512, 512, seed=7, amp=0.5)
    img[:, ::N] = 1.0  # vertical lines only
    g = lattice_gradient(img, N)
    assert g.ratio_x > 2.0 and g.ratio_y < 1.1
    assert g.score == g.ratio_x


def test_gradient_skips_a_direction_under_two_tiles_and_checks_inputs():
    g = lattice_gradient(_noise(40, 256, seed=8), N)
    assert g.ratio_y is None and g.ratio_x is not None
    with pytest.raises(ShapeError):
        lattice_gradient(_noise(60, 60), N)
    with pytest.raises(ParameterError, match="tile_size"):
        lattice_gradient(_noise(64, 64), 1)
    d = g.to_dict()
    assert d["ratio_y"] is None and len(d["profile_x"]) == N


# ------------------------------------------------------------------------------------------ folded
def _disc(r):
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    return (yy * yy + xx * xx) <= r * r


def test_folded_noise_is_one():
    f = lattice_folded(_noise(512, 512, seed=9), N)
    assert 0.85 < f.score < 1.15
    assert f.cells == 256


def test_folded_planted_motif_is_high_and_found():
    img = _noise(512, 512, seed=10, amp=0.6)
    d = _disc(4)
    for i in range(0, 512, N):
        for j in range(0, 512, N):
            img[i + 10 : i + 19, j + 20 : j + 29][d] = 1.0
    f = lattice_folded(img, N)
    assert f.score > 3.0
    assert 10 <= f.peak[0] <= 18 and 20 <= f.peak[1] <= 28
    assert folded_mean(img, N).shape == (N, N)


def test_folded_motif_at_random_positions_is_one():
    rng = np.random.default_rng(11)
    img = _noise(512, 512, seed=12, amp=0.6)
    d = _disc(4)
    for _ in range((512 // N) ** 2):  # one motif per cell, anywhere
        y, x = rng.integers(0, 512 - 9, 2)
        img[y : y + 9, x : x + 9][d] = 1.0
    assert 0.8 < lattice_folded(img, N).score < 1.25


def test_folded_checks_inputs():
    with pytest.raises(ShapeError):
        lattice_folded(_noise(40, 40), N)


# ------------------------------------------------------------------------------------------ objects
def _discs_on_white(size, r, count, seed, half=False):
    """Black discs of radius r on white, not touching each other (rejection sampling); ``half``: only the
    left half of every disc (cut in halves)."""
    rng = np.random.default_rng(seed)
    img = np.ones((size, size, 3), np.float32)
    centres: list[tuple[int, int]] = []
    d = _disc(r)
    if half:
        d = d & (np.arange(-r, r + 1)[None, :] < 0)
    tries = 0
    while len(centres) < count and tries < 20000:
        tries += 1
        y, x = (int(v) for v in rng.integers(r + 1, size - r - 1, 2))
        if all((y - a) ** 2 + (x - b) ** 2 > (2 * r + 3) ** 2 for a, b in centres):
            centres.append((y, x))
            img[y - r : y + r + 1, x - r : x + r + 1][d] = 0.0
    return img


def test_label_components_matches_scipy():
    ndimage = pytest.importorskip("scipy.ndimage")
    rng = np.random.default_rng(13)
    for p in (0.3, 0.55, 0.7):
        m = rng.random((97, 131)) < p
        a, ka = label_components(m)
        b, kb = ndimage.label(m)
        assert ka == kb and np.array_equal(a, b)
    assert label_components(np.zeros((5, 5), bool))[1] == 0


def test_otsu_splits_two_levels():
    v = np.r_[np.full(100, 0.2), np.full(300, 0.8)]
    assert 0.2 < otsu_threshold(v) <= 0.8


def test_objects_intact_discs_score_one():
    ex = _discs_on_white(256, 9, 40, seed=14)
    out = _discs_on_white(512, 9, 160, seed=15)
    o = objects_intact(out, ex)
    assert o.applies and o.polarity == "dark"
    assert o.exemplar_share == 1.0
    assert o.share > 0.97 and o.n_counted >= 100


def test_objects_cut_in_halves_score_zero():
    ex = _discs_on_white(256, 9, 40, seed=14)
    out = _discs_on_white(512, 9, 160, seed=16, half=True)
    o = objects_intact(out, ex)
    assert o.share == 0.0 and o.n_counted >= 100


def test_objects_grid_cut_scores_between():
    """A periodic patchwork of exemplar blocks cut at a grid: the discs on the block edges are cut."""
    ex = _discs_on_white(256, 9, 40, seed=14)
    rng = np.random.default_rng(17)
    out = np.ones((512, 512, 3), np.float32)
    for i in range(0, 512, 32):
        for j in range(0, 512, 32):
            y, x = rng.integers(0, 256 - 32, 2)
            out[i : i + 32, j : j + 32] = ex[y : y + 32, x : x + 32]
    o = objects_intact(out, ex)
    assert 0.0 < o.share < 0.6


def test_objects_mirrored_shape_is_intact():
    """An L-shaped object mirrored and turned is still one whole object (the 8 orientations)."""
    ell = np.zeros((15, 15), bool)
    ell[:, :5] = True
    ell[-5:, :] = True
    ex = np.ones((200, 200, 3), np.float32)
    out = np.ones((200, 200, 3), np.float32)
    k = 0
    for i in range(10, 180, 40):
        for j in range(10, 180, 40):
            ex[i : i + 15, j : j + 15][ell] = 0
            out[i : i + 15, j : j + 15][np.rot90(ell, k % 4)[:, :: 1 if k % 2 else -1]] = 0
            k += 1
    o = objects_intact(out, ex)
    assert o.share == 1.0


def test_objects_on_noise_does_not_apply_and_checks_inputs():
    o = objects_intact(_noise(128, 128, seed=18), _noise(128, 128, seed=19))
    assert not o.applies
    with pytest.raises(ParameterError, match="polarity"):
        objects_intact(_noise(32, 32), _noise(32, 32), polarity="up")
    with pytest.raises(ParameterError, match="iou"):
        objects_intact(_noise(32, 32), _noise(32, 32), iou=0)


def test_exported_from_the_package():
    assert ts.lattice_gradient is lattice_gradient
    assert ts.lattice_folded is lattice_folded
    assert ts.objects_intact is objects_intact


# ------------------------------------------------------------------------------------------ tile scale
def test_feature_tile_size_grows_with_objects_only():
    from tilesynth.builder.tile_scale import feature_tile_size

    ex = _discs_on_white(256, 9, 40, seed=14)  # d = 2·√(A/π) ≈ 18 px: 4·d ≈ 72 → 72 or 80 (multiple of 8)
    n, info = feature_tile_size(ex)
    assert info["kind"] == "objects" and info["default"] == 64
    assert n in (72, 80) and n % 8 == 0
    big = _discs_on_white(256, 30, 12, seed=20)  # 4·d ≈ 240: capped at half the shorter side
    assert feature_tile_size(big)[0] == 128
    n2, info2 = feature_tile_size(_noise(256, 256, seed=21))  # no objects: the build's default, unchanged
    assert n2 is None and info2["kind"] is None and info2["size"] == 64
    small = _discs_on_white(256, 4, 150, seed=22)  # objects that fit the default tile: no change either
    n3, info3 = feature_tile_size(small)
    assert n3 is None and info3["kind"] == "objects"


# ------------------------------------------------------------------------------------------ in the metrics
def test_image_metrics_report_the_lattice_objects_and_the_exemplars_own():
    """`tilesynth metrics` and the report carry the three measures (issue 29), with the exemplar's own values on
    the same grid beside them; none without a grid, objects only for an exemplar of separate objects."""
    from tilesynth.measure.metrics import format_metrics, image_metrics
    from tilesynth.measure.report_page import metrics_rows

    # grain on the discs and the cells: no phase has zero steps, so the ratios stay finite
    ex = _discs_on_white(128, 5, 30, seed=20) * 0.8 + _noise(128, 128, seed=25, amp=0.2)
    img = _cells(128, 160, N, seed=21) + _noise(128, 160, seed=26, amp=0.2)
    m = image_metrics(img, tile_size=N, exemplar=ex, patch=8, stride=8)
    la = m["lattice"]
    assert la["gradient"]["score"] == pytest.approx(lattice_gradient(img, N).score)
    assert la["gradient"]["score"] > 5  # planted steps on the grid lines
    assert la["folded"]["score"] == pytest.approx(lattice_folded(img, N).score)
    assert la["exemplar_gradient"] == pytest.approx(lattice_gradient(ex, N).score)
    assert la["exemplar_folded"] == pytest.approx(lattice_folded(ex, N).score)
    assert m["objects"]["share"] == pytest.approx(objects_intact(img, ex).share)
    text = format_metrics(m)
    assert "lattice       gradient" in text and "objects" in text
    names = [r[0] for r in metrics_rows(m)]
    assert {"lattice (gradient)", "lattice (folded)", "objects intact"} <= set(names)
    plain = image_metrics(_noise(96, 96, seed=22), exemplar=_noise(64, 64, seed=23), patch=8, stride=8)
    assert plain["lattice"] is None and plain["objects"] is None  # no grid given; not an object exemplar
    small = image_metrics(_noise(40, 40, seed=24), tile_size=N, patch=8, stride=8)
    assert small["lattice"] is None  # under two tiles and two cells: neither measure applies


def test_objects_cut_warning_fires_below_the_objects_tile_size_only():
    """The build warns when the exemplar's objects ask for larger tiles than it builds (issue 29: the grid shows
    on object photos), naming the recipe and its size; not at that size, not on a texture without objects."""
    from tilesynth.measure.diagnose import diagnose_objects
    from tilesynth.measure.lattice import object_tile_size

    ex = _discs_on_white(256, 9, 60, seed=30) * 0.8 + _noise(256, 256, seed=31, amp=0.2)
    want, scale = object_tile_size(ex)
    assert want is not None and 16 < scale < 22 and want % 8 == 0

    def found(img, n):
        return {f["code"]: f for f in diagnose_objects(img, tile_size=n)}

    hit = found(ex, want - 8)["objects-cut"]
    assert f"--tile-size {want}" in hit["message"] and "--recipe objects" in hit["message"]
    assert hit["value"] == pytest.approx(want / (want - 8))
    assert "objects-cut" not in found(ex, want)
    assert "objects-cut" not in found(_noise(256, 256, seed=32), 32)
    assert object_tile_size(_noise(256, 256, seed=32)) == (None, 0.0)
