"""Command-line glue of material builds (:mod:`tilesynth.builder.materials`): the ``build`` flags ``--map``,
``--map-kind``, ``--map-weight``, ``--normal-y``, and the ``synth`` outputs of the stored maps."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from .argtypes import normal_y_text

__all__ = [
    "add_build_arguments",
    "add_synth_arguments",
    "load_build_maps",
    "plan_map_outputs",
    "write_map_outputs",
]


def add_build_arguments(parser: argparse.ArgumentParser) -> None:
    """The material flags of ``tilesynth build``."""
    parser.add_argument(
        "--map",
        dest="material_maps",
        action="append",
        default=[],
        metavar="NAME[:KIND]=FILE",
        help="a map of the material, pixel-aligned with the exemplar (PNG 8/16-bit, OpenEXR, TIFF, .npy), e.g. "
        "normal=rock-n.png, height=rock-h.png, roughness=rock-r.png; matching and cuts then use every map "
        "jointly and the tile set stores them. KIND (colour, scalar, normal, label) is inferred from NAME unless "
        "given; repeatable",
    )
    parser.add_argument(
        "--map-kind",
        action="append",
        default=[],
        metavar="NAME=KIND",
        help="kind of a --map: colour (sRGB), scalar (linear: height, roughness, AO), normal (tangent space), "
        "label (mask / IDs: exact copies, weight 0 by default); repeatable",
    )
    parser.add_argument(
        "--map-weight",
        action="append",
        default=[],
        metavar="NAME=W",
        help="share of a --map (or 'albedo') in the matching distance and cut weights, relative to the albedo's "
        "1 after each map is normalised by its standard deviation (default 0.5 for scalar and normal maps, 1 for "
        "colour maps, 0 for labels); repeatable",
    )
    parser.add_argument(
        "--normal-y",
        default=None,
        type=normal_y_text,
        choices=("up", "down"),
        help="Y convention of the --map normal maps: up (OpenGL, default) or down (DirectX; +y and -y are accepted "
        "too); recorded",
    )


def add_synth_arguments(parser: argparse.ArgumentParser) -> None:
    """The material flags of ``tilesynth synth``."""
    parser.add_argument(
        "--normal-y",
        default=None,
        type=normal_y_text,
        choices=("up", "down"),
        help="write the tile set's normal maps in this Y convention: up (OpenGL) or down (DirectX); default: "
        "as recorded at build",
    )


def _pairs(values: list[str], flag: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for v in values:
        key, sep, val = v.partition("=")
        if not sep or not key or not val:
            raise ParameterError(f"{flag} {v!r}: expected NAME=VALUE")
        if key in out:
            raise ParameterError(f"{flag}: duplicate map name {key!r}")
        out[key] = val
    return out


def load_build_maps(args: argparse.Namespace) -> dict[str, Any] | None:
    """The material keywords of a ``build`` command line (None without ``--map``): maps loaded, kinds and
    weights parsed; every map is loaded and checked before any work."""
    from ..io.images import load_raster

    specs = getattr(args, "material_maps", None) or []
    kinds_flag = getattr(args, "map_kind", None) or []
    weights_flag = getattr(args, "map_weight", None) or []
    if not specs:
        if kinds_flag or weights_flag or getattr(args, "normal_y", None):
            raise ParameterError("--map-kind, --map-weight and --normal-y: only with --map NAME=FILE")
        return None
    maps: dict[str, Any] = {}
    kinds: dict[str, str] = {}
    suffixes: dict[str, str] = {}
    seen: dict[str, str] = {}
    for text in specs:
        head, sep, path = text.partition("=")
        name, _, kind = head.partition(":")
        if not sep or not name or not path:
            raise ParameterError(f"--map {text!r}: expected NAME=FILE or NAME:KIND=FILE")
        if name.lower() in seen:
            raise ParameterError(
                f"--map {text!r}: duplicate map name {name!r} (already --map {seen[name.lower()]!r})"
            )
        seen[name.lower()] = text
        try:
            maps[name] = load_raster(path)
        except ParameterError as exc:
            raise ParameterError(f"--map {name}: {exc}") from None
        suffixes[name] = Path(path).suffix.lower() or ".png"
        if kind:
            kinds[name] = kind
    for name, kind in _pairs(kinds_flag, "--map-kind").items():
        if name in kinds:
            raise ParameterError(f"--map-kind {name}={kind}: the kind of {name!r} is already given in --map")
        kinds[name] = kind
    weights: dict[str, Any] = {}
    for name, w in _pairs(weights_flag, "--map-weight").items():
        try:
            weights[name] = float(w)
        except ValueError:
            raise ParameterError(f"--map-weight {name}={w}: expected a number >= 0") from None
    return {
        "maps": maps,
        "map_kinds": kinds,
        "map_weights": weights,
        "normal_y": getattr(args, "normal_y", None) or "up",
        "map_suffixes": suffixes,
    }


def plan_map_outputs(
    ts: Any,
    output: str,
    inputs: list[tuple[str, Any]],
    outputs: list[tuple[str, Any]],
    smooth: bool | None = None,
) -> list[tuple[str, Path]]:
    """``[(map name, output path)]`` of the maps stored in ``ts`` (``OUT-<name>.<ext>`` by
    :func:`tilesynth.io.paths.map_output`), refused up front when one cannot be smoothed as asked, or when one
    would be an input or another output: the command's ``inputs`` and ``outputs`` (``(label, path)``) and these
    maps go through the one collision rule, :func:`tilesynth.io.paths.check_paths`."""
    from ..builder.materials import MapSpec, smooths
    from ..io.paths import check_paths, map_output

    for d in getattr(ts, "map_specs", None) or []:
        smooths(ts, MapSpec.from_dict(d), smooth)  # raises before anything is written

    out = []
    for d in getattr(ts, "map_specs", None) or []:
        target = map_output(output, d["name"] + d.get("suffix", ".png"), np.dtype(d["dtype"]))
        out.append((d["name"], target))
    check_paths(inputs, [*outputs, *((f"map {n!r} of the tile set: output", t, "image") for n, t in out)])
    return out


def write_map_outputs(
    prog: Any,
    ts: Any,
    planned: list[tuple[str, Path]],
    imap: np.ndarray,
    size: tuple[int, int],
    threads: int | None,
    smooth: bool | None,
    normal_y: str | None,
    offset: tuple[int, int] = (0, 0),
    seams: str | None = None,
) -> None:
    """Synthesize and write every stored map of ``ts`` (:func:`tilesynth.builder.materials.synthesize_maps`),
    the window at pixel ``offset = (oy, ox)`` into the first cell of ``imap`` (the colour's, for ``--origin``);
    ``seams``: the seam treatment of its smoothed scalar and normal maps (``--map-seams``)."""
    from ..builder.materials import synthesize_maps
    from ..io.images import atomic_open, save_image

    if not planned:
        if normal_y is not None:
            raise ParameterError("--normal-y: the tile set stores no maps (build it with --map)")
        return
    prog("material maps", 0, 1)
    outs = synthesize_maps(
        ts,
        imap,
        size[0],
        size[1],
        threads=threads,
        smooth=smooth,
        normal_y=normal_y,
        offset=offset,
        seams=seams,
    )
    from ..builder.materials import MapSpec, smooths

    kinds = {d["name"]: d["kind"] for d in ts.map_specs}
    smoothed = {d["name"]: smooths(ts, MapSpec.from_dict(d), smooth) for d in ts.map_specs}
    for name, target in planned:
        arr = outs[name]
        if target.suffix == ".npy":
            with atomic_open(target) as fh:
                np.save(fh, arr, allow_pickle=False)
        else:
            save_image(target, arr)
        fused = smoothed[name] and kinds[name] in ("scalar", "normal")
        treated = ", blended across the seams" if seams in (None, "blend") else ", fused across the seams"
        how = (
            (treated if fused else ", Poisson-smoothed inside the cuts")
            if smoothed[name]
            else ", pure copies"
        )
        prog.message(f"wrote {target}: map {name} ({kinds[name]}, {arr.dtype}) through the same cuts{how}")
    prog("material maps", 1, 1)


def info_lines(ts: Any) -> list[str]:
    """``tilesynth info``'s lines about the maps of a material set (none for a colour-only set)."""
    specs = getattr(ts, "map_specs", None) or []
    if not specs:
        return []
    mat = ts.params.get("material", {}) if isinstance(ts.params.get("material"), dict) else {}
    maps = ", ".join(
        f"{d.get('name')} ({d.get('kind')}, weight {d.get('weight')}, {d.get('dtype')}"
        + (f", Y {d['normal_y']}" if d.get("normal_y") else "")
        + ")"
        for d in specs
    )
    how = (
        f"cut jointly on {mat.get('feature_channels', '?')} feature channels, variance kept "
        f"{mat['variance_kept']:.3f}" if mat.get("joint") and isinstance(mat.get("variance_kept"), (int, float))
        else "cut on the albedo (no weighted map)"
    )  # fmt: skip
    lines = [f"maps          {maps}", f"              {how}; D, E and cut costs in feature units"]
    fixed = mat.get("normalised") if isinstance(mat.get("normalised"), dict) else {}
    lines += [f"              map {name}: {note}" for name, note in fixed.items()]
    return lines
