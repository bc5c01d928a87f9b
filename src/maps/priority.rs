//! Removal priority w(λ, i) (notes "Hierarchy"; seed "Constructing the Mesh Hierarchies (2/5)"
//! and "Notation (4/4)").

use nalgebra::{Matrix3, Point3, Vector3};

/// 1-ring area a(i) = Σ over the faces of star(i) of ½|(q − p) × (r − p)|.
pub fn ring_area(positions: &[Point3<f64>], star: &[[u32; 3]]) -> f64 {
    star.iter()
        .map(|f| {
            triangle_area(
                &positions[f[0] as usize],
                &positions[f[1] as usize],
                &positions[f[2] as usize],
            )
        })
        .sum()
}

/// Area of the triangle (p, q, r).
pub fn triangle_area(p: &Point3<f64>, q: &Point3<f64>, r: &Point3<f64>) -> f64 {
    0.5 * (q - p).cross(&(r - p)).norm()
}

/// Area-weighted normal Σ (q − p) × (r − p) of `star` (not normalised; zero if degenerate).
pub fn star_normal(positions: &[Point3<f64>], star: &[[u32; 3]]) -> Vector3<f64> {
    star.iter().fold(Vector3::zeros(), |n, f| {
        let [p, q, r] = f.map(|v| positions[v as usize]);
        n + (q - p).cross(&(r - p))
    })
}

/// Two unit tangents `e1 = n × h / |n × h|`, `e2 = n × e1` completing the unit normal `n` to a
/// right-handed frame (`h` = x, or y when `n` is within 26° of x): the frame of the local fit
/// in [`curvature`].
pub fn tangent_frame(n: &Vector3<f64>) -> [Vector3<f64>; 2] {
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = n.cross(&helper).normalize();
    [e1, n.cross(&e1)]
}

/// Curvature magnitude κ(i) = |κ₁| + |κ₂| from a local fit (seed "Notation (4/4)"): in the frame
/// (e₁, e₂, n) at p_i, n the area-weighted star normal, fit the height z = A x² + B xy + C y² of
/// the ring vertices by least squares; the shape operator is [[2A, B], [B, 2C]] with eigenvalues
/// κ₁,₂ = (A + C) ± √((A − C)² + B²). Returns 0 when the normal or the 3×3 normal equations are
/// degenerate (fewer than three independent directions), so no NaN reaches the priority.
///
/// **Departure, stated:** the seed writes κ(i) = κ₁ + κ₂ (twice the mean curvature). Taken
/// literally that sum is 0 at a saddle, however sharp, and negative in a concave region, so a
/// vertex at the crease of a saddle would look flat and be removed first; the priority needs a
/// magnitude that is large wherever the surface bends, which the seed's "conservative curvature
/// estimate" intends. |κ₁| + |κ₂| equals the seed's κ₁ + κ₂ wherever both are ≥ 0 (convex
/// regions) and bounds |κ₁ + κ₂| everywhere.
pub fn curvature(centre: &Point3<f64>, ring: &[Point3<f64>], normal: &Vector3<f64>) -> f64 {
    let len = normal.norm();
    if len.is_nan() || len <= 0.0 || ring.len() < 3 {
        return 0.0;
    }
    let n = normal / len;
    let [e1, e2] = tangent_frame(&n);
    let mut m = Matrix3::zeros();
    let mut rhs = Vector3::zeros();
    for q in ring {
        let d = q - centre;
        let (x, y, z) = (d.dot(&e1), d.dot(&e2), d.dot(&n));
        let row = Vector3::new(x * x, x * y, y * y);
        m += row * row.transpose();
        rhs += row * z;
    }
    let Some(inv) = m.try_inverse() else {
        return 0.0;
    };
    let coef = inv * rhs;
    let (a, b, c) = (coef.x, coef.y, coef.z);
    let mean = a + c;
    let dev = ((a - c) * (a - c) + b * b).sqrt();
    let k = (mean + dev).abs() + (mean - dev).abs();
    if k.is_finite() {
        k
    } else {
        0.0
    }
}

/// w(λ, i) = λ a(i)/max a + (1 − λ) κ(i)/max κ (seed 2/5), maxima over the level's candidates.
/// A term whose maximum is 0 (a flat mesh has κ ≡ 0) contributes 0.
pub fn priorities(lambda: f64, area: &[f64], kappa: &[f64]) -> Vec<f64> {
    let max_a = area.iter().fold(0.0f64, |m, &x| m.max(x));
    let max_k = kappa.iter().fold(0.0f64, |m, &x| m.max(x));
    area.iter()
        .zip(kappa)
        .map(|(&a, &k)| {
            let ta = if max_a > 0.0 { a / max_a } else { 0.0 };
            let tk = if max_k > 0.0 { k / max_k } else { 0.0 };
            lambda * ta + (1.0 - lambda) * tk
        })
        .collect()
}

/// Beyond the paper (issue #23, [`crate::maps::MapsOptions::priority_quantile`]): w(λ, i) with
/// each term normalised by its `q`-quantile over the level's candidates instead of its maximum
/// and clamped to 1: w = λ min(a/a_q, 1) + (1 − λ) min(κ/κ_q, 1). A few extreme values (a
/// needle tip's κ, a huge flat triangle's a) then no longer squash the term to ≈ 0 for every
/// other vertex. A term whose quantile is 0 contributes 0. `q` ≥ 1 is the paper's [`priorities`].
pub fn priorities_quantile(lambda: f64, area: &[f64], kappa: &[f64], q: f64) -> Vec<f64> {
    if q >= 1.0 {
        return priorities(lambda, area, kappa);
    }
    let reference = |v: &[f64]| {
        let mut s: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
        s.sort_by(f64::total_cmp);
        crate::maps::distortion::quantile(&s, q.max(0.0))
    };
    let (ra, rk) = (reference(area), reference(kappa));
    area.iter()
        .zip(kappa)
        .map(|(&a, &k)| {
            let ta = if ra > 0.0 { (a / ra).min(1.0) } else { 0.0 };
            let tk = if rk > 0.0 { (k / rk).min(1.0) } else { 0.0 };
            lambda * ta + (1.0 - lambda) * tk
        })
        .collect()
}

/// Beyond the paper (issue #23, [`crate::maps::MapsOptions::shuffle_seed`]): a pseudo-random
/// visiting key in [0, 1) for `vertex` at `level` (SplitMix64 of seed, level and vertex), the
/// order the public ports use instead of w(λ, i). Deterministic: the same seed gives the same
/// hierarchy on any number of threads.
pub fn shuffle_key(seed: u64, level: usize, vertex: u32) -> f64 {
    let mut z = seed
        .wrapping_add((level as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add(u64::from(vertex).wrapping_mul(0xD1B5_4A32_D192_ED03));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}
