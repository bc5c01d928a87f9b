//! The BPM kernels' candidates from their twins ([`crate::twin::bpm_eval`],
//! [`crate::twin::bpm_precompute`]) over the vectors' inputs (read by
//! [`crate::vectors::bpm::twin_io`]): `bpm_eval` and `bpm_eval_linear`, the UV of every sample
//! ([samples, 2]), and `bpm_precompute`, every face's per-triangle data ([faces, 45]), as a
//! conforming GPU under a [`Model`] computes them.

use std::path::Path;

use crate::error::Result;
use crate::twin::bpm_common::{eval, Complex, TriangleMaps, INTERP_BPM, INTERP_LINEAR};
use crate::twin::bpm_precompute::{triangle_maps, StarInput, FIT_LOCAL};
use crate::twin::real::sum;
use crate::twin::{with_model, Model, Real, F, V3};
use crate::vectors::bpm::twin_io;
use crate::vectors::{Array, KernelVectors};

/// An evaluation of one sample at barycentrics b: the twin's kernel body or a port's.
pub type EvalFn = fn(&TriangleMaps<F>, V3<F>) -> Complex<F>;

/// A face's precompute from its star: the twin's or a port's.
pub type PrecomputeFn = fn(&StarInput<F>) -> TriangleMaps<F>;

/// The eval kernels' candidate (vectors in `dir`, entry `k`) with `body` per sample under
/// `model`: b = (1 − b₁ − b₂, b₁, b₂) as the kernel forms it; NaN where the face is out of range.
pub fn eval_with(dir: &Path, k: &KernelVectors, model: Model, body: EvalFn) -> Result<Array> {
    let maps = twin_io::maps(&k.load_input(dir, "maps")?, &k.load_input(dir, "flags")?)?;
    let samples = twin_io::samples(&k.load_input(dir, "face")?, &k.load_input(dir, "bary")?)?;
    let uv: Vec<Option<Complex<F>>> = samples
        .iter()
        .map(|s| {
            let t = maps.get(s.face as usize)?;
            let b = V3::new(sum(&[F::lit(1.0), -s.b[0], -s.b[1]]), s.b[0], s.b[1]);
            Some(with_model(model, || body(t, b)))
        })
        .collect();
    Ok(twin_io::uv_candidate(&uv))
}

/// The twin's BPM evaluation body.
pub fn eval_bpm(t: &TriangleMaps<F>, b: V3<F>) -> Complex<F> {
    eval(t, b, INTERP_BPM)
}

/// The twin's linear evaluation body.
pub fn eval_linear(t: &TriangleMaps<F>, b: V3<F>) -> Complex<F> {
    eval(t, b, INTERP_LINEAR)
}

/// `bpm_eval`'s candidate under `model`.
pub fn bpm_eval(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    eval_with(dir, k, model, eval_bpm)
}

/// `bpm_eval_linear`'s candidate under `model`.
pub fn bpm_eval_linear(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    eval_with(dir, k, model, eval_linear)
}

/// The twin's precompute body: [`triangle_maps`] with the local fit.
pub fn precompute_twin(star: &StarInput<F>) -> TriangleMaps<F> {
    triangle_maps(star, FIT_LOCAL)
}

/// `bpm_precompute`'s candidate with `body` per face under `model`.
pub fn precompute_with(
    dir: &Path,
    k: &KernelVectors,
    model: Model,
    body: PrecomputeFn,
) -> Result<Array> {
    let stars = twin_io::stars(
        &k.load_input(dir, "star_p")?,
        &k.load_input(dir, "star_w")?,
        &k.load_input(dir, "mask")?,
    )?;
    let maps: Vec<TriangleMaps<F>> = stars
        .iter()
        .map(|s| with_model(model, || body(s)))
        .collect();
    Ok(twin_io::maps_candidate(&maps))
}

/// `bpm_precompute`'s candidate under `model`.
pub fn bpm_precompute(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    precompute_with(dir, k, model, precompute_twin)
}
