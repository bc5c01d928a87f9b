//! `maps_priority`'s candidate from its twin ([`crate::twin::maps_priority`]): per ring of the
//! vectors' batch, [a(i), κ(i)] as a conforming GPU under a [`Model`] computes them.

use std::path::Path;

use super::maps_rings::rings;
use crate::error::Result;
use crate::twin::maps_priority::{priority_terms, Ring};
use crate::twin::{with_model, Model, F};
use crate::vectors::{Array, KernelVectors};

/// The body of one invocation: a ring's [a(i), κ(i)] (the twin's [`priority_terms`], or a
/// mutant's).
pub type Body = fn(&Ring<F>) -> [F; 2];

/// The candidate of kernel `k` (vectors in `dir`) under `model`: [rings, 2].
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, priority_terms)
}

/// [`candidate`] with each invocation's body `body`.
pub fn candidate_with(dir: &Path, k: &KernelVectors, model: Model, body: Body) -> Result<Array> {
    let rings = rings(dir, k)?;
    let out: Vec<f32> = rings
        .iter()
        .flat_map(|h| {
            crate::twin::coverage::invocation(|| with_model(model, || body(h))).map(F::get)
        })
        .collect();
    Ok(Array::f32(&[rings.len(), 2], out))
}
