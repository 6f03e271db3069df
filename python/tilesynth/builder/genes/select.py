"""Selection of the sample patches (the *genes*) of an ω-tile set.

A gene vector is an int64 ``(n, 2)`` array of distinct top-left (row, col) positions of N x N patches inside an
H x W exemplar (each in ``[0, H−N] x [0, W−N]``, see :func:`tilesynth.builder.genes.draws.random_genes`). Its quality is
E = λ·ΣD_j + (1−λ)·Var(D_j) (smaller is better), computed by an ``evaluate(genes[P, n, 2]) -> (E[P], D[P, m])``
callable, normally ``tilesynth.PopulationEvaluator(...).evaluate``. Every method here evaluates a whole
population per call (never one call per individual).

Methods (:func:`select_genes`):

``random``
    One random gene vector (the original ω-tile construction).
``best-of``
    The best of ``count`` (default 100) random gene vectors: the "semi-random" of 003 (§5, Table 2).
``ga``
    The genetic algorithm of 000 §4.2 (and 001 §4): :func:`run_ga`.
``ais``
    The artificial immune system (adaptive dynamic clonal selection) of 003 §4.2: :func:`run_ais`.

``polish=True`` follows any method with an exact coordinate descent (:func:`polish_genes`): one gene at a time
is moved to its best position over every valid position, until no single-gene move improves E.

All randomness comes from the given seed / :class:`numpy.random.Generator`: same seed, same evaluator → same
result. The returned genes are the best ever evaluated, and the returned E and D are the evaluator's values for
them. Gene vectors already evaluated during a run are not evaluated again (the evaluator is exact and
deterministic, so a cached value is the value); ``evaluations`` counts the individuals actually evaluated.

The methods live in their own modules (:mod:`~tilesynth.builder.genes.ga`, :mod:`~tilesynth.builder.genes.ais`,
:mod:`~tilesynth.builder.genes.polish`, what they share in :mod:`~tilesynth.builder.genes.population`); this
module is the entry (:func:`select_genes`, :func:`choose_genes`) and re-exports their public names.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ...errors import ParameterError
from .ais import (  # noqa: F401 - BGA_TERMS, stratified_genes re-exported
    BGA_TERMS,
    bga_delta,
    bga_fold,
    bga_mutation,
    clone_counts,
    mutation_probabilities,
    population_diversity,
    relative_affinity,
    run_ais,
    stratified_genes,
)
from .draws import Region, _region, check_genes, random_genes
from .draws import int_param as _int_param
from .ga import crossover_repair, ga_crossover, rank_probabilities, roulette_select, run_ga, segment_mutation
from .polish import polish_genes
from .population import (  # noqa: F401 - MAX_GENERATIONS re-exported
    MAX_GENERATIONS,
    MAX_POPULATION,
    Evaluate,
    Progress,
    SelectionResult,
    _bool_param,
    _Evaluator,
    _random_population,
    _result,
    _Run,
    as_generator,
)

METHODS: tuple[str, ...] = ("random", "best-of", "ga", "ais")
"""Names accepted by :func:`select_genes`."""

GA_DEFAULTS: dict[str, Any] = {
    "population": 40,
    "alpha": 0.05,
    "p_crossover": 0.3,
    "p_mutation": 0.2,
    "generations": 50,
    "stagnation": 5,
    "elitism": False,
}
"""Defaults of :func:`run_ga`: 000 §5 {pop_size 40, α 0.05, P_c 0.3, P_m 0.2, N_g 50, N_o 5}."""

AIS_DEFAULTS: dict[str, Any] = {
    "population": 40,
    "s_min": 0.2,
    "s_max": 0.4,
    "alpha": 0.4,
    "beta": 4.0,
    "deaths": None,
    "generations": 50,
    "stagnation": 6,
}
"""Defaults of :func:`run_ais`: 003 §4.4 {N_p 40, s_min 0.2, s_max 0.4, α 0.4, β 4, N_d 10, N_g 50, N_o 6}.

``deaths=None`` means ⌊N_p / 4⌋: the paper's 10 for N_p = 40, kept in proportion for other population sizes.
"""

BEST_OF_DEFAULTS: dict[str, Any] = {"count": 100}
"""Default of :func:`run_best_of`: 003's semi-random takes the best of 100 random sets."""

POLISH_DEFAULTS: dict[str, Any] = {"polish_sweeps": None, "polish_batch": 256, "polish_min_distance": None}
"""Defaults of the polish step: sweep until converged; at most 256 individuals per evaluation call."""

# --------------------------------------------------------------------------------------------------------------
# random, best-of


def run_random(
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    progress: Progress | None = None,
) -> SelectionResult:
    """One random gene vector (:func:`tilesynth.builder.omega.random_genes`), evaluated once."""
    t0 = time.perf_counter()
    shp, n, t, _ = _region(shape, n, tile_size)
    g = as_generator(rng)
    ev = _Evaluator(evaluate, n, cache=False)
    run = _Run("random", 1, None, progress)
    E, _ = ev(random_genes(shp, n, t, g)[None])
    run.generation(E, ev.best_E)
    return _result("random", ev, {}, run, t0, "done")


def run_best_of(
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    count: int = 100,
    progress: Progress | None = None,
) -> SelectionResult:
    """The best of ``count`` random gene vectors, evaluated in one call (003's "semi-random").

    Exactly ``count`` vectors are evaluated (no de-duplication), as one generation.
    """
    t0 = time.perf_counter()
    shp, n, t, _ = _region(shape, n, tile_size)
    count = _int_param("count", count, 1, MAX_POPULATION)
    g = as_generator(rng)
    ev = _Evaluator(evaluate, n, cache=False)
    run = _Run("best-of", 1, None, progress)
    E, _ = ev(_random_population(g, count, shp, n, t))
    run.generation(E, ev.best_E)
    return _result("best-of", ev, {"count": count}, run, t0, "done")


# --------------------------------------------------------------------------------------------------------------
# Entry point

_METHOD_PARAMS: dict[str, dict[str, Any]] = {
    "random": {},
    "best-of": BEST_OF_DEFAULTS,
    "ga": GA_DEFAULTS,
    "ais": AIS_DEFAULTS,
}


def _method_kwargs(
    name: str, params: dict[str, Any], generations: int | None, population: int | None
) -> dict[str, Any]:
    """The runner's keywords of method ``name``: its parameters checked against the method's known ones, with
    ``generations`` / ``population`` mapped onto it (``population`` is best-of's ``count``)."""
    allowed = _METHOD_PARAMS[name]
    for key in params:
        if key not in allowed or key in ("generations", "population"):
            known = sorted((set(allowed) - {"generations", "population"}) | set(POLISH_DEFAULTS))
            raise ParameterError(
                f"{key} = {params[key]!r}: not a parameter of method {name!r}"
                + (f" (known: {', '.join(known)})" if known else "")
            )
    kwargs = dict(params)
    if generations is not None:
        if "generations" not in allowed:
            raise ParameterError(f"generations = {generations!r}: method {name!r} has no generations")
        kwargs["generations"] = generations
    if population is not None:
        if name == "best-of":
            if "count" in kwargs:
                raise ParameterError("population and count: give one (both set the best-of count)")
            kwargs["count"] = population
        elif "population" in allowed:
            kwargs["population"] = population
        else:
            raise ParameterError(f"population = {population!r}: method {name!r} has no population")

    return kwargs


def _polish_settings(polish_opts: dict[str, Any]) -> tuple[int | None, int, int | None]:
    """``(polish_sweeps, polish_batch, polish_min_distance)`` from the given polish options and the defaults."""
    p_sweeps = polish_opts.get("polish_sweeps", POLISH_DEFAULTS["polish_sweeps"])
    p_batch = _int_param("polish_batch", polish_opts.get("polish_batch", POLISH_DEFAULTS["polish_batch"]), 1)
    if p_sweeps is not None:
        p_sweeps = _int_param("polish_sweeps", p_sweeps, 1)
    p_min = polish_opts.get("polish_min_distance", POLISH_DEFAULTS["polish_min_distance"])
    if p_min is not None:
        p_min = _int_param("polish_min_distance", p_min, 0)
    return p_sweeps, p_batch, p_min


# Length: 84 lines, of which 28 are the docstring; the body (56) dispatches to the methods.
def select_genes(
    method: str,
    evaluate: Evaluate,
    shape: tuple[int, ...],
    n: int,
    tile_size: int,
    rng: Any = None,
    *,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    progress: Progress | None = None,
    **params: Any,
) -> SelectionResult:
    """Select n sample patches with ``method``, optionally followed by the exact polish.

    Parameters
    ----------
    method : "random", "best-of", "ga" or "ais" ("best_of" is accepted for "best-of").
    evaluate : ``genes[P, n, 2] int64 -> (E[P], D[P, m])``, called once per generation with the population.
    shape : exemplar shape (H, W[, C]).
    n : number of genes (colours of the tile set).
    tile_size : N.
    rng : seed (int) or :class:`numpy.random.Generator`; None draws fresh entropy.
    polish : follow the method with :func:`polish_genes`.
    generations : N_g of "ga" / "ais" (None: the paper's 50). Not accepted by "random" / "best-of".
    population : pop_size / N_p of "ga" / "ais", the count of "best-of" (None: 40, 40, 100). Not accepted by
        "random".
    progress : ``(stage, done, total)`` callback, once per generation (stage = method name, then "polish").
    **params : method parameters: "ga": alpha, p_crossover, p_mutation, stagnation, elitism (see
        :func:`run_ga`); "ais": s_min, s_max, alpha, beta, deaths, stagnation (:func:`run_ais`); "best-of":
        count. With ``polish``: polish_sweeps (None: until converged), polish_batch (256).

    Returns
    -------
    SelectionResult; with polish, genes / E / D are the polished ones, ``evaluations`` and ``wall_time``
    include the polish, ``history`` and ``generations`` are the method's, ``polish`` holds the polish facts.

    Raises
    ------
    ParameterError (a ValueError) naming the unknown method or the bad parameter.
    """
    t0 = time.perf_counter()
    if not isinstance(method, str):
        raise ParameterError(f"method = {method!r}: must be one of {', '.join(METHODS)}")
    name = method.strip().lower().replace("_", "-")
    if name not in _METHOD_PARAMS:
        raise ParameterError(f"method = {method!r}: unknown, expected one of {', '.join(METHODS)}")
    polish = _bool_param("polish", polish)
    polish_opts = {k: params.pop(k) for k in list(params) if k in POLISH_DEFAULTS}
    if polish_opts and not polish:
        raise ParameterError(f"{next(iter(polish_opts))}: only used with polish=True")
    kwargs = _method_kwargs(name, params, generations, population)
    runner: Callable[..., SelectionResult] = {
        "random": run_random,
        "best-of": run_best_of,
        "ga": run_ga,
        "ais": run_ais,
    }[name]
    # validate polish options before the (possibly long) run
    p_sweeps, p_batch, p_min = _polish_settings(polish_opts) if polish else (None, 0, None)
    res = runner(evaluate, shape, n, tile_size, rng, progress=progress, **kwargs)
    res.params = {**res.params, "polish": polish}
    if polish:
        genes, E, D, info = polish_genes(
            evaluate,
            res.genes,
            shape,
            tile_size,
            E=res.E,
            D=res.D,
            max_sweeps=p_sweeps,
            batch_size=p_batch,
            min_distance=p_min,
            progress=progress,
        )
        res.genes, res.E, res.D = genes, E, D
        res.evaluations += info["evaluations"]
        res.polish = info
        res.params.update(
            {"polish_sweeps": p_sweeps, "polish_batch": p_batch, "polish_min_distance": info["min_distance"]}
        )
    res.wall_time = time.perf_counter() - t0
    return res


# --------------------------------------------------------------------------------------------------------------
# The builders' one path to a gene vector


def wants_selection(select: Any, polish: bool, select_params: Any, *, extra: bool = False) -> bool:
    """Whether the options ask for an optimised gene vector (anything but one random draw)."""
    return (select is not None and select != "random") or bool(polish) or bool(extra) or bool(select_params)


def check_select(select: Any) -> None:
    """Refuse a ``select`` that is neither None nor a method name (a string)."""
    if select is not None and not isinstance(select, str):
        raise ParameterError(f"select = {select!r}: must be one of {', '.join(METHODS)} or None")


def choose_genes(
    genes: Any,
    *,
    n: int,
    size: int,
    shape: tuple[int, ...],
    rng: np.random.Generator,
    evaluator: Callable[[], Evaluate] | None,
    select: str | None = None,
    polish: bool = False,
    generations: int | None = None,
    population: int | None = None,
    select_params: dict[str, Any] | None = None,
    selection: dict[str, Any] | None = None,
    ga_defaults: dict[str, Any] | None = None,
    optimise: bool = False,
    record: dict[str, Any] | None = None,
    progress: Progress | None = None,
    mask: Any = None,
    tile_size: int | None = None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Given, random or selected genes (``n`` top-left corners of ``size`` squares) and how they were chosen.

    * ``genes`` given: checked (:func:`check_genes`), recorded as ``selection`` (default ``{"method": "given"}``);
      giving ``select`` too is an error.
    * no selection asked for (``select`` None or "random", no ``polish``, no ``select_params``, ``optimise``
      false): one :func:`random_genes` draw from ``rng``, recorded as ``{"method": "random"}``.
    * otherwise :func:`select_genes` on ``evaluator()`` (called only then, so its cost is only
      paid when selecting). ``ga_defaults`` (a scheme's GA settings, e.g. 001's) fill the GA parameters the
      caller did not give. The record is the selection result without its genes and wall time, ``E`` / ``D``
      renamed ``objective_E`` / ``objective_D``, plus ``record``.

    ``optimise`` lets a scheme count one of its own options as a selection request (ω's ``normalise``).

    ``mask`` (a :class:`tilesynth.builder.masking.ExemplarMask`): only windows clear of the mask are used
    (random genes drawn over them, given genes checked, a selection run on the projection onto them; see
    :mod:`tilesynth.builder.masking`); ``tile_size`` (default ``size``) names the build's tile size in its errors.
    """
    from ..masking import active

    m = active(mask)
    if m is not None:
        return _masked_genes(
            m, genes, n=n, size=size, shape=shape, rng=rng, evaluator=evaluator, select=select, polish=polish,
            generations=generations, population=population, select_params=select_params, selection=selection,
            ga_defaults=ga_defaults, optimise=optimise, record=record, progress=progress,
            tile_size=size if tile_size is None else tile_size,
        )  # fmt: skip
    check_select(select)
    optimise = wants_selection(select, polish, select_params, extra=optimise)
    if genes is not None and (select is not None or optimise):
        raise ParameterError("genes and select: give one (select chooses the genes)")
    if genes is not None:
        return check_genes(genes, n, shape, size), (
            {"method": "given"} if selection is None else dict(selection)
        )
    if not optimise:
        return random_genes(shape, n, size, rng), (
            {"method": "random"} if selection is None else dict(selection)
        )
    method = (select or "random").strip().lower().replace("_", "-")
    params = dict(select_params or {})
    if method == "ga" and ga_defaults:
        for key, value in ga_defaults.items():
            if key == "generations" and generations is None:
                generations = value
            elif key == "population" and population is None:
                population = value
            elif key not in ("generations", "population"):
                params.setdefault(key, value)
    if evaluator is None:
        raise ParameterError(f"select = {select!r}: this scheme has no objective to select genes by")
    from ...base.chunks import (
        chunkable,  # the scheme's own evaluator: safe to evaluate in chunks (so Ctrl-C acts promptly)
    )

    res = select_genes(
        method, chunkable(evaluator()), shape, n, size, rng, polish=polish, generations=generations,
        population=population, progress=progress, **params,
    )  # fmt: skip
    info = res.to_dict()
    info.pop("genes")
    info.update(record or {})
    info["objective_E"] = info.pop("E")
    info["objective_D"] = info.pop("D")
    info.pop("wall_time")  # wall time goes in the tile set's timing (selection_s), not in its content
    return res.genes, info


def _masked_genes(m: Any, genes: Any, *, tile_size: int, **kw: Any) -> tuple[np.ndarray, dict[str, Any]]:
    """:func:`choose_genes` with a mask: the same three paths, on the windows clear of the mask."""
    size, n, rng = kw["size"], kw["n"], kw["rng"]
    m.require(size, n, "sample patches", tile_size)
    if genes is not None:
        g, sel = choose_genes(genes, **kw)
        m.check_genes(g, size)
        return g, sel
    evaluator = kw.pop("evaluator")
    if not wants_selection(kw["select"], kw["polish"], kw["select_params"], extra=kw["optimise"]):
        check_select(kw["select"])
        sel = {"method": "random"} if kw["selection"] is None else dict(kw["selection"])
        return m.random_genes(n, size, rng, tile_size), sel
    ev = None if evaluator is None else (lambda: m.penalised(evaluator(), size))
    g, sel = choose_genes(None, evaluator=ev, **kw)
    return m.final_genes(g, size, rng), sel


__all__ = [
    "AIS_DEFAULTS",
    "BEST_OF_DEFAULTS",
    "GA_DEFAULTS",
    "METHODS",
    "POLISH_DEFAULTS",
    "Region",
    "SelectionResult",
    "as_generator",
    "choose_genes",
    "bga_delta",
    "bga_fold",
    "bga_mutation",
    "clone_counts",
    "crossover_repair",
    "ga_crossover",
    "mutation_probabilities",
    "polish_genes",
    "population_diversity",
    "rank_probabilities",
    "relative_affinity",
    "roulette_select",
    "run_ais",
    "run_best_of",
    "run_ga",
    "run_random",
    "segment_mutation",
    "select_genes",
]
