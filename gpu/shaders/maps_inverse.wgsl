// maps_inverse: Π⁻¹ of a batch of base points (seed "Parameterization (1/3)–(3/3)",
// "Remeshing (1/5)"; notes maps.md "Parameter bookkeeping", "Smoothing and remeshing"), one
// invocation per point. Prepended by the host: dispatch.wgsl.
//
// Twin of Param::inverse, to_plane and locate_in_star (src/maps/param.rs) and of
// retriangulate::barycentric: from the base face, replay backwards every removal that created
// the face the point is in: u = Σ b_c μ(corner_c) in the removal's plane (the face's `created`
// chart), then the old star face (the fan (0, μ_m, μ_{m+1}), each face's `removed` chart)
// containing u: the first with all barycentrics ≥ 0 in the removal's order, else the one with the
// largest smallest barycentric. A bounded search: a star has at most max_degree faces. Down at
// an input face, the surface point interpolates its corners.
//
// Which removals exist, their planes μ and their faces are decided by the f64 hierarchy; the
// kernel only evaluates the planar maps. Its orientations are plain f32 (the reference's are
// robust), so near a star edge it may pick the neighbouring face: the maps agree on shared
// edges, so the surface point does not jump.

const NONE: u32 = 0xffffffffu;

struct Params {
    count: u32,        // points
    face_count: u32,   // decimation faces (bounds the walk: face ids decrease at every step)
    _pad0: u32,
    _pad1: u32,
}

// A face of the decimation (16 bytes; `DecimationFace` in gpu/src/maps/inverse.rs).
struct DecimationFace {
    corners: vec3<u32>,
    created_by: u32,   // the removal that created it, NONE for an input face
}

// μ of a face's corners in the plane of the removal that created it and of the one that
// removed it (48 bytes; `FaceCharts`); the removed vertex is at 0.
struct FaceCharts {
    created: array<vec2<f32>, 3>,
    removed: array<vec2<f32>, 3>,
}

// The old (star) faces of a removal: old_faces[first .. first + count] (8 bytes).
struct RemovalRange {
    first: u32,
    count: u32,
}

// A base point (16 bytes; `BaseQuery`).
struct BaseQuery {
    bary: vec3<f32>,
    face: u32,         // base face index
}

// Π⁻¹ of a base point (32 bytes; `InverseResult`).
struct InverseResult {
    position: vec3<f32>,
    face: u32,         // input face
    bary: vec3<f32>,   // barycentrics in the input face (clamped, sum 1)
    min_bary: f32,     // smallest barycentric met on the way before clamping
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> faces: array<DecimationFace>;
@group(0) @binding(3) var<storage, read> charts: array<FaceCharts>;
@group(0) @binding(4) var<storage, read> removals: array<RemovalRange>;
@group(0) @binding(5) var<storage, read> old_faces: array<u32>;
@group(0) @binding(6) var<storage, read> base_to_face: array<u32>;
@group(0) @binding(7) var<storage, read> queries: array<BaseQuery>;
@group(0) @binding(8) var<storage, read_write> results: array<InverseResult>;

fn orient2d(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> f32 {
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

// λ_a = orient(u, b, c)/Σ and cyclically (Σ the sum of the three, or orient(a, b, c) if 0).
fn barycentric(u: vec2<f32>, a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> vec3<f32> {
    let area = orient2d(a, b, c);
    let l = vec3<f32>(orient2d(u, b, c), orient2d(a, u, c), orient2d(a, b, u));
    var norm = l.x + l.y + l.z;
    if (norm == 0.0) {
        norm = area;
    }
    return l / norm;
}

fn min3(l: vec3<f32>) -> f32 {
    return min(l.x, min(l.y, l.z));
}

// u = Σ b_c μ(corner_c) in the plane of the removal that created `face`.
fn to_plane(face: u32, b: vec3<f32>) -> vec2<f32> {
    let m = charts[face].created;
    return b.x * m[0] + b.y * m[1] + b.z * m[2];
}

struct Located {
    face: u32,
    bary: vec3<f32>,
}

// The old star face of removal r containing u, else the one with the largest smallest
// barycentric.
fn locate_in_star(r: RemovalRange, u: vec2<f32>) -> Located {
    var best = Located(old_faces[r.first], vec3<f32>(0.0));
    var best_min = -3.4028234e38;
    for (var m = 0u; m < r.count; m++) {
        let f = old_faces[r.first + m];
        let c = charts[f].removed;
        let l = barycentric(u, c[0], c[1], c[2]);
        let lowest = min3(l);
        if (lowest >= 0.0) {
            return Located(f, l);
        }
        if (lowest > best_min) {
            best_min = lowest;
            best = Located(f, l);
        }
    }
    return best;
}

// Barycentrics clamped to ≥ 0 and renormalised.
fn clamp_bary(l: vec3<f32>) -> vec3<f32> {
    let c = max(l, vec3<f32>(0.0));
    return c / (c.x + c.y + c.z);
}

// Π⁻¹ of one base point (Param::inverse).
fn inverse(q: BaseQuery) -> InverseResult {
    var face = base_to_face[q.face];
    var bary = q.bary;
    var min_bary = min3(bary);
    for (var step = 0u; step < params.face_count; step++) {
        let created_by = faces[face].created_by;
        if (created_by == NONE) {
            break;
        }
        let u = to_plane(face, bary);
        let found = locate_in_star(removals[created_by], u);
        min_bary = min(min_bary, min3(found.bary));
        face = found.face;
        bary = clamp_bary(found.bary);
    }
    let t = faces[face].corners;
    let position = bary.x * positions[t.x].xyz + bary.y * positions[t.y].xyz
        + bary.z * positions[t.z].xyz;
    return InverseResult(position, face, bary, min_bary);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn maps_inverse(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) workgroups: vec3<u32>,
) {
    let n = linear_index(gid, workgroups);
    if (n >= params.count) {
        return;
    }
    results[n] = inverse(queries[n]);
}
