//! Host side of the `maps_flatten` kernel (`shaders/maps_flatten.wgsl`): the z^a flattening of
//! every 1-ring of a batch (seed "Constructing the Mesh Hierarchies (4/5)"; notes "Flattening a
//! 1-ring"):
//!
//! θ_k = Σ_{m<k} ∠(p_{j_m}, p_i, p_{j_{m+1}}), μ(p_{j_k}) = r_k^a e^{i(a θ_k + offset)},
//! a = 2π/θ_K (disk), π/θ_K (half disk), π/θ_side per side of a feature line (offsets and chord
//! ends as the reference's `flatten_ring`), with its two rejections: degenerate radius or angle,
//! and a scaled sector a·φ_k ≥ π (a flipped fan). Unlike the reference, which returns no μ for a
//! rejected ring, the kernel still writes μ (so a mismatch can be looked at); the status says
//! what the reference would have decided from these f32 values.

use bytemuck::{Pod, Zeroable};

use super::{ring_kernel, upload_rings, Rings};
use crate::{ComputeKernel, Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and `maps_rings.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/maps_flatten.wgsl");

/// [`FlatRing::status`]: flattened.
pub const STATUS_OK: u32 = 0;
/// [`FlatRing::status`]: a radius or a sector angle is zero or not finite, or a μ is not finite
/// (`FlattenReject::Degenerate`).
pub const STATUS_DEGENERATE: u32 = 1;
/// [`FlatRing::status`]: a scaled sector angle a·φ_k ≥ π, or a side with a single sector
/// (`FlattenReject::FlippedFan`).
pub const STATUS_FLIPPED_FAN: u32 = 2;

/// Per ring (16 bytes; WGSL `FlatRing`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FlatRing {
    /// a of the disk or half disk; a₁ = π/θ(s→t) of a feature line's upper side.
    pub a: f32,
    /// a₂ = π/θ(t→s) of a feature line's lower side; a otherwise.
    pub a2: f32,
    /// θ_K of a closed ring, θ_{K−1} of a half disk.
    pub theta_total: f32,
    /// [`STATUS_OK`], [`STATUS_DEGENERATE`] or [`STATUS_FLIPPED_FAN`].
    pub status: u32,
}

/// Per ring slot k, in the order of [`Rings::neighbours`] (16 bytes; WGSL `FlatPoint`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FlatPoint {
    /// μ(p_{j_k}).
    pub mu: [f32; 2],
    /// θ_k (θ_0 = 0).
    pub theta: f32,
    /// r_k = |p_{j_k} − p_i|.
    pub radius: f32,
}

/// The compiled `maps_flatten` kernel.
pub struct FlattenKernel {
    kernel: ComputeKernel,
}

impl FlattenKernel {
    /// Compile the kernel.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        Ok(FlattenKernel {
            kernel: ring_kernel(gpu, "maps_flatten", WGSL)?,
        })
    }

    /// The flattening of every ring of `rings`: one [`FlatRing`] per ring and one [`FlatPoint`]
    /// per slot of [`Rings::neighbours`] (one invocation per ring). [`GpuError::Input`] for an
    /// inconsistent batch ([`Rings::check`]).
    pub fn run(
        &self,
        gpu: &Gpu,
        rings: &Rings,
    ) -> Result<(Vec<FlatRing>, Vec<FlatPoint>), GpuError> {
        let (count, [params, positions, neighbours, headers]) =
            upload_rings(gpu, "maps_flatten", rings)?;
        let flat = gpu.output_storage::<FlatRing>("maps_flatten rings out", rings.rings.len())?;
        let points = gpu.output_storage::<FlatPoint>("maps_flatten points", rings.slot_count())?;
        gpu.dispatch(
            &self.kernel,
            &[&params, &positions, &neighbours, &headers, &flat, &points],
            count,
        )?;
        Ok((
            gpu.read_back(&flat, rings.rings.len())?,
            gpu.read_back(&points, rings.slot_count())?,
        ))
    }
}

/// [`FlattenKernel::new`] then [`FlattenKernel::run`].
pub fn run(gpu: &Gpu, rings: &Rings) -> Result<(Vec<FlatRing>, Vec<FlatPoint>), GpuError> {
    FlattenKernel::new(gpu)?.run(gpu, rings)
}
