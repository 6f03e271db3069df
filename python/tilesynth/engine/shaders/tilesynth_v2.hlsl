// tilesynth_v2.hlsl: per-pixel lookup of a tilesynth export version 2 (provenance), HLSL (Shader Model 4.0+).
// Same functions, hash, conventions and fetch counts as tilesynth_v2.glsl (see its header: TsSite, ts_site,
// ts_weight, ts_map). Registers: change to fit your root signature / effect.
//   ts_bits      labels_bits.png as R8_UINT (Load only)
//   ts_coverage  labels_coverage.png + levels as R8_UNORM, sampled with ts_sampler
//   ts_table     table.bin as R32G32B32A32_SINT, width 256 (Load only)
//   ts_index     index_map mode: index.png as R16_UINT (hash mode: any 1x1 uint texture, never read)
//   ts_sampler   MIN_MAG_MIP_LINEAR, MIRROR: for the coverage (its reads stay inside a tile's cell) and every
//                map (the seam blend reads an entry past its piece, mirrored at the exemplar's edge)
//   ts_blend_cov labels_blend.png as R16_FLOAT, texel = count / 4^l, sampled with ts_sampler at level 0 (any
//                1x1 float texture without it)
//   ts_blend_layout  (columns, high_level, reach_levels[0] or -1, reach_levels[1]) of the manifest's labels.blend
// Every map: a Texture2D<float4> with its full mip chain, passed to ts_map (or, for a smooth map whose manifest
// "seam" is "blend", to ts_smooth_map: the seam blend, as in tilesynth_v2.glsl, whose header has the formula,
// the approximations, minification and fetches).
Texture2D<uint> ts_bits : register(t0);
Texture2D<float> ts_coverage : register(t1);
Texture2D<uint> ts_index : register(t2);
Texture2D<int4> ts_table : register(t3);
SamplerState ts_sampler : register(s0);
Texture2D<float> ts_blend_cov : register(t5);
cbuffer TsParams : register(b0) {
    int4 ts_layout;      // tile size N, bits columns, coverage columns, coverage max level
    int4 ts_lookup;      // mode (0 index map, 1 hash corner, 2 hash edge), K (or Kh), Kv, V
    int2 ts_wrap;        // hash period in tiles (0, 0: none)
    uint ts_seed;
    uint ts_pad;
    int4 ts_blend_layout;  // (columns, high_level, reach_levels[0] or -1, reach_levels[1]) of labels.blend
};

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
        return int(ts_index.Load(int3(ts_emod(cell.x, int(w)), ts_emod(cell.y, int(h)), 0)));
    }
    if (ts_wrap.x > 0) cell = int2(ts_emod(cell.x, ts_wrap.x), ts_emod(cell.y, ts_wrap.y));
    uint V = uint(ts_lookup.w);
    uint v = ts_lattice(cell, 3u) % V;
    if (ts_lookup.x == 1) {
        uint K = uint(ts_lookup.y);
        uint tl = ts_lattice(cell, 0u) % K;
        uint tr = ts_lattice(cell + int2(1, 0), 0u) % K;
        uint bl = ts_lattice(cell + int2(0, 1), 0u) % K;
        uint br = ts_lattice(cell + int2(1, 1), 0u) % K;
        return int((((tl * K + bl) * K + tr) * K + br) * V + v);
    }
    uint Kh = uint(ts_lookup.y), Kv = uint(ts_lookup.z);
    uint n = ts_lattice(cell, 1u) % Kh;
    uint s = ts_lattice(cell + int2(0, 1), 1u) % Kh;
    uint w = ts_lattice(cell, 2u) % Kv;
    uint e = ts_lattice(cell + int2(1, 0), 2u) % Kv;
    return int((((n * Kv + e) * Kh + s) * Kv + w) * V + v);
}

struct TsSite {
    int4 ent;     // (code_A, bx_A, code_B, bx_B), code = (radius << 19) | ((by + 32768) << 3) | symmetry
    int tile;
    float2 p;     // position in the tile in pixels (x, y)
    float2 gx, gy;
    float lod;
};

int4 ts_table_texel(int tile, float2 p) {
    float h = float(ts_layout.x / 2);
    int q = (p.y >= h ? 2 : 0) + (p.x >= h ? 1 : 0);
    int i = 4 * tile + q;
    return ts_table.Load(int3(i % 256, i / 256, 0));
}

TsSite ts_site(float2 uv, float2 duvdx, float2 duvdy) {
    TsSite s;
    float2 cellf = floor(uv);
    float n = float(ts_layout.x);
    s.tile = ts_tile_index(int2(cellf));
    s.p = (uv - cellf) * n;
    s.gx = duvdx * n;
    s.gy = duvdy * n;
    s.lod = 0.5 * log2(max(max(dot(s.gx, s.gx), dot(s.gy, s.gy)), 1e-20));
    s.ent = ts_table_texel(s.tile, s.p);
    return s;
}

bool ts_one_source(TsSite s) { return all(s.ent.xy == s.ent.zw); }

// The radii of the sample's quadrant (pixels from the tile's centre): see tilesynth_v2.glsl.
float ts_r_in(TsSite s) { return float(s.ent.x >> 19) * 0.5; }
float ts_r_out(TsSite s) { return float(s.ent.z >> 19) * 0.5; }

// The label bit of the pixel under the sample (1: entry B): one fetch inside the label band, none outside it.
float ts_bit(TsSite s) {
    int n = ts_layout.x;
    int2 ip = clamp(int2(floor(s.p)), int2(0, 0), int2(n - 1, n - 1));
    float d = length(float2(ip) + 0.5 - 0.5 * float(n));
    if (d < ts_r_in(s)) return 1.0;
    if (d > ts_r_out(s)) return 0.0;
    int c = ts_layout.y;
    int2 cell = int2((s.tile % c) * (n / 8), (s.tile / c) * n);
    uint byte = ts_bits.Load(int3(cell + int2(ip.x / 8, ip.y), 0));
    return float((byte >> uint(ip.x % 8)) & 1u);
}

// Weight of entry B at level max(footprint, blend_level): see tilesynth_v2.glsl.
float ts_weight(TsSite s, float blend_level) {
    if (ts_one_source(s)) return 0.0;
    float lw = max(s.lod, blend_level);
    if (lw < 1.0) return ts_bit(s);
    int n = ts_layout.x;
    float lc = clamp(lw - 2.0, 0.0, float(ts_layout.w));
    float d = length(s.p - 0.5 * float(n));
    float reach = 2.2 * exp2(ceil(lc) + 2.0);
    float w;
    if (d + reach < ts_r_in(s)) {
        w = 1.0;
    } else if (d - reach > ts_r_out(s)) {
        w = 0.0;
    } else {
        float side = float(n / 4);
        float half_texel = 0.5 * exp2(ceil(lc));
        float2 q = clamp(s.p * 0.25, min(half_texel, 0.5 * side).xx, max(side - half_texel, 0.5 * side).xx);
        int c = ts_layout.z;
        float2 pos = float2(float(s.tile % c), float(s.tile / c)) * side + q;
        uint cw, ch, cl;
        ts_coverage.GetDimensions(0, cw, ch, cl);
        w = ts_coverage.SampleLevel(ts_sampler, pos / float2(cw, ch), lc);
    }
    float2 e = min(s.p, float(n).xx - s.p);
    w *= clamp(min(e.x, e.y) / min(exp2(lw), float(n) / 16.0), 0.0, 1.0);
    if (blend_level > s.lod) w = max(ts_bit(s), min(1.0, 2.0 * w));
    return w;
}

float2 ts_src(int code, int bx, float2 p) {
    int sym = code & 7;
    float n = float(ts_layout.x);
    float y = p.y, x = p.x;
    if (sym >= 4) x = n - x;
    int k = sym & 3;
    float2 rc = k == 0 ? float2(y, x) : k == 1 ? float2(x, n - y) : k == 2 ? float2(n - y, n - x) : float2(n - x, y);
    return float2(rc.y + float(bx), rc.x + float(((code >> 3) & 0xFFFF) - 32768));
}

float2 ts_turn(int code, float2 g) {
    int sym = code & 7;
    float y = g.y, x = g.x;
    if (sym >= 4) x = -x;
    int k = sym & 3;
    float2 rc = k == 0 ? float2(y, x) : k == 1 ? float2(x, -y) : k == 2 ? float2(-y, -x) : float2(-x, y);
    return rc.yx;
}

// normal: 0 no turn, 1 / 2 unsigned codes +y / -y, 3 / 4 signed vectors +y / -y; -1 a one-channel scalar map
// bound with its low band in .g: the value, grey.
float4 ts_turn_normal(float4 c, int code, int normal) {
    if (normal < 0) return float4(c.rrr, 1.0);
    int sym = code & 7;
    if (normal == 0 || sym == 0) return c;
    float2 v = normal <= 2 ? c.xy * 2.0 - 1.0 : c.xy;
    bool down = normal == 2 || normal == 4;
    if (down) v.y = -v.y;
    for (int i = 0; i < (sym & 3); i++) v = float2(-v.y, v.x);
    if (sym >= 4) v.x = -v.x;
    if (down) v.y = -v.y;
    c.xy = normal <= 2 ? v * 0.5 + 0.5 : v;
    return c;
}

// The texel of an entry as stored (no turn of a normal).
float4 ts_entry_raw(Texture2D<float4> map, TsSite s, int code, int bx) {
    uint w, h, levels;
    map.GetDimensions(0, w, h, levels);
    float2 size = float2(w, h);
    float2 src = ts_src(code, bx, s.p);
    return map.SampleGrad(ts_sampler, src / size, ts_turn(code, s.gx) / size, ts_turn(code, s.gy) / size);
}

float4 ts_entry(Texture2D<float4> map, TsSite s, int code, int bx, int normal) {
    return ts_turn_normal(ts_entry_raw(map, s, code, bx), code, normal);
}

float4 ts_map(Texture2D<float4> map, TsSite s, float w, int normal) {
    if (w <= 0.0 || ts_one_source(s)) return ts_entry(map, s, s.ent.x, s.ent.y, normal);
    if (w >= 1.0) return ts_entry(map, s, s.ent.z, s.ent.w, normal);
    return lerp(ts_entry(map, s, s.ent.x, s.ent.y, normal), ts_entry(map, s, s.ent.z, s.ent.w, normal), w);
}

float4 ts_fetch_map(Texture2D<float4> map, int2 p, int normal) {
    int n = ts_layout.x;
    int2 cell = int2(ts_floordiv(p.x, n), ts_floordiv(p.y, n));
    int tile = ts_tile_index(cell);
    int2 l = p - cell * n;
    int4 ent = ts_table_texel(tile, float2(l) + 0.5);
    int c = ts_layout.y;
    uint byte = ts_bits.Load(int3((tile % c) * (n / 8) + l.x / 8, (tile / c) * n + l.y, 0));
    bool b = ((byte >> uint(l.x % 8)) & 1u) == 1u;
    int code = b ? ent.z : ent.x, bx = b ? ent.w : ent.y;
    int sym = code & 7, m = n - 1, y = l.y, x = l.x;
    if (sym >= 4) x = m - x;
    int k = sym & 3;
    int2 rc = k == 0 ? int2(y, x) : k == 1 ? int2(x, m - y) : k == 2 ? int2(m - y, m - x) : int2(m - x, y);
    float4 v = map.Load(int3(rc.y + bx, rc.x + ((code >> 3) & 0xFFFF) - 32768, 0));
    return ts_turn_normal(v, code, normal);
}

float4 ts_sample_map(Texture2D<float4> map, float2 uv, float blend_level, int normal) {
    TsSite s = ts_site(uv, ddx(uv), ddy(uv));
    return ts_map(map, s, ts_weight(s, blend_level), normal);
}

// ------------------------------------------------------------------------------------------ the seam blend
// The weights of the entries of a tile near a pixel: A_0..A_3 (each quadrant's own) and B (the matching patch).
struct TsBlend {
    int4 ca, xa, cb;    // per quadrant: code_A (with r_in), bx_A, code_B (with r_out), from the table
    int2 bb;            // (code, bx) of B
    int loaded;         // bit q: quadrant q's table texel read
    float4 ha; float hb;  // detail-band weights of A_0..A_3 and B
    float4 ga; float gb;  // low-band weights
};

void ts_quad(inout TsBlend b, int tile, int q) {
    if (((b.loaded >> q) & 1) != 0) return;
    int i = 4 * tile + q;
    int4 e = ts_table.Load(int3(i % 256, i / 256, 0));
    b.ca[q] = e.x; b.xa[q] = e.y; b.cb[q] = e.z; b.bb = int2(e.z & 0x7FFFF, e.w);
    b.loaded |= 1 << q;
}

// The radii's verdict on the pixels [p0, p1] of quadrant q (band 1: of the labels extended reach px): 0 all A,
// 1 all B, -1 unknown.
float ts_rect_known(TsBlend b, int band, int2 p0, int2 p1, int q, int reach) {
    int n = ts_layout.x;
    float2 lo = float2(p0) + 0.5 - 0.5 * float(n), hi = float2(p1) + 0.5 - 0.5 * float(n);
    float dnear = length(max(max(lo, -hi), float2(0.0, 0.0)));
    float dfar = length(max(abs(lo), abs(hi)));
    float rin = float(b.ca[q] >> 19) * 0.5, rout = float(b.cb[q] >> 19) * 0.5;
    int dmin = min(min(p0.x, p0.y), min(n - 1 - p1.x, n - 1 - p1.y));
    bool zone = band == 1 && dmin < reach;
    if (dnear > rout && (!zone || rout < 0.5 * float(n) - 0.5)) return 0.0;
    if (dfar < rin && !zone) return 1.0;
    return -1.0;
}

// Share of B in block ib of level l of the labels (levels below the detail band's top: bits and coverage).
float ts_block_b(inout TsBlend b, TsSite s, int l, int2 ib, int q) {
    ts_quad(b, s.tile, q);
    int n = ts_layout.x, sz = 1 << l;
    int2 p0 = ib * sz;
    float known = ts_rect_known(b, 0, p0, p0 + sz - 1, q, 1);
    if (known >= 0.0) return known;
    int t = s.tile;
    if (l >= 2) {
        int c = ts_layout.z, side = (n / 4) >> (l - 2);
        float v = ts_coverage.Load(int3((t % c) * side + ib.x, (t / c) * side + ib.y, l - 2));
        float cells = float(sz * sz);
        return floor(v * cells + 0.5) / cells;  // 8-bit rint(count * 255 / 4^l): the count, exactly, to l = 3
    }
    int c = ts_layout.y;
    int2 cell = int2((t % c) * (n / 8), (t / c) * n);
    float sum = 0.0;
    for (int r = 0; r < sz; r++) {
        uint bits8 = ts_bits.Load(int3(cell + int2(p0.x / 8, p0.y + r), 0));
        for (int k = 0; k < sz; k++) sum += float((bits8 >> uint((p0.x + k) % 8)) & 1u);
    }
    return sum / float(sz * sz);
}

void ts_level(inout TsBlend b, TsSite s, int l, float lw) {
    int n = ts_layout.x, nl = n >> l;
    float2 u = s.p / exp2(float(l)) - 0.5;
    float2 i0 = floor(u), f = u - i0;
    int2 a = clamp(int2(i0), int2(0, 0), int2(nl - 1, nl - 1));
    int2 c = clamp(int2(i0) + 1, int2(0, 0), int2(nl - 1, nl - 1));
    for (int k = 0; k < 4; k++) {
        float w = lw * ((k & 1) == 0 ? 1.0 - f.x : f.x) * (k < 2 ? 1.0 - f.y : f.y);
        if (w <= 0.0) continue;
        int2 ib = int2((k & 1) == 0 ? a.x : c.x, k < 2 ? a.y : c.y);
        int q = ((ib.y << l) >= n / 2 ? 2 : 0) + ((ib.x << l) >= n / 2 ? 1 : 0);
        float cb = ts_block_b(b, s, l, ib, q);
        b.ha[q] += w * (1.0 - cb); b.hb += w * cb;
    }
}

int2 ts_blend_cell() {
    int n = ts_layout.x, h = ts_blend_layout.y;
    if (ts_blend_layout.z < 0) return int2(n >> h, n >> h);
    int sum = 0;
    for (int k = ts_blend_layout.z; k <= ts_blend_layout.w; k++) sum += n >> k;
    return int2((n >> h) + (n >> ts_blend_layout.z), max(n >> h, sum));
}

int2 ts_blend_origin(int band, int l) {
    int n = ts_layout.x;
    if (band == 0) return int2(0, 0);
    int y = 0;
    for (int k = ts_blend_layout.z; k < l; k++) y += n >> k;
    return int2(n >> ts_blend_layout.y, y);
}

// The bilinear sample of level l of a band's coverage in ts_blend_cov: one filtered read per quadrant the taps
// fall in, none where the radii know the blocks (tilesynth_v2.glsl).
void ts_level_f(inout TsBlend b, TsSite s, int band, int l, float lw, int reach) {
    int n = ts_layout.x, nl = n >> l, hq = nl / 2, sz = 1 << l;
    float2 u = s.p / exp2(float(l)) - 0.5;
    float2 i0 = floor(u), f = u - i0;
    int2 a = clamp(int2(i0), int2(0, 0), int2(nl - 1, nl - 1));
    int2 c = clamp(int2(i0) + 1, int2(0, 0), int2(nl - 1, nl - 1));
    bool cutx = (a.x < hq) != (c.x < hq), cuty = (a.y < hq) != (c.y < hq);
    int t = s.tile, cols = ts_blend_layout.x;
    float2 base = float2(int2(t % cols, t / cols) * ts_blend_cell() + ts_blend_origin(band, l));
    uint tw, th;
    ts_blend_cov.GetDimensions(tw, th);
    if (cutx || cuty) {
        // taps in several quadrants whose own-quadrant taps the radii call all B: one filtered read of all four
        // taps; 1 means every tap is B (tilesynth_v2.glsl)
        bool hx = s.p.x >= float(n / 2), hy = s.p.y >= float(n / 2);
        int2 lo = a, hi = c;
        if (cutx) { lo.x = hx ? c.x : a.x; hi.x = lo.x; }
        if (cuty) { lo.y = hy ? c.y : a.y; hi.y = lo.y; }
        int qo = (hy ? 2 : 0) + (hx ? 1 : 0);
        if (ts_rect_known(b, band, lo * sz, hi * sz + sz - 1, qo, reach) == 1.0) {
            float2 pos = float2(a) + 0.5 + float2(a != c) * f;
            if (ts_blend_cov.SampleLevel(ts_sampler, (base + pos) / float2(tw, th), 0.0) >= 1.0) {
                if (band == 0) b.hb += lw; else b.gb += lw;
                return;
            }
        }
    }
    for (int g = 0; g < 4; g++) {
        int gx = g & 1, gy = g >> 1;
        if ((gx == 1 && !cutx) || (gy == 1 && !cuty)) continue;
        int2 lo = a, hi = c;
        float2 pos = float2(a) + 0.5 + float2(a != c) * f;
        float w = lw;
        if (cutx) { lo.x = gx == 0 ? a.x : c.x; hi.x = lo.x; pos.x = float(lo.x) + 0.5; w *= gx == 0 ? 1.0 - f.x : f.x; }
        if (cuty) { lo.y = gy == 0 ? a.y : c.y; hi.y = lo.y; pos.y = float(lo.y) + 0.5; w *= gy == 0 ? 1.0 - f.y : f.y; }
        if (w <= 0.0) continue;
        int q = (lo.y >= hq ? 2 : 0) + (lo.x >= hq ? 1 : 0);
        ts_quad(b, t, q);
        float cb = ts_rect_known(b, band, lo * sz, hi * sz + sz - 1, q, reach);
        if (cb < 0.0) cb = ts_blend_cov.SampleLevel(ts_sampler, (base + pos) / float2(tw, th), 0.0);
        if (band == 0) { b.ha[q] += w * (1.0 - cb); b.hb += w * cb; }
        else { b.ga[q] += w * (1.0 - cb); b.gb += w * cb; }
    }
}

void ts_band(inout TsBlend b, TsSite s, int band, float level, float reach) {
    int n = ts_layout.x;
    float2 pc = s.p - 0.5;
    float d = max(min(min(pc.x, pc.y), min(float(n - 1) - pc.x, float(n - 1) - pc.y)), 0.0);
    float lod = min(level, log2(reach + d));
    if (abs(lod - floor(lod + 0.5)) < 1e-5) lod = floor(lod + 0.5);
    float l0 = floor(lod), f = lod - l0;
    int l = int(l0);
    if (band == 1 || l >= ts_blend_layout.y) ts_level_f(b, s, band, l, 1.0 - f, int(reach));
    else ts_level(b, s, l, 1.0 - f);
    if (f > 0.0) {
        if (band == 1 || l + 1 >= ts_blend_layout.y) ts_level_f(b, s, band, l + 1, f, int(reach));
        else ts_level(b, s, l + 1, f);
    }
}

TsBlend ts_blend(TsSite s, float4 bands) {
    TsBlend b;
    b.ca = int4(0, 0, 0, 0); b.xa = int4(0, 0, 0, 0); b.cb = int4(0, 0, 0, 0);
    b.ha = float4(0.0, 0.0, 0.0, 0.0); b.hb = 0.0; b.ga = float4(0.0, 0.0, 0.0, 0.0); b.gb = 0.0;
    int h = ts_layout.x / 2;
    int q = (s.p.y >= float(h) ? 2 : 0) + (s.p.x >= float(h) ? 1 : 0);
    b.ca[q] = s.ent.x; b.xa[q] = s.ent.y; b.cb[q] = s.ent.z; b.bb = int2(s.ent.z & 0x7FFFF, s.ent.w);
    b.loaded = 1 << q;
    float top = bands.y >= 0.0 ? bands.y : bands.x;
    if (s.lod >= top + 1.0) return b;
    ts_band(b, s, 0, bands.x, 1.0);
    if (bands.y >= 0.0) ts_band(b, s, 1, bands.y, bands.w);
    return b;
}

int2 ts_slot(TsBlend b, int i) { return i < 4 ? int2(b.ca[i] & 0x7FFFF, b.xa[i]) : b.bb; }
float ts_h(TsBlend b, int i) { return i < 4 ? b.ha[i] : b.hb; }
float ts_g(TsBlend b, int i) { return i < 4 ? b.ga[i] : b.gb; }

float4 ts_entry_low(Texture2D<float4> map, TsSite s, int2 e, float split) {
    uint w, h, levels;
    map.GetDimensions(0, w, h, levels);
    return map.SampleLevel(ts_sampler, ts_src(e.x, e.y, s.p) / float2(w, h), max(split, s.lod));
}

float2 ts_slope(float4 c, int normal) {
    float3 v = normal <= 2 ? c.xyz * 2.0 - 1.0 : c.xyz;
    return v.xy / max(v.z, 1.0 / 16.0);
}

float4 ts_blend_map(Texture2D<float4> map, TsSite s, TsBlend b, float4 bands, float4 mean, int normal) {
    bool low = bands.y >= 0.0 && normal <= 0;
    for (int i0 = 0; i0 < 5; i0++) {
        if (ts_h(b, i0) >= 1.0 - 1e-5 && (!low || ts_g(b, i0) >= 1.0 - 1e-5)) {
            int2 e = ts_slot(b, i0);
            return ts_entry(map, s, e.x, e.y, normal);
        }
    }
    if (normal > 0) {
        float2 sl = float2(0.0, 0.0);
        for (int i1 = 0; i1 < 5; i1++) {
            float h = ts_h(b, i1);
            if (h <= 0.0) continue;
            int2 e = ts_slot(b, i1);
            sl += h * ts_slope(ts_entry(map, s, e.x, e.y, normal), normal);
        }
        float3 v = normalize(float3(sl, 1.0));
        return float4(normal <= 2 ? v * 0.5 + 0.5 : v, 1.0);
    }
    float4 base = float4(0.0, 0.0, 0.0, 0.0), det = float4(0.0, 0.0, 0.0, 0.0);
    float g2 = 0.0;
    for (int i = 0; i < 5; i++) {
        float h = ts_h(b, i), g = low ? ts_g(b, i) : 0.0;
        if (h <= 0.0 && g <= 0.0) continue;
        int2 e = ts_slot(b, i);
        float4 a = float4(0.0, 0.0, 0.0, 0.0), v = float4(0.0, 0.0, 0.0, 0.0);
        if (normal < 0) {  // value and low band in one fetch
            float4 c = ts_entry_raw(map, s, e.x, e.y);
            v = float4(c.rrr, 1.0);
            if (low) a = float4(c.ggg, 1.0);
        } else {
            if (low) a = ts_entry_low(map, s, e, bands.z);
            if (h > 0.0) v = ts_entry(map, s, e.x, e.y, normal);
        }
        if (h > 0.0) det += h * (v - a);
        if (g > 0.0) {
            base += g * a;
            bool seen = false;
            float gs = g;
            for (int j = 0; j < 5; j++) {
                if (j == i || ts_g(b, j) <= 0.0 || any(ts_slot(b, j) != e)) continue;
                if (j < i) seen = true;
                gs += ts_g(b, j);
            }
            if (!seen) g2 += gs * gs;
        }
    }
    return low ? mean + (base - mean) / sqrt(g2) + det : det;
}

float4 ts_smooth_map(Texture2D<float4> map, TsSite s, TsBlend b, float4 bands, float4 mean, int normal, float w0) {
    float top = bands.y >= 0.0 && normal <= 0 ? bands.y : bands.x;
    float t = clamp(s.lod - top, 0.0, 1.0);
    if (t >= 1.0) return ts_map(map, s, w0, normal);
    float4 v = ts_blend_map(map, s, b, bands, mean, normal);
    return t <= 0.0 ? v : lerp(v, ts_map(map, s, w0, normal), t);
}
