// tilesynth.hlsl: per-pixel lookup of a tilesynth export (manifest.json "format" "tilesynth-export" v1), HLSL
// (Shader Model 4.0+). Same functions, same hash (pcg3d, bit for bit) and same conventions as tilesynth.glsl.
// Registers: change to fit your root signature / effect.
//   ts_atlas   the atlas of one map, levels 0..max_level; ts_sampler: MIN_MAG_MIP_LINEAR, CLAMP
//   ts_index   index_map mode: index.png as an R16_UINT texture (hash mode: any 1x1 uint texture, never read)
Texture2D<float4> ts_atlas : register(t0);
Texture2D<uint> ts_index : register(t1);
SamplerState ts_sampler : register(s0);
cbuffer TsParams : register(b0) {
    int4 ts_layout;      // tile size N, padding P, atlas columns, max_level
    int4 ts_lookup;      // mode (0 index map, 1 hash corner, 2 hash edge), K (or Kh), Kv, V
    int2 ts_wrap;        // hash period in tiles (0, 0: none)
    uint ts_seed;
    uint ts_pad;
    float2 ts_atlas_size; // level-0 atlas size in texels
};

// uint arithmetic wraps mod 2^32.
uint3 ts_pcg3d(uint3 v) {
    v = v * 1664525u + 1013904223u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    v ^= v >> 16u;
    v.x += v.y * v.z; v.y += v.z * v.x; v.z += v.x * v.y;
    return v;
}

uint ts_hash(int x, int y, uint seed, uint role) {
    return ts_pcg3d(uint3(asuint(x), asuint(y), seed ^ (role * 0x9E3779B9u))).x;
}

// Floor division / Euclidean modulo for b > 0, dividing non-negative operands only; ~a = -a - 1 never overflows.
int ts_floordiv(int a, int b) { return a >= 0 ? a / b : -1 - (~a) / b; }
int ts_emod(int a, int b) { return a - b * ts_floordiv(a, b); }

uint ts_lattice(int2 v, uint role) {
    if (ts_wrap.x > 0) v = int2(ts_emod(v.x, ts_wrap.x), ts_emod(v.y, ts_wrap.y));
    return ts_hash(v.x, v.y, ts_seed, role);
}

int ts_tile_index(int2 cell) {
    if (ts_lookup.x == 0) {
        uint w, h;
        ts_index.GetDimensions(w, h);
        return (int)ts_index.Load(int3(ts_emod(cell.x, (int)w), ts_emod(cell.y, (int)h), 0));
    }
    // wrap the cell first, so cell + 1 never overflows and (cx + 1) mod Tx is exact for every int32 cx
    if (ts_wrap.x > 0) cell = int2(ts_emod(cell.x, ts_wrap.x), ts_emod(cell.y, ts_wrap.y));
    uint V = (uint)ts_lookup.w;
    uint v = ts_lattice(cell, 3u) % V;
    if (ts_lookup.x == 1) {
        uint K = (uint)ts_lookup.y;
        uint tl = ts_lattice(cell, 0u) % K;
        uint tr = ts_lattice(cell + int2(1, 0), 0u) % K;
        uint bl = ts_lattice(cell + int2(0, 1), 0u) % K;
        uint br = ts_lattice(cell + int2(1, 1), 0u) % K;
        return (int)((((tl * K + bl) * K + tr) * K + br) * V + v);
    }
    uint Kh = (uint)ts_lookup.y, Kv = (uint)ts_lookup.z;
    uint n = ts_lattice(cell, 1u) % Kh;
    uint s = ts_lattice(cell + int2(0, 1), 1u) % Kh;
    uint w2 = ts_lattice(cell, 2u) % Kv;
    uint e = ts_lattice(cell + int2(1, 0), 2u) % Kv;
    return (int)((((n * Kv + e) * Kh + s) * Kv + w2) * V + v);
}

int2 ts_tile_origin(int t) {
    int s = ts_layout.x + 2 * ts_layout.y;
    return int2((t % ts_layout.z) * s, (t / ts_layout.z) * s) + ts_layout.y;
}

// The exact texel (x, y) of the infinite texture.
float4 ts_fetch(int2 p) {
    int n = ts_layout.x;
    int2 cell = int2(ts_floordiv(p.x, n), ts_floordiv(p.y, n));
    return ts_atlas.Load(int3(ts_tile_origin(ts_tile_index(cell)) + (p - cell * n), 0));
}

// Filtered sample at uv (tile units) with the gradients of the continuous uv; footprint clamped to max_level.
float4 ts_sample_grad(float2 uv, float2 duvdx, float2 duvdy) {
    float2 cellf = floor(uv);
    float n = (float)ts_layout.x;
    float2 texel = (float2)ts_tile_origin(ts_tile_index((int2)cellf)) + (uv - cellf) * n;
    float2 gx = duvdx * n, gy = duvdy * n;
    float m = max(dot(gx, gx), dot(gy, gy));
    float lim = exp2(2.0 * (float)ts_layout.w);
    if (m > lim) {
        float k = sqrt(lim / m);
        gx *= k;
        gy *= k;
    }
    return ts_atlas.SampleGrad(ts_sampler, texel / ts_atlas_size, gx / ts_atlas_size, gy / ts_atlas_size);
}

float4 ts_sample(float2 uv) { return ts_sample_grad(uv, ddx(uv), ddy(uv)); }
