//! Poisson smoothing of the region inside an ω-tile's cutting curve: guided interpolation (Pérez, Gangnet and
//! Blake, *Poisson image editing*, 2003), as used by Ng et al. (002 §3.3) and Dong et al. (003 §4.3).
//!
//! # The equation
//!
//! Given a destination `dst` (the intermediate tile I), a source `src` (the matching patch O, whose content C fills
//! the region) and a region Ω (`region`, True = unknown), the smoothed tile `f` equals `dst` outside Ω and solves,
//! for every pixel p of Ω and every channel independently, the discrete Poisson equation with guidance field
//! `v_pq = src_p − src_q` (Pérez eq. (7)–(11), the "importing gradients" case):
//!
//! ```text
//!     Σ_{q ∈ N(p)} (f_p − f_q) = Σ_{q ∈ N(p)} (src_p − src_q),     f_q = dst_q for q ∉ Ω,
//! ```
//!
//! i.e. `|N(p)|·f_p − Σ_{q ∈ N(p) ∩ Ω} f_q = Σ_{q ∈ N(p)} (src_p − src_q) + Σ_{q ∈ N(p) \ Ω} dst_q`, where N(p) are
//! the 4-neighbours of p **inside the image**. The pixels of `dst` next to the region are the Dirichlet boundary
//! ∂Ω, so everything outside Ω, and in particular the tile border, is untouched and ω-tiles stay seamless with each
//! other.
//!
//! - **Image border.** A neighbour outside the image is simply absent (it appears in neither sum). Where Ω touches
//!   the image border this is a homogeneous Neumann condition on the correction `f − src` there: the solution
//!   takes the source's gradient across the border rather than any boundary value. The ω construction never
//!   produces this (the one-pixel border ring is never in the region).
//! - **No Dirichlet pixel.** A connected component of Ω without any neighbour outside Ω must be closed under
//!   taking in-image neighbours, so (the pixel grid being connected) it is the whole image. The system is then
//!   singular (f is determined up to a constant); this kernel returns `f = src`, the solution whose mean equals
//!   the mean of `src`, with 0 iterations. Every other region gives a symmetric positive definite system.
//! - **Empty region**: the output is a copy of `dst`.
//! - **No clipping.** The output is the exact solution rounded to f32, not clipped to [0, 1]: guided
//!   interpolation can overshoot the range of its inputs near strong seams, and clipping would break the
//!   equation (and the residual reported). A caller that stores the result as an image should clip it.
//!
//! # Solver
//!
//! Conjugate gradients in f64 on the correction `e = f − src` (initial guess `f = src`, i.e. the composed tile),
//! preconditioned by one geometric multigrid V-cycle in f32 on the bounding box of Ω padded by one pixel, with
//! the pixels outside Ω held at zero (McAdams, Sifakis and Teran, 2010, for irregular domains):
//!
//! - vertex-centred coarsening (coarse point `(Y, X)` is fine point `(2Y, 2X)`, active iff that fine pixel is),
//!   the 5-point operator re-discretised on every level, bilinear prolongation masked to the active pixels and
//!   restriction equal to its transpose;
//! - red-black Gauss–Seidel, red then black before the coarse-grid correction and black then red after it
//!   ([`PRE_SWEEPS`] each), and [`COARSE_SWEEPS`] symmetric sweeps on the coarsest level. The V-cycle is therefore a
//!   symmetric positive definite operator for any region (Gauss–Seidel is a convergent smoother for any SPD
//!   matrix), so PCG converges however poorly the coarse grids represent an irregular region.
//!
//! The three channels share the geometry (masks, levels) and are solved as independent PCG runs, in parallel.
//! Each channel iterates until its **true** relative residual `‖b − A f‖₂ / ‖b‖₂` (recomputed from the f64
//! solution, not the recursive CG residual) is at most `tol` (default [`DEFAULT_TOL`] = 1e-6); the residual and
//! the iteration count are returned. (Rounding the f64 solution to f32 then adds at most half an f32 ulp per
//! pixel.) A channel with `b = 0` has the exact solution `f = 0` on Ω. Reaching `tol` is guaranteed in exact
//! arithmetic; if it is not reached within [`max_iterations`] the call fails rather than return an inexact
//! result.
//!
//! A direct factorisation cannot be reused across ω-tiles (their regions differ), and factorising every region
//! (scipy's `splu`) costs about ten times the per-tile solve of a cached factorisation; MGPCG needs O(pixels)
//! work per iteration and a handful of iterations (about 5–10 for ω regions at 80–256 pixels).
//!
//! Results are deterministic: every reduction has a fixed order, and tiles and channels are independent jobs, so
//! the output is bit-identical at any thread count.

use crate::error::{
    fmt_shape, try_collect, try_standard, try_to_owned, try_vec, try_with_capacity, Result,
    TilesynthError,
};
use ndarray::{Array3, Array4, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;

mod simd;
use simd::{Portable, Simd};

/// Default relative residual `‖b − A f‖₂ / ‖b‖₂` at which the iteration stops.
pub const DEFAULT_TOL: f64 = 1e-6;

/// The smallest accepted `tol` (below it the f64 residual floor may not let CG get there).
pub const MIN_TOL: f64 = 1e-12;

/// Red-black Gauss–Seidel sweeps before (and, in reverse colour order, after) each coarse-grid correction.
pub const PRE_SWEEPS: usize = 1;

/// Symmetric red-black sweeps on the coarsest level (that many red-black, then as many black-red).
pub const COARSE_SWEEPS: usize = 4;

/// The iteration limit for an `n x m` tile: `100 + 10·(n + m)`. MGPCG needs about ten on ω regions; the limit
/// only matters for degenerate grids (e.g. a 1-pixel-high image, where no coarsening is possible).
pub fn max_iterations(n: usize, m: usize) -> usize {
    100 + 10 * (n + m)
}

/// What the solver did for one tile.
#[derive(Debug, Clone, PartialEq)]
pub struct PoissonInfo {
    /// PCG iterations, the largest over the channels (0 when nothing had to be solved).
    pub iterations: usize,
    /// The final relative residual `‖b − A f‖₂ / ‖b‖₂` of each channel, recomputed from the f64 solution
    /// (0 for an empty region, a whole-image region and a channel with `b = 0`).
    pub residual: Vec<f64>,
    /// The number of unknown pixels (region pixels).
    pub unknowns: usize,
}

// ------------------------------------------------------------------------------------------------ validation

/// Whether every value is finite (a branchless fold over the standard-layout data, which vectorises).
fn all_finite<D: ndarray::Dimension>(a: &ndarray::ArrayView<f32, D>) -> bool {
    let a = a.as_standard_layout();
    let s = a.as_slice().expect("standard layout");
    !s.iter().fold(false, |bad, v| bad | !v.is_finite())
}

fn check_finite<D: ndarray::Dimension>(
    name: &'static str,
    a: &ndarray::ArrayView<f32, D>,
) -> Result<()> {
    if !all_finite(a) {
        return Err(TilesynthError::param(
            name,
            "non-finite value",
            "images must not contain NaN or infinity",
        ));
    }
    Ok(())
}

fn check_tol(tol: f64) -> Result<()> {
    if !(tol.is_finite() && (MIN_TOL..1.0).contains(&tol)) {
        return Err(TilesynthError::param(
            "tol",
            tol,
            format!("must be a relative residual in [{MIN_TOL:e}, 1)"),
        ));
    }
    Ok(())
}

/// The shape checks shared by [`poisson_smooth`] (`dst` `(N, M, C)`) and [`poisson_smooth_batch`] (`dst`
/// `(K, N, M, C)`): no empty tile axis, `src` shaped like `dst`, `region` like `dst` without its channels.
fn check_shapes(dst: &[usize], src: &[usize], region: &[usize]) -> Result<()> {
    let (batch, axes) = if dst.len() == 4 {
        ("(K, N, M, C)", "three")
    } else {
        ("(N, M, C)", "two")
    };
    if dst[dst.len() - 3..].contains(&0) {
        return Err(TilesynthError::shape(
            "dst",
            format!("{batch} with N, M, C >= 1"),
            fmt_shape(dst),
        ));
    }
    if src != dst {
        return Err(TilesynthError::shape(
            "src",
            format!("{} (the shape of dst)", fmt_shape(dst)),
            fmt_shape(src),
        ));
    }
    let want = &dst[..dst.len() - 1];
    if region != want {
        return Err(TilesynthError::shape(
            "region",
            format!("{} (the first {axes} axes of dst)", fmt_shape(want)),
            fmt_shape(region),
        ));
    }
    Ok(())
}

// ------------------------------------------------------------------------------------------------ public API

/// Poisson smoothing of one tile: `dst` and `src` `(N, M, C)` f32, `region` `(N, M)` (True = unknown).
///
/// Returns the smoothed tile (`dst` outside the region, the solution of the module's equation inside it) and
/// what the solver did. Channels are solved in parallel on the current rayon pool; the result does not depend on
/// the number of threads. See the module documentation for the equation, the boundary handling and the solver.
pub fn poisson_smooth(
    dst: ArrayView3<f32>,
    src: ArrayView3<f32>,
    region: ArrayView2<bool>,
    tol: f64,
) -> Result<(Array3<f32>, PoissonInfo)> {
    check_shapes(dst.shape(), src.shape(), region.shape())?;
    check_finite("dst", &dst)?;
    check_finite("src", &src)?;
    check_tol(tol)?;
    let mut out = try_to_owned("dst", dst)?;
    let info = solve_tile(
        dst,
        src,
        region,
        tol,
        Path::Auto,
        out.as_slice_mut().expect("standard layout"),
    )?;
    Ok((out, info))
}

/// [`poisson_smooth`] for K tiles at once: `dst`, `src` `(K, N, M, C)`, `region` `(K, N, M)`. Tiles (and their
/// channels) are solved in parallel; results are bit-identical at any thread count. On failure the error of the
/// first failing tile (in tile order) is returned.
pub fn poisson_smooth_batch(
    dst: ArrayView4<f32>,
    src: ArrayView4<f32>,
    region: ArrayView3<bool>,
    tol: f64,
) -> Result<(Array4<f32>, Vec<PoissonInfo>)> {
    check_shapes(dst.shape(), src.shape(), region.shape())?;
    check_finite("dst", &dst)?;
    check_finite("src", &src)?;
    check_tol(tol)?;
    // Every tile starts as its dst and is solved in place, in parallel.
    let mut out = try_to_owned("dst", dst)?;
    let solved: Vec<Result<PoissonInfo>> = out
        .axis_iter_mut(Axis(0))
        .into_par_iter()
        .enumerate()
        .map(|(t, mut tile)| {
            solve_tile(
                dst.index_axis(Axis(0), t),
                src.index_axis(Axis(0), t),
                region.index_axis(Axis(0), t),
                tol,
                Path::Auto,
                tile.as_slice_mut().expect("standard layout"),
            )
        })
        .collect();
    let infos = solved.into_iter().collect::<Result<Vec<_>>>()?;
    Ok((out, infos))
}

// ------------------------------------------------------------------------------------------------ one tile

/// Which code path runs the solver: the best the CPU supports, or the portable one (tests compare the two).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Path {
    Auto,
    #[cfg_attr(not(test), allow(dead_code))]
    Portable,
}

/// Runs [`solve_tile`] on a fresh copy of `dst` (tests compare the code paths).
#[cfg(test)]
fn solve_with(
    dst: ArrayView3<f32>,
    src: ArrayView3<f32>,
    region: ArrayView2<bool>,
    tol: f64,
    path: Path,
) -> (Array3<f32>, PoissonInfo) {
    let mut out = dst.as_standard_layout().into_owned();
    let info = solve_tile(dst, src, region, tol, path, out.as_slice_mut().unwrap()).unwrap();
    (out, info)
}

/// Solves one tile into `out` (the tile's `(N, M, C)` standard-layout data, holding `dst` on entry).
fn solve_tile(
    dst: ArrayView3<f32>,
    src: ArrayView3<f32>,
    region: ArrayView2<bool>,
    tol: f64,
    path: Path,
    out: &mut [f32],
) -> Result<PoissonInfo> {
    let (n, m, c) = dst.dim();
    let unknowns = region.iter().filter(|&&v| v).count();
    let trivial = PoissonInfo {
        iterations: 0,
        residual: vec![0.0; c],
        unknowns,
    };
    let src = try_standard("src", src)?;
    let src_s = src.as_slice().expect("standard layout");
    if unknowns == 0 {
        return Ok(trivial);
    }
    if unknowns == n * m {
        // No Dirichlet pixel: f = src + const, anchored to the mean of src (see the module documentation).
        out.copy_from_slice(src_s);
        return Ok(trivial);
    }
    let grid = Grid::new(region)?;
    let dst_s = try_standard("dst", dst)?;
    let dst_s = dst_s.as_slice().expect("standard layout");
    let max_iter = max_iterations(n, m);
    let channels: Vec<Result<Channel>> = (0..c)
        .into_par_iter()
        .map(|ch| grid.solve_channel(dst_s, src_s, c, ch, tol, max_iter, path))
        .collect();
    let mut iterations = 0;
    let mut residual = try_with_capacity("src", c)?;
    for (ch, res) in channels.into_iter().enumerate() {
        let res = res?;
        iterations = iterations.max(res.iterations);
        residual.push(res.residual);
        let mut bad = false;
        for &(pix, g) in &grid.active {
            let v = res.f[g] as f32;
            bad |= !v.is_finite();
            out[pix * c + ch] = v;
        }
        if bad {
            return Err(TilesynthError::param(
                "dst/src",
                "values this large",
                "the solution is not representable in float32",
            ));
        }
    }
    Ok(PoissonInfo {
        iterations,
        residual,
        unknowns,
    })
}

/// One channel's solution on level 0 (f64, packed layout; only the active points are meaningful).
struct Channel {
    f: Buf<f64>,
    iterations: usize,
    residual: f64,
}

/// The packed red-black layout of an `h x w` grid. Row `y` starts at `y · stride`; its even columns come first
/// (`x = 2k` at `k`), then its odd ones (`x = 2k + 1` at `blk + k`). A red point (`y + x` even) of an even row is
/// in the even block, of an odd row in the odd block, so one colour of a row is contiguous, and its left / right
/// neighbours are the other block at `k − 1, k` (even block) or `k, k + 1` (odd block). Each block has room for
/// [`VEC`] more entries than it has columns, so that every loop can run over whole vectors: the extra lanes fall on
/// inactive points, whose weights are 0.
#[derive(Debug, Clone, Copy)]
struct Layout {
    h: usize,
    w: usize,
    /// Capacity of a block (a multiple of [`VEC`], at least `⌈w/2⌉ + VEC`).
    blk: usize,
    /// Row stride, `2 · blk`.
    stride: usize,
}

/// Loops over a row's points run in whole vectors of this many lanes.
const VEC: usize = simd::LANES;

impl Layout {
    fn new(h: usize, w: usize) -> Layout {
        let blk = (w.div_ceil(2) + VEC).div_ceil(VEC) * VEC;
        Layout {
            h,
            w,
            blk,
            stride: 2 * blk,
        }
    }

    #[inline(always)]
    fn idx(&self, y: usize, x: usize) -> usize {
        y * self.stride + if x % 2 == 0 { x / 2 } else { self.blk + x / 2 }
    }

    fn len(&self) -> usize {
        self.h * self.stride
    }
}

/// The block ranges of the natural column span `[lo, hi)`: `[even k range, odd k range]`, exact.
#[inline(always)]
fn block_spans(lo: usize, hi: usize) -> [(usize, usize); 2] {
    [(lo.div_ceil(2), hi.div_ceil(2)), (lo / 2, hi / 2)]
}

/// [`block_spans`] with each range lengthened to whole vectors (empty ranges stay empty).
#[inline(always)]
fn vec_spans(lo: usize, hi: usize) -> [(usize, usize); 2] {
    block_spans(lo, hi).map(|(a, b)| (a, a + (b.max(a) - a).div_ceil(VEC) * VEC))
}

/// The starts `a, a + VEC, …` of the whole vectors in `[a, z)` (`z − a` is a multiple of `VEC`).
#[inline(always)]
fn starts(a: usize, z: usize) -> impl Iterator<Item = usize> {
    (0..(z - a) / VEC).map(move |k| a + k * VEC)
}

// The hot loops below slice every operand of a segment once (bounds-checked, all of the segment's length `n`,
// a multiple of VEC) and then load and store whole vectors at offsets `i = 0, VEC, …, n − VEC` without further
// checks: `i + VEC <= n` is the safety condition of every `*u` call (plus one more element where a slice is
// declared `n + 1` long for the right-hand neighbour at `i + 1`).

/// A stretch of one colour of one row, in whole vectors: packed indices `[a, b)`; the left neighbour of `a + j` is
/// `l + j` (in the other block of the row), the right one `l + j + 1`, the upper and lower ones `a + j ∓ stride`.
#[derive(Debug, Clone, Copy)]
struct Seg {
    a: usize,
    b: usize,
    l: usize,
}

/// One multigrid level: an `h x w` grid whose ring is never active; arrays in the packed layout.
struct Level {
    lay: Layout,
    /// Diagonal of the operator (number of in-image neighbours on level 0, 4 on coarse levels; 0 if inactive).
    diag: Vec<f32>,
    /// `1 / diag` on active points, 0 elsewhere.
    winv: Vec<f32>,
    /// 1 on active (unknown) points, 0 elsewhere.
    act: Vec<f32>,
    /// Per row, the natural column range `[lo, hi)` spanning its active points (`(0, 0)` when it has none).
    span: Vec<(usize, usize)>,
    /// Per row, [`vec_spans`] of `span`.
    vspan: Vec<[(usize, usize); 2]>,
    /// The red (`[0]`) and black (`[1]`) stretches of every row, top to bottom.
    segs: [Vec<Seg>; 2],
}

impl Level {
    /// `active` in natural row-major order.
    fn from_active(
        h: usize,
        w: usize,
        active: &[bool],
        diag_of: impl Fn(usize, usize) -> f32,
    ) -> Result<Level> {
        let lay = Layout::new(h, w);
        let mut diag = try_vec("region", lay.len(), 0.0f32)?;
        let mut winv = try_vec("region", lay.len(), 0.0f32)?;
        let mut act = try_vec("region", lay.len(), 0.0f32)?;
        let mut span = try_vec("region", h, (0usize, 0usize))?;
        for y in 0..h {
            let (mut lo, mut hi) = (usize::MAX, 0);
            for x in 0..w {
                if !active[y * w + x] {
                    continue;
                }
                debug_assert!(y > 0 && x > 0 && y + 1 < h && x + 1 < w);
                let g = lay.idx(y, x);
                let d = diag_of(y, x);
                diag[g] = d;
                winv[g] = 1.0 / d;
                act[g] = 1.0;
                lo = lo.min(x);
                hi = x + 1;
            }
            if hi > 0 {
                span[y] = (lo, hi);
            }
        }
        let vspan: Vec<[(usize, usize); 2]> =
            try_collect("region", h, span.iter().map(|&(lo, hi)| vec_spans(lo, hi)))?;
        let mut segs = [Vec::new(), Vec::new()];
        for (y, vs) in vspan.iter().enumerate() {
            for (colour, list) in segs.iter_mut().enumerate() {
                // Red points of an even row are in its even block, of an odd row in its odd block.
                let even = (y % 2 == 0) == (colour == 0);
                let (kl, kh) = vs[usize::from(!even)];
                if kl < kh {
                    let row = y * lay.stride;
                    let (boff, ooff, sh) = if even {
                        (0, lay.blk, kl - 1)
                    } else {
                        (lay.blk, 0, kl)
                    };
                    list.push(Seg {
                        a: row + boff + kl,
                        b: row + boff + kh,
                        l: row + ooff + sh,
                    });
                }
            }
        }
        Ok(Level {
            lay,
            diag,
            winv,
            act,
            span,
            vspan,
            segs,
        })
    }

    /// The coarse level: point `(Y, X)` is fine point `(2Y, 2X)`, active iff that one is. `None` when the grid is
    /// too small to coarsen or the coarse grid would have no active point.
    fn coarsen(&self) -> Result<Option<Level>> {
        let (h, w) = (self.lay.h, self.lay.w);
        if h < 5 || w < 5 {
            return Ok(None);
        }
        let (hc, wc) = (h / 2 + 1, w / 2 + 1);
        let mut active = try_vec("region", hc * wc, false)?;
        let mut any = false;
        for yc in 1..hc - 1 {
            for xc in 1..wc - 1 {
                if self.act[self.lay.idx(2 * yc, 2 * xc)] != 0.0 {
                    active[yc * wc + xc] = true;
                    any = true;
                }
            }
        }
        any.then(|| Level::from_active(hc, wc, &active, |_, _| 4.0))
            .transpose()
    }
}

/// One red-black Gauss–Seidel half-sweep, in place: on the points of one colour `u ← (f + Σ_q u_q) / diag`.
/// With `first`, the other colour is taken as 0 (the sweep that starts a V-cycle level from u = 0; stale values
/// of the other colour are overwritten by the next half-sweep).
#[inline(always)]
fn relax<S: Simd>(v: S, lev: &Level, u: &mut [f32], f: &[f32], red: bool, first: bool) {
    let (stride, winv, segs) = (
        lev.lay.stride,
        &lev.winv[..],
        &lev.segs[usize::from(!red)][..],
    );
    for s in segs {
        let n = s.b - s.a;
        let (fs, ws) = (&f[s.a..s.b], &winv[s.a..s.b]);
        // The points updated, and (disjoint from them) their neighbours before and after in memory.
        let (before, rest) = u.split_at_mut(s.a);
        let (tgt, after) = rest.split_at_mut(n);
        if first {
            for i in starts(0, n) {
                // SAFETY: i + VEC <= n (see above).
                unsafe { v.st32u(tgt, i, v.mul32(v.ld32u(ws, i), v.ld32u(fs, i))) };
            }
            continue;
        }
        let up = &before[s.a - stride..][..n];
        let dn = &after[stride - n..][..n];
        // The other block of the row: before the segment (odd block updated) or after it (even block).
        let lr = if s.l < s.a {
            &before[s.l..][..n + 1]
        } else {
            &after[s.l - s.b..][..n + 1]
        };
        for i in starts(0, n) {
            // SAFETY: i + VEC <= n, and lr has n + 1 elements.
            unsafe {
                let vert = v.add32(v.ld32u(up, i), v.ld32u(dn, i));
                let horz = v.add32(v.ld32u(lr, i), v.ld32u(lr, i + 1));
                let nv = v.mul32(v.ld32u(ws, i), v.add32(v.ld32u(fs, i), v.add32(vert, horz)));
                v.st32u(tgt, i, nv);
            }
        }
    }
}

/// The residual `f − A u` after a half-sweep on black: 0 on the black points (Gauss–Seidel just solved their
/// equations), so only the red points are computed (the black entries of `res` are never written and stay 0).
#[inline(always)]
fn residual_red<S: Simd>(v: S, lev: &Level, u: &[f32], f: &[f32], res: &mut [f32]) {
    let (stride, winv, diag, segs) = (
        lev.lay.stride,
        &lev.winv[..],
        &lev.diag[..],
        &lev.segs[0][..],
    );
    for s in segs {
        let n = s.b - s.a;
        let (up, dn, cu) = (
            &u[s.a - stride..s.b - stride],
            &u[s.a + stride..s.b + stride],
            &u[s.a..s.b],
        );
        let lr = &u[s.l..s.l + n + 1];
        let (fs, ws, ds) = (&f[s.a..s.b], &winv[s.a..s.b], &diag[s.a..s.b]);
        let out = &mut res[s.a..s.b];
        for i in starts(0, n) {
            // SAFETY: i + VEC <= n, and lr has n + 1 elements.
            unsafe {
                let vert = v.add32(v.ld32u(up, i), v.ld32u(dn, i));
                let horz = v.add32(v.ld32u(lr, i), v.ld32u(lr, i + 1));
                let gs = v.mul32(v.ld32u(ws, i), v.add32(v.ld32u(fs, i), v.add32(vert, horz)));
                v.st32u(out, i, v.mul32(v.ld32u(ds, i), v.sub32(gs, v.ld32u(cu, i))));
            }
        }
    }
}

/// `fc = act · Pᵀ res` (full weighting with weights 1, 1/2, 1/4, the transpose of [`prolong_add`]) for a
/// residual that is 0 on black points: coarse `(Y, X)` collects fine `(2Y, 2X)` (red, weight 1) and its four
/// diagonal neighbours (red, weight 1/4); the edge neighbours are black.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // rows are indexed in several arrays at once
fn restrict<S: Simd>(
    v: S,
    fine: &Level,
    coarse: &Level,
    res: &[f32],
    fc: &mut [f32],
    tmp: &mut [f32],
) {
    let Layout { blk, stride, .. } = fine.lay;
    let Layout {
        h: hc,
        blk: blkc,
        stride: sc,
        ..
    } = coarse.lay;
    let quarter = v.splat32(0.25);
    let (span, act) = (&coarse.span[..], &coarse.act[..]);
    for yc in 1..hc - 1 {
        let (lo, hi) = span[yc];
        if lo >= hi {
            continue;
        }
        let y = 2 * yc;
        let (ra, rb, rc) = ((y - 1) * stride + blk, y * stride, (y + 1) * stride + blk);
        // t[j] for coarse column lo + j (in whole vectors; the extra lanes read zeros of the fine blocks' slack).
        let n = (hi - lo).div_ceil(VEC) * VEC;
        let ev = &res[rb + lo..rb + lo + n];
        let (a0, b0) = (
            &res[ra + lo - 1..ra + lo + n],
            &res[rc + lo - 1..rc + lo + n],
        );
        let t = &mut tmp[..n];
        for j in starts(0, n) {
            // SAFETY: j + VEC <= n, and a0, b0 have n + 1 elements.
            unsafe {
                let diag = v.add32(
                    v.add32(v.ld32u(a0, j), v.ld32u(a0, j + 1)),
                    v.add32(v.ld32u(b0, j), v.ld32u(b0, j + 1)),
                );
                v.st32u(t, j, v.add32(v.ld32u(ev, j), v.mul32(quarter, diag)));
            }
        }
        let [(el, eh), (ol, oh)] = block_spans(lo, hi);
        let crow = yc * sc;
        for k in el..eh {
            fc[crow + k] = act[crow + k] * tmp[2 * k - lo];
        }
        for k in ol..oh {
            fc[crow + blkc + k] = act[crow + blkc + k] * tmp[2 * k + 1 - lo];
        }
    }
}

/// The coarse solution in natural row-major order, rows `w` apart (so that prolongation reads contiguous rows).
#[inline(always)]
fn unpack(coarse: &Level, uc: &[f32], nat: &mut [f32]) {
    let Layout {
        h, w, blk, stride, ..
    } = coarse.lay;
    for y in 0..h {
        let (lo, hi) = coarse.span[y];
        let row = &mut nat[y * w..(y + 1) * w];
        if lo >= hi {
            row.fill(0.0);
            continue;
        }
        let src = &uc[y * stride..(y + 1) * stride];
        let (evens, odds) = src.split_at(blk);
        for ((pair, &e), &o) in row.chunks_exact_mut(2).zip(evens).zip(odds) {
            pair[0] = e;
            pair[1] = o;
        }
        if w % 2 == 1 {
            row[w - 1] = evens[w / 2];
        }
    }
}

/// `u += act · P uc` (bilinear interpolation from the coarse points; `nat` is the coarse solution unpacked, with
/// at least [`NAT_SLACK`] elements after its last row).
#[inline(always)]
fn prolong_add<S: Simd>(
    v: S,
    fine: &Level,
    coarse: &Level,
    nat: &[f32],
    u: &mut [f32],
    tmp: &mut [f32],
) {
    let Layout { h, blk, stride, .. } = fine.lay;
    let wc = coarse.lay.w;
    let half = v.splat32(0.5);
    let (span, vspan, act) = (&fine.span[..], &fine.vspan[..], &fine.act[..]);
    for y in 1..h - 1 {
        let (lo, hi) = span[y];
        if lo >= hi {
            continue;
        }
        let [(el, eh), (ol, oh)] = vspan[y];
        // Coarse columns from ca: fine column 2k (even block k) takes c[k − ca], 2k + 1 (odd block k) takes
        // (c[k − ca] + c[k − ca + 1]) / 2. The extra lanes multiply by act = 0.
        let ca = lo / 2;
        let need = (eh.max(ca) - ca).max(oh.max(ca) + 1 - ca).div_ceil(VEC) * VEC;
        let yc = y / 2;
        let c: &[f32] = if y % 2 == 0 {
            &nat[yc * wc + ca..yc * wc + ca + need + VEC]
        } else {
            let (a, b) = (yc * wc + ca, (yc + 1) * wc + ca);
            let (na, nb) = (&nat[a..a + need + VEC], &nat[b..b + need + VEC]);
            let t = &mut tmp[..need + VEC];
            for j in starts(0, need + VEC) {
                // SAFETY: j + VEC <= need + VEC, the length of na, nb and t.
                unsafe { v.st32u(t, j, v.mul32(half, v.add32(v.ld32u(na, j), v.ld32u(nb, j)))) };
            }
            t
        };
        let row = y * stride;
        let (n, ce) = (eh - el, &c[el - ca..el - ca + eh - el]);
        let (ue, ae) = (&mut u[row + el..row + eh], &act[row + el..row + eh]);
        for i in starts(0, n) {
            // SAFETY: i + VEC <= n, the length of ue, ae and ce.
            unsafe {
                let add = v.mul32(v.ld32u(ae, i), v.ld32u(ce, i));
                v.st32u(ue, i, v.add32(v.ld32u(ue, i), add));
            }
        }
        let (n, co) = (oh - ol, &c[ol - ca..ol - ca + oh - ol + 1]);
        let (uo, ao) = (
            &mut u[row + blk + ol..row + blk + oh],
            &act[row + blk + ol..row + blk + oh],
        );
        for i in starts(0, n) {
            // SAFETY: i + VEC <= n, the length of uo and ao; co has n + 1 elements.
            unsafe {
                let mid = v.mul32(half, v.add32(v.ld32u(co, i), v.ld32u(co, i + 1)));
                v.st32u(uo, i, v.add32(v.ld32u(uo, i), v.mul32(v.ld32u(ao, i), mid)));
            }
        }
    }
}

/// Elements kept after the last row of an unpacked coarse solution (reads of whole vectors run past rows).
const NAT_SLACK: usize = 4 * VEC;

/// The geometry of one tile's problem, shared by its channels.
struct Grid {
    /// Image size.
    n: usize,
    m: usize,
    /// Image row / column of grid point (1, 1) (the top-left corner of the region's bounding box).
    y0: usize,
    x0: usize,
    /// Level 0 is the region's bounding box padded by a one-pixel ring; then the coarse levels.
    levels: Vec<Level>,
    /// Level 0's diagonal and mask in f64 (for the PCG operator).
    diag64: Vec<f64>,
    act64: Vec<f64>,
    /// Every unknown pixel as (image pixel index `y·M + x`, packed level-0 index).
    active: Vec<(usize, usize)>,
    /// Level 0's rows as packed index ranges in whole vectors (two per row with active points); every PCG
    /// vector is 0 on the inactive points of these ranges, and only these ranges are ever written.
    segments: Vec<(usize, usize)>,
}

impl Grid {
    /// Fallible: the levels' arrays are sized by the region's bounding box, and a refused allocation is an
    /// error naming `region`.
    fn new(region: ArrayView2<bool>) -> Result<Grid> {
        let (n, m) = region.dim();
        let (mut y0, mut y1, mut x0, mut x1) = (usize::MAX, 0, usize::MAX, 0);
        for (y, row) in region.outer_iter().enumerate() {
            for (x, &v) in row.iter().enumerate() {
                if v {
                    y0 = y0.min(y);
                    y1 = y1.max(y);
                    x0 = x0.min(x);
                    x1 = x1.max(x);
                }
            }
        }
        let (h, w) = (y1 - y0 + 3, x1 - x0 + 3);
        let mut active = try_vec("region", h * w, false)?;
        for gy in 1..h - 1 {
            let src = region.row(y0 + gy - 1);
            for (a, &v) in active[gy * w + 1..gy * w + w - 1]
                .iter_mut()
                .zip(src.iter().skip(x0))
            {
                *a = v;
            }
        }
        // Neighbours inside the image (a pixel on the image border has fewer).
        let degree = |gy: usize, gx: usize| -> f32 {
            let (iy, ix) = (y0 + gy - 1, x0 + gx - 1);
            (usize::from(iy > 0)
                + usize::from(iy + 1 < n)
                + usize::from(ix > 0)
                + usize::from(ix + 1 < m)) as f32
        };
        let mut levels = vec![Level::from_active(h, w, &active, degree)?];
        while let Some(coarse) = levels.last().expect("level 0").coarsen()? {
            levels.push(coarse);
        }
        let l0 = &levels[0];
        let mut list = Vec::new();
        for gy in 1..h - 1 {
            for gx in 1..w - 1 {
                if active[gy * w + gx] {
                    list.push(((y0 + gy - 1) * m + x0 + gx - 1, l0.lay.idx(gy, gx)));
                }
            }
        }
        let diag64 = try_collect("region", l0.diag.len(), l0.diag.iter().map(|&d| d as f64))?;
        let act64 = try_collect("region", l0.act.len(), l0.act.iter().map(|&a| a as f64))?;
        let segments = l0.segs[0]
            .iter()
            .chain(&l0.segs[1])
            .map(|s| (s.a, s.b))
            .collect();
        Ok(Grid {
            n,
            m,
            y0,
            x0,
            levels,
            diag64,
            act64,
            active: list,
            segments,
        })
    }

    /// `q = A p` (the masked 5-point operator of level 0) in f64 on the segments; returns `p · q`.
    #[inline(always)]
    fn apply_dot<S: Simd>(&self, v: S, p: &[f64], q: &mut [f64]) -> f64 {
        self.stencil64(v, p, q, true)
    }

    /// `out = act · (diag · x − Σ_q x_q)` (`with_diag`, returning `x · out`) or `act · Σ_q x_q` (returning 0)
    /// on the segments.
    #[inline(always)]
    fn stencil64<S: Simd>(&self, v: S, x: &[f64], out: &mut [f64], with_diag: bool) -> f64 {
        let l0 = &self.levels[0];
        let (stride, act, diag) = (l0.lay.stride, &self.act64[..], &self.diag64[..]);
        let (red, black) = (&l0.segs[0][..], &l0.segs[1][..]);
        let mut acc = v.zero64();
        for s in red.iter().chain(black) {
            let n = s.b - s.a;
            let (up, dn, cu) = (
                &x[s.a - stride..s.b - stride],
                &x[s.a + stride..s.b + stride],
                &x[s.a..s.b],
            );
            let lr = &x[s.l..s.l + n + 1];
            let (ms, ds) = (&act[s.a..s.b], &diag[s.a..s.b]);
            let o = &mut out[s.a..s.b];
            for i in starts(0, n) {
                // SAFETY: i + VEC <= n, and lr has n + 1 elements.
                unsafe {
                    let vert = v.add64(v.ld64u(up, i), v.ld64u(dn, i));
                    let horz = v.add64(v.ld64u(lr, i), v.ld64u(lr, i + 1));
                    let nb = v.add64(vert, horz);
                    let m = v.ld64u(ms, i);
                    if with_diag {
                        let c = v.ld64u(cu, i);
                        let ov = v.mul64(m, v.sub64(v.mul64(v.ld64u(ds, i), c), nb));
                        acc = v.add64(acc, v.mul64(c, ov));
                        v.st64u(o, i, ov);
                    } else {
                        v.st64u(o, i, v.mul64(m, nb));
                    }
                }
            }
        }
        reduce(v.lanes64(acc))
    }

    #[allow(clippy::too_many_arguments)]
    fn solve_channel(
        &self,
        dst: &[f32],
        src: &[f32],
        c: usize,
        ch: usize,
        tol: f64,
        max_iter: usize,
        path: Path,
    ) -> Result<Channel> {
        #[cfg(target_arch = "x86_64")]
        if path == Path::Auto {
            if let Some(v) = simd::Avx2::detect() {
                // SAFETY: the token proves that the CPU supports AVX2.
                return unsafe { self.solve_channel_avx2(v, dst, src, c, ch, tol, max_iter) };
            }
        }
        let _ = path;
        self.solve_channel_body(Portable, dst, src, c, ch, tol, max_iter)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn solve_channel_avx2(
        &self,
        v: simd::Avx2,
        dst: &[f32],
        src: &[f32],
        c: usize,
        ch: usize,
        tol: f64,
        max_iter: usize,
    ) -> Result<Channel> {
        self.solve_channel_body(v, dst, src, c, ch, tol, max_iter)
    }

    /// PCG for one channel (everything it calls is inlined, so that the AVX2 entry point compiles it all to AVX2).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn solve_channel_body<S: Simd>(
        &self,
        v: S,
        dst: &[f32],
        src: &[f32],
        c: usize,
        ch: usize,
        tol: f64,
        max_iter: usize,
    ) -> Result<Channel> {
        let len = self.levels[0].lay.len();
        // s = src on level 0 (0 outside the image), g = dst − src on the in-image pixels outside the region.
        let mut s = Buf::take(len, false)?;
        let mut g = Buf::take(len, false)?;
        self.gather(dst, src, c, ch, &mut s, &mut g);
        // p and q are 0 off the segments throughout (the stencils read p there).
        let mut p = Buf::take(len, true)?;
        let mut q = Buf::take(len, true)?;
        // r = b − A·src, the residual of the initial guess f = src: Σ_{q ∉ Ω} (dst_q − src_q); b = r + A·src.
        let mut r = Buf::take(len, false)?;
        self.stencil64(v, &g, &mut r, false);
        drop(g);
        self.seg_mul_add(v, &self.act64, &s, None, &mut p);
        self.apply_dot(v, &p, &mut q);
        let mut b = Buf::take(len, false)?;
        self.seg_add(v, &r, &q, false, &mut b);
        let bnorm = self.seg_dot(v, &b, &b).sqrt();
        if bnorm == 0.0 {
            // The exact solution is 0 on the region.
            for &(a, z) in &self.segments {
                p[a..z].fill(0.0);
            }
            return Ok(Channel {
                f: p,
                iterations: 0,
                residual: 0.0,
            });
        }
        let mut ws = Workspace::new(&self.levels)?;
        let mut e = Buf::take(len, false)?;
        for &(a, z) in &self.segments {
            e[a..z].fill(0.0);
        }
        let target = tol * bnorm;
        let mut iterations = 0;
        let mut rnorm = self.seg_dot(v, &r, &r).sqrt();
        loop {
            // PCG on A e = r from the current e (after a restart, r is the true residual). z = M r is kept as
            // rscale · u0, u0 the V-cycle's result for the input f0 = r / rscale (values of order 1 in f32).
            let before = iterations;
            if rnorm > target {
                let mut rscale = rnorm;
                self.seg_to_f32(v, &r, 1.0 / rscale, &mut ws.f[0]);
                self.vcycle(v, &mut ws);
                let mut rz = self.seg_dot_scaled(v, &r, &ws.u[0], rscale);
                self.seg_set_p(v, &mut p, &ws.u[0], rscale, 0.0);
                while iterations < max_iter && rz > 0.0 {
                    let pq = self.apply_dot(v, &p, &mut q);
                    if pq.is_nan() || pq <= 0.0 {
                        break;
                    }
                    iterations += 1;
                    // Also writes the next V-cycle's input, r / rscale (rscale = the previous ‖r‖).
                    let rr = self.seg_update_er(
                        v,
                        &mut e,
                        &mut r,
                        &p,
                        &q,
                        rz / pq,
                        &mut ws.f[0],
                        rscale,
                    );
                    rnorm = rr.sqrt();
                    if rnorm <= target {
                        break;
                    }
                    self.vcycle(v, &mut ws);
                    let rz_new = self.seg_dot_scaled(v, &r, &ws.u[0], rscale);
                    self.seg_set_p(v, &mut p, &ws.u[0], rscale, rz_new / rz);
                    rz = rz_new;
                    rscale = rnorm;
                }
            }
            // The true residual b − A f of f = src + e (0 off the region in the product). p is free now (a
            // restart sets it again) and 0 off the segments, so it holds f.
            self.seg_mul_add(v, &self.act64, &s, Some(&e), &mut p);
            self.apply_dot(v, &p, &mut q);
            self.seg_add(v, &b, &q, true, &mut r);
            rnorm = self.seg_dot(v, &r, &r).sqrt();
            let residual = rnorm / bnorm;
            if residual <= tol {
                return Ok(Channel {
                    f: p,
                    iterations,
                    residual,
                });
            }
            // No progress (a breakdown, or the f64 floor above tol) also ends it.
            if iterations >= max_iter || iterations == before || !residual.is_finite() {
                return Err(TilesynthError::param(
                    "tol",
                    tol,
                    format!(
                        "not reached in {iterations} iterations (channel {ch}: relative residual \
                         {residual:.3e})"
                    ),
                ));
            }
        }
    }

    /// `s` = channel `ch` of `src` on level 0 (0 outside the image) and `g` = `dst − src` on the in-image points
    /// that are not unknowns (0 elsewhere); every element of both is written.
    #[inline(always)]
    fn gather(&self, dst: &[f32], src: &[f32], c: usize, ch: usize, s: &mut [f64], g: &mut [f64]) {
        let l0 = &self.levels[0];
        let Layout {
            h, w, blk, stride, ..
        } = l0.lay;
        // Grid columns inside the image: gx in [xa, xb).
        let xa = usize::from(self.x0 == 0);
        let xb = w.min(self.m + 1 - self.x0);
        s.fill(0.0);
        g.fill(0.0);
        for gy in 0..h {
            if gy + self.y0 < 1 || gy + self.y0 > self.n {
                continue;
            }
            let row = gy * stride;
            // Image sample of grid column gx: (base + x0 + gx − 1) · c + ch (gx ≥ xa, so x0 + gx ≥ 1).
            let base = (self.y0 + gy - 1) * self.m + self.x0;
            for parity in 0..2 {
                // Block index k holds grid column 2k + parity.
                let (ka, kb) = ((xa + 1 - parity) / 2, (xb + 1 - parity) / 2);
                let off = row + parity * blk;
                let (sr, gr) = (&mut s[off + ka..off + kb], &mut g[off + ka..off + kb]);
                let ar = &l0.act[off + ka..off + kb];
                for (j, ((sv, gv), &a)) in sr.iter_mut().zip(gr.iter_mut()).zip(ar).enumerate() {
                    let k = (base + 2 * (ka + j) + parity - 1) * c + ch;
                    let x = src[k] as f64;
                    *sv = x;
                    *gv = (1.0 - a as f64) * (dst[k] as f64 - x);
                }
            }
        }
    }

    /// `Σ a_i b_i` over the segments, in a fixed order.
    #[inline(always)]
    fn seg_dot<S: Simd>(&self, v: S, a: &[f64], b: &[f64]) -> f64 {
        let mut acc = v.zero64();
        for &(s, z) in &self.segments {
            let (x, y) = (&a[s..z], &b[s..z]);
            for i in starts(0, z - s) {
                // SAFETY: i + VEC <= z − s.
                acc = v.add64(acc, unsafe { v.mul64(v.ld64u(x, i), v.ld64u(y, i)) });
            }
        }
        reduce(v.lanes64(acc))
    }

    /// `out = (x · scale) as f32` on the segments.
    #[inline(always)]
    fn seg_to_f32<S: Simd>(&self, v: S, x: &[f64], scale: f64, out: &mut [f32]) {
        let sc = v.splat64(scale);
        for &(a, z) in &self.segments {
            let (xs, o) = (&x[a..z], &mut out[a..z]);
            for i in starts(0, z - a) {
                // SAFETY: i + VEC <= z − a.
                unsafe { v.st32u(o, i, v.narrow(v.mul64(v.ld64u(xs, i), sc))) };
            }
        }
    }

    /// `out = a ⊙ (b + c)` on the segments (`c = None`: `a ⊙ b`).
    #[inline(always)]
    fn seg_mul_add<S: Simd>(&self, v: S, a: &[f64], b: &[f64], c: Option<&[f64]>, out: &mut [f64]) {
        for &(s, z) in &self.segments {
            let (x, y, o) = (&a[s..z], &b[s..z], &mut out[s..z]);
            let w = c.map(|c| &c[s..z]);
            for i in starts(0, z - s) {
                // SAFETY: i + VEC <= z − s.
                unsafe {
                    let bc = match w {
                        Some(w) => v.add64(v.ld64u(y, i), v.ld64u(w, i)),
                        None => v.ld64u(y, i),
                    };
                    v.st64u(o, i, v.mul64(v.ld64u(x, i), bc));
                }
            }
        }
    }

    /// `out = a + b` (`minus`: `a − b`) on the segments.
    #[inline(always)]
    fn seg_add<S: Simd>(&self, v: S, a: &[f64], b: &[f64], minus: bool, out: &mut [f64]) {
        for &(s, z) in &self.segments {
            let (x, y, o) = (&a[s..z], &b[s..z], &mut out[s..z]);
            for i in starts(0, z - s) {
                // SAFETY: i + VEC <= z − s.
                unsafe {
                    let (p, q) = (v.ld64u(x, i), v.ld64u(y, i));
                    v.st64u(o, i, if minus { v.sub64(p, q) } else { v.add64(p, q) });
                }
            }
        }
    }

    /// One symmetric V-cycle from `ws.f[0]` into `ws.u[0]`.
    #[inline(always)]
    #[allow(clippy::reversed_empty_ranges)] // PRE_SWEEPS may be 1
    fn vcycle<S: Simd>(&self, v: S, ws: &mut Workspace) {
        let nl = self.levels.len();
        for l in 0..nl - 1 {
            let lev = &self.levels[l];
            relax(v, lev, &mut ws.u[l], &ws.f[l], true, true);
            relax(v, lev, &mut ws.u[l], &ws.f[l], false, false);
            for _ in 1..PRE_SWEEPS {
                relax(v, lev, &mut ws.u[l], &ws.f[l], true, false);
                relax(v, lev, &mut ws.u[l], &ws.f[l], false, false);
            }
            residual_red(v, lev, &ws.u[l], &ws.f[l], &mut ws.res[l]);
            restrict(
                v,
                lev,
                &self.levels[l + 1],
                &ws.res[l],
                &mut ws.f[l + 1],
                &mut ws.tmp,
            );
        }
        let (lev, l) = (&self.levels[nl - 1], nl - 1);
        relax(v, lev, &mut ws.u[l], &ws.f[l], true, true);
        relax(v, lev, &mut ws.u[l], &ws.f[l], false, false);
        for _ in 1..COARSE_SWEEPS {
            relax(v, lev, &mut ws.u[l], &ws.f[l], true, false);
            relax(v, lev, &mut ws.u[l], &ws.f[l], false, false);
        }
        for _ in 0..COARSE_SWEEPS {
            relax(v, lev, &mut ws.u[l], &ws.f[l], false, false);
            relax(v, lev, &mut ws.u[l], &ws.f[l], true, false);
        }
        for l in (0..nl - 1).rev() {
            let (lev, coarse) = (&self.levels[l], &self.levels[l + 1]);
            unpack(coarse, &ws.u[l + 1], &mut ws.nat);
            prolong_add(v, lev, coarse, &ws.nat, &mut ws.u[l], &mut ws.tmp);
            for _ in 0..PRE_SWEEPS {
                relax(v, lev, &mut ws.u[l], &ws.f[l], false, false);
                relax(v, lev, &mut ws.u[l], &ws.f[l], true, false);
            }
        }
    }

    /// `scale · Σ r_i u_i` over the segments.
    #[inline(always)]
    fn seg_dot_scaled<S: Simd>(&self, v: S, r: &[f64], u: &[f32], scale: f64) -> f64 {
        let mut acc = v.zero64();
        for &(a, z) in &self.segments {
            let (rs, us) = (&r[a..z], &u[a..z]);
            for i in starts(0, z - a) {
                // SAFETY: i + VEC <= z − a.
                acc = v.add64(acc, unsafe {
                    v.mul64(v.ld64u(rs, i), v.widen(v.ld32u(us, i)))
                });
            }
        }
        reduce(v.lanes64(acc)) * scale
    }

    /// `p = scale · u + β p` over the segments.
    #[inline(always)]
    fn seg_set_p<S: Simd>(&self, v: S, p: &mut [f64], u: &[f32], scale: f64, beta: f64) {
        let (sc, be) = (v.splat64(scale), v.splat64(beta));
        for &(a, z) in &self.segments {
            let (ps, us) = (&mut p[a..z], &u[a..z]);
            for i in starts(0, z - a) {
                // SAFETY: i + VEC <= z − a.
                unsafe {
                    let zv = v.mul64(v.widen(v.ld32u(us, i)), sc);
                    let np = v.add64(zv, v.mul64(be, v.ld64u(ps, i)));
                    v.st64u(ps, i, np);
                }
            }
        }
    }

    /// `e += α p`, `r −= α q` and `f0 = r / rscale` (as f32) over the segments; returns `‖r‖²`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn seg_update_er<S: Simd>(
        &self,
        v: S,
        e: &mut [f64],
        r: &mut [f64],
        p: &[f64],
        q: &[f64],
        alpha: f64,
        f0: &mut [f32],
        rscale: f64,
    ) -> f64 {
        let (al, inv) = (v.splat64(alpha), v.splat64(1.0 / rscale));
        let mut acc = v.zero64();
        for &(a, z) in &self.segments {
            let (es, rs, fs) = (&mut e[a..z], &mut r[a..z], &mut f0[a..z]);
            let (ps, qs) = (&p[a..z], &q[a..z]);
            for i in starts(0, z - a) {
                // SAFETY: i + VEC <= z − a.
                unsafe {
                    let ne = v.add64(v.ld64u(es, i), v.mul64(al, v.ld64u(ps, i)));
                    let nr = v.sub64(v.ld64u(rs, i), v.mul64(al, v.ld64u(qs, i)));
                    v.st64u(es, i, ne);
                    v.st64u(rs, i, nr);
                    v.st32u(fs, i, v.narrow(v.mul64(nr, inv)));
                    acc = v.add64(acc, v.mul64(nr, nr));
                }
            }
        }
        reduce(v.lanes64(acc))
    }
}

/// Per-channel scratch arrays of the V-cycle (f32, packed layout).
struct Workspace {
    /// Solutions (0 off the spans and on inactive points, always).
    u: Vec<Buf<f32>>,
    /// Right-hand sides (only read on the spans, where they are written first).
    f: Vec<Buf<f32>>,
    /// Residuals (0 on black points and off the spans, always).
    res: Vec<Buf<f32>>,
    /// The unpacked coarse solution (sized for level 1, written in full before it is read).
    nat: Buf<f32>,
    tmp: Vec<f32>,
}

impl Workspace {
    fn new(levels: &[Level]) -> Result<Workspace> {
        let sizes: Vec<usize> = levels.iter().map(|l| l.lay.len()).collect();
        let wmax = levels.iter().map(|l| l.lay.w).max().unwrap_or(0);
        let nat = levels.get(1).map_or(0, |l| l.lay.h * l.lay.w) + NAT_SLACK;
        Ok(Workspace {
            u: sizes
                .iter()
                .map(|&s| Buf::take(s, true))
                .collect::<Result<_>>()?,
            f: sizes
                .iter()
                .map(|&s| Buf::take(s, false))
                .collect::<Result<_>>()?,
            // The coarsest level needs no residual.
            res: sizes[..sizes.len() - 1]
                .iter()
                .map(|&s| Buf::take(s, true))
                .collect::<Result<_>>()?,
            nat: Buf::take(nat, false)?,
            tmp: try_vec("region", wmax + 4 * VEC, 0.0)?,
        })
    }
}

/// Scratch buffers kept per thread between calls. A 256x256 tile needs about 5 MB of scratch per channel, and
/// fresh memory costs a page fault per 4 kB (more than the solve itself, measured); reusing it costs at most a
/// memset where an array must start at 0. At most [`POOL_BYTES`] per element type are kept per thread.
struct Buf<T: Pooled>(Vec<T>);

/// The most scratch memory kept per thread and element type.
const POOL_BYTES: usize = 32 << 20;

trait Pooled: Copy + Default + 'static {
    fn with_pool<R>(f: impl FnOnce(&mut Vec<Vec<Self>>) -> R) -> R;
}

thread_local! {
    static POOL_F64: std::cell::RefCell<Vec<Vec<f64>>> = const { std::cell::RefCell::new(Vec::new()) };
    static POOL_F32: std::cell::RefCell<Vec<Vec<f32>>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl Pooled for f64 {
    fn with_pool<R>(f: impl FnOnce(&mut Vec<Vec<f64>>) -> R) -> R {
        POOL_F64.with(|p| f(&mut p.borrow_mut()))
    }
}

impl Pooled for f32 {
    fn with_pool<R>(f: impl FnOnce(&mut Vec<Vec<f32>>) -> R) -> R {
        POOL_F32.with(|p| f(&mut p.borrow_mut()))
    }
}

impl<T: Pooled> Buf<T> {
    /// A buffer of `len` elements: all 0 with `zero`, else arbitrary (the caller writes before it reads).
    ///
    /// Fallible: a fresh buffer is allocated with `try_reserve`, so a refused one is an error naming `region`
    /// (the buffers are sized by the region's bounding box).
    fn take(len: usize, zero: bool) -> Result<Buf<T>> {
        let found = T::with_pool(|pool| {
            // The smallest pooled buffer that is large enough.
            let best = pool
                .iter()
                .enumerate()
                .filter(|(_, v)| v.capacity() >= len)
                .min_by_key(|(_, v)| v.capacity())
                .map(|(i, _)| i);
            best.map(|i| pool.swap_remove(i))
        });
        match found {
            Some(mut v) => {
                if zero {
                    v.clear();
                }
                v.truncate(len);
                v.resize(len, T::default());
                Ok(Buf(v))
            }
            None => Ok(Buf(try_vec("region", len, T::default())?)),
        }
    }
}

impl<T: Pooled> Drop for Buf<T> {
    fn drop(&mut self) {
        let v = std::mem::take(&mut self.0);
        let bytes = |v: &Vec<T>| v.capacity() * std::mem::size_of::<T>();
        if bytes(&v) == 0 || bytes(&v) > POOL_BYTES {
            return;
        }
        T::with_pool(|pool| {
            pool.push(v);
            // Over the limit: drop the oldest buffers first.
            while pool.iter().map(bytes).sum::<usize>() > POOL_BYTES {
                pool.remove(0);
            }
        });
    }
}

impl<T: Pooled> std::ops::Deref for Buf<T> {
    type Target = [T];
    fn deref(&self) -> &[T] {
        &self.0
    }
}

impl<T: Pooled> std::ops::DerefMut for Buf<T> {
    fn deref_mut(&mut self) -> &mut [T] {
        &mut self.0
    }
}

/// Lanes of the fixed-order reductions (one per lane of a chunk).
const LANES: usize = VEC;

#[inline(always)]
fn reduce(acc: [f64; LANES]) -> f64 {
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array3};

    fn lcg(seed: u64) -> impl FnMut() -> f32 {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        move || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 40) as f32) / ((1u64 << 24) as f32)
        }
    }

    fn image(n: usize, m: usize, c: usize, seed: u64) -> Array3<f32> {
        let mut next = lcg(seed);
        Array3::from_shape_fn((n, m, c), |_| next())
    }

    fn random_region(n: usize, m: usize, p: f32, seed: u64) -> Array2<bool> {
        let mut next = lcg(seed);
        Array2::from_shape_fn((n, m), |_| next() < p)
    }

    fn disc(n: usize, r: f64) -> Array2<bool> {
        let c = (n as f64 - 1.0) / 2.0;
        Array2::from_shape_fn((n, n), |(y, x)| {
            let (dy, dx) = (y as f64 - c, x as f64 - c);
            dy * dy + dx * dx <= r * r
        })
    }

    type DenseSystem = (Vec<Vec<f64>>, Vec<f64>, Vec<(usize, usize)>);

    /// The dense system of the module's equation for one channel: `(A, b, unknown pixels)`.
    fn dense_system(
        dst: &Array3<f32>,
        src: &Array3<f32>,
        region: &Array2<bool>,
        ch: usize,
    ) -> DenseSystem {
        let (n, m) = region.dim();
        let pix: Vec<(usize, usize)> = region
            .indexed_iter()
            .filter(|(_, &v)| v)
            .map(|(p, _)| p)
            .collect();
        let mut index = Array2::from_elem((n, m), usize::MAX);
        for (k, &p) in pix.iter().enumerate() {
            index[p] = k;
        }
        let k = pix.len();
        let mut a = vec![vec![0.0f64; k]; k];
        let mut b = vec![0.0f64; k];
        for (i, &(y, x)) in pix.iter().enumerate() {
            let mut nb = vec![];
            if y > 0 {
                nb.push((y - 1, x));
            }
            if y + 1 < n {
                nb.push((y + 1, x));
            }
            if x > 0 {
                nb.push((y, x - 1));
            }
            if x + 1 < m {
                nb.push((y, x + 1));
            }
            for &(qy, qx) in &nb {
                a[i][i] += 1.0;
                b[i] += src[(y, x, ch)] as f64 - src[(qy, qx, ch)] as f64;
                if region[(qy, qx)] {
                    a[i][index[(qy, qx)]] -= 1.0;
                } else {
                    b[i] += dst[(qy, qx, ch)] as f64;
                }
            }
        }
        (a, b, pix)
    }

    /// Gaussian elimination with partial pivoting, f64.
    #[allow(clippy::needless_range_loop)]
    fn gauss(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
        let k = b.len();
        for col in 0..k {
            let piv = (col..k)
                .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
                .unwrap();
            a.swap(col, piv);
            b.swap(col, piv);
            for row in col + 1..k {
                let f = a[row][col] / a[col][col];
                if f != 0.0 {
                    for j in col..k {
                        a[row][j] -= f * a[col][j];
                    }
                    b[row] -= f * b[col];
                }
            }
        }
        let mut x = vec![0.0; k];
        for row in (0..k).rev() {
            let s: f64 = (row + 1..k).map(|j| a[row][j] * x[j]).sum();
            x[row] = (b[row] - s) / a[row][row];
        }
        x
    }

    fn rel_residual(a: &[Vec<f64>], b: &[f64], x: &[f64]) -> f64 {
        let mut rr = 0.0;
        let mut bb = 0.0;
        for i in 0..b.len() {
            let ax: f64 = a[i].iter().zip(x).map(|(p, q)| p * q).sum();
            rr += (b[i] - ax).powi(2);
            bb += b[i] * b[i];
        }
        (rr / bb).sqrt()
    }

    fn check_against_dense(dst: &Array3<f32>, src: &Array3<f32>, region: &Array2<bool>, tol: f64) {
        let (out, info) = poisson_smooth(dst.view(), src.view(), region.view(), tol).unwrap();
        let c = dst.dim().2;
        assert_eq!(info.residual.len(), c);
        for ch in 0..c {
            let (a, b, pix) = dense_system(dst, src, region, ch);
            let x = gauss(a.clone(), b.clone());
            let got: Vec<f64> = pix.iter().map(|&(y, x)| out[(y, x, ch)] as f64).collect();
            // The reported residual is that of the f64 solution; the f32 output is within rounding of it.
            assert!(info.residual[ch] <= tol, "{:?}", info);
            let xnorm = x.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-30);
            let err = x
                .iter()
                .zip(&got)
                .map(|(p, q)| (p - q).powi(2))
                .sum::<f64>()
                .sqrt();
            // ‖x − x*‖ ≤ κ(A) · tol · ‖x*‖ plus f32 rounding; these regions are small (κ ≲ 100).
            assert!(
                err <= (200.0 * tol + 1e-6) * xnorm,
                "channel {ch}: error {err:e}, |x| {xnorm:e}, residual {:e}",
                info.residual[ch]
            );
            let r32 = rel_residual(&a, &b, &got);
            assert!(r32 <= tol + 1e-6, "f32 output residual {r32:e}");
        }
        // Outside the region: dst, bit for bit.
        for ((y, x, ch), &v) in out.indexed_iter() {
            if !region[(y, x)] {
                assert_eq!(v.to_bits(), dst[(y, x, ch)].to_bits());
            }
        }
    }

    #[test]
    fn matches_dense_oracle_on_small_regions() {
        for (n, m, c, p, seed) in [
            (5, 5, 1, 0.5, 1),
            (8, 9, 3, 0.6, 2),
            (12, 10, 3, 0.8, 3),
            (16, 16, 2, 0.7, 4),
            (3, 17, 3, 0.9, 5),
            (1, 9, 1, 0.7, 6),
            (14, 14, 4, 0.95, 7),
        ] {
            let dst = image(n, m, c, seed);
            let src = image(n, m, c, seed + 100);
            let mut region = random_region(n, m, p, seed + 200);
            if region.iter().all(|&v| v) {
                region[(0, 0)] = false;
            }
            check_against_dense(&dst, &src, &region, 1e-10);
            check_against_dense(&dst, &src, &region, DEFAULT_TOL);
        }
    }

    #[test]
    fn disc_and_omega_like_region_match_oracle() {
        let n = 20;
        let dst = image(n, n, 3, 11);
        let src = image(n, n, 3, 12);
        check_against_dense(&dst, &src, &disc(n, n as f64 / 2.0 - 2.0), 1e-9);
        // A blob with a thin arm and a hole, off the border.
        let mut region = disc(n, 6.0);
        for x in 2..18 {
            region[(9, x)] = true;
        }
        region[(9, 9)] = false;
        region[(10, 10)] = false;
        check_against_dense(&dst, &src, &region, 1e-9);
    }

    #[test]
    fn residual_bound_and_iterations_at_tile_sizes() {
        for n in [80usize, 128] {
            let dst = image(n, n, 3, n as u64);
            let src = image(n, n, 3, n as u64 + 1);
            let region = disc(n, n as f64 / 2.0 - 2.0);
            for tol in [1e-6, 1e-9] {
                let (_, info) = poisson_smooth(dst.view(), src.view(), region.view(), tol).unwrap();
                assert!(info.residual.iter().all(|&r| r <= tol), "{info:?}");
                assert!(info.iterations >= 1 && info.iterations <= 30, "{info:?}");
                assert_eq!(info.unknowns, region.iter().filter(|&&v| v).count());
            }
        }
    }

    #[test]
    fn empty_full_and_trivial_regions() {
        let dst = image(6, 7, 3, 1);
        let src = image(6, 7, 3, 2);
        let none = Array2::from_elem((6, 7), false);
        let (out, info) = poisson_smooth(dst.view(), src.view(), none.view(), 1e-6).unwrap();
        assert_eq!(out, dst);
        assert_eq!(info.iterations, 0);
        assert_eq!(info.unknowns, 0);
        let all = Array2::from_elem((6, 7), true);
        let (out, info) = poisson_smooth(dst.view(), src.view(), all.view(), 1e-6).unwrap();
        assert_eq!(out, src);
        assert_eq!(info.residual, vec![0.0; 3]);
        // src = dst: the solution is src itself (b = A·src), reached without iterating.
        let region = disc(7, 2.0).slice(ndarray::s![..6, ..]).to_owned();
        let (out, info) = poisson_smooth(dst.view(), dst.view(), region.view(), 1e-6).unwrap();
        assert_eq!(info.iterations, 0);
        for (a, b) in out.iter().zip(dst.iter()) {
            assert!((a - b).abs() <= 1e-6);
        }
        // Constant src and zero dst: b = 0, f = 0.
        let zero = Array3::<f32>::zeros((6, 7, 1));
        let flat = Array3::<f32>::from_elem((6, 7, 1), 0.25);
        let (out, info) = poisson_smooth(zero.view(), flat.view(), region.view(), 1e-6).unwrap();
        assert!(out.iter().all(|&v| v == 0.0));
        assert_eq!(info.iterations, 0);
    }

    #[test]
    fn batch_equals_single_and_is_thread_independent() {
        let (k, n, c) = (4, 40, 3);
        let mut dst = Array4::<f32>::zeros((k, n, n, c));
        let mut src = Array4::<f32>::zeros((k, n, n, c));
        let mut reg = ndarray::Array3::from_elem((k, n, n), false);
        for t in 0..k {
            dst.index_axis_mut(Axis(0), t)
                .assign(&image(n, n, c, 10 + t as u64));
            src.index_axis_mut(Axis(0), t)
                .assign(&image(n, n, c, 20 + t as u64));
            let r = disc(n, 8.0 + 3.0 * t as f64);
            let noise = random_region(n, n, 0.3, 30 + t as u64);
            reg.index_axis_mut(Axis(0), t)
                .assign(&(&r | &(&noise & &disc(n, 17.0))));
        }
        let one = crate::parallel::install(Some(1), || {
            poisson_smooth_batch(dst.view(), src.view(), reg.view(), 1e-6)
        })
        .unwrap()
        .unwrap();
        let two = crate::parallel::install(Some(2), || {
            poisson_smooth_batch(dst.view(), src.view(), reg.view(), 1e-6)
        })
        .unwrap()
        .unwrap();
        let bits = |a: &Array4<f32>| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&one.0), bits(&two.0));
        assert_eq!(one.1, two.1);
        for t in 0..k {
            let (single, info) = poisson_smooth(
                dst.index_axis(Axis(0), t),
                src.index_axis(Axis(0), t),
                reg.index_axis(Axis(0), t),
                1e-6,
            )
            .unwrap();
            assert_eq!(single, one.0.index_axis(Axis(0), t));
            assert_eq!(info, one.1[t]);
        }
    }

    #[test]
    fn simd_and_portable_paths_are_bit_identical() {
        // Odd sizes exercise the vector tails; the ω-like disc with holes exercises masked coarse levels.
        for (n, m, seed) in [(37usize, 53usize, 1u64), (80, 80, 2), (129, 97, 3)] {
            let dst = image(n, m, 3, seed);
            let src = image(n, m, 3, seed + 100);
            let mut region = random_region(n, m, 0.9, seed + 200);
            region.indexed_iter_mut().for_each(|((y, x), v)| {
                let (dy, dx) = (y as f64 - n as f64 / 2.0, x as f64 - m as f64 / 2.0);
                *v &= dy * dy + dx * dx <= (n.min(m) as f64 / 2.0 - 2.0).powi(2);
            });
            let a = solve_with(dst.view(), src.view(), region.view(), 1e-6, Path::Auto);
            let b = solve_with(dst.view(), src.view(), region.view(), 1e-6, Path::Portable);
            let bits = |x: &Array3<f32>| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&a.0), bits(&b.0), "{n}x{m}");
            assert_eq!(a.1, b.1);
        }
    }

    #[test]
    fn errors_name_the_parameter() {
        let a = image(6, 6, 3, 1);
        let b = image(6, 5, 3, 1);
        let r = Array2::from_elem((6, 6), true);
        let e = poisson_smooth(a.view(), b.view(), r.view(), 1e-6).unwrap_err();
        assert!(e.to_string().starts_with("src has shape (6, 5, 3)"), "{e}");
        let r5 = Array2::from_elem((5, 6), true);
        let e = poisson_smooth(a.view(), a.view(), r5.view(), 1e-6).unwrap_err();
        assert!(e.to_string().starts_with("region has shape (5, 6)"), "{e}");
        let z = Array3::<f32>::zeros((0, 6, 3));
        let e = poisson_smooth(z.view(), z.view(), r.view(), 1e-6).unwrap_err();
        assert!(e.to_string().starts_with("dst has shape"), "{e}");
        for bad in [0.0, -1.0, 1.0, f64::NAN, 1e-13] {
            let e = poisson_smooth(a.view(), a.view(), r.view(), bad).unwrap_err();
            assert!(e.to_string().starts_with("tol = "), "{e}");
        }
        let mut nan = a.clone();
        nan[(2, 2, 1)] = f32::NAN;
        let e = poisson_smooth(nan.view(), a.view(), r.view(), 1e-6).unwrap_err();
        assert!(e.to_string().starts_with("dst = non-finite"), "{e}");
        let e = poisson_smooth(a.view(), nan.view(), r.view(), 1e-6).unwrap_err();
        assert!(e.to_string().starts_with("src = non-finite"), "{e}");
        let d4 = Array4::<f32>::zeros((2, 6, 6, 3));
        let r3 = ndarray::Array3::from_elem((2, 6, 5), true);
        let e = poisson_smooth_batch(d4.view(), d4.view(), r3.view(), 1e-6).unwrap_err();
        assert!(
            e.to_string().starts_with("region has shape (2, 6, 5)"),
            "{e}"
        );
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::{Buf, Level};
    use crate::error::{assert_alloc_error, HUGE_SIDE};

    /// The solver's level arrays and scratch buffers, sized by the region's bounding box, are allocated
    /// fallibly: a size that cannot be allocated is an error naming `region`.
    #[test]
    fn levels_and_buffers_that_cannot_be_allocated_are_errors() {
        assert_alloc_error(
            Level::from_active(HUGE_SIDE, HUGE_SIDE, &[], |_, _| 4.0).map(|l| l.lay.len()),
            "region",
        );
        assert_alloc_error(
            Buf::<f32>::take(HUGE_SIDE * HUGE_SIDE, true).map(|b| b.0.len()),
            "region",
        );
        assert_alloc_error(
            Buf::<f64>::take(HUGE_SIDE * HUGE_SIDE, false).map(|b| b.0.len()),
            "region",
        );
        assert_eq!(Buf::<f32>::take(5, true).unwrap().0, vec![0.0; 5]);
    }
}
