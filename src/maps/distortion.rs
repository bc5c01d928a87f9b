//! Distortion of Π, the map from the input surface to the base domain (issue #23), per level
//! and for the final map. For each input triangle t with corners p_0, p_1, p_2 the image is the
//! triangle of q_c = Π_l(p_c), each a point of a face of the level-l mesh written in 3D as
//! Σ b_c P(corner_c) (the seed's "Parameterization": Π is piecewise linear on the input
//! triangles and the level-l mesh is a piecewise flat surface, so the image triangle is the
//! straight triangle of the q_c; exact when the three lie in one face, a chord across the
//! fold of a level edge otherwise).
//!
//! Per triangle:
//! - area distortion: log r_t, r_t = (A'_t / Σ A') / (A_t / Σ A), A the 3D area and A' the
//!   image area; 0 when the map is area-preserving up to the total scale;
//! - conformal distortion: σ_max / σ_min of the linear map J from t to its image, each in its
//!   own plane (1 for a similarity);
//! - folded: the image's normal points against the level mesh's normal there (the sum of the
//!   unit normals of the faces holding q_0, q_1, q_2), or the image has no area.
//!
//! Statistics are over the triangles that did not fold: |log r| and σ_max/σ_min, each as mean,
//! 95th percentile and max, every triangle counting once.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use super::Maps;

/// Distortion statistics of one map (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct DistortionStats {
    /// Input triangles measured (those whose three corners have an image).
    pub triangles: usize,
    /// Images that folded or have no area (excluded from the figures below). Π itself never
    /// folds (each level map is orientation preserving, [`super::Param::count_flipped`]); an
    /// image counted here is the straight triangle of its three corners facing against the
    /// level mesh's normals, which happens when the corners lie on faces either side of a
    /// sharp level edge (measured at a 96-face base: 0 after the first level, 1.0% of blub's
    /// triangles and 0.4% of the genus-3 model's at the end).
    pub folded: usize,
    /// Mean of |log r_t|.
    pub area_mean: f64,
    /// 95th percentile of |log r_t|.
    pub area_p95: f64,
    /// Max of |log r_t|.
    pub area_max: f64,
    /// Mean of σ_max/σ_min.
    pub conformal_mean: f64,
    /// 95th percentile of σ_max/σ_min.
    pub conformal_p95: f64,
    /// Max of σ_max/σ_min.
    pub conformal_max: f64,
}

/// The distortion of Π level by level and at the end.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Distortion {
    /// Entry l: the map from the input to the mesh after level l.
    pub per_level: Vec<DistortionStats>,
    /// The final map Π to the base domain (the last level's entry; the identity's figures when
    /// the hierarchy has no level).
    pub final_map: DistortionStats,
    /// The input's own triangle-size spread: the 95th percentile of |log(A_t / Ā)| over input
    /// triangles, Ā their mean area. Issue #23's target compares `final_map.area_p95` with it.
    pub input_area_spread: f64,
    /// How exactly Π composes across the levels: the largest |Π⁻¹(Π(p_v)) − p_v| over the
    /// input vertices, relative to the bounding-box diagonal, with Π(p_v) the hierarchy's
    /// bookkeeping (each removal re-stores the points of its ring, notes "Parameter
    /// bookkeeping") and Π⁻¹ the level maps replayed backwards ([`super::Param::inverse`]).
    /// Rounding only: each level rounds u = Σ b μ and the barycentrics to ~1e-16 of the ring's
    /// size, and Π⁻¹ multiplies that by its local stretch. Measured at base 96: 2e-16 on spot,
    /// bob and the genus models, 7.6e-15 on nefertiti; 1.5e-9 on blub, whose fins Π squeezes
    /// (area ratio down to e⁻²⁵, σmax/σmin up to 3·10⁶), so that a rounding of 1e-16 in the
    /// base domain is a displacement of 1e-9 on the fin.
    pub round_trip_max_relative: f64,
    /// Per input triangle, log r_t of the final map (`None` for a folded image or a triangle
    /// without image): the picture colours by it.
    #[serde(skip)]
    pub log_area_ratio: Vec<Option<f64>>,
}

/// The image of one input triangle: 3D corners and the reference normal of the level mesh.
struct Image {
    q: [Point3<f64>; 3],
    normal: Vector3<f64>,
}

/// Area and σ_max/σ_min of the linear map from triangle `p` to triangle `q` (both in 3D, each
/// in its own plane): in each triangle's frame (x along its first edge, y = n × x) the edge
/// matrices P = [e₁ e₂] and Q = [e₁' e₂'] give J = Q P⁻¹; for J = [[a, b], [c, d]] the singular
/// values are σ = √(E² + H²) ± √(F² + G²) with E = (a + d)/2, F = (a − d)/2, G = (c + b)/2,
/// H = (c − b)/2. Returns (area of p, area of q, σ_max/σ_min), `None` when either triangle
/// is degenerate.
pub fn triangle_map(p: &[Point3<f64>; 3], q: &[Point3<f64>; 3]) -> Option<(f64, f64, f64)> {
    let frame = |t: &[Point3<f64>; 3]| -> Option<(nalgebra::Matrix2<f64>, f64)> {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let n = e1.cross(&e2);
        let area = 0.5 * n.norm();
        let x = e1.try_normalize(0.0)?;
        let y = n.try_normalize(0.0)?.cross(&x);
        let m = nalgebra::Matrix2::new(e1.dot(&x), e2.dot(&x), e1.dot(&y), e2.dot(&y));
        (area > 0.0).then_some((m, area))
    };
    let (pm, pa) = frame(p)?;
    let (qm, qa) = frame(q)?;
    let j = qm * pm.try_inverse()?;
    let (a, b, c, d) = (j[(0, 0)], j[(0, 1)], j[(1, 0)], j[(1, 1)]);
    let (e, f, g, h) = ((a + d) / 2.0, (a - d) / 2.0, (c + b) / 2.0, (c - b) / 2.0);
    let (s, r) = ((e * e + h * h).sqrt(), (f * f + g * g).sqrt());
    let (max, min) = (s + r, (s - r).abs());
    let ratio = max / min;
    (ratio.is_finite() && min > 0.0).then_some((pa, qa, ratio))
}

/// The `p`-quantile (0 ≤ p ≤ 1) of sorted values: the element at rank ⌈p n⌉ (1-based);
/// 0 for no values.
pub fn quantile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = (p * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

/// Mean, 95th percentile and max of `values` (sorted here; zeros for none).
fn summary(mut values: Vec<f64>) -> (f64, f64, f64) {
    if values.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    values.sort_by(f64::total_cmp);
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    (mean, quantile(&values, 0.95), quantile(&values, 1.0))
}

/// [`DistortionStats`] of the images `images[t]` of the input triangles (`None`: no image),
/// with log r_t per triangle.
fn stats_of(maps: &Maps, images: &[Option<Image>]) -> (DistortionStats, Vec<Option<f64>>) {
    // Per triangle (parallel, collected in triangle order): (3D area, image area, σ ratio),
    // or None when folded or degenerate.
    let measured: Vec<Option<Option<(f64, f64, f64)>>> = maps
        .input_faces
        .par_iter()
        .zip(images)
        .map(|(t, image)| {
            let image = image.as_ref()?;
            let p = t.map(|v| maps.positions[v as usize]);
            let q = image.q;
            let n = (q[1] - q[0]).cross(&(q[2] - q[0]));
            if n.dot(&image.normal) <= 0.0 {
                return Some(None);
            }
            Some(triangle_map(&p, &q))
        })
        .collect();
    let (mut total, mut total_image) = (0.0, 0.0);
    for &(a, b, _) in measured.iter().flatten().flatten() {
        total += a;
        total_image += b;
    }
    let log_ratio: Vec<Option<f64>> = measured
        .iter()
        .map(|m| {
            let (a, b, _) = (*m)??;
            let r = (b / total_image) / (a / total);
            r.ln().is_finite().then(|| r.ln())
        })
        .collect();
    let area: Vec<f64> = log_ratio.iter().flatten().map(|x| x.abs()).collect();
    let conformal: Vec<f64> = measured.iter().flatten().flatten().map(|m| m.2).collect();
    let triangles = measured.iter().filter(|m| m.is_some()).count();
    let folded = measured.iter().filter(|m| matches!(m, Some(None))).count();
    let (area_mean, area_p95, area_max) = summary(area);
    let (conformal_mean, conformal_p95, conformal_max) = summary(conformal);
    (
        DistortionStats {
            triangles,
            folded,
            area_mean,
            area_p95,
            area_max,
            conformal_mean,
            conformal_p95,
            conformal_max,
        },
        log_ratio,
    )
}

/// The images of the input triangles when every used input vertex v sits at `loc[v]`
/// (decimation face id and barycentrics; `None` for an unused vertex).
fn images(maps: &Maps, loc: &[Option<(u32, [f64; 3])>]) -> Vec<Option<Image>> {
    let point = |(f, b): (u32, [f64; 3])| {
        let t = maps.param.face(f);
        let mut p = Point3::origin();
        for c in 0..3 {
            p += maps.positions[t[c] as usize].coords * b[c];
        }
        p
    };
    let unit_normal = |f: u32| {
        let [a, b, c] = maps.param.face(f).map(|v| maps.positions[v as usize]);
        (b - a)
            .cross(&(c - a))
            .try_normalize(0.0)
            .unwrap_or_default()
    };
    maps.input_faces
        .par_iter()
        .map(|t| {
            let l = [
                loc[t[0] as usize]?,
                loc[t[1] as usize]?,
                loc[t[2] as usize]?,
            ];
            Some(Image {
                q: l.map(point),
                normal: l.iter().map(|&(f, _)| unit_normal(f)).sum(),
            })
        })
        .collect()
}

/// p95 of |log(A_t / Ā)| over the input triangles ([`Distortion::input_area_spread`]).
/// Triangles of zero area have no log ratio; triangles whose area or log ratio is not finite in
/// f64 (coordinates near 10¹⁵⁴ and beyond, found by fuzzing) are left out, and Ā is summed as
/// Σ A_t / n when Σ A_t overflows.
pub fn input_area_spread(positions: &[Point3<f64>], faces: &[[u32; 3]]) -> f64 {
    let areas: Vec<f64> = faces
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            0.5 * (b - a).cross(&(c - a)).norm()
        })
        .filter(|a| a.is_finite())
        .collect();
    if areas.is_empty() {
        return 0.0;
    }
    let n = areas.len() as f64;
    let mut mean = areas.iter().sum::<f64>() / n;
    if !mean.is_finite() {
        mean = areas.iter().map(|a| a / n).sum::<f64>();
    }
    let mut logs: Vec<f64> = areas
        .iter()
        .filter(|&&a| a > 0.0 && mean > 0.0)
        .map(|a| (a / mean).ln().abs())
        .filter(|l| l.is_finite())
        .collect();
    logs.sort_by(f64::total_cmp);
    quantile(&logs, 0.95)
}

/// The distortion of Π level by level ([`Distortion`]): every used input vertex starts at a
/// corner of an input face holding it and is carried by [`super::Param::forward_until`] through
/// each level's removals in turn; after each level the images of the input triangles are
/// measured.
pub fn distortion(maps: &Maps) -> Distortion {
    let mut loc: Vec<Option<(u32, [f64; 3])>> = vec![None; maps.positions.len()];
    for (f, t) in maps.input_faces.iter().enumerate() {
        for (c, &v) in t.iter().enumerate() {
            if loc[v as usize].is_none() {
                let mut b = [0.0; 3];
                b[c] = 1.0;
                loc[v as usize] = Some((f as u32, b));
            }
        }
    }
    let mut per_level = Vec::with_capacity(maps.levels.len());
    let mut limit = 0usize;
    let mut last = stats_of(maps, &images(maps, &loc));
    for level in &maps.levels {
        limit += level.removed.len();
        loc = loc
            .par_iter()
            .map(|l| l.and_then(|(f, b)| maps.param.forward_until(f, b, limit)))
            .collect();
        last = stats_of(maps, &images(maps, &loc));
        per_level.push(last.0);
    }
    Distortion {
        per_level,
        final_map: last.0,
        input_area_spread: input_area_spread(&maps.positions, &maps.input_faces),
        round_trip_max_relative: round_trip_max_relative(maps),
        log_area_ratio: last.1,
    }
}

/// The distortion of another map of the input onto the base domain, given by its value at
/// every input vertex (`None`: a vertex no face uses), measured as the final map of
/// [`distortion`] is: each input triangle's image is the 3D triangle between its corners'
/// images on the base faces. Returns the statistics and log r_t per input triangle (the
/// picture's colours). Used for Π' = Φ ∘ Π ([`super::equalise`]).
pub fn map_distortion(
    maps: &Maps,
    params: &[Option<super::BasePoint>],
) -> (DistortionStats, Vec<Option<f64>>) {
    let loc: Vec<Option<(u32, [f64; 3])>> = params
        .iter()
        .map(|p| p.and_then(|p| Some((maps.param.decimation_face(p.face)?, p.bary))))
        .collect();
    stats_of(maps, &images(maps, &loc))
}

/// max_v |Π⁻¹(Π(p_v)) − p_v| / diagonal over the input vertices that have a parameter
/// ([`Distortion::round_trip_max_relative`]); 0 for a mesh without extent.
pub fn round_trip_max_relative(maps: &Maps) -> f64 {
    let (lo, hi) = maps.positions.iter().fold(
        (
            nalgebra::Vector3::repeat(f64::INFINITY),
            nalgebra::Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)),
    );
    let diagonal = (hi - lo).norm();
    if !(diagonal.is_finite() && diagonal > 0.0) {
        return 0.0;
    }
    let worst = (0..maps.positions.len() as u32)
        .into_par_iter()
        .filter_map(|v| {
            let back = maps.param.inverse(&maps.param.vertex(v)?)?;
            Some((back.position - maps.positions[v as usize]).norm())
        })
        .reduce(|| 0.0, f64::max);
    worst / diagonal
}
