//! Example poses of a skinned glTF model (SPEC.md § 1): which animation
//! times train the simplification and which are held out for evaluation, and the joint
//! matrices `M_k^j = G(joint_k, pose j) · IBM_k` at those times.

use nalgebra::Matrix4;

use super::{Deformation, Input};
use crate::error::{Error, Result};
use crate::mesh::SkinnedMesh;

/// How example poses are chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum PoseSelection {
    /// Every distinct key time of the named clips (all clips when `None`), in time order;
    /// even-numbered keys train, odd-numbered keys are held out (every other keyframe).
    Keyframes(Option<Vec<String>>),
    /// Per clip, `2N` uniform times `t_i = i·T/(2N − 1)`, `i = 0 … 2N − 1` (T the clip's
    /// length); even `i` train, odd `i` are held out. `N ≥ 1`.
    Uniform(usize),
}

impl Default for PoseSelection {
    /// `Keyframes(None)`: every keyframe of every clip.
    fn default() -> Self {
        PoseSelection::Keyframes(None)
    }
}

/// An animation time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExamplePose {
    pub animation: usize,
    pub time: f64,
}

/// Training and held-out poses.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseSets {
    pub training: Vec<ExamplePose>,
    pub held_out: Vec<ExamplePose>,
}

/// The poses of `selection` for `model`. Errors: no skin, no animation, an unknown clip name,
/// `Uniform(0)`.
pub fn select_poses(model: &SkinnedMesh, selection: &PoseSelection) -> Result<PoseSets> {
    require_skin(model)?;
    if model.animations.is_empty() {
        return Err(Error::InvalidArgument(format!(
            "{}: the file has a skin but no animation: there are no example poses",
            model.mesh.name
        )));
    }
    let mut sets = PoseSets {
        training: Vec::new(),
        held_out: Vec::new(),
    };
    match selection {
        PoseSelection::Keyframes(clips) => {
            for a in clip_indices(model, clips.as_deref())? {
                let mut times: Vec<f64> = model.animations[a]
                    .channels
                    .iter()
                    .flat_map(|c| c.times.iter().copied())
                    .collect();
                times.sort_by(f64::total_cmp);
                times.dedup();
                split_alternating(&mut sets, a, &times);
            }
        }
        PoseSelection::Uniform(n) => {
            if *n == 0 {
                return Err(Error::InvalidArgument(
                    "uniform pose count must be ≥ 1".into(),
                ));
            }
            for a in 0..model.animations.len() {
                let length = model.duration(a)?;
                let count = 2 * n;
                let times: Vec<f64> = (0..count)
                    .map(|i| length * i as f64 / (count - 1) as f64)
                    .collect();
                split_alternating(&mut sets, a, &times);
            }
        }
    }
    Ok(sets)
}

/// Even-indexed times train, odd-indexed are held out.
fn split_alternating(sets: &mut PoseSets, animation: usize, times: &[f64]) {
    for (i, &time) in times.iter().enumerate() {
        let pose = ExamplePose { animation, time };
        if i % 2 == 0 {
            sets.training.push(pose);
        } else {
            sets.held_out.push(pose);
        }
    }
}

/// Animation indices of the named clips (all when `None`).
fn clip_indices(model: &SkinnedMesh, clips: Option<&[String]>) -> Result<Vec<usize>> {
    match clips {
        None => Ok((0..model.animations.len()).collect()),
        Some(names) => names
            .iter()
            .map(|name| {
                model.animation_index(name).ok_or_else(|| {
                    Error::InvalidArgument(format!(
                        "{}: no animation {name:?} (the file has {:?})",
                        model.mesh.name,
                        model.animation_names()
                    ))
                })
            })
            .collect(),
    }
}

/// The typed error for a model without skin (the frame-sequence path is the alternative).
fn require_skin(model: &SkinnedMesh) -> Result<()> {
    if model.skeleton.is_none() || model.influences.is_empty() {
        return Err(Error::InvalidArgument(format!(
            "{}: the file has no skinned mesh (no skin with joints and weights); skinsimp needs \
             one, or a sequence of OBJ frames with shared connectivity (`--frames`)",
            model.mesh.name
        )));
    }
    Ok(())
}

/// `M_k = G(joint_k, τ) · IBM_k` for every joint at `pose`.
pub fn joint_matrices(model: &SkinnedMesh, pose: ExamplePose) -> Result<Vec<Matrix4<f64>>> {
    require_skin(model)?;
    let skeleton = model.skeleton.as_ref().expect("checked");
    let animation = model.animations.get(pose.animation).ok_or_else(|| {
        Error::InvalidArgument(format!(
            "{}: no animation {}",
            model.mesh.name, pose.animation
        ))
    })?;
    let local = skeleton.local_transforms(Some(animation), pose.time);
    Ok(skeleton.joint_matrices(&skeleton.world_matrices(&local)))
}

/// The simplification input of a skinned model with the given training poses.
pub fn skinned_input(model: &SkinnedMesh, training: &[ExamplePose]) -> Result<Input> {
    require_skin(model)?;
    let joints = training
        .iter()
        .map(|&p| joint_matrices(model, p))
        .collect::<Result<Vec<_>>>()?;
    let influences = model
        .influences
        .iter()
        .map(|list| list.iter().map(|i| (i.joint, i.weight)).collect())
        .collect();
    let input = Input {
        mesh: model.mesh.clone(),
        deformation: Deformation::Skinned { influences, joints },
    };
    input.validate()?;
    Ok(input)
}

/// The simplification input of a frame sequence with shared connectivity: `frames[0]` is the
/// rest mesh (with its UVs); every other frame must have the same faces. Errors name the frame.
pub fn frames_input(frames: &[crate::mesh::TriMesh]) -> Result<Input> {
    let first = frames
        .first()
        .ok_or_else(|| Error::InvalidArgument("no frame given".into()))?;
    for f in frames {
        if f.faces != first.faces || f.positions.len() != first.positions.len() {
            return Err(Error::InvalidArgument(format!(
                "{}: connectivity differs from {} (frames need the same vertices and faces)",
                f.name, first.name
            )));
        }
    }
    let input = Input {
        mesh: first.clone(),
        deformation: Deformation::Frames {
            frames: frames.iter().map(|f| f.positions.clone()).collect(),
        },
    };
    input.validate()?;
    Ok(input)
}
