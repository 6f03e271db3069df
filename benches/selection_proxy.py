#!/usr/bin/env python3
"""Selection by the visible measures on a proxy (issue 15): the data behind the choice of the default selection.

For each texture and each build seed, the default's first stage (best-of ``--count`` random gene vectors by ΣD,
the same draws as ``build_omega(seed=s)``) keeps its ``--keep`` best candidates; each is built, and measured twice:

* on the **proxy** the selection may see: the tiles' own cut score and cut seam, and a small synthesis with a
  different seed and size than the evaluation (:class:`tilesynth.builder.genes.visible_objective.ProxyJudge`: a 256² synthesis with
  seed :data:`tilesynth.builder.genes.visible_objective.PROXY_SEED` = 7919 at 80-px tiles): coherence, texture statistics;
* on the **evaluation** the bench scores: a ``--size``² synthesis with seed 1 (exactly
  ``benches/selection.py``'s :func:`visible_measures`).

The random baseline is ``benches/selection.py``'s: ``--random`` builds with ``select="random"`` (seeds 1000+).
Every record goes to ``--json``; :func:`strategies` then replays selection rules offline (which candidate each
rule would keep, from the proxy only) and prints the gains of the evaluation measures over the random median,
per texture and as means. A rule never sees the evaluation synthesis (other seed, other size).

Usage::

    OPENBLAS_NUM_THREADS=1 python benches/selection_proxy.py --json /tmp/proxy.json
    python benches/selection_proxy.py --replay /tmp/proxy.json
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import tilesynth as ts
import tilesynth.builder.genes.cut_objective as cutselect

sys.path.insert(0, str(Path(__file__).resolve().parent))
from selection import DEFAULT_TEXTURES, VISIBLE_MEASURES, _gain, load, visible_measures  # noqa: E402


def _fast_gram_patch() -> None:
    """Speed the evaluation's texture statistics: the 25 x 25 Gram product by BLAS (run with
    OPENBLAS_NUM_THREADS=1) instead of einsum; the value is the same up to float rounding."""
    import tilesynth.measure.quality as q

    slow = q._gram

    def gram(img: np.ndarray) -> np.ndarray:
        h, w, c = img.shape
        k = q.TEXSTATS_SIZE
        fh, fw = q._fast_len(h + k - 1), q._fast_len(w + k - 1)
        spec = np.fft.rfft2(img.transpose(2, 0, 1), s=(fh, fw), axes=(1, 2))
        kern = q._filter_spectra(c, fh, fw)
        acc = spec[0][None] * kern[0]
        for ch in range(1, c):
            acc += spec[ch][None] * kern[ch]
        resp = np.fft.irfft2(acc, s=(fh, fw), axes=(1, 2))[:, k - 1 : h, k - 1 : w]
        r = np.empty((resp.shape[0] + 1, resp.shape[1] * resp.shape[2]))
        np.maximum(resp.reshape(resp.shape[0], -1), 0.0, out=r[:-1])
        r[-1] = 1.0
        return (r @ r.T) / r.shape[1]

    gram.slow = slow  # type: ignore[attr-defined]
    q._gram = gram


TEXTURES = ("gravel.png", "beans.png", "caustics.png", "grapes.png", "tomatoes.png", "crackers.png")


def proxy_measures(tset: Any, judge: Any) -> dict[str, float]:
    """The library's proxy (:class:`tilesynth.builder.genes.visible_objective.ProxyJudge`) plus the tiles' cut score and the proxy's
    histogram distance (for rules that use them)."""
    from tilesynth.measure.quality import cut_score

    out = judge.measures(tset)
    out["cut_score"] = cut_score(tset.cut_costs, tset.tile_size)
    return out


def candidates(ex: np.ndarray, seed: int, keep: int, count: int, base: dict[str, Any], threads: int | None):
    """The ``keep`` best gene vectors by ΣD of the default's first stage (best-of ``count``), best first."""
    got: list[list[np.ndarray]] = []
    orig = cutselect.rerank

    def capture(cands, build, tile_size, progress=None):
        got.append([np.asarray(g) for g in cands])
        return orig(cands[:1], build, tile_size, progress)

    cutselect.rerank = capture
    try:
        ts.build_omega(ex, seed=seed, threads=threads, rerank=keep, population=count, **base)
    finally:
        cutselect.rerank = orig
    return got[0]


EVAL_RULES = ("1:sumd", "4:cut", "4:rank3", "6:rank3", "8:rank3", "8:logsum3", "8:rank4")
"""The rules whose picks are evaluated (the evaluation synthesis is the costly part; other candidates are not)."""


def collect(a: argparse.Namespace) -> dict[str, Any]:
    from tilesynth.builder.genes.visible_objective import ProxyJudge

    kind = a.kind
    base = {"tileset": "n2", "tile_size": 80} if kind == "n2" else {"tileset": kind}
    out: dict[str, Any] = {"kind": kind, "textures": {}, "args": vars(a)}
    for name in a.textures.split(","):
        ex = load(a.dir / name)
        rec: dict[str, Any] = {"random": [], "seeds": {}}
        out["textures"][name] = rec
        t_rand = []
        for s in range(a.random):
            t0 = time.process_time()
            tset = ts.build_omega(ex, seed=1000 + s, threads=a.threads, select="random", **base)
            t_rand.append(time.process_time() - t0)
            rec["random"].append(visible_measures(tset, a.size, a.threads))
        rec["random_cpu_s"] = t_rand
        for s in range(1, a.seeds + 1):
            cands = candidates(ex, s, a.keep, a.count, base, a.threads)
            rows, tsets = [], []
            judge = None
            for g in cands:
                t0 = time.process_time()
                tset = ts.build_omega(ex, genes=g, threads=a.threads, **base)
                t_build = time.process_time() - t0
                t0 = time.process_time()
                judge = judge or ProxyJudge(tset.exemplar, tset.tile_size, a.threads)
                prox = proxy_measures(tset, judge)
                rows.append({"genes": g.tolist(), "proxy": prox, "build_cpu_s": t_build,
                             "proxy_cpu_s": time.process_time() - t0})  # fmt: skip
                tsets.append(tset)
            for i in sorted({rule_pick(rows, r) for r in EVAL_RULES}):
                rows[i]["eval"] = visible_measures(tsets[i], a.size, a.threads)
            rec["seeds"][str(s)] = rows
            print(f"  {kind} {name} seed {s}: {len(rows)} candidates", file=sys.stderr, flush=True)
            if a.json:
                a.json.write_text(json.dumps(out, default=str))
    return out


# ------------------------------------------------------------------------------------------------ replay
PROXY_KEYS = ("cut_seam", "coherence", "texstats")


def rule_pick(rows: list[dict[str, Any]], rule: str) -> int:
    """Index of the candidate ``rule`` keeps (ties: the better one by ΣD, i.e. the lower index)."""
    k, _, how = rule.partition(":")
    n = int(k)
    rows = rows[:n]
    if how == "sumd":
        return 0
    if how == "cut":
        return int(np.argmin([r["proxy"]["cut_score"] for r in rows]))
    if how in PROXY_KEYS or how in ("histogram",):
        return int(np.argmin([r["proxy"][how] for r in rows]))
    keys = {
        "rank3": PROXY_KEYS,
        "rank4": (*PROXY_KEYS, "cut_score"),
        "rank5": (*PROXY_KEYS, "cut_score", "histogram"),
        "seamcoh": ("cut_seam", "coherence"),
        "seamcoh2tex": ("cut_seam", "coherence", "coherence", "texstats"),
        "logsum3": PROXY_KEYS,
        "logsum4": (*PROXY_KEYS, "histogram"),
    }[how]
    m = np.array([[r["proxy"][q] for q in keys] for r in rows])
    if not how.startswith("logsum"):
        from tilesynth.builder.genes.visible_objective import pick_by_ranks

        return pick_by_ranks([r["proxy"] for r in rows], keys)
    else:  # sum of logs: the product of the ratios to the candidates' median
        score = np.log(np.maximum(m, 1e-12) / np.median(m, axis=0)).sum(axis=1)
    return int(np.argmin(score + 1e-9 * np.arange(len(rows))))


def replay(data: dict[str, Any], rules: list[str], seeds: int | None = None) -> dict[str, Any]:
    res: dict[str, Any] = {}
    for rule in rules:
        per: dict[str, dict[str, float]] = {}
        for name, rec in data["textures"].items():
            med = {k: float(np.nanmedian([r[k] for r in rec["random"]])) for _, k, _ in VISIBLE_MEASURES}
            picks = []
            for _s, rows in list(rec["seeds"].items())[:seeds]:
                row = rows[rule_pick(rows, rule)]
                if "eval" not in row:
                    raise KeyError(f"{rule}: its pick was not evaluated (add it to EVAL_RULES)")
                picks.append(row["eval"])
            val = {k: float(np.nanmedian([p[k] for p in picks])) for _, k, _ in VISIBLE_MEASURES}
            per[name] = {k: _gain(val[k], med[k], sg) for _, k, sg in VISIBLE_MEASURES}
        res[rule] = per
    return res


def cpu_table(data: dict[str, Any]) -> None:
    """Median CPU seconds per candidate build and per proxy measurement, and per random build."""
    b = [
        r["build_cpu_s"] for rec in data["textures"].values() for rows in rec["seeds"].values() for r in rows
    ]
    q = [
        r["proxy_cpu_s"] for rec in data["textures"].values() for rows in rec["seeds"].values() for r in rows
    ]
    rnd = [v for rec in data["textures"].values() for v in rec["random_cpu_s"]]
    print(f"\nmedian CPU s: random build {np.median(rnd):.3f}, candidate build {np.median(b):.3f}, "
          f"proxy measures {np.median(q):.3f}")  # fmt: skip


def print_replay(res: dict[str, Any]) -> None:
    head = "| rule | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " | min of 3 targets |"
    print(head)
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 2))
    for rule, per in res.items():
        means = {k: np.mean([g[k] for g in per.values()]) for _, k, _ in VISIBLE_MEASURES}
        tgt = min(means["cut_seam"], means["coherence"], means["texstats"])
        print(
            f"| {rule} | "
            + " | ".join(f"{means[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES)
            + f" | {tgt:+.1f} |"
        )


def print_per_texture(res: dict[str, Any], rule: str) -> None:
    per = res[rule]
    print(f"\n### {rule}\n")
    print("| texture | " + " | ".join(lbl for lbl, _, _ in VISIBLE_MEASURES) + " |")
    print("|" + "---|" * (len(VISIBLE_MEASURES) + 1))
    for t, g in per.items():
        print(f"| {t} | " + " | ".join(f"{g[k]:+.1f}" for _, k, _ in VISIBLE_MEASURES) + " |")
    means = {k: np.mean([g[k] for g in per.values()]) for _, k, _ in VISIBLE_MEASURES}
    print("| **mean** | " + " | ".join(f"**{means[k]:+.1f}**" for _, k, _ in VISIBLE_MEASURES) + " |")


DEFAULT_RULES = list(EVAL_RULES)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", type=Path, default=DEFAULT_TEXTURES)
    p.add_argument("--textures", default=",".join(TEXTURES))
    p.add_argument("--kind", default="n2")
    p.add_argument("--random", type=int, default=10)
    p.add_argument("--seeds", type=int, default=6)
    p.add_argument("--keep", type=int, default=8)
    p.add_argument("--count", type=int, default=32)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--proxy-size", type=int, default=256)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--json", type=Path, default=None)
    p.add_argument("--replay", type=Path, nargs="*", default=None)
    p.add_argument("--rules", default=",".join(DEFAULT_RULES))
    p.add_argument("--detail", default=None, help="replay: per-texture tables of these rules")
    a = p.parse_args(argv)
    if a.replay:
        data: dict[str, Any] = {"textures": {}}
        for path in a.replay:
            data["textures"].update(json.loads(path.read_text())["textures"])
        res = replay(data, a.rules.split(","))
        print_replay(res)
        cpu_table(data)
        for rule in (a.detail or "").split(","):
            if rule:
                print_per_texture(res, rule)
        return 0
    if os.environ.get("OPENBLAS_NUM_THREADS") == "1":
        _fast_gram_patch()
    collect(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
