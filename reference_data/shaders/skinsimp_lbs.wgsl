// skinsimp_lbs written to the `reparam verify --shader` ABI, as a user would ship it:
//   reparam verify reference_data/vectors/skinsimp --kernel skinsimp_lbs \
//       --shader reference_data/shaders/skinsimp_lbs.wgsl
// (`--print-abi` prints the declarations below). One invocation per vertex (the output's
// first axis), every pose: p_i^j = Σ_k w_ik (M_k^j v̂_i), v̂ = (v, 1), summed over the
// influences in list order, each joint product formed first and then scaled by its weight
// (the plain path of src/skinsimp/mod.rs `skin` and gpu/shaders/skinsimp_lbs.wgsl).

struct Params {
    count: u32,            // vertices
    rest_len0: u32,
    rest_len1: u32,
    joints_len0: u32,
    joints_len1: u32,
    weights_len0: u32,
    weights_len1: u32,
    matrices_len0: u32,    // poses
    matrices_len1: u32,    // joints
    matrices_len2: u32,    // 12: the 3×4 top of each joint matrix, row by row
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rest: array<f32>;       // (V, 3)
@group(0) @binding(2) var<storage, read> joints: array<u32>;     // (V, 4)
@group(0) @binding(3) var<storage, read> weights: array<f32>;    // (V, 4)
@group(0) @binding(4) var<storage, read> matrices: array<f32>;   // (P, J, 12)
@group(0) @binding(5) var<storage, read_write> out: array<f32>;  // (V, P, 3)

// M h for joint `joint` in pose `pose` and the homogeneous point h.
fn joint_times(pose: u32, joint: u32, h: vec4<f32>) -> vec3<f32> {
    let o = 12u * (pose * params.matrices_len1 + joint);
    let r0 = vec4<f32>(matrices[o], matrices[o + 1u], matrices[o + 2u], matrices[o + 3u]);
    let r1 = vec4<f32>(matrices[o + 4u], matrices[o + 5u], matrices[o + 6u], matrices[o + 7u]);
    let r2 = vec4<f32>(matrices[o + 8u], matrices[o + 9u], matrices[o + 10u], matrices[o + 11u]);
    return vec3<f32>(dot(r0, h), dot(r1, h), dot(r2, h));
}

@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let vertex = gid.x + gid.y * groups.x * 64u;
    if vertex >= params.count {
        return;
    }
    let h = vec4<f32>(rest[3u * vertex], rest[3u * vertex + 1u], rest[3u * vertex + 2u], 1.0);
    let poses = params.matrices_len0;
    for (var pose = 0u; pose < poses; pose++) {
        var sum = vec3<f32>(0.0);
        for (var k = 0u; k < 4u; k++) {
            let w = weights[4u * vertex + k];
            if w != 0.0 {
                sum += joint_times(pose, joints[4u * vertex + k], h) * w;
            }
        }
        let o = 3u * (vertex * poses + pose);
        out[o] = sum.x;
        out[o + 1u] = sum.y;
        out[o + 2u] = sum.z;
    }
}
