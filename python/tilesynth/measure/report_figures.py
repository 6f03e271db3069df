"""The figures of the report (:mod:`tilesynth.measure.report`), drawn with Pillow: the viridis colour map and
its colour bars, the sample with its tile borders, the seam and coherence heat-maps, the selection's
convergence chart."""

from __future__ import annotations

import math

import numpy as np

from ..base.validate import to_uint
from .metrics import seam_profiles

# viridis at 0, 1/8, ..., 1 (piecewise linear in between): perceptually ordered, readable in grey
_VIRIDIS = np.array(
    [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ],
    dtype=np.float64,
)


SEAM_RANGE = 3.0
"""Seam ratios are coloured on [0, SEAM_RANGE] (larger values get the top colour)."""


def colormap(v: np.ndarray) -> np.ndarray:
    """Map values in [0, 1] (clipped) to uint8 RGB with viridis; ``(..., 3)``."""
    t = np.clip(np.nan_to_num(np.asarray(v, dtype=np.float64)), 0.0, 1.0) * (len(_VIRIDIS) - 1)
    i = np.minimum(t.astype(np.int64), len(_VIRIDIS) - 2)
    f = (t - i)[..., None]
    return np.rint(_VIRIDIS[i] * (1 - f) + _VIRIDIS[i + 1] * f).astype(np.uint8)


def _font(size: int = 13):  # noqa: ANN202
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: the fixed bitmap font
        return ImageFont.load_default()


def _rgb8(img: np.ndarray) -> np.ndarray:
    u = to_uint(img, 8)
    if u.shape[2] < 3:
        return np.repeat(u[:, :, :1], 3, axis=2)
    return np.ascontiguousarray(u[:, :, :3])


def _dimmed(img: np.ndarray, level: float = 0.45) -> np.ndarray:
    """The image as dim grey (so colours drawn over it stand out): float ``(H, W, 3)`` in [0, 255]."""
    rgb = _rgb8(img).astype(np.float64)
    grey = rgb @ np.array([0.299, 0.587, 0.114])
    return np.repeat((grey * level)[..., None], 3, axis=2)


def _smooth_1d(v: np.ndarray, width: int, axis: int) -> np.ndarray:
    """Moving average of ``width`` samples along ``axis`` (edges: average of what is inside)."""
    if width <= 1 or v.size == 0:  # no border in this direction (an output one tile wide or high)
        return v
    k = np.ones(width)
    num = np.apply_along_axis(lambda a: np.convolve(a, k, "same"), axis, v)
    den = np.convolve(np.ones(v.shape[axis]), k, "same")
    shape = [1] * v.ndim
    shape[axis] = -1
    return num / den.reshape(shape)


def _colour_bar(width: int, lo: float, hi: float, label: str, ticks: list[float], mark: float | None = None):  # noqa: ANN202
    """A horizontal viridis bar with ticks and a label: PIL image ``width`` x 46."""
    from PIL import Image, ImageDraw

    bar = Image.new("RGB", (width, 46), (255, 255, 255))
    x0, x1 = 10, width - 10
    ramp = colormap(np.linspace(0, 1, x1 - x0))[None].repeat(12, axis=0)
    bar.paste(Image.fromarray(ramp), (x0, 4))
    d = ImageDraw.Draw(bar)
    font = _font(12)
    for t in ticks:
        x = x0 + (t - lo) / (hi - lo) * (x1 - x0 - 1)
        d.line([(x, 16), (x, 20)], fill=(0, 0, 0))
        text = f"{t:g}" + ("+" if t == hi else "")
        tw = d.textlength(text, font=font)
        d.text((min(max(x - tw / 2, 0), width - tw - 1), 21), text, fill=(0, 0, 0), font=font)
    if mark is not None:
        x = x0 + (mark - lo) / (hi - lo) * (x1 - x0 - 1)
        d.line([(x, 2), (x, 17)], fill=(220, 0, 0), width=2)
    d.text((x0, 33), label, fill=(0, 0, 0), font=font)
    return bar


def _stack(top, bottom):  # noqa: ANN001, ANN202
    from PIL import Image

    out = Image.new("RGB", (max(top.width, bottom.width), top.height + bottom.height), (255, 255, 255))
    out.paste(top, (0, 0))
    out.paste(bottom, (0, top.height))
    return out


def sample_with_borders(
    img: np.ndarray, tile_size: int, colour: tuple[int, int, int] = (255, 0, 255), alpha: float = 0.5
) -> np.ndarray:
    """uint8 RGB copy of ``img`` with the first pixel row / column of every tile blended with ``colour``."""
    out = _rgb8(img).astype(np.float64)
    h, w = out.shape[:2]
    cols = (np.arange(w) % tile_size == 0) & (np.arange(w) > 0)  # the image edge is no border
    rows = (np.arange(h) % tile_size == 0) & (np.arange(h) > 0)
    line = cols[None, :] | rows[:, None]
    out[line] = out[line] * (1 - alpha) + np.array(colour) * alpha
    return np.rint(out).astype(np.uint8)


def seam_heatmap(img: np.ndarray, tile_size: int, half_width: int = 2):  # noqa: ANN201
    """The seam heat-map figure (see :mod:`tilesynth.measure.report`) as a PIL image, colour bar below."""
    from PIL import Image

    h, w = img.shape[:2]
    n = tile_size
    base = _dimmed(img)
    vert, horiz = seam_profiles(img, n)
    win = max(3, n // 8)
    v = _smooth_1d(vert, win, 0) / SEAM_RANGE
    hz = _smooth_1d(horiz, win, 1) / SEAM_RANGE
    for k in range(vert.shape[1]):
        x = (k + 1) * n  # the border lies between columns x-1 and x
        base[:, max(0, x - half_width) : x + half_width] = colormap(v[:, k])[:, None, :]
    for k in range(horiz.shape[0]):
        y = (k + 1) * n
        base[max(0, y - half_width) : y + half_width, :] = colormap(hz[k])[None, :, :]
    fig = Image.fromarray(np.rint(base).astype(np.uint8))
    bar = _colour_bar(
        max(260, w),
        0.0,
        SEAM_RANGE,
        f"squared step across the border / mean inside tiles (smoothed over {win} px); red: 1",
        [0.0, 1.0, 2.0, SEAM_RANGE],
        mark=1.0,
    )
    return _stack(fig, bar)


def coherence_heatmap(img: np.ndarray, values: np.ndarray, patch: int, stride: int, channels: int):  # noqa: ANN201
    """The coherence heat-map: each patch's rms difference to its best exemplar patch, PIL image + colour bar.

    Every pixel takes the largest value of the patches whose central ``stride`` x ``stride`` cell covers it
    (patch (i, j) paints rows i·s + (p−s)/2 ... + s); pixels of exact copies (value 0) keep the dimmed texture.
    """
    from PIL import Image

    h, w = img.shape[:2]
    base = _dimmed(img)
    rms = np.sqrt(np.maximum(values, 0.0) / (patch * patch * channels))
    top = float(np.quantile(rms[rms > 0], 0.99)) if (rms > 0).any() else 1.0
    top = max(top, 1e-6)
    paint = np.zeros((h, w))
    off = (patch - stride) // 2
    for (i, j), r in np.ndenumerate(rms):
        if r > 0:
            y0, x0 = i * stride + off, j * stride + off
            cell = paint[y0 : y0 + stride, x0 : x0 + stride]
            np.maximum(cell, r, out=cell)
    hot = paint > 0
    base[hot] = colormap(paint[hot] / top)
    fig = Image.fromarray(np.rint(base).astype(np.uint8))
    ticks = [0.0, round(top / 2, 3), round(top, 3)]
    bar = _colour_bar(
        max(260, w),
        0.0,
        ticks[-1],
        f"rms difference of each {patch}x{patch} patch to its best exemplar patch (grey: exact copy)",
        ticks,
    )
    return _stack(fig, bar)


def _nice_ticks(lo: float, hi: float, count: int = 6) -> list[float]:
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / max(1, count - 1)
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 2.5, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step) * step
    return [first + k * step for k in range(int((hi - first) / step + 1e-9) + 1)]


def convergence_chart(best: list[float], mean: list[float], title: str, width: int = 720, height: int = 400):  # noqa: ANN201
    """Line chart of best (blue) and mean (orange) E per generation, drawn with Pillow. Linear axes; the E axis
    spans both series (5% padding)."""
    from PIL import Image, ImageDraw

    im = Image.new("RGB", (width, height), (255, 255, 255))
    d = ImageDraw.Draw(im)
    font, small = _font(14), _font(12)
    left, right, top, bottom = 90, 20, 40, 50
    x0, x1, y0, y1 = left, width - right, top, height - bottom
    values = [v for v in list(best) + list(mean) if math.isfinite(v)]
    lo, hi = min(values), max(values)
    pad = (hi - lo) * 0.05 or abs(hi) * 0.05 or 1.0
    lo, hi = lo - pad, hi + pad
    g = len(best)
    gx_hi = max(2, g)

    def px(i: float) -> float:
        return x0 + (i - 1) / (gx_hi - 1) * (x1 - x0)

    def py(v: float) -> float:
        return y1 - (v - lo) / (hi - lo) * (y1 - y0)

    for t in _nice_ticks(lo, hi, 8):
        y = py(t)
        d.line([(x0, y), (x1, y)], fill=(230, 230, 230))
        d.line([(x0 - 4, y), (x0, y)], fill=(0, 0, 0))
        label = f"{t:.6g}"
        d.text((x0 - 8 - d.textlength(label, font=small), y - 7), label, fill=(0, 0, 0), font=small)
    for t in _nice_ticks(1, gx_hi, 8):
        if t != int(t):
            continue
        x = px(t)
        d.line([(x, y1), (x, y1 + 4)], fill=(0, 0, 0))
        d.text(
            (x - d.textlength(str(int(t)), font=small) / 2, y1 + 6), str(int(t)), fill=(0, 0, 0), font=small
        )
    d.rectangle([x0, y0, x1, y1], outline=(0, 0, 0))
    for series, colour in ((mean, (230, 120, 20)), (best, (30, 90, 200))):
        pts = [(px(i + 1), py(v)) for i, v in enumerate(series) if math.isfinite(v)]
        if len(pts) > 1:
            d.line(pts, fill=colour, width=2)
        for x, y in pts:
            d.ellipse([x - 2.5, y - 2.5, x + 2.5, y + 2.5], fill=colour)
    d.text((x0, 12), title, fill=(0, 0, 0), font=font)
    d.text(((x0 + x1) / 2 - 30, height - 22), "generation", fill=(0, 0, 0), font=font)
    d.text((8, (y0 + y1) / 2 - 8), "E", fill=(0, 0, 0), font=font)
    lx = x1 - 150
    for k, (name, colour) in enumerate((("best E", (30, 90, 200)), ("mean E", (230, 120, 20)))):
        y = y0 + 12 + 18 * k
        d.line([(lx, y), (lx + 24, y)], fill=colour, width=3)
        d.text((lx + 30, y - 8), name, fill=(0, 0, 0), font=small)
    return im
