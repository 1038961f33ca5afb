//! The threaded runtime behind [`Engine`]: its balls move by themselves, on their own threads;
//! the interface keeps the simulated clock and turns commands into the runtime's messages.

use std::time::{Duration, Instant};

use glam::DVec2;

use super::{
    Engine, EngineError, EngineFigures, EngineKind, Placement, Shutdown, admit, check_mass, check_velocity,
    clamp_restitution,
};
use crate::engine::runtime::{BallRecord, Runtime, RuntimeConfig};
use crate::physics::{AttractionMethod, Ball, BallId, Diagnostics, Effects, Field, Integrator, WallImpulses, measure};
use crate::scene::Scene;

/// The runtime configuration a scene asks for. `BALLFIELD_BALL_WAIT=sleep` makes the ball threads
/// always sleep between cycles, never yield (to measure what yielding gains); `BALLFIELD_SLEEP=off`
/// keeps every ball awake (to measure what sleeping islands gain).
pub fn runtime_config(scene: &Scene) -> RuntimeConfig {
    RuntimeConfig {
        ball_cycle: Duration::from_secs_f64(scene.ball_cycle),
        max_balls: scene.max_balls,
        yield_when_crowded: std::env::var("BALLFIELD_BALL_WAIT").map_or(true, |v| v != "sleep"),
        sleep: std::env::var("BALLFIELD_SLEEP").map_or(true, |v| v != "off"),
        ..RuntimeConfig::default()
    }
}

/// The simulated clock of a runtime whose balls run in wall-clock time times the time scale.
#[derive(Clone, Copy, Debug)]
struct Clock {
    /// Simulated seconds up to `since`.
    banked: f64,
    /// When the clock last started running (`None`: stopped, paused).
    since: Option<Instant>,
    scale: f64,
}

impl Clock {
    fn now(&self) -> f64 {
        self.banked + self.since.map_or(0.0, |s| s.elapsed().as_secs_f64() * self.scale)
    }

    /// Banks the time run so far and goes on (`running`) or stops.
    fn rebase(&mut self, running: bool) {
        self.banked = self.now();
        self.since = running.then(Instant::now);
    }
}

/// [`Runtime`] behind the interface.
pub struct ThreadedEngine {
    runtime: Runtime,
    clock: Clock,
    /// A single step in progress: pause again at this instant.
    step_until: Option<Instant>,
    cycle: Duration,
    placement: Placement,
    last_rate: f64,
    /// The table as last read (kept for its memory).
    records: Vec<BallRecord>,
    /// The runtime's clock (s) at the instant the engine last paused it.
    paused_clock: Option<f64>,
    /// Simulated seconds the balls stand ahead of the engine's clock after [`Engine::quiesce`]:
    /// paused, every ball catches up to the monitor's horizon, which runs up to a few monitor
    /// periods ahead of the clock, so the balls read then are of that later instant.
    lead: f64,
}

impl ThreadedEngine {
    /// Starts a thread for every ball of `scene` and the collision monitor. The clock starts
    /// once every thread is running.
    pub fn start(scene: &Scene) -> Result<ThreadedEngine, EngineError> {
        let runtime = Runtime::start(scene, runtime_config(scene))?;
        // From the runtime's zero, so that the engine's time is the balls' own.
        let zero = runtime.zero_instant();
        Ok(ThreadedEngine {
            runtime,
            clock: Clock { banked: 0.0, since: Some(zero), scale: 1.0 },
            step_until: None,
            cycle: scene.ball_cycle_duration(),
            placement: Placement::new(scene.seed),
            last_rate: 0.0,
            records: Vec::new(),
            paused_clock: None,
            lead: 0.0,
        })
    }

    /// The runtime itself, for a caller that needs more than the interface gives (its table,
    /// its stats).
    pub fn runtime(&self) -> &Runtime {
        &self.runtime
    }

    fn pause_now(&mut self) {
        // The clock before the flag: the monitor drops paused time only once it sees the flag.
        self.paused_clock.get_or_insert(self.runtime.clock_seconds());
        self.runtime.pause();
        self.clock.rebase(false);
    }

    fn resume_now(&mut self) {
        self.paused_clock = None;
        self.lead = 0.0;
        self.runtime.resume();
        self.clock.rebase(true);
    }
}

impl Engine for ThreadedEngine {
    fn kind(&self) -> EngineKind {
        EngineKind::Threaded
    }

    fn time(&self) -> f64 {
        // Less the wall time the runtime dropped from its clock (a stalled process); plus, once
        // quiesced, how far ahead the balls stand.
        (self.clock.now() - self.runtime.clock_dropped_seconds() * self.clock.scale).max(0.0) + self.lead
    }

    fn advance_to(&mut self, t: f64) {
        if self.runtime.is_paused() || self.clock.scale <= 0.0 {
            return;
        }
        // Again after each sleep: a stall the runtime drops from its clock makes it run longer.
        loop {
            let left = (t - self.time()) / self.clock.scale;
            if left <= 0.0 {
                return;
            }
            std::thread::sleep(Duration::from_secs_f64(left));
        }
    }

    fn advance_steps(&mut self, n: u64) {
        let t = self.clock.now() + n as f64 * self.cycle.as_secs_f64();
        self.advance_to(t);
    }

    fn step(&self) -> f64 {
        self.cycle.as_secs_f64()
    }

    fn tick(&mut self, _wall: Duration) {
        if let Some(t) = self.step_until
            && Instant::now() >= t
        {
            self.pause_now();
            self.step_until = None;
        }
    }

    fn set_paused(&mut self, paused: bool) {
        self.step_until = None;
        if paused { self.pause_now() } else { self.resume_now() }
    }

    fn is_paused(&self) -> bool {
        // A single step in progress is still "paused" to the player: it pauses by itself.
        self.runtime.is_paused() || self.step_until.is_some()
    }

    fn single_step(&mut self, span: Duration) {
        if self.runtime.is_paused() && self.step_until.is_none() {
            self.resume_now();
            self.step_until = Some(Instant::now() + span);
        }
    }

    fn set_time_scale(&mut self, scale: f64) {
        if scale.is_finite() && scale >= 0.0 {
            let running = self.clock.since.is_some();
            self.clock.rebase(running);
            self.clock.scale = scale;
            self.runtime.set_time_scale(scale);
        }
    }

    fn time_scale(&self) -> f64 {
        self.clock.scale
    }

    fn quiesce(&mut self) {
        self.step_until = None;
        // The monitor judges the contacts up to the clock first, so the balls are not read
        // before the instant the engine was run to (see `Runtime::catch_up`).
        if !self.runtime.catch_up(Duration::from_secs(1)) {
            log::warn!("the threaded engine's monitor did not catch up with its clock within 1 s");
        }
        self.pause_now();
        // Every ball catches up to the monitor's horizon with every contact message applied, so
        // the balls are read at one instant: the horizon, which the monitor published before it
        // saw the pause, on the clock the pause was read from.
        if !self.runtime.settle(Duration::from_secs(5)) {
            log::warn!("the threaded engine's balls did not all catch up within 5 s: the end state mixes instants");
        }
        let paused = self.paused_clock.unwrap_or_else(|| self.runtime.clock_seconds());
        self.lead = (self.runtime.horizon_seconds() - paused).max(0.0) * self.clock.scale;
    }

    fn sample(&mut self, out: &mut Vec<Ball>) {
        self.runtime.snapshot_into(&mut self.records);
        out.clear();
        out.extend(self.records.iter().map(|r| r.ball));
        out.sort_unstable_by_key(|b| b.id);
    }

    fn ball_count(&self) -> usize {
        self.runtime.ball_count()
    }

    fn add_ball(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        let ball = admit(ball, &self.runtime.params().field)?;
        self.runtime.add_ball(ball)
    }

    fn remove_ball(&mut self, id: BallId) -> Result<Ball, EngineError> {
        self.runtime.remove_ball(id)
    }

    fn put_back(&mut self, ball: Ball) -> Result<BallId, EngineError> {
        let ball = admit(ball, &self.runtime.params().field)?;
        self.runtime.put_back(ball)
    }

    fn remove_last(&mut self) -> Option<Ball> {
        self.runtime.remove_last()
    }

    fn set_velocity(&mut self, id: BallId, velocity: DVec2) -> Result<(), EngineError> {
        self.runtime.set_velocity(id, check_velocity(velocity)?)
    }

    fn set_mass(&mut self, id: BallId, mass: f64) -> Result<(), EngineError> {
        self.runtime.set_mass(id, check_mass(mass)?)
    }

    fn set_pull(&mut self, force: DVec2) {
        if force.is_finite() {
            self.runtime.set_pull(force);
        }
    }

    fn key_ball(&self) -> Option<BallId> {
        self.runtime.key_ball()
    }

    fn placement(&mut self) -> &mut Placement {
        &mut self.placement
    }

    fn field(&self) -> Field {
        self.runtime.params().field
    }

    fn effects(&self) -> Effects {
        self.runtime.params().effects
    }

    fn set_effects(&mut self, effects: Effects) {
        self.runtime.set_effects(effects);
    }

    fn integrator(&self) -> Integrator {
        self.runtime.params().integrator
    }

    fn set_restitution(&mut self, walls: f64, balls: f64) {
        let params = self.runtime.params();
        let balls_now = params.effects.collisions.map_or(1.0, |c| c.restitution);
        self.runtime
            .set_restitution(clamp_restitution(walls, params.field.restitution), clamp_restitution(balls, balls_now));
    }

    fn wall_impulses(&self) -> WallImpulses {
        self.runtime.wall_impulses()
    }

    fn diagnostics(&mut self) -> Diagnostics {
        let params = self.runtime.params();
        measure(&self.runtime.bodies(), &params.field, &params.effects, self.runtime.wall_impulses())
    }

    fn active_effects(&self) -> Vec<String> {
        // Attraction is summed as lockstep sums it, switched by the same rule: from the monitor's
        // tree from TREE_MIN_BALLS balls on, directly below (the runtime's counters say which
        // the ball cycles actually took).
        let effects = self.runtime.params().effects;
        let n = self.runtime.ball_count();
        effects
            .active_names()
            .iter()
            .map(|&s| match (s, &effects.attraction) {
                ("attraction", Some(att)) => AttractionMethod::choose(n, att).label(),
                _ => s,
            })
            .map(String::from)
            .collect()
    }

    fn rate_unit(&self) -> &'static str {
        "cycles/s per ball"
    }

    fn rate(&mut self) -> f64 {
        self.last_rate = self.runtime.stats().ball_rate_median;
        self.last_rate
    }

    fn figures(&mut self) -> EngineFigures {
        let stats = self.runtime.stats();
        EngineFigures {
            dt: self.cycle.as_secs_f64(),
            steps: 0,
            rate: stats.ball_rate_median,
            phases: None,
            state_hash: None,
            threads: None,
            runtime: Some(stats),
            exact: None,
        }
    }

    fn shutdown(&mut self) -> Shutdown {
        self.clock.rebase(false);
        let report = self.runtime.shutdown();
        Shutdown { threads_joined: report.joined, panics: report.panics, seconds: report.seconds }
    }
}
