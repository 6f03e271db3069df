"""Typed wrappers around the Rust kernels of :mod:`tilesynth._core`.

Each function validates and converts its inputs (C-contiguous arrays of the one dtype the kernel accepts),
releases the GIL inside the kernel and returns numpy arrays. ``threads=None`` uses ``TILESYNTH_NUM_THREADS`` or
all cores; results never depend on the thread count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from ._validate import as_image, positive_int
from .errors import ParameterError, ShapeError

DEFAULT_EPS = 1e-6
"""Epsilon in the denominator of the Kwatra edge weight (guards flat regions)."""

DEFAULT_POISSON_TOL = 1e-6
"""Default relative residual ‖b − A f‖₂ / ‖b‖₂ at which :func:`poisson_smooth` stops."""


def _templates(templates: np.ndarray, name: str = "templates") -> tuple[np.ndarray, bool]:
    t = np.asarray(templates)
    single = t.ndim in (2, 3)
    if t.ndim == 2:
        t = t[:, :, None]
    if single:
        t = t[None]
    if t.ndim != 4:
        raise ShapeError(f"{name} has shape {np.shape(templates)}, expected (h, w, C) or (K, h, w, C)")
    t = np.stack([as_image(x, name) for x in t]) if t.dtype != np.float32 else np.ascontiguousarray(t)
    return t, single


def _mask(mask: np.ndarray | None) -> np.ndarray | None:
    return None if mask is None else np.ascontiguousarray(mask, dtype=bool)


class SsdIndex:
    """Exhaustive SSD against one image, with everything that depends only on the image cached.

    Building the index computes the image's per-channel spectra (FFT size = image size, which is exact for
    fully-overlapping translations), the spectrum of Σ_c I_c² and an integral image of it; each template then
    costs one forward FFT of its non-zero rows per channel, a multiply-accumulate in the frequency domain and one
    partial inverse FFT. Build it once and match many templates (the ω construction does).

    ``map[ty, tx] = Σ_{y,x,c} m(y,x) (T[y,x,c] − I[ty+y, tx+x, c])²``; the map is accurate to ~1e-9 of its
    largest value (float64 FFTs), and :meth:`best_matches` re-ranks every candidate within the FFT's error bound
    by a direct float64 sum, so its order and values are exact.
    """

    def __init__(self, image: np.ndarray, threads: int | None = None) -> None:
        self.image = as_image(image)
        self._index = _core.SsdIndex(self.image, threads)

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(H, W, C)`` of the indexed image."""
        return self._index.shape

    def ssd(self, templates: np.ndarray, mask: np.ndarray | None = None, threads: int | None = None) -> np.ndarray:
        """SSD map(s): float32 ``(H-h+1, W-w+1)`` for a ``(h, w, C)`` template, ``(K, ...)`` for a stack.

        ``mask``: optional ``(h, w)`` bool, True where a template pixel counts.
        """
        t, single = _templates(templates)
        maps = self._index.ssd_maps(t, _mask(mask), threads)
        return maps[0] if single else maps

    def best_matches(
        self,
        templates: np.ndarray,
        k: int = 1,
        exclude_radius: int = 0,
        mask: np.ndarray | None = None,
        threads: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` best translations of each template with exact float64 SSD values, best first.

        Ties go to the smaller (row, col). After the first, each match lies more than ``exclude_radius`` pixels
        (Chebyshev) from those already chosen. Returns int64 offsets ``(K, k, 2)`` (top-left row, col) and float64
        values ``(K, k)``, or ``(k, 2)`` and ``(k,)`` for a single template; fewer than ``k`` columns when the
        image has fewer admissible translations.
        """
        t, single = _templates(templates)
        offsets, values = self._index.best_matches(t, int(k), int(exclude_radius), _mask(mask), threads)
        return (offsets[0], values[0]) if single else (offsets, values)


def patch_ssd(
    image: np.ndarray,
    templates: np.ndarray,
    mask: np.ndarray | None = None,
    threads: int | None = None,
) -> np.ndarray:
    """Exhaustive SSD of template(s) over every fully-overlapping translation of ``image``.

    One-shot form of :meth:`SsdIndex.ssd` (builds the image's index, then matches all templates against it).

    Parameters
    ----------
    image : (H, W, C) image.
    templates : (h, w, C) or (K, h, w, C), same C.
    mask : optional (h, w) bool, True where a template pixel counts.

    Returns
    -------
    float32 ``(H-h+1, W-w+1)``, or ``(K, H-h+1, W-w+1)`` for a stack of templates.
    """
    return SsdIndex(image, threads).ssd(templates, mask, threads)


def best_matches(
    image: np.ndarray,
    templates: np.ndarray,
    k: int = 1,
    exclude_radius: int = 0,
    mask: np.ndarray | None = None,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """One-shot form of :meth:`SsdIndex.best_matches`: the ``k`` best translations with exact SSD values.

    Returns
    -------
    offsets : int64 ``(K, k, 2)`` (row, col) of the top-left corner; ``(k, 2)`` for a single template.
    ssd : float64 ``(K, k)``; ``(k,)`` for a single template.
    """
    return SsdIndex(image, threads).best_matches(templates, k, exclude_radius, mask, threads)


def grid_mincut(
    wx: np.ndarray,
    wy: np.ndarray,
    source: np.ndarray,
    sink: np.ndarray,
    source_cap: np.ndarray | None = None,
    sink_cap: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """Minimum cut of a 4-connected ``(H, W)`` pixel grid (Boykov–Kolmogorov max-flow).

    ``wx[y, x]`` is the capacity of edge (y,x)–(y,x+1) and ``wy[y, x]`` of (y,x)–(y+1,x) (both directions;
    the last column / row is ignored). ``source`` / ``sink`` are bool masks of pixels tied to a terminal with
    infinite capacity; ``source_cap`` / ``sink_cap`` optional finite t-link capacities.

    Returns ``(labels, flow)``: bool ``(H, W)``, True on the sink side, and the max-flow value (= the cut cost).
    """

    def f64(a: np.ndarray | None) -> np.ndarray | None:
        return None if a is None else np.ascontiguousarray(a, dtype=np.float64)

    return _core.grid_mincut(
        f64(wx),
        f64(wy),
        np.ascontiguousarray(source, dtype=bool),
        np.ascontiguousarray(sink, dtype=bool),
        f64(source_cap),
        f64(sink_cap),
    )


def _grad(g: np.ndarray | None) -> np.ndarray | None:
    return None if g is None else np.ascontiguousarray(g, dtype=np.float64)


def kwatra_weights(
    a: np.ndarray,
    b: np.ndarray,
    region: np.ndarray | None = None,
    eps: float = DEFAULT_EPS,
    a_grad: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Kwatra et al.'s gradient-normalised seam weights between images ``a`` (kept) and ``b`` (inserted).

    ``w(s,t) = (‖a(s)−b(s)‖ + ‖a(t)−b(t)‖) / (‖g_a(s)‖ + ‖g_a(t)‖ + ‖g_b(s)‖ + ‖g_b(t)‖ + eps)`` with g the
    forward difference along s→t (0 past the image edge). Returns ``(wx, wy)``, float64 ``(H, W)``: ``wx[y, x]``
    weights edge (y,x)–(y,x+1), ``wy[y, x]`` edge (y,x)–(y+1,x); edges with both ends outside ``region`` get 0.
    ``a_grad`` (``(H, W, 2)``: ‖g_a‖ along x, along y) replaces the gradients of ``a`` (see :mod:`tilesynth.omega`).
    """
    return _core.kwatra_weights(as_image(a, "a"), as_image(b, "b"), _mask(region), float(eps), _grad(a_grad))


def omega_cuts(
    intermediate: np.ndarray,
    matching: np.ndarray,
    eps: float = DEFAULT_EPS,
    threads: int | None = None,
    intermediate_grad: np.ndarray | None = None,
    keep_border: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """ω cutting curves for a stack of intermediate tiles and their matching patches, ``(K, N, N, C)`` each.

    Sources are the pixels outside the inscribed circle, sinks the two central rows and columns inside it (with
    ``keep_border``, the default, the one-pixel border ring is a source too and its cross pixels are not sinks,
    so the matching patch never reaches the tile border; ``keep_border=False`` is 002's literal definition, the
    one of the reference data ``mincut80.npz``), edge
    weights those of :func:`kwatra_weights`; ``intermediate_grad`` (``(K, N, N, 2)``) optionally replaces the
    gradients of the intermediate tiles. Returns bool masks ``(K, N, N)`` (True = the pixel takes the matching
    patch) and the float64 cut costs (= max-flow values).
    """
    i, _ = _templates(intermediate, "intermediate")
    o, _ = _templates(matching, "matching")
    return _core.omega_cuts(i, o, float(eps), threads, _grad(intermediate_grad), bool(keep_border))


def tile_copy(atlas: np.ndarray, index_map: np.ndarray, out: np.ndarray, threads: int | None = None) -> np.ndarray:
    """Fill ``out`` ``(H, W, C)`` with tiles of ``atlas`` ``(K, th, tw, C)`` laid out by ``index_map``.

    ``atlas`` and ``out`` must share a dtype (uint8, uint16 or float32) and ``out`` must be C-contiguous; the map
    may cover more than ``out`` (cropped). Returns ``out``.
    """
    _core.tile_copy(
        np.ascontiguousarray(atlas), np.ascontiguousarray(index_map, dtype=np.int32), out, threads
    )
    return out


def _float_tiles(value: object, name: str) -> np.ndarray:
    """``value`` as C-contiguous float32: floats as they are (any finite values; the kernel checks), uint8 /
    uint16 scaled by their maximum, bool as 0 / 1."""
    a = np.asarray(value)
    if a.dtype == np.uint8:
        a = a.astype(np.float32) / np.float32(255)
    elif a.dtype == np.uint16:
        a = a.astype(np.float32) / np.float32(65535)
    elif a.dtype == np.bool_:
        a = a.astype(np.float32)
    elif a.dtype in (np.float16, np.float32, np.float64):
        a = a.astype(np.float32, copy=False)
    else:
        raise TypeError(f"{name} has dtype {a.dtype}, expected float, uint8, uint16 or bool")
    return np.ascontiguousarray(a)


@dataclass(frozen=True)
class PoissonInfo:
    """What :func:`poisson_smooth` did, per tile (scalars / ``(C,)`` for a single tile, arrays for a stack).

    Attributes
    ----------
    iterations : PCG iterations, the largest over the channels (0 when nothing had to be solved); int or int64
        ``(K,)``.
    residual : the final relative residual ‖b − A f‖₂ / ‖b‖₂ of each channel, recomputed from the float64
        solution (≤ ``tol``; 0 for an empty or whole-image region and for a channel with b = 0); float64 ``(C,)``
        or ``(K, C)``.
    unknowns : the number of region pixels; int or int64 ``(K,)``.
    """

    iterations: int | np.ndarray
    residual: np.ndarray
    unknowns: int | np.ndarray


def poisson_smooth(
    dst: np.ndarray,
    src: np.ndarray,
    region: np.ndarray,
    threads: int | None = None,
    tol: float = DEFAULT_POISSON_TOL,
    *,
    info: bool = False,
) -> np.ndarray | tuple[np.ndarray, PoissonInfo]:
    """Poisson smoothing of the region of a tile: guided interpolation (Pérez, Gangnet and Blake 2003).

    ``dst`` is the destination (the intermediate tile I of an ω-tile), ``src`` the source whose gradients guide
    the interpolation (the matching patch O), ``region`` the unknown pixels Ω (inside the cutting curve). For every
    pixel p of Ω and every channel, the result f solves the discrete Poisson equation with guidance field
    v_pq = src_p − src_q (Pérez eqs. (7)–(11))::

        Σ_{q ∈ N(p)} (f_p − f_q) = Σ_{q ∈ N(p)} (src_p − src_q),   f_q = dst_q for q ∉ Ω,

    N(p) the 4-neighbours of p inside the image. Outside Ω the result is ``dst``, bit for bit: the pixels of
    ``dst`` next to Ω are the Dirichlet boundary, so the tile border (never in an ω region) is untouched and
    ω-tiles stay seamless with each other.

    - Where Ω touches the image border, the missing neighbours are simply absent: a zero-normal-derivative
      (Neumann) condition on ``f − src`` there.
    - Ω covering the whole image has no Dirichlet pixel and f is determined only up to a constant: the result is
      ``src`` (the solution with the mean of ``src``). An empty Ω returns ``dst``.
    - The result is **not clipped** to [0, 1]: guided interpolation can overshoot near strong seams, and the
      result is the exact solution (clip it before storing it as an image).

    Solver: conjugate gradients in float64 on f − src (initial guess f = src), preconditioned by one symmetric
    geometric-multigrid V-cycle (float32, red-black Gauss–Seidel, the pixels outside Ω held fixed) per
    iteration; each channel stops once its true relative residual ‖b − A f‖₂ / ‖b‖₂ is at most ``tol`` (about
    8–10 iterations at 1e-6 for ω regions), which is reported. Rounding the solution to float32 adds at most half
    an ulp per pixel. Channels and tiles are solved in parallel; the result does not depend on ``threads``.

    Parameters
    ----------
    dst, src : a tile ``(N, M, C)`` or a stack ``(K, N, M, C)``: float (converted to float32, any finite
        values), or uint8 / uint16 (scaled to [0, 1]).
    region : bool ``(N, M)`` or ``(K, N, M)`` (integers: nonzero = unknown); its number of axes decides
        between one tile and a stack.
    threads : worker threads (None: ``TILESYNTH_NUM_THREADS`` or all cores).
    tol : the relative residual to reach, in [1e-12, 1).
    info : also return a :class:`PoissonInfo`.

    Returns
    -------
    The smoothed float32 tile(s), shaped like ``dst``; with ``info=True``, ``(tiles, PoissonInfo)``. The inputs are
    never modified.
    """
    r = np.asarray(region)
    if r.dtype != np.bool_:
        if not np.issubdtype(r.dtype, np.integer):
            raise TypeError(f"region has dtype {r.dtype}, expected bool (or integers, nonzero = unknown)")
        r = r != 0
    if r.ndim not in (2, 3):
        raise ShapeError(f"region has shape {r.shape}, expected (N, M) or (K, N, M)")
    single = r.ndim == 2
    d = _float_tiles(dst, "dst")
    s = _float_tiles(src, "src")
    if d.ndim != r.ndim + 1 or d.shape[:-1] != r.shape:
        raise ShapeError(f"dst has shape {d.shape}, expected {r.shape} + (C,) (the shape of region, then channels)")
    if s.shape != d.shape:
        raise ShapeError(f"src has shape {s.shape}, expected {d.shape} (the shape of dst)")
    if isinstance(tol, (bool, np.bool_)) or not isinstance(tol, (int, float, np.integer, np.floating)):
        raise ParameterError(f"tol = {tol!r}: must be a number in [1e-12, 1)")
    r = np.ascontiguousarray(r)
    if single:
        d, s, r = d[None], s[None], r[None]
    out, iterations, residual, unknowns = _core.poisson_smooth(d, s, r, float(tol), threads)
    if single:
        out = out[0]
    if not info:
        return out
    if single:
        return out, PoissonInfo(int(iterations[0]), residual[0], int(unknowns[0]))
    return out, PoissonInfo(iterations, residual, unknowns)


def _int_array(value: object, name: str, ndim: int, shape_text: str) -> np.ndarray:
    a = np.asarray(value)
    if a.ndim != ndim:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape_text}")
    if a.size and not (np.issubdtype(a.dtype, np.integer) or a.dtype == np.bool_):
        raise ParameterError(f"{name} has dtype {a.dtype}, expected integers")
    return np.ascontiguousarray(a, dtype=np.int64)


class PopulationEvaluator:
    """The ω-tile objective E for whole populations of gene vectors, exact, with cached partial SSD maps.

    A gene vector holds ``n_patches`` top-left positions (row, col) of ``tile_size`` x ``tile_size`` patches of the
    exemplar; ``tile_patches`` ``(m, 4)`` names each tile's ⟨TL, BL, TR, BR⟩ patch by gene index. Intermediate
    tile T_j is assembled as in :func:`tilesynth.omega.intermediate_tiles` (TL quadrant = bottom-right quarter of
    the TL patch, BL = top-right quarter of the BL patch, TR = bottom-left quarter of the TR patch, BR = top-left
    quarter of the BR patch), and

    - C_j(t) = Σ_p Σ_c (T_j(p) − I(p + t))² over every translation t in [0, H−N] x [0, W−N],
      divided by N·N when ``normalise`` (paper 003);
    - D_j = min_t C_j(t);
    - E = λ·Σ_j D_j + (1−λ)·Var(D_1..D_m), population variance (papers 000, 003), λ = ``lam``.

    **Exact.** The SSD is additive over the four quadrants; each quadrant's SSD map over all translations (a
    *partial map* of one (patch position, role) pair) comes from the float64 FFT kernel with a rigorous error
    bound. Every translation whose summed FFT value lies within the summed bound of the minimum is re-evaluated
    by the direct float64 sum over the assembled tile, so D_j is the exact minimum (the same value as
    :meth:`SsdIndex.best_matches` gives, up to float64 summation order), never an FFT approximation.

    **Cache.** Partial maps are kept across calls, keyed by (row, col, role), least recently used dropped first
    once they exceed ``cache_bytes`` (0 keeps nothing): a GA or AIS that changes a few genes per generation pays
    four FFT maps per new position, and only sums and minima for the rest. Results never depend on the cache
    contents nor on ``threads``. :meth:`cache_stats` reports entries, bytes, limit, hits and misses.

    Positions need not be distinct here (checking that is the caller's business).
    """

    def __init__(
        self,
        exemplar: np.ndarray,
        tile_size: int,
        tile_patches: np.ndarray,
        n_patches: int,
        lam: float = 0.8,
        normalise: bool = False,
        cache_bytes: int = 256 << 20,
    ) -> None:
        self.exemplar = as_image(exemplar, "exemplar")
        self.tile_patches = _int_array(tile_patches, "tile_patches", 2, "(m, 4)")
        tile_size = positive_int(tile_size, "tile_size")
        n_patches = positive_int(n_patches, "n_patches")
        cache_bytes = positive_int(cache_bytes, "cache_bytes", minimum=0)
        if isinstance(lam, (bool, np.bool_)) or not isinstance(lam, (int, float, np.integer, np.floating)):
            raise ParameterError(f"lam = {lam!r}: must be a number in [0, 1]")
        self.lam = float(lam)
        self.normalise = bool(normalise)
        self._ev = _core.PopulationEvaluator(
            self.exemplar, tile_size, self.tile_patches, n_patches, self.lam, self.normalise, cache_bytes
        )
        self.tile_size, self.n_patches, self.n_tiles = self._ev.dims

    def evaluate(self, genes: np.ndarray, threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """E and D of a population ``genes`` ``(P, n_patches, 2)`` (integer top-left row, col of every patch).

        Returns float64 ``E`` ``(P,)`` and ``D`` ``(P, m)``.
        """
        g = _int_array(genes, "genes", 3, f"(P, {self.n_patches}, 2)")
        return self._ev.evaluate(g, threads)

    def cache_stats(self) -> dict[str, int]:
        """Partial-map cache counters: ``entries``, ``bytes``, ``limit``, ``hits``, ``misses``."""
        return self._ev.cache_stats()

    def clear_cache(self) -> None:
        """Drop every cached partial map (the counters are kept)."""
        self._ev.clear_cache()


def evaluate_population(
    exemplar: np.ndarray,
    genes: np.ndarray,
    tile_patches: np.ndarray,
    tile_size: int,
    lam: float = 0.8,
    normalise: bool = False,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """One-shot form of :class:`PopulationEvaluator`: ``(E, D)`` of ``genes`` ``(P, n, 2)``.

    ``n`` is taken from ``genes``; nothing is cached between calls (build a :class:`PopulationEvaluator` to
    evaluate many generations).
    """
    g = _int_array(genes, "genes", 3, "(P, n, 2)")
    if g.shape[1] < 1:
        raise ShapeError(f"genes has shape {g.shape}, expected (P, n, 2) with n >= 1")
    ev = PopulationEvaluator(exemplar, tile_size, tile_patches, g.shape[1], lam, normalise, cache_bytes=0)
    return ev.evaluate(g, threads)


__all__ = [
    "DEFAULT_EPS",
    "DEFAULT_POISSON_TOL",
    "PoissonInfo",
    "PopulationEvaluator",
    "SsdIndex",
    "best_matches",
    "evaluate_population",
    "grid_mincut",
    "kwatra_weights",
    "omega_cuts",
    "patch_ssd",
    "poisson_smooth",
    "tile_copy",
]
