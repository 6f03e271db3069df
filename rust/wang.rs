//! Wang tiles: Cohen et al.'s construction (diamond samples joined by minimum-error cuts, with the improved
//! match of Dong, Sun and Paul, paper 001), Burke's square variant, and the closed graph cut of the strict
//! Wang tiles of Zhang and Kim (paper 004).
//!
//! ## Geometry (the same as `tilesynth.builder.wang`, which documents it with a figure)
//!
//! A tile is `N x N` (N even, `h = N/2`), pixel `(y, x)` with centre `(y + ½, x + ½)`. Its four edge colours
//! N, E, S, W each name one *sample*: a square of exemplar content of side `P` whose top-left corner is the
//! gene `(gr, gc)`. The sample of an edge colour is centred on that edge's midpoint, so tile pixel `(y, x)`
//! (also outside the tile) reads the exemplar at
//!
//! ```text
//! N: (gr + m + h + y, gc + m + x)      S: (gr + m - h + y, gc + m + x)
//! E: (gr + m + y, gc + m - h + x)      W: (gr + m + y, gc + m + h + x)
//! ```
//!
//! with the margin `m = P/2 - h`. Two tiles that share an edge colour show the two halves of the same sample
//! on either side of that edge: contiguous exemplar content.
//!
//! The *support* of a sample is where it may contribute: a diamond `|Y - cy| + |X - cx| <= h + w` around its
//! edge midpoint `(cy, cx)` (Cohen; `w = overlap / 2`), or the `N x N` square (Burke). The tile is split by
//! four cuts from the centre to the corners, one per quadrant between the horizontal-edge sample `A` (N or
//! S) and the vertical-edge sample `B` (E or W): NE (top-right), ES (bottom-right), SW (bottom-left), WN
//! (top-left). By symmetry each is computed in the frame of the NE cut:
//!
//! - lines `s = x - y` (perpendicular to the diagonal `x + y = N - 1`), `s = 1, 2, ...`; position along a
//!   line `d = x + y - (N - 1)` (`d < 0` towards A), so `y = (d - s + N - 1) / 2`, `x = (d + s + N - 1) / 2`;
//!   consecutive pixels of a path differ by `d ± 1`: a 4-connected staircase;
//! - the *band* of line `s` is the `d` (of the parity of `s + 1`) inside the cone `|d| <= s - 1` (the
//!   quadrant and, for free corners, beyond it past the corner) and inside both supports; with pinned
//!   corners also inside the tile, never on the right edge except at the corner;
//! - the cut starts at the tile centre (`s = 1`, `d = 0`: pixel `(h - 1, h)`), ends at the corner pixel
//!   `(0, N - 1)` (`s = N - 1`, `d = 0`) when pinned, or anywhere on the last band line (past the corner, as
//!   Cohen's cropped diamonds do: the corner problem of 004) when free;
//! - a tile pixel of the quadrant on line `s` takes A when `d <= d_s` (the path pixel itself goes to A), B
//!   otherwise. So the top edge is A and the right edge B, except where a free cut leaves the tile; corner
//!   pixels always take the horizontal-edge sample.
//!
//! ## The match of 001
//!
//! On the band (the overlap region, `n_overlap` pixels) `D_overlap = Σ Σ_c (A − B)²`. The minimum-error
//! boundary cut (Efros–Freeman dynamic programming over the lines) minimises the luminance error
//! `(Y_A − Y_B)²` (Y of YIQ: `0.299 R + 0.587 G + 0.114 B`; channel 0 for fewer than three channels) summed
//! along the path; `D_path` is that sum and `n_path` the number of path pixels. Then
//!
//! ```text
//! D_boundary = ω D_overlap / n_overlap + C (1 − ω) D_path / n_path      (C = 3 for RGB: 001's factor 3)
//! D_sum      = Σ over the tile's four cuts of D_boundary
//! E          = ω Σ_tiles D_sum + (1 − ω) Var(D_sum)                      (population variance)
//! ```
//!
//! The graph-cut option replaces the path by a minimum cut of the quadrant (plus margin) with Kwatra
//! weights between A and B ([`crate::seams::kwatra_weights`], [`crate::maxflow::grid_mincut`]): left column of
//! the quadrant tied to A, bottom row to B (with pinned corners also the top row to A and the right column to
//! B), the band free; the seam pixels (A pixels with a B neighbour) play the role of the path.
//!
//! ## Strict Wang tiles
//!
//! [`swang_cuts`] is 004's closed cut: Kwatra weights between the initial tile and the supplementary patch,
//! the border ring tied to the initial tile, both diagonals (corner pixels excepted: they belong to the
//! border) tied to the supplementary patch.
//!
//! Every cut is a pure function of its inputs; batches run in parallel and are assembled in a fixed order,
//! so results never depend on the number of threads.

use crate::error::{
    fmt_shape, try_array, try_collect, try_vec, try_with_capacity, Result, TilesynthError,
};
use crate::maxflow::grid_mincut;
use crate::seams::kwatra_weights;
use ndarray::{Array2, Array3, ArrayView2, ArrayView3, ArrayView4, Axis};
use rayon::prelude::*;

/// Role index of the north edge's sample (column 0 of `tile_samples`).
pub const NORTH: usize = 0;
/// Role index of the east edge's sample.
pub const EAST: usize = 1;
/// Role index of the south edge's sample.
pub const SOUTH: usize = 2;
/// Role index of the west edge's sample.
pub const WEST: usize = 3;

/// The four cuts of a tile, in this order: (A, B) roles of NE, ES, SW, WN.
pub const CUT_ROLES: [(usize, usize); 4] =
    [(NORTH, EAST), (SOUTH, EAST), (SOUTH, WEST), (NORTH, WEST)];

/// Number of values per cut in [`WangTiles::stats`].
pub const N_STATS: usize = 6;

/// Default `ω` of 001 (it gives none; 000, by the same authors, uses 0.8 for the same weighting).
pub const DEFAULT_OMEGA: f64 = 0.8;

/// What a cut does at the tile corner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Corners {
    /// Cohen et al.: the cut runs along the whole overlap of the diamonds, past the corner, and the tile is
    /// cropped from the result; the cut generally crosses the tile edge near the corner (004's corner problem).
    Free,
    /// The cut ends at the corner pixel and stays inside the tile: every edge pixel shows its edge's sample.
    Pinned,
}

/// The support of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Samples {
    /// Cohen et al.: a diamond of L1 radius `N/2 + overlap/2` around the edge midpoint.
    Diamond,
    /// Burke: the `N x N` square centred on the edge midpoint (overlap = the whole quadrant, pinned corners).
    Square,
}

/// How the cuts are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CutMethod {
    /// Efros–Freeman minimum-error boundary cut by dynamic programming.
    Dp,
    /// Minimum graph cut (Kwatra weights, Boykov–Kolmogorov max-flow).
    Graph,
}

impl Corners {
    /// `"free"` or `"pinned"`.
    pub fn parse(s: &str) -> Result<Corners> {
        match s {
            "free" => Ok(Corners::Free),
            "pinned" => Ok(Corners::Pinned),
            _ => Err(TilesynthError::param(
                "corners",
                format!("{s:?}"),
                "must be 'free' or 'pinned'",
            )),
        }
    }
}

impl Samples {
    /// `"diamond"` or `"square"`.
    pub fn parse(s: &str) -> Result<Samples> {
        match s {
            "diamond" => Ok(Samples::Diamond),
            "square" => Ok(Samples::Square),
            _ => Err(TilesynthError::param(
                "samples",
                format!("{s:?}"),
                "must be 'diamond' or 'square'",
            )),
        }
    }
}

impl CutMethod {
    /// `"dp"` or `"graph"`.
    pub fn parse(s: &str) -> Result<CutMethod> {
        match s {
            "dp" => Ok(CutMethod::Dp),
            "graph" => Ok(CutMethod::Graph),
            _ => Err(TilesynthError::param(
                "cut",
                format!("{s:?}"),
                "must be 'dp' or 'graph'",
            )),
        }
    }
}

/// Parameters of a Wang tile construction.
#[derive(Debug, Clone, PartialEq)]
pub struct WangParams {
    /// Tile size `N` (even, >= 4).
    pub tile_size: usize,
    /// Width of the overlap band of two diamonds, `2 w` (even, >= 2; ignored for square samples).
    pub overlap: usize,
    /// Free or pinned corners (square samples need pinned corners).
    pub corners: Corners,
    /// Diamond (Cohen) or square (Burke) samples.
    pub samples: Samples,
    /// Dynamic programming or graph cut.
    pub cut: CutMethod,
    /// `ω` of `D_boundary` and `E`, in [0, 1].
    pub omega: f64,
    /// Epsilon of the Kwatra weight (graph cuts only), finite and > 0.
    pub eps: f64,
}

/// The exemplar, contiguous.
struct Exemplar {
    data: Vec<f32>,
    /// Luminance of every pixel ([`luminance`]).
    lum: Vec<f64>,
    h: usize,
    w: usize,
    c: usize,
}

impl Exemplar {
    fn new(ex: ArrayView3<f32>) -> Result<Exemplar> {
        let (h, w, c) = ex.dim();
        if h == 0 || w == 0 || c == 0 {
            return Err(TilesynthError::shape(
                "exemplar",
                "(H, W, C) with H, W, C >= 1",
                fmt_shape(ex.shape()),
            ));
        }
        let data: Vec<f32> = try_collect("exemplar", h * w * c, ex.iter().copied())?;
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
            return Err(TilesynthError::param(
                "exemplar",
                data[i],
                format!("all values must be finite (found at flat index {i})"),
            ));
        }
        let lum = try_collect("exemplar", h * w, data.chunks_exact(c).map(luminance))?;
        Ok(Exemplar { data, lum, h, w, c })
    }

    #[inline(always)]
    fn px(&self, row: i64, col: i64) -> &[f32] {
        debug_assert!(row >= 0 && col >= 0 && (row as usize) < self.h && (col as usize) < self.w);
        let p = (row as usize * self.w + col as usize) * self.c;
        &self.data[p..p + self.c]
    }
}

/// Luminance (Y of YIQ) of a pixel; channel 0 for fewer than three channels.
#[inline(always)]
fn luminance(p: &[f32]) -> f64 {
    if p.len() >= 3 {
        0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64
    } else {
        p[0] as f64
    }
}

/// The band and sample layout shared by all cuts of one construction.
#[derive(Debug, Clone)]
pub struct Geometry {
    n: i64,
    h: i64,
    margin: i64,
    radius2: i64,
    corners: Corners,
    samples: Samples,
    /// `(lo, hi)` of line `s = k + 1`.
    lines: Vec<(i64, i64)>,
    /// Index of the first band pixel of each line.
    start: Vec<usize>,
    /// Number of band pixels.
    nband: usize,
    /// Tile coordinates of the band pixels of each cut (NE, ES, SW, WN), in band order (line by line, `d`
    /// increasing).
    band_px: [Vec<(i64, i64)>; 4],
}

impl Geometry {
    /// Validates `params` and lays out the band.
    pub fn new(params: &WangParams) -> Result<Geometry> {
        let n = params.tile_size;
        if n < 4 || n % 2 != 0 {
            return Err(TilesynthError::param(
                "tile_size",
                n,
                "must be even and >= 4",
            ));
        }
        if n > 1 << 14 {
            return Err(TilesynthError::param("tile_size", n, "must be <= 16384"));
        }
        if !(0.0..=1.0).contains(&params.omega) {
            return Err(TilesynthError::param(
                "omega",
                params.omega,
                "must lie in [0, 1]",
            ));
        }
        if !(params.eps.is_finite() && params.eps > 0.0) {
            return Err(TilesynthError::param(
                "eps",
                params.eps,
                "must be finite and > 0",
            ));
        }
        let (n, h) = (n as i64, (n / 2) as i64);
        let (margin, radius2) = match params.samples {
            Samples::Square => {
                if params.corners == Corners::Free {
                    return Err(TilesynthError::param(
                        "corners",
                        "'free'",
                        "square samples end at the tile corner: use pinned corners",
                    ));
                }
                (0, n)
            }
            Samples::Diamond => {
                let o = params.overlap;
                if o < 2 || o % 2 != 0 || o > 1 << 14 {
                    return Err(TilesynthError::param(
                        "overlap",
                        o,
                        "must be even, >= 2 and <= 16384 (the band must hold a staircase path)",
                    ));
                }
                let w = (o / 2) as i64;
                let margin = if params.corners == Corners::Free {
                    w
                } else {
                    0
                };
                (margin, n + o as i64)
            }
        };
        let mut g = Geometry {
            n,
            h,
            margin,
            radius2,
            corners: params.corners,
            samples: params.samples,
            lines: Vec::new(),
            start: Vec::new(),
            nband: 0,
            band_px: Default::default(),
        };
        let s_cap = match params.corners {
            Corners::Pinned => n - 1,
            Corners::Free => n + 2 * margin + 2,
        };
        for s in 1..=s_cap {
            let mut lo = None;
            let mut hi = None;
            let mut count = 0i64;
            let mut d = -(s - 1);
            while d < s {
                if g.in_band(s, d) {
                    if lo.is_none() {
                        lo = Some(d);
                    }
                    hi = Some(d);
                    count += 1;
                }
                d += 2;
            }
            match (lo, hi) {
                (Some(lo), Some(hi)) => {
                    if (hi - lo) / 2 + 1 != count {
                        return Err(TilesynthError::param(
                            "overlap",
                            params.overlap,
                            format!("internal: band line {s} is not contiguous"),
                        ));
                    }
                    g.start.push(g.nband);
                    g.nband += count as usize;
                    g.lines.push((lo, hi));
                }
                _ => break,
            }
        }
        if g.corners == Corners::Pinned && g.lines.len() as i64 != n - 1 {
            return Err(TilesynthError::param(
                "overlap",
                params.overlap,
                "internal: the band does not reach the corner",
            ));
        }
        if (g.lines.len() as i64) < n - 1 {
            return Err(TilesynthError::param(
                "overlap",
                params.overlap,
                "internal: the band is shorter than the diagonal",
            ));
        }
        let mut band_px: [Vec<(i64, i64)>; 4] = Default::default();
        for (q, px) in band_px.iter_mut().enumerate() {
            px.reserve(g.nband);
            for (k, &(lo, hi)) in g.lines.iter().enumerate() {
                let s = k as i64 + 1;
                let mut d = lo;
                while d <= hi {
                    let (yc, xc) = g.canon(s, d);
                    px.push(g.flip(q, yc, xc));
                    d += 2;
                }
            }
        }
        g.band_px = band_px;
        Ok(g)
    }

    /// Side `P` of the sample squares (`N + 2 margin`): genes are their top-left corners.
    pub fn sample_size(&self) -> usize {
        (self.n + 2 * self.margin) as usize
    }

    /// Number of band pixels of one cut (`n_overlap`).
    pub fn band_size(&self) -> usize {
        self.nband
    }

    /// The `(lo, hi)` range of `d` on band line `s` (1-based), in the NE frame.
    pub fn line(&self, s: usize) -> Option<(i64, i64)> {
        s.checked_sub(1).and_then(|k| self.lines.get(k).copied())
    }

    /// Number of band lines.
    pub fn n_lines(&self) -> usize {
        self.lines.len()
    }

    /// NE-frame `(s, d)` to tile coordinates `(y, x)` (parity of `d` = parity of `s + 1`).
    #[inline(always)]
    fn canon(&self, s: i64, d: i64) -> (i64, i64) {
        ((d - s + self.n - 1) / 2, (d + s + self.n - 1) / 2)
    }

    /// NE-frame tile coordinates to the tile coordinates of cut `q` (NE, ES, SW, WN).
    #[inline(always)]
    fn flip(&self, q: usize, y: i64, x: i64) -> (i64, i64) {
        let m = self.n - 1;
        match q {
            0 => (y, x),
            1 => (m - y, x),
            2 => (m - y, m - x),
            _ => (y, m - x),
        }
    }

    /// Whether tile pixel `(y, x)` lies in the support of the sample of `role`.
    #[inline(always)]
    fn support(&self, role: usize, y: i64, x: i64) -> bool {
        let (cy, cx) = match role {
            NORTH => (0, self.n),
            EAST => (self.n, 2 * self.n),
            SOUTH => (2 * self.n, self.n),
            _ => (self.n, 0),
        };
        let (dy, dx) = ((2 * y + 1 - cy).abs(), (2 * x + 1 - cx).abs());
        match self.samples {
            Samples::Diamond => dy + dx <= self.radius2,
            Samples::Square => dy.max(dx) <= self.radius2,
        }
    }

    /// Whether NE-frame `(s, d)` is a band pixel.
    fn in_band(&self, s: i64, d: i64) -> bool {
        if s < 1 || d.abs() > s - 1 {
            return false;
        }
        let (y, x) = self.canon(s, d);
        if !(self.support(NORTH, y, x) && self.support(EAST, y, x)) {
            return false;
        }
        if self.corners == Corners::Pinned {
            if y < 0 || x > self.n - 1 {
                return false;
            }
            if x == self.n - 1 && y > 0 {
                return false;
            }
        }
        true
    }

    /// Exemplar `(row, col)` of tile pixel `(y, x)` in the sample of `role` with gene `g`.
    #[inline(always)]
    fn at(&self, role: usize, g: (i64, i64), y: i64, x: i64) -> (i64, i64) {
        let (oy, ox) = match role {
            NORTH => (self.h, 0),
            EAST => (0, -self.h),
            SOUTH => (-self.h, 0),
            _ => (0, self.h),
        };
        (g.0 + self.margin + oy + y, g.1 + self.margin + ox + x)
    }
}

/// One solved cut.
#[derive(Debug, Clone)]
struct Cut {
    d_overlap: f64,
    n_overlap: usize,
    d_path: f64,
    n_path: usize,
    cost: f64,
    /// NE-frame quadrant labels, `h x h` row-major over `(y, x - h)`: true = B. Empty unless asked for.
    takes_b: Vec<bool>,
}

impl Cut {
    fn boundary(&self, omega: f64, channels: usize) -> f64 {
        omega * self.d_overlap / self.n_overlap as f64
            + channels as f64 * (1.0 - omega) * self.d_path / self.n_path as f64
    }
}

/// Everything a cut needs: exemplar, geometry, method.
struct Solver<'a> {
    ex: &'a Exemplar,
    geo: &'a Geometry,
    cut: CutMethod,
    eps: f64,
}

impl Solver<'_> {
    /// Cut `q` between the samples with genes `ga` (role A of the cut) and `gb` (role B).
    fn solve(&self, q: usize, ga: (i64, i64), gb: (i64, i64), labels: bool) -> Result<Cut> {
        match self.cut {
            CutMethod::Dp => Ok(self.dp(q, ga, gb, labels)),
            CutMethod::Graph => self.graph(q, ga, gb, labels),
        }
    }

    /// The A and B pixels of NE-frame tile pixel `(yc, xc)` for cut `q`.
    #[inline(always)]
    fn pair(&self, q: usize, ga: (i64, i64), gb: (i64, i64), yc: i64, xc: i64) -> (&[f32], &[f32]) {
        let (ra, rb) = CUT_ROLES[q];
        let (y, x) = self.geo.flip(q, yc, xc);
        let (ar, ac) = self.geo.at(ra, ga, y, x);
        let (br, bc) = self.geo.at(rb, gb, y, x);
        (self.ex.px(ar, ac), self.ex.px(br, bc))
    }

    /// Squared colour difference (summed over channels) and squared luminance difference.
    #[inline(always)]
    fn errors(a: &[f32], b: &[f32]) -> (f64, f64) {
        let rgb = a
            .iter()
            .zip(b)
            .map(|(&u, &v)| {
                let d = u as f64 - v as f64;
                d * d
            })
            .sum::<f64>();
        let dy = luminance(a) - luminance(b);
        (rgb, dy * dy)
    }

    fn dp(&self, q: usize, ga: (i64, i64), gb: (i64, i64), labels: bool) -> Cut {
        let geo = self.geo;
        let ex = self.ex;
        let nb = geo.nband;
        let mut ey = vec![0.0f64; nb];
        let mut d_overlap = 0.0f64;
        // Pixel (y, x) of the sample of role r with gene g is exemplar pixel origin_r + y W + x.
        let (ra, rb) = CUT_ROLES[q];
        let width = ex.w as i64;
        let origin = |role: usize, g: (i64, i64)| {
            let (r, c) = geo.at(role, g, 0, 0);
            r * width + c
        };
        let (oa, ob) = (origin(ra, ga), origin(rb, gb));
        let c = ex.c;
        for (i, &(y, x)) in geo.band_px[q].iter().enumerate() {
            let rel = y * width + x;
            let (pa, pb) = ((oa + rel) as usize, (ob + rel) as usize);
            debug_assert!(pa < ex.h * ex.w && pb < ex.h * ex.w);
            let (a, b) = (&ex.data[pa * c..pa * c + c], &ex.data[pb * c..pb * c + c]);
            let mut rgb = 0.0f64;
            for (&u, &v) in a.iter().zip(b) {
                let d = u as f64 - v as f64;
                rgb += d * d;
            }
            d_overlap += rgb;
            let dl = ex.lum[pa] - ex.lum[pb];
            ey[i] = dl * dl;
        }
        // Cumulative minimum error; back[i] = true when the predecessor is d + 1 (else d - 1).
        let mut cum = vec![f64::INFINITY; nb];
        let mut back = vec![false; nb];
        cum[0] = ey[0];
        for k in 1..geo.lines.len() {
            let (lo, hi) = geo.lines[k];
            let (plo, phi) = geo.lines[k - 1];
            let (base, pbase) = (geo.start[k], geo.start[k - 1]);
            let mut d = lo;
            while d <= hi {
                let prev = |pd: i64| -> f64 {
                    if pd < plo || pd > phi {
                        f64::INFINITY
                    } else {
                        cum[pbase + ((pd - plo) / 2) as usize]
                    }
                };
                let (left, right) = (prev(d - 1), prev(d + 1));
                let i = base + ((d - lo) / 2) as usize;
                // ties go to d - 1 (towards A)
                if right < left {
                    cum[i] = ey[i] + right;
                    back[i] = true;
                } else {
                    cum[i] = ey[i] + left;
                }
                d += 2;
            }
        }
        let last = geo.lines.len() - 1;
        let (lo, hi) = geo.lines[last];
        let base = geo.start[last];
        let mut end = lo;
        let mut best = cum[base];
        let mut d = lo + 2;
        while d <= hi {
            let v = cum[base + ((d - lo) / 2) as usize];
            if v < best {
                best = v;
                end = d;
            }
            d += 2;
        }
        let mut path = vec![0i64; geo.lines.len()];
        let mut d = end;
        for k in (0..geo.lines.len()).rev() {
            path[k] = d;
            if k > 0 {
                let i = geo.start[k] + ((d - geo.lines[k].0) / 2) as usize;
                d = if back[i] { d + 1 } else { d - 1 };
            }
        }
        let takes_b = if labels {
            let (n, h) = (geo.n, geo.h);
            let mut out = Vec::with_capacity((h * h) as usize);
            for yc in 0..h {
                for xc in h..n {
                    let s = xc - yc;
                    let d = xc + yc - (n - 1);
                    out.push(d > path[(s - 1) as usize]);
                }
            }
            out
        } else {
            Vec::new()
        };
        Cut {
            d_overlap,
            n_overlap: nb,
            d_path: best,
            n_path: geo.lines.len(),
            cost: best,
            takes_b,
        }
    }

    fn graph(&self, q: usize, ga: (i64, i64), gb: (i64, i64), labels: bool) -> Result<Cut> {
        const FREE: u8 = 0;
        const A: u8 = 1;
        const B: u8 = 2;
        const OUT: u8 = 3;
        let geo = self.geo;
        let (n, h, m) = (geo.n, geo.h, geo.margin);
        let c = self.ex.c;
        let side = (h + m) as usize;
        let mut class = try_vec("tile_size", side * side, OUT)?;
        let mut a_img = try_array("tile_size", (side, side, c), 0.0f32)?;
        let mut b_img = try_array("tile_size", (side, side, c), 0.0f32)?;
        let mut ey = try_vec("tile_size", side * side, 0.0f64)?;
        let mut d_overlap = 0.0f64;
        let mut n_overlap = 0usize;
        let pinned = geo.corners == Corners::Pinned;
        for r in 0..side {
            let yc = r as i64 - m;
            for col in 0..side {
                let xc = h + col as i64;
                let (s, d) = (xc - yc, xc + yc - (n - 1));
                let i = r * side + col;
                let k = if col == 0 && yc >= 0 {
                    A
                } else if yc == h - 1 {
                    B
                } else if pinned && yc == 0 {
                    A
                } else if pinned && xc == n - 1 {
                    B
                } else if geo.in_band(s, d) {
                    FREE
                } else {
                    match geo.line(s as usize) {
                        Some((lo, _)) if d < lo => A,
                        Some((_, hi)) if d > hi => B,
                        _ => OUT,
                    }
                };
                class[i] = k;
                let (pa, pb) = self.pair(q, ga, gb, yc, xc);
                for ch in 0..c {
                    a_img[(r, col, ch)] = pa[ch];
                    b_img[(r, col, ch)] = pb[ch];
                }
                let (rgb, lum) = Self::errors(pa, pb);
                ey[i] = lum;
                // the overlap region is the band, as for the DP (some band pixels are tied to a terminal)
                if geo.in_band(s, d) {
                    d_overlap += rgb;
                    n_overlap += 1;
                }
            }
        }
        let (mut wx, mut wy) = kwatra_weights(a_img.view(), b_img.view(), None, self.eps, None)?;
        for r in 0..side {
            for col in 0..side {
                let i = r * side + col;
                if col + 1 < side && (class[i] == OUT || class[i + 1] == OUT) {
                    wx[(r, col)] = 0.0;
                }
                if r + 1 < side && (class[i] == OUT || class[i + side] == OUT) {
                    wy[(r, col)] = 0.0;
                }
            }
        }
        let src = Array2::from_shape_fn((side, side), |(r, col)| class[r * side + col] == A);
        let snk = Array2::from_shape_fn((side, side), |(r, col)| class[r * side + col] == B);
        let cut = grid_mincut(wx.view(), wy.view(), src.view(), snk.view(), None, None)?;
        let is_b = |r: usize, col: usize| cut.sink_side[(r, col)];
        let mut d_path = 0.0f64;
        let mut n_path = 0usize;
        for r in 0..side {
            for col in 0..side {
                let i = r * side + col;
                if class[i] == OUT || is_b(r, col) {
                    continue;
                }
                let mut seam = false;
                if col + 1 < side && class[i + 1] != OUT && is_b(r, col + 1) {
                    seam = true;
                }
                if col > 0 && class[i - 1] != OUT && is_b(r, col - 1) {
                    seam = true;
                }
                if r + 1 < side && class[i + side] != OUT && is_b(r + 1, col) {
                    seam = true;
                }
                if r > 0 && class[i - side] != OUT && is_b(r - 1, col) {
                    seam = true;
                }
                if seam {
                    d_path += ey[i];
                    n_path += 1;
                }
            }
        }
        let takes_b = if labels {
            let hh = h as usize;
            let mut out = try_with_capacity("tile_size", hh * hh)?;
            for yc in 0..hh {
                for col in 0..hh {
                    out.push(is_b(yc + m as usize, col));
                }
            }
            out
        } else {
            Vec::new()
        };
        Ok(Cut {
            d_overlap,
            n_overlap,
            d_path,
            n_path: n_path.max(1),
            cost: cut.flow,
            takes_b,
        })
    }
}

/// The tile set as gene indices of every tile's N, E, S, W samples, and the distinct cuts it needs.
#[derive(Debug, Clone)]
struct Layout {
    tiles: Vec<[usize; 4]>,
    n_samples: usize,
    /// Distinct `(cut, gene of A, gene of B)`.
    cuts: Vec<(usize, usize, usize)>,
    /// Index into `cuts` of every tile's four cuts.
    tile_cuts: Vec<[usize; 4]>,
}

impl Layout {
    fn new(tile_samples: ArrayView2<i64>, n_samples: usize) -> Result<Layout> {
        if n_samples == 0 {
            return Err(TilesynthError::param("n_samples", 0, "must be >= 1"));
        }
        let (k, four) = tile_samples.dim();
        if k == 0 || four != 4 {
            return Err(TilesynthError::shape(
                "tile_samples",
                "(K, 4) with K >= 1 (gene indices of the N, E, S, W samples)",
                fmt_shape(tile_samples.shape()),
            ));
        }
        let mut tiles = Vec::with_capacity(k);
        for j in 0..k {
            let mut t = [0usize; 4];
            for (r, slot) in t.iter_mut().enumerate() {
                let v = tile_samples[[j, r]];
                if v < 0 || v as u64 >= n_samples as u64 {
                    return Err(TilesynthError::param(
                        "tile_samples",
                        format!("{v} at [{j}, {r}]"),
                        format!("gene indices must lie in [0, n_samples) = [0, {n_samples})"),
                    ));
                }
                *slot = v as usize;
            }
            tiles.push(t);
        }
        let mut cuts: Vec<(usize, usize, usize)> = Vec::new();
        let mut tile_cuts = Vec::with_capacity(k);
        for t in &tiles {
            let mut idx = [0usize; 4];
            for (q, &(ra, rb)) in CUT_ROLES.iter().enumerate() {
                let key = (q, t[ra], t[rb]);
                idx[q] = match cuts.iter().position(|&c| c == key) {
                    Some(i) => i,
                    None => {
                        cuts.push(key);
                        cuts.len() - 1
                    }
                };
            }
            tile_cuts.push(idx);
        }
        Ok(Layout {
            tiles,
            n_samples,
            cuts,
            tile_cuts,
        })
    }
}

/// Validates `(P, n, 2)` genes against the exemplar and the sample size; returns `P * n` positions.
fn positions(
    genes: ArrayView3<i64>,
    n_samples: usize,
    ex: &Exemplar,
    p: usize,
) -> Result<Vec<(i64, i64)>> {
    let (pop, n, two) = genes.dim();
    if n != n_samples || two != 2 {
        return Err(TilesynthError::shape(
            "genes",
            format!("(P, {n_samples}, 2) (top-left row, col of every sample square)"),
            fmt_shape(genes.shape()),
        ));
    }
    if p > ex.h || p > ex.w {
        return Err(TilesynthError::param(
            "tile_size",
            p,
            format!(
                "the sample squares ({p} x {p}) are larger than the exemplar ({} rows, {} columns)",
                ex.h, ex.w
            ),
        ));
    }
    let (rmax, cmax) = ((ex.h - p) as i64, (ex.w - p) as i64);
    let mut out = try_with_capacity("genes", pop * n)?;
    for i in 0..pop {
        for g in 0..n {
            let (r, c) = (genes[[i, g, 0]], genes[[i, g, 1]]);
            if r < 0 || c < 0 || r > rmax || c > cmax {
                return Err(TilesynthError::param(
                    "genes",
                    format!("({r}, {c}) at [{i}, {g}]"),
                    format!(
                        "the {p} x {p} sample square must lie inside the exemplar (row in [0, {rmax}], col in [0, {cmax}])"
                    ),
                ));
            }
            out.push((r, c));
        }
    }
    Ok(out)
}

/// `E = ω Σ D + (1 − ω) Var(D)` (population variance), summed in order.
pub fn energy(d: &[f64], omega: f64) -> f64 {
    let m = d.len() as f64;
    let sum: f64 = d.iter().sum();
    let mean = sum / m;
    let var = d.iter().map(|&x| (x - mean) * (x - mean)).sum::<f64>() / m;
    omega * sum + (1.0 - omega) * var
}

/// A built Wang tile set: which sample every tile pixel takes, and the facts of every cut.
#[derive(Debug, Clone)]
pub struct WangTiles {
    /// `(K, N, N)` role of every pixel: 0 N, 1 E, 2 S, 3 W.
    pub labels: Array3<u8>,
    /// `(K, 4, 6)`: for the cuts NE, ES, SW, WN of every tile, `[D_overlap, n_overlap, D_path, n_path,
    /// D_boundary, cost]` (cost: the path's luminance error for DP, the max-flow value for graph cuts).
    pub stats: Array3<f64>,
}

/// Builds the labels and cut facts of every tile of `tile_samples` (`(K, 4)` gene indices of N, E, S, W)
/// with the samples at `genes` (`(n, 2)`, top-left corners of the sample squares, see
/// [`Geometry::sample_size`]). Parallel over the distinct cuts.
pub fn wang_tiles(
    exemplar: ArrayView3<f32>,
    genes: ArrayView2<i64>,
    tile_samples: ArrayView2<i64>,
    params: &WangParams,
) -> Result<WangTiles> {
    let ex = Exemplar::new(exemplar)?;
    let geo = Geometry::new(params)?;
    let layout = Layout::new(tile_samples, genes.nrows())?;
    let pos = positions(
        genes.insert_axis(Axis(0)),
        layout.n_samples,
        &ex,
        geo.sample_size(),
    )?;
    let solver = Solver {
        ex: &ex,
        geo: &geo,
        cut: params.cut,
        eps: params.eps,
    };
    let cuts: Vec<Result<Cut>> = layout
        .cuts
        .par_iter()
        .map(|&(q, ia, ib)| solver.solve(q, pos[ia], pos[ib], true))
        .collect();
    let cuts: Vec<Cut> = cuts.into_iter().collect::<Result<_>>()?;
    let k = layout.tiles.len();
    let n = params.tile_size;
    let h = n / 2;
    let mut labels = try_array("tile_size", (k, n, n), 0u8)?;
    let mut stats = try_array("tile_size", (k, 4, N_STATS), 0.0f64)?;
    for (t, idx) in layout.tile_cuts.iter().enumerate() {
        for (q, &ci) in idx.iter().enumerate() {
            let cut = &cuts[ci];
            let (ra, rb) = CUT_ROLES[q];
            for yc in 0..h {
                for xl in 0..h {
                    let (y, x) = geo.flip(q, yc as i64, (h + xl) as i64);
                    let role = if cut.takes_b[yc * h + xl] { rb } else { ra };
                    labels[(t, y as usize, x as usize)] = role as u8;
                }
            }
            let row = [
                cut.d_overlap,
                cut.n_overlap as f64,
                cut.d_path,
                cut.n_path as f64,
                cut.boundary(params.omega, ex.c),
                cut.cost,
            ];
            for (j, v) in row.into_iter().enumerate() {
                stats[(t, q, j)] = v;
            }
        }
    }
    Ok(WangTiles { labels, stats })
}

/// The objective of 001 (`E`, per-tile `D_sum`) for whole populations of gene vectors.
pub struct WangEvaluator {
    ex: Exemplar,
    geo: Geometry,
    layout: Layout,
    params: WangParams,
}

impl WangEvaluator {
    /// An evaluator for the tile set `tile_samples` (`(m, 4)` gene indices of N, E, S, W) with `n_samples`
    /// genes per individual.
    pub fn new(
        exemplar: ArrayView3<f32>,
        tile_samples: ArrayView2<i64>,
        n_samples: usize,
        params: WangParams,
    ) -> Result<WangEvaluator> {
        let ex = Exemplar::new(exemplar)?;
        let geo = Geometry::new(&params)?;
        let layout = Layout::new(tile_samples, n_samples)?;
        let p = geo.sample_size();
        if p > ex.h || p > ex.w {
            return Err(TilesynthError::param(
                "tile_size",
                params.tile_size,
                format!(
                    "the sample squares ({p} x {p}) are larger than the exemplar ({} rows, {} columns)",
                    ex.h, ex.w
                ),
            ));
        }
        Ok(WangEvaluator {
            ex,
            geo,
            layout,
            params,
        })
    }

    /// `(sample size P, n_samples, n_tiles)`.
    pub fn dims(&self) -> (usize, usize, usize) {
        (
            self.geo.sample_size(),
            self.layout.n_samples,
            self.layout.tiles.len(),
        )
    }

    /// `E` (`(P,)`) and `D_sum` (`(P, m)`) of the individuals `genes` (`(P, n, 2)`). Parallel over
    /// (individual, distinct cut); bit-identical at any thread count.
    pub fn evaluate(&self, genes: ArrayView3<i64>) -> Result<(Vec<f64>, Array2<f64>)> {
        let pos = positions(
            genes,
            self.layout.n_samples,
            &self.ex,
            self.geo.sample_size(),
        )?;
        let pop = genes.dim().0;
        let nc = self.layout.cuts.len();
        let n = self.layout.n_samples;
        let solver = Solver {
            ex: &self.ex,
            geo: &self.geo,
            cut: self.params.cut,
            eps: self.params.eps,
        };
        let vals: Vec<Result<f64>> = (0..pop * nc)
            .into_par_iter()
            .map(|item| {
                let (i, ci) = (item / nc, item % nc);
                let (q, ia, ib) = self.layout.cuts[ci];
                let cut = solver.solve(q, pos[i * n + ia], pos[i * n + ib], false)?;
                Ok(cut.boundary(self.params.omega, self.ex.c))
            })
            .collect();
        let vals: Vec<f64> = vals.into_iter().collect::<Result<_>>()?;
        let m = self.layout.tiles.len();
        let mut d = try_array("genes", (pop, m), 0.0f64)?;
        for i in 0..pop {
            for (t, idx) in self.layout.tile_cuts.iter().enumerate() {
                let mut sum = 0.0;
                for &ci in idx {
                    sum += vals[i * nc + ci];
                }
                d[(i, t)] = sum;
            }
        }
        let e = d
            .rows()
            .into_iter()
            .map(|row| energy(row.as_slice().expect("standard layout"), self.params.omega))
            .collect();
        Ok((e, d))
    }
}

/// Source (border ring) and sink (both diagonals, corner pixels excepted) pixels of 004's closed cut on an
/// `n x n` tile.
pub fn swang_terminals(n: usize) -> (Array2<bool>, Array2<bool>) {
    let border = Array2::from_shape_fn((n, n), |(y, x)| {
        y == 0 || x == 0 || y + 1 == n || x + 1 == n
    });
    let diag = Array2::from_shape_fn((n, n), |(y, x)| {
        (y == x || y + x + 1 == n) && !border[(y, x)]
    });
    (border, diag)
}

/// 004's closed cuts for `K` tiles: `initial` and `supplementary` `(K, N, N, C)`, `initial_grad` optionally
/// `(K, N, N, 2)` (gradient norms replacing those of the initial tiles, see [`kwatra_weights`]). Returns the
/// masks `(K, N, N)` (true = the pixel takes the supplementary patch) and the cut costs. Parallel over tiles.
pub fn swang_cuts(
    initial: ArrayView4<f32>,
    supplementary: ArrayView4<f32>,
    eps: f64,
    initial_grad: Option<ArrayView4<f64>>,
) -> Result<(Array3<bool>, Vec<f64>)> {
    let (k, n, n2, _) = initial.dim();
    if n != n2 || n < 4 {
        return Err(TilesynthError::shape(
            "initial",
            "(K, N, N, C) with N >= 4",
            fmt_shape(initial.shape()),
        ));
    }
    if supplementary.dim() != initial.dim() {
        return Err(TilesynthError::shape(
            "supplementary",
            format!("{} (the shape of initial)", fmt_shape(initial.shape())),
            fmt_shape(supplementary.shape()),
        ));
    }
    if let Some(g) = &initial_grad {
        if g.dim() != (k, n, n, 2) {
            return Err(TilesynthError::shape(
                "initial_grad",
                fmt_shape(&[k, n, n, 2]),
                fmt_shape(g.shape()),
            ));
        }
    }
    let (src, snk) = swang_terminals(n);
    let cuts: Vec<Result<(Array2<bool>, f64)>> = (0..k)
        .into_par_iter()
        .map(|t| {
            let (wx, wy) = kwatra_weights(
                initial.index_axis(Axis(0), t),
                supplementary.index_axis(Axis(0), t),
                None,
                eps,
                initial_grad.as_ref().map(|g| g.index_axis(Axis(0), t)),
            )?;
            let cut = grid_mincut(wx.view(), wy.view(), src.view(), snk.view(), None, None)?;
            Ok((cut.sink_side, cut.flow))
        })
        .collect();
    let mut masks = try_array("initial", (k, n, n), false)?;
    let mut costs = Vec::with_capacity(k);
    for (t, cut) in cuts.into_iter().enumerate() {
        let (mask, flow) = cut?;
        masks.index_axis_mut(Axis(0), t).assign(&mask);
        costs.push(flow);
    }
    Ok((masks, costs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::{arr2, Array4};

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

    fn params(
        n: usize,
        overlap: usize,
        corners: Corners,
        samples: Samples,
        cut: CutMethod,
    ) -> WangParams {
        WangParams {
            tile_size: n,
            overlap,
            corners,
            samples,
            cut,
            omega: DEFAULT_OMEGA,
            eps: 1e-6,
        }
    }

    /// The 8-tile set: N, S in {0, 1} (genes 0, 1), W, E in {0, 1} (genes 2, 3).
    fn set8() -> Array2<i64> {
        let mut rows = Vec::new();
        for n in 0..2i64 {
            for w in 0..2i64 {
                for j in 0..2i64 {
                    rows.push([n, 2 + (w + j) % 2, (n + j) % 2, 2 + w]);
                }
            }
        }
        Array2::from_shape_vec((8, 4), rows.concat()).unwrap()
    }

    #[test]
    fn band_geometry() {
        let g = Geometry::new(&params(
            16,
            4,
            Corners::Pinned,
            Samples::Diamond,
            CutMethod::Dp,
        ))
        .unwrap();
        assert_eq!(g.n_lines(), 15);
        assert_eq!(g.line(1), Some((0, 0)));
        assert_eq!(g.line(15), Some((0, 0)));
        assert_eq!(g.line(14), Some((-1, -1)));
        // mid-diagonal lines are limited by the overlap |d| <= 2
        assert_eq!(g.line(8), Some((-1, 1)));
        assert_eq!(g.line(7), Some((-2, 2)));
        assert_eq!(g.sample_size(), 16);
        let f = Geometry::new(&params(
            16,
            4,
            Corners::Free,
            Samples::Diamond,
            CutMethod::Dp,
        ))
        .unwrap();
        assert_eq!(f.sample_size(), 20);
        // the free band runs past the corner by w = 2 lines (up to s = N + w)
        assert_eq!(f.n_lines(), 18);
        assert_eq!(f.line(15), Some((-2, 2)));
        let sq = Geometry::new(&params(
            16,
            0,
            Corners::Pinned,
            Samples::Square,
            CutMethod::Dp,
        ))
        .unwrap();
        // the whole quadrant: |d| <= min(s - 1, N - 1 - s), right edge excluded
        assert_eq!(sq.line(8), Some((-7, 5)));
        assert!(Geometry::new(&params(
            16,
            4,
            Corners::Free,
            Samples::Square,
            CutMethod::Dp
        ))
        .is_err());
        assert!(Geometry::new(&params(
            16,
            3,
            Corners::Free,
            Samples::Diamond,
            CutMethod::Dp
        ))
        .is_err());
        assert!(Geometry::new(&params(
            6,
            0,
            Corners::Free,
            Samples::Diamond,
            CutMethod::Dp
        ))
        .is_err());
        assert!(Geometry::new(&params(
            7,
            2,
            Corners::Free,
            Samples::Diamond,
            CutMethod::Dp
        ))
        .is_err());
    }

    #[test]
    fn identical_samples_give_zero_error() {
        // an exemplar periodic with period h = 8: every role of one gene shows the same content
        let base = lcg_image(8, 8, 3, 1);
        let ex = Array3::from_shape_fn((40, 40, 3), |(y, x, c)| base[(y % 8, x % 8, c)]);
        let genes = arr2(&[[3i64, 4], [3, 4], [3, 4], [3, 4]]);
        for cut in [CutMethod::Dp, CutMethod::Graph] {
            let p = params(16, 4, Corners::Free, Samples::Diamond, cut);
            let t = wang_tiles(ex.view(), genes.view(), set8().view(), &p).unwrap();
            assert!(t.stats.iter().all(|v| v.is_finite()));
            for tile in 0..8 {
                for q in 0..4 {
                    assert_eq!(t.stats[(tile, q, 0)], 0.0);
                    assert_eq!(t.stats[(tile, q, 2)], 0.0);
                }
            }
        }
    }

    #[test]
    fn pinned_edges_show_their_sample() {
        let ex = lcg_image(50, 50, 3, 2);
        let genes = arr2(&[[0i64, 0], [10, 30], [25, 5], [31, 33]]);
        for (samples, cut) in [
            (Samples::Diamond, CutMethod::Dp),
            (Samples::Diamond, CutMethod::Graph),
            (Samples::Square, CutMethod::Dp),
            (Samples::Square, CutMethod::Graph),
        ] {
            let n = 16;
            let p = params(n, 6, Corners::Pinned, samples, cut);
            let t = wang_tiles(ex.view(), genes.view(), set8().view(), &p).unwrap();
            for k in 0..8 {
                for i in 0..n {
                    assert_eq!(t.labels[(k, 0, i)], NORTH as u8);
                    assert_eq!(t.labels[(k, n - 1, i)], SOUTH as u8);
                    if i > 0 && i + 1 < n {
                        assert_eq!(t.labels[(k, i, 0)], WEST as u8);
                        assert_eq!(t.labels[(k, i, n - 1)], EAST as u8);
                    }
                }
            }
        }
    }

    #[test]
    fn dp_is_the_minimum_over_all_paths() {
        // brute force over every staircase path of the band, N = 8
        let ex = lcg_image(30, 30, 3, 3);
        for corners in [Corners::Pinned, Corners::Free] {
            let p = params(8, 4, corners, Samples::Diamond, CutMethod::Dp);
            let geo = Geometry::new(&p).unwrap();
            let e = Exemplar::new(ex.view()).unwrap();
            let solver = Solver {
                ex: &e,
                geo: &geo,
                cut: CutMethod::Dp,
                eps: 1e-6,
            };
            for q in 0..4 {
                let (ga, gb) = ((1i64, 2i64), (9i64, 7i64));
                let cut = solver.solve(q, ga, gb, false).unwrap();
                let err = |s: i64, d: i64| {
                    let (yc, xc) = geo.canon(s, d);
                    let (a, b) = solver.pair(q, ga, gb, yc, xc);
                    Solver::errors(a, b).1
                };
                let lines = geo.n_lines() as i64;
                let mut best = f64::INFINITY;
                let mut stack = vec![(1i64, 0i64, err(1, 0))];
                while let Some((s, d, acc)) = stack.pop() {
                    if s == lines {
                        if corners == Corners::Free || d == 0 {
                            best = best.min(acc);
                        }
                        continue;
                    }
                    let (lo, hi) = geo.line((s + 1) as usize).unwrap();
                    for nd in [d - 1, d + 1] {
                        if nd >= lo && nd <= hi {
                            stack.push((s + 1, nd, acc + err(s + 1, nd)));
                        }
                    }
                }
                assert!(
                    (cut.d_path - best).abs() <= 1e-12 * best.max(1.0),
                    "{corners:?} {q}"
                );
            }
        }
    }

    #[test]
    fn evaluator_matches_build_and_thread_count() {
        let ex = lcg_image(48, 48, 3, 4);
        let genes =
            Array3::from_shape_fn((5, 4, 2), |(i, g, c)| ((i * 7 + g * 5 + c * 3) % 20) as i64);
        for cut in [CutMethod::Dp, CutMethod::Graph] {
            let p = params(16, 6, Corners::Free, Samples::Diamond, cut);
            let ev = WangEvaluator::new(ex.view(), set8().view(), 4, p.clone()).unwrap();
            let (e1, d1) = crate::parallel::install(Some(1), || ev.evaluate(genes.view()))
                .unwrap()
                .unwrap();
            let (e2, d2) = crate::parallel::install(Some(2), || ev.evaluate(genes.view()))
                .unwrap()
                .unwrap();
            assert_eq!(e1, e2);
            assert_eq!(d1, d2);
            for i in 0..5 {
                let g = genes.index_axis(Axis(0), i);
                let t = wang_tiles(ex.view(), g, set8().view(), &p).unwrap();
                for k in 0..8 {
                    let s: f64 = (0..4).map(|q| t.stats[(k, q, 4)]).sum();
                    assert_eq!(s, d1[(i, k)]);
                }
                let row: Vec<f64> = d1.row(i).to_vec();
                assert_eq!(energy(&row, p.omega), e1[i]);
            }
        }
        let p = params(16, 6, Corners::Free, Samples::Diamond, CutMethod::Dp);
        let ev = WangEvaluator::new(ex.view(), set8().view(), 4, p).unwrap();
        let bad = Array3::from_elem((1, 4, 2), 40i64);
        assert!(ev.evaluate(bad.view()).is_err());
        let wrong = Array3::from_elem((1, 3, 2), 0i64);
        assert!(ev.evaluate(wrong.view()).is_err());
    }

    #[test]
    fn swang_cut_is_closed_around_the_diagonals() {
        let n = 20;
        let a4: Array4<f32> = lcg_image(n, n, 3, 5).insert_axis(Axis(0));
        let b4: Array4<f32> = lcg_image(n, n, 3, 6).insert_axis(Axis(0));
        let (masks, costs) = swang_cuts(a4.view(), b4.view(), 1e-6, None).unwrap();
        let (src, snk) = swang_terminals(n);
        for ((&m, &s), &k) in masks.iter().zip(src.iter()).zip(snk.iter()) {
            if s {
                assert!(!m);
            }
            if k {
                assert!(m);
            }
        }
        assert!(!snk[(0, 0)] && src[(0, 0)] && snk[(1, 1)] && snk[(1, n - 2)]);
        assert!(costs[0] > 0.0);
        let (same, zero) = swang_cuts(a4.view(), a4.view(), 1e-6, None).unwrap();
        assert_eq!(zero[0], 0.0);
        assert_eq!(same.dim(), (1, n, n));
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::Exemplar;
    use crate::error::{assert_alloc_error, HUGE_SIDE};
    use ndarray::Array3;

    /// An exemplar whose copy cannot be allocated is an error naming `exemplar` (the Wang builder and the
    /// evaluator start with this copy; the per-cut and output arrays are allocated the same way).
    #[test]
    fn an_exemplar_that_cannot_be_copied_is_an_error() {
        let one = Array3::from_elem((1, 1, 1), 0.5f32);
        let big = one.broadcast((HUGE_SIDE, HUGE_SIDE, 3)).unwrap();
        assert_alloc_error(Exemplar::new(big).map(|e| e.h), "exemplar");
    }
}
