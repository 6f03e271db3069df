"""Quality metrics of synthesized textures and tile sets: the numbers to judge a result by.

Every metric takes float32 ``(H, W, C)`` images in [0, 1] (anything :func:`tilesynth.base.validate.as_image`
accepts) and returns a small frozen dataclass with a ``to_dict()`` (JSON-able, non-finite values become
``None``). Sums run over the C channels; "SSD" is Σ over pixels and channels of squared differences, as in the
rest of tilesynth.

**Border seam score** (:func:`seam_score`). For tiles of N x N pixels laid from the top-left corner (as
:func:`tilesynth.synthesize` lays them), a horizontal neighbour pair (y, x)–(y, x+1) *crosses a border* when
(x+1) is a multiple of N, otherwise it lies inside a tile; likewise vertically. With d²(p, q) = Σ_c (I_c(p) −
I_c(q))², let B_x, B_y be the mean d² over the pairs crossing vertical / horizontal borders and I_x, I_y the
mean over the pairs inside tiles along the same direction. The score is

    S = (B_x + B_y) / (I_x + I_y),

a direction is left out of both sums when the image has no border across it (an output one tile wide). S ≈ 1
means the tile borders look like any other pixel step of the texture (invisible); a visible seam gives S > 1.
We pool the two directions with equal weight rather than pooling all pairs, so that an anisotropic texture
(stronger steps along x than along y) in a non-square output, whose border pairs and interior pairs come in
different x/y proportions, does not move S away from 1 by itself. The per-direction ratios B_x/I_x and B_y/I_y
are reported too. Cost O(H·W·C). For ω-tiles the border pixels come from a few exemplar rows and columns only
(the side midlines of the sample patches), so S of a valid ω tiling scatters around 1 (about 0.8-1.3 in our
tests) with the content of those lines, while a random placement that ignores the corner colours gives S well
above 1 (about 3 on the 128x128 gravel, 15 on the lettuce crop of the tests: the busier the texture, the smaller
a seam is against its own steps).

**Coherence energy** (:func:`coherence_energy`): Kwatra et al.'s texture energy, which 000 says its objective
resembles. For every output patch P of p x p pixels at the positions (y, x) ∈ {0, s, 2s, ...} (the last H−p
mod s rows / columns are not the top-left of any patch), e(P) = min over every fully-overlapping exemplar
patch Q of SSD(P, Q); the energy is the mean of e over the patches (defaults p = 8, s = 4), and rms = √(energy
/ (p²·C)) is the same number as a root-mean-square pixel difference in [0, 1] units. The minimum is exact: a
patch that is a bit-identical copy of some exemplar patch has e = 0 (found by a 64-bit hash of the patch's
float bits with a random linear key, confirmed by comparing the pixels, so a hash collision can never produce
a wrong 0); every other patch is searched exhaustively by :meth:`tilesynth.SsdIndex.best_matches` (FFT maps of
the cached exemplar spectrum, candidates within the FFT error bound re-ranked by the direct float64 sum), in
batches. Cost: O(H_e·W_e·p²·C) for the exemplar hash, and O(C·H_e·W_e·log(H_e·W_e)) per searched patch; an
ω-tile output copies exemplar content everywhere but near its cutting curves, so only the patches that
straddle a cut (typically 15-40%) are searched. About 0.4 ms per searched patch for a 128x128 exemplar and
4-8 ms for 378x378 (2 shared cores): a 512x512 output (16,129 patches) costs about 2-3 s on a 128x128
exemplar, 15-20 s on the 378x378 lettuce.

**Coverage** (:func:`coverage`), from a provenance map (the exemplar (row, col) of every output pixel, see
:func:`tilesynth.source_map`): with n(q) the number of output pixels copied from exemplar pixel q,
``fraction`` is the share of exemplar pixels with n(q) > 0; ``evenness`` = H(n / Σn) / log(H_e·W_e), the
Shannon entropy of the usage distribution over *all* exemplar pixels divided by its largest possible value (1
= every exemplar pixel used equally often, 0 = one pixel used for everything); ``cv`` = std(n) / mean(n) over
all exemplar pixels (0 = even).

**Repetition** (:func:`repetition`): the normalised autocorrelation of the output is, for an offset d = (dy,
dx), the Pearson correlation between the image and itself shifted by d over their overlap, pooled over
channels:

    r(d) = Σ_c cov_c(d) / √(Σ_c var_c^A(d) · Σ_c var_c^B(d)),

with A the pixels p whose partner p + d is inside the image and B = A + d, each channel centred by its mean
over A (resp. B). r(0) = 1 and |r| ≤ 1; an image periodic with period d has r(d) = 1. Offsets are limited to
|dy| ≤ H/2, |dx| ≤ W/2 (at least a quarter of the image overlaps). The reported *peak* is the largest r over
the offsets d ≠ 0 that are local maxima of r (≥ their 8 neighbours), so the central lobe around d = 0 — high
for any smooth texture — is never reported; its offset is given with dy > 0 or dy = 0, dx > 0 (r(d) = r(−d));
among peaks within 1e-9 of each other the shortest offset wins. A seamless but repetitive tiling shows a peak
at a multiple of the tile size. Cost: FFTs of size (H + H/2) x (W + W/2) per channel plus O(1) per offset from
summed-area tables.

**Objective** (:func:`objective`): of a tile set, E = λ·ΣD_j + (1−λ)·Var(D_j) over its intermediate tiles (λ =
0.8, the stored ``TileSet.E``), f = 1/E, the same with 003's normalisation (D_j divided by the N·N pixels of
the tile: ``E_normalised``, ``f_normalised``, the affinity 003's Table 2 reports), the spread of D_j (min,
max, mean, std, max/min) and the cut costs (min, max, mean, sum).

**Cut seam** (:func:`cut_seam_score`): of a tile set, the mean squared colour step across its cuts (ω and s-Wang:
the cutting curve; Wang: the quilting cuts between the diamonds, where ``cut_masks`` changes value) (pixel pairs with one pixel on each side of the cut) divided by the mean squared step
over every pixel pair of the tiles. 1 means the cut is as invisible as any pair of neighbours; a visible cut
scores above 1. It is the score that Poisson smoothing (``smooth=True``) lowers; the seam score above measures
the tile borders, which smoothing never changes.

:func:`tileset_metrics` and :func:`image_metrics` compute everything that can be computed for a tile set
(after synthesizing a sample, default 512x512 with seed 1) or for a plain image (seam score only with a tile
size, coherence only with an exemplar, coverage only with a provenance map, objective never); what was skipped
and why is listed in ``notes``. ``tilesynth metrics`` is the command line of these two.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..base.validate import as_image, positive_int
from ..errors import ParameterError, ShapeError
from .energy import LAMBDA, energy
from .quality import _fast_len as _fft_size  # smallest 2^a·3^b·5^c >= n (fast FFT lengths)

DEFAULT_PATCH = 8
"""Side p of the coherence patches."""
DEFAULT_STRIDE = 4
"""Stride s between coherence patches."""
DEFAULT_SAMPLE_SIZE = (512, 512)
"""(width, height) of the sample :func:`tileset_metrics` synthesizes."""
DEFAULT_SAMPLE_SEED = 1
"""Tiling seed of that sample."""
COHERENCE_BATCH = 64
"""Templates per :meth:`SsdIndex.best_matches` call (bounds the memory of the SSD maps)."""

_HASH_SEED = 0x5EED_C0DE


def _finite(v: Any) -> Any:
    """JSON-able copy: numpy scalars to Python, non-finite floats to None, arrays dropped by the callers."""
    if isinstance(v, dict):
        return {k: _finite(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_finite(x) for x in v]
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return f if math.isfinite(f) else None
    return v


def _ratio(num: float, den: float) -> float:
    if den > 0:
        return num / den
    return math.inf if num > 0 else math.nan


# ---------------------------------------------------------------------------------------------- seam score
def _pair_differences(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d² of every horizontal pair ``(H, W-1)`` and every vertical pair ``(H-1, W)``, float64."""
    x = image.astype(np.float64)
    dx2 = ((x[:, 1:] - x[:, :-1]) ** 2).sum(axis=2)
    dy2 = ((x[1:] - x[:-1]) ** 2).sum(axis=2)
    return dx2, dy2


def _border_pairs(length: int, tile: int) -> np.ndarray:
    """bool ``(length-1,)``: pair (i, i+1) crosses a tile border."""
    return (np.arange(1, length) % tile) == 0


@dataclass(frozen=True)
class SeamScore:
    """Border seam score S (see the module docstring) and its parts.

    ``ratio_x`` = B_x / I_x is for the vertical borders (pairs of horizontal neighbours), ``ratio_y`` for the
    horizontal ones; a direction without border is ``None`` (its parts too).
    """

    score: float
    ratio_x: float | None
    ratio_y: float | None
    border_x: float | None
    border_y: float | None
    interior_x: float | None
    interior_y: float | None
    border_pairs: int
    interior_pairs: int
    tile_size: int

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def seam_score(image: np.ndarray, tile_size: int) -> SeamScore:
    """Border seam score of ``image`` tiled with ``tile_size`` x ``tile_size`` tiles from its top-left corner.

    Raises ShapeError when the image holds no tile border (at most one tile in each direction).
    """
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    h, w = img.shape[:2]
    if h <= n and w <= n:
        raise ShapeError(f"tile_size = {n}: the {w}x{h} image holds no tile border (one tile or less)")
    dx2, dy2 = _pair_differences(img)
    bx_mask, by_mask = _border_pairs(w, n), _border_pairs(h, n)
    parts: dict[str, float | None] = {}
    num = den = 0.0
    nb = ni = 0
    for axis, d2, mask in (("x", dx2, bx_mask), ("y", dy2.T, by_mask)):
        # d2 is (lines, pairs); mask selects the border pairs along the last axis
        if not mask.any():
            parts.update({f"border_{axis}": None, f"interior_{axis}": None, f"ratio_{axis}": None})
            continue
        b = float(d2[:, mask].mean())
        inner = d2[:, ~mask]
        i = float(inner.mean()) if inner.size else math.nan
        parts.update({f"border_{axis}": b, f"interior_{axis}": i, f"ratio_{axis}": _ratio(b, i)})
        num += b
        den += i if inner.size else 0.0
        nb += int(d2[:, mask].size)
        ni += int(inner.size)
    return SeamScore(score=_ratio(num, den), border_pairs=nb, interior_pairs=ni, tile_size=n, **parts)


def seam_profiles(image: np.ndarray, tile_size: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel border terms, for pictures: d² across each border divided by the interior mean of its direction.

    Returns ``vertical`` float64 ``(H, n_v)`` (column k: the pairs across the border between pixel columns
    (k+1)·N − 1 and (k+1)·N) and ``horizontal`` ``(n_h, W)``; their means are ``ratio_x`` and ``ratio_y`` of
    :func:`seam_score`.
    """
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    s = seam_score(img, n)
    dx2, dy2 = _pair_differences(img)
    bx, by = _border_pairs(img.shape[1], n), _border_pairs(img.shape[0], n)
    v = dx2[:, bx] / s.interior_x if s.interior_x else np.zeros((img.shape[0], int(bx.sum())))
    hz = dy2[by] / s.interior_y if s.interior_y else np.zeros((int(by.sum()), img.shape[1]))
    return v, hz


# ----------------------------------------------------------------------------------------- coherence energy
@dataclass(frozen=True)
class Coherence:
    """Coherence energy (see the module docstring) with the per-patch minima and where they are.

    ``values`` float64 ``(rows, cols)``: e of the patch at (i·stride, j·stride); ``offsets`` int64
    ``(rows, cols, 2)``: top-left (row, col) of an exemplar patch reaching it (for ties, the smallest (row, col)
    among exact copies, otherwise the one :meth:`SsdIndex.best_matches` ranks first). ``exact_copies`` patches
    were bit-identical copies (e = 0), ``searched`` were matched exhaustively.
    """

    energy: float
    rms: float
    max: float
    patch: int
    stride: int
    n_patches: int
    exact_copies: int
    searched: int
    seconds: float
    values: np.ndarray = field(repr=False)
    offsets: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        d = {
            k: getattr(self, k)
            for k in (
                "energy",
                "rms",
                "max",
                "patch",
                "stride",
                "n_patches",
                "exact_copies",
                "searched",
                "seconds",
            )
        }
        return _finite(d)


def _patch_keys(bits: np.ndarray, p: int, rows: int, cols: int, step: int, weights: np.ndarray) -> np.ndarray:
    """Σ_{i,j,c} w[i,j,c]·bits[y+i, x+j, c] mod 2^64 at y = 0, step, ..., x likewise: uint64 ``(rows, cols)``."""
    key = np.zeros((rows, cols), np.uint64)
    ylen, xlen = step * (rows - 1) + 1, step * (cols - 1) + 1
    for i in range(p):
        for j in range(p):
            for c in range(bits.shape[2]):
                key += bits[i : i + ylen : step, j : j + xlen : step, c] * weights[i, j, c]
    return key


def _float_bits(img: np.ndarray) -> np.ndarray:
    # + 0.0 turns −0.0 into +0.0, so equal values have equal bits (images hold no NaN: as_image refuses them)
    return np.ascontiguousarray(img + np.float32(0.0)).view(np.uint32).astype(np.uint64)


def coherence_energy(
    image: np.ndarray,
    exemplar: np.ndarray,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    index: Any = None,
) -> Coherence:
    """Exact coherence energy of ``image`` against ``exemplar`` (see the module docstring).

    ``index``: optionally a prebuilt :class:`tilesynth.SsdIndex` of ``exemplar`` (reused across calls).
    """
    t0 = time.perf_counter()
    img, ex, p, s = _coherence_args(image, exemplar, patch, stride, index)
    h, w, c = img.shape
    rows, cols = (h - p) // s + 1, (w - p) // s + 1
    rx = ex.shape[1] - p + 1
    m = rows * cols
    values = np.full(m, np.nan)
    offsets = np.zeros((m, 2), np.int64)
    out_patches, ex_patches = _patch_gatherers(img, ex, p, s, m, cols, rx)
    _exact_copies(img, ex, p, s, rows, cols, values, offsets, out_patches, ex_patches)
    todo = _search_the_rest(ex, values, offsets, out_patches, index, threads)
    energy = float(values.mean())
    return Coherence(
        energy=energy,
        rms=math.sqrt(energy / (p * p * c)),
        max=float(values.max()),
        patch=p,
        stride=s,
        n_patches=m,
        exact_copies=int(m - todo.size),
        searched=int(todo.size),
        seconds=time.perf_counter() - t0,
        values=values.reshape(rows, cols),
        offsets=offsets.reshape(rows, cols, 2),
    )


def _coherence_args(
    image: np.ndarray, exemplar: np.ndarray, patch: int, stride: int, index: Any
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The checked arguments of :func:`coherence_energy`: image, exemplar, patch, stride."""
    from ..base.kernels import SsdIndex

    img = as_image(image)
    ex = as_image(exemplar, "exemplar")
    p = positive_int(patch, "patch")
    s = positive_int(stride, "stride")
    if img.shape[2] != ex.shape[2]:
        raise ShapeError(f"exemplar has {ex.shape[2]} channel(s), the image {img.shape[2]}")
    if index is not None and not (isinstance(index, SsdIndex) and np.array_equal(index.image, ex)):
        what = f"an SsdIndex of another {index.shape} image" if isinstance(index, SsdIndex) else repr(index)
        raise ParameterError(f"index is {what}, expected an SsdIndex of the exemplar {ex.shape} (or None)")
    for name, a in (("image", img), ("exemplar", ex)):
        if p > a.shape[0] or p > a.shape[1]:
            raise ParameterError(f"patch = {p}: larger than the {a.shape[1]}x{a.shape[0]} {name}")
    return img, ex, p, s


def _patch_gatherers(
    img: np.ndarray, ex: np.ndarray, p: int, s: int, m: int, cols: int, rx: int
) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray]]:
    """``out_patches(i)``: the p x p output patches of grid indices ``i``; ``ex_patches(k)``: the exemplar
    patches at flat offsets ``k`` (row * rx + col)."""
    py, px = np.divmod(np.arange(m), cols)
    py, px = py * s, px * s
    ii, jj = np.mgrid[0:p, 0:p]

    def out_patches(idx: np.ndarray) -> np.ndarray:
        return img[py[idx, None, None] + ii, px[idx, None, None] + jj]

    def ex_patches(flat: np.ndarray) -> np.ndarray:
        r, q = np.divmod(flat, rx)
        return ex[r[:, None, None] + ii, q[:, None, None] + jj]

    return out_patches, ex_patches


def _exact_copies(
    img: np.ndarray,
    ex: np.ndarray,
    p: int,
    s: int,
    rows: int,
    cols: int,
    values: np.ndarray,
    offsets: np.ndarray,
    out_patches: Callable[[np.ndarray], np.ndarray],
    ex_patches: Callable[[np.ndarray], np.ndarray],
) -> None:
    """Mark every output patch that is a bit-for-bit copy of an exemplar patch (value 0, its offset): a hash of
    the float bits of every patch, confirmed by the pixels."""
    c = img.shape[2]
    ry, rx = ex.shape[0] - p + 1, ex.shape[1] - p + 1
    weights = np.random.default_rng(_HASH_SEED).integers(0, 2**63, size=(p, p, c), dtype=np.uint64) * 2 + 1
    ex_keys = _patch_keys(_float_bits(ex), p, ry, rx, 1, weights).ravel()
    out_keys = _patch_keys(_float_bits(img), p, rows, cols, s, weights).ravel()
    order = np.argsort(ex_keys, kind="stable")  # equal keys stay in increasing (row, col) order
    sorted_keys = ex_keys[order]
    lo = np.searchsorted(sorted_keys, out_keys, side="left")
    hi = np.searchsorted(sorted_keys, out_keys, side="right")

    # exact copies: confirm the first key match by the pixels; on a (never seen) collision try the others
    hits = np.nonzero(hi > lo)[0]
    for b0 in range(0, hits.size, 4096):  # in chunks: bounded memory for large outputs
        hit = hits[b0 : b0 + 4096]
        cand = order[lo[hit]]
        same = (out_patches(hit) == ex_patches(cand)).all(axis=(1, 2, 3))
        values[hit[same]] = 0.0
        offsets[hit[same]] = np.stack(np.divmod(cand[same], rx), axis=1)
        for q in hit[~same]:
            for k in order[lo[q] + 1 : hi[q]]:
                if np.array_equal(out_patches(np.array([q]))[0], ex_patches(np.array([k]))[0]):
                    values[q] = 0.0
                    offsets[q] = divmod(int(k), rx)
                    break


def _search_the_rest(
    ex: np.ndarray,
    values: np.ndarray,
    offsets: np.ndarray,
    out_patches: Callable[[np.ndarray], np.ndarray],
    index: Any,
    threads: int | None,
) -> np.ndarray:
    """The exhaustive nearest-patch search of every patch that is not an exact copy; returns their indices."""
    from ..base.kernels import SsdIndex

    todo = np.nonzero(np.isnan(values))[0]
    if todo.size:
        idx = index if index is not None else SsdIndex(ex, threads)
        for b in range(0, todo.size, COHERENCE_BATCH):
            sel = todo[b : b + COHERENCE_BATCH]
            off, val = idx.best_matches(np.ascontiguousarray(out_patches(sel)), k=1, threads=threads)
            values[sel] = np.maximum(val[:, 0], 0.0)
            offsets[sel] = off[:, 0]
    return todo


# ------------------------------------------------------------------------------------------------- coverage
@dataclass(frozen=True)
class Coverage:
    """Exemplar coverage of one output (see the module docstring); ``counts`` int64 ``(H_e, W_e)`` = n(q)."""

    fraction: float
    evenness: float
    cv: float
    used: int
    pixels: int
    output_pixels: int
    counts: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        return _finite(
            {k: getattr(self, k) for k in ("fraction", "evenness", "cv", "used", "pixels", "output_pixels")}
        )


def coverage(source: np.ndarray, exemplar_shape: tuple[int, ...]) -> Coverage:
    """Coverage of an exemplar of ``exemplar_shape`` by an output whose provenance is ``source`` ``(H, W, 2)``."""
    src = np.asarray(source)
    if src.ndim != 3 or src.shape[2] != 2 or not np.issubdtype(src.dtype, np.integer):
        raise ShapeError(f"source has shape {src.shape} and dtype {src.dtype}, expected integer (H, W, 2)")
    he, we = int(exemplar_shape[0]), int(exemplar_shape[1])
    r, c = src[..., 0].ravel(), src[..., 1].ravel()
    if r.size == 0:
        raise ShapeError("source is empty")
    lo_r, hi_r, lo_c, hi_c = (
        int(r.min()),
        int(r.max()),
        int(c.min()),
        int(c.max()),
    )  # before any cast can wrap
    if lo_r < 0 or lo_c < 0 or hi_r >= he or hi_c >= we:
        raise ParameterError(
            f"source: positions in rows [{lo_r}, {hi_r}], cols [{lo_c}, {hi_c}] outside the {we}x{he} exemplar"
        )
    r, c = r.astype(np.int64), c.astype(np.int64)
    counts = np.bincount(r * we + c, minlength=he * we).astype(np.int64)
    total = counts.sum()
    pr = counts[counts > 0] / total
    entropy = float(-(pr * np.log(pr)).sum())
    evenness = entropy / math.log(he * we) if he * we > 1 else 1.0
    return Coverage(
        fraction=float((counts > 0).mean()),
        evenness=evenness,
        cv=float(counts.std() / counts.mean()),
        used=int((counts > 0).sum()),
        pixels=he * we,
        output_pixels=int(total),
        counts=counts.reshape(he, we),
    )


# ----------------------------------------------------------------------------------------------- repetition
@dataclass(frozen=True)
class Repetition:
    """Strongest secondary peak of the normalised autocorrelation (see the module docstring).

    ``peak`` / ``offset`` are None when r has no local maximum besides d = 0. ``correlation`` float64
    ``(2·Hm+1, 2·Wm+1)`` holds r(dy, dx) at index (dy + Hm, dx + Wm), Hm = H // 2, Wm = W // 2 (NaN where the
    overlap has no variance).
    """

    peak: float | None
    offset: tuple[int, int] | None
    max_offset: tuple[int, int]
    correlation: np.ndarray = field(repr=False)

    def to_dict(self) -> dict[str, Any]:
        return _finite(
            {
                "peak": self.peak,
                "offset": None if self.offset is None else list(self.offset),
                "max_offset": list(self.max_offset),
            }
        )


def _box_sums(sat: np.ndarray, r0: np.ndarray, r1: np.ndarray, c0: np.ndarray, c1: np.ndarray) -> np.ndarray:
    """Sums over rows [r0, r1) x cols [c0, c1) from a summed-area table ``(H+1, W+1, C)``; broadcast."""
    return sat[r1, c1] - sat[r0, c1] - sat[r1, c0] + sat[r0, c0]


def _lag_maxima(r: np.ndarray, hm: int, wm: int) -> tuple[np.ndarray, np.ndarray]:
    """The autocorrelation ``r`` without its outer ring (``core``, lag (0, 0) at ``[hm, wm]``) and the mask of
    its local maxima over the 8 neighbours (NaN never one, the origin excluded)."""
    core = r[1:-1, 1:-1]
    filled = np.where(np.isnan(r), -np.inf, r)
    is_max = np.isfinite(core)
    for ddy in (-1, 0, 1):
        for ddx in (-1, 0, 1):
            if ddy or ddx:
                is_max &= core >= filled[1 + ddy : r.shape[0] - 1 + ddy, 1 + ddx : r.shape[1] - 1 + ddx]
    is_max[hm, wm] = False
    return core, is_max


def autocorrelation(image: np.ndarray, max_dy: int, max_dx: int) -> np.ndarray:
    """r(dy, dx) of the module docstring for |dy| <= max_dy, |dx| <= max_dx: ``(2·max_dy+1, 2·max_dx+1)``."""
    x = as_image(image).astype(np.float64)
    h, w, _ = x.shape
    if not (0 <= max_dy < h and 0 <= max_dx < w):
        raise ParameterError(f"max offset ({max_dy}, {max_dx}): must be below the image size ({h}, {w})")
    x -= x.mean(axis=(0, 1))  # conditioning only: r does not depend on a constant per channel
    fh, fw = _fft_size(h + max_dy), _fft_size(w + max_dx)
    spec = np.fft.rfft2(x, s=(fh, fw), axes=(0, 1))
    auto = np.fft.irfft2((spec * spec.conj()).real.sum(axis=2), s=(fh, fw))  # Σ_c Σ_p x_c(p) x_c(p + d)
    dy = np.arange(-max_dy, max_dy + 1)[:, None]
    dx = np.arange(-max_dx, max_dx + 1)[None, :]
    cross = auto[dy % fh, dx % fw]
    sat1 = np.zeros((h + 1, w + 1, x.shape[2]))
    sat1[1:, 1:] = x.cumsum(0).cumsum(1)
    sat2 = np.zeros_like(sat1)
    sat2[1:, 1:] = (x * x).cumsum(0).cumsum(1)
    # A: pixels p with p + d inside; B = A + d
    ar0, ar1 = np.maximum(0, -dy), h - np.maximum(0, dy)
    ac0, ac1 = np.maximum(0, -dx), w - np.maximum(0, dx)
    br0, br1, bc0, bc1 = ar0 + dy, ar1 + dy, ac0 + dx, ac1 + dx
    n = ((ar1 - ar0) * (ac1 - ac0)).astype(np.float64)[..., None]
    ma = _box_sums(sat1, ar0, ar1, ac0, ac1) / n
    mb = _box_sums(sat1, br0, br1, bc0, bc1) / n
    va = (_box_sums(sat2, ar0, ar1, ac0, ac1) / n - ma * ma).sum(axis=2)
    vb = (_box_sums(sat2, br0, br1, bc0, bc1) / n - mb * mb).sum(axis=2)
    cov = cross / n[..., 0] - (ma * mb).sum(axis=2)
    den = np.sqrt(np.maximum(va, 0.0) * np.maximum(vb, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(den > 1e-12 * max(float((x * x).sum(axis=2).mean()), 1e-300), cov / den, np.nan)
    return np.clip(r, -1.0, 1.0)


def repetition(image: np.ndarray) -> Repetition:
    """Strongest non-zero peak of the normalised autocorrelation of ``image`` (at least 4x4 pixels)."""
    img = as_image(image)
    h, w = img.shape[:2]
    if h < 4 or w < 4:
        raise ShapeError(f"image is {w}x{h}: repetition needs at least 4x4 pixels")
    hm, wm = h // 2, w // 2
    r = autocorrelation(img, hm + 1, wm + 1)  # one ring more, so every candidate has its 8 neighbours
    core, is_max = _lag_maxima(r, hm, wm)
    if not is_max.any():
        return Repetition(peak=None, offset=None, max_offset=(hm, wm), correlation=core)
    ys, xs = np.nonzero(is_max)
    vals = core[ys, xs]
    dys, dxs = ys - hm, xs - wm
    # strongest first; ties (within 1e-9, FFT rounding): the shortest offset, then the smallest (dy, dx)
    tied = vals >= vals.max() - 1e-9
    ys, xs, vals, dys, dxs = ys[tied], xs[tied], vals[tied], dys[tied], dxs[tied]
    best = np.lexsort((dxs, dys, dys * dys + dxs * dxs))[0]
    oy, ox = int(dys[best]), int(dxs[best])
    if oy < 0 or (oy == 0 and ox < 0):
        oy, ox = -oy, -ox
    return Repetition(peak=float(vals[best]), offset=(oy, ox), max_offset=(hm, wm), correlation=core)


# ------------------------------------------------------------------------------------------------ objective
def objective(tileset: Any) -> dict[str, Any]:
    """E, f = 1/E (plain and with 003's normalisation), the spread of D_j and the cut costs of a tile set.

    E is over the intermediate tiles, i.e. the D_j of the variant-0 tile of every distinct corner tuple (a
    tile set's variants share their intermediate tile); it equals the stored ``tileset.E``.
    """
    lam = float(tileset.params.get("lambda", LAMBDA))
    variants = getattr(tileset.definition, "variants", None)
    if variants is None:  # a set without variants: every tile has its own D_j
        variants = [0] * tileset.n_tiles
    per_tuple: dict[tuple[int, ...], float] = {}
    for k in range(tileset.n_tiles):
        if variants[k] == 0:
            per_tuple.setdefault(tuple(int(v) for v in tileset.tile_patches[k]), float(tileset.D[k]))
    d = np.array(list(per_tuple.values()), dtype=np.float64)
    n2 = float(tileset.tile_size) ** 2
    e = energy(d, lam)
    en = energy(d / n2, lam)
    costs = np.asarray(tileset.cut_costs, dtype=np.float64)
    return _finite(
        {
            "E": e,
            "f": _ratio(1.0, e),
            "E_stored": float(tileset.E),
            "E_normalised": en,
            "f_normalised": _ratio(1.0, en),
            "lambda": lam,
            "intermediate_tiles": int(d.size),
            "D": {
                "min": float(d.min()),
                "max": float(d.max()),
                "mean": float(d.mean()),
                "std": float(d.std()),
                "max_over_min": _ratio(float(d.max()), float(d.min())),
            },
            "cut_costs": {
                "min": float(costs.min()),
                "max": float(costs.max()),
                "mean": float(costs.mean()),
                "sum": float(costs.sum()),
            },
            "selection": tileset.params.get("selection", {}).get("method"),
            "cut_score": _cut_score(costs, int(tileset.tile_size)),
        }
    )


def _cut_score(costs: np.ndarray, n: int) -> float:
    from .quality import cut_score  # issue 15

    return cut_score(costs, n)


def cut_seam_score(tileset: Any) -> dict[str, Any] | None:
    """The cut seam of a tile set (see the module docstring): ``{"score", "cut_pairs", "pairs"}``, or None for
    a set whose cuts never separate two pixels."""
    masks = getattr(tileset, "cut_masks", None)
    if masks is None or np.asarray(masks).ndim != 3 or np.asarray(masks).size == 0:
        return None
    m = np.asarray(masks, dtype=np.int8)
    num = den = 0.0
    cut = pairs = 0
    for ax in (1, 2):
        d = _squared_steps(tileset.tiles, ax)
        across = np.diff(m, axis=ax) != 0
        num += float(d[across].sum())
        cut += int(across.sum())
        den += float(d.sum())
        pairs += int(d.size)
        del d, across  # one axis at a time (issue 12: peak memory)
    if cut == 0:
        return None
    return _finite({"score": _ratio(num / cut, den / pairs), "cut_pairs": cut, "pairs": pairs})


def _squared_steps(tiles: Any, ax: int) -> np.ndarray:
    """``(np.diff(x, axis=ax) ** 2).sum(axis=-1)`` of ``x`` = the tiles as float64, computed a chunk of tiles
    at a time (every value is elementwise, so the same bytes): the whole float64 copy and its differences were
    most of a c5 build's peak memory (issue 12)."""
    t = np.asarray(tiles)
    shape = list(t.shape)
    shape[ax] -= 1
    d = np.empty(shape[:-1])
    step = max(1, (16 << 20) // max(1, 8 * int(np.prod(t.shape[1:]))))
    for lo in range(0, t.shape[0], step):
        x = np.asarray(t[lo : lo + step], dtype=np.float64)
        d[lo : lo + step] = (np.diff(x, axis=ax) ** 2).sum(axis=-1)
    return d


# ------------------------------------------------------------------------------------ non-periodicity (issue 12)
COPY_PATCH = 16
"""Side of the grid patches of :func:`periodic_copies`."""
COPY_TOLERANCE = (2.0 / 255.0) ** 2
"""Mean squared difference at or below which a grid patch is a copy of its partner one lag away."""
COPY_LAGS = 4
"""How many of the strongest autocorrelation lags :func:`periodic_copies` tries (each with its opposite)."""
DETAIL_SIGMA = 8.0
"""σ of the Gaussian blur subtracted from the luminance to get the detail layer."""
HISTOGRAM_SCALES = (1, 2, 4)
"""Scales (box downsampling factors) of the gradient-magnitude histograms of :func:`histogram_distance`."""


def luminance(image: np.ndarray) -> np.ndarray:
    """``(H, W)`` float64 luminance: Rec. 709 weights of RGB (alpha ignored), the mean of other channel counts."""
    img = as_image(image).astype(np.float64)
    c = img.shape[2]
    if c >= 3:
        return img[..., 0] * 0.2126 + img[..., 1] * 0.7152 + img[..., 2] * 0.0722
    return img[..., 0] if c == 1 else img.mean(axis=2)


def _gaussian_blur(x: np.ndarray, sigma: float) -> np.ndarray:
    """Separable Gaussian blur (radius ⌈4σ⌉, reflected borders) of a 2-d array."""
    r = int(math.ceil(4 * sigma))
    t = np.arange(-r, r + 1, dtype=np.float64)
    k = np.exp(-0.5 * (t / sigma) ** 2)
    k /= k.sum()
    out = x
    for axis in (0, 1):
        pad = [(0, 0), (0, 0)]
        pad[axis] = (r, r)
        mode = "reflect" if out.shape[axis] > r else "symmetric"
        padded = np.pad(out, pad, mode=mode)
        n = out.shape[axis]
        acc = np.zeros_like(out)
        for i, w in enumerate(k):
            acc += w * (padded[i : i + n] if axis == 0 else padded[:, i : i + n])
        out = acc
    return out


_luminance = luminance  # for the methods whose keyword arguments are named luminance


def detail_layer(image: np.ndarray, sigma: float = DETAIL_SIGMA) -> np.ndarray:
    """Luminance minus its Gaussian blur (σ = ``sigma``): ``(H, W)`` float64, the texture's fine structure."""
    y = luminance(image)
    return y - _gaussian_blur(y, sigma)


def _autocorr_peaks(x: np.ndarray, count: int) -> tuple[list[tuple[int, int]], list[float]]:
    """The ``count`` strongest local maxima d ≠ 0 (one of each ±d) of the autocorrelation of the 2-d array x,
    lags up to half the size, strongest first, as in :func:`repetition`."""
    lo, hi = float(x.min()), float(x.max())
    unit = (x - lo) / (hi - lo) if hi > lo else np.zeros_like(x)  # r is invariant to an affine map
    h, w = x.shape
    hm, wm = h // 2, w // 2
    r = autocorrelation(unit.astype(np.float32)[..., None], hm + 1, wm + 1)
    core, is_max = _lag_maxima(r, hm, wm)
    ys, xs = np.nonzero(is_max)
    dys, dxs = ys - hm, xs - wm
    keep = (dys > 0) | ((dys == 0) & (dxs > 0))  # one of each ±d
    ys, xs, dys, dxs = ys[keep], xs[keep], dys[keep], dxs[keep]
    vals = core[ys, xs]
    order = np.lexsort((dxs, dys, dys * dys + dxs * dxs, -vals))[:count]
    return [(int(dys[i]), int(dxs[i])) for i in order], [float(vals[i]) for i in order]


@dataclass(frozen=True)
class DetailRepetition:
    """Autocorrelation peak of the detail layer (:func:`detail_repetition`)."""

    peak: float | None
    offset: tuple[int, int] | None
    sigma: float

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def detail_repetition(image: np.ndarray, sigma: float = DETAIL_SIGMA) -> DetailRepetition:
    """The strongest off-origin peak of the normalised autocorrelation (:func:`repetition`'s definition) of
    the detail layer (luminance minus a Gaussian blur of σ = 8), lags up to half the output. Smooth colour
    variations do not count; a repeated pebble or streak gives a peak near 1."""
    img = as_image(image)
    if img.shape[0] < 4 or img.shape[1] < 4:
        raise ShapeError(
            f"image is {img.shape[1]}x{img.shape[0]}: detail repetition needs at least 4x4 pixels"
        )
    lags, vals = _autocorr_peaks(detail_layer(img, sigma), 1)
    if not lags:
        return DetailRepetition(peak=None, offset=None, sigma=float(sigma))
    return DetailRepetition(peak=vals[0], offset=lags[0], sigma=float(sigma))


@dataclass(frozen=True)
class PeriodicCopies:
    """Share of grid patches that copy the patch one dominant lag away (:func:`periodic_copies`)."""

    fraction: float
    n_patches: int
    lags: list[tuple[int, int]]
    patch: int
    tolerance: float

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def _copy_distances(img: np.ndarray, p: int, lags: int) -> tuple[np.ndarray, list]:
    """The ``(rows, cols)`` mean squared difference of every ``p`` x ``p`` grid patch of the float64 image
    ``(H, W, C)`` to its nearest partner at one of the ``lags`` strongest autocorrelation lags of the detail
    layer, in either direction (inf where every partner falls outside), and those lags: the inner loop of
    :func:`periodic_copies`, shared with ``benches/copy_split.py``, which needs the mask itself."""
    h, w, _ = img.shape
    rows, cols = h // p, w // p
    found, _ = _autocorr_peaks(detail_layer(img), lags)
    crop = img[: rows * p, : cols * p]
    best = np.full((rows, cols), np.inf)
    for dy, dx in found:
        for sy, sx in ((dy, dx), (-dy, -dx)):
            sq = np.full((rows * p, cols * p), np.inf)
            y0, y1 = max(0, -sy), min(rows * p, h - sy)
            x0, x1 = max(0, -sx), min(cols * p, w - sx)
            if y1 <= y0 or x1 <= x0:
                continue
            diff = crop[y0:y1, x0:x1] - img[y0 + sy : y1 + sy, x0 + sx : x1 + sx]
            sq[y0:y1, x0:x1] = (diff * diff).mean(axis=2)
            best = np.minimum(best, sq.reshape(rows, p, cols, p).mean(axis=(1, 3)))
    return best, found


def periodic_copies(
    image: np.ndarray, patch: int = COPY_PATCH, lags: int = COPY_LAGS, tolerance: float = COPY_TOLERANCE
) -> PeriodicCopies:
    """Periodic-copy fraction: the share of the output's ``patch`` x ``patch`` grid patches (top-left at
    multiples of ``patch``; a last partial row/column is left out) whose mean squared difference (over pixels
    and channels, values in [0, 1]) to the patch at one of the ``lags`` strongest autocorrelation lags of the
    detail layer (:func:`detail_repetition`), in either direction, is at most ``tolerance`` ((2/255)²). A patch
    whose partners all fall outside the image counts as no copy. A periodic image gives 1, noise 0; 69-89 % of
    a 16a output's patches were such copies (issue 12), image quilting 0-5 %.
    """
    img = as_image(image).astype(np.float64)
    p = positive_int(patch, "patch")
    h, w, _ = img.shape
    rows, cols = h // p, w // p
    if rows < 1 or cols < 1 or h < 4 or w < 4:
        raise ShapeError(f"image is {w}x{h}: periodic copies need at least one {p}x{p} patch and 4x4 pixels")
    best, found = _copy_distances(img, p, positive_int(lags, "lags"))
    frac = float((best <= tolerance).mean())
    return PeriodicCopies(
        fraction=frac, n_patches=rows * cols, lags=found, patch=p, tolerance=float(tolerance)
    )


@dataclass(frozen=True)
class RepeatedPatches:
    """Share of grid patches whose exact content appears elsewhere in the image (:func:`repeated_patches`)."""

    fraction: float
    n_patches: int
    patch: int

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def _window_keys(bits: np.ndarray, p: int) -> np.ndarray:
    """A 64-bit key of every ``p`` x ``p`` window (top-left (y, x), y <= H - p, x <= W - p) of the uint64 pixel
    bits ``(H, W, C)``: Σ_{i,j,c} a^i·b^j·r_c·bits[y+i, x+j, c] mod 2^64, by prefix sums along each axis (b and a
    odd, so b^x and a^y are invertible mod 2^64 and a window's sum is a difference of prefixes times b^-x).
    Equal windows have equal keys; unequal ones collide with probability about 2^-63 (the caller confirms by the
    pixels). uint64 array arithmetic wraps, which is the mod 2^64."""
    h, w, c = bits.shape
    rng = np.random.default_rng(_HASH_SEED + 1)
    r = rng.integers(0, 2**63, size=c, dtype=np.uint64) * np.uint64(2) + np.uint64(1)
    a, b = (int(v) * 2 + 1 for v in rng.integers(0, 2**62, size=2))
    mask = 2**64 - 1

    def powers(base: int, n: int) -> np.ndarray:
        out, v = np.empty(n, np.uint64), 1
        for k in range(n):
            out[k] = v
            v = (v * base) & mask
        return out

    v = (bits * r).sum(axis=2, dtype=np.uint64)  # (H, W): the channels folded with their weights
    for axis, base, n in ((1, b, w), (0, a, h)):
        fwd, inv = powers(base, n + 1), powers(pow(base, -1, 2**64), n + 1)
        shape = (1, -1) if axis == 1 else (-1, 1)
        pre = np.cumsum(v * fwd[:n].reshape(shape), axis=axis, dtype=np.uint64)
        pre = np.concatenate([np.zeros_like(pre.take([0], axis=axis)), pre], axis=axis)
        m = n - p + 1
        hi, lo = pre.take(np.arange(p, p + m), axis=axis), pre.take(np.arange(m), axis=axis)
        v = (hi - lo) * inv[:m].reshape(shape)
    return v


def repeated_patches(image: np.ndarray, patch: int = COPY_PATCH) -> RepeatedPatches:
    """Repeated-patch fraction: the share of the image's ``patch`` x ``patch`` grid patches (top-left at
    multiples of ``patch``; a last partial row/column is left out) whose pixels appear bit for bit in another
    window of the image at any position that does not overlap it (Chebyshev distance ≥ ``patch``).

    Unlike :func:`periodic_copies` it looks at every offset, not only the dominant lags, so it counts content
    that recurs at irregular places: the vertex content of a corner-tile set (every vertex of one colour shows
    the same sample patch; issue 12), a matching patch used by several tiles, a tile drawn twice, a quilting
    block taken twice from the same place. It measures exact re-use, not only visible repetition: a copying
    method must re-use exemplar content once the output is larger than the exemplar (a 1024² output of a 512²
    exemplar uses every exemplar pixel about 4 times), so compare methods at the same sizes. 0 for blended or
    resampled content (hex tiling), 1 for a periodic image. Flat regions (one exact colour over more than two
    patches) count as repeated. Exact: window keys by a rolling 64-bit hash (:func:`_window_keys`), every match
    confirmed by the pixels. Cost O(H·W·C) plus a sort of the H·W keys."""
    img = as_image(image)
    p = positive_int(patch, "patch")
    h, w, _ = img.shape
    rows, cols = h // p, w // p
    if rows < 1 or cols < 1:
        raise ShapeError(f"image is {w}x{h}: repeated patches need at least one {p}x{p} patch")
    keys = _window_keys(_float_bits(img), p)
    ww = keys.shape[1]
    flat = keys.ravel()
    order = np.argsort(flat, kind="stable")
    sk = flat[order]
    gy, gx = np.meshgrid(np.arange(rows) * p, np.arange(cols) * p, indexing="ij")
    gk = keys[gy, gx].ravel()
    lo = np.searchsorted(sk, gk, side="left")
    hi = np.searchsorted(sk, gk, side="right")
    hit = np.zeros(gk.size, bool)
    for q in np.nonzero(hi - lo > 1)[0]:  # a patch whose key occurs elsewhere: find a confirmed, disjoint one
        y, x = int(gy.flat[q]), int(gx.flat[q])
        mine = img[y : y + p, x : x + p]
        for k in order[lo[q] : hi[q]]:
            yy, xx = divmod(int(k), ww)
            if max(abs(yy - y), abs(xx - x)) >= p and np.array_equal(img[yy : yy + p, xx : xx + p], mine):
                hit[q] = True
                break
    return RepeatedPatches(fraction=float(hit.mean()), n_patches=rows * cols, patch=p)


def _wasserstein1(a: np.ndarray, b: np.ndarray, n: int = 512) -> float:
    """1-D Wasserstein-1 distance of two samples: mean |Q_a(u) − Q_b(u)| over n mid-point quantiles."""
    u = (np.arange(n) + 0.5) / n
    return float(np.abs(np.quantile(a.ravel(), u) - np.quantile(b.ravel(), u)).mean())


def _downsample(x: np.ndarray, f: int) -> np.ndarray:
    h, w = (x.shape[0] // f) * f, (x.shape[1] // f) * f
    return x[:h, :w].reshape(h // f, f, w // f, f, *x.shape[2:]).mean(axis=(1, 3))


def _gradient_magnitude(y: np.ndarray) -> np.ndarray:
    gy = np.diff(y, axis=0)[:, :-1]
    gx = np.diff(y, axis=1)[:-1, :]
    return np.sqrt(gx * gx + gy * gy)


@dataclass(frozen=True)
class HistogramDistance:
    """Colour and gradient histogram distance to the exemplar (:func:`histogram_distance`)."""

    distance: float
    colour: list[float]
    gradient: list[float]
    scales: list[int]

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def histogram_distance(
    image: np.ndarray, exemplar: np.ndarray, scales: tuple[int, ...] = HISTOGRAM_SCALES
) -> HistogramDistance:
    """Colour/gradient histogram distance: the mean of the 1-D Wasserstein-1 distances between ``image`` and
    ``exemplar`` of every colour channel (values in [0, 1]) and of the luminance gradient magnitude (forward
    differences) at each scale of ``scales`` (box downsampling by 1, 2, 4). 0 = the same distributions; it
    grows when a synthesis drops part of the exemplar (a vanished stone colour) or blurs its edges."""
    img, ex = as_image(image), as_image(exemplar, "exemplar")
    if img.shape[2] != ex.shape[2]:
        raise ShapeError(f"image has {img.shape[2]} channels, exemplar {ex.shape[2]}")
    colour = [_wasserstein1(img[..., c], ex[..., c]) for c in range(img.shape[2])]
    grad = []
    yi, ye = luminance(img), luminance(ex)
    used = []
    for f in scales:
        a, b = _downsample(yi, f), _downsample(ye, f)
        if min(a.shape + b.shape) < 2:
            continue
        grad.append(_wasserstein1(_gradient_magnitude(a), _gradient_magnitude(b)))
        used.append(int(f))
    parts = colour + grad
    return HistogramDistance(distance=float(np.mean(parts)), colour=colour, gradient=grad, scales=used)


# -------------------------------------------------------------------------------- inner-lattice seam (issue 12)
INNER_DEPTHS = (1, 2, 3, 4)
"""Depths (pixels inside the tile borders) of the lines :func:`inner_seam_score` measures."""


@dataclass(frozen=True)
class InnerSeamScore:
    """Seam score on the lattice-parallel lines a few pixels inside the tile borders (:func:`inner_seam_score`).

    ``scores`` maps each signed depth to its score: +k is the line between pixels k−1 and k of every tile
    (k pixels after a border), −k the line between pixels N−k−1 and N−k (k pixels before the next one).
    ``max`` and ``mean`` are over those depths; ``depth_of_max`` says where the worst line is."""

    max: float
    mean: float
    depth_of_max: int
    scores: dict[int, float]
    tile_size: int

    def to_dict(self) -> dict[str, Any]:
        d = _finite(asdict(self))
        d["scores"] = {str(k): v for k, v in d["scores"].items()}
        return d


def inner_seam_score(
    image: np.ndarray, tile_size: int, depths: tuple[int, ...] = INNER_DEPTHS
) -> InnerSeamScore:
    """Seam score of the lines parallel to the tile lattice ``depths`` pixels inside every tile border.

    A cut that runs along the tile border at a fixed depth in every tile (for example a min cut pressed onto
    the border ring of the free cut region) draws a square grid of straight seams that the border seam score
    (:func:`seam_score`, depth 0) does not see. For each signed depth s (±k, k in ``depths``) the lattice pairs
    are the neighbour pairs (i, i+1) with (i + 1 − s) mod N = 0 along x and along y; as in :func:`seam_score`,
    S(s) = (B_x(s) + B_y(s)) / (I_x + I_y), where B is the mean squared colour step over those pairs and I the
    mean over the pairs on none of the measured lines (not the borders, no depth ±k): S ≈ 1 when the lines
    look like any other pixel step, a grid of seams gives S > 1. Depths of N/2 or more are left out (they
    would meet the lines of the opposite border). Cost O(H·W·C).

    Raises ShapeError when the image holds no tile border, ParameterError when no depth is below N/2.
    """
    img = as_image(image)
    n = positive_int(tile_size, "tile_size", minimum=2)
    h, w = img.shape[:2]
    if h <= n and w <= n:
        raise ShapeError(f"tile_size = {n}: the {w}x{h} image holds no tile border (one tile or less)")
    ks = sorted({positive_int(k, "depth") for k in depths})
    ks = [k for k in ks if k < n / 2]
    if not ks:
        raise ParameterError(f"depths = {tuple(depths)}: none is below tile_size / 2 = {n / 2:g}")
    signed = [s for k in ks for s in (k, -k)]
    measured = {0} | {s % n for s in signed}
    dx2, dy2 = _pair_differences(img)
    num = {s: 0.0 for s in signed}
    den = 0.0
    used = 0
    for d2 in (dx2, dy2.T):  # (lines, pairs): pair j joins positions j and j + 1 along the last axis
        if d2.shape[1] + 1 < n + ks[-1] + 1:
            continue  # not every measured line crosses this direction
        used += 1
        cls = np.arange(1, d2.shape[1] + 1) % n
        sums = np.bincount(cls, weights=d2.sum(axis=0), minlength=n)
        counts = np.bincount(cls, minlength=n) * d2.shape[0]
        inner = np.array([c not in measured for c in range(n)])
        den += _ratio(float(sums[inner].sum()), float(counts[inner].sum()))
        for s in signed:
            c = s % n
            num[s] += _ratio(float(sums[c]), float(counts[c])) if counts[c] else 0.0
    if not used:
        raise ShapeError(
            f"tile_size = {n}: the {w}x{h} image is under N + {ks[-1] + 1} pixels in both directions "
            "(no full set of inner lines)"
        )
    scores = {s: _ratio(num[s], den) for s in signed}
    worst = max(signed, key=lambda s: (scores[s], -abs(s), s))
    return InnerSeamScore(
        max=float(scores[worst]),
        mean=float(np.mean(list(scores.values()))),
        depth_of_max=int(worst),
        scores=scores,
        tile_size=n,
    )


# ---------------------------------------------------------------------------------------------- everything
def image_metrics(
    image: np.ndarray,
    tile_size: int | None = None,
    exemplar: np.ndarray | None = None,
    source: np.ndarray | None = None,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    progress: Any = None,
) -> dict[str, Any]:
    """Every metric that the given facts allow, as a JSON-able dict (``progress``: an optional
    ``(stage, done, total)`` callable, e.g. :class:`tilesynth.base.progress.Progress`, called around every step).

    Keys ``input``, ``seam``, ``coherence``, ``coverage``, ``repetition`` (a dict each, or None when skipped)
    and ``notes`` (why something was skipped). The seam score needs ``tile_size``, the coherence energy the
    ``exemplar``, the coverage the provenance ``source`` and the exemplar (its shape).
    """
    return _measure(image, tile_size, exemplar, source, patch, stride, threads, progress)[0]


def _measure(
    image: np.ndarray,
    tile_size: int | None,
    exemplar: np.ndarray | None,
    source: np.ndarray | None,
    patch: int,
    stride: int,
    threads: int | None,
    progress: Any = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`image_metrics` and the metric objects themselves (for pictures: per-patch values, counts, r)."""
    step = _Steps(progress)
    img = as_image(image)
    notes: list[str] = []
    objs: dict[str, Any] = {}
    out: dict[str, Any] = {"input": {"width": img.shape[1], "height": img.shape[0], "channels": img.shape[2]}}
    if tile_size is None:
        out["seam"] = None
        notes.append("seam score skipped: it needs the tile grid (give the tile size)")
    else:
        with step("seam score"):
            objs["seam"] = seam_score(img, tile_size)
        out["seam"] = objs["seam"].to_dict()
        if tile_size > 2 * INNER_DEPTHS[0]:  # issue 12: lattice-parallel seams inside the tiles
            objs["inner_seam"] = inner_seam_score(img, tile_size)
        out["inner_seam"] = objs["inner_seam"].to_dict() if "inner_seam" in objs else None
    if exemplar is None:
        out["coherence"] = None
        notes.append("coherence energy skipped: it needs the exemplar")
    else:
        with step("coherence energy"):
            objs["coherence"] = coherence_energy(img, exemplar, patch, stride, threads)
        out["coherence"] = objs["coherence"].to_dict()
    if source is None or exemplar is None:
        out["coverage"] = None
        notes.append("coverage skipped: it needs the provenance of every pixel (a tile set) and the exemplar")
    else:
        with step("coverage"):
            objs["coverage"] = coverage(source, np.shape(exemplar))
        out["coverage"] = objs["coverage"].to_dict()
    t = time.perf_counter()
    with step("repetition"):
        objs["repetition"] = repetition(img)
    out["repetition"] = objs["repetition"].to_dict()
    out["repetition"]["seconds"] = time.perf_counter() - t
    if min(img.shape[:2]) >= COPY_PATCH:  # the measures of issue 12
        objs["detail_repetition"] = detail_repetition(img)
        out["detail_repetition"] = objs["detail_repetition"].to_dict()
        objs["periodic_copies"] = periodic_copies(img)
        out["periodic_copies"] = objs["periodic_copies"].to_dict()
    else:
        out["detail_repetition"] = out["periodic_copies"] = None
        notes.append(f"detail repetition and periodic copies skipped: the image is under {COPY_PATCH} pixels")
    if exemplar is not None:
        objs["histogram"] = histogram_distance(img, exemplar)
        out["histogram"] = objs["histogram"].to_dict()
    else:
        out["histogram"] = None
    out["texture_stats"] = _texture_stats(img, exemplar)  # issue 15
    out["notes"] = notes
    return out, objs


def _texture_stats(img: np.ndarray, exemplar: np.ndarray | None) -> dict[str, Any] | None:
    """``{"distance"}`` of :func:`tilesynth.measure.quality.texture_stats_distance`, None without an exemplar (or one
    too small for its filters)."""
    if exemplar is None:
        return None
    from .quality import texture_stats_distance

    try:
        return _finite({"distance": texture_stats_distance(img, exemplar)})
    except ShapeError:
        return None


def tileset_metrics(
    tileset: Any,
    width: int = DEFAULT_SAMPLE_SIZE[0],
    height: int = DEFAULT_SAMPLE_SIZE[1],
    seed: int = DEFAULT_SAMPLE_SEED,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    index_map: np.ndarray | None = None,
    progress: Any = None,
) -> dict[str, Any]:
    """All metrics of a tile set: a ``width`` x ``height`` sample synthesized with ``seed`` (or ``index_map``)
    measured by :func:`image_metrics` with its tile size, exemplar and provenance, plus the ``objective``.

    The dict also holds ``sample`` (size, seed, tiles used) and ``tileset`` (what was measured); the sample
    image is not kept: :func:`tilesynth.synthesize` with the same size and seed gives it back.
    """
    return measure_tileset(tileset, width, height, seed, patch, stride, threads, index_map, progress)[0]


def measure_tileset(
    tileset: Any,
    width: int = DEFAULT_SAMPLE_SIZE[0],
    height: int = DEFAULT_SAMPLE_SIZE[1],
    seed: int = DEFAULT_SAMPLE_SEED,
    patch: int = DEFAULT_PATCH,
    stride: int = DEFAULT_STRIDE,
    threads: int | None = None,
    index_map: np.ndarray | None = None,
    progress: Any = None,
) -> tuple[dict[str, Any], dict[str, Any]]:
    """:func:`tileset_metrics` and what it measured: ``{"image", "index_map", "source"}`` plus the metric
    objects (:class:`SeamScore`, :class:`Coherence`, :class:`Coverage`, :class:`Repetition`) by name."""
    from ..synth.synthesis import source_map, synthesize

    step = _Steps(progress)
    with step("sample synthesis"):
        img, imap = synthesize(tileset, width, height, seed=seed, index_map=index_map, threads=threads)
        src = source_map(tileset, imap, width, height)
    out, objs = _measure(img, tileset.tile_size, tileset.exemplar, src, patch, stride, threads, progress)
    out["sample"] = {
        "width": int(width),
        "height": int(height),
        "seed": None if index_map is not None else int(seed),
        "tiles": [int(imap.shape[1]), int(imap.shape[0])],
        "distinct_tiles_used": int(np.unique(imap).size),
    }
    with step("objective and cut seams"):
        out["objective"] = objective(tileset)
        out["cut_seam"] = cut_seam_score(tileset)
    out["tileset"] = {
        "scheme": tileset.scheme,
        "set": tileset.params.get("set"),
        "n_tiles": tileset.n_tiles,
        "tile_size": tileset.tile_size,
        "exemplar": tileset.exemplar_info.get("file"),
        "exemplar_shape": list(tileset.exemplar.shape),
    }
    objs.update({"image": img, "index_map": imap, "source": src})
    return out, objs


class _Steps:
    """``with step(name):`` reports ``(name, 0, 1)`` before and ``(name, 1, 1)`` after to ``progress`` (if any),
    so every metric step that takes more than a second shows up (issue 16: ``metrics`` ran minutes silently)."""

    def __init__(self, progress: Any) -> None:
        self.progress = progress

    @contextlib.contextmanager
    def __call__(self, name: str):  # noqa: ANN204
        if self.progress is not None:
            self.progress(name, 0, 1)
        yield
        if self.progress is not None:
            self.progress(name, 1, 1)


def format_metrics(m: dict[str, Any]) -> str:
    """Human-readable lines of a dict from :func:`image_metrics` / :func:`tileset_metrics`."""
    lines = _format_header(m) + _format_measures(m) + _format_objective(m)
    for note in m.get("notes", []):
        lines.append(f"note          {note}")
    return "\n".join(lines)


def _num(v: Any, fmt: str = ".4g") -> str:
    return "n/a" if v is None else format(v, fmt)


def _format_header(m: dict[str, Any]) -> list[str]:
    """What was measured: the tile set and its sample, or the image."""
    lines = []
    inp = m["input"]
    if "tileset" in m:
        t, s = m["tileset"], m["sample"]
        how = f"seed {s['seed']}" if s["seed"] is not None else "given map"
        lines.append(
            f"tile set      {t['scheme']} {t['set']}, {t['n_tiles']} tiles of {t['tile_size']}x"
            f"{t['tile_size']}, exemplar {t['exemplar'] or '?'}"
        )
        lines.append(
            f"sample        {s['width']}x{s['height']}, {how}, {s['tiles'][0]}x{s['tiles'][1]} tiles, "
            f"{s['distinct_tiles_used']} distinct"
        )
    else:
        lines.append(f"image         {inp['width']}x{inp['height']}, {inp['channels']} channel(s)")
    return lines


def _format_measures(m: dict[str, Any]) -> list[str]:
    """The image measures: seam, coherence, coverage, repetition, detail peak, copies, histograms."""
    lines = []
    sm = m.get("seam")
    if sm:
        lines.append(
            f"seam score    {_num(sm['score'], '.4f')}  (border / interior mean squared step; x "
            f"{_num(sm['ratio_x'], '.4f')}, y {_num(sm['ratio_y'], '.4f')}; tile {sm['tile_size']})"
        )
    ins = m.get("inner_seam")
    if ins:
        lines.append(
            f"inner seam    {_num(ins['max'], '.4f')}  (worst lattice-parallel line {ins['depth_of_max']:+d} px "
            f"inside the tile borders; mean over ±{len(ins['scores']) // 2} depths {_num(ins['mean'], '.4f')})"
        )
    co = m.get("coherence")
    if co:
        lines.append(
            f"coherence     {_num(co['energy'], '.5g')}  (mean min SSD of {co['patch']}x{co['patch']} "
            f"patches, stride {co['stride']}; rms {_num(co['rms'], '.4f')}; {co['n_patches']} patches, "
            f"{co['exact_copies']} exact copies, {co['searched']} searched, {co['seconds']:.2f} s)"
        )
    cv = m.get("coverage")
    if cv:
        lines.append(
            f"coverage      {_num(cv['fraction'], '.4f')} of exemplar pixels used  (evenness "
            f"{_num(cv['evenness'], '.4f')}, cv {_num(cv['cv'], '.3f')})"
        )
    rp = m.get("repetition")
    if rp:
        where = "none" if rp["offset"] is None else f"at (dy, dx) = ({rp['offset'][0]}, {rp['offset'][1]})"
        lines.append(
            f"repetition    {_num(rp['peak'], '.4f')}  (strongest non-zero autocorrelation peak, {where})"
        )
    dr = m.get("detail_repetition")
    if dr:
        where = "none" if dr["offset"] is None else f"at (dy, dx) = ({dr['offset'][0]}, {dr['offset'][1]})"
        lines.append(
            f"detail peak   {_num(dr['peak'], '.4f')}  (autocorrelation peak of the detail layer, σ "
            f"{dr['sigma']:g}, {where})"
        )
    pc = m.get("periodic_copies")
    if pc:
        lines.append(
            f"copies        {_num(pc['fraction'], '.4f')} of {pc['n_patches']} {pc['patch']}x{pc['patch']} "
            f"patches copy the patch one dominant lag away (lags {pc['lags']})"
        )
    hd = m.get("histogram")
    if hd:
        lines.append(
            f"histograms    {_num(hd['distance'], '.4f')}  (mean 1-D Wasserstein of colour channels and of "
            f"gradient magnitude at scales {hd['scales']})"
        )
    tx = m.get("texture_stats")  # issue 15
    if tx:
        lines.append(
            f"texture stats {_num(tx['distance'], '.4f')}  (relative distance of the Gram matrices of fixed random "
            "filter responses to the exemplar's)"
        )
    return lines


def _format_objective(m: dict[str, Any]) -> list[str]:
    """The tile set's own measures: the objective E, D_j, the cut costs and the cut seam."""
    lines = []
    ob = m.get("objective")
    if ob:
        d, c = ob["D"], ob["cut_costs"]
        lines.append(
            f"objective     E {_num(ob['E'], '.6g')}, f = 1/E {_num(ob['f'], '.4g')}; normalised (003) E "
            f"{_num(ob['E_normalised'], '.4g')}, f {_num(ob['f_normalised'], '.4f')}  "
            f"({ob['intermediate_tiles']} intermediate tiles, selection {ob['selection']})"
        )
        lines.append(
            f"D_j           min {_num(d['min'])}, max {_num(d['max'])}, mean {_num(d['mean'])}, std "
            f"{_num(d['std'])}, max/min {_num(d['max_over_min'], '.3g')}"
        )
        lines.append(
            f"cut costs     min {_num(c['min'])}, max {_num(c['max'])}, mean {_num(c['mean'])}, "
            f"sum {_num(c['sum'])}" + (f", cut score {_num(ob['cut_score'])}" if "cut_score" in ob else "")
        )
    cs = m.get("cut_seam")
    if cs:
        lines.append(
            f"cut seam      {_num(cs['score'], '.4f')}  (mean squared step across the cutting curves / over "
            f"all pixel pairs of the tiles; {cs['cut_pairs']} pairs on the cuts)"
        )
    return lines


# ------------------------------------------------------------------------------ vertex saliency (issue 12)
VERTEX_DISC = 0.22
"""Radius of the vertex discs of :func:`vertex_disc_radius`, as a fraction of the tile size N: the part of its
colour's sample patch that a complete set's vertex shows whole (the shared vertex content the cuts leave to the
intermediate tiles). Measured on the c5 default (q = 8) of lettuce (N = 88, 1024² output, seed 1): around the
121 inner vertices, the share of a disc's pixels copied at the vertex's own offset is ≥ 0.8 at 99 % of the
vertices for radius 18, 93 % for 20, 82 % for 22 and 20 % for 26 (median share 0.94 / 0.89 / 0.84 / 0.74).
0.22·N = 19 px there, 28 px at N = 128: a motif some 40-55 px across, what users pointed at (a curled lettuce
leaf, a cluster of stones on dry soil)."""
SALIENT_PERCENTILE = 0.9
"""Percentile of the exemplar's discs above which a disc counts as salient in :class:`RepeatedDiscs`."""
REPEAT_COUNT = 4
"""Occurrences from which :func:`repeated_discs` calls an exemplar disc repeated."""
COPY_SHARE = 0.8
"""Share of a disc's pixels that must be copied at the offset of its centre pixel for :func:`repeated_discs` to
count the disc as a copy of that exemplar disc: the four tiles' cuts nibble at the edge of the vertex content
(see :data:`VERTEX_DISC`), so whole-disc copies would miss most vertices although the motif is plainly there."""


def vertex_disc_radius(tile_size: int) -> int:
    """Radius in pixels of the vertex content of a corner tile set with tiles of ``tile_size``: round(0.22·N),
    at least 2 and at most N/2 (:data:`VERTEX_DISC`)."""
    n = positive_int(tile_size, "tile_size")
    return int(min(max(2, round(VERTEX_DISC * n)), max(1, n // 2)))


def _disc_kernel(radius: int) -> np.ndarray:
    """``(2R, 2R)`` float64 indicator of the disc of radius R centred on the window's centre (between pixels R −
    1 and R): pixel (i, j) is in when (i + 0.5 − R)² + (j + 0.5 − R)² ≤ R²."""
    t = np.arange(2 * radius, dtype=np.float64) + 0.5 - radius
    return ((t[:, None] ** 2 + t[None, :] ** 2) <= radius * radius).astype(np.float64)


def _disc_sums(x: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Σ over the disc ``kernel`` of ``x`` ``(..., H, W)`` for every window inside: ``(..., H − 2R + 1, W − 2R +
    1)``, entry (y, x) for the window with top-left (y, x) (FFT cross-correlation; no wrap reaches a valid window).
    Leading axes are planes summed alike: the kernel's spectrum is computed once for all of them."""
    x = np.asarray(x, dtype=np.float64)
    h, w = x.shape[-2:]
    k = kernel.shape[0]
    fh, fw = _fft_size(h), _fft_size(w)
    spec = np.conj(np.fft.rfft2(kernel, s=(fh, fw)))
    # one plane at a time (the same transforms, the same bits): the spectra of all planes at once were the
    # peak of a default 2048² build (six planes: 3 x 200 MB of spectra and padded results)
    planes = x.reshape(-1, h, w)
    out = np.empty((planes.shape[0], h - k + 1, w - k + 1))
    for i, plane in enumerate(planes):
        out[i] = np.fft.irfft2(np.fft.rfft2(plane, s=(fh, fw)) * spec, s=(fh, fw))[: h - k + 1, : w - k + 1]
    return out.reshape(*x.shape[:-2], h - k + 1, w - k + 1)


class DiscSaliency:
    """How unusual every disc of radius ``radius`` of an exemplar is among all the exemplar's discs of that
    radius (issue 12: the vertex content of a complete set).

    Each disc (every window of ``2R`` x ``2R`` pixels inside the exemplar, the inscribed disc) is described by
    its mean colour (the first three channels; one for grey), its luminance standard deviation (coarse local
    contrast: a bright leaf on dark shadow) and the root mean square of its detail layer (:func:`detail_layer`,
    the fine structure at σ = 8: a cluster of small stones). The saliency of a disc is its Mahalanobis distance
    from the mean of these features over *all* the exemplar's discs (their covariance: colour channels are
    strongly correlated), and its percentile the share of the exemplar's discs that are closer to the mean.
    Percentile 0.5 is a typical disc of the texture; near 1 it is one of the texture's few outliers, the kind of
    content an eye picks out when it recurs at every vertex of one colour. Cost: five FFT correlations of the
    exemplar's size and a sort; then O(1) per look-up (:meth:`at`).
    """

    def __init__(
        self,
        exemplar: np.ndarray,
        radius: int,
        *,
        luminance: np.ndarray | None = None,
        detail: np.ndarray | None = None,
    ) -> None:
        """``luminance`` / ``detail``: the exemplar's :func:`luminance` and :func:`detail_layer` when the caller
        has them already (a build's :class:`~tilesynth.builder.exemplar.Exemplar`), else computed here."""
        img = as_image(exemplar, "exemplar").astype(np.float64)
        r = positive_int(radius, "radius")
        h, w, c = img.shape
        if 2 * r > min(h, w):
            raise ParameterError(f"radius = {r}: a disc of {2 * r} px does not fit the {w}x{h} exemplar")
        k = _disc_kernel(r)
        area = float(k.sum())
        lum = _luminance(img) if luminance is None else luminance
        det = detail_layer(img) if detail is None else detail
        nc = min(c, 3)
        planes = np.concatenate([np.moveaxis(img[..., :nc], -1, 0), np.stack([lum, lum * lum, det * det])])
        sums = _disc_sums(planes, k)  # the channel means, then E[lum], E[lum²], E[det²] over each disc
        del planes  # exemplar-sized: not kept through the features (the peak of a 2048² build)
        sums /= area
        m1, m2, e_det = sums[nc], sums[nc + 1], sums[nc + 2]
        contrast = np.sqrt(np.maximum(m2 - m1 * m1, 0.0))
        f = np.stack([*sums[:nc], contrast, np.sqrt(np.maximum(e_det, 0.0))], axis=-1)  # (H', W', F)
        flat = f.reshape(-1, f.shape[-1])
        self.radius = r
        self.shape = f.shape[:2]
        self._mean = flat.mean(axis=0)
        cov = np.atleast_2d(np.cov(flat, rowvar=False))
        self._prec = np.linalg.pinv(cov + np.eye(cov.shape[0]) * 1e-12 * max(float(np.trace(cov)), 1e-300))
        d = self._distance(flat)
        self.distances = d.reshape(self.shape)
        self._sorted = np.sort(d)

    def _distance(self, feats: np.ndarray) -> np.ndarray:
        z = feats - self._mean
        return np.sqrt(np.maximum(np.einsum("ni,ij,nj->n", z, self._prec, z), 0.0))

    def at(self, rows: Any, cols: Any) -> tuple[np.ndarray, np.ndarray]:
        """(Mahalanobis distance, percentile) of the discs whose windows have top-left (``rows``, ``cols``)."""
        r = np.asarray(rows, dtype=np.int64)
        c = np.asarray(cols, dtype=np.int64)
        if np.any((r < 0) | (c < 0) | (r >= self.shape[0]) | (c >= self.shape[1])):
            raise ParameterError(
                f"disc windows outside the exemplar's {self.shape[1]}x{self.shape[0]} positions"
            )
        d = self.distances[r, c]
        pct = np.searchsorted(self._sorted, d, side="left") / self._sorted.size
        return d, pct

    def at_patches(self, genes: np.ndarray, tile_size: int) -> tuple[np.ndarray, np.ndarray]:
        """(distance, percentile) of the centre discs of the ``tile_size`` sample patches with top-left corners
        ``genes`` ``(n, 2)``: the discs every vertex of their colour shows (centred between patch pixels N/2 −
        1 and N/2)."""
        g = np.asarray(genes, dtype=np.int64).reshape(-1, 2)
        off = int(tile_size) // 2 - self.radius
        return self.at(g[:, 0] + off, g[:, 1] + off)


def vertex_saliency(exemplar: np.ndarray, genes: np.ndarray, tile_size: int) -> tuple[np.ndarray, np.ndarray]:
    """(Mahalanobis distance, percentile) of the centre disc of each sample patch (``genes``: top-left corners,
    ``(n, 2)``) among all the exemplar's discs of radius :func:`vertex_disc_radius` ``(tile_size)``: see
    :class:`DiscSaliency`. For a complete set the percentile of its most salient colour is what a user sees
    repeat at a fifth (c5) of the lattice vertices."""
    return DiscSaliency(exemplar, vertex_disc_radius(tile_size)).at_patches(genes, tile_size)


@dataclass(frozen=True)
class RepeatedDiscs:
    """Discs of the output that are exact copies of one exemplar disc, counted by provenance (:func:`repeated_discs`).

    ``most_repeated``: occurrences of the most repeated exemplar disc; ``repeated``: distinct exemplar discs
    found at ``min_count`` places or more; ``max_percentile`` / ``max_distance``: the saliency (:class:`DiscSaliency`)
    of the most salient of those; ``salient_repeats``: how many output discs are copies of a repeated disc above
    :data:`SALIENT_PERCENTILE`, per 100 disc centres of the grid (0 = nothing salient repeats)."""

    most_repeated: int
    repeated: int
    max_percentile: float
    max_distance: float
    salient_repeats: float
    radius: int
    stride: int
    centres: int

    def to_dict(self) -> dict[str, Any]:
        return _finite(asdict(self))


def repeated_discs(
    source: np.ndarray,
    exemplar: np.ndarray,
    radius: int,
    stride: int = 8,
    min_count: int = REPEAT_COUNT,
    saliency: DiscSaliency | None = None,
) -> RepeatedDiscs:
    """Repeated salient motifs of an output, from its exact provenance ``source`` (int ``(H, W, 2)``, the
    exemplar (row, col) of every pixel, :func:`tilesynth.source_map`).

    Discs of radius ``radius`` centred on the points (k·stride, l·stride) (between pixels, as a tile vertex) are
    looked at; a disc is a copy of the exemplar disc at its centre pixel's offset (source − position) when at
    least :data:`COPY_SHARE` of its pixels have that offset (the cuts of the tiles around a vertex nibble at its
    edge). Copies are grouped by the exemplar disc they copy; what recurs ``min_count`` times or more is repeated, and each repeated disc is rated by its saliency
    among all the exemplar's discs of that radius (:class:`DiscSaliency`). Why: a corner-tile set repeats its
    vertex content at every vertex of one colour whatever its sample patches are; whether a user sees it depends
    on what that content is, a typical piece of the texture or a motif that stands out. Neither the periodic
    copies (lags of the autocorrelation) nor the autocorrelation peak say which. Cost: O(H·W·R²/stride²) integer
    comparisons (1024² output, R = 26, stride 8: 35 M) and a look-up per disc."""
    src = np.asarray(source)
    if src.ndim != 3 or src.shape[2] != 2:
        raise ShapeError(f"source of shape {src.shape}: need (H, W, 2)")
    r = positive_int(radius, "radius")
    s = positive_int(stride, "stride")
    sal = saliency if saliency is not None else DiscSaliency(exemplar, r)
    if sal.radius != r:
        raise ParameterError(f"saliency of radius {sal.radius} for discs of radius {r}")
    h, w = src.shape[:2]
    if h < 2 * r or w < 2 * r:
        raise ShapeError(f"source is {w}x{h}: discs of radius {r} need at least {2 * r} px")
    yy, xx = np.mgrid[0:h, 0:w]
    oy = src[..., 0].astype(np.int64) - yy
    ox = src[..., 1].astype(np.int64) - xx
    k = _disc_kernel(r).astype(bool)
    area = int(k.sum())
    first = -(-r // s) * s  # centres at the multiples of the stride whose disc is inside the output
    cy = np.arange(first, h - r + 1, s)
    cx = np.arange(first, w - r + 1, s)
    gy, gx = np.meshgrid(cy, cx, indexing="ij")
    win_y = np.lib.stride_tricks.sliding_window_view(oy, (2 * r, 2 * r))
    win_x = np.lib.stride_tricks.sliding_window_view(ox, (2 * r, 2 * r))
    share = np.empty(gy.shape)
    for i in range(gy.shape[0]):  # one row of centres at a time: (cols, 2R, 2R) offsets
        y0, x0 = gy[i] - r, gx[i] - r
        same = (win_y[y0, x0] == oy[gy[i], gx[i], None, None]) & (
            win_x[y0, x0] == ox[gy[i], gx[i], None, None]
        )
        share[i] = (same & k).sum(axis=(1, 2)) / area
    ok = share >= COPY_SHARE
    ty = src[gy, gx, 0].astype(np.int64) - r  # the copied exemplar window's top-left
    tx = src[gy, gx, 1].astype(np.int64) - r
    ok &= (ty >= 0) & (tx >= 0) & (ty < sal.shape[0]) & (tx < sal.shape[1])
    keys = ty[ok] * sal.shape[1] + tx[ok]
    centres = int(gy.size)
    if keys.size == 0:
        return RepeatedDiscs(0, 0, math.nan, math.nan, 0.0, r, s, centres)
    uk, cnt = np.unique(keys, return_counts=True)
    rep = cnt >= int(min_count)
    if not rep.any():
        return RepeatedDiscs(int(cnt.max()), 0, math.nan, math.nan, 0.0, r, s, centres)
    d, pct = sal.at(uk[rep] // sal.shape[1], uk[rep] % sal.shape[1])
    i = int(np.argmax(d))
    salient = float(cnt[rep][pct > SALIENT_PERCENTILE].sum())
    return RepeatedDiscs(
        most_repeated=int(cnt.max()),
        repeated=int(rep.sum()),
        max_percentile=float(pct[i]),
        max_distance=float(d[i]),
        salient_repeats=100.0 * salient / centres,
        radius=r,
        stride=s,
        centres=centres,
    )


__all__ = [
    "DiscSaliency",
    "RepeatedDiscs",
    "repeated_discs",
    "vertex_disc_radius",
    "vertex_saliency",
    "INNER_DEPTHS",
    "InnerSeamScore",
    "inner_seam_score",
    "DetailRepetition",
    "HistogramDistance",
    "PeriodicCopies",
    "detail_layer",
    "detail_repetition",
    "histogram_distance",
    "periodic_copies",
    "RepeatedPatches",
    "repeated_patches",
    "Coherence",
    "Coverage",
    "Repetition",
    "SeamScore",
    "autocorrelation",
    "coherence_energy",
    "coverage",
    "cut_seam_score",
    "format_metrics",
    "image_metrics",
    "measure_tileset",
    "objective",
    "repetition",
    "seam_profiles",
    "seam_score",
    "tileset_metrics",
]
