#!/usr/bin/env python3
"""The selection users actually get (issue 15, helper selq2): ``tilesynth build``'s default set is ``c5`` (625
tiles), whose default selection is one random gene vector made border-aware ("obord": 32 random draws, the one
whose predicted border seam is closest to 0.8 without exceeding 1 kept, :mod:`tilesynth.builder.genes.omega_borders`).

Its visible measures (``benches/selection.py``'s :func:`visible_measures`: the tiles' cut score and cut seam, and
of a 512² synthesis with seed 1 coherence, texture statistics, histogram distance, coverage) against the median
of ``--random`` single random draws (``border_tries=1``, seeds 1000+), with the default (``border_tries`` 32)
built with seeds 1..``--seeds``; CPU seconds per build of both.

Usage::

    OPENBLAS_NUM_THREADS=1 python benches/selection_c5.py --json /tmp/c5.json
    python benches/selection_c5.py --replay /tmp/c5.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import tilesynth as ts

sys.path.insert(0, str(Path(__file__).resolve().parent))
from selection import DEFAULT_TEXTURES, VISIBLE_MEASURES, _gain, load, visible_measures  # noqa: E402

TEXTURES = ("gravel.png", "beans.png", "caustics.png", "grapes.png", "tomatoes.png", "crackers.png")


def collect(a: argparse.Namespace) -> dict[str, Any]:
    out: dict[str, Any] = {"kind": a.kind, "textures": {}}
    for name in a.textures.split(","):
        ex = load(a.dir / name)
        rec: dict[str, Any] = {"random": [], "random_cpu_s": [], "default": [], "default_cpu_s": []}
        out["textures"][name] = rec
        for s in range(max(a.random, a.seeds)):  # interleaved: one random build, one default build
            if s < a.random:
                t0 = time.process_time()
                tset = ts.build_omega(ex, tileset=a.kind, seed=1000 + s, threads=a.threads, border_tries=1)
                rec["random_cpu_s"].append(time.process_time() - t0)
                rec["random"].append(visible_measures(tset, a.size, a.threads))
            if s < a.seeds:
                t0 = time.process_time()
                tset = ts.build_omega(ex, tileset=a.kind, seed=1 + s, threads=a.threads)
                rec["default_cpu_s"].append(time.process_time() - t0)
                rec["default"].append(visible_measures(tset, a.size, a.threads))
        print(f"  {a.kind} {name} done", file=sys.stderr, flush=True)
        if a.json:
            a.json.write_text(json.dumps(out, default=str))
    return out


def report(data: dict[str, Any]) -> None:
    print("| texture | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " |")
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 1))
    gains = []
    for name, rec in data["textures"].items():
        med = {k: float(np.nanmedian([r[k] for r in rec["random"]])) for _, k, _ in VISIBLE_MEASURES}
        val = {k: float(np.nanmedian([r[k] for r in rec["default"]])) for _, k, _ in VISIBLE_MEASURES}
        g = {k: _gain(val[k], med[k], sg) for _, k, sg in VISIBLE_MEASURES}
        gains.append(g)
        print(f"| {name} | " + " | ".join(f"{g[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES) + " |")
    m = {k: np.mean([g[k] for g in gains]) for _, k, _ in VISIBLE_MEASURES}
    print("| **mean** | " + " | ".join(f"**{m[k]:+.1f}**" for _, k, _ in VISIBLE_MEASURES) + " |")
    rc = [v for r in data["textures"].values() for v in r["random_cpu_s"]]
    dc = [v for r in data["textures"].values() for v in r["default_cpu_s"]]
    print(
        f"\nmedian CPU s per build: single random draw {np.median(rc):.2f}, default (obord) {np.median(dc):.2f}"
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", type=Path, default=DEFAULT_TEXTURES)
    p.add_argument("--textures", default=",".join(TEXTURES))
    p.add_argument("--kind", default="c5")
    p.add_argument("--random", type=int, default=10)
    p.add_argument("--seeds", type=int, default=6)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", type=Path, default=None)
    p.add_argument("--replay", type=Path, nargs="*", default=None)
    a = p.parse_args(argv)
    if a.replay:
        data: dict[str, Any] = {"textures": {}}
        for path in a.replay:
            data["textures"].update(json.loads(path.read_text())["textures"])
        report(data)
        return 0
    collect(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
