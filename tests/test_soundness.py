"""Soundness of the bindings against callers that rust-numpy's borrow checking cannot see (issue 16's crash hunt).

* **The SIGSEGV "inside hashed_index_map"** (found again by ``test_fuzz_api.py --hypothesis-seed=114`` and 118):
  ``size = (0, 2**63 - 1)`` has no cells, so it passed the cell limit, but numpy refuses to make an array of that
  shape and rust-numpy 0.30's ``into_pyarray`` sets the base object of the null array it gets back. Each side
  is now bounded, and a shape numpy cannot make is refused before ``into_pyarray``.

* **Aliasing through different base objects.** rust-numpy refuses a mutable borrow of an array that shares its
  base object with a borrowed input, but two arrays made from one buffer through different objects (two
  memoryviews of one bytearray, an mmap) have different bases. ``tile_copy`` (the only binding that writes into a
  caller's array) compares the addresses itself.
* **The environment while the GIL is released.** Python threads change ``os.environ`` (``setenv``, which may move
  and free libc's ``environ`` array) holding the GIL; the bindings read ``TILESYNTH_NUM_THREADS`` before releasing
  it. Checked exactly with a ``getenv`` interposer (``LD_PRELOAD``) that records calls made without the GIL, and
  by a short stress run of threads that change the environment while others call kernels.
* **Misaligned arrays** (a buffer at an odd offset, a field of a packed structured array): rust-numpy's
  ``as_array`` does not check alignment and a view of a misaligned pointer is undefined behaviour (ndarray asserts
  it only under debug assertions), so the bindings refuse them and the public API copies them.
* **Inputs written by another thread during a call.** The index map is copied before the GIL is released, so the
  indices the kernel checks are the indices it uses.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import tilesynth as ts
from tilesynth import _core
from tilesynth.errors import ParameterError


def _views(nbytes: int) -> tuple[bytearray, memoryview, memoryview]:
    buf = bytearray(nbytes)
    return buf, memoryview(buf), memoryview(buf)


# ------------------------------------------------------------------------------------------- the SIGSEGV
@pytest.mark.parametrize(
    "call",
    [
        "_core.hashed_index_map('edge', [2, 3], 1, 175356, (1513710, 370), (0, 2**63 - 1), None, None)",
        "_core.hashed_index_map('corner', [2], 1, 0, (0, 0), (2**62, 0), None, None)",
        "ts.hashed_index_map(ts.LookupScheme('corner', (3,), 2), 0, (0, 2**63 - 1))",
        "ts.hashed_index_map(ts.LookupScheme('edge', (2, 3)), 5, (2**40, 0))",
    ],
)
def test_an_empty_map_with_a_huge_side_is_an_error_not_a_segfault(call: str):
    """Run in a child process: before the fix the call killed the interpreter with SIGSEGV."""
    code = f"import tilesynth as ts\nfrom tilesynth import _core\ntry:\n    {call}\nexcept ValueError as e:\n    print('refused', e)\n"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, (r.returncode, r.stderr[-1500:])
    assert "refused" in r.stdout and "size" in r.stdout, r.stdout


def test_small_empty_maps_still_work():
    assert ts.hashed_index_map(ts.LookupScheme("corner", (3,), 2), 0, (0, 5)).shape == (5, 0)
    assert _core.hashed_index_map("corner", [2], 1, 0, (0, 0), (7, 0), None, None).shape == (0, 7)


# ------------------------------------------------------------------------------------------- aliasing
def test_core_tile_copy_refuses_out_overlapping_atlas_through_another_base():
    _, m1, m2 = _views(16)
    atlas = np.frombuffer(m1, np.uint8).reshape(1, 4, 4, 1)
    out = np.frombuffer(m2, np.uint8).reshape(4, 4, 1)
    assert atlas.base is not out.base and np.shares_memory(atlas, out)
    with pytest.raises(ParameterError, match="out = .*shares memory with atlas"):
        _core.tile_copy(atlas, np.zeros((1, 1), np.int32), out)


def test_core_tile_copy_refuses_out_overlapping_part_of_atlas():
    """A partial overlap (out starts inside atlas) is refused too; adjacent arrays are fine."""
    _, m1, m2 = _views(64)
    atlas = np.frombuffer(m1, np.uint8, count=32).reshape(2, 4, 4, 1)
    out = np.frombuffer(m2, np.uint8, count=16, offset=24).reshape(4, 4, 1)
    with pytest.raises(ParameterError, match="shares memory with atlas"):
        _core.tile_copy(atlas, np.zeros((1, 1), np.int32), out)
    after = np.frombuffer(m2, np.uint8, count=16, offset=32).reshape(4, 4, 1)
    np.frombuffer(m1, np.uint8, count=32)[:] = np.arange(32)
    _core.tile_copy(atlas, np.ones((1, 1), np.int32), after)
    assert np.array_equal(after[..., 0], np.arange(16, 32).reshape(4, 4))


@settings(max_examples=150, deadline=None)
@given(
    n_atlas=st.integers(0, 48),
    n_out=st.integers(0, 48),
    shift=st.integers(0, 100),
    dtype=st.sampled_from(["uint8", "uint16", "float32", "int32"]),
)
def test_tile_copy_overlap_property(n_atlas: int, n_out: int, shift: int, dtype: str):
    """atlas (K, 2, 2, 1) and out (H, 2, 1) placed at random byte offsets in one buffer, through two
    memoryviews: refused exactly when their bytes overlap; otherwise the copy is the reference one."""
    dt = np.dtype(dtype)
    k, h = max(1, n_atlas // 4), n_out // 2
    size = dt.itemsize
    a_bytes, o_bytes = k * 4 * size, h * 2 * size
    shift = shift // size * size  # aligned offsets: alignment is its own test
    buf = bytearray(max(a_bytes, shift + o_bytes) + 16)
    m1, m2 = memoryview(buf), memoryview(buf)
    atlas = np.frombuffer(m1, dt, count=k * 4).reshape(k, 2, 2, 1)
    atlas[...] = (np.arange(k * 4) % 100).reshape(k, 2, 2, 1)
    out = np.frombuffer(m2, dt, count=h * 2, offset=shift).reshape(h, 2, 1)
    imap = np.zeros((max(1, -(-h // 2)), 1), np.int32)
    overlap = a_bytes > 0 and o_bytes > 0 and shift < a_bytes
    want = np.asarray(atlas[0]).copy()
    if overlap:
        with pytest.raises(ParameterError, match="shares memory with atlas"):
            _core.tile_copy(atlas, imap, out)
    else:
        _core.tile_copy(atlas, imap, out)
        for y in range(h):
            assert np.array_equal(out[y], want[y % 2])


def test_tile_copy_refuses_an_index_map_overlapping_out():
    """Public API: an int32 out (a provenance map) whose memory is also the index map."""
    _, m1, m2 = _views(4 * 4 * 4)
    out = np.frombuffer(m1, np.int32).reshape(4, 4, 1)
    imap = np.frombuffer(m2, np.int32).reshape(4, 4)
    atlas = np.arange(4, dtype=np.int32).reshape(1, 2, 2, 1)
    with pytest.raises(ParameterError, match="shares memory with index_map"):
        ts.tile_copy(atlas, imap, out)


def test_same_base_aliasing_is_still_refused():
    atlas = np.zeros((1, 4, 4, 1), np.uint8)
    with pytest.raises((TypeError, ValueError)):
        _core.tile_copy(atlas, np.zeros((1, 1), np.int32), atlas[0])


# ------------------------------------------------------------------------------------------- alignment
def _misaligned(a: np.ndarray) -> np.ndarray:
    buf = bytearray(a.nbytes + 1)
    b = np.frombuffer(memoryview(buf)[1:], a.dtype).reshape(a.shape)
    b[...] = a
    assert not b.flags.aligned and b.flags.c_contiguous
    return b


_R = np.random.default_rng(3)
_IMG = _R.random((20, 20, 3), dtype=np.float32)
_T = _R.random((4, 4, 3), dtype=np.float32)
_W = _R.random((6, 6))
_NO = np.zeros((6, 6), bool)

CORE_CALLS = {
    "SsdIndex": lambda m: _core.SsdIndex(m(_IMG)),
    "kwatra_weights": lambda m: _core.kwatra_weights(_IMG, _IMG, None, 1e-6, m(_R.random((20, 20, 2)))),
    "grid_mincut": lambda m: _core.grid_mincut(m(_W), _W, _NO, _NO),
    "poisson_smooth": lambda m: _core.poisson_smooth(m(_IMG[None]), _IMG[None], np.ones((1, 20, 20), bool)),
    "ts_hash": lambda m: _core.ts_hash(m(np.arange(4, dtype=np.int32)), np.arange(4, dtype=np.int32), 1, 0),
    "tile_copy out": lambda m: _core.tile_copy(
        np.zeros((1, 2, 2, 1), np.float32), np.zeros((1, 1), np.int32), m(np.zeros((2, 2, 1), np.float32))
    ),
    "weighted_ssd_map": lambda m: _core.weighted_ssd_map(
        _IMG, m(_R.random((20, 20))), _T, _R.random((4, 4)), 1.0, 1e-3
    ),
}


@pytest.mark.parametrize("name", sorted(CORE_CALLS))
def test_core_refuses_misaligned_arrays(name: str):
    CORE_CALLS[name](lambda a: a)  # aligned: fine
    with pytest.raises(TypeError, match="aligned"):
        CORE_CALLS[name](_misaligned)


def test_empty_misaligned_arrays_are_refused_too():
    """numpy may flag an empty array at an odd address aligned; a Rust view of it is still undefined behaviour
    (ndarray's debug assertion fired on such arrays in a debug-asserting build of the fuzzers)."""
    empty = np.frombuffer(memoryview(bytearray(1))[1:], np.int32)
    assert empty.size == 0 and empty.__array_interface__["data"][0] % 4 != 0
    with pytest.raises(TypeError, match="aligned"):
        _core.ts_hash(empty, np.zeros(0, np.int32), 1, 0)
    assert ts.ts_hash(empty, np.zeros(0, np.int32), 1, 0).shape == (0,)  # the public API copies it


PUBLIC_CALLS = {
    "patch_ssd": lambda m: ts.patch_ssd(m(_IMG), m(_T)),
    "best_matches": lambda m: ts.best_matches(m(_IMG), m(_T), k=3),
    "kwatra_weights": lambda m: ts.kwatra_weights(m(_IMG), m(_IMG[::-1].copy())),
    "grid_mincut": lambda m: ts.grid_mincut(m(_W), m(_W.T.copy()), _NO, _NO),
    "poisson_smooth": lambda m: ts.poisson_smooth(m(_IMG), m(_IMG[::-1].copy()), np.ones((20, 20), bool)),
    "tile_copy": lambda m: ts.tile_copy(
        m(_IMG.reshape(4, 5, 20, 3)),
        m(np.array([[1, 3], [0, 2]], np.int32)),
        np.zeros((10, 40, 3), np.float32),
    ),
    "ts_hash": lambda m: ts.ts_hash(m(np.arange(-3, 5, dtype=np.int64)), 7, 1, 0),
}


@pytest.mark.parametrize("name", sorted(PUBLIC_CALLS))
def test_public_api_takes_misaligned_arrays_like_any_layout(name: str):
    want, got = PUBLIC_CALLS[name](lambda a: a), PUBLIC_CALLS[name](_misaligned)
    flat = lambda r: r if isinstance(r, tuple) else (r,)  # noqa: E731
    for w, g in zip(flat(want), flat(got), strict=True):
        assert np.array_equal(np.asarray(w), np.asarray(g))


# ------------------------------------------------------------------------------------------- environment
_SHIM = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <string.h>
#include <unistd.h>
/* getenv that writes a line to fd 2 when TILESYNTH_NUM_THREADS is read by a thread without the GIL. */
char *getenv(const char *name) {
    static char *(*real)(const char *) = 0;
    static int (*gil)(void) = 0;
    if (!real) real = (char *(*)(const char *))dlsym(RTLD_NEXT, "getenv");
    if (name && strcmp(name, "TILESYNTH_NUM_THREADS") == 0) {
        if (!gil) gil = (int (*)(void))dlsym(RTLD_DEFAULT, "PyGILState_Check");
        if (gil && !gil()) {
            static const char msg[] = "GETENV-WITHOUT-GIL\n";
            (void)!write(2, msg, sizeof msg - 1);
        }
    }
    return real(name);
}
"""


def test_thread_count_is_read_from_the_environment_with_the_gil_held(tmp_path: Path):
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None or not sys.platform.startswith("linux"):
        pytest.skip("needs a C compiler and Linux (LD_PRELOAD)")
    (tmp_path / "shim.c").write_text(_SHIM)
    so = tmp_path / "shim.so"
    subprocess.run(
        [cc, "-shared", "-fPIC", "-O1", "-o", str(so), str(tmp_path / "shim.c"), "-ldl"], check=True
    )
    code = textwrap.dedent(
        """
        import numpy as np
        from tilesynth import _core
        _core.hashed_index_map("corner", [2], 1, 0, (0, 0), (3, 3), None, None)
        _core.tile_copy(np.zeros((1, 2, 2, 1), np.uint8), np.zeros((1, 1), np.int32), np.zeros((2, 2, 1), np.uint8))
        _core.SsdIndex(np.zeros((4, 4, 1), np.float32))
        print("ran")
        """
    )
    env = {**os.environ, "LD_PRELOAD": str(so)}
    env.pop("TILESYNTH_NUM_THREADS", None)
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "ran" in r.stdout, r.stderr[-2000:]
    assert "GETENV-WITHOUT-GIL" not in r.stderr


def test_kernels_while_other_threads_change_the_environment():
    """Threads that set and unset variables (``build_many`` in a ThreadPoolExecutor sets TILESYNTH_NUM_THREADS
    per job) while other threads call kernels that read it: no crash, every call right."""
    stop = threading.Event()
    errors: list[BaseException] = []
    want = _core.hashed_index_map("corner", [3], 2, 5, (0, 0), (4, 4), None, None)

    def writer() -> None:
        i = 0
        while not stop.is_set():
            for k in range(32):
                os.environ[f"TILESYNTH_TEST_RACE_{k}"] = "v" * (i % 5 + 1)
            os.environ["TILESYNTH_NUM_THREADS"] = str(1 + i % 2)
            for k in range(32):
                del os.environ[f"TILESYNTH_TEST_RACE_{k}"]
            i += 1

    def reader() -> None:
        try:
            while not stop.is_set():
                got = _core.hashed_index_map("corner", [3], 2, 5, (0, 0), (4, 4), None, None)
                assert np.array_equal(got, want)
        except BaseException as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    before = os.environ.get("TILESYNTH_NUM_THREADS")
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    threads = [threading.Thread(target=writer)] + [threading.Thread(target=reader) for _ in range(2)]
    try:
        for t in threads:
            t.start()
        time.sleep(1.5)
    finally:
        stop.set()
        for t in threads:
            t.join()
        sys.setswitchinterval(switch)
        if before is None:
            os.environ.pop("TILESYNTH_NUM_THREADS", None)
        else:
            os.environ["TILESYNTH_NUM_THREADS"] = before
    assert not errors, errors[:1]


# ------------------------------------------------------------------------------------------- concurrent writes
def test_index_map_written_by_another_thread_during_a_copy_never_breaks_the_call():
    """Another thread sets one cell of the index map to a bad index and back while copies run: every call
    either copies or refuses the map (ParameterError) — never an internal error from an index that changed
    after it was checked (the old binding read the caller's map again after checking it: about 3% of the calls
    here panicked)."""
    atlas = np.arange(2 * 8 * 8, dtype=np.float32).reshape(2, 8, 8, 1)
    imap = np.ones((256, 256), np.int32)
    out = np.zeros((2048, 2048, 1), np.float32)
    stop = threading.Event()

    def flipper() -> None:
        while not stop.is_set():
            time.sleep(0.001)
            imap[-1, -1] = 7
            time.sleep(0.0002)
            imap[-1, -1] = 1

    t = threading.Thread(target=flipper)
    t.start()
    outcomes = {"copied": 0, "refused": 0}
    try:
        for _ in range(200):
            try:
                _core.tile_copy(atlas, imap, out, 2)
                outcomes["copied"] += 1
            except ParameterError:
                outcomes["refused"] += 1
    finally:
        stop.set()
        t.join()
    assert outcomes["copied"] and outcomes["refused"], outcomes  # the race was really run
