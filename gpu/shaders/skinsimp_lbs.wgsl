// skinsimp_lbs: linear blend skinning of V vertices in P poses, one invocation per
// (vertex, pose). Prepended by the host: dispatch.wgsl.
//
// Twin of `skin` in src/skinsimp/mod.rs (src/skinsimp/SPEC.md § 1):
//   p_i^j = Σ_k w_ik (M_k^j v̂_i),  v̂ = (v, 1),
// summed over the vertex's influences in list order, each joint product formed first and then
// scaled by its weight, as the reference does. A joint matrix is stored as the top three rows
// of the affine 4×4 M (its last row is (0, 0, 0, 1)), row-major: 12 floats.

struct LbsParams {
    vertex_count: u32,
    pose_count: u32,
    joint_count: u32,
    count: u32,          // vertex_count · pose_count invocations
}

// Up to four (joint, weight) pairs per vertex (32 bytes; `Influences` in
// gpu/src/skinsimp/lbs.rs). Unused slots have weight 0.
struct Influences {
    joints: vec4<u32>,
    weights: vec4<f32>,
}

@group(0) @binding(0) var<uniform> params: LbsParams;
@group(0) @binding(1) var<storage, read> rest: array<f32>;              // 3 per vertex
@group(0) @binding(2) var<storage, read> influences: array<Influences>; // 1 per vertex
@group(0) @binding(3) var<storage, read> joints: array<f32>;            // 12 per (pose, joint), index pose·J + joint
@group(0) @binding(4) var<storage, read_write> posed: array<f32>;       // 3 per (vertex, pose), index vertex·P + pose

// M h for the joint matrix number `m` (pose·J + joint) and the homogeneous point h.
fn joint_times(m: u32, h: vec4<f32>) -> vec3<f32> {
    let o = 12u * m;
    let r0 = vec4<f32>(joints[o], joints[o + 1u], joints[o + 2u], joints[o + 3u]);
    let r1 = vec4<f32>(joints[o + 4u], joints[o + 5u], joints[o + 6u], joints[o + 7u]);
    let r2 = vec4<f32>(joints[o + 8u], joints[o + 9u], joints[o + 10u], joints[o + 11u]);
    return vec3<f32>(dot(r0, h), dot(r1, h), dot(r2, h));
}

// p = Σ_k w_k (M_k h), the reference's `skin` for one vertex in one pose.
fn skin(vertex: u32, pose: u32) -> vec3<f32> {
    let h = vec4<f32>(rest[3u * vertex], rest[3u * vertex + 1u], rest[3u * vertex + 2u], 1.0);
    let inf = influences[vertex];
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let w = inf.weights[k];
        if w != 0.0 {
            sum += joint_times(pose * params.joint_count + inf.joints[k], h) * w;
        }
    }
    return sum;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn skinsimp_lbs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.count {
        return;
    }
    let vertex = index / params.pose_count;
    let pose = index % params.pose_count;
    let p = skin(vertex, pose);
    posed[3u * index] = p.x;
    posed[3u * index + 1u] = p.y;
    posed[3u * index + 2u] = p.z;
}
