//! Host side of the `gridwarp_naa_cell` kernel (`shaders/gridwarp_naa.wgsl`): the
//! non-axis-aligned energy (seed 000 §8) and its Gauss–Newton normal equations, one cell per
//! invocation.
//!
//! Inputs are plain f32 arrays, one buffer each, in the order of the conformance manifest
//! (`gridwarp_naa.*`, the binding layout of every reparam-gpu kernel): the rest samples
//! (α, β, σ, o_s, o_t) of every cell (precomputed by the caller, as the reference's
//! `rest_samples` does), the rest cell widths h_i and heights k_j, the current vertices P_ab and
//! the unknown index of each of their coordinates, and the deformed frame's partial derivative
//! fields D_s, D_t ([H, W, 3]: x, y, z per texel). The output is one [`NaaCellContribution`]
//! per cell, in cell order `i·(N − 1) + j`.
//!
//! **Reduction.** As `gridwarp_aa_cell` ([`super::aa`]): one invocation per cell loops over its
//! K×L samples in a fixed order; the sum over cells is the caller's, on the CPU in f64 and in
//! cell order, so the assembled normal equations are deterministic.

use bytemuck::{Pod, Zeroable};

use super::aa::RestSample;
use super::FIELD_WGSL;
use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and [`FIELD_WGSL`]).
pub const WGSL: &str = include_str!("../../shaders/gridwarp_naa.wgsl");

/// The per-sample residuals entry point (after `dispatch.wgsl`, [`FIELD_WGSL`] and [`WGSL`]).
pub const RESIDUALS_WGSL: &str = include_str!("../../shaders/gridwarp_naa_residuals.wgsl");

/// Slots per cell: the (s, t) coordinates of its 4 corners.
pub const SLOTS: usize = 8;

/// One cell's share (336 bytes; WGSL `NaaCellContribution`): Σ r², the 8×8 block of JᵀJ
/// (row-major) and the 8 entries of Jᵀr over the slots (P00.s, P00.t, P10.s, P10.t, P01.s,
/// P01.t, P11.s, P11.t), and the slots' indices in the unknown vector (−1 for a fixed
/// coordinate: drop its row and column).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct NaaCellContribution {
    pub jtj: [f32; 64],
    pub jtr: [f32; 8],
    pub unknowns: [i32; 8],
    pub energy: f32,
    pub _pad: [f32; 3],
}

impl Default for NaaCellContribution {
    fn default() -> Self {
        Zeroable::zeroed()
    }
}

/// A W×H field of 3-vectors at texel centres, row-major, row 0 at t = 0, the three components
/// of a texel together: texel (x, y) component c at `values[(y·W + x)·3 + c]` (the reference's
/// three scalar `Field`s of one `VectorField` in f32, interleaved).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VectorFieldF32 {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

/// Everything `gridwarp_naa_cell` reads. M = `rest_h.len() + 1` vertex columns along s and
/// N = `rest_k.len() + 1` along t.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NaaInput {
    /// K·L samples per cell, cell (i, j) at `samples[(i·(N − 1) + j)·per_cell ..]`.
    pub samples: Vec<RestSample>,
    /// K·L.
    pub per_cell: u32,
    /// Rest cell widths h_i (M − 1 values).
    pub rest_h: Vec<f32>,
    /// Rest cell heights k_j (N − 1 values).
    pub rest_k: Vec<f32>,
    /// The current vertices P_ab = (s, t), vertex (a, b) at a·N + b (M·N values).
    pub vertices: Vec<[f32; 2]>,
    /// The unknown index of each vertex's s and t coordinate (−1: fixed), laid out as
    /// `vertices`.
    pub vertex_index: Vec<[i32; 2]>,
    /// D_s = ∂D/∂s of the deformed frame.
    pub d_s: VectorFieldF32,
    /// D_t = ∂D/∂t.
    pub d_t: VectorFieldF32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct NaaParams {
    cells: u32,
    columns: u32,
    rows: u32,
    per_cell: u32,
    ds_width: u32,
    ds_height: u32,
    dt_width: u32,
    dt_height: u32,
}

impl NaaInput {
    /// (M, N): vertex columns along s and rows along t.
    pub fn lines(&self) -> (usize, usize) {
        (self.rest_h.len() + 1, self.rest_k.len() + 1)
    }

    /// Number of cells (M − 1)(N − 1).
    pub fn cells(&self) -> usize {
        self.rest_h.len() * self.rest_k.len()
    }

    /// [`GpuError::Input`] unless the lengths agree and the fields are non-empty.
    pub fn check(&self) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("gridwarp_naa_cell: {what}")));
        let (m, n) = self.lines();
        if m < 2 || n < 2 {
            return bad(format!(
                "{} rest widths and {} rest heights, need at least 1 each",
                m - 1,
                n - 1
            ));
        }
        if self.per_cell == 0 {
            return bad("per_cell is 0".into());
        }
        if self.vertices.len() != m * n || self.vertex_index.len() != m * n {
            return bad(format!(
                "{} vertices and {} vertex indices for {m}×{n} vertices",
                self.vertices.len(),
                self.vertex_index.len()
            ));
        }
        let expected = self.cells() * self.per_cell as usize;
        if self.samples.len() != expected {
            return bad(format!(
                "{} samples, expected {expected} ({} cells × {})",
                self.samples.len(),
                self.cells(),
                self.per_cell
            ));
        }
        for (name, f) in [("d_s", &self.d_s), ("d_t", &self.d_t)] {
            let texels = f.width as usize * f.height as usize;
            if f.width == 0 || f.height == 0 || f.values.len() != 3 * texels {
                return bad(format!(
                    "field {name} is {}×{} with {} values (3 per texel)",
                    f.width,
                    f.height,
                    f.values.len()
                ));
            }
        }
        Ok(())
    }

    fn params(&self) -> Result<NaaParams, GpuError> {
        let cells = self.cells();
        let count =
            u32::try_from(cells).map_err(|_| GpuError::TooLarge(format!("{cells} grid cells")))?;
        Ok(NaaParams {
            cells: count,
            columns: self.rest_h.len() as u32,
            rows: self.rest_k.len() as u32,
            per_cell: self.per_cell,
            ds_width: self.d_s.width,
            ds_height: self.d_s.height,
            dt_width: self.d_t.width,
            dt_height: self.d_t.height,
        })
    }
}

/// The compiled `gridwarp_naa_cell` pipeline, to run many evaluations without recompiling.
#[derive(Clone, Debug)]
pub struct NaaKernel {
    kernel: ComputeKernel,
}

impl NaaKernel {
    /// Compile the kernel (`dispatch.wgsl` + `gridwarp_field.wgsl` + `gridwarp_naa.wgsl`).
    pub fn new(gpu: &Gpu) -> Result<NaaKernel, GpuError> {
        let source = [DISPATCH_WGSL, FIELD_WGSL, WGSL].join("\n");
        Ok(NaaKernel {
            kernel: gpu.compute_kernel("gridwarp_naa_cell", &source, "gridwarp_naa_cell")?,
        })
    }

    /// One evaluation: upload `input`, run one invocation per cell, read the cells back (in
    /// cell order `i·(N − 1) + j`).
    pub fn run(&self, gpu: &Gpu, input: &NaaInput) -> Result<Vec<NaaCellContribution>, GpuError> {
        self.bind(gpu, input)?.run(gpu, &input.vertices)
    }

    /// Upload everything of `input` that stays fixed during a solve (rest samples, rest sizes,
    /// unknown map, fields) once; [`NaaBinding::run`] then only writes the vertices.
    pub fn bind(&self, gpu: &Gpu, input: &NaaInput) -> Result<NaaBinding, GpuError> {
        input.check()?;
        let params = input.params()?;
        let label = "gridwarp_naa_cell";
        Ok(NaaBinding {
            kernel: self.kernel.clone(),
            count: params.cells,
            vertex_count: input.vertices.len(),
            params: gpu.upload_uniform(label, &params),
            samples: gpu.upload_storage(label, &input.samples)?,
            rest_h: gpu.upload_storage(label, &input.rest_h)?,
            rest_k: gpu.upload_storage(label, &input.rest_k)?,
            vertices: gpu.upload_storage(label, &input.vertices)?,
            vertex_index: gpu.upload_storage(label, &input.vertex_index)?,
            d_s: gpu.upload_storage(label, &input.d_s.values)?,
            d_t: gpu.upload_storage(label, &input.d_t.values)?,
            out: gpu.output_storage::<NaaCellContribution>(label, params.cells as usize)?,
        })
    }
}

/// The `gridwarp_naa_cell` kernel with one solve's fixed data resident on the device.
#[derive(Debug)]
pub struct NaaBinding {
    kernel: ComputeKernel,
    count: u32,
    vertex_count: usize,
    params: wgpu::Buffer,
    samples: wgpu::Buffer,
    rest_h: wgpu::Buffer,
    rest_k: wgpu::Buffer,
    vertices: wgpu::Buffer,
    vertex_index: wgpu::Buffer,
    d_s: wgpu::Buffer,
    d_t: wgpu::Buffer,
    out: wgpu::Buffer,
}

impl NaaBinding {
    /// The nine buffers at bindings 0 … 8, with `out` as the output.
    fn buffers<'a>(&'a self, out: &'a wgpu::Buffer) -> [&'a wgpu::Buffer; 9] {
        [
            &self.params,
            &self.samples,
            &self.rest_h,
            &self.rest_k,
            &self.vertices,
            &self.vertex_index,
            &self.d_s,
            &self.d_t,
            out,
        ]
    }

    /// One evaluation at `vertices` (M·N values, P_ab at a·N + b): write them, run one
    /// invocation per cell, read the cells back in cell order.
    pub fn run(
        &self,
        gpu: &Gpu,
        vertices: &[[f32; 2]],
    ) -> Result<Vec<NaaCellContribution>, GpuError> {
        if vertices.len() != self.vertex_count {
            return Err(GpuError::Input(format!(
                "gridwarp_naa_cell: {} vertices for a kernel bound to {}",
                vertices.len(),
                self.vertex_count
            )));
        }
        gpu.write_storage(&self.vertices, vertices);
        gpu.dispatch(&self.kernel, &self.buffers(&self.out), self.count)?;
        gpu.read_back(&self.out, self.count as usize)
    }
}

/// The residuals r^s, r^t of every sample of `input` at its vertices, in sample order (cells in
/// the order `i·(N − 1) + j`, K·L samples each; (0, 0) for a sample of weight 0): the
/// `gridwarp_naa_residuals` entry point, the same per-sample functions as `gridwarp_naa_cell`.
pub fn naa_residuals(gpu: &Gpu, input: &NaaInput) -> Result<Vec<[f32; 2]>, GpuError> {
    input.check()?;
    let source = [DISPATCH_WGSL, FIELD_WGSL, WGSL, RESIDUALS_WGSL].join("\n");
    let label = "gridwarp_naa_residuals";
    let kernel = gpu.compute_kernel(label, &source, label)?;
    let binding = NaaKernel { kernel }.bind(gpu, input)?;
    let samples = input.samples.len();
    let count = u32::try_from(samples)
        .map_err(|_| GpuError::TooLarge(format!("{samples} gridwarp samples")))?;
    let out = gpu.output_storage::<[f32; 2]>(label, samples)?;
    gpu.dispatch(&binding.kernel, &binding.buffers(&out), count)?;
    gpu.read_back(&out, samples)
}

/// One evaluation of the per-cell energy and normal-equation blocks (compiles the kernel; use
/// [`NaaKernel`] to evaluate repeatedly).
pub fn naa_cells(gpu: &Gpu, input: &NaaInput) -> Result<Vec<NaaCellContribution>, GpuError> {
    NaaKernel::new(gpu)?.run(gpu, input)
}
