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
use super::grid::Grid;

/// Stretch of rigid content (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RigidStretch {
    pub mean: f64,
    pub max: f64,
}

/// Index of the cell of `lines` containing x (the last cell for x = 1).
fn cell_of(lines: &[f64], x: f64) -> usize {
    lines.partition_point(|&v| v <= x).clamp(1, lines.len() - 1) - 1
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
            let (i, j) = (cell_of(&rest_grid.s, s), cell_of(&rest_grid.t, t));
            let alpha = (s - rest_grid.s[i]) / (rest_grid.s[i + 1] - rest_grid.s[i]);
            let beta = (t - rest_grid.t[j]) / (rest_grid.t[j + 1] - rest_grid.t[j]);
            let a = (warped.s[i + 1] - warped.s[i]) / (rest_grid.s[i + 1] - rest_grid.s[i]);
            let b = (warped.t[j + 1] - warped.t[j]) / (rest_grid.t[j + 1] - rest_grid.t[j]);
            let p = (
                warped.s[i] + alpha * (warped.s[i + 1] - warped.s[i]),
                warped.t[j] + beta * (warped.t[j + 1] - warped.t[j]),
            );
            let v_s = (deformed.d_s.bilinear(p.0, p.1).value * a / rest.o_s.bilinear(s, t).value
                - 1.0)
                .abs();
            let v_t = (deformed.d_t.bilinear(p.0, p.1).value * b / rest.o_t.bilinear(s, t).value
                - 1.0)
                .abs();
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
