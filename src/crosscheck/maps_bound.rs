//! The bounds of the MAPS ring kernels `maps_priority` and `maps_flatten`, per ring and per
//! slot, derived by running their f32 twins ([`crate::twin::maps_priority`],
//! [`crate::twin::maps_flatten`]) over [`Lin`]: the WGSL accuracy table operation by operation
//! at this ring's magnitudes, through the conditioning of the formulas that follow. Written once
//! here and used by `crosscheck maps` ([`crate::maps::gpu`]), the conformance vectors
//! ([`crate::vectors::maps`]) and the tests.
//!
//! The kernels read the f32-rounded normalised positions and the reference runs on the same
//! values, so the inputs enter exactly. The bound of an output y is
//!
//!   2 · Σᵢ |∂y/∂eᵢ| aᵢ + |v(y) − y_ref|
//!
//! with aᵢ the table's allowance of operation i (one ULP per `+ − ×`, 2.5 per division, 4.5
//! per square root, 3 + 2|x| per `exp2`, 2⁻²¹ or 3 ULP per `log2`, 2⁻¹¹ absolute per `cos` and
//! `sin`, any order and fusion of a sum), ∂y/∂eᵢ the derivative of y with respect to a
//! perturbation there (one reverse sweep of the tape), the factor 2 for the neglected
//! second-order terms ([`crate::twin::lin`] says when first order is trusted), and v(y) the
//! twin's own f64 value: the kernel's formula's departure from the reference's, evaluated, not
//! assumed (Cephes' atan polynomial in `maps_flatten` against f64 `atan2`; f64 rounding of two
//! orders of evaluation elsewhere).
//!
//! **Why this and not a hand count** (issue #34): κ(i) is the end of a 3 × 3 least-squares
//! solve, κ = |κ₁| + |κ₂| = 2·max(|A + C|, √((A − C)² + B²)) of c = M⁻¹ rhs. A perturbation
//! δM, δrhs moves c by M⁻¹(δrhs − δM c), and κ by the component of that change along ∂κ/∂c —
//! not by ‖M⁻¹‖ (‖δrhs‖ + ‖δM‖ ‖c‖), which the former hand bound took for every component and
//! every rounding at once (each with its worst sign, the 4-Lipschitz constant of κ on top).
//! The roundings of M's entries are correlated (M = Σ row rowᵀ: a rounded row moves M along
//! row δrowᵀ + δrow rowᵀ, largely in the directions M⁻¹ weighs least), and ∂κ/∂c is 0 along
//! the deviation when the fit is umbilic-like (|A + C| > dev). The tape sees all three; the
//! hand bound was 160 to 3000 times the lavapipe error on the real inputs (issue #34).
//!
//! Where the table promises nothing (a divisor within 16 times its bound of 0: a singular fit
//! det M ≈ 0, a normal that cancels; a sector decided within rounding of a·φ = π; `cos` or `sin`
//! of an angle outside [−π, π]) the bound is infinite: such an element is not compared by the
//! cross-check and not written to the vectors.

use nalgebra::Point3;

use crate::crosscheck::F32_FLUSH;
use crate::maps::flatten::{
    cumulative_angles, flatten_ring, ring_exponents, ring_mu, FlattenReject, Flattening, RingShape,
};
use crate::maps::priority::{curvature, ring_area, star_normal};
use crate::twin::lin::{self, first_order_bound, first_order_bound2, Lin, SECOND_ORDER};
use crate::twin::maps_flatten::{
    flatten_ring as twin_flatten, STATUS_DEGENERATE, STATUS_FLIPPED_FAN, STATUS_OK,
};
use crate::twin::maps_priority::{
    priority_terms, Ring, KIND_DISK, KIND_FEATURE_LINE, KIND_HALF_DISK,
};
use crate::twin::{Real, V3};

/// The kernels' ring kind and feature positions (s, t) of a [`RingShape`].
pub fn kind_of(shape: RingShape) -> (u32, usize, usize) {
    match shape {
        RingShape::Disk => (KIND_DISK, 0, 0),
        RingShape::HalfDisk => (KIND_HALF_DISK, 0, 0),
        RingShape::FeatureLine { s, t } => (KIND_FEATURE_LINE, s, t),
    }
}

/// The twin's ring of vertex `centre` with ring vertices `ring` over `positions`, each
/// coordinate lifted into `R` by `lift` (an f32 as [`crate::twin::F`], an exact input as
/// [`Lin::exact`]).
pub fn twin_ring<R: Real>(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    shape: RingShape,
    lift: impl Fn(f64) -> R,
) -> Ring<R> {
    let point = |v: u32| {
        let p = positions[v as usize];
        V3::new(lift(p.x), lift(p.y), lift(p.z))
    };
    let (kind, s, t) = kind_of(shape);
    Ring {
        centre: point(centre),
        points: ring.iter().map(|&v| point(v)).collect(),
        kind,
        s,
        t,
    }
}

/// 2 · (first-order bound of y) + |v(y) − reference|, and at least 2⁻¹²⁶ (what a flushed
/// subnormal may lose: an output the kernel writes as a literal 0, θ₀ or a chord end's μ_y, is
/// held to that and no bound is 0); ∞ where the analysis is ambiguous.
fn bound_of(y: Lin, reference: f64, ambiguous: bool) -> f64 {
    if ambiguous {
        return f64::INFINITY;
    }
    let b = (SECOND_ORDER * first_order_bound(y) + (y.v - reference).abs()).max(F32_FLUSH);
    if b.is_finite() {
        b
    } else {
        f64::INFINITY
    }
}

/// The reference's priority terms [a(i), κ(i)] of one ring ([`ring_area`] of its `star`,
/// [`curvature`] with the [`star_normal`]).
pub fn priority_reference(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    star: &[[u32; 3]],
) -> [f64; 2] {
    let pts: Vec<Point3<f64>> = ring.iter().map(|&w| positions[w as usize]).collect();
    [
        ring_area(positions, star),
        curvature(
            &positions[centre as usize],
            &pts,
            &star_normal(positions, star),
        ),
    ]
}

/// The bounds [on |Δa|, on |Δκ|] of one ring whose reference terms are `reference` (module
/// docs; ∞ where the table gives none, e.g. a singular fit).
pub fn priority_bounds(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    shape: RingShape,
    reference: [f64; 2],
) -> [f64; 2] {
    let ((area, kappa), ambiguous) = lin::record(|| {
        let h = twin_ring(positions, centre, ring, shape, Lin::exact);
        let [a, k] = priority_terms(&h);
        (
            bound_of(a, reference[0], false),
            bound_of(k, reference[1], false),
        )
    });
    // The area takes no decision and no division: its bound stands even where κ's analysis
    // found a singular fit.
    [area, if ambiguous { f64::INFINITY } else { kappa }]
}

/// The reference's flattening of one ring in the kernel's layout: per slot (μ_x, μ_y, θ_k, r_k),
/// per ring (a, a₂, θ_total, status). μ is the formula's ([`ring_mu`]) whatever the status, as
/// the kernel writes it, and 0 (with a = a₂ = 0) for a degenerate ring.
#[derive(Clone, Debug, PartialEq)]
pub struct FlattenReference {
    pub points: Vec<[f64; 4]>,
    pub ring: [f64; 4],
}

/// The kernel's status code of the reference's decision.
pub fn status_code(result: &Result<Vec<[f64; 2]>, FlattenReject>) -> u32 {
    match result {
        Ok(_) => STATUS_OK,
        Err(FlattenReject::Degenerate) => STATUS_DEGENERATE,
        Err(FlattenReject::FlippedFan) => STATUS_FLIPPED_FAN,
    }
}

/// [`FlattenReference`] of vertex `centre` with ring `ring` and `shape` over `positions`.
pub fn flatten_reference(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    shape: RingShape,
) -> FlattenReference {
    let c = positions[centre as usize];
    let pts: Vec<Point3<f64>> = ring.iter().map(|&w| positions[w as usize]).collect();
    let closed = !matches!(shape, RingShape::HalfDisk);
    let theta = cumulative_angles(&c, &pts, closed);
    let radii: Vec<f64> = pts.iter().map(|p| (p - c).norm()).collect();
    let result = flatten_ring(&c, &pts, shape);
    let status = status_code(&result);
    let (mu, (a1, a2)) = if status == STATUS_DEGENERATE {
        (vec![[0.0; 2]; pts.len()], (0.0, 0.0))
    } else {
        (
            ring_mu(&theta, &radii, shape, Flattening::Conformal),
            ring_exponents(&theta, shape),
        )
    };
    FlattenReference {
        points: (0..pts.len())
            .map(|k| [mu[k][0], mu[k][1], theta[k], radii[k]])
            .collect(),
        ring: [a1, a2, theta[theta.len() - 1], f64::from(status)],
    }
}

/// The bounds of one ring's flattening against its [`FlattenReference`]: per slot the bounds
/// on (|Δμ_x|, |Δμ_y|, |Δθ_k|, |Δr_k|) and on |Δμ_k|₂, per ring on (|Δa|, |Δa₂|, |Δθ_total|);
/// `None` where the table gives none (module docs). The status has no rounding bound: it is a
/// decision, and a decision within rounding of its threshold makes the ring ambiguous.
#[derive(Clone, Debug, PartialEq)]
pub struct FlattenBounds {
    pub points: Vec<[f64; 4]>,
    pub mu_norm: Vec<f64>,
    pub ring: [f64; 3],
}

/// [`FlattenBounds`] of a ring (the arguments of [`flatten_reference`] and its result).
pub fn flatten_bounds(
    positions: &[Point3<f64>],
    centre: u32,
    ring: &[u32],
    shape: RingShape,
    reference: &FlattenReference,
) -> Option<FlattenBounds> {
    let (bounds, ambiguous) = lin::record(|| {
        let h = twin_ring(positions, centre, ring, shape, Lin::exact);
        let (out, points) = twin_flatten(&h);
        let per_slot: Vec<([f64; 4], f64)> = points
            .iter()
            .zip(&reference.points)
            .map(|(p, r)| {
                let values = [p.mu.x, p.mu.y, p.theta, p.radius];
                let b: [f64; 4] = std::array::from_fn(|i| bound_of(values[i], r[i], false));
                let method = (p.mu.x.v - r[0]).hypot(p.mu.y.v - r[1]);
                let norm =
                    (SECOND_ORDER * first_order_bound2(p.mu.x, p.mu.y) + method).max(F32_FLUSH);
                (b, norm)
            })
            .collect();
        let ring = [out.a, out.a2, out.theta_total];
        let ring: [f64; 3] = std::array::from_fn(|i| bound_of(ring[i], reference.ring[i], false));
        (per_slot, ring, f64::from(out.status))
    });
    let (per_slot, ring, status) = bounds;
    if ambiguous || status != reference.ring[3] {
        return None;
    }
    let all_finite = ring.iter().all(|b| b.is_finite())
        && per_slot
            .iter()
            .all(|(b, n)| n.is_finite() && b.iter().all(|x| x.is_finite()));
    all_finite.then(|| FlattenBounds {
        points: per_slot.iter().map(|(b, _)| *b).collect(),
        mu_norm: per_slot.iter().map(|(_, n)| *n).collect(),
        ring,
    })
}
