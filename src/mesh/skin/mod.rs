//! Skinned meshes from glTF 2.0 files: the rest-pose [`TriMesh`], the joint influences of each
//! vertex, the node hierarchy with its inverse bind matrices, and the keyframe animations; and
//! posing them by linear blend skinning.
//!
//! One file per step:
//! - `load.rs`: read a `.gltf` / `.glb` file into a [`SkinnedMesh`] ([`load_gltf`]).
//! - `weld.rs`: clean the skin weights and weld the corners of the (often unindexed) glTF
//!   triangles into shared vertices, keeping UV seams.
//! - `sample.rs`: the value of an animation channel at a time (STEP, LINEAR, CUBICSPLINE).
//! - this file: the types, and posing: at time τ,
//!   1. local transform of every node: its rest TRS, with the animated translation, rotation or
//!      scale replacing the rest one, `L_n = T · R · S`;
//!   2. world matrices down the hierarchy: `G_n = G_parent(n) · L_n` (`G_n = L_n` at a root);
//!   3. joint matrices `J_j = G_node(j) · IBM_j` (IBM: inverse bind matrix);
//!   4. linear blend skinning `p = Σ_j w_j J_j p_rest`.
//!
//! As the glTF spec requires (§3.7.3.1), the transform of the skinned mesh node itself is not
//! applied: the inverse bind matrices already bring the mesh into the joints' space, and the
//! joints' world matrices carry it to the scene.

mod load;
mod sample;
mod weld;

use std::fmt;

use nalgebra::{Matrix4, Point3, UnitQuaternion, Vector3, Vector4};

use super::trimesh::TriMesh;
use crate::error::{Error, Result};

pub use load::{load_gltf, load_gltf_base_colour, load_gltf_with, GltfOptions};
pub use sample::{hermite, slerp};

/// A mesh with its skeleton and animations, as loaded by [`load_gltf`].
///
/// Without a skin in the file (or for a mesh node without skin), `skeleton` is `None`,
/// `influences` is empty and posing returns the rest positions.
#[derive(Clone, Debug)]
pub struct SkinnedMesh {
    /// The rest pose: positions welded (see [`load_gltf`]), UVs with their own indices, named
    /// after the file. For a skinned mesh these are the glTF `POSITION`s as stored (the bind
    /// space the inverse bind matrices expect); for an unskinned one they are in world space.
    pub mesh: TriMesh,
    /// The joint influences of each vertex of `mesh.positions` (same indices): weights > 0,
    /// summing to 1, sorted by decreasing weight (ties by joint). Empty without skeleton.
    pub influences: Vec<Vec<Influence>>,
    /// The node hierarchy and the skin's joints; `None` for an unskinned mesh.
    pub skeleton: Option<Skeleton>,
    /// The file's animations, in file order.
    pub animations: Vec<Animation>,
    /// What the loader did that a user may want to know (ignored parts, repairs).
    pub report: GltfReport,
}

/// One joint's share of a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Influence {
    /// Index into [`Skeleton::joints`] (the glTF `JOINTS_n` value).
    pub joint: u32,
    /// Weight `w_j` in `p = Σ_j w_j J_j p_rest`.
    pub weight: f64,
}

/// The node hierarchy of the file and the skin of the loaded mesh.
///
/// Invariants (checked by the loader): every node has at most one parent, the hierarchy has no
/// cycle, `parent_first` lists every node once with parents before children, and every joint
/// names an existing node.
#[derive(Clone, Debug)]
pub struct Skeleton {
    /// Every node of the file; the index is the glTF node index. Non-joint nodes are kept
    /// because their transforms also move the joints below them.
    pub nodes: Vec<SceneNode>,
    /// Node indices, each parent before its children.
    pub parent_first: Vec<usize>,
    /// The skin's joints, in the order the `JOINTS_n` attributes refer to them.
    pub joints: Vec<Joint>,
    /// The node whose mesh was loaded (its own transform is ignored, see the module docs).
    pub mesh_node: usize,
}

/// A node of the glTF hierarchy.
#[derive(Clone, Debug)]
pub struct SceneNode {
    /// The node's name, or `node <index>` when it has none.
    pub name: String,
    /// The parent node, `None` for a root.
    pub parent: Option<usize>,
    /// The local transform in the file (a `matrix` is decomposed into TRS).
    pub rest: Trs,
}

/// A joint of the skin.
#[derive(Clone, Debug)]
pub struct Joint {
    /// The node that moves this joint.
    pub node: usize,
    /// `IBM_j`: takes bind-pose mesh positions into the joint's local space (identity when the
    /// file gives none, as the glTF spec says).
    pub inverse_bind: Matrix4<f64>,
}

/// A local transform as translation, rotation and scale: the matrix `T · R · S`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Trs {
    pub translation: Vector3<f64>,
    pub rotation: UnitQuaternion<f64>,
    pub scale: Vector3<f64>,
}

impl Default for Trs {
    /// The identity transform.
    fn default() -> Self {
        Trs {
            translation: Vector3::zeros(),
            rotation: UnitQuaternion::identity(),
            scale: Vector3::new(1.0, 1.0, 1.0),
        }
    }
}

impl Trs {
    /// The 4×4 matrix `T · R · S`: scale first, then rotate, then translate.
    pub fn matrix(&self) -> Matrix4<f64> {
        Matrix4::new_translation(&self.translation)
            * self.rotation.to_homogeneous()
            * Matrix4::new_nonuniform_scaling(&self.scale)
    }

    /// This transform with the channel value `value` (x, y, z[, w]) replacing `property`.
    pub fn with(mut self, property: Property, value: Vector4<f64>) -> Trs {
        match property {
            Property::Translation => self.translation = value.xyz(),
            Property::Scale => self.scale = value.xyz(),
            Property::Rotation => {
                let q = nalgebra::Quaternion::new(value.w, value.x, value.y, value.z);
                self.rotation = UnitQuaternion::new_normalize(q);
            }
        }
        self
    }
}

/// A named set of channels played together.
#[derive(Clone, Debug)]
pub struct Animation {
    /// The animation's name, or `animation <index>` when it has none.
    pub name: String,
    /// The translation / rotation / scale channels (morph-weight channels are not kept).
    pub channels: Vec<Channel>,
}

/// Keyframes of one property of one node (a glTF channel with its sampler).
///
/// Build with [`Channel::new`], which checks the invariants [`Channel::sample`] relies on.
#[derive(Clone, Debug)]
pub struct Channel {
    /// The animated node (glTF node index).
    pub node: usize,
    /// Which part of the node's TRS it replaces.
    pub property: Property,
    /// How values between keys are computed.
    pub interpolation: Interpolation,
    /// Key times in seconds, non-decreasing, at least one.
    pub times: Vec<f64>,
    /// One value per key: (x, y, z, 0) for translation and scale, the unit quaternion
    /// (x, y, z, w) for rotation.
    pub values: Vec<Vector4<f64>>,
    /// CUBICSPLINE only (else empty): in-tangent `a_k` of each key.
    pub in_tangents: Vec<Vector4<f64>>,
    /// CUBICSPLINE only (else empty): out-tangent `b_k` of each key.
    pub out_tangents: Vec<Vector4<f64>>,
}

/// The part of a node's transform a channel animates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
}

/// glTF keyframe interpolation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Hold the value of the last key at or before τ.
    Step,
    /// Linear between keys (spherical for rotations).
    Linear,
    /// Cubic Hermite spline with an in- and out-tangent at each key.
    CubicSpline,
}

/// What the loader ignored, repaired or noticed; all counts are zero for a clean file.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GltfReport {
    /// glTF nodes whose meshes were loaded.
    pub mesh_nodes: Vec<usize>,
    /// Nodes with a mesh that were not loaded (a skinned mesh is loaded alone).
    pub skipped_mesh_nodes: usize,
    /// Triangle primitives loaded.
    pub primitives: usize,
    /// Vertices in the loaded primitives' accessors, before welding.
    pub gltf_vertices: usize,
    /// Primitives with morph targets (the targets are ignored: the base shape is loaded).
    pub morph_target_primitives: usize,
    /// Animation channels on morph-target weights (ignored).
    pub ignored_weight_channels: usize,
    /// glTF vertices whose weights did not sum to 1 (within 1e-6) and were rescaled.
    pub renormalised_vertices: usize,
    /// glTF vertices that listed the same joint twice (the weights were added).
    pub repeated_joint_vertices: usize,
    /// Welded positions where corners with different influences had to stay separate vertices.
    pub split_positions: usize,
    /// Triangles with two corners on the same welded vertex (kept).
    pub degenerate_faces: usize,
    /// Loaded primitives without `TEXCOORD_0` (then the mesh has no UVs at all).
    pub primitives_without_uvs: usize,
}

impl fmt::Display for GltfReport {
    /// One line per non-zero item, for the command line.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "mesh node(s) {:?}: {} primitive(s), {} glTF vertices",
            self.mesh_nodes, self.primitives, self.gltf_vertices
        )?;
        let items = [
            (self.skipped_mesh_nodes, "other mesh node(s) not loaded"),
            (
                self.morph_target_primitives,
                "primitive(s) with morph targets (ignored)",
            ),
            (
                self.ignored_weight_channels,
                "morph-weight animation channel(s) (ignored)",
            ),
            (
                self.renormalised_vertices,
                "vertices with weights rescaled to sum 1",
            ),
            (
                self.repeated_joint_vertices,
                "vertices listing a joint twice (weights added)",
            ),
            (
                self.split_positions,
                "positions split by differing skin weights",
            ),
            (
                self.degenerate_faces,
                "degenerate triangle(s) after welding",
            ),
            (
                self.primitives_without_uvs,
                "primitive(s) without TEXCOORD_0 (mesh has no UVs)",
            ),
        ];
        for (count, what) in items {
            if count > 0 {
                writeln!(f, "{count} {what}")?;
            }
        }
        Ok(())
    }
}

impl SkinnedMesh {
    /// The animations' names, in file order.
    pub fn animation_names(&self) -> Vec<&str> {
        self.animations.iter().map(|a| a.name.as_str()).collect()
    }

    /// The index of the animation called `name`.
    pub fn animation_index(&self, name: &str) -> Option<usize> {
        self.animations.iter().position(|a| a.name == name)
    }

    /// Length of an animation in seconds: the latest key time of its channels (glTF times
    /// count from 0; an animation without channels lasts 0 s).
    pub fn duration(&self, animation: usize) -> Result<f64> {
        let animation = self.animation(animation)?;
        let last_key = |c: &Channel| c.times.last().copied().unwrap_or(0.0);
        Ok(animation.channels.iter().map(last_key).fold(0.0, f64::max))
    }

    /// The vertex positions at time `time` (seconds) of animation `animation`: linear blend
    /// skinning `p = Σ_j w_j (G_j · IBM_j) p_rest`, with each node's local transform sampled at
    /// `time` (clamped to the key range) and `G_j` composed down the hierarchy (module docs).
    ///
    /// Without skeleton the rest positions are returned. Errors: [`Error::InvalidArgument`] for
    /// an animation index out of range or a non-finite time.
    pub fn pose(&self, animation: usize, time: f64) -> Result<Vec<Point3<f64>>> {
        let animation = self.animation(animation)?;
        if !time.is_finite() {
            return Err(Error::InvalidArgument(format!(
                "{}: animation time {time} is not finite",
                self.mesh.name
            )));
        }
        let Some(skeleton) = &self.skeleton else {
            return Ok(self.mesh.positions.clone());
        };
        let local = skeleton.local_transforms(Some(animation), time);
        let joints = skeleton.joint_matrices(&skeleton.world_matrices(&local));
        Ok(skin_positions(
            &self.mesh.positions,
            &self.influences,
            &joints,
        ))
    }

    /// The rest mesh with the positions of [`pose`](Self::pose): same faces, UVs and texture,
    /// named `<file> [<animation> @ <time> s]`.
    pub fn posed_mesh(&self, animation: usize, time: f64) -> Result<TriMesh> {
        let positions = self.pose(animation, time)?;
        let name = format!(
            "{} [{} @ {time} s]",
            self.mesh.name, self.animations[animation].name
        );
        Ok(TriMesh {
            positions,
            name,
            ..self.mesh.clone()
        })
    }

    /// Animation number `index`, or a typed error naming the file and the valid range.
    fn animation(&self, index: usize) -> Result<&Animation> {
        self.animations.get(index).ok_or_else(|| {
            Error::InvalidArgument(format!(
                "{}: there is no animation {index} (the file has {}: {:?})",
                self.mesh.name,
                self.animations.len(),
                self.animation_names()
            ))
        })
    }
}

impl Skeleton {
    /// The local transform of every node at time `time`: its rest TRS, with each channel of
    /// `animation` replacing the property it animates by its sampled value. `None` gives the
    /// rest transforms. Channels on nodes that do not exist are skipped.
    pub fn local_transforms(&self, animation: Option<&Animation>, time: f64) -> Vec<Trs> {
        let mut local: Vec<Trs> = self.nodes.iter().map(|n| n.rest).collect();
        for channel in animation.map_or(&[][..], |a| &a.channels) {
            if let Some(trs) = local.get_mut(channel.node) {
                *trs = trs.with(channel.property, channel.sample(time));
            }
        }
        local
    }

    /// World matrix of every node, `G_n = G_parent(n) · L_n` (`G_n = L_n` at a root), with
    /// `L_n = local[n].matrix()`. `local` has one entry per node.
    pub fn world_matrices(&self, local: &[Trs]) -> Vec<Matrix4<f64>> {
        compose_world(&self.nodes, &self.parent_first, local)
    }

    /// Joint matrices `J_j = G_node(j) · IBM_j` from the nodes' world matrices.
    pub fn joint_matrices(&self, world: &[Matrix4<f64>]) -> Vec<Matrix4<f64>> {
        self.joints
            .iter()
            .map(|joint| world[joint.node] * joint.inverse_bind)
            .collect()
    }
}

/// `G_n = G_parent(n) · L_n` for the nodes in `parent_first` order (see
/// [`Skeleton::world_matrices`]).
pub(crate) fn compose_world(
    nodes: &[SceneNode],
    parent_first: &[usize],
    local: &[Trs],
) -> Vec<Matrix4<f64>> {
    let mut world = vec![Matrix4::identity(); nodes.len()];
    for &n in parent_first {
        let own = local[n].matrix();
        world[n] = match nodes[n].parent {
            Some(parent) => world[parent] * own,
            None => own,
        };
    }
    world
}

/// Linear blend skinning: `p_i = Σ_j w_ij J_j p_rest,i` for every vertex `i`, with the
/// influences `(j, w_ij)` of vertex `i` and the joint matrices `J_j` (homogeneous, w = 1).
/// A vertex without influences keeps its rest position; influences naming a joint that has no
/// matrix are skipped.
pub fn skin_positions(
    rest: &[Point3<f64>],
    influences: &[Vec<Influence>],
    joint_matrices: &[Matrix4<f64>],
) -> Vec<Point3<f64>> {
    rest.iter()
        .enumerate()
        .map(|(i, p)| match influences.get(i) {
            Some(list) if !list.is_empty() => blend(p, list, joint_matrices),
            _ => *p,
        })
        .collect()
}

/// `Σ_j w_j J_j p` for one vertex, summed in the order of `influences`.
fn blend(
    p: &Point3<f64>,
    influences: &[Influence],
    joint_matrices: &[Matrix4<f64>],
) -> Point3<f64> {
    let mut sum = Vector3::zeros();
    for influence in influences {
        if let Some(matrix) = joint_matrices.get(influence.joint as usize) {
            sum += influence.weight * (matrix * p.to_homogeneous()).xyz();
        }
    }
    Point3::from(sum)
}
