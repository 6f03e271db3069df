"""The texture fetches of the version-2 shader per pixel, by kind and by the number of entries with a non-zero
weight in the CPU formula (issue 28): the table, the footprint path's label read (``ts_weight``), the seam
blend's label reads (bits and coverage of the detail band's levels 0-2; the filtered coverage ``labels_blend``),
and per map its values (level 0) and its low band. Counted in the shader (``TS_COUNT_FETCHES``, headless
Chromium) by rewriting each counted fetch of ``tilesynth_v2.glsl`` into a per-kind counter (four kinds a page).

    nice .venv-dev/bin/python benches/fetch_breakdown.py                      # the engine_v2 bench's set
    nice .venv-dev/bin/python benches/fetch_breakdown.py --tiles /tmp/relief/sets/rock.tiles
"""

from __future__ import annotations

import argparse
import base64
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

import tilesynth as ts
from tilesynth.engine import export, sources
from tilesynth.engine import reference as ref
from tilesynth.engine import viewer as xv
from tilesynth.engine import viewer_v2 as v2

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

# the counted fetches of tilesynth_v2.glsl, by the function they are in (the kind they count as)
KINDS_OF_FUNCTION = {
    "ts_tile_index": "index",
    "ts_table_texel": "table",
    "ts_quad": "table",
    "ts_bit": "w0 label",
    "ts_weight": "w0 label",
    "ts_block_b": "blend bits/cov",
    "ts_level_f": "blend cov",
    "ts_entry": "value",
    "ts_entry_low": "low",
    "ts_entry_raw": "value",  # with the low band beside the map: value and low band in one fetch
}


def patched_glsl(src: str, kinds: list[str]) -> str:
    """The GLSL with every ``TS_COUNT(1)`` counting into ``ts_kc[j]`` when its kind is ``kinds[j]`` (a map's
    values and low band: "value i" / "low i", i the map being drawn)."""
    out, fn = [], None
    for line in src.splitlines():
        m = re.match(r"^\w[\w ]*? (ts_\w+)\(", line)
        if m:
            fn = m.group(1)
        if "TS_COUNT(1)" in line and fn is not None:
            kind = KINDS_OF_FUNCTION[fn]
            conds = []
            for j, k in enumerate(kinds):
                if k == kind:
                    conds.append(f"ts_kc[{j}]++;")
                elif k.split(" ")[0] == kind and " " in k:
                    conds.append(f"if (ts_map_now == {int(k.split(' ')[1])}) ts_kc[{j}]++;")
            line = line.replace("TS_COUNT(1);", "{ TS_COUNT(1); " + " ".join(conds) + " }")
        out.append(line)
    text = "\n".join(out)
    return text.replace(
        "#ifdef TS_COUNT_FETCHES", "int ts_kc[4]; int ts_map_now = 0;\n#ifdef TS_COUNT_FETCHES", 1
    )


def run_kinds(tiles, m, d, cases, exe, run_page, kinds: list[str]) -> dict[str, dict[str, np.ndarray]]:
    orig = sources.shader_source

    def fake(name: str) -> str:
        s = orig(name)
        return patched_glsl(s, kinds) if name == "tilesynth_v2.glsl" else s

    sources.shader_source = fake
    try:
        cfg = v2.config_for(tiles, m, d, None, cases)
        cfg["autorun"] = True
        html = v2.page(cfg)
    finally:
        sources.shader_source = orig
    a = "got[k] = mapAt(i, s, w, b);"
    b = "if (u_mode == 3) { o = vec4(float(ts_fetches) / 255.0, straddles ? 1.0 : 0.0, 0.0, 1.0); return; }"
    assert a in html and b in html
    html = html.replace(a, "ts_map_now = i; " + a).replace(
        b,
        "if (u_mode == 3) { o = vec4(float(ts_kc[0]), float(ts_kc[1]), float(ts_kc[2]), float(ts_kc[3])) / 255.0; return; }",
    )
    p = d / "p.html"
    p.write_text(html)
    rep = run_page(exe, p, timeout=900)
    assert rep.get("error") is None, rep
    res = {}
    for c in rep["cases"]:
        side = int(round(c["pixels"] ** 0.5))
        img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(side, side, 4)
        res[c["name"]] = {k: img[..., j].astype(int) for j, k in enumerate(kinds) if k}
    return res


def entries_per_pixel(tiles, m, x0, y0, w, n):
    """The CPU formula's entries with a non-zero weight in some band (and in the detail band) at 1x."""
    from tilesynth.synth.seams import blend_weights, check_bands, tile_bands

    prov = tiles._provenance()
    bands = tile_bands(check_bands(None, "scalar"), n)
    e = prov.table.shape[1]
    index_of = ref.index_function(m["lookup"], None)
    yy, xx = np.mgrid[0:w, 0:w]
    py, px = np.floor(y0 + yy + 0.5).astype(int), np.floor(x0 + xx + 0.5).astype(int)
    t = index_of(np.floor_divide(px, n), np.floor_divide(py, n))
    uniq = np.unique(t)
    used = prov.table[uniq][:, :, 0, None, None] >= 0
    wh = blend_weights(prov.labels[uniq], e, bands["high"]) * used
    both = wh > 0
    if "low" in bands:
        wl = blend_weights(prov.labels[uniq], e, bands["low"], int(bands["reach"])) * used
        both |= wl > 0
    kh, kb = (wh > 0).sum(1), both.sum(1)
    pos = np.searchsorted(uniq, t)
    return kb[pos, py % n, px % n], kh[pos, py % n, px % n]


def blended_reference(
    r, name: str, x0: float, y0: float, w: int, h: int, scale: float, level: int
) -> np.ndarray:
    """As ``ReferenceV2.sampled`` but of :func:`tilesynth.synthesize_maps` (the seam blend), 8-bit as the viewer
    shows it: bilinear samples of its 2^level box filter."""
    f = 2**level
    gx, gy, win = ref.sample_grid(x0, y0, w, h, scale, level)
    tex = ref.to_rgba8(v2.to_preview8(r.synthesized(name, *win)))
    lvl = ref.box_level(tex, level, srgb=False) if level else tex
    return ref.bilinear(lvl, gx, gy, win[0] // f, win[1] // f)


def mips(tiles, maps, exe, run_page, names=("height", "roughness")) -> None:
    """RMS (of 255) of the blended maps minified (levels 1-5, 32 x 32 px, exact gradients) against the box filter
    of ``synthesize_maps``."""
    n = tiles.tile_size
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        m = export(tiles, d / "v2", maps=maps, seed=7)
        r = v2.ReferenceV2(tiles, m, None, v2.arrays_of(tiles, m, d / "v2"))
        all_names = [mp["name"] for mp in m["maps"]]
        cases, refs = [], {}
        for name in names:
            for lv in range(1, 6):
                f = 2**lv
                ox, oy = -3 * n - 0.37 * f, -5 * n + 0.21 * f
                exact = blended_reference(r, name, ox, oy, 32, 32, f, lv)
                c = xv.case(
                    f"{name} L{lv}",
                    "grad",
                    (ox, oy),
                    32,
                    32,
                    f,
                    255,
                    np.zeros((32, 32, 4), np.uint8),
                    dump=True,
                )
                c["map"] = all_names.index(name)
                cases.append(c)
                refs[c["name"]] = exact
        cfg = v2.config_for(tiles, m, d / "v2", None, cases)
        cfg["autorun"] = True
        (d / "p.html").write_text(v2.page(cfg))
        rep = run_page(exe, d / "p.html", timeout=900)
        assert rep.get("error") is None, rep
    print("map | level | RMS against the box filter of synthesize_maps (of 255)")
    for c in rep["cases"]:
        img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(32, 32, 4)
        diff = img[..., :1].astype(float) - refs[c["name"]][..., :1]
        print(f"{c['name']} | {float(np.sqrt((diff**2).mean())):.2f}")


def main() -> None:
    from engine_v2 import derived_maps, exemplar
    from webgl import find_browser, run_page

    ap = argparse.ArgumentParser()
    ap.add_argument(
        "--tiles", help="a material .tiles (its maps exported); default: the engine_v2 bench's set"
    )
    ap.add_argument("--size", type=int, default=256, help="window side at 1x (pixels)")
    ap.add_argument("--mips", action="store_true", help="only the blended maps' RMS per mip level")
    a = ap.parse_args()
    exe = find_browser()
    if a.tiles:
        tiles = ts.load(a.tiles)
        maps = None
    else:
        tiles = ts.build_omega(exemplar(512), seed=1)
        maps = derived_maps(tiles.exemplar)
    if a.mips:
        mips(tiles, maps, exe, run_page)
        return
    n = tiles.tile_size
    w = a.size
    x0, y0 = -n - 0.3, -2 * n + 0.7
    dummy = np.zeros((w, w, 4), np.uint8)
    scales = (1.0, 8.0, 64.0)
    cases = [xv.case(f"{s}", "count", (x0, y0), w, w, s, 255, dummy, dump=True) for s in scales]
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        m = export(tiles, d / "v2", maps=maps, seed=7)
        names = [mp["name"] for mp in m["maps"]]
        print(f"tiles of {n}, maps {names}, seams {[mp['seam'] for mp in m['maps']]}")
        kinds = ["table", "w0 label", "blend bits/cov", "blend cov"]
        kinds += [f"value {i}" for i in range(len(names))]
        kinds += [f"low {i}" for i, mp in enumerate(m["maps"]) if "low" in (mp.get("bands") or {})]
        kinds += ["index"]
        res: dict[str, dict[str, np.ndarray]] = {}
        for lo in range(0, len(kinds), 4):
            part = kinds[lo : lo + 4] + [""] * (4 - len(kinds[lo : lo + 4]))
            got = run_kinds(tiles, m, d / "v2", cases, exe, run_page, part)
            for c, v in got.items():
                res.setdefault(c, {}).update(v)
    kb, kh = entries_per_pixel(tiles, m, x0, y0, w, n)

    def label(k: str) -> str:
        if k.startswith(("value ", "low ")):
            a, i = k.split(" ")
            return f"{a} {names[int(i)]}"
        return k

    for c, v in res.items():
        total = sum(v.values())
        print(f"\nzoom-out {c}x: total mean {total.mean():.2f}, median {np.median(total):.0f}, max {total.max()}, "
              f"share <= M + 1 {(total <= len(names) + 1).mean():.3f}, <= 2M + 1 {(total <= 2 * len(names) + 1).mean():.3f}")  # fmt: skip
        print("  kind | mean | max")
        for k, a_ in v.items():
            print(f"  {label(k)} | {a_.mean():.2f} | {a_.max()}")
        if c == "1.0":
            print("  by entries of non-zero weight (CPU, any band) | share | total mean | max | "
                  + " | ".join(label(k) for k in v))  # fmt: skip
            for e in range(1, kb.max() + 1):
                sel = kb == e
                if not sel.any():
                    continue
                print(f"  {e} | {sel.mean():.3f} | {total[sel].mean():.2f} | {total[sel].max()} | "
                      + " | ".join(f"{a_[sel].mean():.2f}" for a_ in v.values()))  # fmt: skip
            print(f"  detail band's entries: mean {kh.mean():.2f}; any band: mean {kb.mean():.2f}")
            # the formula's floor for the three smooth maps of this bench (normal, height, roughness) and a cut
            # albedo: the table, the albedo, the normal per detail entry, each scalar map per entry of either
            # band (value and low band in one fetch; 2 per entry of the detail band more without) and at least
            # one label read where more than one entry weighs
            mm = len(names)
            for tag, fl in (
                ("low band beside the map", 2 + kh + 2 * kb + (kb > 1)),
                ("low band from the map's mips", 2 + kh + 2 * (kh + kb) + (kb > 1)),
            ):
                print(f"  floor ({tag}): mean {fl.mean():.2f}, share <= M + 1 {(fl <= mm + 1).mean():.3f}, "
                      f"share <= 2M + 1 {(fl <= 2 * mm + 1).mean():.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
