"""The built tile set and its file format.

A ``.tiles`` file is a ZIP archive (readable with any zip tool and ``numpy.load`` per member) holding:

==================  =========================================================================================
member              content
==================  =========================================================================================
``manifest.json``   ``format`` = "tilesynth-tileset", ``format_version`` (1 here; 2 below), ``tilesynth_version``, ``scheme``
                    ("omega", "wang" or "swang"), ``layout`` (the tile-set definition: name, colours, one entry per tile), ``params``
                    (tile size, eps, selection method and its parameters, seed), ``per_tile`` table (colours,
                    patch numbers, matching offset, D_j, cut cost), ``E``, ``exemplar`` (file name, shape, bits,
                    SHA-256 of its float32 pixels), ``arrays`` (name -> dtype and shape, for checking)
``tiles.npy``       float32 ``(K, N, N, C)`` the tiles, values in [0, 1]
``source.npy``      int32 ``(K, N, N, 2)`` exemplar (row, col) each tile pixel was copied from (provenance)
``cut_masks.npy``   bool ``(K, N, N)`` True where the pixel came from the matching patch O
``genes.npy``       int64 ``(n, 2)`` top-left (row, col) of the n sample patches
``tile_patches.npy`` int64 ``(K, 4)`` index into genes of each tile's ⟨TL, BL, TR, BR⟩ patch
``match_offsets.npy`` int64 ``(K, 2)`` top-left (row, col) of each tile's matching patch O
``D.npy``           float64 ``(K,)`` exact SSD between the intermediate tile and O
``cut_costs.npy``   float64 ``(K,)`` min-cut cost of each tile's cutting curve
``exemplar.npy``    float32 ``(H, W, C)`` the exemplar itself (so provenance can be resolved and maps that follow
                    the cuts can be synthesised without the original file)
``timing.json``     wall-clock seconds of each build stage; the last member, and optional (``save(...,
                    include_timing=False)``)
==================  =========================================================================================

**Format version 2: provenance.** A set whose every tile pixel is a copy of the exemplar pixel its provenance
names (every set built without Poisson smoothing: :mod:`tilesynth.tileset.provenance` says why) is saved as
version 2, which stores the provenance instead of ``tiles.npy`` and ``source.npy``:

=========================  ==================================================================================
``prov_labels.npy``        uint8 ``(K, N, N)``: which entry of its tile's source table each pixel comes from
``prov_table.npy``         int32 ``(K, L, 3)``: per tile and entry ``(s, by, bx)``, pixel p comes from
                           ``D_s(p) + (by, bx)`` (``s`` a symmetry of the square, -1 past the tile's entries)
``cut_masks_packed.npy``   uint8 ``(K, N, ⌈N/8⌉)``: ``cut_masks`` bit-packed along the rows (``numpy.packbits``)
``exemplar.npy``           the exemplar as its 8- or 16-bit codes when they decode to it bit for bit (``code /
                           (2^bits − 1)`` in float32, as the image reader does), else float32 (the manifest's
                           ``storage.exemplar_dtype`` says which)
``level_<map>.npy``        material sets: float64 ``(B + M, C)``, the solved block and corner levels of each fused
                           map (:func:`tilesynth.builder.materials.map_levels`), and ``level_corners.npy`` int64
                           ``(M,)`` the corner pixels (the fusion's first stage, solved on the first fused synthesis)
=========================  ==================================================================================

with ``genes``, ``tile_patches``, ``match_offsets``, ``D``, ``cut_costs``, the optional members and the maps as in
version 1, and the manifest's ``storage`` (``kind`` "provenance", ``exemplar_dtype``). A loaded version-2 set
materialises ``tiles`` and ``source`` only when they are read; synthesis gathers from the exemplar and never
does. Sets that are not pure copies (Poisson-smoothed) are saved as version 1; ``save(format_version=1)`` writes
version 1 for any set. :meth:`TileSet.content_digest` describes a pure-copy set in version 2 whichever version
it was read from.

**Schemes.** ``scheme`` is ``"omega"`` (ω-tiles, :mod:`tilesynth.builder.omega`), ``"wang"`` (Cohen et al.'s Wang tiles,
:mod:`tilesynth.builder.wang`) or ``"swang"`` (strict Wang tiles of 004). The ``layout`` of an ω set has ``kind`` "corner"
(⟨TL, BL, TR, BR⟩ tuples, :class:`~tilesynth.layouts.omega_sets.CornerTileSet`); a Wang or s-Wang set has ``kind`` "wang"
(⟨N, E, S, W⟩ tuples, :class:`~tilesynth.layouts.wang_sets.WangTileSet`). The members mean, for the Wang schemes:

* ``genes``: top-left (row, col) of the P x P sample squares, one per edge colour in the order of the layout's
  ``horizontal`` then ``vertical`` colours (P = ``params["sample_size"]``); ``tile_patches``: gene index of
  each tile's ⟨N, E, S, W⟩ sample;
* ``cut_masks``: "wang": True where the pixel came from a vertical-edge (E or W) sample, so the mask's
  boundary is the tile's four cuts; "swang": True where it came from the supplementary patch (as for ω);
* ``match_offsets``: "swang": top-left of each tile's supplementary patch; "wang": (-1, -1) (no such patch);
* ``D``: "wang": D_sum of 001 (the sum of the four D_boundary); "swang": exact SSD between the initial tile and
  the supplementary patch; ``cut_costs``: the sum of the four cut costs / the closed cut's cost.

Optional members (written only by the Wang schemes, so ω files are unchanged; a reader that does not know them
ignores them, and their absence is valid): ``labels.npy`` uint8 ``(K, N, N)``, the sample each pixel came from
(0 N, 1 E, 2 S, 3 W, 4 the supplementary patch); ``cut_stats.npy`` float64 ``(K, 4, 6)`` ("wang" only): for the
cuts NE, ES, SW, WN of every tile ``[D_overlap, n_overlap, D_path, n_path, D_boundary, cost]`` (see
:mod:`tilesynth.builder.wang`). They were added without changing ``format_version`` (still 1): every version-1 file
stays valid and loads as before.

Optional members of a material build (:mod:`tilesynth.builder.materials`): ``map_<name>.npy``, one per map,
``(H, W, C)`` uint8, uint16 or float32, pixel-aligned with the exemplar, and the manifest's top-level ``maps``
list (one object per map, in order: ``name``, ``kind`` colour|scalar|normal|label, ``weight``, ``dtype``,
``channels``, ``suffix`` and for normals ``normal_y`` up|down and ``encoding`` unorm|snorm). The exemplar is the
albedo; ``params["material"]`` records the feature image the set was built on (D, E and cut costs are in its
units). Files without maps are unchanged.

Members are written in a fixed order with a fixed timestamp (1980-01-01) and deflate level 1
(:data:`DEFLATE_LEVEL`), so the bytes depend only on the content. Arrays use the ``.npy`` format, floats in JSON use Python's shortest round-trip repr:
loading and saving again reproduces every array and value bit for bit.

**Determinism.** The same inputs, parameters and seed give the same tile set at any thread count and in any run
(``tests/test_golden.py``). What that means for the file: every member but ``timing.json`` is byte-identical,
and since ``timing.json`` is written last, so is the whole file up to it; :meth:`TileSet.content_digest`
(shown by ``tilesynth info``) is equal; and ``save(path, include_timing=False)`` writes a file that is
byte-identical as a whole. Wall-clock times differ from run to run by nature, so they are kept apart rather
than dropped.

**Loading is safe.** ``load`` never executes code: arrays are read with ``allow_pickle=False`` (object arrays
are refused) and JSON is plain data. It refuses, with :class:`~tilesynth.errors.TileSetFormatError` naming the
file and the problem: files that are not ZIP archives, truncated or corrupt archives (bad CRC, bad deflate
data), archives whose members would unpack to more than :data:`MAX_UNPACKED_BYTES`, a wrong ``format`` (the
magic), an unknown ``format_version``, tampered JSON (not an object, wrong field types, a layout that is not a
tile set), and arrays of the wrong dtype or shape or with impossible values (tiles outside [0, 1], provenance
outside the exemplar, patch indices outside the genes, non-finite D or costs).

The format's version and limits, the member names and how each member is checked and written live in
:mod:`tilesynth.tileset.members` (re-exported here), the reading of a file in :mod:`tilesynth.tileset.reader`,
the consistency checks in :mod:`tilesynth.tileset.checks`; this module is :class:`TileSet`.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError, TileSetFormatError
from ..io.images import atomic_path
from .checks import CUT_STAT_NAMES, check_shapes, check_values
from .members import (  # noqa: F401 - re-exported: tilesynth.tileset.tilefile.<name> stays the import path
    _ARRAYS,
    _ARRAYS_V2,
    _MAP_NAME,
    _OPTIONAL,
    BZIP2_LEVEL,
    DEFLATE_LEVEL,
    FORMAT,
    FORMAT_VERSION,
    FORMAT_VERSIONS,
    LEVEL_BLOCK,
    MAX_MANIFEST_BYTES,
    MAX_UNPACKED_BYTES,
    _bzip2_member,
    _check_levels,
    _check_manifest,
    _check_map_shapes,
    _json_bytes,
    _level_members,
    _map_members,
    _npy_bytes,
    _npy_size,
    _write_array,
    _write_member,
    exemplar_digest,
    member_sizes,
)
from .reader import read_archive

#: Names of the four cuts of a Wang tile, in the order of ``cut_stats``.
CUT_NAMES: tuple[str, ...] = ("NE", "ES", "SW", "WN")


class _Materialised:
    """A field of :class:`TileSet` (``tiles``, ``source``) that a version-2 set holds as provenance: materialised
    from the exemplar on first access (and then kept), so that only the code that needs the whole atlas pays for
    it; synthesis gathers from the exemplar instead (:mod:`tilesynth.tileset.provenance`)."""

    def __set_name__(self, owner: type, name: str) -> None:
        self.name = name
        self.slot = f"_{name}_array"

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            raise AttributeError(self.name)  # no class-level default: the dataclass field stays required
        value = obj.__dict__.get(self.slot)
        if value is None and obj.__dict__.get("provenance") is not None:
            value = obj._materialise(self.name)
            obj.__dict__[self.slot] = value
        return value

    def __set__(self, obj: Any, value: Any) -> None:
        obj.__dict__[self.slot] = value


@dataclass(eq=False)
class TileSet:
    """A built set of tiles with full provenance; see the module docstring for the meaning of each field.

    ``layout`` is the tile-set definition as a JSON-able dict (``CornerTileSet.to_dict()``); use
    :attr:`definition` for the object.
    """

    scheme: str
    layout: dict[str, Any]
    tiles: np.ndarray = _Materialised()  # type: ignore[assignment]
    source: np.ndarray = _Materialised()  # type: ignore[assignment]
    cut_masks: np.ndarray
    genes: np.ndarray
    tile_patches: np.ndarray
    match_offsets: np.ndarray
    D: np.ndarray
    cut_costs: np.ndarray
    exemplar: np.ndarray
    E: float
    params: dict[str, Any]
    exemplar_info: dict[str, Any]
    timing: dict[str, float] = field(default_factory=dict)
    version: str = ""
    labels: np.ndarray | None = None
    cut_stats: np.ndarray | None = None
    maps: dict[str, np.ndarray] | None = None
    """Material builds (:mod:`tilesynth.builder.materials`): every map, ``(H, W, C)`` in its own sample type."""
    map_specs: list[dict[str, Any]] | None = None
    """Material builds: the manifest's ``maps`` entries (name, kind, weight, dtype, channels, ...), in order."""
    provenance: Any = None
    """The :class:`~tilesynth.tileset.provenance.Provenance` (labels and source table) of a set read from a
    version-2 file: ``tiles`` and ``source`` are then materialised from it only when read (a built set has
    None here: :meth:`storage` finds its provenance when it is saved)."""
    file_version: int | None = None
    """The format version of the file this set was loaded from (None: built in this process)."""
    map_levels: dict[str, Any] | None = None
    """Material sets: the first stage of every fused map's seam treatment (``seams="fuse"``), solved on the first
    fused synthesis and kept (:func:`tilesynth.builder.materials.map_levels`); stored in version-2 files as
    ``level_<name>.npy`` when present."""

    # ---------------------------------------------------------------------------------------- provenance
    def _materialise(self, name: str) -> np.ndarray:
        """The whole ``tiles`` (float32) or ``source`` (int32) array of a provenance set."""
        from .provenance import coordinate_grid, materialise

        if name == "tiles":
            return materialise(self.exemplar, self.provenance)
        return materialise(coordinate_grid(*self.exemplar.shape[:2]), self.provenance)

    def has_pixels(self) -> bool:
        """Whether the float tiles are held in memory (a built or version-1 set, or a materialised one)."""
        return self.__dict__.get("_tiles_array") is not None

    def storage(self) -> int:
        """The format version this set is saved as (and its :meth:`manifest` and :meth:`content_digest` describe):
        2 (provenance) for pure copies, every tile pixel the exemplar pixel its provenance names bit for bit (as
        without Poisson smoothing); 1 (pixels) otherwise. Whether a set built or read from a version-1 file is
        a pure copy (:func:`~tilesynth.tileset.provenance.factorise`) is found once."""
        return 2 if self._provenance() is not None else 1

    def _provenance(self) -> Any:
        """The provenance a version-2 file of this set stores: the loaded one while the tiles are not in memory,
        else found from the tiles and provenance in memory (once for these arrays: a set whose arrays are
        replaced is looked at again)."""
        if not self.has_pixels():
            return self.provenance
        tiles, source = self.tiles, self.source
        found = self.__dict__.get("_found")
        if found is None or found[0] is not tiles or found[1] is not source or found[2] is not self.exemplar:
            from .provenance import factorise, pure_copy, turned_pixels

            prov = None
            if not isinstance(self.params.get("smooth"), dict) and pure_copy(tiles, self.exemplar, source):
                turns = turned_pixels(source, self.match_offsets, self.params.get("match_transforms"))
                prov = factorise(source, orient=turns)  # an entry's symmetry is its pixels' turn
            found = (tiles, source, self.exemplar, prov)
            self.__dict__["_found"] = found
        return found[3]

    # ----------------------------------------------------------------------------------------------- views
    @property
    def definition(self):  # noqa: ANN201 - CornerTileSet | WangTileSet
        """The tile-set definition object (colours and matching rule)."""
        from ..layouts.omega_sets import tileset_from_dict

        return tileset_from_dict(self.layout)

    def _arrays(self, version: int | None = None) -> dict[str, str]:
        """Name -> dtype of every member array of the file of ``version`` (None: :meth:`storage`), the optional
        ones only when present."""
        version = self.storage() if version is None else version
        if version == 2:
            out = dict(_ARRAYS_V2)
            out["exemplar"] = self._exemplar_codes()[0]
        else:
            out = dict(_ARRAYS)
        out.update({k: v for k, v in _OPTIONAL.items() if getattr(self, k) is not None})
        out.update(_map_members(self.map_specs))  # material maps, last
        if version == 2 and self.map_levels:
            out.update(_level_members(self.map_levels, self.map_specs))
        return out

    def _member(self, name: str, version: int | None = None) -> np.ndarray:
        """The array of member ``name`` (``map_<name>`` for a material map; the provenance members of version 2)."""
        if name.startswith("map_") and self.maps is not None and name[4:] in self.maps:
            return self.maps[name[4:]]
        if name == "prov_labels":
            return self._provenance().labels
        if name == "prov_table":
            return self._provenance().table
        if name == "cut_masks_packed":
            return np.packbits(self.cut_masks, axis=-1)
        if name == "exemplar" and (self.storage() if version is None else version) == 2:
            return self._exemplar_codes()[1]
        if name == "level_corners":
            return self.map_levels["corners"]
        if name.startswith("level_") and self.map_levels and name[6:] in self.map_levels:
            return self.map_levels[name[6:]]
        return getattr(self, name)

    def _exemplar_codes(self) -> tuple[str, np.ndarray]:
        """The exemplar as a version-2 file stores it: its 8- or 16-bit codes when decoding them as the image
        reader does (``code / (2^bits - 1)`` in float32) gives it back bit for bit, else its float32 pixels."""
        if "_codes" not in self.__dict__ or self.__dict__["_codes"][0] is not self.exemplar:
            ex = self.exemplar
            out: tuple[str, np.ndarray] = ("float32", ex)
            for dt, top in ((np.uint8, 255), (np.uint16, 65535)):
                codes = np.rint(ex * np.float32(top)).astype(dt)
                if np.array_equal(codes.astype(np.float32) / np.float32(top), ex):
                    out = (np.dtype(dt).name, codes)
                    break
            self.__dict__["_codes"] = (ex, out)
        return self.__dict__["_codes"][1]

    @property
    def n_tiles(self) -> int:
        if not self.has_pixels() and self.provenance is not None:
            return self.provenance.n_tiles
        return int(self.tiles.shape[0])

    @property
    def tile_size(self) -> int:
        if not self.has_pixels() and self.provenance is not None:
            return self.provenance.tile_size
        return int(self.tiles.shape[1])

    @property
    def channels(self) -> int:
        if not self.has_pixels() and self.provenance is not None:
            return int(self.exemplar.shape[2])
        return int(self.tiles.shape[3])

    def per_tile(self) -> list[dict[str, Any]]:
        """One JSON-able row per tile: colours, variant, patches, matching offset, D_j, cut cost."""
        defn = self.definition
        rows = []
        if self.layout.get("kind", "corner") == "wang":
            for k in range(self.n_tiles):
                row: dict[str, Any] = {
                    "index": k,
                    "edges": "".join(defn.tiles[k]),
                    "patches": [int(v) for v in self.tile_patches[k]],
                    "match_offset": [int(v) for v in self.match_offsets[k]],
                    "D": float(self.D[k]),
                    "cut_cost": float(self.cut_costs[k]),
                }
                if self.cut_stats is not None:
                    row["cuts"] = {
                        name: dict(zip(CUT_STAT_NAMES, (float(v) for v in self.cut_stats[k, q])))
                        for q, name in enumerate(CUT_NAMES)
                    }
                rows.append(row)
            return rows
        for k in range(self.n_tiles):
            rows.append(
                {
                    "index": k,
                    "corners": "".join(defn.tiles[k]),
                    "variant": int(defn.variants[k]),
                    "patches": [int(v) for v in self.tile_patches[k]],
                    "match_offset": [int(v) for v in self.match_offsets[k]],
                    "D": float(self.D[k]),
                    "cut_cost": float(self.cut_costs[k]),
                }
            )
        return rows

    def manifest(self, version: int | None = None) -> dict[str, Any]:
        """The ``manifest.json`` content of the file of ``version`` (None: :meth:`storage`)."""
        version = self.storage() if version is None else version
        storage = {"storage": {"kind": "provenance", "exemplar_dtype": self._exemplar_codes()[0]}}
        return {
            "format": FORMAT,
            "format_version": version,
            "tilesynth_version": self.version,
            "scheme": self.scheme,
            "layout": self.layout,
            "params": self.params,
            "E": float(self.E),
            "exemplar": self.exemplar_info,
            "per_tile": self.per_tile(),
            "arrays": {
                name: {"dtype": dt, "shape": list(self._member_shape(name, version))}
                for name, dt in self._arrays(version).items()
            },
            **({"maps": self.map_specs} if self.map_specs else {}),
            **(storage if version == 2 else {}),
        }

    def _member_shape(self, name: str, version: int | None) -> tuple[int, ...]:
        if name == "cut_masks_packed":
            k, n = self.cut_masks.shape[:2]
            return (k, n, -(-n // 8))
        return tuple(self._member(name, version).shape)

    def content_digest(self) -> str:
        """SHA-256 over everything but the timing, as :meth:`storage` saves it: equal digests mean equal tile
        sets (a pure-copy set has the same digest whether it was read from a version-1 or a version-2 file)."""
        h = hashlib.sha256()
        h.update(_json_bytes(self.manifest()))
        for name in self._arrays():
            h.update(_npy_bytes(self._member(name)))
        return h.hexdigest()

    def stored_sizes(self) -> dict[str, int]:
        """Bytes of every member array as :meth:`storage` saves it, uncompressed (``.npy`` with header): what
        ``tilesynth info`` shows beside the file's own member sizes."""
        return {name: _npy_size(self._member(name)) for name in self._arrays()}

    # ---------------------------------------------------------------------------------------------- files
    def save(
        self, path: str | os.PathLike[str], include_timing: bool = True, format_version: int | None = None
    ) -> None:
        """Write the tile set to ``path`` atomically (see the module docstring for the layout).

        ``include_timing=False`` leaves out ``timing.json``, so that the same build gives a byte-identical
        file in every run (see "Determinism" in the module docstring). ``format_version``: None (default)
        writes version 2 (provenance) for a pure-copy set and version 1 (pixels) otherwise (:meth:`storage`);
        1 writes pixels whatever the set (for readers older than version 2).
        """
        self._check()
        version = self.storage() if format_version is None else int(format_version)
        if version not in FORMAT_VERSIONS or (version == 2 and self.storage() != 2):
            raise ParameterError(
                f"format_version = {format_version!r}: must be None, 1, or 2 for a pure-copy set (this set "
                f"{'is' if self.storage() == 2 else 'is not'} one)"
            )
        with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w") as zf:
            _write_member(zf, "manifest.json", _json_bytes(self.manifest(version)))
            for name in self._arrays(version):
                _write_array(
                    zf, f"{name}.npy", self._member(name, version), version == 2 and _bzip2_member(name)
                )
            if include_timing:
                _write_member(zf, "timing.json", _json_bytes(self.timing))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> TileSet:
        """Read a ``.tiles`` file; raises :class:`TileSetFormatError` naming the path and the problem.

        Never executes code from the file (see "Loading is safe" in the module docstring).
        """
        p, kwargs = read_archive(path)
        ts = cls(**kwargs)
        try:
            ts._check(values=True)
        except TileSetFormatError as exc:
            raise TileSetFormatError(f"tileset = {p!r}: {exc}") from None
        return ts

    def _check(self, values: bool = False) -> None:
        """Consistency of dtypes and shapes, and with ``values`` of the array contents and the layout
        (raises TileSetFormatError). ``load`` checks everything; ``save`` the dtypes and shapes."""
        check_shapes(self, values)
        if values:
            check_values(self)

    # ------------------------------------------------------------------------------------------ synthesis
    def synthesize(self, width: int, height: int, seed: int | None = None, **kwargs: Any):  # noqa: ANN201
        """Shorthand for :func:`tilesynth.synthesize` on this tile set."""
        from ..synth.synthesis import synthesize

        return synthesize(self, width, height, seed=seed, **kwargs)
