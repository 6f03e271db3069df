"""The patch scheme: a baseline of random exemplar crops joined to a corner layout by min-cuts.

Each tile of a corner set (⟨TL, BL, TR, BR⟩, as for ω-tiles) starts from the same intermediate tile as an
ω-tile: the four quadrants of its corner colours' sample patches, so that tiles sharing a side show the two
halves of one patch across it and every tiling is seamless by construction. Instead of the matching patch
that ω-tiles search for (the exemplar translation with the smallest SSD), each tile takes **one uniformly
random exemplar crop**, drawn from the seed, and the same min-cut as ω-tiles (Kwatra weights, border ring tied
to the intermediate tile, sinks on the central cross) joins it in. D_j is the SSD between intermediate tile j
and its crop; E = 0.8·ΣD_j + 0.2·Var(D_j) over all tiles (each has its own crop).

What it is for: a benchmark baseline that isolates what the matching search buys. Everything but the choice of
the patch is the ω construction, so a difference in seam cost or coherence between ``omega`` and ``patch``
sets of the same genes is the match's doing. There is no objective to select genes by (the crops are random),
so ``select`` other than "random" is refused.

Choices: one crop per *tile* (not per corner tuple), so a set with variants (16bx2, 32) gets different content
per variant without a second-best search; crops are drawn with replacement (two tiles may share one: rare, and
harmless for a baseline); the crop may overlap the tile's own sample patches.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..base import kernels
from ..base.validate import finite_float
from ..builder.compose import cut_and_compose, finish_tileset, patches_at
from ..builder.genes.draws import LAMBDA, energy
from ..builder.genes.omega_borders import DEFAULT_BORDER_TRIES, corner_border_draws
from ..builder.genes.select import choose_genes
from ..builder.genes.wang_borders import check_border_tries
from ..builder.masking import active
from ..builder.options import Progress, SeedLike, common_options
from ..errors import ParameterError
from ..layouts.corners import CornerPlan, corner_set, intermediate_tiles
from ..measure.diagnose import finish_build
from ..tileset.tilefile import TileSet
from .base import Scheme, lambda_energy_line
from .common import CORNER_BORDER_TRIES, GRADIENTS, LITERAL_BORDER

__all__ = ["SCHEME", "build_patch"]


# Length: 81 lines, of which 12 are the docstring and 17 the signature (one option a line); the body is 52.
def build_patch(
    exemplar: np.ndarray,
    *,
    tileset: str = "16a",
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
    select_params: dict[str, Any] | None = None,
    mask: Any = None,
    alpha: str = "auto",
    border_tries: int = DEFAULT_BORDER_TRIES,
) -> TileSet:
    """Build a patch-baseline tile set from ``exemplar`` (see the module docstring).

    Parameters are those of :func:`tilesynth.build_omega` that apply: ``tileset`` (a corner set), ``tile_size``,
    ``genes`` (given sample patches) or random ones from ``seed``, ``threads``, ``eps``, ``gradients``,
    ``keep_border``, ``progress``, ``selection``, ``exemplar_info``. ``select`` may only be None or "random" (and
    ``polish``, ``generations``, ``population``, ``select_params`` unset): the scheme has no objective to select by.
    ``mask``, ``alpha``: as for :func:`tilesynth.build_omega` (random crops are drawn among the windows clear of
    the mask).

    Returns
    -------
    TileSet with ``scheme="patch"``: ``match_offsets`` are the crops' top-left corners, ``cut_masks`` True where a
    pixel came from the crop, ``D`` the SSD between each intermediate tile and its crop.
    """
    b = common_options(
        exemplar, tileset=tileset, resolve_set=corner_set, tile_size=tile_size, seed=seed, threads=threads,
        progress=progress, exemplar_info=exemplar_info, mask=mask, alpha=alpha,
    )  # fmt: skip
    eps = finite_float(eps, "eps", positive=True)
    if gradients not in ("patch", "tile"):
        raise ParameterError(f"gradients = {gradients!r}: must be 'patch' or 'tile'")
    keep_border = bool(keep_border)
    tries = check_border_tries(border_tries)
    plan = CornerPlan.of(b.definition)
    genes_arr, sel = choose_genes(
        genes, n=plan.n_colours, size=b.tile_size, shape=b.exemplar.shape, rng=b.rng, evaluator=None,
        select=select, polish=polish, generations=generations, population=population,
        select_params=select_params, selection=selection, progress=b.progress, mask=b.mask,
    )  # fmt: skip
    genes_arr, sel = corner_border_draws(  # border-aware random draws, as ω's
        b.exemplar, b.tile_size, b.rng, genes_arr, sel, tries,
        genes is None and active(b.mask) is None,  # not mask-aware: a masked build keeps its one clear draw
    )  # fmt: skip
    n, (h, w) = b.tile_size, b.exemplar.shape[:2]
    inter, inter_src = intermediate_tiles(b.exemplar, genes_arr, plan.unique, n)
    I_tiles, I_src = inter[plan.inverse], inter_src[plan.inverse]
    cols = w - n + 1
    m = active(b.mask)
    if m is None:
        flat = b.rng.integers(0, (h - n + 1) * cols, size=plan.tile_patches.shape[0])
    else:  # a masked pixel is no data: random crops among the clear windows
        valid = np.flatnonzero(m.valid(n))
        flat = valid[b.rng.integers(0, valid.size, size=plan.tile_patches.shape[0])]
    crops = np.stack([flat // cols, flat % cols], axis=1).astype(np.int64)
    diff = I_tiles.astype(np.float64) - patches_at(b.exemplar, crops, n)
    D = (diff * diff).sum(axis=(1, 2, 3))
    tiles, source, masks, costs, _, timing = cut_and_compose(
        b,
        I_tiles,
        I_src,
        crops,
        eps=eps,
        grad_from_patches=gradients == "patch",
        keep_border=keep_border,
        smooth=False,
    )
    params = {
        "set": b.definition.name,
        "tile_size": n,
        "eps": float(eps),
        "gradients": gradients,
        "keep_border": keep_border,
        "lambda": LAMBDA,
        "crops": "random",
        "seed": b.seed,
        "selection": sel,
        **({"border_tries": tries} if "border_tries" in sel else {}),
    }
    ts = finish_tileset(
        scheme="patch", definition=b.definition, exemplar=b.exemplar, tiles=tiles, source=source,
        cut_masks=masks, genes=genes_arr, tile_patches=plan.tile_patches, match_offsets=crops, D=D,
        cut_costs=costs, E=energy(D), params=params, exemplar_info=b.exemplar_info, timing=timing,
        started=b.started,
    )  # fmt: skip
    return finish_build(ts, b)  # the mask record and the input warnings


def _describe(ts: Any) -> list[str]:
    return [
        "matching      none: one random exemplar crop per tile (the patch baseline)",
        lambda_energy_line(ts.params, ts.E, "tiles and their random crops"),
    ]


SCHEME = Scheme(
    name="patch",
    title="patch tiles",
    summary="random exemplar crops cut into a corner layout (a baseline for benchmarks)",
    layout="corner",
    default_set="16a",
    builder=build_patch,
    options=(GRADIENTS, LITERAL_BORDER, CORNER_BORDER_TRIES),
    describe=_describe,
    selects=False,
)
