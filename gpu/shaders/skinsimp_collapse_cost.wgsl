// skinsimp_collapse_cost: for every candidate (edge (a, b), fixed weights α over the
// candidate bones), the position step and the collapse cost E(v̂, α), one invocation per
// candidate. Prepended by the host: dispatch.wgsl.
//
// Twin of src/skinsimp/cost.rs, function for function: `blend` (Candidates::blend),
// `position_quadric`, `solve_position`, `position_step` with the fallbacks (a, b, midpoint)
// of `endpoint_start`, and `energy` — together `position_given_weights`:
//   A^j = Σ_k α_k M_k^j,  Q^j = Q_a^j + Q_b^j,  Q̃ = Σ_j A^{jT} Q^j A^j,
//   v = −Q̃[0:3,0:3]⁻¹ Q̃[0:3,3] if cond_F(Q̃[0:3,0:3]) ≤ max_condition,
//   the least v̂ᵀQ̃v̂ among {v, a, b, (a + b)/2} (ties: the earlier),
//   E(v̂, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂), summed over poses in order.
// The weight step (the QP on the simplex) and the alternation stay on the CPU.
//
// Joint matrices are the top three rows of the affine M (row-major, 12 floats); the blended
// A^j gets the last row (0, 0, 0, Σ_k α_k), as the reference's 4×4 sum does.

const MAX_CANDIDATES: u32 = 8u;
const CHOICE_SOLUTION: u32 = 0u;   // then 1: a, 2: b, 3: midpoint

struct CostParams {
    vertex_count: u32,
    pose_count: u32,
    joint_count: u32,
    count: u32,           // candidates
    max_condition: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// One candidate (80 bytes; `EdgeItem` in gpu/src/skinsimp/collapse_cost.rs).
struct EdgeItem {
    a: u32,
    b: u32,
    candidates: u32,                      // K ≤ MAX_CANDIDATES bones
    _pad: u32,
    joints: array<u32, 8>,
    alpha: array<f32, 8>,
}

// One result (72 bytes; `EdgeCost` in gpu/src/skinsimp/collapse_cost.rs).
struct EdgeCost {
    quadric: array<f32, 10>,   // Q̃, upper triangle
    condition: f32,            // ‖B‖_F ‖B⁻¹‖_F of B = Q̃[0:3,0:3] (0 when singular)
    value: f32,                // v̂ᵀQ̃v̂ at the chosen point
    position: array<f32, 3>,   // the chosen rest position v
    cost: f32,                 // E(v̂, α)
    choice: u32,               // 0 solution, 1 a, 2 b, 3 midpoint
    _pad: u32,
}

@group(0) @binding(0) var<uniform> params: CostParams;
@group(0) @binding(1) var<storage, read> rest: array<f32>;               // 3 per vertex
@group(0) @binding(2) var<storage, read> vertex_quadrics: array<f32>;    // 10 per (vertex, pose)
@group(0) @binding(3) var<storage, read> joints: array<f32>;             // 12 per (pose, joint)
@group(0) @binding(4) var<storage, read> items: array<EdgeItem>;
@group(0) @binding(5) var<storage, read_write> results: array<EdgeCost>;

fn rest_at(v: u32) -> vec3<f32> {
    return vec3<f32>(rest[3u * v], rest[3u * v + 1u], rest[3u * v + 2u]);
}

// The symmetric 4×4 of an upper triangle.
fn quadric_matrix(q: array<f32, 10>) -> mat4x4<f32> {
    return mat4x4<f32>(
        vec4<f32>(q[0], q[1], q[2], q[3]),
        vec4<f32>(q[1], q[4], q[5], q[6]),
        vec4<f32>(q[2], q[5], q[7], q[8]),
        vec4<f32>(q[3], q[6], q[8], q[9]),
    );
}

// Q^j = Q_a^j + Q_b^j.
fn summed_quadric(item: EdgeItem, pose: u32) -> mat4x4<f32> {
    let oa = 10u * (item.a * params.pose_count + pose);
    let ob = 10u * (item.b * params.pose_count + pose);
    var q: array<f32, 10>;
    for (var k = 0u; k < 10u; k++) {
        q[k] = vertex_quadrics[oa + k] + vertex_quadrics[ob + k];
    }
    return quadric_matrix(q);
}

// The affine joint matrix M (4×4, column-major) of `joint` in `pose`.
fn joint_matrix(pose: u32, joint: u32) -> mat4x4<f32> {
    let o = 12u * (pose * params.joint_count + joint);
    return mat4x4<f32>(
        vec4<f32>(joints[o], joints[o + 4u], joints[o + 8u], 0.0),
        vec4<f32>(joints[o + 1u], joints[o + 5u], joints[o + 9u], 0.0),
        vec4<f32>(joints[o + 2u], joints[o + 6u], joints[o + 10u], 0.0),
        vec4<f32>(joints[o + 3u], joints[o + 7u], joints[o + 11u], 1.0),
    );
}

// `Candidates::blend`: A^j = Σ_k α_k M_k^j (zero weights skipped).
fn blend(item: EdgeItem, pose: u32) -> mat4x4<f32> {
    var a = mat4x4<f32>(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var k = 0u; k < item.candidates; k++) {
        let w = item.alpha[k];
        if w != 0.0 {
            a += joint_matrix(pose, item.joints[k]) * w;
        }
    }
    return a;
}

// `position_quadric`: Q̃ = Σ_j A^{jT} Q^j A^j.
fn position_quadric(item: EdgeItem) -> mat4x4<f32> {
    var total = mat4x4<f32>(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    for (var j = 0u; j < params.pose_count; j++) {
        let a = blend(item, j);
        total += transpose(a) * summed_quadric(item, j) * a;
    }
    return total;
}

// `energy`: E(v̂, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂), poses in order.
fn energy(item: EdgeItem, v: vec3<f32>) -> f32 {
    let h = vec4<f32>(v, 1.0);
    var e = 0.0;
    for (var j = 0u; j < params.pose_count; j++) {
        let p = blend(item, j) * h;
        e += dot(p, summed_quadric(item, j) * p);
    }
    return e;
}

// v̂ᵀ Q v̂.
fn quadric_value(q: mat4x4<f32>, v: vec3<f32>) -> f32 {
    let h = vec4<f32>(v, 1.0);
    return dot(h, q * h);
}

fn is_finite(x: f32) -> bool {
    return abs(x) <= 3.4028235e38;
}

fn max_abs3(x: vec3<f32>) -> f32 {
    let a = abs(x);
    return max(max(a.x, a.y), a.z);
}

struct Solution {
    found: bool,
    v: vec3<f32>,
    condition: f32,
}

// `solve_position`: v = −B⁻¹ b, B = Q̃[0:3,0:3], b = Q̃[0:3,3], with the adjugate inverse
// (rows of B⁻¹ = (c1 × c2, c2 × c0, c0 × c1) / det for the columns c of B, the cofactor formula
// nalgebra's 3×3 `try_inverse` uses); none when det = 0, when cond_F = ‖B‖_F ‖B⁻¹‖_F exceeds
// max_condition (or is not a number), or when v is not finite.
// B and b are first scaled by 2^−e, 2^e the binary exponent of B's largest entry: exact in
// f32, and cond_F and v are unchanged by a common scale, but the cofactors (degree 2) and det
// (degree 3) stay in f32's range. Unscaled, entries of 1e10 gave cofactors whose squares
// overflowed, cond = ∞, and the solution was wrongly refused (found by the command fuzzer).
fn solve_position(q: mat4x4<f32>) -> Solution {
    let largest = max(max(max_abs3(q[0].xyz), max_abs3(q[1].xyz)), max_abs3(q[2].xyz));
    let shift = vec3<i32>(-frexp(largest).exp);
    let c0 = ldexp(q[0].xyz, shift);
    let c1 = ldexp(q[1].xyz, shift);
    let c2 = ldexp(q[2].xyz, shift);
    let b = ldexp(q[3].xyz, shift);
    let r0 = cross(c1, c2);
    let r1 = cross(c2, c0);
    let r2 = cross(c0, c1);
    let det = dot(c0, r0);
    var out = Solution(false, vec3<f32>(0.0), 0.0);
    if det == 0.0 {
        return out;
    }
    let norm_b = sqrt(dot(c0, c0) + dot(c1, c1) + dot(c2, c2));
    let norm_inv = sqrt(dot(r0, r0) + dot(r1, r1) + dot(r2, r2)) / abs(det);
    out.condition = norm_b * norm_inv;
    if !(out.condition <= params.max_condition) {
        return out;
    }
    let v = -vec3<f32>(dot(r0, b), dot(r1, b), dot(r2, b)) / det;
    out.found = is_finite(v.x) && is_finite(v.y) && is_finite(v.z);
    out.v = v;
    return out;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn skinsimp_collapse_cost(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.count {
        return;
    }
    let item = items[index];
    let q = position_quadric(item);
    // `position_step` with the fallbacks (a, b, midpoint).
    let solution = solve_position(q);
    let a = rest_at(item.a);
    let b = rest_at(item.b);
    var fallbacks = array<vec3<f32>, 3>(a, b, (a + b) * 0.5);
    var found = solution.found;
    var best = solution.v;
    var best_value = 0.0;
    var choice = CHOICE_SOLUTION;
    if found {
        best_value = quadric_value(q, best);
    }
    for (var k = 0u; k < 3u; k++) {
        let e = quadric_value(q, fallbacks[k]);
        if !found || e < best_value {
            found = true;
            best = fallbacks[k];
            best_value = e;
            choice = k + 1u;
        }
    }
    var out: EdgeCost;
    out.quadric = array<f32, 10>(
        q[0][0], q[1][0], q[2][0], q[3][0], q[1][1], q[2][1], q[3][1], q[2][2], q[3][2], q[3][3],
    );
    out.condition = solution.condition;
    out.value = best_value;
    out.position = array<f32, 3>(best.x, best.y, best.z);
    out.cost = energy(item, best);
    out.choice = choice;
    out._pad = 0u;
    results[index] = out;
}
