"""The built tile set and its file format.

A ``.tiles`` file is a ZIP archive (readable with any zip tool and ``numpy.load`` per member) holding:

==================  =========================================================================================
member              content
==================  =========================================================================================
``manifest.json``   ``format`` = "tilesynth-tileset", ``format_version``, ``tilesynth_version``, ``scheme``
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

Optional members of a material build (issue 14, :mod:`tilesynth.builder.materials`): ``map_<name>.npy``, one per map,
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
"""

from __future__ import annotations

import hashlib
import io
import json
import lzma
import os
import re
import zipfile
import zlib
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import TileSetFormatError
from ..io.images import atomic_path

FORMAT = "tilesynth-tileset"
FORMAT_VERSION = 1

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

#: Optional members (Wang schemes), written after the others when present.
_OPTIONAL: dict[str, str] = {
    "labels": "uint8",
    "cut_stats": "float64",
}

#: Names of the four cuts of a Wang tile, in the order of ``cut_stats``.
CUT_NAMES: tuple[str, ...] = ("NE", "ES", "SW", "WN")
#: The six values per cut in ``cut_stats``.
CUT_STAT_NAMES: tuple[str, ...] = ("D_overlap", "n_overlap", "D_path", "n_path", "D_boundary", "cost")


@dataclass(eq=False)
class TileSet:
    """A built set of tiles with full provenance; see the module docstring for the meaning of each field.

    ``layout`` is the tile-set definition as a JSON-able dict (``CornerTileSet.to_dict()``); use
    :attr:`definition` for the object.
    """

    scheme: str
    layout: dict[str, Any]
    tiles: np.ndarray
    source: np.ndarray
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

    # ----------------------------------------------------------------------------------------------- views
    @property
    def definition(self):  # noqa: ANN201 - CornerTileSet | WangTileSet
        """The tile-set definition object (colours and matching rule)."""
        from ..layouts.omega_sets import tileset_from_dict

        return tileset_from_dict(self.layout)

    def _arrays(self) -> dict[str, str]:
        """Name -> dtype of every member array this tile set holds (the optional ones only when present)."""
        out = dict(_ARRAYS)
        out.update({k: v for k, v in _OPTIONAL.items() if getattr(self, k) is not None})
        out.update(_map_members(self.map_specs))  # issue 14: material maps, last
        return out

    def _member(self, name: str) -> np.ndarray:
        """The array of member ``name`` (``map_<name>`` for a material map)."""
        if name.startswith("map_") and self.maps is not None and name[4:] in self.maps:
            return self.maps[name[4:]]
        return getattr(self, name)

    @property
    def n_tiles(self) -> int:
        return int(self.tiles.shape[0])

    @property
    def tile_size(self) -> int:
        return int(self.tiles.shape[1])

    @property
    def channels(self) -> int:
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

    def manifest(self) -> dict[str, Any]:
        """The ``manifest.json`` content."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "tilesynth_version": self.version,
            "scheme": self.scheme,
            "layout": self.layout,
            "params": self.params,
            "E": float(self.E),
            "exemplar": self.exemplar_info,
            "per_tile": self.per_tile(),
            "arrays": {
                name: {"dtype": dt, "shape": list(self._member(name).shape)}
                for name, dt in self._arrays().items()
            },
            **({"maps": self.map_specs} if self.map_specs else {}),
        }

    def content_digest(self) -> str:
        """SHA-256 over everything but the timing: equal digests mean equal tile sets."""
        h = hashlib.sha256()
        h.update(_json_bytes(self.manifest()))
        for name in self._arrays():
            h.update(_npy_bytes(self._member(name)))
        return h.hexdigest()

    # ---------------------------------------------------------------------------------------------- files
    def save(self, path: str | os.PathLike[str], include_timing: bool = True) -> None:
        """Write the tile set to ``path`` atomically (see the module docstring for the layout).

        ``include_timing=False`` leaves out ``timing.json``, so that the same build gives a byte-identical
        file in every run (see "Determinism" in the module docstring).
        """
        self._check()
        with atomic_path(path) as tmp, zipfile.ZipFile(tmp, "w") as zf:
            _write_member(zf, "manifest.json", _json_bytes(self.manifest()))
            for name in self._arrays():
                _write_array(zf, f"{name}.npy", self._member(name))
            if include_timing:
                _write_member(zf, "timing.json", _json_bytes(self.timing))

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> TileSet:
        """Read a ``.tiles`` file; raises :class:`TileSetFormatError` naming the path and the problem.

        Never executes code from the file (see "Loading is safe" in the module docstring).
        """
        p = os.fspath(path)
        if os.path.isdir(p):
            raise TileSetFormatError(f"tileset = {p!r}: is a directory, expected a .tiles file")
        if not os.path.isfile(p):
            what = "not a regular file (a device, FIFO or socket)" if os.path.exists(p) else "no such file"
            raise TileSetFormatError(f"tileset = {p!r}: {what}")
        try:
            with zipfile.ZipFile(p) as zf:
                infos = {i.filename: i for i in zf.infolist()}
                missing = [m for m in ["manifest.json", *(f"{a}.npy" for a in _ARRAYS)] if m not in infos]
                if missing:
                    raise TileSetFormatError(
                        f"tileset = {p!r}: not a tilesynth tile set (missing members {missing})"
                    )
                unpacked = sum(i.file_size for i in infos.values())
                if unpacked > MAX_UNPACKED_BYTES:
                    raise TileSetFormatError(
                        f"tileset = {p!r}: members unpack to {unpacked} bytes, more than the limit of "
                        f"{MAX_UNPACKED_BYTES} (MAX_UNPACKED_BYTES)"
                    )
                if infos["manifest.json"].file_size > MAX_MANIFEST_BYTES:
                    raise TileSetFormatError(
                        f"tileset = {p!r}: manifest.json unpacks to {infos['manifest.json'].file_size} bytes, more "
                        f"than the limit of {MAX_MANIFEST_BYTES} (MAX_MANIFEST_BYTES)"
                    )
                manifest = json.loads(zf.read("manifest.json"))
                from .manifest import check_archive

                members = {**_ARRAYS, **_OPTIONAL}
                if isinstance(manifest, dict) and isinstance(manifest.get("maps"), list):
                    members.update(_map_members(manifest["maps"], checked=False))  # issue 14
                check_archive(zf, manifest, members)  # schema and .npy headers (issue 16)
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
                    for a in [*_ARRAYS, *_OPTIONAL]
                    if a in _ARRAYS or f"{a}.npy" in infos
                }
                maps = {
                    m[4:]: np.load(io.BytesIO(zf.read(f"{m}.npy")), allow_pickle=False)
                    for m in _map_members(map_specs)
                } or None
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
        ts = cls(
            scheme=manifest["scheme"],
            layout=manifest["layout"],
            E=float(manifest["E"]),
            params=manifest["params"],
            exemplar_info=manifest["exemplar"],
            timing=timing,
            version=manifest["tilesynth_version"],
            maps=maps,
            map_specs=map_specs,
            **arrays,
        )
        try:
            ts._check(values=True)
        except TileSetFormatError as exc:
            raise TileSetFormatError(f"tileset = {p!r}: {exc}") from None
        return ts

    def _check(self, values: bool = False) -> None:
        """Consistency of dtypes and shapes, and with ``values`` of the array contents and the layout
        (raises TileSetFormatError). ``load`` checks everything; ``save`` the dtypes and shapes."""
        self._check_shapes(values)
        if values:
            self._check_values()

    def _check_shapes(self, values: bool) -> None:
        """Dtypes and shapes of the arrays, and (with ``values``) the manifest's exemplar shape."""
        for name, dt in self._arrays().items():
            a = self._member(name)
            if not isinstance(a, np.ndarray) or a.dtype != np.dtype(dt):
                raise TileSetFormatError(f"array {name} must be {dt}, got {getattr(a, 'dtype', type(a))}")
        k, n, n2, c = self.tiles.shape
        expect = {
            "source": (k, n, n, 2),
            "cut_masks": (k, n, n),
            "tile_patches": (k, 4),
            "match_offsets": (k, 2),
            "D": (k,),
            "cut_costs": (k,),
        }
        if self.labels is not None:
            expect["labels"] = (k, n, n)
        if self.cut_stats is not None:
            expect["cut_stats"] = (k, 4, len(CUT_STAT_NAMES))
        if n != n2:
            raise TileSetFormatError(f"tiles must be square, got shape {self.tiles.shape}")
        for name, shape in expect.items():
            if getattr(self, name).shape != shape:
                raise TileSetFormatError(
                    f"array {name} has shape {getattr(self, name).shape}, expected {shape}"
                )
        if len(self.layout.get("tiles", [])) != k:
            raise TileSetFormatError(
                f"layout lists {len(self.layout.get('tiles', []))} tiles, the arrays {k}"
            )
        if self.exemplar.ndim != 3 or self.exemplar.shape[2] != c:
            raise TileSetFormatError(f"exemplar has shape {self.exemplar.shape}, expected (H, W, {c})")
        if values and list(self.exemplar_info.get("shape", [])) != list(self.exemplar.shape):
            raise TileSetFormatError(
                f"manifest exemplar.shape {self.exemplar_info.get('shape')} disagrees with the exemplar array "
                f"{list(self.exemplar.shape)}"
            )
        _check_map_shapes(self.maps, self.map_specs, self.exemplar.shape[:2])
        if k == 0 or n == 0 or not 1 <= c <= 4 or 0 in self.exemplar.shape:
            raise TileSetFormatError(
                f"tiles have shape {self.tiles.shape}, expected (K, N, N, C) with K, N >= 1 and C in 1..4"
            )
        if self.genes.ndim != 2 or self.genes.shape[1] != 2 or self.genes.shape[0] == 0:
            raise TileSetFormatError(f"array genes has shape {self.genes.shape}, expected (n, 2) with n >= 1")

    def _check_values(self) -> None:
        """The array contents and the layout: values in range, positions inside the exemplar."""
        k, n = self.tiles.shape[:2]
        try:
            from ..layouts.omega_sets import tileset_from_dict

            defn = tileset_from_dict(self.layout)
        except Exception as exc:  # noqa: BLE001 - tampered content may fail in any way; it is a format error
            raise TileSetFormatError(
                f"layout is not a tile-set definition ({type(exc).__name__}: {exc})"
            ) from None
        if len(defn.tiles) != k:
            raise TileSetFormatError(f"layout lists {len(defn.tiles)} tiles, the arrays {k}")
        h, w = self.exemplar.shape[:2]
        for name in ("tiles", "exemplar"):
            a = getattr(self, name)
            if not np.isfinite(a).all() or a.min() < 0 or a.max() > 1:
                raise TileSetFormatError(f"array {name} has values outside [0, 1] (or NaN)")
        for name, m in (self.maps or {}).items():
            if m.dtype == np.float32 and not np.isfinite(m).all():
                raise TileSetFormatError(f"map {name!r} has NaN or infinite values")
        for name in ("D", "cut_costs"):
            if not np.isfinite(getattr(self, name)).all():
                raise TileSetFormatError(f"array {name} has non-finite values")
        src = self.source
        if src.size and (src.min() < 0 or src[..., 0].max() >= h or src[..., 1].max() >= w):
            raise TileSetFormatError(f"array source points outside the {w}x{h} exemplar")
        for name in ("genes", "match_offsets"):
            g = getattr(self, name)
            if name == "match_offsets" and (g == -1).any():
                # a scheme without a matching patch (Cohen's Wang tiles) stores (-1, -1) for every tile; the
                # format asks no scheme which: all -1, or all valid positions
                if not (g == -1).all():
                    raise TileSetFormatError(
                        "array match_offsets must be all -1 (a scheme without matching patches) or patch positions"
                    )
                if isinstance(self.params.get("smooth"), dict):  # smoothing follows the matching patches
                    raise TileSetFormatError(
                        "array match_offsets of a smoothed tile set must hold patch positions"
                    )
                continue
            if (g < 0).any() or (g[:, 0] > h - n).any() or (g[:, 1] > w - n).any():
                raise TileSetFormatError(f"array {name} has patch positions outside the {w}x{h} exemplar")
        if (self.tile_patches < 0).any() or (self.tile_patches >= self.genes.shape[0]).any():
            raise TileSetFormatError(f"array tile_patches has indices outside [0, {self.genes.shape[0]})")

    # ------------------------------------------------------------------------------------------ synthesis
    def synthesize(self, width: int, height: int, seed: int | None = None, **kwargs: Any):  # noqa: ANN201
        """Shorthand for :func:`tilesynth.synthesize` on this tile set."""
        from ..synth.synthesis import synthesize

        return synthesize(self, width, height, seed=seed, **kwargs)


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
    if m.get("format_version") != FORMAT_VERSION:
        raise TileSetFormatError(
            f"format version {m.get('format_version')!r}, this tilesynth reads version {FORMAT_VERSION}"
        )
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
    """``{"map_<name>": dtype}`` of the maps of a material set (issue 14); ``checked=False`` skips what the
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


def _write_array(zf: zipfile.ZipFile, name: str, a: np.ndarray) -> None:
    """:func:`_write_member` of ``_npy_bytes(a)``, streamed: the same member bytes (the uncompressed size is
    set in advance, as ``writestr`` sets it, and ``np.lib.format.write_array`` writes the same header and data
    in 16 MiB pieces), without the two whole in-memory copies of the array (issue 12: a c5 set's 123 MB of
    tiles were the peak of saving it)."""
    a = np.ascontiguousarray(a)
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    info.external_attr = 0o644 << 16
    info.file_size = _npy_size(a)
    if "compress_level" in getattr(zipfile.ZipInfo, "__slots__", ()):  # Python >= 3.13
        info.compress_level = DEFLATE_LEVEL
    else:
        info._compresslevel = DEFLATE_LEVEL  # what writestr(..., compresslevel=) sets before 3.13
    with zf.open(info, mode="w") as dest:
        np.lib.format.write_array(dest, a, allow_pickle=False)
