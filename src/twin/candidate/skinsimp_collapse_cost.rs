//! `skinsimp_collapse_cost` over its vectors: one [`skinsimp_collapse_cost`] per candidate, each
//! laid out as the manifest's 14 values (Q̃'s upper triangle, v̂, E).

use std::path::Path;

use super::{as_f32, as_u32};
use crate::error::Result;
use crate::twin::skinsimp_collapse_cost::{skinsimp_collapse_cost, Buffers, EdgeCost, EdgeItem};
use crate::twin::{with_model, Model, F};
use crate::vectors::{Array, KernelVectors};

/// One candidate's body: the twin's [`skinsimp_collapse_cost`] or a mutant of it.
pub type Body = fn(&Buffers, &EdgeItem) -> EdgeCost<F>;

/// The 14 output values of one result, as f32.
pub fn row(out: &EdgeCost<F>) -> [f32; 14] {
    let mut row = [0.0; 14];
    for (k, q) in out.quadric.iter().enumerate() {
        row[k] = q.get();
    }
    row[10] = out.position.x.get();
    row[11] = out.position.y.get();
    row[12] = out.position.z.get();
    row[13] = out.cost.get();
    row
}

/// The candidate of `body` on the vectors in `dir` under `model`: [candidates, 14].
pub fn candidate_with(dir: &Path, k: &KernelVectors, model: Model, body: Body) -> Result<Array> {
    let rest = as_f32(&k.load_input(dir, "rest")?);
    let quadrics = k.load_input(dir, "vertex_quadrics")?;
    let matrices = k.load_input(dir, "matrices")?;
    let edges = as_u32(&k.load_input(dir, "edges")?);
    let bones = as_u32(&k.load_input(dir, "bones")?);
    let alpha = as_f32(&k.load_input(dir, "alpha")?);
    let max_condition = as_f32(&k.load_input(dir, "max_condition")?);
    let (pose_count, joint_count) = (matrices.shape[0] as u32, matrices.shape[1] as u32);
    let (vertex_quadrics, joints) = (as_f32(&quadrics), as_f32(&matrices));
    let buffers = Buffers {
        rest: &rest,
        vertex_quadrics: &vertex_quadrics,
        joints: &joints,
        pose_count,
        joint_count,
        max_condition: max_condition.first().copied().unwrap_or(0.0),
    };
    let n = edges.len() / 2;
    let mut out = Vec::with_capacity(n * 14);
    for c in 0..n {
        // All 8 slots: those past K weigh 0, which `blend` skips as the kernel's loop to K does.
        let slots = 8 * c..8 * c + 8;
        let item = EdgeItem {
            a: edges[2 * c],
            b: edges[2 * c + 1],
            joints: bones[slots.clone()].to_vec(),
            alpha: alpha[slots].to_vec(),
        };
        out.extend(crate::twin::coverage::invocation(|| {
            with_model(model, || row(&body(&buffers, &item)))
        }));
    }
    Ok(Array::f32(&[n, 14], out))
}

/// The twin's candidate on the vectors in `dir` under `model`.
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, skinsimp_collapse_cost)
}
