//! BPM vectors: the `bpm_eval` kernel (BPM and linear interpolation) from the per-triangle data
//! it receives, against the f64 reference evaluation (seed 004 steps 6–9).

use num_complex::Complex64 as C;

use super::{Array, KernelData, Metric};
use crate::bpm::gpu::{maps_to_gpu, samples_to_gpu};
use crate::bpm::{precompute, BpmOptions, Interp};
use crate::crosscheck::bpm::{
    crosscheck_samples, eval_kernel_tolerance, round_mesh_to_f32, TEXTURE_SIZE,
};
use crate::error::Result;
use crate::mesh::TriMesh;

/// The per-triangle data (`reparam_gpu::bpm::TriangleMaps`, f32) of every face as one row of 44
/// values: z_j, z_k (4), uv_i, uv_j (4), uv_k, w_origin (4), M_t (8: a, b, c, d as re, im), the
/// three edge logs (24: per edge [a.re, a.im, b.re, b.im, c.re, c.im, 0, 0]); and the flags.
pub fn maps_arrays(maps: &[reparam_gpu::bpm::GpuTriangleMaps]) -> (Array, Array) {
    let mut rows = Vec::with_capacity(maps.len() * 44);
    for m in maps {
        rows.extend(m.z);
        rows.extend(m.uv_ij);
        rows.extend(m.uv_k_origin);
        rows.extend(m.m.iter().flatten());
        rows.extend(m.logs.iter().flatten());
    }
    (
        Array::f32(&[maps.len(), 44], rows),
        Array::u32(&[maps.len()], maps.iter().map(|m| m.flags).collect()),
    )
}

const MAPS_MEANING: &str = "per face (0-based, the mesh's face order), f32: z_j.re, z_j.im, \
    z_k.re, z_k.im (corners j, k in t's frame, z_i = 0); uv_i.x, uv_i.y, uv_j.x, uv_j.y; uv_k.x, \
    uv_k.y, w_origin.re, w_origin.im; M_t = [[a, b], [c, d]] as a.re, a.im, b.re, b.im, c.re, \
    c.im, d.re, d.im; for edges e = 0, 1, 2 (opposite corners i, j, k) the log ratio [[a, b], \
    [c, −a]] as a.re, a.im, b.re, b.im, c.re, c.im, 0, 0";
const FLAGS_MEANING: &str =
    "per face, u32: bit 0 = evaluate linearly (fallback), bit 1 = the star's layout is mirrored";
const FACE_MEANING: &str = "per sample, u32: the face (0-based)";
const BARY_MEANING: &str = "per sample, f32: b_j, b_k, the barycentrics of corners j and k \
    (corner order of the face: i, j, k); b_i = 1 − b_j − b_k";

/// The `bpm_eval` vectors of `mesh` (needs UVs): the mesh rounded to f32, the reference's
/// per-triangle data rounded to f32 as the kernel receives it, the cross-check's samples
/// (interior points and corners of every face), and the f64 UVs with the eval kernel's bound.
pub fn eval_vectors(mesh: &TriMesh) -> Result<Vec<KernelData>> {
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let samples = crosscheck_samples(mesh.face_count());
    let gpu_samples = samples_to_gpu(&samples);
    let (maps, flags) = maps_arrays(&maps_to_gpu(&reference));
    let uv_max = mesh.uvs.iter().map(|t| t.coords.norm()).fold(0.0, f64::max);
    let bound = eval_kernel_tolerance(uv_max);
    let uv_array = |uv: &[C]| {
        Array::f64(
            &[uv.len(), 2],
            uv.iter().flat_map(|c| [c.re, c.im]).collect(),
        )
    };
    let face = Array::u32(
        &[gpu_samples.len()],
        gpu_samples.iter().map(|s| s.face).collect(),
    );
    let bary = Array::f32(
        &[gpu_samples.len(), 2],
        gpu_samples.iter().flat_map(|s| s.b).collect(),
    );
    let kernel = |name: &str, interp: Interp, what: &str| {
        KernelData {
        name: name.into(),
        description: format!(
            "{what}: f(z) at face t and barycentrics b, z = b_j z_j + b_k z_k in t's frame \
             (seed 004 steps 6–9)"
        ),
        inputs: vec![
            ("maps".into(), MAPS_MEANING.into(), maps.clone()),
            ("flags".into(), FLAGS_MEANING.into(), flags.clone()),
            ("face".into(), FACE_MEANING.into(), face.clone()),
            ("bary".into(), BARY_MEANING.into(), bary.clone()),
        ],
        expected: (
            "per sample, f64: u, v (texture widths), the f64 reference at the f32 barycentrics".into(),
            uv_array(&reference.eval_many(&samples, interp)),
        ),
        bound: (
            "per sample, texels of a 4096² texture".into(),
            Array::f64(&[samples.len()], vec![bound; samples.len()]),
        ),
        metric: Metric::NormOfLastAxis {
            scale: TEXTURE_SIZE,
            unit: "texels of a 4096² texture".into(),
        },
        bound_formula: "122 u · max(max|uv|, 1) · 4096, u = 2⁻²⁴".into(),
        derivation: "the final sum rounds to ½ulp(|f|) ≤ u|f| and w_origin carries u|w_origin|; \
            the Möbius part is ≈ 60 dependent operations on f32 data, ≤ 60u|Δ| with |Δ| ≤ 2 max|uv| \
            (crosscheck::bpm::eval_kernel_tolerance)"
            .into(),
        per_element: vec!["face".into(), "bary".into()],
    }
    };
    Ok(vec![
        kernel("bpm_eval", Interp::Bpm, "BPM interpolation"),
        kernel(
            "bpm_eval_linear",
            Interp::Linear,
            "piecewise-linear interpolation",
        ),
    ])
}

/// The candidate of reparam's own `bpm_eval` kernel for each of [`eval_vectors`]' kernels, read
/// back from the arrays as written (f32 UVs, shape (samples, 2)).
#[cfg(feature = "gpu")]
pub fn gpu_candidates(gpu: &reparam_gpu::Gpu, mesh: &TriMesh) -> Result<Vec<(String, Array)>> {
    use crate::bpm::gpu::eval_gpu;
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let samples = samples_to_gpu(&crosscheck_samples(mesh.face_count()));
    let maps = maps_to_gpu(&reference);
    let mut out = Vec::new();
    for (name, interp) in [
        ("bpm_eval", Interp::Bpm),
        ("bpm_eval_linear", Interp::Linear),
    ] {
        let uv = eval_gpu(gpu, &maps, &samples, interp)?;
        out.push((
            name.to_string(),
            Array::f32(
                &[uv.len(), 2],
                uv.iter().flat_map(|c| [c.re as f32, c.im as f32]).collect(),
            ),
        ));
    }
    Ok(out)
}

/// The seed's determinant fit in f32 as a `bpm_eval` candidate: `bpm_precompute` with
/// [`crate::bpm::Fit::Determinant`], then `bpm_eval` (BPM), on the same mesh and samples — what
/// a straight port of the seed computes. It fails where the UVs are far from the origin
/// compared with their triangles' size (the speckling of issue #2).
#[cfg(feature = "gpu")]
pub fn determinant_fit_candidate(gpu: &reparam_gpu::Gpu, mesh: &TriMesh) -> Result<Array> {
    use crate::bpm::gpu::{eval_gpu, precompute_gpu};
    let mesh = round_mesh_to_f32(mesh);
    let samples = samples_to_gpu(&crosscheck_samples(mesh.face_count()));
    let maps = precompute_gpu(gpu, &mesh, crate::bpm::Fit::Determinant)?;
    let uv = eval_gpu(gpu, &maps, &samples, Interp::Bpm)?;
    Ok(Array::f32(
        &[uv.len(), 2],
        uv.iter().flat_map(|c| [c.re as f32, c.im as f32]).collect(),
    ))
}
