"""The build's exemplar (:class:`tilesynth.builder.exemplar.Exemplar`): validated once, derived layers once."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth.base import validate
from tilesynth.builder.exemplar import Exemplar
from tilesynth.errors import ParameterError
from tilesynth.measure import metrics


@pytest.fixture
def crop(small_exemplar):
    return np.ascontiguousarray(small_exemplar[:96, :96])


def _count_scans(monkeypatch, hw: tuple[int, ...]) -> list[str]:
    """The names of the image checks (``as_image``) of arrays ``hw`` pixels in size made from now on."""
    scans: list[str] = []
    check = validate._check_image

    def counting(image, name):
        if np.shape(image)[:2] == tuple(hw):
            scans.append(name)
        return check(image, name)

    monkeypatch.setattr(validate, "_check_image", counting)
    return scans


def test_a_default_build_validates_its_exemplar_once_and_derives_its_luminance_once(crop, monkeypatch):
    """The default build (a complete set: periodic rule, the stats draw and its vertex saliency, the diverse
    matching search) checks the exemplar once (was 7 times, and 3 luminances: issue's count of 8 scans of
    exemplar-sized arrays included the detail layer's autocorrelation, still checked as a derived array)."""
    scans: list[str] = []
    check = validate._check_image

    def counting(image, name):
        if np.shape(image) == crop.shape:
            scans.append(name)
        return check(image, name)

    lums: list[int] = []
    lum = metrics.luminance

    def counting_lum(image):
        lums.append(1)
        return lum(image)

    monkeypatch.setattr(validate, "_check_image", counting)
    monkeypatch.setattr(metrics, "luminance", counting_lum)
    ts = tilesynth.build_omega(crop, seed=1)
    assert ts.params["selection"].get("border_criterion") == "stats"  # the path that reads the derived layers
    assert scans == ["exemplar"]
    assert len(lums) == 1


@pytest.mark.parametrize("scheme", ["wang", "swang", "patch"])
def test_every_scheme_checks_its_exemplar_once(crop, scheme, monkeypatch):
    """The papers' schemes run their stages inside the exemplar's validated block too (Wang's cut kernel and
    the strict Wang tiles' supplementary search checked it a second time)."""
    scans = _count_scans(monkeypatch, crop.shape[:2])
    tilesynth.build(crop, scheme=scheme, seed=1, tile_size=32)
    assert scans == ["exemplar"]


def test_a_build_from_an_exemplar_equals_the_build_from_its_array(crop):
    a = tilesynth.build_omega(crop, tileset="c3", seed=4)
    b = tilesynth.build_omega(Exemplar.of(crop), tileset="c3", seed=4)
    assert np.array_equal(a.tiles, b.tiles)
    assert a.params == b.params


def test_exemplar_of_converts_once_and_never_aliases(crop):
    u8 = (crop * 255).round().astype(np.uint8)
    ex = Exemplar.of(u8, info={"bit_depth": 8})
    assert ex.image.dtype == np.float32 and ex.image.flags.c_contiguous
    assert ex.shape == crop.shape and ex.bit_depth == 8 and ex.mask is None
    f = Exemplar.of(crop)
    assert not np.shares_memory(f.image, crop)
    assert Exemplar.of(f) is f
    with pytest.raises(ParameterError, match="Exemplar carries its own mask"):
        Exemplar.of(f, alpha="mask")
    with pytest.raises(ParameterError, match="exemplar_info"):
        Exemplar.of(crop, info=3)


def test_exemplar_layers_equal_the_measures_and_are_kept(crop):
    ex = Exemplar.of(crop)
    assert np.array_equal(ex.luminance, metrics.luminance(crop))
    assert np.array_equal(ex.detail, metrics.detail_layer(crop))
    assert ex.detail is ex.detail
    s = ex.saliency(8)
    assert s is ex.saliency(8)
    ref = metrics.DiscSaliency(crop, 8)
    rows, cols = np.arange(0, 80, 7), np.arange(0, 80, 5)[: len(np.arange(0, 80, 7))]
    assert np.array_equal(s.at(rows, cols)[0], ref.at(rows, cols)[0])


def test_validated_image_trusts_only_that_object_and_only_inside(crop):
    ex = Exemplar.of(crop)
    bad = ex.image.copy()
    bad[0, 0, 0] = np.nan
    with ex.validated():
        assert validate.as_image(ex.image) is ex.image
        with pytest.raises(ParameterError, match="NaN"):
            validate.as_image(bad)  # an equal-shaped other array is still checked
    ex.image[0, 0, 0] = np.nan  # outside the block the promise is gone: the array is checked again
    with pytest.raises(ParameterError, match="NaN"):
        validate.as_image(ex.image)


def _material(crop):
    h = np.ascontiguousarray(crop[..., 0]).astype(np.float32)
    rough = (crop[..., 1] * 65535).round().astype(np.uint16)
    return {"height": h, "roughness": rough}


def test_a_material_build_checks_the_albedo_and_the_maps_once(crop, monkeypatch):
    """The albedo is scanned once (the feature image derived from it is not checked again) and the maps are
    checked once, before the build (it used to check the albedo, then the feature image in the builder)."""
    from tilesynth.builder import exemplar as exemplar_mod

    scans = _count_scans(monkeypatch, crop.shape[:2])
    calls: list[int] = []
    check_maps = exemplar_mod.check_maps

    def counting_maps(*a, **k):
        calls.append(1)
        return check_maps(*a, **k)

    monkeypatch.setattr(exemplar_mod, "check_maps", counting_maps)
    ts = tilesynth.build(crop, maps=_material(crop), tileset="c3", tile_size=24, seed=1)
    assert ts.params["material"]["joint"] is True
    assert scans == ["exemplar"] and calls == [1]


def test_exemplar_of_a_material_keeps_the_checked_maps_and_derives_the_features_once(crop):
    maps = _material(crop)
    ex = Exemplar.of(crop, maps=maps, map_weights={"albedo": 0.5})
    assert [s.name for s, _ in ex.maps] == ["height", "roughness"]
    assert [s.kind for s, _ in ex.maps] == ["scalar", "scalar"]
    assert ex.albedo_weight == 0.5 and ex.joint
    feats, record = ex.features()
    again, _ = ex.features()
    assert again is feats and feats.dtype == np.float32 and feats.flags.c_contiguous
    assert feats.shape[:2] == crop.shape[:2] and record["albedo_weight"] == 0.5
    assert "maps height+roughness" in repr(ex)
    labels_only = Exemplar.of(crop, maps=maps, map_weights={"height": 0, "roughness": 0})
    assert not labels_only.joint  # weight-0 maps only: the colour build, plus the maps
    with pytest.raises(ParameterError, match="carries its own mask, alpha, info and maps"):
        Exemplar.of(ex, maps=maps)
    with pytest.raises(ParameterError, match="needs a material"):
        Exemplar.of(crop).features()
    with pytest.raises(ParameterError, match="map weight of 'albedo'"):
        Exemplar.of(crop, maps=maps, map_weights={"albedo": -1})
    with pytest.raises(ParameterError, match="map name 'albedo'"):
        Exemplar.of(crop, maps={"albedo": maps["height"]})
