//! Exact min-cut of a pixel region by a shortest path in the planar dual (the ω cut's quadrants).
//!
//! A rectangle of `h x w` pixels, each *free*, tied to the source or tied to the sink, with symmetric
//! 4-neighbour edge weights. When
//!
//! 1. every pixel of the one-pixel ring of the rectangle is tied to a terminal,
//! 2. walking around the ring, the terminal changes exactly twice (one run of source pixels, one run of
//!    sink pixels), and
//! 3. every tied pixel is joined to the ring through pixels tied to the same terminal,
//!
//! the labellings that respect the ties correspond one to one to the sets of dual edges (a dual edge crosses
//! one primal edge, between two pixel corners) whose odd-degree corners are exactly the two ring corners `A`
//! and `B` where the terminal changes, provided the edges between two pixels tied to the same terminal are
//! left out of the dual (they can never be cut). The cost of a labelling is the weight of its set, so a
//! minimum cut is a shortest `A`–`B` path in the dual (Dijkstra; weights are finite and `>= 0`). Edges
//! between a source-tied and a sink-tied pixel are always cut; they get weight 0 here (the caller counts
//! them as constant flow). This is the classical reduction of an s–t planar min-cut with both terminals on
//! the outer face to a shortest path (Itai and Shiloach 1979; Hassin 1981).
//!
//! The returned labelling is not the path's own two sides but, as in the BK solver's labelling rule
//! ([`super`]), the pixels the source reaches: a free pixel is on the source side iff it is joined to a
//! source-tied pixel by a chain of edges of positive weight that the path does not cross. Every edge
//! leaving that set is crossed by the path or has weight 0, so its cost is at most the path's: it is a
//! minimum cut too, and free pixels cut off from everything (or behind weight-0 edges only) go to the sink
//! side as with BK.
//!
//! Cost: `O(h w)` heap operations (a radix heap), against BK's augmenting paths on the same network (the ω quadrants are
//! solved 5-10x faster). The flow value is the path length, summed along the path: it equals BK's value
//! up to rounding (a few ulps relative), not bit for bit, and among minimum cuts of exactly equal cost
//! the two solvers may pick different ones.

use crate::error::{try_vec, Result};

/// A free pixel (labelled by the cut).
pub(crate) const PX_FREE: u8 = 0;
/// A pixel tied to the source.
pub(crate) const PX_SOURCE: u8 = 1;
/// A pixel tied to the sink.
pub(crate) const PX_SINK: u8 = 2;

/// Absent dual edge (it would cross an edge between two pixels tied to the same terminal).
const ABSENT: f64 = f64::INFINITY;

/// The minimum cut of the `h x w` region with pixel classes `class` (row-major, [`PX_FREE`],
/// [`PX_SOURCE`], [`PX_SINK`]), if the region meets conditions 1-3 of the module documentation; `None`
/// otherwise (the caller then uses a general solver).
///
/// `wx(i, j)` is the weight of the edge `(i, j)`–`(i, j + 1)`, `wy(i, j)` that of `(i, j)`–`(i + 1, j)`;
/// they are called only for edges with at least one free end, and must return finite values `>= 0`.
/// Returns the flow (the path length, without the always-cut source–sink edges) and the sink-side flag of
/// every pixel (tied pixels: their terminal). Allocation failures are errors naming `name`.
#[inline(never)]
pub(crate) fn planar_mincut(
    name: &'static str,
    h: usize,
    w: usize,
    class: &[u8],
    wx: impl Fn(usize, usize) -> f64,
    wy: impl Fn(usize, usize) -> f64,
) -> Result<Option<(f64, Vec<bool>)>> {
    assert_eq!(class.len(), h * w, "one class per pixel");
    let Some((a, b)) = dual_terminals(h, w, class) else {
        return Ok(None);
    };
    if !ties_reach_ring(name, h, w, class)? {
        return Ok(None);
    }
    // Corner (i, j), 0 <= i <= h, 0 <= j <= w (the top-left corner of pixel (i, j)), is stored at
    // (i + 1) * cw + j + 1 of a grid padded by one absent corner on every side, so that the four
    // neighbours of a corner never need a bounds check.
    let cw = w + 3;
    let nc = (h + 3) * cw;
    let corner = |i: usize, j: usize| (i + 1) * cw + j + 1;
    // right[k]: the dual edge k -> k + 1 (it crosses the vertical primal edge between the pixels above
    // and below it); down[k]: k -> k + cw (it crosses the horizontal edge between the pixels left and
    // right of it).
    let mut right = try_vec(name, nc, ABSENT)?;
    let mut down = try_vec(name, nc, ABSENT)?;
    // Between two tied pixels: absent if tied to the same terminal, else always cut (weight 0 here).
    let tied = |p: u8, q: u8| -> Option<f64> {
        if p != PX_FREE && q != PX_FREE {
            Some(if p == q { ABSENT } else { 0.0 })
        } else {
            None
        }
    };
    for i in 0..h {
        for j in 0..w - 1 {
            let (p, q) = (class[i * w + j], class[i * w + j + 1]);
            down[corner(i, j + 1)] = tied(p, q).unwrap_or_else(|| wx(i, j));
        }
    }
    for i in 0..h - 1 {
        for j in 0..w {
            let (p, q) = (class[i * w + j], class[(i + 1) * w + j]);
            right[corner(i + 1, j)] = tied(p, q).unwrap_or_else(|| wy(i, j));
        }
    }
    let (a, b) = (corner(a.0, a.1), corner(b.0, b.1));
    let Some((flow, cut)) = shortest_path(name, cw, &right, &down, a, b)? else {
        return Ok(None);
    };
    // The source side: what the source-tied pixels reach through uncrossed edges of positive weight.
    let mut reached = try_vec(name, h * w, false)?;
    let mut stack: Vec<usize> = Vec::new();
    stack
        .try_reserve(h * w)
        .map_err(|_| crate::error::alloc_error::<usize>(name, h * w))?;
    for (p, &k) in class.iter().enumerate() {
        if k == PX_SOURCE {
            reached[p] = true;
            stack.push(p);
        }
    }
    let open = |k: usize, wgt: &[f64], bit: u8| wgt[k] > 0.0 && cut[k] & bit == 0;
    while let Some(p) = stack.pop() {
        let (i, j) = (p / w, p % w);
        let mut visit = |q: usize, passable: bool| {
            if passable && class[q] == PX_FREE && !reached[q] {
                reached[q] = true;
                stack.push(q);
            }
        };
        if j + 1 < w {
            visit(p + 1, open(corner(i, j + 1), &down, CUT_DOWN));
        }
        if j > 0 {
            visit(p - 1, open(corner(i, j), &down, CUT_DOWN));
        }
        if i + 1 < h {
            visit(p + w, open(corner(i + 1, j), &right, CUT_RIGHT));
        }
        if i > 0 {
            visit(p - w, open(corner(i, j), &right, CUT_RIGHT));
        }
    }
    let sink_side = class
        .iter()
        .zip(&reached)
        .map(|(&k, &r)| match k {
            PX_SOURCE => false,
            PX_SINK => true,
            _ => !r,
        })
        .collect();
    Ok(Some((flow, sink_side)))
}

/// Whether the region meets the conditions of the module documentation (tests and assertions).
#[cfg(test)]
pub(crate) fn planar_applies(h: usize, w: usize, class: &[u8]) -> bool {
    dual_terminals(h, w, class).is_some() && ties_reach_ring("class", h, w, class).unwrap()
}

/// Bit of `cut[k]`: the dual edge `k -> k + 1` is on the path.
const CUT_RIGHT: u8 = 1;
/// Bit of `cut[k]`: the dual edge `k -> k + cw` is on the path.
const CUT_DOWN: u8 = 2;

/// Dijkstra from corner `a` to corner `b` over the padded corner grid of width `cw`. Returns the length
/// and the edges of the path (bits [`CUT_RIGHT`], [`CUT_DOWN`] at the edge's upper-left corner), or `None`
/// if `b` cannot be reached. Ties are broken by the corner index, so the result is deterministic.
#[inline(never)]
fn shortest_path(
    name: &'static str,
    cw: usize,
    right: &[f64],
    down: &[f64],
    a: usize,
    b: usize,
) -> Result<Option<(f64, Vec<u8>)>> {
    let nc = right.len();
    let mut dist = try_vec(name, nc, f64::INFINITY)?;
    // The move that reached each corner: 1 from the left, 2 from the right, 3 from above, 4 from below.
    let mut from = try_vec(name, nc, 0u8)?;
    let mut heap = RadixHeap::new();
    dist[a] = 0.0;
    // Distances are finite and >= 0, so their bit patterns order like the values.
    heap.push(0.0f64.to_bits(), a as u32);
    while let Some((bits, k)) = heap.pop() {
        let k = k as usize;
        if bits != dist[k].to_bits() {
            continue; // stale entry
        }
        if k == b {
            break;
        }
        let d = dist[k];
        let mut relax = |q: usize, wgt: f64, mv: u8, heap: &mut RadixHeap| {
            let nd = d + wgt;
            if nd < dist[q] {
                dist[q] = nd;
                from[q] = mv;
                heap.push(nd.to_bits(), q as u32);
            }
        };
        relax(k + 1, right[k], 1, &mut heap);
        relax(k - 1, right[k - 1], 2, &mut heap);
        relax(k + cw, down[k], 3, &mut heap);
        relax(k - cw, down[k - cw], 4, &mut heap);
    }
    if !dist[b].is_finite() {
        return Ok(None);
    }
    let mut cut = try_vec(name, nc, 0u8)?;
    let mut k = b;
    while k != a {
        k = match from[k] {
            1 => {
                cut[k - 1] |= CUT_RIGHT;
                k - 1
            }
            2 => {
                cut[k] |= CUT_RIGHT;
                k + 1
            }
            3 => {
                cut[k - cw] |= CUT_DOWN;
                k - cw
            }
            _ => {
                cut[k] |= CUT_DOWN;
                k + cw
            }
        };
    }
    Ok(Some((dist[b], cut)))
}

/// A monotone priority queue of `(key, corner)` (Ahuja, Mehlhorn, Orlin and Tarjan's radix heap over
/// 64-bit keys): every key pushed is at least the last key popped, which Dijkstra guarantees. An entry
/// sits in the bucket of the highest bit in which its key differs from the last popped key; popping
/// empties the lowest non-empty bucket into lower ones around its minimum. Amortised `O(64)` per entry,
/// against `O(log n)` comparisons with cache misses for a binary heap. Equal keys come out in a fixed
/// order (the results are deterministic).
struct RadixHeap {
    last: u64,
    len: usize,
    /// Bit `i` set iff `buckets[i]` is non-empty.
    full: u128,
    buckets: [Vec<(u64, u32)>; 65],
}

impl RadixHeap {
    fn new() -> RadixHeap {
        RadixHeap {
            last: 0,
            len: 0,
            full: 0,
            buckets: std::array::from_fn(|_| Vec::new()),
        }
    }

    #[inline]
    fn bucket(last: u64, key: u64) -> usize {
        (64 - (key ^ last).leading_zeros()) as usize
    }

    #[inline]
    fn push(&mut self, key: u64, v: u32) {
        debug_assert!(key >= self.last, "radix heap keys must not decrease");
        let i = Self::bucket(self.last, key);
        self.buckets[i].push((key, v));
        self.full |= 1 << i;
        self.len += 1;
    }

    #[inline(never)]
    fn pop(&mut self) -> Option<(u64, u32)> {
        if self.len == 0 {
            return None;
        }
        if self.full & 1 == 0 {
            let i = self.full.trailing_zeros() as usize;
            let mut moved = std::mem::take(&mut self.buckets[i]);
            self.full &= !(1 << i);
            let last = moved.iter().map(|e| e.0).min().expect("non-empty");
            self.last = last;
            for &(key, v) in &moved {
                let j = Self::bucket(last, key);
                self.buckets[j].push((key, v));
                self.full |= 1 << j;
            }
            moved.clear();
            // Keep the bucket's allocation for later refills.
            self.buckets[i] = moved;
        }
        self.len -= 1;
        let e = self.buckets[0].pop();
        if self.buckets[0].is_empty() {
            self.full &= !1;
        }
        e
    }
}

/// The two ring corners where the terminal of the ring pixels changes (condition 2), if every ring pixel
/// is tied (condition 1) and there are exactly two. Corners as `(i, j)`, `0 <= i <= h`, `0 <= j <= w`.
fn dual_terminals(h: usize, w: usize, class: &[u8]) -> Option<((usize, usize), (usize, usize))> {
    if h < 2 || w < 2 {
        return None;
    }
    let at = |i: usize, j: usize| class[i * w + j];
    let ring_tied = (0..w).all(|j| at(0, j) != PX_FREE && at(h - 1, j) != PX_FREE)
        && (0..h).all(|i| at(i, 0) != PX_FREE && at(i, w - 1) != PX_FREE);
    if !ring_tied {
        return None;
    }
    let mut switches: Vec<(usize, usize)> = Vec::with_capacity(3);
    let mut note = |p: u8, q: u8, c: (usize, usize)| {
        if p != q && switches.len() < 3 {
            switches.push(c);
        }
    };
    for j in 0..w - 1 {
        note(at(0, j), at(0, j + 1), (0, j + 1));
        note(at(h - 1, j), at(h - 1, j + 1), (h, j + 1));
    }
    for i in 0..h - 1 {
        note(at(i, 0), at(i + 1, 0), (i + 1, 0));
        note(at(i, w - 1), at(i + 1, w - 1), (i + 1, w));
    }
    match switches[..] {
        [a, b] => Some((a, b)),
        _ => None,
    }
}

/// Condition 3: every tied pixel is joined to the ring through pixels tied to the same terminal.
fn ties_reach_ring(name: &'static str, h: usize, w: usize, class: &[u8]) -> Result<bool> {
    let mut seen = try_vec(name, h * w, false)?;
    let mut stack: Vec<usize> = Vec::new();
    for (p, s) in seen.iter_mut().enumerate() {
        let (i, j) = (p / w, p % w);
        if i == 0 || j == 0 || i + 1 == h || j + 1 == w {
            *s = true;
            stack.push(p);
        }
    }
    while let Some(p) = stack.pop() {
        let (i, j) = (p / w, p % w);
        let k = class[p];
        let mut visit = |q: usize| {
            if !seen[q] && class[q] == k {
                seen[q] = true;
                stack.push(q);
            }
        };
        if j + 1 < w {
            visit(p + 1);
        }
        if j > 0 {
            visit(p - 1);
        }
        if i + 1 < h {
            visit(p + w);
        }
        if i > 0 {
            visit(p - w);
        }
    }
    Ok(class.iter().zip(&seen).all(|(&k, &s)| k == PX_FREE || s))
}

#[cfg(test)]
mod tests {
    use super::super::tests::{close, SplitMix};
    use super::*;
    use crate::maxflow::{grid_cut_cost, grid_mincut};
    use ndarray::Array2;

    /// A random region meeting the conditions: the ring split into a source run and a sink run at two
    /// random places, the interior free except for a few tied pixels (kept only where condition 3 holds,
    /// which `planar_mincut` checks itself).
    fn random_region(rng: &mut SplitMix, h: usize, w: usize) -> Vec<u8> {
        let ring: Vec<usize> = (0..w)
            .chain((1..h).map(|i| i * w + w - 1))
            .chain((0..w - 1).rev().map(|j| (h - 1) * w + j))
            .chain((1..h - 1).rev().map(|i| i * w))
            .collect();
        let (s, t) = (rng.below(ring.len()), rng.below(ring.len()));
        let (lo, hi) = (s.min(t), s.max(t).max(s.min(t) + 1));
        let mut class = vec![PX_FREE; h * w];
        for (k, &p) in ring.iter().enumerate() {
            class[p] = if (lo..hi).contains(&k) {
                PX_SINK
            } else {
                PX_SOURCE
            };
        }
        let p_tied = rng.uniform() * 0.3;
        for i in 1..h - 1 {
            for j in 1..w - 1 {
                if rng.uniform() < p_tied {
                    class[i * w + j] = if rng.below(2) == 0 {
                        PX_SOURCE
                    } else {
                        PX_SINK
                    };
                }
            }
        }
        class
    }

    /// Oracle: the BK grid solver on the same region (ties as hard masks). The flows agree to rounding
    /// (BK's includes the always-cut source–sink edges), and the planar labelling is a minimum cut.
    #[test]
    fn random_regions_match_bk() {
        let mut rng = SplitMix(2027);
        let mut tested = 0;
        for case in 0..3000 {
            let h = 2 + rng.below(12);
            let w = 2 + rng.below(12);
            let class = random_region(&mut rng, h, w);
            let zero_p = if case % 2 == 0 {
                0.0
            } else {
                rng.uniform() * 0.4
            };
            let cap = |rng: &mut SplitMix| {
                if rng.uniform() < zero_p {
                    0.0
                } else {
                    0.01 * (rng.uniform() * 9.0).exp()
                }
            };
            let wx =
                Array2::from_shape_fn((h, w), |(_, j)| if j + 1 < w { cap(&mut rng) } else { 0.0 });
            let wy =
                Array2::from_shape_fn((h, w), |(i, _)| if i + 1 < h { cap(&mut rng) } else { 0.0 });
            let got =
                planar_mincut("wx", h, w, &class, |i, j| wx[(i, j)], |i, j| wy[(i, j)]).unwrap();
            let Some((flow, sink_side)) = got else {
                continue;
            };
            tested += 1;
            let src = Array2::from_shape_fn((h, w), |(i, j)| class[i * w + j] == PX_SOURCE);
            let snk = Array2::from_shape_fn((h, w), |(i, j)| class[i * w + j] == PX_SINK);
            let want =
                grid_mincut(wx.view(), wy.view(), src.view(), snk.view(), None, None).unwrap();
            // Constant part: the edges between a source-tied and a sink-tied pixel.
            let mut constant = 0.0;
            for i in 0..h {
                for j in 0..w {
                    let p = class[i * w + j];
                    let tied_pair = |q: u8| p != PX_FREE && q != PX_FREE && p != q;
                    if j + 1 < w && tied_pair(class[i * w + j + 1]) {
                        constant += wx[(i, j)];
                    }
                    if i + 1 < h && tied_pair(class[(i + 1) * w + j]) {
                        constant += wy[(i, j)];
                    }
                }
            }
            assert!(
                close(flow + constant, want.flow),
                "case {case}: planar {flow} + {constant} != BK {}",
                want.flow
            );
            let labels = Array2::from_shape_vec((h, w), sink_side).unwrap();
            let cost = grid_cut_cost(
                wx.view(),
                wy.view(),
                Some(src.view()),
                Some(snk.view()),
                None,
                None,
                labels.view(),
            )
            .unwrap();
            assert!(
                close(cost, want.flow),
                "case {case}: cost of the planar labels {cost} != BK flow {}",
                want.flow
            );
            // With weights drawn from a continuum the minimum cut is unique apart from pixels behind
            // weight-0 edges; both solvers label by what the source reaches.
            if zero_p == 0.0 {
                assert_eq!(labels, want.sink_side, "case {case}");
            }
        }
        assert!(tested > 800, "only {tested} regions met the conditions");
    }

    #[test]
    fn conditions_are_checked() {
        let s = PX_SOURCE;
        let t = PX_SINK;
        let f = PX_FREE;
        let one = |_: usize, _: usize| 1.0;
        // A free ring pixel.
        let c = [s, f, s, s, f, t, t, t, t];
        assert!(planar_mincut("wx", 3, 3, &c, one, one).unwrap().is_none());
        // Four switches around the ring.
        let c = [s, t, s, t, f, t, s, t, s];
        assert!(planar_mincut("wx", 3, 3, &c, one, one).unwrap().is_none());
        // One source run, one sink run: solved (the free centre has two source and two sink neighbours:
        // either label cuts two unit edges, an exact tie).
        let c = [s, s, s, s, f, t, s, t, t];
        let (flow, labels) = planar_mincut("wx", 3, 3, &c, one, one).unwrap().unwrap();
        assert_eq!(flow, 2.0);
        for (&k, &l) in c.iter().zip(&labels) {
            assert!(k == f || l == (k == t));
        }
        // A sink island not joined to the sink run of the ring.
        let c = [
            s, s, s, s, s, //
            s, f, f, f, t, //
            s, f, t, f, t, //
            s, f, f, f, t, //
            t, t, t, t, t,
        ];
        assert!(planar_mincut("wx", 5, 5, &c, one, one).unwrap().is_none());
        // The same without the island: a 3 x 3 free block between a source run and a sink run.
        let mut c2 = c;
        c2[12] = f;
        let (flow, labels) = planar_mincut("wx", 5, 5, &c2, one, one).unwrap().unwrap();
        // Every separating staircase crosses three rows and three columns of unit edges.
        assert_eq!(flow, 6.0);
        assert_eq!(labels.len(), 25);
    }
}
