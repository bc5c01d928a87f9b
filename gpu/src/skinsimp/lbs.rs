//! Host side of the `skinsimp_lbs` kernel (`shaders/skinsimp_lbs.wgsl`): linear blend
//! skinning of every vertex in every pose, `p_i^j = Σ_k w_ik M_k^j v̂_i` (notes "Linear blend
//! skinning"; the reference is `skin` in `src/skinsimp/mod.rs`).

use bytemuck::{Pod, Zeroable};

use super::JointMatrix;
use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/skinsimp_lbs.wgsl");

/// Up to four `(joint, weight)` pairs of one vertex, applied in slot order (32 bytes; WGSL
/// `Influences`). Unused slots have weight 0 (and are skipped).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Influences {
    pub joints: [u32; 4],
    pub weights: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct LbsParams {
    vertex_count: u32,
    pose_count: u32,
    joint_count: u32,
    count: u32,
}

/// Everything `skinsimp_lbs` reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LbsInput {
    /// Rest positions.
    pub rest: Vec<[f32; 3]>,
    /// One per vertex.
    pub influences: Vec<Influences>,
    /// Joints per pose, J.
    pub joint_count: u32,
    /// `joints[pose · J + joint]`, P·J matrices.
    pub joints: Vec<JointMatrix>,
}

impl LbsInput {
    /// Number of poses P (`joints.len() / J`).
    pub fn pose_count(&self) -> usize {
        self.joints.len() / (self.joint_count.max(1) as usize)
    }

    /// [`GpuError::Input`] unless the sizes agree and every used joint index is below J.
    pub fn check(&self) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("skinsimp_lbs: {what}")));
        let j = self.joint_count as usize;
        if j == 0 || self.joints.is_empty() || !self.joints.len().is_multiple_of(j) {
            return bad(format!(
                "{} joint matrices for {j} joints per pose",
                self.joints.len()
            ));
        }
        if self.influences.len() != self.rest.len() {
            return bad(format!(
                "{} influence sets for {} vertices",
                self.influences.len(),
                self.rest.len()
            ));
        }
        for (i, inf) in self.influences.iter().enumerate() {
            if (0..4).any(|k| inf.weights[k] != 0.0 && inf.joints[k] as usize >= j) {
                return bad(format!("vertex {i} uses a joint ≥ {j}: {inf:?}"));
            }
        }
        Ok(())
    }
}

/// The compiled `skinsimp_lbs` pipeline.
pub struct LbsKernel {
    kernel: ComputeKernel,
}

impl LbsKernel {
    /// Compile the kernel.
    pub fn new(gpu: &Gpu) -> Result<Self, GpuError> {
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        Ok(LbsKernel {
            kernel: gpu.compute_kernel("skinsimp_lbs", &source, "skinsimp_lbs")?,
        })
    }

    /// Posed positions `p_i^j` at index `i · P + j` (V·P of them); reads back.
    pub fn skin(&self, gpu: &Gpu, input: &LbsInput) -> Result<Vec<[f32; 3]>, GpuError> {
        let (buffer, len) = self.skin_on_gpu(gpu, input)?;
        gpu.read_back(&buffer, len)
    }

    /// [`LbsKernel::skin`] without the readback: the output buffer (3 f32 per (vertex, pose))
    /// and its length in positions, for the quadric kernel to read.
    pub fn skin_on_gpu(
        &self,
        gpu: &Gpu,
        input: &LbsInput,
    ) -> Result<(wgpu::Buffer, usize), GpuError> {
        input.check()?;
        let len = input.rest.len() * input.pose_count();
        let count =
            u32::try_from(len).map_err(|_| GpuError::TooLarge(format!("{len} posed positions")))?;
        let params = gpu.upload_uniform(
            "skinsimp_lbs params",
            &LbsParams {
                vertex_count: input.rest.len() as u32,
                pose_count: input.pose_count() as u32,
                joint_count: input.joint_count,
                count,
            },
        );
        let rest = gpu.upload_storage("skinsimp_lbs rest", &input.rest)?;
        let influences = gpu.upload_storage("skinsimp_lbs influences", &input.influences)?;
        let joints = gpu.upload_storage("skinsimp_lbs joints", &input.joints)?;
        let posed = gpu.output_storage::<[f32; 3]>("skinsimp_lbs posed", len)?;
        gpu.dispatch(
            &self.kernel,
            &[&params, &rest, &influences, &joints, &posed],
            count,
        )?;
        Ok((posed, len))
    }
}
