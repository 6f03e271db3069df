"""One rule for the files a command touches: no output may be an input or another output.

Before a command does any work, :func:`check_paths` compares every output path with every input and with every
other output. Two paths name the same file when

* both exist and have the same device and inode (``os.stat`` follows symbolic links, and hard links share
  the inode), or
* either does not exist yet and both resolve to the same absolute path (``os.path.realpath``: symbolic links
  in the directories and a dangling link itself are followed).

Any collision is a :class:`~tilesynth.errors.ParameterError` naming both options (exit status 2 in the CLI),
raised before anything is read in full or written. The same up-front pass checks that every output can be
written at all (its directory exists, it is not a directory, an image output has a known extension), so an
error that would only be found after a first output was written (``build -o y.tiles --sheet y.sheet``) is
found before any output exists.

Why the rule is strict: writing is atomic (a temporary file renamed into place), so an output equal to an input
replaces the input with the result, silently and irrecoverably (``build in.png -o in.png`` turned the exemplar
into a ZIP archive). A user who really wants to replace a file can write elsewhere and move it.

:func:`check_command` maps each CLI subcommand's parsed arguments to its inputs and outputs and applies the
rule; the CLI calls it once, right after parsing.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from ..errors import ParameterError

#: Kinds of output: an image written through :func:`tilesynth.io.images.save_image`, a ``.npy`` array, a tile-set
#: ZIP, or a plain file.
OUTPUT_KINDS = ("image", "npy", "tiles", "file")

#: The files ``tilesynth report`` writes into its directory (see :func:`tilesynth.measure.report.write_report`).
REPORT_FILES = (
    "tiles.png",
    "sample.png",
    "sample-borders.png",
    "seams.png",
    "coherence.png",
    "convergence.png",
    "metrics.json",
    "index.html",
)

#: The files ``tilesynth demo`` writes into its directory.
DEMO_FILES = ("lettuce.tiles", "tiles.png", "texture.png", "texture-map.npy")


def file_identity(path: str | os.PathLike[str]) -> tuple:
    """What makes two paths the same file: ``("inode", dev, ino)`` for an existing file (after symbolic
    links), else ``("path", resolved absolute path)``."""
    p = os.fspath(path)
    try:
        st = os.stat(p)
    except (FileNotFoundError, NotADirectoryError):
        return ("path", os.path.realpath(p))
    except OSError:  # permission denied on a directory of the path, a loop of links, ...: compare by name
        return ("path", os.path.realpath(p))
    return ("inode", st.st_dev, st.st_ino)


def check_paths(
    inputs: Iterable[tuple[str, str | os.PathLike[str] | None]],
    outputs: Iterable[
        tuple[str, str | os.PathLike[str] | None] | tuple[str, str | os.PathLike[str] | None, str]
    ],
    writable: bool = True,
) -> None:
    """Raise :class:`ParameterError` if an output names the same file as an input or another output.

    ``inputs`` and ``outputs`` are ``(label, path)`` pairs (the label names the option in the message; a
    ``None`` path is skipped); an output may carry a third item, its kind (:data:`OUTPUT_KINDS`, default
    "file"), for the writability check of :func:`check_output` (skipped with ``writable=False``: outputs in a
    directory the command creates later).
    """
    ins = [(label, os.fspath(p)) for label, p in inputs if p is not None]
    outs: list[tuple[str, str, str]] = []
    for item in outputs:
        label, p = item[0], item[1]
        if p is None:
            continue
        outs.append((label, os.fspath(p), item[2] if len(item) > 2 else "file"))  # type: ignore[misc]
    seen: dict[tuple, tuple[str, str, bool]] = {}
    for label, p in ins:
        seen.setdefault(file_identity(p), (label, p, True))
    for label, p, _ in outs:
        ident = file_identity(p)
        if ident in seen:
            other, op, is_input = seen[ident]
            what = "the input" if is_input else "the output"
            raise ParameterError(
                f"{label} = {p!r}: is the same file as {what} {other} = {op!r}; writing it would "
                f"{'destroy the input' if is_input else 'overwrite the other output'} (choose another path)"
            )
        seen[ident] = (label, p, False)
    if writable:
        for label, p, kind in outs:
            check_output(label, p, kind)


def check_output(label: str, path: str | os.PathLike[str], kind: str = "file") -> None:
    """Raise :class:`ParameterError` unless ``path`` can be written as an output of ``kind``: its directory
    exists, it is not a directory, and an image output has an extension Pillow writes."""
    if kind not in OUTPUT_KINDS:
        raise ValueError(f"kind = {kind!r}: expected one of {OUTPUT_KINDS}")
    from .images import _format_for, check_writable

    p = Path(path)
    check_writable(p, label)
    if kind == "image" and p.suffix.lower() != ".exr":  # .exr: written by tilesynth's own OpenEXR codec
        try:
            _format_for(p)
        except ParameterError as exc:
            raise ParameterError(str(exc).replace("output = ", f"{label} = ", 1)) from None


def map_output(output: str, map_path: str, dtype: Any) -> Path:
    """``OUT-<map stem>.png`` next to ``output`` for a ``synth --with`` map (``.exr`` for an EXR map, ``.npy``
    for a float32 one): the one naming rule of the CLI and of the path check."""
    import numpy as np

    out = Path(output)
    suffix = Path(map_path).suffix.lower()
    ext = ".exr" if suffix == ".exr" else ".npy" if np.dtype(dtype) == np.float32 else ".png"
    return out.with_name(f"{out.stem}-{Path(map_path).stem}{ext}")


def _with_output(output: str, map_path: str) -> Path:
    """The file ``synth --with MAP`` writes (:func:`map_output`); the dtype of an ``.npy`` map is read from its
    header only (other maps are not float32 .npy, so any non-float dtype names them the same)."""
    import numpy as np

    dtype: Any = np.uint8
    if Path(map_path).suffix.lower() == ".npy":
        try:
            with open(map_path, "rb") as fh:
                version = np.lib.format.read_magic(fh)
                read = (
                    np.lib.format.read_array_header_1_0
                    if version == (1, 0)
                    else np.lib.format.read_array_header_2_0
                )
                _, _, dtype = read(fh)
        except (OSError, ValueError, SyntaxError, TypeError):
            pass  # an unreadable map is refused later by load_raster, before anything is written
    return map_output(output, map_path, dtype)


def command_paths(args: Any) -> tuple[list[tuple[str, Any]], list[tuple[str, Any, str]]]:
    """The inputs and outputs of one parsed ``tilesynth`` command line (``argparse.Namespace``)."""
    cmd = getattr(args, "command", None)
    ins: list[tuple[str, Any]] = []
    outs: list[tuple[str, Any, str]] = []
    if cmd == "build":
        ins.append(("input", args.input))
        ins.append(("--mask", getattr(args, "mask", None)))
        ins.extend(
            ("--map", m.partition("=")[2]) for m in getattr(args, "material_maps", None) or []
        )  # the material maps of a build
        outs.append(("--output", args.output, "tiles"))
        if args.sheet:
            outs.append(("--sheet", args.sheet, "image"))
    elif cmd == "synth":
        ins.append(("tileset", args.tileset))
        ins.append(("--map", args.map))
        ins.extend(("--with", m) for m in args.with_maps or [])
        outs.append(("--output", args.output, "image"))
        outs.append(("--save-map", args.save_map, "npy"))
        for m in args.with_maps or []:
            outs.append((f"--with {m!r} output", str(_with_output(args.output, m)), "file"))
    elif cmd in ("info", "sheet", "report", "export"):
        ins.append(("tileset", getattr(args, "tileset", None)))
        if cmd == "sheet":
            outs.append(("--output", args.output, "image"))
        elif cmd == "report":
            outs.extend(_dir_outputs("--output-dir", args.output_dir, REPORT_FILES))
        elif cmd == "export":
            # the files depend on the tile set (its maps, mip levels, lookup): tilesynth.engine.export lists
            # them all and applies check_paths before writing anything
            ins.extend(("--with", m) for m in getattr(args, "with_maps", None) or [])
            _dir_outputs("--output-dir", args.output_dir, ())
    elif cmd == "view":
        ins.append(("tileset", args.tileset))
        outs.append(("--output", getattr(args, "output", None), "file"))
    elif cmd == "metrics":
        ins.append(("input", args.input))
        ins.append(("--exemplar", args.exemplar))
    elif cmd == "demo":
        outs.extend(_dir_outputs("--output-dir", args.output_dir, DEMO_FILES))
    return ins, outs


def _dir_outputs(label: str, directory: str, names: Sequence[str]) -> list[tuple[str, Any, str]]:
    """Outputs of a command that writes ``names`` into ``directory`` (created if missing: the files are then
    compared by path, and no input can be among them)."""
    d = Path(directory)
    if d.exists() and not d.is_dir():
        raise ParameterError(f"{label} = {directory!r}: exists and is not a directory")
    return [(f"{label} file {n}", str(d / n), "file") for n in names]


def check_command(args: Any) -> None:
    """Apply :func:`check_paths` to a parsed command line (the CLI's one call, before any work)."""
    ins, outs = command_paths(args)
    if getattr(args, "command", None) in ("report", "demo", "export"):
        # the directory's files: an input among them would be replaced; their directory is created later
        seen = {file_identity(p) for _, p in ins if p is not None}
        for label, p, _ in outs:
            if file_identity(p) in seen:
                check_paths(ins, [(label, p)])
        return
    check_paths(ins, outs)


__all__ = ["map_output", "check_command", "check_output", "check_paths", "command_paths", "file_identity"]
