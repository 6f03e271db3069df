"""Levers against repetition in ω-tiles (issue 12, item 6): a free cut region and diverse matching patches.

Every vertex of colour c shows the centre of the same sample patch, so the content that tiles share (what the
ω cut keeps of the intermediate tile) sits on the lattice and repeats; the content unique to a tile is its
matching patch O. Two build options of :func:`tilesynth.build_omega` move that balance:

``cut_region="free"`` (:func:`free_cuts`)
    The ω cut of 002 keeps everything outside the inscribed circle (at least 21.5 % of the tile, its corners)
    from the intermediate tile. Here the terminals are instead: sources = a border ring of ``ring`` pixels
    (default 2) and a disc of radius ``disc`` (default N/8) around each tile corner; sinks = the intermediate
    tile's central cross (where its four sample quadrants meet), minus the sources. Everything else is free,
    so the min cut (Kwatra weights, the same as the circle's, by the general grid min cut
    :func:`tilesynth.kernels.grid_mincut`) may give most of the tile to O. The tile border is still the
    intermediate tile's (the ring), so neighbouring tiles match exactly as before. Left alone the min cut
    stays close to the cross (a short cut is cheap); ``cut_bias`` (default :data:`FREE_BIAS`) rewards the area
    given to O so the cut moves outwards.

``diversity=m`` (:func:`diverse_matches`)
    Instead of each intermediate tile's independent best matching patch, the matching patches are assigned
    greedily (tiles in the order of their best distance, then variants) among each tile's ``DIVERSE_CANDIDATES``
    best translations: a candidate is skipped while some already chosen patch lies within N/2 pixels
    (Chebyshev) of it ``m`` times or more (each exemplar region used a bounded number of times). If every
    candidate is used up the least used one is taken. m = 1 makes the patches pairwise more than N/2 apart as
    far as the candidates allow.

Both cost seam quality (a longer cut through less similar content; a worse match than the best): the bench
``benches/repetition.py`` measures what each buys.
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .errors import ParameterError

CUT_REGIONS = ("circle", "free")
"""Values of ``cut_region``."""
DIVERSE_CANDIDATES = 24
"""Candidate translations per intermediate tile of :func:`diverse_matches`."""


def free_terminals(n: int, ring: int | None = None, disc: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(source, sink) bool masks ``(n, n)`` of the free cut region (see the module docstring).

    Defaults: ``ring`` 2 pixels (1 for tiles under 16 pixels), ``disc`` N/8 (at least 1, below N/2)."""
    if ring is None:
        ring = 2 if n >= 16 else 1
    if disc is None:
        disc = min(max(1, n // 8), n // 2 - 1)
    if not (1 <= ring <= n // 2 - 1) or not (0 <= disc < n // 2):
        raise ParameterError(
            f"ring = {ring}, disc = {disc}: need 1 <= ring <= N/2 - 1 and 0 <= disc < N/2 (N = {n})"
        )
    yy, xx = np.mgrid[0:n, 0:n]
    src = (yy < ring) | (yy >= n - ring) | (xx < ring) | (xx >= n - ring)
    c = n - 1
    for cy, cx in ((0, 0), (0, c), (c, 0), (c, c)):
        src |= (yy - cy) ** 2 + (xx - cx) ** 2 <= disc * disc
    a, b = n // 2 - 1, n // 2
    sink = ((yy == a) | (yy == b) | (xx == a) | (xx == b)) & ~src
    return src, sink


FREE_BIAS = 0.02
"""Default area reward of the free cut region (see :func:`free_cuts`). Measured on grass (c3x2, 128-px tiles,
diversity 1, 512² output): bias 0 gives O 52 % of the tile (the cut hugs the cross as the circle's does) and
copies 0.24; 0.02 gives O 75 %, copies 0.05, autocorrelation peak 0.12, coverage 0.56, cut seam score 5.1
(circle 4.4-4.8); 0.05 and more push the cut onto the border ring (O 83-90 %), where it shows as a square grid
of straight seams two pixels inside the tile borders that the border seam score does not see."""


def free_cuts(
    intermediate: np.ndarray,
    matching: np.ndarray,
    eps: float,
    grad: np.ndarray | None,
    ring: int | None = None,
    disc: int | None = None,
    bias: float = FREE_BIAS,
) -> tuple[np.ndarray, np.ndarray]:
    """Masks ``(K, N, N)`` (True = take O) and cut costs of the free cut region, one grid min cut per tile.

    ``bias`` > 0 rewards area given to O: every free pixel gets a sink t-link of ``bias`` times the tile's mean
    edge weight, so the cut moves outwards where the seam there costs little more (the reported cost is then
    the cut's edge weights plus the rewards it forgoes)."""
    k, n = intermediate.shape[:2]
    src, sink = free_terminals(n, ring, disc)
    free = ~src & ~sink
    masks = np.zeros((k, n, n), bool)
    costs = np.zeros(k)
    for j in range(k):
        wx, wy = kernels.kwatra_weights(
            intermediate[j], matching[j], eps=eps, a_grad=None if grad is None else grad[j]
        )
        cap = None
        if bias > 0:
            mean_w = float(np.concatenate([wx[:, :-1].ravel(), wy[:-1].ravel()]).mean())
            cap = np.where(free, bias * mean_w, 0.0)
        masks[j], costs[j] = kernels.grid_mincut(wx, wy, src, sink, sink_cap=cap)
    return masks, costs


def diverse_matches(
    ex: np.ndarray, inter: np.ndarray, n_variants: int, max_uses: int, threads: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Matching offsets ``(U, V, 2)`` and their SSD ``(U, V)`` under the diversity constraint (module docstring).

    Variants of one tile also stay more than N/4 apart (the candidates are N/4-separated already)."""
    if not isinstance(max_uses, (int, np.integer)) or isinstance(max_uses, bool) or max_uses < 1:
        raise ParameterError(f"diversity = {max_uses!r}: must be a positive int (uses per exemplar region)")
    n = inter.shape[1]
    k = max(DIVERSE_CANDIDATES, n_variants)
    offsets, ssd = kernels.best_matches(ex, inter, k=k, exclude_radius=n // 4, threads=threads)
    if offsets.shape[1] < n_variants:
        raise ParameterError(
            f"tile_size = {n}: the exemplar has too few distinct translations for {n_variants} matching patches"
        )
    u = inter.shape[0]
    chosen = np.zeros((u, n_variants, 2), np.int64)
    chosen_d = np.zeros((u, n_variants))
    used = np.zeros((u * n_variants, 2), np.int64)  # the offsets assigned so far: used[:m]
    m = 0
    radius = n // 2
    for v in range(n_variants):
        for t in np.argsort(ssd[:, min(v, ssd.shape[1] - 1)], kind="stable"):
            cand = offsets[t]  # (J, 2), nearest first
            free = ~(cand[:, None, :] == chosen[t, None, :v, :]).all(axis=2).any(axis=1)  # not a variant yet
            # uses of each candidate's region: assigned offsets within `radius` (Chebyshev), all at once
            uses = (np.abs(cand[:, None, :] - used[None, :m, :]).max(axis=2) <= radius).sum(axis=1)
            ok = free & (uses < max_uses)
            # the first candidate under the bound, else the first of the least used
            best = (
                int(np.argmax(ok))
                if ok.any()
                else int(np.argmin(np.where(free, uses, np.iinfo(np.int64).max)))
            )
            assert free[best]
            chosen[t, v] = cand[best]
            chosen_d[t, v] = ssd[t, best]
            used[m] = cand[best]
            m += 1
    return chosen, chosen_d
