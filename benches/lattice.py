"""Lattice bench: is the tile grid visible? The default build beside hex tiling and image quilting, on one grid.

For every texture (``benches/textures``: the structured, high-contrast and object photos, see its CREDITS.md;
or a name of ``../shared/textures``) the default build (``build_omega(exemplar, seed)``: the c5 complete set at
its default tile size N) is synthesized at ``--size``² and measured on its N-grid; the two controls of
``benches/repetition.py`` are laid on the same grid: ``hex`` (by-example hex tiling, triangle edge N·4/3) and
``quilt`` (image quilting, blocks of N/2, exhaustive SSD). Levers (``--methods "default;default+<lever>"``,
:data:`LEVERS`) are build options on top of the default.

Measures (:mod:`tilesynth.measure.lattice`, :mod:`tilesynth.measure.metrics`): ``grad`` lattice (gradient),
``fold`` lattice (folded) (``ex_grad`` / ``ex_fold``: the exemplar's own on the same grid; a texture whose own
period divides N scores high there too, whatever lays it out), ``hist`` the colour/gradient histogram distance to the exemplar, ``dup`` the
verbatim 16x16 duplicates (:func:`repeated_patches`), ``obj`` objects intact (only where the exemplar is one
of separate objects; its own score in the header line), and for the no-loss check on stochastic textures
``copies`` (periodic copies), ``acorr`` (detail autocorrelation peak), ``tstats`` (texture statistics
distance), ``seam`` (border seam score, tile sets only) and the build CPU seconds. ``--png DIR`` writes the
top-left 512² (or ``--size``) of every output at 1:1.

Usage: ``python benches/lattice.py [--textures a,b] [--size 1024] [--methods "default;hex;quilt"] [--out F]``
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
from repetition import hex_tiling, quilt  # the controls of the repetition bench, unchanged

import tilesynth as ts
from tilesynth.builder.matching import levers
from tilesynth.builder.tile_scale import feature_tile_size
from tilesynth.layouts.complete import default_complete_tile_size
from tilesynth.measure.lattice import lattice_folded, lattice_gradient, objects_intact
from tilesynth.measure.metrics import (
    detail_repetition,
    histogram_distance,
    periodic_copies,
    repeated_patches,
    seam_score,
)
from tilesynth.measure.quality import texture_stats_distance

HERE = Path(__file__).resolve().parent
OWN = HERE / "textures"
SHARED = HERE.parents[1] / "shared" / "textures"
if not SHARED.exists():
    SHARED = Path("/work/shared/textures")
PHOTOS = [
    "carpet-squares",
    "ceiling-grid",
    "white-tiles",
    "coins",
    "gravel-grey",
    "chalk-text",
    "pool-tiles",
    "deep-field",
]
HELD_OUT = {"pool-tiles", "deep-field"}
"""Never used to choose or tune a lever (CREDITS.md)."""
SHARED_DEFAULT = ["bark-lichen", "lettuce-leaves", "dry-soil", "bricks-red"]
LEVERS: dict[str, Callable[[np.ndarray], dict]] = {
    "scale": lambda ex: {"tile_size": feature_tile_size(ex)[0]},
    "smooth": lambda ex: {"smooth": True},
}
"""``default+<name>`` -> the build kwargs on top of the defaults, from the exemplar: ``scale`` the tile size
from the exemplar's objects (:func:`tilesynth.builder.tile_scale.feature_tile_size`), ``smooth`` Poisson
smoothing inside the cutting curves (``smooth=True``, the existing option)."""
CONSTANTS: dict[str, dict[str, object]] = {
    "ring2": {"RING": 2, "REWARD_GAP": 0},
}
"""``default+<name>`` -> module constants of :mod:`tilesynth.builder.matching.levers` set for that build only (not
build options): ``ring2`` the free cut region of before issue 29's change (a 2-px border ring and the area reward
tapering to 0 at the ring itself; the same for every tile of 16 px or more), for the before/after rows."""
METHODS = ["default", "hex", "quilt"]


def texture_path(name: str) -> Path:
    for d in (OWN, SHARED):
        p = d / f"{name}.png"
        if p.exists():
            return p
    raise SystemExit(f"texture {name!r} is in neither {OWN} nor {SHARED}")


def measure(img: np.ndarray, ex: np.ndarray, n: int, tiles: bool) -> dict:
    o = objects_intact(img, ex)
    return {
        "grad": lattice_gradient(img, n).score,
        "fold": lattice_folded(img, n).score,
        "hist": histogram_distance(img, ex).distance,
        "dup": repeated_patches(img).fraction,
        "obj": o.share if o.applies else None,
        "copies": periodic_copies(img).fraction,
        "acorr": detail_repetition(img).peak,
        "tstats": texture_stats_distance(img, ex),
        "seam": seam_score(img, n).score if tiles else None,
    }


@contextlib.contextmanager
def _constants(values: dict[str, object]) -> Iterator[None]:
    """Set constants of :mod:`tilesynth.builder.matching.levers` for one build, then restore them."""
    old = {k: getattr(levers, k) for k in values}
    try:
        for k, v in values.items():
            setattr(levers, k, v)
        yield
    finally:
        for k, v in old.items():
            setattr(levers, k, v)


def run_texture(name: str, methods: list[str], size: int, seed: int, png: Path | None) -> list[dict]:
    ex = ts.load_image(texture_path(name))[0]
    rows: list[dict] = []
    n = None
    own = objects_intact(ex, ex)
    n0 = default_complete_tile_size(ex.shape)
    # the exemplar's own lattice on the same grid: a texture whose own period divides N scores high whatever
    # lays it out (the lattice is the texture's, not the tiles')
    ex_grad, ex_fold = lattice_gradient(ex, n0).score, lattice_folded(ex, n0).score
    for method in methods:
        t = time.process_time()
        tiles = method.startswith("default")
        if tiles:
            lever = method.split("+", 1)[1] if "+" in method else None
            kw = LEVERS[lever](ex) if lever in LEVERS else {}
            with _constants(CONSTANTS.get(lever, {})):
                tset = ts.build_omega(ex, seed=seed, **kw)
            build = time.process_time() - t
            n = n or tset.tile_size
            img, _ = ts.synthesize(tset, size, size, seed=seed)
            grid = tset.tile_size
        else:
            if n is None:  # the controls lie on the default build's grid
                n = default_complete_tile_size(ex.shape)
            if method == "hex":
                img, _ = hex_tiling(ex, size, edge=n * 4 / 3, seed=seed)
            elif method == "quilt":
                img, _ = quilt(ex, size, block=max(16, n // 2), seed=seed)
            else:
                raise SystemExit(f"unknown method {method!r}")
            build = time.process_time() - t
            grid = n
        row = measure(img, ex, grid, tiles)
        row.update(
            ex_grad=ex_grad,
            ex_fold=ex_fold,
            texture=name,
            method=method,
            n=grid,
            build_s=build,
            obj_ex=own.exemplar_share if own.applies else None,
        )
        rows.append(row)
        if png is not None:
            ts.save_image(png / f"{name}-{method}.png", img[:512, :512])
        print(
            f"  {name} {method}: "
            + ", ".join(f"{k}={_f(v)}" for k, v in row.items() if k not in ("texture", "method")),
            file=sys.stderr,
            flush=True,
        )
    return rows


def _f(v, fmt=".3f") -> str:
    if v is None:
        return "n/a"
    if isinstance(v, (int, np.integer)):
        return str(v)
    return format(v, fmt)


COLS = [
    "grad",
    "fold",
    "ex_grad",
    "ex_fold",
    "hist",
    "dup",
    "obj",
    "copies",
    "acorr",
    "tstats",
    "seam",
    "build_s",
]


def table(rows: list[dict]) -> str:
    head = "| texture | method | N | " + " | ".join(COLS) + " |"
    lines = [head, "|" + "---|" * (len(COLS) + 3)]
    for r in rows:
        tag = f"{r['texture']}{' (held out)' if r['texture'] in HELD_OUT else ''}"
        lines.append(f"| {tag} | {r['method']} | {r['n']} | " + " | ".join(_f(r.get(c)) for c in COLS) + " |")
    lines += ["", "Means per method (over the textures where a column applies):", ""]
    lines += ["| method | " + " | ".join(COLS) + " |", "|" + "---|" * (len(COLS) + 1)]
    by: dict[str, list[dict]] = {}
    for r in rows:
        by.setdefault(r["method"], []).append(r)
    for m, rs in by.items():
        cells = []
        for c in COLS:
            vals = [r[c] for r in rs if r.get(c) is not None]
            cells.append(_f(float(np.mean(vals))) if vals else "n/a")
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--textures", default=None, help="comma-separated names (default: the 8 photos)")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--methods",
        default=";".join(METHODS),
        help="semicolon-separated: default, default+<lever>, hex, quilt",
    )
    ap.add_argument("--png", default=None, help="directory for the top-left 512² of every output")
    ap.add_argument("--out", default=None, help="also write the table to this Markdown file")
    a = ap.parse_args()
    names = a.textures.split(",") if a.textures else PHOTOS
    methods = a.methods.split(";")
    bad = [
        m
        for m in methods
        if m not in ("default", "hex", "quilt") and m.removeprefix("default+") not in {**LEVERS, **CONSTANTS}
    ]
    if bad:
        ap.error(f"unknown methods {bad}; levers: {sorted({**LEVERS, **CONSTANTS})}")
    png = Path(a.png) if a.png else None
    if png:
        png.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows = [r for name in names for r in run_texture(name, methods, a.size, a.seed, png)]
    text = table(rows) + (
        f"\n\n{len(names)} textures, {a.size}² outputs, seed {a.seed}, {time.perf_counter() - t0:.0f} s wall "
        "(shared 2-core machine: times indicative).\n"
    )
    print(text)
    if a.out:
        Path(a.out).write_text(text)


if __name__ == "__main__":
    main()
