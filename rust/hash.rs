//! The hashed lookup of complete tile sets (`HASH-SPEC.md`, shared bit for bit with the GPU shaders).
//!
//! The colour of every lattice vertex (corner sets) or edge (Wang sets) and the variant of every cell come from
//! `ts_hash(x, y, seed, role)`, the `x` output of pcg3d (Jarzynski & Olano, "Hash Functions for GPU
//! Rendering", JCGT 9(3), 2020) of `(x, y, seed ^ role * 0x9E3779B9)`. All arithmetic is on `u32` with wrapping
//! multiplication and addition, so that GLSL ES 3.0, WGSL and HLSL give the same bits. Lattice coordinates are
//! `i32` taken as their two's complement (`x as u32`); a window that runs past `i32::MAX` continues at
//! `i32::MIN` (wrapping, as the shaders' `uint` arithmetic does).
//!
//! A complete set stores its tiles in the index order of [`Scheme::index`], so the lookup needs no table:
//! - corner, K colours, V variants: `index = (((TL*K + BL)*K + TR)*K + BR)*V + v`;
//! - edge (Wang), Kh horizontal and Kv vertical colours: `index = (((N*Kv + E)*Kh + S)*Kv + W)*V + v`.
//!
//! With `wrap = Some((tx, ty))` every vertex, edge and cell coordinate is reduced Euclidean-mod `(tx, ty)`
//! before hashing, so the texture is periodic with a period of `(tx, ty)` cells.

use crate::error::{try_array, try_collect, Result, TilesynthError};
use ndarray::Array2;
use rayon::prelude::*;

/// The name of the hash, as exports record it.
pub const HASH_NAME: &str = "pcg3d";
/// Multiplier of the LCG step of pcg3d.
pub const PCG_MUL: u32 = 1_664_525;
/// Increment of the LCG step of pcg3d.
pub const PCG_INC: u32 = 1_013_904_223;
/// The role multiplier (the 32-bit golden ratio) mixed into the seed: `seed ^ role * ROLE_MUL`.
pub const ROLE_MUL: u32 = 0x9E37_79B9;
/// Role of a corner lattice vertex colour.
pub const ROLE_VERTEX: u32 = 0;
/// Role of a horizontal edge colour (the N/S edges of cells).
pub const ROLE_HEDGE: u32 = 1;
/// Role of a vertical edge colour (the E/W edges of cells).
pub const ROLE_VEDGE: u32 = 2;
/// Role of a cell variant.
pub const ROLE_VARIANT: u32 = 3;

/// pcg3d of Jarzynski & Olano (2020), wrapping `u32` arithmetic.
#[inline]
pub fn pcg3d(v: [u32; 3]) -> [u32; 3] {
    let [mut x, mut y, mut z] = v.map(|a| a.wrapping_mul(PCG_MUL).wrapping_add(PCG_INC));
    x = x.wrapping_add(y.wrapping_mul(z));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    x ^= x >> 16;
    y ^= y >> 16;
    z ^= z >> 16;
    x = x.wrapping_add(y.wrapping_mul(z));
    y = y.wrapping_add(z.wrapping_mul(x));
    z = z.wrapping_add(x.wrapping_mul(y));
    [x, y, z]
}

/// `ts_hash(x, y, seed, role) = pcg3d(x as u32, y as u32, seed ^ role * ROLE_MUL).x`.
#[inline]
pub fn ts_hash(x: i32, y: i32, seed: u32, role: u32) -> u32 {
    ts_hash_u(x as u32, y as u32, seed, role)
}

/// [`ts_hash`] on coordinates already cast to `u32`.
#[inline]
fn ts_hash_u(x: u32, y: u32, seed: u32, role: u32) -> u32 {
    pcg3d([x, y, seed ^ role.wrapping_mul(ROLE_MUL)])[0]
}

/// A complete tile set's lookup scheme.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// Complete corner set: `k` vertex colours, `v` variants per ⟨TL, BL, TR, BR⟩ tuple (`k^4 * v` tiles).
    Corner {
        /// Vertex colours.
        k: u32,
        /// Variants per tuple.
        v: u32,
    },
    /// Complete edge (Wang) set: `kh` N/S colours, `kv` E/W colours, `v` variants (`kh^2 * kv^2 * v` tiles).
    Edge {
        /// Horizontal-edge (N, S) colours.
        kh: u32,
        /// Vertical-edge (E, W) colours.
        kv: u32,
        /// Variants per tuple.
        v: u32,
    },
}

impl Scheme {
    /// Checks the counts (each >= 1) and that the number of tiles fits an `i32` index.
    pub fn validate(&self) -> Result<()> {
        let (counts, tiles): (&[(&'static str, u32)], u128) = match self {
            Scheme::Corner { k, v } => (&[("k", *k), ("v", *v)], (*k as u128).pow(4) * *v as u128),
            Scheme::Edge { kh, kv, v } => (
                &[("kh", *kh), ("kv", *kv), ("v", *v)],
                (*kh as u128).pow(2) * (*kv as u128).pow(2) * *v as u128,
            ),
        };
        for &(name, n) in counts {
            if n == 0 {
                return Err(TilesynthError::param(name, n, "must be >= 1"));
            }
        }
        if tiles > i32::MAX as u128 {
            return Err(TilesynthError::param(
                "scheme",
                format!("{self:?}"),
                format!("{tiles} tiles do not fit an int32 tile index"),
            ));
        }
        Ok(())
    }

    /// The number of tiles of the complete set.
    pub fn n_tiles(&self) -> u64 {
        match *self {
            Scheme::Corner { k, v } => (k as u64).pow(4) * v as u64,
            Scheme::Edge { kh, kv, v } => (kh as u64).pow(2) * (kv as u64).pow(2) * v as u64,
        }
    }

    /// Tile index of a corner tuple `(tl, bl, tr, br)` (or an edge tuple `(n, e, s, w)`) and variant `var`.
    #[inline]
    pub fn index(&self, t: [u32; 4], var: u32) -> u32 {
        match *self {
            Scheme::Corner { k, v } => (((t[0] * k + t[1]) * k + t[2]) * k + t[3]) * v + var,
            Scheme::Edge { kh, kv, v } => (((t[0] * kv + t[1]) * kh + t[2]) * kv + t[3]) * v + var,
        }
    }
}

/// Reduces a wrapped lattice coordinate: `c` Euclidean-mod `period` when wrapping, else `c` as `u32`.
#[inline]
fn reduce(c: i64, period: Option<u32>) -> u32 {
    match period {
        Some(p) => c.rem_euclid(p as i64) as u32,
        // Two's complement of the coordinate taken mod 2^32 (a window may run past i32::MAX).
        None => c as u32,
    }
}

/// The tile index of cell `(cx, cy)` (any `i64`; taken mod 2^32, or mod the wrap period).
#[inline]
pub fn cell_index(scheme: Scheme, seed: u32, cx: i64, cy: i64, wrap: Option<(u32, u32)>) -> u32 {
    let (px, py) = (wrap.map(|w| w.0), wrap.map(|w| w.1));
    let (x0, x1) = (reduce(cx, px), reduce(cx + 1, px));
    let (y0, y1) = (reduce(cy, py), reduce(cy + 1, py));
    match scheme {
        Scheme::Corner { k, v } => {
            let c = |x, y| ts_hash_u(x, y, seed, ROLE_VERTEX) % k;
            let var = ts_hash_u(x0, y0, seed, ROLE_VARIANT) % v;
            scheme.index([c(x0, y0), c(x0, y1), c(x1, y0), c(x1, y1)], var)
        }
        Scheme::Edge { kh, kv, v } => {
            let h = |x, y| ts_hash_u(x, y, seed, ROLE_HEDGE) % kh;
            let e = |x, y| ts_hash_u(x, y, seed, ROLE_VEDGE) % kv;
            let var = ts_hash_u(x0, y0, seed, ROLE_VARIANT) % v;
            scheme.index([h(x0, y0), e(x1, y0), h(x0, y1), e(x0, y0)], var)
        }
    }
}

/// Checks a window: origin cells in the `i32` range, wrap periods >= 1.
fn check_window(cx0: i64, cy0: i64, wrap: Option<(u32, u32)>) -> Result<()> {
    for (name, c) in [("cx0", cx0), ("cy0", cy0)] {
        if c < i32::MIN as i64 || c > i32::MAX as i64 {
            return Err(TilesynthError::param(
                name,
                c,
                "the origin cell must be in [-2^31, 2^31)",
            ));
        }
    }
    if let Some((tx, ty)) = wrap {
        if tx == 0 || ty == 0 {
            return Err(TilesynthError::param(
                "wrap",
                format!("({tx}, {ty})"),
                "the wrap period must be >= 1 cell in each direction",
            ));
        }
    }
    Ok(())
}

/// The `(rows, cols)` index map of the window of cells `cx0 .. cx0 + cols`, `cy0 .. cy0 + rows`.
///
/// Each vertex (edge) colour is hashed once per map row pair rather than four (two) times per cell; the rows are
/// filled in parallel and the result does not depend on the thread count.
pub fn index_map(
    scheme: Scheme,
    seed: u32,
    cx0: i64,
    cy0: i64,
    rows: usize,
    cols: usize,
    wrap: Option<(u32, u32)>,
) -> Result<Array2<i32>> {
    scheme.validate()?;
    check_window(cx0, cy0, wrap)?;
    let mut map = try_array("rows", (rows, cols), 0i32)?;
    if rows == 0 || cols == 0 {
        return Ok(map);
    }
    let (px, py) = (wrap.map(|w| w.0), wrap.map(|w| w.1));
    let xs: Vec<u32> = try_collect(
        "cols",
        cols + 1,
        (0..=cols as i64).map(|j| reduce(cx0 + j, px)),
    )?;
    let slice = map.as_slice_mut().expect("standard layout");
    slice.par_chunks_mut(cols).enumerate().for_each(|(i, row)| {
        let y0 = reduce(cy0 + i as i64, py);
        let y1 = reduce(cy0 + i as i64 + 1, py);
        match scheme {
            Scheme::Corner { k, v } => {
                let c = |x, y| ts_hash_u(x, y, seed, ROLE_VERTEX) % k;
                let (mut tl, mut bl) = (c(xs[0], y0), c(xs[0], y1));
                for (j, out) in row.iter_mut().enumerate() {
                    let (tr, br) = (c(xs[j + 1], y0), c(xs[j + 1], y1));
                    let var = ts_hash_u(xs[j], y0, seed, ROLE_VARIANT) % v;
                    *out = scheme.index([tl, bl, tr, br], var) as i32;
                    (tl, bl) = (tr, br);
                }
            }
            Scheme::Edge { kh, kv, v } => {
                let e = |x, y| ts_hash_u(x, y, seed, ROLE_VEDGE) % kv;
                let mut w = e(xs[0], y0);
                for (j, out) in row.iter_mut().enumerate() {
                    let n = ts_hash_u(xs[j], y0, seed, ROLE_HEDGE) % kh;
                    let s = ts_hash_u(xs[j], y1, seed, ROLE_HEDGE) % kh;
                    let east = e(xs[j + 1], y0);
                    let var = ts_hash_u(xs[j], y0, seed, ROLE_VARIANT) % v;
                    *out = scheme.index([n, east, s, w], var) as i32;
                    w = east;
                }
            }
        }
    });
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// pcg3d written out once more, with explicit `u64` products reduced mod 2^32 (an independent oracle).
    fn pcg3d_u64(v: [u32; 3]) -> [u32; 3] {
        let m = |a: u64| a % (1u64 << 32);
        let mut a = v.map(|c| m(c as u64 * 1_664_525 + 1_013_904_223));
        a[0] = m(a[0] + a[1] * a[2]);
        a[1] = m(a[1] + a[2] * a[0]);
        a[2] = m(a[2] + a[0] * a[1]);
        for c in a.iter_mut() {
            *c ^= *c >> 16;
        }
        a[0] = m(a[0] + a[1] * a[2]);
        a[1] = m(a[1] + a[2] * a[0]);
        a[2] = m(a[2] + a[0] * a[1]);
        a.map(|c| c as u32)
    }

    const COORDS: [i32; 7] = [0, 1, -1, i32::MAX, i32::MIN, 12345, -54321];
    const SEEDS: [u32; 4] = [0, 1, u32::MAX, 0xDEAD_BEEF];

    #[test]
    fn pcg3d_matches_u64_oracle() {
        for &x in &COORDS {
            for &y in &COORDS {
                for &s in &SEEDS {
                    let v = [x as u32, y as u32, s];
                    assert_eq!(pcg3d(v), pcg3d_u64(v));
                    for role in 0..4u32 {
                        let z = (s as u64 ^ ((role as u64 * 0x9E37_79B9) % (1 << 32))) as u32;
                        assert_eq!(
                            ts_hash(x, y, s, role),
                            pcg3d_u64([x as u32, y as u32, z])[0]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn known_value() {
        // pcg3d(0, 0, 0): every component starts at 1013904223 (computed by hand with the u64 oracle).
        assert_eq!(pcg3d([0, 0, 0]), pcg3d_u64([0, 0, 0]));
        assert_ne!(ts_hash(0, 0, 0, 0), ts_hash(0, 0, 0, 1));
        assert_ne!(ts_hash(0, 0, 0, 0), ts_hash(1, 0, 0, 0));
    }

    #[test]
    fn map_matches_cell_index_and_shared_vertices() {
        for scheme in [
            Scheme::Corner { k: 3, v: 2 },
            Scheme::Corner { k: 2, v: 1 },
            Scheme::Edge { kh: 2, kv: 3, v: 2 },
        ] {
            for (cx0, cy0) in [
                (0i64, 0i64),
                (-3, 5),
                (i32::MAX as i64 - 2, i32::MIN as i64),
            ] {
                let m = index_map(scheme, 77, cx0, cy0, 6, 7, None).unwrap();
                for ((i, j), &t) in m.indexed_iter() {
                    let want = cell_index(scheme, 77, cx0 + j as i64, cy0 + i as i64, None);
                    assert_eq!(t as u32, want);
                    assert!((t as u64) < scheme.n_tiles());
                }
            }
        }
        // Neighbouring corner tiles agree on their shared vertices.
        let (k, v) = (3u32, 2u32);
        let m = index_map(Scheme::Corner { k, v }, 5, -4, -4, 9, 9, None).unwrap();
        let tuple = |t: i32| {
            let t = t as u32 / v;
            [t / (k * k * k), (t / (k * k)) % k, (t / k) % k, t % k]
        };
        for i in 0..9 {
            for j in 0..8 {
                let (a, b) = (tuple(m[(i, j)]), tuple(m[(i, j + 1)]));
                assert_eq!((a[2], a[3]), (b[0], b[1]));
            }
        }
    }

    #[test]
    fn sub_windows_agree_and_wrap_is_periodic() {
        let s = Scheme::Edge { kh: 3, kv: 2, v: 3 };
        let big = index_map(s, 9, -10, -7, 20, 30, None).unwrap();
        let small = index_map(s, 9, -3, 2, 5, 6, None).unwrap();
        assert_eq!(small, big.slice(ndarray::s![9..14, 7..13]));
        let w = Some((4u32, 3u32));
        let base = index_map(s, 9, 0, 0, 3, 4, w).unwrap();
        let far = index_map(s, 9, -8, 6, 6, 8, w).unwrap();
        for ((i, j), &t) in far.indexed_iter() {
            assert_eq!(t, base[(i % 3, j % 4)]);
        }
    }

    #[test]
    fn thread_count_does_not_matter() {
        let s = Scheme::Corner { k: 4, v: 3 };
        let run = |n| crate::parallel::install(Some(n), || index_map(s, 3, -50, 20, 64, 33, None));
        assert_eq!(run(1).unwrap().unwrap(), run(2).unwrap().unwrap());
    }

    #[test]
    fn rejects_bad_parameters() {
        let e = index_map(Scheme::Corner { k: 0, v: 1 }, 0, 0, 0, 1, 1, None).unwrap_err();
        assert!(e.to_string().contains("k = 0"), "{e}");
        let e = index_map(Scheme::Corner { k: 216, v: 1 }, 0, 0, 0, 1, 1, None).unwrap_err();
        assert!(e.to_string().contains("int32"), "{e}");
        let e = index_map(Scheme::Corner { k: 2, v: 1 }, 0, 1 << 31, 0, 1, 1, None).unwrap_err();
        assert!(e.to_string().contains("cx0"), "{e}");
        let e = index_map(Scheme::Corner { k: 2, v: 1 }, 0, 0, 0, 1, 1, Some((0, 2))).unwrap_err();
        assert!(e.to_string().contains("wrap"), "{e}");
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::{index_map, Scheme};
    use crate::error::{assert_alloc_error, HUGE_SIDE};

    /// A hashed index map too large to allocate is an error naming `rows`, not an abort.
    #[test]
    fn a_map_that_cannot_be_allocated_is_an_error() {
        let scheme = Scheme::Corner { k: 2, v: 1 };
        assert_alloc_error(
            index_map(scheme, 1, 0, 0, HUGE_SIDE, HUGE_SIDE, None),
            "rows",
        );
        assert_eq!(
            index_map(scheme, 1, 0, 0, 2, 3, None).unwrap().dim(),
            (2, 3)
        );
    }
}
