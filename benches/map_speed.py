#!/usr/bin/env python3
"""CPU time of a material's blended maps over its colour, per window of new tiles (issue 28's target: the maps of
a 256² window at most 3x the colour's time).

For each window size (``--sizes``, default 256 and 1024) and each of ``--repeat`` fresh processes (run one after
the other, ``nice``), ``--windows`` windows at random origins (new tiles: the origins are ±10⁶ px apart) are
synthesized: the colour (:func:`tilesynth.synthesize`, which also makes the index map) and then the set's maps
(:func:`tilesynth.builder.materials.synthesize_maps`, seam blend, the default), each timed as the process's CPU
time (both threads of the default pool count). Printed: the medians over every window of every process, their
ratio, and the peak RSS (``VmHWM``) of a process that loads the set and synthesizes a 1024² colour with its maps.

The set: a material tile set with its maps, e.g. ``benches/relief.py``'s ``rock`` (``/tmp/relief/sets/rock.tiles``,
built from ambientCG Rock058 as that script's docstring says). Results: ``benches/relief-results.md`` ("Speed").

    python benches/map_speed.py /tmp/relief/sets/rock.tiles --repeat 5 --windows 8
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time


def child(path: str, size: int, windows: int, seed: int, mode: str = "blend") -> None:
    """In a fresh process: CPU times (s) of ``windows`` colour and maps windows of ``size``² (a warm-up first);
    ``size = 0``: the peak RSS of load + 1024² colour + maps. ``mode``: the maps' seams, "blend" (the default),
    "fusion" (``seams="fuse"``) or "copies" (``smooth=False``; ``benches/relief.py`` times all three). Prints
    JSON."""
    import numpy as np

    import tilesynth as ts
    from tilesynth.builder import materials

    t = ts.load(path)
    if size == 0:
        _, imap = ts.synthesize(t, 1024, 1024, seed=1)
        materials.synthesize_maps(t, imap, 1024, 1024)
        peak = [int(x.split()[1]) / 1024 for x in open("/proc/self/status") if x.startswith("VmHWM:")][0]
        print(json.dumps({"rss_mb": peak}))
        return
    seams = "fuse" if mode == "fusion" else None
    smooth = False if mode == "copies" else None
    n = t.tile_size
    r = np.random.default_rng(seed)
    # warm-up: the set's caches (the maps' copies, slopes and low bands)
    materials.synthesize_maps(
        t, ts.synthesize(t, size, size, seed=1)[1], size, size, seams=seams, smooth=smooth
    )
    res: dict[str, list[float]] = {"colour": [], "maps": []}
    for _ in range(windows):
        origin = (int(r.integers(-(10**6), 10**6)), int(r.integers(-(10**6), 10**6)))
        c0 = time.process_time()
        _, imap = ts.synthesize(t, size, size, seed=1, origin=origin)
        c1 = time.process_time()
        cache = materials._cache(t)  # new tiles: nothing fused before (the fusion caches per tile)
        cache.get("fused", {}).clear()
        cache["fused_bytes"] = 0
        c2 = time.process_time()
        materials.synthesize_maps(
            t, imap, size, size, offset=(origin[1] % n, origin[0] % n), seams=seams, smooth=smooth
        )
        res["colour"].append(c1 - c0)
        res["maps"].append(time.process_time() - c2)
    print(json.dumps(res))


def run_child(*args: str) -> dict:
    out = subprocess.run(
        ["nice", sys.executable, __file__, "--child", *args], check=True, capture_output=True, text=True
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("set", nargs="?", default="/tmp/relief/sets/rock.tiles", help="a material tile set")
    ap.add_argument("--sizes", default="256,1024", help="window sides (comma-separated)")
    ap.add_argument("--repeat", type=int, default=5, help="fresh processes per size (default 5)")
    ap.add_argument("--windows", type=int, default=8, help="windows per process (default 8)")
    ap.add_argument("--child", nargs=5, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child[0], int(args.child[1]), int(args.child[2]), int(args.child[3]), args.child[4])
        return 0
    sizes = [int(s) for s in args.sizes.split(",") if s]
    runs = {s: {"colour": [], "maps": []} for s in sizes}
    for rep in range(args.repeat):
        for s in sizes:  # interleaved: every size once per round
            got = run_child(
                args.set,
                str(s),
                str(args.windows if s < 1024 else max(2, args.windows // 4)),
                str(rep),
                "blend",
            )
            runs[s]["colour"] += got["colour"]
            runs[s]["maps"] += got["maps"]
    print("| window | colour ms | maps ms | maps / colour |\n|---|---|---|---|")
    for s in sizes:
        c, m = statistics.median(runs[s]["colour"]) * 1e3, statistics.median(runs[s]["maps"]) * 1e3
        print(f"| {s}² | {c:.2f} | {m:.2f} | {m / c:.2f}x |")
    print(
        f"\nPeak RSS, load + 1024² colour + maps: {run_child(args.set, '0', '0', '0', 'blend')['rss_mb']:.0f} MB"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
