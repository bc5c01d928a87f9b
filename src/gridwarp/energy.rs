//! The axis-aligned distortion energy (seed §5.1, notes "Formulation" and "Analytic Jacobian").
//!
//! Per cell (i, j) of the rest grid and per axis, E = ∫∫ (R (‖D_s(f(s), g(t))‖ a_i − ‖O_s(s, t)‖))²,
//! integrated by the midpoint rule on K×L sub-cells. One residual per sub-cell sample per axis:
//!
//!   r^s = σ (c_s(p) a_i − o_s),  r^t = σ (c_t(p) b_j − o_t),  σ = √w R(s, t),
//!
//! with w = h_i k_j/(K L) the sample's area, (s, t) = (ŝ_i + α h_i, t̂_j + β k_j) the rest point,
//! p = (s_i + α(s_{i+1} − s_i), t_j + β(t_{j+1} − t_j)) the warped point, a_i = (s_{i+1} − s_i)/h_i,
//! b_j = (t_{j+1} − t_j)/k_j, c = ‖D_·‖ at p, o = ‖O_·‖ at the rest point. Σ r² is the
//! Gauss–Newton model of the integral (notes). JᵀJ and Jᵀr are accumulated sample by sample
//! (each row has at most 4 non-zeros); J is never stored.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::field::{Field, Sample};
use super::grid::Grid;
use crate::lm::{NormalEquations, Residuals};

/// The fields of the rest pose: ‖O_s‖, ‖O_t‖ and the rigidity R.
#[derive(Clone, Debug)]
pub struct RestFields {
    pub o_s: Field,
    pub o_t: Field,
    pub rigidity: Field,
}

/// The fields of one deformed frame: ‖D_s‖, ‖D_t‖.
#[derive(Clone, Debug)]
pub struct DeformedFields {
    pub d_s: Field,
    pub d_t: Field,
}

/// What a sample contributes that does not depend on the unknowns: its fractional position
/// (α, β) in the cell, σ = √w R at the rest point, and ‖O_s‖, ‖O_t‖ there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestSample {
    pub alpha: f64,
    pub beta: f64,
    pub sigma: f64,
    pub o_s: f64,
    pub o_t: f64,
}

/// The rest samples of every cell, K×L midpoints each, in the order cell column i, row j,
/// sample a, b: α = (a + ½)/K, β = (b + ½)/L, rest point (ŝ_i + α h_i, t̂_j + β k_j), sample
/// area w = h_i k_j/(K L). Shared by the axis-aligned, non-axis-aligned and GPU energies.
pub fn rest_samples(rest: &RestFields, rest_grid: &Grid, k: usize, l: usize) -> Vec<RestSample> {
    let (k, l) = (k.max(1), l.max(1));
    let mut samples = Vec::with_capacity((rest_grid.s.len() - 1) * (rest_grid.t.len() - 1) * k * l);
    for i in 0..rest_grid.s.len() - 1 {
        let h = rest_grid.s[i + 1] - rest_grid.s[i];
        for j in 0..rest_grid.t.len() - 1 {
            let kj = rest_grid.t[j + 1] - rest_grid.t[j];
            let w = h * kj / (k * l) as f64;
            for a in 0..k {
                for b in 0..l {
                    let (alpha, beta) = ((a as f64 + 0.5) / k as f64, (b as f64 + 0.5) / l as f64);
                    let (s, t) = (rest_grid.s[i] + alpha * h, rest_grid.t[j] + beta * kj);
                    samples.push(RestSample {
                        alpha,
                        beta,
                        sigma: w.sqrt() * rest.rigidity.nearest(s, t),
                        o_s: rest.o_s.bilinear(s, t).value,
                        o_t: rest.o_t.bilinear(s, t).value,
                    });
                }
            }
        }
    }
    samples
}

/// The axis-aligned energy of one frame as a least-squares problem in the interior grid lines.
pub struct AaEnergy<'a> {
    rest_grid: &'a Grid,
    deformed: &'a DeformedFields,
    /// Samples of cell (i, j) at `samples[(i·(N−1) + j)·K·L ..]`.
    samples: Vec<RestSample>,
    per_cell: usize,
}

impl<'a> AaEnergy<'a> {
    /// Precompute the rest-point quantities of every sample: K×L midpoints per cell.
    pub fn new(
        rest: &RestFields,
        rest_grid: &'a Grid,
        deformed: &'a DeformedFields,
        k: usize,
        l: usize,
    ) -> Self {
        let samples = rest_samples(rest, rest_grid, k, l);
        AaEnergy {
            rest_grid,
            deformed,
            samples,
            per_cell: k.max(1) * l.max(1),
        }
    }

    fn columns(&self) -> usize {
        self.rest_grid.s.len() - 1
    }

    fn rows(&self) -> usize {
        self.rest_grid.t.len() - 1
    }

    /// Index of line s_i in the unknowns (None for the fixed lines 0 and 1).
    fn s_index(&self, i: usize) -> Option<usize> {
        (i > 0 && i < self.rest_grid.s.len() - 1).then(|| i - 1)
    }

    /// Index of line t_j in the unknowns.
    fn t_index(&self, j: usize) -> Option<usize> {
        let m = self.rest_grid.s.len();
        (j > 0 && j < self.rest_grid.t.len() - 1).then(|| m - 2 + j - 1)
    }

    /// Visit every residual of cell column i at the grid `g`: `visit(r, [(unknown, ∂r/∂x)])`.
    fn for_each_residual(
        &self,
        g: &Grid,
        i: usize,
        mut visit: impl FnMut(f64, [(Option<usize>, f64); 4]),
    ) {
        let h = self.rest_grid.s[i + 1] - self.rest_grid.s[i];
        let a = (g.s[i + 1] - g.s[i]) / h;
        for j in 0..self.rows() {
            let kj = self.rest_grid.t[j + 1] - self.rest_grid.t[j];
            let b = (g.t[j + 1] - g.t[j]) / kj;
            let cell = &self.samples[(i * self.rows() + j) * self.per_cell..][..self.per_cell];
            let (si, si1, tj, tj1) = (
                self.s_index(i),
                self.s_index(i + 1),
                self.t_index(j),
                self.t_index(j + 1),
            );
            for p in cell {
                if p.sigma == 0.0 {
                    continue;
                }
                let f = g.s[i] + p.alpha * (g.s[i + 1] - g.s[i]);
                let gt = g.t[j] + p.beta * (g.t[j + 1] - g.t[j]);
                let cs: Sample = self.deformed.d_s.bilinear(f, gt);
                let ct: Sample = self.deformed.d_t.bilinear(f, gt);
                let (al, be, sg) = (p.alpha, p.beta, p.sigma);
                // r^s = σ (c_s a − o_s) and its four partial derivatives (notes).
                visit(
                    sg * (cs.value * a - p.o_s),
                    [
                        (si, sg * (a * cs.ds * (1.0 - al) - cs.value / h)),
                        (si1, sg * (a * cs.ds * al + cs.value / h)),
                        (tj, sg * a * cs.dt * (1.0 - be)),
                        (tj1, sg * a * cs.dt * be),
                    ],
                );
                // r^t = σ (c_t b − o_t), symmetric.
                visit(
                    sg * (ct.value * b - p.o_t),
                    [
                        (tj, sg * (b * ct.dt * (1.0 - be) - ct.value / kj)),
                        (tj1, sg * (b * ct.dt * be + ct.value / kj)),
                        (si, sg * b * ct.ds * (1.0 - al)),
                        (si1, sg * b * ct.ds * al),
                    ],
                );
            }
        }
    }

    /// All residuals at `x`, in a fixed order (cell column, row, sample, axis). For tests.
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        let g = self.rest_grid.with_unknowns(x);
        let mut out = Vec::new();
        for i in 0..self.columns() {
            self.for_each_residual(&g, i, |r, _| out.push(r));
        }
        out
    }

    /// The dense Jacobian at `x` (rows as in [`AaEnergy::residuals`]). For tests.
    pub fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        let g = self.rest_grid.with_unknowns(x);
        let mut rows = Vec::new();
        for i in 0..self.columns() {
            self.for_each_residual(&g, i, |_, d| rows.push(d));
        }
        let mut jac = DMatrix::zeros(rows.len(), x.len());
        for (row, d) in rows.iter().enumerate() {
            for (col, v) in d.iter().filter_map(|(c, v)| c.map(|c| (c, *v))) {
                jac[(row, col)] += v;
            }
        }
        jac
    }
}

impl Residuals for AaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest_grid.unknowns()
    }

    /// F(x) = Σ r², summed per cell column in parallel, then in column order (deterministic).
    fn energy(&mut self, x: &[f64]) -> f64 {
        let g = self.rest_grid.with_unknowns(x);
        let per_column: Vec<f64> = (0..self.columns())
            .into_par_iter()
            .map(|i| {
                let mut e = 0.0;
                self.for_each_residual(&g, i, |r, _| e += r * r);
                e
            })
            .collect();
        per_column.iter().sum()
    }

    /// F, JᵀJ and Jᵀr, accumulated per cell column in parallel and reduced in column order.
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        let n = self.dim();
        let g = self.rest_grid.with_unknowns(x);
        let per_column: Vec<NormalEquations> = (0..self.columns())
            .into_par_iter()
            .map(|i| {
                let mut ne = NormalEquations::zeros(n);
                self.for_each_residual(&g, i, |r, d| ne.add_row(r, &d));
                ne
            })
            .collect();
        NormalEquations::sum_in_order(n, per_column)
    }
}
