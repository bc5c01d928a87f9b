//! The one error type of `reparam-gpu`.

use thiserror::Error;

/// Everything that can go wrong between asking for an adapter and reading results back.
///
/// Shader compilation and pipeline validation errors are captured with wgpu error scopes and
/// returned as [`GpuError::Validation`] instead of panicking in wgpu's default error handler.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum GpuError {
    /// No wgpu adapter at all (no GPU driver and no software rasteriser).
    #[error(
        "no GPU adapter found; for a CPU implementation of Vulkan install Mesa's software \
         Vulkan driver: apt-get install -y mesa-vulkan-drivers libvulkan1"
    )]
    NoAdapter,
    /// `--adapter` / `REPARAM_ADAPTER` named no adapter that exists.
    #[error(
        "no GPU adapter matches '{selector}'; give an index or a part of a name among: {available}"
    )]
    NoMatchingAdapter { selector: String, available: String },
    /// The adapter refused to create a device.
    #[error("the GPU adapter refused to create a device: {0}")]
    RequestDevice(String),
    /// The GPU did not finish the submitted work within the readback timeout.
    #[error("the GPU did not finish within the readback timeout")]
    Timeout,
    /// Mapping a readback buffer failed.
    #[error("mapping a GPU buffer for readback failed: {0}")]
    Map(String),
    /// A wgpu validation error: invalid WGSL, pipeline/bind group mismatch, misuse of the API.
    #[error("GPU validation error: {0}")]
    Validation(String),
    /// The device ran out of memory, or a count does not fit the kernel's 32-bit indices.
    #[error("input too large for the GPU: {0}")]
    TooLarge(String),
    /// One dispatch, buffer or binding of `kernel` would need `needed` (bytes, workgroups or
    /// texels) where the device's `limit` allows `allowed`, and the kernel cannot split it
    /// further. Raised before wgpu sees the call, so it never reaches wgpu's validation panic.
    #[error(
        "input too large for the GPU: {kernel} needs {needed} where the device's {limit} is \
         {allowed}"
    )]
    ExceedsLimit {
        /// The kernel (or buffer) label, e.g. `skinsimp_lbs rest`.
        kernel: String,
        /// The wgpu limit, e.g. `max_storage_buffer_binding_size`.
        limit: &'static str,
        needed: u64,
        allowed: u64,
    },
    /// Inconsistent input (lengths that do not match, face ids out of range).
    #[error("invalid input to a GPU kernel: {0}")]
    Input(String),
}
