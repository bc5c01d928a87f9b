//! Host side of the `bpm_eval` kernel (`shaders/bpm_eval.wgsl`): the interpolated UV at many
//! points. Twin of the reference's `Bpm::eval` / `bpm::eval::eval_bpm`.

use super::{shader_source, Interp, KernelParams, Sample, TriangleMaps, BPM_COMMON_WGSL};
use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and `bpm_common.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/bpm_eval.wgsl");

/// The UV at each sample (WGSL `eval`): with T = `maps[face]` and b = (1 − b_j − b_k, b_j, b_k),
///
/// - [`Interp::Bpm`]: z = b_j z_j + b_k z_k, γ = edge_weights(b), ℓ = Σ_e γ_e l_e,
///   f = w_origin + M_t(exp(½ ℓ)(z));
/// - [`Interp::Linear`], or a face flagged linear fallback: f = b_i uv_i + b_j uv_j + b_k uv_k.
///
/// Any number of samples and faces: samples are dispatched in chunks, and meshes whose maps
/// exceed one storage binding are processed in windows of faces (see [`run_chunked`]).
pub fn run(
    gpu: &Gpu,
    maps: &[TriangleMaps],
    samples: &[Sample],
    interp: Interp,
) -> Result<Vec<[f32; 2]>, GpuError> {
    let samples_per_chunk = gpu.max_chunk_len(std::mem::size_of::<Sample>());
    let faces_per_window = gpu.max_chunk_len(std::mem::size_of::<TriangleMaps>());
    run_chunked(
        gpu,
        maps,
        samples,
        interp,
        samples_per_chunk,
        faces_per_window,
    )
}

/// [`run`] with at most `samples_per_chunk` samples per dispatch and `faces_per_window` faces
/// bound at a time. With several windows, each window's samples are gathered (face ids made
/// relative to the window), evaluated, and scattered back to their places.
pub fn run_chunked(
    gpu: &Gpu,
    maps: &[TriangleMaps],
    samples: &[Sample],
    interp: Interp,
    samples_per_chunk: usize,
    faces_per_window: usize,
) -> Result<Vec<[f32; 2]>, GpuError> {
    if samples.is_empty() {
        return Ok(Vec::new());
    }
    check_faces(maps.len(), samples)?;
    let source = shader_source(&[DISPATCH_WGSL, BPM_COMMON_WGSL, WGSL]);
    let kernel = gpu.compute_kernel("bpm_eval", &source, "bpm_eval")?;
    let window = faces_per_window.max(1);
    if maps.len() <= window {
        return eval_window(gpu, &kernel, maps, samples, interp, samples_per_chunk);
    }
    let mut uv = vec![[0.0; 2]; samples.len()];
    for (w, window_maps) in maps.chunks(window).enumerate() {
        let faces = w * window..w * window + window_maps.len();
        let (places, local): (Vec<usize>, Vec<Sample>) = samples
            .iter()
            .enumerate()
            .filter(|(_, s)| faces.contains(&(s.face as usize)))
            .map(|(n, s)| {
                (
                    n,
                    Sample {
                        face: s.face - faces.start as u32,
                        ..*s
                    },
                )
            })
            .unzip();
        if local.is_empty() {
            continue;
        }
        let values = eval_window(gpu, &kernel, window_maps, &local, interp, samples_per_chunk)?;
        for (n, value) in places.into_iter().zip(values) {
            uv[n] = value;
        }
    }
    Ok(uv)
}

/// Evaluate `samples` whose face ids index `maps` (bound whole).
fn eval_window(
    gpu: &Gpu,
    kernel: &ComputeKernel,
    maps: &[TriangleMaps],
    samples: &[Sample],
    interp: Interp,
    samples_per_chunk: usize,
) -> Result<Vec<[f32; 2]>, GpuError> {
    let maps = gpu.upload_storage("bpm_eval maps", maps)?;
    gpu.run_per_item(
        kernel,
        |count| KernelParams::new(count, interp.code()),
        &[&maps],
        samples,
        samples_per_chunk,
    )
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
