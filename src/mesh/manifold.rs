//! Loading any supported mesh file, and the 2-manifold check that algorithms needing a surface
//! (MAPS) run first.

use std::path::Path;

use rayon::prelude::*;

use super::adjacency::{Adjacency, EdgeKind, EDGE_CORNERS};
use super::trimesh::TriMesh;
use crate::error::{Error, Result};

/// Load an OBJ, PLY or OFF file, chosen by the extension (case-insensitive).
pub fn load_mesh(path: &Path) -> Result<TriMesh> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => super::io::load_obj(path),
        Some("ply") => super::ply::load_ply(path),
        Some("off") => super::off::load_off(path),
        _ => Err(Error::MeshParse {
            path: path.to_path_buf(),
            message: "unknown mesh format (expected .obj, .ply or .off)".into(),
        }),
    }
}

/// At most this many offending edges and vertices are listed in a [`Error::NonManifoldMesh`].
pub const MAX_LISTED: usize = 16;

/// Check that `mesh` is a valid, consistently oriented 2-manifold triangle mesh (with or without
/// boundary): every face has three distinct vertices and non-zero area, every edge has one or
/// two faces traversing it in opposite directions, and the faces around every vertex form one
/// fan (a disk or a half-disk).
///
/// Errors: [`Error::DegenerateFace`] for a repeated vertex or a zero-area face,
/// [`Error::NonManifoldMesh`] listing the offending edges (3+ faces or inconsistent
/// orientation) and vertices (more than one fan), sorted, at most [`MAX_LISTED`] of each.
pub fn check_manifold(mesh: &TriMesh) -> Result<()> {
    mesh.validate()?;
    check_faces(mesh)?;
    // Position-only adjacency: UV seams are irrelevant to the surface.
    let surface = TriMesh {
        uvs: Vec::new(),
        uv_faces: Vec::new(),
        ..mesh.clone()
    };
    let adjacency = Adjacency::new(&surface);
    let mut bad_edges: Vec<(u32, u32)> = Vec::new();
    for (f, kinds) in adjacency.edges.iter().enumerate() {
        for (e, kind) in kinds.iter().enumerate() {
            if matches!(kind, EdgeKind::NonManifold | EdgeKind::Misoriented { .. }) {
                let [a, b] = EDGE_CORNERS[e].map(|c| mesh.faces[f][c]);
                bad_edges.push((a.min(b), a.max(b)));
            }
        }
    }
    bad_edges.sort_unstable();
    bad_edges.dedup();
    let bad_vertices = if bad_edges.is_empty() {
        non_manifold_vertices(mesh, &adjacency)
    } else {
        Vec::new()
    };
    if bad_edges.is_empty() && bad_vertices.is_empty() {
        return Ok(());
    }
    Err(Error::NonManifoldMesh {
        mesh: mesh.name.clone(),
        edge_count: bad_edges.len(),
        vertex_count: bad_vertices.len(),
        edges: bad_edges.into_iter().take(MAX_LISTED).collect(),
        vertices: bad_vertices.into_iter().take(MAX_LISTED).collect(),
    })
}

/// Faces with a repeated vertex or exactly zero area.
fn check_faces(mesh: &TriMesh) -> Result<()> {
    for (f, &[a, b, c]) in mesh.faces.iter().enumerate() {
        let reason = if a == b || b == c || c == a {
            Some("a vertex is repeated".to_string())
        } else {
            let [p, q, r] = mesh.face_positions(f);
            ((q - p).cross(&(r - p)).norm() == 0.0).then(|| "zero area".to_string())
        };
        if let Some(reason) = reason {
            return Err(Error::DegenerateFace {
                mesh: mesh.name.clone(),
                face: f,
                reason,
            });
        }
    }
    Ok(())
}

/// Vertices whose incident faces form more than one fan (connected through edges at the
/// vertex), e.g. two cones touching at their apex. Assumes every edge is manifold.
fn non_manifold_vertices(mesh: &TriMesh, adjacency: &Adjacency) -> Vec<u32> {
    let n = mesh.positions.len();
    let mut start = vec![0usize; n + 1];
    for f in &mesh.faces {
        for &v in f {
            start[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = start.clone();
    let mut incident = vec![0u32; start[n]];
    for (fi, f) in mesh.faces.iter().enumerate() {
        for &v in f {
            incident[fill[v as usize]] = fi as u32;
            fill[v as usize] += 1;
        }
    }
    (0..n)
        .into_par_iter()
        .filter(|&v| {
            let faces = &incident[start[v]..start[v + 1]];
            fan_count(mesh, adjacency, v as u32, faces) > 1
        })
        .map(|v| v as u32)
        .collect()
}

/// Number of fans around `v`: components of its faces linked across edges that contain `v`.
/// `faces` must be sorted (as [`non_manifold_vertices`] builds it).
fn fan_count(mesh: &TriMesh, adjacency: &Adjacency, v: u32, faces: &[u32]) -> usize {
    let mut seen = vec![false; faces.len()];
    let mut fans = 0;
    for s in 0..faces.len() {
        if seen[s] {
            continue;
        }
        fans += 1;
        let mut stack = vec![s];
        seen[s] = true;
        while let Some(k) = stack.pop() {
            let f = faces[k] as usize;
            for (e, corners) in EDGE_CORNERS.iter().enumerate() {
                if !corners.iter().any(|&c| mesh.faces[f][c] == v) {
                    continue;
                }
                if let Some((g, _)) = adjacency.edges[f][e].interior() {
                    // `faces` is in increasing order (filled in face order): a binary search
                    // keeps a vertex in every face of a huge fan O(d log d), not O(d²).
                    if let Ok(m) = faces.binary_search(&(g as u32)) {
                        if !seen[m] {
                            seen[m] = true;
                            stack.push(m);
                        }
                    }
                }
            }
        }
    }
    fans
}
