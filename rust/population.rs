//! Population evaluation of ω-tile gene vectors: the objective of the selection papers (000, 003), exact, for
//! many individuals at once, with the per-patch SSD maps cached across calls.
//!
//! ## The objective
//!
//! A gene vector `A` holds `n` top-left positions `(row, col)` of `N x N` patches of the exemplar `I`
//! (`(H, W, C)`); a tile set names, for each of its `m` tiles, the gene indices of the tile's
//! `⟨TL, BL, TR, BR⟩` patches. Intermediate tile `T_j` (`N x N`) takes its TL quadrant from the bottom-right
//! quarter of the TL patch, its BL quadrant from the top-right quarter of the BL patch, its TR quadrant from
//! the bottom-left quarter of the TR patch and its BR quadrant from the top-left quarter of the BR patch
//! (see `tilesynth.builder.omega`). Then
//!
//! ```text
//! C_j(t) = sum_{p, c} (T_j(p, c) - I(p + t, c))^2        t in [0, H - N] x [0, W - N]
//! D_j    = min_t C_j(t)               (normalise: min_t C_j(t) / (N N))
//! E(A)   = lambda sum_j D_j + (1 - lambda) Var(D_1..D_m)   (population variance)
//! ```
//!
//! ## How it is computed
//!
//! The SSD is additive over the four quadrants, and each quadrant is one of `4 n` *pieces* (`N/2 x N/2`
//! sub-images of the exemplar, one per (gene position, role)). With `P_q` the SSD map of piece `q` over every
//! translation of the exemplar, `C_j(t) = sum_q P_q(t + off_q)`, where `off_q` is the quadrant's place in
//! the tile (`(0, 0)` TL, `(N/2, 0)` BL, `(0, N/2)` TR, `(N/2, N/2)` BR). Each needed `P_q` restricted to
//! the `(H - N + 1) x (W - N + 1)` window the tile can use (a *partial map*) comes from the FFT kernel
//! ([`SsdIndex::ssd_map_f64`], `f64`, with an absolute error bound) and is cached across calls, keyed by
//! `(row, col, role)` of the gene: a genetic algorithm changes few genes per generation, so most maps are
//! reused. The cache is bounded in bytes (least recently used maps are dropped first).
//! The distinct tiles of one call are evaluated in batches whose partial maps fit a quarter of that limit
//! (at least one tile), so the maps alive at any time stay within about 1.25 times the limit however
//! large the population (holding every map of a first generation at once took 1.0-1.6 GB at 512² with
//! 128-px tiles).
//!
//! Per tile the remaining work is the sum of four contiguous `f64` maps and their minimum, a tight loop
//! compiled for AVX2 when the CPU has it (no FMA; the same operations in the same order as the portable
//! path, so results are bit-identical on either). Identical tiles (same four positions) within one call are
//! evaluated once.
//!
//! ## Exactness
//!
//! Each partial map satisfies `|F_q(t) - E_q(t)| <= B_q` against the exact quadrant SSD `E_q`, so the
//! summed map `F` is within `B = sum_q B_q` (plus the rounding of three additions of non-negative numbers,
//! accounted for by a relative slack) of the exact `C_j`. With `f0 = min_t F(t)` every translation whose `F`
//! is at most `f0 + 2B` is a candidate (the exact minimiser must be one: `F(t*) <= C_j(t*) + B <=
//! C_j(t0) + B <= f0 + 2B`); candidates are taken in increasing `F` and re-evaluated by the direct `f64`
//! sum over the assembled tile (fixed order) until `F(t) - B` exceeds the best exact value found. So `D_j`
//! is the exact minimum (the direct `f64` sum at the exact minimiser), never an FFT value, and it does not
//! depend on the cache state or the number of threads. In practice one direct sum per tile is needed (more
//! only on exact or 1e-12-relative ties, e.g. flat exemplars, where all tied translations are summed).
//!
//! ## Parallelism and determinism
//!
//! Missing partial maps are computed in parallel (each independently); tiles are evaluated in parallel over
//! (individual, tile) items, each item's value a pure function of its four positions; `E` is summed in a
//! fixed order. Outputs are bit-identical at any thread count and any cache size.

use crate::error::{
    fmt_shape, try_array, try_collect, try_vec, try_with_capacity, Result, TilesynthError,
};
#[cfg(any(test, feature = "oracles"))]
use crate::ssd::ssd_map_brute;
use crate::ssd::SsdIndex;
#[cfg(any(test, feature = "oracles"))]
use ndarray::Array3;
use ndarray::{s, Array2, ArrayView2, ArrayView3};
use rayon::prelude::*;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::sync::{Arc, Mutex};

/// Default byte limit of the partial-map cache (256 MiB).
pub const DEFAULT_CACHE_BYTES: usize = 256 << 20;
/// Default `lambda` of `E = lambda sum D + (1 - lambda) Var(D)` (paper 000).
pub const DEFAULT_LAMBDA: f64 = 0.8;
/// Bookkeeping bytes charged per cache entry on top of its map.
const ENTRY_OVERHEAD: usize = 96;

/// Where each role's quarter lies inside its patch, `(dy, dx)` in units of `N/2`: TL, BL, TR, BR.
const PATCH_OFF: [(usize, usize); 4] = [(1, 1), (0, 1), (1, 0), (0, 0)];
/// Where each role's quadrant lies inside the tile, `(dy, dx)` in units of `N/2`: TL, BL, TR, BR.
const TILE_OFF: [(usize, usize); 4] = [(0, 0), (1, 0), (0, 1), (1, 1)];

/// Counters of the partial-map cache (see [`PopulationEvaluator::cache_stats`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CacheStats {
    /// Partial maps currently kept.
    pub entries: usize,
    /// Bytes charged for them (map data plus a fixed overhead per entry).
    pub bytes: usize,
    /// The byte limit.
    pub limit: usize,
    /// Lookups served from the cache (one per distinct `(row, col, role)` needed by a call).
    pub hits: u64,
    /// Lookups that had to compute the map.
    pub misses: u64,
}

/// One cached partial map: the FFT SSD map of one piece over the translation window of its role,
/// `(H - N + 1) x (W - N + 1)` row-major, and its absolute error bound.
struct PartialMap {
    data: Vec<f64>,
    bound: f64,
}

/// `(gene row, gene col, role)`.
type Key = (usize, usize, u8);
/// The four gene positions of a tile, in role order TL, BL, TR, BR.
type Tuple = [(usize, usize); 4];

struct Cache {
    maps: HashMap<Key, (Arc<PartialMap>, u64)>,
    lru: BTreeMap<u64, Key>,
    tick: u64,
    bytes: usize,
    limit: usize,
    hits: u64,
    misses: u64,
}

impl Cache {
    fn touch(&mut self, key: Key) -> Option<Arc<PartialMap>> {
        self.tick += 1;
        let tick = self.tick;
        let (map, t) = self.maps.get_mut(&key)?;
        self.lru.remove(t);
        *t = tick;
        self.lru.insert(tick, key);
        Some(Arc::clone(map))
    }

    fn insert(&mut self, key: Key, map: Arc<PartialMap>, entry_bytes: usize) {
        if self.maps.contains_key(&key) {
            // Computed concurrently by another call: keep the existing one (identical values).
            self.touch(key);
            return;
        }
        self.tick += 1;
        self.lru.insert(self.tick, key);
        self.maps.insert(key, (map, self.tick));
        self.bytes += entry_bytes;
    }

    fn evict(&mut self, entry_bytes: usize) {
        while self.bytes > self.limit {
            let Some((_, key)) = self.lru.pop_first() else {
                break;
            };
            self.maps.remove(&key);
            self.bytes -= entry_bytes;
        }
    }
}

/// The validated problem: exemplar, tile size and tile set.
struct Problem {
    h: usize,
    w: usize,
    c: usize,
    /// The exemplar, `(H, W, C)` C-contiguous.
    image: Vec<f32>,
    /// The same in `f64` (the direct sums read it without conversions).
    image64: Vec<f64>,
    /// Tile size `N` (even) and `N/2`.
    n: usize,
    half: usize,
    /// Gene indices of every tile, TL, BL, TR, BR.
    tiles: Vec<[usize; 4]>,
    n_patches: usize,
    lambda: f64,
    normalise: bool,
}

impl Problem {
    fn new(
        exemplar: ArrayView3<f32>,
        tile_size: usize,
        tile_patches: ArrayView2<i64>,
        n_patches: usize,
        lambda: f64,
        normalise: bool,
    ) -> Result<Problem> {
        let (h, w, c) = exemplar.dim();
        if h == 0 || w == 0 || c == 0 {
            return Err(TilesynthError::shape(
                "exemplar",
                "(H, W, C) with H, W, C >= 1",
                fmt_shape(exemplar.shape()),
            ));
        }
        let image: Vec<f32> = try_collect("exemplar", h * w * c, exemplar.iter().copied())?;
        if let Some(i) = image.iter().position(|v| !v.is_finite()) {
            return Err(TilesynthError::param(
                "exemplar",
                image[i],
                format!("all values must be finite (found at flat index {i})"),
            ));
        }
        if tile_size < 2 || tile_size % 2 != 0 {
            return Err(TilesynthError::param(
                "tile_size",
                tile_size,
                "must be even and >= 2 (the tile is cut from the centre of a 2x2 block of patches)",
            ));
        }
        if tile_size > h || tile_size > w {
            return Err(TilesynthError::param(
                "tile_size",
                tile_size,
                format!("larger than the exemplar ({h} rows, {w} columns)"),
            ));
        }
        if n_patches == 0 {
            return Err(TilesynthError::param("n_patches", 0, "must be >= 1"));
        }
        let (m, four) = tile_patches.dim();
        if m == 0 || four != 4 {
            return Err(TilesynthError::shape(
                "tile_patches",
                "(m, 4) with m >= 1 (gene indices of TL, BL, TR, BR)",
                fmt_shape(tile_patches.shape()),
            ));
        }
        let mut tiles = try_with_capacity("tile_patches", m)?;
        for j in 0..m {
            let mut t = [0usize; 4];
            for (q, slot) in t.iter_mut().enumerate() {
                let v = tile_patches[[j, q]];
                if v < 0 || v as u64 >= n_patches as u64 {
                    return Err(TilesynthError::param(
                        "tile_patches",
                        format!("{v} at [{j}, {q}]"),
                        format!("gene indices must lie in [0, n_patches) = [0, {n_patches})"),
                    ));
                }
                *slot = v as usize;
            }
            tiles.push(t);
        }
        if !(0.0..=1.0).contains(&lambda) {
            return Err(TilesynthError::param("lam", lambda, "must lie in [0, 1]"));
        }
        let image64 = try_collect("exemplar", image.len(), image.iter().map(|&v| v as f64))?;
        Ok(Problem {
            h,
            w,
            c,
            image,
            image64,
            n: tile_size,
            half: tile_size / 2,
            tiles,
            n_patches,
            lambda,
            normalise,
        })
    }

    /// Translation window of a tile: `(H - N + 1, W - N + 1)`.
    fn window(&self) -> (usize, usize) {
        (self.h - self.n + 1, self.w - self.n + 1)
    }

    /// Validates `(P, n, 2)` genes and returns the positions, `P * n` in order.
    fn positions(&self, genes: ArrayView3<i64>) -> Result<Vec<(usize, usize)>> {
        let (p, n, two) = genes.dim();
        if n != self.n_patches || two != 2 {
            return Err(TilesynthError::shape(
                "genes",
                format!(
                    "(P, {}, 2) (top-left row, col of every patch)",
                    self.n_patches
                ),
                fmt_shape(genes.shape()),
            ));
        }
        let (rmax, cmax) = (self.h - self.n, self.w - self.n);
        let mut out = try_with_capacity("genes", p * n)?;
        for i in 0..p {
            for g in 0..n {
                let (r, c) = (genes[[i, g, 0]], genes[[i, g, 1]]);
                if r < 0 || c < 0 || r as u64 > rmax as u64 || c as u64 > cmax as u64 {
                    return Err(TilesynthError::param(
                        "genes",
                        format!("({r}, {c}) at [{i}, {g}]"),
                        format!(
                            "the patch must lie inside the exemplar (row in [0, {rmax}], col in [0, {cmax}])"
                        ),
                    ));
                }
                out.push((r as usize, c as usize));
            }
        }
        Ok(out)
    }

    /// `E` of every individual from `D` (`P x m`, already normalised if asked).
    fn energies(&self, d: &Array2<f64>) -> Vec<f64> {
        let m = self.tiles.len() as f64;
        d.rows()
            .into_iter()
            .map(|row| {
                let sum: f64 = row.iter().sum();
                let mean = sum / m;
                let var = row.iter().map(|&x| (x - mean) * (x - mean)).sum::<f64>() / m;
                self.lambda * sum + (1.0 - self.lambda) * var
            })
            .collect()
    }

    /// The scale applied to the minimum: `1 / (N N)` when normalising.
    fn scale(&self, d: f64) -> f64 {
        if self.normalise {
            d / (self.n * self.n) as f64
        } else {
            d
        }
    }

    /// Direct `f64` SSD of the tile with these four positions at translation `(ty, tx)` (fixed order).
    fn exact(&self, pos: &Tuple, ty: usize, tx: usize) -> f64 {
        let hf = self.half;
        let mut rows = [(0usize, 0usize); 4];
        for (q, &(gr, gc)) in pos.iter().enumerate() {
            let (pr, pc) = (gr + PATCH_OFF[q].0 * hf, gc + PATCH_OFF[q].1 * hf);
            let (ir, ic) = (ty + TILE_OFF[q].0 * hf, tx + TILE_OFF[q].1 * hf);
            rows[q] = ((pr * self.w + pc) * self.c, (ir * self.w + ic) * self.c);
        }
        simd::quad_ssd(&self.image64, self.w * self.c, hf, hf * self.c, &rows)
    }
}

/// The two hot loops, compiled for AVX2 (without FMA) when available and portable otherwise. Both builds
/// perform the same IEEE operations in the same order, so they give identical bits.
mod simd {
    /// Independent accumulators of the direct sum (the final fold has a fixed order).
    const LANES: usize = 16;

    /// `sum (img[a + y s + i] - img[b + y s + i])^2` over `y < rows`, `i < len`, for the four `(a, b)` of
    /// `starts` (stride `s`), in a fixed order: lanes by `i mod 16`, a 4-wide tail, a scalar tail.
    #[inline(always)]
    fn quad_body(
        img: &[f64],
        stride: usize,
        rows: usize,
        len: usize,
        starts: &[(usize, usize); 4],
    ) -> f64 {
        let mut acc = [0.0f64; LANES];
        let mut tail = [0.0f64; 4];
        let mut last = 0.0f64;
        for &(a0, b0) in starts {
            for y in 0..rows {
                let a = &img[a0 + y * stride..][..len];
                let b = &img[b0 + y * stride..][..len];
                let mut ac = a.chunks_exact(LANES);
                let mut bc = b.chunks_exact(LANES);
                for (x, z) in (&mut ac).zip(&mut bc) {
                    for l in 0..LANES {
                        let d = x[l] - z[l];
                        acc[l] += d * d;
                    }
                }
                let (ar, br) = (ac.remainder(), bc.remainder());
                let mut a4 = ar.chunks_exact(4);
                let mut b4 = br.chunks_exact(4);
                for (x, z) in (&mut a4).zip(&mut b4) {
                    for l in 0..4 {
                        let d = x[l] - z[l];
                        tail[l] += d * d;
                    }
                }
                for (&x, &z) in a4.remainder().iter().zip(b4.remainder()) {
                    let d = x - z;
                    last += d * d;
                }
            }
        }
        let mut n = LANES;
        while n > 1 {
            n /= 2;
            for i in 0..n {
                acc[i] += acc[i + n];
            }
        }
        acc[0] + ((tail[0] + tail[2]) + (tail[1] + tail[3])) + last
    }

    /// `out = ((a + b) + c) + d` elementwise; returns `min(out)` (`+inf` when empty).
    #[inline(always)]
    fn sum4_min_body(a: &[f64], b: &[f64], c: &[f64], d: &[f64], out: &mut [f64]) -> f64 {
        const L: usize = 8;
        let n = out.len();
        let (a, b, c, d) = (&a[..n], &b[..n], &c[..n], &d[..n]);
        let mut mins = [f64::INFINITY; L];
        let full = n - n % L;
        for k in (0..full).step_by(L) {
            let (a, b, c, d) = (&a[k..k + L], &b[k..k + L], &c[k..k + L], &d[k..k + L]);
            let o = &mut out[k..k + L];
            for l in 0..L {
                let v = ((a[l] + b[l]) + c[l]) + d[l];
                o[l] = v;
                mins[l] = if v < mins[l] { v } else { mins[l] };
            }
        }
        for k in full..n {
            let v = ((a[k] + b[k]) + c[k]) + d[k];
            out[k] = v;
            mins[0] = if v < mins[0] { v } else { mins[0] };
        }
        mins.iter()
            .fold(f64::INFINITY, |m, &v| if v < m { v } else { m })
    }

    /// Pushes `(v, i)` for every `v = values[i] <= limit` (in index order).
    #[inline(always)]
    fn below_body(values: &[f64], limit: f64, out: &mut Vec<(f64, usize)>) {
        const L: usize = 8;
        for (k, chunk) in values.chunks(L).enumerate() {
            if chunk.iter().fold(false, |any, &v| any | (v <= limit)) {
                for (l, &v) in chunk.iter().enumerate() {
                    if v <= limit {
                        out.push((v, k * L + l));
                    }
                }
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn below_avx2(values: &[f64], limit: f64, out: &mut Vec<(f64, usize)>) {
        below_body(values, limit, out)
    }

    #[inline]
    pub(super) fn below(values: &[f64], limit: f64, out: &mut Vec<(f64, usize)>) {
        #[cfg(target_arch = "x86_64")]
        if has_avx2() {
            // SAFETY: the CPU supports AVX2 (checked at run time).
            return unsafe { below_avx2(values, limit, out) };
        }
        below_body(values, limit, out)
    }

    #[cfg(target_arch = "x86_64")]
    fn has_avx2() -> bool {
        use std::sync::OnceLock;
        static AVX2: OnceLock<bool> = OnceLock::new();
        *AVX2.get_or_init(|| std::arch::is_x86_feature_detected!("avx2"))
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn quad_avx2(
        img: &[f64],
        stride: usize,
        rows: usize,
        len: usize,
        starts: &[(usize, usize); 4],
    ) -> f64 {
        quad_body(img, stride, rows, len, starts)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn sum4_min_avx2(a: &[f64], b: &[f64], c: &[f64], d: &[f64], out: &mut [f64]) -> f64 {
        sum4_min_body(a, b, c, d, out)
    }

    /// See [`quad_body`].
    #[inline]
    pub(super) fn quad_ssd(
        img: &[f64],
        stride: usize,
        rows: usize,
        len: usize,
        starts: &[(usize, usize); 4],
    ) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if has_avx2() {
            // SAFETY: the CPU supports AVX2 (checked at run time).
            return unsafe { quad_avx2(img, stride, rows, len, starts) };
        }
        quad_body(img, stride, rows, len, starts)
    }

    #[inline]
    pub(super) fn sum4_min(a: &[f64], b: &[f64], c: &[f64], d: &[f64], out: &mut [f64]) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if has_avx2() {
            // SAFETY: the CPU supports AVX2 (checked at run time).
            return unsafe { sum4_min_avx2(a, b, c, d, out) };
        }
        sum4_min_body(a, b, c, d, out)
    }

    #[cfg(test)]
    pub(super) fn portable_quad(
        img: &[f64],
        stride: usize,
        rows: usize,
        len: usize,
        starts: &[(usize, usize); 4],
    ) -> f64 {
        quad_body(img, stride, rows, len, starts)
    }

    #[cfg(test)]
    pub(super) fn portable_sum4(
        a: &[f64],
        b: &[f64],
        c: &[f64],
        d: &[f64],
        out: &mut [f64],
    ) -> f64 {
        sum4_min_body(a, b, c, d, out)
    }

    #[cfg(test)]
    pub(super) fn portable_below(values: &[f64], limit: f64, out: &mut Vec<(f64, usize)>) {
        below_body(values, limit, out)
    }
}

/// Evaluates the ω-tile objective `E` (and every `D_j`) for whole populations of gene vectors against one
/// exemplar and one tile set, exactly, with the partial SSD maps of every (gene position, role) cached across
/// calls (see the [module documentation](self)). `Send + Sync`: calls may run concurrently.
pub struct PopulationEvaluator {
    prob: Problem,
    /// One FFT index per role, of the sub-image that role's quadrant can cover (see [`PopulationEvaluator::new`]).
    indices: Vec<SsdIndex>,
    cache: Mutex<Cache>,
}

impl PopulationEvaluator {
    /// Prepares the evaluation of gene vectors of `n_patches` patches of size `tile_size` (`N`, even,
    /// `2 <= N <= min(H, W)`) against `exemplar` `(H, W, C)` (finite values) for the tile set
    /// `tile_patches` `(m, 4)` (gene indices in `[0, n_patches)` of each tile's TL, BL, TR, BR patch,
    /// `m >= 1`). `lambda` in `[0, 1]` weighs `E = lambda sum D + (1 - lambda) Var(D)`; `normalise` divides
    /// every `C_j` by `N N`; `cache_bytes` bounds the memory the partial-map cache keeps between calls
    /// (0 keeps nothing; [`DEFAULT_CACHE_BYTES`] is a good default). Builds the exemplar's FFT index.
    pub fn new(
        exemplar: ArrayView3<f32>,
        tile_size: usize,
        tile_patches: ArrayView2<i64>,
        n_patches: usize,
        lambda: f64,
        normalise: bool,
        cache_bytes: usize,
    ) -> Result<Self> {
        let prob = Problem::new(
            exemplar,
            tile_size,
            tile_patches,
            n_patches,
            lambda,
            normalise,
        )?;
        let view = ArrayView3::from_shape((prob.h, prob.w, prob.c), &prob.image[..])
            .expect("image length matches its shape");
        // A role's quadrant sits at a fixed offset `off_q` in the tile, and the tile only moves over the
        // `(H - N + 1) x (W - N + 1)` translations, so the quadrant only ever covers the
        // `(H - N/2) x (W - N/2)` sub-image at `off_q`. The partial map of a piece is its full SSD map over
        // that sub-image (exactly the window, nothing to cut away), and the FFT is over the sub-image, not
        // the whole exemplar: (H - N/2)(W - N/2) points instead of HW (0.47x for 128/80).
        let hf = prob.half;
        let indices = TILE_OFF
            .iter()
            .map(|&(dy, dx)| {
                let (oy, ox) = (dy * hf, dx * hf);
                SsdIndex::new(view.slice(s![oy..oy + prob.h - hf, ox..ox + prob.w - hf, ..]))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(PopulationEvaluator {
            prob,
            indices,
            cache: Mutex::new(Cache {
                maps: HashMap::new(),
                lru: BTreeMap::new(),
                tick: 0,
                bytes: 0,
                limit: cache_bytes,
                hits: 0,
                misses: 0,
            }),
        })
    }

    /// Number of tiles `m` of the tile set.
    pub fn n_tiles(&self) -> usize {
        self.prob.tiles.len()
    }

    /// Number of patches `n` per gene vector.
    pub fn n_patches(&self) -> usize {
        self.prob.n_patches
    }

    /// Tile size `N`.
    pub fn tile_size(&self) -> usize {
        self.prob.n
    }

    /// Evaluates `P` gene vectors `genes` `(P, n, 2)` (top-left `(row, col)` of every patch, each inside
    /// `[0, H - N] x [0, W - N]`). Returns `E` (`P` values) and `D` (`(P, m)`, the exact minimum SSD of every
    /// intermediate tile, divided by `N N` when normalising). Distinct positions within an individual are
    /// NOT required here (that is the caller's business; repeated positions are evaluated like any other).
    ///
    /// Runs in parallel (rayon: call inside [`crate::parallel::install`]); results are bit-identical at any
    /// thread count and do not depend on the cache's contents.
    pub fn evaluate(&self, genes: ArrayView3<i64>) -> Result<(Vec<f64>, Array2<f64>)> {
        let prob = &self.prob;
        let pos = prob.positions(genes)?;
        let (np, m) = (genes.dim().0, prob.tiles.len());
        let n = prob.n_patches;

        // Distinct tiles (four positions) of the call, in order of first appearance.
        let mut uniq: Vec<Tuple> = Vec::new();
        let mut seen: HashMap<Tuple, usize> = HashMap::new();
        let mut item_uniq = try_with_capacity("genes", np * m)?;
        for i in 0..np {
            let g = &pos[i * n..(i + 1) * n];
            for t in &prob.tiles {
                let tuple = [g[t[0]], g[t[1]], g[t[2]], g[t[3]]];
                let u = *seen.entry(tuple).or_insert_with(|| {
                    uniq.push(tuple);
                    uniq.len() - 1
                });
                item_uniq.push(u);
            }
        }

        // The distinct tiles in batches whose partial maps fit a quarter of the cache limit (at least one
        // tile), so that the maps held at any time stay near the limit whatever the population size (a
        // first generation needs ~4 n P maps: > 1 GB at 512² with 128-px tiles when all were held at once).
        let entry_bytes = self.entry_bytes();
        let batch_maps = (self.cache_limit() / 4 / entry_bytes).max(4);
        let mut mins = try_vec("genes", uniq.len(), 0.0f64)?;
        let mut start = 0;
        while start < uniq.len() {
            let mut keys: Vec<Key> = Vec::new();
            let mut in_batch: HashSet<Key> = HashSet::new();
            let mut end = start;
            while end < uniq.len() {
                let new: Vec<Key> = (0..4u8)
                    .map(|q| (uniq[end][q as usize].0, uniq[end][q as usize].1, q))
                    .filter(|k| !in_batch.contains(k))
                    .collect();
                if keys.len() + new.len() > batch_maps && end > start {
                    break;
                }
                for k in new {
                    if in_batch.insert(k) {
                        keys.push(k);
                    }
                }
                end += 1;
            }
            self.evaluate_batch(&uniq[start..end], &keys, entry_bytes, &mut mins[start..end])?;
            start = end;
        }

        let mut d = try_array("genes", (np, m), 0.0f64)?;
        for ((i, j), v) in d.indexed_iter_mut() {
            *v = prob.scale(mins[item_uniq[i * m + j]]);
        }
        Ok((prob.energies(&d), d))
    }

    /// The byte limit of the cache.
    fn cache_limit(&self) -> usize {
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).limit
    }

    /// The exact minimum of every tile of `tiles` into `out`, given the distinct `keys` of their maps:
    /// look up, compute the missing ones in parallel, store (evicting beyond the limit), then the tiles.
    fn evaluate_batch(
        &self,
        tiles: &[Tuple],
        keys: &[Key],
        entry_bytes: usize,
        out: &mut [f64],
    ) -> Result<()> {
        let mut have: HashMap<Key, Arc<PartialMap>> = HashMap::with_capacity(keys.len());
        let mut missing = Vec::new();
        {
            let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
            for &k in keys {
                match cache.touch(k) {
                    Some(map) => {
                        cache.hits += 1;
                        have.insert(k, map);
                    }
                    None => {
                        cache.misses += 1;
                        missing.push(k);
                    }
                }
            }
        }
        let computed: Vec<Arc<PartialMap>> = missing
            .par_iter()
            .map(|&k| self.partial_map(k).map(Arc::new))
            .collect::<Result<_>>()?;
        {
            let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
            for (&k, map) in missing.iter().zip(&computed) {
                cache.insert(k, Arc::clone(map), entry_bytes);
                have.insert(k, Arc::clone(map));
            }
            cache.evict(entry_bytes);
        }
        drop(computed);
        let (th, tw) = self.prob.window();
        // One window-sized sum buffer per worker, allocated fallibly (an error, not an abort, when the
        // exemplar's window does not fit in the memory left).
        tiles.par_iter().zip(out.par_iter_mut()).try_for_each_init(
            || try_vec("exemplar", th * tw, 0.0f64).map(|b| (b, Vec::new())),
            |scratch, (t, o)| {
                let (buf, cands) = scratch.as_mut().map_err(|e| e.clone())?;
                let maps = [0usize, 1, 2, 3].map(|q| &*have[&(t[q].0, t[q].1, q as u8)]);
                *o = self.tile_min(t, maps, buf, cands);
                Ok(())
            },
        )
    }

    /// Hits, misses and size of the partial-map cache.
    pub fn cache_stats(&self) -> CacheStats {
        let cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        CacheStats {
            entries: cache.maps.len(),
            bytes: cache.bytes,
            limit: cache.limit,
            hits: cache.hits,
            misses: cache.misses,
        }
    }

    /// Drops every cached map (the hit and miss counters are kept).
    pub fn clear_cache(&self) {
        let mut cache = self.cache.lock().unwrap_or_else(|e| e.into_inner());
        cache.maps.clear();
        cache.lru.clear();
        cache.bytes = 0;
    }

    fn entry_bytes(&self) -> usize {
        let (th, tw) = self.prob.window();
        th * tw * std::mem::size_of::<f64>() + ENTRY_OVERHEAD
    }

    /// The FFT map of the piece of gene position `(r, c)` in role `q`, cut to the role's translation window.
    fn partial_map(&self, (r, c, q): Key) -> Result<PartialMap> {
        let prob = &self.prob;
        let hf = prob.half;
        let q = q as usize;
        let (pr, pc) = (r + PATCH_OFF[q].0 * hf, c + PATCH_OFF[q].1 * hf);
        let view = ArrayView3::from_shape((prob.h, prob.w, prob.c), &prob.image[..])
            .expect("image length matches its shape");
        let piece = view.slice(s![pr..pr + hf, pc..pc + hf, ..]);
        let (map, bound) = self.indices[q].ssd_map_f64(piece, None)?;
        debug_assert_eq!(map.dim(), prob.window());
        Ok(PartialMap {
            data: map.into_raw_vec_and_offset().0,
            bound,
        })
    }

    /// Exact `min_t C(t)` (not normalised) of the tile with positions `t`: FFT sum, then direct sums of
    /// every candidate within the error bound (see the module documentation).
    fn tile_min(
        &self,
        t: &Tuple,
        maps: [&PartialMap; 4],
        buf: &mut [f64],
        cands: &mut Vec<(f64, usize)>,
    ) -> f64 {
        let f0 = simd::sum4_min(
            &maps[0].data,
            &maps[1].data,
            &maps[2].data,
            &maps[3].data,
            buf,
        );
        let bound = (maps[0].bound + maps[1].bound) + (maps[2].bound + maps[3].bound);
        // Slack for the three additions (non-negative terms) and the comparisons themselves.
        let b = bound + 8.0 * f64::EPSILON * (f0.abs() + bound) + f64::MIN_POSITIVE;
        let limit = f0 + 2.0 * b;
        cands.clear();
        simd::below(buf, limit, cands);
        cands.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let tw = self.prob.window().1;
        let mut best = f64::INFINITY;
        for &(f, i) in cands.iter() {
            if f - b > best {
                break;
            }
            let e = self.prob.exact(t, i / tw, i % tw);
            if e < best {
                best = e;
            }
        }
        best
    }
}

/// Slow oracle for tests: assembles every intermediate tile and takes the minimum of the direct `f64` SSD
/// over every translation ([`crate::ssd::ssd_map_brute`]). Same arguments, validation and results as
/// [`PopulationEvaluator::new`] followed by [`PopulationEvaluator::evaluate`].
#[doc(hidden)]
#[cfg(any(test, feature = "oracles"))]
pub fn evaluate_brute(
    exemplar: ArrayView3<f32>,
    tile_size: usize,
    tile_patches: ArrayView2<i64>,
    n_patches: usize,
    lambda: f64,
    normalise: bool,
    genes: ArrayView3<i64>,
) -> Result<(Vec<f64>, Array2<f64>)> {
    let prob = Problem::new(
        exemplar,
        tile_size,
        tile_patches,
        n_patches,
        lambda,
        normalise,
    )?;
    let pos = prob.positions(genes)?;
    let (np, m) = (genes.dim().0, prob.tiles.len());
    let (n, hf) = (prob.n, prob.half);
    let mut d = Array2::<f64>::zeros((np, m));
    for i in 0..np {
        for (j, t) in prob.tiles.iter().enumerate() {
            let mut tile = Array3::<f32>::zeros((n, n, prob.c));
            for q in 0..4 {
                let (gr, gc) = pos[i * n_patches + t[q]];
                let (pr, pc) = (gr + PATCH_OFF[q].0 * hf, gc + PATCH_OFF[q].1 * hf);
                let (oy, ox) = (TILE_OFF[q].0 * hf, TILE_OFF[q].1 * hf);
                tile.slice_mut(s![oy..oy + hf, ox..ox + hf, ..])
                    .assign(&exemplar.slice(s![pr..pr + hf, pc..pc + hf, ..]));
            }
            let map = ssd_map_brute(exemplar, tile.view(), None)?;
            let min = map.iter().copied().fold(f64::INFINITY, f64::min);
            d[[i, j]] = prob.scale(min);
        }
    }
    Ok((prob.energies(&d), d))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{Array2, Array3};

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

    /// Tile set 16a (colours R, G, B, Y = gene indices 0..4), as in `tilesynth.layouts.omega_sets`.
    const SET_16A: &str =
        "BRYG BYRG BYYR BRRB YGRB YRGB YRRG YGGY RBGY RGBY RGGB RBBR GYBR GBYR GBBY GYYG";

    fn tileset(s: &str, colours: &str) -> Array2<i64> {
        let rows: Vec<Vec<i64>> = s
            .split_whitespace()
            .map(|t| {
                t.chars()
                    .map(|ch| colours.find(ch).unwrap() as i64)
                    .collect()
            })
            .collect();
        Array2::from_shape_fn((rows.len(), 4), |(j, q)| rows[j][q])
    }

    /// `m` deterministic 4-tuples over `n` patches.
    fn random_tiles(rng: &mut Rng, m: usize, n: usize) -> Array2<i64> {
        Array2::from_shape_simple_fn((m, 4), || rng.below(n) as i64)
    }

    fn random_genes(rng: &mut Rng, p: usize, n: usize, rmax: usize, cmax: usize) -> Array3<i64> {
        let mut g = Array3::<i64>::zeros((p, n, 2));
        for i in 0..p {
            for k in 0..n {
                g[[i, k, 0]] = rng.below(rmax + 1) as i64;
                g[[i, k, 1]] = rng.below(cmax + 1) as i64;
            }
        }
        g
    }

    fn image(rng: &mut Rng, h: usize, w: usize, c: usize) -> Array3<f32> {
        Array3::from_shape_simple_fn((h, w, c), || rng.f32())
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * a.abs().max(b.abs()) + 1e-12
    }

    fn check(
        img: &Array3<f32>,
        n: usize,
        tp: &Array2<i64>,
        n_patches: usize,
        genes: &Array3<i64>,
        normalise: bool,
        cache: usize,
    ) {
        let ev =
            PopulationEvaluator::new(img.view(), n, tp.view(), n_patches, 0.8, normalise, cache)
                .unwrap();
        let (e, d) = ev.evaluate(genes.view()).unwrap();
        let (be, bd) = evaluate_brute(
            img.view(),
            n,
            tp.view(),
            n_patches,
            0.8,
            normalise,
            genes.view(),
        )
        .unwrap();
        assert_eq!(d.dim(), bd.dim());
        for (x, y) in d.iter().zip(bd.iter()) {
            assert!(close(*x, *y), "D {x} vs brute {y}");
        }
        for (x, y) in e.iter().zip(&be) {
            assert!(close(*x, *y), "E {x} vs brute {y}");
        }
        // E formula from D, population variance
        for (i, row) in d.rows().into_iter().enumerate() {
            let m = row.len() as f64;
            let mean = row.sum() / m;
            let var = row.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m;
            assert!(close(e[i], 0.8 * row.sum() + 0.2 * var));
        }
    }

    #[test]
    fn matches_brute_force() {
        let mut rng = Rng(11);
        let sixteen = tileset(SET_16A, "RGBY");
        for &(h, w, c, n) in &[
            (24, 20, 3, 8),
            (20, 24, 1, 6),
            (17, 19, 2, 4),
            (12, 12, 3, 12),
            (9, 7, 4, 2),
        ] {
            let img = image(&mut rng, h, w, c);
            for &(n_patches, p) in &[(4, 1), (4, 3), (5, 2), (6, 4)] {
                let tp = if n_patches == 4 {
                    sixteen.clone()
                } else {
                    random_tiles(&mut rng, 7 + n_patches, n_patches)
                };
                let genes = random_genes(&mut rng, p, n_patches, h - n, w - n);
                for normalise in [false, true] {
                    check(
                        &img,
                        n,
                        &tp,
                        n_patches,
                        &genes,
                        normalise,
                        DEFAULT_CACHE_BYTES,
                    );
                }
                check(&img, n, &tp, n_patches, &genes, false, 0);
            }
        }
    }

    #[test]
    fn exact_zero_and_ties() {
        let mut rng = Rng(12);
        // A tile cut from the exemplar: genes forming a contiguous 2N x 2N block give D = 0 exactly.
        let img = image(&mut rng, 24, 20, 3);
        let tp = Array2::from_shape_vec((1, 4), vec![0i64, 1, 2, 3]).unwrap();
        // Tile at translation (ty, tx) = (r + N/2, c + N/2): TL gene (r, c), BL (r + N, c), TR (r, c + N),
        // BR (r + N, c + N).
        let (r, c, n) = (3i64, 2i64, 8usize);
        let ni = n as i64;
        let genes =
            Array3::from_shape_vec((1, 4, 2), vec![r, c, r + ni, c, r, c + ni, r + ni, c + ni])
                .unwrap();
        let ev =
            PopulationEvaluator::new(img.view(), n, tp.view(), 4, 0.8, false, 1 << 20).unwrap();
        let (_, d) = ev.evaluate(genes.view()).unwrap();
        let (_, bd) =
            evaluate_brute(img.view(), n, tp.view(), 4, 0.8, false, genes.view()).unwrap();
        assert_eq!(bd[[0, 0]], 0.0);
        assert_eq!(d[[0, 0]], 0.0);
        // A constant exemplar: every translation ties.
        let flat = Array3::from_elem((14, 12, 3), 0.375f32);
        let genes = random_genes(&mut rng, 2, 4, 6, 4);
        let ev =
            PopulationEvaluator::new(flat.view(), 8, tp.view(), 4, 0.5, false, 1 << 20).unwrap();
        let (e, d) = ev.evaluate(genes.view()).unwrap();
        assert!(d.iter().all(|&v| v == 0.0) && e.iter().all(|&v| v == 0.0));
        // Repeated positions (not distinct) are allowed.
        let img = image(&mut rng, 24, 20, 3);
        let genes = Array3::<i64>::from_elem((2, 4, 2), 5);
        check(&img, 8, &tp, 4, &genes, false, 1 << 20);
    }

    #[test]
    fn deterministic_across_threads_and_cache() {
        let mut rng = Rng(13);
        let img = image(&mut rng, 40, 36, 3);
        let tp = random_tiles(&mut rng, 38, 6);
        let genes = random_genes(&mut rng, 9, 6, 40 - 16, 36 - 16);
        let run = |threads, cache| {
            crate::parallel::install(Some(threads), || {
                let ev = PopulationEvaluator::new(img.view(), 16, tp.view(), 6, 0.8, false, cache)
                    .unwrap();
                let a = ev.evaluate(genes.view()).unwrap();
                let b = ev.evaluate(genes.view()).unwrap();
                assert_eq!(a, b);
                (a, ev.cache_stats())
            })
            .unwrap()
        };
        let (a1, s1) = run(1, DEFAULT_CACHE_BYTES);
        let (a2, s2) = run(2, DEFAULT_CACHE_BYTES);
        let (a3, _) = run(3, 1);
        let (a4, s4) = run(2, 0);
        assert!(a1 == a2 && a2 == a3 && a3 == a4);
        assert_eq!(s1, s2);
        // second call is all hits with a big cache, all misses with none
        assert_eq!(s1.hits, s1.misses);
        assert_eq!(s4.hits, 0);
        assert_eq!((s4.entries, s4.bytes), (0, 0));
        fn assert_send_sync<T: Send + Sync>() {}
        assert_send_sync::<PopulationEvaluator>();
    }

    #[test]
    fn cache_bounded_and_reused() {
        let mut rng = Rng(14);
        let img = image(&mut rng, 30, 30, 3);
        let tp = tileset(SET_16A, "RGBY");
        let n = 10;
        let (th, tw) = (30 - n + 1, 30 - n + 1);
        let entry = th * tw * 8 + ENTRY_OVERHEAD;
        let limit = 7 * entry + 5;
        let ev = PopulationEvaluator::new(img.view(), n, tp.view(), 4, 0.8, true, limit).unwrap();
        let big =
            PopulationEvaluator::new(img.view(), n, tp.view(), 4, 0.8, true, DEFAULT_CACHE_BYTES)
                .unwrap();
        let mut prev: Option<Array3<i64>> = None;
        for _ in 0..6 {
            // a generation: mutate one gene of a previous population
            let mut genes = match &prev {
                Some(g) => g.clone(),
                None => random_genes(&mut rng, 5, 4, 30 - n, 30 - n),
            };
            let (i, k) = (rng.below(5), rng.below(4));
            genes[[i, k, 0]] = rng.below(30 - n + 1) as i64;
            let small = ev.evaluate(genes.view()).unwrap();
            let s = ev.cache_stats();
            assert!(s.bytes <= limit && s.entries <= 7, "{s:?}");
            assert_eq!(s.bytes, s.entries * entry);
            assert_eq!(small, big.evaluate(genes.view()).unwrap());
            prev = Some(genes);
        }
        let s = big.cache_stats();
        assert!(s.hits > s.misses, "{s:?}");
        big.clear_cache();
        assert_eq!(big.cache_stats().entries, 0);
        let g = prev.unwrap();
        let again = big.evaluate(g.view()).unwrap();
        assert_eq!(again, ev.evaluate(g.view()).unwrap());
    }

    #[test]
    fn batched_evaluation_matches_unbatched() {
        // Populations evaluated in batches of a few maps (cache limit 0 or a few entries) give exactly the
        // values of one batch (a large limit), with repeated and shared positions.
        let mut rng = Rng(21);
        let img = Array3::from_shape_simple_fn((34, 31, 3), || rng.f32());
        let n = 8;
        let tp = Array2::from_shape_vec(
            (5, 4),
            vec![0, 1, 2, 3, 3, 2, 1, 0, 4, 4, 5, 5, 1, 5, 0, 4, 2, 2, 2, 2],
        )
        .unwrap();
        let entry = (34 - n + 1) * (31 - n + 1) * 8 + ENTRY_OVERHEAD;
        let mut genes = random_genes(&mut rng, 12, 6, 34 - n, 31 - n);
        let first = genes.slice(s![0, .., ..]).to_owned();
        genes.slice_mut(s![3, .., ..]).assign(&first);
        let big =
            PopulationEvaluator::new(img.view(), n, tp.view(), 6, 0.8, false, DEFAULT_CACHE_BYTES)
                .unwrap()
                .evaluate(genes.view())
                .unwrap();
        for limit in [0, entry, 5 * entry, 17 * entry + 3] {
            let ev =
                PopulationEvaluator::new(img.view(), n, tp.view(), 6, 0.8, false, limit).unwrap();
            assert_eq!(ev.evaluate(genes.view()).unwrap(), big, "limit {limit}");
            assert!(ev.cache_stats().bytes <= limit);
        }
    }

    #[test]
    fn simd_matches_portable() {
        let mut rng = Rng(15);
        for len in [0usize, 1, 3, 7, 8, 15, 16, 17, 21, 120, 1001] {
            let img: Vec<f64> = (0..20 * (len + 5)).map(|_| rng.f32() as f64).collect();
            let starts = [(0, 5), (len, 3), (2, 2 * len + 1), (7, 4 * len + 8)];
            for rows in [1usize, 2, 3] {
                let got = simd::quad_ssd(&img, len + 1, rows, len, &starts);
                let want = simd::portable_quad(&img, len + 1, rows, len, &starts);
                assert_eq!(got.to_bits(), want.to_bits());
                let naive: f64 = starts
                    .iter()
                    .flat_map(|&(a, b)| {
                        let img = &img;
                        (0..rows).flat_map(move |y| {
                            (0..len).map(move |i| {
                                (img[a + y * (len + 1) + i] - img[b + y * (len + 1) + i]).powi(2)
                            })
                        })
                    })
                    .sum();
                assert!((got - naive).abs() <= 1e-12 * naive.max(1.0));
            }
            let maps: Vec<Vec<f64>> = (0..4)
                .map(|_| (0..len).map(|_| rng.f32() as f64 * 3.0).collect())
                .collect();
            let mut o1 = vec![0.0; len];
            let mut o2 = vec![0.0; len];
            let m1 = simd::sum4_min(&maps[0], &maps[1], &maps[2], &maps[3], &mut o1);
            let m2 = simd::portable_sum4(&maps[0], &maps[1], &maps[2], &maps[3], &mut o2);
            assert_eq!(o1, o2);
            assert_eq!(m1.to_bits(), m2.to_bits());
            assert_eq!(m1, o1.iter().copied().fold(f64::INFINITY, f64::min));
            let (mut c1, mut c2) = (Vec::new(), Vec::new());
            simd::below(&o1, 6.0, &mut c1);
            simd::portable_below(&o1, 6.0, &mut c2);
            assert_eq!(c1, c2);
            let want: Vec<(f64, usize)> = o1
                .iter()
                .enumerate()
                .filter(|(_, &v)| v <= 6.0)
                .map(|(i, &v)| (v, i))
                .collect();
            assert_eq!(c1, want);
        }
    }

    #[test]
    fn errors() {
        let img = Array3::<f32>::zeros((20, 16, 3));
        let tp = Array2::from_shape_vec((2, 4), vec![0i64, 1, 2, 3, 3, 2, 1, 0]).unwrap();
        let is_shape = |e: TilesynthError, n: &str| matches!(e, TilesynthError::Shape { name, .. } if name == n);
        let is_param = |e: TilesynthError, n: &str| matches!(e, TilesynthError::Parameter { name, .. } if name == n);
        let new = |img: &Array3<f32>, n, tp: &Array2<i64>, np, lam| {
            PopulationEvaluator::new(img.view(), n, tp.view(), np, lam, false, 0)
                .err()
                .unwrap()
        };
        assert!(is_param(new(&img, 7, &tp, 4, 0.8), "tile_size"));
        assert!(is_param(new(&img, 0, &tp, 4, 0.8), "tile_size"));
        assert!(is_param(new(&img, 18, &tp, 4, 0.8), "tile_size"));
        assert!(is_param(new(&img, 8, &tp, 3, 0.8), "tile_patches"));
        assert!(is_param(new(&img, 8, &tp, 0, 0.8), "n_patches"));
        assert!(is_param(new(&img, 8, &tp, 4, 1.5), "lam"));
        assert!(is_param(new(&img, 8, &tp, 4, -0.1), "lam"));
        assert!(is_param(new(&img, 8, &tp, 4, f64::NAN), "lam"));
        let neg = Array2::from_shape_vec((1, 4), vec![0i64, -1, 2, 3]).unwrap();
        assert!(is_param(new(&img, 8, &neg, 4, 0.8), "tile_patches"));
        assert!(is_shape(
            new(&img, 8, &Array2::zeros((0, 4)), 4, 0.8),
            "tile_patches"
        ));
        assert!(is_shape(
            new(&img, 8, &Array2::zeros((2, 3)), 4, 0.8),
            "tile_patches"
        ));
        assert!(is_shape(
            new(&Array3::zeros((0, 16, 3)), 8, &tp, 4, 0.8),
            "exemplar"
        ));
        let mut bad = img.clone();
        bad[[1, 2, 0]] = f32::NAN;
        assert!(is_param(new(&bad, 8, &tp, 4, 0.8), "exemplar"));

        let ev = PopulationEvaluator::new(img.view(), 8, tp.view(), 4, 0.8, false, 0).unwrap();
        let eval = |g: Array3<i64>| ev.evaluate(g.view()).err().unwrap();
        assert!(is_shape(eval(Array3::zeros((2, 3, 2))), "genes"));
        assert!(is_shape(eval(Array3::zeros((2, 4, 3))), "genes"));
        let mut g = Array3::<i64>::zeros((2, 4, 2));
        g[[1, 2, 0]] = 13; // H - N = 12
        assert!(is_param(eval(g.clone()), "genes"));
        g[[1, 2, 0]] = 12;
        g[[0, 3, 1]] = 9; // W - N = 8
        assert!(is_param(eval(g.clone()), "genes"));
        g[[0, 3, 1]] = -1;
        assert!(is_param(eval(g.clone()), "genes"));
        g[[0, 3, 1]] = 8;
        assert!(ev.evaluate(g.view()).is_ok());
        // empty population
        let (e, d) = ev.evaluate(Array3::<i64>::zeros((0, 4, 2)).view()).unwrap();
        assert!(e.is_empty() && d.dim() == (0, 2));
        assert!(is_shape(
            evaluate_brute(
                img.view(),
                8,
                tp.view(),
                4,
                0.8,
                false,
                Array3::zeros((1, 5, 2)).view()
            )
            .unwrap_err(),
            "genes"
        ));
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::PopulationEvaluator;
    use crate::error::{assert_alloc_error, HUGE_SIDE};
    use ndarray::{Array2, Array3};

    /// An exemplar whose copies cannot be allocated (a broadcast view: no memory behind it) is an error
    /// naming `exemplar`, not an abort.
    #[test]
    fn an_exemplar_that_cannot_be_copied_is_an_error() {
        let one = Array3::from_elem((1, 1, 1), 0.5f32);
        let big = one.broadcast((HUGE_SIDE, HUGE_SIDE, 3)).unwrap();
        let tp = Array2::from_shape_vec((1, 4), vec![0i64, 1, 2, 3]).unwrap();
        assert_alloc_error(
            PopulationEvaluator::new(big, 8, tp.view(), 4, 0.8, false, 0).map(|e| e.n_tiles()),
            "exemplar",
        );
    }
}
