//! The headless wgpu context: adapter choice, device creation, error scopes.

use std::any::Any;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use crate::error::GpuError;

/// How long a wait for the GPU (a read-back, a timed submission) lasts before giving up with
/// [`GpuError::Timeout`] (generous: lavapipe runs shaders on the CPU). Defined here, in the
/// lowest layer, so that the context never imports `compute`: `compute` builds on `context`.
pub const READBACK_TIMEOUT: Duration = Duration::from_secs(120);

/// A headless wgpu device and its queue, with the adapter's description and the limits the
/// device was created with. Cheap to clone (wgpu handles are reference counted) and shareable
/// between threads.
#[derive(Clone, Debug)]
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    shared: Arc<Shared>,
}

/// What the clones of one context share: compiled pipelines (made once per context, see
/// [`Gpu::cached`]) and the compute clock ([`Gpu::start_clock`]).
#[derive(Default)]
struct Shared {
    cache: Mutex<HashMap<String, Arc<dyn Any + Send + Sync>>>,
    clock: Mutex<Option<Clock>>,
}

impl std::fmt::Debug for Shared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Shared").finish_non_exhaustive()
    }
}

/// GPU time measured by [`Gpu::start_clock`] … [`Gpu::stop_clock`]: each submitted dispatch
/// (or render pass) from its submission to its completion, without buffer uploads before it and
/// readbacks after it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Clock {
    /// Seconds between submission and completion, summed over the submissions.
    pub seconds: f64,
    /// Submissions timed.
    pub submissions: u64,
}

impl Gpu {
    /// Open a headless context on the adapter named by `REPARAM_ADAPTER` when that variable
    /// is set (an index into [`list_adapters`] or a case-insensitive substring of its
    /// [`AdapterDescription::summary`], as `--adapter` takes), else on the best adapter by
    /// [`adapter_rank`] (hardware before software, native APIs before GL), with a device of the
    /// adapter's own buffer and dispatch limits (see [`device_limits`]).
    pub fn new() -> Result<Gpu, GpuError> {
        Gpu::on(default_adapter()?, None)
    }

    /// [`Gpu::new`]'s adapter with a device created with `limits` instead of the adapter's own
    /// (each clamped to what the adapter supports, `or_worse_values_from`). Kernels see these
    /// limits through [`Gpu::limits`]: with lowered buffer, binding or workgroup limits they
    /// split their work into more dispatches or refuse it with [`GpuError::ExceedsLimit`],
    /// which is how the tests exercise inputs too large for a device without allocating them.
    pub fn with_limits(limits: &wgpu::Limits) -> Result<Gpu, GpuError> {
        Gpu::on(default_adapter()?, Some(limits))
    }

    /// Open a context on the adapter that `selector` names: an index into [`list_adapters`]
    /// (`"0"`, `"1"`, …) or a case-insensitive substring of the adapter's one-line summary
    /// (`"llvmpipe"`, `"gl"`, `"nvidia"`); the first match in rank order wins.
    /// [`GpuError::NoAdapter`] when there is none at all, [`GpuError::NoMatchingAdapter`]
    /// (listing what exists) when none matches.
    pub fn with_adapter(selector: &str) -> Result<Gpu, GpuError> {
        Gpu::on(selected_adapter(selector)?, None)
    }

    /// A context on every usable adapter, in [`list_adapters`] order (one that refuses a
    /// device is returned as its error, so the caller can report it beside the others).
    pub fn all_adapters() -> Vec<(AdapterDescription, Result<Gpu, GpuError>)> {
        usable_adapters()
            .into_iter()
            .enumerate()
            .map(|(index, a)| {
                (
                    AdapterDescription::of(index, &a.get_info()),
                    Gpu::on(a, None),
                )
            })
            .collect()
    }

    /// A device and queue on `adapter`, with [`device_limits`] or `requested` (clamped to the
    /// adapter's).
    fn on(adapter: wgpu::Adapter, requested: Option<&wgpu::Limits>) -> Result<Gpu, GpuError> {
        let info = adapter.get_info();
        let limits = match requested {
            Some(limits) => limits.clone().or_worse_values_from(&adapter.limits()),
            None => device_limits(&adapter.limits()),
        };
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
            shared: Arc::default(),
        })
    }

    /// The value cached under `key` in this context (and its clones), made by `make` the first
    /// time: shader modules and pipelines are compiled once per context, not once per call.
    pub fn cached<T: Clone + Send + Sync + 'static>(
        &self,
        key: &str,
        make: impl FnOnce() -> Result<T, GpuError>,
    ) -> Result<T, GpuError> {
        // A panic while holding the lock leaves a usable map (inserts are atomic).
        let lock = || {
            self.shared
                .cache
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
        };
        if let Some(v) = lock().get(key) {
            if let Some(v) = v.downcast_ref::<T>() {
                return Ok(v.clone());
            }
        }
        let value = make()?;
        lock().insert(key.to_string(), Arc::new(value.clone()));
        Ok(value)
    }

    /// How many values (pipelines) [`Gpu::cached`] holds: constant once every kernel has run
    /// once, whatever is run again.
    pub fn cached_count(&self) -> usize {
        self.shared
            .cache
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .len()
    }

    /// Start timing submissions (see [`Clock`]). While the clock runs every submission waits for
    /// its completion, so kernels run one after another.
    pub fn start_clock(&self) {
        *self
            .shared
            .clock
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = Some(Clock::default());
    }

    /// Stop timing and return what was measured since [`Gpu::start_clock`] (zero if it was not
    /// started).
    pub fn stop_clock(&self) -> Clock {
        self.shared
            .clock
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .take()
            .unwrap_or_default()
    }

    /// Submit `commands`; while the clock runs, wait for them and add the time to the clock.
    pub(crate) fn submit(&self, commands: wgpu::CommandBuffer) -> wgpu::SubmissionIndex {
        let timing = self
            .shared
            .clock
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .is_some();
        let start = Instant::now();
        let index = self.queue.submit([commands]);
        if timing {
            let _ = self.device.poll(wgpu::PollType::Wait {
                submission_index: Some(index.clone()),
                timeout: Some(READBACK_TIMEOUT),
            });
            let seconds = start.elapsed().as_secs_f64();
            if let Some(c) = self
                .shared
                .clock
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .as_mut()
            {
                c.seconds += seconds;
                c.submissions += 1;
            }
        }
        index
    }

    /// One line describing the adapter: name, backend, device type, driver and driver info,
    /// e.g. `llvmpipe (LLVM 15.0.6, 256 bits) (Vulkan, Cpu, llvmpipe Mesa 22.3.6 (LLVM 15.0.6))`.
    pub fn adapter_summary(&self) -> String {
        AdapterDescription::of(0, &self.info).summary()
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

/// Environment variable that picks the adapter of [`Gpu::new`] (and so of the tests):
/// `REPARAM_ADAPTER=1` or `REPARAM_ADAPTER=gl`, as `reparam crosscheck --adapter` takes.
pub const ADAPTER_ENV: &str = "REPARAM_ADAPTER";

/// The adapter of [`Gpu::new`]: the one `REPARAM_ADAPTER` selects when set, else the best.
fn default_adapter() -> Result<wgpu::Adapter, GpuError> {
    match std::env::var(ADAPTER_ENV) {
        Ok(selector) if !selector.trim().is_empty() => selected_adapter(&selector),
        _ => usable_adapters()
            .into_iter()
            .next()
            .ok_or(GpuError::NoAdapter),
    }
}

/// The adapter `selector` names (see [`Gpu::with_adapter`]).
fn selected_adapter(selector: &str) -> Result<wgpu::Adapter, GpuError> {
    let adapters = usable_adapters();
    if adapters.is_empty() {
        return Err(GpuError::NoAdapter);
    }
    let descriptions: Vec<AdapterDescription> = adapters
        .iter()
        .enumerate()
        .map(|(index, a)| AdapterDescription::of(index, &a.get_info()))
        .collect();
    let chosen = match selector.trim().parse::<usize>() {
        Ok(index) => index,
        Err(_) => {
            let needle = selector.trim().to_lowercase();
            descriptions
                .iter()
                .position(|d| d.summary().to_lowercase().contains(&needle))
                .unwrap_or(usize::MAX)
        }
    };
    adapters
        .into_iter()
        .nth(chosen)
        .ok_or_else(|| GpuError::NoMatchingAdapter {
            selector: selector.to_string(),
            available: descriptions
                .iter()
                .map(|d| format!("{}: {}", d.index, d.summary()))
                .collect::<Vec<_>>()
                .join("; "),
        })
}

/// Every adapter wgpu finds on all backends that [`adapter_rank`] accepts, best first.
fn usable_adapters() -> Vec<wgpu::Adapter> {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::all(),
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let mut adapters: Vec<wgpu::Adapter> =
        pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()))
            .into_iter()
            .filter(|a| adapter_rank(&a.get_info()).is_some())
            .collect();
    // Stable: adapters of equal rank keep wgpu's enumeration order.
    adapters.sort_by_key(|a| adapter_rank(&a.get_info()));
    adapters
}

/// What `--list-adapters` prints of one adapter.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AdapterDescription {
    /// Position in [`list_adapters`] (what `--adapter 1` selects).
    pub index: usize,
    pub name: String,
    /// `Vulkan`, `Metal`, `Dx12` or `Gl`.
    pub backend: String,
    /// `DiscreteGpu`, `IntegratedGpu`, `VirtualGpu`, `Cpu` or `Other`.
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
}

impl AdapterDescription {
    fn of(index: usize, i: &wgpu::AdapterInfo) -> AdapterDescription {
        AdapterDescription {
            index,
            name: i.name.clone(),
            backend: format!("{:?}", i.backend),
            device_type: format!("{:?}", i.device_type),
            driver: i.driver.clone(),
            driver_info: i.driver_info.clone(),
        }
    }

    /// `name (backend, device type, driver driver-info)`.
    pub fn summary(&self) -> String {
        format!(
            "{} ({}, {}, {} {})",
            self.name, self.backend, self.device_type, self.driver, self.driver_info
        )
    }
}

/// Every usable adapter, best first by [`adapter_rank`]; the index of each is what
/// [`Gpu::with_adapter`] takes.
pub fn list_adapters() -> Vec<AdapterDescription> {
    usable_adapters()
        .iter()
        .enumerate()
        .map(|(index, a)| AdapterDescription::of(index, &a.get_info()))
        .collect()
}
