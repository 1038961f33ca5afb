//! PNG frames of a headless run (`ballfield headless ... --frames DIR`), drawn offscreen by the
//! same drawing as the window's ([`Renderer::render`](crate::render::Renderer::render); the
//! window records it through `Renderer::encode` to add its panel). When they are taken is the
//! run loop's business (see the module above).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::physics::{Ball, Field};
use crate::render::{FrameSnapshot, Layout, OffscreenRenderer, RenderError};
use crate::scene::Scene;

/// Where and how often to write frames.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameOptions {
    /// The directory the PNGs go to (`--frames DIR`); created if it is missing.
    pub dir: PathBuf,
    /// Seconds between frames: simulated (lockstep) or wall-clock (threaded).
    pub every: f64,
    /// Pixels; `None` = the field at 10 px/m.
    pub size: Option<(u32, u32)>,
}

/// What was written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FramesWritten {
    /// Frames written, numbered from 0 (see [`frame_path`]).
    pub frames: usize,
    /// Frame instants that passed while the previous frame was drawn (threaded engine), not
    /// written.
    pub skipped: usize,
    /// Width of each frame, px.
    pub width: u32,
    /// Height of each frame, px.
    pub height: u32,
    /// The GPU adapter that drew them, as `name (backend, device type)`: on a machine without a
    /// GPU, a CPU driver such as llvmpipe.
    pub adapter: String,
    /// Mean seconds to draw a frame and read it back (PNG encoding excluded).
    pub render_seconds: f64,
}

/// Why frames could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum FramesError {
    /// The offscreen renderer failed: no adapter, no device, or a failed readback.
    #[error("--frames: {0}")]
    Render(#[from] RenderError),
    /// The frames' directory could not be created.
    #[error("--frames {dir}: cannot create the directory: {cause}")]
    Dir {
        /// The directory asked for.
        dir: PathBuf,
        /// What the file system said.
        cause: std::io::Error,
    },
    /// A frame could not be encoded or saved as a PNG.
    #[error("--frames: cannot write {file}: {cause}")]
    Write {
        /// The frame's file.
        file: PathBuf,
        /// What the image encoder or the file system said.
        cause: image::ImageError,
    },
}

/// Draws frames offscreen and writes them as PNGs.
pub(super) struct Recorder {
    out: OffscreenRenderer,
    snapshot: FrameSnapshot,
    dir: PathBuf,
    written: FramesWritten,
    render_time: Duration,
}

impl Recorder {
    pub(super) fn new(scene: &Scene, frames: &FrameOptions) -> Result<Recorder, FramesError> {
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

    /// Draws `balls` and writes them as the next frame.
    pub(super) fn write(&mut self, field: Field, balls: &[Ball]) -> Result<(), FramesError> {
        self.snapshot.fill(field, balls);
        let t = Instant::now();
        let image = self.out.render_image(&self.snapshot)?;
        self.render_time += t.elapsed();
        let file = frame_path(&self.dir, self.written.frames);
        image.save(&file).map_err(|cause| FramesError::Write { file, cause })?;
        self.written.frames += 1;
        Ok(())
    }

    /// Counts frames whose instant passed unseen.
    pub(super) fn skipped(&mut self, frames: usize) {
        self.written.skipped += frames;
    }

    pub(super) fn finish(mut self) -> FramesWritten {
        self.written.render_seconds = self.render_time.as_secs_f64() / self.written.frames.max(1) as f64;
        self.written
    }
}

/// `DIR/frame-00042.png`.
pub fn frame_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(format!("frame-{index:05}.png"))
}
