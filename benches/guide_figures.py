#!/usr/bin/env python3
"""The pictures of ``docs/guide.md``: outputs of each scheme's default on a few textures, side by side.

Every panel is a ``--panel`` x ``--panel`` crop (default 320) of a 1024x1024 synthesis (tiling seed 7, tile-set
seed 1) starting at pixel (64, 64), so that several tile borders and corners are inside it; the exemplars are
cropped to their central 256x256 as in ``benches/seams.py``. ``guide-wang-corners`` instead enlarges 2x the
160x160 pixels around the lattice vertex at (2N, 2N) (the tile corner is at the centre of each panel). Panels are separated by 4 white pixels, and the
file is stored as an 8-bit palette PNG (256 colours, no dithering) to keep each figure near 100-150 KB: the
colours are those of the synthesis to within the palette's rounding, so seams and repetition show as they are.

Usage::

    python benches/guide_figures.py            # writes docs/figures/guide-*.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

import tilesynth as ts

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from seams import DEFAULT_TEXTURES, load  # noqa: E402

FIGURES: dict[str, tuple[str, list[tuple[str, dict[str, Any]]]]] = {
    # name: (texture, [(scheme, builder kwargs), ...])
    "guide-wang-corners": (
        "lettuce-leaves.png",
        [
            ("wang", {"tileset": "wang8", "corners": "free", "border_tries": 1}),
            ("wang", {"tileset": "wang8"}),
        ],
    ),
    "guide-stochastic": ("rust.png", [("omega", {}), ("wang", {"tileset": "wang8"})]),
    "guide-semi-structured": ("pebbles.png", [("omega", {}), ("swang", {"tileset": "wang8"})]),
    "guide-structured": (
        "bricks-brown.png",
        [("omega", {}), ("wang", {"tileset": "wang8"}), ("swang", {"tileset": "wang8"})],
    ),
}


#: Figures shown as a 2x enlargement (nearest neighbour) of the (size/2)² pixels centred on the lattice vertex at
#: (2N, 2N), so that the tile corner sits at the centre of the panel.
ZOOM = {"guide-wang-corners"}


def panel(ex: np.ndarray, scheme: str, kw: dict[str, Any], size: int, zoom: bool) -> tuple[np.ndarray, int]:
    tiles = ts.build(ex, scheme=scheme, seed=1, **kw)
    img, _ = ts.synthesize(tiles, 1024, 1024, seed=7, dtype=np.uint8)
    if zoom:
        c, h = 2 * tiles.tile_size, size // 4
        return img[c - h : c + h, c - h : c + h].repeat(2, axis=0).repeat(2, axis=1), tiles.tile_size
    return img[64 : 64 + size, 64 : 64 + size], tiles.tile_size


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--textures", type=Path, default=DEFAULT_TEXTURES)
    ap.add_argument("--out", type=Path, default=HERE.parent / "docs" / "figures")
    ap.add_argument("--panel", type=int, default=320)
    ap.add_argument("--only", default=None)
    args = ap.parse_args(argv)
    for name, (tex, runs) in FIGURES.items():
        if args.only and args.only not in name:
            continue
        ex = load(args.textures, tex, 256)
        panels = []
        for scheme, kw in runs:
            p, n = panel(ex, scheme, kw, args.panel, name in ZOOM)
            panels.append(p)
            print(f"{name}: {tex} {scheme} {kw} tile {n}", file=sys.stderr)
        gap = np.full((args.panel, 4, 3), 255, np.uint8)
        row = np.concatenate([x for p in panels for x in (p, gap)][:-1], axis=1)
        path = args.out / f"{name}.png"
        Image.fromarray(row).quantize(256, dither=Image.Dither.NONE).save(path, optimize=True)
        print(f"{path}: {path.stat().st_size // 1024} KB", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
