"""Material builds (issue 14, :mod:`tilesynth.builder.materials`): maps cut jointly with the albedo, stored in the tile
set, laid out through the same provenance; map kinds, normals, labels, and every bad input."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import tilesynth as ts
from tilesynth.base.kernels import DEFAULT_EPS
from tilesynth.builder import materials
from tilesynth.errors import ParameterError, ShapeError
from tilesynth.synth.synthesis import is_smoothed


def _material(h: int = 64, w: int = 64, seed: int = 3):
    """A small albedo (uint8) with a height map that is *not* a function of the colour and its normal map."""
    r = np.random.default_rng(seed)
    base = r.random((h // 4, w // 4, 3))
    albedo = np.kron(base, np.ones((4, 4, 1)))
    albedo = (albedo + 0.1 * r.random((h, w, 3))) / 1.1
    albedo_u8 = np.round(albedo * 255).astype(np.uint8)
    yy, xx = np.mgrid[0:h, 0:w]
    height = 0.5 + 0.25 * np.sin(xx / 5.0) * np.cos(yy / 7.0) + 0.2 * r.random((h, w)) * 0.1
    gy, gx = np.gradient(height * 8.0)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    normal_u8 = np.round((n * 0.5 + 0.5) * 255).astype(np.uint8)
    height_u16 = np.round(np.clip(height, 0, 1) * 65535).astype(np.uint16)
    return albedo_u8, height_u16, normal_u8


def _unit_normals(h: int, w: int, seed: int = 0, rough: float = 3.0) -> np.ndarray:
    """Unit normals (float64 ``(h, w, 3)``, +y up) of a smooth random height field."""
    r = np.random.default_rng(seed)
    f = np.fft.rfft2(r.standard_normal((h, w)))
    f /= 1 + (np.hypot(np.fft.fftfreq(h)[:, None], np.fft.rfftfreq(w)[None]) * 40) ** 2
    hgt = np.fft.irfft2(f, (h, w))
    gy, gx = np.gradient(hgt / hgt.std() * rough)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def _encode8(v: np.ndarray) -> np.ndarray:
    return np.round(np.clip(v * 0.5 + 0.5, 0, 1) * 255).astype(np.uint8)


def _real_world_normals(kind: str, size: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """A normal map as tools write it (uint8) and its true unit vectors: ``downscaled`` (box-filtered 4x from a
    4x larger unit map: short vectors), ``z0.78`` / ``z0.51`` (z stored times that factor)."""
    if kind == "downscaled":
        big = _unit_normals(4 * size, 4 * size, seed=5)
        d = big.reshape(size, 4, size, 4, 3).mean(axis=(1, 3))
        return _encode8(d), d / np.linalg.norm(d, axis=-1, keepdims=True)
    n = _unit_normals(size, size, seed=5, rough=1.5)
    z = n.copy()
    z[..., 2] *= float(kind[1:])
    return _encode8(z), n


def _build(albedo, maps, **kw):
    kw.setdefault("tileset", "4")
    kw.setdefault("tile_size", 16)
    kw.setdefault("seed", 1)
    return ts.build(albedo, maps=maps, **kw)


def test_round_trip_keeps_every_map_kind_and_weight(tmp_path):
    albedo, height, normal = _material()
    label = (np.arange(64 * 64).reshape(64, 64) % 5).astype(np.uint8)
    t = _build(albedo, {"height": height, "normal": normal, "mask": label}, map_weights={"height": 2.0})
    kinds = {d["name"]: (d["kind"], d["weight"]) for d in t.map_specs}
    assert kinds == {"height": ("scalar", 2.0), "normal": ("normal", 0.5), "mask": ("label", 0.0)}
    assert t.params["material"]["joint"] and t.params["material"]["feature_channels"] == 4
    assert t.exemplar.shape == (64, 64, 3)  # the albedo, not the feature image
    p = tmp_path / "m.tiles"
    t.save(p)
    back = ts.load(p)
    assert back.content_digest() == t.content_digest()
    assert back.map_specs == t.map_specs
    for name, arr in t.maps.items():
        assert back.maps[name].dtype == arr.dtype and np.array_equal(back.maps[name], arr)
    assert np.array_equal(back.tiles, t.tiles)


def test_tiles_are_the_albedo_through_the_provenance():
    albedo, height, normal = _material()
    t = _build(albedo, {"height": height, "normal": normal})
    a = albedo.astype(np.float32) / np.float32(255)
    assert np.array_equal(t.tiles, a[t.source[..., 0], t.source[..., 1]])


def test_every_map_goes_through_the_colour_provenance():
    """A map equal to a deterministic function of the colour comes out as that function of the colour output."""
    albedo, height, _ = _material()
    f = albedo[..., 1].copy()  # the green channel, as its own map (joint, weight 1)
    t = _build(albedo, {"green": f, "height": height})
    img, imap = ts.synthesize(t, 80, 72, seed=5, dtype=np.uint8)
    out = materials.synthesize_maps(t, imap, 80, 72, smooth=False)
    assert np.array_equal(out["green"][..., 0], img[..., 1])
    where = ts.source_map(t, imap, 80, 72)
    assert np.array_equal(out["height"][..., 0], height[where[..., 0], where[..., 1]])
    # by default scalar maps are fused across their seams (the exemplar's level correction, then the tile
    # interiors); the second stage alone copies the tile border ring
    smoothed = materials.synthesize_maps(t, imap, 80, 72)["height"][..., 0]
    ring = np.ones((t.n_tiles, 16, 16, 1), np.uint8)
    ring[:, 1:-1, 1:-1] = 0
    border = kernels_tile_copy(ring, imap, (72, 80))[..., 0] == 1
    spec = materials.MapSpec.from_dict(next(d for d in t.map_specs if d["name"] == "height"))
    copies = np.ascontiguousarray(t.maps["height"][t.source[..., 0], t.source[..., 1]])
    inner = materials.fuse_map_atlas(t, t.maps["height"], copies, level=False)
    inner_img = kernels_tile_copy(inner, imap, (72, 80))[..., 0]
    assert spec.kind == "scalar"
    assert np.array_equal(inner_img[border], out["height"][..., 0][border])
    assert not np.array_equal(inner_img[~border], out["height"][..., 0][~border])
    assert not np.array_equal(smoothed, out["height"][..., 0])


def kernels_tile_copy(atlas: np.ndarray, imap: np.ndarray, hw: tuple[int, int]) -> np.ndarray:
    out = np.empty((*hw, atlas.shape[3]), atlas.dtype)
    ts.tile_copy(np.ascontiguousarray(atlas), imap, out)
    return out


def test_joint_build_differs_from_colour_only_and_label_only_equals_it():
    albedo, height, normal = _material()
    colour = ts.build(albedo, tileset="4", tile_size=16, seed=1)
    joint = _build(albedo, {"height": height, "normal": normal}, map_weights={"height": 4.0})
    assert not np.array_equal(colour.source, joint.source)
    label = (albedo[..., 0] > 128).astype(np.uint8)
    only_labels = _build(albedo, {"mask": label})
    assert np.array_equal(only_labels.tiles, colour.tiles) and np.array_equal(
        only_labels.source, colour.source
    )
    assert only_labels.params["material"]["joint"] is False


def test_smoothed_normals_are_renormalised_and_labels_stay_exact():
    albedo, height, normal = _material()
    nf = (normal.astype(np.float32) / 255) * 2 - 1
    nf /= np.linalg.norm(nf, axis=-1, keepdims=True)  # float (signed) normals
    label = np.zeros((64, 64), np.uint8)
    label[::3] = 7
    label[:, ::5] = 200
    n16 = np.round((nf * 0.5 + 0.5) * 65535).astype(np.uint16)  # unit vectors to 16-bit precision
    t = _build(albedo, {"normal": nf.astype(np.float32), "nrm16": n16,
                        "labels": label, "height": height}, smooth=True)  # fmt: skip
    assert is_smoothed(t)
    img, imap = ts.synthesize(t, 96, 96, seed=2)
    out = materials.synthesize_maps(t, imap, 96, 96)
    for name, enc in (("normal", "snorm"), ("nrm16", "unorm")):
        length = materials.normal_lengths(out[name], enc)
        assert (np.abs(length - 1) <= 0.005).mean() >= 0.999, name
    # the plain --with path (no renormalisation) is not unit length where smoothed: the test can fail
    raw = ts.synthesize_map(t, nf.astype(np.float32), imap, 96, 96)
    assert (np.abs(materials.normal_lengths(raw, "snorm") - 1) > 0.005).any()
    where = ts.source_map(t, imap, 96, 96)
    assert np.array_equal(out["labels"][..., 0], label[where[..., 0], where[..., 1]])
    # the height was smoothed in the same regions (not a pure copy everywhere)
    assert not np.array_equal(out["height"][..., 0], height[where[..., 0], where[..., 1]])


def test_normal_y_conversion_flips_green_exactly():
    albedo, _, normal = _material()
    t = _build(albedo, {"normal": normal}, normal_y="down")
    assert t.map_specs[0]["normal_y"] == "down"
    _, imap = ts.synthesize(t, 64, 64, seed=1)
    same = materials.synthesize_maps(t, imap, 64, 64)["normal"]
    assert np.array_equal(same, materials.synthesize_maps(t, imap, 64, 64, normal_y="down")["normal"])
    up = materials.synthesize_maps(t, imap, 64, 64, normal_y="up")["normal"]
    assert np.array_equal(up[..., 1], 255 - same[..., 1])
    assert np.array_equal(up[..., [0, 2]], same[..., [0, 2]])


def test_kinds_inferred_from_names_and_overridden():
    assert materials.infer_kind("normal") == "normal"
    assert materials.infer_kind("rock_nrm") == "normal"
    assert materials.infer_kind("height") == "scalar"
    assert materials.infer_kind("roughness") == "scalar"
    assert materials.infer_kind("ao") == "scalar"
    assert materials.infer_kind("mask") == "label"
    assert materials.infer_kind("material_id") == "label"
    assert materials.infer_kind("basecolor") == "colour"
    albedo, height, _ = _material()
    t = _build(albedo, {"bumps": height}, map_kinds={"bumps": "label"})
    assert t.map_specs[0]["kind"] == "label" and t.map_specs[0]["weight"] == 0.0


# ------------------------------------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "case, error, words",
    [
        ("size", ShapeError, ["'height'", "60x64", "64x64", "pixel-aligned"]),
        ("nan", ParameterError, ["'height'", "nan", "row 3", "column 5"]),
        ("inf", ParameterError, ["'height'", "inf"]),
        ("normal", ParameterError, ["'normal'", "grey image", "normal:scalar=FILE"]),
        ("kind", ParameterError, ["'height'", "unknown map kind", "'bump'"]),
        ("duplicate", ParameterError, ["duplicate map name", "'Height'"]),
        ("weight", ParameterError, ["'height'", "-1"]),
    ],
)
def test_bad_maps_are_refused_naming_the_map_and_the_value(case, error, words):
    albedo, height, normal = _material()
    maps = {"height": height.astype(np.float32) / 65535, "normal": normal}
    kw = {}
    if case == "size":
        maps["height"] = maps["height"][:, :60]
    elif case == "nan":
        maps["height"][3, 5] = np.nan
    elif case == "inf":
        maps["height"][3, 5] = np.inf
    elif case == "normal":
        maps["normal"] = np.repeat(albedo[..., :1], 3, axis=2)  # a grey image given as a normal map
    elif case == "kind":
        kw["map_kinds"] = {"height": "bump"}
    elif case == "duplicate":
        maps["Height"] = maps["height"]
    elif case == "weight":
        kw["map_weights"] = {"height": -1}
    with pytest.raises(error) as exc:
        _build(albedo, maps, **kw)
    msg = str(exc.value)
    for w in words:
        assert w.lower() in msg.lower(), (w, msg)


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "tilesynth", *args], cwd=cwd, capture_output=True, text=True, timeout=600
    )


@pytest.fixture(scope="module")
def material_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("mat")
    albedo, height, normal = _material()
    ts.save_image(d / "albedo.png", albedo)
    ts.save_image(d / "height.png", height)
    ts.save_image(d / "normal.png", normal)
    ts.save_image(d / "small.png", height[:, :60])
    bad = np.repeat(albedo[..., :1], 3, axis=2)
    ts.save_image(d / "grey.png", bad)
    h = height.astype(np.float32) / 65535
    h[3, 5] = np.nan
    np.save(d / "nan.npy", h)
    return d


@pytest.mark.parametrize(
    "maps, words",
    [
        (["--map", "height=small.png"], ["height", "60x64", "pixel-aligned"]),
        (["--map", "height=nan.npy"], ["height", "nan"]),
        (["--map", "normal=grey.png"], ["normal", "grey image", "scalar"]),
        (["--map", "height:bump=height.png"], ["height", "unknown map kind", "bump"]),
        (["--map", "height=height.png", "--map", "height=normal.png"], ["duplicate map name", "height"]),
    ],
)
def test_cli_bad_maps_exit_2_without_a_file(material_files, maps, words):
    out = material_files / "bad.tiles"
    r = _cli("build", "albedo.png", "-o", str(out), "--set", "4", "--tile-size", "16", *maps, "-q",
             cwd=material_files)  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    for w in words:
        assert w.lower() in r.stderr.lower(), (w, r.stderr)
    assert not out.exists() and not list(material_files.glob("*.part"))


def test_cli_build_synth_export_write_every_map(material_files):
    d = material_files
    r = _cli("build", "albedo.png", "-o", "m.tiles", "--set", "4", "--tile-size", "16", "--seed", "1",
             "--map", "normal=normal.png", "--map", "height=height.png", "--map-weight", "height=2", cwd=d)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "maps normal (normal), height (scalar)" in r.stderr
    r = _cli("synth", "m.tiles", "-o", "out.png", "--size", "64x48", "--seed", "3", "--normal-y", "down",
             "--with", "albedo.png", cwd=d)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "not part of the cut" in r.stderr
    for name in ("out-normal.png", "out-height.png", "out-albedo.png"):
        assert (d / name).is_file(), name
    n_out = ts.load_raster(d / "out-normal.png")
    h_out = ts.load_raster(d / "out-height.png")
    assert n_out.dtype == np.uint8 and h_out.dtype == np.uint16 and h_out.shape == (48, 64, 1)
    t = ts.load(d / "m.tiles")
    img = ts.load_raster(d / "out.png")
    imap = ts.synthesize(t, 64, 48, seed=3)[1]
    ref = materials.synthesize_maps(t, imap, 64, 48, normal_y="down")
    assert np.array_equal(ref["normal"], n_out) and np.array_equal(ref["height"], h_out)
    assert img.shape == (48, 64, 3)
    r = _cli("export", "m.tiles", "-o", "exp", cwd=d)
    assert r.returncode == 0, r.stderr
    import json

    m = json.loads((d / "exp" / "manifest.json").read_text())
    names = {e["name"]: e for e in m["maps"]}
    assert {"albedo", "normal", "height"} <= set(names)
    assert names["normal"].get("normal_y") in ("+y", "up")
    r = _cli("info", "m.tiles", cwd=d)
    assert r.returncode == 0 and "normal" in r.stdout


def test_export_refuses_a_with_map_named_like_a_stored_one(material_files):
    t = ts.load(material_files / "m.tiles") if (material_files / "m.tiles").exists() else None
    if t is None:
        albedo, height, normal = _material()
        t = _build(albedo, {"normal": normal, "height": height})
    with pytest.raises(ParameterError, match="height"):
        ts.export(t, os.fspath(material_files / "exp2"), maps={"height": t.maps["height"]})


def test_cli_refuses_a_map_that_is_the_output(material_files):
    import shutil

    shutil.copy(material_files / "height.png", material_files / "same.tiles")  # a readable map
    before = (material_files / "same.tiles").read_bytes()
    r = _cli("build", "albedo.png", "-o", "same.tiles", "--map", "height=same.tiles", cwd=material_files)
    assert r.returncode == 2 and "same.tiles" in r.stderr and "--map" in r.stderr, r.stderr
    assert (material_files / "same.tiles").read_bytes() == before


def test_report_shows_every_map_with_its_cut_seam(tmp_path):
    albedo, height, normal = _material()
    t = _build(albedo, {"height": height, "normal": normal})
    res = ts.write_report(t, tmp_path / "rep", 64, 64, seed=1)
    assert (tmp_path / "rep" / "sample-height.png").is_file() and (
        tmp_path / "rep" / "sample-normal.png"
    ).is_file()
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "sample-height.png" in page and "cut seam score" in page
    assert "map-height" in res["files"]
    seams = materials.map_cut_seams(t)
    assert set(seams) == {"height", "normal"} and all(v is not None and v > 0 for v in seams.values())


# The small Wang sets may warn of a cut-cost outlier (tilesynth.measure.diagnose): not what this test is about.
@pytest.mark.filterwarnings("ignore::tilesynth.InputWarning")
def test_joint_builds_cut_with_the_material_eps_and_a_given_eps_wins():
    """Joint s-Wang and ω builds cut with ``MATERIAL_CUT_EPS`` (a capped gradient normalisation, so the cut does
    not follow the maps' own edges); a caller's ``eps`` is kept; a colour-only or labels-only build keeps the
    scheme's default."""
    albedo, height, normal = _material()
    kw = {"scheme": "swang", "tileset": "wang8", "tile_size": 16, "seed": 1}
    maps = {"height": height, "normal": normal}
    joint = ts.build(albedo, maps=maps, **kw)
    assert joint.params["eps"] == materials.MATERIAL_CUT_EPS == 1.0
    given = ts.build(albedo, maps=maps, eps=1e-3, **kw)
    assert given.params["eps"] == 1e-3
    explicit = ts.build(albedo, maps=maps, eps=materials.MATERIAL_CUT_EPS, **kw)
    assert np.array_equal(explicit.source, joint.source)
    colour = ts.build(albedo, **kw)
    labels = ts.build(albedo, maps={"mask": (albedo[..., 0] > 128).astype(np.uint8)}, **kw)
    assert colour.params["eps"] == labels.params["eps"] == DEFAULT_EPS
    assert np.array_equal(colour.source, labels.source)
    assert _build(albedo, maps).params["eps"] == materials.MATERIAL_CUT_EPS
    assert ts.build(albedo, tileset="4", tile_size=16, seed=1).params["eps"] == DEFAULT_EPS


@pytest.mark.parametrize("scheme, tileset", [("wang", "wang8"), ("swang", "wang8"), ("patch", "4")])
def test_every_scheme_builds_materials(tmp_path, scheme, tileset):
    """Every scheme's scalar maps are fused across the seams of its tiles (Cohen's Wang tiles, which have no
    matching patch, too: the fusion needs only the provenance's seams), so they are not the copies."""
    albedo, height, normal = _material()
    t = ts.build(
        albedo, scheme=scheme, tileset=tileset, tile_size=16, seed=1, maps={"height": height, "n": normal}
    )
    t.save(tmp_path / "s.tiles")
    back = ts.load(tmp_path / "s.tiles")
    _, imap = ts.synthesize(back, 48, 48, seed=2)
    out = materials.synthesize_maps(back, imap, 48, 48)
    where = ts.source_map(back, imap, 48, 48)
    copies = height[where[..., 0], where[..., 1]]
    assert out["n"].shape == (48, 48, 3) and out["height"].dtype == np.uint16
    assert not np.array_equal(out["height"][..., 0], copies)
    plain = materials.synthesize_maps(back, imap, 48, 48, smooth=False)
    assert np.array_equal(plain["height"][..., 0], copies)


def test_synth_with_a_normal_map_on_a_smoothed_set_renormalises_it(tmp_path):
    albedo, _, normal = _material()
    nf = normal.astype(np.float64) / 255 * 2 - 1
    nf /= np.linalg.norm(nf, axis=-1, keepdims=True)
    n16 = np.round((nf * 0.5 + 0.5) * 65535).astype(np.uint16)
    ts.save_image(tmp_path / "albedo.png", albedo)
    ts.save_image(tmp_path / "rock-normal.png", n16)
    r = _cli(
        "build",
        "albedo.png",
        "-o",
        "s.tiles",
        "--set",
        "4",
        "--tile-size",
        "16",
        "--smooth",
        "-q",
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    r = _cli(
        "synth", "s.tiles", "-o", "o.png", "--size", "64", "--with", "rock-normal.png", "-q", cwd=tmp_path
    )
    assert r.returncode == 0, r.stderr
    out = ts.load_raster(tmp_path / "o-rock-normal.png")
    assert (np.abs(materials.normal_lengths(out) - 1) <= 0.005).mean() >= 0.999


def test_material_builds_are_deterministic_at_any_thread_count():
    albedo, height, normal = _material()
    maps = {"height": height, "normal": normal, "rough": albedo[..., 2].copy()}
    a = _build(albedo, maps, threads=1)
    b = _build(albedo, maps, threads=2)
    assert a.content_digest() == b.content_digest()


def test_synth_map_smooth_on_a_set_without_matching_patches_fails_before_writing(tmp_path):
    """A colour map follows the colour's Poisson smoothing, which needs matching patches: refused on Cohen's
    Wang tiles. A scalar map is fused across the seams of any scheme, so there it is accepted."""
    albedo, height, _ = _material()
    emissive = np.ascontiguousarray(albedo[..., ::-1])
    t = ts.build(albedo, scheme="wang", tileset="wang8", tile_size=16, seed=1, maps={"emissive": emissive})
    t.save(tmp_path / "w.tiles")
    r = _cli("synth", "w.tiles", "-o", "o.png", "--size", "32", "--map-smooth", "on", "-q", cwd=tmp_path)
    assert r.returncode == 2 and "emissive" in r.stderr and "matching patches" in r.stderr, r.stderr
    assert not (tmp_path / "o.png").exists()
    t = ts.build(albedo, scheme="wang", tileset="wang8", tile_size=16, seed=1, maps={"height": height})
    t.save(tmp_path / "h.tiles")
    r = _cli("synth", "h.tiles", "-o", "o.png", "--size", "32", "--map-smooth", "on", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize("how", ["mask", "alpha"])
@pytest.mark.parametrize("tileset", ["4", "c2"])
def test_masked_material_builds_never_use_a_masked_pixel(how, tileset):
    """A material build with a mask (``mask=`` or the albedo's alpha): the mask is taken from the albedo, never
    from the feature image (whose 4th channel is a feature), and no tile pixel comes from a masked pixel; the
    complete sets' diversity search (at most 4 channels with the mask's penalty channel) works too."""
    albedo, height, normal = _material(96, 96)
    hole = np.zeros((96, 96), bool)
    hole[30:50, 40:64] = True
    kw: dict = {"tileset": tileset}
    if how == "mask":
        kw["mask"] = hole
        img = albedo
    else:
        img = np.concatenate([albedo, np.where(hole, 0, 255).astype(np.uint8)[..., None]], axis=2)
    t = _build(img, {"height": height, "normal": normal}, **kw)
    assert t.exemplar.shape == (96, 96, 3)
    assert t.params["material"]["joint"] and t.params["material"]["feature_channels"] == 3
    assert t.params["mask"]["masked_pixels"] == int(hole.sum())
    assert not hole[t.source[..., 0], t.source[..., 1]].any()
    a = albedo.astype(np.float32) / np.float32(255)
    assert np.array_equal(t.tiles, a[t.source[..., 0], t.source[..., 1]])


def test_unmasked_material_build_keeps_four_feature_channels_as_features():
    """Without a mask, the 4-channel feature image is not read as RGBA (its 4th channel is not an alpha)."""
    albedo, height, normal = _material()
    t = _build(albedo, {"height": height, "normal": normal})
    assert t.params["material"]["feature_channels"] == 4 and "mask" not in t.params


# ------------------------------------------------------------------------------------------- real normal maps
@pytest.mark.parametrize(
    "kind, note", [("downscaled", "renormalised"), ("z0.78", "z rebuilt"), ("z0.51", "z rebuilt")]
)
def test_real_world_normal_maps_are_normalised_and_the_fix_recorded(kind, note):
    albedo, _, _ = _material()
    raw, truth = _real_world_normals(kind)
    length = materials.normal_lengths(raw)
    assert (np.abs(length - 1) > materials.NORMAL_TOLERANCE).mean() > 0.05  # refused before
    t = _build(albedo, {"normal": raw})
    fixed = t.params["material"]["normalised"]
    assert list(fixed) == ["normal"] and fixed["normal"].startswith(note), fixed
    stored = t.maps["normal"]
    assert stored.dtype == np.uint8
    assert (np.abs(materials.normal_lengths(stored) - 1) <= 0.005).all()
    v = stored.astype(np.float64) / 255 * 2 - 1
    angle = np.arccos(np.clip((v * truth).sum(-1) / np.linalg.norm(v, axis=-1), -1, 1))
    assert np.median(angle) < 0.02 and np.quantile(angle, 0.99) < 0.06, (np.median(angle), angle.max())
    # a unit map is used as it is: same bytes, nothing recorded
    unit = _build(albedo, {"normal": _encode8(truth)})
    assert "normalised" not in unit.params["material"]
    assert np.array_equal(unit.maps["normal"], _encode8(truth))


@pytest.mark.parametrize(
    "case, words",
    [
        ("grey", ["grey image"]),
        ("zero", ["near zero"]),
        ("off-centre", ["not centred", "mean x +0.5"]),
        ("photo", ["vary together"]),
        ("z-negative", ["z (blue) is not positive"]),
    ],
)
def test_what_cannot_be_a_normal_map_is_refused_saying_how_to_pass_it(case, words):
    albedo, height, _ = _material()
    n = _unit_normals(64, 64, seed=2)
    if case == "grey":
        m = np.repeat((height >> 8).astype(np.uint8)[..., None], 3, axis=2)
    elif case == "zero":
        m = np.full((64, 64, 3), 128, np.uint8)
    elif case == "off-centre":
        m = _encode8(n * 0.8 + np.array([0.5, 0.0, 0.0]))
    elif case == "photo":
        m = (albedo.mean(axis=2, keepdims=True) * 0.6 + albedo * 0.4).astype(
            np.uint8
        )  # channels move together
    else:
        m = _encode8(n * np.array([0.7, 0.7, -0.7]))
    with pytest.raises(ParameterError) as exc:
        _build(albedo, {"normal": m})
    msg = str(exc.value)
    for w in [*words, "'normal'", "normal:scalar=FILE", "map_kinds"]:
        assert w in msg, (w, msg)
    # and passed as a scalar map it builds
    t = _build(albedo, {"normal": m}, map_kinds={"normal": "scalar"})
    assert t.map_specs[0]["kind"] == "scalar"


def test_cli_builds_a_downscaled_normal_map_and_info_says_what_was_done(tmp_path):
    albedo, _, _ = _material()
    raw, _ = _real_world_normals("downscaled")
    ts.save_image(tmp_path / "albedo.png", albedo)
    ts.save_image(tmp_path / "rock-normal.png", raw)
    r = _cli("build", "albedo.png", "-o", "m.tiles", "--set", "4", "--tile-size", "16", "--seed", "1",
             "--map", "normal=rock-normal.png", cwd=tmp_path)  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "map normal: renormalised (median length" in r.stdout + r.stderr
    info = _cli("info", "m.tiles", cwd=tmp_path)
    assert info.returncode == 0 and "map normal: renormalised" in info.stdout, info.stdout
    t = ts.TileSet.load(tmp_path / "m.tiles")
    assert t.params["material"]["normalised"]["normal"].startswith("renormalised")
