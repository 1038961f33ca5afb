//! Finding an adapter and a device. On machines without a GPU this is Mesa's CPU drivers:
//! llvmpipe through GL/EGL, or lavapipe through Vulkan (see ci-notes.md).

use super::RenderError;

/// The backends to try: every native one we build, unless `WGPU_BACKEND=gl|vulkan` says otherwise.
pub fn instance_descriptor() -> wgpu::InstanceDescriptor {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::GL;
    desc.with_env()
}

/// A device and its queue, with the adapter's description.
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A device for offscreen rendering: no window, no display needed.
    pub fn headless() -> Result<Gpu, RenderError> {
        let instance = wgpu::Instance::new(instance_descriptor());
        Self::with_instance(instance, None)
    }

    /// A device on `instance` that can present to `surface`, if given.
    pub fn with_instance(instance: wgpu::Instance, surface: Option<&wgpu::Surface<'_>>) -> Result<Gpu, RenderError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            apply_limit_buckets: false,
        }))
        .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("ballfield"),
            // What the adapter can do, so GL's lower limits are no problem.
            required_limits: wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(e.to_string()))?;
        log::info!("GPU adapter: {}", describe(&adapter));
        Ok(Gpu { instance, adapter, device, queue })
    }

    /// `name (backend, device type)`, e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Gl, Cpu)`.
    pub fn describe(&self) -> String {
        describe(&self.adapter)
    }
}

fn describe(adapter: &wgpu::Adapter) -> String {
    let info = adapter.get_info();
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}
