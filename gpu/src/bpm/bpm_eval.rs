//! Host side of the `bpm_eval` kernel (`shaders/bpm_eval.wgsl`): the interpolated UV at many
//! points. Twin of the reference's `Bpm::eval` / `bpm::eval::eval_bpm`.

use super::{shader_source, Interp, KernelParams, Sample, TriangleMaps, BPM_COMMON_WGSL};
use crate::compute::DISPATCH_WGSL;
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and `bpm_common.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/bpm_eval.wgsl");

/// The UV at each sample (WGSL `eval`): with T = maps[face] and b = (1 − b_j − b_k, b_j, b_k),
///
/// - [`Interp::Bpm`]: z = b_j z_j + b_k z_k, γ = edge_weights(b), ℓ = Σ_e γ_e l_e,
///   f = w_origin + M_t(exp(½ ℓ)(z));
/// - [`Interp::Linear`], or a face flagged linear fallback: f = b_i uv_i + b_j uv_j + b_k uv_k.
///
/// Samples are processed in chunks that fit the device's buffer limits, so any number works.
pub fn run(gpu: &Gpu, maps: &[TriangleMaps], samples: &[Sample], interp: Interp) -> Result<Vec<[f32; 2]>, GpuError> {
    let chunk_len = gpu.max_chunk_len(std::mem::size_of::<Sample>());
    run_chunked(gpu, maps, samples, interp, chunk_len)
}

/// [`run`] with at most `chunk_len` samples per dispatch (smaller chunks bound memory use).
pub fn run_chunked(
    gpu: &Gpu,
    maps: &[TriangleMaps],
    samples: &[Sample],
    interp: Interp,
    chunk_len: usize,
) -> Result<Vec<[f32; 2]>, GpuError> {
    if samples.is_empty() {
        return Ok(Vec::new());
    }
    check_faces(maps.len(), samples)?;
    let maps = gpu.upload_storage("bpm_eval maps", maps)?;
    let source = shader_source(&[DISPATCH_WGSL, BPM_COMMON_WGSL, WGSL]);
    let kernel = gpu.compute_kernel("bpm_eval", &source, "bpm_eval")?;
    gpu.run_per_item(&kernel, |count| KernelParams::new(count, interp.code()), &[&maps], samples, chunk_len)
}

/// [`GpuError::Input`] naming the first sample whose face id is not below `faces`.
fn check_faces(faces: usize, samples: &[Sample]) -> Result<(), GpuError> {
    match samples.iter().position(|s| s.face as usize >= faces) {
        Some(n) => Err(GpuError::Input(format!(
            "sample {n} is on face {} but there are {faces} faces",
            samples[n].face
        ))),
        None => Ok(()),
    }
}
