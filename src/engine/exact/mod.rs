//! The exact engine: event-driven hard balls, every collision at its exact instant.
//!
//! Between events a ball under uniform gravity (and the key ball under its pull, constant
//! between two changes of it) flies an exact parabola, so nothing is integrated: the engine jumps
//! from one collision, wall bounce or cell crossing to the next, each the root of a polynomial
//! ([`crate::physics`]'s `event` functions), and any instant in between is read off the
//! parabolas. To rounding, an elastic run is the true motion of hard balls — the reference the
//! stepped engines are measured against. Drag and attraction are not piecewise constant; a scene
//! with either is refused ([`EngineError::Unsupported`]).
//!
//! - `calendar.rs` — the predicted events, one slot per ball under a tournament tree;
//! - `cells.rs` — the cell list the neighbours are found in;
//! - `world.rs` — the balls, their prediction, and what each event does (with the rest model for
//!   balls pressed against walls and each other, the collapse model for slow inelastic
//!   collisions, and the rules for many collisions at one instant).

mod calendar;
mod cells;
mod world;

use std::time::{Duration, Instant};

use glam::DVec2;
use serde::Serialize;

use super::{
    Engine, EngineError, EngineFigures, EngineKind, Placement, Shutdown, admit, check_mass, check_velocity,
    clamp_restitution,
};
use crate::physics::{Ball, BallId, Bodies, Diagnostics, Effects, Field, Integrator, WallImpulses, measure};
use crate::scene::Scene;

pub use world::{ExactCounters, ExactParams, REST_HEIGHT, World};

/// The longest stretch of wall-clock time one window tick advances (as the lockstep engine's).
const MAX_TICK: f64 = 0.1;
/// The most wall-clock time one window tick may spend on events: beyond it the game slows down
/// rather than missing frames.
const TICK_BUDGET: Duration = Duration::from_millis(12);

/// What the exact engine measured, for the report.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ExactStats {
    /// Events processed: collisions, wall bounces and cell crossings.
    pub events: u64,
    /// What the engine counted, event by event.
    #[serde(flatten)]
    pub counters: ExactCounters,
    /// Events per second of wall-clock time spent processing them.
    pub events_per_second: f64,
    /// Collisions per second of wall-clock time spent processing events.
    pub collisions_per_second: f64,
    /// Events overwritten in the calendar by a newer prediction of their owner before they came
    /// up.
    pub invalidated_superseded: u64,
    /// Events that came up with their partner's course changed (the owner then predicted again).
    pub invalidated_partner: u64,
    /// Largest number of events the calendar held (at most one per ball).
    pub calendar_peak: usize,
    /// Balls at rest at the end.
    pub at_rest: usize,
    /// Balls sliding on a wall at the end.
    pub sliding: usize,
    /// The rest and collapse models' parameters.
    pub params: ExactParams,
}

/// The parameters for a scene: see [`ExactParams::for_scene`].
pub fn params_for(scene_balls: &[Ball], effects: &Effects) -> ExactParams {
    let smallest = scene_balls.iter().map(|b| b.diameter).fold(f64::INFINITY, f64::min);
    let smallest = if smallest.is_finite() { smallest } else { 1.0 };
    let g = effects.gravity.map_or(0.0, |g| g.g.length());
    let n = scene_balls.len().max(1) as f64;
    let rms = (scene_balls.iter().map(|b| b.velocity.length_squared()).sum::<f64>() / n).sqrt();
    ExactParams::for_scene(smallest, g, rms)
}

/// Refuses effects that are not piecewise constant.
pub fn check_effects(effects: &Effects) -> Result<(), EngineError> {
    let names: Vec<&str> = [("drag", effects.drag.is_some()), ("attraction", effects.attraction.is_some())]
        .iter()
        .filter(|(_, on)| *on)
        .map(|(n, _)| *n)
        .collect();
    if names.is_empty() {
        Ok(())
    } else {
        Err(EngineError::Unsupported { engine: EngineKind::Exact, effects: names.join(" and ") })
    }
}

/// `World` behind the engine interface.
#[derive(Clone)]
pub struct ExactEngine {
    world: World,
    scene_dt: f64,
    integrator: Integrator,
    paused: bool,
    time_scale: f64,
    stepping: Duration,
    rate_events: u64,
    rate_since: Instant,
    last_rate: f64,
    placement: Placement,
}

impl ExactEngine {
    /// The engine for `scene`, or why it cannot run it.
    pub fn new(scene: &Scene) -> Result<ExactEngine, EngineError> {
        check_effects(&scene.effects)?;
        let params = params_for(&scene.balls, &scene.effects);
        Ok(ExactEngine::with_params(scene, params))
    }

    /// The engine for `scene` (drag and attraction ignored) with its own rest and collapse
    /// parameters.
    pub fn with_params(scene: &Scene, params: ExactParams) -> ExactEngine {
        let field = scene.field;
        let balls: Vec<Ball> = scene.balls.iter().map(|b| admit(*b, &field).unwrap_or(*b)).collect();
        ExactEngine {
            world: World::new(field, scene.effects, &balls, scene.max_balls, params),
            scene_dt: scene.dt,
            integrator: scene.integrator,
            paused: false,
            time_scale: 1.0,
            stepping: Duration::ZERO,
            rate_events: 0,
            rate_since: Instant::now(),
            last_rate: 0.0,
            placement: Placement::new(scene.seed),
        }
    }

    /// The engine for `balls` in `field` under `effects`, without a scene file (the tests, the
    /// benches and the accuracy report build their problems so): room for as many balls as are
    /// given, or 1, the scene's defaults for the rest.
    pub fn from_parts(field: Field, effects: Effects, balls: &[Ball]) -> Result<ExactEngine, EngineError> {
        check_effects(&effects)?;
        let scene = Scene {
            name: "exact".into(),
            description: String::new(),
            field,
            integrator: Integrator::default(),
            dt: 0.001,
            seed: 0,
            max_balls: balls.len().max(1),
            ball_cycle: 0.001,
            effects,
            pull: 0.0,
            balls: balls.to_vec(),
        };
        ExactEngine::new(&scene)
    }

    /// The simulation itself (tests and the accuracy report read it).
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Processes events until `n` more collisions have happened (the speed bench's unit).
    pub fn run_collisions(&mut self, n: u64) {
        let t = Instant::now();
        self.world.run_collisions(n);
        self.stepping += t.elapsed();
    }

    /// The exact engine's figures.
    pub fn stats(&self) -> ExactStats {
        let c = self.world.counters;
        let cal = self.world.calendar_stats();
        let secs = self.stepping.as_secs_f64();
        let events = c.collisions + c.wall_bounces + c.cell_crossings;
        let per = |n: u64| if secs > 0.0 { n as f64 / secs } else { 0.0 };
        let (at_rest, sliding) = self.world.resting();
        ExactStats {
            events,
            counters: c,
            events_per_second: per(events),
            collisions_per_second: per(c.collisions),
            invalidated_superseded: cal.superseded,
            invalidated_partner: cal.stale_partner,
            calendar_peak: cal.peak_len,
            at_rest,
            sliding,
            params: self.world.params(),
        }
    }

    /// FNV-1a of the exact bits of every ball now (as the lockstep engine's state hash).
    pub fn state_hash(&self) -> u64 {
        let mut balls = Vec::new();
        self.world.sample(&mut balls);
        crate::engine::lockstep::state_hash(&Bodies::from_balls(&balls))
    }

    fn events(&self) -> u64 {
        let c = self.world.counters;
        c.collisions + c.wall_bounces + c.cell_crossings
    }

    fn run_to(&mut self, t: f64, deadline: Option<Instant>) {
        let before = self.events();
        let clock = Instant::now();
        match deadline {
            None => self.world.advance_to(t),
            Some(d) => {
                self.world.advance_while(t, || Instant::now() < d);
            }
        }
        self.stepping += clock.elapsed();
        self.rate_events += self.events() - before;
    }

    fn params(&self, effects: &Effects) -> ExactParams {
        let mut balls = Vec::new();
        self.world.sample(&mut balls);
        params_for(&balls, effects)
    }
}

impl Engine for ExactEngine {
    fn kind(&self) -> EngineKind {
        EngineKind::Exact
    }

    fn time(&self) -> f64 {
        self.world.now()
    }

    fn advance_to(&mut self, t: f64) {
        if !self.paused {
            self.run_to(t, None);
        }
    }

    /// Steps of the scene's dt, as the lockstep engine's: the clock moves by `n·dt`.
    fn step(&self) -> f64 {
        self.scene_dt
    }

    fn advance_steps(&mut self, n: u64) {
        if !self.paused {
            let t = self.world.now() + n as f64 * self.scene_dt;
            self.run_to(t, None);
        }
    }

    fn tick(&mut self, wall: Duration) {
        if self.paused {
            return;
        }
        let t = self.world.now() + wall.as_secs_f64().min(MAX_TICK) * self.time_scale;
        self.run_to(t, Some(Instant::now() + TICK_BUDGET));
    }

    fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
    }

    fn is_paused(&self) -> bool {
        self.paused
    }

    fn single_step(&mut self, span: Duration) {
        if self.paused {
            let t = self.world.now() + span.as_secs_f64() * self.time_scale;
            self.run_to(t, Some(Instant::now() + TICK_BUDGET));
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
        self.world.sample(out);
    }

    fn ball_count(&self) -> usize {
        self.world.len()
    }

    fn add_ball(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        let ball = admit(ball, self.world.field())?;
        self.world.insert(ball, false)
    }

    fn remove_ball(&mut self, id: BallId) -> Result<Ball, EngineError> {
        let i = self.world.index_of(id).ok_or(EngineError::NoSuchBall(id))?;
        Ok(self.world.remove(i))
    }

    fn put_back(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        let ball = admit(ball, self.world.field())?;
        self.world.insert(ball, true)
    }

    fn remove_last(&mut self) -> Option<Ball> {
        let mut balls = Vec::new();
        self.world.sample(&mut balls);
        let last = balls.iter().filter(|b| b.kind != crate::physics::BallKind::Key).max_by_key(|b| b.id)?;
        let i = self.world.index_of(last.id)?;
        Some(self.world.remove(i))
    }

    fn set_velocity(&mut self, id: BallId, velocity: DVec2) -> Result<(), EngineError> {
        let velocity = check_velocity(velocity)?;
        let i = self.world.index_of(id).ok_or(EngineError::NoSuchBall(id))?;
        self.world.set_velocity(i, velocity);
        Ok(())
    }

    fn set_mass(&mut self, id: BallId, mass: f64) -> Result<(), EngineError> {
        let mass = check_mass(mass)?;
        let i = self.world.index_of(id).ok_or(EngineError::NoSuchBall(id))?;
        self.world.set_mass(i, mass);
        Ok(())
    }

    fn set_pull(&mut self, force: DVec2) {
        if force.is_finite() {
            self.world.set_pull(force);
        }
    }

    fn key_ball(&self) -> Option<BallId> {
        self.world.key_index().map(|i| self.world.ball(i).id)
    }

    fn placement(&mut self) -> &mut Placement {
        &mut self.placement
    }

    fn field(&self) -> Field {
        *self.world.field()
    }

    fn effects(&self) -> Effects {
        *self.world.effects()
    }

    /// Drag and attraction are dropped (with a warning): the exact engine cannot run them, and
    /// this command cannot refuse.
    fn set_effects(&mut self, effects: Effects) {
        if let Err(e) = check_effects(&effects) {
            log::warn!("{e}; running without them");
        }
        let params = self.params(&effects);
        self.world.set_effects(effects, params);
    }

    fn integrator(&self) -> Integrator {
        self.integrator
    }

    fn motion(&self) -> &'static str {
        // Nothing is integrated: every ball flies its exact parabola between events.
        "exact parabolas"
    }

    fn set_restitution(&mut self, walls: f64, balls: f64) {
        let walls = clamp_restitution(walls, self.world.field().restitution);
        let current = self.world.effects().collisions.map_or(1.0, |c| c.restitution);
        self.world.set_restitution(walls, clamp_restitution(balls, current));
    }

    fn wall_impulses(&self) -> WallImpulses {
        self.world.wall_impulses()
    }

    fn diagnostics(&mut self) -> Diagnostics {
        let mut balls = Vec::new();
        self.world.sample(&mut balls);
        measure(&Bodies::from_balls(&balls), self.world.field(), self.world.effects(), self.world.wall_impulses())
    }

    fn active_effects(&self) -> Vec<String> {
        self.world.effects().active_names().into_iter().map(String::from).collect()
    }

    fn rate_unit(&self) -> &'static str {
        "events/s"
    }

    fn rate(&mut self) -> f64 {
        let secs = self.rate_since.elapsed().as_secs_f64();
        if secs > 0.0 {
            self.last_rate = self.rate_events as f64 / secs;
        }
        self.rate_events = 0;
        self.rate_since = Instant::now();
        self.last_rate
    }

    fn figures(&mut self) -> EngineFigures {
        let stats = self.stats();
        EngineFigures {
            dt: self.scene_dt,
            steps: stats.events,
            rate: stats.events_per_second,
            phases: None,
            state_hash: Some(self.state_hash()),
            threads: None,
            runtime: None,
            exact: Some(stats),
        }
    }

    fn shutdown(&mut self) -> Shutdown {
        Shutdown::default()
    }
}
