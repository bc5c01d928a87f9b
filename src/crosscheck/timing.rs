//! Timing each side of a cross-check: the CPU reference's wall-clock time, the GPU call's and
//! its dispatches'. Imports only the row's [`Timing`], so that every per-algorithm file can
//! use it without importing the harness that runs them.

use std::time::Instant;

use reparam_gpu::Gpu;

use super::row::Timing;
use crate::error::Result;

/// `f` on the CPU and its wall-clock time in milliseconds.
pub fn time_cpu<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let start = Instant::now();
    let value = f();
    (value, start.elapsed().as_secs_f64() * 1e3)
}

/// `f` (GPU work on `gpu`) with its times: the whole call (uploads, dispatches, readbacks) and
/// the dispatches alone, submission to completion ([`reparam_gpu::Clock`]).
pub fn time_gpu<T>(gpu: &Gpu, f: impl FnOnce() -> Result<T>) -> Result<(T, Timing)> {
    gpu.start_clock();
    let start = Instant::now();
    let value = f();
    let total = start.elapsed().as_secs_f64() * 1e3;
    let clock = gpu.stop_clock();
    Ok((
        value?,
        Timing {
            gpu_kernel_ms: Some(clock.seconds * 1e3),
            gpu_total_ms: Some(total),
            cpu_ms: None,
        },
    ))
}

/// [`time_gpu`] after one untimed call of `f`: the times of a warm kernel (pipelines compiled,
/// the driver's first-use work done), as a caller that runs it repeatedly sees them.
pub fn time_gpu_warm<T>(gpu: &Gpu, mut f: impl FnMut() -> Result<T>) -> Result<(T, Timing)> {
    f()?;
    time_gpu(gpu, f)
}
