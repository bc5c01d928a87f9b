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
//! Gauss–Newton model of the integral (notes). A cell's residuals depend on its four lines
//! only (s_i, s_{i+1}, t_j, t_{j+1}, the cell's "slots"), so JᵀJ and Jᵀr are accumulated per cell
//! in a 4×4 block ([`LocalNormalEquations`], the GPU kernel's `CellContribution`), cells in
//! parallel, and the blocks scattered in cell order; J is never stored.

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::field::{Axis, Field, Sample};
use super::grid::Grid;
use crate::lm::{LocalNormalEquations, NormalEquations, Residuals};

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
    let columns = RestAxis::along(&rest_grid.s, k, [rest.o_s.width, rest.o_t.width]);
    let rows = RestAxis::along(&rest_grid.t, l, [rest.o_s.height, rest.o_t.height]);
    // One cell column per parallel task, concatenated in column order.
    let per_column: Vec<Vec<RestSample>> = columns
        .par_chunks(k)
        .enumerate()
        .map(|(i, column)| {
            let h = rest_grid.s[i + 1] - rest_grid.s[i];
            let mut samples = Vec::with_capacity(column.len() * rows.len());
            for (j, row) in rows.chunks(l).enumerate() {
                let kj = rest_grid.t[j + 1] - rest_grid.t[j];
                let root_w = (h * kj / (k * l) as f64).sqrt();
                for x in column {
                    for y in row {
                        samples.push(RestSample {
                            alpha: x.fraction,
                            beta: y.fraction,
                            sigma: root_w * rest.rigidity.nearest(x.s, y.s),
                            o_s: rest.o_s.bilinear_at(&x.o_s, &y.o_s).value,
                            o_t: rest.o_t.bilinear_at(&x.o_t, &y.o_t).value,
                        });
                    }
                }
            }
            samples
        })
        .collect();
    per_column.concat()
}

/// One coordinate of the rest samples along one axis: the midpoint fraction (a + ½)/K in its
/// cell, the rest coordinate ŝ_i + α h_i and its texel positions on the ‖O_s‖ and ‖O_t‖
/// fields, found once per column (row) of samples instead of once per sample.
struct RestAxis {
    fraction: f64,
    s: f64,
    o_s: Axis,
    o_t: Axis,
}

impl RestAxis {
    /// The K midpoints of every cell along `lines` (cell-major), `texels` the ‖O_s‖ and
    /// ‖O_t‖ fields' sizes along that axis.
    fn along(lines: &[f64], per_cell: usize, texels: [usize; 2]) -> Vec<RestAxis> {
        let mut out = Vec::with_capacity((lines.len() - 1) * per_cell);
        for i in 0..lines.len() - 1 {
            let h = lines[i + 1] - lines[i];
            for a in 0..per_cell {
                let fraction = (a as f64 + 0.5) / per_cell as f64;
                let s = lines[i] + fraction * h;
                out.push(RestAxis {
                    fraction,
                    s,
                    o_s: Axis::new(s, texels[0]),
                    o_t: Axis::new(s, texels[1]),
                });
            }
        }
        out
    }
}

/// The axis-aligned energy of one frame as a least-squares problem in the interior grid lines.
pub struct AaEnergy<'a> {
    rest_grid: &'a Grid,
    deformed: &'a DeformedFields,
    /// Samples of cell (i, j) at `samples[(i·(N−1) + j)·K·L ..]`, sample (a, b) at a·L + b.
    samples: Vec<RestSample>,
    k: usize,
    l: usize,
}

/// The warped sample coordinates of one grid, separable because the grid is axis-aligned:
/// f = s_i + α_a (s_{i+1} − s_i) depends on the cell column and α only, g = t_j + β_b (t_{j+1} −
/// t_j) on the row and β only. Their texel [`Axis`] positions are found once per column sample
/// (index i·K + a) and row sample (j·L + b), not once per sample.
struct WarpedAxes {
    columns: Vec<Axis>,
    rows: Vec<Axis>,
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
            k: k.max(1),
            l: l.max(1),
        }
    }

    fn columns(&self) -> usize {
        self.rest_grid.s.len() - 1
    }

    fn rows(&self) -> usize {
        self.rest_grid.t.len() - 1
    }

    fn cells(&self) -> usize {
        self.columns() * self.rows()
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

    /// The unknowns of cell `cell` = (i, j) in slot order (s_i, s_{i+1}, t_j, t_{j+1}).
    pub fn cell_unknowns(&self, cell: usize) -> [Option<usize>; 4] {
        let (i, j) = (cell / self.rows(), cell % self.rows());
        [
            self.s_index(i),
            self.s_index(i + 1),
            self.t_index(j),
            self.t_index(j + 1),
        ]
    }

    /// The [`Axis`] positions of every column and row sample of the grid `g` (on the D_s
    /// field's texels; [`Field::bilinear_at`] redoes them if D_t has another resolution).
    fn warped_axes(&self, g: &Grid) -> WarpedAxes {
        let along = |lines: &[f64], per_cell: usize, texels: usize| -> Vec<Axis> {
            let mut axes = Vec::with_capacity((lines.len() - 1) * per_cell);
            for i in 0..lines.len() - 1 {
                for a in 0..per_cell {
                    let alpha = (a as f64 + 0.5) / per_cell as f64;
                    axes.push(Axis::new(
                        lines[i] + alpha * (lines[i + 1] - lines[i]),
                        texels,
                    ));
                }
            }
            axes
        };
        WarpedAxes {
            columns: along(&g.s, self.k, self.deformed.d_s.width),
            rows: along(&g.t, self.l, self.deformed.d_s.height),
        }
    }

    /// Visit every sample of cell `cell` = (i, j) at the grid `g` with a non-zero weight:
    /// `visit(cell, x, y, p)`, x and y the texel positions of its warped point p = (f, g).
    #[inline(always)]
    fn for_each_sample(
        &self,
        g: &Grid,
        axes: &WarpedAxes,
        cell: usize,
        mut visit: impl FnMut(&WarpedCell, &Axis, &Axis, &RestSample),
    ) {
        let (i, j) = (cell / self.rows(), cell % self.rows());
        let h = self.rest_grid.s[i + 1] - self.rest_grid.s[i];
        let kj = self.rest_grid.t[j + 1] - self.rest_grid.t[j];
        let warped = WarpedCell {
            h,
            kj,
            a: (g.s[i + 1] - g.s[i]) / h,
            b: (g.t[j + 1] - g.t[j]) / kj,
        };
        let per_cell = self.k * self.l;
        let samples = &self.samples[cell * per_cell..][..per_cell];
        let column_axes = &axes.columns[i * self.k..][..self.k];
        let row_axes = &axes.rows[j * self.l..][..self.l];
        for (x, column) in column_axes.iter().zip(samples.chunks_exact(self.l)) {
            for (y, p) in row_axes.iter().zip(column) {
                if p.sigma != 0.0 {
                    visit(&warped, x, y, p);
                }
            }
        }
    }

    /// Σ r² over cell `cell`'s residuals: values only, no field gradients (an energy-only
    /// evaluation of a damping trial). Same residuals, same order as
    /// [`AaEnergy::for_each_residual`].
    fn cell_energy(&self, g: &Grid, axes: &WarpedAxes, cell: usize) -> f64 {
        let mut e = 0.0;
        self.for_each_sample(g, axes, cell, |w, x, y, p| {
            let cs = self.deformed.d_s.bilinear_at(x, y).value;
            let ct = self.deformed.d_t.bilinear_at(x, y).value;
            let (rs, rt) = (w.residual_s(cs, p), w.residual_t(ct, p));
            e += rs * rs;
            e += rt * rt;
        });
        e
    }

    /// Visit every residual of cell `cell` = (i, j) at the grid `g`: `visit(r, ∂r/∂x)`, the
    /// derivatives in slot order (s_i, s_{i+1}, t_j, t_{j+1}) of [`AaEnergy::cell_unknowns`].
    #[inline(always)]
    fn for_each_residual(
        &self,
        g: &Grid,
        axes: &WarpedAxes,
        cell: usize,
        mut visit: impl FnMut(f64, &[f64; 4]),
    ) {
        self.for_each_sample(g, axes, cell, |w, x, y, p| {
            // c_s, c_t and their gradients at the warped point p = (f, g).
            let cs: Sample = self.deformed.d_s.bilinear_at(x, y);
            let ct: Sample = self.deformed.d_t.bilinear_at(x, y);
            let (al, be, sg) = (p.alpha, p.beta, p.sigma);
            let (a, b, h, kj) = (w.a, w.b, w.h, w.kj);
            // r^s = σ (c_s a − o_s) and its four partial derivatives (notes).
            visit(
                w.residual_s(cs.value, p),
                &[
                    sg * (a * cs.ds * (1.0 - al) - cs.value / h),
                    sg * (a * cs.ds * al + cs.value / h),
                    sg * a * cs.dt * (1.0 - be),
                    sg * a * cs.dt * be,
                ],
            );
            // r^t = σ (c_t b − o_t), symmetric.
            visit(
                w.residual_t(ct.value, p),
                &[
                    sg * b * ct.ds * (1.0 - al),
                    sg * b * ct.ds * al,
                    sg * (b * ct.dt * (1.0 - be) - ct.value / kj),
                    sg * (b * ct.dt * be + ct.value / kj),
                ],
            );
        });
    }

    /// All residuals at `x`, in a fixed order (cell column, row, sample, axis). For tests.
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        let g = self.rest_grid.with_unknowns(x);
        let axes = self.warped_axes(&g);
        let mut out = Vec::new();
        for cell in 0..self.cells() {
            self.for_each_residual(&g, &axes, cell, |r, _| out.push(r));
        }
        out
    }

    /// The dense Jacobian at `x` (rows as in [`AaEnergy::residuals`]). For tests.
    pub fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        let g = self.rest_grid.with_unknowns(x);
        let axes = self.warped_axes(&g);
        let mut rows = Vec::new();
        for cell in 0..self.cells() {
            let slots = self.cell_unknowns(cell);
            self.for_each_residual(&g, &axes, cell, |_, d| rows.push((slots, *d)));
        }
        let mut jac = DMatrix::zeros(rows.len(), x.len());
        for (row, (slots, d)) in rows.iter().enumerate() {
            for (slot, v) in slots.iter().zip(d) {
                if let Some(col) = slot {
                    jac[(row, *col)] += v;
                }
            }
        }
        jac
    }

    /// One cell's energy and normal equations over its four slots.
    pub fn cell_normal_equations(&self, g: &Grid, cell: usize) -> LocalNormalEquations<4> {
        self.cell_normal_equations_with(g, &self.warped_axes(g), cell)
    }

    fn cell_normal_equations_with(
        &self,
        g: &Grid,
        axes: &WarpedAxes,
        cell: usize,
    ) -> LocalNormalEquations<4> {
        let mut local = LocalNormalEquations::default();
        self.for_each_residual(g, axes, cell, |r, d| local.accumulate(r, d));
        local
    }
}

/// What a cell's residuals need of the grid: the rest cell size h_i × k_j and the slopes
/// a_i = (s_{i+1} − s_i)/h_i, b_j = (t_{j+1} − t_j)/k_j.
struct WarpedCell {
    h: f64,
    kj: f64,
    a: f64,
    b: f64,
}

impl WarpedCell {
    /// r^s = σ (c_s a_i − o_s), c_s = ‖D_s‖ at the warped point.
    #[inline(always)]
    fn residual_s(&self, cs: f64, p: &RestSample) -> f64 {
        p.sigma * (cs * self.a - p.o_s)
    }

    /// r^t = σ (c_t b_j − o_t), c_t = ‖D_t‖ at the warped point.
    #[inline(always)]
    fn residual_t(&self, ct: f64, p: &RestSample) -> f64 {
        p.sigma * (ct * self.b - p.o_t)
    }
}

/// Cells per parallel task: enough work (≥ a few thousand samples at 8×8) to amortise rayon's
/// scheduling; the results do not depend on it.
const CELLS_PER_TASK: usize = 4;

impl Residuals for AaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest_grid.unknowns()
    }

    /// F(x) = Σ r², per cell in parallel, then summed in cell order (deterministic).
    fn energy(&mut self, x: &[f64]) -> f64 {
        let g = self.rest_grid.with_unknowns(x);
        let axes = self.warped_axes(&g);
        let per_cell: Vec<f64> = (0..self.cells())
            .into_par_iter()
            .with_min_len(CELLS_PER_TASK)
            .map(|cell| self.cell_energy(&g, &axes, cell))
            .collect();
        per_cell.iter().sum()
    }

    /// F, JᵀJ and Jᵀr: each cell's 4×4 block in parallel, scattered in cell order
    /// (deterministic for any number of threads; the GPU kernel computes the same blocks).
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        let g = self.rest_grid.with_unknowns(x);
        let axes = self.warped_axes(&g);
        let blocks: Vec<([Option<usize>; 4], LocalNormalEquations<4>)> = (0..self.cells())
            .into_par_iter()
            .with_min_len(CELLS_PER_TASK)
            .map(|cell| {
                (
                    self.cell_unknowns(cell),
                    self.cell_normal_equations_with(&g, &axes, cell),
                )
            })
            .collect();
        NormalEquations::assemble(self.dim(), blocks.iter().map(|(s, b)| (s, b)))
    }
}
