//! Kwatra et al.'s gradient-normalised seam weights (Graphcut Textures, 2003), shared by every cut in the core:
//! the ω cutting curve ([`crate::omega`]), the edge-weight heuristics of the matching search, and the graph cuts
//! of Wang and strict Wang tiles ([`crate::wang`]).
//!
//! `w(s,t) = (‖A(s)−B(s)‖ + ‖A(t)−B(t)‖) / (‖g_A(s)‖ + ‖g_A(t)‖ + ‖g_B(s)‖ + ‖g_B(t)‖ + eps)`, ‖·‖ the L2 norm over
//! channels, `g(p)` the forward difference from `p` to its next pixel in the direction s→t (0 past the edge).

use crate::error::{fmt_shape, try_array, try_collect, try_standard, Result, TilesynthError};
use ndarray::{Array2, ArrayView2, ArrayView3, Axis};

/// Default epsilon in the denominator of the Kwatra weight (it guards flat regions where all four gradients
/// vanish; 1e-6 matches the reference data in `shared/reference/mincut80.npz`).
pub const DEFAULT_EPS: f64 = 1e-6;

/// Checks that the gradient norms `g` (if given) are `(h, w, 2)`, finite and >= 0.
pub(crate) fn check_grad(g: Option<&ArrayView3<f64>>, h: usize, w: usize) -> Result<()> {
    if let Some(g) = g {
        if g.dim() != (h, w, 2) {
            return Err(TilesynthError::shape(
                "intermediate_grad",
                fmt_shape(&[h, w, 2]),
                fmt_shape(g.shape()),
            ));
        }
        if g.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(TilesynthError::param(
                "intermediate_grad",
                "negative or non-finite value",
                "gradient norms must be finite and >= 0",
            ));
        }
    }
    Ok(())
}

/// Checks that the Kwatra epsilon is finite and > 0.
pub(crate) fn check_eps(eps: f64) -> Result<()> {
    if !(eps.is_finite() && eps > 0.0) {
        return Err(TilesynthError::param("eps", eps, "must be finite and > 0"));
    }
    Ok(())
}

/// Checks that `i` and `o` are non-empty `(H, W, C)` images of one shape with finite values.
pub(crate) fn check_pair(i: &ArrayView3<f32>, o: &ArrayView3<f32>) -> Result<()> {
    let (h, w, c) = i.dim();
    if h == 0 || w == 0 || c == 0 {
        return Err(TilesynthError::shape(
            "intermediate",
            "(H, W, C) with H, W, C >= 1",
            fmt_shape(i.shape()),
        ));
    }
    if o.dim() != i.dim() {
        return Err(TilesynthError::shape(
            "matching",
            format!("{} (the shape of intermediate)", fmt_shape(i.shape())),
            fmt_shape(o.shape()),
        ));
    }
    if i.iter().chain(o.iter()).any(|v| !v.is_finite()) {
        return Err(TilesynthError::param(
            "intermediate/matching",
            "non-finite value",
            "images must not contain NaN or infinity",
        ));
    }
    Ok(())
}

/// Kwatra edge weights between images `a` (kept, source side) and `b` (inserted, sink side).
///
/// Returns `(wx, wy)`, both `(H, W)` f64: `wx[y, x]` weights edge (y,x)–(y,x+1) (last column 0), `wy[y, x]` edge
/// (y,x)–(y+1,x) (last row 0). If `region` is given, edges with both ends outside it get weight 0.
///
/// `a_grad` optionally replaces the gradient norms of `a`: `(H, W, 2)` holding ‖g_a‖ along x (index 0) and along
/// y (index 1) at every pixel. See [`omega_cut`] for why the ω construction passes the gradients of the sample
/// patches rather than those of the assembled intermediate tile.
pub fn kwatra_weights(
    a: ArrayView3<f32>,
    b: ArrayView3<f32>,
    region: Option<ArrayView2<bool>>,
    eps: f64,
    a_grad: Option<ArrayView3<f64>>,
) -> Result<(Array2<f64>, Array2<f64>)> {
    check_pair(&a, &b)?;
    let (h, w, _) = a.dim();
    check_grad(a_grad.as_ref(), h, w)?;
    check_eps(eps)?;
    if let Some(r) = &region {
        if r.dim() != (h, w) {
            return Err(TilesynthError::shape(
                "region",
                fmt_shape(&[h, w]),
                fmt_shape(r.shape()),
            ));
        }
    }
    let (a, b) = (try_standard("a", a)?, try_standard("b", b)?);
    let (a, b) = (
        a.as_slice().expect("standard layout"),
        b.as_slice().expect("standard layout"),
    );
    let c = a.len() / (h * w);
    // L2 norm over channels of img1(p) − img2(q), in f64.
    let dist = |img1: &[f32], p: usize, img2: &[f32], q: usize| -> f64 {
        let (s, t) = (&img1[p * c..p * c + c], &img2[q * c..q * c + c]);
        s.iter()
            .zip(t)
            .map(|(&u, &v)| {
                let d = u as f64 - v as f64;
                d * d
            })
            .sum::<f64>()
            .sqrt()
    };
    let diff: Vec<f64> = try_collect("a", h * w, (0..h * w).map(|p| dist(a, p, b, p)))?;
    let mut out = Vec::with_capacity(2);
    for (axis, (dy, dx)) in [(0usize, 1usize), (1, 0)].into_iter().enumerate() {
        let step = dy * w + dx;
        // ‖img(p + step) − img(p)‖, 0 where p + step leaves the image.
        let grad = |img: &[f32]| -> Result<Vec<f64>> {
            try_collect(
                "a",
                h * w,
                (0..h * w).map(|p| {
                    let (y, x) = (p / w, p % w);
                    if y + dy >= h || x + dx >= w {
                        0.0
                    } else {
                        dist(img, p + step, img, p)
                    }
                }),
            )
        };
        let ga = match &a_grad {
            Some(g) => try_collect("a_grad", h * w, g.index_axis(Axis(2), axis).iter().copied())?,
            None => grad(a)?,
        };
        let gb = grad(b)?;
        let weight = |y: usize, x: usize| -> f64 {
            let (ty, tx) = (y + dy, x + dx);
            if ty >= h || tx >= w {
                return 0.0;
            }
            if let Some(r) = &region {
                if !r[(y, x)] && !r[(ty, tx)] {
                    return 0.0;
                }
            }
            let (s, t) = (y * w + x, ty * w + tx);
            let num = diff[s] + diff[t];
            let den = ga[s] + ga[t] + gb[s] + gb[t] + eps;
            num / den
        };
        let mut wmap = try_array("a", (h, w), 0.0f64)?;
        for ((y, x), v) in wmap.indexed_iter_mut() {
            *v = weight(y, x);
        }
        out.push(wmap);
    }
    let wy = out.pop().expect("two maps");
    let wx = out.pop().expect("two maps");
    Ok((wx, wy))
}
