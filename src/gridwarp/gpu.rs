//! Bridge between the f64 gridwarp reference and the f32 `gridwarp_aa_cell` kernel of
//! `reparam-gpu`: the paper's hybrid solver (seed §7), the objective and its normal equations on
//! the GPU, Levenberg–Marquardt on the CPU.
//!
//! [`GpuAaEnergy`] is built from the same inputs as [`AaEnergy`] and implements the same
//! [`Residuals`] trait, so [`crate::lm::minimize`] runs unchanged on either. Per evaluation:
//! the current lines are rounded to f32 and uploaded, the kernel returns one
//! energy + 4×4 JᵀJ block + 4-vector Jᵀr per cell, and this module sums them in f64 in cell
//! order (deterministic; the kernel does no cross-cell reduction).

use std::time::Instant;

use reparam_gpu::gridwarp::{
    AaBinding, AaInput, AaKernel, CellContribution, FieldF32, RestSample, NO_UNKNOWN,
};
use reparam_gpu::Gpu;

#[allow(unused_imports)]
use super::energy::AaEnergy;
use super::energy::{DeformedFields, RestFields};
use super::field::Field;
use super::grid::Grid;
use super::solve::{minimize_frame, solve_frames, FrameSolution, SolveOptions};
use crate::error::{Error, Result};
use crate::lm::{LocalNormalEquations, NormalEquations, Residuals};

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

/// A field rounded to f32.
pub fn field_to_gpu(f: &Field) -> FieldF32 {
    FieldF32 {
        width: f.width as u32,
        height: f.height as u32,
        values: f.values.iter().map(|&v| v as f32).collect(),
    }
}

/// The rest-sample data of every cell, computed in f64 exactly as [`AaEnergy::new`] does (same
/// formulas, same order: cell column i, row j, sample a, b) and rounded to f32.
pub fn rest_samples(rest: &RestFields, rest_grid: &Grid, k: usize, l: usize) -> Vec<RestSample> {
    super::energy::rest_samples(rest, rest_grid, k, l)
        .iter()
        .map(|p| RestSample {
            alpha: p.alpha as f32,
            beta: p.beta as f32,
            sigma: p.sigma as f32,
            o_s: p.o_s as f32,
            o_t: p.o_t as f32,
        })
        .collect()
}

/// The kernel input for `rest_grid` and `deformed`, with the current lines set to the rest
/// grid's (see [`set_lines`]).
pub fn aa_input(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
    k: usize,
    l: usize,
) -> AaInput {
    let (m, n) = (rest_grid.s.len(), rest_grid.t.len());
    let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
    let widths = |v: &[f64]| {
        v.windows(2)
            .map(|w| (w[1] - w[0]) as f32)
            .collect::<Vec<f32>>()
    };
    // The reference's s_index / t_index: interior lines are unknowns s₁…s_{M−2}, t₁…t_{N−2}.
    let s_index = (0..m)
        .map(|i| {
            if i > 0 && i < m - 1 {
                (i - 1) as i32
            } else {
                NO_UNKNOWN
            }
        })
        .collect();
    let t_index = (0..n)
        .map(|j| {
            if j > 0 && j < n - 1 {
                (m - 2 + j - 1) as i32
            } else {
                NO_UNKNOWN
            }
        })
        .collect();
    AaInput {
        samples: rest_samples(rest, rest_grid, k, l),
        per_cell: (k.max(1) * l.max(1)) as u32,
        rest_h: widths(&rest_grid.s),
        rest_k: widths(&rest_grid.t),
        s: f32s(&rest_grid.s),
        t: f32s(&rest_grid.t),
        s_index,
        t_index,
        d_s: field_to_gpu(&deformed.d_s),
        d_t: field_to_gpu(&deformed.d_t),
    }
}

/// Set the current lines of `input` to `grid`'s, rounded to f32.
pub fn set_lines(input: &mut AaInput, grid: &Grid) {
    input.s = grid.s.iter().map(|&v| v as f32).collect();
    input.t = grid.t.iter().map(|&v| v as f32).collect();
}

/// A cell's contribution widened to f64: its slots (−1: a fixed line) and its 4×4 block, the
/// [`LocalNormalEquations`] that [`AaEnergy`] computes for the same cell.
pub fn cell_block(c: &CellContribution) -> ([Option<usize>; 4], LocalNormalEquations<4>) {
    let slots = c.unknowns.map(|u| usize::try_from(u).ok());
    let local = LocalNormalEquations {
        energy: c.energy as f64,
        jtj: std::array::from_fn(|u| std::array::from_fn(|v| c.jtj[u * 4 + v] as f64)),
        jtr: c.jtr.map(|v| v as f64),
    };
    (slots, local)
}

/// Sum the cells' contributions in f64, in cell order: F, and JᵀJ (n×n), Jᵀr (n) with each
/// cell's 4×4 block scattered to its unknowns (fixed lines dropped), as the CPU energy does.
pub fn assemble(cells: &[CellContribution], n: usize) -> NormalEquations {
    let blocks: Vec<_> = cells.iter().map(cell_block).collect();
    NormalEquations::assemble(n, blocks.iter().map(|(s, b)| (s, b)))
}

/// The axis-aligned energy of one frame evaluated by the `gridwarp_aa_cell` kernel in f32: the
/// GPU twin of [`AaEnergy`], built from the same (RestFields, rest Grid, DeformedFields, K, L).
///
/// The [`Residuals`] methods panic if the GPU fails mid-solve (the trait has no error path);
/// [`GpuAaEnergy::try_normal_equations`] returns the error instead.
pub struct GpuAaEnergy<'a> {
    gpu: Gpu,
    /// The kernel with the rest samples and fields resident on the device (uploaded once).
    binding: AaBinding,
    rest_grid: &'a Grid,
    input: AaInput,
    /// Kernel evaluations so far (energy and normal equations alike).
    pub evaluations: usize,
    /// Wall time spent in evaluations (upload, kernel, readback, f64 assembly), seconds.
    pub seconds: f64,
}

impl<'a> GpuAaEnergy<'a> {
    /// Precompute the rest samples (as [`AaEnergy::new`] does, then rounded to f32), round the
    /// deformed fields to f32, compile the kernel and upload the fixed data.
    pub fn new(
        gpu: &Gpu,
        rest: &RestFields,
        rest_grid: &'a Grid,
        deformed: &DeformedFields,
        k: usize,
        l: usize,
    ) -> Result<Self> {
        let kernel = AaKernel::new(gpu).map_err(gpu_error)?;
        Self::with_kernel(gpu, &kernel, rest, rest_grid, deformed, k, l)
    }

    /// [`GpuAaEnergy::new`] with an already compiled kernel (compile once per sequence).
    pub fn with_kernel(
        gpu: &Gpu,
        kernel: &AaKernel,
        rest: &RestFields,
        rest_grid: &'a Grid,
        deformed: &DeformedFields,
        k: usize,
        l: usize,
    ) -> Result<Self> {
        let input = aa_input(rest, rest_grid, deformed, k, l);
        Ok(GpuAaEnergy {
            gpu: gpu.clone(),
            binding: kernel.bind(gpu, &input).map_err(gpu_error)?,
            rest_grid,
            input,
            evaluations: 0,
            seconds: 0.0,
        })
    }

    /// The kernel's input (current lines as last evaluated).
    pub fn input(&self) -> &AaInput {
        &self.input
    }

    /// The per-cell contributions at x (lines rounded to f32).
    pub fn cells(&mut self, x: &[f64]) -> Result<Vec<CellContribution>> {
        let start = Instant::now();
        set_lines(&mut self.input, &self.rest_grid.with_unknowns(x));
        let cells = self
            .binding
            .run(&self.gpu, &self.input.s, &self.input.t)
            .map_err(gpu_error)?;
        self.evaluations += 1;
        self.seconds += start.elapsed().as_secs_f64();
        Ok(cells)
    }

    /// F, JᵀJ and Jᵀr at x, or the GPU's error.
    pub fn try_normal_equations(&mut self, x: &[f64]) -> Result<NormalEquations> {
        let n = self.dim();
        let cells = self.cells(x)?;
        let start = Instant::now();
        let ne = assemble(&cells, n);
        self.seconds += start.elapsed().as_secs_f64();
        Ok(ne)
    }
}

impl Residuals for GpuAaEnergy<'_> {
    fn dim(&self) -> usize {
        self.rest_grid.unknowns()
    }

    /// F(x) from the same kernel (its blocks are discarded), summed over cells in f64.
    fn energy(&mut self, x: &[f64]) -> f64 {
        match self.cells(x) {
            Ok(cells) => cells.iter().map(|c| c.energy as f64).sum(),
            Err(e) => panic!("GpuAaEnergy::energy: {e}"),
        }
    }

    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        match self.try_normal_equations(x) {
            Ok(ne) => ne,
            Err(e) => panic!("GpuAaEnergy::normal_equations: {e}"),
        }
    }
}

/// [`super::solve_frame`] with the objective on the GPU ([`GpuAaEnergy`], the kernel compiled
/// once by the caller: `AaKernel::new(gpu)`): same samples per cell, bounds, warm start and LM
/// options.
#[allow(clippy::too_many_arguments)]
pub fn solve_frame_gpu(
    gpu: &Gpu,
    kernel: &AaKernel,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
    previous: &Grid,
    first: &Grid,
    (frame, frames): (usize, usize),
    options: &SolveOptions,
) -> Result<FrameSolution> {
    let start = Instant::now();
    let (k, l) = options.samples_per_cell();
    let energy = GpuAaEnergy::with_kernel(gpu, kernel, rest, rest_grid, deformed, k, l)?;
    minimize_frame(
        energy,
        rest_grid,
        previous,
        first,
        (frame, frames),
        options,
        start,
    )
}

/// [`super::solve_sequence`] with the objective on the GPU: the kernel compiled once, every
/// frame warm-started from the previous solution.
pub fn solve_sequence_gpu(
    gpu: &Gpu,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<Vec<FrameSolution>> {
    let kernel = AaKernel::new(gpu).map_err(gpu_error)?;
    solve_frames(
        rest_grid,
        frames.len(),
        |s: &FrameSolution| &s.grid,
        |j, previous, first| {
            let frame = (j, frames.len());
            let deformed = &frames[j];
            solve_frame_gpu(
                gpu, &kernel, rest, rest_grid, deformed, previous, first, frame, options,
            )
        },
    )
}
