#![doc = include_str!("README.md")]

pub mod bounds;
pub mod energy;
pub mod energy_naa;
pub mod field;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod gpu_lookup;
#[cfg(feature = "gpu")]
pub mod gpu_naa;
pub mod grid;
mod lanes;
pub mod merit;
pub mod picture;
pub mod plain;
pub mod rasterize;
pub mod remap;
pub mod rigidity;
pub mod scene;
pub mod solve;
mod texel_reads;

pub use energy::{AaEnergy, DeformedFields, LaneCode, RestFields, RestSamples};
pub use energy_naa::{DeformedJacobian, NaaEnergy, NaaModel, NaaRestSamples, VertexGrid};
pub use field::Field;
pub use grid::{grid_from_rigidity, Grid};
pub use remap::{AtlasRemap, Remap, RemapOptions, Warped};
pub use solve::{
    solve_frame, solve_frame_with_rest_samples, solve_naa_frame, solve_naa_frame_with_rest_samples,
    solve_naa_sequence, solve_sequence, FrameSolution, NaaFrameSolution, SolveOptions,
};
