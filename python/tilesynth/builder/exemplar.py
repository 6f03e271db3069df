"""The exemplar of a build, validated and converted once, with the derived layers its stages share.

A build used to hand the caller's array to every stage, and each stage checked and converted it again
(:func:`tilesynth.base.validate.as_image`: eight scans of a default ``c5`` build) and derived its own
luminance and detail layer from it (three luminances, two detail layers). :class:`Exemplar` is made once at the
entry of a build (:func:`tilesynth.builder.options.common_options`):

* :attr:`Exemplar.image`: C-contiguous float32 ``(H, W, C)`` in [0, 1], never aliasing the caller's array,
  without the alpha channel when alpha is read as a mask;
* :attr:`Exemplar.mask`: the :class:`~tilesynth.builder.masking.ExemplarMask` (None without one);
* :attr:`Exemplar.info`: what the caller recorded about the input (file name, bit depth), and
  :attr:`Exemplar.bit_depth` from it;
* :attr:`Exemplar.maps`: a material's maps, checked once (:func:`tilesynth.builder.materials_inputs.check_maps`:
  pixel-aligned, kinds, weights, normal encodings), with :attr:`Exemplar.albedo_weight`; None for a colour build;
* the derived layers, computed on first use and kept: :attr:`Exemplar.luminance`, :attr:`Exemplar.detail`
  (:func:`tilesynth.measure.metrics.detail_layer`), :meth:`Exemplar.saliency` (the discs' saliency of one
  radius), :meth:`Exemplar.period` (the periodic exemplar rule at one default tile size) and, for a material,
  :meth:`Exemplar.features` (the feature image a joint build searches).

Inside :meth:`Exemplar.validated` the stages, kernels and measures that are handed :attr:`Exemplar.image` take it
as it is instead of checking it again (:func:`tilesynth.base.validate.validated_image`); the builders run their
stages inside it.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from ..base.validate import as_image, validated_image
from ..errors import ParameterError
from ..layouts.tile_size import check_exemplar_size
from ..measure import metrics
from .masking import ExemplarMask, build_mask
from .materials_inputs import FEATURE_CHANNELS, MapSpec, _weight, check_maps, feature_image
from .periodic import periodic_tile_size

__all__ = ["Exemplar"]


class Exemplar:
    """The validated exemplar of one build and its derived layers (see the module docstring). Make one with
    :meth:`of`; builders accept it in place of an array."""

    __slots__ = ("__dict__", "albedo_weight", "image", "info", "maps", "mask")

    image: np.ndarray
    mask: ExemplarMask | None
    info: dict[str, Any] | None
    maps: list[tuple[MapSpec, np.ndarray]] | None
    albedo_weight: float

    def __init__(
        self,
        image: np.ndarray,
        mask: ExemplarMask | None,
        info: dict[str, Any] | None,
        maps: list[tuple[MapSpec, np.ndarray]] | None = None,
        albedo_weight: float = 1.0,
    ) -> None:
        self.image, self.mask, self.info = image, mask, info
        self.maps, self.albedo_weight = maps, albedo_weight

    @classmethod
    def of(
        cls,
        exemplar: Any,
        *,
        mask: Any = None,
        alpha: Any = "auto",
        info: Any = None,
        maps: Any = None,
        map_kinds: Any = None,
        map_weights: Any = None,
        normal_y: Any = "up",
        map_suffixes: dict[str, str] | None = None,
    ) -> Exemplar:
        """Validate and convert ``exemplar`` (an image array, see :func:`~tilesynth.base.validate.as_image`)
        with its ``mask`` / ``alpha`` (:func:`tilesynth.builder.masking.build_mask`) and ``info`` (a dict or
        None); with ``maps`` (a dict ``{name: array}``), a material: the maps, their kinds and weights (the
        albedo's as ``map_weights["albedo"]``), ``normal_y`` and the output suffixes are checked here, before any
        work (:func:`tilesynth.builder.materials_inputs.check_maps`). An :class:`Exemplar` given with no other
        argument is returned as it is."""
        if isinstance(exemplar, Exemplar):
            if mask is not None or alpha != "auto" or info is not None or maps is not None:
                raise ParameterError(
                    "exemplar: an Exemplar carries its own mask, alpha, info and maps; pass them to Exemplar.of"
                )
            return exemplar
        if info is not None and not isinstance(info, dict):
            raise ParameterError(f"exemplar_info = {info!r}: must be a dict or None")
        ex = as_image(exemplar, "exemplar")
        if np.may_share_memory(ex, exemplar):
            ex = ex.copy()  # the tile set keeps the exemplar: never alias the caller's array
        check_exemplar_size(ex.shape)
        ex, exemplar_mask = build_mask(ex, mask, alpha)
        if maps is None:
            return cls(ex, exemplar_mask, info)
        specs = check_maps(ex.shape, maps, map_kinds, map_weights, normal_y, map_suffixes)
        albedo_weight = _weight((map_weights or {}).get("albedo", 1.0), "albedo")
        return cls(ex, exemplar_mask, info, specs, albedo_weight)

    @property
    def shape(self) -> tuple[int, int, int]:
        h, w, c = self.image.shape
        return h, w, c

    @property
    def bit_depth(self) -> int | None:
        """The input's bit depth when the caller recorded it (``info["bit_depth"]``), else None."""
        bits = (self.info or {}).get("bit_depth")
        return int(bits) if isinstance(bits, (int, np.integer)) else None

    @contextmanager
    def validated(self) -> Iterator[Exemplar]:
        """The block in which :attr:`image` is not checked again (:func:`~tilesynth.base.validate.validated_image`)."""
        with validated_image(self.image):
            yield self

    @functools.cached_property
    def luminance(self) -> np.ndarray:
        """``(H, W)`` float64 luminance (:func:`tilesynth.measure.metrics.luminance`)."""
        return metrics.luminance(self.image)

    @functools.cached_property
    def detail(self) -> np.ndarray:
        """``(H, W)`` float64 detail layer: the luminance minus its Gaussian blur at σ =
        :data:`~tilesynth.measure.metrics.DETAIL_SIGMA` (:func:`tilesynth.measure.metrics.detail_layer`)."""
        y = self.luminance
        return y - metrics._gaussian_blur(y, metrics.DETAIL_SIGMA)

    def saliency(self, radius: int) -> metrics.DiscSaliency:
        """The saliency of the exemplar's discs of ``radius`` (:class:`tilesynth.measure.metrics.DiscSaliency`),
        made once per radius from the cached luminance and detail layer."""
        cache = self.__dict__.setdefault("_saliency", {})
        if radius not in cache:
            cache[radius] = metrics.DiscSaliency(
                self.image, radius, luminance=self.luminance, detail=self.detail
            )
        return cache[radius]

    def period(self, default_tile_size: int) -> tuple[int, float] | None:
        """The periodic exemplar rule at ``default_tile_size``
        (:func:`tilesynth.builder.periodic.periodic_tile_size`, on the cached detail layer), made once."""
        cache = self.__dict__.setdefault("_period", {})
        if default_tile_size not in cache:
            cache[default_tile_size] = periodic_tile_size(self.image, default_tile_size, detail=self.detail)
        return cache[default_tile_size]

    @property
    def joint(self) -> bool:
        """A material whose maps take part in the search (a map of weight > 0, or an albedo weight other
        than 1): the build then runs on :meth:`features`."""
        return bool(self.maps) and (
            self.albedo_weight != 1.0 or any(s.weight > 0 for s, _ in self.maps or ())
        )

    def features(self) -> tuple[np.ndarray, dict[str, Any]]:
        """A material's feature image, float32 ``(H, W, k)`` in [0, 1], and its record
        (:func:`tilesynth.builder.materials_inputs.feature_image`), made once. ``k`` <= 4 channels, one fewer
        with a mask: the masked search adds a penalty channel and the image index takes at most four."""
        if not self.maps:
            raise ParameterError("exemplar: features() needs a material (Exemplar.of(..., maps=...))")
        if "_features" not in self.__dict__:
            k = FEATURE_CHANNELS - (self.mask is not None)
            feats, record = feature_image(self.image, self.maps, self.albedo_weight, channels=k)
            self.__dict__["_features"] = (np.ascontiguousarray(feats, dtype=np.float32), record)
        feats, record = self.__dict__["_features"]
        return feats, dict(record)

    def __repr__(self) -> str:
        h, w, c = self.shape
        where = os.path.basename(str((self.info or {}).get("file", ""))) or "array"
        mask = "" if self.mask is None else f", mask {self.mask.fraction:.1%}"
        maps = "" if not self.maps else ", maps " + "+".join(spec.name for spec, _ in self.maps)
        return f"Exemplar({where}, {w}x{h}x{c}{mask}{maps})"
