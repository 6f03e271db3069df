"""``tilesynth build``: an exemplar (and its material maps, mask, alpha) to a tile set file."""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..schemes import get_scheme


def _print_input_warnings(caught: list) -> None:  # noqa: ANN001
    """The builder's :class:`tilesynth.measure.diagnose.InputWarning` as ``warning: ...`` lines on stderr; other
    warnings are shown as Python shows them."""
    from ..measure.diagnose import InputWarning

    for w in caught:
        if issubclass(w.category, InputWarning):
            print(f"warning: {w.message}", file=sys.stderr)
        else:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)


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
    from ..builder.recipe import NAMED_SETS

    # without --set, the set of the named recipe (--recipe fast builds c4), else the scheme's default
    set_name = set_name or NAMED_SETS.get((options or {}).get("recipe"), sc.default_set)
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
    if material:  # a material build: every map checked before any work
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

    with warnings.catch_warnings(record=True) as caught:  # InputWarning -> "warning: ..." lines
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
    from .materials import load_build_maps

    return load_build_maps(args)


def _material_info(ts: Any) -> list[str]:
    from .materials import info_lines

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
