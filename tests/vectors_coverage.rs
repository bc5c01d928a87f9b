//! Branch coverage of the canonical conformance vectors (issue #51): every kernel whose f32 twin
//! reports its decisions ([`reparam::twin::coverage`]) is run over its canonical inputs
//! (`reference_data/vectors/<algorithm>`) with counting on, and every branch of its catalogue
//! must be taken by at least one invocation, or be listed in [`NOT_REACHED`] with the reason.
//! A listed branch that the vectors now reach fails too, so that the list stays true. The
//! printed table (kernel, branch, invocations) is the coverage the conformance guide quotes.
#![cfg(feature = "gpu")]

mod common;

use reparam::twin::candidate::{branches, runner};
use reparam::twin::coverage::count;
use reparam::twin::Model;
use reparam::vectors::read_manifest;

/// The branches the canonical vectors do not reach yet, `(kernel, branch, why)`, as measured by
/// this test: each is a porting mistake the vectors cannot see, and a case still to add to the
/// canonical inputs (issue #51); none is claimed unreachable.
const NOT_REACHED: &[(&str, &str, &str)] = &[
    (
        "unwarp_pass",
        "unwarp_pass.theta.pow",
        "the canonical θ is the integer default",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.theta.negative",
        "the canonical θ is positive",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.triangle.folded",
        "no start or search point folds a triangle (a ≤ 0)",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.pin.outside",
        "no search point leaves the pin ellipse (q ≥ 1)",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.gradient.not_finite",
        "no start has a folded triangle",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.gradient.zero",
        "no texel starts at a stationary point",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.bracket.lo_by_folded",
        "no start has a folded triangle (the bracket's `else lo = max(lo, t0)`)",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.bracket.empty",
        "every texel has a bracket",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.search.converged",
        "every search runs its 31 iterations",
    ),
    (
        "unwarp_pass",
        "unwarp_pass.guard.refused",
        "the guard never refuses a step",
    ),
    (
        "maps_priority",
        "maps_priority.normal.degenerate",
        "no ring has |N| = 0 or K < 3",
    ),
    (
        "maps_priority",
        "maps_priority.scale.zero",
        "no ring has all its vertices on its centre",
    ),
    (
        "maps_priority",
        "maps_priority.fit.singular",
        "no ring's fit matrix is singular",
    ),
    (
        "maps_priority",
        "maps_priority.kappa.not_finite",
        "no ring's κ overflows",
    ),
    (
        "maps_flatten.points",
        "maps_flatten.angle.near_pi",
        "no sector near π (an acos-based angle passes)",
    ),
    (
        "maps_flatten.points",
        "maps_flatten.sectors.too_wide",
        "no ring with a scaled sector a·φ ≥ π on a side of several sectors",
    ),
    (
        "maps_flatten.points",
        "maps_flatten.mu.not_finite",
        "no sane ring whose μ overflows",
    ),
    (
        "maps_flatten.rings",
        "maps_flatten.angle.near_pi",
        "no sector near π (an acos-based angle passes)",
    ),
    (
        "maps_flatten.rings",
        "maps_flatten.sectors.too_wide",
        "no ring with a scaled sector a·φ ≥ π on a side of several sectors",
    ),
    (
        "maps_flatten.rings",
        "maps_flatten.mu.not_finite",
        "no sane ring whose μ overflows",
    ),
    (
        "maps_inverse",
        "maps_inverse.walk.exhausted",
        "every walk of the canonical tables ends (only a cyclic table exhausts it)",
    ),
    (
        "maps_inverse",
        "maps_inverse.barycentric.area_norm",
        "no query whose three orientations sum to exactly 0",
    ),
    (
        "skinsimp_quadrics.source",
        "skinsimp_quadrics.triangle.degenerate",
        "the tube has no zero-area face",
    ),
    (
        "skinsimp_quadrics.source",
        "skinsimp_quadrics.normal.degenerate",
        "the tube has no zero-area boundary face",
    ),
    (
        "skinsimp_quadrics.source",
        "skinsimp_quadrics.constraint.degenerate",
        "no boundary edge of zero length",
    ),
    (
        "skinsimp_quadrics.vertex",
        "skinsimp_quadrics.vertex.none",
        "every tube vertex has faces",
    ),
    (
        "skinsimp_collapse_cost",
        "skinsimp_collapse_cost.solve.singular",
        "no edge's B has det exactly 0 in f32",
    ),
    (
        "skinsimp_collapse_cost",
        "skinsimp_collapse_cost.solve.not_finite",
        "no solve overflows",
    ),
];

#[test]
fn every_branch_is_reached_by_the_canonical_vectors_or_listed() {
    let mut table = vec![
        "| kernel | branch | invocations |".to_string(),
        "|---|---|---|".to_string(),
    ];
    let mut wrong = Vec::new();
    for algorithm in ["unwarp", "maps", "skinsimp"] {
        let dir = common::canonical::dir(algorithm);
        for k in read_manifest(&dir).unwrap().kernels {
            let (Some(run), Some(catalogue)) = (runner(&k.name), branches(&k.name)) else {
                continue;
            };
            let (out, counts) = count(|| run(&dir, &k, Model::Nearest));
            out.unwrap();
            for b in catalogue {
                let n = counts.of(b.name);
                let listed = NOT_REACHED
                    .iter()
                    .any(|(kernel, branch, _)| *kernel == k.name && *branch == b.name);
                table.push(format!(
                    "| {} | `{}` | {n} of {} |",
                    k.name, b.name, counts.invocations
                ));
                if n == 0 && !listed {
                    wrong.push(format!(
                        "{}: {} ({}) is never taken",
                        k.name, b.name, b.meaning
                    ));
                }
                if n > 0 && listed {
                    wrong.push(format!(
                        "{}: {} is listed but taken {n} times",
                        k.name, b.name
                    ));
                }
            }
        }
    }
    let table = table.join("\n");
    println!("{table}");
    assert!(wrong.is_empty(), "{}\n{table}", wrong.join("\n"));
}
