"""``tilesynth metrics`` and ``tilesynth report``: the quality metrics and the visual report of a tile set."""

from __future__ import annotations

import argparse
import json
import os

from ..errors import ParameterError


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
