//! # reparam-gpu — the f32 wgpu kernels of reparam
//!
//! Plain f32 arrays in (`#[repr(C)]` [`bytemuck::Pod`] structs), plain f32 arrays out. This
//! crate knows nothing of the f64 reference; the reference crate converts the same inputs for
//! both sides and compares (its `crosscheck` module).
//!
//! - [`Gpu`]: a headless context (hardware adapter if any, else a CPU one such as Mesa's
//!   lavapipe), with upload/readback helpers and a compute dispatch helper ([`compute`]).
//! - [`bpm`]: Blended Piecewise Möbius Maps: [`bpm::bpm_precompute`], [`bpm::bpm_eval`],
//!   [`bpm::bpm_render`], one WGSL file each in `shaders/`, plus `shaders/bpm_common.wgsl`.
//! - [`unwarp`]: distortion-free displacement mapping, one descent pass:
//!   [`unwarp::UnwarpPassKernel`], `shaders/unwarp_pass.wgsl`; applying the correction:
//!   [`unwarp::UnwarpLookupKernel`], `shaders/unwarp_lookup.wgsl`.
//! - [`maps`]: MAPS priority terms, batched z^a flattening of 1-rings and Π⁻¹:
//!   [`maps::PriorityKernel`], [`maps::FlattenKernel`], [`maps::InverseKernel`].
//! - [`skinsimp`]: skinned-mesh simplification: LBS, per-pose quadrics, batched collapse costs
//!   ([`skinsimp::LbsKernel`], [`skinsimp::QuadricKernel`], [`skinsimp::CollapseCostKernel`]).
//! - [`user_shader`]: a user's own WGSL, GLSL or SPIR-V compute shader, parsed, reflected and
//!   dispatched under a watchdog with guarded output buffers (`reparam verify --shader`).
//! - [`gpu_or_skip`]: what tests call to get a context or skip.
//!
//! WGSL has no includes: shared WGSL lives in its own file and the host concatenates sources.
//!
//! Layers, bottom up; each module imports only the ones below it: `error` ([`GpuError`]) →
//! `context` ([`Gpu`], adapters, limits, [`compute::READBACK_TIMEOUT`]) → [`compute`] (buffers,
//! dispatch, read-back, [`ComputeKernel`]) → one module per algorithm.

pub mod bpm;
pub mod compute;
mod context;
mod error;
pub mod gridwarp;
pub mod maps;
pub mod skinsimp;
pub mod unwarp;
pub mod user_shader;

use std::sync::OnceLock;

pub use bpm::{bpm_eval, bpm_precompute, bpm_render};
pub use compute::ComputeKernel;
pub use context::{
    adapter_rank, device_limits, list_adapters, AdapterDescription, Clock, Gpu, ADAPTER_ENV,
};
pub use error::GpuError;

/// Environment variable that turns "no adapter" into a test failure: `REPARAM_REQUIRE_GPU=1`.
pub const REQUIRE_GPU_ENV: &str = "REPARAM_REQUIRE_GPU";

/// The process-wide context for tests: [`Gpu::new`] is called once (adapter and device
/// creation dominate a small test's time) and every caller gets a clone of the same device.
static SHARED: OnceLock<Result<Gpu, GpuError>> = OnceLock::new();

/// A GPU context for a test, or `None` after printing `skipped: no GPU adapter`.
///
/// Panics with the error instead of skipping when `REPARAM_REQUIRE_GPU=1` (CI, where lavapipe
/// is installed and a skip would hide a broken setup). The context is created once per process
/// and shared (wgpu devices are thread-safe; error scopes are per thread).
pub fn gpu_or_skip() -> Option<Gpu> {
    match SHARED.get_or_init(Gpu::new) {
        Ok(gpu) => Some(gpu.clone()),
        Err(e) if std::env::var(REQUIRE_GPU_ENV).as_deref() == Ok("1") => {
            panic!("{REQUIRE_GPU_ENV}=1 but no GPU context: {e}")
        }
        Err(_) => {
            println!("skipped: no GPU adapter");
            None
        }
    }
}
