"""The command line: the documented contract, exit codes, one-line errors, no partial files."""

from __future__ import annotations

import json
import subprocess
import sys

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


@pytest.fixture(scope="module")
def built_file(tmp_path_factory, exemplar_png):
    out = tmp_path_factory.mktemp("tiles") / "ex.tiles"
    assert (
        main(
            [
                "build",
                str(exemplar_png),
                "-o",
                str(out),
                "--set",
                "16a",
                "--tile-size",
                "24",
                "--seed",
                "3",
                "--select",
                "random",
                "--quiet",
            ]
        )
        == 0
    )
    return out


def test_build_synth_info(built_file, tmp_path, capsys):
    out = tmp_path / "t.png"
    mp = tmp_path / "map.npy"
    assert (
        main(
            [
                "synth",
                str(built_file),
                "-o",
                str(out),
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
    for words in (
        "scheme        omega",
        "16a",
        "24x24",
        "seed          3",
        "E ",
        "build time",
        "genes (row, col)",
        "cut cost",
        "selection     random",
    ):
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
        (["synth", "{tiles}", "-o", "{out}", "--size", "-5x70"], "--size"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "1024x"], "--size"),  # "1024" is a square (issue 16)
        (["synth", "{tiles}", "-o", "{out}", "--size", "1e3x10"], "--size"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "10x10x3"], "--size"),
        (["synth", "{tiles}", "-o", "{out}", "--size", ""], "--size"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "100000x100000"], "the output needs about"),
        (
            ["synth", "{tiles}", "-o", "{out}", "--size", "10x10", "--threads", "5000"],
            "--threads: 5000 is out of range: expected an integer in [1, 1024]",
        ),
        (["build", "{ex}", "-o", "{out}", "--set", "n100"], "at most n16"),
        (["build", "{ex}", "-o", "{out}", "--tile-size", "0"], "--tile-size"),
        (["build", "{ex}", "-o", "{out}", "--select", "ga", "--population", "0"], "--population"),
        (["build", "{ex}", "-o", "{out}", "--select", "ais", "--generations", "-1"], "--generations"),
        (["build", "{bomb}", "-o", "{out}"], "exceeds the limit"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "10x10", "--map", "{bigmap}"], "--map"),
        (["synth", "{notimage}", "-o", "{out}", "--size", "10x10"], "not a tilesynth tile set"),
        (["synth", "{tiles}", "-o", "{out}", "--size", "10x10", "--map", "{notimage}"], "--map"),
        (["build", "{ex}", "-o", "{nodir}"], "does not exist"),
        (["frobnicate"], "invalid choice"),
    ],
)
def test_bad_input_is_one_line_exit_2_no_output(args, words, tmp_path, exemplar_png, built_file, capsys):
    notimage = tmp_path / "notimage.png"
    notimage.write_text("this is not a PNG")
    # a writable name: every output is checked before any other work (issue 16); build writes a .tiles (an image
    # name is refused, test_first_contact.py), synth an image
    out = tmp_path / ("out.tiles" if args[0] == "build" else "out.png")
    subst = {
        "{missing}": str(tmp_path / "missing.png"),
        "{notimage}": str(notimage),
        "{out}": str(out),
        "{ex}": str(exemplar_png),
        "{tiles}": str(built_file),
        "{nodir}": str(tmp_path / "no" / "such" / "dir.tiles"),
        "{bomb}": str(_bomb(tmp_path)),
        "{bigmap}": str(_big_map(tmp_path)),
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
    code, err = run_err(
        ["synth", str(built_file), "-o", str(out), "--size", "72x72", "--map", str(mp)], capsys
    )
    assert code == 2 and "index_map" in err and not out.exists()


def test_console_script_and_module_entry(built_file, tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "tilesynth", "info", str(built_file)], capture_output=True, text=True
    )
    assert r.returncode == 0 and "omega" in r.stdout
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "tilesynth",
            "synth",
            str(built_file),
            "-o",
            str(tmp_path / "x.png"),
            "--size",
            "axb",
        ],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_demo(tmp_path):
    d = tmp_path / "demo"
    assert main(["demo", "-o", str(d), "--size", "300x200", "-q"]) == 0
    for name in ("lettuce.tiles", "tiles.png", "texture.png", "texture-map.npy"):
        assert (d / name).is_file(), name
    assert read_png(d / "texture.png").shape[:2] == (200, 300)


def _bomb(tmp_path):
    """A 100-byte PNG that declares 100000 x 100000 pixels."""
    import struct
    import zlib

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
        )

    p = tmp_path / "bomb.png"
    p.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", struct.pack(">IIBBBBB", 100000, 100000, 8, 2, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(b""))
        + chunk(b"IEND", b"")
    )
    return p


def _big_map(tmp_path):
    """A .npy whose header declares a 100000 x 100000 int64 map, with no data after it."""
    p = tmp_path / "big.npy"
    with open(p, "wb") as fh:
        np.lib.format.write_array_header_1_0(
            fh, {"descr": "<i8", "fortran_order": False, "shape": (100000, 100000)}
        )
    return p


def test_internal_error_is_exit_1_with_a_short_message(built_file, tmp_path, monkeypatch, capsys):
    """A Rust panic (here provoked on purpose through the test entry point) is a bug: exit 1, one line."""
    from tilesynth import _core
    from tilesynth.synth import synthesis

    def panicking(*args, **kwargs):
        _core._raise_panic("boom in the kernel")

    monkeypatch.setattr(synthesis, "synthesize", panicking)
    out = tmp_path / "o.png"
    code, err = run_err(["synth", str(built_file), "-o", str(out), "--size", "10x10"], capsys)
    assert code == 1
    assert (
        err.strip()
        .splitlines()[-1]
        .startswith("tilesynth: internal error in _raise_panic: boom in the kernel")
    )
    assert "Traceback" not in err and not out.exists()
    monkeypatch.setattr(synthesis, "synthesize", lambda *a, **k: 1 / 0)  # any other unexpected exception
    code, err = run_err(["synth", str(built_file), "-o", str(out), "--size", "10x10"], capsys)
    assert code == 1 and err.strip() == "tilesynth: internal error: ZeroDivisionError: division by zero"


@pytest.mark.parametrize("when", ["image", "tiles", "map"])
def test_ctrl_c_or_error_while_writing_leaves_no_partial_file(
    built_file, exemplar_png, tmp_path, monkeypatch, capsys, when
):
    """Ctrl-C (KeyboardInterrupt) in the middle of writing an output: exit 130, the output is not created,
    a previous file of that name is left as it was, and no temporary file remains."""
    from PIL import Image as PILImage

    out = tmp_path / {"image": "o.png", "tiles": "o.tiles", "map": "m.npy"}[when]
    out.write_bytes(b"previous content")

    def interrupted(*args, **kwargs):
        target = args[1] if len(args) > 1 and not isinstance(args[1], str) else args[0]
        if hasattr(target, "write"):
            target.write(b"half a file")
        else:
            with open(args[1] if len(args) > 1 else args[0], "ab") as fh:
                fh.write(b"half a file")
        raise KeyboardInterrupt

    if when == "image":
        import tilesynth.io.images

        def encode_interrupted(*a, **k):  # the PNG encoder, interrupted while the temporary file is open
            parts = list(tmp_path.glob(".o.png.*.part"))
            assert len(parts) == 1
            interrupted(parts[0])

        monkeypatch.setattr(tilesynth.io.images, "encode_png", encode_interrupted)
        monkeypatch.setattr(PILImage.Image, "save", lambda self, fp, *a, **k: interrupted(self, fp))
        args = ["synth", str(built_file), "-o", str(out), "--size", "40x40", "--seed", "1"]
    elif when == "tiles":
        import tilesynth.tileset.tilefile

        real = (
            tilesynth.tileset.tilefile._write_array
        )  # the array members are streamed (issue 12), not writestr

        def write_array(zf, name, a, *rest):
            real(zf, name, a, *rest)
            if name == "genes.npy":  # a member of both format versions, written after others
                raise KeyboardInterrupt

        monkeypatch.setattr(tilesynth.tileset.tilefile, "_write_array", write_array)
        args = ["build", str(exemplar_png), "-o", str(out), "--set", "4", "--tile-size", "16", "--seed", "1"]
    else:
        monkeypatch.setattr(np, "save", lambda fh, *a, **k: interrupted(fh))
        args = [
            "synth",
            str(built_file),
            "-o",
            str(tmp_path / "img.png"),
            "--size",
            "40x40",
            "--save-map",
            str(out),
        ]
    code, err = run_err(args, capsys)
    assert code == 130 and "interrupted" in err
    assert out.read_bytes() == b"previous content"
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".part")]


def test_same_seed_same_bytes_across_runs_and_threads(exemplar_png, tmp_path):
    """Two separate runs of the command, at 1 and 2 threads: the tile sets are identical member for member
    except timing.json (which is last, so the files are byte-identical up to it), and the textures and maps
    byte-identical. See tilesynth.tileset.tilefile "Determinism"."""
    import os
    import zipfile

    files = {}
    for threads in ("1", "2"):
        d = tmp_path / threads
        d.mkdir()
        env = {**os.environ, "TILESYNTH_NUM_THREADS": threads}
        for args in (
            [
                "build",
                str(exemplar_png),
                "-o",
                str(d / "t.tiles"),
                "--set",
                "16a",
                "--tile-size",
                "24",
                "--seed",
                "5",
                "--select",
                "ga",
                "--generations",
                "2",
                "--population",
                "6",
                "-q",
            ],
            [
                "synth",
                str(d / "t.tiles"),
                "-o",
                str(d / "t.png"),
                "--size",
                "150x100",
                "--seed",
                "9",
                "--save-map",
                str(d / "m.npy"),
                "-q",
            ],
        ):
            r = subprocess.run(
                [sys.executable, "-m", "tilesynth", *args], capture_output=True, text=True, env=env
            )
            assert r.returncode == 0, r.stderr
        files[threads] = d
    a, b = files["1"], files["2"]
    assert (a / "t.png").read_bytes() == (b / "t.png").read_bytes()
    assert (a / "m.npy").read_bytes() == (b / "m.npy").read_bytes()
    with zipfile.ZipFile(a / "t.tiles") as za, zipfile.ZipFile(b / "t.tiles") as zb:
        assert za.namelist() == zb.namelist() and za.namelist()[-1] == "timing.json"
        for name in za.namelist()[:-1]:
            assert za.read(name) == zb.read(name), name
        offset = za.getinfo("timing.json").header_offset
    assert (a / "t.tiles").read_bytes()[:offset] == (b / "t.tiles").read_bytes()[:offset]
    assert tilesynth.load(a / "t.tiles").content_digest() == tilesynth.load(b / "t.tiles").content_digest()


def test_info_with_a_shorter_mean_history_does_not_fail(tmp_path, capsys) -> None:
    """A tampered file whose selection history holds fewer means than bests (found by the manifest fuzzer):
    ``info`` shows what is there instead of an internal error."""
    import zipfile

    rng = np.random.default_rng(5)
    ts = tilesynth.build_omega(
        rng.random((48, 48, 3), dtype=np.float32),
        tileset="4",
        tile_size=16,
        seed=1,
        select="ga",
        generations=3,
        population=4,
    )
    src = tmp_path / "ga.tiles"
    ts.save(src)
    with zipfile.ZipFile(src) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    manifest = json.loads(members["manifest.json"])
    hist = manifest["params"]["selection"]["history"]
    assert len(hist["best"]) > 1
    hist["mean"] = []
    members["manifest.json"] = json.dumps(manifest).encode()
    bad = tmp_path / "bad.tiles"
    with zipfile.ZipFile(bad, "w", zipfile.ZIP_DEFLATED) as zo:
        for n, b in members.items():
            zo.writestr(n, b)
    assert main(["info", str(bad)]) in (0, 2)
    out, err = capsys.readouterr()
    assert "internal error" not in err
    assert "convergence" not in out or " / ?" in out
