"""The recipe of an ω build (:mod:`tilesynth.builder.recipe`): one validated object, defaults in one place."""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

import tilesynth
from tilesynth.builder import recipe as rmod
from tilesynth.builder.options import common_options
from tilesynth.builder.recipe import DEFAULT, Recipe, resolve, why
from tilesynth.errors import ParameterError
from tilesynth.layouts.corners import corner_set

FIELDS = [f.name for f in dataclasses.fields(Recipe)]


@pytest.fixture
def crop(small_exemplar):
    return np.ascontiguousarray(small_exemplar[:96, :96])


def test_build_omega_takes_every_choice_as_a_keyword_with_the_recipe_default():
    """The keyword API is the recipe: every field is a keyword of build_omega with the same default (the CLI
    and the scheme registry read these defaults from the signature)."""
    params = inspect.signature(tilesynth.build_omega).parameters
    for name in FIELDS:
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY
        assert params[name].default == getattr(DEFAULT, name), name
    assert DEFAULT == Recipe()


def test_every_default_says_why():
    for name in FIELDS:
        assert len(why(name)) > 20, name
    assert "0.115 -> 0.056" in why("tileset")  # the measurement behind c5
    with pytest.raises(ParameterError, match="name = 'colour'"):
        why("colour")


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"periodic": "always"}, "periodic = 'always'"),
        ({"eps": -1.0}, "eps"),
        ({"gradients": "image"}, "gradients = 'image'"),
        ({"match": "best"}, "match"),
        ({"metric": "lab"}, "metric"),
        ({"smooth": 1}, "smooth = 1"),
        ({"cut_region": "square"}, "cut_region = 'square'"),
        ({"diversity": -2}, "diversity = -2"),
        ({"augment": "mirror"}, "augment"),
        ({"border_tries": 0}, "border_tries"),
        ({"border_criterion": "best"}, "best"),
    ],
)
def test_a_recipe_refuses_a_bad_choice_naming_it(change, match):
    with pytest.raises(ParameterError, match=match):
        Recipe(**change)
    with pytest.raises(ParameterError, match=match):
        DEFAULT.replace(**change)


def test_a_recipe_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        DEFAULT.tileset = "16a"  # type: ignore[misc]


def test_build_from_a_recipe_equals_the_build_from_keywords(crop):
    a = tilesynth.build_omega(crop, tileset="c3", seed=4, diversity=0)
    b = tilesynth.build_omega(crop, recipe=Recipe(tileset="c3", diversity=0), seed=4)
    assert np.array_equal(a.tiles, b.tiles)
    assert a.params == b.params


def test_a_recipe_and_changed_keywords_are_refused(crop):
    with pytest.raises(ParameterError, match="recipe and tileset, smooth"):
        tilesynth.build_omega(crop, recipe=Recipe(tileset="c3"), tileset="16a", smooth=True)
    with pytest.raises(ParameterError, match="recipe = 'c3'"):
        tilesynth.build_omega(crop, recipe="c3")


def test_resolve_fills_the_set_defaults(crop):
    b = common_options(crop, tileset="c3", resolve_set=corner_set, seed=1)
    b2, r = resolve(Recipe(tileset="c3"), b, None)
    assert (r.opts.cut_region, r.opts.diversity, r.criterion) == ("free", 1, "stats")
    assert b2.tile_size == 24 and r.border_draws and r.select is None and r.objective is None
    b = common_options(crop, tileset="16a", resolve_set=corner_set, seed=1)
    b2, r = resolve(Recipe(tileset="16a"), b, None)
    assert (r.opts.cut_region, r.opts.diversity, r.criterion) == ("circle", None, "cap")
    assert b2.tile_size == 48 and r.objective == "cut" and r.reranks
    with pytest.raises(ParameterError, match="cut_bias"):
        resolve(Recipe(tileset="16a", cut_bias=0.5), b, None)


def test_omega_options_is_still_importable_from_the_builder():
    from tilesynth.builder.omega import PERIODIC_MODES, omega_options

    assert omega_options is rmod.omega_options and PERIODIC_MODES == ("auto", "lock", "off")
