"""The files of an export: the output folder checked and prepared before anything is written, the level and text
writes, the manifest written last, and the previous export's files that a re-export removes."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from .format import EXPORT_FORMAT, _index_size, validate_manifest
from .sources import SHADER_FILES


def _write_level(path: Path, arr: np.ndarray) -> None:
    from ..io.images import save_image

    # float32 levels go to OpenEXR (float channels, values as they are) through tilesynth.io.images's exr-crate writer
    save_image(path, arr, bits=16 if arr.dtype == np.uint16 else 8)


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _prepare_output(
    out: Path, names: list[str], ins: list[tuple[str, Any]], tileset: Any, lookup: str, index_size: Any
) -> set[str]:
    """Before anything is written: every file the export writes (``names``) against every input ``ins`` (the one
    rule of :mod:`tilesynth.io.paths`), the index-map size, the folders made. Returns the previous export's files
    that a re-export may remove: those it listed, less any that is now one of the inputs."""
    from ..io.paths import check_paths, file_identity

    # in a directory not there yet, nothing can be an input (it is created below)
    check_paths(ins, [(f"output file {n}", out / n) for n in names], writable=(out / "shaders").is_dir())
    if lookup == "index_map":  # checked before any work
        _index_size(tileset.definition, index_size)
    taken = {file_identity(p) for _, p in ins if p is not None}
    previous = {n for n in previous_export_files(out) if file_identity(out / n) not in taken}
    out.mkdir(parents=True, exist_ok=True)
    (out / "shaders").mkdir(exist_ok=True)
    return previous


def _write_manifest(out: Path, manifest: dict[str, Any], files: list[str]) -> None:
    """``manifest.json`` listing ``files``, checked against the schema where jsonschema is installed."""
    manifest["files"] = sorted(files)
    try:
        validate_manifest(manifest)
    except ImportError:
        pass
    _write_text(out / "manifest.json", json.dumps(manifest, indent=1) + "\n")


def _remove_stale(out: Path, previous: set[str], files: list[str]) -> None:
    """Removes the previous export's files that the new one does not list (after the new set is committed)."""
    for name in sorted(previous - set(files)):
        with contextlib.suppress(OSError):
            (out / name).unlink()


#: Names an export may write (and so may remove when a re-export no longer lists them): a manifest read back
#: from disk is data, and a tampered one must not make a re-export delete anything else.
_EXPORT_NAME = re.compile(
    r"^((atlas|map)_[A-Za-z0-9_-]+(_mip[0-9]+)?\.(png|exr)|index\.png|viewer\.html|shaders/tilesynth(_v2)?\.[a-z]+"
    r"|labels_bits\.png|labels_coverage(_mip[0-9]+)?\.png|labels_blend\.png|table\.bin)$"
)


#: Largest ``manifest.json`` read back from a previous export (a real one is a few hundred kB at most).
MAX_MANIFEST_BYTES = 64 << 20


def export_files(built: dict[str, Any], levels: int, index_map: bool, viewer: bool) -> list[str]:
    """Every file an export writes into its directory (the names of :func:`export`, in writing order)."""
    names = []
    for name, info in built.items():
        ext = "exr" if info["cells"].dtype == np.float32 else "png"
        names += [f"atlas_{name}.{ext}"] + [f"atlas_{name}_mip{lv}.{ext}" for lv in range(1, levels + 1)]
    if index_map:
        names.append("index.png")
    names += [f"shaders/{s}" for s in SHADER_FILES]
    if viewer:
        names.append("viewer.html")
    return [*names, "manifest.json"]


def previous_export_files(out: Path) -> set[str]:
    """The files the export in ``out`` lists in its manifest (those an export may write only; none when there
    is no readable manifest, or one larger than :data:`MAX_MANIFEST_BYTES`)."""
    p = out / "manifest.json"
    try:
        if not p.is_file() or p.stat().st_size > MAX_MANIFEST_BYTES:
            return set()
        data = json.loads(p.read_text(encoding="utf-8"))
        if not isinstance(data, dict) or data.get("format") != EXPORT_FORMAT:
            return set()
        return {f for f in data.get("files") or [] if isinstance(f, str) and _EXPORT_NAME.match(f)}
    except (OSError, ValueError, TypeError):
        return set()


def _write_text(path: Path, text: str) -> None:
    from ..io.images import atomic_open

    with atomic_open(path, "wb") as fh:
        fh.write(text.encode("utf-8"))


def source_entry(tileset: Any, source_path: Any) -> dict[str, Any]:
    """The manifest's ``source``: the set's content digest, and the ``.tiles`` file's name and SHA-256 when
    given (both export versions)."""
    return {
        "content_digest": tileset.content_digest(),
        "file": os.path.basename(source_path) if source_path else None,
        "file_sha256": _file_digest(Path(source_path)) if source_path else None,
    }


def shader_entry(stem: str) -> dict[str, str]:
    """The manifest's ``shaders``: the file of each language (``stem`` "tilesynth" or "tilesynth_v2")."""
    ext = {"glsl": "glsl", "wgsl": "wgsl", "hlsl": "hlsl", "godot": "gdshader"}
    return {lang: f"shaders/{stem}.{e}" for lang, e in ext.items()}
