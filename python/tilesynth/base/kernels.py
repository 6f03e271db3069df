"""Typed wrappers around the Rust kernels of :mod:`tilesynth._core`.

Each function validates and converts its inputs (C-contiguous, native-endian arrays of the one dtype the
kernel accepts; images by :func:`tilesynth.base.validate.as_image`), releases the GIL inside the kernel and returns
new numpy arrays; no input is ever modified (``tile_copy`` writes only into ``out``). Bad input raises
:class:`ShapeError` / :class:`ParameterError` (``ValueError``) or ``TypeError`` naming the parameter.
``threads=None`` uses ``TILESYNTH_NUM_THREADS`` or all cores (at most 1024); results never depend on the thread
count.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from ..errors import ParameterError, ShapeError
from .validate import (
    as_features,
    as_image,
    as_image_stack,
    asarray_aligned,
    finite_float,
    nonneg_int,
    positive_int,
    threads_arg,
)

DEFAULT_EPS: float = _core.DEFAULT_EPS
"""Epsilon in the denominator of the Kwatra edge weight (guards flat regions); defined in the core
(``rust/seams.rs``) and exported from there."""

DEFAULT_POISSON_TOL: float = _core.DEFAULT_POISSON_TOL
"""Default relative residual ‖b − A f‖₂ / ‖b‖₂ at which :func:`poisson_smooth` stops."""


def _templates(
    templates: np.ndarray, name: str = "templates", features: bool = False
) -> tuple[np.ndarray, bool]:
    if not features:
        return as_image_stack(templates, name)
    t = asarray_aligned(templates)
    single = t.ndim in (2, 3)
    if t.ndim == 2:
        t = t[:, :, None]
    if single:
        t = t[None]
    if t.ndim != 4:
        raise ShapeError(f"{name} has shape {np.shape(templates)}, expected (h, w, C) or (K, h, w, C)")
    return np.stack([as_features(x, name) for x in t]), single


def _asarray(value: object, name: str) -> np.ndarray:
    try:
        a = asarray_aligned(value)
    except (ValueError, TypeError) as exc:
        raise ShapeError(f"{name} is not an array ({exc})") from None
    return a


def _mask(mask: object, name: str = "mask") -> np.ndarray | None:
    """A bool ``(h, w)`` mask: bool arrays as they are, integer or float arrays only if every value is 0 or 1
    (anything else is more likely a weight map passed by mistake than a mask)."""
    if mask is None:
        return None
    m = _asarray(mask, name)
    if m.ndim != 2:
        raise ShapeError(f"{name} has shape {m.shape}, expected a 2-d (h, w) mask")
    if m.dtype != np.bool_:
        if m.dtype.kind not in "iuf":
            raise TypeError(f"{name} has dtype {m.dtype}, expected bool")
        if m.size and not np.isin(m, (0, 1)).all():
            raise ParameterError(
                f"{name} has dtype {m.dtype} with values other than 0 and 1, expected a bool mask"
            )
    return np.ascontiguousarray(m, dtype=bool)


def _real(value: object, name: str, ndim: int, shape_text: str) -> np.ndarray:
    """A C-contiguous float64 array of ``ndim`` dimensions from any real (bool, integer, float) input; the
    kernels check the values (finite, >= 0, ...)."""
    a = _asarray(value, name)
    if a.ndim != ndim:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape_text}")
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} has dtype {a.dtype}, expected real numbers (float64)")
    return np.ascontiguousarray(a, dtype=np.float64)


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

    def __reduce__(self):  # noqa: ANN204 - pickles by rebuilding from the image (issue 17)
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


def _best_matches_in_chunks(index, t, k, r, mask, threads) -> tuple[np.ndarray, np.ndarray]:
    """``index.best_matches`` of the templates ``t`` ``(K, h, w, C)`` in consecutive chunks of about
    :data:`tilesynth.base.chunks.TARGET_SECONDS` x 5 each, so that Ctrl-C and SIGTERM take effect between two chunks
    instead of after the whole stack (issue 16: 18 s for the 256 templates of a 1024² build). Each template's
    matches are computed independently, so the result is bit-identical to one call; the columns are cut to the
    fewest matches any template has, as the one call does."""
    import time

    from .chunks import TARGET_SECONDS

    n = t.shape[0]
    step = max(1, _core.resolve_threads(threads))  # the first chunk: one template per thread
    parts, start = [], 0
    while start < n:
        stop = min(n, start + step)
        t0 = time.perf_counter()
        parts.append(index.best_matches(t[start:stop], k, r, mask, threads))
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


def _grad(g: np.ndarray | None, name: str, ndim: int, shape_text: str) -> np.ndarray | None:
    return None if g is None else _real(g, name, ndim, shape_text)


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


def _index_map(value: object) -> np.ndarray:
    """An int32 ``(rows, cols)`` tile index map; integers only, none beyond the int32 range (no silent wrap)."""
    m = _asarray(value, "index_map")
    if m.ndim != 2:
        raise ShapeError(f"index_map has shape {m.shape}, expected (rows, cols)")
    if m.dtype.kind not in "iu":
        if m.size or m.dtype.kind not in "bf":
            raise TypeError(f"index_map has dtype {m.dtype}, expected integers")
    if m.size and m.dtype.kind in "iu" and m.dtype.itemsize >= 4:
        lo, hi = int(m.min()), int(m.max())
        if lo < -(2**31) or hi >= 2**31:
            raise ParameterError(f"index_map has values in [{lo}, {hi}], expected tile indices")
    return np.ascontiguousarray(m, dtype=np.int32)


def _float_tiles(value: object, name: str) -> np.ndarray:
    """``value`` as C-contiguous float32: floats as they are (any finite values; the kernel checks), uint8 /
    uint16 scaled by their maximum, bool as 0 / 1."""
    a = _asarray(value, name)
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
    r = _asarray(region, "region")
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
        raise ShapeError(
            f"dst has shape {d.shape}, expected {r.shape} + (C,) (the shape of region, then channels)"
        )
    if s.shape != d.shape:
        raise ShapeError(f"src has shape {s.shape}, expected {d.shape} (the shape of dst)")
    if isinstance(tol, (bool, np.bool_)) or not isinstance(tol, (int, float, np.integer, np.floating)):
        raise ParameterError(f"tol = {tol!r}: must be a number in [1e-12, 1)")
    r = np.ascontiguousarray(r)
    if single:
        d, s, r = d[None], s[None], r[None]
    out, iterations, residual, unknowns = _core.poisson_smooth(d, s, r, float(tol), threads_arg(threads))
    if single:
        out = out[0]
    if not info:
        return out
    if single:
        return out, PoissonInfo(int(iterations[0]), residual[0], int(unknowns[0]))
    return out, PoissonInfo(iterations, residual, unknowns)


def _int_array(value: object, name: str, ndim: int, shape_text: str) -> np.ndarray:
    a = _asarray(value, name)
    if a.ndim != ndim:
        raise ShapeError(f"{name} has shape {a.shape}, expected {shape_text}")
    if a.size and not (np.issubdtype(a.dtype, np.integer) or a.dtype == np.bool_):
        raise ParameterError(f"{name} has dtype {a.dtype}, expected integers")
    if a.size == 0 and a.dtype.kind not in "biuf":
        raise ParameterError(f"{name} has dtype {a.dtype}, expected integers")
    if a.size and a.dtype.kind == "u" and a.dtype.itemsize == 8 and int(a.max()) >= 2**63:
        raise ParameterError(f"{name} has values up to {int(a.max())}, beyond int64")
    return np.ascontiguousarray(a, dtype=np.int64)


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

    def __reduce__(self):  # noqa: ANN204 - pickles by rebuilding from its inputs, cache empty (issue 17)
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


def _wang_args(tile_size: int, overlap: int, corners: str, samples: str, cut: str, omega: float) -> tuple:
    tile_size = positive_int(tile_size, "tile_size")
    overlap = positive_int(overlap, "overlap", minimum=0)
    for name, value in (("corners", corners), ("samples", samples), ("cut", cut)):
        if not isinstance(value, str):
            raise ParameterError(f"{name} = {value!r}: must be a string")
    if isinstance(omega, (bool, np.bool_)) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise ParameterError(f"omega = {omega!r}: must be a number in [0, 1]")
    return tile_size, overlap, corners, samples, cut, float(omega)


def wang_tiles(
    exemplar: np.ndarray,
    genes: np.ndarray,
    tile_samples: np.ndarray,
    tile_size: int,
    overlap: int,
    corners: str = "free",
    samples: str = "diamond",
    cut: str = "dp",
    omega: float = _core.DEFAULT_OMEGA,
    eps: float = DEFAULT_EPS,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The cuts of Wang tiles (Cohen / Burke; geometry in :mod:`tilesynth.builder.wang`).

    ``genes`` ``(n, 2)``: top-left corners of the sample squares (side ``tile_size + overlap`` for free-corner
    diamonds, ``tile_size`` otherwise); ``tile_samples`` ``(K, 4)``: gene index of every tile's N, E, S, W
    sample. Returns uint8 labels ``(K, N, N)`` (0 N, 1 E, 2 S, 3 W: the sample each pixel takes) and float64
    ``(K, 4, 6)``: for the cuts NE, ES, SW, WN ``[D_overlap, n_overlap, D_path, n_path, D_boundary, cost]``.
    """
    args = _wang_args(tile_size, overlap, corners, samples, cut, omega)
    return _core.wang_tiles(
        as_image(exemplar, "exemplar"),
        _int_array(genes, "genes", 2, "(n, 2)"),
        _int_array(tile_samples, "tile_samples", 2, "(K, 4)"),
        *args,
        finite_float(eps, "eps", positive=True),
        threads_arg(threads),
    )


class WangEvaluator:
    """001's objective for whole populations of Wang gene vectors, in Rust, parallel, thread-count independent.

    For each individual (``n_samples`` top-left corners of sample squares), every distinct cut of the tile set
    is solved (DP or graph cut, see :mod:`tilesynth.builder.wang`) and

    - D_boundary = ω·D_overlap/n_overlap + C(1−ω)·D_path/n_path (C channels; 3 for RGB);
    - D_sum of a tile = the sum of its four D_boundary (NE, ES, SW, WN, in that order);
    - E = ω·Σ D_sum + (1−ω)·Var(D_sum), population variance.

    Exact (no approximation beyond float64 rounding, in a fixed order); positions need not be distinct.
    """

    def __init__(
        self,
        exemplar: np.ndarray,
        tile_samples: np.ndarray,
        n_samples: int,
        tile_size: int,
        overlap: int,
        corners: str = "free",
        samples: str = "diamond",
        cut: str = "dp",
        omega: float = _core.DEFAULT_OMEGA,
        eps: float = DEFAULT_EPS,
    ) -> None:
        self.exemplar = as_image(exemplar, "exemplar")
        self.tile_samples = _int_array(tile_samples, "tile_samples", 2, "(K, 4)")
        n_samples = positive_int(n_samples, "n_samples")
        args = _wang_args(tile_size, overlap, corners, samples, cut, omega)
        self.omega = args[-1]
        eps = finite_float(eps, "eps", positive=True)
        self._ev = _core.WangEvaluator(self.exemplar, self.tile_samples, n_samples, *args, eps)
        self.sample_size, self.n_samples, self.n_tiles = self._ev.dims
        self._init_args = (
            self.exemplar,
            self.tile_samples,
            n_samples,
            tile_size,
            overlap,
            corners,
            samples,
            cut,
            omega,
            eps,
        )

    def __reduce__(self):  # noqa: ANN204 - pickles by rebuilding from its inputs (issue 17)
        return (type(self), self._init_args)

    def evaluate(self, genes: np.ndarray, threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """E ``(P,)`` and D_sum ``(P, m)`` of ``genes`` ``(P, n_samples, 2)``."""
        g = _int_array(genes, "genes", 3, f"(P, {self.n_samples}, 2)")
        return self._ev.evaluate(g, threads_arg(threads))


def swang_cuts(
    initial: np.ndarray,
    supplementary: np.ndarray,
    eps: float = DEFAULT_EPS,
    threads: int | None = None,
    initial_grad: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """004's closed cuts for a stack of initial tiles and their supplementary patches, ``(K, N, N, C)`` each.

    Kwatra weights (:func:`kwatra_weights`, ``initial_grad`` ``(K, N, N, 2)`` optionally replacing the initial
    tiles' gradients), the one-pixel border ring tied to the initial tile, both diagonals (corner pixels
    excepted) to the supplementary patch, min-cut by :func:`grid_mincut`'s solver. Returns bool masks
    ``(K, N, N)`` (True = the pixel takes the supplementary patch) and float64 cut costs.
    """
    i, _ = _templates(initial, "initial")
    o, _ = _templates(supplementary, "supplementary")
    eps = finite_float(eps, "eps", positive=True)
    return _core.swang_cuts(
        i, o, eps, threads_arg(threads), _grad(initial_grad, "initial_grad", 4, "(K, N, N, 2)")
    )


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
    "kwatra_weights",
    "omega_cuts",
    "patch_ssd",
    "swang_cuts",
    "poisson_smooth",
    "tile_copy",
    "weighted_ssd_map",
    "wang_tiles",
]
