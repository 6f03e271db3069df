"""The cut objective (issue 15): the robust cut score, the texture statistics, the re-ranking of a selection's
best candidates by the real cut cost, the cut polish and the measures stored with every build."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.builder.genes.cut_objective import DEFAULT_COUNT, DEFAULT_RERANK, TopK, resolve_objective
from tilesynth.errors import ParameterError, ShapeError
from tilesynth.measure.quality import CUT_SCORE_EPS, cut_score, texture_stats_distance


def test_cut_score_is_the_geometric_mean_with_eps():
    c = np.array([10.0, 40.0, 0.0])
    eps = CUT_SCORE_EPS * 20
    want = np.exp(np.mean(np.log(c + eps)))
    assert cut_score(c, 20) == pytest.approx(want, rel=1e-12)
    assert cut_score([np.inf, 1.0], 8) == np.inf
    assert np.isnan(cut_score([], 8))


def test_cut_score_is_robust_to_one_blow_up_tile():
    """One tile at 2e6 (Kwatra's eps on a flat saturated region) moves a sum by 10^5, the score by a factor
    below 10 (six tiles): a set with many moderately worse tiles still ranks worse."""
    good = np.full(6, 50.0)
    one_blow_up = good.copy()
    one_blow_up[0] = 2e6
    all_worse = np.full(6, 200.0)
    assert one_blow_up.sum() > 1000 * all_worse.sum() / 4
    assert cut_score(one_blow_up, 80) < 10 * cut_score(good, 80)
    assert cut_score(all_worse, 80) > cut_score(good, 80)
    # a zero-cost cut is good, not infinitely good
    assert cut_score(np.zeros(6), 80) == pytest.approx(CUT_SCORE_EPS * 80)


def test_texture_stats_distance_zero_for_the_exemplar_and_grows_for_other_content(small_exemplar):
    ex = small_exemplar
    assert texture_stats_distance(ex, ex) == pytest.approx(0.0, abs=1e-12)
    rng = np.random.default_rng(0)
    noise = rng.random(ex.shape).astype(np.float32)
    flat = np.full_like(ex, 0.5)
    tiled = np.tile(ex, (2, 2, 1))  # the same content: close
    d_tiled = texture_stats_distance(tiled, ex)
    assert d_tiled < texture_stats_distance(noise, ex)
    assert d_tiled < texture_stats_distance(flat, ex)
    with pytest.raises(ShapeError):
        texture_stats_distance(ex[:5, :5], ex)
    with pytest.raises(ShapeError):
        texture_stats_distance(ex[..., :1], ex)


def test_topk_keeps_the_best_distinct_vectors_first_seen_first():
    top = TopK(3)

    def ev(g):
        e = g[:, 0, 0].astype(float)
        return e, np.zeros((len(g), 1))

    w = top.wrap(ev)
    pops = [np.array([[[v, 0], [0, v + 1]]]) for v in (5, 2, 9, 2, 1, 7, 2)]
    for _ in range(30):  # enough calls to trim
        for p in pops:
            w(p)
    best = top.best()
    assert [int(b[0, 0]) for b in best] == [1, 2, 5]


def test_resolve_objective_rules():
    sel, obj, params, k = resolve_objective(None, None, None, False, None)
    assert (sel, obj, params["count"], k) == ("best-of", "cut", DEFAULT_COUNT, DEFAULT_RERANK)
    assert resolve_objective("ga", None, None, False, None)[1] == "E"  # the papers' methods keep E
    assert resolve_objective("ga", "sum_d", None, False, None)[1:] == ("sum-d", {}, 0)
    assert resolve_objective(None, None, None, False, None, population=7)[2] == {}
    assert resolve_objective(None, None, None, False, {"rerank": 2})[3] == 2
    with pytest.raises(ParameterError, match="objective"):
        resolve_objective(None, "ssd", None, False, None)
    with pytest.raises(ParameterError, match="genes and objective"):
        resolve_objective(None, "cut", np.zeros((2, 2), np.int64), False, None)
    with pytest.raises(ParameterError, match="rerank"):
        resolve_objective("ga", "E", None, False, {"rerank": 3})
    with pytest.raises(ParameterError, match="rerank"):
        resolve_objective(None, None, None, False, {"rerank": 0})


def test_default_keeps_the_candidate_with_the_lowest_real_cut_score(small_exemplar):
    """Oracle: every re-ranked candidate built on its own (genes given) has the recorded score, and the
    default build is the cheapest of them."""
    ts = tilesynth.build_omega(
        small_exemplar, tileset="8", tile_size=24, seed=4, threads=1, population=8, rerank=3
    )
    sel = ts.params["selection"]
    assert sel["method"] == "best-of" and sel["objective"] == "cut"
    cut = sel["cut"]
    assert cut["rerank"] == 3 and len(cut["scores"]) == 3
    assert cut["scores"][cut["chosen"]] == min(cut["scores"])
    assert ts.params["quality"]["cut_score"] == pytest.approx(cut["score"], rel=1e-12)
    again = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=24, genes=ts.genes, threads=2)
    np.testing.assert_array_equal(again.tiles, ts.tiles)
    assert cut_score(again.cut_costs, 24) == pytest.approx(cut["score"], rel=1e-12)
    # the same seed gives the same set at any thread count
    ts2 = tilesynth.build_omega(
        small_exemplar, tileset="8", tile_size=24, seed=4, threads=2, population=8, rerank=3
    )
    np.testing.assert_array_equal(ts2.genes, ts.genes)


def test_rerank_one_is_best_of_by_sum_d(small_exemplar):
    """With one candidate the cut objective keeps the best of the draws by ΣD: the sum-d objective's choice."""
    kw = dict(tileset="8", tile_size=24, seed=9, threads=1, population=6)
    a = tilesynth.build_omega(small_exemplar, rerank=1, **kw)
    b = tilesynth.build_omega(small_exemplar, objective="sum-d", **kw)
    np.testing.assert_array_equal(a.genes, b.genes)
    assert b.params["selection"]["objective"] == "sum-d" and "cut" not in b.params["selection"]


def test_cut_polish_never_raises_the_score_and_matches_a_rebuild(small_exemplar):
    ts = tilesynth.build_omega(
        small_exemplar, tileset="8", tile_size=24, seed=4, threads=1, population=8, rerank=2, polish=True
    )
    cut = ts.params["selection"]["cut"]
    pol = cut["polish"]
    assert cut["score"] <= pol["score_before"]
    assert pol["builds"] >= 1 and pol["sweeps"] >= 1
    again = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=24, genes=ts.genes, threads=1)
    assert cut_score(again.cut_costs, 24) == pytest.approx(cut["score"], rel=1e-12)
    # genes stay distinct and N/4 apart from each other after a move
    g = ts.genes
    cheb = np.abs(g[:, None] - g[None]).max(axis=2) + np.eye(len(g), dtype=int) * 99
    assert cheb.min() >= 24 // 4 or pol["moves"] == 0


def test_explicit_methods_keep_the_papers_objective(small_exemplar):
    kw = dict(tileset="8", tile_size=24, seed=5, threads=1, select="best-of", population=12)
    a = tilesynth.build_omega(small_exemplar, **kw)
    b = tilesynth.build_omega(small_exemplar, objective="E", **kw)
    np.testing.assert_array_equal(a.genes, b.genes)
    assert a.params["selection"]["objective"] == "E"


def test_random_select_is_one_draw_and_measures_are_stored(small_exemplar, tmp_path):
    # border_tries=1: the single draw (the default random draw is border-aware, tilesynth.builder.genes.omega_borders)
    ts = tilesynth.build_omega(
        small_exemplar, tileset="8", tile_size=24, seed=5, select="random", border_tries=1
    )
    assert ts.params["selection"] == {"method": "random"}
    q = ts.params["quality"]
    assert q["cut_score"] == pytest.approx(cut_score(ts.cut_costs, 24))
    assert 0 < q["tile_coverage"] <= 1 and q["cut_seam"] > 0
    p = tmp_path / "s.tiles"
    ts.save(p)
    assert tilesynth.TileSet.load(p).params["quality"] == q


def test_every_scheme_stores_the_measures(small_exemplar):
    for build in (tilesynth.build_wang, tilesynth.build_swang):
        ts = build(small_exemplar, tile_size=24, seed=1)
        assert set(ts.params["quality"]) == {"cut_score", "cut_score_eps", "cut_seam", "tile_coverage"}


def test_cli_objective_and_info(small_exemplar, tmp_path, capsys):
    from tilesynth.cli.main import main

    ex = tmp_path / "ex.png"
    tilesynth.save_image(ex, small_exemplar)
    out = tmp_path / "s.tiles"
    argv = ["build", str(ex), "-o", str(out), "--set", "8", "--tile-size", "24", "--seed", "1", "-q"]
    assert main([*argv, "--population", "5", "--rerank", "2"]) == 0
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "quality       cut score" in text and "objective     cut: 2 candidates" in text
    assert (
        main([*argv, "--select", "ga", "--generations", "2", "--population", "4", "--objective", "sum-d"])
        == 0
    )
    assert tilesynth.TileSet.load(out).params["selection"]["objective"] == "sum-d"
    assert main([*argv, "--objective", "bogus"]) == 2


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402


@given(
    costs=hnp.arrays(np.float64, st.integers(0, 20), elements=st.floats(allow_nan=True, allow_infinity=True)),
    n=st.integers(4, 512),
)
def test_cut_score_fuzz_never_crashes_and_never_nan_for_finite_costs(costs, n):
    s = cut_score(costs, n)
    if costs.size and np.isfinite(costs).all():  # negative costs count as 0: never below eps
        assert np.isfinite(s) and s >= CUT_SCORE_EPS * n * (1 - 1e-12)
    elif costs.size:
        assert s == np.inf
    else:
        assert np.isnan(s)


@settings(max_examples=15)
@given(
    img=hnp.arrays(
        st.sampled_from([np.float32, np.uint8]),
        st.tuples(st.integers(1, 24), st.integers(1, 24), st.sampled_from([1, 3, 4])),
    ),
)
def test_texture_stats_fuzz_gives_a_number_or_a_named_error(img, small_exemplar):
    try:
        d = texture_stats_distance(
            img, small_exemplar[..., : img.shape[2]] if img.shape[2] <= 3 else small_exemplar
        )
    except (ShapeError, ParameterError, TypeError):
        return
    assert np.isfinite(d) and d >= 0


def test_ga_population_is_re_ranked_by_the_cut_score(small_exemplar):
    """objective="cut" with a named method: the best distinct individuals the GA evaluated (by ΣD) are built and
    the cheapest cut kept; the first candidate is the GA's own best by ΣD."""
    kw = dict(tileset="8", tile_size=24, seed=3, threads=1, select="ga", population=6, generations=3)
    cut = tilesynth.build_omega(small_exemplar, objective="cut", rerank=3, **kw)
    sumd = tilesynth.build_omega(small_exemplar, objective="sum-d", **kw)
    rec = cut.params["selection"]["cut"]
    assert cut.params["selection"]["method"] == "ga" and rec["rerank"] == 3
    first = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=24, genes=sumd.genes, threads=1)
    assert rec["scores"][0] == pytest.approx(cut_score(first.cut_costs, 24), rel=1e-12)
    assert rec["score"] == min(rec["scores"])
