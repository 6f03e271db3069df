"""The visual report and the ``metrics`` / ``report`` commands."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image

import tilesynth as ts
from tilesynth.cli.main import main
from tilesynth.measure import metrics as M
from tilesynth.measure import report as R


@pytest.fixture(scope="module")
def ga_set(small_exemplar):
    return ts.build_omega(
        small_exemplar, tileset="16a", tile_size=24, select="ga", generations=4, population=8, seed=2
    )


@pytest.fixture(scope="module")
def random_set(small_exemplar):
    return ts.build_omega(small_exemplar, tileset="16a", tile_size=24, seed=2, select="random")


def png(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def test_report_files_page_and_metrics(ga_set, tmp_path):
    out = tmp_path / "rep"
    res = R.write_report(ga_set, out, width=120, height=96, seed=3, name="small.tiles")
    names = {p.name for p in out.iterdir()}
    assert names == {
        "tiles.png",
        "sample.png",
        "sample-borders.png",
        "seams.png",
        "coherence.png",
        "convergence.png",
        "metrics.json",
        "index.html",
    }
    # the sample is the synthesis with that seed, and the metrics are those of tileset_metrics
    img, imap = ts.synthesize(ga_set, 120, 96, seed=3, dtype=np.uint8)
    np.testing.assert_array_equal(png(out / "sample.png"), img)
    saved = json.loads((out / "metrics.json").read_text())
    want = M.tileset_metrics(ga_set, 120, 96, seed=3)
    for key in ("seam", "coverage", "objective"):
        assert saved[key] == want[key]
    assert saved["coherence"]["energy"] == want["coherence"]["energy"]
    # figures have the sizes they should
    assert png(out / "sample-borders.png").shape == (96, 120, 3)
    assert png(out / "seams.png").shape[1] >= 120 and png(out / "seams.png").shape[0] > 96
    assert png(out / "convergence.png").shape == (400, 720, 3)
    page = (out / "index.html").read_text(encoding="utf-8")
    srcs = re.findall(r'src="([^"]+)"', page)
    assert set(srcs) == {
        "tiles.png",
        "sample.png",
        "sample-borders.png",
        "seams.png",
        "coherence.png",
        "convergence.png",
    }
    assert all((out / s).is_file() for s in srcs)
    # offline: no remote resource, no script
    assert "http://" not in page and "https://" not in page and "<script" not in page.lower()
    for words in (
        "border seam score",
        "coherence energy",
        "coverage",
        "repetition peak",
        "f = 1/E",
        "reference: random placement",
        "small.tiles",
        "Per tile",
        "cut seam",
    ):
        assert words in page, words
    assert page.count("<tr><td class=num>") == ga_set.n_tiles  # one row per tile
    assert res["files"]["page"] == str(out / "index.html")


def test_report_without_history_or_borders(random_set, tmp_path):
    res = R.write_report(random_set, tmp_path, width=64, height=64, borders=False)
    names = {p.name for p in tmp_path.iterdir()}
    assert "convergence.png" not in names and "sample-borders.png" not in names
    assert any("No convergence chart" in n for n in res["notes"])
    assert "No convergence chart" in (tmp_path / "index.html").read_text(encoding="utf-8")


@pytest.mark.parametrize("scheme", ["wang", "swang"])
def test_report_of_wang_tiles(small_exemplar, tmp_path, scheme):
    """The per-tile table of Wang sets (edge colours, no variants): was a KeyError 'corners' after every figure
    had been written (``tilesynth report`` of a Wang set exited 1)."""
    tset = ts.build(small_exemplar, scheme=scheme, tile_size=16, seed=1)
    R.write_report(tset, tmp_path, width=64, height=48)
    page = (tmp_path / "index.html").read_text(encoding="utf-8")
    assert "<th>N E S W</th>" in page and "<th>variant</th>" not in page and "edge colours" in page
    assert page.count("<tr><td class=num>") == tset.n_tiles
    assert "<td>R Y R Y</td>" in page  # tile 0 of wang8: <N=R, E=Y, S=R, W=Y>
    tset.save(tmp_path / "w.tiles")
    assert (
        main(["report", str(tmp_path / "w.tiles"), "-o", str(tmp_path / "cli"), "--size", "40x40", "-q"]) == 0
    )


def test_report_bad_output_and_name(random_set, tmp_path):
    """Found by the fuzzers: an ``out_dir`` that is a file (FileExistsError) or lies under one
    (NotADirectoryError), and a name that is not a string (AttributeError once every file but the page had been
    written). Checked before anything is written."""
    (tmp_path / "f").write_text("x")
    with pytest.raises(ts.ParameterError, match="out_dir = .*f': exists and is not a directory"):
        R.write_report(random_set, tmp_path / "f", width=48, height=48)
    with pytest.raises(ts.ParameterError, match="out_dir = .*sub': cannot create the directory"):
        R.write_report(random_set, tmp_path / "f" / "sub", width=48, height=48)
    with pytest.raises(TypeError, match="name = 5: expected a string or None"):
        R.write_report(random_set, tmp_path / "r", width=48, height=48, name=5)
    with pytest.raises(TypeError, match="out_dir = None: expected a path"):
        R.write_report(random_set, None, width=48, height=48)
    with pytest.raises(ts.ParameterError, match="width = 0"):
        R.write_report(random_set, tmp_path / "r", width=0, height=48)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]  # nothing created


def test_report_of_a_sample_one_tile_wide(random_set, tmp_path):
    # no vertical border: the seam heat-map smoothed an empty profile (numpy's "Cannot apply_along_axis")
    res = R.write_report(random_set, tmp_path, width=24, height=72)
    assert res["metrics"]["seam"]["ratio_x"] is None and (tmp_path / "seams.png").is_file()


def test_sample_with_borders_blends_only_the_grid(rng):
    img = rng.random((20, 30, 3), dtype=np.float32)
    out = R.sample_with_borders(img, 8, colour=(255, 0, 255), alpha=0.5)
    plain = np.rint(img * 255).astype(np.uint8)
    grid = np.zeros((20, 30), bool)
    grid[:, [8, 16, 24]] = True
    grid[[8, 16], :] = True
    np.testing.assert_array_equal(out[~grid], plain[~grid])
    want = np.rint(plain[grid].astype(float) * 0.5 + np.array([255, 0, 255]) * 0.5).astype(np.uint8)
    np.testing.assert_array_equal(out[grid], want)


def test_seam_heatmap_colours_a_seam_with_the_top_colour():
    n = 10
    saw = np.tile((0.05 * (np.arange(40) % n))[None, :, None], (30, 1, 3)).astype(np.float32)
    fig = np.asarray(R.seam_heatmap(saw, n))
    top = R.colormap(np.array(1.0))
    # vertical borders at x = 10, 20, 30: 2 pixels either side; the seam ratio (n-1)^2 = 81 is far above 3
    for x in (8, 9, 10, 11, 18, 29):
        assert (fig[5, x] == top).all(), x
    assert not (fig[5, 5] == top).all()


def test_colormap_and_chart():
    np.testing.assert_array_equal(
        R.colormap(np.array([0.0, 1.0, -3.0, 7.0])),
        [[68, 1, 84], [253, 231, 37], [68, 1, 84], [253, 231, 37]],
    )
    im = np.asarray(R.convergence_chart([5.0, 4.0, 3.5], [9.0, 7.0, 6.0], "t"))
    assert im.shape == (400, 720, 3)
    blue = ((im == [30, 90, 200]).all(axis=2)).sum()
    orange = ((im == [230, 120, 20]).all(axis=2)).sum()
    assert blue > 50 and orange > 50


# ---------------------------------------------------------------------------------------------------- CLI
@pytest.fixture(scope="module")
def files(tmp_path_factory, ga_set, small_exemplar):
    d = tmp_path_factory.mktemp("m")
    ga_set.save(d / "s.tiles")
    ts.save_image(d / "ex.png", small_exemplar)
    img, _ = ts.synthesize(ga_set, 72, 48, seed=4)
    ts.save_image(d / "out.png", img)
    return d


def test_cli_metrics_tileset(files, capsys):
    assert main(["metrics", str(files / "s.tiles"), "--size", "96x72", "--seed", "5", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    want = M.tileset_metrics(ts.load(files / "s.tiles"), 96, 72, seed=5)
    assert data["seam"] == want["seam"] and data["objective"] == want["objective"]
    assert data["sample"]["seed"] == 5 and data["input"]["path"].endswith("s.tiles")
    assert main(["metrics", str(files / "s.tiles"), "--size", "64x64"]) == 0
    text = capsys.readouterr().out
    assert "seam score" in text and "objective" in text and "seed 1" in text  # documented default seed


def test_cli_metrics_image(files, capsys):
    assert main(["metrics", str(files / "out.png"), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["seam"] is None and data["coherence"] is None and len(data["notes"]) == 3
    assert (
        main(
            [
                "metrics",
                str(files / "out.png"),
                "--tile-size",
                "24",
                "--exemplar",
                str(files / "ex.png"),
                "--json",
            ]
        )
        == 0
    )
    data = json.loads(capsys.readouterr().out)
    img, _ = ts.synthesize(ts.load(files / "s.tiles"), 72, 48, seed=4)
    # the PNG round trip of an 8-bit exemplar is exact, so the image's numbers are those of the array
    assert data["seam"]["score"] == pytest.approx(M.seam_score(img, 24).score)
    assert data["coherence"]["exact_copies"] > 0


@pytest.mark.parametrize(
    "argv,words",
    [
        (["metrics", "nope.tiles"], "no such file"),
        (["metrics", "{d}/s.tiles", "--tile-size", "8"], "--tile-size and --exemplar are for images"),
        (["metrics", "{d}/out.png", "--seed", "3"], "--size and --seed are for tile sets"),
        (["metrics", "{d}/out.png", "--exemplar", "{d}/missing.png"], "--exemplar"),
        (["metrics", "{d}/out.png", "--tile-size", "100"], "tile_size = 100"),
        (["report", "{d}/out.png", "-o", "{d}/r"], "not a tilesynth tile set"),
    ],
)
def test_cli_errors_are_one_line(files, capsys, argv, words):
    argv = [a.format(d=files) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1


def test_cli_report(files, tmp_path, capsys):
    out = tmp_path / "a" / "rep"
    assert (
        main(
            [
                "report",
                str(files / "s.tiles"),
                "-o",
                str(out),
                "--size",
                "72x72",
                "--seed",
                "2",
                "--no-borders",
                "-q",
            ]
        )
        == 0
    )
    assert (out / "index.html").is_file() and not (out / "sample-borders.png").exists()
    assert png(out / "sample.png").shape == (72, 72, 3)
