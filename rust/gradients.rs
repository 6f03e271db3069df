//! Gradient norms of an image at given pixel positions (the ω-tiles' per-pixel gradient weights).
//!
//! For an image `E` of shape `(H, W, C)` and positions `(row, col)`, returns `(gx, gy)` per position with
//!
//! ```text
//! gx = ||E(r, c+1) - E(r, c)||_2   (0 when c = W - 1)
//! gy = ||E(r+1, c) - E(r, c)||_2   (0 when r = H - 1)
//! ```
//!
//! the L2 norm over channels in `f64` (each value converted from `f32`, the squares summed in channel
//! order, then `sqrt`): bit-identical to the NumPy reference
//! `sqrt(((e[:, 1:] - e[:, :-1]) ** 2).sum(-1))` for `C < 8` (where NumPy sums sequentially), which is
//! what `tilesynth.builder.omega.patch_gradients` computed before.

use crate::error::{fmt_shape, Result, TilesynthError};
use ndarray::{Array2, ArrayView2, ArrayView3};

/// `(M, 2)` gradient norms `[gx, gy]` of `image` `(H, W, C)` at the `(M, 2)` positions `(row, col)`.
/// Errors (naming `source`) for a position outside the image; `image` must have `1 <= C < 8` channels.
pub fn patch_gradients(image: ArrayView3<f32>, source: ArrayView2<i64>) -> Result<Array2<f64>> {
    let (h, w, c) = image.dim();
    if c == 0 || c >= 8 || h == 0 || w == 0 {
        return Err(TilesynthError::shape(
            "exemplar",
            "(H, W, C) with H, W >= 1 and 1 <= C < 8",
            fmt_shape(image.shape()),
        ));
    }
    if source.dim().1 != 2 {
        return Err(TilesynthError::shape(
            "source",
            "(M, 2) (row, col)",
            fmt_shape(source.shape()),
        ));
    }
    let m = source.dim().0;
    let mut out = Array2::<f64>::zeros((m, 2));
    for (j, pos) in source.outer_iter().enumerate() {
        let (r, col) = (pos[0], pos[1]);
        if r < 0 || col < 0 || r as u64 >= h as u64 || col as u64 >= w as u64 {
            return Err(TilesynthError::param(
                "source",
                format!("({r}, {col})"),
                format!("every position must lie inside the {h} x {w} exemplar"),
            ));
        }
        let (r, col) = (r as usize, col as usize);
        let norm = |r2: usize, c2: usize| {
            let mut s = 0.0f64;
            for ch in 0..c {
                let d = image[(r2, c2, ch)] as f64 - image[(r, col, ch)] as f64;
                s += d * d;
            }
            s.sqrt()
        };
        if col + 1 < w {
            out[(j, 0)] = norm(r, col + 1);
        }
        if r + 1 < h {
            out[(j, 1)] = norm(r + 1, col);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array3};

    #[test]
    fn matches_definition_and_edges() {
        let img = Array3::from_shape_fn((3, 4, 2), |(y, x, ch)| {
            (y * 7 + x * 3 + ch * 5) as f32 * 0.1
        });
        let src = Array2::from_shape_vec((4, 2), vec![0, 0, 2, 3, 1, 3, 2, 1]).unwrap();
        let g = patch_gradients(img.view(), src.view()).unwrap();
        let norm = |a: (usize, usize), b: (usize, usize)| {
            (0..2)
                .map(|ch| {
                    let d = img[(b.0, b.1, ch)] as f64 - img[(a.0, a.1, ch)] as f64;
                    d * d
                })
                .sum::<f64>()
                .sqrt()
        };
        assert_eq!(g[(0, 0)], norm((0, 0), (0, 1)));
        assert_eq!(g[(0, 1)], norm((0, 0), (1, 0)));
        assert_eq!((g[(1, 0)], g[(1, 1)]), (0.0, 0.0)); // bottom-right corner
        assert_eq!(g[(2, 0)], 0.0); // last column
        assert_eq!(g[(2, 1)], norm((1, 3), (2, 3)));
        assert_eq!(g[(3, 1)], 0.0); // last row
        assert_eq!(g[(3, 0)], norm((2, 1), (2, 2)));
    }

    #[test]
    fn errors() {
        let img = Array3::<f32>::zeros((3, 4, 3));
        let bad = Array2::from_shape_vec((1, 2), vec![3i64, 0]).unwrap();
        assert!(patch_gradients(img.view(), bad.view()).is_err());
        let neg = Array2::from_shape_vec((1, 2), vec![0i64, -1]).unwrap();
        assert!(patch_gradients(img.view(), neg.view()).is_err());
        let three = Array2::<i64>::zeros((1, 3));
        assert!(patch_gradients(img.view(), three.view()).is_err());
        let wide = Array3::<f32>::zeros((3, 4, 8));
        let ok = Array2::<i64>::zeros((1, 2));
        assert!(patch_gradients(wide.view(), ok.view()).is_err());
        let empty = Array2::<i64>::zeros((0, 2));
        assert_eq!(
            patch_gradients(img.view(), empty.view()).unwrap().dim(),
            (0, 2)
        );
    }
}
