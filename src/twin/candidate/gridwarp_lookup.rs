//! `gridwarp_lookup` over its vectors: one [`lookup_uv`] per query, laid out as the manifest's
//! expected UVs (u, v per query).

use std::path::Path;

use super::{as_f32, as_u32};
use crate::error::Result;
use crate::gridwarp::gpu_lookup::FlatTables;
use crate::twin::gridwarp_lookup::{lookup_uv, Tables};
use crate::twin::{with_model, Model, F, V2};
use crate::vectors::{Array, KernelVectors};

/// One query's body: the twin's [`lookup_uv`] or a mutant of it.
pub type Body = fn(&Tables, V2<F>) -> V2<F>;

/// The candidate of `body` on the vectors in `dir` under `model`: [queries, 2].
pub fn candidate_with(dir: &Path, k: &KernelVectors, model: Model, body: Body) -> Result<Array> {
    let flat = FlatTables {
        rois: as_f32(&k.load_input(dir, "rois")?),
        grids: as_u32(&k.load_input(dir, "roi_grids")?),
        rest_lines: as_f32(&k.load_input(dir, "rest_lines")?),
        warped: as_f32(&k.load_input(dir, "warped")?),
    };
    flat.checked()
        .map_err(|e| super::invalid(k, e.to_string()))?;
    let queries = as_f32(&k.load_input(dir, "queries")?);
    if !queries.len().is_multiple_of(2) {
        return Err(super::invalid(
            k,
            format!("{} query values, need 2 per query", queries.len()),
        ));
    }
    let tables = flat.tables();
    let out: Vec<f32> = queries
        .chunks(2)
        .flat_map(|q| {
            let uv = with_model(model, || body(&tables, V2::new(F::new(q[0]), F::new(q[1]))));
            [uv.x.get(), uv.y.get()]
        })
        .collect();
    Ok(Array::f32(&[queries.len() / 2, 2], out))
}

/// The twin's candidate on the vectors in `dir` under `model`.
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, lookup_uv)
}
