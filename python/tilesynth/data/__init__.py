"""The bundled exemplar: ``lettuce-leaves.png`` (378x378 RGB, DCor's Texture115, BSD-3-Clause; see
``CREDITS.md`` and ``LICENSE-lettuce-leaves.txt`` next to it), used by ``tilesynth demo`` and the tests."""

from __future__ import annotations

from pathlib import Path


def example_path() -> Path:
    """The path of the bundled exemplar ``lettuce-leaves.png``, to try tilesynth without an image of your own:
    ``tilesynth.load_image(tilesynth.data.example_path())``."""
    return Path(__file__).with_name("lettuce-leaves.png")


__all__ = ["example_path"]
