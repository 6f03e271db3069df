"""Hostile and mistaken command-line input (the input half of issue 30): every value that can only fail must
exit 2 with one line naming the parameter, before any work; strings of a tampered tile set reach neither the
terminal nor the viewer page as commands."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import tilesynth as ts


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "tilesynth", *args], cwd=cwd, capture_output=True, text=True, timeout=300
    )


def _one_line_exit_2(r: subprocess.CompletedProcess, *words: str) -> None:
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "internal error" not in r.stderr
    for w in words:
        assert w in r.stderr, (w, r.stderr)


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("hostile")
    r = np.random.default_rng(0)
    ex = np.kron(r.random((16, 16, 3)), np.ones((4, 4, 1))).astype(np.float32)
    ts.build(ex, tileset="4", tile_size=16, seed=1).save(d / "s.tiles")
    ts.save_image(d / "ex.png", np.round(ex * 255).astype(np.uint8))
    return d


def _rewrite(src: Path, dst: Path, edit) -> Path:  # noqa: ANN001
    with zipfile.ZipFile(src) as zi:
        m = json.loads(zi.read("manifest.json"))
        edit(m)
        with zipfile.ZipFile(dst, "w") as zo:
            for info in zi.infolist():
                data = json.dumps(m).encode() if info.filename == "manifest.json" else zi.read(info.filename)
                zo.writestr(info.filename, data)
    return dst


@pytest.mark.parametrize("padding", ["17", "256"])
def test_export_padding_beyond_the_tile_size_exits_2(small, padding):
    r = _cli("export", "s.tiles", "-o", f"ex{padding}", "--padding", padding, cwd=small)
    _one_line_exit_2(r, "padding", "tile size (16)")
    assert not (small / f"ex{padding}").exists()
    assert _cli("export", "s.tiles", "-o", "ex16", "--padding", "16", cwd=small).returncode == 0


@pytest.mark.parametrize("scheduler", ["notaurl", "http://localhost:8787", "", "tcp://"])
def test_batch_scheduler_that_is_no_address_exits_2(small, scheduler):
    (small / "lib.toml").write_text('output_dir = "out"\n[[jobs]]\nexemplar = "ex.png"\ntile_size = 16\n')
    r = _cli("batch", "lib.toml", "--scheduler", scheduler, "-q", cwd=small)
    _one_line_exit_2(r, "scheduler")
    assert not (small / "out").exists()


@pytest.mark.parametrize("depth", [40, 5000])
def test_deeply_nested_batch_file_exits_2(small, depth):
    (small / "deep.toml").write_text("a = " + "[" * depth + "]" * depth + "\n")
    _one_line_exit_2(_cli("batch", "deep.toml", "-q", cwd=small), "deep.toml", "nested")
    (small / "deep2.toml").write_text("a = " + "{x = " * depth + "1" + "}" * depth + "\n")
    _one_line_exit_2(_cli("batch", "deep2.toml", "-q", cwd=small), "deep2.toml", "nested")


def test_nul_in_a_tampered_map_suffix_exits_2(tmp_path):
    from test_materials import _material

    albedo, height, _ = _material()
    ts.build(albedo, tileset="4", tile_size=16, seed=1, maps={"height": height}).save(tmp_path / "m.tiles")

    def edit(m: dict) -> None:
        m["maps"][0]["suffix"] = ".png\x00x"

    _rewrite(tmp_path / "m.tiles", tmp_path / "bad.tiles", edit)
    for cmd in (["info", "bad.tiles"], ["synth", "bad.tiles", "-o", "o.png", "--size", "32"]):
        _one_line_exit_2(_cli(*cmd, cwd=tmp_path), "maps[0].suffix")
    assert not list(tmp_path.glob("o*"))


HOSTILE = "<!--<script>\x1b]0;owned\x07\x1b[31mred\u202e</script>"


def test_a_hostile_layout_name_cannot_disable_the_viewer(small):
    from tilesynth.engine.viewer import page

    html = page({"levels": [], "title": HOSTILE, "note": "/*TS_GLSL*/ <!--TS_IMAGES-->"})
    body = re.search(r'<script id="ts-config" type="application/json">(.*?)</script>', html, re.S).group(1)
    assert "<" not in body and ">" not in body  # nothing the HTML parser could read as markup
    cfg = json.loads(body)
    assert cfg["title"] == HOSTILE and cfg["note"] == "/*TS_GLSL*/ <!--TS_IMAGES-->"
    # end to end: a tampered set's layout name in the exported viewer
    _rewrite(small / "s.tiles", small / "h.tiles", lambda m: m["layout"].__setitem__("name", "<!--<script>"))
    assert _cli("view", "h.tiles", "-o", "h.html", "--index-size", "2x2", cwd=small).returncode == 0
    page_text = (small / "h.html").read_text(encoding="utf-8")
    assert page_text.count("<script") == page_text.count("</script>")
    assert "<!--<script>" not in page_text


def test_info_escapes_control_characters_of_manifest_strings(small):
    def edit(m: dict) -> None:
        m["layout"]["name"] = HOSTILE
        m["exemplar"]["file"] = "ex\x1b[2J.png"
        m["params"]["set"] = "4\r\x1b]0;title\x07"

    _rewrite(small / "s.tiles", small / "ctl.tiles", edit)
    r = _cli("info", "ctl.tiles", cwd=small)
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert not re.search(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u202e]", out), repr(out[:400])
    assert "\\x1b[2J" in out and "\\x1b]0;title\\x07" in out
    j = _cli("info", "ctl.tiles", "--json", cwd=small)
    assert j.returncode == 0 and "\x1b" not in j.stdout
