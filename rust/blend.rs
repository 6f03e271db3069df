//! The seam blend of smooth material maps over a window of a tiling (`tilesynth.synth.seams`, whose module
//! docstring states the formula; its numpy `blend_tiles` is the oracle of this kernel).
//!
//! Per output pixel: its tile `t` and tile pixel `p` (the index map and offset, as
//! [`crate::provenance::gather_window_into`]); the weights `h_e(p)` of the high band (level `high`, the plain
//! labels) and, with a low band, `g_e(p)` (level `low`, the labels extended `reach` px from the tile border),
//! each a trilinear sample of the tile's coverage pyramid at `lod = min(L, log2(R + d))`; every entry with a
//! non-zero weight read at the pixel (`D_s(p) + b`, mirrored into the map). Scalar maps:
//! `μ + (Σ g a − μ) / √Σ g² + Σ h (v − a)` with a low band (`a`: the low band of the value read, given at every
//! pixel), `Σ h v` without, encoded as the map's samples (`rint(clip(out, 0, 1) · S)`, or float32); normal maps:
//! the blended slopes `Σ h σ` (each entry's turned with its symmetry) encoded at unit length ([`encode_unit`],
//! the codes of `tilesynth.io.normal_codes.encode_unit`). A pixel where one entry has every weight of the map's
//! bands is that entry's copy (the map's samples read through the provenance). The arithmetic (f64) is done in the oracle's
//! order, so the two agree to the last bit in practice.
//!
//! All the maps of a window are blended in one pass: the weights of a pixel are found once and shared (the high
//! band by every map, the low band by the scalar maps), the coverage pyramids of the tiles shown are built once
//! per call, and only for the levels the bands read; an entry's weight is found alone first, and only where it
//! is below 1 (near a cut) are the other entries' weights found.

use crate::error::{fmt_shape, Result, TilesynthError};
use crate::provenance::{check_tables, check_window, dihedral};
use ndarray::{ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;

/// The bands of a blend: the detail's level and, optionally, the low band's `(level, reach)`.
#[derive(Clone, Copy, Debug)]
pub struct Bands {
    /// Level of the high band's weights.
    pub high: f64,
    /// Level of the low band's weights and the reach of its border labels.
    pub low: Option<(f64, usize)>,
}

/// GL `MIRRORED_REPEAT` of an index into `0..size`.
#[inline]
fn mirror(i: i64, size: usize) -> usize {
    if i >= 0 && (i as usize) < size {
        return i as usize;
    }
    let s = size as i64;
    let m = i.rem_euclid(2 * s);
    (if m >= s { 2 * s - 1 - m } else { m }) as usize
}

/// The samples of a map: its codes (read by the copies) or the window written.
pub enum Samples<'a> {
    /// 8-bit codes (`code / 255`).
    U8(&'a [u8]),
    /// 16-bit codes (`code / 65535`).
    U16(&'a [u16]),
    /// Float samples.
    F32(&'a [f32]),
}

/// A window row of a map's output, in its sample type.
pub enum SamplesMut<'a> {
    /// 8-bit codes.
    U8(&'a mut [u8]),
    /// 16-bit codes.
    U16(&'a mut [u16]),
    /// Float samples.
    F32(&'a mut [f32]),
}

impl SamplesMut<'_> {
    fn len(&self) -> usize {
        match self {
            SamplesMut::U8(s) => s.len(),
            SamplesMut::U16(s) => s.len(),
            SamplesMut::F32(s) => s.len(),
        }
    }
}

/// What a map's blend is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Linear data (height, roughness): blended per channel, with the low band when the blend has one.
    Scalar,
    /// A normal map (3 channels, `values` its 2 slopes): "snorm" when its float samples are the vectors
    /// themselves, else "unorm" (`2x − 1`; codes always decode so).
    Normal {
        /// Float samples are the vectors themselves.
        snorm: bool,
    },
}

/// One map of a blend (module docstring): `codes` `(H, W, C)` its samples (what the copies read; a scalar
/// map blends them over their maximum, `code / S`, S = 255, 65535 or 1 for floats, `Cv = C` channels),
/// `values` a normal map's slopes `(H, W, Cv = 2)` (None for a scalar map), `low` the low band of what is
/// blended at every pixel (scalar maps, when the bands have one), `mu` its mean per channel, `out` `(h, w, C)`
/// the window, in the samples' type.
pub struct MapBlend<'a> {
    /// Scalar or normal.
    pub kind: Kind,
    /// `(H, W)`: the map's size (every map's the same, aligned with the exemplar).
    pub size: (usize, usize),
    /// `(H, W, 2)` a normal map's slopes; None for a scalar map.
    pub values: Option<ArrayView3<'a, f64>>,
    /// `(H, W, Cv)` their low band at every pixel, or None.
    pub low: Option<ArrayView3<'a, f64>>,
    /// The values' mean per channel (the low band's centre).
    pub mu: Vec<f64>,
    /// `(H, W, C)` the map's samples, C-contiguous.
    pub codes: Samples<'a>,
    /// The number of channels `C` of `codes` and `out`.
    pub channels: usize,
    /// `(h, w, C)` the window, C-contiguous.
    pub out: SamplesMut<'a>,
    /// A normal map's vector turns (`sel[s][row] = (channel, negated)`, [`crate::provenance::VectorTurn`]):
    /// the slopes and copied codes of an entry of symmetry `s` are turned with it. None: every entry used
    /// must be untransformed (symmetry 0).
    pub turn: Option<Turns>,
}

/// The vector turn of every symmetry: `[s][row] = (channel, negated)`.
pub type Turns = [[(usize, bool); 2]; 8];

/// The pair `(v0, v1)` turned by `sel` (one symmetry's row of [`Turns`]): exact (a swap and negations).
#[inline]
fn turn_pair(sel: &[(usize, bool); 2], v: [f64; 2]) -> [f64; 2] {
    sel.map(|(ch, neg)| if neg { -v[ch] } else { v[ch] })
}

/// The largest distance from unit length of a code [`encode_unit`] picks where it can
/// (`tilesynth.io.normal_codes.UNIT_TOLERANCE`).
pub const UNIT_TOLERANCE: f64 = 0.0049;

/// The integral codes (as floats) of the vector `v` with maximum code `scale` (255 or 65535): `v` normalised,
/// then among the 8 codes made of the floor or ceiling of each scaled component the nearest one within
/// [`UNIT_TOLERANCE`] of unit length and no farther from `v` than rounding can be (`√3 / scale`); else the
/// nearest within the tolerance; else the most nearly unit one within the bound; else the nearest
/// (`tilesynth.io.normal_codes.encode_unit`, the same arithmetic in the same order, so the same codes).
pub fn encode_unit(v: [f64; 3], scale: f64) -> [f64; 3] {
    let f = normalise(v);
    let half = 0.5 * scale;
    let step = 2.0 / scale;
    // per channel, its two codes (floor, ceiling): the code, its decoded value squared, its distance squared
    let mut code = [[0.0f64; 2]; 3];
    let mut dec2 = [[0.0f64; 2]; 3];
    let mut dist2 = [[0.0f64; 2]; 3];
    for i in 0..3 {
        let base = floor_small((f[i] + 1.0) * half).clamp(0.0, scale);
        for b in 0..2 {
            let c = (base + b as f64).min(scale);
            let dec = c * step - 1.0;
            let q = dec - f[i];
            (code[i][b], dec2[i][b], dist2[i][b]) = (c, dec * dec, q * q);
        }
    }
    // the tests `sqrt(x) <= bound` and `|sqrt(x) - 1| <= UNIT_TOLERANCE` without a square root where x is
    // clearly (a relative 1e-9, far above rounding) on one side; the square root decides near the edge
    let bound = 3.0f64.sqrt() / scale * (1.0 + 1e-9);
    let (b_lo, b_hi) = (bound * bound * (1.0 - 1e-9), bound * bound * (1.0 + 1e-9));
    let (u2_lo, u2_hi) = (
        (1.0 - UNIT_TOLERANCE).powi(2),
        (1.0 + UNIT_TOLERANCE).powi(2),
    );
    let (u_lo_in, u_hi_in) = (u2_lo * (1.0 + 1e-9), u2_hi * (1.0 - 1e-9));
    let (u_lo_out, u_hi_out) = (u2_lo * (1.0 - 1e-9), u2_hi * (1.0 + 1e-9));
    // almost always the nearest corner (the nearer code per channel, the floor on a tie: the smallest
    // computed distance, a rounded sum growing with each term) is inside and unit, so it has the smallest key,
    // unless an earlier corner is as near within rounding (then the full search below decides)
    let near = [0, 1, 2].map(|i| usize::from(dist2[i][1] < dist2[i][0]));
    let d2n = dist2[0][near[0]] + dist2[1][near[1]] + dist2[2][near[2]];
    let len2n = dec2[0][near[0]] + dec2[1][near[1]] + dec2[2][near[2]];
    if d2n <= b_lo && len2n >= u_lo_in && len2n <= u_hi_in {
        let pick = near[0] * 4 + near[1] * 2 + near[2];
        let tie = (0..pick).any(|c| {
            dist2[0][c >> 2] + dist2[1][(c >> 1) & 1] + dist2[2][c & 1] <= d2n * (1.0 + 1e-6)
        });
        if !tie {
            return [code[0][near[0]], code[1][near[1]], code[2][near[2]]];
        }
    }
    // the corners in numpy's itertools.product order (the last channel varies fastest); numpy's key:
    // dist (inside and unit), 10 + dist (unit), 20 + err (inside), 100 + dist (neither). The tiers never
    // overlap, so numpy's argmin is in the lowest tier present.
    let mut tiers = [0u8; 8];
    let mut sums = [(0.0f64, 0.0f64); 8];
    for (corner, (tier, sum)) in tiers.iter_mut().zip(sums.iter_mut()).enumerate() {
        let (a, b, c) = (corner >> 2, (corner >> 1) & 1, corner & 1);
        let len2 = dec2[0][a] + dec2[1][b] + dec2[2][c];
        let d2 = dist2[0][a] + dist2[1][b] + dist2[2][c];
        let mut inside = d2 <= b_lo;
        if !inside && d2 < b_hi {
            inside = d2.sqrt() <= bound; // near the edge: the square root decides
        }
        let mut unit = len2 >= u_lo_in && len2 <= u_hi_in;
        if !unit && len2 > u_lo_out && len2 < u_hi_out {
            unit = (len2.sqrt() - 1.0).abs() <= UNIT_TOLERANCE;
        }
        *tier = 2 * u8::from(!unit) + u8::from(!inside);
        *sum = (len2, d2);
    }
    let top = tiers.iter().copied().min().unwrap_or(3);
    let key = |corner: usize| {
        let (len2, d2) = sums[corner];
        match top {
            0 => d2.sqrt(),
            1 => 10.0 + d2.sqrt(),
            2 => 20.0 + (len2.sqrt() - 1.0).abs(),
            _ => 100.0 + d2.sqrt(),
        }
    };
    let mut pick = 8;
    if top != 2 && sums.iter().all(|s| !s.1.is_nan()) {
        // the key grows with the squared distance: the nearest corner (the first of equal ones) has the
        // smallest key; an earlier corner within rounding of it may have the same key, and numpy takes it
        for corner in 0..8 {
            if tiers[corner] == top && (pick == 8 || sums[corner].1 < sums[pick].1) {
                pick = corner;
            }
        }
        let (kmin, d2min) = (key(pick), sums[pick].1);
        if let Some(c) = (0..pick)
            .find(|&c| tiers[c] == top && sums[c].1 <= d2min * (1.0 + 1e-6) && key(c) == kmin)
        {
            pick = c;
        }
    } else {
        let mut best = f64::NAN;
        for (corner, _) in tiers.iter().enumerate().filter(|&(_, &t)| t == top) {
            let k = key(corner);
            if pick == 8 || k < best {
                (pick, best) = (corner, k); // the first of equal keys, as numpy's argmin; a NaN key first
            }
            if k.is_nan() && pick == corner {
                break;
            }
        }
    }
    let corner = pick.min(7);
    [
        code[0][corner >> 2],
        code[1][(corner >> 1) & 1],
        code[2][corner & 1],
    ]
}

/// The levels up to which a pyramid keeps no texels: a row finds the few it reads from the labels (blocks
/// of at most 16 pixels; these levels are read near the tile border only).
const LAZY_LEVELS: usize = 2;

/// The shares `counts / area` of a block's entries into `out`: the oracle's division (a multiplication by
/// the inverse when `area` is a power of two, the same value).
#[inline]
fn share(counts: &[u32], area: usize, out: &mut [f64]) {
    let a = area as f64;
    if area.is_power_of_two() {
        let inv = 1.0 / a;
        for (o, &c) in out.iter_mut().zip(counts) {
            *o = f64::from(c) * inv;
        }
    } else {
        for (o, &c) in out.iter_mut().zip(counts) {
            *o = f64::from(c) / a;
        }
    }
}

/// The coverage pyramid of one tile's labels (extended `reach` px from the border) at the levels a band reads
/// (from `first` >= 1 up; level 0 is the labels' indicator): level `l` is `n_l x n_l x E` shares (entry last).
struct Pyramid {
    n: usize,
    e: usize,
    ext: Vec<u8>,
    first: usize,
    levels: Vec<(usize, Vec<f64>)>,
    /// Per level, per texel: the entries with a non-zero share (bit `k`: entry `k`; none kept when `e` > 64).
    masks: Vec<Vec<u64>>,
}

impl Pyramid {
    /// The pyramid of labels `lab` (`n x n`, every label below `e`) at levels `first..=top` (none when
    /// `top < first`).
    fn new(lab: &[u8], n: usize, e: usize, reach: usize, first: usize, top: usize) -> Pyramid {
        let ext: Vec<u8> = if reach <= 1 {
            lab.to_vec()
        } else {
            let mut out = lab.to_vec();
            for y in 0..n {
                let dy = y.min(n - 1 - y);
                // the pixels within `reach` of the border: the whole row near the top and bottom, else its ends
                let (ends, rest) = if dy < reach {
                    (0..n, 0..0)
                } else {
                    (
                        0..reach.min(n),
                        n.saturating_sub(reach).max(reach.min(n))..n,
                    )
                };
                for x in ends.chain(rest) {
                    let dx = x.min(n - 1 - x);
                    if dy.min(dx) < reach {
                        out[y * n + x] = if dy <= dx {
                            lab[(if y < n - 1 - y { 0 } else { n - 1 }) * n + x]
                        } else {
                            lab[y * n + if x < n - 1 - x { 0 } else { n - 1 }]
                        };
                    }
                }
            }
            out
        };
        let mut levels = Vec::new();
        let mut masks = Vec::new();
        // the levels of small blocks are found from the labels where a row reads them (RowCache::column)
        let first = first.max(LAZY_LEVELS + 1);
        if top >= first {
            // pixel counts per block (exact integers, as the oracle's float sums), the first level from the
            // labels and each next one from its four children (a partial block: the children that exist)
            let mut nl = n.div_ceil(1 << first);
            let mut counts = vec![0u32; nl * nl * e];
            for y in 0..n {
                let row = &ext[y * n..(y + 1) * n];
                let at = (y >> first) * nl;
                for (x, &v) in row.iter().enumerate() {
                    counts[(at + (x >> first)) * e + v as usize] += 1;
                }
            }
            for l in first..=top {
                if l > first {
                    let nn = nl.div_ceil(2);
                    let mut next = vec![0u32; nn * nn * e];
                    for i in 0..nl {
                        for j in 0..nl {
                            let (src, dst) = ((i * nl + j) * e, ((i / 2) * nn + j / 2) * e);
                            for k in 0..e {
                                next[dst + k] += counts[src + k];
                            }
                        }
                    }
                    (nl, counts) = (nn, next);
                }
                if e <= 64 {
                    masks.push(
                        counts
                            .chunks(e)
                            .map(|c| {
                                c.iter()
                                    .enumerate()
                                    .fold(0u64, |m, (k, &v)| m | (u64::from(v > 0) << k))
                            })
                            .collect(),
                    );
                }
                let s = 1usize << l;
                let mut shares = vec![0.0f64; nl * nl * e];
                for i in 0..nl {
                    let rows = n.min((i + 1) * s) - i * s;
                    for j in 0..nl {
                        let area = rows * (n.min((j + 1) * s) - j * s);
                        let at = (i * nl + j) * e;
                        share(&counts[at..at + e], area, &mut shares[at..at + e]);
                    }
                }
                levels.push((nl, shares));
            }
        }
        Pyramid {
            n,
            e,
            ext,
            first,
            levels,
            masks,
        }
    }
}

/// The bilinear taps of one level along one axis at every tile pixel: `(a, b, f)`, texel centres at
/// `(i + 0.5) / 2^l − 0.5`, indices clamped to the level's `n_l` texels.
fn axis_taps(n: usize, l: usize) -> Vec<(usize, usize, f64)> {
    let nl = n.div_ceil(1 << l) as i64;
    let s = (1u64 << l) as f64;
    (0..n)
        .map(|i| {
            let u = (i as f64 + 0.5) / s - 0.5;
            let i0 = u.floor();
            let f = u - i0;
            let a = (i0 as i64).clamp(0, nl - 1) as usize;
            let b = (i0 as i64 + 1).clamp(0, nl - 1) as usize;
            (a, b, f)
        })
        .collect()
}

/// A band's plan for tiles of `n` px: `(l0, f)` of `lod = min(L, log2(R + d))` for every border distance `d`,
/// the levels read (`first..=top`, level 0 aside) and every level's taps.
struct Plan {
    lods: Vec<(usize, f64)>,
    first: usize,
    top: usize,
    taps: Vec<Vec<(usize, usize, f64)>>,
}

impl Plan {
    fn new(level: f64, reach: usize, n: usize) -> Plan {
        let lods: Vec<(usize, f64)> = (0..n.div_ceil(2))
            .map(|d| {
                let lod = level.min(((reach + d) as f64).log2());
                let l0 = lod.floor();
                (l0 as usize, lod - l0)
            })
            .collect();
        let first = lods.iter().map(|&(l, _)| l).min().unwrap_or(0).max(1);
        let top = lods
            .iter()
            .map(|&(l, f)| l + usize::from(f > 0.0))
            .max()
            .unwrap_or(0);
        let taps = (0..=top).map(|l| axis_taps(n, l)).collect();
        Plan {
            lods,
            first,
            top,
            taps,
        }
    }
}

/// A band's coverage along one tile row, level by level: every texel column's blend of the row's two texel
/// rows (the first step of the bilinear sample, `c(ya, j)·(1 − fy) + c(yb, j)·fy`, every entry) and the
/// entries covering either, computed on its first use in a segment and shared by the pixels that read it.
#[derive(Default)]
struct RowCache {
    seg: u64,
    levels: Vec<LevelRow>,
    counts: Vec<u32>,
    shares: Vec<f64>,
}

/// One level of a [`RowCache`].
#[derive(Default)]
struct LevelRow {
    ya: usize,
    yb: usize,
    fy: f64,
    vals: Vec<f64>,
    masks: Vec<u64>,
    stamp: Vec<u64>,
}

/// The taps of a band at one pixel: its levels `l0` (and `l0 + 1` when `f > 0`), and per level the offsets of
/// the two texel columns in the row cache and the column fraction; the entries covering some tap (bit `k`);
/// the label of the pixel (level 0's indicator).
struct Taps {
    l0: usize,
    f: f64,
    cols: [(usize, usize, f64); 2],
    mask: u64,
    label: usize,
}

impl RowCache {
    /// Starts a segment of tile row `y` of the pyramid `pyr` of a band planned by `plan`.
    fn begin(&mut self, plan: &Plan, pyr: &Pyramid, y: usize) {
        self.seg += 1;
        if self.levels.len() <= plan.top {
            self.levels.resize_with(plan.top + 1, LevelRow::default);
        }
        for l in plan.first..=plan.top {
            let nl = pyr.n.div_ceil(1 << l);
            let row = &mut self.levels[l];
            (row.ya, row.yb, row.fy) = plan.taps[l][y];
            if row.stamp.len() < nl {
                row.stamp.resize(nl, 0);
                row.masks.resize(nl, 0);
                row.vals.resize(nl * pyr.e, 0.0);
            }
        }
        if self.counts.len() < 2 * pyr.e {
            self.counts.resize(2 * pyr.e, 0);
            self.shares.resize(2 * pyr.e, 0.0);
        }
    }

    /// The shares of texel `(i, j)` of level `l` from the labels (a level the pyramid does not keep) into
    /// `shares`, its entries' counts into `counts`.
    fn block(
        pyr: &Pyramid,
        l: usize,
        (i, j): (usize, usize),
        counts: &mut [u32],
        shares: &mut [f64],
    ) {
        let (n, s) = (pyr.n, 1usize << l);
        counts.iter_mut().for_each(|c| *c = 0);
        let (rows, cols) = (i * s..n.min((i + 1) * s), j * s..n.min((j + 1) * s));
        let area = rows.len() * cols.len();
        for y in rows {
            for &v in &pyr.ext[y * n + cols.start..y * n + cols.end] {
                counts[v as usize] += 1;
            }
        }
        share(counts, area, shares);
    }

    /// The offset of texel column `j` of level `l` in its row's values (computed here on its first use).
    #[inline]
    fn column(&mut self, pyr: &Pyramid, l: usize, j: usize) -> usize {
        let e = pyr.e;
        let row = &mut self.levels[l];
        if row.stamp[j] != self.seg {
            let fy = row.fy;
            let vals = &mut row.vals[j * e..(j + 1) * e];
            if l >= pyr.first {
                let (nl, data) = &pyr.levels[l - pyr.first];
                let (a, b) = ((row.ya * nl + j) * e, (row.yb * nl + j) * e);
                for (k, v) in vals.iter_mut().enumerate() {
                    *v = data[a + k] * (1.0 - fy) + data[b + k] * fy;
                }
                if e <= 64 {
                    let m = &pyr.masks[l - pyr.first];
                    row.masks[j] = m[row.ya * nl + j] | m[row.yb * nl + j];
                }
            } else {
                let (ca, cb) = self.counts.split_at_mut(e);
                let (sa, sb) = self.shares.split_at_mut(e);
                RowCache::block(pyr, l, (row.ya, j), ca, sa);
                RowCache::block(pyr, l, (row.yb, j), cb, sb);
                for (k, v) in vals.iter_mut().enumerate() {
                    *v = sa[k] * (1.0 - fy) + sb[k] * fy;
                }
                if e <= 64 {
                    row.masks[j] = ca
                        .iter()
                        .zip(cb.iter())
                        .enumerate()
                        .fold(0u64, |m, (k, (&a, &b))| m | (u64::from(a + b > 0) << k));
                }
            }
            row.stamp[j] = self.seg;
        }
        j * e
    }

    /// The taps of the band at tile pixel `(y, x)` at border distance `d` (the row begun).
    #[inline]
    fn taps(&mut self, plan: &Plan, pyr: &Pyramid, d: usize, y: usize, x: usize) -> Taps {
        let (l0, f) = plan.lods[d];
        let label = pyr.ext[y * pyr.n + x] as usize;
        let mut taps = Taps {
            l0,
            f,
            cols: [(0, 0, 0.0); 2],
            mask: if pyr.e > 64 { u64::MAX } else { 0 },
            label,
        };
        for (i, l) in (l0..=l0 + usize::from(f > 0.0)).enumerate() {
            if l == 0 {
                taps.mask |= if pyr.e > 64 { u64::MAX } else { 1u64 << label };
                continue;
            }
            let (xa, xb, fx) = plan.taps[l][x];
            let (oa, ob) = (self.column(pyr, l, xa), self.column(pyr, l, xb));
            if pyr.e <= 64 {
                let row = &self.levels[l];
                taps.mask |= row.masks[xa] | row.masks[xb];
            }
            taps.cols[i] = (oa, ob, fx);
        }
        taps
    }

    /// Entry `k`'s weight at the taps `t`: `(1 − f)·C^{l0} + f·C^{l0+1}`, each `C` bilinear (rows first, then
    /// columns: the oracle's order; level 0 the indicator, whose taps have no fraction).
    #[inline]
    fn weight(&self, t: &Taps, k: usize) -> f64 {
        let sample = |i: usize, l: usize| {
            if l == 0 {
                return f64::from(u8::from(t.label == k));
            }
            let (oa, ob, fx) = t.cols[i];
            let v = &self.levels[l].vals;
            v[oa + k] * (1.0 - fx) + v[ob + k] * fx
        };
        let mut w = 0.0 + sample(0, t.l0) * (1.0 - t.f);
        if t.f > 0.0 {
            w += sample(1, t.l0 + 1) * t.f;
        }
        w
    }

    /// Every entry's weight at the taps `t` into `w` (zero on entry, length `e`), given entry `own`'s, `wo`:
    /// when it is 1 the others are 0 (every tap with a non-zero fraction is then all `own`'s), else the weight
    /// of every entry that covers some tap (the others are 0). The entries written (bit `k`: entry `k`; every
    /// entry when `e` > 64).
    #[inline]
    fn fill(&self, t: &Taps, e: usize, own: usize, wo: f64, w: &mut [f64]) -> u64 {
        let own_bit = if e > 64 { u64::MAX } else { 1u64 << own };
        if wo >= 1.0 {
            w[own] = wo;
            return own_bit;
        }
        let mask = t.mask | own_bit;
        for_entries(mask, e, |k| {
            w[k] = if k == own { wo } else { self.weight(t, k) };
        });
        mask
    }
}

/// A map's slices, checked.
struct MapData<'a> {
    kind: Kind,
    turn: Option<Turns>,
    vals: &'a [f64],
    cv: usize,
    lows: Option<&'a [f64]>,
    mu: &'a [f64],
    codes: &'a Samples<'a>,
    c: usize,
}

fn contiguous<'a, T>(name: &'static str, a: &ArrayView3<'a, T>) -> Result<&'a [T]> {
    a.to_slice()
        .ok_or_else(|| TilesynthError::param(name, "a strided view", "must be C-contiguous"))
}

/// Blends the maps `maps` over a window of the tiling by `map` at pixel `offset = (oy, ox)` into its first cell
/// (module docstring), writing each map's `out`. `labels` `(K, N, N)` / `table` `(K, L, 3)` the provenance (an
/// entry's symmetry 0..8, or -1 for none; every entry reads through its symmetry, and a rotated or mirrored
/// entry needs the turns of every normal map, [`MapBlend::turn`]; every label of a tile shown an entry of the
/// table), `bands` the blend's bands: the high band is every map's, the low band the scalar maps' (each then
/// gives its `low`).
pub fn blend_maps(
    maps: &mut [MapBlend<'_>],
    labels: ArrayView3<u8>,
    table: ArrayView3<i32>,
    map: ArrayView2<i32>,
    offset: (usize, usize),
    bands: Bands,
    (h, w): (usize, usize),
) -> Result<()> {
    let (k, n, e) = check_tables(&labels, &table)?;
    for (name, level) in [("high", Some(bands.high)), ("low", bands.low.map(|b| b.0))] {
        if let Some(l) = level {
            if !(0.0..=8.0).contains(&l) {
                return Err(TilesynthError::param(name, l, "a level must be in [0, 8]"));
            }
        }
    }
    if let Some((_, reach)) = bands.low {
        if !(1..=128).contains(&reach) || !reach.is_power_of_two() {
            return Err(TilesynthError::param(
                "reach",
                reach,
                "must be a power of two in [1, 128]",
            ));
        }
    }
    let mut data = Vec::with_capacity(maps.len());
    let (vh, vw) = maps.first().map_or((1, 1), |m| m.size);
    let mut outs: Vec<&mut SamplesMut<'_>> = Vec::with_capacity(maps.len());
    for m in maps.iter_mut() {
        let MapBlend {
            kind,
            size,
            values,
            low,
            mu,
            codes,
            channels,
            out,
            turn,
        } = m;
        let kind = *kind;
        let c = *channels;
        let cv = if kind == Kind::Scalar { c } else { 2 };
        let ncodes = match &*codes {
            Samples::U8(s) => s.len(),
            Samples::U16(s) => s.len(),
            Samples::F32(s) => s.len(),
        };
        let vals_ok = match (kind, &*values) {
            (Kind::Scalar, None) => true,
            (Kind::Normal { .. }, Some(v)) => v.dim() == (vh, vw, 2) && c == 3,
            _ => false,
        };
        if *size != (vh, vw) || vh == 0 || vw == 0 || c == 0 || !vals_ok {
            return Err(TilesynthError::shape(
                "values",
                "None for a scalar map of C >= 1 channels, (H, W, 2) slopes for a normal map of 3 (H, W >= 1, \
                 the first map's size)",
                format!(
                    "{} for {c} channels of {size:?}",
                    values.as_ref().map_or("None".to_string(), |v| fmt_shape(v.shape()))
                ),
            ));
        }
        if ncodes != vh * vw * c || out.len() != h * w * c {
            return Err(TilesynthError::shape(
                "codes/out",
                format!(
                    "({vh}, {vw}, {c}) and ({h}, {w}, {c}) (the values' and the window's pixels)"
                ),
                format!("{ncodes} and {} samples", out.len()),
            ));
        }
        if mu.len() != cv {
            return Err(TilesynthError::shape(
                "mu",
                format!("{cv} means (the channels of values)"),
                format!("{} means", mu.len()),
            ));
        }
        if kind == Kind::Scalar && turn.is_some() {
            return Err(TilesynthError::param(
                "turns",
                "given for a scalar map",
                "only normal maps turn their vectors",
            ));
        }
        let scalar_low = kind == Kind::Scalar && bands.low.is_some();
        let lows = match (&*low, scalar_low) {
            (Some(l), true) if l.dim() == (vh, vw, cv) => Some(contiguous("low", l)?),
            (None, false) => None,
            (got, _) => {
                return Err(TilesynthError::shape(
                    "low",
                    if scalar_low {
                        format!("({vh}, {vw}, {cv}) (the values' low band at every pixel)")
                    } else {
                        "None (a normal map, or a blend without a low band)".to_string()
                    },
                    got.as_ref()
                        .map_or("None".to_string(), |l| fmt_shape(l.shape())),
                ));
            }
        };
        data.push(MapData {
            kind,
            turn: *turn,
            vals: match values {
                Some(v) => contiguous("values", v)?,
                None => &[],
            },
            cv,
            lows,
            mu: &*mu,
            codes: &*codes,
            c,
        });
        outs.push(out);
    }
    check_window(&map, k, n, (h, w), offset)?;
    // a turned normal map without its turns would light the relief from the wrong side: refused
    let unturned = data
        .iter()
        .any(|d| matches!(d.kind, Kind::Normal { .. }) && d.turn.is_none());
    if let Some(&bad) = table
        .index_axis(Axis(2), 0)
        .iter()
        .find(|&&s| !(-1..8).contains(&s) || (unturned && s > 0))
    {
        return Err(TilesynthError::param(
            "table",
            bad,
            if (-1..8).contains(&bad) {
                "a rotated or mirrored entry needs the normal maps' vector turns"
            } else {
                "symmetries must be in 0..8 (or -1 for no entry)"
            },
        ));
    }
    if h == 0 || w == 0 || data.is_empty() {
        return Ok(());
    }
    let lab = labels
        .to_slice()
        .ok_or_else(|| TilesynthError::param("labels", "a strided view", "must be C-contiguous"))?;
    let tab = table.as_standard_layout();
    let tab = tab.as_slice().expect("standard layout");
    let (oy, ox) = offset;
    // the tiles the window shows, their labels checked: every pixel's entry one of the table's
    let mut shown: Vec<usize> = Vec::new();
    for ty in oy / n..=(oy + h - 1) / n {
        for tx in ox / n..=(ox + w - 1) / n {
            shown.push(map[(ty, tx)] as usize);
        }
    }
    shown.sort_unstable();
    shown.dedup();
    for &t in &shown {
        let rows = &tab[t * e * 3..(t + 1) * e * 3];
        if let Some(&bad) = lab[t * n * n..(t + 1) * n * n]
            .iter()
            .find(|&&v| v as usize >= e || rows[v as usize * 3] < 0)
        {
            return Err(TilesynthError::param(
                "labels",
                bad,
                format!("tile {t} has a pixel of an entry that its table row does not have"),
            ));
        }
    }
    let high = Plan::new(bands.high, 1, n);
    let low = bands
        .low
        .map(|(level, reach)| (Plan::new(level, reach, n), reach));
    let any_low = low.is_some() && data.iter().any(|m| m.lows.is_some());
    // the pyramids of the tiles shown, once each, for every map
    let pyramids: Vec<(Pyramid, Option<Pyramid>)> = shown
        .par_iter()
        .map(|&t| {
            let l = &lab[t * n * n..(t + 1) * n * n];
            let hi = Pyramid::new(l, n, e, 1, high.first, high.top);
            let lo = low
                .as_ref()
                .filter(|_| any_low)
                .map(|(p, reach)| Pyramid::new(l, n, e, *reach, p.first, p.top));
            (hi, lo)
        })
        .collect();
    let low = low.filter(|_| any_low).map(|(p, _)| p);
    let (cy0, cx0) = (oy / n, ox / n);
    let ccols = (ox + w - 1) / n - cx0 + 1;
    let cells: Vec<usize> = (cy0..=(oy + h - 1) / n)
        .flat_map(|ty| (cx0..cx0 + ccols).map(move |tx| (ty, tx)))
        .map(|(ty, tx)| {
            shown
                .binary_search(&(map[(ty, tx)] as usize))
                .expect("a shown tile")
        })
        .collect();
    // every map's window split in rows, a row of every map per task
    let mut rows: Vec<Vec<SamplesMut<'_>>> =
        (0..h).map(|_| Vec::with_capacity(data.len())).collect();
    for (out, d) in outs.into_iter().zip(&data) {
        let step = w * d.c;
        match out {
            SamplesMut::U8(s) => {
                for (r, chunk) in rows.iter_mut().zip(s.chunks_mut(step)) {
                    r.push(SamplesMut::U8(chunk));
                }
            }
            SamplesMut::U16(s) => {
                for (r, chunk) in rows.iter_mut().zip(s.chunks_mut(step)) {
                    r.push(SamplesMut::U16(chunk));
                }
            }
            SamplesMut::F32(s) => {
                for (r, chunk) in rows.iter_mut().zip(s.chunks_mut(step)) {
                    r.push(SamplesMut::F32(chunk));
                }
            }
        }
    }
    let ctx = Context {
        n,
        e,
        vh,
        vw,
        lab,
        tab,
        high: &high,
        low: low.as_ref(),
    };
    let cvmax = data.iter().map(|d| d.cv).max().unwrap_or(0);
    rows.into_par_iter()
        .with_min_len(8)
        .enumerate()
        .for_each_init(
            || Segment::new(n, e, cvmax),
            |seg, (y, mut outs)| {
                let gy = y + oy;
                let mut x = 0;
                while x < w {
                    let gx = x + ox;
                    let px0 = gx % n;
                    let end = w.min(x + n - px0);
                    let t = map[(gy / n, gx / n)] as usize;
                    let pyr = &pyramids[cells[(gy / n - cy0) * ccols + gx / n - cx0]];
                    seg.weigh(&ctx, pyr, t, gy % n, px0..px0 + (end - x));
                    for (m, o) in data.iter().zip(outs.iter_mut()) {
                        seg.write(m, o, x);
                    }
                    x = end;
                }
            },
        );
    Ok(())
}

/// What every segment of a window reads: the tile size and entries, the maps' size, the provenance, the bands.
struct Context<'a> {
    n: usize,
    e: usize,
    vh: usize,
    vw: usize,
    lab: &'a [u8],
    tab: &'a [i32],
    high: &'a Plan,
    low: Option<&'a Plan>,
}

/// One pixel of a segment: the exemplar pixel its own entry reads, whether one entry has every weight of the
/// high band (`single_h`) and of both bands (`single`), and its entries with a non-zero weight
/// (`entries[start..end]`, where one of the maps blends it), with `norm = √Σ g²` of the low band's weights.
#[derive(Clone, Copy, Default)]
struct Pixel {
    own_at: usize,
    own_sym: u8,
    single_h: bool,
    single: bool,
    start: usize,
    end: usize,
    norm: f64,
}

/// One entry of a blended pixel: the exemplar pixel it reads, its high and low band weights.
#[derive(Clone, Copy)]
struct Entry {
    at: usize,
    sym: u8,
    wh: f64,
    wl: f64,
}

/// The weights of a run of pixels of one tile row (shared by every map), and the scratch of the blend.
struct Segment {
    len: usize,
    pixels: Vec<Pixel>,
    entries: Vec<Entry>,
    rbase: Vec<usize>,
    wh: Vec<f64>,
    wl: Vec<f64>,
    acc: Vec<f64>,
    lowacc: Vec<f64>,
    hc: RowCache,
    lc: RowCache,
}

/// The entries of `mask` (bit `k`: entry `k`), ascending; every entry below `e` when `e` > 64.
#[inline]
fn for_entries(mask: u64, e: usize, mut f: impl FnMut(usize)) {
    if e > 64 {
        (0..e).for_each(f);
    } else {
        let mut m = mask;
        while m != 0 {
            f(m.trailing_zeros() as usize);
            m &= m - 1;
        }
    }
}

impl Segment {
    fn new(n: usize, e: usize, cv: usize) -> Segment {
        Segment {
            len: 0,
            pixels: vec![Pixel::default(); n],
            entries: Vec::with_capacity(4 * n),
            rbase: vec![0; e],
            wh: vec![0.0; e],
            wl: vec![0.0; e],
            acc: vec![0.0; cv],
            lowacc: vec![0.0; cv],
            hc: RowCache::default(),
            lc: RowCache::default(),
        }
    }

    /// The weights of tile `t`'s pixels `xs` of row `py` (module docstring, steps 2-3): each band's weight of
    /// the pixel's own entry first; where it is below 1, every entry that covers a tap (the others are 0).
    fn weigh(
        &mut self,
        ctx: &Context<'_>,
        (hi, lo): &(Pyramid, Option<Pyramid>),
        t: usize,
        py: usize,
        xs: std::ops::Range<usize>,
    ) {
        let (n, e) = (ctx.n, ctx.e);
        let xs_len = xs.len();
        let tl = &ctx.lab[(t * n + py) * n..(t * n + py + 1) * n];
        let trows = &ctx.tab[t * e * 3..(t + 1) * e * 3];
        for (j, r) in self.rbase.iter_mut().enumerate() {
            *r = mirror(py as i64 + i64::from(trows[j * 3 + 1]), ctx.vh) * ctx.vw;
        }
        // the exemplar pixel entry j reads at tile pixel (py, px): D_s(p) + b, mirrored into the map
        let at = |rbase: &[usize], j: usize, px: usize| {
            let s = trows[j * 3].max(0) as u8;
            if s == 0 {
                rbase[j] + mirror(px as i64 + i64::from(trows[j * 3 + 2]), ctx.vw)
            } else {
                let (dy, dx) = dihedral(s, n, py, px);
                mirror(dy as i64 + i64::from(trows[j * 3 + 1]), ctx.vh) * ctx.vw
                    + mirror(dx as i64 + i64::from(trows[j * 3 + 2]), ctx.vw)
            }
        };
        let sym = |j: usize| trows[j * 3].max(0) as u8;
        let dy = py.min(n - 1 - py);
        self.entries.clear();
        self.hc.begin(ctx.high, hi, py);
        let low = match (ctx.low, lo) {
            (Some(plan), Some(lo)) => {
                self.lc.begin(plan, lo, py);
                Some((plan, lo))
            }
            _ => None,
        };
        for (i, px) in xs.enumerate() {
            let d = dy.min(px.min(n - 1 - px));
            let own = tl[px] as usize;
            let ht = self.hc.taps(ctx.high, hi, d, py, px);
            let ho = self.hc.weight(&ht, own);
            let mut single_h = ho >= 1.0;
            let mut single = single_h;
            let mut low_own = None;
            if let Some((plan, lo)) = low {
                let lt = self.lc.taps(plan, lo, d, py, px);
                let wo = self.lc.weight(&lt, lt.label);
                single &= wo >= 1.0;
                low_own = Some((lt, wo));
            }
            let start = self.entries.len();
            let mut norm = 0.0;
            if !single {
                let mut mask = self.hc.fill(&ht, e, own, ho, &mut self.wh);
                // the oracle's test, some entry of every band with weight 1, over the entries weighed
                let (mut any_h, mut any_l) = (ho >= 1.0, true);
                if let Some((lt, wo)) = low_own {
                    mask |= self.lc.fill(&lt, e, lt.label, wo, &mut self.wl);
                    any_l = wo >= 1.0;
                }
                let mut sq = 0.0f64;
                for_entries(mask, e, |j| {
                    let (wh, wl) = (self.wh[j], self.wl[j]);
                    if wh != 0.0 || wl != 0.0 {
                        any_h |= wh >= 1.0;
                        any_l |= wl >= 1.0;
                        sq += wl * wl; // the entries with no weight add exactly nothing
                        self.entries.push(Entry {
                            at: at(&self.rbase, j, px),
                            sym: sym(j),
                            wh,
                            wl,
                        });
                    }
                    self.wh[j] = 0.0;
                    self.wl[j] = 0.0;
                });
                single_h = any_h;
                single = any_h && any_l;
                norm = sq.sqrt();
            }
            self.pixels[i] = Pixel {
                own_at: at(&self.rbase, own, px),
                own_sym: sym(own),
                single_h,
                single,
                start,
                end: self.entries.len(),
                norm,
            };
        }
        self.len = xs_len;
    }

    /// Writes the segment's pixels of map `m` into its window row `o` from pixel `x0` on.
    fn write(&mut self, m: &MapData<'_>, o: &mut SamplesMut<'_>, x0: usize) {
        match (m.codes, o) {
            (Samples::U8(c), SamplesMut::U8(d)) => self.write_as(m, c, d, x0),
            (Samples::U16(c), SamplesMut::U16(d)) => self.write_as(m, c, d, x0),
            (Samples::F32(c), SamplesMut::F32(d)) => self.write_as(m, c, d, x0),
            _ => unreachable!("codes and out of one sample type (checked)"),
        }
    }

    /// [`Segment::write`] in the map's sample type: the copies where one entry has every weight of the map's
    /// bands, else the blend (module docstring, step 5) encoded.
    fn write_as<T: Code>(&mut self, m: &MapData<'_>, codes: &[T], out: &mut [T], x0: usize) {
        let (c, cv) = (m.c, m.cv);
        let pixels = &self.pixels[..self.len];
        // the common cases with the sums in registers: one-channel scalar maps with a low band, normal maps
        match (m.kind, m.lows, cv) {
            (Kind::Scalar, Some(lows), 1) => {
                let mu = m.mu[0];
                for (i, p) in pixels.iter().enumerate() {
                    out[x0 + i] = if p.single {
                        codes[p.own_at]
                    } else {
                        let (mut lowacc, mut acc) = (0.0f64, 0.0f64);
                        for en in &self.entries[p.start..p.end] {
                            let band = lows[en.at];
                            lowacc += en.wl * band;
                            acc += en.wh * (codes[en.at].value() - band);
                        }
                        // the oracle's `μ + (Σ g a − μ) / √Σ g² + Σ h (v − a)` (a sum of two terms commutes)
                        T::scalar(acc + (mu + (lowacc - mu) / p.norm))
                    };
                }
                return;
            }
            (Kind::Normal { snorm }, _, 2) => {
                for (i, p) in pixels.iter().enumerate() {
                    let o = &mut out[(x0 + i) * 3..(x0 + i + 1) * 3];
                    if p.single_h {
                        let from = &codes[p.own_at * 3..(p.own_at + 1) * 3];
                        (o[0], o[1], o[2]) = (from[0], from[1], from[2]);
                        turn_codes(m.turn.as_ref(), p.own_sym, snorm, o);
                        continue;
                    }
                    let (mut a0, mut a1) = (0.0f64, 0.0f64);
                    for en in &self.entries[p.start..p.end] {
                        if en.wh == 0.0 {
                            continue; // adds exactly nothing: skipped (the same bits as the oracle)
                        }
                        let v = [m.vals[en.at * 2], m.vals[en.at * 2 + 1]];
                        let [v0, v1] = match m.turn {
                            Some(t) if en.sym != 0 => turn_pair(&t[en.sym as usize], v),
                            _ => v,
                        };
                        a0 += en.wh * v0;
                        a1 += en.wh * v1;
                    }
                    o.copy_from_slice(&T::normal([a0, a1, 1.0], snorm));
                }
                return;
            }
            _ => {}
        }
        let (acc, lowacc) = (&mut self.acc[..cv], &mut self.lowacc[..cv]);
        for (i, p) in pixels.iter().enumerate() {
            let o = &mut out[(x0 + i) * c..(x0 + i + 1) * c];
            let single = if m.lows.is_some() {
                p.single
            } else {
                p.single_h
            };
            if single {
                let from = &codes[p.own_at * c..(p.own_at + 1) * c];
                for (q, &v) in o.iter_mut().zip(from) {
                    *q = v; // a loop, not a call to memcpy, for a few samples
                }
                if let Kind::Normal { snorm } = m.kind {
                    turn_codes(m.turn.as_ref(), p.own_sym, snorm, o);
                }
                continue;
            }
            let ents = &self.entries[p.start..p.end];
            acc.iter_mut().for_each(|v| *v = 0.0);
            match m.lows {
                None => {
                    for en in ents {
                        if en.wh == 0.0 {
                            continue; // adds exactly nothing: skipped (the same bits as the oracle)
                        }
                        if m.kind == Kind::Scalar {
                            let vals = &codes[en.at * cv..(en.at + 1) * cv];
                            for (a, &v) in acc.iter_mut().zip(vals) {
                                *a += en.wh * v.value();
                            }
                        } else {
                            let v = [m.vals[en.at * 2], m.vals[en.at * 2 + 1]];
                            let v = match m.turn {
                                Some(t) if en.sym != 0 => turn_pair(&t[en.sym as usize], v),
                                _ => v,
                            };
                            for (a, &v) in acc.iter_mut().zip(&v) {
                                *a += en.wh * v;
                            }
                        }
                    }
                }
                Some(lows) => {
                    lowacc.iter_mut().for_each(|v| *v = 0.0);
                    for en in ents {
                        let at = en.at * cv;
                        for ch in 0..cv {
                            let band = lows[at + ch];
                            lowacc[ch] += en.wl * band;
                            acc[ch] += en.wh * (codes[at + ch].value() - band);
                        }
                    }
                    for ch in 0..cv {
                        // the oracle's `μ + (Σ g a − μ) / √Σ g² + Σ h (v − a)` (a sum of two terms commutes)
                        acc[ch] += m.mu[ch] + (lowacc[ch] - m.mu[ch]) / p.norm;
                    }
                }
            }
            match m.kind {
                Kind::Scalar => {
                    for (q, &v) in o.iter_mut().zip(acc.iter()) {
                        *q = T::scalar(v);
                    }
                }
                Kind::Normal { snorm } => {
                    o.copy_from_slice(&T::normal([acc[0], acc[1], 1.0], snorm))
                }
            }
        }
    }
}

/// `floor(v)` of `v < 2^52`, where a negative `v` may give any value at most 0 (the callers clamp it to 0): a
/// truncation (no libm call: a generic x86-64 build has no floor instruction).
#[inline]
fn floor_small(v: f64) -> f64 {
    if v.is_nan() {
        v
    } else {
        v as i64 as f64
    }
}

/// `rint(v)` (round half to even) of `0 <= v < 2^52`: adding `2^52` leaves no fraction bits, so the sum is
/// rounded to an integer by the FPU's round-half-even (no libm call, the same value).
#[inline]
fn rint_small(v: f64) -> f64 {
    const BIG: f64 = 4_503_599_627_370_496.0;
    (v + BIG) - BIG
}

/// A sample type of the maps: how a blended value is encoded (module docstring, step 6).
/// The first two samples (x, y) of a copied normal code `o` turned by symmetry `s` (none for 0 or without
/// turns): exact in the sample type ([`Code::negate`]).
#[inline]
fn turn_codes<T: Code>(turn: Option<&Turns>, s: u8, snorm: bool, o: &mut [T]) {
    if let Some(t) = turn.filter(|_| s != 0) {
        let old = [o[0], o[1]];
        for (r, &(ch, neg)) in t[s as usize].iter().enumerate() {
            o[r] = if neg { old[ch].negate(snorm) } else { old[ch] };
        }
    }
}

trait Code: Copy {
    /// The sample of the negated vector component: `max − c` for codes, `1 − c` (unorm) or `−c` (snorm) for
    /// floats (`tilesynth.builder.matching.augment.transform_normal_codes`).
    fn negate(self, snorm: bool) -> Self;
    /// What a scalar map blends: the sample over its maximum (numpy's `codes.astype(float64) / S`).
    fn value(self) -> f64;
    /// A scalar map's blended value.
    fn scalar(v: f64) -> Self;
    /// A normal map's blended vector `(σx, σy, 1)`.
    fn normal(v: [f64; 3], snorm: bool) -> [Self; 3];
}

/// The unsigned codes' impl: samples over their maximum `S` (255 or 65535; `f64::from(MAX)` is exact).
macro_rules! code_for_unsigned {
    ($t:ty) => {
        impl Code for $t {
            #[inline]
            fn negate(self, _: bool) -> $t {
                <$t>::MAX - self
            }
            #[inline]
            fn value(self) -> f64 {
                f64::from(self) / f64::from(<$t>::MAX)
            }
            #[inline]
            fn scalar(v: f64) -> $t {
                rint_small(v.clamp(0.0, 1.0) * f64::from(<$t>::MAX)) as $t
            }
            #[inline]
            fn normal(v: [f64; 3], _: bool) -> [$t; 3] {
                encode_unit(v, f64::from(<$t>::MAX)).map(|c| c as $t)
            }
        }
    };
}
code_for_unsigned!(u8);
code_for_unsigned!(u16);

impl Code for f32 {
    #[inline]
    fn negate(self, snorm: bool) -> f32 {
        if snorm {
            -self
        } else {
            1.0 - self
        }
    }
    #[inline]
    fn value(self) -> f64 {
        f64::from(self)
    }
    #[inline]
    fn scalar(v: f64) -> f32 {
        v as f32
    }
    #[inline]
    fn normal(v: [f64; 3], snorm: bool) -> [f32; 3] {
        normalise(v).map(|x| if snorm { x } else { (x + 1.0) * 0.5 } as f32)
    }
}

/// The vector `v` over its length (at least 1e-300), as `encode_unit` normalises.
#[inline]
fn normalise(v: [f64; 3]) -> [f64; 3] {
    let div = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-300);
    [v[0] / div, v[1] / div, v[2] / div]
}
