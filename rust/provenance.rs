//! Tile sets as provenance: every pixel of a pure-copy tile is an exemplar pixel reached by one of a few affine
//! maps of the tile grid.
//!
//! Pixel `p = (y, x)` of tile `t` comes from exemplar pixel `D_s(p) + b` where `l = labels[t, y, x]` picks the
//! entry `table[t, l] = (s, by, bx)` of the tile's source table: `s` in 0..8 one of the eight symmetries of the
//! square ([`dihedral`]) and `b = (by, bx)` an offset. [`factorise`] finds such a table for a provenance array
//! (greedily, per tile); [`gather_window_into`] lays any window of a tiling by an index map straight from the
//! exemplar (or any pixel-aligned map), without the tiles. Both are pure integer work: the result does not
//! depend on the thread count.

use crate::error::{fmt_shape, Result, TilesynthError};
use ndarray::{Array3, ArrayView2, ArrayView3, ArrayView4, ArrayViewMut3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// The most entries one tile's source table may have (labels are `u8`).
pub const MAX_ENTRIES: usize = 255;

/// How the tangent-space vectors of a normal map turn with an entry's symmetry: a rotated or mirrored copy of
/// a normal map must have its vectors' x and y turned with its pixels, or the relief is lit from the wrong side.
/// A turn only swaps and negates x and y (channels 0 and 1), so it is exact in the samples' own type.
#[derive(Clone, Copy, Debug)]
pub struct VectorTurn<T> {
    /// `sel[s][row] = (channel, negated)`: the new channel `row` (0 = x, 1 = y) of a pixel of symmetry `s` is
    /// the old `channel`, negated or not.
    pub sel: [[(usize, bool); 2]; 8],
    /// The negation of one sample: `max − c` for unsigned codes, `1 − c` for unorm floats, `−c` for snorm.
    pub negate: fn(T) -> T,
}

impl<T: Copy> VectorTurn<T> {
    /// The turn of the matrices `m` `[s][row][col]` (each row exactly one ±1: `tilesynth.builder.matching.
    /// augment.vector_turns`), or an error naming `turns`.
    pub fn new(m: &[[[i8; 2]; 2]; 8], negate: fn(T) -> T) -> Result<VectorTurn<T>> {
        let mut sel = [[(0usize, false); 2]; 8];
        for (s, rows) in m.iter().enumerate() {
            for (r, row) in rows.iter().enumerate() {
                sel[s][r] = match *row {
                    [1, 0] => (0, false),
                    [-1, 0] => (0, true),
                    [0, 1] => (1, false),
                    [0, -1] => (1, true),
                    other => {
                        return Err(TilesynthError::param(
                            "turns",
                            format!("{other:?} (symmetry {s}, row {r})"),
                            "every row of a vector turn must be one of (1, 0), (-1, 0), (0, 1), (0, -1)",
                        ))
                    }
                };
            }
        }
        Ok(VectorTurn { sel, negate })
    }

    /// Turns the first two channels of the pixel `px` in place by symmetry `s`.
    #[inline]
    pub fn apply(&self, s: u8, px: &mut [T]) {
        if s == 0 {
            return;
        }
        let old = [px[0], px[1]];
        for (r, &(ch, neg)) in self.sel[s as usize].iter().enumerate() {
            px[r] = if neg { (self.negate)(old[ch]) } else { old[ch] };
        }
    }
}

/// Symmetry `s` (0..8) of the `n x n` grid applied to `(y, x)`: with `k = s % 4`, `f = s >= 4`, the pixel of
/// `F^f(R^k(P))` at `(y, x)` is `P`'s pixel at the returned position, `R` = `numpy.rot90` (anticlockwise in the
/// (row, col) plane) and `F` the left-right mirror: the numbering of the matching patches' transforms
/// (`tilesynth.builder.matching.augment`), so a transformed patch is one entry.
#[inline]
pub fn dihedral(s: u8, n: usize, y: usize, x: usize) -> (usize, usize) {
    let m = n - 1;
    let x = if s >= 4 { m - x } else { x };
    match s % 4 {
        0 => (y, x),
        1 => (x, m - y),
        2 => (m - y, m - x),
        _ => (m - x, y),
    }
}

/// One tile's factors: its label plane and its table entries `(s, by, bx)`.
type TileFactors = (Vec<u8>, Vec<[i32; 3]>);

/// The labels `(K, N, N)` and source table `(K, L, 3)` (`(s, by, bx)`, rows past a tile's own entries `-1`) of
/// the provenance `source` `(K, N, N, 2)` (exemplar row, col of every tile pixel), or `None` when some tile
/// needs more than [`MAX_ENTRIES`] entries.
///
/// Greedy per tile, in raster order: the first pixel without an entry starts a new one, with the symmetry (and
/// its offset through that pixel) that covers the most pixels still without an entry (ties: the lowest `s`, so
/// untransformed pieces are plain translations). Every pixel then satisfies `source = D_s(p) + b` exactly.
///
/// `orient` `(K, N, N)` (optional): the symmetry every pixel must be given, where it matters beyond geometry:
/// a normal map's vectors turn with the entry's symmetry, and a piece that is one pixel or one line fits
/// several symmetries equally (a single pixel of a rotated patch would otherwise be a translation and keep
/// its vectors unturned). With it, an entry's symmetry is its pixels' `orient`.
pub fn factorise(
    source: ArrayView4<i32>,
    orient: Option<ArrayView3<u8>>,
) -> Result<Option<(Array3<u8>, Array3<i32>)>> {
    let (k, n, n2, two) = source.dim();
    if n != n2 || two != 2 || n == 0 {
        return Err(TilesynthError::shape(
            "source",
            "(K, N, N, 2) with N >= 1",
            fmt_shape(source.shape()),
        ));
    }
    if let Some(o) = &orient {
        if o.dim() != (k, n, n) {
            return Err(TilesynthError::shape(
                "orient",
                format!("({k}, {n}, {n}) (one symmetry per tile pixel)"),
                fmt_shape(o.shape()),
            ));
        }
        if let Some(&bad) = o.iter().find(|&&v| v >= 8) {
            return Err(TilesynthError::param(
                "orient",
                bad,
                "symmetries must be in 0..8",
            ));
        }
    }
    let orient = orient.map(|o| o.as_standard_layout().into_owned());
    let orient = orient
        .as_ref()
        .map(|o| o.as_slice().expect("standard layout"));
    let src = source.as_standard_layout();
    let src = src.as_slice().expect("standard layout");
    let per = n * n;
    let tables: Vec<Option<TileFactors>> = (0..k)
        .into_par_iter()
        .map(|t| {
            let s = &src[t * per * 2..(t + 1) * per * 2];
            let want = orient.map(|o| &o[t * per..(t + 1) * per]);
            // whether pixel p may take symmetry sym
            let allowed = |p: usize, sym: u8| want.map_or(true, |w| w[p] == sym);
            let mut label = vec![u8::MAX; per];
            let mut entries: Vec<[i32; 3]> = Vec::new();
            let mut next = 0usize;
            while next < per {
                if label[next] != u8::MAX {
                    next += 1;
                    continue;
                }
                if entries.len() == MAX_ENTRIES {
                    return None;
                }
                let (y0, x0) = (next / n, next % n);
                let (ry, rx) = (s[2 * next], s[2 * next + 1]);
                let mut best = (0usize, 0u8, 0i32, 0i32);
                for sym in (0..8u8).filter(|&sym| allowed(next, sym)) {
                    let (dy, dx) = dihedral(sym, n, y0, x0);
                    let (by, bx) = (ry - dy as i32, rx - dx as i32);
                    let mut count = 0usize;
                    for p in next..per {
                        if label[p] == u8::MAX && allowed(p, sym) {
                            let (dy, dx) = dihedral(sym, n, p / n, p % n);
                            if s[2 * p] == dy as i32 + by && s[2 * p + 1] == dx as i32 + bx {
                                count += 1;
                            }
                        }
                    }
                    if count > best.0 {
                        best = (count, sym, by, bx);
                    }
                }
                let (_, sym, by, bx) = best;
                let l = entries.len() as u8;
                for p in next..per {
                    if label[p] == u8::MAX && allowed(p, sym) {
                        let (dy, dx) = dihedral(sym, n, p / n, p % n);
                        if s[2 * p] == dy as i32 + by && s[2 * p + 1] == dx as i32 + bx {
                            label[p] = l;
                        }
                    }
                }
                entries.push([sym as i32, by, bx]);
            }
            Some((label, entries))
        })
        .collect();
    let mut width = 1usize;
    for t in &tables {
        match t {
            None => return Ok(None),
            Some((_, e)) => width = width.max(e.len()),
        }
    }
    let mut labels = Array3::<u8>::zeros((k, n, n));
    let mut table = Array3::<i32>::from_elem((k, width, 3), -1);
    for (t, entry) in tables.into_iter().enumerate() {
        let (l, e) = entry.expect("checked above");
        labels
            .slice_mut(ndarray::s![t, .., ..])
            .as_slice_mut()
            .expect("standard layout")
            .copy_from_slice(&l);
        for (j, v) in e.iter().enumerate() {
            for c in 0..3 {
                table[(t, j, c)] = v[c];
            }
        }
    }
    Ok(Some((labels, table)))
}

/// The shapes of a provenance's label planes `(K, N, N)` and source table `(K, L, 3)`, checked once for the
/// gather and the seam blend: `(K, N, L)`.
pub(crate) fn check_tables(
    labels: &ArrayView3<u8>,
    table: &ArrayView3<i32>,
) -> Result<(usize, usize, usize)> {
    let (k, n, n2) = labels.dim();
    let (tk, width, three) = table.dim();
    if n != n2 || n == 0 || k == 0 || tk != k || three != 3 || width == 0 {
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
    Ok((k, n, width))
}

/// Checks a window of `h x w` pixels starting `offset = (oy, ox)` pixels into the first cell of `map`, a tile
/// index map over `k` tiles of `n x n`: the offset inside a cell, the map covering the window, every index a
/// tile. The window checks of [`gather_window_into`] and of the seam blend (`blend::blend_maps`).
pub(crate) fn check_window(
    map: &ArrayView2<i32>,
    k: usize,
    n: usize,
    (h, w): (usize, usize),
    (oy, ox): (usize, usize),
) -> Result<()> {
    if oy >= n || ox >= n {
        return Err(TilesynthError::param(
            "offset",
            format!("({oy}, {ox})"),
            format!("must be below the tile size {n}"),
        ));
    }
    let (rows, cols) = map.dim();
    if rows * n < h + oy || cols * n < w + ox {
        return Err(TilesynthError::shape(
            "index_map",
            format!(
                "at least ({}, {}) tiles to cover the window",
                (h + oy).div_ceil(n),
                (w + ox).div_ceil(n)
            ),
            fmt_shape(map.shape()),
        ));
    }
    if let Some(&bad) = map.iter().find(|&&t| t < 0 || t as usize >= k) {
        return Err(TilesynthError::param(
            "index_map",
            bad,
            format!("tile indices must be in [0, {k})"),
        ));
    }
    Ok(())
}

/// Fills `out` `(H, W, C)` with the window of the tiling by `map` whose top-left pixel is `offset = (oy, ox)`
/// pixels into the map's first cell, reading every pixel from `exemplar` `(EH, EW, C)` through the provenance
/// `labels` `(K, N, N)` / `table` `(K, L, 3)`:
/// `out[y, x] = exemplar[D_s(p) + b]` with `t = map[(y+oy)/N, (x+ox)/N]`, `p = ((y+oy)%N, (x+ox)%N)` and
/// `(s, by, bx) = table[t, labels[t, p]]`. Runs of pixels of one untransformed entry along a tile row are copied
/// as slices. With `turn` (a normal map) the vectors of every pixel of a rotated or mirrored entry are turned
/// with it ([`VectorTurn`]). An entry that is not a symmetry or a source outside the exemplar is an error
/// (nothing is promised about `out` then).
pub fn gather_window_into<T: Copy + Send + Sync>(
    exemplar: ArrayView3<T>,
    labels: ArrayView3<u8>,
    table: ArrayView3<i32>,
    map: ArrayView2<i32>,
    offset: (usize, usize),
    mut out: ArrayViewMut3<T>,
    turn: Option<&VectorTurn<T>>,
) -> Result<()> {
    let (eh, ew, c) = exemplar.dim();
    let (k, n, width) = check_tables(&labels, &table)?;
    if turn.is_some() && c < 2 {
        return Err(TilesynthError::shape(
            "exemplar",
            "(EH, EW, C >= 2) to turn vectors",
            fmt_shape(exemplar.shape()),
        ));
    }
    let (out_h, out_w, out_c) = out.dim();
    if out_c != c {
        return Err(TilesynthError::shape(
            "out",
            format!("(H, W, {c}) (the channels of the exemplar)"),
            fmt_shape(out.shape()),
        ));
    }
    check_window(&map, k, n, (out_h, out_w), offset)?;
    let (oy, ox) = offset;
    let cols = map.ncols();
    if out_h == 0 || out_w == 0 || c == 0 {
        return Ok(());
    }
    let ex = exemplar.as_standard_layout();
    let ex = ex.as_slice().expect("standard layout");
    let lab = labels.as_standard_layout();
    let lab = lab.as_slice().expect("standard layout");
    let tab = table.as_standard_layout();
    let tab = tab.as_slice().expect("standard layout");
    let map = map.as_standard_layout();
    let map = map.as_slice().expect("standard layout");
    let out = out.as_slice_mut().ok_or_else(|| {
        TilesynthError::param("out", "non-contiguous array", "must be C-contiguous")
    })?;
    let bad = AtomicBool::new(false);
    let row_len = out_w * c;
    out.par_chunks_mut(row_len * 8)
        .enumerate()
        .for_each(|(chunk, block)| {
            for (r, dst) in block.chunks_mut(row_len).enumerate() {
                let y = chunk * 8 + r + oy;
                let (ty, py) = (y / n, y % n);
                let mut x = 0usize; // output column
                while x < out_w {
                    let gx = x + ox;
                    let t = map[ty * cols + gx / n] as usize;
                    let px = gx % n;
                    let lrow = &lab[(t * n + py) * n..(t * n + py + 1) * n];
                    let l = lrow[px] as usize;
                    // the run of this entry along the tile row, within the window
                    let mut end = px + 1;
                    let stop = (n).min(px + (out_w - x));
                    while end < stop && lrow[end] as usize == l {
                        end += 1;
                    }
                    let run = end - px;
                    if l >= width {
                        bad.store(true, Ordering::Relaxed);
                        return;
                    }
                    let e = &tab[(t * width + l) * 3..(t * width + l) * 3 + 3];
                    let (sym, by, bx) = (e[0], e[1] as i64, e[2] as i64);
                    if !(0..8).contains(&sym) {
                        bad.store(true, Ordering::Relaxed);
                        return;
                    }
                    let sym = sym as u8;
                    let d = &mut dst[x * c..(x + run) * c];
                    if sym == 0 || sym == 6 {
                        // x maps to x (plus a constant): one slice of the exemplar row
                        let (dy, dx) = dihedral(sym, n, py, px);
                        let (sy, sx) = (dy as i64 + by, dx as i64 + bx);
                        if sy < 0 || sy >= eh as i64 || sx < 0 || sx + run as i64 > ew as i64 {
                            bad.store(true, Ordering::Relaxed);
                            return;
                        }
                        let start = (sy as usize * ew + sx as usize) * c;
                        d.copy_from_slice(&ex[start..start + run * c]);
                    } else {
                        for i in 0..run {
                            let (dy, dx) = dihedral(sym, n, py, px + i);
                            let (sy, sx) = (dy as i64 + by, dx as i64 + bx);
                            if sy < 0 || sy >= eh as i64 || sx < 0 || sx >= ew as i64 {
                                bad.store(true, Ordering::Relaxed);
                                return;
                            }
                            let start = (sy as usize * ew + sx as usize) * c;
                            d[i * c..(i + 1) * c].copy_from_slice(&ex[start..start + c]);
                        }
                    }
                    if let Some(tv) = turn.filter(|_| sym != 0) {
                        d.chunks_exact_mut(c).for_each(|px| tv.apply(sym, px));
                    }
                    x += run;
                }
            }
        });
    if bad.load(Ordering::Relaxed) {
        return Err(TilesynthError::param(
            "table",
            "a provenance entry",
            format!("every entry used must be a symmetry 0..8 whose sources lie inside the {ew}x{eh} exemplar"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array4};

    /// A provenance with three pieces: a translation, a rotated patch in a disc, a mirrored strip.
    fn example(k: usize, n: usize) -> Array4<i32> {
        Array4::from_shape_fn((k, n, n, 2), |(t, y, x, c)| {
            let (sym, by, bx) = if (y as i64 - 4).pow(2) + (x as i64 - 4).pow(2) < 9 {
                ((t % 8) as u8, 3 + t as i32, 5)
            } else if x < 2 {
                (4u8, 1, 2 * t as i32)
            } else {
                (0u8, t as i32, 1)
            };
            let (dy, dx) = dihedral(sym, n, y, x);
            if c == 0 {
                dy as i32 + by
            } else {
                dx as i32 + bx
            }
        })
    }

    #[test]
    fn dihedral_is_a_bijection() {
        for s in 0..8u8 {
            let mut seen = [false; 25];
            for y in 0..5 {
                for x in 0..5 {
                    let (a, b) = dihedral(s, 5, y, x);
                    assert!(!seen[a * 5 + b]);
                    seen[a * 5 + b] = true;
                }
            }
        }
    }

    #[test]
    fn factorise_reproduces_the_source() {
        let src = example(9, 10);
        let (labels, table) = factorise(src.view(), None).unwrap().unwrap();
        assert!(table.dim().1 <= 3, "{:?}", table.dim());
        for t in 0..9 {
            for y in 0..10 {
                for x in 0..10 {
                    let l = labels[(t, y, x)] as usize;
                    let (dy, dx) = dihedral(table[(t, l, 0)] as u8, 10, y, x);
                    assert_eq!(dy as i32 + table[(t, l, 1)], src[(t, y, x, 0)]);
                    assert_eq!(dx as i32 + table[(t, l, 2)], src[(t, y, x, 1)]);
                }
            }
        }
    }

    #[test]
    fn gather_equals_copying_materialised_tiles() {
        let (k, n) = (9, 10);
        let src = example(k, n);
        let ex = Array3::from_shape_fn((30, 40, 2), |(y, x, c)| (y * 1000 + x * 3 + c) as u16);
        let (labels, table) = factorise(src.view(), None).unwrap().unwrap();
        let map = Array2::from_shape_fn((4, 5), |(i, j)| ((i * 5 + j * 2) % k) as i32);
        for (oy, ox, h, w) in [(0, 0, 40, 50), (3, 7, 30, 41), (9, 9, 1, 1), (2, 0, 5, 33)] {
            let mut out = Array3::<u16>::zeros((h, w, 2));
            gather_window_into(
                ex.view(),
                labels.view(),
                table.view(),
                map.view(),
                (oy, ox),
                out.view_mut(),
                None,
            )
            .unwrap();
            for y in 0..h {
                for x in 0..w {
                    let t = map[((y + oy) / n, (x + ox) / n)] as usize;
                    let (py, px) = ((y + oy) % n, (x + ox) % n);
                    let (sy, sx) = (src[(t, py, px, 0)] as usize, src[(t, py, px, 1)] as usize);
                    for c in 0..2 {
                        assert_eq!(out[(y, x, c)], ex[(sy, sx, c)]);
                    }
                }
            }
        }
    }

    #[test]
    fn gather_turns_vectors_with_their_entries() {
        // the quarter turn and the left-right mirror of the vectors, y up: (x, y) -> (-y, x) and (-x, y)
        let mut m = [[[1i8, 0], [0, 1]]; 8];
        m[1] = [[0, -1], [1, 0]];
        m[4] = [[-1, 0], [0, 1]];
        m[2] = [[-1, 0], [0, -1]];
        m[3] = [[0, 1], [-1, 0]];
        m[5] = [[0, 1], [1, 0]];
        m[6] = [[1, 0], [0, -1]];
        m[7] = [[0, -1], [-1, 0]];
        let turn = VectorTurn::new(&m, |c: u8| u8::MAX - c).unwrap();
        let (k, n) = (9, 10);
        let src = example(k, n);
        let ex = Array3::from_shape_fn((30, 40, 3), |(y, x, c)| {
            ((y * 7 + x * 3 + c * 50) % 256) as u8
        });
        let (labels, table) = factorise(src.view(), None).unwrap().unwrap();
        let map = Array2::from_shape_fn((3, 4), |(i, j)| ((i * 4 + j) % k) as i32);
        let (h, w) = (30, 40);
        let gather = |t: Option<&VectorTurn<u8>>| {
            let mut out = Array3::<u8>::zeros((h, w, 3));
            let (l, tb, m) = (labels.view(), table.view(), map.view());
            gather_window_into(ex.view(), l, tb, m, (0, 0), out.view_mut(), t).unwrap();
            out
        };
        let (plain, turned) = (gather(None), gather(Some(&turn)));
        let mut seen = 0;
        for y in 0..h {
            for x in 0..w {
                let t = map[(y / n, x / n)] as usize;
                let s = table[(t, labels[(t, y % n, x % n)] as usize, 0)] as usize;
                let (p, q) = (plain[(y, x, 0)], plain[(y, x, 1)]);
                let pick = |row: [i8; 2]| match row {
                    [1, 0] => p,
                    [-1, 0] => 255 - p,
                    [0, 1] => q,
                    _ => 255 - q,
                };
                assert_eq!(turned[(y, x, 0)], pick(m[s][0]), "({y}, {x}) s {s}");
                assert_eq!(turned[(y, x, 1)], pick(m[s][1]), "({y}, {x}) s {s}");
                assert_eq!(turned[(y, x, 2)], plain[(y, x, 2)]);
                seen += usize::from(s != 0);
            }
        }
        assert!(seen > 0);
        assert!(VectorTurn::new(&[[[1i8, 1], [0, 1]]; 8], |c: u8| c).is_err());
    }

    #[test]
    fn factorise_gives_pixels_their_orientation() {
        // one pixel of a turned patch: a translation fits it as well, the orientation decides
        let one = Array4::from_shape_fn((1, 1, 1, 2), |(_, _, _, c)| [5, 7][c]);
        let (_, t) = factorise(one.view(), None).unwrap().unwrap();
        assert_eq!(t[(0, 0, 0)], 0);
        let o = Array3::from_elem((1, 1, 1), 3u8);
        let (_, t) = factorise(one.view(), Some(o.view())).unwrap().unwrap();
        assert_eq!([t[(0, 0, 0)], t[(0, 0, 1)], t[(0, 0, 2)]], [3, 5, 7]);
        let bad = Array3::from_elem((1, 1, 1), 8u8);
        assert!(factorise(one.view(), Some(bad.view())).is_err());
    }

    #[test]
    fn gather_refuses_sources_outside() {
        let src = example(2, 10);
        let (labels, mut table) = factorise(src.view(), None).unwrap().unwrap();
        table[(0, 0, 1)] = 1000;
        let ex = Array3::<u8>::zeros((30, 40, 1));
        let map = Array2::<i32>::zeros((1, 1));
        let mut out = Array3::<u8>::zeros((10, 10, 1));
        let e = gather_window_into(
            ex.view(),
            labels.view(),
            table.view(),
            map.view(),
            (0, 0),
            out.view_mut(),
            None,
        )
        .unwrap_err();
        assert!(e.to_string().contains("table"), "{e}");
    }
}
