//! The axis-aligned distortion energy (seed §5.1, notes "Formulation" and "Analytic Jacobian"),
//! fast. The formula reads plainly, sample by sample, in [`super::plain::aa`]; this module
//! computes the same residuals and derivatives with the same operations in the layout below,
//! and `tests/gridwarp_plain.rs` checks it against the plain path (residuals bit for bit, the
//! sums within a derived bound).
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
//! parallel, and the blocks added up in cell order (entry by entry, by an
//! [`crate::lm::AssemblyPlan`] made once per [`RestSamples`]); J is never stored.
//!
//! # Evaluation layout
//! - The rest side of every sample (σ, o_s, o_t) depends only on the rest fields, the rest grid
//!   and K×L: [`RestSamples`], built once per sequence ([`super::solve::solve_sequence`]) and
//!   shared by every frame's energy ([`AaEnergy::from_rest_samples`]).
//! - Per evaluation, the warped sample coordinates are separable (f depends on the column
//!   sample only, g on the row sample only), so their texel positions are tabulated once per
//!   column and row sample.
//! - The four texels around each lane's warped point are read by gathers or, with AVX-512,
//!   by permuting two vector loads from the fields stored column by column, where a chunk's
//!   texel rows fit in 16 (module `texel_reads`; the same values either way).
//! - Inside a cell, samples are processed 8 (`LANES`) at a time (L row samples of one column
//!   sample, or two column samples of ≤ 4 rows each: a "chunk") in plain loops over
//!   fixed-size arrays that the compiler turns into vector instructions. The chunks of a cell
//!   go chunk row by chunk row (what a row of chunks shares, β and the texel rows, is found
//!   once), column sample by column sample within a row. The normal equations compute the
//!   residuals and derivatives of up to 8 chunks, then add them to the sums (two short loops
//!   rather than one long one: the 15 sums then stay in registers). Each lane keeps its own
//!   partial sums of F, Jᵀr and JᵀJ, added in lane order at the end of the cell. The sums
//!   therefore depend on the sample layout only, never on the number of threads.
//! - Products are added to the sums by fused multiply-adds (one rounding; the same result
//!   whether the CPU has the instruction or not), and c a − o is rounded once. The lane loops
//!   are compiled for AVX-512, for AVX2 + FMA and for no extension, and the fastest the CPU
//!   has runs ([`LaneCode`]); all give the same bits.

use std::borrow::Cow;
use std::mem::MaybeUninit;
use std::sync::OnceLock;

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::field::{bilinear_formula, bilinear_value, nearest_texel, Axis, Field, Sample};
use super::grid::Grid;
use super::lanes::{for_each_task, lane_total, lanes, LaneResiduals, LaneSums, LANES};
use super::texel_reads::{
    ColumnMajor, Gathers, LaneColumns, LaneRows, Quads, RowWindow, TexelReads, Windows,
};
use crate::lm::{AssemblyPlan, LocalNormalEquations, NormalEquations, Residuals};

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
/// area w = h_i k_j/(K L). Shared by the axis-aligned, non-axis-aligned and GPU energies
/// ([`RestSamples`] in sample-by-sample form).
pub fn rest_samples(rest: &RestFields, rest_grid: &Grid, k: usize, l: usize) -> Vec<RestSample> {
    RestSamples::new(rest, rest_grid, k, l).to_vec()
}

/// The layout of a cell's samples in the lane loops: (C, S) = (column samples, stored row
/// samples) per chunk of [`LANES`] samples. L ≤ 4: two column samples of S = 4 rows each
/// (L padded to 4); else one column sample and S = L rounded up to a multiple of 8.
fn chunk_layout(l: usize) -> (usize, usize) {
    if l <= LANES / 2 {
        (2, LANES / 2)
    } else {
        (1, l.div_ceil(LANES) * LANES)
    }
}

/// The rest side of the axis-aligned energy: σ, o_s, o_t of every sample. They depend only
/// on the rest fields, the rest grid and K×L, so a sequence builds them once (the paper's
/// preprocessing) and every frame's [`AaEnergy`] reads them
/// ([`AaEnergy::from_rest_samples`]).
///
/// Stored structure-of-arrays, sample (a, b) of cell c = i·(N−1) + j at (c·K' + a)·S + b, the
/// L row samples of a column sample contiguous, L padded to S and K to K' (a multiple of C)
/// as `chunk_layout` says, with σ = 0 samples (which contribute exactly 0).
#[derive(Clone, Debug, PartialEq)]
pub struct RestSamples {
    grid: Grid,
    k: usize,
    l: usize,
    /// C: column samples per chunk of LANES samples.
    chunk_columns: usize,
    /// K': column samples stored per cell (K plus padding).
    padded_k: usize,
    /// S: row samples stored per column sample (L plus padding).
    stride: usize,
    /// α_a = (a + ½)/K for a < K, 0 for the padding (length K').
    alpha: Vec<f64>,
    /// β_b = (b + ½)/L at c·S + b for b < L, c < C, 0 for the padding (length C·S).
    beta: Vec<f64>,
    /// The entries of a row table of C·S entries per cell row: row sample b at c·S + b for
    /// every c < C (None for padding), so that a chunk of C column samples reads its
    /// LANES row samples at once.
    row_slots: Vec<Option<f64>>,
    /// The entries of a column table of K' entries per cell column (None for padding).
    column_slots: Vec<Option<f64>>,
    sigma: Vec<f64>,
    o_s: Vec<f64>,
    o_t: Vec<f64>,
    /// 1/h_i and 1/k_j of the rest cells.
    inv_h: Vec<f64>,
    inv_k: Vec<f64>,
    /// Cell c has a sample with σ ≠ 0 (a cell without one contributes exactly nothing).
    active: Vec<bool>,
    /// The unknowns of cell c in slot order (s_i, s_{i+1}, t_j, t_{j+1}); None for the fixed
    /// lines 0 and 1 ([`AaEnergy::cell_unknowns`]).
    cell_unknowns: Vec<[Option<usize>; 4]>,
    /// The fixed-order sum of the cells' blocks over `cell_unknowns`, planned once.
    assembly: AssemblyPlan<4>,
}

/// One coordinate of the rest samples along one axis: the rest coordinate ŝ_i + α h_i, its
/// texel positions on the ‖O_s‖ and ‖O_t‖ fields and its nearest texel on R, found once per
/// column (row) of samples instead of once per sample.
struct RestAxis {
    o_s: Axis,
    o_t: Axis,
    rigidity: usize,
}

impl RestAxis {
    /// The samples at `fractions` of every cell along `lines` (cell-major); `texels` the
    /// sizes of ‖O_s‖, ‖O_t‖ and R along that axis.
    fn along(lines: &[f64], fractions: &[f64], texels: [usize; 3]) -> Vec<RestAxis> {
        let mut out = Vec::with_capacity((lines.len() - 1) * fractions.len());
        for cell in lines.windows(2) {
            let h = cell[1] - cell[0];
            for &fraction in fractions {
                let s = cell[0] + fraction * h;
                out.push(RestAxis {
                    o_s: Axis::new(s, texels[0]),
                    o_t: Axis::new(s, texels[1]),
                    rigidity: nearest_texel(s, texels[2]),
                });
            }
        }
        out
    }
}

/// The midpoint fractions (a + ½)/n, a = 0..n.
fn midpoints(n: usize) -> Vec<f64> {
    (0..n).map(|a| (a as f64 + 0.5) / n as f64).collect()
}

impl RestSamples {
    /// σ = √w R, o_s = ‖O_s‖ and o_t = ‖O_t‖ at the K×L midpoints of every rest cell
    /// (R at the nearest texel, ‖O_·‖ bilinear, exactly as [`Field::nearest`] and
    /// [`Field::bilinear`] give them). Cell columns in parallel (beyond twice
    /// `SAMPLES_PER_TASK` = 4096 samples).
    pub fn new(rest: &RestFields, rest_grid: &Grid, k: usize, l: usize) -> RestSamples {
        let (k, l) = (k.max(1), l.max(1));
        let (chunk_columns, stride) = chunk_layout(l);
        let padded_k = k.div_ceil(chunk_columns) * chunk_columns;
        let alpha = midpoints(k);
        let mut beta = midpoints(l);
        beta.resize(stride, 0.0);
        let slots = |fractions: &[f64], stored: usize| -> Vec<Option<f64>> {
            (0..stored).map(|a| fractions.get(a).copied()).collect()
        };
        let row_slots = slots(&beta[..l], stride).repeat(chunk_columns);
        let column_slots = slots(&alpha, padded_k);
        let beta = beta.repeat(chunk_columns);
        let (r, o_s, o_t) = (&rest.rigidity, &rest.o_s, &rest.o_t);
        let columns = RestAxis::along(&rest_grid.s, &alpha, [o_s.width, o_t.width, r.width]);
        let mut alpha = alpha;
        alpha.resize(padded_k, 0.0);
        let rows = RestAxis::along(&rest_grid.t, &beta[..l], [o_s.height, o_t.height, r.height]);
        let (m, n) = (rest_grid.s.len() - 1, rest_grid.t.len() - 1);
        let per_column = n * padded_k * stride;
        let mut out = RestSamples {
            grid: rest_grid.clone(),
            k,
            l,
            chunk_columns,
            padded_k,
            stride,
            alpha,
            beta,
            row_slots,
            column_slots,
            sigma: vec![0.0; m * per_column],
            o_s: vec![0.0; m * per_column],
            o_t: vec![0.0; m * per_column],
            inv_h: rest_grid
                .s
                .windows(2)
                .map(|w| 1.0 / (w[1] - w[0]))
                .collect(),
            inv_k: rest_grid
                .t
                .windows(2)
                .map(|w| 1.0 / (w[1] - w[0]))
                .collect(),
            active: Vec::new(),
            cell_unknowns: Vec::new(),
            assembly: AssemblyPlan::new(0, &[]),
        };
        // Cell column i's samples.
        let fill = |i: usize, sigma: &mut [f64], os: &mut [f64], ot: &mut [f64]| {
            let h = rest_grid.s[i + 1] - rest_grid.s[i];
            for j in 0..n {
                let kj = rest_grid.t[j + 1] - rest_grid.t[j];
                let root_w = (h * kj / (k * l) as f64).sqrt();
                for a in 0..k {
                    let x = &columns[i * k + a];
                    let base = (j * padded_k + a) * stride;
                    for (b, y) in rows[j * l..][..l].iter().enumerate() {
                        sigma[base + b] = root_w * r.values[y.rigidity * r.width + x.rigidity];
                        os[base + b] = o_s.bilinear_at(&x.o_s, &y.o_s).value;
                        ot[base + b] = o_t.bilinear_at(&x.o_t, &y.o_t).value;
                    }
                }
            }
        };
        if m * n * k * l <= 2 * SAMPLES_PER_TASK {
            // A small problem (as in [`for_each_task`]; a per-frame NAA energy's): on this
            // thread.
            let chunks = out.sigma.chunks_mut(per_column);
            let chunks = chunks.zip(out.o_s.chunks_mut(per_column));
            let chunks = chunks.zip(out.o_t.chunks_mut(per_column));
            for (i, ((sigma, os), ot)) in chunks.enumerate() {
                fill(i, sigma, os, ot);
            }
        } else {
            let chunks = out.sigma.par_chunks_mut(per_column);
            let chunks = chunks.zip(out.o_s.par_chunks_mut(per_column));
            let chunks = chunks.zip(out.o_t.par_chunks_mut(per_column));
            chunks
                .enumerate()
                .for_each(|(i, ((sigma, os), ot))| fill(i, sigma, os, ot));
        }
        out.cell_unknowns = (0..m * n).map(|c| out.unknowns_of(c)).collect();
        out.assembly = AssemblyPlan::new(rest_grid.unknowns(), &out.cell_unknowns);
        out.active = out
            .sigma
            .chunks_exact(padded_k * stride)
            .map(|cell| cell.iter().any(|&s| s != 0.0))
            .collect();
        out
    }

    /// The rest grid these samples belong to.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// The unknowns of cell `cell` = (i, j) in slot order (s_i, s_{i+1}, t_j, t_{j+1}): s_i
    /// is unknown i − 1 for 0 < i < M − 1, t_j unknown M − 2 + j − 1 for 0 < j < N − 1.
    fn unknowns_of(&self, cell: usize) -> [Option<usize>; 4] {
        let (m, rows) = (self.grid.s.len(), self.rows());
        let (i, j) = (cell / rows, cell % rows);
        let s_index = |i: usize| (i > 0 && i < m - 1).then(|| i - 1);
        let t_index = |j: usize| (j > 0 && j < rows).then(|| m - 2 + j - 1);
        [s_index(i), s_index(i + 1), t_index(j), t_index(j + 1)]
    }

    /// Samples per cell (K, L).
    pub fn per_cell(&self) -> (usize, usize) {
        (self.k, self.l)
    }

    fn rows(&self) -> usize {
        self.grid.t.len() - 1
    }

    fn cells(&self) -> usize {
        (self.grid.s.len() - 1) * self.rows()
    }

    /// The samples one by one, in the order of [`rest_samples`] (padding left out).
    pub fn to_vec(&self) -> Vec<RestSample> {
        let mut out = Vec::with_capacity(self.cells() * self.k * self.l);
        for cell in 0..self.cells() {
            for (a, &alpha) in self.alpha[..self.k].iter().enumerate() {
                let at = (cell * self.padded_k + a) * self.stride;
                for (b, &beta) in self.beta[..self.l].iter().enumerate() {
                    out.push(RestSample {
                        alpha,
                        beta,
                        sigma: self.sigma[at + b],
                        o_s: self.o_s[at + b],
                        o_t: self.o_t[at + b],
                    });
                }
            }
        }
        out
    }
}

/// The axis-aligned energy of one frame as a least-squares problem in the interior grid lines.
pub struct AaEnergy<'a> {
    deformed: &'a DeformedFields,
    /// Built for this energy ([`AaEnergy::new`]) or shared by a sequence's frames.
    rest: Cow<'a, RestSamples>,
    /// Which compiled form of the lane loops runs.
    code: LaneCode,
    /// ‖D_s‖ and ‖D_t‖ stored column by column, for the window reads (None: gathers only).
    /// Built at the first evaluation (on the solver's pool thread, both fields at once) if
    /// `windows`.
    column_major: OnceLock<Box<[ColumnMajor; 2]>>,
    /// Whether this energy reads texels by windows (its [`LaneCode`] and the CPU allow it).
    windows: bool,
    /// The cells' blocks of the last normal equations (a buffer kept between evaluations).
    blocks: Vec<LocalNormalEquations<4>>,
    /// The grid and the texel tables of the last evaluation (buffers kept likewise).
    grid: Grid,
    axes: WarpedAxes,
}

/// Which compiled form of the lane loops an [`AaEnergy`] runs. All give the same results bit
/// for bit (the same IEEE operations in the same order, and a fused multiply-add rounds once
/// whether the CPU has the instruction or not); tests compare them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LaneCode {
    /// The fastest this CPU has: AVX-512 with texels read by permuting vector loads where a
    /// chunk's texel rows fit, else AVX2 + FMA, else portable code.
    #[default]
    Fastest,
    /// AVX-512 or AVX2 + FMA as the CPU has them, every texel read by a gather.
    Gathers,
    /// AVX2 + FMA if the CPU has them (else portable), texels read by gathers.
    Avx2,
    /// Portable code (no instruction-set extension; on an x86-64 CPU each fused
    /// multiply-add is a library call).
    Portable,
}

/// The instruction set a pass runs with ([`LaneCode`] and what the CPU has).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum InstructionSet {
    Avx512,
    Avx2Fma,
    Portable,
}

impl InstructionSet {
    /// The best this CPU has for `code`.
    fn for_code(code: LaneCode) -> InstructionSet {
        #[cfg(target_arch = "x86_64")]
        if code != LaneCode::Portable {
            if code != LaneCode::Avx2 && std::arch::is_x86_feature_detected!("avx512f") {
                return InstructionSet::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return InstructionSet::Avx2Fma;
            }
        }
        let _ = code;
        InstructionSet::Portable
    }
}

/// Where the warped samples of one grid fall on one deformed field's texels, separable
/// because the grid is axis-aligned: f = s_i + α_a (s_{i+1} − s_i) depends on the cell column
/// and α only, g = t_j + β_b (t_{j+1} − t_j) on the row and β only. Found once per column
/// sample (index i·K + a) and row sample (j·S + b, padded as [`RestSamples`]), not once per
/// sample.
#[derive(Default)]
struct FieldTexels {
    columns: AxisTexels,
    /// Texel rows stored as offsets y·W into the field's values.
    rows: AxisTexels,
    /// The window of each chunk row (LANES consecutive row table entries) for [`Windows`].
    windows: Vec<Option<RowWindow>>,
}

impl FieldTexels {
    /// Lane l's column sample `column(l)`.
    #[inline(always)]
    fn columns_at(&self, column: impl Fn(usize) -> usize) -> ColumnTexels {
        let c = &self.columns;
        ColumnTexels {
            lower: std::array::from_fn(|lane| c.lower[column(lane)]),
            upper: std::array::from_fn(|lane| c.upper[column(lane)]),
            frac: std::array::from_fn(|lane| c.frac[column(lane)]),
            scale: std::array::from_fn(|lane| c.scale[column(lane)]),
        }
    }

    /// The LANES row table entries from `at` on (a multiple of LANES).
    #[inline(always)]
    fn rows_at(&self, at: usize) -> RowTexels<'_> {
        RowTexels {
            lower: lanes(&self.rows.lower, at),
            upper: lanes(&self.rows.upper, at),
            frac: lanes(&self.rows.frac, at),
            scale: lanes(&self.rows.scale, at),
            window: self.windows.get(at / LANES).and_then(Option::as_ref),
        }
    }
}

/// [`Axis`] positions of many coordinates, structure-of-arrays (what a lane loop reads).
#[derive(Default)]
struct AxisTexels {
    lower: Vec<usize>,
    upper: Vec<usize>,
    frac: Vec<f64>,
    scale: Vec<f64>,
}

impl AxisTexels {
    /// The samples of every cell along `lines` at the fractions `slots` (one table entry
    /// each; None: padding at the texels of the entry before, frac = scale = 0), on an axis
    /// of `texels` texels; texel indices multiplied by `step` (1 along s, the field's width
    /// along t).
    /// (Refilled in place: the tables are kept from one evaluation to the next.)
    fn refill(&mut self, lines: &[f64], slots: &[Option<f64>], texels: usize, step: usize) {
        let size = (lines.len() - 1) * slots.len();
        let out = self;
        for v in [&mut out.lower, &mut out.upper] {
            v.clear();
            v.resize(size, 0);
        }
        for v in [&mut out.frac, &mut out.scale] {
            v.clear();
            v.resize(size, 0.0);
        }
        for (i, cell) in lines.windows(2).enumerate() {
            for (a, slot) in slots.iter().enumerate() {
                let at = i * slots.len() + a;
                let Some(fraction) = slot else {
                    // Padding (σ = 0) reads the texels of the sample before it, so that it
                    // stays within that chunk's window ([`RowWindow`]).
                    if at > 0 {
                        out.lower[at] = out.lower[at - 1];
                        out.upper[at] = out.upper[at - 1];
                    }
                    continue;
                };
                let axis = Axis::new(cell[0] + fraction * (cell[1] - cell[0]), texels);
                out.lower[at] = axis.lower * step;
                out.upper[at] = axis.upper * step;
                out.frac[at] = axis.frac;
                out.scale[at] = axis.scale;
            }
        }
    }

    /// The windows of the chunk rows of a row table (entries with texel rows `lower`/`step`,
    /// LANES consecutive entries a chunk row), for chunks of `columns` column samples.
    fn windows_into(&self, step: usize, columns: usize, out: &mut Vec<Option<RowWindow>>) {
        let row = |v: &[usize]| -> [usize; LANES] { std::array::from_fn(|l| v[l] / step.max(1)) };
        let lower = self.lower.chunks_exact(LANES);
        let upper = self.upper.chunks_exact(LANES);
        out.clear();
        out.extend(
            lower
                .zip(upper)
                .map(|(lower, upper)| RowWindow::of(&row(lower), &row(upper), columns)),
        );
    }
}

/// Everything an evaluation at the grid g needs besides the rest samples: the texel tables of
/// D_s and (if its resolution differs) D_t, and the cell slopes a_i, b_j.
#[derive(Default)]
struct WarpedAxes {
    d_s: FieldTexels,
    d_t: Option<FieldTexels>,
    slope_s: Vec<f64>,
    slope_t: Vec<f64>,
}

impl WarpedAxes {
    fn d_t(&self) -> &FieldTexels {
        self.d_t.as_ref().unwrap_or(&self.d_s)
    }
}

/// What a cell's residuals need of the grid: the slopes a_i = (s_{i+1} − s_i)/h_i,
/// b_j = (t_{j+1} − t_j)/k_j and the inverse rest sizes 1/h_i, 1/k_j; and where the cell's
/// entries start in the rest samples, the column tables and the row tables (found once per
/// cell, not once per chunk).
#[derive(Clone, Copy)]
struct WarpedCell {
    a: f64,
    b: f64,
    inv_h: f64,
    inv_k: f64,
    first_sample: usize,
    first_column: usize,
    first_row: usize,
}

/// The column samples' texel positions on one field, per lane (lane l belongs to column
/// sample a₀ + l / (LANES/C) of its chunk).
#[derive(Clone, Copy)]
struct ColumnTexels {
    lower: [usize; LANES],
    upper: [usize; LANES],
    frac: [f64; LANES],
    scale: [f64; LANES],
}

/// The row samples' texel rows on one field, per lane, and their window.
#[derive(Clone, Copy)]
struct RowTexels<'c> {
    lower: &'c [usize; LANES],
    upper: &'c [usize; LANES],
    frac: &'c [f64; LANES],
    scale: &'c [f64; LANES],
    window: Option<&'c RowWindow>,
}

/// One deformed field at a chunk's lanes: the four texels around each warped point
/// ([`TexelReads`]) and the point's (frac, scale) along s and t ([`Axis`]).
struct LaneTexels {
    quads: Quads,
    s: ([f64; LANES], [f64; LANES]),
    t: ([f64; LANES], [f64; LANES]),
}

impl LaneTexels {
    /// Read with `reads` on field `field` (0: ‖D_s‖, 1: ‖D_t‖).
    #[inline(always)]
    fn read(reads: impl TexelReads, field: usize, x: &ColumnTexels, y: &RowTexels) -> Self {
        let (columns, rows) = Self::positions(x, y);
        LaneTexels {
            quads: reads.quads(field, columns, rows, y.window),
            s: (x.frac, x.scale),
            t: (*y.frac, *y.scale),
        }
    }

    /// Both fields read with `reads` at the same texel positions (fields of one resolution).
    #[inline(always)]
    fn read_both(reads: impl TexelReads, x: &ColumnTexels, y: &RowTexels) -> [Self; 2] {
        let (columns, rows) = Self::positions(x, y);
        let [s, t] = reads.quads_of_both(columns, rows, y.window);
        let field = |quads| LaneTexels {
            quads,
            s: (x.frac, x.scale),
            t: (*y.frac, *y.scale),
        };
        [field(s), field(t)]
    }

    /// The texel positions of the lanes, as the reads take them.
    #[inline(always)]
    fn positions<'c>(x: &'c ColumnTexels, y: &RowTexels<'c>) -> (LaneColumns<'c>, LaneRows<'c>) {
        let columns = LaneColumns {
            lower: &x.lower,
            upper: &x.upper,
        };
        let rows = LaneRows {
            lower: y.lower,
            upper: y.upper,
        };
        (columns, rows)
    }

    /// [f₀₀, f₁₀, f₀₁, f₁₁] of lane `lane`.
    #[inline(always)]
    fn quad(&self, lane: usize) -> [f64; 4] {
        let q = &self.quads;
        [q[0][lane], q[1][lane], q[2][lane], q[3][lane]]
    }

    /// The field's value at lane `lane`'s warped point.
    #[inline(always)]
    fn value(&self, lane: usize) -> f64 {
        bilinear_value(self.s.0[lane], self.t.0[lane], self.quad(lane))
    }

    /// The field's value and gradient at lane `lane`'s warped point.
    #[inline(always)]
    fn sample(&self, lane: usize) -> Sample {
        bilinear_formula(
            (self.s.0[lane], self.s.1[lane]),
            (self.t.0[lane], self.t.1[lane]),
            self.quad(lane),
        )
    }
}

/// What the chunks of one chunk row of a cell (row samples b₀ … b₀ + LANES/C − 1) share: β
/// and the texel rows of ‖D_s‖ and ‖D_t‖, found once per cell and chunk row.
struct ChunkRow<'c> {
    b0: usize,
    beta: &'c [f64; LANES],
    rows: [RowTexels<'c>; 2],
}

/// LANES samples of a cell: C column samples a₀ … a₀ + C − 1, each with LANES/C row samples
/// b₀ …: what the lane loops read.
struct Chunk<'c> {
    alpha: [f64; LANES],
    beta: &'c [f64; LANES],
    sigma: &'c [f64; LANES],
    o_s: &'c [f64; LANES],
    o_t: &'c [f64; LANES],
    /// ‖D_s‖ and ‖D_t‖ at the lanes.
    fields: [LaneTexels; 2],
}

impl Chunk<'_> {
    /// c_s = ‖D_s‖ and c_t = ‖D_t‖ at lane `lane`'s warped point, values only.
    #[inline(always)]
    fn values(&self, lane: usize) -> [f64; 2] {
        [self.fields[0].value(lane), self.fields[1].value(lane)]
    }

    /// c_s and c_t at lane `lane`'s warped point with their gradients.
    #[inline(always)]
    fn samples(&self, lane: usize) -> [Sample; 2] {
        [self.fields[0].sample(lane), self.fields[1].sample(lane)]
    }

    /// Lane `lane`'s residuals r^s = σ (c_s a_i − o_s), r^t = σ (c_t b_j − o_t), c a − o
    /// rounded once (a fused multiply-add: exactly 0 where c a = o).
    #[inline(always)]
    fn residuals(&self, w: WarpedCell, [cs, ct]: [f64; 2], lane: usize) -> [f64; 2] {
        let sigma = self.sigma[lane];
        [
            sigma * cs.mul_add(w.a, -self.o_s[lane]),
            sigma * ct.mul_add(w.b, -self.o_t[lane]),
        ]
    }

    /// Lane `lane`'s two residuals with their derivatives in slot order (s_i, s_{i+1}, t_j,
    /// t_{j+1}) (notes, "Analytic Jacobian"):
    ///   ∂r^s = σ [a c_s,x (1−α) − c_s/h, a c_s,x α + c_s/h, a c_s,y (1−β), a c_s,y β],
    ///   ∂r^t = σ [b c_t,x (1−α), b c_t,x α, b c_t,y (1−β) − c_t/k, b c_t,y β + c_t/k],
    /// computed from u = σ a c_s,x, v = σ c_s/h, w = σ a c_s,y (and the same for c_t) as
    /// [u(1−α) − v, uα + v, w(1−β), wβ], the first two by fused multiply-adds.
    #[inline(always)]
    fn residuals_and_derivatives(
        &self,
        w: WarpedCell,
        [cs, ct]: [Sample; 2],
        lane: usize,
    ) -> [(f64, [f64; 4]); 2] {
        let [rs, rt] = self.residuals(w, [cs.value, ct.value], lane);
        let (al, be, sg) = (self.alpha[lane], self.beta[lane], self.sigma[lane]);
        let (sa, sb) = (sg * w.a, sg * w.b);
        // σ a ∂c_s/∂s, σ c_s/h, σ a ∂c_s/∂t and the same for c_t.
        let (us, vs, ws) = (sa * cs.ds, (sg * w.inv_h) * cs.value, sa * cs.dt);
        let (ut, vt, wt) = (sb * ct.dt, (sg * w.inv_k) * ct.value, sb * ct.ds);
        [
            (
                rs,
                [
                    us.mul_add(1.0 - al, -vs),
                    us.mul_add(al, vs),
                    ws * (1.0 - be),
                    ws * be,
                ],
            ),
            (
                rt,
                [
                    wt * (1.0 - al),
                    wt * al,
                    ut.mul_add(1.0 - be, -vt),
                    ut.mul_add(be, vt),
                ],
            ),
        ]
    }

    /// The sizes of the terms of [`Self::residuals_and_derivatives`]' derivatives, which may
    /// cancel there: |u|(1 − α) + |v|, |u| α + |v| along the axis, |w|(1 − β), |w| β across (and
    /// the same for r^t). An f32 derivative's error is relative to these, not to its value.
    fn derivative_magnitudes(
        &self,
        w: WarpedCell,
        [cs, ct]: [Sample; 2],
        lane: usize,
    ) -> [[f64; 4]; 2] {
        let (al, be, sg) = (self.alpha[lane], self.beta[lane], self.sigma[lane]);
        let (sa, sb) = ((sg * w.a).abs(), (sg * w.b).abs());
        let (us, vs, ws) = (
            sa * cs.ds.abs(),
            (sg * w.inv_h * cs.value).abs(),
            sa * cs.dt.abs(),
        );
        let (ut, vt, wt) = (
            sb * ct.dt.abs(),
            (sg * w.inv_k * ct.value).abs(),
            sb * ct.ds.abs(),
        );
        [
            [us * (1.0 - al) + vs, us * al + vs, ws * (1.0 - be), ws * be],
            [wt * (1.0 - al), wt * al, ut * (1.0 - be) + vt, ut * be + vt],
        ]
    }
}

/// Chunks whose residuals the axis-aligned normal equations compute before summing them.
const BATCH: usize = 8;

/// The first `filled` entries of `batch`, which the caller has written.
#[inline(always)]
fn written<T>(batch: &[MaybeUninit<T>; BATCH], filled: usize) -> &[T] {
    let filled = filled.min(BATCH);
    // SAFETY: the caller wrote entries 0 … filled − 1 (`MaybeUninit::write`) since it last
    // read them; `MaybeUninit<T>` has the layout of `T`.
    unsafe { std::slice::from_raw_parts(batch.as_ptr().cast::<T>(), filled) }
}

/// Samples per parallel task at most ([`for_each_task`]), and the fewest worth splitting:
/// tens of microseconds of work (≈ 7 ns a sample for the normal equations), enough to
/// amortise forking a task. Results do not depend on it.
const SAMPLES_PER_TASK: usize = 4096;

impl<'a> AaEnergy<'a> {
    /// Precompute the rest-point quantities of every sample ([`RestSamples`]): K×L midpoints
    /// per cell.
    pub fn new(
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &'a DeformedFields,
        k: usize,
        l: usize,
    ) -> Self {
        Self::with_rest(
            deformed,
            Cow::Owned(RestSamples::new(rest, rest_grid, k, l)),
        )
    }

    /// The energy of `deformed` over rest samples built beforehand (once per sequence).
    pub fn from_rest_samples(samples: &'a RestSamples, deformed: &'a DeformedFields) -> Self {
        Self::with_rest(deformed, Cow::Borrowed(samples))
    }

    /// The energy of `deformed` over `rest`, with the fastest lane code.
    fn with_rest(deformed: &'a DeformedFields, rest: Cow<'a, RestSamples>) -> Self {
        AaEnergy {
            deformed,
            code: LaneCode::Fastest,
            column_major: OnceLock::new(),
            windows: false,
            blocks: Vec::new(),
            grid: rest.grid.clone(),
            axes: WarpedAxes::default(),
            rest,
        }
        .with_lane_code(LaneCode::Fastest)
    }

    /// The same energy run with the lane code `code` (the same results; for tests and
    /// comparisons). [`LaneCode::Fastest`] stores the deformed fields column by column too
    /// (at the first evaluation) if the CPU can read them by permuting vector loads.
    pub fn with_lane_code(mut self, code: LaneCode) -> Self {
        self.windows = code == LaneCode::Fastest && Windows::available();
        if !self.windows {
            self.column_major = OnceLock::new();
        }
        self.code = code;
        self
    }

    /// ‖D_s‖ and ‖D_t‖ column by column if this energy reads by windows, transposed the
    /// first time (the two fields side by side on rayon's pool).
    fn column_major(&self) -> Option<&[ColumnMajor; 2]> {
        if !self.windows {
            return None;
        }
        let (d_s, d_t) = (&self.deformed.d_s, &self.deformed.d_t);
        let both = self.column_major.get_or_init(|| {
            let (s, t) = rayon::join(|| ColumnMajor::of(d_s), || ColumnMajor::of(d_t));
            Box::new([s, t])
        });
        Some(both)
    }

    /// (Chunk rows of ‖D_s‖ read by windows at `x`, all chunk rows): how many of this energy's
    /// texel reads at `x` permute vector loads (none without AVX-512F). For tests.
    pub fn chunk_rows_read_by_windows(&self, x: &[f64]) -> (usize, usize) {
        let axes = self.warped_axes(&self.rest.grid.with_unknowns(x));
        let windows = &axes.d_s.windows;
        let used = if self.windows().is_some() {
            windows.iter().flatten().count()
        } else {
            0
        };
        (used, windows.len())
    }

    /// The rest grid.
    pub fn rest_grid(&self) -> &Grid {
        &self.rest.grid
    }

    fn rows(&self) -> usize {
        self.rest.rows()
    }

    fn cells(&self) -> usize {
        self.rest.cells()
    }

    /// The unknowns of cell `cell` = (i, j) in slot order (s_i, s_{i+1}, t_j, t_{j+1}); None
    /// for the fixed lines 0 and 1.
    pub fn cell_unknowns(&self, cell: usize) -> [Option<usize>; 4] {
        self.rest.cell_unknowns[cell]
    }

    /// The texel tables of every column and row sample of the grid `g` on D_s's texels (and
    /// D_t's, if it has another resolution), and the cells' slopes.
    fn warped_axes(&self, g: &Grid) -> WarpedAxes {
        let mut axes = WarpedAxes::default();
        self.refill_warped_axes(g, &mut axes);
        axes
    }

    /// [`AaEnergy::warped_axes`] into `axes` (its tables reused).
    fn refill_warped_axes(&self, g: &Grid, axes: &mut WarpedAxes) {
        let r = &*self.rest;
        let refill = |f: &Field, out: &mut FieldTexels| {
            out.rows.refill(&g.t, &r.row_slots, f.height, f.width);
            out.columns.refill(&g.s, &r.column_slots, f.width, 1);
            out.rows
                .windows_into(f.width, r.chunk_columns, &mut out.windows);
        };
        let (d_s, d_t) = (&self.deformed.d_s, &self.deformed.d_t);
        refill(d_s, &mut axes.d_s);
        if (d_t.width, d_t.height) != (d_s.width, d_s.height) {
            refill(d_t, axes.d_t.get_or_insert_with(FieldTexels::default));
        } else {
            axes.d_t = None;
        }
        // a_i = (s_{i+1} − s_i)/h_i, b_j likewise.
        let slopes = |lines: &[f64], rest: &[f64], out: &mut Vec<f64>| {
            let widths = lines.windows(2).zip(rest.windows(2));
            out.clear();
            out.extend(widths.map(|(w, h)| (w[1] - w[0]) / (h[1] - h[0])));
        };
        slopes(&g.s, &r.grid.s, &mut axes.slope_s);
        slopes(&g.t, &r.grid.t, &mut axes.slope_t);
    }

    /// This energy's evaluation tables at `x`, in the buffers kept from the last evaluation
    /// (taken out; the caller puts them back).
    fn axes_at(&mut self, x: &[f64]) -> WarpedAxes {
        let mut axes = std::mem::take(&mut self.axes);
        self.grid.set_unknowns(x);
        self.refill_warped_axes(&self.grid, &mut axes);
        axes
    }

    /// Cell `cell` = (i, j)'s slopes and inverse rest sizes, and where its entries start.
    #[inline(always)]
    fn warped_cell(&self, w: &WarpedAxes, cell: usize) -> WarpedCell {
        let (i, j) = (cell / self.rows(), cell % self.rows());
        let r = &*self.rest;
        WarpedCell {
            a: w.slope_s[i],
            b: w.slope_t[j],
            inv_h: r.inv_h[i],
            inv_k: r.inv_k[j],
            first_sample: cell * r.padded_k * r.stride,
            first_column: i * r.padded_k,
            first_row: j * r.chunk_columns * r.stride,
        }
    }

    /// The chunk row of the cell `cell` from row sample b₀ (a multiple of LANES/C): what
    /// its chunks share.
    #[inline(always)]
    fn chunk_row<'c>(&'c self, w: &'c WarpedAxes, cell: &WarpedCell, b0: usize) -> ChunkRow<'c> {
        let row = cell.first_row + b0;
        ChunkRow {
            b0,
            beta: lanes(&self.rest.beta, b0),
            rows: [w.d_s.rows_at(row), w.d_t().rows_at(row)],
        }
    }

    /// The chunk of the cell `cell` in the chunk row `row` from column sample a₀ (a multiple
    /// of C, C = `COLUMNS`, [`chunk_layout`]).
    #[inline(always)]
    fn chunk<'c, const COLUMNS: usize>(
        &'c self,
        reads: impl TexelReads,
        w: &'c WarpedAxes,
        cell: &WarpedCell,
        row: &ChunkRow<'c>,
        a0: usize,
    ) -> Chunk<'c> {
        let r = &*self.rest;
        let at = cell.first_sample + a0 * r.stride + row.b0;
        let (ts, tt) = (&w.d_s, w.d_t());
        // Lane l reads column sample a₀ + l / (LANES/C): one value broadcast (C = 1) or two.
        let column = |lane: usize| cell.first_column + a0 + lane / (LANES / COLUMNS);
        Chunk {
            alpha: std::array::from_fn(|lane| r.alpha[a0 + lane / (LANES / COLUMNS)]),
            beta: row.beta,
            sigma: lanes(&r.sigma, at),
            o_s: lanes(&r.o_s, at),
            o_t: lanes(&r.o_t, at),
            // ‖D_t‖ at ‖D_s‖'s resolution (no tables of its own): the same texel positions.
            fields: match &w.d_t {
                None => LaneTexels::read_both(reads, &ts.columns_at(column), &row.rows[0]),
                Some(_) => [
                    LaneTexels::read(reads, 0, &ts.columns_at(column), &row.rows[0]),
                    LaneTexels::read(reads, 1, &tt.columns_at(column), &row.rows[1]),
                ],
            },
        }
    }

    /// Σ r² over cell `cell`'s residuals: values only, no field gradients (an energy-only
    /// evaluation of a damping trial); per-lane sums added in lane order.
    #[inline(always)]
    fn cell_energy<const COLUMNS: usize>(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        cell: usize,
    ) -> f64 {
        if !self.rest.active[cell] {
            return 0.0;
        }
        let warped = self.warped_cell(w, cell);
        let mut sums = [0.0; LANES];
        for b0 in (0..self.rest.stride).step_by(LANES / COLUMNS) {
            let row = self.chunk_row(w, &warped, b0);
            for a0 in (0..self.rest.padded_k).step_by(COLUMNS) {
                let chunk = self.chunk::<COLUMNS>(reads, w, &warped, &row, a0);
                for (lane, sum) in sums.iter_mut().enumerate() {
                    let c = chunk.values(lane);
                    let [rs, rt] = chunk.residuals(warped, c, lane);
                    *sum = rs.mul_add(rs, *sum);
                    *sum = rt.mul_add(rt, *sum);
                }
            }
        }
        lane_total(&sums)
    }

    /// Cell `cell`'s F, JᵀJ and Jᵀr over its four slots.
    #[inline(always)]
    fn cell_block<const COLUMNS: usize>(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        cell: usize,
    ) -> LocalNormalEquations<4> {
        if !self.rest.active[cell] {
            return LocalNormalEquations::default();
        }
        let warped = self.warped_cell(w, cell);
        let mut sums = LaneSums::<4, 10>::new();
        // Residuals and derivatives of BATCH chunks, then their sums: the sums' loop then
        // holds its 15 partial sums in registers. (The batch is not zeroed first: it would
        // cost as much as writing it; only written entries are read.)
        let mut batch = [const { MaybeUninit::<LaneResiduals<4>>::uninit() }; BATCH];
        let mut filled = 0;
        for b0 in (0..self.rest.stride).step_by(LANES / COLUMNS) {
            let row = self.chunk_row(w, &warped, b0);
            for a0 in (0..self.rest.padded_k).step_by(COLUMNS) {
                let chunk = self.chunk::<COLUMNS>(reads, w, &warped, &row, a0);
                // One simple loop over the lanes (each one vector operation per line).
                let mut out = LaneResiduals::ZERO;
                for lane in 0..LANES {
                    let c = chunk.samples(lane);
                    let rd = chunk.residuals_and_derivatives(warped, c, lane);
                    for (axis, (r_axis, d_axis)) in rd.into_iter().enumerate() {
                        out.r[axis][lane] = r_axis;
                        for (d, d_p) in out.d[axis].iter_mut().zip(d_axis) {
                            d[lane] = d_p;
                        }
                    }
                }
                batch[filled].write(out);
                filled += 1;
                if filled == BATCH {
                    sums.accumulate_chunks(written(&batch, filled));
                    filled = 0;
                }
            }
        }
        sums.accumulate_chunks(written(&batch, filled));
        sums.reduce()
    }

    /// `out[c] = cell_energy(first + c)`, with the chunk layout of these rest samples.
    #[inline(always)]
    fn fill_energies_baseline(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        first: usize,
        out: &mut [f64],
    ) {
        for (c, e) in out.iter_mut().enumerate() {
            *e = match self.rest.chunk_columns {
                2 => self.cell_energy::<2>(reads, w, first + c),
                _ => self.cell_energy::<1>(reads, w, first + c),
            };
        }
    }

    /// `out[c] = cell_block(first + c)`.
    #[inline(always)]
    fn fill_blocks_baseline(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        first: usize,
        out: &mut [LocalNormalEquations<4>],
    ) {
        for (c, block) in out.iter_mut().enumerate() {
            *block = match self.rest.chunk_columns {
                2 => self.cell_block::<2>(reads, w, first + c),
                _ => self.cell_block::<1>(reads, w, first + c),
            };
        }
    }

    /// [`AaEnergy::fill_energies_baseline`] compiled with AVX-512 (8 lanes in one register):
    /// the same IEEE operations in the same order (Rust never fuses a multiply and an add by
    /// itself), so the same results bit for bit.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn fill_energies_avx512(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        first: usize,
        out: &mut [f64],
    ) {
        self.fill_energies_baseline(reads, w, first, out)
    }

    /// [`AaEnergy::fill_blocks_baseline`] compiled with AVX-512 (same results bit for bit).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn fill_blocks_avx512(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        first: usize,
        out: &mut [LocalNormalEquations<4>],
    ) {
        self.fill_blocks_baseline(reads, w, first, out)
    }

    /// [`AaEnergy::fill_energies_baseline`] compiled with AVX2 and FMA (4 lanes a register,
    /// fused multiply-adds in hardware; same results bit for bit).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn fill_energies_avx2(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        first: usize,
        out: &mut [f64],
    ) {
        self.fill_energies_baseline(reads, w, first, out)
    }

    /// [`AaEnergy::fill_blocks_baseline`] compiled with AVX2 and FMA (same results bit for
    /// bit).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn fill_blocks_avx2(
        &self,
        reads: impl TexelReads,
        w: &WarpedAxes,
        first: usize,
        out: &mut [LocalNormalEquations<4>],
    ) {
        self.fill_blocks_baseline(reads, w, first, out)
    }

    /// The portable texel reads.
    fn gathers(&self) -> Gathers<'_> {
        Gathers {
            fields: [&self.deformed.d_s, &self.deformed.d_t],
        }
    }

    /// Window reads, if this energy stores its fields column by column and the CPU has
    /// AVX-512F.
    fn windows(&self) -> Option<Windows<'_>> {
        let columns = self.column_major()?;
        Windows::new([&self.deformed.d_s, &self.deformed.d_t], columns)
    }

    /// Cell energies `first..` into `out`, with this energy's [`LaneCode`].
    fn fill_energies(&self, w: &WarpedAxes, first: usize, out: &mut [f64]) {
        let gathers = self.gathers();
        // SAFETY (each unsafe call): `InstructionSet::for_code` returned the instruction set
        // only after checking that the CPU has it.
        #[cfg(target_arch = "x86_64")]
        match InstructionSet::for_code(self.code) {
            InstructionSet::Avx512 => {
                return match self.windows() {
                    Some(reads) => unsafe { self.fill_energies_avx512(reads, w, first, out) },
                    None => unsafe { self.fill_energies_avx512(gathers, w, first, out) },
                }
            }
            InstructionSet::Avx2Fma => {
                return unsafe { self.fill_energies_avx2(gathers, w, first, out) }
            }
            InstructionSet::Portable => {}
        }
        self.fill_energies_baseline(gathers, w, first, out)
    }

    /// Cell blocks `first..` into `out`, with this energy's [`LaneCode`].
    fn fill_blocks(&self, w: &WarpedAxes, first: usize, out: &mut [LocalNormalEquations<4>]) {
        let gathers = self.gathers();
        // SAFETY (each unsafe call): `InstructionSet::for_code` returned the instruction set
        // only after checking that the CPU has it.
        #[cfg(target_arch = "x86_64")]
        match InstructionSet::for_code(self.code) {
            InstructionSet::Avx512 => {
                return match self.windows() {
                    Some(reads) => unsafe { self.fill_blocks_avx512(reads, w, first, out) },
                    None => unsafe { self.fill_blocks_avx512(gathers, w, first, out) },
                }
            }
            InstructionSet::Avx2Fma => {
                return unsafe { self.fill_blocks_avx2(gathers, w, first, out) }
            }
            InstructionSet::Portable => {}
        }
        self.fill_blocks_baseline(gathers, w, first, out)
    }

    /// Fill `out` (one entry per cell) by `fill(first cell, part)`, in parallel tasks of about
    /// [`SAMPLES_PER_TASK`] samples ([`for_each_task`]).
    fn per_cell<T: Send>(&self, out: &mut [T], fill: impl Fn(usize, &mut [T]) + Sync) {
        for_each_task(out, self.rest.k * self.rest.l, SAMPLES_PER_TASK, fill);
    }

    /// Visit every residual of cell `cell` at the grid `g` (σ ≠ 0 samples, in the order cell,
    /// sample a, b, axis): `visit(r, ∂r/∂x)` in slot order. The lane loops' formulas, one
    /// sample at a time; for the test helpers below.
    fn for_each_residual(
        &self,
        w: &WarpedAxes,
        cell: usize,
        mut visit: impl FnMut(f64, &[f64; 4], &[f64; 4]),
    ) {
        match self.rest.chunk_columns {
            2 => self.for_each_residual_in::<2>(w, cell, &mut visit),
            _ => self.for_each_residual_in::<1>(w, cell, &mut visit),
        }
    }

    fn for_each_residual_in<const COLUMNS: usize>(
        &self,
        w: &WarpedAxes,
        cell: usize,
        visit: &mut impl FnMut(f64, &[f64; 4], &[f64; 4]),
    ) {
        let warped = self.warped_cell(w, cell);
        let rows_per_chunk = LANES / COLUMNS;
        for a0 in (0..self.rest.padded_k).step_by(COLUMNS) {
            for b0 in (0..self.rest.stride).step_by(rows_per_chunk) {
                let row = self.chunk_row(w, &warped, b0);
                let chunk = self.chunk::<COLUMNS>(self.gathers(), w, &warped, &row, a0);
                for lane in 0..LANES {
                    let (a, b) = (a0 + lane / rows_per_chunk, b0 + lane % rows_per_chunk);
                    if a < self.rest.k && b < self.rest.l && chunk.sigma[lane] != 0.0 {
                        let c = chunk.samples(lane);
                        let sizes = chunk.derivative_magnitudes(warped, c, lane);
                        for ((r, d), m) in chunk
                            .residuals_and_derivatives(warped, c, lane)
                            .iter()
                            .zip(&sizes)
                        {
                            visit(*r, d, m);
                        }
                    }
                }
            }
        }
    }

    /// All residuals at `x`, in a fixed order (cell column, row, sample, axis). For tests.
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        let axes = self.warped_axes(&self.rest.grid.with_unknowns(x));
        let mut out = Vec::new();
        for cell in 0..self.cells() {
            self.for_each_residual(&axes, cell, |r, _, _| out.push(r));
        }
        out
    }

    /// The dense Jacobian at `x` (rows as in [`AaEnergy::residuals`]). For tests.
    pub fn jacobian(&self, x: &[f64]) -> DMatrix<f64> {
        self.jacobian_of(x, false)
    }

    /// The sizes of the terms of every derivative in [`Self::jacobian`] (the same layout): where
    /// a derivative's terms cancel, its f32 error is relative to these, not to |J|. For the
    /// cross-check's bounds.
    pub fn jacobian_magnitudes(&self, x: &[f64]) -> DMatrix<f64> {
        self.jacobian_of(x, true)
    }

    fn jacobian_of(&self, x: &[f64], magnitudes: bool) -> DMatrix<f64> {
        let axes = self.warped_axes(&self.rest.grid.with_unknowns(x));
        let mut rows = Vec::new();
        for cell in 0..self.cells() {
            let slots = self.cell_unknowns(cell);
            self.for_each_residual(&axes, cell, |_, d, m| {
                rows.push((slots, if magnitudes { *m } else { *d }))
            });
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
        let mut block = [LocalNormalEquations::default()];
        self.fill_blocks(&self.warped_axes(g), cell, &mut block);
        block[0]
    }
}

impl Residuals for AaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest.grid.unknowns()
    }

    /// F(x) = Σ r², per cell (cells in parallel), then summed in cell order (deterministic).
    fn energy(&mut self, x: &[f64]) -> f64 {
        self.column_major(); // before the cells are forked
        let axes = self.axes_at(x);
        let mut per_cell = vec![0.0; self.cells()];
        self.per_cell(&mut per_cell, |first, out| {
            self.fill_energies(&axes, first, out)
        });
        self.axes = axes;
        per_cell.iter().sum()
    }

    /// F, JᵀJ and Jᵀr: each cell's 4×4 block (cells in parallel), the blocks added up in cell
    /// order by the rest samples' [`AssemblyPlan`] (deterministic for any number of threads;
    /// the GPU kernel computes the same blocks).
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        self.column_major(); // before the cells are forked
        let axes = self.axes_at(x);
        // Every entry is overwritten: the buffer is kept from one evaluation to the next.
        let mut blocks = std::mem::take(&mut self.blocks);
        blocks.resize(self.cells(), LocalNormalEquations::default());
        self.per_cell(&mut blocks, |first, out| {
            self.fill_blocks(&axes, first, out)
        });
        let normal = self.rest.assembly.assemble(&blocks);
        self.blocks = blocks;
        self.axes = axes;
        normal
    }
}
