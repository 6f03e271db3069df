"""ω-tile construction: geometry, provenance, matching, energy, seamless synthesis."""

from __future__ import annotations

import numpy as np
import pytest
from test_kernels_ssd import ssd_oracle

import tilesynth
from tilesynth.builder.omega import energy, intermediate_tiles


@pytest.fixture(scope="module")
def built(small_exemplar):
    return tilesynth.build_omega(
        small_exemplar, tileset="16a", tile_size=32, seed=5, threads=2, select="random"
    )


def test_shapes_and_params(built, small_exemplar):
    assert built.tiles.shape == (16, 32, 32, 3)
    assert built.source.shape == (16, 32, 32, 2)
    assert built.cut_masks.shape == (16, 32, 32)
    assert built.genes.shape == (4, 2)
    assert built.params["seed"] == 5 and built.params["set"] == "16a" and built.params["tile_size"] == 32
    # the default draw is border-aware (issue 14, tilesynth.builder.genes.omega_borders); the record says so
    sel = built.params["selection"]
    assert sel["method"] == "random" and sel["border_tries"] == 32 and sel["border_criterion"] == "cap"
    assert built.params["border_tries"] == 32
    assert len({tuple(g) for g in built.genes.tolist()}) == 4
    assert (built.genes >= 0).all() and (built.genes <= 96 - 32).all()


def test_every_pixel_comes_from_where_provenance_says(built, small_exemplar):
    ex = small_exemplar
    rows, cols = built.source[..., 0], built.source[..., 1]
    np.testing.assert_array_equal(built.tiles, ex[rows, cols])


def test_intermediate_geometry(small_exemplar):
    ex = small_exemplar
    genes = np.array([[0, 0], [10, 50], [40, 7], [60, 60]])
    inter, src = intermediate_tiles(ex, genes, np.array([[0, 1, 2, 3]]), 16)
    # TL quadrant = bottom-right quarter of patch 0, BL = top-right of patch 1, TR = bottom-left of patch 2,
    # BR = top-left of patch 3
    np.testing.assert_array_equal(inter[0, :8, :8], ex[8:16, 8:16])
    np.testing.assert_array_equal(inter[0, 8:, :8], ex[10:18, 58:66])
    np.testing.assert_array_equal(inter[0, :8, 8:], ex[48:56, 7:15])
    np.testing.assert_array_equal(inter[0, 8:, 8:], ex[60:68, 60:68])
    np.testing.assert_array_equal(inter[0], ex[src[0, ..., 0], src[0, ..., 1]])


def test_cut_region_and_matching_patch(built, small_exemplar):
    n = 32
    c = (n - 1) / 2
    yy, xx = np.mgrid[:n, :n]
    inside = (yy - c) ** 2 + (xx - c) ** 2 <= (n / 2) ** 2
    cross = np.zeros((n, n), bool)
    cross[n // 2 - 1 : n // 2 + 1] = True
    cross[:, n // 2 - 1 : n // 2 + 1] = True
    border = np.zeros((n, n), bool)
    border[[0, -1], :] = True
    border[:, [0, -1]] = True
    defn = built.definition
    colour = {col: i for i, col in enumerate(defn.colours)}
    for k in range(built.n_tiles):
        m = built.cut_masks[k]
        assert not m[~inside].any(), "the curve stays inside the inscribed circle"
        assert not m[border].any(), "keep_border: O never reaches the tile border"
        assert m[cross & inside & ~border].all(), "the central cross takes O"
        r, cc = built.match_offsets[k]
        np.testing.assert_array_equal(built.tiles[k][m], small_exemplar[r : r + n, cc : cc + n][m])
        patches = [colour[x] for x in defn.tiles[k]]
        assert list(built.tile_patches[k]) == patches


def test_matching_patch_is_the_exact_best_and_D_is_its_ssd(built, small_exemplar):
    inter, _ = intermediate_tiles(small_exemplar, built.genes, built.tile_patches[:3], 32)
    for k in range(3):
        ref = ssd_oracle(small_exemplar, inter[k])
        assert built.D[k] == pytest.approx(ref.min(), rel=1e-9)
        assert ref[tuple(built.match_offsets[k])] == pytest.approx(ref.min(), rel=1e-9)


def test_energy_formula(built):
    d = built.D
    assert built.E == pytest.approx(0.8 * d.sum() + 0.2 * d.var(), rel=1e-12)
    assert energy([1.0, 3.0]) == pytest.approx(0.8 * 4 + 0.2 * 1.0)


def test_32_set_has_two_distinct_matches_per_intermediate_tile(small_exemplar):
    ts = tilesynth.build_omega(small_exemplar, tileset="32", tile_size=24, seed=2)
    assert ts.n_tiles == 32
    defn = ts.definition
    for k in range(16):
        partner = [j for j in range(32) if j != k and defn.tiles[j] == defn.tiles[k]]
        assert len(partner) == 1
        j = partner[0]
        np.testing.assert_array_equal(ts.tile_patches[k], ts.tile_patches[j])
        assert {defn.variants[k], defn.variants[j]} == {0, 1}
        best, second = (k, j) if defn.variants[k] == 0 else (j, k)
        assert ts.D[best] <= ts.D[second]
        assert np.abs(ts.match_offsets[best] - ts.match_offsets[second]).max() > 24 // 4
    assert ts.E == pytest.approx(energy(ts.D[np.asarray(defn.variants) == 0]), rel=1e-12)


@pytest.mark.parametrize("keep_border", [True, False])
@pytest.mark.parametrize("name", ["4", "8", "16a", "16b", "32"])
def test_synthesis_is_continuous_exemplar_content_across_tile_borders(name, keep_border, small_exemplar):
    """Across every tile border, pixels kept from the intermediate tile continue the same exemplar patch.

    With keep_border (the default) that is every border pixel; with the literal definition O reaches the border
    near the side midpoints, and only the pixels kept from I are continuous."""
    ts = tilesynth.build_omega(small_exemplar, tileset=name, tile_size=16, seed=11, keep_border=keep_border)
    n = 16
    W, H = 16 * 9 + 5, 16 * 7 + 3
    img, imap = tilesynth.synthesize(ts, W, H, seed=3)
    src = tilesynth.source_map(ts, imap, W, H)
    tilesynth.tile_copy(ts.cut_masks.astype(np.uint8)[..., None], imap, m8 := np.zeros((H, W, 1), np.uint8))
    masks = m8[..., 0].astype(bool)
    np.testing.assert_array_equal(img, small_exemplar[src[..., 0], src[..., 1]])
    checked = 0
    for x in range(n, W, n):  # vertical borders between columns x-1 | x
        keep = ~masks[:, x - 1] & ~masks[:, x]
        np.testing.assert_array_equal(src[keep, x, 0], src[keep, x - 1, 0])
        np.testing.assert_array_equal(src[keep, x, 1], src[keep, x - 1, 1] + 1)
        checked += keep.sum()
    for y in range(n, H, n):  # horizontal borders between rows y-1 | y
        keep = ~masks[y - 1] & ~masks[y]
        np.testing.assert_array_equal(src[y, keep, 0], src[y - 1, keep, 0] + 1)
        np.testing.assert_array_equal(src[y, keep, 1], src[y - 1, keep, 1])
        checked += keep.sum()
    total = ((W - 1) // n) * H + ((H - 1) // n) * W
    if keep_border:
        assert checked == total
    else:
        # at N = 16 the inscribed circle meets each side over 6 of 16 pixels, so at least 10/16 are kept from I
        assert checked >= 0.6 * total


def test_genes_interface(small_exemplar):
    genes = np.array([[0, 0], [5, 40], [30, 10], [60, 60]])
    ts = tilesynth.build_omega(small_exemplar, tileset="16b", tile_size=32, genes=genes)
    np.testing.assert_array_equal(ts.genes, genes)
    assert ts.params["selection"] == {"method": "given"}
    with pytest.raises(tilesynth.ParameterError, match=r"genes\[3\]"):
        tilesynth.build_omega(
            small_exemplar, tileset="c4", tile_size=32, genes=np.array([[0, 0], [1, 1], [2, 2], [65, 0]])
        )
    with pytest.raises(tilesynth.ParameterError, match="distinct"):
        tilesynth.build_omega(
            small_exemplar, tileset="c4", tile_size=32, genes=np.array([[0, 0], [1, 1], [1, 1], [3, 0]])
        )
    with pytest.raises(tilesynth.ParameterError, match="genes"):
        tilesynth.build_omega(small_exemplar, tile_size=32, genes=np.zeros((3, 2), int))


@pytest.mark.parametrize(
    ("size", "words"), [(31, "even"), (98, "larger than the exemplar"), (2, ">= 4"), (0, ">= 4")]
)
def test_bad_tile_size(small_exemplar, size, words):
    with pytest.raises(tilesynth.ParameterError, match=words):
        tilesynth.build_omega(small_exemplar, tile_size=size)


def test_unknown_set(small_exemplar):
    with pytest.raises(ValueError, match="16a"):
        tilesynth.build_omega(small_exemplar, tileset="17", tile_size=16)


def test_same_seed_same_tiles_any_threads(small_exemplar):
    a = tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=24, seed=9, threads=1)
    b = tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=24, seed=9, threads=2)
    assert a.content_digest() == b.content_digest()
    c = tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=24, seed=10)
    assert c.content_digest() != a.content_digest()


def test_patch_gradients_follow_provenance(small_exemplar):
    from tilesynth.builder.omega import patch_gradients

    ex = small_exemplar.astype(np.float64)
    src = np.array([[[3, 4], [10, 95]], [[95, 7], [95, 95]]], np.int32)
    g = patch_gradients(small_exemplar, src)
    assert g[0, 0, 0] == pytest.approx(np.linalg.norm(ex[3, 5] - ex[3, 4]))
    assert g[0, 0, 1] == pytest.approx(np.linalg.norm(ex[4, 4] - ex[3, 4]))
    assert g[0, 1, 0] == 0.0 and g[1, 0, 1] == 0.0 and g[1, 1].tolist() == [0.0, 0.0]


def test_tile_gradients_reproduce_the_literal_weights(small_exemplar):
    """gradients='tile' is the literal formula: the cut equals omega_cuts on the assembled tile alone."""
    a = tilesynth.build_omega(small_exemplar, tileset="4", tile_size=24, seed=1, gradients="tile")
    b = tilesynth.build_omega(small_exemplar, tileset="4", tile_size=24, seed=1, gradients="patch")
    inter, src = intermediate_tiles(small_exemplar, a.genes, a.tile_patches, 24)
    O = np.stack([small_exemplar[r : r + 24, c : c + 24] for r, c in a.match_offsets])
    masks, costs = tilesynth.omega_cuts(inter, O)
    np.testing.assert_array_equal(masks, a.cut_masks)
    np.testing.assert_array_equal(costs, a.cut_costs)
    from tilesynth.builder.omega import patch_gradients

    masks_p, costs_p = tilesynth.omega_cuts(inter, O, intermediate_grad=patch_gradients(small_exemplar, src))
    np.testing.assert_array_equal(masks_p, b.cut_masks)
    np.testing.assert_array_equal(costs_p, b.cut_costs)
    assert a.params["gradients"] == "tile" and b.params["gradients"] == "patch"
    with pytest.raises(tilesynth.ParameterError, match="gradients"):
        tilesynth.build_omega(small_exemplar, tile_size=24, gradients="sobel")
