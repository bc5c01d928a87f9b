//! `skinsimp_quadrics.source` and `skinsimp_lbs` through their f32 twins
//! (`src/twin/skinsimp_quadrics.rs`, `src/twin/skinsimp_lbs.rs`):
//! - under every arithmetic model a conforming GPU may use (correctly rounded, FMA-contracted,
//!   reordered, at the edge of the WGSL table) the canonical vectors accept it (issue #34: an
//!   FMA port once failed 42 elements whose bound was exactly 0);
//! - no bound is 0;
//! - the porting mistakes below (mutants) are all rejected. The printed table is the one in src/vectors/README.md.

mod common;

use common::mutation::MutationTable;
use reparam::twin::candidate::skinsimp_lbs::{
    self as lbs, correct as correct_lbs, pose_major, MatrixIndex,
};
use reparam::twin::candidate::skinsimp_quadrics::{
    as_stored, source_candidate_with, vertex_candidate_with, Gather, PoseOf, SourceBody as Body,
};
use reparam::twin::real::{cross, dot, length};
use reparam::twin::skinsimp_lbs::{joint_times, skin};
use reparam::twin::skinsimp_quadrics::{
    edge_constraint, from_plane, from_triangle, plane_quadric, unit_normal, zero_quadric, Quadric,
    SOURCE_FACE,
};
use reparam::twin::{Model, Real, F, V3, V4};
use reparam::vectors::verify::{verify_array, VerifyReport};
use reparam::vectors::{Array, KernelVectors};

/// The canonical vectors' folder.
fn dir() -> std::path::PathBuf {
    common::canonical::dir("skinsimp")
}

/// Kernel `name`'s manifest entry.
fn named(name: &str) -> KernelVectors {
    common::canonical::kernel("skinsimp", name)
}

const KERNEL: &str = "skinsimp_quadrics.source";
const LBS: &str = "skinsimp_lbs";

fn kernel() -> KernelVectors {
    named(KERNEL)
}

/// The candidate of `body` on the canonical inputs under `model`: [sources, poses, 10].
fn candidate(k: &KernelVectors, body: Body, model: Model) -> Array {
    source_candidate_with(&dir(), k, model, body).unwrap()
}

fn judge(k: &KernelVectors, body: Body, model: Model) -> VerifyReport {
    verify_array(&dir(), k, &candidate(k, body, model), "twin").unwrap()
}

/// `from_triangle` without normalising: q = (c, −c·p0) with c the cross product.
fn unnormalised(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind != SOURCE_FACE {
        return plane_quadric(kind, p, w);
    }
    let c = cross(p[1] - p[0], p[2] - p[0]);
    let area = length(c.to_array()) * F::lit(0.5);
    from_plane(c, -dot(c.to_array(), p[0].to_array()), area)
}

/// The face's weight = |c| (twice the area).
fn twice_area(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    let q = plane_quadric(kind, p, w);
    if kind != SOURCE_FACE {
        return q;
    }
    q.map(|x| x * F::lit(2.0))
}

/// d = +n·p0.
fn d_sign(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind != SOURCE_FACE {
        return plane_quadric(kind, p, w);
    }
    let c = cross(p[1] - p[0], p[2] - p[0]);
    let twice = length(c.to_array());
    if twice.value() == 0.0 {
        return zero_quadric();
    }
    let n = c / twice;
    from_plane(n, dot(n.to_array(), p[0].to_array()), F::lit(0.5) * twice)
}

/// The boundary edge e taken as (corner e, corner e + 2): the wrong edge.
fn wrong_edge(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    edge_constraint(p[e], p[(e + 2) % 3], unit_normal(p[0], p[1], p[2]), w)
}

/// The constraint weighted by weight · |e| instead of |e|².
fn weight_unsquared(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    let edge = p[(e + 1) % 3] - p[e];
    let q = edge_constraint(p[e], p[(e + 1) % 3], unit_normal(p[0], p[1], p[2]), w);
    let l = length(edge.to_array());
    q.map(|x| x / l)
}

/// The constraint plane taken as the face's own plane through the edge (no e × n).
fn face_plane_constraint(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    let n = unit_normal(p[0], p[1], p[2]);
    let edge = p[(e + 1) % 3] - p[e];
    from_plane(
        n,
        -dot(n.to_array(), p[e].to_array()),
        w * dot(edge.to_array(), edge.to_array()),
    )
}

/// Boundary constraints left out.
fn no_constraints(kind: u32, p: [V3<F>; 3], w: F) -> Quadric<F> {
    if kind == SOURCE_FACE {
        return from_triangle(p[0], p[1], p[2]);
    }
    let _ = w;
    zero_quadric()
}

const MUTANTS: [(&str, &str, Body); 7] = [
    (
        "unnormalised",
        "the face plane not normalised (q = (c, −c·p0))",
        unnormalised,
    ),
    (
        "twice_area",
        "the face weighted by |c| = twice its area",
        twice_area,
    ),
    ("d_sign", "d = +n·p0", d_sign),
    (
        "wrong_edge",
        "boundary edge e taken as (corner e, corner e + 2)",
        wrong_edge,
    ),
    (
        "weight_unsquared",
        "constraint weighted by boundary_weight · |e|, not |e|²",
        weight_unsquared,
    ),
    (
        "face_plane_constraint",
        "constraint plane = the face's plane (no e × n)",
        face_plane_constraint,
    ),
    (
        "no_constraints",
        "boundary constraints left out",
        no_constraints,
    ),
];

#[test]
fn every_model_passes_every_mutant_fails_and_no_bound_is_zero() {
    let k = kernel();
    let bounds = Array::load(&dir().join(&k.bound.file)).unwrap().to_f64();
    let zero = bounds.iter().filter(|&&b| b == 0.0).count();
    assert_eq!(zero, 0, "{zero} of {} bounds are exactly 0", bounds.len());
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        let r = judge(&k, plane_quadric, model);
        table.twin(&model.name(), &r);
    }
    for (name, mistake, body) in MUTANTS {
        let r = judge(&k, body, Model::Nearest);
        table.mutant(name, mistake, &r);
    }
    table.finish();
}

// ---------------------------------------------------------------------------------------------
// skinsimp_lbs

/// One vertex's skinning: rest point, joints, weights, the pose's matrix of a joint.
type LbsBody = lbs::Body;

/// The candidate of `body` on the canonical LBS inputs under `model`: [vertices, poses, 3].
/// `index(pose, joint, poses, joints)` is where the matrix is read (the manifest's: pose·J +
/// joint).
fn lbs_candidate(body: LbsBody, index: MatrixIndex, model: Model) -> Array {
    lbs::candidate_with(&dir(), &named(LBS), model, body, index).unwrap()
}

/// (x, 0): the translation dropped.
fn no_translation(x: V3<F>, js: [u32; 4], ws: [F; 4], m: &dyn Fn(u32) -> [F; 12]) -> V3<F> {
    let mut sum = V3::splat(F::lit(0.0));
    for k in 0..4 {
        let h = V4::new(x.x, x.y, x.z, F::lit(0.0));
        sum = sum + joint_times(&m(js[k]), h) * ws[k];
    }
    sum
}

/// The 3 × 4 matrix read column by column.
fn column_major(x: V3<F>, js: [u32; 4], ws: [F; 4], m: &dyn Fn(u32) -> [F; 12]) -> V3<F> {
    let transposed = |j: u32| {
        let a = m(j);
        std::array::from_fn(|e| a[3 * (e % 4) + e / 4])
    };
    skin(x, js, ws, transposed)
}

/// Only the first influence, weight 1.
fn first_influence(x: V3<F>, js: [u32; 4], _: [F; 4], m: &dyn Fn(u32) -> [F; 12]) -> V3<F> {
    skin(
        x,
        js,
        [F::lit(1.0), F::lit(0.0), F::lit(0.0), F::lit(0.0)],
        m,
    )
}

/// Equal weights over the four slots.
fn equal_weights(x: V3<F>, js: [u32; 4], _: [F; 4], m: &dyn Fn(u32) -> [F; 12]) -> V3<F> {
    skin(x, js, [F::lit(0.25); 4], m)
}

/// The rest position returned unposed.
fn unposed(x: V3<F>, _: [u32; 4], _: [F; 4], _: &dyn Fn(u32) -> [F; 12]) -> V3<F> {
    x
}

/// Matrices indexed joint·P + pose (the other layout).
fn joint_major(pose: usize, joint: usize, poses: usize, _: usize) -> usize {
    joint * poses + pose
}

#[test]
fn lbs_every_model_passes_every_mutant_fails_and_no_bound_is_zero() {
    let k = named(LBS);
    let bounds = Array::load(&dir().join(&k.bound.file)).unwrap().to_f64();
    assert_eq!(bounds.iter().filter(|&&b| b == 0.0).count(), 0);
    let judge = |a: Array| verify_array(&dir(), &k, &a, "twin").unwrap();
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        let r = judge(lbs_candidate(correct_lbs, pose_major, model));
        table.twin(&model.name(), &r);
    }
    let mutants: [(&str, &str, LbsBody, MatrixIndex); 6] = [
        (
            "no_translation",
            "the point taken as (x, 0): translations dropped",
            no_translation,
            pose_major,
        ),
        (
            "column_major",
            "the 3 × 4 matrix read column by column",
            column_major,
            pose_major,
        ),
        (
            "first_influence",
            "only the first joint, weight 1",
            first_influence,
            pose_major,
        ),
        (
            "equal_weights",
            "the weights ignored (¼ each)",
            equal_weights,
            pose_major,
        ),
        ("unposed", "the rest position returned", unposed, pose_major),
        (
            "joint_major",
            "matrices indexed joint·P + pose",
            correct_lbs,
            joint_major,
        ),
    ];
    for (name, mistake, body, index) in mutants {
        let r = judge(lbs_candidate(body, index, Model::Nearest));
        table.mutant(name, mistake, &r);
    }
    table.finish();
}

// ---------------------------------------------------------------------------------------------
// skinsimp_quadrics.vertex

const VERTEX: &str = "skinsimp_quadrics.vertex";

/// The candidate: each source's quadric by the twin under `model`, then each vertex's sum of
/// the sources `gather` names, read at pose `pose_of(j)`.
fn vertex_candidate(gather: Gather, pose_of: PoseOf, model: Model) -> Array {
    vertex_candidate_with(&dir(), &named(VERTEX), model, gather, pose_of).unwrap()
}

#[test]
fn vertex_quadrics_every_model_passes_every_mutant_fails() {
    let k = named(VERTEX);
    let bounds = Array::load(&dir().join(&k.bound.file)).unwrap().to_f64();
    assert_eq!(bounds.iter().filter(|&&b| b == 0.0).count(), 0);
    let judge = |a: Array| verify_array(&dir(), &k, &a, "twin").unwrap();
    let mut table = MutationTable::default();
    let same_pose = |j: usize| j;
    for model in Model::CHECKED {
        let r = judge(vertex_candidate(as_stored, same_pose, model));
        table.twin(&model.name(), &r);
    }
    let mutants: [(&str, &str, Gather, PoseOf); 6] = [
        (
            "first_source_skipped",
            "the sum starts at offsets\\[v\\] + 1",
            |o, s, _, v| s[o[v] + 1..o[v + 1]].to_vec(),
            |j| j,
        ),
        (
            "csr_shifted",
            "vertex v sums vertex v + 1's sources",
            |o, s, _, v| s[o[(v + 1).min(o.len() - 2)]..o[(v + 2).min(o.len() - 1)]].to_vec(),
            |j| j,
        ),
        (
            "faces_only",
            "boundary constraints left out of the sum",
            |o, s, kind, v| {
                s[o[v]..o[v + 1]]
                    .iter()
                    .copied()
                    .filter(|&x| kind[x] == SOURCE_FACE)
                    .collect()
            },
            |j| j,
        ),
        (
            "constraints_only",
            "face planes left out of the sum",
            |o, s, kind, v| {
                s[o[v]..o[v + 1]]
                    .iter()
                    .copied()
                    .filter(|&x| kind[x] != SOURCE_FACE)
                    .collect()
            },
            |j| j,
        ),
        (
            "first_pose",
            "every pose reads pose 0's sources",
            as_stored,
            |_| 0,
        ),
        (
            "sources_twice",
            "each source added twice",
            |o, s, _, v| s[o[v]..o[v + 1]].iter().flat_map(|&x| [x, x]).collect(),
            |j| j,
        ),
    ];
    for (name, mistake, gather, pose_of) in mutants {
        let r = judge(vertex_candidate(gather, pose_of, Model::Nearest));
        table.mutant(name, mistake, &r);
    }
    table.finish();
}
