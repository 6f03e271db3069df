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
from ..errors import ParameterError
from ..layouts.corners import CornerPlan, IntermediateTiles, corner_set, intermediate_tiles
from ..layouts.hashed import lookup_scheme
from ..measure.diagnose import finish_build
from ..tileset.tilefile import TileSet
from .compose import cut_and_compose, finish_tileset, patch_gradients  # noqa: F401 - patch_gradients re-exported
from .exemplar import Exemplar
from .genes.cut_objective import TopK, cut_polish, selection_record
from .genes.cut_objective import rerank as rerank_by_cut
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
from .genes.omega_borders import corner_border_draws
from .genes.select import choose_genes
from .genes.visible_objective import visible_choice
from .genes.window_objective import WINDOW_DRAWS, window_candidates, window_choice
from .masking import active
from .matching.choose import MU, augmented
from .matching.levers import default_bias
from .matching.patches import matching_patches
from .options import BuildOptions, Progress, SeedLike, common_options
from .periodic import phase_locked_genes
from .recipe import (  # noqa: F401 - OmegaOptions, omega_options, PERIODIC_MODES re-exported
    DEFAULT,
    PERIODIC_MODES,
    OmegaOptions,
    Recipe,
    Resolved,
    named_choices,
    omega_options,
    resolve,
)
from .smoothing import POISSON_TOL, smooth_tiles  # noqa: F401 - re-exported


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


def _cut_bias(opts: OmegaOptions, n: int) -> float:
    return default_bias(opts.cut_region, n) if opts.cut_bias is None else opts.cut_bias


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


def build_omega(
    exemplar: np.ndarray | Exemplar, *, tileset: str | None = None, tile_size: int | None = None,
    genes: np.ndarray | None = None, seed: SeedLike = None, threads: int | None = None, eps: float = DEFAULT.eps,
    gradients: str = DEFAULT.gradients, keep_border: bool = DEFAULT.keep_border, progress: Progress | None = None,
    selection: dict[str, Any] | None = None, exemplar_info: dict[str, Any] | None = None,
    select: str | None = None, polish: bool = False, generations: int | None = None,
    population: int | None = None, normalise: bool = False, select_params: dict[str, Any] | None = None,
    match: str = DEFAULT.match, match_k: int | str | None = None, metric: str = DEFAULT.metric,
    smooth: bool = False, cut_region: str | None = None, diversity: int | None = None,
    cut_bias: float | None = None, mask: Any = None, alpha: str = "auto", objective: str | None = None,
    rerank: int | None = None, border_tries: int = DEFAULT.border_tries, augment: str = DEFAULT.augment,
    periodic: str = DEFAULT.periodic, border_criterion: str | None = None, recipe: Recipe | str | None = None,
) -> TileSet:  # fmt: skip
    """Build a set of ω-tiles from ``exemplar`` (an image ``(H, W[, C])``, uint8/uint16 or float in [0, 1], or
    an :class:`~tilesynth.builder.exemplar.Exemplar`).

    The choices of the build (``tileset`` ... ``border_criterion``: set, tile size, cut, matching, selection and
    objective, border-aware draw, periodic rule) are the fields of :class:`~tilesynth.builder.recipe.Recipe`,
    documented there with why each default was chosen: keywords, or a ``recipe`` (not both), or a recipe's name
    (:data:`~tilesynth.builder.recipe.NAMED_RECIPES`: "default", "fast", "objects") that keywords override
    (``tileset`` None: the named recipe's set, else "c5"). The others: ``genes`` (``(n, 2)`` top-left positions
    of the sample patches, in colour order; default: drawn or selected), ``seed`` (recorded; None draws one),
    ``threads`` (the result does not depend on it), ``progress`` (callback ``(stage, done, total)``),
    ``selection`` (how given genes were chosen, recorded), ``exemplar_info`` (facts to record: file, bit
    depth), ``mask`` / ``alpha`` (pixels never used, :mod:`tilesynth.builder.masking`).

    The stages: the inputs validated once (:func:`~tilesynth.builder.options.common_options`), the recipe
    resolved (:func:`~tilesynth.builder.recipe.resolve`), the genes (:func:`gene_stage`), the tiles
    (:func:`tiles_stage`: intermediate tiles, matching patches, cut and compose), the set (:func:`finish_stage`).
    D_j: the distance of intermediate tile j to its matching patch; E = λ·ΣD_j + (1−λ)·Var(D_j).
    """
    choices = {k: v for k, v in locals().items() if k in _RECIPE_FIELDS}
    named = None
    if isinstance(recipe, str):  # a named recipe: its choices where the keywords are at their defaults
        exemplar = Exemplar.of(exemplar, mask=mask, alpha=alpha)
        mask, alpha = None, "auto"  # the Exemplar carries them now
        kept, named = named_choices(recipe, exemplar.image, choices)
        choices.update(kept)
        recipe = None
    if choices["tileset"] is None:  # not given: the default recipe's set
        choices["tileset"] = DEFAULT.tileset
    if recipe is not None:  # the choices come from the recipe (keywords left at their defaults)
        recipe = Recipe.of(recipe, choices)
        choices = {k: getattr(recipe, k) for k in _RECIPE_FIELDS}
    b = common_options(
        exemplar, tileset=choices["tileset"], resolve_set=corner_set, tile_size=choices["tile_size"], seed=seed,
        threads=threads, progress=progress, exemplar_info=exemplar_info, mask=mask, alpha=alpha,
    )  # fmt: skip
    with b.source.validated():  # the stages take the exemplar as validated here
        b, r = resolve(recipe or Recipe(**choices), b, genes)
        plan = CornerPlan.of(b.definition)
        top = TopK(max(r.n_rerank, 1))
        genes_arr, sel = gene_stage(b, r, plan, genes, selection, top)
        t_sel = time.perf_counter()
        release_freed_memory()  # the selection's freed buffers would add to the later stages' peak
        res, genes_arr, sel, t_sel = tiles_stage(b, r, plan, genes_arr, sel, top, t_sel)
        ts = finish_stage(b, r, plan, genes_arr, sel, res, t_sel)
    if named is not None and named["name"] != "default":  # "default" is the default build, byte for byte
        ts.params["recipe"] = named
    return ts


_RECIPE_FIELDS = frozenset(f.name for f in dataclasses.fields(Recipe))


def gene_stage(
    b: BuildOptions, r: Resolved, plan: CornerPlan, genes: Any, selection: Any, top: TopK
) -> tuple[np.ndarray, dict]:
    """The sample patches: given, selected (the candidates kept in ``top`` for a re-ranking) or drawn; then
    the border-aware draw, the window objective's choice and the periodic rule's record, as they apply."""
    rec, opts = r.recipe, r.opts
    genes_arr, sel = choose_genes(
        genes, n=plan.n_colours, size=b.tile_size, shape=b.exemplar.shape, rng=b.rng,
        evaluator=lambda: top.wrap(
            omega_evaluator(b.exemplar, b.tile_size, plan, opts, b.threads, r.lam, mask=active(b.mask))
        ),
        select=r.select, polish=rec.polish and r.objective != "cut", generations=rec.generations,
        population=rec.population, select_params=r.select_params or None, selection=selection,
        optimise=opts.normalise, record={"normalise": opts.normalise, **({"objective": r.objective} if r.objective else {})},
        progress=b.progress, mask=b.mask,
    )  # fmt: skip
    # tile borders like the texture's own steps: of several random draws, the one whose predicted border
    # seam ranks best (complete sets: the most representative patches among the admissible draws)
    genes_arr, sel = corner_border_draws(
        b.source, b.tile_size, b.rng, genes_arr, sel, r.tries, r.border_draws, criterion=r.criterion
    )
    if r.objective == "window":  # the complete sets' cheap choice: the draw whose tiling window measures best
        genes_arr, sel = _window_selection(b, opts, plan, genes_arr, sel, r.n_rerank)
    if r.lock is not None:  # the periodic rule's record (and with "lock" one phase for every patch)
        if rec.periodic == "lock":
            genes_arr = phase_locked_genes(b.exemplar, genes_arr, b.tile_size)
        sel = {**sel, "periodic": {**r.lock, "mode": rec.periodic}}
    return genes_arr, sel


def tiles_stage(
    b: BuildOptions, r: Resolved, plan: CornerPlan, genes_arr: np.ndarray, sel: dict, top: TopK, t_sel: float
) -> tuple[TileStages, np.ndarray, dict, float]:
    """The tiles of the chosen genes (and the genes: a re-ranking may choose others); when the objective re-ranks ("cut", "visible") and the genes were
    selected, the best candidates are built and re-ranked first (and polished by the cut with ``polish``)."""
    opts = r.opts
    if not (r.reranks and sel.get("method") not in ("given", "random")):
        return tile_stages(b, opts, plan, genes_arr, smooth=opts.smooth), genes_arr, sel, t_sel
    quiet = dataclasses.replace(b, progress=lambda *a: None)
    cands = top.best()
    m = active(b.mask)
    if m is not None:  # the evaluator saw the genes projected onto clear windows: keep distinct clear ones
        cands = [
            g for g in cands if m.windows_ok(g, b.tile_size).all() and len(np.unique(g, axis=0)) == len(g)
        ]
        cands = cands or [genes_arr]
    if r.objective == "visible":  # the visible measures on a proxy synthesis
        genes_arr, res, sel["visible"] = visible_choice(
            cands, lambda g: tile_stages(quiet, opts, plan, g, smooth=False),
            lambda g, rs: _trial_tileset(b, opts, plan, sel, g, rs), b.exemplar, b.tile_size, b.threads,
            b.report,
        )  # fmt: skip
        i, scores = 0, []
    else:
        i, scores, res = rerank_by_cut(
            cands, lambda g: tile_stages(quiet, opts, plan, g, smooth=False), b.tile_size, b.report
        )
        genes_arr = cands[i]
        sel["cut"] = selection_record(scores, i, b.tile_size)
    if r.recipe.polish and r.objective == "cut":
        stage1 = omega_evaluator(b.exemplar, b.tile_size, plan, opts, b.threads, 1.0, mask=m)
        genes_arr, score, res, info = cut_polish(
            genes_arr, scores[i], res, stage1, lambda g: tile_stages(quiet, opts, plan, g, smooth=False),
            b.exemplar.shape, b.tile_size, progress=b.report, allowed=None if m is None else m.valid(b.tile_size),
        )  # fmt: skip
        sel["cut"]["score"] = score if np.isfinite(score) else None
        sel["cut"]["polish"] = info
    if opts.smooth:
        res = tile_stages(b, opts, plan, genes_arr, smooth=True)
    return res, genes_arr, sel, time.perf_counter()


def finish_stage(
    b: BuildOptions,
    r: Resolved,
    plan: CornerPlan,
    genes_arr: np.ndarray,
    sel: dict,
    res: TileStages,
    t_sel: float,
) -> TileSet:
    """The tile set with every choice recorded in ``params``, its timings, the mask record and the input
    warnings (:func:`tilesynth.measure.diagnose.finish_build`)."""
    opts = r.opts
    ts = finish_tileset(
        scheme="omega", definition=b.definition, exemplar=b.exemplar, tiles=res.tiles, source=res.source,
        cut_masks=res.masks, genes=genes_arr, tile_patches=plan.tile_patches, match_offsets=res.offsets,
        D=res.D, cut_costs=res.costs, E=energy(res.best_D),
        params={**_omega_params(b, opts, plan, sel, res.smooth_info),
                **({"border_tries": r.tries} if "border_tries" in sel else {}),
                **({"augment": opts.augment, "match_transforms": res.transforms.tolist()}
                   if res.transforms is not None else {})},
        exemplar_info=b.exemplar_info,
        timing={"selection_s": t_sel - b.started, **res.timing},
        started=b.started,
    )  # fmt: skip
    return finish_build(ts, b)


def _window_selection(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, first: np.ndarray, sel: dict, count: int
) -> tuple[np.ndarray, dict]:
    """``objective="window"``: of the border-best ``count`` of the random draws (``first`` the build's own), the
    one whose window of the hashed tiling measures best (:mod:`tilesynth.builder.genes.window_objective`)."""
    if active(b.mask) is not None:
        raise ParameterError("objective 'window' with a mask: the window draws are not mask-aware; leave the "
                             "objective unset (one clear random draw) with a mask")  # fmt: skip
    cands = window_candidates(b.exemplar, b.tile_size, b.rng, first, count, max(WINDOW_DRAWS, count))
    quiet = dataclasses.replace(b, progress=lambda *a: None)
    genes_arr, rec = window_choice(
        cands, lambda g, idx: tile_stages(quiet, opts, plan.subset(idx), g, smooth=False),
        lookup_scheme(b.definition), b.exemplar, b.tile_size, b.threads, b.report,
    )  # fmt: skip
    return genes_arr, {**sel, "method": "window", "objective": "window", "window": rec}


def _trial_tileset(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, sel: dict, genes_arr: np.ndarray, res: TileStages
) -> TileSet:
    """The tile set of one candidate of a re-ranking (what a build of ``genes_arr`` returns, without the input
    diagnosis), for measures that need a synthesis (:mod:`tilesynth.builder.genes.visible_objective`)."""
    return finish_tileset(
        scheme="omega", definition=b.definition, exemplar=b.exemplar, tiles=res.tiles, source=res.source,
        cut_masks=res.masks, genes=genes_arr, tile_patches=plan.tile_patches, match_offsets=res.offsets,
        D=res.D, cut_costs=res.costs, E=energy(res.best_D), params=_omega_params(b, opts, plan, sel, None),
        exemplar_info=b.exemplar_info, timing=dict(res.timing), started=b.started,
    )  # fmt: skip


@dataclass
class TileStages:
    """What the stages after the genes produce (:func:`tile_stages`)."""

    tiles: np.ndarray
    source: np.ndarray
    masks: np.ndarray
    costs: np.ndarray
    offsets: np.ndarray
    D: np.ndarray
    best_D: np.ndarray
    smooth_info: Any
    timing: dict[str, float]
    transforms: np.ndarray | None = None  # the matching patches' rotations / mirrors (augment), else None


def tile_stages(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, genes_arr: np.ndarray, *, smooth: bool
) -> TileStages:
    """Intermediate tiles, matching patches and the cut of one gene vector (the stages after the selection)."""
    t0 = time.perf_counter()
    b.report("intermediate tiles", 0, 1)
    inter, inter_src = intermediate_tiles(b.exemplar, genes_arr, plan.unique, b.tile_size)
    t_inter = time.perf_counter()
    b.report("intermediate tiles", 1, 1)
    b.report("matching patches", 0, 1)
    chosen, chosen_D, best_D, tids = matching_patches(b, opts, plan, inter, inter_src)
    t_match = time.perf_counter()
    b.report("matching patches", 1, 1)
    # each tile: its tuple's intermediate tile and the (variant+1)-th best matching patch of it
    offsets = chosen[plan.inverse, plan.variants]
    del inter, inter_src  # the cut stage assembles them again a chunk at a time (same bytes, less peak)
    lazy = IntermediateTiles(b.exemplar, genes_arr, plan.unique, b.tile_size)
    tiles, source, masks, costs, smooth_info, timing = cut_and_compose(
        b, lazy, None, offsets, eps=opts.eps,
        grad_from_patches=opts.grad_from_patches, keep_border=opts.keep_border, smooth=smooth,
        cut_region=opts.cut_region, cut_bias=opts.cut_bias,
        transforms=None if tids is None else tids[plan.inverse, plan.variants],
        index=plan.inverse,  # tiles that share an intermediate tile read it once: no copy per tile
    )  # fmt: skip
    return TileStages(
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
