"""Padded tile atlases: gutters filled from provenance, per-tile mip chains, sRGB-correct reduction.

**Layout.** Tile ``k`` of a set with tile size N and padding P occupies the *cell* of side S = N + 2P at
column ``k % cols``, row ``k // cols`` of the atlas (``cols`` = ⌈√K⌉, rows = ⌈K / cols⌉, unused cells black);
its N x N interior starts P texels inside the cell. A shader needs only (N, P, cols) to find a tile: no table.

**Gutters from provenance.** Every tile pixel was copied from one exemplar pixel (``TileSet.source``). The P
gutter texels beyond a tile edge continue that exemplar content: the gutter texel at local (y, x) (outside
[0, N)²) takes the exemplar pixel ``source[clamp(y), clamp(x)] + (y - clamp(y), x - clamp(x))``, i.e. the
exemplar continued in the direction of the nearest tile pixel (diagonally in the corner squares). Where that
point falls outside the exemplar it is clamped to the exemplar's edge.

Where this is exact: an ω tile's border ring (``keep_border``, the default) is the intermediate tile, i.e. the
quadrants of the four sample patches, and a valid neighbour continues the same sample patch across the shared
edge; so the first gutter texel on every side equals the neighbour's border texel for *every* valid neighbour,
and the corner squares continue the corner's patch exactly as the diagonal neighbour does. Deeper gutter texels
(depth >= 2) equal the neighbour's texel wherever the neighbour shows its intermediate tile; near the side
midpoints the neighbour's cutting curve approaches its border (the inscribed circle touches it there) and the
neighbour shows its own matching patch, which differs between neighbours, so no single gutter can be exact there:
we keep the provenance continuation (the intermediate tile, the content shared by all neighbours just outside
their cuts). For Wang tiles the edges' samples continue across each edge, so the gutter is exact along each edge
except near the corners, where the neighbour's content depends on its other edge colours. :func:`gutter_exactness`
measures all this per depth; ``manifest.json`` records it.

**Mips.** Level L halves level L - 1 with a 2 x 2 box filter over the whole atlas. Because S, P and N are
multiples of 2^L for every exported level, every 2 x 2 block lies inside one cell and inside either the interior
or the gutter, so a level never mixes two tiles, and the interior of level L is exactly the 2^L x 2^L box filter
of the tile. The chain stops at ``max_level`` = the largest L with 2^L dividing both N and P (so the level-L
gutter, P / 2^L >= 1 texel, still covers the bilinear footprint); sample with the texture's max level set to it.
sRGB maps (albedo) are reduced in linear light (decoded with the exact sRGB curve, averaged, re-encoded and
rounded); linear maps are averaged as stored; both are rounded to the atlas's bit depth (float maps stay float).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError


def grid_for(n_tiles: int) -> tuple[int, int]:
    """(cols, rows) of the atlas grid: as square as possible, cols >= rows."""
    cols = max(1, math.isqrt(n_tiles - 1) + 1) if n_tiles > 1 else 1
    rows = -(-n_tiles // cols)
    return cols, rows


def max_mip_level(tile_size: int, padding: int) -> int:
    """The last mip level whose cells stay integral with at least one gutter texel (0 without padding)."""
    if padding <= 0:
        return 0
    level = 0
    while tile_size % (2 ** (level + 1)) == 0 and padding % (2 ** (level + 1)) == 0:
        level += 1
    return level


def padded_positions(source: np.ndarray, shape: tuple[int, int], padding: int) -> np.ndarray:
    """int64 ``(K, S, S, 2)`` exemplar (row, col) of every texel of every padded cell (see the module docstring)."""
    n = source.shape[1]
    p = int(padding)
    loc = np.arange(-p, n + p)
    cl = np.clip(loc, 0, n - 1)
    off = loc - cl
    src = source[:, cl][:, :, cl].astype(np.int64)  # (K, S, S, 2)
    src[..., 0] += off[None, :, None]
    src[..., 1] += off[None, None, :]
    np.clip(src[..., 0], 0, shape[0] - 1, out=src[..., 0])
    np.clip(src[..., 1], 0, shape[1] - 1, out=src[..., 1])
    return src


def padded_tiles(tiles: np.ndarray, aligned: np.ndarray, source: np.ndarray, padding: int) -> np.ndarray:
    """``(K, S, S, C)`` padded cells: the tiles inside, the aligned map (exemplar or a map) continued outside."""
    n = tiles.shape[1]
    p = int(padding)
    pos = padded_positions(source, aligned.shape[:2], p)
    cells = aligned[pos[..., 0], pos[..., 1]].astype(tiles.dtype)
    cells[:, p : p + n, p : p + n] = tiles
    return cells


def pack(cells: np.ndarray, cols: int, rows: int) -> np.ndarray:
    """Lay ``(K, S, S, C)`` cells into a ``(rows*S, cols*S, C)`` atlas (empty cells zero)."""
    k, s, _, c = cells.shape
    atlas = np.zeros((rows * s, cols * s, c), cells.dtype)
    for t in range(k):
        r, q = divmod(t, cols)
        atlas[r * s : (r + 1) * s, q * s : (q + 1) * s] = cells[t]
    return atlas


def cell_rects(n_tiles: int, tile_size: int, padding: int, cols: int) -> list[list[int]]:
    """``[x, y, w, h]`` of each tile's *interior* (not the cell) in level-0 atlas texels."""
    s = tile_size + 2 * padding
    return [
        [(t % cols) * s + padding, (t // cols) * s + padding, tile_size, tile_size] for t in range(n_tiles)
    ]


# --------------------------------------------------------------------------------------------- colour
def srgb_to_linear(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v: np.ndarray) -> np.ndarray:
    v = np.clip(np.asarray(v, np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1 / 2.4) - 0.055)


def reduce2(level: np.ndarray, srgb: bool, alpha_linear: bool = True) -> np.ndarray:
    """One 2 x 2 box reduction of an atlas level (uint8, uint16 or float32), see the module docstring."""
    h, w, c = level.shape
    if h % 2 or w % 2:
        raise ParameterError(f"atlas level of {w}x{h} cannot be halved")
    if level.dtype == np.float32:
        x = level.astype(np.float64)
        out = x.reshape(h // 2, 2, w // 2, 2, c).mean(axis=(1, 3))
        return out.astype(np.float32)
    top = float(np.iinfo(level.dtype).max)
    x = level.astype(np.float64) / top
    colour = c if not (alpha_linear and c in (2, 4)) else c - 1
    if srgb:
        x[..., :colour] = srgb_to_linear(x[..., :colour])
    out = x.reshape(h // 2, 2, w // 2, 2, c).mean(axis=(1, 3))
    if srgb:
        out[..., :colour] = linear_to_srgb(out[..., :colour])
    return np.clip(np.rint(out * top), 0, top).astype(level.dtype)


def mip_chain(atlas: np.ndarray, levels: int, srgb: bool) -> list[np.ndarray]:
    """``[level 0, ..., level levels]``."""
    chain = [atlas]
    for _ in range(levels):
        chain.append(reduce2(chain[-1], srgb))
    return chain


def quantise(cells: np.ndarray, bits: int | None) -> np.ndarray:
    """float [0, 1] -> uint8/uint16 with rounding; uint data passes unchanged; ``bits=None`` keeps float32."""
    if cells.dtype in (np.uint8, np.uint16) or bits is None:
        return cells
    from ..base.validate import to_uint

    return to_uint(cells, bits)


# ----------------------------------------------------------------------------------------- exactness
def gutter_exactness(tileset: Any, cells: np.ndarray, padding: int, tiles_q: np.ndarray) -> dict[str, Any]:
    """How often a gutter texel equals what a valid neighbour actually shows there.

    For each tile, side and every tile that may legally sit on that side (same side keys), the P gutter texels
    of that side strip (the corner squares excluded) are compared with the neighbour's first P rows/columns.
    Returns ``{"by_depth": [fraction exact at depth 1..P], "overall": fraction, "pairs": number of (tile,
    neighbour, side) triples}``; values compared after quantisation (``cells`` and ``tiles_q`` of one dtype).
    """
    defn = tileset.definition
    k = len(defn)
    n = tileset.tile_size
    p = int(padding)
    if p == 0:
        return {"by_depth": [], "overall": None, "pairs": 0}
    right = [defn.right_key(t) for t in range(k)]
    left = [defn.left_key(t) for t in range(k)]
    top = [defn.top_key(t) for t in range(k)]
    bottom = [defn.bottom_key(t) for t in range(k)]
    eq = np.zeros(p, np.int64)
    tot = np.zeros(p, np.int64)
    pairs = 0
    inner = slice(p, p + n)
    for a in range(k):
        cell = cells[a]
        strips = {
            "E": cell[inner, p + n : p + n + p],  # (N, P, C), depth along axis 1
            "W": cell[inner, 0:p][:, ::-1],
            "S": cell[p + n : p + n + p, inner].transpose(1, 0, 2),
            "N": cell[0:p, inner][::-1].transpose(1, 0, 2),
        }
        for side, strip in strips.items():
            for b in range(k):
                if side == "E" and left[b] == right[a]:
                    nb = tiles_q[b][:, 0:p]
                elif side == "W" and right[b] == left[a]:
                    nb = tiles_q[b][:, n - p : n][:, ::-1]
                elif side == "S" and top[b] == bottom[a]:
                    nb = tiles_q[b][0:p, :].transpose(1, 0, 2)
                elif side == "N" and bottom[b] == top[a]:
                    nb = tiles_q[b][n - p : n, :][::-1].transpose(1, 0, 2)
                else:
                    continue
                same = np.all(strip == nb, axis=2)  # (N, P)
                eq += same.sum(axis=0)
                tot += same.shape[0]
                pairs += 1
    by_depth = [float(e / t) if t else None for e, t in zip(eq, tot)]
    return {
        "by_depth": by_depth,
        "overall": float(eq.sum() / tot.sum()) if tot.sum() else None,
        "pairs": pairs,
    }
