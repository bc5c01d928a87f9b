//! Bridge between the f64 unwarp reference and the f32 `unwarp_pass` kernel of `reparam-gpu`
//! (`shaders/unwarp_pass.wgsl`, the twin of [`super::pass::descend_texel`]).
//!
//! [`GpuPass`] implements [`PassBackend`], so [`super::solve_with`] runs the same sweeps and
//! coarse-to-fine with the passes on the GPU: per pass the offsets are rounded to f32 and
//! uploaded, the kernel updates the phase's texels, the results are read back into the f64
//! offsets (the energy per pass is then measured in f64 on the CPU, as for the reference).

use reparam_gpu::unwarp::{TexelResult, UnwarpGrid, UnwarpPassKernel};
use reparam_gpu::Gpu;

use super::solve::{solve_with, PassBackend, Progress, Solution};
use super::{HeightMap, Problem, UnwarpOptions};
use crate::error::{Error, Result};

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

/// A GPU context ([`Error::Gpu`] when there is no adapter).
pub fn context() -> Result<Gpu> {
    Gpu::new().map_err(gpu_error)
}

/// The kernel's input for `problem`: z and pin weights rounded to f32, the active texels of
/// every phase in the reference's order ([`super::UnwarpMesh::active_texels`]).
pub fn grid_for(problem: &Problem) -> UnwarpGrid {
    let mesh = &problem.mesh;
    UnwarpGrid {
        width: mesh.width as u32,
        height: mesh.height as u32,
        periodic: mesh.border == super::Border::Periodic,
        theta: problem.theta as f32,
        pin_resolution: problem.pin_resolution.map(|r| r as f32),
        z: mesh.z.iter().map(|&v| v as f32).collect(),
        pins: problem.pins.iter().map(|&v| v as f32).collect(),
        phases: (0..mesh.phase_count())
            .map(|p| {
                mesh.active_texels(p)
                    .iter()
                    .map(|&(x, y)| mesh.index(x, y) as u32)
                    .collect()
            })
            .collect(),
    }
}

/// `problem` with z and the pin weights rounded to f32: the reference run on the GPU's inputs.
pub fn round_problem(problem: &Problem) -> Problem {
    let mut rounded = problem.clone();
    rounded
        .mesh
        .z
        .iter_mut()
        .for_each(|v| *v = *v as f32 as f64);
    rounded.pins.iter_mut().for_each(|v| *v = *v as f32 as f64);
    rounded.theta = problem.theta as f32 as f64;
    rounded
}

/// Offsets rounded to f32.
pub fn offsets_to_f32(offsets: &[[f64; 2]]) -> Vec<[f32; 2]> {
    offsets.iter().map(|o| [o[0] as f32, o[1] as f32]).collect()
}

/// Passes on the GPU; the kernel is rebuilt when the level (grid) changes.
pub struct GpuPass {
    gpu: Gpu,
    kernel: Option<(UnwarpGrid, UnwarpPassKernel)>,
    /// The per-texel results of the last pass, in the phase's active order.
    pub last_results: Vec<TexelResult>,
}

impl GpuPass {
    pub fn new(gpu: Gpu) -> GpuPass {
        GpuPass {
            gpu,
            kernel: None,
            last_results: Vec::new(),
        }
    }

    /// One pass of `phase` from `offsets` (rounded to f32), returning the results; `offsets`
    /// is updated with the new f32 offsets of the active texels.
    pub fn run(
        &mut self,
        problem: &Problem,
        offsets: &mut [[f64; 2]],
        phase: usize,
    ) -> Result<&[TexelResult]> {
        let grid = grid_for(problem);
        let start = offsets_to_f32(offsets);
        match &mut self.kernel {
            Some((g, kernel)) if *g == grid => {
                kernel.set_offsets(&self.gpu, &start).map_err(gpu_error)?
            }
            _ => {
                let kernel =
                    UnwarpPassKernel::new(&self.gpu, grid.clone(), &start).map_err(gpu_error)?;
                self.kernel = Some((grid, kernel));
            }
        }
        let (grid, kernel) = self.kernel.as_ref().expect("kernel built above");
        self.last_results = kernel.pass(&self.gpu, phase).map_err(gpu_error)?;
        for (&i, r) in grid.phases[phase].iter().zip(&self.last_results) {
            offsets[i as usize] = [r.offset[0] as f64, r.offset[1] as f64];
        }
        Ok(&self.last_results)
    }
}

impl PassBackend for GpuPass {
    fn pass(&mut self, problem: &Problem, offsets: &mut [[f64; 2]], phase: usize) -> Result<()> {
        self.run(problem, offsets, phase).map(|_| ())
    }
}

/// [`super::solve()`] with the passes on the GPU; also returns the adapter's description.
pub fn solve_gpu(
    heights: &HeightMap,
    options: &UnwarpOptions,
    progress: impl FnMut(&Progress),
) -> Result<(Solution, String)> {
    let gpu = context()?;
    let adapter = gpu.adapter_summary();
    let mut backend = GpuPass::new(gpu);
    Ok((
        solve_with(&mut backend, heights, options, progress)?,
        adapter,
    ))
}
