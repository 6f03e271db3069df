//! The seam blend of smooth material maps over a window of a tiling (`tilesynth.synth.seams`, whose module
//! docstring states the formula; its numpy `blend_tiles` is the oracle of this kernel).
//!
//! Per output pixel: its tile `t` and tile pixel `p` (the index map and offset, as
//! [`crate::provenance::gather_window_into`]); the weights `h_e(p)` of the high band (level `high`, the plain
//! labels) and, with a low band, `g_e(p)` (level `low`, the labels extended `reach` px from the tile border),
//! each a trilinear sample of the tile's coverage pyramid at `lod = min(L, log2(R + d))`; every entry with a
//! non-zero weight read at the pixel (`D_s(p) + b`, mirrored into the map). Out:
//! `μ + (Σ g a − μ) / √Σ g² + Σ h (v − a)` with a low band (`a`: the low band of the value read, given at every pixel), `Σ h v`
//! without. The arithmetic (f64) is done in the oracle's order, so the two agree to the last bit in practice.
//! `single[y, x]` is 1 where one entry has every weight (the pixel is that entry's copy).

use crate::error::{fmt_shape, Result, TilesynthError};
use crate::provenance::{check_window, dihedral};
use ndarray::{ArrayView2, ArrayView3, ArrayViewMut2, ArrayViewMut3, Axis};
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

/// The coverage pyramid of one tile's labels (extended `reach` px from the border): level `l` is
/// `n_l x n_l x E` shares (entry last).
struct Pyramid {
    n: usize,
    e: usize,
    reach: usize,
    ext: Vec<u8>,
    levels: Vec<(usize, Vec<f64>)>,
}

/// The bilinear taps of one pyramid level at one pixel ([`Pyramid::taps`]).
struct Taps {
    l: usize,
    nl: usize,
    ya: usize,
    yb: usize,
    fy: f64,
    xa: usize,
    xb: usize,
    fx: f64,
}

impl Pyramid {
    fn new(lab: &[u8], n: usize, e: usize, reach: usize, top: u32) -> Pyramid {
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
        let mut levels = Vec::with_capacity(top as usize + 1);
        for l in 0..=top {
            let s = 1usize << l;
            let nl = n.div_ceil(s);
            let mut sums = vec![0.0f64; nl * nl * e];
            for y in 0..n {
                for x in 0..n {
                    let v = ext[y * n + x] as usize;
                    if v < e {
                        sums[((y / s) * nl + x / s) * e + v] += 1.0;
                    }
                }
            }
            for i in 0..nl {
                for j in 0..nl {
                    let count =
                        ((n.min((i + 1) * s) - i * s) * (n.min((j + 1) * s) - j * s)) as f64;
                    for v in &mut sums[(i * nl + j) * e..(i * nl + j + 1) * e] {
                        *v /= count;
                    }
                }
            }
            levels.push((nl, sums));
        }
        Pyramid {
            n,
            e,
            reach,
            ext,
            levels,
        }
    }

    /// The label the pyramid was built from at tile pixel `(y, x)` (extended from the border ring).
    #[inline]
    fn label_at(&self, y: usize, x: usize) -> usize {
        self.ext[y * self.n + x] as usize
    }

    /// The bilinear taps of level `l` at tile pixel `(y, x)`: the level's side, its two rows and columns and
    /// the fractions (texel centres at `(i + 0.5) / 2^l - 0.5`, indices clamped to the level).
    #[inline]
    fn taps(&self, l: usize, y: usize, x: usize) -> Taps {
        let nl = self.levels[l].0;
        let s = (1u64 << l) as f64;
        let axis = |i: usize| {
            let u = (i as f64 + 0.5) / s - 0.5;
            let i0 = u.floor();
            let f = u - i0;
            let a = (i0 as i64).clamp(0, nl as i64 - 1) as usize;
            let b = (i0 as i64 + 1).clamp(0, nl as i64 - 1) as usize;
            (a, b, f)
        };
        let (ya, yb, fy) = axis(y);
        let (xa, xb, fx) = axis(x);
        Taps {
            l,
            nl,
            ya,
            yb,
            fy,
            xa,
            xb,
            fx,
        }
    }

    /// Entry `k`'s coverage at the taps `t`, bilinear: rows (y) first, then columns (x), the oracle's order.
    #[inline]
    fn sample(&self, t: &Taps, k: usize) -> f64 {
        let data = &self.levels[t.l].1;
        let (nl, e) = (t.nl, self.e);
        let c = |i: usize, j: usize| data[(i * nl + j) * e + k];
        let left = c(t.ya, t.xa) * (1.0 - t.fy) + c(t.yb, t.xa) * t.fy;
        let right = c(t.ya, t.xb) * (1.0 - t.fy) + c(t.yb, t.xb) * t.fy;
        left * (1.0 - t.fx) + right * t.fx
    }

    /// Adds `scale` times the bilinear sample of level `l` at pixel `(y, x)` to `w` (every entry).
    #[inline]
    fn add_sample(&self, l: usize, y: usize, x: usize, scale: f64, w: &mut [f64]) {
        let t = self.taps(l, y, x);
        for (k, wk) in w.iter_mut().enumerate().take(self.e) {
            *wk += self.sample(&t, k) * scale;
        }
    }

    /// The level and trilinear share of tile pixel `(y, x)` for a band of `level`.
    #[inline]
    fn lod(&self, level: f64, y: usize, x: usize) -> (usize, f64) {
        let n = self.n;
        let d = y.min(x).min(n - 1 - y).min(n - 1 - x);
        let lod = level.min(((self.reach + d) as f64).log2());
        let l0 = lod.floor();
        (l0 as usize, lod - l0)
    }

    /// The weight of entry `k` alone at tile pixel `(y, x)` (the same arithmetic as [`Pyramid::weights`]).
    #[inline]
    fn weight_of(&self, level: f64, y: usize, x: usize, k: usize) -> f64 {
        let (l0, f) = self.lod(level, y, x);
        let mut w = 0.0;
        w += self.sample(&self.taps(l0, y, x), k) * (1.0 - f);
        if f > 0.0 {
            w += self.sample(&self.taps(l0 + 1, y, x), k) * f;
        }
        w
    }

    /// The weights at `(y, x)` into `w`: the own entry's alone first, and when it is 1 the others are 0 (their
    /// coverage is 0 wherever the own entry's is 1), so only mixed pixels pay for every entry.
    #[inline]
    fn weights_fast(&self, level: f64, y: usize, x: usize, own: usize, w: &mut [f64]) {
        let wo = if own < self.e {
            self.weight_of(level, y, x, own)
        } else {
            0.0
        };
        if wo >= 1.0 {
            w.iter_mut().for_each(|v| *v = 0.0);
            w[own] = wo;
        } else {
            self.weights(level, y, x, w);
        }
    }

    /// The weights of every entry at tile pixel `(y, x)` for a band of `level` (into `w`, length `e`).
    fn weights(&self, level: f64, y: usize, x: usize, w: &mut [f64]) {
        let n = self.n;
        let d = y.min(x).min(n - 1 - y).min(n - 1 - x);
        let lod = level.min(((self.reach + d) as f64).log2());
        let l0 = lod.floor();
        let f = lod - l0;
        w.iter_mut().for_each(|v| *v = 0.0);
        self.add_sample(l0 as usize, y, x, 1.0 - f, w);
        if f > 0.0 {
            self.add_sample(l0 as usize + 1, y, x, f, w);
        }
    }
}

/// Checks and runs the blend of a window (module docstring). `values` `(H, W, C)` the map (floats: codes over
/// their maximum, or a normal map's slopes), `low` `(H, W, C)` its low band at every pixel (the box mip at the
/// `split` level sampled bilinearly at the pixel's centre; unused without a low band), `mu` its mean per
/// channel; `labels` / `table` / `map` / `offset` as
/// [`crate::provenance::gather_window_into`] (every entry must be symmetry 0: rotated entries are turned by
/// the caller); `out` `(h, w, C)`, `single` `(h, w)`.
#[allow(clippy::too_many_arguments)]
pub fn blend_window(
    values: ArrayView3<f64>,
    low: ArrayView3<f64>,
    mu: &[f64],
    labels: ArrayView3<u8>,
    table: ArrayView3<i32>,
    map: ArrayView2<i32>,
    offset: (usize, usize),
    bands: Bands,
    mut out: ArrayViewMut3<f64>,
    mut single: ArrayViewMut2<u8>,
) -> Result<()> {
    let (vh, vw, c) = values.dim();
    let (k, n, n2) = labels.dim();
    let (tk, e, three) = table.dim();
    if n != n2 || n == 0 || k == 0 || tk != k || three != 3 || e == 0 || vh == 0 || vw == 0 {
        return Err(TilesynthError::shape(
            "values/labels/table",
            "(H, W, C), (K, N, N) and (K, L, 3) with H, W, K, N, L >= 1",
            format!(
                "{}, {} and {}",
                fmt_shape(values.shape()),
                fmt_shape(labels.shape()),
                fmt_shape(table.shape())
            ),
        ));
    }
    let (h, w, oc) = out.dim();
    if oc != c || single.dim() != (h, w) || mu.len() != c {
        return Err(TilesynthError::shape(
            "out/single/mu",
            format!("(H, W, {c}), (H, W) and {c} means (the channels of values)"),
            format!(
                "{}, {} and {} means",
                fmt_shape(out.shape()),
                fmt_shape(single.shape()),
                mu.len()
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
        if low.dim() != (vh, vw, c) {
            return Err(TilesynthError::shape(
                "low",
                format!("({vh}, {vw}, {c}) (the values' low band at every pixel)"),
                fmt_shape(low.shape()),
            ));
        }
        if !(1..=128).contains(&reach) || !reach.is_power_of_two() {
            return Err(TilesynthError::param(
                "reach",
                reach,
                "must be a power of two in [1, 128]",
            ));
        }
    }
    check_window(&map, k, n, (h, w), offset)?;
    let (oy, ox) = offset;
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
    if h == 0 || w == 0 || c == 0 {
        return Ok(());
    }
    let values = values.as_standard_layout();
    let vals = values.as_slice().expect("standard layout");
    let low = low.as_standard_layout();
    let lows = low.as_slice().expect("standard layout");
    let lab = labels.as_standard_layout();
    let lab = lab.as_slice().expect("standard layout");
    let tab = table.as_standard_layout();
    let tab = tab.as_slice().expect("standard layout");
    // the pyramids of the tiles the window shows, once each
    let mut shown: Vec<usize> = Vec::new();
    for ty in oy / n..=(oy + h - 1) / n {
        for tx in ox / n..=(ox + w - 1) / n {
            shown.push(map[(ty, tx)] as usize);
        }
    }
    shown.sort_unstable();
    shown.dedup();
    let top = |level: f64| level.ceil() as u32;
    let pyramids: Vec<(Pyramid, Option<Pyramid>)> = shown
        .par_iter()
        .map(|&t| {
            let l = &lab[t * n * n..(t + 1) * n * n];
            let hi = Pyramid::new(l, n, e, 1, top(bands.high));
            let lo = bands
                .low
                .map(|(level, reach)| Pyramid::new(l, n, e, reach, top(level)));
            (hi, lo)
        })
        .collect();
    // the pyramid of every cell of the window
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
    let out_s = out
        .as_slice_mut()
        .ok_or_else(|| TilesynthError::param("out", "a strided view", "must be C-contiguous"))?;
    let single_s = single
        .as_slice_mut()
        .ok_or_else(|| TilesynthError::param("single", "a strided view", "must be C-contiguous"))?;
    out_s
        .par_chunks_mut(w * c)
        .zip(single_s.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (orow, srow))| {
            let mut wh = vec![0.0f64; e];
            let mut wl = vec![0.0f64; e];
            let mut acc = vec![0.0f64; c];
            let mut lowacc = vec![0.0f64; c];
            let gy = y + oy;
            for x in 0..w {
                let gx = x + ox;
                let t = map[(gy / n, gx / n)] as usize;
                let (py_, px_) = (gy % n, gx % n);
                let (hi, lo) = &pyramids[cells[(gy / n - cy0) * ccols + gx / n - cx0]];
                let own = lab[(t * n + py_) * n + px_] as usize;
                hi.weights_fast(bands.high, py_, px_, own, &mut wh);
                let mut one = wh.iter().any(|&v| v >= 1.0);
                if let (Some(lo), Some((level, reach))) = (lo, bands.low) {
                    // the low band's labels near the border are the border ring's, not the pixel's own
                    let lown = if reach > 1 {
                        lo.label_at(py_, px_)
                    } else {
                        own
                    };
                    lo.weights_fast(level, py_, px_, lown, &mut wl);
                    one &= wl.iter().any(|&v| v >= 1.0);
                }
                let src = |j: usize| {
                    let row = &tab[(t * e + j) * 3..(t * e + j) * 3 + 3];
                    let (dy, dx) = dihedral(0, n, py_, px_);
                    (
                        mirror(dy as i64 + row[1] as i64, vh),
                        mirror(dx as i64 + row[2] as i64, vw),
                    )
                };
                let o = &mut orow[x * c..(x + 1) * c];
                srow[x] = one as u8;
                if one {
                    let (r, cc) = src(own);
                    o.copy_from_slice(&vals[(r * vw + cc) * c..(r * vw + cc + 1) * c]);
                    continue;
                }
                match bands.low {
                    None => {
                        acc.iter_mut().for_each(|v| *v = 0.0);
                        for (j, &wj) in wh.iter().enumerate() {
                            if wj == 0.0 {
                                continue; // adds exactly nothing: skipped (the same bits as the oracle)
                            }
                            let (r, cc) = src(j);
                            for ch in 0..c {
                                acc[ch] += wj * vals[(r * vw + cc) * c + ch];
                            }
                        }
                        o.copy_from_slice(&acc);
                    }
                    Some(_) => {
                        acc.iter_mut().for_each(|v| *v = 0.0);
                        lowacc.iter_mut().for_each(|v| *v = 0.0);
                        let mut sq = 0.0f64;
                        for j in 0..e {
                            if wh[j] == 0.0 && wl[j] == 0.0 {
                                continue; // adds exactly nothing: skipped (the same bits as the oracle)
                            }
                            let (r, cc) = src(j);
                            let at = (r * vw + cc) * c;
                            for ch in 0..c {
                                let band = lows[at + ch];
                                lowacc[ch] += wl[j] * band;
                                acc[ch] += wh[j] * (vals[at + ch] - band);
                            }
                            sq += wl[j] * wl[j];
                        }
                        let norm = sq.sqrt();
                        for ch in 0..c {
                            o[ch] = mu[ch] + (lowacc[ch] - mu[ch]) / norm + acc[ch];
                        }
                    }
                }
            }
        });
    Ok(())
}
