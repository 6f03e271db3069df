// tilesynth.wgsl: per-pixel lookup of a tilesynth export (manifest.json "format" "tilesynth-export" v1), WGSL.
// Same functions, same hash (pcg3d, bit for bit) and same conventions as tilesynth.glsl; see its header.
// Bindings (change the group/binding numbers to fit your pipeline):
//   ts_atlas    the atlas of one map, levels 0..max_level; ts_sampler: linear min/mag/mipmap, clamp-to-edge
//   ts_index    index_map mode: index.png as an r16uint texture (hash mode: any 1x1 u32 texture, never read)
//   ts          the parameters from manifest.json (grid = N, P, atlas columns, max_level; lookup = mode
//               (0 index map, 1 hash corner, 2 hash edge), K (or Kh), Kv, V; wrap = hash period, 0 0 = none)
// Host layout of TsParams (64 bytes): grid @0, lookup @16, wrap @32, seed @40, _pad @44, atlas_size @48.
struct TsParams {
    grid: vec4<i32>,        // tile size N, padding P, atlas columns, max_level
    lookup: vec4<i32>,
    wrap: vec2<i32>,
    seed: u32,
    _pad: u32,
    atlas_size: vec2<f32>,
};
@group(0) @binding(0) var ts_atlas: texture_2d<f32>;
@group(0) @binding(1) var ts_sampler: sampler;
@group(0) @binding(2) var ts_index: texture_2d<u32>;
@group(0) @binding(3) var<uniform> ts: TsParams;

// u32 arithmetic wraps mod 2^32 in WGSL.
fn ts_pcg3d(v0: vec3<u32>) -> vec3<u32> {
    var v = v0 * 1664525u + 1013904223u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> vec3<u32>(16u);
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    return v;
}

fn ts_hash(x: i32, y: i32, seed: u32, role: u32) -> u32 {
    return ts_pcg3d(vec3<u32>(bitcast<u32>(x), bitcast<u32>(y), seed ^ (role * 0x9E3779B9u))).x;
}

// Floor division / Euclidean modulo for b > 0, dividing non-negative operands only; ~a = -a - 1 never overflows.
fn ts_floordiv(a: i32, b: i32) -> i32 { return select(-1 - (~a) / b, a / b, a >= 0); }
fn ts_emod(a: i32, b: i32) -> i32 { return a - b * ts_floordiv(a, b); }

fn ts_lattice(v0: vec2<i32>, role: u32) -> u32 {
    var v = v0;
    if (ts.wrap.x > 0) { v = vec2<i32>(ts_emod(v.x, ts.wrap.x), ts_emod(v.y, ts.wrap.y)); }
    return ts_hash(v.x, v.y, ts.seed, role);
}

fn ts_tile_index(cell0: vec2<i32>) -> i32 {
    var cell = cell0;
    if (ts.lookup.x == 0) {
        let sz = vec2<i32>(textureDimensions(ts_index, 0));
        return i32(textureLoad(ts_index, vec2<i32>(ts_emod(cell.x, sz.x), ts_emod(cell.y, sz.y)), 0).r);
    }
    // wrap the cell first, so cell + 1 never overflows and (cx + 1) mod Tx is exact for every i32 cx
    if (ts.wrap.x > 0) { cell = vec2<i32>(ts_emod(cell.x, ts.wrap.x), ts_emod(cell.y, ts.wrap.y)); }
    let V = u32(ts.lookup.w);
    let v = ts_lattice(cell, 3u) % V;
    if (ts.lookup.x == 1) {
        let K = u32(ts.lookup.y);
        let tl = ts_lattice(cell, 0u) % K;
        let tr = ts_lattice(cell + vec2<i32>(1, 0), 0u) % K;
        let bl = ts_lattice(cell + vec2<i32>(0, 1), 0u) % K;
        let br = ts_lattice(cell + vec2<i32>(1, 1), 0u) % K;
        return i32((((tl * K + bl) * K + tr) * K + br) * V + v);
    }
    let Kh = u32(ts.lookup.y);
    let Kv = u32(ts.lookup.z);
    let n = ts_lattice(cell, 1u) % Kh;
    let s = ts_lattice(cell + vec2<i32>(0, 1), 1u) % Kh;
    let w = ts_lattice(cell, 2u) % Kv;
    let e = ts_lattice(cell + vec2<i32>(1, 0), 2u) % Kv;
    return i32((((n * Kv + e) * Kh + s) * Kv + w) * V + v);
}

fn ts_tile_origin(t: i32) -> vec2<i32> {
    let s = ts.grid.x + 2 * ts.grid.y;
    return vec2<i32>((t % ts.grid.z) * s, (t / ts.grid.z) * s) + vec2<i32>(ts.grid.y);
}

// The exact texel (x, y) of the infinite texture.
fn ts_fetch(p: vec2<i32>) -> vec4<f32> {
    let n = ts.grid.x;
    let cell = vec2<i32>(ts_floordiv(p.x, n), ts_floordiv(p.y, n));
    return textureLoad(ts_atlas, ts_tile_origin(ts_tile_index(cell)) + (p - cell * n), 0);
}

// Filtered sample at uv (tile units) with the gradients of the continuous uv; footprint clamped to max_level.
fn ts_sample_grad(uv: vec2<f32>, duvdx: vec2<f32>, duvdy: vec2<f32>) -> vec4<f32> {
    let cellf = floor(uv);
    let n = f32(ts.grid.x);
    let texel = vec2<f32>(ts_tile_origin(ts_tile_index(vec2<i32>(cellf)))) + (uv - cellf) * n;
    var gx = duvdx * n;
    var gy = duvdy * n;
    let m = max(dot(gx, gx), dot(gy, gy));
    let lim = exp2(2.0 * f32(ts.grid.w));
    if (m > lim) {
        let k = sqrt(lim / m);
        gx *= k;
        gy *= k;
    }
    return textureSampleGrad(ts_atlas, ts_sampler, texel / ts.atlas_size, gx / ts.atlas_size, gy / ts.atlas_size);
}

// Call from uniform control flow (dpdx/dpdy).
fn ts_sample(uv: vec2<f32>) -> vec4<f32> { return ts_sample_grad(uv, dpdx(uv), dpdy(uv)); }
