//! # f32 CPU twins of the WGSL kernels
//!
//! One file per WGSL file (`src/twin/<shader>.rs` beside `gpu/shaders/<shader>.wgsl`), function
//! for function and operation for operation, written over a number type [`Real`] so that the
//! same lines serve three purposes:
//!
//! - over [`F`] (an f32 under an arithmetic [`Model`]: correctly rounded, fused multiply-adds,
//!   reordered sums, or every operation and builtin at the edge of the WGSL accuracy table),
//!   a twin *is* a conforming GPU: it shows that the bounds hold for every GPU the spec allows,
//!   not only for lavapipe's accurate CPU math;
//! - over [`Ball`] (f64 value and radius), a twin *derives* the bound: the radius of its output
//!   bounds the error of any conforming f32 evaluation, from the table and the magnitudes of
//!   that very element;
//! - over [`Lin`] (f64 values on a tape), a twin derives a bound correct to first order, with
//!   the cancellations a ball cannot see (a long kernel such as `bpm_precompute`, whose Möbius
//!   maps are defined up to a common scale).
//!
//! The twins also make the conformance vectors' mutants (`tests/mutants_bpm.rs`,
//! `tests/twin_skinsimp.rs`, `tests/twin_skinsimp_cost.rs`, `tests/twin_gridwarp.rs`,
//! `tests/twin_unwarp.rs`, `tests/twin_maps.rs`, `tests/twin_maps_inverse.rs`): a mutant is a
//! porting mistake (a term dropped, slots swapped, the wrong multiplication order, a branch
//! ignored) built from a twin's functions, and the canonical vectors must reject every one.
//!
//! | twin | WGSL | f64 reference |
//! |---|---|---|
//! | [`bpm_common`] | `bpm_common.wgsl` | `bpm::moebius`, `bpm::eval` |
//! | [`bpm_eval`] | `bpm_eval.wgsl` | [`crate::bpm::Bpm::eval`] |
//! | [`bpm_precompute`] | `bpm_precompute.wgsl` | [`crate::bpm::precompute()`] |
//! | [`bpm_render`] | `bpm_render.wgsl` (and the fixed-function stages) | [`crate::bpm::render::render_cpu`] |
//! | [`gridwarp_aa`] | `gridwarp_aa.wgsl`, `gridwarp_aa_residuals.wgsl`, `gridwarp_field.wgsl` | `gridwarp::plain::aa` |
//! | [`gridwarp_naa`] | `gridwarp_naa.wgsl`, `gridwarp_naa_residuals.wgsl` | `gridwarp::plain::naa` |
//! | [`gridwarp_lookup`] | `gridwarp_lookup.wgsl` | [`crate::gridwarp::AtlasRemap::lookup_uv`] |
//! | [`maps_flatten`] | `maps_flatten.wgsl` | [`crate::maps::flatten::flatten_ring`] |
//! | [`maps_inverse`] | `maps_inverse.wgsl` | [`crate::maps::Param::inverse`] |
//! | [`maps_priority`] | `maps_priority.wgsl`, `maps_rings.wgsl` | [`crate::maps::priority::ring_area`], [`crate::maps::priority::curvature`] |
//! | [`skinsimp_lbs`] | `skinsimp_lbs.wgsl` | [`crate::mesh::skin::skin_positions`] |
//! | [`skinsimp_quadrics`] | `skinsimp_quadrics.wgsl` | `skinsimp::quadric` (`Quadric::from_plane`, …) |
//! | [`skinsimp_collapse_cost`] | `skinsimp_collapse_cost.wgsl` | [`crate::skinsimp::gpu::position_given_weights_f64`] |
//! | [`unwarp_lookup`] | `unwarp_lookup.wgsl` | [`crate::unwarp::apply::lookup_coordinate`], [`crate::unwarp::apply::bake_colour`] |
//! | [`unwarp_pass`] | `unwarp_pass.wgsl` | [`crate::unwarp::pass::descend_texel`] |
//!
//! [`candidate`] runs a twin over its kernel's conformance-vector inputs (what `verify` judges).
#![doc = include_str!("README.md")]

pub mod ball;
pub mod bpm_common;
pub mod bpm_eval;
pub mod bpm_precompute;
pub mod bpm_render;
#[cfg(feature = "gpu")]
pub mod candidate;
pub mod coverage;
pub mod gridwarp_aa;
pub mod gridwarp_lookup;
pub mod gridwarp_naa;
pub mod lin;
pub mod maps_flatten;
pub mod maps_inverse;
pub mod maps_priority;
pub mod model;
pub mod real;
pub mod skinsimp_collapse_cost;
pub mod skinsimp_lbs;
pub mod skinsimp_quadrics;
pub mod unwarp_lookup;
pub mod unwarp_pass;

pub use ball::Ball;
pub use lin::Lin;
pub use model::{with_model, Model, F};
pub use real::{Real, V2, V3, V4};

/// What the number types' unit tests share: random inputs and the expressions they evaluate
/// over every `Real` (the same lines over `F`, `Ball` and `Lin`).
#[cfg(test)]
pub(crate) mod test_support {
    use super::real::{exp, length, sqrt, Real};

    /// `count` points of 4 coordinates in [−2, 2), from a fixed LCG seeded by `seed`.
    pub fn random_points(seed: u64, count: usize) -> Vec<[f64; 4]> {
        let mut state = seed;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..count)
            .map(|_| std::array::from_fn(|_| 4.0 * next() - 2.0))
            .collect()
    }

    /// (v₀ v₁ + v₂) / (v₃² + 1): products, a sum and a division.
    pub fn rational<R: Real>(v: &[R]) -> R {
        (v[0] * v[1] + v[2]) / (v[3] * v[3] + R::lit(1.0))
    }

    /// √(|(v₀, v₁, v₂)| + exp v₃): a dot product, roots and a builtin.
    pub fn root_of_length<R: Real>(v: &[R]) -> R {
        sqrt(length([v[0], v[1], v[2]]) + exp(v[3]))
    }
}
