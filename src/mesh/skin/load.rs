//! Reading glTF 2.0 files (`.gltf` with embedded or external buffers, `.glb`) into a
//! [`SkinnedMesh`].
//!
//! The `gltf` crate parses and validates the JSON and loads the buffers; the accessors are read
//! here (`read_accessor`), so that every size, type and range is checked and reported with the
//! element it belongs to instead of panicking inside the crate.

use std::path::{Path, PathBuf};

use gltf::accessor::{DataType, Dimensions};
use gltf::animation::Property as GltfProperty;
use gltf::mesh::{Mode, Semantic};
use gltf::{Accessor, Document, Node};
use nalgebra::{
    Matrix3, Matrix4, Point2, Point3, Quaternion, Rotation3, UnitQuaternion, Vector3, Vector4,
};

use super::weld::{clean_influences, weld, without_welding, Soup};
use super::{
    compose_world, Animation, Channel, GltfReport, Influence, Interpolation, Joint, Property,
    SceneNode, Skeleton, SkinnedMesh, Trs,
};
use crate::error::{Error, Result};
use crate::input::{check_count, read_input, Length, Reference};
use crate::mesh::TriMesh;

/// Options of [`load_gltf_with`].
#[derive(Clone, Debug)]
pub struct GltfOptions {
    /// Load the mesh of this glTF node (skinned or not) instead of choosing as [`load_gltf`]
    /// does. Default: `None`.
    pub node: Option<usize>,
    /// Weld corners into shared vertices as [`load_gltf`] describes. With `false` the glTF
    /// vertices stay as stored (concatenated over primitives). Default: `true`.
    pub weld: bool,
}

impl Default for GltfOptions {
    fn default() -> Self {
        GltfOptions {
            node: None,
            weld: true,
        }
    }
}

/// Load a glTF 2.0 file (`.gltf` or `.glb`) with the default [`GltfOptions`].
///
/// **Which mesh.** The first node (in file order) that has both a mesh and a skin: all of its
/// triangle primitives, with the skin's joints, the whole node hierarchy and every animation.
/// Other mesh nodes are skipped (counted in [`GltfReport::skipped_mesh_nodes`]). A file without
/// any skinned mesh node loads as a plain mesh: all mesh nodes, each placed by its node's rest
/// world matrix, no skeleton (posing then returns the rest positions).
///
/// **Rest pose.** For a skinned mesh, the `POSITION`s as stored: the bind pose, in the space
/// the inverse bind matrices expect (the mesh node's own transform is ignored, as glTF requires
/// for skinned meshes).
///
/// **Attributes.** `POSITION`; `TEXCOORD_0` with v flipped to the OBJ convention
/// (`v_obj = 1 − v_gltf`, origin at the bottom-left; no UVs at all when one primitive lacks
/// them); `JOINTS_n`/`WEIGHTS_n` for every set n = 0, 1, … present. Weights are cleaned: zero
/// weights dropped, a repeated joint's weights added, rescaled to sum 1, sorted by decreasing
/// weight. Indexed and non-indexed primitives; TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN
/// (strips and fans split into triangles as the glTF spec orders their corners). Normals,
/// tangents, colours and materials are ignored; morph targets too (the base shape is loaded and
/// [`GltfReport::morph_target_primitives`] counts them), and so are animation channels on morph
/// weights. The texture is the first primitive's base colour texture when it is an external
/// file (embedded images are not extracted).
///
/// **Welding.** Corners with exactly equal positions and identical influences become one
/// vertex; exactly equal UVs share a UV index; so UV seams stay seams without cutting the
/// surface. Corners at one position with different influences stay separate vertices (counted
/// in [`GltfReport::split_positions`]). Vertices and UVs are numbered in order of first use by
/// the triangles; triangles keep the file order (primitive by primitive).
///
/// **Errors** ([`Error::Io`], [`Error::MeshParse`], [`Error::Gltf`], [`Error::EmptyMesh`]) name
/// the file and the element: the JSON path of a validation error, or node / mesh / primitive /
/// accessor / vertex / skin / animation channel. Among them: points and lines primitives,
/// sparse accessors, accessors of the wrong type or reaching outside their buffer, vertex or
/// joint indices out of range, negative or all-zero weights, non-finite numbers, decreasing key
/// times, a node hierarchy with cycles.
pub fn load_gltf(path: &Path) -> Result<SkinnedMesh> {
    load_gltf_with(path, &GltfOptions::default())
}

/// [`load_gltf`] with options: which node's mesh, whether to weld.
pub fn load_gltf_with(path: &Path, options: &GltfOptions) -> Result<SkinnedMesh> {
    let file = GltfFile::open(path)?;
    let nodes = file.read_nodes()?;
    let parent_first = file.parent_first_order(&nodes)?;
    let mut report = GltfReport::default();

    let (soup, skeleton, texture) = match file.choose_mesh_nodes(options)? {
        MeshChoice::Skinned(node, skin) => {
            let skeleton = file.read_skeleton(&node, &skin, nodes, parent_first)?;
            let joint_count = skeleton.joints.len();
            let soup = file.read_node_mesh(&node, Some(joint_count), None, &mut report)?;
            report.mesh_nodes = vec![node.index()];
            (soup, Some(skeleton), file.base_color_texture(&node)?)
        }
        MeshChoice::Static(mesh_nodes) => {
            let rest: Vec<Trs> = nodes.iter().map(|n| n.rest).collect();
            let world = compose_world(&nodes, &parent_first, &rest);
            let mut soup = Soup::default();
            for node in &mesh_nodes {
                let placement = Some(&world[node.index()]);
                soup.append(file.read_node_mesh(node, None, placement, &mut report)?);
            }
            report.mesh_nodes = mesh_nodes.iter().map(Node::index).collect();
            let texture = match mesh_nodes.first() {
                Some(node) => file.base_color_texture(node)?,
                None => None,
            };
            (soup, None, texture)
        }
    };
    report.skipped_mesh_nodes = file.mesh_node_count() - report.mesh_nodes.len();

    let welded = if options.weld {
        weld(&soup)
    } else {
        without_welding(soup)
    };
    report.split_positions = welded.split_positions;
    report.degenerate_faces = welded.degenerate_faces;
    let mesh = TriMesh {
        positions: welded.positions,
        uvs: welded.uvs,
        faces: welded.faces,
        uv_faces: welded.uv_faces,
        texture,
        name: path.display().to_string(),
    };
    mesh.validate()?;
    let animations = file.read_animations(&mut report)?;
    let influences = match skeleton {
        Some(_) => welded.influences,
        None => Vec::new(),
    };
    Ok(SkinnedMesh {
        mesh,
        influences,
        skeleton,
        animations,
        report,
    })
}

/// A parsed and validated glTF document with its buffers loaded.
struct GltfFile {
    path: PathBuf,
    document: Document,
    buffers: Vec<Vec<u8>>,
}

/// The mesh node(s) to load.
enum MeshChoice<'a> {
    Skinned(Node<'a>, gltf::Skin<'a>),
    Static(Vec<Node<'a>>),
}

/// What an accessor must look like: its element type and allowed component types.
struct Expect {
    dimensions: Dimensions,
    types: &'static [DataType],
}

const POSITIONS: Expect = Expect {
    dimensions: Dimensions::Vec3,
    types: &[DataType::F32],
};
const TEX_COORDS: Expect = Expect {
    dimensions: Dimensions::Vec2,
    types: &[DataType::F32, DataType::U8, DataType::U16],
};
const JOINTS: Expect = Expect {
    dimensions: Dimensions::Vec4,
    types: &[DataType::U8, DataType::U16],
};
const WEIGHTS: Expect = Expect {
    dimensions: Dimensions::Vec4,
    types: &[DataType::F32, DataType::U8, DataType::U16],
};
const INDICES: Expect = Expect {
    dimensions: Dimensions::Scalar,
    types: &[DataType::U8, DataType::U16, DataType::U32],
};
const INVERSE_BIND_MATRICES: Expect = Expect {
    dimensions: Dimensions::Mat4,
    types: &[DataType::F32],
};
const KEY_TIMES: Expect = Expect {
    dimensions: Dimensions::Scalar,
    types: &[DataType::F32],
};
const KEY_VECTORS: Expect = Expect {
    dimensions: Dimensions::Vec3,
    types: &[DataType::F32],
};
const KEY_ROTATIONS: Expect = Expect {
    dimensions: Dimensions::Vec4,
    types: &[
        DataType::F32,
        DataType::I8,
        DataType::U8,
        DataType::I16,
        DataType::U16,
    ],
};

impl GltfFile {
    /// Read, parse and validate the file, and load its buffers.
    fn open(path: &Path) -> Result<GltfFile> {
        let bytes = read_input(path)?;
        let gltf::Gltf { document, mut blob } = parse_document(&bytes, path)?;
        let mut file = GltfFile {
            path: path.to_path_buf(),
            document,
            buffers: Vec::new(),
        };
        let base = path.parent().unwrap_or(Path::new("."));
        for buffer in file.document.buffers() {
            let data = file.load_buffer(&buffer, base, &mut blob)?;
            file.buffers.push(data);
        }
        Ok(file)
    }

    /// A typed error naming this file and `element`.
    fn error(&self, element: impl Into<String>, message: impl Into<String>) -> Error {
        Error::Gltf {
            path: self.path.clone(),
            element: element.into(),
            message: message.into(),
        }
    }

    /// The bytes of one buffer: the GLB `BIN` chunk, a `data:` URI or an external file. An
    /// external file is read through [`Reference::read`]: by default inside the glTF's folder,
    /// a regular file, at least `byteLength` bytes long, of which `byteLength` are read and no
    /// more (`"uri": "/dev/urandom"` read until the memory ran out).
    fn load_buffer(
        &self,
        buffer: &gltf::Buffer,
        base: &Path,
        blob: &mut Option<Vec<u8>>,
    ) -> Result<Vec<u8>> {
        let kind = format!("buffer {} URI", buffer.index());
        let declared = buffer.length() as u64;
        if let gltf::buffer::Source::Uri(uri) = buffer.source() {
            if !uri.starts_with("data:") {
                let written = external_path(uri).map_err(|m| self.reference(&kind, uri, m))?;
                let reference = Reference {
                    model: &self.path,
                    kind: &kind,
                    written: &written,
                };
                return reference.read(Length::Declared(declared))?.map_err(|e| {
                    let element = format!("buffer {} ({uri:?})", buffer.index());
                    self.error(element, e.to_string())
                });
            }
        }
        let data = gltf::buffer::Data::from_source_and_blob(buffer.source(), Some(base), blob)
            .map_err(|e| self.error(format!("buffer {}", buffer.index()), e.to_string()))?;
        if (data.0.len() as u64) < declared {
            let message = format!("has {} bytes, the file declares {declared}", data.0.len());
            return Err(self.error(format!("buffer {}", buffer.index()), message));
        }
        Ok(data.0)
    }

    /// An [`Error::Reference`] for the URI `uri` named by `kind` in this file.
    fn reference(&self, kind: &str, uri: &str, reason: String) -> Error {
        Reference {
            model: &self.path,
            kind,
            written: uri,
        }
        .error(reason)
    }

    /// Every node with its name, parent and rest TRS. A node listed as the child of two nodes is
    /// an error.
    fn read_nodes(&self) -> Result<Vec<SceneNode>> {
        let mut nodes = Vec::new();
        for node in self.document.nodes() {
            let rest = node_trs(&node).map_err(|m| self.error(node_label(&node), m))?;
            let name = node
                .name()
                .map_or_else(|| format!("node {}", node.index()), String::from);
            nodes.push(SceneNode {
                name,
                parent: None,
                rest,
            });
        }
        for node in self.document.nodes() {
            for child in node.children() {
                if let Some(other) = nodes[child.index()].parent {
                    let message =
                        format!("is a child of both node {other} and node {}", node.index());
                    return Err(self.error(node_label(&child), message));
                }
                nodes[child.index()].parent = Some(node.index());
            }
        }
        Ok(nodes)
    }

    /// Node indices with parents before children (breadth first from the roots). A node not
    /// reached from a root is on a cycle: an error.
    fn parent_first_order(&self, nodes: &[SceneNode]) -> Result<Vec<usize>> {
        let mut children = vec![Vec::new(); nodes.len()];
        for (i, node) in nodes.iter().enumerate() {
            if let Some(parent) = node.parent {
                children[parent].push(i);
            }
        }
        let mut order: Vec<usize> = (0..nodes.len())
            .filter(|&i| nodes[i].parent.is_none())
            .collect();
        let mut next = 0;
        while next < order.len() {
            order.extend_from_slice(&children[order[next]]);
            next += 1;
        }
        if order.len() < nodes.len() {
            let mut reached = vec![false; nodes.len()];
            order.iter().for_each(|&i| reached[i] = true);
            let on_cycle = reached.iter().position(|r| !r).unwrap_or(0);
            return Err(self.error(
                format!("node {on_cycle} {:?}", nodes[on_cycle].name),
                "is on a cycle of the node hierarchy",
            ));
        }
        Ok(order)
    }

    fn mesh_node_count(&self) -> usize {
        self.document.nodes().filter(|n| n.mesh().is_some()).count()
    }

    /// `options.node` if given, else the first skinned mesh node, else all mesh nodes.
    fn choose_mesh_nodes(&self, options: &GltfOptions) -> Result<MeshChoice<'_>> {
        if let Some(index) = options.node {
            let count = self.document.nodes().len();
            let node = self.document.nodes().nth(index).ok_or_else(|| {
                self.error(
                    format!("node {index}"),
                    format!("does not exist ({count} nodes)"),
                )
            })?;
            if node.mesh().is_none() {
                return Err(self.error(node_label(&node), "has no mesh"));
            }
            return Ok(match node.skin() {
                Some(skin) => MeshChoice::Skinned(node, skin),
                None => MeshChoice::Static(vec![node]),
            });
        }
        let all: Vec<Node> = self
            .document
            .nodes()
            .filter(|n| n.mesh().is_some())
            .collect();
        let first_skinned = all.iter().find_map(|n| Some((n.clone(), n.skin()?)));
        if let Some((node, skin)) = first_skinned {
            return Ok(MeshChoice::Skinned(node, skin));
        }
        if all.is_empty() {
            return Err(Error::EmptyMesh {
                mesh: format!("{} (no node has a mesh)", self.path.display()),
            });
        }
        Ok(MeshChoice::Static(all))
    }

    /// The skin of `node`: its joints with their inverse bind matrices (identity when the skin
    /// has none), plus the node hierarchy.
    fn read_skeleton(
        &self,
        node: &Node,
        skin: &gltf::Skin,
        nodes: Vec<SceneNode>,
        parent_first: Vec<usize>,
    ) -> Result<Skeleton> {
        let element = format!("skin {} (of {})", skin.index(), node_label(node));
        let joint_nodes: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        if joint_nodes.is_empty() {
            return Err(self.error(element, "has no joints"));
        }
        let inverse_binds = match skin.inverse_bind_matrices() {
            None => vec![Matrix4::identity(); joint_nodes.len()],
            Some(accessor) => {
                let flat = self.read_accessor(&accessor, &INVERSE_BIND_MATRICES, &element)?;
                let matrices: Vec<Matrix4<f64>> = flat
                    .chunks_exact(16)
                    .map(Matrix4::from_column_slice)
                    .collect();
                if matrices.len() < joint_nodes.len() {
                    let message = format!(
                        "has {} joints but {} inverse bind matrices",
                        joint_nodes.len(),
                        matrices.len()
                    );
                    return Err(self.error(element, message));
                }
                if let Some(j) = matrices
                    .iter()
                    .position(|m| !m.iter().all(|x| x.is_finite()))
                {
                    let message = format!("inverse bind matrix {j} is not finite");
                    return Err(self.error(element, message));
                }
                matrices
            }
        };
        let joints = joint_nodes
            .into_iter()
            .zip(inverse_binds)
            .map(|(node, inverse_bind)| Joint { node, inverse_bind })
            .collect();
        Ok(Skeleton {
            nodes,
            parent_first,
            joints,
            mesh_node: node.index(),
        })
    }

    /// All primitives of the mesh of `node`, concatenated. `joint_count`: the skin's joint
    /// count for a skinned mesh (influences are read), `None` otherwise. `placement`: a matrix
    /// applied to the positions (the node's world matrix for unskinned meshes).
    fn read_node_mesh(
        &self,
        node: &Node,
        joint_count: Option<usize>,
        placement: Option<&Matrix4<f64>>,
        report: &mut GltfReport,
    ) -> Result<Soup> {
        let mut soup = Soup::default();
        let Some(mesh) = node.mesh() else {
            return Ok(soup);
        };
        for primitive in mesh.primitives() {
            let element = format!("{}, primitive {}", mesh_label(&mesh), primitive.index());
            let mut part = self.read_primitive(&primitive, &element, joint_count, report)?;
            if let Some(matrix) = placement {
                part.positions
                    .iter_mut()
                    .for_each(|p| *p = matrix.transform_point(p));
            }
            soup.append(part);
        }
        Ok(soup)
    }

    /// One primitive's vertices (positions, UVs, influences) and triangles.
    fn read_primitive(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        joint_count: Option<usize>,
        report: &mut GltfReport,
    ) -> Result<Soup> {
        let triangle_mode = matches!(
            primitive.mode(),
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        );
        if !triangle_mode {
            let message = format!(
                "mode {:?} is not supported (only TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN)",
                primitive.mode()
            );
            return Err(self.error(element, message));
        }
        let positions = self.read_positions(primitive, element)?;
        let count = positions.len();
        let uvs = self.read_tex_coords(primitive, element, count)?;
        let influences = match joint_count {
            Some(joints) => self.read_influences(primitive, element, count, joints, report)?,
            None => vec![Vec::new(); count],
        };
        let indices = self.read_indices(primitive, element, count)?;
        let triangles =
            assemble_triangles(primitive.mode(), &indices).map_err(|m| self.error(element, m))?;

        report.primitives += 1;
        report.gltf_vertices += count;
        report.primitives_without_uvs += usize::from(uvs.is_none());
        report.morph_target_primitives += usize::from(primitive.morph_targets().len() > 0);
        Ok(Soup {
            positions,
            uvs,
            influences,
            triangles,
        })
    }

    fn read_positions(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
    ) -> Result<Vec<Point3<f64>>> {
        let accessor = primitive
            .get(&Semantic::Positions)
            .ok_or_else(|| self.error(element, "has no POSITION attribute"))?;
        let flat = self.read_accessor(&accessor, &POSITIONS, &format!("{element}, POSITION"))?;
        let positions: Vec<Point3<f64>> = flat.chunks_exact(3).map(Point3::from_slice).collect();
        if let Some(v) = positions
            .iter()
            .position(|p| !p.iter().all(|x| x.is_finite()))
        {
            let message = format!(
                "position is not finite ({:?})",
                positions[v].coords.as_slice()
            );
            return Err(self.error(format!("{element}, vertex {v}"), message));
        }
        Ok(positions)
    }

    /// `TEXCOORD_0` with v flipped to the OBJ convention: `(u, 1 − v)`. `None` without it.
    fn read_tex_coords(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        count: usize,
    ) -> Result<Option<Vec<Point2<f64>>>> {
        let Some(accessor) = primitive.get(&Semantic::TexCoords(0)) else {
            return Ok(None);
        };
        let element = format!("{element}, TEXCOORD_0");
        let flat = self.read_attribute(&accessor, &TEX_COORDS, &element, count)?;
        let uvs: Vec<Point2<f64>> = flat
            .chunks_exact(2)
            .map(|t| Point2::new(t[0], 1.0 - t[1]))
            .collect();
        if let Some(v) = uvs
            .iter()
            .position(|t| !(t.x.is_finite() && t.y.is_finite()))
        {
            let message = format!(
                "texture coordinate is not finite ({} {})",
                uvs[v].x, uvs[v].y
            );
            return Err(self.error(format!("{element}, vertex {v}"), message));
        }
        Ok(Some(uvs))
    }

    /// The cleaned influences of every vertex from all `JOINTS_n` / `WEIGHTS_n` sets.
    fn read_influences(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        count: usize,
        joint_count: usize,
        report: &mut GltfReport,
    ) -> Result<Vec<Vec<Influence>>> {
        let mut raw: Vec<Vec<(u32, f64)>> = vec![Vec::new(); count];
        for set in 0u32.. {
            let joints = primitive.get(&Semantic::Joints(set));
            let weights = primitive.get(&Semantic::Weights(set));
            let (joints, weights) = match (joints, weights) {
                (Some(j), Some(w)) => (j, w),
                (None, None) if set > 0 => break,
                _ => {
                    let message =
                        format!("a skinned mesh needs both JOINTS_{set} and WEIGHTS_{set}");
                    return Err(self.error(element, message));
                }
            };
            let joints =
                self.read_attribute(&joints, &JOINTS, &format!("{element}, JOINTS_{set}"), count)?;
            let weights = self.read_attribute(
                &weights,
                &WEIGHTS,
                &format!("{element}, WEIGHTS_{set}"),
                count,
            )?;
            for (v, pairs) in raw.iter_mut().enumerate() {
                let pair = |c: usize| (joints[4 * v + c] as u32, weights[4 * v + c]);
                pairs.extend((0..4).map(pair));
            }
        }
        let mut influences = Vec::with_capacity(count);
        for (v, pairs) in raw.iter().enumerate() {
            let vertex = || format!("{element}, vertex {v}");
            let clean = clean_influences(pairs).map_err(|m| self.error(vertex(), m))?;
            if let Some(bad) = clean
                .influences
                .iter()
                .find(|i| i.joint as usize >= joint_count)
            {
                let message = format!(
                    "refers to joint {} but the skin has {joint_count} joints",
                    bad.joint
                );
                return Err(self.error(vertex(), message));
            }
            report.renormalised_vertices += usize::from(clean.renormalised);
            report.repeated_joint_vertices += usize::from(clean.repeated_joint);
            influences.push(clean.influences);
        }
        Ok(influences)
    }

    /// The index list, or `0, 1, …, count − 1` for a non-indexed primitive; every index must
    /// name one of the `count` vertices.
    fn read_indices(
        &self,
        primitive: &gltf::Primitive,
        element: &str,
        count: usize,
    ) -> Result<Vec<u32>> {
        let Some(accessor) = primitive.indices() else {
            return Ok((0..count as u32).collect());
        };
        let element = format!("{element}, indices");
        let flat = self.read_accessor(&accessor, &INDICES, &element)?;
        if let Some(k) = flat.iter().position(|&i| i as usize >= count) {
            let message = format!(
                "index {k} is {}, but the primitive has {count} vertices",
                flat[k]
            );
            return Err(self.error(
                format!("{element} (accessor {})", accessor.index()),
                message,
            ));
        }
        Ok(flat.into_iter().map(|i| i as u32).collect())
    }

    /// A per-vertex attribute: like [`read_accessor`](Self::read_accessor), and it must have
    /// `count` elements like `POSITION`.
    fn read_attribute(
        &self,
        accessor: &Accessor,
        expect: &Expect,
        element: &str,
        count: usize,
    ) -> Result<Vec<f64>> {
        if accessor.count() != count {
            let message = format!(
                "accessor {} has {} elements, POSITION has {count}",
                accessor.index(),
                accessor.count()
            );
            return Err(self.error(element, message));
        }
        self.read_accessor(accessor, expect, element)
    }

    /// The accessor's components as f64, element after element (`count × components` numbers;
    /// matrices column by column). Integer components of a `normalized` accessor are mapped to
    /// [0, 1] (unsigned, `c / (2ⁿ − 1)`) or [−1, 1] (signed, `max(c / (2ⁿ⁻¹ − 1), −1)`).
    ///
    /// Errors (naming `element` and the accessor): wrong element or component type, sparse
    /// accessor, a byte stride shorter than an element, data reaching past the buffer view or
    /// the view past its buffer.
    fn read_accessor(
        &self,
        accessor: &Accessor,
        expect: &Expect,
        element: &str,
    ) -> Result<Vec<f64>> {
        let element = format!("{element} (accessor {})", accessor.index());
        let fail = |message: String| self.error(&element, message);
        let (dimensions, data_type) = (accessor.dimensions(), accessor.data_type());
        if dimensions != expect.dimensions || !expect.types.contains(&data_type) {
            return Err(fail(format!(
                "is {dimensions:?} of {data_type:?}, expected {:?} of one of {:?}",
                expect.dimensions, expect.types
            )));
        }
        if accessor.sparse().is_some() {
            return Err(fail("sparse accessors are not supported".to_string()));
        }
        let Some(view) = accessor.view() else {
            return Err(fail("has no buffer view".to_string()));
        };
        let bytes = self.view_bytes(&view).map_err(&fail)?;
        let layout = Layout {
            offset: accessor.offset(),
            count: accessor.count(),
            components: dimensions.multiplicity(),
            data_type,
            stride: view.stride(),
        };
        read_components(bytes, &layout, accessor.normalized()).map_err(fail)
    }

    /// The bytes of a buffer view, checked to lie inside its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View) -> std::result::Result<&[u8], String> {
        let buffer = &self.buffers[view.buffer().index()];
        let (start, length) = (view.offset(), view.length());
        start
            .checked_add(length)
            .and_then(|end| buffer.get(start..end))
            .ok_or_else(|| {
                format!(
                    "buffer view {} (bytes {start}..{start}+{length}) lies outside buffer {} ({} bytes)",
                    view.index(),
                    view.buffer().index(),
                    buffer.len()
                )
            })
    }

    /// The first primitive's base colour texture when it is an external image file, checked as
    /// a reference ([`Reference::resolve_file`]: by default in the glTF's folder; a regular file
    /// when it exists). A URI that is not a file path (`data:`, `http:`) is no texture here.
    fn base_color_texture(&self, node: &Node) -> Result<Option<PathBuf>> {
        let Some(mesh) = node.mesh() else {
            return Ok(None);
        };
        let external = mesh.primitives().find_map(|primitive| {
            let material = primitive.material();
            let image = material
                .pbr_metallic_roughness()
                .base_color_texture()?
                .texture()
                .source();
            match image.source() {
                gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                    Some((image.index(), external_path(uri).ok()?))
                }
                _ => None,
            }
        });
        let Some((index, written)) = external else {
            return Ok(None);
        };
        let kind = format!("image {index} URI");
        Reference {
            model: &self.path,
            kind: &kind,
            written: &written,
        }
        .resolve_file()
        .map(Some)
    }

    /// Every animation's translation / rotation / scale channels; morph-weight channels are
    /// skipped and counted.
    fn read_animations(&self, report: &mut GltfReport) -> Result<Vec<Animation>> {
        let mut animations = Vec::new();
        for animation in self.document.animations() {
            let name = animation
                .name()
                .map_or_else(|| format!("animation {}", animation.index()), String::from);
            let mut channels = Vec::new();
            for (c, channel) in animation.channels().enumerate() {
                let property = match channel.target().property() {
                    GltfProperty::Translation => Property::Translation,
                    GltfProperty::Rotation => Property::Rotation,
                    GltfProperty::Scale => Property::Scale,
                    GltfProperty::MorphTargetWeights => {
                        report.ignored_weight_channels += 1;
                        continue;
                    }
                };
                let element = format!(
                    "animation {} {name:?}, channel {c} ({}, {property:?})",
                    animation.index(),
                    node_label(&channel.target().node())
                );
                channels.push(self.read_channel(&channel, property, &element)?);
            }
            animations.push(Animation { name, channels });
        }
        Ok(animations)
    }

    /// One channel: key times, outputs as (x, y, z, 0) or quaternions (x, y, z, w).
    fn read_channel(
        &self,
        channel: &gltf::animation::Channel,
        property: Property,
        element: &str,
    ) -> Result<Channel> {
        let sampler = channel.sampler();
        let times =
            self.read_accessor(&sampler.input(), &KEY_TIMES, &format!("{element}, input"))?;
        let (expect, n) = match property {
            Property::Rotation => (&KEY_ROTATIONS, 4),
            _ => (&KEY_VECTORS, 3),
        };
        let flat = self.read_accessor(&sampler.output(), expect, &format!("{element}, output"))?;
        let to_vector = |c: &[f64]| Vector4::new(c[0], c[1], c[2], if n == 4 { c[3] } else { 0.0 });
        let outputs = flat.chunks_exact(n).map(to_vector).collect();
        let interpolation = match sampler.interpolation() {
            gltf::animation::Interpolation::Step => Interpolation::Step,
            gltf::animation::Interpolation::Linear => Interpolation::Linear,
            gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
        };
        let node = channel.target().node().index();
        Channel::new(node, property, interpolation, times, outputs)
            .map_err(|m| self.error(element, m))
    }
}

/// Parse a `.gltf` (JSON) or `.glb` (binary) file and validate it.
///
/// Four checks run before the crate's own validation, which would otherwise panic: a GLB header
/// length below the header size, a `POSITION` accessor index out of range (the crate's
/// validator looks the accessor up unchecked), animation channel targets (the crate does not
/// validate them and panics on reading a missing node or an unknown path such as `"matrix"`),
/// and image sources ([`check_image_sources`]).
fn parse_document(bytes: &[u8], path: &Path) -> Result<gltf::Gltf> {
    let parse_error = |message: String| Error::MeshParse {
        path: path.to_path_buf(),
        message,
    };
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 {
            return Err(parse_error(format!(
                "GLB header declares a length of {length} bytes"
            )));
        }
    }
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| parse_error(format!("not a glTF 2.0 file: {e}")))?;
    let json = document.into_json();
    check_position_accessors(&json, path)?;
    check_animation_targets(&json, path)?;
    check_image_sources(&json, path)?;
    let document = Document::from_json(json).map_err(|e| match e {
        gltf::Error::Validation(problems) => validation_error(&problems, path),
        other => parse_error(other.to_string()),
    })?;
    Ok(gltf::Gltf { document, blob })
}

/// Every `POSITION` attribute names an existing accessor.
fn check_position_accessors(json: &gltf::json::Root, path: &Path) -> Result<()> {
    use gltf::json::validation::Checked;
    let count = json.accessors.len();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let key = Checked::Valid(gltf::json::mesh::Semantic::Positions);
            if let Some(index) = primitive.attributes.get(&key) {
                if index.value() >= count {
                    return Err(Error::Gltf {
                        path: path.to_path_buf(),
                        element: format!("meshes[{m}].primitives[{p}].attributes[\"POSITION\"]"),
                        message: format!(
                            "accessor {} does not exist ({count} accessors)",
                            index.value()
                        ),
                    });
                }
            }
        }
    }
    Ok(())
}

/// Every animation channel targets an existing node and a known path (`translation`,
/// `rotation`, `scale` or `weights`). `gltf` 1.4 leaves both unchecked and then panics in
/// `Target::node` (index out of range) and `Target::property` (unwraps an invalid path).
fn check_animation_targets(json: &gltf::json::Root, path: &Path) -> Result<()> {
    use gltf::json::validation::Checked;
    let nodes = json.nodes.len();
    for (a, animation) in json.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let element = |field: &str| format!("animations[{a}].channels[{c}].target.{field}");
            let error = |field: &str, message: String| Error::Gltf {
                path: path.to_path_buf(),
                element: element(field),
                message,
            };
            let node = channel.target.node.value();
            if node >= nodes {
                return Err(error(
                    "node",
                    format!("node {node} does not exist ({nodes} nodes); point the channel at an existing node or remove it"),
                ));
            }
            if matches!(channel.target.path, Checked::Invalid) {
                return Err(error(
                    "path",
                    "not one of translation, rotation, scale, weights (glTF animates no other \
                     property, e.g. not \"matrix\"); fix the path or remove the channel"
                        .into(),
                ));
            }
        }
    }
    Ok(())
}

/// Every image has a source `gltf` 1.4 can read: a `uri`, or an existing `bufferView` with a
/// `mimeType`. `Image::source` unwraps both and the crate's validator checks neither (an image
/// without `uri` panicked when its material was read, found by the reference mutation of
/// `tests/fuzz_parsers.rs`, issue #35).
fn check_image_sources(json: &gltf::json::Root, path: &Path) -> Result<()> {
    let views = json.buffer_views.len();
    for (i, image) in json.images.iter().enumerate() {
        let message = match (&image.uri, &image.buffer_view, &image.mime_type) {
            (None, None, _) => "has neither a `uri` nor a `bufferView`".to_string(),
            (_, Some(_), None) => "has a `bufferView` but no `mimeType`".to_string(),
            (_, Some(view), _) if view.value() >= views => {
                format!(
                    "buffer view {} does not exist ({views} buffer views)",
                    view.value()
                )
            }
            _ => continue,
        };
        return Err(Error::Gltf {
            path: path.to_path_buf(),
            element: format!("images[{i}]"),
            message: format!("{message}; give the image a source or remove it"),
        });
    }
    Ok(())
}

/// The crate's validation problems as one error: the first problem's JSON path and message.
fn validation_error(
    problems: &[(gltf::json::Path, gltf::json::validation::Error)],
    path: &Path,
) -> Error {
    let (element, message) = match problems.first() {
        Some((json_path, problem)) => (json_path.to_string(), problem.to_string()),
        None => ("document".to_string(), "invalid".to_string()),
    };
    Error::Gltf {
        path: path.to_path_buf(),
        element,
        message: format!(
            "{message} ({} validation problem(s) in all)",
            problems.len()
        ),
    }
}

/// Where an accessor's elements lie in its buffer view.
struct Layout {
    /// Byte offset of the first element in the view.
    offset: usize,
    count: usize,
    /// Components per element (3 for VEC3, 16 for MAT4).
    components: usize,
    data_type: DataType,
    /// Bytes from one element to the next; `None`: tightly packed.
    stride: Option<usize>,
}

/// Read `count` elements as f64 from `bytes`, checking that they fit.
fn read_components(
    bytes: &[u8],
    layout: &Layout,
    normalized: bool,
) -> std::result::Result<Vec<f64>, String> {
    let size = layout.data_type.size();
    let element_size = layout.components * size;
    let stride = layout.stride.unwrap_or(element_size);
    if stride < element_size {
        return Err(format!(
            "byte stride {stride} is shorter than an element ({element_size} bytes)"
        ));
    }
    // `count` elements from `offset` take (count − 1)·stride + element_size bytes, so they fit
    // when count·stride ≤ view − offset + stride − element_size.
    let room = (bytes.len() + (stride - element_size)).saturating_sub(layout.offset);
    let unit = format!(
        "bytes of its buffer view from byte {} (stride {stride}, elements of {element_size} \
         bytes); they do not fit",
        layout.offset
    );
    check_count(
        "the accessor count",
        layout.count as u64,
        stride as u64,
        room as u64,
        &unit,
    )?;
    let mut values = Vec::with_capacity(layout.count * layout.components);
    for e in 0..layout.count {
        let start = layout.offset + e * stride;
        for c in 0..layout.components {
            let at = start + c * size;
            values.push(component(
                &bytes[at..at + size],
                layout.data_type,
                normalized,
            ));
        }
    }
    Ok(values)
}

/// One little-endian component as f64 (glTF 2.0 §3.6.2 and §3.11 for the normalised ints).
fn component(bytes: &[u8], data_type: DataType, normalized: bool) -> f64 {
    let signed = |x: f64, max: f64| if normalized { (x / max).max(-1.0) } else { x };
    let unsigned = |x: f64, max: f64| if normalized { x / max } else { x };
    match data_type {
        DataType::I8 => signed(bytes[0] as i8 as f64, 127.0),
        DataType::U8 => unsigned(bytes[0] as f64, 255.0),
        DataType::I16 => signed(i16::from_le_bytes([bytes[0], bytes[1]]) as f64, 32767.0),
        DataType::U16 => unsigned(u16::from_le_bytes([bytes[0], bytes[1]]) as f64, 65535.0),
        DataType::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    }
}

/// Split a primitive's index list into triangles (glTF 2.0 §3.7.2.1):
/// TRIANGLES `(i₃ₖ, i₃ₖ₊₁, i₃ₖ₊₂)`; TRIANGLE_STRIP `(iₖ, iₖ₊₁, iₖ₊₂)` for even k and
/// `(iₖ₊₁, iₖ, iₖ₊₂)` for odd k (keeping the winding); TRIANGLE_FAN `(iₖ₊₁, iₖ₊₂, i₀)`.
fn assemble_triangles(mode: Mode, indices: &[u32]) -> std::result::Result<Vec<[u32; 3]>, String> {
    let n = indices.len();
    let i = |k: usize| indices[k];
    match mode {
        Mode::Triangles if !n.is_multiple_of(3) => {
            Err(format!("{n} indices is not a multiple of 3"))
        }
        Mode::Triangles => Ok(indices
            .chunks_exact(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect()),
        Mode::TriangleStrip => Ok((0..n.saturating_sub(2))
            .map(|k| {
                if k % 2 == 0 {
                    [i(k), i(k + 1), i(k + 2)]
                } else {
                    [i(k + 1), i(k), i(k + 2)]
                }
            })
            .collect()),
        Mode::TriangleFan => Ok((0..n.saturating_sub(2))
            .map(|k| [i(k + 1), i(k + 2), i(0)])
            .collect()),
        other => Err(format!("mode {other:?} has no triangles")),
    }
}

/// A node's rest transform as TRS (a `matrix` is decomposed); `Err` for non-finite numbers or
/// a zero rotation quaternion.
fn node_trs(node: &Node) -> std::result::Result<Trs, String> {
    let trs = match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let columns: Vec<f64> = matrix.iter().flatten().map(|&x| x as f64).collect();
            decompose_matrix(&Matrix4::from_column_slice(&columns))
        }
        gltf::scene::Transform::Decomposed {
            translation: t,
            rotation: [x, y, z, w],
            scale: s,
        } => {
            let q = Quaternion::new(w as f64, x as f64, y as f64, z as f64);
            if q.norm() == 0.0 {
                return Err("rotation is the zero quaternion".to_string());
            }
            Trs {
                translation: Vector3::from(t.map(f64::from)),
                rotation: UnitQuaternion::new_normalize(q),
                scale: Vector3::from(s.map(f64::from)),
            }
        }
    };
    let finite = trs
        .translation
        .iter()
        .chain(trs.scale.iter())
        .chain(trs.rotation.coords.iter());
    if !finite.into_iter().all(|x| x.is_finite()) {
        return Err("transform is not finite".to_string());
    }
    Ok(trs)
}

/// Split an affine matrix `M = T · R · S` (glTF node matrices have no shear) into its parts:
/// T is the last column; scale `sᵢ` is the length of column i of the 3×3 part (the first one
/// negated when the determinant is negative, so that R stays a rotation); R is the 3×3 part with
/// column i divided by `sᵢ` (left as is for a zero scale).
fn decompose_matrix(m: &Matrix4<f64>) -> Trs {
    let translation = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
    let mut linear: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
    let mut scale = Vector3::new(
        linear.column(0).norm(),
        linear.column(1).norm(),
        linear.column(2).norm(),
    );
    if linear.determinant() < 0.0 {
        scale.x = -scale.x;
    }
    for i in 0..3 {
        if scale[i] != 0.0 {
            let mut column = linear.column_mut(i);
            column /= scale[i];
        }
    }
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(linear));
    Trs {
        translation,
        rotation,
        scale,
    }
}

/// `node 3 "Hips"`, or `node 3` without a name.
fn node_label(node: &Node) -> String {
    match node.name() {
        Some(name) => format!("node {} {name:?}", node.index()),
        None => format!("node {}", node.index()),
    }
}

/// `mesh 0 "fox1"`, or `mesh 0` without a name.
fn mesh_label(mesh: &gltf::Mesh) -> String {
    match mesh.name() {
        Some(name) => format!("mesh {} {name:?}", mesh.index()),
        None => format!("mesh {}", mesh.index()),
    }
}

/// Decode `%XX` escapes of a relative URI; `None` when the result is not UTF-8. Invalid escapes
/// are kept as written (as the `gltf` crate's decoder does).
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let hex = |k: usize| bytes.get(k).and_then(|&b| (b as char).to_digit(16));
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut k = 0;
    while k < bytes.len() {
        match (bytes[k], hex(k + 1), hex(k + 2)) {
            (b'%', Some(high), Some(low)) => {
                decoded.push((high * 16 + low) as u8);
                k += 3;
            }
            (byte, _, _) => {
                decoded.push(byte);
                k += 1;
            }
        }
    }
    String::from_utf8(decoded).ok()
}

/// The file path an external URI names: a relative URI percent-decoded, or the path of a
/// `file:` URI (as the `gltf` crate reads it). `Err` for another scheme or a relative URI that
/// does not decode to UTF-8.
fn external_path(uri: &str) -> std::result::Result<String, String> {
    if let Some(path) = uri
        .strip_prefix("file://")
        .or_else(|| uri.strip_prefix("file:"))
    {
        return Ok(path.to_string());
    }
    if uri.contains(':') {
        return Err("unsupported URI scheme (only relative paths, file: and data: URIs)".into());
    }
    percent_decode(uri).ok_or_else(|| "the URI is not valid percent-encoded UTF-8".into())
}

/// The base-colour image of the first material (in document order) that has one, decoded to
/// RGBA8: embedded in a GLB's `BIN` chunk or a buffer view (a `bufferView` image), or an
/// external file next to the glTF. `Ok(None)` when no material has a base-colour texture.
///
/// Errors ([`Error::Gltf`] naming the image, [`Error::Image`], [`Error::Io`]): an unreadable
/// file, a buffer view outside its buffer, an undecodable image.
pub fn load_gltf_base_colour(path: &Path) -> Result<Option<crate::texture::Image<[u8; 4]>>> {
    let file = GltfFile::open(path)?;
    let Some(image) = file.document.materials().find_map(|m| {
        m.pbr_metallic_roughness()
            .base_color_texture()
            .map(|info| info.texture().source())
    }) else {
        return Ok(None);
    };
    let element = format!("image {}", image.index());
    let decoded = match image.source() {
        gltf::image::Source::View { view, .. } => {
            let bytes = file
                .view_bytes(&view)
                .map_err(|m| file.error(&element, m))?;
            // Decoded with the checks of an image file; its errors name the glTF's image.
            crate::texture::decode_image(bytes, path).map_err(|e| match e {
                Error::Image { message, .. } => {
                    file.error(&element, format!("cannot decode: {message}"))
                }
                other => other,
            })?
        }
        gltf::image::Source::Uri { uri, .. } => {
            let written = external_path(uri).map_err(|m| file.reference(&element, uri, m))?;
            let full = Reference {
                model: path,
                kind: &format!("{element} URI"),
                written: &written,
            }
            .resolve_file()?;
            return crate::texture::load_rgba8(&full).map(Some);
        }
    };
    let rgba = decoded.to_rgba8();
    let (w, h) = (rgba.width() as usize, rgba.height() as usize);
    let pixels = rgba.pixels().map(|p| p.0).collect();
    Ok(Some(crate::texture::Image {
        width: w,
        height: h,
        pixels,
    }))
}
