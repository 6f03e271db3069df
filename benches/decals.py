"""Decals prototype: a sparse second layer at the lattice vertices (and edge midpoints) of a c5 default output.

Every lattice vertex of corner colour c shows the same content (the centre of sample patch c, kept by the ω cuts
in a disc of radius ``disc`` around each tile corner, :func:`tilesynth.builder.matching.levers.free_terminals`),
one of K per vertex: the folded lattice score of ``benches/lattice.py``. A decal replaces that content by one of
V exemplar patches per *site key* (the content the tiles guarantee around the site), chosen per site by a hash of
its integer coordinates, and pasted with a min-cut seam that is computed once per (key, variant) against the
guaranteed content, so it is the same wherever the key occurs (random access, no per-output work but a copy).

Prototype, bench side: the guaranteed content of every key is read from a synthesis's provenance
(``source_map``) and checked there: every site of a key must show the same exemplar pixels inside the kept disc
(pixels where the sites disagree are left out of the decal's reach, and counted). Per key: the V best
translations of the exemplar for the annulus ``r0 <= r <= r1`` around the site (masked SSD,
:meth:`tilesynth.base.kernels.SsdIndex.best_matches`), excluding translations within ``r1`` pixels (Chebyshev)
of any key's own content and of each other; then one min cut per variant (Kwatra weights of the project,
:func:`tilesynth.base.kernels.kwatra_weights` / :func:`grid_mincut`): decal inside ``r0``, the guaranteed content
outside ``r1``.

Sites: ``vertex`` (tile corners) and ``mid`` (side midpoints; they need a kept disc there too: ``--mid-disc``
adds one, as a fraction of N, by wrapping ``free_terminals``; the vertex disc is ``--disc``, default N/8).

Outputs: the 1024² (``--size``) crop, one tile in from the top-left, of a (size + 2N)² synthesis, so every site of
the crop has its whole window; the lattice bench's measures on the default (V=0) and on each V. ``--split``
splits the folded score's square by cell position (vertex discs, midpoint discs, ring, the rest by whether most
tiles show their matching patch there); ``--matching-only`` scores the cells filled with their tiles' whole
matching patches; ``--png`` / ``--figure`` write crops. Results: ``benches/lattice-results.md`` ("Vertex and
edge-midpoint decals").

Usage: ``python benches/decals.py --textures coins,gravel-grey --variants 4,8,16 --disc 0.25 [--mid-disc 0.25]
[--r0 0.8] [--split] [--matching-only] [--png DIR] [--figure docs/figures/lattice-decals-NAME.png]``
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from lattice import measure, texture_path  # the lattice bench's measures and texture lookup

import tilesynth as ts
import tilesynth.builder.matching.levers as levers
from tilesynth.base import kernels
from tilesynth.measure.lattice import folded_mean, lattice_folded
from tilesynth.measure.metrics import luminance
from tilesynth.synth.synthesis import source_map

ORIGINAL_TERMINALS = levers.free_terminals


def set_terminals(disc: float | None, mid: float | None) -> None:
    """Wrap ``free_terminals``: vertex disc ``disc`` x N (None: the default N/8) and, with ``mid``, a kept disc of
    radius ``mid`` x N around each side midpoint (a source terminal: the intermediate tile's content)."""

    def terminals(n, ring=None, d=None):
        if d is None and disc is not None:
            d = min(max(0, round(n * disc)), n // 2 - 1)
        src, sink = ORIGINAL_TERMINALS(n, ring, d)
        if mid:
            r = max(1, round(n * mid))
            yy, xx = np.mgrid[0:n, 0:n] + 0.5  # pixel centres; the site points lie on pixel corners
            h = n / 2
            for cy, cx in ((0, h), (n, h), (h, 0), (h, n)):
                src |= (yy - cy) ** 2 + (xx - cx) ** 2 <= r * r
            sink &= ~src
        return src, sink

    levers.free_terminals = terminals


def splitmix(x: int) -> int:
    x = (x + 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF
    x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & 0xFFFFFFFFFFFFFFFF
    x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & 0xFFFFFFFFFFFFFFFF
    return x ^ (x >> 31)


def site_hash(kind: int, i: int, j: int, seed: int) -> int:
    """Deterministic hash of a site's integer lattice coordinates (any integers: random access)."""
    return splitmix(splitmix(splitmix(seed * 4 + kind) ^ (i & 0xFFFFFFFF)) ^ (j & 0xFFFFFFFF))


def sites(n: int, size: int, kinds: tuple[str, ...]) -> list[tuple[int, int, int]]:
    """(kind, Y, X) of every site point (pixel corners) of a size² output: 0 vertex, 1 horizontal-edge midpoint
    (on a tile row), 2 vertical-edge midpoint (on a tile column)."""
    out = []
    h = n // 2
    for y in range(0, size + 1, n):
        for x in range(0, size + 1, n):
            if "vertex" in kinds:
                out.append((0, y, x))
            if "mid" in kinds:
                out.append((1, y, x + h))
                out.append((2, y + h, x))
    return out


def build_decals(ex, img, src, n, size, kinds, radius, r0, r1, variants):
    """The decal table of a ``size``² output ``img`` with provenance ``src``: ``{key: (variants, sites,
    contiguous)}``, each variant ``(exemplar top-left, decal mask (2R, 2R), decal pixels)``, and stats (the
    number of keys, the share of disc pixels where two sites of one key show different exemplar pixels)."""
    rr = radius
    yy, xx = np.mgrid[-rr:rr, -rr:rr] + 0.5
    dist = np.hypot(yy, xx)
    groups: dict[tuple, list[tuple[int, int, int]]] = {}
    for kind, y, x in sites(n, size, kinds):
        if y - rr < 0 or x - rr < 0 or y + rr > size or x + rr > size:
            continue
        key = (kind, *map(int, src[y - 1, x - 1]), *map(int, src[y, x]))
        groups.setdefault(key, []).append((kind, y, x))
    index = kernels.SsdIndex(ex)
    table = {}
    disagree = 0
    total = 0
    own = []
    for ss in groups.values():
        _, y, x = ss[0]
        own.append(src[y, x].astype(np.int64) - rr)  # exemplar top-left of the key's window (if contiguous)
    for key, ss in groups.items():
        kind, y, x = ss[0]
        w0 = src[y - rr : y + rr, x - rr : x + rr]
        same = np.ones((2 * rr, 2 * rr), bool)
        for _, y2, x2 in ss[1:]:
            same &= np.all(src[y2 - rr : y2 + rr, x2 - rr : x2 + rr] == w0, axis=-1)
        # the vertex content is one contiguous exemplar window (the midpoints' is two)
        contiguous = np.all(w0 - src[y, x] == np.stack(np.mgrid[-rr:rr, -rr:rr], -1), axis=-1)
        guaranteed = same & (dist <= r1 + 0.5)
        total += int((dist <= r1).sum())
        disagree += int(((dist <= r1) & ~same).sum())
        template = img[y - rr : y + rr, x - rr : x + rr]
        annulus = (dist >= r0) & (dist <= r1) & guaranteed
        k = variants + 8 * len(groups)
        offs, _ = index.best_matches(template, k=min(k, 4096), exclude_radius=r1, mask=annulus)
        chosen = []
        for o in offs:
            if any(np.abs(o - p).max() <= r1 for p in own):
                continue
            chosen.append(o)
            if len(chosen) == variants:
                break
        ents = []
        sink = ~guaranteed | (dist > r1)
        source = (dist < r0) & guaranteed
        for o in chosen:
            decal = ex[o[0] : o[0] + 2 * rr, o[1] : o[1] + 2 * rr]
            wx, wy = kernels.kwatra_weights(template, decal)
            labels, _ = kernels.grid_mincut(wx, wy, source, sink)
            ents.append((o, ~labels, decal))
        table[key] = (ents, ss, contiguous & guaranteed)
    return table, {"keys": len(groups), "disagree": disagree / max(1, total)}


def overlay(img, table, rr, seed):
    """The output with every site's hashed variant pasted, and the bool map of the decal pixels."""
    out = img.copy()
    flag = np.zeros(img.shape[:2], bool)
    for ents, ss, _ in table.values():
        if not ents:
            continue
        for kind, y, x in ss:
            o, mask, decal = ents[site_hash(kind, y, x, seed) % len(ents)]
            w = out[y - rr : y + rr, x - rr : x + rr]
            w[mask] = decal[mask]
            flag[y - rr : y + rr, x - rr : x + rr] |= mask
    return out, flag


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--textures", default="coins,gravel-grey,chalk-text,caustics,lettuce-leaves")
    ap.add_argument("--variants", default="4,8,16", help="comma-separated V (empty: the default build only)")
    ap.add_argument("--disc", type=float, default=None, help="vertex disc as a fraction of N (default 1/8)")
    ap.add_argument("--mid-disc", type=float, default=None, help="side-midpoint disc, fraction of N (off)")
    ap.add_argument("--r0", type=float, default=0.5, help="decal core radius as a fraction of the disc")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--matching-only", action="store_true", help="folded score of the matching patches laid alone"
    )
    ap.add_argument("--split", action="store_true", help="print where in the cell the folded score sits")
    ap.add_argument("--png", default=None, help="directory for the top-left 512² before / after / outlined")
    ap.add_argument(
        "--figure", default=None, help="PATH with NAME: 256² of the default build | decals | decal outlines"
    )
    a = ap.parse_args()
    set_terminals(a.disc, a.mid_disc)
    kinds = ("vertex", "mid") if a.mid_disc else ("vertex",)
    png = Path(a.png) if a.png else None
    if png:
        png.mkdir(parents=True, exist_ok=True)
    for name in a.textures.split(","):
        ex = ts.load_image(texture_path(name))[0]
        t0 = time.process_time()
        tset = ts.build_omega(ex, seed=a.seed)
        build = time.process_time() - t0
        n = tset.tile_size
        big = a.size + 2 * n
        img, imap = ts.synthesize(tset, big, big, seed=a.seed)
        src = source_map(tset, imap, big, big)
        disc = round(n * a.disc) if a.disc is not None else max(1, n // 8)
        rad = disc if not a.mid_disc else min(disc, round(n * a.mid_disc))
        rr = max(2, rad)
        r1 = rr - 1
        r0 = min(max(1.0, a.r0 * rr), r1 - 1.0)  # the decal core never meets the kept content
        crop = (slice(n, n + a.size), slice(n, n + a.size))
        base = img[crop]
        tag = (
            f"disc={a.disc or 0.125:.3f}"
            + (f" mid={a.mid_disc:.3f}" if a.mid_disc else "")
            + f" r0={a.r0:.2f}"
        )
        row = measure(base, ex, n, True)
        print(f"{name} N={n} {tag} V=0: build {build:.2f}s " + fmt(row), flush=True)
        if a.matching_only:
            print("  " + matching_only(ex, tset, imap, src, n, a.size, a.seed), flush=True)
        if a.split:
            cls = position_classes(tset, imap, n, a.size, disc, round(n * a.mid_disc) if a.mid_disc else 0)
            print("  fold split V=0: " + fold_split(base, n, cls), flush=True)
        if png:
            ts.save_image(png / f"{name}-{tag.replace(' ', '_')}-V0.png", base[:512, :512])
        for v in [int(v) for v in a.variants.split(",") if v]:
            t1 = time.process_time()
            table, st = build_decals(ex, img, src, n, big, kinds, rr, r0, r1, v)
            dt = time.process_time() - t1
            out, flag = overlay(img, table, rr, a.seed)
            area = float(flag[crop].mean())
            row = measure(out[crop], ex, n, True)
            nv = min(len(e[0]) for e in table.values())
            print(
                f"{name} N={n} {tag} V={v}: keys {st['keys']} (min variants {nv}), disagree "
                f"{st['disagree']:.4f}, decal share {area:.3f}, decal build {dt:.2f}s " + fmt(row),
                flush=True,
            )
            if a.split:
                print(f"  fold split V={v}: " + fold_split(out[crop], n, cls), flush=True)
            if png:
                ts.save_image(png / f"{name}-{tag.replace(' ', '_')}-V{v}.png", out[crop][:512, :512])
                ts.save_image(
                    png / f"{name}-{tag.replace(' ', '_')}-V{v}-outline.png",
                    outline(out, flag)[crop][:512, :512],
                )
            if a.figure:
                side = 256
                default = default_output(ex, a.seed, big, a.disc, a.mid_disc)[crop]
                parts = [
                    default[:side, :side],
                    out[crop][:side, :side],
                    outline(out, flag)[crop][:side, :side],
                ]
                c = max(p.shape[2] for p in parts)
                parts = [np.repeat(p, c // p.shape[2], axis=2) for p in parts]
                gap = np.ones((side, 4, c), np.float32)
                ts.save_image(
                    a.figure.replace("NAME", name),
                    np.concatenate([parts[0], gap, parts[1], gap, parts[2]], axis=1),
                )


def position_classes(tset, imap, n: int, size: int, disc: int, mid: int) -> dict[str, np.ndarray]:
    """Bool ``(N, N)`` masks of the cell positions: the vertex discs, the midpoint discs, the 2-px ring outside
    them, and the rest split by the share of the output's tiles that show their matching patch there (the cut
    masks; ``imap`` of the padded output, whose crop starts one tile in)."""
    yy, xx = np.mgrid[0:n, 0:n] + 0.5
    dv = np.min([np.hypot(yy - cy, xx - cx) for cy in (0, n) for cx in (0, n)], axis=0)
    dm = np.min(
        [np.hypot(yy - cy, xx - cx) for cy, cx in ((0, n / 2), (n, n / 2), (n / 2, 0), (n / 2, n))], axis=0
    )
    ring = (yy < 2) | (yy > n - 2) | (xx < 2) | (xx > n - 2)
    tiles = np.asarray(imap)[1 : 1 + size // n, 1 : 1 + size // n]
    o_share = np.asarray(tset.cut_masks)[tiles].mean(axis=(0, 1))
    vdisc = dv <= disc
    mdisc = (dm <= mid) & ~vdisc
    ring &= ~vdisc & ~mdisc
    rest = ~(vdisc | mdisc | ring)
    return {
        "vdisc": vdisc,
        "mdisc": mdisc,
        "ring": ring,
        "I": rest & (o_share < 0.5),
        "O": rest & (o_share >= 0.5),
    }


def fold_split(img: np.ndarray, n: int, cls: dict[str, np.ndarray]) -> str:
    """Per position class: its share of the cell, mean z² and its part of the folded score's square (score² =
    the mean z² over the cell)."""
    f = folded_mean(img, n)
    rows, cols = img.shape[0] // n, img.shape[1] // n
    unit = float(luminance(img)[: rows * n, : cols * n].std()) / np.sqrt(rows * cols)
    z2 = ((f - f.mean()) / unit) ** 2
    parts = [f"score² {z2.mean():.1f}"]
    for k, m in cls.items():
        if m.any():
            parts.append(f"{k} {m.mean():.3f} z² {z2[m].mean():.1f} part {z2[m].sum() / z2.size:.2f}")
    return "; ".join(parts)


def intermediate_mean(ex: np.ndarray, src: np.ndarray, n: int) -> np.ndarray:
    """Luminance ``(N, N)``: the mean over the K vertex patches of what each tile quadrant shows of its corner's
    vertex patch (the intermediate tiles' mean image; vertex centres read from the provenance ``src``)."""
    centres = {tuple(src[y, x]) for y in range(n, src.shape[0] - n, n) for x in range(n, src.shape[1] - n, n)}
    h = n // 2
    out = np.zeros((n, n))
    for qy, qx in ((0, 0), (0, 1), (1, 0), (1, 1)):
        acc = []
        for cy, cx in centres:
            ys = cy + np.arange(qy * h, qy * h + h) - qy * n
            xs = cx + np.arange(qx * h, qx * h + h) - qx * n
            if ys.min() >= 0 and xs.min() >= 0 and ys.max() < ex.shape[0] and xs.max() < ex.shape[1]:
                acc.append(luminance(ex[np.ix_(ys, xs)]))
        out[qy * h : qy * h + h, qx * h : qx * h + h] = np.mean(acc, axis=0)
    return out


def matching_only(ex: np.ndarray, tset, imap, src, n: int, size: int, seed: int) -> str:
    """The folded score of the output's cells filled with their tiles' whole matching patches (no cuts, no
    intermediate content), and of the same cells filled with uniformly random exemplar windows (the control);
    and the correlation of the matching patches' mean image with the intermediate tiles' mean image."""
    tiles = np.asarray(imap)[1 : 1 + size // n, 1 : 1 + size // n]
    offs = np.asarray(tset.match_offsets)
    rng = np.random.default_rng(seed)
    rows, cols = tiles.shape
    laid = np.zeros((rows * n, cols * n, ex.shape[2]), np.float32)
    rand = np.zeros_like(laid)
    for i in range(rows):
        for j in range(cols):
            oy, ox = offs[tiles[i, j]]
            laid[i * n : (i + 1) * n, j * n : (j + 1) * n] = ex[oy : oy + n, ox : ox + n]
            ry, rx = rng.integers(0, ex.shape[0] - n + 1), rng.integers(0, ex.shape[1] - n + 1)
            rand[i * n : (i + 1) * n, j * n : (j + 1) * n] = ex[ry : ry + n, rx : rx + n]
    corr = np.corrcoef(folded_mean(laid, n).ravel(), intermediate_mean(ex, src, n).ravel())[0, 1]
    return (
        f"fold of the matching patches alone {lattice_folded(laid, n).score:.3f}, "
        f"random exemplar windows {lattice_folded(rand, n).score:.3f}, "
        f"corr(matching patches' mean, intermediate tiles' mean) {corr:.2f}"
    )


def default_output(ex: np.ndarray, seed: int, size: int, disc, mid) -> np.ndarray:
    """The default build's ``size``² output (library terminals), for the figure's first panel."""
    levers.free_terminals = ORIGINAL_TERMINALS
    try:
        img, _ = ts.synthesize(ts.build_omega(ex, seed=seed), size, size, seed=seed)
    finally:
        set_terminals(disc, mid)
    return img


def outline(img: np.ndarray, flag: np.ndarray) -> np.ndarray:
    """RGB copy of ``img`` with the decal seams (decal pixels next to a non-decal pixel) drawn red."""
    rgb = np.repeat(img, 3, axis=2) if img.shape[2] == 1 else img[..., :3].copy()
    edge = np.zeros_like(flag)
    edge[:-1] |= flag[:-1] & ~flag[1:]
    edge[1:] |= flag[1:] & ~flag[:-1]
    edge[:, :-1] |= flag[:, :-1] & ~flag[:, 1:]
    edge[:, 1:] |= flag[:, 1:] & ~flag[:, :-1]
    rgb[edge] = (1.0, 0.0, 0.0)
    return rgb


def fmt(row: dict) -> str:
    return " ".join(f"{k}={v:.3f}" for k, v in row.items() if v is not None)


if __name__ == "__main__":
    sys.exit(main())
