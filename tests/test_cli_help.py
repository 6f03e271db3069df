"""``tilesynth build --help`` for users: what a user sets first, then the advanced groups, in plain words."""

from __future__ import annotations

import re

from tilesynth.cli.main import build_parser


def test_build_help_leads_with_what_a_user_sets_then_the_advanced_groups():
    parser = build_parser()._subparsers._group_actions[0].choices["build"]
    titles = [g.title for g in parser._action_groups if g._group_actions]
    first = ["input and output", "what you set", "material maps and masks"]
    assert titles[1:4] == first, titles  # after argparse's own (-h)
    assert all(t.startswith("advanced: ") for t in titles[4:-1]) and titles[-1] == "output encoding", titles
    flags = {g.title: [o for a in g._group_actions for o in a.option_strings] for g in parser._action_groups}
    assert {"-o", "--sheet"} <= set(flags["input and output"])
    assert {"--tile-size", "--seed", "--set"} <= set(flags["what you set"])
    assert {"--map", "--mask"} <= set(flags["material maps and masks"])
    assert "--select" in flags["advanced: choosing the sample patches"]
    assert (
        "--cut-region" in flags["advanced: matching and cuts"]
        and "--overlap" in flags["advanced: Wang tiles"]
    )
    text = " ".join(parser.format_help().split())
    # plain words: no paper numbers ("002 section 3.3", "000 eq. 3", "003's"); the README names the papers
    assert not re.search(r"\b00[0-4]\b|section \d|eq\. \d", text), re.findall(r".{30}\b00[0-4]\b.{30}", text)
    assert "README's 'Command line' section" in text
