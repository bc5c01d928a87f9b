// bpm_render: draw a textured mesh whose per-pixel UV is the BPM (or linear) interpolant.
// Prepended by the host: bpm_common.wgsl.
//
// Twin of the f64 reference src/bpm/render.rs (`render_cpu`): per pixel,
// colour = bilinear(texture, eval(face, barycentrics)), no lighting. Conventions: clip space
// depth 0..1, NDC y up, pixel (0, 0) top-left; texture sampled at (u, 1 − v) (OBJ origin
// bottom-left) with REPEAT addressing and linear filtering on raw Rgba8Unorm values.

struct RenderParams {
    view_proj: mat4x4<f32>,   // world → clip, column-major
    interp: u32,              // INTERP_BPM or INTERP_LINEAR
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> params: RenderParams;
@group(0) @binding(1) var<storage, read> corners: array<vec4<f32>>;   // 3 per face, xyz used
@group(0) @binding(2) var<storage, read> maps: array<TriangleMaps>;
@group(0) @binding(3) var uv_texture: texture_2d<f32>;
@group(0) @binding(4) var uv_sampler: sampler;

struct Varyings {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) face: u32,
    // One-hot at the corners, perspective-correct in between: the barycentrics (b_i, b_j, b_k).
    @location(1) @interpolate(perspective, center) bary: vec3<f32>,
}

// Corner n of face f = vertex_index / 3 (non-indexed): clip = view_proj · (p, 1).
@vertex
fn bpm_render_vertex(@builtin(vertex_index) vertex: u32) -> Varyings {
    var out: Varyings;
    out.clip = params.view_proj * vec4<f32>(corners[vertex].xyz, 1.0);
    out.face = vertex / 3u;
    let corner = vertex % 3u;
    out.bary = vec3<f32>(f32(corner == 0u), f32(corner == 1u), f32(corner == 2u));
    return out;
}

// colour = texture(u, 1 − v) with (u, v) = eval(face, barycentrics) (no mipmaps: level 0).
@fragment
fn bpm_render_fragment(in: Varyings) -> @location(0) vec4<f32> {
    let uv = eval(maps[in.face], in.bary, params.interp);
    return textureSampleLevel(uv_texture, uv_sampler, vec2<f32>(uv.x, 1.0 - uv.y), 0.0);
}
