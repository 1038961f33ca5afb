//! The headless run: a scene stepped without a window, with state files and a JSON report.

use std::path::PathBuf;
use std::time::Instant;

use std::time::Duration;

use cpu_time::ProcessTime;

use crate::lockstep::Lockstep;
use crate::physics::Integrator;
use crate::physics::{AttractionMethod, Bodies, Diagnostics, measure};
use crate::report::ThreadedFigures;
use crate::report::{MemoryUse, RunReport};
use crate::runtime::{Runtime, RuntimeConfig, RuntimeError};
use crate::scene::Scene;
use crate::state_file::{StateFileError, read_state, write_state};

/// How long to run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RunLength {
    /// Simulated seconds (rounded to whole steps).
    Duration(f64),
    Steps(u64),
}

/// Which engine advances the balls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Engine {
    Lockstep,
    /// One thread per ball; the run length is wall-clock time.
    Threaded,
}

impl Engine {
    pub fn name(self) -> &'static str {
        match self {
            Engine::Lockstep => "lockstep",
            Engine::Threaded => "threaded",
        }
    }
}

#[derive(Clone, Debug)]
pub struct HeadlessOptions {
    /// What the scene is called in the report (its file or built-in name).
    pub scene_file: String,
    pub length: RunLength,
    pub dt: Option<f64>,
    pub integrator: Option<Integrator>,
    pub engine: Engine,
    pub state_in: Option<PathBuf>,
    pub state_out: Option<PathBuf>,
    /// Threads for the lockstep engine (None: every core).
    pub threads: Option<usize>,
}

#[derive(Debug, thiserror::Error)]
pub enum HeadlessError {
    #[error("--state-in: {0}")]
    StateIn(StateFileError),
    #[error("--state-out: {0}")]
    StateOut(StateFileError),
    #[error("cannot start the threaded runtime: {0}")]
    Runtime(RuntimeError),
    #[error("--state-in {file}: {count} balls, more than simulation.max-balls = {limit} of the scene")]
    TooManyBalls { file: PathBuf, count: usize, limit: usize },
}

/// Number of steps of `dt` in `length`.
pub fn steps_for(length: RunLength, dt: f64) -> u64 {
    match length {
        RunLength::Steps(n) => n,
        RunLength::Duration(d) => (d / dt).round() as u64,
    }
}

/// Runs `scene` as `options` say and returns the report. Writes `state_out` if asked.
pub fn run(scene: &Scene, options: &HeadlessOptions) -> Result<RunReport, HeadlessError> {
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
    if options.engine == Engine::Threaded {
        return run_threaded(&scene, options);
    }
    let steps = steps_for(options.length, scene.dt);
    let rss_before = MemoryUse::now();
    let mut engine = lockstep_engine(&scene, options);
    let start = engine.diagnostics();
    let clock = Instant::now();
    engine.run(steps);
    let wall_seconds = clock.elapsed().as_secs_f64();
    let mut report = lockstep_report(&scene, options, &engine, start, steps, wall_seconds)?;
    report.memory = MemoryUse::since(rss_before, engine.bodies().len());
    Ok(report)
}

/// The lockstep engine for a scene, with the thread count the options ask for. Shared with
/// `frames`.
pub(crate) fn lockstep_engine(scene: &Scene, options: &HeadlessOptions) -> Lockstep {
    let mut engine = Lockstep::new(scene);
    if let Some(threads) = options.threads {
        engine.set_threads(threads);
    }
    engine
}

/// The report of a finished lockstep run (writes `--state-out` first). Shared with `frames`.
pub(crate) fn lockstep_report(
    scene: &Scene,
    options: &HeadlessOptions,
    engine: &Lockstep,
    start: Diagnostics,
    steps: u64,
    wall_seconds: f64,
) -> Result<RunReport, HeadlessError> {
    let end = engine.diagnostics();
    if let Some(path) = &options.state_out {
        write_state(path, &engine.bodies().to_balls()).map_err(HeadlessError::StateOut)?;
    }
    Ok(RunReport {
        scene: scene.name.clone(),
        scene_file: options.scene_file.clone(),
        engine: Engine::Lockstep.name().into(),
        integrator: scene.integrator.name().into(),
        dt: scene.dt,
        steps,
        simulated_seconds: engine.time(),
        wall_seconds,
        steps_per_second: if wall_seconds > 0.0 { steps as f64 / wall_seconds } else { 0.0 },
        balls: engine.bodies().len(),
        active_effects: engine.active_effects().iter().map(|s| s.to_string()).collect(),
        start,
        end,
        phases: Some(*engine.counters()),
        state_hash: Some(format!("{:016x}", engine.state_hash())),
        threads: Some(engine.threads()),
        memory: None,
        runtime: None,
    })
}

/// The runtime configuration a scene asks for. `BALLFIELD_BALL_WAIT=sleep` makes the ball threads
/// always sleep between cycles, never yield (to measure what yielding gains).
pub(crate) fn runtime_config(scene: &Scene) -> RuntimeConfig {
    RuntimeConfig {
        ball_cycle: Duration::from_secs_f64(scene.ball_cycle),
        max_balls: scene.max_balls,
        yield_when_crowded: std::env::var("BALLFIELD_BALL_WAIT").map_or(true, |v| v != "sleep"),
        ..RuntimeConfig::default()
    }
}

/// Wall-clock seconds a threaded run lasts (`--steps N` means N ball cycles' worth of time).
pub(crate) fn threaded_seconds(scene: &Scene, length: RunLength) -> f64 {
    match length {
        RunLength::Duration(d) => d,
        RunLength::Steps(n) => n as f64 * scene.ball_cycle,
    }
}

/// The scene's own state, measured: the start of a threaded run (its balls start moving while
/// the others' threads are still being spawned).
pub(crate) fn threaded_start(scene: &Scene) -> Diagnostics {
    measure(&Bodies::from_balls(&scene.balls), &scene.field, &scene.effects, Default::default())
}

/// The threaded run: the scene on one thread per ball for a wall-clock duration.
fn run_threaded(scene: &Scene, options: &HeadlessOptions) -> Result<RunReport, HeadlessError> {
    let seconds = threaded_seconds(scene, options.length);
    let start = threaded_start(scene);
    let rss_before = MemoryUse::now();
    let runtime = Runtime::start(scene, runtime_config(scene)).map_err(HeadlessError::Runtime)?;
    let cpu = ProcessTime::now();
    let clock = Instant::now();
    std::thread::sleep(Duration::from_secs_f64(seconds));
    // Peak memory is read before the threads are joined (and their stacks freed).
    let memory = MemoryUse::since(rss_before, scene.balls.len());
    let mut report = finish_threaded(scene, options, runtime, start, cpu, clock)?;
    report.memory = memory;
    Ok(report)
}

/// Ends a threaded run: pauses (so the snapshot is of balls at rest in time), reads the figures,
/// joins every thread, writes `--state-out` and builds the report. Shared with `frames`.
pub(crate) fn finish_threaded(
    scene: &Scene,
    options: &HeadlessOptions,
    runtime: Runtime,
    start: Diagnostics,
    cpu: ProcessTime,
    clock: Instant,
) -> Result<RunReport, HeadlessError> {
    if !runtime.settle(Duration::from_secs(5)) {
        log::warn!("the threaded run's balls did not all catch up within 5 s: the end state mixes instants");
    }
    let wall_seconds = clock.elapsed().as_secs_f64();
    let cpu_seconds = cpu.elapsed().as_secs_f64();
    let stats = runtime.stats();
    let bodies = runtime.bodies();
    let walls = runtime.wall_impulses();
    let params = runtime.params();
    let shutdown = runtime.shutdown();
    let end = measure(&bodies, &params.field, &params.effects, walls);
    if let Some(path) = &options.state_out {
        write_state(path, &bodies.to_balls()).map_err(HeadlessError::StateOut)?;
    }
    Ok(RunReport {
        scene: scene.name.clone(),
        scene_file: options.scene_file.clone(),
        engine: Engine::Threaded.name().into(),
        integrator: params.integrator.name().into(),
        dt: scene.ball_cycle,
        steps: 0,
        // Less the time the runtime's clock dropped (a stalled process is not simulated).
        simulated_seconds: (wall_seconds - stats.clock_dropped_seconds).max(0.0) * params.time_scale,
        wall_seconds,
        steps_per_second: stats.ball_rate_median,
        balls: bodies.len(),
        // Attraction is summed as lockstep sums it, switched by the same rule: from the monitor's
        // tree from TREE_MIN_BALLS balls on, directly below (the runtime's counters say which
        // the ball cycles actually took).
        active_effects: scene
            .effects
            .active_names()
            .iter()
            .map(|&s| match (s, &params.effects.attraction) {
                ("attraction", Some(att)) => AttractionMethod::choose(bodies.len(), att).label(),
                _ => s,
            })
            .map(str::to_string)
            .collect(),
        start,
        end,
        phases: None,
        state_hash: None,
        threads: None,
        memory: None,
        runtime: Some(ThreadedFigures {
            stats,
            cpu_seconds,
            cpu_cores_used: cpu_seconds / wall_seconds.max(1e-9),
            shutdown_seconds: shutdown.seconds,
            threads_joined: shutdown.joined,
        }),
    })
}
