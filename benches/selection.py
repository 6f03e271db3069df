#!/usr/bin/env python3
"""Sample-patch selection, measured: speed against a side-by-side OpenCV evaluation loop, and quality (003 Table 2).

Two sections, each printed as Markdown (``--json`` also writes every figure):

1. ``speed``  On a 128x128 exemplar (``gravel.png``, 003's "stones") with 80x80 tiles and the N2 set (6 patches,
   38 tiles): wall time of the whole GA at 000's settings {pop 40, α 0.05, P_c 0.3, P_m 0.2, N_g 50, N_o 5} and of
   the whole AIS at 003's settings {N_p 40, s_min 0.2, s_max 0.4, α 0.4, β 4, N_d 10, N_g 50, N_o 6}, with a cold
   evaluator (no partial map cached when the run starts), at 2 threads, over several seeds (median, min, max).
   Side by side, in the same process: the *same* GA / AIS code driven by an evaluation loop that a Python user
   would write today, one ``cv2.matchTemplate(TM_SQDIFF)`` per intermediate tile (38 per individual) and the
   minimum of each map. Both evaluators are exact up to float32 rounding, so the runs follow nearly the same
   trajectory; the table gives both wall times, their evaluation counts and the ratio. Targets (issue 3): GA <= 2 s,
   AIS <= 5 s, ratio against the cv2 loop >= 20x. With ``--quick`` the cv2 runs are replaced by a projection
   (measured cv2 time per individual x the evaluations of our run), said so in the table.
2. ``quality`` For the textures 003's Table 2 names that are in ../shared/textures (beans, bread, caustics, eggs,
   gravel = "stones", grapes, school-fish = "school", tomatoes, grass-straw = "grass"), with 003's normalisation
   (C_j divided by the N·N overlapping pixels, summed over RGB) and its set-up (N2, 80x80 tiles; every exemplar at
   its native size, which is 128x128 or smaller for all but grapes, 144x144): f = 1/E for random (the mean of
   f over 100 random gene vectors), best-of-100 ("semi-random"), GA, AIS and AIS + polish, each also as a multiple
   of random, the mean over ``--seeds`` seeds, and 003's own random and AIS (40, 50) figures beside them.

3. ``visible`` (issue 15) The gains of selections (the default cut re-ranking, best-of by ΣD and by E, the cut
   polish, the GA) over the median of random gene vectors in what users see: the cut score and cut seam of the
   tiles, and of a 512² synthesis the coherence energy, texture-statistics and histogram distances and the
   coverage, per texture and set kind (n2, c4), as Markdown tables (``benches/selection-results.md``).

Usage::

    python benches/selection.py                 # everything (a few minutes)
    python benches/selection.py --quick         # fewer seeds, projected cv2 baseline
    python benches/selection.py --only quality --seeds 5 --json sel.json
    python benches/selection.py --only visible --kinds n2 --random 10 --seeds 3
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
from tilesynth.builder.genes.select import select_genes

HERE = Path(__file__).resolve().parent
DEFAULT_TEXTURES = HERE.parent.parent / "shared" / "textures"
N_TILE = 80
SET = "n2"

# 003 Table 2: (random, AIS at (N_p, N_g) = (40, 50)) affinities, for the textures we have.
PAPER_003 = {
    "beans.png": ("Beans", 0.179, 0.353),
    "caustics.png": ("Caustics", 0.137, 0.315),
    "gravel.png": ("Stones", 0.247, 0.418),
    "bread.png": ("Bread", 0.164, 0.285),
    "grapes.png": ("Grape", 0.237, 0.435),
    "grass-straw.png": ("Grass", 0.230, 0.423),
    "school-fish.png": ("School", 0.271, 0.451),
    "tomatoes.png": ("Tomato", 0.165, 0.296),
    "eggs.png": ("Eggs", 0.558, 0.998),
}


def tile_patches(set_name: str) -> tuple[np.ndarray, int]:
    defn = ts.get_tileset(set_name)
    index = {c: i for i, c in enumerate(defn.colours)}
    tp = np.array([[index[c] for c in t] for t in defn.tiles], dtype=np.int64)
    return np.unique(tp, axis=0), len(defn.colours)


class Cv2Loop:
    """E of a population with one cv2.matchTemplate(TM_SQDIFF) per intermediate tile (what a user writes today)."""

    def __init__(self, exemplar: np.ndarray, n: int, tp: np.ndarray, normalise: bool = False) -> None:
        import cv2

        self.cv2 = cv2
        self.ex = np.ascontiguousarray(exemplar, dtype=np.float32)
        self.n, self.tp, self.normalise = n, tp, normalise
        self.individuals = 0

    def tiles(self, genes: np.ndarray) -> np.ndarray:
        n, h = self.n, self.n // 2
        P = np.stack([self.ex[r : r + n, c : c + n] for r, c in genes])
        a, b, c, d = self.tp.T
        t = np.empty((len(self.tp), n, n, self.ex.shape[2]), np.float32)
        t[:, :h, :h] = P[a, h:, h:]
        t[:, :h, h:] = P[c, h:, :h]
        t[:, h:, :h] = P[b, :h, h:]
        t[:, h:, h:] = P[d, :h, :h]
        return t

    def __call__(self, pop: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        D = np.empty((pop.shape[0], len(self.tp)))
        for i, genes in enumerate(pop):
            for j, tile in enumerate(self.tiles(genes)):
                D[i, j] = float(self.cv2.matchTemplate(self.ex, tile, self.cv2.TM_SQDIFF).min())
        D = np.maximum(D, 0.0)
        if self.normalise:
            D /= self.n * self.n
        self.individuals += pop.shape[0]
        return 0.8 * D.sum(axis=1) + 0.2 * D.var(axis=1), D


def load(path: Path) -> np.ndarray:
    img, _ = ts.load_image(path)
    return img


def run_method(
    ex: np.ndarray,
    method: str,
    seed: int,
    threads: int | None,
    normalise: bool = False,
    polish: bool = False,
    evaluate: Any = None,
    **kw: Any,
) -> dict[str, Any]:
    tp, n_col = tile_patches(SET)
    t0 = time.perf_counter()
    if evaluate is None:
        ev = ts.PopulationEvaluator(ex, N_TILE, tp, n_col, normalise=normalise)
        evaluate = lambda g: ev.evaluate(g, threads)  # noqa: E731
    res = select_genes(method, evaluate, ex.shape, n_col, N_TILE, seed, polish=polish, **kw)
    wall = time.perf_counter() - t0
    return {
        "E": res.E,
        "f": 1.0 / res.E,
        "wall_s": wall,
        "evaluations": res.evaluations,
        "generations": res.generations,
        "stop": res.stop_reason,
        "genes": res.genes.tolist(),
    }


def md_table(headers: list[str], rows: list[list[Any]]) -> str:
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def section_speed(textures: Path, seeds: list[int], quick: bool, threads: int | None) -> dict[str, Any]:
    ex = load(textures / "gravel.png")
    assert ex.shape[:2] == (128, 128), ex.shape
    tp, n_col = tile_patches(SET)
    out: dict[str, Any] = {"exemplar": "gravel.png 128x128", "set": SET, "tile": N_TILE, "threads": threads}
    rows = []
    try:
        import cv2  # noqa: F401

        have_cv2 = True
    except ImportError:
        have_cv2 = False
    # warm-up (page in the FFT plans and the extension)
    run_method(ex, "best-of", 0, threads, count=10)
    for method, target in (("ga", 2.0), ("ais", 5.0)):
        runs = [run_method(ex, method, s, threads) for s in seeds]
        walls = [r["wall_s"] for r in runs]
        med = statistics.median(walls)
        info: dict[str, Any] = {"runs": runs, "median_s": med, "target_s": target}
        base_note = ""
        if have_cv2:
            loop = Cv2Loop(ex, N_TILE, tp)
            if quick:
                # per-individual cost of the cv2 loop on random populations, times our evaluation count
                pop = np.stack(
                    [
                        ts.omega.random_genes(ex.shape, n_col, N_TILE, np.random.default_rng(i))
                        for i in range(8)
                    ]
                )
                t0 = time.perf_counter()
                loop(pop)
                per = (time.perf_counter() - t0) / len(pop)
                cv2_s = per * statistics.median(r["evaluations"] for r in runs)
                base_note = "projected"
                info["cv2_per_individual_s"] = per
            else:
                r = run_method(ex, method, seeds[0], threads, evaluate=loop)
                cv2_s = r["wall_s"]
                info["cv2_run"] = r
                base_note = f"measured, seed {seeds[0]}, {r['evaluations']} evaluations, E {r['E']:.6g}"
            ratio = cv2_s / (runs[0]["wall_s"] if not quick else med)
            info.update({"cv2_s": cv2_s, "ratio": ratio})
        else:
            cv2_s, ratio = float("nan"), float("nan")
            base_note = "cv2 not installed"
        out[method] = info
        rows.append(
            [
                method.upper(),
                f"{med:.2f}",
                f"{min(walls):.2f}-{max(walls):.2f}",
                f"{statistics.median(r['evaluations'] for r in runs):.0f}",
                f"{statistics.median(r['generations'] for r in runs):.0f}",
                f"<= {target:g}",
                "yes" if med <= target else "**no**",
                f"{cv2_s:.1f} ({base_note})",
                f"{ratio:.0f}x",
                "yes" if ratio >= 20 else "**no**",
            ]
        )
    print(
        f"\n## Speed: {SET}, {N_TILE}x{N_TILE} tiles, gravel 128x128, threads={threads or 'default'}, "
        f"seeds {seeds}\n"
    )
    print(
        md_table(
            [
                "method",
                "median s",
                "range s",
                "evaluations",
                "generations",
                "target",
                "met",
                "cv2 loop s",
                "ratio",
                ">= 20x",
            ],
            rows,
        )
    )
    return out


def section_quality(textures: Path, seeds: list[int], threads: int | None) -> dict[str, Any]:
    tp, n_col = tile_patches(SET)
    out: dict[str, Any] = {}
    rows = []
    for name, (paper_name, p_rand, p_ais) in PAPER_003.items():
        path = textures / name
        if not path.exists():
            print(f"(skipping {name}: not found)", file=sys.stderr)
            continue
        ex = load(path)
        if min(ex.shape[:2]) < N_TILE:
            print(f"(skipping {name}: smaller than {N_TILE})", file=sys.stderr)
            continue
        per_seed: dict[str, list[float]] = {k: [] for k in ("random", "best-of", "ga", "ais", "ais+polish")}
        times: dict[str, list[float]] = {k: [] for k in per_seed}
        for s in seeds:
            ev = ts.PopulationEvaluator(ex, N_TILE, tp, n_col, normalise=True)
            rng = np.random.default_rng(10_000 + s)
            pop = np.stack([ts.omega.random_genes(ex.shape, n_col, N_TILE, rng) for _ in range(100)])
            t0 = time.perf_counter()
            E, _ = ev.evaluate(pop, threads)
            times["random"].append((time.perf_counter() - t0) / 100)
            per_seed["random"].append(float(np.mean(1.0 / E)))
            for key, method, polish in (
                ("best-of", "best-of", False),
                ("ga", "ga", False),
                ("ais", "ais", False),
            ):
                r = run_method(ex, method, s, threads, normalise=True, polish=polish)
                per_seed[key].append(r["f"])
                times[key].append(r["wall_s"])
            # polish starts from the AIS result of the same seed (same genes), so it is "AIS alone, then polish"
            ais_genes = np.array(r["genes"])
            ev2 = ts.PopulationEvaluator(ex, N_TILE, tp, n_col, normalise=True)
            t0 = time.perf_counter()
            g, Ep, _, info = ts.select.polish_genes(
                lambda p: ev2.evaluate(p, threads), ais_genes, ex.shape, N_TILE
            )
            per_seed["ais+polish"].append(1.0 / Ep)
            times["ais+polish"].append(times["ais"][-1] + time.perf_counter() - t0)
        mean = {k: float(np.mean(v)) for k, v in per_seed.items()}
        out[name] = {
            "f": per_seed,
            "time_s": times,
            "mean_f": mean,
            "shape": list(ex.shape),
            "paper": {"random": p_rand, "ais_40_50": p_ais},
        }
        r0 = mean["random"]
        rows.append(
            [
                f"{name} ({paper_name}) {ex.shape[1]}x{ex.shape[0]}",
                f"{r0:.3f}",
                f"{p_rand:.3f}",
                *(f"{mean[k]:.3f} ({mean[k] / r0:.2f}x)" for k in ("best-of", "ga", "ais", "ais+polish")),
                f"{p_ais:.3f} ({p_ais / p_rand:.2f}x)",
                f"{np.median(times['ga']):.1f} / {np.median(times['ais']):.1f} / {np.median(times['ais+polish']):.1f}",
            ]
        )
    print(
        f"\n## Quality: f = 1/E with 003's normalisation, {SET}, {N_TILE}x{N_TILE} tiles, mean over seeds {seeds}\n"
    )
    print(
        md_table(
            [
                "texture",
                "random",
                "003 random",
                "best-of-100",
                "GA",
                "AIS",
                "AIS + polish",
                "003 AIS (40,50)",
                "s GA / AIS / AIS+polish",
            ],
            rows,
        )
    )
    return out


# ------------------------------------------------------------------------------------------- visible (issue 15)
VISIBLE_TEXTURES = ("gravel.png", "beans.png", "caustics.png", "grapes.png", "tomatoes.png", "crackers.png")
VISIBLE_MEASURES = (
    ("cut score", "cut_score", -1),
    ("cut seam", "cut_seam", -1),
    ("coherence", "coherence", -1),
    ("texture stats", "texstats", -1),
    ("histogram", "histogram", -1),
    ("coverage", "coverage", +1),
)
"""(label, key, sign): sign -1 = smaller is better, +1 = larger is better."""


def visible_measures(tset: Any, size: int, threads: int | None) -> dict[str, float]:
    """What users see of a tile set: the cut score and cut seam of its tiles, and of a ``size``² synthesis
    (seed 1) the coherence energy, texture-statistics and histogram distances to the exemplar and the coverage."""
    from tilesynth.measure.metrics import coherence_energy, coverage, cut_seam_score, histogram_distance
    from tilesynth.measure.quality import cut_score, texture_stats_distance
    from tilesynth.synth.synthesis import source_map

    img, imap = ts.synthesize(tset, size, size, seed=1, threads=threads)
    src = source_map(tset, imap, size, size)
    seam = cut_seam_score(tset)
    return {
        "cut_score": cut_score(tset.cut_costs, tset.tile_size),
        "cut_seam": float("nan") if seam is None else float(seam["score"]),
        "coherence": float(coherence_energy(img, tset.exemplar, threads=threads).energy),
        "texstats": texture_stats_distance(img, tset.exemplar),
        "histogram": histogram_distance(img, tset.exemplar).distance,
        "coverage": coverage(src, tset.exemplar.shape).fraction,
    }


def _gain(value: float, median: float, sign: int) -> float:
    """Gain in % over the random median (positive = better)."""
    return 100.0 * (median - value) / median if sign < 0 else 100.0 * (value - median) / median


VISIBLE_CANDIDATES: dict[str, dict[str, Any]] = {
    "default (best-of 32, ΣD, cut re-rank 4)": {},
    "best-of 32 by ΣD": {"select": "best-of", "population": 32, "objective": "sum-d"},
    "best-of 32 by E": {"select": "best-of", "population": 32, "objective": "E"},
    "best-of 32, cut re-rank 8": {"select": "best-of", "population": 32, "objective": "cut", "rerank": 8},
    "default + cut polish": {"polish": True},
    "GA on E": {"select": "ga"},
}


def section_visible(
    textures: Path, kinds: list[str], n_random: int, seeds: list[int], size: int, threads: int | None,
    names: tuple[str, ...] = VISIBLE_TEXTURES, candidates: list[str] | None = None,
) -> dict[str, Any]:  # fmt: skip
    """Gains of selections over the median of ``n_random`` random gene vectors, per measure and texture.

    ``kinds``: "n2" (the papers' set: N2, 80-px tiles, circle cut) and/or "c4" (the default complete corner set:
    256 tiles of a quarter of the exemplar, free cut, diversity 1). Each candidate runs with every seed of
    ``seeds``; its measure is the median over them."""
    out: dict[str, Any] = {}
    cand_names = candidates or list(VISIBLE_CANDIDATES)
    for kind in kinds:
        base = {"tileset": "n2", "tile_size": N_TILE} if kind == "n2" else {"tileset": "c4"}
        cands = [c for c in cand_names if not (kind == "c4" and ("polish" in c or "GA" in c))]
        gains: dict[str, dict[str, dict[str, float]]] = {c: {} for c in cands}
        times: dict[str, list[float]] = {c: [] for c in ["random", *cands]}
        for name in names:
            path = textures / name
            if not path.exists():
                print(f"(skipping {name}: not found)", file=sys.stderr)
                continue
            ex = load(path)
            rand = []
            for s in range(n_random):
                t0 = time.process_time()
                tset = ts.build_omega(ex, seed=1000 + s, threads=threads, select="random", **base)
                times["random"].append(time.process_time() - t0)
                rand.append(visible_measures(tset, size, threads))
            med = {k: float(np.nanmedian([r[k] for r in rand])) for _, k, _ in VISIBLE_MEASURES}
            out.setdefault(kind, {}).setdefault(name, {"random_median": med, "random": rand})
            for c in cands:
                ms = []
                for s in seeds:
                    t0 = time.process_time()
                    tset = ts.build_omega(ex, seed=s, threads=threads, **base, **VISIBLE_CANDIDATES[c])
                    times[c].append(time.process_time() - t0)
                    ms.append(visible_measures(tset, size, threads))
                val = {k: float(np.nanmedian([m[k] for m in ms])) for _, k, _ in VISIBLE_MEASURES}
                gains[c][name] = {k: _gain(val[k], med[k], sg) for _, k, sg in VISIBLE_MEASURES}
                out[kind][name][c] = {"values": ms, "median": val, "gain_pct": gains[c][name]}
                print(f"  {kind} {name} {c}: " + ", ".join(f"{k} {v:+.1f}%" for k, v in gains[c][name].items()),
                      file=sys.stderr, flush=True)  # fmt: skip
        print(f"\n## Visible measures, set {kind}: gain in % over the median of {n_random} random gene vectors "
              f"(positive = better; candidates: median over seeds {seeds}; {size}x{size} synthesis)\n")  # fmt: skip
        for c in cands:
            rows = [[t, *(f"{g[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES)] for t, g in gains[c].items()]
            mean_row = ["**mean**", *(f"**{np.mean([g[k] for g in gains[c].values()]):+.1f}**"
                                      for _, k, _ in VISIBLE_MEASURES)]  # fmt: skip
            print(f"\n### {c} (median CPU s per build: {np.median(times[c]):.2f}, random "
                  f"{np.median(times['random']):.2f})\n")  # fmt: skip
            print(md_table(["texture", *(lbl for lbl, _, _ in VISIBLE_MEASURES)], [*rows, mean_row]))
        out.setdefault(kind, {})["_times_cpu_s"] = {c: float(np.median(v)) for c, v in times.items() if v}
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--textures", type=Path, default=Path(os.environ.get("TILESYNTH_TEXTURES", DEFAULT_TEXTURES))
    )
    p.add_argument("--only", choices=("speed", "quality", "visible"))
    p.add_argument("--kinds", default="n2,c4", help="visible: the set kinds, n2 and/or c4")
    p.add_argument("--random", type=int, default=12, help="visible: random gene vectors per texture")
    p.add_argument("--size", type=int, default=512, help="visible: side of the synthesis")
    p.add_argument(
        "--candidates", default=None, help="visible: semicolon-separated candidate names (default all)"
    )
    p.add_argument("--quick", action="store_true", help="one seed per measurement, projected cv2 baseline")
    p.add_argument(
        "--seeds", type=int, default=None, help="seeds per measurement (default 5 speed, 3 quality)"
    )
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--json", type=Path, default=None)
    a = p.parse_args(argv)
    if not a.textures.is_dir():
        p.error(f"--textures {a.textures}: not a directory (set TILESYNTH_TEXTURES)")
    print(
        f"# tilesynth benches/selection.py — tilesynth {ts.__version__}, CPython {platform.python_version()}, "
        f"{os.cpu_count()} cores, numpy {np.__version__}"
    )
    report: dict[str, Any] = {}
    if a.only in (None, "speed"):
        n = 1 if a.quick else (a.seeds or 5)
        report["speed"] = section_speed(a.textures, list(range(1, n + 1)), a.quick, a.threads)
    if a.only in (None, "quality"):
        n = 1 if a.quick else (a.seeds or 3)
        report["quality"] = section_quality(a.textures, list(range(1, n + 1)), a.threads)
    if a.only in (None, "visible"):
        n = 1 if a.quick else (a.seeds or 3)
        report["visible"] = section_visible(
            a.textures, a.kinds.split(","), 4 if a.quick else a.random, list(range(1, n + 1)), a.size,
            a.threads, candidates=None if a.candidates is None else a.candidates.split(";"),
        )  # fmt: skip
    if a.json:
        a.json.write_text(json.dumps(report, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
