"""Periodic exemplars in complete sets (issue 12, tilesynth.builder.periodic): the tile size from the period, the
phase lock, and every other build unchanged."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.builder.periodic import (
    PERIODIC_MIN_CORR,
    periodic_tile_size,
    phase_locked_genes,
    tile_shift_correlation,
)
from tilesynth.errors import ParameterError
from tilesynth.layouts.complete import default_complete_tile_size

COURSE, BRICK = 20, 40  # the wall's lattice: (20, 20) and (0, 40) (row, col); pure periods 40 and 40


def _wall(seed: int = 0, size: int = 200) -> np.ndarray:
    """A staggered brick wall with exact integer periods: courses of 20 px, bricks of 40, half-brick offset."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size]
    row = yy // COURSE
    sx = xx + (BRICK // 2) * (row % 2)
    tone = rng.uniform(0.45, 0.7, size=(row.max() + 1, sx.max() // BRICK + 1, 3))
    img = tone[row, sx // BRICK]
    img[(yy % COURSE < 3) | (sx % BRICK < 3)] = 0.9
    img = img + rng.normal(0, 0.02, img.shape)
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def _in_lattice(d: np.ndarray) -> bool:
    """Whether the shift ``d`` (row, col) is a lattice vector of :func:`_wall`."""
    dy, dx = int(d[0]), int(d[1])
    return dy % COURSE == 0 and (dx - (dy // COURSE) * (BRICK // 2)) % BRICK == 0


def test_tile_size_from_the_period():
    ex = _wall()
    default = default_complete_tile_size(ex.shape)
    assert default == 48  # not a multiple of the wall's period: the rule has something to change
    corr = tile_shift_correlation(ex, [40, 48, 56])
    assert corr[0] > 0.9 and corr[1] < 0.2 and corr[2] < 0.2
    n, c = periodic_tile_size(ex, default)
    assert n == 40 and c == pytest.approx(corr[0])
    # the same size with the rows of the wall shuffled: no period at a tile's shift any more
    shuffled = ex[np.random.default_rng(1).permutation(ex.shape[0])]
    assert periodic_tile_size(shuffled, default) is None
    noise = (np.random.default_rng(3).uniform(size=(200, 200, 3)) * 255).astype(np.uint8)
    assert periodic_tile_size(noise, default) is None


def test_tile_size_rule_on_the_lettuce(lettuce):
    assert periodic_tile_size(lettuce, default_complete_tile_size(lettuce.shape)) is None
    assert np.nanmax(tile_shift_correlation(lettuce, range(8, 129, 8))) < PERIODIC_MIN_CORR / 4


def test_phase_lock_puts_every_patch_at_one_phase():
    ex, n = _wall(), 40
    genes = np.array([[5, 7], [60, 100], [120, 33], [150, 150]])
    assert not all(_in_lattice(g - genes[0]) for g in genes[1:])
    locked = phase_locked_genes(ex, genes, n)
    np.testing.assert_array_equal(locked[0], genes[0])
    for k in range(1, len(genes)):
        assert _in_lattice(locked[k] - locked[0]), (k, locked[k])
        assert np.abs(locked[k] - genes[k]).max() <= n // 2
        for j in range(k):
            assert np.abs(locked[k] - locked[j]).max() > n // 4
    assert (locked >= 0).all() and (locked <= 200 - n).all()
    np.testing.assert_array_equal(phase_locked_genes(ex, genes, n), locked)  # deterministic


def test_build_takes_the_periodic_tile_size():
    ex = _wall()
    auto = ts.build_omega(ex, tileset="c2", seed=3)
    assert auto.tile_size == 40
    rec = auto.params["selection"]["periodic"]
    assert rec["tile_size"] == 40 and rec["mode"] == "auto" and rec["shift_correlation"] > 0.9
    off = ts.build_omega(ex, tileset="c2", seed=3, periodic="off")
    assert off.tile_size == 48 and "periodic" not in off.params["selection"]
    # an explicit tile size, given genes or a selection: the rule stays out
    assert ts.build_omega(ex, tileset="c2", seed=3, tile_size=48).tile_size == 48
    assert "periodic" not in ts.build_omega(ex, tileset="c2", seed=3, select="best-of").params["selection"]
    # the papers' sets never
    assert "periodic" not in ts.build_omega(ex, tileset="16a", seed=3).params["selection"]
    with pytest.raises(ParameterError, match="periodic"):
        ts.build_omega(ex, tileset="c2", seed=3, periodic="yes")


def test_lock_mode_continues_the_period_across_tiles():
    """With ``periodic="lock"`` every output pixel of the vertex content is at one phase of the wall: the
    provenance minus the pixel position is a lattice vector away from one constant, at every vertex."""
    ex = _wall()
    locked = ts.build_omega(ex, tileset="c2", seed=3, periodic="lock")
    auto = ts.build_omega(ex, tileset="c2", seed=3)
    assert locked.params["selection"]["periodic"]["mode"] == "lock"
    g = locked.genes
    assert all(_in_lattice(x - g[0]) for x in g[1:])
    assert not all(_in_lattice(x - auto.genes[0]) for x in auto.genes[1:])  # the draw alone is not locked

    def phase_share(tset):
        img, imap = ts.synthesize(tset, 240, 240, seed=5)
        src = ts.source_map(tset, imap, 240, 240)
        yy, xx = np.mgrid[0:240, 0:240]
        d = src - np.stack([yy, xx], axis=-1)
        ref = d[tset.tile_size // 2, tset.tile_size // 2]
        rel = d - ref
        ok = (rel[..., 0] % COURSE == 0) & (
            (rel[..., 1] - (rel[..., 0] // COURSE) * (BRICK // 2)) % BRICK == 0
        )
        return float(ok.mean())

    assert phase_share(locked) > 0.95
    assert phase_share(auto) < 0.8


def test_other_exemplars_build_byte_for_byte(small_exemplar):
    a = ts.build_omega(small_exemplar, tileset="c2", seed=4)
    b = ts.build_omega(small_exemplar, tileset="c2", seed=4, periodic="off")
    assert "periodic" not in a.params["selection"]
    np.testing.assert_array_equal(a.tiles, b.tiles)
    np.testing.assert_array_equal(a.genes, b.genes)
    np.testing.assert_array_equal(a.source, b.source)


# ---------------------------------------------------------------------------------------------------------
# representative sample patches (omegaborders "stats" criterion, the default of complete sets)


def _two_halves(size: int = 192) -> np.ndarray:
    """A non-stationary exemplar: fine grey noise on the left half, coarse green blobs on the right half."""
    rng = np.random.default_rng(7)
    img = np.empty((size, size, 3))
    img[:, : size // 2] = 0.5 + 0.15 * rng.standard_normal((size, size // 2, 1))
    coarse = rng.standard_normal((size // 8, size // 16))
    blobs = np.kron(coarse, np.ones((8, 8)))[:, :, None] * np.array([0.05, 0.2, 0.05])
    img[:, size // 2 :] = np.array([0.3, 0.5, 0.3]) + blobs
    return (np.clip(img, 0, 1) * 255).astype(np.uint8)


def test_sample_stats_distance_sees_unrepresentative_patches():
    from tilesynth.builder.genes.omega_borders import sample_colour_distance, sample_stats_distance

    ex, n = _two_halves(), 48
    left = np.array([[0, 0], [60, 10], [120, 40], [140, 0]])
    right = left + [0, 96]
    mixed = np.array([[0, 0], [60, 100], [120, 40], [140, 140]])
    d_left, d_right, d_mixed = (sample_stats_distance(ex, g, n) for g in (left, right, mixed))
    assert d_mixed < 0.5 * min(d_left, d_right), (d_left, d_right, d_mixed)
    assert sample_stats_distance(ex, mixed, n) == d_mixed  # deterministic
    # the colour part: grey left, green right; the mixed draw is closer in colour too
    c_left, c_right, c_mixed = (sample_colour_distance(ex, g, n) for g in (left, right, mixed))
    assert c_mixed < 0.5 * min(c_left, c_right), (c_left, c_right, c_mixed)


def test_stats_draws_keep_the_most_representative_admissible_draw(monkeypatch):
    """The draw's choice; the move of salient vertex content that follows it is switched off here (cap 1) and
    tested in tests/test_saliency.py."""
    import tilesynth.builder.genes.omega_borders as ob
    from tilesynth.builder.genes.draws import random_genes
    from tilesynth.builder.genes.omega_borders import (
        STATS_SEAM_CAP,
        border_aware_corner_genes,
        predicted_corner_border_seam,
        sample_colour_distance,
        sample_stats_distance,
    )

    monkeypatch.setattr(ob, "VERTEX_SALIENCY_CAP", 1.0)
    ex, n = _two_halves(), 48
    rng = np.random.default_rng(0)
    first = random_genes(ex.shape, 4, n, rng)
    state = rng.bit_generator.state
    g, rec = border_aware_corner_genes(ex, first, n, rng, 8, "stats")
    rng.bit_generator.state = state
    cands = [first] + [random_genes(ex.shape, 4, n, rng) for _ in range(7)]
    seams = [predicted_corner_border_seam(ex, c, n) for c in cands]
    ok = [i for i, s in enumerate(seams) if s <= STATS_SEAM_CAP]
    assert ok  # the test means something only if some draws are admissible
    dist = {i: sample_stats_distance(ex, cands[i], n) for i in ok}
    colour = {i: sample_colour_distance(ex, cands[i], n) for i in ok}
    best = min(ok, key=lambda i: (dist[i] + colour[i], i))
    np.testing.assert_array_equal(g, cands[best])
    assert rec["border_criterion"] == "stats"
    assert rec["border_seam_predicted"] == pytest.approx(seams[best], rel=1e-6)
    assert rec["sample_stats_predicted"] == pytest.approx(dist[best], rel=1e-9)
    assert rec["sample_colour_predicted"] == pytest.approx(colour[best], rel=1e-6)
    assert len(set(dist.values())) > 1  # the criterion has a choice to make


@pytest.mark.filterwarnings("ignore::tilesynth.InputWarning")  # the halves match nothing across: cut outliers
def test_complete_sets_draw_representative_patches():
    """The default of complete sets: the sample patches of the kept draw are closer to the exemplar in texture
    statistics than those of the "cap" draw (two-halves exemplar, seeds 1-3). Whether the synthesis follows is a
    measurement, in ``benches/repetition-results.md`` (9 textures): on this synthetic exemplar it did for all
    three seeds with the reward's q = 3, and for 2 of 3 (mean 0.0613 vs 0.0606) after q = 8 gave the matching
    patches more of each tile, so it is not asserted here."""
    from tilesynth.builder.genes.omega_borders import sample_colour_distance, sample_stats_distance

    ex = _two_halves()
    out = []
    for seed in (1, 2, 3):
        d = ts.build_omega(ex, tileset="c2", seed=seed)
        c = ts.build_omega(ex, tileset="c2", seed=seed, border_criterion="cap")
        assert d.params["selection"]["border_criterion"] == "stats"
        assert c.params["selection"]["border_criterion"] == "cap"
        n = d.tile_size
        both = [
            sample_stats_distance(ex, t.genes, n) + sample_colour_distance(ex, t.genes, n) for t in (d, c)
        ]
        assert both[0] <= both[1]
        out.append(both[0] < both[1])
    assert any(out)  # the criterion changed the draw at least once (else the test shows nothing)
    # the papers' sets keep "cap"
    p = ts.build_omega(ex, tileset="16a", seed=1, select="random")
    assert p.params["selection"]["border_criterion"] == "cap"


def test_records_survive_the_file(tmp_path):
    t = ts.build_omega(_wall(), tileset="c2", seed=3)
    t.save(tmp_path / "w.tiles")
    sel = ts.TileSet.load(tmp_path / "w.tiles").params["selection"]
    assert sel["border_criterion"] == "stats" and sel["sample_stats_predicted"] > 0
    assert sel["sample_colour_predicted"] >= 0
    assert sel["periodic"] == {
        "tile_size": 40,
        "shift_correlation": sel["periodic"]["shift_correlation"],
        "mode": "auto",
    }
