"""CPU references for the GPU lookup: exact texels of the infinite texture, bilinear samples and box-filtered
mip levels, computed from :func:`tilesynth.synthesize` (never from the atlas), so a shader that matches them
matches the library."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from . import atlas as _atlas


def index_function(
    lookup: dict[str, Any], imap: np.ndarray | None
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``f(cx, cy) -> tile indices`` for integer arrays of cell coordinates (any sign)."""
    if lookup["mode"] == "index_map":
        assert imap is not None
        rows, cols = imap.shape

        def f(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
            return imap[np.mod(cy, rows), np.mod(cx, cols)]

        return f

    def g(cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
        x0, y0 = int(cx.min()), int(cy.min())
        w, h = int(cx.max()) - x0 + 1, int(cy.max()) - y0 + 1
        full = hashed_index_map_for(lookup, x0, y0, w, h)
        return full[cy - y0, cx - x0]

    return g


def hashed_index_map_for(lookup: dict[str, Any], x0: int, y0: int, w: int, h: int) -> np.ndarray:
    """int32 ``(h, w)`` tile indices of cells x0.., y0.. in hash mode (via :mod:`tilesynth.layouts.hashed`)."""
    from ..layouts import hashed as lk

    colours = (lookup["K"],) if lookup["kind"] == "corner" else (lookup["Kh"], lookup["Kv"])
    scheme = lk.LookupScheme(lookup["kind"], colours, lookup["V"])
    wrap = tuple(lookup["wrap"]) if lookup.get("wrap") else None
    return lk.index_map(scheme, lookup["seed"], (w, h), origin=(x0, y0), wrap=wrap)


def texture_window(
    tileset: Any, index_of: Callable, x0: int, y0: int, w: int, h: int, dtype: Any = np.uint8
) -> np.ndarray:
    """``(h, w, C)`` pixels [y0, y0+h) x [x0, x0+w) of the infinite texture, by :func:`tilesynth.synthesize`."""
    from ..synth.synthesis import synthesize

    n = tileset.tile_size
    cx0, cy0 = x0 // n, y0 // n
    cx1, cy1 = (x0 + w - 1) // n, (y0 + h - 1) // n
    cy, cx = np.mgrid[cy0 : cy1 + 1, cx0 : cx1 + 1]
    sub = np.ascontiguousarray(index_of(cx, cy), dtype=np.int32)
    img, _ = synthesize(tileset, sub.shape[1] * n, sub.shape[0] * n, index_map=sub, dtype=dtype)
    ox, oy = x0 - cx0 * n, y0 - cy0 * n
    return img[oy : oy + h, ox : ox + w]


def to_rgba8(img: np.ndarray) -> np.ndarray:
    """What a WebGL2 RGBA8 read-back of an 8-bit texture of ``img``'s channels gives: grey is replicated, missing
    alpha is 255."""
    h, w, c = img.shape
    out = np.full((h, w, 4), 255, np.uint8)
    if c in (1, 2):
        out[..., :3] = img[..., :1]
        if c == 2:
            out[..., 3] = img[..., 1]
    else:
        out[..., :c] = img
    return out


def bilinear(img: np.ndarray, qx: np.ndarray, qy: np.ndarray, ox: int, oy: int) -> np.ndarray:
    """Bilinear samples (float64) of ``img`` (whose pixel (0, 0) is texture pixel (ox, oy)) at texture positions
    (qx, qy) in texels (pixel centres at +0.5), the GL convention."""
    x = qx - 0.5 - ox
    y = qy - 0.5 - oy
    i = np.floor(x).astype(np.int64)
    j = np.floor(y).astype(np.int64)
    fx = (x - i)[..., None]
    fy = (y - j)[..., None]
    a = img.astype(np.float64)
    p00, p10 = a[j, i], a[j, i + 1]
    p01, p11 = a[j + 1, i], a[j + 1, i + 1]
    return (p00 * (1 - fx) + p10 * fx) * (1 - fy) + (p01 * (1 - fx) + p11 * fx) * fy


def sample_grid(
    x0: float, y0: float, w: int, h: int, scale: float, level: int
) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int, int]]:
    """The ``h x w`` sample positions ``origin + (i + 0.5) * scale`` (texels) in level-``level`` texels
    ``(gx, gy)``, and the texture window ``(x, y, width, height)`` they read: aligned to the level's 2^L blocks,
    with one level texel of margin (what :func:`box_level` then :func:`bilinear` at ``(x, y) // 2^L`` need)."""
    f = 2**level
    qx = x0 + (np.arange(w) + 0.5) * scale
    qy = y0 + (np.arange(h) + 0.5) * scale
    ax0 = (int(np.floor(qx.min())) // f - 2) * f
    ay0 = (int(np.floor(qy.min())) // f - 2) * f
    ax1 = (int(np.ceil(qx.max())) // f + 3) * f
    ay1 = (int(np.ceil(qy.max())) // f + 3) * f
    gx, gy = np.meshgrid(qx / f, qy / f)
    return gx, gy, (ax0, ay0, ax1 - ax0, ay1 - ay0)


def box_level(img: np.ndarray, level: int, srgb: bool) -> np.ndarray:
    """Direct 2^L x 2^L box filter (linear light for sRGB, as the mips), rounded once; ``img`` uint8, its size a
    multiple of 2^L."""
    f = 2**level
    h, w, c = img.shape
    x = img.astype(np.float64) / 255.0
    colour = c - 1 if c in (2, 4) else c
    if srgb:
        x[..., :colour] = _atlas.srgb_to_linear(x[..., :colour])
    x = x.reshape(h // f, f, w // f, f, c).mean(axis=(1, 3))
    if srgb:
        x[..., :colour] = _atlas.linear_to_srgb(x[..., :colour])
    return np.clip(np.rint(x * 255.0), 0, 255).astype(np.uint8)


def map_window(
    tileset: Any,
    array: np.ndarray,
    index_of: Callable,
    x0: int,
    y0: int,
    w: int,
    h: int,
    normal: int = 0,
) -> np.ndarray:
    """``(h, w, C)`` pixels of the infinite texture of a map pixel-aligned with the exemplar (``array`` in its
    own sample type), gathered through the tile set's provenance (pure copies); a normal map (``normal`` the
    shaders' code: 1 / 2 unsigned +y / -y, 3 / 4 signed) has its vectors turned with their patches."""
    from ..tileset.provenance import gather

    prov = tileset._provenance()
    n = tileset.tile_size
    cx0, cy0 = x0 // n, y0 // n
    cx1, cy1 = (x0 + w - 1) // n, (y0 + h - 1) // n
    cy, cx = np.mgrid[cy0 : cy1 + 1, cx0 : cx1 + 1]
    sub = np.ascontiguousarray(index_of(cx, cy), dtype=np.int32)
    a = np.ascontiguousarray(array if array.ndim == 3 else array[:, :, None])
    out = np.empty((h, w, a.shape[2]), a.dtype)
    gather(a, prov, sub, out, offset=(y0 - cy0 * n, x0 - cx0 * n))
    if normal:
        from ..builder.matching.augment import transform_normal_codes

        sym = np.asarray(prov.table)[..., 0]  # (K, L)
        yy = np.arange(h)[:, None] + y0
        xx = np.arange(w)[None, :] + x0
        t = sub[yy // n - cy0, xx // n - cx0]
        s = sym[t, prov.labels[t, yy % n, xx % n]]
        out = transform_normal_codes(out, s, "snorm" if normal >= 3 else "unorm", y_down=normal in (2, 4))
    return out
