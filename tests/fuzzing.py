"""Hypothesis strategies for the fuzz tests: careless arrays and parameters, and the "nothing mutated" check.

Arrays are drawn as (shape, dtype, layout, value kind, seed) and filled by a numpy generator seeded from the
draw, which keeps the examples cheap while still shrinking towards small shapes and plain layouts.

Each fuzzed call is drawn in one of two modes (:data:`MODE`, set by the test before drawing the call): **tame**
calls have the expected dtypes, dimensions, C-contiguous layouts and integer parameters of the right type, so
they reach the kernels (with random shapes, sizes and values, NaN and infinities included); **wild** calls are
near-valid with a chance for every argument to have any dtype, ndim, layout or parameter type (they exercise
the type checks of the bindings and the conversions of the wrappers).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from hypothesis import strategies as st

# Every dtype a careless caller might pass, including non-native byte order.
ALL_DTYPES = [
    "float32",
    "float64",
    "float16",
    "uint8",
    "uint16",
    "uint32",
    "int8",
    "int32",
    "int64",
    "bool",
    "complex64",
    ">f4",
    ">f8",
    ">u2",
    ">i8",
]
LAYOUTS = ["C", "F", "strided", "reversed", "readonly", "unaligned"]
VALUE_KINDS = ["unit", "unit", "unit", "special", "large", "negative", "tiny"]

MODE = {"tame": False}
"""Set ``MODE["tame"]`` before drawing a call (see the module docstring)."""

SPECIALS = np.array([np.nan, np.inf, -np.inf, -0.0, 1.0 + 2**-20, -1e-30, 3e38, -3e38, 5e-324])


def fill(
    shape: tuple[int, ...], dtype: Any, kind: str, seed: int, lo: float = 0.0, hi: float = 1.0
) -> np.ndarray:
    """An array of ``shape`` and ``dtype`` with values of ``kind`` (see :data:`VALUE_KINDS`)."""
    with np.errstate(all="ignore"):
        return _fill(shape, dtype, kind, seed, lo, hi)


def _fill(shape: tuple[int, ...], dtype: Any, kind: str, seed: int, lo: float, hi: float) -> np.ndarray:
    rng = np.random.default_rng(seed)
    dt = np.dtype(dtype)
    v = rng.uniform(lo, hi, size=shape)
    if kind == "special" and v.size:
        idx = rng.integers(0, v.size, size=max(1, v.size // 7))
        v.flat[idx] = rng.choice(SPECIALS, size=idx.size)
    elif kind == "large":
        v = v * 1e30
    elif kind == "negative":
        v = v - 0.5 * (hi - lo + 1.0)
    elif kind == "tiny":
        v = v * 1e-40
    if dt.kind == "b":
        return (v > 0.5 * (lo + hi)).astype(dt)
    if dt.kind in "iu":
        info = np.iinfo(dt)
        if kind in ("large", "special"):
            return rng.integers(
                info.min, info.max, size=shape, dtype=dt.newbyteorder("="), endpoint=True
            ).astype(dt)
        return np.clip(
            np.nan_to_num(np.rint(v * (info.max if hi <= 1.0 else 1.0))), info.min, info.max
        ).astype(dt)
    return v.astype(dt)


def relayout(a: np.ndarray, layout: str) -> np.ndarray:
    """The same values as ``a`` in another memory layout (Fortran, strided view, negative strides, read-only,
    misaligned)."""
    if layout == "F":
        return np.asfortranarray(a)
    if layout == "strided" and a.ndim:
        big = np.zeros(a.shape[:-1] + (2 * a.shape[-1],), a.dtype)
        big[..., ::2] = a
        return big[..., ::2]
    if layout == "reversed" and a.ndim:
        return np.ascontiguousarray(a[::-1])[::-1]
    if layout == "readonly":
        b = a.copy()
        b.setflags(write=False)
        return b
    if layout == "unaligned" and a.dtype.itemsize > 1:
        # C-contiguous data one byte into a buffer (as numpy.frombuffer at an odd offset gives): misaligned for
        # the dtype; the bindings refuse it (a Rust view of it is undefined behaviour), the public API copies it
        buf = bytearray(a.nbytes + 1)
        b = np.frombuffer(memoryview(buf)[1:], a.dtype).reshape(a.shape)
        b[...] = a
        return b
    return a


@st.composite
def arrays(
    draw: st.DrawFn,
    ndim: int | None = None,
    dtype: Any = "float32",
    shape: tuple[int | None, ...] | None = None,
    max_side: int = 6,
    lo: float = 0.0,
    hi: float = 1.0,
    wild: float = 0.1,
) -> np.ndarray:
    """A near-valid array: ``ndim`` / ``dtype`` / ``shape`` (``None`` entries free) most of the time.

    With probability about ``wild`` each of the dtype, the ndim and the shape is drawn freely instead.
    """
    if MODE["tame"]:
        wild = 0.0
    go_wild = st.floats(0, 1).map(lambda u: u < wild)
    if ndim is None or draw(go_wild):
        ndim = draw(st.integers(0, 5))
    if shape is not None and len(shape) == ndim and not draw(go_wild):
        shp = tuple(draw(st.integers(0, max_side)) if s is None else s for s in shape)
    else:
        shp = tuple(draw(st.lists(st.integers(0, max_side), min_size=ndim, max_size=ndim)))
    shp = _bounded(shp)
    dt = draw(st.sampled_from(ALL_DTYPES)) if draw(go_wild) else dtype
    kind = draw(st.sampled_from(VALUE_KINDS))
    seed = draw(st.integers(0, 2**32 - 1))
    a = fill(shp, dt, kind, seed, lo, hi)
    return relayout(a, draw(st.sampled_from(["C", "readonly"] if MODE["tame"] else LAYOUTS)))


def _tame_or_wild(tame: st.SearchStrategy[Any], wild: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    return st.booleans().flatmap(lambda _: tame if MODE["tame"] else st.one_of(tame, tame, wild))


MAX_ELEMENTS = 1 << 18
"""Largest array the fuzzers make (a wild 5-d shape of 120-pixel sides would be 25 G elements)."""


def _bounded(shape: tuple[int, ...]) -> tuple[int, ...]:
    """``shape`` with its largest sides halved until it has at most :data:`MAX_ELEMENTS` elements."""
    dims = list(shape)
    while int(np.prod(dims, dtype=np.float64)) > MAX_ELEMENTS:
        i = int(np.argmax(dims))
        dims[i] //= 2
    return tuple(dims)


def threads() -> st.SearchStrategy[Any]:
    """Thread counts: None, 1 or 2 (tame); sometimes zero, negative, huge or not an integer (wild)."""
    return _tame_or_wild(
        st.sampled_from([None, 1, 2]), st.sampled_from([0, -1, 2**31, 2**64, 1.5, "2", True])
    )


def sizes(lo: int = -2, hi: int = 12) -> st.SearchStrategy[Any]:
    """Small integer parameters (tame: in [max(lo, 0), hi], or huge); wild: negative, beyond usize, i64 limits
    or of the wrong type."""
    return _tame_or_wild(
        st.one_of(*[st.integers(max(lo, 0), hi)] * 5, st.sampled_from([2**31, 2**63 - 1])),
        st.one_of(st.integers(lo, hi), st.sampled_from([2**64, -(2**63), -1, 2.0, None, "3"])),
    )


def choices(valid: list[Any]) -> st.SearchStrategy[Any]:
    """One of the ``valid`` option strings (tame); sometimes an unknown string, an empty one or not a string
    (wild)."""
    return _tame_or_wild(st.sampled_from(valid), st.sampled_from(["x", "", valid[0].upper(), None, 1]))


def floats() -> st.SearchStrategy[Any]:
    """Float parameters: ordinary, zero, negative, NaN, infinite, huge (tame), or not a number (wild)."""
    return _tame_or_wild(
        st.one_of(
            st.floats(1e-9, 10.0),
            st.sampled_from([0.0, -1.0, float("nan"), float("inf"), -float("inf"), 1e308, 5e-324, 1]),
        ),
        st.sampled_from(["0.5", None, 1j]),
    )


# ------------------------------------------------------------------------------------------- mutation check
@dataclass
class Snapshot:
    """A copy of an argument's bytes, dtype, shape, strides and flags, to check it was not modified."""

    value: Any
    data: bytes
    meta: tuple


def _snap(a: np.ndarray) -> Snapshot:
    return Snapshot(a, a.tobytes(order="A"), (a.dtype.str, a.shape, a.strides, a.flags.writeable))


def snapshot(*args: Any, **kwargs: Any) -> list[Snapshot]:
    """Snapshots of every numpy array among the arguments (nested in lists, tuples and dicts too)."""
    out: list[Snapshot] = []

    def walk(v: Any) -> None:
        if isinstance(v, np.ndarray):
            out.append(_snap(v))
        elif isinstance(v, (list, tuple)):
            for x in v:
                walk(x)
        elif isinstance(v, dict):
            for x in v.values():
                walk(x)

    walk(args)
    walk(kwargs)
    return out


def assert_unchanged(snaps: list[Snapshot]) -> None:
    """Fails if any snapshotted array changed its content, dtype, shape, strides or writeability."""
    for i, s in enumerate(snaps):
        a = s.value
        assert (a.dtype.str, a.shape, a.strides, a.flags.writeable) == s.meta, (
            f"argument array {i}: layout changed"
        )
        assert a.tobytes(order="A") == s.data, f"argument array {i} ({a.dtype} {a.shape}) was modified"


# Exceptions a call with bad input may raise. OverflowError is allowed only at the raw ``_core`` boundary
# (pyo3 rejects a negative or too-large int for an unsigned parameter with it); the public API turns those
# into ParameterError.
CORE_ERRORS = (ValueError, TypeError, OverflowError)
API_ERRORS = (ValueError, TypeError)


def call_checked(fn: Any, args: tuple, kwargs: dict, allowed: tuple, mutable: tuple[int, ...] = ()) -> Any:
    """Call ``fn``; it may return or raise one of ``allowed`` (with a message), and must not modify its
    array arguments (except the positional arguments listed in ``mutable``, e.g. an ``out`` array). A keyword
    argument named ``out`` must stay unchanged only when the call fails: a drawn ``out`` that happens to fit
    is the call's output, written as documented.

    A Rust panic surfaces as ``pyo3_runtime.PanicException`` (a ``BaseException``) or, through the bindings'
    guard, as ``tilesynth.InternalError``: both fail here.
    """
    import warnings

    from tilesynth.errors import InternalError
    from tilesynth.measure.diagnose import InputWarning

    keep = tuple(a for i, a in enumerate(args) if i not in mutable)
    snaps = snapshot(keep, {k: v for k, v in kwargs.items() if k != "out"})
    out_snaps = snapshot(kwargs.get("out"))
    result: Any = None
    failed = False
    # a build's findings about a random input (issue 14) are allowed; other warnings stay errors
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", InputWarning)
        try:
            result = fn(*args, **kwargs)
        except InternalError:
            raise
        except allowed as exc:
            assert str(exc).strip(), f"{type(exc).__name__} without a message"
            failed = True
    assert all(str(w.message).strip() for w in caught), "a warning without a message"
    assert_unchanged(snaps + out_snaps if failed else snaps)
    return result
