//! Host side of the `maps_inverse` kernel (`shaders/maps_inverse.wgsl`): Π⁻¹ of a batch of base
//! points (seed "Parameterization", "Remeshing (1/5)"; notes "Parameter bookkeeping").
//!
//! Design: the combinatorics of the hierarchy stay on the CPU. The f64 hierarchy's faces, the
//! removal that created each, each removal's old (star) faces and the μ of every face's corners
//! in the planes of the removals that created and removed it are tabulated once
//! ([`InverseTables`]); the kernel walks from the base face down through the removals that
//! created the faces the point is in, exactly as `Param::inverse` does, with a bounded search per
//! step among the removal's star faces (at most max_degree of them) for the one containing the
//! point. The walk ends at an input face, whose corners it interpolates.

use bytemuck::{Pod, Zeroable};

use crate::compute::DISPATCH_WGSL;
use crate::{ComputeKernel, Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/maps_inverse.wgsl");

/// [`DecimationFace::created_by`] of an input face.
pub const NONE: u32 = u32::MAX;

/// A face of the decimation (16 bytes; WGSL `DecimationFace`): input faces first, then the
/// faces created by the removals.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct DecimationFace {
    /// Vertex indices.
    pub corners: [u32; 3],
    /// The removal that created the face ([`NONE`] for an input face).
    pub created_by: u32,
}

/// μ of a face's three corners (in corner order) in the plane of the removal that created it
/// and in that of the removal that deleted it (48 bytes; WGSL `FaceCharts`). The removed vertex
/// sits at 0; a chart that does not apply (an input face has no `created`, a base face no
/// `removed`) is zero.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FaceCharts {
    pub created: [[f32; 2]; 3],
    pub removed: [[f32; 2]; 3],
}

/// A base point (16 bytes; WGSL `BaseQuery`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BaseQuery {
    /// Barycentrics in the base face's corner order.
    pub bary: [f32; 3],
    /// Base face index (into [`InverseTables::base_to_face`]).
    pub face: u32,
}

/// Π⁻¹ of one base point (32 bytes; WGSL `InverseResult`; `SurfacePoint` of the reference).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct InverseResult {
    /// Σ bary_c p_c.
    pub position: [f32; 3],
    /// The input face reached.
    pub face: u32,
    /// Barycentrics in that face (clamped to ≥ 0, sum 1).
    pub bary: [f32; 3],
    /// The smallest barycentric met on the way before clamping.
    pub min_bary: f32,
}

/// The hierarchy in the kernel's layout.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InverseTables {
    /// xyz per vertex (w unused).
    pub positions: Vec<[f32; 4]>,
    /// Every face of the decimation.
    pub faces: Vec<DecimationFace>,
    /// One per face.
    pub charts: Vec<FaceCharts>,
    /// Per removal, (first, count) of its old faces in [`InverseTables::old_faces`].
    pub removals: Vec<[u32; 2]>,
    /// The old (star) faces of all removals, removal after removal, in the removal's order.
    pub old_faces: Vec<u32>,
    /// Base face index → decimation face id.
    pub base_to_face: Vec<u32>,
}

impl InverseTables {
    /// [`GpuError::Input`] unless the indices are in range and every removal's old faces come
    /// before the faces it created (so the walk's face id decreases and it ends).
    pub fn check(&self) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("maps_inverse: {what}")));
        let (nv, nf) = (self.positions.len(), self.faces.len());
        if self.charts.len() != nf {
            return bad(format!("{} charts for {nf} faces", self.charts.len()));
        }
        let mut oldest_new = vec![u32::MAX; self.removals.len()];
        for (f, face) in self.faces.iter().enumerate() {
            if let Some(&v) = face.corners.iter().find(|&&v| v as usize >= nv) {
                return bad(format!("face {f}: vertex {v} outside {nv} positions"));
            }
            if face.created_by != NONE {
                let Some(slot) = oldest_new.get_mut(face.created_by as usize) else {
                    return bad(format!(
                        "face {f}: created by removal {} of {}",
                        face.created_by,
                        self.removals.len()
                    ));
                };
                *slot = (*slot).min(f as u32);
            }
        }
        for (r, &[first, count]) in self.removals.iter().enumerate() {
            let end = first as u64 + count as u64;
            if count == 0 || end > self.old_faces.len() as u64 {
                return bad(format!("removal {r}: old faces {first}..{end}"));
            }
            let old = &self.old_faces[first as usize..end as usize];
            if let Some(&g) = old
                .iter()
                .find(|&&g| g >= oldest_new[r] || g as usize >= nf)
            {
                return bad(format!(
                    "removal {r}: old face {g} is not before its new faces (first {})",
                    oldest_new[r]
                ));
            }
        }
        if let Some(&f) = self.base_to_face.iter().find(|&&f| f as usize >= nf) {
            return bad(format!("base face maps to face {f} of {nf}"));
        }
        Ok(())
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct InverseParams {
    count: u32,
    face_count: u32,
    _pad: [u32; 2],
}

/// The compiled kernel with the tables on the GPU.
pub struct InverseKernel {
    kernel: ComputeKernel,
    tables: [wgpu::Buffer; 6],
    face_count: u32,
    base_faces: usize,
}

impl InverseKernel {
    /// Compile the kernel and upload `tables` (checked with [`InverseTables::check`]).
    pub fn new(gpu: &Gpu, tables: &InverseTables) -> Result<Self, GpuError> {
        tables.check()?;
        let face_count = u32::try_from(tables.faces.len())
            .map_err(|_| GpuError::TooLarge(format!("{} faces", tables.faces.len())))?;
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        let kernel = gpu.compute_kernel("maps_inverse", &source, "maps_inverse")?;
        Ok(InverseKernel {
            kernel,
            tables: [
                gpu.upload_storage("maps_inverse positions", &tables.positions)?,
                gpu.upload_storage("maps_inverse faces", &tables.faces)?,
                gpu.upload_storage("maps_inverse charts", &tables.charts)?,
                gpu.upload_storage("maps_inverse removals", &tables.removals)?,
                gpu.upload_storage("maps_inverse old faces", &tables.old_faces)?,
                gpu.upload_storage("maps_inverse base faces", &tables.base_to_face)?,
            ],
            face_count,
            base_faces: tables.base_to_face.len(),
        })
    }

    /// Π⁻¹ of every query, in order (one invocation per query, in chunks of at most
    /// [`Gpu::max_chunk_len`] queries). [`GpuError::Input`] for a base face out of range.
    pub fn run(&self, gpu: &Gpu, queries: &[BaseQuery]) -> Result<Vec<InverseResult>, GpuError> {
        if let Some(q) = queries.iter().find(|q| q.face as usize >= self.base_faces) {
            return Err(GpuError::Input(format!(
                "maps_inverse: base face {} of {}",
                q.face, self.base_faces
            )));
        }
        let t = &self.tables;
        gpu.run_per_item(
            &self.kernel,
            |count| InverseParams {
                count,
                face_count: self.face_count,
                _pad: [0; 2],
            },
            &[&t[0], &t[1], &t[2], &t[3], &t[4], &t[5]],
            queries,
            gpu.max_chunk_len(std::mem::size_of::<InverseResult>()),
        )
    }
}

/// [`InverseKernel::new`] then [`InverseKernel::run`].
pub fn run(
    gpu: &Gpu,
    tables: &InverseTables,
    queries: &[BaseQuery],
) -> Result<Vec<InverseResult>, GpuError> {
    InverseKernel::new(gpu, tables)?.run(gpu, queries)
}
