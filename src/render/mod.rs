//! Drawing a snapshot of the field with wgpu, into a window's surface or an offscreen texture
//! (DESIGN.md, "render/"). One path serves both: [`Renderer::encode`] records the drawing into a
//! `TextureView` (the window adds its panel on the same encoder), and [`Renderer::render`] is that
//! path submitted at once (the offscreen frames); they differ only in where the view comes from.
//! The renderer reads its [`FrameSnapshot`]; it never changes the simulation.
//!
//! Balls are discs drawn by `shaders/balls.wgsl` (a signed distance with a one-pixel anti-aliased
//! edge), the field, the walls and the overlays thick segments from `shaders/segments.wgsl`.

mod gpu;
mod layout;
mod offscreen;
mod renderer;
mod snapshot;
mod splat;

pub use gpu::{Gpu, instance_descriptor, raise_render_priority};
pub use layout::{Layout, MARGIN_PX, PIXELS_PER_METRE};
pub use offscreen::{OFFSCREEN_FORMAT, Offscreen};
pub use renderer::{BallPath, FrameBalls, Renderer, SPLAT_MAX_RADIUS_PX, SPLAT_MIN_BALLS};
pub use snapshot::{BallSprite, BallStyle, FrameSnapshot, Segment, ball_colour, palette, rgba, with_style};

/// Why drawing failed.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// wgpu found no adapter for the backends tried (see [`instance_descriptor`]); the string is
    /// wgpu's reason. On a machine without a GPU this means Mesa's CPU drivers are missing.
    #[error(
        "no GPU adapter found ({0}); on a machine without a GPU install Mesa's drivers (libegl-mesa0 and libgl1-mesa-dri, or mesa-vulkan-drivers)"
    )]
    NoAdapter(String),
    /// The adapter refused to open a device with the limits asked for; the string is wgpu's
    /// reason.
    #[error("cannot open the GPU device: {0}")]
    Device(String),
    /// A target of this size cannot be made: a side is 0, or larger than the device's
    /// `max_texture_dimension_2d`.
    #[error("a {width}×{height} target is not possible: each side must be from 1 to {max} pixels")]
    Size {
        /// The width asked for, pixels.
        width: u32,
        /// The height asked for, pixels.
        height: u32,
        /// The device's largest texture side, pixels.
        max: u32,
    },
    /// Waiting for the GPU, or mapping and reading the readback buffer, failed; the string is
    /// the cause.
    #[error("reading the frame back failed: {0}")]
    Readback(String),
}

/// Draws one frame offscreen and returns its pixels: the whole path, for tests and tools.
pub struct OffscreenRenderer {
    /// The headless device it draws with: public so that callers can name the adapter, make
    /// other targets, or record more drawing (a panel) with its device and queue.
    pub gpu: Gpu,
    /// Pipelines for [`OFFSCREEN_FORMAT`]; its [`BallPath`] can be set to compare the ways of
    /// drawing balls.
    pub renderer: Renderer,
    /// The texture frames are drawn into and read back from; it can be replaced by another of
    /// [`OFFSCREEN_FORMAT`] (say an [`Offscreen::draw_only`] one) made on `gpu.device`.
    pub target: Offscreen,
}

impl OffscreenRenderer {
    /// A headless device, a renderer and a `width × height` target.
    pub fn new(width: u32, height: u32) -> Result<OffscreenRenderer, RenderError> {
        let gpu = Gpu::headless()?;
        let target = Offscreen::new(&gpu.device, width, height)?;
        let renderer = Renderer::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT);
        Ok(OffscreenRenderer { gpu, renderer, target })
    }

    /// Renders `snapshot` and waits for the GPU (no readback).
    pub fn render(&mut self, snapshot: &FrameSnapshot) -> Result<(), RenderError> {
        self.renderer.render(self.target.view(), snapshot);
        Offscreen::wait(&self.gpu.device)
    }

    /// Renders `snapshot` and reads the pixels back.
    pub fn render_image(&mut self, snapshot: &FrameSnapshot) -> Result<image::RgbaImage, RenderError> {
        self.renderer.render(self.target.view(), snapshot);
        self.target.read(&self.gpu.device, &self.gpu.queue)
    }
}
