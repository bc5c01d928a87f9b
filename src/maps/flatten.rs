//! Flattening a 1-ring with the conformal map z^a (notes "Flattening a 1-ring"; seed
//! "Constructing the Mesh Hierarchies (4/5)").

use nalgebra::Point3;

/// Why a 1-ring cannot be flattened (the vertex is then kept).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlattenReject {
    /// A ring edge has zero length or an angle is zero or not finite.
    Degenerate,
    /// A scaled sector angle a·φ_k ≥ π: the fan triangle would flip.
    FlippedFan,
}

/// How the 1-ring is cut before flattening.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RingShape {
    /// Closed ring, no feature edge at the centre: one disk, a = 2π/θ_K.
    Disk,
    /// Open ring (boundary vertex): one half disk, a = π/θ_K; the chord joins the two ends.
    HalfDisk,
    /// Closed ring cut by two feature edges to ring positions `s` and `t` (s < t): the arc
    /// s→t maps to the upper half disk, t→s to the lower one, each with a = π/θ_side; the
    /// chord s–t is the image of the feature line.
    FeatureLine { s: usize, t: usize },
}

/// Cumulative angles θ_k = Σ_{m≤k} ∠(p_{j_{m−1}}, p_i, p_{j_m}) along `ring` (θ_0 = 0),
/// one entry per ring vertex, plus the closing total θ_K for a closed ring as the last entry.
/// Angles are atan2(|a×b|, a·b), accurate for small and near-π angles alike.
pub fn cumulative_angles(centre: &Point3<f64>, ring: &[Point3<f64>], closed: bool) -> Vec<f64> {
    let k = ring.len();
    let sectors = if closed { k } else { k - 1 };
    let mut theta = Vec::with_capacity(sectors + 1);
    theta.push(0.0);
    for m in 0..sectors {
        let a = ring[m] - centre;
        let b = ring[(m + 1) % k] - centre;
        let phi = a.cross(&b).norm().atan2(a.dot(&b));
        theta.push(theta[m] + phi);
    }
    theta
}

/// The flattened 1-ring of vertex `centre`: μ(p_i) = 0 and
/// μ(p_{j_k}) = r_k^a e^{i(a θ_k + offset)} (notes; seed 4/5), with r_k = |p_{j_k} − p_i|,
/// θ_k cumulative ([`cumulative_angles`]), and per [`RingShape`]:
/// - Disk: a = 2π/θ_K, offset 0;
/// - HalfDisk: a = π/θ_K, offset 0 (the ends land on the real axis at angles 0 and π);
/// - FeatureLine: a₁ = π/θ(s→t), offset −a₁θ_s on the upper arc, a₂ = π/θ(t→s), offset π on the
///   lower arc; the chord ends μ(j_s), μ(j_t) are on the real axis with radius r^{(a₁+a₂)/2} so
///   both arcs agree on them (on a flat, straight feature line a₁ = a₂ = 1).
///
/// The chord ends are placed exactly on the real axis (y = 0), so the removed vertex (at 0) lies
/// exactly on the chord. Rejects the ring if a scaled sector angle a·φ_k ≥ π (a flipped fan
/// triangle) or a radius or angle is degenerate.
pub fn flatten_ring(
    centre: &Point3<f64>,
    ring: &[Point3<f64>],
    shape: RingShape,
) -> Result<Vec<[f64; 2]>, FlattenReject> {
    flatten_ring_with(centre, ring, shape, Flattening::Conformal)
}

/// What a flattening does to the radii; the angles are scaled by a in both.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Flattening {
    /// The paper's conformal map z^a: |μ_k| = r_k^a. Default.
    #[default]
    Conformal,
    /// Beyond the paper (issue #23): |μ_k| = r_k, the angles scaled by a as in z^a (a polar map
    /// that keeps distances from the removed vertex). Where a ≫ 1 (a sharp tip, θ_K ≪ 2π) z^a
    /// shrinks the ring's short spokes against its long ones by (r_short/r_long)^{a−1}, and the
    /// points re-stored near the tip with them; this map does not. The same guard (a·φ_k < π)
    /// keeps the fan positive; on a flat ring (a = 1) the two are the same map.
    Polar,
}

/// [`flatten_ring`] with the radii mapped by `map` ([`Flattening`]).
pub fn flatten_ring_with(
    centre: &Point3<f64>,
    ring: &[Point3<f64>],
    shape: RingShape,
    map: Flattening,
) -> Result<Vec<[f64; 2]>, FlattenReject> {
    let closed = !matches!(shape, RingShape::HalfDisk);
    let theta = cumulative_angles(centre, ring, closed);
    let radii: Vec<f64> = ring.iter().map(|p| (p - centre).norm()).collect();
    let sane = radii.iter().all(|r| *r > 0.0 && r.is_finite())
        && theta.windows(2).all(|w| w[1] > w[0] && w[1].is_finite());
    if !sane {
        return Err(FlattenReject::Degenerate);
    }
    check_shape(&theta, shape)?;
    let mu = ring_mu(&theta, &radii, shape, map);
    if mu.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
        return Err(FlattenReject::Degenerate);
    }
    Ok(mu)
}

/// The exponents (a, a₂) of a ring with cumulative angles `theta` ([`cumulative_angles`]):
/// (2π/θ_K, the same) for a disk, (π/θ_{K−1}, the same) for a half disk, (π/(θ_t − θ_s),
/// π/(θ_K − (θ_t − θ_s))) for a feature line (upper side s → t, lower side t → s).
pub fn ring_exponents(theta: &[f64], shape: RingShape) -> (f64, f64) {
    let last = theta[theta.len() - 1];
    match shape {
        RingShape::Disk => {
            let a = 2.0 * std::f64::consts::PI / last;
            (a, a)
        }
        RingShape::HalfDisk => {
            let a = std::f64::consts::PI / last;
            (a, a)
        }
        RingShape::FeatureLine { s, t } => {
            let upper = theta[t] - theta[s];
            (
                std::f64::consts::PI / upper,
                std::f64::consts::PI / (last - upper),
            )
        }
    }
}

/// The guards of [`flatten_ring`] for `shape` ([`check_sectors`] on each side): a flipped fan
/// when a scaled sector angle reaches π.
fn check_shape(theta: &[f64], shape: RingShape) -> Result<(), FlattenReject> {
    let k = match shape {
        RingShape::HalfDisk => theta.len(),
        _ => theta.len() - 1,
    };
    let (a1, a2) = ring_exponents(theta, shape);
    match shape {
        RingShape::Disk => check_sectors(theta, &[(0, k)], a1),
        RingShape::HalfDisk => check_sectors(theta, &[(0, k - 1)], a1),
        RingShape::FeatureLine { s, t } => {
            check_sectors(theta, &[(s, t)], a1)?;
            check_sectors(theta, &[(t, k), (0, s)], a2)
        }
    }
}

/// The formulas of [`flatten_ring_with`] without its guards: μ_k of every ring slot from the
/// cumulative angles `theta` and the radii `radii` (the notes' z^a, or the polar map, per
/// `map`), with the exponents of [`ring_exponents`]. [`flatten_ring_with`] returns these when
/// the ring passes its guards; the conformance vectors of `maps_flatten` also hold them for a
/// flipped fan (the kernel writes μ whatever the status).
pub fn ring_mu(theta: &[f64], radii: &[f64], shape: RingShape, map: Flattening) -> Vec<[f64; 2]> {
    let k = radii.len();
    let (a1, a2) = ring_exponents(theta, shape);
    let modulus = |r: f64, a: f64| match map {
        Flattening::Conformal => r.powf(a),
        Flattening::Polar => r,
    };
    let polar = |r: f64, a: f64, angle: f64| -> [f64; 2] {
        let rho = modulus(r, a);
        [rho * angle.cos(), rho * angle.sin()]
    };
    let mut mu = vec![[0.0; 2]; k];
    match shape {
        RingShape::Disk => {
            for m in 0..k {
                mu[m] = polar(radii[m], a1, a1 * theta[m]);
            }
            mu[0] = [modulus(radii[0], a1), 0.0];
        }
        RingShape::HalfDisk => {
            for m in 1..k - 1 {
                mu[m] = polar(radii[m], a1, a1 * theta[m]);
            }
            mu[0] = [modulus(radii[0], a1), 0.0];
            mu[k - 1] = [-modulus(radii[k - 1], a1), 0.0];
        }
        RingShape::FeatureLine { s, t } => {
            let total = theta[k];
            for m in 0..k {
                mu[m] = if m > s && m < t {
                    polar(radii[m], a1, a1 * (theta[m] - theta[s]))
                } else {
                    // Lower arc: angle measured from j_t onwards, wrapping past j_0.
                    let from_t = if m > t {
                        theta[m] - theta[t]
                    } else {
                        theta[m] + total - theta[t]
                    };
                    polar(radii[m], a2, std::f64::consts::PI + a2 * from_t)
                };
            }
            let a_mid = 0.5 * (a1 + a2);
            mu[s] = [modulus(radii[s], a_mid), 0.0];
            mu[t] = [-modulus(radii[t], a_mid), 0.0];
        }
    }
    mu
}

/// Guard of the notes: every scaled sector angle a·(θ_{m+1} − θ_m) of one side is < π.
///
/// By the triangle inequality for angles between directions, a sector of a closed ring is at
/// most the sum of the others, so a·φ_k ≤ π always, with equality only for a degenerate ring;
/// on a half disk (a = π/θ_side) equality holds exactly when the side has a single sector. That
/// case is rejected explicitly (rounding could make a·φ land a hair below π), the others by the
/// comparison.
/// `ranges` are the sector index ranges of one side (the lower side of a feature line wraps
/// past j_0, so it has two).
fn check_sectors(theta: &[f64], ranges: &[(usize, usize)], a: f64) -> Result<(), FlattenReject> {
    if ranges.iter().map(|(from, to)| to - from).sum::<usize>() == 1 {
        return Err(FlattenReject::FlippedFan);
    }
    for &(from, to) in ranges {
        for m in from..to {
            if a * (theta[m + 1] - theta[m]) >= std::f64::consts::PI {
                return Err(FlattenReject::FlippedFan);
            }
        }
    }
    Ok(())
}
