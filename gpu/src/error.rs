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
    /// The input does not fit the device's limits (buffer sizes, texture size, dispatch size).
    #[error("input too large for the GPU: {0}")]
    TooLarge(String),
    /// Inconsistent input (lengths that do not match, face ids out of range).
    #[error("invalid input to a GPU kernel: {0}")]
    Input(String),
}
