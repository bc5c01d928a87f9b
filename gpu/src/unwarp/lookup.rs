//! Host side of the `unwarp_lookup` kernel (`shaders/unwarp_lookup.wgsl`): the render-time
//! lookup through the offset mip chain (entry `main`, one invocation per [`LookupQuery`]) and
//! the pre-warped bake (entry `bake`, one invocation per colour texel).
//!
//! The chain ([`OffsetChain`]: sampler mode, level table, every level's offsets) is uploaded
//! once ([`UnwarpLookupKernel::new`]); [`UnwarpLookupKernel::lookup`] runs any number of
//! queries (in chunks within the device's limits), [`UnwarpLookupKernel::bake`] one texture.
//! The buffers are bound exactly as the kernel's conformance vectors lay them out: `mode`,
//! `levels`, `offsets`, then `queries` or `colour`, then the output.

use bytemuck::{Pod, Zeroable};

use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/unwarp_lookup.wgsl");

/// One query (24 bytes; WGSL `Query`): the coordinate (OBJ convention, v up) and the footprint
/// ∂u/∂x, ∂u/∂y in texels of level 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LookupQuery {
    pub uv: [f32; 2],
    pub dx: [f32; 2],
    pub dy: [f32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct LookupParams {
    count: u32,
    level_count: u32,
    colour_width: u32,
    colour_height: u32,
}

/// The offset mip chain as the kernel reads it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OffsetChain {
    /// Wrap across the border (periodic map); else clamp (fixed border).
    pub periodic: bool,
    /// Trilinear level selection; else the nearest level.
    pub mipmap_linear: bool,
    /// Per level: width, height, index of its first texel in `offsets`.
    pub levels: Vec<[u32; 3]>,
    /// Every level's solver offsets (UV units, o.y down), level 0 first, row-major, top first.
    pub offsets: Vec<[f32; 2]>,
}

impl OffsetChain {
    /// The `mode` binding: [periodic, mipmap linear] as 1 or 0.
    pub fn mode(&self) -> [u32; 2] {
        [u32::from(self.periodic), u32::from(self.mipmap_linear)]
    }

    /// [`GpuError::Input`] unless there is a level, every level has texels, and each level's
    /// texels lie inside `offsets`.
    pub fn check(&self) -> Result<(), GpuError> {
        let bad = |what: String| Err(GpuError::Input(format!("unwarp_lookup: {what}")));
        if self.levels.is_empty() {
            return bad("no level in the offset chain".into());
        }
        for (l, &[w, h, first]) in self.levels.iter().enumerate() {
            let end = u64::from(first) + u64::from(w) * u64::from(h);
            if w == 0 || h == 0 || end > self.offsets.len() as u64 {
                return bad(format!(
                    "level {l} ({w}×{h} from texel {first}) does not fit {} offsets",
                    self.offsets.len()
                ));
            }
        }
        Ok(())
    }
}

/// The compiled entry points with a chain on the GPU.
pub struct UnwarpLookupKernel {
    lookup: ComputeKernel,
    bake: ComputeKernel,
    level_count: u32,
    mode: wgpu::Buffer,
    levels: wgpu::Buffer,
    offsets: wgpu::Buffer,
}

impl UnwarpLookupKernel {
    /// Compile both entry points and upload `chain` (checked: [`OffsetChain::check`]).
    pub fn new(gpu: &Gpu, chain: &OffsetChain) -> Result<Self, GpuError> {
        chain.check()?;
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        let flat: Vec<u32> = chain.levels.iter().flatten().copied().collect();
        Ok(UnwarpLookupKernel {
            lookup: gpu.compute_kernel("unwarp_lookup", &source, "main")?,
            bake: gpu.compute_kernel("unwarp_lookup.bake", &source, "bake")?,
            level_count: chain.levels.len() as u32,
            mode: gpu.upload_storage("unwarp_lookup mode", &chain.mode())?,
            levels: gpu.upload_storage("unwarp_lookup levels", &flat)?,
            offsets: gpu.upload_storage("unwarp_lookup offsets", &chain.offsets)?,
        })
    }

    /// The lookup coordinate of every query, in order (chunks as the device's limits need;
    /// the split does not change the results).
    pub fn lookup(&self, gpu: &Gpu, queries: &[LookupQuery]) -> Result<Vec<[f32; 2]>, GpuError> {
        let level_count = self.level_count;
        gpu.run_per_item(
            &self.lookup,
            |count| LookupParams {
                count,
                level_count,
                ..Default::default()
            },
            &[&self.mode, &self.levels, &self.offsets],
            queries,
            usize::MAX,
        )
    }

    /// The pre-warped colour (0–255 per channel, before rounding) of every texel of a
    /// `width × height` colour texture (`colour`: one packed RGBA8 texel each, R in the low
    /// byte, row-major, top row first), through level 0 of the chain. One dispatch:
    /// [`GpuError::ExceedsLimit`] when the texture or its output exceeds a binding.
    pub fn bake(
        &self,
        gpu: &Gpu,
        colour: &[u32],
        width: u32,
        height: u32,
    ) -> Result<Vec<[f32; 4]>, GpuError> {
        let count = u64::from(width) * u64::from(height);
        if width == 0 || height == 0 || colour.len() as u64 != count {
            return Err(GpuError::Input(format!(
                "unwarp_lookup.bake: {} texels for a {width}×{height} colour texture",
                colour.len()
            )));
        }
        let count = u32::try_from(count)
            .map_err(|_| GpuError::TooLarge(format!("{width}×{height} colour texels")))?;
        let params = gpu.upload_uniform(
            "unwarp_lookup.bake params",
            &LookupParams {
                count,
                level_count: self.level_count,
                colour_width: width,
                colour_height: height,
            },
        );
        let input = gpu.upload_storage("unwarp_lookup.bake colour", colour)?;
        let out = gpu.output_storage::<[f32; 4]>("unwarp_lookup.bake out", colour.len())?;
        gpu.dispatch(
            &self.bake,
            &[
                &params,
                &self.mode,
                &self.levels,
                &self.offsets,
                &input,
                &out,
            ],
            count,
        )?;
        gpu.read_back(&out, colour.len())
    }
}
