//! Remesh quality beside the Hausdorff distance (issue #23): how far the remesh lies from the
//! input on average, how much of its area faces the wrong way, and how thin its triangles are.
//! The distance figures come from [`crate::mesh::distance::compare_surfaces`] (a BVH from the
//! parry3d crate); this file adds the angle distribution and the figures relative to the
//! input's bounding-box diagonal.

use nalgebra::Point3;

use super::distortion::input_area_spread;
use crate::mesh::distance::{compare_surfaces_per_face, FaceComparison, SurfaceComparison};

/// Issue #23's target for a faithful remesh: two-sided Hausdorff distance at most 1.5% of the
/// bounding-box diagonal.
pub const FAITHFUL_HAUSDORFF: f64 = 0.015;

/// Issue #23's target for a faithful remesh: mean distance at most 0.1% of the diagonal.
pub const FAITHFUL_MEAN: f64 = 0.001;

/// The largest coordinate magnitude a mesh may have for its remeshes' distance figures:
/// 2²⁰⁰. A coordinate difference is at most 2·2²⁰⁰·√3 < 2²⁰²; the figures go up to degree four
/// in such differences (the closest point on a triangle solves with determinants of dot
/// products, d₀₀d₁₁ − d₀₁², below 2⁸⁰⁸ · 2) and sum degree-three terms (a distance times a
/// triangle area, for the area-weighted mean, below 2⁶⁰⁶) over at most 2⁶⁰ samples: everything
/// stays far below f64's overflow at 2¹⁰²⁴. A wavy grid with one z of 1e307 (found by the
/// remesh fuzzer) gave a NaN Hausdorff distance.
pub const DISTANCE_COORDINATE_MAX: f64 = 1.606_938_044_258_990_3e60; // 2^200

/// Refuse a mesh whose remeshes' distance figures would overflow
/// ([`crate::Error::OutOfDistanceRange`], naming the first vertex beyond ±[`DISTANCE_COORDINATE_MAX`]).
pub fn check_distance_range(mesh: &str, positions: &[Point3<f64>]) -> crate::Result<()> {
    match crate::mesh::first_beyond(positions, DISTANCE_COORDINATE_MAX) {
        Some((vertex, value)) => Err(crate::Error::OutOfDistanceRange {
            mesh: mesh.to_string(),
            vertex,
            value,
            limit: DISTANCE_COORDINATE_MAX,
        }),
        None => Ok(()),
    }
}

/// Upper ends (degrees) of the bins of [`AngleStats::histogram`]: [0, 10), [10, 20), [20, 30),
/// [30, 40), [40, 50), [50, 60]. The smallest angle of a triangle is at most 60°.
pub const ANGLE_BINS_DEG: [f64; 6] = [10.0, 20.0, 30.0, 40.0, 50.0, 60.0];

/// The distribution over the faces of a mesh of each face's smallest angle.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct AngleStats {
    /// The smallest angle of any face, degrees (0 for a degenerate face).
    pub min_deg: f64,
    /// Mean over faces of the smallest angle, degrees.
    pub mean_deg: f64,
    /// Fraction of faces whose smallest angle is below 10°.
    pub below_10: f64,
    /// Face counts per bin of [`ANGLE_BINS_DEG`].
    pub histogram: [usize; 6],
}

/// The smallest angle of triangle (a, b, c) in degrees: min over corners of
/// atan2(|u × v|, u · v), u and v the corner's two edge vectors (exact near 0 and 180°, unlike
/// acos). 0 for a degenerate triangle.
pub fn smallest_angle_deg(a: &Point3<f64>, b: &Point3<f64>, c: &Point3<f64>) -> f64 {
    let corner = |p: &Point3<f64>, q: &Point3<f64>, r: &Point3<f64>| {
        let (u, v) = (q - p, r - p);
        u.cross(&v).norm().atan2(u.dot(&v))
    };
    let m = corner(a, b, c).min(corner(b, c, a)).min(corner(c, a, b));
    if m.is_finite() {
        m.to_degrees()
    } else {
        0.0
    }
}

/// [`AngleStats`] of the faces of a mesh (all zero for no faces).
pub fn angle_stats(positions: &[Point3<f64>], faces: &[[u32; 3]]) -> AngleStats {
    if faces.is_empty() {
        return AngleStats::default();
    }
    let mut stats = AngleStats {
        min_deg: f64::INFINITY,
        ..AngleStats::default()
    };
    let mut sum = 0.0;
    let mut below_10 = 0usize;
    for f in faces {
        let [a, b, c] = f.map(|v| positions[v as usize]);
        let angle = smallest_angle_deg(&a, &b, &c);
        stats.min_deg = stats.min_deg.min(angle);
        sum += angle;
        if angle < 10.0 {
            below_10 += 1;
        }
        let bin = ANGLE_BINS_DEG
            .iter()
            .position(|&hi| angle < hi)
            .unwrap_or(ANGLE_BINS_DEG.len() - 1);
        stats.histogram[bin] += 1;
    }
    stats.mean_deg = sum / faces.len() as f64;
    stats.below_10 = below_10 as f64 / faces.len() as f64;
    stats
}

/// Quality of a remesh against its input (issue #23).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RemeshQuality {
    /// Remesh (A) against input (B): Hausdorff, mean distances, opposed-area fraction of the
    /// remesh ([`SurfaceComparison`]).
    pub distances: SurfaceComparison,
    /// The input's bounding-box diagonal.
    pub diagonal: f64,
    /// max(Hausdorff both ways) / diagonal.
    pub hausdorff_relative: f64,
    /// max(mean both ways) / diagonal.
    pub mean_relative: f64,
    /// Fraction of the remesh's area whose normal opposes the nearest input triangle's.
    pub wrong_facing_area: f64,
    /// Where the wrong-facing area is: how many faces, how thin and how far from the input.
    pub wrong_facing: WrongFacing,
    /// The remesh's smallest angles.
    pub angles: AngleStats,
    /// How unevenly the remesh spends its triangles: p95 of |log(A_f / Ā)| over its faces
    /// ([`super::distortion::input_area_spread`] applied to the remesh; 0 when every face has
    /// the same area). Compare with the input's own spread.
    pub area_spread: f64,
    /// Wall-clock seconds of the distance figures (BVH builds and queries).
    pub distance_seconds: f64,
}

impl RemeshQuality {
    /// Whether the remesh meets issue #23's targets: Hausdorff ≤ [`FAITHFUL_HAUSDORFF`], mean
    /// distance ≤ [`FAITHFUL_MEAN`] (relative to the diagonal), no area facing the wrong way.
    pub fn faithful(&self) -> bool {
        self.hausdorff_relative <= FAITHFUL_HAUSDORFF
            && self.mean_relative <= FAITHFUL_MEAN
            && self.wrong_facing_area == 0.0
    }
}

/// The remesh faces with some area facing the wrong way (n_remesh · n_input < 0 at one of
/// their samples, [`SurfaceComparison::opposed_area_fraction`]), described by how thin and how
/// far from the input they are. Wrong-facing slivers on the surface (smallest angles of a few
/// degrees, distances of the order of the mean distance) are a remesh triangle folding over
/// where Π⁻¹ stretches a small base-domain triangle across a bend; a wrong-facing triangle of
/// ordinary shape far from the surface is a misplaced part of the remesh.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct WrongFacing {
    /// Faces with some wrong-facing area.
    pub faces: usize,
    /// The largest smallest angle (degrees) among them: every one is at least this thin.
    pub largest_smallest_angle_deg: f64,
    /// The largest distance from the input at their samples, relative to the diagonal.
    pub largest_distance_relative: f64,
}

/// [`WrongFacing`] of a remesh from its faces' comparisons with the input.
pub fn wrong_facing(
    positions: &[Point3<f64>],
    faces: &[[u32; 3]],
    compared: &[FaceComparison],
    diagonal: f64,
) -> WrongFacing {
    let mut w = WrongFacing::default();
    for (f, c) in faces.iter().zip(compared) {
        if c.opposed_area > 0.0 {
            let [a, b, d] = f.map(|v| positions[v as usize]);
            w.faces += 1;
            w.largest_smallest_angle_deg = w
                .largest_smallest_angle_deg
                .max(smallest_angle_deg(&a, &b, &d));
            w.largest_distance_relative = w.largest_distance_relative.max(if diagonal > 0.0 {
                c.max_distance / diagonal
            } else {
                0.0
            });
        }
    }
    w
}

/// Measure `remesh` against `input` ([`RemeshQuality`]); `diagonal` is the input's bounding-box
/// diagonal (a zero diagonal gives relative figures of 0).
pub fn remesh_quality(
    remesh_positions: &[Point3<f64>],
    remesh_faces: &[[u32; 3]],
    input_positions: &[Point3<f64>],
    input_faces: &[[u32; 3]],
    diagonal: f64,
) -> RemeshQuality {
    let t = std::time::Instant::now();
    let (distances, per_face) =
        compare_surfaces_per_face(remesh_positions, remesh_faces, input_positions, input_faces);
    let distance_seconds = t.elapsed().as_secs_f64();
    let relative = |x: f64| if diagonal > 0.0 { x / diagonal } else { 0.0 };
    RemeshQuality {
        distances,
        diagonal,
        hausdorff_relative: relative(distances.hausdorff.max()),
        mean_relative: relative(distances.mean()),
        wrong_facing_area: distances.opposed_area_fraction,
        wrong_facing: wrong_facing(remesh_positions, remesh_faces, &per_face, diagonal),
        angles: angle_stats(remesh_positions, remesh_faces),
        area_spread: input_area_spread(remesh_positions, remesh_faces),
        distance_seconds,
    }
}

/// Folds of the input surface: interior edges whose two faces' normals make more than 90°
/// (n₁ · n₂ < 0), and the share of the area of the faces along them. A scan with such folds
/// has facets that face against their neighbours; any remesh coarser than the fold faces
/// them the wrong way, so the wrong-facing area cannot reach 0 there.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct InputFolds {
    /// Interior edges (two faces, opposite directions) folded past 90°.
    pub edges: usize,
    /// Area of the faces along those edges over the total area.
    pub area_fraction: f64,
}

/// [`InputFolds`] of a triangle mesh, in time linear in its faces (one hash map of directed
/// edges; edges of one face or of three or more are left out, and so are faces whose area is
/// not a finite number).
pub fn input_folds(positions: &[Point3<f64>], faces: &[[u32; 3]]) -> InputFolds {
    use std::collections::HashMap;
    let normal = |f: &[u32; 3]| {
        let [a, b, c] = f.map(|v| positions[v as usize]);
        (b - a).cross(&(c - a))
    };
    let mut directed: HashMap<(u32, u32), Option<usize>> = HashMap::with_capacity(3 * faces.len());
    for (i, f) in faces.iter().enumerate() {
        for e in 0..3 {
            let key = (f[e], f[(e + 1) % 3]);
            // A directed edge met twice is non-manifold: left out.
            directed
                .entry(key)
                .and_modify(|slot| *slot = None)
                .or_insert(Some(i));
        }
    }
    let mut on_fold = vec![false; faces.len()];
    let mut edges = 0;
    for (&(a, b), &slot) in &directed {
        if a > b {
            continue;
        }
        let (Some(i), Some(Some(j))) = (slot, directed.get(&(b, a)).copied()) else {
            continue;
        };
        if normal(&faces[i]).dot(&normal(&faces[j])) < 0.0 {
            edges += 1;
            on_fold[i] = true;
            on_fold[j] = true;
        }
    }
    // Areas scaled by the largest finite one, so that the sums cannot overflow; a face whose
    // area is not finite (coordinates near f64's range) is left out.
    let areas: Vec<f64> = faces.iter().map(|f| 0.5 * normal(f).norm()).collect();
    let largest = areas
        .iter()
        .copied()
        .filter(|a| a.is_finite())
        .fold(0.0, f64::max);
    let share = |keep: &dyn Fn(usize) -> bool| -> f64 {
        areas
            .iter()
            .enumerate()
            .filter(|&(i, a)| a.is_finite() && keep(i))
            .map(|(_, a)| a / largest)
            .sum()
    };
    let (total, folded) = if largest > 0.0 {
        (share(&|_| true), share(&|i| on_fold[i]))
    } else {
        (0.0, 0.0)
    };
    InputFolds {
        edges,
        area_fraction: if total > 0.0 { folded / total } else { 0.0 },
    }
}
