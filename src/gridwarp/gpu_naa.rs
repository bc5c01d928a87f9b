//! Bridge between the f64 non-axis-aligned energy and the f32 `gridwarp_naa_cell` kernel of
//! `reparam-gpu`: the paper's hybrid solver for the `nonaa-` rows of Table 1 (seed §7, §8), the
//! objective and its Gauss–Newton normal equations on the GPU, Levenberg–Marquardt on the CPU.
//!
//! [`GpuNaaEnergy`] is built from the same inputs as [`NaaEnergy`] and
//! [`super::plain::PlainNaaEnergy`] and implements the same [`Residuals`] trait, so
//! [`super::solve::minimize_naa_frame`] runs unchanged on either. Per evaluation: the current
//! vertices are checked for folds in f64 (a folded grid has F = +∞ without a dispatch, as on the
//! CPU), rounded to f32 and uploaded; the kernel returns one energy + 8×8 JᵀJ block + 8-vector
//! Jᵀr per cell, and this module sums them in f64 in cell order (deterministic).

use std::time::Instant;

use reparam_gpu::gridwarp::{
    NaaBinding, NaaCellContribution, NaaInput, NaaKernel, VectorFieldF32, NO_UNKNOWN,
};
use reparam_gpu::Gpu;

use super::energy::RestFields;
#[allow(unused_imports)]
use super::energy_naa::NaaEnergy;
use super::energy_naa::{DeformedJacobian, VectorField, VertexGrid};
use super::gpu::rest_samples;
use super::grid::Grid;
use super::solve::{minimize_naa_frame, solve_frames, NaaFrameSolution, SolveOptions};
use crate::error::{Error, Result};
use crate::lm::{LocalNormalEquations, NormalEquations, Residuals};

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

/// A vector field rounded to f32 and interleaved per texel (`d_s`, `d_t` of the kernel).
///
/// Errors: its three components do not share one size (the kernel reads one W × H per field).
pub fn vector_field_to_gpu(name: &str, f: &VectorField) -> Result<VectorFieldF32> {
    let (width, height) = (f.x.width, f.x.height);
    for (c, component) in [("y", &f.y), ("z", &f.z)] {
        if (component.width, component.height) != (width, height) {
            return Err(Error::InvalidArgument(format!(
                "gridwarp naa GPU objective: {name}.{c} is {}×{} texels where {name}.x is \
                 {width}×{height}; the kernel needs one size per vector field",
                component.width, component.height
            )));
        }
    }
    let values = (0..width * height)
        .flat_map(|n| [&f.x, &f.y, &f.z].map(|c| c.values[n] as f32))
        .collect();
    Ok(VectorFieldF32 {
        width: width as u32,
        height: height as u32,
        values,
    })
}

/// The unknown index of each vertex's (s, t) coordinates, vertex (a, b) at a·N + b
/// ([`VertexGrid::unknown_index`]; −1 for a fixed coordinate).
pub fn vertex_index(g: &VertexGrid) -> Vec<[i32; 2]> {
    (0..g.m)
        .flat_map(|a| (0..g.n).map(move |b| (a, b)))
        .map(|(a, b)| {
            g.unknown_index(a, b)
                .map(|u| u.map_or(NO_UNKNOWN, |u| u as i32))
        })
        .collect()
}

/// The vertices of `g` rounded to f32, vertex (a, b) at a·N + b.
pub fn vertices_f32(g: &VertexGrid) -> Vec<[f32; 2]> {
    g.points.iter().map(|p| p.map(|v| v as f32)).collect()
}

/// The kernel input for `rest_grid`, `deformed` and K × L samples, at the vertices `at`
/// (whose border mode, fixed or sliding, numbers the unknowns).
///
/// Errors: `at` is not the rest grid's shape; a vector field's components differ in size.
pub fn naa_input(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    (k, l): (usize, usize),
    at: &VertexGrid,
) -> Result<NaaInput> {
    let (m, n) = (rest_grid.s.len(), rest_grid.t.len());
    if (at.m, at.n, at.points.len()) != (m, n, m * n) {
        return Err(Error::InvalidArgument(format!(
            "gridwarp naa GPU objective: a {}×{} vertex grid for {m}×{n} rest lines",
            at.m, at.n
        )));
    }
    let widths = |v: &[f64]| {
        v.windows(2)
            .map(|w| (w[1] - w[0]) as f32)
            .collect::<Vec<f32>>()
    };
    Ok(NaaInput {
        samples: rest_samples(rest, rest_grid, k, l),
        per_cell: (k.max(1) * l.max(1)) as u32,
        rest_h: widths(&rest_grid.s),
        rest_k: widths(&rest_grid.t),
        vertices: vertices_f32(at),
        vertex_index: vertex_index(at),
        d_s: vector_field_to_gpu("D_s", &deformed.d_s)?,
        d_t: vector_field_to_gpu("D_t", &deformed.d_t)?,
    })
}

/// A cell's contribution widened to f64: its slots (−1: a fixed coordinate) and its 8×8 block.
pub fn cell_block(c: &NaaCellContribution) -> ([Option<usize>; 8], LocalNormalEquations<8>) {
    let slots = c.unknowns.map(|u| usize::try_from(u).ok());
    let local = LocalNormalEquations {
        energy: c.energy as f64,
        jtj: std::array::from_fn(|u| std::array::from_fn(|v| c.jtj[u * 8 + v] as f64)),
        jtr: c.jtr.map(|v| v as f64),
    };
    (slots, local)
}

/// Sum the cells' contributions in f64, in cell order: F, and JᵀJ (n×n), Jᵀr (n) with each
/// cell's 8×8 block scattered to its unknowns (fixed coordinates dropped), as the CPU energy does.
pub fn assemble(cells: &[NaaCellContribution], n: usize) -> NormalEquations {
    let blocks: Vec<_> = cells.iter().map(cell_block).collect();
    NormalEquations::assemble(n, blocks.iter().map(|(s, b)| (s, b)))
}

/// The non-axis-aligned energy of one frame evaluated by the `gridwarp_naa_cell` kernel in f32
/// (Gauss–Newton's JᵀJ, the paper's model): the GPU twin of [`NaaEnergy`], built from the same
/// (RestFields, rest Grid, DeformedJacobian, K, L) and the rest vertices' border mode.
///
/// The [`Residuals`] methods panic if the GPU fails mid-solve (the trait has no error path);
/// [`GpuNaaEnergy::try_normal_equations`] returns the error instead.
pub struct GpuNaaEnergy {
    gpu: Gpu,
    /// The kernel with the rest samples and fields resident on the device (uploaded once).
    binding: NaaBinding,
    rest_vertices: VertexGrid,
    input: NaaInput,
    /// Kernel evaluations so far (energy and normal equations alike).
    pub evaluations: usize,
    /// Wall time spent in evaluations (upload, kernel, readback, f64 assembly), seconds.
    pub seconds: f64,
}

impl GpuNaaEnergy {
    /// Precompute the rest samples (as [`NaaEnergy::new`] does, then rounded to f32), round the
    /// deformed fields to f32, compile the kernel and upload the fixed data; the border
    /// vertices slide along their edges if `sliding_border`.
    pub fn new(
        gpu: &Gpu,
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &DeformedJacobian,
        kl: (usize, usize),
        sliding_border: bool,
    ) -> Result<Self> {
        let kernel = NaaKernel::new(gpu).map_err(gpu_error)?;
        Self::with_kernel(gpu, &kernel, rest, rest_grid, deformed, kl, sliding_border)
    }

    /// [`GpuNaaEnergy::new`] with an already compiled kernel (compile once per sequence).
    pub fn with_kernel(
        gpu: &Gpu,
        kernel: &NaaKernel,
        rest: &RestFields,
        rest_grid: &Grid,
        deformed: &DeformedJacobian,
        kl: (usize, usize),
        sliding_border: bool,
    ) -> Result<Self> {
        let rest_vertices = VertexGrid::from_grid(rest_grid).with_sliding_border(sliding_border);
        let input = naa_input(rest, rest_grid, deformed, kl, &rest_vertices)?;
        Ok(GpuNaaEnergy {
            gpu: gpu.clone(),
            binding: kernel.bind(gpu, &input).map_err(gpu_error)?,
            rest_vertices,
            input,
            evaluations: 0,
            seconds: 0.0,
        })
    }

    /// The rest vertices (their border mode numbers the unknowns).
    pub fn rest_vertices(&self) -> &VertexGrid {
        &self.rest_vertices
    }

    /// The kernel's input (current vertices as last evaluated).
    pub fn input(&self) -> &NaaInput {
        &self.input
    }

    /// The per-cell contributions at x (vertices rounded to f32), whether or not the grid folds.
    pub fn cells(&mut self, x: &[f64]) -> Result<Vec<NaaCellContribution>> {
        let start = Instant::now();
        self.input.vertices = vertices_f32(&self.rest_vertices.with_unknowns(x));
        let cells = self
            .binding
            .run(&self.gpu, &self.input.vertices)
            .map_err(gpu_error)?;
        self.evaluations += 1;
        self.seconds += start.elapsed().as_secs_f64();
        Ok(cells)
    }

    /// Whether the vertices at x fold a cell ([`VertexGrid::is_valid`], in f64).
    fn folds(&self, x: &[f64]) -> bool {
        !self.rest_vertices.with_unknowns(x).is_valid()
    }

    /// F, JᵀJ and Jᵀr at x (F = +∞ and zeros at a folded grid), or the GPU's error.
    pub fn try_normal_equations(&mut self, x: &[f64]) -> Result<NormalEquations> {
        let n = self.dim();
        if self.folds(x) {
            return Ok(NormalEquations {
                energy: f64::INFINITY,
                ..NormalEquations::zeros(n)
            });
        }
        let cells = self.cells(x)?;
        let start = Instant::now();
        let ne = assemble(&cells, n);
        self.seconds += start.elapsed().as_secs_f64();
        Ok(ne)
    }
}

impl Residuals for GpuNaaEnergy {
    fn dim(&self) -> usize {
        self.rest_vertices.unknowns()
    }

    /// F(x) from the same kernel (its blocks are discarded), summed over cells in f64; +∞ if a
    /// cell folds.
    fn energy(&mut self, x: &[f64]) -> f64 {
        if self.folds(x) {
            return f64::INFINITY;
        }
        match self.cells(x) {
            Ok(cells) => cells.iter().map(|c| c.energy as f64).sum(),
            Err(e) => panic!("GpuNaaEnergy::energy: {e}"),
        }
    }

    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        match self.try_normal_equations(x) {
            Ok(ne) => ne,
            Err(e) => panic!("GpuNaaEnergy::normal_equations: {e}"),
        }
    }
}

/// [`super::solve_naa_frame`] with the objective on the GPU ([`GpuNaaEnergy`], the kernel
/// compiled once by the caller: `NaaKernel::new(gpu)`): same samples per cell, bounds, warm
/// start and LM options, Gauss–Newton's model whatever `options.naa_model` says (the kernel
/// computes JᵀJ; the paper's). The border mode is `previous`'s.
#[allow(clippy::too_many_arguments)]
pub fn solve_naa_frame_gpu(
    gpu: &Gpu,
    kernel: &NaaKernel,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedJacobian,
    previous: &VertexGrid,
    first: &VertexGrid,
    frame: (usize, usize),
    options: &SolveOptions,
) -> Result<NaaFrameSolution> {
    let start = Instant::now();
    let kl = options.samples_per_cell();
    let sliding = previous.sliding_border;
    let energy = GpuNaaEnergy::with_kernel(gpu, kernel, rest, rest_grid, deformed, kl, sliding)?;
    let rest_vertices = energy.rest_vertices().clone();
    minimize_naa_frame(
        energy,
        &rest_vertices,
        previous,
        first,
        frame,
        options,
        start,
    )
}

/// [`super::solve_naa_sequence`] with the objective on the GPU: the kernel compiled once, every
/// frame warm-started from the previous solution (frame 0 from `start`).
pub fn solve_naa_sequence_gpu(
    gpu: &Gpu,
    rest: &RestFields,
    rest_grid: &Grid,
    start: &VertexGrid,
    frames: &[DeformedJacobian],
    options: &SolveOptions,
) -> Result<Vec<NaaFrameSolution>> {
    let kernel = NaaKernel::new(gpu).map_err(gpu_error)?;
    solve_frames(
        start,
        frames.len(),
        |s: &NaaFrameSolution| &s.vertices,
        |j, previous, first| {
            let frame = (j, frames.len());
            solve_naa_frame_gpu(
                gpu, &kernel, rest, rest_grid, &frames[j], previous, first, frame, options,
            )
        },
    )
}
