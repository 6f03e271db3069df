"""The report's HTML page (:mod:`tilesynth.measure.report`): the metrics table (one maker of rows per family
of metrics), the figures with their captions, the per-tile table, the notes; one file, no script, no
network."""

from __future__ import annotations

import html
from collections.abc import Callable
from typing import Any


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


def _lattice_rows(la: dict[str, Any]) -> list[tuple[str, str, str]]:
    g, f = la["gradient"] or {}, la["folded"] or {}
    return [
        (
            "lattice (gradient)",
            _fmt(g.get("score"), ".3f"),
            f"mean squared step at the worst depth of the tile grid / the median depth (worst: x "
            f"{_fmt(g.get('phase_x'))}, y {_fmt(g.get('phase_y'))} px after a border); 1 = no line at a fixed "
            f"depth; the exemplar itself on this grid: {_fmt(la.get('exemplar_gradient'), '.3f')}",
        ),
        (
            "lattice (folded)",
            _fmt(f.get("score"), ".3f"),
            f"spread of the luminance averaged over the {_fmt(f.get('cells'))} tile cells against noise; 1 = "
            "nothing at fixed tile positions (grows with the number of cells for a fixed pattern); the "
            f"exemplar itself: {_fmt(la.get('exemplar_folded'), '.3f')}",
        ),
    ]


def _objects_rows(ob: dict[str, Any]) -> list[tuple[str, str, str]]:
    return [
        (
            "objects intact",
            _fmt(ob["share"], ".3f"),
            f"share of the object pixels in whole exemplar objects ({ob['n_intact']} of {ob['n_counted']}); "
            f"the exemplar itself: {_fmt(ob['exemplar_share'], '.3f')}",
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
    ("inner_seam", _inner_seam_rows),  # straight cuts inside the tiles, which the border score misses
    ("lattice", _lattice_rows),  # the tile grid by steps at a fixed depth and content at fixed positions
    ("objects", _objects_rows),
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
    from .diagnose import info_lines  # the mask and the input warnings of the build

    parts += [f'<p class="note">{esc(line.split(None, 1)[0])}: {esc(line.split(None, 1)[1])}</p>'
              for line in info_lines(tileset.params)]  # fmt: skip
    parts += _figures(files, s, wang, reference)
    # a material set's maps
    parts += [_img(f, f"Map {k[4:]}") for k, f in files.items() if k.startswith("map-")]
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
