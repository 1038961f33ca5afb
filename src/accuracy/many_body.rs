//! The accuracy report's many-body section, with the exact engine as the reference (`ballfield
//! accuracy --many-body`): where a time-stepped engine errs with many balls — the order of
//! collisions, simultaneous contacts, chaos — measured against event-driven hard balls, exact to
//! rounding.
//!
//! - **Newton's cradle** (the `cradle` scene: a ball at 5 m/s into a row of five with 1 mm
//!   gaps): the last ball's outgoing speed and the instant it leaves, against the closed form.
//! - **An elastic gas under gravity**: how fast two exact runs a rounding apart part (the
//!   largest Lyapunov exponent λ, fitted to the growth of their distance), horizons chosen inside
//!   it, and the stepped engines' position error at those horizons against their wall time.
//! - **Hard-disk pressure** from the walls' gauge: `Z = P·A/(N·kT)` at packings from dilute to
//!   dense, each extrapolated to a field without walls over three field sizes, against Henderson's
//!   equation of state and the virial series through B₁₀ (`equation_of_state`), for the exact
//!   engine; the lockstep engine at several dt and the threaded engine against it at η = 0.3.
//! - **The threaded engine** on the cradle and the gas.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use glam::DVec2;
use plotters::prelude::*;

use super::equation_of_state::{henderson_z, virial_z};
use super::{AccuracyError, write_file};
use crate::engine::lockstep::Lockstep;
use crate::engine::{self, Engine, EngineKind, ExactEngine, Placement};
use crate::physics::{Ball, BallId, BallKind, Collisions, Effects, Field, Gravity, Integrator};
use crate::scenes;

/// A gas of `count` disks of diameter 1 m and mass 1 kg in a square field with elastic walls,
/// covering the fraction `packing` of its area (`N·π/4 / L²`), on a square lattice (which fits
/// up to π/4 ≈ 0.785; a gas melts from it within a few collisions per disk), each at 1 m/s in a
/// direction from `seed`, less the mean velocity (the centre of mass at rest).
///
/// `None` if `count` is 0 or `packing` is not in (0, 0.78].
pub fn disk_gas(count: usize, packing: f64, seed: u64) -> Option<(Field, Vec<Ball>)> {
    if count == 0 || !(packing > 0.0 && packing <= 0.78) {
        return None;
    }
    let side = (count as f64 * std::f64::consts::FRAC_PI_4 / packing).sqrt();
    let k = (count as f64).sqrt().ceil() as usize;
    let spacing = side / k as f64;
    let mut placement = Placement::new(seed);
    let mut balls: Vec<Ball> = (0..count)
        .map(|i| {
            let (cx, cy) = (i % k, i / k);
            let angle = std::f64::consts::TAU * placement.next_uniform();
            Ball {
                id: BallId(i as u32),
                kind: BallKind::Ball,
                position: DVec2::new((cx as f64 + 0.5) * spacing, (cy as f64 + 0.5) * spacing),
                velocity: DVec2::from_angle(angle),
                mass: 1.0,
                diameter: 1.0,
            }
        })
        .collect();
    let mean = balls.iter().map(|b| b.velocity).sum::<DVec2>() / count as f64;
    for b in &mut balls {
        b.velocity -= mean;
    }
    Some((Field { width: side, height: side, restitution: 1.0 }, balls))
}

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct ManyBodyConfig {
    /// Lockstep steps for the cradle, s.
    pub cradle_dts: Vec<f64>,
    /// Disks in the gas under gravity.
    pub gas_balls: usize,
    /// Lockstep steps for the gas, s.
    pub gas_dts: Vec<f64>,
    /// Disks of each pressure run.
    pub z_balls: usize,
    /// Packing fractions of the pressure runs.
    pub z_packings: Vec<f64>,
    /// Collisions per disk each pressure run is measured over (after as many again to melt).
    pub z_collisions_per_ball: u64,
    /// Lockstep steps for the pressure at packing 0.3, s.
    pub z_dts: Vec<f64>,
    /// Disks of the finite-size series at every packing (beside `z_balls`): the bulk's Z is
    /// extrapolated from them.
    pub z_sizes: Vec<usize>,
    /// Wall seconds of each threaded run.
    pub threaded_seconds: f64,
}

impl ManyBodyConfig {
    /// The full section: a few minutes on two cores.
    pub fn full() -> Self {
        ManyBodyConfig {
            cradle_dts: vec![1e-2, 1e-3, 1e-4, 1e-5],
            gas_balls: 200,
            gas_dts: vec![1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5],
            z_balls: 1000,
            z_packings: vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
            z_collisions_per_ball: 1000,
            z_dts: vec![1e-2, 3e-3, 1e-3, 3e-4],
            z_sizes: vec![250, 4000],
            threaded_seconds: 3.0,
        }
    }

    /// A short run (`--quick`): seconds.
    pub fn quick() -> Self {
        ManyBodyConfig {
            cradle_dts: vec![1e-3, 1e-4],
            gas_balls: 100,
            gas_dts: vec![1e-2, 1e-3, 1e-4],
            z_balls: 400,
            z_packings: vec![0.3],
            z_collisions_per_ball: 20,
            z_dts: vec![1e-3],
            z_sizes: vec![100],
            threaded_seconds: 1.0,
        }
    }
}

/// One engine's run of the cradle.
#[derive(Clone, Debug, PartialEq)]
pub struct CradleRow {
    /// "exact", "lockstep" or "threaded".
    pub engine: &'static str,
    /// Lockstep's step, s (threaded: its ball cycle).
    pub dt: Option<f64>,
    /// The last ball's speed at the end, m/s.
    pub speed: f64,
    /// The instant it left, s: `T − (x(T) − x₀)/v_x(T)`.
    pub leave: f64,
    /// The speeds of the six balls at the end, m/s (striker first).
    pub speeds: Vec<f64>,
    /// Wall time of the run, s.
    pub wall_seconds: f64,
}

/// One run of the gas or of the pressure: its error against the exact engine, and its cost.
#[derive(Clone, Debug, PartialEq)]
pub struct ErrorRow {
    /// "exact", "lockstep" or "threaded".
    pub engine: &'static str,
    /// The step, s (lockstep) or the ball cycle (threaded); `None` for the exact engine.
    pub dt: Option<f64>,
    /// The horizon, s of simulated time.
    pub horizon: f64,
    /// The error (what it is depends on the table: see its heading).
    pub error: f64,
    /// Wall time of the run, s.
    pub wall_seconds: f64,
}

/// One pressure run.
#[derive(Clone, Debug, PartialEq)]
pub struct PressureRow {
    /// Disks.
    pub balls: usize,
    /// Packing fraction `N·π/4 / (W·H)`.
    pub packing: f64,
    /// The field's perimeter over its area, 1/m: the walls' share of the system.
    pub perimeter_per_area: f64,
    /// Z from the walls' gauge, `P·A/(N·kT)`, and its standard error over ten blocks.
    pub z: f64,
    /// Standard error of `z` (ten blocks of the run).
    pub z_error: f64,
    /// Collisions measured over.
    pub collisions: u64,
    /// Wall time of the run, s.
    pub wall_seconds: f64,
}

/// The bulk's Z at one packing: the walled runs of every size fitted as
/// `Z = Z∞ + c·(perimeter/area)` (least squares weighted by their standard errors), against the
/// equations of state.
#[derive(Clone, Debug, PartialEq)]
pub struct BulkZ {
    /// Packing fraction.
    pub packing: f64,
    /// Z∞: the fit's intercept.
    pub z: f64,
    /// Its standard error, from the runs' own.
    pub z_error: f64,
    /// The walls' coefficient `c`, m.
    pub c: f64,
    /// Henderson's Z.
    pub henderson: f64,
    /// The virial series through B₁₀, resummed.
    pub virial: f64,
}

/// The whole section.
#[derive(Clone, Debug, PartialEq)]
pub struct ManyBodyReport {
    /// The configuration it ran.
    pub config: ManyBodyConfig,
    /// The cradle: its closed form's leave instant, s, and each engine's run.
    pub cradle_leave: f64,
    /// Each engine's cradle run.
    pub cradle: Vec<CradleRow>,
    /// The fitted Lyapunov exponent of the gas, 1/s, and the range of times it was fitted on.
    pub lyapunov: f64,
    /// The times (s) between which the fit of [`ManyBodyReport::lyapunov`] was taken.
    pub lyapunov_range: (f64, f64),
    /// The distance of the two exact runs (max over balls, m) every sample: `(t, d)`.
    pub divergence: Vec<(f64, f64)>,
    /// Collisions per ball per second in the gas.
    pub collision_rate: f64,
    /// The stepped engines' position errors on the gas (max over balls, m).
    pub gas: Vec<ErrorRow>,
    /// The pressure runs of the exact engine.
    pub pressure: Vec<PressureRow>,
    /// The finite-size series at every packing (the `z_balls` runs among them), by packing
    /// and then size.
    pub finite_size: Vec<PressureRow>,
    /// The bulk's Z at every packing, from [`ManyBodyReport::finite_size`].
    pub bulk: Vec<BulkZ>,
    /// The lockstep engine's Z error at packing 0.3 (relative to the exact engine's Z).
    pub pressure_lockstep: Vec<ErrorRow>,
    /// Wall time of the whole section, s.
    pub total_seconds: f64,
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let clock = Instant::now();
    let out = f();
    (out, clock.elapsed().as_secs_f64())
}

fn balls_of(engine: &mut dyn Engine) -> Vec<Ball> {
    let mut out = Vec::new();
    engine.sample(&mut out);
    out
}

/// The largest distance between the balls of two states of the same balls, m.
fn distance(a: &[Ball], b: &[Ball]) -> f64 {
    a.iter().zip(b).map(|(p, q)| p.position.distance(q.position)).fold(0.0, f64::max)
}

// ---- the cradle -----------------------------------------------------------------------------

/// Seconds every cradle run lasts (the last ball leaves at 1.6008 s).
const CRADLE_END: f64 = 3.0;

fn cradle_row(engine: &'static str, dt: Option<f64>, balls: &[Ball], x0: f64, t: f64, wall: f64) -> CradleRow {
    let last = balls.last().copied().unwrap_or(balls[0]);
    CradleRow {
        engine,
        dt,
        speed: last.velocity.length(),
        leave: t - (last.position.x - x0) / last.velocity.x,
        speeds: balls.iter().map(|b| b.velocity.length()).collect(),
        wall_seconds: wall,
    }
}

fn run_cradle(config: &ManyBodyConfig) -> Result<(f64, Vec<CradleRow>), AccuracyError> {
    let scene = scenes::builtin("cradle").expect("the cradle is built in")?;
    let balls = &scene.balls;
    let x0 = balls.last().map_or(0.0, |b| b.position.x);
    // The closed form: the striker crosses its gap, then the pulse crosses each 1 mm gap at the
    // striker's speed (equal masses, e = 1: each ball stops and passes its whole speed on).
    let v = balls[0].velocity.x;
    let gaps: f64 =
        balls.windows(2).map(|w| w[1].position.x - w[0].position.x - 0.5 * (w[0].diameter + w[1].diameter)).sum();
    let leave = gaps / v;
    let mut rows = Vec::new();
    let mut exact = ExactEngine::new(&scene).map_err(|e| AccuracyError::Problem(e.to_string()))?;
    let ((), wall) = timed(|| exact.advance_to(CRADLE_END));
    rows.push(cradle_row("exact", None, &balls_of(&mut exact), x0, exact.time(), wall));
    for &dt in &config.cradle_dts {
        let mut l = Lockstep::from_parts(scene.field, scene.effects, scene.integrator, dt, scene.max_balls, balls);
        let n = (CRADLE_END / dt).round() as u64;
        let ((), wall) = timed(|| l.run(n));
        rows.push(cradle_row("lockstep", Some(dt), &l.bodies().to_balls(), x0, n as f64 * dt, wall));
    }
    let mut threaded =
        engine::start(EngineKind::Threaded, &scene, None).map_err(|e| AccuracyError::Problem(e.to_string()))?;
    let ((), wall) = timed(|| threaded.advance_to(CRADLE_END));
    threaded.quiesce();
    let t = threaded.time();
    let state = balls_of(threaded.as_mut());
    threaded.shutdown();
    rows.push(cradle_row("threaded", Some(scene.ball_cycle), &state, x0, t, wall));
    Ok((leave, rows))
}

// ---- the gas under gravity ------------------------------------------------------------------

/// The gas under gravity: `count` disks at packing 0.2 and 10 m/s (a scale height of about
/// 5 m in a field of about 28 m for 200 disks) under 9.81 m/s².
fn gravity_gas(count: usize) -> (Field, Effects, Vec<Ball>) {
    let (field, mut balls) = disk_gas(count, 0.2, 1).expect("a valid gas");
    for b in &mut balls {
        b.velocity *= 10.0;
    }
    let effects = Effects {
        collisions: Some(Collisions { restitution: 1.0 }),
        gravity: Some(Gravity { g: DVec2::new(0.0, -9.81) }),
        ..Effects::default()
    };
    (field, effects, balls)
}

/// The first distance between two exact runs, m: one ball of the second moved by this.
const NUDGE: f64 = 1e-12;

/// The distances fitted for λ: above the nudge's first collisions, below saturation.
const FIT_RANGE: (f64, f64) = (1e-10, 1e-3);

fn exact_at(field: Field, effects: Effects, balls: &[Ball], t: f64) -> Result<(Vec<Ball>, f64), AccuracyError> {
    let mut e = ExactEngine::from_parts(field, effects, balls).map_err(|e| AccuracyError::Problem(e.to_string()))?;
    let ((), wall) = timed(|| e.advance_to(t));
    Ok((balls_of(&mut e), wall))
}

/// λ of the gas: two exact runs `NUDGE` apart, their distance sampled every 0.02 s until it
/// passes 1e-2 m; the least-squares slope of ln d against t over `FIT_RANGE`. Also the
/// collisions per ball per second.
#[allow(clippy::type_complexity)]
fn lyapunov(
    field: Field,
    effects: Effects,
    balls: &[Ball],
) -> Result<(f64, (f64, f64), Vec<(f64, f64)>, f64), AccuracyError> {
    let start =
        |b: &[Ball]| ExactEngine::from_parts(field, effects, b).map_err(|e| AccuracyError::Problem(e.to_string()));
    let mut nudged = balls.to_vec();
    nudged[0].position.x += NUDGE;
    let (mut a, mut b) = (start(balls)?, start(&nudged)?);
    let mut samples = Vec::new();
    let mut t = 0.0;
    while t < 60.0 {
        t += 0.02;
        a.advance_to(t);
        b.advance_to(t);
        let d = distance(&balls_of(&mut a), &balls_of(&mut b));
        samples.push((t, d));
        if d > 1e-2 {
            break;
        }
    }
    let rate = a.stats().counters.collisions as f64 * 2.0 / (balls.len() as f64 * t);
    let fit: Vec<(f64, f64)> =
        samples.iter().filter(|s| s.1 >= FIT_RANGE.0 && s.1 <= FIT_RANGE.1).map(|s| (s.0, s.1.ln())).collect();
    if fit.len() < 5 {
        return Err(AccuracyError::Problem(format!("the gas's divergence left too few points to fit: {samples:?}")));
    }
    let n = fit.len() as f64;
    let (mx, my) = (fit.iter().map(|p| p.0).sum::<f64>() / n, fit.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = fit.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = fit.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    Ok((sxy / sxx, (fit[0].0, fit[fit.len() - 1].0), samples, rate))
}

fn run_gas(
    config: &ManyBodyConfig,
    report: &mut ManyBodyReport,
    mut progress: impl FnMut(&str),
) -> Result<(), AccuracyError> {
    let (field, effects, balls) = gravity_gas(config.gas_balls);
    progress("gas: the Lyapunov exponent");
    let (lambda, range, divergence, rate) = lyapunov(field, effects, &balls)?;
    (report.lyapunov, report.lyapunov_range, report.divergence, report.collision_rate) =
        (lambda, range, divergence, rate);
    // Horizons inside the exponential growth: a difference grows tenfold, and a thousandfold.
    for growth in [10.0f64, 1000.0] {
        let horizon = growth.ln() / lambda;
        progress(&format!("gas: horizon {horizon:.3} s"));
        let (want, wall) = exact_at(field, effects, &balls, horizon)?;
        // The exact engine's row: what the chaos makes of a difference of `NUDGE` by then (the
        // divergence measured above), the resolution of any comparison at that horizon.
        let spread = report.divergence.iter().find(|s| s.0 >= horizon).map_or(f64::NAN, |s| s.1);
        report.gas.push(ErrorRow { engine: "exact", dt: None, horizon, error: spread, wall_seconds: wall });
        for &dt in &config.gas_dts {
            for integrator in [Integrator::SemiImplicitEuler, Integrator::Leapfrog] {
                let mut l = Lockstep::from_parts(field, effects, integrator, dt, balls.len(), &balls);
                l.set_threads(1);
                let n = (horizon / dt).round() as u64;
                let ((), wall) = timed(|| l.run(n));
                // Lockstep stops at a whole step: the exact state at that instant.
                let at = n as f64 * dt;
                let want =
                    if (at - horizon).abs() > 0.0 { exact_at(field, effects, &balls, at)?.0 } else { want.clone() };
                let engine = if integrator == Integrator::Leapfrog { "lockstep (leapfrog)" } else { "lockstep" };
                let error = distance(&l.bodies().to_balls(), &want);
                report.gas.push(ErrorRow { engine, dt: Some(dt), horizon, error, wall_seconds: wall });
            }
        }
        // The threaded engine keeps wall-clock time: run it to the horizon, compare at its clock.
        let scene = crate::scene::Scene {
            name: "gas".into(),
            description: String::new(),
            field,
            integrator: Integrator::SemiImplicitEuler,
            dt: 1e-3,
            seed: 1,
            max_balls: balls.len(),
            ball_cycle: 1e-3,
            effects,
            pull: 0.0,
            balls: balls.clone(),
        };
        let mut threaded =
            engine::start(EngineKind::Threaded, &scene, None).map_err(|e| AccuracyError::Problem(e.to_string()))?;
        let ((), wall) = timed(|| threaded.advance_to(horizon));
        threaded.quiesce();
        let t = threaded.time();
        let got = balls_of(threaded.as_mut());
        threaded.shutdown();
        let (want, _) = exact_at(field, effects, &balls, t)?;
        report.gas.push(ErrorRow {
            engine: "threaded",
            dt: Some(scene.ball_cycle),
            horizon: t,
            error: distance(&got, &want),
            wall_seconds: wall,
        });
    }
    Ok(())
}

// ---- the pressure ---------------------------------------------------------------------------

fn elastic() -> Effects {
    Effects { collisions: Some(Collisions { restitution: 1.0 }), ..Effects::default() }
}

/// Z from the walls' total impulse over `seconds`, for disks of total kinetic energy `kinetic`.
fn z_of(total_impulse: f64, seconds: f64, field: &Field, kinetic: f64) -> f64 {
    let pressure = total_impulse / (seconds * 2.0 * (field.width + field.height));
    // In 2D the kinetic energy is N·kT (two degrees of freedom of ½kT each).
    pressure * field.width * field.height / kinetic
}

/// Melts a gas of `n` disks at `packing` (as many collisions as are measured), then measures Z
/// over `collisions_per_ball` collisions per disk in ten blocks. Returns the row, the melted
/// balls, its field and the kinetic energy.
fn measure_z(
    n: usize,
    packing: f64,
    collisions_per_ball: u64,
) -> Result<(PressureRow, Vec<Ball>, Field, f64, f64), AccuracyError> {
    let per = collisions_per_ball * n as u64;
    let (field, balls) = disk_gas(n, packing, 7)
        .ok_or_else(|| AccuracyError::Problem(format!("no gas of {n} disks at packing {packing}")))?;
    let start =
        |b: &[Ball]| ExactEngine::from_parts(field, elastic(), b).map_err(|e| AccuracyError::Problem(e.to_string()));
    let mut e = start(&balls)?;
    e.run_collisions(per);
    let melted = balls_of(&mut e);
    let mut e = start(&melted)?;
    let kinetic = e.diagnostics().kinetic;
    let clock = Instant::now();
    let mut blocks = Vec::new();
    let (mut t0, mut w0) = (0.0, 0.0);
    for _ in 0..10 {
        e.run_collisions(per / 10);
        let w = e.wall_impulses();
        let total = w.left + w.right + w.bottom + w.top;
        blocks.push(z_of(total - w0, e.time() - t0, &field, kinetic));
        (t0, w0) = (e.time(), total);
    }
    let wall = clock.elapsed().as_secs_f64();
    let w = e.wall_impulses();
    let z = z_of(w.left + w.right + w.bottom + w.top, e.time(), &field, kinetic);
    let mean = blocks.iter().sum::<f64>() / blocks.len() as f64;
    let var = blocks.iter().map(|b| (b - mean) * (b - mean)).sum::<f64>() / (blocks.len() - 1) as f64;
    let row = PressureRow {
        balls: n,
        packing,
        perimeter_per_area: 2.0 * (field.width + field.height) / (field.width * field.height),
        z,
        z_error: (var / blocks.len() as f64).sqrt(),
        collisions: e.stats().counters.collisions,
        wall_seconds: wall,
    };
    Ok((row, melted, field, kinetic, e.time()))
}

/// One exact run of the pressure: `n` disks at `packing` (see [`disk_gas`], seed 7), melted
/// for `collisions_per_ball` collisions per disk, then measured over as many.
pub fn pressure_run(n: usize, packing: f64, collisions_per_ball: u64) -> Result<PressureRow, AccuracyError> {
    Ok(measure_z(n, packing, collisions_per_ball)?.0)
}

/// The fit of [`BulkZ`] over runs at one packing (`None` with fewer than two sizes).
pub fn bulk_z(packing: f64, runs: &[PressureRow]) -> Option<BulkZ> {
    if runs.len() < 2 {
        return None;
    }
    // Weighted least squares of z = Z∞ + c·x, weights 1/σ² (a σ of zero counts as the smallest
    // other one's, so one run does not take all the weight).
    let floor = runs.iter().map(|r| r.z_error).filter(|&e| e > 0.0).fold(f64::INFINITY, f64::min);
    let floor = if floor.is_finite() { floor } else { 1.0 };
    let (mut sw, mut sx, mut sxx, mut sy, mut sxy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for r in runs {
        let w = 1.0 / r.z_error.max(floor).powi(2);
        let x = r.perimeter_per_area;
        (sw, sx, sxx, sy, sxy) = (sw + w, sx + w * x, sxx + w * x * x, sy + w * r.z, sxy + w * x * r.z);
    }
    let det = sw * sxx - sx * sx;
    if det.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let c = (sw * sxy - sx * sy) / det;
    let z = (sy - c * sx) / sw;
    Some(BulkZ {
        packing,
        z,
        z_error: (sxx / det).sqrt(),
        c,
        henderson: henderson_z(packing),
        virial: virial_z(packing),
    })
}

fn run_pressure(
    config: &ManyBodyConfig,
    report: &mut ManyBodyReport,
    mut progress: impl FnMut(&str),
) -> Result<(), AccuracyError> {
    let n = config.z_balls;
    for &packing in &config.z_packings {
        progress(&format!("pressure: packing {packing}"));
        let (row, melted, field, kinetic, span) = measure_z(n, packing, config.z_collisions_per_ball)?;
        let (z, wall, spread) = (row.z, row.wall_seconds, row.z_error / row.z);
        report.pressure.push(row.clone());
        let mut sizes = vec![row];
        for &size in &config.z_sizes {
            progress(&format!("pressure: {size} disks at packing {packing}"));
            sizes.push(pressure_run(size, packing, config.z_collisions_per_ball)?);
        }
        sizes.sort_by_key(|r| r.balls);
        if let Some(bulk) = bulk_z(packing, &sizes) {
            report.bulk.push(bulk);
        }
        report.finite_size.extend(sizes);
        if (packing - 0.3).abs() < 1e-9 {
            // The exact engine's own uncertainty is statistical: the standard error of its Z.
            report.pressure_lockstep.push(ErrorRow {
                engine: "exact",
                dt: None,
                horizon: span,
                error: spread,
                wall_seconds: wall,
            });
            for &dt in &config.z_dts {
                progress(&format!("pressure: lockstep dt {dt}"));
                let mut l = Lockstep::from_parts(field, elastic(), Integrator::SemiImplicitEuler, dt, n, &melted);
                l.set_threads(1);
                let steps = (span / dt).round() as u64;
                let ((), wall) = timed(|| l.run(steps));
                let w = l.wall_impulses();
                let zl = z_of(w.left + w.right + w.bottom + w.top, steps as f64 * dt, &field, kinetic);
                report.pressure_lockstep.push(ErrorRow {
                    engine: "lockstep",
                    dt: Some(dt),
                    horizon: span,
                    error: (zl - z).abs() / z,
                    wall_seconds: wall,
                });
            }
            // The threaded engine keeps wall-clock time, so it measures over `threaded_seconds`
            // only.
            progress("pressure: threaded");
            let scene = crate::scene::Scene {
                name: "pressure".into(),
                description: String::new(),
                field,
                integrator: Integrator::SemiImplicitEuler,
                dt: 1e-3,
                seed: 1,
                max_balls: n,
                ball_cycle: 1e-3,
                effects: elastic(),
                pull: 0.0,
                balls: melted.clone(),
            };
            let mut threaded =
                engine::start(EngineKind::Threaded, &scene, None).map_err(|e| AccuracyError::Problem(e.to_string()))?;
            let ((), wall) = timed(|| threaded.advance_to(config.threaded_seconds));
            threaded.quiesce();
            let t = threaded.time();
            let w = threaded.wall_impulses();
            threaded.shutdown();
            let zt = z_of(w.left + w.right + w.bottom + w.top, t, &field, kinetic);
            // Against the exact engine's Z over the same seconds from the same state: over a few
            // seconds the two have not parted by chaos, so this is the engine's error, not the
            // short run's statistics (a 3 s Z differs from the long run's by 10 %).
            let mut exact = ExactEngine::from_parts(field, elastic(), &melted)
                .map_err(|e| AccuracyError::Problem(e.to_string()))?;
            exact.advance_to(t);
            let we = exact.wall_impulses();
            let ze = z_of(we.left + we.right + we.bottom + we.top, exact.time(), &field, kinetic);
            report.pressure_lockstep.push(ErrorRow {
                engine: "threaded",
                dt: Some(scene.ball_cycle),
                horizon: t,
                error: (zt - ze).abs() / ze,
                wall_seconds: wall,
            });
        }
    }
    Ok(())
}

/// Runs the whole section. `progress` is told what starts.
pub fn run(config: &ManyBodyConfig, mut progress: impl FnMut(&str)) -> Result<ManyBodyReport, AccuracyError> {
    let clock = Instant::now();
    progress("cradle");
    let (cradle_leave, cradle) = run_cradle(config)?;
    let mut report = ManyBodyReport {
        config: config.clone(),
        cradle_leave,
        cradle,
        lyapunov: 0.0,
        lyapunov_range: (0.0, 0.0),
        divergence: Vec::new(),
        collision_rate: 0.0,
        gas: Vec::new(),
        pressure: Vec::new(),
        finite_size: Vec::new(),
        bulk: Vec::new(),
        pressure_lockstep: Vec::new(),
        total_seconds: 0.0,
    };
    run_gas(config, &mut report, &mut progress)?;
    run_pressure(config, &mut report, &mut progress)?;
    report.total_seconds = clock.elapsed().as_secs_f64();
    Ok(report)
}

/// A log axis's label: the tick's value if it is a power of ten (to rounding), else nothing.
fn power_of_ten_label(v: &f64) -> String {
    let exponent = v.log10();
    if (exponent - exponent.round()).abs() < 1e-6 { format!("{v:.0e}") } else { String::new() }
}

/// The least-squares slope of `(x, y)` points, if there are at least three.
fn slope(pts: &[(f64, f64)]) -> Option<f64> {
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    Some(sxy / sxx)
}

fn dt_text(dt: Option<f64>) -> String {
    dt.map_or("—".into(), |d| format!("{d:.0e}"))
}

impl ManyBodyReport {
    /// The section as Markdown (`docs/accuracy/many-body.md`): its introduction, then the
    /// cradle, the gas and the pressure, each a part of its own.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# Many-body accuracy — the exact engine as the reference\n");
        let _ = writeln!(
            s,
            "Generated by `ballfield accuracy --many-body` ({:.0} s). The exact engine is event-driven: every collision at its \
             instant, every ball on its exact parabola between collisions (see `src/engine/exact/`). Wall times are of one \
             core on a shared 2-core machine: they are upper bounds.\n",
            self.total_seconds
        );
        self.markdown_cradle(&mut s);
        self.markdown_gas(&mut s);
        self.markdown_pressure(&mut s);
        let _ = writeln!(s, "\nThe plot: [many-body.svg](many-body.svg).");
        s
    }

    /// The cradle's part of [`ManyBodyReport::markdown`].
    fn markdown_cradle(&self, s: &mut String) {
        let _ = writeln!(s, "## Newton's cradle\n");
        let _ = writeln!(
            s,
            "The `cradle` scene: a ball at 5 m/s into a row of five equal balls with 1 mm gaps, e = 1. The closed form: the \
             last ball leaves at 5 m/s at t = {:.6} s, every other ball at rest. Leave instant: `T − (x(T) − x₀)/v_x(T)` at \
             T = {CRADLE_END} s.\n",
            self.cradle_leave
        );
        let _ = writeln!(
            s,
            "| engine | dt (s) | last ball's speed (m/s) | its error | leave instant (s) | its error (s) | speeds of all six (m/s) | wall (s) |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---|---:|");
        for r in &self.cradle {
            let speeds: Vec<String> = r.speeds.iter().map(|v| format!("{v:.3}")).collect();
            let _ = writeln!(
                s,
                "| {} | {} | {:.6} | {:.1e} | {:.6} | {:.1e} | {} | {:.4} |",
                r.engine,
                dt_text(r.dt),
                r.speed,
                (r.speed - 5.0).abs() / 5.0,
                r.leave,
                (r.leave - self.cradle_leave).abs(),
                speeds.join(" "),
                r.wall_seconds
            );
        }
    }

    /// The gas's part of [`ManyBodyReport::markdown`].
    fn markdown_gas(&self, s: &mut String) {
        let _ = writeln!(s, "\n## An elastic gas under gravity\n");
        let _ = writeln!(
            s,
            "{} disks (1 m, 1 kg) at packing 0.2 in a {:.1} m square, 10 m/s in random directions, g = 9.81 m/s², e = 1: \
             {:.2} collisions per ball per second. **Chaos:** two exact runs whose first ball starts {NUDGE:e} m apart part \
             as `d(t) ∝ e^(λt)` with **λ = {:.2} /s** (fitted to ln d from {:.2} s to {:.2} s, d from {:e} to {:e} m): a \
             difference grows tenfold in {:.3} s at that rate (once it has reached a collision: the nudged runs stay 1e-12 m \
             apart until the nudged ball's first). Every stepped run is compared with the exact one at two horizons, \
             ln(10)/λ and ln(1000)/λ; a run whose error is ε early on is not comparable ball by ball beyond about \
             ln(1/ε)/λ, and a run that takes two contacts of one ball in the wrong order within a step is off by a \
             ball's size at once. Error: the largest distance of a ball from where the exact run has it, m.\n",
            self.config.gas_balls,
            (self.config.gas_balls as f64 * std::f64::consts::FRAC_PI_4 / 0.2).sqrt(),
            self.collision_rate,
            self.lyapunov,
            self.lyapunov_range.0,
            self.lyapunov_range.1,
            FIT_RANGE.0,
            FIT_RANGE.1,
            10f64.ln() / self.lyapunov,
        );
        let _ = writeln!(
            s,
            "The exact engine's row: the distance its two runs started {NUDGE:e} m apart have reached by then (the first sample \
             at or after the horizon), the resolution of any comparison there.\n"
        );
        let shorter = self.gas.iter().map(|r| r.horizon).fold(f64::INFINITY, f64::min);
        for engine in ["lockstep", "lockstep (leapfrog)"] {
            let pts: Vec<(f64, f64)> = self
                .gas
                .iter()
                .filter(|r| r.engine == engine && r.horizon == shorter && r.error > 0.0)
                .filter_map(|r| r.dt.map(|dt| (dt.ln(), r.error.ln())))
                .collect();
            let largest = pts.iter().map(|p| p.1.exp()).fold(0.0, f64::max);
            if largest < 1e-9 {
                let _ = writeln!(
                    s,
                    "- {engine} at the shorter horizon: the exact engine's answer to rounding at every dt (at most {largest:.1e} m, \
                     growing with the number of steps)."
                );
            } else if let Some(order) = slope(&pts) {
                let _ = writeln!(s, "- {engine} at the shorter horizon: error ∝ dt^{order:.2} over the sweep.");
            }
        }
        let _ = writeln!(s);
        let _ = writeln!(s, "| horizon (s) | engine | dt (s) | position error (m) | wall (s) |");
        let _ = writeln!(s, "|---:|---|---:|---:|---:|");
        for r in &self.gas {
            let _ = writeln!(
                s,
                "| {:.3} | {} | {} | {:.2e} | {:.4} |",
                r.horizon,
                r.engine,
                dt_text(r.dt),
                r.error,
                r.wall_seconds
            );
        }
    }

    /// The pressure's part of [`ManyBodyReport::markdown`].
    fn markdown_pressure(&self, s: &mut String) {
        let _ = writeln!(s, "\n## Hard-disk pressure from the walls' gauge\n");
        let sizes: Vec<String> = std::iter::once(self.config.z_balls)
            .chain(self.config.z_sizes.iter().copied())
            .map(|n| n.to_string())
            .collect();
        let _ = writeln!(
            s,
            "Disks of 1 m, e = 1, no gravity, in a square field with elastic walls, melted for {c} collisions per disk \
             from a lattice, then measured over as many: `Z = P·A/(N·kT)` with P the walls' total impulse per second per \
             metre of wall, A the field's area and N·kT the kinetic energy (2D). The walls are part of the system: the \
             density next to a wall is not the bulk's, which shows as a difference of order (perimeter × diameter)/area. \
             So every packing runs in fields of {sizes} disks, and the bulk's Z∞ is the fit `Z = Z∞ + c·(perimeter/area)` \
             over them (weighted by their standard errors over ten blocks). Against: Henderson (1975), \
             `Z = (1 + η²/8)/(1 − η)²`, and the virial series through B₁₀ (Clisby & McCoy 2006), resummed over \
             `(1 − η)²` as Henderson's is (`src/accuracy/equation_of_state.rs`): the dense fluid's reference, with a \
             truncation of about 5e-5 of Z at η = 0.6.\n",
            c = self.config.z_collisions_per_ball,
            sizes = sizes.join(", ")
        );
        let _ = writeln!(
            s,
            "| packing η | Z, {} disks (walls) | bulk Z∞ | ± | virial B₂–B₁₀ | Z∞ − virial | Henderson | Z∞ − Henderson |",
            self.config.z_balls
        );
        let _ = writeln!(s, "|---:|---:|---:|---:|---:|---:|---:|---:|");
        for b in &self.bulk {
            let walled = self.pressure.iter().find(|r| r.packing == b.packing).map_or(f64::NAN, |r| r.z);
            let _ = writeln!(
                s,
                "| {:.2} | {:.4} | **{:.4}** | {:.4} | {:.4} | {:+.2} % | {:.4} | {:+.2} % |",
                b.packing,
                walled,
                b.z,
                b.z_error,
                b.virial,
                100.0 * (b.z - b.virial) / b.virial,
                b.henderson,
                100.0 * (b.z - b.henderson) / b.henderson,
            );
        }
        if !self.finite_size.is_empty() {
            let _ = writeln!(s, "\nThe runs the fits are made of:\n");
            let _ = writeln!(s, "| packing η | disks | perimeter/area (1/m) | Z | ± | collisions | wall (s) |");
            let _ = writeln!(s, "|---:|---:|---:|---:|---:|---:|---:|");
            for r in &self.finite_size {
                let _ = writeln!(
                    s,
                    "| {:.2} | {} | {:.4} | {:.4} | {:.4} | {} | {:.2} |",
                    r.packing, r.balls, r.perimeter_per_area, r.z, r.z_error, r.collisions, r.wall_seconds
                );
            }
        }
        if !self.pressure_lockstep.is_empty() {
            let _ = writeln!(
                s,
                "\nThe lockstep engine on the same melted gas at η = 0.3 over the same simulated time: its Z against the exact \
                 engine's (relative). The exact engine's row gives its Z's standard error: the runs part by chaos long before \
                 the end of so long a run, so a difference of that size is noise, not error. The threaded engine runs in wall time, so it \
                 measures over its own run only (a few seconds), against the exact engine's Z over the same seconds from \
                 the same state: over so short a run the two have not parted by chaos.\n"
            );
            let _ = writeln!(s, "| engine | dt (s) | simulated (s) | Z error | wall (s) |");
            let _ = writeln!(s, "|---|---:|---:|---:|---:|");
            for r in &self.pressure_lockstep {
                let _ = writeln!(
                    s,
                    "| {} | {} | {:.2} | {:.2e} | {:.3} |",
                    r.engine,
                    dt_text(r.dt),
                    r.horizon,
                    r.error,
                    r.wall_seconds
                );
            }
        }
    }

    /// The plot: the gas's position error and the pressure's Z error against wall time (log-log).
    pub fn plot(&self, path: &Path) -> Result<(), String> {
        let root = SVGBackend::new(path, (1200, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let areas = root.split_evenly((1, 2));
        let panels: [(&str, Vec<&ErrorRow>); 2] = [
            ("gas under gravity: position error (m) at the longer horizon", {
                // The threaded run stops at its own clock, a little past the horizon.
                let h = self.gas.iter().filter(|r| r.engine != "threaded").map(|r| r.horizon).fold(0.0, f64::max);
                self.gas
                    .iter()
                    .filter(|r| if r.engine == "threaded" { r.horizon >= h } else { (r.horizon - h).abs() < 1e-9 })
                    .collect()
            }),
            ("pressure at η = 0.3: Z error (relative)", self.pressure_lockstep.iter().collect()),
        ];
        for (area, (title, rows)) in areas.iter().zip(panels) {
            let pts: Vec<(&str, f64, f64)> = rows
                .iter()
                .filter(|r| r.wall_seconds > 0.0)
                .map(|r| (r.engine, r.wall_seconds, r.error.max(1e-16)))
                .collect();
            if pts.is_empty() {
                continue;
            }
            let (x0, x1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
            let (y0, y1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.2), b.max(p.2)));
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 18))
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d((x0 / 2.0..x1 * 2.0).log_scale(), (y0 / 3.0..y1 * 3.0).log_scale())
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc("wall time (s)")
                .y_desc("error")
                // Log-scale ticks are computed in floating point (0.00999…), and a range under a
                // decade gets ticks between powers of ten: only the powers are named, with one
                // significant figure.
                .x_label_formatter(&power_of_ten_label)
                .y_label_formatter(&power_of_ten_label)
                .draw()
                .map_err(|e| e.to_string())?;
            for (engine, colour) in [
                ("exact", RGBColor(0, 0, 0)),
                ("lockstep", RGBColor(255, 127, 14)),
                ("lockstep (leapfrog)", RGBColor(44, 160, 44)),
                ("threaded", RGBColor(31, 119, 180)),
            ] {
                let series: Vec<(f64, f64)> = pts.iter().filter(|p| p.0 == engine).map(|p| (p.1, p.2)).collect();
                if series.is_empty() {
                    continue;
                }
                chart
                    .draw_series(LineSeries::new(series.clone(), colour.stroke_width(2)))
                    .map_err(|e| e.to_string())?
                    .label(engine)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2)));
                chart
                    .draw_series(series.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                    .map_err(|e| e.to_string())?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE)
                .border_style(BLACK)
                .draw()
                .map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())
    }
}

/// `ballfield accuracy --many-body [--quick]`: runs the section, prints it and writes
/// `many-body.md` and `many-body.svg` into `out`.
pub fn run_command(out: &Path, quick: bool) -> Result<(), AccuracyError> {
    let config = if quick { ManyBodyConfig::quick() } else { ManyBodyConfig::full() };
    let report = run(&config, |what| eprintln!("accuracy (many-body): {what} ..."))?;
    let mut text = report.markdown();
    // The machine's load says how much the wall times owe to other work (Linux only).
    if let Some(load) =
        std::fs::read_to_string("/proc/loadavg").ok().and_then(|l| l.split(' ').next().map(String::from))
    {
        let _ = writeln!(text, "\nLoad average (1 min) of the machine when the runs ended: {load}.");
    }
    println!("{text}");
    std::fs::create_dir_all(out).map_err(|source| AccuracyError::Io { path: out.to_path_buf(), source })?;
    let (md, svg) = (out.join("many-body.md"), out.join("many-body.svg"));
    write_file(&md, &text)?;
    report.plot(&svg).map_err(|message| AccuracyError::Plot { path: svg.clone(), message })?;
    println!("wrote {} and {}", md.display(), svg.display());
    Ok(())
}
