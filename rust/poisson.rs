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

use crate::error::{fmt_shape, Result, TilesynthError};
use ndarray::{Array3, Array4, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;

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

fn check_finite(name: &'static str, a: &ArrayView3<f32>) -> Result<()> {
    if a.iter().any(|v| !v.is_finite()) {
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

fn check_single(
    dst: &ArrayView3<f32>,
    src: &ArrayView3<f32>,
    region: &ArrayView2<bool>,
) -> Result<()> {
    let (n, m, c) = dst.dim();
    if n == 0 || m == 0 || c == 0 {
        return Err(TilesynthError::shape(
            "dst",
            "(N, M, C) with N, M, C >= 1",
            fmt_shape(dst.shape()),
        ));
    }
    if src.dim() != dst.dim() {
        return Err(TilesynthError::shape(
            "src",
            format!("{} (the shape of dst)", fmt_shape(dst.shape())),
            fmt_shape(src.shape()),
        ));
    }
    if region.dim() != (n, m) {
        return Err(TilesynthError::shape(
            "region",
            format!("{} (the first two axes of dst)", fmt_shape(&[n, m])),
            fmt_shape(region.shape()),
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
    check_single(&dst, &src, &region)?;
    check_finite("dst", &dst)?;
    check_finite("src", &src)?;
    check_tol(tol)?;
    solve_tile(dst, src, region, tol)
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
    let (k, n, m, c) = dst.dim();
    if n == 0 || m == 0 || c == 0 {
        return Err(TilesynthError::shape(
            "dst",
            "(K, N, M, C) with N, M, C >= 1",
            fmt_shape(dst.shape()),
        ));
    }
    if src.dim() != dst.dim() {
        return Err(TilesynthError::shape(
            "src",
            format!("{} (the shape of dst)", fmt_shape(dst.shape())),
            fmt_shape(src.shape()),
        ));
    }
    if region.dim() != (k, n, m) {
        return Err(TilesynthError::shape(
            "region",
            format!("{} (the first three axes of dst)", fmt_shape(&[k, n, m])),
            fmt_shape(region.shape()),
        ));
    }
    if dst.iter().any(|v| !v.is_finite()) {
        return Err(TilesynthError::param(
            "dst",
            "non-finite value",
            "images must not contain NaN or infinity",
        ));
    }
    if src.iter().any(|v| !v.is_finite()) {
        return Err(TilesynthError::param(
            "src",
            "non-finite value",
            "images must not contain NaN or infinity",
        ));
    }
    check_tol(tol)?;
    let solved: Vec<Result<(Array3<f32>, PoissonInfo)>> = (0..k)
        .into_par_iter()
        .map(|t| {
            solve_tile(
                dst.index_axis(Axis(0), t),
                src.index_axis(Axis(0), t),
                region.index_axis(Axis(0), t),
                tol,
            )
        })
        .collect();
    let mut out = Array4::<f32>::zeros((k, n, m, c));
    let mut infos = Vec::with_capacity(k);
    for (t, r) in solved.into_iter().enumerate() {
        let (tile, info) = r?;
        out.index_axis_mut(Axis(0), t).assign(&tile);
        infos.push(info);
    }
    Ok((out, infos))
}

// ------------------------------------------------------------------------------------------------ one tile

fn solve_tile(
    dst: ArrayView3<f32>,
    src: ArrayView3<f32>,
    region: ArrayView2<bool>,
    tol: f64,
) -> Result<(Array3<f32>, PoissonInfo)> {
    let (n, m, c) = dst.dim();
    let unknowns = region.iter().filter(|&&v| v).count();
    let mut out = dst.as_standard_layout().into_owned();
    if unknowns == 0 {
        return Ok((
            out,
            PoissonInfo {
                iterations: 0,
                residual: vec![0.0; c],
                unknowns,
            },
        ));
    }
    if unknowns == n * m {
        // No Dirichlet pixel: f = src + const, anchored to the mean of src (see the module documentation).
        out.assign(&src);
        return Ok((
            out,
            PoissonInfo {
                iterations: 0,
                residual: vec![0.0; c],
                unknowns,
            },
        ));
    }
    let grid = Grid::new(region);
    let src = src.as_standard_layout();
    let dst_s = dst.as_standard_layout();
    let (src_s, dst_s) = (
        src.as_slice().expect("standard layout"),
        dst_s.as_slice().expect("standard layout"),
    );
    let max_iter = max_iterations(n, m);
    let channels: Vec<Result<Channel>> = (0..c)
        .into_par_iter()
        .map(|ch| grid.solve_channel(dst_s, src_s, c, ch, tol, max_iter))
        .collect();
    let mut iterations = 0;
    let mut residual = Vec::with_capacity(c);
    let out_s = out.as_slice_mut().expect("standard layout");
    for (ch, res) in channels.into_iter().enumerate() {
        let res = res?;
        iterations = iterations.max(res.iterations);
        residual.push(res.residual);
        let l0 = &grid.levels[0];
        for gy in 1..l0.h - 1 {
            let (lo, hi) = l0.spans[gy];
            for gx in lo..hi {
                let g = gy * l0.w + gx;
                if l0.act[g] != 0.0 {
                    let (iy, ix) = grid.image_of(gy, gx);
                    let v = res.f[g] as f32;
                    if !v.is_finite() {
                        return Err(TilesynthError::param(
                            "dst/src",
                            format!("{:e}", res.f[g]),
                            "the solution is not representable in float32",
                        ));
                    }
                    out_s[(iy * m + ix) * c + ch] = v;
                }
            }
        }
    }
    Ok((
        out,
        PoissonInfo {
            iterations,
            residual,
            unknowns,
        },
    ))
}

/// One channel's solution on the grid of level 0 (f64, only the active pixels are meaningful).
struct Channel {
    f: Vec<f64>,
    iterations: usize,
    residual: f64,
}

/// One multigrid level: an `h x w` grid whose ring is never active.
struct Level {
    h: usize,
    w: usize,
    /// Diagonal of the operator (number of in-image neighbours on level 0, 4 on coarse levels; 0 if inactive).
    diag: Vec<f32>,
    /// 1 on active (unknown) points, 0 elsewhere.
    act: Vec<f32>,
    /// `1 / diag` on active red points (`(y + x)` even), 0 elsewhere.
    wred: Vec<f32>,
    /// `1 / diag` on active black points, 0 elsewhere.
    wblack: Vec<f32>,
    /// Per row, the half-open range of columns spanning its active points (`(0, 0)` when it has none).
    spans: Vec<(usize, usize)>,
    /// Number of active points.
    active: usize,
}

impl Level {
    fn from_active(h: usize, w: usize, active: &[bool], diag_of: impl Fn(usize) -> f32) -> Level {
        let len = h * w;
        let mut diag = vec![0.0f32; len];
        let mut act = vec![0.0f32; len];
        let mut wred = vec![0.0f32; len];
        let mut wblack = vec![0.0f32; len];
        let mut spans = vec![(0usize, 0usize); h];
        let mut count = 0;
        for y in 0..h {
            let (mut lo, mut hi) = (usize::MAX, 0);
            for x in 0..w {
                let g = y * w + x;
                if !active[g] {
                    continue;
                }
                debug_assert!(y > 0 && x > 0 && y + 1 < h && x + 1 < w);
                count += 1;
                let d = diag_of(g);
                diag[g] = d;
                act[g] = 1.0;
                if (y + x) % 2 == 0 {
                    wred[g] = 1.0 / d;
                } else {
                    wblack[g] = 1.0 / d;
                }
                lo = lo.min(x);
                hi = x + 1;
            }
            if hi > 0 {
                spans[y] = (lo, hi);
            }
        }
        Level {
            h,
            w,
            diag,
            act,
            wred,
            wblack,
            spans,
            active: count,
        }
    }

    /// One red-black half-sweep of Gauss–Seidel with weights `wc` (`wred` or `wblack`): on the points of that
    /// colour `u ← (f + Σ_q u_q) / diag`. Points of the other colour read only the other colour, so a row can be
    /// updated from a copy of itself.
    fn relax(&self, u: &mut [f32], f: &[f32], red: bool, tmp: &mut [f32]) {
        let w = self.w;
        let wc = if red { &self.wred } else { &self.wblack };
        for y in 1..self.h - 1 {
            let (lo, hi) = self.spans[y];
            if lo >= hi {
                continue;
            }
            let len = hi - lo;
            let row = y * w;
            {
                let up = &u[row - w + lo..row - w + hi];
                let dn = &u[row + w + lo..row + w + hi];
                let left = &u[row + lo - 1..row + hi - 1];
                let right = &u[row + lo + 1..row + hi + 1];
                let cur = &u[row + lo..row + hi];
                let fr = &f[row + lo..row + hi];
                let dg = &self.diag[row + lo..row + hi];
                let wr = &wc[row + lo..row + hi];
                let t = &mut tmp[..len];
                for i in 0..len {
                    t[i] = cur[i]
                        + wr[i] * (fr[i] + ((up[i] + dn[i]) + (left[i] + right[i])) - dg[i] * cur[i]);
                }
            }
            u[row + lo..row + hi].copy_from_slice(&tmp[..len]);
        }
    }

    /// `res = act · (f − A u)` on the active spans (the rest of `res` is never written and stays 0).
    fn residual(&self, u: &[f32], f: &[f32], res: &mut [f32]) {
        let w = self.w;
        for y in 1..self.h - 1 {
            let (lo, hi) = self.spans[y];
            if lo >= hi {
                continue;
            }
            let row = y * w;
            let up = &u[row - w + lo..row - w + hi];
            let dn = &u[row + w + lo..row + w + hi];
            let left = &u[row + lo - 1..row + hi - 1];
            let right = &u[row + lo + 1..row + hi + 1];
            let cur = &u[row + lo..row + hi];
            let fr = &f[row + lo..row + hi];
            let dg = &self.diag[row + lo..row + hi];
            let ac = &self.act[row + lo..row + hi];
            let out = &mut res[row + lo..row + hi];
            for i in 0..out.len() {
                out[i] =
                    ac[i] * (fr[i] + ((up[i] + dn[i]) + (left[i] + right[i])) - dg[i] * cur[i]);
            }
        }
    }

    /// The coarse level: point `(Y, X)` is fine point `(2Y, 2X)`, active iff that one is. `None` when the grid is
    /// too small to coarsen or the coarse grid would have no active point.
    fn coarsen(&self) -> Option<Level> {
        if self.h < 5 || self.w < 5 {
            return None;
        }
        let (hc, wc) = (self.h / 2 + 1, self.w / 2 + 1);
        let mut active = vec![false; hc * wc];
        let mut any = false;
        for yc in 1..hc - 1 {
            for xc in 1..wc - 1 {
                let g = 2 * yc * self.w + 2 * xc;
                if self.act[g] != 0.0 {
                    active[yc * wc + xc] = true;
                    any = true;
                }
            }
        }
        if !any {
            return None;
        }
        Some(Level::from_active(hc, wc, &active, |_| 4.0))
    }
}

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
}

impl Grid {
    fn new(region: ArrayView2<bool>) -> Grid {
        let (n, m) = region.dim();
        let (mut y0, mut y1, mut x0, mut x1) = (usize::MAX, 0, usize::MAX, 0);
        for ((y, x), &v) in region.indexed_iter() {
            if v {
                y0 = y0.min(y);
                y1 = y1.max(y);
                x0 = x0.min(x);
                x1 = x1.max(x);
            }
        }
        let (h, w) = (y1 - y0 + 3, x1 - x0 + 3);
        let mut active = vec![false; h * w];
        for gy in 1..h - 1 {
            for gx in 1..w - 1 {
                active[gy * w + gx] = region[(y0 + gy - 1, x0 + gx - 1)];
            }
        }
        // Neighbours inside the image (a pixel on the image border has fewer).
        let degree = |g: usize| -> f32 {
            let (gy, gx) = (g / w, g % w);
            let (iy, ix) = (y0 + gy - 1, x0 + gx - 1);
            (usize::from(iy > 0)
                + usize::from(iy + 1 < n)
                + usize::from(ix > 0)
                + usize::from(ix + 1 < m)) as f32
        };
        let mut levels = vec![Level::from_active(h, w, &active, degree)];
        while let Some(coarse) = levels.last().expect("level 0").coarsen() {
            levels.push(coarse);
        }
        let diag64 = levels[0].diag.iter().map(|&d| d as f64).collect();
        let act64 = levels[0].act.iter().map(|&a| a as f64).collect();
        Grid {
            n,
            m,
            y0,
            x0,
            levels,
            diag64,
            act64,
        }
    }

    /// Image coordinates of an in-image grid point.
    #[inline]
    fn image_of(&self, gy: usize, gx: usize) -> (usize, usize) {
        (self.y0 + gy - 1, self.x0 + gx - 1)
    }

    /// Whether grid point `(gy, gx)` of level 0 lies inside the image.
    #[inline]
    fn in_image(&self, gy: usize, gx: usize) -> bool {
        let (iy, ix) = (self.y0 + gy, self.x0 + gx);
        iy >= 1 && ix >= 1 && iy <= self.n && ix <= self.m
    }

    /// `q = A p` (the masked 5-point operator of level 0) in f64; `q` stays 0 off the active spans.
    fn apply(&self, p: &[f64], q: &mut [f64]) {
        let l0 = &self.levels[0];
        let w = l0.w;
        for y in 1..l0.h - 1 {
            let (lo, hi) = l0.spans[y];
            if lo >= hi {
                continue;
            }
            let row = y * w;
            let up = &p[row - w + lo..row - w + hi];
            let dn = &p[row + w + lo..row + w + hi];
            let left = &p[row + lo - 1..row + hi - 1];
            let right = &p[row + lo + 1..row + hi + 1];
            let cur = &p[row + lo..row + hi];
            let dg = &self.diag64[row + lo..row + hi];
            let ac = &self.act64[row + lo..row + hi];
            let out = &mut q[row + lo..row + hi];
            for i in 0..out.len() {
                out[i] = ac[i] * (dg[i] * cur[i] - ((up[i] + dn[i]) + (left[i] + right[i])));
            }
        }
    }

    /// `z ≈ A⁻¹ r` by one V-cycle in f32 (`r` is scaled by `1 / scale` on the way in and back on the way out, so
    /// the f32 levels see values of order 1).
    fn precondition(&self, r: &[f64], scale: f64, z: &mut [f64], ws: &mut Workspace) {
        let inv = 1.0 / scale;
        for (f, &v) in ws.f[0].iter_mut().zip(r) {
            *f = (v * inv) as f32;
        }
        self.vcycle(0, ws);
        for (zi, &u) in z.iter_mut().zip(&ws.u[0]) {
            *zi = u as f64 * scale;
        }
    }

    fn vcycle(&self, l: usize, ws: &mut Workspace) {
        let lev = &self.levels[l];
        ws.u[l].fill(0.0);
        if l + 1 == self.levels.len() {
            for _ in 0..COARSE_SWEEPS {
                lev.relax(&mut ws.u[l], &ws.f[l], true, &mut ws.tmp);
                lev.relax(&mut ws.u[l], &ws.f[l], false, &mut ws.tmp);
            }
            for _ in 0..COARSE_SWEEPS {
                lev.relax(&mut ws.u[l], &ws.f[l], false, &mut ws.tmp);
                lev.relax(&mut ws.u[l], &ws.f[l], true, &mut ws.tmp);
            }
            return;
        }
        for _ in 0..PRE_SWEEPS {
            lev.relax(&mut ws.u[l], &ws.f[l], true, &mut ws.tmp);
            lev.relax(&mut ws.u[l], &ws.f[l], false, &mut ws.tmp);
        }
        lev.residual(&ws.u[l], &ws.f[l], &mut ws.res[l]);
        self.restrict(l, ws);
        self.vcycle(l + 1, ws);
        self.prolong_add(l, ws);
        for _ in 0..PRE_SWEEPS {
            lev.relax(&mut ws.u[l], &ws.f[l], false, &mut ws.tmp);
            lev.relax(&mut ws.u[l], &ws.f[l], true, &mut ws.tmp);
        }
    }

    /// `f[l+1] = act · Pᵀ res[l]` with the bilinear weights 1, 1/2, 1/4 (the transpose of [`Grid::prolong_add`]).
    fn restrict(&self, l: usize, ws: &mut Workspace) {
        let (fine, coarse) = (&self.levels[l], &self.levels[l + 1]);
        let (w, wc) = (fine.w, coarse.w);
        let (lower, upper) = ws.f.split_at_mut(l + 1);
        let _ = lower;
        let fc = &mut upper[0];
        let res = &ws.res[l];
        let t = &mut ws.tmp;
        for yc in 1..coarse.h - 1 {
            let (lo, hi) = coarse.spans[yc];
            if lo >= hi {
                continue;
            }
            // Vertical pass over fine columns 2·lo − 1 ..= 2·hi − 1.
            let (xa, xb) = (2 * lo - 1, 2 * hi);
            let y = 2 * yc;
            let a = &res[(y - 1) * w + xa..(y - 1) * w + xb];
            let b = &res[y * w + xa..y * w + xb];
            let c = &res[(y + 1) * w + xa..(y + 1) * w + xb];
            let tv = &mut t[..xb - xa];
            for i in 0..tv.len() {
                tv[i] = b[i] + 0.5 * (a[i] + c[i]);
            }
            // Horizontal pass: coarse X ↔ fine 2X, i.e. tv index 2(X − lo) + 1.
            let out = &mut fc[yc * wc + lo..yc * wc + hi];
            let ac = &coarse.act[yc * wc + lo..yc * wc + hi];
            for (k, o) in out.iter_mut().enumerate() {
                let i = 2 * k + 1;
                *o = ac[k] * (tv[i] + 0.5 * (tv[i - 1] + tv[i + 1]));
            }
        }
    }

    /// `u[l] += act · P u[l+1]` (bilinear interpolation from the coarse points).
    fn prolong_add(&self, l: usize, ws: &mut Workspace) {
        let (fine, coarse) = (&self.levels[l], &self.levels[l + 1]);
        let (w, wc) = (fine.w, coarse.w);
        let (lower, upper) = ws.u.split_at_mut(l + 1);
        let (u, uc) = (&mut lower[l], &upper[0]);
        let (crow, e) = ws.tmp.split_at_mut(wc);
        for y in 1..fine.h - 1 {
            let (lo, hi) = fine.spans[y];
            if lo >= hi {
                continue;
            }
            // Coarse columns lo/2 ..= (hi − 1)/2 + 1 cover fine columns lo .. hi.
            let (ca, cb) = (lo / 2, (hi - 1) / 2 + 2);
            let yc = y / 2;
            let c = &mut crow[..cb - ca];
            if y % 2 == 0 {
                c.copy_from_slice(&uc[yc * wc + ca..yc * wc + cb]);
            } else {
                let a = &uc[yc * wc + ca..yc * wc + cb];
                let b = &uc[(yc + 1) * wc + ca..(yc + 1) * wc + cb];
                for i in 0..c.len() {
                    c[i] = 0.5 * (a[i] + b[i]);
                }
            }
            // Expand to fine columns 2·ca .. 2·cb − 1.
            let ex = &mut e[..2 * (cb - ca) - 1];
            for k in 0..cb - ca - 1 {
                ex[2 * k] = c[k];
                ex[2 * k + 1] = 0.5 * (c[k] + c[k + 1]);
            }
            ex[2 * (cb - ca - 1)] = c[cb - ca - 1];
            let off = lo - 2 * ca;
            let ur = &mut u[y * w + lo..y * w + hi];
            let ac = &fine.act[y * w + lo..y * w + hi];
            let ev = &ex[off..off + (hi - lo)];
            for i in 0..ur.len() {
                ur[i] += ac[i] * ev[i];
            }
        }
    }

    fn solve_channel(
        &self,
        dst: &[f32],
        src: &[f32],
        c: usize,
        ch: usize,
        tol: f64,
        max_iter: usize,
    ) -> Result<Channel> {
        let l0 = &self.levels[0];
        let (h, w, m) = (l0.h, l0.w, self.m);
        let len = h * w;
        // src and dst of this channel on the grid (0 outside the image).
        let mut s = vec![0.0f64; len];
        let mut d = vec![0.0f64; len];
        for gy in 0..h {
            for gx in 0..w {
                if self.in_image(gy, gx) {
                    let (iy, ix) = self.image_of(gy, gx);
                    let k = (iy * m + ix) * c + ch;
                    s[gy * w + gx] = src[k] as f64;
                    d[gy * w + gx] = dst[k] as f64;
                }
            }
        }
        // b: the right-hand side; r0 = b − A·src (the residual of the initial guess f = src).
        let mut b = vec![0.0f64; len];
        let mut r = vec![0.0f64; len];
        for gy in 1..h - 1 {
            let (lo, hi) = l0.spans[gy];
            for gx in lo..hi {
                let g = gy * w + gx;
                if l0.act[g] == 0.0 {
                    continue;
                }
                let (mut bg, mut rg) = (0.0, 0.0);
                for (q, qy, qx) in [
                    (g - w, gy - 1, gx),
                    (g + w, gy + 1, gx),
                    (g - 1, gy, gx - 1),
                    (g + 1, gy, gx + 1),
                ] {
                    if !self.in_image(qy, qx) {
                        continue;
                    }
                    bg += s[g] - s[q];
                    if l0.act[q] == 0.0 {
                        bg += d[q];
                        rg += d[q] - s[q];
                    }
                }
                b[g] = bg;
                r[g] = rg;
            }
        }
        let bnorm = dot(&b, &b).sqrt();
        let mut f = vec![0.0f64; len];
        if bnorm == 0.0 {
            // The exact solution is 0 on the region.
            return Ok(Channel {
                f,
                iterations: 0,
                residual: 0.0,
            });
        }
        let mut ws = Workspace::new(&self.levels);
        let mut e = vec![0.0f64; len];
        let mut z = vec![0.0f64; len];
        let mut p = vec![0.0f64; len];
        let mut q = vec![0.0f64; len];
        let target = tol * bnorm;
        let mut iterations = 0;
        let mut rnorm = dot(&r, &r).sqrt();
        loop {
            // PCG on A e = r from the current e (after a restart, r is the true residual).
            let before = iterations;
            if rnorm > target {
                self.precondition(&r, rnorm, &mut z, &mut ws);
                p.copy_from_slice(&z);
                let mut rz = dot(&r, &z);
                while iterations < max_iter && rz > 0.0 {
                    self.apply(&p, &mut q);
                    let pq = dot(&p, &q);
                    if !(pq > 0.0) {
                        break;
                    }
                    iterations += 1;
                    rnorm = update_xr(&mut e, &mut r, &p, &q, rz / pq).sqrt();
                    if rnorm <= target {
                        break;
                    }
                    self.precondition(&r, rnorm, &mut z, &mut ws);
                    let rz_new = dot(&r, &z);
                    update_p(&mut p, &z, rz_new / rz);
                    rz = rz_new;
                }
            }
            // The true residual b − A f of f = src + e (0 off the region in the product).
            for (((fi, &si), &ei), &a) in f.iter_mut().zip(&s).zip(&e).zip(&self.act64) {
                *fi = a * (si + ei);
            }
            self.apply(&f, &mut q);
            for ((ri, &bi), &qi) in r.iter_mut().zip(&b).zip(&q) {
                *ri = bi - qi;
            }
            rnorm = dot(&r, &r).sqrt();
            let residual = rnorm / bnorm;
            if residual <= tol {
                return Ok(Channel {
                    f,
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
}

/// Per-channel scratch arrays of the V-cycle (f32).
struct Workspace {
    u: Vec<Vec<f32>>,
    f: Vec<Vec<f32>>,
    res: Vec<Vec<f32>>,
    tmp: Vec<f32>,
}

impl Workspace {
    fn new(levels: &[Level]) -> Workspace {
        let sizes: Vec<usize> = levels.iter().map(|l| l.h * l.w).collect();
        let wmax = levels.iter().map(|l| l.w).max().unwrap_or(0);
        Workspace {
            u: sizes.iter().map(|&s| vec![0.0; s]).collect(),
            f: sizes.iter().map(|&s| vec![0.0; s]).collect(),
            res: sizes.iter().map(|&s| vec![0.0; s]).collect(),
            tmp: vec![0.0; 4 * wmax + 8],
        }
    }
}

/// Lanes of the fixed-order reductions.
const LANES: usize = 8;

/// `Σ a_i b_i` with [`LANES`] partial sums in a fixed order (deterministic, vectorisable).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0f64; LANES];
    let (ca, cb) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..LANES {
            acc[k] += x[k] * y[k];
        }
    }
    for (k, (x, y)) in ra.iter().zip(rb).enumerate() {
        acc[k] += x * y;
    }
    reduce(acc)
}

fn reduce(acc: [f64; LANES]) -> f64 {
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

/// `e += α p`, `r −= α q`; returns `‖r‖²`.
fn update_xr(e: &mut [f64], r: &mut [f64], p: &[f64], q: &[f64], alpha: f64) -> f64 {
    let mut acc = [0.0f64; LANES];
    let n = e.len();
    let full = n - n % LANES;
    for start in (0..full).step_by(LANES) {
        let (es, rs) = (&mut e[start..start + LANES], &mut r[start..start + LANES]);
        let (ps, qs) = (&p[start..start + LANES], &q[start..start + LANES]);
        for k in 0..LANES {
            es[k] += alpha * ps[k];
            rs[k] -= alpha * qs[k];
            acc[k] += rs[k] * rs[k];
        }
    }
    for (k, i) in (full..n).enumerate() {
        e[i] += alpha * p[i];
        r[i] -= alpha * q[i];
        acc[k] += r[i] * r[i];
    }
    reduce(acc)
}

/// `p = z + β p`.
fn update_p(p: &mut [f64], z: &[f64], beta: f64) {
    for (pi, &zi) in p.iter_mut().zip(z) {
        *pi = zi + beta * *pi;
    }
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

    /// The dense system of the module's equation for one channel: `(A, b, unknown pixels)`.
    fn dense_system(
        dst: &Array3<f32>,
        src: &Array3<f32>,
        region: &Array2<bool>,
        ch: usize,
    ) -> (Vec<Vec<f64>>, Vec<f64>, Vec<(usize, usize)>) {
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

    fn check_against_dense(
        dst: &Array3<f32>,
        src: &Array3<f32>,
        region: &Array2<bool>,
        tol: f64,
    ) {
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
        assert!(e.to_string().starts_with("region has shape (2, 6, 5)"), "{e}");
    }
}
