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
//! The correlations are computed with 2-D FFTs at FFT size = image size: a valid correlation with an
//! image-sized circular correlation is exact, because the circular wrap only touches invalid offsets.
//!
//! ## Centring
//!
//! The image planes are centred before any transform: `I'_c = I_c - mean(I_c)` (and `S' = S - mean(S)`),
//! so `corr(p, I_c) = corr(p, I'_c) + mean(I_c) * sum(p)` with the constant added back exactly in `f64`.
//! This removes the large DC peak of the image spectra, which otherwise dominates the rounding error.
//!
//! ## Two channels per complex transform
//!
//! Template planes are packed in pairs `z = p_a + i p_b` (the planes are `-2 m T_c`, then `m` with a mask).
//! With the image-side spectrum `U = FFT(I'_a + i I'_b) / 2` (cached) and `V[k] = conj(U[-k])`, the
//! spectrum of `corr(p_a, I'_a) + corr(p_b, I'_b)` is `conj(Z[k]) U[k] + Z[-k] V[k]`, which is Hermitian,
//! so only the half `kx <= W/2` is formed and inverted (complex column IFFTs, then a real inverse FFT of
//! each *valid* row). An odd plane out is transformed as a real 2-D FFT (two rows per complex row FFT,
//! only `W/2 + 1` column transforms). Only the `h` template rows are row-transformed.
//!
//! ## Precision and laziness
//!
//! [`SsdIndex::new`] only validates and copies the image and computes `S`, its integral image, the means
//! and the norms. The spectra are built lazily (`OnceLock`) on first use:
//!
//! - maps ([`SsdIndex::ssd_map`], [`ssd_maps`]) use `f32` transforms (rustfft's AVX kernels): accurate to
//!   about `1e-6` of the map scale, well inside the documented `1e-4`;
//! - [`SsdIndex::best_matches`] and [`SsdIndex::ssd_map_f64`] use `f64` transforms with a rigorous
//!   error bound (below), built on first use;
//! - the spectrum of `S` (needed only with a mask) is built the first time a mask is used.
//!
//! ## Exact best matches
//!
//! The `f64` FFT map `F` satisfies `|F(t) - E(t)| <= B` for the exact SSD `E`, with the norm-wise bound
//! `B = 6 a sum_planes (||x||_2 ||y||_1 + ||x||_1 ||y||_2)` (`x`: template side, `y`: centred image side,
//! `a = 16 eps (ceil(log2 H) + ceil(log2 W) + 8)`, a generous constant per FFT level covering mixed-radix
//! and Bluestein algorithms, doubled for the pair packing) plus the rounding of the centring, of the
//! final sums and of the integral image. Every translation whose FFT value is `<= E(t0) + B` (`t0` the FFT
//! argmin) is re-evaluated directly, so no exact winner can be missed. With `f64` transforms `B` is around
//! `1e-9` relative, so in practice only the FFT argmin itself (and exact ties) are re-evaluated.
//!
//! Parallelism (rayon, within one call for large images; over templates in [`ssd_maps`]) splits work into
//! fixed blocks of rows or columns; every transform and every sum is computed the same way whatever
//! thread runs it, so outputs are bit-identical at any number of threads.

use crate::error::{
    checked_len, fmt_shape, probe_alloc, try_collect, try_standard, try_vec, Result, TilesynthError,
};
use ndarray::{Array2, Array3, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;
use realfft::{ComplexToReal, RealFftPlanner};
use rustfft::num_complex::Complex;
use rustfft::num_traits::{Float, Zero};
use rustfft::{Fft, FftNum, FftPlanner};
use std::borrow::Cow;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::sync::{Arc, Mutex, OnceLock};

/// An `f64` ordered by `total_cmp` (for the heap of exact SSD values, which are never NaN).
#[derive(Debug, Clone, Copy, PartialEq)]
struct TotalF64(f64);

impl Eq for TotalF64 {}

impl PartialOrd for TotalF64 {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for TotalF64 {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Images with at least this many pixels run the stages of one call in parallel (rayon), when the pool
/// has more than one thread (the results do not depend on it).
const PAR_MIN_PIXELS: usize = 100 * 100;
/// Maps are computed with `f32` transforms when their typical rounding error is at most this fraction of
/// the map's largest value (else with `f64` transforms); the documented accuracy is `1e-4`.
const F32_REL_EST: f64 = 1e-5;
/// Rows per task of the row stages.
const ROW_BLOCK: usize = 16;
/// Columns per task of the column stages.
const COL_BLOCK: usize = 16;

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
struct Plans<T: FftNum> {
    fwd_w: Arc<dyn Fft<T>>,
    fwd_h: Arc<dyn Fft<T>>,
    inv_h: Arc<dyn Fft<T>>,
    inv_w: Arc<dyn ComplexToReal<T>>,
    scratch: usize,
}

fn make_plans<T: FftNum>(
    cp: &mut FftPlanner<T>,
    rp: &mut RealFftPlanner<T>,
    h: usize,
    w: usize,
) -> Plans<T> {
    let fwd_w = cp.plan_fft_forward(w);
    let fwd_h = cp.plan_fft_forward(h);
    let inv_h = cp.plan_fft_inverse(h);
    let inv_w = rp.plan_fft_inverse(w);
    let scratch = fwd_w
        .get_inplace_scratch_len()
        .max(fwd_h.get_inplace_scratch_len())
        .max(inv_h.get_inplace_scratch_len())
        .max(inv_w.get_scratch_len());
    Plans {
        fwd_w,
        fwd_h,
        inv_h,
        inv_w,
        scratch,
    }
}

/// The floating-point type of a transform pipeline (`f32` for maps, `f64` for exact best matches).
trait Real: FftNum + Float {
    fn of(x: f64) -> Self;
    fn to64(self) -> f64;
    /// Plans from a process-wide planner of this type (plans are cached and shared).
    fn plans(h: usize, w: usize) -> Plans<Self>;
    /// The lazily built spectra of this precision in an index.
    fn spec_cell(idx: &SsdIndex) -> &OnceLock<Spec<Self>>;
    fn tail_cell(idx: &SsdIndex) -> &OnceLock<Chunk<Self>>;
}

macro_rules! impl_real {
    ($t:ty, $spec:ident, $tail:ident) => {
        impl Real for $t {
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to64(self) -> f64 {
                self as f64
            }
            fn plans(h: usize, w: usize) -> Plans<$t> {
                type Planners = (FftPlanner<$t>, RealFftPlanner<$t>);
                static PLANNERS: Mutex<Option<Planners>> = Mutex::new(None);
                let mut guard = PLANNERS.lock().unwrap_or_else(|e| e.into_inner());
                let (cp, rp) =
                    guard.get_or_insert_with(|| (FftPlanner::new(), RealFftPlanner::new()));
                make_plans(cp, rp, h, w)
            }
            fn spec_cell(idx: &SsdIndex) -> &OnceLock<Spec<$t>> {
                &idx.$spec
            }
            fn tail_cell(idx: &SsdIndex) -> &OnceLock<Chunk<$t>> {
                &idx.$tail
            }
        }
    };
}
impl_real!(f32, spec32, tail32);
impl_real!(f64, spec64, tail64);

/// Image-side spectrum of one group of planes, laid out `[kx][ky]` for `kx < W/2 + 1`, all `ky < H`.
enum Chunk<T> {
    /// A pair `(a, b)`: `U = FFT(a + ib) / 2` and `V[k] = conj(U[-k])`.
    Pair {
        u: Vec<Complex<T>>,
        v: Vec<Complex<T>>,
    },
    /// One real plane: its spectrum.
    Lone(Vec<Complex<T>>),
}

/// The spectra of one precision: plans, then the groups of the unmasked planes (channel pairs, then the
/// last channel alone when `C` is odd). With a mask the planes are the channels then `S`: the first
/// `C / 2` groups are shared, the last one is the `tail` (built on first masked use).
struct Spec<T: FftNum> {
    plans: Plans<T>,
    chunks: Vec<Chunk<T>>,
}

/// Everything that depends only on the image: the image (for the exact direct sums), `S = sum_c I_c^2`,
/// its integral image (box sums for the unmasked case), the plane means and norms, and lazily built
/// spectra at FFT size = image size. `Send + Sync`.
pub struct SsdIndex {
    h: usize,
    w: usize,
    c: usize,
    /// The image, `(H, W, C)` C-contiguous.
    image: Vec<f32>,
    /// `S`, `(H, W)`.
    s: Vec<f64>,
    /// Integral image of `S`, `(H + 1, W + 1)`.
    integral: Vec<f64>,
    /// Means of the `C + 1` planes (the channels, then `S`).
    means: Vec<f64>,
    /// `(l1, l2, linf)` norms of every centred plane, for the error bound.
    norms: Vec<(f64, f64, f64)>,
    /// Sum of `S` over the image.
    s_total: f64,
    spec32: OnceLock<Spec<f32>>,
    spec64: OnceLock<Spec<f64>>,
    tail32: OnceLock<Chunk<f32>>,
    tail64: OnceLock<Chunk<f64>>,
}

/// The template-side constants of a map (see [`SsdIndex::template_consts`]).
#[derive(Clone, Copy)]
struct TConsts {
    sum_t2: f64,
    l1: f64,
    nnz: f64,
    kconst: f64,
}

/// A validated template, borrowed when C-contiguous, copied otherwise.
struct Tmpl<'a> {
    h: usize,
    w: usize,
    data: Cow<'a, [f32]>,
}

impl SsdIndex {
    /// Builds the index of `image` `(H, W, C)` (any strides; `H, W, C >= 1`; finite values). Cheap: the
    /// spectra are computed on first use.
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
        let n = (h * w) as f64;

        // S = sum_c I_c^2, the plane means and the norms of the centred planes (local accumulators per
        // plane, so that the loops stay in registers).
        let s: Vec<f64> = try_collect(
            "image",
            h * w,
            data.chunks_exact(c)
                .map(|px| px.iter().map(|&v| (v as f64) * (v as f64)).sum()),
        )?;
        // Per plane: copy into a buffer, then 8-lane sums (a fixed order, vectorisable).
        let mut buf = try_vec("image", checked_len("image", &[h, w])?, 0.0f64)?;
        let mut means = Vec::with_capacity(c + 1);
        let mut norms = Vec::with_capacity(c + 1);
        let mut s_total = 0.0;
        for q in 0..=c {
            if q < c {
                for (b, px) in buf.iter_mut().zip(data.chunks_exact(c)) {
                    *b = px[q] as f64;
                }
            } else {
                buf.copy_from_slice(&s);
            }
            let (sum, _, _, _) = lane_stats(&buf, 0.0);
            let mean = sum / n;
            let (_, l1, l2, li) = lane_stats(&buf, mean);
            if q == c {
                s_total = sum;
            }
            means.push(mean);
            norms.push((l1, l2.sqrt(), li));
        }
        let mut integral = try_vec("image", checked_len("image", &[h + 1, w + 1])?, 0.0f64)?;
        for y in 0..h {
            let mut run = 0.0;
            let (prev, cur) = integral[y * (w + 1)..(y + 2) * (w + 1)].split_at_mut(w + 1);
            for x in 0..w {
                run += s[y * w + x];
                cur[x + 1] = prev[x + 1] + run;
            }
        }
        Ok(SsdIndex {
            h,
            w,
            c,
            image: data.into_owned(),
            s,
            integral,
            means,
            norms,
            s_total,
            spec32: OnceLock::new(),
            spec64: OnceLock::new(),
            tail32: OnceLock::new(),
            tail64: OnceLock::new(),
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

    fn par(&self) -> bool {
        self.h * self.w >= PAR_MIN_PIXELS && rayon::current_num_threads() > 1
    }

    /// Writes row `y` of centred image plane `q` (a channel, or `S` for `q = C`).
    fn image_row<T: Real>(&self, q: usize, y: usize, out: &mut [T]) {
        let (w, c) = (self.w, self.c);
        let mu = self.means[q];
        if q < c {
            let row = &self.image[y * w * c..(y + 1) * w * c];
            for (o, px) in out.iter_mut().zip(row.chunks_exact(c)) {
                *o = T::of(px[q] as f64 - mu);
            }
        } else {
            for (o, &v) in out.iter_mut().zip(&self.s[y * w..(y + 1) * w]) {
                *o = T::of(v - mu);
            }
        }
    }

    fn build_chunk<T: Real>(&self, plans: &Plans<T>, qa: usize, qb: Option<usize>) -> Chunk<T> {
        let (hh, ww) = (self.h, self.w);
        let wc = ww / 2 + 1;
        let par = self.par();
        let fill = |q: usize, y: usize, out: &mut [T]| self.image_row(q, y, out);
        match qb {
            Some(qb) => {
                let mut full = vec![Complex::<T>::zero(); ww * hh];
                fwd_pair(plans, hh, ww, hh, par, &fill, qa, qb, &mut full);
                let half = T::of(0.5);
                let mut u = vec![Complex::<T>::zero(); wc * hh];
                let mut v = vec![Complex::<T>::zero(); wc * hh];
                for kx in 0..wc {
                    let f1 = &full[kx * hh..(kx + 1) * hh];
                    let f2 = &full[((ww - kx) % ww) * hh..][..hh];
                    for (o, z) in u[kx * hh..(kx + 1) * hh].iter_mut().zip(f1) {
                        *o = z * half;
                    }
                    let vo = &mut v[kx * hh..(kx + 1) * hh];
                    vo[0] = f2[0].conj() * half;
                    for (o, z) in vo[1..].iter_mut().zip(f2[1..].iter().rev()) {
                        *o = z.conj() * half;
                    }
                }
                Chunk::Pair { u, v }
            }
            None => {
                let mut x = vec![Complex::<T>::zero(); wc * hh];
                fwd_real(plans, hh, ww, hh, par, &fill, qa, &mut x);
                Chunk::Lone(x)
            }
        }
    }

    /// The spectra of precision `T`, built on first use.
    fn spec<T: Real>(&self) -> &Spec<T> {
        T::spec_cell(self).get_or_init(|| {
            let plans = T::plans(self.h, self.w);
            let c = self.c;
            let mut chunks: Vec<Chunk<T>> = (0..c / 2)
                .map(|k| self.build_chunk(&plans, 2 * k, Some(2 * k + 1)))
                .collect();
            if c % 2 == 1 {
                chunks.push(self.build_chunk(&plans, c - 1, None));
            }
            Spec { plans, chunks }
        })
    }

    /// The last group of the masked planes (`(I_{C-1}, S)` for odd `C`, `S` alone otherwise), built on
    /// the first masked call.
    fn tail<T: Real>(&self) -> &Chunk<T> {
        let plans = &self.spec::<T>().plans;
        T::tail_cell(self).get_or_init(|| {
            let c = self.c;
            if c % 2 == 1 {
                self.build_chunk(plans, c - 1, Some(c))
            } else {
                self.build_chunk(plans, c, None)
            }
        })
    }

    /// Builds every lazily computed part that a call of precision `T` (with or without a mask) needs, so
    /// that parallel loops over templates never initialise them concurrently.
    ///
    /// Fallible: before the spectra exist, their size (one half spectrum per plane pair, plus the full
    /// transform of the pair being built) is reserved and released, so an image whose spectra cannot be
    /// allocated gives an error instead of aborting the process.
    ///
    /// Every call also probes the buffers of one map computation (the half spectrum and the pair transform
    /// of the template planes, the map itself and the walk's order, each image-sized), which are allocated
    /// infallibly deeper down: an image whose maps cannot be computed in the memory left is an error here,
    /// not an abort in the middle of a kernel.
    fn ensure<T: Real>(&self, masked: bool) -> Result<()> {
        let per_call = checked_len(
            "image",
            &[
                self.h,
                self.w / 2 + 1 + self.w,
                std::mem::size_of::<Complex<T>>(),
            ],
        )?
        .saturating_add(checked_len("image", &[self.h, self.w, 16])?);
        probe_alloc("image", per_call)?;
        if T::spec_cell(self).get().is_none() || (masked && T::tail_cell(self).get().is_none()) {
            let wc = self.w / 2 + 1;
            let planes = self.c.div_ceil(2) + 1;
            let half = checked_len(
                "image",
                &[wc, self.h, 2, planes, std::mem::size_of::<Complex<T>>()],
            )?;
            let full = checked_len(
                "image",
                &[self.w, self.h, std::mem::size_of::<Complex<T>>()],
            )?;
            probe_alloc("image", half.saturating_add(full))?;
        }
        self.spec::<T>();
        if masked {
            self.tail::<T>();
        }
        Ok(())
    }

    /// The full SSD map (`f32`, shape `(H - h + 1, W - w + 1)`), via FFT:
    /// `sum m T^2 + boxsum/corr(m, S) - 2 sum_c corr(m T_c, I_c)`, clamped at 0.
    /// Computed with `f32` transforms on centred planes: accurate to about `1e-6` relative to the largest
    /// term for typical images (far inside `1e-4`).
    pub fn ssd_map(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
    ) -> Result<Array2<f32>> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        self.ensure::<f32>(m.is_some())?;
        let map = self.fft_map_f32(&t, m.as_deref());
        let dim = self.map_dim(t.h, t.w);
        Ok(Array2::from_shape_vec(dim, map).expect("map length matches its shape"))
    }

    /// The SSD map in `f64` (`f64` transforms), together with a rigorous-enough bound on its absolute
    /// error against the exact SSD.
    pub fn ssd_map_f64(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
    ) -> Result<(Array2<f64>, f64)> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        self.ensure::<f64>(m.is_some())?;
        let (map, bound) = self.fft_map_f64(&t, m.as_deref());
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
        if k > 0 {
            self.ensure::<f64>(m.is_some())?;
        }
        let mut ws = BestWs::default();
        Ok(self.best_prepared(&t, m.as_deref(), k, exclude_radius, &mut ws))
    }

    /// [`SsdIndex::best_matches`] by the first implementation (every translation sorted up front): the
    /// baseline of the benches. Same results.
    #[doc(hidden)]
    pub fn best_matches_sorting(
        &self,
        template: ArrayView3<f32>,
        mask: Option<ArrayView2<bool>>,
        k: usize,
        exclude_radius: usize,
    ) -> Result<Vec<Match>> {
        let t = self.prepare_template("template", template)?;
        let m = prepare_mask(mask, t.h, t.w)?;
        if k > 0 {
            self.ensure::<f64>(m.is_some())?;
        }
        Ok(self.best_prepared_sorting(&t, m.as_deref(), k, exclude_radius))
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

    /// [`SsdIndex::exact`], compiled for AVX2 when the CPU has it (the matching stage). The same operations
    /// in the same order (four fixed lanes, no FMA), so the same bits.
    fn exact_fast(&self, t: &Tmpl, mask: Option<&[bool]>, ty: usize, tx: usize) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (just checked).
            return unsafe { self.exact_avx2(t, mask, ty, tx) };
        }
        self.exact(t, mask, ty, tx)
    }

    /// # Safety
    /// The CPU must have AVX2 (`unsafe fn`: see [`best_cols_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn exact_avx2(&self, t: &Tmpl, mask: Option<&[bool]>, ty: usize, tx: usize) -> f64 {
        self.exact_body(t, mask, ty, tx)
    }

    /// The direct `f64` SSD at `(ty, tx)` (no validation). Fixed summation order.
    fn exact(&self, t: &Tmpl, mask: Option<&[bool]>, ty: usize, tx: usize) -> f64 {
        self.exact_body(t, mask, ty, tx)
    }

    #[inline(always)]
    fn exact_body(&self, t: &Tmpl, mask: Option<&[bool]>, ty: usize, tx: usize) -> f64 {
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

    /// The map with `f32` transforms, unless the typical `f32` rounding error (`est`, see
    /// [`SsdIndex::fft_map`]) exceeds `F32_REL_EST` of the map's largest value: then (flat images, maps
    /// that are nearly zero everywhere) the map is recomputed with `f64` transforms.
    fn fft_map_f32(&self, t: &Tmpl, mask: Option<&[bool]>) -> Vec<f32> {
        let (map, _, est) = self.fft_map::<f32, f32, _>(t, mask, |v| v as f32);
        let max = map.iter().fold(0.0f32, |a, &v| a.max(v)) as f64;
        if est <= F32_REL_EST * max {
            return map;
        }
        self.fft_map::<f64, f32, _>(t, mask, |v| v as f32).0
    }

    fn fft_map_f64(&self, t: &Tmpl, mask: Option<&[bool]>) -> (Vec<f64>, f64) {
        let (map, bound, _) = self.fft_map::<f64, f64, _>(t, mask, |v| v);
        (map, bound)
    }

    /// The template-side constants of a map: `sum m T^2`, `sum m |T|`, the mask's count and the centring
    /// constant `sum_q mean_q * sum(p_q)`.
    fn template_consts(&self, t: &Tmpl, mask: Option<&[bool]>) -> TConsts {
        let c = self.c;
        let data = &t.data;
        // The constant term sum m T^2 and the norms of the template side (for the error bound), as
        // lane-parallel sums (fixed order, vectorisable): sq = sum m T^2, l1 = sum m |T|, over all channels.
        let (sum_t2, l1) =
            match mask {
                None => lane_sums_f32(data),
                Some(m) => lane_sums(data.chunks_exact(c).zip(m).flat_map(|(px, &on)| {
                    px.iter().map(move |&v| if on { v as f64 } else { 0.0 })
                })),
            };
        let nnz = mask.map_or(0, |m| m.iter().filter(|&&on| on).count()) as f64;
        // The centring constant sum_q mean_q * sum(p_q).
        let mut psum = vec![0.0f64; c];
        match mask {
            None => {
                for px in data.chunks_exact(c) {
                    for (s, &v) in psum.iter_mut().zip(px) {
                        *s += v as f64;
                    }
                }
            }
            Some(m) => {
                for (px, _) in data.chunks_exact(c).zip(m).filter(|(_, &on)| on) {
                    for (s, &v) in psum.iter_mut().zip(px) {
                        *s += v as f64;
                    }
                }
            }
        }
        let mut kconst = 0.0f64;
        for (ch, &ps) in psum.iter().enumerate() {
            kconst += self.means[ch] * (-2.0 * ps);
        }
        if mask.is_some() {
            kconst += self.means[c] * nnz;
        }

        TConsts {
            sum_t2,
            l1,
            nnz,
            kconst,
        }
    }

    /// [`SsdIndex::template_consts`] of an unmasked template with `C` dividing 24, in one pass of 24 lanes
    /// (the flat index modulo 24 fixes the channel of a lane, so every lane sums one channel; vectorisable,
    /// where the per-channel running sums of `template_consts` are one long dependency chain each). The
    /// sums are the same up to rounding (another fixed order), which the bound's terms for the constant
    /// (`k_err`, `sum_err`) cover; used by [`SsdIndex::fft_map_best`] only.
    #[inline(always)]
    fn template_consts_unmasked(&self, t: &Tmpl) -> TConsts {
        const L: usize = 24;
        let c = self.c;
        debug_assert_eq!(L % c, 0);
        let (mut sq, mut ab, mut sm) = ([0.0f64; L], [0.0f64; L], [0.0f64; L]);
        let mut chunks = t.data.chunks_exact(L);
        for ch in &mut chunks {
            for l in 0..L {
                let x = ch[l] as f64;
                sq[l] += x * x;
                ab[l] += x.abs();
                sm[l] += x;
            }
        }
        for (l, &x) in chunks.remainder().iter().enumerate() {
            let x = x as f64;
            sq[l] += x * x;
            ab[l] += x.abs();
            sm[l] += x;
        }
        let (sum_t2, l1) = (sq.iter().sum::<f64>(), ab.iter().sum::<f64>());
        let mut kconst = 0.0f64;
        for ch in 0..c {
            let ps: f64 = sm.iter().skip(ch).step_by(c).sum();
            kconst += self.means[ch] * (-2.0 * ps);
        }
        TConsts {
            sum_t2,
            l1,
            nnz: 0.0,
            kconst,
        }
    }

    /// The rigorous bound on the absolute error of a map with transforms in `T` (see the module docs), and
    /// the typical size of the transform rounding error (see [`SsdIndex::fft_map`]).
    fn map_bound<T: Real>(&self, th: usize, tw: usize, masked: bool, tc: &TConsts) -> (f64, f64) {
        let (hh, ww, c) = (self.h, self.w, self.c);
        let TConsts {
            sum_t2, l1, nnz, ..
        } = *tc;
        // Error bound (see the module docs): per plane pair, the FFT correlation error is at most
        // ~ 3 a (||x||_2 ||y||_1 + ||x||_1 ||y||_2) with a = (rounding per FFT level) * (levels), doubled
        // for the pair packing; plus the rounding of the centred image values, of the centring constant,
        // of the final sums and of the integral image.
        let eps = T::epsilon().to64();
        let e64 = f64::EPSILON;
        let levels = (ceil_log2(hh) + ceil_log2(ww) + 8) as f64;
        let a = 16.0 * eps * levels;
        // Template side: the planes -2 m T_c (sum_c ||x_c||_2 <= sqrt(C) * 2 sqrt(sum_t2) and
        // sum_c ||x_c||_1 = 2 l1) against the largest centred image channel norms; then m against S'.
        let (y1, y2, yinf) = self.norms[..c]
            .iter()
            .fold((0.0f64, 0.0f64, 0.0f64), |(a, b, d), &(n1, n2, ni)| {
                (a.max(n1), b.max(n2), d.max(ni))
            });
        let mean_max = self.means[..c].iter().fold(0.0f64, |a, &m| a.max(m.abs()));
        let x2 = 2.0 * (c as f64).sqrt() * sum_t2.sqrt();
        let x1 = 2.0 * l1;
        let mut fft_err = 6.0 * a * (x2 * y1 + x1 * y2);
        let mut zmax = x2 * y2;
        let mut cent_err = 2.0 * eps * x1 * yinf;
        let mut k_abs = mean_max * x1;
        if masked {
            let (s1, s2, sinf) = self.norms[c];
            fft_err += 6.0 * a * (nnz.sqrt() * s1 + nnz * s2);
            zmax += nnz.sqrt() * s2;
            cent_err += 2.0 * eps * nnz * sinf;
            k_abs += self.means[c].abs() * nnz;
        }
        let k_err = (th * tw + 8) as f64 * e64 * k_abs;
        let box_err = 4.0 * (hh + ww + 4) as f64 * e64 * self.s_total;
        let sum_err = 8.0 * e64 * (sum_t2 + self.s_total + zmax + k_abs);
        let est = 2.0 * eps * levels.sqrt() * zmax;
        (fft_err + cent_err + k_err + box_err + sum_err, est)
    }

    /// The FFT map with transforms in `T` (row-major, clamped at 0, converted by `cvt`), the rigorous
    /// bound on its absolute error, and a typical (not rigorous) size of the transform rounding error,
    /// `2 eps sqrt(levels) ||x||_2 ||y'||_2`, used to choose the precision of maps.
    fn fft_map<T: Real, O: Copy + Default + Send + Sync, F: Fn(f64) -> O + Copy + Send + Sync>(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        cvt: F,
    ) -> (Vec<O>, f64, f64) {
        let (hh, ww, c) = (self.h, self.w, self.c);
        let wc = ww / 2 + 1;
        let (th, tw) = (t.h, t.w);
        let (mh, mw) = self.map_dim(th, tw);
        let par = self.par();
        let spec = self.spec::<T>();
        let tail = mask.map(|_| self.tail::<T>());
        let plans = &spec.plans;
        // Template-side planes: -2 m T_c for every channel, then m (masked only). Scaling by -2 is exact.
        let np = if mask.is_some() { c + 1 } else { c };
        let data = &t.data;
        let zero = Complex::<T>::zero();

        let tc = self.template_consts(t, mask);
        let (sum_t2, kconst) = (tc.sum_t2, tc.kconst);

        let tfill = |q: usize, y: usize, out: &mut [T]| {
            let row = &data[y * tw * c..(y + 1) * tw * c];
            let (head, rest) = out.split_at_mut(tw);
            rest.fill(T::zero());
            match mask {
                // Plain strided indexing: this loop runs for every template row and plane, and the
                // chunk iterator it replaces was not always inlined.
                None => {
                    for (x, b) in head.iter_mut().enumerate() {
                        *b = T::of(-2.0 * row[x * c + q] as f64);
                    }
                }
                Some(m) => {
                    let mr = &m[y * tw..(y + 1) * tw];
                    for ((b, px), &on) in head.iter_mut().zip(row.chunks_exact(c)).zip(mr) {
                        *b = match (on, q < c) {
                            (false, _) => T::zero(),
                            (true, true) => T::of(-2.0 * px[q] as f64),
                            (true, false) => T::one(),
                        };
                    }
                }
            }
        };

        // Row transforms of every template group (only its `th` rows), kept whole (they are small: `th x W`).
        // Then, per block of columns `kx < W/2 + 1`, everything else while the block is in cache: the column
        // transforms of the block (for a pair also those of the mirrored columns `W − kx`, which the pair's
        // products need), the products with the image spectra accumulated over the groups in a fixed order,
        // and the inverse column transforms. Same operations in the same order as transforming each group
        // whole and accumulating image-sized arrays, so the same values, with a fraction of the memory
        // traffic (one pass over the image spectra; no `W x H` intermediate per group).
        let groups: Vec<(Vec<Complex<T>>, &Chunk<T>)> = (0..np.div_ceil(2))
            .map(|k| {
                let qa = 2 * k;
                let img = match tail {
                    Some(tl) if k >= c / 2 => tl,
                    _ => &spec.chunks[k],
                };
                let rows = match img {
                    Chunk::Pair { .. } => {
                        debug_assert!(qa + 1 < np);
                        rows_pair(plans, ww, th, par, &tfill, qa, qa + 1)
                    }
                    Chunk::Lone(_) => {
                        debug_assert!(qa + 1 == np);
                        rows_real(plans, ww, th, par, &tfill, qa)
                    }
                };
                (rows, img)
            })
            .collect();
        let scratch_len = plans.scratch;
        // Column stride of the block buffers: `hh` rounded up to 8, plus 8 (never a multiple of a large power
        // of two, see [`gather_cols`]).
        let st = hh.next_multiple_of(8) + 8;
        let mut g = vec![zero; wc * hh];
        for_each_block(
            &mut g,
            COL_BLOCK * hh,
            par,
            || {
                (
                    vec![zero; COL_BLOCK * st],
                    vec![zero; COL_BLOCK * st],
                    vec![zero; scratch_len],
                )
            },
            |(za, zb, s), bi, blk| {
                let kx0 = bi * COL_BLOCK;
                let nb = blk.len() / hh;
                for (zr, img) in &groups {
                    match img {
                        Chunk::Pair { u, v } => {
                            gather_cols(zr, ww, th, hh, st, nb, |j| kx0 + j, za);
                            gather_cols(zr, ww, th, hh, st, nb, |j| mirror(kx0 + j, ww), zb);
                            for j in 0..nb {
                                plans
                                    .fwd_h
                                    .process_with_scratch(&mut za[j * st..j * st + hh], s);
                                plans
                                    .fwd_h
                                    .process_with_scratch(&mut zb[j * st..j * st + hh], s);
                            }
                            for (j, gk) in blk.chunks_exact_mut(hh).enumerate() {
                                let o = (kx0 + j) * hh;
                                accumulate_pair_col(
                                    gk,
                                    &za[j * st..j * st + hh],
                                    &zb[j * st..j * st + hh],
                                    &u[o..o + hh],
                                    &v[o..o + hh],
                                );
                            }
                        }
                        Chunk::Lone(x) => {
                            split_real_cols(zr, ww, th, hh, st, nb, kx0, za);
                            for (j, gk) in blk.chunks_exact_mut(hh).enumerate() {
                                plans
                                    .fwd_h
                                    .process_with_scratch(&mut za[j * st..j * st + hh], s);
                                let o = (kx0 + j) * hh;
                                accumulate_lone_block(gk, &za[j * st..j * st + hh], &x[o..o + hh]);
                            }
                        }
                    }
                }
                plans.inv_h.process_with_scratch(blk, s);
            },
        );
        drop(groups);

        // A real inverse transform of each valid row, plus the constants.
        let scale = 1.0 / (hh as f64 * ww as f64);
        let base = sum_t2 + kconst;
        let w_even = ww % 2 == 0;
        let integral = &self.integral;
        let iw = ww + 1;
        let mut map = vec![O::default(); mh * mw];
        for_each_block(
            &mut map,
            ROW_BLOCK * mw,
            par,
            || {
                (
                    vec![zero; ROW_BLOCK * wc],
                    vec![T::zero(); ww],
                    vec![zero; scratch_len],
                )
            },
            |(rows, outr, scratch), bi, out| {
                let y0 = bi * ROW_BLOCK;
                let nr = out.len() / mw;
                for kx in 0..wc {
                    for (j, &v) in g[kx * hh + y0..][..nr].iter().enumerate() {
                        rows[j * wc + kx] = v;
                    }
                }
                for j in 0..nr {
                    let row = &mut rows[j * wc..(j + 1) * wc];
                    row[0].im = T::zero();
                    if w_even {
                        row[wc - 1].im = T::zero();
                    }
                    let r = plans.inv_w.process_with_scratch(row, outr, scratch);
                    debug_assert!(r.is_ok());
                    let y = y0 + j;
                    let orow = &mut out[j * mw..(j + 1) * mw];
                    if mask.is_some() {
                        for (o, &z) in orow.iter_mut().zip(&outr[..mw]) {
                            *o = cvt((base + z.to64() * scale).max(0.0));
                        }
                    } else {
                        let (top, bot) = (&integral[y * iw..], &integral[(y + th) * iw..]);
                        let (tl, tr) = (&top[..mw], &top[tw..tw + mw]);
                        let (bl, br) = (&bot[..mw], &bot[tw..tw + mw]);
                        for x in 0..mw {
                            let boxsum = (br[x] - tr[x]) - (bl[x] - tl[x]);
                            orow[x] = cvt((base + boxsum + outr[x].to64() * scale).max(0.0));
                        }
                    }
                }
            },
        );

        let (bound, est) = self.map_bound::<T>(th, tw, mask.is_some(), &tc);
        (map, bound, est)
    }

    /// The `f64` FFT map of [`SsdIndex::best_matches`] only: [`SsdIndex::best_cols`] then
    /// [`SsdIndex::best_rows`], the map into `ws.map` (row-major, `(H - h + 1) x (W - w + 1)`), with its
    /// rigorous error bound and its minimum `(value, first index, count of ties)`.
    ///
    /// The transforms, products and sums are those of [`SsdIndex::fft_map`] in the same order (up to the
    /// sign of zeros, and the centring constant summed in another fixed order, see
    /// [`SsdIndex::template_consts_unmasked`]), so the values are those of [`SsdIndex::ssd_map_f64`] to
    /// within its bound, and the same bound holds. What differs is the work around the transforms, which
    /// the profile of the matching stage showed to be as large as the transforms themselves: the buffers
    /// live in `ws` and are reused across the templates of a call (no zero fill and no page faults per
    /// template); the template rows are written straight into the complex rows; the transposes store whole
    /// cache lines; the minimum the walk starts from is found while the map is written; and these loops are
    /// compiled for AVX2 when the CPU has it. `ssd_map_f64` (GA/AIS partial maps) and the sorting baseline
    /// of the benches keep [`SsdIndex::fft_map`].
    fn fft_map_best(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        ws: &mut BestWs,
    ) -> (f64, (f64, usize, usize)) {
        self.best_cols(t, mask, ws);
        self.best_rows(t, mask, ws)
    }

    /// The row transforms and the column pass of [`SsdIndex::fft_map_best`].
    fn best_cols(&self, t: &Tmpl, mask: Option<&[bool]>, ws: &mut BestWs) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (just checked).
            return unsafe { best_cols_avx2(self, t, mask, ws) };
        }
        best_cols_plain(self, t, mask, ws)
    }

    /// The inverse row transforms, the constants and the minimum of [`SsdIndex::fft_map_best`].
    fn best_rows(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        ws: &mut BestWs,
    ) -> (f64, (f64, usize, usize)) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2 (just checked).
            return unsafe { best_rows_avx2(self, t, mask, ws) };
        }
        best_rows_plain(self, t, mask, ws)
    }

    /// Greedy exact best matches on a prepared template.
    ///
    /// A translation is *resolved* when its exact SSD is known; resolved ones wait in a min-heap on
    /// (exact, index). The top of the heap is the next match as soon as every unresolved translation has
    /// `f > top + bound` (`f` its FFT value; its exact value is then `> top`): so we resolve, in `f` order
    /// (ties by index), only what could still beat the top, each translation at most once.
    ///
    /// The map is that of [`SsdIndex::fft_map_best`] (the matching stage's own, buffers in `ws`), which
    /// also reports its minimum. The `f` order is built lazily ([`LazyOrder`]): the minimum starts it, one
    /// linear pass moves the translations within the exactness bound into a small sorted prefix — for
    /// `k = 1` that is the whole cost (about 1 ms at 1024², where sorting every translation took ~100 ms),
    /// with a unique minimum no pass at all before the exact sum of the minimum. When more
    /// are needed (`k > 1`, large ties) the prefix grows at least geometrically, so the worst case stays
    /// O(n log n). The prefix is always exactly the prefix of the full sort, so the walk, and therefore
    /// the result, is identical to [`SsdIndex::best_prepared_sorting`] (tested), which is the exact greedy
    /// definition.
    fn best_prepared(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        k: usize,
        r: usize,
        ws: &mut BestWs,
    ) -> Vec<Match> {
        self.best_fast(t, mask, k, r, ws, false)
    }

    /// [`SsdIndex::best_prepared`] by the lazy order, whatever `k` and `r` (the tests compare it with the
    /// sorting path in every regime).
    #[cfg(test)]
    fn best_prepared_lazy(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        k: usize,
        r: usize,
    ) -> Vec<Match> {
        self.best_fast(t, mask, k, r, &mut BestWs::default(), true)
    }

    /// The matching stage's walk on the map of [`SsdIndex::fft_map_best`]. `lazy_only`: never sort the
    /// whole order up front (tests).
    fn best_fast(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        k: usize,
        r: usize,
        ws: &mut BestWs,
        lazy_only: bool,
    ) -> Vec<Match> {
        let (mh, mw) = self.map_dim(t.h, t.w);
        let n = mh * mw;
        if k.min(n) == 0 {
            return Vec::new();
        }
        // When the matches and their exclusion windows could cover the whole map, the walk reaches
        // most translations anyway: sorting them all at once is then cheaper than growing the prefix in
        // many steps (same walk, same result).
        let side = 2 * r as u128 + 1;
        let covered = (k.min(n) as u128).saturating_mul(side.saturating_mul(side));
        let sort_all = !lazy_only && k > 1 && covered >= n as u128;
        let (bound, first) = self.fft_map_best(t, mask, ws);
        self.walk_map(
            t,
            mask,
            k,
            r,
            sort_all,
            &ws.map[..n],
            bound,
            Some(first),
            true,
        )
    }

    /// The greedy walk of both paths: translations in increasing FFT value, each one's exact SSD computed
    /// when the bound cannot rule it out, the best k taken with their exclusion windows. `sort_all`: the
    /// order is sorted whole up front ([`LazyOrder::full`]) instead of grown lazily; the walk is the same.
    /// `map`, `bound`: the map of [`SsdIndex::fft_map_best`] with `first` its minimum (the matching stage,
    /// `fast`: exact sums by [`SsdIndex::exact_fast`]) or that of [`SsdIndex::ssd_map_f64`] (the sorting
    /// baseline). Whatever the map, as long as its bound holds the walk returns the exact greedy answer, so
    /// both give the same result.
    #[allow(clippy::too_many_arguments)]
    fn walk_map(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        k: usize,
        r: usize,
        sort_all: bool,
        map: &[f64],
        bound: f64,
        first: Option<(f64, usize, usize)>,
        fast: bool,
    ) -> Vec<Match> {
        let (mh, mw) = self.map_dim(t.h, t.w);
        let n = mh * mw;
        debug_assert_eq!(map.len(), n);
        let k = k.min(n);
        if k == 0 {
            return Vec::new();
        }
        let mut order = if sort_all {
            LazyOrder::full(map)
        } else {
            LazyOrder::new(map, first)
        };
        // + 0.0: no -0.0 in the order
        let exact = |i: usize| {
            let e = if fast {
                self.exact_fast(t, mask, i / mw, i % mw)
            } else {
                self.exact(t, mask, i / mw, i % mw)
            };
            e + 0.0
        };
        let mut excluded = if k > 1 { vec![false; n] } else { Vec::new() };
        let is_excluded = |ex: &[bool], i: usize| !ex.is_empty() && ex[i];
        // `order.sorted[..next]` are resolved or were excluded when reached (exclusion never ends).
        let mut next = 0;
        let mut heap: BinaryHeap<Reverse<(TotalF64, usize)>> = BinaryHeap::new();
        let mut out = Vec::with_capacity(k);
        while out.len() < k {
            while let Some(Reverse((_, i))) = heap.peek() {
                if is_excluded(&excluded, *i) {
                    heap.pop();
                } else {
                    break;
                }
            }
            if heap.is_empty() {
                loop {
                    if next == order.sorted.len() && !order.grow() {
                        break;
                    }
                    if !is_excluded(&excluded, order.sorted[next]) {
                        break;
                    }
                    next += 1;
                }
                // NaN FFT values never enter the order; +inf ones are never a match (as no finite
                // input makes them)
                if next == order.sorted.len() || map[order.sorted[next]] == f64::INFINITY {
                    break;
                }
                let i = order.sorted[next];
                next += 1;
                heap.push(Reverse((TotalF64(exact(i)), i)));
            }
            loop {
                let top = heap.peek().map_or(f64::NAN, |Reverse((e, _))| e.0);
                let thr = top + bound;
                order.cover(thr);
                let mut batch = Vec::new();
                while next < order.sorted.len() && map[order.sorted[next]] <= thr {
                    let i = order.sorted[next];
                    next += 1;
                    if !is_excluded(&excluded, i) {
                        batch.push(i);
                    }
                }
                if batch.is_empty() {
                    break;
                }
                let vals: Vec<f64> = if batch.len() >= 64 {
                    batch.par_iter().map(|&i| exact(i)).collect()
                } else {
                    batch.iter().map(|&i| exact(i)).collect()
                };
                heap.extend(
                    batch
                        .into_iter()
                        .zip(vals)
                        .map(|(i, e)| Reverse((TotalF64(e), i))),
                );
            }
            let Some(Reverse((TotalF64(e), i))) = heap.pop() else {
                break;
            };
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

    /// The greedy exact best matches of [`SsdIndex::walk_map`] (the same results) on a map that is summed a
    /// block of [`QBS`] x [`QBS`] translations at a time, only where it can matter. `bmin` holds a lower
    /// bound of each block's minimum and `fill(map, yb, xb)` writes a block's values into `map`. A block is
    /// filled when its bound is the least of all (until that block is a filled one: its minimum is then the
    /// map's minimum `m0`) or when its bound is within the walk's threshold `m0 + 2 bound` (its translations
    /// may be candidates); every other block's values are above the threshold. So the candidates, their
    /// exact SSDs and the matches are those of the whole map, bit for bit. Translations are excluded by
    /// setting their value to `+inf`: in filled blocks at once, in the others when they are filled (the
    /// windows are recorded). Each match is the smallest `(exact, index)` among the candidates.
    #[allow(clippy::too_many_arguments)]
    fn walk_blocks_lazy(
        &self,
        t: &Tmpl,
        k: usize,
        r: usize,
        map: &mut [f64],
        mut bmin: Vec<f64>,
        fill: &dyn Fn(&mut [f64], usize, usize),
        bound: f64,
    ) -> Vec<Match> {
        const BS: usize = QBS;
        let (mh, mw) = self.map_dim(t.h, t.w);
        let n = mh * mw;
        debug_assert_eq!(map.len(), n);
        let k = k.min(n);
        let (by, bx) = (mh.div_ceil(BS), mw.div_ceil(BS));
        debug_assert_eq!(bmin.len(), by * bx);
        let mut filled = vec![false; by * bx];
        // the unfilled blocks by bound (NaN bounds last: such a block is filled only if nothing else is left)
        let mut heap: BinaryHeap<Reverse<(TotalF64, usize)>> = bmin
            .iter()
            .enumerate()
            .map(|(b, &v)| Reverse((TotalF64(if v.is_nan() { f64::INFINITY } else { v }), b)))
            .collect();
        let mut windows: Vec<(usize, usize, usize, usize)> = Vec::new();
        let block_min = |map: &[f64], yb: usize, xb: usize| -> f64 {
            let mut m = f64::INFINITY;
            for y in yb * BS..((yb + 1) * BS).min(mh) {
                for &v in &map[y * mw + xb * BS..y * mw + ((xb + 1) * BS).min(mw)] {
                    if v < m {
                        m = v;
                    }
                }
            }
            m
        };
        let materialise =
            |map: &mut [f64], filled: &mut [bool], bmin: &mut [f64], b: usize, ws: &[_]| {
                let (yb, xb) = (b / bx, b % bx);
                fill(map, yb, xb);
                let (by0, by1) = (yb * BS, ((yb + 1) * BS).min(mh) - 1);
                let (bx0, bx1) = (xb * BS, ((xb + 1) * BS).min(mw) - 1);
                for &(y0, y1, x0, x1) in ws {
                    let (ya, yz) = (by0.max(y0), by1.min(y1));
                    let (xa, xz) = (bx0.max(x0), bx1.min(x1));
                    if ya <= yz && xa <= xz {
                        for yy in ya..=yz {
                            map[yy * mw + xa..=yy * mw + xz].fill(f64::INFINITY);
                        }
                    }
                }
                filled[b] = true;
                bmin[b] = block_min(map, yb, xb);
            };
        let mut resolved: std::collections::HashMap<usize, f64> = std::collections::HashMap::new();
        let mut out = Vec::with_capacity(k);
        while out.len() < k {
            // The true minimum, best first: the least minimum of the filled blocks `m`; while an unfilled
            // block's bound is below it, fill the block of least bound (it may hold a smaller value).
            let mut m = bmin
                .iter()
                .zip(&filled)
                .filter(|(_, &f)| f)
                .fold(f64::INFINITY, |a, (&v, _)| if v < a { v } else { a });
            while let Some(&Reverse((TotalF64(lb), b))) = heap.peek() {
                if lb >= m {
                    break;
                }
                heap.pop();
                materialise(map, &mut filled, &mut bmin, b, &windows);
                if bmin[b] < m {
                    m = bmin[b];
                }
            }
            let m0 = m;
            if m0 == f64::INFINITY || m0.is_nan() {
                break;
            }
            let thr = m0 + 2.0 * bound + 4.0 * f64::EPSILON * m0.abs();
            while let Some(&Reverse((TotalF64(lb), b))) = heap.peek() {
                if lb > thr {
                    break;
                }
                heap.pop();
                materialise(map, &mut filled, &mut bmin, b, &windows);
            }
            let mut best: Option<(f64, usize)> = None;
            for (b, &bm) in bmin.iter().enumerate() {
                if bm.is_nan() || bm > thr {
                    continue;
                }
                let (yb, xb) = (b / bx, b % bx);
                for y in yb * BS..((yb + 1) * BS).min(mh) {
                    for x in xb * BS..((xb + 1) * BS).min(mw) {
                        let i = y * mw + x;
                        if map[i] <= thr {
                            let e = *resolved
                                .entry(i)
                                .or_insert_with(|| self.exact_fast(t, None, y, x) + 0.0);
                            let better = match best {
                                None => true,
                                Some((be, bi)) => match e.total_cmp(&be) {
                                    std::cmp::Ordering::Less => true,
                                    std::cmp::Ordering::Equal => i < bi,
                                    std::cmp::Ordering::Greater => false,
                                },
                            };
                            if better {
                                best = Some((e, i));
                            }
                        }
                    }
                }
            }
            let Some((e, i)) = best else {
                break;
            };
            let (row, col) = (i / mw, i % mw);
            out.push(Match { row, col, ssd: e });
            // exclude the window (only the chosen one when r = 0: distinct translations)
            let (y0, y1) = (row.saturating_sub(r), row.saturating_add(r).min(mh - 1));
            let (x0, x1) = (col.saturating_sub(r), col.saturating_add(r).min(mw - 1));
            windows.push((y0, y1, x0, x1));
            for yb in y0 / BS..=y1 / BS {
                for xb in x0 / BS..=x1 / BS {
                    let b = yb * bx + xb;
                    if filled[b] {
                        let (ya, yz) = ((yb * BS).max(y0), (((yb + 1) * BS).min(mh) - 1).min(y1));
                        let (xa, xz) = ((xb * BS).max(x0), (((xb + 1) * BS).min(mw) - 1).min(x1));
                        for yy in ya..=yz {
                            map[yy * mw + xa..=yy * mw + xz].fill(f64::INFINITY);
                        }
                        bmin[b] = block_min(map, yb, xb);
                    }
                }
            }
        }
        out
    }

    /// The first implementation of [`SsdIndex::best_prepared`]: the same greedy walk over *every*
    /// translation sorted by its FFT value up front (O(n log n) per template, ~100 ms at 1024²). Kept as the
    /// baseline of the benches and as the oracle of the tests (the results are identical).
    fn best_prepared_sorting(
        &self,
        t: &Tmpl,
        mask: Option<&[bool]>,
        k: usize,
        r: usize,
    ) -> Vec<Match> {
        let (mh, mw) = self.map_dim(t.h, t.w);
        if k.min(mh * mw) == 0 {
            return Vec::new();
        }
        let (map, bound) = self.fft_map_f64(t, mask);
        self.walk_map(t, mask, k, r, true, &map, bound, None, false)
    }
}

/// The translations in increasing FFT value (ties by index, NaN never), built lazily: `sorted` is always
/// exactly the prefix of that full order made of the translations with `f <= covered`, so the others are
/// implicitly those with `f > covered` (no list of them is kept: each growth step is one pass over the map).
///
/// A step moves every translation with `covered < f <= c` for a cut value `c` into `sorted`, sorted by
/// `partial_cmp`, then index: the comparator of the full sort (so `-0.0` and `0.0` tie there too). The
/// first step cuts at the minimum; later ones at an estimated quantile (from a strided sample of the map)
/// that at least doubles the prefix, so many steps (`k > 1`, large ties) stay O(n log n) in all.
struct LazyOrder<'a> {
    map: &'a [f64],
    sorted: Vec<usize>,
    covered: f64,
    /// Translations (not NaN) not yet in `sorted`.
    left: usize,
    /// The map's minimum, its first index and its number of ties, when known (found while the map was
    /// written): the first step then needs no pass over the map (none at all without ties).
    first: Option<(f64, usize, usize)>,
}

impl<'a> LazyOrder<'a> {
    /// Later growth steps add at least this many translations (and at least double the prefix).
    const MIN_GROW: usize = 64;
    /// About this many map values are sampled to estimate a cut value.
    const SAMPLE: usize = 4096;

    /// The order of `map`; `first`: its minimum, first index and ties, when known (a map without NaN).
    fn new(map: &'a [f64], first: Option<(f64, usize, usize)>) -> Self {
        let nan = match first {
            Some(_) => {
                debug_assert!(!map.iter().any(|v| v.is_nan()));
                0
            }
            None => map.iter().filter(|v| v.is_nan()).count(),
        };
        LazyOrder {
            map,
            sorted: Vec::new(),
            covered: f64::NEG_INFINITY,
            left: map.len() - nan,
            first,
        }
    }

    /// The whole order at once (every translation that is not NaN; nothing left to grow).
    fn full(map: &'a [f64]) -> Self {
        let mut order = Self::new(map, None);
        order.take_upto(f64::INFINITY);
        order
    }

    /// Moves every translation with `covered < f <= c` into `sorted` (in order); `covered = c`.
    fn take_upto(&mut self, c: f64) {
        let map = self.map;
        let lo = self.covered;
        let mut part: Vec<usize> = (0..map.len())
            .filter(|&i| map[i] > lo && map[i] <= c)
            .collect();
        part.sort_unstable_by(|&a, &b| {
            map[a]
                .partial_cmp(&map[b])
                .unwrap_or(std::cmp::Ordering::Equal)
                .then(a.cmp(&b))
        });
        self.left -= part.len();
        self.sorted.extend_from_slice(&part);
        self.covered = c;
    }

    /// The smallest FFT value above `covered` (+inf if none).
    fn next_min(&self) -> f64 {
        let lo = self.covered;
        self.map
            .iter()
            .fold(f64::INFINITY, |a, &v| if v > lo && v < a { v } else { a })
    }

    /// A cut value with about `want` of the remaining translations at or below it (estimated from a strided
    /// sample; `+inf` when the sample has none left).
    fn quantile(&self, want: usize) -> f64 {
        let lo = self.covered;
        let stride = (self.map.len() / Self::SAMPLE).max(1);
        let mut sample: Vec<f64> = self
            .map
            .iter()
            .step_by(stride)
            .copied()
            .filter(|&v| v > lo)
            .collect();
        if sample.is_empty() {
            return f64::INFINITY;
        }
        let q = (want as f64 / self.left as f64 * sample.len() as f64).ceil() as usize;
        let q = q.clamp(1, sample.len()) - 1;
        let (_, v, _) = sample.select_nth_unstable_by(q, |a, b| {
            a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal)
        });
        *v
    }

    /// The cut value of a geometric growth step (`+inf`: take everything left).
    fn growth_cut(&self) -> f64 {
        let want = Self::MIN_GROW.max(self.sorted.len());
        if want >= self.left {
            f64::INFINITY
        } else {
            self.quantile(want)
        }
    }

    /// At least one more translation in `sorted`, if any is left; false if none is.
    fn grow(&mut self) -> bool {
        if self.left == 0 {
            return false;
        }
        if self.sorted.is_empty() {
            // the first step only needs the minimum (and its ties)
            match self.first.take() {
                Some((c, i, 1)) => {
                    // a unique minimum: the prefix of the full sort up to it is just its index
                    debug_assert_eq!(self.map[i], c);
                    self.sorted.push(i);
                    self.left -= 1;
                    self.covered = c;
                }
                Some((c, _, _)) => self.take_upto(c),
                None => {
                    let c = self.next_min();
                    self.take_upto(c);
                }
            }
            return true;
        }
        let before = self.sorted.len();
        let c = self.growth_cut();
        self.take_upto(c);
        if self.sorted.len() == before {
            let c = self.next_min();
            self.take_upto(c);
        }
        true
    }

    /// Every translation with `f <= thr` in `sorted` (a no-op when `thr <= covered`).
    fn cover(&mut self, thr: f64) {
        if thr.is_nan() || thr <= self.covered || self.left == 0 {
            return;
        }
        let c = thr.max(self.growth_cut());
        self.take_upto(c);
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
    let n = checked_len("templates", &[ts.len(), mh, mw])?;
    let mut out = Array3::from_shape_vec((ts.len(), mh, mw), try_vec("templates", n, 0.0f32)?)
        .expect("length matches the shape");
    if ts.is_empty() {
        return Ok(out);
    }
    index.ensure::<f32>(m.is_some())?;
    out.axis_iter_mut(Axis(0))
        .into_par_iter()
        .zip(ts.par_iter())
        .for_each(|(mut o, t)| {
            let map = index.fft_map_f32(t, m.as_deref());
            for (d, s) in o.iter_mut().zip(map) {
                *d = s;
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
    if !ts.is_empty() && k > 0 {
        index.ensure::<f64>(m.is_some())?;
    }
    // One buffer set per piece of the parallel loop, reused across its templates, and handed on to the
    // next piece through a pool of this call: rayon splits the templates into more pieces than threads
    // (two with one thread), so without the pool every piece allocated and zero-filled its own. The pool
    // holds at most one set per thread and is released at the end of the call.
    let pool = Mutex::new(Vec::new());
    Ok(ts
        .par_iter()
        .map_init(
            || {
                Pooled(
                    pool.lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .pop()
                        .unwrap_or_default(),
                    &pool,
                )
            },
            |ws, t| index.best_prepared(t, m.as_deref(), k, exclude_radius, &mut ws.0),
        )
        .collect())
}

/// The FFT map of a quadrant template `(hq, wq, C)` for [`best_matches_quadrants`], stored in `f32`: the map
/// `(H - hq + 1, W - wq + 1)`, its error bound against the exact SSD (the `f64` map's bound widened by the
/// storage rounding: half an ulp of its largest value, doubled) and its largest value.
pub fn quadrant_map(index: &SsdIndex, quad: ArrayView3<f32>) -> Result<(Array2<f32>, f64, f64)> {
    let q = index.prepare_template("quad", quad)?;
    index.ensure::<f64>(false)?;
    let (map, bound) = index.fft_map_f64(&q, None);
    let mx = map.iter().fold(0.0f64, |a, &v| a.max(v));
    let dim = index.map_dim(q.h, q.w);
    let map = Array2::from_shape_vec(dim, map.into_iter().map(|v| v as f32).collect())
        .expect("map length matches its shape");
    Ok((map, bound + mx * f32::EPSILON as f64, mx))
}

/// [`best_matches_many`] (unmasked) for templates `(K, 2hq, 2wq, C)` whose four quadrants are among the
/// `quads` `(Q, hq, wq, C)`: `assign[u] = [TL, TR, BL, BR]` indexes the quadrants of template `u` (checked
/// bit for bit), `maps`, `bounds`, `maxes` are the quads' [`quadrant_map`]s. Same results as
/// [`best_matches_many`].
///
/// Why: the SSD of a template is the sum of its quadrants' SSDs, so its map is the sum of four shifted
/// quadrant maps, `F_u(ty, tx) = sum_q F_q(ty + dy_q, tx + dx_q)`, and its error bound the sum of theirs
/// plus the rounding of the sums. The greedy walk ([`SsdIndex::walk_blocks_lazy`]) returns the exact answer for
/// any map whose bound holds, so only the `Q` quadrant maps need FFTs (the intermediate tiles of a complete
/// set share 4 x colours quadrants: 20 transforms instead of 625 for c5).
#[allow(clippy::too_many_arguments)]
pub fn best_matches_quadrants(
    index: &SsdIndex,
    quads: ArrayView4<f32>,
    maps: ArrayView3<f32>,
    bounds: &[f64],
    maxes: &[f64],
    templates: ArrayView4<f32>,
    assign: ArrayView2<i64>,
    k: usize,
    exclude_radius: usize,
) -> Result<Vec<Vec<Match>>> {
    let (nq, hq, wq, c) = quads.dim();
    let (nt, h, w, tc) = templates.dim();
    if nq == 0 || h != 2 * hq || w != 2 * wq || tc != c {
        return Err(TilesynthError::shape(
            "quads",
            format!(
                "(Q >= 1, {}, {}, {}) for templates of {}",
                h / 2,
                w / 2,
                tc,
                fmt_shape(templates.shape())
            ),
            fmt_shape(quads.shape()),
        ));
    }
    let (qh, qw) = index.map_dim(hq, wq);
    if maps.dim() != (nq, qh, qw) || bounds.len() != nq || maxes.len() != nq {
        return Err(TilesynthError::shape(
            "maps",
            format!("({nq}, {qh}, {qw}) with {nq} bounds and maxima"),
            fmt_shape(maps.shape()),
        ));
    }
    if assign.dim() != (nt, 4) {
        return Err(TilesynthError::shape(
            "assign",
            format!("({nt}, 4)"),
            fmt_shape(assign.shape()),
        ));
    }
    let (ts, _) = prepare_many(index, templates, None)?;
    let qs = (0..nq)
        .map(|i| index.prepare_template("quads", quads.index_axis_move(Axis(0), i)))
        .collect::<Result<Vec<_>>>()?;
    let corners = [(0usize, 0usize), (0, wq), (hq, 0), (hq, wq)];
    let mut idx = vec![[0usize; 4]; nt];
    for (u, t) in ts.iter().enumerate() {
        for (j, &(dy, dx)) in corners.iter().enumerate() {
            let a = assign[[u, j]];
            if a < 0 || a as usize >= nq {
                return Err(TilesynthError::param(
                    "assign",
                    a,
                    format!("must index the {nq} quads"),
                ));
            }
            let q = &qs[a as usize];
            let same = (0..hq).all(|y| {
                let tr = &t.data[((dy + y) * w + dx) * c..((dy + y) * w + dx + wq) * c];
                let qr = &q.data[y * wq * c..(y + 1) * wq * c];
                tr.iter().zip(qr).all(|(x, y)| x.to_bits() == y.to_bits())
            });
            if !same {
                return Err(TilesynthError::param(
                    "assign",
                    a,
                    format!("quad {a} is not quadrant {j} of template {u}"),
                ));
            }
            idx[u][j] = a as usize;
        }
    }
    if nt == 0 || k == 0 {
        return Ok(vec![Vec::new(); nt]);
    }
    let maps = maps.as_standard_layout();
    let flat = maps.as_slice().expect("standard layout");
    let (mh, mw) = index.map_dim(h, w);
    let n = mh * mw;
    // Each quadrant map's minimum per aligned BS x BS block, once per call (one pass over the Q maps): the
    // lower bounds of the summed maps' blocks, so a template's map is summed only where it can hold a match.
    let (qby, qbx) = (qh.div_ceil(QBS), qw.div_ceil(QBS));
    let qbmin: Vec<Vec<f32>> = (0..nq)
        .into_par_iter()
        .map(|q| {
            let qm = &flat[q * qh * qw..(q + 1) * qh * qw];
            let mut out = vec![f32::INFINITY; qby * qbx];
            for y in 0..qh {
                let row = &qm[y * qw..(y + 1) * qw];
                let ob = &mut out[(y / QBS) * qbx..(y / QBS + 1) * qbx];
                for (b, chunk) in row.chunks(QBS).enumerate() {
                    let m = chunk.iter().fold(ob[b], |a, &v| if v < a { v } else { a });
                    ob[b] = m;
                }
            }
            out
        })
        .collect();
    Ok(ts
        .par_iter()
        .zip(idx.par_iter())
        .map_init(Vec::<f64>::new, |buf, (t, a)| {
            buf.clear();
            buf.resize(n, 0.0);
            let mut bound = 0.0;
            let mut total_max = 0.0;
            for &q in a.iter() {
                bound += bounds[q];
                total_max += maxes[q] * (1.0 + f32::EPSILON as f64);
            }
            // the three f64 additions per translation: at most 3 roundings of a value <= total_max
            bound += 8.0 * f64::EPSILON * total_max;
            let (by, bx) = (mh.div_ceil(QBS), mw.div_ceil(QBS));
            // Lower bound of block (yb, xb): per corner, the least quadrant block minimum over the (at most
            // 2 x 2) aligned quadrant blocks that the shifted block covers, summed in the order the map's
            // values are (f64 addition is monotone, so the bound holds after rounding).
            let lower = (0..by * bx)
                .map(|b| {
                    let (yb, xb) = (b / bx, b % bx);
                    let (y0, y1) = (yb * QBS, ((yb + 1) * QBS).min(mh) - 1);
                    let (x0, x1) = (xb * QBS, ((xb + 1) * QBS).min(mw) - 1);
                    let mut s = 0.0f64;
                    for (j, &(dy, dx)) in corners.iter().enumerate() {
                        let m = &qbmin[a[j]];
                        let mut lo = f32::INFINITY;
                        for qy in (y0 + dy) / QBS..=(y1 + dy) / QBS {
                            for qx in (x0 + dx) / QBS..=(x1 + dx) / QBS {
                                lo = lo.min(m[qy * qbx + qx]);
                            }
                        }
                        s += lo as f64;
                    }
                    s
                })
                .collect();
            let fill = |buf: &mut [f64], yb: usize, xb: usize| {
                let (y0, y1) = (yb * QBS, ((yb + 1) * QBS).min(mh));
                let (x0, x1) = (xb * QBS, ((xb + 1) * QBS).min(mw));
                for y in y0..y1 {
                    buf[y * mw + x0..y * mw + x1].fill(0.0);
                }
                for (j, &(dy, dx)) in corners.iter().enumerate() {
                    let qm = &flat[a[j] * qh * qw..(a[j] + 1) * qh * qw];
                    for y in y0..y1 {
                        let src = &qm[(y + dy) * qw + dx + x0..(y + dy) * qw + dx + x1];
                        for (d, &v) in buf[y * mw + x0..y * mw + x1].iter_mut().zip(src) {
                            *d += v as f64;
                        }
                    }
                }
            };
            index.walk_blocks_lazy(t, k, exclude_radius, buf, lower, &fill, bound)
        })
        .collect())
}

/// Block side of [`best_matches_quadrants`]' lower bounds and of [`SsdIndex::walk_blocks_lazy`]. Measured on
/// the default 2048² build (625 templates of 256², 32 matches each): blocks of 32 / 16 / 8 filled 11 / 5.6 /
/// 3.6 % of each map, and 16 took the least time (the heap and the bounds grow as the blocks shrink).
const QBS: usize = 16;

/// A [`BestWs`] of [`best_matches_many`]'s pool, given back to it when dropped.
struct Pooled<'a>(BestWs, &'a Mutex<Vec<BestWs>>);

impl Drop for Pooled<'_> {
    fn drop(&mut self) {
        let ws = std::mem::take(&mut self.0);
        self.1.lock().unwrap_or_else(|e| e.into_inner()).push(ws);
    }
}

/// [`best_matches_many`] by the first implementation (every translation sorted up front): the baseline of
/// the benches. Same results.
#[doc(hidden)]
pub fn best_matches_many_sorting(
    index: &SsdIndex,
    templates: ArrayView4<f32>,
    mask: Option<ArrayView2<bool>>,
    k: usize,
    exclude_radius: usize,
) -> Result<Vec<Vec<Match>>> {
    let (ts, m) = prepare_many(index, templates, mask)?;
    if !ts.is_empty() && k > 0 {
        index.ensure::<f64>(m.is_some())?;
    }
    Ok(ts
        .par_iter()
        .map(|t| index.best_prepared_sorting(t, m.as_deref(), k, exclude_radius))
        .collect())
}

/// `((H, W, C), (h, w))` of an image and a template, from [`check_image_template`].
type ImageTemplateDims = ((usize, usize, usize), (usize, usize));

/// The shape rules of one image and one template that fits inside it (same channels): returns the image's
/// `(H, W, C)` and the template's `(h, w)`.
fn check_image_template(
    image: &ArrayView3<f32>,
    template: &ArrayView3<f32>,
) -> Result<ImageTemplateDims> {
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
    Ok(((hh, ww, c), (h, w)))
}

/// Slow obvious oracle (`f64` loops over every translation and template pixel), public so tests and
/// benches can use it. Same shape rules and errors as [`SsdIndex::ssd_map`].
#[cfg(any(test, feature = "oracles"))]
pub fn ssd_map_brute(
    image: ArrayView3<f32>,
    template: ArrayView3<f32>,
    mask: Option<ArrayView2<bool>>,
) -> Result<Array2<f64>> {
    let ((hh, ww, c), (h, w)) = check_image_template(&image, &template)?;
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

/// The gradient-weighted distance of 000's eq. 2 over every fully-overlapping translation `t`:
///
/// `D(t) = sum_p sum_c (T(p, c) - I(p + t, c))^2 / (mu (g_T(p) + g_I(p + t)) + eps)`
///
/// with `g_T` (`(h, w)`) and `g_I` (`(H, W)`) given per-pixel gradient magnitudes (`>= 0`, finite), `mu >= 0`
/// and `eps > 0`. The denominator couples a template pixel with the image pixel under it, so this is not a
/// correlation and no FFT applies: it is computed by direct `f64` summation, `O((H-h+1)(W-w+1) h w C)`,
/// parallel over rows of translations (each value a fixed-order sum, so the result does not depend on the
/// thread count). Returns `(H - h + 1, W - w + 1)`.
pub fn weighted_ssd_map(
    image: ArrayView3<f32>,
    image_grad: ArrayView2<f64>,
    template: ArrayView3<f32>,
    template_grad: ArrayView2<f64>,
    mu: f64,
    eps: f64,
) -> Result<Array2<f64>> {
    let ((hh, ww, c), (h, w)) = check_image_template(&image, &template)?;
    if image_grad.dim() != (hh, ww) {
        return Err(TilesynthError::shape(
            "image_grad",
            fmt_shape(&[hh, ww]),
            fmt_shape(image_grad.shape()),
        ));
    }
    if template_grad.dim() != (h, w) {
        return Err(TilesynthError::shape(
            "template_grad",
            fmt_shape(&[h, w]),
            fmt_shape(template_grad.shape()),
        ));
    }
    if !(mu.is_finite() && mu >= 0.0) {
        return Err(TilesynthError::param("mu", mu, "must be finite and >= 0"));
    }
    if !(eps.is_finite() && eps > 0.0) {
        return Err(TilesynthError::param("eps", eps, "must be finite and > 0"));
    }
    if image_grad
        .iter()
        .chain(template_grad.iter())
        .any(|v| !(v.is_finite() && *v >= 0.0))
    {
        return Err(TilesynthError::param(
            "image_grad/template_grad",
            "negative or non-finite value",
            "gradient magnitudes must be finite and >= 0",
        ));
    }
    let img = contiguous_finite("image", image)?;
    let tpl = contiguous_finite("template", template)?;
    let ig = try_standard("image_grad", image_grad)?;
    let tg = try_standard("template_grad", template_grad)?;
    let (ig, tg) = (
        ig.as_slice().expect("standard layout"),
        tg.as_slice().expect("standard layout"),
    );
    let (th, tw) = (hh - h + 1, ww - w + 1);
    let mut out = try_vec("image", th * tw, 0.0f64)?;
    out.par_chunks_mut(tw).enumerate().for_each(|(ty, row)| {
        for (tx, o) in row.iter_mut().enumerate() {
            *o = {
                let mut s = 0.0f64;
                for py in 0..h {
                    let irow = (ty + py) * ww + tx;
                    for px in 0..w {
                        let (ip, tp) = (irow + px, py * w + px);
                        let mut d2 = 0.0f64;
                        for ch in 0..c {
                            let d = tpl[tp * c + ch] as f64 - img[ip * c + ch] as f64;
                            d2 += d * d;
                        }
                        s += d2 / (mu * (tg[tp] + ig[ip]) + eps);
                    }
                }
                s
            };
        }
    });
    Ok(Array2::from_shape_vec((th, tw), out).expect("th * tw values"))
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
        None => Cow::Owned(try_collect(name, a.len(), a.iter().copied())?),
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

/// [`lane_sums`] of a slice (the same sums in the same order, by chunks of 8 lanes, which vectorises).
fn lane_sums_f32(v: &[f32]) -> (f64, f64) {
    let mut sq = [0.0f64; 8];
    let mut ab = [0.0f64; 8];
    let mut chunks = v.chunks_exact(8);
    for ch in &mut chunks {
        for l in 0..8 {
            let x = ch[l] as f64;
            sq[l] += x * x;
            ab[l] += x.abs();
        }
    }
    for (l, &x) in chunks.remainder().iter().enumerate() {
        let x = x as f64;
        sq[l] += x * x;
        ab[l] += x.abs();
    }
    let fold = |x: [f64; 8]| ((x[0] + x[4]) + (x[2] + x[6])) + ((x[1] + x[5]) + (x[3] + x[7]));
    (fold(sq), fold(ab))
}

/// For `d = v - shift`: `(sum d, sum |d|, sum d^2, max |d|)` with 8 interleaved partial sums (a fixed
/// order, so deterministic, and vectorisable).
fn lane_stats(v: &[f64], shift: f64) -> (f64, f64, f64, f64) {
    let (mut s, mut a, mut q, mut m) = ([0.0f64; 8], [0.0f64; 8], [0.0f64; 8], [0.0f64; 8]);
    let mut chunks = v.chunks_exact(8);
    for ch in &mut chunks {
        for l in 0..8 {
            let d = ch[l] - shift;
            let ad = d.abs();
            s[l] += d;
            a[l] += ad;
            q[l] += d * d;
            m[l] = if ad > m[l] { ad } else { m[l] };
        }
    }
    for (l, &x) in chunks.remainder().iter().enumerate() {
        let d = x - shift;
        let ad = d.abs();
        s[l] += d;
        a[l] += ad;
        q[l] += d * d;
        m[l] = if ad > m[l] { ad } else { m[l] };
    }
    let fold = |x: [f64; 8]| ((x[0] + x[4]) + (x[2] + x[6])) + ((x[1] + x[5]) + (x[3] + x[7]));
    let mx = m.iter().fold(0.0f64, |p, &x| p.max(x));
    (fold(s), fold(a), fold(q), mx)
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

/// Fills row `y` (all `W` entries) of plane `q`.
type Fill<'a, T> = dyn Fn(usize, usize, &mut [T]) + Sync + 'a;

/// 2-D FFT of the complex plane `a + ib` (planes `qa`, `qb` from `fill`; rows `>= rows` are zero) into
/// `cols`, laid out `[kx][ky]` (`W` columns of length `H`). Only the `rows` non-zero rows are transformed.
#[allow(clippy::too_many_arguments)]
fn fwd_pair<T: Real>(
    p: &Plans<T>,
    hh: usize,
    ww: usize,
    rows: usize,
    par: bool,
    fill: &Fill<T>,
    qa: usize,
    qb: usize,
    cols: &mut [Complex<T>],
) {
    let zero = Complex::<T>::zero();
    let zr = rows_pair(p, ww, rows, par, fill, qa, qb);
    for_each_block(
        &mut cols[..ww * hh],
        COL_BLOCK * hh,
        par,
        || vec![zero; p.scratch],
        |scratch, bi, blk| {
            let kx0 = bi * COL_BLOCK;
            gather_cols(&zr, ww, rows, hh, hh, blk.len() / hh, |j| kx0 + j, blk);
            p.fwd_h.process_with_scratch(blk, scratch);
        },
    );
}

/// The row transforms of [`fwd_pair`]: `rows x W`, row `y` the FFT of `a + ib` on row `y` of planes
/// `qa`, `qb`.
fn rows_pair<T: Real>(
    p: &Plans<T>,
    ww: usize,
    rows: usize,
    par: bool,
    fill: &Fill<T>,
    qa: usize,
    qb: usize,
) -> Vec<Complex<T>> {
    let zero = Complex::<T>::zero();
    let mut zr = vec![zero; rows * ww];
    for_each_block(
        &mut zr,
        ROW_BLOCK * ww,
        par,
        || {
            (
                vec![T::zero(); ww],
                vec![T::zero(); ww],
                vec![zero; p.scratch],
            )
        },
        |(a, b, scratch), bi, blk| {
            for (j, row) in blk.chunks_exact_mut(ww).enumerate() {
                let y = bi * ROW_BLOCK + j;
                fill(qa, y, a);
                fill(qb, y, b);
                for ((o, &x), &v) in row.iter_mut().zip(a.iter()).zip(b.iter()) {
                    *o = Complex::new(x, v);
                }
            }
            p.fwd_w.process_with_scratch(blk, scratch);
        },
    );
    zr
}

/// Columns `col_of(0), col_of(1), ...` of the `rows x W` row transforms `zr`, zero-padded to length `hh`,
/// into `out` (`out.len() / hh` columns, laid out one after the other).
/// Column `j` starts at `j * stride` (`stride >= hh`; a stride that is not a large power of two keeps the
/// columns of a block in different cache sets, which the transposing stores need).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn gather_cols<T: Real>(
    zr: &[Complex<T>],
    ww: usize,
    rows: usize,
    hh: usize,
    stride: usize,
    nb: usize,
    col_of: impl Fn(usize) -> usize,
    out: &mut [Complex<T>],
) {
    for y in 0..rows {
        let row = &zr[y * ww..(y + 1) * ww];
        for j in 0..nb {
            out[j * stride + y] = row[col_of(j)];
        }
    }
    if rows < hh {
        for j in 0..nb {
            zero_fill(&mut out[j * stride + rows..j * stride + hh]);
        }
    }
}

/// Sets every value of `v` to zero: a plain loop, inlined (and vectorised with the caller's target
/// features), where `slice::fill` was a call.
#[inline(always)]
fn zero_fill<T: Real>(v: &mut [Complex<T>]) {
    for z in v {
        *z = Complex::zero();
    }
}

/// [`gather_cols`] for the columns `cols` (at most [`COL_BLOCK`]), in tiles of four rows: every store
/// fills 64 contiguous bytes of a column, where one row at a time scattered 16-byte stores over all the
/// columns of the block. Same values.
#[inline(always)]
fn gather_cols4(
    zr: &[Complex<f64>],
    ww: usize,
    rows: usize,
    hh: usize,
    stride: usize,
    cols: &[usize],
    out: &mut [Complex<f64>],
) {
    let mut y = 0;
    while y + 4 <= rows {
        let r0 = &zr[y * ww..(y + 1) * ww];
        let r1 = &zr[(y + 1) * ww..(y + 2) * ww];
        let r2 = &zr[(y + 2) * ww..(y + 3) * ww];
        let r3 = &zr[(y + 3) * ww..(y + 4) * ww];
        for (j, &cx) in cols.iter().enumerate() {
            let o = &mut out[j * stride + y..j * stride + y + 4];
            o[0] = r0[cx];
            o[1] = r1[cx];
            o[2] = r2[cx];
            o[3] = r3[cx];
        }
        y += 4;
    }
    for y in y..rows {
        let row = &zr[y * ww..(y + 1) * ww];
        for (j, &cx) in cols.iter().enumerate() {
            out[j * stride + y] = row[cx];
        }
    }
    if rows < hh {
        for j in 0..cols.len() {
            zero_fill(&mut out[j * stride + rows..j * stride + hh]);
        }
    }
}

/// [`split_real_cols`] two row pairs at a time (64-byte stores, see [`gather_cols4`]). Same values.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn split_real_cols4(
    zr: &[Complex<f64>],
    ww: usize,
    rows: usize,
    hh: usize,
    stride: usize,
    nb: usize,
    kx0: usize,
    out: &mut [Complex<f64>],
) {
    #[inline(always)]
    fn split(z: &[Complex<f64>], kx: usize, ww: usize) -> (Complex<f64>, Complex<f64>) {
        let a = z[kx];
        let b = z[mirror(kx, ww)].conj();
        // Even row: (a + b) / 2; odd row: (a - b) / 2i.
        (
            Complex::new((a.re + b.re) * 0.5, (a.im + b.im) * 0.5),
            Complex::new((a.im - b.im) * 0.5, (b.re - a.re) * 0.5),
        )
    }
    let mut jr = 0;
    // Whole tiles of four rows (two row pairs, both complete).
    while 2 * jr + 4 <= rows {
        let z0 = &zr[jr * ww..(jr + 1) * ww];
        let z1 = &zr[(jr + 1) * ww..(jr + 2) * ww];
        let y = 2 * jr;
        for j in 0..nb {
            let (e0, o0) = split(z0, kx0 + j, ww);
            let (e1, o1) = split(z1, kx0 + j, ww);
            let o = &mut out[j * stride + y..j * stride + y + 4];
            o[0] = e0;
            o[1] = o0;
            o[2] = e1;
            o[3] = o1;
        }
        jr += 2;
    }
    for jr in jr..rows.div_ceil(2) {
        let z = &zr[jr * ww..(jr + 1) * ww];
        let y = 2 * jr;
        let odd = y + 1 < rows;
        for j in 0..nb {
            let (e, o) = split(z, kx0 + j, ww);
            out[j * stride + y] = e;
            if odd {
                out[j * stride + y + 1] = o;
            }
        }
    }
    if rows < hh {
        for j in 0..nb {
            zero_fill(&mut out[j * stride + rows..j * stride + hh]);
        }
    }
}

/// The column `-kx` (mod `ww`) of column `kx`.
#[inline(always)]
fn mirror(kx: usize, ww: usize) -> usize {
    if kx == 0 {
        0
    } else {
        ww - kx
    }
}

/// Half spectrum (`kx < W/2 + 1`, all `ky`, laid out `[kx][ky]`) of the real plane `q` (rows `>= rows`
/// zero): rows are transformed two at a time as one complex row, then split by Hermitian symmetry.
#[allow(clippy::too_many_arguments)]
fn fwd_real<T: Real>(
    p: &Plans<T>,
    hh: usize,
    ww: usize,
    rows: usize,
    par: bool,
    fill: &Fill<T>,
    q: usize,
    cols: &mut [Complex<T>],
) {
    let zero = Complex::<T>::zero();
    let wc = ww / 2 + 1;
    let zr = rows_real(p, ww, rows, par, fill, q);
    for_each_block(
        &mut cols[..wc * hh],
        COL_BLOCK * hh,
        par,
        || vec![zero; p.scratch],
        |scratch, bi, blk| {
            let nb = blk.len() / hh;
            split_real_cols(&zr, ww, rows, hh, hh, nb, bi * COL_BLOCK, blk);
            p.fwd_h.process_with_scratch(blk, scratch);
        },
    );
}

/// The row transforms of [`fwd_real`]: `ceil(rows / 2) x W`, row `j` the FFT of rows `2j` (real part)
/// and `2j + 1` (imaginary part, zero past `rows`) of plane `q`.
fn rows_real<T: Real>(
    p: &Plans<T>,
    ww: usize,
    rows: usize,
    par: bool,
    fill: &Fill<T>,
    q: usize,
) -> Vec<Complex<T>> {
    let zero = Complex::<T>::zero();
    let pairs = rows.div_ceil(2);
    let mut zr = vec![zero; pairs * ww];
    for_each_block(
        &mut zr,
        ROW_BLOCK * ww,
        par,
        || {
            (
                vec![T::zero(); ww],
                vec![T::zero(); ww],
                vec![zero; p.scratch],
            )
        },
        |(a, b, scratch), bi, blk| {
            for (j, row) in blk.chunks_exact_mut(ww).enumerate() {
                let y = 2 * (bi * ROW_BLOCK + j);
                fill(q, y, a);
                if y + 1 < rows {
                    fill(q, y + 1, b);
                } else {
                    b.fill(T::zero());
                }
                for ((o, &x), &v) in row.iter_mut().zip(a.iter()).zip(b.iter()) {
                    *o = Complex::new(x, v);
                }
            }
            p.fwd_w.process_with_scratch(blk, scratch);
        },
    );
    zr
}

/// Columns `kx0 ..` (`out.len() / hh` of them) of the row spectra of the real plane, split from the paired
/// row transforms `zr` of [`rows_real`] by Hermitian symmetry and zero-padded to length `hh`.
/// Column `j` starts at `j * stride` (see [`gather_cols`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn split_real_cols<T: Real>(
    zr: &[Complex<T>],
    ww: usize,
    rows: usize,
    hh: usize,
    stride: usize,
    nb: usize,
    kx0: usize,
    out: &mut [Complex<T>],
) {
    let half = T::of(0.5);
    for jr in 0..rows.div_ceil(2) {
        let z = &zr[jr * ww..(jr + 1) * ww];
        let y = 2 * jr;
        let odd = y + 1 < rows;
        for j in 0..nb {
            let kx = kx0 + j;
            let a = z[kx];
            let b = z[mirror(kx, ww)].conj();
            // Even row: (a + b) / 2; odd row: (a - b) / 2i.
            out[j * stride + y] = Complex::new((a.re + b.re) * half, (a.im + b.im) * half);
            if odd {
                out[j * stride + y + 1] = Complex::new((a.im - b.im) * half, (b.re - a.re) * half);
            }
        }
    }
    if rows < hh {
        for j in 0..nb {
            zero_fill(&mut out[j * stride + rows..j * stride + hh]);
        }
    }
}

/// One column `kx` of the half spectrum: `g[ky] += conj(Z[kx, ky]) U[ky] + Z[-kx, -ky] V[ky]`, with `z1`
/// the column `kx` of `Z` and `z2` its column `-kx` (both in `ky` order).
#[inline]
fn accumulate_pair_col<T: Real>(
    gk: &mut [Complex<T>],
    z1: &[Complex<T>],
    z2: &[Complex<T>],
    uu: &[Complex<T>],
    vv: &[Complex<T>],
) {
    #[inline(always)]
    fn step<T: Real>(
        g: &mut Complex<T>,
        z1: Complex<T>,
        z2: Complex<T>,
        u: Complex<T>,
        v: Complex<T>,
    ) {
        g.re = g.re + (z1.re * u.re + z1.im * u.im) + (z2.re * v.re - z2.im * v.im);
        g.im = g.im + (z1.re * u.im - z1.im * u.re) + (z2.re * v.im + z2.im * v.re);
    }
    step(&mut gk[0], z1[0], z2[0], uu[0], vv[0]);
    for ((((gv, &a), &b), &uv), &vv) in gk[1..]
        .iter_mut()
        .zip(&z1[1..])
        .zip(z2[1..].iter().rev())
        .zip(&uu[1..])
        .zip(&vv[1..])
    {
        step(gv, a, b, uv, vv);
    }
}

/// `g[k] += conj(X[k]) I[k]` elementwise.
#[inline]
fn accumulate_lone_block<T: Real>(g: &mut [Complex<T>], x: &[Complex<T>], img: &[Complex<T>]) {
    for ((gv, &a), &b) in g.iter_mut().zip(x).zip(img) {
        gv.re = gv.re + (a.re * b.re + a.im * b.im);
        gv.im = gv.im + (a.re * b.im - a.im * b.re);
    }
}

/// The first part of the map of [`SsdIndex::best_cols`]: the row transforms and the column pass, into
/// `ws.rows`, `ws.g`, `ws.tc`. Expanded twice: once in a function
/// compiled for AVX2 (the loops around the transforms — fills, transposes, products, conversion — then use
/// 256-bit vectors; no FMA, so the same values) and once for any CPU.
macro_rules! best_cols_body {
    ($idx:expr, $t:expr, $mask:expr, $ws:expr) => {{
        let (this, t, mask, ws): (&SsdIndex, &Tmpl, Option<&[bool]>, &mut BestWs) = ($idx, $t, $mask, $ws);
        let (hh, ww, c) = (this.h, this.w, this.c);
        let wc = ww / 2 + 1;
        let (th, tw) = (t.h, t.w);
        let par = this.par();
        let spec = this.spec::<f64>();
        let tail = mask.map(|_| this.tail::<f64>());
        let plans = &spec.plans;
        let np = if mask.is_some() { c + 1 } else { c };
        let zero = Complex::<f64>::zero();
        ws.tc = Some(match mask {
            None if 24 % c == 0 => this.template_consts_unmasked(t),
            _ => this.template_consts(t, mask),
        });
        let scratch_len = plans.scratch;

        // Plane q of template row y, value x: -2 m T_c (q < C), m (q = C).
        let fill_row = |data: &[f32], q: usize, y: usize, out: &mut [Complex<f64>], im: bool| {
            let row = &data[y * tw * c..(y + 1) * tw * c];
            let head = &mut out[..tw];
            match mask {
                None => {
                    if im {
                        for (x, b) in head.iter_mut().enumerate() {
                            b.im = -2.0 * row[x * c + q] as f64;
                        }
                    } else {
                        for (x, b) in head.iter_mut().enumerate() {
                            b.re = -2.0 * row[x * c + q] as f64;
                        }
                    }
                }
                Some(m) => {
                    let mr = &m[y * tw..(y + 1) * tw];
                    for (x, (b, &on)) in head.iter_mut().zip(mr).enumerate() {
                        let v = match (on, q < c) {
                            (false, _) => 0.0,
                            (true, true) => -2.0 * row[x * c + q] as f64,
                            (true, false) => 1.0,
                        };
                        if im {
                            b.im = v;
                        } else {
                            b.re = v;
                        }
                    }
                }
            }
        };

        // Row transforms of every plane group (only the template's rows), into buffers of `ws`.
        let ngroups = np.div_ceil(2);
        if ws.rows.len() < ngroups {
            ws.rows.resize_with(ngroups, Vec::new);
        }
        let imgs: Vec<&Chunk<f64>> = (0..ngroups)
            .map(|k| match tail {
                Some(tl) if k >= c / 2 => tl,
                _ => &spec.chunks[k],
            })
            .collect();
        let data: &[f32] = &t.data;
        for k in 0..ngroups {
            let qa = 2 * k;
            let pair = matches!(imgs[k], Chunk::Pair { .. });
            let nrows = if pair { th } else { th.div_ceil(2) };
            grow(&mut ws.scratch, scratch_len, zero);
            let zr = &mut grow(&mut ws.rows[k], nrows * ww, zero)[..nrows * ww];
            for_each_block_ws(
                zr,
                ROW_BLOCK * ww,
                par,
                || vec![zero; scratch_len],
                &mut ws.scratch,
                |scratch, bi, blk| {
                    let scratch = &mut scratch[..scratch_len];
                    for (j, row) in blk.chunks_exact_mut(ww).enumerate() {
                        let jr = bi * ROW_BLOCK + j;
                        zero_fill(&mut row[tw..]);
                        if pair {
                            fill_row(data, qa, jr, row, false);
                            fill_row(data, qa + 1, jr, row, true);
                        } else {
                            fill_row(data, qa, 2 * jr, row, false);
                            if 2 * jr + 1 < th {
                                fill_row(data, qa, 2 * jr + 1, row, true);
                            } else {
                                row[..tw].iter_mut().for_each(|b| b.im = 0.0);
                            }
                        }
                    }
                    plans.fwd_w.process_with_scratch(blk, scratch);
                },
            );
        }

        // Per block of columns of the half spectrum: the column transforms of every group, the products
        // with the image spectra (written by the first group, added by the others, in the fixed group
        // order), and the inverse column transforms.
        let st = hh.next_multiple_of(8) + 8;
        let rows_all = &ws.rows;
        let g = &mut grow(&mut ws.g, wc * hh, zero)[..wc * hh];
        let blen = 2 * COL_BLOCK * st + scratch_len;
        grow(&mut ws.blocks, blen, zero);
        for_each_block_ws(
            g,
            COL_BLOCK * hh,
            par,
            || vec![zero; blen],
            &mut ws.blocks,
            |buf, bi, blk| {
                let (za, rest) = buf.split_at_mut(COL_BLOCK * st);
                let (zb, rest) = rest.split_at_mut(COL_BLOCK * st);
                let s = &mut rest[..scratch_len];
                let kx0 = bi * COL_BLOCK;
                let nb = blk.len() / hh;
                for (gi, img) in imgs.iter().enumerate() {
                    let first = gi == 0;
                    let zr = &rows_all[gi];
                    match img {
                        Chunk::Pair { u, v } => {
                            let mut cols = [0usize; COL_BLOCK];
                            for (j, cx) in cols[..nb].iter_mut().enumerate() {
                                *cx = kx0 + j;
                            }
                            gather_cols4(zr, ww, th, hh, st, &cols[..nb], za);
                            for (j, cx) in cols[..nb].iter_mut().enumerate() {
                                *cx = mirror(kx0 + j, ww);
                            }
                            gather_cols4(zr, ww, th, hh, st, &cols[..nb], zb);
                            for j in 0..nb {
                                plans
                                    .fwd_h
                                    .process_with_scratch(&mut za[j * st..j * st + hh], s);
                                plans
                                    .fwd_h
                                    .process_with_scratch(&mut zb[j * st..j * st + hh], s);
                            }
                            for (j, gk) in blk.chunks_exact_mut(hh).enumerate() {
                                let o = (kx0 + j) * hh;
                                let (z1, z2) = (&za[j * st..j * st + hh], &zb[j * st..j * st + hh]);
                                let (uu, vv) = (&u[o..o + hh], &v[o..o + hh]);
                                if first {
                                    pair_col::<true>(gk, z1, z2, uu, vv);
                                } else {
                                    pair_col::<false>(gk, z1, z2, uu, vv);
                                }
                            }
                        }
                        Chunk::Lone(x) => {
                            split_real_cols4(zr, ww, th, hh, st, nb, kx0, za);
                            for (j, gk) in blk.chunks_exact_mut(hh).enumerate() {
                                plans
                                    .fwd_h
                                    .process_with_scratch(&mut za[j * st..j * st + hh], s);
                                let o = (kx0 + j) * hh;
                                let (z1, xx) = (&za[j * st..j * st + hh], &x[o..o + hh]);
                                if first {
                                    lone_block::<true>(gk, z1, xx);
                                } else {
                                    lone_block::<false>(gk, z1, xx);
                                }
                            }
                        }
                    }
                }
                plans.inv_h.process_with_scratch(blk, s);
            },
        );
    }};
}

/// The second part of the map of [`SsdIndex::best_cols`] (expanded like [`best_cols_body`]): the real
/// inverse transform of each valid row plus the constants, into `ws.map`, with the minimum found on the
/// way. Returns the bound and `(minimum, first index, ties)`.
macro_rules! best_rows_body {
    ($idx:expr, $t:expr, $mask:expr, $ws:expr) => {{
        let (this, t, mask, ws): (&SsdIndex, &Tmpl, Option<&[bool]>, &mut BestWs) = ($idx, $t, $mask, $ws);
        let (hh, ww) = (this.h, this.w);
        let wc = ww / 2 + 1;
        let (th, tw) = (t.h, t.w);
        let (mh, mw) = this.map_dim(th, tw);
        let par = this.par();
        let plans = &this.spec::<f64>().plans;
        let scratch_len = plans.scratch;
        let zero = Complex::<f64>::zero();
        let tc = ws.tc.expect("best_cols ran first");
        let g: &[Complex<f64>] = &ws.g[..wc * hh];
        let gcol = |kx: usize| -> &[Complex<f64>] { &g[kx * hh..(kx + 1) * hh] };

        // A real inverse transform of each valid row, plus the constants; the minimum on the way.
        let scale = 1.0 / (hh as f64 * ww as f64);
        let base = tc.sum_t2 + tc.kconst;
        let w_even = ww % 2 == 0;
        let integral = &this.integral;
        let iw = ww + 1;
        let best = Mutex::new((f64::INFINITY, usize::MAX, 0usize));
        let rlen = ROW_BLOCK * wc + scratch_len;
        grow(&mut ws.inv.0, rlen, zero);
        grow(&mut ws.inv.1, ww, 0.0);
        let map = &mut grow(&mut ws.map, mh * mw, 0.0)[..mh * mw];
        for_each_block_ws(
            map,
            ROW_BLOCK * mw,
            par,
            || (vec![zero; rlen], vec![0.0f64; ww]),
            &mut ws.inv,
            |(rbuf, outr), bi, out| {
                let (rows, rest) = rbuf.split_at_mut(ROW_BLOCK * wc);
                let scratch = &mut rest[..scratch_len];
                let outr = &mut outr[..ww];
                let y0 = bi * ROW_BLOCK;
                let nr = out.len() / mw;
                // In tiles of four columns, so that every store fills 64 contiguous bytes.
                let mut kx = 0;
                while kx + 4 <= wc {
                    let g0 = &gcol(kx)[y0..y0 + nr];
                    let g1 = &gcol(kx + 1)[y0..y0 + nr];
                    let g2 = &gcol(kx + 2)[y0..y0 + nr];
                    let g3 = &gcol(kx + 3)[y0..y0 + nr];
                    for j in 0..nr {
                        let r = &mut rows[j * wc + kx..j * wc + kx + 4];
                        r[0] = g0[j];
                        r[1] = g1[j];
                        r[2] = g2[j];
                        r[3] = g3[j];
                    }
                    kx += 4;
                }
                for kx in kx..wc {
                    for (j, &v) in gcol(kx)[y0..y0 + nr].iter().enumerate() {
                        rows[j * wc + kx] = v;
                    }
                }
                let (mut bmin, mut bidx, mut bcnt) = (f64::INFINITY, usize::MAX, 0usize);
                for j in 0..nr {
                    let row = &mut rows[j * wc..(j + 1) * wc];
                    row[0].im = 0.0;
                    if w_even {
                        row[wc - 1].im = 0.0;
                    }
                    let r = plans.inv_w.process_with_scratch(row, outr, scratch);
                    debug_assert!(r.is_ok());
                    let y = y0 + j;
                    let orow = &mut out[j * mw..(j + 1) * mw];
                    if mask.is_some() {
                        for (o, &z) in orow.iter_mut().zip(&outr[..mw]) {
                            *o = (base + z * scale).max(0.0);
                        }
                    } else {
                        let (top, bot) = (&integral[y * iw..], &integral[(y + th) * iw..]);
                        let (tl, tr) = (&top[..mw], &top[tw..tw + mw]);
                        let (bl, br) = (&bot[..mw], &bot[tw..tw + mw]);
                        for x in 0..mw {
                            let boxsum = (br[x] - tr[x]) - (bl[x] - tl[x]);
                            orow[x] = (base + boxsum + outr[x] * scale).max(0.0);
                        }
                    }
                    // The row minimum (a vectorisable fold), then its first position and ties only when
                    // it reaches the block's minimum.
                    let rmin = orow.iter().fold(f64::INFINITY, |a, &v| a.min(v));
                    if rmin <= bmin {
                        if rmin < bmin {
                            (bmin, bidx, bcnt) = (rmin, usize::MAX, 0);
                        }
                        for (x, &v) in orow.iter().enumerate() {
                            if v == rmin {
                                if bidx == usize::MAX {
                                    bidx = y * mw + x;
                                }
                                bcnt += 1;
                            }
                        }
                    }
                }
                let mut b = best.lock().unwrap_or_else(|e| e.into_inner());
                if bmin < b.0 || (bmin == b.0 && bidx < b.1) {
                    let cnt = if bmin == b.0 { b.2 + bcnt } else { bcnt };
                    *b = (bmin, bidx, cnt);
                } else if bmin == b.0 {
                    b.2 += bcnt;
                }
            },
        );
        let (bound, _) = this.map_bound::<f64>(th, tw, mask.is_some(), &tc);
        let best = best.into_inner().unwrap_or_else(|e| e.into_inner());
        (bound, best)
    }};
}

/// [`best_cols_body`] compiled for AVX2. `unsafe fn` (not a safe `#[target_feature]` fn, Rust >= 1.86) so the
/// crate builds with its rust-version 1.80.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn best_cols_avx2(idx: &SsdIndex, t: &Tmpl, mask: Option<&[bool]>, ws: &mut BestWs) {
    best_cols_body!(idx, t, mask, ws)
}

/// [`best_cols_body`] for any CPU.
fn best_cols_plain(idx: &SsdIndex, t: &Tmpl, mask: Option<&[bool]>, ws: &mut BestWs) {
    best_cols_body!(idx, t, mask, ws)
}

/// [`best_rows_body`] compiled for AVX2 (`unsafe fn`: see [`best_cols_avx2`]).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn best_rows_avx2(
    idx: &SsdIndex,
    t: &Tmpl,
    mask: Option<&[bool]>,
    ws: &mut BestWs,
) -> (f64, (f64, usize, usize)) {
    best_rows_body!(idx, t, mask, ws)
}

/// [`best_rows_body`] for any CPU.
fn best_rows_plain(
    idx: &SsdIndex,
    t: &Tmpl,
    mask: Option<&[bool]>,
    ws: &mut BestWs,
) -> (f64, (f64, usize, usize)) {
    best_rows_body!(idx, t, mask, ws)
}

/// Reusable buffers of [`SsdIndex::fft_map_best`], kept by each worker across the templates of one
/// best-matches call (the map, the row transforms of the template groups, the half spectrum, and the
/// block, row and scratch buffers of the serial case).
#[derive(Default)]
struct BestWs {
    rows: Vec<Vec<Complex<f64>>>,
    scratch: Vec<Complex<f64>>,
    g: Vec<Complex<f64>>,
    blocks: Vec<Complex<f64>>,
    inv: (Vec<Complex<f64>>, Vec<f64>),
    map: Vec<f64>,
    tc: Option<TConsts>,
}

/// `v` grown (zero-filled) to at least `n` values; never shrunk, so a reused buffer is filled only once.
fn grow<T: Clone>(v: &mut Vec<T>, n: usize, zero: T) -> &mut Vec<T> {
    if v.len() < n {
        v.resize(n, zero);
    }
    v
}

/// [`for_each_block`] whose serial case runs with the caller's state `serial` (kept across calls)
/// instead of a new one; the parallel case makes one state per task with `init`, as before.
fn for_each_block_ws<T, S, I, F>(
    data: &mut [T],
    block: usize,
    par: bool,
    init: I,
    serial: &mut S,
    f: F,
) where
    T: Send,
    S: Send,
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
        for (i, b) in data.chunks_mut(block).enumerate() {
            f(serial, i, b);
        }
    }
}

/// [`accumulate_pair_col`] in `f64`; `SET`: the products are written (the first group of a map) instead
/// of added.
#[inline(always)]
fn pair_col<const SET: bool>(
    gk: &mut [Complex<f64>],
    z1: &[Complex<f64>],
    z2: &[Complex<f64>],
    uu: &[Complex<f64>],
    vv: &[Complex<f64>],
) {
    #[inline(always)]
    fn step<const SET: bool>(
        g: &mut Complex<f64>,
        z1: Complex<f64>,
        z2: Complex<f64>,
        u: Complex<f64>,
        v: Complex<f64>,
    ) {
        // The association of `accumulate_pair_col`: (g + first product) + second product.
        let (re1, re2) = (z1.re * u.re + z1.im * u.im, z2.re * v.re - z2.im * v.im);
        let (im1, im2) = (z1.re * u.im - z1.im * u.re, z2.re * v.im + z2.im * v.re);
        if SET {
            *g = Complex::new(re1 + re2, im1 + im2);
        } else {
            g.re = g.re + re1 + re2;
            g.im = g.im + im1 + im2;
        }
    }
    step::<SET>(&mut gk[0], z1[0], z2[0], uu[0], vv[0]);
    for ((((gv, &a), &b), &uv), &vv) in gk[1..]
        .iter_mut()
        .zip(&z1[1..])
        .zip(z2[1..].iter().rev())
        .zip(&uu[1..])
        .zip(&vv[1..])
    {
        step::<SET>(gv, a, b, uv, vv);
    }
}

/// [`accumulate_lone_block`] in `f64`; `SET` as in [`pair_col`].
#[inline(always)]
fn lone_block<const SET: bool>(g: &mut [Complex<f64>], x: &[Complex<f64>], img: &[Complex<f64>]) {
    for ((gv, &a), &b) in g.iter_mut().zip(x).zip(img) {
        let re = a.re * b.re + a.im * b.im;
        let im = a.re * b.im - a.im * b.re;
        if SET {
            *gv = Complex::new(re, im);
        } else {
            gv.re += re;
            gv.im += im;
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
    fn best_matches_all_translations() {
        // k beyond the number of translations: every translation, in exact (ssd, row, col) order
        let mut rng = Rng(6);
        for &(hh, ww, h, w, c) in &SIZES[..6] {
            let img = rand3(&mut rng, (hh, ww, c));
            let t = rand3(&mut rng, (h, w, c));
            check_best(&img, &t, None, usize::MAX, 0);
            check_best(&img, &t, None, usize::MAX, 1);
        }
        // a larger map: sorted, complete, distinct (the greedy walk is O(n log n), not O(k n))
        let img = rand3(&mut rng, (120, 110, 3));
        let t = rand3(&mut rng, (8, 9, 3));
        let idx = SsdIndex::new(img.view()).unwrap();
        let got = idx.best_matches(t.view(), None, usize::MAX, 0).unwrap();
        assert_eq!(got.len(), 113 * 102);
        assert!(got
            .windows(2)
            .all(|p| (p[0].ssd, p[0].row, p[0].col) <= (p[1].ssd, p[1].row, p[1].col)));
        let mut seen = vec![false; 113 * 102];
        for m in &got {
            assert!(!std::mem::replace(&mut seen[m.row * 102 + m.col], true));
        }
        // a constant image: all tie, (row, col) order throughout
        let flat = Array3::from_elem((9, 8, 2), 0.5f32);
        let idx = SsdIndex::new(flat.view()).unwrap();
        let got = idx
            .best_matches(
                Array3::from_elem((3, 3, 2), 0.25f32).view(),
                None,
                usize::MAX,
                0,
            )
            .unwrap();
        let pos: Vec<(usize, usize)> = got.iter().map(|m| (m.row, m.col)).collect();
        let want: Vec<(usize, usize)> = (0..7).flat_map(|y| (0..6).map(move |x| (y, x))).collect();
        assert_eq!(pos, want);
        // a large constant image: every FFT value lies within the bound of every other (the worst case of
        // the old per-match rescan), still (row, col) order, each translation once
        let flat = Array3::from_elem((120, 120, 3), 0.5f32);
        let idx = SsdIndex::new(flat.view()).unwrap();
        let t = Array3::from_elem((5, 5, 3), 0.25f32);
        let got = idx.best_matches(t.view(), None, usize::MAX, 0).unwrap();
        assert_eq!(got.len(), 116 * 116);
        assert!(got
            .iter()
            .enumerate()
            .all(|(j, m)| (m.row, m.col) == (j / 116, j % 116) && m.ssd == got[0].ssd));
        let spaced = idx.best_matches(t.view(), None, usize::MAX, 3).unwrap();
        assert_eq!(spaced.len(), 29 * 29);
        assert_eq!((spaced[1].row, spaced[1].col), (0, 4));
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
    fn lazy_scan_matches_sorting_path() {
        // The lazy candidate scan and the full sort walk the same order, so the results are identical
        // (bit for bit), on random images and on flat / periodic ones where exact ties decide the order.
        let mut rng = Rng(11);
        let check = |img: &Array3<f32>, t: &Array3<f32>, m: Option<&Array2<bool>>| {
            let idx = SsdIndex::new(img.view()).unwrap();
            let n = {
                let (mh, mw) = idx.map_dim(t.dim().0, t.dim().1);
                mh * mw
            };
            for &(k, r) in &[
                (1, 0),
                (2, 0),
                (5, 1),
                (17, 2),
                (70, 0),
                (n, 0),
                (usize::MAX, 1),
            ] {
                let mv = m.map(|m| m.view());
                let new = idx.best_matches(t.view(), mv, k, r).unwrap();
                let old = idx.best_matches_sorting(t.view(), mv, k, r).unwrap();
                assert_eq!(new, old);
                let tp = idx.prepare_template("template", t.view()).unwrap();
                let mp = prepare_mask(mv, t.dim().0, t.dim().1).unwrap();
                let new = idx.best_prepared_lazy(&tp, mp.as_deref(), k, r);
                assert_eq!(new.len(), old.len(), "k {k} r {r} image {:?}", img.dim());
                for (a, b) in new.iter().zip(&old) {
                    assert_eq!((a.row, a.col), (b.row, b.col), "k {k} r {r}");
                    assert_eq!(a.ssd.to_bits(), b.ssd.to_bits());
                }
            }
        };
        for &(hh, ww, h, w, c) in SIZES {
            let img = rand3(&mut rng, (hh, ww, c));
            let t = rand3(&mut rng, (h, w, c));
            check(&img, &t, None);
            check(&img, &t, Some(&rand_mask(&mut rng, h, w)));
        }
        // flat image and template: every translation ties
        let flat = Array3::from_elem((40, 37, 3), 0.5f32);
        let t = Array3::from_elem((6, 5, 3), 0.25f32);
        check(&flat, &t, None);
        check(&flat, &t, Some(&rand_mask(&mut rng, 6, 5)));
        // periodic images (period 4 x 6 and a stripe pattern): many exact copies of a cut template
        let per = Array3::from_shape_fn((48, 50, 3), |(y, x, ch)| {
            ((y % 4) * 7 + (x % 6) * 3 + ch) as f32 / 40.0
        });
        let cut = per.slice(s![5..13, 7..16, ..]).to_owned();
        check(&per, &cut, None);
        check(&per, &cut, Some(&rand_mask(&mut rng, 8, 9)));
        let stripes = Array3::from_shape_fn((33, 64, 1), |(_, x, _)| (x % 8 < 4) as u8 as f32);
        let cut = stripes.slice(s![0..10, 3..20, ..]).to_owned();
        check(&stripes, &cut, None);
        // quantised noise: many near and exact ties of the FFT values
        let q = Array3::from_shape_simple_fn((45, 41, 3), || (rng.below(3) as f32) * 0.5);
        let t = Array3::from_shape_simple_fn((4, 4, 3), || (rng.below(3) as f32) * 0.5);
        check(&q, &t, None);
        check(&q, &t, Some(&rand_mask(&mut rng, 4, 4)));
        // best_matches_many agrees too
        let idx = SsdIndex::new(q.view()).unwrap();
        let ts = Array4::from_shape_simple_fn((4, 5, 6, 3), || (rng.below(2) as f32) * 0.5);
        assert_eq!(
            best_matches_many(&idx, ts.view(), None, 9, 1).unwrap(),
            best_matches_many_sorting(&idx, ts.view(), None, 9, 1).unwrap()
        );
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
    fn weighted_map_matches_definition_and_reduces_to_ssd() {
        let img = Array3::from_shape_fn((9, 8, 2), |(y, x, c)| {
            ((y * 7 + x * 3 + c * 5) % 11) as f32 / 11.0
        });
        let tpl = Array3::from_shape_fn((4, 3, 2), |(y, x, c)| ((y * 5 + x + c) % 7) as f32 / 7.0);
        let ig = Array2::from_shape_fn((9, 8), |(y, x)| ((y + x) % 3) as f64 * 0.5);
        let tg = Array2::from_shape_fn((4, 3), |(y, x)| ((y * x) % 4) as f64 * 0.25);
        let got =
            weighted_ssd_map(img.view(), ig.view(), tpl.view(), tg.view(), 10.0, 1e-6).unwrap();
        let (ty, tx) = (3, 2);
        let mut want = 0.0;
        for py in 0..4 {
            for px in 0..3 {
                let mut d2 = 0.0;
                for c in 0..2 {
                    let d = tpl[(py, px, c)] as f64 - img[(ty + py, tx + px, c)] as f64;
                    d2 += d * d;
                }
                want += d2 / (10.0 * (tg[(py, px)] + ig[(ty + py, tx + px)]) + 1e-6);
            }
        }
        assert!((got[(ty, tx)] - want).abs() <= 1e-12 * want.max(1.0));
        // mu = 0 and eps = 1: the plain SSD
        let plain =
            weighted_ssd_map(img.view(), ig.view(), tpl.view(), tg.view(), 0.0, 1.0).unwrap();
        let brute = ssd_map_brute(img.view(), tpl.view(), None).unwrap();
        for (a, b) in plain.iter().zip(brute.iter()) {
            assert!((a - b).abs() <= 1e-12 * b.max(1.0));
        }
        let bad = Array2::from_elem((4, 4), 0.0);
        assert!(
            weighted_ssd_map(img.view(), ig.view(), tpl.view(), bad.view(), 1.0, 1.0)
                .unwrap_err()
                .to_string()
                .contains("template_grad")
        );
        assert!(
            weighted_ssd_map(img.view(), ig.view(), tpl.view(), tg.view(), -1.0, 1.0)
                .unwrap_err()
                .to_string()
                .contains("mu")
        );
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
    fn best_map_within_bound_with_its_minimum() {
        // The map of the matching stage (its own code, see `fft_map_best`): every value within the bound
        // of the direct sum, close to `ssd_map_f64`, its reported minimum, first index and ties exact, and
        // the same bits whether the loops run compiled for AVX2 or not, and whether its buffers are fresh
        // or were used by a template of another size (the reuse within one call). C = 5 takes the general
        // path of the template constants.
        let mut rng = Rng(21);
        let mut ws = BestWs::default();
        let check =
            |img: &Array3<f32>, t: &Array3<f32>, m: Option<&Array2<bool>>, ws: &mut BestWs| {
                let idx = SsdIndex::new(img.view()).unwrap();
                idx.ensure::<f64>(m.is_some()).unwrap();
                let tp = idx.prepare_template("template", t.view()).unwrap();
                let mp = prepare_mask(m.map(|m| m.view()), t.dim().0, t.dim().1).unwrap();
                let want = ssd_map_brute(img.view(), t.view(), m.map(|m| m.view())).unwrap();
                let (old, old_bound) = idx.ssd_map_f64(t.view(), m.map(|m| m.view())).unwrap();
                let n = want.len();
                let (bound, (min, first, ties)) = idx.fft_map_best(&tp, mp.as_deref(), ws);
                let map = ws.map[..n].to_vec();
                // the same bound, up to the rounding of the template's sums (summed in another order)
                assert!((bound - old_bound).abs() <= 1e-12 * old_bound);
                for ((g, w), o) in map.iter().zip(want.iter()).zip(old.iter()) {
                    assert!((g - w).abs() <= bound, "{g} vs {w} bound {bound}");
                    assert!((g - o).abs() <= 2.0 * bound);
                    assert!(!g.is_nan() && *g >= 0.0);
                }
                let m0 = map.iter().fold(f64::INFINITY, |a, &v| a.min(v));
                assert_eq!(min, m0);
                assert_eq!(first, map.iter().position(|&v| v == m0).unwrap());
                assert_eq!(ties, map.iter().filter(|&&v| v == m0).count());
                let plain = {
                    let mut fresh = BestWs::default();
                    best_cols_plain(&idx, &tp, mp.as_deref(), &mut fresh);
                    let r = best_rows_plain(&idx, &tp, mp.as_deref(), &mut fresh);
                    (r, fresh.map[..n].to_vec())
                };
                assert_eq!(plain.0, (bound, (min, first, ties)));
                assert!(plain
                    .1
                    .iter()
                    .zip(&map)
                    .all(|(a, b)| a.to_bits() == b.to_bits()));
            };
        let mut sizes: Vec<_> = SIZES.to_vec();
        // Templates of half the image (the matching stage's 256 in 512), less or just over half, odd sides.
        sizes.extend([
            (70, 66, 33, 30, 5),
            (64, 64, 32, 32, 3),
            (130, 120, 64, 40, 3),
            (128, 96, 64, 48, 3),
            (96, 128, 24, 64, 3),
            (66, 70, 20, 35, 4),
            (64, 64, 33, 31, 3),
            (63, 64, 20, 32, 3),
            (64, 63, 32, 20, 2),
        ]);
        for &(hh, ww, h, w, c) in &sizes {
            let img = rand3(&mut rng, (hh, ww, c));
            let t = rand3(&mut rng, (h, w, c));
            check(&img, &t, None, &mut ws);
            check(&img, &t, Some(&rand_mask(&mut rng, h, w)), &mut ws);
            let (y, x) = (rng.below(hh - h + 1), rng.below(ww - w + 1));
            let cut = img.slice(s![y..y + h, x..x + w, ..]).to_owned();
            check(&img, &cut, None, &mut ws);
        }
        // exact ties: a flat image (every translation ties) and a periodic one (copies of the template)
        let flat = Array3::from_elem((40, 37, 3), 0.5f32);
        check(&flat, &Array3::from_elem((6, 5, 3), 0.25f32), None, &mut ws);
        let per = Array3::from_shape_fn((48, 50, 3), |(y, x, ch)| {
            ((y % 4) * 7 + (x % 6) * 3 + ch) as f32 / 40.0
        });
        let cut = per.slice(s![5..13, 7..16, ..]).to_owned();
        check(&per, &cut, None, &mut ws);
        check(&per, &cut, Some(&rand_mask(&mut rng, 8, 9)), &mut ws);
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

#[cfg(test)]
mod alloc_tests {
    use super::SsdIndex;
    use crate::error::{assert_alloc_error, HUGE_SIDE};
    use ndarray::Array3;

    /// An image whose contiguous copy and index cannot be allocated is an error naming `image`.
    #[test]
    fn an_image_that_cannot_be_indexed_is_an_error() {
        let one = Array3::from_elem((1, 1, 1), 0.5f32);
        let big = one.broadcast((HUGE_SIDE, HUGE_SIDE, 3)).unwrap();
        assert_alloc_error(SsdIndex::new(big).map(|i| i.shape()), "image");
    }
}
