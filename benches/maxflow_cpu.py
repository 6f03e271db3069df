#!/usr/bin/env python3
"""The ω cut at one thread against PyMaxflow's grid pipeline in CPU time (issue 15 target: <= 0.5x at N = 80,
160, 256).

`benches/compare.py --only cut` measures wall time, which moves by 2-3x on a loaded shared machine; this script
times the same two pipelines (PyMaxflow: numpy Kwatra weights, graph build, maxflow, segments; ours:
``tilesynth.omega_cuts(threads=1)``) with :func:`time.process_time`, interleaved call by call over four tile
pairs, and prints the medians and their ratio. Both cuts are checked to have the same cost first.
Needs ``pip install PyMaxflow``.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import compare as C  # noqa: E402

import tilesynth as ts  # noqa: E402


def main() -> int:
    tex = C.load_texture(C.pick_texture(None))
    print("| N | PyMaxflow ms CPU | ours ms CPU | ratio |\n|---|---|---|---|")
    for n, reps in ((80, 60), (160, 20), (256, 10)):
        rng = np.random.default_rng(n)
        pairs = [C.omega_pair(C.at_least(tex, n), n, rng) for _ in range(4)]
        inside, sink = C.omega_masks(n)
        pm = [C.PyMaxflowCut(a, b, inside, sink) for a, b in pairs]
        a4 = [a[None].copy() for a, _ in pairs]
        b4 = [b[None].copy() for _, b in pairs]
        for k in range(4):  # exact: the same min-cut cost
            flow, _ = pm[k]()
            _, cost = ts.omega_cuts(a4[k], b4[k], threads=1, keep_border=False)
            assert abs(flow - cost[0]) <= 1e-6 * max(1.0, flow), (n, flow, cost)
        tp, to = [], []
        for r in range(reps):
            k = r % 4
            t = time.process_time()
            pm[k]()
            tp.append(time.process_time() - t)
            t = time.process_time()
            ts.omega_cuts(a4[k], b4[k], threads=1, keep_border=False)
            to.append(time.process_time() - t)
        mp, mo = statistics.median(tp), statistics.median(to)
        print(f"| {n} | {mp * 1e3:.2f} | {mo * 1e3:.2f} | {mo / mp:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
