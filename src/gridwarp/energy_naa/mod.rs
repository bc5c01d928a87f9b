//! The non-axis-aligned (NAA) distortion energy (seed §8; notes "Formulation: NAA", "Analytic
//! Jacobian: NAA", "Bounds"), mirroring the axis-aligned [`super::energy::AaEnergy`]. The
//! formula reads plainly, sample by sample, in [`super::plain::naa`]; this module is its fast
//! implementation (lane arrays, interleaved J_D, tiled sums, moments for S), tested against it
//! in `tests/gridwarp_plain.rs`.
//!
//! # Unknowns
//! The grid vertices P_ab ∈ R², a = 0..M−1 along s, b = 0..N−1 along t. By default (the paper's
//! count, seed Table 1) only the interior vertices move: x = (P_11.s, P_11.t, P_12.s, P_12.t, …),
//! vertex (a, b) at 2·((a−1)(N−2) + (b−1)) (see [`VertexGrid::unknown_index`]), (M−2)(N−2)·2
//! values, and the border vertices are **fixed** at their rest positions.
//!
//! Opt-in ([`VertexGrid::sliding_border`]): the non-corner border vertices also slide along their
//! edge (bottom/top edge vertices move in s, left/right ones in t; corners stay fixed), appended
//! after the interior unknowns: bottom edge s (a = 1..M−2), top edge s, left edge t (b = 1..N−2),
//! right edge t; 2(M−2)(N−2) + 2(M−2) + 2(N−2) values. Only this mode contains every AA grid
//! (moving AA line s_i moves its border vertices too) and reproduces the AA energy exactly. The
//! ROI's outline (the unit square) is preserved in both modes.
//!
//! # Energy
//! Rest cell (i, j) of size h_i × k_j is warped bilinearly,
//!   W(α, β) = (1−α)(1−β) P00 + α(1−β) P10 + (1−α)β P01 + αβ P11,
//! P00 = P_{i,j}, P10 = P_{i+1,j}, P01 = P_{i,j+1}, P11 = P_{i+1,j+1}. Per K×L midpoint sample
//! (α, β) of the cell: W_s = (∂W/∂α)/h_i, W_t = (∂W/∂β)/k_j, p = W(α, β),
//!   q_s = J_D(p) W_s,  q_t = J_D(p) W_t,  J_D = [D_s D_t] (3×2),
//!   r^s = σ (‖q_s‖ − o_s),  r^t = σ (‖q_t‖ − o_t),  σ = √w R(s, t),
//! with w, σ, o_s, o_t exactly as in the AA energy (same rest samples). On an axis-aligned vertex
//! grid W_s = (a_i, 0), q_s = a_i D_s and r^s is the AA residual σ(‖D_s‖ a_i − o_s).
//!
//! Since ‖D_s‖ alone does not give J_D W_s, the deformed frame is given by its full partial
//! derivative vectors D_s, D_t: [`DeformedJacobian`], six scalar [`Field`]s (x, y, z of each),
//! each sampled bilinearly (value and gradient).
//!
//! # Analytic Jacobian
//! φ_c the bilinear corner weights, u_s = q_s/‖q_s‖ (0 if q_s = 0), for coordinate k ∈ {s, t}:
//!   ∂r^s/∂P_c,k = σ [(∂φ_c/∂s) m_s,k + φ_c g_s,k],  m_s = J_D(p)ᵀ u_s,
//!   g_s,k = u_s · (∂_k J_D(p)) W_s   (the sample moving: ∂_k J_D from the fields' gradients),
//! ∂φ_c/∂s = (∂φ_c/∂α)/h_i; r^t likewise with ∂φ_c/∂t = (∂φ_c/∂β)/k_j and W_t. At most 8
//! non-zeros per row, all among the cell's 8 slots (its corners' coordinates): F, Jᵀr and JᵀJ
//! are accumulated per cell in an 8×8 block ([`crate::lm::LocalNormalEquations`]), cells in
//! parallel, and the blocks scattered in cell order (deterministic for any number of threads).
//! Inside a cell, samples are processed 8 at a time (one per lane); each of the 1 + 8 + 36
//! entries is summed per lane over the cell's samples (F and Jᵀr per axis too; JᵀJ in tiles
//! of 4×4 slots), then added in a fixed order (`super::lanes::cell_block_of`), so the sums
//! depend on the sample layout only.
//!
//! # Model Hessian
//! LM's model uses JᵀJ by default (Gauss–Newton, the paper's); [`NaaModel::Newton`] uses
//! JᵀJ + S, S = Σ r∇²r, both summed per cell as the moments of [`curvature`] (in place of the
//! 36 JᵀJ sums above); [`NaaModel::Adaptive`] hands LM JᵀJ (as Gauss–Newton) and S apart and
//! lets it choose per iteration.
//!
//! # Validity
//! det(∂W/∂α, ∂W/∂β) is bilinear in (α, β) (∂W/∂α depends on β only, ∂W/∂β on α only), so it
//! is positive over the whole cell iff it is positive at the cell's 4 corners. A vertex grid with any corner
//! determinant ≤ 0 has energy +∞ (a rejected LM trial). The per-coordinate foldover boxes of
//! [`naa_bounds`] are not sufficient for this (the notes' counterexample), hence the check.

pub mod curvature;

use curvature::{CellMoments, LaneJacobian};

use std::borrow::Cow;

use nalgebra::DMatrix;

use super::bounds::{foldover, loop_distance, merge, BoundOptions, Interval};
use super::energy::{rest_samples, RestFields, RestSample};
use super::field::{bilinear_formula, Axis, Field, Sample};
use super::grid::Grid;
use super::lanes::{
    axes_total, cell_block_of, cell_gradient_of, for_each_task, lanes, LaneResiduals, LANES,
};
use crate::lm::{Bounds, LocalNormalEquations, NormalEquations, Residuals};

/// A 3-vector field over the unit square: one scalar [`Field`] per component.
#[derive(Clone, Debug, PartialEq)]
pub struct VectorField {
    pub x: Field,
    pub y: Field,
    pub z: Field,
}

/// A bilinear sample of a [`VectorField`]: value and its derivatives along s and t.
#[derive(Clone, Copy, Debug, PartialEq)]
struct VectorSample {
    value: [f64; 3],
    ds: [f64; 3],
    dt: [f64; 3],
}

impl VectorField {
    /// The field v(s, t) sampled at the texel centres of a `width`×`height` grid.
    pub fn from_fn(width: usize, height: usize, f: impl Fn(f64, f64) -> [f64; 3]) -> VectorField {
        VectorField {
            x: Field::from_fn(width, height, |s, t| f(s, t)[0]),
            y: Field::from_fn(width, height, |s, t| f(s, t)[1]),
            z: Field::from_fn(width, height, |s, t| f(s, t)[2]),
        }
    }

    /// The three components at the [`Axis`] positions x, y ([`Field::bilinear_at`]: redone
    /// for a component of another resolution).
    #[inline(always)]
    fn bilinear_at(&self, x: &Axis, y: &Axis) -> VectorSample {
        let c: [Sample; 3] = [
            self.x.bilinear_at(x, y),
            self.y.bilinear_at(x, y),
            self.z.bilinear_at(x, y),
        ];
        VectorSample {
            value: c.map(|c| c.value),
            ds: c.map(|c| c.ds),
            dt: c.map(|c| c.dt),
        }
    }
}

/// The deformed frame's full partial derivative vectors D_s = ∂D/∂s and D_t = ∂D/∂t (the
/// columns of J_D), as the NAA energy needs them (the AA energy needs only their lengths,
/// [`super::energy::DeformedFields`]).
#[derive(Clone, Debug, PartialEq)]
pub struct DeformedJacobian {
    pub d_s: VectorField,
    pub d_t: VectorField,
}

impl DeformedJacobian {
    /// D_s, D_t of an analytic surface sampled on `size`×`size` fields (the vector counterpart
    /// of [`super::scene::stretch_fields`]).
    pub fn from_partials(
        size: usize,
        partials: impl Fn(f64, f64) -> (nalgebra::Vector3<f64>, nalgebra::Vector3<f64>),
    ) -> DeformedJacobian {
        let v = |x: nalgebra::Vector3<f64>| [x.x, x.y, x.z];
        DeformedJacobian {
            d_s: VectorField::from_fn(size, size, |s, t| v(partials(s, t).0)),
            d_t: VectorField::from_fn(size, size, |s, t| v(partials(s, t).1)),
        }
    }
}

/// The grid vertices P_ab, a = 0..m−1 (along s), b = 0..n−1 (along t).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct VertexGrid {
    pub m: usize,
    pub n: usize,
    /// P_ab = points[a·n + b] = [s, t].
    pub points: Vec<[f64; 2]>,
    /// Non-corner border vertices are unknowns sliding along their edge (default false: fixed).
    pub sliding_border: bool,
}

impl VertexGrid {
    /// The vertices of a rectilinear grid: P_ab = (s_a, t_b).
    pub fn from_grid(grid: &Grid) -> VertexGrid {
        let (m, n) = (grid.s.len(), grid.t.len());
        let mut points = Vec::with_capacity(m * n);
        for a in 0..m {
            for b in 0..n {
                points.push([grid.s[a], grid.t[b]]);
            }
        }
        VertexGrid {
            m,
            n,
            points,
            sliding_border: false,
        }
    }

    /// The same grid with border vertices sliding along their edges (`true`) or fixed.
    pub fn with_sliding_border(mut self, sliding: bool) -> VertexGrid {
        self.sliding_border = sliding;
        self
    }

    /// P_ab.
    pub fn at(&self, a: usize, b: usize) -> [f64; 2] {
        self.points[a * self.n + b]
    }

    /// Number of unknowns: (M−2)(N−2)·2, plus 2(M−2) + 2(N−2) with a sliding border.
    pub fn unknowns(&self) -> usize {
        let (mi, ni) = (self.m.saturating_sub(2), self.n.saturating_sub(2));
        2 * mi * ni
            + if self.sliding_border {
                2 * mi + 2 * ni
            } else {
                0
            }
    }

    /// Indices of P_ab's (s, t) coordinates in the unknowns; None for fixed coordinates.
    pub fn unknown_index(&self, a: usize, b: usize) -> [Option<usize>; 2] {
        let (m, n) = (self.m, self.n);
        let inner_a = a > 0 && a + 1 < m;
        let inner_b = b > 0 && b + 1 < n;
        if inner_a && inner_b {
            let k = 2 * ((a - 1) * (n - 2) + (b - 1));
            return [Some(k), Some(k + 1)];
        }
        if !self.sliding_border {
            return [None, None];
        }
        let (mi, ni) = (m.saturating_sub(2), n.saturating_sub(2));
        let base = 2 * mi * ni;
        if inner_a {
            // Bottom (b = 0) or top (b = N−1) edge: slides in s.
            let edge = usize::from(b != 0);
            return [Some(base + edge * mi + (a - 1)), None];
        }
        if inner_b {
            // Left (a = 0) or right (a = M−1) edge: slides in t.
            let edge = usize::from(a != 0);
            return [None, Some(base + 2 * mi + edge * ni + (b - 1))];
        }
        [None, None]
    }

    /// x = the free coordinates (interior vertices (s, t) a-major, then sliding border ones).
    pub fn to_unknowns(&self) -> Vec<f64> {
        let mut x = vec![0.0; self.unknowns()];
        for a in 0..self.m {
            for b in 0..self.n {
                for (k, idx) in self.unknown_index(a, b).into_iter().enumerate() {
                    if let Some(idx) = idx {
                        x[idx] = self.at(a, b)[k];
                    }
                }
            }
        }
        x
    }

    /// The grid with free coordinates taken from `x` (inverse of [`VertexGrid::to_unknowns`]).
    pub fn with_unknowns(&self, x: &[f64]) -> VertexGrid {
        let mut g = self.clone();
        for a in 0..self.m {
            for b in 0..self.n {
                for (k, idx) in self.unknown_index(a, b).into_iter().enumerate() {
                    if let Some(idx) = idx {
                        g.points[a * self.n + b][k] = x[idx];
                    }
                }
            }
        }
        g
    }

    /// det(∂W/∂α, ∂W/∂β) of cell (i, j) at its corners (α, β) = (0,0), (1,0), (0,1), (1,1).
    pub fn corner_determinants(&self, i: usize, j: usize) -> [f64; 4] {
        let (p00, p10, p01, p11) = (
            self.at(i, j),
            self.at(i + 1, j),
            self.at(i, j + 1),
            self.at(i + 1, j + 1),
        );
        let d = |a: [f64; 2], b: [f64; 2]| [a[0] - b[0], a[1] - b[1]];
        let det = |u: [f64; 2], v: [f64; 2]| u[0] * v[1] - u[1] * v[0];
        // ∂W/∂α = P10 − P00 at β = 0, P11 − P01 at β = 1; ∂W/∂β = P01 − P00 at α = 0,
        // P11 − P10 at α = 1.
        [
            det(d(p10, p00), d(p01, p00)),
            det(d(p10, p00), d(p11, p10)),
            det(d(p11, p01), d(p01, p00)),
            det(d(p11, p01), d(p11, p10)),
        ]
    }

    /// Every cell's bilinear map has a positive Jacobian determinant everywhere (checked at the
    /// corners, which suffices: the determinant is bilinear in (α, β)).
    pub fn is_valid(&self) -> bool {
        (0..self.m.saturating_sub(1)).all(|i| {
            (0..self.n.saturating_sub(1))
                .all(|j| self.corner_determinants(i, j).iter().all(|&d| d > 0.0))
        })
    }
}

/// The non-axis-aligned energy of one frame as a least-squares problem in the interior vertices.
pub struct NaaEnergy<'a> {
    /// Built for this energy ([`NaaEnergy::new`]) or shared by a sequence's frames.
    rest: Cow<'a, NaaRestSamples>,
    rest_vertices: VertexGrid,
    deformed: &'a DeformedJacobian,
    /// The six components of J_D interleaved per texel, when they share one resolution.
    packed: Option<PackedJacobian>,
    /// What [`Residuals::normal_equations`] returns as "JᵀJ": see [`NaaModel`].
    model: NaaModel,
    /// S at the point of the last normal equations, for [`Residuals::curvature`]
    /// ([`NaaModel::Adaptive`] only).
    pending_curvature: Option<(Vec<f64>, DMatrix<f64>)>,
}

/// The model Hessian the NAA energy hands to LM in place of JᵀJ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum NaaModel {
    /// JᵀJ: Gauss–Newton, the paper's (ALGLIB's Jacobian-only protocol). The default.
    #[default]
    GaussNewton,
    /// JᵀJ + S, S = Σ r∇²r ([`curvature`]): the norm's curvature too (ALGLIB's exact-Hessian
    /// protocol, in spirit). May be indefinite: LM then damps more. Each evaluation costs about
    /// 1.4× a Gauss–Newton one (JᵀJ + S from the residual pass's texel reads, summed as
    /// moments: [`curvature`]). Measured on the built-in scenes (frame 4 of 4, 8×8 samples,
    /// 48/192/288 unknowns), Jacobian evaluations Gauss–Newton → Newton: saddle 19/35/46 →
    /// 8/8/8, bump 36/65/100 → 12/17/18, plane 24/100/100 → 27/7/8 (same minima); worm
    /// 7/64/14 → 37/54/38 (other local minima at 48 and 288): not always faster.
    Newton,
    /// Either model, chosen per iteration (NL2SOL's rule, Dennis, Gay & Welsch 1981): LM gets
    /// JᵀJ and S apart ([`Residuals::curvature`]) and, after each accepted step, keeps for
    /// the next one the model whose predicted decrease was closer to the actual decrease
    /// ([`crate::lm`], "Other model Hessians"). Evaluations cost what Newton's do. Measured as
    /// above: saddle 8/9/9, bump 20/16/21, plane 29/7/8 (same minima), worm 30/47/22 (the
    /// Gauss–Newton minima at 192 and 288, a lower one at 48): never a worse minimum there.
    Adaptive,
}

/// The rest side of the non-axis-aligned energy: the rest samples (cell (i, j)'s K·L samples
/// in the order of [`rest_samples`], exactly the axis-aligned energy's) and, per sample, the
/// bilinear weights' slopes that do not depend on the unknowns: [(1−β)/h_i, β/h_i,
/// (1−α)/k_j, α/k_j] (∂φ_c/∂s and ∂φ_c/∂t up to sign), structure-of-arrays, padded per cell
/// for the lane loops (`SampleLanes`). They depend only on the rest fields, the rest grid
/// and K×L, so a sequence builds them once (the paper's preprocessing;
/// [`super::solve::solve_naa_sequence`]) and every frame's [`NaaEnergy`] reads them
/// ([`NaaEnergy::from_rest_samples`]), as the axis-aligned energy's
/// [`super::energy::RestSamples`].
#[derive(Clone, Debug)]
pub struct NaaRestSamples {
    grid: Grid,
    per_cell: (usize, usize),
    lanes: SampleLanes,
}

impl NaaRestSamples {
    /// The K×L midpoint samples of every rest cell ([`rest_samples`]) and their weight slopes.
    pub fn new(rest: &RestFields, rest_grid: &Grid, k: usize, l: usize) -> NaaRestSamples {
        let samples = rest_samples(rest, rest_grid, k, l);
        let per_cell = k.max(1) * l.max(1);
        let rows = rest_grid.t.len() - 1;
        let weight_slopes: Vec<[f64; 4]> = samples
            .chunks_exact(per_cell)
            .enumerate()
            .flat_map(|(cell, cell_samples)| {
                let (i, j) = (cell / rows, cell % rows);
                let h = rest_grid.s[i + 1] - rest_grid.s[i];
                let kj = rest_grid.t[j + 1] - rest_grid.t[j];
                cell_samples.iter().map(move |p| {
                    [
                        (1.0 - p.beta) / h,
                        p.beta / h,
                        (1.0 - p.alpha) / kj,
                        p.alpha / kj,
                    ]
                })
            })
            .collect();
        NaaRestSamples {
            grid: rest_grid.clone(),
            per_cell: (k.max(1), l.max(1)),
            lanes: SampleLanes::new(&samples, &weight_slopes, per_cell),
        }
    }

    /// The rest grid these samples belong to.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Samples per cell (K, L).
    pub fn per_cell(&self) -> (usize, usize) {
        self.per_cell
    }
}

/// The rest samples and weight slopes of [`NaaEnergy`] structure-of-arrays: cell c's samples
/// at c·P …, P = K·L rounded up to a multiple of [`LANES`] (the samples of a cell processed
/// together, 8 f64 in one 512-bit register), the padding with σ = 0 (its residuals and
/// derivatives are exactly 0; the per-residual visits skip it).
#[derive(Clone, Debug)]
pub(super) struct SampleLanes {
    padded: usize,
    alpha: Vec<f64>,
    beta: Vec<f64>,
    sigma: Vec<f64>,
    o_s: Vec<f64>,
    o_t: Vec<f64>,
    /// [(1−β)/h_i, β/h_i, (1−α)/k_j, α/k_j] of each sample, one vector per entry.
    slopes: [Vec<f64>; 4],
}

impl SampleLanes {
    fn new(samples: &[RestSample], slopes: &[[f64; 4]], per_cell: usize) -> SampleLanes {
        let padded = per_cell.div_ceil(LANES) * LANES;
        let size = samples.len() / per_cell * padded;
        let mut out = SampleLanes {
            padded,
            alpha: vec![0.0; size],
            beta: vec![0.0; size],
            sigma: vec![0.0; size],
            o_s: vec![0.0; size],
            o_t: vec![0.0; size],
            slopes: std::array::from_fn(|_| vec![0.0; size]),
        };
        for (n, (sample, slopes)) in samples.iter().zip(slopes).enumerate() {
            // Sample k of cell c at c·P + k.
            let at = n / per_cell * padded + n % per_cell;
            out.alpha[at] = sample.alpha;
            out.beta[at] = sample.beta;
            out.sigma[at] = sample.sigma;
            out.o_s[at] = sample.o_s;
            out.o_t[at] = sample.o_t;
            for (v, &slope) in out.slopes.iter_mut().zip(slopes) {
                v[at] = slope;
            }
        }
        out
    }
}

/// J_D = [D_s D_t] at a point with its derivatives along s and t: [`PackedJacobian`], or the
/// six fields one by one ([`FieldJacobian`]) when they do not share one resolution.
trait JacobianAt {
    fn at(&self, p: [f64; 2]) -> (VectorSample, VectorSample);
}

/// The six fields of a [`DeformedJacobian`] sampled one by one ([`Field::bilinear_at`]).
struct FieldJacobian<'a>(&'a DeformedJacobian);

impl JacobianAt for FieldJacobian<'_> {
    #[inline(always)]
    fn at(&self, p: [f64; 2]) -> (VectorSample, VectorSample) {
        let first = &self.0.d_s.x;
        let (x, y) = (Axis::new(p[0], first.width), Axis::new(p[1], first.height));
        (
            self.0.d_s.bilinear_at(&x, &y),
            self.0.d_t.bilinear_at(&x, &y),
        )
    }
}

impl JacobianAt for PackedJacobian {
    #[inline(always)]
    fn at(&self, p: [f64; 2]) -> (VectorSample, VectorSample) {
        self.bilinear(p)
    }
}

impl<'a> NaaEnergy<'a> {
    /// Precompute the rest-point quantities of every sample: K×L midpoints per cell (exactly the
    /// AA energy's rest samples; [`NaaRestSamples`]).
    pub fn new(
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &'a DeformedJacobian,
        k: usize,
        l: usize,
    ) -> Self {
        Self::with_rest(
            Cow::Owned(NaaRestSamples::new(rest, rest_grid, k, l)),
            deformed,
        )
    }

    /// The energy of `deformed` over rest samples built beforehand (once per sequence).
    pub fn from_rest_samples(samples: &'a NaaRestSamples, deformed: &'a DeformedJacobian) -> Self {
        Self::with_rest(Cow::Borrowed(samples), deformed)
    }

    fn with_rest(rest: Cow<'a, NaaRestSamples>, deformed: &'a DeformedJacobian) -> Self {
        NaaEnergy {
            rest_vertices: VertexGrid::from_grid(&rest.grid),
            rest,
            deformed,
            packed: PackedJacobian::new(deformed),
            model: NaaModel::GaussNewton,
            pending_curvature: None,
        }
    }

    /// Use `model` as LM's model Hessian ([`NaaModel`]; default Gauss–Newton).
    pub fn with_model(mut self, model: NaaModel) -> Self {
        self.model = model;
        self
    }

    /// Let the non-corner border vertices slide along their edges (see the module docs).
    pub fn with_sliding_border(mut self, sliding: bool) -> Self {
        self.rest_vertices.sliding_border = sliding;
        self
    }

    /// The rest vertices (the starting point of a first frame).
    pub fn rest_vertices(&self) -> &VertexGrid {
        &self.rest_vertices
    }

    fn columns(&self) -> usize {
        self.rest.grid.s.len() - 1
    }

    fn rows(&self) -> usize {
        self.rest.grid.t.len() - 1
    }

    fn cells(&self) -> usize {
        self.columns() * self.rows()
    }

    /// The unknowns of cell `cell` = (i, j) in slot order: corners P00 = P_ij, P10, P01, P11,
    /// each (s, t); None for fixed coordinates.
    pub fn cell_unknowns(&self, g: &VertexGrid, cell: usize) -> [Option<usize>; 8] {
        let (i, j) = (cell / self.rows(), cell % self.rows());
        let [a, b, c, d] = [
            g.unknown_index(i, j),
            g.unknown_index(i + 1, j),
            g.unknown_index(i, j + 1),
            g.unknown_index(i + 1, j + 1),
        ];
        [a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]]
    }

    /// The rest size (h_i, k_j) of cell `cell` = (i, j).
    fn cell_extent(&self, cell: usize) -> (f64, f64) {
        let (i, j) = (cell / self.rows(), cell % self.rows());
        (
            self.rest.grid.s[i + 1] - self.rest.grid.s[i],
            self.rest.grid.t[j + 1] - self.rest.grid.t[j],
        )
    }

    /// The bilinear warp of cell `cell` = (i, j) at the vertices `g`.
    fn cell_warp(&self, g: &VertexGrid, cell: usize) -> CellWarp {
        let (i, j) = (cell / self.rows(), cell % self.rows());
        let (h, k) = self.cell_extent(cell);
        CellWarp::new(
            [
                g.at(i, j),
                g.at(i + 1, j),
                g.at(i, j + 1),
                g.at(i + 1, j + 1),
            ],
            h,
            k,
        )
    }

    /// The residuals (r^s, r^t) of the LANES samples from `at` on (an index into the lane
    /// arrays) of the cell warped by `warp`, values only (what an energy-only evaluation
    /// needs): r = σ (‖J_D(p) W_·‖ − o_·).
    #[inline(always)]
    fn chunk_values(&self, jac: &impl JacobianAt, warp: &CellWarp, at: usize) -> [[f64; LANES]; 2] {
        let s = &self.rest.lanes;
        let (alpha, beta, sigma) = (lanes(&s.alpha, at), lanes(&s.beta, at), lanes(&s.sigma, at));
        let (o_s, o_t) = (lanes(&s.o_s, at), lanes(&s.o_t, at));
        let mut r = [[0.0; LANES]; 2];
        for lane in 0..LANES {
            let w = warp.at(alpha[lane], beta[lane]);
            let (ds, dt) = jac.at(w.pos);
            r[0][lane] = sigma[lane] * (norm(image(&ds.value, &dt.value, w.w_s)) - o_s[lane]);
            r[1][lane] = sigma[lane] * (norm(image(&ds.value, &dt.value, w.w_t)) - o_t[lane]);
        }
        r
    }

    /// The residuals of the LANES samples from `at` on with their derivatives in the slot
    /// order of [`NaaEnergy::cell_unknowns`] (module docs, "Analytic Jacobian"), with u = q/‖q‖
    /// folded into one factor per residual:
    ///   ∂r/∂P_c,k = (∂φ_c/∂s) σm_k + φ_c σg_k,  σm = (σ/‖q‖) J_Dᵀ q,
    ///   σg_k = (σ/‖q‖) q · (∂_k J_D) W_s   (σ/‖q‖ taken as 0 for q = 0),
    /// and r^t likewise. With `KEEP_JACOBIAN` (the second-order models), also J_D and W of
    /// each lane, for S ([`curvature::LaneJacobian`]). One simple loop over the lanes: the
    /// compiler runs the lanes side by side in vector registers.
    #[inline(always)]
    fn chunk_residuals<const KEEP_JACOBIAN: bool>(
        &self,
        jac: &impl JacobianAt,
        warp: &CellWarp,
        at: usize,
    ) -> (LaneResiduals<8>, LaneJacobian) {
        let s = &self.rest.lanes;
        let (alpha, beta, sigma) = (lanes(&s.alpha, at), lanes(&s.beta, at), lanes(&s.sigma, at));
        let (o_s, o_t) = (lanes(&s.o_s, at), lanes(&s.o_t, at));
        let [bs, bt, as_, at_] = s.slopes.each_ref().map(|v| lanes(v, at));
        let mut out = LaneResiduals {
            r: [[0.0; LANES]; 2],
            d: [[[0.0; LANES]; 8]; 2],
        };
        let mut kept = LaneJacobian::zeros();
        for lane in 0..LANES {
            let (al, be, sg) = (alpha[lane], beta[lane], sigma[lane]);
            let w = warp.at(al, be);
            let (ds, dt) = jac.at(w.pos);
            if KEEP_JACOBIAN {
                kept.set(lane, &ds, &dt, [w.w_s, w.w_t]);
            }
            // φ_c and ∂φ_c/∂s = (∂φ_c/∂α)/h, ∂φ_c/∂t = (∂φ_c/∂β)/k for the corners 00, 10, 01, 11.
            let phi = [
                (1.0 - al) * (1.0 - be),
                al * (1.0 - be),
                (1.0 - al) * be,
                al * be,
            ];
            let dphi_ds = [-bs[lane], bs[lane], -bt[lane], bt[lane]];
            let dphi_dt = [-as_[lane], -at_[lane], as_[lane], at_[lane]];
            let axes = [(w.w_s, dphi_ds, o_s[lane]), (w.w_t, dphi_dt, o_t[lane])];
            for (axis, (w, dphi, o)) in axes.into_iter().enumerate() {
                let q = image(&ds.value, &dt.value, w);
                let length = norm(q);
                let factor = if length > 0.0 { sg / length } else { 0.0 };
                let m = [factor * dot(ds.value, q), factor * dot(dt.value, q)];
                let gk = [
                    factor * dot(q, image(&ds.ds, &dt.ds, w)),
                    factor * dot(q, image(&ds.dt, &dt.dt, w)),
                ];
                out.r[axis][lane] = sg * (length - o);
                for c in 0..4 {
                    for k in 0..2 {
                        out.d[axis][2 * c + k][lane] = dphi[c] * m[k] + phi[c] * gk[k];
                    }
                }
            }
        }
        (out, kept)
    }

    /// Σ r² over cell `cell`'s residuals: per-lane, per-axis sums over the cell's chunks (the
    /// padding adding exactly 0), then per lane r^s² + r^t² and the lanes in lane order
    /// ([`axes_total`]); the same sums, bit for bit, as the energy of
    /// [`NaaEnergy::cell_block_with`] ([`super::lanes::chunk_sum`]).
    #[inline(always)]
    fn cell_energy_with(&self, jac: &impl JacobianAt, g: &VertexGrid, cell: usize) -> f64 {
        let warp = self.cell_warp(g, cell);
        let first = cell * self.rest.lanes.padded;
        let mut sums = [[0.0; LANES]; 2];
        for at in (first..first + self.rest.lanes.padded).step_by(LANES) {
            let r = self.chunk_values(jac, &warp, at);
            for (sums, r) in sums.iter_mut().zip(&r) {
                for lane in 0..LANES {
                    sums[lane] += r[lane] * r[lane];
                }
            }
        }
        axes_total(&sums)
    }

    /// Cell `cell`'s F, JᵀJ and Jᵀr over its eight slots: the residuals of its chunks into
    /// `chunks` (a buffer reused from cell to cell), then their per-lane sums of the
    /// 1 + 8 + 36 entries ([`cell_block_of`]).
    #[inline(always)]
    fn cell_block_with(
        &self,
        jac: &impl JacobianAt,
        g: &VertexGrid,
        cell: usize,
        chunks: &mut Vec<LaneResiduals<8>>,
    ) -> CellBlock {
        let warp = self.cell_warp(g, cell);
        let first = cell * self.rest.lanes.padded;
        chunks.clear();
        let mut block = CellBlock::default();
        if self.model == NaaModel::GaussNewton {
            for at in (first..first + self.rest.lanes.padded).step_by(LANES) {
                chunks.push(self.chunk_residuals::<false>(jac, &warp, at).0);
            }
            block.normal = cell_block_of(chunks);
        } else {
            // S from the same texel reads: J_D kept per chunk, its moments summed per cell;
            // for Newton the moments hold JᵀJ + S at once ([`curvature`], "Moments").
            let newton = self.model == NaaModel::Newton;
            let mut moments = CellMoments::zeros();
            for at in (first..first + self.rest.lanes.padded).step_by(LANES) {
                let (chunk, kept) = self.chunk_residuals::<true>(jac, &warp, at);
                chunks.push(chunk);
                moments.add_chunk(&self.rest.lanes, at, &kept, newton);
            }
            let (h, k) = self.cell_extent(cell);
            if newton {
                block.normal = cell_gradient_of(chunks);
                block.normal.jtj = moments.matrix(h, k);
            } else {
                block.normal = cell_block_of(chunks);
                block.curvature.jtj = moments.matrix(h, k);
            }
        }
        block
    }

    /// `out[c] = cell_energy(first + c)`.
    #[inline(always)]
    fn fill_energies_with(
        &self,
        jac: &impl JacobianAt,
        g: &VertexGrid,
        first: usize,
        out: &mut [f64],
    ) {
        for (c, e) in out.iter_mut().enumerate() {
            *e = self.cell_energy_with(jac, g, first + c);
        }
    }

    /// `out[c] = cell_block(first + c)`.
    #[inline(always)]
    fn fill_blocks_with(
        &self,
        jac: &impl JacobianAt,
        g: &VertexGrid,
        first: usize,
        out: &mut [CellBlock],
    ) {
        let mut chunks = Vec::with_capacity(self.rest.lanes.padded / LANES);
        for (c, block) in out.iter_mut().enumerate() {
            *block = self.cell_block_with(jac, g, first + c, &mut chunks);
        }
    }

    /// [`NaaEnergy::fill_energies_with`] on the packed J_D if there is one.
    #[inline(always)]
    fn fill_energies_baseline(&self, g: &VertexGrid, first: usize, out: &mut [f64]) {
        match &self.packed {
            Some(packed) => self.fill_energies_with(packed, g, first, out),
            None => self.fill_energies_with(&FieldJacobian(self.deformed), g, first, out),
        }
    }

    /// [`NaaEnergy::fill_blocks_with`] on the packed J_D if there is one.
    #[inline(always)]
    fn fill_blocks_baseline(&self, g: &VertexGrid, first: usize, out: &mut [CellBlock]) {
        match &self.packed {
            Some(packed) => self.fill_blocks_with(packed, g, first, out),
            None => self.fill_blocks_with(&FieldJacobian(self.deformed), g, first, out),
        }
    }

    /// [`NaaEnergy::fill_energies_baseline`] compiled with AVX-512 (8 lanes in one register,
    /// gathers for the texel reads): the same IEEE operations in the same order (Rust never
    /// fuses a multiply and an add by itself), so the same results bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn fill_energies_avx512(&self, g: &VertexGrid, first: usize, out: &mut [f64]) {
        self.fill_energies_baseline(g, first, out)
    }

    /// [`NaaEnergy::fill_blocks_baseline`] compiled with AVX-512: the lane sums fit in
    /// vector registers (same results bit for bit).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn fill_blocks_avx512(&self, g: &VertexGrid, first: usize, out: &mut [CellBlock]) {
        self.fill_blocks_baseline(g, first, out)
    }

    /// Cell energies `first..` into `out`, AVX-512 if the CPU has it.
    fn fill_energies(&self, g: &VertexGrid, first: usize, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { self.fill_energies_avx512(g, first, out) };
        }
        self.fill_energies_baseline(g, first, out)
    }

    /// Cell blocks `first..` into `out`, AVX-512 if the CPU has it.
    fn fill_blocks(&self, g: &VertexGrid, first: usize, out: &mut [CellBlock]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { self.fill_blocks_avx512(g, first, out) };
        }
        self.fill_blocks_baseline(g, first, out)
    }

    /// Visit every residual of cell `cell` = (i, j) at the vertices `g` (σ ≠ 0 samples, in
    /// the order sample, axis): `visit(r, ∂r/∂x)`, the derivatives in the slot order of
    /// [`NaaEnergy::cell_unknowns`] (module docs, "Analytic Jacobian"). The lane loops'
    /// formulas, one residual at a time; for the test helpers below.
    #[inline(always)]
    fn for_each_residual(&self, g: &VertexGrid, cell: usize, visit: impl FnMut(f64, &[f64; 8])) {
        match &self.packed {
            Some(packed) => self.for_each_residual_with(packed, g, cell, visit),
            None => self.for_each_residual_with(&FieldJacobian(self.deformed), g, cell, visit),
        }
    }

    #[inline(always)]
    fn for_each_residual_with(
        &self,
        jac: &impl JacobianAt,
        g: &VertexGrid,
        cell: usize,
        mut visit: impl FnMut(f64, &[f64; 8]),
    ) {
        let warp = self.cell_warp(g, cell);
        let first = cell * self.rest.lanes.padded;
        for at in (first..first + self.rest.lanes.padded).step_by(LANES) {
            let (chunk, _) = self.chunk_residuals::<false>(jac, &warp, at);
            let sigma = lanes(&self.rest.lanes.sigma, at);
            for (lane, &sigma) in sigma.iter().enumerate() {
                if sigma != 0.0 {
                    for axis in 0..2 {
                        let d = std::array::from_fn(|slot| chunk.d[axis][slot][lane]);
                        visit(chunk.r[axis][lane], &d);
                    }
                }
            }
        }
    }

    /// All residuals at `x`, in a fixed order (cell column, row, sample, axis). For tests.
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        let g = self.rest_vertices.with_unknowns(x);
        let mut out = Vec::new();
        for cell in 0..self.cells() {
            self.for_each_residual(&g, cell, |r, _| out.push(r));
        }
        out
    }

    /// The dense Jacobian at `x` (rows as in [`NaaEnergy::residuals`]). For tests.
    pub fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        let g = self.rest_vertices.with_unknowns(x);
        let mut rows = Vec::new();
        for cell in 0..self.cells() {
            let slots = self.cell_unknowns(&g, cell);
            self.for_each_residual(&g, cell, |_, d| rows.push((slots, *d)));
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

    /// One cell's energy and normal equations over its eight slots.
    pub fn cell_normal_equations(&self, g: &VertexGrid, cell: usize) -> LocalNormalEquations<8> {
        let mut block = [CellBlock::default()];
        self.fill_blocks(g, cell, &mut block);
        block[0].normal
    }

    /// Fill `out` (one entry per cell) by `fill(first cell, part)`, in parallel tasks of
    /// `samples_per_task` samples ([`super::lanes::for_each_task`]: the split depends on the
    /// problem size only).
    fn per_cell<T: Send>(
        &self,
        out: &mut [T],
        samples_per_task: usize,
        fill: impl Fn(usize, &mut [T]) + Sync,
    ) {
        for_each_task(out, self.rest.lanes.padded, samples_per_task, fill);
    }
}

/// The six scalar fields of a [`DeformedJacobian`] (D_s.x, D_s.y, D_s.z, D_t.x, D_t.y, D_t.z)
/// interleaved per texel, so that a sample finds its texel positions once and reads 4
/// neighbouring texels instead of 24 scattered values. Same interpolation
/// ([`super::field::interpolate`]), same values as sampling the fields one by one.
struct PackedJacobian {
    width: u32,
    height: u32,
    /// Texel (x, y) at y·width + x; its 6·width·height values are indexed by u32 (32-bit
    /// index arithmetic in the lane loops).
    texels: Vec<[f64; 6]>,
}

impl PackedJacobian {
    /// The interleaved fields, or None if the six do not share one resolution (or have more
    /// than 2³² values in all).
    fn new(d: &DeformedJacobian) -> Option<PackedJacobian> {
        let fields = [&d.d_s.x, &d.d_s.y, &d.d_s.z, &d.d_t.x, &d.d_t.y, &d.d_t.z];
        let (width, height) = (fields[0].width, fields[0].height);
        if fields
            .iter()
            .any(|f| (f.width, f.height) != (width, height))
        {
            return None;
        }
        u32::try_from(6 * width * height).ok()?;
        let texels = (0..width * height)
            .map(|i| fields.map(|f| f.values[i]))
            .collect();
        Some(PackedJacobian {
            width: width as u32,
            height: height as u32,
            texels,
        })
    }

    /// D_s and D_t at p with their derivatives along s and t. Branch-free (texel positions by
    /// [`texel_axis`], texels read through `get`), so that a loop over samples vectorises.
    #[inline(always)]
    fn bilinear(&self, p: [f64; 2]) -> (VectorSample, VectorSample) {
        let (x, y) = (texel_axis(p[0], self.width), texel_axis(p[1], self.height));
        let texels = self.texels.as_flattened();
        // Component c of texel (column, row); the positions are always in range, so the
        // fallback is never taken (it only spares the loop a panic branch).
        let texel = |row: u32, column: u32, c: u32| {
            texels
                .get(((row * self.width + column) * 6 + c) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let at = |c: u32| {
            bilinear_formula(
                (x.frac, x.scale),
                (y.frac, y.scale),
                [
                    texel(y.lower, x.lower, c),
                    texel(y.lower, x.upper, c),
                    texel(y.upper, x.lower, c),
                    texel(y.upper, x.upper, c),
                ],
            )
        };
        let c: [Sample; 6] = [at(0), at(1), at(2), at(3), at(4), at(5)];
        let vector = |c: &[Sample]| VectorSample {
            value: [c[0].value, c[1].value, c[2].value],
            ds: [c[0].ds, c[1].ds, c[2].ds],
            dt: [c[0].dt, c[1].dt, c[2].dt],
        };
        (vector(&c[..3]), vector(&c[3..]))
    }
}

/// A coordinate's texel position on one axis: [`Axis::new`]'s lower, upper, frac and scale
/// (the same values), computed with selects instead of branches.
struct TexelAxis {
    lower: u32,
    upper: u32,
    frac: f64,
    scale: f64,
}

/// [`Axis::new`] without branches: u = s·n − ½; inside the texel-centre range (0 < u < n − 1)
/// lower = ⌊u⌋, upper = lower + 1, frac = u − lower, scale = n; clamped to the first texel for
/// u ≤ 0 (or NaN) and to the last for u ≥ n − 1, with frac = scale = 0.
#[inline(always)]
fn texel_axis(s: f64, n: u32) -> TexelAxis {
    let u = s * n as f64 - 0.5;
    let last = n.saturating_sub(1);
    let inside = n > 1 && u > 0.0 && u < last as f64;
    let high = n > 1 && u >= last as f64;
    // Truncation of u in [0, n − 1] (its floor inside the range), one vector instruction.
    // SAFETY: max(0) (which also sends NaN to 0) and min(n − 1) leave a finite value in
    // [0, n − 1], which a u32 holds (n is a u32).
    let floor: u32 = unsafe { u.max(0.0).min(last as f64).to_int_unchecked() };
    let lower = if inside {
        floor
    } else if high {
        last
    } else {
        0
    };
    TexelAxis {
        lower,
        upper: if inside { lower + 1 } else { lower },
        frac: if inside { u - lower as f64 } else { 0.0 },
        scale: if inside { n as f64 } else { 0.0 },
    }
}

/// The bilinear warp of one rest cell of size h × k onto the quadrilateral of its corners
/// P00, P10, P01, P11 (module docs, "Energy"):
///   W(α, β) = P00 + α e_α + β e_β + αβ τ,  e_α = P10 − P00,  e_β = P01 − P00,
///   τ = P11 − P10 − P01 + P00 (the twist; exactly 0 on a rectangle, so that an axis-aligned
///   grid reproduces the AA sample points and slopes bit for bit).
/// The slopes W_s = (∂W/∂α)/h = e_α/h + β τ/h and W_t = e_β/k + α τ/k take the quotients
/// once per cell (on a rectangle β·0 adds exactly 0: the AA slopes e_α/h, e_β/k).
struct CellWarp {
    p00: [f64; 2],
    e_a0: [f64; 2],
    e_b0: [f64; 2],
    twist: [f64; 2],
    /// e_α/h, τ/h, e_β/k, τ/k.
    e_a0_h: [f64; 2],
    twist_h: [f64; 2],
    e_b0_k: [f64; 2],
    twist_k: [f64; 2],
}

/// One sample point of a [`CellWarp`]: p = W(α, β), W_s = (∂W/∂α)/h, W_t = (∂W/∂β)/k.
struct WarpedPoint {
    pos: [f64; 2],
    w_s: [f64; 2],
    w_t: [f64; 2],
}

impl CellWarp {
    /// The warp of the corners [P00, P10, P01, P11] of a rest cell of size h × k.
    fn new([p00, p10, p01, p11]: [[f64; 2]; 4], h: f64, k: f64) -> CellWarp {
        let e_a0 = sub(p10, p00); // ∂W/∂α at β = 0
        let e_b0 = sub(p01, p00); // ∂W/∂β at α = 0
        let twist = sub(sub(p11, p10), e_b0);
        let divide = |v: [f64; 2], by: f64| [v[0] / by, v[1] / by];
        CellWarp {
            p00,
            e_a0,
            e_b0,
            twist,
            e_a0_h: divide(e_a0, h),
            twist_h: divide(twist, h),
            e_b0_k: divide(e_b0, k),
            twist_k: divide(twist, k),
        }
    }

    /// W, W_s = e_α/h + β τ/h and W_t = e_β/k + α τ/k at (α, β).
    #[inline(always)]
    fn at(&self, al: f64, be: f64) -> WarpedPoint {
        WarpedPoint {
            pos: add(
                add(self.p00, scale(al, self.e_a0)),
                add(scale(be, self.e_b0), scale(al * be, self.twist)),
            ),
            w_s: add(self.e_a0_h, scale(be, self.twist_h)),
            w_t: add(self.e_b0_k, scale(al, self.twist_k)),
        }
    }
}

/// q = J_D w = D_s w₀ + D_t w₁ (seed eq. 7–8), J_D's columns given as `d_s`, `d_t` (also
/// used with their derivatives along s or t).
#[inline(always)]
fn image(d_s: &[f64; 3], d_t: &[f64; 3], w: [f64; 2]) -> [f64; 3] {
    [
        d_s[0] * w[0] + d_t[0] * w[1],
        d_s[1] * w[0] + d_t[1] * w[1],
        d_s[2] * w[0] + d_t[2] * w[1],
    ]
}

/// ‖q‖.
#[inline(always)]
fn norm(q: [f64; 3]) -> f64 {
    (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt()
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

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

impl Residuals for NaaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest_vertices.unknowns()
    }

    /// F(x) = Σ r², per cell in parallel, then summed in cell order (deterministic); +∞ if any
    /// cell folds (a corner determinant ≤ 0).
    fn energy(&mut self, x: &[f64]) -> f64 {
        let g = self.rest_vertices.with_unknowns(x);
        if !g.is_valid() {
            return f64::INFINITY;
        }
        let mut per_cell = vec![0.0; self.cells()];
        self.per_cell(&mut per_cell, ENERGY_SAMPLES_PER_TASK, |first, out| {
            self.fill_energies(&g, first, out)
        });
        per_cell.iter().sum()
    }

    /// F, JᵀJ and Jᵀr: each cell's 8×8 block (cells in parallel), scattered in cell order
    /// (deterministic for any number of threads). At a folded grid: F = +∞ and zero JᵀJ, Jᵀr
    /// (the solver rejects such a starting point).
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        let n = self.dim();
        let g = self.rest_vertices.with_unknowns(x);
        if !g.is_valid() {
            return NormalEquations {
                energy: f64::INFINITY,
                ..NormalEquations::zeros(n)
            };
        }
        let mut blocks = vec![CellBlock::default(); self.cells()];
        self.per_cell(&mut blocks, BLOCK_SAMPLES_PER_TASK, |first, out| {
            self.fill_blocks(&g, first, out)
        });
        let slots: Vec<[Option<usize>; 8]> = (0..self.cells())
            .map(|c| self.cell_unknowns(&g, c))
            .collect();
        let model = blocks.iter().map(|b| &b.normal);
        if self.model == NaaModel::Adaptive {
            let curvature = blocks.iter().map(|b| &b.curvature);
            let s = NormalEquations::assemble(n, slots.iter().zip(curvature)).jtj;
            self.pending_curvature = Some((x.to_vec(), s));
        }
        NormalEquations::assemble(n, slots.iter().zip(model))
    }

    /// S = Σ r∇²r at x for [`NaaModel::Adaptive`] (computed by the normal equations at the
    /// same x, which LM asks for first); None for the other models.
    fn curvature(&mut self, x: &[f64]) -> Option<DMatrix<f64>> {
        match self.pending_curvature.take() {
            Some((at, s)) if at == x => Some(s),
            _ => None,
        }
    }
}

/// One cell's normal equations with the model Hessian LM gets in place of JᵀJ (JᵀJ, or
/// JᵀJ + S for [`NaaModel::Newton`]) and, for [`NaaModel::Adaptive`], its block of
/// S = Σ r∇²r apart (in `curvature.jtj`; zero for the other models).
#[derive(Clone, Copy, Debug, Default)]
struct CellBlock {
    normal: LocalNormalEquations<8>,
    curvature: LocalNormalEquations<8>,
}

/// Samples per parallel task of an energy-only evaluation at most, and the fewest worth
/// splitting ([`super::lanes::for_each_task`]): tens of microseconds of work (≈ 12 ns a
/// sample here). With 8×8 samples the 48-unknown problem (35 cells, 2,240 samples) is split
/// in two. Results do not depend on it.
const ENERGY_SAMPLES_PER_TASK: usize = 2048;

/// The same for a normal-equations evaluation. A sample's residuals, 16 derivatives and
/// 2 × 45 products cost about three times its energy, but fewer, larger tasks still came
/// out faster on two threads: at 48 unknowns (8×8 samples, Newton and Gauss–Newton solves,
/// best of 200) one task per thread took 17–20% less time than 5 tasks of ≤ 512 samples and
/// 6–13% less than 4 tasks of ≤ 560.
const BLOCK_SAMPLES_PER_TASK: usize = 2048;

/// Foldover interval of one coordinate: between the midpoints to the previous neighbours along
/// that axis (with [`super::bounds::FOLDOVER_MARGIN`]); frozen at the current value if those
/// neighbours are not ordered along the axis (the box would be empty).
fn foldover_coordinate(prev: f64, here: f64, next: f64) -> Interval {
    let box_ = foldover(&[prev, here, next], 1);
    if box_.lo <= here && here <= box_.hi {
        box_
    } else {
        Interval { lo: here, hi: here }
    }
}

/// The merged bounds of every unknown for the next frame: per coordinate the foldover box of
/// seed §5.2 (s of P_ab between the midpoints to P_{a−1,b}, P_{a+1,b} in `previous`; t between
/// those to P_{a,b−1}, P_{a,b+1}), merged with the smoothness box |P' − P| ≤ o and, for looping
/// frame j of K, the looping box |P' − P⁰| ≤ d_j·o around `first`: F(C_L, F(C_F, C_S)).
///
/// These boxes do not prevent fold-overs (notes "Bounds"); [`NaaEnergy`] rejects folded trials.
pub fn naa_frame_bounds(
    previous: &VertexGrid,
    first: &VertexGrid,
    options: &BoundOptions,
) -> Bounds {
    let mut lower = vec![0.0; previous.unknowns()];
    let mut upper = vec![0.0; previous.unknowns()];
    for a in 0..previous.m {
        for b in 0..previous.n {
            let here = previous.at(a, b);
            for (k, idx) in previous.unknown_index(a, b).into_iter().enumerate() {
                let Some(idx) = idx else { continue };
                // A free s coordinate has 0 < a < M−1, a free t coordinate 0 < b < N−1.
                let (lo, hi) = if k == 0 {
                    (previous.at(a - 1, b)[0], previous.at(a + 1, b)[0])
                } else {
                    (previous.at(a, b - 1)[1], previous.at(a, b + 1)[1])
                };
                let smooth = options
                    .smoothness
                    .map_or(Interval::ALL, |o| Interval::around(here[k], o));
                let mut bound = merge(foldover_coordinate(lo, here[k], hi), smooth);
                if let (Some((frame, frames)), Some(o)) = (options.looping, options.smoothness) {
                    bound = merge(
                        Interval::around(first.at(a, b)[k], loop_distance(frame, frames) * o),
                        bound,
                    );
                }
                lower[idx] = bound.lo;
                upper[idx] = bound.hi;
            }
        }
    }
    Bounds { lower, upper }
}

/// Foldover boxes around `previous` merged with the smoothness bound (no looping).
pub fn naa_bounds(previous: &VertexGrid, smoothness: Option<f64>) -> Bounds {
    naa_frame_bounds(
        previous,
        previous,
        &BoundOptions {
            smoothness,
            looping: None,
        },
    )
}

impl VectorField {
    /// The bilinear value of the three components at (s, t) (each [`Field::bilinear`]).
    pub fn value(&self, s: f64, t: f64) -> [f64; 3] {
        [
            self.x.bilinear(s, t).value,
            self.y.bilinear(s, t).value,
            self.z.bilinear(s, t).value,
        ]
    }
}
