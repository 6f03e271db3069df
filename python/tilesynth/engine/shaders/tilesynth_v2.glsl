// tilesynth_v2.glsl: per-pixel lookup of a tilesynth export version 2 (manifest.json "format"
// "tilesynth-export", "format_version" 2: the exemplar maps with full mips, one-bit labels, their coverage and a
// per-tile source table). GLSL ES 3.00 (WebGL2) and desktop GLSL 4.00+; no #version line: prepend
//   "#version 300 es\nprecision highp float;\nprecision highp int;\n"   or   "#version 400\n".
//
// Coordinates: uv is the continuous (unwrapped) texture coordinate in TILE units: pixel (x, y) of the infinite
// texture (x right, y down, as in the PNGs) covers uv in [x/N, (x+1)/N) x [y/N, (y+1)/N). Re-centre uv by whole
// periods when it gets large (float precision), as in version 1.
//
// Use (M maps, each with its own blend level L_map from the manifest, "blend_level"):
//   TsSite s = ts_site(uv, dFdx(uv), dFdy(uv));   // cell, tile, quadrant, footprint, table: 1 texelFetch
//   float w0 = ts_weight(s, 0.0);                 // label (bit or coverage) at level max(footprint, 0): 1 fetch
//   vec4 albedo = ts_map(albedo_tex, s, w0, 0);   // 1 textureGrad, 2 where the footprint straddles a cut
//   float w3 = ts_weight(s, 3.0);                 // another blend level: 1 more fetch (share it between maps)
//   vec4 height = ts_map(height_tex, s, w3, 0);
//   vec4 normal = ts_map(normal_tex, s, w3, 1);   // 1: unsigned +y normal codes turned with their patch
// Texture fetches per pixel: 1 (table) + M maps where no filter reaches the quadrant's label band (ts_r_in ..
// ts_r_out); in it one more per distinct blend level (two for a blend level above the footprint near the cut),
// and 2 per map where 0 < weight < 1.
//
// Smooth maps (manifest "seam": "blend": height, roughness, normals) use the seam blend of the CPU synthesis
// (tilesynth.synth.seams, steps 1-6; its "bands" and "mean" per map in the manifest) instead of the cut:
//   TsBlend b = ts_blend(s, bands);                     // weights; shared by the maps with the same bands
//   vec4 height = ts_smooth_map(height_tex, s, b, bands, mean, 0, w0);
//   vec4 normal = ts_smooth_map(normal_tex, s, b, nbands, vec4(0.0), 1, w0);
// bands = (high, low, split, reach) ("low" < 0 for a normal map or a map without a low band), mean = the map's
// "mean" per channel (1 for the alpha of maps with fewer channels), w0 = ts_weight(s, 0.0) (the footprint path).
// A one-channel scalar map with a "low_band" in the manifest: bind level l of the map and level l of its low band
// as one two-channel texture (R value, G low band) and pass normal = -1 (one fetch per entry serves both; the
// result is the value, grey); without it normal = 0 and the low band comes from the map's own mips.
// The entries of a tile on the GPU are the quadrant form: A_0..A_3 and B. The weights are exact: the detail
// band's label coverage at its top level (3) and the low band's (the labels extended "reach" px from the tile
// border) from ts_blend_cov (exact shares, one bilinear fetch per quadrant the sample's taps fall in: the
// blocks of every level lie in one quadrant; the position clamped to the tile's texel centres, as the CPU
// clamps its indices), the detail band's levels 0-1 from the bits and 2 from the coverage texture (its 8-bit
// values hold the exact counts there; a texelFetch per tap: these are the 6-px border ring only); a read is
// skipped where the quadrant's radii say its blocks are all A or all B (and where the taps straddle a quadrant
// line but the own quadrant's are all B, one filtered read of all four taps first: 1, no other table texel).
// The values: each entry of non-zero weight at the pixel, at level 0 (textureGrad with the footprint's
// derivatives, so bilinear under magnification), and for a low band channel G of the same
// texel (normal = -1: the CPU's low band at every pixel, stored beside the map) or the map's own mip at level
// "split" (textureLod, MIRRORED_REPEAT: the box mip when the map's sides are multiples of 2^split).
// Approximations: float32 arithmetic (the CPU: float64), the low band stored in the map's sample type (8-bit
// maps: within half a code); from the map's mips only: sides not multiples of 2^split (the chain drops the odd
// row; the CPU's box mip averages a partial block: 124 px, split 3, up to 3 codes). Measured against
// synthesize_maps at 1:1 (tests/test_export_v2_browser.py): at most 1 code of 255.
// Minification: the blend reads every entry with the footprint's filter (textureGrad; the low band beside the
// map at the footprint's level of its chain, from the map's mips at level max(split, footprint)); above the
// band's top level (low for scalar maps, high for normals) it fades into the footprint path (ts_map with w0)
// over one level, and from one level above it is that path alone.
// Fetches for a smooth map: 1 per map where every weight is one entry's (away from cuts, quadrant lines and the
// label band); near them the weights' label reads (shared by the maps of the same bands; counted in
// tests/test_export_v2_browser.py) and per map 1 per entry of non-zero weight (normal maps; scalar maps with
// the low band beside them), 2 for a scalar map reading its low band from its mips.
//
// Uniforms (from manifest.json "textures" and "lookup"):
//   ts_bits      labels_bits.png as R8UI (NEAREST, texelFetch only)
//   ts_coverage  labels_coverage.png + its levels as R8 (LINEAR_MIPMAP_LINEAR, CLAMP_TO_EDGE, max level = the
//                manifest's coverage max_level)
//   ts_table     table.bin as RGBA32I, width 256 (NEAREST, texelFetch only)
//   ts_index     index_map mode: index.png as R16UI; hash mode: any unsigned-integer texture on its own unit
//   ts_layout    (tile_size N, bits columns, coverage columns, coverage max level)
//   ts_lookup, ts_seed, ts_wrap: as version 1 (mode 0 index map, 1 corner hash, 2 edge hash)
//   ts_blend_cov labels_blend.png as R16F, texel = count / 4^l (LINEAR, CLAMP_TO_EDGE, one level; any 1x1
//                float texture without it)
//   ts_blend_layout  (columns, high_level, reach_levels[0] or -1, reach_levels[1]) of the manifest's labels.blend
//   every map: its full mip chain, LINEAR_MIPMAP_LINEAR, MIRRORED_REPEAT.
// Define TS_COUNT_FETCHES before this file to count texture fetches in the global ts_fetches (tests).
#ifdef TS_COUNT_FETCHES
int ts_fetches = 0;
#define TS_COUNT(k) ts_fetches += (k)
#else
#define TS_COUNT(k)
#endif

uniform highp usampler2D ts_bits;
uniform highp sampler2D ts_coverage;
uniform highp isampler2D ts_table;
uniform highp usampler2D ts_index;
uniform highp sampler2D ts_blend_cov;
uniform ivec4 ts_blend_layout;
uniform ivec4 ts_layout;
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

uint ts_hash(int x, int y, uint seed, uint role) {
    return ts_pcg3d(uvec3(uint(x), uint(y), seed ^ (role * 0x9E3779B9u))).x;
}

int ts_floordiv(int a, int b) { return a >= 0 ? a / b : -1 - (~a) / b; }
int ts_emod(int a, int b) { return a - b * ts_floordiv(a, b); }

uint ts_lattice(ivec2 v, uint role) {
    if (ts_wrap.x > 0) v = ivec2(ts_emod(v.x, ts_wrap.x), ts_emod(v.y, ts_wrap.y));
    return ts_hash(v.x, v.y, ts_seed, role);
}

// Tile index of a cell (any ivec2, negative included): the version-1 lookup, unchanged.
int ts_tile_index(ivec2 cell) {
    if (ts_lookup.x == 0) {
        ivec2 sz = textureSize(ts_index, 0);
        TS_COUNT(1);
        return int(texelFetch(ts_index, ivec2(ts_emod(cell.x, sz.x), ts_emod(cell.y, sz.y)), 0).r);
    }
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

// What every map of one pixel shares.
struct TsSite {
    ivec4 ent;    // table texel: (code_A, bx_A, code_B, bx_B), code = (radius << 19) | ((by + 32768) << 3) | symmetry
    int tile;
    vec2 p;       // position in the tile in pixels, [0, N)^2, (x, y)
    vec2 gx, gy;  // d(p)/dx, d(p)/dy (pixels per screen pixel)
    float lod;    // footprint level log2(max(|gx|, |gy|)), as the GL scale factor
};

ivec4 ts_table_texel(int tile, vec2 p) {
    int h = ts_layout.x / 2;
    int q = (p.y >= float(h) ? 2 : 0) + (p.x >= float(h) ? 1 : 0);
    int i = 4 * tile + q;
    TS_COUNT(1);
    return texelFetch(ts_table, ivec2(i % 256, i / 256), 0);
}

TsSite ts_site(vec2 uv, vec2 duvdx, vec2 duvdy) {
    TsSite s;
    vec2 cellf = floor(uv);
    float n = float(ts_layout.x);
    s.tile = ts_tile_index(ivec2(cellf));
    s.p = (uv - cellf) * n;
    s.gx = duvdx * n;
    s.gy = duvdy * n;
    s.lod = 0.5 * log2(max(max(dot(s.gx, s.gx), dot(s.gy, s.gy)), 1e-20));
    s.ent = ts_table_texel(s.tile, s.p);
    return s;
}

// The radii of the sample's quadrant (pixels from the tile's centre): nearer than r_in every pixel is entry B,
// farther than r_out entry A (the label band between them holds the cut).
float ts_r_in(TsSite s) { return float(s.ent.x >> 19) * 0.5; }
float ts_r_out(TsSite s) { return float(s.ent.z >> 19) * 0.5; }

// The label bit of the pixel under the sample (1: entry B): one fetch inside the label band, none outside it.
float ts_bit(TsSite s) {
    int n = ts_layout.x;
    ivec2 ip = clamp(ivec2(floor(s.p)), ivec2(0), ivec2(n - 1));
    float d = length(vec2(ip) + 0.5 - 0.5 * float(n));
    if (d < ts_r_in(s)) return 1.0;
    if (d > ts_r_out(s)) return 0.0;
    int c = ts_layout.y;
    ivec2 cell = ivec2((s.tile % c) * (n / 8), (s.tile / c) * n);
    TS_COUNT(1);
    uint byte = texelFetch(ts_bits, cell + ivec2(ip.x / 8, ip.y), 0).r;
    return float((byte >> uint(ip.x % 8)) & 1u);
}

// Weight of entry B (the matching patch) at level max(footprint, blend_level). Below level 1: the pixel's own
// label bit, a hard cut (level 0 is exactly the CPU synthesis). From level 1: the coverage of B, bilinear at the
// sample point, at label level max(L, 2) (the coverage texture starts at label level 2), trilinear between
// levels, clamped inside the tile's cell. B fades out within min(2^L, N/16) pixels of the tile's edge: the
// neighbour's matching patch is not looked up, while the kept border ring (entry A) continues across the edge,
// so both sides of an edge agree. A blend level above the footprint is a seam treatment: there B alone is shown
// inside the cut (so the intermediate tile under the cut, with its quadrant seams, never shows) and B fades out
// over about 2^L pixels outside it (weight min(1, 2 x coverage), 1 at the cut where the coverage is about 1/2).
// Fetches: none where the filter's reach lies outside the quadrant's label band (ts_r_in, ts_r_out); there the
// weight is 0 or 1 without a look; else one (bit or coverage), two for a seam treatment near the cut.
float ts_weight(TsSite s, float blend_level) {
    if (s.ent.xy == s.ent.zw) return 0.0;  // one source in this quadrant: no label needed
    float lw = max(s.lod, blend_level);
    if (lw < 1.0) return ts_bit(s);
    int n = ts_layout.x;
    float lc = clamp(lw - 2.0, 0.0, float(ts_layout.w));
    float d = length(s.p - 0.5 * float(n));
    // the pixels under the coverage texels a bilinear (or trilinear) sample reads: 1.5 texels a side, x sqrt 2
    float reach = 2.2 * exp2(ceil(lc) + 2.0);
    float w;
    if (d + reach < ts_r_in(s)) {
        w = 1.0;
    } else if (d - reach > ts_r_out(s)) {
        w = 0.0;
    } else {
        float side = float(n / 4);
        float half_texel = 0.5 * exp2(ceil(lc));  // half a texel of the coarser level, in level-0 coverage texels
        vec2 q = clamp(s.p * 0.25, vec2(min(half_texel, 0.5 * side)), vec2(max(side - half_texel, 0.5 * side)));
        int c = ts_layout.z;
        vec2 pos = vec2(float(s.tile % c), float(s.tile / c)) * side + q;
        TS_COUNT(1);
        w = textureLod(ts_coverage, pos / vec2(textureSize(ts_coverage, 0)), lc).r;
    }
    vec2 e = min(s.p, float(n) - s.p);
    w *= clamp(min(e.x, e.y) / min(exp2(lw), float(n) / 16.0), 0.0, 1.0);
    // seam treatment: B inside the cut, outside a fade from 1 at the cut (coverage 1/2) to 0 about 2^L out
    if (blend_level > s.lod) w = max(ts_bit(s), min(1.0, 2.0 * w));
    return w;
}

// Source position (x, y) in exemplar pixels of tile position p (x, y) through entry (code, bx), and the linear
// part of the symmetry applied to a vector.
vec2 ts_src(int code, int bx, vec2 p) {
    int sym = code & 7;
    float n = float(ts_layout.x);
    float y = p.y, x = p.x;
    if (sym >= 4) x = n - x;
    int k = sym & 3;
    vec2 rc = k == 0 ? vec2(y, x) : k == 1 ? vec2(x, n - y) : k == 2 ? vec2(n - y, n - x) : vec2(n - x, y);
    return vec2(rc.y + float(bx), rc.x + float(((code >> 3) & 0xFFFF) - 32768));
}

vec2 ts_turn(int code, vec2 g) {
    int sym = code & 7;
    float y = g.y, x = g.x;
    if (sym >= 4) x = -x;
    int k = sym & 3;
    vec2 rc = k == 0 ? vec2(y, x) : k == 1 ? vec2(x, -y) : k == 2 ? vec2(-y, -x) : vec2(-x, y);
    return rc.yx;
}

// A tangent-space normal turned with its patch (normal: 1 unsigned +y codes, 2 unsigned -y, 3 signed +y,
// 4 signed -y; 0 no turn; -1 a one-channel scalar map bound with its low band in .g: the value, grey). R (an
// anticlockwise quarter turn on screen) takes (x, y) to (-y, x), y up.
vec4 ts_turn_normal(vec4 c, int code, int normal) {
    if (normal < 0) return vec4(c.rrr, 1.0);
    int sym = code & 7;
    if (normal == 0 || sym == 0) return c;
    vec2 v = normal <= 2 ? c.xy * 2.0 - 1.0 : c.xy;
    if (normal == 2 || normal == 4) v.y = -v.y;
    for (int i = 0; i < (sym & 3); i++) v = vec2(-v.y, v.x);
    if (sym >= 4) v.x = -v.x;
    if (normal == 2 || normal == 4) v.y = -v.y;
    c.xy = normal <= 2 ? v * 0.5 + 0.5 : v;
    return c;
}

// The texel of an entry as stored (no turn of a normal): textureGrad with the footprint's turned derivatives.
vec4 ts_entry_raw(sampler2D map, TsSite s, int code, int bx) {
    vec2 size = vec2(textureSize(map, 0));
    vec2 src = ts_src(code, bx, s.p);
    TS_COUNT(1);
    return textureGrad(map, src / size, ts_turn(code, s.gx) / size, ts_turn(code, s.gy) / size);
}

vec4 ts_entry(sampler2D map, TsSite s, int code, int bx, int normal) {
    return ts_turn_normal(ts_entry_raw(map, s, code, bx), code, normal);
}

// One map at the site: entry A, entry B or both weighted by w (the weight of B).
vec4 ts_map(sampler2D map, TsSite s, float w, int normal) {
    if (w <= 0.0 || s.ent.xy == s.ent.zw) return ts_entry(map, s, s.ent.x, s.ent.y, normal);
    if (w >= 1.0) return ts_entry(map, s, s.ent.z, s.ent.w, normal);
    return mix(ts_entry(map, s, s.ent.x, s.ent.y, normal), ts_entry(map, s, s.ent.z, s.ent.w, normal), w);
}

vec4 ts_sample_map(sampler2D map, vec2 uv, float blend_level, int normal) {
    TsSite s = ts_site(uv, dFdx(uv), dFdy(uv));
    return ts_map(map, s, ts_weight(s, blend_level), normal);
}

// The exact texel (x, y) of the infinite texture of one map (no filtering): table, bit and map texelFetch.
vec4 ts_fetch_map(sampler2D map, ivec2 p, int normal) {
    int n = ts_layout.x;
    ivec2 cell = ivec2(ts_floordiv(p.x, n), ts_floordiv(p.y, n));
    int tile = ts_tile_index(cell);
    ivec2 l = p - cell * n;
    ivec4 ent = ts_table_texel(tile, vec2(l) + 0.5);
    int c = ts_layout.y;
    uint byte = texelFetch(ts_bits, ivec2((tile % c) * (n / 8) + l.x / 8, (tile / c) * n + l.y), 0).r;
    bool b = ((byte >> uint(l.x % 8)) & 1u) == 1u;
    int code = b ? ent.z : ent.x, bx = b ? ent.w : ent.y;
    // integer symmetry: D_s of pixel (row, col) with m = N - 1
    int sym = code & 7, m = n - 1, y = l.y, x = l.x;
    if (sym >= 4) x = m - x;
    int k = sym & 3;
    ivec2 rc = k == 0 ? ivec2(y, x) : k == 1 ? ivec2(x, m - y) : k == 2 ? ivec2(m - y, m - x) : ivec2(m - x, y);
    vec4 v = texelFetch(map, ivec2(rc.y + bx, rc.x + ((code >> 3) & 0xFFFF) - 32768), 0);
    return ts_turn_normal(v, code, normal);
}

// ------------------------------------------------------------------------------------------ the seam blend
// The weights of the entries of a tile near a pixel: A_0..A_3 (each quadrant's own) and B (the matching patch).
struct TsBlend {
    ivec4 ca, xa, cb;   // per quadrant: code_A (with r_in), bx_A, code_B (with r_out), from the table
    ivec2 bb;           // (code, bx) of B (the same in every quadrant)
    int loaded;         // bit q: quadrant q's table texel read
    vec4 ha; float hb;  // detail-band weights of A_0..A_3 and B
    vec4 ga; float gb;  // low-band weights
};

void ts_quad(inout TsBlend b, int tile, int q) {
    if (((b.loaded >> q) & 1) != 0) return;
    int i = 4 * tile + q;
    TS_COUNT(1);
    ivec4 e = texelFetch(ts_table, ivec2(i % 256, i / 256), 0);
    b.ca[q] = e.x; b.xa[q] = e.y; b.cb[q] = e.z; b.bb = ivec2(e.z & 0x7FFFF, e.w);
    b.loaded |= 1 << q;
}

// The radii's verdict on the pixels [p0, p1] of quadrant q (band 1: of the labels extended reach px): 0 all A,
// 1 all B, -1 unknown.
float ts_rect_known(TsBlend b, int band, ivec2 p0, ivec2 p1, int q, int reach) {
    int n = ts_layout.x;
    vec2 lo = vec2(p0) + 0.5 - 0.5 * float(n), hi = vec2(p1) + 0.5 - 0.5 * float(n);
    float dnear = length(max(max(lo, -hi), vec2(0.0)));
    float dfar = length(max(abs(lo), abs(hi)));
    float rin = float(b.ca[q] >> 19) * 0.5, rout = float(b.cb[q] >> 19) * 0.5;
    int dmin = min(min(p0.x, p0.y), min(n - 1 - p1.x, n - 1 - p1.y));
    bool zone = band == 1 && dmin < reach;
    // all A: no pixel of the block within r_out (and, in the extended zone, no border pixel of B at all)
    if (dnear > rout && (!zone || rout < 0.5 * float(n) - 0.5)) return 0.0;
    if (dfar < rin && !zone) return 1.0;
    return -1.0;
}

// Share of B in block ib of level l of the labels (levels below the detail band's top: bits and coverage).
float ts_block_b(inout TsBlend b, TsSite s, int l, ivec2 ib, int q) {
    ts_quad(b, s.tile, q);
    int n = ts_layout.x, sz = 1 << l;
    ivec2 p0 = ib * sz, p1 = p0 + sz - 1;
    float known = ts_rect_known(b, 0, p0, p1, q, 1);
    if (known >= 0.0) return known;
    int t = s.tile;
    if (l >= 2) {
        int c = ts_layout.z, side = (n / 4) >> (l - 2);
        TS_COUNT(1);
        float v = texelFetch(ts_coverage, ivec2((t % c) * side + ib.x, (t / c) * side + ib.y), l - 2).r;
        float cells = float(sz * sz);
        return floor(v * cells + 0.5) / cells;  // 8-bit rint(count * 255 / 4^l): the count, exactly, to l = 3
    }
    int c = ts_layout.y;
    ivec2 cell = ivec2((t % c) * (n / 8), (t / c) * n);
    float sum = 0.0;
    for (int r = 0; r < sz; r++) {
        TS_COUNT(1);
        uint byte = texelFetch(ts_bits, cell + ivec2(p0.x / 8, p0.y + r), 0).r;
        for (int k = 0; k < sz; k++) sum += float((byte >> uint((p0.x + k) % 8)) & 1u);
    }
    return sum / float(sz * sz);
}

// Adds the bilinear sample of level l (weight lw) of the labels' coverage at the pixel (indices clamped to the
// tile), tap by tap.
void ts_level(inout TsBlend b, TsSite s, int l, float lw) {
    int n = ts_layout.x, nl = n >> l;
    vec2 u = s.p / exp2(float(l)) - 0.5;
    vec2 i0 = floor(u), f = u - i0;
    ivec2 a = clamp(ivec2(i0), ivec2(0), ivec2(nl - 1)), c = clamp(ivec2(i0) + 1, ivec2(0), ivec2(nl - 1));
    for (int k = 0; k < 4; k++) {
        float w = lw * ((k & 1) == 0 ? 1.0 - f.x : f.x) * (k < 2 ? 1.0 - f.y : f.y);
        if (w <= 0.0) continue;
        ivec2 ib = ivec2((k & 1) == 0 ? a.x : c.x, k < 2 ? a.y : c.y);
        int q = ((ib.y << l) >= n / 2 ? 2 : 0) + ((ib.x << l) >= n / 2 ? 1 : 0);
        float cb = ts_block_b(b, s, l, ib, q);
        b.ha[q] += w * (1.0 - cb); b.hb += w * cb;
    }
}

// The cell of a tile in ts_blend_cov and the origin of a band's level l in it (texels).
ivec2 ts_blend_cell() {
    int n = ts_layout.x, h = ts_blend_layout.y;
    if (ts_blend_layout.z < 0) return ivec2(n >> h);
    int sum = 0;
    for (int k = ts_blend_layout.z; k <= ts_blend_layout.w; k++) sum += n >> k;
    return ivec2((n >> h) + (n >> ts_blend_layout.z), max(n >> h, sum));
}
ivec2 ts_blend_origin(int band, int l) {
    int n = ts_layout.x;
    if (band == 0) return ivec2(0);
    int y = 0;
    for (int k = ts_blend_layout.z; k < l; k++) y += n >> k;
    return ivec2(n >> ts_blend_layout.y, y);
}

// Adds the bilinear sample of level l (weight lw) of a band's coverage in ts_blend_cov: one filtered fetch per
// quadrant the taps fall in (split at the quadrant line: each side read at its own texel centre), none where the
// radii know the taps' blocks.
void ts_level_f(inout TsBlend b, TsSite s, int band, int l, float lw, int reach) {
    int n = ts_layout.x, nl = n >> l, hq = nl / 2, sz = 1 << l;
    vec2 u = s.p / exp2(float(l)) - 0.5;
    vec2 i0 = floor(u), f = u - i0;
    ivec2 a = clamp(ivec2(i0), ivec2(0), ivec2(nl - 1)), c = clamp(ivec2(i0) + 1, ivec2(0), ivec2(nl - 1));
    bvec2 cut = bvec2((a.x < hq) != (c.x < hq), (a.y < hq) != (c.y < hq));
    int t = s.tile, cols = ts_blend_layout.x;
    vec2 base = vec2(ivec2(t % cols, t / cols) * ts_blend_cell() + ts_blend_origin(band, l));
    if (cut.x || cut.y) {
        // taps in several quadrants whose own-quadrant taps the radii call all B (the B blob about the tile's
        // centre): one filtered fetch of all four taps; 1 means every tap is B, and the other quadrants'
        // table texels are not needed (each tap's bilinear weight is at least 1/64 at a pixel centre)
        int h = n / 2;
        bvec2 high = bvec2(s.p.x >= float(h), s.p.y >= float(h));
        ivec2 lo = a, hi = c;
        if (cut.x) lo.x = hi.x = high.x ? c.x : a.x;
        if (cut.y) lo.y = hi.y = high.y ? c.y : a.y;
        int qo = (high.y ? 2 : 0) + (high.x ? 1 : 0);
        if (ts_rect_known(b, band, lo * sz, hi * sz + sz - 1, qo, reach) == 1.0) {
            TS_COUNT(1);
            vec2 pos = vec2(a) + 0.5 + vec2(notEqual(a, c)) * f;
            if (textureLod(ts_blend_cov, (base + pos) / vec2(textureSize(ts_blend_cov, 0)), 0.0).r >= 1.0) {
                if (band == 0) b.hb += lw; else b.gb += lw;
                return;
            }
        }
    }
    for (int g = 0; g < 4; g++) {
        int gx = g & 1, gy = g >> 1;
        if ((gx == 1 && !cut.x) || (gy == 1 && !cut.y)) continue;
        ivec2 lo = a, hi = c;
        vec2 pos = vec2(a) + 0.5 + vec2(notEqual(a, c)) * f;
        float w = lw;
        if (cut.x) { lo.x = hi.x = gx == 0 ? a.x : c.x; pos.x = float(lo.x) + 0.5; w *= gx == 0 ? 1.0 - f.x : f.x; }
        if (cut.y) { lo.y = hi.y = gy == 0 ? a.y : c.y; pos.y = float(lo.y) + 0.5; w *= gy == 0 ? 1.0 - f.y : f.y; }
        if (w <= 0.0) continue;
        int q = (lo.y >= hq ? 2 : 0) + (lo.x >= hq ? 1 : 0);
        ts_quad(b, t, q);
        float cb = ts_rect_known(b, band, lo * sz, hi * sz + sz - 1, q, reach);
        if (cb < 0.0) {
            TS_COUNT(1);
            cb = textureLod(ts_blend_cov, (base + pos) / vec2(textureSize(ts_blend_cov, 0)), 0.0).r;
        }
        if (band == 0) { b.ha[q] += w * (1.0 - cb); b.hb += w * cb; }
        else { b.ga[q] += w * (1.0 - cb); b.gb += w * cb; }
    }
}

// One band: lod = min(level, log2(reach + d)), d the pixel's distance to the tile border; trilinear.
void ts_band(inout TsBlend b, TsSite s, int band, float level, float reach) {
    int n = ts_layout.x;
    vec2 pc = s.p - 0.5;
    float d = max(min(min(pc.x, pc.y), min(float(n - 1) - pc.x, float(n - 1) - pc.y)), 0.0);
    float lod = min(level, log2(reach + d));
    if (abs(lod - floor(lod + 0.5)) < 1e-5) lod = floor(lod + 0.5);  // log2 of a power of two, exactly
    float l0 = floor(lod), f = lod - l0;
    int l = int(l0);
    if (band == 1 || l >= ts_blend_layout.y) ts_level_f(b, s, band, l, 1.0 - f, int(reach));
    else ts_level(b, s, l, 1.0 - f);
    if (f > 0.0) {
        if (band == 1 || l + 1 >= ts_blend_layout.y) ts_level_f(b, s, band, l + 1, f, int(reach));
        else ts_level(b, s, l + 1, f);
    }
}

// The weights of the seam blend with bands (high, low, split, reach) at the site (low < 0: the detail band
// alone). Nothing is read where the footprint is past the blend (lod >= the band's top level + 1).
TsBlend ts_blend(TsSite s, vec4 bands) {
    TsBlend b;
    b.ca = ivec4(0); b.xa = ivec4(0); b.cb = ivec4(0);
    b.ha = vec4(0.0); b.hb = 0.0; b.ga = vec4(0.0); b.gb = 0.0;
    int h = ts_layout.x / 2;
    int q = (s.p.y >= float(h) ? 2 : 0) + (s.p.x >= float(h) ? 1 : 0);
    b.ca[q] = s.ent.x; b.xa[q] = s.ent.y; b.cb[q] = s.ent.z; b.bb = ivec2(s.ent.z & 0x7FFFF, s.ent.w);
    b.loaded = 1 << q;
    float top = bands.y >= 0.0 ? bands.y : bands.x;
    if (s.lod >= top + 1.0) return b;
    ts_band(b, s, 0, bands.x, 1.0);
    if (bands.y >= 0.0) ts_band(b, s, 1, bands.y, bands.w);
    return b;
}

// Entry i (0-3: A_i, 4: B) of a blend: (code, bx).
ivec2 ts_slot(TsBlend b, int i) { return i < 4 ? ivec2(b.ca[i] & 0x7FFFF, b.xa[i]) : b.bb; }
float ts_h(TsBlend b, int i) { return i < 4 ? b.ha[i] : b.hb; }
float ts_g(TsBlend b, int i) { return i < 4 ? b.ga[i] : b.gb; }

// The low band of an entry: the map's mip at level max(split, footprint) at the entry's source (bilinear,
// MIRRORED_REPEAT).
vec4 ts_entry_low(sampler2D map, TsSite s, ivec2 e, float split, int normal) {
    vec2 size = vec2(textureSize(map, 0));
    TS_COUNT(1);
    return textureLod(map, ts_src(e.x, e.y, s.p) / size, max(split, s.lod));
}

// A normal sample as a slope (n_x, n_y) / max(n_z, 1/16) (decoded: normal 1/2 unsigned codes, 3/4 signed).
vec2 ts_slope(vec4 c, int normal) {
    vec3 v = normal <= 2 ? c.xyz * 2.0 - 1.0 : c.xyz;
    return v.xy / max(v.z, 1.0 / 16.0);
}

// The seam blend of one map at the site (tilesynth.synth.seams step 5): normal > 0 a normal map (slopes
// blended with the detail weights), else a scalar map (the low band variance-preserving about mean, the detail
// linear; normal -1: a one-channel map bound with its low band in .g, one fetch per entry for both); a pixel
// whose weights are all one entry's is that entry's sample.
vec4 ts_blend_map(sampler2D map, TsSite s, TsBlend b, vec4 bands, vec4 mean, int normal) {
    bool low = bands.y >= 0.0 && normal <= 0;
    for (int i = 0; i < 5; i++) {
        if (ts_h(b, i) >= 1.0 - 1e-5 && (!low || ts_g(b, i) >= 1.0 - 1e-5)) {
            ivec2 e = ts_slot(b, i);
            return ts_entry(map, s, e.x, e.y, normal);
        }
    }
    if (normal > 0) {
        vec2 sl = vec2(0.0);
        for (int i = 0; i < 5; i++) {
            float h = ts_h(b, i);
            if (h <= 0.0) continue;
            ivec2 e = ts_slot(b, i);
            sl += h * ts_slope(ts_entry(map, s, e.x, e.y, normal), normal);
        }
        vec3 v = normalize(vec3(sl, 1.0));
        return vec4(normal <= 2 ? v * 0.5 + 0.5 : v, 1.0);
    }
    vec4 base = vec4(0.0), det = vec4(0.0);
    float g2 = 0.0;
    for (int i = 0; i < 5; i++) {
        float h = ts_h(b, i), g = low ? ts_g(b, i) : 0.0;
        if (h <= 0.0 && g <= 0.0) continue;
        ivec2 e = ts_slot(b, i);
        vec4 a = vec4(0.0), v = vec4(0.0);
        if (normal < 0) {  // value and low band in one fetch
            vec4 c = ts_entry_raw(map, s, e.x, e.y);
            v = vec4(c.rrr, 1.0);
            a = low ? vec4(c.ggg, 1.0) : vec4(0.0);
        } else {
            if (low) a = ts_entry_low(map, s, e, bands.z, normal);
            if (h > 0.0) v = ts_entry(map, s, e.x, e.y, normal);
        }
        if (h > 0.0) det += h * (v - a);
        if (g > 0.0) {
            base += g * a;
            // an entry shown by two slots (the same source) weighs once in the variance normaliser
            bool seen = false;
            float gs = g;
            for (int j = 0; j < 5; j++) {
                if (j == i || ts_g(b, j) <= 0.0 || ts_slot(b, j) != e) continue;
                if (j < i) seen = true;
                gs += ts_g(b, j);
            }
            if (!seen) g2 += gs * gs;
        }
    }
    return low ? mean + (base - mean) / sqrt(g2) + det : det;
}

// A smooth map at the site: the seam blend at magnification and 1:1, fading into the footprint path (ts_map
// with the footprint's weight w0 = ts_weight(s, 0.0)) from the band's top level to one level above it.
vec4 ts_smooth_map(sampler2D map, TsSite s, TsBlend b, vec4 bands, vec4 mean, int normal, float w0) {
    float top = bands.y >= 0.0 && normal <= 0 ? bands.y : bands.x;
    float t = clamp(s.lod - top, 0.0, 1.0);
    if (t >= 1.0) return ts_map(map, s, w0, normal);
    vec4 v = ts_blend_map(map, s, b, bands, mean, normal);
    return t <= 0.0 ? v : mix(v, ts_map(map, s, w0, normal), t);
}
