"""A visual report of a tile set: PNG figures and one HTML page that opens offline.

:func:`write_report` (``tilesynth report TILESET -o DIR``) writes into ``DIR``:

=====================  ==========================================================================================
file                   content
=====================  ==========================================================================================
``tiles.png``          contact sheet of every tile (:func:`tilesynth.contact_sheet`): cutting curves in white,
                       corner colours as squares in the tile corners, index and corner tuple above each tile
``sample.png``         a synthesized sample (default 512x512, seed 1, the sample the metrics are computed on)
``sample-borders.png`` the same with the tile grid outlined (half-transparent magenta; ``borders=False`` skips it)
``seams.png``          seam heat-map: the sample dimmed to grey, every tile border drawn over it in the colour of
                       its local seam ratio (d² across the border / mean d² inside tiles in that direction,
                       averaged over a window of N/8 pixels along the border); 1 = like the texture's own steps
``coherence.png``      coherence heat-map: the minimum SSD of every output patch to the exemplar (as an rms pixel
                       difference), over the dimmed sample; patches that are exact exemplar copies stay grey
``convergence.png``    best and mean E of the population per generation of the GA / AIS that chose the sample
                       patches; not written (and the page says so) when the tile set holds no history (random)
``metrics.json``       the metrics of :func:`tilesynth.measure.metrics.tileset_metrics` on the sample
``index.html``         one page with all of the above, the metrics table and the per-tile table; images are
                       linked by relative path, no script, no network
=====================  ==========================================================================================

Everything is drawn with Pillow (already a dependency), so the report needs no optional extra; matplotlib is
not used. We chose that over a ``[report]`` extra with matplotlib because every figure here is a raster over the
texture itself or a two-line chart, which Pillow draws exactly, and a report that always works beats a nicer
axis style behind an install step.
"""

from __future__ import annotations

import html
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..base.validate import to_uint
from ..errors import ParameterError
from .metrics import DEFAULT_SAMPLE_SEED, DEFAULT_SAMPLE_SIZE, measure_tileset, seam_profiles

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


# -------------------------------------------------------------------------------------------------- figures
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
    """The seam heat-map figure (see the module docstring) as a PIL image, colour bar below."""
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


# ----------------------------------------------------------------------------------------------------- page
def _fmt(v: Any, spec: str = ".4g") -> str:
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return format(v, spec)
    return str(v)


def metrics_rows(m: dict[str, Any]) -> list[tuple[str, str, str]]:
    """(metric, value, meaning) rows of the metrics table."""
    rows: list[tuple[str, str, str]] = []
    for key, make in _ROW_MAKERS:
        if m.get(key):
            rows += make(m[key])
    return rows


def _seam_rows(sm: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "border seam score S",
            _fmt(sm["score"], ".4f"),
            "mean squared step across tile borders / inside tiles; about 1 = borders invisible",
        ),
        ("  across vertical borders (x)", _fmt(sm["ratio_x"], ".4f"), "B_x / I_x"),
        ("  across horizontal borders (y)", _fmt(sm["ratio_y"], ".4f"), "B_y / I_y"),
    ]


def _inner_seam_rows(ins: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "inner-lattice seam",
            _fmt(ins["max"], ".4f"),
            f"worst lattice-parallel line inside the tiles ({ins['depth_of_max']:+d} px from the borders; "
            f"mean {_fmt(ins['mean'], '.4f')}); about 1 = no grid of straight cuts",
        )
    ]


def _coherence_rows(co: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "coherence energy",
            _fmt(co["energy"], ".5g"),
            f"mean over {co['n_patches']} output patches ({co['patch']}x{co['patch']}, stride {co['stride']}) "
            "of the smallest SSD to any exemplar patch (Kwatra), exact",
        ),
        ("  as rms pixel difference", _fmt(co["rms"], ".4f"), "√(energy / (p²·C)), values in [0, 1]"),
        (
            "  exact copies / searched",
            f"{co['exact_copies']} / {co['searched']}",
            "patches copied bit for bit from the exemplar (e = 0) / matched exhaustively",
        ),
    ]


def _coverage_rows(cv: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        ("coverage", _fmt(cv["fraction"], ".4f"), "share of exemplar pixels that appear in the sample"),
        (
            "  evenness",
            _fmt(cv["evenness"], ".4f"),
            "entropy of the per-pixel usage / its maximum (1 = all pixels used equally)",
        ),
        ("  usage cv", _fmt(cv["cv"], ".3f"), "std / mean of the per-pixel usage counts"),
    ]


def _repetition_rows(rp: dict[str, Any]) -> list[tuple[str, str, str]]:
    off = "none" if rp["offset"] is None else f"(dy, dx) = ({rp['offset'][0]}, {rp['offset'][1]})"
    return [
        (
            "repetition peak",
            _fmt(rp["peak"], ".4f"),
            f"strongest non-zero peak of the normalised autocorrelation, at {off}",
        )
    ]


def _periodic_copy_rows(pc: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "periodic-copy fraction",
            _fmt(pc["fraction"], ".4f"),
            f"share of {pc['patch']}x{pc['patch']} grid patches equal (mse <= (2/255)²) to the patch one "
            "dominant autocorrelation lag away; 0 = no visible repetition",
        )
    ]


def _detail_rows(dr: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "detail autocorrelation peak",
            _fmt(dr["peak"], ".4f"),
            f"strongest off-origin peak of the autocorrelation of luminance minus a σ = {dr['sigma']:g} blur",
        )
    ]


def _histogram_rows(hd: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "histogram distance",
            _fmt(hd["distance"], ".4f"),
            "mean 1-D Wasserstein distance to the exemplar of colour channels and gradient magnitude "
            f"(scales {hd['scales']})",
        )
    ]


def _objective_rows(ob: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "E",
            _fmt(ob["E"], ".6g"),
            f"λ·ΣD_j + (1−λ)·Var(D_j), λ = {ob['lambda']}, {ob['intermediate_tiles']} intermediate tiles",
        ),
        ("f = 1/E", _fmt(ob["f"], ".4g"), "affinity (003)"),
        (
            "f normalised",
            _fmt(ob["f_normalised"], ".4f"),
            "1/E with D_j divided by the N·N tile pixels (003)",
        ),
        (
            "D_j min / mean / max",
            f"{_fmt(ob['D']['min'])} / {_fmt(ob['D']['mean'])} / {_fmt(ob['D']['max'])}",
            f"std {_fmt(ob['D']['std'])}, max/min {_fmt(ob['D']['max_over_min'], '.3g')}",
        ),
        (
            "cut costs min / mean / max",
            f"{_fmt(ob['cut_costs']['min'])} / {_fmt(ob['cut_costs']['mean'])} / {_fmt(ob['cut_costs']['max'])}",
            f"sum {_fmt(ob['cut_costs']['sum'])} (min-cut cost of each tile's cutting curve)",
        ),
    ]


def _cut_seam_rows(cs: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "cut seam",
            _fmt(cs["score"], ".4f"),
            "mean squared step across the cutting curves / over all "
            "pixel pairs of the tiles (1 = invisible; Poisson smoothing lowers it)",
        )
    ]


def _texture_stats_rows(tx: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "texture statistics",
            _fmt(tx["distance"], ".4f"),
            "relative distance of the Gram matrices of fixed random filter responses to the exemplar's "
            "(0 = the same statistics)",
        )
    ]


def _cut_score_rows(ob: dict[str, Any]) -> list[tuple[str, str, str]]:
    if "cut_score" not in ob:
        return []
    return [
        (
            "cut score",
            _fmt(ob["cut_score"], ".4g"),
            "geometric mean of the cut costs (+ 0.01·N), what the default selection minimises",
        )
    ]


# the metric families in the order of the table, each with the rows it makes
_ROW_MAKERS: tuple[tuple[str, Callable[[dict[str, Any]], list[tuple[str, str, str]]]], ...] = (
    ("seam", _seam_rows),
    ("inner_seam", _inner_seam_rows),  # issue 12
    ("coherence", _coherence_rows),
    ("coverage", _coverage_rows),
    ("repetition", _repetition_rows),
    ("periodic_copies", _periodic_copy_rows),
    ("detail_repetition", _detail_rows),
    ("histogram", _histogram_rows),
    ("texture_stats", _texture_stats_rows),
    ("objective", _objective_rows),
    ("objective", _cut_score_rows),
    ("cut_seam", _cut_seam_rows),
)


_CSS = """
body { font-family: sans-serif; margin: 24px; color: #222; max-width: 1200px; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.8em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 8px 0; } td, th { border: 1px solid #ccc; padding: 3px 8px; }
th { background: #f0f0f0; text-align: left; } td.num { text-align: right; font-family: monospace; }
figure { display: inline-block; margin: 8px 16px 8px 0; vertical-align: top; }
figcaption { font-size: 0.9em; color: #444; max-width: 600px; }
img { image-rendering: pixelated; border: 1px solid #999; }
.note { color: #844; } td.sub { padding-left: 24px; }
"""


def _img(src: str, caption: str) -> str:
    return (
        f'<figure><img src="{html.escape(src)}" alt="{html.escape(src)}">'
        f"<figcaption>{caption}</figcaption></figure>"
    )


def _page(
    tileset: Any,
    m: dict[str, Any],
    files: dict[str, str],
    tileset_name: str,
    notes: list[str],
    reference: float | None,
) -> str:
    from .._version import __version__

    t, s = m["tileset"], m["sample"]
    wang = tileset.layout.get("kind", "corner") == "wang"
    sel = tileset.params.get("selection", {})
    method = sel.get("method", "?") + (" + polish" if sel.get("params", {}).get("polish") else "")
    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>tilesynth report: {esc(tileset_name)}</title><style>{_CSS}</style></head><body>",
        f"<h1>tilesynth report: {esc(tileset_name)}</h1>",
        f"<p>{esc(t['scheme'])} tile set <b>{esc(str(t['set']))}</b>: {t['n_tiles']} tiles of {t['tile_size']}x"
        f"{t['tile_size']} pixels from the exemplar {esc(str(t['exemplar'] or '?'))} "
        f"({t['exemplar_shape'][1]}x{t['exemplar_shape'][0]}); sample patches chosen by {esc(method)}, "
        f"seed {tileset.params.get('seed')}. Sample: {s['width']}x{s['height']}, tiling seed {s['seed']}, "
        f"{s['tiles'][0]}x{s['tiles'][1]} tiles ({s['distinct_tiles_used']} distinct). tilesynth {esc(__version__)}."
        "</p>",
        "<h2>Metrics</h2>",
    ]
    parts += _metrics_table(m, reference, wang)
    from .diagnose import info_lines  # issue 14: the mask and the input warnings of the build

    parts += [f'<p class="note">{esc(line.split(None, 1)[0])}: {esc(line.split(None, 1)[1])}</p>'
              for line in info_lines(tileset.params)]  # fmt: skip
    parts += _figures(files, s, wang, reference)
    parts += [_img(f, f"Map {k[4:]}") for k, f in files.items() if k.startswith("map-")]  # issue 14: maps
    for note in notes:
        parts.append(f'<p class="note">{esc(note)}</p>')
    parts += _per_tile_table(tileset, wang)
    if m.get("notes"):
        parts += [f'<p class="note">{esc(n)}</p>' for n in m["notes"]]
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"


def _metrics_table(m: dict[str, Any], reference: float | None, wang: bool) -> list[str]:
    """The metrics table (with the random-placement reference under the seam score) and the link to the JSON."""
    esc = html.escape
    parts: list[str] = []
    parts.append("<table><tr><th>metric</th><th>value</th><th>meaning</th></tr>")
    rows = metrics_rows(m)
    if reference is not None and m.get("seam"):
        rows.insert(
            3,
            (
                "  reference: random placement",
                _fmt(reference, ".4f"),
                "S of the same tiles on the same grid placed at random (seed 0), ignoring their "
                + ("edge" if wang else "corner")
                + " colours",
            ),
        )
    for name, value, meaning in rows:
        cls = ' class="sub"' if name.startswith("  ") else ""
        parts.append(
            f"<tr><td{cls}>{esc(name.strip())}</td><td class=num>{esc(value)}</td><td>{esc(meaning)}</td>"
            "</tr>"
        )
    parts.append("</table>")
    parts.append('<p>All numbers as JSON: <a href="metrics.json">metrics.json</a>.</p>')
    return parts


def _figures(files: dict[str, str], s: dict[str, Any], wang: bool, reference: float | None) -> list[str]:
    """The figures: tiles, sample, seam and coherence heat-maps, selection convergence."""
    parts: list[str] = []
    parts.append("<h2>Tiles</h2>")
    if wang:
        parts.append(
            _img(
                files["tiles"],
                "All tiles: the cuts of each (white lines) separate the regions taken from "
                "its samples; the bars at the edge midpoints show the edge colours ⟨N, E, S, W⟩; above each "
                "tile its index.",
            )
        )
    else:
        parts.append(
            _img(
                files["tiles"],
                "All tiles: the cutting curve of each (white line) encloses the region "
                "taken from its matching patch; the squares in the corners show the corner colours ⟨TL, BL, "
                "TR, BR⟩; above each tile its index and corner tuple.",
            )
        )
    parts.append("<h2>Sample</h2>")
    parts.append(
        _img(
            files["sample"],
            f"A {s['width']}x{s['height']} sample (tiling seed {s['seed']}), the one "
            "the metrics are computed on.",
        )
    )
    if "borders" in files:
        parts.append(_img(files["borders"], "The same sample with the tile borders outlined (magenta)."))
    parts.append("<h2>Seams</h2>")
    parts.append(
        _img(
            files["seams"],
            "Seam heat-map: every tile border coloured by its local seam ratio (the "
            "squared step across the border divided by the mean squared step inside tiles, smoothed "
            "along the border); 1 means the border looks like the texture's own pixel steps. The "
            "border pixels of ω-tiles are continuous exemplar content, so bright spots there are edges "
            "of the texture crossing the border line, not seams; a real seam lights up a whole border "
            f"(the same tiles placed at random, ignoring their {'edge' if wang else 'corner'} colours, score "
            f"{_fmt(reference, '.3g')}).",
        )
    )
    parts.append(
        _img(
            files["coherence"],
            "Coherence heat-map: how far each output patch is from the closest "
            "exemplar patch (rms). Grey = an exact copy of the exemplar; colour marks the cutting curves "
            "and any other place where the output is new.",
        )
    )
    parts.append("<h2>Selection convergence</h2>")
    if "convergence" in files:
        parts.append(_img(files["convergence"], "Best and mean E of the population in every generation."))
    return parts


def _per_tile_table(tileset: Any, wang: bool) -> list[str]:
    """The per-tile table."""
    esc = html.escape
    parts: list[str] = []
    # Wang tiles have edge colours and no variants (their rows have "edges", ω rows "corners" and "variant")
    colours, variant = ("N E S W", "") if wang else ("TL BL TR BR", "<th>variant</th>")
    parts.append(
        f"<h2>Per tile</h2><table><tr><th>tile</th><th>{colours}</th>{variant}"
        "<th>match (row, col)</th><th>D_j</th><th>cut cost</th></tr>"
    )
    for row in tileset.per_tile():
        parts.append(
            f"<tr><td class=num>{row['index']}</td><td>{esc(' '.join(row['edges' if wang else 'corners']))}</td>"
            + ("" if wang else f"<td class=num>{row['variant']}</td>")
            + f"<td class=num>({row['match_offset'][0]}, {row['match_offset'][1]})</td>"
            f"<td class=num>{row['D']:.4f}</td><td class=num>{row['cut_cost']:.4f}</td></tr>"
        )
    parts.append("</table>")
    return parts


def random_placement_seam(
    tileset: Any, index_map: np.ndarray, shape: tuple[int, ...], seed: int = 0
) -> float | None:
    """Seam score of the tiles laid on the grid of ``index_map`` at random, ignoring the matching rule: what a
    visible seam scores, for comparison (None when the image holds no border)."""
    from ..base.kernels import tile_copy
    from .metrics import seam_score

    rnd = np.random.default_rng(seed).integers(0, tileset.n_tiles, index_map.shape).astype(np.int32)
    out = tile_copy(tileset.tiles, rnd, np.empty(shape, np.float32))
    try:
        return seam_score(out, tileset.tile_size).score
    except ValueError:
        return None


def write_report(
    tileset: Any,
    out_dir: str | os.PathLike[str],
    width: int = DEFAULT_SAMPLE_SIZE[0],
    height: int = DEFAULT_SAMPLE_SIZE[1],
    seed: int = DEFAULT_SAMPLE_SEED,
    borders: bool = True,
    threads: int | None = None,
    name: str | None = None,
    progress: Any = None,
) -> dict[str, Any]:
    """Write the report of ``tileset`` into ``out_dir`` (created if missing; files in it are replaced).

    Returns ``{"files": {role: path}, "metrics": dict, "notes": [...]}``; ``progress`` (optional ``(stage,
    done, total)`` callable) hears of every step. Every argument is checked (and the sample
    measured) before the directory is created: bad input raises ``ParameterError`` / ``TypeError`` and writes
    nothing. The files are written into a temporary directory next to ``out_dir`` (``.NAME.*.part``) that is
    renamed to ``out_dir`` at the end (or, if ``out_dir`` exists, whose files are moved into it, ``index.html``
    last), so an error or Ctrl-C halfway leaves no partial report.
    """
    if not isinstance(out_dir, (str, os.PathLike)):
        raise TypeError(f"out_dir = {out_dir!r}: expected a path (str or os.PathLike)")
    if name is not None and not isinstance(name, str):
        raise TypeError(f"name = {name!r}: expected a string or None")
    d = Path(out_dir)
    if d.exists() and not d.is_dir():
        raise ParameterError(f"out_dir = {str(d)!r}: exists and is not a directory")
    m, objs = measure_tileset(
        tileset, width, height, seed, threads=threads, progress=progress
    )  # checks first
    try:
        d.parent.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError) as exc:  # a file where a directory of the path should be
        raise ParameterError(f"out_dir = {str(d)!r}: cannot create the directory ({exc.strerror})") from None
    # Everything is written into a temporary directory next to out_dir and moved into place at the end, so a
    # failure halfway (full disk, Ctrl-C) leaves no half report (issue 16).
    tmp = Path(tempfile.mkdtemp(prefix=f".{d.name}.", suffix=".part", dir=d.parent))
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)  # mkdtemp makes 0700; the report gets a plain mkdir's permissions
        if progress is not None:
            progress("report figures", 0, 1)
        result = _write_report_files(tileset, tmp, m, objs, borders, name)
        if progress is not None:
            progress("report figures", 1, 1)
        _move_into_place(tmp, d, list(result["files"].values()))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {
        "files": {k: str(d / v) for k, v in result["files"].items()},
        "metrics": m,
        "notes": result["notes"],
    }


def _move_into_place(tmp: Path, d: Path, names: list[str]) -> None:
    """Rename the finished report directory ``tmp`` to ``d``; if ``d`` exists, move the files in one by one
    (each rename atomic, ``index.html`` last) and leave the directory's other files alone."""
    if not d.exists():
        try:
            os.rename(tmp, d)
            return
        except OSError:  # created meanwhile: fall through to the file-by-file move
            pass
    d.mkdir(exist_ok=True)
    for n in sorted(names, key=lambda n: n == "index.html"):
        os.replace(tmp / n, d / n)


def _write_report_files(tileset: Any, d: Path, m: dict, objs: dict, borders: bool, name: str | None) -> dict:
    """Write every file of the report into the (new, empty) directory ``d``."""
    from ..io.images import atomic_open, save_image
    from .render import contact_sheet

    img = objs["image"]
    n = tileset.tile_size
    files: dict[str, str] = {}
    notes: list[str] = []

    sheet = contact_sheet(tileset, show_cuts=True)
    if n < 48:  # small tiles: twice the size, so the curves and corner marks can be seen
        sheet = np.repeat(np.repeat(sheet, 2, axis=0), 2, axis=1)
    files["tiles"] = "tiles.png"
    save_image(d / files["tiles"], sheet)
    files["sample"] = "sample.png"
    save_image(d / files["sample"], img)
    if borders:
        files["borders"] = "sample-borders.png"
        save_image(d / files["borders"], sample_with_borders(img, n))
    files["seams"] = "seams.png"
    save_image(d / files["seams"], np.asarray(seam_heatmap(img, n)))
    co = objs["coherence"]
    files["coherence"] = "coherence.png"
    save_image(
        d / files["coherence"],
        np.asarray(coherence_heatmap(img, co.values, co.patch, co.stride, img.shape[2])),
    )
    sel = tileset.params.get("selection", {})
    hist = sel.get("history") or {}
    best, mean = list(hist.get("best", [])), list(hist.get("mean", []))
    if best:
        params = sel.get("params", {})
        title = (
            f"selection convergence: {sel.get('method')} (population {params.get('population', '?')}, "
            f"{len(best)} generations, stopped by {sel.get('stop_reason', '?')})"
        )
        chart = convergence_chart(best, mean or best, title)
        files["convergence"] = "convergence.png"
        save_image(d / files["convergence"], np.asarray(chart))
        if sel.get("polish"):
            pol = sel["polish"]
            notes.append(
                f"After the method, the polish moved E from {pol.get('E_before', float('nan')):.6g} to "
                f"{sel.get('objective_E', float('nan')):.6g} ({pol.get('moves', 0)} moves); the chart shows "
                "the method's generations only."
            )
        if sel.get("normalise"):
            notes.append(
                "The selection optimised 003's normalised E (D_j divided by N·N); the chart is in that unit."
            )
    else:
        notes.append(
            f"No convergence chart: the sample patches were chosen by '{sel.get('method', '?')}', which "
            "runs no generations (build with --select ga or ais to get one)."
        )
    if getattr(tileset, "map_specs", None):  # issue 14: the maps of a material set
        from ..builder.materials import report_maps

        for map_name, arr, caption in report_maps(tileset, objs["index_map"], img.shape):
            files[f"map-{map_name}"] = f"sample-{map_name}.png"
            save_image(d / f"sample-{map_name}.png", arr)
            notes.append(caption)
    with atomic_open(d / "metrics.json") as fh:
        fh.write(json.dumps(m, indent=1, sort_keys=True, allow_nan=False).encode("utf-8"))
    label = name or str(tileset.exemplar_info.get("file") or "tile set")
    with atomic_open(d / "index.html") as fh:
        fh.write(
            _page(
                tileset, m, files, label, notes, random_placement_seam(tileset, objs["index_map"], img.shape)
            ).encode("utf-8")
        )
    files["metrics"] = "metrics.json"
    files["page"] = "index.html"
    return {"files": files, "notes": notes}


__all__ = [
    "coherence_heatmap",
    "colormap",
    "convergence_chart",
    "metrics_rows",
    "sample_with_borders",
    "seam_heatmap",
    "write_report",
]
