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
pub fn stretch_fields(
    size: usize,
    partials: impl Fn(f64, f64) -> (Vector3<f64>, Vector3<f64>),
) -> (Field, Field) {
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
    let (o_s, o_t) = stretch_fields(size, plane_partials);
    RestFields { o_s, o_t, rigidity }
}

/// D = (σ s, t, 0): a uniform stretch by σ along s.
pub fn uniform_stretch(size: usize, sigma: f64) -> DeformedFields {
    let (d_s, d_t) = stretch_fields(size, move |_, _| (Vector3::x() * sigma, Vector3::y()));
    DeformedFields { d_s, d_t }
}

/// The paper's "fixed-plane stretch" (fig. 9 family): the left part of the plane stays fixed, the
/// right part is pulled, D_s = 1 + (σ − 1)·smoothstep(s) with the stretch concentrated on the
/// right; `frames` frames ramp σ from 1 to `sigma_max`.
pub fn plane_stretch(size: usize, frames: usize, sigma_max: f64, rigidity: Field) -> Scene {
    let frames = (1..=frames.max(1))
        .map(|k| {
            let sigma = 1.0 + (sigma_max - 1.0) * k as f64 / frames.max(1) as f64;
            let (d_s, d_t) = stretch_fields(size, move |s: f64, _| {
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

/// A surface X(s, t) of the ROI, as a point function.
pub type SurfaceFn = dyn Fn(f64, f64) -> nalgebra::Point3<f64> + Sync;

/// Central-difference partials of a point function, step 1e-5: truncation O(h²·X''') ≈ 1e-10 and
/// rounding O(ε/h) ≈ 1e-11 for these O(1) surfaces, far below what the fields resolve.
pub fn partials_of(surface: &SurfaceFn, s: f64, t: f64) -> (Vector3<f64>, Vector3<f64>) {
    const H: f64 = 1e-5;
    (
        (surface(s + H, t) - surface(s - H, t)) / (2.0 * H),
        (surface(s, t + H) - surface(s, t - H)) / (2.0 * H),
    )
}

/// A built-in scene with its surfaces: the rest surface, one surface per frame, the rigidity.
pub struct AnalyticScene {
    pub name: &'static str,
    pub rest: Box<SurfaceFn>,
    pub frames: Vec<Box<SurfaceFn>>,
    pub rigidity: Field,
}

impl AnalyticScene {
    /// Sample the scene's fields on `size`×`size` texels.
    pub fn fields(&self, size: usize) -> Scene {
        let (o_s, o_t) = stretch_fields(size, |s, t| partials_of(&*self.rest, s, t));
        let frames = self
            .frames
            .iter()
            .map(|x| {
                let (d_s, d_t) = stretch_fields(size, |s, t| partials_of(&**x, s, t));
                DeformedFields { d_s, d_t }
            })
            .collect();
        Scene {
            name: self.name.into(),
            rest: RestFields {
                o_s,
                o_t,
                rigidity: self.rigidity.clone(),
            },
            frames,
        }
    }
}

/// Names accepted by [`analytic_scene`].
pub const SCENES: [&str; 4] = ["bump", "saddle", "worm", "plane"];

/// The paper's scenes rebuilt procedurally (the mocap data is not public, notes "Anchors"):
///
/// - `bump`: a plane whose middle bulges up, X = (s, t, A·exp(−|(s,t) − c|²/w²)), A growing to
///   0.35 over the frames; rigid discs sit on the bulge's flanks (figure 3's creased bump plane);
/// - `saddle`: X = (s, t, κ (s − ½)(t − ½)), κ growing to 3 (the paper's saddle);
/// - `worm`: a tube of radius r around which t wraps, bent with curvature growing to 3: the
///   outer side stretches by 1 + κ r cos θ (the paper's worm);
/// - `plane`: the fixed-plane stretch of [`plane_stretch`] as a surface: the left edge fixed, the
///   right part pulled to twice its length.
pub fn analytic_scene(name: &str, frames: usize) -> Option<AnalyticScene> {
    use nalgebra::Point3;
    use std::f64::consts::TAU;
    let frames = frames.max(1);
    let ramp = move |k: usize| (k + 1) as f64 / frames as f64;
    let surfaces =
        |f: &dyn Fn(f64) -> Box<SurfaceFn>| (0..frames).map(|k| f(ramp(k))).collect::<Vec<_>>();
    Some(match name {
        "bump" => AnalyticScene {
            name: "bump",
            rest: Box::new(|s, t| Point3::new(s, t, 0.0)),
            frames: surfaces(&|a| {
                Box::new(move |s, t| {
                    let r2 = (s - 0.5).powi(2) + (t - 0.5).powi(2);
                    Point3::new(s, t, 0.35 * a * (-r2 / 0.04).exp())
                })
            }),
            rigidity: disc_rigidity(
                128,
                &[(0.35, 0.5, 0.08), (0.65, 0.5, 0.08), (0.5, 0.28, 0.07)],
                0.1,
            ),
        },
        "saddle" => AnalyticScene {
            name: "saddle",
            rest: Box::new(|s, t| Point3::new(s, t, 0.0)),
            frames: surfaces(&|a| {
                Box::new(move |s, t| Point3::new(s, t, 3.0 * a * (s - 0.5) * (t - 0.5)))
            }),
            rigidity: disc_rigidity(
                128,
                &[(0.2, 0.2, 0.1), (0.8, 0.8, 0.1), (0.5, 0.5, 0.1)],
                0.1,
            ),
        },
        "worm" => {
            let radius = 0.08;
            let tube = move |kappa: f64| -> Box<SurfaceFn> {
                Box::new(move |s: f64, t: f64| {
                    // Centre line: an arc of curvature κ (straight for κ = 0), length 1.
                    let theta = TAU * t;
                    let (n, b) = (theta.cos(), theta.sin());
                    if kappa == 0.0 {
                        return Point3::new(s, radius * n, radius * b);
                    }
                    let phi = kappa * s;
                    let centre = Point3::new(phi.sin() / kappa, (1.0 - phi.cos()) / kappa, 0.0);
                    let normal = Vector3::new(-phi.sin(), phi.cos(), 0.0);
                    centre - normal * (radius * n) + Vector3::z() * (radius * b)
                })
            };
            AnalyticScene {
                name: "worm",
                rest: tube(0.0),
                frames: surfaces(&|a| tube(3.0 * a)),
                rigidity: disc_rigidity(128, &[(0.3, 0.5, 0.1), (0.7, 0.5, 0.1)], 0.1),
            }
        }
        "plane" => AnalyticScene {
            name: "plane",
            rest: Box::new(|s, t| Point3::new(s, t, 0.0)),
            frames: surfaces(&|a| {
                Box::new(move |s, t| {
                    // ∫ 1 + (σ − 1)·smoothstep: x(s) = s + (σ − 1)(s³ − s⁴/2), σ = 1 + a.
                    Point3::new(s + a * (s.powi(3) - 0.5 * s.powi(4)), t, 0.0)
                })
            }),
            rigidity: disc_rigidity(128, &[(0.7, 0.5, 0.12), (0.25, 0.3, 0.1)], 0.1),
        },
        _ => return None,
    })
}
