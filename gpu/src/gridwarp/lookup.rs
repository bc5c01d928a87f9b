//! Host side of the `gridwarp_lookup` kernel (`shaders/gridwarp_lookup.wgsl`): the warped
//! texture lookup of a UV atlas with several solved ROIs (seed 000 §6, §8, §10.2), one
//! invocation per query UV.
//!
//! The atlas is four flat tables ([`LookupTables`]), bound at 1–4 in the order of the
//! conformance vectors' inputs, then the queries (binding 5) and the output (binding 6), one
//! looked-up UV per query: no packing beyond the `.npy` arrays' own C order. Each ROI's
//! [`RoiGrid`] says where its rest lines and its warped lines (AA) or vertices (NAA) start.

use bytemuck::{Pod, Zeroable};

use crate::compute::DISPATCH_WGSL;
use crate::{ComputeKernel, Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/gridwarp_lookup.wgsl");

/// [`RoiGrid::variant`] of an axis-aligned grid (warped lines).
pub const AA: u32 = 0;
/// [`RoiGrid::variant`] of a non-axis-aligned grid (warped vertices).
pub const NAA: u32 = 1;

/// A ROI's rectangle [u0, u1] × [v0, v1] in UV (16 bytes; WGSL `Roi`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct RoiRect {
    pub u0: f32,
    pub u1: f32,
    pub v0: f32,
    pub v1: f32,
}

/// A ROI's grid (24 bytes; WGSL `RoiGrid`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RoiGrid {
    /// [`AA`] or [`NAA`].
    pub variant: u32,
    /// Boundary blending (seed §10.2): 1 on, 0 off.
    pub blend: u32,
    /// M lines along s (vertices per row of an NAA grid).
    pub m: u32,
    /// N lines along t.
    pub n: u32,
    /// Its rest lines ŝ_0 … ŝ_{M−1}, t̂_0 … t̂_{N−1} start at `rest_lines[rest]`.
    pub rest: u32,
    /// Its warped lines s_0 … s_{M−1}, t_0 … t_{N−1} (AA) or vertices P_ab = (s, t) at
    /// `2(a·N + b)` (NAA) start at `warped[warped]`.
    pub warped: u32,
}

impl RoiGrid {
    /// The number of `warped` values the grid reads: M + N (AA) or 2MN (NAA).
    pub fn warped_len(&self) -> u64 {
        let (m, n) = (u64::from(self.m), u64::from(self.n));
        if self.variant == NAA {
            2 * m * n
        } else {
            m + n
        }
    }
}

/// The atlas in the kernel's layout: ROI k is `rois[k]` with grid `grids[k]`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LookupTables {
    pub rois: Vec<RoiRect>,
    pub grids: Vec<RoiGrid>,
    pub rest_lines: Vec<f32>,
    pub warped: Vec<f32>,
}

impl LookupTables {
    /// [`GpuError::Input`] (naming the ROI) unless every ROI has a grid, a rectangle of
    /// positive finite size, at least 2 × 2 lines, a known variant and blend flag, and its
    /// lines and vertices inside the tables.
    pub fn check(&self) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("gridwarp_lookup: {what}")));
        if self.grids.len() != self.rois.len() {
            return bad(format!(
                "{} grids for {} ROIs",
                self.grids.len(),
                self.rois.len()
            ));
        }
        for (k, (r, g)) in self.rois.iter().zip(&self.grids).enumerate() {
            let finite = [r.u0, r.u1, r.v0, r.v1].iter().all(|x| x.is_finite());
            if !finite || r.u1 <= r.u0 || r.v1 <= r.v0 {
                return bad(format!(
                    "ROI {k}: u [{}, {}] × v [{}, {}] is not a rectangle of positive size",
                    r.u0, r.u1, r.v0, r.v1
                ));
            }
            if g.variant > NAA || g.blend > 1 {
                return bad(format!(
                    "ROI {k}: variant {} (0 AA, 1 NAA), blend {} (0 or 1)",
                    g.variant, g.blend
                ));
            }
            if g.m < 2 || g.n < 2 {
                return bad(format!("ROI {k}: {}×{} lines, need at least 2×2", g.m, g.n));
            }
            let rest_end = u64::from(g.rest) + u64::from(g.m) + u64::from(g.n);
            if rest_end > self.rest_lines.len() as u64 {
                return bad(format!(
                    "ROI {k}: rest lines {}..{rest_end} beyond the {} in the table",
                    g.rest,
                    self.rest_lines.len()
                ));
            }
            let warped_end = u64::from(g.warped) + g.warped_len();
            if warped_end > self.warped.len() as u64 {
                return bad(format!(
                    "ROI {k}: warped values {}..{warped_end} beyond the {} in the table",
                    g.warped,
                    self.warped.len()
                ));
            }
        }
        Ok(())
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct LookupParams {
    count: u32,
    rois: u32,
    _pad: [u32; 2],
}

/// The compiled kernel with an atlas's tables on the GPU.
pub struct LookupKernel {
    kernel: ComputeKernel,
    tables: [wgpu::Buffer; 4],
    rois: u32,
}

impl LookupKernel {
    /// Compile the kernel (`dispatch.wgsl` + `gridwarp_lookup.wgsl`, entry point `main`) and
    /// upload `tables` (checked with [`LookupTables::check`]).
    pub fn new(gpu: &Gpu, tables: &LookupTables) -> Result<Self, GpuError> {
        tables.check()?;
        let rois = u32::try_from(tables.rois.len())
            .map_err(|_| GpuError::TooLarge(format!("{} ROIs", tables.rois.len())))?;
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        let label = "gridwarp_lookup";
        Ok(LookupKernel {
            kernel: gpu.compute_kernel(label, &source, "main")?,
            tables: [
                gpu.upload_storage(label, &tables.rois)?,
                gpu.upload_storage(label, &tables.grids)?,
                gpu.upload_storage(label, &tables.rest_lines)?,
                gpu.upload_storage(label, &tables.warped)?,
            ],
            rois,
        })
    }

    /// The looked-up UV of every query, in order (one invocation per query, in chunks of at
    /// most [`Gpu::max_chunk_len`]).
    pub fn run(&self, gpu: &Gpu, queries: &[[f32; 2]]) -> Result<Vec<[f32; 2]>, GpuError> {
        let t = &self.tables;
        gpu.run_per_item(
            &self.kernel,
            |count| LookupParams {
                count,
                rois: self.rois,
                _pad: [0; 2],
            },
            &[&t[0], &t[1], &t[2], &t[3]],
            queries,
            gpu.max_chunk_len(std::mem::size_of::<[f32; 2]>()),
        )
    }
}

/// [`LookupKernel::new`] then [`LookupKernel::run`].
pub fn lookup(
    gpu: &Gpu,
    tables: &LookupTables,
    queries: &[[f32; 2]],
) -> Result<Vec<[f32; 2]>, GpuError> {
    LookupKernel::new(gpu, tables)?.run(gpu, queries)
}
