"""First contact (issue 16): the README's Python snippet as pasted, the square --size shorthand, progress in
metrics and report, a retypeable fresh seed."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

import tilesynth
from tilesynth.cli.main import build_parser, main

README = Path(__file__).resolve().parent.parent / "README.md"


@pytest.mark.skipif(not README.is_file(), reason="README.md is not next to the tests")
def test_readme_python_snippet_runs_as_pasted(tmp_path, monkeypatch):
    block = re.search(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.DOTALL).group(1)
    monkeypatch.chdir(tmp_path)
    exec(compile(block, "README.md", "exec"), {})  # noqa: S102 - the documented snippet itself
    assert (tmp_path / "gravel.tiles").is_file() and (tmp_path / "gravel-1024.png").is_file()


def test_example_path_is_the_bundled_exemplar():
    p = tilesynth.data.example_path()
    img, bits = tilesynth.load_image(p)
    assert img.shape == (378, 378, 3) and bits == 8
    assert (p.parent / "LICENSE-lettuce-leaves.txt").is_file()


@pytest.mark.parametrize(("text", "size"), [("1024", (1024, 1024)), ("640x480", (640, 480)), (" 7 ", (7, 7))])
def test_size_square_shorthand(text, size):
    assert build_parser().parse_args(["synth", "x.tiles", "-o", "o.png", "--size", text]).size == size
    assert build_parser().parse_args(["demo", "--size", text]).size == size


@pytest.mark.parametrize("text", ["0", "x", "1024x", "-5", "10x0"])
def test_size_refused(text, capsys):
    assert main(["synth", "x.tiles", "-o", "o.png", "--size", text]) == 2
    assert "--size" in capsys.readouterr().err


@pytest.fixture(scope="module")
def built(tmp_path_factory, small_exemplar):
    d = tmp_path_factory.mktemp("fc")
    ex = d / "ex.png"
    tilesynth.save_image(ex, small_exemplar)
    return ex, d


def test_metrics_and_report_report_every_step(built, tmp_path):
    ex, _ = built
    ts = tilesynth.build(tilesynth.load_image(ex)[0], tile_size=24, seed=1)
    stages: list[tuple[str, int, int]] = []
    tilesynth.tileset_metrics(ts, 96, 96, 1, progress=lambda *a: stages.append(a))
    names = [s for s, done, _ in stages if done == 1]
    assert names == [
        "sample synthesis",
        "seam score",
        "coherence energy",
        "coverage",
        "repetition",
        "objective and cut seams",
    ]
    stages.clear()
    tilesynth.write_report(ts, tmp_path / "rep", 96, 96, 1, progress=lambda *a: stages.append(a))
    assert [s for s, done, _ in stages if done == 1][-1] == "report figures"
    assert "sample synthesis" in [s for s, _, _ in stages]


def test_metrics_cli_prints_slow_steps(built, capsys, monkeypatch):
    """A step over a second is reported on stderr (non-terminal: one line when it ends)."""
    import time

    from tilesynth.measure import metrics

    ex, d = built
    ts = d / "m.tiles"
    assert main(["build", str(ex), "-o", str(ts), "--tile-size", "24", "--seed", "1", "-q"]) == 0
    real = metrics.coherence_energy

    def slow(*a, **k):
        time.sleep(1.05)
        return real(*a, **k)

    monkeypatch.setattr(metrics, "coherence_energy", slow)
    capsys.readouterr()
    assert main(["metrics", str(ts), "--size", "96x96", "--json"]) == 0
    out = capsys.readouterr()
    json.loads(out.out)  # stdout stays pure JSON
    assert "coherence energy: done in" in out.err
    assert main(["metrics", str(ts), "--size", "96x96", "-q"]) == 0
    assert capsys.readouterr().err == ""


def test_fresh_seed_is_retypeable_and_kept(built, capsys):
    ex, d = built
    ts = d / "s.tiles"
    assert main(["build", str(ex), "-o", str(ts), "--tile-size", "24"]) == 0
    seed = re.search(r"seed (\d+)\)", capsys.readouterr().err).group(1)
    assert len(seed) <= 9
    assert main(["info", str(ts), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["params"]["seed"] == int(seed)
    again = d / "again.tiles"
    assert main(["build", str(ex), "-o", str(again), "--tile-size", "24", "--seed", seed, "-q"]) == 0
    assert tilesynth.load(again).content_digest() == tilesynth.load(ts).content_digest()
