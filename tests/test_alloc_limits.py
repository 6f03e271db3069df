"""Kernels and the CLI under an address-space limit (issue 16: "no Rust allocation in a kernel may abort the
process"). Each case runs in a fresh interpreter that builds its inputs, warms the kernel up on a small input (so
the thread pools and malloc arenas exist), then lowers ``RLIMIT_AS`` to what it already uses plus a few MiB, less
than the kernel's own buffers, and calls the kernel. Before the fix the refused allocation aborted the process
(SIGABRT, "memory allocation of N bytes failed"); now it is a Python exception naming the parameter and the size
(``ParameterError`` from the Rust core, ``MemoryError`` from numpy), and the CLI exits with status 2.

The inputs are small (at most 16 MiB) and the refused buffers are never touched, so these tests use little real
memory and take about a second each.
"""

from __future__ import annotations

import struct
import subprocess
import sys
import textwrap
import zlib

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc are Linux")

#: What the child may allocate above its address space at the time of the call: less than the first large buffer
#: of every kernel below (each is at least 8 MiB), more than the small allocations of a call and its error.
HEADROOM = 3 << 20

_PRELUDE = """
import os, resource, sys
import numpy as np
import tilesynth
from tilesynth import _core

def vm_bytes():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmSize")
"""

_LIMIT_AND_CALL = """
call(small=True)  # warm-up: pools, arenas, lazily imported modules
resource.setrlimit(resource.RLIMIT_AS, (vm_bytes() + int(sys.argv[1]), resource.RLIM_INFINITY))
try:
    call(small=False)
except (MemoryError, ValueError) as e:
    print("REFUSED", type(e).__name__, e, flush=True)
    sys.exit(0)
print("COMPLETED", flush=True)
"""


def run_limited(body: str, headroom: int = HEADROOM, extra_path: str | None = None):
    """Runs ``body`` (which defines ``call(small)``) in a child under the address-space limit; returns the
    completed process. ``extra_path`` goes first on ``sys.path`` (to run another build of the package)."""
    code = _PRELUDE + textwrap.dedent(body) + _LIMIT_AND_CALL
    if extra_path:
        code = f"import sys; sys.path.insert(0, {extra_path!r})\n" + code
    return subprocess.run(
        [sys.executable, "-c", code, str(headroom)],
        capture_output=True,
        text=True,
        timeout=120,
        env={"PATH": "/usr/bin:/bin", "TILESYNTH_NUM_THREADS": "2", "PYTHONDONTWRITEBYTECODE": "1"},
    )


def assert_clean_refusal(proc, *needles: str):
    assert proc.returncode == 0, (
        f"child died with status {proc.returncode} (-6 = SIGABRT)\nstdout: {proc.stdout}\nstderr: {proc.stderr}"
    )
    assert proc.stdout.startswith("REFUSED"), proc.stdout + proc.stderr
    for n in needles:
        assert n in proc.stdout, proc.stdout


def _png_declaring(width: int, height: int) -> bytes:
    """A well-formed PNG header (RGBA, 8-bit) declaring ``width x height`` with one tiny IDAT."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(b"\0"))
        + chunk(b"IEND", b"")
    )


# Each kernel: the body of the child (inputs and ``call``) and what its error must name.
KERNELS = {
    "grid_mincut": (
        """
        args = {n: (np.ones((n, n)), np.zeros((n, n), bool)) for n in (8, 1024)}
        def call(small):
            w, f = args[8 if small else 1024]
            _core.grid_mincut(w, w, f, f)
        """,
        ("wx = ", "cannot allocate"),
    ),
    "omega_cuts": (
        """
        big = np.random.default_rng(0).random((1, 2048, 2048, 1), dtype=np.float32)
        args = {s: (big[:, :s, :s].copy(), big[:, :s, :s][:, ::-1].copy()) for s in (16, 2048)}
        def call(small):
            _core.omega_cuts(*args[16 if small else 2048])
        """,
        ("intermediate = ", "cannot allocate"),
    ),
    "kwatra_weights": (
        """
        big = np.random.default_rng(0).random((2048, 2048, 1), dtype=np.float32)
        args = {16: big[:16, :16].copy(), 2048: big}
        def call(small):
            a = args[16 if small else 2048]
            _core.kwatra_weights(a, a)
        """,
        ("cannot allocate",),
    ),
    "edge_weight_sums": (
        """
        img = np.random.default_rng(0).random((2048, 2048, 1), dtype=np.float32)
        t = img[:8, :8].copy()
        m = np.ones((8, 8), bool)
        args = {32: img[:32, :32].copy(), 2048: img}
        def call(small):
            _core.edge_weight_sums(t, args[32 if small else 2048], m, m)
        """,
        ("image = ", "cannot allocate"),
    ),
    "poisson_smooth": (
        """
        rng = np.random.default_rng(0)
        args = {}
        for s in (16, 1024):
            region = np.ones((1, s, s), bool)
            region[:, 0] = False
            d = rng.random((1, s, s, 1), dtype=np.float32)
            args[s] = (d, d[:, ::-1].copy(), region)
        def call(small):
            _core.poisson_smooth(*args[16 if small else 1024])
        """,
        ("cannot allocate",),
    ),
    "PopulationEvaluator": (
        """
        big = np.random.default_rng(0).random((1024, 1024, 3), dtype=np.float32)
        args = {32: big[:32, :32].copy(), 1024: big}
        tp = np.array([[0, 1, 2, 3]], np.int64)
        genes = np.zeros((1, 4, 2), np.int64)
        def call(small):
            ev = _core.PopulationEvaluator(args[32 if small else 1024], 8, tp, 4, cache_bytes=0)
            ev.evaluate(genes)
        """,
        ("cannot allocate",),
    ),
    "SsdIndex": (
        """
        big = np.random.default_rng(0).random((1024, 1024, 3), dtype=np.float32)
        args = {32: big[:32, :32].copy(), 1024: big}
        t = big[None, :8, :8].copy()
        def call(small):
            _core.SsdIndex(args[32 if small else 1024]).best_matches(t, k=1)
        """,
        ("image = ", "cannot allocate"),
    ),
    "hashed_index_map": (
        """
        def call(small):
            s = 8 if small else 8192
            _core.hashed_index_map("corner", [2], 1, 1, (0, 0), (s, s))
        """,
        ("rows", "cannot allocate"),
    ),
    "png_decode": (
        f"""
        huge = {_png_declaring(8192, 8192)!r}
        ok = _core.png_encode(np.zeros((4, 4, 3), np.uint8))
        def call(small):
            _core.png_decode(ok if small else huge, 1 << 26)
        """,
        ("cannot allocate",),
    ),
}


@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_refused_allocation_is_an_exception_not_an_abort(kernel):
    body, needles = KERNELS[kernel]
    assert_clean_refusal(run_limited(body), *needles)


@pytest.mark.parametrize("kernel", ["grid_mincut", "hashed_index_map"])
def test_the_same_calls_complete_with_room(kernel):
    """The limit is what makes the calls above fail: with enough headroom they complete (so the tests cannot
    pass by a call that always raises)."""
    body, _ = KERNELS[kernel]
    proc = run_limited(body, headroom=2 << 30)
    assert proc.returncode == 0 and proc.stdout.startswith("COMPLETED"), proc.stdout + proc.stderr


def test_cli_build_under_a_memory_limit_exits_2(tmp_path):
    """`tilesynth build` on a 1024x1024 exemplar in a process that cannot hold the build's buffers (the budget
    check raised out of the way with TILESYNTH_MAX_BYTES): one line naming the allocation, exit 2, no output
    file (it was SIGABRT on an 8192x8192 exemplar)."""
    import numpy as np

    import tilesynth

    ex = tmp_path / "ex.png"
    rng = np.random.default_rng(3)
    tilesynth.save_image(ex, rng.integers(0, 256, (1024, 1024, 3), dtype=np.uint8))
    out = tmp_path / "x.tiles"
    code = _PRELUDE + textwrap.dedent(f"""
        from tilesynth.cli.main import main
        from tilesynth.io.images import load_image
        load_image({str(ex)!r})  # the decoder and its buffers once, before the limit
        resource.setrlimit(resource.RLIMIT_AS, (vm_bytes() + (48 << 20), resource.RLIM_INFINITY))
        sys.exit(main(["build", {str(ex)!r}, "-o", {str(out)!r}, "--seed", "1", "-q"]))
    """)
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=300,
        env={
            "PATH": "/usr/bin:/bin",
            "TILESYNTH_NUM_THREADS": "2",
            "TILESYNTH_MAX_BYTES": str(1 << 50),
            "PYTHONDONTWRITEBYTECODE": "1",
        },
    )
    assert proc.returncode == 2, f"status {proc.returncode}\nstdout: {proc.stdout}\nstderr: {proc.stderr}"
    err = proc.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("tilesynth: error:"), proc.stderr
    assert "allocate" in err[0], err[0]
    assert not out.exists()
    assert not list(tmp_path.glob(".*part*"))
