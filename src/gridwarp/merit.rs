//! The figure of merit of a warp: how much rigid texture content is stretched.
//!
//! At each point (s, t) of a regular lattice over the rest ROI, with a and b the slopes of the
//! remapping F_s, F_t there (the cell's a_i, b_j) and p = F(s, t) the warped point:
//!
//!   v_s = |‖D_s(p)‖ a / ‖O_s(s, t)‖ − 1|,  v_t = |‖D_t(p)‖ b / ‖O_t(s, t)‖ − 1|,
//!
//! the relative stretch of the texture along each axis (0 = as at rest). Reported: the
//! R-weighted mean Σ R (v_s + v_t)/2 / Σ R, and the max of (v_s, v_t) over rigid points
//! (R ≥ ½). For the rest grid, a = b = 1: the stretch the content would suffer without the warp.

use super::energy::{DeformedFields, RestFields};
use super::energy_naa::{DeformedJacobian, VertexGrid};
use super::grid::Grid;
use super::remap::{bilinear, cell_of, quad};

/// Stretch of rigid content (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RigidStretch {
    pub mean: f64,
    pub max: f64,
}

/// The R-weighted mean and rigid max of per-point stretches `stretch(s, t)` = (v_s, v_t) over a
/// `lattice`×`lattice` grid of rest points (module docs); points with R ≤ 0 are skipped.
pub fn rigid_stretch_over(
    rest: &RestFields,
    lattice: usize,
    stretch: impl Fn(f64, f64) -> (f64, f64),
) -> RigidStretch {
    let (mut weighted, mut weights, mut max) = (0.0, 0.0, 0.0f64);
    for y in 0..lattice {
        for x in 0..lattice {
            let (s, t) = (
                (x as f64 + 0.5) / lattice as f64,
                (y as f64 + 0.5) / lattice as f64,
            );
            let r = rest.rigidity.nearest(s, t);
            if r <= 0.0 {
                continue;
            }
            let (v_s, v_t) = stretch(s, t);
            weighted += r * 0.5 * (v_s + v_t);
            weights += r;
            if r >= 0.5 {
                max = max.max(v_s).max(v_t);
            }
        }
    }
    RigidStretch {
        mean: if weights > 0.0 {
            weighted / weights
        } else {
            0.0
        },
        max,
    }
}

/// The rigid-stretch figure of merit of `warped` (relative to `rest_grid`) on a
/// `lattice`×`lattice` grid of points.
pub fn rigid_stretch(
    rest: &RestFields,
    deformed: &DeformedFields,
    rest_grid: &Grid,
    warped: &Grid,
    lattice: usize,
) -> RigidStretch {
    rigid_stretch_over(rest, lattice, |s, t| {
        let (i, j) = (cell_of(&rest_grid.s, s), cell_of(&rest_grid.t, t));
        let alpha = (s - rest_grid.s[i]) / (rest_grid.s[i + 1] - rest_grid.s[i]);
        let beta = (t - rest_grid.t[j]) / (rest_grid.t[j + 1] - rest_grid.t[j]);
        let a = (warped.s[i + 1] - warped.s[i]) / (rest_grid.s[i + 1] - rest_grid.s[i]);
        let b = (warped.t[j + 1] - warped.t[j]) / (rest_grid.t[j + 1] - rest_grid.t[j]);
        let p = (
            warped.s[i] + alpha * (warped.s[i + 1] - warped.s[i]),
            warped.t[j] + beta * (warped.t[j + 1] - warped.t[j]),
        );
        let v_s =
            (deformed.d_s.bilinear(p.0, p.1).value * a / rest.o_s.bilinear(s, t).value - 1.0).abs();
        let v_t =
            (deformed.d_t.bilinear(p.0, p.1).value * b / rest.o_t.bilinear(s, t).value - 1.0).abs();
        (v_s, v_t)
    })
}

/// The rigid-stretch figure of merit of a non-axis-aligned warp (seed §8): at the rest point
/// (s, t) in rest cell (i, j) at (α, β), with W the cell's bilinear map onto the warped quad,
/// p = W(α, β), W_s = (∂W/∂α)/h_i, W_t = (∂W/∂β)/k_j and J_D = [D_s D_t] at p,
///
///   v_s = |‖J_D W_s‖ / ‖O_s(s, t)‖ − 1|,  v_t = |‖J_D W_t‖ / ‖O_t(s, t)‖ − 1|
///
/// (the NAA energy's q_s, q_t); for the rest vertices W_s = (1, 0), W_t = (0, 1) and this is the
/// stretch without the warp. Mean and max as in [`rigid_stretch`].
pub fn rigid_stretch_naa(
    rest: &RestFields,
    deformed: &DeformedJacobian,
    rest_grid: &Grid,
    warped: &VertexGrid,
    lattice: usize,
) -> RigidStretch {
    rigid_stretch_over(rest, lattice, |s, t| {
        let (i, j) = (cell_of(&rest_grid.s, s), cell_of(&rest_grid.t, t));
        let (h, k) = (
            rest_grid.s[i + 1] - rest_grid.s[i],
            rest_grid.t[j + 1] - rest_grid.t[j],
        );
        let (alpha, beta) = ((s - rest_grid.s[i]) / h, (t - rest_grid.t[j]) / k);
        let q = quad(warped, i, j);
        let p = bilinear(&q, alpha, beta);
        let w_s: [f64; 2] = std::array::from_fn(|c| {
            ((1.0 - beta) * (q[1][c] - q[0][c]) + beta * (q[3][c] - q[2][c])) / h
        });
        let w_t: [f64; 2] = std::array::from_fn(|c| {
            ((1.0 - alpha) * (q[2][c] - q[0][c]) + alpha * (q[3][c] - q[1][c])) / k
        });
        let ds = deformed.d_s.value(p[0], p[1]);
        let dt = deformed.d_t.value(p[0], p[1]);
        let image = |w: [f64; 2]| -> f64 {
            (0..3)
                .map(|c| (ds[c] * w[0] + dt[c] * w[1]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        (
            (image(w_s) / rest.o_s.bilinear(s, t).value - 1.0).abs(),
            (image(w_t) / rest.o_t.bilinear(s, t).value - 1.0).abs(),
        )
    })
}
