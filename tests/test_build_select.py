"""Selection wired into the ω construction: build_omega(select=...), the tile-set file, `build --select`, `info`."""

from __future__ import annotations

import json

import numpy as np
import pytest

import tilesynth
from tilesynth.builder.omega import energy
from tilesynth.cli.main import main


@pytest.fixture(scope="module")
def ex(small_exemplar):
    return np.ascontiguousarray(small_exemplar[:64, :64])


@pytest.mark.parametrize("method", ["best-of", "ga", "ais"])
def test_build_with_selection(method, ex, tmp_path):
    kw = {"population": 8} | ({"generations": 4} if method != "best-of" else {})
    ts = tilesynth.build_omega(ex, tileset="n1", tile_size=32, seed=4, select=method, **kw)
    sel = ts.params["selection"]
    assert sel["method"] == method and sel["evaluations"] >= 8
    # the stored E is the objective of the stored genes, recomputed from scratch by the construction
    assert ts.E == pytest.approx(sel["objective_E"], rel=1e-9)
    assert ts.E == pytest.approx(energy(ts.D), rel=1e-12)
    hist = sel["history"]
    assert len(hist["best"]) == sel["generations"] == len(hist["mean"]) >= 1
    assert all(b <= m + 1e-9 for b, m in zip(hist["best"], hist["mean"]))
    # the best ever is at least as good as the best of the first generation
    assert ts.E <= hist["best"][0] * (1 + 1e-12)
    # it is the evaluator's value for the stored genes
    ev = tilesynth.PopulationEvaluator(ex, 32, np.unique(ts.tile_patches, axis=0), len(ts.genes))
    E, _ = ev.evaluate(ts.genes[None])
    assert E[0] == pytest.approx(ts.E, rel=1e-9)
    p = tmp_path / "s.tiles"
    ts.save(p)
    back = tilesynth.load(p)
    assert back.params["selection"] == sel and back.content_digest() == ts.content_digest()


def test_selection_reproducible_and_thread_independent(ex):
    a = tilesynth.build_omega(
        ex, tileset="8", tile_size=32, seed=9, select="ais", generations=3, population=6, threads=1
    )
    b = tilesynth.build_omega(
        ex, tileset="8", tile_size=32, seed=9, select="ais", generations=3, population=6, threads=2
    )
    assert a.content_digest() == b.content_digest()
    np.testing.assert_array_equal(a.genes, b.genes)


def test_polish_never_worse_and_normalised_objective(ex):
    base = tilesynth.build_omega(
        ex, tileset="8", tile_size=32, seed=2, select="ga", generations=3, population=6
    )
    pol = tilesynth.build_omega(
        ex, tileset="8", tile_size=32, seed=2, select="ga", generations=3, population=6, polish=True
    )
    assert pol.E <= base.E * (1 + 1e-12)
    assert pol.params["selection"]["polish"]["E_before"] == pytest.approx(base.E, rel=1e-9)
    nrm = tilesynth.build_omega(
        ex, tileset="8", tile_size=32, seed=2, select="best-of", population=5, normalise=True
    )
    sel = nrm.params["selection"]
    assert sel["normalise"] is True
    # 003's normalisation divides every C_j by the N·N overlapping pixels: D_j / N² in the objective
    d = nrm.D / (32 * 32)
    assert sel["objective_E"] == pytest.approx(0.8 * d.sum() + 0.2 * d.var(), rel=1e-9)


def test_select_and_genes_conflict(ex):
    with pytest.raises(tilesynth.ParameterError, match="genes"):
        tilesynth.build_omega(
            ex, tileset="4", tile_size=32, genes=[[0, 0], [1, 1], [2, 2], [3, 3]][:2], select="ga"
        )
    with pytest.raises(tilesynth.ParameterError, match="method"):
        tilesynth.build_omega(ex, tileset="4", tile_size=32, select="annealing")


def test_cli_select_and_info(ex, tmp_path, capsys):
    png = tmp_path / "ex.png"
    tilesynth.save_image(png, ex)
    out = tmp_path / "n2.tiles"
    assert (
        main(
            [
                "build",
                str(png),
                "-o",
                str(out),
                "--set",
                "n2",
                "--tile-size",
                "24",
                "--select",
                "ais",
                "--generations",
                "3",
                "--population",
                "6",
                "--polish",
                "--seed",
                "1",
                "-q",
            ]
        )
        == 0
    )
    ts = tilesynth.load(out)
    assert ts.n_tiles == 38 and ts.params["selection"]["method"] == "ais"
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "ais + polish" in text and "convergence" in text and "evaluations" in text
    assert main(["info", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["params"]["selection"]["history"]["best"]


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--set", "zz"], "unknown tile set"),
        (["--select", "annealing"], "--select"),
        (["--generations", "5"], "--generations"),
        (["--select", "ga", "--generations", "0"], "generations"),
        (["--select", "random", "--population", "4"], "--population"),
    ],
)
def test_cli_select_errors(args, words, ex, tmp_path, capsys):
    png = tmp_path / "ex.png"
    tilesynth.save_image(png, ex)
    out = tmp_path / "x.tiles"
    assert main(["build", str(png), "-o", str(out), "--tile-size", "24", "-q", *args]) == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
