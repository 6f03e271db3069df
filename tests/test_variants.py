"""Several ω-tiles per intermediate tile for every set (002 §4.1-4.2): the ``<set>xK`` names."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.layouts.omega_sets import choices_summary, dead_ends, get_tileset, with_variants


@pytest.mark.parametrize("name", ["4x2", "8x2", "16bx2", "Bx3", "n1x2", "n2x2"])
def test_variant_sets_are_complete_with_k_choices_everywhere(name):
    k = int(name[-1])
    ts = get_tileset(name)
    base = get_tileset(name[:-2])
    assert len(ts) == k * len(base) and ts.tiles == base.tiles * k
    assert sorted(set(ts.variants)) == list(range(k))
    assert dead_ends(ts) == []
    assert all(lo >= k for lo, _ in choices_summary(ts).values())


def test_16ax2_is_the_32_set():
    assert get_tileset("16ax2").tiles == get_tileset("32").tiles
    assert get_tileset("16ax2").variants == get_tileset("32").variants
    with pytest.raises(ValueError, match="variants"):
        with_variants(get_tileset("32"), 2)
    with pytest.raises(ValueError, match="unknown tile set"):
        get_tileset("32x2")


def test_build_and_tile_with_variants(small_exemplar):
    ts = tilesynth.build_omega(small_exemplar, tileset="16bx2", tile_size=24, seed=3)
    assert ts.n_tiles == 32
    for j in range(16):
        assert np.abs(ts.match_offsets[j] - ts.match_offsets[j + 16]).max() > 24 // 4
        assert not np.array_equal(ts.tiles[j], ts.tiles[j + 16])
    img, imap = tilesynth.synthesize(ts, 24 * 12, 24 * 10, seed=1)
    tilesynth.validate_index_map(ts.definition, imap)
    assert (imap >= 16).any() and (imap < 16).any()
