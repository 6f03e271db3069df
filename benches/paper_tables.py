#!/usr/bin/env python3
"""The seeds' comparison tables, rebuilt: 003's Table 2 (AIS), 000's Table 1 (GA timings), and a scheme comparison.

On the textures of ../shared/textures that 003 names (beans = Beans, bread = Bread, caustics = Caustics, eggs =
Eggs, gravel = Stones, grapes = Grape, school-fish = School, tomatoes = Tomato, grass-straw = Grass), with the N2
set (38 tiles, 6 sample patches) and the tile sizes of 003's Table 1 / 000's Table 1 (80 x 80; Bread and School
70, Grape 100). Two of our exemplars are smaller than the papers' (beans 96x96 and grass-straw 120x120 against
128x128): there the tile is scaled with the exemplar (80·96/128 = 60, 80·120/128 = 75 → 74, even), so the search
space keeps the papers' proportions. Everything is printed as Markdown (``--out FILE`` also writes it,
``--json FILE`` every number).

1. **003 Table 2**: f = 1/E with 003's normalisation (C_j divided by the N·N overlapping pixels, summed over RGB;
   λ = 0.8). "random" = 1/mean(E) over 100 random gene vectors (003: "the average evaluation value of 100
   randomly obtained sample patches sets"), "best-of-100" = 1/min(E) over the *same* 100 ("semi-random": "the
   minimum evaluation value from 100 randomly obtained sets"), then the AIS at (N_p, N_g) = (10, 10), (20, 30),
   (20, 50), (40, 30), (40, 50), (40, 80) with 003's other parameters. 003's times grow with N_g (Stones: 46 s,
   58 s, 127 s for N_g = 30, 50, 80 at N_p = 40), so its runs went the full N_g generations; with its N_o = 6
   stagnation stop ours stop after 7-10 generations and N_g would not matter, so each (N_p, N_g) run here goes
   exactly N_g generations (stagnation off), and one more column gives the default (40, 50) with N_o = 6. Times
   are wall seconds of the whole selection with a cold evaluator (no cached partial map), 2 threads. Means over
   ``--seeds`` seeds; beside our table, 003's values, the multiples over random of both, and the rank agreement.
2. **000 Table 1**: the wall time of 000's GA {pop 40, α 0.05, P_c 0.3, P_m 0.2, N_g 50, N_o 5} (plain E, as 000)
   on the textures of 000's Table 1 that we have, median over seeds, against 000's seconds (Pentium 4, ANN search).
3. **Schemes**: each scheme of :data:`SCHEMES` builds a tile set per texture (build seed 1) and a sample
   (``--size``, tiling seeds 1..``--seeds``) is measured by :mod:`tilesynth.measure.metrics`: border seam score, coherence
   energy (as rms, 8x8 patches, stride 4), coverage and its evenness, repetition peak; means over the tiling seeds.
   Adding a scheme is one entry in :data:`SCHEMES` (a name and a builder; ``build=None`` prints it as pending).
   The border seam score does not see the cuts inside ω tiles, so smoothing shows up in the coherence energy
   (smoothed pixels are no longer exact copies) rather than in the seam column; ``benches/smoothing.py``
   measures the cut seams themselves.

Usage::

    python benches/paper_tables.py --quick          # 1 seed, 256x256 samples (about 3 minutes on 2 cores)
    python benches/paper_tables.py                  # 3 seeds, 512x512 samples
    python benches/paper_tables.py --only table1 --seeds 5 --out tables.md --json tables.json

``--textures DIR`` (default ``TILESYNTH_TEXTURES`` or ../shared/textures).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

import tilesynth as ts
from tilesynth.builder.genes.select import select_genes
from tilesynth.measure import metrics

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from selection import DEFAULT_TEXTURES, load, md_table, tile_patches  # noqa: E402  (shared bench helpers)

SET = "n2"
AIS_CONFIGS: list[tuple[int, int]] = [(10, 10), (20, 30), (20, 50), (40, 30), (40, 50), (40, 80)]


@dataclass(frozen=True)
class Texture:
    file: str
    paper: str
    paper_size: tuple[int, int]  # (width, height) in 003 / 000 Table 1
    paper_tile: int


TEXTURES = [
    Texture("beans.png", "Beans", (128, 128), 80),
    Texture("caustics.png", "Caustics", (128, 128), 80),
    Texture("gravel.png", "Stones", (128, 128), 80),
    Texture("bread.png", "Bread", (108, 99), 70),
    Texture("grapes.png", "Grape", (144, 144), 100),
    Texture("grass-straw.png", "Grass", (128, 128), 80),
    Texture("school-fish.png", "School", (128, 85), 70),
    Texture("tomatoes.png", "Tomato", (128, 128), 80),
    Texture("eggs.png", "Eggs", (128, 102), 80),
]

# 003 Table 2 for these textures: random, semi-random, then (f, seconds) at each of AIS_CONFIGS.
PAPER_003: dict[str, tuple[float, float, list[tuple[float, int]]]] = {
    "Beans": (0.179, 0.244, [(0.297, 18), (0.316, 34), (0.339, 56), (0.347, 58), (0.353, 68), (0.385, 144)]),
    "Caustics": (
        0.137,
        0.219,
        [(0.266, 15), (0.271, 41), (0.283, 47), (0.296, 71), (0.315, 70), (0.322, 137)],
    ),
    "Stones": (0.247, 0.338, [(0.358, 11), (0.361, 32), (0.387, 44), (0.392, 46), (0.418, 58), (0.429, 127)]),
    "Bread": (0.164, 0.229, [(0.268, 8), (0.276, 29), (0.271, 46), (0.273, 44), (0.285, 75), (0.291, 131)]),
    "Grape": (0.237, 0.319, [(0.362, 17), (0.371, 42), (0.397, 64), (0.411, 86), (0.435, 116), (0.471, 289)]),
    "Grass": (0.230, 0.275, [(0.351, 14), (0.384, 38), (0.411, 50), (0.417, 57), (0.423, 78), (0.428, 148)]),
    "School": (0.271, 0.352, [(0.387, 11), (0.399, 33), (0.416, 42), (0.428, 51), (0.451, 65), (0.465, 119)]),
    "Tomato": (0.165, 0.204, [(0.257, 19), (0.265, 32), (0.271, 46), (0.273, 51), (0.296, 74), (0.311, 130)]),
    "Eggs": (0.558, 0.659, [(0.772, 27), (0.793, 38), (0.831, 59), (0.834, 77), (0.998, 114), (1.055, 149)]),
}

# 000 Table 1: GA seconds (pop 40, N_g 50, N_o 5; Pentium 4 3.2 GHz, ANN matching) for the textures we have.
PAPER_000_GA: dict[str, float] = {
    "Beans": 25,
    "Caustics": 24,
    "Stones": 35,
    "Bread": 18,
    "Grape": 43,
    "Grass": 26,
    "Eggs": 23,
}


def tile_size_for(tex: Texture, shape: tuple[int, ...]) -> int:
    """The paper's tile size; scaled with the exemplar's shorter side (rounded down to even) if ours differs."""
    h, w = shape[:2]
    if (w, h) == tex.paper_size:
        return tex.paper_tile
    n = int(tex.paper_tile * min(h, w) / min(tex.paper_size))
    return n - n % 2


def fmt_s(seconds: float) -> str:
    return f"{seconds:.1f}" if seconds < 100 else f"{seconds:.0f}"


def spearman(a: list[float], b: list[float]) -> float:
    """Spearman rank correlation (average ranks for ties)."""

    def ranks(v: list[float]) -> np.ndarray:
        v = np.asarray(v, dtype=float)
        order = np.argsort(v, kind="stable")
        r = np.empty(len(v))
        r[order] = np.arange(len(v), dtype=float)
        for x in np.unique(v):
            r[v == x] = r[v == x].mean()
        return r

    ra, rb = ranks(a), ranks(b)
    if ra.std() == 0 or rb.std() == 0:
        return float("nan")
    return float(np.corrcoef(ra, rb)[0, 1])


def inversions(values: list[float]) -> list[int]:
    """Indices i where values[i] < values[i-1] (the sequence falls where the paper's column order rises)."""
    return [i for i in range(1, len(values)) if values[i] < values[i - 1] - 1e-12]


def textures_found(root: Path) -> list[tuple[Texture, np.ndarray, int]]:
    out = []
    for tex in TEXTURES:
        p = root / tex.file
        if not p.exists():
            print(f"(skipping {tex.file}: not in {root})", file=sys.stderr)
            continue
        ex = load(p)
        out.append((tex, ex, tile_size_for(tex, ex.shape)))
    return out


# ----------------------------------------------------------------------------------------------- Table 2
def run_selection(
    ex: np.ndarray, n: int, method: str, seed: int, threads: int, normalise: bool, **kw: Any
) -> dict[str, Any]:
    tp, n_col = tile_patches(SET)
    t0 = time.perf_counter()
    ev = ts.PopulationEvaluator(ex, n, tp, n_col, normalise=normalise)
    res = select_genes(method, lambda g: ev.evaluate(g, threads), ex.shape, n_col, n, seed, **kw)
    return {
        "E": res.E,
        "f": 1.0 / res.E,
        "s": time.perf_counter() - t0,
        "generations": res.generations,
        "evaluations": res.evaluations,
        "stop": res.stop_reason,
    }


def table2(found: list, seeds: list[int], threads: int, log: Callable[[str], None]) -> tuple[str, dict]:
    tp, n_col = tile_patches(SET)
    cols = ["random", "best-of-100"] + [f"AIS {c}" for c in AIS_CONFIGS] + ["AIS (40, 50) N_o=6"]
    data: dict[str, Any] = {}
    rows_f, rows_paper, rows_mult, rows_t = [], [], [], []
    for tex, ex, n in found:
        f: dict[str, list[float]] = {c: [] for c in cols}
        secs: dict[str, list[float]] = {c: [] for c in cols}
        gens: dict[str, list[int]] = {c: [] for c in cols}
        for s in seeds:
            t0 = time.perf_counter()
            ev = ts.PopulationEvaluator(ex, n, tp, n_col, normalise=True)
            rng = np.random.default_rng(10_000 + s)
            pop = np.stack([ts.builder.omega.random_genes(ex.shape, n_col, n, rng) for _ in range(100)])
            E, _ = ev.evaluate(pop, threads)
            dt = time.perf_counter() - t0
            f["random"].append(1.0 / float(E.mean()))
            f["best-of-100"].append(1.0 / float(E.min()))
            secs["random"].append(dt)
            secs["best-of-100"].append(dt)
            for (p, g), c in zip(AIS_CONFIGS, cols[2:-1]):
                r = run_selection(
                    ex, n, "ais", s, threads, True, population=p, generations=g, stagnation=g + 1
                )
                f[c].append(r["f"])
                secs[c].append(r["s"])
                gens[c].append(r["generations"])
            r = run_selection(ex, n, "ais", s, threads, True, population=40, generations=50)
            f[cols[-1]].append(r["f"])
            secs[cols[-1]].append(r["s"])
            gens[cols[-1]].append(r["generations"])
        mean = {c: float(np.mean(v)) for c, v in f.items()}
        tmed = {c: float(np.median(v)) for c, v in secs.items()}
        p_rand, p_semi, p_ais = PAPER_003[tex.paper]
        paper = [p_rand, p_semi] + [v for v, _ in p_ais]
        ours = [mean[c] for c in cols[:-1]]
        data[tex.file] = {
            "paper_name": tex.paper,
            "shape": list(ex.shape),
            "tile": n,
            "f": f,
            "seconds": secs,
            "variance": float(ex.astype(np.float64).var(axis=(0, 1)).sum()),
            "generations": gens,
            "mean_f": mean,
            "paper_f": paper,
            "paper_s": [t for _, t in p_ais],
        }
        label = f"{tex.paper} ({tex.file}, {ex.shape[1]}x{ex.shape[0]}, N={n})"
        rows_f.append([label] + [f"{mean[c]:.3f}" for c in cols])
        rows_paper.append([tex.paper] + [f"{v:.3f}" for v in paper])
        rows_mult.append(
            [tex.paper] + [f"{o / ours[0]:.2f}x ({pv / paper[0]:.2f}x)" for o, pv in zip(ours[1:], paper[1:])]
        )
        rows_t.append(
            [tex.paper, fmt_s(tmed["random"])]
            + [f"{fmt_s(tmed[c])} ({t})" for c, (_, t) in zip(cols[2:-1], p_ais)]
            + [f"{fmt_s(tmed[cols[-1]])} ({statistics.median(gens[cols[-1]]):.0f} gen.)"]
        )
        log(f"table 2: {tex.paper} done")
    md = [
        f"### 003 Table 2 analogue: f = 1/E (normalised), {SET}, mean over seeds {seeds}\n",
        md_table(["texture"] + cols, rows_f),
        "\n003's Table 2, same columns (the last one has no counterpart in 003):\n",
        md_table(["texture"] + cols[:-1], rows_paper),
        "\nMultiples over random, ours (003's):\n",
        md_table(["texture"] + cols[1:-1], rows_mult),
        f"\nWall seconds, ours (003's), median over seeds; random = the 100 evaluations; {threads} threads:\n",
        md_table(["texture", "random (100 eval.)"] + [f"{c}" for c in cols[2:-1]] + [cols[-1]], rows_t),
    ]
    md.append("\n" + ordering_text(data, cols))
    return "\n".join(md), data


def ordering_text(data: dict[str, Any], cols: list[str]) -> str:
    """Where our ordering differs from 003's: along each row (methods) and down each column (textures)."""
    lines = ["Ordering against 003:", ""]
    names = [v["paper_name"] for v in data.values()]
    for c_idx, c in enumerate(cols[:-1]):
        ours = [v["mean_f"][c] for v in data.values()]
        paper = [v["paper_f"][c_idx] for v in data.values()]
        rank_o = [names[i] for i in np.argsort(ours)[::-1]]
        rank_p = [names[i] for i in np.argsort(paper)[::-1]]
        lines.append(
            f"- {c}: textures by f, ours {' > '.join(rank_o)}; 003 {' > '.join(rank_p)} "
            f"(Spearman {spearman(ours, paper):+.2f})"
        )
    # what our texture ordering is: random f is nearly 1 / (the exemplar's variance), texture by texture
    var = [v["variance"] for v in data.values()]
    f_r = [v["mean_f"]["random"] for v in data.values()]
    p_r = [v["paper_f"][0] for v in data.values()]
    fv = [a * b for a, b in zip(f_r, var)]
    lines += [
        "",
        f"- Exemplar variance V (per pixel, summed over RGB): our random f·V = {min(fv):.4f}-{max(fv):.4f} "
        f"over the textures, so our texture order is that of 1/V (Spearman of our random f with 1/V "
        f"{spearman(f_r, [1 / x for x in var]):+.2f}); 003's random f against 1/V: "
        f"{spearman(p_r, [1 / x for x in var]):+.2f}.",
    ]
    lines.append("")
    for v in data.values():
        ours = [v["mean_f"][c] for c in cols[:-1]]
        inv_o = inversions(ours)
        inv_p = inversions(v["paper_f"])
        say = lambda inv: ", ".join(f"{cols[i - 1]} > {cols[i]}" for i in inv) or "none"  # noqa: E731
        lines.append(
            f"- {v['paper_name']}: columns where f falls left to right: ours {say(inv_o)}; 003 {say(inv_p)}"
        )
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------------- Table 1
def table1(found: list, seeds: list[int], threads: int, log: Callable[[str], None]) -> tuple[str, dict]:
    rows, data = [], {}
    for tex, ex, n in found:
        if tex.paper not in PAPER_000_GA:
            continue
        runs = [run_selection(ex, n, "ga", s, threads, False) for s in seeds]
        t = [r["s"] for r in runs]
        med = statistics.median(t)
        paper = PAPER_000_GA[tex.paper]
        data[tex.file] = {"paper_name": tex.paper, "runs": runs, "median_s": med, "paper_s": paper, "tile": n}
        rows.append(
            [
                tex.paper,
                f"{ex.shape[1]}x{ex.shape[0]} ({tex.paper_size[0]}x{tex.paper_size[1]})",
                f"{n} ({tex.paper_tile})",
                f"{med:.2f}",
                f"{min(t):.2f}-{max(t):.2f}",
                f"{statistics.median(r['generations'] for r in runs):.0f}",
                f"{statistics.median(r['evaluations'] for r in runs):.0f}",
                f"{paper:.0f}",
                f"{paper / med:.0f}x",
            ]
        )
        log(f"table 1: {tex.paper} done")
    ours = [v["median_s"] for v in data.values()]
    paper = [v["paper_s"] for v in data.values()]
    names = [v["paper_name"] for v in data.values()]
    order_o = " < ".join(names[i] for i in np.argsort(ours, kind="stable"))
    order_p = " < ".join(names[i] for i in np.argsort(paper, kind="stable"))
    md = [
        f"### 000 Table 1 analogue: GA wall time, {SET}, plain E, seeds {seeds}, {threads} threads\n",
        md_table(
            [
                "texture",
                "example (000)",
                "tile (000)",
                "GA s (median)",
                "range s",
                "generations",
                "evaluations",
                "000 GA s",
                "000 / ours",
            ],
            rows,
        ),
        f"\nTextures by GA time: ours {order_o}; 000 {order_p} (Spearman {spearman(ours, paper):+.2f}).",
    ]
    return "\n".join(md), data


# ----------------------------------------------------------------------------------------------- schemes
@dataclass(frozen=True)
class Scheme:
    name: str
    build: (
        Callable[[np.ndarray, int, int, int], Any] | None
    )  # (exemplar, tile size, seed, threads) -> TileSet
    pending: str = ""


def _wang_size(ex: np.ndarray, n: int) -> int:
    """The ω tile size, or less where Wang samples (N + the default overlap N/4) would not fit the exemplar."""
    fit = int(min(ex.shape[:2]) / 1.25)
    return min(n, fit - fit % 2)


SCHEMES: list[Scheme] = [
    Scheme(
        "ω-16", lambda ex, n, seed, th: ts.build_omega(ex, tileset="16a", tile_size=n, seed=seed, threads=th)
    ),
    Scheme(
        "ω-N2 random",
        lambda ex, n, seed, th: ts.build_omega(ex, tileset="n2", tile_size=n, seed=seed, threads=th),
    ),
    Scheme(
        "ω-N2 + AIS",
        lambda ex, n, seed, th: ts.build_omega(
            ex, tileset="n2", tile_size=n, seed=seed, threads=th, select="ais", normalise=True
        ),
    ),
    Scheme(
        "ω-16 + smooth",
        lambda ex, n, seed, th: ts.build_omega(
            ex, tileset="16a", tile_size=n, seed=seed, threads=th, smooth=True
        ),
    ),
    Scheme(
        "Wang-18 + GA",
        lambda ex, n, seed, th: ts.build_wang(
            ex, tileset="wang18", tile_size=_wang_size(ex, n), seed=seed, threads=th, select="ga"
        ),
    ),
    Scheme(
        "s-Wang-8",
        lambda ex, n, seed, th: ts.build_swang(ex, tileset="wang8", tile_size=n, seed=seed, threads=th),
    ),
    Scheme(
        "patch-16 (random crops)",
        lambda ex, n, seed, th: ts.build(
            ex, scheme="patch", tileset="16a", tile_size=n, seed=seed, threads=th
        ),
    ),
]
"""The schemes compared; a new one is one entry (``build`` returns a TileSet that ``tilesynth.synthesize`` lays)."""


def schemes_table(
    found: list, seeds: list[int], size: tuple[int, int], threads: int, log: Callable[[str], None]
) -> tuple[str, dict]:
    rows, data = [], {}
    summary: dict[str, dict[str, list[float]]] = {}
    keys = ("seam", "rms", "energy", "coverage", "evenness", "repetition")
    for tex, ex, n in found:
        data[tex.file] = {}
        for sch in SCHEMES:
            if sch.build is None:
                rows.append([tex.paper, sch.name, "", "", "", "", "", "", sch.pending])
                continue
            t0 = time.perf_counter()
            tset = sch.build(ex, n, 1, threads)
            build_s = time.perf_counter() - t0
            per: dict[str, list[float]] = {k: [] for k in keys}
            offsets = []
            for s in seeds:
                m = metrics.tileset_metrics(tset, size[0], size[1], seed=s, threads=threads)
                per["seam"].append(m["seam"]["score"])
                per["rms"].append(m["coherence"]["rms"])
                per["energy"].append(m["coherence"]["energy"])
                per["coverage"].append(m["coverage"]["fraction"])
                per["evenness"].append(m["coverage"]["evenness"])
                per["repetition"].append(
                    m["repetition"]["peak"] if m["repetition"]["peak"] is not None else 0.0
                )
                offsets.append(m["repetition"]["offset"])
            mean = {k: float(np.mean(v)) for k, v in per.items()}
            data[tex.file][sch.name] = {
                "per_seed": per,
                "mean": mean,
                "offsets": offsets,
                "build_s": build_s,
                "n_tiles": tset.n_tiles,
                "E_normalised_f": metrics.objective(tset)["f_normalised"],
            }
            for k, v in mean.items():
                summary.setdefault(sch.name, {}).setdefault(k, []).append(v)
            off = ", ".join("-" if o is None else f"({o[0]},{o[1]})" for o in offsets)
            rows.append(
                [
                    tex.paper,
                    sch.name,
                    str(tset.n_tiles),
                    f"{mean['seam']:.3f}",
                    f"{mean['rms']:.4f}",
                    f"{mean['coverage']:.3f}",
                    f"{mean['evenness']:.3f}",
                    f"{mean['repetition']:.3f}",
                    f"at {off}; build {build_s:.1f} s",
                ]
            )
        log(f"schemes: {tex.paper} done")
    srows = []
    for sch in SCHEMES:
        if sch.build is None:
            srows.append([sch.name, "", "", "", "", "", sch.pending])
            continue
        s = summary[sch.name]
        srows.append(
            [
                sch.name,
                f"{np.mean(s['seam']):.3f}",
                f"{np.mean(s['rms']):.4f}",
                f"{np.mean(s['energy']):.4g}",
                f"{np.mean(s['coverage']):.3f}",
                f"{np.mean(s['evenness']):.3f}",
                f"{np.mean(s['repetition']):.3f}",
            ]
        )
    md = [
        f"### Schemes: {size[0]}x{size[1]} samples, tiling seeds {seeds}, build seed 1, tile sizes as Table 2\n",
        "seam = border seam score (1 = invisible borders); coherence = rms of the exact per-patch minimum SSD "
        "(8x8, stride 4); coverage = share of exemplar pixels used; evenness = normalised entropy of the use; "
        "repetition = strongest non-zero autocorrelation peak (and its offsets).\n",
        md_table(
            [
                "texture",
                "scheme",
                "tiles",
                "seam",
                "coherence rms",
                "coverage",
                "evenness",
                "repetition",
                "notes",
            ],
            rows,
        ),
        "\nMean over the textures:\n",
        md_table(
            ["scheme", "seam", "coherence rms", "coherence energy", "coverage", "evenness", "repetition"],
            srows,
        ),
    ]
    return "\n".join(md), data


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--textures", type=Path, default=Path(os.environ.get("TILESYNTH_TEXTURES", DEFAULT_TEXTURES))
    )
    p.add_argument("--only", choices=("table2", "table1", "schemes"), action="append")
    p.add_argument("--quick", action="store_true", help="1 seed and 256x256 samples")
    p.add_argument("--seeds", type=int, default=None, help="seeds per measurement (default 3; --quick 1)")
    p.add_argument(
        "--size",
        default=None,
        help="sample size WxH of the scheme comparison (default 512x512; --quick 256x256)",
    )
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--out", type=Path, default=None, help="also write the Markdown here")
    p.add_argument("--json", type=Path, default=None, help="write every number here")
    a = p.parse_args(argv)
    if not a.textures.is_dir():
        p.error(f"--textures {a.textures}: not a directory (set TILESYNTH_TEXTURES)")
    seeds = list(range(1, (a.seeds or (1 if a.quick else 3)) + 1))
    w, h = (int(v) for v in (a.size or ("256x256" if a.quick else "512x512")).lower().split("x"))
    t_start = time.perf_counter()

    def log(text: str) -> None:
        print(f"[{time.perf_counter() - t_start:6.1f} s] {text}", file=sys.stderr, flush=True)

    found = textures_found(a.textures)
    if not found:
        p.error(f"--textures {a.textures}: none of {', '.join(t.file for t in TEXTURES)} found")
    only = set(a.only or ("table2", "table1", "schemes"))
    head = (
        f"## tilesynth paper tables — tilesynth {ts.__version__}, CPython {platform.python_version()}, "
        f"numpy {np.__version__}, {os.cpu_count()} cores, {'quick' if a.quick else 'full'} mode\n"
    )
    print(head, flush=True)
    parts, report = [head], {"seeds": seeds, "size": [w, h], "threads": a.threads, "quick": a.quick}
    # warm-up: page in the extension and the FFT plans, so the first timing is not an outlier
    run_selection(found[0][1], found[0][2], "best-of", 0, a.threads, True, count=10)
    for name, fn in (
        ("table2", lambda: table2(found, seeds, a.threads, log)),
        ("table1", lambda: table1(found, seeds, a.threads, log)),
        ("schemes", lambda: schemes_table(found, seeds, (w, h), a.threads, log)),
    ):
        if name in only:
            md, data = fn()
            parts.append(md)
            report[name] = data
            print(md + "\n", flush=True)
    took = time.perf_counter() - t_start
    parts.append(f"\n(total {took:.0f} s)")
    print(parts[-1])
    report["total_s"] = took
    if a.out:
        a.out.write_text(head + "\n" + "\n\n".join(parts[1:]) + "\n", encoding="utf-8")
    if a.json:
        a.json.write_text(json.dumps(report, indent=1, default=float), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
