"""Before / after crops of the lattice bench's outputs, side by side at 1:1 (issue 29's pictures).

Each row is one texture: the default build with ``--before``'s module constants (``lattice.CONSTANTS``, e.g.
``ring2``: the free cut region before issue 29's change), then the default build, both synthesised as the lattice
bench does (``build_omega(exemplar, seed=1)``, a 1024² synthesis with seed 1), cropped to the top-left
``--crop``² pixels, a white gap of 4 px between them.

Usage: ``python benches/lattice_figure.py --textures grapes,caustics [--before ring2] [--crop 256] --out F.png``
"""

from __future__ import annotations

import argparse

import numpy as np
from lattice import CONSTANTS, _constants, texture_path

import tilesynth as ts


def crops(name: str, before: str, crop: int, size: int = 1024, seed: int = 1) -> list[np.ndarray]:
    ex = ts.load_image(texture_path(name))[0]
    out = []
    for values in (CONSTANTS[before], {}):
        with _constants(values):
            tset = ts.build_omega(ex, seed=seed)
        img, _ = ts.synthesize(tset, size, size, seed=seed)
        out.append(img[:crop, :crop, :3])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--textures", required=True, help="comma-separated names (benches/textures or ../shared)")
    ap.add_argument("--before", default="ring2", choices=sorted(CONSTANTS))
    ap.add_argument("--crop", type=int, default=256)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    rows = []
    for name in a.textures.split(","):
        b, d = crops(name, a.before, a.crop)
        gap = np.ones((a.crop, 4, 3), np.float32)
        rows += [np.concatenate([b, gap, d], axis=1), np.ones((4, 2 * a.crop + 4, 3), np.float32)]
    ts.save_image(a.out, np.concatenate(rows[:-1], axis=0))
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
