//! BPM vectors: the `bpm_eval` kernel (BPM and linear interpolation) from the per-triangle data
//! it receives, against the f64 reference evaluation (seed 004 steps 6–9); and the
//! `bpm_precompute` kernel from the stars it receives, judged by what its per-triangle data
//! evaluates to (seed 004 steps 1–5).

use num_complex::Complex64 as C;

use std::path::Path;

use reparam_gpu::bpm::GpuTriangleMaps;

use super::{Array, KernelData, KernelVectors, Metric};
use crate::bpm::eval::{eval_bpm, eval_linear};
use crate::bpm::gpu::{maps_to_gpu, samples_to_gpu, star_to_gpu, stars};
use crate::bpm::precompute::TriangleMaps;
use crate::bpm::{precompute, BpmOptions, Interp, Mobius, Sl2};
use crate::crosscheck::bpm::{
    crosscheck_samples, eval_kernel_tolerance, round_mesh_to_f32, LOCAL_PIPELINE_MAX, TEXTURE_SIZE,
};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;

/// Values per row of a precompute candidate: the 44 values of [`maps_arrays`], then the flags.
pub const MAPS_ROW: usize = 45;

/// One face's per-triangle data (`reparam_gpu::bpm::TriangleMaps`, f32) as 44 values: z_j, z_k
/// (4), uv_i, uv_j (4), uv_k, w_origin (4), M_t (8: a, b, c, d as re, im), the three edge logs
/// (24: per edge [a.re, a.im, b.re, b.im, c.re, c.im, 0, 0]).
fn maps_values(m: &GpuTriangleMaps) -> impl Iterator<Item = f32> + '_ {
    m.z.iter()
        .chain(&m.uv_ij)
        .chain(&m.uv_k_origin)
        .chain(m.m.iter().flatten())
        .chain(m.logs.iter().flatten())
        .copied()
}

/// The per-triangle data of every face as one row of 44 values ([`maps_values`]), and the flags.
pub fn maps_arrays(maps: &[GpuTriangleMaps]) -> (Array, Array) {
    let rows = maps.iter().flat_map(maps_values).collect();
    (
        Array::f32(&[maps.len(), 44], rows),
        Array::u32(&[maps.len()], maps.iter().map(|m| m.flags).collect()),
    )
}

/// A precompute's output as a candidate: per face the 44 values and the flags (shape (faces,
/// [`MAPS_ROW`])).
pub fn maps_candidate(maps: &[GpuTriangleMaps]) -> Array {
    let rows = maps
        .iter()
        .flat_map(|m| maps_values(m).chain([m.flags as f32]))
        .collect();
    Array::f32(&[maps.len(), MAPS_ROW], rows)
}

/// The reference's [`TriangleMaps`] read back from a candidate's row ([`maps_candidate`]'s
/// layout), in f64.
pub fn triangle_maps_from_row(row: &[f64]) -> TriangleMaps {
    let c = |k: usize| C::new(row[k], row[k + 1]);
    let log = |e: usize| {
        let b = 20 + 8 * e;
        Sl2 {
            a: c(b),
            b: c(b + 2),
            c: c(b + 4),
        }
    };
    let flags = row[44] as u32;
    TriangleMaps {
        z: [C::new(0.0, 0.0), c(0), c(2)],
        uv: [c(4), c(6), c(8)],
        w_origin: c(10),
        m_t: Mobius {
            a: c(12),
            b: c(14),
            c: c(16),
            d: c(18),
        },
        logs: [log(0), log(1), log(2)],
        fallback_linear: flags & reparam_gpu::bpm::FLAG_LINEAR_FALLBACK != 0,
        mirrored: flags & reparam_gpu::bpm::FLAG_MIRRORED != 0,
    }
}

/// What a precompute candidate's array holds.
pub const CANDIDATE_MAPS_MEANING: &str = "per face (0-based, the mesh's face order), f32 or \
    f64: the 44 values of the bpm_eval kernel's `maps` input (see bpm_eval.maps in a bpm_eval \
    manifest, or maps_arrays), then the flags as a number (bit 0 linear fallback, bit 1 mirrored)";

/// The errors of [`Metric::BpmMapsAtSamples`]: each sample of the kernel's `face` and `bary`
/// inputs evaluated in f64 from the candidate's row of its face, against `expected`.
pub fn errors_at_samples(
    dir: &Path,
    k: &KernelVectors,
    expected: &[f64],
    candidate: &[f64],
) -> Result<Vec<f64>> {
    let Metric::BpmMapsAtSamples { scale, faces, .. } = k.metric else {
        return Ok(Vec::new());
    };
    let input = |name: &str| -> Result<Vec<f64>> {
        let info = k
            .inputs
            .iter()
            .find(|i| i.file.ends_with(&format!(".{name}.npy")))
            .ok_or_else(|| Error::Vectors {
                file: dir.join("manifest.json").display().to_string(),
                reason: format!("kernel {} has no '{name}' input", k.name),
            })?;
        Ok(Array::load(&dir.join(&info.file))?.to_f64())
    };
    let (face, bary) = (input("face")?, input("bary")?);
    let options = BpmOptions::default();
    face.iter()
        .enumerate()
        .map(|(s, &f)| {
            let f = f as usize;
            if f >= faces || 2 * s + 1 >= bary.len() || 2 * s + 1 >= expected.len() {
                return Err(Error::Vectors {
                    file: dir.display().to_string(),
                    reason: format!("sample [{s}]: face {f} or its barycentrics out of range"),
                });
            }
            let t = triangle_maps_from_row(&candidate[f * MAPS_ROW..(f + 1) * MAPS_ROW]);
            let (bj, bk) = (bary[2 * s], bary[2 * s + 1]);
            let b = [1.0 - bj - bk, bj, bk];
            let uv = if t.fallback_linear {
                eval_linear(&t, b)
            } else {
                eval_bpm(&t, b, options.exp_log, options.order)
            };
            let row = &candidate[f * MAPS_ROW..(f + 1) * MAPS_ROW];
            let e = &expected[2 * s..2 * s + 2];
            let error = scale * (uv - C::new(e[0], e[1])).norm();
            Ok(super::saturate(error, e, row))
        })
        .collect()
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

/// Every BPM kernel's vectors: [`eval_vectors`], [`precompute_vectors`] and the QC protocol
/// ([`qc_vectors`]).
pub fn vectors(mesh: &TriMesh) -> Result<Vec<KernelData>> {
    let mut kernels = eval_vectors(mesh)?;
    kernels.push(precompute_vectors(mesh)?);
    kernels.push(qc_vectors(mesh)?);
    Ok(kernels)
}

/// Subdivisions of the QC protocol in the vectors: 2³ = 8 segments per edge, 64 sub-triangles
/// per face.
pub const QC_SUBDIV: u32 = 3;

/// The QC protocol's figures of a BPM map: area-weighted mean, p50, p95, p99 and max of
/// σ_max/σ_min over the sub-triangles, and the count of folded ones.
fn qc_figures(bpm: &crate::bpm::Bpm) -> Vec<f64> {
    let q = crate::bpm::qc_protocol(bpm, Interp::Bpm, QC_SUBDIV);
    vec![q.mean, q.p50, q.p95, q.p99, q.max, q.folded as f64]
}

/// The whole-algorithm vectors of BPM: the mesh (rounded to f32) and the QC protocol's figures
/// ([`qc_figures`], seed 004's evaluation protocol) of its BPM map (local fit), each with the
/// relative bound that a precompute within [`LOCAL_PIPELINE_MAX`] keeps
/// ([`crate::bpm::quality::qc_sensitivity`]).
pub fn qc_vectors(mesh: &TriMesh) -> Result<KernelData> {
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let figures = qc_figures(&reference);
    let delta = LOCAL_PIPELINE_MAX / TEXTURE_SIZE;
    let (rho, near_fold) =
        crate::bpm::quality::qc_sensitivity(&reference, Interp::Bpm, QC_SUBDIV, delta);
    let folded = figures[5];
    let fold_bound = if folded > 0.0 {
        near_fold as f64 / folded
    } else {
        near_fold as f64
    };
    let (v, f) = (mesh.positions.len(), mesh.faces.len());
    Ok(KernelData {
        name: "bpm_qc".into(),
        description: format!(
            "the QC protocol on the BPM map (local fit): each face cut into {} sub-triangles \
             ({} segments per edge), σ_max/σ_min of the affine map of each sub-triangle's \
             layout to its image, area-weighted over the faces that are not degenerate",
            1 << (2 * QC_SUBDIV),
            1 << QC_SUBDIV
        ),
        inputs: vec![
            (
                "positions".into(),
                "per vertex (0-based), f64 (values of f32): x, y, z".into(),
                Array::f64(
                    &[v, 3],
                    mesh.positions
                        .iter()
                        .flat_map(|p| [p.x, p.y, p.z])
                        .collect(),
                ),
            ),
            (
                "faces".into(),
                "per face, u32: the corners i, j, k (0-based positions)".into(),
                Array::u32(&[f, 3], mesh.faces.iter().flatten().copied().collect()),
            ),
            (
                "uvs".into(),
                "per UV vertex, f64 (values of f32): u, v".into(),
                Array::f64(
                    &[mesh.uvs.len(), 2],
                    mesh.uvs.iter().flat_map(|p| [p.x, p.y]).collect(),
                ),
            ),
            (
                "uv_faces".into(),
                "per face, u32: the UV vertices of corners i, j, k".into(),
                Array::u32(&[f, 3], mesh.uv_faces.iter().flatten().copied().collect()),
            ),
        ],
        expected: (
            "f64: QC mean, p50, p95, p99, max (area-weighted), folded sub-triangles".into(),
            Array::f64(&[6], figures),
        ),
        bound: (
            "per figure, relative (the folded count: absolute where the reference has none)".into(),
            Array::f64(&[6], vec![rho, rho, rho, rho, rho, fold_bound]),
        ),
        metric: Metric::Relative {
            unit: "relative".into(),
        },
        bound_formula: format!(
            "QC figures: ρ = max 2ε_A/σ_min over the sub-triangles, ε_A = 4δ(|dz₁| + |dz₂|)/|det|, \
             δ = 0.1 texel of 4096² = {delta:.3e}; folded: the {near_fold} sub-triangles with \
             σ_min ≤ ε_A (bpm::quality::qc_sensitivity)"
        ),
        derivation: "a precompute within bpm_precompute's bound moves every image corner by \
            ≤ δ; α and β of each sub-triangle's affine map then move by ≤ ε_A together, its \
            σ's by ≤ ε_A, its QC by ≤ 2ε_A/σ_min relatively; every QC moving by ≤ ρ \
            relatively, so do the area-weighted mean and quantiles (areas are the layout's)"
            .into(),
        per_element: vec![],
    })
}

const STAR_P_MEANING: &str = "per face (0-based), 6 points × xyz, f32: corners i, j, k of the \
    face, then the apex of the neighbour across edge ij, jk, ki (0 where there is none)";
const STAR_W_MEANING: &str = "per face, the UVs of the same 6 points, f32";
const MASK_MEANING: &str = "per face, u32: bit e (0, 1, 2) = the neighbour across edge ij, jk, \
    ki exists and shares its UVs there (not a boundary or seam); bit 3 = the face is \
    degenerate (zero 3D or UV area: linear fallback)";

/// The `bpm_precompute` vectors of `mesh` (needs UVs): each face's star as the kernel receives
/// it (rounded to f32), the cross-check's samples, and the f64 UVs there. A candidate gives its
/// per-triangle data ([`maps_candidate`]'s layout); `verify` evaluates it in f64 at the samples
/// ([`Metric::BpmMapsAtSamples`]), so the precompute is judged by the map it defines.
pub fn precompute_vectors(mesh: &TriMesh) -> Result<KernelData> {
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let stars: Vec<_> = stars(&mesh)?.iter().map(star_to_gpu).collect();
    let samples = crosscheck_samples(mesh.face_count());
    let gpu_samples = samples_to_gpu(&samples);
    let faces = stars.len();
    let uv = reference.eval_many(&samples, Interp::Bpm);
    Ok(KernelData {
        name: "bpm_precompute".into(),
        description: "per face t: the layout z of t's star, the Möbius map M_t through t's three \
            corners (local fit: w − w_i) and the log ratios ℓ_e = log(M_t⁻¹ M_s) of each inner \
            edge (seed 004 steps 1–5); judged by f(z) at the samples (steps 6–9, in f64)"
            .into(),
        inputs: vec![
            (
                "star_p".into(),
                STAR_P_MEANING.into(),
                Array::f32(
                    &[faces, 6, 3],
                    stars
                        .iter()
                        .flat_map(|s| s.p.iter().flat_map(|p| [p[0], p[1], p[2]]))
                        .collect(),
                ),
            ),
            (
                "star_w".into(),
                STAR_W_MEANING.into(),
                Array::f32(
                    &[faces, 6, 2],
                    stars
                        .iter()
                        .flat_map(|s| s.w.iter().flatten().copied())
                        .collect(),
                ),
            ),
            (
                "mask".into(),
                MASK_MEANING.into(),
                Array::u32(&[faces], stars.iter().map(|s| s.mask).collect()),
            ),
            (
                "face".into(),
                FACE_MEANING.into(),
                Array::u32(
                    &[gpu_samples.len()],
                    gpu_samples.iter().map(|s| s.face).collect(),
                ),
            ),
            (
                "bary".into(),
                BARY_MEANING.into(),
                Array::f32(
                    &[gpu_samples.len(), 2],
                    gpu_samples.iter().flat_map(|s| s.b).collect(),
                ),
            ),
        ],
        expected: (
            "per sample, f64: u, v (texture widths), the f64 reference (local fit, BPM) at the \
             f32 barycentrics; the candidate is per face (see the metric)"
                .into(),
            Array::f64(
                &[uv.len(), 2],
                uv.iter().flat_map(|c| [c.re, c.im]).collect(),
            ),
        ),
        bound: (
            "per sample, texels of a 4096² texture".into(),
            Array::f64(&[uv.len()], vec![LOCAL_PIPELINE_MAX; uv.len()]),
        ),
        metric: Metric::BpmMapsAtSamples {
            scale: TEXTURE_SIZE,
            unit: "texels of a 4096² texture".into(),
            faces,
        },
        bound_formula: "0.1 texel of a 4096² texture (crosscheck::bpm::LOCAL_PIPELINE_MAX)".into(),
        derivation: "the whole local-fit f32 pipeline's target (issue #2): the fit subtracts w_i \
            before M_t is solved, so each f32 operation is relative to the triangle's own size, \
            not to |w|; reparam's kernel measures p99 ≤ 0.01 texel. The seed's determinant fit \
            in f32 misses it by up to several texels where |w| ≫ the triangle (the speckle)"
            .into(),
        per_element: vec!["face".into(), "bary".into()],
    })
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
    let own = crate::bpm::gpu::precompute_gpu(gpu, &mesh, crate::bpm::Fit::Local)?;
    out.push(("bpm_precompute".to_string(), maps_candidate(&own)));
    // The QC protocol on the map the GPU precompute defines (evaluated in f64).
    let candidate = maps_candidate(&own).to_f64();
    let gpu_bpm = crate::bpm::Bpm {
        maps: candidate
            .chunks(MAPS_ROW)
            .map(triangle_maps_from_row)
            .collect(),
        options: BpmOptions::default(),
        report: Default::default(),
    };
    out.push(("bpm_qc".to_string(), Array::f64(&[6], qc_figures(&gpu_bpm))));
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

/// The seed's determinant fit in f32 as a `bpm_precompute` candidate ([`maps_candidate`]'s
/// layout): the per-triangle data alone, judged by `verify` at the samples in f64.
#[cfg(feature = "gpu")]
pub fn determinant_fit_maps_candidate(gpu: &reparam_gpu::Gpu, mesh: &TriMesh) -> Result<Array> {
    let mesh = round_mesh_to_f32(mesh);
    let maps = crate::bpm::gpu::precompute_gpu(gpu, &mesh, crate::bpm::Fit::Determinant)?;
    Ok(maps_candidate(&maps))
}
