//! The MAPS hierarchy (notes "Hierarchy", "Parameter bookkeeping"; seed "Constructing the Mesh
//! Hierarchies" 1/5–5/5 and "Parameterization" 1/3–3/3): levels of maximal independent vertex
//! removals, each hole flattened with z^a and retriangulated, every removed input vertex carried
//! as (triangle of the current level, barycentrics) down to the base domain.
//!
//! One level:
//! 1. candidates (parallel): alive, not a corner, degree ≤ `max_degree`, a single fan;
//!    priorities w(λ, i) ([`super::priority`]);
//! 2. greedy maximal independent set in (w, vertex index) order — the index breaks ties, so the
//!    same input always gives the same hierarchy;
//! 3. removal plans (parallel; the stars of independent vertices are disjoint): flatten
//!    ([`super::flatten`]), constrained Delaunay triangulation ([`super::retriangulate`]), 3D
//!    orientation check, relocation of the points stored in the star;
//! 4. commits (sequential, in priority order): reject a triangulation that would duplicate an
//!    existing edge or face, falling back to fans; apply; stop at the target base size.
//!
//! A level that removes nothing ends the hierarchy, unless [`MapsOptions::retry_rejected`] and
//! a base size was asked for: then, while some candidate was left out of the independent set,
//! the next level runs without the vertices just rejected (the mesh did not change, so they
//! would fail again).

use std::collections::HashSet;

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use super::features::{vertex_role, Features, VertexRole};
use super::flatten::{flatten_ring_with, Flattening, RingShape};
use super::priority::{curvature, priorities_quantile, ring_area, shuffle_key, star_normal};
use super::quality::smallest_angle_deg;
use super::retriangulate::{
    best_triangulation, cdt_triangulation, fan_triangulation, locate, orient2d,
};
use super::shape::{deferral_threshold, removal_error};
use super::MapsOptions;

/// One level of the hierarchy, in processing order (`levels[0]` is the input mesh, the paper's
/// level L; the mesh after the last level is the base domain, level 0).
#[derive(Clone, Debug, Default)]
pub struct Level {
    /// The faces of the mesh at the start of this level, as input vertex indices.
    pub faces: Vec<[u32; 3]>,
    /// Removable vertices: alive, not a corner, degree ≤ max_degree, a single fan.
    pub candidates: Vec<u32>,
    /// The greedy maximal independent set of the candidates, in priority order.
    pub selected: Vec<u32>,
    /// The selected vertices actually removed.
    pub removed: Vec<u32>,
    /// The selected vertices kept because every triangulation of their hole failed a check.
    pub rejected: Vec<u32>,
    /// Whether the target base size was reached during this level (later selected vertices
    /// were neither removed nor rejected).
    pub truncated: bool,
    /// The selected vertices left for a later level by the shape rule of the coarse levels
    /// ([`super::shape`]: their shape error was above the level's threshold).
    pub deferred: Vec<u32>,
}

/// Where a point of the input lives on a level: a triangle of that level and barycentric
/// coordinates with respect to its corners (in the face's corner order).
pub type Location = (u32, [f64; 3]);

/// Why a removal was rejected (counted in the statistics).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RejectCounts {
    /// a·φ_k ≥ π or a degenerate angle/radius (flatten guard).
    pub flatten: usize,
    /// Neither the CDT nor any fan passed the checks (flipped 2D/3D triangle, duplicate edge or
    /// face, dropped feature edge): `flipped + duplicate`.
    pub triangulation: usize,
    /// Of `triangulation`: no triangulation of the flattened hole (CDT or fan) had every new
    /// triangle facing the side of the removed star's normal in 3D (or a valid 2D fan).
    pub flipped: usize,
    /// Of `triangulation`: some triangulation passed the 3D check, but each such one would
    /// have created an edge or a face that already exists (a non-manifold result).
    pub duplicate: usize,
}

/// Why the hierarchy stopped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The mesh had at most `base_size` faces (`base_size` 0 never stops this way).
    #[default]
    BaseSize,
    /// `max_levels` levels were run.
    MaxLevels,
    /// No vertex was a candidate (every alive vertex a corner, over the degree limit, or not a
    /// single fan).
    NoCandidates,
    /// The last level had candidates but every selected removal was rejected.
    AllRejected,
}

/// How the hierarchy stopped, with the state of the last mesh (issue #23: say why the base
/// size asked for was not reached).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct HierarchyStop {
    /// The reason.
    pub reason: StopReason,
    /// Alive vertices of the final mesh.
    pub vertices: usize,
    /// Of them: corners (tagged, or by the feature-line turn), never removed.
    pub corners: usize,
    /// Of them: degree above `max_degree`.
    pub over_degree: usize,
    /// Of them: star not a single fan.
    pub not_a_fan: usize,
    /// Of them: candidates for removal.
    pub candidates: usize,
    /// Removals rejected in the last level, by cause.
    pub last_level_rejects: RejectCounts,
}

/// The working state of the decimation: the current mesh with dead faces left in place (face
/// ids stay stable), per-vertex incident faces, and per-face the removed points it holds.
pub(crate) struct Work<'a> {
    pub positions: &'a [Point3<f64>],
    pub faces: Vec<[u32; 3]>,
    pub face_alive: Vec<bool>,
    pub vert_faces: Vec<Vec<u32>>,
    pub vert_alive: Vec<bool>,
    pub face_points: Vec<Vec<u32>>,
    pub loc: Vec<Location>,
    pub feature_edges: HashSet<(u32, u32)>,
    pub corner: Vec<bool>,
    pub alive_faces: usize,
    pub corner_turn: f64,
    /// [`MapsOptions::best_triangulation`] (false from [`Work::new`]; set by the caller).
    pub best_triangulation: bool,
    /// [`MapsOptions::flattening`] (the paper's z^a from [`Work::new`]; set by the caller).
    pub flattening: Flattening,
    /// Per face: the removal that created it (`u32::MAX` for an input face).
    pub created_by: Vec<u32>,
    /// Per face: the removal that deleted it (`u32::MAX` while alive).
    pub removed_by: Vec<u32>,
    /// Every committed removal, in commit order: the level maps Π and Π⁻¹ are composed of.
    pub records: Vec<Removal>,
}

/// One committed vertex removal: the flattened hole and the faces before and after. Old and new
/// faces tile the same planar polygon μ, which makes this level's map a bijection (notes
/// "Parameter bookkeeping").
#[derive(Clone, Debug)]
pub struct Removal {
    /// The removed vertex (at μ = 0).
    pub vertex: u32,
    /// Ring vertices j_0 … j_{K−1}.
    pub ring: Vec<u32>,
    /// μ(j_k).
    pub mu: Vec<[f64; 2]>,
    /// The star faces that died, in ring order (face m between j_m and j_{m+1}).
    pub old_faces: Vec<u32>,
    /// The new faces are `new_first .. new_first + new_count` (ids of the decimation).
    pub new_first: u32,
    /// Number of new faces.
    pub new_count: u32,
}

/// The ordered 1-ring of a vertex: neighbours counter-clockwise, the star faces between them.
#[derive(Clone, Debug)]
pub(crate) struct Ring {
    /// Ring vertices j_0 … j_{K−1}; for an open ring j_0 and j_{K−1} are the boundary neighbours.
    pub verts: Vec<u32>,
    /// Star face m lies between j_m and j_{m+1} (mod K when closed).
    pub faces: Vec<u32>,
    /// Closed (interior vertex) or open (boundary vertex).
    pub closed: bool,
}

/// The ordered ring of vertex `i` whose star is the faces `star` (ids into `faces`), or `None`
/// when they do not form one fan. Each star face (i, a, b), rotated so that i comes first,
/// contributes the ring edge a→b; a closed ring starts at its smallest vertex, an open one at
/// the vertex no edge enters.
pub(crate) fn ordered_ring(faces: &[[u32; 3]], star: &[u32], i: u32) -> Option<Ring> {
    let edges: Vec<(u32, u32, u32)> = star
        .iter()
        .map(|&f| {
            let t = faces[f as usize];
            let r = t
                .iter()
                .position(|&v| v == i)
                .expect("star face contains i");
            (t[(r + 1) % 3], t[(r + 2) % 3], f)
        })
        .collect();
    let open_start: Vec<u32> = edges
        .iter()
        .filter(|(a, _, _)| !edges.iter().any(|(_, b, _)| b == a))
        .map(|e| e.0)
        .collect();
    let (start, closed) = match open_start.as_slice() {
        [] => (edges.iter().map(|e| e.0).min()?, true),
        [s] => (*s, false),
        _ => return None,
    };
    let mut verts = vec![start];
    let mut ring_faces = Vec::with_capacity(edges.len());
    let mut cur = start;
    while let Some(&(_, b, f)) = edges.iter().find(|e| e.0 == cur) {
        ring_faces.push(f);
        if b == start {
            break;
        }
        if ring_faces.len() > edges.len() {
            return None;
        }
        verts.push(b);
        cur = b;
    }
    if ring_faces.len() != edges.len() || (closed && verts.len() != ring_faces.len()) {
        return None;
    }
    Some(Ring {
        verts,
        faces: ring_faces,
        closed,
    })
}

/// A hole triangulation (triples of ring positions) with the relocated points
/// (point, new triangle index, barycentrics).
type Triangulation = (Vec<[usize; 3]>, Vec<(u32, usize, [f64; 3])>);

/// A planned removal (computed in parallel, committed sequentially).
struct Plan {
    vertex: u32,
    ring: Ring,
    shape: RingShape,
    mu: Vec<[f64; 2]>,
    chord: Option<(usize, usize)>,
    star_normal: Vector3<f64>,
    /// The CDT triangulation with its relocated points, if it passed the local checks.
    cdt: Option<Triangulation>,
}

enum Planned {
    Plan(Box<Plan>),
    FlattenRejected(u32),
}

/// The outcome of [`Work::commit`].
enum Commit {
    Done,
    /// No triangulation passed the 3D orientation check.
    Flipped,
    /// Some passed it, but each would duplicate an edge or a face.
    Duplicate,
}

impl RejectCounts {
    /// Count one rejection of outcome `c` (`Commit::Done` counts nothing).
    fn add(&mut self, c: &Commit) {
        match c {
            Commit::Done => return,
            Commit::Flipped => self.flipped += 1,
            Commit::Duplicate => self.duplicate += 1,
        }
        self.triangulation += 1;
    }
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl<'a> Work<'a> {
    pub fn new(
        positions: &'a [Point3<f64>],
        faces: &[[u32; 3]],
        features: &Features,
        corner_turn: f64,
    ) -> Self {
        let n = positions.len();
        let mut vert_faces = vec![Vec::new(); n];
        for (f, tri) in faces.iter().enumerate() {
            for &v in tri {
                vert_faces[v as usize].push(f as u32);
            }
        }
        let mut corner = vec![false; n];
        for &c in &features.corners {
            corner[c as usize] = true;
        }
        Work {
            positions,
            faces: faces.to_vec(),
            face_alive: vec![true; faces.len()],
            vert_alive: vert_faces.iter().map(|f| !f.is_empty()).collect(),
            vert_faces,
            face_points: vec![Vec::new(); faces.len()],
            loc: vec![(u32::MAX, [0.0; 3]); n],
            feature_edges: features.edges.iter().copied().collect(),
            corner,
            alive_faces: faces.len(),
            corner_turn,
            best_triangulation: false,
            flattening: Flattening::Conformal,
            created_by: vec![u32::MAX; faces.len()],
            removed_by: vec![u32::MAX; faces.len()],
            records: Vec::new(),
        }
    }

    /// The alive faces in id order.
    pub fn alive_faces_list(&self) -> Vec<[u32; 3]> {
        self.faces
            .iter()
            .zip(&self.face_alive)
            .filter(|(_, &a)| a)
            .map(|(f, _)| *f)
            .collect()
    }

    /// The ordered ring of `i`, or `None` when its faces do not form one fan.
    pub fn ring(&self, i: u32) -> Option<Ring> {
        ordered_ring(&self.faces, &self.vert_faces[i as usize], i)
    }

    /// The shape of the flattening of `i` with ring `ring`, or `None` if `i` is a corner
    /// (tagged, or by [`vertex_role`]).
    pub(crate) fn shape(&self, i: u32, ring: &Ring) -> Option<RingShape> {
        let k = ring.verts.len();
        let mut feature_pos: Vec<usize> = (0..k)
            .filter(|&m| self.feature_edges.contains(&key(i, ring.verts[m])))
            .collect();
        if !ring.closed {
            for m in [0, k - 1] {
                if !feature_pos.contains(&m) {
                    feature_pos.push(m);
                }
            }
            feature_pos.sort_unstable();
        }
        let neighbours: Vec<u32> = feature_pos.iter().map(|&m| ring.verts[m]).collect();
        match vertex_role(
            self.positions,
            i,
            self.corner[i as usize],
            &neighbours,
            self.corner_turn,
        ) {
            VertexRole::Corner => None,
            VertexRole::Free => Some(RingShape::Disk),
            VertexRole::Line if !ring.closed => Some(RingShape::HalfDisk),
            VertexRole::Line => Some(RingShape::FeatureLine {
                s: feature_pos[0],
                t: feature_pos[1],
            }),
        }
    }

    /// Whether an alive face contains both `a` and `b`.
    fn edge_exists(&self, a: u32, b: u32) -> bool {
        self.vert_faces[a as usize]
            .iter()
            .any(|&f| self.faces[f as usize].contains(&b))
    }

    /// Whether an alive face has exactly the vertices {a, b, c}.
    fn face_exists(&self, a: u32, b: u32, c: u32) -> bool {
        self.vert_faces[a as usize].iter().any(|&f| {
            let t = self.faces[f as usize];
            t.contains(&b) && t.contains(&c)
        })
    }

    fn plan(&self, i: u32, ring: Ring, shape: RingShape) -> Planned {
        let centre = self.positions[i as usize];
        let pts: Vec<Point3<f64>> = ring
            .verts
            .iter()
            .map(|&v| self.positions[v as usize])
            .collect();
        let Ok(mu) = flatten_ring_with(&centre, &pts, shape, self.flattening) else {
            return Planned::FlattenRejected(i);
        };
        let k = ring.verts.len();
        let chord = match shape {
            RingShape::Disk => None,
            RingShape::HalfDisk => Some((k - 1, 0)),
            RingShape::FeatureLine { s, t } => Some((s, t)),
        };
        let star: Vec<[u32; 3]> = ring.faces.iter().map(|&f| self.faces[f as usize]).collect();
        let normal = star_normal(self.positions, &star);
        let mut plan = Plan {
            vertex: i,
            ring,
            shape,
            mu,
            chord,
            star_normal: normal,
            cdt: None,
        };
        if let Some(tris) = cdt_triangulation(&plan.mu, chord) {
            if self.valid_3d(&plan, &tris) {
                let moved = self.relocate(&plan, &tris);
                plan.cdt = Some((tris, moved));
            }
        }
        Planned::Plan(Box::new(plan))
    }

    /// Every new triangle's normal points to the same side as the removed star's area-weighted
    /// normal (strictly; a zero-area triangle fails).
    fn valid_3d(&self, plan: &Plan, tris: &[[usize; 3]]) -> bool {
        tris.iter().all(|t| {
            let [p, q, r] = t.map(|m| self.positions[plan.ring.verts[m] as usize]);
            (q - p).cross(&(r - p)).dot(&plan.star_normal) > 0.0
        })
    }

    /// Whether the triangulation can be committed against the current mesh: no new edge (other
    /// than the ring edges j_m j_{m+1}) already exists, and no new triangle duplicates a face.
    fn valid_in_mesh(&self, plan: &Plan, tris: &[[usize; 3]]) -> bool {
        let k = plan.ring.verts.len();
        let ring_edge = |a: usize, b: usize| {
            let consecutive = (a + 1) % k == b || (b + 1) % k == a;
            let closing = (a == 0 && b == k - 1) || (b == 0 && a == k - 1);
            consecutive && (plan.ring.closed || !closing)
        };
        for t in tris {
            let v = t.map(|m| plan.ring.verts[m]);
            let mut all_ring = true;
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                if ring_edge(a, b) {
                    continue;
                }
                all_ring = false;
                if self.edge_exists(v[e], v[(e + 1) % 3]) {
                    return false;
                }
            }
            if all_ring && self.face_exists(v[0], v[1], v[2]) {
                return false;
            }
        }
        true
    }

    /// Bookkeeping (notes "Parameter bookkeeping"; seed "Parameterization (3/3)"): every point
    /// stored in a star face with barycentrics b maps to u = Σ b_c μ(corner_c) (μ(i) = 0) and is
    /// located in the new triangles (robust orientations); the removed vertex i lands at u = 0.
    /// A point on a ring edge (b_i = 0 exactly) goes exactly onto that edge of its new triangle.
    /// Returns (point, new triangle index, barycentrics).
    fn relocate(&self, plan: &Plan, tris: &[[usize; 3]]) -> Vec<(u32, usize, [f64; 3])> {
        let i = plan.vertex;
        let pos_of = |v: u32| plan.ring.verts.iter().position(|&w| w == v);
        let mu_of = |v: u32| pos_of(v).map(|m| plan.mu[m]).unwrap_or([0.0, 0.0]);
        let mut out = Vec::new();
        for &f in &plan.ring.faces {
            let corners = self.faces[f as usize];
            let ci = corners
                .iter()
                .position(|&v| v == i)
                .expect("star face contains i");
            for &p in &self.face_points[f as usize] {
                let b = self.loc[p as usize].1;
                if b[ci] == 0.0 {
                    // On the ring edge a→b (counter-clockwise in the star face and in the hole).
                    let (ca, cb) = ((ci + 1) % 3, (ci + 2) % 3);
                    let (ma, mb) = (pos_of(corners[ca]).unwrap(), pos_of(corners[cb]).unwrap());
                    if let Some((n, t)) = tris
                        .iter()
                        .enumerate()
                        .find(|(_, t)| (0..3).any(|e| t[e] == ma && t[(e + 1) % 3] == mb))
                    {
                        let mut bary = [0.0; 3];
                        bary[t.iter().position(|&m| m == ma).unwrap()] = b[ca];
                        bary[t.iter().position(|&m| m == mb).unwrap()] = b[cb];
                        out.push((p, n, bary));
                        continue;
                    }
                }
                let mut u = [0.0; 2];
                for c in 0..3 {
                    let m = mu_of(corners[c]);
                    u[0] += b[c] * m[0];
                    u[1] += b[c] * m[1];
                }
                let (n, bary) = locate(u, &plan.mu, tris);
                out.push((p, n, bary));
            }
        }
        let (n, bary) = locate([0.0, 0.0], &plan.mu, tris);
        out.push((i, n, bary));
        out
    }

    /// The shape error of a planned removal ([`super::shape::removal_error`]) with the
    /// triangulation [`Work::commit`] would try first: the CDT when it passed the local checks,
    /// else the first fan that passes them and faces the star normal's side in 3D; ∞ when the
    /// flattening guard rejected the ring or no such triangulation exists.
    fn shape_error(&self, planned: &Planned) -> f64 {
        let Planned::Plan(plan) = planned else {
            return f64::INFINITY;
        };
        let ring = &plan.ring.verts;
        if let Some((tris, moved)) = &plan.cdt {
            return removal_error(self.positions, ring, tris, moved);
        }
        for apex in fan_apexes(plan) {
            if let Some(tris) = fan_triangulation(&plan.mu, apex, plan.chord) {
                if self.valid_3d(plan, &tris) {
                    let moved = self.relocate(plan, &tris);
                    return removal_error(self.positions, ring, &tris, &moved);
                }
            }
        }
        f64::INFINITY
    }

    /// Commit `plan` with the first triangulation that passes every check: the CDT, then the
    /// fans from each allowed apex (the chord ends for a feature or boundary vertex, so the
    /// chord stays). Returns the outcome (on a rejection the vertex is kept).
    fn commit(&mut self, plan: &Plan) -> Commit {
        let mut chosen: Option<Triangulation> = None;
        let mut any_3d = plan.cdt.is_some();
        if let Some((tris, moved)) = &plan.cdt {
            if self.valid_in_mesh(plan, tris) {
                chosen = Some((tris.clone(), moved.clone()));
            }
        }
        if chosen.is_none() {
            for apex in fan_apexes(plan) {
                if let Some(tris) = fan_triangulation(&plan.mu, apex, plan.chord) {
                    if self.valid_3d(plan, &tris) {
                        any_3d = true;
                        if self.valid_in_mesh(plan, &tris) {
                            let moved = self.relocate(plan, &tris);
                            chosen = Some((tris, moved));
                            break;
                        }
                    }
                }
            }
        }
        if chosen.is_none() && self.best_triangulation {
            if let Some(tris) = self.best_valid_triangulation(plan) {
                any_3d = true;
                if self.valid_in_mesh(plan, &tris) {
                    let moved = self.relocate(plan, &tris);
                    chosen = Some((tris, moved));
                }
            }
        }
        let Some((tris, moved)) = chosen else {
            return if any_3d {
                Commit::Duplicate
            } else {
                Commit::Flipped
            };
        };
        self.apply(plan, &tris, &moved);
        Commit::Done
    }

    /// The last resort of [`Work::commit`] ([`MapsOptions::best_triangulation`]): among all
    /// triangulations of the flattened hole whose triangles are counter-clockwise in μ and face
    /// the star normal's side in 3D, and whose diagonals are not edges of the mesh yet, the one
    /// whose smallest 3D angle is largest ([`best_triangulation`]). Disk and half-disk holes
    /// only (the half disk's chord is the polygon's closing edge (K−1, 0), kept by
    /// construction); `None` for a feature-line hole or when no such triangulation exists.
    fn best_valid_triangulation(&self, plan: &Plan) -> Option<Vec<[usize; 3]>> {
        if let RingShape::FeatureLine { .. } = plan.shape {
            return None;
        }
        let verts = &plan.ring.verts;
        let p = |m: usize| self.positions[verts[m] as usize];
        let quality = |a: usize, m: usize, b: usize| {
            if orient2d(plan.mu[a], plan.mu[m], plan.mu[b]) <= 0.0 {
                return None;
            }
            let (pa, pm, pb) = (p(a), p(m), p(b));
            if (pm - pa).cross(&(pb - pa)).dot(&plan.star_normal) <= 0.0 {
                return None;
            }
            let angle = smallest_angle_deg(&pa, &pm, &pb);
            angle.is_finite().then_some(angle)
        };
        let diagonal_ok = |a: usize, b: usize| !self.edge_exists(verts[a], verts[b]);
        best_triangulation(verts.len(), quality, diagonal_ok)
    }

    fn apply(&mut self, plan: &Plan, tris: &[[usize; 3]], moved: &[(u32, usize, [f64; 3])]) {
        let i = plan.vertex;
        let record = self.records.len() as u32;
        for &f in &plan.ring.faces {
            self.face_alive[f as usize] = false;
            self.removed_by[f as usize] = record;
            self.face_points[f as usize] = Vec::new();
            for v in self.faces[f as usize] {
                self.vert_faces[v as usize].retain(|&g| g != f);
            }
        }
        self.alive_faces -= plan.ring.faces.len();
        let first = self.faces.len() as u32;
        for t in tris {
            let f = self.faces.len() as u32;
            let tri = t.map(|m| plan.ring.verts[m]);
            self.faces.push(tri);
            self.face_alive.push(true);
            self.face_points.push(Vec::new());
            self.created_by.push(record);
            self.removed_by.push(u32::MAX);
            for v in tri {
                self.vert_faces[v as usize].push(f);
            }
        }
        self.alive_faces += tris.len();
        self.records.push(Removal {
            vertex: i,
            ring: plan.ring.verts.clone(),
            mu: plan.mu.clone(),
            old_faces: plan.ring.faces.clone(),
            new_first: first,
            new_count: tris.len() as u32,
        });
        for &(p, n, bary) in moved {
            let f = first + n as u32;
            self.loc[p as usize] = (f, bary);
            self.face_points[f as usize].push(p);
        }
        self.vert_alive[i as usize] = false;
        if let RingShape::FeatureLine { s, t } = plan.shape {
            let (js, jt) = (plan.ring.verts[s], plan.ring.verts[t]);
            self.feature_edges.remove(&key(i, js));
            self.feature_edges.remove(&key(i, jt));
            self.feature_edges.insert(key(js, jt));
        }
        if let RingShape::HalfDisk = plan.shape {
            // A tagged boundary edge stays tagged along the new boundary edge.
            let (j0, jk) = (
                plan.ring.verts[0],
                plan.ring.verts[plan.ring.verts.len() - 1],
            );
            let tagged =
                self.feature_edges.remove(&key(i, j0)) | self.feature_edges.remove(&key(i, jk));
            if tagged {
                self.feature_edges.insert(key(j0, jk));
            }
        }
    }
}

/// The apexes of the fans [`Work::commit`] falls back to, in order: every ring position for a
/// disk, the chord's ends otherwise (so that the chord stays).
fn fan_apexes(plan: &Plan) -> Vec<usize> {
    match plan.chord {
        None => (0..plan.ring.verts.len()).collect(),
        Some((s, t)) => vec![s, t],
    }
}

/// Candidate data of one vertex for a level.
struct Candidate {
    vertex: u32,
    ring: Ring,
    shape: RingShape,
    area: f64,
    kappa: f64,
}

/// Statistics of one level, for progress reports.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LevelReport {
    /// Index in processing order (0 = the input mesh's level).
    pub level: usize,
    /// Faces after the level.
    pub faces: usize,
    /// Vertices removed in the level.
    pub removed: usize,
    /// Removals rejected in the level.
    pub rejected: usize,
}

/// Run levels until the target base size is reached or no candidate is removable. Returns the
/// levels and how the hierarchy stopped ([`HierarchyStop`]).
pub(crate) fn decimate<'a>(
    work: &mut Work<'a>,
    options: &MapsOptions,
    rejects: &mut RejectCounts,
    progress: &mut dyn FnMut(LevelReport),
) -> (Vec<Level>, HierarchyStop) {
    let mut levels = Vec::new();
    let mut last_level_rejects = RejectCounts::default();
    // Vertices rejected since the mesh last changed ([`MapsOptions::retry_rejected`]).
    let mut excluded: HashSet<u32> = HashSet::new();
    let reason = loop {
        if work.alive_faces <= options.base_size {
            break StopReason::BaseSize;
        }
        if levels.len() >= options.max_levels {
            break StopReason::MaxLevels;
        }
        let mut level_rejects = RejectCounts::default();
        let mut level = Level {
            faces: if options.keep_levels {
                work.alive_faces_list()
            } else {
                Vec::new()
            },
            ..Level::default()
        };
        let candidates: Vec<Candidate> = candidates(work, options)
            .into_iter()
            .filter(|c| !excluded.contains(&c.vertex))
            .collect();
        level.candidates = candidates.iter().map(|c| c.vertex).collect();
        let shape_rule = options.shape_rule.filter(|r| {
            options.shuffle_seed.is_none() && r.applies(work.alive_faces, options.base_size)
        });
        // The shape rule plans every candidate (its order is the planned removals' shape
        // error); the paper's plans only the selected ones.
        let (w, mut planned_all, threshold) = match shape_rule {
            Some(rule) => {
                let planned: Vec<Planned> = candidates
                    .par_iter()
                    .map(|c| work.plan(c.vertex, c.ring.clone(), c.shape))
                    .collect();
                let errors: Vec<f64> = planned.par_iter().map(|p| work.shape_error(p)).collect();
                let threshold = deferral_threshold(&errors, rule.quantile);
                let slots = planned.into_iter().map(Some).collect::<Vec<_>>();
                (errors, Some(slots), threshold)
            }
            None => (
                paper_order(options, levels.len(), &candidates),
                None,
                f64::INFINITY,
            ),
        };
        let selected = independent_set(work, &candidates, &w);
        level.selected = selected.iter().map(|&c| candidates[c].vertex).collect();
        let plans: Vec<(f64, Planned)> = match planned_all.as_mut() {
            Some(slots) => selected
                .iter()
                .filter_map(|&c| Some((w[c], slots[c].take()?)))
                .collect(),
            None => {
                let mut slots: Vec<Option<Candidate>> = candidates.into_iter().map(Some).collect();
                let chosen: Vec<(f64, Candidate)> = selected
                    .iter()
                    .filter_map(|&c| Some((w[c], slots[c].take()?)))
                    .collect();
                chosen
                    .into_par_iter()
                    .map(|(e, c)| (e, work.plan(c.vertex, c.ring, c.shape)))
                    .collect()
            }
        };
        for (error, planned) in plans {
            if work.alive_faces <= options.base_size {
                level.truncated = true;
                break;
            }
            if error > threshold {
                level.deferred.push(planned_vertex(&planned));
                continue;
            }
            match planned {
                Planned::FlattenRejected(v) => {
                    level_rejects.flatten += 1;
                    level.rejected.push(v);
                }
                Planned::Plan(plan) => {
                    let outcome = work.commit(&plan);
                    if let Commit::Done = outcome {
                        level.removed.push(plan.vertex);
                    } else {
                        level_rejects.add(&outcome);
                        level.rejected.push(plan.vertex);
                    }
                }
            }
        }
        rejects.flatten += level_rejects.flatten;
        rejects.triangulation += level_rejects.triangulation;
        rejects.flipped += level_rejects.flipped;
        rejects.duplicate += level_rejects.duplicate;
        last_level_rejects = level_rejects;
        let no_candidates = level.candidates.is_empty();
        let removed = level.removed.len();
        progress(LevelReport {
            level: levels.len(),
            faces: work.alive_faces,
            removed,
            rejected: level.rejected.len(),
        });
        let untried = level.candidates.len() > level.selected.len();
        let rejected = level.rejected.clone();
        levels.push(level);
        if removed > 0 {
            excluded.clear();
        } else if options.retry_rejected && options.base_size > 0 && untried {
            // Nothing changed, so the rejected vertices would be rejected again; their
            // neighbours, kept out of this level's independent set by them, get their turn.
            excluded.extend(rejected);
        } else {
            break if no_candidates {
                StopReason::NoCandidates
            } else {
                StopReason::AllRejected
            };
        }
    };
    let stop = stop_state(work, options, reason, last_level_rejects);
    (levels, stop)
}

/// The paper's order of a level's candidates: w(λ, i) ([`priorities_quantile`]), or the
/// seeded shuffle ([`MapsOptions::shuffle_seed`]).
fn paper_order(options: &MapsOptions, level: usize, candidates: &[Candidate]) -> Vec<f64> {
    match options.shuffle_seed {
        None => {
            let area: Vec<f64> = candidates.iter().map(|c| c.area).collect();
            let kappa: Vec<f64> = candidates.iter().map(|c| c.kappa).collect();
            priorities_quantile(options.lambda, &area, &kappa, options.priority_quantile)
        }
        Some(seed) => candidates
            .iter()
            .map(|c| shuffle_key(seed, level, c.vertex))
            .collect(),
    }
}

/// The vertex of a planned removal.
fn planned_vertex(planned: &Planned) -> u32 {
    match planned {
        Planned::Plan(plan) => plan.vertex,
        Planned::FlattenRejected(v) => *v,
    }
}

/// [`HierarchyStop`] of the final mesh: every alive vertex classified as a corner, over the
/// degree limit, not a single fan, or a candidate (the order of the tests in [`candidates`]).
fn stop_state(
    work: &Work,
    options: &MapsOptions,
    reason: StopReason,
    last_level_rejects: RejectCounts,
) -> HierarchyStop {
    let mut stop = HierarchyStop {
        reason,
        last_level_rejects,
        ..HierarchyStop::default()
    };
    for v in 0..work.positions.len() as u32 {
        if !work.vert_alive[v as usize] {
            continue;
        }
        stop.vertices += 1;
        if work.corner[v as usize] {
            stop.corners += 1;
            continue;
        }
        let Some(ring) = work.ring(v) else {
            stop.not_a_fan += 1;
            continue;
        };
        if ring.verts.len() > options.max_degree || ring.verts.len() < 3 {
            stop.over_degree += 1;
        } else if work.shape(v, &ring).is_none() {
            stop.corners += 1;
        } else {
            stop.candidates += 1;
        }
    }
    stop
}

/// The removable vertices of the current mesh with their ring, shape, 1-ring area and curvature,
/// in vertex order (parallel, order-preserving).
fn candidates(work: &Work, options: &MapsOptions) -> Vec<Candidate> {
    (0..work.positions.len() as u32)
        .into_par_iter()
        .filter_map(|v| {
            if !work.vert_alive[v as usize] || work.corner[v as usize] {
                return None;
            }
            let ring = work.ring(v)?;
            if ring.verts.len() > options.max_degree || ring.verts.len() < 3 {
                return None;
            }
            let shape = work.shape(v, &ring)?;
            let star: Vec<[u32; 3]> = ring.faces.iter().map(|&f| work.faces[f as usize]).collect();
            let pts: Vec<Point3<f64>> = ring
                .verts
                .iter()
                .map(|&w| work.positions[w as usize])
                .collect();
            let centre = work.positions[v as usize];
            let area = ring_area(work.positions, &star);
            let normal = star_normal(work.positions, &star);
            let kappa = if options.priority_error {
                collapse_error(work, v, &ring, &pts, &normal)
            } else {
                curvature(&centre, &pts, &normal)
            };
            Some(Candidate {
                vertex: v,
                ring,
                shape,
                area,
                kappa,
            })
        })
        .collect()
}

/// Beyond the paper ([`MapsOptions::priority_error`]): how far the input points that removing
/// `v` would re-store lie from the plane of its ring: max |n · (p − c)| over `v` and the input
/// vertices stored in its star's faces, n the unit star normal and c the ring's centroid. A
/// vertex whose removal flattens a tip or a fin (every point it carries far from that plane)
/// goes late, whatever its curvature at the current level.
fn collapse_error(
    work: &Work,
    v: u32,
    ring: &Ring,
    pts: &[Point3<f64>],
    normal: &Vector3<f64>,
) -> f64 {
    let len = normal.norm();
    if len.is_nan() || len <= 0.0 || pts.is_empty() {
        return 0.0;
    }
    let n = normal / len;
    let c = pts.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / pts.len() as f64;
    let height = |p: &Point3<f64>| n.dot(&(p.coords - c)).abs();
    ring.faces
        .iter()
        .flat_map(|&f| work.face_points[f as usize].iter())
        .map(|&p| height(&work.positions[p as usize]))
        .fold(height(&work.positions[v as usize]), f64::max)
}

/// Greedy maximal independent set (seed 3/5): visit the candidates in increasing (w, vertex)
/// order; take a vertex unless a taken vertex is its neighbour, then mark its 1-ring.
/// Returns indices into `candidates`, in visiting order.
fn independent_set(work: &Work, candidates: &[Candidate], w: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| {
        w[a].total_cmp(&w[b])
            .then(candidates[a].vertex.cmp(&candidates[b].vertex))
    });
    let mut marked = vec![false; work.positions.len()];
    let mut taken = Vec::new();
    for c in order {
        let v = candidates[c].vertex as usize;
        if marked[v] {
            continue;
        }
        taken.push(c);
        marked[v] = true;
        for &j in &candidates[c].ring.verts {
            marked[j as usize] = true;
        }
    }
    taken
}
