#!/usr/bin/env python3
"""Selection for the default set c5 (issue 15, helper selq4): the ceiling of best-of-K random gene vectors, and a
cheap rule that builds only a small window of the 625 tiles per candidate.

**Collect** (per texture): ``--pool`` single random draws (``build_omega(seed=1000+i, border_tries=1)``: the
random baseline of ``benches/selection_c5.py``), ``--seeds`` builds of today's default (border-aware "obord"
draw, seeds 1..). Every build is scored by ``benches/selection.py``'s :func:`visible_measures` (the tiles' cut
score and cut seam, and of a 512² synthesis with seed 1 coherence, texture statistics, histogram, coverage).
The pool is the random draws themselves (their gene vectors). Every pool vector is also measured on the
cheap **window proxies** (:class:`WindowJudge`, as :mod:`tilesynth.builder.genes.window_objective`): the tiles of one
``W x W``-cell window of the hashed tiling (tiler seed 7919, not the scored seed 1; the cells' tile indices do
not depend on the genes, so every candidate builds the same <= W² tuples) are built, their cut seam and cut
score taken, and the window's image (W·N pixels square) measured for coherence (exact; W = 8: a fixed sample of
400 patches) and texture statistics;
also the predicted border seam S_pred (:mod:`tilesynth.builder.genes.omega_borders`). CPU time (``time.process_time``) of
every build, evaluation and proxy.

**Replay**: the ceiling (the expected best of K pool vectors by the evaluation itself, per measure, exact over
all K-subsets of the pool) and rules ``K:keys`` / ``K/F:keys`` (of K pool vectors, or of the K best of F by the
border criterion ``scap``, the one with the smallest rank sum of the keys: window proxies ``w<W>_seam|cut|coh|tex``,
``scap``, or the oracles ``e_<measure>``; gain of its evaluated measures, median over ``--subsets`` random
subsets); gains in % over the median of the random draws. ``--cost N``: the CPU of random / default / window
builds, interleaved.

Usage::

    OPENBLAS_NUM_THREADS=1 python benches/selection_c5_cheap.py --textures gravel.png,beans.png --json a.json
    python benches/selection_c5_cheap.py --replay a.json b.json --rules "4/8:w8_seam+w8_coh+w8_tex,8:w8_seam"
    OPENBLAS_NUM_THREADS=1 python benches/selection_c5_cheap.py --cost 3 --textures gravel.png,beans.png
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import tilesynth as ts

sys.path.insert(0, str(Path(__file__).resolve().parent))
from selection import DEFAULT_TEXTURES, VISIBLE_MEASURES, _gain, load, visible_measures  # noqa: E402
from selection_cheap import fit  # noqa: E402

TEXTURES = ("gravel.png", "beans.png", "caustics.png", "grapes.png", "tomatoes.png", "crackers.png")
TUNING = (
    "pebbles.png",
    "rust.png",
    "sea-foam.png",
    "bricks-brown.png",
    "lettuce-leaves.png",
    "cracked-mud.png",
)
WINDOWS = (3, 4, 6, 8)
COH_SAMPLE = {8: 400}  # patches of the coherence estimate (None: exact)
PROXY_SEED = 7919
TARGETS = ("cut_seam", "coherence", "texstats")


class C5Builder:
    """The stages of ``build_omega(ex)`` with c5's defaults, callable on a subset of the tiles."""

    def __init__(self, ex: np.ndarray, threads: int | None) -> None:
        from tilesynth.builder.omega import omega_options
        from tilesynth.builder.options import common_options
        from tilesynth.layouts.complete import complete_defaults
        from tilesynth.layouts.corners import CornerPlan, corner_set

        b = common_options(ex, tileset="c5", resolve_set=corner_set, seed=0, threads=threads)
        comp = complete_defaults(b.definition, b.exemplar.shape, "ssd", "color")
        import dataclasses

        self.b = dataclasses.replace(b, tile_size=comp["tile_size"], progress=lambda *a: None)
        self.opts = omega_options(
            eps=ts.kernels.DEFAULT_EPS, gradients="patch", keep_border=True, match="ssd", match_k=None,
            metric="color", smooth=False, normalise=False, cut_region=comp["cut_region"], cut_bias=None,
            diversity=comp["diversity"], augment="none",
        )  # fmt: skip
        self.plan = CornerPlan.of(b.definition)
        assert self.plan.n_variants == 1
        self.n = self.b.tile_size
        self.ex = self.b.exemplar
        from tilesynth.layouts.hashed import lookup_scheme

        self.scheme = lookup_scheme(b.definition)

    def window(self, cells: int, seed: int = PROXY_SEED) -> np.ndarray:
        from tilesynth.layouts.hashed import index_map

        return np.asarray(index_map(self.scheme, seed, (cells, cells)))

    def build_tiles(self, genes: np.ndarray, tile_idx: np.ndarray) -> Any:
        from tilesynth.builder.omega import tile_stages
        from tilesynth.layouts.corners import CornerPlan

        rows = self.plan.inverse[tile_idx]
        k = len(tile_idx)
        sub = CornerPlan(
            self.plan.tile_patches[tile_idx], self.plan.unique[rows], np.arange(k), np.zeros(k, np.int64), 1,
            self.plan.n_colours,
        )  # fmt: skip
        return tile_stages(self.b, self.opts, sub, np.asarray(genes), smooth=False)


class WindowJudge:
    """Proxy measures of one candidate on a window of the hashed tiling (see the module docstring)."""

    def __init__(self, builder: C5Builder, cells: int, sample: int | None = None) -> None:
        from tilesynth.builder.genes.visible_objective import ProxyJudge

        self.sample = sample
        self.builder = builder
        self.imap = builder.window(cells)
        self.uniq, self.pos = np.unique(self.imap, return_inverse=True)
        self.pos = self.pos.reshape(self.imap.shape)
        self.judge = ProxyJudge(builder.ex, builder.n, builder.b.threads)

    def measures(self, genes: np.ndarray) -> dict[str, float]:
        from tilesynth.builder.genes.visible_objective import coherence_estimate, texture_stats_estimate
        from tilesynth.measure.metrics import cut_seam_score
        from tilesynth.measure.quality import cut_score

        t0 = time.process_time()
        res = self.builder.build_tiles(genes, self.uniq)
        t_build = time.process_time() - t0
        n = self.builder.n
        r, c = self.imap.shape
        img = res.tiles[self.pos].transpose(0, 2, 1, 3, 4).reshape(r * n, c * n, -1)

        class _T:
            tiles = res.tiles
            cut_masks = res.masks

        seam = cut_seam_score(_T)
        t1 = time.process_time()
        coh = coherence_estimate(
            img, self.judge.index.image, self.judge.index, self.builder.b.threads, self.sample
        )
        t_coh = time.process_time() - t1
        return {
            "t_build": t_build,
            "t_coh": t_coh,
            "seam": float("nan") if seam is None else float(seam["score"]),
            "cut": cut_score(res.costs, n),
            "coh": coh,
            "tex": texture_stats_estimate(img.astype(np.float64), self.judge.grams),
        }


def collect(a: argparse.Namespace) -> dict[str, Any]:
    from tilesynth.builder.genes.omega_borders import predicted_corner_border_seam

    out: dict[str, Any] = {"textures": {}, "args": {k: str(v) for k, v in vars(a).items()}}
    for name in a.textures.split(","):
        ex = fit(load(a.dir / name), a.fit)
        bld = C5Builder(ex, a.threads)
        t0 = time.process_time()
        judges = {w: WindowJudge(bld, w, COH_SAMPLE.get(w)) for w in WINDOWS}
        judge_cpu = time.process_time() - t0
        rec: dict[str, Any] = {
            "random": [], "random_cpu_s": [], "default": [], "default_cpu_s": [], "pool": [],
            "judge_setup_cpu_s": judge_cpu, "tile_size": bld.n, "shape": list(ex.shape),
        }  # fmt: skip
        out["textures"][name] = rec
        for i in range(max(a.pool, a.seeds)):  # interleaved: one random draw (= pool vector), one default
            if i < a.pool:
                t0 = time.process_time()
                tset = ts.build_omega(ex, tileset="c5", seed=1000 + i, threads=a.threads, border_tries=1)
                build_cpu = time.process_time() - t0
                g = np.asarray(tset.genes)
                t0 = time.process_time()
                ev = visible_measures(tset, a.size, a.threads)
                eval_cpu = time.process_time() - t0
                del tset
                row: dict[str, Any] = {"genes": g.tolist(), "build_cpu_s": build_cpu, "eval": ev}
                row["eval_cpu_s"] = eval_cpu
                t0 = time.process_time()
                row["spred"] = predicted_corner_border_seam(ex, g, bld.n)
                row["t_spred"] = time.process_time() - t0
                for w, j in judges.items():
                    t0 = time.process_time()
                    for k, v in j.measures(g).items():
                        row[f"w{w}_{k}"] = v
                    row[f"t_w{w}"] = time.process_time() - t0
                rec["pool"].append(row)
                rec["random"].append(ev)
                rec["random_cpu_s"].append(build_cpu)
            if i < a.seeds:
                t0 = time.process_time()
                tset = ts.build_omega(ex, tileset="c5", seed=1 + i, threads=a.threads)
                rec["default_cpu_s"].append(time.process_time() - t0)
                rec["default"].append(visible_measures(tset, a.size, a.threads))
            print(f"  {name} {i}", file=sys.stderr, flush=True)
            if a.json:
                a.json.write_text(json.dumps(out, default=float))
    return out


# ------------------------------------------------------------------------------------------------ replay
def _medians(rec: dict[str, Any]) -> dict[str, float]:
    return {k: float(np.nanmedian([r[k] for r in rec["random"]])) for _, k, _ in VISIBLE_MEASURES}


def expected_best(values: np.ndarray, k: int) -> float:
    """E[min of a uniformly random k-subset of ``values``] (exact, by order statistics)."""
    v = np.sort(values)
    n = len(v)
    if k >= n:
        return float(v[0])
    total = math.comb(n, k)
    return float(sum(v[i] * math.comb(n - 1 - i, k - 1) for i in range(n - k + 1)) / total)


def ceiling(data: dict[str, Any], ks: tuple[int, ...]) -> None:
    print(
        "\n### Ceiling: expected best of K pool vectors by the evaluation itself (gain % over the random median)\n"
    )
    print("| texture | " + " | ".join(f"{m} best-of {k}" for m in TARGETS for k in ks) + " | pool median "
          + " | ".join(TARGETS) + " |")  # fmt: skip
    print("|" + "---|" * (1 + len(TARGETS) * len(ks) + len(TARGETS)))
    acc: dict[str, list[float]] = {}
    for name, rec in data["textures"].items():
        med = _medians(rec)
        cells = []
        for m in TARGETS:
            vals = np.array([r["eval"][m] for r in rec["pool"]])
            for k in ks:
                g = _gain(expected_best(vals, k), med[m], -1)
                acc.setdefault(f"{m}{k}", []).append(g)
                cells.append(g)
        for m in TARGETS:
            g = _gain(float(np.median([r["eval"][m] for r in rec["pool"]])), med[m], -1)
            acc.setdefault(f"{m}med", []).append(g)
            cells.append(g)
        print(f"| {name} | " + " | ".join(f"{c:+.1f}" for c in cells) + " |")
    keys = [f"{m}{k}" for m in TARGETS for k in ks] + [f"{m}med" for m in TARGETS]
    print("| **mean** | " + " | ".join(f"**{np.mean(acc[k]):+.1f}**" for k in keys) + " |")


def _pick(rows: list[dict[str, Any]], keys: list[str]) -> int:
    from tilesynth.builder.genes.visible_objective import pick_by_ranks

    return pick_by_ranks(rows, tuple(keys))


def _rule_rows(rec: dict[str, Any], keys: list[str]) -> list[dict[str, float]]:
    out = []
    for r in rec["pool"]:
        d = {}
        for k in keys:
            if k == "scap":  # the obord criterion: log distance of S_pred to 0.8, above 1 last
                s = r["spred"]
                d[k] = abs(math.log(s / 0.8)) if 0 < s <= 1 else 1e6 + s
            elif k.startswith("e_"):  # an oracle: the evaluated measure itself
                d[k] = r["eval"][k[2:]]
            else:
                d[k] = r[k]
        out.append(d)
    return out


def rule_gains(rec: dict[str, Any], rule: str, subsets: int, rng: np.random.Generator) -> tuple[dict, float]:
    """Gains (per visible measure) of rule ``K:key+key`` or ``K/F:key+key`` over the random median: of a random
    F-subset of the pool (F = K without ``/F``), the K best by the border criterion ``scap`` (free: S_pred) are
    ranked by the sum of ranks of the keys; the median over ``subsets`` subsets of the chosen vector's evaluated
    measures. Also the proxy CPU s of one pick (K x the median proxy time of the windows the keys use)."""
    head, spec = rule.split(":", 1)
    k_s, _, f_s = head.partition("/")
    k = int(k_s)
    f = int(f_s) if f_s else k
    keys = spec.split("+")
    rows = _rule_rows(rec, [*keys, "scap"])
    n = len(rec["pool"])
    picks = []
    for _ in range(subsets):
        idx = rng.choice(n, f, replace=False)
        if f > k:
            idx = idx[np.argsort([rows[i]["scap"] for i in idx], kind="stable")[:k]]
        picks.append(int(idx[_pick([rows[i] for i in idx], keys)]))
    med = _medians(rec)
    val = {m: float(np.nanmedian([rec["pool"][i]["eval"][m] for i in picks])) for _, m, _ in VISIBLE_MEASURES}
    tkeys = {f"t_w{w}" for key in keys for w in WINDOWS if key.startswith(f"w{w}_")}
    cost = k * sum(float(np.median([r[t] for r in rec["pool"]])) for t in tkeys)
    return {m: _gain(val[m], med[m], sg) for _, m, sg in VISIBLE_MEASURES}, cost


def rules_table(data: dict[str, Any], rules: list[str], subsets: int, detail: list[str]) -> None:
    print("\n| rule | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " | min of 3 | proxy CPU s |")
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 3))
    per: dict[str, list[tuple[str, dict]]] = {}
    for rule in rules:
        gs, costs = [], []
        for name, rec in data["textures"].items():
            g, c = rule_gains(rec, rule, subsets, np.random.default_rng(12345))
            gs.append(g)
            costs.append(c)
            per.setdefault(rule, []).append((name, g))
        m = {k: float(np.mean([g[k] for g in gs])) for _, k, _ in VISIBLE_MEASURES}
        print(f"| {rule} | " + " | ".join(f"{m[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES)
              + f" | {min(m[t] for t in TARGETS):+.1f} | {np.median(costs):.2f} |")  # fmt: skip
    for rule in detail:
        print(f"\n#### {rule}, per texture\n")
        print("| texture | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " |")
        print("|" + "---|" * (len(VISIBLE_MEASURES) + 1))
        for name, g in per[rule]:
            print(f"| {name} | " + " | ".join(f"{g[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES) + " |")


def default_table(data: dict[str, Any]) -> None:
    print("\n### Today's default (obord) and the pool's cost\n")
    print("| texture | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " |")
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 1))
    gs = []
    for name, rec in data["textures"].items():
        if not rec["default"]:
            continue
        med = _medians(rec)
        val = {k: float(np.nanmedian([r[k] for r in rec["default"]])) for _, k, _ in VISIBLE_MEASURES}
        g = {k: _gain(val[k], med[k], sg) for _, k, sg in VISIBLE_MEASURES}
        gs.append(g)
        print(f"| {name} | " + " | ".join(f"{g[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES) + " |")
    if gs:
        m = {k: np.mean([g[k] for g in gs]) for _, k, _ in VISIBLE_MEASURES}
        print("| **mean** | " + " | ".join(f"**{m[k]:+.1f}**" for _, k, _ in VISIBLE_MEASURES) + " |")
    recs = list(data["textures"].values())
    rc = np.median([v for r in recs for v in r["random_cpu_s"]])
    dc = np.median([v for r in recs for v in r["default_cpu_s"]] or [np.nan])
    pc = np.median([p["build_cpu_s"] for r in recs for p in r["pool"]])
    ec = np.median([p["eval_cpu_s"] for r in recs for p in r["pool"]])
    tw = {w: np.median([p[f"t_w{w}"] for r in recs for p in r["pool"]]) for w in WINDOWS}
    js = np.median([r["judge_setup_cpu_s"] for r in recs])
    print(
        f"\nmedian CPU s: single random build {rc:.3f}, default (obord) build {dc:.3f}, given-genes build {pc:.3f},"
        f" evaluation {ec:.3f}, judge set-up (both windows) {js:.3f}, "
        + ", ".join(f"window {w} proxy {tw[w]:.3f}" for w in WINDOWS)
    )


def correlations(data: dict[str, Any], keys: list[str]) -> None:
    from scipy.stats import spearmanr

    print("\n### Spearman of the proxies with the evaluated measures over the pool (mean over textures)\n")
    print("| proxy | " + " | ".join(TARGETS) + " |")
    print("|" + "---|" * (len(TARGETS) + 1))
    for k in keys:
        cells = []
        for m in TARGETS:
            rs = []
            for rec in data["textures"].values():
                rows = _rule_rows(rec, [k])
                x = [r[k] for r in rows]
                y = [p["eval"][m] for p in rec["pool"]]
                rs.append(spearmanr(x, y).statistic)
            cells.append(float(np.nanmean(rs)))
        print(f"| {k} | " + " | ".join(f"{c:+.2f}" for c in cells) + " |")


def cost(a: argparse.Namespace) -> None:
    """CPU s per build (``time.process_time``, one thread), interleaved per seed: a single random draw, today's
    default (obord) and ``objective="window"`` with ``--rerank`` candidates; medians and ratios to the default."""
    t: dict[str, list[float]] = {"random": [], "default": [], "window": []}
    for name in a.textures.split(","):
        ex = fit(load(a.dir / name), a.fit)
        for s in range(1, a.cost + 1):
            for mode, kw in (
                ("random", {"border_tries": 1}),
                ("default", {}),
                ("window", {"objective": "window", "rerank": a.rerank}),
            ):
                t0 = time.process_time()
                ts.build_omega(ex, tileset="c5", seed=s, threads=a.threads, **kw)
                t[mode].append(time.process_time() - t0)
        print(f"  cost {name} done", file=sys.stderr, flush=True)
    med = {k: float(np.median(v)) for k, v in t.items()}
    print(f"\n| mode | median CPU s per build ({len(t['default'])} builds each) | ratio to the default |")
    print("|---|---|---|")
    for k in ("random", "default", "window"):
        label = f"window, rerank {a.rerank}" if k == "window" else k
        print(f"| {label} | {med[k]:.3f} | {med[k] / med['default']:.2f}x |")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", type=Path, default=DEFAULT_TEXTURES)
    p.add_argument("--textures", default=",".join(TEXTURES))
    p.add_argument("--fit", type=int, default=None)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--pool", type=int, default=16)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", type=Path, default=None)
    p.add_argument("--replay", type=Path, nargs="*", default=None)
    p.add_argument("--rules", default="")
    p.add_argument("--detail", default="")
    p.add_argument("--subsets", type=int, default=400)
    p.add_argument("--ceiling", default="4,8,16")
    p.add_argument("--cost", type=int, default=0, help="only the CPU comparison, this many seeds per texture")
    p.add_argument("--rerank", type=int, default=None, help="--cost: candidates of the window objective")
    a = p.parse_args(argv)
    if a.replay:
        data: dict[str, Any] = {"textures": {}}
        for path in a.replay:
            d = json.loads(path.read_text())
            want = int(d["args"]["pool"])
            data["textures"].update({k: v for k, v in d["textures"].items() if len(v["pool"]) == want})
        default_table(data)
        ceiling(data, tuple(int(k) for k in a.ceiling.split(",")))
        proxies = ["scap", "spred"] + [f"w{w}_{m}" for w in WINDOWS for m in ("seam", "cut", "coh", "tex")]
        correlations(data, proxies)
        if a.rules:
            rules_table(data, a.rules.split(","), a.subsets, [r for r in a.detail.split(",") if r])
        return 0
    if a.cost:
        cost(a)
        return 0
    collect(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
