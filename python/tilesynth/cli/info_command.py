"""``tilesynth info``: what a tile set holds, as text or JSON."""

from __future__ import annotations

import json
import os
import unicodedata

from ..errors import ParameterError
from ..schemes import get_scheme
from ..schemes.base import layout_kind
from .build_command import _material_info


def _printable(line: str) -> str:
    """``line`` with every control or format character (escape sequences that retitle or recolour a terminal,
    carriage returns, bidirectional overrides) written as a Python escape: the strings of a tile set's manifest
    reach the terminal as text, never as commands."""
    return "".join(
        c.encode("unicode_escape").decode("ascii") if unicodedata.category(c) in ("Cc", "Cf") else c
        for c in line
    )


def _info(ts_path: str, as_json: bool) -> None:
    from ..tileset.tilefile import TileSet

    ts = TileSet.load(ts_path)
    data = ts.manifest()
    data.pop("arrays")
    data["n_tiles"] = ts.n_tiles
    data["tile_size"] = ts.tile_size
    data["genes"] = [[int(r), int(c)] for r, c in ts.genes]
    data["timing"] = ts.timing
    data["content_sha256"] = ts.content_digest()
    data["storage"] = _storage(ts_path, ts)
    if as_json:
        print(json.dumps(data, indent=1, sort_keys=True))
        return
    p = ts.params
    sel = p.get("selection", {})
    ex = ts.exemplar_info
    lines = [
        f"tile set      {ts_path}",
        f"scheme        {ts.scheme}",
        f"set           {p.get('set')} ({ts.n_tiles} tiles, colours {''.join(_colours(ts.layout))})",
        f"tile size     {ts.tile_size}x{ts.tile_size}, {ts.channels} channel(s)",
        f"exemplar      {ex.get('file', '?')} {ex['shape'][1]}x{ex['shape'][0]}, {ex.get('bits', '?')}-bit",
        *_material_info(ts),
        *_selection_lines(sel, ts.timing.get("selection_s")),
        f"seed          {p.get('seed')}",
        *_describe(ts),
        *_quality_lines(p),
        f"build time    {ts.timing.get('total_s', float('nan')):.3f} s"
        + "".join(f", {k[:-2]} {v:.3f}" for k, v in ts.timing.items() if k != "total_s"),
        f"version       tilesynth {ts.version}, content sha256 {data['content_sha256'][:16]}",
        *_storage_lines(data["storage"]),
        "genes (row, col): "
        + ", ".join(f"{c}=({r0},{c0})" for c, (r0, c0) in zip(_colours(ts.layout), ts.genes.tolist())),
        *_mask_lines(p),
        "",
    ]
    if layout_kind(ts.layout) == "edge":
        lines += _wang_lines(ts)
        print("\n".join(map(_printable, lines)))
        return
    lines.append(
        f"{'tile':>4}  {'TL BL TR BR':<11}  {'var':>3}  {'match (row,col)':>15}  {'D_j':>12}  {'cut cost':>10}"
    )
    for row in ts.per_tile():
        lines.append(
            f"{row['index']:>4}  {' '.join(row['corners']):<11}  {row['variant']:>3}  "
            f"{'(%d,%d)' % tuple(row['match_offset']):>15}  {row['D']:>12.4f}  {row['cut_cost']:>10.4f}"
        )
    print("\n".join(map(_printable, lines)))


def _storage(ts_path: str, ts) -> dict:  # noqa: ANN001
    """The file's format version and where its bytes go (member -> [in the file, unpacked])."""
    from ..tileset.tilefile import member_sizes

    sizes = member_sizes(ts_path)
    return {
        "format_version": ts.file_version,
        "kind": "provenance" if ts.file_version == 2 else "pixels",
        "file_bytes": os.path.getsize(ts_path),
        "members": {k: list(v) for k, v in sizes.items()},
    }


def _storage_lines(st: dict) -> list[str]:
    """``info``'s lines of the file's storage: the version and the largest members."""
    mb = 1e6
    members = sorted(st["members"].items(), key=lambda kv: -kv[1][0])
    parts = ", ".join(f"{k} {v[0] / mb:.2f} MB ({v[1] / mb:.2f} unpacked)" for k, v in members[:6])
    return [
        f"storage       format {st['format_version']} ({st['kind']}), {st['file_bytes'] / mb:.2f} MB: {parts}"
    ]


def _mask_lines(p: dict) -> list[str]:
    """``info``'s lines of the mask and the input warnings of a build, none without them."""
    from ..measure.diagnose import info_lines

    return info_lines(p)


def _describe(ts) -> list[str]:  # noqa: ANN001
    """The scheme's own ``info`` lines (its matching, its E), asked of the registry; a file of a scheme this
    version does not know still shows its E."""
    try:
        sc = get_scheme(ts.scheme)
    except ParameterError:
        sc = None
    if sc is None or sc.describe is None:
        return [f"E             {ts.E:.6g}"]
    return sc.describe(ts)


def _wang_lines(ts) -> list[str]:  # noqa: ANN001
    """Per-tile table of an edge-coloured set: the four cuts' D_boundary when the set has Cohen's cut statistics
    (``cut_stats``), else each tile's supplementary patch."""
    if ts.cut_stats is not None:
        out = [
            f"{'tile':>4}  {'N E S W':<7}  {'D_sum':>10}  {'cut cost':>10}  "
            f"{'D_boundary NE / ES / SW / WN':>36}"
        ]
        for row in ts.per_tile():
            cuts = row.get("cuts", {})
            db = " / ".join(f"{cuts[q]['D_boundary']:.4f}" for q in ("NE", "ES", "SW", "WN")) if cuts else ""
            out.append(
                f"{row['index']:>4}  {' '.join(row['edges']):<7}  {row['D']:>10.4f}  "
                f"{row['cut_cost']:>10.4f}  {db:>36}"
            )
        return out
    out = [f"{'tile':>4}  {'N E S W':<7}  {'supplementary':>15}  {'D_j':>12}  {'cut cost':>10}"]
    for row in ts.per_tile():
        out.append(
            f"{row['index']:>4}  {' '.join(row['edges']):<7}  "
            f"{'(%d,%d)' % tuple(row['match_offset']):>15}  {row['D']:>12.4f}  {row['cut_cost']:>10.4f}"
        )
    return out


def _colours(layout: dict) -> list[str]:
    """The sample colours of a layout, in gene order (Wang sets: horizontal-edge colours, then vertical)."""
    if layout_kind(layout) == "edge":
        return [*layout.get("horizontal", []), *layout.get("vertical", [])]
    return list(layout.get("colours", []))


def _quality_lines(params: dict) -> list[str]:
    from ..measure.build_measures import info_lines  # the stored visible measures

    return info_lines(params)


def _selection_lines(sel: dict, seconds: float | None) -> list[str]:
    """The selection method, its parameters, its result and its convergence history, for ``info``."""
    params = dict(sel.get("params", {}))
    head = f"selection     {sel.get('method', '?')}"
    if params.get("polish"):
        head += " + polish"
    params.pop("polish", None)
    lines = [head + "".join(f", {k}={v}" for k, v in sorted(params.items()))]
    if "evaluations" in sel:
        obj = "normalised E" if sel.get("normalise") else "E"
        if sel.get("objective") in ("cut", "sum-d", "visible"):  # λ = 1, the first stage
            obj = "normalised ΣD" if sel.get("normalise") else "ΣD"
        lines.append(
            f"              {sel['evaluations']} evaluations, {sel.get('generations', 0)} generation(s), "
            f"stopped by {sel.get('stop_reason', '?')}, {seconds or 0.0:.3f} s; "
            f"objective {obj} = {sel.get('objective_E', float('nan')):.6g}"
        )
    if "border_tries" in sel:  # the Wang schemes' border-aware draws; numbers checked by the manifest
        lines.append(
            f"              border-aware: best of {sel['border_tries']} random draws, predicted border seam "
            f"{sel.get('border_seam_first', float('nan')):.3f} -> {sel.get('border_seam_predicted', float('nan')):.3f}"
            + (f", criterion {sel['border_criterion']}" if "border_criterion" in sel else "")
            + (
                f", sample patches: texture statistics {sel['sample_stats_predicted']:.4f}, colour "
                f"{sel.get('sample_colour_predicted', float('nan')):.4f}"
                + (
                    f", vertex saliency {sel['vertex_saliency_predicted']:.3f}"
                    if "vertex_saliency_predicted" in sel
                    else ""
                )
                if "sample_stats_predicted" in sel
                else ""
            )
        )
    per = sel.get("periodic")
    if isinstance(per, dict):  # the periodic-exemplar rule (tilesynth.builder.periodic)
        lines.append(
            f"              periodic exemplar: tile size {per.get('tile_size')} from its period (autocorrelation "
            f"{per.get('shift_correlation', float('nan')):.3f} at a one-tile shift), mode {per.get('mode')}"
        )
    pol = sel.get("polish")
    if pol:
        lines.append(
            f"              polish: E {pol.get('E_before', float('nan')):.6g} -> "
            f"{sel.get('objective_E', float('nan')):.6g}, {pol.get('moves', 0)} moves in {pol.get('sweeps', 0)} "
            f"sweep(s), {pol.get('evaluations', 0)} evaluations"
        )
    hist = sel.get("history") or {}
    best, mean = hist.get("best", []), hist.get("mean", [])
    if len(best) > 1:
        lines.append("convergence   generation: best E / mean E")
        step = max(1, len(best) // 12)
        shown = sorted(set(range(0, len(best), step)) | {len(best) - 1})
        for g in shown:
            # a tampered file may hold fewer means than bests: show what is there, never fail on it
            m_g = f"{mean[g]:.6g}" if g < len(mean) else "?"
            lines.append(f"              {g + 1:>4}: {best[g]:.6g} / {m_g}")
    return lines
