"""The ``tilesynth`` command line.

Subcommands: ``build`` (exemplar -> tile set), ``synth`` (tile set -> texture of any size), ``info`` (what a tile
set holds), ``sheet`` (contact sheet of the tiles), ``demo`` (all of it on the bundled exemplar).

Exit status: 0 success; 2 usage or input error (one line on stderr naming the problem, no traceback, no partial
output file); 1 internal error (a short message; set ``TILESYNTH_DEBUG=1`` for the traceback); 130 interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from importlib import resources
from pathlib import Path
from typing import NoReturn

import numpy as np

from .errors import InternalError, ParameterError, TilesynthError

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class UsageError(Exception):
    """Raised by the argument parser instead of exiting, so every error takes the same path."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message}")


def _size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*", text)
    if not m or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise argparse.ArgumentTypeError(f"--size = {text!r}: expected WIDTHxHEIGHT with positive integers, e.g. 1024x1024")
    return int(m.group(1)), int(m.group(2))


def _nonneg(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"{v} must be >= 0")
    return v


def _pos(text: str) -> int:
    v = _nonneg(text)
    if v < 1:
        raise argparse.ArgumentTypeError(f"{v} must be >= 1")
    return v


def _set_name(text: str) -> str:
    from .tilesets import get_tileset

    try:
        get_tileset(text)
    except (ValueError, KeyError) as exc:
        raise argparse.ArgumentTypeError(str(exc).strip("'\"")) from None
    return text


def _method(text: str) -> str:
    from .select import METHODS

    name = text.strip().lower().replace("_", "-")
    if name not in METHODS:
        raise argparse.ArgumentTypeError(f"--select = {text!r}: expected one of {', '.join(METHODS)}")
    return name


SET_HELP = ("tile-set definition: 4, 8, 16a, 16b, 32 (002), B (the basic 8-set of the extendable rule), n1 (17 tiles), "
            "n2 (38 tiles) or nK for any K >= 1 (default 16a)")


def build_parser() -> argparse.ArgumentParser:
    from . import __version__

    p = _Parser(prog="tilesynth", description="Tile sets from one example texture, and seamless textures of any size.")
    p.add_argument("--version", action="version", version=f"tilesynth {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    b = sub.add_parser("build", help="build a tile set from an exemplar image")
    b.add_argument("input", help="exemplar image (PNG, JPEG, ...)")
    b.add_argument("-o", "--output", required=True, help="tile-set file to write (.tiles)")
    b.add_argument("--set", default="16a", type=_set_name, metavar="SET", help=SET_HELP)
    b.add_argument("--tile-size", type=_pos, default=None, help="tile size N in pixels, even (default: half the "
                   "exemplar's shorter side, at most 256)")
    b.add_argument("--seed", type=_nonneg, default=None, help="random seed (default: a fresh one, recorded)")
    b.add_argument("--threads", type=_pos, default=None, help="worker threads (default: TILESYNTH_NUM_THREADS or all cores)")
    b.add_argument("--gradients", default="patch", choices=("patch", "tile"),
                   help="gradients of the intermediate tile in the seam weight: of the sample patches (default) or "
                   "of the assembled tile (the literal formula; cuts tend to hug the central cross)")
    b.add_argument("--literal-border", action="store_true",
                   help="002's literal cut: let the matching patch reach the tile border near the side midpoints "
                   "(default: the border ring keeps the intermediate tile, so neighbouring tiles stay continuous)")
    b.add_argument("--select", type=_method, default="random", metavar="METHOD",
                   help="how to choose the sample patches: random (default), best-of (best of 100 random sets), "
                   "ga (000's genetic algorithm) or ais (003's immune system), all minimising E")
    b.add_argument("--polish", action="store_true",
                   help="after the selection, move one patch at a time to its best position until E stops falling")
    b.add_argument("--generations", type=_pos, default=None, help="N_g of ga/ais (default 50)")
    b.add_argument("--population", type=_pos, default=None,
                   help="population of ga/ais (default 40), count of best-of (default 100)")
    b.add_argument("--normalise", action="store_true",
                   help="optimise 003's normalised objective (SSD divided by the tile's pixel count)")
    b.add_argument("--sheet", default=None, help="also write a contact sheet of the tiles to this PNG")
    b.add_argument("-q", "--quiet", action="store_true", help="no progress output")

    s = sub.add_parser("synth", help="synthesize a texture from a tile set")
    s.add_argument("tileset", help="tile-set file (.tiles)")
    s.add_argument("-o", "--output", required=True, help="output image (.png; 16-bit with --bits 16)")
    s.add_argument("--size", type=_size, required=True, help="output size WIDTHxHEIGHT, e.g. 1024x1024")
    s.add_argument("--seed", type=_nonneg, default=None, help="tiling seed (default: a fresh one, printed)")
    s.add_argument("--map", default=None, help="use this tile index map (.npy, int, rows x cols) instead of the tiler")
    s.add_argument("--save-map", default=None, help="write the tile index map used to this .npy file")
    s.add_argument("--bits", type=int, choices=(8, 16), default=None,
                   help="bits per channel of the output (default: those of the exemplar)")
    s.add_argument("--threads", type=_pos, default=None, help="copy threads")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress output")

    i = sub.add_parser("info", help="describe a tile set")
    i.add_argument("tileset", help="tile-set file (.tiles)")
    i.add_argument("--json", action="store_true", help="machine-readable output")

    sh = sub.add_parser("sheet", help="write a contact sheet (all tiles, corner colours, cutting curves) as PNG")
    sh.add_argument("tileset", help="tile-set file (.tiles)")
    sh.add_argument("-o", "--output", required=True, help="PNG to write")
    sh.add_argument("--no-cuts", action="store_true", help="do not draw the cutting curves")

    d = sub.add_parser("demo", help="build and synthesize on the bundled exemplar (lettuce leaves)")
    d.add_argument("-o", "--output-dir", default="tilesynth-demo", help="directory for the results (default ./tilesynth-demo)")
    d.add_argument("--set", default="16a", type=_set_name, metavar="SET", help=SET_HELP)
    d.add_argument("--size", type=_size, default=(1024, 1024), help="texture size (default 1024x1024)")
    d.add_argument("--seed", type=_nonneg, default=1, help="seed (default 1)")
    d.add_argument("--threads", type=_pos, default=None, help="worker threads")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    return p


# ------------------------------------------------------------------------------------------------ commands
def _build(input_path: str, output: str, set_name: str, tile_size: int | None, seed: int | None,
           threads: int | None, quiet: bool, sheet: str | None, gradients: str = "patch",
           literal_border: bool = False, select: str = "random", polish: bool = False,
           generations: int | None = None, population: int | None = None,
           normalise: bool = False) -> "TileSet":  # noqa: F821
    from .io import load_image
    from .omega import build_omega
    from .progress import Progress

    prog = Progress(quiet)
    image, bits = load_image(input_path)
    _check_output_dir(output)
    if sheet:
        _check_output_dir(sheet)
    if select in ("random", "best-of") and generations is not None:
        raise ParameterError(f"--generations = {generations}: only used with --select ga or ais")
    if select == "random" and population is not None:
        raise ParameterError(f"--population = {population}: not used with --select random")
    ts = build_omega(
        image, tileset=set_name, tile_size=tile_size, seed=seed, threads=threads, progress=prog, gradients=gradients,
        keep_border=not literal_border, exemplar_info={"file": os.path.basename(input_path), "bits": bits},
        select=select, polish=polish, generations=generations, population=population, normalise=normalise,
    )
    ts.save(output)
    sel = ts.params.get("selection", {})
    how = sel.get("method", "random") + (" + polish" if sel.get("params", {}).get("polish") else "")
    prog.message(
        f"wrote {output}: {ts.n_tiles} ω-tiles of {ts.tile_size}x{ts.tile_size} (set {set_name}, {how}, seed "
        f"{ts.params['seed']}), E = {ts.E:.6g}, {ts.timing['total_s']:.2f} s"
    )
    if sheet:
        _write_sheet(ts, sheet, True)
        prog.message(f"wrote {sheet}: contact sheet")
    return ts


def _write_sheet(ts, path: str, cuts: bool) -> None:  # noqa: ANN001
    from .io import save_image
    from .render import contact_sheet

    save_image(path, contact_sheet(ts, show_cuts=cuts))


def _check_output_dir(path: str) -> None:
    parent = Path(path).parent
    if str(parent) and not parent.is_dir():
        raise ParameterError(f"output = {path!r}: directory {str(parent)!r} does not exist")


def _synth(ts_path: str, output: str, size: tuple[int, int], seed: int | None, map_path: str | None,
           save_map: str | None, bits: int | None, threads: int | None, quiet: bool) -> None:
    from ._validate import seed_int
    from .io import atomic_open, save_image
    from .progress import Progress
    from .synthesis import check_size, synthesize
    from .tilefile import TileSet

    prog = Progress(quiet)
    ts = TileSet.load(ts_path)
    _check_output_dir(output)
    if save_map:
        _check_output_dir(save_map)
    index_map = None
    if map_path is not None:
        try:
            # memory-mapped first: a header that declares more data than the file holds fails here, cheaply
            index_map = np.array(np.load(map_path, mmap_mode="r", allow_pickle=False))
        except (OSError, ValueError) as exc:
            raise ParameterError(f"--map = {map_path!r}: not a readable .npy array ({exc})") from None
    seed = seed_int(seed) if index_map is None else None
    bits = bits or int(ts.exemplar_info.get("bits", 8))
    # refuse up front what cannot fit: the image, plus the copy the PNG encoder makes
    check_size(ts, size[0], size[1], np.uint16 if bits == 16 else np.uint8, copies=2)
    t0 = time.perf_counter()
    prog("synthesis", 0, 1)
    img, imap = synthesize(ts, size[0], size[1], seed=seed, index_map=index_map,
                           dtype=np.uint16 if bits == 16 else np.uint8, threads=threads)
    prog("synthesis", 1, 1)
    prog("writing image", 0, 1)
    save_image(output, img)
    prog("writing image", 1, 1)
    if save_map:
        with atomic_open(save_map) as fh:
            np.save(fh, imap, allow_pickle=False)
    how = f"seed {seed}" if seed is not None else f"map {map_path}"
    prog.message(f"wrote {output}: {size[0]}x{size[1]}, {imap.shape[1]}x{imap.shape[0]} tiles, {how}, "
                 f"{time.perf_counter() - t0:.2f} s")


def _info(ts_path: str, as_json: bool) -> None:
    from .tilefile import TileSet

    ts = TileSet.load(ts_path)
    data = ts.manifest()
    data.pop("arrays")
    data["n_tiles"] = ts.n_tiles
    data["tile_size"] = ts.tile_size
    data["genes"] = [[int(r), int(c)] for r, c in ts.genes]
    data["timing"] = ts.timing
    data["content_sha256"] = ts.content_digest()
    if as_json:
        print(json.dumps(data, indent=1, sort_keys=True))
        return
    p = ts.params
    sel = p.get("selection", {})
    ex = ts.exemplar_info
    lines = [
        f"tile set      {ts_path}",
        f"scheme        {ts.scheme}",
        f"set           {p.get('set')} ({ts.n_tiles} tiles, colours {''.join(ts.layout.get('colours', []))})",
        f"tile size     {ts.tile_size}x{ts.tile_size}, {ts.channels} channel(s)",
        f"exemplar      {ex.get('file', '?')} {ex['shape'][1]}x{ex['shape'][0]}, {ex.get('bits', '?')}-bit",
        *_selection_lines(sel, ts.timing.get("selection_s")),
        f"seed          {p.get('seed')}",
        f"E             {ts.E:.6g}  (λ={p.get('lambda')}: λ·ΣD + (1−λ)·Var D over the intermediate tiles)",
        f"build time    {ts.timing.get('total_s', float('nan')):.3f} s"
        + "".join(f", {k[:-2]} {v:.3f}" for k, v in ts.timing.items() if k != "total_s"),
        f"version       tilesynth {ts.version}, content sha256 {data['content_sha256'][:16]}",
        "genes (row, col): " + ", ".join(
            f"{c}=({r0},{c0})" for c, (r0, c0) in zip(ts.layout.get("colours", []), ts.genes.tolist())
        ),
        "",
        f"{'tile':>4}  {'TL BL TR BR':<11}  {'var':>3}  {'match (row,col)':>15}  {'D_j':>12}  {'cut cost':>10}",
    ]
    for row in ts.per_tile():
        lines.append(
            f"{row['index']:>4}  {' '.join(row['corners']):<11}  {row['variant']:>3}  "
            f"{'(%d,%d)' % tuple(row['match_offset']):>15}  {row['D']:>12.4f}  {row['cut_cost']:>10.4f}"
        )
    print("\n".join(lines))


def _selection_lines(sel: dict, seconds: float | None) -> list[str]:
    """The selection method, its parameters, its result and its convergence history, for ``info``."""
    params = dict(sel.get("params", {}))
    head = f"selection     {sel.get('method', '?')}"
    if params.get("polish"):
        head += " + polish"
    params.pop("polish", None)
    lines = [head + "".join(f", {k}={v}" for k, v in sorted(params.items()))]
    if "evaluations" in sel:
        obj = "normalised E" if sel.get("normalise") else "E"
        lines.append(
            f"              {sel['evaluations']} evaluations, {sel.get('generations', 0)} generation(s), "
            f"stopped by {sel.get('stop_reason', '?')}, {seconds or 0.0:.3f} s; "
            f"objective {obj} = {sel.get('objective_E', float('nan')):.6g}"
        )
    pol = sel.get("polish")
    if pol:
        lines.append(
            f"              polish: E {pol.get('E_before', float('nan')):.6g} -> "
            f"{sel.get('objective_E', float('nan')):.6g}, {pol.get('moves', 0)} moves in {pol.get('sweeps', 0)} "
            f"sweep(s), {pol.get('evaluations', 0)} evaluations"
        )
    hist = sel.get("history") or {}
    best, mean = hist.get("best", []), hist.get("mean", [])
    if len(best) > 1:
        lines.append("convergence   generation: best E / mean E")
        step = max(1, len(best) // 12)
        shown = sorted(set(range(0, len(best), step)) | {len(best) - 1})
        for g in shown:
            lines.append(f"              {g + 1:>4}: {best[g]:.6g} / {mean[g]:.6g}")
    return lines


def _demo(out_dir: str, set_name: str, size: tuple[int, int], seed: int, threads: int | None, quiet: bool) -> None:
    from .progress import Progress

    prog = Progress(quiet)
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    src = resources.files("tilesynth") / "data" / "lettuce-leaves.png"
    with resources.as_file(src) as exemplar:
        prog.message(f"exemplar: bundled lettuce-leaves.png (DCor, BSD-3-Clause) {exemplar}")
        tiles = str(d / "lettuce.tiles")
        _build(str(exemplar), tiles, set_name, None, seed, threads, quiet, str(d / "tiles.png"))
    _synth(tiles, str(d / "texture.png"), size, seed, None, str(d / "texture-map.npy"), None, threads, quiet)
    prog.message(f"done: open {d / 'tiles.png'} and {d / 'texture.png'}")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``tilesynth`` command; returns the exit status."""
    try:
        args = build_parser().parse_args(argv)
        if args.command == "build":
            _build(args.input, args.output, args.set, args.tile_size, args.seed, args.threads, args.quiet, args.sheet,
                   args.gradients, args.literal_border, args.select, args.polish, args.generations,
                   args.population, args.normalise)
        elif args.command == "synth":
            _synth(args.tileset, args.output, args.size, args.seed, args.map, args.save_map, args.bits,
                   args.threads, args.quiet)
        elif args.command == "info":
            _info(args.tileset, args.json)
        elif args.command == "sheet":
            from .tilefile import TileSet

            _write_sheet(TileSet.load(args.tileset), args.output, not args.no_cuts)
        elif args.command == "demo":
            _demo(args.output_dir, args.set, args.size, args.seed, args.threads, args.quiet)
        return EXIT_OK
    except UsageError as exc:
        print(f"{exc} (see 'tilesynth --help')", file=sys.stderr)
        return EXIT_USAGE
    except InternalError as exc:  # a caught Rust panic: a bug, not bad input
        if os.environ.get("TILESYNTH_DEBUG"):
            raise
        print(f"tilesynth: {exc}", file=sys.stderr)
        return EXIT_INTERNAL
    except TilesynthError as exc:
        print(f"tilesynth: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # unwritable output, full disk, ...
        print(f"tilesynth: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("tilesynth: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except SystemExit as exc:  # --help / --version
        return int(exc.code or 0)
    except Exception as exc:  # noqa: BLE001 - the documented last resort
        if os.environ.get("TILESYNTH_DEBUG"):
            raise
        print(f"tilesynth: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
