"""The kernels of the Wang builders: Cohen et al.'s tiles with 001's match and the strict Wang tiles' cuts, and the
evaluator of Wang sample populations (re-exported by :mod:`tilesynth.base.kernels`)."""

from __future__ import annotations

import numpy as np

from .. import _core
from ..errors import ParameterError
from .kernel_args import DEFAULT_EPS, _grad, _int_array, _templates
from .validate import (
    as_image,
    finite_float,
    positive_int,
    threads_arg,
)


def _wang_args(tile_size: int, overlap: int, corners: str, samples: str, cut: str, omega: float) -> tuple:
    tile_size = positive_int(tile_size, "tile_size")
    overlap = positive_int(overlap, "overlap", minimum=0)
    for name, value in (("corners", corners), ("samples", samples), ("cut", cut)):
        if not isinstance(value, str):
            raise ParameterError(f"{name} = {value!r}: must be a string")
    if isinstance(omega, (bool, np.bool_)) or not isinstance(omega, (int, float, np.integer, np.floating)):
        raise ParameterError(f"omega = {omega!r}: must be a number in [0, 1]")
    return tile_size, overlap, corners, samples, cut, float(omega)


def wang_tiles(
    exemplar: np.ndarray,
    genes: np.ndarray,
    tile_samples: np.ndarray,
    tile_size: int,
    overlap: int,
    corners: str = "free",
    samples: str = "diamond",
    cut: str = "dp",
    omega: float = _core.DEFAULT_OMEGA,
    eps: float = DEFAULT_EPS,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The cuts of Wang tiles (Cohen / Burke; geometry in :mod:`tilesynth.builder.wang`).

    ``genes`` ``(n, 2)``: top-left corners of the sample squares (side ``tile_size + overlap`` for free-corner
    diamonds, ``tile_size`` otherwise); ``tile_samples`` ``(K, 4)``: gene index of every tile's N, E, S, W
    sample. Returns uint8 labels ``(K, N, N)`` (0 N, 1 E, 2 S, 3 W: the sample each pixel takes) and float64
    ``(K, 4, 6)``: for the cuts NE, ES, SW, WN ``[D_overlap, n_overlap, D_path, n_path, D_boundary, cost]``.
    """
    args = _wang_args(tile_size, overlap, corners, samples, cut, omega)
    return _core.wang_tiles(
        as_image(exemplar, "exemplar"),
        _int_array(genes, "genes", 2, "(n, 2)"),
        _int_array(tile_samples, "tile_samples", 2, "(K, 4)"),
        *args,
        finite_float(eps, "eps", positive=True),
        threads_arg(threads),
    )


class WangEvaluator:
    """001's objective for whole populations of Wang gene vectors, in Rust, parallel, thread-count independent.

    For each individual (``n_samples`` top-left corners of sample squares), every distinct cut of the tile set
    is solved (DP or graph cut, see :mod:`tilesynth.builder.wang`) and

    - D_boundary = ω·D_overlap/n_overlap + C(1−ω)·D_path/n_path (C channels; 3 for RGB);
    - D_sum of a tile = the sum of its four D_boundary (NE, ES, SW, WN, in that order);
    - E = ω·Σ D_sum + (1−ω)·Var(D_sum), population variance.

    Exact (no approximation beyond float64 rounding, in a fixed order); positions need not be distinct.
    """

    def __init__(
        self,
        exemplar: np.ndarray,
        tile_samples: np.ndarray,
        n_samples: int,
        tile_size: int,
        overlap: int,
        corners: str = "free",
        samples: str = "diamond",
        cut: str = "dp",
        omega: float = _core.DEFAULT_OMEGA,
        eps: float = DEFAULT_EPS,
    ) -> None:
        self.exemplar = as_image(exemplar, "exemplar")
        self.tile_samples = _int_array(tile_samples, "tile_samples", 2, "(K, 4)")
        n_samples = positive_int(n_samples, "n_samples")
        args = _wang_args(tile_size, overlap, corners, samples, cut, omega)
        self.omega = args[-1]
        eps = finite_float(eps, "eps", positive=True)
        self._ev = _core.WangEvaluator(self.exemplar, self.tile_samples, n_samples, *args, eps)
        self.sample_size, self.n_samples, self.n_tiles = self._ev.dims
        self._init_args = (
            self.exemplar,
            self.tile_samples,
            n_samples,
            tile_size,
            overlap,
            corners,
            samples,
            cut,
            omega,
            eps,
        )

    def __reduce__(self):  # noqa: ANN204 - pickles by rebuilding from its inputs (process pools)
        return (type(self), self._init_args)

    def evaluate(self, genes: np.ndarray, threads: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """E ``(P,)`` and D_sum ``(P, m)`` of ``genes`` ``(P, n_samples, 2)``."""
        g = _int_array(genes, "genes", 3, f"(P, {self.n_samples}, 2)")
        return self._ev.evaluate(g, threads_arg(threads))


def swang_cuts(
    initial: np.ndarray,
    supplementary: np.ndarray,
    eps: float = DEFAULT_EPS,
    threads: int | None = None,
    initial_grad: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """004's closed cuts for a stack of initial tiles and their supplementary patches, ``(K, N, N, C)`` each.

    Kwatra weights (:func:`kwatra_weights`, ``initial_grad`` ``(K, N, N, 2)`` optionally replacing the initial
    tiles' gradients), the one-pixel border ring tied to the initial tile, both diagonals (corner pixels
    excepted) to the supplementary patch, min-cut by :func:`grid_mincut`'s solver. Returns bool masks
    ``(K, N, N)`` (True = the pixel takes the supplementary patch) and float64 cut costs.
    """
    i, _ = _templates(initial, "initial")
    o, _ = _templates(supplementary, "supplementary")
    eps = finite_float(eps, "eps", positive=True)
    return _core.swang_cuts(
        i, o, eps, threads_arg(threads), _grad(initial_grad, "initial_grad", 4, "(K, N, N, 2)")
    )
