//! Features (notes "Features"; seed "Preserving Image Features"): user-tagged corner vertices
//! and feature edges, and their automatic detection by curvature and dihedral-angle thresholds.
//!
//! Rules used by the hierarchy ([`super::hierarchy`]): a corner is never removed; a vertex with
//! exactly two feature edges is a feature-line vertex, removed only with the chord joining its
//! two feature neighbours kept as a constraint (the chord inherits the tag); a vertex with one
//! or three and more feature edges is a corner. Boundary edges behave as feature edges.

use std::collections::BTreeSet;
use std::path::Path;

use nalgebra::Point3;

use super::priority::{curvature, star_normal};
use crate::error::{Error, Result};
use crate::mesh::{Adjacency, TriMesh, EDGE_CORNERS};

/// Tagged corners and feature edges of a mesh (vertex indices of the input mesh; an edge is
/// stored as (min, max)).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Features {
    /// Vertices that must survive to the base domain.
    pub corners: BTreeSet<u32>,
    /// Edges that must map onto base edges.
    pub edges: BTreeSet<(u32, u32)>,
}

/// Thresholds of the automatic detection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureOptions {
    /// An edge is a feature edge when the angle between its two face normals exceeds this
    /// (radians). Default 60° (an interior dihedral angle below 120°, seed "Edge Paths").
    pub dihedral_angle: f64,
    /// A vertex is a corner when κ(i)·h̄(i) exceeds this, κ = |κ₁| + |κ₂| of the local fit
    /// ([`curvature`]) and h̄ the mean length of its edges (dimensionless). Default 4: for a
    /// cone apex κ·h̄ ≈ 4 cot α, so cones of half-angle below 45° keep their apex.
    pub corner_curvature: f64,
    /// A feature-line or boundary vertex is a corner when its two feature edges turn by more
    /// than this (radians, 0 = straight). Default 60°.
    pub corner_turn: f64,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        FeatureOptions {
            dihedral_angle: 60f64.to_radians(),
            corner_curvature: 4.0,
            corner_turn: 60f64.to_radians(),
        }
    }
}

impl Features {
    /// Whether (a, b) is a tagged feature edge.
    pub fn has_edge(&self, a: u32, b: u32) -> bool {
        self.edges.contains(&(a.min(b), a.max(b)))
    }

    /// Check every index against `mesh` (corners < V, edges are edges of the mesh).
    pub fn validate(&self, mesh: &TriMesh) -> Result<()> {
        let n = mesh.positions.len() as u32;
        if let Some(&v) = self.corners.iter().find(|&&v| v >= n) {
            return Err(Error::InvalidArgument(format!(
                "{}: feature corner {v} is not a vertex (the mesh has {n})",
                mesh.name
            )));
        }
        let mut mesh_edges = BTreeSet::new();
        for f in &mesh.faces {
            for [a, b] in EDGE_CORNERS {
                mesh_edges.insert((f[a].min(f[b]), f[a].max(f[b])));
            }
        }
        if let Some(e) = self.edges.iter().find(|e| !mesh_edges.contains(e)) {
            return Err(Error::InvalidArgument(format!(
                "{}: feature edge {e:?} is not an edge of the mesh",
                mesh.name
            )));
        }
        Ok(())
    }
}

/// Read a feature sidecar file: one statement per line, `v I` tags vertex I (0-based) as a
/// corner, `e I J` tags the edge I–J; `#` starts a comment. Errors name `path:line`.
pub fn load_features(path: &Path) -> Result<Features> {
    let text = crate::input::read_input_text(path)?;
    parse_features(&text, path)
}

/// Parse the sidecar format of [`load_features`]; `path` is used in error messages.
pub fn parse_features(text: &str, path: &Path) -> Result<Features> {
    let mut features = Features::default();
    for (n, line) in text.lines().enumerate() {
        let err = |m: &str| Error::MeshParse {
            path: path.to_path_buf(),
            message: format!("line {}: {m}", n + 1),
        };
        let words: Vec<&str> = line
            .split('#')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        let index = |w: Option<&&str>| -> Result<u32> {
            w.and_then(|w| w.parse::<u32>().ok())
                .ok_or_else(|| err("expected a vertex index (0-based)"))
        };
        match words.first() {
            None => {}
            Some(&"v") => {
                features.corners.insert(index(words.get(1))?);
            }
            Some(&"e") => {
                let (a, b) = (index(words.get(1))?, index(words.get(2))?);
                if a == b {
                    return Err(err("a feature edge needs two different vertices"));
                }
                features.edges.insert((a.min(b), a.max(b)));
            }
            Some(w) => return Err(err(&format!("unknown statement `{w}` (expected v or e)"))),
        }
    }
    Ok(features)
}

/// Automatic detection (seed "Preserving Image Features (2/2)"): feature edges where the face
/// normals differ by more than `dihedral_angle`; corners where κ·h̄ > `corner_curvature`.
/// (Chain ends, junctions and sharp turns of feature lines become corners in the hierarchy,
/// see [`vertex_role`].) The mesh must be a checked 2-manifold.
pub fn detect_features(mesh: &TriMesh, options: &FeatureOptions) -> Features {
    let surface = TriMesh {
        uvs: Vec::new(),
        uv_faces: Vec::new(),
        ..mesh.clone()
    };
    let adjacency = Adjacency::new(&surface);
    let normal = |f: usize| {
        let [p, q, r] = mesh.face_positions(f);
        (q - p).cross(&(r - p)).normalize()
    };
    let mut features = Features::default();
    let cos_limit = options.dihedral_angle.cos();
    for (f, kinds) in adjacency.edges.iter().enumerate() {
        for (e, kind) in kinds.iter().enumerate() {
            if let Some((g, _)) = kind.interior() {
                if f < g && normal(f).dot(&normal(g)) < cos_limit {
                    let [a, b] = EDGE_CORNERS[e].map(|c| mesh.faces[f][c]);
                    features.edges.insert((a.min(b), a.max(b)));
                }
            }
        }
    }
    let n = mesh.positions.len();
    let mut star: Vec<Vec<[u32; 3]>> = vec![Vec::new(); n];
    for f in &mesh.faces {
        for &v in f {
            star[v as usize].push(*f);
        }
    }
    for (v, faces) in star.iter().enumerate() {
        let ring: BTreeSet<u32> = faces
            .iter()
            .flatten()
            .copied()
            .filter(|&w| w as usize != v)
            .collect();
        let ring: Vec<Point3<f64>> = ring.iter().map(|&w| mesh.positions[w as usize]).collect();
        if ring.is_empty() {
            continue;
        }
        let centre = mesh.positions[v];
        let mean_edge = ring.iter().map(|q| (q - centre).norm()).sum::<f64>() / ring.len() as f64;
        let kappa = curvature(&centre, &ring, &star_normal(&mesh.positions, faces));
        if kappa * mean_edge > options.corner_curvature {
            features.corners.insert(v as u32);
        }
    }
    features
}

/// What the hierarchy may do with a vertex, from its feature (and boundary) edges.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VertexRole {
    /// No feature edge: removable with the disk map.
    Free,
    /// Exactly two feature or boundary edges, turning by at most `corner_turn`: removable with
    /// the split (half-disk) map and the chord as a constraint.
    Line,
    /// Never removed.
    Corner,
}

/// The role of a vertex with `feature_neighbours` (the other ends of its feature and boundary
/// edges), tagged `corner` or not: Corner if tagged, if the count is not 0 or 2, or if the two
/// feature edges turn by more than `corner_turn` (angle between p − q₀ and q₁ − p).
pub fn vertex_role(
    positions: &[Point3<f64>],
    v: u32,
    corner: bool,
    feature_neighbours: &[u32],
    corner_turn: f64,
) -> VertexRole {
    if corner {
        return VertexRole::Corner;
    }
    match feature_neighbours {
        [] => VertexRole::Free,
        [q0, q1] => {
            let p = positions[v as usize];
            let d0 = p - positions[*q0 as usize];
            let d1 = positions[*q1 as usize] - p;
            let turn = d0.cross(&d1).norm().atan2(d0.dot(&d1));
            if turn > corner_turn {
                VertexRole::Corner
            } else {
                VertexRole::Line
            }
        }
        _ => VertexRole::Corner,
    }
}
