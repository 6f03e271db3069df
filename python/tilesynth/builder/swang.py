"""Strict Wang tiles (004): one closed cut per tile inside edges that are exactly their samples.

The same four samples, P = N and no overlap: the *initial tile* takes each triangle from its edge's sample
(diagonal pixels go to N/S, so corners go to the horizontal-edge sample), which makes every edge exactly its
sample. One square *supplementary patch* per tile (the exemplar translation with the smallest SSD to the
initial tile, found exhaustively, or the lowest-cut-cost of its best SSD candidates with
``supplementary="cut"``) replaces the middle of the tile inside one closed graph cut: the border ring is tied
to the initial tile, both diagonals (corner pixels excepted, they are border) to the supplementary patch, and
the edges carry Kwatra weights with the gradients of the samples (through the provenance), as for ω-tiles.
Edges are then continuous exemplar content everywhere except the two junction pixel pairs per vertical edge.
D_j is the SSD between initial tile and patch, E = 0.8·ΣD_j + 0.2·Var(D_j) as for ω-tiles; ``select``
chooses the four diamond samples by that E (the supplementary patches follow from them).

Provenance as for ω-tiles: ``source`` holds the exemplar (row, col) of every tile pixel, ``labels`` which
sample it came from, ``cut_masks`` the cuts and ``cut_stats`` the facts of each Cohen cut (see
:mod:`tilesynth.tileset.tilefile`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base import kernels
from ..base.validate import as_image, positive_int
from ..errors import ParameterError
from ..layouts.wang_sets import WangTileSet
from ..measure.diagnose import finish_build
from ..tileset.tilefile import TileSet
from .compose import finish_tileset, offset_source, patch_gradients, patches_at
from .genes.draws import LAMBDA, energy
from .genes.select import GA_DEFAULTS, choose_genes
from .genes.wang_borders import DEFAULT_BORDER_TRIES, check_border_tries
from .masking import active, masked_search
from .options import BuildOptions, Progress, SeedLike, common_options
from .wang import (
    SUPPLEMENTARY,
    _border_draws,
    _resolve_set,
    initial_labels,
    sample_source,
)

__all__ = ["SUPPLEMENTARY_METHODS", "SwangEvaluator", "build_swang", "swang_options"]


def _initial_tiles(
    ex: np.ndarray, genes: np.ndarray, tile_patches: np.ndarray, n: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Initial tiles ``(K, N, N, C)``, their provenance ``(K, N, N, 2)`` and labels ``(K, N, N)``."""
    lab = np.broadcast_to(initial_labels(n), (tile_patches.shape[0], n, n))
    src = sample_source(genes, tile_patches, lab, n, 0)
    return ex[src[..., 0], src[..., 1]], src, np.ascontiguousarray(lab)


class SwangEvaluator:
    """E = λ·ΣD_j + (1−λ)·Var(D_j) of s-Wang gene vectors (D_j: exact best SSD of initial tile j), for populations.

    All initial tiles of a population go to the Rust SSD kernel in one call (exact best matches, parallel over
    tiles, cached exemplar spectrum), so one call per generation.
    """

    def __init__(
        self,
        exemplar: np.ndarray,
        tile_size: int,
        tile_patches: np.ndarray,
        lam: float = LAMBDA,
        mask: Any = None,
    ) -> None:
        self.exemplar = as_image(exemplar, "exemplar")
        self.tile_size = int(tile_size)
        self.tile_patches = np.asarray(tile_patches, dtype=np.int64)
        self.lam = float(lam)
        # with a mask (tilesynth.builder.masking.ExemplarMask), D_j is the best match among valid windows
        self._mask = mask
        self._scale = 1.0 if mask is None else mask.search_scale(self.exemplar, self.tile_size)
        search = self.exemplar if mask is None else mask.search_image(self.exemplar, self.tile_size, True)
        self._index = kernels.SsdIndex(search, features=mask is not None)

    def evaluate(self, genes: np.ndarray, threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(E[P], D[P, m])`` of ``genes`` ``(P, n, 2)``."""
        g = np.asarray(genes, dtype=np.int64)
        p, m = g.shape[0], self.tile_patches.shape[0]
        stack = np.concatenate(
            [_initial_tiles(self.exemplar, g[i], self.tile_patches, self.tile_size)[0] for i in range(p)]
        )
        if self._mask is not None:
            stack = self._mask.templates(stack, self._scale)
        _, ssd = self._index.best_matches(stack, k=1, threads=threads)
        D = ssd[:, 0].reshape(p, m) / (self._scale * self._scale)
        E = np.array([energy(row, self.lam) for row in D])
        return E, D


SUPPLEMENTARY_METHODS = ("ssd", "cut")


@dataclass(frozen=True)
class SwangOptions:
    """The s-Wang scheme's own options of one build, validated once (:func:`swang_options`)."""

    method: str
    given: np.ndarray | None
    candidates: int
    gradients: str
    eps: float


def swang_options(
    b: BuildOptions, *, supplementary: Any, candidates: Any, gradients: Any, eps: Any
) -> SwangOptions:
    """Validate the s-Wang options (names as in :func:`build_swang`)."""
    ex, n, k = b.exemplar, b.tile_size, len(b.definition)
    if gradients not in ("patch", "tile"):
        raise ParameterError(f"gradients = {gradients!r}: must be 'patch' or 'tile'")
    given: np.ndarray | None = None
    if isinstance(supplementary, str):
        if supplementary not in SUPPLEMENTARY_METHODS:
            raise ParameterError(f"supplementary = {supplementary!r}: must be 'ssd', 'cut' or a (K, 2) array")
    else:
        given = np.asarray(supplementary)
        if given.shape != (k, 2) or not np.issubdtype(given.dtype, np.integer):
            raise ParameterError(
                f"supplementary has shape {given.shape} and dtype {given.dtype}, expected integer ({k}, 2)"
            )
        hi = np.array([ex.shape[0] - n, ex.shape[1] - n])
        bad = np.nonzero((given < 0).any(1) | (given > hi).any(1))[0]
        if bad.size:
            raise ParameterError(
                f"supplementary[{int(bad[0])}] = {tuple(int(v) for v in given[bad[0]])}: the patch must lie "
                f"inside the exemplar (row in [0, {hi[0]}], col in [0, {hi[1]}])"
            )
        given = given.astype(np.int64)
    method = supplementary if isinstance(supplementary, str) else "given"
    return SwangOptions(method, given, positive_int(candidates, "candidates"), gradients, eps)


def _supplementary_candidates(
    b: BuildOptions, o: SwangOptions, I_tiles: np.ndarray, n_variants: int = 1
) -> tuple[np.ndarray, np.ndarray]:
    """Candidate supplementary patches ``(K, c, 2)`` of every initial tile and their SSD ``(K, c)``; at least
    ``n_variants`` of them, N/4 apart (so that the variants of an edge tuple take different ones)."""
    ex, n = b.exemplar, b.tile_size
    if o.given is not None:
        ssd = np.array(
            [[float(((I_tiles[t].astype(np.float64) - ex[r : r + n, c : c + n]) ** 2).sum())] for t, (r, c) in
             enumerate(o.given)]
        )  # fmt: skip
        return o.given[:, None, :], ssd
    want = 1 if o.method == "ssd" else o.candidates
    if o.method == "cut" and want < n_variants:
        raise ParameterError(
            f"candidates = {o.candidates}: fewer than the {n_variants} variants per edge tuple of the set"
        )
    want = max(want, n_variants)
    m = active(b.mask)  # a masked pixel is no data: supplementary patches only from clear windows
    search, tpl, unscale = (ex, I_tiles, 1.0) if m is None else masked_search(m, ex, I_tiles, n, True)
    index = kernels.SsdIndex(search, b.threads, features=m is not None)
    offsets, ssd = index.best_matches(
        tpl, k=want, exclude_radius=n // 4 if want > 1 else 0, threads=b.threads
    )
    if m is not None:
        ssd = ssd * unscale
        if o.method == "cut":  # candidates touching the mask are dropped (the best valid ones come first)
            keep = m.windows_ok(offsets, n).all(axis=0)
            offsets, ssd = offsets[:, keep], ssd[:, keep]
        m.check_windows(offsets, n, "supplementary patches", n)
    if offsets.shape[1] < want:
        raise ParameterError(
            f"candidates = {o.candidates}: the exemplar has only {offsets.shape[1]} translations N/4 apart"
        )
    return offsets, ssd


def _closed_cuts(
    b: BuildOptions,
    o: SwangOptions,
    I_tiles: np.ndarray,
    I_src: np.ndarray,
    offsets: np.ndarray,
    rank: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The closed cut of every tile against each candidate; per tile the cheapest (ties: the better SSD), or
    with ``rank`` ``(K,)`` the ``rank[j]``-th cheapest (variant v of an edge tuple takes its
    (v+1)-th cheapest candidate). Returns ``(choice (K,), masks (K, N, N), costs (K,))``."""
    ex, n, k = b.exemplar, b.tile_size, I_tiles.shape[0]
    grad = patch_gradients(ex, I_src) if o.gradients == "patch" else None
    n_cand = offsets.shape[1]
    if n_cand == 1:
        masks, costs = kernels.swang_cuts(
            I_tiles, patches_at(ex, offsets[:, 0], n), eps=o.eps, threads=b.threads, initial_grad=grad
        )
        return np.zeros(k, np.int64), masks, costs
    reps = np.repeat(np.arange(k), n_cand)
    cols = np.tile(np.arange(n_cand), k)
    all_masks, all_costs = kernels.swang_cuts(
        np.ascontiguousarray(I_tiles[reps]), patches_at(ex, offsets[reps, cols], n), eps=o.eps, threads=b.threads,
        initial_grad=None if grad is None else np.ascontiguousarray(grad[reps]),
    )  # fmt: skip
    all_costs = all_costs.reshape(k, n_cand)
    if rank is None:
        choice = np.argmin(all_costs, axis=1)  # ties: the better SSD
    else:
        choice = np.argsort(all_costs, axis=1, kind="stable")[np.arange(k), rank]
    return choice, all_masks.reshape(k, n_cand, n, n)[np.arange(k), choice], all_costs[np.arange(k), choice]


# Length: 86 lines, of which 25 are the docstring; the body (61) is the stage sequence.
def build_swang(
    exemplar: np.ndarray,
    *,
    tileset: str | WangTileSet = "wang8",
    tile_size: int | None = None,
    genes: np.ndarray | None = None,
    supplementary: str | np.ndarray = "ssd",
    candidates: int = 8,
    border_tries: int = DEFAULT_BORDER_TRIES,
    seed: SeedLike = None,
    threads: int | None = None,
    eps: float = kernels.DEFAULT_EPS,
    gradients: str = "patch",
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
    """Build strict Wang tiles (Zhang and Kim, 004) from ``exemplar``.

    Parameters
    ----------
    exemplar : image ``(H, W[, C])``.
    tileset : "wang8" (004's set, default) or any Wang set.
    tile_size : N, even; default half the exemplar's shorter side (004 used 100 on 128 x 128 inputs).
    genes : optional ``(n, 2)`` top-left corners of the N x N squares of the diamond samples (horizontal colours
        first).
    supplementary : "ssd" (default: the exemplar translation with the smallest SSD to the initial tile, found
        exhaustively), "cut" (of the ``candidates`` best SSD translations at least N/4 apart, the one whose
        closed cut is cheapest: closer to 004's "most suitable sub-images using graph cut"), or an int
        ``(K, 2)`` array of top-left corners, one per tile.
    candidates : number of candidates of ``supplementary="cut"``.
    border_tries : with random samples, the number of random gene vectors drawn, the one with the smallest
        predicted border seam kept (as for :func:`build_wang`; default 32, 1 = a single random draw).
    seed, threads, eps : as for :func:`tilesynth.build_omega`.
    gradients : "patch" (default: gradients of the samples, through the provenance) or "tile" (of the
        assembled initial tile) in the Kwatra weight, as for ω-tiles.
    select, polish, generations, population, select_params : choose the four diamond samples by
        E = 0.8·ΣD_j + 0.2·Var(D_j) (:class:`SwangEvaluator`); the GA uses 000's settings as for ω-tiles.
    progress, selection, exemplar_info, mask, alpha : as for :func:`tilesynth.build_omega` (the samples and the
        supplementary patches avoid the mask).

    Returns
    -------
    TileSet with ``scheme="swang"``.
    """
    b = common_options(
        exemplar, tileset=tileset, resolve_set=_resolve_set, tile_size=tile_size, seed=seed, threads=threads,
        progress=progress, exemplar_info=exemplar_info, mask=mask, alpha=alpha,
    )  # fmt: skip
    with b.source.validated():  # the stages take the exemplar as validated here (checked once)
        o = swang_options(b, supplementary=supplementary, candidates=candidates, gradients=gradients, eps=eps)
        tries = check_border_tries(border_tries)
        ex, defn, n = b.exemplar, b.definition, b.tile_size
        k, tile_patches = len(defn), defn.sample_indices()
        genes_arr, sel = choose_genes(
            genes, n=defn.n_samples, size=n, shape=ex.shape, rng=b.rng,
            evaluator=lambda: (lambda g, ev=SwangEvaluator(ex, n, tile_patches, mask=active(b.mask)): ev.evaluate(g, b.threads)),  # noqa: B008, E501 - one evaluator, built when selection starts
            select=select, polish=polish, generations=generations, population=population,
            select_params=select_params, selection=selection, ga_defaults=GA_DEFAULTS, progress=b.progress,
            mask=b.mask,
        )  # fmt: skip
        genes_arr, sel = _border_draws(b, genes, select, polish, select_params, genes_arr, sel, n, tries)
        t_sel = time.perf_counter()
        b.report("initial tiles", 0, 1)
        I_tiles, I_src, I_lab = _initial_tiles(ex, genes_arr, tile_patches, n)
        b.report("initial tiles", 1, 1)
        b.report("supplementary patches", 0, 1)
        variants = np.asarray(defn.variants, np.int64)  # wc<K>x<V>: the variants of one edge tuple differ
        nv = int(variants.max()) + 1
        offsets, ssd = _supplementary_candidates(b, o, I_tiles, nv)
        rank = None
        if nv > 1 and o.method == "ssd":  # variant v: the (v+1)-th best SSD translation, N/4 from the others
            rows = np.arange(k)
            offsets, ssd = offsets[rows, variants][:, None], ssd[rows, variants][:, None]
        elif nv > 1 and o.method == "cut":  # variant v: the (v+1)-th cheapest closed cut among the candidates
            rank = variants
        t_match = time.perf_counter()
        b.report("supplementary patches", 1, 1)
        b.report("cuts", 0, 1)
        choice, masks, costs = _closed_cuts(b, o, I_tiles, I_src, offsets, rank)
        t_cut = time.perf_counter()
        b.report("cuts", 1, 1)
        match = offsets[np.arange(k), choice].astype(np.int64)
        D = ssd[np.arange(k), choice].astype(np.float64)
        source = np.where(masks[..., None], offset_source(match, n), I_src).astype(np.int32)
        params = {
            "set": defn.name, "tile_size": n, "sample_size": n, "samples": "diamond", "supplementary": o.method,
            "candidates": o.candidates if o.method == "cut" else None, "eps": float(o.eps), "gradients": o.gradients,
            "lambda": LAMBDA, "match": "ssd", "seed": b.seed, "selection": sel, "border_tries": tries,
        }  # fmt: skip
        ts = finish_tileset(
            scheme="swang", definition=defn, exemplar=ex, tiles=ex[source[..., 0], source[..., 1]], source=source,
            cut_masks=masks, genes=genes_arr, tile_patches=tile_patches, match_offsets=match, D=D, cut_costs=costs,
            E=energy(D), params=params, exemplar_info=b.exemplar_info,
            timing={"selection_s": t_sel - b.started, "matching_s": t_match - t_sel, "cutting_s": t_cut - t_match},
            started=b.started, labels=np.where(masks, SUPPLEMENTARY, I_lab),
        )  # fmt: skip
        return finish_build(ts, b)  # the mask record and the input warnings
