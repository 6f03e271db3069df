"""Issue 12: the memory savings of the build and of saving keep every byte (chunked cut stage, intermediate tiles
assembled on demand, chunked seam measure, streamed members, one matching search for the diverse default)."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest

import tilesynth
from tilesynth.base import kernels
from tilesynth.builder import compose
from tilesynth.builder.matching import levers
from tilesynth.layouts.corners import CornerPlan, IntermediateTiles, intermediate_tiles
from tilesynth.layouts.omega_sets import get_tileset
from tilesynth.measure.metrics import _squared_steps
from tilesynth.tileset import tilefile


def _arrays(ts):
    return [ts.tiles, ts.source, ts.cut_masks, ts.cut_costs, ts.D, ts.match_offsets]


@pytest.mark.parametrize(
    ("name", "kw"),
    [("c2", {}), ("c2x2", {}), ("16a", {"select": "random"}), ("c2", {"cut_region": "circle"})],
)
def test_chunked_cut_stage_is_the_whole_array_one(name, kw, small_exemplar, monkeypatch):
    """Four tiles per chunk against one chunk for the whole set: the same tiles, provenance, masks and costs."""
    monkeypatch.setattr(compose, "CHUNK_BYTES", 1 << 40)
    whole = tilesynth.build_omega(small_exemplar, tileset=name, tile_size=24, seed=5, threads=1, **kw)
    monkeypatch.setattr(compose, "CHUNK_BYTES", 1)
    chunked = tilesynth.build_omega(small_exemplar, tileset=name, tile_size=24, seed=5, threads=1, **kw)
    for a, b in zip(_arrays(whole), _arrays(chunked), strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert whole.content_digest() == chunked.content_digest()


def test_intermediate_tiles_on_demand(small_exemplar):
    plan = CornerPlan.of(get_tileset("c3"))
    ex = small_exemplar.astype(np.float32) / np.float32(255)
    genes = np.array([[0, 0], [40, 8], [10, 60]])
    tiles, src = intermediate_tiles(ex, genes, plan.unique, 16)
    lazy = IntermediateTiles(ex, genes, plan.unique, 16)
    assert lazy.shape == tiles.shape
    ii = np.array([5, 0, 80, 5])
    t2, s2 = lazy.take(ii)
    assert np.array_equal(t2, tiles[ii]) and np.array_equal(s2, src[ii])
    assert t2.dtype == tiles.dtype and s2.dtype == src.dtype


@pytest.mark.parametrize("ax", [1, 2])
def test_squared_steps_chunked(ax, rng, monkeypatch):
    x = rng.random((37, 9, 9, 3), dtype=np.float32)
    want = (np.diff(x.astype(np.float64), axis=ax) ** 2).sum(axis=-1)
    assert np.array_equal(_squared_steps(x, ax), want)


def test_streamed_member_is_writestr_bytes(rng):
    """``_write_array`` writes the bytes ``writestr`` of the whole ``.npy`` wrote, for any array size (a member
    bigger than numpy's 16 MiB write buffer included)."""
    arrays = [
        rng.random((3, 5, 5, 3), dtype=np.float32),
        np.zeros((0, 2), np.int64),
        rng.integers(0, 255, (4200, 1100), dtype=np.int32),  # 18.5 MB: several write_array pieces
        np.asfortranarray(rng.random((7, 11))),
    ]
    for a in arrays:
        old, new = io.BytesIO(), io.BytesIO()
        with zipfile.ZipFile(old, "w") as zf:
            tilefile._write_member(zf, "a.npy", tilefile._npy_bytes(a))
        with zipfile.ZipFile(new, "w") as zf:
            tilefile._write_array(zf, "a.npy", a)
        assert old.getvalue() == new.getvalue()


def test_diverse_default_best_is_the_plain_best(small_exemplar):
    """The diverse matching's first candidate is the exact best translation's SSD (what the second search of
    ``best_matches(k=1)`` returned, and what E is computed from)."""
    ex = small_exemplar.astype(np.float32) / np.float32(255)
    plan = CornerPlan.of(get_tileset("c3"))
    inter, _ = intermediate_tiles(ex, np.array([[0, 0], [40, 8], [10, 60]]), plan.unique, 24)
    cands = levers.diverse_candidates(ex, inter, 1)
    best = kernels.best_matches(ex, inter, k=1)[1][:, 0]
    assert np.array_equal(cands[1][:, 0], best)
