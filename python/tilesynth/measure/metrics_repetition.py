"""Non-periodicity metrics of :mod:`tilesynth.measure.metrics`: the normalised autocorrelation and its
strongest peak, luminance and detail layer, the detail-layer repetition, periodic copies and repeated patches."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..base.validate import as_image, positive_int
from ..errors import ParameterError, ShapeError
from .metrics_coherence import _float_bits
from .metrics_common import _HASH_SEED, _finite
from .quality import _fast_len as _fft_size  # smallest 2^a·3^b·5^c >= n (fast FFT lengths)


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


# -------------------------------------------------------------------------------------------- non-periodicity
COPY_PATCH = 16
"""Side of the grid patches of :func:`periodic_copies`."""
COPY_TOLERANCE = (2.0 / 255.0) ** 2
"""Mean squared difference at or below which a grid patch is a copy of its partner one lag away."""
COPY_LAGS = 4
"""How many of the strongest autocorrelation lags :func:`periodic_copies` tries (each with its opposite)."""
DETAIL_SIGMA = 8.0
"""σ of the Gaussian blur subtracted from the luminance to get the detail layer."""


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
    a 16a output's patches were such copies, image quilting 0-5 %.
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
    the same sample patch), a matching patch used by several tiles, a tile drawn twice, a quilting
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
