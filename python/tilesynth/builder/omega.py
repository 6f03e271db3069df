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
   cross (see :func:`tilesynth.base.kernels.omega_cuts`); the ω-tile takes O inside the curve.

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

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base import kernels
from ..base.memory import release_freed_memory
from ..base.validate import finite_float
from ..errors import ParameterError
from ..layouts.complete import complete_defaults
from ..layouts.corners import CornerPlan, IntermediateTiles, corner_set, intermediate_tiles
from ..measure.diagnose import finish_build
from ..tileset.tilefile import TileSet
from .compose import cut_and_compose, finish_tileset, patch_gradients
from .genes.draws import (  # noqa: F401 - re-exported: the public names of the genes stage lived here
    LAMBDA,
    MIN_TILE_SIZE,
    check_exemplar_size,
    check_genes,
    check_tile_size,
    default_tile_size,
    energy,
    random_genes,
)
from .genes.omega_borders import DEFAULT_BORDER_TRIES, DEFAULT_CRITERION, check_criterion, corner_border_draws
from .genes.select import choose_genes, wants_selection
from .genes.wang_borders import check_border_tries
from .masking import active, masked_search, valid_fallback
from .matching.choose import (
    EQ2_EPS,
    MU,
    augmented,
    check_metric,
    check_strategy,
    gradient_norm,
    pick_distinct,
    strategy_edges,
)
from .options import BuildOptions, Progress, SeedLike, common_options
from .smoothing import POISSON_TOL, smooth_tiles  # noqa: F401 - re-exported


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
            kernels.weighted_ssd_map(
                ex,
                g,
                inter[u],
                np.ascontiguousarray(g[inter_src[u, ..., 0], inter_src[u, ..., 1]]),
                MU,
                EQ2_EPS,
                threads=threads,
            )
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
    opts: OmegaOptions,
    threads: int | None,
    report: Progress,
    mask: Any = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Matching patches by ``opts.strategy`` (see :mod:`tilesynth.builder.matching.choose`): offsets ``(U, v, 2)``, their
    distances ``(U, v)`` and each tile's smallest distance ``(U,)`` (for E)."""
    strategy, match_k, metric, eps = opts.strategy, opts.match_k, opts.metric, opts.eps
    gradients, keep_border = opts.gradients, opts.keep_border
    U = inter.shape[0]
    maps, exact, best = _distance_search(ex, inter, inter_src, metric, threads)
    valid = None if mask is None else mask.valid(n).ravel()  # issue 14: only windows clear of the mask
    if valid is not None:
        maps = [np.where(valid.reshape(m.shape), m, np.inf) for m in maps]
        best = None  # the orders below come from the maps, restricted to valid windows
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
        if valid is not None:
            dist_order = dist_order[valid[dist_order]]
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
                inter[u],
                ex,
                wxm,
                wym,
                eps=eps,
                template_grad=None if grads is None else grads[u],
                threads=threads,
            )
            order = np.argsort(score, axis=None, kind="stable")
            if valid is not None:
                order = order[valid[order]]
        else:  # best-cut: the real cut for the k nearest candidates (per variant, away from earlier picks)
            kk = total if match_k is None or match_k < 0 else min(match_k, total)
            g_u = None if grads is None else grads[u]
            order = _best_cut_order(
                ex, inter[u], g_u, dist_order, cols, n, n_variants, exclude, kk, opts, threads
            )
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


def _best_cut_order(
    ex: np.ndarray,
    tile: np.ndarray,
    grad: np.ndarray | None,
    dist_order: np.ndarray,
    cols: int,
    n: int,
    n_variants: int,
    exclude: int,
    kk: int,
    opts: OmegaOptions,
    threads: int | None,
) -> np.ndarray:
    """``match="best-cut"`` for one intermediate tile: per variant, of the ``kk`` nearest candidates more than
    ``exclude`` pixels from the earlier picks, the one with the cheapest real cut (the nearest of equals)."""
    order_list: list[int] = []
    for _v in range(n_variants):
        far = [f for f in dist_order.tolist()
               if all(max(abs(f // cols - p // cols), abs(f % cols - p % cols)) > exclude
                      for p in order_list)] if order_list else dist_order.tolist()  # fmt: skip
        cand = np.asarray(far[:kk], dtype=np.int64)
        if cand.size == 0:
            break
        costs = np.empty(cand.size)
        for s0 in range(0, cand.size, 256):
            chunk = cand[s0 : s0 + 256]
            O = np.stack([ex[r : r + n, c : c + n] for r, c in (divmod(int(f), cols) for f in chunk)])
            I = np.repeat(tile[None], len(chunk), axis=0)
            g = None if grad is None else np.repeat(grad[None], len(chunk), axis=0)
            _, cc = kernels.omega_cuts(I, O, eps=opts.eps, threads=threads, intermediate_grad=g,
                                       keep_border=opts.keep_border)  # fmt: skip
            costs[s0 : s0 + len(chunk)] = cc
        order_list.append(int(cand[int(np.argmin(costs))]))  # first of the cheapest (nearest first)
    return np.asarray(order_list, dtype=np.int64)


@dataclass(frozen=True)
class OmegaOptions:
    """The ω scheme's own options of one build, validated once (:func:`omega_options`)."""

    eps: float
    gradients: str
    keep_border: bool
    strategy: str
    match_k: int | None
    metric: str
    smooth: bool
    normalise: bool
    cut_region: str = "circle"
    cut_bias: float | None = None
    diversity: int | None = None
    augment: str = "none"

    @property
    def grad_from_patches(self) -> bool:
        return self.gradients == "patch"


def omega_options(
    *, eps: Any, gradients: Any, keep_border: Any, match: Any, match_k: Any, metric: Any, smooth: Any,
    normalise: Any, cut_region: Any = "circle", cut_bias: Any = None, diversity: Any = None,
    augment: Any = "none",
) -> OmegaOptions:  # fmt: skip
    """Validate the ω options (names as in :func:`build_omega`; ``cut_region`` and ``diversity`` already
    resolved from the set's defaults, ``diversity`` 0 meaning off)."""
    eps = finite_float(eps, "eps", positive=True)
    if gradients not in ("patch", "tile"):
        raise ParameterError(f"gradients = {gradients!r}: must be 'patch' or 'tile'")
    strategy, k = check_strategy(match, match_k)
    metric = check_metric(metric)
    if not isinstance(smooth, (bool, np.bool_)):
        raise ParameterError(f"smooth = {smooth!r}: must be True or False")
    if cut_region not in ("circle", "free", "free8", "ring"):
        raise ParameterError(f"cut_region = {cut_region!r}: must be 'circle', 'free', 'free8' or 'ring'")
    if cut_bias is not None and (cut_region == "circle" or finite_float(cut_bias, "cut_bias") < 0):
        raise ParameterError(
            f"cut_bias = {cut_bias!r}: a number >= 0, only with cut_region 'free', 'free8' or 'ring'"
        )
    cut_bias = None if cut_bias is None else float(cut_bias)  # None: levers.default_bias (needs N)
    diversity = None if diversity == 0 else diversity
    if diversity is not None and (
        isinstance(diversity, (bool, np.bool_))
        or not isinstance(diversity, (int, np.integer))
        or diversity < 1
    ):
        raise ParameterError(
            f"diversity = {diversity!r}: a positive int (uses per exemplar region), 0 or None"
        )
    if diversity is not None and (strategy != "ssd" or metric != "color"):
        raise ParameterError("diversity: only with match='ssd' and metric='color'")
    from .matching.augment import (
        check_augment,  # issue 12: flip / rotate augmentation of the matching candidates
    )

    augment = check_augment(augment)
    if augment != "none" and (strategy != "ssd" or metric != "color"):
        raise ParameterError(f"augment = {augment!r}: only with match='ssd' and metric='color'")
    return OmegaOptions(
        eps, gradients, bool(keep_border), strategy, k, metric, bool(smooth), bool(normalise), cut_region,
        cut_bias, None if diversity is None else int(diversity), augment,
    )  # fmt: skip


def omega_evaluator(
    ex: np.ndarray,
    n: int,
    plan: CornerPlan,
    opts: OmegaOptions,
    threads: int | None,
    lam: float = LAMBDA,
    mask: Any = None,
) -> Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]:
    """E of gene populations (:class:`~tilesynth.base.kernels.PopulationEvaluator`) over the intermediate tiles: one
    per distinct corner tuple (the 32-set's variants share theirs), on 000's eq. 3 features for ``metric="eq3"``.
    With a ``mask`` (:class:`tilesynth.builder.masking.ExemplarMask`), D_j is the best match among the valid windows
    (the penalty channel of :meth:`~tilesynth.builder.masking.ExemplarMask.search_image`; the genes are valid)."""
    search = augmented(ex) if opts.metric == "eq3" else ex
    unscale = 1.0
    if mask is not None:
        s = mask.search_scale(search, n)
        search, unscale = mask.search_image(search, n, features=True), 1.0 / (s * s)
    uniq = np.unique(plan.tile_patches, axis=0)
    ev = kernels.PopulationEvaluator(
        search, n, uniq, plan.n_colours, lam=lam, normalise=opts.normalise, features=True
    )
    if mask is None:
        return lambda g: ev.evaluate(g, threads)

    def masked(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # the D_j of the scaled search are exactly s² times the exemplar's; E from the unscaled D_j
        _, D = ev.evaluate(g, threads)
        D = np.asarray(D, dtype=np.float64) * unscale
        d = D / (n * n) if opts.normalise else D
        return LAMBDA * d.sum(axis=1) + (1.0 - LAMBDA) * d.var(axis=1), D

    return masked


def _matching_patches(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, inter: np.ndarray, inter_src: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Offsets ``(U, v, 2)`` and distances ``(U, v)`` of the matching patches, each intermediate tile's
    smallest distance ``(U,)`` (for E), and the patches' transforms ``(U, v)`` (None without ``augment``)."""
    if (
        opts.augment != "none"
    ):  # issue 12: flip / rotate augmentation (tilesynth.builder.matching.augment); no mask (checked)
        return _augmented_matches(b, opts, plan, inter, inter_src)
    return (*_plain_matches(b, opts, plan, inter, inter_src), None)


def _augmented_matches(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, inter: np.ndarray, inter_src: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_matching_patches` with ``augment``: the candidates of every orientation (:mod:`tilesynth.builder.matching.augment`)."""
    from .matching.augment import best_augmented, mode_transforms

    modes = mode_transforms(opts.augment)
    if opts.diversity is None:
        off, ssd, tid, best = best_augmented(b.exemplar, inter, plan.n_variants, modes, b.threads)
        return off, ssd, best, tid
    from .matching.levers import diverse_matches_augmented, self_offsets

    best = kernels.best_matches(b.exemplar, inter, k=1, threads=b.threads)[1][:, 0]
    chosen, chosen_D, tid = diverse_matches_augmented(
        b.exemplar, inter, plan.n_variants, opts.diversity, b.threads, self_offsets(inter_src), modes
    )
    return chosen, chosen_D, best, tid


def _plain_matches(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, inter: np.ndarray, inter_src: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_matching_patches` without ``augment``."""
    n, nv = b.tile_size, plan.n_variants
    exclude = n // 4 if nv > 1 else 0
    m = active(b.mask)  # issue 14: matching patches only from windows clear of the mask
    if opts.strategy != "ssd" or opts.metric != "color":
        out = _choose_matches(b.exemplar, inter, inter_src, n, nv, exclude, opts, b.threads, b.report, m)
        if m is not None:
            m.check_windows(out[0], n, "matching patches", n)
        return out
    diverse = opts.diversity is not None  # the diversity lever's search takes images (at most 4 channels)
    search, tpl, unscale = (
        (b.exemplar, inter, 1.0)
        if m is None
        else masked_search(m, b.exemplar, inter, n, features=not diverse)
    )
    if (
        opts.diversity is not None
    ):  # issue 12: diverse matching patches (tilesynth.builder.matching.levers); E keeps the best
        from .matching.levers import assign_diverse, check_max_uses, diverse_candidates, self_offsets

        check_max_uses(opts.diversity)
        cands = diverse_candidates(search, tpl, nv, b.threads)
        best = cands[1][:, 0].copy()  # the exact best SSD: the candidates come best first (was a 2nd search)
        chosen, chosen_D, _ = assign_diverse(cands, n, nv, opts.diversity, exclude=self_offsets(inter_src))
        if m is not None:
            best, chosen_D = best * unscale, chosen_D * unscale
            chosen, chosen_D = valid_fallback(m, chosen, chosen_D, search, tpl, exclude, b.threads, unscale)
        return chosen, chosen_D, best
    # the plain path: exact best (and second-best, far enough) SSD translations
    if m is None:
        offsets, ssd = kernels.best_matches(search, tpl, k=nv, exclude_radius=exclude, threads=b.threads)
    else:
        index = kernels.SsdIndex(search, b.threads, features=True)
        offsets, ssd = index.best_matches(tpl, k=nv, exclude_radius=exclude, threads=b.threads)
        ssd = ssd * unscale
        m.check_windows(offsets, n, "matching patches", n)
    if offsets.shape[1] < nv:
        raise ParameterError(
            f"tile_size = {n}: the exemplar has too few distinct translations for {nv} matching "
            "patches per intermediate tile; use a smaller tile size or a larger exemplar"
        )
    return offsets, ssd, ssd[:, 0]


def _cut_bias(opts: OmegaOptions, n: int) -> float:
    from .matching.levers import default_bias

    return default_bias(opts.cut_region, n) if opts.cut_bias is None else opts.cut_bias


PERIODIC_MODES = ("auto", "lock", "off")
"""Values of ``build_omega(periodic=...)``."""


def _periodic_rule(b: BuildOptions, periodic: Any, eligible: bool) -> dict[str, Any] | None:
    """The periodic exemplar rule of :mod:`tilesynth.builder.periodic` for a build: ``{"tile_size", "shift_correlation"}``
    or None (not eligible, ``periodic="off"``, a mask, or an exemplar that does not repeat at a tile's shift)."""
    if periodic not in PERIODIC_MODES:
        raise ParameterError(f"periodic = {periodic!r}: must be one of {', '.join(PERIODIC_MODES)}")
    if periodic == "off" or not eligible or active(b.mask) is not None:
        return None
    found = b.source.period(b.tile_size)
    if found is None:
        return None
    return {"tile_size": int(found[0]), "shift_correlation": round(float(found[1]), 6)}


def _omega_params(b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, sel: dict, smooth_info: Any) -> dict:
    n = b.tile_size
    return {
        "set": b.definition.name,
        "tile_size": n,
        "eps": float(opts.eps),
        "gradients": opts.gradients,
        "keep_border": opts.keep_border,
        "lambda": LAMBDA,
        "second_match_exclude_radius": n // 4 if plan.n_variants > 1 else None,
        "match": opts.strategy,
        "match_k": None if opts.match_k is None else ("all" if opts.match_k < 0 else opts.match_k),
        "metric": opts.metric,
        "mu": MU if opts.metric != "color" else None,
        "seed": b.seed,
        "selection": sel,
        **({"smooth": smooth_info} if smooth_info is not None else {}),
        **(
            {"cut_region": opts.cut_region, "cut_bias": _cut_bias(opts, n)}
            if opts.cut_region != "circle"
            else {}
        ),
        **({"diversity": opts.diversity} if opts.diversity is not None else {}),
    }


# Length: 140 lines, of which 57 are the docstring of its 25 options; the body (83) is the stage sequence
# plus the complete-set defaults (tile size, cut region, diversity) resolved before the options are checked.
def build_omega(
    exemplar: np.ndarray,
    *,
    tileset: str = "c5",
    tile_size: int | None = None,
    genes: np.ndarray | None = None,
    seed: SeedLike = None,
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
    cut_region: str | None = None,
    diversity: int | None = None,
    cut_bias: float | None = None,
    mask: Any = None,
    alpha: str = "auto",
    objective: str | None = None,
    rerank: int | None = None,
    border_tries: int = DEFAULT_BORDER_TRIES,
    augment: str = "none",
    periodic: str = "auto",
    border_criterion: str | None = None,
) -> TileSet:
    """Build a set of ω-tiles from ``exemplar``.

    Parameters
    ----------
    exemplar : image ``(H, W[, C])``, uint8/uint16 or float in [0, 1].
    tileset : name of the tile-set definition: the papers' "4", "8", "16a", "16b", "32", "B", "n2", ... or a
        complete set "c<K>" / "c<K>x<V>". Default "c5", the default of ``tilesynth build`` (measured with
        ``benches/repetition.py``, issue 12: the papers' sets repeat visibly; against "c4", the default
        before, c5 halves the periodic copies (0.115 -> 0.056 over the 9 bench textures), lowers the
        autocorrelation peak (0.233 -> 0.213) and raises coverage (0.78 -> 0.84) at the same border seam
        (0.72 -> 0.74, at most 0.86) for 2.3x the build time and 2.4x the tiles: 625).
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
    select : choose the genes (see :mod:`tilesynth.builder.genes.select`): "random" (one random vector), "best-of" (best of
        100 random vectors), "ga" (000's genetic algorithm) or "ais" (003's immune system), by ``objective``.
        None (the default without ``genes``): for the papers' sets best-of 32 by ΣD, the best 4 re-ranked by the
        real cut score; for complete sets (``c4``, ...) one random draw (:mod:`tilesynth.builder.genes.cut_objective`, measured with
        ``benches/selection.py``). Not allowed together with ``genes``.
    objective : what the selection minimises: "cut" (the robust real cut score, :func:`tilesynth.measure.quality.cut_score`,
        ΣD as the cheap first stage and the best ``rerank`` candidates built and re-ranked; the
        default of ``select=None`` on the papers' sets), "visible" (the ``rerank`` best by ΣD built and measured on
        a proxy synthesis, the smallest rank sum of cut seam, coherence and texture statistics kept;
        :mod:`tilesynth.builder.genes.visible_objective`), "sum-d" (ΣD_j) or "E" (the papers' E; the default of a named ``select``).
    rerank : candidates the "cut" / "visible" objective builds and re-ranks (default 4 / 8).
    polish : follow the selection with the exact coordinate-descent polish (:func:`tilesynth.builder.genes.select.polish_genes`);
        with ``objective="cut"`` the cut polish (:func:`tilesynth.builder.genes.cut_objective.cut_polish`).
    generations, population : N_g and the population size of "ga" / "ais" (count of "best-of"); None: the papers'.
    normalise : optimise 003's normalised objective (C_j divided by the N·N pixels of the tile) instead of the
        plain SSD; the stored E and D_j are always the plain ones, the selection's own E is in ``selection``.
    select_params : further method parameters (alpha, p_crossover, s_min, ...; see
        :func:`tilesynth.builder.genes.select.select_genes`).

    match : how the matching patch O of each intermediate tile is chosen: "ssd" (smallest SSD, default),
        "circle" / "midpoints" (002's heuristics: smallest Kwatra weight sum around the circle / near the side
        midpoints), "best-cut" (the real min-cut for the ``match_k`` best candidates by distance, cheapest kept);
        see :mod:`tilesynth.builder.matching.choose`.
    match_k : candidates of "best-cut": a positive int (default 16) or "all" (every translation).
    metric : distance for the matching search and for D_j / E: "color" (SSD), "eq3" (SSD plus μ·squared
        gradient difference, 000 eq. 3) or "eq2" (gradient-weighted SSD, 000 eq. 2; not with ``select``).
    smooth : Poisson-smooth the region inside every cutting curve (002 §3.3; :func:`smooth_tiles`). The solver's
        statistics are stored in ``params["smooth"]``; the cut masks, costs and provenance are unchanged.
    cut_region : "circle" (002's inscribed circle) or "free" (free but for a border ring and corner discs, so
        most of the tile is its own matching patch; a tapered area reward and a ring penalty keep the cut off
        the ring; :mod:`tilesynth.builder.matching.levers`). "ring": the same region with a uniform area reward, which presses
        the cut onto the ring (a grid of seams 2 px inside the tile borders; kept for comparison). "free8": "free"
        on an 8-connected grid with geo-cut weights (cut cost ~ Euclidean length, no staircases; opt-in). None
        (default): "free" for the complete sets of the hashed lookup (``c3x2``, ``c4``, ...), "circle" for the
        papers' sets.
    cut_bias : "free"/"ring" only: the area reward per pixel in units of the mean edge weight (default
        :func:`tilesynth.builder.matching.levers.default_bias`: 32/N for "free", 0.02 for "ring").
    diversity : m >= 1: assign the matching patches under a diversity constraint (each exemplar region used at
        most m times, :func:`tilesynth.builder.matching.levers.diverse_matches`) instead of each tile's best; 0: each tile's
        best. None (default): 1 for complete sets (with ``match="ssd"``, ``metric="color"``), else 0.
        Complete sets also default to a tile size of a quarter of the exemplar's shorter side
        (:func:`tilesynth.layouts.complete.default_complete_tile_size`) instead of half: the lookup, not the tile
        size, makes them non-periodic, and K⁴·V tiles of half the exemplar would be slow to build and big.
    The choice of these defaults was measured with ``benches/repetition.py`` (issue 12).
    mask : pixels that must never be used (issue 14, :mod:`tilesynth.builder.masking`): an ``(H, W)`` array (True or
        >= 0.5 = masked) or the path of a mask image (white = masked); no sample patch, matching patch or cut
        region takes a masked pixel.
    alpha : "auto" (default: the alpha channel of a 2- or 4-channel exemplar that is not opaque everywhere is a
        mask, alpha < 0.5 masked, and is dropped), "mask" (always) or "colour" (alpha matched as a channel).
    border_tries : with random genes (no ``genes``, no selection), the number of random gene vectors drawn, the
        one whose predicted border seam is closest to 0.8 without exceeding 1 kept (tile borders like the
        texture's own steps, neither seams nor quiet lines; :mod:`tilesynth.builder.genes.omega_borders`). Default 32; 1 is the
        single random draw of before (byte-identical to the old default). With a mask the draws are off (the
        single mask-aware draw is kept).
    augment : "none" (default), "flip", "rotate" or "all": the matching patches may also be mirrored / rotated
        exemplar windows (4, 4 or 8 orientations; for isotropic textures; :mod:`tilesynth.builder.matching.augment`). The
        transform of every tile is stored in ``params["match_transforms"]``. Only with ``match="ssd"``,
        ``metric="color"`` and no mask; costs one matching search per orientation.

    border_criterion : how the border-aware draws are ranked (:data:`tilesynth.builder.genes.omega_borders.CRITERIA`). None
        (default): "stats" for complete sets (of the draws whose predicted border seam is at most 0.9, the one
        whose sample patches are closest to the exemplar in texture statistics and colour,
        :func:`tilesynth.builder.genes.omega_borders.sample_stats_distance`; issue 12), "cap" for the papers' sets.
    periodic : "auto" (default), "lock" or "off". "auto": a complete set built with the default tile size,
        random genes and no mask, on an exemplar that repeats at a shift of one tile in both directions (a
        brick wall), takes its tile size from the exemplar's period (:mod:`tilesynth.builder.periodic`; recorded in
        ``params["selection"]["periodic"]``). "lock": the same, and every sample patch moved to one phase of
        the period (continuous courses, but more copies and a border seam no longer checked by the draw:
        measured, opt-in). Other builds, and every build with "off", are unchanged.

    D_j is the distance (``metric``) between intermediate tile j and its matching patch; E is computed from the
    smallest distance of every intermediate tile over all translations, whatever ``match`` chose.

    With ``select``, the convergence history (best and mean E of every generation) is stored in
    ``params["selection"]["history"]``.
    """
    b = common_options(
        exemplar, tileset=tileset, resolve_set=corner_set, tile_size=tile_size, seed=seed, threads=threads,
        progress=progress, exemplar_info=exemplar_info, mask=mask, alpha=alpha,
    )  # fmt: skip
    with b.source.validated():  # the stages take the exemplar as validated here
        complete = complete_defaults(b.definition, b.exemplar.shape, match, metric)
        if complete is not None:
            if tile_size is None:  # (with a mask: no larger than what fits, issue 14)
                n_c = complete["tile_size"] if b.mask is None else min(complete["tile_size"], b.tile_size)
                b = dataclasses.replace(b, tile_size=n_c)
            cut_region = complete["cut_region"] if cut_region is None else cut_region
            diversity = complete["diversity"] if diversity is None else diversity
        lock = _periodic_rule(
            b, periodic,
            complete is not None and tile_size is None and genes is None and objective is None
            and not wants_selection(select, polish, select_params, extra=normalise),
        )  # fmt: skip
        if lock is not None:  # issue 12: a periodic exemplar's tile size (tilesynth.builder.periodic)
            b = dataclasses.replace(b, tile_size=lock["tile_size"])
        opts = omega_options(
            eps=eps, gradients=gradients, keep_border=keep_border, match=match, match_k=match_k, metric=metric,
            smooth=smooth, normalise=normalise, cut_region="circle" if cut_region is None else cut_region,
            cut_bias=cut_bias, diversity=diversity, augment=augment,
        )  # fmt: skip
        if opts.augment != "none" and active(b.mask) is not None:
            raise ParameterError(
                f"augment = {opts.augment!r} with a mask: the masked search takes untransformed windows only; "
                "use augment='none' with a mask"
            )
        tries = check_border_tries(border_tries)
        plan = CornerPlan.of(b.definition)
        if opts.metric == "eq2" and wants_selection(select, polish, select_params, extra=normalise):
            raise ParameterError(
                "metric = 'eq2' with select: eq. 2 has no FFT or quadrant structure (a direct sum over every "
                "translation, ~50 M operations per 80x80 tile), too slow for a population search; select with "
                "metric 'color' or 'eq3', or use eq2 only for the matching patches of given or random genes"
            )
        from .genes.cut_objective import TopK, cut_polish, resolve_objective, selection_record
        from .genes.cut_objective import rerank as rerank_by_cut

        if rerank is not None:
            select_params = {**(select_params or {}), "rerank": rerank}
        select, objective, select_params, n_rerank = resolve_objective(
            select, objective, genes, polish, select_params, population, complete=complete is not None
        )
        lam = LAMBDA if objective in (None, "E") else 1.0
        top = TopK(max(n_rerank, 1))
        genes_arr, sel = choose_genes(
            genes, n=plan.n_colours, size=b.tile_size, shape=b.exemplar.shape, rng=b.rng,
            evaluator=lambda: top.wrap(
                omega_evaluator(b.exemplar, b.tile_size, plan, opts, b.threads, lam, mask=active(b.mask))
            ),
            select=select, polish=polish and objective != "cut", generations=generations, population=population,
            select_params=select_params or None, selection=selection, optimise=opts.normalise,
            record={"normalise": opts.normalise, **({"objective": objective} if objective else {})},
            progress=b.progress, mask=b.mask,
        )  # fmt: skip
        genes_arr, sel = corner_border_draws(  # issue 14: border-aware random draws (tilesynth.builder.genes.omega_borders)
            b.source, b.tile_size, b.rng, genes_arr, sel, tries,
            genes is None
            and not wants_selection(select, polish, select_params, extra=normalise)
            and active(b.mask) is None  # the draws are not mask-aware: a masked build keeps its one clear draw
            and objective != "window",
            # issue 12: complete sets keep the admissible draw whose sample patches are most like the exemplar
            criterion=(("stats" if complete is not None else DEFAULT_CRITERION) if border_criterion is None
                       else check_criterion(border_criterion)),
        )  # fmt: skip
        if (
            objective == "window"
        ):  # issue 15: the cheap choice of the complete sets (tilesynth.builder.genes.window_objective)
            genes_arr, sel = _window_selection(b, opts, plan, genes_arr, sel, n_rerank)
        if (
            lock is not None
        ):  # issue 12: the periodic rule's record (and with "lock" one phase for every patch)
            if periodic == "lock":
                from .periodic import phase_locked_genes

                genes_arr = phase_locked_genes(b.exemplar, genes_arr, b.tile_size)
            sel = {**sel, "periodic": {**lock, "mode": periodic}}
        t_sel = time.perf_counter()
        release_freed_memory()  # issue 15: the selection's freed buffers do not add to the later stages' peak
        if objective in ("cut", "visible") and sel.get("method") not in ("given", "random"):  # issue 15
            quiet = dataclasses.replace(b, progress=lambda *a: None)
            cands = top.best()
            m = active(b.mask)
            if (
                m is not None
            ):  # issue 14: the evaluator saw the genes projected onto clear windows; keep distinct ones
                cands = [
                    g
                    for g in cands
                    if m.windows_ok(g, b.tile_size).all() and len(np.unique(g, axis=0)) == len(g)
                ]
                cands = cands or [genes_arr]
            if (
                objective == "visible"
            ):  # the visible measures on a proxy synthesis (tilesynth.builder.genes.visible_objective)
                from .genes.visible_objective import visible_choice

                genes_arr, res, sel["visible"] = visible_choice(
                    cands, lambda g: _stages(quiet, opts, plan, g, smooth=False),
                    lambda g, r: _trial_tileset(b, opts, plan, sel, g, r), b.exemplar, b.tile_size, b.threads,
                    b.report,
                )  # fmt: skip
                i, scores = 0, []
            else:
                i, scores, res = rerank_by_cut(
                    cands, lambda g: _stages(quiet, opts, plan, g, smooth=False), b.tile_size, b.report
                )
                genes_arr = cands[i]
                sel["cut"] = selection_record(scores, i, b.tile_size)
            if polish and objective == "cut":
                stage1 = omega_evaluator(b.exemplar, b.tile_size, plan, opts, b.threads, 1.0, mask=m)
                genes_arr, score, res, info = cut_polish(
                    genes_arr, scores[i], res, stage1, lambda g: _stages(quiet, opts, plan, g, smooth=False),
                    b.exemplar.shape, b.tile_size, progress=b.report,
                    allowed=None if m is None else m.valid(b.tile_size),
                )  # fmt: skip
                sel["cut"]["score"] = score if np.isfinite(score) else None
                sel["cut"]["polish"] = info
            if opts.smooth:
                res = _stages(b, opts, plan, genes_arr, smooth=True)
            t_sel = time.perf_counter()
        else:
            res = _stages(b, opts, plan, genes_arr, smooth=opts.smooth)
        ts = finish_tileset(
            scheme="omega", definition=b.definition, exemplar=b.exemplar, tiles=res.tiles, source=res.source,
            cut_masks=res.masks, genes=genes_arr, tile_patches=plan.tile_patches, match_offsets=res.offsets,
            D=res.D, cut_costs=res.costs, E=energy(res.best_D),
            params={**_omega_params(b, opts, plan, sel, res.smooth_info),
                    **({"border_tries": tries} if "border_tries" in sel else {}),
                    **({"augment": opts.augment, "match_transforms": res.transforms.tolist()}
                       if res.transforms is not None else {})},
            exemplar_info=b.exemplar_info,
            timing={"selection_s": t_sel - b.started, **res.timing},
            started=b.started,
        )  # fmt: skip
        return finish_build(ts, b)  # issue 14: the mask record and the input warnings


def _window_selection(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, first: np.ndarray, sel: dict, count: int
) -> tuple[np.ndarray, dict]:
    """``objective="window"``: of the border-best ``count`` of the random draws (``first`` the build's own), the
    one whose window of the hashed tiling measures best (:mod:`tilesynth.builder.genes.window_objective`)."""
    from ..layouts.hashed import lookup_scheme
    from .genes.window_objective import WINDOW_DRAWS, window_candidates, window_choice

    if active(b.mask) is not None:
        raise ParameterError("objective 'window' with a mask: the window draws are not mask-aware; leave the "
                             "objective unset (one clear random draw) with a mask")  # fmt: skip
    cands = window_candidates(b.exemplar, b.tile_size, b.rng, first, count, max(WINDOW_DRAWS, count))
    quiet = dataclasses.replace(b, progress=lambda *a: None)
    genes_arr, rec = window_choice(
        cands, lambda g, idx: _stages(quiet, opts, plan.subset(idx), g, smooth=False),
        lookup_scheme(b.definition), b.exemplar, b.tile_size, b.threads, b.report,
    )  # fmt: skip
    return genes_arr, {**sel, "method": "window", "objective": "window", "window": rec}


def _trial_tileset(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, sel: dict, genes_arr: np.ndarray, res: _Stages
) -> TileSet:
    """The tile set of one candidate of a re-ranking (what a build of ``genes_arr`` returns, without the input
    diagnosis), for measures that need a synthesis (issue 15, :mod:`tilesynth.builder.genes.visible_objective`)."""
    return finish_tileset(
        scheme="omega", definition=b.definition, exemplar=b.exemplar, tiles=res.tiles, source=res.source,
        cut_masks=res.masks, genes=genes_arr, tile_patches=plan.tile_patches, match_offsets=res.offsets,
        D=res.D, cut_costs=res.costs, E=energy(res.best_D), params=_omega_params(b, opts, plan, sel, None),
        exemplar_info=b.exemplar_info, timing=dict(res.timing), started=b.started,
    )  # fmt: skip


@dataclass
class _Stages:
    """What the stages after the genes produce (:func:`_stages`)."""

    tiles: np.ndarray
    source: np.ndarray
    masks: np.ndarray
    costs: np.ndarray
    offsets: np.ndarray
    D: np.ndarray
    best_D: np.ndarray
    smooth_info: Any
    timing: dict[str, float]
    transforms: np.ndarray | None = None  # issue 12: the matching patches' transforms (augment)


def _stages(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, genes_arr: np.ndarray, *, smooth: bool
) -> _Stages:
    """Intermediate tiles, matching patches and the cut of one gene vector (the stages after the selection)."""
    t0 = time.perf_counter()
    b.report("intermediate tiles", 0, 1)
    inter, inter_src = intermediate_tiles(b.exemplar, genes_arr, plan.unique, b.tile_size)
    t_inter = time.perf_counter()
    b.report("intermediate tiles", 1, 1)
    b.report("matching patches", 0, 1)
    chosen, chosen_D, best_D, tids = _matching_patches(b, opts, plan, inter, inter_src)
    t_match = time.perf_counter()
    b.report("matching patches", 1, 1)
    # each tile: its tuple's intermediate tile and the (variant+1)-th best matching patch of it
    offsets = chosen[plan.inverse, plan.variants]
    del inter, inter_src  # issue 12: the cut stage assembles them again a chunk at a time (same bytes)
    lazy = IntermediateTiles(b.exemplar, genes_arr, plan.unique, b.tile_size)
    tiles, source, masks, costs, smooth_info, timing = cut_and_compose(
        b, lazy, None, offsets, eps=opts.eps,
        grad_from_patches=opts.grad_from_patches, keep_border=opts.keep_border, smooth=smooth,
        cut_region=opts.cut_region, cut_bias=opts.cut_bias,
        transforms=None if tids is None else tids[plan.inverse, plan.variants],
        index=plan.inverse,  # issue 12: no copy of the intermediate tiles per tile
    )  # fmt: skip
    return _Stages(
        tiles,
        source,
        masks,
        costs,
        offsets,
        chosen_D[plan.inverse, plan.variants],
        best_D,
        smooth_info,
        {"intermediate_s": t_inter - t0, "matching_s": t_match - t_inter, **timing},
        None if tids is None else tids[plan.inverse, plan.variants],
    )
