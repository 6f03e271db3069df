"""The hashed lookup of complete tile sets: random access to an infinite, non-periodic tiling.

A *complete* set has a tile for every corner tuple ⟨TL, BL, TR, BR⟩ over K colours (``c3``, ``c3x2``, see
:mod:`tilesynth.layouts.complete`) or every edge tuple ⟨N, E, S, W⟩ over Kh, Kv colours (``wc2``, ...). The colour of
every lattice vertex (edge) is then free, so it can come from a hash of its integer coordinates and the seed:
no scan-line dependency, any window of the texture is computed on its own, and the same function runs in a
shader (``HASH-SPEC.md``; the engine exports record :data:`HASH_NAME` and the constants below).

**The hash** is pcg3d (Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 9(3), 2020) on unsigned
32-bit integers with wrapping arithmetic::

    v = v * 1664525 + 1013904223;  v.x += v.y*v.z; v.y += v.z*v.x; v.z += v.x*v.y;
    v ^= v >> 16;                  v.x += v.y*v.z; v.y += v.z*v.x; v.z += v.x*v.y;
    ts_hash(x, y, seed, role) = pcg3d(uint(x), uint(y), seed ^ (role * 0x9E3779B9)).x

``uint(x)`` of a negative coordinate is its two's complement. Roles: 0 vertex colour, 1 horizontal-edge (N/S)
colour, 2 vertical-edge (E/W) colour, 3 cell variant. A colour is ``ts_hash % K``: the modulo bias is at most
K / 2^32, negligible, and keeps the shader to one ``%``.

**The lattice**: cell (cx, cy) covers pixels [cx·N, (cx+1)·N) × [cy·N, (cy+1)·N); vertex (vx, vy) is the
top-left corner of cell (vx, vy); horizontal edge (hx, hy) the top edge and vertical edge (ex, ey) the left
edge of cell (ex, ey). Corner tile of a cell: TL = c(cx, cy), BL = c(cx, cy+1), TR = c(cx+1, cy),
BR = c(cx+1, cy+1), v = ts_hash(cx, cy, seed, 3) % V, index = (((TL·K + BL)·K + TR)·K + BR)·V + v. Edge tile:
N = h(cx, cy), S = h(cx, cy+1), W = e(cx, cy), E = e(cx+1, cy), index = (((N·Kv + E)·Kh + S)·Kv + W)·V + v.
With ``wrap = (Tx, Ty)`` every coordinate is reduced Euclidean-mod (Tx, Ty) first, so the texture is periodic.

Pairs are x first throughout (``origin = (x0, y0)``, ``size = (cols, rows)``, ``wrap = (Tx, Ty)``), as in the
spec; the maps returned are numpy ``(rows, cols)``.

:func:`pcg3d_reference` and :func:`ts_hash_reference` are plain-Python versions (the test oracle and the
generator of ``tests/data/hash_vectors.json``); :func:`ts_hash` and :func:`index_map` run in Rust.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _core
from ..base.validate import asarray_aligned, threads_arg
from ..errors import ParameterError

HASH_NAME: str = _core.HASH_NAME
"""Name of the hash (``"pcg3d"``)."""
PCG_MUL: int = _core.HASH_PCG_MUL
"""Multiplier of pcg3d's LCG step (1664525)."""
PCG_INC: int = _core.HASH_PCG_INC
"""Increment of pcg3d's LCG step (1013904223)."""
ROLE_MUL: int = _core.HASH_ROLE_MUL
"""Role multiplier mixed into the seed (0x9E3779B9)."""
ROLE_VERTEX, ROLE_HEDGE, ROLE_VEDGE, ROLE_VARIANT = _core.HASH_ROLES
"""The roles: vertex colour 0, horizontal-edge colour 1, vertical-edge colour 2, cell variant 3."""

MAX_MAP_CELLS = 2**28
"""Most cells of one index map (1 GiB of int32; a map of a ~10^12-pixel texture)."""

_M32 = 0xFFFFFFFF
_I32_MIN, _I32_MAX = -(2**31), 2**31 - 1


# ------------------------------------------------------------------------------------------ reference
def pcg3d_reference(x: int, y: int, z: int) -> tuple[int, int, int]:
    """pcg3d in plain Python integers, every operation reduced mod 2^32 (the test oracle)."""
    x, y, z = ((c * 1664525 + 1013904223) & _M32 for c in (x & _M32, y & _M32, z & _M32))
    x = (x + y * z) & _M32
    y = (y + z * x) & _M32
    z = (z + x * y) & _M32
    x ^= x >> 16
    y ^= y >> 16
    z ^= z >> 16
    x = (x + y * z) & _M32
    y = (y + z * x) & _M32
    z = (z + x * y) & _M32
    return x, y, z


def ts_hash_reference(x: int, y: int, seed: int, role: int) -> int:
    """``ts_hash`` in plain Python: ``pcg3d(uint(x), uint(y), seed ^ (role * 0x9E3779B9)).x``."""
    return pcg3d_reference(x, y, seed ^ ((role * 0x9E3779B9) & _M32))[0]


# ------------------------------------------------------------------------------------------ validation
def hash_seed(seed: Any) -> int:
    """A seed of the hashed lookup: an int in [0, 2^32); None draws one. Anything else: ParameterError."""
    if seed is None:
        return int(np.random.SeedSequence().entropy % (2**32))
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
        raise ParameterError(f"seed = {seed!r}: the hashed lookup needs an integer in [0, 2^32)")
    if not 0 <= int(seed) < 2**32:
        raise ParameterError(f"seed = {seed}: the hashed lookup needs an integer in [0, 2^32)")
    return int(seed)


def _int(value: Any, name: str, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} = {value!r}: must be an integer")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise ParameterError(f"{name} = {v}: must be in [{lo}, {hi}]")
    return v


def _pair(value: Any, name: str) -> tuple[Any, Any]:
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ParameterError(f"{name} = {value!r}: expected a pair (x, y)") from None
    return a, b


# ------------------------------------------------------------------------------------------ scheme
@dataclass(frozen=True)
class LookupScheme:
    """How a complete set is indexed: ``kind`` ``"corner"`` (``colours = (K,)``) or ``"edge"``
    (``colours = (Kh, Kv)``), ``variants`` V per tuple. ``n_tiles`` is K⁴·V (Kh²·Kv²·V)."""

    kind: str
    colours: tuple[int, ...]
    variants: int = 1

    def __post_init__(self) -> None:
        if self.kind not in ("corner", "edge"):
            raise ParameterError(f"kind = {self.kind!r}: must be 'corner' or 'edge'")
        want = 1 if self.kind == "corner" else 2
        cols = tuple(_int(c, "colours", 1, 2**31 - 1) for c in self.colours)
        if len(cols) != want:
            raise ParameterError(
                f"colours = {self.colours!r}: a {self.kind} scheme needs {want} colour count(s)"
            )
        object.__setattr__(self, "colours", cols)
        object.__setattr__(self, "variants", _int(self.variants, "variants", 1, 2**31 - 1))
        if self.n_tiles > _I32_MAX:
            raise ParameterError(f"{self}: {self.n_tiles} tiles do not fit an int32 tile index")

    @property
    def n_tiles(self) -> int:
        """Number of tiles of the complete set."""
        if self.kind == "corner":
            return self.colours[0] ** 4 * self.variants
        kh, kv = self.colours
        return kh * kh * kv * kv * self.variants

    def index(self, t: tuple[int, int, int, int], v: int = 0) -> int:
        """Tile index of tuple ``t`` (⟨TL, BL, TR, BR⟩ or ⟨N, E, S, W⟩ colour numbers) and variant ``v``."""
        if self.kind == "corner":
            (k,) = self.colours
            return (((t[0] * k + t[1]) * k + t[2]) * k + t[3]) * self.variants + v
        kh, kv = self.colours
        return (((t[0] * kv + t[1]) * kh + t[2]) * kv + t[3]) * self.variants + v

    def tuple_of(self, index: int) -> tuple[tuple[int, int, int, int], int]:
        """Inverse of :meth:`index`: ``(tuple, variant)`` of a tile index."""
        t, v = divmod(int(index), self.variants)
        if self.kind == "corner":
            (k,) = self.colours
            sizes = (k, k, k, k)
        else:
            kh, kv = self.colours
            sizes = (kh, kv, kh, kv)
        out = []
        for s in reversed(sizes):
            t, r = divmod(t, s)
            out.append(r)
        a, b, c, d = reversed(out)
        return (a, b, c, d), v


def cell_index_reference(
    scheme: LookupScheme, seed: int, cx: int, cy: int, wrap: tuple[int, int] | None = None
) -> int:
    """The tile index of cell (cx, cy) in plain Python (the oracle of :func:`index_map`)."""

    def red(c: int, p: int | None) -> int:
        return c % p if p is not None else c

    px, py = (wrap[0], wrap[1]) if wrap is not None else (None, None)
    x0, x1, y0, y1 = red(cx, px), red(cx + 1, px), red(cy, py), red(cy + 1, py)
    v = ts_hash_reference(x0, y0, seed, ROLE_VARIANT) % scheme.variants
    if scheme.kind == "corner":
        (k,) = scheme.colours

        def c(x: int, y: int) -> int:
            return ts_hash_reference(x, y, seed, ROLE_VERTEX) % k

        return scheme.index((c(x0, y0), c(x0, y1), c(x1, y0), c(x1, y1)), v)
    kh, kv = scheme.colours
    n = ts_hash_reference(x0, y0, seed, ROLE_HEDGE) % kh
    s = ts_hash_reference(x0, y1, seed, ROLE_HEDGE) % kh
    w = ts_hash_reference(x0, y0, seed, ROLE_VEDGE) % kv
    e = ts_hash_reference(x1, y0, seed, ROLE_VEDGE) % kv
    return scheme.index((n, e, s, w), v)


# ------------------------------------------------------------------------------------------ Rust kernels
def ts_hash(x: Any, y: Any, seed: int, role: int) -> np.ndarray:
    """``ts_hash`` of every element pair of ``x``, ``y`` (int arrays or ints in [-2^31, 2^31), broadcast):
    uint32 array of the broadcast shape."""
    seed = hash_seed(seed)
    role = _int(role, "role", 0, _M32)
    xa, ya = asarray_aligned(x), asarray_aligned(y)
    for name, a in (("x", xa), ("y", ya)):
        # an empty bool or float array is a harmless empty list; complex, strings, objects never (numpy warns
        # or fails casting them even when empty)
        if a.dtype.kind not in "iu" and (a.size or a.dtype.kind not in "bf"):
            raise ParameterError(f"{name} has dtype {a.dtype}, expected integers")
        if a.size and (int(a.min()) < _I32_MIN or int(a.max()) > _I32_MAX):
            raise ParameterError(f"{name} has values in [{a.min()}, {a.max()}], expected int32 coordinates")
    xb, yb = np.broadcast_arrays(xa, ya)
    shape = xb.shape
    xs = np.ascontiguousarray(xb.reshape(-1), dtype=np.int32)
    ys = np.ascontiguousarray(yb.reshape(-1), dtype=np.int32)
    return _core.ts_hash(xs, ys, seed, role).reshape(shape)


def _wrap_arg(wrap: Any) -> tuple[int, int] | None:
    if wrap is None:
        return None
    tx, ty = _pair(wrap, "wrap")
    return _int(tx, "wrap", 1, _M32), _int(ty, "wrap", 1, _M32)


def index_map(
    scheme: LookupScheme,
    seed: int,
    size: tuple[int, int],
    origin: tuple[int, int] = (0, 0),
    wrap: tuple[int, int] | None = None,
    threads: int | None = None,
) -> np.ndarray:
    """int32 ``(rows, cols)`` tile indices of the cells ``origin + [0, cols) × [0, rows)``.

    ``size = (cols, rows)``, ``origin = (cx0, cy0)`` in cells (int32), ``wrap = (Tx, Ty)`` cells or None. Equal
    to the same window of any larger map; time proportional to the window.
    """
    if not isinstance(scheme, LookupScheme):
        raise TypeError(f"scheme is a {type(scheme).__name__}, expected a LookupScheme")
    seed = hash_seed(seed)
    cols, rows = _pair(size, "size")
    cols, rows = _int(cols, "size", 0), _int(rows, "size", 0)
    if cols * rows > MAX_MAP_CELLS or max(cols, rows) > MAX_MAP_CELLS:
        # each side too: (0, 2**63 - 1) has no cells, but numpy cannot make that shape (it crashed the process)
        raise ParameterError(
            f"size = ({cols}, {rows}): more than {MAX_MAP_CELLS} cells in one index map, or a side longer than that"
        )
    cx, cy = _pair(origin, "origin")
    cx, cy = _int(cx, "origin", _I32_MIN, _I32_MAX), _int(cy, "origin", _I32_MIN, _I32_MAX)
    return _core.hashed_index_map(
        scheme.kind,
        list(scheme.colours),
        scheme.variants,
        seed,
        (cx, cy),
        (cols, rows),
        _wrap_arg(wrap),
        threads_arg(threads),
    )


def window_cells(
    origin: tuple[int, int], width: int, height: int, tile_size: int
) -> tuple[int, int, int, int, int, int]:
    """The cells a pixel window needs: ``(cx0, cy0, cols, rows, ox, oy)`` for the window of ``width`` x
    ``height`` pixels whose top-left pixel is ``origin = (x0, y0)`` (floor division, negative included);
    ``(ox, oy)`` is the window's offset into cell (cx0, cy0)."""
    x0, y0 = _pair(origin, "origin")
    x0, y0 = _int(x0, "origin"), _int(y0, "origin")
    n = int(tile_size)
    cx0, ox = divmod(x0, n)
    cy0, oy = divmod(y0, n)
    cols = -(-(ox + int(width)) // n)
    rows = -(-(oy + int(height)) // n)
    for c in (cx0, cy0):
        if not _I32_MIN <= c <= _I32_MAX:
            raise ParameterError(
                f"origin = ({x0}, {y0}): the origin cell ({cx0}, {cy0}) must be int32 (|origin| < 2^31 tiles)"
            )
    return cx0, cy0, cols, rows, ox, oy


# ------------------------------------------------------------------------------------------ synthesis
def hashed_scheme(
    tileset: Any, origin: Any = (0, 0), wrap: Any = False, index_map: Any = None
) -> LookupScheme | None:
    """The scheme :func:`tilesynth.synthesize` hashes ``tileset`` with, or None for the scan-line tiler.

    Complete sets (:func:`lookup_scheme`) are hashed unless an explicit ``index_map`` is
    given. Any other set with ``origin != (0, 0)`` or ``wrap`` is a :class:`ParameterError`: the scan-line
    tiler of the papers' sets (4 .. 32, B, N1, N2) decides every cell from its left and upper neighbours, so it
    has no random access and cannot close a period.
    """
    x0, y0 = _pair(origin, "origin")
    o = (_int(x0, "origin"), _int(y0, "origin"))
    if not isinstance(wrap, (bool, np.bool_)):
        raise ParameterError(f"wrap = {wrap!r}: must be True or False")
    scheme = lookup_scheme(tileset.definition)
    special = o != (0, 0) or bool(wrap)
    if scheme is None:
        if special:
            raise ParameterError(
                f"origin = {o}, wrap = {bool(wrap)}: tile set {tileset.params.get('set', '?')!r} is not complete, so "
                "it is laid by the scan-line tiler, which has no random access and no periodic mode. Build a "
                "complete set (--set c3x2, c4, wc2; see tilesynth.layouts.complete) for origin and wrap"
            )
        return None
    if index_map is not None:
        if special:
            raise ParameterError("index_map with origin or wrap: give one (the hashed lookup makes the map)")
        return None
    return scheme


def synthesize_hashed(
    tileset: Any,
    scheme: LookupScheme,
    width: int,
    height: int,
    seed: Any,
    origin: tuple[int, int],
    wrap: bool,
    atlas: np.ndarray,
    out: np.ndarray,
    threads: int | None,
    copy: Any = None,
) -> np.ndarray:
    """Fill ``out`` with the window of the hashed tiling whose top-left pixel is ``origin = (x0, y0)``;
    returns the index map of the cells the window touches (its first cell is ``floor(origin / N)``).

    Called by :func:`tilesynth.synthesize` (which validates sizes, dtype and ``out``). ``wrap``: the output is
    periodic with its own size (which must be a multiple of the tile size N, in both directions), so that it
    tiles on a REPEAT sampler; the vertex (edge) colours and variants repeat every ``(width/N, height/N)``
    cells. Time is proportional to the window (the hash is evaluated for its cells only, the copy is the
    row-slice copy of :func:`tilesynth.base.kernels.tile_copy`).
    """
    n = tileset.tile_size
    seed = hash_seed(seed)
    period = None
    if wrap:
        if width % n or height % n:
            raise ParameterError(
                f"wrap: the output {width}x{height} must be a multiple of the tile size {n} in both directions "
                f"to be periodic (e.g. {max(n, width // n * n)}x{max(n, height // n * n)})"
            )
        period = (width // n, height // n)
    cx0, cy0, cols, rows, ox, oy = window_cells(origin, width, height, n)
    imap = index_map(scheme, seed, (cols, rows), (cx0, cy0), period, threads)
    if imap.size and int(imap.max()) >= tileset.n_tiles:
        raise ParameterError(f"tile set has {tileset.n_tiles} tiles, its definition {scheme.n_tiles}")
    if copy is not None:  # a set stored as provenance: gathered from the exemplar, the same bytes
        copy(imap, (oy, ox), out)
    else:
        _core.tile_copy_window(atlas, imap, (oy, ox), out, threads_arg(threads))
    return imap


def lookup_scheme(defn: Any) -> LookupScheme | None:
    """The hashed-lookup scheme of a tile-set definition if it is complete and in the spec's index order
    (whatever its name), else None (the scan-line tiler's sets)."""
    if hasattr(defn, "colours") and hasattr(defn, "variants") and not hasattr(defn, "horizontal"):  # a corner
        # set (duck-typed: no import; edge sets have variants too)
        k = len(defn.colours)
        n = len(defn)
        if k < 1 or n % (k**4) != 0:
            return None
        v = n // k**4
        index = {c: i for i, c in enumerate(defn.colours)}
        scheme = LookupScheme("corner", (k,), v)
        for j, (t, var) in enumerate(zip(defn.tiles, defn.variants)):
            if var != j % v or scheme.index(tuple(index[c] for c in t), var) != j:  # type: ignore[arg-type]
                return None
        return scheme
    if hasattr(defn, "horizontal") and hasattr(defn, "vertical"):  # an edge set
        kh, kv = len(defn.horizontal), len(defn.vertical)
        n = len(defn)
        if n % (kh * kh * kv * kv) != 0:
            return None
        v = n // (kh * kh * kv * kv)
        variants = getattr(defn, "variants", None) or (0,) * n  # edge sets have variants too
        hi = {c: i for i, c in enumerate(defn.horizontal)}
        vi = {c: i for i, c in enumerate(defn.vertical)}
        scheme = LookupScheme("edge", (kh, kv), v)
        for j, ((n_, e, s, w), var) in enumerate(zip(defn.tiles, variants)):
            if var != j % v or scheme.index((hi[n_], vi[e], hi[s], vi[w]), var) != j:
                return None
        return scheme
    return None
