//! Greedy edge collapse with a priority queue (notes "Around it"): the cheapest valid edge is
//! collapsed into one vertex placed by the method's cost ([`super::cost`]), until the target
//! vertex count or until no edge is valid.
//!
//! A collapse of `(a, b)` (kept `a = min`, removed `b`) is valid when
//! 1. both endpoints are free (not on a non-manifold or misoriented edge of the input);
//! 2. **link condition**: the common neighbours of `a` and `b` are exactly the opposite
//!    vertices of the one or two faces on the edge, and no face `(a|b, c, d)` joins the two
//!    opposite vertices (no collapse of a tetrahedron);
//! 3. **boundaries**: an interior edge between two boundary vertices is not collapsed (it would
//!    pinch the surface);
//! 4. **UV seams** (meshes with UVs): each UV wedge at one end of the edge pairs with a single
//!    wedge at the other. When every wedge of `a` and of `b` touches a face on the edge the
//!    merged vertex is placed freely and gets, per side, the UV `(1 − t) uv_a + t uv_b`, `t` the
//!    projection of its rest position on `ab` (so seams collapse only along themselves); when
//!    only one endpoint's wedges do, that endpoint collapses onto the other, which keeps its
//!    position and UVs (a half-edge collapse, [`super::cost::place_at_endpoint`]: a seam vertex
//!    never leaves its seam); otherwise the edge is not collapsed (seam corners stay);
//! 5. **no flips in any example pose**: every surviving face around `a` and `b` keeps
//!    `n_before · n_after > 0` in the rest pose and every training pose.
//!
//! Queue entries carry the versions of both endpoints; an entry whose endpoint changed since is
//! skipped. Ties in cost are broken by (a, b): the order does not depend on the thread count
//! (the initial costs are computed in parallel, each edge independently).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use nalgebra::{Matrix4, Point2, Point3};
use rayon::prelude::*;

use super::cost::{
    place_at_endpoint, place_endpoint_weights, place_frames, place_full_cost, place_rest,
    reduce_weights, Candidates, EdgeProblem,
};
use super::hierarchy::{CollapseRecord, Hierarchy};
use super::quadric::{edge_constraint, unit_normal, Quadric};
use super::weights::{largest_support, Weights, MAX_CANDIDATES};
use super::{Deformation, Input, Method, Options};
use crate::error::Result;
use crate::mesh::{Adjacency, EdgeKind, EDGE_CORNERS};

/// Simplify `input` with `options`: the full collapse hierarchy (down to
/// `options.target_vertices`, or as far as the validity checks allow).
pub fn simplify(input: &Input, options: &Options) -> Result<Hierarchy> {
    simplify_with_progress(input, options, &mut |_, _| {})
}

/// [`simplify`], calling `progress(collapses done, collapses wanted)` after each collapse.
///
/// The loop runs on a rayon worker ([`rayon::scope`]) so that the re-evaluation of the edges
/// around each collapse can fork cheaply; results do not depend on the thread count (entries
/// are computed in parallel but pushed in neighbour order).
pub fn simplify_with_progress(
    input: &Input,
    options: &Options,
    progress: &mut (dyn FnMut(usize, usize) + Send),
) -> Result<Hierarchy> {
    input.validate()?;
    options.validate()?;
    let mut result = None;
    rayon::scope(|_| result = Some(collapse_loop(input, options, progress)));
    Ok(result.expect("the scope ran"))
}

/// The greedy loop of [`simplify`]: pop the cheapest edge, skip stale or invalid entries,
/// collapse, re-queue the edges around the kept vertex.
fn collapse_loop(
    input: &Input,
    options: &Options,
    progress: &mut (dyn FnMut(usize, usize) + Send),
) -> Hierarchy {
    let mut state = State::new(input, options);
    let wanted = state.alive_count.saturating_sub(options.target_vertices);
    let mut queue = state.initial_queue();
    // A skinned Full/Mohr cost is an alternating minimisation (tens of µs): worth forking.
    // The rest-pose and frame costs are a 3×3 solve: cheaper than the fork.
    let parallel = state.skinned && state.method != Method::Rest;
    while state.alive_count > options.target_vertices {
        let Some(Reverse(entry)) = queue.pop() else {
            break;
        };
        let (a, b) = (entry.a as usize, entry.b as usize);
        if state.version[a] != entry.version_a || state.version[b] != entry.version_b {
            continue;
        }
        let Some(mode) = state.uv_mode(a, b) else {
            continue;
        };
        let mut candidate = state.evaluate(a, b, mode);
        state.pose(&mut candidate);
        let Some(uv_plan) = state.valid(a, b, mode, &candidate) else {
            continue;
        };
        state.collapse(a, b, candidate, uv_plan);
        // The edges around `a` changed cost: re-evaluate them, push them in neighbour order.
        let neighbours = state.neighbours(a);
        let requeue = |&n: &usize| state.entry(a.min(n), a.max(n));
        let around: Vec<Entry> = if parallel {
            neighbours.par_iter().map(requeue).collect()
        } else {
            neighbours.iter().map(requeue).collect()
        };
        queue.extend(around.into_iter().map(Reverse));
        progress(state.records.len(), wanted);
    }
    state.into_hierarchy()
}

/// Joint matrices per pose, `[pose][joint]`.
type PoseMats = Vec<Vec<Matrix4<f64>>>;
/// Vertex positions per pose, `[pose][vertex]`.
type PosePoints = Vec<Vec<Point3<f64>>>;
/// Faces, UV faces and UVs.
type CleanFaces = (Vec<[u32; 3]>, Vec<[u32; 3]>, Vec<Point2<f64>>);

/// A queued edge with the cost when it was queued and its endpoints' versions then.
#[derive(Clone, Copy, Debug)]
struct Entry {
    cost: f64,
    a: u32,
    b: u32,
    version_a: u32,
    version_b: u32,
}

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    /// By cost, then by `(a, b)` (deterministic ties).
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.cost
            .total_cmp(&other.cost)
            .then(self.a.cmp(&other.a))
            .then(self.b.cmp(&other.b))
    }
}

/// A merged vertex: rest position, weights, positions in the check poses, cost.
#[derive(Clone, Debug)]
struct Candidate {
    rest: Point3<f64>,
    weights: Weights,
    /// Positions in the check poses (skinned: rest, then training poses, filled by
    /// [`State::pose`]; frames: the frames).
    posed: Vec<Point3<f64>>,
    cost: f64,
}

/// How a collapse may place the merged vertex (module docs, condition 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Anywhere (both endpoints' UV wedges all lie on the edge's faces).
    Free,
    /// At endpoint `k` (0 = a, 1 = b): a half-edge collapse of the other endpoint onto it.
    Keep(usize),
}

/// How the UVs of a collapse change: old UV index → new UV index, and the new UVs.
struct UvPlan {
    map: Vec<(u32, u32)>,
    new_uvs: Vec<Point2<f64>>,
}

/// The working mesh during simplification.
struct State<'a> {
    options: &'a Options,
    method: Method,
    skinned: bool,
    /// Poses of the cost quadrics: training poses, or the rest pose for [`Method::Rest`].
    quad_poses: usize,
    /// `quad_mats[j][k]`: joint matrices of the quadric poses (identities for the rest pose).
    quad_mats: Vec<Vec<Matrix4<f64>>>,
    /// `check_mats[c][k]`: rest (identities) then training poses (skinned only).
    check_mats: Vec<Vec<Matrix4<f64>>>,
    check_poses: usize,
    quadrics: Vec<Quadric>,
    check_pos: Vec<Point3<f64>>,
    rest: Vec<Point3<f64>>,
    weights: Vec<Weights>,
    faces: Vec<[u32; 3]>,
    uv_faces: Vec<[u32; 3]>,
    face_alive: Vec<bool>,
    vertex_faces: Vec<Vec<u32>>,
    /// The distinct UV indices (wedges) of each vertex over its alive faces, sorted; kept up to
    /// date by [`State::collapse`] so that [`State::wedges_covered`] costs O(wedges), not
    /// O(valence) (empty without UVs).
    wedges: Vec<Vec<u32>>,
    alive: Vec<bool>,
    version: Vec<u32>,
    locked: Vec<bool>,
    uvs: Vec<Point2<f64>>,
    alive_count: usize,
    records: Vec<CollapseRecord>,
    start: Hierarchy,
}

impl<'a> State<'a> {
    fn new(input: &'a Input, options: &'a Options) -> State<'a> {
        let mesh = &input.mesh;
        let n = mesh.positions.len();
        let training: Vec<Vec<Point3<f64>>> =
            (0..input.pose_count()).map(|j| input.posed(j)).collect();
        let (faces, uv_faces, uvs) = clean_faces(mesh);
        let mut vertex_faces = vec![Vec::new(); n];
        for (f, tri) in faces.iter().enumerate() {
            for &v in tri {
                vertex_faces[v as usize].push(f as u32);
            }
        }
        let locked = locked_vertices(mesh, n);
        let (skinned, rest, joint_count) = match &input.deformation {
            Deformation::Skinned { joints, .. } => (true, mesh.positions.clone(), joints[0].len()),
            Deformation::Frames { frames } => (false, frames[0].clone(), 0),
        };
        let identities = vec![Matrix4::identity(); joint_count];
        let (quad_mats, quad_positions): (PoseMats, PosePoints) =
            match (&input.deformation, options.method) {
                (Deformation::Skinned { .. }, Method::Rest) => {
                    (vec![identities.clone()], vec![rest.clone()])
                }
                (Deformation::Skinned { joints, .. }, _) => (joints.clone(), training.clone()),
                (Deformation::Frames { .. }, _) => (Vec::new(), training.clone()),
            };
        let quad_poses = quad_positions.len();
        let quadrics = vertex_quadrics(
            &faces,
            &uv_faces,
            mesh,
            &quad_positions,
            options.boundary_weight,
        );
        let (check_mats, check_sets): (PoseMats, PosePoints) = if skinned {
            let Deformation::Skinned { joints, .. } = &input.deformation else {
                unreachable!()
            };
            let mats = std::iter::once(identities)
                .chain(joints.iter().cloned())
                .collect();
            (
                mats,
                std::iter::once(rest.clone())
                    .chain(training.iter().cloned())
                    .collect(),
            )
        } else {
            (Vec::new(), training.clone())
        };
        let check_poses = check_sets.len();
        let mut check_pos = vec![Point3::origin(); n * check_poses];
        for (c, set) in check_sets.iter().enumerate() {
            for i in 0..n {
                check_pos[i * check_poses + c] = set[i];
            }
        }
        let training_quadrics = if skinned && options.method == Method::Rest {
            vertex_quadrics(&faces, &uv_faces, mesh, &training, options.boundary_weight)
        } else {
            quadrics.clone()
        };
        let weights = match &input.deformation {
            Deformation::Skinned { influences, joints } => start_weights(
                influences,
                joints,
                &rest,
                &training_quadrics,
                training.len(),
                options,
            ),
            Deformation::Frames { .. } => vec![Weights::from_pairs(&[]); n],
        };
        let frames = if skinned { Vec::new() } else { training };
        let start = Hierarchy {
            name: mesh.name.clone(),
            method: options.method,
            faces: faces.clone(),
            uv_faces: uv_faces.clone(),
            uvs: uvs.clone(),
            rest: rest.clone(),
            weights: weights.clone(),
            frames,
            records: Vec::new(),
            texture: mesh.texture.clone(),
        };
        let mut state = State {
            options,
            method: options.method,
            skinned,
            quad_poses,
            quad_mats,
            check_mats,
            check_poses,
            quadrics,
            check_pos,
            rest,
            weights,
            face_alive: vec![true; faces.len()],
            faces,
            uv_faces,
            wedges: Vec::new(),
            vertex_faces,
            alive: vec![true; n],
            version: vec![0; n],
            locked,
            uvs,
            alive_count: n,
            records: Vec::new(),
            start,
        };
        state.wedges = (0..n).map(|v| state.distinct_wedges(v)).collect();
        state
    }

    /// Every edge of the mesh with its cost, computed in parallel.
    fn initial_queue(&self) -> BinaryHeap<Reverse<Entry>> {
        let mut edges: Vec<(u32, u32)> = self
            .faces
            .iter()
            .flat_map(|t| EDGE_CORNERS.map(|[i, j]| (t[i].min(t[j]), t[i].max(t[j]))))
            .collect();
        edges.par_sort_unstable();
        edges.dedup();
        let entries: Vec<Reverse<Entry>> = edges
            .par_iter()
            .map(|&(a, b)| Reverse(self.entry(a as usize, b as usize)))
            .collect();
        BinaryHeap::from(entries)
    }

    fn entry(&self, a: usize, b: usize) -> Entry {
        let cost = match self.uv_mode(a, b) {
            Some(mode) if !self.locked[a] && !self.locked[b] => self.evaluate(a, b, mode).cost,
            _ => f64::INFINITY,
        };
        Entry {
            cost,
            a: a as u32,
            b: b as u32,
            version_a: self.version[a],
            version_b: self.version[b],
        }
    }

    /// `Q_a^j + Q_b^j` for every quadric pose.
    fn summed_quadrics(&self, a: usize, b: usize) -> Vec<Quadric> {
        let p = self.quad_poses;
        (0..p)
            .map(|j| self.quadrics[a * p + j].add(&self.quadrics[b * p + j]))
            .collect()
    }

    /// The merged vertex of `(a, b)` by the method's cost, free or on the kept endpoint.
    fn evaluate(&self, a: usize, b: usize, mode: Mode) -> Candidate {
        let quadrics = self.summed_quadrics(a, b);
        if !self.skinned {
            let c = self.check_poses;
            let ends: Vec<[Point3<f64>; 2]> = (0..c)
                .map(|j| [self.check_pos[a * c + j], self.check_pos[b * c + j]])
                .collect();
            let (posed, cost) = match mode {
                Mode::Free => place_frames(&quadrics, &ends, self.options.cost.max_condition),
                Mode::Keep(k) => {
                    let posed: Vec<Point3<f64>> = ends.iter().map(|e| e[k]).collect();
                    let cost = quadrics.iter().zip(&posed).map(|(q, p)| q.eval(p)).sum();
                    (posed, cost)
                }
            };
            return Candidate {
                rest: posed[0],
                weights: self.weights[a],
                posed,
                cost,
            };
        }
        let problem = EdgeProblem {
            quadrics: &quadrics,
            mats: &self.quad_mats,
            ends: [self.rest[a], self.rest[b]],
            weights: [self.weights[a], self.weights[b]],
        };
        let options = &self.options.cost;
        let placement = match (mode, self.method) {
            (Mode::Keep(k), method) => place_at_endpoint(&problem, k, method, options),
            (Mode::Free, Method::Rest) => place_rest(&problem, options),
            (Mode::Free, Method::Mohr) => place_endpoint_weights(&problem, options),
            (Mode::Free, Method::Full) => place_full_cost(&problem, options),
        };
        Candidate {
            rest: placement.rest,
            weights: placement.weights,
            posed: Vec::new(),
            cost: placement.cost,
        }
    }

    /// Fill a skinned candidate's positions in the check poses, v_c = Σ_k w_k M_k^c v̂ (linear
    /// blend skinning), needed only by the flip check of an edge popped from the queue, not by
    /// every queued cost. Frame inputs already have them.
    fn pose(&self, candidate: &mut Candidate) {
        if !self.skinned {
            return;
        }
        let h = candidate.rest.to_homogeneous();
        candidate.posed = self
            .check_mats
            .iter()
            .map(|mats| {
                let mut sum = nalgebra::Vector4::zeros();
                for (k, w) in candidate.weights.pairs() {
                    sum += (mats[k as usize] * h) * w;
                }
                Point3::new(sum.x, sum.y, sum.z)
            })
            .collect();
    }

    /// The sorted distinct neighbours of vertex `v` over its alive faces.
    fn neighbours(&self, v: usize) -> Vec<usize> {
        let mut out: Vec<usize> = self.vertex_faces[v]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .map(|x| x as usize)
            .filter(|&x| x != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Alive faces containing both `a` and `b`, in face order (found in the shorter of the
    /// two face lists).
    fn faces_on_edge(&self, a: usize, b: usize) -> Vec<u32> {
        let (short, other) = if self.vertex_faces[a].len() <= self.vertex_faces[b].len() {
            (a, b)
        } else {
            (b, a)
        };
        self.vertex_faces[short]
            .iter()
            .copied()
            .filter(|&f| self.faces[f as usize].contains(&(other as u32)))
            .collect()
    }

    /// Whether `v` has an edge in exactly one alive face.
    fn on_boundary(&self, v: usize) -> bool {
        let mut ends: Vec<u32> = self.vertex_faces[v]
            .iter()
            .flat_map(|&f| self.faces[f as usize])
            .filter(|&x| x as usize != v)
            .collect();
        ends.sort_unstable();
        ends.chunk_by(|x, y| x == y).any(|g| g.len() == 1)
    }

    /// Whether an alive face has exactly the vertices `{x, y, z}`.
    fn has_face(&self, x: usize, y: usize, z: usize) -> bool {
        self.vertex_faces[x].iter().any(|&f| {
            let t = self.faces[f as usize];
            t.contains(&(y as u32)) && t.contains(&(z as u32))
        })
    }

    /// The validity checks of the module docs; `Some(UV plan)` when valid.
    fn valid(&self, a: usize, b: usize, mode: Mode, candidate: &Candidate) -> Option<UvPlan> {
        if self.locked[a] || self.locked[b] || !candidate.cost.is_finite() {
            return None;
        }
        let on_edge = self.faces_on_edge(a, b);
        if on_edge.is_empty() || on_edge.len() > 2 {
            return None;
        }
        if !self.link_condition(a, b, &on_edge) {
            return None;
        }
        if on_edge.len() == 2 && self.on_boundary(a) && self.on_boundary(b) {
            return None;
        }
        let plan = self.uv_plan(a, b, mode, candidate);
        self.flip_free(a, b, candidate).then_some(plan)
    }

    /// Condition 2 of the module docs.
    fn link_condition(&self, a: usize, b: usize, on_edge: &[u32]) -> bool {
        let na = self.neighbours(a);
        let nb = self.neighbours(b);
        let common: Vec<usize> = na
            .iter()
            .copied()
            .filter(|x| nb.binary_search(x).is_ok())
            .collect();
        if common.len() != on_edge.len() {
            return false;
        }
        let opposite = |f: u32| -> usize {
            self.faces[f as usize]
                .iter()
                .map(|&x| x as usize)
                .find(|&x| x != a && x != b)
                .unwrap_or(a)
        };
        let opp: Vec<usize> = on_edge.iter().map(|&f| opposite(f)).collect();
        if opp.iter().any(|o| common.binary_search(o).is_err()) {
            return false;
        }
        if let [c, d] = opp[..] {
            if c == d || self.has_face(a, c, d) || self.has_face(b, c, d) {
                return false;
            }
        }
        true
    }

    /// The UV index of vertex `v` in face `f`.
    fn corner_uv(&self, f: u32, v: usize) -> u32 {
        let t = self.faces[f as usize];
        let k = t.iter().position(|&x| x as usize == v).unwrap_or(0);
        self.uv_faces[f as usize][k]
    }

    /// The UV sides of edge `(a, b)`: one `(uv at a, uv at b)` pair per distinct side among
    /// the faces on the edge; `None` when two sides share one end's UV but not the other's.
    fn uv_sides(&self, a: usize, b: usize) -> Option<Vec<(u32, u32)>> {
        let mut sides: Vec<(u32, u32)> = Vec::new();
        for f in self.faces_on_edge(a, b) {
            let side = (self.corner_uv(f, a), self.corner_uv(f, b));
            if sides.contains(&side) {
                continue;
            }
            if sides.iter().any(|s| s.0 == side.0 || s.1 == side.1) {
                return None;
            }
            sides.push(side);
        }
        Some(sides)
    }

    /// Whether every UV wedge of `v` appears at `v` on a face of the edge (`end` 0: `v = a`).
    fn wedges_covered(&self, v: usize, sides: &[(u32, u32)], end: usize) -> bool {
        self.wedges[v].iter().all(|&u| {
            sides
                .iter()
                .any(|s| if end == 0 { s.0 == u } else { s.1 == u })
        })
    }

    /// The sorted distinct UV indices of `v` over its alive faces (empty without UVs).
    fn distinct_wedges(&self, v: usize) -> Vec<u32> {
        if self.uv_faces.is_empty() {
            return Vec::new();
        }
        let mut out: Vec<u32> = self.vertex_faces[v]
            .iter()
            .map(|&f| self.corner_uv(f, v))
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Condition 4 of the module docs: how the edge may collapse for the UVs. `Free` when both
    /// endpoints' wedges all touch the edge; `Keep(k)` (a half-edge collapse onto endpoint `k`,
    /// which does not move) when only the other endpoint's do; `None` when neither.
    fn uv_mode(&self, a: usize, b: usize) -> Option<Mode> {
        if self.uv_faces.is_empty() {
            return Some(Mode::Free);
        }
        let sides = self.uv_sides(a, b)?;
        if sides.is_empty() {
            return None;
        }
        match (
            self.wedges_covered(a, &sides, 0),
            self.wedges_covered(b, &sides, 1),
        ) {
            (true, true) => Some(Mode::Free),
            (true, false) => Some(Mode::Keep(1)),
            (false, true) => Some(Mode::Keep(0)),
            (false, false) => None,
        }
    }

    /// The UV map of a collapse in `mode`: `Free` gives each side the new UV
    /// `(1 − t) uv_a + t uv_b` (`t` the projection of the new rest position on `ab`);
    /// `Keep(k)` maps the moving endpoint's UV on each side to the kept endpoint's.
    fn uv_plan(&self, a: usize, b: usize, mode: Mode, candidate: &Candidate) -> UvPlan {
        let mut plan = UvPlan {
            map: Vec::new(),
            new_uvs: Vec::new(),
        };
        if self.uv_faces.is_empty() {
            return plan;
        }
        let sides = self.uv_sides(a, b).unwrap_or_default();
        if let Mode::Keep(k) = mode {
            for &(ua, ub) in &sides {
                plan.map.push(if k == 0 { (ub, ua) } else { (ua, ub) });
            }
            return plan;
        }
        let (pa, pb) = (self.rest[a], self.rest[b]);
        let ab = pb - pa;
        let t = if ab.norm_squared() > 0.0 {
            ((candidate.rest - pa).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0)
        } else {
            0.5
        };
        for (k, &(ua, ub)) in sides.iter().enumerate() {
            let uv = self.uvs[ua as usize].coords * (1.0 - t) + self.uvs[ub as usize].coords * t;
            let new = (self.uvs.len() + k) as u32;
            plan.new_uvs.push(Point2::from(uv));
            plan.map.push((ua, new));
            plan.map.push((ub, new));
        }
        plan
    }

    /// Condition 5: `n_before · n_after > 0` for every surviving face around `a`, `b` in every
    /// check pose (faces already degenerate in a pose are not judged in that pose).
    fn flip_free(&self, a: usize, b: usize, candidate: &Candidate) -> bool {
        let c = self.check_poses;
        for &v in &[a, b] {
            for &f in &self.vertex_faces[v] {
                let t = self.faces[f as usize];
                if t.contains(&(a as u32)) && t.contains(&(b as u32)) {
                    continue;
                }
                for pose in 0..c {
                    let old = t.map(|x| self.check_pos[x as usize * c + pose]);
                    let new = t.map(|x| {
                        if x as usize == v {
                            candidate.posed[pose]
                        } else {
                            self.check_pos[x as usize * c + pose]
                        }
                    });
                    let n_old = (old[1] - old[0]).cross(&(old[2] - old[0]));
                    if n_old.norm_squared() == 0.0 {
                        continue;
                    }
                    let n_new = (new[1] - new[0]).cross(&(new[2] - new[0]));
                    if n_old.dot(&n_new).is_nan() || n_old.dot(&n_new) <= 0.0 {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// Merge `b` into `a` at `candidate`, with the UV plan; record it.
    fn collapse(&mut self, a: usize, b: usize, candidate: Candidate, plan: UvPlan) {
        let c = self.check_poses;
        let p = self.quad_poses;
        self.rest[a] = candidate.rest;
        self.weights[a] = candidate.weights;
        self.check_pos[a * c..(a + 1) * c].copy_from_slice(&candidate.posed);
        for j in 0..p {
            let qb = self.quadrics[b * p + j];
            self.quadrics[a * p + j].add_assign(&qb);
        }
        let mut merged: Vec<u32> = Vec::new();
        let mut opposite: Vec<usize> = Vec::new();
        for f in std::mem::take(&mut self.vertex_faces[b]) {
            let t = &mut self.faces[f as usize];
            if t.contains(&(a as u32)) {
                self.face_alive[f as usize] = false;
                opposite.extend(t.iter().map(|&x| x as usize).filter(|&x| x != a && x != b));
            } else {
                for x in t.iter_mut() {
                    if *x as usize == b {
                        *x = a as u32;
                    }
                }
                merged.push(f);
            }
        }
        merged.extend(
            self.vertex_faces[a]
                .iter()
                .copied()
                .filter(|&f| self.face_alive[f as usize]),
        );
        merged.sort_unstable();
        if !self.uv_faces.is_empty() {
            for &f in &merged {
                let k = self.faces[f as usize]
                    .iter()
                    .position(|&x| x as usize == a)
                    .unwrap_or(0);
                let u = &mut self.uv_faces[f as usize][k];
                if let Some(&(_, new)) = plan.map.iter().find(|m| m.0 == *u) {
                    *u = new;
                }
            }
        }
        self.vertex_faces[a] = merged;
        // The faces on the edge also leave their opposite vertices' lists.
        for &x in &opposite {
            let alive = &self.face_alive;
            self.vertex_faces[x].retain(|&f| alive[f as usize]);
        }
        for x in std::iter::once(a).chain(opposite) {
            self.wedges[x] = self.distinct_wedges(x);
        }
        self.wedges[b].clear();
        self.uvs.extend_from_slice(&plan.new_uvs);
        self.alive[b] = false;
        self.version[a] += 1;
        self.version[b] += 1;
        self.alive_count -= 1;
        let frames = if self.skinned {
            Vec::new()
        } else {
            candidate.posed
        };
        self.records.push(CollapseRecord {
            kept: a as u32,
            removed: b as u32,
            rest: candidate.rest,
            weights: candidate.weights,
            frames,
            uv_map: plan.map,
            new_uvs: plan.new_uvs,
            cost: candidate.cost,
        });
    }

    fn into_hierarchy(self) -> Hierarchy {
        Hierarchy {
            records: self.records,
            uvs: self.uvs,
            ..self.start
        }
    }
}

/// Faces without repeated vertices, and UVs split so that each UV index belongs to one vertex
/// (a UV shared by two positions gets one copy per position), so that remapping a UV index
/// touches one vertex only.
fn clean_faces(mesh: &crate::mesh::TriMesh) -> CleanFaces {
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
    let mut index = std::collections::BTreeMap::new();
    let mut uvs = Vec::new();
    let mut uv_faces = Vec::with_capacity(faces.len());
    for &f in &keep {
        let t = [0, 1, 2].map(|k| {
            let key = (mesh.faces[f][k], mesh.uv_faces[f][k]);
            *index.entry(key).or_insert_with(|| {
                uvs.push(mesh.uvs[key.1 as usize]);
                (uvs.len() - 1) as u32
            })
        });
        uv_faces.push(t);
    }
    (faces, uv_faces, uvs)
}

/// Vertices on a non-manifold or misoriented edge of the input: never moved.
fn locked_vertices(mesh: &crate::mesh::TriMesh, n: usize) -> Vec<bool> {
    let adjacency = Adjacency::new(mesh);
    let mut locked = vec![false; n];
    for (f, kinds) in adjacency.edges.iter().enumerate() {
        for (e, kind) in kinds.iter().enumerate() {
            if matches!(kind, EdgeKind::NonManifold | EdgeKind::Misoriented { .. }) {
                for c in EDGE_CORNERS[e] {
                    locked[mesh.faces[f][c] as usize] = true;
                }
            }
        }
    }
    locked
}

/// `Q_i^j = Σ_{f∋i} K_f^j` plus the constraint planes of boundary and UV-seam edges, for
/// every vertex `i` and pose `j` of `positions` (`[pose][vertex]`); layout `i * P + j`.
/// Summed face by face in face order (deterministic).
fn vertex_quadrics(
    faces: &[[u32; 3]],
    uv_faces: &[[u32; 3]],
    mesh: &crate::mesh::TriMesh,
    positions: &[Vec<Point3<f64>>],
    boundary_weight: f64,
) -> Vec<Quadric> {
    let p = positions.len();
    let n = mesh.positions.len();
    let special = special_edges(faces, uv_faces);
    let mut out = vec![Quadric::default(); n * p];
    let per_pose: Vec<Vec<Quadric>> = positions
        .par_iter()
        .map(|pos| {
            let mut q = vec![Quadric::default(); n];
            for (f, t) in faces.iter().enumerate() {
                let [x, y, z] = t.map(|v| pos[v as usize]);
                let k = Quadric::from_triangle(&x, &y, &z);
                for &v in t {
                    q[v as usize].add_assign(&k);
                }
                let normal = unit_normal(&x, &y, &z);
                for (e, [i, j]) in EDGE_CORNERS.iter().enumerate() {
                    if special[f][e] {
                        let (vi, vj) = (t[*i] as usize, t[*j] as usize);
                        let c = edge_constraint(&pos[vi], &pos[vj], &normal, boundary_weight);
                        q[vi].add_assign(&c);
                        q[vj].add_assign(&c);
                    }
                }
            }
            q
        })
        .collect();
    for (j, q) in per_pose.into_iter().enumerate() {
        for (i, x) in q.into_iter().enumerate() {
            out[i * p + j] = x;
        }
    }
    out
}

/// `special[f][e]`: local edge `e` of face `f` is a boundary (no other face) or a UV seam (the
/// other face has different UVs at its ends).
fn special_edges(faces: &[[u32; 3]], uv_faces: &[[u32; 3]]) -> Vec<[bool; 3]> {
    let mut records: Vec<(u32, u32, usize, usize)> = Vec::with_capacity(faces.len() * 3);
    for (f, t) in faces.iter().enumerate() {
        for (e, [i, j]) in EDGE_CORNERS.iter().enumerate() {
            records.push((t[*i].min(t[*j]), t[*i].max(t[*j]), f, e));
        }
    }
    records.sort_unstable();
    let mut special = vec![[false; 3]; faces.len()];
    let uv_at = |f: usize, v: u32| -> Option<u32> {
        let k = faces[f].iter().position(|&x| x == v)?;
        uv_faces.get(f).map(|t| t[k])
    };
    for group in records.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        if group.len() == 1 {
            let (_, _, f, e) = group[0];
            special[f][e] = true;
            continue;
        }
        if group.len() == 2 && !uv_faces.is_empty() {
            let (lo, hi, f, e) = group[0];
            let (_, _, g, d) = group[1];
            if uv_at(f, lo) != uv_at(g, lo) || uv_at(f, hi) != uv_at(g, hi) {
                special[f][e] = true;
                special[g][d] = true;
            }
        }
    }
    special
}

/// The input weights as [`Weights`]; a vertex with more than `W_max` influences is reduced as
/// in the seed's weight reduction, at its own rest position with its own training quadrics:
/// keep the `W_max` largest (of at most [`MAX_CANDIDATES`]), re-solve the weight QP on them.
fn start_weights(
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
