//! Host side of the `unwarp_pass` kernel (`shaders/unwarp_pass.wgsl`).
//!
//! The node data (z = s·h and the pin weight per node) and the active texel list of every
//! phase are uploaded once ([`UnwarpPassKernel::new`]); the offsets live in a GPU buffer that
//! the kernel updates in place (texels of one phase share no triangle, so an invocation reads
//! only offsets no other invocation of the dispatch writes). [`UnwarpPassKernel::pass`] runs one
//! phase and returns the per-texel [`TexelResult`]s; [`UnwarpPassKernel::passes`] runs many
//! without reading back (for throughput).

use bytemuck::{Pod, Zeroable};

use crate::compute::{ComputeKernel, DISPATCH_WGSL};
use crate::{Gpu, GpuError};

/// The kernel's own WGSL (after `dispatch.wgsl`).
pub const WGSL: &str = include_str!("../../shaders/unwarp_pass.wgsl");

/// Bits 0–7 of [`TexelResult::flags`]: ternary-search iterations done.
pub const STEPS_MASK: u32 = 0xff;
/// Bit of [`TexelResult::flags`]: the guard accepted the step.
pub const FLAG_MOVED: u32 = 1 << 8;
/// Bit of [`TexelResult::flags`]: a flip-free bracket was found.
pub const FLAG_BRACKET: u32 = 1 << 9;

/// One active texel's outcome (16 bytes; WGSL `TexelResult`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct TexelResult {
    /// The new offset.
    pub offset: [f32; 2],
    /// Bit i: iteration i of the ternary search moved lo up (f(t1) > f(t2)).
    pub path: u32,
    /// [`STEPS_MASK`] | [`FLAG_MOVED`] | [`FLAG_BRACKET`].
    pub flags: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct UnwarpParams {
    width: u32,
    height: u32,
    periodic: u32,
    count: u32,
    theta: f32,
    pin_resolution: [f32; 2],
    _pad: f32,
}

/// The node mesh of one level in f32 (the reference's `Problem`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UnwarpGrid {
    pub width: u32,
    pub height: u32,
    /// Wrap across the border (else the border ring is fixed and never active).
    pub periodic: bool,
    pub theta: f32,
    /// R of the pin barrier (the finest level's W, H).
    pub pin_resolution: [f32; 2],
    /// z = s·h per node, row-major.
    pub z: Vec<f32>,
    /// Pin weight per node.
    pub pins: Vec<f32>,
    /// Node indices of the active texels of each phase.
    pub phases: Vec<Vec<u32>>,
}

impl UnwarpGrid {
    /// [`GpuError::Input`] unless the sizes agree and the active indices are in range.
    pub fn check(&self) -> Result<(), GpuError> {
        let n = self.width as usize * self.height as usize;
        let bad = |what: String| Err(GpuError::Input(format!("unwarp_pass: {what}")));
        if self.width < 2 || self.height < 2 {
            return bad(format!(
                "{}×{} nodes, need at least 2×2",
                self.width, self.height
            ));
        }
        if self.z.len() != n || self.pins.len() != n {
            return bad(format!(
                "{} heights and {} pins for {n} nodes",
                self.z.len(),
                self.pins.len()
            ));
        }
        if let Some(i) = self.phases.iter().flatten().find(|&&i| i as usize >= n) {
            return bad(format!("active texel {i} outside {n} nodes"));
        }
        Ok(())
    }
}

/// The compiled kernel with a level's node data, phases and offsets on the GPU.
pub struct UnwarpPassKernel {
    kernel: ComputeKernel,
    grid: UnwarpGrid,
    z: wgpu::Buffer,
    pins: wgpu::Buffer,
    active: Vec<wgpu::Buffer>,
    params: Vec<wgpu::Buffer>,
    results: Vec<wgpu::Buffer>,
    offsets: wgpu::Buffer,
}

impl UnwarpPassKernel {
    /// Compile the kernel and upload `grid` and the starting `offsets` (one per node).
    pub fn new(gpu: &Gpu, grid: UnwarpGrid, offsets: &[[f32; 2]]) -> Result<Self, GpuError> {
        grid.check()?;
        let source = [DISPATCH_WGSL, WGSL].join("\n");
        let kernel = gpu.compute_kernel("unwarp_pass", &source, "unwarp_pass")?;
        let mut active = Vec::new();
        let mut params = Vec::new();
        let mut results = Vec::new();
        for phase in &grid.phases {
            let count = u32::try_from(phase.len())
                .map_err(|_| GpuError::TooLarge(format!("{} active texels", phase.len())))?;
            active.push(gpu.upload_storage("unwarp_pass active", phase)?);
            params.push(gpu.upload_uniform(
                "unwarp_pass params",
                &UnwarpParams {
                    width: grid.width,
                    height: grid.height,
                    periodic: u32::from(grid.periodic),
                    count,
                    theta: grid.theta,
                    pin_resolution: grid.pin_resolution,
                    _pad: 0.0,
                },
            ));
            results.push(gpu.output_storage::<TexelResult>("unwarp_pass results", phase.len())?);
        }
        let z = gpu.upload_storage("unwarp_pass z", &grid.z)?;
        let pins = gpu.upload_storage("unwarp_pass pins", &grid.pins)?;
        let mut kernel = UnwarpPassKernel {
            kernel,
            z,
            pins,
            active,
            params,
            results,
            offsets: gpu.output_storage::<[f32; 2]>("unwarp_pass offsets", 1)?,
            grid,
        };
        kernel.set_offsets(gpu, offsets)?;
        Ok(kernel)
    }

    /// Replace the offsets on the GPU (one per node).
    pub fn set_offsets(&mut self, gpu: &Gpu, offsets: &[[f32; 2]]) -> Result<(), GpuError> {
        let n = self.grid.width as usize * self.grid.height as usize;
        if offsets.len() != n {
            return Err(GpuError::Input(format!(
                "unwarp_pass: {} offsets for {n} nodes",
                offsets.len()
            )));
        }
        self.offsets = gpu.upload_storage("unwarp_pass offsets", offsets)?;
        Ok(())
    }

    /// Number of phases.
    pub fn phase_count(&self) -> usize {
        self.grid.phases.len()
    }

    fn dispatch(&self, gpu: &Gpu, phase: usize) -> Result<(), GpuError> {
        let count = self.grid.phases.get(phase).map_or(0, Vec::len) as u32;
        if phase >= self.phase_count() {
            return Err(GpuError::Input(format!(
                "unwarp_pass: phase {phase} of {}",
                self.phase_count()
            )));
        }
        gpu.dispatch(
            &self.kernel,
            &[
                &self.params[phase],
                &self.z,
                &self.pins,
                &self.active[phase],
                &self.offsets,
                &self.results[phase],
            ],
            count,
        )
    }

    /// One pass of `phase`: the offsets are updated on the GPU; returns the active texels'
    /// results in the order of the phase's list.
    pub fn pass(&self, gpu: &Gpu, phase: usize) -> Result<Vec<TexelResult>, GpuError> {
        self.dispatch(gpu, phase)?;
        gpu.read_back(&self.results[phase], self.grid.phases[phase].len())
    }

    /// Run the phases `phases` in order without reading anything back, then wait for the GPU
    /// (a one-element readback).
    pub fn passes(&self, gpu: &Gpu, phases: &[usize]) -> Result<(), GpuError> {
        for &phase in phases {
            self.dispatch(gpu, phase)?;
        }
        gpu.read_back::<[f32; 2]>(&self.offsets, 1).map(|_| ())
    }

    /// The current offsets (one per node).
    pub fn offsets(&self, gpu: &Gpu) -> Result<Vec<[f32; 2]>, GpuError> {
        gpu.read_back(
            &self.offsets,
            self.grid.width as usize * self.grid.height as usize,
        )
    }
}
