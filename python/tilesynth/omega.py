"""ω-tile construction (Ng, Wen, Tan, Zhang, Kim, CGI 2005), thin control over the Rust kernels.

For a tile set whose tiles are corner-colour tuples ⟨TL, BL, TR, BR⟩ and one sample patch per colour (the
*genes*: top-left positions of N x N patches in the exemplar):

1. **Intermediate tile** of each tile: the N x N centre of the 2N x 2N block ``[[TL, TR], [BL, BR]]`` of its
   patches, i.e. its TL quadrant is the bottom-right quarter of the TL patch, its TR quadrant the bottom-left
   quarter of the TR patch, its BL quadrant the top-right quarter of the BL patch and its BR quadrant the top-left
   quarter of the BR patch. Two tiles that share a side therefore show the two halves of the same patch on either
   side of it: tilings are seamless by construction.
2. **Matching patch O**: the translation of the exemplar with the smallest SSD to the intermediate tile, found
   exhaustively (FFT map, exact re-ranking). Its SSD is D_j.
3. **Cutting curve**: min-cut with Kwatra weights, sources outside the inscribed circle, sinks on the central
   cross (see :func:`tilesynth.kernels.omega_cuts`); the ω-tile takes O inside the curve.

**The tile border** (``keep_border``, default True). The inscribed circle touches the border at the four side
midpoints. Taken literally, O may then occupy the border over a stretch around each midpoint (about 19 pixels for
188-pixel tiles), where neighbouring tiles show *different* matching patches: a short seam across the tile border,
plainly visible on the bundled lettuce exemplar (~10% of border pixels were discontinuous). 002 wants the curve to
pass *through* the midpoints, i.e. O touches the border only there, so we tie the whole one-pixel border ring to
I. Every border pixel is then continuous exemplar content with the neighbouring tile; all that is left of the
cross seam on the border is the single pixel pair where two sample patches meet, identical on both sides.
``keep_border=False`` is the literal definition (the one of the reference data ``mincut80.npz``).

**Gradients in the Kwatra weight.** 002 divides by "the gradient of pixel s in the patch I". Read literally on
the assembled intermediate tile, the gradient across the tile's own cross seam is large, so every edge next to the
sink cross is cheap and the min-cut hugs the cross: the result is thin strips of O along the seams, i.e. two seams
instead of one, plainly visible as lines through the middle of the tiles (seen on the bundled lettuce exemplar).
We read "the patch I" as the sample patch the pixel came from: ``gradients="patch"`` (the default) takes the
gradient norms at each pixel's exemplar position (through the provenance), so I's seams do not lower the weights
and the curve goes around the region that O replaces. ``gradients="tile"`` is the literal formula on the assembled
tile (the one the reference data ``mincut80.npz`` were made with).

Sets with two variants of a tile (the 32-set, 002 §4.1-4.2) use the best O for variant 0 and the second-best O for
variant 1. The second best is required to lie more than N/4 pixels (Chebyshev) from the best: the literal
second-smallest SSD is almost always the best translation shifted by one pixel, whose content is the same, and
002 wants two *different* good ω-tiles per intermediate tile.

**Poisson smoothing** (``smooth``, 002 §3.3, 003 §4.3): the region inside each cutting curve is replaced by the
guided interpolation of :func:`smooth_tiles` (source = the matching patch O, Dirichlet boundary = the pixels of the
composed tile next to the region), solved to a 1e-6 relative residual. The one-pixel tile border is never part
of the region, so every border pixel keeps its unsmoothed value and tiles stay seamless with each other. The
provenance ``source`` still names the exemplar pixel each tile pixel *came from* (inside the region, the pixel
whose gradients it carries).

Quality of the whole set: E = λ·ΣD_j + (1−λ)·Var(D_j) over the intermediate tiles (λ = 0.8, population
variance), the objective of the selection papers (000, 003).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from . import kernels
from ._validate import as_image, finite_float, positive_int, seed_int, threads_arg
from .errors import ParameterError
from .tilefile import TileSet, exemplar_digest
from .matching import EQ2_EPS, MU, augmented, check_metric, check_strategy, gradient_norm, pick_distinct, strategy_edges
from .tilesets import get_tileset

LAMBDA = 0.8
"""Default λ of E = λ·ΣD + (1−λ)·Var(D) (paper 000)."""

Progress = Callable[[str, int, int], None]
"""Progress callback: (stage, done, total)."""


MIN_TILE_SIZE = 4
"""The smallest tile: 4 x 4 (2 x 2 quadrants; the cut needs a border ring and a cross inside it)."""


def default_tile_size(shape: tuple[int, ...]) -> int:
    """Half the exemplar's shorter side, rounded down to even, capped at 256 (002 used 64 on 128 inputs), and
    at least :data:`MIN_TILE_SIZE` (exemplars of 4 to 7 pixels a side get 4: the whole-side tile)."""
    n = min(shape[0], shape[1]) // 2
    n -= n % 2
    return max(MIN_TILE_SIZE, min(n, 256))


def check_exemplar_size(shape: tuple[int, ...]) -> None:
    """Refuse exemplars smaller than the smallest tile (a 1x1 image is a valid file, not a texture)."""
    if min(shape[0], shape[1]) < MIN_TILE_SIZE:
        raise ParameterError(
            f"exemplar has shape {tuple(shape)}: too small, at least {MIN_TILE_SIZE}x{MIN_TILE_SIZE} pixels are "
            f"needed (the smallest tile is {MIN_TILE_SIZE}x{MIN_TILE_SIZE})"
        )


def check_tile_size(tile_size: Any, shape: tuple[int, ...]) -> int:
    """Validate ``tile_size`` against an exemplar of ``shape`` (even, >= 4, fits inside the exemplar)."""
    n = positive_int(tile_size, "tile_size", minimum=MIN_TILE_SIZE)
    if n % 2:
        raise ParameterError(f"tile_size = {n}: must be even (the tile is cut from the centre of a 2x2 block)")
    if n > shape[0] or n > shape[1]:
        raise ParameterError(
            f"tile_size = {n}: larger than the exemplar ({shape[1]}x{shape[0]} pixels); "
            f"use at most {min(shape[0], shape[1]) - min(shape[0], shape[1]) % 2}"
        )
    return n


def random_genes(shape: tuple[int, ...], n: int, tile_size: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` distinct random top-left positions of ``tile_size`` patches inside an exemplar of ``shape``.

    Returns int64 ``(n, 2)`` (row, col). Positions are uniform over all valid translations.
    """
    rows, cols = max(shape[0] - tile_size + 1, 0), max(shape[1] - tile_size + 1, 0)  # (-2) x (-2) is not 4
    if rows * cols < n:
        raise ParameterError(
            f"tile_size = {tile_size}: the exemplar has only {rows * cols} patch positions, {n} needed"
        )
    flat = rng.choice(rows * cols, size=n, replace=False)
    return np.stack([flat // cols, flat % cols], axis=1).astype(np.int64)


def check_genes(genes: Any, n: int, shape: tuple[int, ...], tile_size: int) -> np.ndarray:
    """Validate a gene vector: ``n`` distinct (row, col) positions with the patch inside the exemplar."""
    g = np.asarray(genes)
    if g.shape != (n, 2) or not np.issubdtype(g.dtype, np.integer):
        raise ParameterError(f"genes has shape {g.shape} and dtype {g.dtype}, expected integer ({n}, 2)")
    g = g.astype(np.int64)
    hi = np.array([shape[0] - tile_size, shape[1] - tile_size])
    bad = np.nonzero((g < 0).any(axis=1) | (g > hi).any(axis=1))[0]
    if bad.size:
        i = int(bad[0])
        raise ParameterError(
            f"genes[{i}] = {tuple(int(v) for v in g[i])}: patch must lie inside the exemplar "
            f"(row in [0, {hi[0]}], col in [0, {hi[1]}])"
        )
    if len({tuple(r) for r in g.tolist()}) != n:
        raise ParameterError("genes: positions must be distinct")
    return g


def energy(D: np.ndarray, lam: float = LAMBDA) -> float:
    """E = λ·ΣD_j + (1−λ)·Var(D_j) with the population variance."""
    try:
        d = np.asarray(D)
    except (ValueError, TypeError) as exc:
        raise ParameterError(f"D: expected real numbers ({exc})") from None
    if d.dtype.kind not in "biuf":
        raise TypeError(f"D has dtype {d.dtype}, expected real numbers")
    d = d.astype(np.float64)
    if d.ndim != 1 or d.size == 0 or not np.isfinite(d).all():
        raise ParameterError(f"D has shape {d.shape}: expected a non-empty 1-d array of finite values")
    lam = finite_float(lam, "lam")
    if not 0.0 <= lam <= 1.0:
        raise ParameterError(f"lam = {lam}: must be in [0, 1]")
    return float(lam * d.sum() + (1.0 - lam) * d.var())


def intermediate_tiles(
    exemplar: np.ndarray, genes: np.ndarray, tile_patches: np.ndarray, tile_size: int
) -> tuple[np.ndarray, np.ndarray]:
    """Assemble intermediate tiles and their provenance.

    ``tile_patches`` is ``(K, 4)``: the gene index of each tile's ⟨TL, BL, TR, BR⟩ patch. Returns float32
    ``(K, N, N, C)`` tiles and int32 ``(K, N, N, 2)`` exemplar coordinates of every pixel.
    """
    h = tile_size // 2
    k = tile_patches.shape[0]
    c = exemplar.shape[2]
    tiles = np.empty((k, tile_size, tile_size, c), np.float32)
    src = np.empty((k, tile_size, tile_size, 2), np.int32)
    yy, xx = np.mgrid[0:h, 0:h].astype(np.int32)
    # quadrant (tile rows, tile cols) <- patch offset (rows, cols) inside the patch, for TL, BL, TR, BR
    quads = [
        ((slice(0, h), slice(0, h)), (h, h)),  # TL: bottom-right quarter of the TL patch
        ((slice(h, None), slice(0, h)), (0, h)),  # BL: top-right quarter of the BL patch
        ((slice(0, h), slice(h, None)), (h, 0)),  # TR: bottom-left quarter of the TR patch
        ((slice(h, None), slice(h, None)), (0, 0)),  # BR: top-left quarter of the BR patch
    ]
    for j in range(k):
        for q, ((rs, cs), (dy, dx)) in enumerate(quads):
            r0, c0 = genes[tile_patches[j, q]] + (dy, dx)
            tiles[j, rs, cs] = exemplar[r0 : r0 + h, c0 : c0 + h]
            src[j, rs, cs, 0] = yy + r0
            src[j, rs, cs, 1] = xx + c0
    return tiles, src


def patch_gradients(exemplar: np.ndarray, source: np.ndarray) -> np.ndarray:
    """Gradient norms of the exemplar at the positions ``source`` (``(..., 2)`` row, col): ``(..., 2)`` float64.

    Index 0 is ‖E(r, c+1) − E(r, c)‖, index 1 is ‖E(r+1, c) − E(r, c)‖ (L2 over channels, 0 past the exemplar edge).
    """
    e = exemplar.astype(np.float64)
    h, w = e.shape[:2]
    gx = np.zeros((h, w))
    gy = np.zeros((h, w))
    gx[:, :-1] = np.sqrt(((e[:, 1:] - e[:, :-1]) ** 2).sum(-1))
    gy[:-1] = np.sqrt(((e[1:] - e[:-1]) ** 2).sum(-1))
    r, c = source[..., 0], source[..., 1]
    return np.ascontiguousarray(np.stack([gx[r, c], gy[r, c]], axis=-1))


def _distance_search(
    ex: np.ndarray, inter: np.ndarray, inter_src: np.ndarray, metric: str, threads: int | None
) -> tuple[list[np.ndarray], Any, Any]:
    """Per intermediate tile, its distance map over every translation (``metric``); a callable giving the
    exact distance of tile u at offset (r, c); and for the SSD metrics a callable ``best(k, exclude)`` giving the
    exact k best offsets and values of every tile (:meth:`SsdIndex.best_matches`), None for eq2 (whose maps are
    exact direct sums already)."""
    n = inter.shape[1]
    if metric == "eq2":
        g = gradient_norm(ex)
        maps = [
            kernels.weighted_ssd_map(ex, g, inter[u], np.ascontiguousarray(g[inter_src[u, ..., 0], inter_src[u, ..., 1]]),
                                     MU, EQ2_EPS, threads=threads)
            for u in range(inter.shape[0])
        ]
        return maps, lambda u, r, c: float(maps[u][r, c]), None
    search = augmented(ex) if metric == "eq3" else ex
    tpl = search[inter_src[..., 0], inter_src[..., 1]] if metric == "eq3" else inter
    index = kernels.SsdIndex(search, threads, features=True)
    maps = list(index.ssd(np.ascontiguousarray(tpl), threads=threads))

    def exact(u: int, r: int, c: int) -> float:
        d = tpl[u].astype(np.float64) - search[r : r + n, c : c + n].astype(np.float64)
        return float((d * d).sum())

    def best(k: int, exclude: int) -> tuple[np.ndarray, np.ndarray]:
        return index.best_matches(np.ascontiguousarray(tpl), k=k, exclude_radius=exclude, threads=threads)

    return maps, exact, best


def _choose_matches(
    ex: np.ndarray,
    inter: np.ndarray,
    inter_src: np.ndarray,
    n: int,
    n_variants: int,
    exclude: int,
    strategy: str,
    match_k: int | None,
    metric: str,
    gradients: str,
    keep_border: bool,
    eps: float,
    threads: int | None,
    report: Progress,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Matching patches by ``strategy`` (see :mod:`tilesynth.matching`): offsets ``(U, v, 2)``, their distances
    ``(U, v)`` and each tile's smallest distance ``(U,)`` (for E)."""
    U = inter.shape[0]
    maps, exact, best = _distance_search(ex, inter, inter_src, metric, threads)
    cols = maps[0].shape[1]
    total = maps[0].size
    if total < n_variants:
        raise ParameterError(
            f"tile_size = {n}: the exemplar has too few translations for {n_variants} matching patches per "
            "intermediate tile; use a smaller tile size or a larger exemplar"
        )
    best_D = np.empty(U)
    chosen = np.zeros((U, n_variants, 2), np.int64)
    chosen_D = np.zeros((U, n_variants))
    if strategy in ("circle", "midpoints"):
        wxm, wym = strategy_edges(strategy, n, keep_border)
    grads = patch_gradients(ex, inter_src) if gradients == "patch" else None
    if best is not None:
        # exact smallest distances (and, for "ssd", the exact k best far enough apart)
        b_off, b_val = best(n_variants if strategy == "ssd" else 1, exclude if strategy == "ssd" else 0)
        best_D[:] = b_val[:, 0]
    else:
        best_D[:] = [float(m.min()) for m in maps]
    for u in range(U):
        dist_order = np.argsort(maps[u], axis=None, kind="stable")
        if strategy == "ssd":
            if best is not None:
                if b_off.shape[1] < n_variants:
                    raise ParameterError(
                        f"tile_size = {n}: the exemplar has too few distinct translations for {n_variants} "
                        "matching patches per intermediate tile; use a smaller tile size or a larger exemplar"
                    )
                order = b_off[u, :, 0] * cols + b_off[u, :, 1]
            else:
                order = dist_order
        elif strategy in ("circle", "midpoints"):
            score = kernels.edge_weight_sums(
                inter[u], ex, wxm, wym, eps=eps, template_grad=None if grads is None else grads[u], threads=threads
            )
            order = np.argsort(score, axis=None, kind="stable")
        else:  # best-cut: the real cut for the k nearest candidates (per variant, away from earlier picks)
            kk = total if match_k is None or match_k < 0 else min(match_k, total)
            order_list: list[int] = []
            for _v in range(n_variants):
                far = [f for f in dist_order.tolist()
                       if all(max(abs(f // cols - p // cols), abs(f % cols - p % cols)) > exclude
                              for p in order_list)] if order_list else dist_order.tolist()
                cand = np.asarray(far[:kk], dtype=np.int64)
                if cand.size == 0:
                    break
                costs = np.empty(cand.size)
                for s0 in range(0, cand.size, 256):
                    chunk = cand[s0 : s0 + 256]
                    O = np.stack([ex[r : r + n, c : c + n] for r, c in (divmod(int(f), cols) for f in chunk)])
                    I = np.repeat(inter[u][None], len(chunk), axis=0)
                    g = None if grads is None else np.repeat(grads[u][None], len(chunk), axis=0)
                    _, cc = kernels.omega_cuts(I, O, eps=eps, threads=threads, intermediate_grad=g,
                                               keep_border=keep_border)
                    costs[s0 : s0 + len(chunk)] = cc
                order_list.append(int(cand[int(np.argmin(costs))]))  # first of the cheapest (nearest first)
            order = np.asarray(order_list, dtype=np.int64)
        picks = pick_distinct(order, cols, n_variants, exclude)
        if len(picks) < n_variants:
            raise ParameterError(
                f"tile_size = {n}: not enough candidates more than {exclude} pixels apart for {n_variants} "
                f"matching patches (match = {strategy!r}, match_k = {match_k}); use a larger match_k or exemplar"
            )
        for v, f in enumerate(picks):
            r, c = divmod(f, cols)
            chosen[u, v] = (r, c)
            chosen_D[u, v] = exact(u, r, c)
        report("matching patches", u + 1, U)
    return chosen, chosen_D, best_D


def _select(
    ex: np.ndarray,
    n: int,
    tile_patches: np.ndarray,
    n_colours: int,
    rng: np.random.Generator,
    method: str,
    polish: bool,
    generations: int | None,
    population: int | None,
    normalise: bool,
    params: dict[str, Any],
    threads: int | None,
    report: Progress,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Genes chosen by :func:`tilesynth.select.select_genes` on the exact population objective."""
    from .select import select_genes

    # E is over the intermediate tiles: one per distinct corner tuple (the 32-set's variants share theirs).
    from ._chunks import chunkable

    uniq = np.unique(tile_patches, axis=0)
    ev = kernels.PopulationEvaluator(ex, n, uniq, n_colours, lam=LAMBDA, normalise=bool(normalise), features=True)
    res = select_genes(
        method, chunkable(lambda g: ev.evaluate(g, threads)), ex.shape, n_colours, n, rng, polish=polish,
        generations=generations, population=population, progress=report, **params,
    )
    info = res.to_dict()
    info.pop("genes")
    info["normalise"] = bool(normalise)
    info["objective_E"] = info.pop("E")
    info["objective_D"] = info.pop("D")
    # wall time goes in the tile set's timing (selection_s), not in the content: same seed, same bytes.
    info.pop("wall_time")
    return res.genes, info


POISSON_TOL = kernels.DEFAULT_POISSON_TOL
"""Relative residual to which :func:`smooth_tiles` solves the Poisson equation (issue 5: 1e-6)."""


def smooth_tiles(
    intermediate: np.ndarray,
    matching: np.ndarray,
    masks: np.ndarray,
    threads: int | None = None,
    tol: float = POISSON_TOL,
    clip: bool = True,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Poisson-smooth composed ω-tiles (002 §3.3): the region inside each cutting curve is the guided
    interpolation of the matching patch O, with the composed tile's pixels next to the region as the Dirichlet
    boundary (:func:`tilesynth.kernels.poisson_smooth`, exact to ``tol``).

    The region is the cut mask minus the one-pixel tile border. With the default ``keep_border`` the mask never
    reaches the border, so this is the mask itself. With 002's literal border, O reaches the border near the side
    midpoints; those border pixels are then kept as they are (O's values) and act as Dirichlet pixels too, so
    smoothing never changes a border pixel and never adds a seam between tiles. (Taking the tile border as a free
    Neumann boundary instead would move border pixels that the neighbouring tile does not share.)

    The interpolation can overshoot [0, 1] near strong seams; the returned tiles are clipped to [0, 1] (they are
    images), and the number of clipped values is reported. ``clip=False`` returns the solution as it is (float
    maps of any range, :func:`tilesynth.synthesize_map`); ``clipped`` then counts the values outside [0, 1].

    Parameters
    ----------
    intermediate, matching : ``(K, N, N, C)`` float32 intermediate tiles I and matching patches O.
    masks : ``(K, N, N)`` bool cut masks (True = the pixel comes from O).
    threads : worker threads (tiles and channels are solved in parallel; the result does not depend on it).
    tol : relative residual of the solve.

    Returns
    -------
    ``(tiles, info)``: the smoothed float32 tiles and ``{"tol", "iterations_max", "residual_max",
    "unknowns", "clipped"}`` (``unknowns`` and ``clipped`` summed over the tiles).
    """
    cut = np.asarray(masks, dtype=bool)
    m = cut.copy()
    m[:, 0, :] = m[:, -1, :] = False
    m[:, :, 0] = m[:, :, -1] = False
    composed = np.where(cut[..., None], matching, intermediate).astype(np.float32)
    out, pinfo = kernels.poisson_smooth(composed, matching, m, threads=threads, tol=tol, info=True)
    clipped = int(np.count_nonzero((out < 0) | (out > 1)))
    if clip:
        np.clip(out, 0.0, 1.0, out=out)
    info = {
        "tol": float(tol),
        "iterations_max": int(np.max(pinfo.iterations, initial=0)),
        "residual_max": float(np.max(pinfo.residual, initial=0.0)),
        "unknowns": int(np.sum(pinfo.unknowns)),
        "clipped": clipped,
    }
    return out, info


def build_omega(
    exemplar: np.ndarray,
    tileset: str = "16a",
    tile_size: int | None = None,
    genes: np.ndarray | None = None,
    seed: int | None = None,
    threads: int | None = None,
    eps: float = kernels.DEFAULT_EPS,
    gradients: str = "patch",
    keep_border: bool = True,
    progress: Progress | None = None,
    selection: dict[str, Any] | None = None,
    exemplar_info: dict[str, Any] | None = None,
    select: str | None = None,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    normalise: bool = False,
    select_params: dict[str, Any] | None = None,
    match: str = "ssd",
    match_k: int | str | None = None,
    metric: str = "color",
    smooth: bool = False,
) -> TileSet:
    """Build a set of ω-tiles from ``exemplar``.

    Parameters
    ----------
    exemplar : image ``(H, W[, C])``, uint8/uint16 or float in [0, 1].
    tileset : name of the tile-set definition: "4", "8", "16a", "16b" or "32".
    tile_size : N, even, at most the exemplar's shorter side; default :func:`default_tile_size`.
    genes : optional ``(n, 2)`` top-left positions of the n sample patches (n = number of colours of the set),
        in the order of the set's colours. Default: random distinct positions drawn from ``seed``.
    seed : seed of the random choices (recorded in the tile set; None draws one).
    threads : worker threads for the kernels (None: ``TILESYNTH_NUM_THREADS`` or all cores). The result does
        not depend on it.
    eps : epsilon of the Kwatra weight.
    gradients : "patch" (default) or "tile": where the gradients of the intermediate tile in the Kwatra weight
        come from (see the module docstring).
    keep_border : tie the tile's border ring to the intermediate tile, so O never reaches the border (default;
        see the module docstring). False is the literal definition of 002.
    progress : optional callback ``(stage, done, total)``.
    selection : how given ``genes`` were chosen (stored in the tile set), default ``{"method": "given"}``.
    exemplar_info : extra facts about the exemplar to record (file name, bit depth).
    select : choose the genes by optimising E (see :mod:`tilesynth.select`): "random" (one random vector, the
        default without ``genes``), "best-of" (best of 100 random vectors), "ga" (000's genetic algorithm) or
        "ais" (003's immune system). Not allowed together with ``genes``.
    polish : follow the selection with the exact coordinate-descent polish (:func:`tilesynth.select.polish_genes`).
    generations, population : N_g and the population size of "ga" / "ais" (count of "best-of"); None: the papers'.
    normalise : optimise 003's normalised objective (C_j divided by the N·N pixels of the tile) instead of the
        plain SSD; the stored E and D_j are always the plain ones, the selection's own E is in ``selection``.
    select_params : further method parameters (alpha, p_crossover, s_min, ...; see
        :func:`tilesynth.select.select_genes`).

    match : how the matching patch O of each intermediate tile is chosen: "ssd" (smallest SSD, default),
        "circle" / "midpoints" (002's heuristics: smallest Kwatra weight sum around the circle / near the side
        midpoints), "best-cut" (the real min-cut for the ``match_k`` best candidates by distance, cheapest kept);
        see :mod:`tilesynth.matching`.
    match_k : candidates of "best-cut": a positive int (default 16) or "all" (every translation).
    metric : distance for the matching search and for D_j / E: "color" (SSD), "eq3" (SSD plus μ·squared
        gradient difference, 000 eq. 3) or "eq2" (gradient-weighted SSD, 000 eq. 2; not with ``select``).
    smooth : Poisson-smooth the region inside every cutting curve (002 §3.3; :func:`smooth_tiles`). The solver's
        statistics are stored in ``params["smooth"]``; the cut masks, costs and provenance are unchanged.

    D_j is the distance (``metric``) between intermediate tile j and its matching patch; E is computed from the
    smallest distance of every intermediate tile over all translations, whatever ``match`` chose.

    With ``select``, the convergence history (best and mean E of every generation) is stored in
    ``params["selection"]["history"]``.
    """
    t0 = time.perf_counter()
    ex = as_image(exemplar, "exemplar")
    if np.may_share_memory(ex, exemplar):
        ex = ex.copy()  # the tile set keeps the exemplar: never alias the caller's array
    check_exemplar_size(ex.shape)
    if not isinstance(tileset, str):
        raise ParameterError(f"tileset = {tileset!r}: expected a tile-set name such as '16a' or 'n2'")
    defn = get_tileset(tileset)
    n = default_tile_size(ex.shape) if tile_size is None else check_tile_size(tile_size, ex.shape)
    seed = seed_int(seed)
    threads = threads_arg(threads)
    eps = finite_float(eps, "eps", positive=True)
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress = {progress!r}: must be a callable (stage, done, total) or None")
    if exemplar_info is not None and not isinstance(exemplar_info, dict):
        raise ParameterError(f"exemplar_info = {exemplar_info!r}: must be a dict or None")
    rng = np.random.default_rng(seed)
    colours = list(defn.colours)
    if gradients not in ("patch", "tile"):
        raise ParameterError(f"gradients = {gradients!r}: must be 'patch' or 'tile'")
    strategy, match_k = check_strategy(match, match_k)
    metric = check_metric(metric)
    if not isinstance(smooth, (bool, np.bool_)):
        raise ParameterError(f"smooth = {smooth!r}: must be True or False")
    report = progress or (lambda stage, done, total: None)
    index = {c: i for i, c in enumerate(colours)}
    tile_patches = np.array([[index[c] for c in t] for t in defn.tiles], dtype=np.int64)
    optimise = (select is not None and select != "random") or polish or normalise or bool(select_params)
    if optimise and metric == "eq2":
        raise ParameterError(
            "metric = 'eq2' with select: eq. 2 has no FFT or quadrant structure (a direct sum over every "
            "translation, ~50 M operations per 80x80 tile), too slow for a population search; select with "
            "metric 'color' or 'eq3', or use eq2 only for the matching patches of given or random genes"
        )
    if genes is not None and (select is not None or optimise):
        raise ParameterError("genes and select: give one (select chooses the genes)")
    if genes is None and not optimise:
        # One random gene vector (the original ω construction), drawn exactly as random_genes does.
        genes_arr = random_genes(ex.shape, len(colours), n, rng)
        sel = {"method": "random"} if selection is None else dict(selection)
    elif genes is None:
        genes_arr, sel = _select(
            augmented(ex) if metric == "eq3" else ex, n, tile_patches, len(colours), rng, select or "random",
            polish, generations, population, normalise, dict(select_params or {}), threads, report,
        )
    else:
        genes_arr = check_genes(genes, len(colours), ex.shape, n)
        sel = {"method": "given"} if selection is None else dict(selection)
    t_sel = time.perf_counter()
    variants = np.asarray(defn.variants, dtype=np.int64)
    # One intermediate tile per distinct corner tuple; variant v of a tuple takes its (v+1)-th best O.
    uniq, first, inverse = np.unique(tile_patches, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)  # keep the order in which tuples first appear
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    uniq = uniq[order]
    inverse = rank[np.asarray(inverse).reshape(-1)]
    n_variants = int(variants.max()) + 1

    report("intermediate tiles", 0, 1)
    inter, inter_src = intermediate_tiles(ex, genes_arr, uniq, n)
    t1 = time.perf_counter()
    t0_build = t_sel
    report("intermediate tiles", 1, 1)

    report("matching patches", 0, 1)
    exclude = n // 4 if n_variants > 1 else 0
    if strategy == "ssd" and metric == "color":
        # the plain path: exact best (and second-best, far enough) SSD translations
        offsets, ssd = kernels.best_matches(ex, inter, k=n_variants, exclude_radius=exclude, threads=threads)
        if offsets.shape[1] < n_variants:
            raise ParameterError(
                f"tile_size = {n}: the exemplar has too few distinct translations for {n_variants} matching "
                "patches per intermediate tile; use a smaller tile size or a larger exemplar"
            )
        best_D = ssd[:, 0]
        chosen, chosen_D = offsets, ssd
    else:
        chosen, chosen_D, best_D = _choose_matches(
            ex, inter, inter_src, n, n_variants, exclude, strategy, match_k, metric, gradients, keep_border, eps,
            threads, report,
        )
    t2 = time.perf_counter()
    report("matching patches", 1, 1)

    k = tile_patches.shape[0]
    match_offsets = chosen[inverse, variants]
    D = chosen_D[inverse, variants].astype(np.float64)
    I_tiles = inter[inverse]
    I_src = inter_src[inverse]
    O_tiles = np.stack([ex[r : r + n, c : c + n] for r, c in match_offsets])
    report("cutting curves", 0, k)
    grad = patch_gradients(ex, I_src) if gradients == "patch" else None
    masks, costs = kernels.omega_cuts(
        I_tiles, O_tiles, eps=eps, threads=threads, intermediate_grad=grad, keep_border=bool(keep_border)
    )
    t3 = time.perf_counter()
    report("cutting curves", k, k)

    yy, xx = np.mgrid[0:n, 0:n].astype(np.int32)
    O_src = np.stack([np.stack([yy + r, xx + c], axis=-1) for r, c in match_offsets]).astype(np.int32)
    if smooth:
        report("poisson smoothing", 0, k)
        tiles, smooth_info = smooth_tiles(I_tiles, O_tiles, masks, threads=threads)
        report("poisson smoothing", k, k)
    else:
        tiles = np.where(masks[..., None], O_tiles, I_tiles).astype(np.float32)
        smooth_info = None
    t4 = time.perf_counter()
    source = np.where(masks[..., None], O_src, I_src).astype(np.int32)

    E = energy(best_D)
    info = {"shape": list(ex.shape), "sha256": exemplar_digest(ex)}
    info.update(exemplar_info or {})
    from . import __version__

    return TileSet(
        scheme="omega",
        layout=defn.to_dict(),
        tiles=np.ascontiguousarray(tiles),
        source=np.ascontiguousarray(source),
        cut_masks=np.ascontiguousarray(masks),
        genes=genes_arr,
        tile_patches=tile_patches,
        match_offsets=np.ascontiguousarray(match_offsets, dtype=np.int64),
        D=np.ascontiguousarray(D),
        cut_costs=np.ascontiguousarray(costs, dtype=np.float64),
        exemplar=ex,
        E=E,
        params={
            "set": defn.name,
            "tile_size": n,
            "eps": float(eps),
            "gradients": gradients,
            "keep_border": bool(keep_border),
            "lambda": LAMBDA,
            "second_match_exclude_radius": n // 4 if n_variants > 1 else None,
            "match": strategy,
            "match_k": None if match_k is None else ("all" if match_k < 0 else match_k),
            "metric": metric,
            "mu": MU if metric != "color" else None,
            "seed": seed,
            "selection": sel,
            **({"smooth": smooth_info} if smooth_info is not None else {}),
        },
        exemplar_info=info,
        timing={
            "selection_s": t_sel - t0,
            "intermediate_s": t1 - t0_build,
            "matching_s": t2 - t1,
            "cutting_s": t3 - t2,
            **({"smoothing_s": t4 - t3} if smooth else {}),
            "total_s": time.perf_counter() - t0,
        },
        version=__version__,
    )
