//! Greedy edge collapse with a priority queue (SPEC.md § 9): the cheapest valid edge is
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
//! skipped (`super::queue`). Ties in cost are broken by (a, b): the order does not depend on
//! the thread count (the costs are computed in parallel, each edge independently).
//!
//! **Order** ([`Schedule`]): by default exactly greedy — after each collapse every edge around
//! the kept vertex is costed again and re-queued. On shapes where merged vertices gather many
//! edges (the rest-pose quadrics of a tube let whole rulings merge at zero cost, ≈ 40 edges
//! per vertex at 100k triangles) that re-costing dominates; [`Schedule::Passes`] instead costs
//! and sorts all edges once per pass, as meshoptimizer does.
//!
//! **Cost of one step** (issue #6 speed targets): the neighbourhood of a collapse is scanned in
//! O(valence) with reusable per-vertex stamps (`Stars`) instead of sorted neighbour lists;
//! face lists are merged, not re-sorted; nothing is allocated per collapse; a costly candidate
//! (skinned Full/Mohr) is kept with its queue entry so that the popped edge is not evaluated a
//! second time; the rest-pose method queues edges by the QEM value alone
//! ([`super::cost::rest_position`]) and chooses the weights only for the edge it collapses.
//! The faces and UV wedges of every vertex are lists in one flat arena (`super::lists`), not
//! one heap block each. [`Schedule::Passes`] tries edges in cost order, all over the mesh, so
//! nearly every try starts with cache misses; it knows the next edges, though, and prefetches
//! their data a few tries ahead, in steps (vertex data, then face lists, then faces, then
//! the faces' vertices: `State::prefetch_vertices` and the following).
//! None of this changes a bit of the greedy result (a test pins the records' hash).
//!
//! What the loop starts from (clean faces, locked vertices, special edges, the per-pose vertex
//! quadrics `Q_i^j`, the start weights) is built in [`super::setup`], one function each; the
//! order of one pass of [`Schedule::Passes`] is `super::pass_order`.

use std::borrow::Cow;

use nalgebra::{Matrix4, Point2, Point3};
use rayon::prelude::*;

use super::cost::{
    place_at_endpoint, place_endpoint_weights, place_frames, place_full_cost, place_rest,
    rest_position, rest_value, EdgeProblem,
};
use super::hierarchy::{CollapseRecord, Hierarchy};
use super::lists::{prefetch, Lists};
use super::pass_order::PassOrder;
use super::quadric::Quadric;
use super::queue::{Entry, Queue};
use super::setup::{
    clean_faces, locked_vertices, sorted_edge_records, special_edges, start_weights,
    vertex_face_lists, vertex_quadrics,
};
use super::weights::Weights;
use super::{Deformation, Input, Method, Options, Schedule};
use crate::error::Result;

/// Simplify `input` with `options`: the full collapse hierarchy (down to
/// `options.target_vertices`, or as far as the validity checks allow).
pub fn simplify(input: &Input, options: &Options) -> Result<Hierarchy> {
    simplify_with_progress(input, options, &mut |_, _| {})
}

/// [`simplify`], calling `progress(collapses done, collapses wanted)` after each collapse.
///
/// The loop runs on a rayon worker ([`rayon::scope`]) so that the re-evaluation of the edges
/// around each collapse can fork cheaply; results do not depend on the thread count (entries
/// are computed in parallel, each edge on its own, and their order is fixed by their keys).
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

/// The loop of [`simplify`] in the order of `options.schedule`.
fn collapse_loop(
    input: &Input,
    options: &Options,
    progress: &mut (dyn FnMut(usize, usize) + Send),
) -> Hierarchy {
    let mut state = State::new(input, options);
    let wanted = state.alive_count.saturating_sub(options.target_vertices);
    state.records.reserve(wanted);
    match options.schedule {
        Schedule::Greedy => greedy(&mut state, options.target_vertices, progress),
        Schedule::Passes => passes(&mut state, options.target_vertices, progress),
    }
    state.into_hierarchy()
}

/// [`Schedule::Greedy`]: pop the cheapest edge, skip stale entries, try to collapse it,
/// re-queue the edges around the kept vertex.
fn greedy(state: &mut State, target: usize, progress: &mut (dyn FnMut(usize, usize) + Send)) {
    let wanted = state.alive_count.saturating_sub(target);
    let mut scored = ScoredEdges::default();
    state.scored_edges(None, &mut scored);
    let (entries, candidates) = scored.into_flat();
    let mut queue = Queue::new(entries, candidates);
    let mut scratch = Scratch::new(state.alive.len());
    while state.alive_count > target {
        let Some((entry, cached)) = queue.pop(|e| state.is_current(e)) else {
            break;
        };
        let (a, b) = (entry.a as usize, entry.b as usize);
        if !state.is_current(&entry) || !state.try_collapse(a, b, cached, &mut scratch) {
            continue;
        }
        state.requeue_around(a, &mut queue, &mut scratch);
        queue.tidy(|e| state.is_current(e));
        progress(state.records.len(), wanted);
    }
}

/// [`Schedule::Passes`]: repeat { cost every edge; sort; try the edges in that order, skipping
/// those with an endpoint already merged in this pass, until the pass's share is done } until
/// the target or a pass without collapse. A pass stops (as meshoptimizer's) at the cost
/// `1.5 × c_g`, `c_g` the cost of the `g`-th cheapest edge, `g` the collapses still wanted,
/// once it has done more than `max(g / 10, w / 100)` (`w` the collapses wanted at the start):
/// the skipped edges are re-costed by the next pass.
///
/// Only the edges up to that cost are sorted at first ([`PassOrder`]); the others only if the
/// pass has not done its least when it reaches them. The order is the same as a full sort's.
/// An edge whose endpoints no collapse of the last pass changed keeps its cost from that pass
/// ([`Reuse`]): the same value, not computed again.
fn passes(state: &mut State, target: usize, progress: &mut (dyn FnMut(usize, usize) + Send)) {
    let wanted = state.alive_count.saturating_sub(target);
    let mut scratch = Scratch::new(state.alive.len());
    let mut merged = vec![false; state.alive.len()];
    // `changed[v]`: a collapse of the last pass moved, removed or took faces from `v`.
    let mut changed = vec![false; state.alive.len()];
    let mut order = PassOrder::default();
    // This pass's scores and the last one's (if any), their buffers swapped from pass to pass.
    let (mut scored, mut last) = (ScoredEdges::default(), ScoredEdges::default());
    let mut have_last = false;
    while state.alive_count > target {
        let reuse = have_last.then(|| Reuse {
            blocks: &last.blocks,
            changed: &changed,
        });
        // The lists of the vertices in vertex order again, as the scoring reads them.
        state.vertex_faces.compact();
        state.scored_edges(reuse.as_ref(), &mut scored);
        changed.fill(false);
        let goal = state.alive_count - target;
        let stop = order.start(scored.blocks.iter().map(|b| &b.entries[..]), goal);
        // The least a pass does before its cost bound applies (so that the passes do not
        // dwindle to one collapse each near the target).
        let least = (goal / 10).max(wanted / 100);
        merged.fill(false);
        let mut done = 0;
        while let Some((cost, a, b)) = order.next() {
            // Ask for the data of the edges a few places ahead (only a hint: it changes nothing),
            // from the second step on only for those not skipped (so far) in this pass.
            if let Some((x, y)) = order.ahead(PREFETCH_VERTICES) {
                prefetch(&merged[x]);
                prefetch(&merged[y]);
                state.prefetch_vertices(x, y);
            }
            let unmerged = |d| order.ahead(d).filter(|&(x, y)| !merged[x] && !merged[y]);
            if let Some((x, y)) = unmerged(PREFETCH_LISTS) {
                state.prefetch_lists(x, y);
            }
            if let Some((x, y)) = unmerged(PREFETCH_FACES) {
                state.prefetch_faces(x, y);
            }
            if let Some((x, y)) = unmerged(PREFETCH_NEIGHBOURS) {
                state.prefetch_neighbours(x, y, &scratch.stars);
            }
            if state.alive_count <= target || !cost.is_finite() {
                break;
            }
            if cost > stop && done > least {
                break;
            }
            if merged[a] || merged[b] {
                continue;
            }
            let cached = scored.take_candidate(a, b);
            if !state.try_collapse(a, b, cached, &mut scratch) {
                continue;
            }
            merged[a] = true;
            merged[b] = true;
            for &x in [a as u32, b as u32].iter().chain(&scratch.opposite) {
                changed[x as usize] = true;
            }
            done += 1;
            progress(state.records.len(), wanted);
        }
        if done == 0 {
            break;
        }
        std::mem::swap(&mut scored, &mut last);
        have_last = true;
    }
}

/// How many edges ahead of its try [`passes`] asks for an edge's vertex data
/// ([`State::prefetch_vertices`]), then (once that has arrived) for its face lists
/// ([`State::prefetch_lists`]), then for its faces ([`State::prefetch_faces`]), then for
/// the data of their vertices ([`State::prefetch_neighbours`]): each step reads what the one
/// before brought in.
const PREFETCH_VERTICES: usize = 32;
const PREFETCH_LISTS: usize = 16;
const PREFETCH_FACES: usize = 8;
const PREFETCH_NEIGHBOURS: usize = 4;

/// Vertices per block of [`State::scored_edges`] (the unit of its parallel work).
const BLOCK: usize = 4096;

/// The output of [`State::scored_edges`]: every edge's entry and candidate, in blocks of
/// [`BLOCK`] vertices, each block's edges ordered by `(a, b)` (so all of them are, block after
/// block). The blocks are used where they are, not gathered into one list: the passes of
/// [`passes`] reuse their memory rather than copy (and fault in) tens of MB per pass.
#[derive(Default)]
struct ScoredEdges {
    blocks: Vec<ScoredBlock>,
}

/// The edges `(a, b)` whose first endpoint `a` is in one block of vertices, ordered by
/// `(a, b)`: `entries[i]` and `candidates[i]` are those of the same edge. Only a costly method
/// ([`State::costly`]) has candidates; for the others `candidates` stays empty (rather than
/// hold one `None` per edge).
#[derive(Default)]
struct ScoredBlock {
    entries: Vec<Entry>,
    candidates: Vec<Option<Scored>>,
}

impl ScoredEdges {
    /// The candidate of edge `(a, b)`, taken (a pass tries each edge once); `None` without
    /// one. Found by a binary search of the block of `a` (costly methods only: the others
    /// have no candidates to search).
    fn take_candidate(&mut self, a: usize, b: usize) -> Option<Scored> {
        let block = &mut self.blocks[a / BLOCK];
        if block.candidates.is_empty() {
            return None;
        }
        let key = (a as u32, b as u32);
        let i = block.entries.partition_point(|e| (e.a, e.b) < key);
        block.candidates.get_mut(i)?.take()
    }

    /// Every entry and candidate in one list each, ordered by `(a, b)`, the candidates `None`
    /// where there are none (for the queue of [`greedy`]).
    fn into_flat(self) -> (Vec<Entry>, Vec<Option<Scored>>) {
        let total = self.blocks.iter().map(|b| b.entries.len()).sum();
        let (mut entries, mut candidates) = (Vec::with_capacity(total), Vec::with_capacity(total));
        for mut block in self.blocks {
            let missing = block.entries.len() - block.candidates.len();
            entries.append(&mut block.entries);
            candidates.append(&mut block.candidates);
            candidates.extend(std::iter::repeat_with(|| None).take(missing));
        }
        (entries, candidates)
    }
}

/// The scores of the last pass of [`passes`] (in the blocks [`State::scored_edges`] made) and
/// the vertices its collapses changed: an edge with neither endpoint changed has the same
/// faces, UVs, wedges and quadrics at its ends, so the same entry (and candidate, unless a try
/// took it).
struct Reuse<'p> {
    blocks: &'p [ScoredBlock],
    changed: &'p [bool],
}

impl Reuse<'_> {
    /// The kept score of edge `(a, b)`, if it can be kept: the edges of block `block` are asked
    /// for in `(a, b)` order, `cursor` walking the last pass's entries of that block along
    /// (the blocks cover the same vertices from pass to pass).
    fn keep(
        &self,
        block: usize,
        cursor: &mut usize,
        (a, b): (usize, usize),
        costly: bool,
    ) -> Option<(Entry, Option<Scored>)> {
        let ScoredBlock {
            entries,
            candidates,
        } = &self.blocks[block];
        let key = (a as u32, b as u32);
        while entries.get(*cursor).is_some_and(|e| (e.a, e.b) < key) {
            *cursor += 1;
        }
        let i = *cursor;
        let same_edge = entries.get(i).is_some_and(|e| (e.a, e.b) == key);
        if !same_edge || self.changed[a] || self.changed[b] {
            return None;
        }
        // A costly method's candidate is kept with its entry, unless a try took it.
        let candidate = candidates.get(i).cloned().flatten();
        (!costly || candidate.is_some()).then(|| (entries[i], candidate))
    }
}

/// Joint matrices per pose, `[pose][joint]`.
type PoseMats = Vec<Vec<Matrix4<f64>>>;
/// Vertex positions per pose, `[pose][vertex]`, borrowed (not copied: each set is a few MB
/// per million triangles).
type PosePoints<'p> = Vec<&'p [Point3<f64>]>;

/// A candidate with the UV mode it was computed for (boxed: most entries have none, and
/// `Option<Box<_>>` keeps those small).
type Scored = Box<(Mode, Candidate)>;

/// Buffers reused by every collapse (the serial part of the loop allocates per step only what
/// its record keeps: the UV map and the new UVs).
struct Scratch {
    /// The stars of the two endpoints.
    stars: Stars,
    /// Opposite vertices of the faces removed by the last collapse.
    opposite: Vec<u32>,
    /// A list buffer: the merged face list of a collapse, the wedges of a vertex.
    faces: Vec<u32>,
    /// The memory of a skinned candidate's positions in the check poses ([`State::pose`]),
    /// handed back after the flip check or the collapse has read them.
    posed: Vec<Point3<f64>>,
}

impl Scratch {
    /// Buffers for a mesh of `n` vertices.
    fn new(n: usize) -> Scratch {
        Scratch {
            stars: Stars::new(n),
            opposite: Vec::new(),
            faces: Vec::new(),
            posed: Vec::new(),
        }
    }
}

/// The sorted union of two sorted lists without common values, into `out`.
fn merge_sorted<'x>(
    x: impl Iterator<Item = &'x u32>,
    y: impl Iterator<Item = &'x u32>,
    out: &mut Vec<u32>,
) {
    out.clear();
    let (mut x, mut y) = (x.peekable(), y.peekable());
    loop {
        let next = match (x.peek(), y.peek()) {
            (Some(&&p), Some(&&q)) if p <= q => x.next(),
            (Some(_), Some(_)) => y.next(),
            (Some(_), None) => x.next(),
            (None, Some(_)) => y.next(),
            (None, None) => return,
        };
        out.extend(next);
    }
}

/// Insert `x` into the sorted list `out` unless present (a vertex has few distinct wedges:
/// cheaper than sorting a valence-long list).
fn insert_sorted(out: &mut Vec<u32>, x: u32) {
    if let Err(k) = out.binary_search(&x) {
        out.insert(k, x);
    }
}

/// The stars of the two endpoints of an edge, side 0 (`a`) and side 1 (`b`). The star of a
/// vertex `v`: its distinct neighbours, each with the alive faces on the edge `(v, n)` (in
/// face order), found in O(valence) without sorting ([`Stars::gather`]): a neighbour's index
/// in the side's list is remembered per vertex, valid while its stamp is the side's current
/// one (so nothing is cleared between stars).
///
/// The two sides' marks of a vertex lie side by side, so that asking whether a neighbour of
/// `a` is one of `b` (the link condition) reads the cache line that gathering `a`'s star has
/// just loaded, rather than a line of another array.
struct Stars {
    /// Per side, `(n, faces on (v, n))`, neighbours in the order they are first met.
    lists: [Vec<(u32, EdgeFaces)>; 2],
    /// Per side, the current stamp.
    stamps: [u32; 2],
    /// `mark[x][side] = [stamp, i]`: `x` is a neighbour of the side's vertex, at
    /// `lists[side][i]`, when `stamp` is the side's current one.
    mark: Vec<[[u32; 2]; 2]>,
}

impl Stars {
    fn new(n: usize) -> Stars {
        Stars {
            lists: [Vec::new(), Vec::new()],
            stamps: [0; 2],
            mark: vec![[[0; 2]; 2]; n],
        }
    }

    /// The star of `v` on `side` over `vertex_faces[v]` (sorted, so each edge's faces are in
    /// face order).
    fn gather(&mut self, side: usize, v: usize, vertex_faces: &[u32], faces: &[[u32; 3]]) {
        let list = &mut self.lists[side];
        list.clear();
        self.stamps[side] += 1;
        let stamp = self.stamps[side];
        for &f in vertex_faces {
            for x in faces[f as usize] {
                let x = x as usize;
                if x == v {
                    continue;
                }
                let mark = &mut self.mark[x][side];
                if mark[0] != stamp {
                    *mark = [stamp, list.len() as u32];
                    list.push((x as u32, EdgeFaces::default()));
                }
                list[mark[1] as usize].1.push(f);
            }
        }
    }

    /// Prefetch ([`prefetch`]) the marks of `x`.
    fn prefetch(&self, x: usize) {
        prefetch(&self.mark[x]);
    }

    /// The neighbours of the star on `side`, with the faces on their edges.
    fn list(&self, side: usize) -> &[(u32, EdgeFaces)] {
        &self.lists[side]
    }

    /// Whether `x` is a neighbour in the star on `side`.
    fn contains(&self, side: usize, x: u32) -> bool {
        self.mark[x as usize][side][0] == self.stamps[side]
    }

    /// Whether the vertex of `side` is on the boundary: some edge of it is in exactly one
    /// alive face.
    fn on_boundary(&self, side: usize) -> bool {
        self.lists[side]
            .iter()
            .any(|(_, on_edge)| on_edge.count == 1)
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

/// The alive faces on an edge: the first two in face order and how many there are (a manifold
/// edge has one or two; an edge on more never collapses).
#[derive(Clone, Copy, Debug, Default)]
struct EdgeFaces {
    first: [u32; 2],
    count: usize,
}

impl EdgeFaces {
    fn push(&mut self, f: u32) {
        if self.count < 2 {
            self.first[self.count] = f;
        }
        self.count += 1;
    }

    /// The first two faces (all of them on a manifold edge).
    fn faces(&self) -> &[u32] {
        &self.first[..self.count.min(2)]
    }
}

/// The UV sides of an edge with one or two faces: `(uv at a, uv at b)` per distinct side.
#[derive(Clone, Copy, Debug, Default)]
struct UvSides {
    sides: [(u32, u32); 2],
    len: usize,
}

impl UvSides {
    fn push(&mut self, side: (u32, u32)) {
        self.sides[self.len] = side;
        self.len += 1;
    }

    fn pairs(&self) -> &[(u32, u32)] {
        &self.sides[..self.len]
    }
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
    /// The alive faces of each vertex, sorted (in face order), in one arena ([`Lists`]).
    vertex_faces: Lists,
    /// The distinct UV indices (wedges) of each vertex over its alive faces, sorted; kept up to
    /// date by [`State::collapse`] so that [`State::wedges_covered`] costs O(wedges), not
    /// O(valence) (empty without UVs).
    wedges: Lists,
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
        let vertex_faces = vertex_face_lists(&faces, n);
        let records = sorted_edge_records(&faces, n);
        let locked = if faces.len() == mesh.faces.len() {
            locked_vertices(&faces, &records, n)
        } else {
            // The input's degenerate faces count in the lock test (they may make an edge
            // non-manifold): their own records.
            locked_vertices(&mesh.faces, &sorted_edge_records(&mesh.faces, n), n)
        };
        let special = special_edges(&faces, &uv_faces, &records);
        drop(records);
        let (skinned, rest, joint_count) = match &input.deformation {
            Deformation::Skinned { joints, .. } => (true, mesh.positions.clone(), joints[0].len()),
            Deformation::Frames { frames } => (false, frames[0].clone(), 0),
        };
        let identities = vec![Matrix4::identity(); joint_count];
        let training_sets: PosePoints = training.iter().map(Vec::as_slice).collect();
        let (quad_mats, quad_positions): (PoseMats, PosePoints) =
            match (&input.deformation, options.method) {
                (Deformation::Skinned { .. }, Method::Rest) => {
                    (vec![identities.clone()], vec![&rest])
                }
                (Deformation::Skinned { joints, .. }, _) => (joints.clone(), training_sets.clone()),
                (Deformation::Frames { .. }, _) => (Vec::new(), training_sets.clone()),
            };
        let quad_poses = quad_positions.len();
        let quadrics = vertex_quadrics(&faces, &special, &quad_positions, options.boundary_weight);
        let (check_mats, check_sets): (PoseMats, PosePoints) = if skinned {
            let Deformation::Skinned { joints, .. } = &input.deformation else {
                unreachable!()
            };
            let mats = std::iter::once(identities)
                .chain(joints.iter().cloned())
                .collect();
            let sets = std::iter::once(&rest[..]).chain(training_sets.iter().copied());
            (mats, sets.collect())
        } else {
            (Vec::new(), training_sets.clone())
        };
        let check_poses = check_sets.len();
        let mut check_pos = vec![Point3::origin(); n * check_poses];
        for (c, set) in check_sets.iter().enumerate() {
            for i in 0..n {
                check_pos[i * check_poses + c] = set[i];
            }
        }
        let weights = match &input.deformation {
            Deformation::Skinned { influences, joints } => {
                // The reduction of a vertex with more than W_max influences uses the training
                // quadrics; the rest-pose method's own quadrics are of the rest pose, so it
                // builds them, only when some vertex needs them.
                let reduces = influences
                    .iter()
                    .any(|list| list.len() > options.cost.max_weights);
                let training_quadrics: Cow<[Quadric]> = if options.method != Method::Rest {
                    Cow::Borrowed(&quadrics)
                } else if reduces {
                    let w = options.boundary_weight;
                    Cow::Owned(vertex_quadrics(&faces, &special, &training_sets, w))
                } else {
                    Cow::Borrowed(&[]) // never read: no vertex is reduced
                };
                start_weights(
                    influences,
                    joints,
                    &rest,
                    &training_quadrics,
                    training.len(),
                    options,
                )
            }
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
            wedges: Lists::empty(n),
            vertex_faces,
            alive: vec![true; n],
            version: vec![0; n],
            locked,
            uvs,
            alive_count: n,
            records: Vec::new(),
            start,
        };
        let mut scratch = Vec::new();
        for v in 0..n {
            state.refresh_wedges(v, &mut scratch);
        }
        state
    }

    /// Prefetch ([`prefetch`]) the per-vertex data a try of edge `(a, b)` reads first.
    fn prefetch_vertices(&self, a: usize, b: usize) {
        for v in [a, b] {
            self.vertex_faces.prefetch_span(v);
            self.wedges.prefetch_span(v);
            prefetch(&self.quadrics[v * self.quad_poses]);
            prefetch(&self.rest[v]);
            prefetch(&self.locked[v]);
        }
    }

    /// Prefetch ([`prefetch`]) the face lists of `a` and `b`.
    fn prefetch_lists(&self, a: usize, b: usize) {
        self.vertex_faces.prefetch_items(a);
        self.vertex_faces.prefetch_items(b);
    }

    /// Prefetch ([`prefetch`]) the faces of `a` and `b`.
    fn prefetch_faces(&self, a: usize, b: usize) {
        for v in [a, b] {
            for &f in self.vertex_faces.get(v) {
                prefetch(&self.faces[f as usize]);
            }
        }
    }

    /// Prefetch ([`prefetch`]) what a try of edge `(a, b)` reads of each face around `a` and
    /// `b` and of its vertices: UV corners, alive flag, positions in the check poses, marks in
    /// `stars`.
    fn prefetch_neighbours(&self, a: usize, b: usize, stars: &Stars) {
        let c = self.check_poses;
        for v in [a, b] {
            for &f in self.vertex_faces.get(v) {
                let f = f as usize;
                if let Some(uv) = self.uv_faces.get(f) {
                    prefetch(uv);
                }
                prefetch(&self.face_alive[f]);
                for x in self.faces[f] {
                    prefetch(&self.check_pos[x as usize * c]);
                    stars.prefetch(x as usize);
                }
            }
        }
    }

    /// Whether `entry` was computed with the endpoints' current versions.
    fn is_current(&self, entry: &Entry) -> bool {
        self.version[entry.a as usize] == entry.version_a
            && self.version[entry.b as usize] == entry.version_b
    }

    /// Every edge of the alive faces with its cost and candidate ([`State::score`], or kept
    /// from the last pass by `reuse`), in blocks of [`BLOCK`] vertices ordered by `(a, b)`,
    /// into `out`; computed in parallel over the blocks, each into its own buffers (`out`'s,
    /// kept from call to call).
    fn scored_edges(&self, reuse: Option<&Reuse>, out: &mut ScoredEdges) {
        let n = self.alive.len();
        out.blocks.resize_with(n.div_ceil(BLOCK), Default::default);
        let costly = self.costly();
        out.blocks
            .par_iter_mut()
            .enumerate()
            .for_each(|(k, block)| {
                let vertices = k * BLOCK..((k + 1) * BLOCK).min(n);
                let mut cursor = 0;
                let mut fan = Vec::new();
                block.entries.clear();
                block.candidates.clear();
                for a in vertices {
                    self.edges_above(a, &mut fan, |b, on_edge| {
                        let kept = reuse.and_then(|r| r.keep(k, &mut cursor, (a, b), costly));
                        let (entry, scored) = kept.unwrap_or_else(|| self.score(a, b, on_edge));
                        block.entries.push(entry);
                        if costly {
                            block.candidates.push(scored);
                        }
                    });
                }
            });
    }

    /// Call `visit(b, faces on (a, b))` for the edges `(a, b)`, `b > a`, of vertex `a` (faces in
    /// face order), in the order of `b`; `fan` is a buffer.
    fn edges_above(
        &self,
        a: usize,
        fan: &mut Vec<(u32, u32)>,
        mut visit: impl FnMut(usize, EdgeFaces),
    ) {
        fan.clear();
        for &f in self.vertex_faces.get(a) {
            fan.extend(
                self.faces[f as usize]
                    .iter()
                    .filter(|&&x| x as usize > a)
                    .map(|&x| (x, f)),
            );
        }
        fan.sort_unstable();
        for run in fan.chunk_by(|x, y| x.0 == y.0) {
            let mut on_edge = EdgeFaces::default();
            for &(_, f) in run {
                on_edge.push(f);
            }
            visit(run[0].0 as usize, on_edge);
        }
    }

    /// Collapse `(a, b)` if it is valid now: the UV mode of now, the candidate (`cached` when
    /// it was computed for that mode with the same endpoints, else evaluated again), the
    /// validity checks. Whether it collapsed.
    fn try_collapse(
        &mut self,
        a: usize,
        b: usize,
        cached: Option<Scored>,
        scratch: &mut Scratch,
    ) -> bool {
        let on_edge = self.faces_on_edge(a, b);
        let Some(mode) = self.uv_mode(a, b, on_edge) else {
            return false;
        };
        let mut candidate = match cached.map(|s| *s) {
            Some((m, c)) if m == mode => c,
            _ => self.evaluate(a, b, mode),
        };
        self.pose(&mut candidate, &mut scratch.posed);
        let Some(uv_plan) = self.valid(a, b, mode, on_edge, &candidate, scratch) else {
            scratch.posed = candidate.posed;
            return false;
        };
        self.collapse(a, b, candidate, uv_plan, scratch);
        true
    }

    /// Whether evaluating an edge is costly: a skinned Full/Mohr cost is an alternating
    /// minimisation (tens of µs), worth forking over the edges around a collapse and keeping
    /// with its queue entry (so that the popped edge is not evaluated again); the rest-pose and
    /// frame costs are a 3×3 solve, cheaper than either.
    fn costly(&self) -> bool {
        self.skinned && self.method != Method::Rest
    }

    /// The queue entry of edge `(a, b)` (with `on_edge` its faces) and, for a costly method, the
    /// candidate its cost comes from; cost ∞ when an endpoint is locked or the UVs forbid the
    /// collapse.
    fn score(&self, a: usize, b: usize, on_edge: EdgeFaces) -> (Entry, Option<Scored>) {
        let mode = if self.locked[a] || self.locked[b] {
            None
        } else {
            self.uv_mode(a, b, on_edge)
        };
        let (cost, scored) = match mode {
            None => (f64::INFINITY, None),
            Some(mode) if self.costly() => {
                let candidate = self.evaluate(a, b, mode);
                (candidate.cost, Some(Box::new((mode, candidate))))
            }
            Some(mode) => (self.cost(a, b, mode), None),
        };
        let ends = (a as u32, b as u32);
        let versions = (self.version[a], self.version[b]);
        (Entry::new(cost, ends, versions), scored)
    }

    /// Re-queue the edges around `a` after a collapse into it (their costs changed), costly
    /// ones evaluated in parallel; the queue order does not depend on the push order
    /// ([`super::queue`]).
    fn requeue_around(&self, a: usize, queue: &mut Queue<Scored>, scratch: &mut Scratch) {
        let stars = &mut scratch.stars;
        stars.gather(0, a, self.vertex_faces.get(a), &self.faces);
        let score = |&(n, on_edge): &(u32, EdgeFaces)| {
            let n = n as usize;
            self.score(a.min(n), a.max(n), on_edge)
        };
        if self.costly() {
            let scored: Vec<(Entry, Option<Scored>)> =
                stars.list(0).par_iter().map(score).collect();
            for (entry, s) in scored {
                queue.push(entry, s);
            }
        } else {
            for edge in stars.list(0) {
                let (entry, s) = score(edge);
                queue.push(entry, s);
            }
        }
    }

    /// The cost of [`State::evaluate`] alone. For the rest-pose method that is the plain QEM
    /// value ([`rest_position`], [`rest_value`]), without choosing the merged vertex's weights.
    fn cost(&self, a: usize, b: usize, mode: Mode) -> f64 {
        if !(self.skinned && self.method == Method::Rest) {
            return self.evaluate(a, b, mode).cost;
        }
        // The rest pose is the only quadric pose.
        let q = self.quadrics[a].add(&self.quadrics[b]);
        let quadrics = std::slice::from_ref(&q);
        let ends = [self.rest[a], self.rest[b]];
        match mode {
            Mode::Free => rest_position(quadrics, ends, self.options.cost.max_condition).1,
            Mode::Keep(k) => rest_value(quadrics, &ends[k]),
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
        if self.quad_poses == 1 {
            // One quadric pose (the rest-pose method, or one frame): no list to allocate.
            let q = self.quadrics[a].add(&self.quadrics[b]);
            self.evaluate_with(a, b, mode, std::slice::from_ref(&q))
        } else {
            self.evaluate_with(a, b, mode, &self.summed_quadrics(a, b))
        }
    }

    /// [`State::evaluate`] with the summed quadrics `Q^j = Q_a^j + Q_b^j`.
    fn evaluate_with(&self, a: usize, b: usize, mode: Mode, quadrics: &[Quadric]) -> Candidate {
        if !self.skinned {
            let c = self.check_poses;
            let ends: Vec<[Point3<f64>; 2]> = (0..c)
                .map(|j| [self.check_pos[a * c + j], self.check_pos[b * c + j]])
                .collect();
            let (posed, cost) = match mode {
                Mode::Free => place_frames(quadrics, &ends, self.options.cost.max_condition),
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
            quadrics,
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
    /// every queued cost; in the memory of `buffer` ([`Scratch::posed`], taken). Frame inputs
    /// already have them.
    fn pose(&self, candidate: &mut Candidate, buffer: &mut Vec<Point3<f64>>) {
        if !self.skinned {
            return;
        }
        let h = candidate.rest.to_homogeneous();
        let mut posed = std::mem::take(buffer);
        posed.clear();
        posed.extend(self.check_mats.iter().map(|mats| {
            let mut sum = nalgebra::Vector4::zeros();
            for (k, w) in candidate.weights.pairs() {
                sum += (mats[k as usize] * h) * w;
            }
            Point3::new(sum.x, sum.y, sum.z)
        }));
        candidate.posed = posed;
    }

    /// Alive faces containing both `a` and `b`, in face order (found in the shorter of the
    /// two face lists).
    fn faces_on_edge(&self, a: usize, b: usize) -> EdgeFaces {
        let (short, other) = if self.vertex_faces.get(a).len() <= self.vertex_faces.get(b).len() {
            (a, b)
        } else {
            (b, a)
        };
        let mut out = EdgeFaces::default();
        for &f in self.vertex_faces.get(short) {
            if self.faces[f as usize].contains(&(other as u32)) {
                out.push(f);
            }
        }
        out
    }

    /// Whether an alive face has exactly the vertices `{x, y, z}`.
    fn has_face(&self, x: usize, y: usize, z: usize) -> bool {
        self.vertex_faces.get(x).iter().any(|&f| {
            let t = self.faces[f as usize];
            t.contains(&(y as u32)) && t.contains(&(z as u32))
        })
    }

    /// The validity checks of the module docs; `Some(UV plan)` when valid.
    fn valid(
        &self,
        a: usize,
        b: usize,
        mode: Mode,
        on_edge: EdgeFaces,
        candidate: &Candidate,
        scratch: &mut Scratch,
    ) -> Option<UvPlan> {
        if self.locked[a] || self.locked[b] || !candidate.cost.is_finite() {
            return None;
        }
        if on_edge.count == 0 || on_edge.count > 2 {
            return None;
        }
        let stars = &mut scratch.stars;
        stars.gather(0, a, self.vertex_faces.get(a), &self.faces);
        stars.gather(1, b, self.vertex_faces.get(b), &self.faces);
        if !self.link_condition(a, b, on_edge.faces(), stars) {
            return None;
        }
        if on_edge.count == 2 && stars.on_boundary(0) && stars.on_boundary(1) {
            return None;
        }
        if !self.flip_free(a, b, candidate) {
            return None;
        }
        Some(self.uv_plan(a, b, mode, on_edge, candidate))
    }

    /// Condition 2 of the module docs, with the stars of `a` (side 0) and `b` (side 1).
    fn link_condition(&self, a: usize, b: usize, on_edge: &[u32], stars: &Stars) -> bool {
        let common = stars
            .list(0)
            .iter()
            .filter(|&&(x, _)| stars.contains(1, x))
            .count();
        if common != on_edge.len() {
            return false;
        }
        let in_both = |o: u32| stars.contains(0, o) && stars.contains(1, o);
        let opposite = |f: u32| -> u32 {
            self.faces[f as usize]
                .iter()
                .copied()
                .find(|&x| x as usize != a && x as usize != b)
                .unwrap_or(a as u32)
        };
        let mut opp = [0; 2];
        for (o, &f) in opp.iter_mut().zip(on_edge) {
            *o = opposite(f);
            if !in_both(*o) {
                return false;
            }
        }
        if let [c, d] = opp[..on_edge.len()] {
            let (c, d) = (c as usize, d as usize);
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
    /// the faces on the edge; `None` when two sides share one end's UV but not the other's,
    /// or when more than two faces are on the edge (such an edge never collapses, [`State::valid`]).
    fn uv_sides(&self, a: usize, b: usize, on_edge: EdgeFaces) -> Option<UvSides> {
        if on_edge.count > 2 {
            return None;
        }
        let mut sides = UvSides::default();
        for &f in on_edge.faces() {
            let side = (self.corner_uv(f, a), self.corner_uv(f, b));
            if sides.pairs().contains(&side) {
                continue;
            }
            if sides.pairs().iter().any(|s| s.0 == side.0 || s.1 == side.1) {
                return None;
            }
            sides.push(side);
        }
        Some(sides)
    }

    /// Whether every UV wedge of `v` appears at `v` on a face of the edge (`end` 0: `v = a`).
    fn wedges_covered(&self, v: usize, sides: &[(u32, u32)], end: usize) -> bool {
        self.wedges.get(v).iter().all(|&u| {
            sides
                .iter()
                .any(|s| if end == 0 { s.0 == u } else { s.1 == u })
        })
    }

    /// Recompute the sorted distinct UV indices of `v` over its alive faces (empty without
    /// UVs); `out` is a buffer.
    fn refresh_wedges(&mut self, v: usize, out: &mut Vec<u32>) {
        if self.uv_faces.is_empty() {
            return;
        }
        out.clear();
        for &f in self.vertex_faces.get(v) {
            insert_sorted(out, self.corner_uv(f, v));
        }
        self.wedges.replace(v, out);
    }

    /// [`State::refresh_wedges`] of `v` after it lost faces: a vertex with one wedge keeps it
    /// while it has faces left (all its faces had that UV), so only one with several wedges (on
    /// a UV seam) or without faces needs its faces scanned again.
    fn wedges_after_losing_faces(&mut self, v: usize, out: &mut Vec<u32>) {
        if self.wedges.get(v).len() == 1 && !self.vertex_faces.get(v).is_empty() {
            return;
        }
        self.refresh_wedges(v, out);
    }

    /// Apply a collapse's UV `map` (old → new index) at the merged vertex `a` of each of its
    /// faces, and recompute its wedges ([`State::refresh_wedges`]) on the way.
    fn remap_uvs(&mut self, a: usize, map: &[(u32, u32)], out: &mut Vec<u32>) {
        if self.uv_faces.is_empty() {
            return;
        }
        out.clear();
        for &f in self.vertex_faces.get(a) {
            let k = self.faces[f as usize]
                .iter()
                .position(|&x| x as usize == a)
                .unwrap_or(0);
            let u = &mut self.uv_faces[f as usize][k];
            if let Some(&(_, new)) = map.iter().find(|m| m.0 == *u) {
                *u = new;
            }
            insert_sorted(out, *u);
        }
        self.wedges.replace(a, out);
    }

    /// Condition 4 of the module docs: how the edge may collapse for the UVs. `Free` when both
    /// endpoints' wedges all touch the edge; `Keep(k)` (a half-edge collapse onto endpoint `k`,
    /// which does not move) when only the other endpoint's do; `None` when neither. `on_edge`:
    /// the faces on the edge ([`State::faces_on_edge`]).
    fn uv_mode(&self, a: usize, b: usize, on_edge: EdgeFaces) -> Option<Mode> {
        if self.uv_faces.is_empty() {
            return Some(Mode::Free);
        }
        let sides = self.uv_sides(a, b, on_edge)?;
        if sides.pairs().is_empty() {
            return None;
        }
        match (
            self.wedges_covered(a, sides.pairs(), 0),
            self.wedges_covered(b, sides.pairs(), 1),
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
    fn uv_plan(
        &self,
        a: usize,
        b: usize,
        mode: Mode,
        on_edge: EdgeFaces,
        candidate: &Candidate,
    ) -> UvPlan {
        let mut plan = UvPlan {
            map: Vec::new(),
            new_uvs: Vec::new(),
        };
        if self.uv_faces.is_empty() {
            return plan;
        }
        let sides = self.uv_sides(a, b, on_edge).unwrap_or_default();
        // Allocated at their final lengths (they go into the record as they are).
        let n = sides.pairs().len();
        if let Mode::Keep(k) = mode {
            plan.map.reserve_exact(n);
            for &(ua, ub) in sides.pairs() {
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
        plan.map.reserve_exact(2 * n);
        plan.new_uvs.reserve_exact(n);
        for (k, &(ua, ub)) in sides.pairs().iter().enumerate() {
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
            for &f in self.vertex_faces.get(v) {
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
    fn collapse(
        &mut self,
        a: usize,
        b: usize,
        candidate: Candidate,
        plan: UvPlan,
        scratch: &mut Scratch,
    ) {
        let c = self.check_poses;
        let p = self.quad_poses;
        self.rest[a] = candidate.rest;
        self.weights[a] = candidate.weights;
        self.check_pos[a * c..(a + 1) * c].copy_from_slice(&candidate.posed);
        for j in 0..p {
            let qb = self.quadrics[b * p + j];
            self.quadrics[a * p + j].add_assign(&qb);
        }
        // `a` keeps its alive faces and takes `b`'s others; the faces on the edge die.
        let opposite = &mut scratch.opposite;
        opposite.clear();
        for &f in self.vertex_faces.get(b) {
            let t = &mut self.faces[f as usize];
            if t.contains(&(a as u32)) {
                self.face_alive[f as usize] = false;
                opposite.extend(
                    t.iter()
                        .copied()
                        .filter(|&x| x as usize != a && x as usize != b),
                );
            } else {
                for x in t.iter_mut() {
                    if *x as usize == b {
                        *x = a as u32;
                    }
                }
            }
        }
        let alive = |f: &&u32| self.face_alive[**f as usize];
        merge_sorted(
            self.vertex_faces.get(a).iter().filter(alive),
            self.vertex_faces.get(b).iter().filter(alive),
            &mut scratch.faces,
        );
        self.vertex_faces.replace(a, &scratch.faces);
        self.vertex_faces.clear(b);
        self.remap_uvs(a, &plan.map, &mut scratch.faces);
        // The faces on the edge also leave their opposite vertices' lists.
        for &x in opposite.iter() {
            let alive = &self.face_alive;
            self.vertex_faces.retain(x as usize, |f| alive[f as usize]);
        }
        for &x in &scratch.opposite {
            self.wedges_after_losing_faces(x as usize, &mut scratch.faces);
        }
        self.wedges.clear(b);
        self.uvs.extend_from_slice(&plan.new_uvs);
        self.alive[b] = false;
        self.version[a] += 1;
        self.version[b] += 1;
        self.alive_count -= 1;
        let frames = if self.skinned {
            scratch.posed = candidate.posed;
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
