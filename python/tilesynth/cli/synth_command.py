"""``tilesynth synth``: a tile set to a texture of any size, with its index map and material maps."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from .build_command import _check_output_dir, _map_output


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
    from .materials import plan_map_outputs, write_map_outputs  # the maps of a material set

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
        arr = requantise_with_map(Path(mp).stem, arr)  # normal maps' copies at unit length too
        out_map = synthesize_map(ts, arr, imap, size[0], size[1], threads=threads, smooth=smooth_maps)
        out_map = turn_with_map(
            ts, Path(mp).stem, arr, out_map, imap
        )  # normals of turned patches (--augment)
        if smooth_maps:  # a normal map (by its name) renormalised where smoothed
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
