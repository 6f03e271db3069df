"""Vertex saliency of :mod:`tilesynth.measure.metrics`: the discs at the tile vertices, their saliency in the
exemplar, and the salient exemplar discs an output repeats."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from ..base.validate import as_image, positive_int
from ..errors import ParameterError, ShapeError
from .metrics_common import _finite
from .metrics_repetition import _luminance, detail_layer
from .quality import _fast_len as _fft_size  # smallest 2^a·3^b·5^c >= n (fast FFT lengths)

# -------------------------------------------------------------------------------------------- vertex saliency
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
    radius (the vertex content of a complete set).

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
