"""Shared fixtures: a small real exemplar (the bundled lettuce texture), RNG, hypothesis profiles.

Hypothesis profiles: ``ci`` (default, bounded examples, no deadline: the machines are shared and noisy) and
``local`` (more examples); select with ``HYPOTHESIS_PROFILE=local``.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile("ci", max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("local", max_examples=200, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

DATA = Path(__file__).parent / "data"


@pytest.fixture(scope="session")
def lettuce_path() -> Path:
    with resources.as_file(resources.files("tilesynth") / "data" / "lettuce-leaves.png") as p:
        return Path(p)


@pytest.fixture(scope="session")
def lettuce(lettuce_path: Path) -> np.ndarray:
    import tilesynth

    img, bits = tilesynth.load_image(lettuce_path)
    assert bits == 8 and img.dtype == np.float32
    return img


@pytest.fixture(scope="session")
def small_exemplar(lettuce: np.ndarray) -> np.ndarray:
    """A 96x96 crop of the lettuce texture: fast to build on."""
    return np.ascontiguousarray(lettuce[100:196, 60:156])


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def mincut80() -> dict[str, np.ndarray]:
    with np.load(DATA / "mincut80.npz") as d:
        return {k: d[k] for k in d.files}
