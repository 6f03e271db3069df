"""Masks and input warnings (issue 14): masked pixels never reach a tile, in every scheme; bad masks; warnings.

Provenance is the check: ``TileSet.source`` names the exemplar pixel of every tile pixel, so a build honours its
mask iff no source pixel is masked (and every synthesis copies tile pixels only).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageDraw

import tilesynth as ts
from tilesynth.builder.masking import ExemplarMask, resolve_mask
from tilesynth.cli.main import main as cli_main
from tilesynth.measure.diagnose import InputWarning, diagnose_exemplar, outliers, stationarity

SHARED = Path("/work/shared/textures")


def _texture(name: str, lettuce: np.ndarray) -> np.ndarray:
    """A texture of the shared set as float32 RGB, or a crop of the bundled lettuce when it is absent."""
    p = SHARED / f"{name}.png"
    if p.is_file():
        return np.asarray(Image.open(p).convert("RGB"), np.float32) / 255.0
    return np.ascontiguousarray(lettuce[:256, :256, :3])


def _shrink(img: np.ndarray, size: int) -> np.ndarray:
    im = Image.fromarray((img * 255).round().astype(np.uint8))
    return np.asarray(im.resize((size, size), Image.LANCZOS), np.float32) / 255.0


def _hole(h: int, w: int, fraction: float = 0.17) -> np.ndarray:
    r = np.sqrt(fraction * h * w / np.pi)
    yy, xx = np.mgrid[:h, :w]
    return (yy - 0.45 * h) ** 2 + (xx - 0.55 * w) ** 2 <= r * r


def _z_mask(h: int, w: int) -> np.ndarray:
    im = Image.new("L", (w, h), 0)
    ImageDraw.Draw(im).line(
        [(0.3 * w, 0.28 * h), (0.68 * w, 0.28 * h), (0.32 * w, 0.7 * h), (0.7 * w, 0.7 * h)],
        fill=255,
        width=max(3, w // 28),
    )
    return np.asarray(im) > 0


@pytest.fixture(scope="module")
def bricks_hole(lettuce):
    """bricks-red (shrunk to 128 px) as RGBA with a transparent disc of 17 % of the pixels."""
    rgb = _shrink(_texture("bricks-red", lettuce), 128)
    hole = _hole(128, 128)
    rgb[hole] = 0.0
    return np.dstack([rgb, np.where(hole, 0.0, 1.0).astype(np.float32)]), hole


@pytest.fixture(scope="module")
def bark_z(lettuce):
    """bark-lichen (shrunk to 96 px) with a painted red Z, and the mask of the Z."""
    bark = _shrink(_texture("bark-lichen", lettuce), 96)
    z = _z_mask(96, 96)
    bark[z] = (0.9, 0.08, 0.08)
    return bark, z


def _quiet_build(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        return ts.build(*args, **kw)


def _masked_hits(tset, masked: np.ndarray) -> int:
    return int(masked[tset.source[..., 0], tset.source[..., 1]].sum())


# every scheme's default, plus the other matching paths of ω and the selection of sample patches
SCHEME_CASES = [
    ("omega", {}),
    ("omega", {"tileset": "16a"}),
    ("omega", {"tileset": "32", "match": "best-cut", "match_k": 4}),
    ("omega", {"tileset": "8", "metric": "eq3", "select": "ga", "population": 8, "generations": 3}),
    ("omega", {"tileset": "4", "select": "ais", "population": 8, "generations": 2, "polish": True}),
    # issue 15's cut objective: the re-ranked candidates and the cut polish only take clear windows
    ("omega", {"tileset": "4", "objective": "cut", "polish": True, "population": 12, "rerank": 3}),
    ("patch", {}),
    ("wang", {}),
    ("wang", {"select": "ga", "population": 8, "generations": 2}),
    ("swang", {}),
    ("swang", {"supplementary": "cut"}),
]


@pytest.mark.parametrize(("scheme", "kw"), SCHEME_CASES)
def test_bark_z_never_copied(bark_z, scheme, kw):
    bark, z = bark_z
    size = 24 if kw.get("tileset", "c5" if scheme == "omega" else "") != "c5" else 16
    t = _quiet_build(bark, scheme=scheme, mask=z, seed=3, tile_size=size, **kw)
    assert _masked_hits(t, z) == 0
    assert t.params["mask"]["masked_pixels"] == int(z.sum())
    # an output: every pixel's provenance through the index map
    img, imap = ts.synthesize(t, 160, 160, seed=1)
    where = ts.source_map(t, imap, 160, 160)
    assert not z[where[..., 0], where[..., 1]].any()
    assert not (np.abs(img - np.array([0.9, 0.08, 0.08], np.float32)).max(axis=2) < 0.02).any()


def test_bark_z_without_mask_copies_it(bark_z):
    """The test above can fail: without the mask the Z is copied."""
    bark, z = bark_z
    hits = [_masked_hits(_quiet_build(bark, scheme="omega", seed=s, tile_size=16), z) for s in range(3)]
    assert max(hits) > 0


def test_brick_hole_alpha_is_a_mask_by_default(bricks_hole):
    rgba, hole = bricks_hole
    with pytest.warns(InputWarning, match="transparent"):
        t = ts.build(rgba, seed=1, tileset="16a", tile_size=32)
    assert t.channels == 3  # the alpha channel became the mask and was dropped
    assert _masked_hits(t, hole) == 0
    assert t.params["mask"]["source"] == "alpha"
    assert abs(t.params["mask"]["masked_fraction"] - hole.mean()) < 1e-6
    assert any(w["code"] == "masked-area" for w in t.params["warnings"])
    img, imap = ts.synthesize(t, 256, 256, seed=2)
    where = ts.source_map(t, imap, 256, 256)
    assert not hole[where[..., 0], where[..., 1]].any()
    # alpha as colour copies the hole (the behaviour before masks)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        t2 = ts.build(rgba, seed=1, tileset="16a", tile_size=32, alpha="colour")
    assert t2.channels == 4 and _masked_hits(t2, hole) > 0


def test_opaque_alpha_changes_nothing(small_exemplar):
    rgba = np.dstack([small_exemplar, np.ones(small_exemplar.shape[:2], np.float32)])
    t = ts.build_omega(rgba, tileset="16a", tile_size=32, seed=2026)
    assert t.channels == 4 and "mask" not in t.params


def test_empty_mask_is_the_unmasked_build(small_exemplar):
    a = ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=2026)
    b = ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=2026, mask=np.zeros((96, 96), bool))
    assert np.array_equal(a.tiles, b.tiles) and b.params["mask"]["masked_fraction"] == 0.0
    assert "mask" not in a.params and "warnings" not in a.params


def test_mask_digest_in_saved_file_and_info(bark_z, tmp_path, capsys):
    bark, z = bark_z
    t = _quiet_build(bark, mask=z, seed=3, tile_size=24, tileset="16a")
    path = tmp_path / "z.tiles"
    t.save(path)
    back = ts.load(path)
    assert back.params["mask"] == t.params["mask"]
    assert cli_main(["info", str(path)]) == 0
    assert "mask          array: 4." in capsys.readouterr().out


@pytest.mark.parametrize(
    ("mask", "kind", "match"),
    [
        (np.ones((96, 96), bool), ts.ParameterError, "every pixel is masked"),
        (np.zeros((100, 96), bool), ts.ShapeError, "96x100 .* the exemplar 96x96"),
        (np.zeros((96, 96, 5)), ts.ShapeError, "expected \\(h, w\\)"),
        (np.full((96, 96), np.nan), ts.ParameterError, "non-finite"),
        (np.full((96, 96), "x"), TypeError, "dtype"),
    ],
)
def test_bad_masks(bark_z, mask, kind, match):
    with pytest.raises(kind, match=match):
        ts.build(bark_z[0], mask=mask, seed=1)


def test_too_little_valid_area_names_what_fits(bark_z):
    bark = bark_z[0]
    m = np.ones((96, 96), bool)
    m[10:50, 20:60] = False  # one clear 40 x 40 square
    with pytest.raises(
        ts.ParameterError, match=r"largest valid square window: 40x40.*tile_size <= \d+ would fit"
    ):
        ts.build(bark, scheme="omega", tileset="16a", tile_size=48, mask=m, seed=1)
    # and the size it names does build
    msg = ""
    try:
        ts.build(bark, scheme="omega", tileset="16a", tile_size=48, mask=m, seed=1)
    except ts.ParameterError as exc:
        msg = str(exc)
    fit = int(msg.split("tile_size <= ")[1].split()[0])
    t = _quiet_build(bark, scheme="omega", tileset="16a", tile_size=fit, mask=m, seed=1)
    assert _masked_hits(t, m) == 0


def test_given_genes_on_the_mask_are_refused(bark_z):
    bark, z = bark_z
    r, c = np.argwhere(z)[0]
    genes = np.array([[min(max(r - 2, 0), 72), min(max(c - 2, 0), 72)], [0, 0], [0, 72], [72, 0]])
    with pytest.raises(ts.ParameterError, match=r"genes\[0\].*masked pixels"):
        ts.build_omega(bark, tileset="4", tile_size=24, genes=genes, mask=z)


def test_alpha_options(small_exemplar):
    with pytest.raises(ts.ParameterError, match="no alpha channel"):
        ts.build_omega(small_exemplar, alpha="mask", seed=1)
    with pytest.raises(ts.ParameterError, match="alpha = 'rgb'"):
        ts.build_omega(small_exemplar, alpha="rgb", seed=1)
    rgba = np.dstack([small_exemplar, np.zeros((96, 96), np.float32)])
    with pytest.raises(ts.ParameterError, match="alpha channel is below 0.5 everywhere"):
        ts.build_omega(rgba, seed=1)


def test_resolve_mask_binarises():
    ex = np.zeros((4, 4, 3), np.float32)
    m8 = np.array([[0, 127, 128, 255]] * 4, np.uint8)
    _, em = resolve_mask(ex, m8)
    assert em.masked[0].tolist() == [False, False, True, True]
    _, em = resolve_mask(ex, np.array([[0.0, 0.49, 0.5, 1.0]] * 4))
    assert em.masked[0].tolist() == [False, False, True, True]
    assert resolve_mask(ex, None)[1] is None


def test_exemplar_mask_geometry():
    m = np.zeros((10, 12), bool)
    m[4, 5] = True
    em = ExemplarMask(m, "array")
    assert em.largest_window() == 6  # 10 x 12 with one pixel at (4, 5): the 6 x 6 to its right is clear
    v = em.valid(3)
    assert not v[2:5, 3:6].any() and v.sum() == v.size - 9
    proj = em.project(np.argwhere(~v), 3)
    assert em.windows_ok(proj, 3).all()


# --------------------------------------------------------------------------------------------------------------
# the command line


def test_cli_mask_and_warning(tmp_path, bark_z, capsys):
    bark, z = bark_z
    ex, mk = tmp_path / "bark.png", tmp_path / "z.png"
    Image.fromarray((bark * 255).round().astype(np.uint8)).save(ex)
    Image.fromarray((z * 255).astype(np.uint8)).save(mk)
    out = tmp_path / "b.tiles"
    assert cli_main(["build", str(ex), "-o", str(out), "--mask", str(mk), "--seed", "1", "-q", "--set", "16a",
                     "--tile-size", "24"]) == 0  # fmt: skip
    t = ts.load(out)
    assert _masked_hits(t, z) == 0 and t.params["mask"]["source"] == "file"
    capsys.readouterr()
    # a mask of another size: exit 2, one line naming it, no file
    small = tmp_path / "small.png"
    Image.fromarray(np.zeros((50, 60), np.uint8)).save(small)
    bad = tmp_path / "bad.tiles"
    assert cli_main(["build", str(ex), "-o", str(bad), "--mask", str(small), "-q"]) == 2
    err = capsys.readouterr().err
    assert "mask 'small.png' has shape 60x50" in err and not bad.exists()
    assert cli_main(["build", str(ex), "-o", str(bad), "--mask", str(tmp_path / "none.png"), "-q"]) == 2
    assert "no such file" in capsys.readouterr().err
    # a folder named like an array mask says what it is, not "no such file"
    (tmp_path / "dir.npy").mkdir()
    assert cli_main(["build", str(ex), "-o", str(bad), "--mask", str(tmp_path / "dir.npy"), "-q"]) == 2
    assert "is a directory" in capsys.readouterr().err and not bad.exists()


def test_cli_prints_warnings(tmp_path, bricks_hole, capsys):
    rgba, hole = bricks_hole
    ex = tmp_path / "hole.png"
    Image.fromarray((rgba * 255).round().astype(np.uint8), "RGBA").save(ex)
    out = tmp_path / "h.tiles"
    assert (
        cli_main(["build", str(ex), "-o", str(out), "--seed", "1", "-q", "--set", "16a", "--tile-size", "32"])
        == 0
    )
    err = capsys.readouterr().err
    assert "warning: 17.0 % of the exemplar is transparent" in err
    assert cli_main(["info", str(out)]) == 0
    assert "warning       masked-area" in capsys.readouterr().out


# --------------------------------------------------------------------------------------------------------------
# the warnings, on synthetic inputs that must and must not warn


def _noise(seed: int = 0, n: int = 128) -> np.ndarray:
    return np.random.default_rng(seed).random((n, n, 3)).astype(np.float32)


def test_stationary_noise_does_not_warn():
    assert not [f for f in diagnose_exemplar(_noise()) if f["code"] == "non-stationary"]
    st = stationarity(_noise())
    assert st["mean_trend"] < 0.2 and st["contrast_trend"] < 1.3


def test_lighting_gradient_warns():
    n = _noise()
    ramp = np.clip(n * 0.5 + np.linspace(0, 0.5, 128, dtype=np.float32)[None, :, None], 0, 1)
    f = [f for f in diagnose_exemplar(ramp) if f["code"] == "non-stationary"]
    assert f and "crop" in f[0]["message"].lower()


def test_dark_half_warns():
    n = _noise()
    n[:, 64:] *= 0.3
    assert any(f["code"] == "non-stationary" for f in diagnose_exemplar(n))


def test_masking_the_odd_region_silences_the_warning():
    n = _noise()
    n[:, 96:] *= 0.2
    m = np.zeros((128, 128), bool)
    m[:, 96:] = True
    assert any(f["code"] == "non-stationary" for f in diagnose_exemplar(n))
    em = ExemplarMask(m, "array")
    assert not any(f["code"] == "non-stationary" for f in diagnose_exemplar(n, em))


def test_small_mask_does_not_warn_large_does():
    small = np.zeros((128, 128), bool)
    small[:5, :5] = True
    assert not diagnose_exemplar(_noise(), ExemplarMask(small, "array"), 32)
    big = np.zeros((128, 128), bool)
    big[:40] = True
    f = diagnose_exemplar(_noise(), ExemplarMask(big, "array"), 32)
    assert [x["code"] for x in f] == ["masked-area"] and "smaller tiles" in f[0]["message"]


def test_outliers_robust_log_scale():
    base = np.random.default_rng(1).uniform(90, 110, 40)
    assert outliers(base)[0].size == 0
    spiky = base.copy()
    spiky[7] = 2000
    assert outliers(spiky)[0].tolist() == [7]
    tight = np.full(40, 100.0)
    tight[3] = 130  # far in MADs, but only 1.3x the median: not flagged
    assert outliers(tight)[0].size == 0
    assert outliers(np.array([1.0, 50.0]))[0].size == 0  # too few tiles to judge


def test_cut_cost_outlier_in_a_tile_set(small_exemplar):
    """diagnose_tileset on a built set: no finding; with one tile's cut cost raised 20x: that tile is named."""
    from types import SimpleNamespace

    from tilesynth.measure.diagnose import diagnose_tileset

    t = ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=2026)
    assert diagnose_tileset(t) == []
    costs = t.cut_costs.copy()
    costs[5] *= 20
    fake = SimpleNamespace(cut_costs=costs, D=t.D, source=t.source, exemplar=t.exemplar)
    found = diagnose_tileset(fake)
    assert [f["code"] for f in found] == ["cut-cost-outlier"] and "(5)" in found[0]["message"]


def test_low_coverage_warns():
    big = _noise(2, 512)
    with pytest.warns(InputWarning, match="only .* % of the usable exemplar"):
        t = ts.build_omega(big, tileset="4", tile_size=8, seed=1)
    assert [w["code"] for w in t.params["warnings"]] == ["low-coverage"]


def test_report_shows_mask_and_warnings(bricks_hole, tmp_path):
    rgba, _ = bricks_hole
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        t = ts.build(rgba, seed=1, tileset="16a", tile_size=32)
    ts.write_report(t, tmp_path / "r", width=128, height=128)
    page = (tmp_path / "r" / "index.html").read_text()
    assert "mask: alpha: 17.0 % masked" in page and "warning: masked-area" in page


def _grating(turn_deg: float, n: int = 192, base: float = 0.3, seed: int = 0) -> np.ndarray:
    """A sinusoidal grating (period 12 px) whose orientation turns linearly by ``turn_deg`` from the left edge to
    the right one, plus a little noise."""
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float64)
    th = base + np.radians(turn_deg) * (xx / n - 0.5)
    g = 0.5 + 0.4 * np.sin(2 * np.pi / 12 * (xx * np.cos(th) + yy * np.sin(th)))
    g += 0.05 * np.random.default_rng(seed).standard_normal(g.shape)
    return np.repeat(np.clip(g, 0, 1)[..., None], 3, axis=2).astype(np.float32)


def test_turning_structure_warns_and_straight_structure_does_not():
    turned = _grating(30.0)
    st = stationarity(turned)
    assert 28.0 < st["orientation_turn"] < 40.0 and st["orientation_r2"] > 0.9
    found = [f for f in diagnose_exemplar(turned) if f["code"] == "orientation-drift"]
    assert len(found) == 1 and "rectify" in found[0]["message"].lower()
    assert found[0]["value"] == pytest.approx(st["orientation_turn"])
    for calm in (_grating(0.0), _grating(0.0, base=1.2), _grating(8.0), _noise(n=192)):
        st = stationarity(calm)
        assert not [f for f in diagnose_exemplar(calm) if f["code"] == "orientation-drift"], st
    assert stationarity(_grating(0.0))["orientation_turn"] < 2.0


def test_isotropic_noise_has_no_orientation_field():
    # the fitted field of an isotropic texture is short: its direction is noise and must not warn
    st = stationarity(_noise(3, 192))
    assert st["orientation_coherence"] < 0.1


def test_masking_the_turned_part_silences_the_orientation_warning():
    g = _grating(0.0)
    g[:, 128:] = _grating(90.0, base=0.3 + np.radians(45.0))[:, 128:]  # the right third runs another way
    assert any(f["code"] == "orientation-drift" for f in diagnose_exemplar(g))
    m = np.zeros(g.shape[:2], bool)
    m[:, 128:] = True
    assert not any(f["code"] == "orientation-drift" for f in diagnose_exemplar(g, ExemplarMask(m, "array")))


def test_a_brick_wall_photographed_at_an_angle_warns():
    # tests/data/README.md: scikit-image's brick.png (CC0), reduced to 128²: the courses lean one way on the left,
    # the other way on the right; brightness and contrast are uniform, so only the orientation test sees it
    img, _ = ts.load_image(Path(__file__).parent / "data" / "brick-perspective-128.png")
    codes = [f["code"] for f in diagnose_exemplar(img)]
    assert codes == ["orientation-drift"]
    assert stationarity(img)["orientation_turn"] > 30.0
