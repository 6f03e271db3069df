"""The ``tilesynth`` command line.

Subcommands: ``build`` (exemplar -> tile set of any registered ``--scheme``, :mod:`tilesynth.schemes`), ``synth`` (tile set -> texture of any size), ``info`` (what a tile
set holds), ``sheet`` (contact sheet of the tiles), ``demo`` (all of it on the bundled exemplar).

Exit status: 0 success; 2 usage or input error (one line on stderr naming the problem, no traceback, no partial
output file); 1 internal error (a short message; set ``TILESYNTH_DEBUG=1`` for the traceback); 130 interrupted.

This module keeps :func:`main`, the dispatch and the demo; the parser is in :mod:`tilesynth.cli.parser`, the
commands in ``build_command``, ``synth_command``, ``info_command`` and ``metrics_command`` (``metrics``,
``report``), all re-exported here.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from importlib import resources
from pathlib import Path

from ..errors import InternalError, TilesynthError
from ..io.images import set_png_compression
from ..schemes import get_scheme
from .build_command import (  # noqa: F401 - re-exported: tilesynth.cli.main.<name> stays the import path
    _NOT_TILESET_SUFFIXES,
    _build,
    _check_output_dir,
    _check_tileset_name,
    _map_output,
    _material_args,
    _material_info,
    _print_input_warnings,
    _write_sheet,
)
from .info_command import (  # noqa: F401 - re-exported: tilesynth.cli.main.<name> stays the import path
    _colours,
    _describe,
    _info,
    _mask_lines,
    _printable,
    _quality_lines,
    _selection_lines,
    _storage,
    _storage_lines,
    _wang_lines,
)
from .metrics_command import (  # noqa: F401 - re-exported: tilesynth.cli.main.<name> stays the import path
    _metrics,
    _report,
)
from .parser import (  # noqa: F401 - re-exported: tilesynth.cli.main.<name> stays the import path
    _SELECTION_FLAGS,
    _WANG_FLAGS,
    BUILD_DESCRIPTION,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    EXIT_USAGE,
    SET_HELP,
    UsageError,
    _add_build_parser,
    _add_demo_parser,
    _add_info_parser,
    _add_mask_options,
    _add_metrics_parsers,
    _add_scheme_options,
    _add_sheet_parser,
    _add_synth_parser,
    _bits,
    _IndexMapAction,
    _method,
    _nonneg,
    _origin,
    _Parser,
    _pos,
    _scheme_kwargs,
    _set_name,
    _size,
    _threads,
    build_parser,
)
from .synth_command import (  # noqa: F401 - re-exported: tilesynth.cli.main.<name> stays the import path
    _synth,
    _synth_load_maps,
    _synth_write_maps,
)


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
    elif args.command == "batch":  # exit status 1 when any job failed
        from .batch import cli_main as _batch_main

        return _batch_main(args)
    elif args.command in ("export", "view"):
        from .export import run as _run_export

        _run_export(args)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``tilesynth`` command; returns the exit status."""
    from ..base.signals import EXIT_TERMINATED, Terminated, install_sigterm

    install_sigterm()  # SIGTERM removes the .part files like Ctrl-C
    try:
        args = build_parser().parse_args(argv)
        set_png_compression(getattr(args, "png_compression", None))
        from ..io.paths import check_command

        check_command(args)  # before any work: no output may be an input or another output
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
