//! Host side of the `skinsimp_plane_quadrics` and `skinsimp_vertex_quadrics` kernels
//! (`shaders/skinsimp_quadrics.wgsl`): per-pose Garland–Heckbert quadrics (notes "Per-pose
//! quadrics"; the reference is `src/skinsimp/quadric.rs` and `vertex_quadrics` in
//! `src/skinsimp/collapse.rs`).
//!
//! 1. One quadric per (source, pose): a source is a face (`K_f^j = area · q qᵀ`) or a boundary
//!    / UV-seam edge of a face (its constraint plane, `Quadric` names `from_triangle` and
//!    `edge_constraint`).
//! 2. One quadric per (vertex, pose): `Q_i^j` = the sum of the vertex's sources in the order
//!    of its CSR list. The caller lists them in the reference's order (faces ascending, each
//!    face followed by its constraint edges), so the f32 sum adds the same terms in the same
//!    order; a gather with no atomics, deterministic.

use bytemuck::{Pod, Zeroable};

use super::QuadricF32;
use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernels' own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/skinsimp_quadrics.wgsl");

/// [`PlaneSource::kind`] of a face quadric; 0, 1, 2 name the constraint plane of a local edge
/// (corners `e`, `(e + 1) % 3`).
pub const SOURCE_FACE: u32 = 3;

/// One quadric source (16 bytes; WGSL `PlaneSource`): a face's vertices and its kind.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PlaneSource {
    pub corners: [u32; 3],
    pub kind: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct QuadricParams {
    item_count: u32,
    pose_count: u32,
    count: u32,
    boundary_weight: f32,
}

/// The mesh side of the quadric kernels (the posed positions come separately).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QuadricInput {
    pub vertex_count: u32,
    pub pose_count: u32,
    /// Faces and constraint edges.
    pub sources: Vec<PlaneSource>,
    /// CSR offsets, `vertex_count + 1` of them: vertex `i` sums
    /// `vertex_sources[vertex_offsets[i]..vertex_offsets[i + 1]]`.
    pub vertex_offsets: Vec<u32>,
    /// Source ids, in summation order per vertex.
    pub vertex_sources: Vec<u32>,
    /// Weight of the constraint planes relative to the face quadrics.
    pub boundary_weight: f32,
}

impl QuadricInput {
    /// [`GpuError::Input`] unless the CSR is well formed and every index is in range.
    pub fn check(&self) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("skinsimp_quadrics: {what}")));
        let v = self.vertex_count as usize;
        if self.pose_count == 0 {
            return bad("no pose".into());
        }
        if let Some(s) = self
            .sources
            .iter()
            .find(|s| s.kind > SOURCE_FACE || s.corners.iter().any(|&c| c as usize >= v))
        {
            return bad(format!("source {s:?} with {v} vertices"));
        }
        let o = &self.vertex_offsets;
        if o.len() != v + 1
            || o[0] != 0
            || o.windows(2).any(|w| w[0] > w[1])
            || o[v] as usize != self.vertex_sources.len()
        {
            return bad(format!(
                "{} CSR offsets (need {} ascending from 0 to {})",
                o.len(),
                v + 1,
                self.vertex_sources.len()
            ));
        }
        if let Some(s) = self
            .vertex_sources
            .iter()
            .find(|&&s| s as usize >= self.sources.len())
        {
            return bad(format!("source id {s} of {}", self.sources.len()));
        }
        Ok(())
    }
}

/// The two compiled pipelines.
pub struct QuadricKernel {
    plane: ComputeKernel,
    vertex: ComputeKernel,
}

impl QuadricKernel {
    /// Compile both entry points.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        Ok(QuadricKernel {
            plane: gpu.compute_kernel(
                "skinsimp_plane_quadrics",
                &source,
                "skinsimp_plane_quadrics",
            )?,
            vertex: gpu.compute_kernel(
                "skinsimp_vertex_quadrics",
                &source,
                "skinsimp_vertex_quadrics",
            )?,
        })
    }

    /// The source quadrics (index `source · P + pose`) and the vertex quadrics (index
    /// `vertex · P + pose`) of the posed positions `posed` (index `vertex · P + pose`).
    pub fn quadrics(
        &self,
        gpu: &Gpu,
        input: &QuadricInput,
        posed: &[[f32; 3]],
    ) -> Result<(Vec<QuadricF32>, Vec<QuadricF32>), GpuError> {
        let expected = input.vertex_count as usize * input.pose_count as usize;
        if posed.len() != expected {
            return Err(GpuError::Input(format!(
                "skinsimp_quadrics: {} posed positions for {} vertices × {} poses",
                posed.len(),
                input.vertex_count,
                input.pose_count
            )));
        }
        let posed = gpu.upload_storage("skinsimp_quadrics posed", posed)?;
        let (plane, vertex) = self.quadrics_on_gpu(gpu, input, &posed)?;
        let p = input.pose_count as usize;
        Ok((
            gpu.read_back(&plane, input.sources.len() * p)?,
            gpu.read_back(&vertex, expected)?,
        ))
    }

    /// [`QuadricKernel::quadrics`] without readback, from a posed-position buffer (e.g. the
    /// output of [`super::LbsKernel::skin_on_gpu`]): the source and vertex quadric buffers.
    pub fn quadrics_on_gpu(
        &self,
        gpu: &Gpu,
        input: &QuadricInput,
        posed: &wgpu::Buffer,
    ) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
        input.check()?;
        let p = input.pose_count as usize;
        let count = |items: usize| {
            u32::try_from(items * p)
                .map_err(|_| GpuError::TooLarge(format!("{items} × {p} quadrics")))
        };
        let params = |items: usize| -> Result<wgpu::Buffer, GpuError> {
            Ok(gpu.upload_uniform(
                "skinsimp_quadrics params",
                &QuadricParams {
                    item_count: items as u32,
                    pose_count: input.pose_count,
                    count: count(items)?,
                    boundary_weight: input.boundary_weight,
                },
            ))
        };
        let sources = gpu.upload_storage("skinsimp_quadrics sources", &input.sources)?;
        let plane = gpu
            .output_storage::<QuadricF32>("skinsimp_plane_quadrics out", input.sources.len() * p)?;
        let plane_params = params(input.sources.len())?;
        gpu.dispatch(
            &self.plane,
            &[&plane_params, posed, &sources, &plane],
            count(input.sources.len())?,
        )?;
        let v = input.vertex_count as usize;
        let offsets = gpu.upload_storage("skinsimp_quadrics offsets", &input.vertex_offsets)?;
        let lists = gpu.upload_storage("skinsimp_quadrics lists", &input.vertex_sources)?;
        let vertex = gpu.output_storage::<QuadricF32>("skinsimp_vertex_quadrics out", v * p)?;
        let vertex_params = params(v)?;
        gpu.dispatch(
            &self.vertex,
            &[&vertex_params, &offsets, &lists, &plane, &vertex],
            count(v)?,
        )?;
        Ok((plane, vertex))
    }
}
