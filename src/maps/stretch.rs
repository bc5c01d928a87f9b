//! Sander, Snyder, Gortler and Hoppe's L² stretch (SIGGRAPH 2001, "Texture Mapping Progressive
//! Meshes", §3 "Texture stretch metric"): the energy that [`super::equalise`] minimises (beyond
//! the MAPS paper; issue #37).
//!
//! A parameter triangle q = (q₁, q₂, q₃) ⊂ ℝ² mapped affinely onto a 3D triangle
//! p = (p₁, p₂, p₃) has the Jacobian J = P Q⁻¹, with P = [p₂ − p₁, p₃ − p₁] (3×2) and
//! Q = [q₂ − q₁, q₃ − q₁] (2×2). Its columns are the paper's S_s and S_t, and the paper's
//! per-triangle L² stretch is
//!
//! L²(T)² = (Γ² + γ²)/2 = (S_s·S_s + S_t·S_t)/2 = ‖J‖²_F / 2 = tr(G Q⁻¹ Q⁻ᵀ)/2, G = PᵀP,
//!
//! the root-mean-square stretch over all directions of the parameter plane. The mesh's is
//! L²(M) = √(Σ_T A(T) L²(T)² / Σ_T A(T)), A(T) the 3D area, scaled by √(Σ A'(T) / Σ A(T)), A'
//! the parameter area, so that 1 is its least value (an isometry up to one global scale).
//! As det Q → 0⁺ a triangle's stretch grows without bound, so a descent that keeps every
//! det Q > 0 never folds the parameterisation. For a triangle mapped by a similarity of scale s,
//! ‖J‖² = 2 s² = 2 A/A', and Σ A · A/A' under a fixed Σ A' is least when A' ∝ A (Lagrange:
//! A²/A'² is the same for every triangle): minimising it makes the parameter area follow the
//! surface's area.
//!
//! [`weighted_stretch`] adds μ A' L²(T)², the Dirichlet energy of the same map, which is at
//! least A (= A' σ₁σ₂ ≤ A' (σ₁² + σ₂²)/2) with equality only for a conformal map: its excess over
//! the fixed Σ A charges anisotropy, which stretch alone tolerates where it equalises area
//! (measured in `src/maps/README.md`: slivers of the remesh that face the wrong way).

use nalgebra::{Matrix2, Matrix3x2};

/// The fixed 3D side of a triangle's stretch: G = PᵀP of its edge vectors from the first corner,
/// and its 3D area A.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StretchTarget {
    /// G = PᵀP, P = [p₂ − p₁, p₃ − p₁].
    pub gram: Matrix2<f64>,
    /// A = ½ √det G, the 3D area (the triangle's weight in the energy).
    pub area: f64,
}

impl StretchTarget {
    /// The target of the 3D triangle `p`.
    pub fn of(p: [[f64; 3]; 3]) -> StretchTarget {
        let m = Matrix3x2::new(
            p[1][0] - p[0][0],
            p[2][0] - p[0][0],
            p[1][1] - p[0][1],
            p[2][1] - p[0][1],
            p[1][2] - p[0][2],
            p[2][2] - p[0][2],
        );
        let gram = m.transpose() * m;
        StretchTarget {
            gram,
            area: 0.5 * gram.determinant().max(0.0).sqrt(),
        }
    }
}

/// (A + μ A') L²(T)² = (A + μ A') f, f = ‖J‖²_F / 2 = tr(G Q⁻¹ Q⁻ᵀ)/2, of the parameter
/// triangle `q` (module docs; μ = 0: Sander et al.'s A L²(T)²), and its gradient with respect
/// to q₁, q₂, q₃:
///
/// ∂f/∂Q = −Q⁻ᵀ G Q⁻¹ Q⁻ᵀ = −JᵀJ Q⁻ᵀ,  ∂A'/∂Q = A' Q⁻ᵀ (A' = det Q / 2),
/// ∂((A + μ A') f)/∂Q = −A JᵀJ Q⁻ᵀ + μ A' (f I − JᵀJ) Q⁻ᵀ,
///
/// whose columns are the derivatives by q₂ and q₃, and ∂/∂q₁ = −(∂/∂q₂ + ∂/∂q₃). `None` when
/// det Q ≤ 0 (a folded or degenerate parameter triangle: the energy is +∞ there).
pub fn weighted_stretch(
    target: &StretchTarget,
    q: [[f64; 2]; 3],
    mu: f64,
) -> Option<(f64, [[f64; 2]; 3])> {
    let qm = Matrix2::new(
        q[1][0] - q[0][0],
        q[2][0] - q[0][0],
        q[1][1] - q[0][1],
        q[2][1] - q[0][1],
    );
    let det = qm.determinant();
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    let inv = qm.try_inverse()?;
    let jtj = inv.transpose() * target.gram * inv;
    let f = 0.5 * jtj.trace();
    let parameter_area = 0.5 * det;
    let value = (target.area + mu * parameter_area) * f;
    let d = (-target.area * jtj + mu * parameter_area * (Matrix2::identity() * f - jtj))
        * inv.transpose();
    if !(value.is_finite() && d.iter().all(|x| x.is_finite())) {
        return None;
    }
    let g2 = [d[(0, 0)], d[(1, 0)]];
    let g3 = [d[(0, 1)], d[(1, 1)]];
    let g1 = [-(g2[0] + g3[0]), -(g2[1] + g3[1])];
    Some((value, [g1, g2, g3]))
}

/// Sander et al.'s L²(M) of a parameterisation given Σ_T A(T) L²(T)² (`energy`), Σ A(T)
/// (`area`) and Σ A'(T) (`parameter_area`): √(energy / area · parameter_area / area); 1 for an
/// isometry up to scale, larger otherwise.
pub fn l2_stretch(energy: f64, area: f64, parameter_area: f64) -> f64 {
    (energy / area * parameter_area / area).sqrt()
}

/// Half the cross product of (b − a) and (c − a): the signed area of a 2D triangle.
pub fn signed_area(q: [[f64; 2]; 3]) -> f64 {
    0.5 * ((q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[1][1] - q[0][1]) * (q[2][0] - q[0][0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An isometric parameter triangle has ‖J‖² = 2, so A · L² = A; scaling the parameter
    /// triangle by s divides ‖J‖² by s²; the Dirichlet term is μ A for a similarity and more
    /// for a sheared map.
    #[test]
    fn isometry_and_scale() -> Result<(), String> {
        let p = [[0.0, 0.0, 1.0], [2.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
        let t = StretchTarget::of(p);
        assert!((t.area - 1.0).abs() < 1e-15);
        let q = [[0.0, 0.0], [2.0, 0.0], [0.0, 1.0]];
        let (e, _) = weighted_stretch(&t, q, 0.0).ok_or("isometric triangle refused")?;
        assert!((e - 1.0).abs() < 1e-14, "{e}");
        let half = q.map(|x| [0.5 * x[0], 0.5 * x[1]]);
        let (e2, _) = weighted_stretch(&t, half, 0.0).ok_or("scaled triangle refused")?;
        assert!((e2 - 4.0).abs() < 1e-13, "{e2}");
        assert!(
            weighted_stretch(&t, [q[0], q[2], q[1]], 0.0).is_none(),
            "a folded triangle"
        );
        // The Dirichlet term of a similarity is μ A (A' f = A' · A/A'): 4 + 2 · 1 here.
        let (e3, _) = weighted_stretch(&t, half, 2.0).ok_or("scaled triangle refused")?;
        assert!((e3 - 6.0).abs() < 1e-13, "{e3}");
        // A sheared map of the same parameter area costs more than μ A in the Dirichlet term.
        let sheared = [[0.0, 0.0], [1.0, 0.0], [0.0, 2.0]];
        let (e4, _) = weighted_stretch(&t, sheared, 2.0).ok_or("sheared triangle refused")?;
        let (e5, _) = weighted_stretch(&t, sheared, 0.0).ok_or("sheared triangle refused")?;
        assert!(e4 - e5 > 2.0 * t.area + 0.1, "{e4} {e5}");
        let l2 = l2_stretch(e2, t.area, signed_area(half));
        assert!((l2 - 1.0).abs() < 1e-14, "a similarity has L²(M) = 1: {l2}");
        Ok(())
    }

    /// The gradient against central differences on a skewed triangle, with and without the
    /// Dirichlet term (error O(h²): h = 1e-6 on values of order 1 leaves ~1e-10 of truncation
    /// and ~1e-10 of rounding, ε/h).
    #[test]
    fn gradient_matches_differences() -> Result<(), String> {
        for mu in [0.0, 5.0] {
            gradient_check(mu)?;
        }
        Ok(())
    }

    fn gradient_check(mu: f64) -> Result<(), String> {
        let p = [[0.1, 0.2, 0.3], [1.3, -0.2, 0.5], [0.4, 0.9, -0.6]];
        let t = StretchTarget::of(p);
        let q = [[0.2, 0.1], [1.1, 0.3], [0.5, 0.8]];
        let (_, g) = weighted_stretch(&t, q, mu).ok_or("refused")?;
        let h = 1e-6;
        for c in 0..3 {
            for k in 0..2 {
                let mut plus = q;
                let mut minus = q;
                plus[c][k] += h;
                minus[c][k] -= h;
                let ep = weighted_stretch(&t, plus, mu).ok_or("refused")?.0;
                let em = weighted_stretch(&t, minus, mu).ok_or("refused")?.0;
                let fd = (ep - em) / (2.0 * h);
                assert!(
                    (fd - g[c][k]).abs() <= 1e-7 * (1.0 + fd.abs()),
                    "μ {mu}, corner {c} axis {k}: {fd} vs {}",
                    g[c][k]
                );
            }
        }
        Ok(())
    }
}
