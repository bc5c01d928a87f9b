//! Twin of `gpu/shaders/skinsimp_quadrics.wgsl` (the source quadrics, `skinsimp_plane_quadrics`),
//! function for function: Garland–Heckbert plane quadrics w q qᵀ per source and pose (seed 003
//! §4, per pose), a face's plane weighted by its area and each boundary edge's constraint plane
//! perpendicular to the face, weighted by `boundary_weight · |e|²`.

use super::coverage::{branches, hit, taken, Branch};
use super::real::{cross, dot, length, Real, V3};

/// `skinsimp_quadrics.source`'s branches ([`super::coverage`]).
pub const SOURCE_BRANCHES: &[Branch] = branches![
    "skinsimp_quadrics.source.face" => "a face source: the face's own plane, weight = its area",
    "skinsimp_quadrics.source.edge0" => "a boundary constraint on edge (corner 0, corner 1)",
    "skinsimp_quadrics.source.edge1" => "a boundary constraint on edge (corner 1, corner 2)",
    "skinsimp_quadrics.source.edge2" => "a boundary constraint on edge (corner 2, corner 0)",
    "skinsimp_quadrics.triangle.degenerate" => "a face of zero area (|n| = 0): the zero quadric",
    "skinsimp_quadrics.normal.degenerate" => "a constraint's face of zero area: unit normal 0",
    "skinsimp_quadrics.constraint.degenerate" => "a constraint whose edge × normal = 0: the zero quadric",
];

/// `skinsimp_quadrics.vertex`'s branches ([`super::coverage`]).
pub const VERTEX_BRANCHES: &[Branch] = branches![
    "skinsimp_quadrics.vertex.sources" => "a vertex with sources: their quadrics summed entry by entry",
    "skinsimp_quadrics.vertex.none" => "a vertex without sources: the zero quadric",
];

/// `SOURCE_FACE`: a source of this kind is its face's own plane; 0, 1, 2 name the edge
/// (corner e, corner e + 1 mod 3) of a boundary constraint.
pub const SOURCE_FACE: u32 = 3;

/// `Quadric`: the upper triangle of the symmetric 4 × 4 matrix, row by row.
pub type Quadric<R> = [R; 10];

/// `from_plane`: w · q qᵀ for q = (n, d), entry (r, c ≥ r) = (w q_r) q_c.
pub fn from_plane<R: Real>(n: V3<R>, d: R, w: R) -> Quadric<R> {
    let q = [n.x, n.y, n.z, d];
    let mut out = [R::lit(0.0); 10];
    let mut k = 0;
    for r in 0..4 {
        for c in r..4 {
            out[k] = w * q[r] * q[c];
            k += 1;
        }
    }
    out
}

/// `zero_quadric`.
pub fn zero_quadric<R: Real>() -> Quadric<R> {
    [R::lit(0.0); 10]
}

/// `from_triangle`: area · q qᵀ, q = (n, −n·p0), zero for a degenerate triangle.
pub fn from_triangle<R: Real>(p0: V3<R>, p1: V3<R>, p2: V3<R>) -> Quadric<R> {
    let c = cross(p1 - p0, p2 - p0);
    let twice_area = length(c.to_array());
    if twice_area.value() == 0.0 {
        hit("skinsimp_quadrics.triangle.degenerate");
        return zero_quadric();
    }
    let n = c / twice_area;
    from_plane(
        n,
        -dot(n.to_array(), p0.to_array()),
        R::lit(0.5) * twice_area,
    )
}

/// `unit_normal`: the unit normal of (p0, p1, p2), zero when degenerate.
pub fn unit_normal<R: Real>(p0: V3<R>, p1: V3<R>, p2: V3<R>) -> V3<R> {
    let c = cross(p1 - p0, p2 - p0);
    let n = length(c.to_array());
    if n.value() == 0.0 {
        hit("skinsimp_quadrics.normal.degenerate");
        return V3::splat(R::lit(0.0));
    }
    c / n
}

/// `edge_constraint`: the plane through (p0, p1) perpendicular to the face (unit normal
/// `face_n`), weighted by `weight · |p1 − p0|²`; zero for a degenerate edge or face.
pub fn edge_constraint<R: Real>(p0: V3<R>, p1: V3<R>, face_n: V3<R>, weight: R) -> Quadric<R> {
    let e = p1 - p0;
    let m = cross(e, face_n);
    let len = length(m.to_array());
    if len.value() == 0.0 {
        hit("skinsimp_quadrics.constraint.degenerate");
        return zero_quadric();
    }
    let n = m / len;
    from_plane(
        n,
        -dot(n.to_array(), p0.to_array()),
        weight * dot(e.to_array(), e.to_array()),
    )
}

/// The body of `skinsimp_plane_quadrics` for one source of `kind` with posed corners `p`.
pub fn plane_quadric<R: Real>(kind: u32, p: [V3<R>; 3], boundary_weight: R) -> Quadric<R> {
    if kind == SOURCE_FACE {
        hit("skinsimp_quadrics.source.face");
        return from_triangle(p[0], p[1], p[2]);
    }
    let e = kind as usize;
    hit(match e {
        0 => "skinsimp_quadrics.source.edge0",
        1 => "skinsimp_quadrics.source.edge1",
        _ => "skinsimp_quadrics.source.edge2",
    });
    let normal = unit_normal(p[0], p[1], p[2]);
    edge_constraint(p[e], p[(e + 1) % 3], normal, boundary_weight)
}

/// The body of `skinsimp_vertex_quadrics`: Σ of the vertex's source quadrics, in the given
/// order, entry by entry (a sum a compiler may reorder).
pub fn vertex_quadric<R: Real>(sources: &[Quadric<R>]) -> Quadric<R> {
    let mut out = zero_quadric();
    taken(
        !sources.is_empty(),
        "skinsimp_quadrics.vertex.sources",
        "skinsimp_quadrics.vertex.none",
    );
    for (k, entry) in out.iter_mut().enumerate() {
        let terms: Vec<R> = sources.iter().map(|q| q[k]).collect();
        if !terms.is_empty() {
            *entry = R::sum(&terms);
        }
    }
    out
}
