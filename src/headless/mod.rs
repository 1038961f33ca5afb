//! The headless run (`ballfield headless`): a scene advanced without a window by any engine,
//! with its state files, its JSON report and, if asked, PNG frames drawn offscreen. No window
//! and no display are involved: never a winit event loop here.
//!
//! One run loop for every engine ([`run`]): the engine is advanced from frame instant to frame
//! instant (or straight to the end when no frames are recorded) through the engine interface
//! alone. Frames are taken every `every` seconds of the engine's clock: simulated time, which for
//! the threaded engine runs with the wall clock. A frame whose instant passed while the previous
//! one was drawn (the threaded engine does not wait for the drawing) is skipped and counted. The
//! time spent drawing and writing is not in the report's `wall_seconds`, so a lockstep run with
//! frames is the same run, bit for bit and in its timing, as one without.

mod frames;
mod report;
mod state_file;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use cpu_time::ProcessTime;

use crate::engine::{self, Engine, EngineError, EngineKind};
use crate::physics::{Ball, Bodies, Integrator, measure};
use crate::scene::Scene;

pub use frames::{FrameOptions, FramesError, FramesWritten, frame_path};
pub use report::{MemoryUse, RunReport, ThreadedFigures};
pub use state_file::{HEADER, StateFileError, parse_state, read_state, write_state};

use frames::Recorder;

/// How long to run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RunLength {
    /// Seconds on the engine's clock (rounded to whole steps or ball cycles).
    Duration(f64),
    /// Steps of `dt` (lockstep), or ball cycles of time (threaded).
    Steps(u64),
}

/// What `ballfield headless` was asked to do: the command line's options, parsed.
#[derive(Clone, Debug)]
pub struct HeadlessOptions {
    /// What the scene is called in the report (its file or built-in name).
    pub scene_file: String,
    /// How long to run (`--duration` or `--steps`).
    pub length: RunLength,
    /// Overrides the scene's `simulation.dt`.
    pub dt: Option<f64>,
    /// Overrides the scene's integrator.
    pub integrator: Option<Integrator>,
    /// The engine that advances the balls (`--engine`).
    pub engine: EngineKind,
    /// A state CSV whose balls replace the scene's (`--state-in`).
    pub state_in: Option<PathBuf>,
    /// Where to write the balls at the end, as a state CSV (`--state-out`).
    pub state_out: Option<PathBuf>,
    /// Threads for the lockstep engine (None: every core).
    pub threads: Option<usize>,
    /// Also draw PNG frames.
    pub frames: Option<FrameOptions>,
}

/// Why a headless run failed, or why it could not write its state file.
#[derive(Debug, thiserror::Error)]
pub enum HeadlessError {
    /// The `--state-in` file could not be read or parsed.
    #[error("--state-in: {0}")]
    StateIn(StateFileError),
    /// The `--state-out` file could not be written.
    #[error("--state-out: {0}")]
    StateOut(StateFileError),
    /// The engine refused to start on the scene (a ball it rejects, a thread it could not spawn).
    #[error("cannot start the {0} engine: {1}")]
    Engine(EngineKind, EngineError),
    /// The `--state-in` file holds more balls than the scene allows.
    #[error("--state-in {file}: {count} balls, more than simulation.max-balls = {limit} of the scene")]
    TooManyBalls {
        /// The `--state-in` file.
        file: PathBuf,
        /// Balls in the file.
        count: usize,
        /// The scene's `simulation.max-balls`.
        limit: usize,
    },
    /// A frame could not be drawn or written.
    #[error(transparent)]
    Frames(#[from] FramesError),
}

/// What a run produced.
#[derive(Debug)]
pub struct Outcome {
    /// The run's figures, for `--report`.
    pub report: RunReport,
    /// What was drawn, when frames were asked for.
    pub frames: Option<FramesWritten>,
    /// Whether `--state-out` could be written (the run's other outputs stand either way).
    pub state_out: Result<(), HeadlessError>,
}

/// Number of steps of `dt` in `length`.
pub fn steps_for(length: RunLength, dt: f64) -> u64 {
    match length {
        RunLength::Steps(n) => n,
        RunLength::Duration(d) => (d / dt).round() as u64,
    }
}

/// The scene as the options change it: dt, integrator, and the balls of `--state-in`.
pub fn prepare(scene: &Scene, options: &HeadlessOptions) -> Result<Scene, HeadlessError> {
    let mut scene = scene.clone();
    if let Some(dt) = options.dt {
        scene.dt = dt;
    }
    if let Some(integrator) = options.integrator {
        scene.integrator = integrator;
    }
    if let Some(path) = &options.state_in {
        let balls = read_state(path, &scene.field).map_err(HeadlessError::StateIn)?;
        if balls.len() > scene.max_balls {
            return Err(HeadlessError::TooManyBalls { file: path.clone(), count: balls.len(), limit: scene.max_balls });
        }
        scene.balls = balls;
    }
    Ok(scene)
}

/// Runs `scene` as `options` say: the one run loop of every engine. Writes `--state-out` (if
/// asked) and the frames, and returns the report.
///
/// A failure to write `--state-out` is returned in [`Outcome::state_out`], beside the report,
/// so that the caller still writes the run's other outputs.
pub fn run(scene: &Scene, options: &HeadlessOptions) -> Result<Outcome, HeadlessError> {
    let scene = prepare(scene, options)?;
    // The recorder first: the driver compiles its shaders on its first frame (hundreds of ms on a
    // CPU adapter), which must not fall into a timed or threaded run.
    let mut recorder = match &options.frames {
        Some(frames) => Some(Recorder::new(&scene, frames)?),
        None => None,
    };
    // The start is the scene's own state, measured: the threaded engine's balls start moving
    // while the others' threads are still being spawned.
    let start = measure(&Bodies::from_balls(&scene.balls), &scene.field, &scene.effects, Default::default());
    let rss_before = MemoryUse::now();
    let mut engine =
        engine::start(options.engine, &scene, options.threads).map_err(|e| HeadlessError::Engine(options.engine, e))?;
    let step = engine.step();
    let end = steps_for(options.length, step) as f64 * step;
    let mut stepping = Stepping::default();
    let mut balls = Vec::new();
    let mut outcome = Ok(());
    if let (Some(rec), Some(frames)) = (&mut recorder, &options.frames) {
        outcome = record(engine.as_mut(), rec, frames.every, (end, step), &mut stepping, &mut balls);
    }
    if outcome.is_ok() {
        advance(engine.as_mut(), end, &mut stepping);
    }
    engine.quiesce();
    let report = finish(&scene, options, engine.as_mut(), start, stepping, rss_before, &mut balls);
    let shutdown = engine.shutdown();
    for p in &shutdown.panics {
        log::error!("a ball thread had panicked: {p}");
    }
    outcome?;
    let mut report = report;
    if let Some(t) = &mut report.runtime {
        t.shutdown_seconds = shutdown.seconds;
        t.threads_joined = shutdown.threads_joined;
    }
    let state_out = match &options.state_out {
        Some(path) => write_state(path, &balls).map_err(HeadlessError::StateOut),
        None => Ok(()),
    };
    Ok(Outcome { report, frames: recorder.map(Recorder::finish), state_out })
}

/// The wall-clock time a run spent advancing its engine, and the process's CPU time over the
/// same stretches (not while frames are drawn, nor while the engine quiesces at the end), so
/// that their ratio is the cores the engine kept busy.
#[derive(Clone, Copy, Debug, Default)]
struct Stepping {
    wall: Duration,
    cpu: Duration,
}

/// Advances `engine` to `t`, adding the time it took to `stepping`.
fn advance(engine: &mut dyn Engine, t: f64, stepping: &mut Stepping) {
    let (clock, cpu) = (Instant::now(), ProcessTime::now());
    engine.advance_to(t);
    stepping.wall += clock.elapsed();
    stepping.cpu += cpu.elapsed();
}

/// Draws a frame every `every` seconds of the engine's clock from 0 to `end` inclusive (to a hair
/// of the engine's `step`).
fn record(
    engine: &mut dyn Engine,
    rec: &mut Recorder,
    every: f64,
    (end, step): (f64, f64),
    stepping: &mut Stepping,
    balls: &mut Vec<Ball>,
) -> Result<(), HeadlessError> {
    let field = engine.field();
    let mut k = 0u64;
    loop {
        // Frame k shows the engine at k·every (lockstep: the first step at or after it).
        let at = k as f64 * every;
        if at > end + 1e-9 * step {
            return Ok(());
        }
        let now = engine.time();
        if k > 0 && now > at + every {
            // Drawing the last frame took longer than the interval (the threaded engine ran on
            // meanwhile): skip the instants missed.
            let next = (now / every).ceil() as u64;
            rec.skipped((next - k) as usize);
            k = next;
            continue;
        }
        advance(engine, at, stepping);
        engine.sample(balls);
        rec.write(field, balls)?;
        k += 1;
    }
}

/// The report of a run that has just stopped (`engine` quiesced); leaves the final balls in
/// `balls`.
#[allow(clippy::too_many_arguments)]
fn finish(
    scene: &Scene,
    options: &HeadlessOptions,
    engine: &mut dyn Engine,
    start: crate::physics::Diagnostics,
    stepping: Stepping,
    rss_before: Option<u64>,
    balls: &mut Vec<Ball>,
) -> RunReport {
    let figures = engine.figures();
    let end = engine.diagnostics();
    engine.sample(balls);
    let wall_seconds = stepping.wall.as_secs_f64();
    let cpu_seconds = stepping.cpu.as_secs_f64();
    RunReport {
        scene: scene.name.clone(),
        scene_file: options.scene_file.clone(),
        engine: options.engine.name().into(),
        integrator: engine.motion().into(),
        dt: figures.dt,
        steps: figures.steps,
        simulated_seconds: engine.time(),
        wall_seconds,
        steps_per_second: figures.rate,
        balls: balls.len(),
        active_effects: engine.active_effects(),
        start,
        end,
        phases: figures.phases,
        state_hash: figures.state_hash.map(|h| format!("{h:016x}")),
        threads: figures.threads,
        memory: MemoryUse::since(rss_before, balls.len()),
        runtime: figures.runtime.map(|stats| ThreadedFigures {
            stats,
            cpu_seconds,
            cpu_cores_used: cpu_seconds / wall_seconds.max(1e-9),
            shutdown_seconds: 0.0,
            threads_joined: 0,
        }),
        exact: figures.exact,
    }
}
