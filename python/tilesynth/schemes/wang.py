"""The Wang scheme (Cohen et al. 2003 with 001's match; Burke's square variant): :func:`tilesynth.build_wang`."""

from __future__ import annotations

from typing import Any

from ..builder.wang import build_wang
from .base import Option, Scheme, positive_int_text


def _describe(ts: Any) -> list[str]:
    p = ts.params
    line = (
        f"E             {ts.E:.6g}  (ω={p.get('omega')}: ω·ΣD_sum + (1−ω)·Var D_sum, 001; "
        f"{p.get('samples')} samples, overlap {p.get('overlap')}, {p.get('corners')} corners, {p.get('cut')} cuts)"
    )
    return [line]


SCHEME = Scheme(
    name="wang",
    title="Wang tiles",
    summary="Wang tiles (Cohen et al.), each diamond the best match of its neighbours",
    layout="edge",
    default_set="wang8",
    builder=build_wang,
    options=(
        Option(
            "cut",
            "--cut",
            "minimum-error boundary cuts by dynamic programming (default) or graph cuts",
            choices=("dp", "graph"),
        ),
        Option(
            "overlap",
            "--overlap",
            "width of the overlap band of two diamonds, even (default N/4)",
            cli_type=positive_int_text,
        ),
        Option(
            "corners",
            "--corners",
            "pinned (default: the cut ends at the corner, edges match exactly) or free (Cohen's literal "
            "construction: the cut may miss the corner, visible seams near the tile corners)",
            choices=("free", "pinned"),
        ),
        Option(
            "border_tries",
            "--border-tries",
            "random sample sets drawn, the one whose tile borders fall on the quietest exemplar lines kept "
            "(default 32; 1: a single random draw, with --corners free Cohen's literal construction)",
            cli_type=positive_int_text,
        ),
        Option(
            "samples",
            "--samples",
            "diamond samples (Cohen, default) or N x N square samples (Burke)",
            choices=("diamond", "square"),
        ),
    ),
    describe=_describe,
)
