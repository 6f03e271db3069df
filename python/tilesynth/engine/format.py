"""The export format: its name and version, the manifest's schema and check, the hash constants the manifest
records, and the argument checks both export versions share (:func:`tilesynth.engine.export`)."""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

import numpy as np

from ..errors import ParameterError, ShapeError
from .periodic import default_index_size

EXPORT_FORMAT = "tilesynth-export"


EXPORT_VERSION = 1


HASH_NAME = "pcg3d"  # tilesynth.layouts.hashed.HASH_NAME


HASH_CONSTANTS = {
    "lcg_multiplier": 1664525,
    "lcg_increment": 1013904223,
    "role_multiplier": 0x9E3779B9,
    "shift": 16,
}
"""The constants of the hash as the manifest records them (checked against :mod:`tilesynth.layouts.hashed` by the tests)."""


def manifest_schema() -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of ``manifest.json``."""
    return json.loads(
        resources.files(__package__).joinpath("manifest.schema.json").read_text(encoding="utf-8")
    )


def validate_manifest(manifest: dict[str, Any]) -> None:
    """Validate a manifest against :func:`manifest_schema` (needs ``jsonschema``, the ``test`` extra)."""
    try:
        import jsonschema
    except ImportError:
        raise ImportError("validating a manifest needs jsonschema: pip install 'tilesynth[test]'") from None
    jsonschema.Draft202012Validator(manifest_schema()).validate(manifest)


def _check_choice(value: Any, name: str, options: tuple[Any, ...]) -> Any:
    if value not in options:
        raise ParameterError(f"{name} = {value!r}: must be one of {', '.join(map(repr, options))}")
    return value


def _map_array(name: str, value: Any, exemplar_shape: tuple[int, int]) -> np.ndarray:
    a = np.asarray(value)
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[:2] != exemplar_shape or not 1 <= a.shape[2] <= 4:
        raise ShapeError(
            f"maps[{name!r}] has shape {np.shape(value)}, expected {exemplar_shape} or {exemplar_shape + (1,)}..."
            f"{exemplar_shape + (4,)}: pixel-aligned with the exemplar"
        )
    if a.dtype not in (np.uint8, np.uint16, np.float32):
        raise ParameterError(f"maps[{name!r}] has dtype {a.dtype}, expected uint8, uint16 or float32")
    return a


def _index_size(defn: Any, index_size: tuple[int, int] | None) -> tuple[int, int]:
    """The (cols, rows) of the index map, checked."""
    if index_size is None:
        index_size = default_index_size(defn)
    icols, irows = (int(v) for v in index_size)
    if icols < 1 or irows < 1 or icols * irows > 1 << 22:
        raise ParameterError(f"index_size = {index_size!r}: (cols, rows) >= 1 and at most 4M cells")
    return icols, irows


def _version() -> str:
    from .._version import __version__

    return __version__
