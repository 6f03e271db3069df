// tilesynth_v2.wgsl: per-pixel lookup of a tilesynth export version 2 (provenance), WGSL. Same functions, hash,
// conventions and fetch counts as tilesynth_v2.glsl (see its header: TsSite, ts_site, ts_weight, ts_map).
// Bindings (change the group/binding numbers to fit your pipeline):
//   ts_bits      labels_bits.png as an r8uint texture (textureLoad only)
//   ts_coverage  labels_coverage.png + levels as r8unorm, sampled with ts_sampler
//   ts_table     table.bin as an rgba32sint texture of width 256 (textureLoad only)
//   ts_index     index_map mode: index.png as r16uint (hash mode: any 1x1 u32 texture, never read)
//   ts_sampler   linear min/mag/mipmap, mirror-repeat: for the coverage (its reads stay inside a tile's cell)
//                and every map (the seam blend reads an entry past its piece, mirrored at the exemplar's edge)
//   ts_blend_cov labels_blend.png as r16float, texel = count / 4^l, sampled with ts_sampler at level 0 (any 1x1
//                float texture without it)
//   ts_blend_layout  (columns, high_level, reach_levels[0] or -1, reach_levels[1]) of the manifest's labels.blend
// The seam blend of smooth maps (manifest "seam": "blend"): TsBlend, ts_blend, ts_blend_map, ts_smooth_map, as
// in tilesynth_v2.glsl (its header: the formula, the approximations, minification and fetches).
//   ts           the parameters: grid = N, bits columns, coverage columns, coverage max level; lookup = mode
//                (0 index map, 1 hash corner, 2 hash edge), K (or Kh), Kv, V; wrap = hash period (0 0: none)
// Every map: a texture_2d<f32> with its full mip chain, passed to ts_map with ts_sampler.
// Host layout of TsParams (48 bytes): grid @0, lookup @16, wrap @32, seed @40, _pad @44.
struct TsParams {
    grid: vec4<i32>,
    lookup: vec4<i32>,
    wrap: vec2<i32>,
    seed: u32,
    _pad: u32,
};
@group(0) @binding(0) var ts_bits: texture_2d<u32>;
@group(0) @binding(1) var ts_coverage: texture_2d<f32>;
@group(0) @binding(2) var ts_index: texture_2d<u32>;
@group(0) @binding(3) var<uniform> ts: TsParams;
@group(0) @binding(4) var ts_table: texture_2d<i32>;
@group(0) @binding(5) var ts_sampler: sampler;
@group(0) @binding(6) var ts_blend_cov: texture_2d<f32>;
@group(0) @binding(7) var<uniform> ts_blend_layout: vec4<i32>;

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

struct TsSite {
    ent: vec4<i32>,   // (code_A, bx_A, code_B, bx_B), code = (radius << 19) | ((by + 32768) << 3) | symmetry
    tile: i32,
    p: vec2<f32>,     // position in the tile in pixels (x, y)
    gx: vec2<f32>,
    gy: vec2<f32>,
    lod: f32,
};

fn ts_table_texel(tile: i32, p: vec2<f32>) -> vec4<i32> {
    let h = f32(ts.grid.x / 2);
    let q = select(0, 2, p.y >= h) + select(0, 1, p.x >= h);
    let i = 4 * tile + q;
    return textureLoad(ts_table, vec2<i32>(i % 256, i / 256), 0);
}

fn ts_site(uv: vec2<f32>, duvdx: vec2<f32>, duvdy: vec2<f32>) -> TsSite {
    var s: TsSite;
    let cellf = floor(uv);
    let n = f32(ts.grid.x);
    s.tile = ts_tile_index(vec2<i32>(cellf));
    s.p = (uv - cellf) * n;
    s.gx = duvdx * n;
    s.gy = duvdy * n;
    s.lod = 0.5 * log2(max(max(dot(s.gx, s.gx), dot(s.gy, s.gy)), 1e-20));
    s.ent = ts_table_texel(s.tile, s.p);
    return s;
}

fn ts_one_source(s: TsSite) -> bool { return all(s.ent.xy == s.ent.zw); }

// The radii of the sample's quadrant (pixels from the tile's centre): see tilesynth_v2.glsl.
fn ts_r_in(s: TsSite) -> f32 { return f32(s.ent.x >> 19u) * 0.5; }
fn ts_r_out(s: TsSite) -> f32 { return f32(s.ent.z >> 19u) * 0.5; }

// The label bit of the pixel under the sample (1: entry B): one fetch inside the label band, none outside it.
fn ts_bit(s: TsSite) -> f32 {
    let n = ts.grid.x;
    let ip = clamp(vec2<i32>(floor(s.p)), vec2<i32>(0), vec2<i32>(n - 1));
    let d = length(vec2<f32>(ip) + 0.5 - 0.5 * f32(n));
    if (d < ts_r_in(s)) { return 1.0; }
    if (d > ts_r_out(s)) { return 0.0; }
    let c = ts.grid.y;
    let cell = vec2<i32>((s.tile % c) * (n / 8), (s.tile / c) * n);
    let byte = textureLoad(ts_bits, cell + vec2<i32>(ip.x / 8, ip.y), 0).r;
    return f32((byte >> u32(ip.x % 8)) & 1u);
}

// Weight of entry B at level max(footprint, blend_level): see tilesynth_v2.glsl.
fn ts_weight(s: TsSite, blend_level: f32) -> f32 {
    if (ts_one_source(s)) { return 0.0; }
    let lw = max(s.lod, blend_level);
    if (lw < 1.0) { return ts_bit(s); }
    let n = ts.grid.x;
    let lc = clamp(lw - 2.0, 0.0, f32(ts.grid.w));
    let d = length(s.p - 0.5 * f32(n));
    let reach = 2.2 * exp2(ceil(lc) + 2.0);
    var w: f32;
    if (d + reach < ts_r_in(s)) {
        w = 1.0;
    } else if (d - reach > ts_r_out(s)) {
        w = 0.0;
    } else {
        let side = f32(n / 4);
        let half_texel = 0.5 * exp2(ceil(lc));
        let q = clamp(s.p * 0.25, vec2<f32>(min(half_texel, 0.5 * side)), vec2<f32>(max(side - half_texel, 0.5 * side)));
        let c = ts.grid.z;
        let pos = vec2<f32>(f32(s.tile % c), f32(s.tile / c)) * side + q;
        w = textureSampleLevel(ts_coverage, ts_sampler, pos / vec2<f32>(textureDimensions(ts_coverage, 0)), lc).r;
    }
    let e = min(s.p, vec2<f32>(f32(n)) - s.p);
    w *= clamp(min(e.x, e.y) / min(exp2(lw), f32(n) / 16.0), 0.0, 1.0);
    if (blend_level > s.lod) { w = max(ts_bit(s), min(1.0, 2.0 * w)); }
    return w;
}

fn ts_src(code: i32, bx: i32, p: vec2<f32>) -> vec2<f32> {
    let sym = code & 7;
    let n = f32(ts.grid.x);
    let y = p.y;
    var x = p.x;
    if (sym >= 4) { x = n - x; }
    let k = sym & 3;
    var rc = vec2<f32>(y, x);
    if (k == 1) { rc = vec2<f32>(x, n - y); } else if (k == 2) { rc = vec2<f32>(n - y, n - x); } else if (k == 3) { rc = vec2<f32>(n - x, y); }
    return vec2<f32>(rc.y + f32(bx), rc.x + f32(((code >> 3u) & 0xFFFF) - 32768));
}

fn ts_turn(code: i32, g: vec2<f32>) -> vec2<f32> {
    let sym = code & 7;
    let y = g.y;
    var x = g.x;
    if (sym >= 4) { x = -x; }
    let k = sym & 3;
    var rc = vec2<f32>(y, x);
    if (k == 1) { rc = vec2<f32>(x, -y); } else if (k == 2) { rc = vec2<f32>(-y, -x); } else if (k == 3) { rc = vec2<f32>(-x, y); }
    return rc.yx;
}

// normal: 0 no turn, 1 / 2 unsigned codes +y / -y, 3 / 4 signed vectors +y / -y; -1 a one-channel scalar map
// bound with its low band in .g: the value, grey.
fn ts_turn_normal(c0: vec4<f32>, code: i32, normal: i32) -> vec4<f32> {
    if (normal < 0) { return vec4<f32>(c0.xxx, 1.0); }
    let sym = code & 7;
    if (normal == 0 || sym == 0) { return c0; }
    var c = c0;
    var v = select(c.xy, c.xy * 2.0 - 1.0, normal <= 2);
    let down = normal == 2 || normal == 4;
    if (down) { v.y = -v.y; }
    for (var i = 0; i < (sym & 3); i++) { v = vec2<f32>(-v.y, v.x); }
    if (sym >= 4) { v.x = -v.x; }
    if (down) { v.y = -v.y; }
    let o = select(v, v * 0.5 + 0.5, normal <= 2);
    c.x = o.x;
    c.y = o.y;
    return c;
}

// The texel of an entry as stored (no turn of a normal).
fn ts_entry_raw(map: texture_2d<f32>, s: TsSite, code: i32, bx: i32) -> vec4<f32> {
    let size = vec2<f32>(textureDimensions(map, 0));
    let src = ts_src(code, bx, s.p);
    return textureSampleGrad(map, ts_sampler, src / size, ts_turn(code, s.gx) / size, ts_turn(code, s.gy) / size);
}

fn ts_entry(map: texture_2d<f32>, s: TsSite, code: i32, bx: i32, normal: i32) -> vec4<f32> {
    return ts_turn_normal(ts_entry_raw(map, s, code, bx), code, normal);
}

fn ts_map(map: texture_2d<f32>, s: TsSite, w: f32, normal: i32) -> vec4<f32> {
    if (w <= 0.0 || ts_one_source(s)) { return ts_entry(map, s, s.ent.x, s.ent.y, normal); }
    if (w >= 1.0) { return ts_entry(map, s, s.ent.z, s.ent.w, normal); }
    return mix(ts_entry(map, s, s.ent.x, s.ent.y, normal), ts_entry(map, s, s.ent.z, s.ent.w, normal), w);
}

// The exact texel (x, y) of the infinite texture of one map (textureLoad only: any shader stage).
fn ts_fetch_map(map: texture_2d<f32>, p: vec2<i32>, normal: i32) -> vec4<f32> {
    let n = ts.grid.x;
    let cell = vec2<i32>(ts_floordiv(p.x, n), ts_floordiv(p.y, n));
    let tile = ts_tile_index(cell);
    let l = p - cell * n;
    let ent = ts_table_texel(tile, vec2<f32>(l) + 0.5);
    let c = ts.grid.y;
    let byte = textureLoad(ts_bits, vec2<i32>((tile % c) * (n / 8) + l.x / 8, (tile / c) * n + l.y), 0).r;
    let b = ((byte >> u32(l.x % 8)) & 1u) == 1u;
    let code = select(ent.x, ent.z, b);
    let bx = select(ent.y, ent.w, b);
    let sym = code & 7;
    let m = n - 1;
    let y = l.y;
    var x = l.x;
    if (sym >= 4) { x = m - x; }
    let k = sym & 3;
    var rc = vec2<i32>(y, x);
    if (k == 1) { rc = vec2<i32>(x, m - y); } else if (k == 2) { rc = vec2<i32>(m - y, m - x); } else if (k == 3) { rc = vec2<i32>(m - x, y); }
    let v = textureLoad(map, vec2<i32>(rc.y + bx, rc.x + ((code >> 3u) & 0xFFFF) - 32768), 0);
    return ts_turn_normal(v, code, normal);
}

// Call from uniform control flow (dpdx/dpdy).
fn ts_sample_map(map: texture_2d<f32>, uv: vec2<f32>, blend_level: f32, normal: i32) -> vec4<f32> {
    let s = ts_site(uv, dpdx(uv), dpdy(uv));
    return ts_map(map, s, ts_weight(s, blend_level), normal);
}

// ------------------------------------------------------------------------------------------ the seam blend
// The weights of the entries of a tile near a pixel: A_0..A_3 (each quadrant's own) and B (the matching patch).
struct TsBlend {
    ca: vec4<i32>,   // per quadrant: code_A (with r_in), bx_A, code_B (with r_out), from the table
    xa: vec4<i32>,
    cb: vec4<i32>,
    bb: vec2<i32>,   // (code, bx) of B
    loaded: i32,     // bit q: quadrant q's table texel read
    ha: vec4<f32>,   // detail-band weights of A_0..A_3 and B
    hb: f32,
    ga: vec4<f32>,   // low-band weights
    gb: f32,
};

fn ts_quad(b: ptr<function, TsBlend>, tile: i32, q: i32) {
    if ((((*b).loaded >> u32(q)) & 1) != 0) { return; }
    let i = 4 * tile + q;
    let e = textureLoad(ts_table, vec2<i32>(i % 256, i / 256), 0);
    (*b).ca[q] = e.x; (*b).xa[q] = e.y; (*b).cb[q] = e.z; (*b).bb = vec2<i32>(e.z & 0x7FFFF, e.w);
    (*b).loaded |= 1 << u32(q);
}

// The radii's verdict on the pixels [p0, p1] of quadrant q (band 1: of the labels extended reach px): 0 all A,
// 1 all B, -1 unknown.
fn ts_rect_known(b: TsBlend, band: i32, p0: vec2<i32>, p1: vec2<i32>, q: i32, reach: i32) -> f32 {
    let n = ts.grid.x;
    let lo = vec2<f32>(p0) + 0.5 - 0.5 * f32(n);
    let hi = vec2<f32>(p1) + 0.5 - 0.5 * f32(n);
    let dnear = length(max(max(lo, -hi), vec2<f32>(0.0)));
    let dfar = length(max(abs(lo), abs(hi)));
    let rin = f32(b.ca[q] >> 19u) * 0.5;
    let rout = f32(b.cb[q] >> 19u) * 0.5;
    let dmin = min(min(p0.x, p0.y), min(n - 1 - p1.x, n - 1 - p1.y));
    let zone = band == 1 && dmin < reach;
    if (dnear > rout && (!zone || rout < 0.5 * f32(n) - 0.5)) { return 0.0; }
    if (dfar < rin && !zone) { return 1.0; }
    return -1.0;
}

// Share of B in block ib of level l of the labels (levels below the detail band's top: bits and coverage).
fn ts_block_b(b: ptr<function, TsBlend>, s: TsSite, l: i32, ib: vec2<i32>, q: i32) -> f32 {
    ts_quad(b, s.tile, q);
    let n = ts.grid.x;
    let sz = 1 << u32(l);
    let p0 = ib * sz;
    let known = ts_rect_known(*b, 0, p0, p0 + vec2<i32>(sz - 1), q, 1);
    if (known >= 0.0) { return known; }
    let t = s.tile;
    if (l >= 2) {
        let c = ts.grid.z;
        let side = (n / 4) >> u32(l - 2);
        let v = textureLoad(ts_coverage, vec2<i32>((t % c) * side + ib.x, (t / c) * side + ib.y), l - 2).r;
        let cells = f32(sz * sz);
        return floor(v * cells + 0.5) / cells;  // 8-bit rint(count * 255 / 4^l): the count, exactly, to l = 3
    }
    let c = ts.grid.y;
    let cell = vec2<i32>((t % c) * (n / 8), (t / c) * n);
    var sum = 0.0;
    for (var r = 0; r < sz; r++) {
        let byte = textureLoad(ts_bits, cell + vec2<i32>(p0.x / 8, p0.y + r), 0).r;
        for (var k = 0; k < sz; k++) { sum += f32((byte >> u32((p0.x + k) % 8)) & 1u); }
    }
    return sum / f32(sz * sz);
}

fn ts_level(b: ptr<function, TsBlend>, s: TsSite, l: i32, lw: f32) {
    let n = ts.grid.x;
    let nl = n >> u32(l);
    let u = s.p / exp2(f32(l)) - 0.5;
    let i0 = floor(u);
    let f = u - i0;
    let a = clamp(vec2<i32>(i0), vec2<i32>(0), vec2<i32>(nl - 1));
    let c = clamp(vec2<i32>(i0) + 1, vec2<i32>(0), vec2<i32>(nl - 1));
    for (var k = 0; k < 4; k++) {
        let w = lw * select(f.x, 1.0 - f.x, (k & 1) == 0) * select(f.y, 1.0 - f.y, k < 2);
        if (w <= 0.0) { continue; }
        let ib = vec2<i32>(select(c.x, a.x, (k & 1) == 0), select(c.y, a.y, k < 2));
        let q = select(0, 2, (ib.y << u32(l)) >= n / 2) + select(0, 1, (ib.x << u32(l)) >= n / 2);
        let cb = ts_block_b(b, s, l, ib, q);
        (*b).ha[q] += w * (1.0 - cb);
        (*b).hb += w * cb;
    }
}

fn ts_blend_cell() -> vec2<i32> {
    let n = ts.grid.x;
    let h = ts_blend_layout.y;
    if (ts_blend_layout.z < 0) { return vec2<i32>(n >> u32(h)); }
    var sum = 0;
    for (var k = ts_blend_layout.z; k <= ts_blend_layout.w; k++) { sum += n >> u32(k); }
    return vec2<i32>((n >> u32(h)) + (n >> u32(ts_blend_layout.z)), max(n >> u32(h), sum));
}

fn ts_blend_origin(band: i32, l: i32) -> vec2<i32> {
    let n = ts.grid.x;
    if (band == 0) { return vec2<i32>(0); }
    var y = 0;
    for (var k = ts_blend_layout.z; k < l; k++) { y += n >> u32(k); }
    return vec2<i32>(n >> u32(ts_blend_layout.y), y);
}

// The bilinear sample of level l of a band's coverage in ts_blend_cov: one filtered read per quadrant the taps
// fall in, none where the radii know the blocks (tilesynth_v2.glsl).
fn ts_level_f(b: ptr<function, TsBlend>, s: TsSite, band: i32, l: i32, lw: f32, reach: i32) {
    let n = ts.grid.x;
    let nl = n >> u32(l);
    let hq = nl / 2;
    let sz = 1 << u32(l);
    let u = s.p / exp2(f32(l)) - 0.5;
    let i0 = floor(u);
    let f = u - i0;
    let a = clamp(vec2<i32>(i0), vec2<i32>(0), vec2<i32>(nl - 1));
    let c = clamp(vec2<i32>(i0) + 1, vec2<i32>(0), vec2<i32>(nl - 1));
    let cutx = (a.x < hq) != (c.x < hq);
    let cuty = (a.y < hq) != (c.y < hq);
    let t = s.tile;
    let cols = ts_blend_layout.x;
    let base = vec2<f32>(vec2<i32>(t % cols, t / cols) * ts_blend_cell() + ts_blend_origin(band, l));
    let tsize = vec2<f32>(textureDimensions(ts_blend_cov, 0));
    if (cutx || cuty) {
        // taps in several quadrants whose own-quadrant taps the radii call all B: one filtered read of all four
        // taps; 1 means every tap is B (tilesynth_v2.glsl)
        let hx = s.p.x >= f32(n / 2);
        let hy = s.p.y >= f32(n / 2);
        var lo = a;
        var hi = c;
        if (cutx) { lo.x = select(a.x, c.x, hx); hi.x = lo.x; }
        if (cuty) { lo.y = select(a.y, c.y, hy); hi.y = lo.y; }
        let qo = select(0, 2, hy) + select(0, 1, hx);
        if (ts_rect_known(*b, band, lo * sz, hi * sz + vec2<i32>(sz - 1), qo, reach) == 1.0) {
            let pos = vec2<f32>(a) + 0.5 + select(vec2<f32>(0.0), f, a != c);
            if (textureSampleLevel(ts_blend_cov, ts_sampler, (base + pos) / tsize, 0.0).r >= 1.0) {
                if (band == 0) { (*b).hb += lw; } else { (*b).gb += lw; }
                return;
            }
        }
    }
    for (var g = 0; g < 4; g++) {
        let gx = g & 1;
        let gy = g >> 1u;
        if ((gx == 1 && !cutx) || (gy == 1 && !cuty)) { continue; }
        var lo = a;
        var hi = c;
        var pos = vec2<f32>(a) + 0.5 + select(vec2<f32>(0.0), f, a != c);
        var w = lw;
        if (cutx) { lo.x = select(c.x, a.x, gx == 0); hi.x = lo.x; pos.x = f32(lo.x) + 0.5; w *= select(f.x, 1.0 - f.x, gx == 0); }
        if (cuty) { lo.y = select(c.y, a.y, gy == 0); hi.y = lo.y; pos.y = f32(lo.y) + 0.5; w *= select(f.y, 1.0 - f.y, gy == 0); }
        if (w <= 0.0) { continue; }
        let q = select(0, 2, lo.y >= hq) + select(0, 1, lo.x >= hq);
        ts_quad(b, t, q);
        var cb = ts_rect_known(*b, band, lo * sz, hi * sz + vec2<i32>(sz - 1), q, reach);
        if (cb < 0.0) { cb = textureSampleLevel(ts_blend_cov, ts_sampler, (base + pos) / tsize, 0.0).r; }
        if (band == 0) { (*b).ha[q] += w * (1.0 - cb); (*b).hb += w * cb; }
        else { (*b).ga[q] += w * (1.0 - cb); (*b).gb += w * cb; }
    }
}

fn ts_band(b: ptr<function, TsBlend>, s: TsSite, band: i32, level: f32, reach: f32) {
    let n = ts.grid.x;
    let pc = s.p - 0.5;
    let d = max(min(min(pc.x, pc.y), min(f32(n - 1) - pc.x, f32(n - 1) - pc.y)), 0.0);
    var lod = min(level, log2(reach + d));
    if (abs(lod - floor(lod + 0.5)) < 1e-5) { lod = floor(lod + 0.5); }
    let l0 = floor(lod);
    let f = lod - l0;
    let l = i32(l0);
    if (band == 1 || l >= ts_blend_layout.y) { ts_level_f(b, s, band, l, 1.0 - f, i32(reach)); }
    else { ts_level(b, s, l, 1.0 - f); }
    if (f > 0.0) {
        if (band == 1 || l + 1 >= ts_blend_layout.y) { ts_level_f(b, s, band, l + 1, f, i32(reach)); }
        else { ts_level(b, s, l + 1, f); }
    }
}

fn ts_blend(s: TsSite, bands: vec4<f32>) -> TsBlend {
    var b: TsBlend;
    let h = ts.grid.x / 2;
    let q = select(0, 2, s.p.y >= f32(h)) + select(0, 1, s.p.x >= f32(h));
    b.ca[q] = s.ent.x; b.xa[q] = s.ent.y; b.cb[q] = s.ent.z; b.bb = vec2<i32>(s.ent.z & 0x7FFFF, s.ent.w);
    b.loaded = 1 << u32(q);
    let top = select(bands.x, bands.y, bands.y >= 0.0);
    if (s.lod >= top + 1.0) { return b; }
    ts_band(&b, s, 0, bands.x, 1.0);
    if (bands.y >= 0.0) { ts_band(&b, s, 1, bands.y, bands.w); }
    return b;
}

fn ts_slot(b: TsBlend, i: i32) -> vec2<i32> {
    if (i < 4) { return vec2<i32>(b.ca[i] & 0x7FFFF, b.xa[i]); }
    return b.bb;
}
fn ts_h(b: TsBlend, i: i32) -> f32 { if (i < 4) { return b.ha[i]; } return b.hb; }
fn ts_g(b: TsBlend, i: i32) -> f32 { if (i < 4) { return b.ga[i]; } return b.gb; }

fn ts_entry_low(map: texture_2d<f32>, s: TsSite, e: vec2<i32>, split: f32) -> vec4<f32> {
    let size = vec2<f32>(textureDimensions(map, 0));
    return textureSampleLevel(map, ts_sampler, ts_src(e.x, e.y, s.p) / size, max(split, s.lod));
}

fn ts_slope(c: vec4<f32>, normal: i32) -> vec2<f32> {
    let v = select(c.xyz, c.xyz * 2.0 - 1.0, normal <= 2);
    return v.xy / max(v.z, 1.0 / 16.0);
}

fn ts_blend_map(map: texture_2d<f32>, s: TsSite, b: TsBlend, bands: vec4<f32>, mean: vec4<f32>, normal: i32) -> vec4<f32> {
    let low = bands.y >= 0.0 && normal <= 0;
    for (var i = 0; i < 5; i++) {
        if (ts_h(b, i) >= 1.0 - 1e-5 && (!low || ts_g(b, i) >= 1.0 - 1e-5)) {
            let e = ts_slot(b, i);
            return ts_entry(map, s, e.x, e.y, normal);
        }
    }
    if (normal > 0) {
        var sl = vec2<f32>(0.0);
        for (var i = 0; i < 5; i++) {
            let h = ts_h(b, i);
            if (h <= 0.0) { continue; }
            let e = ts_slot(b, i);
            sl += h * ts_slope(ts_entry(map, s, e.x, e.y, normal), normal);
        }
        let v = normalize(vec3<f32>(sl, 1.0));
        return vec4<f32>(select(v, v * 0.5 + 0.5, normal <= 2), 1.0);
    }
    var base = vec4<f32>(0.0);
    var det = vec4<f32>(0.0);
    var g2 = 0.0;
    for (var i = 0; i < 5; i++) {
        let h = ts_h(b, i);
        let g = select(0.0, ts_g(b, i), low);
        if (h <= 0.0 && g <= 0.0) { continue; }
        let e = ts_slot(b, i);
        var a = vec4<f32>(0.0);
        var v = vec4<f32>(0.0);
        if (normal < 0) {  // value and low band in one fetch
            let c = ts_entry_raw(map, s, e.x, e.y);
            v = vec4<f32>(c.xxx, 1.0);
            if (low) { a = vec4<f32>(c.yyy, 1.0); }
        } else {
            if (low) { a = ts_entry_low(map, s, e, bands.z); }
            if (h > 0.0) { v = ts_entry(map, s, e.x, e.y, normal); }
        }
        if (h > 0.0) { det += h * (v - a); }
        if (g > 0.0) {
            base += g * a;
            var seen = false;
            var gs = g;
            for (var j = 0; j < 5; j++) {
                if (j == i || ts_g(b, j) <= 0.0 || any(ts_slot(b, j) != e)) { continue; }
                if (j < i) { seen = true; }
                gs += ts_g(b, j);
            }
            if (!seen) { g2 += gs * gs; }
        }
    }
    if (low) { return mean + (base - mean) / sqrt(g2) + det; }
    return det;
}

fn ts_smooth_map(map: texture_2d<f32>, s: TsSite, b: TsBlend, bands: vec4<f32>, mean: vec4<f32>, normal: i32, w0: f32) -> vec4<f32> {
    let top = select(bands.x, bands.y, bands.y >= 0.0 && normal <= 0);
    let t = clamp(s.lod - top, 0.0, 1.0);
    if (t >= 1.0) { return ts_map(map, s, w0, normal); }
    let v = ts_blend_map(map, s, b, bands, mean, normal);
    if (t <= 0.0) { return v; }
    return mix(v, ts_map(map, s, w0, normal), t);
}
