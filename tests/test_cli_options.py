"""The value rules of every command-line option (:mod:`tilesynth.cli.argtypes`), checked over every subcommand's parser.

Properties over all parsers rather than one option at a time: every option that takes a value has a checking
type (no bare ``int``/``float``, which take other scripts' digits, underscores, ``nan``); every integer, size and
pair type refuses non-ASCII digits and underscores and accepts ASCII integers in its range; an out-of-range
value names the option, the value and the range.
"""

from __future__ import annotations

import argparse
import contextlib
import io
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tilesynth.cli import argtypes
from tilesynth.cli.main import build_parser, main


def _subparsers(p: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for a in p._actions:
        if isinstance(a, argparse._SubParsersAction):
            return dict(a.choices)
    raise AssertionError("no subcommands")


def _valued_actions() -> list[tuple[str, argparse.Action]]:
    out = []
    for cmd, sp in _subparsers(build_parser()).items():
        for a in sp._actions:
            if a.option_strings and a.nargs != 0 and not isinstance(a, argparse._HelpAction):
                out.append((cmd, a))
    return out


ACTIONS = _valued_actions()


def _flag(a: argparse.Action) -> str:
    return max(a.option_strings, key=len)


def _kind(a: argparse.Action) -> str | None:
    """What a value-taking option parses: int, pair, float, normal-y, or None (free text / choices of words)."""
    t = a.type
    if t is None:
        return None
    name = getattr(t, "__name__", "")
    if t in (argtypes.size_text, argtypes.pair_text, argtypes.origin_text):
        return "pair"
    if t is argtypes.normal_y_text:
        return "normal-y"
    if name.startswith("int_") or name in ("nonneg_int_text", "positive_int_text"):
        return "int"
    if name == "float":
        return "float"
    return "other"


def test_every_numeric_option_uses_a_checking_type():
    bare = [(cmd, _flag(a)) for cmd, a in ACTIONS if a.type in (int, float)]
    assert not bare, f"options parsed with Python's int/float (take '٣٢', '1_0', 'nan'): {bare}"
    # the options the brief names are all covered
    kinds = {(cmd, _flag(a)): _kind(a) for cmd, a in ACTIONS}
    for key in [
        ("build", "--tile-size"),
        ("build", "--seed"),
        ("build", "--threads"),
        ("synth", "--size"),
        ("synth", "--bits"),
        ("export", "--padding"),
        ("export", "--seed"),
        ("sheet", "--png-compression"),
    ]:
        assert key in kinds, key
    assert kinds[("synth", "--size")] == "pair" and kinds[("build", "--tile-size")] == "int"


NON_ASCII_DIGITS = ["٣٢", "３２", "۳۲", "३२", "𝟑𝟐", "3٢"]


@pytest.mark.parametrize("cmd,action", ACTIONS, ids=[f"{c} {_flag(a)}" for c, a in ACTIONS])
def test_numeric_options_refuse_other_scripts_digits_and_underscores(cmd: str, action: argparse.Action):
    kind = _kind(action)
    if kind not in ("int", "pair", "float"):
        return
    bad = NON_ASCII_DIGITS + ["1_0", "", " ", "0x10", "1e3" if kind != "float" else "1e", "nan", "inf"]
    if kind == "pair":
        bad += [f"{d}x{d}" for d in NON_ASCII_DIGITS] + ["32x", "x32", "3_2x32"]
    for text in bad:
        with pytest.raises(argparse.ArgumentTypeError):
            action.type(text)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_integer_options_accept_exactly_ascii_integers_in_their_range(data):
    ints = [(cmd, a) for cmd, a in ACTIONS if _kind(a) == "int"]
    cmd, a = data.draw(st.sampled_from(ints), label="option")
    lo, hi = getattr(a.type, "lo", None), getattr(a.type, "hi", None)
    if a.type in (argtypes.int_text,):  # pragma: no cover - the factory itself is never an option's type
        return
    if getattr(a.type, "__name__", "") == "nonneg_int_text":
        lo = 0
    elif getattr(a.type, "__name__", "") == "positive_int_text":
        lo = 1
    v = data.draw(st.integers(-(2**40), 2**70), label="value")
    text = data.draw(st.sampled_from([str(v), f" {v} ", f"+{v}" if v >= 0 else str(v)]), label="text")
    inside = (lo is None or v >= lo) and (hi is None or v <= hi)
    if inside:
        assert a.type(text) == v
    else:
        with pytest.raises(argparse.ArgumentTypeError, match=rf"{v} is out of range: expected an integer"):
            a.type(text)
    # any Unicode decimal digit that is not ASCII makes the text refused
    d = data.draw(st.characters(categories=["Nd"]).filter(lambda c: not c.isascii()), label="digit")
    with pytest.raises(argparse.ArgumentTypeError):
        a.type(str(abs(v))[:-1] + d)


@settings(max_examples=100, deadline=None)
@given(st.text(st.characters(categories=["Nd", "Zs", "Pd", "Lu", "Ll"]), max_size=6))
def test_int_and_size_rules_agree_with_the_ascii_grammar(text: str):
    import re

    ascii_int = re.fullmatch(r"\s*\+?[0-9]+\s*", text) is not None
    try:
        argtypes.parse_int(text, 0)
        accepted = True
    except argparse.ArgumentTypeError:
        accepted = False
    assert accepted == ascii_int
    ascii_size = re.fullmatch(r"\s*[0-9]+\s*(?:[xX]\s*[0-9]+\s*)?", text) is not None
    try:
        w, h = argtypes.size_text(text)
        assert w >= 1 and h >= 1 and ascii_size
    except argparse.ArgumentTypeError:
        assert not ascii_size or "0" in text


def _cli(*argv: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(list(argv))
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize(
    "argv,flag,value,rng",
    [
        (["build", "x.png", "-o", "y.tiles", "--tile-size", "-4"], "--tile-size", "-4", ">= 4"),
        (["build", "x.png", "-o", "y.tiles", "--tile-size=2"], "--tile-size", "2", ">= 4"),
        (["build", "x.png", "-o", "y.tiles", "--threads", "5000"], "--threads", "5000", "in [1, 1024]"),
        (["build", "x.png", "-o", "y.tiles", "--seed", "-1"], "--seed", "-1", ">= 0"),
        (
            ["synth", "x.tiles", "-o", "y.png", "--size", "8", "--threads", "0"],
            "--threads",
            "0",
            "in [1, 1024]",
        ),
        (["export", "x.tiles", "-o", "d", "--padding", "300"], "--padding", "300", "in [0, 256]"),
        (
            ["export", "x.tiles", "-o", "d", "--seed", "4294967296"],
            "--seed",
            "4294967296",
            "in [0, 4294967295]",
        ),
        (["metrics", "x.png", "--patch", "0"], "--patch", "0", ">= 1"),
        (["batch", "b.toml", "--workers", "0"], "--workers", "0", ">= 1"),
    ],
)
def test_out_of_range_values_name_the_option_the_value_and_the_range(
    argv, flag, value, rng, tmp_path, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    code, _, err = _cli(*argv)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert flag in err and value in err and rng in err, err


@pytest.mark.parametrize(
    "argv",
    [
        ["synth", "x.tiles", "-o", "y.png", "--size", "٣٢"],
        ["synth", "x.tiles", "-o", "y.png", "--size", "３２x３２"],
        ["build", "x.png", "-o", "y.tiles", "--seed", "1_000"],
        ["build", "x.png", "-o", "y.tiles", "--tile-size", "٣٢"],
        ["synth", "x.tiles", "-o", "y.png", "--size", "8", "--bits", "١٦"],
        ["synth", "x.tiles", "-o", "y.png", "--size", "8", "--origin", "٣,4"],
        ["export", "x.tiles", "-o", "d", "--wrap", "٤x4"],
        ["export", "x.tiles", "-o", "d", "--padding", "٨"],
        ["build", "x.png", "-o", "y.tiles", "--cut-region", "free", "--cut-bias", "nan"],
    ],
)
def test_non_ascii_digits_are_a_usage_error(argv, tmp_path, monkeypatch):
    """``--size ٣٢`` used to write a 32x32 texture; every numeric option refuses it before any work."""
    monkeypatch.chdir(tmp_path)
    Path("x.tiles").write_bytes(b"")  # never opened: the parser refuses first
    code, _, err = _cli(*argv)
    assert code == 2 and "expected" in err, err
    assert not Path("y.png").exists() and not Path("y.tiles").exists()


@pytest.fixture(scope="module")
def small_tiles(tmp_path_factory) -> Path:
    import tilesynth as ts

    d = tmp_path_factory.mktemp("opts")
    r = np.random.default_rng(2)
    ts.build_omega(r.random((24, 24, 3), dtype=np.float32), tileset="8", tile_size=8, seed=1).save(
        d / "s.tiles"
    )
    return d / "s.tiles"


def test_sheet_has_quiet(small_tiles: Path, tmp_path: Path):
    code, out, err = _cli("sheet", str(small_tiles), "-o", str(tmp_path / "a.png"))
    assert code == 0 and "wrote" in err and (tmp_path / "a.png").stat().st_size > 0
    code, out, err = _cli("sheet", str(small_tiles), "-o", str(tmp_path / "b.png"), "-q")
    assert code == 0 and out == "" and err == "" and (tmp_path / "b.png").stat().st_size > 0


def test_every_subcommand_that_reports_progress_has_quiet():
    subs = _subparsers(build_parser())
    for cmd in ("build", "synth", "sheet", "demo", "metrics", "report", "batch"):
        assert any("-q" in a.option_strings for a in subs[cmd]._actions), cmd


@pytest.mark.parametrize("spelling,canonical", [("up", "up"), ("+y", "up"), ("down", "down"), ("-y", "down")])
def test_normal_y_takes_both_spellings_everywhere(spelling: str, canonical: str):
    for cmd in ("build", "synth", "export"):
        sp = _subparsers(build_parser())[cmd]
        args = {
            "build": ["x.png", "-o", "y.tiles"],
            "synth": ["x.tiles", "-o", "y.png", "--size", "8"],
            "export": ["x.tiles", "-o", "d"],
        }[cmd]
        assert sp.parse_args([*args, f"--normal-y={spelling}"]).normal_y == canonical, cmd
    assert argtypes.normal_y_value(spelling) == canonical
    for bad in ("UP", "y", "+Y", "", None, 1):
        with pytest.raises(ValueError):
            argtypes.normal_y_value(bad)


def test_export_records_plus_y_for_either_spelling(tmp_path: Path):
    """The export manifest keeps its spelling (+y/-y, its schema): up and +y give the same files."""
    import json

    import tilesynth as ts
    from tilesynth.engine import export

    r = np.random.default_rng(4)
    ex = r.random((24, 24, 3), dtype=np.float32)
    nm = r.random((24, 24, 3), dtype=np.float32)
    tiles = ts.build_omega(ex, tileset="8", tile_size=8, seed=1)
    got = {}
    for spelling in ("up", "+y", "down"):
        d = tmp_path / spelling.replace("+", "p")
        export(tiles, d, maps={"normal": nm}, normal_y=spelling)
        m = json.loads((d / "manifest.json").read_text())
        got[spelling] = m
    entry = lambda m: {mp["name"]: mp for mp in m["maps"]}["normal"]  # noqa: E731
    assert entry(got["up"])["normal_y"] == entry(got["+y"])["normal_y"] == "+y"
    assert entry(got["down"])["normal_y"] == "-y"
