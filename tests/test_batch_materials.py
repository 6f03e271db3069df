"""Batch keys of material builds (issue 14, :mod:`tilesynth.cli.batch_materials`): ``maps`` table entries with kind and
weight, ``mask``, ``alpha``, ``normal_y``; a batch material build equals ``tilesynth build`` with the same options; every bad value is refused
before any work, naming the job and the field."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from test_materials import _material, _real_world_normals

import tilesynth as ts
from tilesynth.builder.materials import DEFAULT_WEIGHTS
from tilesynth.cli import batch
from tilesynth.cli.batch import BatchError, build_many, load_library
from tilesynth.cli.main import main as cli_main

LIB = """
output_dir = "out"

[presets.mat]
tile_size = 16
set = "4"
sheet = false
previews = [{{ size = "48x40", seed = 3 }}]
{preset_extra}

[[jobs]]
exemplar = "rock.png"
preset = "mat"
seed = 2
{job_extra}
maps.normal = {{ file = "rock-normal.png", kind = "normal", weight = 0.75 }}
maps.height = {{ file = "rock-height.png" }}
maps.ao = "rock-height.png"
"""


@pytest.fixture
def mat_dir(tmp_path: Path) -> Path:
    albedo, height, normal = _material()
    ts.save_image(tmp_path / "rock.png", albedo)
    ts.save_image(tmp_path / "rock-height.png", height)
    ts.save_image(tmp_path / "rock-normal.png", normal)
    mask = np.zeros((64, 64), np.uint8)
    mask[5:12, 40:50] = 255
    ts.save_image(tmp_path / "rock-mask.png", mask)
    return tmp_path


def _write(d: Path, job_extra: str = "", preset_extra: str = "") -> Path:
    f = d / "lib.toml"
    f.write_text(LIB.format(job_extra=job_extra, preset_extra=preset_extra), encoding="utf-8")
    return f


def test_material_job_equals_the_cli_build_and_writes_every_map(mat_dir: Path) -> None:
    f = _write(
        mat_dir, job_extra='mask = "rock-mask.png"\nnormal_y = "down"', preset_extra='alpha = "colour"'
    )
    lib = load_library(f)
    (job,) = lib.jobs
    assert set(job.material) == {"normal", "height"} and set(job.maps) == {"ao"}
    assert job.material["normal"]["weight"] == 0.75 and job.material["height"]["kind"] == "scalar"
    assert job.material["height"]["weight"] == DEFAULT_WEIGHTS["scalar"]
    assert (
        job.mask == (mat_dir / "rock-mask.png").resolve() and job.alpha == "colour" and job.normal_y == "down"
    )
    assert {"preview-normal", "preview-height", "preview-ao"} <= set(job.outputs)
    res = build_many(f, "serial", quiet=True)
    assert res.n_failed == 0, res.records
    got = ts.load(mat_dir / "out" / "rock.tiles")
    d = str(mat_dir) + "/"
    argv = ["build", d + "rock.png", "-o", d + "cli.tiles", "--set", "4", "--tile-size", "16", "--seed", "2",
            "--map", "normal:normal=" + d + "rock-normal.png", "--map", "height=" + d + "rock-height.png",
            "--map-weight", "normal=0.75", "--normal-y", "down", "--mask", d + "rock-mask.png", "--alpha", "colour",
            "-q"]  # fmt: skip
    assert cli_main(argv) == 0
    ref = ts.load(mat_dir / "cli.tiles")  # the same build as `tilesynth build` with the same options
    assert got.content_digest() == ref.content_digest()
    assert got.map_specs == ref.map_specs and got.params["mask"] == ref.params["mask"]
    imap = ts.synthesize(got, 48, 40, seed=3)[1]
    maps = ts.synthesize_maps(got, imap, 48, 40)
    for name in ("normal", "height"):
        out = ts.load_raster(mat_dir / "out" / f"rock-preview-{name}.png")
        assert np.array_equal(out, maps[name]), name
    assert (mat_dir / "out" / "rock-preview-ao.png").is_file()
    # the mask's content is part of the key: a changed mask rebuilds the job, an unchanged one skips it
    assert build_many(f, "serial", quiet=True).records[0]["status"] == "skipped"
    m = ts.load_raster(mat_dir / "rock-mask.png")
    m[30:33, 30:33] = 255
    ts.save_image(mat_dir / "rock-mask.png", m)
    assert build_many(f, "serial", quiet=True).records[0]["status"] == "built"


def test_jobs_without_the_new_keys_keep_their_parameters(mat_dir: Path) -> None:
    f = mat_dir / "plain.toml"
    f.write_text('[[jobs]]\nexemplar = "rock.png"\nmaps = { ao = "rock-height.png" }\n', encoding="utf-8")
    (job,) = load_library(f).jobs
    params = job.params()
    assert not {"material_maps", "mask", "alpha", "normal_y"} & set(params)  # old stamps' keys unchanged


@pytest.mark.parametrize(
    "job_extra, words",
    [
        ('maps.x = { file = "rock-height.png", kind = "bump" }', ["'x'", "unknown map kind", "bump"]),
        ('maps.x = { file = "rock-height.png", weight = -1 }', ["'x'", "weight", "-1"]),
        ('maps.x = { file = "rock-height.png", weight = "2" }', ["'x'", "weight"]),
        ('maps.x = { file = "rock-height.png", wieght = 2 }', ["'x'", "unknown key", "wieght"]),
        ('maps.x = { kind = "scalar" }', ["'x'", "'file'"]),
        ('maps.x = { file = "nope.png" }', ["'x'", "no such file", "nope.png"]),
        ('maps.albedo = { file = "rock-height.png" }', ["'albedo'"]),
        ('maps.Height = { file = "rock-height.png" }', ["duplicate", "Height"]),
        ('normal_y = "sideways"', ["normal_y", "sideways"]),
        ('alpha = "opaque"', ["alpha", "opaque"]),
        ('mask = "missing-mask.png"', ["mask", "no such file"]),
        ('mask = "a-folder"', ["mask", "is a directory", "a-folder"]),
        ('maps.x = { file = "a-folder" }', ["'x'", "is a directory", "a-folder"]),
        ('maps.x = { file = "a-fifo" }', ["'x'", "not a regular file", "a-fifo"]),
        ("mask = 3", ["mask", "file path"]),
        ('map_kinds = { height = "copy" }', ["map_kinds", "height", "material map"]),
    ],
)
def test_bad_material_keys_are_refused_before_any_work(
    mat_dir: Path, job_extra: str, words: list[str]
) -> None:
    (mat_dir / "a-folder").mkdir()
    os.mkfifo(mat_dir / "a-fifo")  # reading it would block: the check must not open it
    f = _write(mat_dir, job_extra=job_extra)
    with pytest.raises(BatchError) as e:
        load_library(f)
    msg = str(e.value)
    assert "job 1" in msg
    for w in words:
        assert w.lower() in msg.lower(), (w, msg)
    assert not (mat_dir / "out").exists()


def test_normal_y_needs_a_normal_material_map(mat_dir: Path) -> None:
    f = mat_dir / "n.toml"
    f.write_text(
        '[[jobs]]\nexemplar = "rock.png"\nnormal_y = "down"\nmaps.height = { file = "rock-height.png" }\n',
        encoding="utf-8",
    )
    with pytest.raises(BatchError, match="normal_y"):
        load_library(f)


def test_a_misaligned_material_map_fails_its_job_with_the_map_named(mat_dir: Path) -> None:
    ts.save_image(mat_dir / "small.png", np.zeros((32, 64), np.uint8))
    f = _write(mat_dir, job_extra='maps.rough = { file = "small.png", kind = "scalar" }')
    res = build_many(f, "serial", quiet=True)
    (rec,) = res.records
    assert rec["status"] == "failed" and "rough" in rec["error"] and "pixel-aligned" in rec["error"], rec
    assert not (mat_dir / "out" / "rock.tiles").exists()
    assert batch.BatchResult  # the result type stays public


def test_a_downscaled_normal_map_builds_in_a_batch_and_the_fix_is_recorded(mat_dir: Path) -> None:
    raw, _ = _real_world_normals("z0.51")
    ts.save_image(mat_dir / "rock-normal.png", raw)
    res = build_many(_write(mat_dir), "serial", quiet=True)
    (rec,) = res.records
    assert rec["status"] == "built", rec
    t = ts.TileSet.load(mat_dir / "out" / "rock.tiles")
    assert t.params["material"]["normalised"]["normal"].startswith("z rebuilt from x and y")


def test_dry_run_checks_map_contents_as_the_build_does(mat_dir: Path, capsys) -> None:
    ts.save_image(
        mat_dir / "rock-normal.png", np.repeat(_material()[0][..., :1], 3, axis=2)
    )  # a grey "normal"
    f = _write(mat_dir)
    assert cli_main(["batch", str(f), "--dry-run"]) == 2
    out = capsys.readouterr()
    assert "rock: would fail:" in out.out and "grey image" in out.out and "normal:scalar" in out.out
    assert "1 of 1 job(s) would fail" in out.err and len(out.err.strip().splitlines()) == 1
    assert not (mat_dir / "out").exists()
    ts.save_image(mat_dir / "small.png", np.zeros((32, 64), np.uint8))  # a misaligned map: refused too
    ts.save_image(mat_dir / "rock-normal.png", _material()[2])
    f = _write(mat_dir, job_extra='maps.rough = { file = "small.png", kind = "scalar" }')
    assert cli_main(["batch", str(f), "--dry-run"]) == 2
    assert "pixel-aligned" in capsys.readouterr().out
    f = _write(mat_dir)
    assert cli_main(["batch", str(f), "--dry-run"]) == 0
    assert "rock: to build" in capsys.readouterr().out


@pytest.mark.parametrize(
    "preset_extra, words",
    [
        ("export = { padding = 999 }", ["'padding' = 999", "[0, 256]"]),
        ("export = { padding = 20 }", ["'padding' = 20", "tile size (16)"]),
        ('previews = [{ size = "100000x100000" }]', ["'previews' entry 1", "100000x100000", "limit"]),
    ],
)
def test_values_that_would_fail_after_the_build_are_refused_before_any_work(
    mat_dir: Path, preset_extra: str, words: list[str], monkeypatch
) -> None:
    monkeypatch.setenv("TILESYNTH_MAX_BYTES", str(8 << 30))
    f = mat_dir / "lib.toml"
    f.write_text(LIB.replace("previews = [{{ size = \"48x40\", seed = 3 }}]", "").format(
        job_extra="", preset_extra=preset_extra), encoding="utf-8")  # fmt: skip
    with pytest.raises(BatchError) as exc:
        load_library(f)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))
    assert not (mat_dir / "out").exists()


def test_an_output_name_too_long_for_the_file_system_is_refused_before_any_work(mat_dir: Path) -> None:
    f = _write(mat_dir, job_extra=f'name = "{"n" * 256}"')
    with pytest.raises(BatchError, match="field 'name'.*256 characters"):
        load_library(f)
    ok = _write(mat_dir, job_extra=f'name = "{"n" * 150}"')
    assert load_library(ok).jobs[0].name == "n" * 150
