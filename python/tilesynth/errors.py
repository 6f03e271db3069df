"""Exceptions raised by tilesynth.

Every error message names the parameter and the offending value. The classes subclass the builtins so that
``except ValueError`` works as users expect; the Rust core raises :class:`ShapeError` and
:class:`ParameterError` directly.
"""

from __future__ import annotations


class TilesynthError(Exception):
    """Base class of every tilesynth error."""


class ShapeError(TilesynthError, ValueError):
    """An array has the wrong shape, or two arrays disagree."""


class ParameterError(TilesynthError, ValueError):
    """A parameter or the content of an array is out of range."""


class TileSetFormatError(TilesynthError, ValueError):
    """A tile-set file is unreadable, of an unknown version, or inconsistent."""


class InternalError(TilesynthError, RuntimeError):
    """A bug in tilesynth, not in the input: the Rust core panicked (the bindings catch every panic and raise
    this instead of pyo3's ``PanicException``, which ``except Exception`` would miss). The CLI exits with
    status 1 on it. Please report it with the inputs that caused it."""


__all__ = ["TilesynthError", "ShapeError", "ParameterError", "TileSetFormatError", "InternalError"]
