"""The members of a ``.tiles`` archive (:mod:`tilesynth.tileset.tilefile`): the format's version and limits,
the member names and dtypes, the checks of a manifest and of the map members, and how each member is written."""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import zipfile
from typing import Any

import numpy as np

from ..errors import TileSetFormatError

FORMAT = "tilesynth-tileset"
FORMAT_VERSION = 2
"""The version :meth:`TileSet.save` writes for a pure-copy set (provenance); sets that are not pure copies are
written as version 1 (pixels). Both load."""
FORMAT_VERSIONS = (1, 2)

MAX_UNPACKED_BYTES = 8 << 30
"""Refuse tile-set files whose members declare more than 8 GiB unpacked (a ZIP bomb; the largest real set,
|N16| = 5000 tiles of 256 x 256 RGBA float32, is 5.2 GiB with its provenance)."""

MAX_MANIFEST_BYTES = 64 << 20
"""Refuse tile-set files whose ``manifest.json`` declares more than 64 MiB unpacked, before it is read (a 7 GB
manifest of whitespace was read whole, then refused); a real manifest, layout and selection history included, is
a few MB at most."""

_ARRAYS: dict[str, str] = {
    "tiles": "float32",
    "source": "int32",
    "cut_masks": "bool",
    "genes": "int64",
    "tile_patches": "int64",
    "match_offsets": "int64",
    "D": "float64",
    "cut_costs": "float64",
    "exemplar": "float32",
}

#: The members of a version-2 file (provenance storage) in their order; ``exemplar`` takes the dtype that
#: ``manifest["storage"]["exemplar_dtype"]`` names.
_ARRAYS_V2: dict[str, str] = {
    "prov_labels": "uint8",
    "prov_table": "int32",
    "cut_masks_packed": "uint8",
    "genes": "int64",
    "tile_patches": "int64",
    "match_offsets": "int64",
    "D": "float64",
    "cut_costs": "float64",
    "exemplar": "float32",
}

#: Optional members (Wang schemes), written after the others when present.
_OPTIONAL: dict[str, str] = {
    "labels": "uint8",
    "cut_stats": "float64",
}

#: The block side of stored map levels: :data:`tilesynth.builder.fusion.LEVEL_BLOCK` (the builder is above this
#: module; ``tests/test_provenance.py`` ties the two).
LEVEL_BLOCK = 4


def member_sizes(path: str | os.PathLike[str]) -> dict[str, tuple[int, int]]:
    """``{member: (bytes in the file, bytes unpacked)}`` of a ``.tiles`` file, in the file's order (what ``tilesynth
    info`` shows: where the file's bytes go)."""
    with zipfile.ZipFile(os.fspath(path)) as zf:
        return {i.filename: (i.compress_size, i.file_size) for i in zf.infolist()}


def _check_manifest(m: Any) -> None:
    """The manifest's magic, version and field types (raises TileSetFormatError without the path)."""
    if not isinstance(m, dict):
        raise TileSetFormatError(
            f"not a tilesynth tile set (manifest.json is a {type(m).__name__}, not an object)"
        )
    if m.get("format") != FORMAT:
        raise TileSetFormatError(
            f"not a tilesynth tile set (format {m.get('format')!r}, expected {FORMAT!r})"
        )
    if type(m.get("format_version")) is not int or m.get("format_version") not in FORMAT_VERSIONS:
        raise TileSetFormatError(
            f"format version {m.get('format_version')!r}, this tilesynth reads versions 1 and {FORMAT_VERSION}"
        )
    if m["format_version"] == 2 and not isinstance(m.get("storage"), dict):
        raise TileSetFormatError("manifest.json of format version 2 lacks 'storage'")
    from .manifest import check_top_level

    check_top_level(m)
    shape = m["exemplar"].get("shape")
    if not (isinstance(shape, list) and len(shape) == 3 and all(type(v) is int for v in shape)):
        raise TileSetFormatError(f"manifest.json field exemplar.shape = {shape!r:.60}: expected [H, W, C]")
    bits = m["exemplar"].get("bits", 8)
    if type(bits) is not int or bits not in (8, 16):
        raise TileSetFormatError(f"manifest.json field exemplar.bits = {bits!r:.60}: expected 8 or 16")
    if not isinstance(m["exemplar"].get("file", ""), str):
        raise TileSetFormatError("manifest.json field exemplar.file: expected a file name")
    if not isinstance(m["layout"].get("tiles"), list):
        raise TileSetFormatError("manifest.json field layout.tiles: expected a list of tiles")
    if not isinstance(m["params"].get("selection", {}), dict):
        raise TileSetFormatError("manifest.json field params.selection: expected an object")


_MAP_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")


def _map_members(specs: Any, checked: bool = True) -> dict[str, str]:
    """``{"map_<name>": dtype}`` of the maps of a material set; ``checked=False`` skips what the
    schema has not yet vetted (entries that are not objects with a name and a dtype)."""
    out: dict[str, str] = {}
    for d in specs or []:
        if not checked and not (isinstance(d, dict) and isinstance(d.get("name"), str)
                                and d.get("dtype") in ("uint8", "uint16", "float32")):  # fmt: skip
            continue
        name = d["name"]
        if not _MAP_NAME.fullmatch(name):
            raise TileSetFormatError(f"manifest.json field maps: map name {name[:70]!r} is not a valid name")
        if f"map_{name}" in out:
            raise TileSetFormatError(f"manifest.json field maps: duplicate map name {name!r}")
        out[f"map_{name}"] = d["dtype"]
    return out


def _level_members(levels: Any, specs: Any, infos: Any = None, checked: bool = True) -> dict[str, str]:
    """``{"level_corners": "int64", "level_<name>": "float64", ...}``: the stored first stage of the seam
    treatment of each fused map (:func:`tilesynth.builder.materials.map_levels`), in the order of the maps; from
    ``levels`` (saving) or from the archive's member names ``infos`` (loading)."""
    names = [d.get("name") for d in specs or [] if isinstance(d, dict) and isinstance(d.get("name"), str)]
    if checked:
        names = [m for m in names if levels and m in levels]
    else:
        names = [
            m for m in names if infos is not None and f"level_{m}.npy" in infos and _MAP_NAME.fullmatch(m)
        ]
    if not names:
        return {}
    return {"level_corners": "int64", **{f"level_{m}": "float64" for m in names}}


def _check_levels(levels: Any, maps: Any, hw: tuple[int, ...]) -> None:
    """The stored map levels agree with the maps: ``(B + M, C)`` float64 finite per map, ``B`` the exemplar's
    blocks of :data:`LEVEL_BLOCK` pixels, ``M`` the corner pixels, inside the exemplar."""
    if not levels:
        return
    corners = levels.get("corners")
    h, w = int(hw[0]), int(hw[1])
    if not isinstance(corners, np.ndarray) or corners.ndim != 1 or corners.dtype != np.int64:
        raise TileSetFormatError("array level_corners must be int64 (M,)")
    if corners.size and (corners.min() < 0 or corners.max() >= h * w):
        raise TileSetFormatError(f"array level_corners has pixels outside the {w}x{h} exemplar")
    blocks = -(-h // LEVEL_BLOCK) * -(-w // LEVEL_BLOCK)
    for name, x in levels.items():
        if name == "corners":
            continue
        m = (maps or {}).get(name)
        want = (blocks + corners.size, None if m is None else m.shape[2])
        if m is None or not isinstance(x, np.ndarray) or x.dtype != np.float64 or x.shape != want:
            raise TileSetFormatError(
                f"array level_{name} has shape {getattr(x, 'shape', None)}, expected {want} float64 (a stored map)"
            )
        if not np.isfinite(x).all():
            raise TileSetFormatError(f"array level_{name} has non-finite values")


def _check_map_shapes(maps: Any, specs: Any, hw: tuple[int, ...]) -> None:
    """The maps agree with their specs and are pixel-aligned with the exemplar."""
    if (maps is None) != (not specs):
        raise TileSetFormatError("maps and map_specs must be given together")
    if maps is None:
        return
    names = [d["name"] for d in specs]
    if sorted(names) != sorted(maps):
        raise TileSetFormatError(f"maps {sorted(maps)} disagree with manifest.json field maps {names}")
    for d in specs:
        if d["kind"] == "normal" and d["channels"] != 3:
            raise TileSetFormatError(
                f"map {d['name']!r} is a normal map of {d['channels']} channel(s), expected 3"
            )
        a = maps[d["name"]]
        want = (int(hw[0]), int(hw[1]), int(d["channels"]))
        if not isinstance(a, np.ndarray) or a.dtype != np.dtype(d["dtype"]) or a.shape != want:
            raise TileSetFormatError(
                f"map {d['name']!r} has shape {getattr(a, 'shape', None)} and dtype {getattr(a, 'dtype', None)}, "
                f"expected {want} {d['dtype']}"
            )


def exemplar_digest(exemplar: np.ndarray) -> str:
    """SHA-256 of the float32 exemplar pixels and shape."""
    h = hashlib.sha256(repr(exemplar.shape).encode())
    h.update(np.ascontiguousarray(exemplar, dtype=np.float32).tobytes())
    return h.hexdigest()


def _json_bytes(obj: Any) -> bytes:
    return json.dumps(obj, indent=1, sort_keys=True, ensure_ascii=False).encode("utf-8")


def _npy_bytes(a: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.ascontiguousarray(a), allow_pickle=False)
    return buf.getvalue()


DEFLATE_LEVEL = 1
"""zlib level of the members. Level 1 writes an N2 set of 256-pixel tiles (about 56 MB of arrays) in about 1 s
instead of 7.7 s at level 6, for files about 11 % larger (16.7 MB instead of 15.0 MB): float32 tiles and int32
provenance compress little better at higher levels."""


def _write_member(zf: zipfile.ZipFile, name: str, data: bytes) -> None:
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    zf.writestr(info, data, compress_type=zipfile.ZIP_DEFLATED, compresslevel=DEFLATE_LEVEL)


def _npy_size(a: np.ndarray) -> int:
    """The length of ``np.lib.format.write_array(fp, a)``'s output (header + data) without writing the data:
    the header as ``write_array`` chooses it (format 1.0, 2.0 when the header does not fit 1.0) and ``nbytes``."""
    head = io.BytesIO()
    d = np.lib.format.header_data_from_array_1_0(a)
    try:
        np.lib.format.write_array_header_1_0(head, d)
    except ValueError:  # a header over 65535 bytes: write_array falls back to 2.0 the same way
        head = io.BytesIO()
        np.lib.format.write_array_header_2_0(head, d)
    return head.tell() + a.nbytes


BZIP2_LEVEL = 9
"""bzip2 level of version 2's label, mask, exemplar and map members (:data:`BZIP2_MEMBERS`). Measured on the
default colour set of a 512² exemplar (roof-tiles): labels 10.2 MB raw are 483 KB at deflate level 1, 210 KB at
level 9, 123 KB in bzip2; the packed cut masks 207 / 133 / 97 KB; the exemplar's 8-bit codes 560 / 606 / 404 KB
(its PNG: 439 KB). The members are small, so the slower compressor costs about a second per set."""


def _bzip2_member(name: str) -> bool:
    """Whether a version-2 member is written with bzip2 (the members that dominate its size)."""
    return name in ("prov_labels", "cut_masks_packed", "exemplar") or name.startswith("map_")


def _write_array(zf: zipfile.ZipFile, name: str, a: np.ndarray, bzip2: bool = False) -> None:
    """:func:`_write_member` of ``_npy_bytes(a)``, streamed: the same member bytes (the uncompressed size is
    set in advance, as ``writestr`` sets it, and ``np.lib.format.write_array`` writes the same header and data
    in 16 MiB pieces), without the two whole in-memory copies of the array (a c5 set's 123 MB of
    tiles were the peak of saving it)."""
    a = np.ascontiguousarray(a)
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_BZIP2 if bzip2 else zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    info.file_size = _npy_size(a)
    level = BZIP2_LEVEL if bzip2 else DEFLATE_LEVEL
    if "compress_level" in getattr(zipfile.ZipInfo, "__slots__", ()):  # Python >= 3.13
        info.compress_level = level
    else:
        info._compresslevel = level  # what writestr(..., compresslevel=) sets before 3.13
    with zf.open(info, mode="w") as dest:
        np.lib.format.write_array(dest, a, allow_pickle=False)
