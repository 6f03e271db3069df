"""The default output on the demo exemplar beside the old 16a one (issue 12): ``docs/figures/repetition-default.png``.

Both are 1024² syntheses (seed 1) of the bundled lettuce exemplar, as ``tilesynth demo`` makes them: the old
default (``--set 16a``, its default tile size) and the current default (``--set c5``; ``--sets`` names the panels, default 16a, c4 (the default before) and c5,
default tile size, complete-set levers). Every panel shows the top-left 384² at full resolution, with the tile
lattice marked by short ticks on the panel's edges (not drawn over the texture), so that banding at the tile
period can be judged.

Usage: ``python benches/repetition_figure.py [--sets 16a,c4,c5] [--crop 384] [--out docs/figures/repetition-default.png]``
"""

from __future__ import annotations

import argparse
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import tilesynth as ts
from tilesynth.io.images import load_image


def panel(set_name: str, ex: np.ndarray, crop: int) -> tuple[np.ndarray, int, str]:
    tset = ts.build_omega(ex, tileset=set_name, seed=1)
    img, _ = ts.synthesize(tset, 1024, 1024, seed=1, dtype=np.uint8)
    return img[:crop, :crop], tset.tile_size, f"{set_name} (N = {tset.tile_size}, {tset.n_tiles} tiles)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sets", default="16a,c4,c5")
    ap.add_argument("--crop", type=int, default=384)
    ap.add_argument("--out", default="docs/figures/repetition-default.png")
    a = ap.parse_args()
    ex = load_image(resources.files("tilesynth") / "data" / "lettuce-leaves.png")[0]
    panels = [panel(s, ex, a.crop) for s in a.sets.split(",")]
    pad, tick, label_h = 8, 6, 18
    w = len(panels) * (a.crop + 2 * tick) + (len(panels) + 1) * pad
    h = a.crop + 2 * tick + label_h + 2 * pad
    canvas = Image.new("RGB", (w, h), (255, 255, 255))
    draw = ImageDraw.Draw(canvas)
    for i, (img, n, label) in enumerate(panels):
        x0 = pad + i * (a.crop + 2 * tick + pad) + tick
        y0 = pad + label_h + tick
        canvas.paste(Image.fromarray(img), (x0, y0))
        draw.text((x0, pad), label, fill=(0, 0, 0))
        for t in range(0, a.crop + 1, n):  # lattice ticks outside the image
            draw.line([(x0 + t, y0 - tick), (x0 + t, y0 - 1)], fill=(200, 0, 0))
            draw.line([(x0 + t, y0 + a.crop), (x0 + t, y0 + a.crop + tick - 1)], fill=(200, 0, 0))
            draw.line([(x0 - tick, y0 + t), (x0 - 1, y0 + t)], fill=(200, 0, 0))
            draw.line([(x0 + a.crop, y0 + t), (x0 + a.crop + tick - 1, y0 + t)], fill=(200, 0, 0))
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    canvas.save(a.out, optimize=True)
    print(f"wrote {a.out} ({w}x{h})")


if __name__ == "__main__":
    main()
