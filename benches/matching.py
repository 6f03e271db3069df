#!/usr/bin/env python3
"""How much each matching-patch strategy (and distance) lowers the ω cut cost, and what it costs in build time.

For five textures of ../shared/textures (or ``--textures``), set 16a, the default tile size (half the shorter
side, at most 256), random genes of a fixed seed (the same genes for every row of a texture): the mean cut cost
of the 16 tiles, its ratio to the ``ssd`` strategy, and the build time (median of ``--repeat`` builds), for

- ``--match ssd | circle | midpoints | best-cut (k = 16, 64, and all with --all)`` with the colour SSD, and
- ``--metric eq3 | eq2`` with ``--match ssd``.

Build times come from the same process, run back to back; on a shared machine only their ratios mean much.

Usage::

    python benches/matching.py              # five textures, about a minute or two
    python benches/matching.py --all        # also best-cut over every translation (slow: one cut per translation)
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import tilesynth as ts

HERE = Path(__file__).resolve().parent
DEFAULT_TEXTURES = HERE.parent.parent / "shared" / "textures"
TEXTURES = ["gravel.png", "tomatoes.png", "caustics.png", "bricks-brown.png", "basket-weave.png"]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--textures", type=Path, default=Path(os.environ.get("TILESYNTH_TEXTURES", DEFAULT_TEXTURES))
    )
    p.add_argument("--all", action="store_true", help="include best-cut over every translation")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--seed", type=int, default=1)
    a = p.parse_args(argv)
    rows_def = [
        ("ssd", None, "color"),
        ("circle", None, "color"),
        ("midpoints", None, "color"),
        ("best-cut", 16, "color"),
        ("best-cut", 64, "color"),
    ]
    if a.all:
        rows_def.append(("best-cut", "all", "color"))
    rows_def += [("ssd", None, "eq3"), ("ssd", None, "eq2")]
    print(
        f"# benches/matching.py — tilesynth {ts.__version__}, set 16a, seed {a.seed}, {os.cpu_count()} cores\n"
    )
    header = "| texture | strategy | metric | mean cut cost | vs ssd | build s (median) | vs ssd |"
    print(header)
    print("|" + "---|" * 7)
    summary: dict[tuple, list[tuple[float, float]]] = {}
    for name in TEXTURES:
        path = a.textures / name
        if not path.exists():
            print(f"(skipping {name}: not found)", file=sys.stderr)
            continue
        ex, _ = ts.load_image(path)
        base_cost = base_time = None
        for match, k, metric in rows_def:
            times, built = [], None
            reps = 1 if k == "all" or metric == "eq2" else a.repeat
            for _ in range(reps):
                t0 = time.perf_counter()
                built = ts.build_omega(ex, tileset="16a", seed=a.seed, match=match, match_k=k, metric=metric)
                times.append(time.perf_counter() - t0)
            cost = float(np.mean(built.cut_costs))
            t = statistics.median(times)
            if base_cost is None:
                base_cost, base_time = cost, t
            label = match if k is None else f"{match} k={k}"
            summary.setdefault((label, metric), []).append((cost / base_cost, t / base_time))
            print(
                f"| {name} {ex.shape[1]}x{ex.shape[0]} N={built.tile_size} | {label} | {metric} | {cost:.2f} | "
                f"{cost / base_cost:.3f} | {t:.2f} | {t / base_time:.1f}x |",
                flush=True,
            )
    print("\n| strategy | metric | mean cut cost vs ssd (geometric mean over textures) | build time vs ssd |")
    print("|---|---|---|---|")
    for (label, metric), vals in summary.items():
        c = float(np.exp(np.mean(np.log([v[0] for v in vals]))))
        t = float(np.exp(np.mean(np.log([v[1] for v in vals]))))
        print(f"| {label} | {metric} | {c:.3f} | {t:.1f}x |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
