//! Remeshing through Π⁻¹ (notes "Smoothing and remeshing"; seed "Remeshing (1/5)–(5/5)"):
//! uniform quadrisection of every base triangle j times, and adaptive refinement while the
//! error E(t)/B exceeds ε, with red-green closing of T-junctions. Vertices are Π⁻¹ of dyadic
//! barycentric points of the base triangles (the unsmoothed, midpoint parameterisation).
//!
//! A remesh vertex is named by its exact dyadic parameter ([`VKey`]): a base vertex, a point of
//! a base edge, or a point inside a base face, so neighbouring base faces share their edge
//! vertices and the remesh is conforming.

use std::collections::HashMap;

use nalgebra::Point3;
use rayon::prelude::*;

use super::param::BasePoint;
use super::quality::{remesh_quality, RemeshQuality};
use super::retriangulate::locate;
use super::Maps;
use crate::error::{Error, Result};
use crate::mesh::distance::{point_triangle_distance, Hausdorff};
use crate::mesh::TriMesh;

/// The exact parameter of a remesh vertex, reduced to its coarsest dyadic depth.
#[derive(Clone, Copy, Debug, Hash, PartialEq, Eq, PartialOrd, Ord)]
pub enum VKey {
    /// A base vertex (input vertex index).
    Vertex(u32),
    /// On base edge (lo, hi): the barycentric coordinate of `hi` is m / 2^depth.
    Edge {
        lo: u32,
        hi: u32,
        m: u32,
        depth: u32,
    },
    /// Inside base face t: barycentrics (·, b, c) / 2^depth.
    Face { t: u32, b: u32, c: u32, depth: u32 },
}

/// A dyadic triangle of a base face: integer barycentrics of its corners at `depth`
/// (each corner's three integers sum to 2^depth), counter-clockwise like the base face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DyadicTri {
    /// Base face.
    pub t: u32,
    /// Subdivision depth.
    pub depth: u32,
    /// Corner barycentrics × 2^depth.
    pub corners: [[u32; 3]; 3],
}

impl DyadicTri {
    /// The base face itself (depth 0).
    pub fn base(t: u32) -> Self {
        DyadicTri {
            t,
            depth: 0,
            corners: [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
        }
    }

    /// The four children of the quadrisection (corner triangles at A, B, C, then the middle
    /// one), counter-clockwise. Corners are doubled, midpoints are sums.
    pub fn children(&self) -> [DyadicTri; 4] {
        let [a, b, c] = self.corners.map(|p| p.map(|x| 2 * x));
        let mid =
            |p: [u32; 3], q: [u32; 3]| [(p[0] + q[0]) / 2, (p[1] + q[1]) / 2, (p[2] + q[2]) / 2];
        let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
        let d = self.depth + 1;
        let make = |corners| DyadicTri {
            t: self.t,
            depth: d,
            corners,
        };
        [
            make([a, ab, ca]),
            make([ab, b, bc]),
            make([ca, bc, c]),
            make([ab, bc, ca]),
        ]
    }

    /// The midpoint of edge e (corner e → corner e+1) at depth + 1.
    pub(crate) fn edge_midpoint(&self, e: usize) -> [u32; 3] {
        let p = self.corners[e];
        let q = self.corners[(e + 1) % 3];
        [p[0] + q[0], p[1] + q[1], p[2] + q[2]]
    }

    /// The quarter points of edge e at depth + 2.
    fn edge_quarters(&self, e: usize) -> [[u32; 3]; 2] {
        let p = self.corners[e];
        let q = self.corners[(e + 1) % 3];
        [
            [3 * p[0] + q[0], 3 * p[1] + q[1], 3 * p[2] + q[2]],
            [p[0] + 3 * q[0], p[1] + 3 * q[1], p[2] + 3 * q[2]],
        ]
    }

    /// Corner k as a point of the (β₁, β₂) chart of the base face.
    fn corner_2d(&self, k: usize) -> [f64; 2] {
        let s = (1u64 << self.depth) as f64;
        [self.corners[k][1] as f64 / s, self.corners[k][2] as f64 / s]
    }
}

/// The canonical key of integer barycentrics `p` at `depth` in base face `t`.
pub fn vkey(base_faces: &[[u32; 3]], t: u32, p: [u32; 3], depth: u32) -> VKey {
    let (mut p, mut depth) = (p, depth);
    while depth > 0 && p.iter().all(|x| x % 2 == 0) {
        p = p.map(|x| x / 2);
        depth -= 1;
    }
    let corners = base_faces[t as usize];
    let nonzero: Vec<usize> = (0..3).filter(|&c| p[c] != 0).collect();
    match nonzero.as_slice() {
        [c] => VKey::Vertex(corners[*c]),
        [c1, c2] => {
            let (v1, v2) = (corners[*c1], corners[*c2]);
            let (lo, hi, m) = if v1 < v2 {
                (v1, v2, p[*c2])
            } else {
                (v2, v1, p[*c1])
            };
            VKey::Edge { lo, hi, m, depth }
        }
        _ => VKey::Face {
            t,
            b: p[1],
            c: p[2],
            depth,
        },
    }
}

/// A remesh with its error figures.
#[derive(Clone, Debug)]
pub struct Remesh {
    /// The remeshed surface (vertices Π⁻¹ of dyadic base points).
    pub mesh: TriMesh,
    /// For each remesh vertex, its base point.
    pub params: Vec<BasePoint>,
    /// Sampled two-sided Hausdorff distance to the input ([`crate::mesh::distance::hausdorff`]).
    pub hausdorff: Hausdorff,
    /// The input's bounding-box diagonal (to make distances relative).
    pub diagonal: f64,
    /// Remesh vertices whose Π⁻¹ found no input face (placed on the flat base triangle).
    pub unmapped: usize,
    /// Seconds spent on the distance figures, Hausdorff included (part of the caller's total;
    /// the paper's remesh times have no such measurement).
    pub hausdorff_seconds: f64,
    /// Mean distances, wrong-facing area and angles ([`super::quality`], issue #23).
    pub quality: RemeshQuality,
}

/// Faces 4^j F₀ and vertices V₀ + E₀(2^j − 1) + F₀(2^j − 1)(2^j − 2)/2 of a uniform remesh of
/// level j of a base domain with V₀ vertices, E₀ edges and F₀ faces (notes).
pub fn uniform_counts(v0: usize, e0: usize, f0: usize, j: u32) -> (usize, usize) {
    let n = 1usize << j;
    let faces = f0 * n * n;
    let verts = v0 + e0 * (n - 1) + f0 * (n - 1) * (n.saturating_sub(2)) / 2;
    (verts, faces)
}

/// The largest uniform level accepted (4^10 ≈ 10⁶ faces per base face).
pub const MAX_UNIFORM_LEVEL: u32 = 10;

/// Uniform remesh of level `j`: every base triangle quadrisected j times, vertices Π⁻¹ of the
/// dyadic points (notes; seed "Remeshing (1/5)"). Error: `j` above [`MAX_UNIFORM_LEVEL`].
pub fn uniform(maps: &Maps, j: u32) -> Result<Remesh> {
    let leaves = uniform_leaves(maps, j)?;
    Ok(assemble(
        maps,
        &leaves,
        format!("{} (uniform remesh j={j})", maps.name),
    ))
}

/// The dyadic triangles of the uniform remesh of level `j`: every base face quadrisected j
/// times, in base-face order, children in [`DyadicTri::children`] order (face i of
/// [`uniform`]'s mesh is leaf i). Error: `j` above [`MAX_UNIFORM_LEVEL`].
pub fn uniform_leaves(maps: &Maps, j: u32) -> Result<Vec<DyadicTri>> {
    check_level(j)?;
    let mut leaves: Vec<DyadicTri> = (0..maps.base_faces.len() as u32)
        .map(DyadicTri::base)
        .collect();
    for _ in 0..j {
        leaves = leaves.iter().flat_map(|t| t.children()).collect();
    }
    Ok(leaves)
}

/// Error unless `j` ≤ [`MAX_UNIFORM_LEVEL`].
pub(crate) fn check_level(j: u32) -> Result<()> {
    if j > MAX_UNIFORM_LEVEL {
        return Err(Error::InvalidArgument(format!(
            "uniform remesh level {j} is above {MAX_UNIFORM_LEVEL}"
        )));
    }
    Ok(())
}

/// Options of the adaptive remesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveOptions {
    /// Refine while E(t)/B > ε (B the longest bounding-box side). Default 0.01 (1%).
    pub epsilon: f64,
    /// Never subdivide deeper than this. Default 8.
    pub max_depth: u32,
}

impl Default for AdaptiveOptions {
    fn default() -> Self {
        AdaptiveOptions {
            epsilon: 0.01,
            max_depth: 8,
        }
    }
}

/// A leaf of the adaptive refinement with the input vertices whose Π lies in it.
struct Leaf {
    tri: DyadicTri,
    points: Vec<u32>,
}

/// Adaptive remesh (seed "Remeshing (4/5), (5/5)"; notes): starting from the base triangles,
/// quadrisect every triangle t with E(t)/B > ε, E(t) = max distance from the input vertices
/// whose Π lies in t to the remesh triangle of t (corners Π⁻¹ of t's corners), each vertex going
/// to the child that contains its parameter; then close: a triangle with two or three refined
/// neighbours, or a neighbour refined twice, is refined too (red), one with one refined
/// neighbour is bisected towards the hanging vertex (green). A green half that breaks the bound
/// makes its triangle red and the loop runs again. At the end every remesh triangle t satisfies
/// E(t) ≤ ε B unless `max_depth` stopped it. Errors: ε ≤ 0 or not finite.
pub fn adaptive(maps: &Maps, options: &AdaptiveOptions) -> Result<Remesh> {
    if !(options.epsilon > 0.0 && options.epsilon.is_finite()) {
        return Err(Error::InvalidArgument(format!(
            "adaptive remesh epsilon {} must be positive and finite",
            options.epsilon
        )));
    }
    let (lo, hi) = bbox(&maps.positions);
    let b = (hi - lo).max();
    let tol = options.epsilon * b;
    let mut leaves: Vec<Leaf> = (0..maps.base_faces.len() as u32)
        .map(|t| Leaf {
            tri: DyadicTri::base(t),
            points: Vec::new(),
        })
        .collect();
    for (v, &(f, _)) in maps.location.iter().enumerate() {
        if f != u32::MAX {
            leaves[f as usize].points.push(v as u32);
        }
    }
    let mut cache: HashMap<VKey, Point3<f64>> = HashMap::new();
    loop {
        let mut changed = false;
        // 1. Error-driven refinement to a fixed point.
        let mut k = 0;
        while k < leaves.len() {
            let split = leaves[k].tri.depth < options.max_depth
                && leaf_error(maps, &leaves[k].tri, &leaves[k].points, &mut cache) > tol;
            if split {
                split_leaf(maps, &mut leaves, k);
                changed = true;
            } else {
                k += 1;
            }
        }
        // 2. Red closing: two or more hanging midpoints, or a hanging quarter point.
        loop {
            let keys = vertex_keys(maps, &leaves);
            let mut red = false;
            let mut k = 0;
            while k < leaves.len() {
                let (hanging, deep) = hanging_edges(maps, &leaves[k].tri, &keys);
                if hanging.len() >= 2 || deep {
                    split_leaf(maps, &mut leaves, k);
                    red = true;
                    changed = true;
                } else {
                    k += 1;
                }
            }
            if !red {
                break;
            }
        }
        // 3. Green halves must meet the bound too.
        let keys = vertex_keys(maps, &leaves);
        let mut k = 0;
        while k < leaves.len() {
            let (hanging, _) = hanging_edges(maps, &leaves[k].tri, &keys);
            let bad = match hanging.as_slice() {
                [e] if leaves[k].tri.depth < options.max_depth => {
                    green_halves(&leaves[k].tri, *e).iter().any(|h| {
                        leaf_error(maps, h, &points_in(maps, h, &leaves[k].points), &mut cache)
                            > tol
                    })
                }
                _ => false,
            };
            if bad {
                split_leaf(maps, &mut leaves, k);
                changed = true;
            } else {
                k += 1;
            }
        }
        if !changed {
            break;
        }
    }
    let keys = vertex_keys(maps, &leaves);
    let mut tris = Vec::with_capacity(leaves.len());
    for leaf in &leaves {
        let (hanging, _) = hanging_edges(maps, &leaf.tri, &keys);
        match hanging.as_slice() {
            [] => tris.push(leaf.tri),
            [e] => tris.extend(green_halves(&leaf.tri, *e)),
            _ => unreachable!("red closing leaves at most one hanging midpoint"),
        }
    }
    let name = format!("{} (adaptive remesh eps={})", maps.name, options.epsilon);
    Ok(assemble(maps, &tris, name))
}

/// Replace leaf `k` by its four children (the first child takes slot k, the others are
/// appended), distributing its points by their parameter.
fn split_leaf(maps: &Maps, leaves: &mut Vec<Leaf>, k: usize) {
    let children = leaves[k].tri.children();
    let points = std::mem::take(&mut leaves[k].points);
    let mut lists: [Vec<u32>; 4] = Default::default();
    let chart: Vec<[f64; 2]> = (0..4)
        .flat_map(|c| (0..3).map(move |i| (c, i)))
        .map(|(c, i)| children[c].corner_2d(i))
        .collect();
    let tris: Vec<[usize; 3]> = (0..4).map(|c| [3 * c, 3 * c + 1, 3 * c + 2]).collect();
    for p in points {
        let (_, beta) = maps.location[p as usize];
        let (c, _) = locate([beta[1], beta[2]], &chart, &tris);
        lists[c].push(p);
    }
    let [l0, l1, l2, l3] = lists;
    leaves[k] = Leaf {
        tri: children[0],
        points: l0,
    };
    for (tri, points) in children[1..].iter().zip([l1, l2, l3]) {
        leaves.push(Leaf { tri: *tri, points });
    }
}

/// The points of `points` whose parameter lies in the dyadic triangle `tri` (closed).
fn points_in(maps: &Maps, tri: &DyadicTri, points: &[u32]) -> Vec<u32> {
    let c = [tri.corner_2d(0), tri.corner_2d(1), tri.corner_2d(2)];
    points
        .iter()
        .copied()
        .filter(|&p| {
            let (_, beta) = maps.location[p as usize];
            let l = super::retriangulate::barycentric([beta[1], beta[2]], c[0], c[1], c[2]);
            l.iter().all(|&x| x >= 0.0)
        })
        .collect()
}

/// E(t) = max of two one-sided distances to the 3D triangle of t (corners Π⁻¹ of t's corners):
/// from the input vertices `points` whose Π lies in t (the paper's criterion, seed "Remeshing
/// (4/5)"), and from the surface points Π⁻¹ of t's three edge midpoints. The second term sees
/// what the first cannot: a triangle with few or no input vertices that cuts across the surface
/// (a sliver of a strongly distorted base face), whose midpoints lie far from it. Both are
/// vertices of the remesh once t is split, so refining until E(t) ≤ ε B bounds the distance
/// both ways at those samples.
fn leaf_error(
    maps: &Maps,
    tri: &DyadicTri,
    points: &[u32],
    cache: &mut HashMap<VKey, Point3<f64>>,
) -> f64 {
    let mut position = |corner: [u32; 3], depth: u32| {
        let key = vkey(&maps.base_faces, tri.t, corner, depth);
        *cache
            .entry(key)
            .or_insert_with(|| vertex_position(maps, tri.t, corner, depth).0)
    };
    let corners = [0, 1, 2].map(|k| position(tri.corners[k], tri.depth));
    let midpoints = [0, 1, 2].map(|e| position(tri.edge_midpoint(e), tri.depth + 1));
    let distance =
        |p: &Point3<f64>| point_triangle_distance(p, &corners[0], &corners[1], &corners[2]);
    let from_vertices = points
        .iter()
        .map(|&p| distance(&maps.positions[p as usize]))
        .fold(0.0, f64::max);
    midpoints.iter().map(distance).fold(from_vertices, f64::max)
}

/// The keys of all leaf corners.
fn vertex_keys(maps: &Maps, leaves: &[Leaf]) -> std::collections::HashSet<VKey> {
    leaves
        .iter()
        .flat_map(|l| {
            (0..3).map(move |k| vkey(&maps.base_faces, l.tri.t, l.tri.corners[k], l.tri.depth))
        })
        .collect()
}

/// The edges of `tri` whose midpoint is a vertex of another leaf, and whether some edge has a
/// quarter point that is one (a neighbour refined two levels deeper).
fn hanging_edges(
    maps: &Maps,
    tri: &DyadicTri,
    keys: &std::collections::HashSet<VKey>,
) -> (Vec<usize>, bool) {
    let mut hanging = Vec::new();
    let mut deep = false;
    for e in 0..3 {
        if keys.contains(&vkey(
            &maps.base_faces,
            tri.t,
            tri.edge_midpoint(e),
            tri.depth + 1,
        )) {
            hanging.push(e);
            deep |= tri
                .edge_quarters(e)
                .iter()
                .any(|q| keys.contains(&vkey(&maps.base_faces, tri.t, *q, tri.depth + 2)));
        }
    }
    (hanging, deep)
}

/// The green bisection of `tri` at the midpoint M of edge e = (P → Q), R opposite:
/// (P, M, R) and (M, Q, R), at depth + 1, counter-clockwise.
fn green_halves(tri: &DyadicTri, e: usize) -> [DyadicTri; 2] {
    let d = tri.depth + 1;
    let double = |p: [u32; 3]| p.map(|x| 2 * x);
    let p = double(tri.corners[e]);
    let q = double(tri.corners[(e + 1) % 3]);
    let r = double(tri.corners[(e + 2) % 3]);
    let m = tri.edge_midpoint(e);
    let make = |corners| DyadicTri {
        t: tri.t,
        depth: d,
        corners,
    };
    [make([p, m, r]), make([m, q, r])]
}

/// Π⁻¹ of a dyadic base point: the base vertex itself at a corner, else [`super::Param::inverse`];
/// `(position, found)`, falling back to the flat base triangle when no input face covers it.
fn vertex_position(maps: &Maps, t: u32, p: [u32; 3], depth: u32) -> (Point3<f64>, bool) {
    if let VKey::Vertex(v) = vkey(&maps.base_faces, t, p, depth) {
        return (maps.positions[v as usize], true);
    }
    place(maps, &dyadic_point(t, p, depth))
}

/// Π⁻¹ of a base point, `(position, found)`, falling back to the flat base triangle
/// Σ b_c P(corner_c) when no input face covers it.
pub(crate) fn place(maps: &Maps, point: &BasePoint) -> (Point3<f64>, bool) {
    match maps.param.inverse(point) {
        Some(sp) => (sp.position, true),
        None => {
            let corners = maps.base_faces[point.face as usize].map(|v| maps.positions[v as usize]);
            let b = point.bary;
            let flat =
                corners[0].coords * b[0] + corners[1].coords * b[1] + corners[2].coords * b[2];
            (Point3::from(flat), false)
        }
    }
}

/// One vertex per distinct [`VKey`] of `tris`, in order of first use: for each its (base face,
/// integer barycentrics, depth) as first met, and the faces as vertex indices.
pub(crate) type Indexed = (Vec<(u32, [u32; 3], u32)>, Vec<[u32; 3]>);

/// Number the corners of `tris` by their [`VKey`] ([`Indexed`]).
pub(crate) fn index_vertices(maps: &Maps, tris: &[DyadicTri]) -> Indexed {
    let mut index: HashMap<VKey, u32> = HashMap::new();
    let mut verts: Vec<(u32, [u32; 3], u32)> = Vec::new();
    let mut faces = Vec::with_capacity(tris.len());
    for tri in tris {
        let f = [0, 1, 2].map(|k| {
            let key = vkey(&maps.base_faces, tri.t, tri.corners[k], tri.depth);
            *index.entry(key).or_insert_with(|| {
                verts.push((tri.t, tri.corners[k], tri.depth));
                verts.len() as u32 - 1
            })
        });
        faces.push(f);
    }
    (verts, faces)
}

/// The base point of integer barycentrics `p` / 2^`depth` in base face `t`.
pub(crate) fn dyadic_point(t: u32, p: [u32; 3], depth: u32) -> BasePoint {
    let s = (1u64 << depth) as f64;
    BasePoint {
        face: t,
        bary: p.map(|x| x as f64 / s),
    }
}

/// Build the remesh from its triangles: vertices numbered by [`index_vertices`], positions by
/// Π⁻¹ of the dyadic points in parallel, then [`finish`].
fn assemble(maps: &Maps, tris: &[DyadicTri], name: String) -> Remesh {
    let (verts, faces) = index_vertices(maps, tris);
    let placed: Vec<(Point3<f64>, bool)> = verts
        .par_iter()
        .map(|&(t, p, d)| vertex_position(maps, t, p, d))
        .collect();
    let params = verts
        .iter()
        .map(|&(t, p, d)| dyadic_point(t, p, d))
        .collect();
    let unmapped = placed.iter().filter(|p| !p.1).count();
    let positions: Vec<Point3<f64>> = placed.into_iter().map(|p| p.0).collect();
    finish(maps, name, positions, faces, params, unmapped)
}

/// The remesh of placed vertices: the mesh, and its quality against the input
/// ([`remesh_quality`]: Hausdorff and mean distances, wrong-facing area, angles).
pub(crate) fn finish(
    maps: &Maps,
    name: String,
    positions: Vec<Point3<f64>>,
    faces: Vec<[u32; 3]>,
    params: Vec<BasePoint>,
    unmapped: usize,
) -> Remesh {
    let (lo, hi) = bbox(&maps.positions);
    let diagonal = (hi - lo).norm();
    let quality = remesh_quality(
        &positions,
        &faces,
        &maps.positions,
        &maps.input_faces,
        diagonal,
    );
    Remesh {
        mesh: TriMesh::with_shared_indices(name, positions, Vec::new(), faces),
        params,
        hausdorff: quality.distances.hausdorff,
        diagonal,
        unmapped,
        hausdorff_seconds: quality.distance_seconds,
        quality,
    }
}

fn bbox(points: &[Point3<f64>]) -> (Point3<f64>, Point3<f64>) {
    let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
    let mut hi = Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for p in points {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    (lo, hi)
}
