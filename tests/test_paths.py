"""No output may be an input or another output (issue 16): the rule of tilesynth.io.paths, in general (property
tests over generated path sets with symbolic and hard links) and on every CLI example of the issue."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
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


# ------------------------------------------------------- every input and every output of every command
def test_build_mask_is_an_input(exemplar_png, tmp_path, capsys):
    ex = _copy(exemplar_png, tmp_path / "in.png")
    mask = tmp_path / "m.png"
    tilesynth.save_image(mask, np.zeros((8, 8), np.uint8))
    _refused(
        ["build", str(ex), "--mask", str(mask), "-o", str(tmp_path / "x.tiles"), "--sheet", str(mask), "-q"],
        capsys,
        mask,
    )
    _refused(["build", str(ex), "--mask", str(mask), "-o", str(mask), "-q"], capsys, mask)
    assert sorted(os.listdir(tmp_path)) == ["in.png", "m.png"]


@pytest.fixture(scope="module")
def material_file(tmp_path_factory, exemplar_png, small_exemplar):
    d = tmp_path_factory.mktemp("mat")
    h = d / "h.png"
    tilesynth.save_image(h, small_exemplar[..., :1])
    out = d / "mat.tiles"
    args = ["build", str(exemplar_png), "--map", f"height={h}", "-o", str(out), "--tile-size", "24"]
    assert main([*args, "--seed", "3", "-q"]) == 0
    return out


def test_synth_of_a_material_set_never_writes_over_a_with_input(
    material_file, exemplar_png, tmp_path, capsys
):
    """The stored map 'height' is written as OUT-height.png: a --with input of that name is refused up front,
    and so are the tile set itself and --save-map under that name."""
    ts = _copy(material_file, tmp_path / "m.tiles")
    w = _copy(exemplar_png, tmp_path / "o-height.png")
    base = ["synth", str(ts), "--size", "48x48", "--seed", "1", "-q", "-o", str(tmp_path / "o.png")]
    err = _refused([*base, "--with", str(w)], capsys, w, ts)
    assert "map 'height' of the tile set" in err
    _refused([*base, "--save-map", str(tmp_path / "o-height.png")], capsys, w)
    ts2 = _copy(material_file, tmp_path / "p-height.png")  # the tile set itself under that name
    _refused(["synth", str(ts2), "--size", "48x48", "-q", "-o", str(tmp_path / "p.png")], capsys, ts2)
    assert sorted(os.listdir(tmp_path)) == ["m.tiles", "o-height.png", "p-height.png"]


@pytest.fixture(scope="module")
def set16a_file(tmp_path_factory, small_exemplar):
    """A small index-map set (16a: the export writes index.png)."""
    p = tmp_path_factory.mktemp("s16a") / "s.tiles"
    tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=24, seed=1).save(p)
    return p


@pytest.mark.parametrize("fmt", ["atlas", "provenance"])
def test_export_compares_every_file_it_writes_with_its_inputs(
    set16a_file, exemplar_png, tmp_path, capsys, fmt
):
    """A tile set or --with map named like a mip level, a map atlas, the index map, a shader, the labels or
    the source table in the output folder: refused before anything is written (both export formats)."""
    out = tmp_path / "exp"
    (out / "shaders").mkdir(parents=True)
    pre, sh = ("atlas", "tilesynth") if fmt == "atlas" else ("map", "tilesynth_v2")
    cases = [
        (_copy(set16a_file, out / f"{pre}_albedo_mip2.png"), []),
        (_copy(set16a_file, out / "shaders" / f"{sh}.wgsl"), []),
        (_copy(set16a_file, out / "index.png"), []),
    ]
    if fmt == "provenance":
        cases += [
            (_copy(set16a_file, out / n), []) for n in ("labels_bits.png", "table.bin", "labels_coverage.png")
        ]
    ts = _copy(set16a_file, tmp_path / "in.tiles")
    h = _copy(exemplar_png, tmp_path / "h.png")
    cases.append(
        (ts, ["--with", str(_copy(exemplar_png, out / f"{pre}_albedo_mip1.png"))])
    )  # named like a mip
    cases.append((ts, ["--with", str(_copy(exemplar_png, out / f"{pre}_h_mip3.png")), "--with", str(h)]))
    for tiles, extra in cases:
        before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
        assert main(["export", str(tiles), "-o", str(out), "--format", fmt, *extra]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "same file" in err, err
        assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before


EXPORT_NAMES = [
    "atlas_albedo.png",
    "atlas_albedo_mip1.png",
    "atlas_albedo_mip2.png",
    "atlas_albedo_mip3.png",
    "atlas_albedo_mip4.png",
    "atlas_albedo.exr",
    "atlas_ex.png",
    "atlas_ex_mip3.png",
    "atlas_m.png",
    "index.png",
    "index.html",
    "manifest.json",
    "viewer.html",
    "shaders/tilesynth.glsl",
    "shaders/tilesynth.gdshader",
    "shaders/other.glsl",
    "ex.png",
    "x.tiles",
]


@settings(max_examples=25)
@given(
    tiles_name=st.sampled_from(EXPORT_NAMES),
    map_names=st.lists(st.sampled_from(EXPORT_NAMES), max_size=2, unique=True),
    viewer=st.booleans(),
)
def test_export_collision_property(tiles_name, map_names, viewer):
    """Over generated names of the inputs (the tile set and --with maps placed in the output folder): the
    export is refused exactly when an input is one of the files it writes (the oracle lists them from the
    documented layout: level 0 to 3 of atlas_<map> for 24-pixel tiles and padding 8, index.png for this
    index-map set, the four shaders, viewer.html with --viewer, manifest.json), and then nothing changes."""
    import shutil

    from tilesynth.engine import export

    if tiles_name in map_names:
        return
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "exp"
        (out / "shaders").mkdir(parents=True)
        tiles_path = out / tiles_name
        shutil.copyfile(_BUILT[0], tiles_path)
        maps, inputs = {}, [("--with", None)]
        for k, n in enumerate(map_names):
            p = out / n
            p.write_bytes(b"map")
            maps[f"m{k}"] = _MAP[0]
            inputs.append(("--with", str(p)))
        stems = ["albedo", *maps]
        writes = {f"atlas_{s}.png" for s in stems} | {
            f"atlas_{s}_mip{lv}.png" for s in stems for lv in (1, 2, 3)
        }
        writes |= {"index.png", "manifest.json"} | {
            f"shaders/tilesynth.{e}" for e in ("glsl", "wgsl", "hlsl", "gdshader")
        }
        if viewer:
            writes.add("viewer.html")
        ts = tilesynth.load(tiles_path)
        clash = {tiles_name, *map_names} & writes
        before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
        if clash:
            with pytest.raises(ParameterError, match="same file as the input"):
                export(
                    ts, out, maps=maps, viewer=viewer, source_path=tiles_path, inputs=inputs, format="atlas"
                )
            assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
        else:
            export(ts, out, maps=maps, viewer=viewer, source_path=tiles_path, inputs=inputs, format="atlas")
            written = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()}
            assert written == writes | {tiles_name, *map_names}


_BUILT: list[Path] = []
_MAP: list[np.ndarray] = []


@pytest.fixture(autouse=True, scope="module")
def _property_inputs(set16a_file, small_exemplar):
    _BUILT[:] = [set16a_file]
    _MAP[:] = [(small_exemplar[..., :1] * 255).astype(np.uint8)]
