//! Small balls without a primitive each: a compute shader adds every ball's pixels into a buffer,
//! one rectangle blends the buffer over the frame (`shaders/splat.wgsl` says why and how).

use bytemuck::{Pod, Zeroable};

use super::renderer::GrowBuffer;
use super::snapshot::BallSprite;

/// Invocations in a workgroup of `splat` (`@workgroup_size` in the shader).
const WORKGROUP: u32 = 64;

/// Bytes of the accumulation buffer per pixel: two u32 (`rg`, `ba`).
const BYTES_PER_PIXEL: u64 = 8;

/// `struct Splat` in the shader.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct SplatParams {
    rect_min: [i32; 2],
    rect_size: [i32; 2],
    count: u32,
    row: u32,
    _pad: [u32; 2],
}

/// A rectangle of target pixels, top-left origin, y down: `[x, y, width, height]`.
pub(super) type PixelRect = [i32; 4];

/// The splat pipelines and their buffers.
pub(super) struct Splatter {
    splat: wgpu::ComputePipeline,
    resolve: wgpu::RenderPipeline,
    splat_layout: wgpu::BindGroupLayout,
    resolve_layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    balls: GrowBuffer,
    sums: GrowBuffer,
    /// For `splat` and for the resolve; made again when a buffer grows.
    bind_groups: Option<(wgpu::BindGroup, wgpu::BindGroup)>,
    /// The rectangle of the frame being drawn; `None` = nothing to resolve.
    rect: Option<PixelRect>,
}

impl Splatter {
    /// Whether `device` can splat: compute shaders and storage buffers in fragment shaders. A
    /// device created with WebGL2's limits (no storage buffers, no compute) cannot; [`super::Gpu`]
    /// asks for these limits only when the adapter has both.
    pub(super) fn supported(device: &wgpu::Device) -> bool {
        let l = device.limits();
        l.max_storage_buffers_per_shader_stage >= 2
            && l.max_compute_invocations_per_workgroup >= WORKGROUP
            && l.max_compute_workgroup_size_x >= WORKGROUP
            && l.max_compute_workgroups_per_dimension >= 1
    }

    /// The pipelines for targets of `format`, reading the renderer's `globals`; `None` when the
    /// device cannot splat.
    pub(super) fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Option<Splatter> {
        if !Self::supported(device) {
            return None;
        }
        let entry = |binding, visibility, ty| wgpu::BindGroupLayoutEntry { binding, visibility, ty, count: None };
        let uniform = wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let storage = |read_only| wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let compute = wgpu::ShaderStages::COMPUTE;
        let splat_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("splat"),
            entries: &[
                entry(0, compute, uniform),
                entry(1, compute, uniform),
                entry(2, compute, storage(true)),
                entry(3, compute, storage(false)),
            ],
        });
        let draw = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let resolve_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("splat resolve"),
            entries: &[
                entry(0, draw, uniform),
                entry(1, draw, uniform),
                entry(4, wgpu::ShaderStages::FRAGMENT, storage(true)),
            ],
        });
        let shader = device.create_shader_module(wgpu::include_wgsl!("../../shaders/splat.wgsl"));
        let splat = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("splat"),
            layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("splat"),
                bind_group_layouts: &[Some(&splat_layout)],
                immediate_size: 0,
            })),
            module: &shader,
            entry_point: Some("splat"),
            compilation_options: Default::default(),
            cache: None,
        });
        let resolve = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("splat resolve"),
            layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("splat resolve"),
                bind_group_layouts: &[Some(&resolve_layout)],
                immediate_size: 0,
            })),
            vertex: wgpu::VertexState {
                module: &shader,
                entry_point: Some("vs_resolve"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_resolve"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("splat params"),
            size: std::mem::size_of::<SplatParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let storage = wgpu::BufferUsages::STORAGE;
        Some(Splatter {
            splat,
            resolve,
            splat_layout,
            resolve_layout,
            params,
            balls: GrowBuffer::new(device, "splat balls", storage, 64 * 1024),
            sums: GrowBuffer::new(device, "splat sums", storage, 1024 * 1024),
            bind_groups: None,
            rect: None,
        })
    }

    /// Whether a `rect` of sums fits in one storage binding of `device`.
    pub(super) fn fits(device: &wgpu::Device, rect: PixelRect) -> bool {
        let bytes = rect[2] as u64 * rect[3] as u64 * BYTES_PER_PIXEL;
        let l = device.limits();
        bytes <= l.max_storage_buffer_binding_size && bytes <= l.max_buffer_size
    }

    /// Uploads `balls` and records, on `encoder`, the clearing of the sums over `rect` and the
    /// splat of every ball into them. `rect` must be inside the target, not empty, and
    /// [`Self::fits`]; `globals` is the renderer's uniform.
    pub(super) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        globals: &wgpu::Buffer,
        balls: &[BallSprite],
        rect: PixelRect,
    ) {
        let count = balls.len() as u32;
        let groups = count.div_ceil(WORKGROUP);
        // A large count is dispatched as rows of at most the device's limit of workgroups.
        let max_groups = device.limits().max_compute_workgroups_per_dimension;
        let (groups_x, groups_y) = (groups.min(max_groups), groups.div_ceil(max_groups));
        let params = SplatParams {
            rect_min: [rect[0], rect[1]],
            rect_size: [rect[2], rect[3]],
            count,
            row: groups_x * WORKGROUP,
            _pad: [0; 2],
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let sums_bytes = rect[2] as u64 * rect[3] as u64 * BYTES_PER_PIXEL;
        let grew = self.balls.write(device, queue, bytemuck::cast_slice(balls)) | self.sums.reserve(device, sums_bytes);
        if grew || self.bind_groups.is_none() {
            fn whole(b: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
                b.as_entire_binding()
            }
            let splat = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("splat"),
                layout: &self.splat_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: whole(globals) },
                    wgpu::BindGroupEntry { binding: 1, resource: whole(&self.params) },
                    wgpu::BindGroupEntry { binding: 2, resource: whole(&self.balls.buffer) },
                    wgpu::BindGroupEntry { binding: 3, resource: whole(&self.sums.buffer) },
                ],
            });
            let resolve = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("splat resolve"),
                layout: &self.resolve_layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: whole(globals) },
                    wgpu::BindGroupEntry { binding: 1, resource: whole(&self.params) },
                    wgpu::BindGroupEntry { binding: 4, resource: whole(&self.sums.buffer) },
                ],
            });
            self.bind_groups = Some((splat, resolve));
        }
        let (splat_group, _) = self.bind_groups.as_ref().expect("made above");
        encoder.clear_buffer(&self.sums.buffer, 0, Some(sums_bytes));
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("splat"), timestamp_writes: None });
        pass.set_pipeline(&self.splat);
        pass.set_bind_group(0, splat_group, &[]);
        pass.dispatch_workgroups(groups_x, groups_y, 1);
        self.rect = Some(rect);
    }

    /// Blends the sums of the last [`Self::prepare`] over the target.
    pub(super) fn resolve(&mut self, pass: &mut wgpu::RenderPass<'_>) {
        if self.rect.take().is_none() {
            return;
        }
        let (_, resolve_group) = self.bind_groups.as_ref().expect("prepare made them");
        pass.set_pipeline(&self.resolve);
        pass.set_bind_group(0, resolve_group, &[]);
        pass.draw(0..6, 0..1);
    }
}
