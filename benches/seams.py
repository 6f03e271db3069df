#!/usr/bin/env python3
"""Seams at tile borders and along cuts, for the default of every scheme (issue 14, item 6).

For every scheme of :data:`tilesynth.schemes.REGISTRY` built with its defaults (the set the CLI uses by default,
``Scheme.default_set``: ω ``c4``, patch ``16a``, Wang ``wang8``, s-Wang ``wang8``; every other option left at
the builder's default), plus the variants that tell the Wang corner story (Cohen's literal free corners against
pinned corners, for ``wang8`` and ``wang18``), on the textures below:

- ``border``: the border seam score S of a ``--size`` synthesis (default 1024x1024, tiling seed 7;
  :func:`tilesynth.measure.metrics.seam_score`: mean squared step across tile borders over the mean inside tiles; 1 =
  borders look like any other step, > 1 visible);
- ``cut``: the cut seam score of the tile set (:func:`tilesynth.measure.metrics.cut_seam_score`; the same ratio for the
  pixel pairs across the cutting curves inside the tiles);
- ``disc``: the share of pixel pairs across tile borders of that synthesis that are *not* continuous exemplar
  content (through the provenance, :func:`tilesynth.source_map`).

Exemplars larger than ``--crop`` (default 256) are cropped to their central ``crop x crop`` so that the ω
default (256 tiles of c4 with matching) stays a few seconds per texture on a shared 2-core machine; tile sizes
are each scheme's default for that exemplar (half the shorter side for the papers' sets and the Wang schemes,
a quarter for complete sets). Tile-set seed 1.

Usage::

    python benches/seams.py                                 # the table, Markdown, to stdout
    python benches/seams.py --json seams.json --markdown benches/seams-results.md
    python benches/seams.py --textures DIR --size 512 --only wang
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import tilesynth as ts
from tilesynth.measure import metrics
from tilesynth.schemes import REGISTRY

HERE = Path(__file__).resolve().parent
DEFAULT_TEXTURES = Path(os.environ.get("TILESYNTH_TEXTURES", HERE.parent.parent / "shared" / "textures"))

#: (file, class as in MANIFEST.tsv): 4 stochastic, 4 semi-structured, 4 structured.
TEXTURES = [
    ("gravel.png", "stochastic"),
    ("grass.png", "stochastic"),
    ("dry-soil.png", "stochastic"),
    ("rust.png", "stochastic"),
    ("pebbles.png", "semi-structured"),
    ("lettuce-leaves.png", "semi-structured"),
    ("cracked-mud.png", "semi-structured"),
    ("bark-lichen.png", "semi-structured"),
    ("bricks-brown.png", "structured"),
    ("basket-weave.png", "structured"),
    ("roof-tiles.png", "structured"),
    ("brodatz-d103-burlap.png", "structured"),
]


def variants() -> list[tuple[str, str, dict[str, Any]]]:
    """(label, scheme, builder kwargs): every scheme's default ("after"), then the Wang variants: the old defaults
    ("before": Cohen's free corners and a single random draw; s-Wang's single draw), pinned corners alone, and
    the complete edge set wc2 (every ⟨N, E, S, W⟩ over 2 + 2 colours)."""
    out = [(f"{s.name} default ({s.default_set})", s.name, {"tileset": s.default_set}) for s in REGISTRY]
    for tset in ("wang8", "wang18", "wc2"):
        if tset != "wang8":
            out.append((f"wang {tset} default", "wang", {"tileset": tset}))
        out.append(
            (
                f"wang {tset} free, 1 try (Cohen, before)",
                "wang",
                {"tileset": tset, "corners": "free", "border_tries": 1},
            )
        )
        out.append(
            (f"wang {tset} pinned, 1 try", "wang", {"tileset": tset, "corners": "pinned", "border_tries": 1})
        )
    out.append(("swang wang8 1 try (before)", "swang", {"tileset": "wang8", "border_tries": 1}))
    return out


def corner_variants() -> list[tuple[str, str, dict[str, Any]]]:
    """``--corner``: ω c4 and patch 16a with 1, 16 (ω only) and 32 border-aware draws ranked by the criteria of
    :mod:`tilesynth.builder.genes.omega_borders` ("min": smallest S_pred; "log": smallest |log S_pred|; "cap": closest to
    0.8 among S_pred <= 1), and the
    Wang-8 default with the "log" and "cap" criteria as a figure. Each row is built from explicit genes drawn here from
    ``default_rng(1)`` (the first draw is the same for every count and criterion), so the rows differ only by
    the draw the criterion kept."""
    out: list[tuple[str, str, dict[str, Any]]] = []
    for scheme, tset in (("omega", "c4"), ("patch", "16a")):
        out.append((f"{scheme} {tset} 1 try", scheme, {"tileset": tset, "_tries": 1, "_crit": "min"}))
        counts = ((16, "min"), (32, "min")) if scheme == "omega" else ((32, "min"),)
        for k, crit in (*counts, (32, "log"), (32, "cap")):
            out.append((f"{scheme} {tset} {k} {crit}", scheme, {"tileset": tset, "_tries": k, "_crit": crit}))
    for crit in ("log", "cap"):
        out.append((f"wang wang8 32 {crit}", "wang", {"tileset": "wang8", "_tries": 32, "_crit": crit}))
    return out


def corner_genes(ex: np.ndarray, scheme: str, kw: dict[str, Any]) -> dict[str, Any]:
    """The builder kwargs of a :func:`corner_variants` row: explicit genes chosen by its criterion."""
    from tilesynth.builder.genes import omega_borders as omegaborders
    from tilesynth.builder.genes import wang_borders as wangborders
    from tilesynth.builder.genes.draws import default_tile_size, random_genes
    from tilesynth.layouts.complete import default_complete_tile_size

    kw = dict(kw)
    tries, crit = kw.pop("_tries"), kw.pop("_crit")
    rng = np.random.default_rng(1)
    if scheme == "wang":  # the default's sample size and colours, then the log criterion on its S_pred
        d = ts.build(ex, scheme="wang", seed=1, border_tries=1, **kw)
        n, p, nh = d.tile_size, d.params["sample_size"], len(d.definition.horizontal)
        first = random_genes(ex.shape, len(d.genes), p, rng)
        x = ex.astype(np.float64)
        steps = wangborders._steps(x)
        g, _ = wangborders.best_of_draws(
            ex.shape, first, p, rng, tries,
            lambda g: wangborders._predict(steps, x, g, nh, n, p),
            lambda v: omegaborders._rank(v, crit),
        )  # fmt: skip
        return {**kw, "genes": g}
    # the default tile size of the scheme's set (a quarter of the exemplar for complete sets) and its colours
    n = (default_complete_tile_size if kw["tileset"].startswith("c") else default_tile_size)(ex.shape)
    colours = len(ts.get_tileset(kw["tileset"]).colours)
    first = random_genes(ex.shape, colours, n, rng)
    g, _ = omegaborders.border_aware_corner_genes(ex, first, n, rng, tries, crit)
    return {**kw, "genes": g, "tile_size": n}


def load(textures: Path, name: str, crop: int) -> np.ndarray:
    img, _ = ts.load_image(textures / name)
    h, w = img.shape[:2]
    if min(h, w) > crop:
        c = crop
        y0, x0 = (h - c) // 2, (w - c) // 2
        img = np.ascontiguousarray(img[y0 : y0 + c, x0 : x0 + c])
    return img


def discontinuous_share(tiles: ts.TileSet, imap: np.ndarray, width: int, height: int) -> float:
    """Share of the pixel pairs across tile borders that are not continuous exemplar content."""
    src = ts.source_map(tiles, imap, width, height)
    n = tiles.tile_size
    xs, ys = np.arange(n, width, n), np.arange(n, height, n)
    v_ok = (src[:, xs, 0] == src[:, xs - 1, 0]) & (src[:, xs, 1] == src[:, xs - 1, 1] + 1)
    h_ok = (src[ys, :, 0] == src[ys - 1, :, 0] + 1) & (src[ys, :, 1] == src[ys - 1, :, 1])
    return 1.0 - (int(v_ok.sum()) + int(h_ok.sum())) / (v_ok.size + h_ok.size)


def measure(
    ex: np.ndarray, scheme: str, kw: dict[str, Any], size: int, threads: int | None
) -> dict[str, Any]:
    if "_tries" in kw:
        kw = corner_genes(ex, scheme, kw)
    t0 = time.process_time()
    tiles = ts.build(ex, scheme=scheme, seed=1, threads=threads, **kw)
    t1 = time.process_time()
    img, imap = ts.synthesize(tiles, size, size, seed=7, threads=threads)
    s = metrics.seam_score(img, tiles.tile_size)
    cut = metrics.cut_seam_score(tiles)
    return {
        "tile_size": tiles.tile_size,
        "border": s.score,
        "border_x": s.ratio_x,
        "border_y": s.ratio_y,
        "cut": None if cut is None else cut["score"],
        "disc": discontinuous_share(tiles, imap, size, size),
        "corners": tiles.params.get("corners"),
        "predicted": _predicted(ex, tiles),
        "copies": metrics.periodic_copies(img).fraction,
        "autocorr": metrics.detail_repetition(img).peak,
        "hist": metrics.histogram_distance(img, ex).distance,
        "coverage": metrics.coverage(ts.source_map(tiles, imap, size, size), ex.shape).fraction,
        "build_cpu_s": t1 - t0,
    }


def _predicted(ex: np.ndarray, tiles: ts.TileSet) -> float | None:
    """S_pred of a corner set's genes (:func:`tilesynth.builder.genes.omega_borders.predicted_corner_border_seam`)."""
    if tiles.scheme not in ("omega", "patch"):
        return None
    from tilesynth.builder.genes.omega_borders import predicted_corner_border_seam

    return predicted_corner_border_seam(ex, tiles.genes, tiles.tile_size)


def fmt(v: float | None, spec: str = ".3f") -> str:
    return "–" if v is None else format(v, spec)


SHORT = {
    "omega default (c4)": "ω c4",
    "patch default (16a)": "patch 16a",
    "wang wang8 free, 1 try (Cohen, before)": "Wang-8 before",
    "wang wang8 pinned, 1 try": "Wang-8 pinned only",
    "wang default (wang8)": "Wang-8 after",
    "wang wang18 free, 1 try (Cohen, before)": "Wang-18 before",
    "wang wang18 pinned, 1 try": "Wang-18 pinned only",
    "wang wang18 default": "Wang-18 after",
    "wang wc2 free, 1 try (Cohen, before)": "wc2 before",
    "wang wc2 pinned, 1 try": "wc2 pinned only",
    "wang wc2 default": "wc2 after",
    "swang wang8 1 try (before)": "s-Wang-8 before",
    "swang default (wang8)": "s-Wang-8 after",
}
"""Column names of the Markdown tables, in their order (before, pinned only, after for each Wang scheme)."""


def markdown(rows: list[dict[str, Any]], labels: list[str], meta: dict[str, Any]) -> str:
    texs = list(dict.fromkeys(r["texture"] for r in rows))
    by = {(r["texture"], r["variant"]): r for r in rows}
    cols = [lab for lab in SHORT if lab in labels] + [lab for lab in labels if lab not in SHORT]
    head = "| texture | class | " + " | ".join(SHORT.get(c, c) for c in cols) + " |"
    rule = "|---|---|" + "---|" * len(cols)
    out = [
        "# Border and cut seams of every scheme (benches/seams.py)",
        "",
        f"Machine: {meta['machine']}; {meta['note']}.",
        f"Synthesis {meta['size']}x{meta['size']} (tiling seed 7), tile sets seed 1, exemplars cropped to their "
        f"central {meta['crop']}x{meta['crop']} when larger; tile size: each scheme's default (half the shorter "
        "side, a quarter for ω's complete set c4). *before*: the old Wang defaults (Cohen's free corners, one "
        "random draw; s-Wang one random draw); *pinned only*: pinned corners, one random draw; *after*: the "
        "defaults now (pinned corners, 32 border-aware draws). ω c4 and patch are unchanged (ω's defaults are "
        "issue 12's).",
        "",
    ]
    for key, title, spec in (
        ("border", "Border seam score (1 = tile borders like any other step; target ≤ 1.0)", ".2f"),
        ("cut", "Cut seam score of the tile set (steps across the cuts inside the tiles)", ".2f"),
        (
            "disc",
            "Share of the pixel pairs across tile borders that are not continuous exemplar content",
            "%",
        ),
    ):
        out += [f"## {title}", "", head, rule]
        for t in texs:
            cells = []
            for c in cols:
                r = by.get((t, c))
                v = None if r is None else r[key]
                cells.append("–" if v is None else (f"{100 * v:.1f} %" if spec == "%" else format(v, spec)))
            cls = next(r["class"] for r in rows if r["texture"] == t)
            out.append(f"| {t.removesuffix('.png')} | {cls} | " + " | ".join(cells) + " |")
        out.append("")
    out += ["## Border seam score over the textures", "", "| variant | min | median | max | textures > 1.0 |"]
    out.append("|---|---|---|---|---|")
    for c in cols:
        v = [by[(t, c)]["border"] for t in texs if (t, c) in by]
        if not v:
            continue
        over = [t.removesuffix(".png") for t in texs if (t, c) in by and by[(t, c)]["border"] > 1.0]
        out.append(
            f"| {SHORT.get(c, c)} | {min(v):.2f} | {float(np.median(v)):.2f} | {max(v):.2f} | "
            f"{len(over)}{': ' + ', '.join(over) if over else ''} |"
        )
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--textures", type=Path, default=DEFAULT_TEXTURES)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--crop", type=int, default=256)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument(
        "--corner", action="store_true", help="the border-aware draws of ω and patch (corner_variants)"
    )
    ap.add_argument("--only", default=None, help="measure only the variants whose label contains this text")
    ap.add_argument("--texture", action="append", default=None, help="only these texture files (repeatable)")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--markdown", type=Path, default=None)
    ap.add_argument("--note", default="", help="a line about the machine's load, copied into the Markdown")
    ap.add_argument(
        "--from-json", type=Path, default=None, help="rewrite the Markdown of an earlier --json run"
    )
    args = ap.parse_args(argv)
    if args.from_json:
        data = json.loads(args.from_json.read_text(encoding="utf-8"))
        labels = list(dict.fromkeys(r["variant"] for r in data["rows"]))
        md = markdown(data["rows"], labels, data["meta"])
        print(md)
        if args.markdown:
            args.markdown.write_text(md, encoding="utf-8")
        return 0
    todo = [
        v
        for v in (corner_variants() if args.corner else variants())
        if args.only is None or args.only in v[0]
    ]
    texs = [t for t in TEXTURES if args.texture is None or t[0] in args.texture]
    rows = []
    for name, cls in texs:
        ex = load(args.textures, name, args.crop)
        for label, scheme, kw in todo:
            r = measure(ex, scheme, kw, args.size, args.threads)
            r.update(texture=name, **{"class": cls}, variant=label, scheme=scheme, options=kw)
            rows.append(r)
            print(
                f"{name:26s} {label:36s} N={r['tile_size']:3d} border {r['border']:.3f} cut {fmt(r['cut'])} "
                f"disc {100 * r['disc']:.2f} % pred {fmt(r['predicted'])} copies {r['copies']:.3f} "
                f"ac {fmt(r['autocorr'])} hist {r['hist']:.4f} cov {r['coverage']:.3f} "
                f"({r['build_cpu_s']:.1f} s CPU)",
                file=sys.stderr,
                flush=True,
            )
    meta = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
        "note": args.note or "figures are exact (no timing); the machine was shared",
        "size": args.size,
        "crop": args.crop,
        "tilesynth": ts.__version__,
    }
    md = markdown(rows, [v[0] for v in todo], meta)
    print(md)
    if args.markdown:
        args.markdown.write_text(md, encoding="utf-8")
    if args.json:
        args.json.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
