//! Point-to-surface distances: the closest point of a triangle, a uniform grid and a BVH
//! (parry3d's triangle mesh) for nearest-surface queries, the sampled two-sided Hausdorff
//! distance and the surface comparison of issue #23 (mean distances, area facing the wrong way).
//! Shared by the MAPS remesh errors (issues #5, #23) and the skinned-simplification errors
//! (issue #6).

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

/// Distance from `p` to the closed triangle (a, b, c): the Voronoi-region case analysis of
/// Ericson, *Real-Time Collision Detection* §5.1.5 (closest point on a triangle), exact for
/// degenerate triangles too (it falls through to an edge or a vertex).
pub fn point_triangle_distance(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> f64 {
    (p - closest_point_on_triangle(p, a, b, c)).norm()
}

/// The closest point of triangle (a, b, c) to `p` (Ericson §5.1.5).
pub fn closest_point_on_triangle(
    p: &Point3<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    c: &Point3<f64>,
) -> Point3<f64> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom == 0.0 {
        // Degenerate (collinear) triangle: the closest of its three edges.
        let edges = [(a, b), (b, c), (c, a)];
        return edges
            .iter()
            .map(|(x, y)| closest_on_segment(p, x, y))
            .min_by(|u, v| (p - u).norm().total_cmp(&(p - v).norm()))
            .expect("three edges");
    }
    let v = vb / denom;
    let w = vc / denom;
    a + ab * v + ac * w
}

fn closest_on_segment(p: &Point3<f64>, a: &Point3<f64>, b: &Point3<f64>) -> Point3<f64> {
    let d = b - a;
    let len2 = d.norm_squared();
    if len2 == 0.0 {
        return *a;
    }
    a + d * ((p - a).dot(&d) / len2).clamp(0.0, 1.0)
}

/// A uniform grid over a triangle set for nearest-surface queries: each triangle is listed in
/// every cell its bounding box touches; a query searches shells of cells around the query's cell
/// until the best distance found is below the distance to the next shell.
pub struct SurfaceGrid<'a> {
    positions: &'a [Point3<f64>],
    faces: &'a [[u32; 3]],
    lo: Point3<f64>,
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl<'a> SurfaceGrid<'a> {
    /// Build the grid with about one triangle per cell (cell side from the bounding box volume,
    /// at least 1/256 of the longest side).
    pub fn new(positions: &'a [Point3<f64>], faces: &'a [[u32; 3]]) -> Self {
        let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for f in faces {
            for &v in f {
                let p = positions[v as usize];
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
        }
        let ext: Vector3<f64> = hi - lo;
        let longest = ext.max().max(1e-300);
        // Surface-like sets: about one triangle per cell on a 2D sheet means a side of
        // longest/√F; never finer than longest/256 along an axis.
        let cell = (longest / (faces.len() as f64).sqrt().max(1.0)).max(longest / 256.0);
        let dims = [0, 1, 2].map(|a| ((ext[a] / cell).floor() as usize + 1).min(257));
        let index = |p: &Point3<f64>| {
            [0, 1, 2].map(|a| (((p[a] - lo[a]) / cell).floor().max(0.0) as usize).min(dims[a] - 1))
        };
        let mut counts = vec![0u32; dims[0] * dims[1] * dims[2] + 1];
        let mut ranges = Vec::with_capacity(faces.len());
        for f in faces {
            let pts = f.map(|v| positions[v as usize]);
            let mut flo = pts[0];
            let mut fhi = pts[0];
            for p in &pts[1..] {
                for a in 0..3 {
                    flo[a] = flo[a].min(p[a]);
                    fhi[a] = fhi[a].max(p[a]);
                }
            }
            let (i0, i1) = (index(&flo), index(&fhi));
            ranges.push((i0, i1));
            for x in i0[0]..=i1[0] {
                for y in i0[1]..=i1[1] {
                    for z in i0[2]..=i1[2] {
                        counts[(z * dims[1] + y) * dims[0] + x + 1] += 1;
                    }
                }
            }
        }
        for k in 1..counts.len() {
            counts[k] += counts[k - 1];
        }
        let mut fill = counts.clone();
        let mut items = vec![0u32; *counts.last().unwrap() as usize];
        for (f, (i0, i1)) in ranges.iter().enumerate() {
            for x in i0[0]..=i1[0] {
                for y in i0[1]..=i1[1] {
                    for z in i0[2]..=i1[2] {
                        let c = (z * dims[1] + y) * dims[0] + x;
                        items[fill[c] as usize] = f as u32;
                        fill[c] += 1;
                    }
                }
            }
        }
        SurfaceGrid {
            positions,
            faces,
            lo,
            cell,
            dims,
            start: counts,
            items,
        }
    }

    /// Distance from `p` to the nearest triangle.
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        // Clamping a query outside the grid to its nearest cell keeps the shell bound valid:
        // cells s+1 index steps away are still at least s cells away from p.
        let c = [0, 1, 2].map(|a| {
            (((p[a] - self.lo[a]) / self.cell).floor().max(0.0) as i64).min(self.dims[a] as i64 - 1)
        });
        let mut best = f64::INFINITY;
        let max_shell = self.dims.iter().max().copied().unwrap_or(1) as i64;
        for shell in 0..=max_shell {
            self.search_shell(p, c, shell, &mut best);
            // Every triangle not yet seen lies outside the searched block of cells, at least
            // `gap` away from p (a block side at the grid's edge has nothing beyond it).
            if best <= self.block_gap(p, c, shell) {
                break;
            }
        }
        best
    }

    /// The distance from p to the nearest side of the block of cells within Chebyshev index
    /// distance `shell` of cell `c` that has cells beyond it (∞ when the block covers the grid).
    fn block_gap(&self, p: &Point3<f64>, c: [i64; 3], shell: i64) -> f64 {
        let mut gap = f64::INFINITY;
        for a in 0..3 {
            if c[a] - shell > 0 {
                gap = gap.min(p[a] - (self.lo[a] + (c[a] - shell) as f64 * self.cell));
            }
            if c[a] + shell < self.dims[a] as i64 - 1 {
                gap = gap.min(self.lo[a] + (c[a] + shell + 1) as f64 * self.cell - p[a]);
            }
        }
        gap
    }

    /// Update `best` with the triangles of the cells at Chebyshev index distance exactly
    /// `shell` from cell `c`.
    fn search_shell(&self, p: &Point3<f64>, c: [i64; 3], shell: i64, best: &mut f64) {
        let range = |a: usize| (c[a] - shell).max(0)..=(c[a] + shell).min(self.dims[a] as i64 - 1);
        for x in range(0) {
            for y in range(1) {
                for z in range(2) {
                    let on_shell = (x - c[0]).abs() == shell
                        || (y - c[1]).abs() == shell
                        || (z - c[2]).abs() == shell;
                    if !on_shell {
                        continue;
                    }
                    let cell = (z as usize * self.dims[1] + y as usize) * self.dims[0] + x as usize;
                    for &f in &self.items[self.start[cell] as usize..self.start[cell + 1] as usize]
                    {
                        let [a, b, cc] = self.faces[f as usize].map(|v| self.positions[v as usize]);
                        *best = best.min(point_triangle_distance(p, &a, &b, &cc));
                    }
                }
            }
        }
    }
}

/// Sample points of a triangle set: every vertex used by a face, and per face the centroid and
/// the three points halfway between the centroid and a corner (4 interior samples per face).
pub fn surface_samples(positions: &[Point3<f64>], faces: &[[u32; 3]]) -> Vec<Point3<f64>> {
    let mut used = vec![false; positions.len()];
    for f in faces {
        for &v in f {
            used[v as usize] = true;
        }
    }
    let mut out: Vec<Point3<f64>> = positions
        .iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(p, _)| *p)
        .collect();
    for f in faces {
        let [a, b, c] = f.map(|v| positions[v as usize]);
        let g = Point3::from((a.coords + b.coords + c.coords) / 3.0);
        out.push(g);
        for p in [a, b, c] {
            out.push(Point3::from((g.coords + p.coords) * 0.5));
        }
    }
    out
}

/// Two-sided sampled Hausdorff distance between surfaces A and B.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Hausdorff {
    /// max over samples of A of the distance to B.
    pub a_to_b: f64,
    /// max over samples of B of the distance to A.
    pub b_to_a: f64,
}

impl Hausdorff {
    /// max(a_to_b, b_to_a).
    pub fn max(&self) -> f64 {
        self.a_to_b.max(self.b_to_a)
    }
}

/// Sampled Hausdorff distance: each side's [`surface_samples`] (vertices, centroids and the
/// three centroid–corner midpoints of every face) measured exactly against the other side's
/// triangles (nearest triangle by [`SurfaceBvh`]). A lower bound of the true Hausdorff
/// distance, tight when the faces are small compared with the surfaces' features. Parallel,
/// order-independent (a max). [`compare_surfaces`] gives the same maxima and more.
pub fn hausdorff(
    a_positions: &[Point3<f64>],
    a_faces: &[[u32; 3]],
    b_positions: &[Point3<f64>],
    b_faces: &[[u32; 3]],
) -> Hausdorff {
    compare_surfaces(a_positions, a_faces, b_positions, b_faces).hausdorff
}

/// Where on its triangle a nearest point lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NearestFeature {
    /// Inside the triangle.
    Face,
    /// On the edge between these two vertices (mesh vertex indices).
    Edge(u32, u32),
    /// At this vertex (mesh vertex index).
    Vertex(u32),
}

/// The nearest point of a triangle set to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nearest {
    /// Index of the nearest triangle.
    pub face: u32,
    /// The part of that triangle it lies on.
    pub feature: NearestFeature,
    /// The closest point on it.
    pub point: Point3<f64>,
    /// |point − query|.
    pub distance: f64,
}

/// A bounding-volume hierarchy over a triangle set for nearest-surface queries: parry3d's
/// `TriMesh` (an AABB tree of the triangles, searched best-first with the box distance as the
/// bound), its triangle ids the indices into `faces`.
pub struct SurfaceBvh {
    mesh: Option<parry3d_f64::shape::TriMesh>,
}

impl SurfaceBvh {
    /// Build the BVH of `faces` over `positions` (an empty set gives a BVH that finds nothing).
    pub fn new(positions: &[Point3<f64>], faces: &[[u32; 3]]) -> Self {
        use parry3d_f64::math::Vector;
        let vertices: Vec<Vector> = positions
            .iter()
            .map(|p| Vector::new(p.x, p.y, p.z))
            .collect();
        // No flags: parry keeps the triangles as given (no merging, no removal), so its
        // triangle ids are our face indices.
        let mesh = parry3d_f64::shape::TriMesh::new(vertices, faces.to_vec()).ok();
        SurfaceBvh { mesh }
    }

    /// The nearest point of the triangle set to `p` (`None` when the set is empty or `p` is
    /// not finite).
    pub fn nearest(&self, p: &Point3<f64>) -> Option<Nearest> {
        use parry3d_f64::math::Vector;
        use parry3d_f64::shape::CompositeShapeRef;
        let mesh = self.mesh.as_ref()?;
        let q = Vector::new(p.x, p.y, p.z);
        use parry3d_f64::shape::TrianglePointLocation as L;
        let (face, proj, location) =
            CompositeShapeRef(mesh).project_local_point_and_get_location(q, f64::MAX, false)?;
        let point = Point3::new(proj.point.x, proj.point.y, proj.point.z);
        let distance = (point - p).norm();
        let t = mesh.indices()[face as usize];
        // parry's edge numbering: 0 = AB, 1 = BC, 2 = AC.
        let feature = match location {
            L::OnVertex(i) => NearestFeature::Vertex(t[i as usize]),
            L::OnEdge(0, _) => NearestFeature::Edge(t[0], t[1]),
            L::OnEdge(1, _) => NearestFeature::Edge(t[1], t[2]),
            L::OnEdge(_, _) => NearestFeature::Edge(t[0], t[2]),
            L::OnFace(..) | L::OnSolid => NearestFeature::Face,
        };
        distance.is_finite().then_some(Nearest {
            face,
            feature,
            point,
            distance,
        })
    }

    /// Distance from `p` to the nearest triangle (∞ when there is none).
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        self.nearest(p).map_or(f64::INFINITY, |n| n.distance)
    }
}

/// Two surfaces compared by sampling (issue #23): Hausdorff distances, area-weighted mean
/// distances, and the part of A's area whose normal opposes that of the nearest triangle of B.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct SurfaceComparison {
    /// Sampled Hausdorff distances ([`hausdorff`]).
    pub hausdorff: Hausdorff,
    /// Mean distance from A to B: Σ_f area_f · (mean over f's four interior samples of the
    /// distance to B) / Σ_f area_f — a four-point quadrature of (1/|A|) ∫_A d(x, B) dA.
    pub mean_a_to_b: f64,
    /// The same from B to A.
    pub mean_b_to_a: f64,
    /// Fraction of A's area (same quadrature) at whose samples the unit normal n_A of A's face
    /// and the pseudo-normal n_B of B at the nearest point (the face normal inside a face, the
    /// edge's or the vertex's angle-weighted pseudo-normal on an edge or at a vertex) satisfy
    /// n_A · n_B < 0: A faces the wrong way there.
    pub opposed_area_fraction: f64,
}

impl SurfaceComparison {
    /// max(mean_a_to_b, mean_b_to_a): the two-sided mean distance.
    pub fn mean(&self) -> f64 {
        self.mean_a_to_b.max(self.mean_b_to_a)
    }
}

/// Pseudo-normals of a triangle set (Bærentzen & Aanæs, "Signed distance computation using the
/// angle weighted pseudonormal", IEEE TVCG 2005): the unit face normal inside a face, the
/// normalised sum of the two face normals on an edge, the angle-weighted sum of the face
/// normals at a vertex. The side of a surface a point lies on, or the direction a surface
/// faces at its nearest point, is then well defined even when that point is on an edge or a
/// vertex (a crease, a thin ridge).
struct PseudoNormals<'a> {
    positions: &'a [Point3<f64>],
    faces: &'a [[u32; 3]],
    vertex: Vec<Vector3<f64>>,
    edge: std::collections::HashMap<(u32, u32), Vector3<f64>>,
}

impl<'a> PseudoNormals<'a> {
    fn new(positions: &'a [Point3<f64>], faces: &'a [[u32; 3]]) -> Self {
        let mut vertex = vec![Vector3::zeros(); positions.len()];
        let mut edge = std::collections::HashMap::new();
        for t in faces {
            let p = t.map(|v| positions[v as usize]);
            let Some(n) = (p[1] - p[0]).cross(&(p[2] - p[0])).try_normalize(0.0) else {
                continue;
            };
            for c in 0..3 {
                let (u, w) = (p[(c + 1) % 3] - p[c], p[(c + 2) % 3] - p[c]);
                let angle = u.cross(&w).norm().atan2(u.dot(&w));
                vertex[t[c] as usize] += n * angle;
                let (a, b) = (t[c], t[(c + 1) % 3]);
                *edge.entry((a.min(b), a.max(b))).or_insert(Vector3::zeros()) += n;
            }
        }
        PseudoNormals {
            positions,
            faces,
            vertex,
            edge,
        }
    }

    /// The unit pseudo-normal at a nearest point (`None` where it vanishes).
    fn at(&self, n: &Nearest) -> Option<Vector3<f64>> {
        match n.feature {
            NearestFeature::Face => {
                let [a, b, c] = self.faces[n.face as usize].map(|v| self.positions[v as usize]);
                (b - a).cross(&(c - a)).try_normalize(0.0)
            }
            NearestFeature::Edge(a, b) => self
                .edge
                .get(&(a.min(b), a.max(b)))
                .and_then(|v| v.try_normalize(0.0)),
            NearestFeature::Vertex(v) => self.vertex[v as usize].try_normalize(0.0),
        }
    }
}

/// One side of [`compare_surfaces`]: (max distance, mean distance, opposed area fraction) of
/// the samples of `from` measured against `to`.
fn one_way(
    from_p: &[Point3<f64>],
    from_f: &[[u32; 3]],
    to_p: &[Point3<f64>],
    to_f: &[[u32; 3]],
) -> (f64, f64, f64) {
    let bvh = SurfaceBvh::new(to_p, to_f);
    let unit_normal = |p: &[Point3<f64>], t: [u32; 3]| {
        let [a, b, c] = t.map(|v| p[v as usize]);
        (b - a).cross(&(c - a)).try_normalize(0.0)
    };
    let pseudo = PseudoNormals::new(to_p, to_f);
    // Per face (in parallel, collected in face order so that the sums below do not depend on
    // the thread count): (max over its interior samples, area · mean distance, opposed area).
    let per_face: Vec<(f64, f64, f64, f64)> = from_f
        .par_iter()
        .map(|&t| {
            let [a, b, c] = t.map(|v| from_p[v as usize]);
            let area = 0.5 * (b - a).cross(&(c - a)).norm();
            let n_from = unit_normal(from_p, t);
            let g = Point3::from((a.coords + b.coords + c.coords) / 3.0);
            let samples = [
                g,
                Point3::from((g.coords + a.coords) * 0.5),
                Point3::from((g.coords + b.coords) * 0.5),
                Point3::from((g.coords + c.coords) * 0.5),
            ];
            let (mut max, mut sum, mut opposed) = (0.0f64, 0.0, 0.0);
            for s in &samples {
                let Some(n) = bvh.nearest(s) else {
                    return (f64::INFINITY, f64::INFINITY, 0.0, area);
                };
                max = max.max(n.distance);
                sum += n.distance;
                let n_to = pseudo.at(&n);
                if let (Some(x), Some(y)) = (n_from, n_to) {
                    if x.dot(&y) < 0.0 {
                        opposed += area / 4.0;
                    }
                }
            }
            (max, area * sum / 4.0, opposed, area)
        })
        .collect();
    let mut used = vec![false; from_p.len()];
    for f in from_f {
        for &v in f {
            used[v as usize] = true;
        }
    }
    let vertex_max = from_p
        .par_iter()
        .zip(&used)
        .filter(|(_, &u)| u)
        .map(|(p, _)| bvh.distance(p))
        .reduce(|| 0.0, f64::max);
    let (mut max, mut weighted, mut opposed, mut total) = (vertex_max, 0.0, 0.0, 0.0);
    for &(m, w, o, a) in &per_face {
        max = max.max(m);
        weighted += w;
        opposed += o;
        total += a;
    }
    if total > 0.0 {
        (max, weighted / total, opposed / total)
    } else {
        (max, 0.0, 0.0)
    }
}

/// Compare surface A with surface B (issue #23): the sampled Hausdorff distances (samples of
/// [`surface_samples`]), the mean distances and the opposed-area fraction of A
/// ([`SurfaceComparison`]). Nearest triangles by [`SurfaceBvh`]. Parallel; every sum is taken
/// in face order, so the result does not depend on the thread count. An empty side gives
/// infinite distances from the other side.
pub fn compare_surfaces(
    a_positions: &[Point3<f64>],
    a_faces: &[[u32; 3]],
    b_positions: &[Point3<f64>],
    b_faces: &[[u32; 3]],
) -> SurfaceComparison {
    let (ab_max, ab_mean, opposed) = one_way(a_positions, a_faces, b_positions, b_faces);
    let (ba_max, ba_mean, _) = one_way(b_positions, b_faces, a_positions, a_faces);
    SurfaceComparison {
        hausdorff: Hausdorff {
            a_to_b: ab_max,
            b_to_a: ba_max,
        },
        mean_a_to_b: ab_mean,
        mean_b_to_a: ba_mean,
        opposed_area_fraction: opposed,
    }
}
