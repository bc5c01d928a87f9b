//! The BPM kernels under every arithmetic model a conforming GPU may use: their f32 twins run
//! as a GPU with fused multiply-adds, reordered sums, or every operation and builtin at the
//! edge of the WGSL accuracy table would ([`Model`]), and each result is judged by the bound
//! of [`super::bpm_bound`]. A worst ratio ≤ 1 under every model says the bound holds on any
//! conforming GPU, not only on the adapter at hand; `crosscheck --sweep` shows the table and
//! plot, and `tests/twin_bpm.rs` asserts it on six meshes.

use num_complex::Complex64 as C;
use rayon::prelude::*;

use super::bpm::{crosscheck_samples, round_mesh_to_f32, TEXTURE_SIZE};
use super::bpm_bound::{ball_maps, ball_star, complex, eval_bounds, interp_code, pipeline_bounds};
use crate::bpm::gpu::stars;
use crate::bpm::{precompute, BpmOptions, Interp, Sample};
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::twin::bpm_common::TriangleMaps;
use crate::twin::bpm_eval::{bpm_eval, Sample as TwinSample};
use crate::twin::bpm_precompute::{triangle_maps, StarInput, FIT_LOCAL};
use crate::twin::{with_model, Ball, Model, Real, F, V2, V3};

/// Worst error / bound of the BPM twins under one model on one mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelRatios {
    pub model: Model,
    /// `bpm_eval` (BPM) on the reference's maps rounded to f32.
    pub eval_bpm: f64,
    /// `bpm_eval` (linear).
    pub eval_linear: f64,
    /// `bpm_precompute` (local fit) → `bpm_eval` from the f32 mesh.
    pub pipeline: f64,
    /// Samples over their bound, over the three.
    pub over: usize,
}

/// What the GPU receives for a ball: its value rounded to f32.
fn f32_of<R: Real>(x: R) -> F {
    F::new(x.value() as f32)
}

/// The per-triangle data as the GPU receives it (f32).
pub fn f32_maps(t: &TriangleMaps<Ball>) -> TriangleMaps<F> {
    TriangleMaps::from_values(&t.values().map(f32_of), t.flags)
}

/// The star as the GPU receives it (f32).
pub fn f32_star(s: &StarInput<Ball>) -> StarInput<F> {
    StarInput {
        p: s.p.map(|p| V3::new(f32_of(p.x), f32_of(p.y), f32_of(p.z))),
        w: s.w.map(|w| V2::new(f32_of(w.x), f32_of(w.y))),
        mask: s.mask,
    }
}

/// The sample as the GPU receives it (b_j, b_k in f32).
pub fn f32_sample(s: &Sample) -> TwinSample<F> {
    TwinSample {
        face: 0,
        b: [F::new(s.bary[1] as f32), F::new(s.bary[2] as f32)],
    }
}

/// Texels between a twin's UV and the reference's.
fn texels(uv: V2<F>, reference: C) -> f64 {
    (complex(uv) - reference).norm() * TEXTURE_SIZE
}

/// The worst ratio and the count over 1 of `errors` against `bounds`.
fn judge(errors: &[f64], bounds: &[f64]) -> (f64, usize) {
    errors
        .iter()
        .zip(bounds)
        .fold((0.0f64, 0), |(worst, over), (e, b)| {
            let ratio = e / b;
            (worst.max(ratio), over + usize::from(!(ratio <= 1.0)))
        })
}

/// The BPM twins under `model` on `mesh` (rounded to f32 first), at the cross-check's samples,
/// against the derived bounds.
pub fn bpm_model_ratios(mesh: &TriMesh, model: Model) -> Result<ModelRatios> {
    let mesh = round_mesh_to_f32(mesh);
    let reference = precompute(&mesh, BpmOptions::default())?;
    let samples = crosscheck_samples(mesh.face_count());
    let maps: Vec<TriangleMaps<F>> = reference
        .maps
        .iter()
        .map(|t| f32_maps(&ball_maps(t)))
        .collect();
    let eval = |interp: Interp| -> (f64, usize) {
        let expected = reference.eval_many(&samples, interp);
        let bounds = eval_bounds(&reference, &samples, interp, &expected);
        let errors: Vec<f64> = samples
            .par_iter()
            .zip(&expected)
            .map(|(s, &f)| {
                let t = [maps[s.face as usize]];
                with_model(model, || bpm_eval(&t, &f32_sample(s), interp_code(interp)))
                    .map_or(f64::INFINITY, |uv| texels(uv, f))
            })
            .collect();
        judge(&errors, &bounds)
    };
    let (eval_bpm, over_bpm) = eval(Interp::Bpm);
    let (eval_linear, over_linear) = eval(Interp::Linear);

    let stars = stars(&mesh)?;
    let expected = reference.eval_many(&samples, Interp::Bpm);
    let bounds = pipeline_bounds(&stars, &samples, &expected);
    let twin_maps: Vec<TriangleMaps<F>> = stars
        .par_iter()
        .map(|s| {
            let star = f32_star(&ball_star(s));
            with_model(model, || triangle_maps(&star, FIT_LOCAL))
        })
        .collect();
    let errors: Vec<f64> = samples
        .par_iter()
        .zip(&expected)
        .map(|(s, &f)| {
            let t = [twin_maps[s.face as usize]];
            with_model(model, || {
                bpm_eval(&t, &f32_sample(s), interp_code(Interp::Bpm))
            })
            .map_or(f64::INFINITY, |uv| texels(uv, f))
        })
        .collect();
    let (pipeline, over_pipeline) = judge(&errors, &bounds);
    Ok(ModelRatios {
        model,
        eval_bpm,
        eval_linear,
        pipeline,
        over: over_bpm + over_linear + over_pipeline,
    })
}
