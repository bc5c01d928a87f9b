//! `skinsimp_collapse_cost` through its f32 twin (`src/twin/skinsimp_collapse_cost.rs`):
//! - under every arithmetic model a conforming GPU may use (correctly rounded, FMA-contracted,
//!   reordered, at the edge of the WGSL table) the canonical vectors accept it;
//! - no bound is 0, and the vectors exercise the solve and all three fallbacks;
//! - the porting mistakes below (mutants) are all rejected. The printed table is the one in src/vectors/README.md.

mod common;

use common::mutation::MutationTable;
use reparam::twin::candidate::skinsimp_collapse_cost::{candidate, candidate_with, Body};
use reparam::twin::real::{cross, dot, is_finite, sqrt, Real};
use reparam::twin::skinsimp_collapse_cost::{
    blend, condition_within, energy, joint_matrix, ldexp, max_abs3, plus, position_quadric,
    quadric_matrix, quadric_value, rest_at, scaled, skinsimp_collapse_cost, summed_quadric,
    times_matrix, times_vector, transpose, upper_triangle, vertex_quadric, zero_matrix, Buffers,
    EdgeCost, EdgeItem, Solution, M4,
};
use reparam::twin::{Model, F, V3};
use reparam::vectors::KernelVectors;

const KERNEL: &str = "skinsimp_collapse_cost";

fn dir() -> std::path::PathBuf {
    common::canonical::dir("skinsimp")
}

fn kernel() -> KernelVectors {
    common::canonical::kernel("skinsimp", KERNEL)
}

/// The porting mistakes, each one step of the kernel done wrong.
#[derive(Clone, Copy, PartialEq)]
enum Mistake {
    None,
    TransposedProduct,
    OneEndpoint,
    JointColumns,
    SolutionSign,
    ConditionIgnored,
    NoMidpoint,
    ColumnOrder,
    FirstBoneEnergy,
    LastPoseDropped,
}

/// Q^j as the mutant reads it (`OneEndpoint`: Q_a^j alone).
fn quadric_of(m: Mistake, buffers: &Buffers, item: &EdgeItem, pose: u32) -> M4<F> {
    if m == Mistake::OneEndpoint {
        return quadric_matrix(&vertex_quadric(buffers, item.a, pose));
    }
    summed_quadric(buffers, item, pose)
}

/// A^j as the mutant blends it (`JointColumns`: the 3 × 4 rows read as columns).
fn blend_of(m: Mistake, buffers: &Buffers, item: &EdgeItem, pose: u32) -> M4<F> {
    if m != Mistake::JointColumns {
        return blend(buffers, item, pose);
    }
    let mut a = zero_matrix();
    for (&joint, &w) in item.joints.iter().zip(&item.alpha) {
        if w != 0.0 {
            let o = 12 * (pose * buffers.joint_count + joint) as usize;
            let e = |k: usize| F::new(buffers.joints[o + k]);
            let (zero, one) = (F::lit(0.0), F::lit(1.0));
            let m: M4<F> = [
                [e(0), e(1), e(2), zero],
                [e(3), e(4), e(5), zero],
                [e(6), e(7), e(8), zero],
                [e(9), e(10), e(11), one],
            ];
            a = plus(&a, &scaled(&m, F::new(w)));
        }
    }
    a
}

fn pose_count(m: Mistake, buffers: &Buffers) -> u32 {
    if m == Mistake::LastPoseDropped {
        buffers.pose_count - 1
    } else {
        buffers.pose_count
    }
}

fn mutated_quadric(m: Mistake, buffers: &Buffers, item: &EdgeItem) -> M4<F> {
    if m == Mistake::None {
        return position_quadric(buffers, item);
    }
    let mut total = zero_matrix();
    for j in 0..pose_count(m, buffers) {
        let a = blend_of(m, buffers, item, j);
        let q = quadric_of(m, buffers, item, j);
        let term = if m == Mistake::TransposedProduct {
            times_matrix(&times_matrix(&a, &q), &transpose(&a))
        } else {
            times_matrix(&times_matrix(&transpose(&a), &q), &a)
        };
        total = plus(&total, &term);
    }
    total
}

fn mutated_energy(m: Mistake, buffers: &Buffers, item: &EdgeItem, v: V3<F>) -> F {
    if m == Mistake::None {
        return energy(buffers, item, v);
    }
    let h = [v.x, v.y, v.z, F::lit(1.0)];
    let mut e = F::lit(0.0);
    for j in 0..pose_count(m, buffers) {
        let a = if m == Mistake::FirstBoneEnergy {
            joint_matrix(buffers, j, item.joints[0])
        } else {
            blend_of(m, buffers, item, j)
        };
        let p = times_vector(&a, h);
        e = e + dot(p, times_vector(&quadric_of(m, buffers, item, j), p));
    }
    e
}

/// The adjugate solve with the mutant's sign and condition test.
fn mutated_solve(m: Mistake, q: &M4<F>, max_condition: f32) -> Solution<F> {
    let column = |c: usize| V3::new(q[c][0], q[c][1], q[c][2]);
    let largest = max_abs3(column(0))
        .max(max_abs3(column(1)))
        .max(max_abs3(column(2)));
    let shift = -reparam::twin::skinsimp_collapse_cost::frexp_exponent(largest.value());
    let (c0, c1, c2) = (
        ldexp(column(0), shift),
        ldexp(column(1), shift),
        ldexp(column(2), shift),
    );
    let b = ldexp(column(3), shift);
    let (r0, r1, r2) = (cross(c1, c2), cross(c2, c0), cross(c0, c1));
    let det = dot(c0.to_array(), r0.to_array());
    let mut out = Solution {
        found: false,
        v: V3::splat(F::lit(0.0)),
        condition: F::lit(0.0),
    };
    if det.value() == 0.0 {
        return out;
    }
    let sq = |v: V3<F>| dot(v.to_array(), v.to_array());
    out.condition = sqrt(sq(c0) + sq(c1) + sq(c2)) * sqrt(sq(r0) + sq(r1) + sq(r2)) / det.abs();
    if m != Mistake::ConditionIgnored && !condition_within(out.condition.value(), max_condition) {
        return out;
    }
    let y = V3::new(
        dot(r0.to_array(), b.to_array()),
        dot(r1.to_array(), b.to_array()),
        dot(r2.to_array(), b.to_array()),
    ) / det;
    let v = if m == Mistake::SolutionSign { y } else { -y };
    out.found = is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
    out.v = v;
    out
}

/// The kernel's body with mistake `m` (none: the twin, step for step).
fn mutated(m: Mistake, buffers: &Buffers, item: &EdgeItem) -> EdgeCost<F> {
    let q = mutated_quadric(m, buffers, item);
    let solution = mutated_solve(m, &q, buffers.max_condition);
    let (a, b) = (rest_at(buffers, item.a), rest_at(buffers, item.b));
    let mut fallbacks = vec![a, b, (a + b) * F::lit(0.5)];
    if m == Mistake::NoMidpoint {
        fallbacks.pop();
    }
    let (mut found, mut best, mut best_value, mut choice) =
        (solution.found, solution.v, F::lit(0.0), 0);
    if found {
        best_value = quadric_value(&q, best);
    }
    for (k, &point) in fallbacks.iter().enumerate() {
        let e = quadric_value(&q, point);
        if !found || e.decides_lt(best_value) {
            (found, best, best_value, choice) = (true, point, e, k as u32 + 1);
        }
    }
    let mut quadric = upper_triangle(&q);
    if m == Mistake::ColumnOrder {
        // (0,0), (0,1), (1,1), (0,2), (1,2), (2,2), (0,3), (1,3), (2,3), (3,3).
        quadric = [0, 1, 4, 2, 5, 7, 3, 6, 8, 9].map(|k| quadric[k]);
    }
    EdgeCost {
        quadric,
        condition: solution.condition,
        value: best_value,
        position: best,
        cost: mutated_energy(m, buffers, item, best),
        choice,
    }
}

macro_rules! body {
    ($m:expr) => {
        |buffers: &Buffers, item: &EdgeItem| mutated($m, buffers, item)
    };
}

const MUTANTS: [(&str, &str, Body); 9] = [
    (
        "transposed_product",
        "Q̃ = Σ_j A^j Q^j A^{jT}",
        body!(Mistake::TransposedProduct),
    ),
    (
        "one_endpoint",
        "Q^j = Q_a^j (Q_b^j forgotten)",
        body!(Mistake::OneEndpoint),
    ),
    (
        "joint_columns",
        "the joint matrix's 12 floats read column by column",
        body!(Mistake::JointColumns),
    ),
    ("solution_sign", "v = +B⁻¹ b", body!(Mistake::SolutionSign)),
    (
        "condition_ignored",
        "the solve kept whatever cond_F(B) (max_condition ignored)",
        body!(Mistake::ConditionIgnored),
    ),
    (
        "no_midpoint",
        "fallbacks a and b only",
        body!(Mistake::NoMidpoint),
    ),
    (
        "column_order",
        "Q̃'s upper triangle written column by column",
        body!(Mistake::ColumnOrder),
    ),
    (
        "first_bone_energy",
        "E with the first bone's matrix instead of the blend",
        body!(Mistake::FirstBoneEnergy),
    ),
    (
        "last_pose_dropped",
        "the pose loops stop at P − 1",
        body!(Mistake::LastPoseDropped),
    ),
];

#[test]
fn every_model_passes_every_mutant_fails_and_no_bound_is_zero() {
    let run = |model: Model, body: Option<Body>| match body {
        Some(body) => candidate_with(&dir(), &kernel(), model, body).unwrap(),
        None => candidate(&dir(), &kernel(), model).unwrap(),
    };
    MutationTable::judge_kernel(&dir(), &kernel(), run, &MUTANTS);
}

/// The mutants' harness with no mistake is the twin, bit for bit (so that each mutant differs
/// from the twin by its one mistake only).
#[test]
fn the_harness_without_a_mistake_is_the_twin() {
    let k = kernel();
    MutationTable::assert_bit_identical(
        &candidate(&dir(), &k, Model::Nearest).unwrap(),
        &candidate_with(&dir(), &k, Model::Nearest, body!(Mistake::None)).unwrap(),
    );
    let _ = skinsimp_collapse_cost::<F>;
}

/// The vectors cover the solve and each fallback (the manifest's `covers` says how often).
#[test]
fn the_vectors_cover_every_choice() {
    let k = kernel();
    for (choice, words) in [
        (0, "the solve kept"),
        (1, "fallback a:"),
        (2, "fallback b:"),
        (3, "fallback midpoint"),
    ] {
        let line = k
            .covers
            .iter()
            .find(|c| c.starts_with(words))
            .unwrap_or_else(|| panic!("no covers line for choice {choice}"));
        let count: usize = line
            .rsplit(": ")
            .next()
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap();
        // Several per choice, so that a mistake confined to one branch shows on more than one
        // element.
        assert!(
            count >= 5,
            "choice {choice}: only {count} candidates ({line})"
        );
    }
}
