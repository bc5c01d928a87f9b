//! The start of the simplification (seed 003, slides "QEF-Edge Collapse" and "Our method"):
//! what the collapse loop of [`super::collapse`] needs before its first collapse, each in one
//! function:
//!
//! 1. [`clean_faces`]: faces without repeated vertices, UVs split so that a UV index belongs to
//!    one vertex;
//! 2. `vertex_face_lists`, [`sorted_edge_records`]: the faces of every vertex, the sides of
//!    every edge (counting sort, O(F));
//! 3. [`locked_vertices`]: the ends of non-manifold or misoriented edges, never moved;
//! 4. [`special_edges`]: boundary and UV-seam edges, whose constraint planes join the quadrics;
//! 5. [`vertex_quadrics`]: the per-pose quadrics `Q_i^j = Σ_{f∋i} K_f^j` (seed slide "Modify
//!    QEF equation"), the error every collapse cost sums over the poses;
//! 6. [`start_weights`]: the input skin weights, a vertex with more than `W_max` influences
//!    reduced by the seed's weight QP.

use nalgebra::{Matrix4, Point2, Point3};
use rayon::prelude::*;

use super::cost::{reduce_weights, Candidates};
use super::lists::Lists;
use super::quadric::{edge_constraint, unit_normal, Quadric};
use super::weights::{largest_support, Weights, MAX_CANDIDATES};
use super::Options;
use crate::mesh::EDGE_CORNERS;

/// Faces, UV faces and UVs.
pub type CleanFaces = (Vec<[u32; 3]>, Vec<[u32; 3]>, Vec<Point2<f64>>);

/// Faces without repeated vertices, and UVs split so that each UV index belongs to one vertex
/// (a UV shared by two positions gets one copy per position), so that remapping a UV index
/// touches one vertex only.
pub fn clean_faces(mesh: &crate::mesh::TriMesh) -> CleanFaces {
    let keep: Vec<usize> = (0..mesh.faces.len())
        .filter(|&f| {
            let [x, y, z] = mesh.faces[f];
            x != y && y != z && z != x
        })
        .collect();
    let faces: Vec<[u32; 3]> = keep.iter().map(|&f| mesh.faces[f]).collect();
    if !mesh.has_uvs() {
        return (faces, Vec::new(), Vec::new());
    }
    // The copies of each vertex's UVs as a chain: `first[v]` its first copy, `next[c]` the
    // copy after `c`, `source[c]` the input UV of copy `c` (a vertex has few copies).
    const END: u32 = u32::MAX;
    let mut first = vec![END; mesh.positions.len()];
    let (mut next, mut source): (Vec<u32>, Vec<u32>) = (Vec::new(), Vec::new());
    let mut uvs = Vec::new();
    let mut uv_faces = Vec::with_capacity(faces.len());
    for &f in &keep {
        let t = [0, 1, 2].map(|k| {
            let (v, uv) = (mesh.faces[f][k] as usize, mesh.uv_faces[f][k]);
            let mut link = &mut first[v];
            while *link != END {
                let c = *link as usize;
                if source[c] == uv {
                    return c as u32;
                }
                link = &mut next[c];
            }
            *link = uvs.len() as u32;
            uvs.push(mesh.uvs[uv as usize]);
            source.push(uv);
            next.push(END);
            (uvs.len() - 1) as u32
        });
        uv_faces.push(t);
    }
    (faces, uv_faces, uvs)
}

/// The faces of every vertex, in face order.
pub(super) fn vertex_face_lists(faces: &[[u32; 3]], n: usize) -> Lists {
    Lists::from_pairs(n, || {
        faces
            .iter()
            .enumerate()
            .flat_map(|(f, t)| t.map(|v| (v, f as u32)))
    })
}

/// One side of an edge: its ends `lo ≤ hi` and where it lies, `3 f + e` (local edge `e` of
/// face `f`, [`EDGE_CORNERS`]).
pub type EdgeRecord = (u32, u32, u32);

/// The records of every local edge of `faces` (vertices `< n`), sorted: the records of one
/// edge are contiguous and in face order. A counting sort on `lo`, then each vertex's few
/// records sorted: O(F).
pub fn sorted_edge_records(faces: &[[u32; 3]], n: usize) -> Vec<EdgeRecord> {
    let record = |flat: usize| -> EdgeRecord {
        let (t, [i, j]) = (faces[flat / 3], EDGE_CORNERS[flat % 3]);
        (t[i].min(t[j]), t[i].max(t[j]), flat as u32)
    };
    let sides = 3 * faces.len();
    // start[v]..start[v + 1]: the records with lo = v.
    let mut start = vec![0usize; n + 1];
    for flat in 0..sides {
        start[record(flat).0 as usize + 1] += 1;
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut records = vec![(0, 0, 0); sides];
    let mut cursor = start.clone();
    for flat in 0..sides {
        let r = record(flat);
        records[cursor[r.0 as usize]] = r;
        cursor[r.0 as usize] += 1;
    }
    for v in 0..n {
        records[start[v]..start[v + 1]].sort_unstable();
    }
    records
}

/// The groups of `records` ([`sorted_edge_records`]) that are one edge each.
fn edge_groups(records: &[EdgeRecord]) -> impl Iterator<Item = &[EdgeRecord]> {
    records.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1))
}

/// Vertex `k` (0: start, 1: end) of the local edge `flat = 3 f + e` of `faces`.
fn edge_end(faces: &[[u32; 3]], flat: u32, k: usize) -> u32 {
    faces[flat as usize / 3][EDGE_CORNERS[flat as usize % 3][k]]
}

/// Vertices on a non-manifold edge (three or more faces) or a misoriented one (two faces
/// running it in the same direction) of `faces`, as [`crate::mesh::Adjacency`] classifies
/// them: never moved. `records` from [`sorted_edge_records`].
pub fn locked_vertices(faces: &[[u32; 3]], records: &[EdgeRecord], n: usize) -> Vec<bool> {
    let mut locked = vec![false; n];
    for group in edge_groups(records) {
        let lock = match group {
            [_] => false,
            [r, s] => edge_end(faces, r.2, 0) != edge_end(faces, s.2, 1),
            _ => true,
        };
        if lock {
            locked[group[0].0 as usize] = true;
            locked[group[0].1 as usize] = true;
        }
    }
    locked
}

/// The per-pose vertex quadrics of seed 003's slide "Modify QEF equation"
/// (`E_i(v) = Σ_j Σ_m (n_m^j · (v − p_i^j))² = Σ_j vᵀ Q_i^j v` over the example poses `j`):
/// `Q_i^j = Σ_{f∋i} K_f^j`, with `K_f^j = n nᵀ` the plane quadric of face `f`
/// in pose `j` ([`Quadric::from_triangle`]), plus the constraint planes of the `special`
/// (boundary and UV-seam) edges weighted by `boundary_weight` ([`edge_constraint`]), for every
/// vertex `i` and pose `j` of `positions` (`[pose][vertex]`); layout `i * P + j`. Summed face
/// by face in face order, so the sums do not depend on the thread count.
pub fn vertex_quadrics(
    faces: &[[u32; 3]],
    special: &[[bool; 3]],
    positions: &[&[Point3<f64>]],
    boundary_weight: f64,
) -> Vec<Quadric> {
    let mut per_pose: Vec<Vec<Quadric>> = positions
        .par_iter()
        .map(|pos| pose_quadrics(faces, special, pos, boundary_weight))
        .collect();
    if let [only] = &mut per_pose[..] {
        return std::mem::take(only);
    }
    let (p, n) = (
        positions.len(),
        positions.first().map_or(0, |set| set.len()),
    );
    let mut out = vec![Quadric::default(); n * p];
    for (j, q) in per_pose.into_iter().enumerate() {
        for (i, x) in q.into_iter().enumerate() {
            out[i * p + j] = x;
        }
    }
    out
}

/// The quadrics of [`vertex_quadrics`] in one pose, vertex positions `pos`: each face's
/// plane quadric added to its three vertices, then its special edges' constraint planes to
/// their two ends.
pub fn pose_quadrics(
    faces: &[[u32; 3]],
    special: &[[bool; 3]],
    pos: &[Point3<f64>],
    boundary_weight: f64,
) -> Vec<Quadric> {
    let mut q = vec![Quadric::default(); pos.len()];
    for (t, special) in faces.iter().zip(special) {
        let [x, y, z] = t.map(|v| pos[v as usize]);
        let k = Quadric::from_triangle(&x, &y, &z);
        for &v in t {
            q[v as usize].add_assign(&k);
        }
        if !special.contains(&true) {
            continue;
        }
        let normal = unit_normal(&x, &y, &z);
        for (&[i, j], _) in EDGE_CORNERS.iter().zip(special).filter(|e| *e.1) {
            let (vi, vj) = (t[i] as usize, t[j] as usize);
            let c = edge_constraint(&pos[vi], &pos[vj], &normal, boundary_weight);
            q[vi].add_assign(&c);
            q[vj].add_assign(&c);
        }
    }
    q
}

/// `special[f][e]`: local edge `e` of face `f` is a boundary (no other face) or a UV seam (the
/// other face has different UVs at its ends). `records` from [`sorted_edge_records`].
pub fn special_edges(
    faces: &[[u32; 3]],
    uv_faces: &[[u32; 3]],
    records: &[EdgeRecord],
) -> Vec<[bool; 3]> {
    let mut special = vec![[false; 3]; faces.len()];
    let uv_at = |flat: u32, v: u32| -> Option<u32> {
        let f = flat as usize / 3;
        let k = faces[f].iter().position(|&x| x == v)?;
        uv_faces.get(f).map(|t| t[k])
    };
    let mut mark = |flat: u32| special[flat as usize / 3][flat as usize % 3] = true;
    for group in edge_groups(records) {
        match group {
            [r] => mark(r.2),
            [r, s] if !uv_faces.is_empty() => {
                let (lo, hi) = (r.0, r.1);
                if uv_at(r.2, lo) != uv_at(s.2, lo) || uv_at(r.2, hi) != uv_at(s.2, hi) {
                    mark(r.2);
                    mark(s.2);
                }
            }
            _ => {}
        }
    }
    special
}

/// The input weights as [`Weights`]; a vertex with more than `W_max` influences is reduced as
/// in the seed's weight reduction, at its own rest position with its own training quadrics:
/// keep the `W_max` largest (of at most [`MAX_CANDIDATES`]), re-solve the weight QP on them.
pub fn start_weights(
    influences: &[Vec<(u32, f64)>],
    joints: &[Vec<Matrix4<f64>>],
    rest: &[Point3<f64>],
    quadrics: &[Quadric],
    poses: usize,
    options: &Options,
) -> Vec<Weights> {
    let w_max = options.cost.max_weights;
    influences
        .par_iter()
        .enumerate()
        .map(|(i, list)| {
            if list.len() <= w_max {
                return Weights::from_pairs(list);
            }
            let mut sorted = list.clone();
            sorted.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.cmp(&y.0)));
            sorted.truncate(MAX_CANDIDATES);
            let total: f64 = sorted.iter().map(|p| p.1).sum();
            let cand = Candidates {
                joints: sorted.iter().map(|p| p.0).collect(),
                mats: joints
                    .iter()
                    .flat_map(|pose| sorted.iter().map(|p| pose[p.0 as usize]))
                    .collect(),
            };
            let alpha: Vec<f64> = sorted.iter().map(|p| p.1 / total).collect();
            let keep = largest_support(&alpha, w_max);
            let q = &quadrics[i * poses..(i + 1) * poses];
            let reduced = reduce_weights(q, &cand, &rest[i], &alpha, &alpha, &keep, &options.cost);
            cand.weights(&reduced)
        })
        .collect()
}
