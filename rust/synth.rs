//! Synthesis: copy tiles into a large output by a tile index map.
//!
//! `out[y, x, :] = atlas[map[y / th, x / tw], y % th, x % tw, :]` for every output pixel; the map may cover more
//! than the output (the last row and column of tiles are cropped). Each output row is assembled from contiguous
//! tile-row slices (`tw * C` elements per copy), rows are filled in parallel, and the result is independent of the
//! thread count (it is a pure copy).

use crate::error::{fmt_shape, Result, TilesynthError};
use ndarray::{ArrayView2, ArrayView4, ArrayViewMut3};
use rayon::prelude::*;

/// Checks that `map` can fill an `(out_h, out_w)` output from `n_tiles` tiles of `th x tw`.
fn check(
    n_tiles: usize,
    th: usize,
    tw: usize,
    map: &ArrayView2<i32>,
    out_h: usize,
    out_w: usize,
) -> Result<()> {
    if n_tiles == 0 || th == 0 || tw == 0 {
        return Err(TilesynthError::shape(
            "atlas",
            "(K, th, tw, C) with K, th, tw >= 1",
            format!("({n_tiles}, {th}, {tw}, C)"),
        ));
    }
    let (rows, cols) = map.dim();
    if rows * th < out_h || cols * tw < out_w {
        return Err(TilesynthError::shape(
            "index_map",
            format!(
                "at least ({}, {}) tiles to cover a {out_h}x{out_w} output with {th}x{tw} tiles",
                out_h.div_ceil(th),
                out_w.div_ceil(tw)
            ),
            fmt_shape(map.shape()),
        ));
    }
    if let Some(&bad) = map.iter().find(|&&k| k < 0 || k as usize >= n_tiles) {
        return Err(TilesynthError::param(
            "index_map",
            bad,
            format!("tile indices must be in [0, {n_tiles})"),
        ));
    }
    Ok(())
}

/// Fills `out` (`(H, W, C)`, C-contiguous) from `atlas` (`(K, th, tw, C)`) by `map` (`(rows, cols)`).
pub fn tile_copy_into<T: Copy + Send + Sync>(
    atlas: ArrayView4<T>,
    map: ArrayView2<i32>,
    out: ArrayViewMut3<T>,
) -> Result<()> {
    tile_copy_window_into(atlas, map, (0, 0), out)
}

/// Like [`tile_copy_into`] for a window whose top-left pixel is `offset = (oy, ox)` pixels into the map's first
/// cell (`oy < th`, `ox < tw`): `out[y, x] = atlas[map[(y+oy)/th, (x+ox)/tw], (y+oy)%th, (x+ox)%tw]`. The map
/// must cover `oy + H` by `ox + W` pixels. Each output row is still assembled from contiguous tile-row slices
/// (the first and last cropped), so a window at any pixel offset copies at the same rate.
pub fn tile_copy_window_into<T: Copy + Send + Sync>(
    atlas: ArrayView4<T>,
    map: ArrayView2<i32>,
    offset: (usize, usize),
    mut out: ArrayViewMut3<T>,
) -> Result<()> {
    let (k, th, tw, c) = atlas.dim();
    let (out_h, out_w, out_c) = out.dim();
    let (oy, ox) = offset;
    if k > 0 && (oy >= th || ox >= tw) {
        return Err(TilesynthError::param(
            "offset",
            format!("({oy}, {ox})"),
            format!("must be below the tile size ({th}, {tw})"),
        ));
    }
    check(k, th, tw, &map, out_h + oy, out_w + ox)?;
    if out_c != c {
        return Err(TilesynthError::shape(
            "out",
            format!("(H, W, {c}) (the channels of atlas)"),
            fmt_shape(out.shape()),
        ));
    }
    let atlas = atlas.as_standard_layout();
    let atlas = atlas.as_slice().expect("standard layout");
    let map = map.as_standard_layout();
    let cols = map.ncols();
    let map = map.as_slice().expect("standard layout");
    let row_len = out_w * c;
    if row_len == 0 || out_h == 0 {
        return Ok(());
    }
    let out = out.as_slice_mut().ok_or_else(|| {
        TilesynthError::param("out", "non-contiguous array", "must be C-contiguous")
    })?;
    let tile_len = th * tw * c;
    let tile_row = tw * c;
    // Chunks of 8 output rows: large enough to amortise scheduling, small enough to balance 2+ threads.
    out.par_chunks_mut(row_len * 8)
        .enumerate()
        .for_each(|(chunk, rows)| {
            for (r, dst) in rows.chunks_mut(row_len).enumerate() {
                let y = chunk * 8 + r + oy;
                let (ty, yy) = (y / th, y % th);
                let map_row = &map[ty * cols..ty * cols + cols];
                if ox == 0 {
                    for (j, piece) in dst.chunks_mut(tile_row).enumerate() {
                        let t = map_row[j] as usize;
                        let start = t * tile_len + yy * tile_row;
                        piece.copy_from_slice(&atlas[start..start + piece.len()]);
                    }
                } else {
                    // The first piece starts `ox` pixels into its tile row; the rest are whole tile rows.
                    let first = ((tw - ox) * c).min(row_len);
                    let (head, tail) = dst.split_at_mut(first);
                    let start = map_row[0] as usize * tile_len + yy * tile_row + ox * c;
                    head.copy_from_slice(&atlas[start..start + first]);
                    for (j, piece) in tail.chunks_mut(tile_row).enumerate() {
                        let t = map_row[j + 1] as usize;
                        let start = t * tile_len + yy * tile_row;
                        piece.copy_from_slice(&atlas[start..start + piece.len()]);
                    }
                }
            }
        });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array3, Array4};

    fn naive(atlas: &Array4<u16>, map: &Array2<i32>, h: usize, w: usize) -> Array3<u16> {
        let (_, th, tw, c) = atlas.dim();
        Array3::from_shape_fn((h, w, c), |(y, x, ch)| {
            atlas[(map[(y / th, x / tw)] as usize, y % th, x % tw, ch)]
        })
    }

    #[test]
    fn matches_naive_copy_with_cropping() {
        let atlas = Array4::from_shape_fn((5, 4, 3, 2), |(k, y, x, c)| {
            (k * 1000 + y * 100 + x * 10 + c) as u16
        });
        let map = Array2::from_shape_fn((7, 9), |(i, j)| ((i * 7 + j * 3) % 5) as i32);
        for (h, w) in [(28, 27), (25, 20), (1, 1), (17, 26)] {
            let mut out = Array3::zeros((h, w, 2));
            tile_copy_into(atlas.view(), map.view(), out.view_mut()).unwrap();
            assert_eq!(out, naive(&atlas, &map, h, w));
        }
    }

    #[test]
    fn window_matches_crop_of_full_copy() {
        let atlas = Array4::from_shape_fn((5, 4, 3, 2), |(k, y, x, c)| {
            (k * 1000 + y * 100 + x * 10 + c) as u16
        });
        let map = Array2::from_shape_fn((7, 9), |(i, j)| ((i * 7 + j * 3) % 5) as i32);
        let full = naive(&atlas, &map, 28, 27);
        for (oy, ox, h, w) in [
            (0, 0, 28, 27),
            (1, 2, 27, 25),
            (3, 1, 5, 1),
            (2, 2, 1, 1),
            (0, 1, 9, 2),
        ] {
            let mut out = Array3::zeros((h, w, 2));
            tile_copy_window_into(atlas.view(), map.view(), (oy, ox), out.view_mut()).unwrap();
            assert_eq!(out, full.slice(ndarray::s![oy..oy + h, ox..ox + w, ..]));
        }
        let mut out = Array3::zeros((28, 27, 2));
        assert!(tile_copy_window_into(atlas.view(), map.view(), (1, 0), out.view_mut()).is_err());
        assert!(tile_copy_window_into(atlas.view(), map.view(), (0, 3), out.view_mut()).is_err());
    }

    #[test]
    fn thread_count_does_not_matter() {
        let atlas = Array4::from_shape_fn((3, 8, 8, 3), |(k, y, x, c)| {
            (k * 7 + y * 5 + x * 3 + c) as u16
        });
        let map = Array2::from_shape_fn((40, 40), |(i, j)| ((i * 31 + j * 17) % 3) as i32);
        let run = |n| {
            let mut out = Array3::zeros((317, 301, 3));
            crate::parallel::install(Some(n), || {
                tile_copy_into(atlas.view(), map.view(), out.view_mut())
            })
            .unwrap()
            .unwrap();
            out
        };
        assert_eq!(run(1), run(2));
    }

    #[test]
    fn rejects_bad_maps() {
        let atlas = Array4::<u8>::zeros((2, 4, 4, 3));
        let mut out = Array3::<u8>::zeros((8, 8, 3));
        let small = Array2::<i32>::zeros((1, 2));
        let e = tile_copy_into(atlas.view(), small.view(), out.view_mut()).unwrap_err();
        assert!(e.to_string().contains("index_map"), "{e}");
        let bad = Array2::from_elem((2, 2), 2i32);
        let e = tile_copy_into(atlas.view(), bad.view(), out.view_mut()).unwrap_err();
        assert!(e.to_string().contains("[0, 2)"), "{e}");
        let mut out4 = Array3::<u8>::zeros((8, 8, 4));
        let ok = Array2::<i32>::zeros((2, 2));
        assert!(tile_copy_into(atlas.view(), ok.view(), out4.view_mut()).is_err());
    }
}
