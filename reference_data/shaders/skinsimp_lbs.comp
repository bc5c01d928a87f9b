// skinsimp_lbs in GLSL 450 compute, to the `reparam verify --shader` ABI (the WGSL twin:
// skinsimp_lbs.wgsl beside it):
//   reparam verify reference_data/vectors/skinsimp --kernel skinsimp_lbs \
//       --shader reference_data/shaders/skinsimp_lbs.comp
// One invocation per vertex, every pose: p = Σ_k w_k (M_k (v, 1)), influences in list order,
// each joint product formed first and then scaled by its weight.
#version 450

layout(local_size_x = 64, local_size_y = 1, local_size_z = 1) in;

layout(std140, set = 0, binding = 0) uniform Params {
    uint count;          // vertices
    uint rest_len0;
    uint rest_len1;
    uint joints_len0;
    uint joints_len1;
    uint weights_len0;
    uint weights_len1;
    uint matrices_len0;  // poses
    uint matrices_len1;  // joints
    uint matrices_len2;  // 12
    uint _pad0;
    uint _pad1;
} params;

layout(std430, set = 0, binding = 1) readonly buffer Rest { float rest[]; };
layout(std430, set = 0, binding = 2) readonly buffer Joints { uint joints[]; };
layout(std430, set = 0, binding = 3) readonly buffer Weights { float weights[]; };
layout(std430, set = 0, binding = 4) readonly buffer Matrices { float matrices[]; };
layout(std430, set = 0, binding = 5) buffer Out { float outputs[]; };

vec3 joint_times(uint pose, uint joint, vec4 h) {
    uint o = 12u * (pose * params.matrices_len1 + joint);
    vec4 r0 = vec4(matrices[o], matrices[o + 1u], matrices[o + 2u], matrices[o + 3u]);
    vec4 r1 = vec4(matrices[o + 4u], matrices[o + 5u], matrices[o + 6u], matrices[o + 7u]);
    vec4 r2 = vec4(matrices[o + 8u], matrices[o + 9u], matrices[o + 10u], matrices[o + 11u]);
    return vec3(dot(r0, h), dot(r1, h), dot(r2, h));
}

void main() {
    uint vertex = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * 64u;
    if (vertex >= params.count) {
        return;
    }
    vec4 h = vec4(rest[3u * vertex], rest[3u * vertex + 1u], rest[3u * vertex + 2u], 1.0);
    uint poses = params.matrices_len0;
    for (uint pose = 0u; pose < poses; pose++) {
        vec3 sum = vec3(0.0);
        for (uint k = 0u; k < 4u; k++) {
            float w = weights[4u * vertex + k];
            if (w != 0.0) {
                sum += joint_times(pose, joints[4u * vertex + k], h) * w;
            }
        }
        uint o = 3u * (vertex * poses + pose);
        outputs[o] = sum.x;
        outputs[o + 1u] = sum.y;
        outputs[o + 2u] = sum.z;
    }
}
