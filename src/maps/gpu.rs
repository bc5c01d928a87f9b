//! Bridge between the f64 MAPS reference and the f32 kernels of `reparam-gpu`
//! (`gpu/src/maps/`, `shaders/maps_priority.wgsl`, `maps_flatten.wgsl`, `maps_inverse.wgsl`).
//!
//! | step | f64 reference | f32 kernel | here |
//! |---|---|---|---|
//! | priority terms a(i), κ(i) | [`super::priority::ring_area`], [`super::priority::curvature`] | `maps_priority` | [`priority_terms_cpu`], [`priority_terms_gpu`], [`crosscheck_priority`] |
//! | z^a flattening of every ring of a level | [`super::flatten::cumulative_angles`], [`super::flatten::flatten_ring`] | `maps_flatten` | [`flatten_cpu`], [`flatten_gpu`], [`crosscheck_flatten`] |
//! | Π⁻¹ of base points | [`super::Param::inverse`] | `maps_inverse` | [`inverse_tables`], [`inverse_gpu`], [`crosscheck_inverse`] |
//!
//! Combinatorial decisions stay on the CPU: which rings exist and their shape ([`level_rings`]),
//! the hierarchy's removals, planes μ and faces ([`inverse_tables`]). The kernels evaluate the
//! formulas.
//!
//! Inputs: positions are centred on the bounding box's centre and divided by its diagonal
//! ([`normalise`]), so lengths are fractions of the diagonal and f32 keeps its relative precision
//! whatever the model's units. For the priority terms and the flattening the reference runs on
//! the same f32-rounded normalised positions (identical inputs: the comparison measures the
//! kernel's f32 arithmetic only). Π⁻¹ is compared with [`super::Param::inverse`] itself: the
//! kernel gets the f64 hierarchy's μ rounded to f32 (barycentrics do not depend on a plane's
//! scale, so μ is not normalised) and the rounded normalised positions.

// `!(e <= bound)` is meant throughout: a NaN error counts as over any bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{Matrix3, Point3, Vector3};
use reparam_gpu::maps::inverse::{InverseKernel, NONE};
use reparam_gpu::maps::{
    flatten, priority, BaseQuery, DecimationFace, FaceCharts, FlatPoint, FlatRing, InverseResult,
    InverseTables, RingHeader, Rings, KIND_DISK, KIND_FEATURE_LINE, KIND_HALF_DISK,
    STATUS_DEGENERATE, STATUS_FLIPPED_FAN, STATUS_OK,
};
use reparam_gpu::Gpu;

use super::features::Features;
use super::flatten::{cumulative_angles, flatten_ring, FlattenReject, RingShape};
use super::hierarchy::Work;
use super::param::BasePoint;
use super::priority::{curvature, ring_area, star_normal};
use super::Maps;
use crate::crosscheck::{ErrorSummary, F32_FLUSH};
use crate::error::{Error, Result};

/// f32 unit roundoff u = 2⁻²⁴.
pub const U32: f64 = f32::EPSILON as f64 / 2.0;

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

/// A GPU context ([`Error::Gpu`] when there is no adapter).
pub fn context() -> Result<Gpu> {
    Gpu::new().map_err(gpu_error)
}

/// Positions in the kernels' frame: p' = (p − centre)/diagonal (bounding box), rounded to f32.
#[derive(Clone, Debug)]
pub struct Normalised {
    /// The bounding box's centre.
    pub centre: Point3<f64>,
    /// The bounding box's diagonal.
    pub diagonal: f64,
    /// p' rounded to f32, w = 0 (what the kernels read).
    pub gpu: Vec<[f32; 4]>,
    /// The same rounded values in f64 (what the reference runs on for identical inputs).
    pub cpu: Vec<Point3<f64>>,
}

impl Normalised {
    /// p' = (p − centre)/diagonal in f64 (not rounded).
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from((p - self.centre) / self.diagonal)
    }
}

/// [`Normalised`] positions. [`Error::InvalidArgument`] for no positions, a non-finite
/// coordinate or a zero diagonal.
pub fn normalise(positions: &[Point3<f64>]) -> Result<Normalised> {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in positions {
        lo = lo.inf(&p.coords);
        hi = hi.sup(&p.coords);
    }
    let diagonal = (hi - lo).norm();
    if positions.is_empty() || !diagonal.is_finite() || diagonal <= 0.0 {
        return Err(Error::InvalidArgument(format!(
            "cannot normalise {} positions (bounding box diagonal {diagonal})",
            positions.len()
        )));
    }
    let centre = Point3::from((lo + hi) / 2.0);
    let gpu: Vec<[f32; 4]> = positions
        .iter()
        .map(|p| {
            let q = (p - centre) / diagonal;
            [q.x as f32, q.y as f32, q.z as f32, 0.0]
        })
        .collect();
    let cpu = gpu
        .iter()
        .map(|q| Point3::new(q[0] as f64, q[1] as f64, q[2] as f64))
        .collect();
    Ok(Normalised {
        centre,
        diagonal,
        gpu,
        cpu,
    })
}

/// The flattenable 1-rings of a level: every vertex of `faces` whose star is one fan of 3 or more
/// ring vertices and which is not a corner, with the ring and shape the hierarchy would use
/// (`Work::ring`, `Work::shape`; any degree — the hierarchy's degree limit is not applied).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LevelRings {
    /// The centre vertices, increasing.
    pub vertices: Vec<u32>,
    /// Ring vertices j_0 … j_{K−1} of each (counter-clockwise).
    pub rings: Vec<Vec<u32>>,
    /// The star faces of each, in ring order.
    pub stars: Vec<Vec<[u32; 3]>>,
    /// The flattening's shape of each.
    pub shapes: Vec<RingShape>,
}

impl LevelRings {
    /// Total ring slots Σ K.
    pub fn slot_count(&self) -> usize {
        self.rings.iter().map(Vec::len).sum()
    }
}

/// The rings of the mesh (`positions`, `faces`) with `features` (tags) and the corner threshold
/// `corner_turn` ([`super::MapsOptions::corner_turn`]). For `faces` = [`super::Level::faces`] of a
/// level, these are that level's rings; the shapes use `features` as tagged on the input, which
/// is exact at level 0 and at every level of a mesh without tagged feature edges (the hierarchy
/// moves a removed feature vertex's tags onto its chord; the levels do not store the moved tags).
pub fn level_rings(
    positions: &[Point3<f64>],
    faces: &[[u32; 3]],
    features: &Features,
    corner_turn: f64,
) -> LevelRings {
    let work = Work::new(positions, faces, features, corner_turn);
    let mut out = LevelRings::default();
    for v in 0..positions.len() as u32 {
        if !work.vert_alive[v as usize] || work.corner[v as usize] {
            continue;
        }
        let Some(ring) = work.ring(v) else { continue };
        if ring.verts.len() < 3 {
            continue;
        }
        let Some(shape) = work.shape(v, &ring) else {
            continue;
        };
        out.vertices.push(v);
        out.stars
            .push(ring.faces.iter().map(|&f| work.faces[f as usize]).collect());
        out.rings.push(ring.verts);
        out.shapes.push(shape);
    }
    out
}

/// The kernels' batch of `rings` over the normalised positions `positions`.
pub fn rings_batch(positions: &[[f32; 4]], rings: &LevelRings) -> Rings {
    let mut batch = Rings {
        positions: positions.to_vec(),
        neighbours: Vec::with_capacity(rings.slot_count()),
        rings: Vec::with_capacity(rings.vertices.len()),
    };
    for ((&v, ring), shape) in rings.vertices.iter().zip(&rings.rings).zip(&rings.shapes) {
        let (kind, s, t) = match *shape {
            RingShape::Disk => (KIND_DISK, 0, 0),
            RingShape::HalfDisk => (KIND_HALF_DISK, 0, 0),
            RingShape::FeatureLine { s, t } => (KIND_FEATURE_LINE, s as u32, t as u32),
        };
        batch.rings.push(RingHeader {
            centre: v,
            first: batch.neighbours.len() as u32,
            count: ring.len() as u32,
            kind,
            s,
            t,
            _pad: [0; 2],
        });
        batch.neighbours.extend(ring);
    }
    batch
}

fn ring_points(positions: &[Point3<f64>], ring: &[u32]) -> Vec<Point3<f64>> {
    ring.iter().map(|&w| positions[w as usize]).collect()
}

/// The reference's priority terms [a(i), κ(i)] of every ring: `ring_area` of the star and
/// `curvature` with the `star_normal` (exactly the hierarchy's candidate computation).
pub fn priority_terms_cpu(positions: &[Point3<f64>], rings: &LevelRings) -> Vec<[f64; 2]> {
    rings
        .vertices
        .iter()
        .zip(&rings.rings)
        .zip(&rings.stars)
        .map(|((&v, ring), star)| {
            let pts = ring_points(positions, ring);
            [
                ring_area(positions, star),
                curvature(&positions[v as usize], &pts, &star_normal(positions, star)),
            ]
        })
        .collect()
}

/// The `maps_priority` kernel's [a(i), κ(i)] of every ring of `batch`.
pub fn priority_terms_gpu(gpu: &Gpu, batch: &Rings) -> Result<Vec<[f64; 2]>> {
    Ok(priority::run(gpu, batch)
        .map_err(gpu_error)?
        .iter()
        .map(|t| [t.area as f64, t.kappa as f64])
        .collect())
}

/// Absolute error, from underflow alone, of an f32 length |a × b| = √(Σ c²) whose components
/// c are differences of two products: each component loses ≤ 2·2⁻¹²⁶, the three squares
/// ≤ 3·2⁻¹²⁶ together, and √(s + δ) − √s ≤ √δ: ≤ √(3·2⁻¹²⁶) + 2√3·2⁻¹²⁶ ≈ 1.9e-19. Negligible
/// unless the vectors are themselves ~1e-10 long (a mesh whose features are 10⁻¹⁰ of its
/// diagonal, found by the command fuzzer), where it dominates.
pub fn length_underflow() -> f64 {
    (3.0 * F32_FLUSH).sqrt() + 2.0 * 3f64.sqrt() * F32_FLUSH
}

/// Bound on |a_f32 − a_f64| of one star from the reference's quantities: each triangle's cross
/// product (differences rounded by u, products and a subtraction) is off by ≤ 4u|q − p||r − p|
/// per component, ≤ 7u|q − p||r − p| in length with the norm's 3 roundings, times ½, plus ½ the
/// underflow of the length ([`length_underflow`]); the K − 1 additions add ≤ K u·a.
pub fn area_bound(positions: &[Point3<f64>], star: &[[u32; 3]], area: f64) -> f64 {
    let edges: f64 = star
        .iter()
        .map(|f| {
            let [p, q, r] = f.map(|v| positions[v as usize]);
            (q - p).norm() * (r - p).norm()
        })
        .sum();
    let k = star.len() as f64;
    3.5 * U32 * edges + k * 0.5 * length_underflow() + k * U32 * area
}

/// Bound on |κ_f32 − κ_f64| of one ring, from the reference's quantities (the kernel fits in
/// coordinates divided by ℓ, the largest radius, so every scaled coordinate is ≤ 1):
/// - the f32 star normal's direction is off by δn ≤ (K + 4)u·ν, ν = Σ|q − p||r − p| / |Σ (q − p)
///   × (r − p)| (cancellation in the sum); the frame (n, e₁, e₂) by ≤ 2δn, so each scaled
///   coordinate by ε = 3δn + 6u;
/// - a row (x², xy, y²) by ≤ 3ε; M' = Σ row rowᵀ by δM ≤ 6Kε + Ku·λ_max(M'), rhs = Σ row z by
///   δr ≤ 4Kε + Ku|rhs|;
/// - the coefficients c' = M'⁻¹ rhs by δc ≤ (δr + δM|c'|)/λ_min(M') + 10u·(λ_max/λ_min)|c'| (the
///   adjugate's roundings);
/// - κ = |m + d| + |m − d| is 4-Lipschitz in (A, B, C) and c = c'/ℓ: δκ ≤ 4δc/ℓ + 6u|κ|.
///
/// Infinite when M' is singular (the reference returns 0 there and the kernel anything).
pub fn kappa_bound(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    star: &[[u32; 3]],
    kappa: f64,
) -> f64 {
    let p = positions[centre as usize];
    let normal = star_normal(positions, star);
    let spread: f64 = star
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| positions[v as usize]);
            (b - a).norm() * (c - a).norm()
        })
        .sum();
    let len = normal.norm();
    if len <= 0.0 {
        return f64::INFINITY;
    }
    let k = ring.len() as f64;
    let dn = (k + 4.0) * U32 * spread / len;
    let eps = 3.0 * dn + 6.0 * U32;
    let n = normal / len;
    let [e1, e2] = crate::maps::priority::tangent_frame(&n);
    let scale = ring
        .iter()
        .map(|&w| (positions[w as usize] - p).norm())
        .fold(0.0, f64::max);
    let mut m = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    for &w in ring {
        let d = (positions[w as usize] - p) / scale;
        let (x, y, z) = (d.dot(&e1), d.dot(&e2), d.dot(&n));
        let row = Vector3::new(x * x, x * y, y * y);
        m += row * row.transpose();
        rhs += row * z;
    }
    let eig = m.symmetric_eigenvalues();
    let (lmin, lmax) = (eig.min(), eig.max());
    if !(lmin > 0.0) {
        return f64::INFINITY;
    }
    let Some(inv) = m.try_inverse() else {
        return f64::INFINITY;
    };
    let c = (inv * rhs).norm();
    let dm = 6.0 * k * eps + k * U32 * lmax;
    let dr = 4.0 * k * eps + k * U32 * rhs.norm();
    let dc = (dr + dm * c) / lmin + 10.0 * U32 * (lmax / lmin) * c;
    4.0 * dc / scale + 6.0 * U32 * kappa.abs()
}

/// Priority terms on the GPU against the reference, from identical inputs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PriorityCrosscheck {
    /// Rings compared.
    pub rings: usize,
    /// |Δa|/a (tolerance: the largest relative [`area_bound`]).
    pub area: ErrorSummary,
    /// |Δκ| in units of 1/diagonal (tolerance: the largest finite [`kappa_bound`]).
    pub kappa: ErrorSummary,
    /// Rings whose error exceeds their own bound ([`area_bound`], [`kappa_bound`]).
    pub area_over_bound: usize,
    pub kappa_over_bound: usize,
    /// max error/bound over the rings.
    pub area_worst_ratio: f64,
    pub kappa_worst_ratio: f64,
    /// Rings whose scaled fit is singular (bound infinite; κ not compared).
    pub kappa_singular: usize,
}

/// Run `maps_priority` on `rings` over `positions` (normalised and rounded with [`normalise`])
/// and compare with [`priority_terms_cpu`] on the same values, ring by ring against
/// [`area_bound`] and [`kappa_bound`].
pub fn crosscheck_priority(
    gpu: &Gpu,
    positions: &Normalised,
    rings: &LevelRings,
) -> Result<PriorityCrosscheck> {
    let gpu_terms = priority_terms_gpu(gpu, &rings_batch(&positions.gpu, rings))?;
    let cpu_terms = priority_terms_cpu(&positions.cpu, rings);
    let pos = &positions.cpu;
    let (mut area_err, mut area_mag, mut kappa_err, mut kappa_mag) =
        (vec![], vec![], vec![], vec![]);
    let (mut area_over, mut kappa_over, mut singular) = (0, 0, 0);
    let (mut area_ratio, mut kappa_ratio, mut area_tol, mut kappa_tol) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (r, (g, c)) in gpu_terms.iter().zip(&cpu_terms).enumerate() {
        let ab = area_bound(pos, &rings.stars[r], c[0]);
        let da = (g[0] - c[0]).abs();
        area_err.push(da / c[0]);
        area_mag.push(1.0);
        area_tol = area_tol.max(ab / c[0]);
        area_ratio = area_ratio.max(da / ab);
        area_over += usize::from(!(da <= ab));
        let kb = kappa_bound(
            pos,
            rings.vertices[r],
            &rings.rings[r],
            &rings.stars[r],
            c[1],
        );
        if !kb.is_finite() {
            singular += 1;
            continue;
        }
        let dk = (g[1] - c[1]).abs();
        kappa_err.push(dk);
        kappa_mag.push(c[1]);
        kappa_tol = kappa_tol.max(kb);
        kappa_ratio = kappa_ratio.max(dk / kb);
        kappa_over += usize::from(!(dk <= kb));
    }
    Ok(PriorityCrosscheck {
        rings: rings.vertices.len(),
        area: ErrorSummary::from_errors("relative", &area_err, &area_mag, area_tol),
        kappa: ErrorSummary::from_errors("1/diagonal", &kappa_err, &kappa_mag, kappa_tol),
        area_over_bound: area_over,
        kappa_over_bound: kappa_over,
        area_worst_ratio: area_ratio,
        kappa_worst_ratio: kappa_ratio,
        kappa_singular: singular,
    })
}

/// The reference's flattening of one ring: θ ([`cumulative_angles`]: K + 1 entries closed, K
/// open) and μ ([`flatten_ring`], or its rejection).
pub type FlattenedRing = (Vec<f64>, std::result::Result<Vec<[f64; 2]>, FlattenReject>);

/// The reference's flattening of every ring ([`FlattenedRing`]).
pub fn flatten_cpu(positions: &[Point3<f64>], rings: &LevelRings) -> Vec<FlattenedRing> {
    rings
        .vertices
        .iter()
        .zip(&rings.rings)
        .zip(&rings.shapes)
        .map(|((&v, ring), &shape)| {
            let centre = positions[v as usize];
            let pts = ring_points(positions, ring);
            let closed = !matches!(shape, RingShape::HalfDisk);
            (
                cumulative_angles(&centre, &pts, closed),
                flatten_ring(&centre, &pts, shape),
            )
        })
        .collect()
}

/// The `maps_flatten` kernel's output for `batch`: per ring and per slot.
pub fn flatten_gpu(gpu: &Gpu, batch: &Rings) -> Result<(Vec<FlatRing>, Vec<FlatPoint>)> {
    flatten::run(gpu, batch).map_err(gpu_error)
}

/// Bound on |θ_k,f32 − θ_k| given the reference's θ (θ_0 … θ_k) and, per sector m, the
/// product |a||b| of its two edge vectors. Per angle φ = atan2(y, x), y = |a×b|, x = a·b: the
/// components of a×b and x carry ≤ 3u|a||b| absolute error, the length 2u|y| more, which moves
/// φ by ≤ (|x| + |y|)3u/(|a||b|) + 2u ≤ 6.3u; rounding the differences a, b turns each by
/// ≤ √3u (≤ 3.5u together); the kernel's atan (Cephes' atanf, ≤ 2 ulp), its argument's
/// division and π − t add ≤ 6uφ + 2uφ. Underflow moves y by ≤ [`length_underflow`] and x by
/// ≤ 3·2⁻¹²⁶, so φ by ≤ (those)/(|a||b|) more (√(x² + y²) = |a||b|). The k − 1 additions add
/// ≤ u θ_k each.
pub fn theta_bound(theta: &[f64], edge_products: &[f64], k: usize) -> f64 {
    let underflow = length_underflow() + 3.0 * F32_FLUSH;
    let angles: f64 = (0..k)
        .map(|m| 10.0 * U32 + 8.0 * U32 * (theta[m + 1] - theta[m]) + underflow / edge_products[m])
        .sum();
    angles + k as f64 * U32 * theta[k]
}

/// |a||b| of each sector of a ring (a = p_{j_m} − p_i, b = p_{j_{m+1}} − p_i, the last sector
/// closing the ring when `closed`), for [`theta_bound`].
pub fn sector_edge_products(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    closed: bool,
) -> Vec<f64> {
    let p = positions[centre as usize];
    let k = ring.len();
    let sectors = if closed { k } else { k.saturating_sub(1) };
    (0..sectors)
        .map(|m| {
            let a = positions[ring[m] as usize] - p;
            let b = positions[ring[(m + 1) % k] as usize] - p;
            a.norm() * b.norm()
        })
        .collect()
}

/// Bound on |μ_f32 − μ| at a slot of modulus |μ| = r^{a_k}, given the bound Δθ on the ring's θ
/// (its largest, [`theta_bound`] of the total) and the largest exponent a_max: a = c/θ_side has
/// relative error ρ_a ≤ 2Δθ·a_max/π + u (θ_side ≥ π/a_max; a side is a difference of two θ);
/// the angle a(θ_k − θ_s) + offset ≤ 3π is off by ≤ 2a_maxΔθ + 3πρ_a; the modulus r^a =
/// exp2(a log2 r) by ≤ |μ|(3a u + |ln r|a ρ_a + 4u); sin, cos and the products ≤ 4u|μ|.
pub fn mu_bound(modulus: f64, radius: f64, a_max: f64, dtheta: f64) -> f64 {
    let rho = a_relative_bound(a_max, dtheta);
    let angle = 2.0 * a_max * dtheta + 3.0 * std::f64::consts::PI * rho;
    modulus * (angle + 3.0 * a_max * U32 + radius.ln().abs() * a_max * rho + 8.0 * U32)
}

/// Bound on the relative error of a = c/θ_side: ρ_a ≤ 2Δθ·a_max/π + u (θ_side ≥ π/a_max is a
/// difference of two θ, each off by ≤ Δθ; the division adds u).
pub fn a_relative_bound(a_max: f64, dtheta: f64) -> f64 {
    2.0 * dtheta * a_max / std::f64::consts::PI + U32
}

/// Flattening on the GPU against the reference, from identical inputs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FlattenCrosscheck {
    /// Rings compared.
    pub rings: usize,
    /// |Δθ_k| in radians over every slot and total (tolerance: the largest [`theta_bound`]).
    pub theta: ErrorSummary,
    /// |Δa|/a (a and a₂) over the rings both sides flattened (tolerance: the largest
    /// [`a_relative_bound`]).
    pub a: ErrorSummary,
    /// |Δμ_k|/|μ_k| over the slots of rings both sides flattened (tolerance: the largest
    /// relative [`mu_bound`]).
    pub mu: ErrorSummary,
    /// Slots whose θ or μ error, rings whose a or a₂ error, exceeds its own bound.
    pub theta_over_bound: usize,
    pub a_over_bound: usize,
    pub mu_over_bound: usize,
    /// max error/bound.
    pub theta_worst_ratio: f64,
    pub mu_worst_ratio: f64,
    /// Rings the reference rejected (degenerate, flipped fan).
    pub rejected: usize,
    /// Rings whose kernel status differs from the reference's decision.
    pub status_mismatches: usize,
    /// Rings not compared because a ring vertex coincides with the centre once the positions
    /// are rounded to f32 (|a||b| = 0: the angle atan2(0, 0) is undefined on both sides).
    pub coincident_in_f32: usize,
}

/// Run `maps_flatten` on `rings` over `positions` and compare with [`flatten_cpu`] on the same
/// values, slot by slot against [`theta_bound`] and [`mu_bound`].
pub fn crosscheck_flatten(
    gpu: &Gpu,
    positions: &Normalised,
    rings: &LevelRings,
) -> Result<FlattenCrosscheck> {
    let batch = rings_batch(&positions.gpu, rings);
    let (flat, points) = flatten_gpu(gpu, &batch)?;
    let cpu = flatten_cpu(&positions.cpu, rings);
    let (mut theta_err, mut theta_mag, mut a_err, mut a_mag, mut mu_err, mut mu_mag) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut theta_over, mut mu_over, mut a_over, mut rejected, mut mismatches) = (0, 0, 0, 0, 0);
    let mut coincident = 0;
    let mut a_tol = 0.0f64;
    let (mut theta_ratio, mut mu_ratio, mut theta_tol, mut mu_tol) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (r, ((theta, mu), h)) in cpu.iter().zip(&batch.rings).enumerate() {
        let g = &flat[r];
        let slots = &points[h.first as usize..(h.first + h.count) as usize];
        let last = theta.len() - 1;
        let closed = !matches!(rings.shapes[r], RingShape::HalfDisk);
        let products =
            sector_edge_products(&positions.cpu, rings.vertices[r], &rings.rings[r], closed);
        if products.iter().any(|&x| !(x > 0.0)) {
            coincident += 1;
            continue;
        }
        // θ of every slot and the total.
        let mut pairs: Vec<(f64, f64, usize)> = slots
            .iter()
            .enumerate()
            .map(|(k, p)| (p.theta as f64, theta[k], k))
            .collect();
        pairs.push((g.theta_total as f64, theta[last], last));
        for (gt, ct, k) in pairs {
            let bound = theta_bound(theta, &products, k);
            let e = (gt - ct).abs();
            theta_err.push(e);
            theta_mag.push(ct);
            theta_tol = theta_tol.max(bound);
            theta_ratio = theta_ratio.max(e / bound.max(f64::MIN_POSITIVE));
            theta_over += usize::from(!(e <= bound));
        }
        let expected = match mu {
            Ok(_) => STATUS_OK,
            Err(FlattenReject::Degenerate) => STATUS_DEGENERATE,
            Err(FlattenReject::FlippedFan) => STATUS_FLIPPED_FAN,
        };
        mismatches += usize::from(g.status != expected);
        let Ok(mu) = mu else {
            rejected += 1;
            continue;
        };
        if g.status != STATUS_OK {
            continue;
        }
        let (a1, a2) = match rings.shapes[r] {
            RingShape::Disk => {
                let a = std::f64::consts::TAU / theta[last];
                (a, a)
            }
            RingShape::HalfDisk => {
                let a = std::f64::consts::PI / theta[last];
                (a, a)
            }
            RingShape::FeatureLine { s, t } => {
                let upper = theta[t] - theta[s];
                (
                    std::f64::consts::PI / upper,
                    std::f64::consts::PI / (theta[last] - upper),
                )
            }
        };
        let dtheta = theta_bound(theta, &products, last);
        let a_max = a1.max(a2);
        let rho = a_relative_bound(a_max, dtheta);
        a_tol = a_tol.max(rho);
        for (ga, ca) in [(g.a as f64, a1), (g.a2 as f64, a2)] {
            let e = (ga - ca).abs() / ca;
            a_err.push(e);
            a_mag.push(1.0);
            a_over += usize::from(!(e <= rho));
        }
        for (k, p) in slots.iter().enumerate() {
            let modulus = mu[k][0].hypot(mu[k][1]);
            let bound = mu_bound(modulus, p.radius as f64, a_max, dtheta);
            let e = (p.mu[0] as f64 - mu[k][0]).hypot(p.mu[1] as f64 - mu[k][1]);
            mu_err.push(e / modulus);
            mu_mag.push(1.0);
            mu_tol = mu_tol.max(bound / modulus);
            mu_ratio = mu_ratio.max(e / bound);
            mu_over += usize::from(!(e <= bound));
        }
    }
    Ok(FlattenCrosscheck {
        rings: rings.vertices.len(),
        theta: ErrorSummary::from_errors("radians", &theta_err, &theta_mag, theta_tol),
        a: ErrorSummary::from_errors("relative", &a_err, &a_mag, a_tol),
        mu: ErrorSummary::from_errors("relative to |μ_k|", &mu_err, &mu_mag, mu_tol),
        theta_over_bound: theta_over,
        a_over_bound: a_over,
        mu_over_bound: mu_over,
        theta_worst_ratio: theta_ratio,
        mu_worst_ratio: mu_ratio,
        rejected,
        coincident_in_f32: coincident,
        status_mismatches: mismatches,
    })
}

/// The hierarchy of `maps` in the `maps_inverse` layout ([`InverseTables`]): every decimation
/// face (input faces, then the faces of each removal, [`super::Param::face`]) with the removal
/// that created it, per face μ of its corners in the planes of the removals that created and
/// deleted it (rounded to f32; the removed vertex at 0), per removal its old faces, the base
/// faces (the faces no removal deleted, in id order: [`Maps::base_faces`]'s order), and the
/// positions of `positions` ([`normalise`]).
pub fn inverse_tables(maps: &Maps, positions: &Normalised) -> InverseTables {
    let param = &maps.param;
    let records = param.removals();
    let total =
        maps.input_faces.len() + records.iter().map(|r| r.new_count as usize).sum::<usize>();
    let mut faces: Vec<DecimationFace> = (0..total as u32)
        .map(|f| DecimationFace {
            corners: param.face(f),
            created_by: NONE,
        })
        .collect();
    let mut charts = vec![FaceCharts::default(); total];
    let mut removed = vec![false; total];
    let mut removals = Vec::with_capacity(records.len());
    let mut old_faces = Vec::new();
    for (index, r) in records.iter().enumerate() {
        let mu_of = |v: u32| {
            r.ring
                .iter()
                .position(|&w| w == v)
                .map_or([0.0; 2], |m| r.mu[m].map(|x| x as f32))
        };
        removals.push([old_faces.len() as u32, r.old_faces.len() as u32]);
        for &g in &r.old_faces {
            old_faces.push(g);
            removed[g as usize] = true;
            charts[g as usize].removed = faces[g as usize].corners.map(mu_of);
        }
        for f in r.new_first..r.new_first + r.new_count {
            faces[f as usize].created_by = index as u32;
            charts[f as usize].created = faces[f as usize].corners.map(mu_of);
        }
    }
    InverseTables {
        positions: positions.gpu.clone(),
        faces,
        charts,
        removals,
        old_faces,
        base_to_face: (0..total as u32)
            .filter(|&f| !removed[f as usize])
            .collect(),
    }
}

/// The base points in the kernel's layout (barycentrics rounded to f32).
pub fn base_queries(points: &[BasePoint]) -> Vec<BaseQuery> {
    points
        .iter()
        .map(|p| BaseQuery {
            bary: p.bary.map(|x| x as f32),
            face: p.face,
        })
        .collect()
}

/// Π⁻¹ of `points` on the GPU over `tables` (positions in the tables' normalised frame).
pub fn inverse_gpu(
    gpu: &Gpu,
    tables: &InverseTables,
    points: &[BasePoint],
) -> Result<Vec<InverseResult>> {
    InverseKernel::new(gpu, tables)
        .and_then(|k| k.run(gpu, &base_queries(points)))
        .map_err(gpu_error)
}

/// The smallest altitude of triangle (p, q, r): 2·area / longest edge.
pub fn smallest_altitude(p: &Point3<f64>, q: &Point3<f64>, r: &Point3<f64>) -> f64 {
    let longest = (q - p).norm().max((r - q).norm()).max((p - r).norm());
    (q - p).cross(&(r - p)).norm() / longest
}

/// Π⁻¹ on the GPU against [`super::Param::inverse`] (the figures).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct InverseCrosscheck {
    /// Points compared.
    pub points: usize,
    /// |Δp| as a fraction of the bounding box diagonal (tolerance 1e-5, the issue's).
    pub position: ErrorSummary,
    /// max_c |Δb_c| over the points that reached the same input face, whose smallest altitude
    /// exceeds 1e-3 of the diagonal (its tolerance the largest of `bary_bounds`).
    pub bary: ErrorSummary,
    /// Per compared point (the order of `bary`'s errors): max_c |Δb_c| …
    pub bary_errors: Vec<f64>,
    /// … and its bound, `position_bound / h` with h the face's smallest altitude (fraction of
    /// the diagonal): |∇b_c| = 1/h_c, so a point moved by |Δp| in the face's plane moves each
    /// barycentric by at most |Δp|/h.
    pub bary_bounds: Vec<f64>,
    /// Points the kernel took to another input face than the reference.
    pub face_mismatches: usize,
    /// The largest reference barycentric distance to an edge, min_c b_c, among those points
    /// (small: a point changes face only next to an edge).
    pub mismatch_max_min_bary: f64,
    /// Points whose face's smallest altitude is below 1e-3 of the diagonal (bary not compared).
    pub thin: usize,
}

/// Run `maps_inverse` on `points` and compare with [`super::Param::inverse`] (module docs).
/// [`Error::InvalidArgument`] for a base point the reference cannot map (face out of range).
///
/// `position_bound` is the bound on |Δp| (fraction of the diagonal) from which each compared
/// point's barycentric bound follows (`bary_bounds`).
pub fn crosscheck_inverse(
    gpu: &Gpu,
    maps: &Maps,
    points: &[BasePoint],
    position_bound: f64,
) -> Result<InverseCrosscheck> {
    let norm = normalise(&maps.positions)?;
    let tables = inverse_tables(maps, &norm);
    let gpu_points = inverse_gpu(gpu, &tables, points)?;
    let (mut pos_err, mut pos_mag, mut bary_err, mut bary_mag) = (vec![], vec![], vec![], vec![]);
    let mut bary_bound = vec![];
    let (mut mismatches, mut mismatch_min, mut thin) = (0, 0.0f64, 0);
    for (p, g) in points.iter().zip(&gpu_points) {
        let c = maps.param.inverse(p).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "base point in face {} of {}",
                p.face,
                maps.base_faces.len()
            ))
        })?;
        let expected = norm.apply(&c.position);
        let got = Point3::new(
            g.position[0] as f64,
            g.position[1] as f64,
            g.position[2] as f64,
        );
        pos_err.push((got - expected).norm());
        pos_mag.push(expected.coords.norm());
        if g.face != c.face {
            mismatches += 1;
            mismatch_min = mismatch_min.max(c.bary.iter().copied().fold(f64::INFINITY, f64::min));
            continue;
        }
        let [a, b, d] =
            maps.input_faces[c.face as usize].map(|v| norm.apply(&maps.positions[v as usize]));
        let h = smallest_altitude(&a, &b, &d);
        if h <= 1e-3 {
            thin += 1;
            continue;
        }
        bary_bound.push(position_bound / h);
        let e = (0..3)
            .map(|k| (g.bary[k] as f64 - c.bary[k]).abs())
            .fold(0.0, f64::max);
        bary_err.push(e);
        bary_mag.push(1.0);
    }
    Ok(InverseCrosscheck {
        points: points.len(),
        position: ErrorSummary::from_errors("fraction of the diagonal", &pos_err, &pos_mag, 1e-5),
        bary: ErrorSummary::from_errors(
            "barycentric",
            &bary_err,
            &bary_mag,
            bary_bound.iter().copied().fold(0.0, f64::max),
        ),
        bary_errors: bary_err,
        bary_bounds: bary_bound,
        face_mismatches: mismatches,
        mismatch_max_min_bary: mismatch_min,
        thin,
    })
}
