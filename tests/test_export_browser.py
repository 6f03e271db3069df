"""The exported GLSL in a real browser (headless Chromium, WebGL2 on SwiftShader) against the CPU.

Every expected image comes from :func:`tilesynth.synthesize` (``tilesynth.engine.reference``), never from the
atlas. Windows are small (SwiftShader is slow); each test renders all its windows in one page load.
Skipped, with the reason, only when no Chromium can be found (``tests/webgl.py``).
"""

from __future__ import annotations

import base64
from pathlib import Path

import numpy as np
import pytest
from webgl import browser_or_skip, run_page

import tilesynth as ts
from tilesynth.engine import atlas as xatlas
from tilesynth.engine import export
from tilesynth.engine import viewer as xv
from tilesynth.measure.metrics import seam_score


@pytest.fixture(scope="module")
def browser() -> str:
    return browser_or_skip()


@pytest.fixture(scope="module")
def omega_set(small_exemplar: np.ndarray):
    return ts.build_omega(small_exemplar, tileset="16a", tile_size=32, seed=1, select="random")


@pytest.fixture(scope="module")
def wang_set(small_exemplar: np.ndarray):
    return ts.build(small_exemplar, scheme="wang", tileset="wang8", tile_size=32, seed=1)


@pytest.fixture(scope="module")
def omega64(lettuce: np.ndarray):
    """Bigger tiles for the mip tests (levels 1-3 keep 32, 16, 8 texels a tile)."""
    # one random draw (border_tries=1, the default before issue 14): the no-gutter control needs tile borders of
    # ordinary contrast to show its seam; the border-aware default makes them quieter (control 1.17 < 1.25 at L2)
    return ts.build_omega(
        np.ascontiguousarray(lettuce[:192, :192]),
        tileset="16a",
        tile_size=64,
        seed=2,
        select="random",
        border_tries=1,
    )


def _exported(tileset, out: Path, **kw):
    m = export(tileset, out, format="atlas", **kw)
    imap = xv.read_index(out, m)
    levels = xv.albedo_levels(out, m)
    return m, imap, levels, xv.Reference(tileset, m, imap, levels)


def _run(browser: str, tmp: Path, tileset, m, imap, levels, cases, layout=None) -> dict:
    cfg = xv.config_for(tileset, m, levels, imap, cases)
    cfg["autorun"] = True
    if layout is not None:
        cfg["layout"] = layout
    page = tmp / "page.html"
    page.write_text(xv.page(cfg), encoding="utf-8")
    rep = run_page(browser, page)
    assert rep.get("error") is None, rep
    return rep


def _by_name(rep: dict) -> dict:
    return {c["name"]: c for c in rep["cases"]}


def _fetch_cases(r: xv.Reference, n: int) -> list[dict]:
    out = []
    windows = [
        ("negative origin, 4 tiles", -n - 5, -n - 11, 40, 36),
        ("straddling borders", 2 * n - 13, 3 * n - 20, 45, 33),
        ("across the index period (x = 8 tiles)", 8 * n - 20, -3, 40, 24),
        ("far negative", -100003, -77777, 37, 29),
        ("far positive", 2**20 + 7, 2**19 - 5, 31, 27),
    ]
    for name, x0, y0, w, h in windows:
        out.append(xv.case(name, "fetch", (x0, y0), w, h, 1.0, 0, r.fetch(x0, y0, w, h)))
    return out


@pytest.mark.parametrize("which", ["omega", "wang"])
def test_texelfetch_composition_equals_synthesize(browser, tmp_path, which, omega_set, wang_set):
    tileset = omega_set if which == "omega" else wang_set
    m, imap, levels, r = _exported(tileset, tmp_path / "x", index_size=(8, 8))
    assert m["lookup"]["mode"] == "index_map"
    rep = _run(browser, tmp_path, tileset, m, imap, levels, _fetch_cases(r, tileset.tile_size))
    assert rep["status"] == "PASS" and rep["dom_status"] == "PASS 0", rep
    assert all(c["differing"] == 0 and c["max_diff"] == 0 for c in rep["cases"])
    assert sum(c["pixels"] for c in rep["cases"]) > 5000


@pytest.mark.parametrize("which", ["omega", "wang"])
def test_bilinear_centres_exact_and_magnified_within_one(browser, tmp_path, which, omega_set, wang_set):
    tileset = omega_set if which == "omega" else wang_set
    n = tileset.tile_size
    m, imap, levels, r = _exported(tileset, tmp_path / "x", index_size=(8, 8))
    cases = []
    for x0, y0 in ((-n - 6, -2 * n + 3), (3 * n - 17, n - 9)):
        exact = np.rint(r.sampled(x0, y0, 40, 40, 1.0)).astype(np.uint8)
        cases.append(xv.case(f"centres {x0},{y0}", "grad", (x0, y0), 40, 40, 1.0, 0, exact))
    for x0, y0, s in ((-n / 2 - 2.3, 0.7 - n, 0.25), (n - 5.1, -n - 4.6, 0.3), (-7.05, -6.95, 0.5)):
        ref = r.sampled(x0, y0, 48, 48, s)
        ex = r.inexact_gutter(x0, y0, 48, 48, s, 0)
        cases.append(
            xv.case(
                f"magnified {s}", "grad", (x0, y0), 48, 48, s, 1, np.rint(ref).astype(np.uint8), exempt=ex
            )
        )
    rep = _run(browser, tmp_path, tileset, m, imap, levels, cases)
    cs = rep["cases"]
    assert all(c["differing"] == 0 for c in cs), cs
    assert all(c["max_diff"] == 0 for c in cs[:2]), cs
    if which == "omega":
        # the kept border ring makes the first gutter texel exact for every valid neighbour
        assert all(c["exempt"] == 0 for c in cs), cs


def _seam(img: np.ndarray, tile: int) -> float:
    return seam_score(img[..., :3].astype(np.float32) / 255.0, tile).score


def test_minified_mips_gradients_and_seams(browser, tmp_path, omega64):
    """At each level L: texel centres within 2/255 of the box-filtered texture; samples shifted a quarter texel
    (so every border pixel reads the gutter) within 2/255 wherever the gutter can be exact; the border seam score
    of the render no worse than the reference's; and a negative control without gutters that shows the seam."""
    tileset = omega64
    n = tileset.tile_size
    m, imap, levels, r = _exported(tileset, tmp_path / "x", index_size=(8, 8))
    assert m["atlas"]["max_level"] == 3
    cases, refs = [], {}
    for lv in (1, 2, 3):
        f = 2**lv
        w = h = 4 * n // f  # four tiles across
        c = np.clip(np.rint(r.sampled(-2 * n, -n, w, h, f, lv)), 0, 255).astype(np.uint8)
        cases.append(xv.case(f"centres L{lv}", "grad", (-2 * n, -n), w, h, f, 2, c))
        ox, oy = -2 * n + f / 4, -n + f / 4
        s = r.sampled(ox, oy, w, h, f, lv)
        ex = r.inexact_gutter(ox, oy, w, h, f, lv)
        refs[lv] = (np.clip(np.rint(s), 0, 255).astype(np.uint8), ex)
        cases.append(
            xv.case(f"shifted L{lv}", "grad", (ox, oy), w, h, f, 2, refs[lv][0], dump=True, exempt=ex)
        )
    rep = _run(browser, tmp_path, tileset, m, imap, levels, cases)
    got = _by_name(rep)
    # negative control: the same tiles packed without gutter (P = 0), the mips reduced over the whole atlas
    cols, rows = m["atlas"]["columns"], m["atlas"]["rows"]
    cells = xatlas.quantise(xatlas.padded_tiles(tileset.tiles, tileset.exemplar, tileset.source, 0), 8)
    naive = xatlas.mip_chain(xatlas.pack(cells, cols, rows), 3, srgb=True)
    m0 = dict(m, padding=0, atlas=dict(m["atlas"], width=naive[0].shape[1], height=naive[0].shape[0]))
    ctrl = _run(
        browser,
        tmp_path,
        tileset,
        m0,
        imap,
        naive,
        [c for c in cases if c["name"].startswith("shifted")],
        layout=[n, 0, cols, 3],
    )
    bad = _by_name(ctrl)
    lines = []
    for lv in (1, 2, 3):
        f = 2**lv
        cen, sh = got[f"centres L{lv}"], got[f"shifted L{lv}"]
        assert cen["differing"] == 0 and cen["exempt"] == 0, cen
        assert sh["differing"] == 0, sh
        ref_img, ex = refs[lv]
        img = np.frombuffer(base64.b64decode(sh["image"]), np.uint8).reshape(ref_img.shape)
        ctl = np.frombuffer(base64.b64decode(bad[f"shifted L{lv}"]["image"]), np.uint8).reshape(ref_img.shape)
        s_ref, s_gpu, s_ctl = _seam(ref_img, n // f), _seam(img, n // f), _seam(ctl, n // f)
        lines.append(
            (lv, s_ref, s_gpu, s_ctl, sh["exempt"], sh["exempt_max_diff"], bad[f"shifted L{lv}"]["max_diff"])
        )
        # "no worse than the interior": the render's border/interior ratio does not exceed 1 beyond what the
        # true (box-filtered) texture itself has there
        assert s_gpu <= max(1.0, s_ref) * 1.10, lines
        # the control fails where the gutters make the difference
        assert bad[f"shifted L{lv}"]["differing"] > 0 and s_ctl > max(1.0, s_ref) * 1.25, lines
    print("level, seam ref, seam gpu, seam no-gutter, exempt px, exempt max diff, control max diff")
    for row in lines:
        print(row)


# ------------------------------------------------------------------------------------------ hash mode
DATA = Path(__file__).parent / "data"


def test_shader_hash_matches_the_vectors_bit_for_bit(browser, tmp_path):
    import json

    from webgl import hash_page

    from tilesynth.engine import shader_source

    vectors = json.loads((DATA / "hash_vectors.json").read_text())
    page = tmp_path / "hash.html"
    page.write_text(hash_page(vectors, shader_source("tilesynth.glsl")), encoding="utf-8")
    rep = run_page(browser, page)
    assert rep.get("error") is None, rep
    assert rep["checked"] == len(vectors["ts_hash"]) + len(vectors["pcg3d"]) + len(vectors["cells"]) > 1000
    assert rep["status"] == "PASS" and rep["differing"] == 0, rep["fails"]


def complete_set(base, kind: str, variants: int = 1):
    """A tile set in the hash's index order built from the tiles of ``base`` (complete sets are not on this
    branch yet): K = 2 corner colours (16 tuples) or Kh = Kv = 2 edge colours, the tiles of ``base`` reused
    (variant 1 darkened, so variants differ). Only the lookup is under test, not seamlessness."""
    import dataclasses

    from tilesynth.layouts.omega_sets import CornerTileSet
    from tilesynth.layouts.wang_sets import WangTileSet

    k = base.n_tiles
    assert k == 16
    reps = variants
    arrays = {}
    for name in ("tiles", "source", "cut_masks", "tile_patches", "match_offsets", "D", "cut_costs"):
        a = getattr(base, name)
        if kind == "corner" and reps > 1:  # index = tuple * V + v: interleave the variants
            a = np.repeat(a, reps, axis=0)
        arrays[name] = np.ascontiguousarray(a)
    if kind == "corner" and reps > 1:
        arrays["tiles"] = arrays["tiles"].copy()
        arrays["tiles"][1::2] *= np.float32(0.6)
    if kind == "corner":
        cols = ("R", "G")
        tuples, var = [], []
        for t in range(16 * reps):
            rest, v = divmod(t, reps)
            rest, br = divmod(rest, 2)
            rest, tr = divmod(rest, 2)
            tl, bl = divmod(rest, 2)
            tuples.append((cols[tl], cols[bl], cols[tr], cols[br]))
            var.append(v)
        layout = CornerTileSet("k2", cols, tuples, var).to_dict()
        scheme = "omega"
    else:
        hz, vt = ("a", "b"), ("x", "y")
        tuples = []
        for t in range(16):
            rest, w = divmod(t, 2)
            rest, s = divmod(rest, 2)
            n, e = divmod(rest, 2)
            tuples.append((hz[n], vt[e], hz[s], vt[w]))
        layout = WangTileSet("e22", hz, vt, tuples).to_dict()
        scheme = "wang"
    return dataclasses.replace(base, layout=layout, scheme=scheme, labels=None, cut_stats=None, **arrays)


@pytest.mark.parametrize(
    "kind,variants,seed,wrap",
    [("corner", 2, 0xDEADBEEF, None), ("edge", 1, 7, None), ("corner", 1, 2**32 - 1, (5, 3))],
)
def test_hash_mode_composition_equals_synthesize(browser, tmp_path, omega_set, kind, variants, seed, wrap):
    tileset = complete_set(omega_set, kind, variants)
    m, imap, levels, r = _exported(tileset, tmp_path / "x", seed=seed, wrap=wrap)
    assert m["lookup"]["mode"] == "hash" and imap is None and "index.png" not in m["files"]
    assert m["lookup"]["kind"] == kind and m["lookup"]["V"] == variants
    n = tileset.tile_size
    cases = _fetch_cases(r, n)
    for x0, y0 in ((-n - 6, -2 * n + 3), (5 * n - 17, -9)):
        exact = np.rint(r.sampled(x0, y0, 40, 40, 1.0)).astype(np.uint8)
        cases.append(xv.case(f"centres {x0},{y0}", "grad", (x0, y0), 40, 40, 1.0, 0, exact))
    # another seed in the same page: the seed uniform is live
    other = xv.Reference(tileset, dict(m, lookup=dict(m["lookup"], seed=12345)), None, levels)
    cases.append(
        xv.case("seed 12345", "fetch", (-40, -40), 48, 48, 1.0, 0, other.fetch(-40, -40, 48, 48), seed=12345)
    )
    rep = _run(browser, tmp_path, tileset, m, imap, levels, cases)
    assert rep["status"] == "PASS", rep
    assert all(c["differing"] == 0 and c["max_diff"] == 0 for c in rep["cases"]), rep["cases"]
    # the hashed layout is really used: the window holds many different tiles
    cy, cx = np.mgrid[-4:4, -4:4]
    assert len(np.unique(r.index_of(cx, cy))) >= 8


def test_wgsl_hash_and_tile_index_match_the_vectors_in_webgpu(browser, tmp_path):
    """The WGSL shader through Chromium's WebGPU (Dawn on SwiftShader's Vulkan), in a compute pass."""
    import json

    from webgl import run_webgpu_page, wgsl_page

    from tilesynth.engine import shader_source

    vectors = json.loads((DATA / "hash_vectors.json").read_text())
    page = tmp_path / "wgsl.html"
    page.write_text(wgsl_page(vectors, shader_source("tilesynth.wgsl")), encoding="utf-8")
    rep = run_webgpu_page(browser, page)
    if "adapter" in str(rep.get("error", "")).lower() or "navigator.gpu" in str(rep.get("error", "")):
        pytest.skip(f"no WebGPU adapter in this browser: {rep['error']}")
    assert rep.get("error") is None, rep
    assert rep["checked"] == 1180 and rep["status"] == "PASS", rep["fails"]


@pytest.mark.parametrize("target", ["glsl-es300", "glsl-400", "hlsl"])
def test_shaders_compile_with_glslang(tmp_path, target):
    """The GLSL (ES 3.00 and desktop 4.00) and HLSL (to SPIR-V) sources compile with Khronos' glslang."""
    import shutil
    import subprocess

    from tilesynth.engine import shader_source

    exe = shutil.which("glslangValidator")
    if exe is None:
        pytest.skip("glslangValidator not found (apt-get install glslang-tools)")
    if target == "hlsl":
        src = shader_source("tilesynth.hlsl") + (
            "float4 main(float2 uv : TEXCOORD0) : SV_Target { return ts_sample(uv) + ts_fetch(int2(uv)); }\n"
        )
        f = tmp_path / "t.hlsl"
        cmd = [exe, "-D", "-V", "-e", "main", "-S", "frag", "-o", str(tmp_path / "t.spv"), str(f)]
    else:
        head = (
            "#version 300 es\nprecision highp float;\nprecision highp int;\n"
            if target == "glsl-es300"
            else "#version 400\n"
        )
        src = (
            head
            + shader_source("tilesynth.glsl")
            + ("in vec2 uv; out vec4 o; void main() { o = ts_sample(uv) + ts_fetch(ivec2(uv)); }\n")
        )
        f = tmp_path / "t.frag"
        cmd = [exe, str(f)]
    f.write_text(src)
    out = subprocess.run(cmd, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr
