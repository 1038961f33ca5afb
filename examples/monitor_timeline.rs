//! The collision monitor over time: runs a scene on the threaded runtime (optionally from a
//! `--state-out` CSV) and prints, every half second of wall time, the monitor's passes a
//! second, its mean pass, its longest pass so far, the balls asleep, the solves that hit an
//! iteration cap and the contacts a pass solved, all over that half second. The report's
//! figures are means over a whole run; this shows where in a run (a pile landing, settling,
//! asleep) the monitor's time goes, with the balls' kinetic energy and the runtime's clock at the
//! row's end (how far the pile has come). `BALLFIELD_SLEEP=off` keeps every ball awake.
//!
//! ```sh
//! cargo run --release --example monitor_timeline -- --scene pile --seconds 20
//! BALLFIELD_SLEEP=off cargo run --release --example monitor_timeline -- \
//!     --scene pile1024.toml --state-in pile1024.csv --seconds 14
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use ballfield::engine::ThreadedEngine;
use ballfield::{Scene, scenes};
use clap::Parser;

mod common;
use common::positive;

#[derive(Parser, Debug)]
#[command(about = "The collision monitor's passes, half a second at a time")]
struct Args {
    /// A scene file, or the name of a built-in scene.
    #[arg(long, default_value = "pile")]
    scene: String,
    /// Balls to start from instead of the scene's (a `--state-out` CSV).
    #[arg(long)]
    state_in: Option<PathBuf>,
    /// Wall-clock seconds to run.
    #[arg(long, default_value_t = 20.0, value_parser = positive)]
    seconds: f64,
}

fn main() -> ExitCode {
    let args = Args::parse();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("monitor_timeline: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: &Args) -> anyhow::Result<()> {
    let mut scene: Scene = scenes::resolve(&args.scene)?;
    if let Some(path) = &args.state_in {
        scene.balls = ballfield::headless::read_state(path, &scene.field)?;
    }
    let engine = ThreadedEngine::start(&scene)?;
    let started = Instant::now();
    let mut last = engine.runtime().stats();
    let half = Duration::from_millis(500);
    println!(
        "| s | passes/s | mean pass ms | longest so far ms | asleep | unconverged | contacts a pass | kinetic J | clock s |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    while started.elapsed().as_secs_f64() < args.seconds {
        std::thread::sleep(half);
        let now = engine.runtime().stats();
        let passes = now.monitor_passes - last.monitor_passes;
        let busy = now.monitor_pass_seconds * now.monitor_passes as f64
            - last.monitor_pass_seconds * last.monitor_passes as f64;
        let per_pass = |x: u64| x as f64 / passes.max(1) as f64;
        let kinetic: f64 =
            engine.runtime().snapshot().iter().map(|r| 0.5 * r.ball.mass * r.ball.velocity.length_squared()).sum();
        println!(
            "| {:.1} | {:.0} | {:.3} | {:.1} | {} | {} | {:.0} | {:.2e} | {:.2} |",
            started.elapsed().as_secs_f64(),
            passes as f64 / (now.seconds - last.seconds).max(1e-9),
            busy / passes.max(1) as f64 * 1e3,
            now.monitor_pass_seconds_max * 1e3,
            now.balls_asleep,
            now.solves_unconverged - last.solves_unconverged,
            per_pass(now.contacts_solved - last.contacts_solved),
            kinetic,
            engine.runtime().clock_seconds(),
        );
        last = now;
    }
    Ok(())
}
