#!/usr/bin/env python3
"""Whole builds of two installs side by side: CPU time, wall time and peak RSS, interleaved, medians.

Each case runs as its own child process (``--old-python`` / ``--new-python``, e.g. a venv with the wheel of an
older commit and this checkout's venv), alternately, ``--repeat`` times; the CPU time (user + sys) and the
peak RSS (``ru_maxrss``, i.e. VmHWM) come from ``os.wait4`` of that child, the wall time from the parent.
Start-up (imports) is included: it is part of what a user waits for.

Cases (``--cases``, comma-separated):

- ``random1024``: ``build_omega`` of set n2, random genes (seed 1), 256-px tiles, on ``bark-lichen.png``
  upscaled to 1024², saved as a tile set (issue 15 target: >= 2x faster).
- ``ga512`` / ``ga1024``: the same with ``select="ga"`` and 128-px tiles on 512² / 1024² exemplars,
  ``--generations`` generations (issue 15 targets: peak RSS <= 600 MB / <= 1.2 GB).
- ``c5default512``: the default build (``c5``: 625 tiles, 128 px, free cut, diversity 1, border-aware draw) of
  the 512² exemplar, saved (issue 12: its peak RSS was 1.1 GB).
- ``c3x2_512``: the complete ``c3x2`` set (162 tiles) with 128-px tiles on it (issue 12 target: <= 5 s CPU).

The machine may be shared: only the ratios of medians mean much.

Usage::

    python benches/build_speed.py --old-python /tmp/base/.venv/bin/python --cases random1024 --repeat 3
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFAULT_TEXTURES = HERE.parent.parent / "shared" / "textures"

CHILD = r"""
import sys, numpy as np
from PIL import Image
import tilesynth as ts
tex, size, tile, select, gens, out = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5], sys.argv[6]
tileset = sys.argv[7] if len(sys.argv) > 7 else "n2"
im = Image.open(tex).convert("RGB")
if im.size != (size, size):
    im = im.resize((size, size), Image.BICUBIC)
ex = np.asarray(im)
kw = {} if select in ("random", "default") else {"select": select, "generations": int(gens)}
if tileset != "n2" and tile == 0:  # the default build (tile size, selection and levers of the set)
    tiles = ts.build_omega(ex, tileset=tileset, seed=1)
else:
    tiles = ts.build_omega(ex, tileset=tileset, tile_size=tile, seed=1, **kw)
tiles.save(out)
"""

CASES = {
    "random1024": (1024, 256, "random"),
    "ga512": (512, 128, "ga"),
    "ga1024": (1024, 128, "ga"),
    "c5default512": (512, 0, "default", "c5"),
    "c3x2_512": (512, 128, "default", "c3x2"),
}


def run(python: str, args: list[str]) -> tuple[float, float, float]:
    t0 = time.perf_counter()
    proc = subprocess.Popen([python, "-c", CHILD, *args])
    _, status, ru = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise SystemExit(f"child failed ({status}): {python} {args}")
    return ru.ru_utime + ru.ru_stime, wall, ru.ru_maxrss / 1024.0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--textures", type=Path, default=Path(os.environ.get("TILESYNTH_TEXTURES", DEFAULT_TEXTURES))
    )
    p.add_argument("--old-python", required=True)
    p.add_argument("--new-python", default=sys.executable)
    p.add_argument("--cases", default="random1024")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--generations", type=int, default=3)
    p.add_argument(
        "--new-only",
        default="",
        help="cases run with the new install only (e.g. ga1024: the old one needs an estimated 5-7 GB there)",
    )
    a = p.parse_args(argv)
    tex = str(a.textures / "bark-lichen.png")
    print(f"# benches/build_speed.py — {os.cpu_count()} cores; old {a.old_python}, new {a.new_python}")
    print("# medians of interleaved child processes; the machine may be shared with other jobs\n")
    print(
        "| case | old CPU s | new CPU s | CPU ratio | old wall s | new wall s | wall ratio | old peak MB | new peak MB |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for case in a.cases.split(","):
            size, tile, select, *tileset = CASES[case]
            args = [
                tex,
                str(size),
                str(tile),
                select,
                str(a.generations),
                str(Path(tmp) / "out.tiles"),
                *tileset,
            ]
            res: dict[str, list[tuple[float, float, float]]] = {"old": [], "new": []}
            new_only = case in a.new_only.split(",")
            for _ in range(a.repeat):
                if not new_only:
                    res["old"].append(run(a.old_python, args))
                res["new"].append(run(a.new_python, args))
            med = {k: [statistics.median(x[i] for x in v) for i in range(3)] for k, v in res.items() if v}
            (nc, nw, nm) = med["new"]
            name = case + (f" ({a.generations} gen)" if select not in ("random", "default") else "")
            if new_only:
                print(f"| {name} | – | {nc:.2f} | – | – | {nw:.2f} | – | not run | {nm:.0f} |", flush=True)
                continue
            (oc, ow, om) = med["old"]
            print(
                f"| {name} | {oc:.2f} | {nc:.2f} | {oc / nc:.2f}× | {ow:.2f} | {nw:.2f} | {ow / nw:.2f}× "
                f"| {om:.0f} | {nm:.0f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
