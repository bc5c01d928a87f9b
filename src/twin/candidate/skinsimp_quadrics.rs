//! `skinsimp_quadrics`' candidates from its twin ([`crate::twin::skinsimp_quadrics`]):
//! `.source`, every source's quadric at every pose ([sources, poses, 10]), and `.vertex`, every
//! vertex's sum of its sources' quadrics at every pose ([vertices, poses, 10]), as a
//! conforming GPU under a [`Model`] computes them.

use std::path::Path;

use super::{as_u32, invalid};
use crate::error::Result;
use crate::twin::skinsimp_quadrics::{plane_quadric, vertex_quadric, Quadric};
use crate::twin::{with_model, Model, F, V3};
use crate::vectors::{Array, KernelVectors};

/// The body of one source invocation: (kind, posed corners, boundary weight) → its quadric
/// (the twin's [`plane_quadric`], or a mutant's).
pub type SourceBody = fn(u32, [V3<F>; 3], F) -> Quadric<F>;

/// How a port gathers vertex v's sources: (CSR offsets, source ids, kinds, v) → the ids it sums.
pub type Gather = fn(&[usize], &[usize], &[u32], usize) -> Vec<usize>;

/// Which pose's source quadrics a port reads for pose j.
pub type PoseOf = fn(usize) -> usize;

/// The sources' inputs as the kernels' bindings hold them: posed vertices [V, P, 3], each
/// source's corners and kind, the boundary weight.
struct Sources {
    posed: Vec<f64>,
    poses: usize,
    corners: Vec<f64>,
    kind: Vec<u32>,
    weight: F,
}

impl Sources {
    /// Errors: a missing input; a source whose corner is not a posed vertex.
    fn load(dir: &Path, k: &KernelVectors) -> Result<Sources> {
        let posed = k.load_input(dir, "posed")?;
        let vertices = posed.shape.first().copied().unwrap_or(0);
        let x = Sources {
            poses: posed.shape.get(1).copied().unwrap_or(0),
            posed: posed.to_f64(),
            corners: k.load_input(dir, "corners")?.to_f64(),
            kind: as_u32(&k.load_input(dir, "kind")?),
            weight: F::new(
                k.load_input(dir, "boundary_weight")?
                    .to_f64()
                    .first()
                    .copied()
                    .unwrap_or(0.0) as f32,
            ),
        };
        let short = x.corners.len() < 3 * x.kind.len();
        if short || x.corners.iter().any(|&c| c as usize >= vertices) {
            return Err(invalid(
                k,
                format!("every source needs 3 corners among the {vertices} posed vertices"),
            ));
        }
        Ok(x)
    }

    /// Source s's quadric at pose j by `body` under `model`.
    fn quadric(&self, s: usize, j: usize, model: Model, body: SourceBody) -> Quadric<F> {
        let p = [0, 1, 2].map(|c| {
            let v = self.corners[3 * s + c] as usize;
            let o = 3 * (v * self.poses + j);
            V3::new(
                F::new(self.posed[o] as f32),
                F::new(self.posed[o + 1] as f32),
                F::new(self.posed[o + 2] as f32),
            )
        });
        crate::twin::coverage::invocation(|| {
            with_model(model, || body(self.kind[s], p, self.weight))
        })
    }
}

/// `.source`'s candidate (vectors in `dir`, manifest entry `k`) under `model`.
pub fn source_candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    source_candidate_with(dir, k, model, plane_quadric)
}

/// [`source_candidate`] with each invocation's body `body`.
pub fn source_candidate_with(
    dir: &Path,
    k: &KernelVectors,
    model: Model,
    body: SourceBody,
) -> Result<Array> {
    let x = Sources::load(dir, k)?;
    let sources = x.kind.len();
    let mut out = Vec::with_capacity(sources * x.poses * 10);
    for s in 0..sources {
        for j in 0..x.poses {
            out.extend(x.quadric(s, j, model, body).iter().map(|q| q.get()));
        }
    }
    Ok(Array::f32(&[sources, x.poses, 10], out))
}

/// The CSR layout as stored: vertex v sums `sources[offsets[v]..offsets[v + 1]]`.
pub fn as_stored(offsets: &[usize], sources: &[usize], _: &[u32], v: usize) -> Vec<usize> {
    sources[offsets[v]..offsets[v + 1]].to_vec()
}

/// `.vertex`'s candidate under `model`.
pub fn vertex_candidate(dir: &Path, k: &KernelVectors, model: Model) -> Result<Array> {
    vertex_candidate_with(dir, k, model, as_stored, |j| j)
}

/// [`vertex_candidate`] with a port's `gather` and `pose_of`: each source's quadric by the
/// twin, then each vertex's [`vertex_quadric`] of the sources `gather` names, read at pose
/// `pose_of(j)`.
pub fn vertex_candidate_with(
    dir: &Path,
    k: &KernelVectors,
    model: Model,
    gather: Gather,
    pose_of: PoseOf,
) -> Result<Array> {
    let x = Sources::load(dir, k)?;
    let as_usize = |name: &str| -> Result<Vec<usize>> {
        let indices = as_u32(&k.load_input(dir, name)?);
        Ok(indices.into_iter().map(|v| v as usize).collect())
    };
    let offsets = as_usize("vertex_offsets")?;
    let sources = as_usize("vertex_sources")?;
    let sorted = offsets.windows(2).all(|w| w[0] <= w[1]);
    if !sorted
        || offsets.last().is_some_and(|&e| e > sources.len())
        || sources.iter().any(|&s| s >= x.kind.len())
    {
        return Err(invalid(
            k,
            "vertex_offsets must rise to at most the number of vertex_sources, each a source \
             index"
                .into(),
        ));
    }
    let vertices = offsets.len().saturating_sub(1);
    let mut out = Vec::with_capacity(vertices * x.poses * 10);
    for v in 0..vertices {
        for j in 0..x.poses {
            let q = crate::twin::coverage::invocation(|| {
                let qs: Vec<Quadric<F>> = gather(&offsets, &sources, &x.kind, v)
                    .into_iter()
                    .map(|s| x.quadric(s, pose_of(j), model, plane_quadric))
                    .collect();
                with_model(model, || vertex_quadric(&qs))
            });
            out.extend(q.iter().map(|q| q.get()));
        }
    }
    Ok(Array::f32(&[vertices, x.poses, 10], out))
}
