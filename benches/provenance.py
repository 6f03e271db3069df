"""Tile sets stored as provenance (format version 2) against pixels (version 1): file sizes, map synthesis time
per window, synthesis memory.

Inputs: ``../shared/textures/roof-tiles.png`` (512², BSD-3-Clause; no CC0 material is available offline here) as
the colour exemplar, and the 4-map material of ``benches/materials.py`` derived from it (albedo, normal 8-bit,
height 16-bit, roughness 8-bit). Builds are the defaults (``c5``, 625 tiles of 128 px), seed 1.

Measured:

* ``.tiles`` bytes of the colour build and of the material build, version 1 and version 2, against the PNG
  bytes of the exemplar (and of the four maps, written by tilesynth's PNG writer);
* the CPU time (``time.process_time``, all threads) of ``synthesize`` (colour) and of ``synthesize_maps`` for a
  256² window at random origins, on a freshly loaded set: the first window (cold: nothing cached yet) and
  the following ones (warm: the set's fused tiles cache); for version 1 the maps as before this change (every
  call fuses the whole set's map atlas, level solve included, ``--old``); interleaved runs, medians;
* peak RSS of a child process that loads the set and synthesizes a 256² window (colour and maps), and a
  1024² colour output;
* with ``--big``: the default build of the exemplar upscaled to 2048² (CPU time, peak RSS, file sizes).

Usage::

    python benches/provenance.py [--repeat 5] [--big] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
SHARED = HERE.parents[1] / "shared" / "textures"


def _mb(b: float) -> str:
    return f"{b / 1e6:.2f} MB"


def _png_bytes(a: np.ndarray, path: Path) -> int:
    import tilesynth as ts

    ts.save_image(path, a, bits=16 if a.dtype == np.uint16 else 8)
    return path.stat().st_size


def build_sets(out: Path) -> dict:
    """Build the colour and material sets (once), save them as v1 and v2, return the sizes."""
    from materials import derive_material

    import tilesynth as ts

    albedo_u8 = np.ascontiguousarray(ts.load_raster(SHARED / "roof-tiles.png")[..., :3])
    maps = derive_material(albedo_u8.astype(np.float32) / 255)
    sizes: dict = {"exemplar_png": (SHARED / "roof-tiles.png").stat().st_size}
    sizes["maps_png"] = sizes["exemplar_png"] + sum(
        _png_bytes(a, out / f"map-{k}.png") for k, a in maps.items()
    )
    for name, kw in (("colour", {}), ("material", {"maps": maps})):
        t0 = time.process_time()
        t = ts.build(albedo_u8, seed=1, **kw)
        sizes[f"{name}_build_cpu_s"] = time.process_time() - t0
        sizes[f"{name}_map_levels_s"] = t.timing.get("map_levels_s", 0.0)
        for v in (1, 2):
            p = out / f"{name}-v{v}.tiles"
            t.save(p, include_timing=False, format_version=v)
            sizes[f"{name}_v{v}"] = p.stat().st_size
        del t
    return sizes


def _old_maps(t, imap, w, h, offset):  # noqa: ANN001, ANN202
    """The maps as synthesize_maps made them before: the whole set's map atlas (level solve and fusion of every
    tile) per call, then the tile copy."""
    from tilesynth import _core
    from tilesynth.builder import materials

    src = t.source
    out = {}
    for d in t.map_specs:
        spec = materials.MapSpec.from_dict(d)
        arr = t.maps[spec.name]
        atlas = np.ascontiguousarray(arr[src[..., 0], src[..., 1]])
        if materials.smooths(t, spec):
            atlas = materials.fuse_map_atlas(t, arr, atlas)
        if spec.kind == "normal":
            atlas = materials.renormalise_image(atlas, spec.encoding or "unorm")
        img = np.empty((h, w, arr.shape[2]), arr.dtype)
        _core.tile_copy_window(np.ascontiguousarray(atlas), imap, offset, img, None)
        out[spec.name] = img
    return out


def _peak_mb() -> float:
    """This process's peak RSS (``VmHWM``: ``ru_maxrss`` of a child keeps the forked parent's peak across
    ``exec``)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def child(args: list[str]) -> None:
    """One measurement in a fresh process: ``child MODE PATH [N]``; prints JSON."""
    import tilesynth as ts
    from tilesynth.builder import materials

    mode, path = args[0], args[1]
    n_windows = int(args[2]) if len(args) > 2 else 1
    t = ts.load(path)
    r = np.random.default_rng(int(args[3]) if len(args) > 3 else 0)
    res: dict = {"colour_s": [], "maps_s": []}
    for _ in range(n_windows):
        origin = (int(r.integers(-(10**6), 10**6)), int(r.integers(-(10**6), 10**6)))
        c0 = time.process_time()
        img, imap = ts.synthesize(t, 256, 256, seed=1, origin=origin)
        c1 = time.process_time()
        res["colour_s"].append(c1 - c0)
        if t.map_specs and mode != "colour":
            n = t.tile_size
            offset = (origin[1] % n, origin[0] % n)
            if mode == "old":
                _old_maps(t, imap, 256, 256, offset)
            else:
                materials.synthesize_maps(
                    t, imap, 256, 256, offset=offset, smooth=False if mode == "copies" else None
                )
            res["maps_s"].append(time.process_time() - c1)
            if mode == "maps":  # the same window again: its fused tiles are cached with the set
                c2 = time.process_time()
                materials.synthesize_maps(t, imap, 256, 256, offset=offset)
                res.setdefault("again_s", []).append(time.process_time() - c2)
    res["rss_256_mb"] = _peak_mb()
    if mode == "colour":
        c0 = time.process_time()
        ts.synthesize(t, 1024, 1024, seed=1)
        res["colour_1024_s"] = time.process_time() - c0
        res["rss_1024_mb"] = _peak_mb()
    print(json.dumps(res))


def run_child(*args: str) -> dict:
    out = subprocess.run(
        [sys.executable, __file__, "--child", *args], check=True, capture_output=True, text=True
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


def big(out: Path) -> dict:
    """The default build of roof-tiles upscaled to 2048² (nearest, 4x) in a child: CPU time, peak RSS, sizes."""
    code = f"""
import json, resource, time, numpy as np, tilesynth as ts
a = ts.load_raster({str(SHARED / "roof-tiles.png")!r})[..., :3]
a = np.ascontiguousarray(np.repeat(np.repeat(a, 4, axis=0), 4, axis=1))
ts.save_image({str(out / "roof-2048.png")!r}, a)
t0 = time.process_time()
t = ts.build(a, seed=1)
cpu = time.process_time() - t0
def peak():
    return [int(x.split()[1]) / 1024 for x in open("/proc/self/status") if x.startswith("VmHWM:")][0]
rss = peak()
t.save({str(out / "big-v2.tiles")!r}, include_timing=False)
rss_v2 = peak()
t.save({str(out / "big-v1.tiles")!r}, include_timing=False, format_version=1)
print(json.dumps({{"cpu_s": cpu, "rss_build_mb": rss, "rss_after_v2_save_mb": rss_v2, "n": t.tile_size}}))
"""
    res = json.loads(
        subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout
    )
    res["png"] = (out / "roof-2048.png").stat().st_size
    res["v1"] = (out / "big-v1.tiles").stat().st_size
    res["v2"] = (out / "big-v2.tiles").stat().st_size
    return res


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved runs of each child (default 5)")
    ap.add_argument("--windows", type=int, default=4, help="256² windows per child run (default 4)")
    ap.add_argument("--big", action="store_true", help="also the 2048² default build")
    ap.add_argument("--out", default="/tmp/tilesynth-provenance-bench", help="working directory")
    ap.add_argument("--big-only", action="store_true", help="only the 2048² build")
    ap.add_argument("--reuse", action="store_true", help="reuse the sets of an earlier run in --out")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.big_only:
        print(json.dumps(big(out)))
        return 0
    sizes = build_sets(out) if not args.reuse else json.loads((out / "sizes.json").read_text())
    (out / "sizes.json").write_text(json.dumps(sizes))
    print(json.dumps(sizes, indent=1), flush=True)
    runs: dict[str, list[dict]] = {k: [] for k in ("v1-old", "v2", "v1", "copies", "colour-v1", "colour-v2")}
    for i in range(args.repeat):  # interleaved
        if i == 0:  # a minute of CPU per run: once
            runs["v1-old"].append(run_child("old", str(out / "material-v1.tiles"), "1", str(i)))
        runs["copies"].append(run_child("copies", str(out / "material-v2.tiles"), str(args.windows), str(i)))
        runs["v1"].append(run_child("maps", str(out / "material-v1.tiles"), str(args.windows), str(i)))
        runs["v2"].append(run_child("maps", str(out / "material-v2.tiles"), str(args.windows), str(i)))
        runs["colour-v1"].append(run_child("colour", str(out / "colour-v1.tiles"), "1", str(i)))
        runs["colour-v2"].append(run_child("colour", str(out / "colour-v2.tiles"), "1", str(i)))
    med = statistics.median
    lines = [
        "| file | v1 (pixels) | v2 (provenance) | reference | v1 / ref | v2 / ref |",
        "|---|---|---|---|---|---|",
        f"| colour .tiles | {_mb(sizes['colour_v1'])} | {_mb(sizes['colour_v2'])} | exemplar PNG "
        f"{_mb(sizes['exemplar_png'])} | {sizes['colour_v1'] / sizes['exemplar_png']:.1f}x | "
        f"{sizes['colour_v2'] / sizes['exemplar_png']:.2f}x |",
        f"| 4-map material .tiles | {_mb(sizes['material_v1'])} | {_mb(sizes['material_v2'])} | 4 map PNGs "
        f"{_mb(sizes['maps_png'])} | {sizes['material_v1'] / sizes['maps_png']:.1f}x | "
        f"{sizes['material_v2'] / sizes['maps_png']:.2f}x |",
        "",
        "| material, 256² window (CPU s, median) | colour | maps | maps / colour | peak RSS |",
        "|---|---|---|---|---|",
    ]
    for key, what in (("v1-old", "v1, maps as before (whole atlas per call)"), ("v1", "v1, per window"),
                      ("v2", "v2, per window"), ("copies", "v2, maps as copies (smooth=False)")):  # fmt: skip
        col = med(x for r in runs[key] for x in r["colour_s"])
        first = med(r["maps_s"][0] for r in runs[key])
        lines.append(
            f"| {what}: first window | {col * 1e3:.2f} ms | {first * 1e3:.1f} ms | {first / col:.0f}x | "
            f"{med(r['rss_256_mb'] for r in runs[key]):.0f} MB |"
        )
        if key != "v1-old" and args.windows > 1:
            warm = med(x for r in runs[key] for x in r["maps_s"][1:])
            lines.append(f"| {what}: next windows | | {warm * 1e3:.1f} ms | {warm / col:.1f}x | |")
        if runs[key] and "again_s" in runs[key][0]:
            again = med(x for r in runs[key] for x in r["again_s"])
            lines.append(f"| {what}: the same window again | | {again * 1e3:.1f} ms | {again / col:.1f}x | |")
    for key in ("colour-v1", "colour-v2"):
        lines.append(
            f"| {key}: colour 256² / 1024² | {med(r['colour_s'][0] for r in runs[key]) * 1e3:.2f} ms | "
            f"{med(r['colour_1024_s'] for r in runs[key]) * 1e3:.1f} ms (1024²) | | "
            f"{med(r['rss_1024_mb'] for r in runs[key]):.0f} MB |"
        )
    lines.append(
        f"\nbuild CPU: colour {sizes['colour_build_cpu_s']:.1f} s, material {sizes['material_build_cpu_s']:.1f} s "
        f"(of which the stored map levels {sizes['material_map_levels_s']:.1f} s wall)"
    )
    if args.big:
        b = big(out)
        lines.append(
            f"2048² default build: {b['cpu_s']:.1f} s CPU, peak RSS {b['rss_build_mb']:.0f} MB (after saving v2: "
            f"{b['rss_after_v2_save_mb']:.0f} MB), tile {b['n']}; .tiles v1 {_mb(b['v1'])}, v2 {_mb(b['v2'])}, "
            f"PNG {_mb(b['png'])} (v2 / PNG {b['v2'] / b['png']:.2f}x)"
        )
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        child(sys.argv[2:])
        sys.exit(0)
    sys.exit(main())
