"""The recipe of an ω build: every choice of :func:`tilesynth.builder.omega.build_omega`, in one validated object.

:class:`Recipe` holds the choices a caller makes (the set, the tile size, the cut, the matching, the selection
and its objective, the border-aware draw, the periodic rule, ...); ``None`` means "the default of the set",
resolved against the exemplar by :func:`resolve` into :class:`Resolved`. :data:`DEFAULT` is the default recipe,
and each field's ``why`` (:func:`why`) says why its default was chosen, with the measurement behind it. The
keyword arguments of ``build_omega`` are these fields; ``build_omega(exemplar, recipe=...)`` takes one.

What is checked where: :class:`Recipe` checks every choice that can be checked alone (types, names, ranges),
in the order ``build_omega`` always checked them; the set name and the tile size are checked with the exemplar
(:func:`tilesynth.builder.options.common_options`); choices that depend on each other or on the set (a cut bias
needs a free cut region, diversity and augmentation need the plain SSD match, an objective needs a set it
applies to, ...) are checked by :func:`resolve` and the selection
(:func:`tilesynth.builder.genes.cut_objective.resolve_objective`,
:func:`tilesynth.builder.genes.select.choose_genes`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..base import kernels
from ..base.validate import finite_float
from ..errors import ParameterError
from ..layouts.complete import complete_defaults
from ..measure.energy import LAMBDA
from .genes.cut_objective import resolve_objective
from .genes.omega_borders import DEFAULT_BORDER_TRIES, DEFAULT_CRITERION, check_criterion
from .genes.select import wants_selection
from .genes.wang_borders import check_border_tries
from .masking import active
from .matching.augment import check_augment
from .matching.choose import check_metric, check_strategy
from .options import BuildOptions
from .tile_scale import feature_tile_size

__all__ = [
    "CUT_REGIONS",
    "DEFAULT",
    "NAMED_RECIPES",
    "NAMED_SETS",
    "PERIODIC_MODES",
    "OmegaOptions",
    "Recipe",
    "Resolved",
    "named_choices",
    "omega_options",
    "resolve",
    "why",
]

PERIODIC_MODES = ("auto", "lock", "off")
"""Values of ``Recipe.periodic``."""

CUT_REGIONS = ("circle", "free", "free8", "ring")
"""Values of ``Recipe.cut_region`` (None: the set's default)."""


def _choice(default: Any, why: str) -> Any:
    return field(default=default, metadata={"why": why})


@dataclass(frozen=True)
class Recipe:
    """The choices of an ω build (see the module docstring); ``None``: the set's default (:func:`resolve`).
    What each does is below; why each default is what it is: :func:`why`.

    tileset : name of the tile-set definition: the papers' "4", "8", "16a", "16b", "32", "B", "n2", ... or a
        complete set "c<K>" / "c<K>x<V>". Default "c5", the default of ``tilesynth build``.
    tile_size : N, even, at most the exemplar's shorter side; default :func:`tilesynth.layouts.tile_size.default_tile_size`.
    genes : optional ``(n, 2)`` top-left positions of the n sample patches (n = number of colours of the set),
        in the order of the set's colours. Default: random distinct positions drawn from ``seed``.
    seed : seed of the random choices (recorded in the tile set; None draws one).
    threads : worker threads for the kernels (None: ``TILESYNTH_NUM_THREADS`` or all cores). The result does
        not depend on it.
    eps : epsilon of the Kwatra weight.
    gradients : "patch" (default) or "tile": where the gradients of the intermediate tile in the Kwatra weight
        come from (see :mod:`tilesynth.builder.omega`).
    keep_border : tie the tile's border ring to the intermediate tile, so O never reaches the border (default;
        see :mod:`tilesynth.builder.omega`). False is the literal definition of 002.
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
    smooth : Poisson-smooth the region inside every cutting curve (002 §3.3; :func:`tilesynth.builder.smoothing.smooth_tiles`). The solver's
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
        :func:`tilesynth.builder.genes.omega_borders.sample_stats_distance`), "cap" for the papers' sets.
    periodic : "auto" (default), "lock" or "off". "auto": a complete set built with the default tile size,
        random genes and no mask, on an exemplar that repeats at a shift of one tile in both directions (a
        brick wall), takes its tile size from the exemplar's period (:mod:`tilesynth.builder.periodic`; recorded in
        ``params["selection"]["periodic"]``). "lock": the same, and every sample patch moved to one phase of
        the period (continuous courses, but more copies and a border seam no longer checked by the draw:
        measured, opt-in). Other builds, and every build with "off", are unchanged.
    """

    tileset: Any = _choice(
        "c5",
        "Complete sets repeat least: measured with benches/repetition.py (9 bench textures, "
        "benches/repetition-results.md), the papers' sets repeat visibly; against c4, the default before, c5 "
        "halves the periodic copies (0.115 -> 0.056), lowers the autocorrelation peak (0.233 -> 0.213) and "
        "raises the coverage (0.78 -> 0.84) at the same border seam (0.72 -> 0.74, at most 0.86), for 2.3x the "
        "build time and 2.4x the tiles (625).",
    )
    tile_size: int | None = _choice(
        None,
        "Papers' sets: half the exemplar's shorter side, even, capped at 256 (002 used 64 on 128 inputs). "
        "Complete sets: a quarter, rounded down to a multiple of 8 (the engine's mip chains reach level 3), "
        "capped at 256: the lookup, not the tile size, makes them non-periodic, and K^4 tiles of half the "
        "exemplar would be slow to build and big; rounding down measured better seams than to the nearest "
        "(lettuce 88 / 94 / 96 px: border seam 0.75 / 0.94 / 0.98). With a mask, no larger than what fits.",
    )
    eps: float = _choice(kernels.DEFAULT_EPS, "The epsilon of Kwatra's weight: keeps flat regions finite.")
    gradients: str = _choice(
        "patch",
        "The gradient of each pixel in the sample patch it came from: read on the assembled tile (002's "
        "literal formula, 'tile'), the tile's own cross seam makes every edge next to it cheap and the cut hugs "
        "the cross, two seams instead of one (seen on the bundled lettuce).",
    )
    keep_border: bool = _choice(
        True,
        "The tile's border ring stays the intermediate tile's: taken literally, the matching patch reaches the "
        "border around the side midpoints, where neighbours show different patches (~10% of the border pixels "
        "were discontinuous on lettuce).",
    )
    select: str | None = _choice(
        None,
        "Papers' sets: best-of 32 random gene vectors by ΣD, the best 4 re-ranked by the real cut score "
        "(benches/selection-results.md: a cheap visible re-ranking gained little more for 1.9-2.4x the CPU). "
        "Complete sets: one random draw (the cut re-ranking raised coherence +10.6 % but made the texture "
        "statistics -22 % and histograms -14 % worse, for 4x the build time).",
    )
    polish: bool = _choice(False, "The exact polish costs many evaluations for little: opt-in.")
    generations: int | None = _choice(None, "The papers' N_g for 'ga' / 'ais'.")
    population: int | None = _choice(None, "The papers' population (the count of 'best-of').")
    normalise: bool = _choice(False, "The plain SSD of 000; 003's normalised objective is opt-in.")
    select_params: dict[str, Any] | None = _choice(
        None, "The methods' own defaults (alpha, p_crossover, ...)."
    )
    match: str = _choice(
        "ssd",
        "The matching patch of smallest SSD, exact (FFT map, exact re-ranking); 002's heuristics "
        "('circle', 'midpoints') and 'best-cut' are kept for comparison.",
    )
    match_k: int | str | None = _choice(None, "16 candidates for 'best-cut'.")
    metric: str = _choice(
        "color", "Plain SSD: the FFT search is exact and fast; 000's eq. 3 / eq. 2 are opt-in."
    )
    smooth: bool = _choice(
        False,
        "Poisson smoothing changes the copied pixels (the tiles are no longer pure exemplar copies): opt-in.",
    )
    cut_region: str | None = _choice(
        None,
        "Complete sets: 'free' (most of the tile is its own matching patch; a tapered reward and a ring penalty "
        "keep the cut off the border ring; the old uniform reward pressed it onto the ring, a grid of seams, "
        "inner seam 6.40 on cracked mud: benches/repetition-results.md). Papers' sets: 002's 'circle'.",
    )
    diversity: int | None = _choice(
        None,
        "Complete sets: 1 (each exemplar region used at most once by the matching patches, with the plain SSD "
        "match: 625 tiles spread over the exemplar instead of piling on its best regions; "
        "benches/repetition-results.md). Papers' sets: 0 (each tile's best).",
    )
    cut_bias: float | None = _choice(
        None, "32/N for 'free' and 'free8', 0.02 for 'ring' (levers.default_bias)."
    )
    objective: str | None = _choice(
        None,
        "'cut' for the default selection of the papers' sets, the papers' 'E' for a named select; complete "
        "sets: none (one random draw, see select).",
    )
    rerank: int | None = _choice(None, "4 candidates for 'cut', 8 for 'visible'.")
    border_tries: int = _choice(
        DEFAULT_BORDER_TRIES,
        "32 random draws, the one with the best predicted border seam kept: 16 left 1 seed of 12 above a border "
        "seam of 1, 32 none (benches/seams-results.md); with a mask the single mask-aware draw is kept.",
    )
    augment: str = _choice(
        "none",
        "Mirrored / rotated matching patches bought nothing measurable in repetition (flip: copies 0.108 vs "
        "0.115) and 'all' made bark worse (0.205): only for isotropic textures, opt-in.",
    )
    periodic: str = _choice(
        "auto",
        "A complete set with default choices on an exemplar that repeats at a tile's shift (a brick wall) takes "
        "its tile size from the period: of the 24 shared textures only bricks-red passes (0.655 against at most "
        "0.24); 'lock' (every patch at one phase) measured more copies: opt-in.",
    )
    border_criterion: str | None = _choice(
        None,
        "Complete sets: 'stats' (of the admissible draws, the one whose sample patches are closest to the "
        "exemplar in texture statistics and colour; benches/repetition-results.md, lever 1). Papers' sets: "
        "'cap' (predicted border seam closest to 0.8 without exceeding 1).",
    )

    def __post_init__(self) -> None:
        # the checks of single choices, in the order build_omega always made them
        if self.periodic not in PERIODIC_MODES:
            raise ParameterError(f"periodic = {self.periodic!r}: must be one of {', '.join(PERIODIC_MODES)}")
        finite_float(self.eps, "eps", positive=True)
        _check_gradients(self.gradients)
        check_strategy(self.match, self.match_k)
        check_metric(self.metric)
        _check_smooth(self.smooth)
        if self.cut_region is not None:
            _check_cut_region(self.cut_region)
        _check_diversity(None if self.diversity == 0 else self.diversity)
        check_augment(self.augment)
        check_border_tries(self.border_tries)
        if self.border_criterion is not None:
            check_criterion(self.border_criterion)

    @classmethod
    def of(cls, recipe: Recipe | None, choices: dict[str, Any]) -> Recipe:
        """``recipe``, or the recipe of the keyword ``choices`` (a ``build_omega`` call's); both only when the
        keywords are all at their defaults."""
        if recipe is None:
            return cls(**choices)
        if not isinstance(recipe, Recipe):
            raise ParameterError(
                f"recipe = {recipe!r}: a Recipe, None or one of the named recipes "
                f"{', '.join(map(repr, NAMED_RECIPES))}"
            )
        changed = [k for k, v in choices.items() if _differs(v, getattr(DEFAULT, k))]
        if changed:
            raise ParameterError(
                f"recipe and {', '.join(changed)}: give the choices in the recipe or as keywords, not both "
                "(dataclasses.replace(recipe, ...) changes a recipe)"
            )
        return recipe

    def replace(self, **changes: Any) -> Recipe:
        """A copy with ``changes`` (validated again)."""
        return dataclasses.replace(self, **changes)


def _differs(a: Any, b: Any) -> bool:
    try:
        return bool(a != b) or type(a) is not type(b)
    except ValueError:  # an array compares element-wise: it is not a default
        return True


def why(name: str) -> str:
    """Why the default of the recipe field ``name`` is what it is (the measurement behind it)."""
    fields = {f.name: f for f in dataclasses.fields(Recipe)}
    if name not in fields:
        raise ParameterError(f"name = {name!r}: not a recipe field ({', '.join(fields)})")
    return str(fields[name].metadata["why"])


# ------------------------------------------------------------------------------------------ named recipes
NAMED_RECIPES = {
    "default": "the default recipe (DEFAULT): the complete set c5, 625 tiles, the tile size a quarter of the "
    "exemplar's shorter side",
    "fast": "the complete set c4 (256 tiles instead of 625): builds about 2.3x faster; periodic copies about "
    "twice the default's (benches/repetition-results.md, 9 textures: 0.115 against 0.056) and the "
    "autocorrelation peak 0.233 against 0.213. For previews and quick iterations",
    "objects": "tiles about four objects wide on photos of separate objects (coins, floor tiles, carpet "
    "squares, fruit; tilesynth.builder.tile_scale): on 6 such photos objects kept whole 0.28 -> 0.37 and the "
    "folded lattice 7.1 -> 3.8, but periodic copies about 2x and the build 1.8x slower "
    "(benches/lattice-results.md); other exemplars get the default, byte for byte",
}
"""The recipes a user picks by name (``build_omega(recipe="fast")``, ``tilesynth build --recipe fast``), with
what each trades, measured. Choices given as keywords win over the named recipe's."""

NAMED_SETS = {"fast": "c4"}
"""The set a named recipe builds when no set is given (the others build :data:`DEFAULT`'s); the CLI and batch
resolve ``--set`` / ``set`` with it, so that they print and record the set that is built."""


def named_choices(
    name: Any, exemplar: np.ndarray, choices: dict[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The choices of the named recipe ``name`` (:data:`NAMED_RECIPES`) that ``choices`` (a ``build_omega``
    call's keywords) leave unset (None: ``tileset`` and ``tile_size`` default to None, so a set or size given
    explicitly, the default one included, wins), and the record stored in the tile set's ``params["recipe"]``.
    ``exemplar``: the validated exemplar image (the "objects" recipe measures its objects)."""
    if not isinstance(name, str) or name not in NAMED_RECIPES:
        raise ParameterError(
            f"recipe = {name!r}: a Recipe, None or one of the named recipes {', '.join(map(repr, NAMED_RECIPES))}"
        )
    want: dict[str, Any] = {}
    record: dict[str, Any] = {"name": name}
    if name in NAMED_SETS:
        want["tileset"] = NAMED_SETS[name]
    if name == "objects":
        size, how = feature_tile_size(exemplar)
        record["feature_scale"] = {k: v for k, v in how.items() if k != "default"}
        if size is not None:
            want["tile_size"] = size
    kept = {k: v for k, v in want.items() if choices[k] is None}
    # the recipe's choices in effect: those it set, and those given as it would have set them (the CLI and
    # batch pass the recipe's set explicitly: NAMED_SETS)
    record["applied"] = sorted(k for k, v in want.items() if k in kept or not _differs(choices[k], v))
    return kept, record


# ------------------------------------------------------------------------------------------ the ω options
def _check_gradients(gradients: Any) -> None:
    if gradients not in ("patch", "tile"):
        raise ParameterError(f"gradients = {gradients!r}: must be 'patch' or 'tile'")


def _check_smooth(smooth: Any) -> None:
    if not isinstance(smooth, (bool, np.bool_)):
        raise ParameterError(f"smooth = {smooth!r}: must be True or False")


def _check_cut_region(cut_region: Any) -> None:
    if cut_region not in CUT_REGIONS:
        raise ParameterError(f"cut_region = {cut_region!r}: must be 'circle', 'free', 'free8' or 'ring'")


def _check_diversity(diversity: Any) -> None:
    if diversity is not None and (
        isinstance(diversity, (bool, np.bool_))
        or not isinstance(diversity, (int, np.integer))
        or diversity < 1
    ):
        raise ParameterError(
            f"diversity = {diversity!r}: a positive int (uses per exemplar region), 0 or None"
        )


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
    _check_gradients(gradients)
    strategy, k = check_strategy(match, match_k)
    metric = check_metric(metric)
    _check_smooth(smooth)
    _check_cut_region(cut_region)
    if cut_bias is not None and (cut_region == "circle" or finite_float(cut_bias, "cut_bias") < 0):
        raise ParameterError(
            f"cut_bias = {cut_bias!r}: a number >= 0, only with cut_region 'free', 'free8' or 'ring'"
        )
    cut_bias = None if cut_bias is None else float(cut_bias)  # None: levers.default_bias (needs N)
    diversity = None if diversity == 0 else diversity
    _check_diversity(diversity)
    if diversity is not None and (strategy != "ssd" or metric != "color"):
        raise ParameterError("diversity: only with match='ssd' and metric='color'")
    augment = check_augment(augment)  # mirrored / rotated matching candidates
    if augment != "none" and (strategy != "ssd" or metric != "color"):
        raise ParameterError(f"augment = {augment!r}: only with match='ssd' and metric='color'")
    return OmegaOptions(
        eps, gradients, bool(keep_border), strategy, k, metric, bool(smooth), bool(normalise), cut_region,
        cut_bias, None if diversity is None else int(diversity), augment,
    )  # fmt: skip


# ------------------------------------------------------------------------------------------ resolution
@dataclass(frozen=True)
class Resolved:
    """A recipe resolved against its exemplar and set (:func:`resolve`): what the stages run."""

    recipe: Recipe
    complete: dict[str, Any] | None
    """The complete set's defaults (:func:`tilesynth.layouts.complete.complete_defaults`), None for the papers'."""
    lock: dict[str, Any] | None
    """The periodic rule's record (``tile_size``, ``shift_correlation``), None when it does not apply."""
    opts: OmegaOptions
    tries: int
    select: Any
    objective: str | None
    select_params: dict[str, Any]
    n_rerank: int
    criterion: str
    """The border-aware draw's criterion ("stats" for complete sets, "cap" for the papers')."""
    border_draws: bool
    """Whether the genes are one random draw made border-aware (no given genes, no selection, no mask)."""

    @property
    def lam(self) -> float:
        """λ of the selection's E: the papers' for their objective, 1 (ΣD) for the others."""
        return LAMBDA if self.objective in (None, "E") else 1.0

    @property
    def reranks(self) -> bool:
        """Whether the selection's best candidates are built and re-ranked ("cut" / "visible")."""
        return self.objective in ("cut", "visible")


def resolve(recipe: Recipe, b: BuildOptions, genes: Any) -> tuple[BuildOptions, Resolved]:
    """The set's defaults, the periodic rule and the selection of ``recipe`` for the build ``b`` (its tile
    size replaced when a complete set's default or the periodic rule sets it), checked against each other."""
    r = recipe
    complete = complete_defaults(b.definition, b.exemplar.shape, r.match, r.metric)
    cut_region, diversity = r.cut_region, r.diversity
    if complete is not None:
        if r.tile_size is None:  # with a mask: no larger than what fits
            n_c = complete["tile_size"] if b.mask is None else min(complete["tile_size"], b.tile_size)
            b = dataclasses.replace(b, tile_size=n_c)
        cut_region = complete["cut_region"] if cut_region is None else cut_region
        diversity = complete["diversity"] if diversity is None else diversity
    default_genes = genes is None and r.objective is None
    lock = _periodic_rule(
        b, r.periodic,
        complete is not None and r.tile_size is None and default_genes
        and not wants_selection(r.select, r.polish, r.select_params, extra=r.normalise),
    )  # fmt: skip
    if lock is not None:
        b = dataclasses.replace(b, tile_size=lock["tile_size"])
    opts = omega_options(
        eps=r.eps, gradients=r.gradients, keep_border=r.keep_border, match=r.match, match_k=r.match_k,
        metric=r.metric, smooth=r.smooth, normalise=r.normalise,
        cut_region="circle" if cut_region is None else cut_region, cut_bias=r.cut_bias, diversity=diversity,
        augment=r.augment,
    )  # fmt: skip
    if opts.augment != "none" and active(b.mask) is not None:
        raise ParameterError(
            f"augment = {opts.augment!r} with a mask: the masked search takes untransformed windows only; "
            "use augment='none' with a mask"
        )
    tries = check_border_tries(r.border_tries)
    if opts.metric == "eq2" and wants_selection(r.select, r.polish, r.select_params, extra=r.normalise):
        raise ParameterError(
            "metric = 'eq2' with select: eq. 2 has no FFT or quadrant structure (a direct sum over every "
            "translation, ~50 M operations per 80x80 tile), too slow for a population search; select with "
            "metric 'color' or 'eq3', or use eq2 only for the matching patches of given or random genes"
        )
    select_params = r.select_params if r.rerank is None else {**(r.select_params or {}), "rerank": r.rerank}
    select, objective, select_params, n_rerank = resolve_objective(
        r.select, r.objective, genes, r.polish, select_params, r.population, complete=complete is not None
    )
    border_draws = (
        genes is None
        and not wants_selection(select, r.polish, select_params, extra=r.normalise)
        and active(b.mask) is None  # the draws are not mask-aware: a masked build keeps its one clear draw
        and objective != "window"
    )
    criterion = (
        ("stats" if complete is not None else DEFAULT_CRITERION)
        if r.border_criterion is None
        else check_criterion(r.border_criterion)
    )
    return b, Resolved(
        r, complete, lock, opts, tries, select, objective, select_params, n_rerank, criterion, border_draws
    )


def _periodic_rule(b: BuildOptions, periodic: str, eligible: bool) -> dict[str, Any] | None:
    """The periodic exemplar rule of :mod:`tilesynth.builder.periodic` for a build: ``{"tile_size",
    "shift_correlation"}`` or None (not eligible, ``periodic="off"``, a mask, or an exemplar that does not repeat
    at a tile's shift)."""
    if periodic == "off" or not eligible or active(b.mask) is not None:
        return None
    found = b.source.period(b.tile_size) if b.source is not None else None
    if found is None:
        return None
    return {"tile_size": int(found[0]), "shift_correlation": round(float(found[1]), 6)}


DEFAULT = Recipe()
"""The default recipe: ``build_omega(exemplar)``."""
