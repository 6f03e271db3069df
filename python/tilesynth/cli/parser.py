"""The argument parser of the ``tilesynth`` command (:func:`build_parser`): every subcommand's options, the
exit statuses and :class:`UsageError`."""

from __future__ import annotations

import argparse
from typing import Any, NoReturn

from ..base.validate import MAX_THREADS
from ..errors import ParameterError
from ..io.images import add_png_compression_argument
from ..schemes import REGISTRY, SCHEMES, Option, Scheme
from ..schemes.base import nonneg_int_text, positive_int_text
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
    from .batch import add_parser as _add_batch_parser  # tilesynth batch

    _add_batch_parser(sub)
    from .export import add_parsers as _add_export_parsers  # export, view

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
    from .materials import add_synth_arguments  # --normal-y

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
    """``metrics`` and ``report`` (implemented in :mod:`tilesynth.measure.metrics` /
    :mod:`tilesynth.measure.report`)."""
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


def _add_mask_options(parser: argparse.ArgumentParser) -> None:
    """``--mask`` and ``--alpha`` (:mod:`tilesynth.builder.masking`)."""
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
