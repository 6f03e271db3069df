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

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from .metrics import DEFAULT_SAMPLE_SEED, DEFAULT_SAMPLE_SIZE, measure_tileset
from .report_figures import (  # noqa: F401 - SEAM_RANGE re-exported
    SEAM_RANGE,
    coherence_heatmap,
    colormap,
    convergence_chart,
    sample_with_borders,
    seam_heatmap,
)
from .report_page import _page, metrics_rows


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
    # failure halfway (full disk, Ctrl-C) leaves no half report.
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
    if getattr(tileset, "map_specs", None):  # the maps of a material set
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
