//! Retriangulating the flattened hole (notes "Retriangulating the hole"; seed 5/5): the
//! constrained Delaunay triangulation of the flattened 1-ring polygon with the `spade` crate,
//! the fan fallbacks, the local validity checks, and point location with robust predicates.

use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};

/// Robust orientation of (a, b, c): > 0 counter-clockwise, < 0 clockwise, exactly 0 collinear
/// (Shewchuk's adaptive predicate from the `robust` crate).
pub fn orient2d(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    robust::orient2d(
        robust::Coord { x: a[0], y: a[1] },
        robust::Coord { x: b[0], y: b[1] },
        robust::Coord { x: c[0], y: c[1] },
    )
}

/// The constrained Delaunay triangulation of the simple polygon `mu` (counter-clockwise, as
/// the flattened ring is: arg μ increases along the ring) whose edges, and the `chord` when
/// given, are constraints. Returns the K − 2 triangles inside the polygon as counter-clockwise
/// triples of polygon indices, or `None` when spade cannot build it (coincident points,
/// crossing constraints) or the result fails [`locally_valid`].
pub fn cdt_triangulation(
    mu: &[[f64; 2]],
    chord: Option<(usize, usize)>,
) -> Option<Vec<[usize; 3]>> {
    let k = mu.len();
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
    let mut handles = Vec::with_capacity(k);
    for p in mu {
        handles.push(cdt.insert(Point2::new(p[0], p[1])).ok()?);
    }
    if cdt.num_vertices() != k {
        return None; // two ring vertices flattened onto the same point
    }
    let mut index_of = vec![usize::MAX; k];
    for (m, h) in handles.iter().enumerate() {
        index_of[h.index()] = m;
    }
    let mut constraints: Vec<(usize, usize)> = (0..k).map(|m| (m, (m + 1) % k)).collect();
    if let Some(c) = chord {
        constraints.push(c);
    }
    for (a, b) in constraints {
        if cdt.exists_constraint(handles[a], handles[b]) {
            continue;
        }
        if !cdt.can_add_constraint(handles[a], handles[b]) {
            return None;
        }
        cdt.add_constraint(handles[a], handles[b]);
    }
    let mut tris = Vec::with_capacity(k - 2);
    for face in cdt.inner_faces() {
        let [a, b, c] = face.vertices().map(|v| index_of[v.fix().index()]);
        let centroid = [
            (mu[a][0] + mu[b][0] + mu[c][0]) / 3.0,
            (mu[a][1] + mu[b][1] + mu[c][1]) / 3.0,
        ];
        if inside_polygon(centroid, mu) {
            tris.push([a, b, c]);
        }
    }
    tris.sort_unstable();
    locally_valid(mu, &tris, chord).then_some(tris)
}

/// The fan of the polygon from vertex `apex`: (apex, apex+m, apex+m+1), m = 1 … K−2 (mod K).
/// The notes' fallback when the CDT result is rejected; checked with [`locally_valid`].
pub fn fan_triangulation(
    mu: &[[f64; 2]],
    apex: usize,
    chord: Option<(usize, usize)>,
) -> Option<Vec<[usize; 3]>> {
    let k = mu.len();
    let tris: Vec<[usize; 3]> = (1..k - 1)
        .map(|m| [apex, (apex + m) % k, (apex + m + 1) % k])
        .collect();
    locally_valid(mu, &tris, chord).then_some(tris)
}

/// Local validity of a hole triangulation: K − 2 triangles, each strictly counter-clockwise
/// (robust orient2d > 0, so no flipped or degenerate triangle), and the required `chord`
/// (feature or boundary edge) is an edge of some triangle.
pub fn locally_valid(mu: &[[f64; 2]], tris: &[[usize; 3]], chord: Option<(usize, usize)>) -> bool {
    if tris.len() + 2 != mu.len() {
        return false;
    }
    if tris
        .iter()
        .any(|&[a, b, c]| orient2d(mu[a], mu[b], mu[c]) <= 0.0)
    {
        return false;
    }
    match chord {
        None => true,
        Some((s, t)) => tris.iter().any(|tri| {
            (0..3).any(|e| {
                let (x, y) = (tri[e], tri[(e + 1) % 3]);
                (x, y) == (s, t) || (x, y) == (t, s)
            })
        }),
    }
}

/// Crossing-number point-in-polygon test (used for CDT triangle centroids, which are well
/// inside their triangle, so the plain floating-point test is reliable).
fn inside_polygon(p: [f64; 2], poly: &[[f64; 2]]) -> bool {
    let mut inside = false;
    let k = poly.len();
    for m in 0..k {
        let (a, b) = (poly[m], poly[(m + 1) % k]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// Barycentric coordinates of `u` in triangle (a, b, c): λ_a = orient(u, b, c)/orient(a, b, c)
/// and cyclically, with robust orientations (so a sign, in particular 0 on an edge, is exact).
pub fn barycentric(u: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> [f64; 3] {
    let area = orient2d(a, b, c);
    let l = [orient2d(u, b, c), orient2d(a, u, c), orient2d(a, b, u)];
    let sum = l[0] + l[1] + l[2];
    let norm = if sum != 0.0 { sum } else { area };
    [l[0] / norm, l[1] / norm, l[2] / norm]
}

/// Locate `u` in the triangles `tris` over the points `mu`: the first triangle (in the given,
/// deterministic order) whose three robust orientations are all ≥ 0; if rounding put `u` a hair
/// outside every triangle, the one with the largest smallest barycentric coordinate.
/// Returns (triangle index, barycentrics summing to 1).
pub fn locate(u: [f64; 2], mu: &[[f64; 2]], tris: &[[usize; 3]]) -> (usize, [f64; 3]) {
    let mut best = (0, [f64::NEG_INFINITY; 3], f64::NEG_INFINITY);
    for (n, &[a, b, c]) in tris.iter().enumerate() {
        let l = barycentric(u, mu[a], mu[b], mu[c]);
        let min = l[0].min(l[1]).min(l[2]);
        if min >= 0.0 {
            return (n, l);
        }
        if min > best.2 {
            best = (n, l, min);
        }
    }
    (best.0, best.1)
}

/// The triangulation of the polygon 0, 1, …, K−1 (counter-clockwise, the edge (K−1, 0)
/// always kept) that maximises the smallest `quality` of its triangles, among those whose
/// triangles (a, m, b), a < m < b, all have `quality(a, m, b)` = `Some(q)` and whose
/// diagonals (a, b) all pass `diagonal_ok(a, b)`; `None` when there is none. Dynamic
/// programming over sub-polygons (Klincsek 1980, the max–min triangulation of a polygon):
/// best(a, b) = max over a < m < b of min(q(a, m, b), best(a, m), best(m, b)),
/// best(a, a+1) = +∞, in O(K³). Triangles are returned counter-clockwise (a, m, b), sorted.
///
/// Beyond the paper (issue #23): the hierarchy's last resort when neither the CDT nor a fan of
/// a hole passes the checks ([`crate::maps::MapsOptions::best_triangulation`]).
pub fn best_triangulation(
    k: usize,
    quality: impl Fn(usize, usize, usize) -> Option<f64>,
    diagonal_ok: impl Fn(usize, usize) -> bool,
) -> Option<Vec<[usize; 3]>> {
    if k < 3 {
        return None;
    }
    let idx = |a: usize, b: usize| a * k + b;
    let mut best = vec![f64::NEG_INFINITY; k * k];
    let mut split = vec![usize::MAX; k * k];
    for a in 0..k - 1 {
        best[idx(a, a + 1)] = f64::INFINITY;
    }
    for len in 2..k {
        for a in 0..k - len {
            let b = a + len;
            if (a, b) != (0, k - 1) && !diagonal_ok(a, b) {
                continue;
            }
            for m in a + 1..b {
                let Some(q) = quality(a, m, b) else {
                    continue;
                };
                let v = q.min(best[idx(a, m)]).min(best[idx(m, b)]);
                if v > best[idx(a, b)] {
                    best[idx(a, b)] = v;
                    split[idx(a, b)] = m;
                }
            }
        }
    }
    if split[idx(0, k - 1)] == usize::MAX {
        return None;
    }
    let mut tris = Vec::with_capacity(k - 2);
    let mut stack = vec![(0, k - 1)];
    while let Some((a, b)) = stack.pop() {
        if b - a < 2 {
            continue;
        }
        let m = split[idx(a, b)];
        tris.push([a, m, b]);
        stack.push((a, m));
        stack.push((m, b));
    }
    tris.sort_unstable();
    Some(tris)
}
