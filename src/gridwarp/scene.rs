//! Procedural scenes with analytic surfaces: the rest surface O(s, t), the deformed surfaces
//! D(s, t) of each frame, and a rigidity map, turned into the fields the energy reads.
//!
//! A surface is given by its two partial derivatives (∂X/∂s, ∂X/∂t) as functions of (s, t); the
//! fields store their lengths at texel centres.

use nalgebra::Vector3;

use super::energy::{DeformedFields, RestFields};
use super::field::Field;

/// A surface through its partial derivatives (∂X/∂s, ∂X/∂t) at (s, t).
pub type Partials = dyn Fn(f64, f64) -> (Vector3<f64>, Vector3<f64>) + Sync;

/// ‖∂X/∂s‖ and ‖∂X/∂t‖ sampled on a `size`×`size` field.
pub fn stretch_fields(size: usize, partials: &Partials) -> (Field, Field) {
    (
        Field::from_fn(size, size, |s, t| partials(s, t).0.norm()),
        Field::from_fn(size, size, |s, t| partials(s, t).1.norm()),
    )
}

/// The flat unit square X = (s, t, 0).
pub fn plane_partials(_: f64, _: f64) -> (Vector3<f64>, Vector3<f64>) {
    (Vector3::x(), Vector3::y())
}

/// A built-in scene: rest fields and the deformed fields of each frame.
pub struct Scene {
    pub name: String,
    pub rest: RestFields,
    pub frames: Vec<DeformedFields>,
}

/// The rest pose: the plane, with rigidity `rigidity`.
pub fn flat_rest(size: usize, rigidity: Field) -> RestFields {
    let (o_s, o_t) = stretch_fields(size, &plane_partials);
    RestFields { o_s, o_t, rigidity }
}

/// D = (σ s, t, 0): a uniform stretch by σ along s.
pub fn uniform_stretch(size: usize, sigma: f64) -> DeformedFields {
    let (d_s, d_t) = stretch_fields(size, &move |_, _| (Vector3::x() * sigma, Vector3::y()));
    DeformedFields { d_s, d_t }
}

/// The paper's "fixed-plane stretch" (fig. 9 family): the left part of the plane stays fixed, the
/// right part is pulled, D_s = 1 + (σ − 1)·smoothstep(s) with the stretch concentrated on the
/// right; `frames` frames ramp σ from 1 to `sigma_max`.
pub fn plane_stretch(size: usize, frames: usize, sigma_max: f64, rigidity: Field) -> Scene {
    let frames = (1..=frames.max(1))
        .map(|k| {
            let sigma = 1.0 + (sigma_max - 1.0) * k as f64 / frames.max(1) as f64;
            let (d_s, d_t) = stretch_fields(size, &move |s: f64, _| {
                let ramp = (3.0 * s * s - 2.0 * s * s * s).clamp(0.0, 1.0);
                (Vector3::x() * (1.0 + (sigma - 1.0) * ramp), Vector3::y())
            });
            DeformedFields { d_s, d_t }
        })
        .collect();
    Scene {
        name: "plane".into(),
        rest: flat_rest(size, rigidity),
        frames,
    }
}

/// A rigidity map of disc-shaped rigid features (value 1 inside the discs, `background`
/// outside): the "bumps" of the paper's figure 3, at (centre s, centre t, radius).
pub fn disc_rigidity(size: usize, discs: &[(f64, f64, f64)], background: f64) -> Field {
    Field::from_fn(size, size, |s, t| {
        if discs
            .iter()
            .any(|&(cs, ct, r)| (s - cs).powi(2) + (t - ct).powi(2) <= r * r)
        {
            1.0
        } else {
            background
        }
    })
}
