"""Pictures for people: a contact sheet of the tiles.

Each tile is drawn with its index, small squares in its corners showing the corner colours (the sample patches
R, G, B, Y, ...) of ω-tiles or short bars at the edge midpoints showing the edge colours of Wang tiles, and
optionally the outline of its cutting curve(s), so the set can be checked by eye.
"""

from __future__ import annotations

import numpy as np

from ..base.validate import positive_int, to_uint
from ..tileset.tilefile import TileSet

# Display colours for corner labels; colours beyond these get a grey ramp.
_LABEL_RGB = {
    "R": (220, 40, 40),
    "G": (40, 170, 60),
    "B": (40, 80, 220),
    "Y": (235, 200, 30),
    "C": (30, 200, 210),
    "M": (200, 50, 200),
    "K": (20, 20, 20),
    "W": (245, 245, 245),
    "L": (150, 220, 60),
    "O": (240, 140, 30),
}


def _rgb8(img: np.ndarray) -> np.ndarray:
    u = to_uint(img, 8)
    if u.shape[2] == 1:
        return np.repeat(u, 3, axis=2)
    if u.shape[2] == 2:
        return np.repeat(u[:, :, :1], 3, axis=2)
    return u[:, :, :3]


def contact_sheet(
    tileset: TileSet, columns: int | None = None, show_cuts: bool = True, gap: int = 6
) -> np.ndarray:
    """Render all tiles in a grid: uint8 RGB ``(H, W, 3)``.

    The cutting curve (the border of the region taken from the matching patch; for Wang tiles the four cuts
    between the samples) is drawn as a thin white line when ``show_cuts``; corner markers show the corner
    colours ⟨TL, BL, TR, BR⟩ of ω-tiles, edge markers the edge colours ⟨N, E, S, W⟩ of Wang tiles.
    """
    from PIL import Image, ImageDraw

    if not isinstance(tileset, TileSet):
        raise TypeError(f"tileset is a {type(tileset).__name__}, expected a TileSet")
    k, n = tileset.n_tiles, tileset.tile_size
    # more columns than tiles would only add empty space (and a huge columns value a huge image)
    cols = min(k, positive_int(columns, "columns")) if columns is not None else int(np.ceil(np.sqrt(k)))
    gap = positive_int(gap, "gap", minimum=0, maximum=1024)
    rows = -(-k // cols)
    label_h = 14
    cell_w, cell_h = n + gap, n + gap + label_h
    sheet = np.full((rows * cell_h + gap, cols * cell_w + gap, 3), 40, np.uint8)
    defn = tileset.definition
    marker = max(3, n // 12)
    for t in range(k):
        r, c = divmod(t, cols)
        y0, x0 = gap + r * cell_h + label_h, gap + c * cell_w
        tile = _rgb8(tileset.tiles[t]).copy()
        if show_cuts:
            m = tileset.cut_masks[t]
            edge = np.zeros_like(m)
            edge[:-1] |= m[:-1] != m[1:]
            edge[:, :-1] |= m[:, :-1] != m[:, 1:]
            tile[edge] = (255, 255, 255)
        if tileset.layout.get("kind", "corner") == "wang":
            # ⟨N, E, S, W⟩: a bar of 2 x marker by marker/2 at each edge midpoint
            north, east, south, west = defn.tiles[t]
            half, thick = max(2, marker), max(2, marker // 2)
            mid = n // 2
            for name, (ys, xs) in zip(
                (north, east, south, west),
                (
                    (slice(0, thick), slice(mid - half, mid + half)),
                    (slice(mid - half, mid + half), slice(n - thick, n)),
                    (slice(n - thick, n), slice(mid - half, mid + half)),
                    (slice(mid - half, mid + half), slice(0, thick)),
                ),
            ):
                tile[ys, xs] = _LABEL_RGB.get(name, (128, 128, 128))
        else:
            tl, bl, tr, br = defn.tiles[t]
            for name, (yy, xx) in zip(
                (tl, bl, tr, br), ((0, 0), (n - marker, 0), (0, n - marker), (n - marker, n - marker))
            ):
                colour = _LABEL_RGB.get(name, (128, 128, 128))
                tile[yy : yy + marker, xx : xx + marker] = colour
        sheet[y0 : y0 + n, x0 : x0 + n] = tile
    im = Image.fromarray(sheet)
    draw = ImageDraw.Draw(im)
    for t in range(k):
        r, c = divmod(t, cols)
        y0, x0 = gap + r * cell_h, gap + c * cell_w
        variants = getattr(defn, "variants", (0,) * k)
        v = variants[t]
        text = f"{t} {''.join(defn.tiles[t])}" + (f" v{v}" if max(variants) > 0 else "")
        draw.text((x0, y0 + 1), text, fill=(230, 230, 230))
    return np.asarray(im)
