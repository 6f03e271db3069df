"""The packaged lookup shaders (``shaders/``): their names and text. A module of its own so that the viewer
and the exporter read them without importing each other."""

from __future__ import annotations

from importlib import resources

from ..errors import ParameterError

__all__ = ["SHADER_FILES", "shader_source"]

SHADER_FILES = ("tilesynth.glsl", "tilesynth.wgsl", "tilesynth.hlsl", "tilesynth.gdshader")
"""The shader files of an export, one per shading language (GLSL ES 3.00 / 4.x, WGSL, HLSL, Godot)."""


def shader_source(name: str) -> str:
    """Text of one of the packaged shaders (:data:`SHADER_FILES`)."""
    if name not in SHADER_FILES:
        raise ParameterError(f"shader = {name!r}: one of {', '.join(SHADER_FILES)}")
    return resources.files(__package__).joinpath("shaders", name).read_text(encoding="utf-8")
