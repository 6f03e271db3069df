"""Batch builds: a library of jobs from a TOML file, locally and on a real Dask LocalCluster.

The library: six small crops of /work/shared/textures (or tests/data when that is absent), 16-pixel tiles, one job
with an aligned map, one Wang job, one glob job; a contact sheet and a preview per job.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import pickle
import shutil
import signal
import zipfile
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import tilesynth as ts
from tilesynth.cli import batch
from tilesynth.cli.batch import BatchError, build_many, load_library
from tilesynth.cli.main import main as cli_main

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "textures"
if not SHARED.is_dir():
    SHARED = Path("/work/shared/textures")
TEXTURES = ["gravel", "grass-straw", "caustics", "beans", "bread", "crackers"]
CROP = 48

LIBRARY = """
output_dir = "{out}"

[presets.small]
tile_size = 16
set = "8"
sheet = true
previews = [{{ size = "80x64", seed = 7 }}]

[presets.wang]
scheme = "wang"
set = "wang8"
tile_size = 16
previews = [{{ size = "64x64", seed = 3 }}]

[[jobs]]
exemplar = "tex/gravel.png"
preset = "small"
seed = 5
maps = {{ height = "maps/gravel-height.png" }}

[[jobs]]
exemplar = "tex/grass-straw.png"
preset = "wang"
seed = 2

[[jobs]]
exemplar = "tex/c*.png"
name = "food/{{stem}}"
preset = "small"
seed = 11

[[jobs]]
exemplar = "tex/beans.png"
preset = "small"
seed = 4
select = "best-of"
population = 4

[[jobs]]
exemplar = "tex/bread.png"
name = "bread-loaf"
preset = "small"
"""


def _textures() -> list[Path]:
    return [SHARED / f"{t}.png" for t in TEXTURES]


@pytest.fixture(scope="module")
def lib_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """tex/ (six crops), maps/ (one aligned map) and two batch files writing to out-a/ and out-b/."""
    if not all(p.is_file() for p in _textures()):
        pytest.skip(f"the shared textures are not in {SHARED}")
    d = tmp_path_factory.mktemp("library")
    (d / "tex").mkdir()
    (d / "maps").mkdir()
    for p in _textures():
        im = Image.open(p).convert("RGB")
        im.crop((0, 0, CROP, CROP)).save(d / "tex" / p.name)
    g = np.asarray(Image.open(d / "tex" / "gravel.png"))[:, :, 0]
    Image.fromarray(np.ascontiguousarray(255 - g)).save(d / "maps" / "gravel-height.png")
    for out in ("out-a", "out-b"):
        (d / f"{out}.toml").write_text(LIBRARY.format(out=out))
    return d


@pytest.fixture(scope="module")
def cluster():  # noqa: ANN201
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=40
        ) as lc,
        distributed.Client(lc) as client,
    ):
        yield client


def _members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as zf:
        return {n: zf.read(n) for n in zf.namelist() if n != "timing.json"}


def _outputs(root: Path) -> dict[str, Path]:
    return {
        str(p.relative_to(root)): p
        for p in sorted(root.rglob("*"))
        if p.is_file() and not p.name.endswith((".batch.json", ".jsonl"))
    }


def _same_outputs(a: Path, b: Path) -> None:
    fa, fb = _outputs(a), _outputs(b)
    assert sorted(fa) == sorted(fb)
    for rel in fa:
        if rel.endswith(".tiles"):  # byte-identical but for the timing member
            assert _members(fa[rel]) == _members(fb[rel]), rel
        else:
            assert fa[rel].read_bytes() == fb[rel].read_bytes(), rel


def _run(records: list[dict]) -> dict[str, str]:
    return {r["job"]: r["status"] for r in records}


# ------------------------------------------------------------------------------------------------ the library
def test_library_expands_and_names_outputs(lib_dir: Path) -> None:
    lib = load_library(lib_dir / "out-a.toml")
    names = [j.name for j in lib.jobs]
    assert names == ["gravel", "grass-straw", "food/caustics", "food/crackers", "beans", "bread-loaf"]
    g = lib.jobs[0]
    assert g.options["seed"] == 5 and g.options["set"] == "8" and g.options["tile_size"] == 16
    assert set(g.outputs) == {"tiles", "sheet", "preview", "preview-height"}
    assert g.outputs["preview-height"].name == "gravel-preview-height.png"
    assert lib.jobs[5].options["seed"] == batch.DEFAULT_SEED
    assert lib.jobs[1].options["scheme"] == "wang" and "smooth" not in lib.jobs[1].options


def test_dask_local_and_cli_builds_are_identical(lib_dir: Path, cluster) -> None:  # noqa: ANN001
    """LocalCluster (2 worker processes) == local process pool == one CLI build/synth per job."""
    res_a = build_many(
        lib_dir / "out-a.toml", executor=cluster.get_executor(pure=False), threads=1, quiet=True
    )
    assert _run(res_a.records) == dict.fromkeys(_run(res_a.records), "built"), res_a.summary()
    assert len(res_a.records) == 6
    workers = {r["worker"] for r in res_a.records}
    assert all(not w.endswith(f":{os.getpid()}") for w in workers)  # ran in the cluster's processes
    res_b = build_many(lib_dir / "out-b.toml", workers=2, quiet=True)
    assert res_b.n_built == 6 and res_b.exit_status == 0, res_b.summary()
    assert all(r["threads"] == max(1, batch.executors._cores() // 2) for r in res_b.records)
    _same_outputs(lib_dir / "out-a", lib_dir / "out-b")

    # the single commands with the same options and seeds
    cli = lib_dir / "cli"
    (cli / "food").mkdir(parents=True)
    tex = lib_dir / "tex"
    builds = {
        "gravel": ("gravel", ["--set", "8", "--tile-size", "16", "--seed", "5"], "80x64", "7"),
        "grass-straw": (
            "grass-straw",
            ["--scheme", "wang", "--set", "wang8", "--tile-size", "16", "--seed", "2"],
            "64x64",
            "3",
        ),
        "food/caustics": ("caustics", ["--set", "8", "--tile-size", "16", "--seed", "11"], "80x64", "7"),
        "food/crackers": ("crackers", ["--set", "8", "--tile-size", "16", "--seed", "11"], "80x64", "7"),
        "beans": (
            "beans",
            ["--set", "8", "--tile-size", "16", "--seed", "4", "--select", "best-of", "--population", "4"],
            "80x64",
            "7",
        ),
        "bread-loaf": ("bread", ["--set", "8", "--tile-size", "16", "--seed", "1"], "80x64", "7"),
    }
    for name, (src, opts, size, seed) in builds.items():
        tiles = cli / f"{name}.tiles"
        sheet = ["--sheet", str(cli / f"{name}-sheet.png")]
        assert cli_main(["build", str(tex / f"{src}.png"), "-o", str(tiles), "-q", *opts, *sheet]) == 0
        with_ = ["--with", str(lib_dir / "maps" / "gravel-height.png")] if name == "gravel" else []
        assert (
            cli_main(
                [
                    "synth",
                    str(tiles),
                    "-o",
                    str(cli / f"{name}-preview.png"),
                    "--size",
                    size,
                    "--seed",
                    seed,
                    "-q",
                    *with_,
                ]
            )
            == 0
        )
    (cli / "gravel-preview-gravel-height.png").rename(cli / "gravel-preview-height.png")
    _same_outputs(lib_dir / "out-b", cli)


def test_rerun_skips_touch_and_change(lib_dir: Path) -> None:
    out = lib_dir / "out-c"
    toml = lib_dir / "out-c.toml"
    shutil.copytree(lib_dir / "tex", lib_dir / "tex-c")
    toml.write_text(LIBRARY.format(out="out-c").replace('"tex/', '"tex-c/'))
    first = build_many(toml, workers=2, quiet=True)
    assert first.n_built == 6
    again = build_many(toml, workers=2, quiet=True)
    assert _run(again.records) == dict.fromkeys(_run(first.records), "skipped")
    os.utime(lib_dir / "tex-c" / "beans.png")  # a touch alone changes nothing: the key is the content
    assert build_many(toml, quiet=True).n_built == 0
    before = {p: p.read_bytes() for p in out.rglob("*.png")}
    img = np.asarray(Image.open(lib_dir / "tex-c" / "beans.png")).copy()
    img[3, 4] ^= 1  # one pixel
    Image.fromarray(img).save(lib_dir / "tex-c" / "beans.png")
    changed = build_many(toml, workers=2, quiet=True)
    assert {k for k, v in _run(changed.records).items() if v == "built"} == {"beans"}
    assert {k for k, v in _run(changed.records).items() if v == "skipped"} == set(_run(changed.records)) - {
        "beans"
    }
    after = {p: p.read_bytes() for p in out.rglob("*.png")}
    assert [p.name for p in before if before[p] != after[p] and not p.name.startswith("beans")] == []
    # a parameter change rebuilds the jobs of that preset only
    toml.write_text(toml.read_text().replace("seed = 3 }]", "seed = 4 }]"))
    assert {k for k, v in _run(build_many(toml, quiet=True).records).items() if v == "built"} == {
        "grass-straw"
    }
    # --force rebuilds all, the outputs stay the same
    now = {p: p.read_bytes() for p in out.rglob("*.png")}
    assert now[out / "grass-straw-preview.png"] != after[out / "grass-straw-preview.png"]
    forced = build_many(toml, executor="serial", force=True, quiet=True)
    assert forced.n_built == 6
    assert {p: p.read_bytes() for p in out.rglob("*.png")} == now
    lines = [json.loads(s) for s in (out / "batch-log.jsonl").read_text().splitlines()]
    assert len({r["run"] for r in lines}) == 6 and all(len(r["outputs"]) >= 2 for r in lines)
    built = [r for r in lines if r["status"] == "built"]
    assert all(r["peak_rss_mb"] > 0 and r["timings"]["build_s"] > 0 for r in built)


def test_broken_file_fails_alone(lib_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = lib_dir / "broken"
    (d / "tex").mkdir(parents=True)
    for name in ("gravel", "beans", "bread"):
        shutil.copy(lib_dir / "tex" / f"{name}.png", d / "tex" / f"{name}.png")
    good = (d / "tex" / "beans.png").read_bytes()
    (d / "tex" / "beans.png").write_bytes(good[: len(good) // 2])  # cut short
    (d / "lib.toml").write_text(
        'output_dir = "out"\n[presets.p]\ntile_size = 16\nset = "4"\n'
        'previews = [{ size = "40x40" }]\n'
        '[[jobs]]\nexemplar = "tex/*.png"\npreset = "p"\n'
        '[[jobs]]\nexemplar = "tex/gravel.png"\nname = "too-big"\ntile_size = 64\n'
    )
    status = cli_main(["batch", str(d / "lib.toml"), "--workers", "2", "-q"])
    assert status == 1
    out = capsys.readouterr().out
    assert "4 jobs: 2 built, 0 up to date, 2 failed" in out
    recs = {r["job"]: r for r in map(json.loads, (d / "out" / "batch-log.jsonl").read_text().splitlines())}
    assert recs["gravel"]["status"] == recs["bread"]["status"] == "built"
    assert recs["beans"]["status"] == "failed" and "beans.png" in recs["beans"]["error"]
    assert recs["too-big"]["status"] == "failed" and "tile_size = 64" in recs["too-big"]["error"]
    assert recs["beans"]["outputs"] == []
    left = sorted(p.name for p in (d / "out").iterdir())
    assert not [n for n in left if n.startswith(("beans", "too-big", "."))], (
        left
    )  # no partial output, no temp dir
    assert "gravel.tiles" in left and "bread-preview.png" in left


def test_interrupted_job_is_rebuilt_and_temp_removed(lib_dir: Path) -> None:
    d = lib_dir / "resume"
    (d / "tex").mkdir(parents=True)
    shutil.copy(lib_dir / "tex" / "bread.png", d / "tex" / "bread.png")
    (d / "lib.toml").write_text(
        'output_dir = "out"\n[[jobs]]\nexemplar = "tex/bread.png"\ntile_size = 16\nset = "4"\n'
    )
    assert build_many(d / "lib.toml", executor="serial", quiet=True).n_built == 1
    ref = _members(d / "out" / "bread.tiles")
    # what an interruption between the renames and the stamp leaves: outputs, a temp directory, no stamp
    (d / "out" / "bread.batch.json").unlink()
    stale = d / "out" / f"{batch.TMP_PREFIX}bread.batch.json.abc123"
    stale.mkdir()
    (stale / "bread.tiles").write_bytes(b"partial")
    res = build_many(d / "lib.toml", executor="serial", quiet=True)
    assert _run(res.records) == {"bread": "built"}
    assert not stale.exists() and _members(d / "out" / "bread.tiles") == ref
    # an output removed by hand makes the job out of date
    (d / "out" / "bread-sheet.png").unlink()
    assert build_many(d / "lib.toml", executor="serial", quiet=True).n_built == 1
    assert build_many(d / "lib.toml", executor="serial", quiet=True).n_skipped == 1


def test_progress_lines(lib_dir: Path) -> None:
    d = lib_dir / "progress"
    (d / "tex").mkdir(parents=True)
    for n in ("bread", "beans"):
        shutil.copy(lib_dir / "tex" / f"{n}.png", d / "tex" / f"{n}.png")
    (d / "lib.toml").write_text(
        'output_dir = "out"\n[[jobs]]\nexemplar = "tex/b*.png"\ntile_size = 16\nset = "4"\n'
    )
    stream = io.StringIO()
    build_many(d / "lib.toml", executor="serial", stream=stream)
    text = stream.getvalue()
    assert "[1/2] beans: built in" in text and "[2/2] bread: built in" in text
    assert "batch: 2/2 done (0 failed), 0 running, 0 up to date" in text and "ETA 0s" in text


# ------------------------------------------------------------------------------------------------ bad files
BAD = {
    "unknown preset": (
        '[[jobs]]\nexemplar = "tex/bread.png"\npreset = "nope"\n',
        "job 1 ('tex/bread.png'): field 'preset' = 'nope': unknown preset",
    ),
    "missing exemplar": ('[[jobs]]\nexemplar = "tex/none.png"\n', "job 1 ('tex/none.png'): field 'exemplar'"),
    "no exemplar field": ("[[jobs]]\nseed = 1\n", "job 1: field 'exemplar' is missing"),
    "glob matching nothing": ('[[jobs]]\nexemplar = "tex/zz*.png"\n', "the glob matches no file"),
    "duplicate names": (
        '[[jobs]]\nexemplar = "tex/bread.png"\n[[jobs]]\nexemplar = "tex/beans.png"\nname = "bread"\n',
        "job 2 ('tex/beans.png'): field 'name': duplicate output name 'bread'",
    ),
    "same file": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nname = "x"\nmaps = {preview = "tex/bread.png"}\n'
        'previews = [{size = "32x32"}]\n[[jobs]]\nexemplar = "tex/beans.png"\nname = "x-preview"\n'
        'previews = [{size = "32x32"}]\n',
        "job 2 ('tex/beans.png'): field 'name': its preview output",
    ),
    "same file as the log": (
        'output_dir = "out"\nlog = "out/bread.tiles"\n[[jobs]]\nexemplar = "tex/bread.png"\n',
        "its tiles output",
    ),
    "output inside a report": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nname = "a"\nreport = true\n[[jobs]]\n'
        'exemplar = "tex/beans.png"\nname = "a-report/b"\n',
        "lies inside report output",
    ),
    "glob without stem": ('[[jobs]]\nexemplar = "tex/b*.png"\nname = "same"\n', "needs {stem}"),
    "unknown key": (
        '[[jobs]]\nexemplar = "tex/bread.png"\ntilesize = 16\n',
        "field 'tilesize' (did you mean 'tile_size'?)",
    ),
    "unknown preset key": (
        '[presets.p]\ncolour = 1\n[[jobs]]\nexemplar = "tex/bread.png"\n',
        "preset 'p': unknown field 'colour'",
    ),
    "unknown top key": (
        'jobz = 1\n[[jobs]]\nexemplar = "tex/bread.png"\n',
        "top level: unknown field 'jobz'",
    ),
    "wrong type": (
        '[[jobs]]\nexemplar = "tex/bread.png"\ntile_size = "16"\n',
        "field 'tile_size' = '16': expected an integer",
    ),
    "bool for int": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nseed = true\n',
        "field 'seed' = True: expected an integer",
    ),
    "odd tile size": ('[[jobs]]\nexemplar = "tex/bread.png"\ntile_size = 15\n', "must be even"),
    "bad scheme": ('[[jobs]]\nexemplar = "tex/bread.png"\nscheme = "hex"\n', "field 'scheme' = 'hex'"),
    "set of another scheme": ('[[jobs]]\nexemplar = "tex/bread.png"\nset = "wang8"\n', "needs a corner set"),
    "unknown set": ('[[jobs]]\nexemplar = "tex/bread.png"\nset = "17q"\n', "field 'set' = '17q'"),
    "option of another scheme": (
        '[presets.w]\nscheme = "wang"\nsmooth = true\n[[jobs]]\nexemplar = "tex/bread.png"\npreset = "w"\n',
        "field 'smooth' (from the preset): not used with scheme 'wang'",
    ),
    "generations with random": (
        '[[jobs]]\nexemplar = "tex/bread.png"\ngenerations = 3\n',
        "field 'generations'",
    ),
    "bad preview": (
        '[[jobs]]\nexemplar = "tex/bread.png"\npreviews = [{size = "0x4"}]\n',
        "field 'previews' entry 1: field 'size'",
    ),
    "preview without size": (
        '[[jobs]]\nexemplar = "tex/bread.png"\npreviews = [{seed = 1}]\n',
        "'size' is missing",
    ),
    "bad map kind": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nmap_kinds = {n = "blur"}\n',
        "entry 'n' = 'blur'",
    ),
    "missing map": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nmaps = {n = "tex/none.png"}\n',
        "field 'maps' entry 'n' = 'tex/none.png': no such file",
    ),
    "name escaping": ('[[jobs]]\nexemplar = "tex/bread.png"\nname = "../x"\n', "field 'name' = '../x'"),
    "output over an input": (
        'output_dir = "tex"\n[[jobs]]\nexemplar = "tex/bread.png"\n'
        '[[jobs]]\nexemplar = "tex/bread-sheet.png"\nname = "r"\n',
        "would overwrite an input",
    ),
    "export unknown option": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nexport = {format = "gltf"}\n',
        "field 'export': unknown field 'format'",
    ),
    "export bad bits": (
        '[presets.e]\nexport = {bits = 12}\n[[jobs]]\nexemplar = "tex/bread.png"\npreset = "e"\n',
        "preset 'e': field 'export': field 'bits' = 12: expected 8 or 16",
    ),
    "export bad lookup": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nexport = {lookup = "wang"}\n',
        "field 'export': field 'lookup' = 'wang': expected one of auto, hash, index_map",
    ),
    "export not a table": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nexport = "yes"\n',
        "field 'export' = 'yes'",
    ),
    "recipe unknown": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nrecipe = "quick"\n',
        "field 'recipe' = 'quick'",
    ),
    "recipe with wang": (
        '[[jobs]]\nexemplar = "tex/bread.png"\nscheme = "wang"\nrecipe = "fast"\n',
        "field 'recipe'",
    ),
    "no jobs": ('[presets.p]\nset = "8"\n', "no jobs"),
    "not toml": ("[[jobs]\nexemplar = 1\n", "not valid TOML"),
    "version": ('version = 2\n[[jobs]]\nexemplar = "tex/bread.png"\n', "only version 1"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_batch_file_is_an_error_before_any_work(lib_dir: Path, tmp_path: Path, case: str) -> None:
    text, expected = BAD[case]
    shutil.copytree(lib_dir / "tex", tmp_path / "tex")
    if case == "output over an input":
        shutil.copy(tmp_path / "tex" / "bread.png", tmp_path / "tex" / "bread-sheet.png")
    f = tmp_path / "lib.toml"
    f.write_text(text)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    with pytest.raises(BatchError) as err:
        build_many(f, quiet=True)
    assert expected in str(err.value), str(err.value)
    assert str(f) in str(err.value)
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing written, not even the output dir
    assert cli_main(["batch", str(f)]) == 2


def test_cli_dry_run_and_json(lib_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = lib_dir / "dry"
    (d / "tex").mkdir(parents=True)
    shutil.copy(lib_dir / "tex" / "bread.png", d / "tex" / "bread.png")
    (d / "lib.toml").write_text(
        'output_dir = "out"\n[[jobs]]\nexemplar = "tex/bread.png"\ntile_size = 16\nset = "4"\n'
    )
    assert cli_main(["batch", str(d / "lib.toml"), "--dry-run"]) == 0
    assert "bread: to build" in capsys.readouterr().out and not (d / "out").exists()
    assert cli_main(["batch", str(d / "lib.toml"), "--json", "-q", "--threads", "1"]) == 0
    recs = json.loads(capsys.readouterr().out)
    assert [r["status"] for r in recs] == ["built"] and recs[0]["threads"] == 1
    assert cli_main(["batch", str(d / "lib.toml"), "--dry-run"]) == 0
    assert "bread: up to date" in capsys.readouterr().out


def test_build_many_arguments(lib_dir: Path) -> None:
    f = lib_dir / "out-a.toml"
    with pytest.raises(ValueError, match="workers = 0"):
        build_many(f, workers=0)
    with pytest.raises(ValueError, match="executor = 'dask'"):
        build_many(f, executor="dask")
    with pytest.raises(TypeError, match="executor"):
        build_many(f, executor=object())
    with pytest.raises(TypeError, match="jobs"):
        build_many(42)


# ------------------------------------------------------------------------------------------------ pickling
def test_kernel_objects_pickle_by_rebuilding() -> None:
    r = np.random.default_rng(3)
    img = r.random((32, 32, 3), dtype=np.float32)
    idx = ts.SsdIndex(img)
    t = img[4:12, 5:13]
    idx2 = pickle.loads(pickle.dumps(idx))
    assert np.array_equal(idx.ssd(t), idx2.ssd(t))
    assert all(np.array_equal(a, b) for a, b in zip(idx.best_matches(t, k=3), idx2.best_matches(t, k=3)))
    patches = np.array([[0, 1, 2, 3], [1, 0, 3, 2]])
    ev = ts.PopulationEvaluator(img, 8, patches, 4, lam=0.7, normalise=True, cache_bytes=1 << 20)
    genes = r.integers(0, 24, size=(5, 4, 2))
    e1 = ev.evaluate(genes)
    ev2 = pickle.loads(pickle.dumps(ev))
    assert (
        ev2.cache_stats()["entries"] == 0 and ev2.cache_stats()["limit"] == 1 << 20
    )  # the cache is not sent
    assert ev2.lam == 0.7 and ev2.normalise
    assert all(np.array_equal(a, b) for a, b in zip(e1, ev2.evaluate(genes)))
    ws = ts.get_wang_tileset("wang8")
    wev = ts.WangEvaluator(
        img, ws.sample_indices(), ws.n_samples, 16, 4, corners="pinned", cut="graph", omega=0.6
    )
    g = r.integers(0, 16, size=(3, ws.n_samples, 2))
    w2 = pickle.loads(pickle.dumps(wev))
    assert all(np.array_equal(a, b) for a, b in zip(wev.evaluate(g), w2.evaluate(g)))


def test_ctrl_c_then_the_same_command_resumes(lib_dir: Path) -> None:
    """A real Ctrl-C (SIGINT to the process group) in the middle of a batch: exit 130, whole outputs only; the
    same command then builds only what is missing, and the result equals an uninterrupted batch."""
    import signal
    import subprocess
    import sys
    import time

    d = lib_dir / "ctrl-c"
    (d / "tex").mkdir(parents=True)
    for n in TEXTURES:
        shutil.copy(lib_dir / "tex" / f"{n}.png", d / "tex" / f"{n}.png")
    # slow enough jobs (the GA) that the interruption lands while some are still to run
    body = (
        '[presets.p]\ntile_size = 16\nset = "8"\nselect = "ga"\npopulation = 30\ngenerations = 40\n'
        'previews = [{ size = "64x64" }]\n[[jobs]]\nexemplar = "tex/*.png"\npreset = "p"\n'
    )
    (d / "lib.toml").write_text('output_dir = "out"\n' + body)
    (d / "ref.toml").write_text('output_dir = "ref"\n' + body)
    cmd = [sys.executable, "-m", "tilesynth", "batch", str(d / "lib.toml"), "--workers", "1", "-q"]
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    log = d / "out" / "batch-log.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not (log.is_file() and log.read_text().count("\n") >= 1):
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        pytest.fail("the interrupted batch did not exit")
    assert proc.returncode == 130, proc.returncode
    built = {r["job"] for r in map(json.loads, log.read_text().splitlines()) if r["status"] == "built"}
    assert 1 <= len(built) < 6
    stamps = {p.name.removesuffix(batch.STAMP_SUFFIX) for p in (d / "out").glob("*" + batch.STAMP_SUFFIX)}
    # the workers stopped with the batch (a job may complete in the instant between its stamp and its log line)
    assert built <= stamps and len(stamps) < 6
    res = build_many(d / "lib.toml", workers=2, quiet=True)
    assert {r["job"] for r in res.records if r["status"] == "skipped"} == stamps
    assert not [p for p in (d / "out").iterdir() if p.name.startswith(".")]  # a cut-short job's temp is gone
    assert res.n_built == 6 - len(stamps) and res.n_failed == 0
    assert build_many(d / "ref.toml", workers=2, quiet=True).n_built == 6
    _same_outputs(d / "out", d / "ref")


def test_local_pool_never_forks_a_process_that_ran_kernels(lib_dir: Path) -> None:
    """The parent has run kernels (and so owns thread pools); the local workers start by forkserver or spawn and
    build normally."""
    assert batch.executors._start_method() in ("forkserver", "spawn")
    img = np.random.default_rng(1).random((24, 24, 3), dtype=np.float32)
    ts.patch_ssd(img, img[:8, :8], threads=2)
    d = lib_dir / "after-kernels"
    (d / "tex").mkdir(parents=True)
    for n in ("bread", "beans"):
        shutil.copy(lib_dir / "tex" / f"{n}.png", d / "tex" / f"{n}.png")
    (d / "lib.toml").write_text(
        'output_dir = "out"\n[[jobs]]\nexemplar = "tex/b*.png"\ntile_size = 16\nset = "4"\n'
    )
    res = build_many(d / "lib.toml", workers=2, quiet=True)
    assert res.n_built == 2 and {r["worker"] for r in res.records}.isdisjoint(
        {f"{os.uname().nodename}:{os.getpid()}"}
    )


def test_cli_scheduler_address_runs_on_the_cluster(lib_dir: Path, cluster, capsys) -> None:  # noqa: ANN001
    """``tilesynth batch --scheduler tcp://...``: the jobs run in the cluster's worker processes."""
    d = lib_dir / "scheduler"
    (d / "tex").mkdir(parents=True)
    for n in ("bread", "beans"):
        shutil.copy(lib_dir / "tex" / f"{n}.png", d / "tex" / f"{n}.png")
    (d / "lib.toml").write_text(
        'output_dir = "out"\n[[jobs]]\nexemplar = "tex/b*.png"\ntile_size = 16\nset = "4"\n'
    )
    addr = cluster.scheduler.address
    assert addr.startswith("tcp://")
    assert cli_main(["batch", str(d / "lib.toml"), "--scheduler", addr, "--threads", "1", "-q"]) == 0
    recs = [json.loads(s) for s in (d / "out" / "batch-log.jsonl").read_text().splitlines()]
    workers = {w.split(":")[-1] for w in cluster.run(lambda: f"{os.getpid()}").values()}
    assert [r["status"] for r in recs] == ["built", "built"]
    assert {r["worker"].split(":")[-1] for r in recs} <= workers
    assert cli_main(["batch", str(d / "lib.toml"), "--scheduler", addr, "-q"]) == 0  # up to date
    assert "2 up to date" in capsys.readouterr().out
    assert cli_main(["batch", str(d / "lib.toml"), "--scheduler", addr, "--workers", "1"]) == 2


def test_any_executor_thread_pool(lib_dir: Path) -> None:
    """A plain ThreadPoolExecutor (any concurrent.futures.Executor) gives the outputs of the serial executor."""
    import concurrent.futures as cf

    d = lib_dir / "threads"
    (d / "tex").mkdir(parents=True)
    for n in ("bread", "beans", "eggs" if (lib_dir / "tex" / "eggs.png").exists() else "gravel"):
        shutil.copy(lib_dir / "tex" / f"{n}.png", d / "tex" / f"{n}.png")
    for out in ("a", "b"):
        (d / f"{out}.toml").write_text(
            f'output_dir = "{out}"\n[[jobs]]\nexemplar = "tex/*.png"\ntile_size = 16\nset = "8"\n'
            'previews = [{ size = "48x40", seed = 2 }]\n'
        )
    with cf.ThreadPoolExecutor(2) as ex:
        res = build_many(d / "a.toml", executor=ex, threads=1, quiet=True)
    assert res.n_built == 3 and res.exit_status == 0
    assert build_many(d / "b.toml", executor="serial", quiet=True).n_built == 3
    _same_outputs(d / "a", d / "b")


# ------------------------------------------------------------------------------------------------ engine export
def test_job_with_export_writes_a_valid_manifest(lib_dir: Path) -> None:
    pytest.importorskip("jsonschema")
    from tilesynth.engine import validate_manifest

    d = lib_dir / "export"
    (d / "tex").mkdir(parents=True)
    (d / "maps").mkdir()
    shutil.copy(lib_dir / "tex" / "gravel.png", d / "tex" / "gravel.png")
    shutil.copy(lib_dir / "maps" / "gravel-height.png", d / "maps" / "gravel-height.png")
    text = (
        'output_dir = "out"\n[[jobs]]\nexemplar = "tex/gravel.png"\ntile_size = 16\nset = "8"\n'
        'maps = {{ height = "maps/gravel-height.png" }}\nexport = {export}\n'
    )
    f = d / "lib.toml"
    f.write_text(
        text.format(export='{ bits = 16, padding = 4, viewer = true, lookup = "index_map", index_seed = 9 }')
    )
    res = build_many(f, executor="serial", quiet=True)
    assert _run(res.records) == {"gravel": "built"}, res.summary()
    out = d / "out" / "gravel-export"
    assert str(out) in res.records[0]["outputs"] and "export_s" in res.records[0]["timings"]
    manifest = json.loads((out / "manifest.json").read_text("utf-8"))
    validate_manifest(manifest)
    assert manifest["lookup"]["mode"] == "index_map" and manifest["tile_count"] == 8
    files = manifest["files"]
    names = files if isinstance(files, list) else list(files)
    names = [n if isinstance(n, str) else n["path"] for n in names]
    assert names and all((out / n).is_file() for n in names), files
    assert (out / "viewer.html").is_file()
    assert "height" in json.dumps(manifest["maps"])
    assert not list(d.rglob(".tilesynth-*"))  # the temporary directory is gone
    stamp = json.loads((d / "out" / "gravel.batch.json").read_text("utf-8"))
    assert stamp["outputs"]["export"] == {"path": "gravel-export", "size": None}
    # the same batch again: up to date; another export option: rebuilt with another key
    assert _run(build_many(f, executor="serial", quiet=True).records) == {"gravel": "skipped"}
    f.write_text(
        text.format(export='{ bits = 16, padding = 4, viewer = true, lookup = "index_map", index_seed = 10 }')
    )
    assert _run(build_many(f, executor="serial", quiet=True).records) == {"gravel": "built"}
    stamp2 = json.loads((d / "out" / "gravel.batch.json").read_text("utf-8"))
    assert stamp2["key"] != stamp["key"] and stamp2["params_sha256"] != stamp["params_sha256"]
    # export = false (the default) drops the output from the job and changes the key again
    f.write_text(text.replace("export = {export}\n", "").format())
    lib = load_library(f)
    assert "export" not in lib.jobs[0].outputs and lib.jobs[0].export is None
    assert batch.job_key(lib.jobs[0])[0] != stamp2["key"]


# ------------------------------------------------------------------ the log, masks and material maps as inputs
@pytest.mark.parametrize(
    ("text", "cli_log", "expected"),
    [
        ('output_dir = "out"\nlog = "lib.toml"\n', None, "the log"),  # the log over the batch file itself
        ('output_dir = "out"\nlog = "tex/bread.png"\n', None, "the log"),  # ... over an exemplar
        ('output_dir = "out"\n', "lib.toml", "the batch file"),  # --log lib.toml
        ('output_dir = "out"\n', "tex/bread.png", "(exemplar)"),  # --log tex/g.png
        ('output_dir = "tex"\nmask_file = "tex/bread-sheet.png"\n', None, "(mask)"),
        ('output_dir = "tex"\nmat_file = "tex/bread-sheet.png"\n', None, "(material map 'height')"),
    ],
)
def test_log_mask_and_material_maps_are_inputs_of_the_check(
    lib_dir: Path, tmp_path: Path, text: str, cli_log: str | None, expected: str
) -> None:
    """The log (`log =` or `--log`) is compared with every input (the batch file, exemplars, maps, masks), and a
    job's mask and material maps (`maps.x.file`) are inputs: refused before any work, every file unchanged."""
    shutil.copytree(lib_dir / "tex", tmp_path / "tex")
    shutil.copy(tmp_path / "tex" / "bread.png", tmp_path / "tex" / "bread-sheet.png")
    job = '[[jobs]]\nexemplar = "tex/bread.png"\ntile_size = 16\nset = "4"\n'
    if "mask_file" in text:
        job += 'mask = "tex/bread-sheet.png"\n'
    if "mat_file" in text:
        job += 'maps = { height = { file = "tex/bread-sheet.png" } }\n'
    head = "\n".join(line for line in text.splitlines() if not line.startswith(("mask_file", "mat_file")))
    f = tmp_path / "lib.toml"
    f.write_text(head + "\n" + job)
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    log = None if cli_log is None else str(tmp_path / cli_log)
    with pytest.raises(BatchError) as err:
        build_many(f, quiet=True, log=log)
    assert expected in str(err.value), str(err.value)
    args = ["batch", str(f), "-q"] + ([] if log is None else ["--log", log])
    assert cli_main(args) == 2
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("pattern", "out_dir", "extra"),
    [
        ("tex/**/*.png", "tex/out", "report = true\n"),  # the output folder below the glob's folder
        (
            "tex/b*.png",
            "tex",
            'maps = { h = "tex/{stem}.png" }\npreviews = [{ size = "32x32" }]\n',
        ),  # the same
    ],
)
def test_a_glob_never_takes_the_outputs_as_exemplars(
    lib_dir: Path, tmp_path: Path, pattern: str, out_dir: str, extra: str
) -> None:
    """A glob that also matches the output folder (`exemplar = "tex/**/*.png"`, `output_dir = "tex/out"`, or the
    outputs written beside the exemplars) excludes the outputs: the second run finds the same jobs, all up to
    date (every later run failed, or built the outputs of the first)."""
    (tmp_path / "tex").mkdir()
    for t in ("bread", "beans"):
        shutil.copy(lib_dir / "tex" / f"{t}.png", tmp_path / "tex" / f"{t}.png")
    f = tmp_path / "lib.toml"
    f.write_text(
        f'output_dir = "{out_dir}"\n[[jobs]]\nexemplar = "{pattern}"\ntile_size = 16\nset = "4"\n{extra}'
    )
    first = build_many(f, executor="serial", quiet=True)
    assert [r["status"] for r in first.records] == ["built", "built"]
    assert len(load_library(f).jobs) == 2
    second = build_many(f, executor="serial", quiet=True)
    assert [(r["job"], r["status"]) for r in second.records] == [("beans", "skipped"), ("bread", "skipped")]


# ------------------------------------------------------------------------------------ signals and processes
def _marked(marker: str) -> list[int]:
    """Processes whose environment holds ``marker`` (the batch process, its forkserver, workers and resource
    tracker all inherit it)."""
    pids = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit() and int(d.name) != os.getpid():
            try:
                if marker.encode() in (d / "environ").read_bytes():
                    stat = (d / "stat").read_text().rsplit(")", 1)[1].split()
                    if stat[0] != "Z":  # a zombie has ended; only its parent has not reaped it yet
                        pids.append(int(d.name))
            except OSError:
                continue
    return pids


def _wait_gone(marker: str, seconds: float) -> list[int]:
    import time

    deadline = time.monotonic() + seconds
    while (left := _marked(marker)) and time.monotonic() < deadline:
        time.sleep(0.2)
    return left


def _ga_library(d: Path, exemplar: np.ndarray, n: int, population: int, generations: int, tile: int) -> Path:
    (d / "tex").mkdir()
    for k in range(n):
        ts.save_image(d / "tex" / f"t{k}.png", np.roll(exemplar, k, axis=0))
    f = d / "lib.toml"
    f.write_text(
        f'output_dir = "out"\n[[jobs]]\nexemplar = "tex/t*.png"\ntile_size = {tile}\nset = "16a"\nsheet = false\n'
        f'select = "ga"\npopulation = {population}\ngenerations = {generations}\n'
    )
    return f


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_sigterm_stops_a_local_batch_as_ctrl_c_does(tmp_path: Path, small_exemplar: np.ndarray) -> None:
    """SIGTERM during a batch on the local pool: no queued job is built after it (it waited for all of them),
    the jobs finished before it are in the log, exit 143, and no process of the batch is left."""
    import subprocess
    import sys
    import time
    import uuid

    f = _ga_library(tmp_path, small_exemplar, 5, 400, 4, 32)  # about 3 s per job on one thread
    marker = f"TILESYNTH_TEST_MARK={uuid.uuid4().hex}"
    env = {**os.environ, marker.split("=")[0]: marker.split("=")[1]}
    p = subprocess.Popen(
        [sys.executable, "-m", "tilesynth", "batch", str(f), "--workers", "1", "--threads", "1", "-q"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    log = tmp_path / "out" / "batch-log.jsonl"
    deadline = time.monotonic() + 120
    while not (log.is_file() and log.read_text().count("\n") >= 1):
        assert p.poll() is None and time.monotonic() < deadline, "no job finished"
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM, err
    logged = [json.loads(line)["job"] for line in log.read_text().splitlines()]
    built = sorted(q.stem for q in (tmp_path / "out").glob("*.tiles"))
    assert sorted(logged) == built and 1 <= len(built) < 5, (logged, built)
    assert not _wait_gone(marker.split("=")[1], 20)


@pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")
def test_workers_die_with_a_killed_batch(tmp_path: Path, lettuce: np.ndarray) -> None:
    """SIGKILL of the batch process while a worker runs a long job (a GA of 800 tiles of 128 px, a minute or
    more): the worker, the forkserver and the resource tracker are gone within seconds (they ran for minutes)."""
    import subprocess
    import sys
    import time
    import uuid

    big = np.tile(lettuce, (2, 2, 1))[:512, :512]
    f = _ga_library(tmp_path, big, 1, 800, 3, 128)
    tag = uuid.uuid4().hex
    env = {**os.environ, "TILESYNTH_TEST_MARK": tag}
    p = subprocess.Popen(
        [sys.executable, "-m", "tilesynth", "batch", str(f), "--workers", "1", "--threads", "1", "-q"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    deadline = time.monotonic() + 120
    while not list((tmp_path / "out").glob(".tilesynth-batch-*")):  # the worker has started the job
        assert p.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    time.sleep(2.0)  # into the build
    assert p.poll() is None and len(_marked(tag)) >= 2  # the batch process and its pool
    p.kill()
    p.wait(timeout=30)
    left = _wait_gone(tag, 20)
    for pid in left:  # do not leave them running if the test fails
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
    assert not left, f"processes of the killed batch still running: {left}"


def test_a_run_never_removes_the_live_temporary_folder_of_another(lib_dir: Path, tmp_path: Path) -> None:
    """Two batch runs on one library: a run's clean-up of stale temporary folders removes those whose owner
    (pid and start time in the name) has ended, and an old-style one, but not the folder of a run still going
    (it deleted it, and that run's job failed)."""
    import subprocess
    import sys

    (tmp_path / "tex").mkdir()
    shutil.copy(lib_dir / "tex" / "bread.png", tmp_path / "tex" / "bread.png")
    f = tmp_path / "lib.toml"
    f.write_text('output_dir = "out"\n[[jobs]]\nexemplar = "tex/bread.png"\ntile_size = 16\nset = "4"\n')
    out = tmp_path / "out"
    out.mkdir()
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])  # the other run
    try:
        prefix = f"{batch.TMP_PREFIX}bread.batch.json."
        live = out / f"{prefix}aaaaaaaaaaaa-{batch.worker._owner_tag(other.pid)}"
        gone_pid = max(int(p) for p in os.listdir("/proc") if p.isdigit()) + 10_000  # no such process
        dead = out / f"{prefix}bbbbbbbbbbbb-{gone_pid}-123-{batch.worker._host_tag()}"
        # same pid, another start
        reused = out / f"{prefix}cccccccccccc-{other.pid}-1-{batch.worker._host_tag()}"
        old = out / f"{prefix}abc123"
        for d in (live, dead, reused, old):
            d.mkdir()
            (d / "bread.tiles").write_bytes(b"partial")
        res = build_many(f, executor="serial", quiet=True, force=True)
        assert _run(res.records) == {"bread": "built"}
        assert live.is_dir() and (live / "bread.tiles").read_bytes() == b"partial"
        assert not dead.exists() and not reused.exists() and not old.exists()
    finally:
        other.kill()
        other.wait()
    build_many(f, executor="serial", quiet=True, force=True)
    assert not live.exists()  # its owner has ended: stale now


def test_a_job_recipe_builds_as_the_cli_does(lib_dir: Path, tmp_path: Path) -> None:
    """``recipe = "fast"`` in a job is ``tilesynth build --recipe fast``: the same tiles, recorded."""
    shutil.copytree(lib_dir / "tex", tmp_path / "tex")
    f = tmp_path / "lib.toml"
    f.write_text('output_dir = "out"\n[[jobs]]\nexemplar = "tex/bread.png"\nrecipe = "fast"\nsheet = false\n')
    build_many(f, quiet=True)
    got = ts.load(tmp_path / "out" / "bread.tiles")
    assert cli_main(["build", str(tmp_path / "tex" / "bread.png"), "-o", str(tmp_path / "c.tiles"), "--seed", "1",
                     "--recipe", "fast", "-q"]) == 0  # fmt: skip
    want = ts.load(tmp_path / "c.tiles")
    assert got.n_tiles == 256 and got.params["recipe"] == want.params["recipe"] == {
        "name": "fast",
        "applied": ["tileset"],
    }
    assert np.array_equal(got.tiles, want.tiles)
    # a set given with the recipe wins, the default set included (it used to be refused: the default could not
    # be told from "not given")
    f.write_text('output_dir = "out2"\n[[jobs]]\nexemplar = "tex/bread.png"\nrecipe = "fast"\nset = "c3"\n'
                 'sheet = false\n')  # fmt: skip
    build_many(f, quiet=True)
    given = ts.load(tmp_path / "out2" / "bread.tiles")
    assert given.n_tiles == 81 and given.params["recipe"] == {"name": "fast", "applied": []}
