//! The contact phase: the physics contact solver's phases (`crate::physics::contact_solver`)
//! driven band by band, on one thread or several with the same bits.
//!
//! The broad phase groups the candidate pairs by band, by seam between bands and with big balls
//! (see [`crate::physics::BroadPhase`]): the pairs of two different bands never share a ball, nor
//! do those of two different seams. The contacts of a sub-step are kept in one list per band,
//! per seam and one for the big balls, in that order; a ball's wall contacts go in the list of its
//! band (or the big balls'). Each phase then works the lists in this fixed order:
//!
//! - **impacts**: one serial pass over all lists in order (impacts are few, and a round's Jacobi
//!   sweeps do not depend on the order anyway);
//! - **resting contacts** and **positions**: Gauss–Seidel passes, the bands at the same time,
//!   then the seams, then the big balls on one thread. Each ball sees exactly the same sequence of
//!   updates as in the serial loop (only balls of *other* bands are updated in between, and they
//!   are never read), so the result is bit-identical for any number of threads. Whether to make
//!   another pass is decided from the pass's largest change, a maximum: the same on any thread
//!   count.
//!
//! For the parallel case the balls are copied into slot order (the broad phase's order, in which
//! a band or a seam is one contiguous run), so each task gets its own `&mut` sub-slices by
//! `split_at_mut`: no `unsafe`, no locks. The copy costs O(n) per sub-step, so it is only made
//! when there are enough pairs to pay for it ([`PARALLEL_MIN_PAIRS`]); below that the serial loop
//! works on the balls in place.
//!
//! **Warm start.** A resting contact's impulse is kept with its candidate pair between
//! sub-steps (and carried over by ball ids when the pairs are found afresh), and a wall's with
//! its ball: a settled pile's weight is then already in place when a sub-step starts, so its
//! passes converge at once.

use std::collections::HashMap;
use std::ops::Range;

use glam::DVec2;
use rayon::prelude::*;

use crate::physics::{
    BallId, Bodies, BroadPhase, Contact, Field, ImpactScratch, MAX_POSITION_PASSES, MAX_REDETECTIONS,
    MAX_RESTING_PASSES, NEVER, RESTED, RestingIslands, Tolerances, WALL, WallImpulses, impact_phase,
    islands_after_passes, iterate_position, iterate_resting, nearer_walls, pair_contact, position_pass,
    pushed_together, redetect_wall, resting_begin, resting_end, resting_pass, resting_warm_start,
    solve_resting_islands, wall_contact, wall_pass,
};

/// Fewest touching pairs for which the contact phase is worked in parallel (and at least half as
/// many as there are balls; see `ContactSolver::solve`).
pub const PARALLEL_MIN_PAIRS: usize = 512;

/// A candidate pair (slots) and its resting impulse of the last sub-step (warm start).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Candidate {
    k: u32,
    m: u32,
    impulse: f64,
    /// Whether the sub-step has a contact for this pair (see [`ContactSolver::redetect`]).
    listed: bool,
}

/// What one sub-step's contacts did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outcome {
    /// Ball–ball contacts struck with restitution.
    pub impacts: u64,
    /// Ball–wall contacts (touching during the sub-step).
    pub wall_contacts: u64,
    /// Contacts still touching after the impacts (the resting phase's).
    pub resting: u64,
    pub walls: WallImpulses,
    /// False when a phase reached its iteration cap.
    pub converged: bool,
    pub rounds: u32,
    pub resting_passes: u32,
    pub position_passes: u32,
    /// Islands of resting contacts solved directly after the passes reached their cap (see
    /// `physics::solve_resting_islands`).
    pub islands_solved: u64,
    /// Candidate pairs added for balls an impact or the position passes sent beyond the broad
    /// phase's skin (see `ContactSolver::reach_struck_balls`).
    pub pairs_reached: u64,
    /// Contacts listed for pairs the position passes pushed together (see
    /// `physics::pushed_together`).
    pub pushed_together: u64,
}

/// The per-sub-step inputs besides the balls.
#[derive(Clone, Copy, Debug)]
pub struct Inputs<'a> {
    pub restitution: f64,
    pub field: &'a Field,
    pub span: f64,
    pub drift: f64,
    pub tolerances: Tolerances,
    /// Uniform acceleration of every ball (gravity), and the key ball's index and its extra
    /// acceleration (the pull).
    pub gravity: DVec2,
    pub key: Option<usize>,
    pub key_acceleration: DVec2,
    /// The balls near a wall (ball indices, increasing).
    pub near_walls: &'a [u32],
}

/// The candidate pairs grouped for the solver, the sub-step's contacts, and scratch memory.
#[derive(Clone, Debug, Default)]
pub struct ContactSolver {
    band_pairs: Vec<Vec<Candidate>>,
    seam_pairs: Vec<Vec<Candidate>>,
    big_pairs: Vec<Candidate>,
    /// The sub-step's contacts: one list per band, per seam, then the big balls'.
    lists: Vec<Vec<Contact>>,
    /// Wall contacts' resting impulses of the last sub-step, by (ball, axis 0 = x, 1 = y),
    /// increasing.
    wall_warm: Vec<(u32, u8, f64)>,
    wall_warm_next: Vec<(u32, u8, f64)>,
    /// Resting impulses by ball ids, carried over a fresh search for pairs.
    carry: HashMap<(BallId, BallId), f64>,
    local: SlotBodies,
    impact: ImpactScratch,
    /// First slot of every band, and of the big balls (for placing wall contacts).
    band_start: Vec<usize>,
    /// The key ball's index into the sub-step's working arrays.
    key_working: Option<usize>,
    /// Scratch of the islands solved directly.
    islands: RestingIslands,
}

/// The balls in slot order, the copy the parallel phases work on (both lockstep contact paths).
#[derive(Clone, Debug, Default)]
pub(super) struct SlotBodies {
    pub(super) id: Vec<BallId>,
    pub(super) inverse_mass: Vec<f64>,
    pub(super) radius: Vec<f64>,
    pub(super) position: Vec<DVec2>,
    pub(super) velocity: Vec<DVec2>,
}

impl SlotBodies {
    /// Copies the balls of `b` into slot order (`slots[k]` is the ball in slot k); each task
    /// writes its own slots, the bodies are only read.
    pub(super) fn gather(&mut self, b: &Bodies, slots: &[u32]) {
        let n = slots.len();
        self.id.resize(n, BallId(0));
        self.inverse_mass.resize(n, 0.0);
        self.radius.resize(n, 0.0);
        self.position.resize(n, DVec2::ZERO);
        self.velocity.resize(n, DVec2::ZERO);
        self.id
            .par_iter_mut()
            .zip(&mut self.inverse_mass)
            .zip(&mut self.radius)
            .zip(&mut self.position)
            .zip(&mut self.velocity)
            .enumerate()
            .for_each(|(k, ((((id, w), r), x), v))| {
                let i = slots[k] as usize;
                (*id, *w, *r, *x, *v) = (b.id[i], b.inverse_mass[i], b.radius[i], b.position[i], b.velocity[i]);
            });
    }

    /// Writes the copy's positions and velocities back to `b` (`ball_slot[i]` is ball i's slot);
    /// each task writes its own balls, the copy is only read.
    pub(super) fn scatter(&self, b: &mut Bodies, ball_slot: &[u32]) {
        let (lx, lv) = (&self.position, &self.velocity);
        b.position.par_iter_mut().zip(&mut b.velocity).enumerate().for_each(|(i, (x, v))| {
            let k = ball_slot[i] as usize;
            (*x, *v) = (lx[k], lv[k]);
        });
    }
}

/// The working arrays' fixed part, indexed like the contacts say: what the solvers read but
/// never write.
#[derive(Clone, Copy)]
pub(super) struct Fixed<'a> {
    pub(super) id: &'a [BallId],
    pub(super) inverse_mass: &'a [f64],
    pub(super) radius: &'a [f64],
}

fn key(a: BallId, b: BallId) -> (BallId, BallId) {
    if a <= b { (a, b) } else { (b, a) }
}

impl ContactSolver {
    /// Candidate pairs found by the last [`ContactSolver::find_pairs`].
    pub fn pair_count(&self) -> usize {
        self.band_pairs.iter().chain(&self.seam_pairs).map(Vec::len).sum::<usize>() + self.big_pairs.len()
    }

    /// Forgets every warm-start impulse (balls were added or removed: indices moved).
    pub fn forget(&mut self) {
        self.carry.clear();
        self.wall_warm.clear();
        for c in self.band_pairs.iter_mut().chain(&mut self.seam_pairs).flatten().chain(&mut self.big_pairs) {
            c.impulse = 0.0;
        }
    }

    /// Remembers the resting impulses by ball ids before the pairs are found afresh (`grid` still
    /// the one they were found in).
    pub fn remember(&mut self, b: &Bodies, grid: &BroadPhase) {
        self.carry.clear();
        let slots = grid.slots();
        for c in self.band_pairs.iter().chain(&self.seam_pairs).flatten().chain(&self.big_pairs) {
            if c.impulse > 0.0 {
                let (i, j) = (slots[c.k as usize] as usize, slots[c.m as usize] as usize);
                self.carry.insert(key(b.id[i], b.id[j]), c.impulse);
            }
        }
    }

    /// Collects the candidate pairs of the grid's last update, band by band (in parallel when
    /// `parallel`; the lists are the same either way), with the impulses [`remember`]ed.
    ///
    /// [`remember`]: ContactSolver::remember
    pub fn find_pairs(&mut self, b: &Bodies, grid: &BroadPhase, parallel: bool) {
        let bands = grid.band_count();
        self.band_pairs.resize_with(bands, Vec::new);
        self.seam_pairs.resize_with(bands.saturating_sub(1), Vec::new);
        let (slots, carry) = (grid.slots(), &self.carry);
        let warm = |k: usize, m: usize| {
            if carry.is_empty() {
                return 0.0;
            }
            let (i, j) = (slots[k] as usize, slots[m] as usize);
            carry.get(&key(b.id[i], b.id[j])).copied().unwrap_or(0.0)
        };
        let band = |n: usize, list: &mut Vec<Candidate>| {
            list.clear();
            grid.for_each_band_pair(n, |k, m| {
                list.push(Candidate { k: k as u32, m: m as u32, impulse: warm(k, m), listed: false })
            });
        };
        let seam = |n: usize, list: &mut Vec<Candidate>| {
            list.clear();
            grid.for_each_seam_pair(n, |k, m| {
                list.push(Candidate { k: k as u32, m: m as u32, impulse: warm(k, m), listed: false })
            });
        };
        if parallel {
            self.band_pairs.par_iter_mut().enumerate().for_each(|(n, list)| band(n, list));
            self.seam_pairs.par_iter_mut().enumerate().for_each(|(n, list)| seam(n, list));
        } else {
            self.band_pairs.iter_mut().enumerate().for_each(|(n, list)| band(n, list));
            self.seam_pairs.iter_mut().enumerate().for_each(|(n, list)| seam(n, list));
        }
        self.big_pairs.clear();
        let big = &mut self.big_pairs;
        grid.for_each_big_pair(|k, m| {
            big.push(Candidate { k: k as u32, m: m as u32, impulse: warm(k, m), listed: false })
        });
        self.carry.clear();
    }

    /// Solves the sub-step's contacts (see the module comment). `parallel` says whether the bands
    /// may be worked on several threads (the caller runs this inside its thread pool); it changes
    /// no bit of the result.
    pub fn solve(&mut self, bodies: &mut Bodies, grid: &BroadPhase, inputs: &Inputs<'_>, parallel: bool) -> Outcome {
        if self.pair_count() == 0 && inputs.near_walls.is_empty() {
            self.wall_warm.clear();
            return Outcome { converged: true, ..Default::default() };
        }
        // The parallel solver first copies every ball into slot order and back (O(n)), which a
        // sparse field's few pairs do not pay for: it takes the bands in parallel only when there
        // are at least half as many pairs as balls (a pile has about three per ball, a falling
        // rain one per ten). Both ways give the same bits.
        if parallel && self.pair_count() >= PARALLEL_MIN_PAIRS.max(bodies.len() / 2) {
            self.solve_parallel(bodies, grid, inputs)
        } else {
            self.solve_serial(bodies, grid, inputs)
        }
    }

    /// The reference order, in place: the contacts index the balls themselves.
    fn solve_serial(&mut self, b: &mut Bodies, grid: &BroadPhase, inputs: &Inputs<'_>) -> Outcome {
        let slots = grid.slots();
        let fixed = Fixed { id: &b.id, inverse_mass: &b.inverse_mass, radius: &b.radius };
        self.build(fixed, &b.position, &b.velocity, grid, inputs, |k| slots[k] as usize, |i| i);
        let parts = Parts { bands: &[], seams: &[] };
        let outcome = {
            let ball_slot = grid.ball_slots();
            let slot = |i: usize| ball_slot[i] as usize;
            self.phases(&mut b.position, &mut b.velocity, fixed, inputs, &parts, (grid, &slot), &|k| slots[k] as usize)
        };
        self.keep();
        outcome
    }

    /// The same phases with the bands (then the seams) on the pool's threads, on a slot-ordered
    /// copy of the balls (see the module comment).
    fn solve_parallel(&mut self, b: &mut Bodies, grid: &BroadPhase, inputs: &Inputs<'_>) -> Outcome {
        let mut l = std::mem::take(&mut self.local);
        l.gather(b, grid.slots());
        let ball_slot = grid.ball_slots();
        let fixed = Fixed { id: &l.id, inverse_mass: &l.inverse_mass, radius: &l.radius };
        self.build(fixed, &l.position, &l.velocity, grid, inputs, |k| k, |i| ball_slot[i] as usize);
        let bands: Vec<Range<usize>> = (0..grid.band_count()).map(|k| grid.band_slots(k)).collect();
        let seams: Vec<Range<usize>> = (0..grid.band_count().saturating_sub(1)).map(|k| grid.seam_slots(k)).collect();
        let parts = Parts { bands: &bands, seams: &seams };
        let outcome = self.phases(&mut l.position, &mut l.velocity, fixed, inputs, &parts, (grid, &|i| i), &|k| k);
        self.keep();
        l.scatter(b, ball_slot);
        self.local = l;
        outcome
    }

    /// Builds the sub-step's contact lists from the candidates and the balls near a wall.
    /// `index(slot)` is a slot's index into the working arrays, `working(ball)` a ball's.
    #[allow(clippy::too_many_arguments)]
    fn build(
        &mut self,
        fixed: Fixed<'_>,
        x: &[DVec2],
        v: &[DVec2],
        grid: &BroadPhase,
        inputs: &Inputs<'_>,
        index: impl Fn(usize) -> usize + Sync,
        working: impl Fn(usize) -> usize + Sync,
    ) {
        let bands = self.band_pairs.len();
        let seams = self.seam_pairs.len();
        self.lists.resize_with(bands + seams + 1, Vec::new);
        let key_index = inputs.key.map(&working);
        self.key_working = key_index;
        let acceleration = |i: usize| acceleration_of(inputs, key_index, i);
        let body =
            |i: usize| (i as u32, fixed.id[i], x[i], v[i], acceleration(i), fixed.inverse_mass[i], fixed.radius[i]);
        let (span, e) = (inputs.span, inputs.restitution);
        // Walls first, so that a pass carries the floor's support up the pile at once (the pairs
        // of a band come bottom row first). Each ball near a wall gets its contacts in its own
        // band's list (or the big balls').
        for list in self.lists.iter_mut() {
            list.clear();
        }
        self.band_start.clear();
        self.band_start.extend((0..bands).map(|k| grid.band_slots(k).start));
        self.band_start.push(grid.big_slots().start);
        let slot_of = grid.ball_slots();
        let mut warm = self.wall_warm.iter().peekable();
        for &ball in inputs.near_walls {
            let i = working(ball as usize);
            let slot = slot_of[ball as usize] as usize;
            let list = if slot >= self.band_start[bands] {
                bands + seams
            } else {
                self.band_start[..bands].partition_point(|&s| s <= slot).saturating_sub(1)
            };
            let (_, _, xi, vi, ai, wi, ri) = body(i);
            for (axis, wall) in nearer_walls(xi, inputs.field).into_iter().enumerate() {
                while warm.peek().is_some_and(|&&(bw, ax, _)| (bw, ax) < (ball, axis as u8)) {
                    warm.next();
                }
                let impulse = match warm.peek() {
                    Some(&&(bw, ax, j)) if (bw, ax) == (ball, axis as u8) => j,
                    _ => 0.0,
                };
                let mut c = wall_contact((i as u32, xi, vi, ai, wi, ri), wall, inputs.field, span);
                c.impulse = impulse;
                c.key = ball * 2 + axis as u32;
                self.lists[list].push(c);
            }
        }
        let fill = |pairs: &mut Vec<Candidate>, list: &mut Vec<Contact>| {
            for (n, p) in pairs.iter_mut().enumerate() {
                let (i, j) = (index(p.k as usize), index(p.m as usize));
                p.listed = false;
                if let Some(mut c) = pair_contact(body(i), body(j), span, e) {
                    c.impulse = p.impulse;
                    c.key = n as u32;
                    list.push(c);
                    p.listed = true;
                }
                p.impulse = 0.0;
            }
        };
        let many = bands > 1 && rayon::current_thread_index().is_some();
        let (band_lists, rest) = self.lists.split_at_mut(bands);
        let (seam_lists, big_list) = rest.split_at_mut(seams);
        if many {
            self.band_pairs.par_iter_mut().zip(band_lists.par_iter_mut()).for_each(|(p, l)| fill(p, l));
            self.seam_pairs.par_iter_mut().zip(seam_lists.par_iter_mut()).for_each(|(p, l)| fill(p, l));
        } else {
            self.band_pairs.iter_mut().zip(band_lists.iter_mut()).for_each(|(p, l)| fill(p, l));
            self.seam_pairs.iter_mut().zip(seam_lists.iter_mut()).for_each(|(p, l)| fill(p, l));
        }
        fill(&mut self.big_pairs, &mut big_list[0]);
    }

    /// Adds the contacts this sub-step's impacts made: candidate pairs with a struck ball that
    /// had no contact, now touching, and walls a struck ball now meets ([`redetect_wall`]; see
    /// [`MAX_REDETECTIONS`]). Returns how many were added.
    fn redetect(
        &mut self,
        x: &[DVec2],
        v: &[DVec2],
        fixed: Fixed<'_>,
        inputs: &Inputs<'_>,
        index: &dyn Fn(usize) -> usize,
    ) -> u64 {
        let key = self.key_working;
        let acceleration = |i: usize| acceleration_of(inputs, key, i);
        let impact = &self.impact;
        let mut added = 0;
        for c in self.lists.iter_mut().flatten().filter(|c| c.is_wall() && c.tau == NEVER) {
            let a = c.a as usize;
            if impact.struck(a) && redetect_wall(c, x[a], v[a], acceleration(a), inputs.field, inputs.span) {
                added += 1;
            }
        }
        let struck = |i: usize, j: usize| impact.struck(i) || impact.struck(j);
        added
            + list_unlisted(
                (&mut self.band_pairs, &mut self.seam_pairs, &mut self.big_pairs, &mut self.lists),
                (x, v, fixed, key),
                inputs,
                index,
                struck,
            )
    }

    /// Adds the candidate pairs a struck ball's new path may meet beyond those the broad phase
    /// found. The candidates hold every pair that can touch while each ball stays within half
    /// the skin of where the grid last saw it (the engine searches afresh once one has moved
    /// further), but an impact can send a ball beyond that within the sub-step: a light ball
    /// struck by heavy ones in a landing pile leaves at up to 180 m/s, 0.18 m in a step of
    /// 1 ms against a skin of 0.1 m. On 80 balls of 100 kg and 80 of 1 kg landing at e = 0.99
    /// such balls met balls they had no pair with and ended steps overlapping them by up to 9 %
    /// of a diameter. A struck ball whose path since its impact (taken as the whole sub-step's,
    /// straight back along its velocity) leaves that half skin is looked up around its path
    /// ([`ContactSolver::reach`]).
    fn reach_struck_balls(
        &mut self,
        x: &[DVec2],
        v: &[DVec2],
        fixed: Fixed<'_>,
        inputs: &Inputs<'_>,
        grid: &BroadPhase,
        slot: &dyn Fn(usize) -> usize,
    ) -> u64 {
        let half_skin = 0.5 * grid.skin();
        let mut beyond: Vec<(usize, DVec2, f64)> = Vec::new();
        for &i in self.impact.struck_balls() {
            let (i, k) = (i as usize, slot(i as usize));
            let half_path = 0.5 * v[i].length() * inputs.span;
            let centre = x[i] - 0.5 * inputs.span * v[i];
            let (seen, _) = grid.slot_shape(k);
            if centre.distance(seen) + half_path > half_skin {
                beyond.push((k, centre, fixed.radius[i] + half_path));
            }
        }
        beyond.sort_unstable_by_key(|b| b.0);
        self.reach(&beyond, grid)
    }

    /// Adds the candidate pairs of the balls the position passes pushed beyond half the skin of
    /// where the grid last saw them (see [`ContactSolver::reach_struck_balls`]): the passes split
    /// each push by inverse mass, and a light ball between heavy ones, taking nearly all of each,
    /// was pushed 0.2 m in one step of the same landing at e = 0.5, into a ball it had no pair
    /// with (24 % of a diameter). Each ball is looked up around where it is now.
    fn reach_pushed_balls(
        &mut self,
        x: &[DVec2],
        fixed: Fixed<'_>,
        grid: &BroadPhase,
        index: &dyn Fn(usize) -> usize,
    ) -> u64 {
        let half_skin = 0.5 * grid.skin();
        let mut beyond: Vec<(usize, DVec2, f64)> = Vec::new();
        for k in 0..grid.slots().len() {
            let i = index(k);
            let (seen, _) = grid.slot_shape(k);
            if x[i].distance_squared(seen) > half_skin * half_skin {
                beyond.push((k, x[i], fixed.radius[i]));
            }
        }
        self.reach(&beyond, grid)
    }

    /// Makes a candidate of each pair of a ball of `beyond` (its slot, and the circle it may be
    /// in: centre and radius; in slot order) with a ball whose shape in the grid touches that
    /// circle, unless it is one already. The new pairs go with the big balls' (worked serially
    /// over all the balls), in slot order: the same pairs in the same order on any number of
    /// threads. They stay candidates until the pairs are next found afresh. Returns how many.
    fn reach(&mut self, beyond: &[(usize, DVec2, f64)], grid: &BroadPhase) -> u64 {
        // The pairs of those balls that are candidates already come from a scan of all of them:
        // this happens in a few steps of a landing, never in a settled pile or a gas.
        let known = self.band_pairs.iter().chain(&self.seam_pairs).flatten().chain(&self.big_pairs).map(|p| (p.k, p.m));
        let mut added = Vec::new();
        let count = grid.for_each_pair_beyond(beyond, known, |_| true, |k, m| added.push((k, m)));
        self.big_pairs.extend(added.into_iter().map(|(k, m)| Candidate { k, m, impulse: 0.0, listed: false }));
        count
    }

    /// Adds a contact for each candidate pair without one that the position passes pushed together
    /// ([`pushed_together`]). Returns how many were added.
    fn list_pushed_together(
        &mut self,
        x: &[DVec2],
        v: &[DVec2],
        fixed: Fixed<'_>,
        inputs: &Inputs<'_>,
        index: &dyn Fn(usize) -> usize,
    ) -> u64 {
        let key = self.key_working;
        let t = &inputs.tolerances;
        let pushed = |i: usize, j: usize| pushed_together(x[i], fixed.radius[i], x[j], fixed.radius[j], t);
        list_unlisted(
            (&mut self.band_pairs, &mut self.seam_pairs, &mut self.big_pairs, &mut self.lists),
            (x, v, fixed, key),
            inputs,
            index,
            pushed,
        )
    }

    /// Writes the resting impulses back to the candidates and the wall memory.
    fn keep(&mut self) {
        let bands = self.band_pairs.len();
        let seams = self.seam_pairs.len();
        self.wall_warm_next.clear();
        for (l, list) in self.lists.iter().enumerate() {
            let pairs = if l < bands {
                &mut self.band_pairs[l]
            } else if l < bands + seams {
                &mut self.seam_pairs[l - bands]
            } else {
                &mut self.big_pairs
            };
            for c in list {
                if !c.active {
                    continue;
                }
                // An active contact that carried nothing is kept too, with the mark (see
                // `RESTED`): the next span knows it rested.
                let impulse = c.impulse.max(RESTED);
                if c.b == WALL {
                    self.wall_warm_next.push((c.key / 2, (c.key % 2) as u8, impulse));
                } else {
                    pairs[c.key as usize].impulse = impulse;
                }
            }
        }
        self.wall_warm_next.sort_unstable_by_key(|&(b, a, _)| (b, a));
        std::mem::swap(&mut self.wall_warm, &mut self.wall_warm_next);
    }

    /// The three phases over the lists (in parallel by `parts` when it has bands).
    #[allow(clippy::too_many_arguments)]
    fn phases(
        &mut self,
        x: &mut [DVec2],
        v: &mut [DVec2],
        fixed: Fixed<'_>,
        inputs: &Inputs<'_>,
        parts: &Parts<'_>,
        (grid, slot): (&BroadPhase, &dyn Fn(usize) -> usize),
        index: &dyn Fn(usize) -> usize,
    ) -> Outcome {
        let mut outcome = Outcome { converged: true, ..Default::default() };
        for list in &self.lists {
            outcome.wall_contacts += list.iter().filter(|c| c.b == WALL && c.tau >= 0.0).count() as u64;
        }
        let mut impacts = impact_phase(&mut self.lists, x, v, &inputs.tolerances, true, &mut self.impact);
        // Whether every pair that touches after the impacts has its contact: the impacts
        // converged, and the last search for the pairs they brought together found none.
        let mut all_listed = false;
        for _ in 0..MAX_REDETECTIONS {
            outcome.pairs_reached += self.reach_struck_balls(x, v, fixed, inputs, grid, slot);
            if self.redetect(x, v, fixed, inputs, index) == 0 {
                all_listed = impacts.converged;
                break;
            }
            let more = impact_phase(&mut self.lists, x, v, &inputs.tolerances, false, &mut self.impact);
            impacts.rounds += more.rounds;
            impacts.converged &= more.converged;
        }
        outcome.converged &= impacts.converged;
        outcome.rounds = impacts.rounds;
        for list in &self.lists {
            outcome.impacts += list.iter().filter(|c| c.b != WALL && c.impact > 0.0).count() as u64;
        }
        let ids = fixed.id;
        let (span, drift, reach_gap) = (inputs.span, inputs.drift, inputs.tolerances.reach_gap);
        let slop = inputs.tolerances.slop;
        sweep(&mut self.lists, x, v, parts, |list, x, v, base| {
            resting_begin(list, x, v, base, &ids[base..], span, drift, reach_gap);
            (0.0, WallImpulses::default())
        });
        sweep(&mut self.lists, x, v, parts, |list, _, v, base| {
            resting_warm_start(list, v, base);
            (0.0, WallImpulses::default())
        });
        outcome.resting = self.lists.iter().flatten().filter(|c| c.active).count() as u64;
        if outcome.resting > 0 {
            let lists = &mut self.lists;
            let (passes, converged) = iterate_resting(MAX_RESTING_PASSES, inputs.tolerances.resting, |backward| {
                let (change, _) = sweep_in(lists, x, v, parts, backward, |list, _, v, base| {
                    (resting_pass(list, v, base, backward), WallImpulses::default())
                });
                change
            });
            outcome.resting_passes = passes;
            outcome.converged &= converged;
            // The islands `islands_after_passes` says. Serial, over the whole arrays: each
            // island's contacts in list order, the same bits on any number of threads.
            let t = &inputs.tolerances;
            if let Some(tolerance) = islands_after_passes(converged, outcome.resting, t.weighed, t.resting) {
                let n = v.len();
                outcome.islands_solved = solve_resting_islands(&mut self.lists, v, n, tolerance, &mut self.islands);
            }
        }
        let (_, walls) = sweep(&mut self.lists, x, v, parts, |list, x, _, base| {
            let mut walls = WallImpulses::default();
            resting_end(list, x, base, span, drift, &mut walls);
            (0.0, walls)
        });
        outcome.walls = walls;
        let position = |lists: &mut [Vec<Contact>], x: &mut [DVec2], v: &mut [DVec2]| {
            iterate_position(MAX_POSITION_PASSES, inputs.tolerances.overlap + slop, || {
                let (overlap, _) = sweep(lists, x, v, parts, |list, x, _, base| {
                    (position_pass(list, x, base, &ids[base..], slop), WallImpulses::default())
                });
                overlap
            })
        };
        let (mut passes, mut converged) = position(&mut self.lists, x, v);
        // Pairs the passes pushed together are listed and the passes run again (see
        // `pushed_together`; with the pairs of balls pushed beyond the skin), as are pairs a
        // cut-off cascade of impacts left overlapping. A
        // single pass found no overlap beyond the tolerance, so it moved no ball by more than a
        // few times `overlap` of its size: after impacts that listed every touching pair, it
        // cannot have closed a gap by the slop.
        let mut last = if all_listed { passes } else { 2 };
        while last > 1 {
            outcome.pairs_reached += self.reach_pushed_balls(x, fixed, grid, index);
            let listed = self.list_pushed_together(x, v, fixed, inputs, index);
            if listed == 0 {
                break;
            }
            outcome.pushed_together += listed;
            let (more, within) = position(&mut self.lists, x, v);
            (last, passes, converged) = (more, passes + more, within);
        }
        outcome.position_passes = passes;
        outcome.converged &= converged;
        sweep(&mut self.lists, x, v, parts, |list, x, _, base| {
            wall_pass(list, x, base);
            (0.0, WallImpulses::default())
        });
        outcome
    }
}

/// The uniform acceleration of working ball `i`: gravity, and the pull on the key ball (`key`).
fn acceleration_of(inputs: &Inputs<'_>, key: Option<usize>, i: usize) -> DVec2 {
    if Some(i) == key { inputs.gravity + inputs.key_acceleration } else { inputs.gravity }
}

/// The candidate pairs by group (bands, seams, big balls) and the contact lists, one a group.
type Groups<'a> = (&'a mut [Vec<Candidate>], &'a mut [Vec<Candidate>], &'a mut Vec<Candidate>, &'a mut [Vec<Contact>]);

/// Adds a contact for each candidate pair that has none this sub-step and that `want` (working
/// indices) picks, if the pair touches within the span ([`pair_contact`]), to the list of its
/// group (so the bands stay disjoint). Returns how many were added.
fn list_unlisted(
    (bands, seams, big, lists): Groups<'_>,
    (x, v, fixed, key): (&[DVec2], &[DVec2], Fixed<'_>, Option<usize>),
    inputs: &Inputs<'_>,
    index: &dyn Fn(usize) -> usize,
    want: impl Fn(usize, usize) -> bool,
) -> u64 {
    let body = |i: usize| {
        (i as u32, fixed.id[i], x[i], v[i], acceleration_of(inputs, key, i), fixed.inverse_mass[i], fixed.radius[i])
    };
    let mut added = 0;
    let groups = bands.iter_mut().chain(seams.iter_mut()).chain(std::iter::once(big));
    for (l, pairs) in groups.enumerate() {
        for (n, p) in pairs.iter_mut().enumerate() {
            if p.listed {
                continue;
            }
            let (i, j) = (index(p.k as usize), index(p.m as usize));
            if !want(i, j) {
                continue;
            }
            if let Some(mut c) = pair_contact(body(i), body(j), inputs.span, inputs.restitution) {
                c.key = n as u32;
                lists[l].push(c);
                p.listed = true;
                added += 1;
            }
        }
    }
    added
}

/// The slot runs of the bands and seams (empty: work serially in place).
struct Parts<'a> {
    bands: &'a [Range<usize>],
    seams: &'a [Range<usize>],
}

/// Runs `f(list, x, v, base)` over every list in the fixed order — bands, seams, big balls —
/// in parallel by band and by seam when `parts` has them, and combines the results: the largest
/// of the numbers and the wall impulses summed in list order (the same bits on any number of
/// threads).
fn sweep<F>(
    lists: &mut [Vec<Contact>],
    x: &mut [DVec2],
    v: &mut [DVec2],
    parts: &Parts<'_>,
    f: F,
) -> (f64, WallImpulses)
where
    F: Fn(&mut [Contact], &mut [DVec2], &mut [DVec2], usize) -> (f64, WallImpulses) + Sync + Send,
{
    sweep_in(lists, x, v, parts, false, f)
}

/// [`sweep`], or with `backward` the whole order reversed: big balls, seams, bands (each list's
/// own reversal is `f`'s business). Bands still run at the same time, then seams.
fn sweep_in<F>(
    lists: &mut [Vec<Contact>],
    x: &mut [DVec2],
    v: &mut [DVec2],
    parts: &Parts<'_>,
    backward: bool,
    f: F,
) -> (f64, WallImpulses)
where
    F: Fn(&mut [Contact], &mut [DVec2], &mut [DVec2], usize) -> (f64, WallImpulses) + Sync + Send,
{
    let combine = |(a, mut wa): (f64, WallImpulses), (b, wb): (f64, WallImpulses)| {
        wa.add_all(&wb);
        (a.max(b), wa)
    };
    if parts.bands.is_empty() {
        let mut total = (0.0, WallImpulses::default());
        if backward {
            for list in lists.iter_mut().rev() {
                total = combine(total, f(list, x, v, 0));
            }
        } else {
            for list in lists.iter_mut() {
                total = combine(total, f(list, x, v, 0));
            }
        }
        return total;
    }
    let (bands, rest) = lists.split_at_mut(parts.bands.len());
    let (seams, big) = rest.split_at_mut(parts.seams.len());
    let mut total = (0.0, WallImpulses::default());
    if backward {
        total = combine(total, f(&mut big[0], x, v, 0));
    }
    let groups = if backward {
        [(parts.seams, seams), (parts.bands, bands)]
    } else {
        [(parts.bands, bands), (parts.seams, seams)]
    };
    for (runs, lists) in groups {
        let split = split_runs(x, v, runs);
        let results: Vec<(f64, WallImpulses)> =
            split.into_par_iter().zip(lists.par_iter_mut()).map(|((base, x, v), list)| f(list, x, v, base)).collect();
        // Combined in list order: the same sums on any number of threads (only maxima and wall
        // impulses are combined, and no wall impulse is taken in a backward pass).
        for r in results {
            total = combine(total, r);
        }
    }
    if !backward {
        total = combine(total, f(&mut big[0], x, v, 0));
    }
    total
}

/// Splits the two slot-ordered arrays into the disjoint, increasing runs given, returning each
/// run's first slot with its sub-slices.
pub(super) fn split_runs<'a>(
    mut x: &'a mut [DVec2],
    mut v: &'a mut [DVec2],
    runs: &[Range<usize>],
) -> Vec<(usize, &'a mut [DVec2], &'a mut [DVec2])> {
    let mut parts = Vec::with_capacity(runs.len());
    let mut at = 0;
    for run in runs {
        debug_assert!(run.start >= at && run.end >= run.start);
        let (_, rest_x) = std::mem::take(&mut x).split_at_mut(run.start - at);
        let (_, rest_v) = std::mem::take(&mut v).split_at_mut(run.start - at);
        let (part_x, rest_x) = rest_x.split_at_mut(run.len());
        let (part_v, rest_v) = rest_v.split_at_mut(run.len());
        parts.push((run.start, part_x, part_v));
        (x, v, at) = (rest_x, rest_v, run.end);
    }
    parts
}
