#![doc = include_str!("README.md")]

pub mod apply;
pub mod coarse_move;
pub mod energy;
pub mod fixation;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod height;
pub mod mesh;
pub mod output;
pub mod pass;
pub mod solve;
pub mod stats;

pub use energy::{total_energy, Energy};
pub use fixation::FixationOptions;
pub use height::{load_height_map, procedural, HeightMap};
pub use mesh::{Border, UnwarpMesh};
pub use solve::{solve, solve_with, CpuPass, PassBackend, Progress, Solution};

use crate::error::{Error, Result};

/// Everything the solver needs besides the height map.
#[derive(Clone, Debug, PartialEq)]
pub struct UnwarpOptions {
    /// Displacement scale s in texture-width units (node z = s·h). Default 0.05 (the demo's).
    pub scale: f64,
    /// Area exponent θ of the energy. Default 5 (the demo's; the HLSL port uses 3).
    pub theta: f64,
    /// Periodic (tileable) or fixed border. Default periodic.
    pub border: Border,
    /// Pinning. Default h_fix = 0, Δ = 0.04, no mask.
    pub fixation: FixationOptions,
    /// Sweeps (of 4, or 3, passes) on the finest level. Default 60 (240 passes).
    pub sweeps: usize,
    /// Stop a level early when a sweep lowers the energy by less than this, relatively.
    /// Default none (always run `sweeps`).
    pub tolerance: Option<f64>,
    /// Levels of coarse-to-fine (1 = single level). Default 1.
    pub levels: usize,
    /// Sweeps on each coarser level. Default 30.
    pub coarse_sweeps: usize,
    /// Scales of coarse moves at the end of every sweep on every level (r = 2, 4, …, 2^n;
    /// [`coarse_move`]); 0 = texel passes only, the paper's scheme. Default 0.
    pub coarse_moves: usize,
}

impl Default for UnwarpOptions {
    fn default() -> Self {
        UnwarpOptions {
            scale: 0.05,
            theta: 5.0,
            border: Border::Periodic,
            fixation: FixationOptions::default(),
            sweeps: 60,
            tolerance: None,
            levels: 1,
            coarse_sweeps: 30,
            coarse_moves: 0,
        }
    }
}

/// One level's problem: the node mesh, θ and the pin weight of every node.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    pub mesh: UnwarpMesh,
    pub theta: f64,
    /// Pin weight w ∈ [0, 1] per node, row-major.
    pub pins: Vec<f64>,
    /// R of the pin barrier ½/(1 − ‖w R⊙o‖²): the *finest* level's (W, H) on every level, so
    /// a pin's radius 1/w is in texels of the final map whatever level is being solved.
    pub pin_resolution: [f64; 2],
}

impl Problem {
    /// The problem of `heights` under `options` (mesh, pin weights). Errors: the mesh's
    /// ([`UnwarpMesh::new`]), the fixation's ([`fixation::pin_weights`]), θ not finite or
    /// negative, a negative tolerance ([`Error::InvalidArgument`]).
    pub fn new(heights: &HeightMap, options: &UnwarpOptions) -> Result<Problem> {
        if !(options.theta.is_finite() && options.theta >= 0.0) {
            return Err(Error::InvalidArgument(format!(
                "θ = {} must be finite and ≥ 0",
                options.theta
            )));
        }
        if let Some(tol) = options.tolerance {
            if !(tol.is_finite() && tol >= 0.0) {
                return Err(Error::InvalidArgument(format!(
                    "tolerance {tol} must be finite and ≥ 0"
                )));
            }
        }
        let mesh = UnwarpMesh::new(heights, options.scale, options.border)?;
        let pins = fixation::pin_weights(heights, &options.fixation)?;
        Ok(Problem {
            pin_resolution: mesh.resolution(),
            mesh,
            theta: options.theta,
            pins,
        })
    }
}
