//! maps vectors: Π⁻¹ of base points (`maps_inverse`), from the hierarchy's tables as the kernel
//! receives them, against [`crate::maps::Param::inverse`] (MAPS §3, seed 002), held to the
//! cross-check's limit [`INVERSE_POSITION_MAX`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::maps::INVERSE_POSITION_MAX;
use crate::error::{Error, Result};
use crate::maps::gpu::{base_queries, inverse_gpu, inverse_tables, normalise};
use crate::maps::param::BasePoint;
use crate::maps::Maps;

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
        description: "Π⁻¹ of base points: replay the removals backwards from the base face to \
            the input face containing the point, then Σ b_c p_c (MAPS §3.3)"
            .into(),
        inputs,
        expected: (
            "per query, f64: x, y, z in the normalised frame".into(),
            Array::f64(&[n, 3], expected.iter().flatten().copied().collect()),
        ),
        bound: (
            "per query, fraction of the diagonal".into(),
            Array::f64(&[n], vec![INVERSE_POSITION_MAX; n]),
        ),
        metric: Metric::NormOfLastAxis {
            scale: 1.0,
            unit: "fraction of the diagonal".into(),
        },
        bound_formula: "1e-5 of the diagonal".into(),
        derivation: "crosscheck::maps::INVERSE_POSITION_MAX: ≤ 204u of the diagonal per \
            replayed removal, √L of them in a random walk"
            .into(),
        per_element: vec!["query_face".into(), "query_bary".into()],
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
