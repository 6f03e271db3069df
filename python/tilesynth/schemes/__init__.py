"""The tile schemes, registered in one list (:data:`REGISTRY`); :func:`build` builds any of them.

=========  ===========================================  ==================================================
scheme     builder                                      tile sets (``tileset=``)
=========  ===========================================  ==================================================
"omega"    :func:`tilesynth.builder.omega.build_omega`          corner sets: 4, 8, 16a, 16b, 32, B, n1, n2, nK
"wang"     :func:`tilesynth.builder.wang.build_wang`            edge sets: wang8, wang18, wang<2k²>
"swang"    :func:`tilesynth.builder.swang.build_swang`          edge sets: wang8 (004), wang18, ...
"patch"    :func:`tilesynth.schemes.patch.build_patch`  corner sets (a random-crop baseline)
=========  ===========================================  ==================================================

Every builder returns a :class:`~tilesynth.tileset.tilefile.TileSet`; :func:`tilesynth.synthesize`, the file format
and the command line serve all of them alike.

**Adding a square-grid scheme** is a module here defining a :class:`~tilesynth.schemes.base.Scheme` (name,
layout "corner" or "edge", default set, its options with their CLI flags, the builder, how ``info`` describes
its sets) and one line in :data:`REGISTRY`; the command line's ``build`` flags, ``--scheme`` choices, the
option checks and ``info`` follow from the registry. :mod:`tilesynth.schemes.patch` is the smallest example.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError
from ..tileset.tilefile import TileSet
from . import omega, patch, swang, wang
from .base import Option, Scheme

__all__ = ["DEFAULT_SETS", "REGISTRY", "SCHEMES", "Option", "Scheme", "build", "build_material", "get_scheme"]

#: Every scheme, in the order the command line lists them. A new scheme is one line here.
REGISTRY: tuple[Scheme, ...] = (omega.SCHEME, wang.SCHEME, swang.SCHEME, patch.SCHEME)

#: The names of the schemes :func:`build` knows.
SCHEMES: tuple[str, ...] = tuple(s.name for s in REGISTRY)

#: The default tile set of each scheme.
DEFAULT_SETS: dict[str, str] = {s.name: s.default_set for s in REGISTRY}


def get_scheme(name: Any) -> Scheme:
    """The registered scheme called ``name``.

    Raises
    ------
    ParameterError
        If no scheme has that name.
    """
    for s in REGISTRY:
        if s.name == name:
            return s
    raise ParameterError(f"scheme = {name!r}: must be one of {', '.join(SCHEMES)}")


def build(exemplar: np.ndarray, scheme: str = "omega", *, maps: Any = None, **kwargs: Any) -> TileSet:
    """Build a tile set of ``scheme`` from ``exemplar``; ``kwargs`` go to the scheme's builder.

    ``maps={name: array}`` (with optional ``map_kinds``, ``map_weights``, ``normal_y``) makes a material build:
    matching and cuts on the exemplar and every map jointly, every map stored in the set
    (:func:`tilesynth.builder.materials.build_material`).

    Raises
    ------
    ParameterError
        If ``scheme`` is unknown (and whatever the builder raises for its parameters).
    """
    if maps is not None or any(k in kwargs for k in ("map_kinds", "map_weights", "normal_y")):
        return build_material(
            exemplar, scheme=scheme, maps=maps, **kwargs
        )  # the maps are cut with the colour
    return get_scheme(scheme).build(exemplar, **kwargs)


def build_material(
    exemplar: np.ndarray,
    scheme: str = "omega",
    *,
    maps: Any,
    map_kinds: Any = None,
    map_weights: Any = None,
    normal_y: str = "up",
    map_suffixes: dict[str, str] | None = None,
    **kwargs: Any,
) -> TileSet:
    """Build a tile set of ``scheme`` from ``exemplar`` (the albedo) and its pixel-aligned ``maps``, matched and
    cut jointly (the method, the kinds and the defaults: :mod:`tilesynth.builder.materials`); ``kwargs`` go to
    the scheme's builder. :func:`build` with ``maps=`` calls it.

    Parameters
    ----------
    exemplar : the albedo, as for every builder.
    maps : ``{name: (H, W[, C]) uint8 | uint16 | float array}``, each pixel-aligned with the exemplar.
    map_kinds : ``{name: kind}`` overriding the kind inferred from the name (colour, scalar, normal, label).
    map_weights : ``{name: weight >= 0}`` (``"albedo"`` too) overriding the defaults (1; labels 0).
    normal_y : "up" (OpenGL, default) or "down" (DirectX): the Y convention of the input normal maps.
    map_suffixes : the file suffix of each map (".png", ".exr", ".npy"), recorded to name the outputs alike.
    """
    from ..builder.materials import build_with_maps

    sc = get_scheme(scheme)
    return build_with_maps(
        sc.build, exemplar, maps=maps, map_kinds=map_kinds, map_weights=map_weights, normal_y=normal_y,
        map_suffixes=map_suffixes, material_options=sc.material_options, **kwargs,
    )  # fmt: skip
