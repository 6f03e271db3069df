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
        "lattice",
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


# ------------------------------------------------------------------- first contact, second round (issue 30)
def test_quiet_is_accepted_by_export_view_and_info(built, tmp_path, capsys):
    ex, d = built
    ts = d / "q.tiles"
    assert main(["build", str(ex), "-o", str(ts), "--tile-size", "24", "--seed", "1", "-q"]) == 0
    capsys.readouterr()
    assert main(["export", str(ts), "-o", str(tmp_path / "e"), "--index-size", "2x2", "-q"]) == 0
    assert main(["view", str(ts), "-o", str(tmp_path / "v.html"), "--index-size", "2x2", "-q"]) == 0
    out = capsys.readouterr()
    assert out.out == "" and out.err == ""
    assert (tmp_path / "e" / "manifest.json").is_file() and (tmp_path / "v.html").is_file()
    assert main(["info", str(ts), "-q"]) == 0 and "tile set" in capsys.readouterr().out


def test_synth_index_map_flag_and_the_old_spelling_with_a_note(built, tmp_path, capsys):
    ex, d = built
    ts = d / "q.tiles"
    if not ts.exists():
        assert main(["build", str(ex), "-o", str(ts), "--tile-size", "24", "--seed", "1", "-q"]) == 0
    m = tmp_path / "m.npy"
    assert (
        main(["synth", str(ts), "-o", str(tmp_path / "a.png"), "--size", "64", "--save-map", str(m), "-q"])
        == 0
    )
    capsys.readouterr()
    assert main(["synth", str(ts), "-o", str(tmp_path / "b.png"), "--size", "64", "--index-map", str(m)]) == 0
    assert "--map is now" not in capsys.readouterr().err
    assert main(["synth", str(ts), "-o", str(tmp_path / "c.png"), "--size", "64", "--map", str(m)]) == 0
    assert "note: --map is now --index-map" in capsys.readouterr().err
    a, b, c = (tilesynth.load_image(tmp_path / f"{x}.png")[0] for x in "abc")
    assert (a == b).all() and (a == c).all()
    assert "--index-map" in build_parser()._subparsers._group_actions[0].choices["synth"].format_help()


def test_build_help_says_which_seed_is_used():
    text = build_parser()._subparsers._group_actions[0].choices["build"].format_help()
    flat = " ".join(text.split())
    assert (
        "fresh random seed, printed and recorded in the tile set" in flat
        and "batch files default to 1" in flat
    )


@pytest.mark.parametrize("name", ["a.png", "a.PNG", "a.jpg", "a.exr", "a.npy"])
def test_build_refuses_an_image_name_for_the_tile_set(built, tmp_path, capsys, name):
    ex, _ = built
    assert main(["build", str(ex), "-o", str(tmp_path / name), "--tile-size", "24", "-q"]) == 2
    err = capsys.readouterr().err
    assert "--output" in err and ".tiles" in err and "--sheet" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / name).exists()


def test_huge_map_weights_build_without_numpy_warnings(built, tmp_path):
    import warnings

    import numpy as np

    img = tilesynth.load_image(built[0])[0]
    height = img[..., :1].astype(np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for weights in (
            {"albedo": 1e308},
            {"height": 1e308},
            {"height": 1e300, "albedo": 1e-300},
            {"height": 1e-300},
        ):
            t = tilesynth.build(img, tile_size=24, seed=1, maps={"height": height}, map_weights=weights)
            assert np.isfinite(t.D).all()
    # only the ratio of the weights matters: 1e308 against 1 is the map alone, as 1 against 0
    a = tilesynth.build(
        img, tileset="4", tile_size=24, seed=1, maps={"height": height}, map_weights={"height": 1e308}
    )
    b = tilesynth.build(
        img, tileset="4", tile_size=24, seed=1, maps={"height": height}, map_weights={"albedo": 0}
    )
    assert np.array_equal(a.source, b.source)


def test_a_mask_with_nan_names_a_plain_position(built, tmp_path, capsys):
    import numpy as np

    ex, _ = built
    shape = tilesynth.load_image(ex)[0].shape[:2]
    m = np.zeros(shape, np.float32)
    m[3, 5] = np.nan
    np.save(tmp_path / "m.npy", m)
    assert (
        main(["build", str(ex), "-o", str(tmp_path / "x.tiles"), "--mask", str(tmp_path / "m.npy"), "-q"])
        == 2
    )
    err = capsys.readouterr().err
    assert "non-finite value nan at row 3, column 5" in err and "np." not in err


@pytest.mark.parametrize("n, words", [("3", "out of range"), ("17", "must be even"), ("2", "out of range")])
def test_metrics_tile_size_follows_builds_rules(built, tmp_path, capsys, n, words):
    ex, _ = built
    assert main(["metrics", str(ex), "--tile-size", n, "-q"]) == 2
    assert words in capsys.readouterr().err
    assert main(["metrics", str(ex), "--tile-size", "16", "-q"]) == 0


def test_shader_headers_have_no_placeholder_url():
    from importlib import resources

    for f in resources.files("tilesynth.engine").joinpath("shaders").iterdir():
        text = f.read_text(encoding="utf-8")
        assert "..." not in text.split("\n")[0] and "github.com/..." not in text, f.name


def test_batch_docstring_names_the_default_set():
    from tilesynth.cli import batch
    from tilesynth.schemes import DEFAULT_SETS

    assert f"default: {DEFAULT_SETS['omega']} for omega" in batch.__doc__


@pytest.mark.skipif(not README.is_file(), reason="README.md is not next to the tests")
def test_readme_says_the_first_command_compiles_rust_and_shows_progress():
    text = README.read_text(encoding="utf-8")
    first = re.search(r"```sh\n(.*?)```", text, re.DOTALL).group(1)
    assert "pip install -v ." in first
    after = text[text.index(first) : text.index(first) + len(first) + 400]
    assert "5 minutes" in after and "progress" in after
