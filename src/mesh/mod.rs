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

/// The first point with a coordinate beyond ±`limit` (or not a number): its index and that
/// coordinate. Shared by the range checks of `crosscheck` and of the remesh distance figures.
pub fn first_beyond(points: &[nalgebra::Point3<f64>], limit: f64) -> Option<(usize, f64)> {
    points.iter().enumerate().find_map(|(index, p)| {
        p.iter()
            .find(|x| x.is_nan() || x.abs() > limit)
            .map(|&value| (index, value))
    })
}
