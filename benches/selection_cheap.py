#!/usr/bin/env python3
"""Cheap visible selection (issue 15, helper selq2): the data to choose a default selection by cut seam,
coherence and texture statistics at the cost of today's default.

For each texture and build seed, the default's first stage (best-of ``--count`` by ΣD, the draws of
``build_omega(seed=s)``) keeps its ``--keep`` best candidates; each is built and measured by every proxy the rules
may use (all from a small synthesis with seed :data:`tilesynth.builder.genes.visible_objective.PROXY_SEED`, never the evaluation's):

* ``cut_score``, ``cut_seam``: of the tiles (no synthesis);
* ``coh_exact``: the coherence of the ``--proxy``² proxy (:func:`tilesynth.builder.genes.visible_objective.coherence_estimate`, exact at
  these sizes); ``coh_s{k}``: the same from a fixed sample of k searched patches;
* ``tex``: the texture statistics of the proxy; ``tex_c{k}``: of its top-left k² crop;

and every candidate is **evaluated** (``benches/selection.py``'s :func:`visible_measures`: 512² synthesis, seed 1),
so any rule over the first K candidates can be replayed offline (``selection_cheap_replay.py``). The random
baseline: ``--random`` builds with ``select="random"`` (seeds 1000+), as in ``benches/selection.py``.

Usage::

    OPENBLAS_NUM_THREADS=1 python benches/selection_cheap.py --textures eggs.png --seeds 11,12,13 --json t.json
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
from selection import DEFAULT_TEXTURES, load, visible_measures  # noqa: E402
from selection_proxy import _fast_gram_patch, candidates  # noqa: E402

SAMPLES = (128, 256, 512)
CROPS = (128, 192)


def proxies(tset: Any, judge: Any, side: int, threads: int | None) -> dict[str, float]:
    from tilesynth.builder.genes.visible_objective import (
        PROXY_SEED,
        coherence_estimate,
        texture_stats_estimate,
    )
    from tilesynth.measure.metrics import cut_seam_score
    from tilesynth.measure.quality import cut_score

    out: dict[str, float] = {}
    t0 = time.process_time()
    seam = cut_seam_score(tset)
    out["cut_seam"] = float("nan") if seam is None else float(seam["score"])
    out["cut_score"] = cut_score(tset.cut_costs, tset.tile_size)
    out["t_seam"] = time.process_time() - t0
    t0 = time.process_time()
    img, _ = ts.synthesize(tset, side, side, seed=PROXY_SEED, threads=threads)
    img = np.asarray(img)
    out["t_synth"] = time.process_time() - t0
    t0 = time.process_time()
    out["coh_exact"] = coherence_estimate(img, judge.index.image, judge.index, threads)
    out["t_coh_exact"] = time.process_time() - t0
    for k in SAMPLES:
        t0 = time.process_time()
        out[f"coh_s{k}"] = coherence_estimate(img, judge.index.image, judge.index, threads, sample=k)
        out[f"t_coh_s{k}"] = time.process_time() - t0
    f = img.astype(np.float64)
    t0 = time.process_time()
    out["tex"] = texture_stats_estimate(f, judge.grams)
    out["t_tex"] = time.process_time() - t0
    for k in CROPS:
        t0 = time.process_time()
        out[f"tex_c{k}"] = texture_stats_estimate(f[:k, :k], judge.grams)
        out[f"t_tex_c{k}"] = time.process_time() - t0
    return out


def fit(ex: np.ndarray, side: int | None) -> np.ndarray:
    """``ex`` reduced to ``side``² (``--fit``; None: unchanged): block means over f x f pixels with
    f = ⌊min(h, w) / side⌋ (so several texture elements of a large exemplar stay in view), then the centre
    ``side``² crop. For a second tuning set from the larger shared textures at the bench's exemplar scale."""
    if side is None or min(ex.shape[:2]) <= side:
        return ex
    f = min(ex.shape[:2]) // side
    h, w = ex.shape[0] // f * f, ex.shape[1] // f * f
    a = ex[:h, :w].astype(np.float64).reshape(h // f, f, w // f, f, -1).mean(axis=(1, 3))
    y, x = (a.shape[0] - side) // 2, (a.shape[1] - side) // 2
    a = a[y : y + side, x : x + side]
    out = np.rint(a) if np.issubdtype(ex.dtype, np.integer) else a
    return np.ascontiguousarray(out.astype(ex.dtype).reshape(side, side, *ex.shape[2:]))


def collect(a: argparse.Namespace) -> dict[str, Any]:
    from tilesynth.builder.genes.visible_objective import ProxyJudge

    base = {"tileset": a.kind, "tile_size": 80} if a.kind == "n2" else {"tileset": a.kind}
    out: dict[str, Any] = {"kind": a.kind, "textures": {}, "args": {k: str(v) for k, v in vars(a).items()}}
    seeds = [int(s) for s in a.seeds.split(",")]
    for name in a.textures.split(","):
        ex = fit(load(a.dir / name), a.fit)
        rec: dict[str, Any] = {"random": [], "random_cpu_s": [], "seeds": {}}
        out["textures"][name] = rec
        for s in range(a.random):
            t0 = time.process_time()
            tset = ts.build_omega(ex, seed=1000 + s, threads=a.threads, select="random", **base)
            rec["random_cpu_s"].append(time.process_time() - t0)
            rec["random"].append(visible_measures(tset, a.size, a.threads))
        for s in seeds:
            cands = candidates(ex, s, a.keep, a.count, base, a.threads)
            rows = []
            judge = None
            for g in cands:
                t0 = time.process_time()
                tset = ts.build_omega(ex, genes=g, threads=a.threads, **base)
                t_build = time.process_time() - t0
                judge = judge or ProxyJudge(tset.exemplar, tset.tile_size, a.threads)
                rows.append({"genes": g.tolist(), "build_cpu_s": t_build,
                             "proxy": proxies(tset, judge, a.proxy, a.threads),
                             "eval": visible_measures(tset, a.size, a.threads)})  # fmt: skip
            rec["seeds"][str(s)] = rows
            print(f"  {a.kind} {name} seed {s}: {len(rows)} candidates", file=sys.stderr, flush=True)
            if a.json:
                a.json.write_text(json.dumps(out, default=str))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dir", type=Path, default=DEFAULT_TEXTURES)
    p.add_argument("--textures", required=True)
    p.add_argument("--kind", default="n2")
    p.add_argument("--random", type=int, default=10)
    p.add_argument("--seeds", default="1,2,3,4,5,6")
    p.add_argument("--keep", type=int, default=8)
    p.add_argument("--count", type=int, default=32)
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--proxy", type=int, default=256)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", type=Path, default=None)
    p.add_argument("--fit", type=int, default=None, help="reduce each exemplar to this side (see fit())")
    a = p.parse_args(argv)
    import os

    if os.environ.get("OPENBLAS_NUM_THREADS") == "1":
        _fast_gram_patch()
    collect(a)
    return 0


if __name__ == "__main__":
    sys.exit(main())
