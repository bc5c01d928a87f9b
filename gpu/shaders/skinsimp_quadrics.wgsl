// skinsimp_quadrics: Garland–Heckbert plane quadrics per example pose (src/skinsimp/SPEC.md
// § 2), in two entry points. Prepended by the host: dispatch.wgsl.
//
// Twin of src/skinsimp/quadric.rs (`Quadric::from_plane`, `Quadric::from_triangle`,
// `edge_constraint`, `unit_normal`) and of the per-vertex sum `Q_i^j = Σ_{f∋i} K_f^j` (+ the
// boundary / UV-seam constraint planes) of `vertex_quadrics` in src/skinsimp/collapse.rs.
//
// A quadric is the upper triangle (xx, xy, xz, xw, yy, yz, yw, zz, zw, ww) of the symmetric
// 4×4 Q, 10 floats. Every per-pose array is indexed element · P + pose.
//
// 1. `skinsimp_plane_quadrics`, one invocation per (source, pose): a source is a face (kind 3:
//    K_f = area · q qᵀ, q = (n, −n·p0)) or a boundary / seam edge e of a face (kind e ∈ 0..2:
//    the plane through the edge perpendicular to the face, weighted by weight · |edge|²).
// 2. `skinsimp_vertex_quadrics`, one invocation per (vertex, pose): the sum of the vertex's
//    sources in the order of its CSR list (the reference's order: faces ascending, each face
//    followed by its constraint edges). A gather, no atomics: the sums are deterministic.
//
// The two entry points declare their own resources; the bindings of each are 0, 1, 2, … .

const SOURCE_FACE: u32 = 3u;

struct QuadricParams {
    item_count: u32,       // sources (entry 1) or vertices (entry 2)
    pose_count: u32,
    count: u32,            // item_count · pose_count invocations
    boundary_weight: f32,  // weight of the constraint planes (entry 1)
}

// A quadric source (16 bytes; `PlaneSource` in gpu/src/skinsimp/quadrics.rs): the face's three
// vertices and the kind (SOURCE_FACE or the local edge 0, 1, 2 joining corners e and (e+1)%3).
struct PlaneSource {
    corners: vec3<u32>,
    kind: u32,
}

@group(0) @binding(0) var<uniform> params: QuadricParams;
// Entry 1.
@group(0) @binding(1) var<storage, read> posed: array<f32>;               // 3 per (vertex, pose)
@group(0) @binding(2) var<storage, read> sources: array<PlaneSource>;
@group(0) @binding(3) var<storage, read_write> plane_out: array<f32>;     // 10 per (source, pose)
// Entry 2.
@group(0) @binding(1) var<storage, read> vertex_offsets: array<u32>;      // CSR: V + 1 offsets
@group(0) @binding(2) var<storage, read> vertex_sources: array<u32>;      // CSR: source ids
@group(0) @binding(3) var<storage, read> plane_in: array<f32>;            // entry 1's output
@group(0) @binding(4) var<storage, read_write> vertex_out: array<f32>;    // 10 per (vertex, pose)

struct Quadric {
    a: array<f32, 10>,
}

// `Quadric::from_plane`: w · q qᵀ for q = (n, d), upper triangle row by row, (w q_r) q_c.
fn from_plane(n: vec3<f32>, d: f32, w: f32) -> Quadric {
    let q = array<f32, 4>(n.x, n.y, n.z, d);
    var out: Quadric;
    var k = 0u;
    for (var r = 0u; r < 4u; r++) {
        for (var c = r; c < 4u; c++) {
            out.a[k] = w * q[r] * q[c];
            k++;
        }
    }
    return out;
}

fn zero_quadric() -> Quadric {
    var out: Quadric;
    for (var k = 0u; k < 10u; k++) {
        out.a[k] = 0.0;
    }
    return out;
}

// `Quadric::from_triangle`: area · q qᵀ, q = (n, −n·p0), zero for a degenerate triangle.
fn from_triangle(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>) -> Quadric {
    let c = cross(p1 - p0, p2 - p0);
    let twice_area = length(c);
    if twice_area == 0.0 {
        return zero_quadric();
    }
    let n = c / twice_area;
    return from_plane(n, -dot(n, p0), 0.5 * twice_area);
}

// `unit_normal`: the unit normal of (p0, p1, p2), zero when degenerate.
fn unit_normal(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>) -> vec3<f32> {
    let c = cross(p1 - p0, p2 - p0);
    let n = length(c);
    if n == 0.0 {
        return vec3<f32>(0.0);
    }
    return c / n;
}

// `edge_constraint`: the plane through (p0, p1) perpendicular to the face (unit normal
// face_n), weighted by weight · |p1 − p0|²; zero for a degenerate edge or face.
fn edge_constraint(p0: vec3<f32>, p1: vec3<f32>, face_n: vec3<f32>, weight: f32) -> Quadric {
    let e = p1 - p0;
    let m = cross(e, face_n);
    let len = length(m);
    if len == 0.0 {
        return zero_quadric();
    }
    let n = m / len;
    return from_plane(n, -dot(n, p0), weight * dot(e, e));
}

fn posed_at(vertex: u32, pose: u32) -> vec3<f32> {
    let o = 3u * (vertex * params.pose_count + pose);
    return vec3<f32>(posed[o], posed[o + 1u], posed[o + 2u]);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn skinsimp_plane_quadrics(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.count {
        return;
    }
    let source = sources[index / params.pose_count];
    let pose = index % params.pose_count;
    var p = array<vec3<f32>, 3>(
        posed_at(source.corners.x, pose),
        posed_at(source.corners.y, pose),
        posed_at(source.corners.z, pose),
    );
    var q: Quadric;
    if source.kind == SOURCE_FACE {
        q = from_triangle(p[0], p[1], p[2]);
    } else {
        let e = source.kind;
        let normal = unit_normal(p[0], p[1], p[2]);
        q = edge_constraint(p[e], p[(e + 1u) % 3u], normal, params.boundary_weight);
    }
    for (var k = 0u; k < 10u; k++) {
        plane_out[10u * index + k] = q.a[k];
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn skinsimp_vertex_quadrics(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.count {
        return;
    }
    let vertex = index / params.pose_count;
    let pose = index % params.pose_count;
    var sum = zero_quadric();
    for (var s = vertex_offsets[vertex]; s < vertex_offsets[vertex + 1u]; s++) {
        let o = 10u * (vertex_sources[s] * params.pose_count + pose);
        for (var k = 0u; k < 10u; k++) {
            sum.a[k] += plane_in[o + k];
        }
    }
    for (var k = 0u; k < 10u; k++) {
        vertex_out[10u * index + k] = sum.a[k];
    }
}
