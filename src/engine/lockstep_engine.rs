//! The lockstep engine behind [`Engine`]: whole steps of `dt`, on demand.

use std::time::{Duration, Instant};

use glam::DVec2;

use super::{
    Engine, EngineError, EngineFigures, EngineKind, Placement, Shutdown, admit, check_mass, check_velocity,
    clamp_restitution,
};
use crate::engine::lockstep::Lockstep;
use crate::physics::{Ball, BallId, Diagnostics, Effects, Field, Integrator, WallImpulses};
use crate::scene::Scene;

/// The longest stretch of wall-clock time one window tick advances: after a stall the game slows
/// down rather than running hundreds of steps in one go.
const MAX_TICK: f64 = 0.1;

/// [`Lockstep`] with what the interface needs around it: pause, time scale, the part of a step
/// that a tick left over, and its own step count and stepping time.
pub struct LockstepEngine {
    engine: Lockstep,
    paused: bool,
    time_scale: f64,
    /// Simulated time a tick owed but that made less than a whole step.
    carry: f64,
    /// Steps taken, and the wall time spent taking them.
    steps: u64,
    stepping: Duration,
    /// Steps since the rate was last read, and since when.
    rate_steps: u64,
    rate_since: Instant,
    last_rate: f64,
    placement: Placement,
}

impl LockstepEngine {
    /// The engine for `scene`, sharing its phases over `threads` (`None`: every core).
    pub fn new(scene: &Scene, threads: Option<usize>) -> LockstepEngine {
        let mut engine = Lockstep::new(scene);
        if let Some(threads) = threads {
            engine.set_threads(threads);
        }
        LockstepEngine {
            engine,
            paused: false,
            time_scale: 1.0,
            carry: 0.0,
            steps: 0,
            stepping: Duration::ZERO,
            rate_steps: 0,
            rate_since: Instant::now(),
            last_rate: 0.0,
            placement: Placement::new(scene.seed),
        }
    }

    /// The engine itself, for a caller that needs more than the interface gives (its bodies,
    /// its counters).
    pub fn lockstep(&self) -> &Lockstep {
        &self.engine
    }

    fn run(&mut self, n: u64) {
        if n == 0 {
            return;
        }
        let t = Instant::now();
        self.engine.run(n);
        self.stepping += t.elapsed();
        self.steps += n;
        self.rate_steps += n;
    }
}

impl Engine for LockstepEngine {
    fn kind(&self) -> EngineKind {
        EngineKind::Lockstep
    }

    fn time(&self) -> f64 {
        self.engine.time()
    }

    fn advance_to(&mut self, t: f64) {
        if self.paused {
            return;
        }
        // The first whole step at or after `t`, counted in steps (not from the summed clock,
        // whose rounding grows with the run), with a hair of tolerance for `t`'s own rounding.
        let target = (t / self.engine.dt() - 1e-9).ceil().max(0.0) as u64;
        self.run(target.saturating_sub(self.engine.steps()));
    }

    fn advance_steps(&mut self, n: u64) {
        if !self.paused {
            self.run(n);
        }
    }

    fn step(&self) -> f64 {
        self.engine.dt()
    }

    fn tick(&mut self, wall: Duration) {
        if self.paused {
            return;
        }
        let t = wall.as_secs_f64().min(MAX_TICK) * self.time_scale + self.carry;
        let dt = self.engine.dt();
        let n = (t / dt).floor();
        self.carry = t - n * dt;
        self.run(n as u64);
    }

    fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
    }

    fn is_paused(&self) -> bool {
        self.paused
    }

    fn single_step(&mut self, span: Duration) {
        if self.paused {
            let n = (span.as_secs_f64() * self.time_scale / self.engine.dt()).round().max(1.0);
            self.run(n as u64);
        }
    }

    fn set_time_scale(&mut self, scale: f64) {
        if scale.is_finite() && scale >= 0.0 {
            self.time_scale = scale;
        }
    }

    fn time_scale(&self) -> f64 {
        self.time_scale
    }

    fn quiesce(&mut self) {
        self.paused = true;
    }

    fn sample(&mut self, out: &mut Vec<Ball>) {
        out.clear();
        // Straight into `out` (no temporary copy of every ball each tick); the bodies keep the
        // order of their ids.
        let bodies = self.engine.bodies();
        out.extend((0..bodies.len()).map(|i| bodies.get(i)));
    }

    fn ball_count(&self) -> usize {
        self.engine.bodies().len()
    }

    fn add_ball(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        let ball = admit(ball, self.engine.field())?;
        self.engine.add_ball(ball)
    }

    fn remove_ball(&mut self, id: BallId) -> Result<Ball, EngineError> {
        self.engine.remove_ball(id)
    }

    fn put_back(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        let ball = admit(ball, self.engine.field())?;
        self.engine.put_back(ball)
    }

    fn remove_last(&mut self) -> Option<Ball> {
        self.engine.remove_last()
    }

    fn set_velocity(&mut self, id: BallId, velocity: DVec2) -> Result<(), EngineError> {
        self.engine.set_velocity(id, check_velocity(velocity)?)
    }

    fn set_mass(&mut self, id: BallId, mass: f64) -> Result<(), EngineError> {
        self.engine.set_mass(id, check_mass(mass)?)
    }

    fn set_pull(&mut self, force: DVec2) {
        if force.is_finite() {
            self.engine.set_pull(force);
        }
    }

    fn key_ball(&self) -> Option<BallId> {
        let b = self.engine.bodies();
        b.key_index().map(|i| b.id[i])
    }

    fn placement(&mut self) -> &mut Placement {
        &mut self.placement
    }

    fn field(&self) -> Field {
        *self.engine.field()
    }

    fn effects(&self) -> Effects {
        *self.engine.effects()
    }

    fn set_effects(&mut self, effects: Effects) {
        self.engine.set_effects(effects);
    }

    fn integrator(&self) -> Integrator {
        self.engine.integrator()
    }

    fn set_restitution(&mut self, walls: f64, balls: f64) {
        let field = *self.engine.field();
        self.engine.set_field_restitution(clamp_restitution(walls, field.restitution));
        let mut effects = *self.engine.effects();
        if let Some(c) = &mut effects.collisions {
            c.restitution = clamp_restitution(balls, c.restitution);
            self.engine.set_effects(effects);
        }
    }

    fn wall_impulses(&self) -> WallImpulses {
        self.engine.wall_impulses()
    }

    fn diagnostics(&mut self) -> Diagnostics {
        self.engine.diagnostics()
    }

    fn active_effects(&self) -> Vec<String> {
        self.engine.active_effects().into_iter().map(String::from).collect()
    }

    fn rate_unit(&self) -> &'static str {
        "steps/s"
    }

    fn rate(&mut self) -> f64 {
        let secs = self.rate_since.elapsed().as_secs_f64();
        if secs > 0.0 {
            self.last_rate = self.rate_steps as f64 / secs;
        }
        self.rate_steps = 0;
        self.rate_since = Instant::now();
        self.last_rate
    }

    fn figures(&mut self) -> EngineFigures {
        let secs = self.stepping.as_secs_f64();
        EngineFigures {
            dt: self.engine.dt(),
            steps: self.steps,
            rate: if secs > 0.0 { self.steps as f64 / secs } else { 0.0 },
            phases: Some(*self.engine.counters()),
            state_hash: Some(self.engine.state_hash()),
            threads: Some(self.engine.threads()),
            runtime: None,
            exact: None,
        }
    }

    fn shutdown(&mut self) -> Shutdown {
        Shutdown::default()
    }
}
