//! Headless runs that also record PNG frames (`ballfield headless ... --frames DIR`), drawn
//! offscreen through the same [`Renderer::render`](crate::render::Renderer::render) path as the
//! window. No window and no display are involved: never a winit event loop here.
//!
//! - lockstep: a frame every `every` of *simulated* time, from t = 0 to the end inclusive; the
//!   stepping is timed alone (drawing and PNG writes are not in `wall_seconds`), and the run is
//!   the same, bit for bit, as one without frames;
//! - threaded: a frame every `every` of *wall-clock* time while the ball threads run; a frame
//!   whose time has passed while the previous one was drawn is skipped (counted in
//!   [`FramesWritten::skipped`]).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cpu_time::ProcessTime;

use crate::headless::{
    Engine, HeadlessError, HeadlessOptions, finish_threaded, lockstep_report, runtime_config, steps_for,
    threaded_seconds, threaded_start,
};
use crate::render::{FrameSnapshot, Layout, OffscreenRenderer, RenderError};
use crate::report::RunReport;
use crate::runtime::Runtime;
use crate::scene::Scene;
use crate::state_file::read_state;

/// Where and how often to write frames.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameOptions {
    pub dir: PathBuf,
    /// Seconds between frames: simulated (lockstep) or wall-clock (threaded).
    pub every: f64,
    /// Pixels; `None` = the field at 10 px/m.
    pub size: Option<(u32, u32)>,
}

/// What was written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FramesWritten {
    pub frames: usize,
    pub skipped: usize,
    pub width: u32,
    pub height: u32,
    pub adapter: String,
    /// Mean seconds to draw a frame and read it back (PNG encoding excluded).
    pub render_seconds: f64,
}

#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    #[error(transparent)]
    Headless(#[from] HeadlessError),
    #[error("--frames: {0}")]
    Render(#[from] RenderError),
    #[error("--frames {dir}: cannot create the directory: {cause}")]
    Dir { dir: PathBuf, cause: std::io::Error },
    #[error("--frames: cannot write {file}: {cause}")]
    Write { file: PathBuf, cause: image::ImageError },
}

/// Parses `--frame-every`: `15ms`, `0.5s` or `0.5` (seconds); finite and greater than zero.
pub fn parse_interval(s: &str) -> Result<f64, String> {
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

/// Largest side of a frame accepted on the command line.
pub const MAX_SIDE: u32 = 8192;

/// Parses `--size WxH`: two whole numbers of pixels from 1 to [`MAX_SIDE`].
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("`{s}` is not a size: write WIDTHxHEIGHT in pixels, e.g. 1280x720");
    let (w, h) = s.trim().split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
        return Err(format!("`{s}`: each side must be from 1 to {MAX_SIDE} pixels"));
    }
    Ok((w, h))
}

struct Recorder {
    out: OffscreenRenderer,
    snapshot: FrameSnapshot,
    dir: PathBuf,
    written: FramesWritten,
    render_time: Duration,
}

impl Recorder {
    fn new(scene: &Scene, frames: &FrameOptions) -> Result<Recorder, FramesError> {
        let (width, height) = frames.size.unwrap_or_else(|| Layout::default_size(&scene.field));
        std::fs::create_dir_all(&frames.dir).map_err(|cause| FramesError::Dir { dir: frames.dir.clone(), cause })?;
        let mut out = OffscreenRenderer::new(width, height)?;
        let adapter = out.gpu.describe();
        let mut snapshot = FrameSnapshot::new(scene.field);
        // One frame and a readback before the run: the driver compiles its shaders on first use
        // (hundreds of ms on a CPU adapter), which must not fall into a timed, threaded run.
        snapshot.fill(scene.field, &scene.balls);
        out.render_image(&snapshot)?;
        Ok(Recorder {
            out,
            snapshot,
            dir: frames.dir.clone(),
            written: FramesWritten { width, height, adapter, ..Default::default() },
            render_time: Duration::ZERO,
        })
    }

    /// Draws the snapshot as it is now filled and writes it as the next frame.
    fn write(&mut self) -> Result<(), FramesError> {
        let t = Instant::now();
        let image = self.out.render_image(&self.snapshot)?;
        self.render_time += t.elapsed();
        let file = frame_path(&self.dir, self.written.frames);
        image.save(&file).map_err(|cause| FramesError::Write { file, cause })?;
        self.written.frames += 1;
        Ok(())
    }

    fn finish(mut self) -> FramesWritten {
        self.written.render_seconds = self.render_time.as_secs_f64() / self.written.frames.max(1) as f64;
        self.written
    }
}

/// `DIR/frame-00042.png`.
pub fn frame_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(format!("frame-{index:05}.png"))
}

/// Runs `scene` as [`crate::headless::run`] does, writing frames as `frames` says.
pub fn run_with_frames(
    scene: &Scene,
    options: &HeadlessOptions,
    frames: &FrameOptions,
) -> Result<(RunReport, FramesWritten), FramesError> {
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
            return Err(
                HeadlessError::TooManyBalls { file: path.clone(), count: balls.len(), limit: scene.max_balls }.into()
            );
        }
        scene.balls = balls;
    }
    let recorder = Recorder::new(&scene, frames)?;
    match options.engine {
        Engine::Lockstep => run_lockstep(&scene, options, frames.every, recorder),
        Engine::Threaded => run_threaded(&scene, options, frames.every, recorder),
    }
}

fn run_lockstep(
    scene: &Scene,
    options: &HeadlessOptions,
    every: f64,
    mut rec: Recorder,
) -> Result<(RunReport, FramesWritten), FramesError> {
    let steps = steps_for(options.length, scene.dt);
    let mut engine = crate::headless::lockstep_engine(scene, options);
    let start = engine.diagnostics();
    let mut stepping = Duration::ZERO;
    let mut done = 0u64;
    for k in 0u64.. {
        // Frame k shows the first step at or after k·every (a hair of tolerance for rounding).
        let at = (k as f64 * every / scene.dt - 1e-9).ceil().max(0.0) as u64;
        if at > steps {
            break;
        }
        let clock = Instant::now();
        engine.run(at - done);
        stepping += clock.elapsed();
        done = at;
        let bodies = engine.bodies();
        rec.snapshot.fill(*engine.field(), (0..bodies.len()).map(|i| bodies.get(i)));
        rec.write()?;
    }
    engine.run(steps - done);
    let report = lockstep_report(scene, options, &engine, start, steps, stepping.as_secs_f64())?;
    Ok((report, rec.finish()))
}

fn run_threaded(
    scene: &Scene,
    options: &HeadlessOptions,
    every: f64,
    mut rec: Recorder,
) -> Result<(RunReport, FramesWritten), FramesError> {
    let seconds = threaded_seconds(scene, options.length);
    let start = threaded_start(scene);
    let runtime = Runtime::start(scene, runtime_config(scene)).map_err(HeadlessError::Runtime)?;
    let cpu = ProcessTime::now();
    let clock = Instant::now();
    let mut records = Vec::new();
    let mut k = 0u64;
    let mut failure = None;
    loop {
        let at = k as f64 * every;
        if at > seconds {
            break;
        }
        let now = clock.elapsed().as_secs_f64();
        if now < at {
            std::thread::sleep(Duration::from_secs_f64(at - now));
        } else if now > at + every && k > 0 {
            // Drawing the last frame took longer than the interval: skip the slots missed.
            let next = (now / every).ceil() as u64;
            rec.written.skipped += (next - k) as usize;
            k = next;
            continue;
        }
        runtime.snapshot_into(&mut records);
        rec.snapshot.fill(runtime.params().field, records.iter().map(|r| &r.ball));
        if let Err(e) = rec.write() {
            failure = Some(e);
            break;
        }
        k += 1;
    }
    let left = seconds - clock.elapsed().as_secs_f64();
    if failure.is_none() && left > 0.0 {
        std::thread::sleep(Duration::from_secs_f64(left));
    }
    if let Some(e) = failure {
        // Dropping the runtime stops and joins every thread.
        return Err(e);
    }
    let report = finish_threaded(scene, options, runtime, start, cpu, clock)?;
    Ok((report, rec.finish()))
}

#[cfg(test)]
mod tests {
    use super::*;

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
