//! Shared geometry: the triangle mesh, its adjacency, file I/O and built-in meshes.

pub mod adjacency;
pub mod io;
pub(crate) mod obj_check;
pub mod procedural;
pub mod skin;
pub mod trimesh;

pub use adjacency::{Adjacency, EdgeKind, EDGE_CORNERS};
pub use io::{load_obj, write_obj};
pub use skin::{load_gltf, load_gltf_with, GltfOptions, SkinnedMesh};
pub use trimesh::TriMesh;
