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
    crosscheck_samples, eval_bounds, pipeline_bounds, round_mesh_to_f32, EVAL_BOUND_FORMULA,
    PIPELINE_BOUND_FORMULA, TEXTURE_SIZE,
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

/// The per-triangle data of every face as one row of 44 values (`maps_values`), and the flags.
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
    let input = |name: &str| -> Result<Vec<f64>> { Ok(k.load_input(dir, name)?.to_f64()) };
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

const MAPS_MEANING: &str = "per face f (0-based, the mesh's face order), 44 f32 values; \
    with k = 0-based column: [0..4) z_j.re, z_j.im, z_k.re, z_k.im: corners j and k laid out in \
    the face's own frame, z_i = 0 and z_j on the positive real axis (|z_j| = |p_j − p_i|), \
    already mirrored (imaginary parts negated) when flags bit 1 is set; [4..8) uv_i.x, uv_i.y, \
    uv_j.x, uv_j.y; [8..10) uv_k.x, uv_k.y; [10..12) w_origin.re, w_origin.im = uv_i (the fit's \
    UV origin: M_t(z_i) = M_t(0) = 0, so f(z_i) = w_origin); [12..20) M_t = [[a, b], [c, d]] as \
    a.re, a.im, b.re, b.im, c.re, c.im, d.re, d.im (det 1; maps z to w − w_origin); \
    [20 + 8e .. 28 + 8e) for e = 0, 1, 2 the log ratio ℓ_e = [[a, b], [c, −a]] of the edge \
    e = 0: ij (corners i→j), 1: jk, 2: ki, as a.re, a.im, b.re, b.im, c.re, c.im, 0, 0 (all 0 \
    on a boundary or UV-seam edge)";
const FLAGS_MEANING: &str = "per face, u32: bit 0 = evaluate linearly (degenerate face: the \
    fallback), bit 1 = the face's UV triangle is clockwise and its layout z was mirrored \
    (informative: the stored z are already mirrored, the evaluation uses them as they are)";
const FACE_MEANING: &str = "per sample, u32: the face (0-based)";
const BARY_MEANING: &str = "per sample, f32: b_j, b_k, the barycentrics of corners j and k \
    (corner order of the face: i, j, k); b_i = 1 − b_j − b_k";
/// How `bpm_eval` evaluates a sample, for the manifest: every symbol of [`MAPS_MEANING`] used.
const EVAL_FORMULA: &str = "f at sample s (face t, b = (b_i, b_j, b_k)): if interp is linear \
    or flags[t] bit 0: f = b_i uv_i + b_j uv_j + b_k uv_k. Else: z = b_j z_j + b_k z_k; edge \
    lengths l_ij = |z_j|, l_jk = |z_k − z_j|, l_ki = |z_k|; g = (l_ij b_i b_j, l_jk b_j b_k, \
    l_ki b_k b_i), γ = g / (g_0 + g_1 + g_2) (γ = 0 when the sum is 0: at a corner); \
    ℓ = γ_0 ℓ_0 + γ_1 ℓ_1 + γ_2 ℓ_2 (slot e = edge ij, jk, ki as stored); Y = ½ ℓ = \
    [[a, b], [c, −a]], p = a² + b c, E = exp Y = [[C + S a, S b], [S c, C − S a]] with \
    C = cosh √p, S = sinh √p / √p (entire in p: Σ pⁿ/(2n)!, Σ pⁿ/(2n+1)!); with \
    M(z) = (a z + b)/(c z + d): f = w_origin + M_t(E(z)) (M_t applied after E: the right \
    order of seed 004)";

/// What the canonical BPM vectors exercise: per branch of the evaluation, the faces and samples
/// that show it (for the manifest's `covers`).
fn eval_covers(reference: &crate::bpm::Bpm, samples: &[crate::bpm::Sample]) -> Vec<String> {
    let maps = &reference.maps;
    let count = |f: &dyn Fn(&TriangleMaps) -> bool| maps.iter().filter(|t| f(t)).count();
    let samples_on = |f: &dyn Fn(&TriangleMaps) -> bool| {
        samples.iter().filter(|s| f(&maps[s.face as usize])).count()
    };
    let blended = |t: &TriangleMaps| !t.fallback_linear && t.logs.iter().any(|l| l.max_abs() > 0.0);
    let largest_log = maps
        .iter()
        .flat_map(|t| t.logs.iter().map(|l| l.max_abs()))
        .fold(0.0, f64::max);
    let boundary = maps
        .iter()
        .map(|t| t.logs.iter().filter(|l| l.max_abs() == 0.0).count())
        .sum::<usize>();
    let corners = samples
        .iter()
        .filter(|s| s.bary.iter().filter(|&&b| b == 0.0).count() == 2)
        .count();
    vec![
        format!(
            "blending (log ratios not 0): {} faces, {} samples, largest |ℓ| entry {:.3}",
            count(&blended),
            samples_on(&blended),
            largest_log
        ),
        format!(
            "mirrored layout (flags bit 1): {} faces, {} samples",
            count(&|t| t.mirrored),
            samples_on(&|t| t.mirrored)
        ),
        format!(
            "linear fallback (flags bit 0): {} faces, {} samples",
            count(&|t| t.fallback_linear),
            samples_on(&|t| t.fallback_linear)
        ),
        format!("boundary or seam edges (ℓ_e = 0): {boundary} edge slots"),
        format!(
            "corners (weights 0/0 → 0): {corners} samples; interior points: {} samples",
            samples.len() - corners
        ),
    ]
}

/// What the canonical precompute vectors exercise, from the stars' masks and UVs (for the
/// manifest's `covers`).
fn precompute_covers(stars: &[crate::bpm::precompute::Star]) -> Vec<String> {
    let degenerate = stars.iter().filter(|s| s.degenerate).count();
    let mirrored = stars
        .iter()
        .filter(|s| {
            !s.degenerate && crate::bpm::precompute::signed_area2(s.w[0], s.w[1], s.w[2]) < 0.0
        })
        .count();
    let inner = stars
        .iter()
        .map(|s| s.neighbour.iter().filter(|&&n| n).count())
        .sum::<usize>();
    vec![
        format!("mirrored layout (clockwise UV triangle): {mirrored} faces"),
        format!("degenerate faces (mask bit 3, linear fallback): {degenerate}"),
        format!(
            "inner edges (mask bits 0–2, a log ratio fitted): {inner}; boundary or seam edges: {}",
            3 * stars.len() - inner
        ),
    ]
}

/// The `bpm_eval` vectors of `mesh` (needs UVs): the mesh rounded to f32, the reference's
/// per-triangle data rounded to f32 as the kernel receives it, the cross-check's samples
/// (interior points and corners of every face), and the f64 UVs with the eval kernel's
/// per-sample bounds ([`crate::crosscheck::bpm_bound::eval_bounds`]).
pub fn eval_vectors(mesh: &TriMesh) -> Result<Vec<KernelData>> {
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let samples = crosscheck_samples(mesh.face_count());
    let gpu_samples = samples_to_gpu(&samples);
    let (maps, flags) = maps_arrays(&maps_to_gpu(&reference));
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
    let covers = eval_covers(&reference, &samples);
    let kernel = |name: &str, interp: Interp, what: &str| {
        let expected = reference.eval_many(&samples, interp);
        let bounds = eval_bounds(&reference, &samples, interp, &expected);
        KernelData {
            name: name.into(),
            description: format!("{what} (seed 004 steps 6–9). {EVAL_FORMULA}"),
            inputs: vec![
                ("maps".into(), MAPS_MEANING.into(), maps.clone()),
                ("flags".into(), FLAGS_MEANING.into(), flags.clone()),
                ("face".into(), FACE_MEANING.into(), face.clone()),
                ("bary".into(), BARY_MEANING.into(), bary.clone()),
            ],
            expected: (
                "per sample, f64: u, v (texture widths), the f64 reference at the f32 barycentrics"
                    .into(),
                uv_array(&expected),
            ),
            bound: (
                "per sample, texels of a 4096² texture".into(),
                Array::f64(&[bounds.len()], bounds),
            ),
            metric: Metric::NormOfLastAxis {
                scale: TEXTURE_SIZE,
                unit: "texels of a 4096² texture".into(),
            },
            bound_formula: EVAL_BOUND_FORMULA.into(),
            derivation: "the kernel's f32 twin (src/twin/bpm_common.rs) evaluated over balls: \
                each f32 input is a ball around the reference's f64 value with its rounding as \
                radius; each + − × adds one ULP (WGSL rounds up or down), / 2.5 ULP, sqrt 4.5 \
                ULP, every multi-term sum (n − 1) ULP in any order (reassociation and fusion \
                allowed); the output's radii, plus the f32 formulation's departure from the \
                reference formula (6 series terms for 10), × 4096 (crosscheck::bpm_bound)"
                .into(),
            per_element: vec!["face".into(), "bary".into()],
            covers: covers.clone(),
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
/// (`qc_figures`, seed 004's evaluation protocol) of its BPM map (local fit), each with the
/// relative bound that a precompute within its derived bound keeps (δ = the largest of
/// [`pipeline_bounds`] over the samples; [`crate::bpm::quality::qc_sensitivity`]).
pub fn qc_vectors(mesh: &TriMesh) -> Result<KernelData> {
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let figures = qc_figures(&reference);
    let samples = crosscheck_samples(mesh.face_count());
    let expected = reference.eval_many(&samples, Interp::Bpm);
    let delta = pipeline_bounds(&stars(&mesh)?, &samples, &expected)
        .into_iter()
        .fold(0.0, f64::max)
        / TEXTURE_SIZE;
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
             δ = the largest bpm_precompute bound at the samples = {delta:.3e}; folded: the {near_fold} sub-triangles with \
             σ_min ≤ ε_A (bpm::quality::qc_sensitivity)"
        ),
        derivation: "a precompute within bpm_precompute's bound moves every image corner by \
            ≤ δ; α and β of each sub-triangle's affine map then move by ≤ ε_A together, its \
            σ's by ≤ ε_A, its QC by ≤ 2ε_A/σ_min relatively; every QC moving by ≤ ρ \
            relatively, so do the area-weighted mean and quantiles (areas are the layout's)"
            .into(),
        per_element: vec![],
        covers: Vec::new(),
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
    let reference_stars = stars(&mesh)?;
    let stars: Vec<_> = reference_stars.iter().map(star_to_gpu).collect();
    let samples = crosscheck_samples(mesh.face_count());
    let gpu_samples = samples_to_gpu(&samples);
    let faces = stars.len();
    let uv = reference.eval_many(&samples, Interp::Bpm);
    let bounds = pipeline_bounds(&reference_stars, &samples, &uv);
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
            Array::f64(&[bounds.len()], bounds),
        ),
        metric: Metric::BpmMapsAtSamples {
            scale: TEXTURE_SIZE,
            unit: "texels of a 4096² texture".into(),
            faces,
        },
        bound_formula: PIPELINE_BOUND_FORMULA.into(),
        derivation: "the precompute's f32 twin (src/twin/bpm_precompute.rs) and then the eval's \
            on one tape (src/twin/lin.rs) from the star rounded to f32: each operation may err \
            by its WGSL table allowance a_i (+ − × 1 ULP, / 2.5, sqrt 4.5, a sum of n terms \
            (n − 1) ULP in any order or fusion); the bound is 2 Σ_i |∂uv/∂e_i| a_i · 4096 plus \
            the f32 formulation's departure from the reference, the derivatives exact in f64 by \
            one reverse sweep (first order: a common scale of the Möbius coefficients costs \
            nothing, as it changes no map); unbounded where a divisor, a log argument or a \
            branch is within 16× its own bound of 0 (crosscheck::bpm_bound). The local fit \
            subtracts w_i before M_t is solved, so each f32 operation is relative to the \
            triangle's own size, not to |w|. The seed's determinant fit in f32 misses this by \
            up to several texels where |w| ≫ the triangle (the speckle)"
            .into(),
        per_element: vec!["face".into(), "bary".into()],
        covers: precompute_covers(&reference_stars),
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

/// The BPM kernels' inputs and outputs as the f32 twins ([`crate::twin`]) read and write them,
/// from and to the vectors' arrays: what the model checks and the mutants run on.
pub mod twin_io {
    use super::{Array, Error, Result, MAPS_ROW};
    use crate::twin::bpm_common::{Complex, TriangleMaps};
    use crate::twin::bpm_eval::Sample;
    use crate::twin::bpm_precompute::StarInput;
    use crate::twin::{Real, F, V2, V3};

    fn shape_error(name: &str, a: &Array, wanted: &str) -> Error {
        Error::Vectors {
            file: name.into(),
            reason: format!("shape {:?}, expected {wanted}", a.shape),
        }
    }

    /// The `maps` (faces, 44) and `flags` (faces) inputs as the twin's per-triangle data.
    pub fn maps(maps: &Array, flags: &Array) -> Result<Vec<TriangleMaps<F>>> {
        let values = maps.to_f64();
        let flags = flags.to_f64();
        if maps.shape.len() != 2 || maps.shape[1] != 44 || flags.len() != maps.shape[0] {
            return Err(shape_error("maps", maps, "(faces, 44) and flags (faces)"));
        }
        Ok(values
            .chunks(44)
            .zip(&flags)
            .map(|(row, &f)| {
                let v: [F; 44] = std::array::from_fn(|k| F::new(row[k] as f32));
                TriangleMaps::from_values(&v, f as u32)
            })
            .collect())
    }

    /// The `face` (samples) and `bary` (samples, 2) inputs as the twin's samples.
    pub fn samples(face: &Array, bary: &Array) -> Result<Vec<Sample<F>>> {
        let (face, b) = (face.to_f64(), bary.to_f64());
        if b.len() != 2 * face.len() {
            return Err(shape_error("bary", bary, "(samples, 2)"));
        }
        Ok(face
            .iter()
            .zip(b.chunks(2))
            .map(|(&f, b)| Sample {
                face: f as u32,
                b: [F::new(b[0] as f32), F::new(b[1] as f32)],
            })
            .collect())
    }

    /// The `star_p` (faces, 6, 3), `star_w` (faces, 6, 2) and `mask` (faces) inputs as the
    /// twin's stars.
    pub fn stars(p: &Array, w: &Array, mask: &Array) -> Result<Vec<StarInput<F>>> {
        let (pv, wv, mv) = (p.to_f64(), w.to_f64(), mask.to_f64());
        if pv.len() != 18 * mv.len() || wv.len() != 12 * mv.len() {
            return Err(shape_error(
                "star_p",
                p,
                "(faces, 6, 3), star_w (faces, 6, 2)",
            ));
        }
        let f = |x: f64| F::new(x as f32);
        Ok((0..mv.len())
            .map(|n| StarInput {
                p: std::array::from_fn(|k| {
                    let q = &pv[18 * n + 3 * k..];
                    V3::new(f(q[0]), f(q[1]), f(q[2]))
                }),
                w: std::array::from_fn(|k| {
                    V2::new(f(wv[12 * n + 2 * k]), f(wv[12 * n + 2 * k + 1]))
                }),
                mask: mv[n] as u32,
            })
            .collect())
    }

    /// UVs as a candidate (samples, 2), f32; a sample the twin could not evaluate (a face out
    /// of range) is NaN.
    pub fn uv_candidate<R: Real>(uv: &[Option<Complex<R>>]) -> Array {
        Array::f32(
            &[uv.len(), 2],
            uv.iter()
                .flat_map(|u| match u {
                    Some(u) => [u.x.value() as f32, u.y.value() as f32],
                    None => [f32::NAN; 2],
                })
                .collect(),
        )
    }

    /// Per-triangle data as a `bpm_precompute` candidate (faces, 45): the 44 values, then the
    /// flags.
    pub fn maps_candidate<R: Real>(maps: &[TriangleMaps<R>]) -> Array {
        Array::f32(
            &[maps.len(), MAPS_ROW],
            maps.iter()
                .flat_map(|t| {
                    t.values()
                        .into_iter()
                        .map(|v| v.value() as f32)
                        .chain([t.flags as f32])
                        .collect::<Vec<f32>>()
                })
                .collect(),
        )
    }
}
