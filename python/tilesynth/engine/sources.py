"""The packaged lookup shaders (``shaders/``): their names and text. A module of its own so that the viewer
and the exporter read them without importing each other."""

from __future__ import annotations

from importlib import resources

from ..errors import ParameterError

__all__ = ["SHADER_FILES", "SHADER_FILES_V2", "shader_source"]

SHADER_FILES = ("tilesynth.glsl", "tilesynth.wgsl", "tilesynth.hlsl", "tilesynth.gdshader")
"""The shader files of an export, one per shading language (GLSL ES 3.00 / 4.x, WGSL, HLSL, Godot)."""


SHADER_FILES_V2 = ("tilesynth_v2.glsl", "tilesynth_v2.wgsl", "tilesynth_v2.hlsl", "tilesynth_v2.gdshader")
"""The shader files of a version-2 (provenance) export, for M maps."""


def shader_source(name: str) -> str:
    """Text of one of the packaged shaders (:data:`SHADER_FILES`, :data:`SHADER_FILES_V2`)."""
    if name not in SHADER_FILES + SHADER_FILES_V2:
        raise ParameterError(f"shader = {name!r}: one of {', '.join(SHADER_FILES + SHADER_FILES_V2)}")
    return resources.files(__package__).joinpath("shaders", name).read_text(encoding="utf-8")
