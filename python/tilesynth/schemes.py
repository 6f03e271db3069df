"""One entry point for every tile scheme: :func:`build` dispatches to the scheme's builder.

=========  ===========================================  ==================================================
scheme     builder                                      tile sets (``tileset=``)
=========  ===========================================  ==================================================
"omega"    :func:`tilesynth.omega.build_omega`          corner sets: 4, 8, 16a, 16b, 32, B, n1, n2, nK
"wang"     :func:`tilesynth.wang.build_wang`            edge sets: wang8, wang18, wang<2k²>
"swang"    :func:`tilesynth.wang.build_swang`           edge sets: wang8 (004), wang18, ...
=========  ===========================================  ==================================================

Every builder returns a :class:`~tilesynth.tilefile.TileSet`; :func:`tilesynth.synthesize`, the file format
and the command line serve all of them alike.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import ParameterError
from .tilefile import TileSet

__all__ = ["SCHEMES", "DEFAULT_SETS", "build"]

#: The schemes :func:`build` knows.
SCHEMES: tuple[str, ...] = ("omega", "wang", "swang")

#: The default tile set of each scheme.
DEFAULT_SETS: dict[str, str] = {"omega": "16a", "wang": "wang8", "swang": "wang8"}


def build(exemplar: np.ndarray, scheme: str = "omega", **kwargs: Any) -> TileSet:
    """Build a tile set of ``scheme`` from ``exemplar``; ``kwargs`` go to the scheme's builder.

    Raises
    ------
    ParameterError
        If ``scheme`` is unknown (and whatever the builder raises for its parameters).
    """
    from ._budget import check_build_memory

    check_build_memory(exemplar, scheme, kwargs)  # refused up front with the figure (issue 16)
    if scheme == "omega":
        from .omega import build_omega

        return build_omega(exemplar, **kwargs)
    if scheme == "wang":
        from .wang import build_wang

        return build_wang(exemplar, **kwargs)
    if scheme == "swang":
        from .wang import build_swang

        return build_swang(exemplar, **kwargs)
    raise ParameterError(f"scheme = {scheme!r}: must be one of {', '.join(SCHEMES)}")
