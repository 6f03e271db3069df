"""Vertex saliency (issue 12): the saliency of discs among an exemplar's discs, the repeated salient discs of
an output by provenance, and the "stats" draw's exclusion of salient vertex content."""

from __future__ import annotations

import numpy as np
import pytest

from tilesynth.errors import ParameterError, ShapeError
from tilesynth.measure.metrics import (
    DiscSaliency,
    _disc_kernel,
    _disc_sums,
    repeated_discs,
    vertex_disc_radius,
    vertex_saliency,
)


def _noise(size: int = 96, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(0.3, 0.6, size=(size, size, 3))


def test_disc_sums_match_brute_force():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(23, 31))
    r = 4
    k = _disc_kernel(r)
    assert k.shape == (8, 8) and k[3, 3] == k[4, 4] == 1 and k[0, 0] == 0
    np.testing.assert_array_equal(k, k[::-1])  # symmetric about the window's centre
    np.testing.assert_array_equal(k, k.T)
    got = _disc_sums(x, k)
    want = np.array([[(x[y : y + 8, c : c + 8] * k).sum() for c in range(31 - 7)] for y in range(23 - 7)])
    np.testing.assert_allclose(got, want, atol=1e-10)


def test_vertex_disc_radius():
    assert vertex_disc_radius(128) == 28
    assert vertex_disc_radius(88) == 19
    assert vertex_disc_radius(8) == 2
    assert vertex_disc_radius(4) == 2


def test_a_bright_blob_is_salient_and_plain_noise_is_not():
    """Oracle: uniform noise with one bright blob; the disc on the blob is the exemplar's most unusual disc,
    a disc of plain noise far from it is typical."""
    ex = _noise()
    yy, xx = np.mgrid[0:96, 0:96]
    ex[(yy - 30) ** 2 + (xx - 30) ** 2 <= 36] = 1.0  # the blob: radius 6 around (30, 30)
    r = 8
    sal = DiscSaliency(ex, r)
    assert sal.shape == (96 - 15, 96 - 15)
    d_blob, p_blob = sal.at([30 - r], [30 - r])  # disc centred between pixels 29 and 30
    d_far, p_far = sal.at([70 - r], [70 - r])
    assert p_blob[0] > 0.99 and p_far[0] < 0.9, (p_blob, p_far)
    assert d_blob[0] > 3 * d_far[0]
    # the most salient disc of the exemplar covers the blob
    iy, ix = np.unravel_index(np.argmax(sal.distances), sal.shape)
    assert abs(iy + r - 30) <= r and abs(ix + r - 30) <= r
    # at_patches: the centre disc of a patch of size 32 with top-left (14, 14) is centred on (30, 30)
    d, p = sal.at_patches(np.array([[14, 14], [54, 54]]), 32)
    np.testing.assert_array_equal(d, [d_blob[0], d_far[0]])
    np.testing.assert_array_equal(p, [p_blob[0], p_far[0]])
    d2, p2 = vertex_saliency(ex, np.array([[12, 12]]), 36)  # radius round(0.22 · 36) = 8, centre 12 + 18
    assert d2[0] == pytest.approx(d_blob[0]) and p2[0] == p_blob[0]


def test_a_high_contrast_disc_of_typical_colour_is_salient():
    """The contrast features: a checkerboard disc with the noise's mean colour stands out too."""
    ex = _noise(seed=2)
    yy, xx = np.mgrid[0:96, 0:96]
    disc = (yy - 60) ** 2 + (xx - 40) ** 2 <= 49
    ex[disc] = np.where(((yy + xx) % 2 == 0)[disc, None], 0.2, 0.7)  # mean 0.45, the noise's mean
    sal = DiscSaliency(ex, 8)
    _, p = sal.at([60 - 8], [40 - 8])
    assert p[0] > 0.99


def test_disc_saliency_rejects_bad_input():
    with pytest.raises(ParameterError):
        DiscSaliency(_noise(32), 17)  # a disc of 34 px in 32
    sal = DiscSaliency(_noise(32), 4)
    with pytest.raises(ParameterError):
        sal.at([25], [0])  # 32 - 8 + 1 = 25 positions: 0..24


def _scrambled_source(h: int, w: int, ex_side: int, seed: int) -> np.ndarray:
    """A provenance map with no copied disc: every pixel from an independent random exemplar position."""
    rng = np.random.default_rng(seed)
    return rng.integers(0, ex_side, size=(h, w, 2)).astype(np.int32)


def test_repeated_discs_count_exact_copies_by_provenance():
    """Oracle: a scrambled provenance map with the same exemplar disc pasted at 5 known vertex points and
    another one at 2: the first is the most repeated (5), only it is repeated (min_count 4), and its saliency is
    the exemplar's for that disc."""
    ex = _noise()
    r, s = 8, 16
    src = _scrambled_source(128, 128, 96, seed=3)
    yy, xx = np.mgrid[0 : 2 * r, 0 : 2 * r]

    def paste(cy: int, cx: int, ty: int, tx: int) -> None:  # exemplar window (ty, tx) on centre (cy, cx)
        src[cy - r : cy + r, cx - r : cx + r, 0] = ty + yy
        src[cy - r : cy + r, cx - r : cx + r, 1] = tx + xx

    for cy, cx in ((16, 16), (16, 64), (48, 96), (96, 32), (112, 112)):
        paste(cy, cx, 40, 50)
    for cy, cx in ((64, 64), (32, 112)):
        paste(cy, cx, 10, 20)
    sal = DiscSaliency(ex, r)
    got = repeated_discs(src, ex, r, stride=s, saliency=sal)
    assert got.most_repeated == 5 and got.repeated == 1
    d, p = sal.at([40], [50])
    assert got.max_distance == pytest.approx(d[0]) and got.max_percentile == pytest.approx(p[0])
    assert got.centres == 7 * 7  # centres 16, 32, ..., 112 on both axes
    expect = 100.0 * 5 / 49 if p[0] > 0.9 else 0.0
    assert got.salient_repeats == pytest.approx(expect)
    # a disc nibbled at by another offset on a few pixels is still a copy, one cut through is not
    src[16, 20] = (0, 0)
    assert repeated_discs(src, ex, r, stride=s, saliency=sal).most_repeated == 5
    src[8:24, 8:13] = _scrambled_source(16, 5, 96, seed=5)  # a quarter of the disc at (16, 16)
    assert repeated_discs(src, ex, r, stride=s, saliency=sal).most_repeated == 4
    # nothing repeated: nothing salient
    none = repeated_discs(_scrambled_source(128, 128, 96, seed=4), ex, r, stride=s, saliency=sal)
    assert none.most_repeated == 0 and none.repeated == 0 and none.salient_repeats == 0.0


def test_repeated_discs_rejects_bad_input():
    ex = _noise(32)
    with pytest.raises(ShapeError):
        repeated_discs(np.zeros((16, 16, 3), np.int32), ex, 4)
    with pytest.raises(ParameterError):
        repeated_discs(np.zeros((16, 16, 2), np.int32), ex, 4, saliency=DiscSaliency(ex, 5))


def _blobs(seed: int = 0, size: int = 160) -> np.ndarray:
    """Noise with a few bright discs: most sample patches are plain, a few hold a blob at their centre. The
    noise is finer on the left (so that some draws have a predicted border seam within the "stats" cap)."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size]
    amp = 0.05 + 0.25 * xx[..., None] / size
    img = 0.45 + amp * rng.uniform(-0.5, 0.5, size=(size, size, 3))
    for cy, cx in rng.integers(20, size - 20, size=(6, 2)):
        img[(yy - cy) ** 2 + (xx - cx) ** 2 <= 64] = 0.95
    return img


def test_calm_vertices_moves_only_the_salient_patches(monkeypatch):
    """A sample patch centred on a bright blob is moved within N/4 to where no disc around its centre is
    salient; plain patches stay; the predicted border seam stays within the slack; with the cap at 1 nothing
    moves."""
    import tilesynth.builder.genes.omega_borders as ob
    from tilesynth.builder.genes.wang_borders import _steps
    from tilesynth.measure.metrics import DiscSaliency, vertex_disc_radius

    ex, n = _blobs(), 48
    rng = np.random.default_rng(0)
    sal = DiscSaliency(ex, vertex_disc_radius(n))
    r = vertex_disc_radius(n)
    # the most salient centre disc of the exemplar, and three plain ones
    iy, ix = np.unravel_index(np.argmax(sal.distances), sal.shape)
    hot = (int(np.clip(iy + r - n // 2, 0, 160 - n)), int(np.clip(ix + r - n // 2, 0, 160 - n)))
    plain = [
        g for g in rng.integers(0, 160 - n, size=(200, 2)).tolist() if sal.at_patches([g], n)[1][0] < 0.5
    ][:3]
    genes = np.array([hot, *plain])
    assert sal.at_patches(genes[:1], n)[1][0] > 0.99
    steps = _steps(ex)
    monkeypatch.setattr(ob, "STATS_SEAM_CAP", 100.0)  # the seam bound is the slack alone
    g, moved, left = ob._calm_vertices(ex, steps, genes, n)
    assert moved >= 1
    assert np.abs(g[0] - genes[0]).max() <= n // ob.VERTEX_MOVE and not np.array_equal(g[0], genes[0])
    assert sal.at_patches(g[:1], n)[1][0] <= ob.VERTEX_SALIENCY_CAP
    assert left <= ob.VERTEX_SALIENCY_CAP
    for k in range(1, 4):  # a plain patch moves only if a disc near its centre is salient
        if not np.array_equal(g[k], genes[k]):
            assert np.abs(g[k] - genes[k]).max() <= n // ob.VERTEX_MOVE
    assert ob._predict(steps, g, n) <= ob._predict(steps, genes, n) + ob.VERTEX_SEAM_SLACK + 1e-12
    monkeypatch.setattr(ob, "VERTEX_SALIENCY_CAP", 1.0)
    g1, moved1, _ = ob._calm_vertices(ex, steps, genes, n)
    assert moved1 == 0
    np.testing.assert_array_equal(g1, genes)


def test_stats_draw_records_the_vertex_saliency(monkeypatch):
    """The "stats" draw keeps the most representative admissible draw, then calms its vertices: with the cap at
    1 the genes are those of before (the oracle of tests/test_periodic.py), and the record says what was left."""
    import tilesynth.builder.genes.omega_borders as ob
    from tilesynth.builder.genes.draws import random_genes

    ex, n, tries = _blobs(), 48, 8
    moved = False
    for seed in range(3):
        rng = np.random.default_rng(seed)
        first = random_genes(ex.shape, 4, n, rng)
        state = rng.bit_generator.state
        g, rec = ob.border_aware_corner_genes(ex, first, n, rng, tries, "stats")
        if "vertex_moves" not in rec:
            continue  # no admissible draw: "cap"'s choice, nothing calmed
        rng.bit_generator.state = state
        monkeypatch.setattr(ob, "VERTEX_SALIENCY_CAP", 1.0)
        g1, rec1 = ob.border_aware_corner_genes(ex, first, n, rng, tries, "stats")
        monkeypatch.undo()
        assert rec1["vertex_moves"] == 0
        assert (rec["vertex_moves"] == 0) == np.array_equal(g, g1)
        assert np.abs(g - g1).max() <= n // ob.VERTEX_MOVE
        assert rec["vertex_saliency_predicted"] <= max(
            ob.VERTEX_SALIENCY_CAP, rec1["vertex_saliency_predicted"]
        )
        assert rec["border_seam_predicted"] <= ob.STATS_SEAM_CAP
        moved |= rec["vertex_moves"] > 0
    assert moved  # the blobs were moved at least once (else the test shows nothing)
