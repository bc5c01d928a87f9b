//! The authors' quality protocol (SPEC.md § 12): subdivide every face n times 1→4,
//! evaluate the interpolant at the sub-vertices, and measure the quasi-conformal distortion
//! QC = σ_max/σ_min of the affine map from each sub-triangle (in the face's layout) to its image.

use num_complex::Complex64 as C;
use rayon::prelude::*;

use super::eval::Interp;
use super::moebius::c_abs;
use super::precompute::Bpm;
use super::vertex_rule::{grid_index, VertexOwners};
use crate::error::{Error, Result};

/// Distortion statistics over all sub-triangles. Percentiles and the mean are weighted by the
/// sub-triangle's area; folded sub-triangles (orientation reversed) are counted separately and
/// included in the statistics with their (finite) QC.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct QcStats {
    pub interp: Interp,
    pub subdiv: u32,
    pub sub_triangles: usize,
    pub mean: f64,
    pub p50: f64,
    pub p95: f64,
    pub p99: f64,
    pub max: f64,
    /// Sub-triangles whose image is reversed against the face's UV triangle.
    pub folded: usize,
    /// Sub-triangles whose image is degenerate (σ_min = 0, QC = ∞), left out of the figures.
    pub collapsed: usize,
    /// Degenerate input faces (linear fallback), left out of the protocol.
    pub skipped_faces: usize,
}

/// Quasi-conformal distortion of the affine map taking the triangle `z` to the triangle `w`.
///
/// Writing the map as w = α z + β z̄ + c (α, β solved from the two edge vectors):
/// σ_max = |α| + |β|, σ_min = ||α| − |β||, det = |α|² − |β|² (< 0: folded). Returns
/// (σ_max/σ_min, folded).
pub fn quasi_conformal(z: [C; 3], w: [C; 3]) -> (f64, bool) {
    let (alpha, beta, _) = affine_coefficients(z, w);
    let (a, b) = (c_abs(alpha), c_abs(beta));
    ((a + b) / (a - b).abs(), b > a)
}

/// α, β of the affine map w = αz + βz̄ + c taking triangle `z` to triangle `w`, and det = dz₁ z̄₂ −
/// dz₂ z̄₁ (4i × the signed area of z): α = (dw₁ z̄₂ − dw₂ z̄₁)/det, β = (dz₁ dw₂ − dz₂ dw₁)/det.
pub fn affine_coefficients(z: [C; 3], w: [C; 3]) -> (C, C, C) {
    let (dz1, dz2) = (z[1] - z[0], z[2] - z[0]);
    let (dw1, dw2) = (w[1] - w[0], w[2] - w[0]);
    let det = dz1 * dz2.conj() - dz2 * dz1.conj();
    let alpha = (dw1 * dz2.conj() - dw2 * dz1.conj()) / det;
    let beta = (dz1 * dw2 - dz2 * dw1) / det;
    (alpha, beta, det)
}

/// Barycentric coordinates of the regular grid with `n = 2^subdiv` segments per edge: vertex
/// (r, s) has b = (1 − (r + s)/n, r/n, s/n).
fn grid_bary(r: usize, s: usize, n: usize) -> [f64; 3] {
    let (bj, bk) = (r as f64 / n as f64, s as f64 / n as f64);
    [1.0 - bj - bk, bj, bk]
}

/// The grid vertices (r, s), r + s ≤ n, row by row (s outer), in the order [`grid_index`] numbers them.
fn grid_points(n: usize) -> impl Iterator<Item = (usize, usize)> {
    (0..=n).flat_map(move |s| (0..=n - s).map(move |r| (r, s)))
}

/// The sub-triangles of the grid as triples of (r, s) indices: "up" (r,s),(r+1,s),(r,s+1) and
/// "down" (r+1,s),(r+1,s+1),(r,s+1); n² in all, all with the face's orientation.
fn sub_triangles(n: usize) -> Vec<[(usize, usize); 3]> {
    let mut out = Vec::with_capacity(n * n);
    for s in 0..n {
        for r in 0..n - s {
            out.push([(r, s), (r + 1, s), (r, s + 1)]);
            if r + s + 1 < n {
                out.push([(r + 1, s), (r + 1, s + 1), (r, s + 1)]);
            }
        }
    }
    out
}

/// Default most sub-triangles [`qc_protocol`] measures for one interpolant: 2²⁵ (about 800 MiB
/// of (QC, area, folded) records, sorted for the area-weighted quantiles). Raise it with
/// [`MAX_QC_SUB_TRIANGLES_VARIABLE`].
pub const DEFAULT_MAX_QC_SUB_TRIANGLES: u64 = 1 << 25;

/// Environment variable that overrides [`DEFAULT_MAX_QC_SUB_TRIANGLES`] (a positive integer).
pub const MAX_QC_SUB_TRIANGLES_VARIABLE: &str = "REPARAM_MAX_QC_SUB_TRIANGLES";

/// [`Error::TooManySubTriangles`] unless `faces × 4^subdiv` sub-triangles are within the limit
/// ([`MAX_QC_SUB_TRIANGLES_VARIABLE`] when set to a positive integer, else
/// [`DEFAULT_MAX_QC_SUB_TRIANGLES`]): checked before anything is allocated for them.
pub fn check_qc_size(mesh: &str, faces: usize, subdiv: u32) -> Result<()> {
    let limit = std::env::var(MAX_QC_SUB_TRIANGLES_VARIABLE)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
        .filter(|&n| n > 0)
        .unwrap_or(DEFAULT_MAX_QC_SUB_TRIANGLES);
    let needed = (faces as u64).saturating_mul(1u64.checked_shl(2 * subdiv).unwrap_or(u64::MAX));
    if needed > limit {
        return Err(Error::TooManySubTriangles {
            mesh: mesh.to_string(),
            faces,
            subdiv,
            needed,
            limit,
        });
    }
    Ok(())
}

/// Run the QC protocol with `subdiv` 1→4 subdivisions per face (n = 4 gives 256 sub-triangles).
pub fn qc_protocol(bpm: &Bpm, interp: Interp, subdiv: u32) -> QcStats {
    qc_protocol_faces(bpm, interp, subdiv, None).0
}

/// One input face's QC figures under one interpolant (`bpm qc --per-face`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceQc {
    /// Area-weighted mean QC over the face's sub-triangles with finite QC (NaN for a
    /// degenerate face, which the protocol skips).
    pub mean: f64,
    /// Largest finite QC of its sub-triangles (NaN for a degenerate face).
    pub max: f64,
    /// Sub-triangles whose image is reversed.
    pub folded: u32,
    /// Sub-triangles whose image is degenerate (QC = ∞, left out of `mean` and `max`).
    pub collapsed: u32,
    /// Σ area of the sub-triangles with finite QC (the weight of `mean`; the face's area when
    /// none collapsed): Σ_f mean_f · measured_area_f over any set of faces is the protocol's
    /// area-weighted sum over their sub-triangles.
    pub measured_area: f64,
}

/// [`qc_protocol`] with the per-face figures as well, and optionally the authors' vertex rule
/// ([`super::vertex_rule`]): with `owners`, a sub-vertex another face owns is evaluated by that
/// face (`owners` must be built for the same mesh and `subdiv`). Each sub-triangle's record is
/// (QC, area, folded), folded meaning the image's orientation differs from the face's UV
/// triangle's ([`quasi_conformal`]'s reversal against the layout, corrected where the layout is
/// not mirrored to the UV orientation, see `layout_against_uv`); a face's [`FaceQc`]
/// summarises its own 4ⁿ.
pub fn qc_protocol_faces(
    bpm: &Bpm,
    interp: Interp,
    subdiv: u32,
    owners: Option<&VertexOwners>,
) -> (QcStats, Vec<FaceQc>) {
    let per_face: Vec<Vec<(f64, f64, bool)>> =
        sub_triangle_images_with(bpm, interp, subdiv, owners)
            .into_iter()
            .enumerate()
            .map(|(f, face)| {
                let flip = layout_against_uv(&bpm.maps[f]);
                face.into_iter()
                    .map(|(z, w)| {
                        let (qc, reversed) = quasi_conformal(z, w);
                        let area = 0.5 * super::precompute::signed_area2(z[0], z[1], z[2]).abs();
                        (qc, area, reversed != flip)
                    })
                    .collect()
            })
            .collect();
    let faces = per_face.iter().map(|records| face_qc(records)).collect();
    let skipped_faces = bpm.maps.iter().filter(|t| t.fallback_linear).count();
    let stats = summarise(
        per_face.into_iter().flatten().collect(),
        interp,
        subdiv,
        skipped_faces,
    );
    (stats, faces)
}

/// Whether face t's layout and UV triangle have opposite orientations: never under the
/// correct unfolding (the layout is mirrored to match), true for a clockwise UV face under the
/// authors' (no orientation fix). A sub-triangle is folded when its image's orientation differs
/// from the UV triangle's, i.e. reversed against the layout XOR this.
fn layout_against_uv(t: &super::precompute::TriangleMaps) -> bool {
    use super::precompute::{signed_area2, uv_clockwise};
    (signed_area2(t.z[0], t.z[1], t.z[2]) < 0.0) != uv_clockwise(t.uv)
}

/// A face's [`FaceQc`] from its sub-triangles' (QC, area, folded) records.
fn face_qc(records: &[(f64, f64, bool)]) -> FaceQc {
    let finite = || records.iter().filter(|x| x.0.is_finite());
    let measured_area: f64 = finite().map(|x| x.1).sum();
    let finite_count = finite().count();
    let (mean, max) = match finite_count {
        0 => (f64::NAN, f64::NAN),
        _ => (
            finite().map(|x| x.0 * x.1).sum::<f64>() / measured_area,
            finite().map(|x| x.0).fold(f64::NEG_INFINITY, f64::max),
        ),
    };
    FaceQc {
        mean,
        max,
        folded: records.iter().filter(|x| x.2).count() as u32,
        collapsed: (records.len() - finite_count) as u32,
        measured_area,
    }
}

/// Area-weighted mean QC over the faces selected by `keep` (Σ mean_f · measured_area_f / Σ
/// measured_area_f, faces without a finite figure left out); NaN when none is left.
pub fn mean_over_faces(faces: &[FaceQc], keep: impl Fn(usize) -> bool) -> f64 {
    let (mut sum, mut area) = (0.0, 0.0);
    for (f, q) in faces.iter().enumerate() {
        if keep(f) && q.mean.is_finite() {
            sum += q.mean * q.measured_area;
            area += q.measured_area;
        }
    }
    sum / area
}

/// Every sub-triangle of the protocol as (layout z, image w), face by face in order (none for
/// a degenerate face): the grid of `2^subdiv` segments per edge, each grid vertex evaluated once.
pub fn sub_triangle_images(bpm: &Bpm, interp: Interp, subdiv: u32) -> Vec<Vec<([C; 3], [C; 3])>> {
    sub_triangle_images_with(bpm, interp, subdiv, None)
}

/// [`sub_triangle_images`], with the sub-vertices `owners` lists evaluated by their owner face
/// (the authors' vertex rule); the layout z stays the face's own.
pub fn sub_triangle_images_with(
    bpm: &Bpm,
    interp: Interp,
    subdiv: u32,
    owners: Option<&VertexOwners>,
) -> Vec<Vec<([C; 3], [C; 3])>> {
    let n = 1usize << subdiv;
    let subs = sub_triangles(n);
    (0..bpm.maps.len())
        .into_par_iter()
        .map(|f| {
            let t = &bpm.maps[f];
            if t.fallback_linear {
                return Vec::new();
            }
            // Each grid vertex is shared by up to six sub-triangles: evaluate it once.
            let mut grid: Vec<(C, C)> = grid_points(n)
                .map(|(r, s)| {
                    let b = grid_bary(r, s, n);
                    (
                        t.z[0] * b[0] + t.z[1] * b[1] + t.z[2] * b[2],
                        bpm.eval(f, b, interp),
                    )
                })
                .collect();
            if let Some(owners) = owners {
                for borrowed in &owners.borrowed[f] {
                    grid[borrowed.grid_index].1 = bpm.eval(borrowed.owner, borrowed.bary, interp);
                }
            }
            let point = |(r, s): (usize, usize)| grid[grid_index(r, s, n)];
            subs.iter()
                .map(|tri| {
                    let [(z0, w0), (z1, w1), (z2, w2)] = tri.map(point);
                    ([z0, z1, z2], [w0, w1, w2])
                })
                .collect()
        })
        .collect()
}

/// How far the QC figures can move when every image corner moves by at most δ (UV units), as
/// (relative bound of every QC figure, sub-triangles that can flip between folded and not).
///
/// For the affine map w = αz + βz̄ + c of a sub-triangle ([`quasi_conformal`]), α = (dw₁ z̄₂ −
/// dw₂ z̄₁)/det and β = (dz₁ dw₂ − dz₂ dw₁)/det with each dw moved by ≤ 2δ, so |Δα| + |Δβ| ≤
/// ε_A = 4δ(|dz₁| + |dz₂|)/|det|, and σ_max, σ_min = |α| ± |β| move by ≤ ε_A. Then QC =
/// σ_max/σ_min moves by ≤ ε_A/σ_max + ε_A/σ_min ≤ 2ε_A/σ_min relatively (first order). Every
/// QC moving by ≤ ρ = max 2ε_A/σ_min relatively, so do the area-weighted mean and every
/// area-weighted quantile (the areas are the layout's, unchanged). A sub-triangle can change
/// sides of det = 0 only where σ_min ≤ ε_A.
pub fn qc_sensitivity(bpm: &Bpm, interp: Interp, subdiv: u32, delta: f64) -> (f64, usize) {
    let (mut rho, mut near_fold) = (0.0f64, 0usize);
    for (z, w) in sub_triangle_images(bpm, interp, subdiv)
        .into_iter()
        .flatten()
    {
        let (alpha, beta, det) = affine_coefficients(z, w);
        let (dz1, dz2) = (z[1] - z[0], z[2] - z[0]);
        let sigma_min = (c_abs(alpha) - c_abs(beta)).abs();
        let eps_a = 4.0 * delta * (c_abs(dz1) + c_abs(dz2)) / c_abs(det);
        if sigma_min <= eps_a {
            near_fold += 1;
        } else {
            rho = rho.max(2.0 * eps_a / sigma_min);
        }
    }
    (rho, near_fold)
}

fn summarise(mut v: Vec<(f64, f64, bool)>, interp: Interp, subdiv: u32, skipped: usize) -> QcStats {
    let sub_triangles = v.len();
    let folded = v.iter().filter(|x| x.2).count();
    v.retain(|x| x.0.is_finite());
    let collapsed = sub_triangles - v.len();
    v.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    let total_area: f64 = v.iter().map(|x| x.1).sum();
    let mean = v.iter().map(|x| x.0 * x.1).sum::<f64>() / total_area;
    let percentile = |p: f64| {
        let target = p * total_area;
        let mut acc = 0.0;
        for x in &v {
            acc += x.1;
            if acc >= target {
                return x.0;
            }
        }
        v.last().map_or(f64::NAN, |x| x.0)
    };
    QcStats {
        interp,
        subdiv,
        sub_triangles,
        mean,
        p50: percentile(0.50),
        p95: percentile(0.95),
        p99: percentile(0.99),
        max: v.last().map_or(f64::NAN, |x| x.0),
        folded,
        collapsed,
        skipped_faces: skipped,
    }
}
