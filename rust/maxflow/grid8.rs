//! Min-cut on an 8-connected pixel grid (the free-region ω cut with Euclidean-like cut lengths, issue 12).
//!
//! The same reduction as the 4-connected front end ([`super::grid_mincut`]): every pixel is a node, only
//! free pixels get arcs or terminal links, an edge between a free pixel and a hard pixel becomes terminal
//! link capacity of the free pixel, an edge between a hard-source and a hard-sink pixel only adds to the
//! flow. The two diagonal edges of every pixel sit at fixed slots next to the axis ones (`Grid8Topo`). The
//! reduced network is solved by the one BK solver of [`super`], so the labelling rule is the same.
//!
//! The weights are the caller's: with Boykov & Kolmogorov's geo-cut factors ("Computing geodesics and
//! minimal surfaces via graph cuts", ICCV 2003) the cost of a cut approximates its Euclidean length, where
//! on a 4-connected grid every monotone staircase costs as much as the diagonal it follows (L1 length).

use super::grid::{
    check_edge_caps, check_shape, check_terminal_shapes, check_terminal_values, grid_cut, GridCut,
};
use super::{Network, Topology, MAX_INDEX};
use crate::error::{fmt_shape, try_standard, try_vec, Result, TilesynthError};
use ndarray::ArrayView2;

/// The neighbour steps `(dy, dx)` of the four forward edges of a pixel, in slot order: right, down,
/// down-right, down-left.
const FORWARD: [(usize, isize); 4] = [(0, 1), (1, 0), (1, 1), (1, -1)];

/// Min-cut on an 8-connected `H x W` pixel grid with symmetric edge capacities and terminal constraints.
///
/// `wx`, `wy`, the hard masks and the soft terminal capacities are those of [`super::grid_mincut`]; in
/// addition
/// - `wd[y, x]`: capacity of the diagonal edge `(y, x)`–`(y + 1, x + 1)` (last row and column ignored);
/// - `wa[y, x]`: capacity of the anti-diagonal edge `(y, x)`–`(y + 1, x - 1)` (last row and first column
///   ignored);
///
/// both `(H, W)`, finite and `>= 0`. Returns the labelling (rule of [`GridCut::sink_side`]) and the flow
/// value, which equals [`grid_cut_cost8`] of the labelling. With `wd` and `wa` zero the result is that of
/// [`super::grid_mincut`]. Errors as [`super::grid_mincut`], naming `wd` / `wa` for their own problems.
#[allow(clippy::too_many_arguments)]
pub fn grid_mincut8(
    wx: ArrayView2<f64>,
    wy: ArrayView2<f64>,
    wd: ArrayView2<f64>,
    wa: ArrayView2<f64>,
    source_hard: ArrayView2<bool>,
    sink_hard: ArrayView2<bool>,
    source_cap: Option<ArrayView2<f64>>,
    sink_cap: Option<ArrayView2<f64>>,
) -> Result<GridCut> {
    let (h, w) = wx.dim();
    if h == 0 || w == 0 {
        return Err(TilesynthError::shape(
            "wx",
            "(H, W) with H, W >= 1",
            fmt_shape(wx.shape()),
        ));
    }
    let expected = fmt_shape(&[h, w]);
    check_shape("wy", wy.shape(), h, w, &expected)?;
    check_shape("wd", wd.shape(), h, w, &expected)?;
    check_shape("wa", wa.shape(), h, w, &expected)?;
    check_terminal_shapes(
        source_hard,
        sink_hard,
        source_cap,
        sink_cap,
        h,
        w,
        &expected,
    )?;
    if h.checked_mul(w)
        .and_then(|n| n.checked_mul(8))
        .map_or(true, |m| m > MAX_INDEX)
    {
        return Err(TilesynthError::shape(
            "wx",
            "a grid with at most 2^29 - 1 pixels",
            expected,
        ));
    }
    check_edge_caps("wx", wx, h, 0..w - 1)?;
    check_edge_caps("wy", wy, h - 1, 0..w)?;
    check_edge_caps("wd", wd, h - 1, 0..w - 1)?;
    // wa: rows 0..h-1, columns 1..w (an anti-diagonal edge leaves every pixel but those of column 0).
    check_edge_caps("wa", wa, h - 1, 1..w)?;
    check_terminal_values(source_hard, sink_hard, source_cap, sink_cap, h, w)?;
    let caps = [
        try_standard("wx", wx)?,
        try_standard("wy", wy)?,
        try_standard("wd", wd)?,
        try_standard("wa", wa)?,
    ];
    let caps: [&[f64]; 4] = [0, 1, 2, 3].map(|k| caps[k].as_slice().expect("standard layout"));
    let src_hard = try_standard("source_hard", source_hard)?;
    let snk_hard = try_standard("sink_hard", sink_hard)?;
    let src_hard = src_hard.as_slice().expect("standard layout");
    let snk_hard = snk_hard.as_slice().expect("standard layout");
    let src_cap = source_cap
        .map(|c| try_standard("source_cap", c))
        .transpose()?;
    let snk_cap = sink_cap.map(|c| try_standard("sink_cap", c)).transpose()?;
    let src_cap = src_cap
        .as_ref()
        .map(|c| c.as_slice().expect("standard layout"));
    let snk_cap = snk_cap
        .as_ref()
        .map(|c| c.as_slice().expect("standard layout"));

    let mut net = build8(h, w, caps, src_hard, snk_hard, src_cap, snk_cap)?;
    let sol = net.solve("wx")?;
    grid_cut(h, w, src_hard, snk_hard, &sol.sink_side, sol.flow)
}

/// 8-connected grid adjacency. Node `p` is the pixel `(p / w, p % w)`; its four forward edges (right,
/// down, down-right, down-left: [`FORWARD`]) hold the arcs `8p + 2k` (away from `p`) and `8p + 2k + 1`
/// (back), `k = 0..4`. `dirs[p]` has bit `k` set when the arc along forward edge `k` is in use and bit
/// `4 + k` when the arc from `p` back along the forward edge `k` of the neighbour `p - step_k` is.
#[derive(Debug, Clone)]
struct Grid8Topo {
    w: u32,
    dirs: Vec<u8>,
}

impl Grid8Topo {
    /// The index step of forward edge `k` (`w + 1` for down-right etc.).
    #[inline]
    fn step(&self, k: u32) -> u32 {
        match k {
            0 => 1,
            1 => self.w,
            2 => self.w + 1,
            _ => self.w - 1,
        }
    }
}

/// Iterator over the arcs of one 8-connected grid node.
struct Grid8Arcs<'a> {
    topo: &'a Grid8Topo,
    p: u32,
    mask: u8,
}

impl Iterator for Grid8Arcs<'_> {
    type Item = (u32, u32);

    #[inline]
    fn next(&mut self) -> Option<(u32, u32)> {
        if self.mask == 0 {
            return None;
        }
        let d = self.mask.trailing_zeros();
        self.mask &= self.mask - 1;
        let p = self.p;
        Some(if d < 4 {
            (8 * p + 2 * d, p + self.topo.step(d))
        } else {
            let q = p - self.topo.step(d - 4);
            (8 * q + 2 * (d - 4) + 1, q)
        })
    }
}

impl Topology for Grid8Topo {
    #[inline]
    fn arcs(&self, i: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        Grid8Arcs {
            topo: self,
            p: i,
            mask: self.dirs[i as usize],
        }
    }

    #[inline]
    fn head(&self, a: u32) -> u32 {
        let p = a >> 3;
        if a & 1 == 1 {
            p
        } else {
            p + self.step((a >> 1) & 3)
        }
    }
}

/// The neighbour of pixel `(y, x)` along forward edge `k` (`None` past the grid).
#[inline]
fn forward(h: usize, w: usize, y: usize, x: usize, k: usize) -> Option<usize> {
    let (dy, dx) = FORWARD[k];
    let (ty, tx) = (y + dy, x as isize + dx);
    (ty < h && tx >= 0 && (tx as usize) < w).then(|| ty * w + tx as usize)
}

/// The neighbour of pixel `(y, x)` against forward edge `k`, i.e. the pixel whose edge `k` ends at `(y, x)`.
#[inline]
fn backward(w: usize, y: usize, x: usize, k: usize) -> Option<usize> {
    let (dy, dx) = FORWARD[k];
    let tx = x as isize - dx;
    (y >= dy && tx >= 0 && (tx as usize) < w).then(|| (y - dy) * w + tx as usize)
}

/// Builds the reduced residual network of [`grid_mincut8`] (hard pixels folded into terminal links and
/// constant flow).
fn build8(
    h: usize,
    w: usize,
    caps: [&[f64]; 4],
    src_hard: &[bool],
    snk_hard: &[bool],
    src_cap: Option<&[f64]>,
    snk_cap: Option<&[f64]>,
) -> Result<Network<Grid8Topo>> {
    let np = h * w;
    let mut flow = 0.0f64;
    let mut rcap = try_vec("wx", 8 * np, 0.0f64)?;
    let mut dirs = try_vec("wx", np, 0u8)?;
    let mut tr = try_vec("wx", np, 0.0f64)?;
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if src_hard[p] || snk_hard[p] {
                // Constant terms of hard pixels: a soft link to the other terminal, an edge to a pixel tied
                // to the other terminal (counted once, from the hard-source side).
                if src_hard[p] {
                    if let Some(c) = snk_cap {
                        flow += c[p];
                    }
                    for (k, cap) in caps.iter().enumerate() {
                        if let Some(q) = forward(h, w, y, x, k) {
                            if snk_hard[q] {
                                flow += cap[p];
                            }
                        }
                        if let Some(q) = backward(w, y, x, k) {
                            if snk_hard[q] {
                                flow += cap[q];
                            }
                        }
                    }
                } else if let Some(c) = src_cap {
                    flow += c[p];
                }
                continue;
            }
            let mut cs = src_cap.map_or(0.0, |c| c[p]);
            let mut ck = snk_cap.map_or(0.0, |c| c[p]);
            for (k, cap) in caps.iter().enumerate() {
                // Forward edges: arcs between free pixels; backward ones: only links to hard pixels (the
                // arcs were made from the other side).
                if let Some(q) = forward(h, w, y, x, k) {
                    let c = cap[p];
                    if c > 0.0 {
                        if src_hard[q] {
                            cs += c;
                        } else if snk_hard[q] {
                            ck += c;
                        } else {
                            rcap[8 * p + 2 * k] = c;
                            rcap[8 * p + 2 * k + 1] = c;
                            dirs[p] |= 1 << k;
                            dirs[q] |= 1 << (4 + k);
                        }
                    }
                }
                if let Some(q) = backward(w, y, x, k) {
                    let c = cap[q];
                    if src_hard[q] {
                        cs += c;
                    } else if snk_hard[q] {
                        ck += c;
                    }
                }
            }
            flow += cs.min(ck);
            tr[p] = cs - ck;
        }
    }
    Ok(Network {
        topo: Grid8Topo { w: w as u32, dirs },
        rcap,
        tr,
        flow,
    })
}

/// The cost of the cut given by `labels` (`true` = sink side) on the 8-connected grid: the capacities of
/// the edges between pixels with different labels (ignored entries excepted, see [`grid_mincut8`]), plus
/// the cut soft links, plus `f64::INFINITY` if a hard constraint is violated. Capacities are not
/// validated beyond their shapes.
#[allow(clippy::too_many_arguments)]
pub fn grid_cut_cost8(
    wx: ArrayView2<f64>,
    wy: ArrayView2<f64>,
    wd: ArrayView2<f64>,
    wa: ArrayView2<f64>,
    source_hard: Option<ArrayView2<bool>>,
    sink_hard: Option<ArrayView2<bool>>,
    source_cap: Option<ArrayView2<f64>>,
    sink_cap: Option<ArrayView2<f64>>,
    labels: ArrayView2<bool>,
) -> Result<f64> {
    let (h, w) = labels.dim();
    let expected = fmt_shape(&[h, w]);
    check_shape("wd", wd.shape(), h, w, &expected)?;
    check_shape("wa", wa.shape(), h, w, &expected)?;
    let mut cost =
        super::grid_cut_cost(wx, wy, source_hard, sink_hard, source_cap, sink_cap, labels)?;
    for y in 0..h.saturating_sub(1) {
        for x in 0..w {
            let l = labels[(y, x)];
            if x + 1 < w && l != labels[(y + 1, x + 1)] {
                cost += wd[(y, x)];
            }
            if x > 0 && l != labels[(y + 1, x - 1)] {
                cost += wa[(y, x)];
            }
        }
    }
    Ok(cost)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{close, SplitMix};
    use super::super::{grid_mincut, Graph};
    use super::*;
    use ndarray::Array2;

    struct Case {
        w: [Array2<f64>; 4],
        src_hard: Array2<bool>,
        snk_hard: Array2<bool>,
        src_cap: Option<Array2<f64>>,
        snk_cap: Option<Array2<f64>>,
    }

    impl Case {
        fn solve(&self) -> Result<GridCut> {
            grid_mincut8(
                self.w[0].view(),
                self.w[1].view(),
                self.w[2].view(),
                self.w[3].view(),
                self.src_hard.view(),
                self.snk_hard.view(),
                self.src_cap.as_ref().map(|c| c.view()),
                self.snk_cap.as_ref().map(|c| c.view()),
            )
        }

        fn cost(&self, labels: ArrayView2<bool>) -> f64 {
            grid_cut_cost8(
                self.w[0].view(),
                self.w[1].view(),
                self.w[2].view(),
                self.w[3].view(),
                Some(self.src_hard.view()),
                Some(self.snk_hard.view()),
                self.src_cap.as_ref().map(|c| c.view()),
                self.snk_cap.as_ref().map(|c| c.view()),
                labels,
            )
            .unwrap()
        }

        /// The minimum of [`grid_cut_cost8`] over all labellings (written independently of the solver).
        fn brute_force(&self) -> f64 {
            let (h, w) = self.src_hard.dim();
            let n = h * w;
            assert!(n <= 16);
            let mut labels = Array2::from_elem((h, w), false);
            let mut best = f64::INFINITY;
            for mask in 0u32..(1 << n) {
                for (p, l) in labels.iter_mut().enumerate() {
                    *l = mask >> p & 1 == 1;
                }
                best = best.min(self.cost(labels.view()));
            }
            best
        }

        /// The same problem on the general graph, every pixel a node, hard links infinite.
        fn general(&self) -> (f64, Array2<bool>) {
            let (h, w) = self.src_hard.dim();
            let mut g = Graph::new(h * w);
            for y in 0..h {
                for x in 0..w {
                    let p = y * w + x;
                    for (k, cap) in self.w.iter().enumerate() {
                        if let Some(q) = forward(h, w, y, x, k) {
                            g.add_edge(p, q, cap[(y, x)], cap[(y, x)]);
                        }
                    }
                    let inf = |b: bool| if b { f64::INFINITY } else { 0.0 };
                    g.add_tweights(p, inf(self.src_hard[(y, x)]), inf(self.snk_hard[(y, x)]));
                    g.add_tweights(
                        p,
                        self.src_cap.as_ref().map_or(0.0, |c| c[(y, x)]),
                        self.snk_cap.as_ref().map_or(0.0, |c| c[(y, x)]),
                    );
                }
            }
            let f = g.maxflow();
            (
                f,
                Array2::from_shape_vec((h, w), g.sink_side().to_vec()).unwrap(),
            )
        }

        fn check(&self, what: &str) -> GridCut {
            let cut = self.solve().unwrap();
            let cost = self.cost(cut.sink_side.view());
            assert!(
                close(cost, cut.flow),
                "{what}: cut cost {cost} != flow {}",
                cut.flow
            );
            for ((y, x), &s) in cut.sink_side.indexed_iter() {
                assert!(
                    !(self.src_hard[(y, x)] && s),
                    "{what}: hard source on the sink side"
                );
                assert!(
                    !self.snk_hard[(y, x)] || s,
                    "{what}: hard sink on the source side"
                );
            }
            let (gf, glabels) = self.general();
            assert!(
                close(gf, cut.flow),
                "{what}: general {gf} != grid {}",
                cut.flow
            );
            assert_eq!(
                glabels, cut.sink_side,
                "{what}: labels differ from the general graph"
            );
            cut
        }
    }

    fn random_case(rng: &mut SplitMix, h: usize, w: usize) -> Case {
        let zero_p = rng.uniform() * 0.5;
        let mut cap = |_| {
            if rng.uniform() < zero_p {
                0.0
            } else {
                rng.uniform() * 10.0
            }
        };
        let wts = [0, 1, 2, 3].map(|_| Array2::from_shape_fn((h, w), &mut cap));
        let hard = Array2::from_shape_fn((h, w), |_| rng.below(5));
        let soft = |rng: &mut SplitMix| {
            (rng.below(2) == 1).then(|| {
                Array2::from_shape_fn((h, w), |_| {
                    if rng.below(2) == 0 {
                        0.0
                    } else {
                        rng.uniform() * 6.0
                    }
                })
            })
        };
        Case {
            w: wts,
            src_hard: hard.mapv(|k| k == 0),
            snk_hard: hard.mapv(|k| k == 1),
            src_cap: soft(rng),
            snk_cap: soft(rng),
        }
    }

    #[test]
    fn random_small_grids_match_brute_force() {
        let mut rng = SplitMix(4242);
        for case in 0..600 {
            let h = 1 + rng.below(4);
            let w = 1 + rng.below(if h == 4 { 3 } else { 4 }); // at most 12 pixels
            let c = random_case(&mut rng, h, w);
            let cut = c.check(&format!("case {case}"));
            let want = c.brute_force();
            assert!(
                close(cut.flow, want),
                "case {case}: flow {} != brute force {want}",
                cut.flow
            );
        }
    }

    /// Larger random grids with hard borders and a hard centre: the general graph is the oracle.
    #[test]
    fn random_larger_grids_match_the_general_graph() {
        let mut rng = SplitMix(99);
        for case in 0..40 {
            let (h, w) = (5 + rng.below(20), 5 + rng.below(20));
            let mut c = random_case(&mut rng, h, w);
            c.src_hard = Array2::from_shape_fn((h, w), |(y, x)| {
                y == 0 || x == 0 || y == h - 1 || x == w - 1
            });
            c.snk_hard = Array2::from_shape_fn((h, w), |(y, x)| y == h / 2 && x > 1 && x < w - 2);
            c.check(&format!("larger {case}"));
        }
    }

    /// Without diagonal capacity the 8-connected cut is the 4-connected one, labels and flow.
    #[test]
    fn zero_diagonals_give_the_four_connected_cut() {
        let mut rng = SplitMix(7);
        for case in 0..100 {
            let (h, w) = (1 + rng.below(12), 1 + rng.below(12));
            let mut c = random_case(&mut rng, h, w);
            c.w[2].fill(0.0);
            c.w[3].fill(0.0);
            let cut = c.solve().unwrap();
            let four = grid_mincut(
                c.w[0].view(),
                c.w[1].view(),
                c.src_hard.view(),
                c.snk_hard.view(),
                c.src_cap.as_ref().map(|a| a.view()),
                c.snk_cap.as_ref().map(|a| a.view()),
            )
            .unwrap();
            assert!(close(cut.flow, four.flow), "case {case}");
            assert_eq!(cut.sink_side, four.sink_side, "case {case}");
        }
    }

    /// With the geo-cut weights (axis sqrt 2 - 1, diagonal 1 - 1/sqrt 2) a straight 45-degree boundary
    /// costs its Euclidean length, as does an axis-aligned one.
    #[test]
    fn geo_weights_price_a_diagonal_like_an_axis_line() {
        let n = 41;
        let wa_ = 2f64.sqrt() - 1.0;
        let wd_ = 1.0 - 1.0 / 2f64.sqrt();
        let ones = Array2::<f64>::ones((n, n));
        let case = |src: Array2<bool>| Case {
            w: [
                ones.clone() * wa_,
                ones.clone() * wa_,
                ones.clone() * wd_,
                ones.clone() * wd_,
            ],
            snk_hard: src.mapv(|_| false),
            src_hard: src,
            src_cap: None,
            snk_cap: None,
        };
        // Labels: source above the anti-diagonal y + x < n, sink below: cost of that labelling.
        let diag = Array2::from_shape_fn((n, n), |(y, x)| y + x >= n);
        let c = case(Array2::from_elem((n, n), false));
        let d = c.cost(diag.view());
        let axis = Array2::from_shape_fn((n, n), |(y, _)| y >= n / 2);
        let a = c.cost(axis.view());
        // The axis line is n long, the diagonal one about (n - 1) sqrt 2 (both up to the grid's edges).
        assert!((a / n as f64 - 1.0).abs() < 0.03, "axis cut {a}");
        let len = (n as f64 - 1.0) * 2f64.sqrt();
        assert!((d / len - 1.0).abs() < 0.03, "diagonal cut {d} vs {len}");
        // On the 4-connected grid the same staircase costs its L1 length, 2 (n - 1).
        let four = grid_cut_cost8(
            ones.view(),
            ones.view(),
            Array2::zeros((n, n)).view(),
            Array2::zeros((n, n)).view(),
            None,
            None,
            None,
            None,
            diag.view(),
        )
        .unwrap();
        assert_eq!(four, 2.0 * (n as f64 - 1.0));
    }

    #[test]
    fn errors() {
        let ones = Array2::<f64>::ones((3, 4));
        let f = Array2::from_elem((3, 4), false);
        let run = |wd: &Array2<f64>, wa: &Array2<f64>| {
            grid_mincut8(
                ones.view(),
                ones.view(),
                wd.view(),
                wa.view(),
                f.view(),
                f.view(),
                None,
                None,
            )
        };
        match run(&Array2::ones((3, 3)), &ones) {
            Err(TilesynthError::Shape { name, .. }) => assert_eq!(name, "wd"),
            other => panic!("expected a shape error on wd, got {other:?}"),
        }
        match run(&ones, &Array2::ones((2, 4))) {
            Err(TilesynthError::Shape { name, .. }) => assert_eq!(name, "wa"),
            other => panic!("expected a shape error on wa, got {other:?}"),
        }
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let mut b = ones.clone();
            b[(1, 1)] = bad;
            for (name, r) in [("wd", run(&b, &ones)), ("wa", run(&ones, &b))] {
                match r {
                    Err(TilesynthError::Parameter { name: n, .. }) => assert_eq!(n, name),
                    other => panic!("expected a parameter error on {name}, got {other:?}"),
                }
            }
        }
        // Ignored entries: the last row of both, the last column of wd, the first column of wa.
        let mut wd = ones.clone();
        let mut wa = ones.clone();
        wd[(2, 0)] = f64::NAN;
        wd[(0, 3)] = -1.0;
        wa[(2, 2)] = f64::INFINITY;
        wa[(1, 0)] = -1.0;
        assert!(run(&wd, &wa).is_ok());
    }
}
