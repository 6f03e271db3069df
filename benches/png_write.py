"""PNG writing: tilesynth's encoder (``tilesynth.io.images.encode_png``, every compression level) against Pillow's
default ``save`` (zlib level 6, adaptive filters), side by side on the same synthesized texture.

Interleaved rounds (Pillow, then each level, in turn), medians of CPU time (``time.process_time``: all
threads of the process, so a parallel encoder is charged for every core it uses) and of wall time; file size
relative to Pillow's. Every file written is decoded back with Pillow and compared with the array.

    python benches/png_write.py                 # 4096x4096 RGB, 5 rounds
    python benches/png_write.py --quick         # 1024x1024, 3 rounds
    python benches/png_write.py --json out.json

Targets (issue 14): the default level >= 5x faster than Pillow, files at most 25 % larger.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from PIL import Image

import tilesynth as ts
from tilesynth.io.images import PNG_COMPRESSIONS, encode_png

HERE = Path(__file__).resolve().parent
TEXTURE = HERE.parent.parent / "shared" / "textures" / "gravel.png"


def texture(size: int, path: Path) -> np.ndarray:
    """A synthesized ``size`` x ``size`` RGB 8-bit texture of the exemplar ``path`` (default: gravel if the shared
    textures are there, else the bundled exemplar): what ``tilesynth synth`` writes."""
    if not path.exists():
        path = Path(ts.__file__).parent / "data" / "lettuce-leaves.png"
    ex, _ = ts.load_image(path)
    ex = ex[:, :, :3]
    tiles = ts.build_omega(ex, tileset="16a", tile_size=min(64, min(ex.shape[:2]) // 2 // 2 * 2), seed=1)
    img, _ = ts.synthesize(tiles, size, size, seed=7, dtype=np.uint8)
    return np.ascontiguousarray(img)


def pillow_png(arr: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(arr).save(buf, format="PNG")
    return buf.getvalue()


def timed(fn, *args):
    c0, w0 = time.process_time(), time.perf_counter()
    out = fn(*args)
    return out, time.process_time() - c0, time.perf_counter() - w0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=None, help="image side (default 4096, 1024 with --quick)")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 5, 3 with --quick)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument("--texture", type=Path, default=TEXTURE, help="exemplar of the synthesized image")
    args = ap.parse_args()
    size = args.size or (1024 if args.quick else 4096)
    rounds = args.rounds or (3 if args.quick else 5)
    started = time.perf_counter()
    arr = texture(size, args.texture)
    print(
        f"# PNG writing, {args.texture.name}, {size}x{size} RGB 8-bit ({arr.nbytes / 2**20:.0f} MiB raw), {rounds} interleaved rounds, "
        f"{os.cpu_count()} cores, threads = {ts._core.resolve_threads()}",
        file=sys.stderr,
    )
    coders = {"pillow (default save)": pillow_png}
    for level in PNG_COMPRESSIONS:
        coders[f"tilesynth {level}"] = lambda a, level=level: encode_png(a, level)
    cpu: dict[str, list[float]] = {k: [] for k in coders}
    wall: dict[str, list[float]] = {k: [] for k in coders}
    sizes: dict[str, int] = {}
    for r in range(rounds):
        for name, fn in coders.items():
            data, c, w = timed(fn, arr)
            cpu[name].append(c)
            wall[name].append(w)
            if r == 0:  # the oracle: every file decodes (with Pillow and with tilesynth) to the exact array
                got = np.asarray(Image.open(io.BytesIO(data)))
                assert np.array_equal(got, arr), f"{name}: Pillow decodes a different image"
                assert np.array_equal(ts._core.png_decode(data, 2**40)[0], arr), f"{name}: png_decode differs"
                sizes[name] = len(data)
        print(f"  round {r + 1}/{rounds} done", file=sys.stderr)
    base = "pillow (default save)"
    bc, bw, bs = statistics.median(cpu[base]), statistics.median(wall[base]), sizes[base]
    rows = []
    print(
        "\n| encoder | CPU s (median) | wall s (median) | CPU speed-up | wall speed-up | size MiB | size ratio |"
    )
    print("|---|---|---|---|---|---|---|")
    for name in coders:
        c, w = statistics.median(cpu[name]), statistics.median(wall[name])
        row = {
            "encoder": name,
            "cpu_s": c,
            "wall_s": w,
            "cpu_speedup": bc / c,
            "wall_speedup": bw / w,
            "bytes": sizes[name],
            "size_ratio": sizes[name] / bs,
        }
        rows.append(row)
        print(
            f"| {name} | {c:.3f} | {w:.3f} | {bc / c:.1f}x | {bw / w:.1f}x | {sizes[name] / 2**20:.2f} | "
            f"{sizes[name] / bs:.3f} |"
        )
    default = next(r for r in rows if r["encoder"] == "tilesynth default")
    ok_speed = default["cpu_speedup"] >= 5 and default["wall_speedup"] >= 5
    ok_size = default["size_ratio"] <= 1.25
    print(
        f"\ntarget default >= 5x faster (CPU and wall): {'met' if ok_speed else 'NOT met'}; "
        f"files <= 1.25x Pillow's: {'met' if ok_size else 'NOT met'}"
    )
    print(f"total {time.perf_counter() - started:.1f} s (the machine may be shared: CPU times are steadier)")
    if args.json:
        Path(args.json).write_text(json.dumps({"size": size, "rounds": rounds, "rows": rows}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
