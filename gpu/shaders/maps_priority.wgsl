// maps_priority: the priority terms of MAPS (seed "Constructing the Mesh Hierarchies (2/5)",
// "Notation (4/4)"; notes maps.md "Hierarchy"), one invocation per ring. Prepended by the host:
// dispatch.wgsl, maps_rings.wgsl.
//
// Twin of src/maps/priority.rs: ring_area, triangle_area, star_normal, curvature. The star of
// vertex i is the fan of triangles (p_i, p_{j_m}, p_{j_{m+1}}) over the ring's sectors.
//
// One difference of implementation, not of formula: the curvature fit runs in coordinates
// divided by the ring's largest radius ℓ (x' = x/ℓ, …), so the normal equations' entries are
// O(1) instead of O(ℓ⁴) (f32 would underflow the 3×3 determinant, O(ℓ¹²), for ℓ ≲ 1e-3). The
// fitted coefficients scale as A = A'/ℓ, so κ = κ'/ℓ: the same κ.

struct PriorityTerms {
    area: f32,    // a(i) = Σ ½|(q − p) × (r − p)|
    kappa: f32,   // κ(i) = |κ₁| + |κ₂|
}

@group(0) @binding(0) var<uniform> params: CountParams;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> neighbours: array<u32>;
@group(0) @binding(3) var<storage, read> rings: array<RingHeader>;
@group(0) @binding(4) var<storage, read_write> terms: array<PriorityTerms>;

fn ring_point(h: RingHeader, m: u32) -> vec3<f32> {
    return positions[neighbours[h.first + m % h.count]].xyz;
}

// Area of the triangle (p, q, r): ½|(q − p) × (r − p)|.
fn triangle_area(p: vec3<f32>, q: vec3<f32>, r: vec3<f32>) -> f32 {
    return 0.5 * length(cross(q - p, r - p));
}

// a(i) = Σ over the star's triangles of ½|(q − p) × (r − p)|.
fn ring_area(h: RingHeader) -> f32 {
    let p = positions[h.centre].xyz;
    var area = 0.0;
    for (var m = 0u; m < sector_count(h); m++) {
        area += triangle_area(p, ring_point(h, m), ring_point(h, m + 1u));
    }
    return area;
}

// Area-weighted normal Σ (q − p) × (r − p) of the star (not normalised).
fn star_normal(h: RingHeader) -> vec3<f32> {
    let p = positions[h.centre].xyz;
    var n = vec3<f32>(0.0);
    for (var m = 0u; m < sector_count(h); m++) {
        n += cross(ring_point(h, m) - p, ring_point(h, m + 1u) - p);
    }
    return n;
}

// κ = |κ₁| + |κ₂| of the least-squares fit z = A x² + B xy + C y² of the ring vertices in the
// frame (e₁, e₂, n) at p_i: normal equations M c = rhs with rows (x², xy, y²), c = M⁻¹ rhs by
// the adjugate (nalgebra's 3×3 try_inverse), κ₁,₂ = (A + C) ± √((A − C)² + B²). 0 when the
// normal or M is degenerate, or the result is not finite (as the reference).
fn curvature(h: RingHeader, normal: vec3<f32>) -> f32 {
    let len = length(normal);
    if (!(len > 0.0) || h.count < 3u) {
        return 0.0;
    }
    let n = normal / len;
    var helper = vec3<f32>(0.0, 1.0, 0.0);
    if (abs(n.x) < 0.9) {
        helper = vec3<f32>(1.0, 0.0, 0.0);
    }
    let e1 = normalize(cross(n, helper));
    let e2 = cross(n, e1);
    let p = positions[h.centre].xyz;
    var scale = 0.0;
    for (var m = 0u; m < h.count; m++) {
        scale = max(scale, length(ring_point(h, m) - p));
    }
    if (!(scale > 0.0)) {
        return 0.0;
    }
    var m = mat3x3<f32>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var rhs = vec3<f32>(0.0);
    for (var k = 0u; k < h.count; k++) {
        let d = (ring_point(h, k) - p) / scale;
        let x = dot(d, e1);
        let y = dot(d, e2);
        let z = dot(d, n);
        let row = vec3<f32>(x * x, x * y, y * y);
        m += mat3x3<f32>(row * row.x, row * row.y, row * row.z);
        rhs += row * z;
    }
    let det = determinant(m);
    if (!(abs(det) > 0.0)) {
        return 0.0;
    }
    // M⁻¹ = adj(M)/det: the rows of adj(M) are the cross products of M's columns m₁×m₂, m₂×m₀, m₀×m₁.
    let adj = transpose(mat3x3<f32>(cross(m[1], m[2]), cross(m[2], m[0]), cross(m[0], m[1])));
    let coef = (adj * rhs) / det;
    let a = coef.x / scale;
    let b = coef.y / scale;
    let c = coef.z / scale;
    let mean = a + c;
    let dev = sqrt((a - c) * (a - c) + b * b);
    let kappa = abs(mean + dev) + abs(mean - dev);
    // Finite check without isinf/isnan (WGSL has neither): NaN fails <, ∞ fails < max f32.
    if (!(kappa < 3.4028234e38)) {
        return 0.0;
    }
    return kappa;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn maps_priority(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) workgroups: vec3<u32>,
) {
    let r = linear_index(gid, workgroups);
    if (r >= params.count) {
        return;
    }
    let h = rings[r];
    terms[r] = PriorityTerms(ring_area(h), curvature(h, star_normal(h)));
}
