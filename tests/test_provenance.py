"""Tile sets stored as provenance (format version 2): the factorisation, the gather and its numpy oracle, the
file round trip, version-1 files, and map synthesis per window against the whole-set map atlas."""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.builder import materials
from tilesynth.builder.matching.augment import transformed_source
from tilesynth.errors import TileSetFormatError
from tilesynth.tileset import provenance as pv
from tilesynth.tileset.tilefile import TileSet

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="module")
def c2(small_exemplar):
    """A small complete set (hashed lookup) with flipped and rotated matching patches."""
    return ts.build_omega(small_exemplar, tileset="c2", tile_size=16, seed=4, augment="all")


def _digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()[:24]


def test_dihedral_grid_is_augments_numbering():
    offsets = np.array([[3, 5]] * 8)
    for s in range(8):
        want = transformed_source(offsets[s : s + 1], np.array([s]), 7)[0]
        assert np.array_equal(pv.dihedral_grid(s, 7) + (3, 5), want), s


def test_factorise_matches_reference_and_reproduces_source(c2):
    prov = pv.factorise(c2.source)
    ref = pv.factorise_reference(c2.source)
    assert prov is not None and ref is not None
    assert np.array_equal(prov.labels, ref.labels) and np.array_equal(prov.table, ref.table)
    assert np.array_equal(prov.source(), c2.source)
    assert prov.table.shape[1] <= 5  # four quadrants and the matching patch
    assert (prov.table[..., 0] > 0).any()  # some matching patch is transformed


def test_factorise_gives_up_past_255_pieces():
    k, n = 1, 20
    src = np.zeros((k, n, n, 2), np.int32)
    src[..., 0] = np.arange(n * n).reshape(n, n) * 3 % 97  # no two pixels in one piece
    src[..., 1] = np.arange(n * n).reshape(n, n) * 7 % 89
    assert pv.factorise(src) is None and pv.factorise_reference(src) is None


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32, np.int32])
def test_gather_matches_numpy_oracle(c2, dtype):
    prov = pv.factorise(c2.source)
    r = np.random.default_rng(0)
    image = (r.random((*c2.exemplar.shape[:2], 3)) * 1000).astype(dtype)
    imap = r.integers(0, c2.n_tiles, (5, 6)).astype(np.int32)
    for oy, ox, h, w in [(0, 0, 80, 96), (3, 9, 60, 70), (15, 15, 1, 1), (0, 7, 33, 17)]:
        out = np.empty((h, w, 3), dtype)
        pv.gather(image, prov, imap, out, (oy, ox), threads=2)
        assert np.array_equal(out, pv.gather_reference(image, prov, imap, h, w, (oy, ox)))


@pytest.mark.parametrize(
    "dtype, encoding",
    [(np.uint8, "unorm"), (np.uint16, "unorm"), (np.float32, "unorm"), (np.float32, "snorm")],
)
@pytest.mark.parametrize("y_down", [False, True])
def test_gather_turns_normal_vectors_with_their_entries(c2, dtype, encoding, y_down):
    """A normal map's copies through rotated or mirrored entries have their x and y turned with the entry
    (exactly in the sample type): the oracle turns the gathered codes with ``transform_normal_codes``."""
    prov = pv.factorise(c2.source)
    assert (prov.table[..., 0] > 0).any()
    r = np.random.default_rng(1)
    image = r.random((*c2.exemplar.shape[:2], 3))
    if encoding == "snorm":
        image = image * 2 - 1
    elif dtype != np.float32:
        image = image * np.iinfo(dtype).max
    image = image.astype(dtype)
    imap = r.integers(0, c2.n_tiles, (5, 6)).astype(np.int32)
    for oy, ox, h, w in [(0, 0, 80, 96), (3, 9, 60, 70)]:
        out = np.empty((h, w, 3), dtype)
        pv.gather(image, prov, imap, out, (oy, ox), threads=2, normal=(encoding, y_down))
        want = pv.gather_reference(image, prov, imap, h, w, (oy, ox), normal=(encoding, y_down))
        assert np.array_equal(out, want)
        plain = pv.gather_reference(image, prov, imap, h, w, (oy, ox))
        assert (out != plain).any() and np.array_equal(out[..., 2], plain[..., 2])  # x, y turned; z kept
    with pytest.raises(ts.ParameterError, match="turns"):
        pv.gather(
            np.zeros((40, 40, 2), np.int32),
            prov,
            imap,
            np.empty((8, 8, 2), np.int32),
            normal=("unorm", False),
        )


def test_factorise_gives_each_pixel_its_orientation(c2):
    """With ``orient`` (the turn of every pixel of a rotated or mirrored matching patch) an entry's symmetry is
    its pixels' turn, also for pieces of one pixel or one line that a translation fits as well; the Rust
    factorisation is the oracle's."""
    from tilesynth.builder.matching.augment import pixel_transforms

    orient = pixel_transforms(c2)
    assert orient is not None
    prov = pv.factorise(c2.source, orient=orient)
    ref = pv.factorise_reference(c2.source, orient=orient)
    assert np.array_equal(prov.labels, ref.labels) and np.array_equal(prov.table, ref.table)
    assert np.array_equal(prov.source(), c2.source)
    sym = np.take_along_axis(prov.table[..., 0], prov.labels.reshape(c2.n_tiles, -1).astype(np.int64), axis=1)
    assert np.array_equal(sym.reshape(orient.shape), orient)
    # one pixel of a quarter-turned patch: geometry alone calls it a translation (the lowest symmetry)
    one = np.array([[[[5, 7]]]], np.int32)
    assert pv.factorise(one).table[0, 0, 0] == 0
    assert pv.factorise(one, orient=np.array([[[1]]], np.uint8)).table[0, 0].tolist() == [1, 5, 7]
    with pytest.raises(ts.ParameterError, match="orient"):
        pv.factorise(one, orient=np.array([[[9]]], np.uint8))


def test_gather_refuses_a_source_outside(c2):
    prov = pv.factorise(c2.source)
    bad = pv.Provenance(prov.labels, prov.table.copy())
    bad.table[0, 0, 1] = 10_000
    out = np.empty((16, 16, 3), np.float32)
    with pytest.raises(ts.ParameterError, match="table"):
        pv.gather(c2.exemplar, bad, np.zeros((1, 1), np.int32), out)
    assert not pv.check_inside(bad, *c2.exemplar.shape[:2])


def test_v2_round_trip_synthesizes_the_same_bytes(c2, tmp_path):
    p1, p2 = tmp_path / "v1.tiles", tmp_path / "v2.tiles"
    c2.save(p1, include_timing=False, format_version=1)
    c2.save(p2, include_timing=False)
    with zipfile.ZipFile(p2) as zf:
        names = set(zf.namelist())
    assert "tiles.npy" not in names and "source.npy" not in names and "prov_labels.npy" in names
    assert p2.stat().st_size < p1.stat().st_size / 2  # a tiny set: the manifest and the exemplar dominate
    a, b = TileSet.load(p1), TileSet.load(p2)
    assert a.file_version == 1 and b.file_version == 2 and not b.has_pixels()
    assert a.content_digest() == b.content_digest() == c2.content_digest()
    for kw in [
        {"seed": 3},
        {"seed": 3, "dtype": np.uint8, "origin": (-37, 51)},
        {"seed": 9, "dtype": np.uint16, "wrap": True},
    ]:
        wa, ia = ts.synthesize(a, 64, 48, **kw)
        wb, ib = ts.synthesize(b, 64, 48, **kw)
        assert np.array_equal(ia, ib) and np.array_equal(wa, wb), kw
        assert not b.has_pixels()  # synthesis gathered from the exemplar
    imap = ts.synthesize(a, 64, 48, seed=3)[1]
    assert np.array_equal(ts.source_map(a, imap, 64, 48), ts.source_map(b, imap, 64, 48))
    height = np.arange(np.prod(c2.exemplar.shape[:2]), dtype=np.uint16).reshape(c2.exemplar.shape[:2])
    assert np.array_equal(
        ts.synthesize_map(a, height, imap, 64, 48), ts.synthesize_map(b, height, imap, 64, 48)
    )
    # the materialised tiles are the built ones, bit for bit
    assert np.array_equal(b.tiles, c2.tiles) and np.array_equal(b.source, c2.source)
    # and saving a v2 set again gives the same file
    b2 = tmp_path / "again.tiles"
    TileSet.load(p2).save(b2, include_timing=False)
    assert b2.read_bytes() == p2.read_bytes()


def test_smoothed_sets_keep_pixels(small_exemplar, tmp_path):
    t = ts.build_omega(small_exemplar, tileset="c2", tile_size=16, seed=4, smooth=True)
    assert t.storage() == 1
    t.save(tmp_path / "s.tiles")
    with zipfile.ZipFile(tmp_path / "s.tiles") as zf:
        assert "tiles.npy" in zf.namelist()
    with pytest.raises(ts.ParameterError, match="format_version"):
        t.save(tmp_path / "x.tiles", format_version=2)


def test_version1_fixture_still_loads():
    """A version-1 file written before version 2 existed (tests/data/v1-c2.tiles, the c2 set above saved by the
    previous release): it loads, keeps its pixels, and synthesizes the bytes it did then."""
    t = TileSet.load(DATA / "v1-c2.tiles")
    assert t.file_version == 1 and t.has_pixels()
    img, _ = ts.synthesize(t, 64, 48, seed=3, dtype=np.uint8, origin=(5, -3))
    assert _digest(t.tiles) == "526c96463d28f21b195d5939"
    assert _digest(img) == "25efa7f45ab5fd26820edc3f"


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda a: a.__setitem__("prov_labels", a["prov_labels"] + 7), "labels past"),
        (lambda a: a["prov_table"].__setitem__((0, 0, 1), 99999), "outside"),
        (lambda a: a["prov_table"].__setitem__((0, 0, 0), 9), "symmetries"),
    ],
)
def test_tampered_v2_files_are_refused(c2, tmp_path, change, message):
    import io

    p = tmp_path / "v2.tiles"
    c2.save(p, include_timing=False)
    with zipfile.ZipFile(p) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    arrays = {n[:-4]: np.load(io.BytesIO(members[n])) for n in ("prov_labels.npy", "prov_table.npy")}
    change(arrays)
    for name, a in arrays.items():
        buf = io.BytesIO()
        np.save(buf, a)
        members[f"{name}.npy"] = buf.getvalue()
    bad = tmp_path / "bad.tiles"
    with zipfile.ZipFile(bad, "w") as zf:
        for n, data in members.items():
            zf.writestr(n, data)
    with pytest.raises(TileSetFormatError, match=message):
        TileSet.load(bad)


def _material(h: int = 64, w: int = 64, seed: int = 3):
    r = np.random.default_rng(seed)
    albedo = np.kron(r.random((h // 4, w // 4, 3)), np.ones((4, 4, 1)))
    albedo = np.round((albedo + 0.1 * r.random((h, w, 3))) / 1.1 * 255).astype(np.uint8)
    yy, xx = np.mgrid[0:h, 0:w]
    height = 0.5 + 0.25 * np.sin(xx / 5.0) * np.cos(yy / 7.0) + 0.02 * r.random((h, w))
    gy, gx = np.gradient(height * 8.0)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return albedo, {
        "height": np.round(np.clip(height, 0, 1) * 65535).astype(np.uint16),
        "normal": np.round((n * 0.5 + 0.5) * 255).astype(np.uint8),
        "roughness": np.round(r.random((h, w)) * 255).astype(np.uint8),
        "mask": (np.arange(h * w).reshape(h, w) % 5).astype(np.uint8),
    }


def _whole_atlas_maps(t, imap, width, height, offset=(0, 0)):
    """The maps as synthesize_maps laid them before: every map's atlas of the whole set (the fusion of
    fuse_map_atlas, levels solved from scratch), then the tile copy of the window."""
    from tilesynth import _core

    out = {}
    src = t.source
    for d in t.map_specs:
        spec = materials.MapSpec.from_dict(d)
        arr = t.maps[spec.name]
        atlas = np.ascontiguousarray(arr[src[..., 0], src[..., 1]])
        if materials.smooths(t, spec):
            atlas = materials.fuse_map_atlas(t, arr, atlas)
        if spec.kind == "normal":
            atlas = materials.renormalise_image(atlas, spec.encoding or "unorm")
        img = np.empty((height, width, arr.shape[2]), arr.dtype)
        _core.tile_copy_window(
            np.ascontiguousarray(atlas), np.ascontiguousarray(imap, np.int32), offset, img, 1
        )
        out[spec.name] = img
    return out


@pytest.fixture(scope="module")
def material():
    albedo, maps = _material()
    return ts.build(albedo, maps=maps, tileset="c2", tile_size=16, seed=2)


@pytest.fixture
def fused_material():
    """A material set after one ``seams="fuse"`` synthesis: the fusion's levels solved on first use, kept."""
    albedo, maps = _material()
    t = ts.build(albedo, maps=maps, tileset="c2", tile_size=16, seed=2)
    assert t.map_levels is None and "map_levels_s" not in t.timing  # the build no longer solves them
    _, imap = ts.synthesize(t, 16, 16, seed=1)
    materials.synthesize_maps(t, imap, 16, 16, seams="fuse")
    return t


def test_material_levels_are_solved_on_first_fuse_and_saved_with_the_set(fused_material, tmp_path):
    t = fused_material
    assert set(t.map_levels) == {"corners", "height", "normal", "roughness"}
    p = tmp_path / "m.tiles"
    t.save(p, include_timing=False)
    back = TileSet.load(p)
    assert back.file_version == 2 and set(back.map_levels) == set(t.map_levels)
    for name, x in t.map_levels.items():
        assert np.array_equal(back.map_levels[name], x)
    for origin, (w, h) in [((0, 0), (64, 48)), ((-21, 37), (40, 33)), ((5, 3), (1, 1))]:
        img, imap = ts.synthesize(back, w, h, seed=6, origin=origin)
        n = t.tile_size
        offset = (origin[1] % n, origin[0] % n)
        got = materials.synthesize_maps(back, imap, w, h, offset=offset, seams="fuse")  # the fusion's levels
        want = _whole_atlas_maps(t, imap, w, h, offset)
        assert not back.has_pixels()
        for name in want:
            assert got[name].dtype == want[name].dtype and np.array_equal(got[name], want[name]), (
                name,
                origin,
            )
    # the maps as copies (smoothing off) straight from the maps through the provenance
    img, imap = ts.synthesize(back, 64, 48, seed=1)
    flat = materials.synthesize_maps(back, imap, 64, 48, smooth=False)
    src = ts.source_map(t, imap, 64, 48)
    assert np.array_equal(flat["height"], t.maps["height"][src[..., 0], src[..., 1]])
    unit = materials.renormalise_image(t.maps["normal"][src[..., 0], src[..., 1]], "unorm")  # as before
    assert np.array_equal(flat["normal"], unit)
    built = materials.synthesize_maps(t, imap, 64, 48, smooth=False)  # the set in memory, from its pixels
    assert all(np.array_equal(built[k], flat[k]) for k in flat)


def test_material_v1_file_levels_are_solved_once(material, tmp_path):
    p = tmp_path / "m1.tiles"
    material.save(p, include_timing=False, format_version=1)
    back = TileSet.load(p)
    assert back.map_levels is None  # version 1 stores no levels: solved on first use, then kept
    img, imap = ts.synthesize(back, 40, 40, seed=2)
    a = materials.synthesize_maps(back, imap, 40, 40, seams="fuse")
    assert set(back.map_levels) == {"corners", "height", "normal", "roughness"}
    b = materials.synthesize_maps(material, imap, 40, 40, seams="fuse")
    for name in a:
        assert np.array_equal(a[name], b[name])


def test_info_shows_storage(c2, tmp_path, capsys):
    from tilesynth.cli.main import main

    p = tmp_path / "v2.tiles"
    c2.save(p)
    assert main(["info", str(p)]) in (0, None)
    out = capsys.readouterr().out
    assert "storage       format 2 (provenance)" in out and "prov_labels" in out


def test_cli_synth_lays_maps_at_any_origin(material, tmp_path):
    """``synth --origin`` of a material set: every map is the window of the colour's (it was refused before)."""
    from tilesynth.cli.main import main

    p = tmp_path / "m.tiles"
    material.save(p)
    out = tmp_path / "out.png"
    assert (
        main(["synth", str(p), "-o", str(out), "--size", "40x33", "--seed", "6", "--origin=-21,37", "-q"])
        == 0
    )
    back = TileSet.load(p)
    img, imap = ts.synthesize(back, 40, 33, seed=6, origin=(-21, 37))
    n = back.tile_size
    want = materials.synthesize_maps(back, imap, 40, 33, offset=(37 % n, -21 % n))
    got = ts.load_raster(tmp_path / "out-height.png")
    assert np.array_equal(got[..., 0], want["height"][..., 0])
    assert np.array_equal(
        ts.load_raster(out)[..., :3], ts.synthesize(back, 40, 33, seed=6, origin=(-21, 37), dtype=np.uint8)[0]
    )


def test_atlas_export_of_a_v2_material_set_is_the_built_sets(material, tmp_path):
    """The atlas export still works from a version-2 set (it materialises the tiles) and writes the same atlases
    as from the set in memory."""
    from tilesynth.engine import export

    p = tmp_path / "m.tiles"
    material.save(p)
    back = TileSet.load(p)
    export(material, tmp_path / "a", index_size=(4, 4), format="atlas")
    export(back, tmp_path / "b", index_size=(4, 4), format="atlas")
    files = sorted((tmp_path / "a").glob("atlas_*.png"))
    assert len(files) == 20 and sorted(f.name for f in (tmp_path / "b").glob("atlas_*.png")) == [
        f.name for f in files
    ]
    for f in files:
        assert f.read_bytes() == (tmp_path / "b" / f.name).read_bytes(), f.name


@pytest.mark.parametrize(
    "kw",
    [
        {"tileset": "16a", "tile_size": 20},  # a papers' set: the scan-line tiler
        {"scheme": "wang", "tileset": "wang8", "tile_size": 16},
        {"scheme": "swang", "tileset": "wang8", "tile_size": 16},
    ],
)
def test_other_schemes_are_stored_as_provenance_and_synthesize_the_same(small_exemplar, tmp_path, kw):
    t = ts.build(small_exemplar, seed=3, **kw)
    p = tmp_path / "s.tiles"
    t.save(p)
    back = TileSet.load(p)
    assert back.file_version == 2 and not back.has_pixels()
    for dtype in (np.float32, np.uint8):
        a, ia = ts.synthesize(t, 70, 50, seed=5, dtype=dtype)
        b, ib = ts.synthesize(back, 70, 50, seed=5, dtype=dtype)
        assert np.array_equal(ia, ib) and np.array_equal(a, b)
    assert not back.has_pixels() and np.array_equal(back.tiles, t.tiles)
    if t.labels is not None:
        assert np.array_equal(back.labels, t.labels)


def test_tampered_map_levels_are_refused(fused_material, tmp_path):
    import io

    p = tmp_path / "m.tiles"
    fused_material.save(p, include_timing=False)
    with zipfile.ZipFile(p) as zf:
        members = {n: zf.read(n) for n in zf.namelist()}
    x = np.load(io.BytesIO(members["level_height.npy"]))
    buf = io.BytesIO()
    np.save(buf, x[:-1])
    members["level_height.npy"] = buf.getvalue()
    bad = tmp_path / "bad.tiles"
    with zipfile.ZipFile(bad, "w") as zf:
        for n, data in members.items():
            zf.writestr(n, data)
    with pytest.raises(TileSetFormatError, match="level_height"):
        TileSet.load(bad)


def test_stored_level_block_is_the_fusions():
    from tilesynth.builder import fusion
    from tilesynth.tileset import tilefile

    assert tilefile.LEVEL_BLOCK == fusion.LEVEL_BLOCK
