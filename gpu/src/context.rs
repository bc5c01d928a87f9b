//! The headless wgpu context: adapter choice, device creation, error scopes.

use crate::error::GpuError;

/// A headless wgpu device and its queue, with the adapter's description and the limits the
/// device was created with. Cheap to clone (wgpu handles are reference counted) and shareable
/// between threads.
#[derive(Clone, Debug)]
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
}

impl Gpu {
    /// Open a headless context: an instance over all backends, the best adapter by
    /// [`adapter_rank`] (hardware before software, native APIs before GL), and a device with
    /// the adapter's own buffer and dispatch limits (see [`device_limits`]).
    pub fn new() -> Result<Gpu, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::all(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let adapter = adapters
            .into_iter()
            .filter(|a| adapter_rank(&a.get_info()).is_some())
            .min_by_key(|a| adapter_rank(&a.get_info()))
            .ok_or(GpuError::NoAdapter)?;
        let info = adapter.get_info();
        let limits = device_limits(&adapter.limits());
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("reparam-gpu"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::RequestDevice(e.to_string()))?;
        Ok(Gpu {
            device,
            queue,
            info,
            limits,
        })
    }

    /// One line describing the adapter: name, backend, device type, driver and driver info,
    /// e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, llvmpipe Mesa 22.3.6 (LLVM 15.0.6))`.
    pub fn adapter_summary(&self) -> String {
        let i = &self.info;
        format!(
            "{} ({:?}, {:?}, {} {})",
            i.name, i.backend, i.device_type, i.driver, i.driver_info
        )
    }

    /// Whether the adapter is Mesa's lavapipe (llvmpipe behind Vulkan): CI's adapter, on which
    /// the f32 error snapshots are taken. llvmpipe behind OpenGL (what wgpu finds where the
    /// Vulkan driver is not installed) is not: its shaders are translated and rounded
    /// differently.
    pub fn is_lavapipe(&self) -> bool {
        self.info.backend == wgpu::Backend::Vulkan && self.info.name.contains("llvmpipe")
    }

    /// The adapter's description.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// The limits the device was created with.
    pub fn limits(&self) -> &wgpu::Limits {
        &self.limits
    }

    /// Run `work` inside a validation error scope (and an out-of-memory one): a wgpu error
    /// raised by anything `work` does on this device is returned as [`GpuError::Validation`]
    /// (or [`GpuError::TooLarge`] for out-of-memory) instead of reaching wgpu's default handler,
    /// which panics. Scopes are per thread, so concurrent callers do not see each other's errors.
    pub(crate) fn checked<R>(
        &self,
        work: impl FnOnce() -> Result<R, GpuError>,
    ) -> Result<R, GpuError> {
        let memory = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let result = work();
        let validation = pollster::block_on(validation.pop());
        let memory = pollster::block_on(memory.pop());
        if let Some(e) = validation {
            return Err(GpuError::Validation(e.to_string()));
        }
        if let Some(e) = memory {
            return Err(GpuError::TooLarge(e.to_string()));
        }
        result
    }
}

/// Preference order of adapters, smaller first: discrete, integrated and virtual GPUs (0–2),
/// then CPU implementations such as Mesa's lavapipe (3), then unknown types (4); within a type,
/// Vulkan/Metal/DX12 before GL (GL compute support is patchy). `None` for adapters we never
/// use (the no-op backend and WebGPU-in-browser, which cannot block on readback).
pub fn adapter_rank(info: &wgpu::AdapterInfo) -> Option<(u8, u8)> {
    let backend = match info.backend {
        wgpu::Backend::Vulkan | wgpu::Backend::Metal | wgpu::Backend::Dx12 => 0,
        wgpu::Backend::Gl => 1,
        _ => return None,
    };
    let device = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    Some((device, backend))
}

/// Limits to request: wgpu's defaults clamped to what the adapter supports
/// (`or_worse_values_from`), then the adapter's own values for the limits our kernels push
/// against: `max_storage_buffer_binding_size`, `max_buffer_size`,
/// `max_compute_workgroups_per_dimension`.
pub fn device_limits(adapter: &wgpu::Limits) -> wgpu::Limits {
    wgpu::Limits {
        max_storage_buffer_binding_size: adapter.max_storage_buffer_binding_size,
        max_buffer_size: adapter.max_buffer_size,
        max_compute_workgroups_per_dimension: adapter.max_compute_workgroups_per_dimension,
        ..wgpu::Limits::default().or_worse_values_from(adapter)
    }
}
