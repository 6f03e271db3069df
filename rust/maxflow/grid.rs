//! Min-cut on a 4-connected pixel grid (the ω-tile cutting curve).
//!
//! Every pixel is a node (row-major), but only *free* pixels (in neither hard mask) get arcs or
//! terminal links; arcs sit at fixed slots of their edge (see `GridTopo`). An edge between a free pixel
//! and a hard-source (hard-sink) pixel becomes source (sink) link capacity of the free pixel; an edge
//! between a hard-source and a hard-sink pixel is always cut and only adds its capacity to the flow, as
//! does a soft link pointing at the terminal opposite to a hard pixel. Edges of capacity 0 are dropped.
//! The reduced network is solved by the one BK solver of [`super`].

use super::{Network, Topology, MAX_INDEX};
use crate::error::{fmt_shape, try_collect, try_standard, try_vec, Result, TilesynthError};
use ndarray::{Array2, Array3, ArrayView2, ArrayView3, Axis};
use rayon::prelude::*;

/// The minimum cut of a pixel grid, as returned by [`grid_mincut`].
#[derive(Debug, Clone, PartialEq)]
pub struct GridCut {
    /// `true` where the pixel is on the sink side. Hard-source pixels are always `false`, hard-sink pixels
    /// always `true`; a free pixel is on the source side iff it is reachable from the source in the final
    /// residual graph (so free pixels with no path to either terminal go to the sink side).
    pub sink_side: Array2<bool>,
    /// The max-flow value, equal to the cost of the cut (see [`grid_cut_cost`]).
    pub flow: f64,
}

/// Min-cut on a 4-connected `H x W` pixel grid with symmetric edge capacities and terminal constraints.
///
/// - `wx[y, x]`: capacity of the edge `(y, x)`–`(y, x + 1)` (the last column is ignored);
/// - `wy[y, x]`: capacity of the edge `(y, x)`–`(y + 1, x)` (the last row is ignored);
///   both `(H, W)`, finite and `>= 0`;
/// - `source_hard` / `sink_hard`: `(H, W)` masks of the pixels tied to the source / sink with infinite
///   capacity (a pixel may not be in both);
/// - `source_cap` / `sink_cap`: optional `(H, W)` soft terminal link capacities, finite and `>= 0`.
///
/// Returns the labelling (see [`GridCut::sink_side`] for the rule) and the flow value, which equals the cut
/// cost. Errors on `H == 0` or `W == 0`, shape mismatches, negative / NaN / infinite capacities, and a
/// pixel in both hard masks.
pub fn grid_mincut(
    wx: ArrayView2<f64>,
    wy: ArrayView2<f64>,
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
        .and_then(|n| n.checked_mul(4))
        .map_or(true, |m| m > MAX_INDEX)
    {
        return Err(TilesynthError::shape(
            "wx",
            "a grid with at most 2^30 - 1 pixels",
            expected,
        ));
    }
    check_edge_caps("wx", wx, h, 0..w - 1)?;
    check_edge_caps("wy", wy, h - 1, 0..w)?;
    check_terminal_values(source_hard, sink_hard, source_cap, sink_cap, h, w)?;

    let wx = try_standard("wx", wx)?;
    let wy = try_standard("wy", wy)?;
    let src_hard = try_standard("source_hard", source_hard)?;
    let snk_hard = try_standard("sink_hard", sink_hard)?;
    let src_cap = source_cap
        .map(|c| try_standard("source_cap", c))
        .transpose()?;
    let snk_cap = sink_cap.map(|c| try_standard("sink_cap", c)).transpose()?;
    let wx = wx.as_slice().expect("standard layout");
    let wy = wy.as_slice().expect("standard layout");
    let src_hard = src_hard.as_slice().expect("standard layout");
    let snk_hard = snk_hard.as_slice().expect("standard layout");
    let src_cap = src_cap
        .as_ref()
        .map(|c| c.as_slice().expect("standard layout"));
    let snk_cap = snk_cap
        .as_ref()
        .map(|c| c.as_slice().expect("standard layout"));

    let mut net = build(h, w, wx, wy, src_hard, snk_hard, src_cap, snk_cap)?;
    let sol = net.solve("wx")?;
    grid_cut(h, w, src_hard, snk_hard, &sol.sink_side, sol.flow)
}

/// The minimum cuts of `K` independent grids of one shape and one pair of hard masks (the free cuts of a
/// tile set, one grid per tile): [`grid_mincut`] of `wx[k]`, `wy[k]`, `source_hard`, `sink_hard` and
/// `sink_cap[k]` for every `k`, solved in parallel on the caller's pool and returned in order, so the result
/// is the per-grid calls' bit for bit at any thread count. `wx`, `wy` (and `sink_cap`): `(K, H, W)`.
/// Returns the labels `(K, H, W)` and the flows; the first failing grid's error (by index) is returned.
pub fn grid_mincuts(
    wx: ArrayView3<f64>,
    wy: ArrayView3<f64>,
    source_hard: ArrayView2<bool>,
    sink_hard: ArrayView2<bool>,
    sink_cap: Option<ArrayView3<f64>>,
) -> Result<GridCuts> {
    let (k, h, w) = wx.dim();
    let expected = fmt_shape(&[k, h, w]);
    if wy.dim() != (k, h, w) {
        return Err(TilesynthError::shape("wy", expected, fmt_shape(wy.shape())));
    }
    if let Some(c) = &sink_cap {
        if c.dim() != (k, h, w) {
            return Err(TilesynthError::shape(
                "sink_cap",
                expected,
                fmt_shape(c.shape()),
            ));
        }
    }
    if source_hard.dim() != (h, w) || sink_hard.dim() != (h, w) {
        let bad = if source_hard.dim() != (h, w) {
            ("source_hard", source_hard.shape())
        } else {
            ("sink_hard", sink_hard.shape())
        };
        return Err(TilesynthError::shape(
            bad.0,
            fmt_shape(&[h, w]),
            fmt_shape(bad.1),
        ));
    }
    let cuts: Vec<GridCut> = (0..k)
        .into_par_iter()
        .map(|j| {
            grid_mincut(
                wx.index_axis(Axis(0), j),
                wy.index_axis(Axis(0), j),
                source_hard,
                sink_hard,
                None,
                sink_cap.as_ref().map(|c| c.index_axis(Axis(0), j)),
            )
        })
        .collect::<Result<_>>()?;
    let mut labels = Array3::from_elem((k, h, w), false);
    let mut flows = try_vec("wx", k, 0.0)?;
    for (j, cut) in cuts.into_iter().enumerate() {
        labels.index_axis_mut(Axis(0), j).assign(&cut.sink_side);
        flows[j] = cut.flow;
    }
    Ok(GridCuts { labels, flows })
}

/// The minimum cuts of a stack of grids, as returned by [`grid_mincuts`].
#[derive(Debug, Clone, PartialEq)]
pub struct GridCuts {
    /// `(K, H, W)`: grid `k`'s [`GridCut::sink_side`].
    pub labels: Array3<bool>,
    /// Grid `k`'s [`GridCut::flow`].
    pub flows: Vec<f64>,
}

/// The labelling of a solved grid network: hard pixels on their terminal's side, the rest as the solver
/// left them (the rule of [`GridCut::sink_side`]). Shared by the 4- and 8-connected front ends.
pub(super) fn grid_cut(
    h: usize,
    w: usize,
    src_hard: &[bool],
    snk_hard: &[bool],
    solved: &[bool],
    flow: f64,
) -> Result<GridCut> {
    let sink_side = try_collect(
        "wx",
        h * w,
        (0..h * w).map(|p| {
            if src_hard[p] || snk_hard[p] {
                snk_hard[p]
            } else {
                solved[p]
            }
        }),
    )?;
    Ok(GridCut {
        sink_side: Array2::from_shape_vec((h, w), sink_side).expect("h * w labels"),
        flow,
    })
}

/// The shapes of the terminal arrays of a grid cut (the hard masks and the optional soft capacities).
pub(super) fn check_terminal_shapes(
    source_hard: ArrayView2<bool>,
    sink_hard: ArrayView2<bool>,
    source_cap: Option<ArrayView2<f64>>,
    sink_cap: Option<ArrayView2<f64>>,
    h: usize,
    w: usize,
    expected: &str,
) -> Result<()> {
    check_shape("source_hard", source_hard.shape(), h, w, expected)?;
    check_shape("sink_hard", sink_hard.shape(), h, w, expected)?;
    if let Some(c) = &source_cap {
        check_shape("source_cap", c.shape(), h, w, expected)?;
    }
    if let Some(c) = &sink_cap {
        check_shape("sink_cap", c.shape(), h, w, expected)?;
    }
    Ok(())
}

/// The values of the terminal arrays of a grid cut: soft capacities finite and `>= 0`, no pixel in both hard
/// masks.
pub(super) fn check_terminal_values(
    source_hard: ArrayView2<bool>,
    sink_hard: ArrayView2<bool>,
    source_cap: Option<ArrayView2<f64>>,
    sink_cap: Option<ArrayView2<f64>>,
    h: usize,
    w: usize,
) -> Result<()> {
    if let Some(c) = &source_cap {
        check_caps("source_cap", c.view(), h, w)?;
    }
    if let Some(c) = &sink_cap {
        check_caps("sink_cap", c.view(), h, w)?;
    }
    if let Some(((y, x), _)) = source_hard
        .indexed_iter()
        .find(|&((y, x), &s)| s && sink_hard[(y, x)])
    {
        return Err(TilesynthError::param(
            "sink_hard",
            format!("true at ({y}, {x})"),
            "a pixel cannot be tied to both the source and the sink (source_hard is true there too)",
        ));
    }
    Ok(())
}

/// Grid adjacency. Node `p` is the pixel `(p / w, p % w)`; the edge right of `p` holds the arcs `4p`
/// (`p -> p + 1`) and `4p + 1` (back), the edge below `p` the arcs `4p + 2` (`p -> p + w`) and `4p + 3`
/// (back). `dirs[p]` has bit 0 / 1 / 2 / 3 set when the arc to the right / down / left / up neighbour
/// is in use (both pixels free and a positive capacity). Hard pixels are nodes without arcs or terminal
/// links: they stay free and never enter a tree.
#[derive(Debug, Clone)]
struct GridTopo {
    w: u32,
    dirs: Vec<u8>,
}

/// Iterator over the arcs of one grid node.
struct GridArcs {
    p: u32,
    w: u32,
    mask: u8,
}

impl Iterator for GridArcs {
    type Item = (u32, u32);

    #[inline]
    fn next(&mut self) -> Option<(u32, u32)> {
        if self.mask == 0 {
            return None;
        }
        let d = self.mask.trailing_zeros();
        self.mask &= self.mask - 1;
        let p = self.p;
        Some(match d {
            0 => (4 * p, p + 1),
            1 => (4 * p + 2, p + self.w),
            2 => (4 * (p - 1) + 1, p - 1),
            _ => (4 * (p - self.w) + 3, p - self.w),
        })
    }
}

impl Topology for GridTopo {
    #[inline]
    fn arcs(&self, i: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        GridArcs {
            p: i,
            w: self.w,
            mask: self.dirs[i as usize],
        }
    }

    #[inline]
    fn head(&self, a: u32) -> u32 {
        let p = a >> 2;
        match a & 3 {
            0 => p + 1,
            2 => p + self.w,
            _ => p,
        }
    }
}

/// A grid network assembled directly by a caller that has already folded its hard pixels into terminal
/// links (the ω cut builds one per quadrant). Node `p` is the local pixel `(p / w, p % w)`; nodes never
/// given an arc or a terminal link stay isolated and end on the sink side.
#[derive(Debug, Clone)]
pub(crate) struct GridNetwork {
    net: Network<GridTopo>,
    /// The caller's parameter the size comes from, named by allocation errors.
    name: &'static str,
}

impl GridNetwork {
    /// An `h x w` grid without arcs or terminal links. The caller guarantees `4 h w <= MAX_INDEX`.
    /// Fallible: an error naming `name` (the caller's parameter the size comes from) if the arrays (41
    /// bytes per node) cannot be allocated.
    pub(crate) fn new(name: &'static str, h: usize, w: usize) -> Result<GridNetwork> {
        let np = h * w;
        Ok(GridNetwork {
            net: Network {
                topo: GridTopo {
                    w: w as u32,
                    dirs: try_vec(name, np, 0u8)?,
                },
                rcap: try_vec(name, 4 * np, 0.0f64)?,
                tr: try_vec(name, np, 0.0f64)?,
                flow: 0.0,
            },
            name,
        })
    }

    /// The edge `p`–`p + 1` with capacity `c > 0` in both directions (`p + 1` in the same row).
    #[inline]
    pub(crate) fn set_right(&mut self, p: usize, c: f64) {
        self.net.rcap[4 * p] = c;
        self.net.rcap[4 * p + 1] = c;
        self.net.topo.dirs[p] |= 1;
        self.net.topo.dirs[p + 1] |= 4;
    }

    /// The edge `p`–`p + w` with capacity `c > 0` in both directions.
    #[inline]
    pub(crate) fn set_down(&mut self, p: usize, c: f64) {
        let w = self.net.topo.w as usize;
        self.net.rcap[4 * p + 2] = c;
        self.net.rcap[4 * p + 3] = c;
        self.net.topo.dirs[p] |= 2;
        self.net.topo.dirs[p + w] |= 8;
    }

    /// The terminal links of `p` (set once per node): `cs` from the source, `ck` to the sink, finite.
    #[inline]
    pub(crate) fn set_terminal(&mut self, p: usize, cs: f64, ck: f64) {
        self.net.flow += cs.min(ck);
        self.net.tr[p] = cs - ck;
    }

    /// Solves the network: the flow value and the sink-side flag of every node (labelling rule of
    /// [`super`]).
    pub(crate) fn solve(mut self) -> Result<(f64, Vec<bool>)> {
        let sol = self.net.solve(self.name)?;
        Ok((sol.flow, sol.sink_side))
    }
}

/// Builds the reduced residual network (hard pixels folded into terminal links and constant flow).
#[allow(clippy::too_many_arguments)]
fn build(
    h: usize,
    w: usize,
    wx: &[f64],
    wy: &[f64],
    src_hard: &[bool],
    snk_hard: &[bool],
    src_cap: Option<&[f64]>,
    snk_cap: Option<&[f64]>,
) -> Result<Network<GridTopo>> {
    let np = h * w;
    let mut flow = 0.0f64;
    let mut rcap = try_vec("wx", 4 * np, 0.0f64)?;
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
                    if x + 1 < w && snk_hard[p + 1] {
                        flow += wx[p];
                    }
                    if y + 1 < h && snk_hard[p + w] {
                        flow += wy[p];
                    }
                    if x > 0 && snk_hard[p - 1] {
                        flow += wx[p - 1];
                    }
                    if y > 0 && snk_hard[p - w] {
                        flow += wy[p - w];
                    }
                } else if let Some(c) = src_cap {
                    flow += c[p];
                }
                continue;
            }
            let mut cs = src_cap.map_or(0.0, |c| c[p]);
            let mut ck = snk_cap.map_or(0.0, |c| c[p]);
            // Right and down: arcs between free pixels; left and up: only links to hard pixels (the arcs
            // were made from the other side).
            if x + 1 < w && wx[p] > 0.0 {
                let (c, q) = (wx[p], p + 1);
                if src_hard[q] {
                    cs += c;
                } else if snk_hard[q] {
                    ck += c;
                } else {
                    rcap[4 * p] = c;
                    rcap[4 * p + 1] = c;
                    dirs[p] |= 1;
                    dirs[q] |= 4;
                }
            }
            if y + 1 < h && wy[p] > 0.0 {
                let (c, q) = (wy[p], p + w);
                if src_hard[q] {
                    cs += c;
                } else if snk_hard[q] {
                    ck += c;
                } else {
                    rcap[4 * p + 2] = c;
                    rcap[4 * p + 3] = c;
                    dirs[p] |= 2;
                    dirs[q] |= 8;
                }
            }
            if x > 0 {
                let (c, q) = (wx[p - 1], p - 1);
                if src_hard[q] {
                    cs += c;
                } else if snk_hard[q] {
                    ck += c;
                }
            }
            if y > 0 {
                let (c, q) = (wy[p - w], p - w);
                if src_hard[q] {
                    cs += c;
                } else if snk_hard[q] {
                    ck += c;
                }
            }
            flow += cs.min(ck);
            tr[p] = cs - ck;
        }
    }
    Ok(Network {
        topo: GridTopo { w: w as u32, dirs },
        rcap,
        tr,
        flow,
    })
}

/// The cost of the cut given by `labels` (`true` = sink side): the capacities of the grid edges between
/// pixels with different labels (the ignored last column of `wx` and last row of `wy` excepted), plus the
/// soft links that are cut (`source_cap` of sink-side pixels, `sink_cap` of source-side pixels), plus
/// `f64::INFINITY` if a hard constraint is violated. All arrays are `(H, W)`; capacities are not
/// validated beyond their shapes.
pub fn grid_cut_cost(
    wx: ArrayView2<f64>,
    wy: ArrayView2<f64>,
    source_hard: Option<ArrayView2<bool>>,
    sink_hard: Option<ArrayView2<bool>>,
    source_cap: Option<ArrayView2<f64>>,
    sink_cap: Option<ArrayView2<f64>>,
    labels: ArrayView2<bool>,
) -> Result<f64> {
    let (h, w) = labels.dim();
    let expected = fmt_shape(&[h, w]);
    check_shape("wx", wx.shape(), h, w, &expected)?;
    check_shape("wy", wy.shape(), h, w, &expected)?;
    for (name, m) in [("source_hard", &source_hard), ("sink_hard", &sink_hard)] {
        if let Some(m) = m {
            check_shape(name, m.shape(), h, w, &expected)?;
        }
    }
    for (name, c) in [("source_cap", &source_cap), ("sink_cap", &sink_cap)] {
        if let Some(c) = c {
            check_shape(name, c.shape(), h, w, &expected)?;
        }
    }
    let mut cost = 0.0;
    for y in 0..h {
        for x in 0..w {
            let l = labels[(y, x)];
            if x + 1 < w && l != labels[(y, x + 1)] {
                cost += wx[(y, x)];
            }
            if y + 1 < h && l != labels[(y + 1, x)] {
                cost += wy[(y, x)];
            }
            if l {
                if let Some(c) = &source_cap {
                    cost += c[(y, x)];
                }
                if source_hard.as_ref().is_some_and(|m| m[(y, x)]) {
                    cost = f64::INFINITY;
                }
            } else {
                if let Some(c) = &sink_cap {
                    cost += c[(y, x)];
                }
                if sink_hard.as_ref().is_some_and(|m| m[(y, x)]) {
                    cost = f64::INFINITY;
                }
            }
        }
    }
    Ok(cost)
}

pub(super) fn check_shape(
    name: &'static str,
    shape: &[usize],
    h: usize,
    w: usize,
    expected: &str,
) -> Result<()> {
    if shape != [h, w] {
        return Err(TilesynthError::shape(name, expected, fmt_shape(shape)));
    }
    Ok(())
}

/// Edge capacities in the used part `[..rows, cols]` must be finite and `>= 0`.
pub(super) fn check_edge_caps(
    name: &'static str,
    a: ArrayView2<f64>,
    rows: usize,
    cols: std::ops::Range<usize>,
) -> Result<()> {
    for y in 0..rows {
        for x in cols.clone() {
            let c = a[(y, x)];
            if !(c.is_finite() && c >= 0.0) {
                return Err(TilesynthError::param(
                    name,
                    format!("{c} at ({y}, {x})"),
                    "edge capacities must be finite and >= 0",
                ));
            }
        }
    }
    Ok(())
}

/// Soft terminal capacities must be finite and `>= 0`.
pub(super) fn check_caps(
    name: &'static str,
    a: ArrayView2<f64>,
    rows: usize,
    cols: usize,
) -> Result<()> {
    for y in 0..rows {
        for x in 0..cols {
            let c = a[(y, x)];
            if !(c.is_finite() && c >= 0.0) {
                return Err(TilesynthError::param(
                    name,
                    format!("{c} at ({y}, {x})"),
                    "terminal capacities must be finite and >= 0 (use the hard masks for infinite links)",
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::tests::{close, SplitMix};
    use super::super::Graph;
    use super::*;
    use ndarray::Array2;

    struct Case {
        wx: Array2<f64>,
        wy: Array2<f64>,
        src_hard: Array2<bool>,
        snk_hard: Array2<bool>,
        src_cap: Option<Array2<f64>>,
        snk_cap: Option<Array2<f64>>,
    }

    impl Case {
        fn solve(&self) -> Result<GridCut> {
            grid_mincut(
                self.wx.view(),
                self.wy.view(),
                self.src_hard.view(),
                self.snk_hard.view(),
                self.src_cap.as_ref().map(|c| c.view()),
                self.snk_cap.as_ref().map(|c| c.view()),
            )
        }

        fn cost(&self, labels: ArrayView2<bool>) -> f64 {
            grid_cut_cost(
                self.wx.view(),
                self.wy.view(),
                Some(self.src_hard.view()),
                Some(self.snk_hard.view()),
                self.src_cap.as_ref().map(|c| c.view()),
                self.snk_cap.as_ref().map(|c| c.view()),
                labels,
            )
            .unwrap()
        }

        fn brute_force(&self) -> f64 {
            let (h, w) = self.wx.dim();
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
            let (h, w) = self.wx.dim();
            let mut g = Graph::new(h * w);
            for y in 0..h {
                for x in 0..w {
                    let p = y * w + x;
                    if x + 1 < w {
                        g.add_edge(p, p + 1, self.wx[(y, x)], self.wx[(y, x)]);
                    }
                    if y + 1 < h {
                        g.add_edge(p, p + w, self.wy[(y, x)], self.wy[(y, x)]);
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
                if self.src_hard[(y, x)] {
                    assert!(!s, "{what}: hard source pixel ({y}, {x}) on the sink side");
                }
                if self.snk_hard[(y, x)] {
                    assert!(s, "{what}: hard sink pixel ({y}, {x}) on the source side");
                }
            }
            let (gf, glabels) = self.general();
            assert!(
                close(gf, cut.flow),
                "{what}: general graph flow {gf} != grid flow {}",
                cut.flow
            );
            // Same rule (source side = reachable from the source in the residual graph) on both networks:
            // the reachable set of a max flow does not depend on the flow, so the labels agree.
            assert_eq!(
                glabels, cut.sink_side,
                "{what}: labels differ from the general graph"
            );
            cut
        }
    }

    fn random_case(rng: &mut SplitMix, h: usize, w: usize) -> Case {
        let zero_p = rng.uniform() * 0.5;
        let cap = |rng: &mut SplitMix| {
            if rng.uniform() < zero_p {
                0.0
            } else {
                rng.uniform() * 10.0
            }
        };
        let wx = Array2::from_shape_fn((h, w), |_| cap(rng));
        let wy = Array2::from_shape_fn((h, w), |_| cap(rng));
        let hard = Array2::from_shape_fn((h, w), |_| rng.below(5));
        let src_hard = hard.mapv(|k| k == 0);
        let snk_hard = hard.mapv(|k| k == 1);
        let soft = |rng: &mut SplitMix| {
            if rng.below(2) == 0 {
                None
            } else {
                Some(Array2::from_shape_fn((h, w), |_| {
                    if rng.below(2) == 0 {
                        0.0
                    } else {
                        rng.uniform() * 6.0
                    }
                }))
            }
        };
        let src_cap = soft(rng);
        let snk_cap = soft(rng);
        Case {
            wx,
            wy,
            src_hard,
            snk_hard,
            src_cap,
            snk_cap,
        }
    }

    #[test]
    fn random_small_grids_match_brute_force() {
        let mut rng = SplitMix(777);
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

    #[test]
    fn special_grids() {
        let z = Array2::<f64>::zeros((3, 4));
        let ones = Array2::<f64>::ones((3, 4));
        let f = Array2::from_elem((3, 4), false);
        let t = Array2::from_elem((3, 4), true);
        let mk = |wx: &Array2<f64>, sh: &Array2<bool>, kh: &Array2<bool>| Case {
            wx: wx.clone(),
            wy: wx.clone(),
            src_hard: sh.clone(),
            snk_hard: kh.clone(),
            src_cap: None,
            snk_cap: None,
        };
        // All source: no nodes, no flow.
        let cut = mk(&ones, &t, &f).check("all source");
        assert_eq!(cut.flow, 0.0);
        assert!(cut.sink_side.iter().all(|&s| !s));
        // All sink.
        let cut = mk(&ones, &f, &t).check("all sink");
        assert_eq!(cut.flow, 0.0);
        assert!(cut.sink_side.iter().all(|&s| s));
        // No terminals at all: every pixel unreachable from the source -> sink side.
        let cut = mk(&ones, &f, &f).check("free");
        assert_eq!(cut.flow, 0.0);
        assert!(cut.sink_side.iter().all(|&s| s));
        // No free pixels, hard source column next to hard sink columns: the edges between are the cut.
        let sh = Array2::from_shape_fn((3, 4), |(_, x)| x == 0);
        let kh = sh.mapv(|b| !b);
        let cut = mk(&ones, &sh, &kh).check("no free pixels");
        assert_eq!(cut.flow, 3.0);
        // Zero capacities everywhere.
        let cut = mk(&z, &sh, &kh).check("zero capacities");
        assert_eq!(cut.flow, 0.0);
        // Two disconnected components (a zero column in wx separates them).
        let mut wx = ones.clone();
        wx.column_mut(1).fill(0.0);
        let mut c = mk(&wx, &f, &f);
        c.wy = ones.clone();
        c.src_hard[(0, 0)] = true;
        c.snk_hard[(2, 1)] = true;
        c.src_cap = Some(Array2::from_shape_fn((3, 4), |(_, x)| {
            if x == 3 {
                2.0
            } else {
                0.0
            }
        }));
        let cut = c.check("components");
        assert_eq!(cut.flow, 2.0, "(0, 0) is cut off by its two edges");
        // The right component (columns 2..4) is reachable from the source only.
        assert!(cut.sink_side.column(3).iter().all(|&s| !s));
        // A 1 x 1 grid.
        let one = Array2::<f64>::ones((1, 1));
        let c = Case {
            wx: one.clone(),
            wy: one.clone(),
            src_hard: Array2::from_elem((1, 1), false),
            snk_hard: Array2::from_elem((1, 1), false),
            src_cap: Some(one.clone() * 2.0),
            snk_cap: Some(one.clone() * 3.0),
        };
        let cut = c.check("1x1");
        assert_eq!(cut.flow, 2.0);
        assert!(cut.sink_side[(0, 0)]);
    }

    #[test]
    fn stacked_grids_are_each_grids_cut() {
        let mut rng = SplitMix(31);
        let (k, h, w) = (5, 6, 7);
        let mut wx = ndarray::Array3::<f64>::zeros((k, h, w));
        let mut wy = ndarray::Array3::<f64>::zeros((k, h, w));
        let mut cap = ndarray::Array3::<f64>::zeros((k, h, w));
        for v in wx.iter_mut().chain(wy.iter_mut()).chain(cap.iter_mut()) {
            *v = 3.0 * rng.uniform();
        }
        let src = Array2::from_shape_fn((h, w), |(_, x)| x == 0);
        let snk = Array2::from_shape_fn((h, w), |(_, x)| x == w - 1);
        for with_cap in [false, true] {
            let caps = with_cap.then(|| cap.view());
            let got = grid_mincuts(wx.view(), wy.view(), src.view(), snk.view(), caps).unwrap();
            for j in 0..k {
                let one = grid_mincut(
                    wx.index_axis(Axis(0), j),
                    wy.index_axis(Axis(0), j),
                    src.view(),
                    snk.view(),
                    None,
                    with_cap.then(|| cap.index_axis(Axis(0), j)),
                )
                .unwrap();
                assert_eq!(got.labels.index_axis(Axis(0), j), one.sink_side);
                assert_eq!(got.flows[j].to_bits(), one.flow.to_bits());
            }
        }
        let bad = ndarray::Array3::<f64>::zeros((k, h, w - 1));
        match grid_mincuts(wx.view(), bad.view(), src.view(), snk.view(), None) {
            Err(TilesynthError::Shape { name, .. }) => assert_eq!(name, "wy"),
            other => panic!("expected a shape error on wy, got {other:?}"),
        }
    }

    #[test]
    fn errors() {
        let ones = Array2::<f64>::ones((3, 4));
        let f = Array2::from_elem((3, 4), false);
        let run = |wx: &Array2<f64>, wy: &Array2<f64>, sh: &Array2<bool>, kh: &Array2<bool>| {
            grid_mincut(wx.view(), wy.view(), sh.view(), kh.view(), None, None)
        };
        let shape_err = |r: Result<GridCut>, name: &str| match r {
            Err(TilesynthError::Shape { name: n, .. }) => assert_eq!(n, name),
            other => panic!("expected a shape error on {name}, got {other:?}"),
        };
        let param_err = |r: Result<GridCut>, name: &str| match r {
            Err(TilesynthError::Parameter { name: n, .. }) => assert_eq!(n, name),
            other => panic!("expected a parameter error on {name}, got {other:?}"),
        };
        let e = Array2::<f64>::zeros((0, 4));
        let eb = Array2::from_elem((0, 4), false);
        shape_err(run(&e, &e, &eb, &eb), "wx");
        let e = Array2::<f64>::zeros((3, 0));
        let eb = Array2::from_elem((3, 0), false);
        shape_err(run(&e, &e, &eb, &eb), "wx");
        shape_err(run(&ones, &Array2::ones((4, 3)), &f, &f), "wy");
        shape_err(
            run(&ones, &ones, &Array2::from_elem((3, 3), false), &f),
            "source_hard",
        );
        shape_err(
            run(&ones, &ones, &f, &Array2::from_elem((2, 4), false)),
            "sink_hard",
        );
        let r = grid_mincut(
            ones.view(),
            ones.view(),
            f.view(),
            f.view(),
            Some(Array2::ones((1, 1)).view()),
            None,
        );
        shape_err(r, "source_cap");
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let mut wx = ones.clone();
            wx[(1, 1)] = bad;
            param_err(run(&wx, &ones, &f, &f), "wx");
            param_err(run(&ones, &wx, &f, &f), "wy");
            let r = grid_mincut(
                ones.view(),
                ones.view(),
                f.view(),
                f.view(),
                None,
                Some(wx.view()),
            );
            param_err(r, "sink_cap");
        }
        // Ignored entries (last column of wx, last row of wy) are not checked.
        let mut wx = ones.clone();
        wx[(0, 3)] = f64::NAN;
        let mut wy = ones.clone();
        wy[(2, 0)] = -1.0;
        assert!(run(&wx, &wy, &f, &f).is_ok());
        let mut sh = f.clone();
        let mut kh = f.clone();
        sh[(2, 1)] = true;
        kh[(2, 1)] = true;
        param_err(run(&ones, &ones, &sh, &kh), "sink_hard");
    }

    /// An ω-like N x N problem: outside the inscribed circle hard source, the two central rows and
    /// columns inside it hard sink, weights spread over many orders of magnitude.
    fn omega_case(n: usize, seed: u64) -> Case {
        let mut rng = SplitMix(seed);
        let c = (n as f64 - 1.0) / 2.0;
        let r2 = (n as f64 / 2.0).powi(2);
        let inside = Array2::from_shape_fn((n, n), |(y, x)| {
            (y as f64 - c).powi(2) + (x as f64 - c).powi(2) <= r2
        });
        let cross = Array2::from_shape_fn((n, n), |(y, x)| {
            inside[(y, x)] && (y == n / 2 - 1 || y == n / 2 || x == n / 2 - 1 || x == n / 2)
        });
        let weight = |rng: &mut SplitMix| 0.02 * (rng.uniform() * 19.0).exp();
        let wx = Array2::from_shape_fn((n, n), |_| weight(&mut rng));
        let wy = Array2::from_shape_fn((n, n), |_| weight(&mut rng));
        Case {
            wx,
            wy,
            src_hard: inside.mapv(|b| !b),
            snk_hard: cross,
            src_cap: None,
            snk_cap: None,
        }
    }

    #[test]
    fn omega_like_grid() {
        for (n, seed) in [(64, 1), (64, 2), (33, 3), (40, 4)] {
            let c = omega_case(n, seed);
            let cut = c.check(&format!("omega {n} {seed}"));
            assert!(cut.flow.is_finite() && cut.flow > 0.0);
            // Deterministic.
            let again = c.solve().unwrap();
            assert_eq!(again.flow.to_bits(), cut.flow.to_bits());
            assert_eq!(again.sink_side, cut.sink_side);
        }
    }

    #[test]
    fn non_contiguous_inputs() {
        let c = omega_case(24, 9);
        let wx_t = c.wx.t().to_owned();
        let wx_f = wx_t.t(); // same values, Fortran order
        let cut = grid_mincut(
            wx_f,
            c.wy.view(),
            c.src_hard.view(),
            c.snk_hard.view(),
            None,
            None,
        )
        .unwrap();
        assert_eq!(cut, c.solve().unwrap());
    }
}
