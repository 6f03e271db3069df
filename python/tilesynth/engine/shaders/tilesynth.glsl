// tilesynth.glsl: per-pixel lookup of a tilesynth export (manifest.json "format"
// "tilesynth-export" version 1). GLSL ES 3.00 (WebGL2) and desktop GLSL 4.00+; no #version line: prepend
//   "#version 300 es\nprecision highp float;\nprecision highp int;\n"   or   "#version 400\n".
//
// Coordinates: uv is the continuous (unwrapped) texture coordinate in TILE units: pixel (x, y) of the infinite
// texture (x right, y down, as in the PNGs) covers uv in [x/N, (x+1)/N) x [y/N, (y+1)/N). Cell (cx, cy) =
// floor(uv). Far from the origin a float uv loses sub-texel precision (about 2^-24 * |uv| tiles): re-centre uv by
// whole periods (index-map mode: the index map's size; hash mode with wrap: the wrap period) when it gets large.
//
// Uniforms (all from manifest.json):
//   ts_atlas       the atlas of one map, levels 0..max_level (the exported level PNGs), LINEAR_MIPMAP_LINEAR,
//                  CLAMP_TO_EDGE; the shader never reads beyond a tile's padded cell.
//   ts_index       index_map mode: index.png as an R16UI texture (NEAREST; read with texelFetch, wrapped here).
//                  Hash mode: bind any unsigned-integer texture on its own unit (WebGL2 wants distinct units
//                  for samplers of different types) - it is never read.
//   ts_layout      (tile_size N, padding P, atlas columns, max_level)
//   ts_atlas_size  level-0 atlas size in texels (width, height)
//   ts_lookup      (mode, K, Kv, V): mode 0 = index map; 1 = hash, complete corner set (K colours, Kv unused);
//                  2 = hash, complete edge set (K = Kh horizontal-edge colours, Kv vertical); V variants.
//   ts_seed        hash seed (uint), ts_wrap  hash-mode period in tiles (0, 0 = infinite, non-periodic).
uniform highp sampler2D ts_atlas;
uniform highp usampler2D ts_index;
uniform ivec4 ts_layout;
uniform vec2 ts_atlas_size;
uniform ivec4 ts_lookup;
uniform uint ts_seed;
uniform ivec2 ts_wrap;

// pcg3d of Jarzynski & Olano (JCGT 9(3), 2020); unsigned arithmetic wraps mod 2^32 (GLSL ES 3.00 4.1.3).
uvec3 ts_pcg3d(uvec3 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    return v;
}

// uint(int) keeps the bits (two's complement), as the Rust/Python reference.
uint ts_hash(int x, int y, uint seed, uint role) {
    return ts_pcg3d(uvec3(uint(x), uint(y), seed ^ (role * 0x9E3779B9u))).x;
}

// Floor division and Euclidean modulo for b > 0, dividing non-negative operands only (GLSL leaves / and % of
// negative operands implementation-defined or undefined). ~a = -a - 1 never overflows.
int ts_floordiv(int a, int b) { return a >= 0 ? a / b : -1 - (~a) / b; }
int ts_emod(int a, int b) { return a - b * ts_floordiv(a, b); }

uint ts_lattice(ivec2 v, uint role) {
    if (ts_wrap.x > 0) v = ivec2(ts_emod(v.x, ts_wrap.x), ts_emod(v.y, ts_wrap.y));
    return ts_hash(v.x, v.y, ts_seed, role);
}

// Tile index of a cell (any ivec2, negative included).
int ts_tile_index(ivec2 cell) {
    if (ts_lookup.x == 0) {
        ivec2 sz = textureSize(ts_index, 0);
        return int(texelFetch(ts_index, ivec2(ts_emod(cell.x, sz.x), ts_emod(cell.y, sz.y)), 0).r);
    }
    // wrap the cell first, so cell + 1 never overflows and (cx + 1) mod Tx is exact for every int32 cx
    if (ts_wrap.x > 0) cell = ivec2(ts_emod(cell.x, ts_wrap.x), ts_emod(cell.y, ts_wrap.y));
    uint V = uint(ts_lookup.w);
    uint v = ts_lattice(cell, 3u) % V;
    if (ts_lookup.x == 1) {
        uint K = uint(ts_lookup.y);
        uint tl = ts_lattice(cell, 0u) % K;
        uint tr = ts_lattice(cell + ivec2(1, 0), 0u) % K;
        uint bl = ts_lattice(cell + ivec2(0, 1), 0u) % K;
        uint br = ts_lattice(cell + ivec2(1, 1), 0u) % K;
        return int((((tl * K + bl) * K + tr) * K + br) * V + v);
    }
    uint Kh = uint(ts_lookup.y), Kv = uint(ts_lookup.z);
    uint n = ts_lattice(cell, 1u) % Kh;
    uint s = ts_lattice(cell + ivec2(0, 1), 1u) % Kh;
    uint w = ts_lattice(cell, 2u) % Kv;
    uint e = ts_lattice(cell + ivec2(1, 0), 2u) % Kv;
    return int((((n * Kv + e) * Kh + s) * Kv + w) * V + v);
}

// Level-0 atlas texel of the top-left interior pixel of tile t.
ivec2 ts_tile_origin(int t) {
    int s = ts_layout.x + 2 * ts_layout.y;
    return ivec2((t % ts_layout.z) * s, (t / ts_layout.z) * s) + ts_layout.y;
}

// The exact texel (x, y) of the infinite texture (no filtering): one index lookup and one texelFetch.
vec4 ts_fetch(ivec2 p) {
    int n = ts_layout.x;
    ivec2 cell = ivec2(ts_floordiv(p.x, n), ts_floordiv(p.y, n));
    return texelFetch(ts_atlas, ts_tile_origin(ts_tile_index(cell)) + (p - cell * n), 0);
}

// Filtered sample at uv with the gradients of the continuous uv (so no mip seam at tile borders). The footprint
// is shrunk to at most max_level (beyond it the gutter no longer covers the filter), whatever the texture's
// own level range.
vec4 ts_sample_grad(vec2 uv, vec2 duvdx, vec2 duvdy) {
    vec2 cellf = floor(uv);
    float n = float(ts_layout.x);
    vec2 texel = vec2(ts_tile_origin(ts_tile_index(ivec2(cellf)))) + (uv - cellf) * n;
    vec2 gx = duvdx * n, gy = duvdy * n;
    float m = max(dot(gx, gx), dot(gy, gy));
    float lim = exp2(2.0 * float(ts_layout.w));
    if (m > lim) {
        float k = sqrt(lim / m);
        gx *= k;
        gy *= k;
    }
    return textureGrad(ts_atlas, texel / ts_atlas_size, gx / ts_atlas_size, gy / ts_atlas_size);
}

vec4 ts_sample(vec2 uv) { return ts_sample_grad(uv, dFdx(uv), dFdy(uv)); }
