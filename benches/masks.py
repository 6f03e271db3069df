"""Mask bench (issue 14): masked pixels never reach an output, on every scheme; what masking costs.

For a few textures of ``../shared/textures``, each shrunk to 256 px on its longer side, with a mask:

- ``bricks-red`` with a transparent disc of 17 % of the pixels (RGBA; the alpha channel is the mask, the default
  ``alpha="auto"``), the hole filled with black;
- ``bark-lichen`` with a painted red "Z" (4 % of the pixels) and the mask of the Z;
- ``grass`` and ``pebbles`` with three random discs (about 10 %) painted magenta and masked.

For every scheme's default (``omega`` c4, ``patch`` 16a, ``wang`` wang8, ``swang`` wang8; tile size: the
scheme's default for the masked exemplar, which shrinks to fit the mask), three builds at the same tile size:
*masked* (the damaged exemplar with its mask), *unmasked* (the damaged exemplar without a mask, alpha as colour:
what happened before masks) and *clean* (the texture before the damage, no mask: the baseline of the cost).
The masked and clean builds are interleaved ``--repeat`` times; a 512² synthesis of each is traced back to the
exemplar through the provenance (:func:`tilesynth.source_map`). Columns:

- ``masked share``: the share of output pixels whose source pixel is masked (must be 0 with the mask; without
  it this is how much of the hole / paint gets copied);
- ``CPU s``, ``CPU ×``: median build CPU time (``time.process_time``) masked and clean, and their ratio (the
  Wang builds take tens of milliseconds: there the fixed cost of the mask and of the input checks, a few
  milliseconds, shows as a large ratio);
- ``seam``: border seam score of the synthesis (:func:`tilesynth.measure.metrics.seam_score`), masked and clean.

The machine is shared by other jobs: CPU times are indicative only (ratios of interleaved runs, medians).

Usage: ``python benches/masks.py [--quick] [--repeat 3] [--out benches/masks-results.md]``
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import tilesynth as ts
from tilesynth.measure.diagnose import InputWarning, stationarity
from tilesynth.measure.metrics import seam_score

TEXTURES = Path(__file__).resolve().parents[2] / "shared" / "textures"
if not TEXTURES.exists():
    TEXTURES = Path("/work/shared/textures")
SCHEMES = [("omega", "c4"), ("patch", "16a"), ("wang", "wang8"), ("swang", "wang8")]


def _load(name: str, side: int = 256) -> np.ndarray:
    im = Image.open(TEXTURES / f"{name}.png").convert("RGB")
    s = side / max(im.size)
    im = im.resize((round(im.size[0] * s), round(im.size[1] * s)), Image.LANCZOS)
    return np.asarray(im, np.float32) / 255.0


def _disc(h: int, w: int, cy: float, cx: float, frac: float) -> np.ndarray:
    r = np.sqrt(frac * h * w / np.pi)
    yy, xx = np.mgrid[:h, :w]
    return (yy - cy * h) ** 2 + (xx - cx * w) ** 2 <= r * r


def cases(quick: bool) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray, dict]]:
    """(name, damaged exemplar, clean exemplar, masked pixels, kwargs of the masked build)."""
    out = []
    b = _load("bricks-red")
    clean = b.copy()
    h, w = b.shape[:2]
    hole = _disc(h, w, 0.45, 0.55, 0.17)
    b[hole] = 0.0
    rgba = np.dstack([b, np.where(hole, 0.0, 1.0).astype(np.float32)])
    out.append(("bricks-red, 17 % alpha hole", rgba, clean, hole, {}))
    bark = _load("bark-lichen")
    clean = bark.copy()
    h, w = bark.shape[:2]
    zi = Image.new("L", (w, h), 0)
    ImageDraw.Draw(zi).line(
        [(0.3 * w, 0.28 * h), (0.68 * w, 0.28 * h), (0.32 * w, 0.7 * h), (0.7 * w, 0.7 * h)],
        fill=255,
        width=9,
    )
    z = np.asarray(zi) > 0
    bark[z] = (0.9, 0.08, 0.08)
    out.append(("bark-lichen, red Z masked", bark, clean, z, {"mask": z}))
    if not quick:
        rng = np.random.default_rng(5)
        for name in ("grass", "pebbles"):
            img = _load(name)
            clean = img.copy()
            h, w = img.shape[:2]
            m = np.zeros((h, w), bool)
            for _ in range(3):
                m |= _disc(h, w, rng.uniform(0.2, 0.8), rng.uniform(0.2, 0.8), 0.035)
            img[m] = (1.0, 0.0, 1.0)
            out.append((f"{name}, 3 magenta discs masked", img, clean, m, {"mask": m}))
    return out


def _build(ex: np.ndarray, scheme: str, tileset: str, kw: dict) -> tuple[ts.TileSet, float]:
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", InputWarning)
        t = ts.build(ex, scheme=scheme, tileset=tileset, seed=1, **kw)
    return t, time.process_time() - t0


def _measure(t: ts.TileSet, masked: np.ndarray) -> tuple[float, float]:
    img, imap = ts.synthesize(t, 512, 512, seed=7)
    where = ts.source_map(t, imap, 512, 512)
    share = float(masked[where[..., 0], where[..., 1]].mean())
    return share, seam_score(img, t.tile_size).score


def stationarity_table() -> list[str]:
    rows = [
        "| texture | brightness trend | R² | contrast trend | orientation turn ° | R² | coherence |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for p in sorted(TEXTURES.glob("*.png")):
        img, _ = ts.load_image(p)
        st = stationarity(img)
        rows.append(
            f"| {p.stem} | {st['mean_trend']:.3f} | {st['trend_r2']:.3f} | {st['contrast_trend']:.3f} "
            f"| {st['orientation_turn']:.1f} | {st['orientation_r2']:.2f} | {st['orientation_coherence']:.2f} |"
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="2 textures, 1 repeat")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=None, help="write the Markdown here too")
    a = ap.parse_args()
    repeat = 1 if a.quick else a.repeat
    lines = [
        "| exemplar | scheme | masked share (mask) | masked share (no mask) | CPU s (mask / clean) | CPU × | seam (mask) | seam (clean) |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    worst = 0.0
    for name, ex_d, ex_c, masked, kw in cases(a.quick):
        for scheme, tileset in SCHEMES:
            tm, tc = [], []
            for _ in range(repeat):  # interleaved: masked, clean, masked, ...
                t_m, s_m = _build(ex_d, scheme, tileset, kw)
                t_c, s_c = _build(ex_c, scheme, tileset, {"tile_size": t_m.tile_size})
                tm.append(s_m)
                tc.append(s_c)
            t_u, _ = _build(ex_d, scheme, tileset, {"alpha": "colour", "tile_size": t_m.tile_size})
            share_m, seam_m = _measure(t_m, masked)
            share_u, _ = _measure(t_u, masked)
            _, seam_c = _measure(t_c, masked)
            worst = max(worst, share_m)
            ratio = statistics.median(tm) / statistics.median(tc)
            lines.append(
                f"| {name} | {scheme} {tileset} ({t_m.tile_size} px) | {share_m:.4f} | {share_u:.4f} | "
                f"{statistics.median(tm):.3f} / {statistics.median(tc):.3f} | {ratio:.2f} | {seam_m:.3f} | "
                f"{seam_c:.3f} |"
            )
            print(lines[-1], flush=True)
    text = "\n".join(
        [
            "# Masks: provenance and cost (benches/masks.py)",
            "",
            f"Largest masked share of any output with its mask: {worst:.4f} (target 0). CPU × is the median "
            f"build CPU time of the masked build over the clean one at the same tile size ({repeat} interleaved "
            "runs; the machine was shared by other jobs). Seam: border seam score of a 512² synthesis (about 1 = "
            "invisible borders).",
            "",
            *lines,
            "",
            "## Non-stationarity of the shared textures (tilesynth.measure.diagnose.stationarity)",
            "",
            "The warning fires at a brightness trend >= 1.5 with R² >= 0.7, or a contrast trend >= 3; "
            "`orientation-drift` at a turn >= 15° with R² >= 0.3 and coherence >= 0.35 at every corner.",
            "",
            *stationarity_table(),
            "",
        ]
    )
    print(text)
    if a.out:
        Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
