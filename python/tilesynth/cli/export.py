"""The ``export`` and ``view`` subcommands (registered by :func:`tilesynth.cli.main.build_parser`)."""

from __future__ import annotations

import argparse
import re
import sys
import tempfile
from pathlib import Path
from typing import Any

from ..errors import ParameterError
from .argtypes import int_text, normal_y_text, pair_text

_pair = pair_text  # COLSxROWS, positive ASCII integers (tilesynth.cli.argtypes)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--padding",
        type=int_text(0, 256),
        default=8,
        help="gutter texels on every side of every tile (default 8)",
    )
    p.add_argument(
        "--lookup",
        default="auto",
        choices=("auto", "hash", "index_map"),
        help="hash (complete sets stored in hash order: no index texture, infinite plane), index_map "
        "(a toroidal index.png; every other set), auto (default: hash when possible)",
    )
    p.add_argument(
        "--seed", type=int_text(0, 2**32 - 1), default=0, help="hash seed in [0, 2^32) (default 0)"
    )
    p.add_argument(
        "--wrap",
        type=_pair,
        default=None,
        metavar="TXxTY",
        help="hash mode: periodic with TX x TY tiles (default: infinite, non-periodic)",
    )
    p.add_argument(
        "--index-size",
        type=_pair,
        default=None,
        metavar="COLSxROWS",
        help="index-map mode: size of the toroidal index map in tiles (default: the multiple of the "
        "set's torus period nearest 32x32)",
    )
    p.add_argument(
        "--index-seed",
        type=int_text(0, 2**63 - 1),
        default=0,
        help="index-map mode: seed of the tiling (default 0)",
    )
    p.add_argument(
        "--format",
        dest="export_format",
        default="auto",
        choices=("auto", "provenance", "atlas"),
        help="provenance (export version 2: each exemplar map once with full mips, one-bit labels and a "
        "per-tile source table; GPU memory: the maps' own plus about 8 bytes per exemplar pixel of labels for "
        "the default c5 set, 1.6x a 4-map 512² material), atlas (version 1: every tile's pixels with "
        "gutters, mips to level 3), auto (default: provenance for pure-copy omega sets, else atlas)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress output")


def add_parsers(sub: Any) -> None:
    e = sub.add_parser(
        "export",
        help="export a tile set for real time: atlases with mips, index map or hash, "
        "manifest, GLSL/WGSL/HLSL/Godot shaders, optional viewer",
    )
    e.add_argument("tileset", help="tile-set file (.tiles)")
    e.add_argument("-o", "--output-dir", required=True, help="directory to write (created if missing)")
    _common(e)
    e.add_argument(
        "--bits",
        type=int_text(1),
        choices=(8, 16),
        default=8,
        help="PNG depth of the colour atlas (default 8)",
    )
    e.add_argument(
        "--with",
        dest="with_maps",
        action="append",
        default=[],
        metavar="MAP",
        help="also export this map (pixel-aligned with the exemplar; PNG 8/16-bit, TIFF, .npy uint8/"
        "uint16/float32) as atlas_<file stem>.png (.exr for float maps); repeatable",
    )
    e.add_argument(
        "--map-smooth",
        default="auto",
        choices=("auto", "on", "off"),
        help="Poisson-smooth the --with maps like the colour tiles (as synth --map-smooth)",
    )
    e.add_argument(
        "--normal-y",
        default="up",
        type=normal_y_text,
        choices=("up", "down"),
        help="Y convention of the exported normal maps: up (OpenGL, default) or down (DirectX); +y and -y are "
        "accepted too (the manifest records +y or -y)",
    )
    e.add_argument(
        "--blend-level",
        dest="blend_levels",
        action="append",
        default=[],
        metavar="MAP=L",
        help="provenance export: weight map MAP's two sources across a cut by the label coverage from level L "
        "(>= 0; 0: a hard cut, the copies) instead of its default: smooth maps (height, roughness, normals) get "
        "the seam blend of synth (the same relief on the GPU), colour maps a hard cut (L = 0); repeatable",
    )
    e.add_argument("--viewer", action="store_true", help="also write viewer.html (offline WebGL2 viewer)")
    v = sub.add_parser("view", help="write one self-contained offline HTML viewer (WebGL2) of a tile set")
    v.add_argument("tileset", help="tile-set file (.tiles)")
    v.add_argument("-o", "--output", default=None, help="HTML file to write (default: <tileset>-viewer.html)")
    _common(v)
    v.add_argument("--open", action="store_true", help="open it in the default web browser")


def _map_name(path: str) -> str:
    name = re.sub(r"[^A-Za-z0-9_-]", "_", Path(path).stem) or "map"
    return name


def run(args: argparse.Namespace) -> None:
    from ..engine import export
    from ..io.images import load_raster
    from ..tileset.tilefile import TileSet

    tiles = TileSet.load(args.tileset)
    kw = {
        "padding": args.padding,
        "lookup": args.lookup,
        "seed": args.seed,
        "wrap": args.wrap,
        "index_size": args.index_size,
        "index_seed": args.index_seed,
        "source_path": args.tileset,
        "format": args.export_format,
    }
    if args.command == "export":
        maps = {}
        for mp in args.with_maps:
            name = _map_name(mp)
            if name in maps or name == "albedo":
                raise ParameterError(f"--with {mp!r}: map name {name!r} is taken; rename the file")
            maps[name] = load_raster(mp)
        from ..base.progress import Progress

        blend = {}
        for item in args.blend_levels:
            name, sep, value = item.partition("=")
            try:
                blend[name] = float(value)
            except ValueError:
                raise ParameterError(f"--blend-level {item!r}: expected MAP=L with L a number") from None
            if not sep:
                raise ParameterError(f"--blend-level {item!r}: expected MAP=L")
        if blend:
            kw["blend_levels"] = blend
        m = export(
            tiles,
            args.output_dir,
            maps=maps,
            bits=args.bits,
            map_smooth=args.map_smooth,
            normal_y=args.normal_y,
            viewer=args.viewer,
            # every input against every file the export writes (tilesynth.io.paths, before any write)
            inputs=[("--with", mp) for mp in args.with_maps],
            progress=Progress(getattr(args, "quiet", False)),
            **kw,
        )
        if not args.quiet and m["format_version"] == 1:
            print(
                f"wrote {len(m['files']) + 1} files to {args.output_dir} ({m['lookup']['mode']} lookup, "
                f"{m['tile_count']} tiles, atlas {m['atlas']['width']}x{m['atlas']['height']}, "
                f"mips to level {m['atlas']['max_level']})"
            )
        elif not args.quiet:
            g = m["gpu_bytes"]
            print(
                f"wrote {len(m['files']) + 1} files to {args.output_dir} (provenance export, {m['lookup']['mode']} "
                f"lookup, {m['tile_count']} tiles, {len(m['maps'])} map(s) with full mips, GPU "
                f"{g['total'] / 2**20:.2f} MiB = {g['ratio_to_maps']:.2f}x the maps')"
            )
            hard = [
                e["name"]
                for e in m["maps"]
                if e.get("kind") in ("scalar", "normal")
                and e.get("seam") == "cut"
                and e["name"] not in blend
                and args.map_smooth != "off"
            ]
            if (
                hard
            ):  # the shaders cannot blend these (the tile size): what the GPU shows differs from `synth`
                print(
                    f"note: map(s) {', '.join(hard)}: tiles of {m['tile_size']} px are not whole blocks of the seam "
                    "blend's levels (a multiple of 16, of 64 with a low band), so the shaders cut their seams hard "
                    "where tilesynth synth blends them; --format atlas bakes synth's blend into an atlas (many "
                    "times the memory)",
                    file=sys.stderr,
                )
        return
    out = (
        Path(args.output)
        if args.output
        else Path(args.tileset).with_name(Path(args.tileset).stem + "-viewer.html")
    )
    with tempfile.TemporaryDirectory() as tmp:
        export(tiles, tmp, viewer=True, **kw)
        html = (Path(tmp) / "viewer.html").read_bytes()
    from ..io.images import atomic_open

    with atomic_open(out, "wb") as fh:
        fh.write(html)
    if not args.quiet:
        print(f"wrote {out}")
    if args.open:
        import webbrowser

        webbrowser.open(out.resolve().as_uri())
