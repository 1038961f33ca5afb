//! Finding an adapter and a device. On machines without a GPU this is Mesa's CPU drivers:
//! llvmpipe through GL/EGL, or lavapipe through Vulkan (see ci-notes.md).

use super::RenderError;

/// The backends to try: every native one we build, unless `WGPU_BACKEND=gl|vulkan` says otherwise.
pub fn instance_descriptor() -> wgpu::InstanceDescriptor {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::GL;
    desc.with_env()
}

/// The nice value the drawing thread asks for: lower (a larger CPU share) than the collision
/// monitor's −5 and every ordinary nice-0 thread; the ball threads run at `SCHED_IDLE` (see
/// `runtime::ball_thread`'s `background_scheduling`).
const RENDER_NICE: libc::c_int = -10;

/// Asks Linux to run the calling thread, and the threads it creates from now on, at nice −10.
/// Call it before creating the GPU device: Mesa's CPU rasteriser (lavapipe, llvmpipe) draws on
/// worker threads made with the device, and they inherit the value.
///
/// Why: on a CPU adapter a frame is drawn by the CPU, which it shares with the simulation. The
/// threaded runtime's ball threads (all but the key ball's) run at `SCHED_IDLE` and take only the
/// CPU nobody else wants, and its collision monitor asks for nice −5. At −10 the drawing thread
/// and Mesa's workers, when they compete for a core, get about three times the monitor's share
/// and nine times a nice-0 thread's (the kernel's weights: 9548 against 3121 and 1024), so a
/// frame is not held up by the simulation (the frame times behind this are in
/// docs/measurements.md, *Figures behind the renderer's choices*). Lowering niceness needs
/// privilege (root or CAP_SYS_NICE, or RLIMIT_NICE): without it this changes nothing and says so
/// at debug level.
pub fn raise_render_priority() {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: setpriority on PRIO_PROCESS with who = 0 changes only the calling thread's nice
        // value (Linux threads have their own); it takes no pointers.
        let rc = unsafe { libc::setpriority(libc::PRIO_PROCESS, 0, RENDER_NICE) };
        if rc != 0 {
            log::debug!("the render thread could not raise its priority: {}", std::io::Error::last_os_error());
        }
    }
}

/// A device and its queue, with the adapter's description.
pub struct Gpu {
    /// The instance the adapter came from, kept so that the window can make its surface again,
    /// when it is lost, on the instance its device belongs to.
    pub instance: wgpu::Instance,
    /// The adapter the device was opened on: for its surface capabilities and description.
    pub adapter: wgpu::Adapter,
    /// The device every pipeline, buffer and texture of the renderer is made on.
    pub device: wgpu::Device,
    /// The device's queue: buffer writes and command submissions go through it.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A device for offscreen rendering: no window, no display needed.
    pub fn headless() -> Result<Gpu, RenderError> {
        raise_render_priority();
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
