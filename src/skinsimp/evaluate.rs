//! Quality of a simplified skinned mesh (SPEC.md § 10): per example pose, the
//! [`surface_error`] between the original mesh (skinned with its own weights) and the level
//! (skinned with its new weights), summarised over the training and the held-out poses, for
//! the three methods at equal vertex counts.

use std::time::Instant;

use super::distance::{surface_error, SurfaceError};
use super::poses::{joint_matrices, skinned_input, ExamplePose, PoseSets};
use super::{simplify, Hierarchy, Level, Method, Options};
use crate::error::Result;
use crate::mesh::SkinnedMesh;

/// Errors over a set of poses.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PoseSetError {
    pub poses: usize,
    /// Mean over poses of the per-pose RMS distance.
    pub rms_mean: f64,
    /// Largest per-pose RMS distance.
    pub rms_max: f64,
    /// Largest per-pose (sampled) Hausdorff distance.
    pub hausdorff_max: f64,
    /// Per pose, in the order given.
    pub per_pose: Vec<SurfaceError>,
}

/// One method's result in a comparison.
#[derive(Clone, Debug, serde::Serialize)]
pub struct MethodQuality {
    pub method: &'static str,
    pub vertices: usize,
    pub faces: usize,
    pub training: PoseSetError,
    pub held_out: PoseSetError,
    /// Wall-clock seconds of [`simplify`].
    pub seconds: f64,
}

/// The errors of `level` against `model` in each of `poses`.
pub fn pose_set_error(
    model: &SkinnedMesh,
    level: &Level,
    poses: &[ExamplePose],
) -> Result<PoseSetError> {
    let mut per_pose = Vec::with_capacity(poses.len());
    for &pose in poses {
        let original = model.pose(pose.animation, pose.time)?;
        let simplified = level.posed(&joint_matrices(model, pose)?);
        per_pose.push(surface_error(
            &original,
            &model.mesh.faces,
            &simplified,
            &level.mesh.faces,
        ));
    }
    let n = per_pose.len().max(1) as f64;
    Ok(PoseSetError {
        poses: per_pose.len(),
        rms_mean: per_pose.iter().map(|e| e.rms).sum::<f64>() / n,
        rms_max: per_pose.iter().fold(0.0, |m, e| m.max(e.rms)),
        hausdorff_max: per_pose.iter().fold(0.0, |m, e| m.max(e.hausdorff)),
        per_pose,
    })
}

/// Simplify `model` with each of `methods` (training poses of `poses`, `target_vertices`),
/// extract every hierarchy at the same vertex count (the largest count any of them stopped at,
/// so that all reach it), and evaluate on training and held-out poses.
pub fn compare(
    model: &SkinnedMesh,
    poses: &PoseSets,
    methods: &[Method],
    options: &Options,
) -> Result<Vec<MethodQuality>> {
    let input = skinned_input(model, &poses.training)?;
    let mut runs: Vec<(Method, Hierarchy, f64)> = Vec::new();
    for &method in methods {
        let start = Instant::now();
        let h = simplify(&input, &Options { method, ..*options })?;
        runs.push((method, h, start.elapsed().as_secs_f64()));
    }
    let reached = runs
        .iter()
        .map(|(_, h, _)| h.input_vertices() - h.records.len())
        .max()
        .unwrap_or(0);
    runs.iter()
        .map(|(method, h, seconds)| {
            let level = h.level(h.collapses_for(reached));
            Ok(MethodQuality {
                method: method.name(),
                vertices: level.mesh.positions.len(),
                faces: level.mesh.faces.len(),
                training: pose_set_error(model, &level, &poses.training)?,
                held_out: pose_set_error(model, &level, &poses.held_out)?,
                seconds: *seconds,
            })
        })
        .collect()
}
