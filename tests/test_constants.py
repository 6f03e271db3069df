"""Constants shared by Rust and Python are defined once, in the core, and the Python layer uses the core's
(issue 11): eps of the Kwatra weight, the Poisson tolerance, λ, ω, the thread cap and the Wang side indices."""

from __future__ import annotations

import numpy as np
import pytest

import tilesynth
from tilesynth import _core
from tilesynth.base import kernels
from tilesynth.base import validate as _validate
from tilesynth.builder import wang
from tilesynth.builder.genes import draws as genes


def test_python_names_are_the_cores():
    assert kernels.DEFAULT_EPS == _core.DEFAULT_EPS == 1e-6
    assert kernels.DEFAULT_POISSON_TOL == _core.DEFAULT_POISSON_TOL == 1e-6
    assert genes.LAMBDA == tilesynth.builder.omega.LAMBDA == _core.DEFAULT_LAMBDA == 0.8
    assert wang.DEFAULT_OMEGA == _core.DEFAULT_OMEGA == 0.8
    assert _validate.MAX_THREADS == _core.MAX_THREADS == 1024
    assert (wang.NORTH, wang.EAST, wang.SOUTH, wang.WEST) == _core.WANG_SIDES == (0, 1, 2, 3)
    assert _core.THREADS_ENV == "TILESYNTH_NUM_THREADS"


def test_thread_cap_is_the_same_on_both_sides():
    assert _core.resolve_threads(_core.MAX_THREADS) == _core.MAX_THREADS
    with pytest.raises(ValueError):
        _core.resolve_threads(_core.MAX_THREADS + 1)
    with pytest.raises(tilesynth.ParameterError, match=f"at most {_core.MAX_THREADS}"):
        _validate.threads_arg(_core.MAX_THREADS + 1)


def test_the_cores_defaults_are_the_exported_values(small_exemplar):
    """The kernels' own defaults (used when Python passes nothing) equal the exported constants."""
    rng = np.random.default_rng(0)
    a = rng.random((16, 16, 3), dtype=np.float32)
    b = rng.random((16, 16, 3), dtype=np.float32)
    m0, c0 = _core.omega_cuts(a[None], b[None])
    m1, c1 = _core.omega_cuts(a[None], b[None], _core.DEFAULT_EPS)
    np.testing.assert_array_equal(m0, m1)
    assert c0 == c1
    region = np.zeros((1, 16, 16), bool)
    region[0, 4:12, 4:12] = True
    r0 = _core.poisson_smooth(a[None], b[None], region)
    r1 = _core.poisson_smooth(a[None], b[None], region, _core.DEFAULT_POISSON_TOL)
    for x, y in zip(r0, r1):
        np.testing.assert_array_equal(x, y)


def test_wang_side_indices_label_the_edges(small_exemplar):
    """With pinned corners every edge pixel shows its own side's sample: the core's labels use WANG_SIDES."""
    ts = tilesynth.build_wang(small_exemplar, tile_size=16, seed=1, corners="pinned")
    north, east, south, west = _core.WANG_SIDES
    lab = ts.labels
    assert (lab[:, 0, 1:-1] == north).all() and (lab[:, -1, 1:-1] == south).all()
    assert (lab[:, 2:-2, 0] == west).all() and (lab[:, 2:-2, -1] == east).all()
