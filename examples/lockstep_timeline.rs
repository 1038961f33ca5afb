//! A scene on the lockstep engine, half a second a row: the kinetic energy, the largest overlap
//! (of the smaller diameter), the fastest ball, and per row the sub-steps whose contact solve
//! reached a cap, the impacts, the wall contacts, the resting contacts and the finish pass's wall
//! bounces (balls the contact solver left past a wall: 0 while it holds every ball it moves).
//! What `monitor_timeline` shows for the threaded monitor, for the deterministic engine: the same
//! rows every run.
//!
//! ```sh
//! cargo run --release --example lockstep_timeline -- --scene docs/review-scenes/t4_masses_e0.3.toml --seconds 15
//! ```

use std::process::ExitCode;
use std::time::Instant;

use ballfield::{Lockstep, scenes};
use clap::Parser;

mod common;
use common::positive;

#[derive(Parser, Debug)]
#[command(about = "A scene on the lockstep engine, half a second a row")]
struct Args {
    /// A scene file, or the name of a built-in scene.
    #[arg(long, default_value = "pile")]
    scene: String,
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 10.0, value_parser = positive)]
    seconds: f64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    let scene = match scenes::resolve(&args.scene) {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("lockstep_timeline: error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut engine = Lockstep::new(&scene);
    let per_row = (0.5 / engine.dt()).round().max(1.0) as u64;
    let mut last = *engine.counters();
    println!(
        "| s | kinetic J | overlap % | fastest m/s | at a cap | islands solved | impacts | wall contacts | resting | finish bounces | wall s |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    while engine.time() < args.seconds - 1e-9 {
        let started = Instant::now();
        engine.run(per_row);
        let wall = started.elapsed().as_secs_f64();
        let c = *engine.counters();
        let d = engine.diagnostics();
        let fastest = engine.bodies().velocity.iter().map(|v| v.length()).fold(0.0, f64::max);
        println!(
            "| {:.1} | {:.3e} | {:.3} | {:.3e} | {} | {} | {} | {} | {} | {} | {:.2} |",
            engine.time(),
            d.kinetic,
            100.0 * d.largest_overlap_ratio,
            fastest,
            c.unconverged - last.unconverged,
            c.islands_solved - last.islands_solved,
            c.impulses - last.impulses,
            c.wall_contacts - last.wall_contacts,
            c.resting - last.resting,
            c.finish_bounces - last.finish_bounces,
            wall
        );
        last = c;
    }
    ExitCode::SUCCESS
}
