//! Evaluation of the BPM interpolant at a point of a triangle (seed steps 6–9), and
//! piecewise-linear interpolation through the same API.
//!
//! The WGSL twin is the `eval` family in `gpu/shaders/bpm_common.wgsl` (`edge_weights`,
//! `blended_log`, `eval_bpm`, `eval_linear`), used by both the `bpm_eval` compute kernel and
//! the fragment shader of the GPU renderer.

use num_complex::Complex64 as C;
use rayon::prelude::*;

use super::moebius::{c_abs, exp_with, mobius_apply, ExpLog, Sl2};
use super::precompute::{Bpm, Order, TriangleMaps};

/// Which interpolant to evaluate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
pub enum Interp {
    /// Blended piecewise Möbius maps. Default.
    #[default]
    Bpm,
    /// Piecewise-linear interpolation of the corner UVs.
    Linear,
}

impl std::str::FromStr for Interp {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "bpm" => Ok(Interp::Bpm),
            "linear" => Ok(Interp::Linear),
            _ => Err(format!(
                "unknown interpolation '{s}' (expected bpm or linear)"
            )),
        }
    }
}

/// Eight fixed barycentric points spread over a triangle's interior (centroid, near each corner,
/// near each edge midpoint, one off-centre), used where every face is sampled alike (benchmarks,
/// cross-checks).
pub const INTERIOR_POINTS: [[f64; 3]; 8] = [
    [1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0],
    [0.6, 0.2, 0.2],
    [0.2, 0.6, 0.2],
    [0.2, 0.2, 0.6],
    [0.45, 0.45, 0.1],
    [0.1, 0.45, 0.45],
    [0.45, 0.1, 0.45],
    [0.7, 0.25, 0.05],
];

/// The [`INTERIOR_POINTS`] of every face (and its three corners when `with_corners`).
pub fn face_samples(faces: usize, with_corners: bool) -> Vec<Sample> {
    const CORNERS: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let corners: &[[f64; 3]] = if with_corners { &CORNERS } else { &[] };
    (0..faces as u32)
        .flat_map(|face| {
            INTERIOR_POINTS
                .iter()
                .chain(corners)
                .map(move |&bary| Sample { face, bary })
        })
        .collect()
}

/// A point of the mesh: a face and the barycentric coordinates of its corners i, j, k.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub face: u32,
    pub bary: [f64; 3],
}

/// Edge-barycentric weights (γ_ij, γ_jk, γ_ki), product form (SPEC.md § 7):
///
///   γ_ij ∝ |ij| b_i b_j,  γ_jk ∝ |jk| b_j b_k,  γ_ki ∝ |ki| b_k b_i,  normalised to sum 1.
///
/// Identical to the seed's distance form (each distance to an edge line is 2·area·b/|edge|)
/// without distances or epsilon bands. 0/0 happens only exactly at a vertex, where the
/// interpolant equals the vertex's UV whatever the weights: there all weights are 0.
pub fn edge_weights(b: [f64; 3], z: &[C; 3]) -> [f64; 3] {
    let l_ij = c_abs(z[1] - z[0]);
    let l_jk = c_abs(z[2] - z[1]);
    let l_ki = c_abs(z[0] - z[2]);
    let g = [l_ij * b[0] * b[1], l_jk * b[1] * b[2], l_ki * b[2] * b[0]];
    let s = g[0] + g[1] + g[2];
    if s > 0.0 {
        [g[0] / s, g[1] / s, g[2] / s]
    } else {
        [0.0; 3]
    }
}

/// The seed's distance form of the edge-barycentric weights (seed step 6):
///
/// (a) within `eps` of a vertex: the two adjacent edges get ½, the third 0; (b) within `eps` of
/// an edge line: that edge gets 1; (c) otherwise γ_ij = d_jk d_ki / s with d the distances to
/// the edge lines and s = d_ij d_jk + d_jk d_ki + d_ki d_ij (and cyclically).
pub fn edge_weights_distance(b: [f64; 3], z: &[C; 3], eps: f64) -> [f64; 3] {
    let point = z[0] * b[0] + z[1] * b[1] + z[2] * b[2];
    let vertex_edges = [[2, 0], [0, 1], [1, 2]]; // edges (ki, ij) meet at i, (ij, jk) at j, ...
    for (v, edges) in vertex_edges.iter().enumerate() {
        if c_abs(point - z[v]) < eps {
            let mut g = [0.0; 3];
            g[edges[0]] = 0.5;
            g[edges[1]] = 0.5;
            return g;
        }
    }
    let d: [f64; 3] = std::array::from_fn(|e| distance_to_line(point, z[e], z[(e + 1) % 3]));
    if let Some(e) = (0..3).find(|&e| d[e] < eps) {
        let mut g = [0.0; 3];
        g[e] = 1.0;
        return g;
    }
    let s = d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
    [d[1] * d[2] / s, d[2] * d[0] / s, d[0] * d[1] / s]
}

fn distance_to_line(p: C, a: C, b: C) -> f64 {
    let (u, v) = (b - a, p - a);
    (u.re * v.im - u.im * v.re).abs() / c_abs(u)
}

/// Blended log ratio ℓ_t(z) = γ_ij ℓ_ij + γ_jk ℓ_jk + γ_ki ℓ_ki (seed step 7): a linear
/// combination in the vector space sl(2,C).
#[allow(clippy::needless_range_loop)] // e names the edge, as in the formula
pub fn blended_log(t: &TriangleMaps, gamma: [f64; 3]) -> Sl2 {
    let mut l = Sl2::ZERO;
    for e in 0..3 {
        l = l.add(&t.logs[e].scale(C::new(gamma[e], 0.0)));
    }
    l
}

/// f(z) = M_z(z) at the point with barycentrics `b` of triangle t (seed steps 6–9):
///
///   z = b_i z_i + b_j z_j + b_k z_k,  ℓ = blended_log(γ(b)),  E = exp(½ ℓ),
///   right order: f = w_origin + M_t(E(z))   (M_z = M_t exp(½ℓ)),
///   left order:  f = w_origin + E(M_t(z))   (M_z = exp(½ℓ) M_t, with left-form logs).
///
/// The order must match the one the logs were computed with ([`Bpm::options`]).
pub fn eval_bpm(t: &TriangleMaps, b: [f64; 3], exp_log: ExpLog, order: Order) -> C {
    let z = t.z[0] * b[0] + t.z[1] * b[1] + t.z[2] * b[2];
    let gamma = edge_weights(b, &t.z);
    let half_log = blended_log(t, gamma).scale(C::new(0.5, 0.0));
    let e = exp_with(&half_log, exp_log);
    let w = match order {
        Order::Right => mobius_apply(&t.m_t, mobius_apply(&e, z)),
        Order::Left => mobius_apply(&e, mobius_apply(&t.m_t, z)),
    };
    t.w_origin + w
}

/// Piecewise-linear interpolation b_i w_i + b_j w_j + b_k w_k.
pub fn eval_linear(t: &TriangleMaps, b: [f64; 3]) -> C {
    t.uv[0] * b[0] + t.uv[1] * b[1] + t.uv[2] * b[2]
}

impl Bpm {
    /// The interpolated UV at a point of face `face` with barycentrics `bary`. Degenerate faces
    /// are always interpolated linearly.
    pub fn eval(&self, face: usize, bary: [f64; 3], interp: Interp) -> C {
        let t = &self.maps[face];
        if interp == Interp::Linear || t.fallback_linear {
            eval_linear(t, bary)
        } else {
            eval_bpm(t, bary, self.options.exp_log, self.options.order)
        }
    }

    /// [`Bpm::eval`] at many samples, in parallel (each result depends on its sample only, so
    /// the output is identical for any number of threads).
    pub fn eval_many(&self, samples: &[Sample], interp: Interp) -> Vec<C> {
        samples
            .par_iter()
            .map(|s| self.eval(s.face as usize, s.bary, interp))
            .collect()
    }
}
