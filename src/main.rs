//! The `ballfield` command line.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};

use ballfield::EngineKind;
use ballfield::app::{self, AppOptions};
use ballfield::headless::{self, FrameOptions, HeadlessOptions, RunLength};
use ballfield::physics::Integrator;
use ballfield::scenes;

#[derive(Parser, Debug)]
#[command(name = "ballfield", version, about = "A 2D ball-physics game with real units.")]
struct Cli {
    /// Scene to play: a TOML file, or the name of a built-in scene (default, vacuum, gravity,
    /// drag, attraction, pile, gas, cradle).
    #[arg(long, global = true, default_value = "default", value_name = "FILE")]
    scene: String,

    #[command(flatten)]
    play: PlayArgs,

    #[command(subcommand)]
    command: Option<Command>,
}

/// Options of the window (no subcommand).
#[derive(Args, Debug)]
struct PlayArgs {
    /// Engine of the window.
    #[arg(long = "engine", value_enum, default_value = "threaded", value_name = "ENGINE")]
    play_engine: EngineKind,
    /// How often the window samples the field and redraws (e.g. 15ms, 0.02s).
    #[arg(long, value_name = "T", default_value = "15ms", value_parser = parse_interval)]
    sample_every: f64,
    /// Close the window by itself after this many seconds.
    #[arg(long, value_name = "S", value_parser = positive_seconds)]
    exit_after: Option<f64>,
    /// When the window closes, write what happened (JSON: frames, balls added, the key ball's
    /// start and end, ...) here.
    #[arg(long = "report", value_name = "F.json")]
    play_report: Option<PathBuf>,
    /// Window size in pixels, WIDTHxHEIGHT [default: the field at 10 px/m and the panel].
    #[arg(long = "size", value_name = "WxH", value_parser = parse_size)]
    window_size: Option<(u32, u32)>,
    /// Start with the panel hidden (Tab shows it).
    #[arg(long)]
    no_panel: bool,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a scene without a window and report on it.
    Headless(HeadlessArgs),
    /// Measure each integrator's error against exact answers and the time it costs.
    Accuracy(AccuracyArgs),
}

#[derive(Args, Debug)]
struct AccuracyArgs {
    /// Where to write accuracy.csv, accuracy.svg and summary.md.
    #[arg(long, value_name = "DIR", default_value = "docs/accuracy")]
    out: PathBuf,
    /// A short sweep: seconds instead of a minute or two.
    #[arg(long)]
    quick: bool,
    /// Measure the threaded runtime instead (ball cycle and ball count; writes threaded.md).
    #[arg(long, conflicts_with = "many_body")]
    threaded: bool,
    /// The many-body section instead: Newton's cradle, a gas under gravity, hard-disk pressure,
    /// with the exact engine as the reference (writes many-body.md and many-body.svg).
    #[arg(long)]
    many_body: bool,
}

#[derive(Args, Debug)]
struct HeadlessArgs {
    /// Simulated seconds to run [default: 10].
    #[arg(long, value_name = "S", value_parser = positive_seconds, conflicts_with = "steps", allow_negative_numbers = true)]
    duration: Option<f64>,
    /// Number of steps to run.
    #[arg(long, value_name = "N", value_parser = step_count, allow_negative_numbers = true)]
    steps: Option<u64>,
    /// Time step, s (overrides the scene's simulation.dt).
    #[arg(long, value_name = "S", value_parser = time_step, allow_negative_numbers = true)]
    dt: Option<f64>,
    /// explicit-euler, semi-implicit-euler, leapfrog, rk4 or yoshida4 (overrides the scene's).
    #[arg(long, value_name = "NAME", value_parser = integrator)]
    integrator: Option<Integrator>,
    /// Engine of the run (threaded: --duration is wall-clock seconds).
    #[arg(long, value_enum, default_value = "lockstep")]
    engine: EngineKind,
    /// Threads the lockstep engine shares its phases over [default: every core]. The result is
    /// the same to the bit for any number.
    #[arg(long, value_name = "N", value_parser = thread_count, allow_negative_numbers = true)]
    threads: Option<usize>,
    /// Start from this state (CSV: id,kind,x,y,vx,vy,mass,diameter) instead of the scene's balls.
    #[arg(long, value_name = "F.csv")]
    state_in: Option<PathBuf>,
    /// Write the final state here.
    #[arg(long, value_name = "F.csv")]
    state_out: Option<PathBuf>,
    /// Write the run report (JSON) here.
    #[arg(long, value_name = "F.json")]
    report: Option<PathBuf>,
    /// Also write PNG frames, drawn offscreen, into this directory (no window or display needed).
    #[arg(long, value_name = "DIR")]
    frames: Option<PathBuf>,
    /// Time between frames: simulated time for lockstep, wall-clock time for threaded
    /// (e.g. 15ms, 0.5s; a bare number is seconds).
    #[arg(long, value_name = "T", default_value = "15ms", value_parser = parse_interval, requires = "frames")]
    frame_every: f64,
    /// Frame size in pixels, WIDTHxHEIGHT [default: the field at 10 px/m].
    #[arg(long, value_name = "WxH", value_parser = parse_size, requires = "frames")]
    size: Option<(u32, u32)>,
    /// Print nothing but errors.
    #[arg(long, short)]
    quiet: bool,
}

fn positive_seconds(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("`{s}` is not a number"))?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(format!("`{s}` must be a finite number of seconds greater than zero"))
    }
}

/// Parses a time: `15ms`, `0.5s` or `0.5` (seconds); finite, more than 0 and at most an hour.
fn parse_interval(s: &str) -> Result<f64, String> {
    let t = s.trim();
    let (number, unit) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1e-3)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1.0)
    } else {
        (t, 1.0)
    };
    let v: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("`{s}` is not a time: write e.g. `15ms`, `0.5s` or `0.5` (seconds)"))?;
    let seconds = v * unit;
    if seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0 {
        Ok(seconds)
    } else {
        Err(format!("`{s}` must be more than 0 and at most an hour"))
    }
}

/// Largest side of a frame or window accepted on the command line.
const MAX_SIDE: u32 = 8192;

/// Parses `WxH`: two whole numbers of pixels from 1 to [`MAX_SIDE`].
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a size: write WIDTHxHEIGHT in pixels, e.g. 1280x720");
    let (w, h) = s.trim().split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("`{s}`: each side must be from 1 to {MAX_SIDE} pixels"));
    }
    Ok((w, h))
}

/// At most this many steps in one run (a typo such as `--duration 1e300` would never end).
const MAX_STEPS: u64 = 10_000_000_000;

fn step_count(s: &str) -> Result<u64, String> {
    let v: u64 = s.parse().map_err(|_| format!("`{s}` is not a whole number of steps (0 or more)"))?;
    if v <= MAX_STEPS { Ok(v) } else { Err(format!("`{s}` is more than {MAX_STEPS} steps")) }
}

fn thread_count(s: &str) -> Result<usize, String> {
    let v: usize = s.parse().map_err(|_| format!("`{s}` is not a whole number of threads (1 to 256)"))?;
    if (1..=256).contains(&v) { Ok(v) } else { Err(format!("`{s}` threads: give 1 to 256")) }
}

fn time_step(s: &str) -> Result<f64, String> {
    let v = positive_seconds(s)?;
    if v <= 1.0 { Ok(v) } else { Err(format!("`{s}` is longer than the largest allowed step of 1 s")) }
}

fn integrator(s: &str) -> Result<Integrator, String> {
    s.parse().map_err(|e: ballfield::physics::UnknownIntegrator| e.to_string())
}

/// glibc's restartable-sequences tunable, and what `main` sets it to.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
const RSEQ_TUNABLE: &str = "glibc.pthread.rseq";

/// Runs the program again, once, with glibc's restartable-sequences registration off
/// (`GLIBC_TUNABLES=glibc.pthread.rseq=0`, glibc's documented switch), unless `GLIBC_TUNABLES`
/// already says anything about it — so `GLIBC_TUNABLES=glibc.pthread.rseq=1` keeps it on.
///
/// Why: glibc registers an rseq area for every thread, and the kernel then updates it on every
/// return to user space after a context switch. With a thousand ball threads switching half a
/// million times a second that is about a tenth of all the CPU (perf: `__rseq_handle_notify_resume`
/// and its user-memory accesses, 8 % of the samples at 1,024 balls; alternating runs: 10–20 %
/// less CPU per ball update without it). Nothing in this program uses rseq. If the re-execution
/// fails, the program just goes on as it is.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn without_rseq() {
    use std::os::unix::process::CommandExt;
    let current = std::env::var_os("GLIBC_TUNABLES").map(|v| v.to_string_lossy().into_owned()).unwrap_or_default();
    if current.contains(RSEQ_TUNABLE) {
        return;
    }
    let value = if current.is_empty() { format!("{RSEQ_TUNABLE}=0") } else { format!("{current}:{RSEQ_TUNABLE}=0") };
    let mut args = std::env::args_os();
    let (Some(arg0), Ok(exe)) = (args.next(), std::env::current_exe()) else { return };
    // The resolved path rather than /proc/self/exe, so the process keeps its name in `ps`.
    // `exec` returns only if it failed; then carry on with rseq.
    let _ = std::process::Command::new(exe).arg0(arg0).args(args).env("GLIBC_TUNABLES", value).exec();
}

fn main() -> ExitCode {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    without_rseq();
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ballfield: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    let scene = scenes::resolve(&cli.scene)?;
    match cli.command {
        None => {
            let p = cli.play;
            let options = AppOptions {
                scene_name: cli.scene.clone(),
                scene,
                engine: p.play_engine,
                sample_every: Duration::from_secs_f64(p.sample_every),
                exit_after: p.exit_after.map(Duration::from_secs_f64),
                report: p.play_report,
                size: p.window_size,
                panel: !p.no_panel,
            };
            app::run(options)?;
        }
        Some(Command::Headless(args)) => {
            let length = match (args.duration, args.steps) {
                (_, Some(n)) => RunLength::Steps(n),
                (Some(d), None) => RunLength::Duration(d),
                (None, None) => RunLength::Duration(10.0),
            };
            let dt = args.dt.unwrap_or(scene.dt);
            let steps = headless::steps_for(length, dt);
            if steps > MAX_STEPS {
                anyhow::bail!(
                    "--duration {}: at dt = {dt} s that is {steps} steps, more than {MAX_STEPS}",
                    args.duration.unwrap_or_default()
                );
            }
            let options = HeadlessOptions {
                scene_file: cli.scene.clone(),
                length,
                dt: args.dt,
                integrator: args.integrator,
                engine: args.engine,
                state_in: args.state_in,
                state_out: args.state_out,
                threads: args.threads,
                frames: args.frames.clone().map(|dir| FrameOptions { dir, every: args.frame_every, size: args.size }),
            };
            let outcome = headless::run(&scene, &options)?;
            // Every output that can be written is written before any failure is reported.
            let report_written = match &args.report {
                Some(path) => {
                    serde_json::to_string_pretty(&outcome.report).map_err(anyhow::Error::from).and_then(|json| {
                        std::fs::write(path, json + "\n")
                            .with_context(|| format!("--report {}: cannot write", path.display()))
                    })
                }
                None => Ok(()),
            };
            if !args.quiet {
                if let (Some(written), Some(dir)) = (&outcome.frames, &args.frames) {
                    println!(
                        "frames       {} of {}x{} in {} ({} skipped), {:.1} ms each to draw and read back on {}",
                        written.frames,
                        written.width,
                        written.height,
                        dir.display(),
                        written.skipped,
                        written.render_seconds * 1e3,
                        written.adapter
                    );
                }
                print!("{}", outcome.report.summary());
            }
            outcome.state_out?;
            report_written?;
        }
        Some(Command::Accuracy(args)) if args.threaded => {
            ballfield::accuracy::run_threaded_command(&args.out, args.quick)?
        }
        Some(Command::Accuracy(args)) if args.many_body => {
            ballfield::accuracy::many_body::run_command(&args.out, args.quick)?
        }
        Some(Command::Accuracy(args)) => ballfield::accuracy::run_command(&args.out, args.quick)?,
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn the_command_line_is_well_formed() {
        // clap's own consistency checks (conflicting or unknown argument references, duplicate
        // names): seen to fail with `requires = "framez"` on --frame-every.
        Cli::command().debug_assert();
    }

    #[test]
    fn intervals() {
        assert_eq!(parse_interval("15ms"), Ok(0.015));
        assert_eq!(parse_interval("0.5s"), Ok(0.5));
        assert_eq!(parse_interval("2"), Ok(2.0));
        for bad in ["abc", "", "0", "-1ms", "nan", "inf", "1e9"] {
            assert!(parse_interval(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn sizes() {
        assert_eq!(parse_size("1280x720"), Ok((1280, 720)));
        for bad in ["0x5", "5x0", "x", "12", "1280x", "-1x5", "99999x5", "axb"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
