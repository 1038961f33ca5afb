//! An offscreen target: a texture to render into and a buffer to read it back from.

use super::RenderError;

/// The format of offscreen frames: RGBA bytes, written as they are into the PNGs (which are
/// sRGB). Not an `…Srgb` format: the shaders then write sRGB-encoded colour directly and blend in
/// that space, as egui does in the window — and a CPU rasteriser blends into a plain UNORM target
/// about twice as fast as into an sRGB one (docs/measurements.md, *Figures behind the renderer's
/// choices*).
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// A texture of a fixed size and the buffer its pixels are copied to.
pub struct Offscreen {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    readback: wgpu::Buffer,
    width: u32,
    height: u32,
    /// Bytes per row in `readback`: `4 × width` padded to a multiple of 256, as copies require.
    padded_row: u32,
}

impl Offscreen {
    /// A `width × height` pixel target of [`OFFSCREEN_FORMAT`] that can be drawn into, copied
    /// into and read back; [`RenderError::Size`] if a side is 0 or beyond the device's limit.
    pub fn new(device: &wgpu::Device, width: u32, height: u32) -> Result<Offscreen, RenderError> {
        // COPY_DST: small balls are splatted into it (see `BallPath::Splat`).
        Self::with_usage(device, width, height, wgpu::TextureUsages::COPY_DST)
    }

    /// A target that can only be drawn into and read back, as a GL window's surface can: small
    /// balls are splatted onto it by a draw instead of a copy (for tests).
    pub fn draw_only(device: &wgpu::Device, width: u32, height: u32) -> Result<Offscreen, RenderError> {
        Self::with_usage(device, width, height, wgpu::TextureUsages::empty())
    }

    fn with_usage(
        device: &wgpu::Device,
        width: u32,
        height: u32,
        usage: wgpu::TextureUsages,
    ) -> Result<Offscreen, RenderError> {
        let max = device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::Size { width, height, max });
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("offscreen"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OFFSCREEN_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC | usage,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let padded_row = (4 * width).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("offscreen readback"),
            size: padded_row as u64 * height as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        Ok(Offscreen { texture, view, readback, width, height, padded_row })
    }

    /// The view to draw into: what [`Renderer::render`](super::Renderer::render) takes.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// `(width, height)`, pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Waits until the GPU has finished everything submitted (what a frame's time is measured to).
    pub fn wait(device: &wgpu::Device) -> Result<(), RenderError> {
        device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| RenderError::Readback(e.to_string()))?;
        Ok(())
    }

    /// Copies the texture's pixels back: tightly packed RGBA rows, top row first.
    pub fn read(&self, device: &wgpu::Device, queue: &wgpu::Queue) -> Result<image::RgbaImage, RenderError> {
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
        );
        queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        self.readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        Self::wait(device)?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let row = 4 * self.width as usize;
        let mut pixels = Vec::with_capacity(row * self.height as usize);
        {
            let mapped = self.readback.get_mapped_range(..).map_err(|e| RenderError::Readback(e.to_string()))?;
            for r in mapped.chunks_exact(self.padded_row as usize) {
                pixels.extend_from_slice(&r[..row]);
            }
        }
        self.readback.unmap();
        image::RgbaImage::from_raw(self.width, self.height, pixels)
            .ok_or_else(|| RenderError::Readback("pixel buffer of the wrong size".into()))
    }
}
