//! The one seam between the engines and everything that drives them (DESIGN.md, "engine/").
//!
//! The window, the headless run and the panel talk to an engine only through [`Engine`]: they
//! advance it, sample its balls, pull the key ball, add, remove and change balls, switch effects
//! and read its figures. Whatever an engine lacks it gains here, so no caller works around it.
//! Everything that decides *physics* lives in [`crate::physics`], which every engine calls.
//!
//! **A trait, not an enum.** The callers hold a `Box<dyn Engine>` and never ask which engine it
//! is to decide what to do: the engines differ in how they keep time and where their balls live
//! (one loop over arrays, one thread per ball), not in the commands they take. A trait keeps each
//! engine's code in its own module, lets a third engine (the exact, event-driven one) join by
//! implementing it without touching a caller, and costs one virtual call per command — a handful
//! per 15 ms frame, nothing in the hot loops, which stay inside each engine.
//!
//! **Time.** Every engine has a simulated clock ([`Engine::time`]). The lockstep engine moves it
//! by whole steps of `dt` when told to; the threaded engine's balls move it by themselves, in
//! wall-clock time times the time scale, while it is not paused. [`Engine::advance_to`] is the
//! one blocking way to get to an instant (headless runs and their frames); [`Engine::tick`] is
//! the window's non-blocking one.

mod exact;
pub mod lockstep;
mod lockstep_engine;
pub mod runtime;
mod threaded_engine;

use std::time::Duration;

use glam::DVec2;
use serde::Serialize;

use crate::physics::{Ball, BallId, BallKind, Diagnostics, Effects, Field, Integrator, WallImpulses};
use crate::scene::Scene;

/// The lockstep engine's and the threaded runtime's own figures, as [`EngineFigures`] carries them.
pub use lockstep::StepCounters;
pub use runtime::RuntimeStats;

pub use exact::{ExactCounters, ExactEngine, ExactParams, ExactStats, REST_HEIGHT};
pub use lockstep_engine::LockstepEngine;
pub use threaded_engine::{ThreadedEngine, runtime_config};

/// Which engine advances the balls: the command line's `--engine`, the window's E key and the
/// panel's readout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum EngineKind {
    /// One thread per ball and a collision monitor (the game's default); its clock is the wall
    /// clock times the time scale.
    Threaded,
    /// Every ball together, a fixed dt, bit-reproducible (the reference for tests and benches).
    Lockstep,
    /// Event-driven: every collision at its exact instant, on exact parabolas (collisions,
    /// uniform gravity and the key ball's pull only).
    Exact,
}

impl EngineKind {
    /// Every engine, in the order the window's E key cycles through them.
    pub const ALL: [EngineKind; 3] = [EngineKind::Threaded, EngineKind::Lockstep, EngineKind::Exact];

    /// The name on the command line (`--engine threaded|lockstep`), in reports and on the panel.
    pub fn name(self) -> &'static str {
        match self {
            EngineKind::Threaded => "threaded",
            EngineKind::Lockstep => "lockstep",
            EngineKind::Exact => "exact",
        }
    }

    /// The engine after this one (the E key).
    pub fn next(self) -> EngineKind {
        let k = Self::ALL.iter().position(|&e| e == self).unwrap_or(0);
        Self::ALL[(k + 1) % Self::ALL.len()]
    }
}

impl std::fmt::Display for EngineKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why an engine refused a command (or could not start).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// Adding a ball would pass the scene's `simulation.max-balls`.
    #[error("the field is full: {limit} balls is the limit (simulation.max-balls)")]
    TooManyBalls {
        /// The scene's limit on the number of balls.
        limit: usize,
    },
    /// No ball on the field has this id (it was never added, or has been removed).
    #[error("no ball with id {0}")]
    NoSuchBall(BallId),
    /// [`Engine::put_back`] was given a ball whose id is already on the field.
    #[error("a ball with id {0} is already on the field")]
    IdInUse(BallId),
    /// A ball with a non-finite value, a mass or diameter that is not positive, or a diameter
    /// wider than the field; the text shows the ball (or the diameter) as given.
    #[error("invalid ball: {0}")]
    InvalidBall(String),
    /// A mass (kg) that is not finite or not greater than zero.
    #[error("invalid mass {0} kg: it must be finite and greater than zero")]
    InvalidMass(f64),
    /// A velocity (x, y in m/s) with a non-finite component.
    #[error("invalid velocity [{0}, {1}] m/s: it must be finite")]
    InvalidVelocity(f64, f64),
    /// [`free_spot`] found no place for a ball of this diameter (m) in its 1,000 tries.
    #[error("no free spot on the field for a ball of diameter {0} m")]
    NoFreeSpot(f64),
    /// The operating system refused to start a ball or monitor thread; the text is its error.
    #[error("could not start a thread: {0}")]
    Spawn(String),
    /// The engine cannot run an effect the scene turns on (the exact engine: drag, attraction).
    #[error(
        "the {engine} engine cannot run {effects}: it runs collisions, uniform gravity and the key ball's pull \
         only; turn {effects} off or use the lockstep or threaded engine"
    )]
    Unsupported {
        /// The engine that refused.
        engine: EngineKind,
        /// The effects it cannot run, by name ("drag", "attraction", "drag and attraction").
        effects: String,
    },
}

/// What an engine measured about its own run, for the report: the part of the figures that only
/// one kind of engine has.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct EngineFigures {
    /// The step (lockstep) or the ball cycle (threaded), s.
    pub dt: f64,
    /// Steps taken (lockstep; 0 for the threaded engine, whose balls each take their own).
    pub steps: u64,
    /// Steps per second of stepping (lockstep) or the median ball's updates per second.
    pub rate: f64,
    /// Time per phase, summed over the run (lockstep).
    pub phases: Option<StepCounters>,
    /// FNV-1a of the state's bits (lockstep).
    pub state_hash: Option<u64>,
    /// Threads the lockstep engine shares its phases over.
    pub threads: Option<usize>,
    /// The threaded runtime's own figures.
    pub runtime: Option<RuntimeStats>,
    /// The exact engine's own figures.
    pub exact: Option<ExactStats>,
}

/// How an engine's shutdown went.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shutdown {
    /// Threads joined (0 for an engine without threads of its own).
    pub threads_joined: usize,
    /// Messages of ball threads that had panicked.
    pub panics: Vec<String>,
    /// Wall-clock time the shutdown took, s (0 for an engine without threads).
    pub seconds: f64,
}

/// The one interface to an engine (see the module comment).
pub trait Engine: Send {
    /// Which engine this is (for the report and the panel; callers never branch on it).
    fn kind(&self) -> EngineKind;

    // ---- time ---------------------------------------------------------------------------

    /// Simulated seconds since the start.
    fn time(&self) -> f64;
    /// Blocks until the simulated clock reaches `t` (the lockstep engine: the first whole step at
    /// or after `t`, to a hair of rounding). Returns at once if `t` has passed, or if the engine
    /// is paused (the threaded engine's clock then stands still) or, threaded, its time scale
    /// is 0.
    fn advance_to(&mut self, t: f64);
    /// Advances `n` steps: of `dt` (lockstep), or `n` ball cycles of time (threaded). Nothing
    /// while paused.
    fn advance_steps(&mut self, n: u64);
    /// The length of one of [`Engine::advance_steps`]'s steps, simulated s: the scene's dt
    /// (lockstep and exact) or its ball cycle (threaded).
    fn step(&self) -> f64;
    /// The window's tick, never blocking: `wall` is the wall-clock time since the last tick. The
    /// lockstep engine runs the steps that time (times the time scale) is worth, counting at most
    /// 0.1 s of it (after a stall the game slows down rather than catching up) and carrying the
    /// part of a step left over to the next tick; the threaded one ends a single step that is
    /// due.
    fn tick(&mut self, wall: Duration);
    /// Pauses (the clock stands still, the balls keep their state) or resumes the motion.
    fn set_paused(&mut self, paused: bool);
    /// Whether the engine is paused.
    fn is_paused(&self) -> bool;
    /// While paused: advances `span` of wall-clock time's worth of simulation (times the time
    /// scale), then stays paused.
    fn single_step(&mut self, span: Duration);
    /// Simulated seconds per wall-clock second (slow motion below 1); applies to [`Engine::tick`]
    /// and to the threaded engine's clock. A negative or non-finite scale is ignored.
    fn set_time_scale(&mut self, scale: f64);
    /// Simulated seconds per wall-clock second now (see [`Engine::set_time_scale`]).
    fn time_scale(&self) -> f64;
    /// Stops the motion so the balls can be read at one instant (the end of a run): pauses and,
    /// for the threaded engine, waits until every ball has finished its cycle.
    fn quiesce(&mut self);

    // ---- balls --------------------------------------------------------------------------

    /// The balls now, into `out` (cleared first), sorted by id.
    fn sample(&mut self, out: &mut Vec<Ball>);
    /// Number of balls on the field now, the key ball included.
    fn ball_count(&self) -> usize;
    /// Adds a ball with a fresh id (its `id` is ignored), moved inside the field if it is not.
    fn add_ball(&mut self, ball: Ball) -> Result<BallId, EngineError>;
    /// Takes a ball off the field and returns it as it was.
    fn remove_ball(&mut self, id: BallId) -> Result<Ball, EngineError>;
    /// Puts a ball taken off with [`Engine::remove_ball`] back on the field with its own id (the
    /// mouse's drop after a grab), moved inside the field if it is not. Refused if a ball with
    /// that id is on the field.
    fn put_back(&mut self, ball: Ball) -> Result<BallId, EngineError>;
    /// Takes off the most recently added ball that is not the key ball.
    fn remove_last(&mut self) -> Option<Ball>;
    /// Sets a ball's velocity in place, keeping its id (the mouse's throw).
    fn set_velocity(&mut self, id: BallId, velocity: DVec2) -> Result<(), EngineError>;
    /// Sets a ball's mass in place, keeping its id and velocity (the panel's key-ball slider).
    fn set_mass(&mut self, id: BallId, mass: f64) -> Result<(), EngineError>;
    /// The pull on the key ball, N (zero releases it). Ignored when there is no key ball, and a
    /// force with a non-finite component is ignored.
    fn set_pull(&mut self, force: DVec2);
    /// The id of the key ball, if there is one.
    fn key_ball(&self) -> Option<BallId>;

    /// Adds a ball of this size at rest at a free spot of the field, chosen by the engine's
    /// placement sequence (seeded by the scene: the same spots on every run of a lockstep game).
    fn add_ball_at_free_spot(&mut self, mass: f64, diameter: f64) -> Result<BallId, EngineError> {
        let field = self.field();
        let mut balls = Vec::new();
        self.sample(&mut balls);
        let position = free_spot(&field, &balls, diameter, self.placement())?;
        self.add_ball(Ball { id: BallId(0), kind: BallKind::Ball, position, velocity: DVec2::ZERO, mass, diameter })
    }
    /// The state of the engine's placement sequence (see [`Engine::add_ball_at_free_spot`]).
    fn placement(&mut self) -> &mut Placement;

    // ---- parameters ---------------------------------------------------------------------

    /// The field: its size (m) and the walls' restitution now.
    fn field(&self) -> Field;
    /// The effects that act now (collisions, gravity, drag, attraction) and their parameters.
    fn effects(&self) -> Effects;
    /// Replaces the effects (the window's G/D/N/C keys and the panel). The balls keep their
    /// state; the new forces act from the next step (lockstep) or each ball's next cycle
    /// (threaded).
    fn set_effects(&mut self, effects: Effects);
    /// The integration method the balls are advanced with (the scene's `simulation.integrator`).
    fn integrator(&self) -> Integrator;
    /// How the balls move between contacts, for the report: the integrator's name, or what an
    /// engine that integrates nothing does instead.
    fn motion(&self) -> &'static str {
        self.integrator().name()
    }
    /// Restitution of the walls and of ball–ball collisions (if on), each clamped to [0, 1].
    fn set_restitution(&mut self, walls: f64, balls: f64);

    // ---- figures ------------------------------------------------------------------------

    /// The impulse each wall took so far, N·s (the pressure gauge).
    fn wall_impulses(&self) -> WallImpulses;
    /// Energies, momentum, overlap and wall impulses now.
    fn diagnostics(&mut self) -> Diagnostics;
    /// The effects that run, by name; attraction says how it is summed now.
    fn active_effects(&self) -> Vec<String>;
    /// Updates per second since the last call: steps (lockstep), events (exact) or the median
    /// ball's cycles (threaded). Call it rarely (the threaded figure reads the whole table).
    fn rate(&mut self) -> f64;
    /// What [`Engine::rate`] counts, as the panel labels it ("steps/s").
    fn rate_unit(&self) -> &'static str;
    /// The figures only this kind of engine has, for the report.
    fn figures(&mut self) -> EngineFigures;
    /// Stops and joins every thread the engine owns. The engine takes no command afterwards.
    fn shutdown(&mut self) -> Shutdown;
}

/// Starts the engine `kind` on `scene`. `threads` is the lockstep engine's thread count (`None`:
/// every core).
pub fn start(kind: EngineKind, scene: &Scene, threads: Option<usize>) -> Result<Box<dyn Engine>, EngineError> {
    Ok(match kind {
        EngineKind::Lockstep => Box::new(LockstepEngine::new(scene, threads)),
        EngineKind::Threaded => Box::new(ThreadedEngine::start(scene)?),
        EngineKind::Exact => Box::new(ExactEngine::new(scene)?),
    })
}

/// A splitmix64 sequence of uniform numbers in [0, 1): where new balls are placed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Placement(u64);

impl Placement {
    /// The sequence for `seed` (the scene's `simulation.seed`): the same seed gives the same
    /// spots.
    pub fn new(seed: u64) -> Placement {
        Placement(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// The next number, uniform in [0, 1) with 53 random bits.
    pub fn next_uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Tries 1,000 spots from `placement` for a ball of `diameter` that touches neither a wall nor
/// any of `balls`.
pub fn free_spot(
    field: &Field,
    balls: &[Ball],
    diameter: f64,
    placement: &mut Placement,
) -> Result<DVec2, EngineError> {
    let r = 0.5 * diameter;
    if !(diameter > 0.0 && diameter <= field.width.min(field.height)) {
        return Err(EngineError::InvalidBall(format!("diameter {diameter} m")));
    }
    for _ in 0..1000 {
        let (u, v) = (placement.next_uniform(), placement.next_uniform());
        let p = DVec2::new(r + u * (field.width - diameter), r + v * (field.height - diameter));
        if balls.iter().all(|b| b.position.distance(p) >= b.radius() + r) {
            return Ok(p);
        }
    }
    Err(EngineError::NoFreeSpot(diameter))
}

/// Checks a ball for [`Engine::add_ball`] and moves it inside the field: every engine takes the
/// same balls.
pub fn admit(mut ball: Ball, field: &Field) -> Result<Ball, EngineError> {
    if !(ball.is_finite() && ball.mass > 0.0 && ball.diameter > 0.0 && ball.diameter <= field.width.min(field.height)) {
        return Err(EngineError::InvalidBall(format!("{ball:?}")));
    }
    let r = ball.radius();
    ball.position.x = ball.position.x.clamp(r, field.width - r);
    ball.position.y = ball.position.y.clamp(r, field.height - r);
    Ok(ball)
}

/// Checks a mass for [`Engine::set_mass`].
pub fn check_mass(mass: f64) -> Result<f64, EngineError> {
    if mass.is_finite() && mass > 0.0 { Ok(mass) } else { Err(EngineError::InvalidMass(mass)) }
}

/// Checks a velocity for [`Engine::set_velocity`].
pub fn check_velocity(v: DVec2) -> Result<DVec2, EngineError> {
    if v.is_finite() { Ok(v) } else { Err(EngineError::InvalidVelocity(v.x, v.y)) }
}

/// Restitution as the engines take it: clamped to [0, 1]; a NaN keeps `current`.
pub fn clamp_restitution(e: f64, current: f64) -> f64 {
    if e.is_nan() { current } else { e.clamp(0.0, 1.0) }
}

/// Compile-time checks: an engine moves to whichever thread drives it (the window's event loop,
/// a headless run, a test), so every engine and the boxed interface are `Send`; the threaded
/// engine's runtime is also shared by reference across threads (its methods take `&self`), so it
/// is `Sync` too. A field that broke either would fail to compile here, not in a caller.
const _: () = {
    const fn send<T: Send + ?Sized>() {}
    const fn sync<T: Sync + ?Sized>() {}
    send::<Box<dyn Engine>>();
    send::<LockstepEngine>();
    send::<ThreadedEngine>();
    send::<ExactEngine>();
    sync::<crate::engine::runtime::Runtime>();
    send::<RuntimeStats>();
    send::<EngineError>();
    sync::<EngineError>();
};
