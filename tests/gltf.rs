//! glTF loading and skinning: welding of an unindexed soup with a UV seam, weight clean-up,
//! keyframe sampling (STEP / LINEAR / CUBICSPLINE) against hand-computed values, linear blend
//! skinning against the analytic rotation, and typed errors naming the file and the element.
//!
//! Every file is built here: a JSON document with a base64 `data:` buffer, a `.glb` with a BIN
//! chunk, or a `.gltf` with an external `.bin`.

use std::f64::consts::{FRAC_1_SQRT_2, FRAC_PI_4, FRAC_PI_8};
use std::fs;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Vector3, Vector4};
use reparam::mesh::skin::{hermite, slerp, Channel, Interpolation, Property};
use reparam::mesh::{load_gltf, load_gltf_with, GltfOptions, SkinnedMesh};
use reparam::Error;
use serde_json::{json, Value};

// ---------------------------------------------------------------------------------------------
// Building glTF files
// ---------------------------------------------------------------------------------------------

/// The binary buffer of a glTF file being built, with its buffer views and accessors.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

fn components(kind: &str) -> usize {
    match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        "VEC4" => 4,
        "MAT4" => 16,
        _ => panic!("unknown accessor type {kind}"),
    }
}

impl Bin {
    /// Append `data` as a new buffer view (4-byte aligned); returns the accessor index.
    fn accessor(&mut self, data: Vec<u8>, component_type: u32, kind: &str, count: usize) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        let view = json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len()});
        self.views.push(view);
        self.bytes.extend(data);
        let accessor = json!({
            "bufferView": self.views.len() - 1,
            "componentType": component_type,
            "type": kind,
            "count": count,
        });
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn floats(&mut self, values: &[f32], kind: &str) -> usize {
        let data = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(data, 5126, kind, values.len() / components(kind))
    }

    fn u16s(&mut self, values: &[u16], kind: &str) -> usize {
        let data = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(data, 5123, kind, values.len() / components(kind))
    }

    /// A POSITION accessor, with the `min`/`max` glTF requires.
    fn positions(&mut self, points: &[[f32; 3]]) -> usize {
        let flat: Vec<f32> = points.iter().flatten().copied().collect();
        let index = self.floats(&flat, "VEC3");
        let bound = |f: fn(f32, f32) -> f32, start: f32| {
            (0..3)
                .map(|a| points.iter().map(|p| p[a]).fold(start, f))
                .collect::<Vec<f32>>()
        };
        self.accessors[index]["min"] = json!(bound(f32::min, f32::INFINITY));
        self.accessors[index]["max"] = json!(bound(f32::max, f32::NEG_INFINITY));
        index
    }

    /// `document` completed with the asset, buffer, buffer views and accessors.
    fn finish(self, mut document: Value) -> (Value, Vec<u8>) {
        document["asset"] = json!({"version": "2.0"});
        document["buffers"] = json!([{"byteLength": self.bytes.len()}]);
        document["bufferViews"] = Value::Array(self.views);
        document["accessors"] = Value::Array(self.accessors);
        (document, self.bytes)
    }
}

/// Standard base64 with padding (RFC 4648), for `data:` URIs.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Write `document` as a `.gltf` with the buffer embedded as a base64 `data:` URI.
fn write_gltf(dir: &Path, name: &str, document: &Value, bin: &[u8]) -> PathBuf {
    let mut document = document.clone();
    document["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64(bin)
    ));
    let path = dir.join(name);
    fs::write(&path, serde_json::to_string_pretty(&document).unwrap()).unwrap();
    path
}

/// Write `document` as a `.glb`: header, JSON chunk (space-padded), BIN chunk (zero-padded).
fn write_glb(dir: &Path, name: &str, document: &Value, bin: &[u8]) -> PathBuf {
    let mut json_bytes = serde_json::to_vec(document).unwrap();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((json_bytes.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json_bytes);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    let path = dir.join(name);
    fs::write(&path, out).unwrap();
    path
}

// ---------------------------------------------------------------------------------------------
// The test model: a two-bone strip
// ---------------------------------------------------------------------------------------------

/// Column abscissae of the strip: 5 columns × 2 rows (y = 0, 1) of vertices, 4 quads.
const X: [f32; 5] = [0.0, 0.5, 1.0, 1.5, 2.0];

/// Variations of the strip.
#[derive(Default)]
struct StripOptions {
    /// Raw (joint 0, joint 1) weights of the right-hand quads' corners at x = 1, instead of the
    /// left-hand quads' (0.25, 0.25).
    seam_weights: Option<[f32; 2]>,
}

/// Raw glTF skin data of column `col`: (JOINTS_0, WEIGHTS_0, JOINTS_1, WEIGHTS_1).
///
/// col 0: joint 0 only · col 1: joint 1 listed with weight 0, joint 0 with 1 · col 2: 0.25 and
/// 0.25 (sum 0.5: rescaled) · col 3: joint 1 0.9 in set 0, joint 0 0.1 in set 1 · col 4: joint
/// 1 only.
fn column_skin(col: usize) -> ([u16; 4], [f32; 4], [u16; 4], [f32; 4]) {
    let none = ([0; 4], [0.0; 4]);
    let (j0, w0, (j1, w1)) = match col {
        0 => ([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0], none),
        1 => ([1, 0, 0, 0], [0.0, 1.0, 0.0, 0.0], none),
        2 => ([0, 1, 0, 0], [0.25, 0.25, 0.0, 0.0], none),
        3 => (
            [1, 0, 0, 0],
            [0.9, 0.0, 0.0, 0.0],
            ([0, 0, 0, 0], [0.1, 0.0, 0.0, 0.0]),
        ),
        _ => ([1, 0, 0, 0], [1.0, 0.0, 0.0, 0.0], none),
    };
    (j0, w0, j1, w1)
}

/// A strip from x = 0 to 2 (y from 0 to 1, z = 0) as an unindexed triangle soup: 4 quads split
/// into 8 triangles, 24 corners. UV chart A holds the quads with x ≤ 1, chart B those with
/// x ≥ 1, so x = 1 is a UV seam. Skeleton: non-joint node "armature" at z = 5 → joint 0 "root
/// bone" (node 1) → joint 1 "elbow" (node 2) at x = 1; the mesh node (node 3) has a translation
/// that glTF says to ignore. Animations: 0 "bend" (elbow rotation 0 → 90° about z, LINEAR,
/// t ∈ [0, 1]), 1 "steps" (root translation, STEP), 2 "spline" (root translation,
/// CUBICSPLINE), 3 "slide" (root translation, LINEAR).
fn strip(options: &StripOptions) -> (Value, Vec<u8>) {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    let (mut joints0, mut weights0, mut joints1, mut weights1) = (vec![], vec![], vec![], vec![]);
    for quad in 0..4 {
        let corners = [
            (quad, 0),
            (quad + 1, 0),
            (quad + 1, 1),
            (quad, 0),
            (quad + 1, 1),
            (quad, 1),
        ];
        for (col, row) in corners {
            let (x, y) = (X[col], row as f32);
            positions.push([x, y, 0.0]);
            uvs.extend(if quad < 2 {
                [0.25 * x, 0.5 * y]
            } else {
                [0.5 + 0.25 * (x - 1.0), 0.5 * y]
            });
            let (j0, mut w0, j1, w1) = column_skin(col);
            if let (Some([a, b]), true) = (options.seam_weights, quad >= 2 && col == 2) {
                w0 = [a, b, 0.0, 0.0];
            }
            joints0.extend(j0);
            weights0.extend(w0);
            joints1.extend(j1);
            weights1.extend(w1);
        }
    }
    let mut bin = Bin::default();
    let position = bin.positions(&positions);
    let uv = bin.floats(&uvs, "VEC2");
    let (j0, w0) = (bin.u16s(&joints0, "VEC4"), bin.floats(&weights0, "VEC4"));
    let (j1, w1) = (bin.u16s(&joints1, "VEC4"), bin.floats(&weights1, "VEC4"));
    #[rustfmt::skip]
    let ibm = bin.floats(&[
        1.0, 0.0, 0.0, 0.0,  0.0, 1.0, 0.0, 0.0,  0.0, 0.0, 1.0, 0.0,  0.0, 0.0, -5.0, 1.0,
        1.0, 0.0, 0.0, 0.0,  0.0, 1.0, 0.0, 0.0,  0.0, 0.0, 1.0, 0.0,  -1.0, 0.0, -5.0, 1.0,
    ], "MAT4");
    let s = FRAC_1_SQRT_2 as f32;
    let t01 = bin.floats(&[0.0, 1.0], "SCALAR");
    let bend = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s, s], "VEC4");
    let t012 = bin.floats(&[0.0, 1.0, 2.0], "SCALAR");
    let steps = bin.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0], "VEC3");
    let t023 = bin.floats(&[0.0, 2.0, 3.0], "SCALAR");
    #[rustfmt::skip]
    let spline = bin.floats(&[
        // in-tangent a_k, value v_k, out-tangent b_k
        9.0, 9.0, 9.0,   0.0, 0.0, 0.0,   1.0, 0.0, 0.0,
        0.0, 0.0, 4.0,   1.0, 2.0, 0.0,   0.0, 0.0, 0.0,
        2.0, 0.0, 0.0,   3.0, 2.0, 0.0,   9.0, 9.0, 9.0,
    ], "VEC3");
    let t02 = bin.floats(&[0.0, 2.0], "SCALAR");
    let slide = bin.floats(&[0.0, 0.0, 0.0, 2.0, 4.0, 0.0], "VEC3");

    let animation =
        |name: &str, node: usize, path: &str, input: usize, output: usize, interp: &str| {
            json!({
                "name": name,
                "channels": [{"sampler": 0, "target": {"node": node, "path": path}}],
                "samplers": [{"input": input, "output": output, "interpolation": interp}],
            })
        };
    let document = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"name": "armature", "translation": [0.0, 0.0, 5.0], "children": [1]},
            {"name": "root bone", "children": [2]},
            {"name": "elbow", "translation": [1.0, 0.0, 0.0]},
            {"name": "strip", "mesh": 0, "skin": 0, "translation": [100.0, 0.0, 0.0]},
        ],
        "meshes": [{"name": "strip", "primitives": [{
            "attributes": {
                "POSITION": position, "TEXCOORD_0": uv,
                "JOINTS_0": j0, "WEIGHTS_0": w0, "JOINTS_1": j1, "WEIGHTS_1": w1,
            },
            "mode": 4,
        }]}],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm, "skeleton": 1}],
        "animations": [
            animation("bend", 2, "rotation", t01, bend, "LINEAR"),
            animation("steps", 1, "translation", t012, steps, "STEP"),
            animation("spline", 1, "translation", t023, spline, "CUBICSPLINE"),
            animation("slide", 1, "translation", t02, slide, "LINEAR"),
        ],
    });
    bin.finish(document)
}

/// Write `document` as `strip.gltf` in a fresh directory and load it.
fn load_document(
    document: &Value,
    bin: &[u8],
) -> (tempfile::TempDir, PathBuf, reparam::Result<SkinnedMesh>) {
    let dir = tempfile::tempdir().unwrap();
    let path = write_gltf(dir.path(), "strip.gltf", document, bin);
    let loaded = load_gltf(&path);
    (dir, path, loaded)
}

fn load_strip(options: &StripOptions) -> SkinnedMesh {
    let (document, bin) = strip(options);
    let (_dir, _path, loaded) = load_document(&document, &bin);
    loaded.unwrap()
}

/// The welded vertex at (x, y, 0) (the first one, should there be several).
fn vertex_at(mesh: &SkinnedMesh, x: f64, y: f64) -> usize {
    let at = Point3::new(x, y, 0.0);
    mesh.mesh.positions.iter().position(|p| *p == at).unwrap()
}

fn assert_close(a: Point3<f64>, b: Point3<f64>, tolerance: f64, what: &str) {
    assert!((a - b).norm() <= tolerance, "{what}: {a} vs {b}");
}

/// `(element, message)` of an [`Error::Gltf`]; panics on any other error.
fn gltf_error(result: reparam::Result<SkinnedMesh>, path: &Path) -> (String, String) {
    match result {
        Err(Error::Gltf {
            path: p,
            element,
            message,
        }) => {
            assert_eq!(p, path);
            (element, message)
        }
        other => panic!("expected Error::Gltf, got {other:?}"),
    }
}

// ---------------------------------------------------------------------------------------------
// Loading and welding
// ---------------------------------------------------------------------------------------------

#[test]
fn welding_restores_connectivity_and_keeps_the_uv_seam() {
    let skinned = load_strip(&StripOptions::default());
    let mesh = &skinned.mesh;
    // 24 corners → 10 positions (5 columns × 2 rows), 12 UVs (the seam column twice), 8 faces.
    assert_eq!(skinned.report.gltf_vertices, 24);
    assert_eq!(mesh.positions.len(), 10);
    assert_eq!(mesh.uvs.len(), 12);
    assert_eq!(mesh.faces.len(), 8);
    assert_eq!(mesh.uv_faces.len(), 8);
    assert_eq!(skinned.influences.len(), 10);
    assert_eq!(skinned.report.split_positions, 0);
    assert_eq!(skinned.report.degenerate_faces, 0);
    mesh.validate_with_uvs().unwrap();

    // The seam: the faces on either side of x = 1 share the positions but not the UVs there.
    let seam = [vertex_at(&skinned, 1.0, 0.0), vertex_at(&skinned, 1.0, 1.0)];
    let uvs_at = |side: std::ops::Range<usize>, v: usize| -> Vec<u32> {
        let mut uvs: Vec<u32> = side
            .flat_map(|f| {
                (0..3)
                    .filter(move |&k| mesh.faces[f][k] as usize == v)
                    .map(move |k| mesh.uv_faces[f][k])
            })
            .collect();
        uvs.sort();
        uvs.dedup();
        uvs
    };
    for v in seam {
        let (left, right) = (uvs_at(0..4, v), uvs_at(4..8, v));
        assert_eq!(
            (left.len(), right.len()),
            (1, 1),
            "one UV per side at vertex {v}"
        );
        assert_ne!(left, right, "the seam keeps two UVs at vertex {v}");
    }
    // UVs follow the OBJ convention: v = 1 − v_glTF; the right chart starts at u = 0.5.
    let (left_uv, right_uv) = (uvs_at(0..4, seam[1])[0], uvs_at(4..8, seam[1])[0]);
    assert_eq!(mesh.uvs[left_uv as usize], nalgebra::Point2::new(0.25, 0.5));
    assert_eq!(mesh.uvs[right_uv as usize], nalgebra::Point2::new(0.5, 0.5));
    // Name and skeleton.
    assert!(mesh.name.ends_with("strip.gltf"));
    let skeleton = skinned.skeleton.as_ref().unwrap();
    assert_eq!(skeleton.nodes.len(), 4);
    assert_eq!(skeleton.nodes[2].parent, Some(1));
    assert_eq!(skeleton.nodes[1].parent, Some(0));
    assert_eq!(
        skeleton.joints.iter().map(|j| j.node).collect::<Vec<_>>(),
        vec![1, 2]
    );
    assert_eq!(skeleton.mesh_node, 3);
    assert_eq!(skeleton.joints[1].inverse_bind[(0, 3)], -1.0);
}

#[test]
fn weights_are_cleaned_normalised_and_sorted() {
    let skinned = load_strip(&StripOptions::default());
    let influences_at = |x, y| &skinned.influences[vertex_at(&skinned, x, y)];
    let pairs = |x, y| {
        influences_at(x, y)
            .iter()
            .map(|i| (i.joint, i.weight))
            .collect::<Vec<_>>()
    };
    // Column 1 listed joint 1 with weight 0: dropped.
    assert_eq!(pairs(0.5, 0.0), vec![(0, 1.0)]);
    // Column 2 had 0.25 + 0.25: rescaled to 0.5 + 0.5 (6 glTF corners lie on that column).
    assert_eq!(pairs(1.0, 1.0), vec![(0, 0.5), (1, 0.5)]);
    assert_eq!(skinned.report.renormalised_vertices, 6);
    // Column 3: 0.9 (set 0) and 0.1 (set 1), sorted by decreasing weight, summing to 1.
    let column3 = influences_at(1.5, 0.0);
    assert_eq!(
        column3.iter().map(|i| i.joint).collect::<Vec<_>>(),
        vec![1, 0]
    );
    assert!((column3[0].weight - 0.9).abs() < 1e-7 && (column3[1].weight - 0.1).abs() < 1e-7);
    for (v, list) in skinned.influences.iter().enumerate() {
        let sum: f64 = list.iter().map(|i| i.weight).sum();
        assert!(
            (sum - 1.0).abs() < 1e-15,
            "vertex {v}: weights sum to {sum}"
        );
        assert!(list.windows(2).all(|w| w[0].weight >= w[1].weight));
    }
}

#[test]
fn differing_influences_at_one_position_stay_separate_and_are_reported() {
    let options = StripOptions {
        seam_weights: Some([0.3, 0.7]),
    };
    let skinned = load_strip(&options);
    // Both seam positions now carry two different influence sets: 12 vertices, 2 reported.
    assert_eq!(skinned.mesh.positions.len(), 12);
    assert_eq!(skinned.report.split_positions, 2);
    assert_eq!(skinned.mesh.uvs.len(), 12);
}

#[test]
fn without_welding_the_soup_stays_a_soup() {
    let (document, bin) = strip(&StripOptions::default());
    let dir = tempfile::tempdir().unwrap();
    let path = write_gltf(dir.path(), "strip.gltf", &document, &bin);
    let options = GltfOptions {
        weld: false,
        ..GltfOptions::default()
    };
    let skinned = load_gltf_with(&path, &options).unwrap();
    assert_eq!(skinned.mesh.positions.len(), 24);
    assert_eq!(skinned.mesh.uvs.len(), 24);
    assert_eq!(skinned.mesh.faces.len(), 8);
}

#[test]
fn glb_and_external_buffer_load_the_same_mesh() {
    let (document, bin) = strip(&StripOptions::default());
    let dir = tempfile::tempdir().unwrap();
    let reference = load_gltf(&write_gltf(dir.path(), "strip.gltf", &document, &bin)).unwrap();

    let glb = load_gltf(&write_glb(dir.path(), "strip.glb", &document, &bin)).unwrap();
    let mut external = document.clone();
    external["buffers"][0]["uri"] = json!("strip%20data.bin");
    fs::write(dir.path().join("strip data.bin"), &bin).unwrap();
    let external_path = dir.path().join("external.gltf");
    fs::write(&external_path, external.to_string()).unwrap();
    let external = load_gltf(&external_path).unwrap();

    for other in [&glb, &external] {
        assert_eq!(other.mesh.positions, reference.mesh.positions);
        assert_eq!(other.mesh.uvs, reference.mesh.uvs);
        assert_eq!(other.mesh.faces, reference.mesh.faces);
        assert_eq!(other.mesh.uv_faces, reference.mesh.uv_faces);
        assert_eq!(other.influences, reference.influences);
        assert_eq!(other.animation_names(), reference.animation_names());
    }
}

#[test]
fn indexed_strips_and_fans_give_the_same_triangles_as_the_spec() {
    // One quad as TRIANGLE_STRIP (0 1 3 2) and as TRIANGLE_FAN (0 1 2 3), indexed. The spec's
    // corner order: strip (i, i+1, i+2) for even i, (i+1, i, i+2) for odd; fan (i+1, i+2, 0).
    for (mode, order, expected) in [
        (5, [0u16, 1, 3, 2], [[0, 1, 3], [3, 1, 2]]),
        (6, [0u16, 1, 2, 3], [[1, 2, 0], [2, 3, 0]]),
    ] {
        let mut bin = Bin::default();
        let position = bin.positions(&[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ]);
        let indices = bin.u16s(&order, "SCALAR");
        let document = json!({
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "indices": indices, "mode": mode}]}],
        });
        let (document, bin) = bin.finish(document);
        let (_dir, _path, loaded) = load_document(&document, &bin);
        let loaded = loaded.unwrap();
        // Welding numbers vertices in order of first use; map back to the file's corners.
        let corner = |v: u32| {
            let p = loaded.mesh.positions[v as usize];
            [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
                .iter()
                .position(|c| c[0] == p.x && c[1] == p.y)
                .unwrap()
        };
        let faces: Vec<[usize; 3]> = loaded.mesh.faces.iter().map(|f| f.map(corner)).collect();
        assert_eq!(faces, expected, "mode {mode}");
        assert!(!loaded.mesh.has_uvs());
    }
}

#[test]
fn a_file_without_skin_is_a_plain_mesh_placed_by_its_node() {
    let (mut document, bin) = strip(&StripOptions::default());
    document["nodes"][3].as_object_mut().unwrap().remove("skin");
    let (_dir, _path, loaded) = load_document(&document, &bin);
    let plain = loaded.unwrap();
    assert!(plain.skeleton.is_none());
    assert!(plain.influences.is_empty());
    assert_eq!(plain.mesh.positions.len(), 10);
    // The node's translation (100, 0, 0) places the unskinned mesh.
    let (lo, hi) = plain.mesh.bounding_box();
    assert_eq!((lo.x, hi.x), (100.0, 102.0));
    // Animations are still listed; posing returns the rest positions.
    assert_eq!(plain.animations.len(), 4);
    assert_eq!(plain.pose(0, 0.5).unwrap(), plain.mesh.positions);
}

// ---------------------------------------------------------------------------------------------
// Posing
// ---------------------------------------------------------------------------------------------

/// The "bend" rotation of the elbow by `angle` about the z axis through (1, 0, 0).
fn bent(p: Point3<f64>, angle: f64) -> Point3<f64> {
    let (s, c) = angle.sin_cos();
    let (dx, dy) = (p.x - 1.0, p.y);
    Point3::new(1.0 + c * dx - s * dy, s * dx + c * dy, p.z)
}

#[test]
fn the_pose_at_the_start_of_an_identity_key_is_the_rest_pose() {
    let skinned = load_strip(&StripOptions::default());
    // The bend's first key is the identity rotation, equal to the elbow's rest rotation, and the
    // inverse bind matrices undo the rest world matrices (armature at z = 5 included).
    let posed = skinned.pose(0, 0.0).unwrap();
    for (p, rest) in posed.iter().zip(&skinned.mesh.positions) {
        assert_close(*p, *rest, 1e-12, "t = 0");
    }
    // The mesh node's own translation (100, 0, 0) is ignored, as glTF requires.
    assert!(posed.iter().all(|p| p.x <= 2.0));
}

#[test]
fn a_quarter_turn_of_the_elbow_moves_vertices_as_the_rotation_predicts() {
    let skinned = load_strip(&StripOptions::default());
    for (time, angle) in [
        (1.0, 2.0 * FRAC_PI_4),
        (0.5, FRAC_PI_4),
        (7.0, 2.0 * FRAC_PI_4),
    ] {
        let posed = skinned.pose(0, time).unwrap();
        for (v, rest) in skinned.mesh.positions.iter().enumerate() {
            // p = Σ w_j J_j p_rest: J_0 = identity (root bone still), J_1 = the elbow rotation.
            let w1: f64 = skinned.influences[v]
                .iter()
                .filter(|i| i.joint == 1)
                .map(|i| i.weight)
                .sum();
            let expected = Point3::from((1.0 - w1) * rest.coords + w1 * bent(*rest, angle).coords);
            assert_close(
                posed[v],
                expected,
                1e-12,
                &format!("t = {time}, vertex {v}"),
            );
        }
    }
    // Fully weighted to the elbow: the tip column turns about (1, 0, 0) exactly.
    let posed = skinned.pose(0, 1.0).unwrap();
    assert_close(
        posed[vertex_at(&skinned, 2.0, 0.0)],
        Point3::new(1.0, 1.0, 0.0),
        1e-12,
        "tip, y = 0",
    );
    assert_close(
        posed[vertex_at(&skinned, 2.0, 1.0)],
        Point3::new(0.0, 1.0, 0.0),
        1e-12,
        "tip, y = 1",
    );
    // Fully weighted to the root bone: unmoved.
    assert_close(
        posed[vertex_at(&skinned, 0.5, 1.0)],
        Point3::new(0.5, 1.0, 0.0),
        1e-12,
        "base",
    );

    let mesh = skinned.posed_mesh(0, 1.0).unwrap();
    assert_eq!(mesh.faces, skinned.mesh.faces);
    assert_eq!(mesh.uv_faces, skinned.mesh.uv_faces);
    assert_eq!(mesh.positions, posed);
}

#[test]
fn animation_names_durations_and_bad_arguments() {
    let skinned = load_strip(&StripOptions::default());
    assert_eq!(
        skinned.animation_names(),
        vec!["bend", "steps", "spline", "slide"]
    );
    let durations: Vec<f64> = (0..4).map(|a| skinned.duration(a).unwrap()).collect();
    assert_eq!(durations, vec![1.0, 2.0, 3.0, 2.0]);
    assert_eq!(skinned.animation_index("slide"), Some(3));
    assert!(matches!(
        skinned.pose(4, 0.0),
        Err(Error::InvalidArgument(_))
    ));
    assert!(matches!(
        skinned.pose(0, f64::NAN),
        Err(Error::InvalidArgument(_))
    ));
    assert!(matches!(
        skinned.duration(9),
        Err(Error::InvalidArgument(_))
    ));
}

// ---------------------------------------------------------------------------------------------
// Keyframe sampling
// ---------------------------------------------------------------------------------------------

/// Translation of the root bone (node 1) in animation `animation` at `time`.
fn root_translation(skinned: &SkinnedMesh, animation: usize, time: f64) -> Vector3<f64> {
    let skeleton = skinned.skeleton.as_ref().unwrap();
    skeleton.local_transforms(Some(&skinned.animations[animation]), time)[1].translation
}

#[test]
fn step_holds_the_last_key_and_clamps() {
    let skinned = load_strip(&StripOptions::default());
    for (time, x) in [
        (-1.0, 0.0),
        (0.0, 0.0),
        (0.5, 0.0),
        (1.0, 1.0),
        (1.999, 1.0),
        (2.0, 2.0),
        (9.0, 2.0),
    ] {
        assert_eq!(
            root_translation(&skinned, 1, time),
            Vector3::new(x, 0.0, 0.0),
            "t = {time}"
        );
    }
}

#[test]
fn linear_interpolates_translations_and_slerps_rotations() {
    let skinned = load_strip(&StripOptions::default());
    for (time, expected) in [
        (0.0, [0.0, 0.0]),
        (0.5, [0.5, 1.0]),
        (1.5, [1.5, 3.0]),
        (2.0, [2.0, 4.0]),
        (3.0, [2.0, 4.0]),
    ] {
        let t = root_translation(&skinned, 3, time);
        assert!(
            (t - Vector3::new(expected[0], expected[1], 0.0)).norm() < 1e-12,
            "t = {time}: {t}"
        );
    }
    // Halfway through the bend: 45° about z, q = (0, 0, sin 22.5°, cos 22.5°).
    let skeleton = skinned.skeleton.as_ref().unwrap();
    let elbow = skeleton.local_transforms(Some(&skinned.animations[0]), 0.5)[2].rotation;
    let expected = Vector4::new(0.0, 0.0, FRAC_PI_8.sin(), FRAC_PI_8.cos());
    assert!((elbow.coords - expected).norm() < 1e-12, "{elbow:?}");
}

#[test]
fn cubic_spline_matches_hand_computed_hermite_values() {
    let skinned = load_strip(&StripOptions::default());
    // Keys t = 0, 2, 3; values v = (0,0,0), (1,2,0), (3,2,0); b_0 = (1,0,0), a_1 = (0,0,4),
    // b_1 = 0, a_2 = (2,0,0). At t = 1 (Δt = 2, s = ½): ½ v_0 + ¼ b_0 + ½ v_1 − ¼ a_1.
    // At t = 2.5 (Δt = 1, s = ½): ½ v_1 + ⅛ b_1 + ½ v_2 − ⅛ a_2.
    for (time, expected) in [
        (-1.0, [0.0, 0.0, 0.0]),
        (0.0, [0.0, 0.0, 0.0]),
        (1.0, [0.75, 1.0, -1.0]),
        (2.0, [1.0, 2.0, 0.0]),
        (2.5, [1.75, 2.0, 0.0]),
        (3.0, [3.0, 2.0, 0.0]),
        (4.0, [3.0, 2.0, 0.0]),
    ] {
        let t = root_translation(&skinned, 2, time);
        assert!(
            (t - Vector3::from(expected)).norm() < 1e-12,
            "t = {time}: {t}"
        );
    }
}

#[test]
fn hermite_and_slerp_helpers() {
    let (v0, v1) = (
        Vector4::new(1.0, 0.0, 0.0, 0.0),
        Vector4::new(3.0, 0.0, 0.0, 0.0),
    );
    let zero = Vector4::zeros();
    assert_eq!(hermite(v0, zero, v1, zero, 0.0, 2.0), v0);
    assert_eq!(hermite(v0, zero, v1, zero, 1.0, 2.0), v1);
    assert_eq!(
        hermite(v0, zero, v1, zero, 0.5, 2.0),
        Vector4::new(2.0, 0.0, 0.0, 0.0)
    );
    // slerp takes the short way: −q is the same rotation as q.
    let identity = Vector4::new(0.0, 0.0, 0.0, 1.0);
    let quarter = Vector4::new(0.0, 0.0, FRAC_1_SQRT_2, FRAC_1_SQRT_2);
    let half_way = Vector4::new(0.0, 0.0, FRAC_PI_8.sin(), FRAC_PI_8.cos());
    assert!((slerp(identity, quarter, 0.5) - half_way).norm() < 1e-15);
    assert!((slerp(identity, -quarter, 0.5) - half_way).norm() < 1e-15);
    // Nearly equal quaternions: no 0/0.
    assert_eq!(slerp(identity, identity, 0.3), identity);
}

#[test]
fn channel_new_checks_its_keys() {
    let key = |x: f64| Vector4::new(x, 0.0, 0.0, 0.0);
    let new = |times: Vec<f64>, outputs: Vec<Vector4<f64>>, interpolation| {
        Channel::new(0, Property::Translation, interpolation, times, outputs)
    };
    assert!(new(vec![], vec![], Interpolation::Linear)
        .unwrap_err()
        .contains("no key"));
    assert!(new(
        vec![1.0, 0.0],
        vec![key(0.0), key(1.0)],
        Interpolation::Linear
    )
    .unwrap_err()
    .contains("decrease"));
    assert!(new(
        vec![0.0, 1.0],
        vec![key(0.0), key(1.0)],
        Interpolation::CubicSpline
    )
    .unwrap_err()
    .contains("6 output"));
    let zero_rotation = Channel::new(
        0,
        Property::Rotation,
        Interpolation::Step,
        vec![0.0],
        vec![Vector4::zeros()],
    );
    assert!(zero_rotation.unwrap_err().contains("zero quaternion"));
    // Equal neighbouring times are accepted: the later key wins from that time on.
    let jump = new(
        vec![0.0, 1.0, 1.0, 2.0],
        vec![key(0.0), key(1.0), key(5.0), key(6.0)],
        Interpolation::Linear,
    )
    .unwrap();
    assert_eq!(jump.sample(0.5), key(0.5));
    assert_eq!(jump.sample(1.0), key(5.0));
    assert_eq!(jump.sample(1.5), key(5.5));
}

// ---------------------------------------------------------------------------------------------
// Typed errors
// ---------------------------------------------------------------------------------------------

#[test]
fn a_missing_file_names_its_path() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nowhere.glb");
    match load_gltf(&path) {
        Err(Error::Io { path: p, .. }) => assert_eq!(p, path),
        other => panic!("expected Error::Io, got {other:?}"),
    }
}

#[test]
fn corrupt_json_and_truncated_glb_are_parse_errors() {
    let dir = tempfile::tempdir().unwrap();
    let json_path = dir.path().join("broken.gltf");
    fs::write(
        &json_path,
        "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [",
    )
    .unwrap();
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend(4u32.to_le_bytes()); // a total length shorter than the header itself
    let glb_path = dir.path().join("broken.glb");
    fs::write(&glb_path, glb).unwrap();
    for path in [json_path, glb_path] {
        match load_gltf(&path) {
            Err(Error::MeshParse { path: p, message }) => {
                assert_eq!(p, path);
                assert!(!message.is_empty());
            }
            other => panic!(
                "expected Error::MeshParse for {}, got {other:?}",
                path.display()
            ),
        }
    }
}

#[test]
fn a_line_primitive_is_an_error_naming_the_primitive() {
    let (mut document, bin) = strip(&StripOptions::default());
    document["meshes"][0]["primitives"][0]["mode"] = json!(1);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "mesh 0 \"strip\", primitive 0");
    assert!(message.contains("Lines"), "{message}");
}

#[test]
fn accessor_indices_out_of_range_are_errors_naming_the_attribute() {
    // POSITION: checked before the crate's validator (which would index out of bounds).
    let (mut document, bin) = strip(&StripOptions::default());
    document["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "meshes[0].primitives[0].attributes[\"POSITION\"]");
    assert!(message.contains("99"), "{message}");
    // Another attribute: the crate's validation, reported with its JSON path.
    let (mut document, bin) = strip(&StripOptions::default());
    document["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = json!(99);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, _) = gltf_error(loaded, &path);
    assert!(element.contains("WEIGHTS_0"), "{element}");
}

#[test]
fn vertex_indices_out_of_range_are_errors_naming_the_index() {
    let mut bin = Bin::default();
    let position = bin.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]);
    let indices = bin.u16s(&[0, 1, 50], "SCALAR");
    let document = json!({
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": position}, "indices": indices}]}],
    });
    let (document, bin) = bin.finish(document);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "mesh 0, primitive 0, indices (accessor 1)");
    assert!(message.contains("index 2 is 50"), "{message}");
}

#[test]
fn accessors_reading_past_their_buffer_view_or_of_the_wrong_type_are_errors() {
    let (mut document, bin) = strip(&StripOptions::default());
    document["accessors"][0]["count"] = json!(1000);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(
        element,
        "mesh 0 \"strip\", primitive 0, POSITION (accessor 0)"
    );
    assert!(message.contains("do not fit"), "{message}");

    let (mut document, bin) = strip(&StripOptions::default());
    document["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = json!(0);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert!(element.contains("TEXCOORD_0 (accessor 0)"), "{element}");
    assert!(message.contains("expected Vec2"), "{message}");
}

#[test]
fn bad_skin_weights_are_errors_naming_the_vertex() {
    // Corner 0 refers to joint 7 of a 2-joint skin.
    let (document, mut bin) = strip(&StripOptions::default());
    let joints0_offset = document["bufferViews"][2]["byteOffset"].as_u64().unwrap() as usize;
    bin[joints0_offset..joints0_offset + 2].copy_from_slice(&7u16.to_le_bytes());
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "mesh 0 \"strip\", primitive 0, vertex 0");
    assert!(message.contains("joint 7"), "{message}");

    // Corner 1 has all weights zero.
    let (document, mut bin) = strip(&StripOptions::default());
    let weights0_offset = document["bufferViews"][3]["byteOffset"].as_u64().unwrap() as usize;
    bin[weights0_offset + 16..weights0_offset + 32].fill(0);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "mesh 0 \"strip\", primitive 0, vertex 1");
    assert!(message.contains("zero"), "{message}");
}

#[test]
fn decreasing_key_times_are_errors_naming_the_channel() {
    let (document, mut bin) = strip(&StripOptions::default());
    // The "steps" input accessor holds 0, 1, 2: make the last key 0.5.
    let input = document["animations"][1]["samplers"][0]["input"]
        .as_u64()
        .unwrap() as usize;
    let view = document["accessors"][input]["bufferView"].as_u64().unwrap() as usize;
    let offset = document["bufferViews"][view]["byteOffset"]
        .as_u64()
        .unwrap() as usize;
    bin[offset + 8..offset + 12].copy_from_slice(&0.5f32.to_le_bytes());
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(
        element,
        "animation 1 \"steps\", channel 0 (node 1 \"root bone\", Translation)"
    );
    assert!(message.contains("decrease at key 2"), "{message}");
}

#[test]
fn structural_problems_are_errors_naming_the_element() {
    // A cycle in the node hierarchy.
    let (mut document, bin) = strip(&StripOptions::default());
    document["nodes"][2]["children"] = json!([0]);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "node 0 \"armature\"");
    assert!(message.contains("cycle"), "{message}");
    // A missing external buffer names the buffer and its URI.
    let (mut document, bin) = strip(&StripOptions::default());
    document["buffers"][0]["uri"] = json!("missing.bin");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("strip.gltf");
    fs::write(&path, document.to_string()).unwrap();
    let (element, _) = gltf_error(load_gltf(&path), &path);
    assert_eq!(element, "buffer 0 (\"missing.bin\")");
    drop(bin);
    // A node index that does not exist, and a node without mesh, given as options.
    let (document, bin) = strip(&StripOptions::default());
    let path = write_gltf(dir.path(), "strip.gltf", &document, &bin);
    for (node, expected) in [(9, "node 9"), (0, "node 0 \"armature\"")] {
        let options = GltfOptions {
            node: Some(node),
            ..GltfOptions::default()
        };
        let (element, _) = gltf_error(load_gltf_with(&path, &options), &path);
        assert_eq!(element, expected);
    }
}

#[test]
fn animation_channels_on_a_missing_node_or_the_matrix_path_are_errors_naming_the_channel() {
    // Issue #25: `gltf` leaves channel targets unchecked and panics on reading them (an index
    // out of range in `Target::node`, an unwrapped invalid path in `Target::property`).
    let (mut document, bin) = strip(&StripOptions::default());
    document["animations"][1]["channels"][0]["target"]["node"] = json!(42);
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "animations[1].channels[0].target.node");
    assert!(message.contains("node 42 does not exist"), "{message}");
    let (mut document, bin) = strip(&StripOptions::default());
    document["animations"][0]["channels"][0]["target"]["path"] = json!("matrix");
    let (_dir, path, loaded) = load_document(&document, &bin);
    let (element, message) = gltf_error(loaded, &path);
    assert_eq!(element, "animations[0].channels[0].target.path");
    assert!(message.contains("\"matrix\""), "{message}");
    let shown = Error::Gltf {
        path: path.clone(),
        element,
        message,
    }
    .to_string();
    assert!(!shown.contains('\n'), "one line: {shown}");
}
