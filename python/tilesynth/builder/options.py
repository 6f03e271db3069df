"""The options every builder takes, validated once at the entry of a build (:func:`common_options`).

A builder calls :func:`common_options` first and works only with the resulting :class:`BuildOptions`: the
exemplar as float32, the tile-set definition, the tile size, the random generator, the thread count and the
progress callback are checked there, once, before any work (``threads`` is not re-checked at every stage; the
kernels still check what they are given, as public functions must).

**Seeds** (numpy SPEC 7, :func:`resolve_seed`): ``seed`` may be an int, a :class:`numpy.random.SeedSequence`, a
:class:`numpy.random.Generator` or None.

* an int ``s`` gives exactly the result it always gave (``numpy.random.default_rng(s)``), and is recorded;
* a SeedSequence gives the same result as the int of the same entropy (``SeedSequence(s)`` and ``s`` are the
  same stream); its entropy is recorded (with its spawn key when it has one, as ``{"entropy", "spawn_key"}``);
* a Generator is used as it is (and advanced); its state is not a seed, so ``params["seed"]`` is None and the
  build cannot be repeated from the file alone: pass an int or a SeedSequence for that;
* None draws a fresh int seed from the OS and records it, so the build can be repeated.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..base.validate import seed_int, threads_arg
from ..errors import ParameterError
from ..layouts.tile_size import check_tile_size, default_tile_size
from .exemplar import Exemplar

__all__ = ["BuildOptions", "Progress", "SeedLike", "common_options", "resolve_seed"]

Progress = Callable[[str, int, int], None]
"""Progress callback: (stage, done, total)."""

SeedLike = int | np.integer | np.random.SeedSequence | np.random.Generator | None


def resolve_seed(seed: Any) -> tuple[Any, np.random.Generator]:
    """``(recorded seed, generator)`` of a SPEC 7 seed (see the module docstring)."""
    if isinstance(seed, np.random.Generator):
        return None, seed
    if isinstance(seed, np.random.SeedSequence):
        entropy = seed.entropy
        recorded: Any = int(entropy) if isinstance(entropy, (int, np.integer)) else [int(v) for v in entropy]
        if seed.spawn_key:
            recorded = {"entropy": recorded, "spawn_key": [int(v) for v in seed.spawn_key]}
        return recorded, np.random.default_rng(seed)
    if isinstance(seed, np.random.BitGenerator):
        raise ParameterError(
            f"seed = {seed!r}: pass a numpy Generator (numpy.random.Generator(bit_generator)), a SeedSequence, "
            "a non-negative integer or None"
        )
    s = seed_int(seed)
    return s, np.random.default_rng(s)


@dataclass(frozen=True)
class BuildOptions:
    """What every build has, validated (:func:`common_options`)."""

    exemplar: np.ndarray
    """float32 ``(H, W, C)``, never aliasing the caller's array."""
    definition: Any
    """The tile-set definition (:class:`~tilesynth.layouts.omega_sets.CornerTileSet` or :class:`~tilesynth.layouts.wang_sets.WangTileSet`)."""
    tile_size: int
    seed: Any
    """The recorded seed (:func:`resolve_seed`)."""
    rng: np.random.Generator
    threads: int | None
    progress: Progress
    exemplar_info: dict[str, Any] | None
    started: float
    """:func:`time.perf_counter` at the entry (the build's ``total_s`` counts from here)."""
    mask: Any = None
    """The exemplar's :class:`~tilesynth.builder.masking.ExemplarMask`, None without one."""
    source: Exemplar | None = None
    """The validated exemplar with its cached derived layers (:attr:`exemplar` is its image)."""

    def report(self, stage: str, done: int, total: int) -> None:
        self.progress(stage, done, total)


def _no_progress(stage: str, done: int, total: int) -> None:
    return None


def common_options(
    exemplar: Any,
    *,
    tileset: Any,
    resolve_set: Callable[[Any], Any],
    tile_size: Any = None,
    seed: Any = None,
    threads: Any = None,
    progress: Any = None,
    exemplar_info: Any = None,
    started: float | None = None,
    mask: Any = None,
    alpha: Any = "auto",
) -> BuildOptions:
    """Validate the options every builder takes; ``resolve_set`` turns ``tileset`` into its definition.

    ``exemplar``: an image array or an :class:`~tilesynth.builder.exemplar.Exemplar` (validated once, here:
    :meth:`~tilesynth.builder.exemplar.Exemplar.of`). ``mask`` / ``alpha``: the exemplar's mask
    (:func:`tilesynth.builder.masking.build_mask`); the exemplar loses its alpha channel when that is read as a
    mask."""
    t0 = time.perf_counter() if started is None else started
    source = Exemplar.of(exemplar, mask=mask, alpha=alpha)
    ex, exemplar_mask = source.image, source.mask
    defn = resolve_set(tileset)
    n = default_tile_size(ex.shape) if tile_size is None else check_tile_size(tile_size, ex.shape)
    if tile_size is None and exemplar_mask is not None:
        n = exemplar_mask.default_tile_size(n)
    recorded, rng = resolve_seed(seed)
    threads = threads_arg(threads)
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress = {progress!r}: must be a callable (stage, done, total) or None")
    if exemplar_info is not None and not isinstance(exemplar_info, dict):
        raise ParameterError(f"exemplar_info = {exemplar_info!r}: must be a dict or None")
    if exemplar_info is not None:
        source = Exemplar(source.image, source.mask, exemplar_info)
    return BuildOptions(
        ex, defn, n, recorded, rng, threads, progress or _no_progress, source.info, t0, exemplar_mask, source
    )
