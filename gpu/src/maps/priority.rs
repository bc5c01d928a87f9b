//! Host side of the `maps_priority` kernel (`shaders/maps_priority.wgsl`): per ring the 1-ring
//! area a(i) and the curvature κ(i) of the priority w(λ, i) = λ a/max a + (1 − λ) κ/max κ
//! (seed "Constructing the Mesh Hierarchies (2/5)"). The normalisation by the maxima and the
//! ordering are left to the CPU (they decide which vertices go).

use bytemuck::{Pod, Zeroable};

use super::{ring_kernel, upload_rings, Rings};
use crate::{ComputeKernel, Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl` and `maps_rings.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/maps_priority.wgsl");

/// The priority terms of one ring (8 bytes; WGSL `PriorityTerms`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PriorityTerms {
    /// a(i) = Σ over the star's triangles of ½|(q − p) × (r − p)| (`ring_area`).
    pub area: f32,
    /// κ(i) = |κ₁| + |κ₂| of the quadratic height fit in the star normal's frame
    /// (`curvature`; 0 for a degenerate normal or fit).
    pub kappa: f32,
}

/// The compiled `maps_priority` kernel.
pub struct PriorityKernel {
    kernel: ComputeKernel,
}

impl PriorityKernel {
    /// Compile the kernel.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        Ok(PriorityKernel {
            kernel: ring_kernel(gpu, "maps_priority", WGSL)?,
        })
    }

    /// a(i) and κ(i) for every ring of `rings`, in ring order (one invocation per ring).
    /// [`GpuError::Input`] for an inconsistent batch ([`Rings::check`]).
    pub fn run(&self, gpu: &Gpu, rings: &Rings) -> Result<Vec<PriorityTerms>, GpuError> {
        let (count, [params, positions, neighbours, headers]) =
            upload_rings(gpu, "maps_priority", rings)?;
        let terms =
            gpu.output_storage::<PriorityTerms>("maps_priority terms", rings.rings.len())?;
        gpu.dispatch(
            &self.kernel,
            &[&params, &positions, &neighbours, &headers, &terms],
            count,
        )?;
        gpu.read_back(&terms, rings.rings.len())
    }
}

/// [`PriorityKernel::new`] then [`PriorityKernel::run`].
pub fn run(gpu: &Gpu, rings: &Rings) -> Result<Vec<PriorityTerms>, GpuError> {
    PriorityKernel::new(gpu)?.run(gpu, rings)
}
