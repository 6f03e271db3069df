"""Options that several schemes share (one definition each, referenced by every scheme that uses it)."""

from __future__ import annotations

from .base import Option, positive_int_text

GRADIENTS = Option(
    "gradients",
    "--gradients",
    "gradients in the seam weight: of the sample patches (default) or of the assembled tile (the literal "
    "formula; cuts tend to hug the seams of the assembled tile)",
    choices=("patch", "tile"),
)

LITERAL_BORDER = Option(
    "keep_border",
    "--literal-border",
    "the paper's literal cut: let the matching patch reach the tile border near the side midpoints (default: the "
    "border ring keeps the intermediate tile, so neighbouring tiles stay continuous)",
    store_true=True,
    flag_value=lambda literal: not literal,
)

CORNER_BORDER_TRIES = Option(
    "border_tries",
    "--border-tries",
    "random sample sets drawn, the one whose tile borders fall best kept (Wang schemes: on the quietest exemplar "
    "lines; omega and patch: predicted border seam closest to 0.8, at most 1); default 32; 1: a single random draw",
    cli_type=positive_int_text,
)
"""``border_tries`` of the corner schemes (ω and its patch baseline draw the same sample patches). The CLI shows
one help text for a flag that several schemes share (the first registered scheme's, ω's), so this one also says
what the Wang schemes do with it."""
