#!/usr/bin/env python3
"""The matching stage: exact best matches by the linear candidate scan against the old full sort, side by side.

For exemplars of 512² and 1024² (``bark-lichen.png`` of ../shared/textures, upscaled bicubically to 1024²) and
256- and 128-px templates (``--tiles``), ``--templates`` templates built like intermediate ω-tiles (four quadrants cut from four random
places of the exemplar, so not exact copies), the CPU time (``time.process_time``, all threads) of
``SsdIndex.best_matches(k=1)`` and of the hidden baseline ``_core._best_matches_sorting`` (the first
implementation: every translation sorted by its FFT value), interleaved, ``--repeat`` times, medians. Also k = 16
with exclusion (what ``--match best-cut`` asks). The results are checked identical (offsets and float64 bits).

The machine may be shared: only the ratios mean much. Target (issue 15): ratio >= 3x at 512² and 1024².

Usage::

    python benches/matching_scan.py [--repeat 3] [--templates 8] [--threads 1]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numpy as np
from PIL import Image

import tilesynth as ts
from tilesynth import _core

HERE = Path(__file__).resolve().parent
DEFAULT_TEXTURES = HERE.parent.parent / "shared" / "textures"


def exemplar(textures: Path, size: int) -> np.ndarray:
    im = Image.open(textures / "bark-lichen.png").convert("RGB")
    if im.size != (size, size):
        im = im.resize((size, size), Image.BICUBIC)
    return np.asarray(im, dtype=np.float32) / 255.0


def templates(ex: np.ndarray, n: int, count: int, rng: np.random.Generator) -> np.ndarray:
    h = n // 2
    out = np.empty((count, n, n, ex.shape[2]), np.float32)
    for t in range(count):
        for qy in range(2):
            for qx in range(2):
                r, c = rng.integers(0, ex.shape[0] - h + 1), rng.integers(0, ex.shape[1] - h + 1)
                out[t, qy * h : (qy + 1) * h, qx * h : (qx + 1) * h] = ex[r : r + h, c : c + h]
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--textures", type=Path, default=Path(os.environ.get("TILESYNTH_TEXTURES", DEFAULT_TEXTURES))
    )
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--templates", type=int, default=8)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--sizes", default="512,1024")
    p.add_argument("--tiles", default="256,128", help="template sizes")
    a = p.parse_args(argv)
    print(
        f"# benches/matching_scan.py — tilesynth {ts.__version__}, {os.cpu_count()} cores, threads {a.threads}"
    )
    print("# CPU s (process_time, medians); the machine may be shared with other jobs\n")
    print("| exemplar | templates | k, exclude | sorting CPU s | scan CPU s | speed-up | identical |")
    print("|---|---|---|---|---|---|---|")
    rng = np.random.default_rng(1)
    for size in [int(s) for s in a.sizes.split(",")]:
        ex = exemplar(a.textures, size)
        idx = ts.SsdIndex(ex, a.threads)
        for n, k, r in [(t, k, r) for t in map(int, a.tiles.split(",")) for k, r in [(1, 0), (16, t // 4)]]:
            tpl = np.ascontiguousarray(templates(ex, n, a.templates, rng))
            idx.best_matches(tpl[:1], k=1, threads=a.threads)  # build the f64 spectra before timing
            t_new, t_old, same = [], [], True
            for _ in range(a.repeat):
                t0 = time.process_time()
                on, vn = idx._index.best_matches(tpl, k, r, None, a.threads)
                t1 = time.process_time()
                oo, vo = _core._best_matches_sorting(idx._index, tpl, k, r, None, a.threads)
                t2 = time.process_time()
                t_new.append(t1 - t0)
                t_old.append(t2 - t1)
                same &= bool(np.array_equal(on, oo) and np.array_equal(vn.view(np.int64), vo.view(np.int64)))
            mn, mo = statistics.median(t_new), statistics.median(t_old)
            print(
                f"| {size}² | {a.templates} × {n}² | {k}, {r} | {mo:.3f} | {mn:.3f} | {mo / mn:.2f}× | {same} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
