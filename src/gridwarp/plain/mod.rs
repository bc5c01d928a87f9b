//! # The grid-warp energies as the paper states them (seed 000 §5.1, §8, appendix A)
//!
//! **Start reading here.** This module is the formula of the axis-aligned ([`aa`]) and
//! non-axis-aligned ([`naa`]) energies written out sample by sample, with plain loops over the
//! cells and their samples: one small function per quantity, no lanes, no SIMD, no tables, no
//! parallelism. [`super::energy`] and [`super::energy_naa`] compute the same residuals, with the
//! same operations, in the layout that makes them fast (lane arrays, texel tables, AVX-512
//! dispatch, tiled sums); `tests/gridwarp_plain.rs` checks every fast variant against this
//! module. Both implement [`crate::lm::Residuals`], so the solver runs on either
//! ([`super::solve::minimize_frame`], [`super::solve::minimize_naa_frame`]).
//!
//! ## The energy (seed §5.1 eq. 1–4, notes "Formulation")
//! The ROI is the unit square (s, t). A rest grid of lines ŝ_0 = 0 < … < ŝ_{M−1} = 1 and
//! t̂_0 … t̂_{N−1} covers it; cell (i, j) is [ŝ_i, ŝ_{i+1}] × [t̂_j, t̂_{j+1}], of size
//! h_i × k_j. Per cell and axis,
//!
//!   E^s_ij = ∫∫_cell (R(s, t) (‖D_s(f(s), g(t))‖ a_i − ‖O_s(s, t)‖))² ds dt,
//!
//! E^t_ij likewise with D_t, b_j and O_t, integrated by the midpoint rule on K×L sub-cells.
//! Each sub-cell sample gives one residual per axis, r = √w R (c a − o), and F = Σ r² (the
//! Gauss–Newton model of the integral; notes, "Residual layout").
//!
//! ## Reading order
//! 1. The rest side of a sample, shared by both energies (this file): [`rest_cell`],
//!    [`midpoint`], [`rest_point`], [`sample_weight`], [`rest_sample`].
//! 2. The axis-aligned energy, [`aa`]: [`aa::slope`], [`aa::warped_point`], [`aa::stretch`],
//!    [`aa::residual`], [`aa::line_derivatives`], and [`aa::PlainAaEnergy`]'s loops.
//! 3. The non-axis-aligned energy, [`naa`]: [`naa::bilinear_warp`], [`naa::jacobian_at`],
//!    [`naa::image`], [`naa::residual`], [`naa::residual_derivatives`],
//!    [`naa::residual_curvature`], and [`naa::PlainNaaEnergy`]'s loops.
//!
//! ## Order of the sums
//! Cells in order (cell column i, then row j: cell i·(N−1) + j), samples a = 0..K, b = 0..L in
//! each, axis s then t: F, Jᵀr and JᵀJ are added one residual after another. The fast path adds
//! the same terms in another order (per lane, per cell, then the cells), so its sums differ
//! from these by rounding only: `tests/gridwarp_plain.rs` derives the bound.

pub mod aa;
pub mod naa;

use super::energy::{RestFields, RestSample};
use super::grid::Grid;
use crate::error::{Error, Result};
use crate::lm::NormalEquations;

pub use aa::PlainAaEnergy;
pub use naa::PlainNaaEnergy;

/// Rest cell (i, j): its lower-left corner (ŝ_i, t̂_j) and its size h_i × k_j (seed §3.1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestCell {
    pub s: f64,
    pub t: f64,
    /// h_i = ŝ_{i+1} − ŝ_i.
    pub h: f64,
    /// k_j = t̂_{j+1} − t̂_j.
    pub k: f64,
}

/// Rest cell (i, j) of `rest_grid`: corner (ŝ_i, t̂_j), size h_i = ŝ_{i+1} − ŝ_i by
/// k_j = t̂_{j+1} − t̂_j (seed §3.1, §5.1).
pub fn rest_cell(rest_grid: &Grid, i: usize, j: usize) -> RestCell {
    RestCell {
        s: rest_grid.s[i],
        t: rest_grid.t[j],
        h: rest_grid.s[i + 1] - rest_grid.s[i],
        k: rest_grid.t[j + 1] - rest_grid.t[j],
    }
}

/// The midpoint rule's fraction of sub-cell `index` of `count`: (index + ½)/count (seed §5.1:
/// the per-cell integral as a sum over K×L sub-cells; α for a = 0..K, β for b = 0..L).
pub fn midpoint(index: usize, count: usize) -> f64 {
    (index as f64 + 0.5) / count as f64
}

/// The rest point of the sample at fractions (α, β) of `cell`: (ŝ_i + α h_i, t̂_j + β k_j)
/// (seed §5.1, the (s, t) of eq. 3–4).
pub fn rest_point(cell: &RestCell, alpha: f64, beta: f64) -> [f64; 2] {
    [cell.s + alpha * cell.h, cell.t + beta * cell.k]
}

/// The area of one of the K×L sub-cells of `cell`: w = h_i k_j / (K L) (the midpoint rule's
/// weight; seed §5.1).
pub fn sample_weight(cell: &RestCell, k: usize, l: usize) -> f64 {
    cell.h * cell.k / (k * l) as f64
}

/// What a sample contributes that does not depend on the unknowns (seed §5.1 eq. 3–4, the
/// paper's preprocessing, §7): at the rest point (s, t) = [`rest_point`],
///   σ = √w R(s, t)   (R at the nearest texel: a per-texel weight with sharp edges),
///   o_s = ‖O_s(s, t)‖,  o_t = ‖O_t(s, t)‖   (bilinear),
/// w = [`sample_weight`].
pub fn rest_sample(
    rest: &RestFields,
    cell: &RestCell,
    (alpha, beta): (f64, f64),
    (k, l): (usize, usize),
) -> RestSample {
    let [s, t] = rest_point(cell, alpha, beta);
    RestSample {
        alpha,
        beta,
        sigma: sample_weight(cell, k, l).sqrt() * rest.rigidity.nearest(s, t),
        o_s: rest.o_s.bilinear(s, t).value,
        o_t: rest.o_t.bilinear(s, t).value,
    }
}

/// The K×L rest samples of every cell of `rest_grid`, cell by cell (cell i·(N−1) + j), sample
/// a (α = [`midpoint`]`(a, K)`) then b (β = [`midpoint`]`(b, L)`): [`rest_sample`] of each.
pub fn rest_samples(rest: &RestFields, rest_grid: &Grid, k: usize, l: usize) -> Vec<RestSample> {
    let (k, l) = (k.max(1), l.max(1));
    let mut out = Vec::new();
    for i in 0..rest_grid.s.len() - 1 {
        for j in 0..rest_grid.t.len() - 1 {
            let cell = rest_cell(rest_grid, i, j);
            for a in 0..k {
                for b in 0..l {
                    let fractions = (midpoint(a, k), midpoint(b, l));
                    out.push(rest_sample(rest, &cell, fractions, (k, l)));
                }
            }
        }
    }
    out
}

/// Add one residual r with its derivatives `d` with respect to the unknowns `unknowns` (None:
/// a fixed coordinate, dropped) to the normal equations: F += r², Jᵀr_u += d_p r,
/// JᵀJ_uv += d_p d_q (u, v the unknowns of slots p, q). J itself is never stored (notes,
/// "Analytic Jacobian").
pub fn add_residual(normal: &mut NormalEquations, unknowns: &[Option<usize>], r: f64, d: &[f64]) {
    normal.energy += r * r;
    for (&u, &d_p) in unknowns.iter().zip(d) {
        let Some(u) = u else { continue };
        normal.jtr[u] += d_p * r;
        for (&v, &d_q) in unknowns.iter().zip(d) {
            if let Some(v) = v {
                normal.jtj[(u, v)] += d_p * d_q;
            }
        }
    }
}

/// Ok if `samples` holds K·L samples (`per_cell`) for every cell of `rest_grid`.
fn check_sample_count(
    rest_grid: &Grid,
    (k, l): (usize, usize),
    samples: &[RestSample],
) -> Result<()> {
    let cells = (rest_grid.s.len() - 1) * (rest_grid.t.len() - 1);
    if k == 0 || l == 0 || samples.len() != cells * k * l {
        return Err(Error::InvalidArgument(format!(
            "gridwarp plain: {} rest samples for {cells} cells of {k}×{l} samples",
            samples.len()
        )));
    }
    Ok(())
}
