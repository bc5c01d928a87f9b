//! Which face evaluates each vertex of the subdivided mesh in the QC protocol (issue #36).
//!
//! reparam's protocol ([`VertexRule::PerFace`]) evaluates every face's sub-vertices with that
//! face's own interpolant. The authors' MATLAB code (shirrorbe/BPM) subdivides the whole mesh
//! (`External/meshSubdivision.m`, applied n times) so that a sub-vertex on an input edge or at
//! an input vertex is shared by the faces around it, and evaluates it **once**:
//!
//! ```text
//!   Vzsubd_origF(F_subd(:)) = orig_F_inds      (BPMTransformPoints.m)
//! ```
//!
//! With repeated indices MATLAB keeps the last assignment, so a vertex belongs to the face of
//! its last occurrence in `F_subd(:)`, read column-major: column 3 of every sub-face, after
//! column 2, after column 1, and within a column the last row. `meshSubdivision` puts the four
//! children of row r at rows 4r−3 … 4r (corner-child 1 (v1, m12, m31), corner-child 2
//! (m12, v2, m23), corner-child 3 (m23, v3, m31), middle (m12, m23, m31)), so after n rounds
//! face f's 4ⁿ sub-faces are the rows (f−1)4ⁿ+1 … f·4ⁿ, in depth-first order. The last
//! occurrence of a vertex is therefore in the face f maximising (c_f, f), c_f the last column
//! in which it appears among f's own sub-faces ([`last_columns`]).
//!
//! BPM is continuous across an edge when both faces lay each other out isometrically, so the
//! rule changes only rounding there; under the authors' unfolding ([`Unfold::Authors`]) the
//! two faces of an edge folded past 90° disagree on the edge, and which face evaluates an edge
//! vertex changes the QC figures ([`VertexRule::Authors`] reproduces them). Their linear
//! interpolation (`LinearContinuousParam.m`) splits the mesh into separate faces first, so it
//! evaluates per face: apply the rule to BPM only.
//!
//! Vertices are identified as in the authors' code run on a seam-cut mesh (one vertex per
//! distinct (position, UV) pair): an edge is shared when it is interior in [`Adjacency`] (same
//! UVs at both ends, opposite orientation); non-manifold and misoriented edges, which their
//! `triangulation` would share, are not.
//!
//! [`Unfold::Authors`]: super::precompute::Unfold::Authors

use std::collections::HashMap;

use crate::mesh::{Adjacency, TriMesh, EDGE_CORNERS};

/// Which face evaluates a sub-vertex shared by several faces.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum VertexRule {
    /// Every face evaluates its own sub-vertices (reparam's protocol). Default.
    #[default]
    PerFace,
    /// Each shared sub-vertex is evaluated once, by the face of its last occurrence in the
    /// authors' `F_subd(:)` (module documentation).
    Authors,
}

/// A face's sub-vertices that another face evaluates under [`VertexRule::Authors`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Borrowed {
    /// The sub-vertex's index in the face's grid (the QC protocol's order: rows s = 0 … n,
    /// within a row r = 0 … n − s).
    pub grid_index: usize,
    /// The face that evaluates it.
    pub owner: usize,
    /// Its barycentric coordinates in the owner face.
    pub bary: [f64; 3],
}

/// The authors' vertex rule for one mesh and subdivision level: per face, the sub-vertices it
/// does not evaluate itself.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexOwners {
    pub subdiv: u32,
    pub borrowed: Vec<Vec<Borrowed>>,
}

/// Index of grid vertex (r, s) with `n` segments per edge: rows s' < s hold Σ (n + 1 − s')
/// vertices (the QC protocol's numbering).
pub fn grid_index(r: usize, s: usize, n: usize) -> usize {
    s * (n + 1) - s * (s.saturating_sub(1)) / 2 + r
}

/// For every grid vertex of a face subdivided `subdiv` times, the last column (0, 1, 2) in
/// which it appears among the face's 4^subdiv sub-faces in `meshSubdivision`'s order.
///
/// Grid coordinates: corner 0 = (0, 0), corner 1 = (n, 0), corner 2 = (0, n), n = 2^subdiv;
/// a triangle (a, b, c) becomes (a, m_ab, m_ca), (m_ab, b, m_bc), (m_bc, c, m_ca),
/// (m_ab, m_bc, m_ca), recursively. Only the columns matter, not the rows within the face:
/// between faces the higher face index comes later in every column.
pub fn last_columns(subdiv: u32) -> Vec<u8> {
    let n = 1usize << subdiv;
    let mut last = vec![0u8; grid_index(0, n, n) + 1];
    let corners = [(0, 0), (n, 0), (0, n)];
    visit_leaves(corners, subdiv, &mut |tri| {
        for (column, &(r, s)) in tri.iter().enumerate() {
            let k = grid_index(r, s, n);
            last[k] = last[k].max(column as u8);
        }
    });
    last
}

type GridTri = [(usize, usize); 3];

/// Call `leaf` on the sub-faces of `tri` after `depth` rounds of `meshSubdivision`, in row
/// order.
fn visit_leaves(tri: GridTri, depth: u32, leaf: &mut impl FnMut(GridTri)) {
    if depth == 0 {
        return leaf(tri);
    }
    let mid = |p: (usize, usize), q: (usize, usize)| ((p.0 + q.0) / 2, (p.1 + q.1) / 2);
    let [a, b, c] = tri;
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    for child in [[a, ab, ca], [ab, b, bc], [bc, c, ca], [ab, bc, ca]] {
        visit_leaves(child, depth - 1, leaf);
    }
}

/// Grid coordinates (r, s) of the point with integer barycentric weights `w` (summing to n).
fn grid_of(w: [usize; 3]) -> (usize, usize) {
    (w[1], w[2])
}

fn bary_of(w: [usize; 3], n: usize) -> [f64; 3] {
    w.map(|x| x as f64 / n as f64)
}

/// Build the authors' vertex rule for `mesh` subdivided `subdiv` times.
///
/// Edge sub-vertex at k/n along f's edge a→b (0 < k < n): in the neighbour g across it (local
/// edge e_g, traversed b→a) it is at k/n from g's corner `EDGE_CORNERS[e_g][0]`; g evaluates it
/// when (c_g, g) > (c_f, f) ([`last_columns`]). Input vertex (a (position, UV) pair): evaluated
/// by the face maximising (last column of its corner there, face) over all faces with that
/// pair.
pub fn authors_vertex_owners(mesh: &TriMesh, adjacency: &Adjacency, subdiv: u32) -> VertexOwners {
    let n = 1usize << subdiv;
    let last = last_columns(subdiv);
    let column = |w: [usize; 3]| {
        let (r, s) = grid_of(w);
        last[grid_index(r, s, n)]
    };
    let mut borrowed: Vec<Vec<Borrowed>> = vec![Vec::new(); mesh.face_count()];
    for (f, list) in borrowed.iter_mut().enumerate() {
        #[allow(clippy::needless_range_loop)] // e names the edge, as in `adjacency.neighbour(f, e)`
        for e in 0..3 {
            let Some((g, eg)) = adjacency.neighbour(f, e) else {
                continue;
            };
            let [a, b] = EDGE_CORNERS[e];
            let [ga, gb] = EDGE_CORNERS[eg];
            for k in 1..n {
                let mut wf = [0; 3];
                wf[a] = n - k;
                wf[b] = k;
                let mut wg = [0; 3];
                wg[ga] = k; // g's first corner on the edge is f's b
                wg[gb] = n - k;
                if (column(wg), g) > (column(wf), f) {
                    let (r, s) = grid_of(wf);
                    list.push(Borrowed {
                        grid_index: grid_index(r, s, n),
                        owner: g,
                        bary: bary_of(wg, n),
                    });
                }
            }
        }
    }
    let corner_column = |c: usize| {
        let mut w = [0; 3];
        w[c] = n;
        column(w)
    };
    for (f, corner, owner, owner_corner) in corner_owners(mesh, corner_column) {
        if owner != f {
            let mut wf = [0; 3];
            wf[corner] = n;
            let (r, s) = grid_of(wf);
            let mut bary = [0.0; 3];
            bary[owner_corner] = 1.0;
            borrowed[f].push(Borrowed {
                grid_index: grid_index(r, s, n),
                owner,
                bary,
            });
        }
    }
    VertexOwners { subdiv, borrowed }
}

/// For every face corner (f, c): the face and corner that evaluate its (position, UV) vertex,
/// the one maximising (last column, face) among the corners with the same pair, the last
/// column of corner c being `column(c)` ([`last_columns`]: 0, 1, 1 for corners 0, 1, 2 — the
/// third corner is the second corner of its corner-child at every level).
fn corner_owners(
    mesh: &TriMesh,
    column: impl Fn(usize) -> u8,
) -> Vec<(usize, usize, usize, usize)> {
    let key = |f: usize, c: usize| (mesh.faces[f][c], mesh.uv_faces[f][c]);
    // Per vertex: the greatest ((last column, face), corner).
    let mut best: HashMap<(u32, u32), ((u8, usize), usize)> = HashMap::new();
    for f in 0..mesh.face_count() {
        for c in 0..3 {
            let candidate = ((column(c), f), c);
            let entry = best.entry(key(f, c)).or_insert(candidate);
            if candidate.0 > entry.0 {
                *entry = candidate;
            }
        }
    }
    let mut out = Vec::with_capacity(3 * mesh.face_count());
    for f in 0..mesh.face_count() {
        for c in 0..3 {
            let ((_, owner), owner_corner) = best[&key(f, c)];
            out.push((f, c, owner, owner_corner));
        }
    }
    out
}
