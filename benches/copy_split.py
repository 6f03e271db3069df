"""Where the periodic copies of a c5 default output are (issue 12, item 4): matching patch, corner disc, border ring
or other kept intermediate-tile content, for the default free-region terminals or smaller ones.

Every output pixel is classed by its tile's cut mask and its position in the tile; the 16x16 grid patches that
:func:`tilesynth.measure.metrics.periodic_copies` counts as copies (same lags, same tolerance) are split by class. The
terminals are changed by wrapping :func:`tilesynth.builder.matching.levers.free_terminals` (``--disc`` as a fraction of N,
``--ring`` in pixels); the rest of the build is the library's default.

Usage: ``python benches/copy_split.py TEXTURE [--disc 0.0625] [--ring 1] [--seed 1] [--size 1024]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import tilesynth as ts
import tilesynth.builder.matching.levers as levers
from tilesynth.io.images import load_image
from tilesynth.measure.metrics import (
    COPY_PATCH,
    COPY_TOLERANCE,
    _copy_distances,
    coverage,
    cut_seam_score,
    detail_repetition,
    inner_seam_score,
    seam_score,
)
from tilesynth.measure.quality import texture_stats_distance
from tilesynth.synth.synthesis import source_map

TEXTURES = Path(__file__).resolve().parents[2] / "shared" / "textures"
if not TEXTURES.exists():
    TEXTURES = Path("/work/shared/textures")
CLASSES = ("O", "disc", "ring", "other I")


def copy_mask(img: np.ndarray, lags: int = 4) -> tuple[np.ndarray, list]:
    """The (rows, cols) bool mask of the grid patches :func:`periodic_copies` counts, and its lags."""
    best, found = _copy_distances(img.astype(np.float64), COPY_PATCH, lags)
    return best <= COPY_TOLERANCE, found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("texture")
    ap.add_argument(
        "--disc", type=float, default=None, help="corner disc radius as a fraction of N (default N/8)"
    )
    ap.add_argument("--ring", type=int, default=None, help="border ring in pixels (default 2)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--size", type=int, default=1024)
    a = ap.parse_args()
    original = levers.free_terminals

    def terminals(n, ring=None, disc=None):
        ring = a.ring if ring is None else ring
        disc = (None if a.disc is None else max(0, round(n * a.disc))) if disc is None else disc
        return original(n, ring, disc)

    levers.free_terminals = terminals
    ex = load_image(TEXTURES / f"{a.texture}.png")[0]
    t = ts.build_omega(ex, seed=a.seed)
    n, s = t.tile_size, a.size
    img, imap = ts.synthesize(t, s, s, seed=a.seed)
    src = source_map(t, imap, s, s)
    source, _ = terminals(n)
    r = 2 if a.ring is None else a.ring
    yy, xx = np.mgrid[0:n, 0:n]
    ring = (yy < r) | (yy >= n - r) | (xx < r) | (xx >= n - r)
    disc = source & ~ring
    oy, ox = np.mgrid[0:s, 0:s]
    tid = np.asarray(imap)[oy // n, ox // n]
    ly, lx = oy % n, ox % n
    cls = np.where(t.cut_masks[tid, ly, lx], 0, np.where(disc[ly, lx], 1, np.where(ring[ly, lx], 2, 3)))
    cp, lags = copy_mask(img)
    p = COPY_PATCH
    cpp = np.repeat(np.repeat(cp, p, 0), p, 1)
    cls = cls[: cpp.shape[0], : cpp.shape[1]]
    share = [float((cls == k).mean()) for k in range(4)]
    in_copies = [float((cls[cpp] == k).mean()) if cpp.any() else 0.0 for k in range(4)]
    print(f"{a.texture}: N = {n}, disc {a.disc if a.disc is not None else '1/8'} N, ring {r}, seed {a.seed}")
    print(f"  copies {cp.mean():.4f} at lags {lags}")
    print("  pixel share     " + "  ".join(f"{c} {v:.3f}" for c, v in zip(CLASSES, share)))
    print("  in copied cells " + "  ".join(f"{c} {v:.3f}" for c, v in zip(CLASSES, in_copies)))
    print(
        f"  border seam {seam_score(img, n).score:.3f}, inner seam {inner_seam_score(img, n).max:.3f}, "
        f"cut seam {cut_seam_score(t)['score']:.3f}, autocorr {detail_repetition(img).peak:.3f}, "
        f"coverage {coverage(src, ex.shape).fraction:.3f}, tex stats {texture_stats_distance(img, ex):.4f}"
    )


if __name__ == "__main__":
    main()
