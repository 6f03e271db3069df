"""The seam blend of smooth material maps (:mod:`tilesynth.synth.seams`): the formula against a pixel-by-pixel
oracle, relief kept and cliffs removed on a small material, copies away from the seams, unit normals,
determinism, and the fusion still selectable."""

from __future__ import annotations

import math

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.builder import materials
from tilesynth.builder.matching.augment import transform_vectors
from tilesynth.errors import ParameterError
from tilesynth.io.normal_codes import decode
from tilesynth.synth import seams
from tilesynth.tileset.provenance import Provenance, dihedral_grid


def _oracle_weight(lab: np.ndarray, e: int, level: float, y: int, x: int) -> float:
    """Steps 1-3 of the module docstring, one pixel at a time, in plain Python."""
    n = lab.shape[0]
    d = min(y, x, n - 1 - y, n - 1 - x)
    lod = min(level, math.log2(1 + d))
    l0 = math.floor(lod)
    f = lod - l0

    def texel(lv: int, i: int, j: int) -> float:
        s = 2**lv
        rows = range(i * s, min((i + 1) * s, n))
        cols = range(j * s, min((j + 1) * s, n))
        return sum(lab[r, c] == e for r in rows for c in cols) / (len(rows) * len(cols))

    def sample(lv: int) -> float:
        nl = -(-n // 2**lv)
        u, v = (x + 0.5) / 2**lv - 0.5, (y + 0.5) / 2**lv - 0.5
        j0, i0 = math.floor(u), math.floor(v)
        fx, fy = u - j0, v - i0

        def cl(k: int) -> int:
            return min(max(k, 0), nl - 1)

        return (1 - fy) * ((1 - fx) * texel(lv, cl(i0), cl(j0)) + fx * texel(lv, cl(i0), cl(j0 + 1))) + fy * (
            (1 - fx) * texel(lv, cl(i0 + 1), cl(j0)) + fx * texel(lv, cl(i0 + 1), cl(j0 + 1))
        )

    return (1 - f) * sample(l0) + (f * sample(l0 + 1) if f > 0 else 0.0)


def _mirror(i: int, size: int) -> int:
    m = i % (2 * size)
    return 2 * size - 1 - m if m >= size else m


def _random_prov(k: int, n: int, e: int, seed: int, ex: int, turns: bool = True) -> Provenance:
    """Tiles of ``e`` pieces: a few random discs and half-planes of labels, entries at random offsets (some
    reading past the exemplar's edge), random symmetries."""
    r = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:n, 0:n]
    labels = np.zeros((k, n, n), np.uint8)
    for t in range(k):
        labels[t][xx > r.integers(n // 3, n)] = 1
        for lab in range(2, e):
            cy, cx, rad = r.integers(0, n), r.integers(0, n), r.integers(2, n // 2)
            labels[t][(yy - cy) ** 2 + (xx - cx) ** 2 < rad * rad] = lab
        labels[t, 0, 0] = e - 1  # every entry used somewhere (the table's rule)
        labels[t, 0, 1:e] = np.arange(e - 1)[: e - 1]
    table = np.zeros((k, e, 3), np.int32)
    table[..., 0] = r.integers(0, 8 if turns else 1, (k, e))
    table[..., 1:] = r.integers(-n // 2, ex - n // 2, (k, e, 2))
    return Provenance(labels=labels, table=table)


@pytest.mark.parametrize("n,level", [(12, 3.0), (16, 2.0), (10, 2.5)])
def test_weights_match_the_pixel_by_pixel_oracle(n, level):
    prov = _random_prov(2, n, 4, seed=n, ex=20)
    w = seams.blend_weights(prov.labels, 4, level)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)
    for t in range(2):
        for e in range(4):
            ref = [[_oracle_weight(prov.labels[t], e, level, y, x) for x in range(n)] for y in range(n)]
            np.testing.assert_allclose(w[t, e], ref, atol=1e-12)


def test_border_ring_is_the_plain_label():
    prov = _random_prov(3, 16, 4, seed=2, ex=30)
    w = seams.blend_weights(prov.labels, 4, 3.0)
    onehot = prov.labels[:, None] == np.arange(4)[None, :, None, None]
    ring = np.ones((16, 16), bool)
    ring[1:-1, 1:-1] = False
    assert np.array_equal(w[..., ring], onehot[..., ring].astype(float))


def _oracle_scalar(img: np.ndarray, prov: Provenance, t: int, level: float) -> np.ndarray:
    n = prov.tile_size
    h, w = img.shape[:2]
    lab, tab = prov.labels[t], prov.table[t]
    grids = [dihedral_grid(s, n) for s in range(8)]
    out = np.zeros((n, n, img.shape[2]))
    for y in range(n):
        for x in range(n):
            acc = np.zeros(img.shape[2])
            for e in range(tab.shape[0]):
                wt = _oracle_weight(lab, e, level, y, x)
                if wt > 0:
                    r, c = grids[tab[e, 0]][y, x] + tab[e, 1:]
                    acc += wt * img[_mirror(int(r), h), _mirror(int(c), w)].astype(np.float64) / 65535.0
            out[y, x] = acc
    return out


def test_scalar_blend_matches_the_oracle_with_mirrored_reads():
    r = np.random.default_rng(4)
    img = r.integers(0, 65536, (20, 18, 1), dtype=np.uint16)
    prov = _random_prov(2, 12, 3, seed=7, ex=18)
    got = seams.blend_tiles(img, prov, np.arange(2), "scalar", level=2.0)
    for t in range(2):
        ref = _oracle_scalar(img, prov, t, 2.0)
        want = np.rint(np.clip(ref, 0, 1) * 65535)
        diff = np.abs(got[t].astype(np.float64) - want)
        assert (
            diff.max() <= 1 and (diff == 0).mean() > 0.95
        )  # sums in another order: a rounding tie may differ


def test_normal_blend_matches_the_oracle_in_slope_space():
    r = np.random.default_rng(5)
    v = r.normal(size=(20, 20, 3)) * [0.4, 0.4, 0.0] + [0, 0, 1]
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    img = materials.renormalise_image(np.rint((v * 0.5 + 0.5) * 255).astype(np.uint8), "unorm")
    prov = _random_prov(2, 12, 3, seed=9, ex=20)
    got = decode(seams.blend_tiles(img, prov, np.arange(2), "normal", level=2.0), "unorm")
    n = prov.tile_size
    grids = [dihedral_grid(s, n) for s in range(8)]
    for t in range(2):
        lab, tab = prov.labels[t], prov.table[t]
        for y in range(n):
            for x in range(n):
                slope = np.zeros(2)
                for e in range(tab.shape[0]):
                    wt = _oracle_weight(lab, e, 2.0, y, x)
                    if wt > 0:
                        rr, cc = grids[tab[e, 0]][y, x] + tab[e, 1:]
                        vec = decode(img[_mirror(int(rr), 20), _mirror(int(cc), 20)], "unorm")
                        vec = transform_vectors(vec, tab[e, 0])  # turned with its pixels, as the copies
                        slope += wt * vec[:2] / max(vec[2], seams.ZMIN)
                ref = np.array([slope[0], slope[1], 1.0])
                ref /= np.linalg.norm(ref)
                assert np.linalg.norm(got[t, y, x] - ref) < 2.0 * math.sqrt(3) / 255 + 1e-9


def test_bad_levels_and_kinds_are_refused():
    prov = _random_prov(1, 8, 2, seed=1, ex=10)
    img = np.zeros((10, 10, 1), np.uint8)
    for bad in (-1, 9, float("nan"), "3", True):
        with pytest.raises(ParameterError, match="level"):
            seams.blend_tiles(img, prov, [0], "scalar", level=bad)
    with pytest.raises(ParameterError, match="kind"):
        seams.blend_tiles(img, prov, [0], "label")


# ------------------------------------------------------------------------------- on a built material set
def _rocks(size: int = 96, seed: int = 3) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """A small material: bumps of random heights (a rock-like height with level offsets between patches),
    its normals, and an albedo following the height loosely."""
    r = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:size, 0:size]
    h = np.zeros((size, size))
    for _ in range(60):
        cy, cx, rad, amp = r.uniform(0, size), r.uniform(0, size), r.uniform(4, 12), r.uniform(0.2, 1.0)
        h = np.maximum(h, amp * np.clip(1 - ((yy - cy) ** 2 + (xx - cx) ** 2) / rad**2, 0, None) ** 0.5)
    h += 0.05 * r.random((size, size))
    h = (h - h.min()) / np.ptp(h)
    gy, gx = np.gradient(h * 8.0)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    albedo = np.clip(np.stack([h, h * 0.8, 0.5 * r.random((size, size))], -1), 0, 1)
    maps = {
        "height": np.rint(h * 65535).astype(np.uint16)[..., None],
        "normal": materials.renormalise_image(np.rint((n * 0.5 + 0.5) * 255).astype(np.uint8), "unorm"),
    }
    return np.rint(albedo * 255).astype(np.uint8), maps


@pytest.fixture(scope="module")
def rock_set():
    albedo, maps = _rocks()
    return ts.build(albedo, maps=maps, tileset="c3", tile_size=24, seed=1)


def _steps(a: np.ndarray) -> np.ndarray:
    return np.concatenate([np.abs(np.diff(a, axis=0)).ravel(), np.abs(np.diff(a, axis=1)).ravel()])


def test_blend_keeps_the_relief_and_removes_the_cliffs(rock_set):
    t = rock_set
    _, imap = ts.synthesize(t, 240, 240, seed=5)
    ex = t.maps["height"][..., 0] / 65535.0
    out = {
        how: materials.synthesize_maps(t, imap, 240, 240, **kw)["height"][..., 0] / 65535.0
        for how, kw in (("copies", {"smooth": False}), ("blend", {}), ("fuse", {"seams": "fuse"}))
    }
    thr = np.quantile(_steps(ex), 0.999)
    cliffs = {k: (_steps(v) > thr).mean() / 0.001 for k, v in out.items()}
    std = {k: v.std() / ex.std() for k, v in out.items()}
    assert cliffs["copies"] > 3.0  # the test can fail: the copies have cliffs
    assert cliffs["blend"] < 0.5 * cliffs["copies"]
    assert 0.9 <= std["blend"] / std["copies"] <= 1.02
    assert std["blend"] > std["fuse"]  # the fusion flattens, the blend does not


def test_blend_is_the_copies_away_from_seams_and_on_the_border_ring(rock_set):
    t = rock_set
    idx = np.arange(t.n_tiles)
    for d in t.map_specs:
        spec = materials.MapSpec.from_dict(d)
        arr = t.maps[spec.name]
        blended = materials.map_atlas(t, spec, arr)
        copies = materials.map_atlas(t, spec, arr, smooth=False)
        assert np.array_equal(blended[:, 0], copies[:, 0]) and np.array_equal(
            blended[:, :, -1], copies[:, :, -1]
        )
        prov = materials.map_provenance(t)
        single = seams.blend_weights(prov.labels[idx], prov.table.shape[1], 3.0).max(axis=1) >= 1.0
        assert np.array_equal(blended[single], copies[single])
        assert not np.array_equal(blended, copies)


def test_blended_normals_are_unit_length_and_follow_the_height(rock_set):
    t = rock_set
    _, imap = ts.synthesize(t, 192, 192, seed=2)
    out = materials.synthesize_maps(t, imap, 192, 192)
    lengths = materials.normal_lengths(out["normal"])
    assert (np.abs(lengths - 1.0) <= 0.005).all()
    nx = decode(out["normal"], "unorm")[..., 0].ravel()
    h = out["height"][..., 0] / 65535.0
    assert np.corrcoef(nx, -np.gradient(h, axis=1).ravel())[0, 1] > 0.8


def test_blend_is_deterministic_and_the_same_per_window_and_per_set(rock_set, tmp_path):
    t = rock_set
    _, imap = ts.synthesize(t, 100, 100, seed=9)
    a = materials.synthesize_maps(t, imap, 100, 100)
    t.save(tmp_path / "r.tiles")
    fresh = ts.load(tmp_path / "r.tiles")
    b = materials.synthesize_maps(fresh, imap, 100, 100, threads=1)
    whole = materials.synthesize_maps(fresh, imap, 100, 100)  # from the cache now
    for k in a:
        assert a[k].tobytes() == b[k].tobytes() == whole[k].tobytes()


def test_fusion_is_still_selectable_and_bad_values_are_refused(rock_set):
    t = rock_set
    _, imap = ts.synthesize(t, 64, 64, seed=1)
    fused = materials.synthesize_maps(t, imap, 64, 64, seams="fuse")
    spec = materials.MapSpec.from_dict(next(d for d in t.map_specs if d["name"] == "height"))
    shown = np.unique(imap)
    ref = materials.fused_tiles(t, spec, t.maps["height"], shown)
    from tilesynth.base import kernels

    img = np.empty((64, 64, 1), np.uint16)
    kernels.tile_copy(ref, np.searchsorted(shown, imap).astype(np.int32), img)
    assert np.array_equal(fused["height"], img)
    for bad in ("poisson", 1, ""):
        with pytest.raises(ParameterError, match="seams"):
            materials.synthesize_maps(t, imap, 64, 64, seams=bad)
