"""Levers against repetition in ω-tiles: a free cut region and diverse matching patches.

Every vertex of colour c shows the centre of the same sample patch, so the content that tiles share (what the
ω cut keeps of the intermediate tile) sits on the lattice and repeats; the content unique to a tile is its
matching patch O. Two build options of :func:`tilesynth.build_omega` move that balance:

``cut_region="free"`` (:func:`free_cuts`)
    The ω cut of 002 keeps everything outside the inscribed circle (at least 21.5 % of the tile, its corners)
    from the intermediate tile. Here the terminals are instead: sources = a border ring of ``ring`` pixels
    (default :data:`RING` = 1) and a disc of radius ``disc`` (default N/8) around each tile corner; sinks = the
    intermediate tile's central cross (where its four sample quadrants meet), minus the sources. Everything
    else is free, so the min cut (Kwatra weights, the same as the circle's, by the general grid min cut
    :func:`tilesynth.base.kernels.grid_mincut`) may give most of the tile to O. The tile border is still the
    intermediate tile's (the ring), so neighbouring tiles match exactly as before.

    On a 4-connected grid every monotone path from one side midpoint (where the cross meets the ring) to the
    next has the same length, so left alone the cut wanders with the content, often close to the cross. Two
    terms shape it (:func:`free_weights`):

    - an *area reward* for giving pixels to O (a sink t-link of ``cut_bias`` times the tile's mean edge
      weight per pixel, default :func:`default_bias` = 32/N), full inside the rounded square ρ ≤ 1/2 and
      tapering linearly to 0 next to the ring, where ρ = (|u|^q + |v|^q)^(1/q) is the superellipse radius of the
      pixel (u, v = its offsets from the tile centre in units of N/2, q = :data:`SUPERELLIPSE` = 8): the cut
      moves outwards, into the corners more than a circle would, but nothing presses it onto the ring (the
      taper ends :data:`REWARD_GAP` = 2 pixels inside the ring, so the rows beside it earn nothing);
    - a *ring penalty* on the edges whose cut would run parallel to a tile border near it: their weight is
      multiplied by 1 + :data:`RING_PENALTY`·(1 − t)², t = (depth − ring) / (N/4) clipped to [0, 1] (depth =
      pixels from that border), smooth at both ends so that no depth is a preferred resting line.

    Measured (``benches/repetition.py``): with a uniform reward over the whole free region (the
    first version, kept as ``cut_region="ring"``, reward 0.02) the cut lay on the ring along most of every
    tile side and drew a square grid of straight seams two pixels inside the tile borders (inner-lattice seam
    score :func:`tilesynth.measure.metrics.inner_seam_score` 4.7 on cracked mud, a normal pixel step is 1); the
    tapered reward without the penalty still left 3.1 (the tie of equal-length paths), the penalty brings it to
    1.4-1.6 at a cost of a few points of O's share (0.71 instead of 0.78 of the tile on cracked mud).

``cut_region="free8"`` (:func:`free_cuts`, opt-in: measured no better than ``"free"``, the default)
    The same terminals, reward and ring penalty as ``"free"``, cut on an 8-connected grid whose cost
    approximates the Euclidean length of the cut instead of its L1 length. On the 4-connected grid every
    monotone staircase between two points costs as much as the straight diagonal, so the cut follows
    content edges in long axis-aligned runs joined by right-angle steps of a few pixels, and tiles are hard
    copies: where a bright part of O meets darker vertex content each step shows as a notch
    (``benches/repetition-results.md``). The edge weights are Boykov & Kolmogorov's geo-cut weights
    ("Computing geodesics and minimal surfaces via graph cuts", ICCV 2003: ``w_k = δ² Δφ_k / (2 |e_k|)``,
    Δφ = π/4 for the 8-neighbourhood) times the local seam cost, scaled so that a straight axis-aligned cut
    through content of unit Kwatra weight costs 1 per pixel as on the 4-connected grid (the reward and the
    penalty keep their calibration): :data:`GEO_AXIS` = √2 − 1 for the axis edges, :data:`GEO_DIAG` =
    1 − 1/√2 for the diagonals. A 45° cut then also costs its length (4-connected: √2 times it), at 22.5°
    8 % more (the metrication error of the 8-neighbourhood). The paper's metric is a density evaluated at
    the edge; for a diagonal edge the Kwatra weights need a gradient along the diagonal that the patch
    gradients of the ω construction do not hold, so its density is the mean of the four (penalised) Kwatra
    weights of the axis edges of the pixel square it crosses (the density at the square's centre, where
    both diagonals cross). Consequence: the ring penalty acts at about 3/4 strength on a cut parallel to a
    border (its diagonal share averages a penalised and an unpenalised pair).

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

from ...base import kernels
from ...errors import ParameterError

CUT_REGIONS = ("circle", "free", "free8", "ring")
"""Values of ``cut_region``."""
DIVERSE_CANDIDATES = 32
"""Candidate translations per intermediate tile of :func:`diverse_matches` (24 before self-matches were
excluded; 32 keeps the c2 test set of 16 tiles pairwise more than N/2 apart)."""


def free_terminals(n: int, ring: int | None = None, disc: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(source, sink) bool masks ``(n, n)`` of the free cut region (see the module docstring).

    Defaults: ``ring`` :data:`RING` pixels, ``disc`` N/8 (at least 1, below N/2)."""
    if ring is None:
        ring = RING
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


FREE_BETA = 16.0
"""Area reward of ``cut_region="free"`` at the tile centre, in units of (mean edge weight) / (N/2) per pixel:
:func:`default_bias` is FREE_BETA / (N/2). Scale-free, so the cut takes the same shape at every tile size
(a reward that beats a cut moved outwards by one pixel along a circle of radius ρ·N/2 where FREE_BETA·ρ·f(ρ)
> 1). Chosen with the bench among 4, 8 and 16 (16: the largest share of O without a lattice seam)."""
RING_BIAS = 0.02
"""Uniform area reward of ``cut_region="ring"`` (the first free region, kept for comparison)."""
RING_PENALTY = 3.0
"""Extra weight factor, at the ring, of the cut edges parallel to a nearby tile border (see the module
docstring); it falls to 0 at N/4 inside. 3 and 6 were measured: 6 shrinks O with no further gain."""
RING = 1
"""Width in pixels of the border ring tied to the intermediate tile (the free cut region's sources besides the
corner discs): the tile borders stay the vertex patches' own, so neighbouring tiles meet seamlessly. It was 2
for tiles of 16 px and more until issue 29; see :data:`REWARD_GAP` for why it is 1."""
REWARD_GAP = 2
"""Pixels next to the ring that get no area reward: the taper of :func:`free_weights` reaches 0 at depth
``ring + REWARD_GAP`` (3 px) instead of at the ring (tiles under 4·(ring + REWARD_GAP) px keep the ring as the
end).

Why (issue 29): with a 2-px ring and the reward still positive on the first free row, the cut was paid to lay
the matching patch against the ring wherever its seam there is cheap in Kwatra's gradient-normalised units,
which on high-contrast object photos it often is: the O/ring boundary became a straight line at the same depth
in every tile, the worst phase of the lattice (gradient) (grapes 8.1, crackers 9.2), seen as a grid of bright
and dark lines; and the 4-px straight seam where the two vertex patches of an edge meet inside the rings (2 px on
each side of the border) drew the side midpoints (caustics, sea foam). Measured (1024², seed 1, default c5,
``benches/lattice-results.md``), ring / reward end before -> ring 2, end 3 -> ring 1, end 3: lattice (gradient)
grapes 8.09 -> 4.58 -> 4.10, crackers 9.15 -> 7.22 -> 7.14, tomatoes 4.47 -> 3.11 -> 2.96, chalk text 4.32 ->
3.24 -> 3.00, caustics 3.60 -> 3.57 -> 2.60, sea foam 3.74 -> 3.75 -> 2.75; on 13 stochastic textures of
``../shared/textures`` periodic copies / autocorrelation peak / texture statistics (means) +1.4 / +2.2 / +1.4 %
and +2.0 / −1.1 / +0.2 % (the issue's no-loss bound is 5 %). Measured and not taken: the reward ending at depth 4
(ring 2: copies +9.6 %, the matching patch loses area to the vertex content); ring 1 with the reward ending at 2
(grapes 6.7: the cut rests on the ring again); a sharp cut-off (reward 0 within 4 px, the taper unchanged
inside: a new resting line at its edge); a larger ring penalty (12: grapes 7.9); unnormalised seam weights at
the ring (worse: the cut rests one row further in)."""
SUPERELLIPSE = 8.0
"""Exponent q of the rounded square that shapes the reward (2 = circle; larger reaches further into the corners).

What the tiles share is their vertex content: every vertex of colour c shows the centre of sample patch c, over
the corner region the cut leaves to the intermediate tile, at a fifth of the vertices of a c5 tiling. With q = 3
the reward is zero over a corner region of about 0.2·N, and the cut kept the vertex content out to about 0.3·N
from each corner (c5 on dry-soil: 0.5 % of the pixels within 0.19·N of a corner, 37 % within 0.375·N belong to
the matching patch). Measured on the 9 textures of ``benches/repetition.py`` (c5 defaults, 1024² outputs, seed
1; ``benches/repetition-results.md``), q = 3 → 8 (means): matching-patch share of the tiles 0.648 →
0.684, periodic copies 0.056 → 0.039, coverage 0.835 → 0.845, texture statistics 0.0136 → 0.0132, histogram
and border seam equal, cut seam +0.3 %, inner-lattice seam +2.5 % (worst: cracked mud 1.77 → 1.91); q = 16
bought nothing more than 8, and a doubled reward (FREE_BETA 32) halved copies again but raised the inner seam
by up to 26 % (lettuce 1.42 → 1.79)."""
FREE_REGIONS = ("free", "free8", "ring")
"""The values of ``cut_region`` cut by :func:`free_cuts` (``circle`` is the ω kernel's)."""
TAPERED_REGIONS = ("free", "free8")
"""The free regions with the tapered reward and the ring penalty (:func:`free_weights`)."""
GEO_AXIS = float(np.sqrt(2.0) - 1.0)
"""Geo-cut factor of the axis edges of ``cut_region="free8"`` (module docstring)."""
GEO_DIAG = float(1.0 - 1.0 / np.sqrt(2.0))
"""Geo-cut factor of the diagonal edges of ``cut_region="free8"`` (GEO_AXIS / √2, as Δφ/(2|e|) prescribes)."""


def default_bias(cut_region: str, n: int) -> float:
    """The default ``cut_bias`` of a free cut region for tiles of ``n`` pixels: FREE_BETA / (N/2) for "free" and
    "free8", RING_BIAS for "ring"."""
    return FREE_BETA / (n / 2) if cut_region in TAPERED_REGIONS else RING_BIAS


def free_weights(
    n: int, bias: float, ring: int | None = None, tapered: bool = True
) -> tuple[np.ndarray, ...]:
    """The shaping terms of a free cut region: ``(reward, factor_x, factor_y)``.

    ``reward`` ``(n, n)``: the area reward per pixel in units of the mean edge weight (``bias`` at most;
    tapered as in the module docstring, or ``bias`` everywhere with ``tapered=False``, the "ring" region);
    ``factor_x`` ``(1, n)`` multiplies the horizontal-neighbour weights ``wx[:, x]`` (a cut there runs
    parallel to the left and right borders), ``factor_y`` ``(n, 1)`` the vertical ones (all ones untapered)."""
    if ring is None:
        ring = RING
    if not tapered:
        one = np.ones(n)
        return np.full((n, n), float(bias)), one[None, :], one[:, None]
    h = n / 2
    t = np.abs(np.arange(n) - (n - 1) / 2) / h  # |u| of every pixel centre
    rho = (t[:, None] ** SUPERELLIPSE + t[None, :] ** SUPERELLIPSE) ** (1 / SUPERELLIPSE)
    # the reward reaches 0 REWARD_GAP pixels inside the ring (where the tile is large enough for it)
    edge = ring + REWARD_GAP if ring + REWARD_GAP < h / 2 else ring
    rho0, rho1 = 0.5, 1 - edge / h
    reward = bias * np.clip((rho1 - rho) / (rho1 - rho0), 0.0, 1.0)
    # pair (x, x+1) lies (x + 1) pixels from the left border, (n - 1 - x) from the right one
    x = np.arange(n)
    depth = np.minimum(x + 1, np.maximum(n - 1 - x, 1))
    taper = np.clip((depth - ring) / max(1.0, n / 4), 0.0, 1.0)
    factor = 1 + RING_PENALTY * (1 - taper) ** 2
    return reward, factor[None, :], factor[:, None]


def free_cuts(
    intermediate: np.ndarray,
    matching: np.ndarray,
    eps: float,
    grad: np.ndarray | None,
    ring: int | None = None,
    disc: int | None = None,
    bias: float | None = None,
    cut_region: str = "free",
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Masks ``(K, N, N)`` (True = take O) and cut costs of a free cut region, one grid min cut per tile
    (``threads`` at once; the result does not depend on it).

    ``cut_region`` "free" (tapered reward and ring penalty, :func:`free_weights`), "free8" (the same on the
    8-connected geo-cut grid, :func:`geo_weights`) or "ring" (a uniform reward, the first version). ``bias`` > 0
    rewards area given to O: free pixels get sink t-links of the reward times the tile's mean edge weight
    (None: :func:`default_bias`). The reported cost is the cut's edge weights (penalised ones included) plus
    the rewards it forgoes."""
    if cut_region not in FREE_REGIONS:
        raise ParameterError(f"cut_region = {cut_region!r}: free_cuts takes {FREE_REGIONS}")
    k, n = intermediate.shape[:2]
    src, sink = free_terminals(n, ring, disc)
    free = ~src & ~sink
    bias = default_bias(cut_region, n) if bias is None else float(bias)
    reward, fx, fy = free_weights(n, bias, ring, tapered=cut_region in TAPERED_REGIONS)
    reward = np.where(free, reward, 0.0)
    if cut_region == "free8":
        masks = np.zeros((k, n, n), bool)
        costs = np.zeros(k)
        for j in range(k):
            wx, wy, cap = _free_weights(intermediate, matching, j, eps, grad, fx, fy, reward, bias)
            gx, gy, gd, ga = geo_weights(wx, wy)
            masks[j], costs[j] = kernels.grid_mincut(gx, gy, src, sink, sink_cap=cap, wd=gd, wa=ga)
        return masks, costs
    # the 4-connected cuts of a chunk solved in one call, in parallel (each grid's cut as grid_mincut gives it);
    # the weights stay per tile: their mean is numpy's (pairwise) sum, which the recorded costs depend on
    wxs, wys = np.empty((k, n, n)), np.empty((k, n, n))
    caps = np.empty((k, n, n)) if bias > 0 else None
    for j in range(k):
        wxs[j], wys[j], cap = _free_weights(intermediate, matching, j, eps, grad, fx, fy, reward, bias)
        if caps is not None:
            caps[j] = cap
    return kernels.grid_mincuts(wxs, wys, src, sink, sink_cap=caps, threads=threads)


def _free_weights(
    intermediate: np.ndarray,
    matching: np.ndarray,
    j: int,
    eps: float,
    grad: np.ndarray | None,
    fx: np.ndarray,
    fy: np.ndarray,
    reward: np.ndarray,
    bias: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Tile ``j``'s cut weights of :func:`free_cuts`: the Kwatra edge weights times the ring factors, and the
    sink capacities (the reward times the tile's mean edge weight; None without a reward)."""
    wx, wy = kernels.kwatra_weights(
        intermediate[j], matching[j], eps=eps, a_grad=None if grad is None else grad[j]
    )
    mean_w = float(np.concatenate([wx[:, :-1].ravel(), wy[:-1].ravel()]).mean())
    return wx * fx, wy * fy, reward * mean_w if bias > 0 else None


def geo_weights(wx: np.ndarray, wy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The 8-connected geo-cut capacities ``(wx, wy, wd, wa)`` of ``cut_region="free8"`` from the axis weights
    ``(H, W)`` of :func:`tilesynth.base.kernels.kwatra_weights` (layout of :func:`tilesynth.base.kernels.grid_mincut`):
    axis edges times :data:`GEO_AXIS`; the diagonals of the pixel square with top-left (y, x) (``wd[y, x]``
    from (y, x), ``wa[y, x + 1]`` from (y, x + 1)) :data:`GEO_DIAG` times the mean of its four axis weights
    (module docstring). Entries the solver ignores are 0."""
    h, w = wx.shape
    wd = np.zeros((h, w))
    wa = np.zeros((h, w))
    if h > 1 and w > 1:
        square = (wx[:-1, :-1] + wx[1:, :-1] + wy[:-1, :-1] + wy[:-1, 1:]) * (GEO_DIAG / 4)
        wd[:-1, :-1] = square
        wa[:-1, 1:] = square
    return wx * GEO_AXIS, wy * GEO_AXIS, wd, wa


def self_offsets(inter_src: np.ndarray) -> np.ndarray:
    """``(U, 4, 2)``: for every intermediate tile, the four matching-patch offsets that would copy one of its
    own quadrants back from where it was cut (the offset that puts the tile's pixel (r, c) of a quadrant on its
    exemplar source pixel, ``inter_src[u, r, c] − (r, c)``, at the quadrant's top-left corner)."""
    n = inter_src.shape[1]
    h = n // 2
    corners = ((0, 0), (h, 0), (0, h), (h, h))
    return np.stack([inter_src[:, r, c].astype(np.int64) - (r, c) for r, c in corners], axis=1)


def diverse_matches(
    ex: np.ndarray,
    inter: np.ndarray,
    n_variants: int,
    max_uses: int,
    threads: int | None = None,
    exclude: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Matching offsets ``(U, V, 2)`` and their SSD ``(U, V)`` under the diversity constraint (module docstring).

    Variants of one tile also stay more than N/4 apart (the candidates are N/4-separated already).
    ``exclude`` ``(U, E, 2)`` (:func:`self_offsets`): offsets that tile u must not take, nor any candidate
    within N/4 (Chebyshev) of them: a *self-match*, the exemplar window that holds one of the tile's own
    sample quadrants, matches that quadrant exactly and is chosen for it (19 of 256 tiles of a c4 set on
    cracked mud, 16 on lettuce), but only repeats the shared vertex content the matching patch is meant to
    replace. N/4 is the distance at which variants count as different (:mod:`tilesynth.layouts.complete`). When every
    candidate of a tile is excluded the rule falls back to all of them."""
    chosen, chosen_d, _ = diverse_matches_augmented(ex, inter, n_variants, max_uses, threads, exclude)
    return chosen, chosen_d


def diverse_matches_augmented(
    ex: np.ndarray,
    inter: np.ndarray,
    n_variants: int,
    max_uses: int,
    threads: int | None = None,
    exclude: np.ndarray | None = None,
    transforms: tuple[int, ...] = (0,),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`diverse_matches` over the candidates of every orientation in ``transforms``
    (``augment``, :mod:`tilesynth.builder.matching.augment`): also returns the chosen transform numbers ``(U, V)``. A region's
    uses are counted per orientation, and self-matches are excluded only untransformed (see
    :mod:`tilesynth.builder.matching.augment`). ``transforms=(0,)`` is :func:`diverse_matches` exactly."""
    check_max_uses(max_uses)
    cands = diverse_candidates(ex, inter, n_variants, threads, transforms)
    return assign_diverse(cands, inter.shape[1], n_variants, max_uses, exclude)


def check_max_uses(max_uses: object) -> None:
    """``diversity`` must be a positive int (raises ParameterError)."""
    if not isinstance(max_uses, (int, np.integer)) or isinstance(max_uses, bool) or max_uses < 1:
        raise ParameterError(f"diversity = {max_uses!r}: must be a positive int (uses per exemplar region)")


def diverse_candidates(
    ex: np.ndarray,
    inter: np.ndarray,
    n_variants: int,
    threads: int | None = None,
    transforms: tuple[int, ...] = (0,),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The candidates of :func:`diverse_matches_augmented`: offsets, SSD and transforms of every tile's
    ``max(DIVERSE_CANDIDATES, n_variants)`` best translations, N/4 apart (:func:`tilesynth.builder.matching.augment.candidates`).
    With ``transforms=(0,)`` the first column is each tile's exact best translation and its SSD
    (:meth:`tilesynth.base.kernels.SsdIndex.best_matches` returns the best first)."""
    from .augment import candidates

    n = inter.shape[1]
    return candidates(ex, inter, max(DIVERSE_CANDIDATES, n_variants), n // 4, tuple(transforms), threads)


def assign_diverse(
    cands: tuple[np.ndarray, np.ndarray, np.ndarray],
    n: int,
    n_variants: int,
    max_uses: int,
    exclude: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The greedy assignment of :func:`diverse_matches_augmented` over :func:`diverse_candidates` ``cands``
    (tiles of ``n`` pixels)."""
    check_max_uses(max_uses)
    offsets, ssd, tids = cands
    if offsets.shape[1] < n_variants:
        raise ParameterError(
            f"tile_size = {n}: the exemplar has too few distinct translations for {n_variants} matching patches"
        )
    u = offsets.shape[0]
    chosen = np.zeros((u, n_variants, 2), np.int64)
    chosen_d = np.zeros((u, n_variants))
    chosen_t = np.zeros((u, n_variants), np.int64)
    used = np.zeros((u * n_variants, 2), np.int64)  # the offsets assigned so far: used[:m]
    used_t = np.zeros(u * n_variants, np.int64)  # and their orientations
    m = 0
    radius = n // 2
    for v in range(n_variants):
        for t in np.argsort(ssd[:, min(v, ssd.shape[1] - 1)], kind="stable"):
            cand, ct = offsets[t], tids[t]  # (J, 2), (J,), nearest first
            same = (cand[:, None, :] == chosen[t, None, :v, :]).all(axis=2) & (
                ct[:, None] == chosen_t[t, None, :v]
            )
            free = ~same.any(axis=1)  # not a variant yet
            if exclude is not None:  # no self-match (docstring), untransformed only
                own = (np.abs(cand[:, None, :] - exclude[t][None, :, :]).max(axis=2) <= n // 4).any(axis=1)
                own &= ct == 0
                if (free & ~own).any():
                    free &= ~own
            # uses of each candidate's region (in its orientation): assigned offsets within `radius` (Chebyshev)
            near = np.abs(cand[:, None, :] - used[None, :m, :]).max(axis=2) <= radius
            uses = (near & (ct[:, None] == used_t[None, :m])).sum(axis=1)
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
            chosen_t[t, v] = ct[best]
            used[m], used_t[m] = cand[best], ct[best]
            m += 1
    return chosen, chosen_d, chosen_t
