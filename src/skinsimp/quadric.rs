//! Garland–Heckbert plane quadrics, one set per example pose (SPEC.md § 2).
//!
//! A quadric is the symmetric 4×4 matrix `Q` of `E(v̂) = v̂ᵀ Q v̂`, `v̂ = (v, 1)`, stored as its
//! 10 upper-triangle values. Per face `f` and pose `j`, with unit normal `n` and a corner `x₀`
//! of the posed triangle, `K_f^j = area_f^j · q qᵀ`, `q = (n, −n·x₀)`: the area-weighted squared
//! distance to the face's plane. A vertex's quadric in pose `j` is `Q_i^j = Σ_{f∋i} K_f^j`
//! (plus the boundary / seam constraint planes of [`edge_constraint`]), and a collapse sums
//! its endpoints' quadrics pose by pose.

use nalgebra::{Matrix4, Point3, Vector3, Vector4};

/// A symmetric 4×4 quadric: upper triangle `(xx, xy, xz, xw, yy, yz, yw, zz, zw, ww)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quadric(pub [f64; 10]);

impl Quadric {
    /// `w · q qᵀ` for the homogeneous plane `q = (n, d)` (the plane `n·x + d = 0`).
    pub fn from_plane(n: Vector3<f64>, d: f64, w: f64) -> Quadric {
        let q = [n.x, n.y, n.z, d];
        let mut a = [0.0; 10];
        let mut k = 0;
        for r in 0..4 {
            for c in r..4 {
                a[k] = w * q[r] * q[c];
                k += 1;
            }
        }
        Quadric(a)
    }

    /// `K_f = area · q qᵀ` of the triangle `(p0, p1, p2)`, `q = (n, −n·p0)` with the unit normal
    /// `n`. A degenerate (zero-area) triangle gives the zero quadric.
    pub fn from_triangle(p0: &Point3<f64>, p1: &Point3<f64>, p2: &Point3<f64>) -> Quadric {
        let cross = (p1 - p0).cross(&(p2 - p0));
        let twice_area = cross.norm();
        if twice_area == 0.0 || !twice_area.is_finite() {
            return Quadric::default();
        }
        let n = cross / twice_area;
        Quadric::from_plane(n, -n.dot(&p0.coords), 0.5 * twice_area)
    }

    /// `self + other`, element by element.
    pub fn add(&self, other: &Quadric) -> Quadric {
        let mut a = self.0;
        for (x, y) in a.iter_mut().zip(other.0.iter()) {
            *x += y;
        }
        Quadric(a)
    }

    /// Add `other` in place.
    pub fn add_assign(&mut self, other: &Quadric) {
        for (x, y) in self.0.iter_mut().zip(other.0.iter()) {
            *x += y;
        }
    }

    /// The full symmetric matrix `Q`.
    pub fn matrix(&self) -> Matrix4<f64> {
        let a = &self.0;
        Matrix4::new(
            a[0], a[1], a[2], a[3], //
            a[1], a[4], a[5], a[6], //
            a[2], a[5], a[7], a[8], //
            a[3], a[6], a[8], a[9],
        )
    }

    /// `v̂ᵀ Q v̂` for the point `v` (`v̂ = (v, 1)`).
    pub fn eval(&self, v: &Point3<f64>) -> f64 {
        let h = Vector4::new(v.x, v.y, v.z, 1.0);
        h.dot(&(self.matrix() * h))
    }
}

/// The constraint quadric that keeps a boundary or UV-seam edge in place (Garland–Heckbert
/// §6.1): the plane through the edge `(p0, p1)` perpendicular to its face (normal `face_n`,
/// unit), weighted by `weight · |p1 − p0|²` so that it scales like the face quadrics (area).
/// Zero for a degenerate edge or face.
pub fn edge_constraint(
    p0: &Point3<f64>,
    p1: &Point3<f64>,
    face_n: &Vector3<f64>,
    weight: f64,
) -> Quadric {
    let e = p1 - p0;
    let n = e.cross(face_n);
    let len = n.norm();
    if len == 0.0 || !len.is_finite() {
        return Quadric::default();
    }
    let n = n / len;
    Quadric::from_plane(n, -n.dot(&p0.coords), weight * e.norm_squared())
}

/// The unit normal of triangle `(p0, p1, p2)`, zero when degenerate.
pub fn unit_normal(p0: &Point3<f64>, p1: &Point3<f64>, p2: &Point3<f64>) -> Vector3<f64> {
    let c = (p1 - p0).cross(&(p2 - p0));
    let n = c.norm();
    if n == 0.0 || !n.is_finite() {
        Vector3::zeros()
    } else {
        c / n
    }
}
