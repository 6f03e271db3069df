"""Exemplar masks: pixels that no sample patch, matching patch or cut region may ever take.

A mask comes from the exemplar's alpha channel or from a separate image / array, pixel-aligned with the exemplar
(:func:`resolve_mask`). It is *binary*: a pixel is masked or it is not.

**Alpha** (``alpha=``; ``--alpha`` on the command line):

* ``"auto"`` (default): an exemplar with 2 (grey + alpha) or 4 (RGBA) channels whose alpha channel is not
  opaque everywhere is read as colour + mask: pixels with alpha < :data:`ALPHA_THRESHOLD` (0.5) are masked and
  the alpha channel is dropped, so the tiles and outputs are opaque colour. *Why:* a transparent hole in a photo
  is "no data", and the user who brings one expects it never to be copied (matching alpha as an ordinary colour
  channel copied the hole all over the output as transparent discs). An exemplar whose alpha is 1 everywhere
  is left as it is (alpha stays a channel, as before: nothing to mask, the result does not change).
* ``"mask"``: the same, and also refuses an exemplar without an alpha channel (1 or 3 channels).
* ``"colour"``: alpha is an ordinary channel, matched and copied like colour (the behaviour before masks).

**Mask images** (``mask=``; ``--mask M.png``): white (>= 0.5) is masked, black is usable. A colour mask file
counts the mean of its colour channels; an alpha channel of the mask file is ignored. A bool array is used as
it is (True = masked); a numeric array is scaled to [0, 1] (integers by their dtype's maximum) and binarised
at 0.5. It must have the exemplar's height and width. A mask given together with an alpha mask is combined
with it (a pixel masked by either is masked).

**What a mask means for a build.** A *window* (the square of exemplar pixels a sample patch or a matching patch
takes) is valid when none of its pixels is masked; every window a build uses is valid, so no tile pixel's
provenance (``TileSet.source``) is ever a masked pixel, in every scheme:

* sample patches (genes): drawn uniformly over the valid windows; a selection (best-of, GA, AIS, polish)
  evaluates each gene vector with every gene moved to its nearest valid window (a fixed projection, so the
  operators of the papers run unchanged), and returns the projected genes; vectors whose projection repeats a
  window are penalised. Given genes must be valid windows.
* matching / supplementary patches: the exact SSD search runs on the exemplar with a penalty channel (zero on
  usable pixels, larger than any possible SSD on masked ones: :meth:`ExemplarMask.search_image`), so every valid
  window ranks before every window touching the mask, and the chosen windows are checked afterwards.
  The objective E of a selection uses the same penalised search (D_j is the best *valid* match).
* random crops (the patch baseline): drawn over the valid windows.

An empty mask changes nothing (the build is that of no mask; the mask record says 0 % masked). An all-masked
mask, one of another size than the exemplar, and one that leaves fewer valid windows than the build needs are
refused with a :class:`~tilesynth.errors.ParameterError` (exit status 2) naming what is left (the largest valid
square window) and what would fit (the largest tile size that works). Without an explicit tile size, the default
shrinks to what fits (:meth:`ExemplarMask.default_tile_size`).

**Exactness and cost.** The masked SSD search is the exact k-best search of the unmasked one on a scaled copy
(see :meth:`ExemplarMask.search_image`), so the chosen matching patches are the exact best *valid* ones and their
D_j the exemplar's SSD. The strategies and metrics that rank by whole maps (``match="circle"`` / ``"midpoints"``
/ ``"best-cut"``, ``metric="eq3"`` / ``"eq2"``) restrict the maps to valid windows instead (the map precision of
those paths, then the exact distance of the pick). ``benches/masks.py`` measures the cost: about 1.0-1.5x the
build time of the clean exemplar at the same tile size.

The tile set records the mask in ``params["mask"]`` (:meth:`ExemplarMask.record`: where it came from, its sha256,
the masked fraction, the largest valid window) and ``tilesynth info`` shows it.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ParameterError, ShapeError
from ..io.images import check_input_file

__all__ = [
    "ALPHA_MODES",
    "ALPHA_THRESHOLD",
    "MASK_THRESHOLD",
    "ExemplarMask",
    "load_mask",
    "resolve_mask",
]

#: Alpha below this is masked (alpha in [0, 1]).
ALPHA_THRESHOLD = 0.5
#: Mask images: values at or above this (in [0, 1]) are masked.
MASK_THRESHOLD = 0.5
#: The choices of ``alpha=`` / ``--alpha``.
ALPHA_MODES = ("auto", "mask", "colour")

_PENALTY_OFF = 1e30  # added to E of a gene vector whose projection repeats a window


def _integral(masked: np.ndarray) -> np.ndarray:
    """The integral image ``(H+1, W+1)`` of the masked pixels."""
    h, w = masked.shape
    ii = np.zeros((h + 1, w + 1), np.int64)
    ii[1:, 1:] = masked.astype(np.int64).cumsum(0).cumsum(1)
    return ii


def _window_sums(ii: np.ndarray, size: int) -> np.ndarray:
    """Number of masked pixels in every ``size x size`` window (top-left (r, c)), int64 ``(H-s+1, W-s+1)``,
    from the integral image ``ii``."""
    return ii[size:, size:] - ii[:-size, size:] - ii[size:, :-size] + ii[:-size, :-size]


@dataclass
class ExemplarMask:
    """A binary mask of an exemplar: ``masked[y, x]`` True where the pixel must never be used."""

    masked: np.ndarray
    source: str
    """"alpha", "file" (a mask image, CLI), "array" (``mask=`` of the API), or "alpha+file" / "alpha+array"."""
    file: str | None = None
    _valid: dict[int, np.ndarray] = field(default_factory=dict, repr=False)
    _proj: dict[int, np.ndarray] = field(default_factory=dict, repr=False)
    _ii: np.ndarray | None = field(default=None, repr=False)

    @property
    def fraction(self) -> float:
        """The masked fraction of the exemplar's pixels."""
        return float(self.masked.mean())

    @property
    def empty(self) -> bool:
        return not bool(self.masked.any())

    def valid(self, size: int) -> np.ndarray:
        """bool ``(H-size+1, W-size+1)``: True where the ``size x size`` window at (r, c) has no masked pixel."""
        if size not in self._valid:
            h, w = self.masked.shape
            if size > h or size > w:
                self._valid[size] = np.zeros((max(h - size + 1, 0), max(w - size + 1, 0)), bool)
            else:
                if self._ii is None:
                    self._ii = _integral(self.masked)
                self._valid[size] = _window_sums(self._ii, size) == 0
        return self._valid[size]

    def count(self, size: int) -> int:
        return int(self.valid(size).sum())

    def largest_window(self) -> int:
        """The side of the largest square window without a masked pixel (0 if every pixel is masked)."""
        lo, hi = 0, min(self.masked.shape)
        while lo < hi:  # the count of valid windows falls as the size grows: bisect
            mid = (lo + hi + 1) // 2
            if self.count(mid) > 0:
                lo = mid
            else:
                hi = mid - 1
        return lo

    def largest_fitting(self, need: int) -> int:
        """The largest window side with at least ``need`` valid windows (0 if none)."""
        lo, hi = 0, min(self.masked.shape)
        while lo < hi:
            mid = (lo + hi + 1) // 2
            if self.count(mid) >= need:
                lo = mid
            else:
                hi = mid - 1
        return lo

    def default_tile_size(self, n: int) -> int:
        """The default tile size ``n`` of an unmasked exemplar, made smaller when the mask leaves too few windows:
        at most the largest even N whose windows of 1.25·N (the Wang samples of N + N/4) have at least 16 valid
        positions. *Why:* a user who gave no tile size wants a build, and the largest size that fits is the
        nearest to the default (an explicit ``tile_size`` that does not fit is an error instead)."""
        fit = int(self.largest_fitting(16) / 1.25)
        fit -= fit % 2
        return max(4, min(n, fit))

    def digest(self) -> str:
        m = np.ascontiguousarray(self.masked, dtype=bool)
        return hashlib.sha256(np.packbits(m).tobytes() + repr(m.shape).encode()).hexdigest()

    def record(self) -> dict[str, Any]:
        """``params["mask"]`` of the tile set."""
        return {
            "source": self.source,
            **({"file": self.file} if self.file else {}),
            "sha256": self.digest(),
            "masked_fraction": round(self.fraction, 6),
            "masked_pixels": int(self.masked.sum()),
            "largest_valid_window": self.largest_window(),
            "threshold": ALPHA_THRESHOLD if "alpha" in self.source else MASK_THRESHOLD,
        }

    # ---------------------------------------------------------------------------------------------------------
    # the build stages

    def too_small(self, size: int, need: int, what: str, tile_size: int) -> ParameterError:
        """The error of a mask that leaves fewer than ``need`` valid ``size`` windows for ``what``."""
        left = self.count(size)
        fit = self.largest_fitting(need)
        # the tile size whose window is at most `fit` (windows scale with the tile: P = N + N/4 for Wang samples)
        tile_fit = int(fit * tile_size / size) if size else fit
        tile_fit -= tile_fit % 2
        fits = (
            f"tile_size <= {tile_fit} would fit"
            if tile_fit >= 4
            else "no tile size of at least 4 fits: mask less, or use a larger exemplar"
        )
        return ParameterError(
            f"mask: {100 * self.fraction:.1f} % of the exemplar is masked and leaves {left} valid {size}x{size} "
            f"windows for the {need} {what} of tile_size = {tile_size} (largest valid square window: "
            f"{self.largest_window()}x{self.largest_window()} pixels); {fits}"
        )

    def require(self, size: int, need: int, what: str, tile_size: int) -> None:
        if self.count(size) < need:
            raise self.too_small(size, need, what, tile_size)

    def random_genes(self, n: int, size: int, rng: np.random.Generator, tile_size: int) -> np.ndarray:
        """``n`` distinct top-left corners drawn uniformly over the valid ``size`` windows."""
        self.require(size, n, "sample patches", tile_size)
        flat = np.flatnonzero(self.valid(size))
        pick = flat[rng.choice(flat.size, size=n, replace=False)]
        cols = self.valid(size).shape[1]
        return np.stack([pick // cols, pick % cols], axis=1).astype(np.int64)

    def check_genes(self, genes: np.ndarray, size: int) -> None:
        v = self.valid(size)
        for i, (r, c) in enumerate(np.asarray(genes).tolist()):
            if not v[r, c]:
                bad = int(self.masked[r : r + size, c : c + size].sum())
                raise ParameterError(
                    f"genes[{i}] = ({r}, {c}): its {size}x{size} window holds {bad} masked pixels; give genes "
                    "whose windows avoid the mask (or no genes: they are then drawn from the valid windows)"
                )

    def projection(self, size: int) -> np.ndarray:
        """int64 ``(rows, cols, 2)``: for every window position, the nearest valid one (itself when valid).

        Nearest in the 4-connected grid distance, found by a breadth-first flood from the valid positions
        (ties: the neighbour met first in the order up, down, left, right), so the map is deterministic."""
        if size in self._proj:
            return self._proj[size]
        v = self.valid(size)
        rows, cols = v.shape
        out = np.full((rows, cols, 2), -1, np.int64)
        rr, cc = np.nonzero(v)
        out[rr, cc, 0], out[rr, cc, 1] = rr, cc
        done = v.copy()
        while not done.all():
            grew = done.copy()
            for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                # pixels not yet done whose neighbour (y+dy, x+dx) was done before this round
                src = np.zeros_like(done)
                ys = slice(max(-dy, 0), rows - max(dy, 0))
                xs = slice(max(-dx, 0), cols - max(dx, 0))
                ys2 = slice(max(dy, 0), rows - max(-dy, 0))
                xs2 = slice(max(dx, 0), cols - max(-dx, 0))
                src[ys, xs] = done[ys2, xs2]
                take = src & ~grew
                if take.any():
                    ty, tx = np.nonzero(take)
                    out[ty, tx] = out[ty + dy, tx + dx]
                    grew |= take
            if (grew == done).all():  # no valid window at all (refused earlier)
                break
            done = grew
        self._proj[size] = out
        return out

    def project(self, genes: np.ndarray, size: int) -> np.ndarray:
        g = np.asarray(genes, dtype=np.int64)
        return self.projection(size)[g[..., 0], g[..., 1]]

    def penalised(self, evaluate: Any, size: int) -> Any:
        """A population evaluator that scores every gene vector by its projection onto the valid windows; a
        vector whose projection repeats a window gets E + 1e30 (worse than any vector of distinct windows)."""
        proj = self.projection(size)
        cols = proj.shape[1]

        def ev(genes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            g = np.asarray(genes, dtype=np.int64)
            p = np.ascontiguousarray(proj[g[..., 0], g[..., 1]])
            E, D = evaluate(p)
            E = np.array(E, dtype=np.float64)
            flat = np.sort(p[..., 0] * cols + p[..., 1], axis=1)
            dup = (np.diff(flat, axis=1) == 0).any(axis=1) if flat.shape[1] > 1 else np.zeros(len(E), bool)
            E[dup] += _PENALTY_OFF
            return E, D

        return ev

    def final_genes(self, genes: np.ndarray, size: int, rng: np.random.Generator) -> np.ndarray:
        """The projection of selected genes; a repeated window (a selection that found nothing better) is
        replaced by a random valid window not yet taken."""
        g = self.project(genes, size)
        cols = self.valid(size).shape[1]
        seen: set[int] = set()
        free = [int(f) for f in np.flatnonzero(self.valid(size))]
        for i in range(g.shape[0]):
            f = int(g[i, 0] * cols + g[i, 1])
            if f in seen:
                left = [x for x in free if x not in seen]
                f = left[int(rng.integers(len(left)))]
                g[i] = (f // cols, f % cols)
            seen.add(f)
        return g

    def search_scale(self, ex: np.ndarray, size: int) -> float:
        """The power of two s that scales the colour channels of a masked search (:meth:`search_image`)."""
        ex = np.asarray(ex, dtype=np.float32)
        rng2 = float(((ex.max(axis=(0, 1)) - ex.min(axis=(0, 1))).astype(np.float64) ** 2).sum())
        bound = 2.0 * size * size * max(rng2, 1.0)  # > the SSD of any two windows, with a margin of 2
        return float(2.0 ** -math.ceil(0.5 * math.log2(bound) + 1))

    def search_image(self, ex: np.ndarray, size: int, features: bool = False) -> np.ndarray:
        """The exemplar scaled by s (:meth:`search_scale`) with a penalty channel, for the SSD search of
        ``size`` windows.

        The penalty channel is 0 on usable pixels and 1 on masked ones; the colour channels are multiplied by
        a power of two s with s² · (the largest SSD two windows can have) < 1/2. A template scaled by s with a
        zero channel there (:meth:`templates`) then has exactly s² times its SSD at every valid window (a power
        of two scales every float exactly, so the ranking and the values are the unmasked ones: divide by s²),
        and at least 1 — more than any valid window — at every window touching the mask. The exact k-best
        search of the SSD index therefore ranks every valid window first with no change to the kernel, whose
        inputs stay in [0, 1]. Without ``features`` (an index of images, not of feature stacks) the index takes
        at most 4 channels, so the exemplar may have at most 3 (RGB, or grey + alpha as colour)."""
        ex = np.asarray(ex, dtype=np.float32)
        if ex.shape[2] >= 4 and not features:
            raise ParameterError(
                f"mask: the exemplar has {ex.shape[2]} channels; a masked build takes at most 3 (the SSD search "
                "adds one for the mask). With RGBA and --alpha colour, drop the alpha channel or use --alpha mask"
            )
        s = np.float32(self.search_scale(ex, size))
        pen = self.masked[..., None].astype(np.float32)
        return np.ascontiguousarray(np.concatenate([ex * s, pen], axis=2))

    @staticmethod
    def templates(tpl: np.ndarray, scale: float) -> np.ndarray:
        """Templates ``(..., C)`` scaled by ``scale`` with a zero penalty channel (:meth:`search_image`)."""
        t = np.asarray(tpl, dtype=np.float32) * np.float32(scale)
        pad = np.zeros(t.shape[:-1] + (1,), np.float32)
        return np.ascontiguousarray(np.concatenate([t, pad], axis=-1))

    def windows_ok(self, offsets: np.ndarray, size: int) -> np.ndarray:
        """bool per offset ``(..., 2)``: its window is valid."""
        o = np.asarray(offsets, dtype=np.int64)
        return self.valid(size)[o[..., 0], o[..., 1]]

    def check_windows(self, offsets: np.ndarray, size: int, what: str, tile_size: int) -> None:
        """Refuse chosen windows that touch the mask (too few valid windows for the build's constraints)."""
        ok = self.windows_ok(offsets, size)
        if not ok.all():
            raise ParameterError(
                f"mask: {int((~ok).sum())} of {ok.size} {what} found no {size}x{size} window clear of the mask "
                f"({self.count(size)} valid windows, {100 * self.fraction:.1f} % of the exemplar masked, largest "
                f"valid square window {self.largest_window()}x{self.largest_window()} pixels); use smaller tiles "
                "(tile_size), fewer variants or no diversity constraint, or mask less"
            )

    def check_provenance(self, source: np.ndarray) -> None:
        """The last guard of every masked build: no tile pixel's source is a masked pixel."""
        s = np.asarray(source)
        hits = int(self.masked[s[..., 0], s[..., 1]].sum())
        if hits:
            from ..errors import InternalError

            raise InternalError(
                f"mask: {hits} tile pixels come from masked exemplar pixels (a bug, please report)"
            )


def _binarise(m: np.ndarray, name: str) -> np.ndarray:
    """bool ``(H, W)`` of a mask array: bool as is; numbers scaled to [0, 1] and compared with 0.5."""
    if m.dtype == bool:
        out = m
    elif m.dtype.kind in "iu":
        top = float(np.iinfo(m.dtype).max) if m.dtype.kind == "u" else None
        if top is None:
            if m.min() < 0 or m.max() > 1:
                raise ParameterError(
                    f"{name}: a signed integer mask must hold 0 and 1 only, got values in [{m.min()}, {m.max()}]"
                )
            out = m >= 1
        else:
            out = m.astype(np.float64) / top >= MASK_THRESHOLD
    elif m.dtype.kind == "f":
        if not np.isfinite(m).all():
            bad = tuple(int(v) for v in np.argwhere(~np.isfinite(m))[0])
            raise ParameterError(
                f"{name}: non-finite value {float(m[bad])} at row {bad[0]}, column {bad[1]} "
                f"({int((~np.isfinite(m)).sum())} in all); a mask must be finite"
            )
        out = m >= MASK_THRESHOLD
    else:
        raise TypeError(f"{name} has dtype {m.dtype}, expected a bool or numeric (h, w) mask")
    return np.ascontiguousarray(out, dtype=bool)


def _mask_array(mask: Any, shape: tuple[int, int], name: str) -> np.ndarray:
    try:
        m = np.asarray(mask)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} = {mask!r}: expected an (h, w) array") from exc
    if m.ndim == 3 and m.shape[2] in (1, 2, 3, 4):
        # an image: grey (+ alpha) or colour (+ alpha); alpha ignored, colour averaged
        colour = m[..., : 1 if m.shape[2] <= 2 else 3]
        m = colour.mean(axis=2) if colour.shape[2] > 1 and m.dtype != bool else colour[..., 0]
    if m.ndim != 2:
        raise ShapeError(f"{name} has shape {m.shape}, expected (h, w) = {shape}")
    if m.shape != shape:
        raise ShapeError(
            f"{name} has shape {m.shape[1]}x{m.shape[0]} (width x height), the exemplar {shape[1]}x{shape[0]}: "
            "a mask must be pixel-aligned with the exemplar"
        )
    return _binarise(m, name)


def load_mask(path: str) -> np.ndarray:
    """A mask image file (PNG, ..., or a bool/numeric ``.npy``) as a float or bool array, unbinarised."""
    if str(path).lower().endswith(".npy"):
        check_input_file(path, f"--mask = {str(path)!r}")  # a folder or FIFO says what it is
        try:
            return np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise ParameterError(f"--mask = {str(path)!r}: not a readable .npy array ({exc})") from None
    from ..io.images import load_image

    try:
        img, _ = load_image(path)
    except ParameterError as exc:
        raise ParameterError(f"--mask: {exc}") from None
    return img


def resolve_mask(
    exemplar: np.ndarray, mask: Any = None, alpha: Any = "auto", *, mask_source: str = "array",
    mask_file: str | None = None,
) -> tuple[np.ndarray, ExemplarMask | None]:  # fmt: skip
    """The exemplar to build from (alpha dropped when it is a mask) and its mask (None when there is none).

    ``exemplar`` is float32 ``(H, W, C)``. See the module docstring for ``alpha`` and ``mask``.
    """
    if not isinstance(alpha, str) or alpha not in ALPHA_MODES:
        raise ParameterError(f"alpha = {alpha!r}: must be one of {', '.join(map(repr, ALPHA_MODES))}")
    h, w, c = exemplar.shape
    masked: np.ndarray | None = None
    source: list[str] = []
    has_alpha = c in (2, 4)
    if alpha == "mask" and not has_alpha:
        raise ParameterError(
            f"alpha = 'mask': the exemplar has {c} channel(s) and no alpha channel (grey + alpha or RGBA needed)"
        )
    if has_alpha and alpha != "colour":
        a = exemplar[..., -1]
        if alpha == "mask" or bool((a < 1.0).any()):
            masked = a < ALPHA_THRESHOLD
            exemplar = np.ascontiguousarray(exemplar[..., :-1])
            source.append("alpha")
    if mask is not None:
        m = _mask_array(mask, (h, w), "mask" if mask_file is None else f"mask {mask_file!r}")
        masked = m if masked is None else (masked | m)
        source.append(mask_source)
    if masked is None:
        return exemplar, None
    em = ExemplarMask(masked, "+".join(source), mask_file)
    if bool(masked.all()):
        what = "the alpha channel is below 0.5 everywhere" if source == ["alpha"] else "every pixel is masked"
        raise ParameterError(
            f"mask ({em.source}{', ' + mask_file if mask_file else ''}): {what} ({w}x{h} pixels), nothing is "
            "left to build from"
            + (" (use --alpha colour to match alpha as colour)" if "alpha" in source else "")
        )
    return exemplar, em


def build_mask(exemplar: np.ndarray, mask: Any, alpha: Any) -> tuple[np.ndarray, ExemplarMask | None]:
    """``mask=`` of a builder: None, an ``(H, W)`` array, an image / ``.npy`` path, or an :class:`ExemplarMask`;
    with ``alpha`` (:func:`resolve_mask`). Returns the exemplar to build from and the mask (None without)."""
    import os

    if isinstance(mask, ExemplarMask):
        ex, _ = resolve_mask(exemplar, None, "colour")
        if mask.masked.shape != exemplar.shape[:2]:
            raise ShapeError(f"mask has shape {mask.masked.shape}, the exemplar {exemplar.shape[:2]}")
        return ex, mask
    if isinstance(mask, (str, os.PathLike)):
        path = os.fspath(mask)
        return resolve_mask(
            exemplar, load_mask(path), alpha, mask_source="file", mask_file=os.path.basename(path)
        )
    return resolve_mask(exemplar, mask, alpha)


def active(mask: ExemplarMask | None) -> ExemplarMask | None:
    """The mask if it masks anything (an empty mask changes nothing in a build), else None."""
    return None if mask is None or mask.empty else mask


def masked_search(
    mask: ExemplarMask, exemplar: np.ndarray, templates: np.ndarray, size: int, features: bool = False
) -> tuple[np.ndarray, np.ndarray, float]:
    """The penalised exemplar and templates of a masked SSD search (:meth:`ExemplarMask.search_image`) and the
    factor 1/s² that turns its SSD values back into the exemplar's (exact: a power of two)."""
    scale = mask.search_scale(exemplar, size)
    search = mask.search_image(exemplar, size, features)
    return search, mask.templates(templates, scale), 1.0 / (scale * scale)


def valid_fallback(
    mask: ExemplarMask,
    chosen: np.ndarray,
    chosen_d: np.ndarray,
    search: np.ndarray,
    templates: np.ndarray,
    exclude: int,
    threads: int | None,
    unscale: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Matching offsets ``(U, V, 2)`` of a constrained assignment (the diversity lever) with every window that
    touches the mask replaced by the tile's V-th best valid window (the plain exact search), then checked."""
    from ..base import kernels

    n = templates.shape[1]
    ok = mask.windows_ok(chosen, n)
    if ok.all():
        return chosen, chosen_d
    nv = chosen.shape[1]
    index = kernels.SsdIndex(search, threads, features=True)
    plain, ssd = index.best_matches(templates, k=nv, exclude_radius=exclude, threads=threads)
    chosen, chosen_d = chosen.copy(), chosen_d.copy()
    chosen[~ok] = plain[~ok]
    if plain.shape[1] < nv:
        raise mask.too_small(n, nv, "matching patches of every tile", n)
    chosen_d[~ok] = ssd[~ok] * unscale
    mask.check_windows(chosen, n, "matching patches", n)
    return chosen, chosen_d
