//! # gridwarp — content-aware texture grid warp (seed 000)
//!
//! Koniaris, Cosker, Yang, Mitchell, Matthews, "Real-time content-aware texturing for deformable
//! surfaces", CVMP 2013; restated in `../shared/notes/gridwarp.md`.
//!
//! A texture-space region of interest (ROI, the unit square in (s, t)) is covered by a
//! rectilinear grid. When the surface deforms, the grid lines move so that rigid texture content
//! (rigidity R ≈ 1) keeps its rest-pose stretch, at the expense of non-rigid content; the texture
//! is then looked up through the piecewise-linear remapping of the grid.
//!
//! **Reading the energies:** start with [`plain`], the axis-aligned and non-axis-aligned
//! energies written sample by sample as the paper states them (plain loops, one function per
//! quantity). [`energy`] and [`energy_naa`] are the fast path: the same residuals in lane
//! arrays, texel tables and SIMD dispatch, tested against [`plain`] (`tests/gridwarp_plain.rs`).
//! The layers, bottom up: [`field`], [`grid`] → the lane machinery (`lanes`, `texel_reads`) →
//! the energies ([`energy`], [`energy_naa`], [`plain`]) → [`bounds`] and [`solve`].
//!
//! | stage | seed | file |
//! |---|---|---|
//! | **the energies as the paper states them, sample by sample (start here)** | §5.1, §8, appendix A | [`plain`] |
//! | fields ‖O_s‖, ‖O_t‖, ‖D_s‖, ‖D_t‖, R over the ROI | §3.1, §7 | [`field`] |
//! | the same fields (and D_s, D_t vectors) rasterised from meshes over a UV ROI | §3.1, §7 | [`rasterize`] |
//! | starting grid from R (Algorithm 1) | §4 | [`grid`] |
//! | axis-aligned energy, analytic Jacobian | §5.1, appendix A | [`energy`] |
//! | non-axis-aligned energy (bilinear cells), analytic Jacobian | §8 | [`energy_naa`] |
//! | its optional second-order model JᵀJ + Σ r∇²r ([`NaaModel::Newton`], [`NaaModel::Adaptive`]) | — | [`energy_naa::curvature`] |
//! | foldover / smoothness / looping bounds and their merge | §5.2 | [`bounds`] |
//! | bound-constrained Levenberg–Marquardt, warm start | §5.3, §7 | [`solve`], [`crate::lm`] |
//! | remapping F_s, F_t and inverses, inverse bilinear lookup, boundary blending, several ROIs | §6, §8, §10.2 | [`remap`] |
//! | rigidity maps from a texture's detail or from discs | §9 | [`rigidity`] |
//! | procedural scenes | figs. 3, 5, 9 | [`scene`] |
//! | rigid-stretch figure of merit, pictures | — | [`merit`], [`picture`] |

pub mod bounds;
pub mod energy;
pub mod energy_naa;
pub mod field;
#[cfg(feature = "gpu")]
pub mod gpu;
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
