"""Export version 2 (provenance) against version 1 (atlas): GPU memory, file sizes, fetches, minification error per
level and contrast at far zoom-out (issue 28). Results: ``benches/engine-v2-results.md``.

Material: ``cracked-mud.png`` (512², ``/work/shared/textures``), the default ``c5`` build (625 tiles of 128), with
three maps derived from its luma (height 16-bit, unit normals +y 8-bit, roughness 8-bit) exported beside the
albedo; ``--size 2048`` builds from the exemplar upscaled bicubic (as ``benches/build_scale.py``) and exports v2
only (its atlas would be about 6800² per map: its bytes are computed from the v1 layout rule, not written).
``--browser`` renders the albedo at levels 1..7 in headless Chromium (SwiftShader) through both exports and
compares each with the box filter of the exact CPU synthesis (``tilesynth.engine.reference``).

    nice .venv-dev/bin/python benches/engine_v2.py --size 512 --browser
    nice .venv-dev/bin/python benches/engine_v2.py --size 2048
"""

from __future__ import annotations

import argparse
import base64
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import tilesynth as ts
from tilesynth.engine import atlas as xatlas
from tilesynth.engine import export
from tilesynth.engine import reference as ref
from tilesynth.engine import viewer as xv
from tilesynth.engine import viewer_v2 as v2

TEXTURE = Path("/work/shared/textures/cracked-mud.png")


def derived_maps(ex: np.ndarray) -> dict[str, np.ndarray]:
    luma = ex[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    gy, gx = np.gradient(luma * 6.0)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return {
        "height": np.round(luma * 65535).astype(np.uint16),
        "normal": np.round((n * 0.5 + 0.5) * 255).astype(np.uint8),
        "roughness": np.round((1 - luma) * 255).astype(np.uint8),
    }


def exemplar(size: int) -> np.ndarray:
    from PIL import Image

    im = Image.open(TEXTURE).convert("RGB")
    if size != im.size[0]:
        im = im.resize((size, size), Image.BICUBIC)
    return np.asarray(im, np.float32) / 255.0


def dir_bytes(d: Path) -> dict[str, int]:
    files = [p for p in d.rglob("*") if p.is_file()]
    return {
        "total": sum(p.stat().st_size for p in files),
        "viewer": sum(p.stat().st_size for p in files if p.name == "viewer.html"),
        "maps": sum(p.stat().st_size for p in files if p.name.startswith("map_")),
    }


def v1_gpu_bytes(m: dict) -> int:
    """Uncompressed GPU bytes of a version-1 export: every atlas level, 3-channel maps as RGBA."""
    total = 0
    for mp in m["maps"]:
        c = 4 if mp["channels"] == 3 else mp["channels"]
        b = {"uint8": 1, "uint16": 2, "float32": 4}[mp["sample_type"]]
        total += sum(lv["width"] * lv["height"] * c * b for lv in mp["levels"])
    return total


def v1_gpu_bytes_rule(n_tiles: int, n: int, padding: int, shapes: list[tuple[int, int]]) -> int:
    """The same from the layout rule (cells of N + 2P, levels to the largest L with 2^L | N, P)."""
    cols, rows = xatlas.grid_for(n_tiles)
    levels = xatlas.max_mip_level(n, padding)
    s = n + 2 * padding
    total = 0
    for c, b in shapes:
        c = 4 if c == 3 else c
        total += sum((cols * s >> lv) * (rows * s >> lv) * c * b for lv in range(levels + 1))
    return total


def memory(size: int, with_v1: bool) -> None:
    ex = exemplar(size)
    t = time.process_time()
    tiles = ts.build_omega(ex, seed=1)
    print(f"build {size}²: {time.process_time() - t:.1f} s CPU, {tiles.n_tiles} tiles of {tiles.tile_size}")
    maps = derived_maps(ex)
    with tempfile.TemporaryDirectory() as d:
        t = time.process_time()
        m2 = export(tiles, Path(d) / "v2", maps=maps, viewer=size <= 512)
        print(f"export v2: {time.process_time() - t:.1f} s CPU")
        g = m2["gpu_bytes"]
        print(
            f"v2 GPU: maps {g['maps'] / 2**20:.2f} MiB, bits {g['bits'] / 2**20:.2f}, coverage "
            f"{g['coverage'] / 2**20:.2f}, table {g['table'] / 2**20:.3f}, blend {g.get('blend', 0) / 2**20:.3f}, "
            f"low bands {g.get('low_band', 0) / 2**20:.3f}, total "
            f"{g['total'] / 2**20:.2f} MiB = {g['ratio_to_maps']:.3f}x the maps"
        )
        fb = dir_bytes(Path(d) / "v2")
        print(
            f"v2 files: {fb['total'] / 2**20:.2f} MiB (maps' PNGs {fb['maps'] / 2**20:.2f}, viewer {fb['viewer'] / 2**20:.2f})"
        )
        shapes = [
            (a.shape[2] if a.ndim == 3 else 1, a.dtype.itemsize)
            for a in [tiles.exemplar[..., :3], *maps.values()]
        ]
        shapes[0] = (3, 1)  # the albedo at 8 bits
        rule = v1_gpu_bytes_rule(tiles.n_tiles, tiles.tile_size, 8, shapes)
        print(f"v1 GPU by the layout rule: {rule / 2**20:.1f} MiB = {rule / g['maps']:.1f}x the maps")
        if with_v1:
            t = time.process_time()
            m1 = export(tiles, Path(d) / "v1", maps=maps, viewer=True, format="atlas")
            print(f"export v1: {time.process_time() - t:.1f} s CPU")
            b1 = v1_gpu_bytes(m1)
            fb1 = dir_bytes(Path(d) / "v1")
            print(
                f"v1 GPU (written): {b1 / 2**20:.1f} MiB = {b1 / g['maps']:.1f}x; files {fb1['total'] / 2**20:.2f} MiB, viewer {fb1['viewer'] / 2**20:.2f} MiB"
            )


def _luma(img: np.ndarray) -> np.ndarray:
    return img[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])


def browser(size: int) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from webgl import find_browser, run_page

    exe = find_browser()
    ex = exemplar(size)
    tiles = ts.build_omega(ex, seed=1)
    n = tiles.tile_size
    rows = []
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        m2 = export(tiles, d / "v2", seed=7)
        m1 = export(tiles, d / "v1", seed=7, format="atlas")
        imap = None
        r2 = v2.ReferenceV2(tiles, m2, imap, v2.arrays_of(tiles, m2, d / "v2"))
        levels1 = xv.albedo_levels(d / "v1", m1)
        r1 = xv.Reference(tiles, m1, imap, levels1)
        cases, refs = [], {}
        for lv in range(1, 8):
            f = 2**lv
            w = h = 48
            ox, oy = -3 * n - 0.37 * f, -5 * n + 0.21 * f
            refs[lv] = np.clip(np.rint(r2.sampled("albedo", ox, oy, w, h, f, lv)), 0, 255).astype(np.uint8)
            cases.append(xv.case(f"L{lv}", "grad", (ox, oy), w, h, f, 255, refs[lv], dump=True))
        cfg2 = v2.config_for(tiles, m2, d / "v2", imap, cases)
        cfg2["autorun"] = True
        (d / "p2.html").write_text(v2.page(cfg2))
        cfg1 = xv.config_for(tiles, m1, levels1, imap, cases)
        cfg1["autorun"] = True
        (d / "p1.html").write_text(xv.page(cfg1))
        got = {}
        for tag, p in (("v1", d / "p1.html"), ("v2", d / "p2.html")):
            rep = run_page(exe, p, timeout=900)
            assert rep.get("error") is None, rep
            got[tag] = {c["name"]: c for c in rep["cases"]}
        del r1
        for lv in range(1, 8):
            row = [lv]
            for tag in ("v1", "v2"):
                img = np.frombuffer(base64.b64decode(got[tag][f"L{lv}"]["image"]), np.uint8).reshape(
                    refs[lv].shape
                )
                diff = img[..., :3].astype(float) - refs[lv][..., :3]
                rms = float(np.sqrt((diff**2).mean()))
                contrast = _luma(img).std() / max(_luma(refs[lv]).std(), 1e-9)
                row += [round(rms, 2), round(contrast, 3)]
            rows.append(row)
    print("level | v1 RMS | v1 contrast | v2 RMS | v2 contrast   (of 255; contrast = luma std / reference's)")
    for row in rows:
        print(" | ".join(map(str, row)))
    counts(tiles, exe, run_page)


def counts(tiles, exe, run_page) -> None:
    """Texture fetches per pixel counted in the shader (TS_COUNT_FETCHES), 4 maps, hash: the smooth maps cut
    (every blend level 0) and with the seam blend (the default; its weights shared by the three smooth maps),
    128 x 128 pixels from 1/2x to 64x zoom-out; at 1x also apart for the pixels whose CPU blend weights are all
    one entry's (the formula's "single" pixels, :func:`tilesynth.synth.seams.blend_weights`) and the others."""
    from tilesynth.synth.seams import blend_weights, check_bands, tile_bands

    n = tiles.tile_size
    maps = derived_maps(tiles.exemplar)
    w = 128
    dummy = np.zeros((w, w, 4), np.uint8)
    scales = (0.5, 1.0, 2.0, 8.0, 64.0)
    x0, y0 = -n - 0.3, -2 * n + 0.7
    cases = [xv.case(f"{s}", "count", (x0, y0), w, w, s, 255, dummy, dump=True) for s in scales]
    prov = tiles._provenance()
    bands = tile_bands(check_bands(None, "scalar"), n)
    e = prov.table.shape[1]
    single_t = np.zeros(prov.labels.shape, bool)
    for lo in range(0, tiles.n_tiles, 16):  # bounded memory: 16 tiles at a time
        lab = prov.labels[lo : lo + 16]
        s1 = blend_weights(lab, e, bands["high"]).max(axis=1) >= 1.0
        if "low" in bands:
            s1 &= blend_weights(lab, e, bands["low"], int(bands["reach"])).max(axis=1) >= 1.0
        single_t[lo : lo + 16] = s1
    cut = {"height": 0, "normal": 0, "roughness": 0}
    print("fetches per pixel: smooth maps | zoom-out | mean | share at <= M + 1 | median | max")
    for tag, blend in (("cut", cut), ("blend", None)):
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            m = export(tiles, d / "v2", maps=maps, seed=7, blend_levels=blend)
            cfg = v2.config_for(tiles, m, d / "v2", None, cases)
            cfg["autorun"] = True
            (d / "p.html").write_text(v2.page(cfg))
            rep = run_page(exe, d / "p.html", timeout=900)
        mm = len(m["maps"])
        index_of = ref.index_function(m["lookup"], None)
        for c in rep["cases"]:
            img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(w, w, 4)
            k = img[..., 0].astype(int)
            print(
                f"{tag} | {c['name']}x | {k.mean():.2f} | {(k <= mm + 1).mean():.3f} | {np.median(k):.0f} | {k.max()}"
            )
            if c["name"] == "1.0":
                yy, xx = np.mgrid[0:w, 0:w]
                py, px = np.floor(y0 + yy + 0.5).astype(int), np.floor(x0 + xx + 0.5).astype(int)
                t = index_of(np.floor_divide(px, n), np.floor_divide(py, n))
                single = single_t[t, py % n, px % n]
                print(
                    f"  1x, {tag}: single-entry pixels {single.mean():.3f}: mean {k[single].mean():.2f}, at <= M + 1 "
                    f"{(k[single] <= mm + 1).mean():.3f}, max {k[single].max()}; the others: mean "
                    f"{k[~single].mean():.2f}, median {np.median(k[~single]):.0f}, max {k[~single].max()}"
                )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--browser", action="store_true")
    ap.add_argument("--no-v1", action="store_true")
    ap.add_argument("--counts", action="store_true", help="only the fetch counts (browser)")
    a = ap.parse_args()
    if a.counts:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        from webgl import find_browser, run_page

        counts(ts.build_omega(exemplar(a.size), seed=1), find_browser(), run_page)
        return
    memory(a.size, with_v1=not a.no_v1 and a.size <= 512)
    if a.browser:
        browser(a.size)


if __name__ == "__main__":
    _ = ref
    main()
