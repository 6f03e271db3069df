#!/usr/bin/env python3
"""Side-by-side timing of the tilesynth kernels against what a Python user would reach for today.

Three measurements, each run in this one process with the competing methods **interleaved** (every round runs
every method for a short batch, so a slow drift of a shared, noisy host hits all of them alike), after warm-up
calls and with the garbage collector disabled while timing. Tables give the median, the minimum and the
inter-quartile range of the per-call times, and a ratio against the section's baseline. Absolute times on a
shared machine move by 30-40 % between runs; only the ratios measured in the same run are meaningful.

1. ``ssd``   exhaustive SSD of a 3-channel float32 template over every fully-overlapping translation, at
             exemplar/template 128/80, 256/128 and 512/256: ``cv2.matchTemplate(TM_SQDIFF)`` (1 thread
             and OpenCV's default), a numpy FFT loop with the exemplar's spectrum and box sums cached (and
             the same with ``scipy.fft``, ``workers`` 1 and 2), versus ``tilesynth.patch_ssd`` (a) one
             template per call (the exemplar spectrum is built inside every call) and (b) 16 templates per
             call, time / 16. Target: ours >= 2x faster than cv2.matchTemplate at all three sizes.
2. ``cut``   the ω cutting curve at N = 80, 160, 256: PyMaxflow's grid API in total (numpy Kwatra weights,
             graph build, maxflow, get_grid_segments) versus ``tilesynth.omega_cuts`` (weights, graph and
             solve in Rust). Target: ours <= 0.5x PyMaxflow's total at all three sizes.
3. ``synth`` an 8192x8192x3 uint8 output from 16 tiles of 64x64 and a random 128x128 index map:
             ``np.copyto`` of an equally large array (1 and 2 threads), ``np.take`` per 64-row strip (1 and
             2 threads), versus ``tilesynth.tile_copy`` (1 and 2 threads), all into preallocated,
             already-touched arrays. Target: ours (2 threads) >= 0.6x the bandwidth of the 2-thread np.copyto.

Every method is checked against a reference before it is timed. OpenCV (``opencv-python-headless``), PyMaxflow
and scipy are optional: without one, its rows are skipped with a note (``pip install ".[bench]"`` installs
them). If tilesynth itself cannot be imported, only the baselines are timed.

Usage::

    python benches/compare.py                 # full run, about a minute
    python benches/compare.py --quick         # smoke run (fewer rounds)
    python benches/compare.py --only ssd --json figures.json
"""

from __future__ import annotations

import argparse
import gc
import importlib
import json
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import numpy.typing as npt

FloatImage = npt.NDArray[np.float32]
Array = npt.NDArray[Any]


# ------------------------------------------------------------------------------------------ optional imports


def _optional(name: str) -> tuple[ModuleType | None, str]:
    """Import ``name`` if possible; returns the module (or None) and a note on why it is missing."""
    try:
        return importlib.import_module(name), ""
    except Exception as exc:  # ImportError, or a broken binary wheel raising something else
        return None, f"{type(exc).__name__}: {exc}"


cv2, CV2_MISSING = _optional("cv2")
maxflow, MAXFLOW_MISSING = _optional("maxflow")
scipy_fft, SCIPY_MISSING = _optional("scipy.fft")
ts, TILESYNTH_MISSING = _optional("tilesynth")

CV2_DEFAULT_THREADS: int = cv2.getNumThreads() if cv2 is not None else 0
"""OpenCV's thread count before this script changes it (restored after every cv2 batch)."""

REPO = Path(__file__).resolve().parents[1]
BUNDLED_TEXTURE = REPO / "python" / "tilesynth" / "data" / "lettuce-leaves.png"
SHARED_TEXTURE = Path("/work/shared/textures/roof-tiles.png")

SSD_SIZES: tuple[tuple[int, int], ...] = ((128, 80), (256, 128), (512, 256))
SSD_BATCH = 16
SSD_TOLERANCE = 1e-4
"""Largest accepted max|SSD − reference| / max|reference| (tilesynth documents ~1e-6)."""
SSD_TARGET = 2.0

CUT_SIZES: tuple[int, ...] = (80, 160, 256)
CUT_EPS = 1e-6
CUT_BIG = 1e9
CUT_FLOW_RTOL = 1e-6
CUT_TARGET = 0.5

SYNTH_TILE = 64
SYNTH_TILES = 16
SYNTH_GRID = 128
SYNTH_TARGET = 0.6


# --------------------------------------------------------------------------------------------- timing


@dataclass(frozen=True)
class Stats:
    """Summary of one method's per-call times, in seconds."""

    median: float
    min: float
    p25: float
    p75: float
    n: int

    @staticmethod
    def of(times: Sequence[float]) -> Stats:
        """Median, minimum, quartiles and count of ``times`` (needs at least one sample)."""
        if len(times) >= 4:
            q = statistics.quantiles(times, n=4)
            p25, p75 = q[0], q[2]
        else:
            p25, p75 = min(times), max(times)
        return Stats(statistics.median(times), min(times), p25, p75, len(times))

    def as_ms(self) -> dict[str, float | int]:
        """The figures in milliseconds, for the JSON output."""
        return {
            "median_ms": self.median * 1e3,
            "min_ms": self.min * 1e3,
            "p25_ms": self.p25 * 1e3,
            "p75_ms": self.p75 * 1e3,
            "n": self.n,
        }


@dataclass
class Method:
    """One competitor in an interleaved benchmark.

    ``fn`` is called with no arguments; ``pre`` / ``post`` run (untimed) around each of its batches, e.g. to
    set a library's thread count. Each timed sample is divided by ``per_call`` (the number of work items one
    call does, e.g. 16 templates), so the figures are per item.
    """

    name: str
    fn: Callable[[], object]
    pre: Callable[[], None] | None = None
    post: Callable[[], None] | None = None
    per_call: int = 1


@dataclass(frozen=True)
class Plan:
    """How hard to time: rounds of interleaving, minimum samples per method, batch length per round."""

    rounds: int
    min_reps: int
    round_s: float
    warmup: int
    max_per_round: int = 200


def bench_interleaved(
    methods: Sequence[Method], plan: Plan, before_timing: Callable[[], None] | None = None
) -> dict[str, Stats]:
    """Time competing methods in interleaved rounds (alternating order), GC disabled.

    Each method is warmed up (``plan.warmup`` calls) and calibrated by one more call; its batch size is chosen
    so that one batch takes about ``plan.round_s``, with at least ``plan.min_reps`` samples over all rounds.
    ``before_timing`` runs once after the warm-up and calibration calls, right before the timed rounds.
    """
    batch: dict[str, int] = {}
    for m in methods:
        if m.pre:
            m.pre()
        for _ in range(plan.warmup):
            m.fn()
        t0 = time.perf_counter()
        m.fn()
        one = time.perf_counter() - t0
        if m.post:
            m.post()
        floor = -(-plan.min_reps // plan.rounds)
        batch[m.name] = max(floor, min(plan.max_per_round, int(plan.round_s / max(one, 1e-7))))
    if before_timing:
        before_timing()
    samples: dict[str, list[float]] = {m.name: [] for m in methods}
    gc_was_enabled = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        for r in range(plan.rounds):
            for m in methods if r % 2 == 0 else list(methods)[::-1]:
                if m.pre:
                    m.pre()
                out = samples[m.name]
                fn = m.fn
                for _ in range(batch[m.name]):
                    t0 = time.perf_counter()
                    fn()
                    out.append((time.perf_counter() - t0) / m.per_call)
                if m.post:
                    m.post()
    finally:
        if gc_was_enabled:
            gc.enable()
    return {name: Stats.of(ts_) for name, ts_ in samples.items()}


# --------------------------------------------------------------------------------------------- output


def fmt_ms(seconds: float) -> str:
    """Milliseconds with about three significant digits."""
    v = seconds * 1e3
    if v < 10:
        return f"{v:.3f}"
    if v < 100:
        return f"{v:.2f}"
    return f"{v:.1f}"


def fmt_iqr(s: Stats) -> str:
    """``p25-p75`` in milliseconds."""
    return f"{fmt_ms(s.p25)}-{fmt_ms(s.p75)}"


def print_table(title: str, headers: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """A Markdown table with aligned columns."""
    print(f"\n### {title}\n")
    cells = [list(headers)] + [[str(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(headers))]
    print("| " + " | ".join(h.ljust(w) for h, w in zip(headers, widths)) + " |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for r in cells[1:]:
        print("| " + " | ".join(c.ljust(w) for c, w in zip(r, widths)) + " |")
    sys.stdout.flush()


def note(text: str) -> None:
    """A one-line remark under a table (skipped rows, failed checks)."""
    print(f"note: {text}")
    sys.stdout.flush()


@dataclass
class Target:
    """One of the issue's targets and how this run measured against it."""

    name: str
    figures: list[str] = field(default_factory=list)
    status: str = "SKIPPED"
    values: dict[str, float] = field(default_factory=dict)


def decide(target: Target, ok: list[bool], problems: list[str]) -> None:
    """PASS when every size met the target and nothing went wrong, else FALL SHORT (with the reasons)."""
    if problems:
        target.status = "FALL SHORT (" + "; ".join(problems) + ")"
    elif not ok:
        target.status = "SKIPPED (nothing measured)"
    else:
        target.status = "PASS" if all(ok) else "FALL SHORT"


# --------------------------------------------------------------------------------------------- environment


def cpu_model() -> str:
    """The ``model name`` of /proc/cpuinfo (else ``platform.processor()``)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def environment() -> dict[str, Any]:
    """CPU, core count, Python and library versions, thread settings."""

    def version(mod: ModuleType | None, missing: str) -> str:
        return getattr(mod, "__version__", "?") if mod is not None else f"not installed ({missing})"

    scipy_version = "not installed"
    if scipy_fft is not None:
        scipy_version = getattr(importlib.import_module("scipy"), "__version__", "?")
    env: dict[str, Any] = {
        "cpu": cpu_model(),
        "nproc": os.cpu_count(),
        "affinity": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "python": f"{platform.python_implementation()} {platform.python_version()}",
        "platform": platform.platform(),
        "numpy": np.__version__,
        "cv2": version(cv2, CV2_MISSING),
        "cv2_default_threads": CV2_DEFAULT_THREADS if cv2 is not None else None,
        "maxflow": version(maxflow, MAXFLOW_MISSING),
        "scipy": scipy_version,
        "tilesynth": version(ts, TILESYNTH_MISSING),
        "tilesynth_path": getattr(ts, "__file__", None),
        "TILESYNTH_NUM_THREADS": os.environ.get("TILESYNTH_NUM_THREADS"),
    }
    if ts is not None:
        try:
            env["tilesynth_default_threads"] = int(ts._core.resolve_threads(None))
        except Exception as exc:
            env["tilesynth_default_threads"] = f"? ({exc})"
    return env


def print_environment(env: dict[str, Any], texture: str) -> None:
    """The environment block at the top of the output."""
    print("# tilesynth benches/compare.py")
    print(f"# cpu: {env['cpu']}  nproc={env['nproc']}  affinity={env['affinity']}")
    print(f"# {env['python']} on {env['platform']}")
    print(
        f"# numpy {env['numpy']}, cv2 {env['cv2']}"
        + (f" (default threads {env['cv2_default_threads']})" if cv2 is not None else "")
        + f", maxflow {env['maxflow']}, scipy {env['scipy']}"
    )
    threads = env.get("tilesynth_default_threads")
    print(
        f"# tilesynth {env['tilesynth']}"
        + (f" from {env['tilesynth_path']}, default threads {threads}" if ts is not None else "")
        + f", TILESYNTH_NUM_THREADS={env['TILESYNTH_NUM_THREADS']}"
    )
    print(f"# texture: {texture}")
    print("# only ratios within this run are meaningful (absolute times move 30-40 % between runs)")
    sys.stdout.flush()


# --------------------------------------------------------------------------------------------- inputs


def load_texture(path: Path) -> FloatImage:
    """An RGB image file as float32 ``(H, W, 3)`` in [0, 1]."""
    from PIL import Image

    with Image.open(path) as im:
        rgb = im.convert("RGB")
        arr = np.asarray(rgb, dtype=np.float32)
    return np.ascontiguousarray(arr / np.float32(255.0))


def pick_texture(explicit: str | None) -> Path:
    """``--texture``, else the shared 512x512 roof-tiles texture, else the exemplar bundled with tilesynth."""
    if explicit:
        return Path(explicit)
    if SHARED_TEXTURE.is_file():
        return SHARED_TEXTURE
    if BUNDLED_TEXTURE.is_file():
        return BUNDLED_TEXTURE
    if ts is not None:
        from importlib.resources import files

        resource = files("tilesynth") / "data" / "lettuce-leaves.png"
        if resource.is_file():
            return Path(str(resource))
    raise FileNotFoundError(f"no texture: neither {SHARED_TEXTURE} nor {BUNDLED_TEXTURE} exists")


def at_least(img: FloatImage, n: int) -> FloatImage:
    """``img`` reflect-padded (bottom and right) to at least ``n x n``."""
    ph, pw = max(0, n - img.shape[0]), max(0, n - img.shape[1])
    if ph == 0 and pw == 0:
        return img
    return np.ascontiguousarray(np.pad(img, ((0, ph), (0, pw), (0, 0)), mode="reflect"))


def random_crop(img: Array, h: int, w: int, rng: np.random.Generator) -> Array:
    """A C-contiguous ``h x w`` crop at a uniformly random position."""
    y = int(rng.integers(0, img.shape[0] - h + 1))
    x = int(rng.integers(0, img.shape[1] - w + 1))
    return np.ascontiguousarray(img[y : y + h, x : x + w])


# --------------------------------------------------------------------------------------------- 1. SSD


def boxsum(a: Array, h: int, w: int) -> npt.NDArray[np.float64]:
    """Sum of the 2-d array ``a`` over every ``h x w`` window ('valid'), via a float64 integral image."""
    ii = np.zeros((a.shape[0] + 1, a.shape[1] + 1), np.float64)
    np.cumsum(np.cumsum(a, 0, dtype=np.float64), 1, out=ii[1:, 1:])
    return ii[h:, w:] - ii[:-h, w:] - ii[h:, :-w] + ii[:-h, :-w]


class FFTCachedSSD:
    """SSD maps by FFT with the exemplar's spectrum and box sum of I² computed once.

    Per template: one rfft2 of the zero-padded template (FFT size = exemplar size, which is exact for 'valid'
    correlation), a multiply-accumulate over channels in the frequency domain, one irfft2, and
    ``SSD = ΣT² + boxsum(I²) − 2·corr``. Computes in the exemplar's precision (float32, or float64 for a
    reference). ``backend`` is ``numpy.fft`` or ``scipy.fft`` (the latter with ``workers`` threads).
    """

    def __init__(
        self, image: Array, h: int, w: int, backend: ModuleType = np.fft, workers: int | None = None
    ) -> None:
        self.shape = (image.shape[0], image.shape[1])
        self.out = (image.shape[0] - h + 1, image.shape[1] - w + 1)
        kw: dict[str, int] = {} if workers is None else {"workers": workers}
        self._rfft2 = partial(backend.rfft2, s=self.shape, axes=(-2, -1), **kw)
        self._irfft2 = partial(backend.irfft2, s=self.shape, axes=(-2, -1), **kw)
        channels_first = np.ascontiguousarray(image.transpose(2, 0, 1))
        self.spectrum = self._rfft2(channels_first)
        self.i2 = boxsum((image * image).sum(axis=2), h, w).astype(image.dtype)

    def __call__(self, template: Array) -> Array:
        tc = np.ascontiguousarray(template.transpose(2, 0, 1))
        ft = self._rfft2(tc)
        np.conj(ft, out=ft)
        acc = self.spectrum[0] * ft[0]
        for c in range(1, ft.shape[0]):
            acc += self.spectrum[c] * ft[c]
        corr = self._irfft2(acc)
        flat = tc.ravel()
        t2 = np.einsum("i,i->", flat, flat)  # no BLAS
        return t2 + self.i2 - 2.0 * corr[: self.out[0], : self.out[1]]


def rel_err(a: Array, ref: Array) -> float:
    """max|a − ref| / max|ref|."""
    return float(np.abs(a.astype(np.float64) - ref).max() / max(float(np.abs(ref).max()), 1e-300))


@dataclass
class SsdCandidate:
    """An SSD method under test: ``maps()`` returns all templates' maps (checked), ``method`` is timed."""

    method: Method
    maps: Callable[[], Array]
    ours: str | None = None  # "a" / "b" with the thread count, for the targets
    threads: int | None = None


def cv2_threads(n: int) -> tuple[Callable[[], None], Callable[[], None]]:
    """pre/post hooks that run a batch with ``cv2.setNumThreads(n)`` and then restore the default."""
    assert cv2 is not None

    def pre() -> None:
        cv2.setNumThreads(n)

    def post() -> None:
        cv2.setNumThreads(CV2_DEFAULT_THREADS)

    return pre, post


def cycle(call: Callable[[Array], object], items: Sequence[Array]) -> Callable[[], object]:
    """A no-argument function that applies ``call`` to the next item of ``items`` on each call."""
    state = [0]
    n = len(items)

    def run() -> object:
        i = state[0]
        state[0] = i + 1 if i + 1 < n else 0
        return call(items[i])

    return run


NUMPY_FFT_NAME = "numpy fft, exemplar spectrum + box sums cached"


def ssd_candidates(image: FloatImage, templates: FloatImage) -> list[SsdCandidate]:
    """Every SSD method available here, for one exemplar and a stack of templates."""
    m = templates.shape[1]
    tlist = [templates[k] for k in range(templates.shape[0])]
    out: list[SsdCandidate] = []

    if cv2 is not None:
        for label, n in (("1 thr", 1), (f"default, {CV2_DEFAULT_THREADS} thr", CV2_DEFAULT_THREADS)):
            pre, post = cv2_threads(n)

            def match(t: Array) -> Array:
                return cv2.matchTemplate(image, t, cv2.TM_SQDIFF)

            out.append(
                SsdCandidate(
                    Method(f"cv2.matchTemplate ({label})", cycle(match, tlist), pre, post),
                    lambda match=match: np.stack([match(t) for t in tlist]),
                )
            )

    np_cached = FFTCachedSSD(image, m, m, np.fft)
    out.append(
        SsdCandidate(
            Method(NUMPY_FFT_NAME, cycle(np_cached, tlist)),
            lambda: np.stack([np_cached(t) for t in tlist]),
        )
    )
    if scipy_fft is not None:
        for workers in (1, 2):
            cached = FFTCachedSSD(image, m, m, scipy_fft, workers)
            out.append(
                SsdCandidate(
                    Method(f"scipy.fft (workers={workers}), cached, as numpy", cycle(cached, tlist)),
                    lambda cached=cached: np.stack([cached(t) for t in tlist]),
                )
            )

    if ts is not None:
        for threads in (1, 2):

            def single(t: Array, threads: int = threads) -> Array:
                return ts.patch_ssd(image, t, threads=threads)

            out.append(
                SsdCandidate(
                    Method(f"ours (a) patch_ssd, 1 template/call, threads={threads}", cycle(single, tlist)),
                    lambda single=single: np.stack([single(t) for t in tlist]),
                    "a",
                    threads,
                )
            )
        index = ts.SsdIndex(image) if hasattr(ts, "SsdIndex") else None
        for threads in (1, 2) if index is not None else ():

            def cached_one(t: Array, threads: int = threads, index: Any = index) -> Array:
                return index.ssd(t, threads=threads)

            out.append(
                SsdCandidate(
                    Method(
                        f"ours (c) SsdIndex.ssd, index built once, 1 template/call, threads={threads}",
                        cycle(cached_one, tlist),
                    ),
                    lambda cached_one=cached_one: np.stack([cached_one(t) for t in tlist]),
                    "c",
                    threads,
                )
            )
        for threads in (1, 2):

            def batch(threads: int = threads) -> Array:
                return ts.patch_ssd(image, templates, threads=threads)

            out.append(
                SsdCandidate(
                    Method(
                        f"ours (b) patch_ssd, {len(tlist)} templates/call ÷ {len(tlist)}, threads={threads}",
                        batch,
                        per_call=len(tlist),
                    ),
                    batch,
                    "b",
                    threads,
                )
            )
    return out


def run_ssd(texture: FloatImage, plan: Plan, report: dict[str, Any], targets: list[Target]) -> None:
    """Section 1: exhaustive SSD, ms per template, speed-up against cv2.matchTemplate (1 thread)."""
    print("\n## 1. Exhaustive SSD (3-ch float32), ms per template")
    if cv2 is None:
        note(f"cv2 rows skipped: opencv-python-headless is not importable ({CV2_MISSING})")
    if scipy_fft is None:
        note(f"scipy.fft rows skipped: scipy is not importable ({SCIPY_MISSING})")
    if ts is None:
        note(f"tilesynth rows skipped: the package is not importable ({TILESYNTH_MISSING})")
    baseline_name = "cv2.matchTemplate (1 thr)" if cv2 is not None else NUMPY_FFT_NAME
    rng = np.random.default_rng(1234)
    section: list[dict[str, Any]] = []
    # speed-ups of ours against cv2, keyed by (variant, threads), one entry per size
    speedups: dict[tuple[str, int], list[tuple[str, float | None, str]]] = {}
    rows: list[list[object]] = []
    context: list[str] = []
    for n, m in SSD_SIZES:
        size = f"{n}/{m}"
        image = random_crop(texture, n, n, rng)
        templates = np.stack([random_crop(texture, m, m, rng) for _ in range(SSD_BATCH)])
        ref64 = FFTCachedSSD(image.astype(np.float64), m, m, np.fft)
        refs = np.stack([ref64(t.astype(np.float64)) for t in templates])
        ref_argmin = refs.reshape(SSD_BATCH, -1).argmin(axis=1)
        candidates = ssd_candidates(image, templates)

        checks: dict[str, dict[str, Any]] = {}
        cv2_maps: Array | None = None
        live: list[SsdCandidate] = []
        for cand in candidates:
            name = cand.method.name
            try:
                if cand.method.pre:
                    cand.method.pre()
                try:
                    maps = np.asarray(cand.maps())
                finally:
                    if cand.method.post:
                        cand.method.post()
            except Exception as exc:
                note(f"{size}: {name} raised {type(exc).__name__}: {exc}; not timed")
                checks[name] = {"error": f"{type(exc).__name__}: {exc}"}
                continue
            if maps.shape != refs.shape:
                note(f"{size}: {name} returned shape {maps.shape}, expected {refs.shape}; not timed")
                checks[name] = {"error": f"shape {maps.shape}"}
                continue
            if cv2_maps is None and name.startswith("cv2.matchTemplate"):
                cv2_maps = maps
            err_cv2 = None
            if cv2_maps is not None:
                err_cv2 = max(rel_err(maps[k], cv2_maps[k]) for k in range(SSD_BATCH))
            err_ref = max(rel_err(maps[k], refs[k]) for k in range(SSD_BATCH))
            argmin_ok = int((maps.reshape(SSD_BATCH, -1).argmin(axis=1) == ref_argmin).sum())
            agree = err_ref <= SSD_TOLERANCE and (err_cv2 is None or err_cv2 <= SSD_TOLERANCE)
            checks[name] = {
                "err_vs_cv2": err_cv2,
                "err_vs_f64": err_ref,
                "argmin_ok": argmin_ok,
                "agree": agree,
            }
            if not agree:
                note(f"{size}: {name} disagrees (vs cv2 {err_cv2}, vs float64 {err_ref:.2e}); timed anyway")
            live.append(cand)

        stats = bench_interleaved([c.method for c in live], plan)
        base = stats.get(baseline_name)
        for cand in live:
            name = cand.method.name
            s = stats[name]
            chk = checks[name]
            speedup = base.median / s.median if base else None
            err_cv2 = chk["err_vs_cv2"]
            rows.append(
                [
                    f"{n}x{n} / {m}x{m}",
                    name,
                    fmt_ms(s.median),
                    fmt_ms(s.min),
                    fmt_iqr(s),
                    s.n,
                    "-" if err_cv2 is None else f"{err_cv2:.1e}",
                    f"{chk['err_vs_f64']:.1e}",
                    f"{chk['argmin_ok']}/{SSD_BATCH}",
                    "-" if speedup is None else f"{speedup:.2f}x",
                ]
            )
            section.append({"size": size, "method": name, **s.as_ms(), **chk, "speedup_vs_baseline": speedup})
        for cand in candidates:
            if cand.ours is None:
                continue
            name = cand.method.name
            key = (cand.ours, cand.threads or 0)
            chk = checks[name]
            if "error" in chk:
                speedups.setdefault(key, []).append((size, None, "error: " + chk["error"]))
                continue
            cv2_name = "cv2.matchTemplate (1 thr)"
            if cand.threads != 1:
                cv2_name = f"cv2.matchTemplate (default, {CV2_DEFAULT_THREADS} thr)"
            cv2_ref = stats.get(cv2_name)
            value = cv2_ref.median / stats[name].median if cv2_ref else None
            speedups.setdefault(key, []).append((size, value, "" if chk["agree"] else "results disagree"))
        ffts = [c.method.name for c in live if c.ours is None and not c.method.name.startswith("cv2")]
        best_fft = min(ffts, key=lambda name: stats[name].median)
        for variant in ("a", "b", "c"):
            mine = [c.method.name for c in live if c.ours == variant]
            if mine:
                best = min(mine, key=lambda name: stats[name].median)
                context.append(
                    f"{size}: speed-up of the fastest ours ({variant}) over the best cached-FFT baseline = "
                    f"{stats[best_fft].median / stats[best].median:.2f}x ({best} vs {best_fft})"
                )

    print_table(
        f"SSD, ms per template; speed-up = {baseline_name} time / method time",
        [
            "exemplar / template",
            "method",
            "median ms",
            "min ms",
            "IQR ms",
            "n",
            "err vs cv2",
            "err vs f64",
            "argmin ok",
            "speed-up",
        ],
        rows,
    )
    print(
        f"err = max|SSD − other| / max|other| over the templates (required <= {SSD_TOLERANCE:g}); "
        "argmin ok = same best translation as the float64 reference (near-ties may differ)."
    )
    for line in context:
        print(line)
    report["ssd"] = section

    variants = {
        "a": "one template per call (exemplar spectrum built in every call)",
        "b": f"{SSD_BATCH} templates per call, time / {SSD_BATCH} (amortised)",
        "c": "exemplar index (spectrum) built once, one template per call",
    }
    for variant in ("a", "b", "c"):
        for threads in (1, 2):
            default = f"({CV2_DEFAULT_THREADS} thr)" if cv2 is not None else "threads"
            vs = "cv2 1 thr" if threads == 1 else f"cv2 default {default}"
            target = Target(
                f"SSD ({variant}) {variants[variant]}, ours threads={threads} vs {vs}: "
                f">= {SSD_TARGET:g}x faster"
            )
            if ts is None or cv2 is None:
                target.status = "SKIPPED (" + ("tilesynth" if ts is None else "cv2") + " not importable)"
                targets.append(target)
                continue
            ok: list[bool] = []
            problems: list[str] = []
            for size, value, problem in speedups.get((variant, threads), []):
                if value is None:
                    target.figures.append(f"{size} -")
                    problems.append(f"{size}: {problem or 'not measured'}")
                    continue
                target.figures.append(f"{size} {value:.2f}x")
                target.values[size] = value
                ok.append(value >= SSD_TARGET)
                if problem:
                    problems.append(f"{size}: {problem}")
            decide(target, ok, problems)
            targets.append(target)


# --------------------------------------------------------------------------------------------- 2. cut

RIGHT = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]])
DOWN = np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]])


def omega_pair(texture: FloatImage, n: int, rng: np.random.Generator) -> tuple[FloatImage, FloatImage]:
    """Intermediate tile A (the four quadrants of four random crops, as in an ω-tile set) and a crop B."""
    p = [random_crop(texture, n, n, rng) for _ in range(4)]
    h = n // 2
    a = np.empty((n, n, texture.shape[2]), np.float32)
    a[:h, :h] = p[0][h:, h:]
    a[:h, h:] = p[2][h:, :h]
    a[h:, :h] = p[1][:h, h:]
    a[h:, h:] = p[3][:h, :h]
    return a, random_crop(texture, n, n, rng)


def omega_masks(n: int) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """Pixels inside the inscribed circle, and the sink cross (rows/cols n/2−1, n/2) inside it."""
    c = (n - 1) / 2.0
    yy, xx = np.mgrid[:n, :n]
    inside = (yy - c) ** 2 + (xx - c) ** 2 <= (n / 2.0) ** 2
    cross = np.zeros((n, n), bool)
    cross[n // 2 - 1 : n // 2 + 1, :] = True
    cross[:, n // 2 - 1 : n // 2 + 1] = True
    return inside, cross & inside


def kwatra_numpy(
    a: FloatImage, b: FloatImage, inside: npt.NDArray[np.bool_]
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Kwatra's seam weights in float64: ``wx[y,x]`` for edge (y,x)–(y,x+1), ``wy[y,x]`` for (y,x)–(y+1,x).

    ``w = (|A−B|(s) + |A−B|(t)) / (|gA(s)|+|gA(t)|+|gB(s)|+|gB(t)| + eps)``, |·| the L2 norm over channels,
    g the forward difference along s→t (0 past the border); edges with both ends outside the circle get 0.
    """
    a64 = a.astype(np.float64)
    b64 = b.astype(np.float64)
    diff = np.sqrt(((a64 - b64) ** 2).sum(-1))
    out: list[npt.NDArray[np.float64]] = []
    for axis in (1, 0):
        lo = (slice(None), slice(None, -1)) if axis == 1 else (slice(None, -1), slice(None))
        hi = (slice(None), slice(1, None)) if axis == 1 else (slice(1, None), slice(None))
        ga = np.zeros_like(diff)
        gb = np.zeros_like(diff)
        ga[lo] = np.sqrt((np.diff(a64, axis=axis) ** 2).sum(-1))
        gb[lo] = np.sqrt((np.diff(b64, axis=axis) ** 2).sum(-1))
        w = np.zeros_like(diff)
        w[lo] = (diff[lo] + diff[hi]) / (ga[lo] + ga[hi] + gb[lo] + gb[hi] + CUT_EPS)
        both_out = np.zeros_like(inside)
        both_out[lo] = ~inside[lo] & ~inside[hi]
        w[both_out] = 0.0
        out.append(w)
    return out[0], out[1]


class PyMaxflowCut:
    """The ω cut with PyMaxflow's grid API, recording the time of each stage of every call."""

    STAGES = ("weights (numpy)", "graph build", "maxflow", "get_grid_segments")

    def __init__(
        self, a: FloatImage, b: FloatImage, inside: npt.NDArray[np.bool_], sink: npt.NDArray[np.bool_]
    ) -> None:
        self.a, self.b, self.inside = a, b, inside
        self.source_caps = np.where(inside, 0.0, CUT_BIG)
        self.sink_caps = np.where(sink, CUT_BIG, 0.0)
        self.stage_times: list[tuple[float, float, float, float]] = []
        self.wx: npt.NDArray[np.float64] | None = None
        self.wy: npt.NDArray[np.float64] | None = None

    def __call__(self) -> tuple[float, npt.NDArray[np.bool_]]:
        assert maxflow is not None
        n = self.a.shape[0]
        t0 = time.perf_counter()
        wx, wy = kwatra_numpy(self.a, self.b, self.inside)
        t1 = time.perf_counter()
        g = maxflow.Graph[float](n * n, 4 * n * n)
        nodes = g.add_grid_nodes((n, n))
        g.add_grid_edges(nodes, weights=wx, structure=RIGHT, symmetric=True)
        g.add_grid_edges(nodes, weights=wy, structure=DOWN, symmetric=True)
        g.add_grid_tedges(nodes, self.source_caps, self.sink_caps)
        t2 = time.perf_counter()
        flow = g.maxflow()
        t3 = time.perf_counter()
        seg = g.get_grid_segments(nodes)
        t4 = time.perf_counter()
        self.stage_times.append((t1 - t0, t2 - t1, t3 - t2, t4 - t3))
        self.wx, self.wy = wx, wy
        return float(flow), seg


def cut_value(label: npt.NDArray[np.bool_], wx: Array, wy: Array) -> float:
    """The sum of the weights of the edges whose ends carry different labels."""
    across = (wx[:, :-1] * (label[:, :-1] != label[:, 1:])).sum()
    down = (wy[:-1, :] * (label[:-1, :] != label[1:, :])).sum()
    return float(across + down)


def run_cut(texture: FloatImage, plan: Plan, report: dict[str, Any], targets: list[Target]) -> None:
    """Section 2: the ω cutting curve, PyMaxflow's grid API in total versus ``omega_cuts``."""
    print("\n## 2. ω cutting curve (weights + graph + max-flow + labels), ms per tile")
    if maxflow is None:
        note(f"PyMaxflow rows skipped: maxflow is not importable ({MAXFLOW_MISSING})")
    if ts is None:
        note(f"tilesynth rows skipped: the package is not importable ({TILESYNTH_MISSING})")
    target = Target(f"ω cut: ours omega_cuts(threads=1) total <= {CUT_TARGET:g}x PyMaxflow grid API total")
    ok: list[bool] = []
    problems: list[str] = []
    context: list[str] = []
    rng = np.random.default_rng(2024)
    rows: list[list[object]] = []
    section: list[dict[str, Any]] = []
    total_name = "PyMaxflow grid API, total"
    ours_name = "ours omega_cuts(A[None], B[None], threads=1)"
    ours2_name = "ours omega_cuts(A[None], B[None], threads=2) [context]"
    for n in CUT_SIZES:
        a, b = omega_pair(texture, n, rng)
        inside, sink = omega_masks(n)
        methods: list[Method] = []
        info: dict[str, str] = {}
        pm: PyMaxflowCut | None = None
        pm_flow = 0.0
        pm_seg = np.zeros((n, n), bool)
        if maxflow is not None:
            pm = PyMaxflowCut(a, b, inside, sink)
            pm_flow, pm_seg = pm()
            assert pm.wx is not None and pm.wy is not None
            hard_ok = not pm_seg[~inside].any() and bool(pm_seg[sink].all())
            cv = cut_value(pm_seg, pm.wx, pm.wy)
            if not hard_ok or abs(cv - pm_flow) > CUT_FLOW_RTOL * max(abs(pm_flow), 1.0):
                note(f"N={n}: PyMaxflow self-check failed (constraints {hard_ok}, cut {cv}, flow {pm_flow})")
            info[total_name] = f"{pm_flow:.6f}"
            methods.append(Method(total_name, pm))
        ours_ok = False
        if ts is not None:
            a4, b4 = a[None], b[None]

            def ours(a4: FloatImage = a4, b4: FloatImage = b4) -> object:
                return ts.omega_cuts(a4, b4, threads=1, keep_border=False)

            try:
                masks, costs = ts.omega_cuts(a4, b4, threads=1, keep_border=False)
                flow = float(np.asarray(costs)[0])
                mask = np.asarray(masks)[0]
            except Exception as exc:
                note(f"N={n}: {ours_name} raised {type(exc).__name__}: {exc}; not timed")
                problems.append(f"N={n}: error {type(exc).__name__}")
            else:
                info[ours_name] = f"{flow:.6f}"
                if mask.shape != (n, n) or mask[~inside].any() or not mask[sink].all():
                    problems.append(f"N={n}: mask violates the hard constraints")
                elif pm is not None and pm.wx is not None and pm.wy is not None:
                    rel = abs(flow - pm_flow) / max(abs(pm_flow), 1e-300)
                    own_cut = cut_value(mask, pm.wx, pm.wy)
                    differ = int((mask != pm_seg).sum())
                    print(
                        f"check N={n}: flow ours {flow:.9f}, PyMaxflow {pm_flow:.9f}, rel diff {rel:.1e} "
                        f"(required <= {CUT_FLOW_RTOL:g}); cut of our mask on the numpy weights "
                        f"{own_cut:.9f}; labels differing {differ} (only ties of equal cost may differ)"
                    )
                    if rel > CUT_FLOW_RTOL:
                        problems.append(f"N={n}: flow differs by {rel:.1e} relative")
                ours_ok = True
                methods.append(Method(ours_name, ours))

                def ours2(a4: FloatImage = a4, b4: FloatImage = b4) -> object:
                    return ts.omega_cuts(a4, b4, threads=2, keep_border=False)

                methods.append(Method(ours2_name, ours2))
        if not methods:
            continue

        def reset(pm: PyMaxflowCut | None = pm) -> None:
            if pm is not None:
                pm.stage_times.clear()

        stats = bench_interleaved(methods, plan, before_timing=reset)
        base = stats.get(total_name)
        for m in methods:
            s = stats[m.name]
            ratio = s.median / base.median if base else None
            rows.append(
                [
                    n,
                    m.name,
                    fmt_ms(s.median),
                    fmt_ms(s.min),
                    fmt_iqr(s),
                    s.n,
                    info.get(m.name, "-"),
                    "-" if ratio is None else f"{ratio:.3f}",
                ]
            )
            section.append(
                {"N": n, "method": m.name, **s.as_ms(), "flow": info.get(m.name), "time_vs_total": ratio}
            )
        if pm is None or base is None:
            continue
        per_stage = [Stats.of(times) for times in zip(*pm.stage_times)]
        for stage, s in zip(PyMaxflowCut.STAGES, per_stage):
            share = s.median / base.median
            rows.append(
                [
                    n,
                    f"  PyMaxflow stage: {stage}",
                    fmt_ms(s.median),
                    fmt_ms(s.min),
                    fmt_iqr(s),
                    s.n,
                    "",
                    f"{share:.3f}",
                ]
            )
            section.append(
                {"N": n, "method": f"PyMaxflow stage: {stage}", **s.as_ms(), "time_vs_total": share}
            )
        if ours_ok:
            ours_s = stats[ours_name]
            ratio = ours_s.median / base.median
            target.figures.append(f"N={n} {ratio:.3f}x")
            target.values[f"N={n}"] = ratio
            ok.append(ratio <= CUT_TARGET)
            maxflow_only = per_stage[2].median
            context.append(
                f"N={n}: ours {fmt_ms(ours_s.median)} ms = {ratio:.3f}x PyMaxflow's total and "
                f"{ours_s.median / maxflow_only:.3f}x its maxflow() alone ({fmt_ms(maxflow_only)} ms)"
            )
            target.values[f"N={n} vs maxflow only"] = ours_s.median / maxflow_only
    if rows:
        print_table(
            "ω cut, ms per tile; ratio = method time / PyMaxflow total (stages: share of the total)",
            ["N", "method", "median ms", "min ms", "IQR ms", "n", "flow", "ratio"],
            rows,
        )
    for line in context:
        print(line)
    report["cut"] = section
    if maxflow is None or ts is None:
        target.status = "SKIPPED (" + ("PyMaxflow" if maxflow is None else "tilesynth") + " not importable)"
    else:
        decide(target, ok, problems)
    targets.append(target)


# --------------------------------------------------------------------------------------------- 3. synthesis


def run_synth(texture: FloatImage, plan: Plan, report: dict[str, Any], targets: list[Target]) -> None:
    """Section 3: tile copy into an 8192x8192x3 uint8 output, GB/s against np.copyto with two threads."""
    size = SYNTH_TILE * SYNTH_GRID
    nbytes = size * size * 3
    print(
        f"\n## 3. Synthesis: {size}x{size}x3 uint8 ({nbytes / 1e6:.1f} MB written) from {SYNTH_TILES} tiles "
        f"of {SYNTH_TILE}x{SYNTH_TILE}, random {SYNTH_GRID}x{SYNTH_GRID} index map"
    )
    if ts is None:
        note(f"tilesynth rows skipped: the package is not importable ({TILESYNTH_MISSING})")
    rng = np.random.default_rng(5)
    tex8 = np.rint(texture * 255.0).astype(np.uint8)
    atlas = np.stack([random_crop(tex8, SYNTH_TILE, SYNTH_TILE, rng) for _ in range(SYNTH_TILES)])
    index_map = rng.integers(0, SYNTH_TILES, size=(SYNTH_GRID, SYNTH_GRID)).astype(np.int32)
    atlas_t = np.ascontiguousarray(atlas.transpose(1, 0, 2, 3))  # (th, K, tw, C) for np.take along axis 1

    src = np.full((size, size, 3), 7, np.uint8)
    dst = np.zeros_like(src)
    out_take = np.ones_like(src)  # allocated and touched: no page faults while timing
    out_ours = np.ones_like(src)
    take5 = out_take.reshape(SYNTH_GRID, SYNTH_TILE, SYNTH_GRID, SYNTH_TILE, 3)
    pool = ThreadPoolExecutor(2)
    half = size // 2
    g_half = SYNTH_GRID // 2

    def copy_1t() -> None:
        np.copyto(dst, src)

    def copy_part(rows: slice) -> None:
        np.copyto(dst[rows], src[rows])

    def copy_2t() -> None:
        list(pool.map(copy_part, (slice(0, half), slice(half, size))))

    def take_rows(lo: int, hi: int, out5: Array = take5) -> None:
        for i in range(lo, hi):
            np.take(atlas_t, index_map[i], axis=1, out=out5[i], mode="clip")

    def take_1t() -> None:
        take_rows(0, SYNTH_GRID)

    def take_2t() -> None:
        list(pool.map(lambda bounds: take_rows(*bounds), ((0, g_half), (g_half, SYNTH_GRID))))

    methods = [
        Method("np.copyto 201 MB, 2 threads (two halves)", copy_2t),
        Method("np.copyto 201 MB, 1 thread", copy_1t),
        Method("np.take per 64-row strip, 2 threads", take_2t),
        Method("np.take per 64-row strip, 1 thread", take_1t),
    ]
    baseline = methods[0].name
    target = Target(f"synthesis: ours tile_copy(threads=2) >= {SYNTH_TARGET:g}x the GB/s of 2-thread copyto")
    problems: list[str] = []
    checks: dict[str, bool] = {}
    try:
        take_1t()
        ys = rng.integers(0, size, 4096)
        xs = rng.integers(0, size, 4096)
        direct = atlas[index_map[ys // SYNTH_TILE, xs // SYNTH_TILE], ys % SYNTH_TILE, xs % SYNTH_TILE]
        checks["np.take (1 thread) matches atlas[map[y//64, x//64], y%64, x%64] on 4096 pixels"] = bool(
            np.array_equal(out_take[ys, xs], direct)
        )
        out_ours[...] = 1
        take_rows(0, SYNTH_GRID, out_ours.reshape(take5.shape))
        checks["np.take 2-thread split reproduces the 1-thread output (same code path)"] = bool(
            np.array_equal(out_ours, out_take)
        )
        if ts is not None:
            for threads in (2, 1):
                name = f"ours tile_copy(threads={threads})"

                def ours(threads: int = threads) -> object:
                    return ts.tile_copy(atlas, index_map, out_ours, threads=threads)

                try:
                    out_ours[...] = 0
                    ours()
                    same = bool(np.array_equal(out_ours, out_take))
                except Exception as exc:
                    note(f"{name} raised {type(exc).__name__}: {exc}; not timed")
                    problems.append(f"threads={threads}: error {type(exc).__name__}")
                    continue
                checks[f"{name} equals np.take"] = same
                if not same:
                    problems.append(f"threads={threads}: output differs from np.take")
                methods.append(Method(name, ours))
        for what, good in checks.items():
            print(f"check: {what}: {'yes' if good else 'NO'}")

        stats = bench_interleaved(methods, plan)
    finally:
        pool.shutdown()
    base = stats[baseline]
    rows: list[list[object]] = []
    section: list[dict[str, Any]] = []
    for m in methods:
        s = stats[m.name]
        ratio = base.median / s.median
        rows.append(
            [
                m.name,
                fmt_ms(s.median),
                fmt_ms(s.min),
                fmt_iqr(s),
                s.n,
                f"{nbytes / s.median / 1e9:.2f}",
                f"{nbytes / s.min / 1e9:.2f}",
                f"{ratio:.3f}",
            ]
        )
        section.append(
            {
                "method": m.name,
                **s.as_ms(),
                "gbps_median": nbytes / s.median / 1e9,
                "gbps_best": nbytes / s.min / 1e9,
                "bandwidth_vs_copyto_2t": ratio,
            }
        )
    print_table(
        f"synthesis {size}x{size}x3 uint8; GB/s = output bytes / time; ratio = GB/s / GB/s of {baseline}",
        ["method", "median ms", "min ms", "IQR ms", "n", "GB/s (median)", "GB/s (best)", "ratio"],
        rows,
    )
    print("np.copyto also reads 201 MB (twice the traffic of a tile copy, whose atlas stays in cache).")
    report["synth"] = {"rows": section, "checks": checks, "output_bytes": nbytes}
    if ts is None:
        target.status = "SKIPPED (tilesynth not importable)"
    else:
        ok: list[bool] = []
        s2 = stats.get("ours tile_copy(threads=2)")
        if s2 is not None:
            ratio = base.median / s2.median
            ours_gbps, base_gbps = nbytes / s2.median / 1e9, nbytes / base.median / 1e9
            target.figures.append(f"{ours_gbps:.2f} vs {base_gbps:.2f} GB/s = {ratio:.3f}x")
            target.values["ratio"] = ratio
            ok.append(ratio >= SYNTH_TARGET)
        s1 = stats.get("ours tile_copy(threads=1)")
        if s1 is not None:
            one = stats["np.copyto 201 MB, 1 thread"]
            target.figures.append(f"context: threads=1 gets {one.median / s1.median:.3f}x 1-thread copyto")
        decide(target, ok, problems)
    targets.append(target)
    src = dst = out_take = out_ours = None  # free the buffers before the next bench


# --------------------------------------------------------------------------------------------- main

PLANS: dict[str, dict[bool, Plan]] = {
    # full runs: about 40 ms per method per round; quick runs: a handful of samples each
    "ssd": {False: Plan(rounds=20, min_reps=30, round_s=0.04, warmup=3), True: Plan(4, 4, 0.015, 1)},
    "cut": {False: Plan(rounds=16, min_reps=24, round_s=0.04, warmup=3), True: Plan(4, 4, 0.015, 1)},
    "synth": {False: Plan(rounds=12, min_reps=20, round_s=0.04, warmup=2), True: Plan(3, 3, 0.0, 1)},
}
SECTIONS: dict[str, Callable[[FloatImage, Plan, dict[str, Any], list[Target]], None]] = {
    "ssd": run_ssd,
    "cut": run_cut,
    "synth": run_synth,
}


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    """Command-line options."""
    p = argparse.ArgumentParser(
        description="Time the tilesynth kernels side by side with OpenCV, numpy FFT, PyMaxflow and numpy.",
    )
    p.add_argument("--quick", action="store_true", help="fewer rounds: a smoke run (well under a minute)")
    p.add_argument(
        "--only",
        action="append",
        choices=sorted(SECTIONS),
        help="run only this measurement (repeatable); default: all three",
    )
    p.add_argument("--json", metavar="PATH", help="also write every figure (ms, ratios, checks) as JSON")
    p.add_argument(
        "--texture",
        metavar="PATH",
        help=f"RGB texture for the inputs (default: {SHARED_TEXTURE} if present, else the bundled exemplar)",
    )
    return p.parse_args(argv)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the selected measurements, print the tables and the summary of targets; returns the exit status."""
    args = parse_args(argv)
    started = time.perf_counter()
    texture_path = pick_texture(args.texture)
    texture = load_texture(texture_path)
    source = f"{texture_path} ({texture.shape[1]}x{texture.shape[0]})"
    if min(texture.shape[:2]) < 512:
        source += ", reflect-padded to 512x512"
    texture = at_least(texture, 512)
    env = environment()
    print_environment(env, source)
    if ts is None:
        print(f"# tilesynth is not importable ({TILESYNTH_MISSING}); only the baselines are timed")

    report: dict[str, Any] = {"environment": env, "texture": source, "quick": args.quick}
    targets: list[Target] = []
    for name in args.only or list(SECTIONS):
        SECTIONS[name](texture, PLANS[name][args.quick], report, targets)

    finish(targets, report, started, args.quick, args.json)
    return 0


def finish(
    targets: list[Target], report: dict[str, Any], started: float, quick: bool, json_path: str | None
) -> None:
    """The end of a side-by-side run: the summary of targets, the total time and, with ``json_path``, every
    figure as JSON (shared with the other side-by-side scripts, e.g. ``benches/poisson_compare.py``)."""
    elapsed = time.perf_counter() - started
    print_table(
        "Summary of targets (ratios of medians measured in this run)",
        ["target", "figures", "result"],
        [[t.name, ", ".join(t.figures) or "-", t.status] for t in targets],
    )
    rough = " (quick run: few samples, ratios are rough)" if quick else ""
    print(f"\ntotal time {elapsed:.1f} s{rough}")
    report["targets"] = [asdict(t) for t in targets]
    report["elapsed_s"] = elapsed
    if json_path:
        Path(json_path).write_text(json.dumps(report, indent=2, default=str) + "\n", encoding="utf-8")
        print(f"figures written to {json_path}")


if __name__ == "__main__":
    sys.exit(main())
