//! The axis-aligned energy, sample by sample (seed §5.1 eq. 1–4, appendix A; notes
//! "Formulation", "Analytic Jacobian"). The unknowns are the interior lines s_1 … s_{M−2},
//! t_1 … t_{N−2} (M + N − 4 values, [`Grid::to_unknowns`]). For the sample at (α, β) of cell
//! (i, j), with σ, o_s, o_t from [`super::rest_sample`]:
//!
//!   a_i = (s_{i+1} − s_i)/h_i,  b_j = (t_{j+1} − t_j)/k_j               ([`slope`])
//!   p = (s_i + α (s_{i+1} − s_i), t_j + β (t_{j+1} − t_j))               ([`warped_point`])
//!   c_s = ‖D_s(p)‖,  c_t = ‖D_t(p)‖   (bilinear)                          ([`stretch`])
//!   r^s = σ (c_s a_i − o_s),  r^t = σ (c_t b_j − o_t)                     ([`residual`])
//!
//! and the derivatives of each residual with respect to the cell's four lines
//! ([`line_derivatives`]). The fast twin is [`crate::gridwarp::AaEnergy`]; the GPU twin is
//! `gpu/shaders/gridwarp_aa.wgsl` (the same names).

use std::borrow::Cow;

use nalgebra::DMatrix;

use super::{add_residual, check_sample_count, rest_cell, rest_samples, RestCell};
use crate::error::Result;
use crate::gridwarp::energy::{DeformedFields, RestFields, RestSample};
use crate::gridwarp::field::{Field, Sample};
use crate::gridwarp::grid::Grid;
use crate::lm::{NormalEquations, Residuals};

/// The slope of the cell's linear remapping along one axis (seed §5.1, f and g of eq. 3–4):
/// a_i = (s_{i+1} − s_i)/h_i for the lines `lines` = s (b_j likewise for t), h_i from the rest
/// lines `rest_lines`.
pub fn slope(lines: &[f64], rest_lines: &[f64], i: usize) -> f64 {
    (lines[i + 1] - lines[i]) / (rest_lines[i + 1] - rest_lines[i])
}

/// The warped point of the sample at (α, β) of cell (i, j) under the lines of `grid`:
/// p = (f, g) = (s_i + α (s_{i+1} − s_i), t_j + β (t_{j+1} − t_j)) (seed §5.1: f, g remap the
/// rest cell linearly onto the current one).
pub fn warped_point(grid: &Grid, i: usize, j: usize, alpha: f64, beta: f64) -> [f64; 2] {
    let (s, t) = (&grid.s, &grid.t);
    [
        s[i] + alpha * (s[i + 1] - s[i]),
        t[j] + beta * (t[j + 1] - t[j]),
    ]
}

/// c = ‖D_·‖ at the warped point p, with its gradient (∂c/∂s, ∂c/∂t): the stretch field `field`
/// (‖D_s‖ or ‖D_t‖, a texture, seed §7) sampled bilinearly ([`Field::bilinear`]), so that c
/// is continuous and has a gradient for the Jacobian.
pub fn stretch(field: &Field, p: [f64; 2]) -> Sample {
    field.bilinear(p[0], p[1])
}

/// One residual (seed §5.1 eq. 3–4; notes "Residual layout"): r = σ (c a − o), a = a_i or b_j
/// the cell's slope along the residual's axis ([`slope`]), c a − o rounded once (a fused
/// multiply-add: r is exactly 0 where the deformed stretch matches the rest one, as for the
/// identity deformation).
pub fn residual(sigma: f64, c: f64, a: f64, o: f64) -> f64 {
    sigma * c.mul_add(a, -o)
}

/// The derivatives of one residual r = σ (c a − o) with respect to the four lines of its
/// cell (notes, "Analytic Jacobian"), for the axis along which the residual stretches
/// (s for r^s: a = a_i, width h = h_i, fractions (along, across) = (α, β); t for r^t:
/// a = b_j, h = k_j, fractions (β, α)):
///
///   ∂r/∂(near line along) = σ a ∂c/∂along (1 − along) − σ c/h,
///   ∂r/∂(far line along)  = σ a ∂c/∂along along + σ c/h,
///   ∂r/∂(near line across) = σ a ∂c/∂across (1 − across),
///   ∂r/∂(far line across)  = σ a ∂c/∂across across,
///
/// returned as [near along, far along, near across, far across]. The first two depend on the
/// line moving the sample (a ∂c …) and on the slope changing (± c/h); the other two only on the
/// sample moving across. Written with u = σ a ∂c/∂along, v = (σ · 1/h) c, w = σ a ∂c/∂across
/// as [u (1 − along) − v, u along + v, w (1 − across), w across], the first two by fused
/// multiply-adds (`inv_h` = 1/h, computed once per cell).
pub fn line_derivatives(
    sigma: f64,
    c: f64,
    (dc_along, dc_across): (f64, f64),
    a: f64,
    inv_h: f64,
    (along, across): (f64, f64),
) -> [f64; 4] {
    let sigma_a = sigma * a;
    let u = sigma_a * dc_along;
    let v = (sigma * inv_h) * c;
    let w = sigma_a * dc_across;
    [
        u.mul_add(1.0 - along, -v),
        u.mul_add(along, v),
        w * (1.0 - across),
        w * across,
    ]
}

/// The axis-aligned energy of one frame as a least-squares problem in the interior lines,
/// evaluated sample by sample (module docs). The rest samples are computed once
/// ([`super::rest_samples`], the paper's preprocessing).
pub struct PlainAaEnergy<'a> {
    rest_grid: Grid,
    deformed: &'a DeformedFields,
    /// K×L midpoint samples per cell.
    per_cell: (usize, usize),
    /// Cell by cell, K·L each ([`super::rest_samples`]): built for this energy or shared.
    samples: Cow<'a, [RestSample]>,
    /// The lines of the last evaluation (a buffer kept between evaluations).
    grid: Grid,
}

impl<'a> PlainAaEnergy<'a> {
    /// The energy of `deformed` over the K×L midpoint samples of every cell of `rest_grid`.
    pub fn new(
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &'a DeformedFields,
        k: usize,
        l: usize,
    ) -> Self {
        let (k, l) = (k.max(1), l.max(1));
        PlainAaEnergy {
            rest_grid: rest_grid.clone(),
            deformed,
            per_cell: (k, l),
            samples: Cow::Owned(rest_samples(rest, rest_grid, k, l)),
            grid: rest_grid.clone(),
        }
    }

    /// The energy of `deformed` over rest samples built beforehand ([`super::rest_samples`] of
    /// `rest_grid` with K×L = `per_cell`, once per sequence: the paper's preprocessing).
    ///
    /// Errors: `samples` does not hold K·L samples for every cell of `rest_grid`.
    pub fn from_rest_samples(
        rest_grid: &Grid,
        per_cell: (usize, usize),
        samples: &'a [RestSample],
        deformed: &'a DeformedFields,
    ) -> Result<Self> {
        check_sample_count(rest_grid, per_cell, samples)?;
        Ok(PlainAaEnergy {
            rest_grid: rest_grid.clone(),
            deformed,
            per_cell,
            samples: Cow::Borrowed(samples),
            grid: rest_grid.clone(),
        })
    }

    /// The rest grid.
    pub fn rest_grid(&self) -> &Grid {
        &self.rest_grid
    }

    /// The rest samples, cell by cell ([`super::rest_samples`]).
    pub fn rest_samples(&self) -> &[RestSample] {
        &self.samples
    }

    /// The unknowns of cell (i, j) in slot order (s_i, s_{i+1}, t_j, t_{j+1}): s_i is unknown
    /// i − 1 for 0 < i < M − 1, t_j unknown M − 2 + j − 1 for 0 < j < N − 1; None for the
    /// fixed lines 0 and 1.
    pub fn cell_unknowns(&self, i: usize, j: usize) -> [Option<usize>; 4] {
        let (m, n) = (self.rest_grid.s.len(), self.rest_grid.t.len());
        let s_index = |i: usize| (i > 0 && i < m - 1).then(|| i - 1);
        let t_index = |j: usize| (j > 0 && j < n - 1).then(|| m - 2 + j - 1);
        [s_index(i), s_index(i + 1), t_index(j), t_index(j + 1)]
    }

    /// Visit every residual at the lines `grid` in order (cell i·(N−1) + j, sample a, b, axis
    /// s then t), samples with σ = 0 left out (their r and ∂r are 0):
    /// `visit(cell unknowns, r, ∂r in slot order)`. With `derivatives` false, ∂r is not
    /// computed (zeros: an energy-only evaluation).
    fn for_each_residual(
        &self,
        grid: &Grid,
        derivatives: bool,
        mut visit: impl FnMut(&[Option<usize>; 4], f64, &[f64; 4]),
    ) {
        let (k, l) = self.per_cell;
        let rows = self.rest_grid.t.len() - 1;
        for i in 0..self.rest_grid.s.len() - 1 {
            for j in 0..rows {
                let unknowns = self.cell_unknowns(i, j);
                let cell = rest_cell(&self.rest_grid, i, j);
                let first = (i * rows + j) * k * l;
                let cell_samples = &self.samples[first..first + k * l];
                for sample in cell_samples.iter().filter(|p| p.sigma != 0.0) {
                    for (r, d) in self.sample_residuals(grid, (i, j), &cell, sample, derivatives) {
                        visit(&unknowns, r, &d);
                    }
                }
            }
        }
    }

    /// The two residuals (r^s, r^t) of one sample of cell (i, j) at the lines `grid`, with
    /// their derivatives in slot order (s_i, s_{i+1}, t_j, t_{j+1}) if `derivatives`.
    fn sample_residuals(
        &self,
        grid: &Grid,
        (i, j): (usize, usize),
        cell: &RestCell,
        sample: &RestSample,
        derivatives: bool,
    ) -> [(f64, [f64; 4]); 2] {
        let (alpha, beta, sigma) = (sample.alpha, sample.beta, sample.sigma);
        let a = slope(&grid.s, &self.rest_grid.s, i);
        let b = slope(&grid.t, &self.rest_grid.t, j);
        let p = warped_point(grid, i, j, alpha, beta);
        let c_s = stretch(&self.deformed.d_s, p);
        let c_t = stretch(&self.deformed.d_t, p);
        let r_s = residual(sigma, c_s.value, a, sample.o_s);
        let r_t = residual(sigma, c_t.value, b, sample.o_t);
        if !derivatives {
            return [(r_s, [0.0; 4]), (r_t, [0.0; 4])];
        }
        let (inv_h, inv_k) = (1.0 / cell.h, 1.0 / cell.k);
        // r^s stretches along s: its lines along are s_i, s_{i+1} (slots 0, 1).
        let d_s = line_derivatives(sigma, c_s.value, (c_s.ds, c_s.dt), a, inv_h, (alpha, beta));
        // r^t stretches along t: its lines along are t_j, t_{j+1} (slots 2, 3).
        let [t_near, t_far, s_near, s_far] =
            line_derivatives(sigma, c_t.value, (c_t.dt, c_t.ds), b, inv_k, (beta, alpha));
        [(r_s, d_s), (r_t, [s_near, s_far, t_near, t_far])]
    }

    /// All residuals at `x`, in the order of the sums (cell, sample a, b, axis; σ = 0 samples
    /// left out): the order of [`crate::gridwarp::AaEnergy::residuals`].
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        let grid = self.rest_grid.with_unknowns(x);
        self.for_each_residual(&grid, false, |_, r, _| out.push(r));
        out
    }

    /// The dense Jacobian at `x` (rows as in [`PlainAaEnergy::residuals`]).
    pub fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        let mut rows = Vec::new();
        let grid = self.rest_grid.with_unknowns(x);
        self.for_each_residual(&grid, true, |unknowns, _, d| rows.push((*unknowns, *d)));
        let mut jac = DMatrix::zeros(rows.len(), x.len());
        for (row, (unknowns, d)) in rows.iter().enumerate() {
            for (&u, &d_p) in unknowns.iter().zip(d) {
                if let Some(u) = u {
                    jac[(row, u)] += d_p;
                }
            }
        }
        jac
    }
}

impl Residuals for PlainAaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest_grid.unknowns()
    }

    /// F(x) = Σ r², one residual after another.
    fn energy(&mut self, x: &[f64]) -> f64 {
        self.grid.set_unknowns(x);
        let mut energy = 0.0;
        self.for_each_residual(&self.grid, false, |_, r, _| energy += r * r);
        energy
    }

    /// F, JᵀJ and Jᵀr, one residual after another ([`add_residual`]); F is the same sum as
    /// [`Residuals::energy`]'s, bit for bit.
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        self.grid.set_unknowns(x);
        let mut normal = NormalEquations::zeros(self.dim());
        self.for_each_residual(&self.grid, true, |unknowns, r, d| {
            add_residual(&mut normal, unknowns, r, d)
        });
        normal
    }
}
