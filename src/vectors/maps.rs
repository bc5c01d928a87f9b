//! maps vectors: Π⁻¹ of base points (`maps_inverse`), from the hierarchy's tables as the kernel
//! receives them, against [`crate::maps::Param::inverse`] (MAPS §3, seed 002), held to the
//! cross-check's limit [`INVERSE_POSITION_MAX`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::maps::INVERSE_POSITION_MAX;
use crate::crosscheck::maps_inverse_bound::{inverse_position_bound, FlatTables};
use crate::error::{Error, Result};
use crate::maps::gpu::{base_queries, inverse_gpu, inverse_tables, normalise};
use crate::maps::param::BasePoint;
use crate::maps::Maps;

/// `maps_inverse` for the manifest, step by step (issue #33: an implementer must be able to
/// write a passing candidate from the manifest alone; `tests/vectors_manifest_maps.rs` does).
const INVERSE_FORMULA: &str = "Π⁻¹ of base points (MAPS §3.3). Per query (base face q, \
    barycentrics b): face = base_to_face[q]. While face_created_by[face] ≠ 4294967295 (not an \
    input face): r = face_created_by[face]; u = Σ_c b_c μ_c with μ_c = (charts[face][2c], \
    charts[face][2c + 1]) (the face's corners in r's plane); over the faces f of \
    old_faces[removals[r][0] .. removals[r][0] + removals[r][1]] in that order, with their \
    corners ν_c = (charts[f][6 + 2c], charts[f][7 + 2c]) in r's plane, λ = barycentric(u, ν): \
    take the first f with min λ ≥ 0, else the f with the largest min λ (the first on ties); \
    face = f, b = max(λ, 0) / Σ max(λ, 0). At an input face: position = Σ_c b_c \
    positions[face_corners[face][c]] (x, y, z). barycentric(u, a, b, c) = (o(u, b, c), \
    o(a, u, c), o(a, b, u)) / s with o(p, q, r) = (q.x − p.x)(r.y − p.y) − (q.y − p.y)(r.x − p.x) \
    and s the sum of the three (o(a, b, c) if that sum is 0)";

/// The vectors of Π⁻¹ at `points` (base face, barycentrics) of `maps`, positions in the
/// normalised frame (centred on the bounding box, divided by its diagonal), and with a GPU
/// reparam's own kernel's output as the candidate.
pub fn vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    maps: &Maps,
    points: &[BasePoint],
) -> Result<VectorsAndCandidates> {
    let norm = normalise(&maps.positions)?;
    let tables = inverse_tables(maps, &norm);
    let queries = base_queries(points);
    let expected = points
        .iter()
        .map(|p| {
            let c = maps.param.inverse(p).ok_or_else(|| {
                Error::InvalidArgument(format!("base point in face {} out of range", p.face))
            })?;
            let q = norm.apply(&c.position);
            Ok([q.x, q.y, q.z])
        })
        .collect::<Result<Vec<_>>>()?;
    let n = points.len();
    let f = tables.faces.len();
    let flat = FlatTables::of(&tables);
    let bounds: Vec<f64> = queries
        .iter()
        .zip(&expected)
        .map(|(q, e)| inverse_position_bound(&flat.tables(), q, *e))
        .collect();
    let inputs: Vec<(String, String, Array)> = vec![
        (
            "positions".into(),
            "per input vertex (0-based), f32: x, y, z in the normalised frame (centred on the \
             bounding box, divided by its diagonal), 0"
                .into(),
            Array::f32(&[tables.positions.len(), 4], tables.positions.iter().flatten().copied().collect()),
        ),
        (
            "face_corners".into(),
            "per decimation face (input faces first, then each removal's new faces), u32: 3 vertices"
                .into(),
            Array::u32(&[f, 3], tables.faces.iter().flat_map(|d| d.corners).collect()),
        ),
        (
            "face_created_by".into(),
            "per decimation face, u32: the removal that created it (4294967295: an input face)".into(),
            Array::u32(&[f], tables.faces.iter().map(|d| d.created_by).collect()),
        ),
        (
            "charts".into(),
            "per decimation face, f32: μ of its 3 corners (x, y each) in the plane of the removal \
             that created it, then in that of the removal that deleted it (the removed vertex at \
             0; zeros where the chart does not apply)"
                .into(),
            Array::f32(
                &[f, 12],
                tables
                    .charts
                    .iter()
                    .flat_map(|c| c.created.iter().chain(&c.removed).flatten().copied().collect::<Vec<_>>())
                    .collect(),
            ),
        ),
        (
            "removals".into(),
            "per removal (hierarchy order), u32: first index into old_faces, count".into(),
            Array::u32(&[tables.removals.len(), 2], tables.removals.iter().flatten().copied().collect()),
        ),
        ("old_faces".into(), "u32: the faces each removal deleted".into(), Array::u32(&[tables.old_faces.len()], tables.old_faces.clone())),
        ("base_to_face".into(), "per base face, u32: its decimation face".into(), Array::u32(&[tables.base_to_face.len()], tables.base_to_face.clone())),
        ("query_face".into(), "per query, u32: the base face (0-based)".into(), Array::u32(&[n], queries.iter().map(|q| q.face).collect())),
        (
            "query_bary".into(),
            "per query, f32: barycentrics in the base face's corner order".into(),
            Array::f32(&[n, 3], queries.iter().flat_map(|q| q.bary).collect()),
        ),
    ];
    let kernel = KernelData {
        name: "maps_inverse".into(),
        description: INVERSE_FORMULA.into(),
        inputs,
        expected: (
            "per query, f64: x, y, z in the normalised frame".into(),
            Array::f64(&[n, 3], expected.iter().flatten().copied().collect()),
        ),
        bound: (
            "per query, fraction of the diagonal".into(),
            Array::f64(&[n], bounds),
        ),
        metric: Metric::NormOfLastAxis {
            scale: 1.0,
            unit: "fraction of the diagonal".into(),
        },
        bound_formula:
            "d_in + 2 ‖(b_x, b_y, b_z)‖₂ per query: d_in = ‖Π⁻¹ on the f32 tables − Π⁻¹ \
            on the f64 charts‖ (computed in f64), b_c = Σᵢ |∂p_c/∂eᵢ| aᵢ the first-order effect of \
            every operation's WGSL allowance along the walk"
                .into(),
        derivation:
            "crosscheck::maps_inverse_bound::inverse_position_bound: the kernel's twin over Lin \
            (src/twin/maps_inverse.rs, src/twin/lin.rs)"
                .into(),
        per_element: vec!["query_face".into(), "query_bary".into()],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let out = inverse_gpu(gpu, &tables, points)?;
        candidates.push((
            "maps_inverse".to_string(),
            Array::f32(&[n, 3], out.iter().flat_map(|r| r.position).collect()),
        ));
    }
    Ok((vec![kernel], candidates))
}

/// The two-sided Hausdorff distance (BVH, [`crate::maps::quality::remesh_quality`]) between the
/// surface with `faces` on `points` and the input, both in the normalised frame (diagonal 1).
fn hausdorff_normalised(
    norm: &crate::maps::gpu::Normalised,
    maps: &Maps,
    points: &[nalgebra::Point3<f64>],
    faces: &[[u32; 3]],
) -> f64 {
    crate::maps::quality::remesh_quality(points, faces, &norm.cpu, &maps.input_faces, 1.0)
        .hausdorff_relative
}

/// The whole-algorithm vectors of MAPS: the base domain's counts (levels, base vertices, base
/// faces) and the two-sided Hausdorff distance between the `remesh` (its vertices Π⁻¹ of its
/// base points, MAPS §4) and the input, as a fraction of the bounding-box diagonal. With a GPU,
/// the candidate is the same hierarchy with the remesh's vertices from reparam's own
/// `maps_inverse` kernel.
pub fn run_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    maps: &Maps,
    remesh: &crate::maps::remesh::Remesh,
) -> Result<VectorsAndCandidates> {
    let norm = normalise(&maps.positions)?;
    let cpu_points: Vec<_> = remesh
        .mesh
        .positions
        .iter()
        .map(|p| norm.apply(p))
        .collect();
    let faces = &remesh.mesh.faces;
    let counts = [
        maps.level_count() as f64,
        maps.base_mesh().positions.len() as f64,
        maps.base_faces.len() as f64,
    ];
    let h = hausdorff_normalised(&norm, maps, &cpu_points, faces);
    let expected = vec![counts[0], counts[1], counts[2], h];
    let h_bound = if h > 0.0 {
        INVERSE_POSITION_MAX / h
    } else {
        INVERSE_POSITION_MAX
    };
    let kernel = KernelData {
        name: "maps_run".into(),
        description: "the MAPS hierarchy (§3) to its base domain and a remesh of it (§4): the \
            hierarchy's levels, the base domain's vertices and faces, and the two-sided \
            Hausdorff distance between the remesh and the input"
            .into(),
        inputs: vec![
            (
                "positions".into(),
                "per input vertex (0-based), f64: x, y, z in the normalised frame (centred on \
                 the bounding box, divided by its diagonal; values of f32)"
                    .into(),
                Array::f64(
                    &[norm.cpu.len(), 3],
                    norm.cpu.iter().flat_map(|p| [p.x, p.y, p.z]).collect(),
                ),
            ),
            (
                "faces".into(),
                "per input face, u32: three vertices (0-based, counter-clockwise)".into(),
                Array::u32(
                    &[maps.input_faces.len(), 3],
                    maps.input_faces.iter().flatten().copied().collect(),
                ),
            ),
            (
                "remesh_faces".into(),
                "per remesh face, u32: three remesh vertices, each the Π⁻¹ of the base point of \
                 the same row of `remesh_points`"
                    .into(),
                Array::u32(&[faces.len(), 3], faces.iter().flatten().copied().collect()),
            ),
            (
                "remesh_points".into(),
                "per remesh vertex, f64: base face (0-based), barycentrics of its corners 0, 1, 2"
                    .into(),
                Array::f64(
                    &[remesh.params.len(), 4],
                    remesh
                        .params
                        .iter()
                        .flat_map(|p| {
                            let b = p.bary;
                            [p.face as f64, b[0], b[1], b[2]]
                        })
                        .collect(),
                ),
            ),
        ],
        expected: (
            "f64: levels of the hierarchy, base vertices, base faces, two-sided Hausdorff \
             distance of the remesh (fraction of the diagonal)"
                .into(),
            Array::f64(&[4], expected),
        ),
        bound: (
            "per figure, relative".into(),
            Array::f64(&[4], vec![0.0, 0.0, 0.0, h_bound]),
        ),
        metric: Metric::Relative {
            unit: "relative".into(),
        },
        bound_formula: "counts: exact; Hausdorff: 1e-5 / H (INVERSE_POSITION_MAX over the \
            figure)"
            .into(),
        derivation: "the counts are integers decided by the priority queue and the stopping \
            rule: an implementation of the same removals (priority λ·a/max a + (1−λ)·κ/max κ, \
            ties to the lower vertex index, the same degree limit) reproduces them exactly. \
            Moving every remesh vertex by ≤ d moves every point of the remesh by ≤ d (a convex \
            combination), so the Hausdorff distance moves by ≤ d both ways; Π⁻¹ is within \
            d = 1e-5 of the diagonal (maps_inverse's bound)"
            .into(),
        per_element: vec![],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let tables = inverse_tables(maps, &norm);
        let out = inverse_gpu(gpu, &tables, &remesh.params)?;
        let points: Vec<_> = out
            .iter()
            .map(|r| {
                nalgebra::Point3::new(
                    r.position[0] as f64,
                    r.position[1] as f64,
                    r.position[2] as f64,
                )
            })
            .collect();
        let h_gpu = hausdorff_normalised(&norm, maps, &points, faces);
        candidates.push((
            "maps_run".to_string(),
            Array::f64(&[4], vec![counts[0], counts[1], counts[2], h_gpu]),
        ));
    }
    Ok((vec![kernel], candidates))
}

/// Every maps vector: Π⁻¹ at the remesh's base points ([`vectors`]) and the whole run
/// ([`run_vectors`]).
pub fn all_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    maps: &Maps,
    remesh: &crate::maps::remesh::Remesh,
) -> Result<VectorsAndCandidates> {
    let (mut kernels, mut candidates) = vectors(gpu, maps, &remesh.params)?;
    let (run, run_candidates) = run_vectors(gpu, maps, remesh)?;
    kernels.extend(run);
    candidates.extend(run_candidates);
    Ok((kernels, candidates))
}
