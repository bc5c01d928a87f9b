//! Bridge between the f64 skinsimp reference and the f32 kernels of `reparam-gpu`
//! (`gpu/src/skinsimp/`, SPEC.md § 12):
//!
//! | step | reference (f64) | kernel (f32) |
//! |---|---|---|
//! | linear blend skinning, V × P | [`super::skin`] | `skinsimp_lbs` ([`SkinsimpKernels::skin`]) |
//! | per-pose face quadrics and boundary / seam planes | [`Quadric::from_triangle`], [`edge_constraint`] ([`plane_quadrics_f64`]) | `skinsimp_plane_quadrics` |
//! | per-vertex sums `Q_i^j` | [`vertex_quadrics_f64`] (the order of `collapse.rs`'s `vertex_quadrics`) | `skinsimp_vertex_quadrics` |
//! | per candidate (edge, endpoint weights): `Q̃`, position step, `E(v̂, α)` | [`position_quadric`], [`position_step`], [`energy`] ([`position_given_weights_f64`]) | `skinsimp_collapse_cost` ([`SkinsimpKernels::costs`]) |
//!
//! The candidates are those of the Mohr–Gleicher placement and of the full method's start
//! (`endpoint_start` in `cost.rs`): every edge `(a, b)` of the mesh with, in turn, `a`'s and
//! `b`'s weights as `α` over the union of their bones. The weight QP and the alternation stay
//! on the CPU.
//!
//! **Protocol** ([`crosscheck`]): the model is first normalised to a unit box ([`normalise`]:
//! `v ↦ s(v − min)`, joint matrices `T M T⁻¹`), since `v̂ᵀQv̂` cancels badly in f32 far from
//! the origin. Then each step runs on both sides from identical f32-rounded inputs: the
//! rounded model ([`round_input`]) for skinning; the reference's posed positions rounded for the
//! quadrics; the reference's vertex quadrics rounded for the costs. So each summary measures one
//! kernel's f32 arithmetic. Costs and positions are compared only on edges with
//! `cond_F(Q̃[0:3,0:3]) ≤ 10⁴` ([`SKIP_CONDITION`]); collapse orders are never compared.
//!
//! Limits of the GPU path (typed errors): skinned input only, at most 4 influences per vertex,
//! affine joint matrices, a consistently oriented 2-manifold without degenerate faces (its
//! boundary and seam edges come from [`Adjacency`]: a seam is an edge whose two faces have
//! different UV values at an end, where the simplifier compares UV indices — the same on
//! meshes without duplicated UV values, such as [`super::tube`]).

// `!(e <= tolerance)` is meant: a NaN error counts as over any tolerance.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{Matrix3, Matrix4, Point3, Vector3};
use rayon::prelude::*;
use reparam_gpu::skinsimp::{
    CollapseCostKernel, CostInput, EdgeCost, EdgeItem, Influences, JointMatrix, LbsInput,
    LbsKernel, PlaneSource, QuadricF32, QuadricInput, QuadricKernel, MAX_CANDIDATES, SOURCE_FACE,
};
use reparam_gpu::Gpu;
use serde::Serialize;

use super::cost::{
    energy, position_quadric, position_step, solve_position, Candidates, EdgeProblem,
};
use super::quadric::{edge_constraint, unit_normal, Quadric};
use super::weights::Weights;
use super::{skin, Deformation, Input};
use crate::crosscheck::ErrorSummary;
use crate::error::{Error, Result};
use crate::mesh::{Adjacency, EdgeKind, TriMesh, EDGE_CORNERS};

/// Costs and positions are compared only where `cond_F(Q̃[0:3,0:3]) ≤ SKIP_CONDITION` (SPEC.md § 12).
pub const SKIP_CONDITION: f64 = 1e4;
/// Per-edge cost tolerance (SPEC.md § 12): `|ΔE| ≤ max(COST_RELATIVE · |E|, COST_ABSOLUTE)`.
pub const COST_RELATIVE: f64 = 1e-4;
pub const COST_ABSOLUTE: f64 = 1e-7;
/// Position tolerance (SPEC.md § 12), as a fraction of the (unit) box.
pub const POSITION_TOLERANCE: f64 = 1e-5;
/// Tolerance of the quadric summaries, relative to the quadric's largest entry. A plane quadric
/// `w q qᵀ` computed in f32 from f32 corners errs by ≲ (7κ + 10) u · w |q|² (κ = |e1||e2| /
/// |e1 × e2| the triangle's conditioning; derivation in `tests/gpu_skinsimp.rs`,
/// `source_bound`), and a vertex sum of n of them adds n u: 1e-5 ≈ 170 u holds for κ up to
/// ≈ 20 (angles down to ≈ 3°) and n ≲ 30 sources, every mesh used here.
pub const QUADRIC_TOLERANCE: f64 = 1e-5;

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

fn invalid(message: String) -> Error {
    Error::InvalidArgument(format!("skinsimp GPU: {message}"))
}

/// A GPU context ([`Error::Gpu`] when there is no adapter).
pub fn context() -> Result<Gpu> {
    Gpu::new().map_err(gpu_error)
}

/// The similarity `T: x ↦ s (x − min)` that maps a bounding box into the unit box (its
/// longest side to length 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitBox {
    pub min: Vector3<f64>,
    pub scale: f64,
}

impl UnitBox {
    /// The box of `points`: `min` the lower corner, `s = 1 / (longest side)` (1 for a single
    /// point or none).
    pub fn of(points: &[Point3<f64>]) -> UnitBox {
        let Some(first) = points.first() else {
            return UnitBox {
                min: Vector3::zeros(),
                scale: 1.0,
            };
        };
        let (mut lo, mut hi) = (first.coords, first.coords);
        for p in points {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
        let side = (hi - lo).max();
        UnitBox {
            min: lo,
            scale: if side > 0.0 { 1.0 / side } else { 1.0 },
        }
    }

    /// `T(p) = s (p − min)`.
    pub fn apply(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from((p.coords - self.min) * self.scale)
    }

    /// `T` as a homogeneous matrix.
    pub fn matrix(&self) -> Matrix4<f64> {
        Matrix4::new_scaling(self.scale) * Matrix4::new_translation(&-self.min)
    }

    /// `T⁻¹(x) = x / s + min`.
    pub fn inverse_matrix(&self) -> Matrix4<f64> {
        Matrix4::new_translation(&self.min) * Matrix4::new_scaling(1.0 / self.scale)
    }
}

/// `input` in the unit box of its rest positions: rest `T v`, joint matrices `T M T⁻¹` (so
/// that posed positions become `T p`), frames `T p`. Also returns `T`.
pub fn normalise(input: &Input) -> (Input, UnitBox) {
    let t = UnitBox::of(&input.mesh.positions);
    let mut out = input.clone();
    out.mesh.positions.iter_mut().for_each(|p| *p = t.apply(p));
    match &mut out.deformation {
        Deformation::Skinned { joints, .. } => {
            let (m, inv) = (t.matrix(), t.inverse_matrix());
            for pose in joints.iter_mut() {
                pose.iter_mut().for_each(|x| *x = m * *x * inv);
            }
        }
        Deformation::Frames { frames } => {
            for f in frames.iter_mut() {
                f.iter_mut().for_each(|p| *p = t.apply(p));
            }
        }
    }
    (out, t)
}

fn round(x: f64) -> f64 {
    x as f32 as f64
}

fn round_point(p: &Point3<f64>) -> Point3<f64> {
    p.map(round)
}

/// `input` with every number the kernels read rounded to f32: rest positions, weights, the top
/// three rows of the joint matrices (frames too). The reference run on this sees what the GPU
/// sees.
pub fn round_input(input: &Input) -> Input {
    let mut out = input.clone();
    out.mesh
        .positions
        .iter_mut()
        .for_each(|p| *p = round_point(p));
    match &mut out.deformation {
        Deformation::Skinned { influences, joints } => {
            for list in influences.iter_mut() {
                list.iter_mut().for_each(|p| p.1 = round(p.1));
            }
            for m in joints.iter_mut().flatten() {
                for r in 0..3 {
                    for c in 0..4 {
                        m[(r, c)] = round(m[(r, c)]);
                    }
                }
            }
        }
        Deformation::Frames { frames } => {
            for p in frames.iter_mut().flatten() {
                *p = round_point(p);
            }
        }
    }
    out
}

fn point_f32(p: &Point3<f64>) -> [f32; 3] {
    [p.x as f32, p.y as f32, p.z as f32]
}

fn point_f64(p: &[f32; 3]) -> Point3<f64> {
    Point3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// The top three rows of an affine `M`, row-major, in f32; an error unless the last row is
/// exactly `(0, 0, 0, 1)`.
pub fn joint_matrix_f32(m: &Matrix4<f64>) -> Result<JointMatrix> {
    if m.row(3).iter().ne([0.0, 0.0, 0.0, 1.0].iter()) {
        return Err(invalid(format!(
            "joint matrix with last row {:?} is not affine",
            m.row(3).iter().collect::<Vec<_>>()
        )));
    }
    let mut out = [0.0f32; 12];
    for r in 0..3 {
        for c in 0..4 {
            out[4 * r + c] = m[(r, c)] as f32;
        }
    }
    Ok(out)
}

/// Per vertex `(joint, weight)` lists and `[pose][joint]` matrices of a skinned input.
type Skin<'a> = (&'a [Vec<(u32, f64)>], &'a [Vec<Matrix4<f64>>]);

/// The influences and joint matrices of a skinned input; errors for frame sequences.
fn skinned(input: &Input) -> Result<Skin<'_>> {
    match &input.deformation {
        Deformation::Skinned { influences, joints } => Ok((influences, joints)),
        Deformation::Frames { .. } => Err(invalid(format!(
            "{}: the GPU kernels take skinned input, not a frame sequence",
            input.mesh.name
        ))),
    }
}

/// `joints[pose · J + joint]` in f32.
fn joints_f32(joints: &[Vec<Matrix4<f64>>]) -> Result<Vec<JointMatrix>> {
    joints.iter().flatten().map(joint_matrix_f32).collect()
}

/// The `skinsimp_lbs` input of a skinned `input`: rest positions, weights (≤ 4 per vertex,
/// else an error naming the vertex) and joint matrices in f32.
pub fn lbs_input(input: &Input) -> Result<LbsInput> {
    input.validate()?;
    let (influences, joints) = skinned(input)?;
    let influences = influences
        .iter()
        .enumerate()
        .map(|(i, list)| {
            if list.len() > 4 {
                return Err(invalid(format!(
                    "{}: vertex {i} has {} influences, the GPU kernels take at most 4",
                    input.mesh.name,
                    list.len()
                )));
            }
            let mut inf = Influences::default();
            for (k, &(j, w)) in list.iter().enumerate() {
                inf.joints[k] = j;
                inf.weights[k] = w as f32;
            }
            Ok(inf)
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(LbsInput {
        rest: input.mesh.positions.iter().map(point_f32).collect(),
        influences,
        joint_count: joints[0].len() as u32,
        joints: joints_f32(joints)?,
    })
}

/// The reference's posed positions of every training pose, at index `i · P + j` (the kernels'
/// layout).
pub fn skin_f64(input: &Input) -> Result<Vec<Point3<f64>>> {
    let (influences, joints) = skinned(input)?;
    let per_pose: Vec<Vec<Point3<f64>>> = joints
        .par_iter()
        .map(|m| skin(&input.mesh.positions, influences, m))
        .collect();
    Ok(interleave(&per_pose))
}

/// `[pose][vertex]` → index `vertex · P + pose`.
fn interleave<T: Copy>(per_pose: &[Vec<T>]) -> Vec<T> {
    let p = per_pose.len();
    let n = per_pose.first().map_or(0, Vec::len);
    (0..n * p).map(|x| per_pose[x % p][x / p]).collect()
}

/// The quadric sources of `mesh` and the per-vertex CSR lists in the order in which the
/// simplifier sums them (`vertex_quadrics` of `collapse.rs`): per face in face order, its face
/// quadric `K_f` to its three vertices, then the constraint plane of each of its boundary or
/// seam edges (local edge order) to the edge's two vertices. Sources: the F faces (id f), then
/// the constraint edges in (face, edge) order (id F + s).
pub fn quadric_input(
    mesh: &TriMesh,
    pose_count: usize,
    boundary_weight: f64,
) -> Result<QuadricInput> {
    let adjacency = Adjacency::new(mesh);
    if adjacency.non_manifold_edges + adjacency.misoriented_edges > 0 {
        return Err(invalid(format!(
            "{}: {} non-manifold and {} misoriented edges; the GPU quadrics need an oriented 2-manifold",
            mesh.name, adjacency.non_manifold_edges, adjacency.misoriented_edges
        )));
    }
    if let Some(f) = mesh
        .faces
        .iter()
        .position(|[x, y, z]| x == y || y == z || z == x)
    {
        return Err(invalid(format!(
            "{}: face {f} repeats a vertex; the GPU quadrics need faces of three distinct vertices",
            mesh.name
        )));
    }
    let n = mesh.positions.len();
    let faces = mesh.faces.len();
    let mut sources: Vec<PlaneSource> = mesh
        .faces
        .iter()
        .map(|&corners| PlaneSource {
            corners,
            kind: SOURCE_FACE,
        })
        .collect();
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (f, t) in mesh.faces.iter().enumerate() {
        for &v in t {
            lists[v as usize].push(f as u32);
        }
        for (e, kind) in adjacency.edges[f].iter().enumerate() {
            if matches!(kind, EdgeKind::Boundary | EdgeKind::Seam { .. }) {
                let id = sources.len() as u32;
                sources.push(PlaneSource {
                    corners: *t,
                    kind: e as u32,
                });
                for c in EDGE_CORNERS[e] {
                    lists[t[c] as usize].push(id);
                }
            }
        }
    }
    debug_assert!(sources.len() >= faces);
    let mut vertex_offsets = Vec::with_capacity(n + 1);
    vertex_offsets.push(0u32);
    let mut vertex_sources = Vec::new();
    for list in &lists {
        vertex_sources.extend_from_slice(list);
        vertex_offsets.push(vertex_sources.len() as u32);
    }
    Ok(QuadricInput {
        vertex_count: n as u32,
        pose_count: pose_count as u32,
        sources,
        vertex_offsets,
        vertex_sources,
        boundary_weight: boundary_weight as f32,
    })
}

/// The reference's source quadrics (index `source · P + pose`) of posed positions `posed`
/// (index `vertex · P + pose`): [`Quadric::from_triangle`] for a face,
/// [`edge_constraint`] with the face's [`unit_normal`] for a constraint edge.
pub fn plane_quadrics_f64(
    posed: &[Point3<f64>],
    input: &QuadricInput,
    boundary_weight: f64,
) -> Vec<Quadric> {
    let p = input.pose_count as usize;
    (0..input.sources.len() * p)
        .into_par_iter()
        .map(|x| {
            let (s, j) = (input.sources[x / p], x % p);
            let [p0, p1, p2] = s.corners.map(|c| posed[c as usize * p + j]);
            if s.kind == SOURCE_FACE {
                Quadric::from_triangle(&p0, &p1, &p2)
            } else {
                let corners = [p0, p1, p2];
                let [i, k] = EDGE_CORNERS[s.kind as usize];
                let normal = unit_normal(&p0, &p1, &p2);
                edge_constraint(&corners[i], &corners[k], &normal, boundary_weight)
            }
        })
        .collect()
}

/// `Q_i^j` = the sum of vertex `i`'s sources in CSR order, from zero (index `i · P + j`).
pub fn vertex_quadrics_f64(plane: &[Quadric], input: &QuadricInput) -> Vec<Quadric> {
    let p = input.pose_count as usize;
    (0..input.vertex_count as usize * p)
        .into_par_iter()
        .map(|x| {
            let (i, j) = (x / p, x % p);
            let range = input.vertex_offsets[i] as usize..input.vertex_offsets[i + 1] as usize;
            let mut q = Quadric::default();
            for &s in &input.vertex_sources[range] {
                q.add_assign(&plane[s as usize * p + j]);
            }
            q
        })
        .collect()
}

fn quadric_f32(q: &Quadric) -> QuadricF32 {
    q.0.map(|x| x as f32)
}

fn quadric_f64(q: &QuadricF32) -> Quadric {
    Quadric(q.map(|x| x as f64))
}

/// One candidate of the position step: edge `(a, b)` (`a < b`) with the weights of endpoint
/// `endpoint` (0: a, 1: b) as `α`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeCandidate {
    pub a: u32,
    pub b: u32,
    pub endpoint: u8,
}

/// Every edge of `mesh` (sorted by `(min, max)`, as the simplifier's initial queue), each with
/// `a`'s then `b`'s weights.
pub fn endpoint_candidates(mesh: &TriMesh) -> Vec<EdgeCandidate> {
    let mut edges: Vec<(u32, u32)> = mesh
        .faces
        .iter()
        .flat_map(|t| EDGE_CORNERS.map(|[i, j]| (t[i].min(t[j]), t[i].max(t[j]))))
        .collect();
    edges.sort_unstable();
    edges.dedup();
    edges
        .into_iter()
        .flat_map(|(a, b)| [0, 1].map(|endpoint| EdgeCandidate { a, b, endpoint }))
        .collect()
}

/// What the position step reads, in f64 (for the reference) — the kernel gets it rounded by
/// [`CostData::cost_input`].
#[derive(Clone, Debug)]
pub struct CostData {
    pub rest: Vec<Point3<f64>>,
    pub weights: Vec<Weights>,
    /// `mats[pose][joint]`.
    pub mats: Vec<Vec<Matrix4<f64>>>,
    /// `Q_i^j` at `i · P + j`.
    pub vertex_quadrics: Vec<Quadric>,
}

impl CostData {
    /// From a skinned `input` (≤ 4 influences per vertex) and its vertex quadrics.
    pub fn new(input: &Input, vertex_quadrics: Vec<Quadric>) -> Result<CostData> {
        let (influences, joints) = skinned(input)?;
        if let Some(i) = influences.iter().position(|l| l.len() > 4) {
            return Err(invalid(format!(
                "{}: vertex {i} has more than 4 influences",
                input.mesh.name
            )));
        }
        Ok(CostData {
            rest: input.mesh.positions.clone(),
            weights: influences.iter().map(|l| Weights::from_pairs(l)).collect(),
            mats: joints.to_vec(),
            vertex_quadrics,
        })
    }

    fn pose_count(&self) -> usize {
        self.mats.len()
    }

    /// The same data with the vertex quadrics rounded to f32 (identical inputs for both sides).
    pub fn rounded_quadrics(&self) -> CostData {
        CostData {
            vertex_quadrics: self
                .vertex_quadrics
                .iter()
                .map(|q| quadric_f64(&quadric_f32(q)))
                .collect(),
            ..self.clone()
        }
    }

    /// `[Q_a^j + Q_b^j]_j`, the edge problem, and `α` of the candidate over its bones.
    fn problem<'a>(&'a self, c: &EdgeCandidate, summed: &'a [Quadric]) -> EdgeProblem<'a> {
        let (a, b) = (c.a as usize, c.b as usize);
        EdgeProblem {
            quadrics: summed,
            mats: &self.mats,
            ends: [self.rest[a], self.rest[b]],
            weights: [self.weights[a], self.weights[b]],
        }
    }

    fn summed(&self, c: &EdgeCandidate) -> Vec<Quadric> {
        let p = self.pose_count();
        let (a, b) = (c.a as usize, c.b as usize);
        (0..p)
            .map(|j| self.vertex_quadrics[a * p + j].add(&self.vertex_quadrics[b * p + j]))
            .collect()
    }

    /// The kernel's items of `candidates`: bones = the union of the endpoints' joints
    /// ([`Candidates::of`]), `α` = the endpoint's weights over them, in f32.
    pub fn edge_items(&self, candidates: &[EdgeCandidate]) -> Result<Vec<EdgeItem>> {
        candidates
            .iter()
            .map(|c| {
                let summed = Vec::new();
                let problem = EdgeProblem {
                    mats: &[],
                    ..self.problem(c, &summed)
                };
                let cand = Candidates::of(&problem);
                if cand.joints.len() > MAX_CANDIDATES {
                    return Err(invalid(format!(
                        "edge ({}, {}) has {} candidate bones, the kernel takes {MAX_CANDIDATES}",
                        c.a,
                        c.b,
                        cand.joints.len()
                    )));
                }
                let alpha = cand.vector(&problem.weights[c.endpoint as usize]);
                let mut item = EdgeItem {
                    a: c.a,
                    b: c.b,
                    candidates: cand.joints.len() as u32,
                    ..EdgeItem::default()
                };
                for (k, (&j, &w)) in cand.joints.iter().zip(&alpha).enumerate() {
                    item.joints[k] = j;
                    item.alpha[k] = w as f32;
                }
                Ok(item)
            })
            .collect()
    }

    /// The kernel's input (everything rounded to f32).
    pub fn cost_input(&self, max_condition: f64) -> Result<CostInput> {
        Ok(CostInput {
            rest: self.rest.iter().map(point_f32).collect(),
            pose_count: self.pose_count() as u32,
            joint_count: self.mats.first().map_or(0, Vec::len) as u32,
            joints: joints_f32(&self.mats)?,
            vertex_quadrics: self.vertex_quadrics.iter().map(quadric_f32).collect(),
            max_condition: max_condition as f32,
        })
    }
}

/// `‖B‖_F ‖B⁻¹‖_F` of `B = q[0:3,0:3]` (∞ when singular), as [`solve_position`] measures it.
pub fn position_condition(q: &Matrix4<f64>) -> f64 {
    let a: Matrix3<f64> = q.fixed_view::<3, 3>(0, 0).into_owned();
    a.try_inverse()
        .map_or(f64::INFINITY, |inv| a.norm() * inv.norm())
}

/// The reference's result for one candidate (the twin of [`EdgeCost`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceCost {
    /// `Q̃` ([`position_quadric`]).
    pub quadric: Matrix4<f64>,
    /// [`position_condition`] of `Q̃`.
    pub condition: f64,
    /// [`position_step`] with the fallbacks a, b, midpoint: the point and `v̂ᵀQ̃v̂`.
    pub position: Point3<f64>,
    pub value: f64,
    /// `E(v̂, α)` ([`energy`]).
    pub cost: f64,
    /// 0 the solution, 1 a, 2 b, 3 the midpoint.
    pub choice: u32,
}

/// The reference's position step and cost for one candidate, as `endpoint_start` in `cost.rs`
/// does them, with the per-pose definitions the kernel mirrors: `Q̃ =` [`position_quadric`],
/// [`position_step`]`(Q̃, [a, b, mid])`, `E =` [`energy`]. (The simplifier evaluates the same
/// `Q̃` and `E` through `cost::PoseGram`, `Σ_kl α_k α_l G_kl`: equal in exact arithmetic,
/// summed in another order.)
pub fn position_given_weights_f64(
    data: &CostData,
    c: &EdgeCandidate,
    max_condition: f64,
) -> ReferenceCost {
    let summed = data.summed(c);
    let problem = data.problem(c, &summed);
    let cand = Candidates::of(&problem);
    let alpha = cand.vector(&problem.weights[c.endpoint as usize]);
    let q = position_quadric(&summed, &cand, &alpha);
    let [a, b] = problem.ends;
    let fallbacks = [a, b, Point3::from((a.coords + b.coords) * 0.5)];
    let (position, value) = position_step(&q, &fallbacks, max_condition);
    let choice = if solve_position(&q, max_condition) == Some(position) {
        0
    } else {
        1 + fallbacks.iter().position(|f| *f == position).unwrap_or(0) as u32
    };
    ReferenceCost {
        quadric: q,
        condition: position_condition(&q),
        position,
        value,
        cost: energy(&summed, &cand, &position, &alpha),
        choice,
    }
}

/// `Q̃` of a kernel result as a matrix.
pub fn edge_cost_quadric(r: &EdgeCost) -> Matrix4<f64> {
    quadric_f64(&r.quadric).matrix()
}

/// The GPU result's position in f64.
pub fn edge_cost_position(r: &EdgeCost) -> Point3<f64> {
    point_f64(&r.position)
}

/// The three compiled kernels on one device.
pub struct SkinsimpKernels {
    pub gpu: Gpu,
    lbs: LbsKernel,
    quadrics: QuadricKernel,
    cost: CollapseCostKernel,
}

impl SkinsimpKernels {
    /// Compile the kernels on `gpu`.
    pub fn new(gpu: Gpu) -> Result<SkinsimpKernels> {
        Ok(SkinsimpKernels {
            lbs: LbsKernel::new(&gpu).map_err(gpu_error)?,
            quadrics: QuadricKernel::new(&gpu).map_err(gpu_error)?,
            cost: CollapseCostKernel::new(&gpu).map_err(gpu_error)?,
            gpu,
        })
    }

    /// Posed positions of every training pose on the GPU, index `i · P + j`.
    pub fn skin(&self, input: &Input) -> Result<Vec<Point3<f64>>> {
        let lbs = lbs_input(input)?;
        let out = self.lbs.skin(&self.gpu, &lbs).map_err(gpu_error)?;
        Ok(out.iter().map(point_f64).collect())
    }

    /// Source and vertex quadrics on the GPU from `posed` (index `i · P + j`, rounded to f32).
    pub fn quadrics(
        &self,
        input: &QuadricInput,
        posed: &[Point3<f64>],
    ) -> Result<(Vec<Quadric>, Vec<Quadric>)> {
        let posed: Vec<[f32; 3]> = posed.iter().map(point_f32).collect();
        let (plane, vertex) = self
            .quadrics
            .quadrics(&self.gpu, input, &posed)
            .map_err(gpu_error)?;
        Ok((
            plane.iter().map(quadric_f64).collect(),
            vertex.iter().map(quadric_f64).collect(),
        ))
    }

    /// The position step and cost of every candidate on the GPU.
    pub fn costs(
        &self,
        data: &CostData,
        candidates: &[EdgeCandidate],
        max_condition: f64,
    ) -> Result<Vec<EdgeCost>> {
        let input = data.cost_input(max_condition)?;
        let items = data.edge_items(candidates)?;
        self.cost
            .position_given_weights(&self.gpu, &input, &items)
            .map_err(gpu_error)
    }
}

/// Every result of [`crosscheck`], reference and GPU side by side, for tests that apply their
/// own per-element bounds.
pub struct CrossCheckData {
    /// The normalised model rounded to f32 (the inputs of the skinning step).
    pub input: Input,
    /// Posed positions, index `i · P + j`: reference on `input`, GPU.
    pub posed_ref: Vec<Point3<f64>>,
    pub posed_gpu: Vec<Point3<f64>>,
    /// The quadric step's inputs: `posed_ref` rounded to f32, and the sources.
    pub posed_rounded: Vec<Point3<f64>>,
    pub sources: QuadricInput,
    /// Source quadrics (index `s · P + j`) and vertex quadrics (`i · P + j`).
    pub plane_ref: Vec<Quadric>,
    pub plane_gpu: Vec<Quadric>,
    pub vertex_ref: Vec<Quadric>,
    pub vertex_gpu: Vec<Quadric>,
    /// The cost step's inputs (`vertex_ref` rounded to f32), candidates and results.
    pub cost_data: CostData,
    pub candidates: Vec<EdgeCandidate>,
    pub costs_ref: Vec<ReferenceCost>,
    pub costs_gpu: Vec<EdgeCost>,
}

/// Aggregate figures of one cross-check (module docs, "Protocol").
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CrossCheck {
    pub mesh: String,
    pub vertices: usize,
    pub faces: usize,
    pub poses: usize,
    /// Posed positions, in units of the box; tolerance [`POSITION_TOLERANCE`].
    pub lbs: ErrorSummary,
    /// Per source quadric, max entry error / max |entry| of the reference; tolerance
    /// [`QUADRIC_TOLERANCE`].
    pub plane_quadrics: ErrorSummary,
    /// Per vertex quadric, the same measure.
    pub vertex_quadrics: ErrorSummary,
    /// Candidates (edge, endpoint weights) and how many had `cond > SKIP_CONDITION`.
    pub candidates: usize,
    pub skipped_ill_conditioned: usize,
    /// Compared candidates where the GPU kept another point (solution / a / b / midpoint):
    /// left out of `positions`.
    pub choice_mismatches: usize,
    /// Chosen positions where both chose the same point, in units of the box; tolerance
    /// [`POSITION_TOLERANCE`].
    pub positions: ErrorSummary,
    /// `|ΔE| / max(COST_RELATIVE · |E|, COST_ABSOLUTE)`; tolerance 1.
    pub costs: ErrorSummary,
}

impl CrossCheck {
    /// The same figures rounded to `digits` significant digits.
    pub fn rounded(&self, digits: u32) -> CrossCheck {
        CrossCheck {
            lbs: self.lbs.rounded(digits),
            plane_quadrics: self.plane_quadrics.rounded(digits),
            vertex_quadrics: self.vertex_quadrics.rounded(digits),
            positions: self.positions.rounded(digits),
            costs: self.costs.rounded(digits),
            ..self.clone()
        }
    }
}

/// Max entry error and max |entry| of the reference, per quadric.
fn quadric_errors(reference: &[Quadric], gpu: &[Quadric]) -> (Vec<f64>, Vec<f64>) {
    reference
        .iter()
        .zip(gpu)
        .map(|(r, g)| {
            let error =
                r.0.iter()
                    .zip(&g.0)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
            let size = r.0.iter().map(|x| x.abs()).fold(0.0, f64::max);
            (error, size)
        })
        .unzip()
}

/// Relative quadric errors (error / size; 0 for a zero reference quadric matched exactly).
fn relative(errors: &[f64], sizes: &[f64]) -> Vec<f64> {
    errors
        .iter()
        .zip(sizes)
        .map(|(&e, &s)| if e == 0.0 { 0.0 } else { e / s })
        .collect()
}

/// Run every kernel on the GPU and its reference from identical inputs (module docs,
/// "Protocol") on the unit-box normalised `input`, with the constraint-plane weight
/// `boundary_weight` and the position step's `max_condition`.
/// The largest posed coordinate (in the unit box of the rest pose) the f32 skinsimp kernels
/// are cross-checked on: 2¹⁶. With |x| ≤ 2¹⁶ a source quadric's weight (an area) is ≤ 2³³ and
/// its plane's d² ≤ 3·2³², so its entries are ≤ 2⁶⁷; a vertex quadric sums ≤ 2¹⁴ of them, and a
/// cost v̂ᵀQv̂ with |v̂|² ≤ 2³⁴ stays ≤ 2¹¹⁹ < f32::MAX ≈ 2¹²⁸. The quadrics are quartic and the
/// costs sextic in the coordinates, so the meshes' bound ±2⁴⁸
/// ([`crate::crosscheck::F32_COORDINATE_MAX`]) would let them overflow.
pub const POSED_COORDINATE_MAX: f64 = 65_536.0;

/// Refuse posed positions beyond ±[`POSED_COORDINATE_MAX`]: an animation that throws vertices
/// that far makes the f32 quadrics or costs overflow, and the comparison would measure
/// overflow, not arithmetic. The error names the vertex and the pose.
fn check_posed_range(input: &Input, posed: &[Point3<f64>]) -> Result<()> {
    let poses = input.pose_count().max(1);
    crate::crosscheck::check_range(posed, POSED_COORDINATE_MAX, |i| {
        (
            format!("{}, training pose {} (skinned)", input.mesh.name, i % poses),
            i / poses,
        )
    })
}

pub fn crosscheck(
    kernels: &SkinsimpKernels,
    input: &Input,
    boundary_weight: f64,
    max_condition: f64,
) -> Result<(CrossCheck, CrossCheckData)> {
    input.validate()?;
    let rounded = round_input(&normalise(input).0);
    let poses = rounded.pose_count();
    // 1. Skinning.
    let posed_ref = skin_f64(&rounded)?;
    check_posed_range(&rounded, &posed_ref)?;
    let posed_gpu = kernels.skin(&rounded)?;
    // 2. Quadrics from the reference's posed positions rounded to f32.
    let posed_rounded: Vec<Point3<f64>> = posed_ref.iter().map(round_point).collect();
    let sources = quadric_input(&rounded.mesh, poses, boundary_weight)?;
    let weight = sources.boundary_weight as f64;
    let plane_ref = plane_quadrics_f64(&posed_rounded, &sources, weight);
    let vertex_ref = vertex_quadrics_f64(&plane_ref, &sources);
    let (plane_gpu, vertex_gpu) = kernels.quadrics(&sources, &posed_rounded)?;
    // 3. Costs from the reference's vertex quadrics rounded to f32.
    let cost_data = CostData::new(&rounded, vertex_ref.clone())?.rounded_quadrics();
    let candidates = endpoint_candidates(&rounded.mesh);
    let costs_ref: Vec<ReferenceCost> = candidates
        .par_iter()
        .map(|c| position_given_weights_f64(&cost_data, c, max_condition))
        .collect();
    let costs_gpu = kernels.costs(&cost_data, &candidates, max_condition)?;
    let data = CrossCheckData {
        input: rounded,
        posed_ref,
        posed_gpu,
        posed_rounded,
        sources,
        plane_ref,
        plane_gpu,
        vertex_ref,
        vertex_gpu,
        cost_data,
        candidates,
        costs_ref,
        costs_gpu,
    };
    Ok((summarise(&data), data))
}

/// The aggregate figures of [`crosscheck`]'s data.
pub fn summarise(data: &CrossCheckData) -> CrossCheck {
    let box_unit = "unit box";
    let lbs_errors: Vec<f64> = data
        .posed_ref
        .iter()
        .zip(&data.posed_gpu)
        .map(|(r, g)| (r - g).norm())
        .collect();
    let lbs_sizes: Vec<f64> = data.posed_ref.iter().map(|p| p.coords.norm()).collect();
    let (pe, ps) = quadric_errors(&data.plane_ref, &data.plane_gpu);
    let (ve, vs) = quadric_errors(&data.vertex_ref, &data.vertex_gpu);
    let quadric_unit = "max |entry| of the quadric";
    let (mut position_errors, mut position_sizes) = (Vec::new(), Vec::new());
    let (mut cost_errors, mut cost_sizes) = (Vec::new(), Vec::new());
    let (mut skipped, mut mismatches) = (0, 0);
    for (r, g) in data.costs_ref.iter().zip(&data.costs_gpu) {
        if !(r.condition <= SKIP_CONDITION) {
            skipped += 1;
            continue;
        }
        // A different choice (solution / a / b / midpoint) is a near tie of v̂ᵀQ̃v̂ that f32
        // cannot resolve: its positions may be far apart, its costs are still comparable.
        if r.choice == g.choice {
            position_errors.push((r.position - edge_cost_position(g)).norm());
            position_sizes.push(r.position.coords.norm());
        } else {
            mismatches += 1;
        }
        let scale = (COST_RELATIVE * r.cost.abs()).max(COST_ABSOLUTE);
        cost_errors.push((r.cost - g.cost as f64).abs() / scale);
        cost_sizes.push(r.cost.abs() / scale);
    }
    CrossCheck {
        mesh: data.input.mesh.name.clone(),
        vertices: data.input.mesh.positions.len(),
        faces: data.input.mesh.faces.len(),
        poses: data.input.pose_count(),
        lbs: ErrorSummary::from_errors(box_unit, &lbs_errors, &lbs_sizes, POSITION_TOLERANCE),
        plane_quadrics: ErrorSummary::from_errors(
            quadric_unit,
            &relative(&pe, &ps),
            &vec![1.0; ps.len()],
            QUADRIC_TOLERANCE,
        ),
        vertex_quadrics: ErrorSummary::from_errors(
            quadric_unit,
            &relative(&ve, &vs),
            &vec![1.0; vs.len()],
            QUADRIC_TOLERANCE,
        ),
        candidates: data.candidates.len(),
        skipped_ill_conditioned: skipped,
        choice_mismatches: mismatches,
        positions: ErrorSummary::from_errors(
            box_unit,
            &position_errors,
            &position_sizes,
            POSITION_TOLERANCE,
        ),
        costs: ErrorSummary::from_errors("max(1e-4 |E|, 1e-7)", &cost_errors, &cost_sizes, 1.0),
    }
}
