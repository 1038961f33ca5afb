//! The engine behind the window: the threaded runtime (the default) or the lockstep engine,
//! behind one set of commands. Only commands go in; the window reads samples.

use std::time::{Duration, Instant};

use glam::DVec2;

use crate::lockstep::Lockstep;
use crate::physics::{Ball, BallId, BallKind, Effects, WallImpulses};
use crate::runtime::{BallRecord, Runtime, next_uniform};
use crate::scene::Scene;

/// Which engine runs the field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EngineKind {
    Threaded,
    Lockstep,
}

impl EngineKind {
    pub fn name(self) -> &'static str {
        match self {
            EngineKind::Threaded => "threaded",
            EngineKind::Lockstep => "lockstep",
        }
    }
}

/// The longest stretch of time one window tick advances the lockstep engine: after a stall the
/// game slows down rather than running hundreds of steps in one go.
const MAX_TICK: f64 = 0.1;

enum Inner {
    Threaded(Runtime),
    Lockstep { engine: Box<Lockstep>, last: Instant, carry: f64 },
}

pub struct Sim {
    kind: EngineKind,
    inner: Inner,
    paused: bool,
    time_scale: f64,
    /// Threaded single step: pause again at this instant.
    step_until: Option<Instant>,
    /// What one single step advances (the window's sampling period).
    step: Duration,
    records: Vec<BallRecord>,
    rng: u64,
    /// Steps (lockstep) done since the rate was last read, and since when.
    rate_steps: u64,
    rate_since: Instant,
    last_rate: f64,
}

impl Sim {
    pub fn start(scene: &Scene, kind: EngineKind, step: Duration) -> Result<Sim, String> {
        let inner = match kind {
            EngineKind::Threaded => {
                let config = crate::headless::runtime_config(scene);
                Inner::Threaded(Runtime::start(scene, config).map_err(|e| e.to_string())?)
            }
            EngineKind::Lockstep => {
                Inner::Lockstep { engine: Box::new(Lockstep::new(scene)), last: Instant::now(), carry: 0.0 }
            }
        };
        Ok(Sim {
            kind,
            inner,
            paused: false,
            time_scale: 1.0,
            step_until: None,
            step,
            records: Vec::new(),
            rng: scene.seed ^ 0x9E37_79B9_7F4A_7C15,
            rate_steps: 0,
            rate_since: Instant::now(),
            last_rate: 0.0,
        })
    }

    pub fn kind(&self) -> EngineKind {
        self.kind
    }

    /// Advances the lockstep engine by the wall time since the last tick (times the time scale);
    /// ends a threaded single step.
    pub fn tick(&mut self) {
        let (paused, scale) = (self.paused, self.time_scale);
        match &mut self.inner {
            Inner::Threaded(rt) => {
                if let Some(t) = self.step_until
                    && Instant::now() >= t
                {
                    rt.pause();
                    self.step_until = None;
                }
            }
            Inner::Lockstep { engine, last, carry } => {
                let now = Instant::now();
                let elapsed = (now - *last).as_secs_f64().min(MAX_TICK);
                *last = now;
                if !paused {
                    let t = elapsed * scale + *carry;
                    let n = (t / engine.dt()).floor();
                    *carry = t - n * engine.dt();
                    engine.run(n as u64);
                    self.rate_steps += n as u64;
                }
            }
        }
    }

    /// The balls now, into `out` (cleared first).
    pub fn sample(&mut self, out: &mut Vec<Ball>) {
        out.clear();
        match &self.inner {
            Inner::Threaded(rt) => {
                rt.snapshot_into(&mut self.records);
                out.extend(self.records.iter().map(|r| r.ball));
            }
            Inner::Lockstep { engine, .. } => {
                // Straight into `out` (no 5.6 MB temporary at 100,000 balls every tick).
                let bodies = engine.bodies();
                out.extend((0..bodies.len()).map(|i| bodies.get(i)));
            }
        }
    }

    pub fn effects(&self) -> Effects {
        match &self.inner {
            Inner::Threaded(rt) => rt.params().effects,
            Inner::Lockstep { engine, .. } => *engine.effects(),
        }
    }

    pub fn field(&self) -> crate::physics::Field {
        match &self.inner {
            Inner::Threaded(rt) => rt.params().field,
            Inner::Lockstep { engine, .. } => *engine.field(),
        }
    }

    pub fn set_effects(&mut self, effects: Effects) {
        match &mut self.inner {
            Inner::Threaded(rt) => rt.set_effects(effects),
            Inner::Lockstep { engine, .. } => engine.set_effects(effects),
        }
    }

    /// The pull on the key ball, N (zero releases it).
    pub fn set_pull(&mut self, force: DVec2) {
        match &mut self.inner {
            Inner::Threaded(rt) => rt.set_pull(force),
            Inner::Lockstep { engine, .. } => engine.set_pull(force),
        }
    }

    pub fn add_ball(&mut self, ball: Ball) -> Result<BallId, String> {
        match &mut self.inner {
            Inner::Threaded(rt) => rt.add_ball(ball).map_err(|e| e.to_string()),
            Inner::Lockstep { engine, .. } => {
                let f = *engine.field();
                let r = ball.radius();
                let mut ball = ball;
                ball.position.x = ball.position.x.clamp(r, (f.width - r).max(r));
                ball.position.y = ball.position.y.clamp(r, (f.height - r).max(r));
                engine.add_ball(ball).map_err(|e| e.to_string())
            }
        }
    }

    /// Adds a ball at rest at a free spot.
    pub fn add_ball_at_free_spot(&mut self, mass: f64, diameter: f64) -> Result<BallId, String> {
        if let Inner::Threaded(rt) = &self.inner {
            return rt.add_ball_at_free_spot(mass, diameter).map_err(|e| e.to_string());
        }
        let mut balls = Vec::new();
        self.sample(&mut balls);
        let field = self.field();
        let r = 0.5 * diameter;
        for _ in 0..1000 {
            let u = next_uniform(&mut self.rng);
            let v = next_uniform(&mut self.rng);
            let p = DVec2::new(r + u * (field.width - diameter), r + v * (field.height - diameter));
            if balls.iter().all(|b| b.position.distance(p) >= b.radius() + r) {
                return self.add_ball(Ball {
                    id: BallId(0),
                    kind: BallKind::Ball,
                    position: p,
                    velocity: DVec2::ZERO,
                    mass,
                    diameter,
                });
            }
        }
        Err(format!("no free spot on the field for a ball of diameter {diameter} m"))
    }

    /// Takes a ball off the field (the mouse picked it up).
    pub fn take_ball(&mut self, id: BallId) -> Option<Ball> {
        match &mut self.inner {
            Inner::Threaded(rt) => {
                let ball = rt.snapshot().into_iter().find(|r| r.ball.id == id)?.ball;
                rt.remove_ball(id).ok()?;
                Some(ball)
            }
            Inner::Lockstep { engine, .. } => engine.remove_ball(id).ok(),
        }
    }

    pub fn remove_last(&mut self) -> bool {
        match &mut self.inner {
            Inner::Threaded(rt) => rt.remove_last().is_some(),
            Inner::Lockstep { engine, .. } => engine.remove_last().is_some(),
        }
    }

    pub fn is_paused(&self) -> bool {
        self.paused
    }

    pub fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
        self.step_until = None;
        match &mut self.inner {
            Inner::Threaded(rt) => {
                if paused {
                    rt.pause()
                } else {
                    rt.resume()
                }
            }
            Inner::Lockstep { last, .. } => *last = Instant::now(),
        }
    }

    /// While paused: advances one sampling period of simulated time, then stays paused.
    pub fn single_step(&mut self) {
        if !self.paused {
            return;
        }
        let scale = self.time_scale;
        match &mut self.inner {
            Inner::Threaded(rt) => {
                rt.resume();
                self.step_until = Some(Instant::now() + self.step);
            }
            Inner::Lockstep { engine, last, .. } => {
                let n = (self.step.as_secs_f64() * scale / engine.dt()).round().max(1.0) as u64;
                engine.run(n);
                self.rate_steps += n;
                *last = Instant::now();
            }
        }
    }

    /// Walls and ball–ball collisions (if on) alike.
    pub fn set_restitution(&mut self, e: f64) {
        let e = e.clamp(0.0, 1.0);
        match &mut self.inner {
            Inner::Threaded(rt) => rt.set_restitution(e, e),
            Inner::Lockstep { engine, .. } => {
                engine.set_field_restitution(e);
                let mut effects = *engine.effects();
                if let Some(c) = &mut effects.collisions {
                    c.restitution = e;
                }
                engine.set_effects(effects);
            }
        }
    }

    pub fn set_time_scale(&mut self, scale: f64) {
        if !(scale.is_finite() && scale >= 0.0) {
            return;
        }
        self.time_scale = scale;
        if let Inner::Threaded(rt) = &self.inner {
            rt.set_time_scale(scale);
        }
    }

    /// The key ball's mass, kg. The lockstep engine has no call for it, so there the key ball is
    /// taken off and put back with the new mass (same place and velocity, a new id).
    pub fn set_key_mass(&mut self, mass: f64) {
        if !(mass.is_finite() && mass > 0.0) {
            return;
        }
        match &mut self.inner {
            Inner::Threaded(rt) => rt.set_key_mass(mass),
            Inner::Lockstep { engine, .. } => {
                if let Some(i) = engine.bodies().key_index() {
                    let id = engine.bodies().id[i];
                    if let Ok(mut key) = engine.remove_ball(id) {
                        key.mass = mass;
                        let _ = engine.add_ball(key);
                    }
                }
            }
        }
    }

    pub fn wall_impulses(&self) -> WallImpulses {
        match &self.inner {
            Inner::Threaded(rt) => rt.wall_impulses(),
            Inner::Lockstep { engine, .. } => engine.wall_impulses(),
        }
    }

    /// Updates per second: the median ball thread's cycles (threaded), or steps (lockstep).
    /// Call it rarely (the threaded figure reads the whole table).
    pub fn rate(&mut self) -> f64 {
        match &self.inner {
            Inner::Threaded(rt) => {
                let stats = rt.stats();
                self.last_rate = stats.ball_rate_median;
            }
            Inner::Lockstep { .. } => {
                let secs = self.rate_since.elapsed().as_secs_f64();
                if secs > 0.0 {
                    self.last_rate = self.rate_steps as f64 / secs;
                }
                self.rate_steps = 0;
                self.rate_since = Instant::now();
            }
        }
        self.last_rate
    }

    /// Stops every thread (threaded) and joins it.
    pub fn shutdown(&mut self) {
        if let Inner::Threaded(rt) = &self.inner {
            let report = rt.shutdown();
            for p in report.panics {
                log::error!("a ball thread had panicked: {p}");
            }
        }
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        self.shutdown();
    }
}
