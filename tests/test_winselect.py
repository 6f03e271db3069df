"""The window objective of the complete sets (issue 15, :mod:`tilesynth.builder.genes.window_objective`): the rules, the sub-plan of
a window's tiles, and the build that keeps the rank-sum winner of the candidates' windows."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.builder.genes.cut_objective import resolve_objective
from tilesynth.builder.genes.visible_objective import PROXY_SEED, ProxyJudge, pick_by_ranks
from tilesynth.builder.genes.window_objective import (
    WINDOW_COUNT,
    WINDOW_MEASURES,
    window_candidates,
    window_cells_map,
    window_image,
    window_measures,
)
from tilesynth.errors import ParameterError
from tilesynth.layouts.corners import CornerPlan, corner_set

KW = dict(tileset="c3", threads=1, diversity=0)  # diversity 0: a window's tiles are the full set's tiles


def test_window_objective_rules():
    assert resolve_objective(None, "window", None, False, None, complete=True) == (
        None,
        "window",
        {},
        WINDOW_COUNT,
    )
    assert resolve_objective(None, "window", None, False, {"rerank": 3}, complete=True)[3] == 3
    with pytest.raises(ParameterError, match="complete"):
        resolve_objective(None, "window", None, False, None)
    for args in (("best-of", "window", None, False, None), (None, "window", None, True, None)):
        with pytest.raises(ParameterError, match="window"):
            resolve_objective(*args, complete=True)
    with pytest.raises(ParameterError, match="rerank"):
        resolve_objective(None, "window", None, False, {"rerank": 0}, complete=True)


def test_plan_subset_keeps_each_tiles_tuple_and_variant():
    plan = CornerPlan.of(corner_set("c3x2"))
    idx = np.array([5, 4, 5, 100, 33, 32, 161])
    sub = plan.subset(idx)
    np.testing.assert_array_equal(sub.tile_patches, plan.tile_patches[idx])
    np.testing.assert_array_equal(sub.unique[sub.inverse], plan.tile_patches[idx])
    np.testing.assert_array_equal(sub.variants, plan.variants[idx])
    assert len(np.unique(sub.unique, axis=0)) == len(sub.unique) and sub.n_variants == plan.n_variants == 2
    assert list(sub.inverse[:3]) == [0, 0, 0]  # tiles 4 and 5 share a tuple; first appearance order


def test_window_candidates_are_the_border_best_in_draw_order(small_exemplar):
    from tilesynth.builder.genes.omega_borders import DEFAULT_CRITERION, _rank, predicted_corner_border_seam

    first = tilesynth.builder.genes.draws.random_genes(small_exemplar.shape, 3, 24, np.random.default_rng(9))
    every = window_candidates(small_exemplar, 24, np.random.default_rng(3), first, count=7, draws=7)
    assert every[0] is not None and np.array_equal(every[0], first) and len(every) == 7
    assert np.array_equal(
        every[1],
        tilesynth.builder.genes.draws.random_genes(small_exemplar.shape, 3, 24, np.random.default_rng(3)),
    )
    rank = [_rank(predicted_corner_border_seam(small_exemplar, g, 24), DEFAULT_CRITERION) for g in every]
    kept = window_candidates(small_exemplar, 24, np.random.default_rng(3), first, count=3, draws=7)
    want = sorted(np.argsort(rank, kind="stable")[:3])
    assert [g.tolist() for g in kept] == [every[i].tolist() for i in want]


# with the 1-px border ring (issue 29) this build has two tiles whose cut costs ~3700x the median (Kwatra's
# gradient-normalised weights): the cut-cost warning fires; it is not what this test is about (the outlier
# warning's false positives on such costs are noted in the issue 29 stop's note)
@pytest.mark.filterwarnings("ignore:.*cut-cost-outlier.*:tilesynth.InputWarning")
def test_window_build_keeps_the_rank_sum_winner_of_its_recorded_windows(small_exemplar, tmp_path):
    """Oracle: the recorded window of the kept genes is the window of the full build of those genes (diversity
    0: the same tiles), its image is the synthesis with the proxy seed, its measures are the recorded ones, the
    kept candidate has the smallest rank sum, and the build equals a build of its genes at any thread count."""
    ts = tilesynth.build_omega(small_exemplar, seed=5, objective="window", rerank=3, **KW)
    sel = ts.params["selection"]
    win = sel["window"]
    assert sel["method"] == "window" and sel["objective"] == "window" and "border_tries" not in sel
    assert win["count"] == 3 and win["cells"] == 8 and win["proxy_seed"] == PROXY_SEED
    rows = [{k: win[k][i] for k in WINDOW_MEASURES} for i in range(3)]
    assert win["chosen"] == pick_by_ranks(rows, WINDOW_MEASURES)
    full = tilesynth.build_omega(small_exemplar, genes=ts.genes, **{**KW, "threads": 2})
    np.testing.assert_array_equal(full.tiles, ts.tiles)
    imap = window_cells_map(tilesynth.layouts.hashed.lookup_scheme(full.definition))
    uniq, pos = np.unique(imap, return_inverse=True)
    pos = pos.reshape(imap.shape)
    assert win["window_tiles"] == uniq.size
    n = full.tile_size
    img, _ = tilesynth.synthesize(full, 8 * n, 8 * n, seed=PROXY_SEED, threads=1)
    np.testing.assert_array_equal(window_image(full.tiles[uniq], pos), np.asarray(img))
    m = window_measures(full.tiles[uniq], full.cut_masks[uniq], pos, ProxyJudge(full.exemplar, n, threads=1))
    for k in WINDOW_MEASURES:
        assert m[k] == pytest.approx(win[k][win["chosen"]], rel=1e-9)
    ts2 = tilesynth.build_omega(small_exemplar, seed=5, objective="window", rerank=3, **{**KW, "threads": 2})
    np.testing.assert_array_equal(ts2.genes, ts.genes)
    p = tmp_path / "w.tiles"
    ts.save(p)
    assert tilesynth.TileSet.load(p).params["selection"]["window"] == win


def test_window_objective_refuses_other_sets_and_masks(small_exemplar):
    with pytest.raises(ParameterError, match="complete"):
        tilesynth.build_omega(small_exemplar, tileset="8", tile_size=24, objective="window", seed=1)
    mask = np.zeros(small_exemplar.shape[:2], bool)
    mask[:8, :8] = True
    with pytest.raises(ParameterError, match="mask"):
        tilesynth.build_omega(small_exemplar, seed=1, objective="window", mask=mask, **KW)


def test_cli_window_objective_and_info(small_exemplar, tmp_path, capsys):
    from tilesynth.cli.main import main

    ex = tmp_path / "ex.png"
    tilesynth.save_image(ex, small_exemplar)
    out = tmp_path / "w.tiles"
    argv = ["build", str(ex), "-o", str(out), "--set", "c3", "--seed", "1", "-q"]
    assert main([*argv, "--rerank", "2", "--objective", "window"]) == 0
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "objective     window: 2 random draws measured on a 8x8-tile window" in text
