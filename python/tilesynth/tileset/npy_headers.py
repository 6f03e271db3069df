"""The check of every ``.npy`` member's header of a tile set against its manifest
(:mod:`tilesynth.tileset.manifest`), before any array is allocated."""

from __future__ import annotations

from collections.abc import Mapping
from typing import IO, Any

import numpy as np

from ..errors import TileSetFormatError


def read_npy_header(fh: IO[bytes], name: str) -> tuple[tuple[int, ...], bool, np.dtype, int]:
    """``(shape, fortran_order, dtype, header length)`` of an ``.npy`` stream, reading only its header."""
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh, max_header_size=1 << 16)
        elif version in ((2, 0), (3, 0)):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh, max_header_size=1 << 16)
        else:
            raise ValueError(f"unknown .npy version {version}")
    except (ValueError, SyntaxError, TypeError, OverflowError, EOFError) as exc:
        raise TileSetFormatError(f"member {name}.npy: not a .npy array ({exc})") from None
    return tuple(shape), bool(fortran), np.dtype(dtype), fh.tell()


def check_member_headers(
    headers: Mapping[str, tuple[tuple[int, ...], np.dtype, int, int]],
    dtypes: Mapping[str, str],
    manifest: Mapping[str, Any],
) -> None:
    """Compare each member's header with its expected dtype, with the other members and with the manifest.

    ``headers`` maps a member name to ``(shape, dtype, header length, unpacked member size)``. Raises
    :class:`TileSetFormatError` naming the member before anything is allocated: the data a header declares
    must be exactly what the member holds, so a header cannot make the loader allocate more than the file
    (itself bounded by ``MAX_UNPACKED_BYTES``) contains.
    """
    for name, (shape, dtype, hlen, size) in headers.items():
        want = np.dtype(dtypes[name])
        if dtype.hasobject:
            raise TileSetFormatError(
                f"not a tilesynth tile set (member {name}.npy is a pickled object array; refused, allow_pickle=False)"
            )
        if dtype != want:
            raise TileSetFormatError(f"array {name} must be {want}, got {dtype}")
        n_items = 1
        for d in shape:
            n_items *= d
        if n_items * want.itemsize != size - hlen:
            raise TileSetFormatError(
                f"not a tilesynth tile set (member {name}.npy: header declares shape {shape} "
                f"({n_items * want.itemsize} bytes) but the member holds {size - hlen} bytes of data)"
            )
    ranks = {
        "tiles": 4,
        "source": 4,
        "cut_masks": 3,
        "genes": 2,
        "tile_patches": 2,
        "match_offsets": 2,
        "D": 1,
        "cut_costs": 1,
        "exemplar": 3,
        "labels": 3,
        "cut_stats": 3,
        "prov_labels": 3,
        "prov_table": 3,
        "cut_masks_packed": 3,
    }
    for name, (shape, *_rest) in headers.items():
        if name in ranks and len(shape) != ranks[name]:
            raise TileSetFormatError(
                f"array {name} has shape {shape} (rank {len(shape)}), expected rank {ranks[name]}"
            )
    if "tiles" in headers:  # the other members follow from the tiles (K, N, N, C), as TileSet._check says
        k, n, _, _ = headers["tiles"][0]
        _check_shapes(headers, {"source": (k, n, n, 2), "cut_masks": (k, n, n), **_per_tile_shapes(k, n)})
    if "prov_labels" in headers:  # format version 2: the members follow from the labels (K, N, N)
        k, n, _ = headers["prov_labels"][0]
        _check_shapes(headers, {"cut_masks_packed": (k, n, -(-n // 8)), **_per_tile_shapes(k, n)})
        table = headers.get("prov_table")
        if table is not None and (table[0][0] != k or table[0][2] != 3):
            raise TileSetFormatError(f"array prov_table has shape {table[0]}, expected ({k}, L, 3)")
        if k != len(manifest["layout"]["tiles"]):
            raise TileSetFormatError(
                f"member prov_labels.npy: {k} tiles, but manifest.json field layout.tiles lists "
                f"{len(manifest['layout']['tiles'])}"
            )
    declared = manifest.get("arrays")
    if isinstance(declared, dict):
        for name, (shape, *_rest) in headers.items():
            d = declared.get(name)
            if d is not None and d["dtype"] != dtypes[name]:
                raise TileSetFormatError(
                    f"manifest.json field arrays.{name}.dtype = {d['dtype']!r:.40}: expected {dtypes[name]!r}"
                )
            if d is not None and tuple(d["shape"]) != shape:
                raise TileSetFormatError(
                    f"member {name}.npy: shape {shape} disagrees with manifest.json field arrays.{name}.shape = "
                    f"{d['shape']}"
                )
    ex_shape = tuple(manifest["exemplar"]["shape"])
    if "exemplar" in headers and headers["exemplar"][0] != ex_shape:
        raise TileSetFormatError(
            f"member exemplar.npy: shape {headers['exemplar'][0]} disagrees with manifest.json field "
            f"exemplar.shape = {list(ex_shape)}"
        )
    n_layout = len(manifest["layout"]["tiles"])
    if "tiles" in headers and headers["tiles"][0][0] != n_layout:
        raise TileSetFormatError(
            f"member tiles.npy: {headers['tiles'][0][0]} tiles, but manifest.json field layout.tiles lists "
            f"{n_layout}"
        )


def _per_tile_shapes(k: int, n: int) -> dict[str, tuple[int, ...]]:
    """The shapes of the members every format version stores per tile, for ``k`` tiles of ``n`` px."""
    return {
        "tile_patches": (k, 4),
        "match_offsets": (k, 2),
        "D": (k,),
        "cut_costs": (k,),
        "labels": (k, n, n),
        "cut_stats": (k, 4, 6),
    }


def _check_shapes(headers: dict[str, Any], expect: dict[str, tuple[int, ...]]) -> None:
    for name, shape in expect.items():
        if name in headers and headers[name][0] != shape:
            raise TileSetFormatError(f"array {name} has shape {headers[name][0]}, expected {shape}")
