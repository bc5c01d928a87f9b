//! Shared geometry: the triangle mesh, its adjacency, file I/O and built-in meshes.

pub mod adjacency;
pub mod distance;
pub mod io;
pub mod manifold;
pub(crate) mod obj_check;
pub(crate) mod off;
pub(crate) mod ply;
pub mod procedural;
pub mod skin;
pub mod trimesh;

pub use adjacency::{Adjacency, EdgeKind, EDGE_CORNERS};
pub use io::{load_obj, write_obj};
pub use manifold::{check_manifold, load_mesh};
pub use off::load_off;
pub use ply::load_ply;
pub use skin::{load_gltf, load_gltf_base_colour, load_gltf_with, GltfOptions, SkinnedMesh};
pub use trimesh::TriMesh;
