//! Twin of `gpu/shaders/maps_priority.wgsl` (with the `sector_count` of `maps_rings.wgsl`),
//! function for function: the MAPS priority terms of one ordered 1-ring, the star's area a(i)
//! and the curvature magnitude κ(i) = |κ₁| + |κ₂| of a local quadric fit (seed 002
//! "Constructing the Mesh Hierarchies (2/5)", "Notation (4/4)"; notes maps.md "Hierarchy"; f64
//! reference [`crate::maps::priority`]).
//!
//! The star of vertex i is the fan of triangles (p_i, p_{j_m}, p_{j_{m+1}}) over the ring's
//! sectors: K of them for a closed ring (disk, feature line), K − 1 for a boundary vertex's
//! open ring (half disk).

use super::coverage::{branches, hit, taken, Branch};
use super::real::{abs, cross, dot, length, max, normalize, sqrt, sum, Real, V3};

/// `maps_priority`'s branches ([`super::coverage`]).
pub const BRANCHES: &[Branch] = branches![
    "maps_rings.open" => "a half disk: K − 1 sectors (the ring is open at j_{K−1} → j_0)",
    "maps_rings.closed" => "a disk or a feature line: K sectors (the closing sector j_{K−1} → j_0)",
    "maps_priority.normal.degenerate" => "|N| = 0 (or NaN), or K < 3: κ = 0",
    "maps_priority.helper.x" => "the frame's helper h = (1, 0, 0) (|n_x| < 0.9)",
    "maps_priority.helper.y" => "the frame's helper h = (0, 1, 0) (|n_x| ≥ 0.9)",
    "maps_priority.scale.zero" => "ℓ = max |p_{j_k} − p_i| = 0 (or NaN): κ = 0",
    "maps_priority.fit.singular" => "det M = 0 (or NaN): κ = 0",
    "maps_priority.fit.solved" => "det M ≠ 0: (A', B', C') = adj(M) b / det M",
    "maps_priority.kappa.not_finite" => "κ not below f32::MAX (∞ or NaN): κ = 0",
];

/// `KIND_DISK`: a closed ring, K sectors.
pub const KIND_DISK: u32 = 0;
/// `KIND_HALF_DISK`: a boundary vertex's open ring, K − 1 sectors.
pub const KIND_HALF_DISK: u32 = 1;
/// `KIND_FEATURE_LINE`: a closed ring cut by two feature edges, K sectors.
pub const KIND_FEATURE_LINE: u32 = 2;

/// One ring as `maps_priority` and `maps_flatten` read it (`RingHeader` of `maps_rings.wgsl`
/// with the positions it points at): the centre p_i, the ring vertices p_{j_0} … p_{j_{K−1}}
/// (counter-clockwise), the ring's kind and, for a feature line, the ring positions s < t of
/// its two feature neighbours (0 otherwise).
#[derive(Clone, Debug)]
pub struct Ring<R> {
    pub centre: V3<R>,
    pub points: Vec<V3<R>>,
    pub kind: u32,
    pub s: usize,
    pub t: usize,
}

/// `sector_count` (`maps_rings.wgsl`): K sectors (j_m, j_{m+1 mod K}) when closed, K − 1 for a half disk.
pub fn sector_count<R>(h: &Ring<R>) -> usize {
    if taken(
        h.kind == KIND_HALF_DISK,
        "maps_rings.open",
        "maps_rings.closed",
    ) {
        return h.points.len() - 1;
    }
    h.points.len()
}

/// `ring_point`: p_{j_{m mod K}}.
pub fn ring_point<R: Real>(h: &Ring<R>, m: usize) -> V3<R> {
    h.points[m % h.points.len()]
}

/// `triangle_area`: ½|(q − p) × (r − p)|.
pub fn triangle_area<R: Real>(p: V3<R>, q: V3<R>, r: V3<R>) -> R {
    R::lit(0.5) * length(cross(q - p, r - p).to_array())
}

/// `ring_area`: a(i) = Σ over the star's triangles of ½|(q − p) × (r − p)| (seed 2/5), summed
/// in sector order from 0.
pub fn ring_area<R: Real>(h: &Ring<R>) -> R {
    let p = h.centre;
    let mut area = R::lit(0.0);
    for m in 0..sector_count(h) {
        area = area + triangle_area(p, ring_point(h, m), ring_point(h, m + 1));
    }
    area
}

/// `star_normal`: the area-weighted normal Σ (q − p) × (r − p) of the star (not normalised).
pub fn star_normal<R: Real>(h: &Ring<R>) -> V3<R> {
    let p = h.centre;
    let mut n = V3::splat(R::lit(0.0));
    for m in 0..sector_count(h) {
        n = n + cross(ring_point(h, m) - p, ring_point(h, m + 1) - p);
    }
    n
}

/// A 3 × 3 matrix as WGSL's `mat3x3<f32>`: three columns.
pub type Mat3<R> = [V3<R>; 3];

/// `determinant(m)`: the six products of the rule of Sarrus, m₀₀(m₁₁m₂₂ − …), as one sum (a
/// compiler may expand and add them in any order; the sum's bound covers every order).
pub fn determinant<R: Real>(m: &Mat3<R>) -> R {
    let c = m.map(|v| v.to_array());
    sum(&[
        c[0][0] * c[1][1] * c[2][2],
        c[1][0] * c[2][1] * c[0][2],
        c[2][0] * c[0][1] * c[1][2],
        -(c[2][0] * c[1][1] * c[0][2]),
        -(c[1][0] * c[0][1] * c[2][2]),
        -(c[0][0] * c[2][1] * c[1][2]),
    ])
}

/// `transpose(mat3x3(m₁ × m₂, m₂ × m₀, m₀ × m₁)) * rhs`: adj(M) rhs, whose entry i is the dot
/// product of the cross product of M's other two columns (in cyclic order) with rhs.
pub fn adjugate_times<R: Real>(m: &Mat3<R>, rhs: V3<R>) -> V3<R> {
    let rows = [cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])];
    V3::from_array(rows.map(|r| dot(r.to_array(), rhs.to_array())))
}

/// `curvature`: κ = |κ₁| + |κ₂| of the least-squares fit z = A x² + B xy + C y² of the ring
/// vertices in the frame (e₁, e₂, n) at p_i (seed "Notation (4/4)"), in coordinates divided by
/// the ring's largest radius ℓ (A = A'/ℓ, …): normal equations M c = rhs with rows
/// (x², xy, y²), c = adj(M) rhs / det M, κ₁,₂ = (A + C) ± √((A − C)² + B²). 0 when the normal
/// or M is degenerate, or κ is not finite.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(len > 0)` is meant: NaN is degenerate too
pub fn curvature<R: Real>(h: &Ring<R>, normal: V3<R>) -> R {
    let zero = R::lit(0.0);
    let len = length(normal.to_array());
    if !(len.value() > 0.0) || h.points.len() < 3 {
        hit("maps_priority.normal.degenerate");
        return zero;
    }
    let n = normal / len;
    let mut helper = V3::new(zero, R::lit(1.0), zero);
    if taken(
        abs(n.x).value() < 0.9,
        "maps_priority.helper.x",
        "maps_priority.helper.y",
    ) {
        helper = V3::new(R::lit(1.0), zero, zero);
    }
    let e1 = normalize(cross(n, helper));
    let e2 = cross(n, e1);
    let p = h.centre;
    let mut scale = zero;
    for m in 0..h.points.len() {
        scale = max(scale, length((ring_point(h, m) - p).to_array()));
    }
    if !(scale.value() > 0.0) {
        hit("maps_priority.scale.zero");
        return zero;
    }
    let mut mat: Mat3<R> = [V3::splat(zero); 3];
    let mut rhs = V3::splat(zero);
    for k in 0..h.points.len() {
        let d = (ring_point(h, k) - p) / scale;
        let x = dot(d.to_array(), e1.to_array());
        let y = dot(d.to_array(), e2.to_array());
        let z = dot(d.to_array(), n.to_array());
        let row = V3::new(x * x, x * y, y * y);
        mat = [
            mat[0] + row * row.x,
            mat[1] + row * row.y,
            mat[2] + row * row.z,
        ];
        rhs = rhs + row * z;
    }
    let det = determinant(&mat);
    if !taken(
        abs(det).value() > 0.0,
        "maps_priority.fit.solved",
        "maps_priority.fit.singular",
    ) {
        return zero;
    }
    let coef = adjugate_times(&mat, rhs) / det;
    let a = coef.x / scale;
    let b = coef.y / scale;
    let c = coef.z / scale;
    kappa_of(a, b, c)
}

/// The end of `curvature`: mean = A + C, dev = √((A − C)² + B²), κ = |mean + dev| +
/// |mean − dev|, 0 unless κ < f32::MAX (NaN and ∞ fail the comparison).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn kappa_of<R: Real>(a: R, b: R, c: R) -> R {
    let mean = a + c;
    let dev = sqrt((a - c) * (a - c) + b * b);
    let kappa = abs(mean + dev) + abs(mean - dev);
    if !(kappa.value() < 3.4028234e38) {
        hit("maps_priority.kappa.not_finite");
        return R::lit(0.0);
    }
    kappa
}

/// The body of `maps_priority` for one ring: `PriorityTerms(ring_area(h),
/// curvature(h, star_normal(h)))`, as [a(i), κ(i)].
pub fn priority_terms<R: Real>(h: &Ring<R>) -> [R; 2] {
    [ring_area(h), curvature(h, star_normal(h))]
}
