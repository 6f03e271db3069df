#!/usr/bin/env python3
"""The clamped fusion correction (issue 14, ``tilesynth.builder.fusion.fuse_tiles(clamp=w)``) against the default
pinned membrane, on the materials of ``benches/materials.py`` (same builds: ``c4``, seed 1, 256² PBR / 192²
derived crops): per map, the cut seam score and the border kink profile (``materials._kink_profile``: d = 0 the
border ring, d = 1 the next pixel row, band = worst over d = 0 .. n/4) of a 384² synthesis; and, with
``--figure``, the shaded height (Lambert on the height gradient, relief x ``--relief``) and the shaded normal map
(Lambert on the decoded normals) of a 320² synthesis, membrane (top row) against clamped (bottom row).

    python benches/fusion_clamp.py --pbr DATA/rocks --pbr DATA/tiles --textures rust,roof-tiles,bricks-red,lettuce-leaves
    python benches/fusion_clamp.py --pbr DATA/tiles --textures "" --figure docs/figures/material-tiles-clamp.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import materials as B  # noqa: E402

import tilesynth as ts  # noqa: E402
from tilesynth.base import kernels
from tilesynth.builder import (
    fusion,  # noqa: E402
    materials,  # noqa: E402
)


def _with_clamp(clamp):  # noqa: ANN001, ANN202
    fusion.fuse_tiles.__defaults__ = (None, clamp)  # map_atlas calls fuse_tiles with its defaults


def _inputs(args):  # noqa: ANN001, ANN202
    out = [(f"pbr:{Path(d).name}", *B.load_pbr(d, 256)) for d in args.pbr]
    for name in filter(None, args.textures.split(",")):
        ex, _ = ts.load_image(B.SHARED / f"{name}.png")
        ex = B._crop(ex, 192)[..., :3]
        out.append((name, ex, B.derive_material(ex, seed=1)))
    return out


def figure(path: str, ex: np.ndarray, maps: dict, relief: float, size: int = 320) -> None:
    from PIL import Image

    t = ts.build(ex, tileset=B.SET, seed=1, maps=maps)
    _, imap = ts.synthesize(t, size, size, seed=7)
    rows = []
    for clamp in (None, np.inf):
        _with_clamp(clamp)
        panels = []
        for name in ("height", "normal"):
            spec = B._specs(t)[name]
            atlas = materials.map_atlas(t, spec, t.maps[name])
            img = np.empty((size, size, atlas.shape[3]), atlas.dtype)
            kernels.tile_copy(np.ascontiguousarray(atlas), imap, img)
            x = materials._float_atlas(t, spec, img[None])[0]
            if name == "height":
                nrm = B.height_normals(x[..., 0], relief)
            else:
                nrm = x * 2 - 1 if x.min() >= 0 else x.copy()
            panels += [B.lambert(nrm), np.full((size, 4), 255, np.uint8)]
        rows += [np.concatenate(panels[:-1], axis=1), np.full((4, 2 * size + 4), 255, np.uint8)]
    _with_clamp(None)
    Image.fromarray(np.concatenate(rows[:-1], axis=0)).save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--pbr", action="append", default=[], metavar="DIR")
    ap.add_argument("--textures", default=",".join(B.TEXTURES))
    ap.add_argument("--clamps", default="none,4,inf")
    ap.add_argument("--figure", default=None)
    ap.add_argument("--relief", type=float, default=60.0)
    args = ap.parse_args(argv)
    clamps = [None if c == "none" else float(c) for c in args.clamps.split(",")]
    for name, ex, maps in _inputs(args):
        if args.figure:
            figure(args.figure, ex, maps, args.relief)
            print(f"wrote {args.figure}")
            return 0
        t = ts.build(ex, tileset=B.SET, seed=1, maps=maps)
        _, imap = ts.synthesize(t, 384, 384, seed=7)
        for mname, spec in B._specs(t).items():
            cells = []
            for c in clamps:
                _with_clamp(c)
                fused = materials.map_atlas(t, spec, t.maps[mname])
                seam = B._score(t, materials._float_atlas(t, spec, fused))
                prof = B._kink_profile(t, spec, fused, imap, 384)
                cells.append(
                    f"{c}: seam {seam:.2f}, kink d0 {prof[0]:.2f} d1 {prof[1]:.2f} band {prof.max():.2f}"
                )
            _with_clamp(None)
            print(f"| {name} | {mname} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
