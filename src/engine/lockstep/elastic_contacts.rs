//! The contacts of a perfectly elastic field (ball restitution 1): sequential impulses over the
//! touching pairs, band by band, on one thread or several with the same bits.
//!
//! Every approaching pair gets the elastic impulse along the line of centres at its instant of
//! contact and is replayed from it (`contact_ball_ball`), passes over the pairs in a fixed order
//! until none overlaps; the walls come after, in the finish pass (`contact_ball_wall`, replayed
//! along the ball's parabola). Each impulse keeps the energy on its own, so the field keeps it to
//! rounding, however dense (the elastic pile of `tests/stability.rs`: 1e-13 over a minute). An
//! impact's impulse does not run on within its pass: a pair closing faster than the chain speed
//! whose ball a fast impulse of the same pass struck waits for the next pass, so fast impacts go
//! in rounds of sequential impacts, as the inelastic solver's rounds go, and a row struck from
//! both ends at once comes out a mirror image whichever end is listed first. The solver of inelastic
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
use crate::physics::{
    BallBallTouch, Bodies, BroadPhase, ContactBody, Field, RoundContact, RoundScratch, SAME_INSTANT, WallImpulses,
    contact_ball_ball_or_touching, contact_ball_wall, out_of_reach, solve_simultaneous,
};

/// Impulses applied and pairs still overlapping in one pass (or summed over passes), and the
/// impulses of contacts that approached faster than the pass's chain speed (see
/// [`ElasticContacts::solve`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tally {
    pub impulses: u64,
    pub active: u64,
    pub fast: u64,
}

impl std::ops::Add for Tally {
    type Output = Tally;
    fn add(self, o: Tally) -> Tally {
        Tally { impulses: self.impulses + o.impulses, active: self.active + o.active, fast: self.fast + o.fast }
    }
}

/// The most passes of one sub-step while a chain of fast impacts goes on (see
/// [`ElasticContacts::solve`]): a heavy ball dropped on a light one resting on the floor strikes
/// it and the floor in turn about π·√(M/m) times before the light one outruns it (14 at 20:1).
pub const MAX_CHAIN_PASSES: usize = 64;

/// The walls as the elastic passes meet them: the field, and each ball's uniform acceleration over
/// the step (for the bounce's replay along its parabola).
#[derive(Clone, Copy)]
pub struct ElasticWalls<'a> {
    pub field: &'a Field,
    pub gravity: DVec2,
    /// The key ball's index and its extra acceleration (the pull).
    pub key: Option<usize>,
    pub key_acceleration: DVec2,
}

impl ElasticWalls<'_> {
    pub(super) fn acceleration(&self, i: usize) -> DVec2 {
        if Some(i) == self.key { self.gravity + self.key_acceleration } else { self.gravity }
    }
}

/// What one sub-step's elastic contacts did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElasticOutcome {
    /// Ball–ball impulses applied.
    pub impulses: u64,
    /// Wall bounces inside the passes, and the impulses the walls took there.
    pub wall_bounces: u64,
    pub walls: WallImpulses,
    /// Whether the passes stopped with pairs of their last pass still overlapping (their cap
    /// reached): a jammed ball, such as a light one in a pocket between heavy ones and a wall,
    /// that the resting phase's position passes must push out (see [`super::ElasticResting`]).
    pub overlaps_left: bool,
    /// Pairs added to the candidates for balls struck beyond the grid's view (see
    /// [`reach_struck`]).
    pub pairs_reached: u64,
}

/// The touching pairs (as slots) grouped for the solver, and the slot-ordered copy of the balls.
#[derive(Clone, Debug, Default)]
pub struct ElasticContacts {
    band_pairs: Vec<Vec<(u32, u32)>>,
    seam_pairs: Vec<Vec<(u32, u32)>>,
    big_pairs: Vec<(u32, u32)>,
    local: SlotBodies,
    /// Per ball (serial: by index; parallel: by slot), how long before the end of the sub-step
    /// its latest replayed impact struck it (∞: none yet): a wall it crossed after that is met
    /// between passes (see [`bounce_walls`]).
    latest: Vec<f64>,
    /// The balls (working indices) a replayed impact struck in this sub-step, in the order first
    /// struck, and each band's of a pass (parallel).
    struck: Vec<u32>,
    band_struck: Vec<Vec<u32>>,
    /// Per ball (indexed as `latest`), the pass (counted over the solver's life, from 1) in which
    /// a fast impulse last struck it: a fast pair of that ball waits for the next pass (see
    /// [`solve_pairs`]).
    fast_in: Vec<u64>,
    /// Per slot, the pass (counted as `fast_in`) that last changed the ball there (an impulse, a
    /// shift, a round, a wall), and per pair list (bands, seams, the big balls' pairs), its pairs
    /// that a pass met without changing their balls while they might be closing fast: after the
    /// first pass of a sub-step, the look for simultaneous impacts tests these pairs and those
    /// with a ball changed since the pass before alone (see [`simultaneous`]).
    changed_in: Vec<u64>,
    unchanged: Vec<Vec<u32>>,
    /// Passes so far, over the solver's life.
    passes: u64,
    /// Calls of [`ElasticContacts::find_pairs`] so far: the pair lists change only then.
    generation: u64,
}

impl ElasticContacts {
    /// Touching pairs found by the last [`ElasticContacts::find_pairs`].
    pub fn pair_count(&self) -> usize {
        self.band_pairs.iter().chain(&self.seam_pairs).map(Vec::len).sum::<usize>() + self.big_pairs.len()
    }

    /// Which [`ElasticContacts::find_pairs`] the pair lists are from (they change only there).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Calls `f(i, j)` with the balls of every pair found by the last
    /// [`ElasticContacts::find_pairs`], in the passes' order (bands, seams, big balls).
    pub fn for_each_pair(&self, grid: &BroadPhase, f: &mut dyn FnMut(usize, usize)) {
        let slots = grid.slots();
        let lists = self.band_pairs.iter().chain(&self.seam_pairs).chain(std::iter::once(&self.big_pairs));
        for &(k, m) in lists.flatten() {
            f(slots[k as usize] as usize, slots[m as usize] as usize);
        }
    }

    /// Collects the touching pairs of the grid's last update, band by band (in parallel when
    /// `parallel`; the lists are the same either way).
    pub fn find_pairs(&mut self, grid: &BroadPhase, parallel: bool) {
        self.generation += 1;
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

    /// Runs passes over the pairs, each followed by the walls of the balls near one
    /// (`contact_ball_wall`, replayed along the ball's parabola; the balls in index order), and
    /// returns what they did. It stops after a pass in which no pair overlapped and no ball met a
    /// wall; after `iterations` passes, unless the last pass struck a contact approaching faster
    /// than `together` (the chain speed: a chain of impacts goes on, such as a heavy ball
    /// dropped on a light one on the floor, struck pass by pass as the sequential impacts
    /// strike it), and after [`MAX_CHAIN_PASSES`] in any case. `parallel` says whether the bands
    /// may be worked on several threads (the caller runs this inside its thread pool); it
    /// changes no bit of the result.
    ///
    /// (With the walls after the passes only, in the finish pass, a 20 kg ball dropped on a 1 kg
    /// one resting on the floor at e = 1 left the light one at 1.861 m/s, against 1.509 m/s at
    /// e = 0.999 and the sequential impacts' 1.528.)
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        bodies: &mut Bodies,
        grid: &BroadPhase,
        walls: &ElasticWalls<'_>,
        restitution: f64,
        dt: f64,
        together: f64,
        iterations: usize,
        parallel: bool,
    ) -> ElasticOutcome {
        if self.pair_count() == 0 {
            return ElasticOutcome::default();
        }
        // The parallel solver first copies every ball into slot order and back (O(n)), which a
        // sparse field's few pairs do not pay for: it takes the bands in parallel only when there
        // are at least half as many pairs as balls (a pile has about three per ball, a falling
        // rain one per ten). Both ways give the same bits.
        if parallel && self.pair_count() >= PARALLEL_MIN_PAIRS.max(bodies.len() / 2) {
            self.solve_parallel(bodies, grid, walls, restitution, dt, together, iterations)
        } else {
            self.solve_serial(bodies, grid, walls, restitution, dt, together, iterations)
        }
    }

    /// The reference order, in place: pair (k, m) is balls (slots[k], slots[m]).
    #[allow(clippy::too_many_arguments)]
    fn solve_serial(
        &mut self,
        b: &mut Bodies,
        grid: &BroadPhase,
        walls: &ElasticWalls<'_>,
        e: f64,
        dt: f64,
        together: f64,
        iterations: usize,
    ) -> ElasticOutcome {
        let slots = grid.slots();
        let Bodies { id, inverse_mass, radius, mass, position, velocity, .. } = b;
        let fixed = Fixed { id, inverse_mass, radius };
        let list_count = self.band_pairs.len() + self.seam_pairs.len() + 1;
        let mut outcome = ElasticOutcome::default();
        let mut group = true;
        let (latest, struck, fast_in) = (&mut self.latest, &mut self.struck, &mut self.fast_in);
        forget_struck(latest, struck, position.len());
        fast_in.resize(position.len(), 0);
        let changed_in = &mut self.changed_in;
        changed_in.resize(position.len(), 0);
        self.unchanged.resize_with(list_count, Vec::new);
        let first = self.passes + 1;
        let ball_slot = grid.ball_slots();
        for iteration in 0..MAX_CHAIN_PASSES {
            self.passes += 1;
            let mut pass = Tally::default();
            let lists = self.band_pairs.iter().chain(&self.seam_pairs).chain(std::iter::once(&self.big_pairs));
            for (list, unchanged) in lists.zip(&mut self.unchanged) {
                let mut marks = Marks { latest, fast_in, pass: self.passes, struck, changed_in, base: 0, unchanged };
                let look = look(group, self.passes, first);
                pass = pass
                    + solve_pairs(list, fixed, position, velocity, &mut marks, e, dt, together, look, |k| {
                        let i = slots[k] as usize;
                        (i, i)
                    });
            }
            let bounced = bounce_walls(
                walls,
                struck,
                radius,
                mass,
                position,
                velocity,
                latest,
                together,
                dt,
                &mut outcome,
                changed_in,
                self.passes,
                |i| i,
                |i| ball_slot[i] as usize,
            );
            outcome.impulses += pass.impulses;
            outcome.overlaps_left = pass.active > 0;
            let lists = (&self.band_pairs[..], &self.seam_pairs[..], &mut self.big_pairs);
            let reached = reach_struck(
                grid,
                struck,
                latest,
                (position, velocity, radius),
                |i| i,
                |i| ball_slot[i] as usize,
                lists,
            );
            outcome.pairs_reached += reached;
            match next_pass(pass, bounced, iteration, iterations) {
                Some(grouped) => group = grouped,
                None if reached > 0 => group = true,
                None => break,
            }
        }
        if outcome.pairs_reached > 0 {
            self.generation += 1;
        }
        outcome
    }

    /// The same passes with the bands (then the seams) on the pool's threads, on a slot-ordered
    /// copy of the balls (see the module comment); the walls, serially, between passes.
    #[allow(clippy::too_many_arguments)]
    fn solve_parallel(
        &mut self,
        b: &mut Bodies,
        grid: &BroadPhase,
        walls: &ElasticWalls<'_>,
        e: f64,
        dt: f64,
        together: f64,
        iterations: usize,
    ) -> ElasticOutcome {
        let l = &mut self.local;
        l.gather(b, grid.slots());
        let fixed = Fixed { id: &l.id, inverse_mass: &l.inverse_mass, radius: &l.radius };
        let bands: Vec<Range<usize>> = (0..grid.band_count()).map(|k| grid.band_slots(k)).collect();
        let seams: Vec<Range<usize>> = (0..self.seam_pairs.len()).map(|k| grid.seam_slots(k)).collect();
        let ball_slot = grid.ball_slots();
        let mut outcome = ElasticOutcome::default();
        let mut group = true;
        let (latest, struck, band_struck) = (&mut self.latest, &mut self.struck, &mut self.band_struck);
        forget_struck(latest, struck, l.position.len());
        let fast_in = &mut self.fast_in;
        fast_in.resize(l.position.len(), 0);
        let changed_in = &mut self.changed_in;
        changed_in.resize(l.position.len(), 0);
        let (band_count, seam_count) = (bands.len(), seams.len());
        self.unchanged.resize_with(band_count + seam_count + 1, Vec::new);
        let slots = grid.slots();
        let first = self.passes + 1;
        for iteration in 0..MAX_CHAIN_PASSES {
            self.passes += 1;
            let this_pass = self.passes;
            let look = look(group, this_pass, first);
            let mut pass = Tally::default();
            let (band_unchanged, rest) = self.unchanged.split_at_mut(band_count);
            let (seam_unchanged, big_unchanged) = rest.split_at_mut(seam_count);
            for (runs, lists, unchanged) in
                [(&bands, &self.band_pairs, band_unchanged), (&seams, &self.seam_pairs, seam_unchanged)]
            {
                let parts = split_runs(&mut l.position, &mut l.velocity, runs);
                let times = split_run(latest, runs);
                let fast = split_run(fast_in, runs);
                let changed = split_run(changed_in, runs);
                band_struck.resize_with(runs.len(), Vec::new);
                // Counts only: the same sums in any order.
                pass = pass
                    + parts
                        .into_par_iter()
                        .zip(times)
                        .zip(fast)
                        .zip(changed)
                        .zip(unchanged.par_iter_mut())
                        .zip(band_struck.par_iter_mut())
                        .zip(lists.par_iter())
                        .map(|(((((((base, x, v), latest), fast_in), changed_in), unchanged), struck), list)| {
                            struck.clear();
                            let mut marks =
                                Marks { latest, fast_in, pass: this_pass, struck, changed_in, base, unchanged };
                            solve_pairs(list, fixed, x, v, &mut marks, e, dt, together, look, |k| (k, k - base))
                        })
                        .reduce(Tally::default, |a, c| a + c);
                // In band (seam) order: the same list on any number of threads.
                for s in band_struck.iter().take(runs.len()) {
                    struck.extend_from_slice(s);
                }
            }
            pass = pass
                + solve_pairs(
                    &self.big_pairs,
                    fixed,
                    &mut l.position,
                    &mut l.velocity,
                    &mut Marks {
                        latest,
                        fast_in,
                        pass: this_pass,
                        struck,
                        changed_in,
                        base: 0,
                        unchanged: &mut big_unchanged[0],
                    },
                    e,
                    dt,
                    together,
                    look,
                    |k| (k, k),
                );
            let bounced = bounce_walls(
                walls,
                struck,
                &b.radius,
                &b.mass,
                &mut l.position,
                &mut l.velocity,
                latest,
                together,
                dt,
                &mut outcome,
                changed_in,
                this_pass,
                |s| slots[s] as usize,
                |s| s,
            );
            outcome.impulses += pass.impulses;
            outcome.overlaps_left = pass.active > 0;
            let lists = (&self.band_pairs[..], &self.seam_pairs[..], &mut self.big_pairs);
            let state = (&l.position[..], &l.velocity[..], &b.radius[..]);
            let reached = reach_struck(grid, struck, latest, state, |s| slots[s] as usize, |s| s, lists);
            outcome.pairs_reached += reached;
            match next_pass(pass, bounced, iteration, iterations) {
                Some(grouped) => group = grouped,
                None if reached > 0 => group = true,
                None => break,
            }
        }
        l.scatter(b, ball_slot);
        if outcome.pairs_reached > 0 {
            self.generation += 1;
        }
        outcome
    }
}

/// After pass `iteration` (from 0) of a sub-step's elastic passes, which did `pass` over the pairs
/// and `bounced` at the walls: `None` when the passes stop (see [`ElasticContacts::solve`]: no
/// overlap and no wall met, or `iterations` passes and no fast impact going on), else whether the
/// next pass solves simultaneous impacts together (only after a pass that struck, or left
/// waiting, a fast impact or bounced a ball off a wall fast; the first pass always does): a fast
/// impulse sets pairs closing that may meet at once, such as a ball struck on top of two
/// touching balls, which then strikes both — they come before or after the first impact in the
/// list, and those before it are seen only in the next pass.
fn next_pass(pass: Tally, bounced: Tally, iteration: usize, iterations: usize) -> Option<bool> {
    if pass.active == 0 && bounced.impulses == 0 {
        return None;
    }
    if iteration + 1 >= iterations && pass.fast + bounced.fast == 0 {
        return None;
    }
    Some(bounced.fast + pass.fast > 0)
}

/// What a pass over the pairs marks on the balls it strikes (indexed as `x`, `v`): each one's
/// latest replayed impact (see [`ElasticContacts`]'s `latest`), the balls struck for the first
/// time in the sub-step (`struck`), and the pass in which a fast impulse last struck each one.
struct Marks<'a> {
    latest: &'a mut [f64],
    fast_in: &'a mut [u64],
    /// This pass's number.
    pass: u64,
    struck: &'a mut Vec<u32>,
    /// Per ball (by its mark index: its slot, or its slot in the run), the pass that last changed
    /// it; and the pairs of the list this pass leaves unchanged while they might close fast (see
    /// [`ElasticContacts`]'s `changed_in` and `unchanged`).
    changed_in: &'a mut [u64],
    /// The slot of `changed_in[0]`: the run's first slot, or 0 for the whole field.
    base: usize,
    unchanged: &'a mut Vec<u32>,
}

/// Which pairs a pass looks at for simultaneous impacts (see [`simultaneous`]).
#[derive(Clone, Copy, PartialEq)]
enum Look {
    /// No look (a pass after one without a fast impulse or a fast wall bounce).
    None,
    /// Every pair: a sub-step's first pass.
    All,
    /// The pairs with a ball changed in the given pass or after it (the last pass), and those
    /// that pass left unchanged while they might close fast.
    ChangedSince(u64),
}

/// The look of pass number `pass` of a sub-step whose first pass is `first`, when `group` (see
/// [`next_pass`]).
fn look(group: bool, pass: u64, first: u64) -> Look {
    match (group, pass == first) {
        (false, _) => Look::None,
        (true, true) => Look::All,
        #[cfg(test)]
        (true, false) if tests::FULL_LOOK.get() => Look::All,
        (true, false) => Look::ChangedSince(pass - 1),
    }
}

/// Whether balls `(fi, i)` and `(fj, j)` (each: index into `fixed`, index into `x` and `v`)
/// overlap or are short of touching by no more than [`SAME_INSTANT`] and close faster than
/// `speed` along their line of centres: the test of the look for simultaneous impacts. The
/// velocities are read only for a pair within reach.
#[inline(always)]
fn closing_fast(
    fixed: Fixed<'_>,
    x: &[DVec2],
    v: &[DVec2],
    (fi, i): (usize, usize),
    (fj, j): (usize, usize),
    speed: f64,
) -> bool {
    let d = x[j] - x[i];
    let touch = (fixed.radius[fi] + fixed.radius[fj]) * (1.0 + SAME_INSTANT);
    let dist2 = d.length_squared();
    dist2 < touch * touch && (v[j] - v[i]).dot(d) < -speed * dist2.sqrt()
}

impl Marks<'_> {
    /// Marks the ball in slot `k` changed in this pass.
    #[inline(always)]
    fn changed(&mut self, k: u32) {
        self.changed_in[k as usize - self.base] = self.pass;
    }

    /// Marks ball `s` (its index into `fixed` `f`) struck by an impulse replayed from `t` before
    /// the end of the sub-step.
    fn replayed(&mut self, f: usize, s: usize, t: f64) {
        if self.latest[s] == f64::INFINITY {
            self.struck.push(f as u32);
        }
        self.latest[s] = self.latest[s].min(t);
    }
}

/// Sets every ball's latest impact to none (∞) for a sub-step of `n` balls: the last sub-step's
/// struck balls alone (`struck`, then emptied), or the whole array when `n` changed. (Filling all
/// of it every sub-step took a few µs of a 10,000-ball gas's step.) The serial and the parallel
/// solver index it differently (ball or slot), so whichever ran last leaves its own marks: both
/// are ∞ everywhere but at `struck`.
fn forget_struck(latest: &mut Vec<f64>, struck: &mut Vec<u32>, n: usize) {
    if latest.len() == n {
        for &s in struck.iter() {
            latest[s as usize] = f64::INFINITY;
        }
    } else {
        latest.clear();
        latest.resize(n, f64::INFINITY);
    }
    struck.clear();
}

/// How much earlier than a ball's latest impact (a share of the step) its wall crossing may seem
/// and still count as after it: a chain's impacts and bounces follow each other within
/// microseconds, and each one's instant is its own rewind along the state the last left, good to
/// a few thousandths of a step (a 10 kg ball on a 1 kg one: the second bounce's crossing came out
/// 4.5e-4 of a step before the second impact). A hot elastic gas's balls that crossed a wall
/// before their impact did so a sizeable part of a step before it.
const CHAIN_SLACK: f64 = 0.01;

/// Splits a slot-ordered array into the disjoint, increasing runs given (as `split_runs` does
/// the positions and velocities).
fn split_run<'a, T>(mut a: &'a mut [T], runs: &[Range<usize>]) -> Vec<&'a mut [T]> {
    let mut parts = Vec::with_capacity(runs.len());
    let mut at = 0;
    for run in runs {
        let (_, rest) = std::mem::take(&mut a).split_at_mut(run.start - at);
        let (part, rest) = rest.split_at_mut(run.len());
        parts.push(part);
        (a, at) = (rest, run.end);
    }
    parts
}

/// The walls of the balls struck so far in the sub-step (`struck`: their indices into `x`, `v`,
/// `latest`, in the order first struck; `ball(s)`: the ball at index s, for its radius and
/// mass), met between passes: a ball that a replayed impact struck in this sub-step and that
/// crossed a wall after it (the crossing `depth / speed` before the end, at most its `latest`;
/// the depth less what a ball resting on the wall sinks into it in a step, `|a|·dt²`, so that one
/// resting there when struck counts as crossing after),
/// moving into the wall faster than `fast` (the chain speed), bounces (`contact_ball_wall`, its
/// impulse on `outcome`'s gauges) and may be struck again in the next pass — the chain of a heavy
/// ball dropped on a light one resting on the floor. Each ball let meet its walls is marked
/// changed in `pass` (`changed_in`, at its slot `slot(s)`). Returns the bounces (as `impulses` and
/// `fast`).
///
/// Any other ball past a wall is left to the finish pass, as before the walls came into the
/// passes: a ball that crossed the wall before its impact (a later pass would replay that impact
/// along the path the bounce left), one resting on the floor, or one a pair pushed there.
/// Bounced between passes, any ball moving fast into a wall cost the hot elastic pile
/// (`hard/elastic-pile`) its energy: a drift of 3e-7 over a minute, against 1e-13.
#[allow(clippy::too_many_arguments)]
fn bounce_walls(
    walls: &ElasticWalls<'_>,
    struck: &[u32],
    radius: &[f64],
    mass: &[f64],
    x: &mut [DVec2],
    v: &mut [DVec2],
    latest: &mut [f64],
    fast: f64,
    dt: f64,
    outcome: &mut ElasticOutcome,
    changed_in: &mut [u64],
    pass: u64,
    ball: impl Fn(usize) -> usize,
    slot: impl Fn(usize) -> usize,
) -> Tally {
    let mut tally = Tally::default();
    let field = walls.field;
    for &s in struck {
        let (s, i) = (s as usize, ball(s as usize));
        if latest[s] == f64::INFINITY {
            continue;
        }
        let (p, u, r) = (x[s], v[s], radius[i]);
        let acceleration = walls.acceleration(i);
        // What a ball resting on the wall sinks into it in a step before it is struck.
        let sink = acceleration.length() * dt * dt;
        // The speed into the walls it is past, and how long ago it crossed the deepest.
        let (mut into, mut crossed) = (f64::NEG_INFINITY, 0.0f64);
        let mut wall = |depth: f64, speed: f64| {
            if depth > 0.0 {
                into = into.max(speed);
                crossed = crossed.max((depth - sink).max(0.0) / speed.max(f64::MIN_POSITIVE));
            }
        };
        wall(r - p.x, -u.x);
        wall(p.x - (field.width - r), u.x);
        wall(r - p.y, -u.y);
        wall(p.y - (field.height - r), u.y);
        if into > fast && crossed <= latest[s] + CHAIN_SLACK * dt {
            changed_in[slot(s)] = pass;
            if !contact_ball_wall(&mut x[s], &mut v[s], r, mass[i], acceleration, field, &mut outcome.walls) {
                continue;
            }
            latest[s] = crossed;
            tally.impulses += 1;
            tally.fast += 1;
            outcome.wall_bounces += 1;
        }
    }
    tally
}

/// The pair lists of the passes: the bands', the seams' and the big balls' (which the passes work
/// serially after the others).
type PairLists<'a> = (&'a [Vec<(u32, u32)>], &'a [Vec<(u32, u32)>], &'a mut Vec<(u32, u32)>);

/// Adds to `big_pairs` (worked serially after the bands and seams, so the bits stay the same on
/// any number of threads) the pairs a struck ball's path since its latest impact may meet beyond
/// those the grid found: the pairs hold every two balls that can touch while each stays within
/// half the skin of where the grid last saw it, but an impact can send a ball beyond that within
/// the sub-step. In an elastic landing of 100 kg and 1 kg balls on elastic walls the light ones
/// are struck to 100–260 m/s, 0.26 m in a step of 1 ms against a skin of 0.1 m, and ended steps
/// up to 24 % of a diameter into balls they had no pair with. A struck ball (working index `s`
/// of `struck`; `latest[s]` how long since its latest impact, its state at `x[s]`, `v[s]`, its
/// radius `radius[ball(s)]`, its slot `slot(s)`) whose path since that impact (straight back
/// along its velocity) leaves that half skin is looked up around its path
/// ([`BroadPhase::for_each_pair_beyond`]); the pairs stay candidates until the pairs are next
/// found afresh. Returns how many were added.
fn reach_struck(
    grid: &BroadPhase,
    struck: &[u32],
    latest: &[f64],
    (x, v, radius): (&[DVec2], &[DVec2], &[f64]),
    ball: impl Fn(usize) -> usize,
    slot: impl Fn(usize) -> usize,
    (bands, seams, big): PairLists<'_>,
) -> u64 {
    let half_skin = 0.5 * grid.skin();
    let mut beyond: Vec<(usize, DVec2, f64)> = Vec::new();
    for &s in struck {
        let s = s as usize;
        let since = latest[s];
        if !since.is_finite() {
            continue;
        }
        let half_path = 0.5 * v[s].length() * since;
        let centre = x[s] - (0.5 * since) * v[s];
        let k = slot(s);
        let (seen, _) = grid.slot_shape(k);
        if centre.distance(seen) + half_path > half_skin {
            beyond.push((k, centre, radius[ball(s)] + half_path));
        }
    }
    if beyond.is_empty() {
        return 0;
    }
    beyond.sort_unstable_by_key(|b| b.0);
    // The pairs of those balls that are candidates already come from a scan of all of them.
    let known = bands.iter().chain(seams).flatten().chain(big.iter()).copied();
    let mut added = Vec::new();
    let count = grid.for_each_pair_beyond(&beyond, known, |_| true, |k, m| added.push((k, m)));
    big.extend(added);
    count
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
/// Pairs that approach into an overlap faster than `together` (the chain speed) and share a ball
/// with another such pair are struck at once (see [`strike_together`]); every other pair is
/// struck in list order, each seeing the last one's impulse. Impulses on pairs approaching faster
/// than `together` are counted as `fast` (a chain of impacts going on). Groups are looked for as
/// `look` says ([`look`]): over every pair in a sub-step's first pass; in each pass after one
/// that struck a fast impulse, left a fast pair waiting or bounced a struck ball off a wall (a
/// ball dropped on two balls resting on the floor strikes them again, at once, after the floor
/// has sent them back up in the same sub-step), over the pairs with a ball changed since the
/// last pass and those it left unchanged while closing fast (`marks`); other passes skip the
/// look (a whole pass over the pairs: 10 % of a gas's step). Each pass marks the balls it
/// changes and the pairs it leaves unchanged for the next one's look.
#[allow(clippy::too_many_arguments)]
#[inline]
fn solve_pairs(
    pairs: &[(u32, u32)],
    fixed: Fixed<'_>,
    x: &mut [DVec2],
    v: &mut [DVec2],
    marks: &mut Marks<'_>,
    e: f64,
    dt: f64,
    together: f64,
    look: Look,
    index: impl Fn(usize) -> (usize, usize),
) -> Tally {
    let mut tally = Tally::default();
    let groups = simultaneous(pairs, fixed, x, v, together, look, marks, &index);
    // Filled anew for the next pass's look.
    marks.unchanged.clear();
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
                let strike = strike_together(pairs, &groups[g], fixed, x, v, marks, e, dt, &index);
                strike.inspect(|t| tally = tally + *t).is_some()
            });
            if done {
                // The round changed the balls it struck; a pair of the group it did not strike
                // is looked at again.
                marks.unchanged.push(n as u32);
                continue;
            }
        }
        let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
        // Most pairs are out of reach: told on the positions and radii alone, before the rest of
        // the balls is read (`contact_ball_ball_or_touching`'s own first test, the same bits).
        if out_of_reach((x[j] - x[i]).length_squared(), fixed.radius[fi] + fixed.radius[fj]) {
            continue;
        }
        let body = |f: usize, s: usize| contact_body(fixed, x, v, f, s);
        let (a, b) = (body(fi, i), body(fj, j));
        let Some((c, touch)) = contact_ball_ball_or_touching(&a, &b, e, dt) else {
            // Within a rounding of touching and not about to: left unchanged, and looked at
            // again if it might be closing fast (the same test as the look's).
            if closing_fast(fixed, x, v, (fi, i), (fj, j), together) {
                marks.unchanged.push(n as u32);
            }
            continue;
        };
        // J = (1 + e)·|v_rel|/(1/m_a + 1/m_b).
        let fast = c.impulse > 0.0 && c.impulse * (a.inverse_mass + b.inverse_mass) > (1.0 + e) * together;
        if touch == BallBallTouch::AboutToTouch && !fast {
            // A pair short of touching by a rounding is struck only when it closes fast, as the
            // inelastic solver strikes every pair within its touch margin. A step that ends on
            // an impact leaves its pairs overlapping by a rounding or short of touching by one,
            // and struck only when overlapping, two impacts of one instant go one step apart: a
            // row struck from both ends at once (each striker reaching its end at t = 1 s
            // exactly, dt = 1 ms) leaves its strikers at −2.220 and 1.333 m/s where the rounds
            // give ∓1.753, and a ball at rest struck at once by balls at 4 and −3 m/s comes out
            // as the sequential impacts (0, −3 and 4 m/s) where the round gives 2/3, −10/3 and
            // 11/3.
            marks.unchanged.push(n as u32);
            continue;
        }
        tally.active += 1;
        if fast && (marks.fast_in[i] == marks.pass || marks.fast_in[j] == marks.pass) {
            // A fast impulse of this pass struck one of its balls: the impact this one is
            // waits for the next pass, as the next round of sequential impacts, judged on
            // the state this pass leaves. Struck now, the impulse just given would run on
            // through the pairs that follow in list order within the pass, and the
            // numbering would pick the outcome (a row struck from both ends at once: the
            // wave from the end that comes first in the list went through the whole row).
            tally.fast += 1;
            marks.unchanged.push(n as u32);
            continue;
        }
        if c.impulse > 0.0 {
            if fast {
                tally.fast += 1;
                marks.fast_in[i] = marks.pass;
                marks.fast_in[j] = marks.pass;
            }
            v[i] += c.velocity_change_a;
            v[j] += c.velocity_change_b;
            tally.impulses += 1;
        }
        x[i] += c.shift_a;
        x[j] += c.shift_b;
        marks.changed(k);
        marks.changed(m);
        if let Some(t) = c.replayed.filter(|_| c.impulse > 0.0) {
            marks.replayed(fi, i, t);
            marks.replayed(fj, j, t);
        }
    }
    tally
}

/// The groups (indices into `pairs`, in list order, two or more each) of pairs that approach into
/// an overlap faster than `speed` and are joined through shared balls: simultaneous impacts, such
/// as a ball striking two touching balls between them. Nearly always none (a gas's collisions are
/// binary; a resting pile's contacts approach at about g·dt, below `speed`).
#[allow(clippy::too_many_arguments)]
fn simultaneous(
    pairs: &[(u32, u32)],
    fixed: Fixed<'_>,
    x: &[DVec2],
    v: &[DVec2],
    speed: f64,
    look: Look,
    marks: &Marks<'_>,
    index: &impl Fn(usize) -> (usize, usize),
) -> Vec<Vec<u32>> {
    // (ball, pair) for both balls of every fast pair: overlapping, or short of touching by no
    // more than [`SAME_INSTANT`] (see [`contact_ball_ball_or_touching`]).
    let mut ends: Vec<(usize, u32)> = Vec::new();
    // A function, not a closure: inlined into each loop for sure (a closure called from three
    // places was not, and its call on every pair cost the scale bench a few per cent).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn test(
        ends: &mut Vec<(usize, u32)>,
        (fixed, x, v): (Fixed<'_>, &[DVec2], &[DVec2]),
        (fi, i): (usize, usize),
        (fj, j): (usize, usize),
        speed: f64,
        n: usize,
    ) {
        if closing_fast(fixed, x, v, (fi, i), (fj, j), speed) {
            ends.push((i, n as u32));
            ends.push((j, n as u32));
        }
    }
    let balls = (fixed, x, v);
    match look {
        Look::None => return Vec::new(),
        Look::All => {
            for (n, &(k, m)) in pairs.iter().enumerate() {
                let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
                test(&mut ends, balls, (fi, i), (fj, j), speed, n);
            }
        }
        Look::ChangedSince(since) => {
            // A pair whose balls nothing changed since its visit in the last pass is fast now only
            // if it was then, unchanged by that visit: it is on `unchanged`. Every other pair
            // has a ball changed since (a mark of this pass or the last). The candidates are
            // tested as above; `ends` is sorted below, so the order they come in picks nothing.
            let changed = |k: u32| marks.changed_in[k as usize - marks.base] >= since;
            for (n, &(k, m)) in pairs.iter().enumerate() {
                // One branch for both (`|`, not `||`): which pairs pass is data, not a pattern.
                if changed(k) | changed(m) {
                    let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
                    test(&mut ends, balls, (fi, i), (fj, j), speed, n);
                }
            }
            for &n in marks.unchanged.iter() {
                let (k, m) = pairs[n as usize];
                if !(changed(k) || changed(m)) {
                    let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
                    test(&mut ends, balls, (fi, i), (fj, j), speed, n as usize);
                }
            }
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
/// then takes them one by one, as if they were not a group). Each pair still touching gets its
/// normal at the instant of contact ([`contact_ball_ball_or_touching`]); the impulses of those approaching are solved together
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
    marks: &mut Marks<'_>,
    e: f64,
    dt: f64,
    index: &impl Fn(usize) -> (usize, usize),
) -> Option<Tally> {
    let mut tally = Tally::default();
    // The group's balls by their index into `x`/`v` (and into `fixed`, and their slot), and each
    // one's latest contact time.
    let mut balls: Vec<(usize, usize, usize)> = Vec::new();
    let mut tau: Vec<f64> = Vec::new();
    let local =
        |balls: &mut Vec<(usize, usize, usize)>, tau: &mut Vec<f64>, (f, i, mark): (usize, usize, usize)| match balls
            .iter()
            .position(|&(s, _, _)| s == i)
        {
            Some(at) => at,
            None => {
                balls.push((i, f, mark));
                tau.push(f64::NEG_INFINITY);
                balls.len() - 1
            }
        };
    let mut round = Vec::new();
    let mut pushes: Vec<(usize, usize, DVec2)> = Vec::new();
    let (mut earliest, mut latest) = (f64::INFINITY, f64::NEG_INFINITY);
    // The contacts touched at one instant when their instants differ by less than a millionth of
    // the step, or by less than the time any of them takes to close [`SAME_INSTANT`] of its
    // contact distance: each one's instant is its rewind along the state the step left, rounded
    // as the positions are (a step that ends on the impact leaves one pair overlapping by a
    // rounding and the other short of touching by one; at dt = 1e-5 s, after 10⁵ steps, the
    // instants of such an impact were 2.5e-11 s apart, a millionth of the step 1e-11 s).
    let mut apart = f64::INFINITY;
    // Approaching contacts replayed and pushed apart.
    let (mut replayed, mut pushed) = (0, 0);
    for &n in group {
        let (k, m) = pairs[n as usize];
        let ((fi, i), (fj, j)) = (index(k as usize), index(m as usize));
        let (mi, mj) = (k as usize, m as usize);
        let body = |f: usize, s: usize| contact_body(fixed, x, v, f, s);
        let (a, b) = (body(fi, i), body(fj, j));
        let Some((c, _)) = contact_ball_ball_or_touching(&a, &b, e, dt) else { continue };
        tally.active += 1;
        let (la, lb) = (local(&mut balls, &mut tau, (fi, i, mi)), local(&mut balls, &mut tau, (fj, j, mj)));
        match c.replayed {
            Some(t) => {
                tau[la] = tau[la].max(t);
                tau[lb] = tau[lb].max(t);
                earliest = earliest.min(t);
                latest = latest.max(t);
            }
            None => pushes.extend([(i, mi, c.shift_a), (j, mj, c.shift_b)]),
        }
        if c.impulse > 0.0 {
            if c.replayed.is_some() {
                replayed += 1;
            } else {
                pushed += 1;
            }
            let vn = (b.velocity - a.velocity).dot(c.normal);
            // How far apart in time the contacts may have touched and still be one impact.
            apart = apart.min(SAME_INSTANT * (a.radius + b.radius) / -vn);
            round.push(RoundContact {
                target: -e * vn,
                ..RoundContact::new(la, Some(lb), c.normal, a.inverse_mass, b.inverse_mass)
            });
        }
    }
    let apart = apart.max(1e-6 * dt);
    if round.len() < 2 || round.len() > MAX_TOGETHER || latest - earliest > apart || replayed * pushed > 0 {
        return None;
    }
    // A ball of pushed contacts alone is not replayed; one struck only where it is about to
    // touch (a negative instant, see [`contact_ball_ball_or_touching`]) is moved back.
    for t in tau.iter_mut().filter(|t| **t == f64::NEG_INFINITY) {
        *t = 0.0;
    }
    let mut velocity: Vec<DVec2> = balls.iter().map(|&(s, _, _)| v[s]).collect();
    let mut counts = RoundScratch::default();
    if !solve_simultaneous(&mut round, &mut velocity, &mut counts, 0.0) {
        return None;
    }
    tally.impulses += round.iter().filter(|c| c.impulse > 0.0).count() as u64;
    // Struck together only when approaching faster than the chain speed.
    tally.fast += tally.impulses;
    for ((&(s, f, mark), &u), &t) in balls.iter().zip(&velocity).zip(&tau) {
        x[s] += (u - v[s]) * t;
        v[s] = u;
        marks.fast_in[s] = marks.pass;
        marks.changed(mark as u32);
        if replayed > 0 {
            marks.replayed(f, s, t);
        }
    }
    for (s, mark, dx) in pushes {
        x[s] += dx;
        marks.changed(mark as u32);
    }
    Some(tally)
}

#[cfg(test)]
mod tests {
    use std::cell::Cell;

    use crate::engine::lockstep::Lockstep;
    use crate::scene::{Origin, Scene};
    use crate::scenes;

    thread_local! {
        /// Every look over every pair (the rule before the look after a pass was narrowed).
        pub(super) static FULL_LOOK: Cell<bool> = const { Cell::new(false) };
    }

    /// The positions and velocities of `scene` after `steps` steps on `threads` threads, with
    /// every look over every pair if `full`.
    fn run(scene: &Scene, steps: u64, threads: usize, full: bool) -> Vec<u64> {
        FULL_LOOK.set(full);
        let mut engine = Lockstep::new(scene);
        engine.set_threads(threads);
        engine.run(steps);
        FULL_LOOK.set(false);
        let b = engine.bodies();
        b.position.iter().chain(&b.velocity).flat_map(|p| [p.x.to_bits(), p.y.to_bits()]).collect()
    }

    /// The look after a pass tests only the pairs with a ball changed since the last pass and the
    /// pairs the last pass left unchanged while closing fast: every other pair is as it was at
    /// its visit, when it was not closing fast. So it finds the groups the look over every pair
    /// finds, and the runs are the same to the bit: elastic scenes with simultaneous impacts (a
    /// crowd started overlapping, a row struck from both ends at once, 100 kg and 1 kg balls
    /// falling into a pile at e = 1), serial and on the pool's threads. Seen to fail with the
    /// look after a pass taking only the changes of its own pass (the row differs) and with the
    /// balls of a round struck at once left unmarked (the pile differs). The pairs left unchanged
    /// while closing fast and the wall bounces' marks are never needed in these runs (a pair
    /// waiting for the next round has a ball struck in the same pass; a ball bounced off a wall
    /// was struck in the same pass): they keep the rule exact where a rounding parts the look's
    /// test from the pass's.
    #[test]
    fn the_narrowed_look_finds_what_the_look_over_every_pair_finds() {
        let row = Scene::from_toml_str(
            include_str!("../../../docs/review-scenes/t8_c_row_both_sides_1.0.toml"),
            &Origin("t8_c_row_both_sides_1.0.toml".into()),
        )
        .unwrap();
        let masses = Scene::from_toml_str(
            &include_str!("../../../docs/review-scenes/t4_masses_e0.3.toml")
                .replace("collisions = { restitution = 0.3 }", "collisions = { restitution = 1.0 }"),
            &Origin("t4_masses_e1.0.toml".into()),
        )
        .unwrap();
        let crowd = scenes::builtin("hard/crowd").unwrap().unwrap();
        for (name, scene, steps) in [("row", &row, 3_000), ("masses", &masses, 3_000), ("crowd", &crowd, 300)] {
            for threads in [1, 2] {
                assert!(
                    run(scene, steps, threads, false) == run(scene, steps, threads, true),
                    "{name} on {threads} threads: the narrowed look changed the run"
                );
            }
        }
    }
}
