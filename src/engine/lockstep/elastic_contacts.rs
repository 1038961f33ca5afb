//! The contacts of a perfectly elastic field (ball restitution 1): sequential impulses over the
//! touching pairs, band by band, on one thread or several with the same bits.
//!
//! Every approaching pair gets the elastic impulse along the line of centres at its instant of
//! contact and is replayed from it (`contact_ball_ball`), passes over the pairs in a fixed order
//! until none overlaps; the walls come after, in the finish pass (`contact_ball_wall`, replayed
//! along the ball's parabola). Each impulse keeps the energy on its own, so the field keeps it to
//! rounding, however dense (the elastic pile of `tests/stability.rs`: 3e-14 over a minute). The solver of inelastic
//! fields (`contact_solver`) solves simultaneous impacts and resting contacts instead; for
//! e = 1 its simultaneous rounds keep the energy only as far as they converge, which a dense
//! elastic pile does not reach every step.
//!
//! The broad phase groups the pairs by band, by seam between bands and with big balls (see
//! [`crate::physics::BroadPhase`]): the pairs of two different bands never share a ball, nor do
//! those of two different seams. Every pass of the solver therefore works the pairs in this fixed
//! order: band 0, band 1, …, then seam 0, seam 1, …, then the big balls' pairs. Done serially,
//! that is one loop. Done in parallel, the bands are worked at the same time, then the seams,
//! then the big balls on one thread; each ball still sees exactly the same sequence of updates as
//! in the serial loop (only balls of *other* bands are updated in between, and they are never
//! read), so the result is bit-identical for any number of threads.
//!
//! For the parallel case the balls are copied into slot order (the broad phase's order, in which
//! a band or a seam is one contiguous run), so each task gets its own `&mut` sub-slices by
//! `split_at_mut`: no `unsafe`, no locks. The copy costs O(n) per sub-step, so it is only made
//! when there are enough pairs to pay for it ([`PARALLEL_MIN_PAIRS`]); below that the serial loop
//! works on the balls in place.

use std::ops::Range;

use glam::DVec2;
use rayon::prelude::*;

use super::PARALLEL_MIN_PAIRS;
use super::contact_solver::{Fixed, SlotBodies, split_runs};
use crate::physics::{Bodies, BroadPhase, ContactBody, RoundContact, contact_ball_ball, solve_simultaneous};

/// Impulses applied and pairs still overlapping in one pass (or summed over passes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    pub impulses: u64,
    pub active: u64,
}

impl std::ops::Add for Tally {
    type Output = Tally;
    fn add(self, o: Tally) -> Tally {
        Tally { impulses: self.impulses + o.impulses, active: self.active + o.active }
    }
}

/// The touching pairs (as slots) grouped for the solver, and the slot-ordered copy of the balls.
#[derive(Clone, Debug, Default)]
pub struct ElasticContacts {
    band_pairs: Vec<Vec<(u32, u32)>>,
    seam_pairs: Vec<Vec<(u32, u32)>>,
    big_pairs: Vec<(u32, u32)>,
    local: SlotBodies,
}

impl ElasticContacts {
    /// Touching pairs found by the last [`ElasticContacts::find_pairs`].
    pub fn pair_count(&self) -> usize {
        self.band_pairs.iter().chain(&self.seam_pairs).map(Vec::len).sum::<usize>() + self.big_pairs.len()
    }

    /// Collects the touching pairs of the grid's last update, band by band (in parallel when
    /// `parallel`; the lists are the same either way).
    pub fn find_pairs(&mut self, grid: &BroadPhase, parallel: bool) {
        let bands = grid.band_count();
        self.band_pairs.resize_with(bands, Vec::new);
        self.seam_pairs.resize_with(bands.saturating_sub(1), Vec::new);
        let band = |b: usize, list: &mut Vec<(u32, u32)>| {
            list.clear();
            grid.for_each_band_pair(b, |k, m| list.push((k as u32, m as u32)));
        };
        let seam = |b: usize, list: &mut Vec<(u32, u32)>| {
            list.clear();
            grid.for_each_seam_pair(b, |k, m| list.push((k as u32, m as u32)));
        };
        if parallel {
            self.band_pairs.par_iter_mut().enumerate().for_each(|(b, list)| band(b, list));
            self.seam_pairs.par_iter_mut().enumerate().for_each(|(b, list)| seam(b, list));
        } else {
            self.band_pairs.iter_mut().enumerate().for_each(|(b, list)| band(b, list));
            self.seam_pairs.iter_mut().enumerate().for_each(|(b, list)| seam(b, list));
        }
        self.big_pairs.clear();
        let big = &mut self.big_pairs;
        grid.for_each_big_pair(|k, m| big.push((k as u32, m as u32)));
    }

    /// Runs up to `iterations` passes over the pairs (stopping after a pass in which no pair
    /// overlapped) and returns the impulses applied. `parallel` says whether the bands may be
    /// worked on several threads (the caller runs this inside its thread pool); it changes no
    /// bit of the result.
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        bodies: &mut Bodies,
        grid: &BroadPhase,
        restitution: f64,
        dt: f64,
        together: f64,
        iterations: usize,
        parallel: bool,
    ) -> u64 {
        if self.pair_count() == 0 {
            return 0;
        }
        // The parallel solver first copies every ball into slot order and back (O(n)), which a
        // sparse field's few pairs do not pay for: it takes the bands in parallel only when there
        // are at least half as many pairs as balls (a pile has about three per ball, a falling
        // rain one per ten). Both ways give the same bits.
        if parallel && self.pair_count() >= PARALLEL_MIN_PAIRS.max(bodies.len() / 2) {
            self.solve_parallel(bodies, grid, restitution, dt, together, iterations)
        } else {
            self.solve_serial(bodies, grid, restitution, dt, together, iterations)
        }
    }

    /// The reference order, in place: pair (k, m) is balls (slots[k], slots[m]).
    fn solve_serial(
        &self,
        b: &mut Bodies,
        grid: &BroadPhase,
        e: f64,
        dt: f64,
        together: f64,
        iterations: usize,
    ) -> u64 {
        let slots = grid.slots();
        let fixed = Fixed { id: &b.id, inverse_mass: &b.inverse_mass, radius: &b.radius };
        let lists = self.band_pairs.iter().chain(&self.seam_pairs).chain(std::iter::once(&self.big_pairs));
        let lists: Vec<&Vec<(u32, u32)>> = lists.collect();
        let mut impulses = 0;
        for iteration in 0..iterations {
            let mut pass = Tally::default();
            let together = (iteration == 0).then_some(together);
            for list in &lists {
                pass = pass
                    + solve_pairs(list, fixed, &mut b.position, &mut b.velocity, e, dt, together, |k| {
                        let i = slots[k] as usize;
                        (i, i)
                    });
            }
            impulses += pass.impulses;
            if pass.active == 0 {
                break;
            }
        }
        impulses
    }

    /// The same passes with the bands (then the seams) on the pool's threads, on a slot-ordered
    /// copy of the balls (see the module comment).
    fn solve_parallel(
        &mut self,
        b: &mut Bodies,
        grid: &BroadPhase,
        e: f64,
        dt: f64,
        together: f64,
        iterations: usize,
    ) -> u64 {
        let l = &mut self.local;
        l.gather(b, grid.slots());
        let fixed = Fixed { id: &l.id, inverse_mass: &l.inverse_mass, radius: &l.radius };
        let bands: Vec<Range<usize>> = (0..grid.band_count()).map(|k| grid.band_slots(k)).collect();
        let seams: Vec<Range<usize>> = (0..self.seam_pairs.len()).map(|k| grid.seam_slots(k)).collect();
        let mut impulses = 0;
        for iteration in 0..iterations {
            let mut pass = Tally::default();
            let together = (iteration == 0).then_some(together);
            for (runs, lists) in [(&bands, &self.band_pairs), (&seams, &self.seam_pairs)] {
                let parts = split_runs(&mut l.position, &mut l.velocity, runs);
                pass = pass
                    + parts
                        .into_par_iter()
                        .zip(lists.par_iter())
                        .map(|((base, x, v), list)| solve_pairs(list, fixed, x, v, e, dt, together, |k| (k, k - base)))
                        .reduce(Tally::default, |a, c| a + c);
            }
            pass = pass
                + solve_pairs(&self.big_pairs, fixed, &mut l.position, &mut l.velocity, e, dt, together, |k| (k, k));
            impulses += pass.impulses;
            if pass.active == 0 {
                break;
            }
        }
        l.scatter(b, grid.ball_slots());
        impulses
    }
}

/// Ball `f` of `fixed` as the contact functions take it, its state at `x[s]`, `v[s]`.
#[inline(always)]
fn contact_body(fixed: Fixed<'_>, x: &[DVec2], v: &[DVec2], f: usize, s: usize) -> ContactBody {
    ContactBody {
        id: fixed.id[f],
        position: x[s],
        velocity: v[s],
        inverse_mass: fixed.inverse_mass[f],
        radius: fixed.radius[f],
    }
}

/// One pass over `pairs`. `index(k)` maps a slot to (index into `fixed`, index into `x`/`v`).
/// With `together` (a sub-step's first pass), pairs that approach into an overlap faster than it
/// and share a ball with another such pair are struck at once (see [`strike_together`]); every
/// other pair is struck in list order, each seeing the last one's impulse.
#[allow(clippy::too_many_arguments)]
#[inline]
fn solve_pairs(
    pairs: &[(u32, u32)],
    fixed: Fixed<'_>,
    x: &mut [DVec2],
    v: &mut [DVec2],
    e: f64,
    dt: f64,
    together: Option<f64>,
    index: impl Fn(usize) -> (usize, usize),
) -> Tally {
    let mut tally = Tally::default();
    let groups = together.map_or_else(Vec::new, |speed| simultaneous(pairs, fixed, x, v, speed, &index));
    // Per pair, its group (or none); per group, whether it was struck at once (`None`: not yet
    // met in the pass; `Some(false)`: taken one by one).
    let mut group_of = vec![u32::MAX; if groups.is_empty() { 0 } else { pairs.len() }];
    for (g, group) in groups.iter().enumerate() {
        for &n in group {
            group_of[n as usize] = g as u32;
        }
    }
    let mut together_done: Vec<Option<bool>> = vec![None; groups.len()];
    for (n, &(k, m)) in pairs.iter().enumerate() {
        if let Some(&g) = group_of.get(n).filter(|&&g| g != u32::MAX) {
            let g = g as usize;
            let done = *together_done[g].get_or_insert_with(|| {
                let strike = strike_together(pairs, &groups[g], fixed, x, v, e, dt, &index);
                strike.inspect(|t| tally = tally + *t).is_some()
            });
            if done {
                continue;
            }
        }
        let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
        let body = |f: usize, s: usize| contact_body(fixed, x, v, f, s);
        if let Some(c) = contact_ball_ball(&body(fi, i), &body(fj, j), e, dt) {
            if c.impulse > 0.0 {
                v[i] += c.velocity_change_a;
                v[j] += c.velocity_change_b;
                tally.impulses += 1;
            }
            x[i] += c.shift_a;
            x[j] += c.shift_b;
            tally.active += 1;
        }
    }
    tally
}

/// The groups (indices into `pairs`, in list order, two or more each) of pairs that approach into
/// an overlap faster than `speed` and are joined through shared balls: simultaneous impacts, such
/// as a ball striking two touching balls between them. Nearly always none (a gas's collisions are
/// binary; a resting pile's contacts approach at about g·dt, below `speed`).
fn simultaneous(
    pairs: &[(u32, u32)],
    fixed: Fixed<'_>,
    x: &[DVec2],
    v: &[DVec2],
    speed: f64,
    index: &impl Fn(usize) -> (usize, usize),
) -> Vec<Vec<u32>> {
    // (ball, pair) for both balls of every fast pair.
    let mut ends: Vec<(usize, u32)> = Vec::new();
    for (n, &(k, m)) in pairs.iter().enumerate() {
        let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
        let d = x[j] - x[i];
        let reach = fixed.radius[fi] + fixed.radius[fj];
        let dist2 = d.length_squared();
        if dist2 < reach * reach && (v[j] - v[i]).dot(d) < -speed * dist2.sqrt() {
            ends.push((i, n as u32));
            ends.push((j, n as u32));
        }
    }
    if ends.len() < 4 {
        return Vec::new();
    }
    ends.sort_unstable();
    // Union–find over the fast pairs, joined where they share a ball.
    let mut fast: Vec<u32> = ends.iter().map(|&(_, n)| n).collect();
    fast.sort_unstable();
    fast.dedup();
    let slot = |n: u32| fast.binary_search(&n).unwrap_or(0);
    let mut parent: Vec<usize> = (0..fast.len()).collect();
    fn root(parent: &mut [usize], mut a: usize) -> usize {
        while parent[a] != a {
            parent[a] = parent[parent[a]];
            a = parent[a];
        }
        a
    }
    for w in ends.windows(2) {
        if w[0].0 == w[1].0 {
            let (a, b) = (root(&mut parent, slot(w[0].1)), root(&mut parent, slot(w[1].1)));
            if a != b {
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut groups: Vec<Vec<u32>> = Vec::new();
    let mut group_of = vec![usize::MAX; fast.len()];
    for (s, &n) in fast.iter().enumerate() {
        let r = root(&mut parent, s);
        if group_of[r] == usize::MAX {
            group_of[r] = groups.len();
            groups.push(Vec::new());
        }
        groups[group_of[r]].push(n);
    }
    groups.retain(|g| g.len() > 1);
    groups
}

/// The most contacts struck at once: more are taken one by one (a few balls striking together;
/// the sweeps of a larger round converge slower, and one that does not converge would not keep
/// the energy).
const MAX_TOGETHER: usize = 8;

/// Strikes the pairs of `group` (indices into `pairs`) at once, every one judged on the state
/// the group met, or returns `None` and changes nothing when they are not one simultaneous
/// impact: fewer than two of them or more than [`MAX_TOGETHER`] approaching, replayed contacts that
/// touched more than a millionth of the step apart, or sweeps that did not converge (the caller
/// then takes them one by one, as if they were not a group). each pair still touching gets its normal at the instant of contact
/// ([`contact_ball_ball`]); the impulses of those approaching are solved together
/// ([`solve_simultaneous`], Jacobi sweeps with each ball's mass split among its contacts: every
/// update from the same velocities, so the numbering picks nothing and a mirror-symmetric strike
/// comes out mirror-symmetric); each ball is replayed by its velocity change times the longest
/// time since one of its contacts touched (the same for every contact of a symmetric strike), and
/// a pair that did not approach into its overlap within the step (resting, or put there by a
/// wall) is pushed apart as alone. At e = 1 the converged round reverses every struck contact's
/// normal speed, so it keeps the energy.
#[allow(clippy::too_many_arguments)]
fn strike_together(
    pairs: &[(u32, u32)],
    group: &[u32],
    fixed: Fixed<'_>,
    x: &mut [DVec2],
    v: &mut [DVec2],
    e: f64,
    dt: f64,
    index: &impl Fn(usize) -> (usize, usize),
) -> Option<Tally> {
    let mut tally = Tally::default();
    // The group's balls by their index into `x`/`v`, and each one's latest contact time.
    let mut balls: Vec<usize> = Vec::new();
    let mut tau: Vec<f64> = Vec::new();
    let local = |balls: &mut Vec<usize>, tau: &mut Vec<f64>, i: usize| match balls.iter().position(|&s| s == i) {
        Some(at) => at,
        None => {
            balls.push(i);
            tau.push(0.0);
            balls.len() - 1
        }
    };
    let mut round = Vec::new();
    let mut pushes: Vec<(usize, DVec2)> = Vec::new();
    let (mut earliest, mut latest) = (f64::INFINITY, f64::NEG_INFINITY);
    // Approaching contacts replayed and pushed apart.
    let (mut replayed, mut pushed) = (0, 0);
    for &n in group {
        let (k, m) = pairs[n as usize];
        let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
        let body = |f: usize, s: usize| contact_body(fixed, x, v, f, s);
        let (a, b) = (body(fi, i), body(fj, j));
        let Some(c) = contact_ball_ball(&a, &b, e, dt) else { continue };
        tally.active += 1;
        let (la, lb) = (local(&mut balls, &mut tau, i), local(&mut balls, &mut tau, j));
        match c.replayed {
            Some(t) => {
                tau[la] = tau[la].max(t);
                tau[lb] = tau[lb].max(t);
                earliest = earliest.min(t);
                latest = latest.max(t);
            }
            None => pushes.extend([(i, c.shift_a), (j, c.shift_b)]),
        }
        if c.impulse > 0.0 {
            if c.replayed.is_some() {
                replayed += 1;
            } else {
                pushed += 1;
            }
            let vn = (b.velocity - a.velocity).dot(c.normal);
            round.push(RoundContact {
                target: -e * vn,
                ..RoundContact::new(la, Some(lb), c.normal, a.inverse_mass, b.inverse_mass)
            });
        }
    }
    if round.len() < 2 || round.len() > MAX_TOGETHER || latest - earliest > 1e-6 * dt || replayed * pushed > 0 {
        return None;
    }
    let mut velocity: Vec<DVec2> = balls.iter().map(|&s| v[s]).collect();
    let mut counts = vec![0; balls.len()];
    if !solve_simultaneous(&mut round, &mut velocity, &mut counts, 0.0) {
        return None;
    }
    tally.impulses += round.iter().filter(|c| c.impulse > 0.0).count() as u64;
    for ((&s, &u), &t) in balls.iter().zip(&velocity).zip(&tau) {
        x[s] += (u - v[s]) * t;
        v[s] = u;
    }
    for (s, dx) in pushes {
        x[s] += dx;
    }
    Some(tally)
}
