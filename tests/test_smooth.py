"""Poisson smoothing of ω-tiles (``build_omega(smooth=True)``, ``tilesynth build --smooth``): the region inside
each cut is the scipy solution of the guided-interpolation system, everything else (the tile border above all)
is the unsmoothed tile bit for bit, and tilings stay seamless."""

from __future__ import annotations

import numpy as np
import pytest
from test_poisson import scipy_solution

import tilesynth as ts
from tilesynth.builder.omega import smooth_tiles
from tilesynth.cli.main import main


@pytest.fixture(scope="module")
def pair(small_exemplar):
    plain = ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=11)
    smoothed = ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=11, smooth=True)
    return plain, smoothed


def _region(ts_: ts.TileSet) -> np.ndarray:
    m = ts_.cut_masks.copy()
    m[:, 0, :] = m[:, -1, :] = m[:, :, 0] = m[:, :, -1] = False
    return m


def test_only_the_region_inside_the_cut_changes(pair):
    plain, smoothed = pair
    # same construction: genes, matching patches, cuts, provenance
    for name in ("genes", "match_offsets", "cut_masks", "cut_costs", "source", "D"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(smoothed, name), err_msg=name)
    assert smoothed.E == plain.E
    outside = ~_region(smoothed)
    np.testing.assert_array_equal(smoothed.tiles[outside], plain.tiles[outside])
    inside = _region(smoothed)
    assert inside.any()
    changed = np.abs(smoothed.tiles - plain.tiles).max(-1)[inside]
    assert np.mean(changed > 1e-4) > 0.5  # the correction reaches most of the region, not just the curve


def test_region_is_the_scipy_solution(pair, small_exemplar):
    plain, smoothed = pair
    ex = smoothed.exemplar
    n = smoothed.tile_size
    for t in range(smoothed.n_tiles):
        r, c = smoothed.match_offsets[t]
        o = ex[r : r + n, c : c + n]
        want = scipy_solution(plain.tiles[t], o, _region(smoothed)[t])
        want = np.clip(want, 0, 1)
        np.testing.assert_allclose(smoothed.tiles[t], want, atol=2e-5, rtol=0, err_msg=f"tile {t}")
    info = smoothed.params["smooth"]
    assert info["residual_max"] <= 1e-6 and 1 <= info["iterations_max"] <= 30
    assert info["unknowns"] == int(_region(smoothed).sum())
    assert 0 <= info["clipped"] < info["unknowns"] * smoothed.channels
    assert "smooth" not in plain.params  # unsmoothed files are unchanged (golden digests)


def test_literal_border_keeps_every_border_pixel(small_exemplar):
    plain = ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=5, keep_border=False)
    smoothed = ts.build_omega(
        small_exemplar, tileset="16a", tile_size=32, seed=5, keep_border=False, smooth=True
    )
    ring = np.ones((32, 32), bool)
    ring[1:-1, 1:-1] = False
    assert (plain.cut_masks[:, ring]).any(), (
        "the literal cut should reach the border for this test to mean much"
    )
    np.testing.assert_array_equal(smoothed.tiles[:, ring], plain.tiles[:, ring])


def test_smoothed_tilings_are_seamless(pair):
    """Every pair of touching tiles in a synthesis agrees on their shared edge exactly as the plain set does:
    the border ring is untouched, so the tile edges are the same exemplar content."""
    plain, smoothed = pair
    a, imap = ts.synthesize(plain, 256, 256, seed=3)
    b, imap2 = ts.synthesize(smoothed, 256, 256, seed=3)
    np.testing.assert_array_equal(imap, imap2)
    n = smoothed.tile_size
    for k in range(n, 256, n):
        np.testing.assert_array_equal(b[:, k - 1 : k + 1], a[:, k - 1 : k + 1])
        np.testing.assert_array_equal(b[k - 1 : k + 1, :], a[k - 1 : k + 1, :])


def test_smooth_tiles_never_modifies_inputs_and_ignores_threads(pair):
    plain, smoothed = pair
    ex, n = smoothed.exemplar, smoothed.tile_size
    o = np.stack([ex[r : r + n, c : c + n] for r, c in smoothed.match_offsets])
    inter = plain.tiles.copy()
    masks = smoothed.cut_masks.copy()
    before = (inter.copy(), o.copy(), masks.copy())
    one, i1 = smooth_tiles(inter, o, masks, threads=1)
    two, i2 = smooth_tiles(inter, o, masks, threads=2)
    assert one.tobytes() == two.tobytes() and i1 == i2
    for x, y in zip(before, (inter, o, masks)):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(one, smoothed.tiles)


def test_smooth_round_trips_and_rejects_non_bools(pair, tmp_path, small_exemplar):
    _, smoothed = pair
    p = tmp_path / "s.tiles"
    smoothed.save(p)
    back = ts.load(p)
    assert back.params["smooth"] == smoothed.params["smooth"]
    np.testing.assert_array_equal(back.tiles, smoothed.tiles)
    with pytest.raises(ts.ParameterError, match="smooth = 'yes'"):
        ts.build_omega(small_exemplar, tileset="4", tile_size=32, seed=1, smooth="yes")


def test_cli_build_smooth(tmp_path, lettuce_path, capsys):
    out = tmp_path / "s.tiles"
    assert (
        main(
            [
                "build",
                str(lettuce_path),
                "--set",
                "8",
                "--tile-size",
                "64",
                "--seed",
                "2",
                "--smooth",
                "-o",
                str(out),
            ]
        )
        == 0
    )
    assert "Poisson-smoothed" in capsys.readouterr().err
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "smoothing     Poisson" in text and "residual <=" in text
    assert ts.load(out).params["smooth"]["residual_max"] <= 1e-6
    code = main(["build", str(lettuce_path), "--scheme", "wang", "--smooth", "-o", str(tmp_path / "w.tiles")])
    assert code == 2
    assert "--smooth: not used with --scheme wang" in capsys.readouterr().err


def test_info_refuses_a_tampered_smooth_record(pair, tmp_path, capsys):
    """A smoothing record of the wrong types is refused by the manifest schema (issue 16: every reader applies
    the same rules), exit 2 naming the field; a record with fields missing still shows them as "?"."""
    import dataclasses

    _, smoothed = pair
    bad = dataclasses.replace(
        smoothed, params={**smoothed.params, "smooth": {"residual_max": "x", "unknowns": None}}
    )
    p = tmp_path / "bad.tiles"
    bad.save(p)
    assert main(["info", str(p)]) == 2
    assert "params.smooth.unknowns" in capsys.readouterr().err
    partial = dataclasses.replace(smoothed, params={**smoothed.params, "smooth": {"unknowns": 5}})
    partial.save(p)
    assert main(["info", str(p)]) == 0
    assert "residual <= ?" in capsys.readouterr().out
