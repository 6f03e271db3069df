"""The matching stage of the ω builder: for every intermediate tile, its matching patches O (the exemplar
windows it is cut against), by the recipe's strategy and metric, with the diversity and augmentation levers
and the exemplar's mask.

:func:`matching_patches` is the entry (:func:`tilesynth.builder.omega.tile_stages` calls it); the plain path is
the exact k-best SSD search (:meth:`tilesynth.base.kernels.SsdIndex.best_matches`, the second best more than
N/4 away); the heuristics of 002 and the real-cut ranking (:mod:`tilesynth.builder.matching.choose`) rank whole
distance maps.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ...base import kernels
from ...errors import ParameterError
from ..compose import patch_gradients
from ..masking import active, masked_search, valid_fallback
from .augment import best_augmented, mode_transforms
from .choose import EQ2_EPS, MU, augmented, gradient_norm, pick_distinct, strategy_edges
from .levers import (
    assign_diverse,
    check_max_uses,
    diverse_candidates,
    diverse_matches_augmented,
    self_offsets,
)

if TYPE_CHECKING:
    from ...layouts.corners import CornerPlan
    from ..options import BuildOptions, Progress
    from ..recipe import OmegaOptions

__all__ = ["matching_patches"]


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
    valid = None if mask is None else mask.valid(n).ravel()  # a masked pixel is no data: only clear windows
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


def matching_patches(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, inter: np.ndarray, inter_src: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Offsets ``(U, v, 2)`` and distances ``(U, v)`` of the matching patches, each intermediate tile's
    smallest distance ``(U,)`` (for E), and the patches' transforms ``(U, v)`` (None without ``augment``)."""
    if (
        opts.augment != "none"
    ):  # mirrored / rotated candidates (the masked search takes untransformed windows: refused earlier)
        return _augmented_matches(b, opts, plan, inter, inter_src)
    return (*_plain_matches(b, opts, plan, inter, inter_src), None)


def _augmented_matches(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, inter: np.ndarray, inter_src: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`matching_patches` with ``augment``: the candidates of every orientation (:mod:`tilesynth.builder.matching.augment`)."""
    modes = mode_transforms(opts.augment)
    if opts.diversity is None:
        off, ssd, tid, best = best_augmented(b.exemplar, inter, plan.n_variants, modes, b.threads)
        return off, ssd, best, tid
    best = kernels.best_matches(b.exemplar, inter, k=1, threads=b.threads)[1][:, 0]
    chosen, chosen_D, tid = diverse_matches_augmented(
        b.exemplar, inter, plan.n_variants, opts.diversity, b.threads, self_offsets(inter_src), modes
    )
    return chosen, chosen_D, best, tid


def _plain_matches(
    b: BuildOptions, opts: OmegaOptions, plan: CornerPlan, inter: np.ndarray, inter_src: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`matching_patches` without ``augment``."""
    n, nv = b.tile_size, plan.n_variants
    exclude = n // 4 if nv > 1 else 0
    m = active(b.mask)  # a masked pixel is no data: matching patches only from clear windows
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
    ):  # spread the tiles over the exemplar (levers.diverse_matches); E keeps each tile's best
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
