"""Unit-length encoding of normal vectors in 8- and 16-bit and float samples.

**Decoding convention assumed** (the one of every common tool: Substance, Blender, Unreal, Unity, glTF):
an unsigned sample ``c`` of a normal map with maximum code ``S`` (255 for 8-bit, 65535 for 16-bit) decodes to
``v = c / S · 2 − 1`` per channel (x, y, z = red, green, blue); a float map with values in [0, 1] to ``2 · x − 1``
("unorm"), a float map with negative values is the vectors themselves ("snorm"). Whether +y points up (OpenGL) or
down (DirectX) does not change lengths; it is recorded per map (``normal_y``) and converted by negating y.

**Why not plain rounding.** Rounding each channel of a unit vector to 8 bits moves each decoded component by up
to 1/255, and the decoded length by up to about 0.0068: on random unit vectors 0.8 % of pixels (on real normal
maps 0.1-0.4 %) land outside 1 ± 0.005, the tolerance renderers and the issue's target use. 16-bit rounding is
within 3e-5.

**What** :func:`encode_unit` **does.** For each vector it considers the 8 codes made of the floor or the ceiling
of each scaled component (the two codes around it per channel, so no component moves by a code step or more) and
picks, among those whose decoded length is within :data:`UNIT_TOLERANCE` of 1 *and* whose decoded vector is no
farther from the exact one than rounding can ever be (``√3 / S``, the worst case of rounding: half a code step in
each channel), the one nearest the exact vector; so the direction moves no more than rounding may, and where
rounding is already within the tolerance and nearest (almost always for 16-bit) the result is rounding's code.
Where no candidate meets both (rare: found by the property test, e.g. (0, 0.7526, 0.6585) in 8 bits), unit
length wins: the nearest candidate within the tolerance, whose direction moves a little more than rounding's
bound (at most 2√3 / S: every channel stays the floor or the ceiling of its exact code).
Measured over 300 000 random unit vectors (``tests/test_normal_codes.py``): every 8-bit code within 0.0049 of
unit length, the largest direction error 0.0067 rad against rounding's 0.0066 rad and the bound √3 / 255 ≈
0.0068. Float maps are renormalised in float64 and stored as float32 (length error below 1e-6).
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = [
    "UNIT_TOLERANCE",
    "encode_unit",
    "decode",
    "code_scale",
    "transform_normal_codes",
    "transform_vectors",
    "vector_turns",
]

#: Largest distance from unit length that :func:`encode_unit` aims for with integer codes (the target is 0.005;
#: 1e-4 is left for decoders that compute in float32).
UNIT_TOLERANCE = 0.0049
_CORNERS = np.array(list(itertools.product((0.0, 1.0), repeat=3)))  # (8, 3)
_CHUNK = 1 << 17


def code_scale(dtype: np.dtype) -> float | None:
    """The maximum code of an unsigned sample type (255, 65535), None for float."""
    return {np.dtype(np.uint8): 255.0, np.dtype(np.uint16): 65535.0}.get(np.dtype(dtype))


def decode(a: np.ndarray, encoding: str) -> np.ndarray:
    """The vectors of normal samples ``(..., 3)`` as float64 (module docstring: the decoding convention)."""
    scale = code_scale(a.dtype) or 1.0
    v = np.asarray(a).astype(np.float64) / scale
    return 2.0 * v - 1.0 if encoding == "unorm" else v


def _encode_codes(v: np.ndarray, scale: float) -> np.ndarray:
    """Codes (float64, integral) of unit vectors ``v`` (P, 3) with maximum code ``scale`` (module docstring)."""
    c = (v + 1.0) * (0.5 * scale)
    base = np.clip(np.floor(c), 0.0, scale)
    cand = np.minimum(base[:, None, :] + _CORNERS[None], scale)  # (P, 8, 3)
    dec = cand * (2.0 / scale) - 1.0
    err = np.abs(np.sqrt((dec * dec).sum(axis=2)) - 1.0)
    dist = np.sqrt(((dec - v[:, None, :]) ** 2).sum(axis=2))
    inside = dist <= np.sqrt(3.0) / scale * (1.0 + 1e-9)
    unit = err <= UNIT_TOLERANCE
    ok = inside & unit
    # Lexicographic choice: within tolerance and bound -> nearest; else within tolerance -> nearest (the
    # length wins over the direction bound: e.g. (0, 0.7526, 0.6585) in 8 bits has no code within both, the
    # most nearly unit code inside the bound is 0.00504 off unit length, the nearest unit code 0.0068 > √3/255
    # away); else within the bound -> most nearly unit; else nearest.
    key = np.where(ok, dist, np.where(unit, 10.0 + dist, np.where(inside, 20.0 + err, 100.0 + dist)))
    pick = key.argmin(axis=1)
    return cand[np.arange(cand.shape[0]), pick]


def encode_unit(v: np.ndarray, dtype: np.dtype, encoding: str) -> np.ndarray:
    """Unit vectors ``v`` ``(..., 3)`` (float, normalised here again in float64) encoded as samples of ``dtype``
    (uint8, uint16: the code nearest to ``v`` among those of nearly unit length, module docstring; float32:
    ``(v + 1) / 2`` for "unorm", ``v`` for "snorm")."""
    v = np.asarray(v, np.float64)
    shape = v.shape
    flat = v.reshape(-1, 3)
    length = np.sqrt((flat * flat).sum(axis=1, keepdims=True))
    flat = flat / np.maximum(length, 1e-300)
    scale = code_scale(dtype)
    if scale is None:
        out = (flat + 1.0) * 0.5 if encoding == "unorm" else flat
        return out.astype(np.float32).reshape(shape)
    codes = np.empty(flat.shape, np.dtype(dtype))
    for i in range(0, flat.shape[0], _CHUNK):
        codes[i : i + _CHUNK] = _encode_codes(flat[i : i + _CHUNK], scale)
    return codes.reshape(shape)


def _vector_turns() -> np.ndarray:
    """``M[t]`` ``(8, 2, 2)``: how ``T_t`` turns a tangent-space vector's (x, y), x right and y up on screen. R
    (:func:`numpy.rot90`, an anticlockwise quarter turn on screen) takes (x, y) to (−y, x); the left-right mirror
    F negates x; ``T_t = F^f R^k``."""
    r = np.array([[0, -1], [1, 0]])
    out = np.zeros((8, 2, 2), np.int64)
    for t in range(8):
        m = np.linalg.matrix_power(r, t % 4)
        out[t] = np.diag([-1, 1]) @ m if t >= 4 else m
    return out


_VECTOR_TURNS = _vector_turns()


def vector_turns(y_down: bool = False) -> np.ndarray:
    """``M[t]`` ``(8, 2, 2)`` int: (x, y) of a tangent-space vector in a patch transformed by ``T_t``; y up
    (OpenGL), or down (``y_down``, DirectX: the same turn seen with y negated)."""
    if not y_down:
        return _VECTOR_TURNS
    d = np.diag([1, -1])
    return np.einsum("ij,tjk,kl->til", d, _VECTOR_TURNS, d)


def transform_vectors(v: np.ndarray, transforms: np.ndarray, y_down: bool = False) -> np.ndarray:
    """Tangent-space vectors (or steps of them) ``v`` ``(..., C >= 2)`` (float; x, y first) turned as their pixels
    were by ``T_t`` (``transforms`` broadcast over ``v.shape[:-1]``, :func:`vector_turns`); other channels (z)
    unchanged. A float64 copy."""
    v = np.array(v, dtype=np.float64, copy=True)
    m = vector_turns(y_down)[np.broadcast_to(np.asarray(transforms, np.int64), v.shape[:-1])]
    xy = v[..., :2].copy()
    v[..., 0] = m[..., 0, 0] * xy[..., 0] + m[..., 0, 1] * xy[..., 1]
    v[..., 1] = m[..., 1, 0] * xy[..., 0] + m[..., 1, 1] * xy[..., 1]
    return v


def transform_normal_codes(
    a: np.ndarray, transforms: np.ndarray, encoding: str, y_down: bool = False
) -> np.ndarray:
    """Normal-map samples ``a`` ``(..., 3)`` (uint8, uint16 or float32; ``encoding`` "unorm" ``2·c − 1`` or
    "snorm") with their vectors turned by ``T_t`` (``transforms`` broadcast over ``a.shape[:-1]``), exactly in
    the samples' own type: a turn only swaps x and y and negates them (``max − c`` for unsigned codes, ``1 − c``
    for unorm floats, ``−c`` for snorm), so no precision is lost."""
    a = np.asarray(a)
    t = np.broadcast_to(np.asarray(transforms, np.int64), a.shape[:-1])
    out = np.array(a, copy=True)
    top = {np.dtype(np.uint8): 255, np.dtype(np.uint16): 65535}.get(a.dtype)
    x, y = a[..., 0], a[..., 1]
    neg = {"x": (top - x) if top else (1.0 - x if encoding == "unorm" else -x)}
    neg["y"] = (top - y) if top else (1.0 - y if encoding == "unorm" else -y)
    m = vector_turns(y_down)
    for ti in np.unique(t):
        if ti == 0:
            continue
        where = t == ti
        for row in (0, 1):
            col = int(np.flatnonzero(m[ti, row])[0])
            src = (x, y)[col] if m[ti, row, col] > 0 else neg["xy"[col]]
            out[..., row][where] = src[where]
    return out
