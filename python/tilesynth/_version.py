"""The installed package's version (a module of its own, so that builders can record it without importing the
package root: ``from .. import __version__`` inside the package would be an import cycle)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tilesynth")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    from ._core import __version__

__all__ = ["__version__"]
