"""The command line and the golden results for the Wang schemes (build / synth / info / sheet, one-line errors)."""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np
import pytest
from PIL import Image

import tilesynth
from tilesynth.cli.main import main


def read_png(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im)


@pytest.fixture(scope="module")
def exemplar_png(tmp_path_factory, small_exemplar):
    p = tmp_path_factory.mktemp("in") / "ex.png"
    tilesynth.save_image(p, small_exemplar)
    return p


BUILDS = {
    "wang8": ["--scheme", "wang"],
    "wang18-graph": ["--scheme", "wang", "--set", "wang18", "--cut", "graph"],
    "wang8-pinned": ["--scheme", "wang", "--corners", "pinned", "--overlap", "6"],
    "burke": ["--scheme", "wang", "--samples", "square"],
    "swang": ["--scheme", "swang"],
    "swang-cut": ["--scheme", "swang", "--supplementary", "cut"],
}


@pytest.mark.parametrize("name", sorted(BUILDS))
def test_build_synth_info_sheet(name, exemplar_png, tmp_path, capsys):
    out = tmp_path / f"{name}.tiles"
    sheet = tmp_path / "sheet.png"
    args = [
        "build",
        str(exemplar_png),
        "-o",
        str(out),
        "--tile-size",
        "24",
        "--seed",
        "3",
        "--sheet",
        str(sheet),
    ]
    assert main(args + BUILDS[name]) == 0
    err = capsys.readouterr().err
    assert ("s-Wang tiles" if "swang" in name else "Wang tiles") in err
    ts = tilesynth.load(out)
    scheme = "swang" if "swang" in name else "wang"
    assert ts.scheme == scheme and ts.tile_size == 24
    assert ts.n_tiles == (18 if "18" in name else 8)
    assert read_png(sheet).shape[1] > 2 * 24
    png, mp = tmp_path / "t.png", tmp_path / "map.npy"
    assert (
        main(
            [
                "synth",
                str(out),
                "-o",
                str(png),
                "--size",
                "100x70",
                "--seed",
                "5",
                "--save-map",
                str(mp),
                "-q",
            ]
        )
        == 0
    )
    assert read_png(png).shape == (70, 100, 3)
    png2 = tmp_path / "t2.png"
    assert main(["synth", str(out), "-o", str(png2), "--size", "100x70", "--map", str(mp), "-q"]) == 0
    np.testing.assert_array_equal(read_png(png2), read_png(png))
    tilesynth.validate_index_map(ts.definition, np.load(mp))
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    for words in (
        f"scheme        {scheme}",
        "N E S W",
        "24x24",
        "seed          3",
        "E ",
        "genes (row, col): R=(",
    ):
        assert words in text, words
    if scheme == "wang":
        assert "D_boundary NE / ES / SW / WN" in text and "ω=0.8" in text
    else:
        assert "supplementary" in text and "initial tiles" in text
    assert main(["info", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["scheme"] == scheme and len(data["per_tile"]) == ts.n_tiles
    assert main(["sheet", str(out), "-o", str(tmp_path / "s2.png")]) == 0


def test_ga_from_the_cli(exemplar_png, tmp_path, capsys):
    out = tmp_path / "ga.tiles"
    assert (
        main(
            [
                "build",
                str(exemplar_png),
                "-o",
                str(out),
                "--scheme",
                "wang",
                "--tile-size",
                "24",
                "--seed",
                "1",
                "--select",
                "ga",
                "--generations",
                "3",
                "--population",
                "8",
                "-q",
            ]
        )
        == 0
    )
    ts = tilesynth.load(out)
    sel = ts.params["selection"]
    assert sel["method"] == "ga" and sel["params"]["population"] == 8 and sel["params"]["stagnation"] == 8
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    assert "selection     ga" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--scheme", "wang", "--set", "16a"], "--scheme wang needs an edge-coloured set"),
        (["--set", "wang8"], "--scheme omega needs a corner set"),
        (["--scheme", "wang", "--set", "wang9"], "unknown tile set 'wang9'"),
        (["--scheme", "swang", "--cut", "graph"], "--cut: not used with --scheme swang"),
        (["--cut", "graph"], "--cut: not used with --scheme omega"),
        (["--scheme", "wang", "--literal-border"], "--literal-border: not used with --scheme wang"),
        (["--scheme", "wang", "--gradients", "tile"], "--gradients: not used with --scheme wang"),
        (["--scheme", "wang", "--overlap", "5"], "overlap = 5: must be even"),
        (["--scheme", "wang", "--samples", "square", "--corners", "free"], "square samples"),
        (["--scheme", "wang", "--tile-size", "90", "--corners", "free"], "sample squares"),
        (["--scheme", "hex"], "invalid choice"),
    ],
)
def test_bad_input_is_one_line_exit_2_no_output(args, words, exemplar_png, tmp_path, capsys):
    out = tmp_path / "out.tiles"
    base = ["build", str(exemplar_png), "-o", str(out)]
    if "--tile-size" not in args:
        base += ["--tile-size", "24"]
    code = main(base + args)
    err = capsys.readouterr().err
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert words in lines[0]
    assert not out.exists()


# --------------------------------------------------------------------------------------------------------------
# Golden results (fixed inputs and seeds, 1 and 2 threads). The tiles are exemplar pixels chosen by exact
# comparisons (float64 DP in a fixed order, exact SSD re-ranking, exact max-flow), so the bytes do not depend on
# the platform or the thread count. To update on purpose: rerun with TILESYNTH_PRINT_GOLDEN=1, look at the
# sheets, paste the printed hashes and say why in the CHANGELOG.

# Issue 14 changed the defaults of both Wang schemes (pinned corners, border-aware random draws: border_tries=16),
# so the three digests of the defaults changed once; the "-literal" entries build the old defaults by name
# (corners="free", border_tries=1; s-Wang border_tries=1) and keep the digests from before, byte for byte.
GOLDEN = {
    "swang": ("477e1d14a7c58532aaca5992", "4ce46128f73672be436f948b"),
    "wang-dp": ("7e5bf76a84c7bee48421664d", "fcccb6aba5b08390c9b24bcb"),
    "wang-graph": ("77c895cd5bb934deab7a6230", "6123c7355d654560c3f5f0bf"),
    "swang-literal": ("392ddd221fcd38011c88b3c9", "d70990fa7e340ef28acdfcce"),
    "wang-dp-literal": ("1e40980721572d0846fd33d9", "a562c8d1bbcf21d8406af12e"),
    "wang-graph-literal": ("e2b6d0c574df4e29fa7140a9", "8b94266948d53e7008ef3404"),
}

_COHEN = {"corners": "free", "border_tries": 1}
GOLDEN_BUILDS = {
    "wang-dp": lambda ex, t: tilesynth.build_wang(ex, tile_size=32, seed=2026, threads=t),
    "wang-graph": lambda ex, t: tilesynth.build_wang(
        ex, tileset="wang18", tile_size=32, seed=2026, cut="graph", threads=t
    ),
    "swang": lambda ex, t: tilesynth.build_swang(ex, tile_size=32, seed=2026, threads=t),
    "wang-dp-literal": lambda ex, t: tilesynth.build_wang(ex, tile_size=32, seed=2026, threads=t, **_COHEN),
    "wang-graph-literal": lambda ex, t: tilesynth.build_wang(
        ex, tileset="wang18", tile_size=32, seed=2026, cut="graph", threads=t, **_COHEN
    ),
    "swang-literal": lambda ex, t: tilesynth.build_swang(
        ex, tile_size=32, seed=2026, threads=t, border_tries=1
    ),
}


def digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:24]


@pytest.mark.parametrize("name", sorted(GOLDEN))
@pytest.mark.parametrize("threads", [1, 2])
def test_golden(name, threads, small_exemplar):
    ts = GOLDEN_BUILDS[name](small_exemplar, threads)
    img, _ = tilesynth.synthesize(ts, 200, 150, seed=7, dtype=np.uint8, threads=threads)
    got = (digest(ts.tiles), digest(img))
    if os.environ.get("TILESYNTH_PRINT_GOLDEN"):
        print(f'\n    "{name}": ("{got[0]}", "{got[1]}"),')
    assert got == GOLDEN[name]
