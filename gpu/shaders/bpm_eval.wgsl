// bpm_eval: one invocation per sample, the interpolated UV at a point of a triangle.
// Prepended by the host: dispatch.wgsl, bpm_common.wgsl.
//
// Twin of the f64 reference src/bpm/eval.rs (`Bpm::eval`): the evaluation itself is `eval` in
// bpm_common.wgsl, shared with the fragment shader of bpm_render.

// One evaluation point (16 bytes; byte for byte `Sample` in gpu/src/bpm/mod.rs): face id and
// barycentrics of corners j and k (b_i = 1 − b_j − b_k).
struct Sample {
    face: u32,
    _pad: u32,
    b: vec2<f32>,
}

struct EvalParams {
    count: u32,
    interp: u32,   // INTERP_BPM or INTERP_LINEAR
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> params: EvalParams;
@group(0) @binding(1) var<storage, read> maps: array<TriangleMaps>;
@group(0) @binding(2) var<storage, read> samples: array<Sample>;
@group(0) @binding(3) var<storage, read_write> uvs: array<vec2<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn bpm_eval(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.count {
        return;
    }
    let s = samples[index];
    let b = vec3<f32>(1.0 - s.b.x - s.b.y, s.b.x, s.b.y);
    uvs[index] = eval(maps[s.face], b, params.interp);
}
