"""The offline viewer: one self-contained HTML file (WebGL2) drawing the exported atlas with the exported GLSL.

It shows the texture on an infinite plane (drag to pan, wheel to zoom, a seed field in hash mode). With
``?selftest`` it renders fixed windows into an RGBA8 target, reads them back and compares them with CPU reference
pixels embedded in the page (computed by :func:`tilesynth.synthesize`, see :mod:`.reference`), then writes
``PASS n`` / ``FAIL n`` (n = differing pixels) into ``#selftest-status`` and a JSON report of every case into
``#selftest-result``. The atlas levels are embedded as 8-bit PNGs (a 16-bit atlas is previewed at 8 bits), the
index map as raw little-endian uint16.

Default self-test windows: texelFetch composition at a negative origin straddling four tiles and at a
positive one (exact), bilinear through ``ts_sample_grad`` at texel centres (exact), magnified 4x (within 1), and
at every mip level L >= 1 minified by 2^L, shifted half a level-L texel so samples straddle tile borders
(within 2 of the box-filtered reference).
"""

from __future__ import annotations

import base64
import io
import json
import re
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from . import reference as ref


def _png_bytes(arr: np.ndarray) -> bytes:
    from PIL import Image

    if arr.dtype == np.uint16:
        arr = np.clip(np.rint(arr.astype(np.float64) / 257.0), 0, 255).astype(np.uint8)
    if arr.dtype != np.uint8:
        arr = np.clip(np.rint(np.asarray(arr, np.float64) * 255.0), 0, 255).astype(np.uint8)
    if arr.shape[2] == 1:
        arr = arr[:, :, 0]
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(arr)).save(buf, format="PNG")
    return buf.getvalue()


def lookup_uniforms(lookup: dict[str, Any]) -> tuple[list[int], list[int]]:
    """``ts_lookup`` (mode, K, Kv, V) and ``ts_wrap`` of a manifest's ``lookup``."""
    if lookup["mode"] == "index_map":
        return [0, 0, 0, 1], [0, 0]
    wrap = lookup.get("wrap") or [0, 0]
    if lookup["kind"] == "corner":
        return [1, lookup["K"], 0, lookup["V"]], list(wrap)
    return [2, lookup["Kh"], lookup["Kv"], lookup["V"]], list(wrap)


def case(
    name: str,
    kind: str,
    origin: tuple[float, float],
    w: int,
    h: int,
    scale: float,
    tol: int,
    reference: np.ndarray,
    dump: bool = False,
    seed: int | None = None,
    exempt: np.ndarray | None = None,
) -> dict[str, Any]:
    """One self-test case; ``reference`` is the ``(h, w, 4)`` uint8 expected read-back; ``exempt`` (bool
    ``(h, w)``) marks pixels counted apart (reported, not failed): footprints on inexact gutter texels."""
    assert reference.shape == (h, w, 4) and reference.dtype == np.uint8
    c = {
        "name": name,
        "kind": kind,
        "origin": [float(origin[0]), float(origin[1])],
        "w": w,
        "h": h,
        "scale": float(scale),
        "tol": int(tol),
        "ref": base64.b64encode(reference.tobytes()).decode(),
        "dump": dump,
    }
    if seed is not None:
        c["seed"] = int(seed)
    if exempt is not None:
        c["exempt"] = base64.b64encode(np.asarray(exempt, np.uint8).tobytes()).decode()
    return c


class Reference:
    """CPU reference windows of one export (albedo, 8-bit)."""

    def __init__(
        self,
        tileset: Any,
        manifest: dict[str, Any],
        imap: np.ndarray | None,
        levels: list[np.ndarray] | None = None,
    ):
        self.tileset = tileset
        self.n = tileset.tile_size
        self.index_of = ref.index_function(manifest["lookup"], imap)
        self.manifest = manifest
        self.levels = levels

    def texels(self, x0: int, y0: int, w: int, h: int) -> np.ndarray:
        from ..base.validate import to_uint

        img = ref.texture_window(self.tileset, self.index_of, x0, y0, w, h, dtype=np.float32)
        return ref.to_rgba8(to_uint(img, 8))

    def fetch(self, x0: int, y0: int, w: int, h: int) -> np.ndarray:
        return self.texels(x0, y0, w, h)

    def sampled(self, x0: float, y0: float, w: int, h: int, scale: float, level: int = 0) -> np.ndarray:
        """Bilinear at level ``level`` (a direct box filter of the texture) at the sample positions
        ``origin + (i + 0.5) * scale``; returns float64 ``(h, w, 4)``."""
        f = 2**level
        gx, gy, win = ref.sample_grid(x0, y0, w, h, scale, level)
        tex = self.texels(*win)
        lvl = ref.box_level(tex, level, srgb=True) if level else tex
        self._last = (lvl, win[0] // f, win[1] // f)
        return ref.bilinear(lvl, gx, gy, win[0] // f, win[1] // f)

    def inexact_gutter(self, x0: float, y0: float, w: int, h: int, scale: float, level: int) -> np.ndarray:
        """bool ``(h, w)``: samples whose level-``level`` bilinear footprint reads a gutter texel that differs
        (by more than 1) from what the neighbouring tile actually shows there (the places where no per-tile
        gutter can be exact, see :mod:`.atlas`). Call after :meth:`sampled` with the same window."""
        lvl, ox, oy = self._last
        f = 2**level
        m = self.manifest
        n, p, cols = m["tile_size"], m["padding"], m["atlas"]["columns"]
        s = n + 2 * p
        nl = n // f
        at = self.levels[level].astype(np.int64)
        at = ref.to_rgba8(at.astype(np.uint8)).astype(np.int64) if at.shape[2] != 4 else at
        truth = lvl.astype(np.int64)
        qx = x0 + (np.arange(w) + 0.5) * scale
        qy = y0 + (np.arange(h) + 0.5) * scale
        gx, gy = np.meshgrid(qx, qy)
        cx, cy = np.floor(gx / n).astype(np.int64), np.floor(gy / n).astype(np.int64)
        tile = self.index_of(cx, cy)
        tx0 = ((tile % cols) * s + p) // f
        ty0 = ((tile // cols) * s + p) // f
        ix = np.floor(gx / f - 0.5).astype(np.int64)
        iy = np.floor(gy / f - 0.5).astype(np.int64)
        bad = np.zeros((h, w), bool)
        for dy in (0, 1):
            for dx in (0, 1):
                tx, ty = ix + dx, iy + dy
                lx, ly = tx - cx * nl, ty - cy * nl
                gutter = (lx < 0) | (lx >= nl) | (ly < 0) | (ly >= nl)
                a = at[ty0 + ly, tx0 + lx]
                t = truth[ty - oy, tx - ox]
                bad |= gutter & (np.abs(a - t).max(axis=-1) > 1)
        return bad


def default_cases(r: Reference, manifest: dict[str, Any]) -> list[dict[str, Any]]:
    n = r.n
    cases = []
    w = h = min(48, 2 * n)
    for name, (x0, y0) in (
        ("fetch, negative origin, 4 tiles", (-n - n // 3, -n // 2 - 5)),
        ("fetch, positive origin", (3 * n - 7, 2 * n + 3)),
    ):
        cases.append(case(name, "fetch", (x0, y0), w, h, 1.0, 0, r.fetch(x0, y0, w, h)))
    x0, y0 = -n // 2 - 3, -n - 9
    exact = np.rint(r.sampled(x0, y0, w, h, 1.0)).astype(np.uint8)
    cases.append(case("bilinear at texel centres", "grad", (x0, y0), w, h, 1.0, 0, exact))
    mag = np.rint(r.sampled(-n / 2 - 2.3, 0.7 - n, w, h, 0.25)).astype(np.uint8)
    cases.append(case("magnified 4x", "grad", (-n / 2 - 2.3, 0.7 - n), w, h, 0.25, 1, mag))
    for lv in range(1, manifest["atlas"]["max_level"] + 1):
        f = 2**lv
        ww = hh = max(8, min(32, 3 * n // f))
        ox, oy = -n - f / 2, -2 * n - f / 2
        m = np.clip(np.rint(r.sampled(-n, -2 * n, ww, hh, f, lv)), 0, 255).astype(np.uint8)
        cases.append(case(f"minified, level {lv}, texel centres", "grad", (-n, -2 * n), ww, hh, f, 2, m))
        m = np.clip(np.rint(r.sampled(ox, oy, ww, hh, f, lv)), 0, 255).astype(np.uint8)
        ex = r.inexact_gutter(ox, oy, ww, hh, f, lv)
        cases.append(case(f"minified, level {lv}, straddling", "grad", (ox, oy), ww, hh, f, 2, m, exempt=ex))
    return cases


def page(config: dict[str, Any]) -> str:
    """The viewer HTML for a config (levels, layout, lookup, selftest cases)."""
    tpl = resources.files(__package__).joinpath("viewer_template.html").read_text(encoding="utf-8")
    from .sources import shader_source

    config = dict(config)
    imgs = "".join(
        f'<img id="ts-level-{i}" alt="" src="data:image/png;base64,{lv["png"]}">'
        for i, lv in enumerate(config["levels"])
    )
    config["levels"] = [{k: v for k, v in lv.items() if k != "png"} for lv in config["levels"]]
    return fill_template(tpl, imgs, config, shader_source("tilesynth.glsl"))


def fill_template(tpl: str, imgs: str, config: dict[str, Any], glsl: str) -> str:
    """A viewer template with its images, configuration and shader put in (both export versions' pages)."""
    # Inside <script>, "</script", "<!--" and "<script" in a string (a tile set's name) would end the element or
    # change how the HTML parser reads it; JSON may write <, > and & as \u escapes, so none of them is left.
    cfg = json.dumps(config).replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    parts = {"<!--TS_IMAGES-->": imgs, "/*TS_CONFIG*/": cfg, "/*TS_GLSL*/": glsl}
    # one pass over the template: text put in for one placeholder is never searched for another
    return re.sub("|".join(map(re.escape, parts)), lambda m: parts[m.group(0)], tpl)


def embed_levels(levels: list[np.ndarray]) -> list[dict[str, Any]]:
    """Images as the viewer embeds them: size and base64 PNG."""
    return [
        {"width": int(a.shape[1]), "height": int(a.shape[0]), "png": base64.b64encode(_png_bytes(a)).decode()}
        for a in levels
    ]


def index_entry(imap: np.ndarray | None) -> dict[str, Any] | None:
    """An index map as the viewer embeds it (little-endian uint16), or None for the hash lookup."""
    if imap is None:
        return None
    return {
        "width": int(imap.shape[1]),
        "height": int(imap.shape[0]),
        "data": base64.b64encode(imap.astype("<u2").tobytes()).decode(),
    }


def config_for(
    tileset: Any,
    manifest: dict[str, Any],
    levels: list[np.ndarray],
    imap: np.ndarray | None,
    selftest: list[dict[str, Any]],
    seed: int | None = None,
) -> dict[str, Any]:
    lookup, wrap = lookup_uniforms(manifest["lookup"])
    cfg: dict[str, Any] = {
        "title": f"tilesynth: {manifest['tile_set']} ({manifest['scheme']}), {manifest['tile_count']} tiles of "
        f"{manifest['tile_size']} px, {manifest['lookup']['mode']} lookup",
        "layout": [manifest["tile_size"], manifest["padding"], manifest["atlas"]["columns"], len(levels) - 1],
        "atlas_size": [manifest["atlas"]["width"], manifest["atlas"]["height"]],
        "lookup": lookup,
        "wrap": wrap,
        "seed": int(manifest["lookup"]["seed"] if seed is None else seed),
        "levels": embed_levels(levels),
        "autorun": False,
        "index": index_entry(imap),
        "selftest": selftest,
        "init": [0.0, 0.0, 1.0],
    }
    return cfg


def read_index(out: Path, manifest: dict[str, Any]) -> np.ndarray | None:
    if manifest["lookup"]["mode"] != "index_map":
        return None
    from PIL import Image

    from ..io.images import pending_path  # written in the same file set, not yet committed

    return np.asarray(Image.open(pending_path(out / manifest["lookup"]["file"]))).astype(np.int32)


def albedo_levels(out: Path, manifest: dict[str, Any]) -> list[np.ndarray]:
    from ..io.images import load_raster, pending_path

    entry = next(m for m in manifest["maps"] if m["name"] == "albedo")
    return [np.asarray(load_raster(pending_path(out / lv["file"]))) for lv in entry["levels"]]


def write_viewer(
    tileset: Any, path: Path, manifest: dict[str, Any], built: dict[str, Any], out: Path
) -> None:
    """Write ``viewer.html`` for an export already written to ``out``."""
    imap = read_index(out, manifest)
    levels = albedo_levels(out, manifest)
    r = Reference(tileset, manifest, imap, levels)
    cfg = config_for(tileset, manifest, levels, imap, default_cases(r, manifest))
    from ..io.images import atomic_open

    with atomic_open(path, "wb") as fh:
        fh.write(page(cfg).encode("utf-8"))
