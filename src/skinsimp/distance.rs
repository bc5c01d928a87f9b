//! Distance between two triangle surfaces in one pose: RMS and Hausdorff, sampled both ways
//! (SPEC.md § 10).
//!
//! **Sampling.** Each triangle of a surface is sampled at the 10 barycentric points
//! `(i, j, k)/3`, `i + j + k = 3` (corners, two points per edge, the centroid), each weighted by
//! `area/10`. For every sample, the exact distance to the nearest triangle of the other surface
//! (closest point on a triangle, Ericson §5.1.5), found through the bounding-volume tree
//! [`SurfaceTree`] of the other surface's triangles. One way: `ms_{A→B} = Σ w d² / Σ w`, `h_{A→B} = max d`. Reported:
//! `rms = √(½(ms_{A→B} + ms_{B→A}))`, `hausdorff = max(h_{A→B}, h_{B→A})` (the sampled
//! Hausdorff distance: a lower bound of the true one, exact at the samples).

use nalgebra::Point3;
use rayon::prelude::*;

use crate::mesh::distance::SurfaceTree;

/// RMS and (sampled) Hausdorff distance between two surfaces.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SurfaceError {
    pub rms: f64,
    pub hausdorff: f64,
}

/// The symmetric distance of the module docs between `(pa, fa)` and `(pb, fb)`.
pub fn surface_error(
    pa: &[Point3<f64>],
    fa: &[[u32; 3]],
    pb: &[Point3<f64>],
    fb: &[[u32; 3]],
) -> SurfaceError {
    let (ms_ab, h_ab) = one_way(pa, fa, pb, fb);
    let (ms_ba, h_ba) = one_way(pb, fb, pa, fa);
    SurfaceError {
        rms: (0.5 * (ms_ab + ms_ba)).sqrt(),
        hausdorff: h_ab.max(h_ba),
    }
}

/// `(Σ w d² / Σ w, max d)` over the samples of `(pa, fa)` against `(pb, fb)`.
fn one_way(pa: &[Point3<f64>], fa: &[[u32; 3]], pb: &[Point3<f64>], fb: &[[u32; 3]]) -> (f64, f64) {
    let tree = SurfaceTree::new(pb, fb);
    let per_face: Vec<(f64, f64, f64)> = fa
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| pa[v as usize]);
            let w = 0.5 * (b - a).cross(&(c - a)).norm() / 10.0;
            let mut sum = 0.0;
            let mut max: f64 = 0.0;
            for i in 0..=3 {
                for j in 0..=(3 - i) {
                    let k = 3 - i - j;
                    let p = Point3::from(
                        (a.coords * i as f64 + b.coords * j as f64 + c.coords * k as f64) / 3.0,
                    );
                    let d = tree.distance(&p);
                    sum += w * d * d;
                    max = max.max(d);
                }
            }
            (sum, 10.0 * w, max)
        })
        .collect();
    let (sum, weight, max) = per_face
        .iter()
        .fold((0.0, 0.0, 0.0f64), |(s, w, m), &(a, b, c)| {
            (s + a, w + b, m.max(c))
        });
    (if weight > 0.0 { sum / weight } else { 0.0 }, max)
}
