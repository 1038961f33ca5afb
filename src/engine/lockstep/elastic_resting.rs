//! The resting contacts of a perfectly elastic field (ball restitution 1): after the elastic
//! passes, the balls that rest on a wall and every ball that touches them, directly or through
//! other touching balls, get the inelastic solver's resting phase (`physics::resting_begin`,
//! `resting_pass`, `resting_end`, `solve_resting_islands`).
//!
//! Why: the elastic passes strike every approach with e = 1 and leave the walls to the finish
//! pass. A ball resting on the floor then meets it as an impact every step (the step's gravity,
//! g·h, taken for an approach) and bounces off by g·h, and a heavy ball on a light one on the
//! floor is held only by the light one rattling between them: 100 kg on 1 kg kept overlaps of
//! 3.4 % and a periodic 4.8 J, where e = 0.99 rests to 1e-14 m. A wall contact touching since
//! the start of the step and approaching at its instant slower than the impact threshold
//! (`physics::wall_contact_rests`) is the weight of what rests on it, not an impact. Its
//! resting impulse, like the contact solver's, stands for a steady force over the step: the
//! balls move as the integrator would have moved them under it, so a resting stack ends where it
//! started, at rest, and keeps its energy exactly — the step's gain of kinetic energy from
//! gravity and its loss of potential energy are both taken back. The floor's gauge takes the
//! weight.
//!
//! Nothing else changes: a contact approaching faster has had its elastic impulse in the passes
//! (the pairs) or gets its bounce in the finish pass (the walls), and a pair of the group that
//! does not approach after the passes takes no impulse (impulses are ≥ 0).
//!
//! Jammed balls join the phase too, for its position passes: a ball the passes pushed past a
//! wall (out of a pair whose other ball is much heavier), found by its gap at the start of the
//! step along its own path, and the balls of pairs the passes left overlapping beyond the slop
//! when they reached their cap. The passes push a pair apart by inverse mass and know no wall,
//! the finish pass puts a ball back on its wall and knows no pair: between them a light ball
//! under a heavy one on the floor stayed 2.6 % into it step after step, and after a landing
//! 40 %. The position passes take both, walls immovable, and the pairs within what a jammed
//! ball may be pushed. A ball that strikes a wall in the step is not jammed (it was inside the
//! field at the step's start): its bounce stays the finish pass's, replayed along its path, and
//! the elastic pile keeps its energy to rounding.
//!
//! Cost: only what rests is looked at. The resting balls are sought among those the last finish
//! pass left touching a wall (it lists them on its way), the balls that touch them along each
//! ball's candidate partners (indexed once per pair search), and the phase sorts its contacts
//! lowest first, as the contact solver's passes go. A field with nothing resting pays the finish
//! pass's list alone: the scale bench (10,000 falling balls, e = 1) took 144 µs a step before
//! and 148 µs after; looking at every ball near a wall each step instead cost 190 µs.
//!
//! It runs serially over whole arrays, in orders fixed by the state (index order, the pair
//! lists', heights with index ties), so the bits are the same on any number of threads.

use glam::DVec2;

use super::elastic_contacts::{ElasticContacts, ElasticWalls};
use crate::physics::{
    BallId, Bodies, BroadPhase, Contact, MAX_RESTING_PASSES, NEVER, RestingIslands, TOUCH_MARGIN, Tolerances, Wall,
    WallImpulses, islands_after_passes, iterate_position, iterate_resting, nearer_walls, pair_contact, position_pass,
    resting_begin, resting_end, resting_pass, solve_resting_islands, wall_contact, wall_contact_rests,
    wall_gap_at_start, wall_pass,
};

/// The position passes of the phase at most. A jam of a light ball between a heavy one and a wall
/// comes out by about a hundredth of the overlap a pass (the heavy ball takes a hundredth of a
/// pair's push) and the next step's passes close it again, so the passes go on from where the
/// last step left them. Measured on the hot e = 1 pile of 100 kg and 1 kg balls, worst overlap
/// every step from 10 to 12 s: with up to 1,000 passes (the contact solver's cap) 0.755 % of a
/// diameter and 620 passes a step on average; with 256, 0.755 % (0.53–1.02 % in half-second
/// samples from 2.5 to 20 s, 0.30 ms a step); with 64, 0.72 % in one build and 1.10 % in
/// another that only moved its chaos (0.36 ms a step); with 16, 1.3 %.
const ELASTIC_POSITION_PASSES: u32 = 256;

/// What one sub-step's resting phase did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RestingOutcome {
    /// Contacts (walls and pairs) touching in the phase.
    pub resting: u64,
    /// Islands solved directly after the passes reached their cap.
    pub islands_solved: u64,
    /// False when the passes reached their cap.
    pub converged: bool,
    /// The impulses the walls took.
    pub walls: WallImpulses,
}

/// Scratch of the resting phase, kept to reuse the memory.
#[derive(Clone, Debug, Default)]
pub struct ElasticResting {
    /// The contacts: the walls, then the pairs, in one list.
    lists: Vec<Vec<Contact>>,
    /// The wall contacts balls rest on.
    walls: Vec<Contact>,
    /// The balls the elastic passes left jammed: pushed past a wall, or in pairs left
    /// overlapping beyond the slop.
    jammed: Vec<u32>,
    /// Each ball's candidate partners (`next[start[i]..start[i + 1]]`), from the elastic pair
    /// lists of generation `built` (rebuilt when the lists are: every few dozen steps).
    start: Vec<u32>,
    next: Vec<u32>,
    built: Option<u64>,
    /// The search's marks, by phase number (`phase`): a ball reached, a ball whose touching
    /// partners are listed.
    phase: u64,
    reached: Vec<u64>,
    done: Vec<u64>,
    queue: Vec<u32>,
    islands: RestingIslands,
}

impl ElasticResting {
    /// The resting phase of one sub-step of length `h` over `b` (the elastic passes done):
    /// `touching` the balls the last finish pass left touching a wall (index order; `None`:
    /// not known, look at every ball), `pairs` the candidate pairs, `overlaps_left` whether the
    /// passes stopped with pairs still overlapping, `drift` the integrator's
    /// [`crate::physics::resting_drift`].
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        b: &mut Bodies,
        touching: Option<&[u32]>,
        pairs: &ElasticContacts,
        overlaps_left: bool,
        grid: &BroadPhase,
        walls: &ElasticWalls<'_>,
        h: f64,
        drift: f64,
        tolerances: &Tolerances,
    ) -> RestingOutcome {
        let mut outcome = RestingOutcome { converged: true, ..Default::default() };
        self.lists.resize_with(1, Vec::new);
        let field = walls.field;
        let Bodies { id, inverse_mass, radius, position, velocity, .. } = b;
        // The walls balls rest on: among the balls the last finish pass left touching a wall
        // (`touching`; every ball when that is not known), those whose wall contact rests.
        self.walls.clear();
        self.jammed.clear();
        // The farthest the position phase may push a jammed ball: its pairs within that of
        // touching take part in the phase.
        let mut depth = 0.0f64;
        let n = position.len();
        let all: Vec<u32>;
        let candidates = match touching {
            Some(list) => list,
            None => {
                all = (0..n as u32).collect();
                &all
            }
        };
        for &ball in candidates {
            let i = ball as usize;
            let (x, v) = (position[i], velocity[i]);
            for wall in nearer_walls(x, field) {
                let acc = walls.acceleration(i);
                let c = wall_contact((i as u32, x, v, acc, inverse_mass[i], radius[i]), wall, field, h);
                if wall_contact_rests(&c, x, v, acc, h, tolerances.impact) {
                    self.walls.push(c);
                } else if c.tau != NEVER && pushed_past(&c, x, v, acc, h, tolerances) {
                    // Past the wall beyond the slop even at the start of the step along its
                    // path: the passes pushed it there, out of a pair (a light ball between a
                    // heavy one and the wall takes nearly all of the pair's push). The finish
                    // pass would bounce it back into that ball, which the next passes push out
                    // again: in the e = 1 pile of 100 kg and 1 kg balls a light ball on the floor
                    // stayed 2.6 % into a heavy one step after step, and after a landing one
                    // 40 %. A ball that strikes the wall in the step was inside the field at its
                    // start: its bounce, replayed along its path, is the finish pass's and keeps
                    // the energy (the elastic pile meets no jammed ball in a minute).
                    self.jammed.push(ball);
                    depth = depth.max(x.dot(c.normal) + c.reach - c.plane);
                }
            }
        }
        // And the balls of pairs left overlapping beyond the slop when the passes reached their
        // cap (a light ball squeezed between heavy ones, away from a wall): found only then, in
        // a look over the candidate pairs.
        if overlaps_left {
            let jammed = &mut self.jammed;
            let slop = tolerances.slop;
            pairs.for_each_pair(grid, &mut |i, j| {
                let reach = radius[i] + radius[j];
                let allowed = reach - slop * 2.0 * radius[i].min(radius[j]);
                let dd = position[i].distance_squared(position[j]);
                if dd < allowed * allowed {
                    jammed.push(i as u32);
                    jammed.push(j as u32);
                    depth = depth.max(reach - dd.sqrt());
                }
            });
        }
        if self.walls.is_empty() && self.jammed.is_empty() {
            return outcome;
        }
        if self.built != Some(pairs.generation()) || self.start.len() != n + 1 {
            self.index_partners(pairs, grid, n);
        }
        // From the resting balls, through touching balls, breadth first: each touching pair
        // listed once, when the first of its balls is taken from the queue.
        self.phase += 1;
        let phase = self.phase;
        self.reached.resize(n, 0);
        self.done.resize(n, 0);
        self.queue.clear();
        for ball in self.walls.iter().map(|c| c.a).chain(self.jammed.iter().copied()) {
            if self.reached[ball as usize] != phase {
                self.reached[ball as usize] = phase;
                self.queue.push(ball);
            }
        }
        let list = &mut self.lists[0];
        list.clear();
        let reach_gap = tolerances.reach_gap;
        let body =
            |k: usize| (k as u32, id[k], position[k], velocity[k], walls.acceleration(k), inverse_mass[k], radius[k]);
        let mut head = 0;
        while head < self.queue.len() {
            let i = self.queue[head] as usize;
            head += 1;
            self.done[i] = phase;
            for &j in &self.next[self.start[i] as usize..self.start[i + 1] as usize] {
                let j = j as usize;
                if self.done[j] == phase {
                    continue;
                }
                let reach = radius[i] + radius[j];
                let within = reach + reach_gap + TOUCH_MARGIN * reach + depth;
                if position[i].distance_squared(position[j]) > within * within {
                    continue;
                }
                if self.reached[j] != phase {
                    self.reached[j] = phase;
                    self.queue.push(j as u32);
                }
                let approach = (velocity[i] - velocity[j]).dot((position[j] - position[i]).normalize_or_zero());
                match pair_contact(body(i), body(j), h, 1.0) {
                    // A pair still approaching faster than an impact after the passes (their cap
                    // reached) is theirs to strike in the next step, not the resting phase's to
                    // stop: it takes part in the position phase alone.
                    Some(c) => list.push(Contact { key: u32::from(approach > tolerances.impact), ..c }),
                    // Apart, but within what a jammed ball may be pushed: the position phase's.
                    None if depth > 0.0 => list.push(apart_contact(body(i), body(j))),
                    None => {}
                }
            }
        }
        // The walls of the balls reached, first (a pass then carries the walls' support up at
        // once): those they rest on, and every other wall contact of theirs that touches and is
        // slow (a ball at a side wall of a stack, not pressed into it yet, carries the stack's
        // sideways push once the resting impulses come); one a ball strikes is the finish
        // pass's.
        let pairs_listed = list.len();
        // Lowest first, as the contact solver sweeps its resting contacts: a pass then carries
        // the support up the pile at once. (In the order the search met them, a 76-ball stack at
        // e = 1 kept 3e-2 J and its floor carried 0.9997 of the weight; lowest first, 1e-4 J and
        // 1 - 2e-6: what the passes leave off their target, the elastic passes strike at e = 1.)
        let up = -walls.gravity.normalize_or(DVec2::NEG_Y);
        list.sort_by(|p, q| {
            let height = |c: &Contact| position[c.a as usize].dot(up).min(position[c.b as usize].dot(up));
            height(p).total_cmp(&height(q)).then((p.a, p.b).cmp(&(q.a, q.b)))
        });
        for &ball in &self.queue {
            let i = ball as usize;
            let (x, v) = (position[i], velocity[i]);
            for wall in nearer_walls(x, field) {
                let acc = walls.acceleration(i);
                let c = wall_contact((ball, x, v, acc, inverse_mass[i], radius[i]), wall, field, h);
                if c.tau == NEVER {
                    continue;
                }
                if v.dot(c.normal) - c.bias <= tolerances.impact {
                    list.push(c);
                } else if pushed_past(&c, x, v, acc, h, tolerances) {
                    // Past the wall since the start of the step (pushed there) and moving into
                    // it: a wall for the position phase alone; its bounce stays the finish
                    // pass's.
                    list.push(Contact { key: 1, ..c });
                }
            }
        }
        let walls_listed = list.len() - pairs_listed;
        list.rotate_right(walls_listed);
        outcome.resting = resting_begin(list, position, velocity, 0, id, h, drift, reach_gap);
        for c in list.iter_mut().filter(|c| c.key == 1) {
            c.active = false;
            c.impulse = 0.0;
        }
        let (_, converged) = iterate_resting(MAX_RESTING_PASSES, tolerances.resting, |backward| {
            resting_pass(list, velocity, 0, backward)
        });
        outcome.converged = converged;
        let t = tolerances;
        if let Some(tolerance) = islands_after_passes(converged, outcome.resting, t.weighed, t.resting) {
            outcome.islands_solved = solve_resting_islands(&mut self.lists, velocity, n, tolerance, &mut self.islands);
        }
        resting_end(&self.lists[0], position, 0, h, drift, &mut outcome.walls);
        // The contact solver's position phase over the same contacts, walls immovable: overlaps
        // beyond the slop pushed apart, no velocity changed. (Without it, a light ball
        // rattling in a pocket between heavy balls resting on the floor and a side wall was
        // pressed into them: the e = 1 pile of 100 kg and 1 kg balls kept overlaps of 25 % at
        // 13-20 s; with it, 2.5 %.)
        let list = &self.lists[0];
        iterate_position(ELASTIC_POSITION_PASSES, tolerances.overlap + tolerances.slop, || {
            position_pass(list, position, 0, id, tolerances.slop)
        });
        wall_pass(list, position, 0);
        outcome
    }

    /// Lists each ball's candidate partners from the elastic pair lists (in their order).
    fn index_partners(&mut self, pairs: &ElasticContacts, grid: &BroadPhase, n: usize) {
        self.start.clear();
        self.start.resize(n + 2, 0);
        pairs.for_each_pair(grid, &mut |i, j| {
            self.start[i + 2] += 1;
            self.start[j + 2] += 1;
        });
        for k in 2..n + 2 {
            self.start[k] += self.start[k - 1];
        }
        self.next.resize(self.start[n + 1] as usize, 0);
        let (start, next) = (&mut self.start, &mut self.next);
        pairs.for_each_pair(grid, &mut |i, j| {
            next[start[i + 1] as usize] = j as u32;
            start[i + 1] += 1;
            next[start[j + 1] as usize] = i as u32;
            start[j + 1] += 1;
        });
        self.start.truncate(n + 1);
        self.built = Some(pairs.generation());
    }
}

/// Whether a wall contact's ball is past its wall beyond the slop even at the start of the step
/// along its own path: the passes pushed it there (see the module comment).
fn pushed_past(c: &Contact, x: DVec2, v: DVec2, acc: DVec2, h: f64, tolerances: &Tolerances) -> bool {
    wall_gap_at_start(c, x, v, acc, h) < -tolerances.slop * c.size
}

/// A pair apart (not touching over the step), for the position phase alone.
fn apart_contact(
    (a, _, xa, _, _, wa, ra): (u32, BallId, DVec2, DVec2, DVec2, f64, f64),
    (b, _, xb, _, _, wb, rb): (u32, BallId, DVec2, DVec2, DVec2, f64, f64),
) -> Contact {
    Contact {
        a,
        b,
        normal: (xb - xa).normalize_or(DVec2::X),
        reach: ra + rb,
        size: 2.0 * ra.min(rb),
        plane: 0.0,
        tau: NEVER,
        persistent: false,
        bias: 0.0,
        inverse_mass_a: wa,
        inverse_mass_b: wb,
        restitution: 1.0,
        impulse: 0.0,
        target: 0.0,
        impact: 0.0,
        active: false,
        wall: Wall::Left,
        key: 1,
    }
}
