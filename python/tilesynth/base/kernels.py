"""Typed wrappers around the Rust kernels of :mod:`tilesynth._core`.

Each function validates and converts its inputs (C-contiguous, native-endian arrays of the one dtype the
kernel accepts; images by :func:`tilesynth.base.validate.as_image`), releases the GIL inside the kernel and returns
new numpy arrays; no input is ever modified (``tile_copy`` writes only into ``out``). Bad input raises
:class:`ShapeError` / :class:`ParameterError` (``ValueError``) or ``TypeError`` naming the parameter.
``threads=None`` uses ``TILESYNTH_NUM_THREADS`` or all cores (at most 1024); results never depend on the thread
count.

The Poisson solver and the Wang kernels have their own modules (:mod:`tilesynth.base.poisson`,
:mod:`tilesynth.base.wang_kernels`), the shared argument conversions :mod:`tilesynth.base.kernel_args`; this
module re-exports them.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from ..errors import ParameterError, ShapeError
from .kernel_args import DEFAULT_EPS, _asarray, _grad, _index_map, _int_array, _mask, _real, _templates
from .poisson import DEFAULT_POISSON_TOL, PoissonInfo, poisson_smooth
from .validate import (
    as_features,
    as_image,
    finite_float,
    nonneg_int,
    positive_int,
    threads_arg,
)
from .wang_kernels import WangEvaluator, swang_cuts, wang_tiles


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

    def __init__(self, image: np.ndarray, threads: int | None = None, features: bool = False) -> None:
        # features=True: any channel count and finite values (e.g. the eq. 3 augmented exemplar)
        self.features = bool(features)
        self.image = as_features(image) if self.features else as_image(image)
        self._index = _core.SsdIndex(self.image, threads_arg(threads))

    def __reduce__(self):  # noqa: ANN204 - pickles by rebuilding from the image (process pools)
        return (type(self), (self.image, None, self.features))

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(H, W, C)`` of the indexed image."""
        return self._index.shape

    def ssd(
        self, templates: np.ndarray, mask: np.ndarray | None = None, threads: int | None = None
    ) -> np.ndarray:
        """SSD map(s): float32 ``(H-h+1, W-w+1)`` for a ``(h, w, C)`` template, ``(K, ...)`` for a stack.

        ``mask``: optional ``(h, w)`` bool, True where a template pixel counts.
        """
        t, single = _templates(templates, features=self.features)
        maps = self._index.ssd_maps(t, _mask(mask), threads_arg(threads))
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
        t, single = _templates(templates, features=self.features)
        k, r = nonneg_int(k, "k"), nonneg_int(exclude_radius, "exclude_radius")
        m, th = _mask(mask), threads_arg(threads)
        if t.shape[0] <= 1:
            offsets, values = self._index.best_matches(t, k, r, m, th)
            return (offsets[0], values[0]) if single else (offsets, values)
        return _best_matches_in_chunks(self._index, t, k, r, m, th)


QUADRANT_SHARE = 2
""":meth:`SsdIndex.best_matches` sums quadrant maps when the templates have at least this many times fewer
distinct quadrants than quadrants (intermediate tiles: 20 distinct of the 2500 quadrants of a c5 set's 625)."""


def _shared_quadrants(t: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(quads (Q, h/2, w/2, C), assign (K, 4))``: the distinct quadrants of the templates ``t`` ``(K, h, w, C)``
    and each template's TL, TR, BL, BR among them, when they share enough (:data:`QUADRANT_SHARE`); else None.

    Why: the ω builders' intermediate tiles are made of the quadrants of a few sample patches, and the SSD of a
    template is the sum of its quadrants' SSDs, so :func:`tilesynth._core.best_matches_quadrants` needs one FFT
    map per distinct quadrant instead of one per template (the matching stage of a default 2048² build was
    ~90 s CPU for 625 transforms). Grouped by content digest; the Rust side checks every quadrant bit for bit.
    :func:`_best_matches_in_chunks` takes this path by itself (one quadrant map per call, then the templates
    in chunks, so that Ctrl-C stays prompt)."""
    import hashlib

    k, h, w, _ = t.shape
    if h % 2 or w % 2 or h < 2 or w < 2:
        return None
    hq, wq = h // 2, w // 2
    seen: dict[bytes, int] = {}
    firsts: list[tuple[int, int, int]] = []
    assign = np.empty((k, 4), np.int64)
    for u in range(k):
        for j, (y, x) in enumerate(((0, 0), (0, wq), (hq, 0), (hq, wq))):
            key = hashlib.sha1(np.ascontiguousarray(t[u, y : y + hq, x : x + wq]).tobytes()).digest()
            if key not in seen:
                if QUADRANT_SHARE * (len(seen) + 1) > 4 * k:
                    return None
                seen[key] = len(firsts)
                firsts.append((u, y, x))
            assign[u, j] = seen[key]
    quads = np.stack([t[u, y : y + hq, x : x + wq] for u, y, x in firsts])
    return np.ascontiguousarray(quads), assign


def _best_matches_in_chunks(index, t, k, r, mask, threads) -> tuple[np.ndarray, np.ndarray]:
    """``index.best_matches`` of the templates ``t`` ``(K, h, w, C)`` in consecutive chunks of about
    :data:`tilesynth.base.chunks.TARGET_SECONDS` x 5 each, so that Ctrl-C and SIGTERM take effect between two chunks
    instead of after the whole stack (which took 18 s for the 256 templates of a 1024² build). Each template's
    matches are computed independently, so the result is bit-identical to one call; the columns are cut to the
    fewest matches any template has, as the one call does."""
    import time

    from .chunks import TARGET_SECONDS

    n = t.shape[0]
    quads = _shared_quadrants(t) if mask is None and k > 0 else None
    if quads is None:
        match = lambda lo, hi: index.best_matches(t[lo:hi], k, r, mask, threads)  # noqa: E731
    else:  # one FFT per distinct quadrant, each its own call (the same exact results)
        q, assign = quads
        maps, bounds, maxes = None, [], []
        for i in range(q.shape[0]):  # filled in place: a stack of the returned maps would hold them twice
            m, bound, mx = _core.quadrant_map(index, q[i], threads)
            maps = np.empty((q.shape[0], *m.shape), np.float32) if maps is None else maps
            maps[i] = m
            bounds.append(bound)
            maxes.append(mx)
        match = (
            lambda lo, hi: _core.best_matches_quadrants(  # noqa: E731
                index, q, maps, bounds, maxes, t[lo:hi], assign[lo:hi], k, r, threads
            )
        )

    step = max(1, _core.resolve_threads(threads))  # the first chunk: one template per thread
    parts, start = [], 0
    while start < n:
        stop = min(n, start + step)
        t0 = time.perf_counter()
        parts.append(match(start, stop))
        dt = time.perf_counter() - t0
        if dt > 0:  # the next chunk aims at 5 x TARGET_SECONDS
            step = max(1, int(5 * TARGET_SECONDS * (stop - start) / dt))
        start = stop
    got = min(o.shape[1] for o, _ in parts)
    return (
        np.concatenate([o[:, :got] for o, _ in parts]),
        np.concatenate([v[:, :got] for _, v in parts]),
    )


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
    wd: np.ndarray | None = None,
    wa: np.ndarray | None = None,
) -> tuple[np.ndarray, float]:
    """Minimum cut of a 4-connected ``(H, W)`` pixel grid (Boykov–Kolmogorov max-flow), 8-connected with
    ``wd`` and ``wa``.

    ``wx[y, x]`` is the capacity of edge (y,x)–(y,x+1) and ``wy[y, x]`` of (y,x)–(y+1,x) (both directions;
    the last column / row is ignored). ``source`` / ``sink`` are bool masks of pixels tied to a terminal with
    infinite capacity; ``source_cap`` / ``sink_cap`` optional finite t-link capacities. ``wd[y, x]``
    (edge (y,x)–(y+1,x+1)) and ``wa[y, x]`` (edge (y,x)–(y+1,x−1)), given together, add the diagonal edges
    (the same BK solver on an 8-connected grid; last row ignored, and the last column of ``wd``, the first
    of ``wa``).

    Returns ``(labels, flow)``: bool ``(H, W)``, True on the sink side, and the max-flow value (= the cut cost).
    """

    def f64(a: np.ndarray | None, name: str) -> np.ndarray | None:
        return None if a is None else _real(a, name, 2, "(H, W)")

    terminals = (
        _mask(source, "source"),
        _mask(sink, "sink"),
        f64(source_cap, "source_cap"),
        f64(sink_cap, "sink_cap"),
    )
    if (wd is None) != (wa is None):
        missing = "wd" if wd is None else "wa"
        raise ParameterError(
            f"{missing} = None: wd and wa (the two diagonals) are given together or not at all"
        )
    if wd is None:
        return _core.grid_mincut(f64(wx, "wx"), f64(wy, "wy"), *terminals)
    return _core.grid_mincut8(f64(wx, "wx"), f64(wy, "wy"), f64(wd, "wd"), f64(wa, "wa"), *terminals)


def grid_mincuts(
    wx: np.ndarray,
    wy: np.ndarray,
    source: np.ndarray,
    sink: np.ndarray,
    sink_cap: np.ndarray | None = None,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`grid_mincut` of ``K`` grids at once, in parallel: ``wx``, ``wy`` (and ``sink_cap``) ``(K, H, W)``,
    one pair of hard masks ``(H, W)`` for all. Returns bool labels ``(K, H, W)`` (True on the sink side) and the
    ``K`` flows, each grid's exactly as :func:`grid_mincut` gives it, at any thread count."""
    return _core.grid_mincuts(
        _real(wx, "wx", 3, "(K, H, W)"),
        _real(wy, "wy", 3, "(K, H, W)"),
        _mask(source, "source"),
        _mask(sink, "sink"),
        None if sink_cap is None else _real(sink_cap, "sink_cap", 3, "(K, H, W)"),
        threads_arg(threads),
    )


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
    ``a_grad`` (``(H, W, 2)``: ‖g_a‖ along x, along y) replaces the gradients of ``a`` (see :mod:`tilesynth.builder.omega`).
    """
    return _core.kwatra_weights(
        as_image(a, "a"),
        as_image(b, "b"),
        _mask(region, "region"),
        finite_float(eps, "eps", positive=True),
        _grad(a_grad, "a_grad", 3, "(H, W, 2)"),
    )


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
    g = _grad(intermediate_grad, "intermediate_grad", 4, "(K, N, N, 2)")
    eps = finite_float(eps, "eps", positive=True)
    return _core.omega_cuts(i, o, eps, threads_arg(threads), g, bool(keep_border))


def edge_weight_sums(
    template: np.ndarray,
    image: np.ndarray,
    wx_mask: np.ndarray,
    wy_mask: np.ndarray,
    eps: float = DEFAULT_EPS,
    template_grad: np.ndarray | None = None,
    threads: int | None = None,
) -> np.ndarray:
    """For every translation t of ``image``, the sum of the Kwatra weights between ``template`` and the candidate
    ``image[t : t + template.shape[:2]]`` over the edges selected by ``wx_mask`` (edge (y,x)–(y,x+1)) and
    ``wy_mask`` (edge (y,x)–(y+1,x)), as :func:`kwatra_weights` would give them (candidate gradients 0 past its
    last row/column; ``template_grad`` ``(N, M, 2)`` optionally replaces the template's). Exact direct sums,
    parallel; float64 ``(H − N + 1, W − M + 1)``. The 002 candidate heuristics rank matching patches by it.
    """
    t = as_image(template, "template")
    return _core.edge_weight_sums(
        t,
        as_image(image, "image"),
        _mask(wx_mask),
        _mask(wy_mask),
        float(eps),
        _grad(template_grad, "template_grad", 3, "(N, M, 2)"),
        threads_arg(threads),
    )


def weighted_ssd_map(
    image: np.ndarray,
    image_grad: np.ndarray,
    template: np.ndarray,
    template_grad: np.ndarray,
    mu: float = 10.0,
    eps: float = 1e-6,
    threads: int | None = None,
) -> np.ndarray:
    """000's eq. 2 over every fully-overlapping translation t, by direct summation (no FFT applies):
    ``D(t) = Σ_p Σ_c (T(p,c) − I(p+t,c))² / (μ (g_T(p) + g_I(p+t)) + ε)``, with per-pixel gradient magnitudes
    ``image_grad`` ``(H, W)`` and ``template_grad`` ``(N, M)``. float64 ``(H − N + 1, W − M + 1)``."""
    return _core.weighted_ssd_map(
        as_image(image, "image"),
        _grad(image_grad, "image_grad", 2, "(H, W)"),
        as_image(template, "template"),
        _grad(template_grad, "template_grad", 2, "(N, M)"),
        float(mu),
        float(eps),
        threads_arg(threads),
    )


def tile_copy(
    atlas: np.ndarray, index_map: np.ndarray, out: np.ndarray, threads: int | None = None
) -> np.ndarray:
    """Fill ``out`` ``(H, W, C)`` with tiles of ``atlas`` ``(K, th, tw, C)`` laid out by ``index_map``.

    ``atlas`` and ``out`` must share a dtype (uint8, uint16, float32, or int32 for provenance maps), ``out`` must
    be a writable, C-contiguous array that does not overlap ``atlas``; the map may cover more than ``out``
    (cropped). Returns ``out``.
    """
    kinds = (np.uint8, np.uint16, np.float32, np.int32)
    a = _asarray(atlas, "atlas")
    if a.ndim != 4:
        raise ShapeError(f"atlas has shape {a.shape}, expected (K, th, tw, C)")
    if not isinstance(out, np.ndarray):
        raise TypeError(f"out is a {type(out).__name__}, expected a numpy array")
    if out.ndim != 3:
        raise ShapeError(f"out has shape {out.shape}, expected (H, W, C)")
    if a.dtype not in kinds or out.dtype != a.dtype or not out.dtype.isnative:
        raise TypeError(
            f"atlas has dtype {a.dtype} and out {out.dtype}: expected the same dtype, uint8, uint16, float32 or "
            "int32 (native byte order)"
        )
    if not out.flags.c_contiguous or not out.flags.writeable or not out.flags.aligned:
        raise TypeError("out: array must be C-contiguous, aligned and writeable")
    if np.may_share_memory(a, out):
        raise ParameterError("out: must not share memory with atlas")
    _core.tile_copy(
        np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("=")),
        _index_map(index_map),
        out,
        threads_arg(threads),
    )
    return out


class PopulationEvaluator:
    """The ω-tile objective E for whole populations of gene vectors, exact, with cached partial SSD maps.

    A gene vector holds ``n_patches`` top-left positions (row, col) of ``tile_size`` x ``tile_size`` patches of the
    exemplar; ``tile_patches`` ``(m, 4)`` names each tile's ⟨TL, BL, TR, BR⟩ patch by gene index. Intermediate
    tile T_j is assembled as in :func:`tilesynth.builder.omega.intermediate_tiles` (TL quadrant = bottom-right quarter of
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
        lam: float = _core.DEFAULT_LAMBDA,
        normalise: bool = False,
        cache_bytes: int = _core.DEFAULT_CACHE_BYTES,
        features: bool = False,
    ) -> None:
        # features=True: any channel count and finite values (e.g. the eq. 3 augmented exemplar)
        self.exemplar = as_features(exemplar, "exemplar") if features else as_image(exemplar, "exemplar")
        self.tile_patches = _int_array(tile_patches, "tile_patches", 2, "(m, 4)")
        tile_size = positive_int(tile_size, "tile_size")
        n_patches = positive_int(n_patches, "n_patches")
        cache_bytes = positive_int(cache_bytes, "cache_bytes", minimum=0)
        if isinstance(lam, (bool, np.bool_)) or not isinstance(lam, (int, float, np.integer, np.floating)):
            raise ParameterError(f"lam = {lam!r}: must be a number in [0, 1]")
        if not 0.0 <= float(lam) <= 1.0:
            raise ParameterError(f"lam = {lam!r}: must be a number in [0, 1]")
        self.lam = float(lam)
        self.normalise = bool(normalise)
        self._ev = _core.PopulationEvaluator(
            self.exemplar, tile_size, self.tile_patches, n_patches, self.lam, self.normalise, cache_bytes
        )
        self.tile_size, self.n_patches, self.n_tiles = self._ev.dims
        self._init_args = (
            self.exemplar,
            tile_size,
            self.tile_patches,
            n_patches,
            self.lam,
            self.normalise,
            cache_bytes,
            bool(features),
        )

    def __reduce__(self):  # noqa: ANN204 - pickles by rebuilding from its inputs, cache empty (process pools)
        return (type(self), self._init_args)

    def evaluate(self, genes: np.ndarray, threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """E and D of a population ``genes`` ``(P, n_patches, 2)`` (integer top-left row, col of every patch).

        Returns float64 ``E`` ``(P,)`` and ``D`` ``(P, m)``.
        """
        g = _int_array(genes, "genes", 3, f"(P, {self.n_patches}, 2)")
        return self._ev.evaluate(g, threads_arg(threads))

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
    lam: float = _core.DEFAULT_LAMBDA,
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
    "WangEvaluator",
    "SsdIndex",
    "best_matches",
    "edge_weight_sums",
    "evaluate_population",
    "grid_mincut",
    "grid_mincuts",
    "kwatra_weights",
    "omega_cuts",
    "patch_ssd",
    "swang_cuts",
    "poisson_smooth",
    "tile_copy",
    "weighted_ssd_map",
    "wang_tiles",
]
