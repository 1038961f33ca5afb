//! The lockstep engine: every ball advances together with a fixed dt in one loop.
//!
//! Bit-reproducible: the same scene gives the same bits on every run, because every loop runs in
//! index order and nothing depends on time or threads. It is the reference engine for tests,
//! benches, replays and the accuracy report. A step is a short list of named phases, each timed
//! into [`StepCounters`] (Box2D's `b2Profile`, Rapier's `Counters`):
//!
//! 1. **integrate** — the force passes of the enabled effects, inside the chosen integrator;
//! 2. **broad phase** — the grid finds the touching pairs (only with collisions on);
//! 3. **contacts** — the contact solver (`crate::physics::ContactSolver`'s phases, band by band):
//!    impacts with restitution from the instant of contact, resting contacts carrying the weight,
//!    overlaps pushed apart; walls are contacts in it (only with collisions on). A perfectly
//!    elastic field (balls and walls of restitution 1) goes through sequential elastic impulses
//!    instead (`elastic_contacts`), which keep its energy to rounding however dense it is;
//! 4. **walls** — without collisions or with elastic ones, reflect and sum the wall impulses here
//!    (with the contact solver, this only catches a ball that some push left past a wall).
//!
//! **Threads.** With [`Lockstep::set_threads`] > 1 (the default is every core) and at least
//! [`PARALLEL_MIN_BALLS`] balls, the phases share the work out over a thread pool: integration
//! and walls by fixed chunks of [`CHUNK`] balls (each ball's update reads only that ball, unless
//! attraction couples them), the pair search and the contact solver by bands of the grid (see
//! `contact_solver`). How the work is cut depends only on the state, never on the number of
//! threads, and every sum is taken in the same order, so the bits are the same for any number of
//! threads (a test runs 1, 2 and 4).

mod contact_solver;
mod elastic_contacts;
mod elastic_resting;

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec2;
use serde::Serialize;

use rayon::prelude::*;

use crate::engine::EngineError;
use crate::physics::{
    Ball, BallId, BallKind, Bodies, BodyProps, BroadPhase, Diagnostics, Drag, Effects, Field, Forces, Integrator,
    IntegratorScratch, PointForce, SpanRates, StepPolicy, TOUCH_MARGIN, Tolerances, WallImpulses, cap_speed,
    contact_ball_wall, drag_rate, drag_rate_bound, integrate, keeps_energy, measure, near_a_wall, resting_drift,
};
#[cfg(doc)]
use crate::physics::{MAX_SPEED, MAX_TRAVEL};
use crate::scene::Scene;
pub use contact_solver::PARALLEL_MIN_PAIRS;
use contact_solver::{ContactSolver, Inputs};
use elastic_contacts::{ElasticContacts, ElasticWalls};
use elastic_resting::ElasticResting;

/// Passes of the elastic contacts over the touching pairs in each (sub-)step.
const ELASTIC_PASSES: usize = 4;
/// Fewest balls for which the phases are shared out over threads (below it, one thread is faster
/// than the hand-over).
pub const PARALLEL_MIN_BALLS: usize = 4096;
/// The broad phase's skin, as a fraction of the median diameter: the pairs it finds stay a
/// complete list of the touching ones until a ball has moved half of it, so the grid is rebuilt
/// only then (a Verlet list; at 3 m/s, 2 m balls and dt = 1 ms, every ~30 steps).
pub const SKIN: f64 = 0.1;
/// Balls per chunk when integration and walls are shared out (fixed: see the module comment).
pub const CHUNK: usize = 2048;

/// Time spent in each phase, summed over steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StepCounters {
    /// Whole steps taken.
    pub steps: u64,
    /// Sub-steps taken (equal to `steps` when no ball was fast; see [`MAX_TRAVEL`]).
    pub substeps: u64,
    #[serde(serialize_with = "secs")]
    /// Time in the integrate pass.
    pub integrate: Duration,
    #[serde(serialize_with = "secs")]
    /// Time in the broad phase (finding candidate pairs).
    pub broad_phase: Duration,
    #[serde(serialize_with = "secs")]
    /// Time in the contact solver.
    pub contacts: Duration,
    #[serde(serialize_with = "secs")]
    /// Time in the finish pass (speed caps, walls, the split's speeds).
    pub walls: Duration,
    /// Candidate pairs the contact solver checked: every touching pair, and those within the
    /// broad phase's skin of touching (see [`SKIN`]).
    pub touching_pairs: u64,
    /// Times the broad phase searched afresh (the rest of the sub-steps reused its pairs).
    pub grid_builds: u64,
    /// Ball–ball impacts (pairs struck with restitution).
    pub impulses: u64,
    /// Ball–wall contacts.
    pub wall_contacts: u64,
    /// Contacts (pairs and walls) still touching after the impacts, summed over sub-steps: the
    /// resting contacts that carry a pile's weight.
    pub resting: u64,
    /// Sub-steps in which a phase of the contact solver reached its iteration cap (the state
    /// stays valid, the contacts only less exactly solved; 0 in the shipped scenes' runs).
    pub unconverged: u64,
    /// Times a ball's speed was capped at [`MAX_SPEED`] (0 in every sane field).
    pub speed_limited: u64,
    /// Wall bounces of the finish pass (see [`Lockstep::finish_phase`]): with collisions on, balls
    /// the contact solver left past a wall (0 while it holds every ball it moves); without, every
    /// wall bounce. Also counted in `wall_contacts`.
    pub finish_bounces: u64,
    /// Islands of resting contacts solved directly after the resting passes reached their cap
    /// (see `physics::solve_resting_islands`).
    pub islands_solved: u64,
    /// Candidate pairs added mid-step for balls an impact sent beyond the broad phase's skin (see
    /// `lockstep::contact_solver::ContactSolver`, and the elastic passes' `reach_struck`): light
    /// balls struck by heavy ones in a landing.
    pub pairs_reached: u64,
    /// Contacts listed for pairs the position passes pushed together (see
    /// [`crate::physics::pushed_together`]).
    pub pushed_together: u64,
    /// Sub-steps whose drag was too stiff even for the shortest sub-step, so the drag pass capped
    /// its rate at 1/h (see [`Forces::set_drag_rate_limit`]; 0 in every sane field).
    pub drag_limited: u64,
}

fn secs<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

impl StepCounters {
    /// Time in all four phases.
    pub fn total(&self) -> Duration {
        self.integrate + self.broad_phase + self.contacts + self.walls
    }
}

/// The lockstep engine. Holds the state and only scratch memory besides.
#[derive(Clone, Debug)]
pub struct Lockstep {
    field: Field,
    effects: Effects,
    forces: Forces,
    integrator: Integrator,
    dt: f64,
    max_balls: usize,
    bodies: Bodies,
    pull: DVec2,
    next_id: u32,
    time: f64,
    steps: u64,
    wall_impulses: WallImpulses,
    counters: StepCounters,
    /// One integrator scratch per chunk of [`CHUNK`] balls.
    scratch: Vec<IntegratorScratch>,
    broad_phase: BroadPhase,
    contacts: ContactSolver,
    /// The contacts of a perfectly elastic field (see [`Lockstep::elastic`]).
    elastic: ElasticContacts,
    /// The resting contacts of a perfectly elastic field (see [`ElasticResting`]).
    elastic_resting: ElasticResting,
    /// Whether the pairs were last found for `elastic` (else for `contacts`).
    pairs_elastic: bool,
    /// The balls near a wall this sub-step (see [`Lockstep::integrate_phase`]).
    near_walls: Vec<u32>,
    /// The balls the last finish pass left touching a wall (perfectly elastic fields only), and
    /// whether that list holds for the balls there are now (not after a ball came or went).
    on_walls: Vec<u32>,
    on_walls_known: bool,
    /// Positions at the last grid build, and whether the pairs must be found afresh regardless
    /// (balls added or removed, collisions turned on).
    built_positions: Vec<DVec2>,
    grid_stale: bool,
    adaptive_substeps: bool,
    /// The speeds the next sub-step's split is judged by, as the last finishing pass left them;
    /// `None` when they must be measured afresh (first step, balls or effects changed).
    split_speeds: Option<SplitSpeeds>,
    /// The balls' largest quadratic drag rate at 1 m/s (`largest_drag_c`): fixed while the balls
    /// and effects are; `None` when it must be found afresh.
    drag_c: Option<f64>,
    /// The chunks' tallies of the last chunked pass (kept to reuse the memory).
    tallies: Vec<ChunkTally>,
    threads: usize,
    /// Built on first need (a field of at least [`PARALLEL_MIN_BALLS`] with `threads` > 1), shared
    /// by clones.
    pool: Option<Arc<rayon::ThreadPool>>,
}

impl Lockstep {
    /// An engine for the scene, as it is at its start.
    pub fn new(scene: &Scene) -> Self {
        Self::from_parts(scene.field, scene.effects, scene.integrator, scene.dt, scene.max_balls, &scene.balls)
    }

    /// An engine from its parts: the balls are taken as given (ids kept; new balls get ids past the largest).
    /// `max_balls` caps [`Lockstep::add_ball`].
    pub fn from_parts(
        field: Field,
        effects: Effects,
        integrator: Integrator,
        dt: f64,
        max_balls: usize,
        balls: &[Ball],
    ) -> Self {
        let next_id = balls.iter().map(|b| b.id.0 + 1).max().unwrap_or(0);
        Lockstep {
            field,
            effects,
            forces: Forces::new(&effects),
            integrator,
            dt,
            max_balls: max_balls.max(balls.len()),
            bodies: Bodies::from_balls(balls),
            pull: DVec2::ZERO,
            next_id,
            time: 0.0,
            steps: 0,
            wall_impulses: WallImpulses::default(),
            counters: StepCounters::default(),
            scratch: Vec::new(),
            broad_phase: {
                // Pairs the solver left exactly touching still carry a pile's weight.
                let mut grid = BroadPhase::new();
                grid.set_margin(TOUCH_MARGIN);
                grid.set_skin(SKIN);
                grid
            },
            built_positions: Vec::new(),
            grid_stale: true,
            contacts: ContactSolver::default(),
            elastic: ElasticContacts::default(),
            elastic_resting: ElasticResting::default(),
            pairs_elastic: false,
            near_walls: Vec::new(),
            on_walls: Vec::new(),
            on_walls_known: false,
            adaptive_substeps: true,
            split_speeds: None,
            drag_c: None,
            tallies: Vec::new(),
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            pool: None,
        }
    }

    /// The balls, in the engine's order.
    pub fn bodies(&self) -> &Bodies {
        &self.bodies
    }
    /// The field (size, walls' restitution).
    pub fn field(&self) -> &Field {
        &self.field
    }
    /// The effects on.
    pub fn effects(&self) -> &Effects {
        &self.effects
    }
    /// The integrator.
    pub fn integrator(&self) -> Integrator {
        self.integrator
    }
    /// The step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// What the phases took and counted, summed over steps.
    pub fn counters(&self) -> &StepCounters {
        &self.counters
    }
    /// The impulse each wall has given, N·s, summed since the start.
    pub fn wall_impulses(&self) -> WallImpulses {
        self.wall_impulses
    }
    /// The pull on the key ball, N.
    pub fn pull(&self) -> DVec2 {
        self.pull
    }
    /// The most balls the engine takes.
    pub fn max_balls(&self) -> usize {
        self.max_balls
    }

    /// Names of the effects that run each step (walls always do); attraction says how it is
    /// summed for the balls there are now: `attraction (direct)` or `attraction (tree)`.
    pub fn active_effects(&self) -> Vec<&'static str> {
        let mut names = self.effects.active_names();
        if let Some(method) = self.forces.attraction_method(self.bodies.len()) {
            names.iter_mut().filter(|n| **n == "attraction").for_each(|n| *n = method.label());
        }
        names
    }

    /// Turns effects on or off; the per-step work is rebuilt from them.
    pub fn set_effects(&mut self, effects: Effects) {
        self.effects = effects;
        self.forces = Forces::new(&effects);
        self.forget_derived();
    }

    /// Forgets what was derived from the balls and effects as they were (the pair list, the speeds
    /// and drag constants the split is judged by, the orbit rate met): balls were added or
    /// removed, or the effects changed.
    fn forget_derived(&mut self) {
        self.grid_stale = true;
        self.on_walls_known = false;
        self.split_speeds = None;
        self.drag_c = None;
        self.forces.forget_orbit_rate();
    }

    /// Turns the automatic step splitting (fast balls, stiff drag, fast orbits; see
    /// [`StepPolicy`]) on or off. On by default; the accuracy report turns it off to measure
    /// each integrator at exactly the step it was given.
    pub fn set_adaptive_substeps(&mut self, on: bool) {
        self.adaptive_substeps = on;
    }

    /// Threads the phases may use (at least 1; the default is every core). Changes no bit of
    /// the result (see the module comment).
    pub fn set_threads(&mut self, threads: usize) {
        let threads = threads.max(1);
        if threads != self.threads {
            self.threads = threads;
            self.pool = None;
        }
    }

    /// Threads the phases share out over (1: serial).
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Whether this field is big enough to share the phases out, building the pool on first need.
    /// Depends on the ball count only, never on `threads`: the work is cut the same way either way.
    fn parallel(&mut self) -> Option<Arc<rayon::ThreadPool>> {
        if self.bodies.len() < PARALLEL_MIN_BALLS || self.threads == 1 {
            return None;
        }
        if self.pool.is_none() {
            let built = rayon::ThreadPoolBuilder::new()
                .num_threads(self.threads)
                .thread_name(|k| format!("lockstep-{k}"))
                .build();
            match built {
                Ok(pool) => self.pool = Some(Arc::new(pool)),
                Err(e) => {
                    log::warn!("lockstep: no thread pool ({e}); running on one thread");
                    self.threads = 1;
                }
            }
        }
        self.pool.clone()
    }

    /// Sets the integrator (the next step uses it).
    pub fn set_integrator(&mut self, integrator: Integrator) {
        self.integrator = integrator;
    }

    /// Sets the step, s (the caller checks it is finite and positive).
    pub fn set_dt(&mut self, dt: f64) {
        self.dt = dt;
    }

    /// Sets the pull on the key ball (N). Ignored when there is no key ball.
    pub fn set_pull(&mut self, force: DVec2) {
        self.pull = force;
    }

    /// Sets the walls' restitution (the caller keeps it in [0, 1]; see `engine::clamp_restitution`).
    pub fn set_field_restitution(&mut self, restitution: f64) {
        self.field.restitution = restitution;
    }

    /// Adds a ball, giving it a fresh id (its `id` field is ignored).
    pub fn add_ball(&mut self, mut ball: Ball) -> Result<BallId, EngineError> {
        ball.id = BallId(self.next_id);
        self.insert(ball)
    }

    /// Puts a ball back with its own id (one taken off with [`Lockstep::remove_ball`]); refused if
    /// a ball with that id is on the field.
    pub fn put_back(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        if self.bodies.index_of(ball.id).is_some() {
            return Err(EngineError::IdInUse(ball.id));
        }
        self.insert(ball)
    }

    fn insert(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        if self.bodies.len() >= self.max_balls {
            return Err(EngineError::TooManyBalls { limit: self.max_balls });
        }
        if !(ball.is_finite() && ball.mass > 0.0 && ball.diameter > 0.0) {
            return Err(EngineError::InvalidBall(format!("{ball:?}")));
        }
        self.next_id = self.next_id.max(ball.id.0 + 1);
        self.bodies.push(ball);
        self.forget_derived();
        Ok(ball.id)
    }

    /// Removes ball `id` and returns it, or [`EngineError::NoSuchBall`].
    pub fn remove_ball(&mut self, id: BallId) -> Result<Ball, EngineError> {
        let index = self.bodies.index_of(id).ok_or(EngineError::NoSuchBall(id))?;
        self.forget_derived();
        Ok(self.bodies.remove(index))
    }

    /// Sets ball `id`'s velocity in place (it keeps its id and its place in the order).
    pub fn set_velocity(&mut self, id: BallId, velocity: DVec2) -> Result<(), EngineError> {
        let index = self.bodies.index_of(id).ok_or(EngineError::NoSuchBall(id))?;
        if !velocity.is_finite() {
            return Err(EngineError::InvalidVelocity(velocity.x, velocity.y));
        }
        self.bodies.velocity[index] = velocity;
        // The speeds the next split is judged by are no longer those of the last sub-step.
        self.split_speeds = None;
        Ok(())
    }

    /// Sets ball `id`'s mass in place (it keeps its id, place, position and velocity).
    pub fn set_mass(&mut self, id: BallId, mass: f64) -> Result<(), EngineError> {
        let index = self.bodies.index_of(id).ok_or(EngineError::NoSuchBall(id))?;
        if !(mass.is_finite() && mass > 0.0) {
            return Err(EngineError::InvalidMass(mass));
        }
        self.bodies.mass[index] = mass;
        self.bodies.inverse_mass[index] = 1.0 / mass;
        // Drag rates and orbit rates depend on the mass.
        self.forget_derived();
        Ok(())
    }

    /// Removes the most recently added ball that is not the key ball.
    pub fn remove_last(&mut self) -> Option<Ball> {
        let index = (0..self.bodies.len()).rev().find(|&i| self.bodies.kind[i] != BallKind::Key)?;
        self.forget_derived();
        Some(self.bodies.remove(index))
    }

    /// Advances `n` steps.
    pub fn run(&mut self, n: u64) {
        // The whole run inside the pool: this thread becomes one of its workers, so the phases'
        // hand-overs are between running workers, not a sleep and a wake-up of this thread per
        // phase (tens of microseconds each on a virtual machine).
        match self.parallel() {
            Some(pool) => pool.install(|| (0..n).for_each(|_| self.step_here())),
            None => (0..n).for_each(|_| self.step_here()),
        }
    }

    /// Advances one step of `dt`.
    pub fn step(&mut self) {
        self.run(1);
    }

    fn step_here(&mut self) {
        // The step is split into sub-steps by the step policy (`StepPolicy`: fast balls with
        // collisions on, stiff drag, fast orbits; its floor and drag guard rail), re-judged before
        // every sub-step over the time left: a collision in the middle of a step can make a ball
        // fast, or drag on a light ball stiff, at once. Ordinary fields pay one pass over the
        // speeds, and that pass is the last sub-step's finishing pass.
        let policy = StepPolicy::new(self.dt);
        let mut remaining = self.dt;
        let mut taken = 0u32;
        while remaining > 0.0 {
            let rates = if self.adaptive_substeps { self.split_rates() } else { SpanRates::default() };
            // With one sub-step, `h` is exactly what is left, so `remaining` becomes exactly zero.
            let sub = policy.split(remaining, &rates);
            self.forces.set_drag_rate_limit(sub.drag_rate_limit);
            self.counters.drag_limited += sub.drag_limited() as u64;
            self.substep(sub.h);
            remaining -= sub.h;
            taken += 1;
        }
        self.counters.substeps += taken as u64;
        self.steps += 1;
        self.counters.steps += 1;
        // Summed, not steps·dt, so that changing dt mid-run does not rewrite the past.
        self.time += self.dt;
    }

    /// The rates the step policy splits the next sub-step by (see [`SpanRates`]): with collisions
    /// on, the fastest travel in radii per second; with drag on, the stiffest drag, now or at the
    /// terminal speed gravity, the pull or attraction drive a ball to; with attraction on, the
    /// fastest pair orbit.
    ///
    /// The speeds are those the last sub-step's finishing pass measured as it went (see
    /// [`Lockstep::finish_phase`]): the same numbers a pass over the balls now would give, as
    /// nothing has moved since. Only when there are none (the first step, balls added or removed,
    /// effects changed) are they measured here.
    fn split_rates(&mut self) -> SpanRates {
        let b = &self.bodies;
        let speeds = match self.split_speeds {
            Some(speeds) => speeds,
            None => {
                let (collisions, drag) = (self.effects.collisions.is_some(), self.effects.drag.as_ref());
                SplitSpeeds::measure(collisions, drag, &b.velocity, &b.radius, &b.diameter, &b.mass)
            }
        };
        let mut rates = SpanRates::default();
        if self.effects.collisions.is_some() {
            rates.travel = speeds.travel2.sqrt();
        }
        if let Some(drag) = &self.effects.drag {
            // The rate now, and the rate at the terminal speed gravity drives each ball to (see
            // `drag_rate_bound`; the largest is that of the ball with the largest `c`), and the
            // key ball's under gravity and the pull.
            let gravity = self.effects.gravity.map_or(DVec2::ZERO, |g| g.g);
            let c = *self.drag_c.get_or_insert_with(|| largest_drag_c(drag, &b.diameter, &b.mass));
            rates.drag = speeds.drag_rate.max((gravity.length() * c).sqrt());
            if let Some(k) = b.key_index().filter(|_| self.pull != DVec2::ZERO) {
                let a = gravity + self.pull * b.inverse_mass[k];
                rates.drag = rates.drag.max(drag_rate_bound(b.velocity[k], a, b.diameter[k], b.mass[k], drag));
            }
        }
        if self.effects.attraction.is_some() {
            // The attraction pass measures the fastest orbit rate while it sums the forces
            // (exactly for the pairs it sums exactly, from a far group's whole mass for the tree),
            // so this costs nothing: the rate is that of the last sub-step's force evaluations, a
            // sub-step old. That is close enough: at ω·h ≤ MAX_ORBIT_STEP a pair falling together
            // at up to its escape speed (√2·ω·r) closes by at most 30 % of its distance in one
            // sub-step, and the next sub-step is judged by the new rate. Only when there were none
            // (the first step, or balls added or removed since) is it measured now, by one
            // evaluation.
            // With quadratic drag on, the same evaluations also tell how hard attraction drives each
            // ball into its drag: the drag rate at the terminal speed it would reach (see
            // `Forces::take_terminal_drag_rate`), so a light ball pulled hard is not given a step
            // in which its drag turns stiff.
            let (worst, terminal) = match (self.forces.take_orbit_rate_squared(), self.forces.take_terminal_drag_rate())
            {
                (Some(w), terminal) => (w, terminal.unwrap_or(0.0)),
                (None, _) => {
                    let props = BodyProps { mass: &b.mass, inverse_mass: &b.inverse_mass, diameter: &b.diameter };
                    self.forces.attraction_rates(props, &b.position)
                }
            };
            rates.orbit = worst.sqrt();
            rates.drag = rates.drag.max(terminal);
        }
        rates
    }

    /// One sub-step: three passes over the balls, however many effects are on —
    ///
    /// 1. **integrate** (chunked, see [`Lockstep::integrate_phase`]): the forces and the
    ///    integrator, how far the balls have moved since the pairs were last found, and which
    ///    balls are near a wall;
    /// 2. **broad phase** and **contacts**, when collisions are on: the contact solver, walls
    ///    included, on the state the free motion left;
    /// 3. **finish** (chunked, see [`Lockstep::finish_phase`], timed as `walls`): speeds capped at
    ///    [`MAX_SPEED`], the walls for a ball past one (all of them without collisions), and the
    ///    speeds the next sub-step's split is judged by.
    ///
    /// Each ball sees the very same arithmetic, in the same order, as in separate passes; fusing
    /// them only saves reading the balls again and, on several threads, the hand-overs between
    /// passes.
    fn substep(&mut self, h: f64) {
        let pool = self.parallel();
        let pool = pool.as_deref();
        let t0 = Instant::now();
        let moved2 = self.integrate_phase(h, pool);
        let t1 = Instant::now();
        self.counters.integrate += t1 - t0;
        if let Some(collisions) = self.effects.collisions {
            self.broad_phase_phase(moved2, pool);
            let t2 = Instant::now();
            self.counters.broad_phase += t2 - t1;
            let Uniform { gravity, key, key_acceleration, largest } = self.uniform();
            if self.elastic() {
                let (bodies, grid, elastic) = (&mut self.bodies, &self.broad_phase, &mut self.elastic);
                // Impacts struck at once are solved together above the settling ramp's top
                // (`physics::settling`: full restitution from 40 impact thresholds, 20·g·h); a
                // resting pile's contacts, approaching at about g·h, go one by one.
                let together = 20.0 * gravity.length() * h;
                let walls = ElasticWalls { field: &self.field, gravity, key, key_acceleration };
                let outcome = in_pool(pool, || {
                    elastic.solve(
                        bodies,
                        grid,
                        &walls,
                        collisions.restitution,
                        h,
                        together,
                        ELASTIC_PASSES,
                        pool.is_some(),
                    )
                });
                self.counters.impulses += outcome.impulses;
                self.counters.pairs_reached += outcome.pairs_reached;
                self.counters.wall_contacts += outcome.wall_bounces;
                self.wall_impulses.add_all(&outcome.walls);
                let resting = self.elastic_resting.solve(
                    bodies,
                    self.on_walls_known.then_some(&self.on_walls[..]),
                    elastic,
                    outcome.overlaps_left,
                    grid,
                    &walls,
                    h,
                    resting_drift(self.integrator, 1),
                    &Tolerances::new(largest, h, true),
                );
                self.counters.resting += resting.resting;
                self.counters.unconverged += u64::from(!resting.converged);
                self.counters.islands_solved += resting.islands_solved;
                self.wall_impulses.add_all(&resting.walls);
                self.counters.contacts += t2.elapsed();
                let t3 = Instant::now();
                self.finish_phase(h, pool);
                self.counters.walls += t3.elapsed();
                return;
            }
            let inputs = Inputs {
                restitution: collisions.restitution,
                field: &self.field,
                span: h,
                // Contacts are solved after every sub-step, each one step of the integrator.
                drift: resting_drift(self.integrator, 1),
                tolerances: Tolerances::new(largest, h, keeps_energy(collisions.restitution, &self.field)),
                gravity,
                key,
                key_acceleration,
                near_walls: &self.near_walls,
            };
            let (bodies, grid, contacts) = (&mut self.bodies, &self.broad_phase, &mut self.contacts);
            let outcome = in_pool(pool, || contacts.solve(bodies, grid, &inputs, pool.is_some()));
            self.counters.impulses += outcome.impacts;
            self.counters.wall_contacts += outcome.wall_contacts;
            self.counters.resting += outcome.resting;
            self.counters.unconverged += u64::from(!outcome.converged);
            self.counters.islands_solved += outcome.islands_solved;
            self.counters.pairs_reached += outcome.pairs_reached;
            self.counters.pushed_together += outcome.pushed_together;
            self.wall_impulses.add_all(&outcome.walls);
            self.counters.contacts += t2.elapsed();
        }
        let t3 = Instant::now();
        self.finish_phase(h, pool);
        self.counters.walls += t3.elapsed();
    }

    /// The force passes inside the integrator; then, ball by ball in the same chunks, how far
    /// each ball has moved since the pairs were last found and (with collisions on) which balls
    /// are near a wall, for the contact solver (kept in `near_walls`, in index order). Returns the
    /// largest squared such distance (+∞ when the pairs must be found afresh anyway, 0 without
    /// collisions).
    ///
    /// Without attraction every ball's update reads only that ball, so the balls are integrated
    /// in chunks of [`CHUNK`] (on the pool's threads when there is one): the same arithmetic on
    /// every ball as one whole-field call. Attraction couples them: one whole-field integration,
    /// then the per-ball work in chunks.
    fn integrate_phase(&mut self, dt: f64, pool: Option<&rayon::ThreadPool>) -> f64 {
        let elastic = self.elastic();
        let pull = match self.bodies.key_index() {
            Some(index) if self.pull != DVec2::ZERO => Some(PointForce { index, force: self.pull }),
            _ => None,
        };
        let n = self.bodies.len();
        let chunks = n.div_ceil(CHUNK);
        let method = self.integrator;
        let velocity_dependent = self.forces.depends_on_velocity();
        let local = self.forces.is_local();
        if !local {
            let Bodies { position, velocity, mass, inverse_mass, diameter, .. } = &mut self.bodies;
            self.scratch.resize_with(1, Default::default);
            let props = BodyProps { mass, inverse_mass, diameter };
            // `&mut`: the attraction pass builds its tree and keeps the orbit rate it met.
            let forces = &mut self.forces;
            integrate(method, dt, position, velocity, velocity_dependent, &mut self.scratch[0], |x, v, a| {
                forces.accelerations(props, pull, x, v, a)
            });
        }
        self.scratch.resize_with(chunks.max(self.scratch.len()), Default::default);
        // Where the balls were when the pairs were last found, if those pairs may still serve.
        let built = (self.effects.collisions.is_some() && !self.grid_stale && self.built_positions.len() == n)
            .then_some(&self.built_positions[..]);
        let Bodies { position, velocity, mass, inverse_mass, diameter, radius, .. } = &mut self.bodies;
        let (mass, inverse_mass, diameter, radius) = (&mass[..], &inverse_mass[..], &diameter[..], &radius[..]);
        let field = &self.field;
        // Only the contact solver takes the walls as contacts here (the elastic passes meet the
        // walls of the balls they strike, which they know themselves, and their resting phase
        // the walls the finish pass left balls touching).
        let collisions = self.effects.collisions.is_some() && !elastic;
        let step = local.then_some(LocalStep {
            method,
            dt,
            velocity_dependent,
            forces: &self.forces,
            pull,
            mass,
            inverse_mass,
            diameter,
        });
        let chunk = |c: usize, x: &mut [DVec2], v: &mut [DVec2], scratch: &mut IntegratorScratch| {
            let base = c * CHUNK;
            if let Some(step) = &step {
                step.run(base, x, v, scratch);
            }
            let mut tally = ChunkTally::default();
            if collisions {
                // Near enough that the sub-step's travel or a contact's push may bring it to the
                // wall (a ball moves at most MAX_TRAVEL radii per sub-step).
                for (k, (x, v)) in x.iter().zip(v.iter()).enumerate() {
                    let r = radius[base + k];
                    if near_a_wall(*x, r, r + v.length() * dt, field) {
                        tally.near_walls.push((base + k) as u32);
                    }
                }
            }
            if let Some(built) = built {
                tally.moved2 = x.iter().zip(&built[base..]).fold(0.0, |m, (x, x0)| m.max(x.distance_squared(*x0)));
            }
            tally
        };
        for_chunks(pool, position, velocity, &mut self.scratch, &mut self.tallies, chunk);
        let stale = self.effects.collisions.is_some() && built.is_none();
        let moved2 = self.tallies.iter().fold(0.0f64, |m, t| m.max(t.moved2));
        self.near_walls.clear();
        for t in &mut self.tallies {
            self.near_walls.append(&mut t.near_walls);
        }
        if stale { f64::INFINITY } else { moved2 }
    }

    /// The last pass of a sub-step, ball by ball in chunks: the speed capped at [`MAX_SPEED`], the
    /// walls for a ball past one (with collisions on, the contact solver has met the walls
    /// already, so only a ball some push left past one is bounced here, its impulse on the
    /// gauge), and the speeds the next sub-step's split needs (kept for
    /// [`Lockstep::split_rates`]).
    fn finish_phase(&mut self, h: f64, pool: Option<&rayon::ThreadPool>) {
        let elastic = self.elastic();
        let (collisions, drag) = (self.effects.collisions.is_some(), self.effects.drag.as_ref());
        let Uniform { gravity, key, largest, .. } = self.uniform();
        let Bodies { position, velocity, radius, mass, inverse_mass, diameter, .. } = &mut self.bodies;
        let (radius, mass, inverse_mass, diameter) = (&radius[..], &mass[..], &inverse_mass[..], &diameter[..]);
        let slack = if collisions && !elastic { TOUCH_MARGIN } else { 0.0 };
        // A ball this close to a wall may have touched it at the start of the next sub-step, as
        // its rewind along its parabola tells (see `physics::wall_contact_rests`): twice what the
        // largest uniform acceleration moves a ball in a sub-step.
        let record = (collisions && elastic).then_some(2.0 * largest * h * h);
        let walls =
            WallPass { field: &self.field, slack, record, gravity, pull: self.pull, key, radius, mass, inverse_mass };
        let chunk = |c: usize, x: &mut [DVec2], v: &mut [DVec2], _: &mut IntegratorScratch| {
            // One loop per job over the chunk (it is in cache by then): each stays simple enough
            // for the compiler to vectorise, which one loop doing all of them is not.
            let range = c * CHUNK..c * CHUNK + x.len();
            let mut tally = ChunkTally::default();
            for v in v.iter_mut() {
                if cap_speed(v) {
                    tally.speed_limited += 1;
                }
            }
            for (k, (x, v)) in x.iter_mut().zip(v.iter_mut()).enumerate() {
                walls.bounce(range.start + k, x, v, &mut tally);
            }
            tally.speeds = SplitSpeeds::measure(
                collisions,
                drag,
                v,
                &radius[range.clone()],
                &diameter[range.clone()],
                &mass[range],
            );
            tally
        };
        for_chunks(pool, position, velocity, &mut self.scratch, &mut self.tallies, chunk);
        let mut speeds = SplitSpeeds::default();
        for t in &self.tallies {
            speeds.travel2 = speeds.travel2.max(t.speeds.travel2);
            speeds.drag_rate = speeds.drag_rate.max(t.speeds.drag_rate);
            self.counters.speed_limited += t.speed_limited;
        }
        self.split_speeds = Some(speeds);
        self.on_walls.clear();
        for t in &mut self.tallies {
            self.on_walls.append(&mut t.on_walls);
        }
        self.on_walls_known = record.is_some();
        self.add_wall_tallies();
    }

    /// Adds the chunks' wall impulses to the run's, chunk after chunk (the same order, so the same
    /// bits, on any number of threads), and clears them.
    fn add_wall_tallies(&mut self) {
        for t in &mut self.tallies {
            if t.wall_contacts > 0 {
                self.wall_impulses.add_all(&t.walls);
                self.counters.wall_contacts += t.wall_contacts;
                self.counters.finish_bounces += t.wall_contacts;
            }
            t.walls = WallImpulses::default();
            t.wall_contacts = 0;
        }
    }

    /// Finds the candidate pairs afresh only when some ball has moved more than half the skin
    /// since the last search (`moved2`, the largest squared distance, measured by the integrate
    /// pass; see [`SKIN`]); otherwise the last list still holds every touching pair and the
    /// solver checks each for overlap itself.
    fn broad_phase_phase(&mut self, moved2: f64, pool: Option<&rayon::ThreadPool>) {
        let b = &self.bodies;
        let half_skin = 0.5 * self.broad_phase.skin();
        let elastic = self.elastic();
        if moved2 > half_skin * half_skin || elastic != self.pairs_elastic {
            self.pairs_elastic = elastic;
            if elastic {
                self.broad_phase.update(&b.position, &b.radius, self.field.width, self.field.height);
                let (grid, contacts) = (&self.broad_phase, &mut self.elastic);
                in_pool(pool, || contacts.find_pairs(grid, pool.is_some()));
                self.contacts.forget();
                self.built_positions.clear();
                self.built_positions.extend_from_slice(&b.position);
                self.grid_stale = false;
                self.counters.grid_builds += 1;
                self.counters.touching_pairs += self.elastic.pair_count() as u64;
                return;
            }
            // The resting impulses are carried over to the new pairs by ball ids, unless balls
            // were added or removed (then the old pairs' slots no longer name the same balls).
            if self.grid_stale {
                self.contacts.forget();
            } else {
                self.contacts.remember(b, &self.broad_phase);
            }
            self.broad_phase.update(&b.position, &b.radius, self.field.width, self.field.height);
            let (grid, contacts) = (&self.broad_phase, &mut self.contacts);
            in_pool(pool, || contacts.find_pairs(b, grid, pool.is_some()));
            self.built_positions.clear();
            self.built_positions.extend_from_slice(&b.position);
            self.grid_stale = false;
            self.counters.grid_builds += 1;
        }
        let pairs = if elastic { self.elastic.pair_count() } else { self.contacts.pair_count() };
        self.counters.touching_pairs += pairs as u64;
    }

    /// The uniform accelerations of a sub-step (see [`Uniform`]).
    fn uniform(&self) -> Uniform {
        let gravity = self.effects.gravity.map_or(DVec2::ZERO, |g| g.g);
        let key = self.bodies.key_index();
        let key_acceleration = key.map_or(DVec2::ZERO, |k| self.pull * self.bodies.inverse_mass[k]);
        let largest = gravity.length().max((gravity + key_acceleration).length());
        Uniform { gravity, key, key_acceleration, largest }
    }

    /// Whether the contacts are perfectly elastic (balls and walls of restitution 1): they then
    /// go through [`ElasticContacts`], sequential elastic impulses that keep the energy to
    /// rounding however dense the field, and the walls through the finish pass; otherwise through
    /// the contact solver, which takes the walls as contacts (see the module comment). A field
    /// of e = 1 balls whose walls take energy has none to keep: through the elastic passes a
    /// column of three on a floor of 0.5 never came to rest (a cycle of three steps, 1.9e-4 J a
    /// ball), where the contact solver's rules for a settling pile rest it.
    fn elastic(&self) -> bool {
        self.effects.collisions.is_some_and(|c| keeps_energy(c.restitution, &self.field))
    }

    /// Energies, momentum, overlap and wall impulses now.
    pub fn diagnostics(&self) -> Diagnostics {
        measure(&self.bodies, &self.field, &self.effects, self.wall_impulses)
    }

    /// A 64-bit FNV-1a hash of the exact bits of every ball's id, position, velocity, mass and
    /// diameter, in order. Two runs agree on it only if they agree to the last bit.
    pub fn state_hash(&self) -> u64 {
        state_hash(&self.bodies)
    }
}

/// Runs `f` inside the pool (so its parallel iterators use the pool's threads), or here.
fn in_pool<R: Send>(pool: Option<&rayon::ThreadPool>, f: impl FnOnce() -> R + Send) -> R {
    match pool {
        Some(pool) => pool.install(f),
        None => f(),
    }
}

/// FNV-1a over the exact bits of a set of balls (see [`Lockstep::state_hash`]).
pub fn state_hash(b: &Bodies) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |x: u64| {
        for byte in x.to_le_bytes() {
            h ^= byte as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for i in 0..b.len() {
        eat(b.id[i].0 as u64);
        eat(b.position[i].x.to_bits());
        eat(b.position[i].y.to_bits());
        eat(b.velocity[i].x.to_bits());
        eat(b.velocity[i].y.to_bits());
        eat(b.mass[i].to_bits());
        eat(b.diameter[i].to_bits());
    }
    h
}

/// The uniform accelerations of a sub-step: gravity, the key ball's index and its extra
/// acceleration (the pull over its mass), and the largest of gravity and gravity plus the pull,
/// which the contacts' tolerances and the finish pass's touching margin are measured by.
struct Uniform {
    gravity: DVec2,
    key: Option<usize>,
    key_acceleration: DVec2,
    largest: f64,
}

/// The speeds a step's split is judged by (see `Lockstep::split_rates`): the largest
/// `(|v|/r)²` (with collisions on) and the largest drag rate (with drag on).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct SplitSpeeds {
    travel2: f64,
    drag_rate: f64,
}

impl SplitSpeeds {
    /// The speeds of the balls with velocities `v` (and these radii, diameters and masses).
    fn measure(
        collisions: bool,
        drag: Option<&Drag>,
        v: &[DVec2],
        radius: &[f64],
        diameter: &[f64],
        mass: &[f64],
    ) -> Self {
        let mut speeds = SplitSpeeds::default();
        if collisions {
            speeds.travel2 = v.iter().zip(radius).fold(0.0, |w, (v, r)| w.max(v.length_squared() / (r * r)));
        }
        if let Some(drag) = drag {
            let rates = v.iter().zip(diameter).zip(mass);
            speeds.drag_rate = rates.fold(0.0, |w, ((v, d), m)| w.max(drag_rate(*v, *d, *m, drag)));
        }
        speeds
    }
}

/// The largest quadratic drag rate at 1 m/s among the balls (`c`, 1/m; 0 for linear drag, whose
/// rate does not grow with speed).
fn largest_drag_c(drag: &Drag, diameter: &[f64], mass: &[f64]) -> f64 {
    match drag {
        Drag::Quadratic { .. } => {
            diameter.iter().zip(mass).fold(0.0, |w, (d, m)| w.max(drag_rate(DVec2::X, *d, *m, drag)))
        }
        Drag::Linear { .. } => 0.0,
    }
}

/// What one pass measured over one chunk of balls. The chunks' tallies are combined in chunk
/// order, so the totals have the same bits on any number of threads.
#[derive(Clone, Debug, Default)]
struct ChunkTally {
    walls: WallImpulses,
    /// Balls near a wall (with collisions on; see [`Lockstep::integrate_phase`]).
    near_walls: Vec<u32>,
    /// Balls left touching a wall (see [`WallPass`]'s `record`).
    on_walls: Vec<u32>,
    wall_contacts: u64,
    speed_limited: u64,
    /// Largest squared distance a ball has moved since the pairs were last found.
    moved2: f64,
    speeds: SplitSpeeds,
}

/// The walls as each ball meets them (see `contact_ball_wall`).
struct WallPass<'a> {
    field: &'a Field,
    /// How far past a wall a ball must be to be bounced here: 0 without collisions; with them,
    /// the contact solver's touching margin, as it has met every ball touching a wall already
    /// (bouncing a ball that rests exactly on the floor again would kick it with the wall's
    /// restitution).
    slack: f64,
    /// Whether to list the balls it leaves touching a wall, and within what gap (m, besides the
    /// touching margin): the next sub-step's resting phase of the elastic passes looks for
    /// resting balls among them.
    record: Option<f64>,
    gravity: DVec2,
    pull: DVec2,
    key: Option<usize>,
    radius: &'a [f64],
    mass: &'a [f64],
    inverse_mass: &'a [f64],
}

impl WallPass<'_> {
    /// Ball `i`, at `x` with `v`, against the walls; its impulses and contact go into `tally`.
    #[inline(always)]
    fn bounce(&self, i: usize, x: &mut DVec2, v: &mut DVec2, tally: &mut ChunkTally) {
        // Strictly inside: `contact_ball_wall` would do nothing (most balls, most sub-steps).
        let r = self.radius[i];
        if let Some(band) = self.record {
            let near = r * (1.0 + TOUCH_MARGIN) + band;
            if x.x > near && x.x < self.field.width - near && x.y > near && x.y < self.field.height - near {
                return;
            }
            tally.on_walls.push(i as u32);
        } else if x.x > r && x.x < self.field.width - r && x.y > r && x.y < self.field.height - r {
            return;
        }
        if self.slack > 0.0 {
            let (lo, hi) =
                (r * (1.0 - self.slack), DVec2::new(self.field.width, self.field.height) - r * (1.0 - self.slack));
            if x.x >= lo && x.y >= lo && x.x <= hi.x && x.y <= hi.y {
                return;
            }
        }
        // The ball's uniform acceleration during the step, for an exact bounce.
        let acceleration =
            if Some(i) == self.key { self.gravity + self.pull * self.inverse_mass[i] } else { self.gravity };
        if contact_ball_wall(x, v, self.radius[i], self.mass[i], acceleration, self.field, &mut tally.walls) {
            tally.wall_contacts += 1;
        }
    }
}

/// Local forces (no attraction) applied to one chunk of balls inside the integrator.
struct LocalStep<'a> {
    method: Integrator,
    dt: f64,
    velocity_dependent: bool,
    forces: &'a Forces,
    pull: Option<PointForce>,
    mass: &'a [f64],
    inverse_mass: &'a [f64],
    diameter: &'a [f64],
}

impl LocalStep<'_> {
    /// Integrates the balls `base..base + x.len()`.
    fn run(&self, base: usize, x: &mut [DVec2], v: &mut [DVec2], scratch: &mut IntegratorScratch) {
        let range = base..base + x.len();
        let pull = self.pull.filter(|p| range.contains(&p.index)).map(|p| PointForce { index: p.index - base, ..p });
        if self.forces.is_empty() && pull.is_none() {
            // No force at all: every integrator reduces to a straight drift, so that is all we do.
            for (x, v) in x.iter_mut().zip(v.iter()) {
                *x += *v * self.dt;
            }
            return;
        }
        let props = BodyProps {
            mass: &self.mass[range.clone()],
            inverse_mass: &self.inverse_mass[range.clone()],
            diameter: &self.diameter[range],
        };
        let forces = self.forces;
        integrate(self.method, self.dt, x, v, self.velocity_dependent, scratch, |x, v, a| {
            forces.local_accelerations(props, pull, x, v, a)
        });
    }
}

/// Runs `f(chunk, positions, velocities, scratch)` over the balls in fixed chunks of [`CHUNK`]
/// (on the pool's threads when there is one) and leaves the chunks' tallies in `out`, in chunk
/// order. How the balls are cut depends on their number only.
fn for_chunks<F>(
    pool: Option<&rayon::ThreadPool>,
    x: &mut [DVec2],
    v: &mut [DVec2],
    scratch: &mut [IntegratorScratch],
    out: &mut Vec<ChunkTally>,
    f: F,
) where
    F: Fn(usize, &mut [DVec2], &mut [DVec2], &mut IntegratorScratch) -> ChunkTally + Sync + Send,
{
    debug_assert!(scratch.len() >= x.len().div_ceil(CHUNK));
    match pool {
        Some(pool) => pool.install(|| {
            x.par_chunks_mut(CHUNK)
                .zip(v.par_chunks_mut(CHUNK))
                .zip(scratch.par_iter_mut())
                .enumerate()
                .map(|(c, ((x, v), s))| f(c, x, v, s))
                .collect_into_vec(out)
        }),
        None => {
            out.clear();
            let chunks = x.chunks_mut(CHUNK).zip(v.chunks_mut(CHUNK)).zip(scratch.iter_mut());
            out.extend(chunks.enumerate().map(|(c, ((x, v), s))| f(c, x, v, s)));
        }
    }
}
