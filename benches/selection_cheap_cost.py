#!/usr/bin/env python3
"""CPU and peak RSS of one n2 build per selection (issue 15, helper selq2): run once per process under
``/usr/bin/time -v`` (see ``benches/selection-results.md``). Modes: ``random``, ``default`` (cut re-rank 4),
``visible`` (8 candidates, exact proxy), ``cheap5`` (5 candidates, rank sum of cut seam and the coherence of 128
sampled patches: the rule chosen on the tuning textures), ``cheap4`` (4 candidates, cut seam + coherence of 256
sampled patches + texture statistics of the 128² crop). The cheap modes patch :mod:`tilesynth.builder.genes.visible_objective`.

Usage: ``python benches/selection_cheap_cost.py MODE TEXTURE TILE_SIZE``; prints the build's CPU seconds."""

from __future__ import annotations

import sys
import time

import tilesynth as ts
import tilesynth.builder.genes.visible_objective as vs


def main() -> int:
    mode, path, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
    ex, _ = ts.load_image(path)
    kw: dict = {"tileset": "n2", "tile_size": n, "seed": 1, "threads": 2}
    if mode == "random":
        kw["select"] = "random"
    elif mode == "visible":
        kw["objective"] = "visible"
    elif mode in ("cheap4", "cheap5"):
        k = 256 if mode == "cheap4" else 128
        vs.coherence_sample = lambda shape, patch=8, k=k: k  # type: ignore[assignment]
        vs.TEXSTATS_SIDE = 128
        if mode == "cheap5":
            orig = vs.pick_by_ranks
            vs.pick_by_ranks = lambda rows, keys=None: orig(rows, ("cut_seam", "coherence"))  # type: ignore
        kw.update(objective="visible", rerank=4 if mode == "cheap4" else 5)
    t0 = time.process_time()
    ts.build_omega(ex, **kw)
    print(f"{mode} cpu {time.process_time() - t0:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
