//! The BPM kernels' bounds, per sample, derived by running their f32 twins over [`Ball`] or
//! [`Lin`] (the WGSL accuracy table, operation by operation, at this sample's magnitudes): written once
//! here and used by `crosscheck bpm`, the conformance vectors' manifests and the tests.
//!
//! **`bpm_eval`** receives the reference's per-triangle data rounded to f32: each of its 44
//! values enters as a ball around the f64 value with the rounding as radius, the barycentrics
//! exactly (the reference is evaluated at the f32 barycentrics). The bound of a sample is
//!
//!   4096 · (‖r(f)‖₂ + |v(f) − f_ref|)
//!
//! texels, r(f) the radii of the two UV components of the twin's output, v(f) its f64 value:
//! the second term is the f32 formulation's own departure from the reference's formula (six
//! series terms where the reference sums ten), evaluated, not assumed.
//!
//! **`bpm_precompute` → `bpm_eval`** (the local-fit pipeline): the star enters rounded to f32,
//! the precompute twin and then the eval twin run over [`Lin`] on one tape, and the bound is
//!
//!   4096 · (2 · Σᵢ ‖∂f/∂eᵢ‖ aᵢ + |v(f) − f_ref|)
//!
//! texels: aᵢ the WGSL table's allowance of operation i, ∂f/∂eᵢ the derivative of the UV with
//! respect to a perturbation there, the factor 2 for the neglected second-order terms
//! ([`crate::twin::lin`] says why balls are too loose here: the Möbius maps' projective gauge,
//! and when first order is trusted). The same bound judges a precompute candidate (`verify`
//! evaluates its maps in f64: the eval's roundings then only make the bound a little larger
//! than needed).
//!
//! Where the table promises nothing (a divisor within its radius of 0: a pole of a Möbius map
//! at the sample; a sign fix or a mirroring decided within rounding; for the pipeline, any
//! check of the first-order analysis that fails) the bound is
//! [`UNBOUNDED`], counted in the rows' notes.

use num_complex::Complex64 as C;
use rayon::prelude::*;

use crate::bpm::gpu::{sample_as_gpu_sees_it, triangle_flags, triangle_values};
use crate::bpm::precompute::{Star, TriangleMaps};
use crate::bpm::{face_samples, Bpm, Interp, Sample};
use crate::twin::ball::{evaluate, Ball};
use crate::twin::bpm_common as common;
use crate::twin::bpm_eval::{bpm_eval, Sample as TwinSample};
use crate::twin::bpm_precompute::{triangle_maps, StarInput, FIT_LOCAL, MASK_DEGENERATE};
use crate::twin::lin::{self, Lin, SECOND_ORDER};
use crate::twin::{Real, V2, V3};

/// BPM's UV errors are measured in texels of a texture this wide (4096²).
pub const TEXTURE_SIZE: f64 = 4096.0;

/// The bound of an element where the WGSL accuracy table gives none (JSON has no ∞).
pub const UNBOUNDED: f64 = f64::MAX;

pub use crate::twin::bpm_common::interp_code;

/// The twin's per-triangle data of a reference face: balls around its 44 f64 values with their
/// f32 rounding as radii.
pub fn ball_maps(t: &TriangleMaps) -> common::TriangleMaps<Ball> {
    let values = triangle_values(t).map(|x| Ball::input(x, x as f32));
    common::TriangleMaps::from_values(&values, triangle_flags(t))
}

/// The twin's star of a reference face over [`Ball`], each point a ball around it with its f32
/// rounding (0 when the mesh is already f32).
pub fn ball_star(star: &Star) -> StarInput<Ball> {
    star_input(star, |x| Ball::input(x, x as f32))
}

/// The twin's star of a reference face, each coordinate made by `number`.
fn star_input<R: Real>(star: &Star, number: impl Fn(f64) -> R) -> StarInput<R> {
    let mut mask = u32::from(star.degenerate) * MASK_DEGENERATE;
    for e in 0..3 {
        mask |= u32::from(star.neighbour[e]) << e;
    }
    StarInput {
        p: star
            .p
            .map(|p| V3::new(number(p.x), number(p.y), number(p.z))),
        w: star.w.map(|w| V2::new(number(w.re), number(w.im))),
        mask,
    }
}

/// The twin's sample: b_j, b_k exactly as the GPU receives them (f32).
fn ball_sample(s: &Sample) -> TwinSample<Ball> {
    TwinSample {
        face: 0,
        b: [
            Ball::exact(f64::from(s.bary[1] as f32)),
            Ball::exact(f64::from(s.bary[2] as f32)),
        ],
    }
}

/// A sample's bound in texels from the twin's output balls and the reference's value.
fn texel_bound(uv: V2<Ball>, reference: C, ambiguous: bool) -> f64 {
    let radius = uv.x.r.hypot(uv.y.r);
    let formulation = (C::new(uv.x.v, uv.y.v) - reference).norm();
    let bound = TEXTURE_SIZE * (radius + formulation);
    if ambiguous || !bound.is_finite() {
        UNBOUNDED
    } else {
        bound
    }
}

/// [`INTERIOR_POINTS`](crate::bpm::INTERIOR_POINTS) and the three corners of every face, with
/// b_j, b_k rounded to f32.
pub fn crosscheck_samples(faces: usize) -> Vec<Sample> {
    face_samples(faces, true)
        .iter()
        .map(sample_as_gpu_sees_it)
        .collect()
}

/// Per sample, the bound (texels) of `bpm_eval` on the reference's maps rounded to f32, against
/// the reference's values `expected` at the same samples.
pub fn eval_bounds(
    reference: &Bpm,
    samples: &[Sample],
    interp: Interp,
    expected: &[C],
) -> Vec<f64> {
    let code = interp_code(interp);
    samples
        .par_iter()
        .zip(expected)
        .map(|(s, &f)| {
            let maps = [ball_maps(&reference.maps[s.face as usize])];
            let (uv, ambiguous) = evaluate(|| bpm_eval(&maps, &ball_sample(s), code));
            uv.map_or(UNBOUNDED, |uv| texel_bound(uv, f, ambiguous))
        })
        .collect()
}

/// Per sample, the bound (texels) of the local-fit pipeline `bpm_precompute` → `bpm_eval` on
/// `stars` (the reference's, one per face), against the reference's values `expected`: the
/// twins over [`Lin`] on one tape per face (the precompute recorded once, each sample's eval
/// after it), [`SECOND_ORDER`] × the first-order bound of the UV (module docs of
/// [`crate::twin::lin`]).
pub fn pipeline_bounds(stars: &[Star], samples: &[Sample], expected: &[C]) -> Vec<f64> {
    pipeline_bounds_for(stars, samples, Interp::Bpm, expected)
}

/// [`pipeline_bounds`] with the eval in `interp` mode (the render draws either).
pub fn pipeline_bounds_for(
    stars: &[Star],
    samples: &[Sample],
    interp: Interp,
    expected: &[C],
) -> Vec<f64> {
    let code = interp_code(interp);
    let mut by_face: Vec<Vec<usize>> = vec![Vec::new(); stars.len()];
    for (n, s) in samples.iter().enumerate() {
        by_face[s.face as usize].push(n);
    }
    let per_face: Vec<Vec<(usize, f64)>> = stars
        .par_iter()
        .zip(&by_face)
        .map(|(star, indices)| face_pipeline_bounds(star, indices, samples, code, expected))
        .collect();
    let mut bounds = vec![UNBOUNDED; samples.len()];
    for (n, bound) in per_face.into_iter().flatten() {
        bounds[n] = bound;
    }
    bounds
}

/// The pipeline bounds of the samples `indices` of one face (see [`pipeline_bounds`]).
fn face_pipeline_bounds(
    star: &Star,
    indices: &[usize],
    samples: &[Sample],
    interp: u32,
    expected: &[C],
) -> Vec<(usize, f64)> {
    let ((maps, prefix), ambiguous) = lin::record(|| {
        let input = star_input(star, |x| Lin::input(x, x as f32));
        let maps = triangle_maps(&input, FIT_LOCAL);
        (maps, lin::mark())
    });
    // A degenerate face is evaluated linearly from its UVs: its mirroring decision, however
    // close, does not reach the output.
    let face_ambiguous = ambiguous && !star.degenerate;
    indices
        .iter()
        .map(|&n| {
            let s = &samples[n];
            let (uv, ambiguous) = lin::record_after(prefix, || {
                let sample = TwinSample {
                    face: 0,
                    b: [
                        Lin::exact(f64::from(s.bary[1] as f32)),
                        Lin::exact(f64::from(s.bary[2] as f32)),
                    ],
                };
                let uv = bpm_eval(&[maps], &sample, interp)?;
                let radius = SECOND_ORDER * lin::first_order_bound2(uv.x, uv.y);
                Some((C::new(uv.x.v, uv.y.v), radius))
            });
            let bound = uv.map_or(f64::INFINITY, |(uv, radius)| {
                TEXTURE_SIZE * (radius + (uv - expected[n]).norm())
            });
            let bound = if ambiguous || face_ambiguous || !bound.is_finite() {
                UNBOUNDED
            } else {
                bound
            };
            (n, bound)
        })
        .collect()
}

/// How many of `bounds` are [`UNBOUNDED`].
pub fn unbounded(bounds: &[f64]) -> usize {
    bounds.iter().filter(|&&b| b == UNBOUNDED).count()
}

/// The value of a twin output over any [`Real`], as a complex number.
pub fn complex<R: Real>(uv: V2<R>) -> C {
    C::new(uv.x.value(), uv.y.value())
}
