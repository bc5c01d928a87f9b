//! The non-axis-aligned energy, sample by sample (seed §8 eq. 7–8; notes "Formulation: NAA",
//! "Analytic Jacobian: NAA"). The unknowns are the grid vertices P_ab ∈ R² that move
//! ([`VertexGrid::unknown_index`]: the interior ones, and with a sliding border the border
//! ones along their edge). Each rest cell (i, j) of size h × k is warped bilinearly onto the
//! quadrilateral of its corners P00 = P_ij, P10 = P_{i+1,j}, P01 = P_{i,j+1}, P11 = P_{i+1,j+1}.
//! For the sample at (α, β), with σ, o_s, o_t from [`super::rest_sample`]:
//!
//!   p = W(α, β),  W_s = (∂W/∂α)/h,  W_t = (∂W/∂β)/k                     ([`bilinear_warp`])
//!   J_D = [D_s D_t] at p (bilinear, with derivatives)                   ([`jacobian_at`])
//!   q_s = J_D W_s,  q_t = J_D W_t   (seed eq. 7–8: H_s, H_t)              ([`image()`])
//!   r^s = σ (‖q_s‖ − o_s),  r^t = σ (‖q_t‖ − o_t)                        ([`residual`])
//!
//! with the derivatives of each residual with respect to the cell's 8 corner coordinates
//! ([`residual_derivatives`]) and, for the second-order models ([`NaaModel::Newton`],
//! [`NaaModel::Adaptive`]), its r∇²r ([`residual_curvature`]). On an axis-aligned vertex grid
//! W_s = (a_i, 0), q_s = a_i D_s and r^s is the axis-aligned residual. A vertex grid with a
//! folded cell (a corner determinant ≤ 0, [`VertexGrid::is_valid`]) has energy +∞. The fast
//! twin is [`crate::gridwarp::NaaEnergy`].

use std::borrow::Cow;

use nalgebra::DMatrix;

use super::{add_residual, check_sample_count, rest_cell, rest_samples, RestCell};
use crate::error::Result;
use crate::gridwarp::energy::{RestFields, RestSample};
use crate::gridwarp::energy_naa::{DeformedJacobian, NaaModel, VectorField, VertexGrid};
use crate::gridwarp::grid::Grid;
use crate::lm::{NormalEquations, Residuals};

/// The corners [P00, P10, P01, P11] of cell (i, j) of the vertex grid `g` (seed §8).
pub fn corners(g: &VertexGrid, i: usize, j: usize) -> [[f64; 2]; 4] {
    [
        g.at(i, j),
        g.at(i + 1, j),
        g.at(i, j + 1),
        g.at(i + 1, j + 1),
    ]
}

/// A sample's warped point p = W(α, β) and the slopes W_s = (∂W/∂α)/h, W_t = (∂W/∂β)/k of the
/// cell's bilinear warp there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Warp {
    pub p: [f64; 2],
    pub w_s: [f64; 2],
    pub w_t: [f64; 2],
}

/// The bilinear warp of the rest cell `cell` onto the quadrilateral `corners` at (α, β)
/// (seed §8: S_p, T_p; notes "Formulation: NAA"):
///
///   W(α, β) = (1−α)(1−β) P00 + α(1−β) P10 + (1−α)β P01 + αβ P11
///           = P00 + α e_α + β e_β + αβ τ,   e_α = P10 − P00,  e_β = P01 − P00,
///                                           τ = P11 − P10 − P01 + P00 (the twist),
///   W_s = (∂W/∂α)/h = e_α/h + β τ/h,   W_t = (∂W/∂β)/k = e_β/k + α τ/k,
///
/// written in the second form: on a rectangle τ is exactly 0, so an axis-aligned grid gives
/// the axis-aligned sample points and slopes bit for bit.
pub fn bilinear_warp(corners: &[[f64; 2]; 4], cell: &RestCell, alpha: f64, beta: f64) -> Warp {
    let [p00, p10, p01, p11] = *corners;
    let e_alpha = sub(p10, p00);
    let e_beta = sub(p01, p00);
    let twist = sub(sub(p11, p10), e_beta);
    let (h, k) = (cell.h, cell.k);
    Warp {
        p: add(
            add(p00, scale(alpha, e_alpha)),
            add(scale(beta, e_beta), scale(alpha * beta, twist)),
        ),
        w_s: add(divide(e_alpha, h), scale(beta, divide(twist, h))),
        w_t: add(divide(e_beta, k), scale(alpha, divide(twist, k))),
    }
}

/// One column of J_D at a point: the vector D_s (or D_t) and its derivatives along s and t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Partial {
    pub value: [f64; 3],
    pub ds: [f64; 3],
    pub dt: [f64; 3],
}

impl Partial {
    /// The derivative of this column along s (`along` = 0) or t (1).
    pub fn along(&self, along: usize) -> &[f64; 3] {
        if along == 0 {
            &self.ds
        } else {
            &self.dt
        }
    }
}

/// One vector field (D_s or D_t) at p: each component sampled bilinearly with its gradient
/// ([`crate::gridwarp::Field::bilinear`]).
fn partial_at(field: &VectorField, p: [f64; 2]) -> Partial {
    let [x, y, z] = [&field.x, &field.y, &field.z].map(|f| f.bilinear(p[0], p[1]));
    Partial {
        value: [x.value, y.value, z.value],
        ds: [x.ds, y.ds, z.ds],
        dt: [x.dt, y.dt, z.dt],
    }
}

/// J_D = [D_s D_t] of the deformed frame at the warped point p, with its derivatives along s
/// and t (the fields' gradients: the sample moving enters the Jacobian), as [D_s, D_t].
pub fn jacobian_at(deformed: &DeformedJacobian, p: [f64; 2]) -> [Partial; 2] {
    [partial_at(&deformed.d_s, p), partial_at(&deformed.d_t, p)]
}

/// q = J_D w = D_s w₀ + D_t w₁: the image of the direction w under the deformation (seed eq.
/// 7–8, H_s = S_s D_s + T_s D_t with w = W_s; also used with J_D's derivatives in place of
/// J_D).
pub fn image(d_s: &[f64; 3], d_t: &[f64; 3], w: [f64; 2]) -> [f64; 3] {
    [
        d_s[0] * w[0] + d_t[0] * w[1],
        d_s[1] * w[0] + d_t[1] * w[1],
        d_s[2] * w[0] + d_t[2] * w[1],
    ]
}

/// ‖q‖.
pub fn norm(q: [f64; 3]) -> f64 {
    (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()
}

/// x · y.
pub fn dot(x: [f64; 3], y: [f64; 3]) -> f64 {
    x[0] * y[0] + x[1] * y[1] + x[2] * y[2]
}

/// One residual (seed §8 eq. 7–8): r = σ (‖q‖ − o), q = [`image()`] of W_s (or W_t).
pub fn residual(sigma: f64, q: [f64; 3], o: f64) -> f64 {
    sigma * (norm(q) - o)
}

/// The bilinear corner weights φ = [(1−α)(1−β), α(1−β), (1−α)β, αβ] of corners 00, 10, 01, 11:
/// ∂p/∂P_c = φ_c.
pub fn corner_weights(alpha: f64, beta: f64) -> [f64; 4] {
    [
        (1.0 - alpha) * (1.0 - beta),
        alpha * (1.0 - beta),
        (1.0 - alpha) * beta,
        alpha * beta,
    ]
}

/// The corner weights' slopes φ'_c = ∂φ_c/∂s = (∂φ_c/∂α)/h for the s residual (`axis` 0):
/// [−(1−β)/h, (1−β)/h, −β/h, β/h]; ∂φ_c/∂t = (∂φ_c/∂β)/k for the t residual (`axis` 1):
/// [−(1−α)/k, −α/k, (1−α)/k, α/k]. W_s = Σ φ'_c P_c, so ∂W_s/∂P_c = φ'_c.
pub fn corner_weight_slopes(axis: usize, cell: &RestCell, alpha: f64, beta: f64) -> [f64; 4] {
    if axis == 0 {
        let (near, far) = ((1.0 - beta) / cell.h, beta / cell.h);
        [-near, near, -far, far]
    } else {
        let (near, far) = ((1.0 - alpha) / cell.k, alpha / cell.k);
        [-near, -far, near, far]
    }
}

/// The derivatives of r = σ (‖q‖ − o), q = J_D(p) w, with respect to the cell's 8 corner
/// coordinates, slot 2c + k = coordinate k (s, t) of corner c (notes, "Analytic Jacobian:
/// NAA"):
///
///   ∂r/∂P_c,k = φ'_c m_k + φ_c g_k,   m_k = (σ/‖q‖) D_k · q,   g_k = (σ/‖q‖) q · (∂_k J_D) w,
///
/// m from w moving (∂w/∂P_c,k = φ'_c e_k, [`corner_weight_slopes`]), g from the sample moving
/// (∂p/∂P_c,k = φ_c e_k, [`corner_weights`]); σ/‖q‖ taken as 0 at q = 0 (where the norm has
/// no derivative).
pub fn residual_derivatives(
    sigma: f64,
    jacobian: &[Partial; 2],
    w: [f64; 2],
    phi: &[f64; 4],
    dphi: &[f64; 4],
) -> [f64; 8] {
    let [d_s, d_t] = jacobian;
    let q = image(&d_s.value, &d_t.value, w);
    let length = norm(q);
    let factor = if length > 0.0 { sigma / length } else { 0.0 };
    let m = [factor * dot(d_s.value, q), factor * dot(d_t.value, q)];
    let g = [
        factor * dot(q, image(&d_s.ds, &d_t.ds, w)),
        factor * dot(q, image(&d_s.dt, &d_t.dt, w)),
    ];
    std::array::from_fn(|slot| {
        let (c, k) = (slot / 2, slot % 2);
        dphi[c] * m[k] + phi[c] * g[k]
    })
}

/// r∇²r of r = σ (‖q‖ − o), q = J_D(p) w, over the cell's 8 corner coordinates (the term that
/// [`NaaModel::Newton`] adds to JᵀJ; module docs of [`crate::gridwarp::energy_naa::curvature`]):
/// for slots a = (c, k), b = (c', l),
///
///   Q_a = ∂q/∂P_c,k = φ'_c D_k + φ_c G_k,   G_k = (∂_k J_D) w,   u = q/‖q‖,
///   r∇²r_ab = σr [(Q_a · Q_b − (u · Q_a)(u · Q_b))/‖q‖ + φ'_c φ_c' u · ∂_l D_k + φ_c φ'_c' u · ∂_k D_l],
///
/// σr = σ² (‖q‖ − o): the norm's curvature (I − uuᵀ)/‖q‖ seen through Q, plus q's own second
/// derivative. Left out, as in the fast path: the fields' mixed derivative ∂_s∂_t J_D (the
/// only second derivative of a bilinear texel patch). 0 at q = 0. Computed for a ≤ b and
/// mirrored (symmetric).
pub fn residual_curvature(
    sigma: f64,
    o: f64,
    jacobian: &[Partial; 2],
    w: [f64; 2],
    phi: &[f64; 4],
    dphi: &[f64; 4],
) -> [[f64; 8]; 8] {
    let mut out = [[0.0; 8]; 8];
    let [d_s, d_t] = jacobian;
    let q = image(&d_s.value, &d_t.value, w);
    let length = norm(q);
    if length <= 0.0 {
        return out;
    }
    let u = q.map(|v| v / length);
    let sigma_r = sigma * sigma * (length - o);
    let g = [image(&d_s.ds, &d_t.ds, w), image(&d_s.dt, &d_t.dt, w)];
    let q_of = |slot: usize| -> [f64; 3] {
        let (c, k) = (slot / 2, slot % 2);
        let d_k = &jacobian[k].value;
        std::array::from_fn(|n| dphi[c] * d_k[n] + phi[c] * g[k][n])
    };
    let upper_triangle = (0..8).flat_map(|a| (a..8).map(move |b| (a, b)));
    for (a, b) in upper_triangle {
        let ((c, k), (c2, l)) = ((a / 2, a % 2), (b / 2, b % 2));
        let (q_a, q_b) = (q_of(a), q_of(b));
        let projected = dot(q_a, q_b) - dot(u, q_a) * dot(u, q_b);
        let second = dphi[c] * phi[c2] * dot(u, *jacobian[k].along(l))
            + phi[c] * dphi[c2] * dot(u, *jacobian[l].along(k));
        out[a][b] = sigma_r * (projected / length + second);
        out[b][a] = out[a][b];
    }
    out
}

/// What one residual contributes: r, its derivatives in slot order and (second-order models
/// only) its r∇²r.
struct ResidualTerms {
    r: f64,
    d: [f64; 8],
    curvature: Option<[[f64; 8]; 8]>,
}

/// How much of a residual a pass needs.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Wanted {
    Values,
    Derivatives,
    Curvature,
}

/// The non-axis-aligned energy of one frame as a least-squares problem in the moving vertex
/// coordinates, evaluated sample by sample (module docs). The rest samples are computed once
/// ([`super::rest_samples`], exactly the axis-aligned energy's).
pub struct PlainNaaEnergy<'a> {
    rest_grid: Grid,
    rest_vertices: VertexGrid,
    deformed: &'a DeformedJacobian,
    per_cell: (usize, usize),
    /// Cell by cell, K·L each ([`super::rest_samples`]): built for this energy or shared.
    samples: Cow<'a, [RestSample]>,
    model: NaaModel,
    /// S = Σ r∇²r at the point of the last normal equations ([`NaaModel::Adaptive`] only).
    pending_curvature: Option<(Vec<f64>, DMatrix<f64>)>,
}

impl<'a> PlainNaaEnergy<'a> {
    /// The energy of `deformed` over the K×L midpoint samples of every cell of `rest_grid`
    /// (border vertices fixed, the Gauss–Newton model).
    pub fn new(
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &'a DeformedJacobian,
        k: usize,
        l: usize,
    ) -> Self {
        let (k, l) = (k.max(1), l.max(1));
        PlainNaaEnergy {
            rest_grid: rest_grid.clone(),
            rest_vertices: VertexGrid::from_grid(rest_grid),
            deformed,
            per_cell: (k, l),
            samples: Cow::Owned(rest_samples(rest, rest_grid, k, l)),
            model: NaaModel::GaussNewton,
            pending_curvature: None,
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
        deformed: &'a DeformedJacobian,
    ) -> Result<Self> {
        check_sample_count(rest_grid, per_cell, samples)?;
        Ok(PlainNaaEnergy {
            rest_grid: rest_grid.clone(),
            rest_vertices: VertexGrid::from_grid(rest_grid),
            deformed,
            per_cell,
            samples: Cow::Borrowed(samples),
            model: NaaModel::GaussNewton,
            pending_curvature: None,
        })
    }

    /// Use `model` as LM's model Hessian ([`NaaModel`]).
    pub fn with_model(mut self, model: NaaModel) -> Self {
        self.model = model;
        self
    }

    /// Let the non-corner border vertices slide along their edges.
    pub fn with_sliding_border(mut self, sliding: bool) -> Self {
        self.rest_vertices.sliding_border = sliding;
        self
    }

    /// The rest vertices (the starting point of a first frame).
    pub fn rest_vertices(&self) -> &VertexGrid {
        &self.rest_vertices
    }

    /// The unknowns of cell (i, j) in slot order: corners P00, P10, P01, P11, each (s, t);
    /// None for fixed coordinates.
    pub fn cell_unknowns(&self, i: usize, j: usize) -> [Option<usize>; 8] {
        let g = &self.rest_vertices;
        let [p00, p10, p01, p11] = [
            g.unknown_index(i, j),
            g.unknown_index(i + 1, j),
            g.unknown_index(i, j + 1),
            g.unknown_index(i + 1, j + 1),
        ];
        [
            p00[0], p00[1], p10[0], p10[1], p01[0], p01[1], p11[0], p11[1],
        ]
    }

    /// Visit every residual at the vertices `g` in order (cell i·(N−1) + j, sample a, b, axis
    /// s then t), samples with σ = 0 left out: `visit(cell unknowns, terms)`, the terms
    /// computed as far as `wanted` says.
    fn for_each_residual(
        &self,
        g: &VertexGrid,
        wanted: Wanted,
        mut visit: impl FnMut(&[Option<usize>; 8], &ResidualTerms),
    ) {
        let (k, l) = self.per_cell;
        let rows = self.rest_grid.t.len() - 1;
        for i in 0..self.rest_grid.s.len() - 1 {
            for j in 0..rows {
                let unknowns = self.cell_unknowns(i, j);
                let cell = rest_cell(&self.rest_grid, i, j);
                let quad = corners(g, i, j);
                let first = (i * rows + j) * k * l;
                for sample in self.samples[first..first + k * l]
                    .iter()
                    .filter(|p| p.sigma != 0.0)
                {
                    for terms in self.sample_residuals(&cell, &quad, sample, wanted) {
                        visit(&unknowns, &terms);
                    }
                }
            }
        }
    }

    /// The two residuals (r^s, r^t) of one sample of `cell`, warped onto `quad`.
    fn sample_residuals(
        &self,
        cell: &RestCell,
        quad: &[[f64; 2]; 4],
        sample: &RestSample,
        wanted: Wanted,
    ) -> [ResidualTerms; 2] {
        let (alpha, beta, sigma) = (sample.alpha, sample.beta, sample.sigma);
        let warp = bilinear_warp(quad, cell, alpha, beta);
        let jacobian = jacobian_at(self.deformed, warp.p);
        let phi = corner_weights(alpha, beta);
        let axes = [(warp.w_s, sample.o_s), (warp.w_t, sample.o_t)];
        std::array::from_fn(|axis| {
            let (w, o) = axes[axis];
            let q = image(&jacobian[0].value, &jacobian[1].value, w);
            let mut terms = ResidualTerms {
                r: residual(sigma, q, o),
                d: [0.0; 8],
                curvature: None,
            };
            if wanted != Wanted::Values {
                let dphi = corner_weight_slopes(axis, cell, alpha, beta);
                terms.d = residual_derivatives(sigma, &jacobian, w, &phi, &dphi);
                if wanted == Wanted::Curvature {
                    terms.curvature = Some(residual_curvature(sigma, o, &jacobian, w, &phi, &dphi));
                }
            }
            terms
        })
    }

    /// All residuals at `x`, in the order of the sums (cell, sample a, b, axis; σ = 0 samples
    /// left out): the order of [`crate::gridwarp::NaaEnergy::residuals`].
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        let mut out = Vec::new();
        let g = self.rest_vertices.with_unknowns(x);
        self.for_each_residual(&g, Wanted::Values, |_, terms| out.push(terms.r));
        out
    }

    /// The dense Jacobian at `x` (rows as in [`PlainNaaEnergy::residuals`]).
    pub fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        let mut rows = Vec::new();
        let g = self.rest_vertices.with_unknowns(x);
        self.for_each_residual(&g, Wanted::Derivatives, |unknowns, terms| {
            rows.push((*unknowns, terms.d))
        });
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

    /// S = Σ r∇²r at `x` over the unknowns ([`residual_curvature`] of every residual, added one
    /// after another).
    pub fn curvature_at(&self, x: &[f64]) -> DMatrix<f64> {
        let n = self.dim();
        let mut s = DMatrix::zeros(n, n);
        let g = self.rest_vertices.with_unknowns(x);
        self.for_each_residual(&g, Wanted::Curvature, |unknowns, terms| {
            if let Some(block) = &terms.curvature {
                add_block(&mut s, unknowns, block);
            }
        });
        s
    }
}

/// S_uv += block_pq for the unknowns u, v of slots p, q (fixed coordinates dropped).
fn add_block(s: &mut DMatrix<f64>, unknowns: &[Option<usize>; 8], block: &[[f64; 8]; 8]) {
    for (&u, row) in unknowns.iter().zip(block) {
        let Some(u) = u else { continue };
        for (&v, &value) in unknowns.iter().zip(row) {
            if let Some(v) = v {
                s[(u, v)] += value;
            }
        }
    }
}

impl Residuals for PlainNaaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest_vertices.unknowns()
    }

    /// F(x) = Σ r², one residual after another; +∞ if a cell folds.
    fn energy(&mut self, x: &[f64]) -> f64 {
        let g = self.rest_vertices.with_unknowns(x);
        if !g.is_valid() {
            return f64::INFINITY;
        }
        let mut energy = 0.0;
        self.for_each_residual(&g, Wanted::Values, |_, terms| energy += terms.r * terms.r);
        energy
    }

    /// F, the model Hessian and Jᵀr, one residual after another ([`super::add_residual`]):
    /// JᵀJ ([`NaaModel::GaussNewton`], [`NaaModel::Adaptive`], which also keeps
    /// S = Σ r∇²r for [`Residuals::curvature`]) or JᵀJ + S ([`NaaModel::Newton`]). At a
    /// folded grid: F = +∞, zero JᵀJ and Jᵀr.
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        let n = self.dim();
        let g = self.rest_vertices.with_unknowns(x);
        if !g.is_valid() {
            return NormalEquations {
                energy: f64::INFINITY,
                ..NormalEquations::zeros(n)
            };
        }
        let wanted = match self.model {
            NaaModel::GaussNewton => Wanted::Derivatives,
            NaaModel::Newton | NaaModel::Adaptive => Wanted::Curvature,
        };
        let mut normal = NormalEquations::zeros(n);
        let mut s = DMatrix::zeros(n, n);
        self.for_each_residual(&g, wanted, |unknowns, terms| {
            add_residual(&mut normal, unknowns, terms.r, &terms.d);
            if let Some(block) = &terms.curvature {
                add_block(&mut s, unknowns, block);
            }
        });
        match self.model {
            NaaModel::GaussNewton => {}
            NaaModel::Newton => normal.jtj += s,
            NaaModel::Adaptive => self.pending_curvature = Some((x.to_vec(), s)),
        }
        normal
    }

    /// S = Σ r∇²r at x for [`NaaModel::Adaptive`] (computed by the normal equations at the
    /// same x); None for the other models.
    fn curvature(&mut self, x: &[f64]) -> Option<DMatrix<f64>> {
        match self.pending_curvature.take() {
            Some((at, s)) if at == x => Some(s),
            _ => None,
        }
    }
}

fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

fn add(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] + b[0], a[1] + b[1]]
}

fn scale(f: f64, a: [f64; 2]) -> [f64; 2] {
    [f * a[0], f * a[1]]
}

fn divide(a: [f64; 2], by: f64) -> [f64; 2] {
    [a[0] / by, a[1] / by]
}
