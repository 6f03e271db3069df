//! Exhaustive sum of squared differences (SSD) of a multi-channel template over every fully-overlapping
//! translation of an image.
//!
//! For an image `I` of shape `(H, W, C)`, a template `T` of shape `(h, w, C)` and an optional mask `m` of
//! shape `(h, w)`, the SSD map has shape `(H - h + 1, W - w + 1)` and
//!
//! ```text
//! map[ty, tx] = sum_{py, px, c} m[py, px] * (T[py, px, c] - I[ty + py, tx + px, c])^2
//!             = sum m T^2  +  sum_window m S  -  2 sum_c corr(m T_c, I_c)       (S = sum_c I_c^2)
//! ```
//!
//! The correlations are computed with real 2-D FFTs at FFT size = image size: a valid correlation with an
//! image-sized circular correlation is exact, because the circular wrap only touches invalid offsets.
//! Everything that depends only on the image (the spectra of every channel and of `S`, an integral image of
//! `S`) is computed once in [`SsdIndex::new`]; a template then costs `C` forward transforms (`C + 1` with a
//! mask), a product accumulated in the frequency domain, and a single inverse transform.
//!
//! ## Precision
//!
//! All transforms run in `f64` (the input data is `f32`). This keeps the rounding error of the FFT map
//! provably tiny (about `1e-16 * log2(HW) * ||T|| * ||I||`), so [`SsdIndex::best_matches`] can re-rank the
//! best candidates with the exact direct sum while re-evaluating only genuine near-ties.
//!
//! ## Layout of the 2-D transform
//!
//! `realfft` provides real-to-complex transforms only (and `rustfft` is not a direct dependency), so the
//! 2-D spectrum is built as: real FFT of every row (length `W`, giving `W/2 + 1` complex columns), then for
//! every column `kx` a real FFT of the real part and one of the imaginary part along `y` (half spectra `A`
//! and `B` of length `H/2 + 1`). Since both are spectra of real sequences, the full complex column spectrum
//! is `F[k] = A[k] + i B[k]` and `F[H - k] = conj(A[k]) + i conj(B[k])`, so the half range `k <= H/2`
//! gives both `G[k] = sum conj(T[k]) I[k]` and `G[H - k]`. The image side is stored as `(I[k], I[H - k])`.
//! The inverse column transform of `G` is split into the half spectra of its real part,
//! `P = (G[k] + conj(G[H - k])) / 2`, and of its imaginary part, `Q = (G[k] - conj(G[H - k])) / 2i`, each
//! inverted with one real inverse FFT; a complex-to-real inverse FFT along each valid row then gives the
//! map. Padding rows of the template are never transformed and only the valid rows of the result are
//! inverted. Intermediate arrays use row- and column-blocked layouts so that the transposes read and write
//! contiguous runs.
//!
//! ## Exact best matches
//!
//! The FFT map `F` satisfies `|F(t) - E(t)| <= B` for the exact SSD `E`, with the norm-wise bound
//! `B = 3 a sum_planes (||x||_2 ||y||_1 + ||x||_1 ||y||_2)` (`x`: template side, `y`: image side,
//! `a = 16 eps (ceil(log2 H) + ceil(log2 W) + 8)`, a generous constant per FFT level covering mixed-radix
//! and Bluestein algorithms) plus the rounding of the final sums and of the integral image. Every
//! translation whose FFT value is `<= E(t0) + B` (`t0` the FFT argmin) is re-evaluated directly, so no
//! exact winner can be missed. With `f64` transforms `B` is around `1e-9` relative, so in practice only the
//! FFT argmin itself (and exact ties) are re-evaluated.
//!
//! Parallelism (rayon, within one call for large images; over templates in [`ssd_maps`]) splits work into
//! fixed blocks of rows or columns whose results never depend on the thread count, so outputs are
//! bit-identical at any number of threads.

use crate::error::{fmt_shape, Result, TilesynthError};
use ndarray::{Array2, Array3, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::borrow::Cow;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

type C64 = Complex<f64>;

const CZERO: C64 = C64 { re: 0.0, im: 0.0 };

/// Images with at least this many pixels run the stages of one call in parallel (rayon).
const PAR_MIN_PIXELS: usize = 100 * 100;
/// Spectrum columns per task of the column stage.
const COL_BLOCK: usize = 4;
/// Padding (in `f64`) between gathered columns of the column stage.
const COL_PAD: usize = 24;
/// Padding (in complex values) between rows buffered by the row stages.
const ROW_PAD: usize = 12;
/// Rows per task of the row stages.
const ROW_BLOCK: usize = 8;

/// One best translation: its top-left corner `(row, col)` in the image and its exact (`f64`) SSD.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// Row of the template's top-left corner in the image.
    pub row: usize,
    /// Column of the template's top-left corner in the image.
    pub col: usize,
    /// The SSD at this translation, as the direct `f64` sum.
    pub ssd: f64,
}

/// The FFT plans of one image size (all `Arc`, `Send + Sync`).
struct Plans {
    fwd_w: Arc<dyn RealToComplex<f64>>,
    inv_w: Arc<dyn ComplexToReal<f64>>,
    fwd_h: Arc<dyn RealToComplex<f64>>,
    inv_h: Arc<dyn ComplexToReal<f64>>,
}

impl Plans {
    /// Plans for an `h x w` image, from a process-wide planner (plans are cached and shared).
    fn new(h: usize, w: usize) -> Plans {
        static PLANNER: Mutex<Option<RealFftPlanner<f64>>> = Mutex::new(None);
        let mut guard = PLANNER.lock().unwrap_or_else(|e| e.into_inner());
        let planner = guard.get_or_insert_with(RealFftPlanner::new);
        Plans {
            fwd_w: planner.plan_fft_forward(w),
            inv_w: planner.plan_fft_inverse(w),
            fwd_h: planner.plan_fft_forward(h),
            inv_h: planner.plan_fft_inverse(h),
        }
    }

    fn scratch_len(&self) -> usize {
        self.fwd_w
            .get_scratch_len()
            .max(self.inv_w.get_scratch_len())
            .max(self.fwd_h.get_scratch_len())
            .max(self.inv_h.get_scratch_len())
    }
}

/// Everything that depends only on the image, computed once: per-channel real FFT spectra at FFT size =
/// image size (valid correlation with an image-sized FFT is exact: circular wrap only touches invalid
/// offsets), the spectrum of `S = sum_c I_c^2` (for masked SSD), and an `f64` integral image of `S` (box sums
/// for the unmasked case). Keeps a copy of the image for the exact direct sums. `Send + Sync`.
pub struct SsdIndex {
    h: usize,
    w: usize,
    c: usize,
    /// Half-spectrum lengths: `H/2 + 1` and `W/2 + 1`.
    hc: usize,
    wc: usize,
    /// The image, `(H, W, C)` C-contiguous.
    image: Vec<f32>,
    /// Spectra, laid out `[kx][plane][F[k] | F[H - k]][k]` for `k < H/2 + 1`, with `C + 1` planes (the
    /// channels, then `S`).
    spec: Vec<C64>,
    /// Integral image of `S`, `(H + 1, W + 1)`.
    integral: Vec<f64>,
    /// `(l1, l2)` norms of every plane, for the FFT error bound.
    norms: Vec<(f64, f64)>,
    /// Sum of `S` over the image.
    s_total: f64,
    plans: Plans,
}

/// A validated template, borrowed when C-contiguous, copied otherwise.
struct Tmpl<'a> {
    h: usize,
    w: usize,
    data: Cow<'a, [f32]>,
}

impl SsdIndex {
    /// Builds the index of `image` `(H, W, C)` (any strides; `H, W, C >= 1`; finite values).
    pub fn new(image: ArrayView3<f32>) -> Result<SsdIndex> {
        let (h, w, c) = image.dim();
        if h == 0 || w == 0 || c == 0 {
            return Err(TilesynthError::shape(
                "image",
                "(H, W, C) with H, W, C >= 1",
                fmt_shape(image.shape()),
            ));
        }
        let data = contiguous_finite("image", image)?;
        let plans = Plans::new(h, w);
        let (hc, wc) = (h / 2 + 1, w / 2 + 1);
        let np = c + 1;

        // S = sum_c I_c^2, its integral image and the plane norms.
        let s: Vec<f64> = data
            .chunks_exact(c)
            .map(|px| px.iter().map(|&v| (v as f64) * (v as f64)).sum())
            .collect();
        let mut integral = vec![0.0f64; (h + 1) * (w + 1)];
        for y in 0..h {
            let mut run = 0.0;
            for x in 0..w {
                run += s[y * w + x];
                integral[(y + 1) * (w + 1) + x + 1] = integral[y * (w + 1) + x + 1] + run;
            }
        }
        let mut norms = vec![(0.0f64, 0.0f64); np];
        for px in data.chunks_exact(c) {
            for (ch, &v) in px.iter().enumerate() {
                let v = v as f64;
                norms[ch].0 += v.abs();
                norms[ch].1 += v * v;
            }
        }
        let s_total: f64 = s.iter().sum();
        norms[c] = (s_total, s.iter().map(|v| v * v).sum());
        for n in norms.iter_mut() {
            n.1 = n.1.sqrt();
        }

        let par = h * w >= PAR_MIN_PIXELS;
        // Row stage: every row of every plane.
        let rt = row_spectra(&plans, np, h, w, wc, par, &|plane, y, buf| {
            if plane < c {
                let row = &data[y * w * c..(y + 1) * w * c];
                for (b, px) in buf.iter_mut().zip(row.chunks_exact(c)) {
                    *b = px[plane] as f64;
                }
            } else {
                buf.copy_from_slice(&s[y * w..(y + 1) * w]);
            }
        });

        // Column stage: half spectra A, B of every column of every plane.
        let mut spec = vec![CZERO; wc * np * 2 * hc];
        let block_len = COL_BLOCK * np * 2 * hc;
        let scratch_len = plans.scratch_len();
        for_each_block(
            &mut spec,
            block_len,
            par,
            || ColWork::new(h, hc, scratch_len),
            |work, bi, out| {
                let kx0 = bi * COL_BLOCK;
                let nb = out.len() / (np * 2 * hc);
                for plane in 0..np {
                    work.gather(&rt, plane, h, wc, kx0, nb, h);
                    for j in 0..nb {
                        let o = &mut out[(j * np + plane) * 2 * hc..][..2 * hc];
                        let (fk, fm) = o.split_at_mut(hc);
                        work.forward(&plans, j, fk, fm);
                        // (A, B) -> (F[k], F[H - k]) = (A + iB, conj(A) + i conj(B)) for k < H/2 + 1.
                        for (x, y) in fk.iter_mut().zip(fm.iter_mut()) {
                            let (a, b) = (*x, *y);
                            *x = C64::new(a.re - b.im, a.im + b.re);
                            *y = C64::new(a.re + b.im, b.re - a.im);
                        }
                    }
                }
            },
        );

        Ok(SsdIndex {
            h,
            w,
            c,
            hc,
            wc,
            image: data.into_owned(),
            spec,
            integral,
            norms,
            s_total,
            plans,
        })
    }

    /// `(H, W, C)` of the indexed image.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.h, self.w, self.c)
    }

    /// The shape `(H - h + 1, W - w + 1)` of the map of a `(h, w, C)` template (no validation).
    fn map_dim(&self, h: usize, w: usize) -> (usize, usize) {
        (self.h + 1 - h, self.w + 1 - w)
    }

    /// The full SSD map (`f32`, shape `(H - h + 1, W - w + 1)`), via FFT:
    /// `sum m T^2 + boxsum/corr(m, S) - 2 sum_c corr(m T_c, I_c)`, clamped at 0.
    /// Accurate to about `1e-12` relative to the largest term (the FFTs run in `f64`).
    pub fn ssd_map(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
    ) -> Result<Array2<f32>> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        let (map, _) = self.fft_map(&t, m.as_deref());
        let dim = self.map_dim(t.h, t.w);
        let v: Vec<f32> = map.iter().map(|&x| x as f32).collect();
        Ok(Array2::from_shape_vec(dim, v).expect("map length matches its shape"))
    }

    /// The SSD map in `f64` (same computation as [`SsdIndex::ssd_map`] without the final rounding to `f32`),
    /// together with a rigorous-enough bound on its absolute error against the exact SSD.
    pub fn ssd_map_f64(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
    ) -> Result<(Array2<f64>, f64)> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        let (map, bound) = self.fft_map(&t, m.as_deref());
        let dim = self.map_dim(t.h, t.w);
        Ok((
            Array2::from_shape_vec(dim, map).expect("map length matches its shape"),
            bound,
        ))
    }

    /// The `k` best translations with EXACT `f64` SSD values, best first. Candidates are chosen greedily:
    /// the best, then the best whose translation is at Chebyshev distance `> exclude_radius` from every one
    /// already chosen (`exclude_radius = 0`: simply distinct translations). Exactness: after the FFT map,
    /// every translation whose FFT value is within a rigorous-enough error bound of the current candidate is
    /// re-evaluated directly in `f64` (a plain loop over the template, see [`SsdIndex::ssd_at`]), so the
    /// returned order and values are those of the exact SSD (ties broken by smaller `(row, col)`).
    /// Returns fewer than `k` if fewer translations exist (`k = 0`: empty).
    ///
    /// Cost: one FFT map, then one direct sum per candidate; only on large exact ties (flat images with a
    /// flat template) do many translations need the direct sum.
    pub fn best_matches(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
        k: usize,
        exclude_radius: usize,
    ) -> Result<Vec<Match>> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        Ok(self.best_prepared(&t, m.as_deref(), k, exclude_radius))
    }

    /// Exact `f64` SSD at one translation `(row, col)` (the direct sum over the template) — used by
    /// [`SsdIndex::best_matches`] and useful to callers. `row <= H - h`, `col <= W - w`.
    pub fn ssd_at(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
        row: usize,
        col: usize,
    ) -> Result<f64> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        let (mh, mw) = self.map_dim(t.h, t.w);
        if row >= mh {
            return Err(TilesynthError::param(
                "row",
                row,
                format!("must be <= H - h = {}", mh - 1),
            ));
        }
        if col >= mw {
            return Err(TilesynthError::param(
                "col",
                col,
                format!("must be <= W - w = {}", mw - 1),
            ));
        }
        Ok(self.exact(&t, m.as_deref(), row, col))
    }

    /// Checks a template against the index and copies it into a contiguous buffer.
    fn prepare_template<'a>(
        &self,
        name: &'static str,
        template: ArrayView3<'a, f32>,
    ) -> Result<Tmpl<'a>> {
        let (h, w, c) = template.dim();
        if h == 0 || w == 0 || h > self.h || w > self.w || c != self.c {
            return Err(TilesynthError::shape(
                name,
                format!(
                    "(h, w, {}) with 1 <= h <= {} and 1 <= w <= {} (the image is {})",
                    self.c,
                    self.h,
                    self.w,
                    fmt_shape(&[self.h, self.w, self.c])
                ),
                fmt_shape(template.shape()),
            ));
        }
        Ok(Tmpl {
            h,
            w,
            data: contiguous_finite(name, template)?,
        })
    }

    /// The direct `f64` SSD at `(ty, tx)` (no validation). Fixed summation order.
    fn exact(&self, t: &Tmpl, mask: Option<&[bool]>, ty: usize, tx: usize) -> f64 {
        let c = self.c;
        let row_len = t.w * c;
        let mut acc = [0.0f64; 4];
        for py in 0..t.h {
            let tr = &t.data[py * row_len..(py + 1) * row_len];
            let start = ((ty + py) * self.w + tx) * c;
            let ir = &self.image[start..start + row_len];
            match mask {
                None => {
                    let mut tc = tr.chunks_exact(4);
                    let mut ic = ir.chunks_exact(4);
                    for (a, b) in (&mut tc).zip(&mut ic) {
                        for l in 0..4 {
                            let d = a[l] as f64 - b[l] as f64;
                            acc[l] += d * d;
                        }
                    }
                    for (&a, &b) in tc.remainder().iter().zip(ic.remainder()) {
                        let d = a as f64 - b as f64;
                        acc[0] += d * d;
                    }
                }
                Some(m) => {
                    let mr = &m[py * t.w..(py + 1) * t.w];
                    for (px, &on) in mr.iter().enumerate() {
                        if on {
                            for ch in 0..c {
                                let d = tr[px * c + ch] as f64 - ir[px * c + ch] as f64;
                                acc[ch & 3] += d * d;
                            }
                        }
                    }
                }
            }
        }
        (acc[0] + acc[1]) + (acc[2] + acc[3])
    }

    /// The FFT map in `f64` (row-major, clamped at 0) and the bound on its absolute error.
    fn fft_map(&self, t: &Tmpl, mask: Option<&[bool]>) -> (Vec<f64>, f64) {
        let (hh, ww, c) = (self.h, self.w, self.c);
        let (hc, wc) = (self.hc, self.wc);
        let (th, tw) = (t.h, t.w);
        let (mh, mw) = self.map_dim(th, tw);
        let par = hh * ww >= PAR_MIN_PIXELS;
        // Template-side planes: -2 m T_c for every channel, then m (masked only). Scaling by -2 is exact.
        let np = if mask.is_some() { c + 1 } else { c };
        let data = &t.data;

        // The constant term sum m T^2 and the norms of the template side (for the error bound), as
        // lane-parallel sums (fixed order, vectorisable): sq = sum m T^2, l1 = sum m |T|, over all channels.
        let (sum_t2, l1) =
            match mask {
                None => lane_sums(data.iter().map(|&v| v as f64)),
                Some(m) => lane_sums(data.chunks_exact(c).zip(m).flat_map(|(px, &on)| {
                    px.iter().map(move |&v| if on { v as f64 } else { 0.0 })
                })),
            };
        let nnz = mask.map_or(0, |m| m.iter().filter(|&&on| on).count()) as f64;

        // Row stage: only the h template rows (the padding rows have zero spectra).
        let rt = row_spectra(&self.plans, np, th, ww, wc, par, &|plane, y, buf| {
            let row = &data[y * tw * c..(y + 1) * tw * c];
            let (head, tail) = buf.split_at_mut(tw);
            tail.fill(0.0);
            match mask {
                None => {
                    for (b, px) in head.iter_mut().zip(row.chunks_exact(c)) {
                        *b = -2.0 * px[plane] as f64;
                    }
                }
                Some(m) => {
                    let mr = &m[y * tw..(y + 1) * tw];
                    for ((b, px), &on) in head.iter_mut().zip(row.chunks_exact(c)).zip(mr) {
                        *b = match (on, plane < c) {
                            (false, _) => 0.0,
                            (true, true) => -2.0 * px[plane] as f64,
                            (true, false) => 1.0,
                        };
                    }
                }
            }
        });

        // Column stage: forward column transforms of the template, product with the image spectra
        // accumulated over planes, inverse column transforms; keeps the mh valid rows, laid out
        // [kx / CB][y / RB][kx % CB][y % RB] (CB = COL_BLOCK, RB = ROW_BLOCK) so that both this stage
        // and the row stage below write and read contiguous runs.
        let nkb = wc.div_ceil(COL_BLOCK);
        let nyb = mh.div_ceil(ROW_BLOCK);
        let zblock = nyb * COL_BLOCK * ROW_BLOCK;
        let mut zt = vec![CZERO; nkb * zblock];
        let scratch_len = self.plans.scratch_len();
        let nsp = c + 1;
        for_each_block(
            &mut zt,
            zblock,
            par,
            || ColWork::new(hh, hc, scratch_len),
            |work, bi, out| {
                let kx0 = bi * COL_BLOCK;
                let nb = COL_BLOCK.min(wc - kx0);
                work.pq.fill(CZERO);
                for plane in 0..np {
                    let ip = if plane < c { plane } else { c };
                    work.gather(&rt, plane, th, wc, kx0, nb, hh);
                    for j in 0..nb {
                        let kx = kx0 + j;
                        work.forward_to_ab(&self.plans, j);
                        let img = &self.spec[(kx * nsp + ip) * 2 * hc..][..2 * hc];
                        let (ci, di) = img.split_at(hc);
                        let (p, q) = work.pq[j * 2 * hc..(j + 1) * 2 * hc].split_at_mut(hc);
                        let (a, b) = work.ab.split_at(hc);
                        // With u = a + ib = T[k] and v = conj(a) + i conj(b) = T[H - k]:
                        // G[k] += conj(u) I[k],  G[H - k] += conj(v) I[H - k].
                        for ky in 0..hc {
                            let (a, b, fk, fm) = (a[ky], b[ky], ci[ky], di[ky]);
                            let (ur, ui) = (a.re - b.im, a.im + b.re);
                            let (vr, vi) = (a.re + b.im, b.re - a.im);
                            p[ky].re += ur * fk.re + ui * fk.im;
                            p[ky].im += ur * fk.im - ui * fk.re;
                            q[ky].re += vr * fm.re + vi * fm.im;
                            q[ky].im += vr * fm.im - vi * fm.re;
                        }
                    }
                }
                for j in 0..nb {
                    let (re, im) = work.inverse_pq(&self.plans, j);
                    for (yb, blk) in out.chunks_exact_mut(COL_BLOCK * ROW_BLOCK).enumerate() {
                        let y0 = yb * ROW_BLOCK;
                        let nr = ROW_BLOCK.min(mh - y0);
                        let run = &mut blk[j * ROW_BLOCK..j * ROW_BLOCK + nr];
                        for (i, o) in run.iter_mut().enumerate() {
                            *o = C64::new(re[y0 + i], im[y0 + i]);
                        }
                    }
                }
            },
        );

        // Row stage of the inverse: the mh valid rows, plus the constant terms.
        let mut map = vec![0.0f64; mh * mw];
        // 1/2 from the P, Q reconstruction, 1/(HW) for the unnormalised transforms.
        let scale = 0.5 / (hh as f64 * ww as f64);
        let w_even = ww % 2 == 0;
        let integral = &self.integral;
        let iw = ww + 1;
        for_each_block(
            &mut map,
            ROW_BLOCK * mw,
            par,
            || RowInvWork::new(ww, wc, scratch_len),
            |work, bi, out| {
                let y0 = bi * ROW_BLOCK;
                let nr = out.len() / mw;
                let rs = wc + ROW_PAD;
                for kx in 0..wc {
                    let (kb, jj) = (kx / COL_BLOCK, kx % COL_BLOCK);
                    let run = &zt[kb * zblock + (bi * COL_BLOCK + jj) * ROW_BLOCK..][..nr];
                    for (j, &v) in run.iter().enumerate() {
                        work.rows[j * rs + kx] = v;
                    }
                }
                for j in 0..nr {
                    let spec_row = &mut work.rows[j * rs..j * rs + wc];
                    spec_row[0].im = 0.0;
                    if w_even {
                        spec_row[wc - 1].im = 0.0;
                    }
                    let r = self.plans.inv_w.process_with_scratch(
                        spec_row,
                        &mut work.out,
                        &mut work.scratch,
                    );
                    debug_assert!(r.is_ok());
                    let y = y0 + j;
                    let orow = &mut out[j * mw..(j + 1) * mw];
                    if mask.is_some() {
                        for (o, &z) in orow.iter_mut().zip(&work.out[..mw]) {
                            *o = (sum_t2 + z * scale).max(0.0);
                        }
                    } else {
                        let (top, bot) = (&integral[y * iw..], &integral[(y + th) * iw..]);
                        let (tl, tr) = (&top[..mw], &top[tw..tw + mw]);
                        let (bl, br) = (&bot[..mw], &bot[tw..tw + mw]);
                        for x in 0..mw {
                            let boxsum = (br[x] - tr[x]) - (bl[x] - tl[x]);
                            orow[x] = (sum_t2 + boxsum + work.out[x] * scale).max(0.0);
                        }
                    }
                }
            },
        );

        // Error bound (see the module docs): per plane pair, the FFT correlation error is at most
        // ~ 3 a (||x||_2 ||y||_1 + ||x||_1 ||y||_2) with a = (rounding per FFT level) * (levels), plus the
        // rounding of the final sums and of the integral image.
        let eps = f64::EPSILON;
        let levels = (ceil_log2(hh) + ceil_log2(ww) + 8) as f64;
        let a = 16.0 * eps * levels;
        // Template side: the planes -2 m T_c (sum_c ||x_c||_2 <= sqrt(C) * 2 sqrt(sum_t2) and
        // sum_c ||x_c||_1 = 2 l1) against the largest image channel norms; then m against S.
        let (y1, y2) = self.norms[..c]
            .iter()
            .fold((0.0f64, 0.0f64), |(a, b), &(n1, n2)| (a.max(n1), b.max(n2)));
        let x2 = 2.0 * (c as f64).sqrt() * sum_t2.sqrt();
        let x1 = 2.0 * l1;
        let mut fft_err = 3.0 * a * (x2 * y1 + x1 * y2);
        let mut zmax = x2 * y2;
        if mask.is_some() {
            let (s1, s2) = self.norms[c];
            fft_err += 3.0 * a * (nnz.sqrt() * s1 + nnz * s2);
            zmax += nnz.sqrt() * s2;
        }
        let box_err = 4.0 * (hh + ww + 4) as f64 * eps * self.s_total;
        let sum_err = 8.0 * eps * (sum_t2 + self.s_total + zmax);
        (map, fft_err + box_err + sum_err)
    }

    /// Greedy exact best matches on a prepared template.
    fn best_prepared(&self, t: &Tmpl, mask: Option<&[bool]>, k: usize, r: usize) -> Vec<Match> {
        let (mh, mw) = self.map_dim(t.h, t.w);
        let n = mh * mw;
        let k = k.min(n);
        if k == 0 {
            return Vec::new();
        }
        let (map, bound) = self.fft_map(t, mask);
        let mut exact_cache: HashMap<usize, f64> = HashMap::new();
        let mut excluded = if k > 1 { vec![false; n] } else { Vec::new() };
        let allowed = |ex: &[bool], i: usize| ex.is_empty() || !ex[i];
        let mut out = Vec::with_capacity(k);
        for _ in 0..k {
            // The smallest FFT value among the allowed translations.
            let mut i0 = usize::MAX;
            let mut f0 = f64::INFINITY;
            for (i, &f) in map.iter().enumerate() {
                if f < f0 && allowed(&excluded, i) {
                    f0 = f;
                    i0 = i;
                }
            }
            if i0 == usize::MAX {
                break;
            }
            let e0 = *exact_cache
                .entry(i0)
                .or_insert_with(|| self.exact(t, mask, i0 / mw, i0 % mw));
            // Every allowed translation that could beat (e0, i0) exactly.
            let thr = e0 + bound;
            let cands: Vec<usize> = map
                .iter()
                .enumerate()
                .filter(|&(i, &f)| f <= thr && i != i0 && allowed(&excluded, i))
                .map(|(i, _)| i)
                .collect();
            let todo: Vec<usize> = cands
                .iter()
                .copied()
                .filter(|i| !exact_cache.contains_key(i))
                .collect();
            let vals: Vec<f64> = if todo.len() >= 64 {
                todo.par_iter()
                    .map(|&i| self.exact(t, mask, i / mw, i % mw))
                    .collect()
            } else {
                todo.iter()
                    .map(|&i| self.exact(t, mask, i / mw, i % mw))
                    .collect()
            };
            exact_cache.extend(todo.into_iter().zip(vals));
            let mut best = (e0, i0);
            for &i in &cands {
                let e = exact_cache[&i];
                if e < best.0 || (e == best.0 && i < best.1) {
                    best = (e, i);
                }
            }
            let (e, i) = best;
            let (row, col) = (i / mw, i % mw);
            out.push(Match { row, col, ssd: e });
            if k > 1 {
                for yy in row.saturating_sub(r)..=row.saturating_add(r).min(mh - 1) {
                    let line = &mut excluded[yy * mw..(yy + 1) * mw];
                    line[col.saturating_sub(r)..=col.saturating_add(r).min(mw - 1)].fill(true);
                }
            }
        }
        out
    }
}

/// Many templates against one index, in parallel over templates (rayon; call it inside
/// [`crate::parallel::install`] at the binding layer). `templates`: `(K, h, w, C)`; `mask`: `(h, w)`.
/// Returns `(K, H - h + 1, W - w + 1)`, each map as from [`SsdIndex::ssd_map`].
pub fn ssd_maps(
    index: &SsdIndex,
    templates: ArrayView4<f32>,
    mask: Option<ArrayView2<bool>>,
) -> Result<Array3<f32>> {
    let (ts, m) = prepare_many(index, templates, mask)?;
    let (_, h, w, _) = templates.dim();
    let (mh, mw) = index.map_dim(h, w);
    let mut out = Array3::<f32>::zeros((ts.len(), mh, mw));
    out.axis_iter_mut(Axis(0))
        .into_par_iter()
        .zip(ts.par_iter())
        .for_each(|(mut o, t)| {
            let (map, _) = index.fft_map(t, m.as_deref());
            for (d, s) in o.iter_mut().zip(map) {
                *d = s as f32;
            }
        });
    Ok(out)
}

/// [`SsdIndex::best_matches`] for many templates `(K, h, w, C)` sharing one mask, in parallel over templates.
pub fn best_matches_many(
    index: &SsdIndex,
    templates: ArrayView4<f32>,
    mask: Option<ArrayView2<bool>>,
    k: usize,
    exclude_radius: usize,
) -> Result<Vec<Vec<Match>>> {
    let (ts, m) = prepare_many(index, templates, mask)?;
    Ok(ts
        .par_iter()
        .map(|t| index.best_prepared(t, m.as_deref(), k, exclude_radius))
        .collect())
}

/// Slow obvious oracle (`f64` loops over every translation and template pixel), public so tests and
/// benches can use it. Same shape rules and errors as [`SsdIndex::ssd_map`].
pub fn ssd_map_brute(
    image: ArrayView3<f32>,
    template: ArrayView3<f32>,
    mask: Option<ArrayView2<bool>>,
) -> Result<Array2<f64>> {
    let (hh, ww, c) = image.dim();
    if hh == 0 || ww == 0 || c == 0 {
        return Err(TilesynthError::shape(
            "image",
            "(H, W, C) with H, W, C >= 1",
            fmt_shape(image.shape()),
        ));
    }
    let (h, w, tc) = template.dim();
    if h == 0 || w == 0 || h > hh || w > ww || tc != c {
        return Err(TilesynthError::shape(
            "template",
            format!("(h, w, {c}) with 1 <= h <= {hh} and 1 <= w <= {ww}"),
            fmt_shape(template.shape()),
        ));
    }
    contiguous_finite("image", image)?;
    contiguous_finite("template", template)?;
    if let Some(m) = &mask {
        if m.dim() != (h, w) {
            return Err(TilesynthError::shape(
                "mask",
                format!("({h}, {w}) like the template"),
                fmt_shape(m.shape()),
            ));
        }
    }
    let mut out = Array2::<f64>::zeros((hh - h + 1, ww - w + 1));
    for ((ty, tx), o) in out.indexed_iter_mut() {
        let mut s = 0.0f64;
        for py in 0..h {
            for px in 0..w {
                if let Some(m) = &mask {
                    if !m[[py, px]] {
                        continue;
                    }
                }
                for ch in 0..c {
                    let d = template[[py, px, ch]] as f64 - image[[ty + py, tx + px, ch]] as f64;
                    s += d * d;
                }
            }
        }
        *o = s;
    }
    Ok(out)
}

// ----------------------------------------------------------------------------------------------------------
// Helpers.

/// Validates `(K, h, w, C)` templates and the shared mask.
fn prepare_many<'a>(
    index: &SsdIndex,
    templates: ArrayView4<'a, f32>,
    mask: Option<ArrayView2<bool>>,
) -> Result<(Vec<Tmpl<'a>>, Option<Vec<bool>>)> {
    let (_, h, w, c) = templates.dim();
    if h == 0 || w == 0 || h > index.h || w > index.w || c != index.c {
        return Err(TilesynthError::shape(
            "templates",
            format!(
                "(K, h, w, {}) with 1 <= h <= {} and 1 <= w <= {}",
                index.c, index.h, index.w
            ),
            fmt_shape(templates.shape()),
        ));
    }
    let ts = (0..templates.len_of(Axis(0)))
        .map(|i| index.prepare_template("templates", templates.index_axis_move(Axis(0), i)))
        .collect::<Result<Vec<_>>>()?;
    let m = prepare_mask(mask, h, w)?;
    Ok((ts, m))
}

/// Validates the mask shape and copies it.
fn prepare_mask(mask: Option<ArrayView2<bool>>, h: usize, w: usize) -> Result<Option<Vec<bool>>> {
    match mask {
        None => Ok(None),
        Some(m) => {
            if m.dim() != (h, w) {
                return Err(TilesynthError::shape(
                    "mask",
                    format!("({h}, {w}) like the template"),
                    fmt_shape(m.shape()),
                ));
            }
            Ok(Some(m.iter().copied().collect()))
        }
    }
}

/// Rejects NaN / infinite values, naming the parameter and the first offending flat index.
fn check_finite(name: &'static str, v: &[f32]) -> Result<()> {
    const CHUNK: usize = 1024;
    for (ci, chunk) in v.chunks(CHUNK).enumerate() {
        // Branch-free test of a whole chunk (vectorises); locate the culprit only on failure.
        let all_finite = chunk.iter().fold(true, |ok, x| {
            ok & (x.to_bits() & 0x7f80_0000 != 0x7f80_0000)
        });
        if !all_finite {
            let (i, x) = chunk
                .iter()
                .enumerate()
                .find(|(_, x)| !x.is_finite())
                .expect("a non-finite value in this chunk");
            return Err(TilesynthError::param(
                name,
                x,
                format!(
                    "all values must be finite (found at flat index {})",
                    ci * CHUNK + i
                ),
            ));
        }
    }
    Ok(())
}

/// The values of a 3-D view in logical (C) order, borrowed when the view is C-contiguous, rejecting
/// non-finite values.
fn contiguous_finite<'a>(name: &'static str, a: ArrayView3<'a, f32>) -> Result<Cow<'a, [f32]>> {
    let v: Cow<'a, [f32]> = match a.to_slice() {
        Some(s) => Cow::Borrowed(s),
        None => Cow::Owned(a.iter().copied().collect()),
    };
    check_finite(name, &v)?;
    Ok(v)
}

/// `(sum v^2, sum |v|)` with 8 interleaved partial sums (a fixed order, so deterministic, and vectorisable).
fn lane_sums(it: impl Iterator<Item = f64>) -> (f64, f64) {
    let mut sq = [0.0f64; 8];
    let mut ab = [0.0f64; 8];
    for (i, v) in it.enumerate() {
        sq[i & 7] += v * v;
        ab[i & 7] += v.abs();
    }
    let fold = |x: [f64; 8]| ((x[0] + x[4]) + (x[2] + x[6])) + ((x[1] + x[5]) + (x[3] + x[7]));
    (fold(sq), fold(ab))
}

fn ceil_log2(n: usize) -> u32 {
    n.next_power_of_two().trailing_zeros()
}

/// Runs `f(state, block_index, block)` over fixed blocks of `data`, in parallel (rayon) or not. The blocks
/// never depend on the thread count, so neither do the results.
fn for_each_block<T, S, I, F>(data: &mut [T], block: usize, par: bool, init: I, f: F)
where
    T: Send,
    I: Fn() -> S + Sync + Send,
    F: Fn(&mut S, usize, &mut [T]) + Sync + Send,
{
    if data.is_empty() {
        return;
    }
    if par {
        data.par_chunks_mut(block)
            .enumerate()
            .for_each_init(init, |s, (i, b)| f(s, i, b));
    } else {
        let mut s = init();
        for (i, b) in data.chunks_mut(block).enumerate() {
            f(&mut s, i, b);
        }
    }
}

/// Real FFTs (length `w`) of `rows` rows of each of `np` planes; `fill(plane, y, buf)` writes the real row.
/// Returns the `wc = w/2 + 1` spectrum columns in a row-blocked layout `[plane][y / RB][kx][y % RB]`
/// (`RB = ROW_BLOCK`; rows past `rows` in the last block are zero), so that the column stage reads
/// contiguous runs instead of one element per row.
fn row_spectra(
    plans: &Plans,
    np: usize,
    rows: usize,
    w: usize,
    wc: usize,
    par: bool,
    fill: &(dyn Fn(usize, usize, &mut [f64]) + Sync),
) -> Vec<C64> {
    let nyb = rows.div_ceil(ROW_BLOCK);
    let mut rt = vec![CZERO; np * nyb * wc * ROW_BLOCK];
    let scratch_len = plans.scratch_len();
    let ts = wc + ROW_PAD;
    for_each_block(
        &mut rt,
        wc * ROW_BLOCK,
        par,
        || {
            (
                vec![0.0f64; w],
                vec![CZERO; ROW_BLOCK * ts],
                vec![CZERO; scratch_len],
            )
        },
        |(buf, tmp, scratch), bi, out| {
            let (plane, yb) = (bi / nyb, bi % nyb);
            let nr = ROW_BLOCK.min(rows - yb * ROW_BLOCK);
            for j in 0..nr {
                fill(plane, yb * ROW_BLOCK + j, buf);
                let res =
                    plans
                        .fwd_w
                        .process_with_scratch(buf, &mut tmp[j * ts..j * ts + wc], scratch);
                debug_assert!(res.is_ok());
            }
            for (kx, o) in out.chunks_exact_mut(ROW_BLOCK).enumerate() {
                for (j, v) in o[..nr].iter_mut().enumerate() {
                    *v = tmp[j * ts + kx];
                }
            }
        },
    );
    rt
}

/// Buffers of one worker of a column stage.
struct ColWork {
    h: usize,
    hc: usize,
    /// Distance between gathered columns: `h + COL_PAD` (the padding avoids 4 KiB aliasing of the
    /// columns, which made the strided gather slow).
    stride: usize,
    /// Real and imaginary parts of `COL_BLOCK` gathered columns, each of length `h`.
    re: Vec<f64>,
    im: Vec<f64>,
    /// Half spectra `A | B` of one column.
    ab: Vec<C64>,
    /// Accumulated `G[k] | G[H - k]` of `COL_BLOCK` columns (turned into `P | Q` by `inverse_pq`).
    pq: Vec<C64>,
    /// Inverse outputs.
    out_re: Vec<f64>,
    out_im: Vec<f64>,
    scratch: Vec<C64>,
}

impl ColWork {
    fn new(h: usize, hc: usize, scratch_len: usize) -> ColWork {
        ColWork {
            h,
            hc,
            stride: h + COL_PAD,
            re: vec![0.0; COL_BLOCK * (h + COL_PAD)],
            im: vec![0.0; COL_BLOCK * (h + COL_PAD)],
            ab: vec![CZERO; 2 * hc],
            pq: vec![CZERO; COL_BLOCK * 2 * hc],
            out_re: vec![0.0; h],
            out_im: vec![0.0; h],
            scratch: vec![CZERO; scratch_len],
        }
    }

    /// Gathers columns `kx0 .. kx0 + nb` of plane `plane` of the row spectra `rt` (`[plane][y][kx]` with
    /// `rows` rows), zero-padded to the full height.
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &mut self,
        rt: &[C64],
        plane: usize,
        rows: usize,
        wc: usize,
        kx0: usize,
        nb: usize,
        h: usize,
    ) {
        debug_assert_eq!(h, self.h);
        let st = self.stride;
        let nyb = rows.div_ceil(ROW_BLOCK);
        for yb in 0..nyb {
            let y0 = yb * ROW_BLOCK;
            let nr = ROW_BLOCK.min(rows - y0);
            let block = &rt[((plane * nyb + yb) * wc + kx0) * ROW_BLOCK..][..nb * ROW_BLOCK];
            for (j, run) in block.chunks_exact(ROW_BLOCK).enumerate() {
                let (re, im) = (&mut self.re[j * st + y0..], &mut self.im[j * st + y0..]);
                for (i, v) in run[..nr].iter().enumerate() {
                    re[i] = v.re;
                    im[i] = v.im;
                }
            }
        }
        if rows < h {
            for j in 0..nb {
                self.re[j * st + rows..j * st + h].fill(0.0);
                self.im[j * st + rows..j * st + h].fill(0.0);
            }
        }
    }

    /// Forward column transforms of gathered column `j`: `oa = A` (real part), `ob = B` (imaginary part).
    fn forward(&mut self, plans: &Plans, j: usize, oa: &mut [C64], ob: &mut [C64]) {
        let h = self.h;
        let r1 = plans.fwd_h.process_with_scratch(
            &mut self.re[j * self.stride..j * self.stride + h],
            oa,
            &mut self.scratch,
        );
        let r2 = plans.fwd_h.process_with_scratch(
            &mut self.im[j * self.stride..j * self.stride + h],
            ob,
            &mut self.scratch,
        );
        debug_assert!(r1.is_ok() && r2.is_ok());
    }

    /// Forward column transforms of gathered column `j` into `self.ab`.
    fn forward_to_ab(&mut self, plans: &Plans, j: usize) {
        let mut ab = std::mem::take(&mut self.ab);
        let (oa, ob) = ab.split_at_mut(self.hc);
        self.forward(plans, j, oa, ob);
        self.ab = ab;
    }

    /// Inverse column transforms of column `j`: `G` to `2P`, `2Q`, then real inverse FFTs (unnormalised).
    fn inverse_pq(&mut self, plans: &Plans, j: usize) -> (&[f64], &[f64]) {
        let (h, hc) = (self.h, self.hc);
        let (p, q) = self.pq[j * 2 * hc..(j + 1) * 2 * hc].split_at_mut(hc);
        // From G[k], G[H - k] to the half spectra of the real and imaginary parts of the column
        // correlation (times 2): P = G[k] + conj(G[H - k]),  Q = -i (G[k] - conj(G[H - k])).
        for (gk, gm) in p.iter_mut().zip(q.iter_mut()) {
            let (k, m) = (*gk, *gm);
            *gk = C64::new(k.re + m.re, k.im - m.im);
            *gm = C64::new(k.im + m.im, m.re - k.re);
        }
        for s in [&mut *p, &mut *q] {
            s[0].im = 0.0;
            if h % 2 == 0 {
                s[hc - 1].im = 0.0;
            }
        }
        let r1 = plans
            .inv_h
            .process_with_scratch(p, &mut self.out_re, &mut self.scratch);
        let r2 = plans
            .inv_h
            .process_with_scratch(q, &mut self.out_im, &mut self.scratch);
        debug_assert!(r1.is_ok() && r2.is_ok());
        (&self.out_re, &self.out_im)
    }
}

/// Buffers of one worker of the inverse row stage.
struct RowInvWork {
    rows: Vec<C64>,
    out: Vec<f64>,
    scratch: Vec<C64>,
}

impl RowInvWork {
    fn new(w: usize, wc: usize, scratch_len: usize) -> RowInvWork {
        RowInvWork {
            rows: vec![CZERO; ROW_BLOCK * (wc + ROW_PAD)],
            out: vec![0.0; w],
            scratch: vec![CZERO; scratch_len],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{s, Array3, Array4};

    /// splitmix64.
    struct Rng(u64);
    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn f32(&mut self) -> f32 {
            (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next_u64() % n as u64) as usize
        }
    }

    fn rand3(rng: &mut Rng, d: (usize, usize, usize)) -> Array3<f32> {
        Array3::from_shape_simple_fn(d, || rng.f32())
    }

    fn rand_mask(rng: &mut Rng, h: usize, w: usize) -> Array2<bool> {
        Array2::from_shape_simple_fn((h, w), || rng.next_u64() % 3 != 0)
    }

    fn check_map(img: &Array3<f32>, t: &Array3<f32>, m: Option<&Array2<bool>>) {
        let idx = SsdIndex::new(img.view()).unwrap();
        let got = idx.ssd_map(t.view(), m.map(|m| m.view())).unwrap();
        let want = ssd_map_brute(img.view(), t.view(), m.map(|m| m.view())).unwrap();
        assert_eq!(got.dim(), want.dim());
        let max = want.iter().cloned().fold(0.0f64, f64::max);
        for (g, w) in got.iter().zip(want.iter()) {
            assert!(
                (*g as f64 - w).abs() <= 1e-4 * max.max(1e-30) + 1e-6,
                "map {g} vs {w} (max {max}) image {:?} template {:?}",
                img.dim(),
                t.dim()
            );
        }
        // f64 map within its stated bound
        let (m64, bound) = idx.ssd_map_f64(t.view(), m.map(|m| m.view())).unwrap();
        for (g, w) in m64.iter().zip(want.iter()) {
            assert!((g - w).abs() <= bound.max(1e-9), "{g} vs {w} bound {bound}");
        }
        // argmin agrees unless near tie
        let am = |a: &dyn Fn(usize) -> f64, n: usize| {
            (0..n).fold(0, |b, i| if a(i) < a(b) { i } else { b })
        };
        let gv: Vec<f64> = got.iter().map(|&v| v as f64).collect();
        let wv: Vec<f64> = want.iter().copied().collect();
        let (ig, iw) = (am(&|i| gv[i], gv.len()), am(&|i| wv[i], wv.len()));
        if ig != iw {
            assert!((wv[ig] - wv[iw]).abs() <= 1e-4 * max + 1e-6);
        }
    }

    fn oracle_best(want: &Array2<f64>, k: usize, r: usize) -> Vec<Match> {
        let (mh, mw) = want.dim();
        let mut chosen: Vec<Match> = Vec::new();
        for _ in 0..k {
            let mut best: Option<Match> = None;
            for ((y, x), &v) in want.indexed_iter() {
                let ok = chosen
                    .iter()
                    .all(|c| c.row.abs_diff(y).max(c.col.abs_diff(x)) > r);
                if ok && best.map_or(true, |b: Match| v < b.ssd) {
                    best = Some(Match {
                        row: y,
                        col: x,
                        ssd: v,
                    });
                }
            }
            match best {
                Some(b) => chosen.push(b),
                None => break,
            }
        }
        let _ = (mh, mw);
        chosen
    }

    fn check_best(
        img: &Array3<f32>,
        t: &Array3<f32>,
        m: Option<&Array2<bool>>,
        k: usize,
        r: usize,
    ) {
        let idx = SsdIndex::new(img.view()).unwrap();
        let got = idx
            .best_matches(t.view(), m.map(|m| m.view()), k, r)
            .unwrap();
        let want = ssd_map_brute(img.view(), t.view(), m.map(|m| m.view())).unwrap();
        let exp = oracle_best(&want, k, r);
        assert_eq!(got.len(), exp.len());
        for (g, e) in got.iter().zip(&exp) {
            assert_eq!((g.row, g.col), (e.row, e.col), "got {got:?} want {exp:?}");
            assert!((g.ssd - e.ssd).abs() <= 1e-9 * e.ssd.abs().max(1e-12));
            let at = idx
                .ssd_at(t.view(), m.map(|m| m.view()), g.row, g.col)
                .unwrap();
            assert_eq!(at, g.ssd);
        }
    }

    const SIZES: &[(usize, usize, usize, usize, usize)] = &[
        // H, W, h, w, C
        (1, 1, 1, 1, 1),
        (7, 5, 3, 2, 3),
        (16, 16, 5, 7, 3),
        (17, 13, 17, 13, 2), // 1x1 map
        (20, 31, 1, 4, 1),   // h = 1
        (23, 9, 6, 1, 4),    // w = 1
        (32, 24, 32, 3, 3),  // h = H
        (29, 37, 11, 13, 3),
        (64, 48, 20, 17, 1),
    ];

    #[test]
    fn map_matches_oracle_unmasked() {
        let mut rng = Rng(1);
        for &(hh, ww, h, w, c) in SIZES {
            let img = rand3(&mut rng, (hh, ww, c));
            let t = rand3(&mut rng, (h, w, c));
            check_map(&img, &t, None);
            // a template cut from the image: exact zero somewhere
            let (y, x) = (rng.below(hh - h + 1), rng.below(ww - w + 1));
            let cut = img.slice(s![y..y + h, x..x + w, ..]).to_owned();
            check_map(&img, &cut, None);
        }
    }

    #[test]
    fn map_matches_oracle_masked() {
        let mut rng = Rng(2);
        for &(hh, ww, h, w, c) in SIZES {
            let img = rand3(&mut rng, (hh, ww, c));
            let t = rand3(&mut rng, (h, w, c));
            let m = rand_mask(&mut rng, h, w);
            check_map(&img, &t, Some(&m));
            let none = Array2::from_elem((h, w), false);
            check_map(&img, &t, Some(&none));
            let all = Array2::from_elem((h, w), true);
            check_map(&img, &t, Some(&all));
            // all-false mask: the map is exactly zero
            let idx = SsdIndex::new(img.view()).unwrap();
            let z = idx.ssd_map(t.view(), Some(none.view())).unwrap();
            assert!(z.iter().all(|&v| v == 0.0));
        }
    }

    #[test]
    fn non_contiguous_views() {
        let mut rng = Rng(3);
        let big = rand3(&mut rng, (40, 50, 4));
        let img = big.slice(s![..;2, 1..;2, ..3]);
        let tbig = rand3(&mut rng, (12, 10, 3));
        let t = tbig.slice(s![..;2, ..;2, ..]);
        let mbig = rand_mask(&mut rng, 6, 10);
        let m = mbig.slice(s![.., ..;2]);
        let idx = SsdIndex::new(img).unwrap();
        let got = idx.ssd_map(t, Some(m)).unwrap();
        let want = ssd_map_brute(img, t, Some(m)).unwrap();
        let max = want.iter().cloned().fold(0.0, f64::max);
        for (g, w) in got.iter().zip(want.iter()) {
            assert!((*g as f64 - w).abs() <= 1e-4 * max);
        }
        check_map(&img.to_owned(), &t.to_owned(), Some(&m.to_owned()));
    }

    #[test]
    fn best_matches_oracle() {
        let mut rng = Rng(4);
        for &(hh, ww, h, w, c) in SIZES {
            let img = rand3(&mut rng, (hh, ww, c));
            let t = rand3(&mut rng, (h, w, c));
            let m = rand_mask(&mut rng, h, w);
            for &(k, r) in &[(1, 0), (5, 0), (4, 2), (3, 100), (2, usize::MAX)] {
                check_best(&img, &t, None, k, r);
                check_best(&img, &t, Some(&m), k, r);
            }
        }
    }

    #[test]
    fn best_matches_ties_and_cut_templates() {
        let mut rng = Rng(5);
        // constant image and template: every translation ties; order by (row, col)
        let img = Array3::from_elem((12, 10, 3), 0.25f32);
        let t = Array3::from_elem((4, 3, 3), 0.5f32);
        let idx = SsdIndex::new(img.view()).unwrap();
        let got = idx.best_matches(t.view(), None, 4, 0).unwrap();
        let pos: Vec<(usize, usize)> = got.iter().map(|m| (m.row, m.col)).collect();
        assert_eq!(pos, vec![(0, 0), (0, 1), (0, 2), (0, 3)]);
        assert!(got.iter().all(|m| m.ssd == got[0].ssd));
        let got = idx.best_matches(t.view(), None, 3, 1).unwrap();
        let pos: Vec<(usize, usize)> = got.iter().map(|m| (m.row, m.col)).collect();
        assert_eq!(pos, vec![(0, 0), (0, 2), (0, 4)]);
        // all-false mask: all zero, order by (row, col)
        let none = Array2::from_elem((4, 3), false);
        let got = idx.best_matches(t.view(), Some(none.view()), 2, 0).unwrap();
        assert_eq!((got[1].row, got[1].col, got[1].ssd), (0, 1, 0.0));
        // more requested than available
        let t = rand3(&mut rng, (11, 9, 3));
        assert_eq!(idx.best_matches(t.view(), None, 10, 0).unwrap().len(), 4);
        assert_eq!(idx.best_matches(t.view(), None, 10, 1).unwrap().len(), 1);
        assert!(idx.best_matches(t.view(), None, 0, 0).unwrap().is_empty());
        // a template cut from the image is found with ssd 0
        let img = rand3(&mut rng, (40, 33, 3));
        let cut = img.slice(s![13..25, 7..20, ..]).to_owned();
        let idx = SsdIndex::new(img.view()).unwrap();
        let got = idx.best_matches(cut.view(), None, 3, 2).unwrap();
        assert_eq!((got[0].row, got[0].col, got[0].ssd), (13, 7, 0.0));
        check_best(&img, &cut, None, 6, 1);
    }

    #[test]
    fn many_templates() {
        let mut rng = Rng(6);
        let img = rand3(&mut rng, (30, 26, 3));
        let ts = Array4::from_shape_simple_fn((5, 7, 9, 3), || rng.f32());
        let m = rand_mask(&mut rng, 7, 9);
        let idx = SsdIndex::new(img.view()).unwrap();
        for mask in [None, Some(m.view())] {
            let maps = ssd_maps(&idx, ts.view(), mask).unwrap();
            let best = best_matches_many(&idx, ts.view(), mask, 3, 1).unwrap();
            assert_eq!(maps.dim(), (5, 24, 18));
            for (i, t) in ts.axis_iter(Axis(0)).enumerate() {
                assert_eq!(maps.index_axis(Axis(0), i), idx.ssd_map(t, mask).unwrap());
                assert_eq!(best[i], idx.best_matches(t, mask, 3, 1).unwrap());
            }
        }
        let empty = Array4::<f32>::zeros((0, 7, 9, 3));
        assert_eq!(
            ssd_maps(&idx, empty.view(), None).unwrap().dim(),
            (0, 24, 18)
        );
        assert!(best_matches_many(&idx, empty.view(), None, 1, 0)
            .unwrap()
            .is_empty());
    }

    #[test]
    fn errors() {
        let img = Array3::<f32>::zeros((10, 8, 3));
        let idx = SsdIndex::new(img.view()).unwrap();
        let is_shape = |e: TilesynthError, n: &str| matches!(e, TilesynthError::Shape { name, .. } if name == n);
        let is_param = |e: TilesynthError, n: &str| matches!(e, TilesynthError::Parameter { name, .. } if name == n);
        for d in [(0, 8, 3), (10, 0, 3), (10, 8, 0)] {
            let e = SsdIndex::new(Array3::<f32>::zeros(d).view()).err().unwrap();
            assert!(is_shape(e, "image"));
        }
        for d in [
            (0, 2, 3),
            (2, 0, 3),
            (11, 2, 3),
            (2, 9, 3),
            (2, 2, 1),
            (2, 2, 4),
        ] {
            let t = Array3::<f32>::zeros(d);
            assert!(is_shape(
                idx.ssd_map(t.view(), None).unwrap_err(),
                "template"
            ));
            assert!(is_shape(
                idx.best_matches(t.view(), None, 1, 0).unwrap_err(),
                "template"
            ));
            assert!(is_shape(
                idx.ssd_at(t.view(), None, 0, 0).unwrap_err(),
                "template"
            ));
            assert!(is_shape(
                ssd_map_brute(img.view(), t.view(), None).unwrap_err(),
                "template"
            ));
        }
        let t = Array3::<f32>::zeros((3, 2, 3));
        let m = Array2::from_elem((2, 3), true);
        assert!(is_shape(
            idx.ssd_map(t.view(), Some(m.view())).unwrap_err(),
            "mask"
        ));
        assert!(is_shape(
            idx.best_matches(t.view(), Some(m.view()), 1, 0)
                .unwrap_err(),
            "mask"
        ));
        assert!(is_shape(
            ssd_map_brute(img.view(), t.view(), Some(m.view())).unwrap_err(),
            "mask"
        ));
        let ts = Array4::<f32>::zeros((2, 3, 2, 3));
        assert!(is_shape(
            ssd_maps(&idx, ts.view(), Some(m.view())).unwrap_err(),
            "mask"
        ));
        let ts = Array4::<f32>::zeros((2, 3, 2, 2));
        assert!(is_shape(
            ssd_maps(&idx, ts.view(), None).unwrap_err(),
            "templates"
        ));
        assert!(is_shape(
            best_matches_many(&idx, ts.view(), None, 1, 0).unwrap_err(),
            "templates"
        ));
        // non-finite values
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut im2 = img.clone();
            im2[[3, 4, 1]] = bad;
            assert!(is_param(SsdIndex::new(im2.view()).err().unwrap(), "image"));
            assert!(is_param(
                ssd_map_brute(im2.view(), t.view(), None).unwrap_err(),
                "image"
            ));
            let mut t2 = t.clone();
            t2[[1, 1, 2]] = bad;
            assert!(is_param(
                idx.ssd_map(t2.view(), None).unwrap_err(),
                "template"
            ));
            assert!(is_param(
                idx.best_matches(t2.view(), None, 2, 0).unwrap_err(),
                "template"
            ));
            assert!(is_param(
                idx.ssd_at(t2.view(), None, 0, 0).unwrap_err(),
                "template"
            ));
            let mut ts2 = Array4::<f32>::zeros((3, 3, 2, 3));
            ts2[[2, 0, 0, 0]] = bad;
            assert!(is_param(
                ssd_maps(&idx, ts2.view(), None).unwrap_err(),
                "templates"
            ));
        }
        // translation out of range
        assert!(is_param(
            idx.ssd_at(t.view(), None, 8, 0).unwrap_err(),
            "row"
        ));
        assert!(is_param(
            idx.ssd_at(t.view(), None, 0, 7).unwrap_err(),
            "col"
        ));
        assert!(idx.ssd_at(t.view(), None, 7, 6).is_ok());
    }

    #[test]
    fn deterministic_across_threads() {
        fn assert_send_sync<T: Send + Sync>() {}
        assert_send_sync::<SsdIndex>();
        let mut rng = Rng(7);
        // large enough for the parallel path inside one call
        let img = rand3(&mut rng, (260, 250, 3));
        let t = rand3(&mut rng, (40, 37, 3));
        let m = rand_mask(&mut rng, 40, 37);
        let ts = Array4::from_shape_simple_fn((3, 9, 8, 3), || rng.f32());
        let run = |threads| {
            crate::parallel::install(Some(threads), || {
                let idx = SsdIndex::new(img.view()).unwrap();
                (
                    idx.ssd_map(t.view(), None).unwrap(),
                    idx.ssd_map(t.view(), Some(m.view())).unwrap(),
                    idx.best_matches(t.view(), Some(m.view()), 4, 3).unwrap(),
                    ssd_maps(&idx, ts.view(), None).unwrap(),
                    best_matches_many(&idx, ts.view(), None, 2, 0).unwrap(),
                )
            })
            .unwrap()
        };
        let a = run(1);
        let b = run(2);
        let c = run(3);
        assert!(a == b && b == c);
        // and the parallel path is right (spot checks against the direct sum)
        let idx = SsdIndex::new(img.view()).unwrap();
        let (mh, mw) = a.0.dim();
        let max = a.0.iter().cloned().fold(0.0f32, f32::max) as f64;
        for _ in 0..300 {
            let (y, x) = (rng.below(mh), rng.below(mw));
            let e = idx.ssd_at(t.view(), None, y, x).unwrap();
            assert!((a.0[[y, x]] as f64 - e).abs() <= 1e-4 * max);
            let e = idx.ssd_at(t.view(), Some(m.view()), y, x).unwrap();
            assert!((a.1[[y, x]] as f64 - e).abs() <= 1e-4 * max);
        }
    }
}
