//! The threaded runtime's price of accuracy: the Kepler orbit (e = 0.5) run on one thread per
//! ball, against the ball cycle and against the number of balls, beside the CPU it costs.
//!
//! A threaded ball integrates itself with the others frozen at their last published state, over
//! the dt its own clock measured. Its error therefore comes from the cycle period (how stale the
//! other ball is, how long the step) and from load: more threads than cores stretch every real
//! cycle. Extra balls for the load runs are 1 µg specks at rest in the field's corners: their
//! pull on the pair is ~10⁻⁸ of the pair's own, but each is a thread that wants a core.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use cpu_time::ProcessTime;
use glam::DVec2;

use super::analytic::TwoBody;
use super::{AccuracyError, Kind, PROBLEMS};
use crate::engine::{Engine, ThreadedEngine};
use crate::physics::{Ball, BallId, BallKind, Bodies};

/// One threaded run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadedRow {
    /// The period each ball aims for between its updates (the scene's `ball_cycle`).
    pub ball_cycle: Duration,
    /// Balls on the field: the Kepler pair and the specks that load the machine.
    pub balls: usize,
    /// How long the balls ran, s, on the engine's clock: wall time since the start.
    pub wall_seconds: f64,
    /// Cycles per second of the median and of the slowest ball.
    pub rate_median: f64,
    /// Cycles per second of the slowest ball.
    pub rate_min: f64,
    /// CPU time of the process over wall time: cores kept busy.
    pub cores_used: f64,
    /// |E − E₀|/|E₀| of the pair at the end.
    pub energy_drift: f64,
    /// Change of the orbit's shape: max(|a − a₀|/a₀, |e − e₀|).
    pub shape_error: f64,
    /// |r − r_exact(t)|/a at the end, with t the wall time since start (the balls' clocks).
    pub position_error: f64,
}

/// Runs the e = 0.5 Kepler scene on the threaded runtime for each ball cycle (with the pair
/// alone) and each ball count (at the default 1 ms cycle), `seconds` of wall time each.
pub fn run(
    cycles_ms: &[f64],
    counts: &[usize],
    seconds: f64,
    mut progress: impl FnMut(&str),
) -> Result<Vec<ThreadedRow>, AccuracyError> {
    let problem = PROBLEMS.iter().find(|p| p.name == "kepler-e05" && p.kind == Kind::Kepler).expect("built in");
    let scene = problem.scene()?;
    let mut rows = Vec::new();
    let mut plan: Vec<(f64, usize)> = cycles_ms.iter().map(|&c| (c, 2)).collect();
    plan.extend(counts.iter().filter(|&&n| n > 2).map(|&n| (1.0, n)));
    for (cycle_ms, balls) in plan {
        progress(&format!("threaded: cycle {cycle_ms} ms, {balls} balls"));
        let mut s = scene.clone();
        s.balls.extend(specks(balls.saturating_sub(2), s.field.width, s.field.height));
        s.max_balls = s.max_balls.max(s.balls.len());
        rows.push(run_one(&s, Duration::from_secs_f64(cycle_ms * 1e-3), seconds)?);
    }
    Ok(rows)
}

/// `n` light balls at rest in the four corners of the field, on small lattices.
fn specks(n: usize, width: f64, height: f64) -> Vec<Ball> {
    let corners = [
        (0.5, 0.5, 1.0, 1.0),
        (width - 0.5, 0.5, -1.0, 1.0),
        (0.5, height - 0.5, 1.0, -1.0),
        (width - 0.5, height - 0.5, -1.0, -1.0),
    ];
    (0..n)
        .map(|k| {
            let (x0, y0, sx, sy) = corners[k % 4];
            let j = k / 4;
            let (col, row) = ((j % 12) as f64, (j / 12) as f64);
            Ball {
                id: BallId(2 + k as u32),
                kind: BallKind::Ball,
                position: DVec2::new(x0 + sx * 0.4 * col, y0 + sy * 0.4 * row),
                velocity: DVec2::ZERO,
                mass: 1e-9,
                diameter: 0.2,
            }
        })
        .collect()
}

fn pair_orbit(b: &Bodies, g: f64) -> Option<TwoBody> {
    let (i, j) = (b.id.iter().position(|&id| id == BallId(0))?, b.id.iter().position(|&id| id == BallId(1))?);
    TwoBody::new(g, [b.mass[i], b.mass[j]], [b.position[i], b.position[j]], [b.velocity[i], b.velocity[j]])
}

fn run_one(scene: &crate::scene::Scene, ball_cycle: Duration, seconds: f64) -> Result<ThreadedRow, AccuracyError> {
    let g = scene.effects.attraction.map(|a| a.g_constant).unwrap_or(0.0);
    let exact = pair_orbit(&Bodies::from_balls(&scene.balls), g)
        .ok_or_else(|| AccuracyError::Problem("the Kepler pair is not bound".into()))?;
    let mut scene = scene.clone();
    scene.ball_cycle = ball_cycle.as_secs_f64();
    let mut engine = ThreadedEngine::start(&scene).map_err(|e| AccuracyError::Problem(e.to_string()))?;
    let cpu = ProcessTime::now();
    engine.advance_to(seconds);
    let quiet = Instant::now();
    engine.quiesce();
    // The balls stop within the quiescing wait: the end state is at this simulated instant.
    let wall_seconds = engine.time();
    let cpu_seconds = cpu.elapsed().as_secs_f64();
    let quiet_seconds = quiet.elapsed().as_secs_f64();
    let stats = engine.figures().runtime.unwrap_or_default();
    let mut balls = Vec::new();
    engine.sample(&mut balls);
    let bodies = Bodies::from_balls(&balls);
    let report = engine.shutdown();
    if !report.panics.is_empty() {
        return Err(AccuracyError::Problem(format!("a ball thread panicked: {:?}", report.panics)));
    }
    let (energy_drift, shape_error, position_error) = match pair_orbit(&bodies, g) {
        Some(end) => {
            let (r_exact, _) = exact.relative_at(wall_seconds);
            let r = end.r0;
            (
                ((end.energy() - exact.energy()) / exact.energy()).abs(),
                ((end.a - exact.a).abs() / exact.a).max((end.e - exact.e).abs()),
                r.distance(r_exact) / exact.a,
            )
        }
        None => (f64::INFINITY, f64::INFINITY, f64::INFINITY),
    };
    Ok(ThreadedRow {
        ball_cycle,
        balls: bodies.len(),
        wall_seconds,
        rate_median: stats.ball_rate_median,
        rate_min: stats.ball_rate_min,
        cores_used: cpu_seconds / (wall_seconds + quiet_seconds),
        energy_drift,
        shape_error,
        position_error,
    })
}

/// The rows as a Markdown table, with a note on what they measure.
pub fn markdown(rows: &[ThreadedRow], seconds: f64) -> String {
    let mut s = String::from("# The threaded runtime's price of accuracy\n\n");
    let _ = writeln!(
        s,
        "Generated by `ballfield accuracy --threaded`: the `reference/kepler-e05` orbit (period 10 s, \
         leapfrog) on one thread per ball for {seconds} s of wall time, on this machine's 2 cores (other \
         work on the machine shows in the rates). Energy drift: |E − E₀|/|E₀| of the pair at the end. \
         Orbit shape: max(|a − a₀|/a₀, |e − e₀|) of the pair's orbit at the end. Position: \
         |r − r_exact(t)|/a at the end against Kepler's equation, t = wall time since start. The first \
         rows vary the ball cycle with the pair alone; the last vary the number of balls (the pair plus \
         light specks, each a thread) at a 1 ms cycle. CPU: process CPU time / wall time (cores busy).\n"
    );
    s.push_str(
        "| ball cycle | balls | cycles/s (median, slowest) | CPU cores | energy drift | orbit shape | position |\n",
    );
    s.push_str("|---:|---:|---:|---:|---:|---:|---:|\n");
    for r in rows {
        let _ = writeln!(
            s,
            "| {} ms | {} | {:.0}, {:.0} | {:.2} | {:.1e} | {:.1e} | {:.1e} |",
            r.ball_cycle.as_secs_f64() * 1e3,
            r.balls,
            r.rate_median,
            r.rate_min,
            r.cores_used,
            r.energy_drift,
            r.shape_error,
            r.position_error
        );
    }
    s
}
