"""The .tiles file format: bit-exact round trip, determinism of the bytes, clear errors."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest

import tilesynth
from tilesynth.tilefile import FORMAT_VERSION, TileSet

ARRAYS = ["tiles", "source", "cut_masks", "genes", "tile_patches", "match_offsets", "D", "cut_costs", "exemplar"]


@pytest.fixture(scope="module")
def built(small_exemplar):
    return tilesynth.build_omega(small_exemplar, tileset="32", tile_size=20, seed=4)


def test_round_trip_is_bit_exact(built, tmp_path):
    p1, p2 = tmp_path / "a.tiles", tmp_path / "b.tiles"
    built.save(p1)
    loaded = tilesynth.load(p1)
    for name in ARRAYS:
        a, b = getattr(built, name), getattr(loaded, name)
        assert a.dtype == b.dtype and a.shape == b.shape
        assert a.tobytes() == b.tobytes(), name
    assert loaded.E == built.E and loaded.params == built.params and loaded.layout == built.layout
    assert loaded.timing == built.timing and loaded.version == built.version
    loaded.save(p2)
    assert p1.read_bytes() == p2.read_bytes()


def test_members_and_manifest(built, tmp_path):
    p = tmp_path / "x.tiles"
    built.save(p)
    with zipfile.ZipFile(p) as zf:
        names = zf.namelist()
        manifest = json.loads(zf.read("manifest.json"))
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in zf.infolist())
    # timing.json last: two builds of the same set are byte-identical up to it (see tilefile "Determinism")
    assert names[0] == "manifest.json" and names[-1] == "timing.json"
    assert set(names) == {"manifest.json", "timing.json", *(f"{a}.npy" for a in ARRAYS)}
    assert manifest["format"] == "tilesynth-tileset" and manifest["format_version"] == FORMAT_VERSION
    assert manifest["scheme"] == "omega" and len(manifest["per_tile"]) == 32
    assert manifest["arrays"]["tiles"] == {"dtype": "float32", "shape": [32, 20, 20, 3]}
    row = manifest["per_tile"][0]
    assert set(row) == {"index", "corners", "variant", "patches", "match_offset", "D", "cut_cost"}


def test_identical_builds_give_identical_bytes_except_timing(small_exemplar, tmp_path):
    a = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=20, seed=4, threads=1)
    b = tilesynth.build_omega(small_exemplar, tileset="8", tile_size=20, seed=4, threads=2)
    b.timing = dict(a.timing)
    a.save(tmp_path / "a.tiles")
    b.save(tmp_path / "b.tiles")
    assert (tmp_path / "a.tiles").read_bytes() == (tmp_path / "b.tiles").read_bytes()


def test_load_errors(tmp_path, built):
    with pytest.raises(tilesynth.TileSetFormatError, match="no such file"):
        tilesynth.load(tmp_path / "missing.tiles")
    junk = tmp_path / "junk.tiles"
    junk.write_bytes(b"not a zip at all")
    with pytest.raises(tilesynth.TileSetFormatError, match="not a tilesynth tile set"):
        tilesynth.load(junk)
    # a zip without our members
    other = tmp_path / "other.tiles"
    with zipfile.ZipFile(other, "w") as zf:
        zf.writestr("hello.txt", "hi")
    with pytest.raises(tilesynth.TileSetFormatError, match="missing members"):
        tilesynth.load(other)
    # a future format version
    good = tmp_path / "good.tiles"
    built.save(good)
    future = tmp_path / "future.tiles"
    with zipfile.ZipFile(good) as zin, zipfile.ZipFile(future, "w") as zout:
        for item in zin.infolist():
            data = zin.read(item)
            if item.filename == "manifest.json":
                m = json.loads(data)
                m["format_version"] = FORMAT_VERSION + 1
                data = json.dumps(m).encode()
            zout.writestr(item, data)
    with pytest.raises(tilesynth.TileSetFormatError, match="format version"):
        tilesynth.load(future)


def test_inconsistent_arrays_are_rejected(built, tmp_path):
    broken = TileSet(**{**built.__dict__, "D": built.D[:-1].copy()})
    with pytest.raises(tilesynth.TileSetFormatError, match="D"):
        broken.save(tmp_path / "b.tiles")
    assert not (tmp_path / "b.tiles").exists()
