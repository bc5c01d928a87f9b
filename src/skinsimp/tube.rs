//! A procedural skinned model: a capped tube along x with three bones and a bending clip
//! (issue #6: "a bending tube with two or three bones"), used by the tests, the demo and the
//! benchmarks. It goes through the same [`SkinnedMesh`] type as a loaded glTF file.
//!
//! - Geometry: radius 0.3, length 3, `rings + 1` rings of `segments` vertices at
//!   `x = 3i/rings`, closed by a fan at each end (genus 0). Triangles: `2·segments·(rings + 1)`.
//! - UVs: the side on `[0, 1] × [0, 0.5]` (a seam along θ = 0), each cap on its own disc in the
//!   upper half (seams around both rims).
//! - Bones `k = 0, 1, 2` cover `x ∈ [k, k + 1]` (joint nodes at x = 0, 1, 2, a chain); weights
//!   `w_k(x) ∝ max(0, 1 − |x − (k + ½)| / 1.2)`, normalised: up to three influences.
//! - Clip "Bend", 2 s, 17 LINEAR keys: bone 1 turns about z by `0.8 sin(πt)`, bone 2 about y
//!   by `0.6 sin(πt + 1)`.

use std::f64::consts::{PI, TAU};

use nalgebra::{Matrix4, Point2, Point3, Vector3, Vector4};

use crate::mesh::skin::{
    Animation, Channel, GltfReport, Influence, Interpolation, Joint, Property, SceneNode, Skeleton,
    SkinnedMesh, Trs,
};
use crate::mesh::TriMesh;

/// Tube radius and length.
const RADIUS: f64 = 0.3;
const LENGTH: f64 = 3.0;
/// Half-width of each bone's weight hat.
const BLEND: f64 = 1.2;
/// Number of keys of the clip and its length in seconds.
const KEYS: usize = 17;
const CLIP_SECONDS: f64 = 2.0;

/// Triangle count of [`skinned_tube`]`(segments, rings)`.
pub fn tube_triangle_count(segments: usize, rings: usize) -> usize {
    2 * segments * (rings + 1)
}

/// The bending tube of the module docs, `segments ≥ 3`, `rings ≥ 1` (clamped).
pub fn skinned_tube(segments: usize, rings: usize) -> SkinnedMesh {
    let (segments, rings) = (segments.max(3), rings.max(1));
    let mesh = tube_mesh(segments, rings);
    let influences = mesh.positions.iter().map(|p| hat_weights(p.x)).collect();
    let skeleton = chain_skeleton();
    SkinnedMesh {
        mesh,
        influences,
        skeleton: Some(skeleton),
        animations: vec![bend_clip()],
        report: GltfReport {
            mesh_nodes: vec![3],
            ..GltfReport::default()
        },
    }
}

/// The capped tube's rest mesh with its UVs.
fn tube_mesh(segments: usize, rings: usize) -> TriMesh {
    let ring_vertex = |i: usize, k: usize| (i * segments + k % segments) as u32;
    let mut positions = Vec::new();
    for i in 0..=rings {
        let x = LENGTH * i as f64 / rings as f64;
        for k in 0..segments {
            let theta = TAU * k as f64 / segments as f64;
            positions.push(Point3::new(x, RADIUS * theta.cos(), RADIUS * theta.sin()));
        }
    }
    let caps = [positions.len() as u32, positions.len() as u32 + 1];
    positions.push(Point3::new(0.0, 0.0, 0.0));
    positions.push(Point3::new(LENGTH, 0.0, 0.0));
    // Side UVs: (rings + 1) × (segments + 1), the seam column duplicated.
    let side_uv = |i: usize, k: usize| (i * (segments + 1) + k) as u32;
    let mut uvs = Vec::new();
    for i in 0..=rings {
        for k in 0..=segments {
            uvs.push(Point2::new(
                k as f64 / segments as f64,
                0.5 * i as f64 / rings as f64,
            ));
        }
    }
    // Cap UVs: centre then rim, on discs of radius 0.2 at (0.25, 0.75) and (0.75, 0.75).
    let mut cap_uv = [[0u32; 2]; 2];
    for (c, centre) in [Point2::new(0.25, 0.75), Point2::new(0.75, 0.75)]
        .into_iter()
        .enumerate()
    {
        cap_uv[c] = [uvs.len() as u32, uvs.len() as u32 + 1];
        uvs.push(centre);
        for k in 0..segments {
            let theta = TAU * k as f64 / segments as f64;
            uvs.push(centre + 0.2 * nalgebra::Vector2::new(theta.cos(), theta.sin()));
        }
    }
    let rim_uv = |c: usize, k: usize| cap_uv[c][1] + (k % segments) as u32;
    let mut faces = Vec::new();
    let mut uv_faces = Vec::new();
    for i in 0..rings {
        for k in 0..segments {
            let (a, b) = (ring_vertex(i, k), ring_vertex(i, k + 1));
            let (c, d) = (ring_vertex(i + 1, k + 1), ring_vertex(i + 1, k));
            let (ua, ub) = (side_uv(i, k), side_uv(i, k + 1));
            let (uc, ud) = (side_uv(i + 1, k + 1), side_uv(i + 1, k));
            faces.push([a, b, c]);
            uv_faces.push([ua, ub, uc]);
            faces.push([a, c, d]);
            uv_faces.push([ua, uc, ud]);
        }
    }
    for k in 0..segments {
        faces.push([caps[0], ring_vertex(0, k + 1), ring_vertex(0, k)]);
        uv_faces.push([cap_uv[0][0], rim_uv(0, k + 1), rim_uv(0, k)]);
        faces.push([caps[1], ring_vertex(rings, k), ring_vertex(rings, k + 1)]);
        uv_faces.push([cap_uv[1][0], rim_uv(1, k), rim_uv(1, k + 1)]);
    }
    TriMesh {
        positions,
        uvs,
        faces,
        uv_faces,
        texture: None,
        name: format!("procedural:skinned_tube({segments},{rings})"),
    }
}

/// `w_k(x) ∝ max(0, 1 − |x − (k + ½)| / BLEND)`, normalised, sorted by decreasing weight.
fn hat_weights(x: f64) -> Vec<Influence> {
    let mut list: Vec<Influence> = (0..3u32)
        .map(|k| Influence {
            joint: k,
            weight: (1.0 - (x - (k as f64 + 0.5)).abs() / BLEND).max(0.0),
        })
        .filter(|i| i.weight > 0.0)
        .collect();
    let total: f64 = list.iter().map(|i| i.weight).sum();
    list.iter_mut().for_each(|i| i.weight /= total);
    list.sort_by(|a, b| b.weight.total_cmp(&a.weight).then(a.joint.cmp(&b.joint)));
    list
}

/// Joint nodes 0, 1, 2 (a chain along x, one unit apart) and the mesh node 3.
fn chain_skeleton() -> Skeleton {
    let node = |name: &str, parent: Option<usize>, x: f64| SceneNode {
        name: name.to_string(),
        parent,
        rest: Trs {
            translation: Vector3::new(x, 0.0, 0.0),
            ..Trs::default()
        },
    };
    Skeleton {
        nodes: vec![
            node("bone0", None, 0.0),
            node("bone1", Some(0), 1.0),
            node("bone2", Some(1), 1.0),
            node("tube", None, 0.0),
        ],
        parent_first: vec![0, 1, 2, 3],
        joints: (0..3)
            .map(|k| Joint {
                node: k,
                inverse_bind: Matrix4::new_translation(&Vector3::new(-(k as f64), 0.0, 0.0)),
            })
            .collect(),
        mesh_node: 3,
    }
}

/// The quaternion (x, y, z, w) of a rotation by `angle` about the unit `axis`.
fn axis_angle(axis: Vector3<f64>, angle: f64) -> Vector4<f64> {
    let s = (0.5 * angle).sin();
    Vector4::new(axis.x * s, axis.y * s, axis.z * s, (0.5 * angle).cos())
}

/// The clip "Bend" of the module docs.
fn bend_clip() -> Animation {
    let times: Vec<f64> = (0..KEYS)
        .map(|i| CLIP_SECONDS * i as f64 / (KEYS - 1) as f64)
        .collect();
    let channel = |node: usize, axis: Vector3<f64>, amplitude: f64, phase: f64| {
        let values = times
            .iter()
            .map(|&t| axis_angle(axis, amplitude * (PI * t + phase).sin()))
            .collect();
        Channel::new(
            node,
            Property::Rotation,
            Interpolation::Linear,
            times.clone(),
            values,
        )
        .expect("valid built-in channel")
    };
    Animation {
        name: "Bend".to_string(),
        channels: vec![
            channel(1, Vector3::z(), 0.8, 0.0),
            channel(2, Vector3::y(), 0.6, 1.0),
        ],
    }
}
