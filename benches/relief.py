#!/usr/bin/env python3
"""Relief of synthesized material maps: copies, the fusion (the old default), the seam blend (the default) and
by-example hex tiling, on real PBR materials.

**Materials** (512², downscaled 2x from 1024² by a box filter as users do; normals renormalised after the
downscale and encoded at unit length, heights kept as 16-bit):

* *tuning* (used to choose the blend: :data:`tilesynth.synth.seams.LEVELS`): ``pbr:rocks``, ``pbr:tiles``
  (pypbr 0.1.0b5's test data, MIT, see ``benches/materials.py``), ``mossyrock`` (ambientCG Rock053, CC0) and
  ``dirt`` (ambientCG Ground048, CC0);
* *held out* (measured once the level was chosen, never tuned on): ``rock`` (ambientCG Rock058), ``bark``
  (ambientCG Bark014), ``sand`` (ambientCG Ground079L), all CC0 1.0 (https://ambientcg.com/view?id=...).

They are not in the repository (1K JPEGs, 4-8 MB a material). Their source copies: Rock058, Rock053 and Bark014
as ``textures/{rock,mossyrock,bark}/{albedo,displacement,normal,roughness}.jpg`` of the GitHub repository
``SimonWadsack/SimonWadsack.github.io`` (its ``source.md`` names the ambientCG assets and the CC0 licence);
Ground079L and Ground048 as ``textures/ground/{sand,dirt}/Ground0xx_1K-JPG_{Color,Displacement,NormalGL,
Roughness}.jpg`` of ``umerkay/fly`` (the ambientCG 1K-JPG downloads as published, with their ``.mtlx``). Put
them in one folder as ``rock_albedo.jpg`` ... ``sand_Color.jpg`` ... (see :data:`SOURCES`) and pass it as
``--src``; pass pypbr's unzipped ``tests/data`` as ``--pypbr``.

**Measured** on a ``--size``² synthesis of each default build (``c5``, seed 1; tiling seeds ``--seeds``), the
height (scalar), roughness (scalar) and normal maps:

* *std ratio*: the output's standard deviation over the exemplar map's (normals: of their x and y together);
* *cliffs*: the share of the output's neighbouring-pixel steps (both directions; normals: the length of the
  vector difference) above the exemplar's own 99.9th percentile step, divided by 0.001 (1 = as often as in
  the exemplar);
* *normal-x corr ratio*: the correlation of the output normal's x with ``-d(height)/dx`` of the output height
  (central differences), over the same in the exemplar (1 = the normals agree with the height as much as in the
  exemplar);
* *unit share*: the share of output normals within 1 ± 0.005 of unit length;
* the CPU time of ``synthesize_maps`` (3 maps) of 256² windows of new tiles over the colour's ``synthesize`` of
  the same window (interleaved, medians), and the peak RSS of a process that loads the set and synthesizes a
  1024² colour with its 3 maps.

**Hex tiling** (the baseline, :func:`hex_tile`): Heitz & Neyret 2018's by-example tiling, each output pixel
blended from 3 exemplar fetches at the vertices of a triangle grid (side ``--hex-side``, 128 px), each vertex a
random offset into the exemplar (chosen so its patch stays inside), barycentric weights, scalar maps blended
histogram-preservingly (each map Gaussianised by its own sorted values, ``Σ w G / √Σ w²``, then mapped back),
normal maps as slopes ``(x, y) / z`` with the same variance-preserving blend, then renormalised.

Usage::

    python benches/relief.py --src SRC --pypbr DATA                 # writes benches/relief-results.md
    python benches/relief.py --src SRC --materials rock --figure docs/figures/relief-rock.png
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
TUNING = ("pbr:rocks", "pbr:tiles", "mossyrock", "dirt")
HELD_OUT = ("rock", "bark", "sand")
SOURCES = {
    "rock": ("rock_albedo", "rock_displacement", "rock_normal", "rock_roughness"),
    "bark": ("bark_albedo", "bark_displacement", "bark_normal", "bark_roughness"),
    "mossyrock": ("mossyrock_albedo", "mossyrock_displacement", "mossyrock_normal", "mossyrock_roughness"),
    "sand": ("sand_Color", "sand_Displacement", "sand_NormalGL", "sand_Roughness"),
    "dirt": ("dirt_Color", "dirt_Displacement", "dirt_NormalGL", "dirt_Roughness"),
}
"""The file stems in ``--src`` of each ambientCG material: (albedo, height, normal, roughness), ``.jpg``."""
METHODS = ("copies", "fusion", "blend", "hex")


def load_material(name: str, src: str, pypbr: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The 512² albedo (uint8) and maps (normal uint8 unit, height uint16, roughness uint8) of a material."""
    from PIL import Image

    from tilesynth.io.normal_codes import encode_unit

    if name.startswith("pbr:"):
        d = Path(pypbr) / name[4:]
        files = [d / f"{k}.png" for k in ("basecolor", "height", "normal", "roughness")]
    else:
        files = [Path(src) / f"{s}.jpg" for s in SOURCES[name]]
    arrs = []
    for f in files:
        im = Image.open(f)
        a = np.asarray(im).astype(np.float64) / (65535.0 if im.mode.startswith("I") else 255.0)
        a = a[..., None] if a.ndim == 2 else a[..., :3]
        k = a.shape[0] // 512
        arrs.append(a.reshape(512, k, 512, k, -1).mean(axis=(1, 3)))
    albedo, height, normal, rough = arrs
    v = normal * 2.0 - 1.0
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    maps = {
        "normal": np.ascontiguousarray(encode_unit(v, np.dtype(np.uint8), "unorm")),
        "height": np.rint(height * 65535).astype(np.uint16),
        "roughness": np.rint(rough * 255).astype(np.uint8),
    }
    return np.rint(albedo * 255).astype(np.uint8), maps


def get_set(name: str, args: argparse.Namespace):  # noqa: ANN201
    import tilesynth as ts

    path = Path(args.cache) / f"{name.replace(':', '_')}.tiles"
    if path.exists():
        return ts.load(path)
    albedo, maps = load_material(name, args.src, args.pypbr)
    t = ts.build(albedo, maps=maps, seed=1)
    path.parent.mkdir(parents=True, exist_ok=True)
    t.save(path)
    return t


# --------------------------------------------------------------------------------------------- hex tiling
def _gaussianise(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Gaussianised map (per channel, by rank) and the sorted values to map back."""
    from scipy.special import ndtri

    flat = x.reshape(-1, x.shape[-1])
    order = np.argsort(flat, axis=0, kind="stable")
    ranks = np.empty_like(order)
    np.put_along_axis(ranks, order, np.arange(flat.shape[0])[:, None].repeat(flat.shape[1], 1), axis=0)
    g = ndtri((ranks + 0.5) / flat.shape[0])
    return g.reshape(x.shape), np.sort(flat, axis=0)


def _degaussianise(g: np.ndarray, sorted_vals: np.ndarray) -> np.ndarray:
    from scipy.special import ndtr

    q = np.clip(ndtr(g) * sorted_vals.shape[0] - 0.5, 0, sorted_vals.shape[0] - 1)
    out = np.empty_like(g)
    for c in range(g.shape[-1]):
        out[..., c] = np.interp(q[..., c], np.arange(sorted_vals.shape[0]), sorted_vals[:, c])
    return out


def hex_grid(h: int, w: int, side: float, ex_shape: tuple[int, int], seed: int) -> tuple[list, np.ndarray]:
    """For each of the 3 vertices of the triangle around every output pixel: the exemplar (row, col) it reads
    (int, inside the exemplar) and the barycentric weights ``(3, h, w)``."""
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64) + 0.5
    # skewed grid (Heitz & Neyret 2018, TriangleGrid): unit triangles of side `side`
    u, v = xx / side, yy / side
    su = u - v / np.sqrt(3.0)
    sv = v * 2.0 / np.sqrt(3.0)
    bu, bv = np.floor(su), np.floor(sv)
    fu, fv = su - bu, sv - bv
    fz = 1.0 - fu - fv
    up = fz > 0
    verts = [
        (np.where(up, bu, bu + 1), np.where(up, bv, bv + 1)),
        (np.where(up, bu, bu + 1), np.where(up, bv + 1, bv)),
        (np.where(up, bu + 1, bu), np.where(up, bv, bv + 1)),
    ]
    wts = np.stack([np.where(up, fz, -fz), np.where(up, fv, 1 - fv), np.where(up, fu, 1 - fu)])
    eh, ew = ex_shape
    r = int(np.ceil(side))
    out = []
    for vu, vv in verts:
        key = (vu.astype(np.int64) * 73856093) ^ (vv.astype(np.int64) * 19349663) ^ (seed * 83492791)
        rng_y = (key * 2654435761 % 2**32) / 2**32
        rng_x = (key * 40503 * 2654435761 % 2**32) / 2**32
        # the vertex's position in output pixels, and where its patch centre reads in the exemplar
        py, px = vv * side * np.sqrt(3.0) / 2.0, (vu + vv / 2.0) * side
        cy = r + rng_y * max(1, eh - 2 * r)
        cx = r + rng_x * max(1, ew - 2 * r)
        ry = np.clip(np.floor(yy - py + cy), 0, eh - 1).astype(np.int64)
        rx = np.clip(np.floor(xx - px + cx), 0, ew - 1).astype(np.int64)
        out.append((ry, rx))
    return out, wts


def hex_tile(maps: dict[str, np.ndarray], h: int, w: int, side: float, seed: int) -> dict[str, np.ndarray]:
    """Hex tiling (module docstring) of float maps: height / roughness in [0, 1] ``(H, W, 1)``, normal as unit
    vectors ``(H, W, 3)``; returns the same kinds, float64."""
    first = next(iter(maps.values()))
    pos, wts = hex_grid(h, w, side, first.shape[:2], seed)
    norm = np.sqrt((wts * wts).sum(axis=0))[..., None]
    out = {}
    for name, m in maps.items():
        if name == "normal":
            s = m[..., :2] / np.maximum(m[..., 2:3], 1.0 / 16)
            mu = s.reshape(-1, 2).mean(axis=0)
            b = mu + sum(wts[i][..., None] * (s[pos[i]] - mu) for i in range(3)) / norm
            n = np.concatenate([b, np.ones(b.shape[:-1] + (1,))], axis=-1)
            out[name] = n / np.linalg.norm(n, axis=-1, keepdims=True)
        else:
            g, sv = _gaussianise(m)
            b = sum(wts[i][..., None] * g[pos[i]] for i in range(3)) / norm
            out[name] = _degaussianise(b, sv)
    return out


# ----------------------------------------------------------------------------------------------- measures
def _steps(x: np.ndarray) -> np.ndarray:
    dy = np.sqrt((np.diff(x, axis=0) ** 2).sum(axis=-1)).ravel()
    dx = np.sqrt((np.diff(x, axis=1) ** 2).sum(axis=-1)).ravel()
    return np.concatenate([dy, dx])


def measures(ex: dict[str, np.ndarray], out: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """Per map: std ratio, cliffs, and for the normal map the normal-x corr ratio and the unit share (maps as
    float: scalars in [0, 1] ``(H, W, 1)``, normals decoded ``(H, W, 3)``)."""
    res: dict[str, dict[str, float]] = {}
    for name in ("height", "roughness", "normal"):
        e, o = ex[name], out[name]
        if name == "normal":
            std = o[..., :2].std() / e[..., :2].std()
        else:
            std = o.std() / e.std()
        thr = np.quantile(_steps(e), 0.999)
        r = {"std": float(std), "cliffs": float((_steps(o) > thr).mean() / 0.001)}
        if name == "normal":

            def corr(n: np.ndarray, hgt: np.ndarray) -> float:
                return float(np.corrcoef(n[..., 0].ravel(), -np.gradient(hgt[..., 0], axis=1).ravel())[0, 1])

            r["corr"] = corr(o, out["height"]) / corr(e, ex["height"])
            r["unit"] = float((np.abs(np.linalg.norm(o, axis=-1) - 1.0) <= 0.005).mean())
        res[name] = r
    return res


def as_float(maps: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    from tilesynth.io.normal_codes import decode

    out = {}
    for k, a in maps.items():
        if k == "normal":
            out[k] = decode(a, "unorm")
        else:
            out[k] = a.astype(np.float64) / (65535.0 if a.dtype == np.uint16 else 255.0)
    return out


def outputs(t, size: int, seed: int, side: float) -> dict[str, dict[str, np.ndarray]]:  # noqa: ANN001
    import tilesynth as ts
    from tilesynth.builder import materials

    _, imap = ts.synthesize(t, size, size, seed=seed)
    res = {
        "copies": materials.synthesize_maps(t, imap, size, size, smooth=False),
        "fusion": materials.synthesize_maps(t, imap, size, size, seams="fuse"),
        "blend": materials.synthesize_maps(t, imap, size, size),
    }
    res = {k: as_float(v) for k, v in res.items()}
    hexed = hex_tile(as_float(t.maps), size, size, side, seed)
    for k, a in hexed.items():  # in the map's own sample type, as the other outputs
        if k != "normal":
            scale = 65535.0 if t.maps[k].dtype == np.uint16 else 255.0
            hexed[k] = np.rint(a * scale) / scale
    res["hex"] = hexed
    return res


# ------------------------------------------------------------------------------------------------- timing
def timing(path: Path, repeat: int, windows: int) -> dict:
    """CPU time of the colour and the maps of ``windows`` 256² windows of new tiles per fresh process, copies,
    blend and fusion interleaved ``repeat`` times (``benches/map_speed.py``'s child), and the peak RSS of a 1024²
    colour + maps synthesis."""
    from map_speed import run_child  # the timing child of the map-speed bench (this folder)

    runs: dict[str, dict[str, list]] = {m: {"colour": [], "maps": []} for m in ("copies", "blend", "fusion")}
    for rep in range(repeat):
        for m in runs:
            r = run_child(str(path), "256", str(windows), str(5 + rep), m)
            runs[m]["colour"] += r["colour"]
            runs[m]["maps"] += r["maps"]
    out = {}
    for m, r in runs.items():
        c, mp = statistics.median(r["colour"]), statistics.median(r["maps"])
        out[m] = {"colour_ms": c * 1e3, "maps_ms": mp * 1e3, "ratio": mp / c}
    out["rss_mb"] = run_child(str(path), "0", "0", "0", "blend")["rss_mb"]
    return out


# ------------------------------------------------------------------------------------------------ figures
def figure(path: str, ex: dict, outs: dict, size: int = 160, relief: float = 60.0) -> None:
    """Rows: height (grey, the exemplar's range), the shaded height (Lambert on its gradient x ``4·relief``,
    light from the upper left: cliffs show as lines) and the shaded normal map (x and y doubled); columns:
    exemplar, copies, fusion, blend, hex."""
    import tilesynth as ts

    light = np.array([0.5, 0.5, 0.7]) / np.linalg.norm([0.5, 0.5, 0.7])
    lo, hi = np.quantile(ex["height"], [0.005, 0.995])
    rows: list[list[np.ndarray]] = [[], [], []]
    for m in ("exemplar", *METHODS):
        d = ex if m == "exemplar" else outs[m]
        hgt = d["height"][:size, :size, 0]
        rows[0].append(np.clip((hgt - lo) / max(hi - lo, 1e-9), 0, 1))
        gy, gx = np.gradient(hgt * relief * 4.0)
        hn = np.dstack([-gx, gy, np.ones_like(gx)])
        rows[1].append(np.clip((hn / np.linalg.norm(hn, axis=-1, keepdims=True)) @ light, 0, 1))
        n = d["normal"][:size, :size].copy()
        n[..., :2] *= 2.0
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        rows[2].append(np.clip(n @ light, 0, 1))
    gap, sep = np.ones((size, 4)), np.ones((4, 5 * size + 16))
    strips = [np.hstack([c for p in r for c in (p, gap)][:-1]) for r in rows]
    img = np.vstack([strips[0], sep, strips[1], sep, strips[2]])
    ts.save_image(path, np.rint(img * 255).astype(np.uint8)[..., None])  # grey: small files


# ---------------------------------------------------------------------------------------------------- main
def table(rows: list[dict]) -> str:
    lines = [
        "| material | set | map | " + " | ".join(f"{m} std / cliffs" for m in METHODS) + " |",
        "|---|---|---|" + "---|" * len(METHODS),
    ]
    for r in rows:
        for name in ("height", "roughness", "normal"):
            cells = [f"{r[m][name]['std']:.2f} / {r[m][name]['cliffs']:.2f}" for m in METHODS]
            lines.append(f"| {r['material']} | {r['set']} | {name} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "| material | set | " + " | ".join(f"{m} corr ratio / unit" for m in METHODS) + " |",
        "|---|---|" + "---|" * len(METHODS),
    ]
    for r in rows:
        cells = [f"{r[m]['normal']['corr']:.2f} / {100 * r[m]['normal']['unit']:.1f} %" for m in METHODS]
        lines.append(f"| {r['material']} | {r['set']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--src", default="/tmp/relief/src", help="folder of the ambientCG JPEGs (module docstring)"
    )
    ap.add_argument("--pypbr", default="/tmp/relief/pypbr/tests/data", help="pypbr's tests/data folder")
    ap.add_argument("--cache", default="/tmp/relief/sets", help="where the built sets are kept")
    ap.add_argument("--materials", default=",".join(TUNING + HELD_OUT), help="comma-separated names")
    ap.add_argument("--size", type=int, default=768, help="synthesis size (default 768)")
    ap.add_argument("--seeds", default="7,8", help="tiling seeds (comma-separated; measures are averaged)")
    ap.add_argument("--hex-side", type=float, default=128.0, help="hex tiling's triangle side (px)")
    ap.add_argument("--timing", default="rock", help="material whose 256² window is timed ('' for none)")
    ap.add_argument("--repeat", type=int, default=3, help="interleaved timing runs (default 3)")
    ap.add_argument("--windows", type=int, default=4, help="256² windows per timing run (default 4)")
    ap.add_argument("--figure", help="write the figure of the first material here (PNG)")
    ap.add_argument("--json", help="also write the raw figures here")
    ap.add_argument("--out", help="write the table here (default: print)")
    args = ap.parse_args(argv)
    names = [m for m in args.materials.split(",") if m]
    seeds = [int(s) for s in args.seeds.split(",")]
    rows = []
    for name in names:
        t = get_set(name, args)
        ex = as_float(t.maps)
        per_seed = []
        for s in seeds:
            outs = outputs(t, args.size, s, args.hex_side)
            per_seed.append({m: measures(ex, outs[m]) for m in METHODS})
            if args.figure and name == names[0] and s == seeds[0]:
                figure(args.figure, ex, outs)
        row = {"material": name, "set": "held out" if name in HELD_OUT else "tuning"}
        for m in METHODS:
            row[m] = {
                k: {q: float(np.mean([p[m][k][q] for p in per_seed])) for q in per_seed[0][m][k]}
                for k in per_seed[0][m]
            }
        rows.append(row)
        print(json.dumps(row), flush=True)
    text = table(rows)
    tim = None
    if args.timing:
        tim = timing(Path(args.cache) / f"{args.timing.replace(':', '_')}.tiles", args.repeat, args.windows)
        text += "\n\n| 256² window, new tiles | colour ms | maps ms | maps / colour |\n|---|---|---|---|\n"
        for m in ("copies", "blend", "fusion"):
            r = tim[m]
            text += f"| {m} | {r['colour_ms']:.2f} | {r['maps_ms']:.1f} | {r['ratio']:.1f}x |\n"
        text += f"\nPeak RSS, load + 1024² colour + 3 blended maps: {tim['rss_mb']:.0f} MB\n"
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "timing": tim}, indent=1))
    if args.out:
        Path(args.out).write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
