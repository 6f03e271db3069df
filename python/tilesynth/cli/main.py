"""The ``tilesynth`` command line.

Subcommands: ``build`` (exemplar -> tile set of any registered ``--scheme``, :mod:`tilesynth.schemes`), ``synth`` (tile set -> texture of any size), ``info`` (what a tile
set holds), ``sheet`` (contact sheet of the tiles), ``demo`` (all of it on the bundled exemplar).

Exit status: 0 success; 2 usage or input error (one line on stderr naming the problem, no traceback, no partial
output file); 1 internal error (a short message; set ``TILESYNTH_DEBUG=1`` for the traceback); 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
import unicodedata
import warnings
from importlib import resources
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from ..base.validate import MAX_THREADS
from ..errors import InternalError, ParameterError, TilesynthError
from ..io.images import add_png_compression_argument, set_png_compression
from ..schemes import REGISTRY, SCHEMES, Option, Scheme, get_scheme
from ..schemes.base import layout_kind, nonneg_int_text, positive_int_text
from .argtypes import int_text, origin_text, size_text

EXIT_OK, EXIT_INTERNAL, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class UsageError(Exception):
    """Raised by the argument parser instead of exiting, so every error takes the same path."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:
        raise UsageError(f"{self.prog}: {message}")


# argparse types: one rule for every integer, size and pair option (tilesynth.cli.argtypes: ASCII digits, ranges
# named in the message)
_size = size_text  # WIDTHxHEIGHT, or one integer for a square (``--size 1024`` is 1024x1024)
_nonneg = nonneg_int_text  # shared with the scheme options (schemes.base)
_pos = positive_int_text
_threads = int_text(1, MAX_THREADS)
_bits = int_text(1)  # then choices (8, 16)
_origin = origin_text


class _IndexMapAction(argparse.Action):
    """``synth --index-map``; the old spelling ``--map`` (which means a material map in ``build``) is kept and
    noted (``args.old_map_flag``)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:  # noqa: ANN001
        setattr(namespace, self.dest, values)
        if option_string == "--map":
            namespace.old_map_flag = True


def _set_name(text: str) -> str:
    from ..layouts.omega_sets import get_tileset
    from ..layouts.wang_sets import is_wang_set_name

    if is_wang_set_name(text):
        return text
    try:
        get_tileset(text)
    except (ValueError, KeyError) as exc:
        raise argparse.ArgumentTypeError(
            str(exc).strip("'\"") + "; Wang sets (--scheme wang|swang): wang8, wang18, wang<2k²>"
        ) from None
    return text


def _method(text: str) -> str:
    from ..builder.genes.select import METHODS

    name = text.strip().lower().replace("_", "-")
    if name not in METHODS:
        raise argparse.ArgumentTypeError(f"--select = {text!r}: expected one of {', '.join(METHODS)}")
    return name


SET_HELP = (
    "tile-set definition: 4, 8, 16a, 16b, 32 (the ω paper's), B (the basic 8-set of the extendable rule), n1 (17 tiles), "
    "n2 (38 tiles) or nK for any K >= 1; append x2, x3 or x4 (e.g. 16bx2, n2x2) for 2-4 omega-tiles per "
    "intermediate tile, i.e. at least that many choices at every tiling step; complete sets c<K> and "
    "c<K>x<V> (every corner tuple over K colours, hashed lookup: non-periodic, random access, --wrap; "
    "default c5, measured in benches/repetition.py); with --scheme wang or swang the edge-coloured wang8 "
    "(default, 2+2 colours), wang18 (3+3 colours) or the complete wc<K>, wc<Kh>-<Kv> (swang: wc<K>x<V>)"
)


def build_parser() -> argparse.ArgumentParser:
    from .._version import __version__

    p = _Parser(
        prog="tilesynth", description="Tile sets from one example texture, and seamless textures of any size."
    )
    p.add_argument("--version", action="version", version=f"tilesynth {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    _add_build_parser(sub)
    _add_synth_parser(sub)
    _add_info_parser(sub)
    _add_sheet_parser(sub)
    _add_demo_parser(sub)
    _add_metrics_parsers(sub)
    from .batch import add_parser as _add_batch_parser  # issue 17: tilesynth batch

    _add_batch_parser(sub)
    from .export import add_parsers as _add_export_parsers  # issue 13: export, view

    _add_export_parsers(sub)
    return p


#: ``build --help`` groups of the scheme options (:func:`_add_scheme_options`): the selection of the sample
#: patches, the Wang schemes' own options; every other one is a matching / cut option.
_SELECTION_FLAGS = ("--objective", "--rerank", "--border-tries", "--normalise")
_WANG_FLAGS = ("--cut", "--overlap", "--corners", "--samples", "--supplementary")

BUILD_DESCRIPTION = (
    "Build a tile set from one exemplar image. Most builds set only the first groups: the input and output, "
    "the tile size and the seed, and the material maps if any. The advanced groups are the levers of the methods "
    "behind tilesynth; the README's 'Command line' section says which paper each one follows."
)


def _add_build_parser(sub) -> None:  # noqa: ANN001
    """``tilesynth build``: what a user sets first (input, output, tile size, seed, material maps), then the
    advanced groups (the selection of the papers' sets, matching and cuts, the Wang schemes, output encoding)."""
    b = sub.add_parser("build", help="build a tile set from an exemplar image", description=BUILD_DESCRIPTION)
    io = b.add_argument_group("input and output")
    io.add_argument("input", help="exemplar image (PNG, JPEG, ...)")
    io.add_argument("-o", "--output", required=True, help="tile-set file to write (.tiles)")
    io.add_argument("--sheet", default=None, help="also write a contact sheet of the tiles to this PNG")
    io.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    main = b.add_argument_group("what you set")
    main.add_argument(
        "--tile-size",
        type=int_text(4),
        default=None,
        help="tile size N in pixels, even: larger tiles keep larger features whole (default: for the complete "
        "sets, c5 included, a quarter of the exemplar's shorter side rounded down to a multiple of 8; for the "
        "papers' sets half of it; at most 256)",
    )
    main.add_argument(
        "--seed",
        type=_nonneg,
        default=None,
        help="random seed; the same seed and options give the same tile set (default: a fresh random seed, "
        "printed and recorded in the tile set, see tilesynth info; batch files default to 1)",
    )
    main.add_argument("--set", default=None, type=_set_name, metavar="SET", help=SET_HELP)
    main.add_argument(
        "--scheme",
        default="omega",
        choices=SCHEMES,
        help="; ".join(f"{sc.name}: {sc.summary}" for sc in REGISTRY),
    )
    main.add_argument(
        "--threads",
        type=_threads,
        default=None,
        help="worker threads (default: TILESYNTH_NUM_THREADS or all cores)",
    )
    mat = b.add_argument_group("material maps and masks")
    from .materials import add_build_arguments  # material builds

    add_build_arguments(mat)
    _add_mask_options(mat)
    sel = b.add_argument_group(
        "advanced: choosing the sample patches",
        "which exemplar windows sit at the tile corners; mostly for the papers' tile sets (4 ... 32, B, nK)",
    )
    sel.add_argument(
        "--select",
        type=_method,
        default=None,
        metavar="METHOD",
        help="how to choose the sample patches: random (one random set), best-of (best of 100 random sets), "
        "ga (a genetic algorithm) or ais (an artificial immune system), minimising --objective (default E); "
        "default for omega: one random set for complete sets (c4, ...), for the papers' sets the best of 32 "
        "random sets by ΣD, the best 4 re-ranked by the real cut cost",
    )
    sel.add_argument(
        "--polish",
        action="store_true",
        help="after the selection, move one patch at a time to its best position until E stops falling "
        "(--objective cut: the cut polish, each patch to the best of its 3 best positions by ΣD if the cut "
        "score falls)",
    )
    sel.add_argument("--generations", type=_pos, default=None, help="generations of ga / ais (default 50)")
    sel.add_argument(
        "--population",
        type=_pos,
        default=None,
        help="population of ga / ais (default 40), count of best-of (default 100)",
    )
    cut = b.add_argument_group(
        "advanced: matching and cuts", "how each tile's matching patch is found and cut in"
    )
    wang = b.add_argument_group("advanced: Wang tiles", "only with --scheme wang or swang")
    groups = {**{f: sel for f in _SELECTION_FLAGS}, **{f: wang for f in _WANG_FLAGS}, "--recipe": main}
    _add_scheme_options(b, lambda flag: groups.get(flag, cut))
    enc = b.add_argument_group("output encoding")
    add_png_compression_argument(enc)


def _add_synth_parser(sub) -> None:  # noqa: ANN001
    """``tilesynth synth``."""
    s = sub.add_parser("synth", help="synthesize a texture from a tile set")
    s.add_argument("tileset", help="tile-set file (.tiles)")
    s.add_argument(
        "-o", "--output", required=True, help="output image (.png, 16-bit with --bits 16; .exr: float colour)"
    )
    s.add_argument(
        "--size",
        type=_size,
        required=True,
        help="output size WIDTHxHEIGHT, or SIZE for a square, e.g. 1920x1080 or 1024",
    )
    s.add_argument("--seed", type=_nonneg, default=None, help="tiling seed (default: a fresh one, printed)")
    s.add_argument(
        "--index-map",
        "--map",
        dest="map",
        action=_IndexMapAction,
        default=None,
        metavar="INDEX.npy",
        help="use this tile index map (.npy, int, rows x cols) instead of the tiler (the old spelling --map "
        "still works, with a note; build's --map is a material map)",
    )
    s.add_argument("--save-map", default=None, help="write the tile index map used to this .npy file")
    s.add_argument(
        "--with",
        dest="with_maps",
        action="append",
        default=[],
        metavar="MAP",
        help="also synthesize this map, pixel-aligned with the exemplar (normal, height, roughness, "
        "...; PNG 8/16-bit, TIFF, or .npy uint8/uint16/float32), with the same cuts and layout; "
        "written next to the output as OUT-<map name>.png (.npy for float maps), same sample type; "
        "repeatable",
    )
    s.add_argument(
        "--map-smooth",
        default="auto",
        choices=("auto", "on", "off"),
        help="Poisson-smooth the --with maps inside the cuts like the colour tiles: auto (default: if the "
        "tile set was built with --smooth), on, or off (pure copies: for labels, masks, IDs). The maps a "
        "material set stores (build --map): auto treats the seams of its scalar and normal maps as "
        "--map-seams says, never smooths its labels",
    )
    s.add_argument(
        "--map-seams",
        default="blend",
        choices=("blend", "fuse"),
        help="how the seams of the scalar and normal maps a material set stores are treated when smoothed "
        "(--map-smooth auto/on): blend (default: each cut blended over about 8 px from the two sources, "
        "relief kept) or fuse (the gradient-domain fusion of every seam over the tile interior: no level "
        "offsets left, but flatter relief)",
    )
    s.add_argument(
        "--bits",
        type=_bits,
        choices=(8, 16),
        default=None,
        help="bits per channel of the output (default: those of the exemplar)",
    )
    s.add_argument("--threads", type=_threads, default=None, help="copy threads")
    add_png_compression_argument(s)
    s.add_argument(
        "--origin",
        type=_origin,
        default=(0, 0),
        metavar="X,Y",
        help="complete sets (c3x2, wc2, ...): top-left pixel of the window of the infinite texture to "
        "write (any integers; write negative ones as --origin=-512,2048; default 0,0)",
    )
    s.add_argument(
        "--wrap",
        action="store_true",
        help="complete sets: make the output tile periodically (size a multiple of the tile size)",
    )
    from .materials import add_synth_arguments  # issue 14: --normal-y

    add_synth_arguments(s)
    s.add_argument("-q", "--quiet", action="store_true", help="no progress output")


def _add_info_parser(sub) -> None:  # noqa: ANN001
    """``tilesynth info``."""
    i = sub.add_parser("info", help="describe a tile set")
    i.add_argument("tileset", help="tile-set file (.tiles)")
    i.add_argument("--json", action="store_true", help="machine-readable output")
    i.add_argument(
        "-q", "--quiet", action="store_true", help="accepted as by every command (info writes no progress)"
    )


def _add_sheet_parser(sub) -> None:  # noqa: ANN001
    """``tilesynth sheet``."""
    sh = sub.add_parser(
        "sheet", help="write a contact sheet (all tiles, corner colours, cutting curves) as PNG"
    )
    sh.add_argument("tileset", help="tile-set file (.tiles)")
    sh.add_argument("-o", "--output", required=True, help="PNG to write")
    sh.add_argument("--no-cuts", action="store_true", help="do not draw the cutting curves")
    sh.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    add_png_compression_argument(sh)


def _add_demo_parser(sub) -> None:  # noqa: ANN001
    """``tilesynth demo``."""
    d = sub.add_parser("demo", help="build and synthesize on the bundled exemplar (lettuce leaves)")
    d.add_argument(
        "-o",
        "--output-dir",
        default="tilesynth-demo",
        help="directory for the results (default ./tilesynth-demo)",
    )
    d.add_argument("--set", default="c5", type=_set_name, metavar="SET", help=SET_HELP)
    d.add_argument("--size", type=_size, default=(1024, 1024), help="texture size (default 1024x1024)")
    d.add_argument("--seed", type=_nonneg, default=1, help="seed (default 1)")
    d.add_argument("--threads", type=_threads, default=None, help="worker threads")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    add_png_compression_argument(d)


def _add_metrics_parsers(sub) -> None:  # noqa: ANN001
    """``metrics`` and ``report`` (issue 6; implemented in :mod:`tilesynth.measure.metrics` / :mod:`tilesynth.measure.report`)."""
    from ..measure.metrics import DEFAULT_PATCH, DEFAULT_SAMPLE_SEED, DEFAULT_SAMPLE_SIZE, DEFAULT_STRIDE

    size = "x".join(map(str, DEFAULT_SAMPLE_SIZE))
    m = sub.add_parser(
        "metrics", help="quality metrics of a tile set (on a synthesized sample) or of an image"
    )
    m.add_argument("input", metavar="OUTPUT_OR_TILESET", help="a tile set (.tiles) or an image (an output)")
    m.add_argument("--json", action="store_true", help="machine-readable output")
    m.add_argument(
        "--size",
        type=_size,
        default=None,
        help=f"tile set: size of the sample to synthesize and measure (default {size})",
    )
    m.add_argument(
        "--seed",
        type=_nonneg,
        default=None,
        help=f"tile set: tiling seed of the sample (default {DEFAULT_SAMPLE_SEED})",
    )
    m.add_argument(
        "--tile-size",
        type=int_text(4),
        default=None,
        help="image: tile size of the grid the image was laid on (the seam score needs it); even and >= 4, as "
        "build's",
    )
    m.add_argument("--exemplar", default=None, help="image: the exemplar (the coherence energy needs it)")
    m.add_argument(
        "--patch", type=_pos, default=DEFAULT_PATCH, help=f"coherence patch size (default {DEFAULT_PATCH})"
    )
    m.add_argument(
        "--stride",
        type=_pos,
        default=DEFAULT_STRIDE,
        help=f"coherence patch stride (default {DEFAULT_STRIDE})",
    )
    m.add_argument("--threads", type=_threads, default=None, help="worker threads")
    m.add_argument("-q", "--quiet", action="store_true", help="no progress output (on stderr)")

    r = sub.add_parser(
        "report", help="write a visual report (PNG figures and one offline HTML page) of a tile set"
    )
    r.add_argument("tileset", help="tile-set file (.tiles)")
    r.add_argument("-o", "--output-dir", required=True, help="directory for the report (created if missing)")
    r.add_argument(
        "--size",
        type=_size,
        default=DEFAULT_SAMPLE_SIZE,
        help=f"size of the synthesized sample (default {size})",
    )
    r.add_argument(
        "--seed",
        type=_nonneg,
        default=DEFAULT_SAMPLE_SEED,
        help=f"tiling seed of the sample (default {DEFAULT_SAMPLE_SEED})",
    )
    r.add_argument(
        "--no-borders", action="store_true", help="do not write the sample with the tile borders outlined"
    )
    r.add_argument("--threads", type=_threads, default=None, help="worker threads")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress output")
    add_png_compression_argument(r)


def _metrics(args: argparse.Namespace) -> None:
    import zipfile

    from ..base.progress import Progress
    from ..io.images import load_image
    from ..measure import metrics
    from ..tileset.tilefile import TileSet

    path = args.input
    if not os.path.isfile(path):
        raise ParameterError(f"input = {path!r}: no such file")
    if zipfile.is_zipfile(path):
        if args.tile_size is not None or args.exemplar is not None:
            raise ParameterError("--tile-size and --exemplar are for images; a tile set has both")
        ts = TileSet.load(path)
        w, h = args.size or metrics.DEFAULT_SAMPLE_SIZE
        seed = metrics.DEFAULT_SAMPLE_SEED if args.seed is None else args.seed
        result = metrics.tileset_metrics(
            ts, w, h, seed, args.patch, args.stride, args.threads, progress=Progress(args.quiet)
        )
        result["input"]["path"] = path
    else:
        if args.size is not None or args.seed is not None:
            raise ParameterError("--size and --seed are for tile sets (the sample to synthesize)")
        if args.tile_size is not None and args.tile_size % 2:
            raise ParameterError(
                f"--tile-size = {args.tile_size}: must be even, as every tile size build makes"
            )
        image, _ = load_image(path)
        exemplar = None
        if args.exemplar is not None:
            try:
                exemplar = load_image(args.exemplar)[0]
            except ParameterError as exc:
                raise ParameterError(f"--exemplar: {exc}") from None
        result = metrics.image_metrics(
            image,
            args.tile_size,
            exemplar,
            None,
            args.patch,
            args.stride,
            args.threads,
            progress=Progress(args.quiet),
        )
        result["input"]["path"] = path
    if args.json:
        print(json.dumps(result, indent=1, sort_keys=True, allow_nan=False))
    else:
        print(metrics.format_metrics(result))


def _report(args: argparse.Namespace) -> None:
    from ..base.progress import Progress
    from ..measure.report import write_report
    from ..tileset.tilefile import TileSet

    prog = Progress(args.quiet)
    ts = TileSet.load(args.tileset)
    res = write_report(
        ts,
        args.output_dir,
        args.size[0],
        args.size[1],
        args.seed,
        not args.no_borders,
        args.threads,
        name=os.path.basename(args.tileset),
        progress=prog,
    )
    prog.message(f"wrote {res['files']['page']} ({len(res['files'])} files)")


# ------------------------------------------------------------------------------------------------ commands
def _add_mask_options(parser: argparse.ArgumentParser) -> None:
    """``--mask`` and ``--alpha`` (issue 14, :mod:`tilesynth.builder.masking`)."""
    parser.add_argument(
        "--mask",
        default=None,
        metavar="M.png",
        help="pixels never to use, pixel-aligned with the exemplar: white (>= 0.5) masked, black usable (an "
        "image or a .npy array); no sample patch, matching patch or cut region takes a masked pixel",
    )
    parser.add_argument(
        "--alpha",
        default="auto",
        choices=("auto", "mask", "colour"),
        help="the exemplar's alpha channel: auto (default: a mask where it is not opaque everywhere, alpha < 0.5 "
        "masked, and dropped from the tiles), mask (always), colour (matched as an ordinary channel)",
    )


def _print_input_warnings(caught: list) -> None:  # noqa: ANN001
    """The builder's :class:`tilesynth.measure.diagnose.InputWarning` as ``warning: ...`` lines on stderr; other
    warnings are shown as Python shows them."""
    from ..measure.diagnose import InputWarning

    for w in caught:
        if issubclass(w.category, InputWarning):
            print(f"warning: {w.message}", file=sys.stderr)
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)


def _add_scheme_options(parser: argparse.ArgumentParser, group: Any = None) -> None:
    """One flag per option of the registered schemes (a flag shared by several schemes is added once);
    ``group(flag)``, if given, is the argument group that shows it in ``--help``."""
    seen: dict[str, tuple[Option, Scheme]] = {}
    users: dict[str, list[str]] = {}
    for sc in REGISTRY:
        for opt in sc.options:
            if opt.flag in seen and not opt.same_flag(seen[opt.flag][0]):
                raise RuntimeError(
                    f"{opt.flag}: schemes {seen[opt.flag][1].name} and {sc.name} disagree on it"
                )
            seen.setdefault(opt.flag, (opt, sc))
            users.setdefault(opt.flag, []).append(sc.name)
    for flag, (opt, sc) in seen.items():
        opt.add_to(parser if group is None else group(flag), sc.default(opt), users[flag])


def _scheme_kwargs(args: argparse.Namespace, scheme: Scheme) -> dict:
    """The builder's keywords for ``scheme`` from the parsed flags; a flag given for a scheme that does not
    declare it is refused (one line, exit 2)."""
    mine = {opt.flag for opt in scheme.options}
    for sc in REGISTRY:
        for opt in sc.options:
            if opt.flag not in mine and opt.given(getattr(args, opt.dest), sc.default(opt)):
                users = [u.name for u in REGISTRY if any(o.flag == opt.flag for o in u.options)]
                raise ParameterError(
                    f"{opt.flag}: not used with --scheme {scheme.name} (only with {' or '.join(users)})"
                )
    return {opt.name: opt.to_builder(getattr(args, opt.dest)) for opt in scheme.options}


def _build(
    input_path: str,
    output: str,
    *,
    scheme: str = "omega",
    set_name: str | None = None,
    tile_size: int | None = None,
    seed: int | None = None,
    threads: int | None = None,
    quiet: bool = False,
    sheet: str | None = None,
    select: str | None = None,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    options: dict | None = None,
    material: dict | None = None,
    mask: str | None = None,
    alpha: str = "auto",
) -> TileSet:  # noqa: F821
    """``tilesynth build``: ``options`` are the scheme's own builder keywords (:func:`_scheme_kwargs`)."""
    from ..base.progress import Progress
    from ..io.images import load_image

    sc = get_scheme(scheme)
    prog = Progress(quiet)
    recipe = (options or {}).get("recipe")
    if recipe == "fast" and set_name == sc.default_set:  # build_omega reads a default keyword as not given
        raise ParameterError(
            f"--set {set_name} with --recipe fast: the fast recipe builds c4; leave out --recipe to build "
            f"{set_name} (the default), or --set to build c4"
        )
    set_name = set_name or sc.default_set
    sc.check_set(set_name)
    _check_tileset_name(output)
    image, bits = load_image(input_path)
    _check_output_dir(output)
    if sheet:
        _check_output_dir(sheet)
    if select in (None, "random", "best-of") and generations is not None:
        raise ParameterError(f"--generations = {generations}: only used with --select ga or ais")
    if select == "random" and population is not None:
        raise ParameterError(f"--population = {population}: not used with --select random")
    build = sc.build
    if material:  # issue 14: a material build (every map checked before any work)
        from ..builder.materials import check_maps
        from ..schemes import build_material

        check_maps(
            image.shape,
            material["maps"],
            material["map_kinds"],
            material["map_weights"],
            material["normal_y"],
        )

        def build(img: Any, **kw: Any) -> Any:
            return build_material(img, scheme=scheme, **material, **kw)

    from ..measure.diagnose import InputWarning

    with warnings.catch_warnings(record=True) as caught:  # issue 14: InputWarning -> "warning: ..." lines
        warnings.simplefilter("always", InputWarning)  # other warnings keep their filters
        ts = build(
            image,
            tileset=set_name,
            tile_size=tile_size,
            seed=seed,
            threads=threads,
            progress=prog,
            exemplar_info={"file": os.path.basename(input_path), "bits": bits},
            select=select,
            polish=polish,
            generations=generations,
            population=population,
            mask=mask,
            alpha=alpha,
            **(options or {}),
        )
    _print_input_warnings(caught)
    ts.save(output)
    sel = ts.params.get("selection", {})
    how = sel.get("method", "random") + (" + polish" if sel.get("params", {}).get("polish") else "")
    how += ", Poisson-smoothed" if ts.params.get("smooth") else ""
    how += (
        f", maps {', '.join(d['name'] + ' (' + d['kind'] + ')' for d in ts.map_specs)}"
        if ts.map_specs
        else ""
    )
    prog.message(
        f"wrote {output}: {ts.n_tiles} {sc.title} of {ts.tile_size}x{ts.tile_size} (set {set_name}, {how}, seed "
        f"{ts.params['seed']}), E = {ts.E:.6g}, {ts.timing['total_s']:.2f} s"
    )
    fixed = ts.params.get("material", {}).get("normalised", {}) if ts.map_specs else {}
    for name, note in fixed.items():
        prog.message(f"map {name}: {note}")
    if sheet:
        _write_sheet(ts, sheet, True)
        prog.message(f"wrote {sheet}: contact sheet")
    return ts


#: Suffixes of images and arrays: a tile set written under one of them would be a ZIP archive that image tools
#: cannot open (``build -o a.png``).
_NOT_TILESET_SUFFIXES = (".png", ".jpg", ".jpeg", ".exr", ".tif", ".tiff", ".bmp", ".webp", ".gif", ".npy")


def _check_tileset_name(output: str) -> None:
    suffix = Path(output).suffix.lower()
    if suffix in _NOT_TILESET_SUFFIXES:
        stem = str(Path(output).with_suffix(""))
        raise ParameterError(
            f"--output = {output!r}: build writes a tile set (a ZIP archive, .tiles), not a {suffix[1:]} file; "
            f"name it {stem}.tiles (a contact sheet of the tiles: --sheet {output}; a texture: tilesynth synth "
            f"{stem}.tiles -o {output})"
        )


def _material_args(args: argparse.Namespace) -> dict | None:
    from .materials import load_build_maps  # issue 14

    return load_build_maps(args)


def _material_info(ts: Any) -> list[str]:
    from .materials import info_lines  # issue 14

    return info_lines(ts)


def _write_sheet(ts, path: str, cuts: bool) -> None:  # noqa: ANN001
    from ..io.images import save_image
    from ..measure.render import contact_sheet

    save_image(path, contact_sheet(ts, show_cuts=cuts))


def _check_output_dir(path: str) -> None:
    parent = Path(path).parent
    if str(parent) and not parent.is_dir():
        raise ParameterError(f"output = {path!r}: directory {str(parent)!r} does not exist")


def _map_output(output: str, map_path: str, dtype: np.dtype) -> Path:
    """``OUT-<map stem>.png`` next to ``output`` (:func:`tilesynth.io.paths.map_output`)."""
    from ..io.paths import map_output

    return map_output(output, map_path, dtype)


def _synth(
    ts_path: str,
    output: str,
    size: tuple[int, int],
    seed: int | None,
    map_path: str | None,
    save_map: str | None,
    bits: int | None,
    threads: int | None,
    quiet: bool,
    with_maps: list[str] | None = None,
    map_smooth: str = "auto",
    origin: tuple[int, int] = (0, 0),
    wrap: bool = False,
    normal_y: str | None = None,
    map_flag: str = "--index-map",
    map_seams: str = "blend",
) -> None:
    from ..base.progress import Progress
    from ..base.validate import seed_int
    from ..io.images import atomic_open, file_set, save_image
    from ..synth.synthesis import check_size, synthesize
    from ..tileset.tilefile import TileSet

    prog = Progress(quiet)
    ts = TileSet.load(ts_path)
    _check_output_dir(output)
    if save_map:
        _check_output_dir(save_map)
    index_map = None
    if map_path is not None:
        from ..io.images import read_npy

        # memory-mapped first: a header that declares more data than the file holds fails here, cheaply
        index_map = read_npy(map_path, f"{map_flag} = {map_path!r}")
    from ..layouts.hashed import hash_seed, hashed_scheme

    hashed = hashed_scheme(ts, origin, wrap, index_map) is not None  # complete sets: 32-bit hashed seeds
    if with_maps and origin != (0, 0):
        raise ParameterError("--with and --origin: the maps follow the index map from (0, 0); give one")
    seed = (hash_seed(seed) if hashed else seed_int(seed)) if index_map is None else None
    bits = bits or int(ts.exemplar_info.get("bits", 8))
    out_dtype = np.float32 if Path(output).suffix.lower() == ".exr" else np.uint16 if bits == 16 else np.uint8
    # refuse up front what cannot fit: the image, plus the copy the PNG encoder makes
    check_size(ts, size[0], size[1], out_dtype, copies=2)
    maps, smooth_maps = _synth_load_maps(ts, ts_path, output, with_maps, map_smooth)
    from .materials import plan_map_outputs, write_map_outputs  # issue 14: the maps of a material set

    stored_smooth = {"auto": None, "on": True, "off": False}[map_smooth]
    stored = plan_map_outputs(
        ts,
        output,
        [("tileset", ts_path), ("--map", map_path), *(("--with", mp) for mp, _, _ in maps)],
        [
            ("--output", output),
            ("--save-map", save_map),
            *((f"--with {mp!r} output", t) for mp, _, t in maps),
        ],
        stored_smooth,
    )
    t0 = time.perf_counter()
    prog("synthesis", 0, 1)
    img, imap = synthesize(
        ts,
        size[0],
        size[1],
        seed=seed,
        index_map=index_map,
        dtype=out_dtype,
        threads=threads,
        origin=origin,
        wrap=wrap,
    )
    prog("synthesis", 1, 1)
    # the colour, the index map and every map are committed as a unit: an error or a signal before the end
    # leaves the previous files of that name as they were, never a new colour beside old maps
    with file_set():
        prog("writing image", 0, 1)
        save_image(output, img)
        prog("writing image", 1, 1)
        if save_map:
            with atomic_open(save_map) as fh:
                np.save(fh, imap, allow_pickle=False)
        _synth_write_maps(prog, ts, maps, imap, size, threads, smooth_maps)
        n = ts.tile_size  # the maps' window starts where the colour's does: at the origin's pixel in its cell
        offset = (origin[1] % n, origin[0] % n) if index_map is None else (0, 0)
        write_map_outputs(prog, ts, stored, imap, size, threads, stored_smooth, normal_y, offset, map_seams)
    how = f"seed {seed}" if seed is not None else f"map {map_path}"
    prog.message(
        f"wrote {output}: {size[0]}x{size[1]}, {imap.shape[1]}x{imap.shape[0]} tiles, {how}, "
        f"{time.perf_counter() - t0:.2f} s"
    )


def _synth_load_maps(
    ts: Any, ts_path: str, output: str, with_maps: list[str] | None, map_smooth: str
) -> tuple[list[tuple[str, np.ndarray, Path]], bool]:
    """Load and check every ``--with`` map before anything is written: ``[(path, array, output)]`` and whether
    the maps are Poisson-smoothed."""
    from ..io.images import load_raster
    from ..synth.synthesis import check_smoothable, is_smoothed

    smooth_maps = {"auto": None, "on": True, "off": False}[map_smooth]
    smooth_maps = is_smoothed(ts) if smooth_maps is None else smooth_maps
    if smooth_maps and not is_smoothed(ts) and with_maps:
        raise ParameterError(
            f"--map-smooth on: {ts_path} was not built with --smooth; there is nothing for --with maps to follow"
        )
    if map_smooth != "auto" and not with_maps and not ts.map_specs:
        raise ParameterError(f"--map-smooth {map_smooth}: only used with --with")
    maps = []  # load and check every map before writing anything
    for mp in with_maps or []:
        arr = load_raster(mp)
        eh, ew = ts.exemplar.shape[:2]
        if arr.shape[:2] != (eh, ew):
            raise ParameterError(
                f"--with = {mp!r}: the map is {arr.shape[1]}x{arr.shape[0]}, the exemplar {ew}x{eh}; a map must be "
                "pixel-aligned with the exemplar"
            )
        target = _map_output(output, mp, arr.dtype)
        if target.resolve() in {Path(output).resolve(), *(t.resolve() for _, _, t in maps)}:
            raise ParameterError(
                f"--with = {mp!r}: its output {str(target)!r} would overwrite another output"
            )
        if smooth_maps:  # refused before anything is written
            check_smoothable(arr, f"--with = {mp!r}: the map")
        maps.append((mp, arr, target))
    return maps, smooth_maps


def _synth_write_maps(
    prog: Any,
    ts: Any,
    maps: list[tuple[str, np.ndarray, Path]],
    imap: np.ndarray,
    size: tuple[int, int],
    threads: int | None,
    smooth_maps: bool,
) -> None:
    """Synthesize every ``--with`` map through the cuts and layout of the colour, and write it."""
    from ..builder.materials import requantise_with_map, turn_with_map
    from ..io.images import atomic_open, save_image
    from ..synth.synthesis import synthesize_map

    for k, (mp, arr, target) in enumerate(maps):
        prog("maps", k, len(maps))
        arr = requantise_with_map(Path(mp).stem, arr)  # issue 14: normal maps' copies at unit length too
        out_map = synthesize_map(ts, arr, imap, size[0], size[1], threads=threads, smooth=smooth_maps)
        out_map = turn_with_map(
            ts, Path(mp).stem, arr, out_map, imap
        )  # normals of turned patches (--augment)
        if smooth_maps:  # issue 14: a normal map (by its name) renormalised where smoothed
            from ..builder.materials import renormalise_with_map

            out_map = renormalise_with_map(ts, Path(mp).stem, arr, out_map, imap)
        if target.suffix == ".npy":
            with atomic_open(target) as fh:
                np.save(fh, out_map, allow_pickle=False)
        else:
            save_image(target, out_map)
        prog("maps", k + 1, len(maps))
        prog.message(
            f"wrote {target}: {mp} ({arr.dtype}, {arr.shape[2]} channel(s)) through the same cuts"
            + (", Poisson-smoothed" if smooth_maps else "")
            + "; note: it was not part of the cut (matching and cuts were chosen without it: seams may show in "
            "it); build with --map NAME=FILE to cut on it"
        )


def _printable(line: str) -> str:
    """``line`` with every control or format character (escape sequences that retitle or recolour a terminal,
    carriage returns, bidirectional overrides) written as a Python escape: the strings of a tile set's manifest
    reach the terminal as text, never as commands."""
    return "".join(
        c.encode("unicode_escape").decode("ascii") if unicodedata.category(c) in ("Cc", "Cf") else c
        for c in line
    )


def _info(ts_path: str, as_json: bool) -> None:
    from ..tileset.tilefile import TileSet

    ts = TileSet.load(ts_path)
    data = ts.manifest()
    data.pop("arrays")
    data["n_tiles"] = ts.n_tiles
    data["tile_size"] = ts.tile_size
    data["genes"] = [[int(r), int(c)] for r, c in ts.genes]
    data["timing"] = ts.timing
    data["content_sha256"] = ts.content_digest()
    data["storage"] = _storage(ts_path, ts)
    if as_json:
        print(json.dumps(data, indent=1, sort_keys=True))
        return
    p = ts.params
    sel = p.get("selection", {})
    ex = ts.exemplar_info
    lines = [
        f"tile set      {ts_path}",
        f"scheme        {ts.scheme}",
        f"set           {p.get('set')} ({ts.n_tiles} tiles, colours {''.join(_colours(ts.layout))})",
        f"tile size     {ts.tile_size}x{ts.tile_size}, {ts.channels} channel(s)",
        f"exemplar      {ex.get('file', '?')} {ex['shape'][1]}x{ex['shape'][0]}, {ex.get('bits', '?')}-bit",
        *_material_info(ts),
        *_selection_lines(sel, ts.timing.get("selection_s")),
        f"seed          {p.get('seed')}",
        *_describe(ts),
        *_quality_lines(p),
        f"build time    {ts.timing.get('total_s', float('nan')):.3f} s"
        + "".join(f", {k[:-2]} {v:.3f}" for k, v in ts.timing.items() if k != "total_s"),
        f"version       tilesynth {ts.version}, content sha256 {data['content_sha256'][:16]}",
        *_storage_lines(data["storage"]),
        "genes (row, col): "
        + ", ".join(f"{c}=({r0},{c0})" for c, (r0, c0) in zip(_colours(ts.layout), ts.genes.tolist())),
        *_mask_lines(p),
        "",
    ]
    if layout_kind(ts.layout) == "edge":
        lines += _wang_lines(ts)
        print("\n".join(map(_printable, lines)))
        return
    lines.append(
        f"{'tile':>4}  {'TL BL TR BR':<11}  {'var':>3}  {'match (row,col)':>15}  {'D_j':>12}  {'cut cost':>10}"
    )
    for row in ts.per_tile():
        lines.append(
            f"{row['index']:>4}  {' '.join(row['corners']):<11}  {row['variant']:>3}  "
            f"{'(%d,%d)' % tuple(row['match_offset']):>15}  {row['D']:>12.4f}  {row['cut_cost']:>10.4f}"
        )
    print("\n".join(map(_printable, lines)))


def _storage(ts_path: str, ts) -> dict:  # noqa: ANN001
    """The file's format version and where its bytes go (member -> [in the file, unpacked])."""
    from ..tileset.tilefile import member_sizes

    sizes = member_sizes(ts_path)
    return {
        "format_version": ts.file_version,
        "kind": "provenance" if ts.file_version == 2 else "pixels",
        "file_bytes": os.path.getsize(ts_path),
        "members": {k: list(v) for k, v in sizes.items()},
    }


def _storage_lines(st: dict) -> list[str]:
    """``info``'s lines of the file's storage: the version and the largest members."""
    mb = 1e6
    members = sorted(st["members"].items(), key=lambda kv: -kv[1][0])
    parts = ", ".join(f"{k} {v[0] / mb:.2f} MB ({v[1] / mb:.2f} unpacked)" for k, v in members[:6])
    return [
        f"storage       format {st['format_version']} ({st['kind']}), {st['file_bytes'] / mb:.2f} MB: {parts}"
    ]


def _mask_lines(p: dict) -> list[str]:
    """``info``'s lines of the mask and the input warnings of a build (issue 14), none without them."""
    from ..measure.diagnose import info_lines

    return info_lines(p)


def _describe(ts) -> list[str]:  # noqa: ANN001
    """The scheme's own ``info`` lines (its matching, its E), asked of the registry; a file of a scheme this
    version does not know still shows its E."""
    try:
        sc = get_scheme(ts.scheme)
    except ParameterError:
        sc = None
    if sc is None or sc.describe is None:
        return [f"E             {ts.E:.6g}"]
    return sc.describe(ts)


def _wang_lines(ts) -> list[str]:  # noqa: ANN001
    """Per-tile table of an edge-coloured set: the four cuts' D_boundary when the set has Cohen's cut statistics
    (``cut_stats``), else each tile's supplementary patch."""
    if ts.cut_stats is not None:
        out = [
            f"{'tile':>4}  {'N E S W':<7}  {'D_sum':>10}  {'cut cost':>10}  "
            f"{'D_boundary NE / ES / SW / WN':>36}"
        ]
        for row in ts.per_tile():
            cuts = row.get("cuts", {})
            db = " / ".join(f"{cuts[q]['D_boundary']:.4f}" for q in ("NE", "ES", "SW", "WN")) if cuts else ""
            out.append(
                f"{row['index']:>4}  {' '.join(row['edges']):<7}  {row['D']:>10.4f}  "
                f"{row['cut_cost']:>10.4f}  {db:>36}"
            )
        return out
    out = [f"{'tile':>4}  {'N E S W':<7}  {'supplementary':>15}  {'D_j':>12}  {'cut cost':>10}"]
    for row in ts.per_tile():
        out.append(
            f"{row['index']:>4}  {' '.join(row['edges']):<7}  "
            f"{'(%d,%d)' % tuple(row['match_offset']):>15}  {row['D']:>12.4f}  {row['cut_cost']:>10.4f}"
        )
    return out


def _colours(layout: dict) -> list[str]:
    """The sample colours of a layout, in gene order (Wang sets: horizontal-edge colours, then vertical)."""
    if layout_kind(layout) == "edge":
        return [*layout.get("horizontal", []), *layout.get("vertical", [])]
    return list(layout.get("colours", []))


def _quality_lines(params: dict) -> list[str]:
    from ..measure.build_measures import info_lines  # issue 15: the stored visible measures

    return info_lines(params)


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
        if sel.get("objective") in ("cut", "sum-d", "visible"):  # issue 15: λ = 1, the first stage
            obj = "normalised ΣD" if sel.get("normalise") else "ΣD"
        lines.append(
            f"              {sel['evaluations']} evaluations, {sel.get('generations', 0)} generation(s), "
            f"stopped by {sel.get('stop_reason', '?')}, {seconds or 0.0:.3f} s; "
            f"objective {obj} = {sel.get('objective_E', float('nan')):.6g}"
        )
    if (
        "border_tries" in sel
    ):  # the Wang schemes' border-aware draws (issue 14); numbers checked by the manifest
        lines.append(
            f"              border-aware: best of {sel['border_tries']} random draws, predicted border seam "
            f"{sel.get('border_seam_first', float('nan')):.3f} -> {sel.get('border_seam_predicted', float('nan')):.3f}"
            + (f", criterion {sel['border_criterion']}" if "border_criterion" in sel else "")
            + (
                f", sample patches: texture statistics {sel['sample_stats_predicted']:.4f}, colour "
                f"{sel.get('sample_colour_predicted', float('nan')):.4f}"
                + (
                    f", vertex saliency {sel['vertex_saliency_predicted']:.3f}"
                    if "vertex_saliency_predicted" in sel
                    else ""
                )
                if "sample_stats_predicted" in sel
                else ""
            )
        )
    per = sel.get("periodic")
    if isinstance(per, dict):  # issue 12: the periodic-exemplar rule (tilesynth.builder.periodic)
        lines.append(
            f"              periodic exemplar: tile size {per.get('tile_size')} from its period (autocorrelation "
            f"{per.get('shift_correlation', float('nan')):.3f} at a one-tile shift), mode {per.get('mode')}"
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
            # a tampered file may hold fewer means than bests: show what is there, never fail on it
            m_g = f"{mean[g]:.6g}" if g < len(mean) else "?"
            lines.append(f"              {g + 1:>4}: {best[g]:.6g} / {m_g}")
    return lines


def _demo(
    out_dir: str, set_name: str, size: tuple[int, int], seed: int, threads: int | None, quiet: bool
) -> None:
    from ..base.progress import Progress

    prog = Progress(quiet)
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    src = resources.files("tilesynth") / "data" / "lettuce-leaves.png"
    with resources.as_file(src) as exemplar:
        prog.message(f"exemplar: bundled lettuce-leaves.png (DCor, BSD-3-Clause) {exemplar}")
        tiles = str(d / "lettuce.tiles")
        _build(
            str(exemplar),
            tiles,
            set_name=set_name,
            seed=seed,
            threads=threads,
            quiet=quiet,
            sheet=str(d / "tiles.png"),
        )
    _synth(tiles, str(d / "texture.png"), size, seed, None, str(d / "texture-map.npy"), None, threads, quiet)
    prog.message(f"done: open {d / 'tiles.png'} and {d / 'texture.png'}")


def _run_command(args: argparse.Namespace) -> int:
    """Run the parsed command; its exit status (errors propagate to :func:`main`, which reports them)."""
    if args.command == "build":
        _build(
            args.input,
            args.output,
            scheme=args.scheme,
            set_name=args.set,
            tile_size=args.tile_size,
            seed=args.seed,
            threads=args.threads,
            quiet=args.quiet,
            sheet=args.sheet,
            select=args.select,
            polish=args.polish,
            generations=args.generations,
            population=args.population,
            options=_scheme_kwargs(args, get_scheme(args.scheme)),
            material=_material_args(args),
            mask=args.mask,
            alpha=args.alpha,
        )
    elif args.command == "synth":
        _synth(
            args.tileset,
            args.output,
            args.size,
            args.seed,
            args.map,
            args.save_map,
            args.bits,
            args.threads,
            args.quiet,
            args.with_maps,
            args.map_smooth,
            args.origin,
            args.wrap,
            args.normal_y,
            "--map" if getattr(args, "old_map_flag", False) else "--index-map",
            args.map_seams,
        )
        # after the work, so that an error stays one line
        if getattr(args, "old_map_flag", False) and not args.quiet:
            print(
                "tilesynth synth: note: --map is now --index-map (the old spelling still works)",
                file=sys.stderr,
            )
    elif args.command == "info":
        _info(args.tileset, args.json)
    elif args.command == "sheet":
        from ..base.progress import Progress
        from ..tileset.tilefile import TileSet

        tiles = TileSet.load(args.tileset)
        _write_sheet(tiles, args.output, not args.no_cuts)
        Progress(args.quiet).message(f"wrote {args.output}: contact sheet of {tiles.n_tiles} tiles")
    elif args.command == "demo":
        _demo(args.output_dir, args.set, args.size, args.seed, args.threads, args.quiet)
    elif args.command == "metrics":
        _metrics(args)
    elif args.command == "report":
        _report(args)
    elif args.command == "batch":  # issue 17: exit status 1 when any job failed
        from .batch import cli_main as _batch_main

        return _batch_main(args)
    elif args.command in ("export", "view"):  # issue 13
        from .export import run as _run_export

        _run_export(args)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``tilesynth`` command; returns the exit status."""
    from ..base.signals import EXIT_TERMINATED, Terminated, install_sigterm

    install_sigterm()  # SIGTERM removes the .part files like Ctrl-C (issue 16)
    try:
        args = build_parser().parse_args(argv)
        set_png_compression(getattr(args, "png_compression", None))
        from ..io.paths import check_command

        check_command(args)  # before any work: no output may be an input or another output (issue 16)
        return _run_command(args)
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
    except BrokenPipeError:  # stdout closed early (``tilesynth info x.tiles | head``): not an error
        with contextlib.suppress(OSError):
            sys.stdout = open(os.devnull, "w")  # noqa: SIM115 - keep the interpreter from flushing to the pipe
        return EXIT_OK
    except OSError as exc:  # unwritable output, full disk, ...
        print(f"tilesynth: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
        return EXIT_USAGE
    except Terminated:
        print("tilesynth: terminated", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("tilesynth: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except SystemExit as exc:  # --help / --version
        return int(exc.code or 0)
    except (
        MemoryError
    ) as exc:  # numpy refused an array (the Rust core raises ParameterError): too large an input
        print(
            f"tilesynth: error: out of memory: {exc or 'an allocation was refused'} (use a smaller input, "
            "tile size or output, or run where more memory is available)",
            file=sys.stderr,
        )
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - the documented last resort
        if os.environ.get("TILESYNTH_DEBUG"):
            raise
        print(f"tilesynth: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
