//! The renderer: one `render(view, snapshot)` path for the window and the offscreen target.

use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

use super::layout::Layout;
use super::snapshot::{BallSprite, FrameSnapshot, Segment, palette};
use super::splat::{PixelRect, Splatter};

/// How the balls are drawn. Every path draws the same discs (see `shaders/balls.wgsl` and
/// `shaders/splat.wgsl`); they differ in what they cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BallPath {
    /// The default: each ball by its size on screen. Balls of at most [`SPLAT_MAX_RADIUS_PX`]
    /// are splatted (see [`BallPath::Splat`]), larger ones drawn as [`BallPath::Triangles`], over
    /// the splatted ones. On a device without compute shaders, all are triangles.
    Auto,
    /// Every ball splatted by a compute shader into a buffer of per-pixel sums, blended over the
    /// frame by one rectangle: no primitive per ball. A CPU rasteriser pays about 1 µs for each
    /// primitive (setup, binning, a fragment-shader call per 4×4 block) however small, and the
    /// splat about 20 ns per covered pixel, so it wins for balls a few pixels across (100,000
    /// of them: see benches/render.rs) and loses for large ones. Falls back to
    /// [`BallPath::Triangles`] on a device without compute shaders.
    Splat,
    /// One instance per ball, a 4-vertex triangle strip each.
    Instanced,
    /// One non-instanced indexed draw, every ball's data repeated on its 4 vertices.
    ///
    /// Mesa's CPU drivers run an instanced draw instance by instance, each with its own small
    /// vertex batch and setup, about 2 µs apiece; one large draw runs the vertex shader over
    /// all the vertices in wide SIMD batches instead. The price is 4× the upload (64 bytes a
    /// ball), negligible next to that.
    Expanded,
    /// One non-instanced draw of one triangle (3 vertices) per ball, the equilateral triangle
    /// around the disc. Half the triangles of a quad for about 30% more pixels; on a CPU
    /// rasteriser the per-triangle setup is what costs, so this is the fastest way to draw
    /// balls as primitives.
    Triangles,
}

/// The largest radius on screen, pixels, of a ball [`BallPath::Auto`] splats.
pub const SPLAT_MAX_RADIUS_PX: f32 = 4.0;

/// How a frame's balls are drawn (see `Renderer::sort_balls`).
#[derive(Clone, Copy, Debug)]
enum Split {
    /// All as primitives, straight from the snapshot.
    AllPrimitives,
    /// The small ones splatted over `splat` (`None`: none on the target), the rest as primitives.
    Sorted { splat: Option<PixelRect> },
}

/// The uniform both shaders read (see `struct Globals` in them).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct Globals {
    scale: f32,
    srgb_target: u32,
    origin: [f32; 2],
    target: [f32; 2],
    _pad: [f32; 2],
}

/// A growable GPU buffer (vertices, indices, storage).
pub(super) struct GrowBuffer {
    pub(super) buffer: wgpu::Buffer,
    capacity: u64,
    usage: wgpu::BufferUsages,
    label: &'static str,
}

impl GrowBuffer {
    pub(super) fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages, capacity: u64) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: capacity,
            usage,
            mapped_at_creation: false,
        });
        GrowBuffer { buffer, capacity, usage, label }
    }

    /// Makes room for `need` bytes (growing to the next power of two; the contents are lost
    /// then). Returns whether the buffer is a new one.
    pub(super) fn reserve(&mut self, device: &wgpu::Device, need: u64) -> bool {
        if need <= self.capacity {
            return false;
        }
        self.capacity = need.next_power_of_two();
        self.buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(self.label),
            size: self.capacity,
            usage: self.usage,
            mapped_at_creation: false,
        });
        true
    }

    /// Writes `data` at the start, growing if it does not fit. Returns whether the buffer is a
    /// new one.
    pub(super) fn write(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, data: &[u8]) -> bool {
        let grew = self.reserve(device, data.len() as u64);
        if !data.is_empty() {
            queue.write_buffer(&self.buffer, 0, data);
        }
        grew
    }
}

/// Draws a [`FrameSnapshot`]: the field, its walls, the balls, then the overlays.
pub struct Renderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    format: wgpu::TextureFormat,
    path: BallPath,
    globals: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    balls_strip: wgpu::RenderPipeline,
    balls_list: wgpu::RenderPipeline,
    balls_triangles: wgpu::RenderPipeline,
    segments: wgpu::RenderPipeline,
    background: wgpu::RenderPipeline,
    ball_buffer: GrowBuffer,
    index_buffer: GrowBuffer,
    indexed_balls: u32,
    segment_buffer: GrowBuffer,
    /// `None` when the device has no compute shaders.
    splatter: Option<Splatter>,
    // Scratch, kept between frames.
    expanded: Vec<BallSprite>,
    small: Vec<BallSprite>,
    large: Vec<BallSprite>,
    segment_scratch: Vec<Segment>,
}

const BALL_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];
const SEGMENT_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x2, 2 => Uint32];

impl Renderer {
    /// Pipelines for targets of `format` (the surface's, or the offscreen texture's).
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Renderer {
        let globals = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("globals"),
            contents: bytemuck::bytes_of(&Globals::zeroed()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("globals"),
            layout: &bind_group_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: globals.as_entire_binding() }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ballfield"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let balls_shader = device.create_shader_module(wgpu::include_wgsl!("../../shaders/balls.wgsl"));
        let segments_shader = device.create_shader_module(wgpu::include_wgsl!("../../shaders/segments.wgsl"));
        let pipeline_at = |label: &str,
                           entry: &str,
                           shader: &wgpu::ShaderModule,
                           buffer: wgpu::VertexBufferLayout<'_>,
                           topology: wgpu::PrimitiveTopology,
                           blend: Option<wgpu::BlendState>| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: shader,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers: &[Some(buffer)],
                },
                primitive: wgpu::PrimitiveState { topology, cull_mode: None, ..Default::default() },
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: shader,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format, blend, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let pipeline = |label: &str,
                        shader: &wgpu::ShaderModule,
                        buffer: wgpu::VertexBufferLayout<'_>,
                        topology: wgpu::PrimitiveTopology,
                        blend: Option<wgpu::BlendState>| {
            pipeline_at(label, "vs_main", shader, buffer, topology, blend)
        };
        let ball_layout = |step_mode| wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<BallSprite>() as u64,
            step_mode,
            attributes: &BALL_ATTRIBUTES,
        };
        let balls_strip = pipeline(
            "balls (instanced)",
            &balls_shader,
            ball_layout(wgpu::VertexStepMode::Instance),
            wgpu::PrimitiveTopology::TriangleStrip,
            Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
        );
        let balls_list = pipeline(
            "balls (expanded)",
            &balls_shader,
            ball_layout(wgpu::VertexStepMode::Vertex),
            wgpu::PrimitiveTopology::TriangleList,
            Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
        );
        let balls_triangles = pipeline_at(
            "balls (triangles)",
            "vs_triangle",
            &balls_shader,
            ball_layout(wgpu::VertexStepMode::Vertex),
            wgpu::PrimitiveTopology::TriangleList,
            Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
        );
        let segment_layout = || wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Segment>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &SEGMENT_ATTRIBUTES,
        };
        let segments = pipeline(
            "segments",
            &segments_shader,
            segment_layout(),
            wgpu::PrimitiveTopology::TriangleStrip,
            Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
        );
        // Opaque: no blending, no read of the target.
        let background =
            pipeline("background", &segments_shader, segment_layout(), wgpu::PrimitiveTopology::TriangleStrip, None);
        let vertex = wgpu::BufferUsages::VERTEX;
        Renderer {
            device: device.clone(),
            queue: queue.clone(),
            format,
            path: BallPath::Auto,
            globals,
            bind_group,
            balls_strip,
            balls_list,
            balls_triangles,
            segments,
            background,
            ball_buffer: GrowBuffer::new(device, "balls", vertex, 64 * 1024),
            index_buffer: GrowBuffer::new(device, "ball indices", wgpu::BufferUsages::INDEX, 4),
            indexed_balls: 0,
            segment_buffer: GrowBuffer::new(device, "segments", vertex, 16 * 1024),
            splatter: Splatter::new(device, format),
            expanded: Vec::new(),
            small: Vec::new(),
            large: Vec::new(),
            segment_scratch: Vec::new(),
        }
    }

    /// The format the pipelines were built for.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    pub fn ball_path(&self) -> BallPath {
        self.path
    }

    /// Chooses how balls are drawn (for benches and tests; the default, [`BallPath::Auto`],
    /// picks the faster way for each ball).
    pub fn set_ball_path(&mut self, path: BallPath) {
        self.path = path;
    }

    /// Whether this renderer's device can splat balls (compute shaders and storage buffers).
    pub fn can_splat(&self) -> bool {
        self.splatter.is_some()
    }

    /// Draws `snapshot` into `view` (cleared first) and submits the work.
    pub fn render(&mut self, view: &wgpu::TextureView, snapshot: &FrameSnapshot) {
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ballfield frame") });
        self.encode(&mut encoder, view, snapshot);
        self.queue.submit([encoder.finish()]);
    }

    /// Records the drawing of `snapshot` into `view` (cleared first) on `encoder`, for callers
    /// that draw more (the window's panel) before submitting.
    pub fn encode(&mut self, encoder: &mut wgpu::CommandEncoder, view: &wgpu::TextureView, snapshot: &FrameSnapshot) {
        let size = view.texture().size();
        let layout = snapshot.layout(size.width, size.height);
        let globals = Globals {
            scale: layout.scale as f32,
            srgb_target: self.format.is_srgb() as u32,
            origin: layout.origin_from_bottom(),
            target: [size.width as f32, size.height as f32],
            _pad: [0.0; 2],
        };
        self.queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));

        // The target is cleared to the field's colour; then the walls and the letterbox are drawn
        // as opaque bands reaching far outside the field (clipped), so no pixel of the field
        // itself is painted twice before the balls: on a CPU rasteriser every covered pixel
        // costs. Each band is a segment with a huge metric half width; its pixel part moves its
        // inner end: 0 for the walls (they start at the field's edge), -WALL_PX for the
        // letterbox (it starts WALL_PX further out).
        let (w, h) = (snapshot.field.width as f32, snapshot.field.height as f32);
        self.segment_scratch.clear();
        for (px, colour) in [(0.0, palette::WALL), (-WALL_PX, palette::OUTSIDE_PACKED)] {
            let band =
                |a: [f32; 2], b: [f32; 2]| Segment { ends: [a[0], a[1], b[0], b[1]], half_width: [FAR, px], colour };
            self.segment_scratch.extend([
                band([-FAR, 0.5 * h], [0.0, 0.5 * h]),
                band([w, 0.5 * h], [w + FAR, 0.5 * h]),
                band([0.5 * w, -FAR], [0.5 * w, 0.0]),
                band([0.5 * w, h], [0.5 * w, h + FAR]),
            ]);
        }
        let background = self.segment_scratch.len() as u32;
        self.segment_scratch.extend_from_slice(&snapshot.overlays);
        self.segment_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(&self.segment_scratch));

        // Which balls are splatted and which drawn as primitives, and the pixels the splat covers.
        let split = self.sort_balls(snapshot, &layout, size.width, size.height);
        if let (Split::Sorted { splat: Some(rect) }, Some(splatter)) = (split, &mut self.splatter) {
            splatter.prepare(&self.device, &self.queue, encoder, &self.globals, &self.small, rect);
        }
        let large = match split {
            Split::AllPrimitives => &snapshot.balls,
            Split::Sorted { .. } => &self.large,
        };
        let n = large.len() as u32;
        let raster = match self.path {
            BallPath::Instanced | BallPath::Expanded => self.path,
            _ => BallPath::Triangles,
        };
        match raster {
            BallPath::Instanced => {
                self.ball_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(large));
            }
            BallPath::Expanded => {
                self.expanded.clear();
                self.expanded.extend(large.iter().flat_map(|b| [*b; 4]));
                self.ball_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(&self.expanded));
                if n > self.indexed_balls {
                    // Indices only change when the count grows past what they cover.
                    let cover = n.next_power_of_two();
                    let indices: Vec<u32> = (0..cover).flat_map(|b| [0, 1, 2, 2, 1, 3].map(|k| 4 * b + k)).collect();
                    self.index_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(&indices));
                    self.indexed_balls = cover;
                }
            }
            _ => {
                self.expanded.clear();
                self.expanded.extend(large.iter().flat_map(|b| [*b; 3]));
                self.ball_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(&self.expanded));
            }
        }

        let [r, g, b] = palette::FIELD_RGB;
        let clear = if self.format.is_srgb() {
            wgpu::Color { r: srgb_to_linear(r), g: srgb_to_linear(g), b: srgb_to_linear(b), a: 1.0 }
        } else {
            wgpu::Color { r, g, b, a: 1.0 }
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("ballfield"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&self.background);
        pass.set_vertex_buffer(0, self.segment_buffer.buffer.slice(..));
        pass.draw(0..4, 0..background);
        if let Some(splatter) = &mut self.splatter {
            // Nothing unless `prepare` ran this frame. It binds its own group 0: the globals'
            // group is bound again below.
            splatter.resolve(&mut pass);
            pass.set_bind_group(0, &self.bind_group, &[]);
        }
        if n > 0 {
            match raster {
                BallPath::Instanced => {
                    pass.set_pipeline(&self.balls_strip);
                    pass.set_vertex_buffer(0, self.ball_buffer.buffer.slice(..));
                    pass.draw(0..4, 0..n);
                }
                BallPath::Expanded => {
                    pass.set_pipeline(&self.balls_list);
                    pass.set_vertex_buffer(0, self.ball_buffer.buffer.slice(..));
                    pass.set_index_buffer(self.index_buffer.buffer.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..6 * n, 0, 0..1);
                }
                _ => {
                    pass.set_pipeline(&self.balls_triangles);
                    pass.set_vertex_buffer(0, self.ball_buffer.buffer.slice(..));
                    pass.draw(0..3 * n, 0..1);
                }
            }
        }
        let overlays = snapshot.overlays.len() as u32;
        if overlays > 0 {
            pass.set_pipeline(&self.segments);
            pass.set_vertex_buffer(0, self.segment_buffer.buffer.slice(..));
            pass.draw(0..4, background..background + overlays);
        }
    }

    /// Splits the snapshot's balls for this frame: those to splat into `self.small`, the rest into
    /// `self.large`, each in their order.
    fn sort_balls(&mut self, snapshot: &FrameSnapshot, layout: &Layout, width: u32, height: u32) -> Split {
        self.small.clear();
        self.large.clear();
        let limit = match self.path {
            _ if self.splatter.is_none() || snapshot.balls.is_empty() => return Split::AllPrimitives,
            BallPath::Auto => SPLAT_MAX_RADIUS_PX / layout.scale as f32,
            BallPath::Splat => f32::INFINITY,
            BallPath::Instanced | BallPath::Expanded | BallPath::Triangles => return Split::AllPrimitives,
        };
        // The splatted balls' extent, m: x0, y0, x1, y1.
        let mut extent = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
        for b in &snapshot.balls {
            if b.radius <= limit {
                extent[0] = extent[0].min(b.x - b.radius);
                extent[1] = extent[1].min(b.y - b.radius);
                extent[2] = extent[2].max(b.x + b.radius);
                extent[3] = extent[3].max(b.y + b.radius);
                self.small.push(*b);
            } else {
                self.large.push(*b);
            }
        }
        if self.small.is_empty() {
            return Split::Sorted { splat: None };
        }
        // To pixels (y down), one pixel of anti-aliased edge around, inside the target.
        let scale = layout.scale as f32;
        let (ox, oy) = (layout.origin.x as f32, layout.origin.y as f32);
        let x0 = ((ox + extent[0] * scale).floor() - 1.0).max(0.0);
        let x1 = ((ox + extent[2] * scale).ceil() + 1.0).min(width as f32);
        let y0 = ((oy - extent[3] * scale).floor() - 1.0).max(0.0);
        let y1 = ((oy - extent[1] * scale).ceil() + 1.0).min(height as f32);
        let rect = [x0 as i32, y0 as i32, (x1 - x0) as i32, (y1 - y0) as i32];
        if rect[2] <= 0 || rect[3] <= 0 {
            // The small balls are all off the target.
            return Split::Sorted { splat: None };
        }
        if !Splatter::fits(&self.device, rect) {
            // A target too large for one storage binding: primitives after all.
            return Split::AllPrimitives;
        }
        Split::Sorted { splat: Some(rect) }
    }
}

/// Width of the walls, pixels.
const WALL_PX: f32 = 4.0;
/// How far (m) the background bands reach out of the field: beyond any target.
const FAR: f32 = 1.0e4;

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}
