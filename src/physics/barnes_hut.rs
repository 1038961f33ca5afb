//! Barnes–Hut: mutual attraction in O(n log n) for large fields.
//!
//! A quadtree over the balls' centres. Each node keeps the total mass, the centre of mass, the
//! quadrupole moment about it, the tight bounding box of the centres it holds and the largest
//! radius among its balls. The force on one ball walks the tree from the root: a node that is far
//! enough — its size over the distance to its centre of mass below the opening angle θ — and
//! clear of contact is replaced by its multipole expansion; any other node is opened, and a leaf
//! that is opened is summed exactly, pair by pair, with [`attraction_force`] (through
//! [`attraction_pair`], which gives the same bits and the pair's orbit rate). So every pair that
//! touches or overlaps gets the uniform-ball interior force exactly as the direct sum gives it,
//! and θ = 0 opens every node: the direct sum, in another order.
//!
//! Use: [`BarnesHut::build`] once per force evaluation (`&mut self`: the arena of nodes and the
//! sorted copies are kept and reused, so a build allocates nothing once the field stops growing),
//! then any number of queries — [`BarnesHut::force`] / [`BarnesHut::force_and_rate`] for a ball of
//! the tree, [`BarnesHut::force_at`] for a body anywhere (`&self`: they read the tree only, so they
//! can run on several threads at once; the threaded runtime's ball threads share one tree). The
//! result for a ball depends on the tree alone — never on which thread asks or in which order.
//!
//! Deterministic: the tree is built from Morton codes sorted with the ball's index as tie-break,
//! children are always visited in the same order, and every sum runs in a fixed order.
//!
//! Pure: f64 throughout, no threads, no I/O.

use glam::DVec2;

#[cfg(doc)]
use super::effects::attraction_force;
use super::effects::{Attraction, attraction_pair};

/// Most balls a leaf holds (a leaf is opened pair by pair). Measured (`cargo bench --bench
/// attraction`, one force evaluation): 4 is the fastest at 1,000 balls and 16 at 10,000; 8 is
/// within 13 % and 9 % of them.
pub const LEAF_SIZE: usize = 8;

/// Bits of a Morton code per axis: the tree is at most this deep. Balls closer than the root's
/// size / 2³² (coincident ones included) share a leaf, however many they are: no endless split.
const MAX_DEPTH: u32 = 32;

/// A node of the tree. Its children follow it in the arena (depth-first order), so a walk never
/// needs a stack: `k + 1` goes down, `next` skips the whole subtree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Node {
    /// Centre of mass, m.
    com: DVec2,
    /// Total mass, kg.
    mass: f64,
    /// `(size / θ)²`: the node may be approximated from farther than this (squared distance to
    /// its centre of mass). +∞ for θ = 0.
    open2: f64,
    /// Quadrupole moment about the centre of mass: the in-plane block of the traceless 3D tensor,
    /// `Σ m·(3·s·sᵀ − |s|²·I)`, kg·m².
    qxx: f64,
    qxy: f64,
    qyy: f64,
    /// Tight bounding box of the centres it holds.
    lo: DVec2,
    hi: DVec2,
    /// Largest radius among its balls, m.
    r_max: f64,
    /// Its balls are `start..end` in tree order.
    start: u32,
    end: u32,
    /// The node after its subtree.
    next: u32,
    leaf: bool,
}

/// The tree, and the scratch it is built in. See the module documentation.
#[derive(Clone, Debug, Default)]
pub struct BarnesHut {
    attraction: Attraction,
    monopole_only: bool,
    nodes: Vec<Node>,
    /// (Morton code, ball index), sorted.
    keys: Vec<(u64, u32)>,
    /// The balls in tree order.
    pos: Vec<DVec2>,
    mass: Vec<f64>,
    inverse_mass: Vec<f64>,
    radius: Vec<f64>,
    /// Tree order → ball index.
    index: Vec<u32>,
    /// Ball index → tree order.
    slot: Vec<u32>,
}

/// Spreads the 32 bits of `v` over the even bits of a u64.
#[inline]
fn spread(v: u32) -> u64 {
    let mut x = v as u64;
    x = (x | (x << 16)) & 0x0000_ffff_0000_ffff;
    x = (x | (x << 8)) & 0x00ff_00ff_00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333_3333_3333;
    x = (x | (x << 1)) & 0x5555_5555_5555_5555;
    x
}

impl BarnesHut {
    /// An empty tree; it allocates on its first build and reuses that memory afterwards.
    pub fn new() -> Self {
        Self::default()
    }

    /// Drops the quadrupole terms from the next builds, leaving the monopole (total mass at the
    /// centre of mass) alone: for measuring what the quadrupole buys (`opening_angle_sweep` in
    /// `tests/barnes_hut.rs`). The engine always uses the quadrupole.
    pub fn set_monopole_only(&mut self, on: bool) {
        self.monopole_only = on;
    }

    /// Number of balls in the tree.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// Whether the tree holds no ball.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Number of nodes of the last build.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The balls' indices in tree order (nearby balls next to each other). Querying in this order
    /// is faster than in a random index order (measured: 15 against 18 ms at 10,000 balls, 0.22
    /// against 0.34 s at 100,000: the walks of neighbours touch the same nodes); the results are
    /// the same.
    pub fn order(&self) -> &[u32] {
        &self.index
    }

    /// The G and opening angle θ the tree was built with.
    pub fn attraction(&self) -> &Attraction {
        &self.attraction
    }

    /// Builds the tree of the balls at `position` with `mass` and `radius` (parallel slices,
    /// indexed like the state), for `attraction`'s G and opening angle. Reuses its memory.
    ///
    /// Non-finite positions do not panic (they make non-finite forces, as in the direct sum).
    pub fn build(&mut self, position: &[DVec2], mass: &[f64], radius: &[f64], attraction: &Attraction) {
        let n = position.len();
        assert!(mass.len() == n && radius.len() == n, "position, mass and radius must have the same length");
        assert!(n <= u32::MAX as usize, "too many balls for the tree");
        self.attraction = *attraction;
        self.nodes.clear();
        self.keys.clear();
        self.pos.clear();
        self.mass.clear();
        self.inverse_mass.clear();
        self.radius.clear();
        self.index.clear();
        self.slot.clear();
        if n == 0 {
            return;
        }

        // The square root cell, and each centre's Morton code in it.
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        for p in position {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let side = (hi - lo).max_element();
        // A zero-size (or non-finite) box puts every code at 0: one leaf, summed exactly.
        let scale = if side > 0.0 && side.is_finite() { u32::MAX as f64 / side } else { 0.0 };
        // `as u32` saturates (and maps NaN to 0), so no code is out of range.
        self.keys.extend(position.iter().enumerate().map(|(i, p)| {
            let q = (*p - lo) * scale;
            (spread(q.x as u32) | (spread(q.y as u32) << 1), i as u32)
        }));
        // Keys are distinct (the index breaks ties), so the unstable sort is deterministic.
        self.keys.sort_unstable();

        self.slot.resize(n, 0);
        for (s, &(_, i)) in self.keys.iter().enumerate() {
            let i = i as usize;
            self.index.push(i as u32);
            self.slot[i] = s as u32;
            self.pos.push(position[i]);
            self.mass.push(mass[i]);
            self.inverse_mass.push(1.0 / mass[i]);
            self.radius.push(radius[i]);
        }
        self.build_node(0, n);
    }

    /// Builds the subtree of the balls `start..end` (tree order) into the arena; returns its index.
    fn build_node(&mut self, start: usize, end: usize) -> usize {
        let k = self.nodes.len();
        self.nodes.push(Node { start: start as u32, end: end as u32, ..Node::default() });
        let first = self.keys[start].0;
        let last = self.keys[end - 1].0;
        // The codes of a range share their leading digits; the first digit (2 bits) where the
        // first and last codes differ is where this range splits into quadrants.
        let common = (first ^ last).leading_zeros() / 2;
        if end - start <= LEAF_SIZE || common >= MAX_DEPTH {
            self.finish_leaf(k);
        } else {
            let shift = 2 * (MAX_DEPTH - 1 - common);
            // The digits above the split, shared by the whole range (none at the root's level).
            let above = first & (!0u64).checked_shl(shift + 2).unwrap_or(0);
            let mut s = start;
            for quadrant in 0..4u64 {
                // The last code of this quadrant.
                let upper = above | (quadrant << shift) | ((1u64 << shift) - 1);
                let e = s + self.keys[s..end].partition_point(|&(c, _)| c <= upper);
                if e > s {
                    self.build_node(s, e);
                }
                s = e;
            }
            debug_assert_eq!(s, end);
            self.finish_internal(k);
        }
        self.nodes[k].next = self.nodes.len() as u32;
        k
    }

    fn finish_leaf(&mut self, k: usize) {
        let (start, end) = (self.nodes[k].start as usize, self.nodes[k].end as usize);
        let mut m = 0.0;
        let mut mp = DVec2::ZERO;
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        let mut r_max = 0.0f64;
        for s in start..end {
            let p = self.pos[s];
            m += self.mass[s];
            mp += self.mass[s] * p;
            lo = lo.min(p);
            hi = hi.max(p);
            r_max = r_max.max(self.radius[s]);
        }
        let com = centre_of_mass(mp, m, lo, hi);
        let (mut qxx, mut qxy, mut qyy) = (0.0, 0.0, 0.0);
        for s in start..end {
            let (a, b, c) = quadrupole(self.mass[s], self.pos[s] - com);
            qxx += a;
            qxy += b;
            qyy += c;
        }
        let theta = self.attraction.opening_angle;
        if self.monopole_only {
            (qxx, qxy, qyy) = (0.0, 0.0, 0.0);
        }
        let node = &mut self.nodes[k];
        *node = Node { com, mass: m, open2: open2(lo, hi, theta), qxx, qxy, qyy, lo, hi, r_max, leaf: true, ..*node };
    }

    fn finish_internal(&mut self, k: usize) {
        let mut m = 0.0;
        let mut mp = DVec2::ZERO;
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        let mut r_max = 0.0f64;
        let mut c = k + 1;
        while c < self.nodes.len() {
            let child = &self.nodes[c];
            m += child.mass;
            mp += child.mass * child.com;
            lo = lo.min(child.lo);
            hi = hi.max(child.hi);
            r_max = r_max.max(child.r_max);
            c = child.next as usize;
        }
        let com = centre_of_mass(mp, m, lo, hi);
        // Parallel axes: each child's moment about its own centre, moved to the parent's.
        let (mut qxx, mut qxy, mut qyy) = (0.0, 0.0, 0.0);
        let mut c = k + 1;
        while c < self.nodes.len() {
            let child = &self.nodes[c];
            let (a, b, d) = quadrupole(child.mass, child.com - com);
            qxx += child.qxx + a;
            qxy += child.qxy + b;
            qyy += child.qyy + d;
            c = child.next as usize;
        }
        let theta = self.attraction.opening_angle;
        if self.monopole_only {
            (qxx, qxy, qyy) = (0.0, 0.0, 0.0);
        }
        let node = &mut self.nodes[k];
        *node = Node { com, mass: m, open2: open2(lo, hi, theta), qxx, qxy, qyy, lo, hi, r_max, leaf: false, ..*node };
    }

    /// Attraction force on ball `i` (N) from every other ball. Panics if `i` is not a ball of the
    /// last build.
    #[inline]
    pub fn force(&self, i: usize) -> DVec2 {
        self.force_and_rate(i).0
    }

    /// Acceleration of ball `i` (m/s²) from the attraction of every other ball.
    #[inline]
    pub fn acceleration(&self, i: usize) -> DVec2 {
        self.force(i) / self.mass[self.slot[i] as usize]
    }

    /// The force on ball `i` (N), and the square of the fastest orbit rate it takes part in, 1/s²
    /// (see [`crate::physics::attraction_rate_squared`]): exact for the pairs summed exactly, `G·(m + M)/d³` for a
    /// node approximated from the distance d to its centre of mass — the rate at which the ball
    /// would orbit that node's whole mass M.
    pub fn force_and_rate(&self, i: usize) -> (DVec2, f64) {
        let s = self.slot[i] as usize;
        self.exact_at::<false>(self.pos[s], self.mass[s], self.radius[s], self.inverse_mass[s], Some(s))
    }

    /// The force (N) and the square of the fastest orbit rate (1/s², as in
    /// [`BarnesHut::force_and_rate`]) on a body of `mass` and `radius` at `position` — anywhere,
    /// in the tree or not — from every ball of the tree except `exclude` (a ball index of the last
    /// build: the body itself, when the tree holds an older state of it).
    ///
    /// For a ball of the tree at its own state, `force_at(pos[i], mass[i], radius[i], Some(i))` is
    /// `force_and_rate(i)`, bit for bit (one walk serves both). A body that has moved away from
    /// its excluded entry still never feels it: a node that holds the excluded ball is always
    /// opened, never replaced by its multipole (which would include the body's own mass).
    /// Panics if `exclude` is not a ball of the last build.
    pub fn force_at(&self, position: DVec2, mass: f64, radius: f64, exclude: Option<usize>) -> (DVec2, f64) {
        let s = exclude.map(|i| self.slot[i] as usize);
        self.exact_at::<true>(position, mass, radius, 1.0 / mass, s)
    }

    /// The force on a body that will move up to `margin` from `position`, split in two, for
    /// evaluating it many times along a short path (a threaded ball's sub-steps):
    ///
    /// - returned: the *far* force (N) — the nodes that are far by θ from `position` and clear of
    ///   contact with every point within `margin` of it, each as its multipole at `position` —
    ///   and the square of the fastest orbit rate (1/s²) at `position`, far nodes and near pairs
    ///   included, as [`BarnesHut::force_at`] gives it;
    /// - `near` (cleared first): a copy of the balls of every leaf that was opened, less
    ///   `exclude`; [`near_force`] sums them exactly at any point, without the tree (so a caller
    ///   may let go of the tree once the split is made).
    ///
    /// `far + near_force(near, position, …)` is `force_at(position, …)` bit for bit when
    /// `margin` is 0 (the same walk; a larger margin only opens more nodes). Elsewhere on the
    /// path, the far force is that of the field where the path starts: each far node is at least
    /// `margin` beyond any point of the path, so keeping its pull fixed errs by at most the
    /// relative change of a pull over a step no longer than its distance.
    pub fn split_at(
        &self,
        position: DVec2,
        mass: f64,
        radius: f64,
        exclude: Option<usize>,
        margin: f64,
        near: &mut Vec<NearBall>,
    ) -> (DVec2, f64) {
        let skip = exclude.map(|i| self.slot[i] as usize);
        let inv_m = 1.0 / mass;
        let mut rate_near = 0.0f64;
        near.clear();
        let (far, rate_far) = self.walk::<true>(position, mass, radius, skip, margin, |t| {
            let ball = NearBall { position: self.pos[t], mass: self.mass[t], radius: self.radius[t] };
            near.push(ball);
            let k = ball.pair(position, mass, radius, &self.attraction).1;
            rate_near = rate_near.max(k * (inv_m + self.inverse_mass[t]));
        });
        (far, rate_near.max(rate_far))
    }

    /// Exactly `attraction_force` between a body and the ball at tree position `t`, and the pair's
    /// stiffness (see [`attraction_pair`]).
    #[inline]
    fn pair(&self, p: DVec2, m: f64, r: f64, t: usize) -> (DVec2, f64) {
        NearBall { position: self.pos[t], mass: self.mass[t], radius: self.radius[t] }.pair(p, m, r, &self.attraction)
    }

    /// The whole force and rate at `p`, leaves summed exactly as they are met. `MOVED`: as in
    /// [`BarnesHut::walk`].
    #[inline]
    fn exact_at<const MOVED: bool>(&self, p: DVec2, m: f64, r: f64, inv_m: f64, skip: Option<usize>) -> (DVec2, f64) {
        let mut near = DVec2::ZERO;
        let mut rate_near = 0.0f64;
        let (far, rate_far) = self.walk::<MOVED>(p, m, r, skip, 0.0, |t| {
            // Exactly `attraction_force`, and the pair's ω² from its stiffness.
            let (f, k) = self.pair(p, m, r, t);
            near += f;
            rate_near = rate_near.max(k * (inv_m + self.inverse_mass[t]));
        });
        (near + far, rate_near.max(rate_far))
    }

    /// The tree walk behind every query: a body at `p` with mass `m` and radius `r`; `skip` is
    /// the excluded ball's position in tree order. Returns the far nodes' force (N) and their
    /// largest orbit rate² (1/s²); hands every ball of every opened leaf (less `skip`) to
    /// `leaf_ball`, in a fixed order. `margin` widens the contact test (0: as far as the body's
    /// own radius). `MOVED`: the body may not be at the excluded ball's tree position, so a node
    /// holding that ball must be opened (false for a ball at its own position, where the contact
    /// test opens those nodes anyway: the check is left out of the lockstep engine's walk, where
    /// it cost about 7 % at 1,000 balls).
    #[inline]
    fn walk<const MOVED: bool>(
        &self,
        p: DVec2,
        m: f64,
        r: f64,
        skip: Option<usize>,
        margin: f64,
        mut leaf_ball: impl FnMut(usize),
    ) -> (DVec2, f64) {
        // `usize::MAX` is in no node's range: nothing skipped.
        let s = skip.unwrap_or(usize::MAX);
        let nodes = self.nodes.as_slice();
        // r + 0 is r: a zero margin changes no bit of the contact test.
        let r = r + margin;
        // Far nodes as accelerations over G (one multiplication at the end).
        let mut far = DVec2::ZERO;
        let mut rate_far = 0.0f64;
        let mut k = 0;
        while k < nodes.len() {
            let nd = &nodes[k];
            let d = nd.com - p;
            let r2 = d.length_squared();
            // A node holding the excluded ball is opened. For a ball at its own tree position this
            // changes nothing (the contact test below already opens every node around it); for a
            // body that moved, it keeps the body's own old mass out of the multipole.
            let holds_skipped = MOVED && (nd.start as usize..nd.end as usize).contains(&s);
            if r2 > nd.open2 && !holds_skipped {
                // Far enough by θ; also clear of contact with every ball in it?
                let ex = (nd.lo.x - p.x).max(p.x - nd.hi.x).max(0.0);
                let ey = (nd.lo.y - p.y).max(p.y - nd.hi.y).max(0.0);
                let reach = r + nd.r_max;
                if ex * ex + ey * ey > reach * reach {
                    let inv_r2 = 1.0 / r2;
                    let inv_r = inv_r2.sqrt();
                    let inv_r3 = inv_r * inv_r2;
                    // a/G = M·d/r³ − Q·d/r⁵ + 5/2·(dᵀQd)·d/r⁷
                    let qd = DVec2::new(nd.qxx * d.x + nd.qxy * d.y, nd.qxy * d.x + nd.qyy * d.y);
                    let dqd = d.dot(qd);
                    let inv_r5 = inv_r3 * inv_r2;
                    far += d * (inv_r3 * (nd.mass + 2.5 * dqd * inv_r2 * inv_r2)) - qd * inv_r5;
                    rate_far = rate_far.max((m + nd.mass) * inv_r3);
                    k = nd.next as usize;
                    continue;
                }
            }
            if nd.leaf {
                for t in nd.start as usize..nd.end as usize {
                    if t != s {
                        leaf_ball(t);
                    }
                }
                k = nd.next as usize;
            } else {
                k += 1;
            }
        }
        let g = self.attraction.g_constant;
        (far * (g * m), g * rate_far)
    }
}

/// A ball of the near part of a split force ([`BarnesHut::split_at`]), copied out of the tree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearBall {
    /// Centre, m.
    pub position: DVec2,
    /// Mass, kg.
    pub mass: f64,
    /// Radius, m: closer than the sum of two radii the attraction falls linearly to zero (see
    /// [`attraction_force`]).
    pub radius: f64,
}

impl NearBall {
    /// Exactly `attraction_force` between a body and this ball, and the pair's stiffness (see
    /// [`attraction_pair`]).
    #[inline]
    fn pair(&self, p: DVec2, m: f64, r: f64, attraction: &Attraction) -> (DVec2, f64) {
        attraction_pair(p, m, r, self.position, self.mass, self.radius, attraction)
    }
}

/// The exact force (N) at `position` on a body of `mass` and `radius` from the balls `near` (from
/// [`BarnesHut::split_at`]), summed in their order.
pub fn near_force(near: &[NearBall], position: DVec2, mass: f64, radius: f64, attraction: &Attraction) -> DVec2 {
    near.iter().fold(DVec2::ZERO, |f, b| f + b.pair(position, mass, radius, attraction).0)
}

/// Centre of mass from Σm·p and Σm; the middle of the box if the mass is zero (no NaN).
#[inline]
fn centre_of_mass(mp: DVec2, m: f64, lo: DVec2, hi: DVec2) -> DVec2 {
    if m > 0.0 { mp / m } else { 0.5 * (lo + hi) }
}

/// `(size / θ)²` for the box `lo..hi`, +∞ for θ = 0 (never approximated).
#[inline]
fn open2(lo: DVec2, hi: DVec2, theta: f64) -> f64 {
    if theta > 0.0 {
        let size = (hi - lo).max_element() / theta;
        size * size
    } else {
        f64::INFINITY
    }
}

/// The in-plane quadrupole of mass `m` at offset `s`: `m·(3·s·sᵀ − |s|²·I)` as (xx, xy, yy).
#[inline]
fn quadrupole(m: f64, s: DVec2) -> (f64, f64, f64) {
    let s2 = s.length_squared();
    (m * (3.0 * s.x * s.x - s2), m * 3.0 * s.x * s.y, m * (3.0 * s.y * s.y - s2))
}
