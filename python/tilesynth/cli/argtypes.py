"""The value rules of every command-line option, shared by all subcommands (argparse ``type`` functions).

**Integers** (``--seed``, ``--tile-size``, ``--threads``, ``--size``, ``--padding``, ...): ASCII decimal digits
``0-9``, with a leading ``-`` or ``+`` where the option takes signed values, spaces around ignored. Python's
``int()`` would also take digits of other scripts (``٣٢``, ``３２``), underscores (``1_000``) and a sign
everywhere: a value that only some scripts or Python itself read as a number is refused, so what a user typed
is what a script, a shell history or a batch file means. A value out of the option's range is refused with the
range (argparse puts the option's name in front: ``argument --tile-size: -4 is out of range: expected an
integer >= 1``).

**Floats** (``--cut-bias``): ASCII decimal or scientific notation (``0.5``, ``.5``, ``2e-3``), finite: no
``nan``, ``inf``, underscores or other scripts' digits.

**Sizes and pairs**: ``WIDTHxHEIGHT`` (``x`` or ``X``), or one integer for a square, each a positive ASCII
integer.

**Normal-map Y convention** (``--normal-y`` of ``build``, ``synth`` and ``export``): ``up`` (OpenGL, green up) or
``down`` (DirectX), the spelling the help shows; ``+y`` and ``-y`` (the spelling of the export manifest and the
shaders) are accepted as the same values everywhere (the Python API too: ``build(..., normal_y=)``,
``export(..., normal_y=)``, a batch file's ``normal_y``).
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from typing import Any

__all__ = [
    "float_text",
    "int_text",
    "normal_y_text",
    "normal_y_value",
    "origin_text",
    "pair_text",
    "size_text",
]

_UNSIGNED = re.compile(r"\+?[0-9]+")
_SIGNED = re.compile(r"[+-]?[0-9]+")
_FLOAT = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def _range(lo: int | float | None, hi: int | float | None, kind: str = "an integer") -> str:
    if lo is not None and hi is not None:
        return f"{kind} in [{lo}, {hi}]"
    if lo is not None:
        return f"{kind} >= {lo}"
    if hi is not None:
        return f"{kind} <= {hi}"
    return kind


def parse_int(text: str, lo: int | None = None, hi: int | None = None) -> int:
    """``text`` as an int by the rule of the module docstring, or :class:`argparse.ArgumentTypeError`."""
    t = str(text).strip()
    signed = lo is None or lo < 0
    if not (_SIGNED if signed else _UNSIGNED).fullmatch(t):
        if not signed and _SIGNED.fullmatch(t):  # a negative value for an option that has none
            raise argparse.ArgumentTypeError(f"{t} is out of range: expected {_range(lo, hi)}")
        raise argparse.ArgumentTypeError(
            f"{text!r} is not an integer: expected {_range(lo, hi)}, in ASCII digits 0-9"
        )
    v = int(t)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise argparse.ArgumentTypeError(f"{v} is out of range: expected {_range(lo, hi)}")
    return v


def int_text(lo: int | None = None, hi: int | None = None) -> Callable[[str], int]:
    """An argparse type: an integer in ``[lo, hi]`` (either bound may be None)."""

    def parse(text: str) -> int:
        return parse_int(text, lo, hi)

    parse.__name__ = f"int_{lo}_{hi}"
    parse.lo, parse.hi = lo, hi  # type: ignore[attr-defined]  # read by the tests of the option rules
    return parse


def float_text(lo: float | None = None, hi: float | None = None) -> Callable[[str], float]:
    """An argparse type: a finite float in ``[lo, hi]`` (either bound may be None)."""

    def parse(text: str) -> float:
        t = str(text).strip()
        if not _FLOAT.fullmatch(t):
            raise argparse.ArgumentTypeError(
                f"{text!r} is not a number: expected {_range(lo, hi, 'a finite number')}, in ASCII digits "
                "(e.g. 0.5 or 2e-3)"
            )
        v = float(t)
        if not math.isfinite(v) or (lo is not None and v < lo) or (hi is not None and v > hi):
            raise argparse.ArgumentTypeError(
                f"{t} is out of range: expected {_range(lo, hi, 'a finite number')}"
            )
        return v

    parse.__name__ = "float"
    return parse


_PAIR = re.compile(r"\s*([0-9]+)\s*(?:[xX]\s*([0-9]+)\s*)?")


def size_text(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` or ``SIZE`` (a square), positive ASCII integers: ``(width, height)``."""
    m = _PAIR.fullmatch(str(text))
    if not m or int(m.group(1)) < 1 or int(m.group(2) or m.group(1)) < 1:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected WIDTHxHEIGHT or SIZE (a square) with positive integers in ASCII digits, "
            "e.g. 1024x768 or 1024"
        )
    return int(m.group(1)), int(m.group(2) or m.group(1))


def pair_text(text: str) -> tuple[int, int]:
    """``COLSxROWS``, positive ASCII integers (both given): ``(cols, rows)``."""
    m = _PAIR.fullmatch(str(text))
    if not m or m.group(2) is None or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected COLSxROWS with positive integers in ASCII digits, e.g. 32x32"
        )
    return int(m.group(1)), int(m.group(2))


def origin_text(text: str) -> tuple[int, int]:
    """``X,Y``: two signed ASCII integers."""
    parts = str(text).split(",")
    if len(parts) != 2 or not all(_SIGNED.fullmatch(p.strip()) for p in parts):
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected X,Y (two integers in ASCII digits, e.g. -512,256)"
        )
    return int(parts[0]), int(parts[1])


_NORMAL_Y = {"up": "up", "+y": "up", "down": "down", "-y": "down"}


def normal_y_value(value: Any, name: str = "normal_y") -> str:
    """``"up"`` or ``"down"`` for either accepted spelling (``up`` or ``+y``, ``down`` or ``-y``); else
    :class:`~tilesynth.errors.ParameterError` naming ``name``."""
    from ..errors import ParameterError

    key = value if isinstance(value, str) else None
    if key not in _NORMAL_Y:
        raise ParameterError(
            f"{name} = {value!r}: expected 'up' (OpenGL, green up; also '+y') or 'down' (DirectX; also '-y')"
        )
    return _NORMAL_Y[key]


def normal_y_text(text: str) -> str:
    """argparse type of ``--normal-y``: :func:`normal_y_value`."""
    from ..errors import ParameterError

    try:
        return normal_y_value(text, "--normal-y")
    except ParameterError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected up (OpenGL, green up; also +y) or down (DirectX; also -y)"
        ) from None
