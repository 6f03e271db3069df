#!/usr/bin/env python3
"""The default build at exemplar sizes 512² to 4096²: CPU time and peak RSS of two installs, each build its
own child process.

The exemplar is ``cracked-mud.png`` (512², ``/work/shared/textures``) upscaled bicubic to each size (a 2K /
4K material without a 2K / 4K texture to hand: the content is smoother than a real one, the sizes and the
build's stages are those of a real one). Each case runs ``build_omega(exemplar, seed=1)`` (the default recipe:
c5, 625 tiles, tile size a quarter of the side capped at 256) and saves the tile set, as ``tilesynth build``
does. The CPU time (user + sys) and the peak RSS (``ru_maxrss``) come from ``os.wait4`` of the child;
imports are included. Old and new alternate per size; ``--repeat`` runs per size and install, medians. The
wall time is reported beside it (what a user waits; the cut stage runs its tiles in parallel), and the
table says whether the two installs' tile sets have the same content digest.

The machine may be shared by other work: CPU time is the steadier figure; wall time depends on the load.

Usage::

    python benches/build_scale.py --old-python /work/main/.venv/bin/python --sizes 512,1024,2048 --repeat 1
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
DEFAULT_TEXTURE = HERE.parent.parent / "shared" / "textures" / "cracked-mud.png"

CHILD = r"""
import sys, numpy as np
from PIL import Image
import tilesynth as ts
tex, size, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
im = Image.open(tex).convert("RGB")
if im.size != (size, size):
    im = im.resize((size, size), Image.BICUBIC)
tiles = ts.build_omega(np.asarray(im), seed=1)
tiles.save(out)
print(tiles.tile_size, tiles.n_tiles, tiles.content_digest()[:16])
"""


def run(python: str, texture: str, size: int, out: str) -> tuple[float, float, float, str]:
    """``(cpu_s, peak_rss_mb, wall_s, child stdout)`` of one build in a child process."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [python, "-c", CHILD, texture, str(size), out], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL
    )
    assert proc.stdout is not None
    text = proc.stdout.read().decode()
    _, status, ru = os.wait4(proc.pid, 0)
    if status != 0:
        raise SystemExit(f"{python}: build of {size}² failed (status {status})")
    return ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024, time.perf_counter() - t0, text.strip()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old-python", help="the baseline install's python (omit: new only)")
    ap.add_argument("--new-python", default=sys.executable)
    ap.add_argument("--texture", default=str(DEFAULT_TEXTURE))
    ap.add_argument("--sizes", default="512,1024,2048")
    ap.add_argument("--old-sizes", help="sizes to run the baseline at (default: all)")
    ap.add_argument("--repeat", type=int, default=1)
    a = ap.parse_args()
    sizes = [int(s) for s in a.sizes.split(",")]
    old_sizes = set(sizes if a.old_sizes is None else (int(s) for s in a.old_sizes.split(",")))
    print(
        "| exemplar | tiles | before CPU s | before peak RSS MB | before wall s | after CPU s | after peak RSS MB "
        "| after wall s | same digest |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for size in sizes:
            got: dict[str, list[tuple[float, float, float]]] = {"old": [], "new": []}
            desc = ""
            digests: dict[str, str] = {}
            for _ in range(a.repeat):
                for name, py in (("old", a.old_python), ("new", a.new_python)):
                    if py is None or (name == "old" and size not in old_sizes):
                        continue
                    cpu, rss, wall, desc = run(py, a.texture, size, os.path.join(tmp, f"{name}.tiles"))
                    got[name].append((cpu, rss, wall))
                    desc, _, digests[name] = desc.rpartition(" ")
                    print(
                        f"# {name} {size}²: {cpu:.1f} s CPU, {rss:.0f} MB, {wall:.1f} s wall",
                        file=sys.stderr,
                        flush=True,
                    )

            def cell(name: str) -> str:
                if not got[name]:
                    return "- | - | -"
                cpu, rss, wall = (statistics.median(v[i] for v in got[name]) for i in range(3))
                return f"{cpu:.1f} | {rss:.0f} | {wall:.1f}"

            same = "-" if len(digests) < 2 else ("yes" if digests["old"] == digests["new"] else "**no**")
            print(f"| {size}² | {desc} | {cell('old')} | {cell('new')} | {same} |", flush=True)


if __name__ == "__main__":
    main()
