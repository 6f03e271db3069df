"""Hangs, signals and odd calls met by the hostile test of issue 16: fork after a kernel call, SIGTERM during a
write, a tile-set name given to the tiler."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import tilesynth


def _kernel_sum(threads):
    rng = np.random.default_rng(0)
    img = rng.random((40, 40, 3), dtype=np.float32)
    return float(tilesynth.patch_ssd(img, img[3:11, 5:13], threads=threads).sum())


def _child(q, threads):
    q.put(_kernel_sum(threads))


@pytest.mark.filterwarnings("ignore:.*fork.*:DeprecationWarning")
@pytest.mark.parametrize("threads", [None, 2, 1])
def test_kernel_call_in_a_forked_child_completes(threads):
    """After a kernel call in the parent (its thread pools cached), a child made by fork (multiprocessing's
    default start method on Linux before 3.14) runs its own kernel call instead of waiting forever on pool
    workers that do not exist in the child."""
    expected = _kernel_sum(threads)
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_child, args=(q, threads))
    p.start()
    p.join(timeout=60)
    if p.is_alive():
        p.kill()
        p.join()
        pytest.fail("the forked child hung in its first kernel call")
    assert p.exitcode == 0
    assert q.get(timeout=5) == expected
    assert _kernel_sum(threads) == expected  # and the parent's pools still work


@pytest.mark.filterwarnings("ignore:.*fork.*:DeprecationWarning")
def test_process_pool_executor_fork():
    from concurrent.futures import ProcessPoolExecutor

    expected = _kernel_sum(2)
    with ProcessPoolExecutor(2, mp_context=multiprocessing.get_context("fork")) as ex:
        futs = [ex.submit(_kernel_sum, 2) for _ in range(3)]
        assert [f.result(timeout=60) for f in futs] == [expected] * 3


def test_scanline_index_map_accepts_a_set_name():
    m = tilesynth.scanline_index_map("16a", 3, 4, seed=1)
    assert m.shape == (3, 4)
    np.testing.assert_array_equal(m, tilesynth.scanline_index_map(tilesynth.get_tileset("16a"), 3, 4, seed=1))
    tilesynth.validate_index_map("16a", m)
    w = tilesynth.scanline_index_map("wang8", 2, 3, seed=2)
    tilesynth.validate_index_map(tilesynth.get_wang_tileset("wang8"), w)
    with pytest.raises(ValueError, match="unknown tile set"):
        tilesynth.scanline_index_map("nope", 2, 2)
    with pytest.raises(TypeError, match="tileset"):
        tilesynth.scanline_index_map(None, 2, 2)
