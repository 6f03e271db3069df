"""Tests of the named ω-tile sets, the appendix properties and the completeness check."""

from __future__ import annotations

import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tilesynth.layouts.omega_sets import (
    PATCH_COLOURS,
    TILESET_NAMES,
    CornerTileSet,
    check_properties,
    choices_summary,
    dead_ends,
    forbidden_pairs,
    get_tileset,
    reachable_situations,
    tileset_from_dict,
)

# Figure 8 decoded in /work/shared/papers/INDEX.md, as ⟨TL, BL, TR, BR⟩ strings.
INDEX_16A = "BRYG BYRG BYYR BRRB YGRB YRGB YRRG YGGY RBGY RGBY RGGB RBBR GYBR GBYR GBBY GYYG".split()
INDEX_16B = "BYRG BRYG BRRB BYYB GYRB GRYB GRRG GYYG RBBY RGBR RGGY RBGR YBGY YGBY YGGR YBBR".split()

TL, BL, TR, BR = 0, 1, 2, 3


def _strings(ts: CornerTileSet) -> list[str]:
    return ["".join(t) for t in ts.tiles]


# --------------------------------------------------------------------------
# Brute force used to cross-check the exact reachability argument.
# --------------------------------------------------------------------------


def _brute_force_situations(tiles: list[tuple[str, ...]], rows: int, cols: int) -> dict[str, set[tuple]]:
    """Every situation met by every run of the scan-line tiler on a rows x cols grid.

    Written from the corner rule only.  Runs are merged by their frontier (the last
    ``cols`` placed tiles, which is all the future depends on), so the enumeration is
    exhaustive yet polynomial.  Situations are (required (TL, BL) | None, required
    (TL, TR) | None).
    """
    found: dict[str, set[tuple]] = {
        "first_tile": set(),
        "first_row": set(),
        "first_column": set(),
        "interior": set(),
    }
    frontiers: set[tuple[int, ...]] = {()}
    for i in range(rows):
        for j in range(cols):
            kind = (
                "first_tile"
                if i == 0 and j == 0
                else "first_row"
                if i == 0
                else "first_column"
                if j == 0
                else "interior"
            )
            nxt: set[tuple[int, ...]] = set()
            for fr in frontiers:
                left = tiles[fr[-1]] if j > 0 else None
                top = tiles[fr[-cols]] if i > 0 else None
                need_left = (left[TR], left[BR]) if left is not None else None
                need_top = (top[BL], top[BR]) if top is not None else None
                found[kind].add((need_left, need_top))
                for k, t in enumerate(tiles):
                    if left is not None and (t[TL] != left[TR] or t[BL] != left[BR]):
                        continue
                    if top is not None and (t[TL] != top[BL] or t[TR] != top[BR]):
                        continue
                    nxt.add((fr + (k,))[-cols:])
            frontiers = nxt
    return found


def _has_candidate(tiles: list[tuple[str, ...]], situation: tuple) -> bool:
    need_left, need_top = situation
    return any(
        (need_left is None or (t[TL], t[BL]) == need_left)
        and (need_top is None or (t[TL], t[TR]) == need_top)
        for t in tiles
    )


# --------------------------------------------------------------------------
# The 16-sets of Figure 8
# --------------------------------------------------------------------------


def test_16_sets_are_the_index_decoding_in_order() -> None:
    assert _strings(get_tileset("16a")) == INDEX_16A
    assert _strings(get_tileset("16b")) == INDEX_16B
    for name in ("16a", "16b"):
        ts = get_tileset(name)
        assert ts.colours == PATCH_COLOURS
        assert ts.variants == (0,) * 16
        assert len(set(ts.tiles)) == 16


@pytest.mark.parametrize("name", ["16a", "16b", "32"])
def test_16_sets_satisfy_all_four_properties(name: str) -> None:
    assert check_properties(get_tileset(name)) == {
        "property1": True,
        "property2": True,
        "property3": True,
        "property4": True,
    }


def test_forbidden_pairs_are_those_of_the_appendix() -> None:
    assert set(forbidden_pairs(get_tileset("16a"))) == {
        ("R", "Y"),
        ("G", "R"),
        ("B", "G"),
        ("Y", "B"),
    }
    assert set(forbidden_pairs(get_tileset("16b"))) == {
        ("R", "Y"),
        ("Y", "R"),
        ("B", "G"),
        ("G", "B"),
    }


def test_properties_detect_violations() -> None:
    ts16a = get_tileset("16a")
    # Property 1: a tile with equal colours on a side.
    bad1 = CornerTileSet("bad1", PATCH_COLOURS, ts16a.tiles + (("R", "R", "G", "B"),))
    assert check_properties(bad1)["property1"] is False
    # Removing every <R, G, -, -> tile adds the forbidden pair R↓G: R gets two
    # forbidden counterparts (Property 2) and (R, G) stays a right column (Property 3).
    keep = [k for k, t in enumerate(ts16a.tiles) if (t[TL], t[BL]) != ("R", "G")]
    props = check_properties(ts16a.subset(keep))
    assert props["property2"] is False
    assert props["property3"] is False
    # Property 4: <B, Y, Y, R> needs neither Y↓R nor Y↓R; forbid Y↓R.
    keep = [k for k, t in enumerate(ts16a.tiles) if (t[TL], t[BL]) != ("Y", "R")]
    assert check_properties(ts16a.subset(keep))["property4"] is False


# --------------------------------------------------------------------------
# The 4-, 8- and 32-sets
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["4", "8"])
def test_small_sets_satisfy_property_1(name: str) -> None:
    ts = get_tileset(name)
    assert check_properties(ts)["property1"] is True
    assert len(set(ts.tiles)) == len(ts) == int(name)
    assert set(c for t in ts.tiles for c in t) == set(PATCH_COLOURS)


def test_4_set_is_deterministic_after_the_first_tile() -> None:
    ts = get_tileset("4")
    # Every left key and every top key belongs to exactly one tile.
    assert len({ts.left_key(k) for k in range(4)}) == 4
    assert len({ts.top_key(k) for k in range(4)}) == 4
    summary = choices_summary(ts)
    assert summary["first_tile"] == (4, 4)
    assert summary["first_row"] == (1, 1)
    assert summary["first_column"] == (1, 1)
    assert summary["interior"] == (1, 1)


def test_8_set_has_a_choice_at_the_leftmost_column_only() -> None:
    ts = get_tileset("8")
    assert len(ts) == 8
    assert set(get_tileset("4").tiles) <= set(ts.tiles)
    summary = choices_summary(ts)
    assert summary["first_column"][0] >= 2
    # Otherwise the tiling is determined, as the paper describes.
    assert summary["first_row"] == (1, 1)
    assert summary["interior"] == (1, 1)


def test_32_set_is_16a_twice() -> None:
    ts32 = get_tileset("32")
    ts16a = get_tileset("16a")
    assert len(ts32) == 32
    assert ts32.tiles == ts16a.tiles + ts16a.tiles
    assert ts32.variants == (0,) * 16 + (1,) * 16
    assert ts32.distinct_tuples() == ts16a.tiles
    for k in range(16):
        assert ts32.tiles[k] == ts32.tiles[k + 16]
        assert ts32.variant(k) == 0 and ts32.variant(k + 16) == 1
    assert ts32.tile_label(0) != ts32.tile_label(16)


# --------------------------------------------------------------------------
# Completeness and choices
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", TILESET_NAMES)
def test_named_sets_have_no_dead_ends(name: str) -> None:
    assert dead_ends(get_tileset(name)) == []


@pytest.mark.parametrize("name", ["16a", "16b", "32"])
def test_16_and_32_sets_have_two_choices_on_the_top_row_and_left_column(name: str) -> None:
    summary = choices_summary(get_tileset(name))
    assert summary["first_row"][0] >= 2
    assert summary["first_column"][0] >= 2


def test_32_set_has_at_least_two_choices_everywhere() -> None:
    summary = choices_summary(get_tileset("32"))
    assert all(lo >= 2 for lo, _hi in summary.values())


@pytest.mark.parametrize("removed", range(16))
def test_16a_minus_one_tile_has_a_dead_end(removed: int) -> None:
    ts = get_tileset("16a")
    broken = ts.subset([k for k in range(16) if k != removed], name="broken")
    found = dead_ends(broken)
    assert found, "the completeness check must be able to fail"
    assert choices_summary(broken)["interior"][0] == 0
    for de in found:
        assert de.kind in ("first_tile", "first_row", "first_column", "interior")
        assert "no tile" in str(de)
        # The witness really produces this situation.
        if de.left_tile is not None:
            assert broken.right_key(de.left_tile) == de.left_key
        if de.top_tile is not None:
            assert broken.bottom_key(de.top_tile) == de.top_key
        if de.diagonal_tile is not None:
            assert broken.top_key(de.left_tile) == broken.bottom_key(de.diagonal_tile)
            assert broken.left_key(de.top_tile) == broken.right_key(de.diagonal_tile)


def test_dead_end_in_the_first_row_is_reported() -> None:
    ts = CornerTileSet("one", PATCH_COLOURS, (("R", "G", "B", "Y"),))
    # A lone tile fits neither right of nor below itself, so the interior is never
    # reached: the dead ends are at (0, 1) and (1, 0).
    kinds = {de.kind for de in dead_ends(ts)}
    assert kinds == {"first_row", "first_column"}


@pytest.mark.parametrize("name", TILESET_NAMES)
def test_reachable_situations_match_brute_force(name: str) -> None:
    """The exact characterisation equals an exhaustive enumeration of tiler runs."""
    ts = get_tileset(name)
    tiles = list(ts.tiles)
    expected = {kind: set(sits) for kind, sits in reachable_situations(ts).items()}
    for rows, cols in [(2, 2), (3, 3), (4, 3), (3, 4)]:
        assert _brute_force_situations(tiles, rows, cols) == expected


@st.composite
def _random_corner_sets(draw: st.DrawFn) -> list[tuple[str, ...]]:
    colours = "RGB"
    corner = st.sampled_from(colours)
    return draw(st.lists(st.tuples(corner, corner, corner, corner), min_size=1, max_size=7))


def _brute_force_union(tiles: list[tuple[str, ...]], max_size: int) -> dict[str, set[tuple]]:
    """Union of :func:`_brute_force_situations` over all grids up to max_size^2."""
    union: dict[str, set[tuple]] = {}
    for rows in range(1, max_size + 1):
        for cols in range(1, max_size + 1):
            for kind, sits in _brute_force_situations(tiles, rows, cols).items():
                union.setdefault(kind, set()).update(sits)
    return union


@settings(max_examples=150, deadline=None)
@given(_random_corner_sets())
def test_exact_search_agrees_with_brute_force_on_random_sets(
    tiles: list[tuple[str, ...]],
) -> None:
    """On arbitrary (often incomplete) sets the reachable situations and the dead ends
    equal those met by some run of the tiler on some grid of up to 4x4 tiles."""
    ts = CornerTileSet("random", ("R", "G", "B"), tuple(tiles))
    exact = {kind: set(sits) for kind, sits in reachable_situations(ts).items()}
    brute = _brute_force_union(list(ts.tiles), 4)
    assert brute == exact
    brute_dead = {(kind, s) for kind, sits in brute.items() for s in sits if not _has_candidate(tiles, s)}
    exact_dead = {(de.kind, (de.left_key, de.top_key)) for de in dead_ends(ts)}
    assert brute_dead == exact_dead


@st.composite
def _perturbed_named_sets(draw: st.DrawFn) -> list[tuple[str, ...]]:
    """A named set with a few tiles removed and possibly one random tile added:
    structured sets that are complete or only narrowly incomplete."""
    tiles = list(get_tileset(draw(st.sampled_from(TILESET_NAMES))).tiles)
    for _ in range(draw(st.integers(0, 2))):
        if len(tiles) > 1:
            tiles.pop(draw(st.integers(0, len(tiles) - 1)))
    if draw(st.booleans()):
        corner = st.sampled_from(PATCH_COLOURS)
        tiles.append(draw(st.tuples(corner, corner, corner, corner)))
    return tiles


@settings(max_examples=60, deadline=None)
@given(_perturbed_named_sets())
def test_exact_search_agrees_with_brute_force_on_perturbed_named_sets(
    tiles: list[tuple[str, ...]],
) -> None:
    ts = CornerTileSet("perturbed", PATCH_COLOURS, tuple(tiles))
    exact = {kind: set(sits) for kind, sits in reachable_situations(ts).items()}
    brute = _brute_force_union(list(ts.tiles), 3)
    assert brute == exact
    brute_dead = {(kind, s) for kind, sits in brute.items() for s in sits if not _has_candidate(tiles, s)}
    assert brute_dead == {(de.kind, (de.left_key, de.top_key)) for de in dead_ends(ts)}


# --------------------------------------------------------------------------
# Serialisation and lookup
# --------------------------------------------------------------------------


@pytest.mark.parametrize("name", TILESET_NAMES)
def test_to_dict_from_dict_round_trip(name: str) -> None:
    ts = get_tileset(name)
    data = json.loads(json.dumps(ts.to_dict()))
    assert data["kind"] == "corner"
    back = CornerTileSet.from_dict(data)
    assert back == ts
    assert tileset_from_dict(data) == ts
    assert hash(back) == hash(ts)


def test_from_dict_rejects_bad_input() -> None:
    good = get_tileset("16a").to_dict()
    with pytest.raises(ValueError, match="kind"):
        CornerTileSet.from_dict({**good, "kind": "edge"})
    with pytest.raises(ValueError, match="tiles"):
        CornerTileSet.from_dict({k: v for k, v in good.items() if k != "tiles"})
    with pytest.raises(ValueError, match="colour"):
        CornerTileSet.from_dict({**good, "tiles": [["R", "G", "B", "Q"]], "variants": [0]})
    with pytest.raises(ValueError, match="four corners"):
        CornerTileSet.from_dict({**good, "tiles": [["R", "G", "B"]], "variants": [0]})
    with pytest.raises(ValueError, match="variants"):
        CornerTileSet.from_dict({**good, "variants": [0, 1]})
    with pytest.raises(ValueError, match="unknown tile set kind"):
        tileset_from_dict({"kind": "hexagon"})


def test_side_keys_of_corner_tiles() -> None:
    ts = CornerTileSet("x", PATCH_COLOURS, (("B", "R", "Y", "G"),))
    assert ts.left_key(0) == ("B", "R")
    assert ts.right_key(0) == ("Y", "G")
    assert ts.top_key(0) == ("B", "Y")
    assert ts.bottom_key(0) == ("R", "G")
    assert ts.corner_indices().tolist() == [[2, 0, 3, 1]]


def test_unknown_name_lists_valid_names() -> None:
    with pytest.raises(ValueError) as info:
        get_tileset("17")
    message = str(info.value)
    assert "'17'" in message
    for name in TILESET_NAMES:
        assert name in message
