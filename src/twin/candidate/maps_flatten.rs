//! `maps_flatten`'s candidates from its twin ([`crate::twin::maps_flatten`]) as a conforming
//! GPU under a [`Model`] computes them: `maps_flatten.points`, per ring slot (μ_x, μ_y, θ_k, r_k)
//! (the kernel's `FlatPoint`), and `maps_flatten.rings`, per ring (a, a₂, θ_total, status)
//! (`FlatRing`, the status as a number).

use std::path::Path;

use super::maps_rings::rings;
use crate::error::{Error, Result};
use crate::twin::maps_flatten::{flatten_ring, FlatPoint, FlatRing};
use crate::twin::maps_priority::Ring;
use crate::twin::{with_model, Model, F};
use crate::vectors::{Array, KernelVectors};

/// The body of one invocation: a ring's flattening (the twin's [`flatten_ring`], or a
/// mutant's).
pub type Body = fn(&Ring<F>) -> (FlatRing<F>, Vec<FlatPoint<F>>);

/// The candidate of kernel `k` (`maps_flatten.points` or `maps_flatten.rings`, vectors in
/// `dir`) under `model`.
pub fn candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    candidate_with(dir, k, model, flatten_ring)
}

/// [`candidate`] with each invocation's body `body`.
pub fn candidate_with(dir: &Path, k: &KernelVectors, model: Model, body: Body) -> Result<Array> {
    let rings = rings(dir, k)?;
    let flat: Vec<_> = rings
        .iter()
        .map(|h| crate::twin::coverage::invocation(|| with_model(model, || body(h))))
        .collect();
    if k.name.ends_with(".points") {
        let out: Vec<f32> = flat
            .iter()
            .flat_map(|(_, points)| {
                points
                    .iter()
                    .flat_map(|p| [p.mu.x.get(), p.mu.y.get(), p.theta.get(), p.radius.get()])
            })
            .collect();
        Ok(Array::f32(&[out.len() / 4, 4], out))
    } else if k.name.ends_with(".rings") {
        let out: Vec<f32> = flat
            .iter()
            .flat_map(|(r, _)| [r.a.get(), r.a2.get(), r.theta_total.get(), r.status as f32])
            .collect();
        Ok(Array::f32(&[rings.len(), 4], out))
    } else {
        Err(Error::InvalidArgument(format!(
            "{}: not a maps_flatten kernel (maps_flatten.points, maps_flatten.rings)",
            k.name
        )))
    }
}
