"""The .tiles file format: bit-exact round trip, determinism of the bytes, clear errors."""

from __future__ import annotations

import dataclasses
import json
import zipfile

import numpy as np
import pytest

import tilesynth
from tilesynth.tileset.tilefile import FORMAT_VERSION

ARRAYS = [
    "tiles",
    "source",
    "cut_masks",
    "genes",
    "tile_patches",
    "match_offsets",
    "D",
    "cut_costs",
    "exemplar",
]


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
    # a pure-copy set is stored as its provenance (format version 2, tilesynth.tileset.provenance)
    v2 = [
        "prov_labels",
        "prov_table",
        "cut_masks_packed",
        *(a for a in ARRAYS if a not in ("tiles", "source", "cut_masks")),
    ]
    assert set(names) == {"manifest.json", "timing.json", *(f"{a}.npy" for a in v2)}
    assert manifest["format"] == "tilesynth-tileset" and manifest["format_version"] == FORMAT_VERSION == 2
    assert manifest["scheme"] == "omega" and len(manifest["per_tile"]) == 32
    assert manifest["arrays"]["prov_labels"] == {"dtype": "uint8", "shape": [32, 20, 20]}
    assert manifest["storage"] == {"kind": "provenance", "exemplar_dtype": "uint8"}
    # and as its pixels on request (format version 1)
    built.save(p, format_version=1)
    with zipfile.ZipFile(p) as zf:
        names = zf.namelist()
        manifest = json.loads(zf.read("manifest.json"))
    assert set(names) == {"manifest.json", "timing.json", *(f"{a}.npy" for a in ARRAYS)}
    assert manifest["format_version"] == 1 and "storage" not in manifest
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
    broken = dataclasses.replace(built, D=built.D[:-1].copy())
    with pytest.raises(tilesynth.TileSetFormatError, match="D"):
        broken.save(tmp_path / "b.tiles")
    assert not (tmp_path / "b.tiles").exists()


# ------------------------------------------------------------------------------ hard inputs (issue 7)
def rewrite(src, dst, change) -> None:
    """Copy the zip ``src`` to ``dst`` with ``change(name, bytes) -> bytes | None`` applied (None drops)."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for item in zin.infolist():
            data = change(item.filename, zin.read(item))
            if data is not None:
                zout.writestr(item, data)


@pytest.fixture
def good(built, tmp_path):
    """A version-1 file (pixels): the hard inputs below tamper with its tiles and provenance members (version 2's
    own members: tests/test_provenance.py)."""
    p = tmp_path / "good.tiles"
    built.save(p, format_version=1)
    return p


def manifest_change(**fields):
    def change(name, data):
        if name != "manifest.json":
            return data
        m = json.loads(data)
        for k, v in fields.items():
            if v is KeyError:
                m.pop(k)
            else:
                m[k] = v
        return json.dumps(m).encode()

    return change


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (manifest_change(format="zipped-pictures"), "not a tilesynth tile set .format 'zipped-pictures'"),
        (manifest_change(format=KeyError), "not a tilesynth tile set .format None"),
        (manifest_change(format_version=0), "format version 0, this tilesynth reads versions 1 and 2"),
        (manifest_change(format_version="1"), "format version '1'"),
        (lambda n, d: b"[1, 2, 3]" if n == "manifest.json" else d, "manifest.json is a list, not an object"),
        (lambda n, d: b"{not json" if n == "manifest.json" else d, "JSONDecodeError"),
        (lambda n, d: b"\xff\xfe" if n == "manifest.json" else d, "not a tilesynth tile set"),
        (manifest_change(layout="16a"), "field 'layout' = '16a': wrong type"),
        (manifest_change(E="small"), "field 'E' = 'small': wrong type"),
        (manifest_change(E=float("nan")), "field 'E' = nan: must be finite"),
        (manifest_change(params=KeyError), "manifest.json lacks 'params'"),
        (
            manifest_change(layout={"name": "x", "colours": ["R"], "tiles": [5] * 32}),
            "layout is not a tile-set",
        ),
        (
            manifest_change(layout={"kind": "wang", "tiles": [["R"] * 4] * 32}),
            "layout is not a tile-set definition",
        ),
        (manifest_change(layout={"tiles": [["R"] * 4] * 32}), "lacks name, colours"),
        (
            lambda n, d: b'{"total_s": "slow"}' if n == "timing.json" else d,
            "timing.json must map stage names",
        ),
        (lambda n, d: None if n == "D.npy" else d, r"missing members \['D.npy'\]"),
        (lambda n, d: d[: len(d) // 2] if n == "tiles.npy" else d, "not a tilesynth tile set"),
    ],
)
def test_tampered_files_are_refused(good, tmp_path, change, words):
    bad = tmp_path / "bad.tiles"
    rewrite(good, bad, change)
    with pytest.raises(tilesynth.TileSetFormatError, match=rf"tileset = '{bad}': .*{words}"):
        tilesynth.load(bad)


@pytest.mark.parametrize(
    ("array", "edit", "words"),
    [
        (
            "tiles",
            lambda a: np.where(a > 0.5, np.nan, a).astype(a.dtype),
            r"tiles has values outside \[0, 1\]",
        ),
        ("tiles", lambda a: a * 3, r"tiles has values outside \[0, 1\]"),
        ("source", lambda a: a + 10_000, "source points outside the"),
        ("tile_patches", lambda a: a + 100, r"tile_patches has indices outside \[0, 4\)"),
        ("genes", lambda a: a - 1000, "genes has patch positions outside"),
        ("D", lambda a: a * np.inf, "D has non-finite values"),
        ("tiles", lambda a: a.astype(np.float64), "array tiles must be float32, got float64"),
        ("cut_masks", lambda a: a[:, :-1], r"cut_masks has shape \(32, 19, 20\), expected \(32, 20, 20\)"),
    ],
)
def test_tampered_arrays_are_refused(good, tmp_path, array, edit, words):
    import io as _io

    def change(name, data):
        if name != f"{array}.npy":
            return data
        buf = _io.BytesIO()
        np.save(buf, edit(np.load(_io.BytesIO(data))))
        return buf.getvalue()

    bad = tmp_path / "bad.tiles"
    with np.errstate(invalid="ignore"):
        rewrite(good, bad, change)
    with pytest.raises(tilesynth.TileSetFormatError, match=words):
        tilesynth.load(bad)


def test_truncated_files_are_refused(good, tmp_path):
    data = good.read_bytes()
    for cut in (0, 4, 100, len(data) // 3, len(data) // 2, len(data) - 30, len(data) - 1):
        p = tmp_path / f"cut{cut}.tiles"
        p.write_bytes(data[:cut])
        with pytest.raises(tilesynth.TileSetFormatError, match="not a tilesynth tile set"):
            tilesynth.load(p)


def test_corrupt_member_data_is_refused(good, tmp_path):
    data = bytearray(good.read_bytes())
    with zipfile.ZipFile(good) as zf:
        info = zf.getinfo("tiles.npy")
    start = info.header_offset + 30 + len(info.filename)
    data[start + 100 : start + 110] = b"\x00" * 10  # inside the deflate stream: CRC or zlib error
    p = tmp_path / "corrupt.tiles"
    p.write_bytes(bytes(data))
    with pytest.raises(tilesynth.TileSetFormatError, match="not a tilesynth tile set"):
        tilesynth.load(p)


def test_loading_never_executes_code(good, tmp_path):
    """An object array whose unpickling would run code (write a marker file) is refused, and the code does
    not run: arrays are read with allow_pickle=False."""
    import io as _io

    marker = tmp_path / "pwned"

    class Evil:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    def change(name, data):
        if name != "genes.npy":
            return data
        buf = _io.BytesIO()
        np.save(buf, np.array([Evil()], dtype=object), allow_pickle=True)
        return buf.getvalue()

    bad = tmp_path / "evil.tiles"
    rewrite(good, bad, change)
    with pytest.raises(tilesynth.TileSetFormatError, match="not a tilesynth tile set .*pickle"):
        tilesynth.load(bad)
    assert not marker.exists()


def test_zip_bomb_is_refused_by_declared_size(good, monkeypatch):
    from tilesynth.tileset import reader, tilefile

    assert tilefile.MAX_UNPACKED_BYTES == reader.MAX_UNPACKED_BYTES == 8 << 30
    monkeypatch.setattr(reader, "MAX_UNPACKED_BYTES", 1000)  # read where the file is read
    with pytest.raises(
        tilesynth.TileSetFormatError, match="members unpack to .* bytes, more than the limit of 1000"
    ):
        tilesynth.load(good)


def test_directory_is_refused(tmp_path):
    with pytest.raises(tilesynth.TileSetFormatError, match="is a directory"):
        tilesynth.load(tmp_path)


def test_saved_file_without_timing_is_byte_identical(small_exemplar, tmp_path):
    """ "Byte-identical tile set": two builds (1 and 2 threads) saved with include_timing=False are the same
    file; with timing they differ only in timing.json, the last member."""
    a = tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=20, seed=8, threads=1)
    b = tilesynth.build_omega(small_exemplar, tileset="16a", tile_size=20, seed=8, threads=2)
    a.save(tmp_path / "a.tiles", include_timing=False)
    b.save(tmp_path / "b.tiles", include_timing=False)
    assert (tmp_path / "a.tiles").read_bytes() == (tmp_path / "b.tiles").read_bytes()
    assert "timing.json" not in zipfile.ZipFile(tmp_path / "a.tiles").namelist()
    assert tilesynth.load(tmp_path / "a.tiles").timing == {}
    a.save(tmp_path / "at.tiles")
    b.save(tmp_path / "bt.tiles")
    ra, rb = (tmp_path / "at.tiles").read_bytes(), (tmp_path / "bt.tiles").read_bytes()
    assert ra != rb  # the wall-clock times differ
    off = zipfile.ZipFile(tmp_path / "at.tiles").getinfo("timing.json").header_offset
    assert ra[:off] == rb[:off] == (tmp_path / "a.tiles").read_bytes()[:off]
    assert a.content_digest() == b.content_digest()
