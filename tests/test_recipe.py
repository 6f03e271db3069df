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
from tilesynth.measure.diagnose import InputWarning

FIELDS = [f.name for f in dataclasses.fields(Recipe)]


@pytest.fixture
def crop(small_exemplar):
    return np.ascontiguousarray(small_exemplar[:96, :96])


def test_build_omega_takes_every_choice_as_a_keyword_with_the_recipe_default():
    """The keyword API is the recipe: every field is a keyword of build_omega with the same default (the CLI
    and the scheme registry read these defaults from the signature). ``tileset`` defaults to None, "not given":
    the default recipe's set, or a named recipe's (a set given explicitly, the default one included, wins)."""
    params = inspect.signature(tilesynth.build_omega).parameters
    for name in FIELDS:
        assert params[name].kind is inspect.Parameter.KEYWORD_ONLY
        assert params[name].default == (None if name == "tileset" else getattr(DEFAULT, name)), name
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


# ------------------------------------------------------------------------------------------ named recipes
def _discs(size: int, r: int, count: int, seed: int) -> np.ndarray:
    """Black discs of radius r on white, apart from each other: a photo of separate objects."""
    rng = np.random.default_rng(seed)
    img = np.ones((size, size, 3), np.float32)
    yy, xx = np.mgrid[-r : r + 1, -r : r + 1]
    disc = yy**2 + xx**2 <= r * r
    centres: list[tuple[int, int]] = []
    for _ in range(20000):
        if len(centres) == count:
            break
        y, x = (int(v) for v in rng.integers(r + 1, size - r - 1, 2))
        if all((y - a) ** 2 + (x - b) ** 2 > (2 * r + 3) ** 2 for a, b in centres):
            centres.append((y, x))
            img[y - r : y + r + 1, x - r : x + r + 1][disc] = 0.0
    return img


def test_every_named_recipe_says_what_it_trades():
    assert set(rmod.NAMED_RECIPES) == {"default", "fast", "objects"}
    for name, text in rmod.NAMED_RECIPES.items():
        assert len(text) > 60, name


def test_the_default_recipe_by_name_is_the_default_build(crop):
    a = tilesynth.build_omega(crop, tileset="c3", seed=4)
    b = tilesynth.build_omega(crop, tileset="c3", seed=4, recipe="default")
    assert a.content_digest() == b.content_digest() and "recipe" not in b.params


def test_fast_is_c4_unless_a_set_is_given(crop):
    t = tilesynth.build_omega(crop, seed=4, recipe="fast")
    assert t.n_tiles == 256 and t.params["recipe"] == {"name": "fast", "applied": ["tileset"]}
    assert np.array_equal(t.tiles, tilesynth.build_omega(crop, seed=4, tileset="c4").tiles)
    given = tilesynth.build_omega(crop, seed=4, recipe="fast", tileset="c3")  # the keyword wins
    assert given.n_tiles == 81 and given.params["recipe"]["applied"] == []
    c5 = tilesynth.build_omega(
        crop, seed=4, recipe="fast", tileset="c5"
    )  # the default set given explicitly too
    assert c5.n_tiles == 625 and c5.params["recipe"]["applied"] == []
    c4 = tilesynth.build_omega(crop, seed=4, recipe="fast", tileset="c4")  # given as the recipe would set it
    assert c4.params["recipe"]["applied"] == ["tileset"] and c4.content_digest() == t.content_digest()


def test_cli_fast_without_a_set_says_and_builds_c4_and_with_the_default_set_builds_it(crop, tmp_path, capsys):
    from PIL import Image

    from tilesynth.cli.main import main

    src = tmp_path / "crop.png"
    Image.fromarray((crop * 255).round().astype(np.uint8)).save(src)
    assert main(["build", str(src), "-o", str(tmp_path / "f.tiles"), "--seed", "4", "--recipe", "fast"]) == 0
    out = capsys.readouterr()
    assert "(set c4," in out.err + out.out  # the set that was built, not the default's name
    assert tilesynth.load(tmp_path / "f.tiles").n_tiles == 256
    args = [
        "build",
        str(src),
        "-o",
        str(tmp_path / "d.tiles"),
        "--seed",
        "4",
        "--recipe",
        "fast",
        "--set",
        "c5",
    ]
    assert main([*args, "-q"]) == 0
    assert tilesynth.load(tmp_path / "d.tiles").n_tiles == 625


def test_objects_sizes_tiles_from_the_objects():
    ex = _discs(192, 9, 24, seed=14)  # discs ~18 px across: tiles of ~4 discs (72-80 px) instead of 48
    t = tilesynth.build_omega(ex, seed=1, recipe="objects", tileset="c3")
    rec = t.params["recipe"]
    assert (
        rec["name"] == "objects"
        and rec["applied"] == ["tile_size"]
        and rec["feature_scale"]["kind"] == "objects"
    )
    assert t.tile_size == rec["feature_scale"]["size"] and t.tile_size in (72, 80)
    sized = tilesynth.build_omega(ex, seed=1, tileset="c3", tile_size=t.tile_size)
    assert np.array_equal(t.tiles, sized.tiles)
    with pytest.warns(InputWarning, match=r"tiles of 48 px.*--tile-size (72|80).*\[objects-cut\]"):
        # the keyword wins, and the build says the objects ask for larger tiles (issue 29)
        kept = tilesynth.build_omega(ex, seed=1, recipe="objects", tileset="c3", tile_size=48)
    assert kept.tile_size == 48 and kept.params["recipe"]["applied"] == []


def test_objects_leaves_other_exemplars_as_the_default(crop):
    a = tilesynth.build_omega(crop, tileset="c3", seed=4)
    b = tilesynth.build_omega(crop, tileset="c3", seed=4, recipe="objects")
    assert np.array_equal(a.tiles, b.tiles) and b.params["recipe"]["applied"] == []


@pytest.mark.parametrize("bad", ["quick", "", 3, b"fast"])
def test_an_unknown_recipe_name_is_refused(crop, bad):
    with pytest.raises(ParameterError, match=r"recipe = .*named recipes 'default', 'fast', 'objects'"):
        tilesynth.build_omega(crop, recipe=bad)


def test_cli_recipe_is_recorded_and_shown(tmp_path, crop):
    from tilesynth.cli.main import main as cli

    src = tmp_path / "ex.png"
    tilesynth.save_image(src, crop)
    out = tmp_path / "a.tiles"
    assert cli(["build", str(src), "-o", str(out), "--seed", "1", "--recipe", "fast", "-q"]) == 0
    t = tilesynth.load(out)
    assert t.n_tiles == 256 and t.params["recipe"]["name"] == "fast"


def test_build_omega_orchestrates_named_stages_in_sixty_lines():
    """The build reads top-down: build_omega (signature and docstring included) only validates, resolves the
    recipe and calls the named stages; what grows belongs in a stage."""
    from tilesynth.builder import omega

    lines, _ = inspect.getsourcelines(omega.build_omega)
    assert len(lines) <= 60
    body = inspect.getsource(omega.build_omega)
    for stage in ("common_options(", "resolve(", "gene_stage(", "tiles_stage(", "finish_stage("):
        assert stage in body, stage
