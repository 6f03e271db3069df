"""Tile sets stored as their provenance: the exemplar once, a small source table per tile and a label plane.

**How a complete-set tile is composed today** (the default ``c5`` set, :func:`tilesynth.builder.compose.cut_and_compose`
without smoothing). Tile ``t`` is ``where(cut_mask, O, I)``:

* ``I``, the intermediate tile (:func:`tilesynth.layouts.corners.intermediate_tiles`), is four quadrants of
  ``N/2 x N/2`` pixels, each a plain copy of a quarter of a sample patch: quadrant ``q`` of ``⟨TL, BL, TR, BR⟩``
  shows the patch at ``genes[tile_patches[t, q]]`` from its (bottom-right, top-right, bottom-left, top-left)
  quarter, so its pixel ``p`` comes from ``p + genes[tile_patches[t, q]] + (h, h) - origin(q)`` (``h = N/2``):
  a translation;
* ``O``, the matching patch, is the exemplar window at ``match_offsets[t]``, under ``augment`` transformed by
  ``params["match_transforms"][t]`` (one of the 8 symmetries of the square,
  :func:`tilesynth.builder.matching.augment.transform`): pixel ``p`` comes from ``match_offsets[t] + D_s(p)``;
* ``cut_mask`` (the ω cut, ``cut_masks``) picks ``O`` inside the cutting curve, ``I`` outside.

So without Poisson smoothing every tile pixel is ``exemplar[D_s(p) + b]`` for the entry ``(s, b)`` of the tile's
source table that its label picks: at most 5 entries for ω (the four quadrant translations, the matching patch;
fewer where two coincide), and the label map is the quadrant split overlaid with the cut mask. The provenance
that the builder stores (``source.npy``, int32 ``(K, N, N, 2)``) is exactly ``D_s(p) + b`` per pixel, and the
float tiles are ``exemplar[source]`` bit for bit (float32 copies, no arithmetic). The same holds for every other
scheme that copies (the papers' sets, Wang and s-Wang tiles, the patch baseline): their pieces are translations
of exemplar windows. It does *not* hold for Poisson-smoothed sets (``params["smooth"]``): their pixels inside the
cut are solved, not copied; those keep storing pixels (format version 1).

**What this module does.** :func:`factorise` turns a provenance array into ``labels`` (uint8 ``(K, N, N)``) and
a source ``table`` (int32 ``(K, L, 3)``: ``(s, by, bx)`` per entry, ``-1`` past a tile's own entries), greedily
per tile (the Rust kernel; :func:`factorise_reference` is the numpy oracle), without asking which scheme made
the set: whatever the builder did, the table reproduces ``source`` exactly or the set is not stored this way.
:func:`gather` lays any window of a tiling (an index map and a pixel offset into its first cell, as the hashed
lookup gives) straight from the exemplar, or from any map pixel-aligned with it, in its own sample type: the
same bytes as copying the materialised tiles (:func:`gather_reference` is the numpy oracle).
:func:`materialise` gives tiles (or their provenance) for chosen tiles, in bounded chunks.

**The symmetries.** ``D_s`` for ``s`` in 0..7 (``k = s mod 4``, ``f = s >= 4``): the pixel of
``F^f(R^k(P))`` at ``(y, x)`` is ``P``'s pixel at ``D_s(y, x)``, ``R`` = :func:`numpy.rot90` and ``F`` the left-right
mirror: the numbering of ``augment``, so a transformed matching patch is one entry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import TileSetFormatError

__all__ = [
    "CHUNK_PIXELS",
    "Provenance",
    "coordinate_grid",
    "dihedral_grid",
    "factorise",
    "factorise_reference",
    "gather",
    "gather_reference",
    "check_inside",
    "materialise",
    "pure_copy",
    "turned_pixels",
]

CHUNK_PIXELS = 1 << 22
"""Tile pixels per chunk of :func:`materialise` and :func:`pure_copy` (4 Mi pixels: 64 MB of RGBA float32)."""


def dihedral_grid(s: int, n: int) -> np.ndarray:
    """``D_s`` of every pixel of the ``n x n`` grid: int64 ``(n, n, 2)`` (row, col)."""
    yy, xx = np.mgrid[0:n, 0:n].astype(np.int64)
    m = n - 1
    if s >= 4:
        xx = m - xx
    k = s % 4
    pos = [(yy, xx), (xx, m - yy), (m - yy, m - xx), (m - xx, yy)][k]
    return np.stack(pos, axis=-1)


def turned_pixels(source: np.ndarray, match_offsets: np.ndarray, transforms: Any) -> np.ndarray | None:
    """The symmetry of every tile pixel ``(K, N, N)`` uint8: ``transforms[t]`` where tile t shows its rotated or
    mirrored matching patch (its provenance is ``match_offsets[t] + D_s(p)``), else 0; None when no matching
    patch is transformed (``transforms`` None or all 0)."""
    if transforms is None:
        return None
    t = np.asarray(transforms, dtype=np.int64).reshape(-1)
    if not t.any():
        return None
    src = np.asarray(source)
    n = src.shape[1]
    grids = np.stack([dihedral_grid(s, n) for s in range(8)])
    window = grids[t] + np.asarray(match_offsets, np.int64)[:, None, None, :]
    inside = (src == window).all(axis=-1)
    return np.where(inside, t[:, None, None], 0).astype(np.uint8)


@dataclass(eq=False)
class Provenance:
    """The provenance of a pure-copy tile set: ``labels`` uint8 ``(K, N, N)`` and ``table`` int32 ``(K, L, 3)``
    (module docstring)."""

    labels: np.ndarray
    table: np.ndarray

    @property
    def n_tiles(self) -> int:
        return int(self.labels.shape[0])

    @property
    def tile_size(self) -> int:
        return int(self.labels.shape[1])

    def check(self) -> None:
        """Dtypes, shapes and the table's consistency (raises :class:`TileSetFormatError`); whether sources lie
        inside the exemplar is checked by every :func:`gather`."""
        lab, tab = self.labels, self.table
        if (
            not isinstance(lab, np.ndarray)
            or lab.dtype != np.uint8
            or lab.ndim != 3
            or lab.shape[1] != lab.shape[2]
        ):
            raise TileSetFormatError(
                f"array prov_labels must be uint8 (K, N, N), got {getattr(lab, 'shape', None)}"
            )
        if (
            not isinstance(tab, np.ndarray)
            or tab.dtype != np.int32
            or tab.ndim != 3
            or tab.shape[0] != lab.shape[0]
            or tab.shape[2] != 3
            or tab.shape[1] < 1
        ):
            raise TileSetFormatError(
                f"array prov_table must be int32 (K, L, 3) with K = {lab.shape[0]}, got {getattr(tab, 'shape', None)}"
            )
        sym = tab[..., 0]
        if ((sym < -1) | (sym > 7)).any():
            raise TileSetFormatError("array prov_table has symmetries outside 0..7 (or -1 for no entry)")
        used = sym >= 0
        counts = used.sum(axis=1)
        if not (used == (np.arange(tab.shape[1])[None] < counts[:, None])).all():
            raise TileSetFormatError("array prov_table has an entry after a missing one")
        if lab.size and (lab.reshape(lab.shape[0], -1).max(axis=1) >= counts).any():
            raise TileSetFormatError("array prov_labels has labels past its tile's entries in prov_table")

    def source(self, tiles: np.ndarray | None = None) -> np.ndarray:
        """int32 ``(k, N, N, 2)`` exemplar (row, col) of every pixel of ``tiles`` (indices; None: all), in numpy."""
        idx = np.arange(self.n_tiles) if tiles is None else np.asarray(tiles, np.int64)
        n = self.tile_size
        grids = np.stack([dihedral_grid(s, n) for s in range(8)])  # (8, N, N, 2)
        yy, xx = np.mgrid[0:n, 0:n]
        out = np.empty((idx.size, n, n, 2), np.int32)
        for j, t in enumerate(idx):
            e = self.table[t][self.labels[t].astype(np.int64)]  # (N, N, 3)
            out[j] = grids[e[..., 0], yy, xx] + e[..., 1:]
        return out


def factorise(
    source: np.ndarray, threads: int | None = None, orient: np.ndarray | None = None
) -> Provenance | None:
    """The :class:`Provenance` of an int32 provenance array ``(K, N, N, 2)``, or None when some tile has more than
    255 pieces (Rust, GIL released; the same result as :func:`factorise_reference`). ``orient`` ``(K, N, N)``
    (optional): the symmetry each pixel's entry must have, the turn of a rotated or mirrored matching patch
    (:func:`~tilesynth.builder.matching.augment.pixel_transforms`): a normal map's vectors turn with their
    entry's symmetry, and a piece of one pixel or one line fits several symmetries geometrically."""
    from .. import _core

    o = None if orient is None else np.ascontiguousarray(orient, dtype=np.uint8)
    out = _core.provenance_factorise(np.ascontiguousarray(source, dtype=np.int32), threads, o)
    return None if out is None else Provenance(labels=out[0], table=out[1])


def factorise_reference(source: np.ndarray, orient: np.ndarray | None = None) -> Provenance | None:
    """The numpy oracle of :func:`factorise` (slow: tests and small sets)."""
    src = np.asarray(source, np.int64)
    k, n = src.shape[:2]
    grids = [dihedral_grid(s, n).reshape(-1, 2) for s in range(8)]
    labels = np.zeros((k, n * n), np.uint8)
    tables = []
    for t in range(k):
        s = src[t].reshape(-1, 2)
        free = np.ones(n * n, bool)
        entries = []
        while free.any():
            if len(entries) == 255:
                return None
            p0 = int(np.argmax(free))
            best = None
            may = (
                np.ones((8, n * n), bool)
                if orient is None
                else np.asarray(orient)[t].reshape(1, -1) == np.arange(8)[:, None]
            )
            for sym in np.flatnonzero(may[:, p0]):
                b = s[p0] - grids[sym][p0]
                hit = free & may[sym] & (s == grids[sym] + b).all(axis=1)
                if best is None or hit.sum() > best[0].sum():
                    best = (hit, sym, b)
            hit, sym, b = best
            labels[t, hit] = len(entries)
            free &= ~hit
            entries.append((int(sym), int(b[0]), int(b[1])))
        tables.append(entries)
    width = max(1, max(len(e) for e in tables))
    table = np.full((k, width, 3), -1, np.int32)
    for t, e in enumerate(tables):
        table[t, : len(e)] = e
    return Provenance(labels=labels.reshape(k, n, n), table=table)


def gather(
    image: np.ndarray,
    prov: Provenance,
    index_map: np.ndarray,
    out: np.ndarray,
    offset: tuple[int, int] = (0, 0),
    threads: int | None = None,
    normal: tuple[str, bool] | None = None,
) -> np.ndarray:
    """Fill ``out`` ``(H, W, C)`` with the window at pixel ``offset = (oy, ox)`` into the first cell of the tiling
    by ``index_map``, every pixel read from ``image`` ``(EH, EW, C)`` (the exemplar or a map aligned with it;
    uint8, uint16, float32 or int32, the dtype of ``out``) through ``prov``. ``normal = (encoding, y_down)`` for a
    normal map: the vectors of rotated or mirrored entries are turned with their pixels, exactly in the sample
    type (:func:`~tilesynth.io.normal_codes.transform_normal_codes`). Rust, GIL released; returns
    ``out``."""
    from .. import _core

    imap = np.ascontiguousarray(index_map, dtype=np.int32)
    turns, snorm = None, False
    if normal is not None and (prov.table[..., 0] > 0).any():
        from ..io.normal_codes import vector_turns

        turns = np.ascontiguousarray(vector_turns(normal[1]), dtype=np.int8)
        snorm = normal[0] == "snorm"
    _core.provenance_gather(
        np.ascontiguousarray(image),
        prov.labels,
        prov.table,
        imap,
        (int(offset[0]), int(offset[1])),
        out,
        threads,
        turns,
        snorm,
    )
    return out


def gather_reference(
    image: np.ndarray,
    prov: Provenance,
    index_map: np.ndarray,
    height: int,
    width: int,
    offset: tuple[int, int] = (0, 0),
    normal: tuple[str, bool] | None = None,
) -> np.ndarray:
    """The numpy oracle of :func:`gather`: materialise the sources of every pixel, then index (and turn)."""
    n = prov.tile_size
    oy, ox = offset
    y = np.arange(height)[:, None] + oy
    x = np.arange(width)[None, :] + ox
    t = np.asarray(index_map)[y // n, x // n]
    src = prov.source()[t, y % n, x % n]
    got = np.asarray(image)[src[..., 0], src[..., 1]]
    if normal is None:
        return got
    from ..io.normal_codes import transform_normal_codes

    sym = np.maximum(prov.table[t, prov.labels[t, y % n, x % n], 0], 0)
    return transform_normal_codes(got, sym, normal[0], normal[1])


def coordinate_grid(height: int, width: int) -> np.ndarray:
    """int32 ``(H, W, 2)`` of every pixel's own (row, col): gathering it gives the provenance."""
    yy, xx = np.mgrid[0:height, 0:width].astype(np.int32)
    return np.ascontiguousarray(np.stack([yy, xx], axis=-1))


def materialise(
    image: np.ndarray, prov: Provenance, tiles: np.ndarray | None = None, threads: int | None = None
) -> np.ndarray:
    """The tiles ``tiles`` (indices; None: all) read from ``image`` through ``prov``: ``(k, N, N, C)`` of
    ``image``'s dtype (:func:`gather` of a one-column index map, a bounded chunk at a time)."""
    img = np.ascontiguousarray(image)
    idx = np.arange(prov.n_tiles) if tiles is None else np.asarray(tiles, np.int64).reshape(-1)
    n, c = prov.tile_size, img.shape[2]
    out = np.empty((idx.size, n, n, c), img.dtype)
    step = max(1, CHUNK_PIXELS // (n * n))
    for lo in range(0, idx.size, step):
        part = idx[lo : lo + step]
        view = out[lo : lo + part.size].reshape(part.size * n, n, c)
        gather(img, prov, part.reshape(-1, 1), view, threads=threads)
    return out


def check_inside(prov: Provenance, height: int, width: int, threads: int | None = None) -> bool:
    """Whether every pixel's source lies inside a ``height x width`` exemplar (and every entry used is a
    symmetry): the gather of the coordinate grid, a bounded chunk at a time, into one reused buffer."""
    grid = coordinate_grid(height, width)
    n = prov.tile_size
    step = max(1, CHUNK_PIXELS // (n * n))
    buf = np.empty((min(step, prov.n_tiles) * n, n, 2), np.int32)
    idx = np.arange(prov.n_tiles)
    for lo in range(0, idx.size, step):
        part = idx[lo : lo + step]
        try:
            gather(grid, prov, part.reshape(-1, 1), buf[: part.size * n], threads=threads)
        except Exception:  # noqa: BLE001 - the kernel's ParameterError for a source outside
            return False
    return True


def pure_copy(tiles: np.ndarray, exemplar: np.ndarray, source: np.ndarray) -> bool:
    """Whether every tile pixel is, bit for bit, the exemplar pixel its provenance names (chunked)."""
    k = tiles.shape[0]
    n = tiles.shape[1]
    step = max(1, CHUNK_PIXELS // max(1, n * n))
    ex = np.ascontiguousarray(exemplar)
    for lo in range(0, k, step):
        s = source[lo : lo + step]
        if (s < 0).any() or (s[..., 0] >= ex.shape[0]).any() or (s[..., 1] >= ex.shape[1]).any():
            return False
        got = ex[s[..., 0], s[..., 1]]
        if not np.array_equal(
            got.view(np.uint32), np.ascontiguousarray(tiles[lo : lo + step]).view(np.uint32)
        ):
            return False
    return True
