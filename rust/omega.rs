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
//! **The tile border.** The inscribed circle touches the tile border at the four side midpoints, and taken
//! literally (as in the reference data) the sink cross and the pixels inside the circle reach the border there:
//! `O` then shows on the border over a stretch of about `√N` pixels on each side of each midpoint, and, because
//! `O` differs from tile to tile, neighbouring ω-tiles no longer continue each other's content there (a short
//! visible seam across the tile border, measured at ~10% of border pixels for 188-pixel tiles). The paper wants the
//! curve to *pass through* the midpoints, i.e. to touch the border only there. With `keep_border = true` (the
//! default of the ω construction) every pixel of the one-pixel border ring is a source as well, and the cross
//! pixels on it are not sinks: `O` never reaches the border, so tiles that share corner patches are continuous
//! exemplar content across every border pixel; what remains of the cross seam is its last border pixel (a
//! one-pixel stub, the same on both sides of the border). `keep_border = false` is the literal definition above.

use crate::error::{
    fmt_shape, try_array, try_collect, try_standard, try_to_owned, try_vec, try_with_capacity,
    Result, TilesynthError,
};
use crate::maxflow::{planar_mincut, GridNetwork, MAX_INDEX, PX_FREE, PX_SINK, PX_SOURCE};
use ndarray::{Array2, Array3, ArrayView2, ArrayView3, ArrayView4, Axis, Zip};
use rayon::prelude::*;

use crate::seams::check_pair;
use crate::seams::{check_eps, check_grad};
pub use crate::seams::{kwatra_weights, DEFAULT_EPS};

/// Whether pixel `(y, x)` lies on the one-pixel border ring of an `n x n` tile.
#[inline]
pub fn on_border(n: usize, y: usize, x: usize) -> bool {
    y == 0 || x == 0 || y + 1 == n || x + 1 == n
}

/// Pixels of an `n x n` tile inside the inscribed circle `(y−c)² + (x−c)² ≤ (n/2)²`, `c = (n−1)/2`.
pub fn circle_mask(n: usize) -> Array2<bool> {
    let c = (n as f64 - 1.0) / 2.0;
    let r2 = (n as f64 / 2.0).powi(2);
    Array2::from_shape_fn((n, n), |(y, x)| {
        let (dy, dx) = (y as f64 - c, x as f64 - c);
        dy * dy + dx * dx <= r2
    })
}

/// The sink cross: rows and columns `n/2 − 1` and `n/2`, restricted to the inscribed circle, and with
/// `keep_border` also to pixels off the border ring.
pub fn cross_mask(n: usize, keep_border: bool) -> Array2<bool> {
    let c = classes(n, keep_border);
    Array2::from_shape_fn((n, n), |(y, x)| c[y * n + x] == SINK)
}

/// The source pixels: outside the inscribed circle, and with `keep_border` also the border ring.
pub fn source_mask(n: usize, keep_border: bool) -> Array2<bool> {
    let c = classes(n, keep_border);
    Array2::from_shape_fn((n, n), |(y, x)| c[y * n + x] == SOURCE)
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
///
/// `keep_border` ties the whole border ring to the source (see the module documentation).
pub fn omega_cut(
    i: ArrayView3<f32>,
    o: ArrayView3<f32>,
    eps: f64,
    i_grad: Option<ArrayView3<f64>>,
    keep_border: bool,
) -> Result<OmegaCut> {
    check_pair(&i, &o)?;
    let (h, w, c) = i.dim();
    if h != w || h % 2 != 0 || h < 2 {
        return Err(TilesynthError::shape(
            "intermediate",
            "(N, N, C) with N even and >= 2",
            fmt_shape(i.shape()),
        ));
    }
    check_grad(i_grad.as_ref(), h, w)?;
    check_eps(eps)?;
    let n = h;
    if n.checked_mul(n)
        .and_then(|v| v.checked_mul(4))
        .map_or(true, |v| v > MAX_INDEX)
    {
        return Err(TilesynthError::shape(
            "intermediate",
            "a tile with at most 2^30 - 1 pixels",
            fmt_shape(i.shape()),
        ));
    }
    let (i, o) = (
        try_standard("intermediate", i)?,
        try_standard("matching", o)?,
    );
    let grad = i_grad
        .map(|g| try_standard("intermediate_grad", g))
        .transpose()?;
    let tile = Tile {
        n,
        c,
        i: i.as_slice().expect("standard layout"),
        o: o.as_slice().expect("standard layout"),
        grad: grad
            .as_ref()
            .map(|g| g.as_slice().expect("standard layout")),
        eps,
        class: try_classes(n, keep_border)?,
    };
    // The sink cross separates the free pixels (inside the circle, off the cross) into four quadrants that
    // share no edge: four independent networks, solved in parallel and merged in a fixed order.
    let quads: Vec<(f64, Vec<bool>)> = (0..4usize)
        .into_par_iter()
        .map(|q| tile.solve_quadrant(q / 2, q % 2))
        .collect::<Result<_>>()?;
    let mut cost = tile.constant_flow();
    let mut takes_o = try_collect("intermediate", n * n, tile.class.iter().map(|&k| k == SINK))?;
    let m = n / 2 - 1;
    for (q, (flow, sink_side)) in quads.into_iter().enumerate() {
        cost += flow;
        let (y0, x0) = ((q / 2) * (n / 2 + 1), (q % 2) * (n / 2 + 1));
        for ly in 0..m {
            let row = (y0 + ly) * n + x0;
            for lx in 0..m {
                if tile.class[row + lx] == FREE_PX {
                    takes_o[row + lx] = sink_side[ly * m + lx];
                }
            }
        }
    }
    Ok(OmegaCut {
        takes_o: Array2::from_shape_vec((n, n), takes_o).expect("n * n labels"),
        cost,
    })
}

/// Pixel classes of the ω construction.
const FREE_PX: u8 = 0;
/// Outside the circle: tied to the source.
const SOURCE: u8 = 1;
/// On the sink cross.
const SINK: u8 = 2;

/// The class of every pixel of an `n x n` tile (row-major): outside the circle (or, with `keep_border`, on the
/// border ring) a source, else on the central cross a sink, else free.
fn classes(n: usize, keep_border: bool) -> Vec<u8> {
    try_classes(n, keep_border).unwrap_or_else(|e| panic!("{e}"))
}

/// [`classes`], allocated fallibly (the size is the caller's tile).
fn try_classes(n: usize, keep_border: bool) -> Result<Vec<u8>> {
    let c = (n as f64 - 1.0) / 2.0;
    let r2 = (n as f64 / 2.0).powi(2);
    let (a, b) = (n / 2 - 1, n / 2);
    try_collect(
        "intermediate",
        n * n,
        (0..n * n).map(|p| {
            let (y, x) = (p / n, p % n);
            let (dy, dx) = (y as f64 - c, x as f64 - c);
            let inside = dy * dy + dx * dx <= r2; // circle_mask(n)[(y, x)]
            if !inside || (keep_border && on_border(n, y, x)) {
                SOURCE
            } else if y == a || y == b || x == a || x == b {
                SINK
            } else {
                FREE_PX
            }
        }),
    )
}

/// L2 norm over channels of `s − t`, in f64 (summed in channel order).
#[inline(always)]
fn dist(s: &[f32], t: &[f32]) -> f64 {
    s.iter()
        .zip(t)
        .fold(0.0f64, |acc, (&u, &v)| {
            let d = u as f64 - v as f64;
            acc + d * d
        })
        .sqrt()
}

/// One ω problem, contiguous.
struct Tile<'a> {
    n: usize,
    c: usize,
    i: &'a [f32],
    o: &'a [f32],
    grad: Option<&'a [f64]>,
    eps: f64,
    class: Vec<u8>,
}

/// Per-pixel terms of the Kwatra weights over a rectangle: `‖I − O‖`, and the gradient norms of `I` and
/// `O` along x and y.
struct Terms {
    diff: Vec<f64>,
    gxa: Vec<f64>,
    gxb: Vec<f64>,
    gya: Vec<f64>,
    gyb: Vec<f64>,
}

impl Tile<'_> {
    #[inline(always)]
    fn px<'b>(&self, img: &'b [f32], p: usize) -> &'b [f32] {
        &img[p * self.c..p * self.c + self.c]
    }

    /// The terms of the rectangle `[ry0, ry0 + rh) x [rx0, rx0 + rw)` (row-major, width `rw`).
    fn terms(&self, ry0: usize, rx0: usize, rh: usize, rw: usize) -> Result<Terms> {
        match self.c {
            1 => self.terms_c::<1>(ry0, rx0, rh, rw),
            3 => self.terms_c::<3>(ry0, rx0, rh, rw),
            4 => self.terms_c::<4>(ry0, rx0, rh, rw),
            _ => self.terms_c::<0>(ry0, rx0, rh, rw),
        }
    }

    /// [`Tile::terms`] for `C` channels (`C = 0`: any count, `self.c`).
    #[inline(always)]
    fn terms_c<const C: usize>(
        &self,
        ry0: usize,
        rx0: usize,
        rh: usize,
        rw: usize,
    ) -> Result<Terms> {
        let n = self.n;
        let c = if C == 0 { self.c } else { C };
        let len = rh * rw;
        let mut t = Terms {
            diff: try_with_capacity("intermediate", len)?,
            gxa: try_with_capacity("intermediate", len)?,
            gxb: try_with_capacity("intermediate", len)?,
            gya: try_with_capacity("intermediate", len)?,
            gyb: try_with_capacity("intermediate", len)?,
        };
        for y in ry0..ry0 + rh {
            for x in rx0..rx0 + rw {
                let p = y * n + x;
                let (ip, op) = (&self.i[p * c..p * c + c], &self.o[p * c..p * c + c]);
                t.diff.push(dist(ip, op));
                let (gxa, gxb) = if x + 1 < n {
                    let (ia, ob) = (&self.i[(p + 1) * c..], &self.o[(p + 1) * c..]);
                    let ga = match self.grad {
                        Some(g) => g[2 * p],
                        None => dist(&ia[..c], ip),
                    };
                    (ga, dist(&ob[..c], op))
                } else {
                    (self.grad.map_or(0.0, |g| g[2 * p]), 0.0)
                };
                let (gya, gyb) = if y + 1 < n {
                    let (ia, ob) = (&self.i[(p + n) * c..], &self.o[(p + n) * c..]);
                    let ga = match self.grad {
                        Some(g) => g[2 * p + 1],
                        None => dist(&ia[..c], ip),
                    };
                    (ga, dist(&ob[..c], op))
                } else {
                    (self.grad.map_or(0.0, |g| g[2 * p + 1]), 0.0)
                };
                t.gxa.push(gxa);
                t.gxb.push(gxb);
                t.gya.push(gya);
                t.gyb.push(gyb);
            }
        }
        Ok(t)
    }

    /// The classes of quadrant `(qy, qx)` and the ring of pixels around it (`(m + 2)²`, row-major, as
    /// [`planar_mincut`] takes them): ring pixel `(i, j)` is the tile pixel `(y0 + i − 1, x0 + j − 1)`;
    /// pixels past the tile border count as sources (they have no edges, so this only fixes where the
    /// ring's terminal changes).
    fn ring_classes(&self, qy: usize, qx: usize) -> Result<Vec<u8>> {
        let n = self.n;
        let rn = n / 2 + 1;
        let (y0, x0) = (qy * (n / 2 + 1), qx * (n / 2 + 1));
        try_collect(
            "intermediate",
            rn * rn,
            (0..rn * rn).map(|k| {
                let (i, j) = (k / rn, k % rn);
                if y0 + i < 1 || y0 + i > n || x0 + j < 1 || x0 + j > n {
                    return PX_SOURCE;
                }
                match self.class[(y0 + i - 1) * n + x0 + j - 1] {
                    FREE_PX => PX_FREE,
                    SOURCE => PX_SOURCE,
                    _ => PX_SINK,
                }
            }),
        )
    }

    /// The min-cut of quadrant `(qy, qx)`: its free pixels, local `m x m` grid (`m = n/2 − 1`), edges to
    /// hard pixels folded into terminal links. Returns the flow and the local sink-side flags.
    fn solve_quadrant(&self, qy: usize, qx: usize) -> Result<(f64, Vec<bool>)> {
        let n = self.n;
        let m = n / 2 - 1;
        if m == 0 {
            return Ok((0.0, Vec::new()));
        }
        let (y0, x0) = (qy * (n / 2 + 1), qx * (n / 2 + 1));
        // The quadrant and the cross row / column next to it.
        let (ry0, rx0) = (y0 - qy, x0 - qx);
        let (rw, rh) = (m + 1, m + 1);
        let t = self.terms(ry0, rx0, rh, rw)?;
        let eps = self.eps;
        let wx = |r: usize| {
            let num = t.diff[r] + t.diff[r + 1];
            let den = t.gxa[r] + t.gxa[r + 1] + t.gxb[r] + t.gxb[r + 1] + eps;
            num / den
        };
        let wy = |r: usize| {
            let num = t.diff[r] + t.diff[r + rw];
            let den = t.gya[r] + t.gya[r + rw] + t.gyb[r] + t.gyb[r + rw] + eps;
            num / den
        };
        // The quadrant with the ring of pixels around it (cross, outside the circle, or past the tile
        // border) is s–t planar with both terminals on its outer face: a shortest path in the dual
        // (`maxflow::planar_mincut`, conditions checked there; they hold for every tile size, see the test
        // `every_quadrant_is_planar`).
        let rn = m + 2;
        let ring_class = self.ring_classes(qy, qx)?;
        // Ring pixel (i, j) is the tile pixel (y0 + i − 1, x0 + j − 1), the pixel (i + qy − 1, j + qx − 1)
        // of the terms' rectangle; the planar solver asks only for edges with a free end, whose other end
        // is in the rectangle whenever it is in the tile.
        let planar = planar_mincut(
            "intermediate",
            rn,
            rn,
            &ring_class,
            |i, j| {
                if x0 + j >= 1 && x0 + j < n {
                    wx((i + qy - 1) * rw + j + qx - 1)
                } else {
                    0.0
                }
            },
            |i, j| {
                if y0 + i >= 1 && y0 + i < n {
                    wy((i + qy - 1) * rw + j + qx - 1)
                } else {
                    0.0
                }
            },
        )?;
        if let Some((flow, sink_side)) = planar {
            let local = try_collect(
                "intermediate",
                m * m,
                (0..m * m).map(|l| sink_side[(l / m + 1) * rn + l % m + 1]),
            )?;
            return Ok((flow, local));
        }
        self.solve_quadrant_bk(m, (y0, x0), (ry0, rx0), rw, &wx, &wy)
    }

    /// [`Tile::solve_quadrant`] by the BK solver on the quadrant's free pixels (edges to hard pixels folded
    /// into terminal links): the fallback for quadrants the planar solver does not take, and its oracle.
    fn solve_quadrant_bk(
        &self,
        m: usize,
        (y0, x0): (usize, usize),
        (ry0, rx0): (usize, usize),
        rw: usize,
        wx: &dyn Fn(usize) -> f64,
        wy: &dyn Fn(usize) -> f64,
    ) -> Result<(f64, Vec<bool>)> {
        let n = self.n;
        let mut net = GridNetwork::new("intermediate", m, m)?;
        let class = &self.class;
        for ly in 0..m {
            let y = y0 + ly;
            for lx in 0..m {
                let x = x0 + lx;
                let g = y * n + x;
                if class[g] != FREE_PX {
                    continue;
                }
                let l = ly * m + lx;
                let r = (y - ry0) * rw + (x - rx0);
                let (mut cs, mut ck) = (0.0f64, 0.0f64);
                // Right and down: arcs to free pixels of the quadrant, else terminal links; left and up:
                // terminal links only (arcs between free pixels are made from the other side).
                if x + 1 < n {
                    let c = wx(r);
                    match class[g + 1] {
                        FREE_PX if lx + 1 < m && c > 0.0 => net.set_right(l, c),
                        SOURCE => cs += c,
                        SINK => ck += c,
                        _ => {}
                    }
                }
                if y + 1 < n {
                    let c = wy(r);
                    match class[g + n] {
                        FREE_PX if ly + 1 < m && c > 0.0 => net.set_down(l, c),
                        SOURCE => cs += c,
                        SINK => ck += c,
                        _ => {}
                    }
                }
                if x > 0 {
                    match class[g - 1] {
                        SOURCE => cs += wx(r - 1),
                        SINK => ck += wx(r - 1),
                        _ => {}
                    }
                }
                if y > 0 {
                    match class[g - n] {
                        SOURCE => cs += wy(r - rw),
                        SINK => ck += wy(r - rw),
                        _ => {}
                    }
                }
                net.set_terminal(l, cs, ck);
            }
        }
        net.solve()
    }

    /// The Kwatra weight of the edge `p`–`p + step` (`step` 1 or `n`), from scratch.
    fn weight(&self, p: usize, step: usize) -> f64 {
        let (n, c) = (self.n, self.c);
        let axis = usize::from(step != 1);
        let q = p + step;
        let grad = |img: &[f32], s: usize| -> f64 {
            let (y, x) = (s / n, s % n);
            if (axis == 0 && x + 1 >= n) || (axis == 1 && y + 1 >= n) {
                0.0
            } else {
                dist(
                    &img[(s + step) * c..(s + step) * c + c],
                    &img[s * c..s * c + c],
                )
            }
        };
        let ga = |s: usize| match self.grad {
            Some(g) => g[2 * s + axis],
            None => grad(self.i, s),
        };
        let num = dist(self.px(self.i, p), self.px(self.o, p))
            + dist(self.px(self.i, q), self.px(self.o, q));
        let den = ga(p) + ga(q) + grad(self.o, p) + grad(self.o, q) + self.eps;
        num / den
    }

    /// Flow of the edges between a source pixel and a sink pixel (always cut), in row-major order of the
    /// sink pixels.
    fn constant_flow(&self) -> f64 {
        let n = self.n;
        let mut flow = 0.0;
        for (p, &k) in self.class.iter().enumerate() {
            if k != SINK {
                continue;
            }
            let (y, x) = (p / n, p % n);
            if x + 1 < n && self.class[p + 1] == SOURCE {
                flow += self.weight(p, 1);
            }
            if y + 1 < n && self.class[p + n] == SOURCE {
                flow += self.weight(p, n);
            }
            if x > 0 && self.class[p - 1] == SOURCE {
                flow += self.weight(p - 1, 1);
            }
            if y > 0 && self.class[p - n] == SOURCE {
                flow += self.weight(p - n, n);
            }
        }
        flow
    }
}

/// [`omega_cut`] for K tiles at once, in parallel over tiles: `intermediate` and `matching` are `(K, N, N, C)`,
/// `intermediate_grad` optionally `(K, N, N, 2)`. Returns the masks `(K, N, N)` and the costs. Results do not
/// depend on the thread count.
pub fn omega_cuts(
    intermediate: ArrayView4<f32>,
    matching: ArrayView4<f32>,
    eps: f64,
    intermediate_grad: Option<ArrayView4<f64>>,
    keep_border: bool,
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
                keep_border,
            )
        })
        .collect();
    let mut masks = try_array("intermediate", (k, n, m), false)?;
    let mut costs = try_with_capacity("intermediate", k)?;
    for (t, cut) in cuts.into_iter().enumerate() {
        let cut = cut?;
        masks.index_axis_mut(Axis(0), t).assign(&cut.takes_o);
        costs.push(cut.cost);
    }
    Ok((masks, costs))
}

/// For every translation `t` of `image`, the sum of the Kwatra weights (as [`kwatra_weights`]) between `i`
/// (kept, `(N, M, C)`) and the candidate `O = image[t : t + (N, M)]` over a chosen set of edges: `wx_mask[y,
/// x]` selects edge (y,x)–(y,x+1) and `wy_mask[y, x]` edge (y,x)–(y+1,x). The candidate-selection heuristics of
/// 002 §3.2 ("the smallest sum of weights for the pixels around the circle", "... near the middle of the four
/// sides") rank the matching patches by this map. `i_grad` optionally replaces the gradient norms of `i`, as in
/// [`omega_cut`]; the gradients of each candidate are its own forward differences, 0 past its last row and
/// column (exactly the weights [`omega_cut`] would then use). Exact (direct `f64` sums, no FFT); cost
/// `O(translations x selected edges x C)`, parallel over rows of translations. Returns `(H − N + 1, W − M + 1)`.
pub fn edge_weight_sums(
    i: ArrayView3<f32>,
    i_grad: Option<ArrayView3<f64>>,
    image: ArrayView3<f32>,
    wx_mask: ArrayView2<bool>,
    wy_mask: ArrayView2<bool>,
    eps: f64,
) -> Result<Array2<f64>> {
    let (n, m, c) = i.dim();
    let (h, w, ci) = image.dim();
    if n == 0 || m == 0 || c == 0 {
        return Err(TilesynthError::shape(
            "template",
            "(N, M, C) with N, M, C >= 1",
            fmt_shape(i.shape()),
        ));
    }
    if ci != c || h < n || w < m {
        return Err(TilesynthError::shape(
            "image",
            format!("(H, W, {c}) with H >= {n} and W >= {m} (at least the template)"),
            fmt_shape(image.shape()),
        ));
    }
    for (name, mk) in [("wx_mask", &wx_mask), ("wy_mask", &wy_mask)] {
        if mk.dim() != (n, m) {
            return Err(TilesynthError::shape(
                name,
                fmt_shape(&[n, m]),
                fmt_shape(mk.shape()),
            ));
        }
    }
    check_grad(i_grad.as_ref(), n, m)?;
    check_eps(eps)?;
    if i.iter().chain(image.iter()).any(|v| !v.is_finite()) {
        return Err(TilesynthError::param(
            "template/image",
            "non-finite value",
            "images must not contain NaN or infinity",
        ));
    }
    let i = try_standard("template", i)?;
    let img = try_standard("image", image)?;
    let (iv, xv) = (
        i.as_slice().expect("standard layout"),
        img.as_slice().expect("standard layout"),
    );
    let d2 = |a: &[f32], b: &[f32]| -> f64 {
        a.iter()
            .zip(b)
            .map(|(&u, &v)| {
                let d = u as f64 - v as f64;
                d * d
            })
            .sum::<f64>()
            .sqrt()
    };
    // Gradient norms of the template (given, or its own forward differences) and of the image.
    let grad_i: Vec<[f64; 2]> = try_collect(
        "template",
        n * m,
        (0..n * m).map(|p| {
            let (y, x) = (p / m, p % m);
            match &i_grad {
                Some(g) => [g[(y, x, 0)], g[(y, x, 1)]],
                None => [
                    if x + 1 < m {
                        d2(&iv[(p + 1) * c..(p + 2) * c], &iv[p * c..p * c + c])
                    } else {
                        0.0
                    },
                    if y + 1 < n {
                        d2(&iv[(p + m) * c..(p + m + 1) * c], &iv[p * c..p * c + c])
                    } else {
                        0.0
                    },
                ],
            }
        }),
    )?;
    let grad_x: Vec<[f64; 2]> = try_collect(
        "image",
        h * w,
        (0..h * w).map(|p| {
            let (y, x) = (p / w, p % w);
            [
                if x + 1 < w {
                    d2(&xv[(p + 1) * c..(p + 2) * c], &xv[p * c..p * c + c])
                } else {
                    0.0
                },
                if y + 1 < h {
                    d2(&xv[(p + w) * c..(p + w + 1) * c], &xv[p * c..p * c + c])
                } else {
                    0.0
                },
            ]
        }),
    )?;
    // The selected edges, as indices into the list of the pixels they touch (each pixel's ‖I − O‖ and
    // candidate gradients are computed once per translation, not once per edge end).
    let mut slot = try_vec("template", n * m, usize::MAX)?;
    let mut touched: Vec<usize> = Vec::new();
    let mut edges: Vec<(usize, usize, usize)> = Vec::new();
    let mut index_of = |p: usize, touched: &mut Vec<usize>| -> usize {
        if slot[p] == usize::MAX {
            slot[p] = touched.len();
            touched.push(p);
        }
        slot[p]
    };
    for y in 0..n {
        for x in 0..m {
            let p = y * m + x;
            if wx_mask[(y, x)] && x + 1 < m {
                let (a, b) = (index_of(p, &mut touched), index_of(p + 1, &mut touched));
                edges.push((a, b, 0));
            }
            if wy_mask[(y, x)] && y + 1 < n {
                let (a, b) = (index_of(p, &mut touched), index_of(p + m, &mut touched));
                edges.push((a, b, 1));
            }
        }
    }
    // Per touched pixel: (local row, local col, its template gradients, whether it is on O's last column/row).
    let info: Vec<(usize, usize, [f64; 2], [bool; 2])> = touched
        .iter()
        .map(|&p| (p / m, p % m, grad_i[p], [p % m + 1 == m, p / m + 1 == n]))
        .collect();
    let (th, tw) = (h - n + 1, w - m + 1);
    let mut out = try_vec("image", th * tw, 0.0f64)?;
    out.par_chunks_mut(tw)
        .enumerate()
        .try_for_each(|(ty, row)| -> Result<()> {
            let mut diff = try_vec("template", touched.len(), 0.0f64)?;
            let mut go = try_vec("template", touched.len(), [0.0f64; 2])?;
            for (tx, out) in row.iter_mut().enumerate() {
                *out = {
                    for (k, &(y, x, _, last)) in info.iter().enumerate() {
                        let g = (ty + y) * w + tx + x;
                        let p = touched[k];
                        diff[k] = d2(&iv[p * c..p * c + c], &xv[g * c..g * c + c]);
                        let gx = grad_x[g];
                        go[k] = [
                            if last[0] { 0.0 } else { gx[0] },
                            if last[1] { 0.0 } else { gx[1] },
                        ];
                    }
                    let mut sum = 0.0f64;
                    for &(a, b, axis) in &edges {
                        let num = diff[a] + diff[b];
                        let den =
                            info[a].2[axis] + info[b].2[axis] + go[a][axis] + go[b][axis] + eps;
                        sum += num / den;
                    }
                    sum
                };
            }
            Ok(())
        })?;
    Ok(Array2::from_shape_vec((th, tw), out).expect("th * tw sums"))
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
    let mut out = try_to_owned("intermediate", i)?;
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
        let cross = cross_mask(n, false);
        assert_eq!(cross.iter().filter(|&&v| v).count(), 4 * 80 - 4);
        assert!(cross.iter().zip(inside.iter()).all(|(&c, &i)| !c || i));
        // keep_border: the eight cross pixels on the border ring become sources, the ring is all source.
        let kept = cross_mask(n, true);
        assert_eq!(kept.iter().filter(|&&v| v).count(), 4 * 80 - 4 - 8);
        let src = source_mask(n, true);
        for i in 0..n {
            assert!(src[(0, i)] && src[(n - 1, i)] && src[(i, 0)] && src[(i, n - 1)]);
        }
        assert!(!src[(1, 39)] && kept[(1, 39)]);
        let literal = source_mask(n, false);
        assert_eq!(literal, inside.mapv(|v| !v));
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
        let cut = omega_cut(a.view(), a.view(), DEFAULT_EPS, None, true).unwrap();
        assert_eq!(cut.cost, 0.0);
    }

    #[test]
    fn cut_respects_terminals() {
        let n = 32;
        let a = lcg_image(n, n, 3, 3);
        let b = lcg_image(n, n, 3, 4);
        for keep_border in [false, true] {
            let cut = omega_cut(a.view(), b.view(), DEFAULT_EPS, None, keep_border).unwrap();
            let src = source_mask(n, keep_border);
            let cross = cross_mask(n, keep_border);
            for ((&t, &s), &c) in cut.takes_o.iter().zip(src.iter()).zip(cross.iter()) {
                if s {
                    assert!(!t);
                }
                if c {
                    assert!(t);
                }
            }
            assert!(cut.cost > 0.0);
            if keep_border {
                for i in 0..n {
                    assert!(!cut.takes_o[(0, i)] && !cut.takes_o[(i, 0)]);
                    assert!(!cut.takes_o[(n - 1, i)] && !cut.takes_o[(i, n - 1)]);
                }
            }
        }
        let cut = omega_cut(a.view(), b.view(), DEFAULT_EPS, None, true).unwrap();
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
            omega_cuts(ii.view(), oo.view(), DEFAULT_EPS, None, true)
        })
        .unwrap()
        .unwrap();
        let two = crate::parallel::install(Some(2), || {
            omega_cuts(ii.view(), oo.view(), DEFAULT_EPS, None, true)
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
                true,
            )
            .unwrap();
            assert_eq!(single.cost, one.1[t]);
        }
    }

    /// The fused per-quadrant path equals the plain pipeline: full weights, then one grid min-cut.
    #[test]
    fn fused_cut_equals_weights_plus_grid_mincut() {
        for (n, ch, seed) in [
            (2, 3, 1),
            (4, 3, 2),
            (6, 1, 3),
            (8, 4, 4),
            (10, 2, 5),
            (30, 3, 6),
            (48, 3, 7),
        ] {
            let a = lcg_image(n, n, ch, seed);
            let b = lcg_image(n, n, ch, seed + 100);
            let grad = Array3::from_shape_fn((n, n, 2), |(y, x, k)| {
                ((y * 7 + x * 3 + k) % 5) as f64 * 0.1
            });
            for (g, keep_border) in [
                (None, false),
                (Some(grad.view()), false),
                (None, true),
                (Some(grad.view()), true),
            ] {
                let inside = circle_mask(n);
                let (wx, wy) =
                    kwatra_weights(a.view(), b.view(), Some(inside.view()), DEFAULT_EPS, g)
                        .unwrap();
                let want = crate::maxflow::grid_mincut(
                    wx.view(),
                    wy.view(),
                    source_mask(n, keep_border).view(),
                    cross_mask(n, keep_border).view(),
                    None,
                    None,
                )
                .unwrap();
                let got = omega_cut(a.view(), b.view(), DEFAULT_EPS, g, keep_border).unwrap();
                assert_eq!(got.takes_o, want.sink_side, "n {n}");
                assert!(
                    (got.cost - want.flow).abs() <= 1e-12 * want.flow.abs().max(1.0),
                    "n {n}: {} != {}",
                    got.cost,
                    want.flow
                );
            }
        }
    }

    /// The map equals the masked sum of `kwatra_weights` of the template and each cut-out candidate.
    #[test]
    fn edge_weight_sums_equal_masked_kwatra_sums() {
        let (n, m) = (6, 5);
        let img = lcg_image(11, 9, 3, 41);
        let t = lcg_image(n, m, 3, 42);
        let grad = Array3::from_shape_fn((n, m, 2), |(y, x, k)| ((y + 2 * x + k) % 4) as f64 * 0.2);
        let wxm = Array2::from_shape_fn((n, m), |(y, x)| (y + x) % 3 != 0);
        let wym = Array2::from_shape_fn((n, m), |(y, x)| (y * x) % 2 == 0);
        for g in [None, Some(grad.view())] {
            let got =
                edge_weight_sums(t.view(), g, img.view(), wxm.view(), wym.view(), 1e-6).unwrap();
            assert_eq!(got.dim(), (11 - n + 1, 9 - m + 1));
            for ty in 0..=11 - n {
                for tx in 0..=9 - m {
                    let o = img
                        .slice(ndarray::s![ty..ty + n, tx..tx + m, ..])
                        .to_owned();
                    let (wx, wy) = kwatra_weights(t.view(), o.view(), None, 1e-6, g).unwrap();
                    let want: f64 = wx
                        .iter()
                        .zip(wxm.iter())
                        .chain(wy.iter().zip(wym.iter()))
                        .filter(|(_, &k)| k)
                        .map(|(v, _)| v)
                        .sum();
                    let v = got[(ty, tx)];
                    assert!((v - want).abs() <= 1e-12 * want.max(1.0), "{v} vs {want}");
                }
            }
        }
        let bad = Array2::from_elem((n, m + 1), true);
        let e =
            edge_weight_sums(t.view(), None, img.view(), bad.view(), wym.view(), 1e-6).unwrap_err();
        assert!(e.to_string().contains("wx_mask"), "{e}");
    }

    /// Every quadrant of every tile size meets the planar solver's conditions (so BK is only a fallback).
    #[test]
    fn every_quadrant_is_planar() {
        for n in (4..=400).step_by(2).chain([512, 1024]) {
            for keep_border in [false, true] {
                let a = Array3::<f32>::zeros((n, n, 1));
                let tile = Tile {
                    n,
                    c: 1,
                    i: a.as_slice().unwrap(),
                    o: a.as_slice().unwrap(),
                    grad: None,
                    eps: DEFAULT_EPS,
                    class: classes(n, keep_border),
                };
                for q in 0..4 {
                    let rc = tile.ring_classes(q / 2, q % 2).unwrap();
                    let rn = n / 2 + 1;
                    assert!(
                        crate::maxflow::planar_applies(rn, rn, &rc),
                        "n {n} keep_border {keep_border} quadrant {q}"
                    );
                }
            }
        }
    }

    #[test]
    fn errors_name_the_parameter() {
        let a = lcg_image(5, 5, 3, 1);
        let e = omega_cut(a.view(), a.view(), DEFAULT_EPS, None, true).unwrap_err();
        assert!(e.to_string().contains("intermediate"), "{e}");
        let b = lcg_image(6, 6, 3, 1);
        let e = omega_cut(b.view(), a.view(), DEFAULT_EPS, None, true).unwrap_err();
        assert!(e.to_string().contains("matching"), "{e}");
        let e = kwatra_weights(b.view(), b.view(), None, 0.0, None).unwrap_err();
        assert!(e.to_string().contains("eps"), "{e}");
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::try_classes;
    use crate::error::{assert_alloc_error, HUGE_SIDE};

    /// The per-tile arrays of the omega cut (pixel classes, then the Kwatra terms and the quadrant networks,
    /// allocated the same way) that cannot be allocated are an error naming `intermediate`.
    #[test]
    fn tile_arrays_that_cannot_be_allocated_are_errors() {
        assert_alloc_error(try_classes(HUGE_SIDE * 4, true), "intermediate");
        assert_eq!(try_classes(8, true).unwrap(), super::classes(8, true));
    }
}
