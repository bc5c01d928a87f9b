//! Host side of the `skinsimp_collapse_cost` kernel (`shaders/skinsimp_collapse_cost.wgsl`):
//! for every candidate — an edge `(a, b)` with fixed weights `α` over its candidate bones — the
//! position step and the collapse cost (notes "The error and its alternating minimisation",
//! position step; the reference is `position_quadric`, `position_step` and `energy` of
//! `src/skinsimp/cost.rs`, as its `endpoint_start` calls them):
//!
//! `Q̃ = Σ_j A^{jT} (Q_a^j + Q_b^j) A^j`, `A^j = Σ_k α_k M_k^j`; `v = −Q̃[0:3,0:3]⁻¹ Q̃[0:3,3]`
//! when `cond_F ≤ max_condition`, else (or if worse) the best of `a`, `b`, the midpoint;
//! `E(v̂, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂)`.
//!
//! The weight QP and the alternation of the full method stay on the CPU: the kernel covers the
//! Mohr–Gleicher placement (one candidate per endpoint's weights) and every position step of
//! the alternation (any α).

use bytemuck::{Pod, Zeroable};

use super::{JointMatrix, QuadricF32, MAX_CANDIDATES};
use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/skinsimp_collapse_cost.wgsl");

/// [`EdgeCost::choice`] of the solved position; 1, 2, 3 are the fallbacks a, b, midpoint.
pub const CHOICE_SOLUTION: u32 = 0;

/// One candidate (80 bytes; WGSL `EdgeItem`): the edge and `α` over `candidates` bones.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EdgeItem {
    pub a: u32,
    pub b: u32,
    /// K ≤ [`MAX_CANDIDATES`]: the used slots of `joints` and `alpha`.
    pub candidates: u32,
    pub _pad: u32,
    pub joints: [u32; MAX_CANDIDATES],
    pub alpha: [f32; MAX_CANDIDATES],
}

/// One candidate's result (72 bytes; WGSL `EdgeCost`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct EdgeCost {
    /// `Q̃`, upper triangle.
    pub quadric: QuadricF32,
    /// `‖B‖_F ‖B⁻¹‖_F` of `B = Q̃[0:3,0:3]` as computed in f32 (0 when `det B = 0`).
    pub condition: f32,
    /// `v̂ᵀQ̃v̂` at the chosen position.
    pub value: f32,
    /// The chosen rest position.
    pub position: [f32; 3],
    /// `E(v̂, α)`.
    pub cost: f32,
    /// [`CHOICE_SOLUTION`], or 1, 2, 3: a, b, midpoint.
    pub choice: u32,
    pub _pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct CostParams {
    vertex_count: u32,
    pose_count: u32,
    joint_count: u32,
    count: u32,
    max_condition: f32,
    _pad: [u32; 3],
}

/// Everything `skinsimp_collapse_cost` reads besides the candidates.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CostInput {
    /// Rest positions (the fallbacks a, b, midpoint).
    pub rest: Vec<[f32; 3]>,
    pub pose_count: u32,
    pub joint_count: u32,
    /// `joints[pose · J + joint]`.
    pub joints: Vec<JointMatrix>,
    /// `Q_i^j` at `i · P + j`.
    pub vertex_quadrics: Vec<QuadricF32>,
    /// Largest condition number at which the position is solved.
    pub max_condition: f32,
}

impl CostInput {
    /// [`GpuError::Input`] unless the sizes agree and the items' indices are in range.
    pub fn check(&self, items: &[EdgeItem]) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("skinsimp_collapse_cost: {what}")));
        let (v, p, j) = (
            self.rest.len(),
            self.pose_count as usize,
            self.joint_count as usize,
        );
        if p == 0 || j == 0 {
            return bad(format!("{p} poses, {j} joints"));
        }
        if self.joints.len() != p * j || self.vertex_quadrics.len() != v * p {
            return bad(format!(
                "{} joint matrices and {} vertex quadrics for {p} poses, {j} joints, {v} vertices",
                self.joints.len(),
                self.vertex_quadrics.len()
            ));
        }
        for (n, item) in items.iter().enumerate() {
            let k = item.candidates as usize;
            if item.a as usize >= v
                || item.b as usize >= v
                || k > MAX_CANDIDATES
                || item.joints[..k.min(MAX_CANDIDATES)]
                    .iter()
                    .any(|&x| x as usize >= j)
            {
                return bad(format!("candidate {n} out of range: {item:?}"));
            }
        }
        Ok(())
    }
}

/// The compiled `skinsimp_collapse_cost` pipeline.
pub struct CollapseCostKernel {
    kernel: ComputeKernel,
}

impl CollapseCostKernel {
    /// Compile the kernel.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        Ok(CollapseCostKernel {
            kernel: gpu.compute_kernel(
                "skinsimp_collapse_cost",
                &source,
                "skinsimp_collapse_cost",
            )?,
        })
    }

    /// One [`EdgeCost`] per item, in item order (`position_given_weights` of the reference
    /// with the fallbacks a, b, midpoint).
    pub fn position_given_weights(
        &self,
        gpu: &Gpu,
        input: &CostInput,
        items: &[EdgeItem],
    ) -> Result<Vec<EdgeCost>, GpuError> {
        input.check(items)?;
        let rest = gpu.upload_storage("skinsimp_collapse_cost rest", &input.rest)?;
        let quadrics =
            gpu.upload_storage("skinsimp_collapse_cost quadrics", &input.vertex_quadrics)?;
        let joints = gpu.upload_storage("skinsimp_collapse_cost joints", &input.joints)?;
        let chunk = gpu.max_chunk_len(std::mem::size_of::<EdgeCost>());
        gpu.run_per_item(
            &self.kernel,
            |count| CostParams {
                vertex_count: input.rest.len() as u32,
                pose_count: input.pose_count,
                joint_count: input.joint_count,
                count,
                max_condition: input.max_condition,
                _pad: [0; 3],
            },
            &[&rest, &quadrics, &joints],
            items,
            chunk,
        )
    }
}
