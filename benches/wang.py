#!/usr/bin/env python3
"""Wang tiles, measured: the figures of ``docs/wang.md`` (issue 4).

Sections (each printed as Markdown; ``--json`` also writes every figure):

1. ``energy``  For five textures of ../shared/textures, 001's E for Wang-8 and Wang-18: random sample patches
   (mean and best over ``--random`` seeds) against 001's GA {pop 50, α 0.05, P_c 0.3, P_m 0.2, 200 generations,
   stop after 8 without improvement} (mean over ``--seeds`` seeds), with the GA's wall time, generations and
   evaluations. Tile size: half the exemplar's shorter side, overlap N/4, i.e. samples of 80 (overlap 16) on
   128-pixel exemplars and 120 (overlap 24) on 192-pixel ones: 001's Table 1 set-ups.
2. ``time``    Build time of every scheme (median of 3) on each texture: ω-16 (16a), Wang-8 and Wang-18 (random,
   DP; Wang-8 with graph cuts), Wang-8/18 with the GA, s-Wang-8 (SSD supplementary patches, and with
   ``--supplementary cut``).
3. ``corners`` 004's corner problem on the same textures: for Cohen's free corners (Wang-8, random, DP and graph
   cuts), the number of edge pixels per tile corner that show the wrong sample (mean, max, share of corners
   with any), and the share of pixel pairs across tile borders of a 512x512 synthesis that are not continuous
   exemplar content (through the provenance), beside pinned corners, s-Wang and ω-16.
4. ``figure``  A side-by-side picture of Wang-18 (GA), ω-16 and s-Wang-8 outputs for one structured texture
   (bricks-brown), with the exemplar, written to ``--figure`` (default docs/figures/wang-compare.png), and with
   ``--tile-sheets`` the contact sheets of the three tile sets beside it.

Large exemplars are cropped to their central 192x192 (lettuce-leaves 378, cracked-mud 512), so that every
texture uses one of 001's two sample sizes.

Usage::

    python benches/wang.py                      # everything (a few minutes on 2 cores)
    python benches/wang.py --only energy --seeds 2 --random 10
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import tilesynth as ts
from tilesynth.builder.wang import corner_mismatch

HERE = Path(__file__).resolve().parent
DEFAULT_TEXTURES = HERE.parent.parent / "shared" / "textures"
TEXTURES = [
    "bricks-brown.png",
    "basket-weave.png",
    "lettuce-leaves.png",
    "brodatz-d103-burlap.png",
    "cracked-mud.png",
]
CROP = 192
#: Cohen's literal construction (free corners, one random draw): the figures of docs/wang.md were measured on it,
#: before issue 14 made pinned corners and border-aware draws the defaults.
COHEN = {"corners": "free", "border_tries": 1}


def load(textures: Path, name: str) -> np.ndarray:
    img, _ = ts.load_image(textures / name)
    h, w = img.shape[:2]
    if min(h, w) > CROP:
        y0, x0 = (h - CROP) // 2, (w - CROP) // 2
        img = np.ascontiguousarray(img[y0 : y0 + CROP, x0 : x0 + CROP])
    return img


def energy_section(textures: Path, seeds: int, n_random: int, threads: int | None) -> list[dict[str, Any]]:
    rows = []
    for name in TEXTURES:
        ex = load(textures, name)
        for tset in ("wang8", "wang18"):
            rnd = [
                ts.build_wang(ex, **COHEN, tileset=tset, seed=s, threads=threads).E
                for s in range(1000, 1000 + n_random)
            ]
            ga, secs, gens, evals = [], [], [], []
            for s in range(seeds):
                t0 = time.perf_counter()
                b = ts.build_wang(ex, **COHEN, tileset=tset, seed=s, select="ga", threads=threads)
                secs.append(time.perf_counter() - t0)
                ga.append(b.E)
                gens.append(b.params["selection"]["generations"])
                evals.append(b.params["selection"]["evaluations"])
            rows.append(
                {
                    "texture": name,
                    "shape": list(ex.shape),
                    "set": tset,
                    "tile_size": b.tile_size,
                    "sample_size": b.params["sample_size"],
                    "overlap": b.params["overlap"],
                    "E_random_mean": statistics.fmean(rnd),
                    "E_random_best": min(rnd),
                    "E_ga_mean": statistics.fmean(ga),
                    "E_ga_best": min(ga),
                    "ga_s_median": statistics.median(secs),
                    "ga_generations": gens,
                    "ga_evaluations": evals,
                }
            )
            print(
                f"  {name} {tset}: random {rows[-1]['E_random_mean']:.4g}, GA {rows[-1]['E_ga_mean']:.4g}",
                file=sys.stderr,
            )
    return rows


def timed(fn, repeat: int = 3) -> float:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def time_section(textures: Path, threads: int | None) -> list[dict[str, Any]]:
    rows = []
    for name in TEXTURES:
        ex = load(textures, name)
        row: dict[str, Any] = {"texture": name, "shape": list(ex.shape)}
        row["omega16"] = timed(lambda: ts.build_omega(ex, tileset="16a", seed=1, threads=threads))
        row["wang8"] = timed(lambda: ts.build_wang(ex, **COHEN, seed=1, threads=threads))
        row["wang18"] = timed(lambda: ts.build_wang(ex, **COHEN, tileset="wang18", seed=1, threads=threads))
        row["wang8_graph"] = timed(lambda: ts.build_wang(ex, **COHEN, seed=1, cut="graph", threads=threads))
        row["wang8_ga"] = timed(lambda: ts.build_wang(ex, **COHEN, seed=1, select="ga", threads=threads), 1)
        row["wang18_ga"] = timed(
            lambda: ts.build_wang(ex, **COHEN, tileset="wang18", seed=1, select="ga", threads=threads), 1
        )
        row["swang8"] = timed(lambda: ts.build_swang(ex, border_tries=1, seed=1, threads=threads))
        row["swang8_cut"] = timed(
            lambda: ts.build_swang(ex, border_tries=1, seed=1, supplementary="cut", threads=threads)
        )
        rows.append(row)
        print(
            f"  {name}: " + ", ".join(f"{k} {v:.2f}" for k, v in row.items() if isinstance(v, float)),
            file=sys.stderr,
        )
    return rows


def discontinuity(tset: ts.TileSet, size: int = 512, seed: int = 5) -> float:
    """Share of pixel pairs across tile borders that are not continuous exemplar content (provenance)."""
    _, imap = ts.synthesize(tset, size, size, seed=seed)
    src = ts.source_map(tset, imap, size, size)
    n = tset.tile_size
    xs, ys = np.arange(n, size, n), np.arange(n, size, n)
    v_ok = (src[:, xs, 0] == src[:, xs - 1, 0]) & (src[:, xs, 1] == src[:, xs - 1, 1] + 1)
    h_ok = (src[ys, :, 0] == src[ys - 1, :, 0] + 1) & (src[ys, :, 1] == src[ys - 1, :, 1])
    return 1.0 - (v_ok.sum() + h_ok.sum()) / (v_ok.size + h_ok.size)


def corner_section(textures: Path, seeds: int, threads: int | None) -> list[dict[str, Any]]:
    rows = []
    for name in TEXTURES:
        ex = load(textures, name)
        row: dict[str, Any] = {"texture": name}
        for label, build in (
            ("free_dp", lambda s: ts.build_wang(ex, **COHEN, seed=s, threads=threads)),
            ("free_graph", lambda s: ts.build_wang(ex, **COHEN, seed=s, cut="graph", threads=threads)),
            (
                "pinned_dp",
                lambda s: ts.build_wang(ex, seed=s, corners="pinned", border_tries=1, threads=threads),
            ),
        ):
            cms, disc = [], []
            for s in range(seeds):
                b = build(s)
                cms.append(corner_mismatch(b.labels).ravel())
                disc.append(discontinuity(b))
            cm = np.concatenate(cms)
            row[label] = {
                "mean_px_per_corner": float(cm.mean()),
                "max_px": int(cm.max()),
                "corners_with_mismatch": float((cm > 0).mean()),
                "discontinuous_pairs": statistics.fmean(disc),
                "tile_size": b.tile_size,
                "w": b.params["overlap"] // 2,
            }
        row["swang_discontinuous_pairs"] = statistics.fmean(
            discontinuity(ts.build_swang(ex, border_tries=1, seed=s, threads=threads)) for s in range(seeds)
        )
        row["omega16_discontinuous_pairs"] = statistics.fmean(
            discontinuity(ts.build_omega(ex, tileset="16a", seed=s, threads=threads)) for s in range(seeds)
        )
        rows.append(row)
        print(f"  {name}: corner mismatch {row['free_dp']['mean_px_per_corner']:.2f} px", file=sys.stderr)
    return rows


def figure(textures: Path, path: Path, threads: int | None, sheets: bool, size: int = 384) -> dict[str, Any]:
    from PIL import Image, ImageDraw

    ex = load(textures, "bricks-brown.png")
    builds = {
        "Wang-18 (GA, DP cuts)": ts.build_wang(
            ex, **COHEN, tileset="wang18", seed=1, select="ga", threads=threads
        ),
        "omega-16 (16a)": ts.build_omega(ex, tileset="16a", seed=1, threads=threads),
        "s-Wang-8": ts.build_swang(ex, border_tries=1, seed=1, threads=threads),
    }
    panels = [("exemplar 192x192", (np.clip(ex, 0, 1) * 255).round().astype(np.uint8))]
    for label, b in builds.items():
        img, _ = ts.synthesize(b, size, size, seed=3, dtype=np.uint8, threads=threads)
        panels.append((label, img))
    gap, head = 8, 18
    width = gap + sum(p.shape[1] + gap for _, p in panels)
    sheet = np.full((head + size + gap, width, 3), 255, np.uint8)
    x = gap
    for _, p in panels:
        sheet[head : head + p.shape[0], x : x + p.shape[1]] = p[..., :3]
        x += p.shape[1] + gap
    im = Image.fromarray(sheet)
    draw = ImageDraw.Draw(im)
    x = gap
    for label, p in panels:
        draw.text((x, 3), label, fill=(0, 0, 0))
        x += p.shape[1] + gap
    path.parent.mkdir(parents=True, exist_ok=True)
    im.save(path, optimize=True)
    written = {}
    for label, b in builds.items() if sheets else ():
        sp = path.with_name(path.stem + "-" + label.split(" ")[0].lower() + "-tiles.png")
        ts.save_image(sp, ts.contact_sheet(b))
        written[label] = str(sp)
    return {"figure": str(path), "tile_sheets": written, "E": {k: b.E for k, b in builds.items()}}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--textures", type=Path, default=Path(os.environ.get("TILESYNTH_TEXTURES", DEFAULT_TEXTURES))
    )
    ap.add_argument("--only", choices=("energy", "time", "corners", "figure"), action="append")
    ap.add_argument("--seeds", type=int, default=3, help="GA seeds (energy), seeds of the corner statistics")
    ap.add_argument("--random", type=int, default=20, help="random gene vectors per texture and set")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--figure", type=Path, default=HERE.parent / "docs" / "figures" / "wang-compare.png")
    ap.add_argument(
        "--tile-sheets", action="store_true", help="also write the contact sheets of the three sets"
    )
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    only = set(args.only or ("energy", "time", "corners", "figure"))
    out: dict[str, Any] = {"machine": platform.platform(), "cpus": os.cpu_count(), "threads": args.threads}

    if "energy" in only:
        rows = out["energy"] = energy_section(args.textures, args.seeds, args.random, args.threads)
        print("\n### E, random vs GA (001)\n")
        print(
            "| texture | set | N / P / overlap | E random (mean of %d) | E random (best) | E GA (mean of %d) | "
            "GA / random | GA time (s) | generations |" % (args.random, args.seeds)
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            print(
                f"| {r['texture']} | {r['set']} | {r['tile_size']} / {r['sample_size']} / {r['overlap']} | "
                f"{r['E_random_mean']:.4g} | {r['E_random_best']:.4g} | {r['E_ga_mean']:.4g} | "
                f"{r['E_ga_mean'] / r['E_random_mean']:.2f} | {r['ga_s_median']:.2f} | "
                f"{', '.join(map(str, r['ga_generations']))} |"
            )
    if "time" in only:
        rows = out["time"] = time_section(args.textures, args.threads)
        keys = ["omega16", "wang8", "wang18", "wang8_graph", "wang8_ga", "wang18_ga", "swang8", "swang8_cut"]
        print("\n### Build time (s)\n")
        print("| texture | " + " | ".join(keys) + " |")
        print("|---|" + "---|" * len(keys))
        for r in rows:
            print(f"| {r['texture']} | " + " | ".join(f"{r[k]:.2f}" for k in keys) + " |")
    if "corners" in only:
        rows = out["corners"] = corner_section(args.textures, args.seeds, args.threads)
        print("\n### Corner mismatch (Wang-8, random samples)\n")
        print(
            "| texture | N, w | free DP: px/corner (max), corners hit | free graph: px/corner (max) | "
            "discontinuous border pairs: free DP / free graph / pinned / s-Wang / omega-16 |"
        )
        print("|---|---|---|---|---|")
        for r in rows:
            f, g, p = r["free_dp"], r["free_graph"], r["pinned_dp"]
            print(
                f"| {r['texture']} | {f['tile_size']}, {f['w']} | {f['mean_px_per_corner']:.2f} ({f['max_px']}), "
                f"{100 * f['corners_with_mismatch']:.0f}% | {g['mean_px_per_corner']:.2f} ({g['max_px']}) | "
                f"{100 * f['discontinuous_pairs']:.2f}% / {100 * g['discontinuous_pairs']:.2f}% / "
                f"{100 * p['discontinuous_pairs']:.2f}% / {100 * r['swang_discontinuous_pairs']:.2f}% / "
                f"{100 * r['omega16_discontinuous_pairs']:.2f}% |"
            )
    if "figure" in only:
        out["figure"] = figure(args.textures, args.figure, args.threads, args.tile_sheets)
        print(f"\nwrote {out['figure']['figure']}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
