//! Point-to-surface distances: the closest point of a triangle, a bounding-volume tree of our own
//! (exact minimum of [`point_triangle_distance`]) and a BVH
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

/// A bounding-volume tree over a triangle set for exact nearest-surface distances: triangles
/// are split at the median of their centroids along the longest side of the centroids' box
/// until at most [`SurfaceTree::LEAF`] remain; a query descends nearer box first and skips a box
/// farther than the best distance found. The minimum is the exact minimum of
/// [`point_triangle_distance`] over all triangles (a box is skipped only when every triangle in
/// it is farther, with a margin of a few ulps of the coordinates), and the cost of a query does
/// not depend on the coordinates' magnitudes: one vertex thrown to 2·10¹⁰ (a flipped bit in a
/// file, issue #25) adds a few long triangles to visit, where a uniform grid sized by the
/// bounding box put every other triangle in one cell and made each query linear.
pub struct SurfaceTree<'a> {
    positions: &'a [Point3<f64>],
    faces: &'a [[u32; 3]],
    /// Node 0 is the root (absent for an empty set).
    nodes: Vec<TreeNode>,
    /// Face ids, each leaf's a contiguous range.
    order: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct TreeNode {
    lo: [f64; 3],
    hi: [f64; 3],
    /// Leaf: `order[start..start + len]`. Inner node (`len == 0`): children `start`, `start + 1`.
    start: u32,
    len: u32,
}

impl<'a> SurfaceTree<'a> {
    /// Most triangles in a leaf.
    pub const LEAF: usize = 4;

    /// Build the tree (O(F log F)).
    pub fn new(positions: &'a [Point3<f64>], faces: &'a [[u32; 3]]) -> Self {
        let boxes: Vec<([f64; 3], [f64; 3])> = faces
            .iter()
            .map(|f| {
                let pts = f.map(|v| positions[v as usize]);
                let lo = [0, 1, 2].map(|a| pts[0][a].min(pts[1][a]).min(pts[2][a]));
                let hi = [0, 1, 2].map(|a| pts[0][a].max(pts[1][a]).max(pts[2][a]));
                (lo, hi)
            })
            .collect();
        let centre = |f: u32, a: usize| {
            let (lo, hi) = boxes[f as usize];
            0.5 * lo[a] + 0.5 * hi[a]
        };
        let mut order: Vec<u32> = (0..faces.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * faces.len() / Self::LEAF + 1);
        if faces.is_empty() {
            return SurfaceTree {
                positions,
                faces,
                nodes,
                order,
            };
        }
        nodes.push(TreeNode {
            lo: [0.0; 3],
            hi: [0.0; 3],
            start: 0,
            len: faces.len() as u32,
        });
        // (node, range of `order`) still to build.
        let mut pending = vec![(0usize, 0usize, faces.len())];
        while let Some((node, start, end)) = pending.pop() {
            let ids = &mut order[start..end];
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            let mut clo = [f64::INFINITY; 3];
            let mut chi = [f64::NEG_INFINITY; 3];
            for &f in ids.iter() {
                let (flo, fhi) = boxes[f as usize];
                for a in 0..3 {
                    lo[a] = lo[a].min(flo[a]);
                    hi[a] = hi[a].max(fhi[a]);
                    clo[a] = clo[a].min(centre(f, a));
                    chi[a] = chi[a].max(centre(f, a));
                }
            }
            nodes[node].lo = lo;
            nodes[node].hi = hi;
            if ids.len() <= Self::LEAF {
                nodes[node].start = start as u32;
                nodes[node].len = ids.len() as u32;
                continue;
            }
            let axis = (0..3)
                .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
                .unwrap_or(0);
            let mid = ids.len() / 2;
            // Ties broken by face id: the tree depends on the input only.
            ids.select_nth_unstable_by(mid, |&f, &g| {
                centre(f, axis).total_cmp(&centre(g, axis)).then(f.cmp(&g))
            });
            let children = nodes.len();
            for _ in 0..2 {
                nodes.push(TreeNode {
                    lo: [0.0; 3],
                    hi: [0.0; 3],
                    start: 0,
                    len: 0,
                });
            }
            nodes[node].start = children as u32;
            nodes[node].len = 0;
            pending.push((children, start, start + mid));
            pending.push((children + 1, start + mid, end));
        }
        SurfaceTree {
            positions,
            faces,
            nodes,
            order,
        }
    }

    /// Distance from `p` to the nearest triangle (∞ for an empty set).
    pub fn distance(&self, p: &Point3<f64>) -> f64 {
        self.distance_and_work(p).0
    }

    /// [`SurfaceTree::distance`] and the number of triangles it measured (the cost of the
    /// query, for tests that it stays small whatever the coordinates).
    pub fn distance_and_work(&self, p: &Point3<f64>) -> (f64, usize) {
        let mut best = f64::INFINITY;
        let mut work = 0;
        if self.nodes.is_empty() {
            return (best, work);
        }
        let mut stack = vec![(0u32, 0.0f64)];
        while let Some((n, gap)) = stack.pop() {
            let node = &self.nodes[n as usize];
            if gap > best {
                continue;
            }
            if node.len > 0 {
                let start = node.start as usize;
                for &f in &self.order[start..start + node.len as usize] {
                    let [a, b, c] = self.faces[f as usize].map(|v| self.positions[v as usize]);
                    best = best.min(point_triangle_distance(p, &a, &b, &c));
                    work += 1;
                }
                continue;
            }
            let (l, r) = (node.start, node.start + 1);
            let (gl, gr) = (self.gap(p, l), self.gap(p, r));
            // Nearer child on top of the stack (ties: the left one).
            if gl <= gr {
                stack.push((r, gr));
                stack.push((l, gl));
            } else {
                stack.push((l, gl));
                stack.push((r, gr));
            }
        }
        (best, work)
    }

    /// A lower bound of the distance from `p` to anything in node `n`'s box: the distance to
    /// the box less a margin of 16 ulps of the largest coordinate involved, so that rounding in
    /// [`point_triangle_distance`] never makes a skipped triangle the nearest one.
    fn gap(&self, p: &Point3<f64>, n: u32) -> f64 {
        let node = &self.nodes[n as usize];
        let mut d2 = 0.0;
        let mut scale: f64 = 0.0;
        for a in 0..3 {
            let d = (node.lo[a] - p[a]).max(p[a] - node.hi[a]).max(0.0);
            d2 += d * d;
            scale = scale
                .max(p[a].abs())
                .max(node.lo[a].abs())
                .max(node.hi[a].abs());
        }
        d2.sqrt() - 16.0 * f64::EPSILON * scale
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
/// One face of A compared with B: the largest distance at its samples, and the part of its
/// area (a quarter per sample) whose normal opposes B's there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FaceComparison {
    /// Largest distance to B over the face's four interior samples.
    pub max_distance: f64,
    /// Area of the face at whose samples n_A · n_B < 0 (0, ¼, ½, ¾ or all of the face's area).
    pub opposed_area: f64,
}

/// One direction of [`compare_surfaces`]: (largest distance, area-weighted mean distance,
/// opposed-area fraction), and each face's [`FaceComparison`].
fn one_way(
    from_p: &[Point3<f64>],
    from_f: &[[u32; 3]],
    to_p: &[Point3<f64>],
    to_f: &[[u32; 3]],
) -> ((f64, f64, f64), Vec<FaceComparison>) {
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
    let faces = per_face
        .iter()
        .map(|&(max_distance, _, opposed_area, _)| FaceComparison {
            max_distance,
            opposed_area,
        })
        .collect();
    let figures = if total > 0.0 {
        (max, weighted / total, opposed / total)
    } else {
        (max, 0.0, 0.0)
    };
    (figures, faces)
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
    compare_surfaces_per_face(a_positions, a_faces, b_positions, b_faces).0
}

/// [`compare_surfaces`], with each face of A's [`FaceComparison`] (in A's face order): where A
/// is far from B, and which of its faces face the wrong way.
pub fn compare_surfaces_per_face(
    a_positions: &[Point3<f64>],
    a_faces: &[[u32; 3]],
    b_positions: &[Point3<f64>],
    b_faces: &[[u32; 3]],
) -> (SurfaceComparison, Vec<FaceComparison>) {
    let ((ab_max, ab_mean, opposed), a_per_face) =
        one_way(a_positions, a_faces, b_positions, b_faces);
    let ((ba_max, ba_mean, _), _) = one_way(b_positions, b_faces, a_positions, a_faces);
    let comparison = SurfaceComparison {
        hausdorff: Hausdorff {
            a_to_b: ab_max,
            b_to_a: ba_max,
        },
        mean_a_to_b: ab_mean,
        mean_b_to_a: ba_mean,
        opposed_area_fraction: opposed,
    };
    (comparison, a_per_face)
}
