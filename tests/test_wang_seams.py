"""Seamless tile borders by default for the Wang schemes (issue 14, item 6): pinned corners, border-aware draws
(:mod:`tilesynth.builder.genes.wang_borders`), and Cohen's literal construction kept as an option."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.builder.genes.draws import random_genes
from tilesynth.builder.genes.wang_borders import (
    DEFAULT_BORDER_TRIES,
    border_aware_genes,
    check_border_tries,
    predicted_border_seam,
)
from tilesynth.builder.wang import NORTH, SOUTH, corner_mismatch
from tilesynth.cli.main import main
from tilesynth.measure import metrics

LITERAL = {"corners": "free", "border_tries": 1}  # Cohen et al.: free corners, one random draw

DEFAULTS = [
    ("wang", "wang8"),
    ("wang", "wang18"),
    ("wang", "wc2"),
    ("swang", "wang8"),
]


def continuity(ts, width, height, seed):
    """(horizontal-border, vertical-border) bool maps: True where the pixel pair across a tile border is
    continuous exemplar content (from the provenance)."""
    img, imap = tilesynth.synthesize(ts, width, height, seed=seed)
    src = tilesynth.source_map(ts, imap, width, height)
    n = ts.tile_size
    xs, ys = np.arange(n, width, n), np.arange(n, height, n)
    v_ok = (src[:, xs, 0] == src[:, xs - 1, 0]) & (src[:, xs, 1] == src[:, xs - 1, 1] + 1)
    h_ok = (src[ys, :, 0] == src[ys - 1, :, 0] + 1) & (src[ys, :, 1] == src[ys - 1, :, 1])
    return h_ok, v_ok


@pytest.mark.parametrize(("scheme", "tset"), DEFAULTS)
def test_defaults_have_no_discontinuous_corner(scheme, tset, small_exemplar):
    """With the defaults, no edge pixel shows a wrong sample, and every pair across a tile border is continuous
    exemplar content except the junction pairs at the two ends of each vertical border (where the samples of two
    horizontal edges meet: unavoidable with edge colours). Cohen's free corners (the old default) break this."""
    n = 24
    ts = tilesynth.build(small_exemplar, scheme=scheme, tileset=tset, tile_size=n, seed=3)
    assert (corner_mismatch(ts.labels) == 0).all()
    W, H = n * 7 + 5, n * 6 + 3
    h_ok, v_ok = continuity(ts, W, H, seed=2)
    rows = np.arange(H) % n
    assert h_ok.all()
    assert v_ok[(rows != 0) & (rows != n - 1)].all()
    if scheme == "wang":
        old = tilesynth.build_wang(small_exemplar, tileset=tset, tile_size=n, seed=3, **LITERAL)
        assert corner_mismatch(old.labels).sum() > 0
        h_old, v_old = continuity(old, W, H, seed=2)
        assert not h_old.all() and not v_old[(rows != 0) & (rows != n - 1)].all()


@pytest.mark.parametrize("tile_size", [24, 32])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_default_border_seam_score_within_one_where_cohen_exceeds_it(tile_size, seed, small_exemplar):
    """The target of issue 14: border seam score <= 1.0 for the default of every Wang scheme. On the lettuce
    crop (96x96) Cohen's literal construction (free corners, one random draw) scores above 1 for every one of
    these seeds (1.09-2.74 when this was written), so the test fails on the old default."""
    n = tile_size
    for scheme in ("wang", "swang"):
        ts = tilesynth.build(small_exemplar, scheme=scheme, tile_size=n, seed=seed)
        img, _ = tilesynth.synthesize(ts, 16 * n, 16 * n, seed=7)
        assert metrics.seam_score(img, n).score <= 1.0, (scheme, seed)
    old = tilesynth.build_wang(small_exemplar, tile_size=n, seed=seed, **LITERAL)
    img, _ = tilesynth.synthesize(old, 16 * n, 16 * n, seed=7)
    assert metrics.seam_score(img, n).score > 1.0


def _line_oracle(ts, ex):
    """S_pred from the built pinned tiles themselves: the pixel pairs each border colour puts across a border,
    read from a tile on either side (not from the gene arithmetic of tilesynth.builder.genes.wang_borders)."""
    tiles = ts.tiles.astype(np.float64)
    defn, n = ts.definition, ts.tile_size

    def with_(side, colour):
        return next(k for k, t in enumerate(defn.tiles) if t[side] == colour)

    def d2(a, b):
        return ((a - b) ** 2).sum(-1)

    # <N, E, S, W>
    by = np.mean([d2(tiles[with_(2, c), -1], tiles[with_(0, c), 0]).mean() for c in defn.horizontal])
    bv = np.mean(
        [d2(tiles[with_(1, c), 1:-1, -1], tiles[with_(3, c), 1:-1, 0]).mean() for c in defn.vertical]
    )
    junc = []
    for a in defn.horizontal:
        for b in defn.horizontal:
            junc.append(
                d2(tiles[with_(2, a), -1, -1], tiles[with_(2, b), -1, 0])
            )  # above the horizontal border
            junc.append(d2(tiles[with_(0, a), 0, -1], tiles[with_(0, b), 0, 0]))  # below it
    bx = ((n - 2) * bv + 2 * np.mean(junc)) / n
    x = ex.astype(np.float64)
    ix = ((x[:, 1:] - x[:, :-1]) ** 2).sum(-1).mean()
    iy = ((x[1:] - x[:-1]) ** 2).sum(-1).mean()
    return (bx + by) / (ix + iy)


@pytest.mark.parametrize(("scheme", "tset", "kw"), [("wang", "wang18", {}), ("swang", "wang8", {}),
                                                     ("wang", "wang8", {"samples": "square"})])  # fmt: skip
def test_predicted_border_seam_matches_the_tiles(scheme, tset, kw, small_exemplar):
    ts = tilesynth.build(
        small_exemplar, scheme=scheme, tileset=tset, tile_size=20, seed=9, border_tries=1, **kw
    )
    got = predicted_border_seam(
        small_exemplar, ts.genes, len(ts.definition.horizontal), ts.tile_size, ts.params["sample_size"]
    )
    assert got == pytest.approx(_line_oracle(ts, small_exemplar), rel=1e-9)


def test_border_aware_draws_keep_the_best_of_the_same_draws(small_exemplar):
    """The first candidate is the single draw; the kept one is the argmin of S_pred over the same draws that a
    second generator with the same seed gives; border_tries = 1 keeps the single draw (the literal goldens of
    test_wang_cli check the bytes)."""
    ex, n = small_exemplar, 24
    single = tilesynth.build_wang(ex, tile_size=n, seed=4, border_tries=1)
    best = tilesynth.build_wang(ex, tile_size=n, seed=4, border_tries=8)
    rec = best.params["selection"]
    assert rec["method"] == "random" and rec["border_tries"] == 8 and best.params["border_tries"] == 8
    assert rec["border_seam_first"] == pytest.approx(predicted_border_seam(ex, single.genes, 2, n, n))
    assert rec["border_seam_predicted"] <= rec["border_seam_first"]
    rng = np.random.default_rng(77)
    first = random_genes(ex.shape, 4, n, rng)
    rng_a = np.random.default_rng(5)
    g, r = border_aware_genes(ex, first, 2, n, n, rng_a, 6)
    rng_b = np.random.default_rng(5)
    cands = [first] + [random_genes(ex.shape, 4, n, rng_b) for _ in range(5)]
    scores = [predicted_border_seam(ex, c, 2, n, n) for c in cands]
    np.testing.assert_array_equal(g, cands[int(np.argmin(scores))])
    assert r["border_seam_predicted"] == min(scores) and r["border_seam_first"] == scores[0]
    # given genes and the selection methods do not draw
    given = tilesynth.build_wang(ex, tile_size=n, genes=single.genes)
    np.testing.assert_array_equal(given.genes, single.genes)
    assert "border_tries" not in given.params["selection"]


def test_literal_construction_is_still_available(small_exemplar, tmp_path):
    ts = tilesynth.build_wang(small_exemplar, tile_size=32, seed=5, **LITERAL)
    assert ts.params["corners"] == "free" and ts.params["sample_size"] == 40
    assert ts.params["selection"] == {"method": "random"}
    assert (corner_mismatch(ts.labels) > 0).any()
    # the default is pinned, and records it
    d = tilesynth.build_wang(small_exemplar, tile_size=32, seed=5)
    assert d.params["corners"] == "pinned" and d.params["border_tries"] == DEFAULT_BORDER_TRIES
    assert (d.labels[:, 0] == NORTH).all() and (d.labels[:, -1] == SOUTH).all()
    d.save(tmp_path / "d.tiles")
    back = tilesynth.load(tmp_path / "d.tiles")
    assert back.params["border_tries"] == DEFAULT_BORDER_TRIES and back.content_digest() == d.content_digest()


@pytest.mark.parametrize("bad", [0, -3, 1.5, True, "8", None, 4097, 2**70])
def test_border_tries_errors(bad, small_exemplar):
    with pytest.raises(tilesynth.ParameterError, match="border_tries"):
        check_border_tries(bad)
    for build in (tilesynth.build_wang, tilesynth.build_swang):
        with pytest.raises(tilesynth.ParameterError, match="border_tries"):
            build(small_exemplar, tile_size=24, seed=1, border_tries=bad)


@pytest.fixture(scope="module")
def exemplar_png(tmp_path_factory, small_exemplar):
    p = tmp_path_factory.mktemp("in") / "ex.png"
    tilesynth.save_image(p, small_exemplar)
    return p


def test_cli_border_tries_and_literal(exemplar_png, tmp_path, capsys):
    out = tmp_path / "w.tiles"
    base = [
        "build",
        str(exemplar_png),
        "-o",
        str(out),
        "--scheme",
        "wang",
        "--tile-size",
        "24",
        "--seed",
        "1",
    ]
    assert main([*base, "--corners", "free", "--border-tries", "1", "--quiet"]) == 0
    ts = tilesynth.load(out)
    assert ts.params["corners"] == "free" and ts.params["border_tries"] == 1
    api = tilesynth.build_wang(ts.exemplar, tile_size=24, seed=1, **LITERAL)
    np.testing.assert_array_equal(ts.tiles, api.tiles)
    np.testing.assert_array_equal(ts.genes, api.genes)
    capsys.readouterr()
    bad = tmp_path / "bad.tiles"
    code = main(["build", str(exemplar_png), "-o", str(bad), "--scheme", "swang", "--border-tries", "0"])
    err = capsys.readouterr().err
    assert code == 2 and "--border-tries" in err and not bad.exists()
