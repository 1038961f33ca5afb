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
//! does not approach after the passes takes no impulse (impulses are ≥ 0). It runs serially over
//! whole arrays in index and pair-list order, so the bits are the same on any number of threads.

use super::elastic_contacts::ElasticWalls;
use crate::physics::{
    Bodies, Contact, Islands, MAX_RESTING_PASSES, NEVER, RestingIslands, TOUCH_MARGIN, Tolerances, WallImpulses,
    nearer_walls, pair_contact, resting_begin, resting_end, resting_pass, solve_resting_islands, wall_contact,
    wall_contact_rests,
};

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
    /// The contacts: the resting walls, then the pairs, in one list.
    lists: Vec<Vec<Contact>>,
    /// The slow wall contacts of the balls near a wall, and whether each is a resting one.
    walls: Vec<(Contact, bool)>,
    /// Touching pairs (ball indices) in the pair lists' order.
    touching: Vec<(u32, u32)>,
    /// Per ball: whether its island holds a ball resting on a wall.
    held: Vec<bool>,
    groups: Islands,
    islands: RestingIslands,
}

impl ElasticResting {
    /// The resting phase of one sub-step of length `h` over `b` (the elastic passes done):
    /// `near_walls` the balls near a wall (index order), `for_each_pair` the candidate pairs (ball
    /// indices, in a fixed order), `drift` the integrator's [`crate::physics::resting_drift`].
    #[allow(clippy::too_many_arguments)]
    pub fn solve(
        &mut self,
        b: &mut Bodies,
        near_walls: &[u32],
        for_each_pair: impl FnOnce(&mut dyn FnMut(usize, usize)),
        walls: &ElasticWalls<'_>,
        h: f64,
        drift: f64,
        tolerances: &Tolerances,
    ) -> RestingOutcome {
        let mut outcome = RestingOutcome { converged: true, ..Default::default() };
        self.lists.resize_with(1, Vec::new);
        let list = &mut self.lists[0];
        list.clear();
        let field = walls.field;
        let Bodies { id, inverse_mass, radius, position, velocity, .. } = b;
        // The walls balls rest on, and every other slow wall contact (a ball touching a side wall
        // of a stack, not pressed into it yet, carries the stack's sideways push once the
        // resting impulses come): the resting phase takes the latter only if its ball is held.
        let walls_rest = &mut self.walls;
        walls_rest.clear();
        let mut any = false;
        for &ball in near_walls {
            let i = ball as usize;
            let (x, v) = (position[i], velocity[i]);
            for wall in nearer_walls(x, field) {
                let acc = walls.acceleration(i);
                let c = wall_contact((i as u32, x, v, acc, inverse_mass[i], radius[i]), wall, field, h);
                let rests = wall_contact_rests(&c, x, v, acc, h, tolerances.impact);
                if rests || (c.tau != NEVER && v.dot(c.normal) - c.bias <= tolerances.impact) {
                    any |= rests;
                    walls_rest.push((c, rests));
                }
            }
        }
        if !any {
            return outcome;
        }
        // The balls touching a resting one, through any chain of touching balls.
        let n = position.len();
        let reach_gap = tolerances.reach_gap;
        self.touching.clear();
        let touching = &mut self.touching;
        for_each_pair(&mut |i, j| {
            let reach = radius[i] + radius[j];
            let within = reach + reach_gap + TOUCH_MARGIN * reach;
            if position[i].distance_squared(position[j]) <= within * within {
                touching.push((i as u32, j as u32));
            }
        });
        self.groups.reset(n);
        for &(i, j) in touching.iter() {
            self.groups.join(i, j);
        }
        self.held.clear();
        self.held.resize(n, false);
        for &(c, rests) in self.walls.iter() {
            if rests {
                let root = self.groups.find(c.a);
                self.held[root as usize] = true;
            }
        }
        for &(c, _) in self.walls.iter() {
            if self.held[self.groups.find(c.a) as usize] {
                list.push(c);
            }
        }
        let acceleration = |i: usize| walls.acceleration(i);
        for &(i, j) in touching.iter() {
            if !self.held[self.groups.find(i) as usize] {
                continue;
            }
            let body = |k: u32| {
                let k = k as usize;
                (k as u32, id[k], position[k], velocity[k], acceleration(k), inverse_mass[k], radius[k])
            };
            // A pair still approaching faster than an impact after the passes (their cap reached)
            // is theirs to strike in the next step, not the resting phase's to stop.
            let approach = (velocity[i as usize] - velocity[j as usize])
                .dot((position[j as usize] - position[i as usize]).normalize_or_zero());
            if approach > tolerances.impact {
                continue;
            }
            if let Some(c) = pair_contact(body(i), body(j), h, 1.0) {
                list.push(c);
            }
        }
        outcome.resting = resting_begin(list, position, velocity, 0, id, h, drift, reach_gap);
        let mut passes = 0;
        loop {
            let change = resting_pass(list, velocity, 0, passes % 2 == 1);
            passes += 1;
            if change <= tolerances.resting {
                break;
            }
            if passes == MAX_RESTING_PASSES {
                outcome.converged = false;
                outcome.islands_solved =
                    solve_resting_islands(&mut self.lists, velocity, n, tolerances.resting, &mut self.islands);
                break;
            }
        }
        resting_end(&self.lists[0], position, 0, h, drift, &mut outcome.walls);
        outcome
    }
}
