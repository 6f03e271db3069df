"""Headless-Chromium harness for the export's WebGL2 tests: build a viewer page with given self-test cases, run
it in ``chromium-headless-shell`` (SwiftShader), return the page's JSON report."""

from __future__ import annotations

import contextlib
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
    cmd = [
        browser,
        "--no-sandbox",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--headless",
        "--dump-dom",
        page.resolve().as_uri() + query,
    ]
    if Path(browser).name == "chromium-headless-shell":
        cmd.remove("--headless")
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    m = re.search(r'<pre id="selftest-result"[^>]*>(.*?)</pre>', out.stdout, re.DOTALL)
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


WGSL_PAGE = """<!DOCTYPE html><html><body><div id="selftest-status">pending</div><pre id="selftest-result"></pre>
<script id="lib" type="text/wgsl">__LIB__</script>
<script>
"use strict";
const V = __VECTORS__;
const st = document.getElementById("selftest-status"), res = document.getElementById("selftest-result");
let DONE; window.tsDone = new Promise(r => { DONE = r; });
const ENTRY = `
struct Job { what: u32, n: u32, _a: u32, _b: u32 };
@group(1) @binding(0) var<storage, read> jin: array<vec4<i32>>;
@group(1) @binding(1) var<storage, read_write> jout: array<vec4<u32>>;
@group(1) @binding(2) var<uniform> job: Job;
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) g: vec3<u32>) {
  let i = g.x;
  if (i >= job.n) { return; }
  let a = jin[i];
  if (job.what == 0u) { jout[i] = vec4<u32>(ts_hash(a.x, a.y, bitcast<u32>(a.z), u32(a.w)), 0u, 0u, 0u); }
  else if (job.what == 1u) { jout[i] = vec4<u32>(ts_pcg3d(bitcast<vec3<u32>>(a.xyz)), 0u); }
  else { jout[i] = vec4<u32>(bitcast<u32>(ts_tile_index(a.xy)), 0u, 0u, 0u); }
}`;
(async () => {
 try {
  if (!navigator.gpu) throw new Error("no navigator.gpu");
  const adapter = await navigator.gpu.requestAdapter();
  if (!adapter) throw new Error("no WebGPU adapter");
  const dev = await adapter.requestDevice();
  const mod = dev.createShaderModule({code: document.getElementById("lib").textContent + ENTRY});
  const info = await mod.getCompilationInfo();
  const errs = info.messages.filter(m => m.type === "error").map(m => m.lineNum + ": " + m.message);
  if (errs.length) throw new Error("WGSL: " + errs.join("; "));
  const pipe = dev.createComputePipeline({layout: "auto", compute: {module: mod, entryPoint: "main"}});
  const U = GPUBufferUsage;
  const tex = dev.createTexture({size: [1, 1], format: "r32uint", usage: GPUTextureUsage.TEXTURE_BINDING});
  const params = dev.createBuffer({size: 64, usage: U.UNIFORM | U.COPY_DST});
  async function run(what, rows, p) {
    dev.pushErrorScope("validation");
    const out = await run1(what, rows, p);
    const err = await dev.popErrorScope();
    if (err) throw new Error("WebGPU: " + err.message);
    return out;
  }
  async function run1(what, rows, p) {
    const n = rows.length;
    const inb = dev.createBuffer({size: Math.max(16, n * 16), usage: U.STORAGE | U.COPY_DST});
    dev.queue.writeBuffer(inb, 0, new Int32Array(rows.flat()));
    const outb = dev.createBuffer({size: Math.max(16, n * 16), usage: U.STORAGE | U.COPY_SRC});
    const rd = dev.createBuffer({size: Math.max(16, n * 16), usage: U.MAP_READ | U.COPY_DST});
    const jb = dev.createBuffer({size: 16, usage: U.UNIFORM | U.COPY_DST});
    dev.queue.writeBuffer(jb, 0, new Uint32Array([what, n, 0, 0]));
    if (p) dev.queue.writeBuffer(params, 0, p);
    const groups = [];
    for (let gi = 0; gi < 2; gi++) {
      const layout = pipe.getBindGroupLayout(gi);
      const entries = gi === 1 ? [{binding: 0, resource: {buffer: inb}}, {binding: 1, resource: {buffer: outb}}, {binding: 2, resource: {buffer: jb}}]
        : [{binding: 2, resource: tex.createView()}, {binding: 3, resource: {buffer: params}}];
      groups.push(entries ? dev.createBindGroup({layout, entries}) : null);
    }
    const enc = dev.createCommandEncoder(); const pass = enc.beginComputePass(); pass.setPipeline(pipe);
    groups.forEach((g, i) => { if (g) pass.setBindGroup(i, g); });
    pass.dispatchWorkgroups(Math.ceil(n / 64)); pass.end();
    enc.copyBufferToBuffer(outb, 0, rd, 0, n * 16); dev.queue.submit([enc.finish()]);
    await rd.mapAsync(GPUMapMode.READ); const out = new Uint32Array(rd.getMappedRange().slice(0)); rd.unmap();
    return out;
  }
  let bad = 0, n = 0; const fails = [];
  const h = await run(0, V.ts_hash.map(v => [v.x, v.y, v.seed | 0, v.role]));
  V.ts_hash.forEach((v, i) => { n++; if (h[4 * i] !== v.value) { bad++; if (fails.length < 5) fails.push({v, got: h[4 * i]}); } });
  const p = await run(1, V.pcg3d.map(v => [v.in[0] | 0, v.in[1] | 0, v.in[2] | 0, 0]));
  V.pcg3d.forEach((v, i) => { n++; if (p[4*i] !== v.out[0] || p[4*i+1] !== v.out[1] || p[4*i+2] !== v.out[2]) { bad++; if (fails.length < 5) fails.push({v}); } });
  for (const c of V.cells) {
    const buf = new ArrayBuffer(64), i32 = new Int32Array(buf), u32 = new Uint32Array(buf);
    i32.set([8, 0, 1, 0,  c.kind === "corner" ? 1 : 2, c.colours[0], c.colours.length > 1 ? c.colours[1] : 0, c.variants,
             c.wrap ? c.wrap[0] : 0, c.wrap ? c.wrap[1] : 0]);
    u32[10] = c.seed >>> 0;
    const r = await run(2, [[c.cx, c.cy, 0, 0]], buf); n++;
    if (r[0] !== c.index) { bad++; if (fails.length < 5) fails.push({c, got: r[0]}); }
  }
  st.textContent = (bad ? "FAIL " : "PASS ") + bad;
  res.textContent = JSON.stringify({status: bad ? "FAIL" : "PASS", differing: bad, checked: n, fails, cases: []});
 } catch (e) { st.textContent = "FAIL error"; res.textContent = JSON.stringify({status: "FAIL", error: String(e), cases: []}); }
 DONE(res.textContent);
})();
</script></body></html>"""


def wgsl_page(vectors: dict, wgsl: str) -> str:
    return WGSL_PAGE.replace("__LIB__", wgsl).replace("__VECTORS__", json.dumps(vectors))


def run_webgpu_page(browser: str, page: Path, timeout: float = 240.0) -> dict[str, Any]:
    """Run a WebGPU page (SwiftShader's Vulkan through Dawn) and return its report (``window.tsDone``)."""
    text = evaluate_async(browser, page, "window.tsDone", ["--enable-unsafe-webgpu"], timeout)
    return json.loads(text)


def evaluate_async(
    browser: str, page: Path, expression: str, flags: list[str], timeout: float = 240.0
) -> Any:
    """Open ``page`` and return the value of an (awaited) JS ``expression``, driving Chromium over the DevTools
    protocol on a pipe (``--remote-debugging-pipe``): for pages whose work is asynchronous (WebGPU), which
    ``--dump-dom`` does not wait for."""
    import select
    import time

    r_in, w_in = os.pipe()  # we write commands -> browser fd 3
    r_out, w_out = os.pipe()  # browser fd 4 -> we read
    proc = subprocess.Popen(
        [browser, "--no-sandbox", "--remote-debugging-pipe", *flags, "about:blank"],
        pass_fds=(3, 4),
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        preexec_fn=lambda: (os.dup2(r_in, 3), os.dup2(w_out, 4)),
    )
    os.close(r_in)
    os.close(w_out)
    buf = b""
    ids = iter(range(1, 1 << 30))

    def send(method: str, params: dict, session: str | None = None) -> int:
        i = next(ids)
        msg = {"id": i, "method": method, "params": params}
        if session:
            msg["sessionId"] = session
        os.write(w_in, json.dumps(msg).encode() + b"\0")
        return i

    def wait(i: int) -> dict:
        nonlocal buf
        end = time.monotonic() + timeout
        while True:
            while b"\0" in buf:
                raw, buf = buf.split(b"\0", 1)
                msg = json.loads(raw)
                if msg.get("id") == i:
                    if "error" in msg:
                        raise AssertionError(f"DevTools error: {msg['error']}")
                    return msg["result"]
            left = end - time.monotonic()
            if left <= 0:
                raise TimeoutError("the browser did not answer")
            ready, _, _ = select.select([r_out], [], [], left)
            if ready:
                chunk = os.read(r_out, 1 << 20)
                if not chunk:
                    raise AssertionError("the browser closed the pipe")
                buf += chunk

    try:
        target = wait(send("Target.createTarget", {"url": page.resolve().as_uri()}))["targetId"]
        session = wait(send("Target.attachToTarget", {"targetId": target, "flatten": True}))["sessionId"]
        end = time.monotonic() + timeout
        while True:  # until the page has defined what we wait for (the navigation is asynchronous)
            probe = wait(
                send(
                    "Runtime.evaluate",
                    {"expression": f"typeof ({expression}) !== 'undefined'", "returnByValue": True},
                    session,
                )
            )
            if probe.get("result", {}).get("value") is True:
                break
            if time.monotonic() > end:
                raise TimeoutError(f"the page never defined {expression}")
            time.sleep(0.1)
        res = wait(
            send(
                "Runtime.evaluate",
                {"expression": expression, "awaitPromise": True, "returnByValue": True},
                session,
            )
        )
        if "exceptionDetails" in res:
            raise AssertionError(f"page exception: {res['exceptionDetails']}")
        return res["result"].get("value")
    finally:
        with contextlib.suppress(Exception):
            send("Browser.close", {})
        with contextlib.suppress(Exception):
            proc.wait(timeout=20)
        if proc.poll() is None:
            proc.kill()
        os.close(w_in)
        os.close(r_out)


WGSL_V2_PAGE = """<!DOCTYPE html><html><body><div id="selftest-status">pending</div><pre id="selftest-result"></pre>
<script id="lib" type="text/wgsl">__LIB__</script>
<script>
"use strict";
const D = __DATA__;
const st = document.getElementById("selftest-status"), res = document.getElementById("selftest-result");
let DONE; window.tsDone = new Promise(r => { DONE = r; });
const ENTRY = `
struct Job { mode: u32, w: u32, h: u32, normal: i32, origin: vec2<f32>, scale: f32, _p: f32, bands: vec4<f32>,
  mean: vec4<f32> };
@group(1) @binding(0) var m0: texture_2d<f32>;
@group(1) @binding(1) var<storage, read_write> jout: array<vec4<u32>>;
@group(1) @binding(2) var<uniform> job: Job;
@compute @workgroup_size(64) fn main(@builtin(global_invocation_id) g: vec3<u32>) {
  let i = g.x;
  if (i >= job.w * job.h) { return; }
  let f = vec2<f32>(f32(i % job.w), f32(i / job.w));
  var v: vec4<f32>;
  if (job.mode == 1u) {
    v = ts_fetch_map(m0, vec2<i32>(floor(job.origin)) + vec2<i32>(f), job.normal);
  } else {
    let n = f32(ts.grid.x);
    let uv = (job.origin + (f + 0.5) * job.scale) / n;
    let gr = job.scale / n;
    let s = ts_site(uv, vec2<f32>(gr, 0.0), vec2<f32>(0.0, gr));
    if (job.mode == 3u) {
      v = ts_smooth_map(m0, s, ts_blend(s, job.bands), job.bands, job.mean, job.normal, ts_weight(s, 0.0));
    } else {
      v = ts_map(m0, s, ts_weight(s, 0.0), job.normal);
    }
  }
  jout[i] = vec4<u32>(round(clamp(v, vec4<f32>(0.0), vec4<f32>(1.0)) * 255.0));
}`;
function b64(s) { const b = atob(s); const a = new Uint8Array(b.length); for (let i = 0; i < b.length; i++) a[i] = b.charCodeAt(i); return a; }
(async () => {
 try {
  if (!navigator.gpu) throw new Error("no navigator.gpu");
  const adapter = await navigator.gpu.requestAdapter();
  if (!adapter) throw new Error("no WebGPU adapter");
  const dev = await adapter.requestDevice();
  dev.pushErrorScope("validation");
  const mod = dev.createShaderModule({code: document.getElementById("lib").textContent + ENTRY});
  const info = await mod.getCompilationInfo();
  const errs = info.messages.filter(m => m.type === "error").map(m => m.lineNum + ": " + m.message);
  if (errs.length) throw new Error("WGSL: " + errs.join("; "));
  const pipe = dev.createComputePipeline({layout: "auto", compute: {module: mod, entryPoint: "main"}});
  const TU = GPUTextureUsage, U = GPUBufferUsage;
  function texture(format, levels, bpp) {  // levels: [{w, h, data (base64)}]
    const t = dev.createTexture({size: [levels[0].w, levels[0].h], format, mipLevelCount: levels.length, usage: TU.TEXTURE_BINDING | TU.COPY_DST});
    levels.forEach((L, lv) => dev.queue.writeTexture({texture: t, mipLevel: lv}, b64(L.data), {bytesPerRow: L.w * bpp, rowsPerImage: L.h}, [L.w, L.h]));
    return t;
  }
  const bits = texture("r8uint", [D.bits], 1), cov = texture("r8unorm", D.coverage, 1);
  const table = texture("rgba32sint", [D.table], 16), index = texture("r16uint", [D.index], 2);
  const sampler = dev.createSampler({magFilter: "linear", minFilter: "linear", mipmapFilter: "linear", addressModeU: "mirror-repeat", addressModeV: "mirror-repeat"});
  const blendc = texture("r16float", [D.blend || {w: 1, h: 1, data: "AAA="}], 2);
  const rl = dev.createBuffer({size: 16, usage: U.UNIFORM | U.COPY_DST});
  dev.queue.writeBuffer(rl, 0, new Int32Array(D.blend_layout || [1, 3, -1, -1]));
  const params = dev.createBuffer({size: 48, usage: U.UNIFORM | U.COPY_DST});
  dev.queue.writeBuffer(params, 0, new Int32Array(b64(D.params).buffer));
  const g0 = dev.createBindGroup({layout: pipe.getBindGroupLayout(0), entries: [
    {binding: 0, resource: bits.createView()}, {binding: 1, resource: cov.createView()},
    {binding: 2, resource: index.createView()}, {binding: 3, resource: {buffer: params}},
    {binding: 4, resource: table.createView()}, {binding: 5, resource: sampler},
    {binding: 6, resource: blendc.createView()}, {binding: 7, resource: {buffer: rl}}]});
  const maps = D.maps.map(m => texture("rgba8unorm", m.levels, 4));
  const cases = [];
  let bad = 0;
  for (const c of D.cases) {
    const n = c.w * c.h;
    const outb = dev.createBuffer({size: n * 16, usage: U.STORAGE | U.COPY_SRC});
    const rd = dev.createBuffer({size: n * 16, usage: U.MAP_READ | U.COPY_DST});
    const jb = dev.createBuffer({size: 64, usage: U.UNIFORM | U.COPY_DST});
    const job = new ArrayBuffer(64), u32 = new Uint32Array(job), i32 = new Int32Array(job), f32 = new Float32Array(job);
    u32[0] = {fetch: 1, grad: 2, blend: 3}[c.kind]; u32[1] = c.w; u32[2] = c.h; i32[3] = D.maps[c.map].normal;
    f32[4] = c.origin[0]; f32[5] = c.origin[1]; f32[6] = c.scale;
    if (c.bands) { f32.set(c.bands, 8); f32.set(c.mean, 12); }
    dev.queue.writeBuffer(jb, 0, job);
    const g1 = dev.createBindGroup({layout: pipe.getBindGroupLayout(1), entries: [
      {binding: 0, resource: maps[c.map].createView()}, {binding: 1, resource: {buffer: outb}}, {binding: 2, resource: {buffer: jb}}]});
    const enc = dev.createCommandEncoder(); const pass = enc.beginComputePass(); pass.setPipeline(pipe);
    pass.setBindGroup(0, g0); pass.setBindGroup(1, g1); pass.dispatchWorkgroups(Math.ceil(n / 64)); pass.end();
    enc.copyBufferToBuffer(outb, 0, rd, 0, n * 16); dev.queue.submit([enc.finish()]);
    await rd.mapAsync(GPUMapMode.READ); const out = new Uint32Array(rd.getMappedRange().slice(0)); rd.unmap();
    const ref = b64(c.ref);
    let diff = 0, maxd = 0;
    for (let p = 0; p < n; p++) {
      let pd = 0;
      for (let k = 0; k < 4; k++) pd = Math.max(pd, Math.abs(out[4 * p + k] - ref[4 * p + k]));
      if (pd > c.tol) diff++;
      maxd = Math.max(maxd, pd);
    }
    if (diff) bad++;
    const r = {name: c.name, pixels: n, differing: diff, max_diff: maxd};
    if (c.dump) { const img = new Uint8Array(n * 4); for (let i = 0; i < n * 4; i++) img[i] = out[i]; let s = ""; for (let i = 0; i < img.length; i += 8192) s += String.fromCharCode.apply(null, img.subarray(i, i + 8192)); r.image = btoa(s); }
    cases.push(r);
  }
  const err = await dev.popErrorScope();
  if (err) throw new Error("WebGPU: " + err.message);
  st.textContent = (bad ? "FAIL " : "PASS ") + bad;
  res.textContent = JSON.stringify({status: bad ? "FAIL" : "PASS", cases});
 } catch (e) { st.textContent = "FAIL error"; res.textContent = JSON.stringify({status: "FAIL", error: String(e), cases: []}); }
 DONE(res.textContent);
})();
</script></body></html>"""


def wgsl_v2_page(data: dict, wgsl: str) -> str:
    """A WebGPU page running the version-2 WGSL map lookup in a compute pass over the windows of ``data``
    (textures as base64 levels, the parameters, the blend coverage as half floats and its layout, cases with
    reference bytes;
    a case of kind "blend" draws a smooth map by ``ts_smooth_map`` with its ``bands`` and ``mean``)."""
    return WGSL_V2_PAGE.replace("__LIB__", wgsl).replace("__DATA__", json.dumps(data))
