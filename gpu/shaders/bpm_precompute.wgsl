// bpm_precompute: one invocation per triangle t = (i, j, k) turns its star into TriangleMaps.
// Prepended by the host: dispatch.wgsl, bpm_common.wgsl.
//
// Twin of the f64 reference src/bpm/precompute.rs (`star_layout`, `place_apex`,
// `triangle_maps`), reading the same star the reference gathers (`gather_star`).

// One triangle's star (160 bytes; byte for byte `StarInput` in gpu/src/bpm/mod.rs).
struct StarInput {
    p: array<vec4<f32>, 6>,   // xyz of i, j, k, then the apex across ij, jk, ki (w unused)
    w: array<vec2<f32>, 6>,   // UVs at the same six points
    mask: u32,                // bit e: neighbour across edge e exists; MASK_DEGENERATE: t is degenerate
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

const MASK_DEGENERATE: u32 = 8u;
const FIT_LOCAL: u32 = 0u;
const FIT_DETERMINANT: u32 = 1u;

struct PrecomputeParams {
    count: u32,
    fit: u32,     // FIT_LOCAL or FIT_DETERMINANT
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: PrecomputeParams;
@group(0) @binding(1) var<storage, read> stars: array<StarInput>;
@group(0) @binding(2) var<storage, read_write> maps: array<TriangleMaps>;

// The corners (a, b) of edge e in t's order: ij = (0, 1), jk = (1, 2), ki = (2, 0)
// (the reference's EDGE_CORNERS).
fn edge_corners(e: u32) -> vec2<u32> {
    return vec2<u32>(e, (e + 1u) % 3u);
}

// Signed area (×2) of a triangle of complex points, counter-clockwise positive:
// (b − a).re (c − a).im − (b − a).im (c − a).re.
fn signed_area2(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> f32 {
    let u = b - a;
    let v = c - a;
    return u.x * v.y - u.y * v.x;
}

struct StarLayout {
    z: array<vec2<f32>, 6>,
    mirrored: bool,
}

// Lay out the star in t's own frame: z_i = 0, z_j = |p_j − p_i| on the real axis,
// z_k = ((p_k − p_i)·e₁) + i |e₁ × (p_k − p_i)|, each apex unfolded across its edge by
// place_apex. If t's UV triangle w_t is clockwise, the whole star is mirrored (z ↦ z̄).
fn star_layout(p: array<vec4<f32>, 6>, w_t: array<vec2<f32>, 3>) -> StarLayout {
    var q = p;
    let ej = q[1].xyz - q[0].xyz;
    let edge_length = length(ej);
    let e1 = ej / edge_length;
    let pk = q[2].xyz - q[0].xyz;
    var z: array<vec2<f32>, 6>;
    z[1] = vec2<f32>(edge_length, 0.0);
    z[2] = vec2<f32>(dot(pk, e1), length(cross(e1, pk)));
    for (var e = 0u; e < 3u; e++) {
        let ab = edge_corners(e);
        z[3u + e] = place_apex(z[ab.x], z[ab.y], q[ab.x].xyz, q[ab.y].xyz, q[3u + e].xyz);
    }
    let mirrored = signed_area2(w_t[0], w_t[1], w_t[2]) < 0.0;
    if mirrored {
        for (var n = 0u; n < 6u; n++) {
            z[n] = vec2<f32>(z[n].x, -z[n].y);
        }
    }
    return StarLayout(z, mirrored);
}

// Unfold a neighbour's apex across the edge a→b of t (an isometric hinge rotation):
// u = (p_b − p_a)/|p_b − p_a|, along = (p_apex − p_a)·u, perp = |u × (p_apex − p_a)|,
// dir = (z_b − z_a)/|z_b − z_a|, z_apex = z_a + dir·(along − i·perp) (right of a→b).
fn place_apex(z_a: vec2<f32>, z_b: vec2<f32>, p_a: vec3<f32>, p_b: vec3<f32>, p_apex: vec3<f32>) -> vec2<f32> {
    let u = (p_b - p_a) / length(p_b - p_a);
    let r = p_apex - p_a;
    let along = dot(r, u);
    let perp = length(cross(u, r));
    let dir = (z_b - z_a) / length(z_b - z_a);
    return z_a + c_mul(dir, vec2<f32>(along, -perp));
}

// The Möbius map through star points (n0, n1, n2): layout z ↦ shifted UVs big_w, by the fit
// chosen in params (the reference's `fit` closure).
fn fit_star(fit: u32, z: array<vec2<f32>, 6>, big_w: array<vec2<f32>, 6>, n: vec3<u32>) -> Mobius {
    var zs = z;
    var ws = big_w;
    let z3 = array<vec2<f32>, 3>(zs[n.x], zs[n.y], zs[n.z]);
    let w3 = array<vec2<f32>, 3>(ws[n.x], ws[n.y], ws[n.z]);
    if fit == FIT_DETERMINANT {
        return fit_mobius_det(z3, w3);
    }
    return fit_mobius_local(z3, w3);
}

// All per-triangle data of one star: with W = w − w_origin (w_origin = w_i for the local fit,
// 0 for the determinant fit), M_t = fit(z_i, z_j, z_k → W_i, W_j, W_k); for each neighbour e
// across edge (a, b): M_e = fit(z_a, z_b, z_apex → W_a, W_b, W_apex), δ_e = M_t⁻¹ M_e,
// l_e = log_sl2_roots(δ_e); l_e = 0 without a neighbour (or when not finite). A degenerate t, or a
// non-finite M_t, gives the linear fallback: M_t = I, logs 0, w_origin 0.
fn triangle_maps(star: StarInput, fit: u32) -> TriangleMaps {
    let uv = array<vec2<f32>, 3>(star.w[0], star.w[1], star.w[2]);
    let star_z = star_layout(star.p, uv);
    let z = star_z.z;
    let z_t = array<vec2<f32>, 3>(z[0], z[1], z[2]);
    let mirrored = select(0u, FLAG_MIRRORED, star_z.mirrored);
    var logs = array<Sl2, 3>(sl2_zero(), sl2_zero(), sl2_zero());
    let fallback = pack_triangle_maps(z_t, uv, C_ZERO, mobius_identity(), logs, FLAG_LINEAR_FALLBACK | mirrored);
    if (star.mask & MASK_DEGENERATE) != 0u {
        return fallback;
    }
    let w_origin = select(C_ZERO, star.w[0], fit == FIT_LOCAL);
    var big_w: array<vec2<f32>, 6>;
    for (var n = 0u; n < 6u; n++) {
        big_w[n] = star.w[n] - w_origin;
    }
    let m_t = fit_star(fit, z, big_w, vec3<u32>(0u, 1u, 2u));
    if !mobius_is_finite(m_t) {
        return fallback;
    }
    let m_t_inv = mobius_inverse(m_t);
    for (var e = 0u; e < 3u; e++) {
        if (star.mask & (1u << e)) == 0u {
            continue;
        }
        let ab = edge_corners(e);
        let m_e = fit_star(fit, z, big_w, vec3<u32>(ab.x, ab.y, 3u + e));
        let ratio = mobius_mul(m_t_inv, m_e);
        let l_e = log_sl2_roots(ratio);
        // A non-finite ratio (a neighbour whose fit blew up) is treated like a boundary edge.
        if is_finite_f32(sl2_max_abs(l_e)) {
            logs[e] = l_e;
        }
    }
    return pack_triangle_maps(z_t, uv, w_origin, m_t, logs, mirrored);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn bpm_precompute(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.count {
        return;
    }
    maps[index] = triangle_maps(stars[index], params.fit);
}
