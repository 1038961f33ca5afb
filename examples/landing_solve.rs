//! The threaded monitor's contact solve on a scene as it runs from its start, without the
//! runtime's threads: every ball carried over a span in free motion (one semi-implicit Euler
//! step under the scene's gravity and drag; the monitor carries balls without attraction), the
//! circle of its path grown by twice the fastest travel (as the monitor's `find_pairs` grows it),
//! the broad phase, one `ContactSolver::solve` of every contact, the responses applied — span
//! after span, the warm start carried over as in a run. Every quarter second of simulated time it
//! prints the mean and the longest solve (wall clock), and per span the impact rounds, resting
//! passes, impacts and contacts, the solves that reached a cap, and the kinetic energy at the end.
//!
//! `monitor_timeline` shows the monitor in the runtime, where a slow pass makes the next span
//! longer; this shows the solve alone over spans of one length (or jittered from 1 to 2 times
//! it, as the monitor's come), the same work every run: the tallies are deterministic.
//!
//! ```sh
//! cargo run --release --example landing_solve -- --scene pile --seconds 9
//! cargo run --release --example landing_solve -- --scene pile --seconds 9 --jitter
//! ```

use std::process::ExitCode;
use std::time::Instant;

use ballfield::physics::{
    BallProps, BroadPhase, ContactParams, ContactSolver, Forces, Integrator, NoOtherBalls, SolverBall, resting_drift,
    swept_circle,
};
use ballfield::{Scene, scenes};
use clap::Parser;
use glam::DVec2;

mod common;
use common::positive;

#[derive(Parser, Debug)]
#[command(about = "The monitor's contact solve on a scene from its start, a quarter second a row")]
struct Args {
    /// A scene file, or the name of a built-in scene.
    #[arg(long, default_value = "pile")]
    scene: String,
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 9.0, value_parser = positive)]
    seconds: f64,
    /// The span, s (the monitor's period: 1 ms).
    #[arg(long, default_value_t = 1e-3, value_parser = positive)]
    span: f64,
    /// Spans from 1 to 2 times `--span`, from a fixed sequence.
    #[arg(long)]
    jitter: bool,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match scenes::resolve(&args.scene) {
        Ok(scene) => {
            run(&args, &scene);
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("landing_solve: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Sums over a quarter second of spans.
#[derive(Default)]
struct Row {
    spans: u64,
    seconds: f64,
    longest: f64,
    rounds: u64,
    resting: u64,
    impacts: u64,
    contacts: u64,
    unconverged: u64,
    /// Pairs the position passes pushed together, and pairs added beyond the broad phase's.
    pushed: u64,
    reached: u64,
}

fn run(args: &Args, scene: &Scene) {
    let forces = Forces::new(&scene.effects);
    let gravity = scene.effects.gravity.map_or(DVec2::ZERO, |g| g.g);
    let restitution = scene.effects.collisions.map_or(1.0, |c| c.restitution);
    let props: Vec<BallProps> = scene
        .balls
        .iter()
        .map(|b| BallProps { mass: b.mass, inverse_mass: b.inverse_mass(), diameter: b.diameter })
        .collect();
    let mut balls: Vec<SolverBall> = scene
        .balls
        .iter()
        .map(|b| SolverBall {
            id: b.id,
            position: b.position,
            velocity: b.velocity,
            acceleration: gravity,
            inverse_mass: b.inverse_mass(),
            radius: b.radius(),
        })
        .collect();
    let mut start: Vec<(DVec2, DVec2)> = balls.iter().map(|b| (b.position, b.velocity)).collect();
    let mut broad_phase = BroadPhase::new();
    broad_phase.set_margin(1e-6);
    let mut solver = ContactSolver::new();
    let mut params = ContactParams {
        restitution,
        field: scene.field,
        span: args.span,
        drift: resting_drift(Integrator::SemiImplicitEuler, 1),
    };
    let (mut centres, mut reach, mut pairs) = (Vec::new(), Vec::new(), Vec::new());
    let mut seed = 1u64;
    let (mut t, mut next_row) = (0.0, 0.25);
    let mut row = Row::default();
    println!(
        "| s | solve ms, mean | longest ms | impact rounds | resting passes | impacts | contacts | at a cap | pushed together | reached | kinetic J |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    while t < args.seconds {
        if args.jitter {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            params.span = args.span * (1.0 + (seed >> 11) as f64 / (1u64 << 53) as f64);
        }
        let h = params.span;
        centres.clear();
        reach.clear();
        let mut fastest = 0.0f64;
        for ((b, &(x, v)), p) in balls.iter_mut().zip(&start).zip(&props) {
            let a = forces.on_ball(*p, DVec2::ZERO, NoOtherBalls).acceleration(x, v);
            let v1 = v + a * h;
            let x1 = x + v1 * h;
            fastest = fastest.max(v.length()).max(v1.length());
            b.position = x1;
            b.velocity = v1;
            let (c, r) = swept_circle(x, x1, gravity, h, b.radius);
            centres.push(c);
            reach.push(r);
        }
        for r in &mut reach {
            *r += 2.0 * fastest * h;
        }
        broad_phase.update(&centres, &reach, scene.field.width, scene.field.height);
        pairs.clear();
        broad_phase.for_each_touching_pair(|i, j| pairs.push((i as u32, j as u32)));
        let clock = Instant::now();
        let tally = solver.solve(&balls, &pairs, &params, Some(&broad_phase));
        let seconds = clock.elapsed().as_secs_f64();
        for ((s, b), r) in start.iter_mut().zip(&balls).zip(solver.responses()) {
            *s = (b.position + r.shift, b.velocity + r.velocity_change);
        }
        row.spans += 1;
        row.seconds += seconds;
        row.longest = row.longest.max(seconds);
        row.rounds += tally.impact_rounds as u64;
        row.resting += tally.resting_passes as u64;
        row.impacts += tally.impacts;
        row.contacts += tally.contacts;
        row.unconverged += !tally.converged as u64;
        row.pushed += tally.pushed_together;
        row.reached += tally.pairs_reached;
        t += h;
        if t >= next_row - 1e-9 || t >= args.seconds {
            let kinetic: f64 = start.iter().zip(&props).map(|((_, v), p)| 0.5 * p.mass * v.length_squared()).sum();
            let n = row.spans as f64;
            println!(
                "| {next_row:.2} | {:.3} | {:.2} | {:.1} | {:.1} | {:.1} | {:.0} | {} | {} | {} | {kinetic:.2e} |",
                row.seconds / n * 1e3,
                row.longest * 1e3,
                row.rounds as f64 / n,
                row.resting as f64 / n,
                row.impacts as f64 / n,
                row.contacts as f64 / n,
                row.unconverged,
                row.pushed,
                row.reached,
            );
            row = Row::default();
            next_row += 0.25;
        }
    }
}
