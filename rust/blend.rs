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
//! the blended slopes `Σ h σ` encoded at unit length ([`encode_unit`], the codes of
//! `tilesynth.io.normal_codes.encode_unit`). A pixel where one entry has every weight of the map's bands is that
//! entry's copy (the map's samples read through the provenance). The arithmetic (f64) is done in the oracle's
//! order, so the two agree to the last bit in practice.
//!
//! All the maps of a window are blended in one pass: the weights of a pixel are found once and shared (the high
//! band by every map, the low band by the scalar maps), the coverage pyramids of the tiles shown are built once
//! per call, and only for the levels the bands read; an entry's weight is found alone first, and only where it
//! is below 1 (near a cut) are the other entries' weights found.

use crate::error::{fmt_shape, Result, TilesynthError};
use crate::provenance::check_window;
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

/// One map of a blend (module docstring): `values` `(H, W, Cv)` what is blended (a scalar map's samples over
/// their maximum, `Cv = C`; a normal map's slopes, `Cv = 2`), `low` its low band at every pixel (scalar maps,
/// when the bands have one), `mu` its mean per channel, `codes` `(H, W, C)` its samples (what the copies
/// read), `out` `(h, w, C)` the window, in the samples' type.
pub struct MapBlend<'a> {
    /// Scalar or normal.
    pub kind: Kind,
    /// `(H, W, Cv)` the values blended.
    pub values: ArrayView3<'a, f64>,
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
    let base = f.map(|x| ((x + 1.0) * half).floor().clamp(0.0, scale));
    let step = 2.0 / scale;
    let bound = 3.0f64.sqrt() / scale * (1.0 + 1e-9);
    let mut best = (f64::INFINITY, [0.0; 3]);
    for corner in 0..8u32 {
        // the corners in numpy's itertools.product order: the last channel varies fastest
        let cand = [
            (base[0] + f64::from((corner >> 2) & 1)).min(scale),
            (base[1] + f64::from((corner >> 1) & 1)).min(scale),
            (base[2] + f64::from(corner & 1)).min(scale),
        ];
        let dec = cand.map(|c| c * step - 1.0);
        let err = ((dec[0] * dec[0] + dec[1] * dec[1] + dec[2] * dec[2]).sqrt() - 1.0).abs();
        let (d0, d1, d2) = (dec[0] - f[0], dec[1] - f[1], dec[2] - f[2]);
        let dist = (d0 * d0 + d1 * d1 + d2 * d2).sqrt();
        let inside = dist <= bound;
        let unit = err <= UNIT_TOLERANCE;
        let key = if inside && unit {
            dist
        } else if unit {
            10.0 + dist
        } else if inside {
            20.0 + err
        } else {
            100.0 + dist
        };
        if key < best.0 || corner == 0 {
            best = (key, cand); // the first of equal keys, as numpy's argmin
        }
    }
    best.1
}

/// The coverage pyramid of one tile's labels (extended `reach` px from the border) at the levels a band reads
/// (from `first` >= 1 up; level 0 is the labels' indicator): level `l` is `n_l x n_l x E` shares (entry last).
struct Pyramid {
    n: usize,
    e: usize,
    ext: Vec<u8>,
    first: usize,
    levels: Vec<(usize, Vec<f64>)>,
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
                for x in 0..n {
                    let (dy, dx) = (y.min(n - 1 - y), x.min(n - 1 - x));
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
                let s = 1usize << l;
                let mut shares = vec![0.0f64; nl * nl * e];
                for i in 0..nl {
                    let rows = n.min((i + 1) * s) - i * s;
                    for j in 0..nl {
                        let area = (rows * (n.min((j + 1) * s) - j * s)) as f64;
                        let at = (i * nl + j) * e;
                        for k in 0..e {
                            shares[at + k] = f64::from(counts[at + k]) / area;
                        }
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

    /// Entry `k`'s coverage at level `l` of `pyr`, bilinear at tile pixel `(y, x)`: rows (y) first, then columns
    /// (x), the oracle's order; level 0 is the indicator (its taps have no fraction).
    #[inline]
    fn sample(&self, pyr: &Pyramid, l: usize, y: usize, x: usize, k: usize) -> f64 {
        if l == 0 {
            return f64::from(u8::from(pyr.ext[y * pyr.n + x] as usize == k));
        }
        let (nl, data) = &pyr.levels[l - pyr.first];
        let (ya, yb, fy) = self.taps[l][y];
        let (xa, xb, fx) = self.taps[l][x];
        let e = pyr.e;
        let c = |i: usize, j: usize| data[(i * nl + j) * e + k];
        let left = c(ya, xa) * (1.0 - fy) + c(yb, xa) * fy;
        let right = c(ya, xb) * (1.0 - fy) + c(yb, xb) * fy;
        left * (1.0 - fx) + right * fx
    }

    /// Entry `k`'s weight at tile pixel `(y, x)` at border distance `d`: `(1 − f)·C^{l0} + f·C^{l0+1}`.
    #[inline]
    fn weight(&self, pyr: &Pyramid, d: usize, y: usize, x: usize, k: usize) -> f64 {
        let (l0, f) = self.lods[d];
        let mut w = 0.0 + self.sample(pyr, l0, y, x, k) * (1.0 - f);
        if f > 0.0 {
            w += self.sample(pyr, l0 + 1, y, x, k) * f;
        }
        w
    }

    /// Every entry's weight at tile pixel `(y, x)` into `w` (length `e`), given entry `own`'s, `wo`: when it
    /// is 1 the others are 0 (every tap with a non-zero fraction is then all `own`'s), else each is found.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn weights(
        &self,
        pyr: &Pyramid,
        d: usize,
        y: usize,
        x: usize,
        own: usize,
        wo: f64,
        w: &mut [f64],
    ) {
        if wo >= 1.0 {
            w.iter_mut().for_each(|v| *v = 0.0);
            w[own] = wo;
        } else {
            for (k, wk) in w.iter_mut().enumerate() {
                *wk = if k == own {
                    wo
                } else {
                    self.weight(pyr, d, y, x, k)
                };
            }
        }
    }
}

/// A map's slices, checked.
struct MapData<'a> {
    kind: Kind,
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
/// (module docstring), writing each map's `out`. `labels` `(K, N, N)` / `table` `(K, L, 3)` the provenance (every
/// entry of symmetry 0, or -1 for none: rotated entries are turned by the caller; every label of a tile shown
/// an entry of the table), `bands` the blend's bands: the high band is every map's, the low band the scalar
/// maps' (each then gives its `low`).
pub fn blend_maps(
    maps: &mut [MapBlend<'_>],
    labels: ArrayView3<u8>,
    table: ArrayView3<i32>,
    map: ArrayView2<i32>,
    offset: (usize, usize),
    bands: Bands,
    (h, w): (usize, usize),
) -> Result<()> {
    let (k, n, n2) = labels.dim();
    let (tk, e, three) = table.dim();
    if n != n2 || n == 0 || k == 0 || tk != k || three != 3 || e == 0 {
        return Err(TilesynthError::shape(
            "labels/table",
            "(K, N, N) and (K, L, 3) with K, N, L >= 1",
            format!(
                "{} and {}",
                fmt_shape(labels.shape()),
                fmt_shape(table.shape())
            ),
        ));
    }
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
    let (vh, vw) = maps
        .first()
        .map_or((1, 1), |m| (m.values.dim().0, m.values.dim().1));
    let mut outs: Vec<&mut SamplesMut<'_>> = Vec::with_capacity(maps.len());
    for m in maps.iter_mut() {
        let MapBlend {
            kind,
            values,
            low,
            mu,
            codes,
            channels,
            out,
        } = m;
        let kind = *kind;
        let cv = values.dim().2;
        let c = *channels;
        let want_cv = if kind == Kind::Scalar { c } else { 2 };
        let ncodes = match &*codes {
            Samples::U8(s) => s.len(),
            Samples::U16(s) => s.len(),
            Samples::F32(s) => s.len(),
        };
        if values.dim() != (vh, vw, cv)
            || vh == 0
            || vw == 0
            || cv != want_cv
            || c == 0
            || (kind != Kind::Scalar && c != 3)
        {
            return Err(TilesynthError::shape(
                "values",
                "(H, W, C) with H, W >= 1 (the first map's) for a scalar map of C >= 1 channels, (H, W, 2) \
                 slopes for a normal map of 3",
                format!("{} for {c} channels", fmt_shape(values.shape())),
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
            vals: contiguous("values", values)?,
            cv,
            lows,
            mu: &*mu,
            codes: &*codes,
            c,
        });
        outs.push(out);
    }
    check_window(&map, k, n, (h, w), offset)?;
    if let Some(&bad) = table
        .index_axis(Axis(2), 0)
        .iter()
        .find(|&&s| s != 0 && s != -1)
    {
        return Err(TilesynthError::param(
            "table",
            bad,
            "only untransformed entries (symmetry 0, or -1 for none) are blended here",
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
    let cvmax = data.iter().map(|d| d.cv).max().unwrap_or(0);
    rows.into_par_iter()
        .with_min_len(8)
        .enumerate()
        .for_each(|(y, mut outs)| {
            let mut wh = vec![0.0f64; e];
            let mut wl = vec![0.0f64; e];
            let mut acc = vec![0.0f64; cvmax];
            let mut lowacc = vec![0.0f64; cvmax];
            let gy = y + oy;
            let (ty, py) = (gy / n, gy % n);
            let dy = py.min(n - 1 - py);
            let mut x = 0;
            while x < w {
                let gx = x + ox;
                let px0 = gx % n;
                let end = w.min(x + n - px0);
                let t = map[(ty, gx / n)] as usize;
                let (hi, lo) = &pyramids[cells[(ty - cy0) * ccols + gx / n - cx0]];
                let tl = &lab[(t * n + py) * n..(t * n + py + 1) * n];
                let trows = &tab[t * e * 3..(t + 1) * e * 3];
                for (xo, px) in (x..end).zip(px0..) {
                    let d = dy.min(px.min(n - 1 - px));
                    let own = tl[px] as usize;
                    let ho = high.weight(hi, d, py, px, own);
                    let mut hfull = false;
                    let mut lfull = false;
                    let (mut lown, mut lo_w) = (0, 1.0);
                    if let (Some(lo), Some((plan, _))) = (lo, &low) {
                        lown = lo.ext[py * n + px] as usize;
                        lo_w = plan.weight(lo, d, py, px, lown);
                    }
                    // the exemplar pixel entry `j` reads at this pixel (mirrored into the maps)
                    let at = |j: usize| {
                        let row = &trows[j * 3..j * 3 + 3];
                        mirror(py as i64 + i64::from(row[1]), vh) * vw
                            + mirror(px as i64 + i64::from(row[2]), vw)
                    };
                    for (m, o) in data.iter().zip(outs.iter_mut()) {
                        let with_low = m.lows.is_some();
                        let mut single = ho >= 1.0 && (!with_low || lo_w >= 1.0);
                        if !single {
                            if !hfull {
                                high.weights(hi, d, py, px, own, ho, &mut wh);
                                hfull = true;
                            }
                            if with_low && !lfull {
                                if let (Some(lo), Some((plan, _))) = (lo, &low) {
                                    plan.weights(lo, d, py, px, lown, lo_w, &mut wl);
                                }
                                lfull = true;
                            }
                            // the oracle's test: some entry of every band has weight 1
                            single = wh.iter().any(|&v| v >= 1.0)
                                && (!with_low || wl.iter().any(|&v| v >= 1.0));
                        }
                        if single {
                            copy_sample(m, o, xo, at(own));
                        } else {
                            blend_pixel(m, o, xo, &at, &wh, &wl, &mut acc, &mut lowacc);
                        }
                    }
                }
                x = end;
            }
        });
    Ok(())
}

/// Writes the samples of exemplar pixel `at` of map `m` to pixel `xo` of its window row `o` (a copy).
#[inline]
fn copy_sample(m: &MapData<'_>, o: &mut SamplesMut<'_>, xo: usize, at: usize) {
    let c = m.c;
    let (from, to) = (at * c..(at + 1) * c, xo * c..(xo + 1) * c);
    match (m.codes, o) {
        (Samples::U8(s), SamplesMut::U8(d)) => d[to].copy_from_slice(&s[from]),
        (Samples::U16(s), SamplesMut::U16(d)) => d[to].copy_from_slice(&s[from]),
        (Samples::F32(s), SamplesMut::F32(d)) => d[to].copy_from_slice(&s[from]),
        _ => unreachable!("codes and out of one sample type (checked)"),
    }
}

/// The vector `v` over its length (at least 1e-300), as `encode_unit` normalises.
#[inline]
fn normalise(v: [f64; 3]) -> [f64; 3] {
    let div = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-300);
    [v[0] / div, v[1] / div, v[2] / div]
}

/// Blends pixel `xo` of map `m` from the entries with a non-zero weight (`at(j)`: the exemplar pixel entry `j`
/// reads) and writes it encoded (module docstring).
#[inline]
#[allow(clippy::too_many_arguments)]
fn blend_pixel(
    m: &MapData<'_>,
    o: &mut SamplesMut<'_>,
    xo: usize,
    at: &impl Fn(usize) -> usize,
    wh: &[f64],
    wl: &[f64],
    acc: &mut [f64],
    lowacc: &mut [f64],
) {
    let cv = m.cv;
    let (acc, lowacc) = (&mut acc[..cv], &mut lowacc[..cv]);
    acc.iter_mut().for_each(|v| *v = 0.0);
    match m.lows {
        None => {
            for (j, &wj) in wh.iter().enumerate() {
                if wj == 0.0 {
                    continue; // adds exactly nothing: skipped (the same bits as the oracle)
                }
                let vals = &m.vals[at(j) * cv..(at(j) + 1) * cv];
                for (a, &v) in acc.iter_mut().zip(vals) {
                    *a += wj * v;
                }
            }
        }
        Some(lows) => {
            lowacc.iter_mut().for_each(|v| *v = 0.0);
            let mut sq = 0.0f64;
            for (j, (&hj, &gj)) in wh.iter().zip(wl).enumerate() {
                if hj == 0.0 && gj == 0.0 {
                    continue; // adds exactly nothing: skipped (the same bits as the oracle)
                }
                let p = at(j) * cv;
                for ch in 0..cv {
                    let band = lows[p + ch];
                    lowacc[ch] += gj * band;
                    acc[ch] += hj * (m.vals[p + ch] - band);
                }
                sq += gj * gj;
            }
            let norm = sq.sqrt();
            for ch in 0..cv {
                // the oracle's `μ + (Σ g a − μ) / √Σ g² + Σ h (v − a)` (a float sum of two terms commutes)
                acc[ch] += m.mu[ch] + (lowacc[ch] - m.mu[ch]) / norm;
            }
        }
    }
    let to = xo * m.c..(xo + 1) * m.c;
    match (m.kind, o) {
        (Kind::Scalar, SamplesMut::U8(d)) => {
            for (q, &v) in d[to].iter_mut().zip(acc.iter()) {
                *q = (v.clamp(0.0, 1.0) * 255.0).round_ties_even() as u8;
            }
        }
        (Kind::Scalar, SamplesMut::U16(d)) => {
            for (q, &v) in d[to].iter_mut().zip(acc.iter()) {
                *q = (v.clamp(0.0, 1.0) * 65535.0).round_ties_even() as u16;
            }
        }
        (Kind::Scalar, SamplesMut::F32(d)) => {
            for (q, &v) in d[to].iter_mut().zip(acc.iter()) {
                *q = v as f32;
            }
        }
        (Kind::Normal { .. }, SamplesMut::U8(d)) => {
            let c = encode_unit([acc[0], acc[1], 1.0], 255.0);
            for (q, v) in d[to].iter_mut().zip(c) {
                *q = v as u8;
            }
        }
        (Kind::Normal { .. }, SamplesMut::U16(d)) => {
            let c = encode_unit([acc[0], acc[1], 1.0], 65535.0);
            for (q, v) in d[to].iter_mut().zip(c) {
                *q = v as u16;
            }
        }
        (Kind::Normal { snorm }, SamplesMut::F32(d)) => {
            let f = normalise([acc[0], acc[1], 1.0]);
            for (q, v) in d[to].iter_mut().zip(f) {
                *q = if snorm { v } else { (v + 1.0) * 0.5 } as f32;
            }
        }
    }
}
