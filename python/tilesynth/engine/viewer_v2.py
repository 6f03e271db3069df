"""The offline viewer of a version-2 export: one self-contained HTML file (WebGL2) drawing every map of a
material through ``tilesynth_v2.glsl``: each map alone, or a lit preview (albedo, normal, height and roughness
under a movable light), from close up to far zoom-out.

The maps are embedded as the exported PNG levels (8-bit previews of 16-bit and float maps), the label bits,
coverage and source table as exported: the file is a small multiple of the maps, whatever the tile count.
With ``?selftest`` it renders fixed windows of the albedo into an RGBA8 target, reads them back and compares
them with CPU references embedded in the page: level 0 (``texelFetch`` and ``textureGrad`` at texel centres)
exactly against :func:`tilesynth.synthesize`, and each mip level within a stated tolerance against a box filter
of the exact synthesis (:class:`ReferenceV2`); ``#selftest-status`` says ``PASS n`` / ``FAIL n``.
"""

from __future__ import annotations

import base64
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ParameterError
from . import reference as ref
from .viewer import case, embed_levels, fill_template, index_entry, lookup_uniforms, read_index

__all__ = [
    "BLEND_TOLERANCE",
    "MIP_RMS",
    "MIP_TOLERANCE",
    "PHASE_FACTOR",
    "ReferenceV2",
    "config_for",
    "default_cases",
    "page",
    "write_viewer",
]

MIP_TOLERANCE = 255
"""Largest per-channel difference (of 255) the self-test allows at a mip level >= 1 against the box-filtered
reference: none (a single texel can differ by the whole contrast of a feature); the cases fail on their RMS
(:data:`MIP_RMS`). Why not 2 as the atlas: the exemplar's level-L texels are not aligned with the texture's 2^L blocks
(a source sits at any pixel offset), so a minified sample is the exemplar's level L bilinear on a shifted grid:
another box filter of the same texture, as correct, but not the same numbers. Measured on lettuce (c5, tiles of
64): the reference against itself with its block grid shifted by half a block differs by RMS 5.2, 8.0, 10.6,
11.3, 10.3, 7.9, 4.7, 2.3 at levels 1..8; the GPU's RMS is below that (3.9-8.4, ``tests/test_export_v2_browser.py``)."""
MIP_RMS = 4.0
"""A mip-level case fails on an RMS (of 255) above ``max(MIP_RMS, PHASE_FACTOR x its phase floor)``: the phase floor
(:attr:`ReferenceV2.phase_floor`) is the RMS between the reference and the same box filter on a grid shifted by
half a block, computed for the case's window, so the tolerance follows the texture's own contrast at that level
(the shift the exemplar's mips see is anywhere from 0 to a whole block). Measured: GPU RMS / floor 0.97-1.39 at
levels 1-8 on lettuce (c5, tiles of 64; RMS 3.9-8.4), RMS 1.8-6.3 at levels 1-7 on the default 512² build of
cracked mud. The rest above the floor: the coverage weights (label level 2 serves levels 1-2) and bilinear
interpolation of two sources across a cut."""
PHASE_FACTOR = 1.5
"""See :data:`MIP_RMS`."""


class ReferenceV2:
    """CPU references of one version-2 export: exact texels of every map (colour by :func:`tilesynth.synthesize`,
    every other map gathered through the provenance, normals turned with their patches) and box-filtered levels."""

    def __init__(
        self, tileset: Any, manifest: dict[str, Any], imap: np.ndarray | None, arrays: dict[str, Any]
    ):
        self.tileset = tileset
        self.n = tileset.tile_size
        self.index_of = ref.index_function(manifest["lookup"], imap)
        self.manifest = manifest
        self.arrays = arrays
        self.maps = {m["name"]: m for m in manifest["maps"]}

    def texels(self, name: str, x0: int, y0: int, w: int, h: int) -> np.ndarray:
        """``(h, w, 4)`` uint8 read-back of map ``name`` (8-bit, as the viewer shows it)."""
        from ..base.validate import to_uint

        if name == "albedo":
            img = ref.texture_window(self.tileset, self.index_of, x0, y0, w, h, dtype=np.float32)
            return ref.to_rgba8(to_uint(img, 8))
        m = self.maps[name]
        img = ref.map_window(self.tileset, self.arrays[name], self.index_of, x0, y0, w, h, m["normal"])
        return ref.to_rgba8(to_preview8(img))

    def synthesized(self, name: str, x0: int, y0: int, w: int, h: int) -> np.ndarray:
        """``(h, w, C)`` of the tile set's map ``name`` by :func:`tilesynth.synthesize_maps` (smooth maps with
        their seams blended) at texture pixel (x0, y0), in its sample type."""
        from ..builder.materials import synthesize_maps

        n = self.n
        cx0, cy0 = x0 // n, y0 // n
        cy, cx = np.mgrid[cy0 : (y0 + h - 1) // n + 1, cx0 : (x0 + w - 1) // n + 1]
        sub = np.ascontiguousarray(self.index_of(cx, cy), dtype=np.int32)
        got = synthesize_maps(self.tileset, sub, w, h, offset=(y0 - cy0 * n, x0 - cx0 * n))[name]
        return got if got.ndim == 3 else got[:, :, None]

    def sampled(
        self, name: str, x0: float, y0: float, w: int, h: int, scale: float, level: int = 0
    ) -> np.ndarray:
        """Bilinear samples of the 2^level box filter of the exact texture at ``origin + (i + 0.5) * scale``:
        float64 ``(h, w, 4)``."""
        f = 2**level
        gx, gy, win = ref.sample_grid(x0, y0, w, h, scale, level)
        ax0, ay0 = win[:2]
        tex = self.texels(name, *win)
        srgb = self.maps[name]["colour_space"] == "srgb"
        lvl = ref.box_level(tex, level, srgb=srgb) if level else tex
        out = ref.bilinear(lvl, gx, gy, ax0 // f, ay0 // f)
        if level:
            # the same box filter on a grid shifted by half a block: as valid a level L, other numbers
            h = f // 2
            sh = ref.box_level(tex[h : h + tex.shape[0] - f, h : h + tex.shape[1] - f], level, srgb=srgb)
            alt = ref.bilinear(sh, gx - h / f, gy - h / f, ax0 // f, ay0 // f)
            self.phase_floor = float(np.sqrt(((out[..., :3] - alt[..., :3]) ** 2).mean()))
        return out


BLEND_TOLERANCE = 2
"""Largest difference (of 255) the self-test allows for a blended smooth map at 1:1 against
:func:`tilesynth.synthesize_maps`: float32 against float64, 8-bit previews of 16-bit maps, the low band stored in
the map's sample type (measured: at most 1, ``tests/test_export_v2_browser.py``; a multi-channel scalar map reads
its low band from its own mips: up to 3 where the exemplar's sides are not multiples of 2^split)."""


def to_preview8(img: np.ndarray) -> np.ndarray:
    """8-bit preview of a map level (uint16 rounded to 8 bits, float clipped to [0, 1]), as the viewer embeds it."""
    if img.dtype == np.uint8:
        return img
    if img.dtype == np.uint16:
        return np.clip(np.rint(img.astype(np.float64) / 257.0), 0, 255).astype(np.uint8)
    return np.clip(np.rint(np.asarray(img, np.float64) * 255.0), 0, 255).astype(np.uint8)


def default_cases(r: ReferenceV2) -> list[dict[str, Any]]:
    """Level 0 exact (texelFetch and texel centres) and levels 1..6 (64x; fewer for an exemplar under 128 px) of
    the albedo within the tolerance (:data:`MIP_RMS`); every blended map the tile set stores at 1:1 within
    :data:`BLEND_TOLERANCE` of :func:`tilesynth.synthesize_maps`."""
    n = r.n
    cases = []
    w = h = min(48, 2 * n)
    for name, (x0, y0) in (
        ("fetch, negative origin, 4 tiles", (-n - n // 3, -n // 2 - 5)),
        ("fetch, positive origin", (3 * n - 7, 2 * n + 3)),
    ):
        cases.append(case(name, "fetch", (x0, y0), w, h, 1.0, 0, r.texels("albedo", x0, y0, w, h)))
    x0, y0 = -n // 2 - 3, -n - 9
    exact = np.rint(r.sampled("albedo", x0, y0, w, h, 1.0)).astype(np.uint8)
    cases.append(case("textureGrad at texel centres", "grad", (x0, y0), w, h, 1.0, 0, exact))
    # every map the shaders blend and the tile set stores: 1:1 against synthesize_maps (the seam blend)
    stored = set(getattr(r.tileset, "maps", None) or {})
    for i, m in enumerate(r.manifest["maps"]):
        if m.get("seam") == "blend" and m["name"] in stored:
            exact = ref.to_rgba8(to_preview8(r.synthesized(m["name"], x0, y0, w, h)))
            c = case(
                f"{m['name']}: the seam blend at 1:1", "grad", (x0, y0), w, h, 1.0, BLEND_TOLERANCE, exact
            )
            c["map"] = i
            cases.append(c)
    ex = r.tileset.exemplar.shape
    top = min(6, max(1, int(np.log2(min(ex[0], ex[1]))) - 1))  # to 64x, while the exemplar has 2 x 2 texels
    for lv in range(1, top + 1):
        f = 2**lv
        ww = hh = 32
        m = np.clip(np.rint(r.sampled("albedo", -n, -2 * n, ww, hh, f, lv)), 0, 255).astype(np.uint8)
        c = case(f"minified, level {lv}", "grad", (-n, -2 * n), ww, hh, f, MIP_TOLERANCE, m)
        c["rms_tol"] = max(MIP_RMS, PHASE_FACTOR * r.phase_floor)
        cases.append(c)
    return cases


def config_for(
    tileset: Any,
    manifest: dict[str, Any],
    out: Path,
    imap: np.ndarray | None,
    selftest: list[dict[str, Any]],
    seed: int | None = None,
) -> dict[str, Any]:
    """The viewer's config: every map's levels (embedded PNGs), the labels, the table, the lookup."""
    from ..io.images import load_raster, pending_path

    def load(fname: str) -> np.ndarray:
        a = np.asarray(load_raster(pending_path(out / fname)))
        return a[:, :, None] if a.ndim == 2 else a

    lookup, wrap = lookup_uniforms(manifest["lookup"])
    lab = manifest["labels"]
    maps = []
    for m in manifest["maps"]:
        levels = [to_preview8(load(lv["file"])) for lv in m["levels"]]
        low = m.get("low_band")
        if low is not None:
            if m["channels"] != 1 or low.get("channel") != 1 or len(low["levels"]) != len(m["levels"]):
                raise ParameterError(
                    f"manifest map {m['name']!r}: a low_band needs a one-channel map and one level per map "
                    f"level in channel 1 (got channels {m['channels']}, channel {low.get('channel')!r}, "
                    f"{len(low['levels'])} levels for {len(m['levels'])}): this viewer cannot read it"
                )
            low = embed_levels([to_preview8(load(lv["file"])) for lv in low["levels"]])
        maps.append(
            {
                "name": m["name"],
                "kind": m["kind"],
                "channels": m["channels"],
                "normal": m["normal"],
                "blend_level": m["blend_level"],
                "levels": embed_levels(levels),
                "low": low,
                **{k: m[k] for k in ("seam", "bands", "mean") if k in m},
            }
        )
    cov = [load(lv["file"])[:, :, 0] for lv in lab["coverage"]["levels"]]
    table = np.fromfile(pending_path(out / lab["table"]["file"]), dtype="<i4")
    cfg: dict[str, Any] = {
        "title": f"tilesynth: {manifest['tile_set']} ({manifest['scheme']}), {manifest['tile_count']} tiles of "
        f"{manifest['tile_size']} px, {manifest['lookup']['mode']} lookup, {len(maps)} map(s), export v2",
        "layout": [manifest["tile_size"], lab["bits"]["columns"], lab["coverage"]["columns"], len(cov) - 1],
        "lookup": lookup,
        "wrap": wrap,
        "seed": int(manifest["lookup"]["seed"] if seed is None else seed),
        "maps": maps,
        "bits": embed_levels([load(lab["bits"]["file"])])[0],
        "coverage": embed_levels([c[:, :, None] for c in cov]),
        "table": {
            "width": lab["table"]["width"],
            "height": lab["table"]["height"],
            "data": base64.b64encode(table.astype("<i4").tobytes()).decode(),
        },
        "blend": None,
        "autorun": False,
        "index": index_entry(imap),
        "selftest": selftest,
        "init": [0.0, 0.0, 1.0],
    }
    if "blend" in lab:
        from .provenance_export import blend_shares

        r = lab["blend"]
        span = tuple(r["reach_levels"]) if r["reach_levels"] else None
        shares = blend_shares(load(r["file"])[:, :, 0], manifest["tile_size"], r["high_level"], span)
        cfg["blend"] = {
            "width": r["width"],
            "height": r["height"],
            "layout": [r["columns"], r["high_level"], span[0] if span else -1, span[1] if span else -1],
            "data": base64.b64encode(shares.astype("<f2").tobytes()).decode(),
        }
    return cfg


def page(config: dict[str, Any]) -> str:
    """The viewer HTML of a config (:func:`config_for`)."""
    from .sources import shader_source

    tpl = resources.files(__package__).joinpath("viewer_v2_template.html").read_text(encoding="utf-8")
    config = dict(config)
    imgs = []
    maps = []
    for i, m in enumerate(config["maps"]):
        for j, lv in enumerate(m["levels"]):
            imgs.append(f'<img id="ts-map-{i}-{j}" alt="" src="data:image/png;base64,{lv["png"]}">')
        for j, lv in enumerate(m.get("low") or []):
            imgs.append(f'<img id="ts-low-{i}-{j}" alt="" src="data:image/png;base64,{lv["png"]}">')
        low = [{k: v for k, v in lv.items() if k != "png"} for lv in m["low"]] if m.get("low") else None
        maps.append(
            dict(m, levels=[{k: v for k, v in lv.items() if k != "png"} for lv in m["levels"]], low=low)
        )
    config["maps"] = maps
    for j, lv in enumerate(config["coverage"]):
        imgs.append(f'<img id="ts-cov-{j}" alt="" src="data:image/png;base64,{lv["png"]}">')
    config["coverage"] = [{k: v for k, v in lv.items() if k != "png"} for lv in config["coverage"]]
    imgs.append(f'<img id="ts-bits" alt="" src="data:image/png;base64,{config["bits"]["png"]}">')
    config["bits"] = {k: v for k, v in config["bits"].items() if k != "png"}
    return fill_template(tpl, "".join(imgs), config, shader_source("tilesynth_v2.glsl"))


def arrays_of(tileset: Any, manifest: dict[str, Any], out: Path) -> dict[str, np.ndarray]:
    """Level 0 of every map as exported (read back from ``out``)."""
    from ..io.images import load_raster, pending_path

    res = {}
    for m in manifest["maps"]:
        a = np.asarray(load_raster(pending_path(out / m["levels"][0]["file"])))
        res[m["name"]] = a[:, :, None] if a.ndim == 2 else a
    return res


def write_viewer(tileset: Any, path: Path, manifest: dict[str, Any], out: Path) -> None:
    """Write ``viewer.html`` for a version-2 export already written to ``out``."""
    imap = read_index(out, manifest)
    r = ReferenceV2(tileset, manifest, imap, arrays_of(tileset, manifest, out))
    cfg = config_for(tileset, manifest, out, imap, default_cases(r))
    from ..io.images import atomic_open

    with atomic_open(path, "wb") as fh:
        fh.write(page(cfg).encode("utf-8"))
