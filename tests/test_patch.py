"""The patch baseline scheme (random exemplar crops cut into a corner layout): build, file, synth, CLI."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.builder.genes.draws import energy
from tilesynth.cli.main import main


@pytest.fixture(scope="module")
def patch_set(small_exemplar):
    return tilesynth.build(small_exemplar, scheme="patch", tileset="16a", tile_size=24, seed=3)


def test_builds_a_corner_set_of_random_crops(patch_set, small_exemplar):
    ts = patch_set
    assert ts.scheme == "patch" and ts.n_tiles == 16 and ts.tile_size == 24
    assert ts.layout["kind"] == "corner"
    n = ts.tile_size
    h, w = small_exemplar.shape[:2]
    assert (ts.match_offsets >= 0).all() and (ts.match_offsets[:, 0] <= h - n).all()
    assert (ts.match_offsets[:, 1] <= w - n).all()
    # the crops are random, not the best matches: at least two tiles have different crops
    assert len({tuple(o) for o in ts.match_offsets.tolist()}) > 1
    # inside the cut every pixel comes from the crop, outside from the intermediate tile's patches
    yy, xx = np.mgrid[0:n, 0:n]
    for k in range(ts.n_tiles):
        r, c = ts.match_offsets[k]
        m = ts.cut_masks[k]
        assert m.any() and not m.all()
        np.testing.assert_array_equal(ts.source[k][m], np.stack([yy + r, xx + c], -1)[m])
        np.testing.assert_array_equal(ts.tiles[k], small_exemplar[ts.source[k, ..., 0], ts.source[k, ..., 1]])


def test_objective_is_the_ssd_to_the_crops(patch_set):
    ts = patch_set
    n = ts.tile_size
    inter, _ = tilesynth.builder.omega.intermediate_tiles(ts.exemplar, ts.genes, ts.tile_patches, n)
    crops = np.stack([ts.exemplar[r : r + n, c : c + n] for r, c in ts.match_offsets])
    D = ((inter.astype(np.float64) - crops) ** 2).sum(axis=(1, 2, 3))
    np.testing.assert_allclose(ts.D, D, rtol=1e-12)
    assert ts.E == pytest.approx(energy(D))


def test_border_ring_is_that_of_omega_tiles_of_the_same_genes(patch_set, small_exemplar):
    """Seamless by the ω construction: with the border ring tied to the intermediate tile, every tile's border
    is exactly the ω-tile's border for the same genes (whatever the crop)."""
    om = tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=24, genes=patch_set.genes)
    ring = np.ones((24, 24), bool)
    ring[1:-1, 1:-1] = False
    assert not patch_set.cut_masks[:, ring].any()
    np.testing.assert_array_equal(patch_set.tiles[:, ring], om.tiles[:, ring])


def test_same_seed_same_bytes_other_seed_other_crops(patch_set, small_exemplar):
    again = tilesynth.build(small_exemplar, scheme="patch", tileset="16a", tile_size=24, seed=3)
    assert again.content_digest() == patch_set.content_digest()
    other = tilesynth.build(small_exemplar, scheme="patch", tileset="16a", tile_size=24, seed=4)
    assert not np.array_equal(other.match_offsets, patch_set.match_offsets)


def test_file_round_trip_and_synthesis(patch_set, tmp_path):
    p = tmp_path / "p.tiles"
    patch_set.save(p)
    back = tilesynth.load(p)
    assert back.scheme == "patch" and back.content_digest() == patch_set.content_digest()
    img, imap = tilesynth.synthesize(back, 100, 70, seed=1)
    assert img.shape == (70, 100, 3) and imap.shape == (3, 5)


def test_no_selection(small_exemplar):
    with pytest.raises(tilesynth.ParameterError, match="no objective"):
        tilesynth.build(small_exemplar, scheme="patch", tile_size=24, seed=1, select="ga")
    with pytest.raises(ValueError, match="unknown tile set 'wang8'"):  # a corner scheme, as build_omega
        tilesynth.build(small_exemplar, scheme="patch", tileset="wang8", tile_size=24, seed=1)


def test_cli_build_synth_info_sheet_report(small_exemplar, tmp_path, capsys):
    ex = tmp_path / "ex.png"
    tilesynth.save_image(ex, small_exemplar)
    out = tmp_path / "p.tiles"
    assert main(["build", str(ex), "-o", str(out), "--scheme", "patch", "--tile-size", "24", "--seed", "2",
                 "--literal-border", "-q"]) == 0  # fmt: skip
    ts = tilesynth.load(out)
    assert ts.scheme == "patch" and ts.params["keep_border"] is False
    assert (
        main(["synth", str(out), "-o", str(tmp_path / "s.png"), "--size", "90x60", "--seed", "1", "-q"]) == 0
    )
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "scheme        patch" in text and "random exemplar crop" in text and "TL BL TR BR" in text
    assert main(["sheet", str(out), "-o", str(tmp_path / "sheet.png")]) == 0
    assert main(["report", str(out), "-o", str(tmp_path / "rep"), "--size", "96x96", "-q"]) == 0
    assert (tmp_path / "rep" / "index.html").is_file()
    # an option of another scheme is refused, naming the schemes that have it
    assert (
        main(["build", str(ex), "-o", str(tmp_path / "x.tiles"), "--scheme", "patch", "--match", "best-cut"])
        == 2
    )
    assert "--match: not used with --scheme patch (only with omega)" in capsys.readouterr().err
    assert not (tmp_path / "x.tiles").exists()
