"""The strict Wang scheme (Zhang and Kim, 004): :func:`tilesynth.build_swang`."""

from __future__ import annotations

from typing import Any

from ..builder.materials import MATERIAL_CUT_EPS
from ..builder.swang import build_swang
from .base import Option, Scheme, lambda_energy_line, positive_int_text
from .common import GRADIENTS


def _describe(ts: Any) -> list[str]:
    return [lambda_energy_line(ts.params, ts.E, "initial tiles")]


SCHEME = Scheme(
    name="swang",
    title="s-Wang tiles",
    summary="strict Wang tiles (Zhang and Kim)",
    layout="edge",
    default_set="wang8",
    builder=build_swang,
    options=(
        GRADIENTS,
        Option(
            "supplementary",
            "--supplementary",
            "the supplementary patch with the smallest SSD to the initial "
            "tile (default), or the one with the cheapest closed cut among the 8 best SSD candidates",
            choices=("ssd", "cut"),
        ),
        Option(
            "border_tries",
            "--border-tries",
            "random sample sets drawn, the one whose tile borders fall on the quietest exemplar lines kept "
            "(default 32; 1: a single random draw)",
            cli_type=positive_int_text,
        ),
    ),
    describe=_describe,
    # joint material builds cut with a capped gradient normalisation (materials.MATERIAL_CUT_EPS)
    material_options={"eps": MATERIAL_CUT_EPS},
)
