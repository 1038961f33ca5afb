//! Small balls drawn without a primitive each, on a CPU adapter: the field's pixels are computed
//! here (the field's colour, then every small ball over it, in order, with the same coverage and
//! colour as `fs_main` in `shaders/balls.wgsl`) and copied into the target through a staging
//! buffer; the render pass then draws the walls, the large balls and the overlays over them.
//!
//! Why: Mesa's CPU rasterisers (lavapipe, llvmpipe) spend about a microsecond on each primitive
//! — setup, binning, a fragment-shader call per 4×4 block touched — however few pixels it
//! covers, so many small balls cost many times their vertex work, as triangles or as one-pixel
//! points alike. A compute shader adding every ball's pixels into a buffer with
//! atomics is no way out: lavapipe runs a storage-buffer atomic lane by lane. Here, four pixels
//! of a row at a time in SIMD, band by band on rayon's threads, a pixel costs a few nanoseconds,
//! and the copy (4 bytes a pixel, ~3.7 MB at 1280×720) is a small part of the frame. The frame
//! times of each way are in docs/measurements.md (*Rendering and the window*). On a real GPU
//! none of this pays: there [`super::BallPath::Auto`] draws triangles.

use rayon::prelude::*;

use super::snapshot::{BallSprite, BallStyle, palette};

/// A rectangle of target pixels, top-left origin, y down: `[x, y, width, height]`.
pub(super) type PixelRect = [u32; 4];

/// The largest width and height of a splat's rectangle (balls keep their pixel spans in u16).
const MAX_SIDE: u32 = u16::MAX as u32;

/// Where the balls land, in the target's pixels (top-left origin, y down), as the shaders
/// compute it (in f32).
#[derive(Clone, Copy, Debug)]
pub(super) struct Placement {
    /// Pixels per metre.
    pub scale: f32,
    /// The field's lower-left corner, pixels from the target's top-left corner.
    pub origin: [f32; 2],
}

/// The byte order of a target's pixels, when the splat can write it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PixelOrder {
    Rgba,
    Bgra,
}

impl PixelOrder {
    /// `Some` for the formats the splat's pixels can be copied into as they are: 8-bit RGBA or
    /// BGRA, not sRGB-encoded (others get them through a [`SplatBlit`]).
    pub(super) fn of(format: wgpu::TextureFormat) -> Option<PixelOrder> {
        match format {
            wgpu::TextureFormat::Rgba8Unorm => Some(PixelOrder::Rgba),
            wgpu::TextureFormat::Bgra8Unorm => Some(PixelOrder::Bgra),
            _ => None,
        }
    }
}

/// The splatted pixels of one frame, and scratch, kept between frames for their memory.
#[derive(Default)]
pub(super) struct Splat {
    /// `rows × stride` pixels, `0xAABBGGRR` (RGBA) or `0xAARRGGBB` (BGRA) as little-endian u32.
    pixels: Vec<u32>,
    /// Pixels per row: the rectangle's width and room for a last group of four.
    stride: usize,
    rect: PixelRect,
    /// For each band of [`BAND_ROWS`] rows, the balls reaching into it, in the snapshot's order:
    /// band `k`'s are `banded[band_start[k]..band_start[k + 1]]`.
    band_start: Vec<u32>,
    banded: Vec<Placed>,
    /// The balls in the rectangle's pixels, in order (those missing it with no rows).
    placed: Vec<Placed>,
    /// Where the pixels are copied for the GPU (see `mapped_staging`), and whether it is mapped.
    staging: Option<wgpu::Buffer>,
    staging_mapped: bool,
}

/// A ball in the rectangle's pixels: 24 bytes, as the balls are read band by band.
#[derive(Clone, Copy, Debug, Default)]
struct Placed {
    /// Centre, pixels from the rectangle's corner.
    centre: [f32; 2],
    /// Radius, pixels.
    radius: f32,
    /// As [`BallSprite::colour`].
    colour: u32,
    /// The pixel columns and rows it touches, clipped to the rectangle: `[first, end)`.
    columns: [u16; 2],
    rows: [u16; 2],
}

/// Pixels of a row processed together: one SIMD register of f32.
const LANES: usize = 4;

/// Rows drawn together: the balls are drawn one band at a time, so the pixels being drawn stay in
/// the cache (at 1280 pixels a row, a band is 160 kB) instead of every ball fetching its rows
/// from memory (in snapshot order, balls are all over the field), and bands can be drawn at once
/// on several threads. A ball across a band's edge is drawn in both bands, each its own rows:
/// every pixel still sees its balls in the snapshot's order.
const BAND_ROWS: usize = 32;

impl Splat {
    /// Draws the pixels of `rect` (inside the target): the field's colour, `balls` over it in
    /// their order, clipped to it; and puts them in the staging buffer, for [`Self::upload`].
    /// `false` if the staging buffer cannot be mapped (a lost device): then nothing is drawn.
    pub(super) fn draw(
        &mut self,
        device: &wgpu::Device,
        balls: &[BallSprite],
        place: Placement,
        rect: PixelRect,
        order: PixelOrder,
    ) -> bool {
        let [_, _, w, h] = rect;
        let bytes = 4 * Self::stride(w) as u64 * h as u64;
        let Some(staging) = self.mapped_staging(device, bytes) else { return false };
        self.paint(balls, place, rect, order);
        let Ok(mut view) = staging.get_mapped_range_mut(..bytes) else {
            self.staging = None;
            return false;
        };
        view.copy_from_slice(bytemuck::cast_slice(&self.pixels));
        drop(view);
        staging.unmap();
        self.staging_mapped = false;
        true
    }

    /// Whether the staging buffer for `rect` can be made on `device`.
    pub(super) fn fits(device: &wgpu::Device, rect: PixelRect) -> bool {
        let [_, _, w, h] = rect;
        w <= MAX_SIDE && h <= MAX_SIDE && 4 * Self::stride(w) as u64 * h as u64 <= device.limits().max_buffer_size
    }

    /// Pixels per row for a rectangle `w` pixels wide: room for a last group of four, and a
    /// multiple of 256 bytes, as a copy from a buffer into a texture needs.
    fn stride(w: u32) -> usize {
        (w as usize + LANES).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize / 4)
    }

    /// The staging buffer, at least `bytes` long and mapped for writing; `None` if it cannot be
    /// mapped.
    ///
    /// Why a buffer of our own, kept from frame to frame, rather than `Queue::write_texture`:
    /// that makes a new staging buffer at every call, and on llvmpipe (GL) each is fresh memory
    /// from the system: a frame pays the page faults of all its pixels (the cost is in
    /// docs/measurements.md, *Figures behind the renderer's choices*). Mapping it again waits for
    /// the GPU to have copied the last frame out of it, which the caller has already waited for.
    fn mapped_staging(&mut self, device: &wgpu::Device, bytes: u64) -> Option<wgpu::Buffer> {
        if self.staging.as_ref().is_none_or(|b| b.size() < bytes) {
            self.staging = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("splat pixels"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: true,
            }));
            self.staging_mapped = true;
        }
        let staging = self.staging.clone()?;
        if !self.staging_mapped {
            let (tx, rx) = std::sync::mpsc::channel();
            staging.map_async(wgpu::MapMode::Write, .., move |r| {
                let _ = tx.send(r);
            });
            let done = device.poll(wgpu::PollType::wait_indefinitely()).is_ok();
            if !(done && matches!(rx.try_recv(), Ok(Ok(())))) {
                log::warn!("the splat's staging buffer cannot be mapped: balls drawn as triangles");
                self.staging = None;
                return None;
            }
            self.staging_mapped = true;
        }
        Some(staging)
    }

    /// Fills `rect` (inside the target) with the field's colour and draws `balls` over it, in
    /// their order, clipped to it, into `self.pixels`.
    fn paint(&mut self, balls: &[BallSprite], place: Placement, rect: PixelRect, order: PixelOrder) {
        let [x, y, w, h] = rect;
        self.rect = rect;
        self.stride = Self::stride(w);
        let field = palette::FIELD_RGB.map(|c| (c * 255.0).round() as u32);
        self.pixels.clear();
        self.pixels.resize(self.stride * h as usize, pack(field, order));
        // Ball centres relative to the rectangle's corner.
        let origin = [place.origin[0] - x as f32, place.origin[1] - y as f32];
        balls
            .par_iter()
            .with_min_len(4096)
            .map(|b| {
                let centre = [origin[0] + b.x * place.scale, origin[1] - b.y * place.scale];
                Placed::new(centre, b.radius * place.scale, b.colour, w, h)
            })
            .collect_into_vec(&mut self.placed);
        // Sort the balls into their bands, in order: count, offsets, fill (a stable counting
        // sort). The balls are copied, not indexed: each band then reads its balls in one sweep
        // through memory (indices into all the balls, read band by band, missed the cache on
        // nearly every ball).
        let bands_of = |p: &Placed| match p.rows {
            [first, end] if first < end => first as usize / BAND_ROWS..(end as usize - 1) / BAND_ROWS + 1,
            _ => 0..0,
        };
        let bands = (h as usize).div_ceil(BAND_ROWS);
        self.band_start.clear();
        self.band_start.resize(bands + 1, 0);
        for p in &self.placed {
            for band in bands_of(p) {
                self.band_start[band + 1] += 1;
            }
        }
        for k in 0..bands {
            self.band_start[k + 1] += self.band_start[k];
        }
        self.banded.resize(self.band_start[bands] as usize, Placed::default());
        let mut next = self.band_start.clone();
        for p in &self.placed {
            for band in bands_of(p) {
                self.banded[next[band] as usize] = *p;
                next[band] += 1;
            }
        }
        let (stride, band_start, banded) = (self.stride, &self.band_start, &self.banded);
        let draw_band = |(k, band): (usize, &mut [u32])| {
            let first_row = (k * BAND_ROWS) as u32;
            let last_row = first_row + (band.len() / stride) as u32;
            for p in &banded[band_start[k] as usize..band_start[k + 1] as usize] {
                let d = Disc::new(p, order);
                for y in (p.rows[0] as u32).max(first_row)..(p.rows[1] as u32).min(last_row) {
                    d.row(&mut band[(y - first_row) as usize * stride..][..stride], y);
                }
            }
        };
        // The bands share no pixel: they are drawn on rayon's threads, and every pixel comes out
        // the same however they are shared (the gain is in docs/measurements.md, *Figures behind
        // the renderer's choices*).
        self.pixels.par_chunks_mut(BAND_ROWS * stride).enumerate().with_min_len(4).for_each(draw_band);
    }

    /// Records, on `encoder`, the copy of the last [`Self::draw`] into `texture` (which needs
    /// `COPY_DST`) at `origin`, before whatever is recorded next. One draw per submission: the
    /// next draw waits for this copy to be done.
    pub(super) fn upload(&self, encoder: &mut wgpu::CommandEncoder, texture: &wgpu::Texture, origin: [u32; 2]) {
        let [_, _, w, h] = self.rect;
        let Some(staging) = &self.staging else { return };
        encoder.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer: staging,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * self.stride as u32),
                    rows_per_image: None,
                },
            },
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: origin[0], y: origin[1], z: 0 },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
    }

    /// The rectangle of the last [`Self::draw`].
    pub(super) fn rect(&self) -> PixelRect {
        self.rect
    }
}

/// Draws the splatted pixels onto a target they cannot be copied into (`shaders/splat.wgsl`):
/// copied into a texture of their own, then drawn as one opaque rectangle. On llvmpipe, a GL
/// surface is such a target: it can only be rendered to.
pub(super) struct SplatBlit {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    format: wgpu::TextureFormat,
    /// The texture the pixels are copied into, and its bind group; made again at another size.
    texture: Option<(wgpu::Texture, wgpu::BindGroup)>,
    /// The rectangle is to be drawn in this frame.
    pending: bool,
}

/// `struct Blit` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BlitUniform {
    rect: [f32; 4],
    target_size: [f32; 2],
    _pad: [f32; 2],
}

impl SplatBlit {
    /// The pipeline for targets of `format`.
    pub(super) fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> SplatBlit {
        let entry = |binding, visibility, ty| wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("splat blit"),
            entries: &[
                entry(
                    0,
                    wgpu::ShaderStages::VERTEX_FRAGMENT,
                    wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                ),
                entry(
                    1,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                ),
            ],
        });
        let shader = device.create_shader_module(wgpu::include_wgsl!("../../shaders/splat.wgsl"));
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("splat blit"),
            layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("splat blit"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            })),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleStrip,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                // Opaque: the pixels are the field's, balls and all.
                targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splat blit"),
            size: std::mem::size_of::<BlitUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        SplatBlit { pipeline, layout, uniform, format, texture: None, pending: false }
    }

    /// Records the copy of `splat`'s last pixels (drawn in RGBA order) into the blit's texture,
    /// for [`Self::draw`] on a `target_size` target.
    pub(super) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        splat: &Splat,
        target_size: [u32; 2],
    ) {
        let [x, y, w, h] = splat.rect();
        if self.texture.as_ref().is_none_or(|(t, _)| (t.width(), t.height()) != (w, h)) {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("splat pixels"),
                size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                // Loading from an sRGB texture decodes what writing to an sRGB target encodes.
                format: if self.format.is_srgb() {
                    wgpu::TextureFormat::Rgba8UnormSrgb
                } else {
                    wgpu::TextureFormat::Rgba8Unorm
                },
                usage: wgpu::TextureUsages::COPY_DST | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("splat blit"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: self.uniform.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                ],
            });
            self.texture = Some((texture, group));
        }
        let (texture, _) = self.texture.as_ref().expect("made above");
        splat.upload(encoder, texture, [0, 0]);
        let uniform = BlitUniform {
            rect: [x as f32, y as f32, w as f32, h as f32],
            target_size: target_size.map(|s| s as f32),
            _pad: [0.0; 2],
        };
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&uniform));
        self.pending = true;
    }

    /// Draws the rectangle prepared for this frame, if any. It binds its own group 0.
    pub(super) fn draw(&mut self, pass: &mut wgpu::RenderPass<'_>) {
        if !std::mem::take(&mut self.pending) {
            return;
        }
        let (_, group) = self.texture.as_ref().expect("prepare made it");
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..4, 0..1);
    }
}

impl Placed {
    /// A ball of radius `radius` (pixels) centred at `centre` (pixels from the rectangle's
    /// corner), with its packed colour; if it misses the `w × h` rectangle, its rows are empty.
    /// Pixels whose centre is within radius + ½ of the ball's centre get some coverage.
    #[inline(always)]
    fn new(centre: [f32; 2], radius: f32, colour: u32, w: u32, h: u32) -> Placed {
        let reach = radius + 0.5;
        let span = |c: f32, n: u32| {
            [floor(c - reach).clamp(0, n as i32) as u16, (floor(c + reach) + 1).clamp(0, n as i32) as u16]
        };
        let (columns, mut rows) = (span(centre[0], w), span(centre[1], h));
        if columns[0] >= columns[1] {
            rows = [0, 0];
        }
        Placed { centre, radius, colour, columns, rows }
    }
}

/// One ball, ready to draw: where, which pixels, which colours.
struct Disc {
    /// Centre, pixels from the rectangle's corner.
    centre: [f32; 2],
    /// The pixel columns it touches: `[first, end)`.
    columns: [usize; 2],
    /// Radius + ½ pixel: coverage is `clamp(reach - d, 0, 1)` at distance d from the centre.
    reach: f32,
    /// fs_main's shading, as a mix from `base` towards `towards` by
    /// `clamp(d + shift, 0, 1) · strength`: a darker rim for a plain ball, a ring for the key
    /// ball and a held one. Colours in the target's byte order, 0–255.
    shift: f32,
    strength: f32,
    base: [f32; 3],
    towards: [f32; 3],
}

impl Disc {
    /// The disc of a placed ball.
    #[inline(always)]
    fn new(p: &Placed, order: PixelOrder) -> Disc {
        let (radius, colour) = (p.radius, p.colour);
        let base = [colour & 255, (colour >> 8) & 255, (colour >> 16) & 255].map(|c| c as f32);
        let (towards, shift, strength) = match colour >> 24 {
            s if s == BallStyle::Plain as u32 => ([0.0; 3], 2.0 - radius, 0.35),
            s => {
                let inner = radius - (radius * 0.22).max(1.5);
                let ring = if s == BallStyle::Held as u32 { [255.0, 216.75, 25.5] } else { [255.0; 3] };
                (ring, 0.5 - inner, 1.0)
            }
        };
        let swap = |c: [f32; 3]| if order == PixelOrder::Bgra { [c[2], c[1], c[0]] } else { c };
        Disc {
            centre: p.centre,
            columns: [p.columns[0] as usize, p.columns[1] as usize],
            reach: radius + 0.5,
            shift,
            strength,
            base: swap(base),
            towards: swap(towards),
        }
    }

    /// Draws the disc's part of pixel row `y`, `row` (with room for a last group of four).
    #[inline(always)]
    fn row(&self, row: &mut [u32], y: u32) {
        let dy = y as f32 + 0.5 - self.centre[1];
        // Groups of four from the first column; the last may reach past the disc's columns (and
        // past the rectangle, into the row's spare room): those pixels are outside the disc and
        // keep their value.
        for x in (self.columns[0]..self.columns[1]).step_by(LANES) {
            let group: &mut [u32; LANES] = (&mut row[x..x + LANES]).try_into().expect("the row has room");
            self.blend(group, x as f32 + 0.5 - self.centre[0], dy * dy);
        }
    }

    /// Blends the disc over four pixels of a row: the first `dx` pixels right of the centre,
    /// `dy2` the squared vertical distance. Written lane by lane over arrays so that the
    /// compiler makes SIMD of it (SSE2 on x86-64: four square roots in one instruction).
    #[inline(always)]
    fn blend(&self, group: &mut [u32; LANES], dx: f32, dy2: f32) {
        let mut coverage = [0.0f32; LANES];
        let mut mix = [0.0f32; LANES];
        for l in 0..LANES {
            let x = dx + l as f32;
            let d = (x * x + dy2).sqrt();
            coverage[l] = (self.reach - d).clamp(0.0, 1.0);
            mix[l] = (d + self.shift).clamp(0.0, 1.0) * self.strength;
        }
        let mut out = [0xFF00_0000u32; LANES];
        for c in 0..3 {
            let shift = 8 * c as u32;
            for l in 0..LANES {
                let under = ((group[l] >> shift) & 255) as f32;
                let shade = self.base[c] + (self.towards[c] - self.base[c]) * mix[l];
                // Premultiplied "over", as the pipeline's blend state; adding 1.5·2²³ leaves the
                // value rounded to an integer in the float's low mantissa bits (a plain `as`
                // conversion saturates, which the compiler cannot do four at a time). The value
                // is within 0..=255, so its low byte is all there is.
                let v = under + (shade - under) * coverage[l] + 12_582_912.0;
                out[l] |= (v.to_bits() & 255) << shift;
            }
        }
        *group = out;
    }
}

/// `v.floor() as i32` without a call into libm (x86-64's baseline has no rounding instruction);
/// saturating at the ends of i32 as `as` does.
fn floor(v: f32) -> i32 {
    let t = v as i32;
    t - ((t as f32) > v) as i32
}

/// An opaque colour in the target's byte order.
fn pack(rgb: [u32; 3], order: PixelOrder) -> u32 {
    let [r, g, b] = rgb;
    let (first, third) = if order == PixelOrder::Bgra { (b, r) } else { (r, b) };
    first | (g << 8) | (third << 16) | 0xFF00_0000
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_matches_std() {
        for v in [-2.5f32, -2.0, -0.5, -0.0, 0.0, 0.3, 1.0, 1.7, 1e9, -1e9, 3e10] {
            assert_eq!(floor(v), v.floor() as i32, "{v}");
        }
    }

    #[test]
    fn a_ball_covers_its_centre_and_not_beyond_its_edge() {
        let mut splat = Splat::default();
        let place = Placement { scale: 10.0, origin: [0.0, 20.0] };
        // A 5 px ball centred on pixel (10, 10) of a 20 × 20 rectangle.
        let ball = BallSprite { x: 1.05, y: 0.95, radius: 0.5, colour: palette::BALLS[0] & 0x00FF_FFFF };
        splat.paint(&[ball], place, [0, 0, 20, 20], PixelOrder::Rgba);
        let at = |x: usize, y: usize| splat.pixels[y * splat.stride + x];
        let field = pack(palette::FIELD_RGB.map(|c| (c * 255.0).round() as u32), PixelOrder::Rgba);
        assert_ne!(at(10, 10), field);
        assert_eq!(at(10, 10) >> 24, 255);
        // 6 px from the centre: outside radius + ½.
        assert_eq!(at(16, 10), field);
        assert_eq!(at(10, 4), field);
        assert_eq!(at(0, 0), field);
        // BGRA swaps red and blue.
        let rgba = at(10, 10);
        splat.paint(&[ball], place, [0, 0, 20, 20], PixelOrder::Bgra);
        let bgra = splat.pixels[10 * splat.stride + 10];
        assert_eq!(bgra, (rgba & 0xFF00_FF00) | ((rgba & 0xFF) << 16) | ((rgba >> 16) & 0xFF));
    }

    /// The pixel a plain ball (style 0) gives over `under`, written out from `fs_main` in
    /// `shaders/balls.wgsl` (not from `Disc`): coverage `clamp(r + ½ − d, 0, 1)`, and a rim 35%
    /// darker within 1.5 px of the edge.
    fn reference_pixel(under: [f64; 3], ball: &BallSprite, place: Placement, px: [f64; 2]) -> [f64; 3] {
        let scale = place.scale as f64;
        let centre = [place.origin[0] as f64 + ball.x as f64 * scale, place.origin[1] as f64 - ball.y as f64 * scale];
        let r = ball.radius as f64 * scale;
        let d = ((px[0] - centre[0]).powi(2) + (px[1] - centre[1]).powi(2)).sqrt();
        let coverage = (r + 0.5 - d).clamp(0.0, 1.0);
        let rim = (d - (r - 1.5) + 0.5).clamp(0.0, 1.0);
        let rgb = [ball.colour & 255, (ball.colour >> 8) & 255, (ball.colour >> 16) & 255];
        std::array::from_fn(|c| {
            let shade = rgb[c] as f64 * (1.0 - 0.35 * rim);
            under[c] + (shade - under[c]) * coverage
        })
    }

    /// Balls across the rectangle's edges are clipped to it, and what is left of them inside is
    /// drawn as if the rectangle went on: a ball across the left edge, one across the top right
    /// corner, one across the bottom edge, and one far outside. Every pixel of the rectangle is
    /// within a level of the reference computed pixel by pixel, and the parts inside are there.
    /// Seen to fail by clipping balls one pixel short of the right and bottom edges (the end of
    /// `span` in `Placed::new` clamped to `n - 1`): a pixel 172 levels off.
    #[test]
    fn balls_across_the_edges_are_clipped_and_drawn_to_the_edge() {
        let mut splat = Splat::default();
        let place = Placement { scale: 10.0, origin: [0.0, 20.0] };
        let plain = |k: usize| palette::BALLS[k] & 0x00FF_FFFF;
        let balls = [
            // Centre 1 px left of the rectangle, 3 px radius: columns 0–2 of rows 7–12 covered.
            BallSprite { x: -0.1, y: 1.0, radius: 0.3, colour: plain(1) },
            // Centre 1 px right of and 1 px above the top-right corner.
            BallSprite { x: 2.1, y: 2.1, radius: 0.3, colour: plain(2) },
            // Centre on the bottom edge, 4 px radius.
            BallSprite { x: 1.0, y: 0.0, radius: 0.4, colour: plain(4) },
            BallSprite { x: 1e9, y: -1e9, radius: 0.3, colour: plain(3) },
        ];
        let (w, h) = (20usize, 20usize);
        splat.paint(&balls, place, [0, 0, w as u32, h as u32], PixelOrder::Rgba);
        let field = palette::FIELD_RGB.map(|c| (c * 255.0).round());
        let mut worst = 0.0f64;
        let mut ball_pixels = [0usize; 4];
        for y in 0..h {
            for x in 0..w {
                let centre = [x as f64 + 0.5, y as f64 + 0.5];
                let mut want = field;
                for b in &balls {
                    want = reference_pixel(want, b, place, centre);
                }
                let got = splat.pixels[y * splat.stride + x];
                assert_eq!(got >> 24, 255, "pixel ({x}, {y}) is not opaque");
                for (c, want) in want.iter().enumerate() {
                    worst = worst.max((((got >> (8 * c)) & 255) as f64 - want).abs());
                }
                // The pixels each ball alone would touch, by the reference.
                for (k, b) in balls.iter().enumerate() {
                    if reference_pixel(field, b, place, centre) != field {
                        ball_pixels[k] += 1;
                    }
                }
            }
        }
        assert!(worst <= 1.0, "a pixel is {worst} levels from the reference");
        // The parts inside, by the reference: the left ball's right third, a corner of the
        // top-right one, the bottom one's upper half; nothing of the far one. (Which pixels the
        // test exercises, not a check of the splat.)
        assert_eq!(ball_pixels, [10, 3, 30, 0]);
        // The left ball reaches column 0, the top-right one row 0 and column 19, the bottom one
        // row 19: the edges are drawn, not left to the field's colour.
        let at = |x: usize, y: usize| splat.pixels[y * splat.stride + x];
        let field_px = pack(field.map(|c| c as u32), PixelOrder::Rgba);
        assert_ne!(at(0, 10), field_px);
        assert_ne!(at(19, 0), field_px);
        assert_ne!(at(10, 19), field_px);
    }
}
