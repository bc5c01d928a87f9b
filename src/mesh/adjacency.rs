//! Edge adjacency of a [`TriMesh`]: which face lies across each edge, and which edges are
//! boundaries, UV seams or non-manifold.
//!
//! Edges are found by sorting `(min vertex, max vertex, face, edge)` records, which is
//! deterministic and parallel (no hash-map iteration order leaks into results).

use rayon::prelude::*;

use super::trimesh::TriMesh;

/// Local edge `e` of a face joins corner `e` to corner `(e + 1) % 3`: 0 = ij, 1 = jk, 2 = ki.
pub const EDGE_CORNERS: [[usize; 2]; 3] = [[0, 1], [1, 2], [2, 0]];

/// What lies across one edge of one face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeKind {
    /// Exactly one other face shares the edge, traverses it in the opposite direction, and has
    /// the same texture coordinates at both ends.
    Interior { face: u32, edge: u8 },
    /// No other face shares the edge.
    Boundary,
    /// One other face shares the edge in 3D, but the texture coordinates differ (a UV seam).
    Seam { face: u32, edge: u8 },
    /// One other face shares the edge but traverses it in the same direction (inconsistent
    /// orientation across the edge).
    Misoriented { face: u32, edge: u8 },
    /// Three or more faces share the edge.
    NonManifold,
}

impl EdgeKind {
    /// The neighbouring face and its local edge index when the edge is interior.
    pub fn interior(self) -> Option<(usize, usize)> {
        match self {
            EdgeKind::Interior { face, edge } => Some((face as usize, edge as usize)),
            _ => None,
        }
    }
}

/// Per-face, per-edge adjacency and counts of the special edges.
#[derive(Clone, Debug)]
pub struct Adjacency {
    /// `edges[f][e]`: what lies across local edge `e` of face `f` (see [`EDGE_CORNERS`]).
    pub edges: Vec<[EdgeKind; 3]>,
    /// Number of undirected boundary edges.
    pub boundary_edges: usize,
    /// Number of undirected UV-seam edges.
    pub seam_edges: usize,
    /// Number of undirected edges shared by three or more faces.
    pub non_manifold_edges: usize,
    /// Number of undirected edges whose two faces disagree on orientation.
    pub misoriented_edges: usize,
    /// The first non-manifold edge found (smallest vertex pair), for error messages.
    pub first_non_manifold: Option<(u32, u32)>,
}

impl Adjacency {
    /// Build the adjacency of `mesh`. UV seams are only detected when the mesh has UVs.
    ///
    /// Complexity O(F log F) (one parallel sort of the 3F directed edges).
    pub fn new(mesh: &TriMesh) -> Self {
        // (lo, hi, face, local edge)
        let mut records: Vec<(u32, u32, u32, u8)> = mesh
            .faces
            .par_iter()
            .enumerate()
            .flat_map_iter(|(f, tri)| {
                EDGE_CORNERS.iter().enumerate().map(move |(e, &[a, b])| {
                    let (va, vb) = (tri[a], tri[b]);
                    (va.min(vb), va.max(vb), f as u32, e as u8)
                })
            })
            .collect();
        records.par_sort_unstable();

        let mut edges = vec![[EdgeKind::Boundary; 3]; mesh.faces.len()];
        let (mut boundary, mut seam, mut non_manifold, mut misoriented) = (0, 0, 0, 0);
        let mut first_non_manifold = None;
        let mut start = 0;
        while start < records.len() {
            let (lo, hi) = (records[start].0, records[start].1);
            let mut end = start + 1;
            while end < records.len() && records[end].0 == lo && records[end].1 == hi {
                end += 1;
            }
            let group = &records[start..end];
            match group.len() {
                1 => boundary += 1,
                2 => {
                    let (f0, e0) = (group[0].2 as usize, group[0].3 as usize);
                    let (f1, e1) = (group[1].2 as usize, group[1].3 as usize);
                    let kind = classify_pair(mesh, (f0, e0), (f1, e1));
                    match kind {
                        PairKind::Interior => {}
                        PairKind::Seam => seam += 1,
                        PairKind::Misoriented => misoriented += 1,
                    }
                    edges[f0][e0] = kind.edge(f1, e1);
                    edges[f1][e1] = kind.edge(f0, e0);
                }
                _ => {
                    non_manifold += 1;
                    first_non_manifold.get_or_insert((lo, hi));
                    for r in group {
                        edges[r.2 as usize][r.3 as usize] = EdgeKind::NonManifold;
                    }
                }
            }
            start = end;
        }
        Adjacency {
            edges,
            boundary_edges: boundary,
            seam_edges: seam,
            non_manifold_edges: non_manifold,
            misoriented_edges: misoriented,
            first_non_manifold,
        }
    }

    /// The face across local edge `e` of face `f`, if the edge is interior.
    pub fn neighbour(&self, f: usize, e: usize) -> Option<(usize, usize)> {
        self.edges[f][e].interior()
    }
}

enum PairKind {
    Interior,
    Seam,
    Misoriented,
}

impl PairKind {
    fn edge(&self, face: usize, edge: usize) -> EdgeKind {
        let (face, edge) = (face as u32, edge as u8);
        match self {
            PairKind::Interior => EdgeKind::Interior { face, edge },
            PairKind::Seam => EdgeKind::Seam { face, edge },
            PairKind::Misoriented => EdgeKind::Misoriented { face, edge },
        }
    }
}

/// Two faces sharing an undirected edge: consistent orientation means face 1 runs the edge
/// b→a where face 0 runs it a→b; a seam means the UVs at the shared corners differ.
fn classify_pair(mesh: &TriMesh, (f0, e0): (usize, usize), (f1, e1): (usize, usize)) -> PairKind {
    let [a0, b0] = EDGE_CORNERS[e0];
    let [a1, b1] = EDGE_CORNERS[e1];
    let (t0, t1) = (mesh.faces[f0], mesh.faces[f1]);
    if t0[a0] != t1[b1] {
        return PairKind::Misoriented;
    }
    if mesh.has_uvs() {
        let (u0, u1) = (mesh.uv_faces[f0], mesh.uv_faces[f1]);
        let same = |x: u32, y: u32| x == y || mesh.uvs[x as usize] == mesh.uvs[y as usize];
        if !(same(u0[a0], u1[b1]) && same(u0[b0], u1[a1])) {
            return PairKind::Seam;
        }
    }
    PairKind::Interior
}
