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
use crate::physics::{Bodies, BroadPhase, ContactBody, contact_ball_ball};

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
    pub fn solve(
        &mut self,
        bodies: &mut Bodies,
        grid: &BroadPhase,
        restitution: f64,
        dt: f64,
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
            self.solve_parallel(bodies, grid, restitution, dt, iterations)
        } else {
            self.solve_serial(bodies, grid, restitution, dt, iterations)
        }
    }

    /// The reference order, in place: pair (k, m) is balls (slots[k], slots[m]).
    fn solve_serial(&self, b: &mut Bodies, grid: &BroadPhase, e: f64, dt: f64, iterations: usize) -> u64 {
        let slots = grid.slots();
        let fixed = Fixed { id: &b.id, inverse_mass: &b.inverse_mass, radius: &b.radius };
        let lists = self.band_pairs.iter().chain(&self.seam_pairs).chain(std::iter::once(&self.big_pairs));
        let lists: Vec<&Vec<(u32, u32)>> = lists.collect();
        let mut impulses = 0;
        for _ in 0..iterations {
            let mut pass = Tally::default();
            for list in &lists {
                pass = pass
                    + solve_pairs(list, fixed, &mut b.position, &mut b.velocity, e, dt, |k| {
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
    fn solve_parallel(&mut self, b: &mut Bodies, grid: &BroadPhase, e: f64, dt: f64, iterations: usize) -> u64 {
        let l = &mut self.local;
        l.gather(b, grid.slots());
        let fixed = Fixed { id: &l.id, inverse_mass: &l.inverse_mass, radius: &l.radius };
        let bands: Vec<Range<usize>> = (0..grid.band_count()).map(|k| grid.band_slots(k)).collect();
        let seams: Vec<Range<usize>> = (0..self.seam_pairs.len()).map(|k| grid.seam_slots(k)).collect();
        let mut impulses = 0;
        for _ in 0..iterations {
            let mut pass = Tally::default();
            for (runs, lists) in [(&bands, &self.band_pairs), (&seams, &self.seam_pairs)] {
                let parts = split_runs(&mut l.position, &mut l.velocity, runs);
                pass = pass
                    + parts
                        .into_par_iter()
                        .zip(lists.par_iter())
                        .map(|((base, x, v), list)| solve_pairs(list, fixed, x, v, e, dt, |k| (k, k - base)))
                        .reduce(Tally::default, |a, c| a + c);
            }
            pass = pass + solve_pairs(&self.big_pairs, fixed, &mut l.position, &mut l.velocity, e, dt, |k| (k, k));
            impulses += pass.impulses;
            if pass.active == 0 {
                break;
            }
        }
        l.scatter(b, grid.ball_slots());
        impulses
    }
}

/// One pass over `pairs`. `index(k)` maps a slot to (index into `fixed`, index into `x`/`v`).
#[inline]
fn solve_pairs(
    pairs: &[(u32, u32)],
    fixed: Fixed<'_>,
    x: &mut [DVec2],
    v: &mut [DVec2],
    e: f64,
    dt: f64,
    index: impl Fn(usize) -> (usize, usize),
) -> Tally {
    let mut tally = Tally::default();
    for &(k, m) in pairs {
        let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
        let body = |f: usize, s: usize| ContactBody {
            id: fixed.id[f],
            position: x[s],
            velocity: v[s],
            inverse_mass: fixed.inverse_mass[f],
            radius: fixed.radius[f],
        };
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
