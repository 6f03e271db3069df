"""Export version 2 (provenance: the exemplar maps with full mips, one-bit labels, coverage, a source table) in a
real browser (headless Chromium, WebGL2 on SwiftShader) against the CPU.

Level 0 must be bit-equal to :func:`tilesynth.synthesize` (colour) and to the provenance gather (every other map
with its seams cut, normals turned with their patches); the smooth maps' seam blend (the default for height,
roughness and normal maps) within 2 codes of :func:`tilesynth.synthesize_maps`; every mip level within the stated
tolerance of a box filter of the exact synthesis; far zoom-out keeps the reference's contrast; fetch counts are
counted in the shader.
Skipped, with the reason, only when no Chromium can be found (``tests/webgl.py``).
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import pytest
from webgl import browser_or_skip, run_page

import tilesynth as ts
from tilesynth.engine import export
from tilesynth.engine import viewer as xv
from tilesynth.engine import viewer_v2 as v2


@pytest.fixture(scope="module")
def browser() -> str:
    return browser_or_skip()


def _derived_maps(ex: np.ndarray) -> dict[str, np.ndarray]:
    """Height (16-bit), unit normals (+y up, 8-bit) and roughness (8-bit) derived from an exemplar's luma."""
    luma = ex[..., :3] @ np.array([0.2126, 0.7152, 0.0722], np.float32)
    gy, gx = np.gradient(luma * 6.0)
    n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return {
        "height": np.round(luma * 65535).astype(np.uint16),
        "normal": np.round((n * 0.5 + 0.5) * 255).astype(np.uint8),
        "roughness": np.round((1 - luma) * 255).astype(np.uint8),
    }


@pytest.fixture(scope="module")
def aug_set(small_exemplar: np.ndarray):
    """A 16a set whose matching patches are rotated and mirrored (every symmetry D_s in use)."""
    return ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=1, augment="all")


@pytest.fixture(scope="module")
def c5_set(lettuce: np.ndarray):
    """The default complete set (625 tiles, hash lookup) on a 128 px crop."""
    return ts.build_omega(np.ascontiguousarray(lettuce[:128, :128]), tileset="c5", tile_size=32, seed=1)


@pytest.fixture(scope="module")
def big_set(lettuce: np.ndarray):
    """Tiles of 64 on a 256 px crop: room for levels 1-6 (the 64x zoom-out test)."""
    return ts.build_omega(np.ascontiguousarray(lettuce[:256, :256]), tileset="c5", tile_size=64, seed=3)


CUT = {"height": 0, "normal": 0, "roughness": 0}
"""The smooth maps of ``_derived_maps`` with their seams cut (``blend_levels``): the copies, bit for bit."""


def _exported(tileset, out: Path, maps=None, **kw):
    m = export(tileset, out, maps=maps, **kw)
    assert m["format_version"] == 2
    imap = xv.read_index(out, m)
    r = v2.ReferenceV2(tileset, m, imap, v2.arrays_of(tileset, m, out))
    return m, imap, r


def _run(browser: str, tmp: Path, tileset, m, imap, out: Path, cases) -> dict:
    cfg = v2.config_for(tileset, m, out, imap, cases)
    cfg["autorun"] = True
    page = tmp / "page.html"
    page.write_text(v2.page(cfg), encoding="utf-8")
    rep = run_page(browser, page)
    assert rep.get("error") is None, rep
    return rep


def _on(c: dict, map_index: int) -> dict:
    c["map"] = map_index
    return c


def _level0_cases(r: v2.ReferenceV2, names: list[str], n: int) -> list[dict]:
    cases = []
    windows = [
        ("negative origin, 4 tiles", -n - 5, -n - 11, 40, 36),
        ("straddling borders", 2 * n - 13, 3 * n - 20, 45, 33),
        ("far negative", -100003, -77777, 37, 29),
        ("far positive", 2**20 + 7, 2**19 - 5, 31, 27),
    ]
    for i, name in enumerate(names):
        for label, x0, y0, w, h in windows:
            ref = r.texels(name, x0, y0, w, h)
            cases.append(_on(xv.case(f"{name} fetch {label}", "fetch", (x0, y0), w, h, 1.0, 0, ref), i))
        for x0, y0 in ((-n - 6, -2 * n + 3), (3 * n - 17, n - 9)):
            exact = np.rint(r.sampled(name, x0, y0, 40, 40, 1.0)).astype(np.uint8)
            cases.append(
                _on(xv.case(f"{name} centres {x0},{y0}", "grad", (x0, y0), 40, 40, 1.0, 0, exact), i)
            )
    return cases


@pytest.mark.parametrize("which", ["aug-index", "c5-hash"])
def test_level0_is_bit_equal_to_the_cpu_for_every_map(browser, tmp_path, which, aug_set, c5_set):
    """texelFetch and textureGrad at texel centres: the albedo equals synthesize, the other maps the provenance
    gather (the normals turned with their rotated / mirrored patches), bit for bit."""
    tileset = aug_set if which == "aug-index" else c5_set
    maps = _derived_maps(tileset.exemplar)
    kw = {"index_size": (8, 8)} if which == "aug-index" else {"seed": 0xDEADBEEF}
    m, imap, r = _exported(tileset, tmp_path / "x", maps=maps, blend_levels=CUT, **kw)
    assert m["lookup"]["mode"] == ("index_map" if which == "aug-index" else "hash")
    names = [mp["name"] for mp in m["maps"]]
    assert names == ["albedo", "height", "normal", "roughness"]
    assert {mp["name"]: mp["normal"] for mp in m["maps"]} == {
        "albedo": 0,
        "height": 0,
        "normal": 1,
        "roughness": 0,
    }
    rep = _run(
        browser, tmp_path, tileset, m, imap, tmp_path / "x", _level0_cases(r, names, tileset.tile_size)
    )
    assert rep["status"] == "PASS" and rep["dom_status"] == "PASS 0", rep
    assert all(c["differing"] == 0 and c["max_diff"] == 0 for c in rep["cases"]), rep["cases"]
    assert sum(c["pixels"] for c in rep["cases"]) > 20000
    if which == "aug-index":  # the symmetries are really exercised
        assert len(np.unique(tileset._provenance().table[..., 0])) >= 6


def _luma(img: np.ndarray) -> np.ndarray:
    return img[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722])


def test_every_mip_level_within_tolerance_and_contrast_far_out(browser, tmp_path, big_set):
    """Levels 1..8 against the box filter of the exact synthesis: RMS within max(MIP_RMS, PHASE_FACTOR x the window's
    phase floor); at 64x zoom-out the contrast (standard deviation of the luma) within 10 % of the reference's."""
    tileset = big_set
    n = tileset.tile_size
    m, imap, r = _exported(tileset, tmp_path / "x", seed=7)
    cases, refs, floors = [], {}, {}
    for lv in range(1, 9):
        f = 2**lv
        w = h = 32 if lv < 6 else 48
        ox, oy = -3 * n - 0.37 * f, -5 * n + 0.21 * f
        ref = np.clip(np.rint(r.sampled("albedo", ox, oy, w, h, f, lv)), 0, 255).astype(np.uint8)
        refs[lv] = ref
        floors[lv] = r.phase_floor
        cases.append(xv.case(f"L{lv}", "grad", (ox, oy), w, h, f, 255, ref, dump=True))
    rep = _run(browser, tmp_path, tileset, m, imap, tmp_path / "x", cases)
    got = {c["name"]: c for c in rep["cases"]}
    lines = []
    for lv in range(1, 9):
        c = got[f"L{lv}"]
        img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(refs[lv].shape)
        contrast = _luma(img).std() / max(_luma(refs[lv]).std(), 1e-9)
        lines.append((lv, round(c["rms"], 2), round(floors[lv], 2), c["max_diff"], round(contrast, 3)))
    print("level, RMS (of 255), phase floor, max diff, contrast GPU / reference:", lines)
    for lv, rms, floor, _, contrast in lines:
        assert rms <= max(v2.MIP_RMS, v2.PHASE_FACTOR * floor), lines
        if lv == 6:
            assert abs(contrast - 1) <= 0.10, lines


def test_fetch_counts(browser, tmp_path, c5_set):
    """Counted in the shader with four maps. Every blend level 0: at most M + 2 texture fetches where no
    footprint straddles a cut (table, label, one per map), at most 2M + 2 where one does; outside the quadrant's
    label band (the radii in the table) the label is not looked up: M + 1 there, the share of such pixels
    reported. Blend levels 0 and 2 (height, normal): at most 1 + 3 + M and 1 + 3 + 2M (the level-2 seam
    treatment near a cut reads the bit and the coverage)."""
    tileset = c5_set
    maps = _derived_maps(tileset.exemplar)
    n = tileset.tile_size
    dummy = np.zeros((48, 48, 4), np.uint8)
    cases = [
        xv.case(f"count at {s}x", "count", (-n - 0.3, -2 * n + 0.7), 48, 48, s, 255, dummy, dump=True)
        for s in (1.0, 2.0, 8.0)
    ]
    mm = len(maps) + 1
    for blend, extra in ((CUT, 0), ({**CUT, "height": 2, "normal": 2}, 2)):
        out = tmp_path / f"x{extra}"
        m, imap, r = _exported(tileset, out, maps=maps, blend_levels=blend)
        rep = _run(browser, tmp_path, tileset, m, imap, out, cases)
        rows = []
        for c in rep["cases"]:
            img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(48, 48, 4)
            count, straddles = img[..., 0].astype(int), img[..., 1] > 127
            away = int(count[~straddles].max()) if (~straddles).any() else 0
            at = int(count[straddles].max()) if straddles.any() else 0
            rows.append(
                (c["name"], away, at, round(float(straddles.mean()), 3), round(float((count <= mm + 1).mean()), 3),
                 round(float(count.mean()), 2))
            )  # fmt: skip
        print(
            f"M = {mm}, blend levels {blend}: (case, max fetches away from cuts, max where a footprint "
            "straddles one, share straddling, share at <= M + 1, mean)",
            rows,
        )
        for _, away, at, _, _, _ in rows:
            assert away <= mm + 2 + extra and at <= 2 * mm + 2 + extra, rows
        assert any(row[3] > 0 for row in rows)  # the straddling path is exercised
        if (
            not extra
        ):  # the label band spares the label fetch (at 2x and beyond its reach covers a 32 px tile)
            assert rows[0][4] > 0.3, rows


# ------------------------------------------------------------------------------- the other shading languages
DATA = Path(__file__).parent / "data"


@pytest.mark.parametrize("target", ["glsl-es300", "glsl-400", "hlsl", "godot-as-glsl"])
def test_v2_shaders_compile_with_glslang(tmp_path, target):
    """The version-2 GLSL (ES 3.00 and desktop 4.00, with and without the fetch counter) and HLSL (to SPIR-V),
    the seam blend included, compile with Khronos' glslang; the Godot shader too, once its Godot-only syntax (shader_type, uniform hints
    and defaults, the fragment() built-ins) is rewritten as GLSL ES 3.00 (no Godot compiler here)."""
    import re
    import shutil
    import subprocess

    from tilesynth.engine import shader_source

    exe = shutil.which("glslangValidator")
    if exe is None:
        pytest.skip("glslangValidator not found (apt-get install glslang-tools)")
    es = "#version 300 es\nprecision highp float;\nprecision highp int;\n"
    use = (
        "void main() { TsSite s = ts_site(uv, dFdx(uv), dFdy(uv));"
        " o = ts_map(m0, s, ts_weight(s, 0.0), 1) + ts_fetch_map(m0, ivec2(uv), 2)"
        " + ts_sample_map(m0, uv, 3.0, 0); vec4 bd = vec4(3.0, 5.0, 4.0, 16.0); TsBlend b = ts_blend(s, bd);"
        " o += ts_smooth_map(m0, s, b, bd, vec4(0.5), 0, 0.0) + ts_smooth_map(m0, s, b, vec4(3.0, -1.0, 0.0, 1.0),"
        " vec4(0.0), 1, 0.0) + ts_smooth_map(m0, s, b, bd, vec4(0.5), -1, 0.0); }\n"
    )
    if target == "hlsl":
        src = shader_source("tilesynth_v2.hlsl") + (
            "Texture2D<float4> m0 : register(t4);\n"
            "float4 main(float2 uv : TEXCOORD0) : SV_Target { TsSite s = ts_site(uv, ddx(uv), ddy(uv));"
            " return ts_map(m0, s, ts_weight(s, 0.0), 1) + ts_fetch_map(m0, int2(uv), 3)"
            " + ts_sample_map(m0, uv, 2.0, 0) + ts_smooth_map(m0, s, ts_blend(s, float4(3, 5, 4, 16)),"
            " float4(3, 5, 4, 16), float4(0.5, 0.5, 0.5, 1), 0, 0.0) + ts_smooth_map(m0, s, ts_blend(s,"
            " float4(3, 5, 4, 16)), float4(3, 5, 4, 16), float4(0.5, 0.5, 0.5, 1), -1, 0.0); }\n"
        )
        f = tmp_path / "t.hlsl"
        cmd = [exe, "-D", "-V", "-e", "main", "-S", "frag", "-o", str(tmp_path / "t.spv"), str(f)]
    elif target == "godot-as-glsl":
        s = shader_source("tilesynth_v2.gdshader").replace("shader_type spatial;", "")
        s = re.sub(r"uniform (\w+) (\w+)\s*:[^;=]*", r"uniform \1 \2", s)
        s = re.sub(r"(uniform [^;]*?)\s*=\s*[^;]*;", r"\1;", s)
        s = s.replace(
            "void fragment() {",
            "out vec4 o; void main() { vec3 ALBEDO, NORMAL_MAP; float ROUGHNESS; vec2 UV = gl_FragCoord.xy;",
        )
        src = es + s.rstrip()[:-1] + " o = vec4(ALBEDO + NORMAL_MAP, ROUGHNESS); }\n"
        f = tmp_path / "g.frag"
        cmd = [exe, str(f)]
    else:
        head = es + "#define TS_COUNT_FETCHES\n" if target == "glsl-es300" else "#version 400\n"
        src = (
            head
            + shader_source("tilesynth_v2.glsl")
            + "in vec2 uv; out vec4 o; uniform sampler2D m0;\n"
            + use
        )
        f = tmp_path / "t.frag"
        cmd = [exe, str(f)]
    f.write_text(src)
    out = subprocess.run(cmd, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_v2_wgsl_validates_with_naga(tmp_path):
    """The version-2 WGSL with a fragment entry point using every function validates with naga (wgpu's
    compiler)."""
    import shutil
    import subprocess

    from tilesynth.engine import shader_source

    exe = shutil.which("naga")
    if exe is None:
        pytest.skip("naga not found (cargo install naga-cli)")
    f = tmp_path / "t.wgsl"
    f.write_text(
        shader_source("tilesynth_v2.wgsl") + "@group(1) @binding(0) var m0: texture_2d<f32>;\n"
        "@fragment fn main(@location(0) uv: vec2<f32>) -> @location(0) vec4<f32> {\n"
        "  let s = ts_site(uv, dpdx(uv), dpdy(uv));\n"
        "  return ts_map(m0, s, ts_weight(s, 0.0), 1) + ts_fetch_map(m0, vec2<i32>(uv), 1)"
        " + ts_sample_map(m0, uv, 2.0, 0)\n"
        "    + ts_smooth_map(m0, s, ts_blend(s, vec4<f32>(3.0, 5.0, 4.0, 16.0)), vec4<f32>(3.0, 5.0, 4.0, 16.0),"
        " vec4<f32>(0.5), 0, 0.0)\n"
        "    + ts_smooth_map(m0, s, ts_blend(s, vec4<f32>(3.0, 5.0, 4.0, 16.0)), vec4<f32>(3.0, 5.0, 4.0, 16.0),"
        " vec4<f32>(0.5), -1, 0.0);\n}\n"
    )
    out = subprocess.run([exe, str(f)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_v2_wgsl_hash_and_tile_index_match_the_vectors_in_webgpu(browser, tmp_path):
    """The version-2 WGSL's hash and tile index through Chromium's WebGPU (the version-1 harness: the index
    texture and the parameters sit at the same bindings and offsets)."""
    import json

    from webgl import run_webgpu_page, wgsl_page

    from tilesynth.engine import shader_source

    vectors = json.loads((DATA / "hash_vectors.json").read_text())
    page = tmp_path / "wgsl.html"
    page.write_text(wgsl_page(vectors, shader_source("tilesynth_v2.wgsl")), encoding="utf-8")
    rep = run_webgpu_page(browser, page)
    if "adapter" in str(rep.get("error", "")).lower() or "navigator.gpu" in str(rep.get("error", "")):
        pytest.skip(f"no WebGPU adapter in this browser: {rep['error']}")
    assert rep.get("error") is None, rep
    assert rep["checked"] == 1180 and rep["status"] == "PASS", rep["fails"]


def test_viewer_selftest_passes_and_the_file_is_a_few_times_the_maps(browser, tmp_path, c5_set):
    """The exported viewer (every map, lit preview) passes its own self-test (level 0 exact, levels 1-5 within
    the tolerance) and is about 3x the bytes of the maps' exported PNG levels, whatever the tile count."""
    maps = _derived_maps(c5_set.exemplar)
    out = tmp_path / "x"
    m = export(c5_set, out, maps=maps, viewer=True, blend_levels={"height": 2, "normal": 2})
    assert {mp["name"]: mp["seam"] for mp in m["maps"]} == {
        "albedo": "cut",
        "height": "coverage",
        "normal": "coverage",
        "roughness": "blend",
    }
    rep = run_page(browser, out / "viewer.html", "?selftest")
    assert rep.get("error") is None and rep["status"] == "PASS" and rep["dom_status"] == "PASS 0", rep
    names = [c["name"] for c in rep["cases"]]
    assert any("level 5" in n for n in names) and any("fetch" in n for n in names)  # 128 px: levels 1-6
    html = (out / "viewer.html").read_text()
    assert all(f'"name": "{mp["name"]}"' in html for mp in m["maps"]) and "lit preview" in html
    map_bytes = sum((out / lv["file"]).stat().st_size for mp in m["maps"] for lv in mp["levels"])
    size = (out / "viewer.html").stat().st_size
    print(f"viewer {size} B, maps' PNG levels {map_bytes} B: {size / map_bytes:.2f}x")
    # 3x was this fixture's own figure when the bound was set (2.99x: 625 tiles of labels on a 128-px
    # exemplar); issue 29's 1-px border ring let the matching patches reach one pixel closer to the borders,
    # and the label bits grew 4 % (3.002x). The bound is there to catch a viewer that embeds more than the
    # maps, the labels and the table (the atlas viewer was 49x the maps), with 3 % room for cut changes.
    assert size <= 3.1 * map_bytes


def _wgsl_data(tileset, m: dict, out: Path, imap, names: tuple[str, ...]) -> dict:
    """The textures and parameters of a version-2 export for the WebGPU harness (``webgl.wgsl_v2_page``): the
    maps ``names`` as their 8-bit previews, the labels, the table, the index, the blend coverage."""
    from tilesynth.engine.reference import to_rgba8
    from tilesynth.io.images import load_raster

    cfg = v2.config_for(tileset, m, out, imap, [])
    lab = m["labels"]

    def enc(a: np.ndarray) -> str:
        return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode()

    def level(a: np.ndarray) -> dict:
        return {"w": int(a.shape[1]), "h": int(a.shape[0]), "data": enc(a)}

    def load(f: str) -> np.ndarray:
        a = np.asarray(load_raster(out / f))
        return a[:, :, None] if a.ndim == 2 else a

    data_maps = []
    for name in names:
        mp = next(x for x in m["maps"] if x["name"] == name)
        levels = [to_rgba8(v2.to_preview8(load(lv["file"]))) for lv in mp["levels"]]
        normal = mp["normal"]
        if "low_band" in mp:  # (value, low band) in R, G: one fetch for both (the shaders' normal = -1)
            for a, lv in zip(levels, mp["low_band"]["levels"]):
                a[..., 1] = v2.to_preview8(load(lv["file"]))[..., 0]
                a[..., 2] = 0
            normal = -1
        data_maps.append({"normal": normal, "levels": [level(a) for a in levels]})
    params = np.zeros(12, np.int32)
    params[:4] = cfg["layout"]
    params[4:8] = cfg["lookup"]
    params[8:10] = cfg["wrap"]
    params[10] = cfg["seed"]
    data = {
        "bits": level(load(lab["bits"]["file"])[:, :, 0]),
        "coverage": [level(load(lv["file"])[:, :, 0]) for lv in lab["coverage"]["levels"]],
        "table": level(
            np.fromfile(out / lab["table"]["file"], "<i4").reshape(lab["table"]["height"], 256, 4)
        ),
        "index": level(imap.astype("<u2") if imap is not None else np.zeros((1, 1), "<u2")),
        "params": enc(params),
        "maps": data_maps,
        "cases": [],
    }
    if "blend" in lab:
        from tilesynth.engine.provenance_export import blend_shares

        r = lab["blend"]
        span = tuple(r["reach_levels"]) if r["reach_levels"] else None
        shares = blend_shares(load(r["file"])[:, :, 0], m["tile_size"], r["high_level"], span)
        data["blend"] = level(shares.astype("<f2"))
        data["blend_layout"] = [r["columns"], r["high_level"], *(span or (-1, -1))]
    return data


def _enc(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a).tobytes()).decode()


def test_v2_wgsl_level0_is_bit_equal_in_webgpu(browser, tmp_path, aug_set):
    """The version-2 WGSL map lookup (textureLoad and textureSampleGrad at texel centres, a compute pass in
    Chromium's WebGPU) equals the CPU for the albedo and the normals of a set with every symmetry."""

    from webgl import run_webgpu_page, wgsl_v2_page

    from tilesynth.engine import shader_source

    maps = _derived_maps(aug_set.exemplar)
    out = tmp_path / "x"
    m, imap, r = _exported(aug_set, out, maps=maps, index_size=(8, 8), blend_levels=CUT)
    data = _wgsl_data(aug_set, m, out, imap, ("albedo", "normal"))
    n = aug_set.tile_size
    for i, name in enumerate(("albedo", "normal")):
        for x0, y0 in ((-n - 5, -n - 11), (2 * n - 13, 3 * n - 20), (-100003, -77777)):
            data["cases"].append(
                {"name": f"{name} fetch {x0},{y0}", "kind": "fetch", "map": i, "origin": [x0, y0], "w": 40,
                 "h": 36, "scale": 1.0, "tol": 0, "ref": _enc(r.texels(name, x0, y0, 40, 36))}
            )  # fmt: skip
            exact = np.rint(r.sampled(name, x0, y0, 40, 36, 1.0)).astype(np.uint8)
            data["cases"].append(
                {"name": f"{name} centres {x0},{y0}", "kind": "grad", "map": i, "origin": [x0, y0], "w": 40,
                 "h": 36, "scale": 1.0, "tol": 0, "ref": _enc(exact)}
            )  # fmt: skip
    page = tmp_path / "wgsl2.html"
    page.write_text(wgsl_v2_page(data, shader_source("tilesynth_v2.wgsl")), encoding="utf-8")
    rep = run_webgpu_page(browser, page)
    print(rep["cases"])
    if "adapter" in str(rep.get("error", "")).lower() or "navigator.gpu" in str(rep.get("error", "")):
        pytest.skip(f"no WebGPU adapter in this browser: {rep['error']}")
    assert rep.get("error") is None, rep
    assert rep["status"] == "PASS" and len(rep["cases"]) == 12, rep["cases"]
    assert all(c["differing"] == 0 and c["max_diff"] == 0 for c in rep["cases"]), rep["cases"]


# ------------------------------------------------------------------------------ the seam blend of smooth maps
@pytest.fixture(scope="module", params=[32, 64], ids=["tiles-32", "tiles-64"])
def material(request):
    """A small pure-copy material set (ambientCG Rock053, CC0, 128 px: albedo, normal; a height from its luma in
    16 bits, a roughness in 8): tiles of 32 (the detail band alone) and 64 (with the low band)."""
    from tilesynth.io.images import load_raster

    albedo = np.asarray(load_raster(DATA / "rock053-albedo-128.png"))
    normal = np.asarray(load_raster(DATA / "rock053-normal-128.png"))
    luma = albedo[..., :3].astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]) / 255.0
    maps = {
        "normal": normal,
        "height": np.round(luma * 65535).astype(np.uint16),
        "roughness": np.round((1.0 - luma) * 255).astype(np.uint8),
    }
    return ts.build(albedo, tileset="c2", tile_size=request.param, seed=1, maps=maps)


def _synth_window(tileset, index_of, name: str, x0: int, y0: int, w: int, h: int) -> np.ndarray:
    """``(h, w, C)`` of map ``name`` by :func:`tilesynth.synthesize_maps` (the seam blend) at texture pixel
    (x0, y0)."""
    n = tileset.tile_size
    cx0, cy0 = x0 // n, y0 // n
    cy, cx = np.mgrid[cy0 : (y0 + h - 1) // n + 1, cx0 : (x0 + w - 1) // n + 1]
    sub = np.ascontiguousarray(index_of(cx, cy), np.int32)
    return ts.synthesize_maps(tileset, sub, w, h, offset=(y0 - cy0 * n, x0 - cx0 * n))[name]


BLEND_MAX = 2
"""Largest difference (codes of 255) of a blended map at 1:1 against ``synthesize_maps``: float32 against
float64, the viewer's 8-bit previews of 16-bit maps, the low band beside the map rounded to its sample type
against the CPU's exact one. Measured: at most 1 (tiles of 32 and 64; 124 x 116 with tiles of 64)."""
BLEND_OFF_BY_2 = 0.01
"""Largest share of pixels more than 1 code off (measured: none)."""


def test_smooth_maps_blend_their_seams_as_synthesize_maps(browser, tmp_path, material):
    """Height (16-bit), roughness (8-bit) and normal maps at 1:1 (texel centres): the seam blend in the shader
    against :func:`tilesynth.synthesize_maps` of the same windows, within :data:`BLEND_MAX` codes and at most
    :data:`BLEND_OFF_BY_2` of the pixels more than 1 off; the same windows with the seams cut (the copies) are
    far off, so the windows do test the blend."""
    from tilesynth.engine import reference as ref
    from tilesynth.synth.seams import BANDS

    tileset = material
    n = tileset.tile_size
    m, imap, r = _exported(tileset, tmp_path / "x", seed=11)
    seam = {mp["name"]: (mp["seam"], mp.get("bands")) for mp in m["maps"]}
    assert seam["albedo"] == ("cut", None)
    assert seam["normal"] == ("blend", {"high": BANDS["normal"]["high"]})
    assert seam["height"][0] == "blend" and ("low" in seam["height"][1]) == (n >= 64)
    assert (m["labels"]["blend"]["reach_levels"] is not None) == (n >= 64)
    index_of = ref.index_function(m["lookup"], imap)
    names = [mp["name"] for mp in m["maps"]]
    cases, refs, copies = [], {}, {}
    for name in ("height", "roughness", "normal"):
        for x0, y0 in ((-n - 5, -n - 11), (3 * n - 17, n - 9)):
            w, h = 2 * n + 10, 2 * n + 6
            exact = ref.to_rgba8(v2.to_preview8(_synth_window(tileset, index_of, name, x0, y0, w, h)))
            c = _on(xv.case(f"{name} at {x0},{y0}", "grad", (x0, y0), w, h, 1.0, BLEND_MAX, exact, dump=True),
                    names.index(name))  # fmt: skip
            cases.append(c)
            refs[c["name"]] = exact
            copies[c["name"]] = r.texels(name, x0, y0, w, h)
    rep = _run(browser, tmp_path, tileset, m, imap, tmp_path / "x", cases)
    rows = []
    for c in rep["cases"]:
        exact = refs[c["name"]]
        img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(exact.shape)
        d = np.abs(img.astype(int) - exact.astype(int))[..., :3].max(axis=2)
        cut = np.abs(copies[c["name"]].astype(int) - exact.astype(int))[..., :3].max(axis=2)
        rows.append((c["name"], int(d.max()), round(float((d > 1).mean()), 4), round(float((d > 0).mean()), 3),
                     int(cut.max()), round(float((cut > BLEND_MAX).mean()), 3)))  # fmt: skip
    print(f"tiles of {n}: (case, max |GPU - synthesize_maps|, share > 1, share > 0, the copies' max, their share "
          f"> {BLEND_MAX})", rows)  # fmt: skip
    for _, mx, over1, _, cut_max, cut_over in rows:
        assert mx <= BLEND_MAX and over1 <= BLEND_OFF_BY_2, rows
        assert cut_max > 4 * BLEND_MAX and cut_over > 0.02, rows  # a hard cut would fail
    assert rep["status"] == "PASS", rep


def test_smooth_map_fetch_counts(browser, tmp_path, material):
    """Texture fetches of a pixel with the albedo cut and the height, roughness and normal maps blended (M = 4,
    counted in the shader, the blend's weights shared by the three): M + 1 where every smooth map's weights are
    one entry's and no tap of the weights' bilinear samples needs a label read (the quadrant's radii decide it),
    more where one does; near cuts the label reads and 1-2 fetches per map and entry. Reported: the share of
    single-entry pixels, their fetches and the others' (the budget of M + 1 away from cuts is not met: the
    taps of the low band reach 1.5 blocks of 2^low px, and the radii rarely rule a block out)."""
    from tilesynth.engine import reference as ref
    from tilesynth.synth.seams import blend_weights, check_bands, tile_bands

    tileset = material
    n = tileset.tile_size
    m, imap, _ = _exported(tileset, tmp_path / "x", seed=11)
    mm = len(m["maps"])
    x0, y0, w = -n - 3, -2 * n + 5, 2 * n + 16
    dummy = np.zeros((w, w, 4), np.uint8)
    cases = [xv.case("count at 1x", "count", (x0, y0), w, w, 1.0, 255, dummy, dump=True)]
    rep = _run(browser, tmp_path, tileset, m, imap, tmp_path / "x", cases)
    img = np.frombuffer(base64.b64decode(rep["cases"][0]["image"]), np.uint8).reshape(w, w, 4)
    count = img[..., 0].astype(int)
    # where the CPU's weights are one entry's in every band (the formula's own "single" pixels)
    prov = tileset._provenance()
    bands = tile_bands(check_bands(None, "scalar"), n)
    e = prov.table.shape[1]
    single_t = blend_weights(prov.labels, e, bands["high"]).max(axis=1) >= 1.0
    if "low" in bands:
        single_t &= blend_weights(prov.labels, e, bands["low"], int(bands["reach"])).max(axis=1) >= 1.0
    index_of = ref.index_function(m["lookup"], imap)
    yy, xx = np.mgrid[y0 : y0 + w, x0 : x0 + w]
    tiles = index_of(np.floor_divide(xx, n), np.floor_divide(yy, n))
    single = single_t[tiles, yy % n, xx % n]
    away, near = count[single], count[~single]
    print(
        f"tiles of {n}, M = {mm}: single-entry pixels {single.mean():.3f} (fetches max {away.max()}, mean "
        f"{away.mean():.2f}); near cuts (fetches max {near.max()}, mean {near.mean():.2f}, median "
        f"{np.median(near):.0f}); all pixels mean {count.mean():.2f}, at <= M + 1: {(count <= mm + 1).mean():.3f}"
    )
    assert 0.05 < single.mean() < 0.95  # both kinds of pixel are in the window
    assert away.min() >= mm + 1  # never fewer than the table texel and one fetch per map
    if n == 32:  # where no tap reaches a cut or quadrant line: table + one per map (the label reads skipped)
        assert away.min() == mm + 1
    # with 64-px tiles the low band's taps reach 48 px, so pixels that need no label read at all are rare: 0.5 %
    # of this window with the 2-px border ring, none with the 1-px ring of issue 29 (mean fetches 12.39 -> 12.54)
    assert (
        near.min() > mm + 1 and near.max() < 255
    )  # near cuts the labels are read; the counter did not saturate


def test_v2_wgsl_blends_smooth_maps_as_synthesize_maps_in_webgpu(browser, tmp_path, material):
    """The WGSL seam blend (``ts_blend``, ``ts_smooth_map``; a compute pass in Chromium's WebGPU) of the height,
    roughness and normal maps at 1:1 against :func:`tilesynth.synthesize_maps`: within :data:`BLEND_MAX` codes, at
    most :data:`BLEND_OFF_BY_2` of the pixels more than 1 off."""
    from webgl import run_webgpu_page, wgsl_v2_page

    from tilesynth.engine import reference as ref
    from tilesynth.engine import shader_source

    tileset = material
    n = tileset.tile_size
    out = tmp_path / "x"
    m, imap, _ = _exported(tileset, out, seed=11)
    names = ("height", "roughness", "normal")
    data = _wgsl_data(tileset, m, out, imap, names)
    index_of = ref.index_function(m["lookup"], imap)
    refs = {}
    for i, name in enumerate(names):
        mp = next(x for x in m["maps"] if x["name"] == name)
        bd = mp["bands"]
        mu = mp.get("mean", [0.0])
        bands = [bd["high"], bd.get("low", -1.0), bd.get("split", 0.0), bd.get("reach", 1.0)]
        mean = [mu[0], mu[0], mu[0], 1.0] if mp["channels"] == 1 else [*mu[:3], 1.0]
        x0, y0, w, h = -n - 5, -n - 11, 2 * n + 10, 2 * n + 6
        exact = ref.to_rgba8(v2.to_preview8(_synth_window(tileset, index_of, name, x0, y0, w, h)))
        c = {"name": name, "kind": "blend", "map": i, "origin": [x0, y0], "w": w, "h": h, "scale": 1.0,
             "tol": BLEND_MAX, "ref": _enc(exact), "bands": bands, "mean": mean, "dump": True}  # fmt: skip
        data["cases"].append(c)
        refs[name] = exact
    page = tmp_path / "wgsl3.html"
    page.write_text(wgsl_v2_page(data, shader_source("tilesynth_v2.wgsl")), encoding="utf-8")
    rep = run_webgpu_page(browser, page)
    if "adapter" in str(rep.get("error", "")).lower() or "navigator.gpu" in str(rep.get("error", "")):
        pytest.skip(f"no WebGPU adapter in this browser: {rep['error']}")
    assert rep.get("error") is None, rep
    rows = []
    for c in rep["cases"]:
        exact = refs[c["name"]]
        img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(exact.shape)
        d = np.abs(img.astype(int) - exact.astype(int))[..., :3].max(axis=2)
        rows.append((c["name"], int(d.max()), round(float((d > 1).mean()), 4)))
    print(f"WGSL, tiles of {n}: (map, max |GPU - synthesize_maps|, share > 1)", rows)
    assert all(mx <= BLEND_MAX and over <= BLEND_OFF_BY_2 for _, mx, over in rows), rows
    assert rep["status"] == "PASS", rep["cases"]


def test_viewer_selftest_checks_the_seam_blend(browser, tmp_path, material):
    """The exported viewer of a material set checks its blended maps too: each stored smooth map at 1:1 within
    ``viewer_v2.BLEND_TOLERANCE`` of :func:`tilesynth.synthesize_maps`, and passes."""
    out = tmp_path / "x"
    export(material, out, viewer=True)
    rep = run_page(browser, out / "viewer.html", "?selftest")
    assert rep.get("error") is None and rep["status"] == "PASS" and rep["dom_status"] == "PASS 0", rep
    blended = {c["name"]: c for c in rep["cases"] if "seam blend" in c["name"]}
    assert set(blended) == {f"{k}: the seam blend at 1:1" for k in ("height", "normal", "roughness")}, rep[
        "cases"
    ]
    assert all(c["max_diff"] <= v2.BLEND_TOLERANCE for c in blended.values()), blended


def test_low_band_on_sides_not_multiples_of_2_split(browser, tmp_path):
    """On an exemplar whose sides are not multiples of 2^split (124 x 116, tiles of 64, split 3) the shader's low
    band is the CPU's (the texture beside the map holds the box mip's bilinear sample by the CPU's rule; the
    map's own mip chain, which drops an odd row, put it up to 3 codes off): height and roughness at 1:1 within
    :data:`BLEND_MAX` codes of :func:`tilesynth.synthesize_maps`, at most :data:`BLEND_OFF_BY_2` more than 1 off."""
    from tilesynth.engine import reference as ref
    from tilesynth.io.images import load_raster

    albedo = np.asarray(load_raster(DATA / "rock053-albedo-128.png"))[:116, :124]
    luma = (albedo.astype(np.float64) @ np.array([0.2126, 0.7152, 0.0722]) / 255.0)[..., None]
    maps = {
        "height": np.rint(luma * 65535).astype(np.uint16),
        "roughness": np.rint((1 - luma) * 255).astype(np.uint8),
    }
    tileset = ts.build(albedo, tileset="c2", tile_size=64, seed=1, maps=maps)
    n = tileset.tile_size
    m, imap, _ = _exported(tileset, tmp_path / "x", seed=5)
    assert all("low_band" in mp for mp in m["maps"] if mp["name"] in maps)
    index_of = ref.index_function(m["lookup"], imap)
    names = [mp["name"] for mp in m["maps"]]
    cases, refs = [], {}
    for name in maps:
        x0, y0, w, h = -n - 5, -n - 11, 2 * n + 10, 2 * n + 6
        exact = ref.to_rgba8(v2.to_preview8(_synth_window(tileset, index_of, name, x0, y0, w, h)))
        c = _on(xv.case(name, "grad", (x0, y0), w, h, 1.0, BLEND_MAX, exact, dump=True), names.index(name))
        cases.append(c)
        refs[name] = exact
    rep = _run(browser, tmp_path, tileset, m, imap, tmp_path / "x", cases)
    rows = []
    for c in rep["cases"]:
        img = np.frombuffer(base64.b64decode(c["image"]), np.uint8).reshape(refs[c["name"]].shape)
        d = np.abs(img.astype(int) - refs[c["name"]].astype(int))[..., :3].max(axis=2)
        rows.append((c["name"], int(d.max()), round(float((d > 1).mean()), 4)))
    print("124 x 116, tiles of 64: (map, max |GPU - synthesize_maps|, share > 1)", rows)
    assert all(mx <= BLEND_MAX and over <= BLEND_OFF_BY_2 for _, mx, over in rows), rows
    assert rep["status"] == "PASS", rep["cases"]
