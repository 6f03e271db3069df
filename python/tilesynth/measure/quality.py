"""Visible quality of a tile set: the robust cut score that selection can optimise and the
texture-statistics distance (the measures stored with every build are joined in :mod:`tilesynth.measure.build_measures`).

**The cut score** (:func:`cut_score`). The selection papers' E = λ·ΣD_j + (1−λ)·Var(D_j) follows what users see
only weakly (Spearman +0.2 to +0.4 with cut cost, cut seam and coherence over random gene vectors; Var(D) is even
anti-correlated). What the user sees is the seam of each tile's cutting curve, whose price is the real min-cut
cost c_j of the tile. Raw cut costs have heavy tails: with Kwatra's ε = 1e-6 in the edge weight, a tile whose
cut has to cross a flat saturated region (grapes: black shadows) costs 2·10⁶ where the others cost tens, and a sum
or mean would rank gene vectors by that one tile alone. The score is therefore the geometric mean

    S = exp( mean_j log(c_j + ε_S) ),   ε_S = :data:`CUT_SCORE_EPS` · N,

i.e. a log-sum: a blow-up tile weighs log(2·10⁶) ≈ 14.5 instead of 10⁵ times the others, and is still penalised.
ε_S keeps log finite for a zero-cost cut (O equal to I along the whole curve, e.g. a patch matched onto itself)
and stops such a cut from pulling the score to −∞: a cut over N edges whose weights are below 1 % of a typical
weight counts as good, not as infinitely good.

**Texture statistics** (:func:`texture_stats_distance`): the relative Frobenius distance between the Gram matrices
(second moments) of the rectified responses of fixed random filters, image vs exemplar, at two scales. It grows
when a synthesis loses a structure of the exemplar or adds one (straight seams, repeated blobs).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ..base.validate import as_image
from ..errors import ShapeError

__all__ = [
    "CUT_SCORE_EPS",
    "TEXSTATS_FILTERS",
    "cut_score",
    "texture_stats_distance",
]

CUT_SCORE_EPS = 0.01
"""ε_S of :func:`cut_score` per pixel of tile side: ε_S = 0.01·N (cost units of the Kwatra weights)."""

TEXSTATS_FILTERS = 24
"""Number of fixed random 7 x 7 filters of :func:`texture_stats_distance`."""

TEXSTATS_SEED = 15
TEXSTATS_SIZE = 7
TEXSTATS_SCALES = (1, 2)


def cut_score(costs: Any, tile_size: int) -> float:
    """The geometric mean of the cut costs ``c_j + ε_S`` (ε_S = :data:`CUT_SCORE_EPS` · ``tile_size``; see the
    module docstring). Smaller is better. Non-finite costs count as +inf."""
    c = np.asarray(costs, dtype=np.float64).ravel()
    if c.size == 0:
        return float("nan")
    if not np.isfinite(c).all():
        return float("inf")
    eps = CUT_SCORE_EPS * float(tile_size)
    return float(np.exp(np.mean(np.log(np.maximum(c, 0.0) + eps))))


def _filters(channels: int) -> np.ndarray:
    rng = np.random.default_rng(TEXSTATS_SEED)
    f = rng.standard_normal((TEXSTATS_FILTERS, TEXSTATS_SIZE, TEXSTATS_SIZE, channels))
    f -= f.mean(
        axis=(1, 2, 3), keepdims=True
    )  # zero mean: insensitive to the mean colour (histograms see it)
    f /= np.sqrt((f * f).sum(axis=(1, 2, 3), keepdims=True))
    return f


def _fast_len(n: int) -> int:
    """The smallest 2^a·3^b·5^c >= n (an FFT size numpy's pocketfft transforms fast)."""
    best = 1 << max(n - 1, 0).bit_length()
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best


@functools.lru_cache(maxsize=8)
def _filter_spectra(channels: int, fh: int, fw: int) -> np.ndarray:
    """``(C, F, fh, fw // 2 + 1)`` spectra of the flipped filters (cached: every image of one size shares them)."""
    filt = _filters(channels)[:, ::-1, ::-1, :].transpose(3, 0, 1, 2)
    return np.fft.rfft2(filt, s=(fh, fw), axes=(2, 3))


def _responses(img: np.ndarray) -> np.ndarray:
    """``(F, P)``: the 'valid' responses of the fixed filters to ``img``, one row per filter (pixels flattened)."""
    h, w, c = img.shape
    k = TEXSTATS_SIZE
    fh, fw = _fast_len(h + k - 1), _fast_len(w + k - 1)
    spec = np.fft.rfft2(img.transpose(2, 0, 1), s=(fh, fw), axes=(1, 2))
    kern = _filter_spectra(c, fh, fw)
    acc = spec[0][None] * kern[0]
    for ch in range(1, c):
        acc += spec[ch][None] * kern[ch]
    resp = np.fft.irfft2(acc, s=(fh, fw), axes=(1, 2))[:, k - 1 : h, k - 1 : w]  # the 'valid' part
    return resp.reshape(resp.shape[0], -1)


def _rectified_gram(resp: np.ndarray) -> np.ndarray:
    """Gram matrix ``(F+1, F+1)`` of rectified responses ``(F, P)`` plus a constant feature (so the means are in
    it too)."""
    r = np.empty((resp.shape[0] + 1, resp.shape[1]))
    np.maximum(resp, 0.0, out=r[:-1])
    r[-1] = 1.0
    # einsum, not BLAS: a threaded BLAS on a loaded machine took seconds for this 25 x 25 product
    return np.einsum("ip,jp->ij", r, r) / r.shape[1]


GRAM_BLOCK = 250
"""Output rows and columns per block of :func:`blocked_gram`: with the 7 x 7 filters its input blocks are 256
pixels a side, an FFT size pocketfft transforms fast."""


def blocked_gram(img: np.ndarray, block: int = GRAM_BLOCK) -> np.ndarray:
    """:func:`_rectified_gram` of :func:`_responses` of ``img`` (``(H, W, C)``, at least 7 x 7), computed a block
    of ``block`` x ``block`` valid responses at a time: the same matrix up to rounding, in memory bounded by the
    block instead of the image. Why: the responses of a whole 2048² exemplar are 24 x 4.2 M float64 (805 MB),
    and its filter spectra and product took 4.4 GB more, the peak of a default 2048² build."""
    h, w, _ = img.shape
    k = TEXSTATS_SIZE
    vh, vw = h - k + 1, w - k + 1
    acc = np.zeros((TEXSTATS_FILTERS + 1, TEXSTATS_FILTERS + 1))
    for y in range(0, vh, block):
        for x in range(0, vw, block):
            part = img[y : min(vh, y + block) + k - 1, x : min(vw, x + block) + k - 1]
            resp = _responses(part)
            acc += _rectified_gram(resp) * resp.shape[1]
    return acc / (vh * vw)


def _gram(img: np.ndarray) -> np.ndarray:
    """Gram matrix ``(F+1, F+1)`` of the rectified 'valid' responses plus a constant feature."""
    h, w, _ = img.shape
    k = TEXSTATS_SIZE
    if h < k or w < k:
        raise ShapeError(f"image of {h}x{w} pixels: too small for the {k}x{k} texture-statistics filters")
    return _rectified_gram(_responses(img))


def _down(img: np.ndarray, f: int) -> np.ndarray:
    if f == 1:
        return img
    h, w = (img.shape[0] // f) * f, (img.shape[1] // f) * f
    return img[:h, :w].reshape(h // f, f, w // f, f, -1).mean(axis=(1, 3))


def texture_stats_distance(image: Any, exemplar: Any) -> float:
    """Texture-statistics distance of ``image`` to ``exemplar`` (0 = the same statistics; see the module
    docstring): mean over the scales 1 and 2 of ‖G_image − G_exemplar‖_F / ‖G_exemplar‖_F, G the Gram matrix of
    the rectified responses of :data:`TEXSTATS_FILTERS` fixed random zero-mean filters (seed fixed, so values are
    comparable across builds). Scales at which the exemplar is smaller than a filter are skipped."""
    img = as_image(image).astype(np.float64)
    ex = as_image(exemplar, "exemplar").astype(np.float64)
    if img.shape[2] != ex.shape[2]:
        raise ShapeError(f"image has {img.shape[2]} channels, exemplar {ex.shape[2]}")
    if min(img.shape[:2] + ex.shape[:2]) < TEXSTATS_SIZE:
        raise ShapeError(
            f"image {img.shape[1]}x{img.shape[0]}, exemplar {ex.shape[1]}x{ex.shape[0]}: the texture statistics "
            f"need at least {TEXSTATS_SIZE}x{TEXSTATS_SIZE} pixels"
        )
    out = []
    for f in TEXSTATS_SCALES:
        a, b = _down(img, f), _down(ex, f)
        if min(a.shape[:2] + b.shape[:2]) < TEXSTATS_SIZE:
            continue
        ga, gb = _gram(a), _gram(b)
        out.append(float(np.linalg.norm(ga - gb) / max(np.linalg.norm(gb), 1e-300)))
    if not out:
        raise ShapeError(f"image or exemplar under {TEXSTATS_SIZE} pixels: no texture statistics")
    return float(np.mean(out))
