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
    /// One parallel sort of the 3F directed edges by their undirected key (min vertex, max
    /// vertex) brings the faces sharing an edge together; each record is then classified from its
    /// group alone, in parallel, and scattered to its face. O(F log F), deterministic.
    pub fn new(mesh: &TriMesh) -> Self {
        let records = sorted_edge_records(mesh);
        let groups = group_ranges(&records);
        let kinds: Vec<(u32, EdgeKind, bool)> = groups
            .par_iter()
            .flat_map_iter(|group| {
                let members = &records[group.clone()];
                (0..members.len()).map(move |k| {
                    let (kind, first) = classify_record(mesh, members, k);
                    (members[k].flat, kind, first)
                })
            })
            .collect();
        let mut edges = vec![[EdgeKind::Boundary; 3]; mesh.faces.len()];
        let mut adjacency = Adjacency {
            edges: Vec::new(),
            boundary_edges: 0,
            seam_edges: 0,
            non_manifold_edges: 0,
            misoriented_edges: 0,
            first_non_manifold: None,
        };
        for (i, &(flat, kind, first_of_group)) in kinds.iter().enumerate() {
            edges[flat as usize / 3][flat as usize % 3] = kind;
            // Count each undirected edge once, at the first record of its group.
            if first_of_group {
                match kind {
                    EdgeKind::Boundary => adjacency.boundary_edges += 1,
                    EdgeKind::Seam { .. } => adjacency.seam_edges += 1,
                    EdgeKind::Misoriented { .. } => adjacency.misoriented_edges += 1,
                    EdgeKind::NonManifold => {
                        adjacency.non_manifold_edges += 1;
                        let r = &records[i];
                        adjacency.first_non_manifold.get_or_insert((r.lo, r.hi));
                    }
                    EdgeKind::Interior { .. } => {}
                }
            }
        }
        adjacency.edges = edges;
        adjacency
    }

    /// The face across local edge `e` of face `f`, if the edge is interior.
    pub fn neighbour(&self, f: usize, e: usize) -> Option<(usize, usize)> {
        self.edges[f][e].interior()
    }
}

/// One directed edge: its undirected key and where it lives (`flat` = 3·face + local edge).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct EdgeRecord {
    lo: u32,
    hi: u32,
    flat: u32,
}

/// All 3F directed edges sorted by (lo, hi, flat): the records of one undirected edge are
/// contiguous and in face order.
///
/// A counting sort on `lo` (bucket offsets by prefix sum, records written in face order), then
/// each bucket, a vertex's few edges, sorted in parallel: O(F) and deterministic, several times
/// faster than a comparison sort of the 3F records. Indices must be in range (validated mesh).
fn sorted_edge_records(mesh: &TriMesh) -> Vec<EdgeRecord> {
    let record = |f: usize, e: usize| {
        let [a, b] = EDGE_CORNERS[e];
        let (va, vb) = (mesh.faces[f][a], mesh.faces[f][b]);
        EdgeRecord {
            lo: va.min(vb),
            hi: va.max(vb),
            flat: (3 * f + e) as u32,
        }
    };
    let vertices = mesh
        .faces
        .iter()
        .flatten()
        .max()
        .map_or(0, |&v| v as usize + 1);
    let mut offsets = vec![0usize; vertices + 1];
    for f in 0..mesh.faces.len() {
        for e in 0..3 {
            offsets[record(f, e).lo as usize + 1] += 1;
        }
    }
    for v in 0..vertices {
        offsets[v + 1] += offsets[v];
    }
    let mut cursor = offsets.clone();
    let mut records = vec![
        EdgeRecord {
            lo: 0,
            hi: 0,
            flat: 0
        };
        3 * mesh.faces.len()
    ];
    for f in 0..mesh.faces.len() {
        for e in 0..3 {
            let r = record(f, e);
            records[cursor[r.lo as usize]] = r;
            cursor[r.lo as usize] += 1;
        }
    }
    let mut buckets = Vec::with_capacity(vertices);
    let mut rest = records.as_mut_slice();
    for v in 0..vertices {
        let (bucket, tail) = rest.split_at_mut(offsets[v + 1] - offsets[v]);
        buckets.push(bucket);
        rest = tail;
    }
    buckets
        .into_par_iter()
        .for_each(|bucket| bucket.sort_unstable());
    records
}

/// The index ranges of the runs of records sharing one undirected edge, in order, found in one
/// pass: O(records) however many faces share an edge (a per-record scan of its run would be
/// quadratic in the run's length, e.g. 200 000 faces of one degenerate polygon on one edge).
fn group_ranges(records: &[EdgeRecord]) -> Vec<std::ops::Range<usize>> {
    let mut groups = Vec::new();
    let mut start = 0;
    for i in 1..=records.len() {
        let ends = i == records.len()
            || (records[i].lo, records[i].hi) != (records[start].lo, records[start].hi);
        if ends {
            groups.push(start..i);
            start = i;
        }
    }
    groups
}

/// What lies across record `k` of `group`, and whether `k` is the group's first record.
fn classify_record(mesh: &TriMesh, group: &[EdgeRecord], k: usize) -> (EdgeKind, bool) {
    let face_edge = |r: &EdgeRecord| (r.flat as usize / 3, r.flat as usize % 3);
    let kind = match group.len() {
        1 => EdgeKind::Boundary,
        2 => {
            let (this, other) = (face_edge(&group[k]), face_edge(&group[1 - k]));
            classify_pair(mesh, this, other).edge(other.0, other.1)
        }
        _ => EdgeKind::NonManifold,
    };
    (kind, k == 0)
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
