"""The ω scheme (Ng et al. 2005, 002): corner-coloured tiles cut from a matching patch (:func:`tilesynth.build_omega`)."""

from __future__ import annotations

from typing import Any

from ..builder.materials import MATERIAL_CUT_EPS
from ..builder.omega import build_omega
from ..builder.recipe import NAMED_RECIPES
from ..cli.argtypes import float_text
from .base import Option, Scheme, lambda_energy_line, nonneg_int_text, positive_int_text
from .common import CORNER_BORDER_TRIES, GRADIENTS, LITERAL_BORDER


def smoothing_line(sm: dict) -> str:
    """The ``info`` line of a smoothed set (values shown as stored; a tampered field prints as "?")."""

    def num(key: str, spec: str = "") -> str:
        v = sm.get(key)
        return format(v, spec) if isinstance(v, (int, float)) and not isinstance(v, bool) else "?"

    return (
        f"smoothing     Poisson, {num('unknowns')} unknowns, at most {num('iterations_max')} iterations, "
        f"residual <= {num('residual_max', '.1e')}, {num('clipped')} values clipped to [0, 1]"
    )


def _describe(ts: Any) -> list[str]:
    p = ts.params
    match = (
        f"matching      {p.get('match', 'ssd')}"
        + (f" (k = {p['match_k']})" if p.get("match_k") is not None else "")
        + f", distance {p.get('metric', 'color')}"
        + ("" if p.get("keep_border", False) else ", literal border (002's cut may reach the tile border)")
    )
    sm = p.get("smooth")
    aug = p.get("augment")
    if aug not in (None, "none"):  # how many tiles took a transformed matching patch
        t = p.get("match_transforms") or []
        moved = sum(1 for v in t if v != 0)
        match += f", augment {aug} ({moved} of {len(t)} matching patches transformed)"
    return [
        *_recipe_line(p.get("recipe")),
        match,
        *([smoothing_line(sm)] if isinstance(sm, dict) else []),
        lambda_energy_line(p, ts.E, "intermediate tiles"),
    ]


def _recipe_line(rec: Any) -> list[str]:
    """The ``info`` line of a named recipe (``params["recipe"]``; a tampered record prints what it can)."""
    if not isinstance(rec, dict):
        return []
    applied = rec.get("applied")
    what = ", ".join(str(a) for a in applied) if isinstance(applied, list) and applied else "nothing changed"
    scale = rec.get("feature_scale")
    extra = ""
    if isinstance(scale, dict) and isinstance(scale.get("scale"), (int, float)) and scale.get("kind"):
        extra = f"; typical object {scale['scale']:.0f} px across"
    return [f"recipe        {rec.get('name', '?')} (set by the recipe: {what}{extra})"]


def _match_k(text: str | None) -> int | str | None:
    if text is None or text.strip().lower() == "all":
        return None if text is None else "all"
    try:
        return int(text)
    except ValueError:
        from ..errors import ParameterError

        raise ParameterError(f"--match-k = {text!r}: expected a positive integer or 'all'") from None


SCHEME = Scheme(
    name="omega",
    title="ω-tiles",
    summary="ω-tiles (default)",
    layout="corner",
    default_set="c5",  # measured with benches/repetition.py (complete set, hashed lookup; c4 before)
    builder=build_omega,
    options=(
        Option(
            "recipe",
            "--recipe",
            "a quality/speed recipe: default (c5, 625 tiles); fast (c4, 256 tiles: builds ~2.3x faster, twice "
            "the periodic copies); objects (for photos of separate objects such as coins or floor tiles: tiles "
            "about four objects wide, more objects kept whole, 1.8x the build time; other photos get the "
            "default). --set and --tile-size override it",
            choices=tuple(NAMED_RECIPES),
        ),
        GRADIENTS,
        LITERAL_BORDER,
        Option(
            "normalise",
            "--normalise",
            "optimise the per-pixel objective (SSD divided by the tile's pixel count)",
            store_true=True,
        ),
        Option(
            "match",
            "--match",
            "how each tile's matching patch is chosen: ssd (smallest SSD, default), "
            "circle / midpoints (the paper's heuristics: smallest seam weights around the circle / near the side "
            "midpoints), best-cut (run the real cut for the --match-k nearest candidates, keep the cheapest)",
            choices=("ssd", "circle", "midpoints", "best-cut"),
        ),
        Option(
            "match_k",
            "--match-k",
            "candidates of --match best-cut: a positive integer (default 16) or 'all'",
            metavar="K|all",
            flag_value=_match_k,
        ),
        Option(
            "metric",
            "--metric",
            "distance for the matching search and the objective E: color (SSD, "
            "default), eq3 (SSD + 10 x squared gradient difference), eq2 (SSD weighted by 1/(10 "
            "(|grad T| + |grad I|)), exact but slow: direct sums, not with --select)",
            choices=("color", "eq2", "eq3"),
        ),
        Option(
            "smooth",
            "--smooth",
            "Poisson-smooth the region inside each cutting curve: the "
            "matching patch's gradients, blended into the tile from the curve; exact to a 1e-6 residual, tile "
            "borders kept",
            store_true=True,
        ),
        Option(
            "cut_region",
            "--cut-region",
            "where the cut may run: the inscribed circle (the paper's; default for the papers' sets) or free but for a "
            "border ring and corner discs, so most of each tile is its own matching patch (less repetition; "
            "default for complete sets); ring: the free region with a uniform area reward, which draws a grid of "
            "seams 2 px inside the tile borders (for comparison); free8: free on an 8-connected grid (cut cost ~ "
            "Euclidean length: straight diagonal cut edges instead of staircases)",
            choices=("circle", "free", "free8", "ring"),
        ),
        Option(
            "cut_bias",
            "--cut-bias",
            "--cut-region free/free8/ring: area reward per pixel that moves the cut outwards, in units of the mean edge "
            "weight (default 32/N for free, 0.02 for ring)",
            cli_type=float_text(0.0),
        ),
        Option(
            "objective",
            "--objective",
            "what --select minimises: visible (cut seam, coherence and texture statistics of a small proxy "
            "synthesis, rank-summed over the best --rerank candidates by ΣD), cut (the real cut cost of the "
            "tiles, robust geometric mean, with ΣD as the cheap first stage and the best --rerank candidates "
            "built), sum-d (ΣD) or E (the papers' objective; the default of a named --select); window "
            "(complete sets only: of --rerank border-best random draws, the one whose 8x8-tile window of "
            "the tiling measures best in cut seam, coherence and texture statistics)",
            choices=("visible", "cut", "sum-d", "E", "window"),
        ),
        Option(
            "rerank",
            "--rerank",
            "--objective visible/cut: how many of the best candidates by ΣD are built and re-ranked (default 8 "
            "for visible, 4 for cut); --objective window: how many border-best random draws are measured on "
            "the window (default 4 of 8)",
            cli_type=positive_int_text,
            metavar="K",
        ),
        Option(
            "diversity",
            "--diversity",
            "assign matching patches so that each exemplar region is used at most M times (less repetition); "
            "0: each tile's best match. Default 1 for complete sets (c4, c3x2, ...), 0 for the papers' sets",
            cli_type=nonneg_int_text,
            metavar="M",
        ),
        CORNER_BORDER_TRIES,
        Option(
            "augment",
            "--augment",
            "matching patches may also be mirrored / rotated exemplar windows (for isotropic textures; "
            "tilesynth.builder.matching.augment): none (default), flip (4 mirrors), rotate (4 rotations), all (8); costs one "
            "matching search per orientation; only with --match ssd --metric color and no mask",
            choices=("none", "flip", "rotate", "all"),
        ),
        Option(
            "periodic",
            "--periodic",
            "complete sets at the default tile size: auto (default) takes the tile size from the exemplar's "
            "period when it repeats at a shift of one tile (a brick wall; tilesynth.builder.periodic), lock also puts "
            "every sample patch at one phase of it (continuous courses, more copies), off never",
            choices=("auto", "lock", "off"),
        ),
    ),
    describe=_describe,
    # joint material builds cut with a capped gradient normalisation (materials.MATERIAL_CUT_EPS)
    material_options={"eps": MATERIAL_CUT_EPS},
)
