//! The renderer: one drawing of a snapshot into a view, [`Renderer::encode`], for the window and
//! the offscreen target ([`Renderer::render`] is it, submitted at once).

use bytemuck::{Pod, Zeroable};
use glam::DVec2;
use wgpu::util::DeviceExt;

use super::layout::Layout;
use super::snapshot::{BallSprite, FrameSnapshot, Segment, palette};
use super::splat::{PixelOrder, PixelRect, Placement, Splat, SplatBlit};

/// How the balls are drawn. Every path draws the same discs (see `shaders/balls.wgsl` and
/// `src/render/splat.rs`); they differ in what they cost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BallPath {
    /// The default: on a CPU adapter (Mesa's lavapipe or llvmpipe), once a frame has at least
    /// [`SPLAT_MIN_BALLS`] balls of at most [`SPLAT_MAX_RADIUS_PX`] on screen, those are
    /// splatted (see [`BallPath::Splat`]) and larger ones drawn as [`BallPath::Triangles`] over
    /// them. Otherwise, and on a real GPU, all are triangles.
    Auto,
    /// Every ball splatted: the field's pixels computed on the CPU, four pixels at a time, and
    /// copied into the target (see `src/render/splat.rs`); no primitive per ball. A CPU rasteriser
    /// pays about 1 µs for each primitive however small, the splat a few nanoseconds per
    /// pixel, so it wins by far for 100,000 balls 1.6 px across (see benches/render.rs) and
    /// loses for very large ones. The pixels are copied into a target with `COPY_DST` usage in
    /// `Rgba8Unorm` or `Bgra8Unorm`, and drawn onto any other as one textured rectangle (a GL
    /// surface can only be drawn into; an sRGB target then shows the balls' edges blended in
    /// sRGB rather than in linear light).
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

/// The largest radius on screen, pixels, of a ball [`BallPath::Auto`] splats. A CPU rasteriser
/// pays for every primitive and, through its fragment shader, for every pixel a triangle covers
/// too, so the splat is as fast as triangles or faster up to fairly large balls; beyond, a few
/// large balls are cheaper as triangles. 16 px is half the radius at which the two measured even
/// on lavapipe (docs/measurements.md, *Figures behind the renderer's choices*).
pub const SPLAT_MAX_RADIUS_PX: f32 = 16.0;

/// The fewest small balls for which [`BallPath::Auto`] splats. Below, a frame costs well under a
/// millisecond either way (docs/measurements.md, *Figures behind the renderer's choices*), and a
/// few balls on a large target are cheaper as triangles than filling and writing the whole field.
pub const SPLAT_MIN_BALLS: usize = 100;

/// How the balls of a frame were drawn (see [`BallPath`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameBalls {
    /// Balls whose pixels the CPU computed ([`BallPath::Splat`]).
    pub splatted: usize,
    /// Balls drawn as GPU primitives ([`BallPath::Triangles`], [`BallPath::Expanded`] or
    /// [`BallPath::Instanced`]).
    pub primitives: usize,
}

/// How a frame's balls are drawn (see `Renderer::sort_balls`).
#[derive(Clone, Copy, Debug)]
enum Split {
    /// All as primitives, straight from the snapshot, over a cleared target.
    AllPrimitives,
    /// The small ones splatted into `rect` (the field, its pixels all written by the splat), the
    /// rest as primitives. With `all`, every ball is splatted, straight from the snapshot;
    /// otherwise they were sorted into `Renderer::small` and `Renderer::large`. With `copy`, the
    /// pixels are copied into the target; otherwise drawn onto it (a [`SplatBlit`]).
    Splatted { rect: PixelRect, order: PixelOrder, all: bool, copy: bool },
}

/// The balls of a frame drawn as primitives: how, and how many.
#[derive(Clone, Copy, Debug)]
struct Primitives {
    /// [`BallPath::Instanced`], [`BallPath::Expanded`] or [`BallPath::Triangles`].
    path: BallPath,
    count: u32,
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
    /// Balls of the last frame splatted, and drawn as primitives.
    last_frame: FrameBalls,
    segment_buffer: GrowBuffer,
    /// The adapter is a CPU (Mesa's lavapipe or llvmpipe): [`BallPath::Auto`] splats.
    cpu_adapter: bool,
    splat: Splat,
    splat_blit: SplatBlit,
    // Scratch, kept between frames.
    expanded: Vec<BallSprite>,
    small: Vec<BallSprite>,
    large: Vec<BallSprite>,
    segment_scratch: Vec<Segment>,
}

const BALL_ATTRIBUTES: [wgpu::VertexAttribute; 2] = wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];
const SEGMENT_ATTRIBUTES: [wgpu::VertexAttribute; 3] =
    wgpu::vertex_attr_array![0 => Float32x4, 1 => Float32x2, 2 => Uint32];

/// The globals' uniform buffer, its bind group's layout and the bind group (the vertex stages
/// read the view's transform from it).
fn globals_binding(device: &wgpu::Device) -> (wgpu::Buffer, wgpu::BindGroupLayout, wgpu::BindGroup) {
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
    (globals, bind_group_layout, bind_group)
}

/// The renderer's pipelines (see [`Renderer`]'s fields).
struct Pipelines {
    balls_strip: wgpu::RenderPipeline,
    balls_list: wgpu::RenderPipeline,
    balls_triangles: wgpu::RenderPipeline,
    segments: wgpu::RenderPipeline,
    background: wgpu::RenderPipeline,
}

impl Pipelines {
    /// The five pipelines for targets of `format`, over the globals' bind group layout: balls as
    /// instanced strips, as expanded lists and as triangles; segments; the opaque background.
    fn new(device: &wgpu::Device, bind_group_layout: &wgpu::BindGroupLayout, format: wgpu::TextureFormat) -> Pipelines {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ballfield"),
            bind_group_layouts: &[Some(bind_group_layout)],
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
        Pipelines { balls_strip, balls_list, balls_triangles, segments, background }
    }
}

impl Renderer {
    /// Pipelines for targets of `format` (the surface's, or the offscreen texture's): the
    /// globals' binding ([`globals_binding`]), the five pipelines ([`Pipelines::new`]), and
    /// the buffers, grown as frames need.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, format: wgpu::TextureFormat) -> Renderer {
        let (globals, bind_group_layout, bind_group) = globals_binding(device);
        let Pipelines { balls_strip, balls_list, balls_triangles, segments, background } =
            Pipelines::new(device, &bind_group_layout, format);
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
            last_frame: FrameBalls::default(),
            segment_buffer: GrowBuffer::new(device, "segments", vertex, 16 * 1024),
            cpu_adapter: device.adapter_info().device_type == wgpu::DeviceType::Cpu,
            splat: Splat::default(),
            splat_blit: SplatBlit::new(device, format),
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

    /// How balls are drawn: [`BallPath::Auto`] unless [`Self::set_ball_path`] chose another.
    pub fn ball_path(&self) -> BallPath {
        self.path
    }

    /// How many balls the last frame splatted and drew as primitives.
    pub fn last_frame(&self) -> FrameBalls {
        self.last_frame
    }

    /// Chooses how balls are drawn (for benches and tests; the default, [`BallPath::Auto`],
    /// picks the faster way for each ball).
    pub fn set_ball_path(&mut self, path: BallPath) {
        self.path = path;
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
        let globals = self.write_globals(&layout, size);
        let background = self.write_segments(snapshot);
        let split = self.splat_small_balls(encoder, view.texture(), snapshot, &layout, &globals);
        let primitives = self.write_primitives(snapshot, split);
        // After a splat copied into the target the field's pixels are there already (the copy is
        // recorded before this pass), and the bands cover every pixel outside the field.
        let load = match split {
            Split::Splatted { copy: true, .. } => wgpu::LoadOp::Load,
            _ => wgpu::LoadOp::Clear(self.field_colour()),
        };
        let overlays = snapshot.overlays.len() as u32;
        self.draw_pass(encoder, view, load, background, primitives, overlays);
    }

    /// Where the field lands on the target, for both shaders.
    fn write_globals(&self, layout: &Layout, size: wgpu::Extent3d) -> Globals {
        let globals = Globals {
            scale: layout.scale as f32,
            srgb_target: self.format.is_srgb() as u32,
            origin: layout.origin_from_bottom(),
            target: [size.width as f32, size.height as f32],
            _pad: [0.0; 2],
        };
        self.queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        globals
    }

    /// Uploads the background bands (the walls and the letterbox), then the overlays; returns how
    /// many bands come first.
    ///
    /// The target is cleared to the field's colour, and the walls and the letterbox are drawn as
    /// opaque bands reaching far outside the field (clipped), so no pixel of the field itself is
    /// painted twice: on a CPU rasteriser every covered pixel costs. Each band
    /// is a segment with a huge metric half width; its pixel part moves its inner end: 0 for the
    /// walls (they start at the field's edge), -WALL_PX for the letterbox (it starts WALL_PX
    /// further out).
    fn write_segments(&mut self, snapshot: &FrameSnapshot) -> u32 {
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
        background
    }

    /// Decides which balls are splatted and which drawn as primitives ([`Self::sort_balls`]),
    /// splats the small ones and records their copy into `target` (or prepares their blit onto
    /// it). Falls back to all primitives if the splat cannot be drawn.
    fn splat_small_balls(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::Texture,
        snapshot: &FrameSnapshot,
        layout: &Layout,
        globals: &Globals,
    ) -> Split {
        let split = self.sort_balls(snapshot, layout, target);
        let Split::Splatted { rect, order, all, copy } = split else { return split };
        let height = target.height();
        let place = Placement { scale: globals.scale, origin: [globals.origin[0], height as f32 - globals.origin[1]] };
        let small = if all { &snapshot.balls } else { &self.small };
        if !self.splat.draw(&self.device, small, place, rect, order) {
            return Split::AllPrimitives;
        }
        if copy {
            self.splat.upload(encoder, target, [rect[0], rect[1]]);
        } else {
            self.splat_blit.prepare(&self.device, &self.queue, encoder, &self.splat, [target.width(), height]);
        }
        split
    }

    /// Uploads the balls drawn as primitives this frame (all of them, none, or the large ones, as
    /// `split` says) in the layout their pipeline reads, and counts the frame's balls.
    fn write_primitives(&mut self, snapshot: &FrameSnapshot, split: Split) -> Primitives {
        let large: &[BallSprite] = match split {
            Split::AllPrimitives => &snapshot.balls,
            Split::Splatted { all: true, .. } => &[],
            Split::Splatted { all: false, .. } => &self.large,
        };
        self.last_frame = FrameBalls { splatted: snapshot.balls.len() - large.len(), primitives: large.len() };
        let count = large.len() as u32;
        let path = match self.path {
            BallPath::Instanced | BallPath::Expanded => self.path,
            _ => BallPath::Triangles,
        };
        match path {
            BallPath::Instanced => {
                self.ball_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(large));
            }
            BallPath::Expanded => {
                self.expanded.clear();
                self.expanded.extend(large.iter().flat_map(|b| [*b; 4]));
                self.ball_buffer.write(&self.device, &self.queue, bytemuck::cast_slice(&self.expanded));
                if count > self.indexed_balls {
                    // Indices only change when the count grows past what they cover.
                    let cover = count.next_power_of_two();
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
        Primitives { path, count }
    }

    /// The field's colour, as the target stores it.
    fn field_colour(&self) -> wgpu::Color {
        let [r, g, b] = palette::FIELD_RGB;
        if self.format.is_srgb() {
            wgpu::Color { r: srgb_to_linear(r), g: srgb_to_linear(g), b: srgb_to_linear(b), a: 1.0 }
        } else {
            wgpu::Color { r, g, b, a: 1.0 }
        }
    }

    /// The render pass: the splatted pixels if they are blitted, the balls drawn as primitives,
    /// the `background` bands, then the `overlays` segments after the bands.
    fn draw_pass(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        load: wgpu::LoadOp<wgpu::Color>,
        background: u32,
        balls: Primitives,
        overlays: u32,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("ballfield"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        // The splatted pixels, when they could not be copied in; the blit binds its own group 0.
        self.splat_blit.draw(&mut pass);
        pass.set_bind_group(0, &self.bind_group, &[]);
        let n = balls.count;
        if n > 0 {
            match balls.path {
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
        // The bands after the balls, so that what of a ball reaches over a wall or out of the
        // field is hidden as it is when the ball is splatted (the splat draws only the field's
        // pixels, and the bands go over its edge).
        pass.set_pipeline(&self.background);
        pass.set_vertex_buffer(0, self.segment_buffer.buffer.slice(..));
        pass.draw(0..4, 0..background);
        if overlays > 0 {
            pass.set_pipeline(&self.segments);
            pass.set_vertex_buffer(0, self.segment_buffer.buffer.slice(..));
            pass.draw(0..4, background..background + overlays);
        }
    }

    /// Chooses how this frame's balls are drawn; for a splat of some of them, puts the balls to
    /// splat into `self.small` and the rest into `self.large`, each in their order.
    fn sort_balls(&mut self, snapshot: &FrameSnapshot, layout: &Layout, target: &wgpu::Texture) -> Split {
        self.small.clear();
        self.large.clear();
        let limit = match self.path {
            BallPath::Auto if self.cpu_adapter => SPLAT_MAX_RADIUS_PX / layout.scale as f32,
            BallPath::Splat => f32::INFINITY,
            _ => return Split::AllPrimitives,
        };
        // Copied into the target when its format and usage allow, else drawn onto it in RGBA.
        let copy = PixelOrder::of(target.format()).filter(|_| target.usage().contains(wgpu::TextureUsages::COPY_DST));
        let order = copy.unwrap_or(PixelOrder::Rgba);
        let small = snapshot.balls.iter().filter(|b| b.radius <= limit).count();
        if small == 0 || (self.path == BallPath::Auto && small < SPLAT_MIN_BALLS) {
            return Split::AllPrimitives;
        }
        let all = small == snapshot.balls.len();
        if !all {
            for b in &snapshot.balls {
                if b.radius <= limit { self.small.push(*b) } else { self.large.push(*b) }
            }
        }
        // Every pixel the field touches (those on its edge are drawn over by the walls).
        let (width, height) = (target.width() as f64, target.height() as f64);
        let corner = |p: DVec2| layout.to_pixels(p);
        let a = corner(DVec2::new(0.0, snapshot.field.height));
        let b = corner(DVec2::new(snapshot.field.width, 0.0));
        let (x0, y0) = (a.x.floor().clamp(0.0, width), a.y.floor().clamp(0.0, height));
        let (x1, y1) = (b.x.ceil().clamp(0.0, width), b.y.ceil().clamp(0.0, height));
        let rect = [x0 as u32, y0 as u32, (x1 - x0) as u32, (y1 - y0) as u32];
        if x1 <= x0 || y1 <= y0 || !Splat::fits(&self.device, rect) {
            return Split::AllPrimitives;
        }
        Split::Splatted { rect, order, all, copy: copy.is_some() }
    }
}

/// Width of the walls, pixels.
const WALL_PX: f32 = 4.0;
/// How far (m) the background bands reach out of the field: beyond any target.
const FAR: f32 = 1.0e4;

fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}
