r"""Wang tiles (Cohen et al. 2003, with the matching and GA selection of 001) and strict Wang tiles (004).

Both schemes lay edge-coloured tiles (:mod:`tilesynth.layouts.wang_sets`, ⟨N, E, S, W⟩) and make every tile from the
*samples* of its four edge colours, one sample per colour, so tiles that share an edge colour show the two
halves of one piece of exemplar across that edge.

Geometry
--------
A tile is N x N pixels (N even, h = N/2); pixel (y, x) has its centre at (y + ½, x + ½). A sample is a P x P
square of the exemplar whose top-left corner is its *gene* (row, col), centred on the midpoint of its edge:
the N sample on the top edge, E on the right, S on the bottom, W on the left. Tile pixel (y, x) (also outside
the tile) reads the exemplar at

    N: (r + m + h + y, c + m + x)          S: (r + m − h + y, c + m + x)
    E: (r + m + y, c + m − h + x)          W: (r + m + y, c + m + h + x)

with (r, c) the gene and the margin m = (P − N) / 2. A *diamond* sample (Cohen) is the part of its square with
|Y − cy| + |X − cx| ≤ h + w around the edge midpoint (cy, cx) (an N x N square of exemplar content rotated 45°
when w = 0, its diagonal along the tile edge), w = overlap / 2. The tile and its samples (schematic)::

                      ┌─────────────────┐
                      │   (tile above)  │
         (0,0) ┌──────┼─────────────────┼──────┐ (0, N−1)
               │╲                             ╱│   N sample: a P x P square centred on the top edge's
               │  ╲                         ╱  │   midpoint; its upper half is the S sample of the
               │    ╲                     ╱    │   tile above, its lower half overlaps this tile
               │      ╲       N         ╱      │
               │         ╲           ╱         │   ╲ ╱ the two diagonals: the four cuts follow them
               │           ╲       ╱           │       in bands of width 2w, from the centre (·)
               │             ╲   ╱             │       to the corners
               │   W           · centre    E   │
               │             ╱   ╲             │   W, E and S samples: the same, centred on the
               │           ╱       ╲           │   midpoints of their edges
               │         ╱           ╲         │
               │      ╱        S        ╲      │
               │    ╱                     ╲    │
               │  ╱                         ╲  │
               │╱                             ╲│
      (N−1,0)  └───────────────────────────────┘ (N−1, N−1)

The band of the NE cut (N = 12, h = 6, w = 2; rows y = −2 .. h − 1, columns x = h .. N + 1)::

         x =  6  7  8  9 10 11 12 13
      y = −2                 ·  ·          o  the diagonal d = 0; the cut starts at (h − 1, h) and, with
      y = −1              ·  ·  ·  ·          pinned corners, ends at the corner pixel (0, N − 1)
      y =  0  A  A  A  a  a  o  ·  ·       a b band pixels (|d| ≤ w) on the A = N and the B = E side
      y =  1  A  A  a  a  o  b  ·          ·  band past the corner: free corners only (with pinned corners
      y =  2  A  a  a  o  b  b                the band also leaves out the right-edge pixels (1, 11), (2, 11))
      y =  3  a  a  o  b  b  B             A B pixels outside the band: always N / always E
      y =  4  a  o  b  b  B  B
      y =  5  o  b  b  B  B  B             lines s = x − y run up and to the right; a cut takes one pixel
                                           per line, d changing by ±1: a 4-connected staircase

The tile's two diagonals split it into four triangles N, E, S, W. Each quadrant is cut between its
horizontal-edge sample A (N or S) and its vertical-edge sample B (E or W) by a 4-connected staircase from the
tile centre to the corner (the NE cut goes from pixel (h−1, h) to the corner (0, N−1)), found by the
Efros–Freeman dynamic programme on the lines s = x − y across the band, or by a graph cut (``cut="graph"``,
the max-flow kernel with Kwatra weights). Pixels on the A side of the path, the path included, take A;
corner pixels always take the horizontal-edge sample. With **pinned** corners the cut ends exactly at the
corner pixel and never touches the other edges, so every edge pixel shows its own edge's sample and adjacent
tiles continue each other's exemplar content across every shared edge, except the two pixel pairs at the ends
of every vertical edge, where four samples meet (the junction every Wang tiling has at tile corners). With
**free** corners (Cohen's literal construction, ``corners="free"``) the band runs on past the corner by w, as
the overlap of Cohen's diamonds does, the path ends anywhere on its last line and the tile is cropped: the cut
generally crosses the tile edge a few pixels from the corner, and there the edge shows the wrong sample —
004's *corner problem*, measured by :func:`corner_mismatch`.

**Pinned is the default** because a demanding user expects tile borders to be invisible: measured by
``benches/seams.py`` (``benches/seams-results.md``), free corners leave 7-13 % of the pixel pairs across tile
borders discontinuous (border seam score 0.9-3.6 on 12 textures), pinned corners only the junction pairs at the
ends of every vertical edge (0.8-1.6 %). Where the borders then fall in the exemplar is chosen by the
border-aware random draws (``border_tries``, :mod:`tilesynth.builder.genes.wang_borders`). ``corners="free"`` stays available for the literal construction of Cohen et al.

**Choices where the papers are silent or garbled.** (1) The four cuts all start at the tile centre, so the
four regions are well defined without Cohen's sequential compositing (the joint problem of 004 is then a
single four-way junction). (2) The DP minimises the luminance error (Y of YIQ) along the path: 001's D_path
"luminance errors of pixels along the minimum cutting path", computed on Y because that "can accelerate the
calculation of the minimum cutting path errors", and its factor 3 makes the one-channel path error comparable
with the three-channel D_overlap. (3) ω (001 gives no value) is 0.8, 000's λ for the same weighting. (4) The
overlap defaults to N/4 (rounded down to even) so that the sample squares are P = N + N/4: 001's Table 1 uses
samples of 80 with overlap 16, i.e. 64-pixel tiles, and 120/20 (100-pixel tiles). (5) Burke's variant
(002 §2, ``samples="square"``): N x N square samples, the overlap is the whole quadrant, corners pinned.

The improved match of 001 (computed in Rust, :class:`tilesynth.base.kernels.WangEvaluator`)::

    D_boundary = ω·D_overlap/n_overlap + 3(1 − ω)·D_path/n_path       (3 = channels for RGB; C in general)
    D_sum      = Σ over the tile's four cuts of D_boundary
    E          = ω·Σ_tiles D_sum + (1 − ω)·Var(D_sum)

D_overlap is the SSD between the two samples over the band (``n_overlap`` pixels), D_path the Y error along
the path (``n_path`` pixels; for graph cuts the seam pixels: A pixels with a B neighbour).

Strict Wang tiles (004) are built by :mod:`tilesynth.builder.swang` with the same samples and helpers.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import _core
from ..base import kernels
from ..base.validate import positive_int
from ..errors import ParameterError
from ..layouts.wang_sets import WangTileSet, get_wang_tileset
from ..measure.diagnose import finish_build
from ..tileset.tilefile import TileSet
from .compose import finish_tileset
from .genes.select import Evaluate, choose_genes, wants_selection
from .genes.wang_borders import DEFAULT_BORDER_TRIES, border_aware_genes, check_border_tries
from .masking import active
from .options import BuildOptions, Progress, SeedLike, common_options

__all__ = [
    "DEFAULT_OMEGA",
    "GA_001",
    "NORTH",
    "EAST",
    "SOUTH",
    "WEST",
    "SUPPLEMENTARY",
    "build_wang",
    "corner_mismatch",
    "default_overlap",
    "initial_labels",
    "sample_size",
    "sample_source",
    "wang_energy",
]

DEFAULT_OMEGA: float = _core.DEFAULT_OMEGA
"""ω of D_boundary and E (001 gives none; 000 uses 0.8 for the same weighting); defined in the core."""

GA_001: dict[str, Any] = {
    "population": 50,
    "alpha": 0.05,
    "p_crossover": 0.3,
    "p_mutation": 0.2,
    "generations": 200,
    "stagnation": 8,
}
"""001's GA: pop_size 50, α 0.05, P_c 0.3, P_m 0.2, 200 generations, stop after 8 without improvement."""

NORTH, EAST, SOUTH, WEST = _core.WANG_SIDES
"""Label values of the four samples (``labels``, columns of ``tile_patches``), the core's side indices
(``rust/wang.rs``); 4 is the supplementary patch."""
SUPPLEMENTARY = 4

#: (dy, dx) of each role's sample relative to the tile, in units of h (see the mapping above).
_ROLE_OFFSETS = ((1, 0), (0, -1), (-1, 0), (0, 1))


def default_overlap(tile_size: int) -> int:
    """N/4 rounded down to even, at least 2 (001: samples of 80 with overlap 16, i.e. 64-pixel tiles)."""
    return max(2, (tile_size // 4) // 2 * 2)


def sample_size(tile_size: int, overlap: int, corners: str, samples: str = "diamond") -> int:
    """Side P of the sample squares: N + overlap for free-corner diamonds (the band runs past the corner), else N."""
    return tile_size + overlap if (samples == "diamond" and corners == "free") else tile_size


def sample_source(
    genes: np.ndarray, tile_patches: np.ndarray, labels: np.ndarray, tile_size: int, margin: int
) -> np.ndarray:
    """Exemplar (row, col) of every tile pixel from its label (0..3) and the genes: int32 ``(K, N, N, 2)``.

    Pixels labelled 4 (supplementary) are left at -1 for the caller to fill.
    """
    k, n = labels.shape[0], tile_size
    h = n // 2
    yy, xx = np.mgrid[0:n, 0:n]
    out = np.full((k, n, n, 2), -1, np.int32)
    for t in range(k):
        for role, (oy, ox) in enumerate(_ROLE_OFFSETS):
            m = labels[t] == role
            r, c = genes[tile_patches[t, role]]
            out[t, m, 0] = r + margin + oy * h + yy[m]
            out[t, m, 1] = c + margin + ox * h + xx[m]
    return out


def initial_labels(tile_size: int) -> np.ndarray:
    """The s-Wang initial tile's triangles: uint8 ``(N, N)``, N/S where the pixel is at least as close to a
    horizontal edge as to a vertical one (diagonals and corners go to N/S), W/E otherwise."""
    n = tile_size
    yy, xx = np.mgrid[0:n, 0:n]
    a = np.minimum(yy, n - 1 - yy)
    b = np.minimum(xx, n - 1 - xx)
    horiz = np.where(yy < n // 2, NORTH, SOUTH)
    vert = np.where(xx < n // 2, WEST, EAST)
    return np.where(a <= b, horiz, vert).astype(np.uint8)


def wang_energy(D: np.ndarray, omega: float = DEFAULT_OMEGA) -> float:
    """E = ω·ΣD + (1−ω)·Var(D), summed in order exactly as the Rust evaluator does (bit-identical)."""
    d = [float(v) for v in np.asarray(D, dtype=np.float64).ravel()]
    total = 0.0
    for v in d:
        total += v
    mean = total / len(d)
    var = 0.0
    for v in d:
        var += (v - mean) * (v - mean)
    var /= len(d)
    return omega * total + (1.0 - omega) * var


def corner_mismatch(labels: np.ndarray) -> np.ndarray:
    """Edge pixels near each corner that do not show their edge's sample (004's corner problem).

    ``labels`` is ``(K, N, N)`` (0 N, 1 E, 2 S, 3 W, 4 supplementary). An edge pixel is wrong when its label is
    not its edge's sample; the corner pixels themselves belong to the horizontal edges (N / S) by construction,
    so they are counted on the top / bottom edge only. Each wrong pixel is charged to the nearer corner of its
    edge. Returns int64 ``(K, 4)`` counts in the order TL, BL, TR, BR (the corner order of ω-tiles).
    """
    lab = np.asarray(labels)
    k, n = lab.shape[0], lab.shape[1]
    h = n // 2
    out = np.zeros((k, 4), np.int64)
    top, bottom = lab[:, 0, :] != NORTH, lab[:, n - 1, :] != SOUTH
    left, right = lab[:, 1 : n - 1, 0] != WEST, lab[:, 1 : n - 1, n - 1] != EAST
    # TL, BL, TR, BR
    out[:, 0] = top[:, :h].sum(1) + left[:, : h - 1].sum(1)
    out[:, 1] = bottom[:, :h].sum(1) + left[:, h - 1 :].sum(1)
    out[:, 2] = top[:, h:].sum(1) + right[:, : h - 1].sum(1)
    out[:, 3] = bottom[:, h:].sum(1) + right[:, h - 1 :].sum(1)
    return out


def _resolve_set(tileset: str | WangTileSet) -> WangTileSet:
    if isinstance(tileset, WangTileSet):
        return tileset
    try:
        return get_wang_tileset(tileset)
    except ValueError as exc:
        raise ParameterError(f"tileset = {tileset!r}: {exc}") from None


@dataclass(frozen=True)
class WangOptions:
    """The Wang scheme's own options of one build, validated once (:func:`wang_options`)."""

    samples: str
    cut: str
    corners: str
    overlap: int
    omega: float
    eps: float
    sample_size: int

    def kernel_args(self) -> dict[str, Any]:
        return {"corners": self.corners, "samples": self.samples, "omega": self.omega, "eps": self.eps}


def wang_options(
    b: BuildOptions, *, overlap: Any, corners: Any, samples: Any, cut: Any, omega: Any, eps: Any
) -> WangOptions:
    """Validate the Wang options (names as in :func:`build_wang`) against the build's tile size and exemplar."""
    n, ex = b.tile_size, b.exemplar
    if samples not in ("diamond", "square"):
        raise ParameterError(f"samples = {samples!r}: must be 'diamond' or 'square'")
    if cut not in ("dp", "graph"):
        raise ParameterError(f"cut = {cut!r}: must be 'dp' or 'graph'")
    if samples == "square":
        if overlap is not None:
            raise ParameterError(
                f"overlap = {overlap!r}: square samples overlap on whole quadrants, give none"
            )
        if corners not in (None, "pinned"):
            raise ParameterError(
                f"corners = {corners!r}: square samples end at the tile corner, use 'pinned'"
            )
        corners, ov = "pinned", n
    else:
        # pinned by default (Cohen's free corners leave 7-13 % of the border pairs discontinuous, border
        # seam score 0.9-3.6, benches/seams-results.md); "free" stays for the literal construction.
        corners = "pinned" if corners is None else corners
        if corners not in ("free", "pinned"):
            raise ParameterError(f"corners = {corners!r}: must be 'free' or 'pinned'")
        ov = default_overlap(n) if overlap is None else positive_int(overlap, "overlap", minimum=2)
        if ov % 2:
            raise ParameterError(f"overlap = {ov}: must be even (the band is w = overlap/2 on each side)")
    if isinstance(omega, bool) or not isinstance(omega, (int, float)) or not 0.0 <= float(omega) <= 1.0:
        raise ParameterError(f"omega = {omega!r}: must be a number in [0, 1]")
    p = sample_size(n, ov, corners, samples)
    if p > min(ex.shape[0], ex.shape[1]):
        raise ParameterError(
            f"tile_size = {n}: the sample squares ({p}x{p} = N + overlap) are larger than the exemplar "
            f"({ex.shape[1]}x{ex.shape[0]}); use a smaller tile size or overlap"
        )
    return WangOptions(samples, cut, corners, ov, float(omega), eps, p)


def wang_evaluator(b: BuildOptions, o: WangOptions, tile_patches: np.ndarray) -> Evaluate:
    """001's E of gene populations (:class:`~tilesynth.base.kernels.WangEvaluator`), always with DP cuts."""
    ev = kernels.WangEvaluator(
        b.exemplar, tile_patches, b.definition.n_samples, b.tile_size, o.overlap, cut="dp", **o.kernel_args()
    )
    return lambda g: ev.evaluate(g, b.threads)


def _border_draws(
    b: BuildOptions,
    genes: Any,
    select: Any,
    polish: Any,
    select_params: Any,
    genes_arr: np.ndarray,
    sel: dict[str, Any],
    sample_size: int,
    tries: int,
) -> tuple[np.ndarray, dict[str, Any]]:
    """The border-aware random draw of both Wang schemes (:func:`tilesynth.builder.genes.wang_borders.border_aware_genes`):
    only when the genes were one random draw; ``tries`` = 1 keeps that draw (and records nothing)."""
    if genes is not None or tries == 1 or wants_selection(select, polish, select_params):
        return genes_arr, sel
    if active(b.mask) is not None:  # the draws are not mask-aware: a masked build keeps its one clear draw
        return genes_arr, sel
    g, rec = border_aware_genes(
        b.exemplar, genes_arr, len(b.definition.horizontal), b.tile_size, sample_size, b.rng, tries
    )
    return g, {**sel, **rec}


def _sum4(values: np.ndarray) -> np.ndarray:
    """Per tile, the sum of its four cuts' values in the evaluator's order (bit-identical to it)."""
    return np.array([((s[0] + s[1]) + s[2]) + s[3] for s in values.tolist()], dtype=np.float64)


# --------------------------------------------------------------------------------------------------------------
# Cohen / Burke


# Length: 91 lines, of which 33 are the docstring of its options; the body (58) is the stage sequence.
def build_wang(
    exemplar: np.ndarray,
    *,
    tileset: str | WangTileSet = "wang8",
    tile_size: int | None = None,
    overlap: int | None = None,
    corners: str | None = None,
    samples: str = "diamond",
    cut: str = "dp",
    border_tries: int = DEFAULT_BORDER_TRIES,
    genes: np.ndarray | None = None,
    seed: SeedLike = None,
    threads: int | None = None,
    omega: float = DEFAULT_OMEGA,
    eps: float = kernels.DEFAULT_EPS,
    select: str | None = None,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    select_params: dict[str, Any] | None = None,
    progress: Progress | None = None,
    selection: dict[str, Any] | None = None,
    exemplar_info: dict[str, Any] | None = None,
    mask: Any = None,
    alpha: str = "auto",
) -> TileSet:
    """Build Cohen et al.'s Wang tiles (or Burke's square variant) from ``exemplar``.

    Parameters
    ----------
    exemplar : image ``(H, W[, C])``.
    tileset : "wang8" (default), "wang18", "wang<2k²>" or a :class:`~tilesynth.layouts.wang_sets.WangTileSet`.
    tile_size : N, even; default half the exemplar's shorter side (at most 256).
    overlap : width of the band between two diamonds (even, >= 2); default N/4 rounded down to even.
        Not used with ``samples="square"``.
    corners : "pinned" (default: the cut ends at the corner pixel, so every edge pixel shows its own edge's
        sample and neighbouring tiles continue each other's exemplar content across every shared edge; the only
        choice for square samples) or "free" (Cohen's literal construction: the cut runs on past the corner and
        may cross the tile edge near it, 004's corner problem; 7-13 % of the pixel pairs across tile borders
        are then seams, border seam score 0.9-3.6 on the 12 textures of ``benches/seams.py``).
    samples : "diamond" (Cohen, default) or "square" (Burke, 002 §2: N x N squares overlapping on whole
        quadrants).
    cut : "dp" (Efros–Freeman dynamic programming, default) or "graph" (min-cut with Kwatra weights).
    border_tries : with random samples (no ``genes``, ``select`` None or "random"), the number of random gene
        vectors drawn; the one whose tile borders fall on the quietest exemplar lines (smallest predicted border
        seam, :mod:`tilesynth.builder.genes.wang_borders`) is kept. Default 32; 1 is Cohen's single random draw
        (``corners="free", border_tries=1`` is the literal construction of Cohen et al.).
    genes : optional ``(n, 2)`` top-left corners of the P x P sample squares, in the order of the set's colours
        (horizontal, then vertical); P = :func:`sample_size`.
    seed : seed of the random choices (recorded; None draws one).
    threads : worker threads (None: ``TILESYNTH_NUM_THREADS`` or all cores); results do not depend on it.
    omega : ω of D_boundary and E (default 0.8).
    eps : epsilon of the Kwatra weight (graph cuts).
    select : "random" (default without genes), "best-of", "ga" (001's settings :data:`GA_001` unless
        overridden) or "ais" (003's), minimising 001's E. The objective always uses DP cuts (graph cuts would
        cost ~100x more per evaluation); with ``cut="graph"`` the stored E is that of the graph cuts, the
        selection's own E is in ``params["selection"]["objective_E"]``.
    polish, generations, population, select_params : as for :func:`tilesynth.build_omega`.
    progress : callback ``(stage, done, total)``.
    selection : how given genes were chosen (recorded), default ``{"method": "given"}``.
    exemplar_info : extra facts about the exemplar to record.
    mask, alpha : pixels never to use, as for :func:`tilesynth.build_omega`: the P x P squares of the samples
        avoid the mask.

    Returns
    -------
    TileSet with ``scheme="wang"`` (see :mod:`tilesynth.tileset.tilefile` for the meaning of each array).
    """
    b = common_options(
        exemplar, tileset=tileset, resolve_set=_resolve_set, tile_size=tile_size, seed=seed, threads=threads,
        progress=progress, exemplar_info=exemplar_info, mask=mask, alpha=alpha,
    )  # fmt: skip
    with b.source.validated():  # the stages take the exemplar as validated here (checked once)
        o = wang_options(b, overlap=overlap, corners=corners, samples=samples, cut=cut, omega=omega, eps=eps)
        tries = check_border_tries(border_tries)
        defn, n = b.definition, b.tile_size
        if defn.n_variants > 1:  # a Cohen tile is its four edge samples: its variants would be copies
            raise ParameterError(
                f"tileset = {defn.name!r} has {defn.n_variants} variants per edge tuple: Cohen's Wang tiles are made "
                "from their four edge samples alone, so variants would be identical; use --scheme swang (strict "
                "Wang tiles, whose variants take different supplementary patches) or a set without variants"
            )
        tile_patches = defn.sample_indices()
        genes_arr, sel = choose_genes(
            genes, n=defn.n_samples, size=o.sample_size, shape=b.exemplar.shape, rng=b.rng,
            evaluator=lambda: wang_evaluator(b, o, tile_patches), select=select, polish=polish,
            generations=generations, population=population, select_params=select_params, selection=selection,
            ga_defaults=GA_001, progress=b.progress, mask=b.mask, tile_size=n,
        )  # fmt: skip
        genes_arr, sel = _border_draws(
            b, genes, select, polish, select_params, genes_arr, sel, o.sample_size, tries
        )
        t_sel = time.perf_counter()
        b.report("cuts", 0, 1)
        labels, stats = kernels.wang_tiles(
            b.exemplar, genes_arr, tile_patches, n, o.overlap, cut=o.cut, threads=b.threads, **o.kernel_args()
        )
        b.report("cuts", 1, 1)
        t_cut = time.perf_counter()
        source = sample_source(genes_arr, tile_patches, labels, n, (o.sample_size - n) // 2)
        D = _sum4(stats[:, :, 4])
        params = {
            "set": defn.name, "tile_size": n, "samples": o.samples, "overlap": o.overlap, "sample_size": o.sample_size,
            "corners": o.corners, "cut": o.cut, "omega": o.omega, "eps": float(o.eps), "seed": b.seed,
            "selection": sel, "border_tries": tries,
        }  # fmt: skip
        ts = finish_tileset(
            scheme="wang", definition=defn, exemplar=b.exemplar, tiles=b.exemplar[source[..., 0], source[..., 1]],
            source=source, cut_masks=(labels == EAST) | (labels == WEST), genes=genes_arr, tile_patches=tile_patches,
            match_offsets=np.full((len(defn), 2), -1, np.int64), D=D, cut_costs=_sum4(stats[:, :, 5]),
            E=wang_energy(D, o.omega), params=params, exemplar_info=b.exemplar_info,
            timing={"selection_s": t_sel - b.started, "cutting_s": t_cut - t_sel}, started=b.started,
            labels=labels, cut_stats=stats,
        )  # fmt: skip
        return finish_build(ts, b)  # the mask record and the input warnings
