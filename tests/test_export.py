"""Engine export without a browser: files, manifest and schema, atlas, gutters, mips, toroidal index maps."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.base.validate import to_uint
from tilesynth.engine import atlas as xatlas
from tilesynth.engine import export, hash_layout, manifest_schema, validate_manifest
from tilesynth.engine.periodic import toroidal_index_map
from tilesynth.errors import ParameterError
from tilesynth.io.images import load_raster
from tilesynth.layouts.scanline import validate_index_map

jsonschema = pytest.importorskip("jsonschema")


@pytest.fixture(scope="module")
def omega_set(small_exemplar: np.ndarray):
    return ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=1)


@pytest.fixture(scope="module")
def wang_set(small_exemplar: np.ndarray):
    return ts.build(small_exemplar, scheme="wang", tileset="wang8", tile_size=32, seed=1)


def _all_files(d: Path) -> set[str]:
    return {p.relative_to(d).as_posix() for p in d.rglob("*") if p.is_file()}


@pytest.mark.parametrize("which", ["omega", "omega-atlas", "wang"])
def test_manifest_validates_and_references_every_file(tmp_path, which, omega_set, wang_set, small_exemplar):
    tileset = wang_set if which == "wang" else omega_set
    fmt = "atlas" if which == "omega-atlas" else "auto"
    src = tmp_path / "set.tiles"
    tileset.save(src)
    normal = (small_exemplar * 65535).astype(np.uint16)
    height = small_exemplar[..., 0].copy()
    m = export(
        ts.load(src),
        tmp_path / "out",
        maps={"normal": normal, "height": height},
        viewer=True,
        index_size=(6, 4),
        source_path=src,
        format=fmt,
    )
    out = tmp_path / "out"
    # the default is version 2 (provenance) for a pure-copy omega set; Wang tiles do not fit the one-bit labels
    assert m["format_version"] == (2 if which == "omega" else 1)
    on_disk = json.loads((out / "manifest.json").read_text())
    assert on_disk == m
    validate_manifest(on_disk)
    referenced = set(m["files"])
    assert _all_files(out) - {"manifest.json"} == referenced  # every exported file is referenced, and exists
    level_files = {lv["file"] for mp in m["maps"] for lv in mp["levels"]}
    assert level_files <= referenced and set(m["shaders"].values()) <= referenced
    assert m["lookup"]["file"] in referenced
    maps = {mp["name"]: mp for mp in m["maps"]}
    assert maps["albedo"]["colour_space"] == "srgb" and maps["normal"]["colour_space"] == "linear"
    assert maps["normal"]["normal_y"] == "+y" and "normal_y" not in maps["height"]
    assert maps["normal"]["sample_type"] == "uint16" and maps["height"]["levels"][0]["file"].endswith(".exr")
    assert m["source"]["content_digest"] == tileset.content_digest()
    if m["format_version"] == 1:
        assert len(m["atlas"]["cells"]) == tileset.n_tiles == m["tile_count"]
        bad = dict(m, padding=-1)
    else:
        assert m["labels"]["table"]["file"] in referenced and m["labels"]["bits"]["file"] in referenced
        assert len(maps["albedo"]["levels"]) == 7  # 96, 48, ..., 3, 1: a full chain to 1 x 1
        assert m["gpu_bytes"]["ratio_to_maps"] < 2
        bad = dict(m, labels=dict(m["labels"], form="atlas"))
    # a tampered manifest fails
    with pytest.raises(jsonschema.ValidationError):
        validate_manifest(bad)
    bad = dict(m, lookup=dict(m["lookup"], mode="magic"))
    with pytest.raises(jsonschema.ValidationError):
        validate_manifest(bad)


def test_schema_is_a_valid_draft_2020_12_schema():
    jsonschema.Draft202012Validator.check_schema(manifest_schema())


def test_atlas_interiors_are_the_tiles_and_mips_stay_in_their_cells(tmp_path, omega_set):
    m = export(omega_set, tmp_path, format="atlas", index_size=(4, 4))
    n, p, cols = m["tile_size"], m["padding"], m["atlas"]["columns"]
    lv0 = load_raster(tmp_path / "atlas_albedo.png")
    q = to_uint(omega_set.tiles, 8)
    for t, (x, y, w, h) in enumerate(m["atlas"]["cells"]):
        assert np.array_equal(lv0[y : y + h, x : x + w], q[t])
    assert m["atlas"]["max_level"] == 3 and len(m["maps"][0]["levels"]) == 4
    # change one tile: no texel of any other cell changes at any level
    other = omega_set.tiles.copy()
    other[5] = 1.0 - other[5]
    cells_a = xatlas.quantise(
        xatlas.padded_tiles(omega_set.tiles, omega_set.exemplar, omega_set.source, p), 8
    )
    cells_b = cells_a.copy()
    cells_b[5, p : p + n, p : p + n] = to_uint(other[5], 8)
    rows = m["atlas"]["rows"]
    ca = xatlas.mip_chain(xatlas.pack(cells_a, cols, rows), 3, True)
    cb = xatlas.mip_chain(xatlas.pack(cells_b, cols, rows), 3, True)
    s = n + 2 * p
    for lv in range(4):
        f = 2**lv
        diff = np.any(ca[lv] != cb[lv], axis=2)
        ys, xs = np.nonzero(diff)
        assert ys.size > 0
        assert set(zip((ys * f) // s, (xs * f) // s)) == {(5 // cols, 5 % cols)}
        assert np.array_equal(load_raster(tmp_path / m["maps"][0]["levels"][lv]["file"]), ca[lv])


def test_mip_interior_is_the_box_filter_of_the_tile(omega_set):
    cells = xatlas.quantise(xatlas.padded_tiles(omega_set.tiles, omega_set.exemplar, omega_set.source, 8), 8)
    chain = xatlas.mip_chain(cells[3], 3, srgb=False)
    t = cells[3, 8:40, 8:40].astype(np.float64)
    box = t.reshape(4, 8, 4, 8, 3).mean(axis=(1, 3))
    assert np.abs(chain[3][1:5, 1:5].astype(np.float64) - box).max() <= 1.5  # rounded at each level


def test_gutter_from_provenance(omega_set, wang_set):
    """First gutter texel exact for every valid neighbour of an omega set with the kept border ring; the
    deeper ones and the Wang corners are measured, not claimed."""
    for tileset in (omega_set, wang_set):
        cells = xatlas.quantise(xatlas.padded_tiles(tileset.tiles, tileset.exemplar, tileset.source, 8), 8)
        ex = xatlas.gutter_exactness(tileset, cells, 8, to_uint(tileset.tiles, 8))
        assert ex["pairs"] > 0 and len(ex["by_depth"]) == 8
        assert all(0.3 < v <= 1.0 for v in ex["by_depth"])
    cells = xatlas.quantise(xatlas.padded_tiles(omega_set.tiles, omega_set.exemplar, omega_set.source, 8), 8)
    assert xatlas.gutter_exactness(omega_set, cells, 8, to_uint(omega_set.tiles, 8))["by_depth"][0] == 1.0
    # the gutter is the exemplar continued: the corner texel (-1, -1) of each tile is the exemplar pixel
    # diagonally before the provenance of its (0, 0)
    for t in range(omega_set.n_tiles):
        r, c = omega_set.source[t, 0, 0]
        assert np.array_equal(cells[t, 7, 7], to_uint(omega_set.exemplar[r - 1, c - 1], 8))


@pytest.mark.parametrize(
    "name,period,strict",
    [
        ("4", 2, True),
        ("8", 2, True),
        ("16a", 2, False),
        ("16b", 4, True),
        ("32", 2, False),
        ("B", 3, True),
        ("n1", 3, True),
        ("n2", 3, True),
        ("16ax2", 2, False),
        ("n2x2", 3, True),
    ],
)
def test_toroidal_index_maps_of_named_corner_sets(name, period, strict):
    """Measured: the smallest square torus each set tiles; 'strict' sets tile no torus of side period + 1."""
    from tilesynth.engine.periodic import default_index_size, torus_period

    defn = ts.get_tileset(name)
    assert torus_period(defn) == period
    dc, dr = default_index_size(defn)
    assert dc == dr and dc % period == 0 and abs(dc - 32) <= period
    for rows, cols in ((dr, dc), (2 * period, 3 * period)):
        imap = toroidal_index_map(defn, rows, cols, seed=3)
        assert imap.shape == (rows, cols) and imap.dtype == np.int32
        validate_index_map(defn, np.tile(imap, (2, 2)))  # valid across the wrap in both directions
    if strict:
        with pytest.raises(ParameterError, match=f"multiples of {period}"):
            toroidal_index_map(defn, period + 1, period + 1)


@pytest.mark.parametrize("name", ["wang8", "wang18"])
def test_toroidal_index_maps_of_wang_sets(name):
    from tilesynth.layouts.wang_sets import get_wang_tileset

    defn = get_wang_tileset(name)
    imap = toroidal_index_map(defn, 8, 8, seed=1)
    validate_index_map(defn, np.tile(imap, (2, 2)))
    assert len(np.unique(imap)) > 3


def test_toroidal_index_map_is_seeded_and_varied():
    defn = ts.get_tileset("16a")
    a, b = toroidal_index_map(defn, 16, 16, 1), toroidal_index_map(defn, 16, 16, 2)
    assert np.array_equal(a, toroidal_index_map(defn, 16, 16, 1)) and not np.array_equal(a, b)
    assert len(np.unique(a)) == len(defn)


@pytest.mark.parametrize("name", ["n2", "n2x2"])
def test_toroidal_fallback_repeats_a_small_torus_and_recolours(name, monkeypatch):
    from tilesynth.engine import periodic
    from tilesynth.layouts.wang_sets import get_wang_tileset

    defn = get_wang_tileset(name) if name.startswith("wang") else ts.get_tileset(name)
    monkeypatch.setattr(periodic, "MAX_NODES", 40)  # the direct search of 12 x 12 cannot finish: fallback
    imap = toroidal_index_map(defn, 12, 12, seed=5)
    validate_index_map(defn, np.tile(imap, (2, 2)))
    assert len(np.unique(imap)) > len(defn) // 2


def test_hash_layout_detects_complete_sets_in_hash_order():
    from tilesynth.layouts.omega_sets import CornerTileSet
    from tilesynth.layouts.wang_sets import WangTileSet

    cols = ("R", "G")
    tiles, variants = [], []
    for idx in range(2**4 * 3):
        rest, v = divmod(idx, 3)
        rest, br = divmod(rest, 2)
        rest, tr = divmod(rest, 2)
        tl, bl = divmod(rest, 2)
        tiles.append((cols[tl], cols[bl], cols[tr], cols[br]))
        variants.append(v)
    assert hash_layout(CornerTileSet("c2", cols, tiles, variants)) == {"kind": "corner", "K": 2, "V": 3}
    assert hash_layout(CornerTileSet("c2", cols, tiles[::-1], variants[::-1])) is None
    assert hash_layout(ts.get_tileset("16a")) is None
    hz, vt = ("a", "b"), ("x", "y", "z")
    wt = []
    for idx in range(2 * 2 * 3 * 3):
        rest, w = divmod(idx, 3)
        rest, s = divmod(rest, 2)
        n, e = divmod(rest, 3)
        wt.append((hz[n], vt[e], hz[s], vt[w]))
    assert hash_layout(WangTileSet("w", hz, vt, wt)) == {"kind": "edge", "Kh": 2, "Kv": 3, "V": 1}


def test_export_parameter_errors(tmp_path, omega_set):
    for kw, word in (
        ({"padding": -1}, "padding"),
        ({"padding": True}, "padding"),
        ({"bits": 12}, "bits"),
        ({"seed": 2**32}, "seed"),
        ({"seed": -1}, "seed"),
        ({"lookup": "hash"}, "hash"),
        ({"lookup": "nope"}, "lookup"),
        ({"wrap": (4, 4)}, "wrap"),
        ({"normal_y": "sideways"}, "normal_y"),  # "up" is valid since the option rules (issue 16)
        ({"maps": {"albedo": omega_set.exemplar}}, "albedo"),
        ({"maps": {"bad name": omega_set.exemplar}}, "map name"),
    ):
        with pytest.raises(ParameterError, match=word):
            export(omega_set, tmp_path / "e", **kw)
    with pytest.raises(ValueError, match="pixel-aligned"):
        export(omega_set, tmp_path / "e", maps={"h": np.zeros((5, 5), np.float32)})
    with pytest.raises(TypeError, match="TileSet"):
        export("x.tiles", tmp_path / "e")


def test_exr_roundtrip(tmp_path, omega_set):
    from tilesynth.io.images import read_exr

    h = np.ascontiguousarray(omega_set.exemplar[..., 0] * 3.0 - 1.0)  # float data outside [0, 1]
    m = export(omega_set, tmp_path, format="atlas", maps={"h": h}, index_size=(2, 2))
    entry = next(mp for mp in m["maps"] if mp["name"] == "h")
    y = read_exr(tmp_path / entry["levels"][0]["file"])[0][..., 0]
    x, yy, w, hh = m["atlas"]["cells"][2]
    src = omega_set.source[2]
    assert np.array_equal(y[yy : yy + hh, x : x + w], h[src[..., 0], src[..., 1]])


def test_sixteen_bit_atlas(tmp_path, omega_set):
    m = export(omega_set, tmp_path, format="atlas", bits=16, index_size=(2, 2))
    lv0 = load_raster(tmp_path / "atlas_albedo.png")
    assert lv0.dtype == np.uint16
    x, y, w, h = m["atlas"]["cells"][0]
    assert np.array_equal(lv0[y : y + h, x : x + w], to_uint(omega_set.tiles[0], 16))


def test_padding_zero_has_no_mips(tmp_path, omega_set):
    m = export(omega_set, tmp_path, format="atlas", padding=0, index_size=(2, 2))
    assert m["atlas"]["max_level"] == 0 and m["gutter"]["exact_fraction"] is None
    assert m["atlas"]["width"] == m["atlas"]["columns"] * 32


def test_cli_export_and_view(tmp_path, omega_set):
    from tilesynth.cli.main import main

    src = tmp_path / "a.tiles"
    omega_set.save(src)
    assert main(["export", str(src), "-o", str(tmp_path / "out"), "--index-size", "4x4", "--viewer"]) == 0
    assert (tmp_path / "out" / "viewer.html").is_file()
    assert main(["view", str(src), "-o", str(tmp_path / "v.html"), "--index-size", "4x4"]) == 0
    html = (tmp_path / "v.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and "ts_site" in html and "http" not in html.split("<script")[0]
    assert main(["export", str(src), "-o", str(tmp_path / "o2"), "--lookup", "hash"]) == 2


# ------------------------------------------------------------------------ a re-export is committed as a unit
def _snapshot(d: Path) -> dict[str, bytes]:
    return {p.relative_to(d).as_posix(): p.read_bytes() for p in d.rglob("*") if p.is_file()}


@pytest.mark.parametrize("error", [KeyboardInterrupt, "enospc"])
def test_interrupted_re_export_leaves_the_previous_export_whole(tmp_path, omega_set, monkeypatch, error):
    """Ctrl-C or a full disk halfway through a re-export (after some atlas levels were written): the previous
    export is byte for byte as it was, with no temporary file beside it; the CLI says which file and exits 2."""
    import errno

    import tilesynth.engine.atlas_export as engine  # where the atlas export (format='atlas') writes levels

    out = tmp_path / "exp"
    extra = {"h": (np.arange(96 * 96, dtype=np.uint32).reshape(96, 96) % 251).astype(np.uint8)}
    export(omega_set, out, format="atlas", maps=extra, seed=0, padding=8)
    before = _snapshot(out)
    real = engine._write_level
    calls = []

    def failing(path, arr):
        calls.append(path)
        if len(calls) == 3:
            if error == "enospc":
                # as a real full disk: the write fails with no file name, atomic_path names the output
                from tilesynth.io.images import atomic_open

                with atomic_open(path) as fh:
                    fh.write(b"partial")
                    raise OSError(errno.ENOSPC, "No space left on device")
            raise KeyboardInterrupt
        real(path, arr)

    monkeypatch.setattr(engine, "_write_level", failing)
    with pytest.raises(KeyboardInterrupt if error is KeyboardInterrupt else OSError) as exc:
        export(omega_set, out, format="atlas", maps=extra, padding=4, index_seed=5)
    if error == "enospc":
        assert exc.value.filename == str(calls[-1])  # the file is named
    assert _snapshot(out) == before
    assert not [p for p in out.rglob("*") if p.name.endswith(".part")]


def test_cli_full_disk_during_export_names_the_file(tmp_path, omega_set, monkeypatch, capsys):
    import errno

    import tilesynth.engine as engine
    from tilesynth.cli.main import main

    src = tmp_path / "s.tiles"
    omega_set.save(src)

    def full(path, arr):
        from tilesynth.io.images import atomic_open

        with atomic_open(path):
            raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(engine, "_write_level", full)
    assert main(["export", str(src), "-o", str(tmp_path / "exp")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device" in err and "_albedo.png" in err, err
    assert not [p for p in (tmp_path / "exp").rglob("*") if p.is_file()]


def test_re_export_removes_the_files_the_new_manifest_does_not_list(tmp_path, omega_set):
    out = tmp_path / "exp"
    out.mkdir()
    (out / "notes.txt").write_text("mine")  # not the export's: kept
    extra = {"h": np.zeros((96, 96), np.uint8)}
    m1 = export(omega_set, out, format="atlas", maps=extra, viewer=True, padding=8)
    assert "viewer.html" in m1["files"] and "atlas_h_mip3.png" in m1["files"]
    m2 = export(omega_set, out, format="atlas", padding=4)
    assert _all_files(out) == {*m2["files"], "manifest.json", "notes.txt"}
    assert not (out / "viewer.html").exists() and not (out / "atlas_h.png").exists()
    # a tampered manifest cannot make a re-export delete anything but export files
    man = json.loads((out / "manifest.json").read_text())
    man["files"] += ["notes.txt", "../outside.txt", "shaders/../../x"]
    (out / "manifest.json").write_text(json.dumps(man))
    (tmp_path / "outside.txt").write_text("keep")
    export(omega_set, out, format="atlas", padding=4)
    assert (out / "notes.txt").read_text() == "mine" and (tmp_path / "outside.txt").read_text() == "keep"
    # an input now stored under a name the previous export listed is never removed
    export(omega_set, out, format="atlas", padding=8)  # lists atlas_albedo_mip3.png
    src = out / "atlas_albedo_mip3.png"
    omega_set.save(src)  # the user's tile set under that name; a padding-4 export does not write it
    export(ts.load(src), out, format="atlas", padding=4, source_path=src)
    assert src.is_file() and ts.load(src).n_tiles == omega_set.n_tiles


def test_index_map_search_reports_progress(tmp_path, omega_set):
    """`export --index-size 2048x2048` ran for minutes without a word: the toroidal search and the recolouring
    sweeps report to the progress (here a recorder; the CLI passes its Progress line)."""
    calls = []
    export(omega_set, tmp_path / "e", index_size=(96, 80), progress=lambda *a: calls.append(a))
    stages = {c[0] for c in calls}
    assert "maps" in stages and stages & {"index map: search", "index map: recolouring"}, stages
    for stage in stages:
        done = [c for c in calls if c[0] == stage]
        assert done[-1][1] == done[-1][2]  # each stage ends complete


def test_export_format_choice_and_blend_level_errors(tmp_path, omega_set, wang_set, capsys):
    """format: auto picks version 2 for a pure-copy omega set and the atlas for Wang tiles; 'provenance' refuses
    what cannot be version 2, saying why; blend levels are checked (name, range) and only for version 2."""
    from tilesynth.cli.main import main

    assert export(omega_set, tmp_path / "a", index_size=(2, 2))["format_version"] == 2
    assert export(wang_set, tmp_path / "b", index_size=(2, 2))["format_version"] == 1
    assert export(omega_set, tmp_path / "c", index_size=(2, 2), format="atlas")["format_version"] == 1
    # map_smooth on asks for the CPU fusion, stored only in an atlas
    assert export(omega_set, tmp_path / "d", index_size=(2, 2), map_smooth="on")["format_version"] == 1
    odd = ts.build_omega(omega_set.exemplar, tileset="16a", tile_size=36, seed=1)  # not a multiple of 8
    assert export(odd, tmp_path / "o", index_size=(2, 2))["format_version"] == 1
    with pytest.raises(ParameterError, match="multiple of 8"):
        export(odd, tmp_path / "o", index_size=(2, 2), format="provenance")
    for tileset, kw, word in (
        (wang_set, {"format": "provenance"}, "one-bit quadrant form"),
        (omega_set, {"format": "provenance", "map_smooth": "on"}, "map_smooth"),
        (omega_set, {"format": "v3"}, "format"),
        (omega_set, {"blend_levels": {"nope": 1}}, "no map named 'nope'"),
        (omega_set, {"blend_levels": {"albedo": -1}}, r"blend_levels\['albedo'\]"),
        (omega_set, {"blend_levels": {"albedo": True}}, r"blend_levels\['albedo'\]"),
        (omega_set, {"blend_levels": [1]}, "blend_levels"),
        (omega_set, {"blend_levels": {"albedo": 1}, "format": "atlas"}, "only for the provenance export"),
    ):
        with pytest.raises(ParameterError, match=word):
            export(tileset, tmp_path / "e", index_size=(2, 2), **kw)
    m = export(omega_set, tmp_path / "f", index_size=(2, 2), blend_levels={"albedo": 1.5})
    assert m["maps"][0]["blend_level"] == 1.5
    src = tmp_path / "s.tiles"
    omega_set.save(src)
    base = ["export", str(src), "-o", str(tmp_path / "g"), "--index-size", "2x2"]
    assert main([*base, "--blend-level", "albedo"]) == 2
    assert "expected MAP=L" in capsys.readouterr().err
    assert main([*base, "--blend-level", "albedo=x"]) == 2
    assert main([*base, "--blend-level", "albedo=2"]) == 0
    got = json.loads((tmp_path / "g" / "manifest.json").read_text())
    assert got["format_version"] == 2 and got["maps"][0]["blend_level"] == 2.0
    assert main([*base, "--format", "atlas"]) == 0
    assert json.loads((tmp_path / "g" / "manifest.json").read_text())["format_version"] == 1
    assert not (tmp_path / "g" / "table.bin").exists()  # the re-export removed the version-2 files


def test_quadrant_form_reproduces_the_provenance_and_its_radii_hold(omega_set, wang_set):
    """The one-bit form gives every pixel's source exactly as the provenance does; Wang tiles do not fit it;
    the label band's radii (half a pixel to spare) never misclassify a pixel; the packed table decodes back."""
    from tilesynth.engine import provenance_export as pe

    form = pe.quadrant_form(omega_set._provenance())
    assert form is not None and np.array_equal(form.source(), omega_set._provenance().source())
    assert pe.quadrant_form(wang_set._provenance()) is None
    n = form.tile_size
    r_in, r_out = pe.quadrant_radii(form)
    yy, xx = np.mgrid[0:n, 0:n]
    d = np.hypot(xx + 0.5 - n / 2, yy + 0.5 - n / 2)
    q = pe.quadrant_of(n)
    for t in range(form.n_tiles):
        for j in range(4):
            sel = q == j
            assert form.bits[t][sel & (d < r_in[t, j] / 2 + 0.5)].all()
            assert not form.bits[t][sel & (d > r_out[t, j] / 2 - 0.5)].any()
    assert (r_in < r_out).any()  # a band exists where the cut runs
    tab = pe.pack_table(form).reshape(-1, 4)[: 4 * form.n_tiles].astype(np.int64)
    e = form.entries.reshape(-1, 2, 3)
    for col, k in ((0, 0), (2, 1)):
        assert np.array_equal(tab[:, col] & 7, e[:, k, 0])
        assert np.array_equal(((tab[:, col] >> 3) & 0xFFFF) - pe.BIAS, e[:, k, 1])
        assert np.array_equal(tab[:, col + 1], e[:, k, 2])
    assert np.array_equal(tab[:, 0] >> 19, r_in.reshape(-1)) and np.array_equal(
        tab[:, 2] >> 19, r_out.reshape(-1)
    )


def test_cli_export_blends_smooth_maps_and_says_where_it_cannot(tmp_path, small_exemplar, capsys):
    """A material's smooth maps get the seam blend of ``synth`` in the provenance shaders (manifest ``seam``
    "blend", with its bands and the map's mean); where the tile size is not whole blocks of the blend's levels
    (24 px) they are cut hard and the export says so (and what to do); with a blend level given, it does not."""
    from tilesynth.cli.main import main

    ex = np.ascontiguousarray(small_exemplar[:64, :64])
    for n in (16, 24):
        t = ts.build(ex, tileset="c2", tile_size=n, seed=1, maps={"height": ex[..., 0].copy()})
        t.save(tmp_path / f"m{n}.tiles")
        assert main(["export", str(tmp_path / f"m{n}.tiles"), "-o", str(tmp_path / f"a{n}")]) == 0
        err = capsys.readouterr().err
        height = next(
            e
            for e in json.loads((tmp_path / f"a{n}" / "manifest.json").read_text())["maps"]
            if e["name"] == "height"
        )
        if n == 16:
            assert "note:" not in err
            assert height["seam"] == "blend" and height["bands"] == {"high": 3.0}
            assert height["mean"] == pytest.approx([float(ex[..., 0].astype(np.float64).mean())], abs=1e-6)
        else:
            assert "note: map(s) height: tiles of 24 px are not whole blocks" in err
            assert height["seam"] == "cut" and "bands" not in height
    assert (
        main(["export", str(tmp_path / "m24.tiles"), "-o", str(tmp_path / "b"), "--blend-level", "height=2"])
        == 0
    )
    assert "note:" not in capsys.readouterr().err
    # every file of a blended export is one a re-export may remove: the atlas export in its place leaves none
    m16 = json.loads((tmp_path / "a16" / "manifest.json").read_text())
    assert "labels_blend.png" in m16["files"]
    atlas = export(ts.load(tmp_path / "m16.tiles"), tmp_path / "a16", format="atlas", padding=4)
    assert _all_files(tmp_path / "a16") == {*atlas["files"], "manifest.json"}


@pytest.fixture(scope="module")
def odd_material():
    """Tiles of 64 (the blend's low band, split 3) on a 124 x 116 exemplar: sides not multiples of 2^3."""
    data = Path(__file__).parent / "data"
    albedo = np.asarray(load_raster(data / "rock053-albedo-128.png"))[:116, :124]
    luma = (albedo.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]) / 255.0)[..., None]
    maps = {
        "height": np.rint(luma * 65535).astype(np.uint16),
        "roughness": np.rint((1 - luma) * 255).astype(np.uint8),
    }
    return ts.build(albedo, tileset="c2", tile_size=64, seed=1, maps=maps), maps


def test_low_band_beside_its_map_is_the_cpu_low_band(tmp_path, odd_material):
    """A one-channel scalar map blended with a low band carries that band as a texture of its own size (bound
    with the map as a second channel): at every texel the CPU formula's ``a`` (the bilinear sample of the box mip
    at level ``split``, a partial last block averaging its own pixels), so the shader reads what
    ``synthesize_maps`` reads wherever an entry lands, mirrored past the exemplar's edge included; the maps
    without a low band (albedo, normals, multi-channel) have none; its bytes are counted apart."""
    from tilesynth.synth import seams

    tileset, maps = odd_material
    normal = np.zeros(tileset.exemplar.shape, np.uint8)
    normal[..., 2] = 255
    m = export(tileset, tmp_path / "x", maps={"normal": normal})
    validate_manifest(m)
    got = {mp["name"]: mp for mp in m["maps"]}
    assert {k for k, mp in got.items() if "low_band" in mp} == {"height", "roughness"}
    low_bytes = 0
    for name in ("height", "roughness"):
        mp = got[name]
        lb = mp["low_band"]
        assert lb["channel"] == 1 and [lv["width"] for lv in lb["levels"]] == [
            lv["width"] for lv in mp["levels"]
        ]
        split = int(mp["bands"]["split"])
        scale = 65535.0 if maps[name].dtype == np.uint16 else 255.0
        stored = np.asarray(load_raster(tmp_path / "x" / lb["levels"][0]["file"])).reshape(
            maps[name].shape[:2]
        )
        assert stored.dtype == maps[name].dtype
        mip = seams.box_mip(maps[name].astype(np.float64) / scale, split)
        # the entries of every tile at every pixel, mirrored where they leave the exemplar
        prov = tileset._provenance()
        coords = seams.entry_coords(prov.table, 64, *maps[name].shape[:2])
        exact = seams.sample_mip(mip, split, coords)[..., 0] * scale
        assert np.abs(stored[coords[..., 0], coords[..., 1]] - exact).max() <= 0.5 + 1e-9
        low_bytes += sum(lv["width"] * lv["height"] * maps[name].dtype.itemsize for lv in lb["levels"])
    g = m["gpu_bytes"]
    assert g["low_band"] == low_bytes and g["total"] == sum(
        v for k, v in g.items() if k not in ("total", "ratio_to_maps")
    )
    assert g["ratio_to_maps"] < 2.5  # a 124 x 116 exemplar of 16 tiles: the labels weigh more than at 512²


def test_viewer_refuses_a_low_band_it_cannot_bind(tmp_path, odd_material):
    from tilesynth.engine import viewer_v2 as v2

    tileset, _ = odd_material
    m = export(tileset, tmp_path / "x")
    bad = json.loads(json.dumps(m))
    mp = next(x for x in bad["maps"] if x["name"] == "height")
    mp["low_band"]["levels"] = mp["low_band"]["levels"][:-1]
    with pytest.raises(ParameterError, match="low_band"):
        v2.config_for(tileset, bad, tmp_path / "x", None, [])
    mp["low_band"]["channel"] = 2
    with pytest.raises(jsonschema.ValidationError):
        validate_manifest(bad)
