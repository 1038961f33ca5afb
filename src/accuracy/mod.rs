//! The accuracy report: what accuracy costs in time.
//!
//! Each reference problem (a built-in scene under `reference/` with an exact answer, see
//! [`PROBLEMS`]) is run on the lockstep engine with every integrator over a sweep of time steps.
//! Each run gives an error against the exact answer and a wall time; from the sweep, each
//! integrator's order of convergence is fitted ([`fit_order`]). `ballfield accuracy` prints the
//! table and writes it as CSV, a log-log plot of error against cost, and a Markdown summary.

pub mod analytic;
pub mod equation_of_state;
mod fit;
pub mod many_body;
mod plot;
mod problems;
pub mod threaded;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub use fit::{CEILING, FLOOR, OrderFit, ROUNDING_MARGIN, fit_order};
pub use problems::{Exact, Kind, Measure, Measured, PROBLEMS, Problem, SweepPoint, TWIN_SHIFT};

use crate::engine::lockstep::Lockstep;
use crate::physics::{Ball, Integrator};
use crate::scene::SceneError;

/// Why the accuracy report could not be made or written.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// A reference scene does not parse.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A reference problem cannot be measured: its scene does not fit the exact answer (wrong
    /// effects, balls that never meet, an unbound orbit), a run did not collide as expected, or
    /// a threaded run failed.
    #[error("{0}")]
    Problem(String),
    /// An output file or directory could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What the file system said.
        source: std::io::Error,
    },
    /// The plot could not be drawn.
    #[error("{path}: cannot draw the plot: {message}")]
    Plot {
        /// The plot's file.
        path: PathBuf,
        /// What the plotting library said.
        message: String,
    },
}

/// What to sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct Config {
    /// The integrators to compare, in the order of the table's columns.
    pub integrators: Vec<Integrator>,
    /// Steps per orbit for the Kepler problems.
    pub kepler_steps_per_orbit: Vec<u64>,
    /// Orbits per Kepler run.
    pub kepler_orbits: u64,
    /// Steps per 0.5 s for the drag fall.
    pub drag_steps_per_sample: Vec<u64>,
    /// Steps per 1.5 s flight for the projectile.
    pub projectile_steps: Vec<u64>,
    /// Whole steps before the contact for the collisions.
    pub collision_steps_to_contact: Vec<u64>,
    /// Each run is timed again (on a fresh copy, without the error bookkeeping) until this much
    /// time has been spent on it; the fastest repeat is reported. Zero: timed once.
    pub min_timing: Duration,
}

impl Config {
    /// The full report (`ballfield accuracy`): about a minute on two cores.
    pub fn full() -> Self {
        Config {
            integrators: Integrator::ALL.to_vec(),
            kepler_steps_per_orbit: vec![30, 50, 100, 200, 300, 500, 1000, 2000, 3000, 5000, 10_000, 20_000],
            kepler_orbits: 100,
            drag_steps_per_sample: vec![1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000],
            projectile_steps: vec![3, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10_000, 20_000],
            collision_steps_to_contact: vec![100, 200, 500, 1000, 2000, 5000, 10_000, 20_000, 50_000],
            min_timing: Duration::from_millis(20),
        }
    }

    /// A short sweep (`--quick`, and the order test): seconds.
    pub fn quick() -> Self {
        Config {
            integrators: Integrator::ALL.to_vec(),
            kepler_steps_per_orbit: vec![30, 50, 100, 200, 500, 1000, 2000, 5000, 10_000, 20_000],
            kepler_orbits: 10,
            drag_steps_per_sample: vec![5, 10, 20, 50, 100, 200, 500, 1000, 2000],
            projectile_steps: vec![100, 200, 500, 1000, 2000, 5000],
            collision_steps_to_contact: vec![500, 1000, 2000, 5000, 10_000],
            min_timing: Duration::ZERO,
        }
    }

    fn resolutions(&self, kind: Kind) -> &[u64] {
        match kind {
            Kind::Kepler => &self.kepler_steps_per_orbit,
            Kind::DragFall => &self.drag_steps_per_sample,
            Kind::Projectile => &self.projectile_steps,
            Kind::Collision => &self.collision_steps_to_contact,
        }
    }
}

/// One run's result for one measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// The problem's name (see [`PROBLEMS`]).
    pub problem: &'static str,
    /// Which of the problem's errors this row gives.
    pub measure: Measure,
    /// The integrator of the run.
    pub integrator: Integrator,
    /// The run's time step, s.
    pub dt: f64,
    /// Steps the run took.
    pub steps: u64,
    /// Balls in the scene.
    pub balls: usize,
    /// The error against the exact answer (relative, see [`Measure::meaning`]).
    pub error: f64,
    /// Estimated rounding part of the error: the same measure of the difference between this run
    /// and the same problem translated by [`TWIN_SHIFT`].
    pub rounding: f64,
    /// Wall time of the run's steps, s (the fastest of the timing repeats).
    pub wall_seconds: f64,
}

impl Row {
    /// Wall time per ball and step, s: the cost axis of the plot, comparable across problems
    /// with different numbers of balls.
    pub fn seconds_per_ball_step(&self) -> f64 {
        self.wall_seconds / (self.steps as f64 * self.balls as f64)
    }
}

/// A measured order of convergence beside the theory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fit {
    /// The problem's name (see [`PROBLEMS`]).
    pub problem: &'static str,
    /// The measure whose errors were fitted.
    pub measure: Measure,
    /// The integrator whose sweep was fitted.
    pub integrator: Integrator,
    /// The order theory predicts, or `None` when the method is exact for the problem (a
    /// second- or higher-order method under a constant force).
    pub theory: Option<Theory>,
    /// The order measured from the sweep, or `None` when fewer than three points were in the
    /// asymptotic range (see [`fit_order`]).
    pub fit: Option<OrderFit>,
}

impl Fit {
    /// Whether the measurement agrees with theory within ±0.2 (or the method is exact and no
    /// order could be fitted because every error was at rounding level).
    pub fn agrees(&self) -> bool {
        match (self.theory, self.fit) {
            (Some(t), Some(f)) => t.agrees(f.order),
            (None, None) => true,
            _ => false,
        }
    }
}

/// The order of convergence theory predicts: one order, or a range when the error is the sum of
/// two terms of different orders whose balance depends on the length of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Theory {
    /// The lowest order expected.
    pub low: u32,
    /// The highest order expected (`low` when theory gives one order).
    pub high: u32,
}

impl Theory {
    /// Exactly order `p`.
    pub const fn order(p: u32) -> Self {
        Theory { low: p, high: p }
    }

    /// Whether a measured order agrees: within ±0.2 of the order (or of the range).
    pub fn agrees(&self, measured: f64) -> bool {
        measured >= self.low as f64 - 0.2 && measured <= self.high as f64 + 0.2
    }
}

impl std::fmt::Display for Theory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.low == self.high { write!(f, "{}", self.low) } else { write!(f, "{}–{}", self.low, self.high) }
    }
}

/// The order theory predicts for `integrator` on a problem's measure, or `None` when the method is
/// exact for it (order 2 or more under a constant force).
///
/// - Smooth problems: the method's order p — with two classic exceptions the sweep does show:
///   - on a **circular** orbit every point is like every other. A symmetric symplectic method's
///     energy error is the variation of the h^p term of its modified energy along the orbit,
///     which vanishes there to first order: 2p (leapfrog 4, Yoshida 8; semi-implicit Euler, whose
///     positions are leapfrog's started from a velocity offset by h·a/2 — perpendicular to the
///     velocity on a circle, so changing the energy only at O(h²) — 2). RK4 advances a uniform rotation like a linear
///     oscillator, whose energy error per step is O(h⁶): 5 over a fixed time;
///   - **RK4 on the eccentric orbit**: its energy error is an O(h⁴) oscillation plus an O(h⁵·t)
///     drift (the h⁵ term of the local energy error averages out over each orbit), and the drift
///     turns into a phase — position — error growing as h⁵·t². Over 10 to 100 orbits the drift
///     dominates down to rounding level, so the measured slope lies between 4 and 5: 4–5;
///   - **semi-implicit Euler's position** likewise: an O(h) offset that stays bounded (the
///     shape of its orbit) plus a phase error growing as h²·t (its period is leapfrog's, second
///     order): 1 over a few orbits, towards 2 over a hundred: 1–2.
/// - Projectile: order 1 for the two Euler methods; the others are exact.
/// - Collisions: the engine finds a contact up to one step late and replays it from the instant
///   of contact with the normal taken there, so the collision is exact at any angle; under
///   gravity the two Euler methods keep their flight's order 1, the others are exact.
pub fn theoretical_order(exact: &Exact, measure: Measure, integrator: Integrator) -> Option<Theory> {
    let p = integrator.order();
    match exact {
        Exact::Kepler(orbit) => {
            let circular = orbit.e < 1e-9;
            Some(match (integrator, measure.name) {
                (Integrator::ExplicitEuler, _) => Theory::order(1),
                (Integrator::Rk4, "energy") if circular => Theory::order(5),
                (Integrator::Rk4, _) => Theory { low: 4, high: 5 },
                (Integrator::SemiImplicitEuler, "energy") if circular => Theory::order(2),
                (Integrator::SemiImplicitEuler, "position") => Theory { low: 1, high: 2 },
                (_, "energy") if circular => Theory::order(2 * p),
                _ => Theory::order(p),
            })
        }
        Exact::DragFall(_) => Some(Theory::order(p)),
        Exact::Projectile { .. } => (p == 1).then_some(Theory::order(1)),
        // The contact is replayed from its instant with the normal taken there, at any angle: the
        // collision itself is exact, and what is left is the flight's own error, as for the
        // projectile (none without gravity).
        Exact::Collision(c) => (p == 1 && c.g != glam::DVec2::ZERO).then_some(Theory::order(1)),
    }
}

/// The whole report.
#[derive(Clone, Debug)]
pub struct Report {
    /// The sweep that was run.
    pub config: Config,
    /// Every run and measure, in the order they ran: by problem, integrator, step (coarsest
    /// first) and measure.
    pub rows: Vec<Row>,
    /// One fitted order per problem, measure and integrator.
    pub fits: Vec<Fit>,
    /// Wall time of the whole report, s.
    pub total_seconds: f64,
}

/// Runs every problem with every integrator over the sweep. `progress` is told each problem's
/// name as it starts.
pub fn run(config: &Config, mut progress: impl FnMut(&str)) -> Result<Report, AccuracyError> {
    let clock = Instant::now();
    let mut rows = Vec::new();
    let mut fits = Vec::new();
    for problem in &PROBLEMS {
        progress(problem.name);
        let scene = problem.scene()?;
        let exact = problem.exact(&scene)?;
        let sweep = exact.sweep(config.resolutions(problem.kind), config.kepler_orbits);
        let shifted: Vec<Ball> = scene.balls.iter().map(|b| Ball { position: b.position + TWIN_SHIFT, ..*b }).collect();
        for &integrator in &config.integrators {
            let first = rows.len();
            for &point in &sweep {
                // Each integrator is measured at exactly the step it is given: no automatic splitting.
                let mut template = Lockstep::from_parts(
                    scene.field,
                    scene.effects,
                    integrator,
                    point.dt,
                    scene.max_balls,
                    &scene.balls,
                );
                template.set_adaptive_substeps(false);
                let mut engine = template.clone();
                let mut twin =
                    Lockstep::from_parts(scene.field, scene.effects, integrator, point.dt, scene.max_balls, &shifted);
                twin.set_adaptive_substeps(false);
                let measured = exact.errors(&mut engine, &mut twin, point)?;
                let wall_seconds = time_run(&template, point.steps, config.min_timing);
                for (&measure, m) in problem.measures().iter().zip(&measured) {
                    rows.push(Row {
                        problem: problem.name,
                        measure,
                        integrator,
                        dt: point.dt,
                        steps: point.steps,
                        balls: scene.balls.len(),
                        error: m.error,
                        // Rounding can pile up by one unit roundoff per step, whatever the twin
                        // says (it cannot see rounding that both runs share, such as that of a
                        // velocity under uniform gravity, which translation leaves identical).
                        rounding: m.rounding.max(point.steps as f64 * f64::EPSILON / 2.0),
                        wall_seconds,
                    });
                }
            }
            for &measure in problem.measures() {
                let points: Vec<(f64, f64, f64)> = rows[first..]
                    .iter()
                    .filter(|r| r.measure == measure)
                    .map(|r| (r.dt, r.error, r.rounding))
                    .collect();
                fits.push(Fit {
                    problem: problem.name,
                    measure,
                    integrator,
                    theory: theoretical_order(&exact, measure, integrator),
                    fit: fit_order(&points),
                });
            }
        }
    }
    Ok(Report { config: config.clone(), rows, fits, total_seconds: clock.elapsed().as_secs_f64() })
}

/// Wall time of `steps` steps from `template`'s state: the fastest of as many fresh runs as fit
/// in `min_total` (at least one).
fn time_run(template: &Lockstep, steps: u64, min_total: Duration) -> f64 {
    let mut spent = Duration::ZERO;
    let mut best = f64::INFINITY;
    loop {
        let mut engine = template.clone();
        let clock = Instant::now();
        engine.run(steps);
        let elapsed = clock.elapsed();
        std::hint::black_box(engine.bodies());
        best = best.min(elapsed.as_secs_f64());
        spent += elapsed;
        if spent >= min_total {
            return best;
        }
    }
}

/// The Kepler figures of issue 5 ("what good looks like"): worst relative energy error over 100
/// orbits, measured by an independent script with velocity Verlet (kick–drift–kick) for leapfrog.
pub const REFERENCE_POINTS: [(&str, u64, Integrator, f64); 6] = [
    ("kepler-e05", 1000, Integrator::SemiImplicitEuler, 9e-3),
    ("kepler-e05", 1000, Integrator::Leapfrog, 1.1e-4),
    ("kepler-e05", 1000, Integrator::Rk4, 3e-8),
    ("kepler-e0", 100, Integrator::SemiImplicitEuler, 4e-3),
    ("kepler-e0", 100, Integrator::Leapfrog, 4e-6),
    ("kepler-e0", 100, Integrator::Rk4, 1.7e-5),
];

fn seconds(s: f64) -> String {
    if s >= 1.0 {
        format!("{s:.2} s")
    } else if s >= 1e-3 {
        format!("{:.2} ms", s * 1e3)
    } else if s >= 1e-6 {
        format!("{:.1} µs", s * 1e6)
    } else {
        format!("{:.1} ns", s * 1e9)
    }
}

fn error_text(e: f64) -> String {
    if e.is_finite() { format!("{e:.2e}") } else { "diverged".into() }
}

impl Report {
    /// Rows of one problem's measure for one integrator, coarsest step first.
    pub fn series(&self, problem: &str, measure: &str, integrator: Integrator) -> Vec<&Row> {
        self.rows
            .iter()
            .filter(|r| r.problem == problem && r.measure.name == measure && r.integrator == integrator)
            .collect()
    }

    /// The fitted order of one problem's measure for one integrator, if it was run.
    pub fn fit(&self, problem: &str, measure: &str, integrator: Integrator) -> Option<&Fit> {
        self.fits.iter().find(|f| f.problem == problem && f.measure.name == measure && f.integrator == integrator)
    }

    /// The (problem, measure) pairs, in report order.
    pub fn panels(&self) -> Vec<(&'static str, Measure)> {
        let mut out: Vec<(&'static str, Measure)> = Vec::new();
        for r in &self.rows {
            if !out.iter().any(|(p, m)| *p == r.problem && *m == r.measure) {
                out.push((r.problem, r.measure));
            }
        }
        out
    }

    /// The full table, one line per run and measure.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{:<18} {:<9} {:<20} {:>10} {:>8} {:>10} {:>10} {:>12}",
            "problem", "measure", "integrator", "dt (s)", "steps", "error", "wall", "per ball-step"
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{:<18} {:<9} {:<20} {:>10.3e} {:>8} {:>10} {:>10} {:>12}",
                r.problem,
                r.measure.name,
                r.integrator.name(),
                r.dt,
                r.steps,
                error_text(r.error),
                seconds(r.wall_seconds),
                seconds(r.seconds_per_ball_step())
            );
        }
        s
    }

    /// What each measure's error means.
    pub fn legend(&self) -> String {
        let mut s = String::new();
        for (problem, measure) in self.panels() {
            let _ = writeln!(s, "  {problem} {}: {}", measure.name, measure.meaning);
        }
        s
    }

    /// Measured orders, one line per problem and measure, one column per integrator:
    /// `measured (theory)`.
    pub fn orders_table(&self) -> String {
        let mut s = String::new();
        let _ = write!(s, "{:<28}", "problem / measure");
        for i in &self.config.integrators {
            let _ = write!(s, " {:>20}", i.name());
        }
        s.push('\n');
        for (problem, measure) in self.panels() {
            let _ = write!(s, "{:<28}", format!("{problem} {}", measure.name));
            for &i in &self.config.integrators {
                let cell = self.fit(problem, measure.name, i).map(order_cell).unwrap_or_default();
                let _ = write!(s, " {cell:>20}");
            }
            s.push('\n');
        }
        s
    }

    /// The Kepler energy errors at the issue's reference points, beside the reference figures.
    pub fn reference_points(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "worst relative energy error over {} orbits (reference: issue 5, 100 orbits, leapfrog there = kick–drift–kick):",
            self.config.kepler_orbits
        );
        for (problem, per_orbit, integrator, reference) in REFERENCE_POINTS {
            let ours = self
                .series(problem, "energy", integrator)
                .into_iter()
                .find(|r| r.steps == per_orbit * self.config.kepler_orbits);
            let text = ours.map(|r| error_text(r.error)).unwrap_or_else(|| "not in this sweep".into());
            let _ = writeln!(
                s,
                "  {problem:<11} {per_orbit:>5} steps/orbit  {:<20} {text:>10}   reference {reference:.1e}",
                integrator.name()
            );
        }
        s
    }

    /// Writes the table as CSV.
    pub fn write_csv(&self, path: &Path) -> Result<(), AccuracyError> {
        let mut s = String::from(
            "problem,measure,integrator,dt,steps,balls,error,rounding,wall_seconds,seconds_per_ball_step\n",
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{},{},{},{:e},{},{},{:e},{:e},{:e},{:e}",
                r.problem,
                r.measure.name,
                r.integrator.name(),
                r.dt,
                r.steps,
                r.balls,
                r.error,
                r.rounding,
                r.wall_seconds,
                r.seconds_per_ball_step()
            );
        }
        write_file(path, &s)
    }

    /// Writes the orders and the reference points as Markdown.
    pub fn write_summary(&self, path: &Path) -> Result<(), AccuracyError> {
        let mut s = String::from("# Accuracy report — measured orders of convergence\n\n");
        let _ = writeln!(
            s,
            "Generated by `ballfield accuracy` ({} orbits per Kepler run). Each cell: the least-squares \
             slope of log(error) against log(dt) over the asymptotic range (the finest decade of dt whose \
             errors are below {CEILING:.0e} and at least {ROUNDING_MARGIN} times their rounding part), then the \
             theoretical order in brackets. `exact`: the \
             method has no truncation error for this problem (every error at rounding level); `—`: no \
             three points in the asymptotic range.\n",
            self.config.kepler_orbits
        );
        s.push_str("| problem / measure |");
        for i in &self.config.integrators {
            let _ = write!(s, " {} |", i.name());
        }
        s.push_str("\n|---|");
        for _ in &self.config.integrators {
            s.push_str("---|");
        }
        s.push('\n');
        for (problem, measure) in self.panels() {
            let _ = write!(s, "| {problem} {} |", measure.name);
            for &i in &self.config.integrators {
                let cell = self.fit(problem, measure.name, i).map(order_cell).unwrap_or_default();
                let _ = write!(s, " {cell} |");
            }
            s.push('\n');
        }
        s.push_str("\nMeasures:\n\n");
        for (problem, measure) in self.panels() {
            let _ = writeln!(s, "- {problem} {}: {}", measure.name, measure.meaning);
        }
        s.push_str("\n```\n");
        s.push_str(&self.reference_points());
        s.push_str("```\n");
        write_file(path, &s)
    }

    /// Draws the log-log plot of error against wall time, one panel per problem and measure.
    pub fn write_plot(&self, path: &Path) -> Result<(), AccuracyError> {
        plot::draw(self, path).map_err(|message| AccuracyError::Plot { path: path.to_path_buf(), message })
    }
}

fn order_cell(f: &Fit) -> String {
    let theory = f.theory.map(|t| t.to_string()).unwrap_or_else(|| "exact".into());
    match (f.fit, f.theory) {
        (Some(fit), _) => format!("{:.2} ({theory})", fit.order),
        (None, None) => "exact (exact)".into(),
        (None, Some(_)) => format!("— ({theory})"),
    }
}

pub(crate) fn write_file(path: &Path, text: &str) -> Result<(), AccuracyError> {
    std::fs::write(path, text).map_err(|source| AccuracyError::Io { path: path.to_path_buf(), source })
}

/// `ballfield accuracy [--out DIR] [--quick]`: runs the report, prints it, and writes
/// `accuracy.csv`, `accuracy.svg` and `summary.md` into `out`.
pub fn run_command(out: &Path, quick: bool) -> Result<(), AccuracyError> {
    let config = if quick { Config::quick() } else { Config::full() };
    let report = run(&config, |name| eprintln!("accuracy: {name} ..."))?;
    std::fs::create_dir_all(out).map_err(|source| AccuracyError::Io { path: out.to_path_buf(), source })?;
    println!("{}", report.table());
    println!("What each error is:\n{}", report.legend());
    println!("Measured order of convergence, measured (theory):\n{}", report.orders_table());
    println!("{}", report.reference_points());
    let (csv, svg, md) = (out.join("accuracy.csv"), out.join("accuracy.svg"), out.join("summary.md"));
    report.write_csv(&csv)?;
    report.write_plot(&svg)?;
    report.write_summary(&md)?;
    println!("wrote {}, {} and {} ({:.1} s)", csv.display(), svg.display(), md.display(), report.total_seconds);
    Ok(())
}

/// `ballfield accuracy --threaded [--quick]`: the threaded runtime's accuracy against its ball
/// cycle and the number of balls; prints the table and writes `threaded.md` into `out`.
pub fn run_threaded_command(out: &Path, quick: bool) -> Result<(), AccuracyError> {
    let (cycles, counts, seconds): (&[f64], &[usize], f64) =
        if quick { (&[0.25, 1.0, 5.0], &[50], 2.0) } else { (&[0.25, 0.5, 1.0, 2.0, 5.0], &[10, 50, 200, 1000], 10.0) };
    let rows = threaded::run(cycles, counts, seconds, |what| eprintln!("accuracy: {what} ..."))?;
    let mut text = threaded::markdown(&rows, seconds);
    // The machine's load says how much the rates owe to other work (Linux only).
    if let Some(load) =
        std::fs::read_to_string("/proc/loadavg").ok().and_then(|l| l.split(' ').next().map(String::from))
    {
        let _ = writeln!(text, "\nLoad average (1 min) of the machine when the runs ended: {load}.");
    }
    println!("{text}");
    std::fs::create_dir_all(out).map_err(|source| AccuracyError::Io { path: out.to_path_buf(), source })?;
    let path = out.join("threaded.md");
    write_file(&path, &text)?;
    println!("wrote {}", path.display());
    Ok(())
}
