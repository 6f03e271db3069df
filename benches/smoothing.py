#!/usr/bin/env python3
"""What Poisson smoothing (``build --smooth``, issue 5) does to real tile sets: the cut seam score with and without
it, how many values the clip to [0, 1] touches, the solver's iterations and residual, and the smoothing's share
of the build time. Both builds use the same seed, so they have the same genes, matching patches and cuts.

The speed of the solver itself against scipy and OpenCV is ``benches/poisson_compare.py``; this script is about
the result. The cut seam score (:func:`tilesynth.measure.metrics.cut_seam_score`) is the mean squared step across the
cutting curves over the mean squared step of all pixel pairs of the tiles: 1 = the cut is as invisible as any
pair of neighbours.

Usage::

    python benches/smoothing.py                       # six textures, 16a, default tile size
    python benches/smoothing.py --set n2 --figure docs/figures/smooth-compare.png
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

import tilesynth as ts
from tilesynth.measure.metrics import cut_seam_score

TEXTURES = ("gravel", "rust", "tomatoes", "bread", "grapes", "caustics")
SHARED = Path(__file__).resolve().parents[2] / "shared" / "textures"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--textures", default=",".join(TEXTURES))
    ap.add_argument(
        "--dir", default=str(SHARED), help="directory of the textures (default ../shared/textures)"
    )
    ap.add_argument("--set", default="16a")
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument(
        "--figure", default=None, help="write a plain / smoothed synthesis of the second texture here"
    )
    args = ap.parse_args(argv)
    rows = []
    for name in args.textures.split(","):
        ex, _ = ts.load_image(Path(args.dir) / f"{name}.png")
        plain = ts.build_omega(ex, tileset=args.set, seed=args.seed)
        smooth = ts.build_omega(ex, tileset=args.set, seed=args.seed, smooth=True)
        info = smooth.params["smooth"]
        a, b = cut_seam_score(plain)["score"], cut_seam_score(smooth)["score"]
        rows.append(
            (
                name,
                smooth.tile_size,
                smooth.n_tiles,
                a,
                b,
                info["iterations_max"],
                info["residual_max"],
                info["clipped"] / max(1, info["unknowns"] * smooth.channels),
                smooth.timing["smoothing_s"] / smooth.n_tiles * 1e3,
                smooth.timing["smoothing_s"] / smooth.timing["total_s"],
            )
        )
        print(f"{name}: cut seam {a:.3f} -> {b:.3f}", file=sys.stderr)
        if args.figure and len(rows) == 2:
            _figure(plain, smooth, args.figure)
    print(
        "\n| texture | N | tiles | cut seam plain | cut seam smoothed | ratio | iterations (max) | residual (max) "
        "| clipped | ms per tile | share of build |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r[0]} | {r[1]} | {r[2]} | {r[3]:.3f} | {r[4]:.3f} | {r[4] / r[3]:.2f} | {r[5]} | {r[6]:.1e} "
            f"| {100 * r[7]:.1f} % | {r[8]:.2f} | {100 * r[9]:.0f} % |"
        )
    gm = float(np.exp(statistics.fmean(np.log([r[4] / r[3] for r in rows]))))
    print(f"\ngeometric mean ratio smoothed / plain: {gm:.2f}")
    return 0


def _figure(plain: ts.TileSet, smooth: ts.TileSet, path: str) -> None:
    w, h = 512, 320
    a, _ = ts.synthesize(plain, w, h, seed=1)
    b, _ = ts.synthesize(smooth, w, h, seed=1)
    gap = np.ones((8, w, a.shape[2]), np.float32)
    ts.save_image(path, np.concatenate([a, gap, b], axis=0))
    print(f"wrote {path}: plain (top) and smoothed (bottom), same cuts and layout", file=sys.stderr)


if __name__ == "__main__":
    raise SystemExit(main())
