//! `skinsimp_lbs`' candidate from its twin ([`crate::twin::skinsimp_lbs`]): every vertex
//! skinned at every pose, [vertices, poses, 3], as a conforming GPU under a [`Model`] computes
//! it.

use std::path::Path;

use super::invalid;
use crate::error::Result;
use crate::twin::skinsimp_lbs::skin;
use crate::twin::{with_model, Model, F, V3};
use crate::vectors::{Array, KernelVectors};

/// One vertex's skinning: (rest point, joints, weights, the pose's 3 × 4 matrix of a joint) →
/// the posed point (the twin's [`skin`], or a mutant's).
pub type Body = fn(V3<F>, [u32; 4], [F; 4], &dyn Fn(u32) -> [F; 12]) -> V3<F>;

/// Where a pose's matrix of a joint is read: (pose, joint, poses, joints) → matrix index.
pub type MatrixIndex = fn(usize, usize, usize, usize) -> usize;

/// The manifest's layout: pose · J + joint.
pub fn pose_major(pose: usize, joint: usize, _: usize, joints: usize) -> usize {
    pose * joints + joint
}

/// The twin's body: [`skin`].
pub fn correct(x: V3<F>, js: [u32; 4], ws: [F; 4], m: &dyn Fn(u32) -> [F; 12]) -> V3<F> {
    skin(x, js, ws, m)
}

/// The candidate of kernel `k` (vectors in `dir`) under `model`.
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, correct, pose_major)
}

/// [`candidate`] with a port's `body` and matrix `index`.
pub fn candidate_with(
    dir: &Path,
    k: &KernelVectors,
    model: Model,
    body: Body,
    index: MatrixIndex,
) -> Result<Array> {
    let rest = k.load_input(dir, "rest")?.to_f64();
    let joints = k.load_input(dir, "joints")?.to_f64();
    let weights = k.load_input(dir, "weights")?.to_f64();
    let m = k.load_input(dir, "matrices")?;
    let (poses, joint_count) = (m.shape[0], m.shape.get(1).copied().unwrap_or(0));
    let m = m.to_f64();
    let matrices = poses * joint_count;
    let vertices = rest.len() / 3;
    if (vertices > 0 && poses > 0 && matrices == 0)
        || m.len() < 12 * matrices
        || joints.len() < 4 * vertices
        || weights.len() < 4 * vertices
    {
        return Err(invalid(
            k,
            format!(
                "{vertices} vertices need 4 joints and weights each and matrices [P, J, 12] with \
             J ≥ 1; found {} joints, {} weights, {} matrix entries for {poses} × {joint_count}",
                joints.len(),
                weights.len(),
                m.len()
            ),
        ));
    }
    let mut out = Vec::with_capacity(vertices * poses * 3);
    for v in 0..vertices {
        let x = V3::new(
            F::new(rest[3 * v] as f32),
            F::new(rest[3 * v + 1] as f32),
            F::new(rest[3 * v + 2] as f32),
        );
        let js = [0, 1, 2, 3].map(|c| joints[4 * v + c] as u32);
        let ws = [0, 1, 2, 3].map(|c| F::new(weights[4 * v + c] as f32));
        for j in 0..poses {
            // An index past the end (a mutant's layout) reads the last matrix, as a GPU's
            // robust buffer access may.
            let matrix = |joint: u32| -> [F; 12] {
                let o = 12 * index(j, joint as usize, poses, joint_count).min(matrices - 1);
                std::array::from_fn(|e| F::new(m[o + e] as f32))
            };
            let p = crate::twin::coverage::invocation(|| {
                with_model(model, || body(x, js, ws, &matrix))
            });
            out.extend([p.x.get(), p.y.get(), p.z.get()]);
        }
    }
    Ok(Array::f32(&[vertices, poses, 3], out))
}
