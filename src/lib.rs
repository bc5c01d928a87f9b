//! # reparam
//!
//! Reference implementations of texture-parameterisation algorithms: a rayon-parallel f64
//! ground truth for each, and f32 wgpu kernels of the same computations (crate `reparam-gpu`),
//! compared by [`crosscheck`].
//!
//! | module | algorithm | source | entry points |
//! |---|---|---|---|
//! | [`bpm`] | Blended Piecewise Möbius Maps (Rorberg, Vaxman, Ben-Chen 2023) | seed 004 | [`bpm::precompute()`], [`bpm::Bpm::eval`], [`bpm::qc_protocol`] |
//! | [`gridwarp`] | content-aware texture grid warp (Koniaris et al. 2013) | seed 000 | [`gridwarp::solve_sequence`], [`gridwarp::solve_naa_frame`] |
//! | [`unwarp`] | distortion-free displacement mapping by per-texel descent (Zirr & Ritschel 2019) | seed 001 | [`unwarp::solve()`], [`unwarp::pass::pass`] |
//! | [`skinsimp`] | quadric simplification of skinned meshes with optimised weights (Landreneau & Schaefer 2009) | seed 003 | [`skinsimp::simplify()`], [`skinsimp::Hierarchy::level`], [`skinsimp::evaluate::compare`] |
//! | [`maps`] | MAPS multiresolution parameterisation and remeshing (Lee et al. 1998) | seed 002 | [`maps::build`], [`maps::Param::inverse`], [`maps::remesh::uniform`], [`maps::remesh::adaptive`] |
//! | [`lm`] | box-constrained Levenberg–Marquardt (ALGLIB minlm semantics) | seed 000 §5.3 | [`lm::minimize`] |
//!
//! Shared layers: [`mesh`] (TriMesh with separate position and UV indices, adjacency, OBJ and
//! glTF I/O, skinning, built-in meshes), [`texture`] (images), [`raster`] (the CPU reference
//! rasteriser), [`report`] and [`reference_data`]; [`input`] reads files within bounds (counts
//! checked before allocation, regular files only, references kept in the model's folder).
//! Every fallible function returns [`Error`], whose variants name the element and the file.

pub mod bpm;
/// The `reparam` command line (the binary is `fn main() { reparam::cli::main() }`), in the
/// library so that tests can run every command in-process ([`cli::run_captured`]).
#[doc(hidden)]
pub mod cli;
pub mod crosscheck;
pub mod error;
pub mod gridwarp;
pub mod input;
pub mod lbfgs;
pub mod lm;
pub mod maps;
pub mod mesh;
pub mod plot;
pub mod raster;
pub mod reference_data;
pub mod report;
pub mod skinsimp;
pub mod texture;
pub mod twin;
pub mod unwarp;
#[cfg(feature = "gpu")]
pub mod vectors;

pub use error::{Error, Result};
