//! One wgpu device for everything: the viewer hands [`device_descriptor`] to eframe so egui and the
//! splatting passes share its device; the CLI, tests and benchmarks open the same kind of device
//! headless with [`GpuContext::headless`].

use thiserror::Error;

#[derive(Debug, Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (tried {backends:?}). Install a Vulkan driver; on Debian without a GPU \
         `apt-get install mesa-vulkan-drivers libvulkan1` gives the software one (lavapipe)"
    )]
    NoAdapter { backends: wgpu::Backends },
    #[error("the adapter {adapter} refused a device: {source}")]
    RequestDevice {
        adapter: String,
        source: wgpu::RequestDeviceError,
    },
}

/// Keeps Mesa's Vulkan device-selection layer from asking Wayland for the default GPU when there
/// is no Wayland session to ask (no `XDG_RUNTIME_DIR`): libwayland then prints "XDG_RUNTIME_DIR is
/// invalid or not set" once per adapter enumeration. wgpu chooses the adapter itself, so the
/// layer has nothing to add there. Call it first thing in `main`, before any thread starts.
#[allow(unsafe_code)] // the one place: setting an environment variable (unsafe since Rust 2024)
pub fn quiet_without_wayland() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        // SAFETY: called from `main` before any other thread exists, so nothing reads the
        // environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// Limits the splatting passes need beyond the WebGPU defaults, capped at what the adapter has:
/// big storage buffers (1M Gaussians × 64 channels is 256 MiB) and 4096² outputs.
pub fn required_limits(adapter: &wgpu::Adapter) -> wgpu::Limits {
    let have = adapter.limits();
    let base = wgpu::Limits::default();
    wgpu::Limits {
        max_texture_dimension_2d: have.max_texture_dimension_2d.min(8192),
        max_storage_buffer_binding_size: have.max_storage_buffer_binding_size,
        max_buffer_size: have.max_buffer_size,
        max_storage_buffers_per_shader_stage: have.max_storage_buffers_per_shader_stage.min(16),
        max_compute_workgroups_per_dimension: base.max_compute_workgroups_per_dimension,
        ..base
    }
}

/// Optional: timestamp queries (the benchmark falls back to CPU timers without them) and subgroup
/// operations (the rasterizer's CPU tuning shares loads with them, `RasterTuning`).
pub fn optional_features(adapter: &wgpu::Adapter) -> wgpu::Features {
    adapter.features() & (wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::SUBGROUP)
}

pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    wgpu::DeviceDescriptor {
        label: Some("guava device"),
        required_features: optional_features(adapter),
        required_limits: required_limits(adapter),
        ..Default::default()
    }
}

/// A headless device and queue, plus what `guava info` reports about them. Clones share the
/// device.
#[derive(Clone)]
pub struct GpuContext {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
}

impl GpuContext {
    /// Opens the highest-performance adapter on the primary backends (Vulkan, Metal, DX12).
    pub fn headless() -> Result<Self, GpuError> {
        Self::headless_with(|_| {})
    }

    /// [`Self::headless`] with the device's limits changed by `adjust` (tests lower them to
    /// reach an adapter's edge cheaply, whatever the adapter).
    pub fn headless_with(adjust: impl FnOnce(&mut wgpu::Limits)) -> Result<Self, GpuError> {
        let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends,
            flags: wgpu::InstanceFlags::from_build_config().with_env(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|_| GpuError::NoAdapter { backends })?;
        let mut descriptor = device_descriptor(&adapter);
        adjust(&mut descriptor.required_limits);
        let (device, queue) =
            pollster::block_on(adapter.request_device(&descriptor)).map_err(|source| {
                GpuError::RequestDevice {
                    adapter: adapter.get_info().name,
                    source,
                }
            })?;
        Ok(Self {
            adapter,
            device,
            queue,
        })
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) · Vulkan · Cpu": how every measured figure names its adapter.
    pub fn adapter_label(&self) -> String {
        adapter_label(&self.adapter.get_info())
    }
}

pub fn adapter_label(info: &wgpu::AdapterInfo) -> String {
    format!(
        "{} · {:?} · {:?}",
        info.name, info.backend, info.device_type
    )
}
