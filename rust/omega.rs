//! The ω-tile cutting curve of Ng et al. (CGI 2005, §3.2).
//!
//! An intermediate tile `I` (N x N, cut from the centre of a 2x2 block of sample patches) has a vertical and a
//! horizontal seam through its middle. A matching patch `O` of the exemplar replaces the interior of `I` inside a
//! closed cutting curve found by min-cut:
//!
//! - nodes are the pixels; 4-neighbour edges carry Kwatra et al.'s gradient-normalised weight
//!   `w(s,t) = (‖I(s)−O(s)‖ + ‖I(t)−O(t)‖) / (‖g_I(s)‖ + ‖g_I(t)‖ + ‖g_O(s)‖ + ‖g_O(t)‖ + eps)`, where ‖·‖ is the
//!   L2 norm over channels and `g(p)` the forward difference from `p` to its next pixel in the direction s→t
//!   (0 when that pixel is outside the tile);
//! - sources (keep `I`): every pixel outside the inscribed circle `(y−c)² + (x−c)² ≤ (N/2)²`, `c = (N−1)/2`;
//! - sinks (take `O`): the two central rows and two central columns (`N/2−1`, `N/2`) inside the circle.
//!
//! `eps` guards flat regions where all four gradients vanish; the default [`DEFAULT_EPS`] = 1e-6 matches the
//! reference data in `shared/reference/mincut80.npz`. Edges with both ends outside the circle join two source
//! pixels and get weight 0 (they can never be cut).
//!
//! Because the curve is confined to the circle, the tile border keeps `I`'s pixels except where the sink cross
//! reaches the four side midpoints, so ω-tiles that share corner patches stay seamless.

use crate::error::{fmt_shape, Result, TilesynthError};
use crate::maxflow::grid_mincut;
use ndarray::{Array2, Array3, ArrayView2, ArrayView3, ArrayView4, Axis, Zip};
use rayon::prelude::*;

/// Default epsilon in the denominator of the Kwatra weight.
pub const DEFAULT_EPS: f64 = 1e-6;

/// Pixels of an `n x n` tile inside the inscribed circle `(y−c)² + (x−c)² ≤ (n/2)²`, `c = (n−1)/2`.
pub fn circle_mask(n: usize) -> Array2<bool> {
    let c = (n as f64 - 1.0) / 2.0;
    let r2 = (n as f64 / 2.0).powi(2);
    Array2::from_shape_fn((n, n), |(y, x)| {
        let (dy, dx) = (y as f64 - c, x as f64 - c);
        dy * dy + dx * dx <= r2
    })
}

/// The sink cross: rows and columns `n/2 − 1` and `n/2`, restricted to the inscribed circle.
pub fn cross_mask(n: usize) -> Array2<bool> {
    let inside = circle_mask(n);
    let (a, b) = (n / 2 - 1, n / 2);
    Array2::from_shape_fn((n, n), |(y, x)| {
        inside[(y, x)] && (y == a || y == b || x == a || x == b)
    })
}

fn check_pair(i: &ArrayView3<f32>, o: &ArrayView3<f32>) -> Result<()> {
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
    if let Some(g) = &a_grad {
        let (h, w, _) = a.dim();
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
    if !(eps.is_finite() && eps > 0.0) {
        return Err(TilesynthError::param("eps", eps, "must be finite and > 0"));
    }
    let (h, w, _) = a.dim();
    if let Some(r) = &region {
        if r.dim() != (h, w) {
            return Err(TilesynthError::shape(
                "region",
                fmt_shape(&[h, w]),
                fmt_shape(r.shape()),
            ));
        }
    }
    let (a, b) = (a.as_standard_layout(), b.as_standard_layout());
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
    let diff: Vec<f64> = (0..h * w).map(|p| dist(a, p, b, p)).collect();
    let mut out = Vec::with_capacity(2);
    for (axis, (dy, dx)) in [(0usize, 1usize), (1, 0)].into_iter().enumerate() {
        let step = dy * w + dx;
        // ‖img(p + step) − img(p)‖, 0 where p + step leaves the image.
        let grad = |img: &[f32]| -> Vec<f64> {
            (0..h * w)
                .map(|p| {
                    let (y, x) = (p / w, p % w);
                    if y + dy >= h || x + dx >= w {
                        0.0
                    } else {
                        dist(img, p + step, img, p)
                    }
                })
                .collect()
        };
        let ga = match &a_grad {
            Some(g) => g.index_axis(Axis(2), axis).iter().copied().collect(),
            None => grad(a),
        };
        let gb = grad(b);
        let wmap = Array2::from_shape_fn((h, w), |(y, x)| {
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
        });
        out.push(wmap);
    }
    let wy = out.pop().expect("two maps");
    let wx = out.pop().expect("two maps");
    Ok((wx, wy))
}

/// One solved cutting curve.
#[derive(Debug, Clone)]
pub struct OmegaCut {
    /// `true` where the ω-tile takes the matching patch `O` (inside the curve).
    pub takes_o: Array2<bool>,
    /// The min-cut cost: the sum of the weights of the edges the curve crosses.
    pub cost: f64,
}

/// The cutting curve between intermediate tile `i` and matching patch `o` (both `(N, N, C)`, N even ≥ 2).
///
/// `i_grad` (`(N, N, 2)`, see [`kwatra_weights`]) optionally gives the gradient norms of `i`. Without it the
/// gradients are forward differences of the assembled tile, exactly the formula of the reference data. The paper
/// defines `G_I(s)` as the gradient "in the patch I"; taken literally on the assembled intermediate tile, the
/// gradient across its own cross seam is large, which makes every edge next to the sink cross cheap, and the
/// min-cut then hugs the cross (thin strips of `O` along the seams instead of a curve around them). The ω
/// construction therefore passes the gradients of the sample patches each pixel came from.
pub fn omega_cut(
    i: ArrayView3<f32>,
    o: ArrayView3<f32>,
    eps: f64,
    i_grad: Option<ArrayView3<f64>>,
) -> Result<OmegaCut> {
    check_pair(&i, &o)?;
    let (h, w, _) = i.dim();
    if h != w || h % 2 != 0 || h < 2 {
        return Err(TilesynthError::shape(
            "intermediate",
            "(N, N, C) with N even and >= 2",
            fmt_shape(i.shape()),
        ));
    }
    let inside = circle_mask(h);
    let sinks = cross_mask(h);
    let (wx, wy) = kwatra_weights(i, o, Some(inside.view()), eps, i_grad)?;
    let outside = inside.mapv(|v| !v);
    let cut = grid_mincut(
        wx.view(),
        wy.view(),
        outside.view(),
        sinks.view(),
        None,
        None,
    )?;
    Ok(OmegaCut {
        takes_o: cut.sink_side,
        cost: cut.flow,
    })
}

/// [`omega_cut`] for K tiles at once, in parallel over tiles: `intermediate` and `matching` are `(K, N, N, C)`,
/// `intermediate_grad` optionally `(K, N, N, 2)`. Returns the masks `(K, N, N)` and the costs. Results do not
/// depend on the thread count.
pub fn omega_cuts(
    intermediate: ArrayView4<f32>,
    matching: ArrayView4<f32>,
    eps: f64,
    intermediate_grad: Option<ArrayView4<f64>>,
) -> Result<(Array3<bool>, Vec<f64>)> {
    if let Some(g) = &intermediate_grad {
        let (k, n, m, _) = intermediate.dim();
        if g.dim() != (k, n, m, 2) {
            return Err(TilesynthError::shape(
                "intermediate_grad",
                fmt_shape(&[k, n, m, 2]),
                fmt_shape(g.shape()),
            ));
        }
    }
    if intermediate.dim() != matching.dim() {
        return Err(TilesynthError::shape(
            "matching",
            format!(
                "{} (the shape of intermediate)",
                fmt_shape(intermediate.shape())
            ),
            fmt_shape(matching.shape()),
        ));
    }
    let (k, n, m, _) = intermediate.dim();
    let cuts: Vec<Result<OmegaCut>> = (0..k)
        .into_par_iter()
        .map(|t| {
            omega_cut(
                intermediate.index_axis(Axis(0), t),
                matching.index_axis(Axis(0), t),
                eps,
                intermediate_grad.as_ref().map(|g| g.index_axis(Axis(0), t)),
            )
        })
        .collect();
    let mut masks = Array3::from_elem((k, n, m), false);
    let mut costs = Vec::with_capacity(k);
    for (t, cut) in cuts.into_iter().enumerate() {
        let cut = cut?;
        masks.index_axis_mut(Axis(0), t).assign(&cut.takes_o);
        costs.push(cut.cost);
    }
    Ok((masks, costs))
}

/// The ω-tile: `o` where `takes_o`, else `i`.
pub fn compose(
    i: ArrayView3<f32>,
    o: ArrayView3<f32>,
    takes_o: ArrayView2<bool>,
) -> Result<Array3<f32>> {
    check_pair(&i, &o)?;
    let (h, w, _) = i.dim();
    if takes_o.dim() != (h, w) {
        return Err(TilesynthError::shape(
            "takes_o",
            fmt_shape(&[h, w]),
            fmt_shape(takes_o.shape()),
        ));
    }
    let mut out = i.to_owned();
    Zip::from(out.lanes_mut(Axis(2)))
        .and(o.lanes(Axis(2)))
        .and(&takes_o)
        .for_each(|mut px, src, &t| {
            if t {
                px.assign(&src);
            }
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg_image(h: usize, w: usize, c: usize, seed: u64) -> Array3<f32> {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        Array3::from_shape_fn((h, w, c), |_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 40) as f32) / ((1u64 << 24) as f32)
        })
    }

    #[test]
    fn masks_match_definition() {
        let n = 80;
        let inside = circle_mask(n);
        assert!(!inside[(0, 0)]);
        assert!(inside[(39, 0)] && inside[(40, 79)] && inside[(0, 39)]);
        let cross = cross_mask(n);
        assert_eq!(cross.iter().filter(|&&v| v).count(), 4 * 80 - 4);
        assert!(cross.iter().zip(inside.iter()).all(|(&c, &i)| !c || i));
    }

    #[test]
    fn weights_follow_formula() {
        let a = lcg_image(6, 7, 3, 1);
        let b = lcg_image(6, 7, 3, 2);
        let (wx, wy) = kwatra_weights(a.view(), b.view(), None, 1e-6, None).unwrap();
        let norm = |v: Vec<f64>| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let px = |img: &Array3<f32>, y: usize, x: usize| -> Vec<f64> {
            (0..3).map(|c| img[(y, x, c)] as f64).collect()
        };
        let sub = |p: Vec<f64>, q: Vec<f64>| -> Vec<f64> {
            p.iter().zip(&q).map(|(a, b)| a - b).collect()
        };
        // edge (2,3)-(2,4): forward differences (2,3)->(2,4) and (2,4)->(2,5)
        let num = norm(sub(px(&a, 2, 3), px(&b, 2, 3))) + norm(sub(px(&a, 2, 4), px(&b, 2, 4)));
        let den = norm(sub(px(&a, 2, 4), px(&a, 2, 3)))
            + norm(sub(px(&a, 2, 5), px(&a, 2, 4)))
            + norm(sub(px(&b, 2, 4), px(&b, 2, 3)))
            + norm(sub(px(&b, 2, 5), px(&b, 2, 4)))
            + 1e-6;
        assert!((wx[(2, 3)] - num / den).abs() < 1e-12);
        // last edge of a row: the forward neighbour of t is outside, so its gradient is 0
        let num = norm(sub(px(&a, 1, 5), px(&b, 1, 5))) + norm(sub(px(&a, 1, 6), px(&b, 1, 6)));
        let den =
            norm(sub(px(&a, 1, 6), px(&a, 1, 5))) + norm(sub(px(&b, 1, 6), px(&b, 1, 5))) + 1e-6;
        assert!((wx[(1, 5)] - num / den).abs() < 1e-12);
        assert_eq!(wx[(1, 6)], 0.0);
        assert_eq!(wy[(5, 2)], 0.0);
        assert!(wy[(4, 2)] > 0.0);
    }

    #[test]
    fn gradient_override_equal_to_own_gradients_changes_nothing() {
        let a = lcg_image(9, 8, 3, 5);
        let b = lcg_image(9, 8, 3, 6);
        let own = Array3::from_shape_fn((9, 8, 2), |(y, x, axis)| {
            let (ty, tx) = if axis == 0 { (y, x + 1) } else { (y + 1, x) };
            if ty >= 9 || tx >= 8 {
                return 0.0;
            }
            (0..3)
                .map(|c| (a[(ty, tx, c)] as f64 - a[(y, x, c)] as f64).powi(2))
                .sum::<f64>()
                .sqrt()
        });
        let plain = kwatra_weights(a.view(), b.view(), None, 1e-6, None).unwrap();
        let over = kwatra_weights(a.view(), b.view(), None, 1e-6, Some(own.view())).unwrap();
        assert_eq!(plain, over);
        let zero = Array3::<f64>::zeros((9, 8, 2));
        let flat = kwatra_weights(a.view(), b.view(), None, 1e-6, Some(zero.view())).unwrap();
        assert!(flat.0[(0, 0)] > plain.0[(0, 0)]);
        let bad = Array3::<f64>::zeros((9, 8, 3));
        assert!(kwatra_weights(a.view(), b.view(), None, 1e-6, Some(bad.view())).is_err());
    }

    #[test]
    fn identical_images_cut_for_free() {
        let a = lcg_image(16, 16, 3, 7);
        let cut = omega_cut(a.view(), a.view(), DEFAULT_EPS, None).unwrap();
        assert_eq!(cut.cost, 0.0);
    }

    #[test]
    fn cut_respects_terminals() {
        let n = 32;
        let a = lcg_image(n, n, 3, 3);
        let b = lcg_image(n, n, 3, 4);
        let cut = omega_cut(a.view(), b.view(), DEFAULT_EPS, None).unwrap();
        let inside = circle_mask(n);
        let cross = cross_mask(n);
        for ((&t, &i), &c) in cut.takes_o.iter().zip(inside.iter()).zip(cross.iter()) {
            if !i {
                assert!(!t);
            }
            if c {
                assert!(t);
            }
        }
        assert!(cut.cost > 0.0);
        let composed = compose(a.view(), b.view(), cut.takes_o.view()).unwrap();
        assert_eq!(composed[(0, 0, 0)], a[(0, 0, 0)]);
        assert_eq!(composed[(n / 2, n / 2, 1)], b[(n / 2, n / 2, 1)]);
    }

    #[test]
    fn batch_equals_single_and_is_thread_independent() {
        let n = 24;
        let k = 3;
        let mut ii = ndarray::Array4::<f32>::zeros((k, n, n, 3));
        let mut oo = ndarray::Array4::<f32>::zeros((k, n, n, 3));
        for t in 0..k {
            ii.index_axis_mut(Axis(0), t)
                .assign(&lcg_image(n, n, 3, 10 + t as u64));
            oo.index_axis_mut(Axis(0), t)
                .assign(&lcg_image(n, n, 3, 20 + t as u64));
        }
        let one = crate::parallel::install(Some(1), || {
            omega_cuts(ii.view(), oo.view(), DEFAULT_EPS, None)
        })
        .unwrap()
        .unwrap();
        let two = crate::parallel::install(Some(2), || {
            omega_cuts(ii.view(), oo.view(), DEFAULT_EPS, None)
        })
        .unwrap()
        .unwrap();
        assert_eq!(one.0, two.0);
        assert_eq!(one.1, two.1);
        for t in 0..k {
            let single = omega_cut(
                ii.index_axis(Axis(0), t),
                oo.index_axis(Axis(0), t),
                DEFAULT_EPS,
                None,
            )
            .unwrap();
            assert_eq!(single.cost, one.1[t]);
        }
    }

    #[test]
    fn errors_name_the_parameter() {
        let a = lcg_image(5, 5, 3, 1);
        let e = omega_cut(a.view(), a.view(), DEFAULT_EPS, None).unwrap_err();
        assert!(e.to_string().contains("intermediate"), "{e}");
        let b = lcg_image(6, 6, 3, 1);
        let e = omega_cut(b.view(), a.view(), DEFAULT_EPS, None).unwrap_err();
        assert!(e.to_string().contains("matching"), "{e}");
        let e = kwatra_weights(b.view(), b.view(), None, 0.0, None).unwrap_err();
        assert!(e.to_string().contains("eps"), "{e}");
    }
}
