//! Max-flow / min-cut by the Boykov–Kolmogorov (BK) algorithm, written from the description in
//! Y. Boykov and V. Kolmogorov, "An experimental comparison of min-cut/max-flow algorithms for energy
//! minimization in vision", IEEE TPAMI 26(9), 2004.
//!
//! Two search trees are grown, `S` from the source and `T` from the sink. Each round has three stages:
//!
//! 1. **growth**: active nodes (kept in a FIFO) acquire the free nodes they reach through non-saturated
//!    residual arcs, until an arc joins the two trees (an augmenting path); a tree neighbour is also
//!    re-hung below the active node when that shortens its (no older) distance estimate;
//! 2. **augmentation**: the bottleneck capacity is pushed along the path; nodes whose tree arc saturates
//!    become *orphans*;
//! 3. **adoption**: every orphan looks for a new parent in its own tree whose chain of parents still
//!    reaches the terminal ("origin" check). Among the valid candidates the one closest to the terminal is
//!    taken; distances are cached per node with a timestamp (`ts`, `dist`), so that the chains checked in
//!    one adoption stage are walked only once. An orphan without a parent becomes free; its tree
//!    neighbours that could reach it are re-activated and its children become orphans in turn.
//!
//! The algorithm stops when no node is active. At that point `S` is exactly the set of nodes reachable
//! from the source in the residual graph.
//!
//! **Labelling rule** (everywhere in this module): a node is on the *source* side iff it belongs to the
//! final `S` tree, i.e. iff it is reachable from the source in the residual graph; every other node
//! (the `T` tree and the nodes left free) is on the *sink* side. This is a minimum cut: its cost equals the
//! flow value.
//!
//! There is one solver, `Network::solve`, generic over the adjacency structure (`Topology`): `u32`
//! indices, flat `f64` residual capacities with every arc stored next to its reverse (`a ^ 1`), node
//! state as a struct of arrays. Two front ends build such a network: [`Graph`], a general directed graph
//! with terminal links (CSR adjacency), and [`grid_mincut`], a 4-connected pixel grid whose arcs sit at
//! fixed slots, heads and reverse arcs found by index arithmetic, and in which pixels hard-wired to a
//! terminal are folded into the terminal links of their free neighbours; [`grid_mincut8`] is the same
//! front end on an 8-connected grid (diagonal edges too, for cuts whose cost approximates Euclidean length).
//!
//! The computation is sequential and deterministic.
//!
//! The ω cut's quadrants are s–t planar with both terminals on the outer face; they are solved by a
//! shortest path in the planar dual instead (`planar`, same minimum value, several times faster), with BK
//! as the fallback for regions that do not have that shape.

mod grid;
mod grid8;
mod planar;

pub(crate) use grid::GridNetwork;
pub use grid::{grid_cut_cost, grid_mincut, grid_mincuts, GridCut, GridCuts};
pub use grid8::{grid_cut_cost8, grid_mincut8};
#[cfg(test)]
pub(crate) use planar::planar_applies;
pub(crate) use planar::{planar_mincut, PX_FREE, PX_SINK, PX_SOURCE};

use crate::error::{alloc_error, try_collect, try_vec, Result};
use std::collections::VecDeque;

/// `parent` value of a node in no tree.
const FREE: u32 = u32::MAX;
/// `parent` value of a node linked directly to its terminal.
const TERMINAL: u32 = u32::MAX - 1;
/// `parent` value of an orphan (during adoption only).
const ORPHAN: u32 = u32::MAX - 2;
/// Largest number of nodes or arcs a [`Network`] can hold (the values above are reserved).
pub(crate) const MAX_INDEX: usize = (u32::MAX - 3) as usize;

/// The adjacency structure of a residual network. Arcs come in reverse pairs: the reverse of arc `a` is
/// `a ^ 1`, so both residual capacities of an edge share a cache line.
pub(crate) trait Topology {
    /// The arcs leaving node `i`, as `(arc, head)`. Every arc of the network must be listed from its
    /// tail, exactly once.
    fn arcs(&self, i: u32) -> impl Iterator<Item = (u32, u32)> + '_;
    /// The head node of arc `a`.
    fn head(&self, a: u32) -> u32;
}

/// Adjacency in compressed sparse row form: the arcs leaving node `i` are `adj[first[i]..first[i + 1]]`.
#[derive(Debug, Clone, Default)]
pub(crate) struct Csr {
    /// Offsets into `adj`, `n + 1` entries.
    first: Vec<u32>,
    /// Arc ids grouped by tail.
    adj: Vec<u32>,
    /// Head node of every arc.
    head: Vec<u32>,
}

impl Topology for Csr {
    #[inline]
    fn arcs(&self, i: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
        let lo = self.first[i as usize] as usize;
        let hi = self.first[i as usize + 1] as usize;
        self.adj[lo..hi].iter().map(|&a| (a, self.head[a as usize]))
    }

    #[inline]
    fn head(&self, a: u32) -> u32 {
        self.head[a as usize]
    }
}

/// A residual network: an adjacency structure, the residual capacity of every arc, and the terminal
/// links of every node.
///
/// The terminal links of node `i` are kept as the single number `tr[i]`: a positive value is a residual
/// capacity source → `i`, a negative one a residual capacity `i` → sink (the common part of both links
/// has already been pushed and counted in `flow`).
#[derive(Debug, Clone)]
pub(crate) struct Network<T> {
    /// Adjacency.
    pub(crate) topo: T,
    /// Residual capacity of every arc (finite, >= 0); arc `a ^ 1` is the reverse of arc `a`.
    pub(crate) rcap: Vec<f64>,
    /// Residual terminal capacity of every node (see the type documentation); may be infinite.
    pub(crate) tr: Vec<f64>,
    /// Flow already routed before the search (trivial source → node → sink paths, constant terms).
    pub(crate) flow: f64,
}

/// Flag bit of a node in the `T` tree (else `S`; meaningless for free nodes).
const IN_T: u8 = 1;
/// Flag bit of a node in the active queue.
const ACTIVE: u8 = 2;

/// Result of [`Network::solve`].
#[derive(Debug, Clone)]
pub(crate) struct Solution {
    /// Max-flow value (including [`Network::flow`]).
    pub(crate) flow: f64,
    /// `true` for nodes on the sink side (see the labelling rule in the module documentation).
    pub(crate) sink_side: Vec<bool>,
}

impl<T: Topology> Network<T> {
    /// Runs the BK algorithm on the residual network (which is left in its final residual state) and
    /// returns the flow value and the minimum cut.
    ///
    /// Fallible: the search state (about 30 bytes per node) is allocated with `try_reserve`, so a network
    /// too large for the memory left is an error naming `name` (the caller's parameter), not an abort.
    pub(crate) fn solve(&mut self, name: &'static str) -> Result<Solution> {
        let n = self.tr.len();
        let mut active = VecDeque::new();
        active
            .try_reserve_exact(n)
            .map_err(|_| alloc_error::<u32>(name, n))?;
        let mut bk = Bk {
            parent: try_vec(name, n, FREE)?,
            stamp: try_vec(name, n, (0, 0))?,
            flags: try_vec(name, n, 0)?,
            active,
            orphans: VecDeque::new(),
            path: try_vec(name, n, (0, 0))?,
            time: 0,
            flow: self.flow,
            net: self,
        };
        bk.run();
        let flow = bk.flow;
        let sink_side = try_collect(
            name,
            n,
            bk.parent
                .iter()
                .zip(&bk.flags)
                .map(|(&p, &f)| p == FREE || f & IN_T != 0),
        )?;
        Ok(Solution { flow, sink_side })
    }
}

/// The BK search state over one [`Network`] (struct of arrays: the parent chains walked by augmentation
/// and adoption touch only `parent`).
struct Bk<'a, T> {
    net: &'a mut Network<T>,
    /// Arc from each node to its parent, or [`FREE`], [`TERMINAL`], [`ORPHAN`].
    parent: Vec<u32>,
    /// `(ts, dist)`: distance to the terminal along parent arcs (1 for children of the terminal) and the
    /// time it was computed.
    stamp: Vec<(u32, u32)>,
    /// [`IN_T`] and [`ACTIVE`] bits.
    flags: Vec<u8>,
    active: VecDeque<u32>,
    orphans: VecDeque<u32>,
    /// Scratch buffer of augmentation: `(node, flow arc)` along the path.
    path: Vec<(u32, u32)>,
    /// Current timestamp, advanced once per augmentation.
    time: u32,
    flow: f64,
}

impl<T: Topology> Bk<'_, T> {
    fn run(&mut self) {
        // Every node with a residual terminal link starts as a child of its terminal, active.
        for (i, &tr) in self.net.tr.iter().enumerate() {
            if tr != 0.0 {
                self.parent[i] = TERMINAL;
                self.stamp[i] = (0, 1);
                self.flags[i] = ACTIVE | if tr < 0.0 { IN_T } else { 0 };
                self.active.push_back(i as u32);
            }
        }
        loop {
            // The next active node still in a tree (nodes freed by adoption stay queued until here).
            let p = loop {
                match self.active.front() {
                    None => return,
                    Some(&p) if self.parent[p as usize] == FREE => {
                        self.flags[p as usize] &= !ACTIVE;
                        self.active.pop_front();
                    }
                    Some(&p) => break p,
                }
            };
            match self.grow(p) {
                // `p` is exhausted: it becomes passive. Otherwise it stays at the front of the queue and
                // is grown again after the augmentation, since it may reach further paths.
                None => {
                    self.flags[p as usize] &= !ACTIVE;
                    self.active.pop_front();
                }
                Some((a, s_node, t_node)) => {
                    self.time += 1;
                    self.augment(a, s_node, t_node);
                    self.adopt();
                }
            }
        }
    }

    /// Growth stage at the active node `p`: acquires free neighbours, and returns the first arc found from
    /// the `S` tree to the `T` tree (with its tail and head) if any.
    #[inline]
    fn grow(&mut self, p: u32) -> Option<(u32, u32, u32)> {
        let net = &*self.net;
        let in_t = self.flags[p as usize] & IN_T;
        let (ts, dist) = self.stamp[p as usize];
        for (a, q) in net.topo.arcs(p) {
            // Residual capacity in the direction of the flow: p -> q in S, q -> p in T.
            if net.rcap[(a ^ in_t as u32) as usize] <= 0.0 {
                continue;
            }
            let qi = q as usize;
            if self.parent[qi] == FREE {
                self.parent[qi] = a ^ 1;
                self.stamp[qi] = (ts, dist + 1);
                // A freed node may still be queued (ACTIVE set); it is then grown from its new tree.
                if self.flags[qi] & ACTIVE == 0 {
                    self.active.push_back(q);
                }
                self.flags[qi] = in_t | ACTIVE;
            } else if self.flags[qi] & IN_T != in_t {
                return Some(if in_t == 0 { (a, p, q) } else { (a ^ 1, q, p) });
            } else {
                let (tq, dq) = self.stamp[qi];
                if tq <= ts && dq > dist + 1 {
                    // `q` can hang below `p` with a shorter, no older, distance estimate.
                    self.parent[qi] = a ^ 1;
                    self.stamp[qi] = (ts, dist + 1);
                }
            }
        }
        None
    }

    /// Augmentation stage: pushes the bottleneck capacity along source → ... → `s_node` -a-> `t_node` → ...
    /// → sink and turns the nodes whose tree link saturates into orphans.
    fn augment(&mut self, a: u32, s_node: u32, t_node: u32) {
        let net = &mut *self.net;
        let parent = &mut self.parent;
        let path = &mut self.path[..];
        // Walk both tree paths once, collecting the flow arcs: in S the flow runs parent -> x (arc
        // pa ^ 1), in T x -> parent (arc pa). The walk is a pure chain of `parent` loads; the bottleneck
        // is taken afterwards over independent loads. The two paths are disjoint, so `len <= n`.
        let mut len = 0;
        let mut x = s_node;
        let s_root = loop {
            let pa = parent[x as usize];
            if pa == TERMINAL {
                break x;
            }
            path[len] = (x, pa ^ 1);
            len += 1;
            x = net.topo.head(pa);
        };
        let mut x = t_node;
        let t_root = loop {
            let pa = parent[x as usize];
            if pa == TERMINAL {
                break x;
            }
            path[len] = (x, pa);
            len += 1;
            x = net.topo.head(pa);
        };
        let path = &path[..len];
        let mut b = min(
            net.rcap[a as usize],
            min(net.tr[s_root as usize], -net.tr[t_root as usize]),
        );
        for &(_, fa) in path {
            b = min(b, net.rcap[fa as usize]);
        }
        // Push. `b` is one of the residual capacities on the path, so the saturated ones become exactly 0;
        // the node below a saturated tree arc becomes an orphan.
        net.rcap[a as usize] -= b;
        net.rcap[(a ^ 1) as usize] += b;
        for &(x, fa) in path.iter() {
            net.rcap[(fa ^ 1) as usize] += b;
            let r = &mut net.rcap[fa as usize];
            *r -= b;
            if *r <= 0.0 {
                parent[x as usize] = ORPHAN;
                self.orphans.push_front(x);
            }
        }
        net.tr[s_root as usize] -= b;
        if net.tr[s_root as usize] <= 0.0 {
            parent[s_root as usize] = ORPHAN;
            self.orphans.push_front(s_root);
        }
        net.tr[t_root as usize] += b;
        if net.tr[t_root as usize] >= 0.0 {
            parent[t_root as usize] = ORPHAN;
            self.orphans.push_front(t_root);
        }
        self.flow += b;
    }

    /// Adoption stage: processes orphans until none is left.
    fn adopt(&mut self) {
        while let Some(x) = self.orphans.pop_front() {
            self.process_orphan(x);
        }
    }

    /// Adoption of one orphan `x`: a new parent in its own tree, or `x` becomes free.
    fn process_orphan(&mut self, x: u32) {
        let net = &*self.net;
        let in_t = self.flags[x as usize] & IN_T;
        let mut best = FREE;
        let mut dmin = u32::MAX;
        // Candidate parents: tree neighbours q with residual capacity in the direction of the flow from
        // the terminal, q -> x in S (arc a ^ 1), x -> q in T (arc a).
        for (a, q) in net.topo.arcs(x) {
            let qi = q as usize;
            if net.rcap[(a ^ 1 ^ in_t as u32) as usize] <= 0.0
                || self.parent[qi] == FREE
                || self.flags[qi] & IN_T != in_t
            {
                continue;
            }
            if let Some(d) = origin_distance(&net.topo, &self.parent, &mut self.stamp, self.time, q)
            {
                if d < dmin {
                    dmin = d;
                    best = a;
                }
            }
        }
        if best != FREE {
            self.parent[x as usize] = best;
            self.stamp[x as usize] = (self.time, dmin + 1);
            return;
        }
        // No parent: `x` becomes free. Its tree neighbours that could grow into it become active again,
        // and its children become orphans.
        self.parent[x as usize] = FREE;
        for (a, q) in net.topo.arcs(x) {
            let qi = q as usize;
            let pq = self.parent[qi];
            if pq == FREE || self.flags[qi] & IN_T != in_t {
                continue;
            }
            if net.rcap[(a ^ in_t as u32) as usize] > 0.0 && self.flags[qi] & ACTIVE == 0 {
                self.flags[qi] |= ACTIVE;
                self.active.push_back(q);
            }
            if pq != TERMINAL && pq != ORPHAN && net.topo.head(pq) == x {
                self.parent[qi] = ORPHAN;
                self.orphans.push_back(q);
            }
        }
    }
}

/// Minimum of two capacities (never NaN), without the NaN handling of `f64::min`.
#[inline(always)]
fn min(a: f64, b: f64) -> f64 {
    if b < a {
        b
    } else {
        a
    }
}

/// Distance from `q` to its terminal along parent arcs if the chain reaches the terminal without meeting
/// an orphan; caches the distances of the chain in `stamp` with timestamp `time`.
#[inline]
fn origin_distance<T: Topology>(
    topo: &T,
    parent: &[u32],
    stamp: &mut [(u32, u32)],
    time: u32,
    q: u32,
) -> Option<u32> {
    let mut d: u32 = 0;
    let mut j = q as usize;
    loop {
        let (ts, dist) = stamp[j];
        if ts == time {
            d += dist;
            break;
        }
        d += 1;
        let pa = parent[j];
        if pa == TERMINAL {
            stamp[j] = (time, 1);
            break;
        }
        if pa == ORPHAN {
            return None;
        }
        j = topo.head(pa) as usize;
    }
    // Cache the distances along the checked chain.
    let dq = d;
    let mut j = q as usize;
    while stamp[j].0 != time {
        stamp[j] = (time, d);
        d -= 1;
        j = topo.head(parent[j]) as usize;
    }
    Some(dq)
}

/// A general directed graph with terminal links, solved by BK.
///
/// Nodes are `0..n_nodes`. Arcs and terminal links accumulate; [`Graph::maxflow`] builds the residual
/// network from them and solves it from scratch (so it may be called again after adding more arcs).
///
/// ```
/// use _core::maxflow::Graph;
/// let mut g = Graph::new(2);
/// g.add_tweights(0, 5.0, 0.0);
/// g.add_tweights(1, 0.0, 4.0);
/// g.add_edge(0, 1, 3.0, 0.0);
/// assert_eq!(g.maxflow(), 3.0);
/// assert!(!g.is_sink_side(0) && g.is_sink_side(1));
/// ```
#[derive(Debug, Clone)]
pub struct Graph {
    /// Arcs as given: `(u, v, cap u -> v, cap v -> u)`.
    edges: Vec<(u32, u32, f64, f64)>,
    /// Accumulated source link capacity of every node.
    source_cap: Vec<f64>,
    /// Accumulated sink link capacity of every node.
    sink_cap: Vec<f64>,
    /// Labels of the last [`Graph::maxflow`] (empty before).
    sink_side: Vec<bool>,
}

impl Graph {
    /// An empty graph with `n_nodes` nodes and no arcs.
    ///
    /// # Panics
    /// If `n_nodes` exceeds `u32::MAX - 3`.
    pub fn new(n_nodes: usize) -> Graph {
        Graph::with_capacity(n_nodes, 0)
    }

    /// Like [`Graph::new`], reserving room for `n_edges` calls of [`Graph::add_edge`].
    ///
    /// # Panics
    /// If `n_nodes` exceeds `u32::MAX - 3`.
    pub fn with_capacity(n_nodes: usize, n_edges: usize) -> Graph {
        assert!(n_nodes <= MAX_INDEX, "too many nodes: {n_nodes}");
        Graph {
            edges: Vec::with_capacity(n_edges),
            source_cap: vec![0.0; n_nodes],
            sink_cap: vec![0.0; n_nodes],
            sink_side: Vec::new(),
        }
    }

    /// Number of nodes.
    pub fn n_nodes(&self) -> usize {
        self.source_cap.len()
    }

    /// Adds the arc `u -> v` with capacity `cap` and the arc `v -> u` with capacity `rev_cap`.
    /// Self-loops are accepted and ignored (they never cross a cut).
    ///
    /// # Panics
    /// If a node is out of range or a capacity is negative, infinite or NaN.
    pub fn add_edge(&mut self, u: usize, v: usize, cap: f64, rev_cap: f64) {
        let n = self.n_nodes();
        assert!(u < n && v < n, "edge ({u}, {v}) out of range for {n} nodes");
        assert!(
            cap.is_finite() && cap >= 0.0 && rev_cap.is_finite() && rev_cap >= 0.0,
            "edge capacities must be finite and >= 0, got {cap}, {rev_cap}"
        );
        self.edges.push((u as u32, v as u32, cap, rev_cap));
    }

    /// Adds `source_cap` to the capacity of the link source -> `u` and `sink_cap` to the link `u` -> sink.
    /// `f64::INFINITY` ties the node to that terminal (a node tied to both makes the flow infinite).
    ///
    /// # Panics
    /// If `u` is out of range or a capacity is negative or NaN.
    pub fn add_tweights(&mut self, u: usize, source_cap: f64, sink_cap: f64) {
        let n = self.n_nodes();
        assert!(u < n, "node {u} out of range for {n} nodes");
        assert!(
            source_cap >= 0.0 && sink_cap >= 0.0,
            "terminal capacities must be >= 0, got {source_cap}, {sink_cap}"
        );
        self.source_cap[u] += source_cap;
        self.sink_cap[u] += sink_cap;
    }

    /// Computes the maximum flow from source to sink and the minimum cut, returning the flow value. The
    /// value is `f64::INFINITY` only when every cut is infinite (a node tied to both terminals).
    ///
    /// # Panics
    /// If the solver's arrays cannot be allocated (see [`Graph::try_maxflow`]).
    pub fn maxflow(&mut self) -> f64 {
        self.try_maxflow().unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Graph::maxflow`] with its arrays (about 50 bytes per node and arc) allocated fallibly: a graph too
    /// large for the memory left is an error naming `nodes` or `arcs` instead of an abort.
    pub fn try_maxflow(&mut self) -> Result<f64> {
        let n = self.n_nodes();
        // Edge e gives the arcs 2e (u -> v) and 2e + 1 (v -> u); CSR by counting sort over the tails.
        let kept = |&&(u, v, c, r): &&(u32, u32, f64, f64)| u != v && (c > 0.0 || r > 0.0);
        let m = 2 * self.edges.iter().filter(kept).count();
        assert!(m <= MAX_INDEX, "too many arcs: {m}");
        let mut first = try_vec("nodes", n + 1, 0u32)?;
        for &(u, v, _, _) in self.edges.iter().filter(kept) {
            first[u as usize + 1] += 1;
            first[v as usize + 1] += 1;
        }
        for i in 0..n {
            first[i + 1] += first[i];
        }
        let mut fill = try_collect("nodes", n, first[..n].iter().copied())?;
        let mut adj = try_vec("arcs", m, 0u32)?;
        let mut head = try_vec("arcs", m, 0u32)?;
        let mut rcap = try_vec("arcs", m, 0.0f64)?;
        for (e, &(u, v, c, r)) in self.edges.iter().filter(kept).enumerate() {
            let a = 2 * e as u32;
            head[a as usize] = v;
            rcap[a as usize] = c;
            head[a as usize + 1] = u;
            rcap[a as usize + 1] = r;
            adj[fill[u as usize] as usize] = a;
            fill[u as usize] += 1;
            adj[fill[v as usize] as usize] = a + 1;
            fill[v as usize] += 1;
        }
        // Terminal links: push the common part of both links directly.
        let mut flow = 0.0;
        let mut tr = try_vec("nodes", n, 0.0f64)?;
        for ((t, &cs), &ck) in tr.iter_mut().zip(&self.source_cap).zip(&self.sink_cap) {
            if cs == f64::INFINITY && ck == f64::INFINITY {
                flow = f64::INFINITY;
            } else {
                flow += cs.min(ck);
                *t = cs - ck;
            }
        }
        let mut net = Network {
            topo: Csr { first, adj, head },
            rcap,
            tr,
            flow,
        };
        let sol = net.solve("nodes")?;
        self.sink_side = sol.sink_side;
        Ok(sol.flow)
    }

    /// After [`Graph::maxflow`]: whether node `u` is on the sink side of the minimum cut (see the labelling
    /// rule in the [module documentation](self): source side = reachable from the source in the residual
    /// graph).
    ///
    /// # Panics
    /// If [`Graph::maxflow`] has not been called or `u` is out of range.
    pub fn is_sink_side(&self, u: usize) -> bool {
        assert!(
            !self.sink_side.is_empty() || self.n_nodes() == 0,
            "call maxflow() first"
        );
        self.sink_side[u]
    }

    /// After [`Graph::maxflow`]: the sink-side flag of every node.
    pub fn sink_side(&self) -> &[bool] {
        &self.sink_side
    }

    /// The cost of the cut given by a labelling (`true` = sink side): the capacities of the arcs from
    /// source-side to sink-side nodes, plus the source links of sink-side nodes and the sink links of
    /// source-side nodes.
    ///
    /// # Panics
    /// If `sink_side.len()` differs from the number of nodes.
    pub fn cut_cost(&self, sink_side: &[bool]) -> f64 {
        assert_eq!(sink_side.len(), self.n_nodes(), "one label per node");
        let mut cost = 0.0;
        for (i, &s) in sink_side.iter().enumerate() {
            cost += if s {
                self.source_cap[i]
            } else {
                self.sink_cap[i]
            };
        }
        for &(u, v, c, r) in &self.edges {
            match (sink_side[u as usize], sink_side[v as usize]) {
                (false, true) => cost += c,
                (true, false) => cost += r,
                _ => {}
            }
        }
        cost
    }
}

/// Slow obvious oracle for tests: the minimum of [`Graph::cut_cost`] over all `2^n` labellings.
///
/// # Panics
/// If the graph has more than 20 nodes.
#[doc(hidden)]
#[cfg(any(test, feature = "oracles"))]
pub fn brute_force_mincut(g: &Graph) -> f64 {
    let n = g.n_nodes();
    assert!(n <= 20, "brute force is for tiny graphs only (n = {n})");
    let mut labels = vec![false; n];
    let mut best = f64::INFINITY;
    for mask in 0u32..(1u32 << n) {
        for (i, l) in labels.iter_mut().enumerate() {
            *l = mask >> i & 1 == 1;
        }
        best = best.min(g.cut_cost(&labels));
    }
    best
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// splitmix64, for reproducible pseudo-random tests.
    pub(crate) struct SplitMix(pub(crate) u64);

    impl SplitMix {
        pub(crate) fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        /// Uniform in [0, 1).
        pub(crate) fn uniform(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        /// Uniform in 0..n.
        pub(crate) fn below(&mut self, n: usize) -> usize {
            (self.next_u64() % n as u64) as usize
        }
    }

    pub(crate) fn close(a: f64, b: f64) -> bool {
        if a.is_infinite() || b.is_infinite() {
            return a == b;
        }
        (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1.0)
    }

    fn random_graph(rng: &mut SplitMix) -> Graph {
        let n = 1 + rng.below(12);
        let mut g = Graph::new(n);
        let p_edge = rng.uniform();
        for u in 0..n {
            for v in u + 1..n {
                if rng.uniform() < p_edge {
                    let c = if rng.below(5) == 0 {
                        0.0
                    } else {
                        rng.uniform() * 10.0
                    };
                    let r = if rng.below(3) == 0 {
                        0.0
                    } else {
                        rng.uniform() * 10.0
                    };
                    if rng.below(2) == 0 {
                        g.add_edge(u, v, c, r);
                    } else {
                        g.add_edge(v, u, c, r);
                    }
                }
            }
        }
        // A few parallel arcs and self-loops.
        for _ in 0..rng.below(3) {
            let (u, v) = (rng.below(n), rng.below(n));
            g.add_edge(u, v, rng.uniform() * 3.0, rng.uniform() * 3.0);
        }
        for u in 0..n {
            let kind = rng.below(8);
            let s = match kind {
                0 => f64::INFINITY,
                1..=3 => 0.0,
                _ => rng.uniform() * 12.0,
            };
            let t = match rng.below(8) {
                0 if kind != 0 => f64::INFINITY,
                0..=3 => 0.0,
                _ => rng.uniform() * 12.0,
            };
            g.add_tweights(u, s, t);
            if rng.below(4) == 0 {
                g.add_tweights(u, rng.uniform(), rng.uniform());
            }
        }
        g
    }

    #[test]
    fn random_graphs_match_brute_force() {
        let mut rng = SplitMix(12345);
        for case in 0..1500 {
            let mut g = random_graph(&mut rng);
            let want = brute_force_mincut(&g);
            let flow = g.maxflow();
            assert!(
                close(flow, want),
                "case {case}: flow {flow} != brute force {want}"
            );
            let labels = g.sink_side().to_vec();
            let cost = g.cut_cost(&labels);
            assert!(
                close(cost, flow),
                "case {case}: cut cost {cost} != flow {flow}"
            );
            // Source side = reachable from the source in the residual graph: a second solve is identical.
            let flow2 = g.maxflow();
            assert_eq!(flow.to_bits(), flow2.to_bits());
            assert_eq!(labels, g.sink_side());
        }
    }

    #[test]
    fn small_examples() {
        let mut g = Graph::new(0);
        assert_eq!(g.maxflow(), 0.0);

        // Node tied to both terminals: infinite flow.
        let mut g = Graph::new(1);
        g.add_tweights(0, f64::INFINITY, f64::INFINITY);
        assert_eq!(g.maxflow(), f64::INFINITY);

        // Infinite source link, finite chain.
        let mut g = Graph::new(3);
        g.add_tweights(0, f64::INFINITY, 0.0);
        g.add_tweights(2, 0.0, f64::INFINITY);
        g.add_edge(0, 1, 2.0, 0.0);
        g.add_edge(1, 2, 5.0, 1.0);
        assert_eq!(g.maxflow(), 2.0);
        assert!(!g.is_sink_side(0));
        assert!(
            g.is_sink_side(1),
            "1 is not reachable from the source after the cut"
        );
        assert!(g.is_sink_side(2));

        // Isolated node without links goes to the sink side.
        let mut g = Graph::new(2);
        g.add_tweights(0, 1.0, 0.0);
        assert_eq!(g.maxflow(), 0.0);
        assert!(!g.is_sink_side(0));
        assert!(g.is_sink_side(1));

        // Both links: the common part is flow.
        let mut g = Graph::new(1);
        g.add_tweights(0, 3.0, 2.0);
        assert_eq!(g.maxflow(), 2.0);
        assert!(!g.is_sink_side(0));
    }

    #[test]
    #[should_panic]
    fn negative_capacity_panics() {
        Graph::new(2).add_edge(0, 1, -1.0, 0.0);
    }
}

#[cfg(test)]
mod alloc_tests {
    use super::GridNetwork;
    use crate::error::{assert_alloc_error, HUGE_SIDE};

    /// A grid network too large for any address space is an error naming the caller's parameter, not an
    /// abort (the omega cut builds its quadrant networks with this constructor; grid_mincut's `build` and
    /// the BK state of `Network::solve` use the same fallible allocations).
    #[test]
    fn a_network_that_cannot_be_allocated_is_an_error() {
        assert_alloc_error(GridNetwork::new("wx", HUGE_SIDE, HUGE_SIDE), "wx");
        assert!(GridNetwork::new("wx", 3, 4).is_ok());
    }
}
