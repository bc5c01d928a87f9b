//! MAPS (Lee et al., SIGGRAPH 98) in f32: the per-vertex and per-point arithmetic of the
//! hierarchy and of Π⁻¹. Every combinatorial decision (which vertices are removed, the ring
//! order, the shape of a flattening, the triangulations) is made by the f64 reference on the
//! CPU; these kernels evaluate formulas on the data it hands over.
//!
//! | kernel | host | WGSL | what it computes | f64 twin (`src/maps/`) |
//! |---|---|---|---|---|
//! | `maps_priority` | [`PriorityKernel`] (or [`priority::run`]) | `shaders/maps_priority.wgsl` | per ring: 1-ring area a(i), curvature κ(i) | `priority.rs`: `ring_area`, `star_normal`, `curvature` |
//! | `maps_flatten` | [`FlattenKernel`] (or [`flatten::run`]) | `shaders/maps_flatten.wgsl` | per ring: θ_k, a, μ_k = r_k^a e^{i a θ_k} (disk, half disk, feature line), reject status | `flatten.rs`: `cumulative_angles`, `flatten_ring`, `check_sectors` |
//! | `maps_inverse` | [`InverseKernel`] (or [`inverse::run`]) | `shaders/maps_inverse.wgsl` | per base point: the removals replayed backwards to an input face, the surface point | `param.rs`: `Param::inverse`, `to_plane`, `locate_in_star` |
//!
//! Each `…Kernel::new` compiles once; `run` uploads a batch, dispatches and reads back.
//! [`Rings`] is the batch the first two kernels share: positions and a CSR of ordered 1-rings,
//! each with its [`RingHeader`] (centre, slice of the neighbour list, shape).

pub mod flatten;
pub mod inverse;
pub mod priority;

use bytemuck::{Pod, Zeroable};

use crate::compute::DISPATCH_WGSL;
use crate::{ComputeKernel, Gpu, GpuError};

pub use flatten::{
    FlatPoint, FlatRing, FlattenKernel, STATUS_DEGENERATE, STATUS_FLIPPED_FAN, STATUS_OK,
};
pub use inverse::{
    BaseQuery, DecimationFace, FaceCharts, InverseKernel, InverseResult, InverseTables,
};
pub use priority::{PriorityKernel, PriorityTerms};

/// [`RingHeader::kind`]: closed ring, one disk, a = 2π/θ_K (`RingShape::Disk`).
pub const KIND_DISK: u32 = 0;
/// [`RingHeader::kind`]: open ring of a boundary vertex, one half disk, a = π/θ_K
/// (`RingShape::HalfDisk`).
pub const KIND_HALF_DISK: u32 = 1;
/// [`RingHeader::kind`]: closed ring cut at ring positions s < t by two feature edges, each side
/// a half disk (`RingShape::FeatureLine { s, t }`).
pub const KIND_FEATURE_LINE: u32 = 2;

/// One ordered 1-ring (32 bytes; WGSL `RingHeader`): the neighbours j_0 … j_{K−1} of `centre`
/// are `neighbours[first .. first + count]`, counter-clockwise. A closed ring has K sectors
/// (j_m, j_{m+1 mod K}), an open one (half disk) K − 1.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct RingHeader {
    /// The vertex i whose ring this is.
    pub centre: u32,
    /// First entry in [`Rings::neighbours`].
    pub first: u32,
    /// K, the number of ring vertices (≥ 3).
    pub count: u32,
    /// [`KIND_DISK`], [`KIND_HALF_DISK`] or [`KIND_FEATURE_LINE`].
    pub kind: u32,
    /// Feature line only: the ring positions s < t of the two feature neighbours.
    pub s: u32,
    pub t: u32,
    pub _pad: [u32; 2],
}

impl RingHeader {
    /// Whether the ring is closed (every kind but the half disk).
    pub fn closed(&self) -> bool {
        self.kind != KIND_HALF_DISK
    }
}

/// A batch of 1-rings over one vertex array.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rings {
    /// xyz per vertex (w unused).
    pub positions: Vec<[f32; 4]>,
    /// The ring vertices of all rings, ring after ring.
    pub neighbours: Vec<u32>,
    /// One header per ring.
    pub rings: Vec<RingHeader>,
}

impl Rings {
    /// [`GpuError::Input`] unless every ring has 3 or more vertices inside `neighbours`, every
    /// index is a vertex, a half-disk ring is the only open kind, and a feature line has
    /// s < t < K.
    pub fn check(&self, kernel: &str) -> Result<(), GpuError> {
        let n = self.positions.len();
        let bad = |what: String| Err(GpuError::Input(format!("{kernel}: {what}")));
        if let Some(&v) = self.neighbours.iter().find(|&&v| v as usize >= n) {
            return bad(format!("ring vertex {v} outside {n} positions"));
        }
        for (r, h) in self.rings.iter().enumerate() {
            let end = h.first as u64 + h.count as u64;
            if h.centre as usize >= n {
                return bad(format!(
                    "ring {r}: centre {} outside {n} positions",
                    h.centre
                ));
            }
            if h.count < 3 || end > self.neighbours.len() as u64 {
                return bad(format!(
                    "ring {r}: {} vertices from {} (need ≥ 3 inside {})",
                    h.count,
                    h.first,
                    self.neighbours.len()
                ));
            }
            match h.kind {
                KIND_DISK | KIND_HALF_DISK => {}
                KIND_FEATURE_LINE if h.s < h.t && h.t < h.count => {}
                KIND_FEATURE_LINE => {
                    return bad(format!(
                        "ring {r}: feature line s = {}, t = {} with K = {}",
                        h.s, h.t, h.count
                    ))
                }
                k => return bad(format!("ring {r}: unknown kind {k}")),
            }
        }
        Ok(())
    }

    /// The number of ring slots (the length of the per-slot outputs).
    pub fn slot_count(&self) -> usize {
        self.neighbours.len()
    }
}

/// `{ count: u32, … }` uniform of the kernels (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(crate) struct CountParams {
    pub count: u32,
    pub limit: u32,
    pub _pad: [u32; 2],
}

/// WGSL shared by `maps_priority` and `maps_flatten` (`shaders/maps_rings.wgsl`: the
/// `RingHeader` struct, the kind constants, `sector_count`), prepended by the host like
/// `dispatch.wgsl`.
pub const MAPS_RINGS_WGSL: &str = include_str!("../../shaders/maps_rings.wgsl");

/// Compile a ring kernel: `dispatch.wgsl`, `maps_rings.wgsl`, then the kernel's own `wgsl`, with
/// entry point `name`.
pub(crate) fn ring_kernel(gpu: &Gpu, name: &str, wgsl: &str) -> Result<ComputeKernel, GpuError> {
    let source = [DISPATCH_WGSL, MAPS_RINGS_WGSL, wgsl].join("\n");
    gpu.compute_kernel(name, &source, name)
}

/// Check `rings` and upload the bindings every ring kernel starts with: the uniform
/// (ring count), positions, neighbours, headers (bindings 0–3).
pub(crate) fn upload_rings(
    gpu: &Gpu,
    name: &str,
    rings: &Rings,
) -> Result<(u32, [wgpu::Buffer; 4]), GpuError> {
    rings.check(name)?;
    let count = u32::try_from(rings.rings.len())
        .map_err(|_| GpuError::TooLarge(format!("{name}: {} rings", rings.rings.len())))?;
    let params = gpu.upload_uniform(
        name,
        &CountParams {
            count,
            ..Default::default()
        },
    );
    Ok((
        count,
        [
            params,
            gpu.upload_storage(name, &rings.positions)?,
            gpu.upload_storage(name, &rings.neighbours)?,
            gpu.upload_storage(name, &rings.rings)?,
        ],
    ))
}
