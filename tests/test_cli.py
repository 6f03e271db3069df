"""The command line: the documented contract, exit codes, one-line errors, no partial files."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

import tilesynth
from tilesynth.cli import main


def read_png(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im)


@pytest.fixture(scope="module")
def exemplar_png(tmp_path_factory, small_exemplar):
    p = tmp_path_factory.mktemp("in") / "ex.png"
    tilesynth.save_image(p, small_exemplar)
    return p


@pytest.fixture(scope="module")
def built_file(tmp_path_factory, exemplar_png):
    out = tmp_path_factory.mktemp("tiles") / "ex.tiles"
    assert main(["build", str(exemplar_png), "-o", str(out), "--set", "16a", "--tile-size", "24", "--seed", "3",
                 "--quiet"]) == 0
    return out


def test_build_synth_info(built_file, tmp_path, capsys):
    out = tmp_path / "t.png"
    mp = tmp_path / "map.npy"
    assert main(["synth", str(built_file), "-o", str(out), "--size", "100x70", "--seed", "5", "--save-map", str(mp),
                 "-q"]) == 0
    im = read_png(out)
    assert im.shape == (70, 100, 3) and im.dtype == np.uint8
    imap = np.load(mp)
    assert imap.shape == (3, 5)
    # the saved map reproduces the image exactly
    out2 = tmp_path / "t2.png"
    assert main(["synth", str(built_file), "-o", str(out2), "--size", "100x70", "--map", str(mp), "-q"]) == 0
    np.testing.assert_array_equal(read_png(out2), im)
    capsys.readouterr()
    assert main(["info", str(built_file)]) == 0
    text = capsys.readouterr().out
    for words in ("scheme        omega", "16a", "24x24", "seed          3", "E ", "build time", "genes (row, col)",
                  "cut cost", "selection     random"):
        assert words in text, words
    assert main(["info", str(built_file), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["n_tiles"] == 16 and data["params"]["seed"] == 3 and len(data["per_tile"]) == 16
    assert len(data["genes"]) == 4 and "total_s" in data["timing"]


def test_sheet(built_file, tmp_path):
    out = tmp_path / "sheet.png"
    assert main(["sheet", str(built_file), "-o", str(out)]) == 0
    assert read_png(out).shape[1] > 4 * 24


def run_err(args, capsys):
    code = main(args)
    err = capsys.readouterr().err
    return code, err


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["build", "{missing}", "-o", "{out}"], "no such file"),
        (["build", "{notimage}", "-o", "{out}"], "not a readable image"),
        (["build", "{ex}", "-o", "{out}", "--tile-size", "25"], "tile_size = 25: must be even"),
        (["build", "{ex}", "-o", "{out}", "--tile-size", "500"], "larger than the exemplar"),
        (["build", "{ex}", "-o", "{out}", "--set", "17"], "unknown tile set '17'"),
        (["build", "{ex}", "-o", "{out}", "--tile-size", "-4"], "--tile-size"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "100by70"], "--size"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "0x70"], "--size"),
        (["synth", "{notimage}", "-o", "{out}", "--size", "10x10"], "not a tilesynth tile set"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "10x10", "--map", "{notimage}"], "--map"),
        (["build", "{ex}", "-o", "{nodir}"], "does not exist"),
        (["frobnicate"], "invalid choice"),
    ],
)
def test_bad_input_is_one_line_exit_2_no_output(args, words, tmp_path, exemplar_png, built_file, capsys):
    notimage = tmp_path / "notimage.png"
    notimage.write_text("this is not a PNG")
    out = tmp_path / "out.file"
    subst = {
        "{missing}": str(tmp_path / "missing.png"),
        "{notimage}": str(notimage),
        "{out}": str(out),
        "{ex}": str(exemplar_png),
        "{tiles}": str(built_file),
        "{nodir}": str(tmp_path / "no" / "such" / "dir.tiles"),
    }
    code, err = run_err([subst.get(a, a) for a in args], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert words in lines[0]
    assert "Traceback" not in err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_bad_map_is_rejected_with_position(built_file, tmp_path, capsys):
    ts = tilesynth.load(built_file)
    _, imap = tilesynth.synthesize(ts, 72, 72, seed=1)
    bad = imap.copy()
    defn = ts.definition
    # replace one interior cell by a tile whose left side does not match
    for k in range(ts.n_tiles):
        if defn.left_key(k) != defn.left_key(int(imap[1, 1])):
            bad[1, 1] = k
            break
    mp = tmp_path / "bad.npy"
    np.save(mp, bad)
    out = tmp_path / "o.png"
    code, err = run_err(["synth", str(built_file), "-o", str(out), "--size", "72x72", "--map", str(mp)], capsys)
    assert code == 2 and "index_map" in err and not out.exists()


def test_console_script_and_module_entry(built_file, tmp_path):
    r = subprocess.run([sys.executable, "-m", "tilesynth", "info", str(built_file)], capture_output=True, text=True)
    assert r.returncode == 0 and "omega" in r.stdout
    r = subprocess.run([sys.executable, "-m", "tilesynth", "synth", str(built_file), "-o", str(tmp_path / "x.png"),
                        "--size", "axb"], capture_output=True, text=True)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_demo(tmp_path):
    d = tmp_path / "demo"
    assert main(["demo", "-o", str(d), "--size", "300x200", "-q"]) == 0
    for name in ("lettuce.tiles", "tiles.png", "texture.png", "texture-map.npy"):
        assert (d / name).is_file(), name
    assert read_png(d / "texture.png").shape[:2] == (200, 300)
