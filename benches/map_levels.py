#!/usr/bin/env python3
"""The maps' fusion with and without its first stage, the exemplar's level correction (issue 14,
``tilesynth.builder.fusion.exemplar_levels``), on the materials of ``benches/materials.py`` (PBR: 256² crops,
derived: 192² crops, seed 1) for the default of every scheme (``omega`` ``c5``, ``wang`` and ``swang`` with their
default sets and options).

Per map: the cut seam score (*before*: ``fuse_map_atlas(level=False)``, the tile-interior fusion alone, the
default until this bench; *after*: both stages, the default now) and the two patches' own steps where the cut
runs (*reference*, ``materials._reference``); the border kink (``materials._kink_profile`` of a 384² synthesis:
the ring, d = 0, and the worst of d = 0 .. n/4); the border seam score of the same synthesis
(``metrics.seam_score``, normals decoded to [0, 1] per channel); the CPU time of the fusion. Per scheme and
material: the CPU time of the 4-map build over the colour-only build, interleaved, medians of ``--repeat``
(``time.process_time``, all threads).

    python benches/map_levels.py --pbr DATA/rocks --pbr DATA/tiles > /tmp/levels.md
    python benches/map_levels.py --pbr DATA/rocks --pbr DATA/tiles --default-only > /tmp/default.md

``--panel MAP --figure PATH``: one shaded panel of map MAP with the default fusion (first material and scheme, a
320² synthesis, tiling seed 7; a normal map shaded directly with its x, y scaled by ``--relief``, a scalar map as a
height): run it under two installs to set two trees' outputs side by side.

``--default-only``: the default fusion alone (both stages), one row per map with the albedo's border seam of the
same synthesis added (the albedo's own cut seam is the tile set's): the columns to compare two trees with (run the
script of one tree under each tree's install, then put the rows side by side).
    python benches/map_levels.py --pbr DATA/tiles --textures "" --schemes c5 --figure docs/figures/material-levels.png
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import materials as B  # noqa: E402

import tilesynth as ts  # noqa: E402
from tilesynth.base import kernels
from tilesynth.builder import materials  # noqa: E402
from tilesynth.measure.metrics import seam_score  # noqa: E402


def _inputs(args):  # noqa: ANN001, ANN202
    out = [(f"pbr:{Path(d).name}", *B.load_pbr(d, 256)) for d in args.pbr]
    for name in filter(None, args.textures.split(",")):
        ex, _ = ts.load_image(B.SHARED / f"{name}.png")
        ex = B._crop(ex, 192)[..., :3]
        out.append((name, ex, B.derive_material(ex, seed=1)))
    return out


def _kw(scheme: str) -> dict:
    return {"tileset": scheme} if scheme.startswith("c") else {"scheme": scheme}


def atlas(t: ts.TileSet, spec: materials.MapSpec, level: bool) -> np.ndarray:
    """The map's tiles as ``synth`` lays them out, fused with (``level``) or without the exemplar stage."""
    arr = t.maps[spec.name]
    a = np.ascontiguousarray(arr[t.source[..., 0], t.source[..., 1]])
    a = materials.fuse_map_atlas(t, arr, a, level=level)
    return materials.renormalise_image(a, spec.encoding or "unorm") if spec.kind == "normal" else a


def _layout(a: np.ndarray, imap: np.ndarray, size: int) -> np.ndarray:
    img = np.empty((size, size, a.shape[3]), a.dtype)
    kernels.tile_copy(np.ascontiguousarray(a), imap, img)
    return img


def _border(t: ts.TileSet, spec: materials.MapSpec, a: np.ndarray, imap: np.ndarray, size: int) -> float:
    x = materials._float_atlas(t, spec, _layout(a, imap, size)[None])[0]
    if spec.kind == "normal":
        x = np.clip((x + 1) * 0.5, 0, 1)
    return float(seam_score(x, t.tile_size).score)


def _timed_builds(ex: np.ndarray, maps: dict, scheme: str, repeat: int) -> tuple[ts.TileSet, list, list]:
    """The joint build of ``scheme`` (seed 1) and the CPU times of ``repeat`` colour-only and joint builds,
    interleaved."""
    ct, jt = [], []
    t = None
    for _ in range(repeat):  # interleaved
        c0 = time.process_time()
        ts.build(ex, seed=1, **_kw(scheme))
        c1 = time.process_time()
        t = ts.build(ex, seed=1, maps=maps, **_kw(scheme))
        ct.append(c1 - c0)
        jt.append(time.process_time() - c1)
    return t, ct, jt


def measure(name: str, ex: np.ndarray, maps: dict, scheme: str, repeat: int) -> list[str]:
    t, ct, jt = _timed_builds(ex, maps, scheme, repeat)
    _, imap = ts.synthesize(t, 384, 384, seed=7)
    alb = B._score(t, np.asarray(t.tiles))
    ratio = statistics.median(jt) / max(statistics.median(ct), 1e-9)
    rows = []
    for mname, spec in B._specs(t).items():
        cells = {}
        for level in (False, True):
            c0 = time.process_time()
            a = atlas(t, spec, level)
            cpu = time.process_time() - c0
            prof = B._kink_profile(t, spec, a, imap, 384)
            cells[level] = (B._score(t, materials._float_atlas(t, spec, a)), prof[0], prof.max(),
                            _border(t, spec, a, imap, 384), cpu)  # fmt: skip
        ref = B._reference(t, spec, atlas(t, spec, True))
        b, a_ = cells[False], cells[True]
        f = "{:.2f}".format
        rows.append(
            f"| {name} | {scheme} | {mname} | {f(b[0])} → **{f(a_[0])}** | {f(ref)} | {f(b[1])} → {f(a_[1])} | "
            f"{f(b[2])} → {f(a_[2])} | {f(b[3])} → {f(a_[3])} | {b[4]:.2f} → {a_[4]:.2f} | {f(alb)} | "
            f"{statistics.median(ct):.2f} / {statistics.median(jt):.2f} = {ratio:.2f} |"
        )
    return rows


def measure_default(name: str, ex: np.ndarray, maps: dict, scheme: str, repeat: int) -> list[str]:
    """The rows of ``--default-only``: every map with the default fusion (both stages)."""
    t, ct, jt = _timed_builds(ex, maps, scheme, repeat)
    img, imap = ts.synthesize(t, 384, 384, seed=7)
    alb = B._score(t, np.asarray(t.tiles))
    alb_border = float(seam_score(np.asarray(img, np.float64), t.tile_size).score)
    ratio = statistics.median(jt) / max(statistics.median(ct), 1e-9)
    f = "{:.2f}".format
    rows = []
    for mname, spec in B._specs(t).items():
        c0 = time.process_time()
        a = atlas(t, spec, True)
        cpu = time.process_time() - c0
        prof = B._kink_profile(t, spec, a, imap, 384)
        score = B._score(t, materials._float_atlas(t, spec, a))
        ref = B._reference(t, spec, a)
        rows.append(
            f"| {name} | {scheme} | {mname} | {f(score)} | {f(ref)} | {f(prof[0])} | "
            f"{f(_border(t, spec, a, imap, 384))} | {f(alb)} | {f(alb_border)} | {cpu:.2f} | "
            f"{statistics.median(ct):.2f} / {statistics.median(jt):.2f} = {ratio:.2f} |"
        )
    return rows


def figure(path: str, ex: np.ndarray, maps: dict, scheme: str, relief: float = 60.0, size: int = 320) -> None:
    """Shaded heights (Lambert on the height gradient x ``relief``, light from the upper left) of a ``size``²
    synthesis: the fusion without (left) and with (right) the exemplar stage."""
    from PIL import Image

    t = ts.build(ex, seed=1, maps=maps, **_kw(scheme))
    _, imap = ts.synthesize(t, size, size, seed=7)
    spec = B._specs(t)["height"]
    panels = []
    for level in (False, True):
        x = materials._float_atlas(t, spec, _layout(atlas(t, spec, level), imap, size)[None])[0][..., 0]
        panels += [B.lambert(B.height_normals(x, relief)), np.full((size, 4), 255, np.uint8)]
    Image.fromarray(np.concatenate(panels[:-1], axis=1)).save(path, optimize=True)


def panel(
    path: str, ex: np.ndarray, maps: dict, scheme: str, name: str, relief: float, size: int = 320
) -> None:
    """``--panel``: Lambert shading of map ``name`` of a ``size``² synthesis, default fusion."""
    from PIL import Image

    t = ts.build(ex, seed=1, maps=maps, **_kw(scheme))
    _, imap = ts.synthesize(t, size, size, seed=7)
    spec = B._specs(t)[name]
    x = materials._float_atlas(t, spec, _layout(atlas(t, spec, True), imap, size)[None])[0].astype(np.float64)
    if spec.kind == "normal":
        n = x.copy()
        n[..., :2] *= relief
        if spec.normal_y != "down":
            n[..., 1] = -n[..., 1]  # Y up (OpenGL) -> rows down, the light's frame
        img = B.lambert(n)
    else:
        img = B.lambert(B.height_normals(x[..., 0], relief))
    Image.fromarray(img).save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pbr", action="append", default=[], metavar="DIR")
    ap.add_argument("--textures", default=",".join(B.TEXTURES))
    ap.add_argument("--schemes", default="c5,wang,swang")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--figure", default=None, help="write the shaded figure of the first material and scheme")
    ap.add_argument("--relief", type=float, default=60.0)
    ap.add_argument("--panel", default=None, metavar="MAP", help="with --figure: one shaded panel of map MAP")
    ap.add_argument(
        "--default-only", action="store_true", help="the default fusion alone, albedo border seam added"
    )
    args = ap.parse_args(argv)
    schemes = args.schemes.split(",")
    if args.figure and args.panel:
        name, ex, maps = _inputs(args)[0]
        panel(args.figure, ex, maps, schemes[0], args.panel, args.relief)
        print(f"wrote {args.figure}")
        return 0
    if args.figure:
        name, ex, maps = _inputs(args)[0]
        figure(args.figure, ex, maps, schemes[0], args.relief)
        print(f"wrote {args.figure}")
        return 0
    if args.default_only:
        print(
            "| material | scheme | map | cut seam | reference | kink ring | border seam | albedo cut seam | "
            "albedo border seam | fusion CPU s | build CPU s colour / joint = ratio |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for name, ex, maps in _inputs(args):
            for scheme in schemes:
                for row in measure_default(name, ex, maps, scheme, args.repeat):
                    print(row, flush=True)
        return 0
    print(
        "| material | scheme | map | cut seam before → **after** | reference | kink ring | kink band | "
        "border seam | fusion CPU s | albedo cut seam | build CPU s colour / joint = ratio |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, ex, maps in _inputs(args):
        for scheme in schemes:
            for row in measure(name, ex, maps, scheme, args.repeat):
                print(row, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
