#![doc = include_str!("README.md")]

pub mod collapse;
pub mod cost;
pub mod distance;
pub mod evaluate;
pub mod glb;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod hierarchy;
mod lists;
mod pass_order;
pub mod picture;
pub mod poses;
pub mod quadric;
mod queue;
pub mod setup;
pub mod tube;
pub mod weights;

/// The most triangles [`simplify`] takes: face indices are `u32`, and the vertices' face lists
/// (three entries per triangle) share one arena of at most about twice their total length,
/// indexed by `u32` (`lists.rs`). Larger meshes are an [`Error::InvalidArgument`].
pub const MAX_FACES: usize = (u32::MAX / 8) as usize;

use nalgebra::{Matrix4, Point3};

use crate::error::{Error, Result};
use crate::mesh::TriMesh;

pub use collapse::{simplify, simplify_with_progress};
pub use cost::{CostOptions, WeightSolver};
pub use hierarchy::{CollapseRecord, Hierarchy, Level};
pub use weights::Weights;

/// Which collapse cost and which weights the merged vertex gets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Method {
    /// Baseline (i): plain quadrics of the rest pose; the weights of the endpoint nearer to
    /// the new position.
    Rest,
    /// Baseline (ii), Mohr & Gleicher 2003: per-pose quadrics summed over the example poses;
    /// the better endpoint's weights with the optimal position for them.
    Mohr,
    /// Landreneau & Schaefer: per-pose quadrics, position and weights optimised by alternation,
    /// weights reduced to `W_max`. Default.
    #[default]
    Full,
}

impl Method {
    /// All three, baselines first.
    pub const ALL: [Method; 3] = [Method::Rest, Method::Mohr, Method::Full];

    /// `rest`, `mohr`, `full`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Rest => "rest",
            Method::Mohr => "mohr",
            Method::Full => "full",
        }
    }
}

/// The order in which [`simplify`] collapses edges.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Schedule {
    /// Always the cheapest valid edge of the current mesh, re-costing the edges around each
    /// collapse (a priority queue; [`collapse`] module docs). Default: the order of the paper.
    #[default]
    Greedy,
    /// meshoptimizer-style passes: cost and sort every edge, collapse in that order skipping
    /// edges with an endpoint already merged in the pass, repeat. Far fewer cost evaluations
    /// when merged vertices gather many edges, but not the exact greedy order.
    Passes,
}

/// Options of [`simplify`].
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// The collapse cost. Default [`Method::Full`].
    pub method: Method,
    /// Stop when at most this many vertices are left (or no collapse is valid). Default 0:
    /// simplify as far as the validity checks allow, so that every level can be extracted.
    pub target_vertices: usize,
    /// Weight of the boundary / UV-seam constraint planes relative to the face quadrics
    /// ([`quadric::edge_constraint`]). Default 10.
    pub boundary_weight: f64,
    /// The alternating minimisation and weight reduction. Default [`CostOptions::default`].
    pub cost: CostOptions,
    /// The collapse order. Default [`Schedule::Greedy`].
    pub schedule: Schedule,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            method: Method::Full,
            target_vertices: 0,
            boundary_weight: 10.0,
            cost: CostOptions::default(),
            schedule: Schedule::Greedy,
        }
    }
}

impl Options {
    /// Typed errors for out-of-range values.
    pub fn validate(&self) -> Result<()> {
        let c = &self.cost;
        if c.max_weights == 0 || c.max_weights > weights::MAX_INFLUENCES {
            return Err(Error::InvalidArgument(format!(
                "skinsimp: max weights {} must be in 1..={}",
                c.max_weights,
                weights::MAX_INFLUENCES
            )));
        }
        let finite_non_negative = [
            ("boundary weight", self.boundary_weight),
            ("regularisation", c.regularisation),
            ("relative tolerance", c.relative_tolerance),
        ];
        for (what, x) in finite_non_negative {
            if !(x.is_finite() && x >= 0.0) {
                return Err(Error::InvalidArgument(format!(
                    "skinsimp: {what} {x} must be finite and ≥ 0"
                )));
            }
        }
        if c.max_condition.is_nan() || c.max_condition <= 1.0 {
            return Err(Error::InvalidArgument(format!(
                "skinsimp: max condition {} must be > 1",
                c.max_condition
            )));
        }
        Ok(())
    }
}

/// What moves the vertices between poses.
#[derive(Clone, Debug)]
pub enum Deformation {
    /// Linear blend skinning: `p_i^j = Σ_k w_ik M_k^j v̂_i`.
    Skinned {
        /// Per vertex `(joint, weight)` pairs, weights > 0 summing to 1 (any number; vertices
        /// with more than `W_max` are reduced when simplification starts).
        influences: Vec<Vec<(u32, f64)>>,
        /// `joints[j][k] = M_k^j` for every training pose `j` and joint `k`.
        joints: Vec<Vec<Matrix4<f64>>>,
    },
    /// A frame sequence with the mesh's connectivity: `frames[j][i]` is vertex `i` in pose `j`
    /// (no weights: pure per-pose quadrics, each pose placed independently).
    Frames { frames: Vec<Vec<Point3<f64>>> },
}

/// A mesh to simplify: the rest (bind) pose with UVs, and its training poses.
#[derive(Clone, Debug)]
pub struct Input {
    /// Rest pose (for [`Deformation::Frames`]: frame 0's positions are used as rest).
    pub mesh: TriMesh,
    pub deformation: Deformation,
}

impl Input {
    /// Number of training poses.
    pub fn pose_count(&self) -> usize {
        match &self.deformation {
            Deformation::Skinned { joints, .. } => joints.len(),
            Deformation::Frames { frames } => frames.len(),
        }
    }

    /// The original vertices in training pose `j` (skinned with the original weights).
    pub fn posed(&self, j: usize) -> Vec<Point3<f64>> {
        match &self.deformation {
            Deformation::Skinned { influences, joints } => {
                skin(&self.mesh.positions, influences, &joints[j])
            }
            Deformation::Frames { frames } => frames[j].clone(),
        }
    }

    /// Check sizes, indices and numbers: typed errors naming the mesh and the element.
    pub fn validate(&self) -> Result<()> {
        self.mesh.validate()?;
        let name = &self.mesh.name;
        let n = self.mesh.positions.len();
        let bad = |m: String| Err(Error::InvalidArgument(format!("{name}: {m}")));
        if self.mesh.faces.len() > MAX_FACES {
            return bad(format!(
                "{} triangles: skinsimp takes at most {MAX_FACES} (u32 face indices)",
                self.mesh.faces.len()
            ));
        }
        match &self.deformation {
            Deformation::Skinned { influences, joints } => {
                if joints.is_empty() {
                    return bad("no training pose".into());
                }
                if influences.len() != n {
                    return bad(format!(
                        "{} weight lists for {n} vertices",
                        influences.len()
                    ));
                }
                let joint_count = joints[0].len();
                if let Some(j) = joints.iter().position(|p| p.len() != joint_count) {
                    return bad(format!(
                        "pose {j} has {} joint matrices, pose 0 has {joint_count}",
                        joints[j].len()
                    ));
                }
                if let Some(j) = joints
                    .iter()
                    .position(|p| p.iter().any(|m| m.iter().any(|x| !x.is_finite())))
                {
                    return bad(format!("pose {j} has a non-finite joint matrix"));
                }
                for (i, list) in influences.iter().enumerate() {
                    let sum: f64 = list.iter().map(|p| p.1).sum();
                    let ok = !list.is_empty()
                        && list
                            .iter()
                            .all(|&(k, w)| (k as usize) < joint_count && w > 0.0 && w.is_finite())
                        && (sum - 1.0).abs() <= 1e-6;
                    if !ok {
                        return bad(format!(
                            "vertex {i} has invalid skin weights {list:?} (need joints < {joint_count}, weights > 0 summing to 1)"
                        ));
                    }
                }
            }
            Deformation::Frames { frames } => {
                if frames.is_empty() {
                    return bad("no frame".into());
                }
                if let Some(j) = frames.iter().position(|f| f.len() != n) {
                    return bad(format!(
                        "frame {j} has {} vertices, the mesh {n}",
                        frames[j].len()
                    ));
                }
                for (j, f) in frames.iter().enumerate() {
                    if let Some(i) = f.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
                        return bad(format!("frame {j}: vertex {i} is not finite"));
                    }
                }
            }
        }
        Ok(())
    }
}

/// Linear blend skinning `p_i = Σ_k w_ik M_k v̂_i` with `(joint, weight)` lists.
pub fn skin(
    rest: &[Point3<f64>],
    influences: &[Vec<(u32, f64)>],
    mats: &[Matrix4<f64>],
) -> Vec<Point3<f64>> {
    rest.iter()
        .zip(influences)
        .map(|(p, list)| {
            let h = p.to_homogeneous();
            let mut sum = nalgebra::Vector4::zeros();
            for &(k, w) in list {
                sum += (mats[k as usize] * h) * w;
            }
            Point3::new(sum.x, sum.y, sum.z)
        })
        .collect()
}

/// [`skin`] with [`Weights`].
pub fn skin_weights(
    rest: &[Point3<f64>],
    weights: &[Weights],
    mats: &[Matrix4<f64>],
) -> Vec<Point3<f64>> {
    rest.iter()
        .zip(weights)
        .map(|(p, w)| {
            let h = p.to_homogeneous();
            let mut sum = nalgebra::Vector4::zeros();
            for (k, x) in w.pairs() {
                sum += (mats[k as usize] * h) * x;
            }
            Point3::new(sum.x, sum.y, sum.z)
        })
        .collect()
}
