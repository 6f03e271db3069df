"""No output may be an input or another output (issue 16): the rule of tilesynth.io.paths, in general (property
tests over generated path sets with symbolic and hard links) and on every CLI example of the issue."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import tilesynth
from tilesynth.cli.main import main
from tilesynth.errors import ParameterError
from tilesynth.io.paths import check_paths

# ------------------------------------------------------------------------------------------ the rule itself
N_FILES, N_MISSING = 3, 2


def _universe(root: Path) -> dict[str, tuple]:
    """Create files and aliases under ``root``; return name -> the file it means (the oracle)."""
    (root / "sub").mkdir()
    (root / "other").mkdir()
    os.symlink(root / "sub", root / "linkdir")
    names: dict[str, tuple] = {}
    for i in range(N_FILES):
        f = root / "sub" / f"f{i}"
        f.write_bytes(b"x")
        names[f"sub/f{i}"] = ("f", i)
        names[f"./sub/f{i}"] = ("f", i)
        names[f"other/../sub/f{i}"] = ("f", i)
        names[f"linkdir/f{i}"] = ("f", i)
        os.symlink(f, root / f"sym{i}")
        names[f"sym{i}"] = ("f", i)
        os.symlink(f"sym{i}", root / f"symsym{i}")  # a link to a link
        names[f"symsym{i}"] = ("f", i)
        os.link(f, root / "other" / f"hard{i}")
        names[f"other/hard{i}"] = ("f", i)
        os.link(f, root / f"hard{i}")
        names[f"hard{i}"] = ("f", i)
    for j in range(N_MISSING):
        names[f"sub/n{j}"] = ("n", j)
        names[f"linkdir/n{j}"] = ("n", j)
        names[f"other/../sub/n{j}"] = ("n", j)
        os.symlink(root / "sub" / f"n{j}", root / f"dangling{j}")
        names[f"dangling{j}"] = ("n", j)
    return names


def _name_list() -> list[str]:
    with tempfile.TemporaryDirectory() as d:
        return sorted(_universe(Path(d)))


NAMES = _name_list()


@given(
    inputs=st.lists(st.sampled_from(NAMES), max_size=4),
    outputs=st.lists(st.sampled_from(NAMES), min_size=1, max_size=4),
)
def test_collision_rule_matches_the_oracle(inputs, outputs):
    """Over generated sets of inputs and outputs built from files, symbolic links (to files, to links, to
    directories, dangling), hard links and ``..`` spellings: an error exactly when an output means the same
    file as an input or another output, and the message names the colliding option."""
    with tempfile.TemporaryDirectory() as d:
        root = Path(d)
        meaning = _universe(root)
        ins = [(f"in{k}", str(root / n)) for k, n in enumerate(inputs)]
        outs = [(f"out{k}", str(root / n)) for k, n in enumerate(outputs)]
        taken: set = {meaning[n] for n in inputs}
        collision = None
        for k, n in enumerate(outputs):
            if meaning[n] in taken:
                collision = f"out{k}"
                break
            taken.add(meaning[n])
        if collision is None:
            check_paths(ins, outs)
        else:
            with pytest.raises(ParameterError, match=f"^{collision} = "):
                check_paths(ins, outs)


def test_relative_and_absolute_spellings(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "a.png").write_bytes(b"x")
    with pytest.raises(ParameterError, match="same file as the input"):
        check_paths([("input", "a.png")], [("--output", str(tmp_path / "a.png"))])
    with pytest.raises(ParameterError, match="overwrite the other output"):
        check_paths([], [("--output", "new.png"), ("--save-map", str(tmp_path / "new.png"))])
    check_paths([("input", "a.png")], [("--output", "b.png"), ("--save-map", "c.npy")])


# ------------------------------------------------------------------------------------------- the CLI cases
@pytest.fixture(scope="module")
def exemplar_png(tmp_path_factory, small_exemplar):
    p = tmp_path_factory.mktemp("in") / "ex.png"
    tilesynth.save_image(p, small_exemplar)
    return p


@pytest.fixture(scope="module")
def built_file(tmp_path_factory, exemplar_png):
    out = tmp_path_factory.mktemp("tiles") / "ex.tiles"
    assert main(["build", str(exemplar_png), "-o", str(out), "--tile-size", "24", "--seed", "3", "-q"]) == 0
    return out


def _copy(src: Path, dst: Path) -> Path:
    dst.write_bytes(src.read_bytes())
    return dst


def _refused(args: list[str], capsys, *untouched: Path) -> str:
    before = {p: p.read_bytes() for p in untouched}
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "same file" in err, err
    for p, b in before.items():
        assert p.read_bytes() == b, f"{p} was changed"
    return err


def test_build_output_is_the_exemplar(exemplar_png, tmp_path, capsys):
    ex = _copy(exemplar_png, tmp_path / "in.png")
    _refused(["build", str(ex), "-o", str(ex), "-q"], capsys, ex)
    _refused(["build", str(ex), "-o", str(tmp_path / "x.tiles"), "--sheet", str(ex), "-q"], capsys, ex)
    assert not (tmp_path / "x.tiles").exists()
    os.link(ex, tmp_path / "hard.png")
    os.symlink(ex, tmp_path / "sym.png")
    _refused(["build", str(ex), "-o", str(tmp_path / "hard.png"), "-q"], capsys, ex)
    _refused(["build", str(tmp_path / "sym.png"), "-o", str(ex), "-q"], capsys, ex)
    _refused(
        ["build", str(ex), "-o", str(tmp_path / "y.tiles"), "--sheet", str(tmp_path / "y.tiles"), "-q"],
        capsys,
    )
    assert not (tmp_path / "y.tiles").exists()


def test_build_sheet_error_found_before_the_tile_set_is_written(exemplar_png, tmp_path, capsys):
    assert (
        main(
            [
                "build",
                str(exemplar_png),
                "-o",
                str(tmp_path / "y.tiles"),
                "--sheet",
                str(tmp_path / "y.sheet"),
                "-q",
            ]
        )
        == 2
    )
    assert "--sheet" in capsys.readouterr().err
    assert os.listdir(tmp_path) == []


def test_synth_outputs_and_inputs(built_file, exemplar_png, tmp_path, capsys):
    ts = _copy(built_file, tmp_path / "in.tiles")
    out = tmp_path / "o.png"
    base = ["synth", str(ts), "--size", "64x64", "--seed", "1", "-q"]
    _refused([*base, "-o", str(out), "--save-map", str(ts)], capsys, ts)
    _refused([*base, "-o", str(ts)], capsys, ts)
    _refused([*base, "-o", str(out), "--save-map", str(out)], capsys)
    height = _copy(exemplar_png, tmp_path / "height.png")
    # --save-map equal to a --with output (o-height.png)
    _refused(
        [*base, "-o", str(out), "--with", str(height), "--save-map", str(tmp_path / "o-height.png")], capsys
    )
    # -o equal to a --with input map
    _refused([*base, "-o", str(height), "--with", str(height)], capsys, height)
    # --map input equal to --save-map output
    mp = tmp_path / "m.npy"
    np.save(mp, np.zeros((2, 2), dtype=np.int64))
    _refused(
        ["synth", str(ts), "--size", "64x64", "-q", "-o", str(out), "--map", str(mp), "--save-map", str(mp)],
        capsys,
        mp,
    )
    assert sorted(os.listdir(tmp_path)) == ["height.png", "in.tiles", "m.npy"]


def test_sheet_and_report_and_demo(built_file, tmp_path, capsys):
    ts = _copy(built_file, tmp_path / "in.tiles")
    _refused(["sheet", str(ts), "-o", str(ts)], capsys, ts)
    d = tmp_path / "rep"
    d.mkdir()
    inside = _copy(built_file, d / "index.html")
    _refused(["report", str(inside), "-o", str(d), "-q"], capsys, inside)
    # demo writes only into its directory (no input of the user's): a file in place of the directory is refused
    before = ts.read_bytes()
    assert main(["demo", "-o", str(ts), "-q"]) == 2
    assert "not a directory" in capsys.readouterr().err and ts.read_bytes() == before


def test_report_failure_halfway_leaves_nothing(built_file, tmp_path, monkeypatch):
    """A failure after some figures were written leaves no report directory and no temporary one."""
    from tilesynth.measure import report

    def broken(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(report, "coherence_heatmap", broken)
    out = tmp_path / "rep"
    assert main(["report", str(built_file), "-o", str(out), "--size", "96x96", "-q"]) == 2
    assert os.listdir(tmp_path) == []
    monkeypatch.undo()
    assert main(["report", str(built_file), "-o", str(out), "--size", "96x96", "-q"]) == 0
    assert (out / "index.html").is_file() and (out / "tiles.png").is_file()
    assert sorted(os.listdir(tmp_path)) == ["rep"]
    assert (out.stat().st_mode & 0o777) == 0o777 & ~_umask()


def _umask() -> int:
    m = os.umask(0)
    os.umask(m)
    return m
