"""The visible objective (issue 15, :mod:`tilesynth.builder.genes.visible_objective`): the proxy measures, their estimates against the
exact metrics, the rank-sum choice and the builds that use it."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.builder.genes.cut_objective import resolve_objective
from tilesynth.builder.genes.visible_objective import (
    PROXY_SEED,
    VISIBLE_RERANK,
    ProxyJudge,
    coherence_estimate,
    coherence_sample,
    pick_by_ranks,
    proxy_side,
    texture_stats_estimate,
)
from tilesynth.errors import ParameterError
from tilesynth.measure.metrics import coherence_energy, cut_seam_score
from tilesynth.measure.quality import texture_stats_distance

KW = dict(tileset="8", tile_size=24, threads=1, population=8)


def test_pick_by_ranks_oracle():
    rows = [
        {"cut_seam": 1.0, "coherence": 5.0, "texstats": 0.3},  # ranks 0 2 2 -> 4
        {"cut_seam": 2.0, "coherence": 1.0, "texstats": 0.2},  # ranks 1 0 1 -> 2
        {"cut_seam": 3.0, "coherence": 2.0, "texstats": 0.1},  # ranks 2 1 0 -> 3
    ]
    assert pick_by_ranks(rows) == 1
    # ties of the sum go to the earlier row; NaN ranks last
    assert pick_by_ranks([{"a": 1.0, "b": 2.0}, {"a": 2.0, "b": 1.0}], ("a", "b")) == 0
    assert pick_by_ranks([{"a": float("nan")}, {"a": 9.0}], ("a",)) == 1
    # equal values share the lower rank
    assert pick_by_ranks([{"a": 1.0, "b": 3.0}, {"a": 1.0, "b": 2.0}], ("a", "b")) == 1


def test_proxy_side_and_sample_rules():
    assert proxy_side(24) == 256 and proxy_side(80) == 256 and proxy_side(256) == 820
    assert coherence_sample((128, 128, 3)) >= 4000  # a 256² proxy on the bench's exemplars is exact
    assert coherence_sample((512, 512, 3)) == 256


@pytest.fixture(scope="module")
def built(lettuce):
    ex = np.ascontiguousarray(lettuce[100:196, 60:156])
    ts = tilesynth.build_omega(
        ex, seed=3, tileset="8", tile_size=24, threads=1, select="random", border_tries=1
    )
    img, _ = tilesynth.synthesize(ts, 256, 256, seed=PROXY_SEED, threads=1)
    return ex, ts, np.asarray(img)


def test_coherence_estimate_is_exact_without_sampling_and_close_with(built):
    ex, ts, img = built
    judge = ProxyJudge(ts.exemplar, 24, threads=1)
    exact = coherence_energy(img, ts.exemplar, threads=1)
    assert coherence_estimate(img, ts.exemplar, judge.index, 1) == pytest.approx(exact.energy, rel=1e-12)
    assert exact.searched > 200
    est = coherence_estimate(img, ts.exemplar, judge.index, 1, sample=exact.searched // 3)
    assert est == pytest.approx(exact.energy, rel=0.2)
    assert est != exact.energy


def test_texture_stats_estimate_equals_the_distance_below_the_pixel_budget(built):
    ex, ts, img = built
    judge = ProxyJudge(ts.exemplar, 24, threads=1)
    want = texture_stats_distance(img, ts.exemplar)
    assert texture_stats_estimate(img.astype(np.float64), judge.grams) == pytest.approx(want, rel=1e-9)


def test_judge_measures_are_the_exact_metrics_of_the_proxy(built):
    ex, ts, img = built
    m = ProxyJudge(ts.exemplar, 24, threads=1).measures(ts)
    assert m["cut_seam"] == pytest.approx(cut_seam_score(ts)["score"], rel=1e-12)
    assert m["coherence"] == pytest.approx(coherence_energy(img, ts.exemplar, threads=1).energy, rel=1e-12)
    assert m["texstats"] == pytest.approx(texture_stats_distance(img, ts.exemplar), rel=1e-9)


def test_visible_build_keeps_the_rank_sum_winner_and_is_reproducible(small_exemplar, tmp_path):
    """Oracle: each of the recorded candidates' measures is the proxy of its own build (genes given), the kept
    one has the smallest rank sum, and the build equals a build of its genes."""
    ts = tilesynth.build_omega(small_exemplar, seed=4, objective="visible", rerank=3, **KW)
    sel = ts.params["selection"]
    vis = sel["visible"]
    assert sel["objective"] == "visible" and sel["method"] == "best-of" and "cut" not in sel
    assert vis["rerank"] == 3 and vis["proxy_side"] == 256 and vis["proxy_seed"] == PROXY_SEED
    rows = [{k: vis[k][i] for k in ("cut_seam", "coherence", "texstats")} for i in range(3)]
    assert vis["chosen"] == pick_by_ranks(rows)
    again = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=24, genes=ts.genes, threads=2)
    np.testing.assert_array_equal(again.tiles, ts.tiles)
    m = ProxyJudge(again.exemplar, 24, threads=1).measures(again)
    for k in ("cut_seam", "coherence", "texstats"):
        assert m[k] == pytest.approx(vis[k][vis["chosen"]], rel=1e-9)
    ts2 = tilesynth.build_omega(small_exemplar, seed=4, objective="visible", rerank=3, **{**KW, "threads": 2})
    np.testing.assert_array_equal(ts2.genes, ts.genes)
    p = tmp_path / "v.tiles"
    ts.save(p)
    assert tilesynth.TileSet.load(p).params["selection"]["visible"] == vis


def test_visible_rerank_one_is_best_of_by_sum_d(small_exemplar):
    a = tilesynth.build_omega(small_exemplar, seed=9, objective="visible", rerank=1, **KW)
    b = tilesynth.build_omega(small_exemplar, seed=9, objective="sum-d", **KW)
    np.testing.assert_array_equal(a.genes, b.genes)


def test_visible_objective_rules():
    assert resolve_objective(None, "visible", None, False, None)[3] == VISIBLE_RERANK
    assert resolve_objective("ga", "visible", None, False, {"rerank": 2})[1:] == ("visible", {}, 2)
    with pytest.raises(ParameterError, match="polish"):
        resolve_objective(None, "visible", None, True, None)


def test_cli_visible_objective_and_info(small_exemplar, tmp_path, capsys):
    from tilesynth.cli.main import main

    ex = tmp_path / "ex.png"
    tilesynth.save_image(ex, small_exemplar)
    out = tmp_path / "s.tiles"
    argv = ["build", str(ex), "-o", str(out), "--set", "8", "--tile-size", "24", "--seed", "1", "-q"]
    assert main([*argv, "--population", "5", "--rerank", "2", "--objective", "visible"]) == 0
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "objective     visible: 2 candidates measured on a 256² proxy synthesis" in text
