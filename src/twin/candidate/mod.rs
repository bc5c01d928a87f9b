//! The twins run over a kernel's conformance-vector inputs: the candidate array a conforming
//! GPU under a given arithmetic model would hand to verify.
//!
//! One file per kernel. Each reads the kernel's inputs from the vectors' folder, runs the
//! twin's entry point once per element (as the WGSL's invocations do) under a [`Model`], and
//! lays the outputs out as the manifest's `expected` array. `crosscheck --sweep` and the twin
//! tests (`tests/twin_*.rs`) call them; the tests' mutants plug their own body in.
//!
//! [`Model`]: super::Model

pub mod bpm;
pub mod gridwarp_aa;
pub mod gridwarp_lookup;
pub mod maps_flatten;
pub mod maps_inverse;
pub mod maps_priority;
pub mod maps_rings;
pub mod skinsimp_collapse_cost;
pub mod skinsimp_lbs;
pub mod skinsimp_quadrics;
pub mod unwarp_pass;

use std::path::Path;

use crate::error::Result;
use crate::vectors::{Array, KernelVectors};

/// An [`crate::Error::Vectors`] about kernel `k`'s inputs.
pub fn invalid(k: &KernelVectors, reason: String) -> crate::Error {
    crate::Error::Vectors {
        file: k.name.clone(),
        reason,
    }
}

/// An array's values as the f32 a kernel reads.
pub fn as_f32(a: &Array) -> Vec<f32> {
    a.to_f64().iter().map(|&x| x as f32).collect()
}

/// An array's values as the u32 a kernel reads.
pub fn as_u32(a: &Array) -> Vec<u32> {
    a.to_f64().iter().map(|&x| x as u32).collect()
}

/// A twin's run over its vectors: `(folder, manifest entry, model) → candidate`.
pub type Runner = fn(&Path, &KernelVectors, super::Model) -> Result<Array>;

/// The runner of kernel `name` (as the manifests name it), for the kernels whose twins run over
/// their vectors here.
pub fn runner(name: &str) -> Option<Runner> {
    match name {
        "bpm_eval" => Some(bpm::bpm_eval),
        "bpm_eval_linear" => Some(bpm::bpm_eval_linear),
        "bpm_precompute" => Some(bpm::bpm_precompute),
        "gridwarp_aa.residuals" => Some(gridwarp_aa::residuals),
        "gridwarp_aa.cell_energy"
        | "gridwarp_aa.energy"
        | "gridwarp_aa.jtj"
        | "gridwarp_aa.jtr" => Some(gridwarp_aa::normal_equations),
        "gridwarp_lookup" => Some(gridwarp_lookup::candidate),
        "maps_flatten.points" | "maps_flatten.rings" => Some(maps_flatten::candidate),
        "maps_inverse" => Some(maps_inverse::candidate),
        "maps_priority" => Some(maps_priority::candidate),
        "skinsimp_collapse_cost" => Some(skinsimp_collapse_cost::candidate),
        "skinsimp_lbs" => Some(skinsimp_lbs::candidate),
        "skinsimp_quadrics.source" => Some(skinsimp_quadrics::source_candidate),
        "skinsimp_quadrics.vertex" => Some(skinsimp_quadrics::vertex_candidate),
        "unwarp_pass" => Some(unwarp_pass::candidate),
        _ => None,
    }
}

/// The branch catalogue ([`crate::twin::coverage`]) of kernel `name`, for the kernels whose
/// twins report their branches.
pub fn branches(name: &str) -> Option<&'static [crate::twin::coverage::Branch]> {
    use crate::twin::{
        maps_flatten, maps_inverse, maps_priority, skinsimp_collapse_cost, skinsimp_lbs,
        skinsimp_quadrics, unwarp_pass,
    };
    match name {
        "maps_flatten.points" | "maps_flatten.rings" => Some(maps_flatten::BRANCHES),
        "maps_inverse" => Some(maps_inverse::BRANCHES),
        "maps_priority" => Some(maps_priority::BRANCHES),
        "skinsimp_collapse_cost" => Some(skinsimp_collapse_cost::BRANCHES),
        "skinsimp_lbs" => Some(skinsimp_lbs::BRANCHES),
        "skinsimp_quadrics.source" => Some(skinsimp_quadrics::SOURCE_BRANCHES),
        "skinsimp_quadrics.vertex" => Some(skinsimp_quadrics::VERTEX_BRANCHES),
        "unwarp_pass" => Some(unwarp_pass::BRANCHES),
        _ => None,
    }
}
