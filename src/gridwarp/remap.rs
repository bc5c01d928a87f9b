//! The remapping of the ROI's parameter space by the warped grid (seed §6): F_s maps the rest
//! lines ŝ to the warped lines s piecewise linearly (F_t likewise); both are strictly increasing,
//! hence invertible. Altering texture coordinates uses the inverses: a surface point with ROI
//! coordinates (s, t) shows the texture at (F_s⁻¹(s), F_t⁻¹(t)).

use super::grid::Grid;

/// Piecewise-linear map through the points (from[i], to[i]) (both strictly increasing, from 0 to
/// 1), clamped outside [0, 1].
pub fn piecewise_linear(from: &[f64], to: &[f64], x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    let i = from.partition_point(|&v| v <= x).clamp(1, from.len() - 1) - 1;
    let alpha = (x - from[i]) / (from[i + 1] - from[i]);
    to[i] + alpha * (to[i + 1] - to[i])
}

/// F(s, t) = (F_s(s), F_t(t)): rest ROI coordinates to warped ones.
pub fn forward(rest: &Grid, warped: &Grid, st: [f64; 2]) -> [f64; 2] {
    [
        piecewise_linear(&rest.s, &warped.s, st[0]),
        piecewise_linear(&rest.t, &warped.t, st[1]),
    ]
}

/// F⁻¹(s, t) = (F_s⁻¹(s), F_t⁻¹(t)): warped ROI coordinates to rest ones (the texture lookup of
/// seed §6, "alter the texture coordinates").
pub fn inverse(rest: &Grid, warped: &Grid, st: [f64; 2]) -> [f64; 2] {
    [
        piecewise_linear(&warped.s, &rest.s, st[0]),
        piecewise_linear(&warped.t, &rest.t, st[1]),
    ]
}
