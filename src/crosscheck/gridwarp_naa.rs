//! gridwarp's non-axis-aligned objective (seed 000 §8; §7 and Table 1's ObjFunc column for the
//! `nonaa-` rows): the `gridwarp_naa_cell` kernel (f32) against the f64 energy at one vertex
//! grid, and whole LM solves with the GPU objective against CPU solves. The bounds are derived
//! here once and used by `reparam crosscheck gridwarp --variant naa`, `tests/gpu_gridwarp_naa.rs`
//! and the twin tests (`tests/twin_gridwarp_naa.rs`, through [`super::gridwarp_naa_twin`] and
//! [`naa_judged_rows`], the same rows for the twin as for the GPU).
//!
//! # The bound: the twin over [`Ball`]
//! A hand count of roundings, as [`super::gridwarp`] does for the axis-aligned kernel, does not
//! fit here: a residual is ≈ 60 f32 operations (the bilinear warp, six bilinear lookups, two
//! 3-vector images, a norm), its derivatives ≈ 40 more, and their sizes cancel in ways that
//! depend on the cell (the twist τ, a component of D_s against one of D_t, the norm's gradient
//! m = J_Dᵀ q/‖q‖ where ‖q‖ is small). So the kernel's f32 twin ([`crate::twin::gridwarp_naa`],
//! the WGSL line for line) runs over [`Ball`]: every value carries a radius that bounds every
//! conforming f32 evaluation (+ − × one ULP up or down, / 2.5 ULP, sqrt 4.5 ULP, fusion and
//! reordering, subnormals flushed: [`crate::twin::ball`]), from the inputs as the GPU receives
//! them (σ, o, α, β, h, k, the vertices and the field texels each a ball around its f64 value
//! with its f32 rounding as radius). Per element the bound is
//!
//!   radius + |v − ref|,
//!
//! v the ball's centre (the twin's formula in f64), ref the f64 reference (`PlainNaaEnergy`'s
//! residuals, `NaaEnergy`'s F, JᵀJ and Jᵀr): the second term is the formulations' departure,
//! evaluated, not assumed; it is f64 rounding only (`tests/twin_gridwarp_naa.rs` checks that it
//! stays below 10⁻³ of the radius, so a twin that left the formula would be seen). Cell
//! energies, F, JᵀJ and Jᵀr add the cells' f32 blocks in f64 on the host: their bound is the
//! sum of the cells' radii, the departure, and the host's f64 sum (cells · 2⁻⁵² Σ|terms|).
//!
//! # What f32 cannot decide: undecided elements
//! - **The texel.** Each of the six lookups picks a texel patch from ⌊u⌋, u = p·W − ½, and
//!   clamps at u ≤ 0 and u ≥ W − 1; its gradient ∂/∂s jumps across u ∈ ℤ, ∂/∂t across
//!   v ∈ ℤ. Where the ball of u (the sample position's f32 error, ≈ 10⁻⁴ texel at W = 128)
//!   holds a texel boundary, a conforming GPU may take the other patch ([`axis_decided`]).
//!   The evaluation point is chosen as `gridwarp_aa`'s is, with every sample off the
//!   boundaries ([`evaluation_point`]: the margin is the ball's own radius, derived, not a
//!   constant); where no candidate clears every sample, the samples that stay undecided are
//!   counted, and every element they reach (their residuals, their cell's energy, F, their
//!   cell's JᵀJ and Jᵀr entries) gets the bound [`UNBOUNDED`] and is counted in the row.
//! - **‖q‖ → 0.** m_k = (σ/‖q‖) D_k · q and g_k divide by ‖q‖: the ball of σ/‖q‖ grows as
//!   r_q/‖q‖², so the bound follows the conditioning, and where ‖q‖'s ball reaches 0 (or the
//!   kernel's `‖q‖ > 0` could go either way, [`crate::twin::Real::decides_lt`]) the radius is
//!   ∞: the cell's JᵀJ and Jᵀr entries are undecided ([`UNBOUNDED`]) and counted.
//!
//! # Whole solves
//! As [`super::gridwarp::solve_bounds`], at the CPU's minimum x*: F's excess is at most
//! 2e + ½ bᵀ|A⁻¹|b + 1e-12 F and the vertices within ‖|A⁻¹| b‖∞ + √(4e/λ_min(A)) ([`solve_tolerances`]), with
//! e, b the bounds above at x* (A = JᵀJ there). x* is not f32 and not chosen: its samples'
//! texels are not decided one by one (values are continuous across texel boundaries, the balls
//! widen them by the whole fraction; the gradient counted is the f64 patch's), and how many
//! samples sit within rounding of a boundary is in the row's note.

use nalgebra::{DMatrix, DVector};
use reparam_gpu::Gpu;

use super::gridwarp::{round, round_field, solve_tolerances};
use super::timing::{time_cpu, time_gpu, time_gpu_warm};
use super::{Bounds, Row, Timing};
use crate::error::{Error, Result};
use crate::gridwarp::energy::{rest_samples, RestFields};
use crate::gridwarp::energy_naa::{DeformedJacobian, NaaModel, VectorField, VertexGrid};
use crate::gridwarp::gpu_naa::{assemble, solve_naa_sequence_gpu, GpuNaaEnergy};
use crate::gridwarp::plain::PlainNaaEnergy;
use crate::gridwarp::{solve_naa_sequence, Grid, NaaEnergy, SolveOptions};
use crate::lm::{NormalEquations, Residuals};
use crate::twin::ball::{evaluate, Ball};
use crate::twin::gridwarp_aa::RestSample as TwinSample;
use crate::twin::gridwarp_naa::{
    bilinear_warp, cell_contribution, sample_residuals, Corners, Fields, NaaCellContribution,
    RestCell, VectorField as TwinField,
};
use crate::twin::{Real, V2};
use reparam_gpu::gridwarp::NaaCellContribution as GpuCellContribution;

/// The bound of an element f32 cannot decide (JSON has no ∞): counted in the rows' notes.
pub const UNBOUNDED: f64 = f64::MAX;

/// f64's ε, 2⁻⁵²: one rounding of the host's f64 sums.
const EPS64: f64 = f64::EPSILON;

/// How much of the f64 reference's value the formulations may depart by, relative to the
/// ball's radius, before the twin is taken to have left the formula (checked by the tests).
pub const DEPARTURE_LIMIT: f64 = 1e-3;

/// A value the GPU receives as f32: a ball around it with its rounding as radius.
fn ball(v: f64) -> Ball {
    Ball::input(v, v as f32)
}

/// Whether every conforming f32 evaluation of the lookup's axis at s (a ball: the sample
/// position with its f32 error) takes the f64 one's branch and texel patch, on an axis of `n`
/// texels: the ball of u = s·n − ½ (the twin's `axis`) holds neither 0 (`!(u > 0)` clamps)
/// nor a texel-centre boundary k ∈ [1, n − 1] (⌊u⌋ changes, and at n − 1 the upper clamp).
pub fn axis_decided(s: Ball, n: usize) -> bool {
    if n <= 1 {
        return true;
    }
    let u = s * Ball::lit(n as f64) - Ball::lit(0.5);
    if !u.r.is_finite() {
        return false;
    }
    let (lo, hi) = (u.v - u.r, u.v + u.r);
    if lo <= 0.0 && hi > 0.0 {
        return false;
    }
    // The largest integer in (lo, hi] within [1, n − 1].
    let k = hi.floor().min((n - 1) as f64);
    !(k >= 1.0 && k > lo)
}

/// Whether the six lookups at p (a ball) are decided on fields of `sizes` = [(W, H) of D_s,
/// (W, H) of D_t].
pub fn texels_decided(p: V2<Ball>, sizes: [(usize, usize); 2]) -> bool {
    sizes
        .iter()
        .all(|&(w, h)| axis_decided(p.x, w) && axis_decided(p.y, h))
}

/// What the twin over [`Ball`] needs of one frame at one vertex grid: the rest samples, rest
/// sizes, corners and fields as balls, with the unknowns of each cell's slots.
pub struct BallInputs {
    /// Cell by cell, K·L each ([`rest_samples`]).
    samples: Vec<TwinSample<Ball>>,
    per_cell: usize,
    h: Vec<Ball>,
    k: Vec<Ball>,
    vertices: VertexGrid,
    d_s: (Vec<Ball>, usize, usize),
    d_t: (Vec<Ball>, usize, usize),
}

/// A vector field as the kernel reads it (interleaved per texel), each texel value a ball.
fn ball_field(name: &str, f: &VectorField) -> Result<(Vec<Ball>, usize, usize)> {
    let g = crate::gridwarp::gpu_naa::vector_field_to_gpu(name, f)?;
    let exact = (0..f.x.values.len()).flat_map(|n| [&f.x, &f.y, &f.z].map(|c| c.values[n]));
    let values = exact
        .zip(&g.values)
        .map(|(v, &s)| Ball::input(v, s))
        .collect();
    Ok((values, g.width as usize, g.height as usize))
}

impl BallInputs {
    /// The inputs of `rest_grid`'s energy of `deformed` with K × L samples, at the vertices
    /// `at` (rounded to f32 as the GPU receives them; their border mode numbers the unknowns).
    pub fn new(
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &DeformedJacobian,
        (k, l): (usize, usize),
        at: &VertexGrid,
    ) -> Result<BallInputs> {
        let samples = rest_samples(rest, rest_grid, k, l)
            .iter()
            .map(|p| TwinSample {
                alpha: ball(p.alpha),
                beta: ball(p.beta),
                sigma: ball(p.sigma),
                o_s: ball(p.o_s),
                o_t: ball(p.o_t),
            })
            .collect();
        let widths = |v: &[f64]| v.windows(2).map(|w| ball(w[1] - w[0])).collect();
        Ok(BallInputs {
            samples,
            per_cell: k.max(1) * l.max(1),
            h: widths(&rest_grid.s),
            k: widths(&rest_grid.t),
            vertices: at.clone(),
            d_s: ball_field("D_s", &deformed.d_s)?,
            d_t: ball_field("D_t", &deformed.d_t)?,
        })
    }

    /// (columns, rows) of cells.
    fn cells(&self) -> (usize, usize) {
        (self.h.len(), self.k.len())
    }

    fn fields(&self) -> Fields<'_, Ball> {
        fn field((values, width, height): &(Vec<Ball>, usize, usize)) -> TwinField<'_, Ball> {
            TwinField {
                values,
                width: *width,
                height: *height,
            }
        }
        Fields {
            d_s: field(&self.d_s),
            d_t: field(&self.d_t),
        }
    }

    fn sizes(&self) -> [(usize, usize); 2] {
        [(self.d_s.1, self.d_s.2), (self.d_t.1, self.d_t.2)]
    }

    /// Cell (i, j)'s rest size and corners (the vertices as the GPU receives them).
    fn cell(&self, i: usize, j: usize) -> (RestCell<Ball>, Corners<Ball>) {
        let p = |a: usize, b: usize| {
            let [s, t] = self.vertices.at(a, b);
            V2::new(ball(s), ball(t))
        };
        (
            RestCell {
                h: self.h[i],
                k: self.k[j],
            },
            Corners {
                p00: p(i, j),
                p10: p(i + 1, j),
                p01: p(i, j + 1),
                p11: p(i + 1, j + 1),
            },
        )
    }

    /// The samples of cell c = i·(N − 1) + j.
    fn cell_samples(&self, c: usize) -> &[TwinSample<Ball>] {
        &self.samples[c * self.per_cell..(c + 1) * self.per_cell]
    }

    /// The unknowns of cell (i, j)'s 8 slots (P00.s, P00.t, P10.s, …; None: fixed).
    fn unknowns(&self, i: usize, j: usize) -> [Option<usize>; 8] {
        let g = &self.vertices;
        let [a, b, c, d] =
            [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)].map(|(a, b)| g.unknown_index(a, b));
        [a[0], a[1], b[0], b[1], c[0], c[1], d[0], d[1]]
    }

    /// The samples (σ ≠ 0) whose texels f32 cannot decide, per cell.
    pub fn undecided_samples(&self) -> Vec<usize> {
        let (columns, rows) = self.cells();
        let sizes = self.sizes();
        (0..columns * rows)
            .map(|c| {
                let (cell, quad) = self.cell(c / rows, c % rows);
                self.cell_samples(c)
                    .iter()
                    .filter(|p| p.sigma.v != 0.0)
                    .filter(|p| {
                        let warp = bilinear_warp(&quad, &cell, p.alpha, p.beta);
                        !texels_decided(warp.p, sizes)
                    })
                    .count()
            })
            .collect()
    }
}

/// One cell's share over [`Ball`], and what f32 cannot decide in it.
#[derive(Clone, Debug)]
pub struct CellBall {
    pub block: NaaCellContribution<Ball>,
    pub unknowns: [Option<usize>; 8],
    /// Samples whose texel patch f32 cannot decide ([`axis_decided`]).
    pub undecided_texels: usize,
    /// A branch (`‖q‖ > 0`) within rounding, or an infinite radius (‖q‖'s ball reaching 0).
    pub unbounded: bool,
}

impl CellBall {
    /// Whether every element this cell reaches has a bound (`texels`: the texel choice counts).
    pub fn decided(&self, texels: bool) -> bool {
        !self.unbounded && (!texels || self.undecided_texels == 0)
    }
}

/// The twin over [`Ball`] at one vertex grid: every cell's share and every sample's residuals.
pub struct NaaBalls {
    pub cells: Vec<CellBall>,
    /// Per sample (σ = 0 included), (r^s, r^t) as balls, None for σ = 0.
    pub residuals: Vec<Option<[Ball; 2]>>,
    /// Per sample, whether its texels are decided (true for σ = 0: it has no residual).
    pub sample_decided: Vec<bool>,
    /// The number of unknowns.
    pub n: usize,
}

impl NaaBalls {
    /// Run the twin over `inputs`, cell by cell.
    pub fn new(inputs: &BallInputs) -> NaaBalls {
        let (columns, rows) = inputs.cells();
        let fields = inputs.fields();
        let sizes = inputs.sizes();
        let mut cells = Vec::with_capacity(columns * rows);
        let mut residuals = Vec::with_capacity(inputs.samples.len());
        let mut sample_decided = Vec::with_capacity(inputs.samples.len());
        for c in 0..columns * rows {
            let (i, j) = (c / rows, c % rows);
            let (cell, quad) = inputs.cell(i, j);
            let samples = inputs.cell_samples(c);
            let mut undecided = 0;
            for p in samples {
                if p.sigma.v == 0.0 {
                    residuals.push(None);
                    sample_decided.push(true);
                    continue;
                }
                let r = sample_residuals(&cell, &quad, p, &fields);
                let decided = texels_decided(r.warp.p, sizes);
                undecided += usize::from(!decided);
                residuals.push(Some([r.r_s, r.r_t]));
                sample_decided.push(decided);
            }
            let (block, ambiguous) = evaluate(|| cell_contribution(&cell, &quad, samples, &fields));
            let finite = block
                .jtj
                .iter()
                .chain(&block.jtr)
                .chain([&block.energy])
                .all(|b| b.r.is_finite());
            cells.push(CellBall {
                block,
                unknowns: inputs.unknowns(i, j),
                undecided_texels: undecided,
                unbounded: ambiguous || !finite,
            });
        }
        NaaBalls {
            cells,
            residuals,
            sample_decided,
            n: inputs.vertices.unknowns(),
        }
    }

    /// Samples whose texels are undecided.
    pub fn undecided_samples(&self) -> usize {
        self.cells.iter().map(|c| c.undecided_texels).sum()
    }

    /// Cells with an unbounded element (‖q‖ within rounding of 0).
    pub fn unbounded_cells(&self) -> usize {
        self.cells.iter().filter(|c| c.unbounded).count()
    }

    /// Per sample (the kernel's `samples` order) the bounds of (r^s, r^t) against the
    /// reference's residuals `reference` (the same layout; 0 for σ = 0, whose bound is 0):
    /// radius + |v − ref|, [`UNBOUNDED`] where the sample's texels are undecided.
    pub fn residual_bounds(&self, reference: &[[f64; 2]]) -> Vec<[f64; 2]> {
        self.residuals
            .iter()
            .zip(&self.sample_decided)
            .zip(reference)
            .map(|((r, &decided), reference)| match r {
                None => [0.0; 2],
                Some(_) if !decided => [UNBOUNDED; 2],
                Some(r) => [0, 1].map(|a| element_bound(r[a].r, r[a].v, reference[a])),
            })
            .collect()
    }

    /// Per cell, the bound of its energy Σ r² against the reference's `reference`.
    pub fn cell_energy_bounds(&self, reference: &[f64]) -> Vec<f64> {
        self.cells
            .iter()
            .zip(reference)
            .map(|(c, &e)| {
                if c.decided(true) {
                    element_bound(c.block.energy.r, c.block.energy.v, e)
                } else {
                    UNBOUNDED
                }
            })
            .collect()
    }

    /// The bound of F = Σ_cells (the host's f64 sum) against the reference's `energy`;
    /// `texels`: whether an undecided texel makes it unbounded (the kernel rows) or not (the
    /// whole-solve bounds, module docs).
    pub fn energy_bound(&self, energy: f64, texels: bool) -> f64 {
        if !self.cells.iter().all(|c| c.decided(texels)) {
            return UNBOUNDED;
        }
        let terms = self.cells.iter().map(|c| c.block.energy);
        summed_bound(terms, energy, self.cells.len())
    }

    /// Per unknown u, the bound of (Jᵀr)_u against the reference's `jtr`.
    pub fn jtr_bounds(&self, jtr: &DVector<f64>, texels: bool) -> Vec<f64> {
        let mut terms: Vec<Vec<Ball>> = vec![Vec::new(); self.n];
        let mut decided = vec![true; self.n];
        for c in &self.cells {
            for (a, u) in c.unknowns.iter().enumerate() {
                let Some(u) = *u else { continue };
                terms[u].push(c.block.jtr[a]);
                decided[u] &= c.decided(texels);
            }
        }
        (0..self.n)
            .map(|u| {
                if decided[u] {
                    summed_bound(terms[u].iter().copied(), jtr[u], self.cells.len())
                } else {
                    UNBOUNDED
                }
            })
            .collect()
    }

    /// Per entry (u, v), the bound of (JᵀJ)_uv against the reference's `jtj`.
    pub fn jtj_bounds(&self, jtj: &DMatrix<f64>, texels: bool) -> DMatrix<f64> {
        let n = self.n;
        let mut terms: Vec<Vec<Ball>> = vec![Vec::new(); n * n];
        let mut decided = vec![true; n * n];
        for c in &self.cells {
            for (a, u) in c.unknowns.iter().enumerate() {
                let Some(u) = *u else { continue };
                for (b, v) in c.unknowns.iter().enumerate() {
                    let Some(v) = *v else { continue };
                    terms[u * n + v].push(c.block.jtj[8 * a + b]);
                    decided[u * n + v] &= c.decided(texels);
                }
            }
        }
        DMatrix::from_fn(n, n, |u, v| {
            if decided[u * n + v] {
                summed_bound(
                    terms[u * n + v].iter().copied(),
                    jtj[(u, v)],
                    self.cells.len(),
                )
            } else {
                UNBOUNDED
            }
        })
    }
}

/// One element's bound: the ball's radius and the formulations' departure |v − ref|.
fn element_bound(radius: f64, v: f64, reference: f64) -> f64 {
    radius + (v - reference).abs()
}

/// The bound of an f64 sum (in cell order, `count` cells at most) of f32 cell values `terms`
/// (balls) against the reference's `reference`: Σ radii + |Σ v − ref| + count·2⁻⁵² Σ|v|.
fn summed_bound(terms: impl Iterator<Item = Ball>, reference: f64, count: usize) -> f64 {
    let (mut radius, mut value, mut size) = (0.0, 0.0, 0.0);
    for t in terms {
        radius += t.r;
        value += t.v;
        size += t.v.abs();
    }
    radius + (value - reference).abs() + count as f64 * EPS64 * size
}

/// `deformed` with every field value rounded to f32 (what the GPU sees).
pub fn round_jacobian(deformed: &DeformedJacobian) -> DeformedJacobian {
    let r = |f: &VectorField| VectorField {
        x: round_field(&f.x),
        y: round_field(&f.y),
        z: round_field(&f.z),
    };
    DeformedJacobian {
        d_s: r(&deformed.d_s),
        d_t: r(&deformed.d_t),
    }
}

/// A frame's inputs rounded to f32, as both sides see them.
pub struct RoundedNaaInputs {
    pub rest: RestFields,
    pub rest_grid: Grid,
    pub deformed: DeformedJacobian,
    /// The rest vertices of the rounded rest grid (border mode as asked).
    pub rest_vertices: VertexGrid,
}

/// `rest`, `rest_grid` and `deformed` with every value rounded to f32.
pub fn round_naa_inputs(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    sliding_border: bool,
) -> Result<RoundedNaaInputs> {
    let rest_grid = Grid::new(round(&rest_grid.s), round(&rest_grid.t))?;
    Ok(RoundedNaaInputs {
        rest: RestFields {
            o_s: round_field(&rest.o_s),
            o_t: round_field(&rest.o_t),
            rigidity: round_field(&rest.rigidity),
        },
        rest_vertices: VertexGrid::from_grid(&rest_grid).with_sliding_border(sliding_border),
        rest_grid,
        deformed: round_jacobian(deformed),
    })
}

/// How many candidates [`evaluation_point`] tries.
pub const CANDIDATES: usize = 200;

/// The evaluation point: every unknown coordinate of the rest vertices moved by up to
/// `amplitude` (≤ a quarter of the smallest rest cell; a fixed deterministic pattern, candidate
/// c = 1, 2, …, as [`super::gridwarp::evaluation_point`] moves the lines; the cells turn
/// non-rectangular, the twist τ ≠ 0), rounded to f32: the first candidate that folds no cell
/// and leaves every sample's texels decided ([`axis_decided`]), else, of the
/// [`CANDIDATES`] tried, the unfolded one with the fewest undecided samples (their count is
/// returned with it). `None` if every candidate folds.
pub fn evaluation_point(
    rounded: &RoundedNaaInputs,
    kl: (usize, usize),
    amplitude: f64,
) -> Result<Option<(Vec<f64>, usize)>> {
    let g0 = &rounded.rest_vertices;
    let x0 = g0.to_unknowns();
    let grid = &rounded.rest_grid;
    let widths = grid.s.windows(2).chain(grid.t.windows(2));
    let h_min = widths.map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
    let amplitude = amplitude.min(0.25 * h_min);
    let mut inputs = BallInputs::new(
        &rounded.rest,
        grid,
        &rounded.deformed,
        kl,
        &g0.with_unknowns(&x0),
    )?;
    let mut best: Option<(Vec<f64>, usize)> = None;
    for c in 1..=CANDIDATES {
        let x: Vec<f64> = x0
            .iter()
            .enumerate()
            .map(|(n, &v)| v + amplitude * ((n * 7 + c * 3) as f64 * 0.61).sin())
            .collect();
        let x = round(&x);
        let g = g0.with_unknowns(&x);
        if !g.is_valid() {
            continue;
        }
        inputs.vertices = g;
        let undecided: usize = inputs.undecided_samples().iter().sum();
        if undecided == 0 {
            return Ok(Some((x, 0)));
        }
        if best.as_ref().is_none_or(|(_, u)| undecided < *u) {
            best = Some((x, undecided));
        }
    }
    Ok(best)
}

/// The f64 reference at one vertex grid: per sample (r^s, r^t) in the kernel's `samples`
/// order (0 for σ = 0), per cell Σ r², and F, JᵀJ, Jᵀr (Gauss–Newton).
pub struct NaaReference {
    pub residuals: Vec<[f64; 2]>,
    pub cell_energy: Vec<f64>,
    pub normal: NormalEquations,
}

/// [`NaaReference`] of `deformed` at x: residuals from the plain path ([`PlainNaaEnergy`], the
/// formula sample by sample), F, JᵀJ and Jᵀr from the fast path ([`NaaEnergy`], what the CPU
/// solver uses; the two agree to f64 rounding, `tests/gridwarp_plain.rs`).
pub fn naa_reference(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    (k, l): (usize, usize),
    sliding_border: bool,
    x: &[f64],
) -> NaaReference {
    let plain =
        PlainNaaEnergy::new(rest, rest_grid, deformed, k, l).with_sliding_border(sliding_border);
    let flat = plain.residuals(x);
    let samples = rest_samples(rest, rest_grid, k, l);
    let per_cell = k.max(1) * l.max(1);
    let mut residuals = Vec::with_capacity(samples.len());
    let mut cell_energy = vec![0.0; samples.len() / per_cell];
    let mut next = flat.chunks_exact(2);
    for (n, p) in samples.iter().enumerate() {
        let r = match (p.sigma != 0.0).then(|| next.next()).flatten() {
            Some(r) => [r[0], r[1]],
            None => [0.0; 2],
        };
        cell_energy[n / per_cell] += r[0] * r[0] + r[1] * r[1];
        residuals.push(r);
    }
    let mut fast = NaaEnergy::new(rest, rest_grid, deformed, k, l)
        .with_sliding_border(sliding_border)
        .with_model(NaaModel::GaussNewton);
    NaaReference {
        residuals,
        cell_energy,
        normal: fast.normal_equations(x),
    }
}

/// `b` scaled by 1/`scale` unless it is [`UNBOUNDED`].
fn scaled(b: f64, scale: f64) -> f64 {
    if b == UNBOUNDED {
        b
    } else {
        b / scale
    }
}

/// "n elements undecided (…)" for a row's note, empty when none.
fn undecided_note(bounds: &[f64], what: &str) -> String {
    match bounds.iter().filter(|&&b| b == UNBOUNDED).count() {
        0 => String::new(),
        n => format!(
            "; {n} {what} undecided (a texel boundary or ‖q‖ = 0 within f32 rounding), not judged"
        ),
    }
}

/// Everything the kernel rows need at one vertex grid, for the CLI, the tests and the vectors.
pub struct NaaEvaluation {
    pub rounded: RoundedNaaInputs,
    pub kl: (usize, usize),
    /// The evaluation point (f32 values).
    pub x: Vec<f64>,
    pub reference: NaaReference,
    pub balls: NaaBalls,
}

impl NaaEvaluation {
    /// The inputs rounded to f32, the evaluation point ([`evaluation_point`], unknowns moved by
    /// up to 0.013), the reference and the twin's balls there. A typed error naming `input`
    /// when every candidate folds a cell.
    pub fn new(
        input: &str,
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &DeformedJacobian,
        kl: (usize, usize),
        sliding_border: bool,
    ) -> Result<NaaEvaluation> {
        let rounded = round_naa_inputs(rest, rest_grid, deformed, sliding_border)?;
        let (x, _) = evaluation_point(&rounded, kl, 0.013)?.ok_or_else(|| {
            Error::InvalidArgument(format!(
                "{input}: every candidate evaluation point folds a cell of the vertex grid"
            ))
        })?;
        let g = rounded.rest_vertices.with_unknowns(&x);
        let reference = naa_reference(
            &rounded.rest,
            &rounded.rest_grid,
            &rounded.deformed,
            kl,
            sliding_border,
            &x,
        );
        let inputs = BallInputs::new(&rounded.rest, &rounded.rest_grid, &rounded.deformed, kl, &g)?;
        let balls = NaaBalls::new(&inputs);
        Ok(NaaEvaluation {
            rounded,
            kl,
            x,
            reference,
            balls,
        })
    }

    /// The vertices at the evaluation point.
    pub fn vertices(&self) -> VertexGrid {
        self.rounded.rest_vertices.with_unknowns(&self.x)
    }

    /// Per sample, the bounds of (r^s, r^t) ([`NaaBalls::residual_bounds`]).
    pub fn residual_bounds(&self) -> Vec<[f64; 2]> {
        self.balls.residual_bounds(&self.reference.residuals)
    }

    /// Per cell, the bound of its energy.
    pub fn cell_energy_bounds(&self) -> Vec<f64> {
        self.balls.cell_energy_bounds(&self.reference.cell_energy)
    }

    /// The bound of F.
    pub fn energy_bound(&self) -> f64 {
        self.balls.energy_bound(self.reference.normal.energy, true)
    }

    /// The bounds of JᵀJ, entry by entry.
    pub fn jtj_bounds(&self) -> DMatrix<f64> {
        self.balls.jtj_bounds(&self.reference.normal.jtj, true)
    }

    /// The bounds of Jᵀr, per unknown.
    pub fn jtr_bounds(&self) -> Vec<f64> {
        self.balls.jtr_bounds(&self.reference.normal.jtr, true)
    }

    /// The largest departure |v − ref| / radius of the twin's formula from the reference over
    /// every decided element (residuals, cell energies): f64 rounding only, unless the twin
    /// left the formula ([`DEPARTURE_LIMIT`]).
    pub fn largest_departure(&self) -> f64 {
        let mut worst: f64 = 0.0;
        let pairs = self.balls.residuals.iter().zip(&self.reference.residuals);
        for (r, reference) in pairs {
            if let Some(r) = r {
                for a in 0..2 {
                    worst = worst.max((r[a].v - reference[a]).abs() / r[a].r);
                }
            }
        }
        for (c, &e) in self.balls.cells.iter().zip(&self.reference.cell_energy) {
            worst = worst.max((c.block.energy.v - e).abs() / c.block.energy.r);
        }
        worst
    }
}

/// The name of the kernel rows (`gridwarp_naa: …`).
pub const KERNEL: &str = "gridwarp_naa";

/// One evaluation of the kernel against the reference: per-sample residuals (the
/// `gridwarp_naa_residuals` entry), per-cell energies, F, JᵀJ and Jᵀr of frame `deformed` at a
/// vertex grid near the rest one ([`evaluation_point`]), with K×L samples.
pub fn naa_kernel_rows(
    gpu: &Gpu,
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    kl: (usize, usize),
    sliding_border: bool,
) -> Result<Vec<Row>> {
    let (e, cpu_ms) =
        time_cpu(|| NaaEvaluation::new(input, rest, rest_grid, deformed, kl, sliding_border));
    let e = e?;
    let r = &e.rounded;
    let mut gpu_energy =
        GpuNaaEnergy::new(gpu, &r.rest, &r.rest_grid, &r.deformed, kl, sliding_border)?;
    let (cells, gpu_times) = time_gpu_warm(gpu, || gpu_energy.cells(&e.x))?;
    let residuals = reparam_gpu::gridwarp::naa_residuals(gpu, gpu_energy.input())
        .map_err(|e| Error::Gpu(e.to_string()))?;
    let timing = Timing {
        cpu_ms: Some(cpu_ms),
        ..gpu_times
    };
    Ok(naa_judged_rows(&e, input, &cells, &residuals, timing))
}

/// The kernel input of the evaluation `e`: the buffers the GPU receives (and the twin reads,
/// [`super::gridwarp_naa_twin::twin_outputs`]).
pub fn evaluation_input(e: &NaaEvaluation) -> Result<reparam_gpu::gridwarp::NaaInput> {
    let r = &e.rounded;
    crate::gridwarp::gpu_naa::naa_input(&r.rest, &r.rest_grid, &r.deformed, e.kl, &e.vertices())
}

/// The five kernel rows of measured outputs (the GPU's, or the twin's under a model) at the
/// evaluation `e`: per-sample `residuals` (the `gridwarp_naa_residuals` entry, samples in the
/// kernel's order) and per-cell `cells` (the `gridwarp_naa_cell` entry, added in f64 here as
/// the host adds them), each element against its bound ([`NaaEvaluation`]).
pub fn naa_judged_rows(
    e: &NaaEvaluation,
    input: &str,
    cells: &[GpuCellContribution],
    residuals: &[[f32; 2]],
    timing: Timing,
) -> Vec<Row> {
    let kl = e.kl;
    let measured = assemble(cells, e.x.len());
    let undecided = e.balls.undecided_samples();
    let point_note = format!(
        "{} cells × {} samples, vertices moved off the rest grid{}",
        cells.len(),
        kl.0 * kl.1,
        match undecided {
            0 => String::new(),
            n => format!(" ({n} samples' texels undecided at the best of {CANDIDATES} points)"),
        }
    );
    let bounds = e.residual_bounds();
    let (mut r_err, mut r_bound) = (Vec::new(), Vec::new());
    for ((g, reference), b) in residuals.iter().zip(&e.reference.residuals).zip(&bounds) {
        for a in 0..2 {
            r_err.push((g[a] as f64 - reference[a]).abs());
            r_bound.push(b[a]);
        }
    }
    let residual_row = Row::compare(
        "gridwarp",
        &format!("{KERNEL}: residuals r^s, r^t"),
        input,
        "absolute",
        &r_err,
        &[],
        Bounds::PerElement(r_bound.clone()),
        "radius + |v − ref| of the twin over Ball (crosscheck::gridwarp_naa)",
    )
    .with_note(&format!(
        "{point_note}{}",
        undecided_note(&r_bound, "residuals")
    ))
    .with_timing(timing);

    let (mut c_err, mut c_bound) = (Vec::new(), Vec::new());
    for ((cell, &f), b) in cells
        .iter()
        .zip(&e.reference.cell_energy)
        .zip(e.cell_energy_bounds())
    {
        let scale = if f > 0.0 { f } else { 1.0 };
        c_err.push((cell.energy as f64 - f).abs() / scale);
        c_bound.push(scaled(b, scale));
    }
    let cells_row = Row::compare(
        "gridwarp",
        &format!("{KERNEL}: cell energy Σr²"),
        input,
        "relative",
        &c_err,
        &[],
        Bounds::PerElement(c_bound.clone()),
        "(radius + |v − ref|) / F_c, the twin's cell over Ball",
    )
    .with_note(undecided_note(&c_bound, "cells").trim_start_matches("; "));

    let f = e.reference.normal.energy.max(f64::MIN_POSITIVE);
    let e_bound = scaled(e.energy_bound(), f);
    let energy_row = Row::compare(
        "gridwarp",
        &format!("{KERNEL}: energy F"),
        input,
        "relative",
        &[(measured.energy - e.reference.normal.energy).abs() / f],
        &[],
        Bounds::Uniform(e_bound),
        "(Σ_cells radius + |Σ v − F| + cells·2⁻⁵² Σ|F_c|) / F",
    )
    .with_note(undecided_note(&[e_bound], "F").trim_start_matches("; "));

    let n = e.x.len();
    let reference = &e.reference.normal;
    let a_max = reference.jtj.amax().max(f64::MIN_POSITIVE);
    let jtj_b = e.jtj_bounds();
    let (mut jtj_err, mut jtj_bound) = (Vec::new(), Vec::new());
    for u in 0..n {
        for v in 0..n {
            jtj_err.push((measured.jtj[(u, v)] - reference.jtj[(u, v)]).abs() / a_max);
            jtj_bound.push(scaled(jtj_b[(u, v)], a_max));
        }
    }
    let jtj_row = Row::compare(
        "gridwarp",
        &format!("{KERNEL}: JᵀJ"),
        input,
        "relative to max |JᵀJ|",
        &jtj_err,
        &[],
        Bounds::PerElement(jtj_bound.clone()),
        "(Σ_cells radius + |Σ v − ref| + cells·2⁻⁵² Σ|v|) / max|JᵀJ|",
    )
    .with_note(undecided_note(&jtj_bound, "entries").trim_start_matches("; "));

    let g_max = reference.jtr.amax().max(f64::MIN_POSITIVE);
    let jtr_b = e.jtr_bounds();
    let jtr_err: Vec<f64> = (0..n)
        .map(|u| (measured.jtr[u] - reference.jtr[u]).abs() / g_max)
        .collect();
    let jtr_bound: Vec<f64> = jtr_b.iter().map(|&b| scaled(b, g_max)).collect();
    let jtr_row = Row::compare(
        "gridwarp",
        &format!("{KERNEL}: Jᵀr"),
        input,
        "relative to max |Jᵀr|",
        &jtr_err,
        &[],
        Bounds::PerElement(jtr_bound.clone()),
        "(Σ_cells radius + |Σ v − ref| + cells·2⁻⁵² Σ|v|) / max|Jᵀr|",
    )
    .with_note(undecided_note(&jtr_bound, "entries").trim_start_matches("; "));
    vec![residual_row, cells_row, energy_row, jtj_row, jtr_row]
}

/// F's excess and the unknowns' distance that an f32 objective may leave at the CPU minimum x*
/// of the non-axis-aligned energy ([`solve_tolerances`] with e, b the Ball bounds of F and Jᵀr
/// at x*, texels not decided one by one: module docs). Returns (energy bound, unknowns' bound,
/// samples within rounding of a texel boundary); `None` when JᵀJ is singular at x* or an
/// element there has no bound (‖q‖ within rounding of 0).
pub fn naa_solve_bounds(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    kl: (usize, usize),
    at: &VertexGrid,
    x_star: &[f64],
) -> Result<Option<(f64, f64, usize)>> {
    let g = at.with_unknowns(x_star);
    let inputs = BallInputs::new(rest, rest_grid, deformed, kl, &g)?;
    let balls = NaaBalls::new(&inputs);
    let mut cpu = NaaEnergy::new(rest, rest_grid, deformed, kl.0, kl.1)
        .with_sliding_border(at.sliding_border);
    let ne = cpu.normal_equations(x_star);
    let e = balls.energy_bound(ne.energy, false);
    let b = balls.jtr_bounds(&ne.jtr, false);
    if e == UNBOUNDED || b.contains(&UNBOUNDED) {
        return Ok(None);
    }
    let b = DVector::from_vec(b);
    Ok(solve_tolerances(e, &b, &ne.jtj, ne.energy)
        .map(|(e_tol, x_tol)| (e_tol, x_tol, balls.undecided_samples())))
}

/// Whole non-axis-aligned sequences solved with the GPU objective ([`solve_naa_sequence_gpu`])
/// and with the CPU one (both Gauss–Newton, the paper's model, from the rest vertices with the
/// border mode `sliding_border`): per frame, the GPU-solved vertices' f64 energy against the
/// CPU minimum, and the vertices, against [`naa_solve_bounds`].
pub fn naa_solve_rows(
    gpu: &Gpu,
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedJacobian],
    options: &SolveOptions,
    sliding_border: bool,
) -> Result<Vec<Row>> {
    let options = SolveOptions {
        naa_model: NaaModel::GaussNewton,
        ..options.clone()
    };
    let start = VertexGrid::from_grid(rest_grid).with_sliding_border(sliding_border);
    let (cpu, cpu_ms) = time_cpu(|| solve_naa_sequence(rest, rest_grid, &start, frames, &options));
    let cpu = cpu?;
    let (solved, gpu_times) = time_gpu(gpu, || {
        solve_naa_sequence_gpu(gpu, rest, rest_grid, &start, frames, &options)
    })?;
    let kl = options.samples_per_cell();
    let (mut f_err, mut f_bound, mut x_err, mut x_bound) = (vec![], vec![], vec![], vec![]);
    let (mut left_out, mut near_boundary) = (0, 0);
    for (j, (c, g)) in cpu.iter().zip(&solved).enumerate() {
        let Some((e_tol, x_tol, undecided)) =
            naa_solve_bounds(rest, rest_grid, &frames[j], kl, &start, &c.lm.x)?
        else {
            left_out += 1;
            continue;
        };
        near_boundary += undecided;
        let mut reference = NaaEnergy::new(rest, rest_grid, &frames[j], kl.0, kl.1)
            .with_sliding_border(sliding_border);
        let e_gpu = reference.energy(&g.lm.x);
        let scale = c.lm.energy.max(f64::MIN_POSITIVE);
        f_err.push((e_gpu - c.lm.energy).abs() / scale);
        f_bound.push(e_tol / scale);
        let moved = c.lm.x.iter().zip(&g.lm.x).map(|(a, b)| (a - b).abs());
        x_err.push(moved.fold(0.0, f64::max));
        x_bound.push(x_tol);
    }
    let timing = Timing {
        cpu_ms: Some(cpu_ms),
        ..gpu_times
    };
    let mut note = format!("{} frames, Gauss–Newton", frames.len());
    if left_out > 0 {
        note += &format!(
            "; {left_out} left out: JᵀJ singular or ‖q‖ = 0 within rounding at the CPU minimum (no bound)"
        );
    }
    if near_boundary > 0 {
        note += &format!(
            "; {near_boundary} samples within rounding of a texel boundary at the minima (module docs)"
        );
    }
    Ok(vec![
        Row::compare(
            "gridwarp",
            "run (naa): LM solve, final F per frame",
            input,
            "relative",
            &f_err,
            &[],
            Bounds::PerElement(f_bound),
            "(2e + ½ bᵀ|A⁻¹|b + 1e-12 F) / F at the CPU minimum, e, b the Ball bounds of F, Jᵀr",
        )
        .with_note(&note)
        .with_timing(timing),
        Row::compare(
            "gridwarp",
            "run (naa): LM solve, vertices per frame",
            input,
            "texture width",
            &x_err,
            &[],
            Bounds::PerElement(x_bound),
            "‖|A⁻¹| b‖∞ + √(4e / λ_min(A))",
        )
        .with_note(&note),
    ])
}

/// The non-axis-aligned gridwarp table for one input: the kernel at the last (most deformed)
/// frame ([`naa_kernel_rows`]) and whole Gauss–Newton solves ([`naa_solve_rows`]), with the
/// rest vertices' border mode `sliding_border`.
pub fn crosscheck_gridwarp_naa(
    gpu: &Gpu,
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedJacobian],
    options: &SolveOptions,
    sliding_border: bool,
) -> Result<Vec<Row>> {
    let last = frames
        .last()
        .ok_or_else(|| Error::InvalidArgument(format!("{input}: no frame to cross-check")))?;
    let start = VertexGrid::from_grid(rest_grid).with_sliding_border(sliding_border);
    if start.unknowns() == 0 {
        return Err(Error::InvalidArgument(format!(
            "{input}: the starting vertex grid has no free coordinate, so there is nothing to \
             evaluate; give a rigidity map or --grid MxN"
        )));
    }
    let kl = options.samples_per_cell();
    let mut rows = naa_kernel_rows(gpu, input, rest, rest_grid, last, kl, sliding_border)?;
    rows.extend(naa_solve_rows(
        gpu,
        input,
        rest,
        rest_grid,
        frames,
        options,
        sliding_border,
    )?);
    Ok(rows)
}
