"""What a tile scheme is: a small registered object (:class:`Scheme`) with its options (:class:`Option`).

The command line, :func:`tilesynth.build` and ``tilesynth info`` ask the registry
(:data:`tilesynth.schemes.REGISTRY`) instead of comparing scheme names: the CLI's ``build`` flags are generated
from the registered schemes' options, an option given for a scheme that does not declare it is refused, and
each scheme says how its tile sets read (:attr:`Scheme.describe`).
"""

from __future__ import annotations

import argparse
import inspect
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from ..base.budget import check_build_memory
from ..cli.argtypes import parse_int
from ..errors import ParameterError
from ..layouts.complete import default_complete_tile_size
from ..layouts.hashed import lookup_scheme
from ..layouts.omega_sets import get_tileset
from ..layouts.wang_sets import get_wang_tileset, is_wang_set_name

if TYPE_CHECKING:
    import numpy as np

    from ..tileset.tilefile import TileSet

__all__ = [
    "LAYOUT_KINDS",
    "Option",
    "Scheme",
    "lambda_energy_line",
    "layout_kind",
    "layout_of_set",
    "nonneg_int_text",
    "positive_int_text",
]

#: The two square-grid layouts: tiles keyed by corner colours ⟨TL, BL, TR, BR⟩, or by edge colours ⟨N, E, S, W⟩.
LAYOUT_KINDS: tuple[str, ...] = ("corner", "edge")

#: The ``kind`` a layout has in the tile-set file (the format predates the names "edge" and keeps "wang").
FILE_KIND = {"corner": "corner", "edge": "wang"}


def layout_kind(layout: dict[str, Any]) -> str:
    """ "corner" or "edge": the layout kind of a tile-set file's ``layout`` (its ``kind``, "corner" if absent)."""
    return "edge" if layout.get("kind", "corner") == FILE_KIND["edge"] else "corner"


def nonneg_int_text(text: str) -> int:
    """argparse type: an integer >= 0 (ASCII digits, :mod:`tilesynth.cli.argtypes`)."""
    return parse_int(text, 0)


def positive_int_text(text: str) -> int:
    """argparse type: an integer >= 1 (ASCII digits, :mod:`tilesynth.cli.argtypes`)."""
    return parse_int(text, 1)


def layout_of_set(name: str) -> str:
    """``"edge"`` for an edge-coloured set name (wang8, wang18, wang<2k²>), else ``"corner"``."""
    return "edge" if is_wang_set_name(name) else "corner"


@dataclass(frozen=True)
class Option:
    """One scheme option: the builder keyword, its command-line flag, type, choices and help.

    ``cli_type`` converts the flag's text (argparse ``type``); ``flag_value`` turns the parsed value into the
    builder's value (for example ``--literal-border`` -> ``keep_border=False``). ``store_true`` options are
    flags without a value. The CLI default is the builder's own default (read from its signature), so the two
    cannot drift; an option counts as *given* when its parsed value differs from that default.
    """

    name: str
    flag: str
    help: str
    cli_type: Callable[[str], Any] | None = None
    choices: tuple[Any, ...] | None = None
    store_true: bool = False
    metavar: str | None = None
    flag_value: Callable[[Any], Any] | None = None

    @property
    def dest(self) -> str:
        return self.flag.lstrip("-").replace("-", "_")

    def add_to(self, parser: argparse.ArgumentParser, default: Any, schemes: list[str]) -> None:
        """Add the flag (its help prefixed with the schemes that use it)."""
        text = f"{' / '.join(schemes)}: {self.help}"
        if self.store_true:
            parser.add_argument(self.flag, action="store_true", help=text)
            return
        kwargs: dict[str, Any] = {"default": default, "help": text}
        if self.cli_type is not None:
            kwargs["type"] = self.cli_type
        if self.choices is not None:
            kwargs["choices"] = self.choices
        if self.metavar is not None:
            kwargs["metavar"] = self.metavar
        parser.add_argument(self.flag, **kwargs)

    def given(self, value: Any, default: Any) -> bool:
        """Whether the parsed ``value`` was given on the command line (differs from the absent flag's value)."""
        return value is True if self.store_true else value != default

    def to_builder(self, value: Any) -> Any:
        """The builder's value for the parsed ``value``."""
        return self.flag_value(value) if self.flag_value is not None else value

    def same_flag(self, other: Option) -> bool:
        """Two schemes may share a flag only with the same meaning on the command line."""
        return (self.flag, self.cli_type, self.choices, self.store_true, self.flag_value) == (
            other.flag, other.cli_type, other.choices, other.store_true, other.flag_value,
        )  # fmt: skip


@dataclass(frozen=True)
class Scheme:
    """A tile scheme, registered once in :data:`tilesynth.schemes.REGISTRY`.

    Attributes
    ----------
    name : the ``scheme`` of the tile sets it builds (``--scheme`` on the command line).
    title : what its tiles are called ("ω-tiles").
    summary : one line for ``--scheme`` help.
    layout : "corner" or "edge" (the tile-set definitions it accepts, :func:`layout_of_set`).
    default_set : the tile set built when none is named.
    builder : the public builder, ``builder(exemplar, *, tileset=..., tile_size=..., seed=..., threads=...,
        progress=..., exemplar_info=..., select=..., polish=..., generations=..., population=..., **options)``.
    options : the scheme's own options (beyond those every builder takes).
    describe : ``info``'s lines about a tile set of this scheme (its matching, its objective E).
    selects : whether the scheme has an objective to select genes by (``--select`` other than random).
    material_options : builder options that a *joint* material build (:func:`tilesynth.builder.materials.build_with_maps`:
        maps of weight > 0, cut on the feature image) uses unless the caller gives them; a colour-only build
        never sees them (ω, s-Wang: the cut's ``eps``, :data:`tilesynth.builder.materials.MATERIAL_CUT_EPS`).
    """

    name: str
    title: str
    summary: str
    layout: Literal["corner", "edge"]
    default_set: str
    builder: Callable[..., TileSet]
    options: tuple[Option, ...] = ()
    describe: Callable[[TileSet], list[str]] | None = None
    selects: bool = True
    extra: dict[str, Any] = field(default_factory=dict)
    material_options: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.layout not in LAYOUT_KINDS:
            raise ValueError(f"scheme {self.name!r}: layout {self.layout!r} is not one of {LAYOUT_KINDS}")
        sig = inspect.signature(self.builder).parameters
        for opt in self.options:
            if opt.name not in sig or sig[opt.name].kind is not inspect.Parameter.KEYWORD_ONLY:
                raise ValueError(
                    f"scheme {self.name!r}: option {opt.name!r} is not a keyword-only builder option"
                )

    @property
    def file_kind(self) -> str:
        """The ``layout["kind"]`` of its tile-set files."""
        return FILE_KIND[self.layout]

    def default(self, option: Option) -> Any:
        """The parsed value of ``option``'s flag when absent: False for flags without a value, else the builder's
        default (read from its signature, so the CLI and the API cannot drift apart)."""
        if option.store_true:
            return False
        return inspect.signature(self.builder).parameters[option.name].default

    def check_set(self, name: str) -> None:
        """Refuse a tile-set name of the other layout."""
        if layout_of_set(name) != self.layout:
            want = (
                "a corner set (4, 8, 16a, ...)"
                if self.layout == "corner"
                else "an edge-coloured set (wang8, wang18)"
            )
            raise ParameterError(f"--set = {name!r}: --scheme {self.name} needs {want}")

    def build(self, exemplar: np.ndarray, **kwargs: Any) -> TileSet:
        """Build a tile set of this scheme (``kwargs`` go to :attr:`builder`); a build that would not fit in
        memory is refused up front with the figure (:func:`_check_build_memory`)."""
        default = inspect.signature(self.builder).parameters.get("tileset")
        default_set = (
            default.default if default is not None and isinstance(default.default, str) else self.default_set
        )
        _check_build_memory(exemplar, default_set, self.layout, kwargs)
        return self.builder(exemplar, **kwargs)


def _check_build_memory(exemplar: Any, default_set: str, layout: str, kwargs: dict[str, Any]) -> None:
    """:func:`tilesynth.base.budget.check_build_memory` for ``exemplar`` and the builder's ``kwargs``, the set
    resolved here (``default_set`` when ``kwargs`` name none; ``layout`` "corner" or "edge") with its tile
    count and default tile size. Arguments it cannot interpret are left to the builder's own checks."""
    shape = getattr(exemplar, "shape", None)
    if shape is None or len(shape) not in (2, 3) or not all(isinstance(v, int) and v > 0 for v in shape):
        return
    h, w = int(shape[0]), int(shape[1])
    c = int(shape[2]) if len(shape) == 3 else 1
    n = kwargs.get("tile_size")
    if not isinstance(n, int) or isinstance(n, bool) or n < 1:
        n = None
    complete = False
    try:
        name = kwargs.get("tileset") or default_set
        if layout == "corner":
            defn = get_tileset(name)
            k = len(defn.tiles)
            complete = lookup_scheme(defn) is not None
            if n is None and complete:  # complete sets default to quarter-side tiles
                n = default_complete_tile_size((h, w))
        else:
            k = len(get_wang_tileset(name).tiles)
    except Exception:  # noqa: BLE001 - a bad name is the builder's to report, with its own message
        return
    n = min(256, min(h, w) // 2) if n is None else n
    if n > min(h, w):  # a tile larger than the exemplar is the builder's error to report (it names the size)
        return
    check_build_memory((h, w, c), n, k, complete, kwargs)


def lambda_energy_line(p: dict[str, Any], E: float, what: str) -> str:
    """``info``'s E line of the λ objective (ω, s-Wang, patch) over ``what`` (the tiles D_j is taken on)."""
    metric = f", D in {p.get('metric')}" if p.get("metric", "color") != "color" else ""
    return f"E             {E:.6g}  (λ={p.get('lambda')}: λ·ΣD + (1−λ)·Var D over the {what}{metric})"
