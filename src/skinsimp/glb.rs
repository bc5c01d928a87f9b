//! Writing a skinned mesh as a binary glTF 2.0 file (`.glb`) that standard viewers animate:
//! the node hierarchy, the skin (joints and inverse bind matrices) and the animations of a
//! [`SkinnedMesh`], with its mesh and weights.
//!
//! The JSON is built with `serde_json` and the container with `gltf::binary::Glb` (the `gltf`
//! crate's typed `gltf_json` structs would do too; plain JSON keeps every written field visible
//! here). One buffer, one buffer view per accessor (4-byte aligned). Corners are split into
//! glTF vertices by (position index, UV index) pairs, in order of first use; UVs are written
//! with `v_glTF = 1 − v` (the loader's convention reversed). Joints as `JOINTS_n` (u16) and
//! `WEIGHTS_n` (f32), four per set, as many sets as the largest influence count needs.
//! Materials and textures are not written.

use std::path::Path;

use serde_json::{json, Value};

use super::hierarchy::Level;
use crate::error::{Error, Result};
use crate::mesh::skin::{Influence, Interpolation, Property, SkinnedMesh};

/// `model` with the mesh and weights of `level` (same skeleton and animations).
pub fn level_model(model: &SkinnedMesh, level: &Level) -> SkinnedMesh {
    let influences = level
        .weights
        .iter()
        .map(|w| {
            let mut list: Vec<Influence> = w
                .pairs()
                .map(|(joint, weight)| Influence { joint, weight })
                .collect();
            list.sort_by(|a, b| b.weight.total_cmp(&a.weight).then(a.joint.cmp(&b.joint)));
            list
        })
        .collect();
    SkinnedMesh {
        mesh: level.mesh.clone(),
        influences,
        skeleton: model.skeleton.clone(),
        animations: model.animations.clone(),
        report: Default::default(),
    }
}

/// Write `model` (which must have a skeleton) to `path` as GLB (module docs).
pub fn write_glb(path: &Path, model: &SkinnedMesh) -> Result<()> {
    let bytes =
        glb_bytes(model).map_err(|m| Error::InvalidArgument(format!("{}: {m}", path.display())))?;
    std::fs::write(path, bytes).map_err(|e| Error::io(path, e))
}

/// The GLB file of `model` as bytes.
pub fn glb_bytes(model: &SkinnedMesh) -> std::result::Result<Vec<u8>, String> {
    let skeleton = model
        .skeleton
        .as_ref()
        .ok_or("the model has no skeleton to write")?;
    let mut b = Builder::default();
    let mesh = &model.mesh;

    // glTF vertices: distinct (position, uv) corners in order of first use.
    let mut index = std::collections::HashMap::new();
    let mut corners: Vec<(u32, Option<u32>)> = Vec::new();
    let mut indices: Vec<u32> = Vec::with_capacity(mesh.faces.len() * 3);
    for (f, t) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            let key = (t[k], mesh.uv_faces.get(f).map(|u| u[k]));
            let next = corners.len() as u32;
            let i = *index.entry(key).or_insert_with(|| {
                corners.push(key);
                next
            });
            indices.push(i);
        }
    }
    let positions: Vec<[f32; 3]> = corners
        .iter()
        .map(|&(v, _)| mesh.positions[v as usize].coords.map(|x| x as f32).into())
        .collect();
    let mut attributes = serde_json::Map::new();
    let (lo, hi) = bounds(&positions);
    attributes.insert(
        "POSITION".into(),
        b.accessor(
            &flat(&positions),
            "VEC3",
            FLOAT,
            Some((lo, hi)),
            Some(ARRAY_BUFFER),
        )
        .into(),
    );
    if mesh.has_uvs() {
        let uvs: Vec<[f32; 2]> = corners
            .iter()
            .map(|&(_, u)| {
                let uv = mesh.uvs[u.unwrap_or(0) as usize];
                [uv.x as f32, (1.0 - uv.y) as f32]
            })
            .collect();
        attributes.insert(
            "TEXCOORD_0".into(),
            b.accessor(&flat(&uvs), "VEC2", FLOAT, None, Some(ARRAY_BUFFER))
                .into(),
        );
    }
    let sets = model
        .influences
        .iter()
        .map(Vec::len)
        .max()
        .unwrap_or(1)
        .div_ceil(4)
        .max(1);
    for set in 0..sets {
        let mut joints: Vec<u8> = Vec::new();
        let mut weights: Vec<f32> = Vec::new();
        for &(v, _) in &corners {
            let list = model
                .influences
                .get(v as usize)
                .map_or(&[][..], |l| l.as_slice());
            for slot in 0..4 {
                let (j, w) = list
                    .get(4 * set + slot)
                    .map_or((0, 0.0), |i| (i.joint, i.weight as f32));
                let j =
                    u16::try_from(j).map_err(|_| format!("joint index {j} does not fit u16"))?;
                joints.extend_from_slice(&j.to_le_bytes());
                weights.push(w);
            }
        }
        let ja = b.accessor_bytes(
            &joints,
            "VEC4",
            UNSIGNED_SHORT,
            corners.len(),
            Some(ARRAY_BUFFER),
        );
        let wa = b.accessor(&weights, "VEC4", FLOAT, None, Some(ARRAY_BUFFER));
        attributes.insert(format!("JOINTS_{set}"), ja.into());
        attributes.insert(format!("WEIGHTS_{set}"), wa.into());
    }
    let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let index_accessor = b.accessor_bytes(
        &index_bytes,
        "SCALAR",
        UNSIGNED_INT,
        indices.len(),
        Some(ELEMENT_ARRAY_BUFFER),
    );

    let ibm: Vec<f32> = skeleton
        .joints
        .iter()
        .flat_map(|j| {
            j.inverse_bind
                .as_slice()
                .iter()
                .map(|&x| x as f32)
                .collect::<Vec<_>>()
        })
        .collect();
    let ibm_accessor = b.accessor(&ibm, "MAT4", FLOAT, None, None);

    let mut children = vec![Vec::new(); skeleton.nodes.len()];
    for (i, n) in skeleton.nodes.iter().enumerate() {
        if let Some(p) = n.parent {
            children[p].push(i);
        }
    }
    let nodes: Vec<Value> = skeleton
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let r = n.rest.rotation.coords;
            let mut node = json!({
                "name": n.name,
                "translation": [n.rest.translation.x, n.rest.translation.y, n.rest.translation.z],
                "rotation": [r.x, r.y, r.z, r.w],
                "scale": [n.rest.scale.x, n.rest.scale.y, n.rest.scale.z],
            });
            if !children[i].is_empty() {
                node["children"] = json!(children[i]);
            }
            if i == skeleton.mesh_node {
                node["mesh"] = json!(0);
                node["skin"] = json!(0);
            }
            node
        })
        .collect();
    let roots: Vec<usize> = (0..skeleton.nodes.len())
        .filter(|&i| skeleton.nodes[i].parent.is_none())
        .collect();

    let mut animations = Vec::new();
    for a in &model.animations {
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        for c in &a.channels {
            let times: Vec<f32> = c.times.iter().map(|&t| t as f32).collect();
            let (tlo, thi) = (times[0], times[times.len() - 1]);
            let input = b.accessor(&times, "SCALAR", FLOAT, Some((vec![tlo], vec![thi])), None);
            let width = if c.property == Property::Rotation {
                4
            } else {
                3
            };
            let mut out: Vec<f32> = Vec::new();
            for k in 0..c.times.len() {
                let keys: Vec<&nalgebra::Vector4<f64>> =
                    if c.interpolation == Interpolation::CubicSpline {
                        vec![&c.in_tangents[k], &c.values[k], &c.out_tangents[k]]
                    } else {
                        vec![&c.values[k]]
                    };
                for v in keys {
                    out.extend(v.iter().take(width).map(|&x| x as f32));
                }
            }
            let output = b.accessor(
                &out,
                if width == 4 { "VEC4" } else { "VEC3" },
                FLOAT,
                None,
                None,
            );
            let interpolation = match c.interpolation {
                Interpolation::Step => "STEP",
                Interpolation::Linear => "LINEAR",
                Interpolation::CubicSpline => "CUBICSPLINE",
            };
            let path = match c.property {
                Property::Translation => "translation",
                Property::Rotation => "rotation",
                Property::Scale => "scale",
            };
            channels
                .push(json!({"sampler": samplers.len(), "target": {"node": c.node, "path": path}}));
            samplers
                .push(json!({"input": input, "output": output, "interpolation": interpolation}));
        }
        animations.push(json!({"name": a.name, "channels": channels, "samplers": samplers}));
    }

    let mut root = json!({
        "asset": {"version": "2.0", "generator": concat!("reparam ", env!("CARGO_PKG_VERSION"), " skinsimp")},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "meshes": [{"name": mesh.name, "primitives": [{"attributes": attributes, "indices": index_accessor, "mode": 4}]}],
        "skins": [{"joints": skeleton.joints.iter().map(|j| j.node).collect::<Vec<_>>(), "inverseBindMatrices": ibm_accessor}],
        "accessors": b.accessors,
        "bufferViews": b.views,
        "buffers": [{"byteLength": b.data.len()}],
    });
    if !animations.is_empty() {
        root["animations"] = json!(animations);
    }
    let json_text = serde_json::to_vec(&root).map_err(|e| e.to_string())?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: std::borrow::Cow::Owned(json_text),
        bin: Some(std::borrow::Cow::Owned(b.data)),
    };
    glb.to_vec().map_err(|e| e.to_string())
}

const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary buffer with its views and accessors.
#[derive(Default)]
struct Builder {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    /// An f32 accessor of `values` (`kind` components each), with optional min/max.
    fn accessor(
        &mut self,
        values: &[f32],
        kind: &str,
        component: u32,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
        target: Option<u32>,
    ) -> usize {
        let width = components(kind);
        let bytes: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        let index = self.accessor_bytes(&bytes, kind, component, values.len() / width, target);
        if let Some((lo, hi)) = bounds {
            self.accessors[index]["min"] = json!(lo);
            self.accessors[index]["max"] = json!(hi);
        }
        index
    }

    /// An accessor of raw little-endian `bytes`, `count` elements.
    fn accessor_bytes(
        &mut self,
        bytes: &[u8],
        kind: &str,
        component: u32,
        count: usize,
        target: Option<u32>,
    ) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut view =
            json!({"buffer": 0, "byteOffset": self.data.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.data.extend_from_slice(bytes);
        self.views.push(view);
        self.accessors.push(json!({
            "bufferView": self.views.len() - 1,
            "componentType": component,
            "count": count,
            "type": kind,
        }));
        self.accessors.len() - 1
    }
}

fn components(kind: &str) -> usize {
    match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        "MAT4" => 16,
        _ => 1,
    }
}

fn flat<const N: usize>(v: &[[f32; N]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

/// Per-component min and max of the positions (glTF requires them for `POSITION`).
fn bounds(p: &[[f32; 3]]) -> (Vec<f32>, Vec<f32>) {
    let mut lo = vec![f32::INFINITY; 3];
    let mut hi = vec![f32::NEG_INFINITY; 3];
    for x in p {
        for a in 0..3 {
            lo[a] = lo[a].min(x[a]);
            hi[a] = hi[a].max(x[a]);
        }
    }
    (lo, hi)
}
