//! Host side of the `gridwarp_aa_cell` kernel (`shaders/gridwarp_aa.wgsl`).
//!
//! Inputs are plain f32 arrays: the rest-sample data of every cell (precomputed by the caller,
//! as the reference's `AaEnergy::new` does), the rest cell widths, the current grid lines, the
//! map from grid lines to unknowns, and the ‖D_s‖, ‖D_t‖ fields. The output is one
//! [`CellContribution`] per cell, in cell order `i·(N − 1) + j`.
//!
//! **Reduction.** The kernel runs one invocation per cell and loops over the cell's K×L samples
//! in a fixed order (no workgroup reduction: simpler, and its f32 sums do not depend on thread
//! scheduling). The sum over cells is left to the caller, who does it on the CPU in f64 and in
//! cell order, so the assembled normal equations are deterministic and the cross-cell sum adds
//! no f32 rounding.

use bytemuck::{Pod, Zeroable};

use super::FIELD_WGSL;
use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and [`FIELD_WGSL`]).
pub const WGSL: &str = include_str!("../../shaders/gridwarp_aa.wgsl");

/// The per-sample residuals entry point (after `dispatch.wgsl`, [`FIELD_WGSL`] and [`WGSL`]).
pub const RESIDUALS_WGSL: &str = include_str!("../../shaders/gridwarp_aa_residuals.wgsl");

/// `unknown_index` entry of a fixed grid line (the boundary lines 0 and 1).
pub const NO_UNKNOWN: i32 = -1;

/// What one sample contributes that does not depend on the unknowns (20 bytes; WGSL
/// `RestSample`): its fractions (α, β) in the cell, σ = √w·R at the rest point, and ‖O_s‖,
/// ‖O_t‖ at the rest point.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RestSample {
    pub alpha: f32,
    pub beta: f32,
    pub sigma: f32,
    pub o_s: f32,
    pub o_t: f32,
}

/// One cell's share (112 bytes; WGSL `CellContribution`): Σ r², the 4×4 block of JᵀJ
/// (row-major) and the 4 entries of Jᵀr over the slots (s_i, s_{i+1}, t_j, t_{j+1}), and the
/// slots' indices in the unknown vector ([`NO_UNKNOWN`] for a fixed line: drop its row and
/// column).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CellContribution {
    pub jtj: [f32; 16],
    pub jtr: [f32; 4],
    pub unknowns: [i32; 4],
    pub energy: f32,
    pub _pad: [f32; 3],
}

/// A W×H field at texel centres, row-major, row 0 at t = 0 (the reference's `Field` in f32).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FieldF32 {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

/// Everything `gridwarp_aa_cell` reads. M = `s.len()` and N = `t.len()` grid lines.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AaInput {
    /// K·L samples per cell, cell (i, j) at `samples[(i·(N − 1) + j)·per_cell ..]`.
    pub samples: Vec<RestSample>,
    /// K·L.
    pub per_cell: u32,
    /// Rest cell widths h_i = ŝ_{i+1} − ŝ_i (M − 1 values).
    pub rest_h: Vec<f32>,
    /// Rest cell heights k_j = t̂_{j+1} − t̂_j (N − 1 values).
    pub rest_k: Vec<f32>,
    /// Current s lines (M values, including 0 and 1).
    pub s: Vec<f32>,
    /// Current t lines (N values).
    pub t: Vec<f32>,
    /// Unknown index of each s line (M values), [`NO_UNKNOWN`] for fixed lines.
    pub s_index: Vec<i32>,
    /// Unknown index of each t line (N values).
    pub t_index: Vec<i32>,
    pub d_s: FieldF32,
    pub d_t: FieldF32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct AaParams {
    cells: u32,
    columns: u32,
    rows: u32,
    per_cell: u32,
    ds_width: u32,
    ds_height: u32,
    dt_width: u32,
    dt_height: u32,
    dt_offset: u32,
    _pad: [u32; 3],
}

impl AaInput {
    /// Number of cells (M − 1)(N − 1).
    pub fn cells(&self) -> usize {
        self.s.len().saturating_sub(1) * self.t.len().saturating_sub(1)
    }

    /// [`GpuError::Input`] unless the lengths agree and the fields are non-empty.
    pub fn check(&self) -> Result<(), GpuError> {
        let (m, n) = (self.s.len(), self.t.len());
        let bad = |what: String| Err(GpuError::Input(format!("gridwarp_aa_cell: {what}")));
        if m < 2 || n < 2 {
            return bad(format!("{m} s lines and {n} t lines, need at least 2 each"));
        }
        if self.per_cell == 0 {
            return bad("per_cell is 0".into());
        }
        if self.rest_h.len() != m - 1 || self.rest_k.len() != n - 1 {
            return bad(format!(
                "{} rest widths and {} rest heights for {m}×{n} lines",
                self.rest_h.len(),
                self.rest_k.len()
            ));
        }
        if self.s_index.len() != m || self.t_index.len() != n {
            return bad(format!(
                "{} s and {} t unknown indices for {m}×{n} lines",
                self.s_index.len(),
                self.t_index.len()
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
            if f.width == 0 || f.height == 0 || f.values.len() != (f.width * f.height) as usize {
                return bad(format!(
                    "field {name} is {}×{} with {} values",
                    f.width,
                    f.height,
                    f.values.len()
                ));
            }
        }
        Ok(())
    }
}

/// The compiled `gridwarp_aa_cell` pipeline, to run many evaluations without recompiling.
#[derive(Clone, Debug)]
pub struct AaKernel {
    kernel: ComputeKernel,
}

impl AaKernel {
    /// Compile the kernel (`dispatch.wgsl` + `gridwarp_field.wgsl` + `gridwarp_aa.wgsl`).
    pub fn new(gpu: &Gpu) -> Result<AaKernel, GpuError> {
        let source = [DISPATCH_WGSL, FIELD_WGSL, WGSL].join("\n");
        Ok(AaKernel {
            kernel: gpu.compute_kernel("gridwarp_aa_cell", &source, "gridwarp_aa_cell")?,
        })
    }

    /// One evaluation: upload `input`, run one invocation per cell, read the cells back (in
    /// cell order `i·(N − 1) + j`).
    pub fn run(&self, gpu: &Gpu, input: &AaInput) -> Result<Vec<CellContribution>, GpuError> {
        self.bind(gpu, input)?.run(gpu, &input.s, &input.t)
    }

    /// Upload everything of `input` that stays fixed during a solve (rest samples, rest
    /// widths, unknown map, fields) once; [`AaBinding::run`] then only writes the lines.
    pub fn bind(&self, gpu: &Gpu, input: &AaInput) -> Result<AaBinding, GpuError> {
        input.check()?;
        let cells = input.cells();
        let count =
            u32::try_from(cells).map_err(|_| GpuError::TooLarge(format!("{cells} grid cells")))?;
        let (m, n) = (input.s.len(), input.t.len());
        let params = AaParams {
            cells: count,
            columns: (m - 1) as u32,
            rows: (n - 1) as u32,
            per_cell: input.per_cell,
            ds_width: input.d_s.width,
            ds_height: input.d_s.height,
            dt_width: input.d_t.width,
            dt_height: input.d_t.height,
            dt_offset: input.d_s.values.len() as u32,
            _pad: [0; 3],
        };
        let geometry: Vec<f32> = [&input.s, &input.t, &input.rest_h, &input.rest_k]
            .into_iter()
            .flatten()
            .copied()
            .collect();
        let index: Vec<i32> = input
            .s_index
            .iter()
            .chain(&input.t_index)
            .copied()
            .collect();
        let fields: Vec<f32> = input
            .d_s
            .values
            .iter()
            .chain(&input.d_t.values)
            .copied()
            .collect();
        let label = "gridwarp_aa_cell";
        Ok(AaBinding {
            kernel: self.kernel.clone(),
            count,
            lines: (m, n),
            params: gpu.upload_uniform(label, &params),
            samples: gpu.upload_storage(label, &input.samples)?,
            geometry: gpu.upload_storage(label, &geometry)?,
            index: gpu.upload_storage(label, &index)?,
            fields: gpu.upload_storage(label, &fields)?,
            out: gpu.output_storage::<CellContribution>(label, cells)?,
        })
    }
}

/// The `gridwarp_aa_cell` kernel with one solve's fixed data resident on the device.
#[derive(Debug)]
pub struct AaBinding {
    kernel: ComputeKernel,
    count: u32,
    /// (M, N): the number of s and t lines.
    lines: (usize, usize),
    params: wgpu::Buffer,
    samples: wgpu::Buffer,
    geometry: wgpu::Buffer,
    index: wgpu::Buffer,
    fields: wgpu::Buffer,
    out: wgpu::Buffer,
}

impl AaBinding {
    /// One evaluation at the lines `s` (M values) and `t` (N values): write them, run one
    /// invocation per cell, read the cells back in cell order.
    pub fn run(&self, gpu: &Gpu, s: &[f32], t: &[f32]) -> Result<Vec<CellContribution>, GpuError> {
        if (s.len(), t.len()) != self.lines {
            return Err(GpuError::Input(format!(
                "gridwarp_aa_cell: {}×{} lines for a kernel bound to {}×{}",
                s.len(),
                t.len(),
                self.lines.0,
                self.lines.1
            )));
        }
        let lines: Vec<f32> = s.iter().chain(t).copied().collect();
        gpu.write_storage(&self.geometry, &lines);
        gpu.dispatch(
            &self.kernel,
            &[
                &self.params,
                &self.samples,
                &self.geometry,
                &self.index,
                &self.fields,
                &self.out,
            ],
            self.count,
        )?;
        gpu.read_back(&self.out, self.count as usize)
    }
}

/// The residuals r^s, r^t of every sample of `input` at its lines, in sample order (cells in
/// the order `i·(N − 1) + j`, K·L samples each; (0, 0) for a sample of weight 0): the
/// `gridwarp_aa_residuals` entry point, the same per-sample functions as `gridwarp_aa_cell`.
pub fn aa_residuals(gpu: &Gpu, input: &AaInput) -> Result<Vec<[f32; 2]>, GpuError> {
    input.check()?;
    let source = [DISPATCH_WGSL, FIELD_WGSL, WGSL, RESIDUALS_WGSL].join("\n");
    let label = "gridwarp_aa_residuals";
    let kernel = gpu.compute_kernel(label, &source, label)?;
    let binding = AaKernel { kernel }.bind(gpu, input)?;
    let samples = input.samples.len();
    let count = u32::try_from(samples)
        .map_err(|_| GpuError::TooLarge(format!("{samples} gridwarp samples")))?;
    let out = gpu.output_storage::<[f32; 2]>(label, samples)?;
    gpu.dispatch(
        &binding.kernel,
        &[
            &binding.params,
            &binding.samples,
            &binding.geometry,
            &binding.index,
            &binding.fields,
            &out,
        ],
        count,
    )?;
    gpu.read_back(&out, samples)
}

/// One evaluation of the per-cell energy and normal-equation blocks (compiles the kernel; use
/// [`AaKernel`] to evaluate repeatedly).
pub fn aa_cells(gpu: &Gpu, input: &AaInput) -> Result<Vec<CellContribution>, GpuError> {
    AaKernel::new(gpu)?.run(gpu, input)
}
