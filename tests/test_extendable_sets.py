"""Tests of the extendable rule: the basic 8-set B, N1, N2 and Nk (papers 000 / 003 §3)."""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterable, Sequence

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from tilesynth.layouts.extendable import _complete_supersets
from tilesynth.layouts.omega_sets import (
    BASIC_SET_NAME,
    EXTENDABLE_TILESET_NAMES,
    PATCH_COLOURS,
    TILESET_NAMES,
    BasicSetCandidate,
    CornerTileSet,
    candidate_basic_sets,
    check_properties,
    choices_summary,
    choose_basic_set,
    dead_ends,
    extend_tileset,
    extendable_tileset,
    extension_step,
    get_tileset,
    reachable_situations,
    tileset_from_dict,
)
from tilesynth.layouts.scanline import scanline_index_map, validate_index_map

TL, BL, TR, BR = 0, 1, 2, 3

#: The chosen basic set, written out independently of the module.
EXPECTED_B = "BYYR GBBY RBBY RGGB RRYG YGGB YGRB YRRB".split()

Tile = tuple[str, ...]


def _strings(ts: CornerTileSet) -> list[str]:
    return ["".join(t) for t in ts.tiles]


def _corner_mismatches(tiles: Sequence[Tile], index_map: np.ndarray) -> list:
    """Neighbouring pairs that do not share their corners, from the corner rule only."""
    rows, cols = index_map.shape
    bad = []
    for i in range(rows):
        for j in range(cols):
            a = tiles[index_map[i, j]]
            if j + 1 < cols:
                x = tiles[index_map[i, j + 1]]
                if x[TL] != a[TR] or x[BL] != a[BR]:
                    bad.append(((i, j), (i, j + 1)))
            if i + 1 < rows:
                x = tiles[index_map[i + 1, j]]
                if x[TL] != a[BL] or x[TR] != a[BR]:
                    bad.append(((i, j), (i + 1, j)))
    return bad


def _brute_force_situations(tiles: Sequence[Tile], rows: int, cols: int) -> dict[str, set]:
    """Every (required (TL, BL) | None, required (TL, TR) | None) met by any run of the
    scan-line tiler on a rows x cols grid, by exhaustive enumeration over frontiers."""
    found: dict[str, set] = {k: set() for k in ("first_tile", "first_row", "first_column", "interior")}
    frontiers: set[tuple[int, ...]] = {()}
    for i in range(rows):
        for j in range(cols):
            kind = (
                "first_tile"
                if i == j == 0
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
                    if need_left is not None and (t[TL], t[BL]) != need_left:
                        continue
                    if need_top is not None and (t[TL], t[TR]) != need_top:
                        continue
                    nxt.add((fr + (k,))[-cols:])
            frontiers = nxt
    return found


def _paper_rule(tiles: Iterable[Tile], reference: str, new: str) -> list[Tile]:
    """The rule exactly as worded in the paper (tiles with at most two reference
    corners): all-replaced copies, plus single replacements for tiles with two."""
    tiles = list(tiles)
    out = list(tiles)
    for t in tiles:
        m = t.count(reference)
        assert m <= 2, "the paper's wording covers at most two reference corners"
        if m:
            out.append(tuple(new if c == reference else c for c in t))
        if m == 2:
            for p in (i for i, c in enumerate(t) if c == reference):
                out.append(tuple(new if i == p else c for i, c in enumerate(t)))
    return out


def _full_preimage(base: Iterable[Tile], colours: Sequence[str], projection: dict[str, str]) -> set[Tile]:
    """All tiles over ``colours`` whose corner-wise projection lies in ``base``."""
    base_set = set(base)
    return {
        t for t in itertools.product(colours, repeat=4) if tuple(projection.get(c, c) for c in t) in base_set
    }


# --------------------------------------------------------------------------
# The basic set B
# --------------------------------------------------------------------------


def test_basic_set_is_the_documented_one() -> None:
    b = get_tileset(BASIC_SET_NAME)
    assert BASIC_SET_NAME == "B"
    assert b.name == "B"
    assert _strings(b) == EXPECTED_B
    assert b.colours == PATCH_COLOURS
    assert b.variants == (0,) * 8
    assert len(set(b.tiles)) == 8
    assert extendable_tileset(0) is b


def test_basic_set_has_the_tiles_the_text_fixes() -> None:
    tiles = _strings(get_tileset("B"))
    assert "BYYR" in tiles and "RGGB" in tiles
    assert [t for t in tiles if t.count("Y") >= 2] == ["BYYR"]
    assert [t for t in tiles if "Y" not in t] == ["RGGB"]
    assert all(t.count("Y") == 1 for t in tiles if t not in ("BYYR", "RGGB"))
    assert set("".join(tiles)) == set(PATCH_COLOURS)


def test_basic_set_is_complete_with_a_choice_at_the_leftmost_column() -> None:
    b = get_tileset("B")
    assert dead_ends(b) == []
    summary = choices_summary(b)
    assert summary["first_column"][1] >= 2
    assert summary == {
        "first_tile": (8, 8),
        "first_row": (1, 2),
        "first_column": (1, 2),
        "interior": (1, 1),
    }
    # Property 1 cannot hold for any candidate; B violates it once (<R,R,Y,G>).
    assert check_properties(b)["property1"] is False
    offenders = [
        t for t in _strings(b) if t[TL] == t[BL] or t[TL] == t[TR] or t[BL] == t[BR] or t[TR] == t[BR]
    ]
    assert offenders == ["RRYG"]


def test_basic_set_reachable_situations_match_brute_force() -> None:
    b = get_tileset("B")
    expected = {kind: set(s) for kind, s in reachable_situations(b).items()}
    for rows, cols in [(2, 2), (3, 3), (4, 3), (3, 4)]:
        assert _brute_force_situations(b.tiles, rows, cols) == expected


# --------------------------------------------------------------------------
# Reproducible derivation of B
# --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def candidates() -> tuple[BasicSetCandidate, ...]:
    """The re-run derivation (about a second), shared by the tests below."""
    return candidate_basic_sets()


def test_derivation_finds_b_among_the_candidates(candidates: tuple[BasicSetCandidate, ...]) -> None:
    labels = [c.label() for c in candidates]
    assert " ".join(EXPECTED_B) in labels
    assert len(candidates) == 28
    assert labels == sorted(labels)
    chosen = choose_basic_set(candidates)
    assert [("".join(t)) for t in chosen.tiles] == EXPECTED_B
    assert chosen.tileset("B") == get_tileset("B")


def test_every_candidate_meets_the_text(candidates: tuple[BasicSetCandidate, ...]) -> None:
    for cand in candidates:
        ts = cand.tileset()
        tiles = [("".join(t)) for t in cand.tiles]
        assert len(set(tiles)) == 8
        assert "BYYR" in tiles and "RGGB" in tiles
        assert sorted(t.count("Y") for t in tiles) == [0, 1, 1, 1, 1, 1, 1, 2]
        assert dead_ends(ts) == []
        n1 = _paper_rule(cand.tiles, "Y", "C")
        n2 = _paper_rule(n1, "R", "M")
        assert (len(n1), len(n2)) == (17, 38)
        # N2 is complete for every candidate, as INDEX.md reports.
        n2_set = CornerTileSet("n2", PATCH_COLOURS + ("C", "M"), tuple(n2))
        assert dead_ends(n2_set) == []
        # INDEX.md: no candidate satisfies Property 1.
        assert check_properties(ts)["property1"] is False
        # The paper's Figure 3 argument holds for all of them.
        assert cand.extras_necessary


def test_criterion_filters_and_ranking(candidates: tuple[BasicSetCandidate, ...]) -> None:
    eligible = [c for c in candidates if c.leftmost_choice and c.extras_necessary]
    assert len(eligible) == 6
    best_p1 = min(c.property1_violations for c in eligible)
    assert best_p1 == 1
    top = [c for c in eligible if c.property1_violations == best_p1]
    most = max(c.square_tilings for c in top)
    winners = sorted(c.label() for c in top if c.square_tilings == most)
    assert winners[0] == " ".join(EXPECTED_B)
    # The tie is between B and its mirror image under <TL,BL,TR,BR> -> <TL,TR,BL,BR>.
    mirror = sorted("".join((t[TL], t[TR], t[BL], t[BR])) for t in EXPECTED_B)
    assert winners == sorted([" ".join(EXPECTED_B), " ".join(mirror)])
    # Ranking by choices first gives the same winner.
    most_overall = max(c.square_tilings for c in eligible)
    assert most_overall == most
    with pytest.raises(ValueError, match="no candidate"):
        choose_basic_set([c for c in candidates if not c.leftmost_choice])


def test_property_1_and_n2_38_exclude_each_other() -> None:
    """INDEX.md: among complete sets of B's shape, those with Property 1 reach at most
    |N2| = 36, so B cannot satisfy Property 1."""
    pool = [
        t
        for t in itertools.product(PATCH_COLOURS, repeat=4)
        if t.count("Y") == 1 and t != ("R", "G", "G", "B")
    ]
    complete = _complete_supersets([("B", "Y", "Y", "R"), ("R", "G", "G", "B")], pool, 8)
    sizes_p1 = set()
    for s in complete:
        ts = CornerTileSet("c", PATCH_COLOURS, tuple(sorted(s)))
        if check_properties(ts)["property1"]:
            sizes_p1.add(len(_paper_rule(_paper_rule(ts.tiles, "Y", "C"), "R", "M")))
    assert max(sizes_p1) == 36


def test_superset_search_is_exhaustive_on_a_small_instance() -> None:
    """The requirement-driven search equals plain enumeration of all subsets."""
    pool = list(itertools.product("RG", repeat=4))
    seed = ("R", "G", "G", "R")
    rest = [t for t in pool if t != seed]
    for size in range(1, 7):
        brute = set()
        for extra in itertools.combinations(rest, size - 1):
            tiles = (seed,) + extra
            if not dead_ends(CornerTileSet("s", ("R", "G"), tiles)):
                brute.add(frozenset(tiles))
        assert _complete_supersets([seed], rest, size) == brute, size


# --------------------------------------------------------------------------
# N1 and N2
# --------------------------------------------------------------------------


def test_n1_follows_the_rule() -> None:
    b, n1 = get_tileset("B"), get_tileset("n1")
    assert n1.name == "n1"
    assert len(n1) == 17
    assert n1.colours == ("R", "G", "B", "Y", "C")
    assert {c for t in n1.tiles for c in t} == set(n1.colours)
    # N1 contains B as its first tiles, then the 7 copies, then the 2 extras.
    assert n1.tiles[:8] == b.tiles
    assert set(b.tiles) < set(n1.tiles)
    copies = [tuple("C" if c == "Y" else c for c in t) for t in b.tiles if "Y" in t]
    assert list(n1.tiles[8:15]) == copies
    assert _strings(n1)[15:] == ["BCYR", "BYCR"]
    assert sorted(n1.tiles) == sorted(_paper_rule(b.tiles, "Y", "C"))
    assert len(set(n1.tiles)) == 17


def test_n2_follows_the_rule() -> None:
    n1, n2 = get_tileset("n1"), get_tileset("n2")
    assert n2.name == "n2"
    assert len(n2) == 38
    assert n2.colours == ("R", "G", "B", "Y", "C", "M")
    assert {c for t in n2.tiles for c in t} == set(n2.colours)
    assert n2.tiles[:17] == n1.tiles
    assert set(n1.tiles) < set(n2.tiles)
    with_r = [t for t in n1.tiles if "R" in t]
    with_rr = [t for t in n1.tiles if t.count("R") == 2]
    assert 17 + len(with_r) + 2 * len(with_rr) == 38
    assert sorted(n2.tiles) == sorted(_paper_rule(n1.tiles, "R", "M"))
    assert len(set(n2.tiles)) == 38


def test_the_copies_without_the_extras_are_a_renamed_basic_set() -> None:
    """000 §3.2: the new tiles without the two additional ones, plus <R,G,G,B>, are a
    copy of B (Y renamed C) and tile any area on their own."""
    n1 = get_tileset("n1")
    copy = n1.subset([3] + list(range(8, 15)), name="copy")
    renamed = sorted(tuple("Y" if c == "C" else c for c in t) for t in copy.tiles)
    assert renamed == sorted(get_tileset("B").tiles)
    assert dead_ends(copy) == []


@pytest.mark.parametrize("dropped", ["BCYR", "BYCR"])
def test_dropping_an_extra_tile_of_n1_creates_a_dead_end(dropped: str) -> None:
    """The paper's Figure 3: without either additional tile, some place needs a Y
    and a C corner at the same time and no tile fits."""
    n1 = get_tileset("n1")
    keep = [k for k, t in enumerate(_strings(n1)) if t != dropped]
    assert len(keep) == 16
    broken = n1.subset(keep, name="broken")
    found = dead_ends(broken)
    assert found
    for de in found:
        assert de.kind == "interior"
        need = set(de.left_key) | set(de.top_key)
        assert {"Y", "C"} <= need
        # The missing tile is exactly the dropped one (its TL, BL, TR).
        assert (de.left_key[0], de.left_key[1], de.top_key[1]) == tuple(dropped[:3])
        # The witness realises the situation.
        assert broken.right_key(de.left_tile) == de.left_key
        assert broken.bottom_key(de.top_tile) == de.top_key
        assert broken.top_key(de.left_tile) == broken.bottom_key(de.diagonal_tile)
        assert broken.left_key(de.top_tile) == broken.right_key(de.diagonal_tile)
    # And the tiler really gets stuck on some 64x64 run.
    with pytest.raises(RuntimeError, match="dead end"):
        for seed in range(200):
            scanline_index_map(broken, 64, 64, seed)


def test_dropping_both_extras_of_n1_creates_a_dead_end() -> None:
    n1 = get_tileset("n1")
    assert dead_ends(n1.subset(range(15)))


# --------------------------------------------------------------------------
# Nk
# --------------------------------------------------------------------------


def test_extension_steps() -> None:
    steps = [extension_step(k) for k in range(1, 9)]
    assert steps == [
        ("Y", "C"),
        ("R", "M"),
        ("G", "P3"),
        ("B", "P4"),
        ("Y", "P5"),
        ("R", "P6"),
        ("G", "P7"),
        ("B", "P8"),
    ]
    assert extension_step(np.int64(3)) == ("G", "P3")
    for bad in (0, -1, 1.5, True, "1"):
        with pytest.raises(ValueError, match="extension step"):
            extension_step(bad)  # type: ignore[arg-type]
    for bad in (-1, 2.0, False):
        with pytest.raises(ValueError, match="extension steps"):
            extendable_tileset(bad)  # type: ignore[arg-type]


def test_nk_chain_sizes_and_colours() -> None:
    sizes = {1: 17, 2: 38, 3: 64, 4: 128, 5: 196, 6: 306, 8: 648}
    prev = get_tileset("B")
    for k in range(1, 9):
        nk = get_tileset(f"n{k}")
        assert nk is extendable_tileset(k)
        assert nk.name == f"n{k}"
        reference, new = extension_step(k)
        assert nk.colours == prev.colours + (new,)
        assert len(nk.colours) == 4 + k
        assert nk.tiles[: len(prev)] == prev.tiles
        assert len(set(nk.tiles)) == len(nk)
        if k in sizes:
            assert len(nk) == sizes[k]
        # Nk is every lift of N(k-1): all tiles projecting into it.
        if k <= 4:
            assert set(nk.tiles) == _full_preimage(prev.tiles, nk.colours, {new: reference})
        prev = nk
    # After every original colour is split c + 1 ways: 8 (c + 1)^4 tiles.
    assert len(get_tileset("n4")) == 8 * 2**4 and len(get_tileset("n8")) == 8 * 3**4


@pytest.mark.parametrize("name", ["B", "n1", "n2", "n3", "n4", "n5", "n6"])
def test_extended_sets_are_complete(name: str) -> None:
    ts = get_tileset(name)
    assert dead_ends(ts) == []
    summary = choices_summary(ts)
    base = choices_summary(get_tileset("B"))
    for kind, (lo, _hi) in summary.items():
        assert lo >= base[kind][0] >= 1


def test_choices_summaries() -> None:
    assert choices_summary(get_tileset("n1")) == {
        "first_tile": (17, 17),
        "first_row": (1, 2),
        "first_column": (1, 2),
        "interior": (1, 2),
    }
    assert choices_summary(get_tileset("n2")) == {
        "first_tile": (38, 38),
        "first_row": (2, 4),
        "first_column": (1, 4),
        "interior": (1, 2),
    }
    assert choices_summary(get_tileset("n4")) == {
        "first_tile": (128, 128),
        "first_row": (4, 8),
        "first_column": (4, 8),
        "interior": (2, 2),
    }


@pytest.mark.parametrize("name", ["n1", "n2"])
def test_extended_reachable_situations_match_brute_force(name: str) -> None:
    ts = get_tileset(name)
    expected = {kind: set(s) for kind, s in reachable_situations(ts).items()}
    for rows, cols in [(2, 2), (3, 3)]:
        assert _brute_force_situations(ts.tiles, rows, cols) == expected


@pytest.mark.parametrize("name", EXTENDABLE_TILESET_NAMES)
@settings(max_examples=15, deadline=None)
@given(rows=st.integers(1, 64), cols=st.integers(1, 64), seed=st.integers(0, 2**63 - 1))
@example(rows=64, cols=64, seed=0)
@example(rows=1, cols=64, seed=1)
@example(rows=64, cols=1, seed=2)
def test_random_tilings_are_valid(name: str, rows: int, cols: int, seed: int) -> None:
    ts = get_tileset(name)
    m = scanline_index_map(ts, rows, cols, seed)
    assert m.shape == (rows, cols)
    assert m.min() >= 0 and m.max() < len(ts)
    assert _corner_mismatches(ts.tiles, m) == []
    assert validate_index_map(ts, m) is None


def test_large_tilings_use_the_new_patches() -> None:
    for name in ("n1", "n2", "n3"):
        ts = get_tileset(name)
        m = scanline_index_map(ts, 64, 64, seed=7)
        used = {c for k in np.unique(m) for c in ts.tiles[k]}
        assert used == set(ts.colours)


@settings(max_examples=30, deadline=None)
@given(
    name=st.sampled_from(TILESET_NAMES + ("B",)),
    references=st.lists(st.sampled_from(PATCH_COLOURS), min_size=1, max_size=3),
)
def test_extending_any_complete_set_keeps_it_complete(name: str, references: list[str]) -> None:
    """The general rule (every non-empty subset of reference corners) preserves
    completeness and never reduces the number of choices, for any reference."""
    ts = get_tileset(name)
    base = choices_summary(ts)
    for step, ref in enumerate(references):
        new = f"X{step}"
        nxt = extend_tileset(ts, ref, new)
        assert nxt.tiles[: len(ts)] == ts.tiles
        assert nxt.variants[: len(ts)] == ts.variants
        assert dead_ends(nxt) == []
        assert set(nxt.tiles) == _full_preimage(ts.tiles, nxt.colours, {new: ref})
        ts = nxt
    for kind, (lo, _hi) in choices_summary(ts).items():
        assert lo >= base[kind][0]


def test_tiles_with_three_reference_corners_get_every_lift() -> None:
    ts = CornerTileSet("t", ("R", "G"), (("R", "R", "R", "G"),))
    ext = extend_tileset(ts, "R", "M", name="e")
    assert ext.name == "e"
    assert len(ext) == 8
    assert _strings(ext) == ["RRRG", "MMMG", "MRRG", "RMRG", "RRMG", "MMRG", "MRMG", "RMMG"]


def test_variants_are_kept_by_the_rule() -> None:
    ts32 = get_tileset("32")
    ext = extend_tileset(ts32, "Y", "C")
    assert ext.name == "32+C"
    assert dead_ends(ext) == []
    for t, v in zip(ext.tiles[32:], ext.variants[32:]):
        source = tuple("Y" if c == "C" else c for c in t)
        assert v in {ts32.variant(k) for k in range(32) if ts32.tiles[k] == source}
    assert ext.variants.count(1) == ext.variants.count(0)


def test_extend_rejects_bad_colours() -> None:
    b = get_tileset("B")
    with pytest.raises(ValueError, match="reference colour"):
        extend_tileset(b, "C", "M")
    with pytest.raises(ValueError, match="already"):
        extend_tileset(b, "Y", "R")
    with pytest.raises(ValueError, match="non-empty"):
        extend_tileset(b, "Y", "")


# --------------------------------------------------------------------------
# Names and serialisation
# --------------------------------------------------------------------------


def test_names() -> None:
    assert EXTENDABLE_TILESET_NAMES == ("B", "n1", "n2", "n3", "n4")
    assert not set(EXTENDABLE_TILESET_NAMES) & set(TILESET_NAMES)
    assert get_tileset("n12").name == "n12"
    for bad in ("n0", "n01", "N1", "b8", "b", "n", "n-1", "n1.0", " n1", "nx"):
        with pytest.raises(ValueError) as info:
            get_tileset(bad)
        message = str(info.value)
        assert repr(bad) in message
        for name in TILESET_NAMES + EXTENDABLE_TILESET_NAMES:
            assert name in message
        assert "n<K>" in message


@pytest.mark.parametrize("name", list(EXTENDABLE_TILESET_NAMES) + ["n6"])
def test_to_dict_from_dict_round_trip(name: str) -> None:
    ts = get_tileset(name)
    data = json.loads(json.dumps(ts.to_dict()))
    assert data["colours"] == list(ts.colours)
    back = CornerTileSet.from_dict(data)
    assert back == ts
    assert tileset_from_dict(data) == ts
    assert hash(back) == hash(ts)
    assert back.tile_label(len(ts) - 1).startswith("<")


def test_multi_letter_colours_work_end_to_end() -> None:
    n3 = get_tileset("n3")
    assert "P3" in n3.colours
    k = next(i for i, t in enumerate(n3.tiles) if "P3" in t)
    assert "P3" in n3.tile_label(k)
    idx = n3.corner_indices()
    assert idx.shape == (len(n3), 4)
    assert [n3.colours[i] for i in idx[k]] == list(n3.tiles[k])
