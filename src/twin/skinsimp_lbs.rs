//! Twin of `gpu/shaders/skinsimp_lbs.wgsl`, function for function: linear blend skinning
//! p_ij = Σ_k w_ik M_{j,k} (x_i, 1) (seed 003 §3), each joint matrix its 3 × 4 top, row by row.

use super::coverage::{branches, taken, Branch};
use super::real::{dot, Real, V3, V4};

/// `skinsimp_lbs`' branches ([`super::coverage`]).
pub const BRANCHES: &[Branch] = branches![
    "skinsimp_lbs.weight.used" => "an influence with w_k ≠ 0: w_k M_{pose, joint_k} (x, 1) added",
    "skinsimp_lbs.weight.skipped" => "an influence with w_k = 0: skipped (its joint index may be any)",
];

/// `joint_times`: the 3 × 4 matrix `m` (row by row) times the homogeneous point h.
pub fn joint_times<R: Real>(m: &[R; 12], h: V4<R>) -> V3<R> {
    let row = |r: usize| [m[4 * r], m[4 * r + 1], m[4 * r + 2], m[4 * r + 3]];
    let h = h.to_array();
    V3::new(dot(row(0), h), dot(row(1), h), dot(row(2), h))
}

/// `skin`: Σ_k w_k M_{pose, joint_k} (x, 1) over the non-zero weights, `matrix(joint)` the
/// pose's matrix of a joint.
pub fn skin<R: Real>(
    rest: V3<R>,
    joints: [u32; 4],
    weights: [R; 4],
    matrix: impl Fn(u32) -> [R; 12],
) -> V3<R> {
    let h = V4::new(rest.x, rest.y, rest.z, R::lit(1.0));
    let mut sum = V3::splat(R::lit(0.0));
    for k in 0..4 {
        let w = weights[k];
        if taken(
            w.value() != 0.0,
            "skinsimp_lbs.weight.used",
            "skinsimp_lbs.weight.skipped",
        ) {
            sum = sum + joint_times(&matrix(joints[k]), h) * w;
        }
    }
    sum
}
