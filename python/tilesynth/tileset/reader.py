"""Reading a ``.tiles`` file safely: the archive, its limits, its schema and its arrays, before any object exists.

:meth:`tilesynth.tileset.tilefile.TileSet.load` is :func:`read_archive` then the set's own consistency checks
(:mod:`tilesynth.tileset.checks`); the format is described in :mod:`tilesynth.tileset.tilefile`.
"""

from __future__ import annotations

import io
import json
import lzma
import os
import zipfile
import zlib
from typing import Any

import numpy as np

from ..errors import TileSetFormatError
from .members import (
    _ARRAYS,
    _ARRAYS_V2,
    _OPTIONAL,
    FORMAT_VERSIONS,
    MAX_MANIFEST_BYTES,
    MAX_UNPACKED_BYTES,
    _check_manifest,
    _level_members,
    _map_members,
)

__all__ = ["read_archive"]


def read_archive(path: str | os.PathLike[str]) -> tuple[str, dict[str, Any]]:
    """The path as a string and the keyword arguments of :class:`~tilesynth.tileset.tilefile.TileSet` read
    from the ``.tiles`` file at ``path``; raises :class:`TileSetFormatError` naming the path and the problem.

    Never executes code from the file (see "Loading is safe" in :mod:`tilesynth.tileset.tilefile`).
    """
    p = os.fspath(path)
    if os.path.isdir(p):
        raise TileSetFormatError(f"tileset = {p!r}: is a directory, expected a .tiles file")
    if not os.path.isfile(p):
        what = "not a regular file (a device, FIFO or socket)" if os.path.exists(p) else "no such file"
        raise TileSetFormatError(f"tileset = {p!r}: {what}")
    try:
        with zipfile.ZipFile(p) as zf:
            manifest, timing, arrays, maps, levels = _read_members(zf, p)
    except TileSetFormatError as exc:
        if str(exc).startswith("tileset = "):
            raise
        raise TileSetFormatError(f"tileset = {p!r}: {exc}") from None
    except (
        zipfile.BadZipFile,
        zipfile.LargeZipFile,
        json.JSONDecodeError,
        UnicodeDecodeError,
        ValueError,
        OSError,
        KeyError,
        EOFError,
        zlib.error,
        lzma.LZMAError,
        NotImplementedError,
        RuntimeError,
    ) as exc:
        # RuntimeError: an encrypted member; NotImplementedError: an unknown compression method;
        # LZMAError: a member that claims LZMA compression and is not (bz2 and deflate damage is OSError /
        # zlib.error)
        raise TileSetFormatError(
            f"tileset = {p!r}: not a tilesynth tile set ({type(exc).__name__}: {exc})"
        ) from None
    extra: dict[str, Any] = {"file_version": manifest["format_version"], "map_levels": levels}
    if manifest["format_version"] == 2:
        extra["provenance"] = _from_provenance(arrays, p)
    return p, dict(
        scheme=manifest["scheme"],
        layout=manifest["layout"],
        E=float(manifest["E"]),
        params=manifest["params"],
        exemplar_info=manifest["exemplar"],
        timing=timing,
        version=manifest["tilesynth_version"],
        maps=maps,
        map_specs=manifest.get("maps") or None,
        **extra,
        **arrays,
    )


def _read_members(zf: zipfile.ZipFile, p: str) -> tuple[Any, dict[str, Any], dict[str, Any], Any, Any]:
    """The manifest, timing, arrays, maps and map levels of the open archive ``zf`` (of the file ``p``), each
    checked before it is read: the archive's limits, the members the manifest needs, the schema and the ``.npy``
    headers."""
    infos = {i.filename: i for i in zf.infolist()}
    unpacked = sum(i.file_size for i in infos.values())
    if unpacked > MAX_UNPACKED_BYTES:
        raise TileSetFormatError(
            f"tileset = {p!r}: members unpack to {unpacked} bytes, more than the limit of "
            f"{MAX_UNPACKED_BYTES} (MAX_UNPACKED_BYTES)"
        )
    if "manifest.json" in infos and infos["manifest.json"].file_size > MAX_MANIFEST_BYTES:
        raise TileSetFormatError(
            f"tileset = {p!r}: manifest.json unpacks to {infos['manifest.json'].file_size} bytes, more "
            f"than the limit of {MAX_MANIFEST_BYTES} (MAX_MANIFEST_BYTES)"
        )
    manifest = json.loads(zf.read("manifest.json")) if "manifest.json" in infos else None
    if isinstance(manifest, dict) and manifest.get("format_version") not in FORMAT_VERSIONS:
        _check_manifest(manifest)  # a future (or unknown) version: say so, not "missing members"
    v2 = isinstance(manifest, dict) and manifest.get("format_version") == 2
    required = _ARRAYS_V2 if v2 else _ARRAYS
    missing = [m for m in ["manifest.json", *(f"{a}.npy" for a in required)] if m not in infos]
    if missing:
        raise TileSetFormatError(f"tileset = {p!r}: not a tilesynth tile set (missing members {missing})")
    from .manifest import check_archive

    members = {**required, **_OPTIONAL}
    if v2:
        storage = manifest.get("storage")
        ex_dt = storage.get("exemplar_dtype") if isinstance(storage, dict) else None
        members["exemplar"] = ex_dt if ex_dt in ("float32", "uint8", "uint16") else "float32"
    if isinstance(manifest, dict) and isinstance(manifest.get("maps"), list):
        members.update(_map_members(manifest["maps"], checked=False))  # material maps
        if v2:
            members.update(_level_members(None, manifest["maps"], infos, checked=False))
    check_archive(zf, manifest, members)  # schema and .npy headers, before any array is read
    _check_manifest(manifest)
    map_specs = manifest.get("maps") or None
    missing = [f"{m}.npy" for m in _map_members(map_specs) if f"{m}.npy" not in infos]
    if missing:
        raise TileSetFormatError(f"manifest.json lists maps whose members are missing: {missing}")
    timing = json.loads(zf.read("timing.json")) if "timing.json" in infos else {}
    if not isinstance(timing, dict) or not all(
        isinstance(k, str) and isinstance(v, (int, float)) and not isinstance(v, bool)
        for k, v in timing.items()
    ):
        raise TileSetFormatError("timing.json must map stage names to seconds")
    arrays = {
        a: np.load(io.BytesIO(zf.read(f"{a}.npy")), allow_pickle=False)
        for a in [*required, *_OPTIONAL]
        if a in required or f"{a}.npy" in infos
    }
    maps = {
        m[4:]: np.load(io.BytesIO(zf.read(f"{m}.npy")), allow_pickle=False) for m in _map_members(map_specs)
    } or None
    levels = None
    if v2:
        levels = {
            name[6:] if name != "level_corners" else "corners": np.load(
                io.BytesIO(zf.read(f"{name}.npy")), allow_pickle=False
            )
            for name in _level_members(None, map_specs, infos, checked=False)
        } or None
    return manifest, timing, arrays, maps, levels


def _from_provenance(arrays: dict[str, Any], p: str) -> Any:
    """A version-2 file's members turned into the set's arrays, in place (``tiles`` and ``source`` left to be
    materialised, the exemplar decoded from its codes, the cut masks unpacked); returns the checked
    :class:`~tilesynth.tileset.provenance.Provenance`."""
    from .provenance import Provenance

    prov = Provenance(labels=arrays.pop("prov_labels"), table=arrays.pop("prov_table"))
    packed = arrays.pop("cut_masks_packed")
    n = prov.tile_size
    try:
        prov.check()
    except TileSetFormatError as exc:
        raise TileSetFormatError(f"tileset = {p!r}: {exc}") from None
    codes = arrays.pop("exemplar")
    top = {np.dtype(np.uint8): 255, np.dtype(np.uint16): 65535}.get(codes.dtype)
    exemplar = codes if top is None else codes.astype(np.float32) / np.float32(top)
    arrays.update(
        tiles=None,
        source=None,
        exemplar=np.ascontiguousarray(exemplar, dtype=np.float32),
        cut_masks=np.ascontiguousarray(np.unpackbits(packed, axis=-1, count=n).astype(bool)),
    )
    return prov
