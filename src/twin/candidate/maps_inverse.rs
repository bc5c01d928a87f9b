//! `maps_inverse` over its vectors: one [`inverse`] per query, laid out as the manifest's
//! expected positions (x, y, z per query).

use std::path::Path;

use super::{as_f32, as_u32};
use crate::error::Result;
use crate::twin::maps_inverse::{inverse, InverseResult, Tables};
use crate::twin::{with_model, Model, F, V3};
use crate::vectors::{Array, KernelVectors};

/// One query's body: the twin's [`inverse`] or a mutant of it.
pub type Body = fn(&Tables, u32, V3<F>) -> InverseResult<F>;

/// The candidate of `body` on the vectors in `dir` under `model`: [queries, 3].
pub fn candidate_with(dir: &Path, k: &KernelVectors, model: Model, body: Body) -> Result<Array> {
    let positions = as_f32(&k.load_input(dir, "positions")?);
    let corners = as_u32(&k.load_input(dir, "face_corners")?);
    let created_by = as_u32(&k.load_input(dir, "face_created_by")?);
    let charts = as_f32(&k.load_input(dir, "charts")?);
    let removals = as_u32(&k.load_input(dir, "removals")?);
    let old_faces = as_u32(&k.load_input(dir, "old_faces")?);
    let base_to_face = as_u32(&k.load_input(dir, "base_to_face")?);
    let query_face = as_u32(&k.load_input(dir, "query_face")?);
    let query_bary = as_f32(&k.load_input(dir, "query_bary")?);
    let tables = Tables {
        positions: &positions,
        corners: &corners,
        created_by: &created_by,
        charts: &charts,
        removals: &removals,
        old_faces: &old_faces,
        base_to_face: &base_to_face,
    };
    let mut out = Vec::with_capacity(3 * query_face.len());
    for (n, &face) in query_face.iter().enumerate() {
        let b = V3::new(
            F::new(query_bary[3 * n]),
            F::new(query_bary[3 * n + 1]),
            F::new(query_bary[3 * n + 2]),
        );
        let r = crate::twin::coverage::invocation(|| with_model(model, || body(&tables, face, b)));
        out.extend([r.position.x, r.position.y, r.position.z].map(|x| x.get()));
    }
    Ok(Array::f32(&[query_face.len(), 3], out))
}

/// The twin's candidate on the vectors in `dir` under `model`.
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, inverse)
}
