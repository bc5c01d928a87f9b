//! Loop-subdivision smoothing of the parameterisation in the parameter domain (notes "Smoothing
//! and remeshing"; seed "Remeshing (2/5), (3/5)").
//!
//! Π is only C0 across base edges: the unsmoothed uniform remesh ([`super::remesh::uniform`], the
//! baseline kept for comparison) places its vertices at Π⁻¹ of the *dyadic* points of the base
//! triangles, and the dyadic grid lines kink where they cross a base edge or meet a base vertex.
//! MAPS smooths the parameterisation by running Loop subdivision on the *parameter values*: the
//! control net starts as the base domain itself (every base vertex at its own parameter), and
//! each of j rounds quadrisects the net like the uniform remesh and gives
//!
//! - a new (odd) vertex on net edge (a, b) with opposite vertices c, d the parameter
//!   u = ⅜ u_a + ⅜ u_b + ⅛ u_c + ⅛ u_d,
//! - an old (even) vertex x with neighbours y_1 … y_n the parameter
//!   u = (1 − nβ) u_x + β Σ u_{y_i}, with Loop's β(n) = (5/8 − (3/8 + ¼ cos 2π/n)²)/n by default
//!   ([`LoopBeta`]; Warren's 3/(8n) on request; both give 1/16 at n = 6),
//!
//! evaluated in a local planar *chart* ([`Chart`]), then located again as (base triangle,
//! barycentrics). The smoothed remesh ([`uniform_smoothed`]) has the connectivity and counts of
//! the uniform remesh of level j, its vertex i at Π⁻¹ of the smoothed parameter instead of
//! Π⁻¹ of the dyadic point.
//!
//! **Charts** (the slides' three cases). Every base face enters a chart through an affine map
//! (its three corners get 2D positions), so a parameter point (face f, barycentrics b) of a
//! chart face has the chart position u = Σ b_c P_c, and a chart position is located back with
//! robust orientations ([`super::retriangulate::barycentric`]). The root chart of a stencil is
//! chosen from the *dyadic* place of its centre, whose dyadic stencil points all lie in it:
//! - centre inside base face t: t laid out with its 3D shape ([`Chart::face`]) — normal Loop;
//! - centre on base edge (p, q): the two base faces unfolded across it, each keeping its 3D
//!   shape ([`Chart::edge`], the hinge map of the slides);
//! - centre at base vertex v (an even base vertex, or an odd vertex on a net edge from v): the
//!   base 1-ring of v flattened with z^a ([`Chart::vertex`]; [`flatten_ring`] with the disk map,
//!   a = 2π/θ, or, for a vertex on a feature or boundary line, the half-disk map a = π/θ_side of
//!   the side (sector) the stencil is in — the hierarchy's own maps; a corner's side keeps its
//!   3D angles).
//!
//! **Re-expressing a moved point.** Smoothed parameters drift off their dyadic places, so a
//! stencil point may sit in a base face that is not in the root chart. [`Chart::position`] also
//! accepts a point on an edge or at a vertex of a chart face (the same point in the neighbour's
//! barycentrics), and otherwise the chart is grown: base faces across non-crease edges of chart
//! faces are unfolded into the chart by the similarity that maps the shared edge onto the
//! chart's copy of that edge (the third corner keeps the 3D triangle's shape:
//! R = Q + x (P − Q) + y (P − Q)^⊥ with (x, y) the 3D coordinates of r in the frame of the edge
//! q → p) — first only the faces sharing a vertex with the point's face, ring by ring
//! ([`Chart::grow_towards`]: a point that drifted around a base vertex of high valence), then, if
//! that cannot reach it, whole rings ([`Chart::grow`], at most [`SmoothOptions::grow_rounds`]).
//! A point still outside uses its dyadic parameter (counted in [`SmoothStats::fallbacks`]). The result u is located in the
//! chart faces in order (root faces first, then the unfolded rings), the first face whose three
//! robust orientations are ≥ 0; if none contains u the chart grows, and at the end u goes to the
//! nearest face with clamped barycentrics ([`SmoothStats::clamped`] — this is also what keeps a
//! point from crossing a crease).
//!
//! **Creases.** Boundary edges and base feature edges are creases: charts never unfold across
//! them, and points on them follow the 1-D rules of Loop's crease scheme in the arclength chart
//! of the crease polyline (`Chain`): even ⅛ u_prev + ¾ u_x + ⅛ u_next, odd ½ u_a + ½ u_b. A
//! base vertex that is a corner (tagged, or by [`vertex_role`]: feature degree not 0 or 2, or a
//! turn above `corner_turn`) keeps its parameter. Points on a crease stay exactly on it (one
//! barycentric exactly 0).
//!
//! Rounds are parallel over the vertices of the finer net (each a pure function of the coarser
//! net), so the result does not depend on the thread count.

use std::collections::{BTreeSet, HashMap};

use nalgebra::Point3;
use rayon::prelude::*;

use super::features::{vertex_role, VertexRole};
use super::flatten::{cumulative_angles, flatten_ring, RingShape};
use super::hierarchy::ordered_ring;
use super::param::{clamp, BasePoint};
use super::remesh::{
    check_level, dyadic_point, finish, index_vertices, place, vkey, DyadicTri, Remesh, VKey,
};
use super::retriangulate::barycentric;
use super::{Maps, MapsOptions};
use crate::error::Result;

/// Which β(n) the even rule uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LoopBeta {
    /// Loop's original β(n) = (5/8 − (3/8 + ¼ cos(2π/n))²)/n (the scheme MAPS uses). Default.
    #[default]
    Loop,
    /// Warren's simplification β(n) = 3/(8n) for n > 3, 3/16 for n = 3.
    Warren,
}

/// β(n) of the even rule for an interior vertex of valence `n` (≥ 1).
pub fn loop_beta(n: usize, rule: LoopBeta) -> f64 {
    let nf = n as f64;
    match rule {
        LoopBeta::Loop => {
            let c = 0.375 + 0.25 * (std::f64::consts::TAU / nf).cos();
            (0.625 - c * c) / nf
        }
        LoopBeta::Warren if n == 3 => 3.0 / 16.0,
        LoopBeta::Warren => 3.0 / (8.0 * nf),
    }
}

/// The even (vertex) stencil of valence `n`: (1 − nβ) for the vertex, β for each neighbour.
/// The weights sum to (1 − nβ) + nβ = 1, and both are positive for n ≥ 3.
pub fn even_weights(n: usize, rule: LoopBeta) -> (f64, f64) {
    let beta = loop_beta(n, rule);
    (1.0 - n as f64 * beta, beta)
}

/// The odd (edge) stencil: ⅜ for the edge ends a, b, ⅛ for the opposite vertices c, d.
pub const ODD_WEIGHTS: [f64; 4] = [0.375, 0.375, 0.125, 0.125];
/// The even crease stencil: ⅛ previous, ¾ the vertex, ⅛ next.
pub const CREASE_EVEN_WEIGHTS: [f64; 3] = [0.125, 0.75, 0.125];
/// The odd crease stencil: the midpoint.
pub const CREASE_ODD_WEIGHTS: [f64; 2] = [0.5, 0.5];

/// Options of the smoothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothOptions {
    /// β of the even rule. Default [`LoopBeta::Loop`].
    pub beta: LoopBeta,
    /// How many whole rings of base faces a chart may unfold when unfolding towards a point's
    /// face cannot reach it, and to locate a result (module docs). Default 2.
    pub grow_rounds: usize,
    /// A feature-line or boundary base vertex whose two crease edges turn by more than this
    /// (radians) keeps its parameter ([`vertex_role`]). Default: the hierarchy's default, 60°.
    pub corner_turn: f64,
}

impl Default for SmoothOptions {
    fn default() -> Self {
        SmoothOptions {
            beta: LoopBeta::Loop,
            grow_rounds: 2,
            corner_turn: MapsOptions::default().corner_turn,
        }
    }
}

/// What happened to the stencils (all zero when every stencil was evaluated as designed, except
/// that `clamped` also counts points held on a crease).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SmoothStats {
    /// Stencils evaluated (vertices of all finer nets).
    pub stencils: usize,
    /// Stencil points that no grown chart contained (their dyadic parameter was used).
    pub fallbacks: usize,
    /// Results outside every chart face, put in the nearest one with clamped barycentrics.
    pub clamped: usize,
}

impl SmoothStats {
    /// Add another's counts.
    pub fn add(&mut self, o: &SmoothStats) {
        self.stencils += o.stencils;
        self.fallbacks += o.fallbacks;
        self.clamped += o.clamped;
    }
}

// ------------------------------------------------------------------------------ base domain

/// The base domain's adjacency, creases and vertex roles (what the charts need).
pub struct BaseDomain<'a> {
    faces: &'a [[u32; 3]],
    positions: &'a [Point3<f64>],
    /// The face across edge e (corner e → e + 1) of each face; `u32::MAX` on the boundary.
    across: Vec<[u32; 3]>,
    /// Whether edge e of each face is a crease (boundary or base feature edge).
    crease: Vec<[bool; 3]>,
    /// Faces around each vertex (ids ascending).
    star: Vec<Vec<u32>>,
    /// The other ends of each vertex's crease edges (ascending).
    crease_neighbours: Vec<Vec<u32>>,
    role: Vec<VertexRole>,
}

impl<'a> BaseDomain<'a> {
    /// Adjacency of `maps.base_faces`; creases are boundary edges and `maps.base_feature_edges`;
    /// roles by [`vertex_role`] with the tagged corners and `corner_turn`.
    pub fn new(maps: &'a Maps, corner_turn: f64) -> Self {
        let faces = &maps.base_faces[..];
        let n = maps.positions.len();
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        let mut star = vec![Vec::new(); n];
        for (f, t) in faces.iter().enumerate() {
            for e in 0..3 {
                directed.insert((t[e], t[(e + 1) % 3]), f as u32);
                star[t[e] as usize].push(f as u32);
            }
        }
        let mut across = Vec::with_capacity(faces.len());
        let mut crease = Vec::with_capacity(faces.len());
        let mut crease_sets = vec![BTreeSet::new(); n];
        for t in faces {
            let mut a = [u32::MAX; 3];
            let mut c = [false; 3];
            for e in 0..3 {
                let (p, q) = (t[e], t[(e + 1) % 3]);
                a[e] = directed.get(&(q, p)).copied().unwrap_or(u32::MAX);
                c[e] = a[e] == u32::MAX || maps.base_feature_edges.contains(&(p.min(q), p.max(q)));
                if c[e] {
                    crease_sets[p as usize].insert(q);
                    crease_sets[q as usize].insert(p);
                }
            }
            across.push(a);
            crease.push(c);
        }
        let crease_neighbours: Vec<Vec<u32>> = crease_sets
            .into_iter()
            .map(|s| s.into_iter().collect())
            .collect();
        let role = (0..n)
            .map(|v| {
                vertex_role(
                    &maps.positions,
                    v as u32,
                    maps.features.corners.contains(&(v as u32)),
                    &crease_neighbours[v],
                    corner_turn,
                )
            })
            .collect();
        BaseDomain {
            faces,
            positions: &maps.positions,
            across,
            crease,
            star,
            crease_neighbours,
            role,
        }
    }

    /// Whether base edge (p, q) is a crease (false if it is not a base edge).
    pub fn is_crease(&self, p: u32, q: u32) -> bool {
        self.edge_face(p, q)
            .is_some_and(|(f, e)| self.crease[f as usize][e])
    }

    /// A face having (p, q) as an edge (the lowest id) and the edge's index in it.
    fn edge_face(&self, p: u32, q: u32) -> Option<(u32, usize)> {
        self.star.get(p as usize)?.iter().find_map(|&f| {
            let t = self.faces[f as usize];
            (0..3)
                .find(|&e| {
                    let (a, b) = (t[e], t[(e + 1) % 3]);
                    (a, b) == (p, q) || (a, b) == (q, p)
                })
                .map(|e| (f, e))
        })
    }

    /// The role of base vertex `v` for the smoothing.
    pub fn role(&self, v: u32) -> VertexRole {
        self.role[v as usize]
    }

    fn point3(&self, v: u32) -> Point3<f64> {
        self.positions[v as usize]
    }
}

/// Where a parameter point lies: at a base vertex, on a base edge (with the two weights), or
/// inside its face.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Support {
    Vertex(u32),
    Edge([(u32, f64); 2]),
    Face,
}

fn support(base: &BaseDomain, p: &BasePoint) -> Support {
    let t = base.faces[p.face as usize];
    let nonzero: Vec<usize> = (0..3).filter(|&c| p.bary[c] != 0.0).collect();
    match nonzero.as_slice() {
        [c] => Support::Vertex(t[*c]),
        [c1, c2] => Support::Edge([(t[*c1], p.bary[*c1]), (t[*c2], p.bary[*c2])]),
        _ => Support::Face,
    }
}

// ------------------------------------------------------------------------------ 2-D charts

/// A planar chart of some base faces: each face's corners get 2D positions (affine per face).
#[derive(Clone, Debug, Default)]
pub struct Chart {
    faces: Vec<u32>,
    corners: Vec<[[f64; 2]; 3]>,
    slot: HashMap<u32, usize>,
}

/// The point C with (A, B, C) counter-clockwise and similar to the 3D triangle (a, b, c):
/// C = A + x (B − A) + y (B − A)^⊥, (x, y) the coordinates of c − a in the frame of a → b
/// measured in units of |b − a|.
fn place_third(
    pa: [f64; 2],
    pb: [f64; 2],
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> [f64; 2] {
    let ab = b - a;
    let ac = c - a;
    let l2 = ab.norm_squared();
    let x = ac.dot(&ab) / l2;
    let y = ac.cross(&ab).norm() / l2;
    let d = [pb[0] - pa[0], pb[1] - pa[1]];
    [pa[0] + x * d[0] - y * d[1], pa[1] + x * d[1] + y * d[0]]
}

impl Chart {
    fn push(&mut self, f: u32, corners: [[f64; 2]; 3]) {
        if !self.slot.contains_key(&f) {
            self.slot.insert(f, self.faces.len());
            self.faces.push(f);
            self.corners.push(corners);
        }
    }

    /// Base face `t` with its 3D shape: corner 0 at the origin, corner 1 on the x axis.
    pub fn face(base: &BaseDomain, t: u32) -> Chart {
        let tri = base.faces[t as usize];
        let [a, b, c] = tri.map(|v| base.point3(v));
        let pb = [(b - a).norm(), 0.0];
        let mut chart = Chart::default();
        chart.push(t, [[0.0, 0.0], pb, place_third([0.0, 0.0], pb, &a, &b, &c)]);
        chart
    }

    /// The base edge (p, q) with its faces: the first face (lowest id) by [`Chart::face`], the
    /// face across unfolded by the hinge map (not across a crease).
    pub fn edge(base: &BaseDomain, p: u32, q: u32) -> Chart {
        let (f, e) = base.edge_face(p, q).expect("a base edge");
        let mut chart = Chart::face(base, f);
        chart.unfold(base, 0, e);
        chart
    }

    /// The base 1-ring of `v` flattened with z^a, v at 0: the whole disk (a = 2π/θ) for a vertex
    /// off the creases; for a vertex on a crease the side (sector between two crease edges)
    /// containing face `root`: as a half disk (a = π/θ_side, the hierarchy's map, which makes
    /// the crease straight like its arclength chart) on a feature or boundary *line*, with its
    /// 3D angles at a corner (`corner_fan`: a = 1 while the side is below 2π). When
    /// [`flatten_ring`] refuses (a side of one face, or a sector of a·φ ≥ π), the sector keeps
    /// its 3D angles (a = 1).
    pub fn vertex(base: &BaseDomain, v: u32, root: u32) -> Chart {
        let mut chart = Chart::default();
        let Some(ring) = ordered_ring(base.faces, &base.star[v as usize], v) else {
            return Chart::face(base, root);
        };
        let k = ring.verts.len();
        let spoke = |m: usize| base.is_crease(v, ring.verts[m % k]);
        let spokes: Vec<usize> = (0..k)
            .filter(|&m| spoke(m) || (!ring.closed && (m == 0 || m == k - 1)))
            .collect();
        let m_root = ring.faces.iter().position(|&f| f == root).unwrap_or(0);
        // Sector [s, e]: ring vertices s ..= e (cyclic), faces s .. e.
        let (s, e, shape) = if ring.closed && spokes.is_empty() {
            (0, k, RingShape::Disk)
        } else {
            let sectors = ring.faces.len();
            let s = (0..=m_root)
                .rev()
                .chain((m_root + 1..k).rev())
                .find(|m| spokes.contains(m))
                .expect("a spoke");
            let mut e = s + 1;
            while !spokes.contains(&(e % k)) && e < s + sectors {
                e += 1;
            }
            (s, e, RingShape::HalfDisk)
        };
        let centre = base.point3(v);
        let verts: Vec<u32> = if shape == RingShape::Disk {
            ring.verts.clone()
        } else {
            (s..=e).map(|m| ring.verts[m % k]).collect()
        };
        let pts: Vec<Point3<f64>> = verts.iter().map(|&w| base.point3(w)).collect();
        let mu = match (shape, base.role(v)) {
            (RingShape::Disk, _) | (_, VertexRole::Line) => flatten_ring(&centre, &pts, shape)
                .unwrap_or_else(|_| isometric_fan(&centre, &pts, shape == RingShape::Disk)),
            _ => corner_fan(&centre, &pts),
        };
        let faces = if shape == RingShape::Disk { k } else { e - s };
        for m in 0..faces {
            let f = ring.faces[(s + m) % ring.faces.len()];
            let (j0, j1) = (verts[m], verts[(m + 1) % verts.len()]);
            let (u0, u1) = (mu[m], mu[(m + 1) % mu.len()]);
            let tri = base.faces[f as usize];
            let corners = tri.map(|w| {
                if w == v {
                    [0.0, 0.0]
                } else if w == j0 {
                    u0
                } else if w == j1 {
                    u1
                } else {
                    unreachable!("a star face joins v and two consecutive ring vertices")
                }
            });
            chart.push(f, corners);
        }
        if chart.faces.is_empty() {
            return Chart::face(base, root);
        }
        chart
    }

    /// Unfold the face across edge `e` of chart face number `slot` (unless it is a crease or
    /// already in the chart).
    fn unfold(&mut self, base: &BaseDomain, slot: usize, e: usize) {
        let f = self.faces[slot];
        let g = base.across[f as usize][e];
        if base.crease[f as usize][e] || g == u32::MAX || self.slot.contains_key(&g) {
            return;
        }
        let t = base.faces[f as usize];
        let (p, q) = (t[e], t[(e + 1) % 3]);
        let (pp, pq) = (self.corners[slot][e], self.corners[slot][(e + 1) % 3]);
        let u = base.faces[g as usize];
        let gq = u.iter().position(|&w| w == q).expect("shared edge");
        let r = u[(gq + 2) % 3];
        // g is counter-clockwise as (q, p, r): R is placed on the left of Q → P.
        let pr = place_third(pq, pp, &base.point3(q), &base.point3(p), &base.point3(r));
        let corners = u.map(|w| {
            if w == q {
                pq
            } else if w == p {
                pp
            } else {
                pr
            }
        });
        self.push(g, corners);
    }

    /// One ring of growth: unfold every face across a non-crease edge of the current chart
    /// faces (in chart order). Returns whether a face was added.
    pub fn grow(&mut self, base: &BaseDomain) -> bool {
        let before = self.faces.len();
        for slot in 0..before {
            for e in 0..3 {
                self.unfold(base, slot, e);
            }
        }
        self.faces.len() > before
    }

    /// Unfold, ring by ring, only the faces that share a vertex with base face `target`, until
    /// `target` is in the chart or none can be added (walks around a base vertex of high
    /// valence, which [`Chart::grow`] would need many rings for). Returns whether it got there.
    pub fn grow_towards(&mut self, base: &BaseDomain, target: u32) -> bool {
        let near = base.faces[target as usize];
        loop {
            if self.slot.contains_key(&target) {
                return true;
            }
            let before = self.faces.len();
            for slot in 0..before {
                for e in 0..3 {
                    let g = base.across[self.faces[slot] as usize][e];
                    if g != u32::MAX && base.faces[g as usize].iter().any(|v| near.contains(v)) {
                        self.unfold(base, slot, e);
                    }
                }
            }
            if self.faces.len() == before {
                return false;
            }
        }
    }

    /// The base faces of the chart, root first.
    pub fn faces(&self) -> &[u32] {
        &self.faces
    }

    /// Chart position of a parameter point: u = Σ b_c P_c in its face, or, for a point on an
    /// edge or at a vertex of a chart face, in that face (`None` otherwise).
    pub fn position(&self, base: &BaseDomain, p: &BasePoint) -> Option<[f64; 2]> {
        let combine = |slot: usize, weights: &[(u32, f64)]| {
            let t = base.faces[self.faces[slot] as usize];
            let mut u = [0.0; 2];
            for &(w, b) in weights {
                let c = t.iter().position(|&x| x == w)?;
                u[0] += b * self.corners[slot][c][0];
                u[1] += b * self.corners[slot][c][1];
            }
            Some(u)
        };
        if let Some(&slot) = self.slot.get(&p.face) {
            let t = base.faces[p.face as usize];
            return combine(
                slot,
                &[(t[0], p.bary[0]), (t[1], p.bary[1]), (t[2], p.bary[2])],
            );
        }
        let weights: Vec<(u32, f64)> = match support(base, p) {
            Support::Vertex(w) => vec![(w, 1.0)],
            Support::Edge(pair) => pair.to_vec(),
            Support::Face => return None,
        };
        (0..self.faces.len()).find_map(|slot| combine(slot, &weights))
    }

    /// The first chart face (in chart order) containing u (robust orientations ≥ 0), with
    /// barycentrics.
    pub fn locate(&self, u: [f64; 2]) -> Option<BasePoint> {
        self.faces.iter().zip(&self.corners).find_map(|(&f, c)| {
            let l = barycentric(u, c[0], c[1], c[2]);
            (l[0] >= 0.0 && l[1] >= 0.0 && l[2] >= 0.0).then_some(BasePoint { face: f, bary: l })
        })
    }

    /// The chart face whose smallest barycentric of u is largest, barycentrics clamped to ≥ 0.
    pub fn nearest(&self, u: [f64; 2]) -> BasePoint {
        let mut best = (f64::NEG_INFINITY, self.faces[0], [1.0, 0.0, 0.0]);
        for (&f, c) in self.faces.iter().zip(&self.corners) {
            let l = barycentric(u, c[0], c[1], c[2]);
            let min = l[0].min(l[1]).min(l[2]);
            if min > best.0 && l.iter().all(|x| x.is_finite()) {
                best = (min, f, l);
            }
        }
        BasePoint {
            face: best.1,
            bary: clamp(best.2),
        }
    }
}

/// The side of a corner's ring: its 3D angles (a = 1) when they sum to less than 2π (a cube
/// corner's 90° side stays 90°: a corner is not a straight crease, so it is not straightened),
/// else the half disk of [`flatten_ring`] (a = π/θ_side).
fn corner_fan(centre: &Point3<f64>, ring: &[Point3<f64>]) -> Vec<[f64; 2]> {
    let theta = cumulative_angles(centre, ring, false);
    if theta[ring.len() - 1] < std::f64::consts::TAU {
        isometric_fan(centre, ring, false)
    } else {
        flatten_ring(centre, ring, RingShape::HalfDisk)
            .unwrap_or_else(|_| isometric_fan(centre, ring, true))
    }
}

/// The ring laid out with its 3D angles (a = 1): μ_k = r_k e^{i θ_k}; a disk whose angles do not
/// fit in 2π is scaled to equal angles 2π k/K instead.
fn isometric_fan(centre: &Point3<f64>, ring: &[Point3<f64>], closed: bool) -> Vec<[f64; 2]> {
    let theta = cumulative_angles(centre, ring, closed);
    let k = ring.len();
    ring.iter()
        .enumerate()
        .map(|(m, p)| {
            let r = (p - centre).norm();
            let angle = if closed {
                std::f64::consts::TAU * m as f64 / k as f64
            } else {
                theta[m]
            };
            [r * angle.cos(), r * angle.sin()]
        })
        .collect()
}

// ------------------------------------------------------------------------------ 1-D charts

/// A crease polyline laid out by arclength: base vertices `verts` at abscissae `s`.
#[derive(Clone, Debug)]
pub(super) struct Chain {
    verts: Vec<u32>,
    s: Vec<f64>,
}

/// How many crease edges a [`Chain`] reaches beyond its middle edge(s) on each side.
const CHAIN_REACH: usize = 2;

impl Chain {
    /// The crease polyline through the base vertices `middle` (consecutive along a crease),
    /// continued on both ends through line vertices for [`CHAIN_REACH`] edges.
    fn through(base: &BaseDomain, middle: &[u32]) -> Chain {
        let extend = |from: u32, to: u32| -> Vec<u32> {
            let (mut prev, mut cur) = (from, to);
            let mut out = Vec::new();
            for _ in 0..CHAIN_REACH {
                if base.role(cur) != VertexRole::Line {
                    break;
                }
                let Some(&next) = base.crease_neighbours[cur as usize]
                    .iter()
                    .find(|&&w| w != prev)
                else {
                    break;
                };
                out.push(next);
                (prev, cur) = (cur, next);
            }
            out
        };
        let n = middle.len();
        let mut verts: Vec<u32> = extend(middle[1], middle[0]).into_iter().rev().collect();
        verts.extend_from_slice(middle);
        verts.extend(extend(middle[n - 2], middle[n - 1]));
        let mut s = vec![0.0];
        for w in verts.windows(2) {
            let l = (base.point3(w[1]) - base.point3(w[0])).norm();
            s.push(s.last().unwrap() + l);
        }
        Chain { verts, s }
    }

    /// Arclength of a point at a chain vertex or on a chain edge (`None` otherwise).
    pub(super) fn position(&self, base: &BaseDomain, p: &BasePoint) -> Option<f64> {
        let at = |w: u32| self.verts.iter().position(|&x| x == w);
        match support(base, p) {
            Support::Vertex(w) => at(w).map(|i| self.s[i]),
            Support::Edge([(w1, b1), (w2, b2)]) => {
                let i = (0..self.verts.len() - 1).find(|&i| {
                    let e = (self.verts[i], self.verts[i + 1]);
                    e == (w1, w2) || e == (w2, w1)
                })?;
                let (s1, s2) = if self.verts[i] == w1 {
                    (self.s[i], self.s[i + 1])
                } else {
                    (self.s[i + 1], self.s[i])
                };
                Some(b1 * s1 + b2 * s2)
            }
            Support::Face => None,
        }
    }

    /// The point at arclength `s` (clamped to the chain) on its chain edge, the third
    /// barycentric exactly 0.
    pub(super) fn locate(&self, base: &BaseDomain, s: f64) -> BasePoint {
        let last = self.s.len() - 1;
        let s = s.clamp(self.s[0], self.s[last]);
        let i = (0..last).find(|&i| s <= self.s[i + 1]).unwrap_or(last - 1);
        let x = ((s - self.s[i]) / (self.s[i + 1] - self.s[i])).clamp(0.0, 1.0);
        let (p, q) = (self.verts[i], self.verts[i + 1]);
        let (f, _) = base.edge_face(p, q).expect("a chain edge is a base edge");
        let t = base.faces[f as usize];
        let bary = t.map(|w| {
            if w == p {
                1.0 - x
            } else if w == q {
                x
            } else {
                0.0
            }
        });
        BasePoint { face: f, bary }
    }
}

// ------------------------------------------------------------------------------ nets and rounds

/// A net over the base domain: dyadic triangles (the uniform remesh's, same order), one vertex
/// per distinct dyadic point (numbered as [`super::remesh::uniform`] numbers them), and each
/// vertex's parameter — the dyadic point itself, or its smoothed parameter.
#[derive(Clone, Debug)]
pub struct ParamNet {
    /// Face i is the dyadic triangle `leaves[i]`.
    pub leaves: Vec<DyadicTri>,
    /// The faces as vertex indices.
    pub faces: Vec<[u32; 3]>,
    /// The dyadic key of each vertex.
    pub keys: Vec<VKey>,
    /// The dyadic point of each vertex.
    pub dyadic: Vec<BasePoint>,
    /// The parameter of each vertex (equal to `dyadic` before smoothing).
    pub params: Vec<BasePoint>,
}

impl ParamNet {
    /// The unsmoothed net of `leaves`: every parameter its dyadic point.
    pub fn dyadic(maps: &Maps, leaves: Vec<DyadicTri>) -> ParamNet {
        let (verts, faces) = index_vertices(maps, &leaves);
        let keys = verts
            .iter()
            .map(|&(t, p, d)| vkey(&maps.base_faces, t, p, d))
            .collect();
        let dyadic: Vec<BasePoint> = verts
            .iter()
            .map(|&(t, p, d)| dyadic_point(t, p, d))
            .collect();
        ParamNet {
            leaves,
            faces,
            keys,
            params: dyadic.clone(),
            dyadic,
        }
    }

    /// Π⁻¹ of every parameter (parallel), and how many found no input face (then the flat
    /// base point is used).
    pub fn positions(&self, maps: &Maps) -> (Vec<Point3<f64>>, usize) {
        let placed: Vec<(Point3<f64>, bool)> =
            self.params.par_iter().map(|p| place(maps, p)).collect();
        let unmapped = placed.iter().filter(|p| !p.1).count();
        (placed.into_iter().map(|p| p.0).collect(), unmapped)
    }
}

/// An edge of a net: its ends, the opposite vertices, the base faces of its net faces.
#[derive(Clone, Debug, Default)]
struct NetEdge {
    ends: [u32; 2],
    opposite: Vec<u32>,
    base_faces: Vec<u32>,
}

/// The base edge a net edge between dyadic points `a` and `b` lies on, if any.
fn base_edge_of(base: &BaseDomain, a: VKey, b: VKey) -> Option<(u32, u32)> {
    let ends = |k: VKey| -> Vec<(u32, u32)> {
        match k {
            VKey::Vertex(v) => base.star[v as usize]
                .iter()
                .flat_map(|&f| {
                    let t = base.faces[f as usize];
                    (0..3).map(move |e| (t[e], t[(e + 1) % 3]))
                })
                .filter(|&(p, q)| p == v || q == v)
                .map(|(p, q)| (p.min(q), p.max(q)))
                .collect(),
            VKey::Edge { lo, hi, .. } => vec![(lo, hi)],
            VKey::Face { .. } => Vec::new(),
        }
    };
    let eb = ends(b);
    ends(a).into_iter().find(|e| eb.contains(e))
}

/// What the even rule does with a net vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum EvenKind {
    Fixed,
    Crease,
    Interior,
}

pub(super) fn even_kind(base: &BaseDomain, key: VKey) -> EvenKind {
    match key {
        VKey::Vertex(v) => match base.role(v) {
            VertexRole::Corner => EvenKind::Fixed,
            VertexRole::Line => EvenKind::Crease,
            VertexRole::Free => EvenKind::Interior,
        },
        VKey::Edge { lo, hi, .. } if base.is_crease(lo, hi) => EvenKind::Crease,
        _ => EvenKind::Interior,
    }
}

/// One stencil point: its current parameter and its dyadic point (the fallback).
pub(super) type StencilPoint = (BasePoint, BasePoint);

/// Σ w_i u_i of the stencil points in `chart` (grown as needed), located back (module docs).
fn combine_2d(
    base: &BaseDomain,
    chart: Chart,
    points: &[StencilPoint],
    weights: &[f64],
    options: &SmoothOptions,
    stats: &mut SmoothStats,
) -> BasePoint {
    let mut placed = place_in_chart(base, chart, points, options, stats);
    let mut u = [0.0; 2];
    for (q, w) in placed.positions.iter().zip(weights) {
        u[0] += w * q[0];
        u[1] += w * q[1];
    }
    placed.locate(base, u, options, stats)
}

/// Stencil points laid out in one chart (grown as needed): what [`combine_2d`] combines, and
/// what the relaxation ([`super::relax`]) weighs.
pub(super) struct Placed {
    pub chart: Chart,
    /// Chart position of each point (its dyadic point's, counted as a fallback, when no grown
    /// chart contained it).
    pub positions: Vec<[f64; 2]>,
    grown: usize,
}

/// Lay `points` out in `chart`, unfolding faces towards those outside it, then whole rings
/// (at most [`SmoothOptions::grow_rounds`]); a point still outside uses its dyadic point.
pub(super) fn place_in_chart(
    base: &BaseDomain,
    mut chart: Chart,
    points: &[StencilPoint],
    options: &SmoothOptions,
    stats: &mut SmoothStats,
) -> Placed {
    let mut grown = 0;
    let mut pos: Vec<Option<[f64; 2]>> =
        points.iter().map(|p| chart.position(base, &p.0)).collect();
    loop {
        let missing: Vec<u32> = (0..points.len())
            .filter(|&i| pos[i].is_none())
            .map(|i| points[i].0.face)
            .collect();
        if missing.is_empty() {
            break;
        }
        let mut added = false;
        for f in missing {
            added |= chart.grow_towards(base, f);
        }
        if !added {
            if grown >= options.grow_rounds || !chart.grow(base) {
                break;
            }
            grown += 1;
        }
        pos = points.iter().map(|p| chart.position(base, &p.0)).collect();
    }
    let positions = pos
        .iter()
        .zip(points)
        .map(|(p, (_, dyadic))| match p {
            Some(q) => *q,
            None => {
                stats.fallbacks += 1;
                chart.position(base, dyadic).unwrap_or([0.0, 0.0])
            }
        })
        .collect();
    Placed {
        chart,
        positions,
        grown,
    }
}

impl Placed {
    /// The chart point `u` as a parameter: the first chart face containing it, growing the
    /// chart while the rounds allow, else the nearest face with clamped barycentrics.
    pub fn locate(
        &mut self,
        base: &BaseDomain,
        u: [f64; 2],
        options: &SmoothOptions,
        stats: &mut SmoothStats,
    ) -> BasePoint {
        loop {
            if let Some(found) = self.chart.locate(u) {
                return found;
            }
            if self.grown >= options.grow_rounds || !self.chart.grow(base) {
                stats.clamped += 1;
                return self.chart.nearest(u);
            }
            self.grown += 1;
        }
    }
}

/// Σ w_i s_i of the stencil points along the crease `chain`, located back on the chain.
pub(super) fn combine_1d(
    base: &BaseDomain,
    chain: &Chain,
    points: &[StencilPoint],
    weights: &[f64],
    stats: &mut SmoothStats,
) -> BasePoint {
    let mut s = 0.0;
    for (p, w) in points.iter().zip(weights) {
        let x = chain.position(base, &p.0).unwrap_or_else(|| {
            stats.fallbacks += 1;
            chain.position(base, &p.1).unwrap_or(chain.s[0])
        });
        s += w * x;
    }
    chain.locate(base, s)
}

/// The coarse net's connectivity the rules need.
pub(super) struct Topology {
    index: HashMap<VKey, u32>,
    edges: HashMap<VKey, NetEdge>,
    pub neighbours: Vec<Vec<u32>>,
}

pub(super) fn topology(maps: &Maps, net: &ParamNet) -> Topology {
    let index = net
        .keys
        .iter()
        .enumerate()
        .map(|(i, &k)| (k, i as u32))
        .collect();
    let mut edges: HashMap<VKey, NetEdge> = HashMap::new();
    let mut neighbours = vec![BTreeSet::new(); net.keys.len()];
    for (tri, f) in net.leaves.iter().zip(&net.faces) {
        for e in 0..3 {
            let (a, b, c) = (f[e], f[(e + 1) % 3], f[(e + 2) % 3]);
            let mid = vkey(&maps.base_faces, tri.t, tri.edge_midpoint(e), tri.depth + 1);
            let entry = edges.entry(mid).or_default();
            entry.ends = [a.min(b), a.max(b)];
            entry.opposite.push(c);
            entry.base_faces.push(tri.t);
            neighbours[a as usize].insert(b);
            neighbours[b as usize].insert(a);
        }
    }
    Topology {
        index,
        edges,
        neighbours: neighbours
            .into_iter()
            .map(|s| s.into_iter().collect())
            .collect(),
    }
}

/// The new parameter of fine vertex `key` (dyadic point `dyadic`) from the coarse net (module
/// docs).
fn stencil(
    base: &BaseDomain,
    coarse: &ParamNet,
    topo: &Topology,
    (key, dyadic): (VKey, BasePoint),
    options: &SmoothOptions,
) -> (BasePoint, SmoothStats) {
    let mut stats = SmoothStats {
        stencils: 1,
        ..SmoothStats::default()
    };
    let point = |i: u32| (coarse.params[i as usize], coarse.dyadic[i as usize]);
    let result = if let Some(&c) = topo.index.get(&key) {
        even_rule(base, coarse, topo, c, options, &mut stats)
    } else {
        let edge = &topo.edges[&key];
        let [a, b] = edge.ends;
        let (ka, kb) = (coarse.keys[a as usize], coarse.keys[b as usize]);
        match base_edge_of(base, ka, kb) {
            Some((p, q)) if base.is_crease(p, q) => {
                let chain = Chain::through(base, &[p, q]);
                combine_1d(
                    base,
                    &chain,
                    &[point(a), point(b)],
                    &CREASE_ODD_WEIGHTS,
                    &mut stats,
                )
            }
            // An edge off the creases has two faces, unless the base domain's creases missed a
            // boundary or non-manifold edge (found by fuzzing: a vertex at y = 9·10¹⁸): the
            // fine vertex keeps its dyadic point then, counted as a fallback.
            _ if edge.opposite.len() != 2 => {
                stats.fallbacks += 1;
                dyadic
            }
            on_base_edge => {
                let root = match (ka, kb) {
                    (VKey::Vertex(_), VKey::Vertex(_)) => {
                        let (p, q) = on_base_edge.expect("a level-0 edge is a base edge");
                        Chart::edge(base, p, q)
                    }
                    (VKey::Vertex(v), _) | (_, VKey::Vertex(v)) => {
                        Chart::vertex(base, v, edge.base_faces[0])
                    }
                    _ => match on_base_edge {
                        Some((p, q)) => Chart::edge(base, p, q),
                        None => Chart::face(base, edge.base_faces[0]),
                    },
                };
                let pts = [
                    point(a),
                    point(b),
                    point(edge.opposite[0]),
                    point(edge.opposite[1]),
                ];
                combine_2d(base, root, &pts, &ODD_WEIGHTS, options, &mut stats)
            }
        }
    };
    (result, stats)
}

/// The even rule for coarse vertex `c` (fixed corner, 1-D crease rule, or Loop's vertex rule).
fn even_rule(
    base: &BaseDomain,
    coarse: &ParamNet,
    topo: &Topology,
    c: u32,
    options: &SmoothOptions,
    stats: &mut SmoothStats,
) -> BasePoint {
    let point = |i: u32| (coarse.params[i as usize], coarse.dyadic[i as usize]);
    let key = coarse.keys[c as usize];
    let ring = &topo.neighbours[c as usize];
    match even_kind(base, key) {
        EvenKind::Fixed => coarse.params[c as usize],
        EvenKind::Crease => {
            let Some((chain, [prev, next])) = crease_chain(base, coarse, topo, c) else {
                stats.fallbacks += 1;
                return coarse.params[c as usize];
            };
            combine_1d(
                base,
                &chain,
                &[point(prev), point(c), point(next)],
                &CREASE_EVEN_WEIGHTS,
                stats,
            )
        }
        EvenKind::Interior => {
            let (w0, beta) = even_weights(ring.len(), options.beta);
            let mut pts = vec![point(c)];
            pts.extend(ring.iter().map(|&n| point(n)));
            let mut weights = vec![w0];
            weights.extend(std::iter::repeat_n(beta, ring.len()));
            combine_2d(base, root_chart(base, key), &pts, &weights, options, stats)
        }
    }
}

/// The root chart of a net vertex's stencil, from its dyadic place (module docs): its base
/// vertex's flattened ring, its base edge's hinge, or its base face.
pub(super) fn root_chart(base: &BaseDomain, key: VKey) -> Chart {
    match key {
        VKey::Vertex(v) => Chart::vertex(base, v, base.star[v as usize][0]),
        VKey::Edge { lo, hi, .. } => Chart::edge(base, lo, hi),
        VKey::Face { t, .. } => Chart::face(base, t),
    }
}

/// For net vertex `c` on a crease: the crease polyline through it and its two neighbours along
/// the crease (`None` when it does not have exactly two).
pub(super) fn crease_chain(
    base: &BaseDomain,
    net: &ParamNet,
    topo: &Topology,
    c: u32,
) -> Option<(Chain, [u32; 2])> {
    let key = net.keys[c as usize];
    let along: Vec<u32> = topo.neighbours[c as usize]
        .iter()
        .copied()
        .filter(|&n| {
            base_edge_of(base, key, net.keys[n as usize]).is_some_and(|(p, q)| base.is_crease(p, q))
        })
        .collect();
    let [prev, next] = along[..] else {
        return None;
    };
    let middle = match key {
        VKey::Vertex(v) => {
            let cn = &base.crease_neighbours[v as usize];
            vec![cn[0], v, cn[1]]
        }
        VKey::Edge { lo, hi, .. } => vec![lo, hi],
        VKey::Face { .. } => return None,
    };
    Some((Chain::through(base, &middle), [prev, next]))
}

/// One round: quadrisect the net and give every vertex of the finer net its Loop parameter.
fn refine(
    maps: &Maps,
    base: &BaseDomain,
    coarse: &ParamNet,
    options: &SmoothOptions,
) -> (ParamNet, SmoothStats) {
    let leaves: Vec<DyadicTri> = coarse.leaves.iter().flat_map(|t| t.children()).collect();
    let mut fine = ParamNet::dyadic(maps, leaves);
    let topo = topology(maps, coarse);
    let results: Vec<(BasePoint, SmoothStats)> = fine
        .keys
        .par_iter()
        .zip(&fine.dyadic)
        .map(|(&key, &dyadic)| stencil(base, coarse, &topo, (key, dyadic), options))
        .collect();
    let mut stats = SmoothStats::default();
    fine.params = results
        .into_iter()
        .map(|(p, s)| {
            stats.add(&s);
            p
        })
        .collect();
    (fine, stats)
}

/// The unsmoothed net of level `j` (parameters the dyadic points: the baseline). Error: `j` above
/// [`super::remesh::MAX_UNIFORM_LEVEL`].
pub fn dyadic_net(maps: &Maps, j: u32) -> Result<ParamNet> {
    Ok(ParamNet::dyadic(
        maps,
        super::remesh::uniform_leaves(maps, j)?,
    ))
}

/// The smoothed net of level `j`: the base domain (every base vertex at its own parameter)
/// refined by `j` rounds of Loop's rules in the parameter domain (module docs). Error: `j`
/// above [`super::remesh::MAX_UNIFORM_LEVEL`].
pub fn smoothed_net(
    maps: &Maps,
    j: u32,
    options: &SmoothOptions,
) -> Result<(ParamNet, SmoothStats)> {
    check_level(j)?;
    let base = BaseDomain::new(maps, options.corner_turn);
    let mut net = ParamNet::dyadic(
        maps,
        (0..maps.base_faces.len() as u32)
            .map(DyadicTri::base)
            .collect(),
    );
    let mut stats = SmoothStats::default();
    for _ in 0..j {
        let (next, s) = refine(maps, &base, &net, options);
        net = next;
        stats.add(&s);
    }
    Ok((net, stats))
}

/// A smoothed remesh and what happened to its stencils.
#[derive(Clone, Debug)]
pub struct Smoothed {
    /// The remesh: vertices Π⁻¹ of the smoothed parameters, `params` the smoothed parameters.
    pub remesh: Remesh,
    /// Stencil counts ([`SmoothStats`]).
    pub stats: SmoothStats,
}

/// [`uniform_smoothed_with`] with the default options.
pub fn uniform_smoothed(maps: &Maps, j: u32) -> Result<Remesh> {
    uniform_smoothed_with(maps, j, &SmoothOptions::default()).map(|s| s.remesh)
}

/// The smoothed uniform remesh of level `j`: the connectivity and vertex numbering of
/// [`super::remesh::uniform`] (4^j F₀ faces), vertex i at Π⁻¹(u_i) with u_i the parameter of
/// [`smoothed_net`] instead of the dyadic point; Hausdorff distance as for every remesh.
pub fn uniform_smoothed_with(maps: &Maps, j: u32, options: &SmoothOptions) -> Result<Smoothed> {
    let (net, stats) = smoothed_net(maps, j, options)?;
    let (positions, unmapped) = net.positions(maps);
    let name = format!("{} (smoothed uniform remesh j={j})", maps.name);
    let remesh = finish(maps, name, positions, net.faces, net.params, unmapped);
    Ok(Smoothed { remesh, stats })
}
