//! Host side of the `bpm_precompute` kernel (`shaders/bpm_precompute.wgsl`): per-triangle BPM
//! data from each triangle's star. Twin of the reference's `bpm::precompute::triangle_maps`.

use super::{shader_source, Fit, KernelParams, StarInput, TriangleMaps, BPM_COMMON_WGSL};
use crate::compute::DISPATCH_WGSL;
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and `bpm_common.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/bpm_precompute.wgsl");

/// Per triangle t = (i, j, k), from its star (WGSL `triangle_maps`):
///
/// - layout z (`star_layout`, `place_apex`): z_i = 0, z_j = |p_j − p_i|, z_k from the 3D
///   triangle, each apex unfolded across its edge; mirrored (z ↦ z̄, flag bit 1) when t's UV
///   triangle is clockwise;
/// - W = w − w_origin (w_origin = w_i for [`Fit::Local`], 0 for [`Fit::Determinant`]),
///   M_t = fit(z_i, z_j, z_k → W_i, W_j, W_k);
/// - per edge e = (a, b) with a neighbour: l_e = log(±M_t⁻¹ M_e), M_e = fit(z_a, z_b, z_apex →
///   W_a, W_b, W_apex); l_e = 0 otherwise;
/// - degenerate t (mask bit 3) or non-finite M_t: M_t = I, logs 0, w_origin 0, flag bit 0.
pub fn run(gpu: &Gpu, stars: &[StarInput], fit: Fit) -> Result<Vec<TriangleMaps>, GpuError> {
    let chunk_len = gpu.max_chunk_len(std::mem::size_of::<TriangleMaps>());
    run_chunked(gpu, stars, fit, chunk_len)
}

/// [`run`] with at most `chunk_len` triangles per dispatch (smaller chunks bound memory use).
pub fn run_chunked(
    gpu: &Gpu,
    stars: &[StarInput],
    fit: Fit,
    chunk_len: usize,
) -> Result<Vec<TriangleMaps>, GpuError> {
    if stars.is_empty() {
        return Ok(Vec::new());
    }
    let source = shader_source(&[DISPATCH_WGSL, BPM_COMMON_WGSL, WGSL]);
    let kernel = gpu.compute_kernel("bpm_precompute", &source, "bpm_precompute")?;
    gpu.run_per_item(
        &kernel,
        |count| KernelParams::new(count, fit.code()),
        &[],
        stars,
        chunk_len,
    )
}
