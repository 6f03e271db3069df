#!/usr/bin/env python3
"""Replay selection rules on the records of ``benches/selection_cheap.py`` (issue 15, helper selq2).

A rule ``K:agg:key+key+...`` keeps one of the first K candidates (by ΣD) from the proxies alone: ``agg`` ``r`` =
smallest sum of ranks (:func:`tilesynth.builder.genes.visible_objective.pick_by_ranks`, ties to the better by ΣD), ``l`` = smallest sum
of logs of the ratios to the candidates' medians; ``1:sumd`` = the best by ΣD; ``K:cut`` = today's default (the
lowest cut score). The kept candidate's **evaluation** (512² synthesis, seed 1) is compared with the median of the
random draws: gain in %, median over the seeds, then the mean over the textures. The CPU column is the model
cost of the rule per build in units of one candidate build (K builds plus K times the proxies the rule reads).

Usage::

    python benches/selection_cheap_replay.py /tmp/tune.json --rules "4:cut,4:r:cut_seam+coh_s128+tex_c128"
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from selection import VISIBLE_MEASURES, _gain  # noqa: E402

TARGETS = ("cut_seam", "coherence", "texstats")

COST_KEYS = {
    "cut_seam": ("t_seam",),
    "cut_score": (),
    "coh_exact": ("t_synth", "t_coh_exact"),
    "tex": ("t_synth", "t_tex"),
}


def _cost_keys(key: str) -> tuple[str, ...]:
    if key in COST_KEYS:
        return COST_KEYS[key]
    if key.startswith("coh_s"):
        return ("t_synth", "t_" + key)
    if key.startswith("tex_c"):
        return ("t_synth", "t_" + key)
    raise KeyError(key)


def pick(rows: list[dict[str, Any]], rule: str) -> int:
    from tilesynth.builder.genes.visible_objective import pick_by_ranks

    parts = rule.split(":")
    k = int(parts[0])
    rows = rows[:k]
    if parts[1] == "sumd":
        return 0
    if parts[1] == "cut":
        return int(np.argmin([r["proxy"]["cut_score"] for r in rows]))
    keys = tuple(parts[2].split("+"))
    prox = [r["proxy"] for r in rows]
    if parts[1] == "r":
        return pick_by_ranks(prox, keys)
    m = np.array([[p[q] for q in keys] for p in prox])
    score = np.log(np.maximum(m, 1e-12) / np.median(m, axis=0)).sum(axis=1)
    return int(np.argmin(score + 1e-9 * np.arange(len(rows))))


def cost(data: dict[str, Any], rule: str) -> float:
    parts = rule.split(":")
    k = int(parts[0])
    keys = set() if parts[1] in ("sumd", "cut") else set(parts[2].split("+"))
    tkeys = {t for q in keys for t in _cost_keys(q)}
    rows = [r for rec in data["textures"].values() for rs in rec["seeds"].values() for r in rs]
    build = float(np.median([r["build_cpu_s"] for r in rows]))
    extra = float(np.median([sum(r["proxy"][t] for t in tkeys) for r in rows])) if tkeys else 0.0
    return k * (build + extra) / build if k > 1 else 0.0


def replay(data: dict[str, Any], rule: str, seeds: slice = slice(None)) -> dict[str, dict[str, float]]:
    per = {}
    for name, rec in data["textures"].items():
        med = {k: float(np.nanmedian([r[k] for r in rec["random"]])) for _, k, _ in VISIBLE_MEASURES}
        picks = [rows[pick(rows, rule)]["eval"] for rows in list(rec["seeds"].values())[seeds]]
        val = {k: float(np.nanmedian([p[k] for p in picks])) for _, k, _ in VISIBLE_MEASURES}
        per[name] = {k: _gain(val[k], med[k], sg) for _, k, sg in VISIBLE_MEASURES}
    return per


def oracle(data: dict[str, Any], k: int) -> dict[str, float]:
    """Per target measure: the gain of the best of the first k candidates by that measure's evaluation itself."""
    out = {}
    for q in TARGETS:
        g = []
        for rec in data["textures"].values():
            med = float(np.nanmedian([r[q] for r in rec["random"]]))
            vals = [min(r["eval"][q] for r in rows[:k]) for rows in rec["seeds"].values()]
            g.append(_gain(float(np.median(vals)), med, -1))
        out[q] = float(np.mean(g))
    return out


def means(per: dict[str, dict[str, float]]) -> dict[str, float]:
    return {k: float(np.mean([g[k] for g in per.values()])) for _, k, _ in VISIBLE_MEASURES}


def table(data: dict[str, Any], rules: list[str]) -> list[tuple[str, dict[str, float], float]]:
    out = []
    print("| rule | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " | min of 3 | cost (builds) |")
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 3))
    for rule in rules:
        m = means(replay(data, rule))
        c = cost(data, rule)
        tgt = min(m[q] for q in TARGETS)
        out.append((rule, m, c))
        print(
            f"| {rule} | "
            + " | ".join(f"{m[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES)
            + f" | {tgt:+.1f} | {c:.1f} |"
        )
    return out


def per_texture(data: dict[str, Any], rule: str) -> None:
    per = replay(data, rule)
    print(f"\n### {rule}\n")
    print("| texture | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " |")
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 1))
    for t, g in per.items():
        print(f"| {t} | " + " | ".join(f"{g[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES) + " |")
    m = means(per)
    print("| **mean** | " + " | ".join(f"**{m[k]:+.1f}**" for _, k, _ in VISIBLE_MEASURES) + " |")


def load_all(paths: list[Path]) -> dict[str, Any]:
    data: dict[str, Any] = {"textures": {}}
    for p in paths:
        data["textures"].update(json.loads(p.read_text())["textures"])
    return data


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("json", type=Path, nargs="+")
    p.add_argument("--rules", default="1:sumd,4:cut")
    p.add_argument("--detail", default="")
    p.add_argument("--oracle", default="4,8")
    a = p.parse_args(argv)
    data = load_all(a.json)
    table(data, a.rules.split(","))
    for k in a.oracle.split(","):
        if k:
            o = oracle(data, int(k))
            print(f"\nceiling (best of the first {k} by the evaluation itself, in sample): "
                  + ", ".join(f"{q} {v:+.1f}" for q, v in o.items()))  # fmt: skip
    for rule in a.detail.split(","):
        if rule:
            per_texture(data, rule)
    return 0


if __name__ == "__main__":
    sys.exit(main())
