"""Headless-Chromium harness for the export's WebGL2 tests: build a viewer page with given self-test cases, run
it in ``chromium-headless-shell`` (SwiftShader), return the page's JSON report."""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
from pathlib import Path
from typing import Any

import pytest

BROWSERS = ("chromium-headless-shell", "chromium", "chromium-browser", "google-chrome", "headless_shell")


def find_browser() -> str | None:
    env = os.environ.get("TILESYNTH_BROWSER")
    if env:
        return env
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    return None


def browser_or_skip() -> str:
    path = find_browser()
    if path is None:
        pytest.skip(
            "no headless Chromium found (apt-get install chromium-headless-shell, or TILESYNTH_BROWSER=/path): "
            "the WebGL2 tests need a real browser"
        )
    return path


def run_page(browser: str, page: Path, query: str = "", timeout: float = 240.0) -> dict[str, Any]:
    """Load ``page`` and return the JSON of ``#selftest-result`` (raises if the page did not report)."""
    cmd = [browser, "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--headless",
           "--dump-dom", page.resolve().as_uri() + query]
    if Path(browser).name == "chromium-headless-shell":
        cmd.remove("--headless")
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    m = re.search(r'<pre id="selftest-result"[^>]*>(.*?)</pre>', out.stdout, re.S)
    if not m or not m.group(1).strip():
        raise AssertionError(f"the page reported nothing; stderr tail:\n{out.stderr[-2000:]}")
    report = json.loads(html.unescape(m.group(1)))
    status = re.search(r'<div id="selftest-status">([^<]*)</div>', out.stdout)
    report["dom_status"] = status.group(1) if status else None
    return report


HASH_PAGE = """<!DOCTYPE html><html><body><div id="selftest-status"></div><pre id="selftest-result"></pre>
<script id="lib" type="x-shader/x-fragment">__LIB__</script>
<script>
"use strict";
const V = __VECTORS__;
const st = document.getElementById("selftest-status"), res = document.getElementById("selftest-result");
try {
  const gl = document.createElement("canvas").getContext("webgl2");
  const FS = `#version 300 es
precision highp float; precision highp int;
${document.getElementById("lib").textContent}
uniform ivec4 u_in;   // x, y, seed bits, role
uniform ivec2 u_cell;
uniform int u_what;   // 0: ts_hash, 1: pcg3d, 2: ts_tile_index
out uvec4 o;
void main() {
  if (u_what == 0) o = uvec4(ts_hash(u_in.x, u_in.y, uint(u_in.z), uint(u_in.w)), 0u, 0u, 0u);
  else if (u_what == 1) o = uvec4(ts_pcg3d(uvec3(u_in.xyz)), 0u);
  else o = uvec4(uint(ts_tile_index(u_cell)), 0u, 0u, 0u);
}`;
  const VS = `#version 300 es
void main() { vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0); gl_Position = vec4(p, 0.0, 1.0); }`;
  function sh(t, s) { const x = gl.createShader(t); gl.shaderSource(x, s); gl.compileShader(x);
    if (!gl.getShaderParameter(x, gl.COMPILE_STATUS)) throw new Error(gl.getShaderInfoLog(x)); return x; }
  const p = gl.createProgram(); gl.attachShader(p, sh(gl.VERTEX_SHADER, VS)); gl.attachShader(p, sh(gl.FRAGMENT_SHADER, FS));
  gl.linkProgram(p); if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(gl.getProgramInfoLog(p));
  gl.useProgram(p); gl.bindVertexArray(gl.createVertexArray());
  const U = n => gl.getUniformLocation(p, n);
  // a dummy integer index texture on its own unit, and the atlas unit
  const t0 = gl.createTexture(); gl.activeTexture(gl.TEXTURE0); gl.bindTexture(gl.TEXTURE_2D, t0);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, 1, 1, 0, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array(4));
  const t1 = gl.createTexture(); gl.activeTexture(gl.TEXTURE1); gl.bindTexture(gl.TEXTURE_2D, t1);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.R16UI, 1, 1, 0, gl.RED_INTEGER, gl.UNSIGNED_SHORT, new Uint16Array(1));
  gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.NEAREST);
  gl.uniform1i(U("ts_atlas"), 0); gl.uniform1i(U("ts_index"), 1);
  const rt = gl.createTexture(); gl.activeTexture(gl.TEXTURE2); gl.bindTexture(gl.TEXTURE_2D, rt);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32UI, 1, 1, 0, gl.RGBA_INTEGER, gl.UNSIGNED_INT, null);
  const fb = gl.createFramebuffer(); gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, rt, 0);
  gl.viewport(0, 0, 1, 1);
  const out = new Uint32Array(4);
  function run(what) { gl.uniform1i(U("u_what"), what); gl.drawArrays(gl.TRIANGLES, 0, 3);
    gl.readPixels(0, 0, 1, 1, gl.RGBA_INTEGER, gl.UNSIGNED_INT, out); return Array.from(out); }
  const i32 = v => v | 0;
  let bad = 0, n = 0; const fails = [];
  for (const h of V.ts_hash) {
    gl.uniform4i(U("u_in"), h.x, h.y, i32(h.seed), h.role); const r = run(0)[0]; n++;
    if (r !== h.value) { bad++; if (fails.length < 5) fails.push({h, got: r}); }
  }
  for (const h of V.pcg3d) {
    gl.uniform4i(U("u_in"), i32(h.in[0]), i32(h.in[1]), i32(h.in[2]), 0); const r = run(1); n++;
    if (r[0] !== h.out[0] || r[1] !== h.out[1] || r[2] !== h.out[2]) { bad++; if (fails.length < 5) fails.push({h, got: r}); }
  }
  gl.uniform4i(U("ts_layout"), 8, 0, 1, 0);
  for (const c of V.cells) {
    const mode = c.kind === "corner" ? 1 : 2, K = c.colours[0], Kv = c.colours.length > 1 ? c.colours[1] : 0;
    gl.uniform4i(U("ts_lookup"), mode, K, Kv, c.variants);
    gl.uniform1ui(U("ts_seed"), c.seed >>> 0);
    gl.uniform2i(U("ts_wrap"), c.wrap ? c.wrap[0] : 0, c.wrap ? c.wrap[1] : 0);
    gl.uniform2i(U("u_cell"), c.cx, c.cy); const r = run(2)[0]; n++;
    if (r !== c.index) { bad++; if (fails.length < 5) fails.push({c, got: r}); }
  }
  st.textContent = (bad ? "FAIL " : "PASS ") + bad;
  res.textContent = JSON.stringify({status: bad ? "FAIL" : "PASS", differing: bad, checked: n, fails, cases: []});
} catch (e) { st.textContent = "FAIL error"; res.textContent = JSON.stringify({status: "FAIL", error: String(e), cases: []}); }
</script></body></html>"""


def hash_page(vectors: dict, glsl: str) -> str:
    return HASH_PAGE.replace("__LIB__", glsl).replace("__VECTORS__", json.dumps(vectors))
