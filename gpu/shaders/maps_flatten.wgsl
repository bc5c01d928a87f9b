// maps_flatten: the conformal map z^a of every 1-ring of a batch (seed "Constructing the Mesh
// Hierarchies (4/5)"; notes maps.md "Flattening a 1-ring"), one invocation per ring. Prepended
// by the host: dispatch.wgsl, maps_rings.wgsl.
//
// Twin of src/maps/flatten.rs: cumulative_angles, flatten_ring (Disk, HalfDisk, FeatureLine),
// check_sectors, in the same order of operations. θ_k is written to the ring's output slots in a
// first loop and read back by the second (so any degree works without a fixed-size array).

const PI: f32 = 3.14159265358979;
const STATUS_OK: u32 = 0u;
const STATUS_DEGENERATE: u32 = 1u;   // FlattenReject::Degenerate
const STATUS_FLIPPED_FAN: u32 = 2u;  // FlattenReject::FlippedFan

// Per ring (16 bytes; `FlatRing` in gpu/src/maps/flatten.rs).
struct FlatRing {
    a: f32,            // a (disk, half disk) or a₁ (feature line, upper side s → t)
    a2: f32,           // a₂ of the lower side t → s (feature line); a otherwise
    theta_total: f32,  // θ_K (closed) or θ_{K−1} (half disk)
    status: u32,       // STATUS_*
}

// Per ring slot k (16 bytes; `FlatPoint`).
struct FlatPoint {
    mu: vec2<f32>,     // μ(p_{j_k})
    theta: f32,        // θ_k (θ_0 = 0)
    radius: f32,       // r_k = |p_{j_k} − p_i|
}

@group(0) @binding(0) var<uniform> params: CountParams;
@group(0) @binding(1) var<storage, read> positions: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> neighbours: array<u32>;
@group(0) @binding(3) var<storage, read> rings: array<RingHeader>;
@group(0) @binding(4) var<storage, read_write> flat_rings: array<FlatRing>;
@group(0) @binding(5) var<storage, read_write> points: array<FlatPoint>;

fn ring_point(h: RingHeader, m: u32) -> vec3<f32> {
    return positions[neighbours[h.first + m % h.count]].xyz;
}

// θ_m of ring h: slot m, or the total for m = K (the closing θ_K of a closed ring).
fn theta_at(h: RingHeader, m: u32, total: f32) -> f32 {
    if (m >= h.count) {
        return total;
    }
    return points[h.first + m].theta;
}

// Finite (WGSL has no isnan/isinf): NaN and ±∞ fail the comparison.
fn finite(x: f32) -> bool {
    return abs(x) < 3.4028234e38;
}

// atan x for 0 ≤ x ≤ 1: Cephes' atanf (range reduction at tan(π/8) by (x − 1)/(x + 1) and a
// degree-9 odd polynomial; ≤ 2 ulp). WGSL's built-in atan2 only promises 4096 ulp, and Mesa's
// llvmpipe's measured ≈ 1e-6 rad on these angles, 20× the rest of a ring's rounding.
fn atan_unit(x: f32) -> f32 {
    var base = 0.0;
    var t = x;
    if (x > 0.41421356) {
        base = 0.78539816;
        t = (x - 1.0) / (x + 1.0);
    }
    let z = t * t;
    return base + ((((8.05374449538e-2 * z - 1.38776856032e-1) * z + 1.99777106478e-1) * z
        - 3.33329491539e-1) * z * t + t);
}

// atan2(y, x) for y ≥ 0 (an angle in [0, π]), from atan_unit of min/max; 0 for y = x = 0, as
// the reference's f64 atan2 (both can underflow to 0 for edges ~1e-19 long).
fn angle_atan2(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    if (y == 0.0 && ax == 0.0) {
        return 0.0;
    }
    var t = 0.0;
    if (y <= ax) {
        t = atan_unit(y / ax);
    } else {
        t = 1.57079633 - atan_unit(ax / y);
    }
    if (x < 0.0) {
        return PI - t;
    }
    return t;
}

// θ_{m+1} = θ_m + ∠(p_{j_m}, p_i, p_{j_{m+1}}), the angle as atan2(|a×b|, a·b); writes θ_k and
// r_k to the ring's slots and returns the last θ (θ_K closed, θ_{K−1} open).
fn cumulative_angles(h: RingHeader) -> f32 {
    let p = positions[h.centre].xyz;
    var theta = 0.0;
    points[h.first].theta = 0.0;
    for (var m = 0u; m < sector_count(h); m++) {
        let a = ring_point(h, m) - p;
        let b = ring_point(h, m + 1u) - p;
        theta += angle_atan2(length(cross(a, b)), dot(a, b));
        if (m + 1u < h.count) {
            points[h.first + m + 1u].theta = theta;
        }
    }
    for (var m = 0u; m < h.count; m++) {
        points[h.first + m].radius = length(ring_point(h, m) - p);
    }
    return theta;
}

// An angle of [0, 3π) moved into [−π, π] (x − 2π above π): WGSL's cos and sin promise their
// absolute 2⁻¹¹ there only (the disk's a·θ_k and the lower side's π + a₂(θ_m − θ_t) reach 2π).
fn wrap_angle(angle: f32) -> f32 {
    if (angle > PI) {
        return angle - 2.0 * PI;
    }
    return angle;
}

// r^a e^{i angle}.
fn polar(r: f32, a: f32, angle: f32) -> vec2<f32> {
    let rho = pow(r, a);
    let w = wrap_angle(angle);
    return vec2<f32>(rho * cos(w), rho * sin(w));
}

// Guard of the notes (check_sectors): a side made of a single sector is a flipped fan (a·φ = π
// exactly), else every scaled sector angle a·(θ_{m+1} − θ_m) over the side's sector ranges
// [first0, end0) and [first1, end1) (the lower side of a feature line wraps past j_0) must be
// < π. Returns false for a flipped fan.
fn check_sectors(h: RingHeader, first0: u32, end0: u32, first1: u32, end1: u32, a: f32,
                 total: f32) -> bool {
    if ((end0 - first0) + (end1 - first1) == 1u) {
        return false;
    }
    for (var m = first0; m < end0; m++) {
        if (a * (theta_at(h, m + 1u, total) - theta_at(h, m, total)) >= PI) {
            return false;
        }
    }
    for (var m = first1; m < end1; m++) {
        if (a * (theta_at(h, m + 1u, total) - theta_at(h, m, total)) >= PI) {
            return false;
        }
    }
    return true;
}

// The flattened ring h: μ written to its slots, (a, a₂, θ_total, status) returned.
fn flatten_ring(h: RingHeader) -> FlatRing {
    let k = h.count;
    let total = cumulative_angles(h);
    // Sanity (Degenerate): every radius positive and finite, θ strictly increasing and finite.
    var sane = true;
    for (var m = 0u; m < k; m++) {
        let radius = points[h.first + m].radius;
        sane = sane && radius > 0.0 && finite(radius);
        points[h.first + m].mu = vec2<f32>(0.0);
    }
    for (var m = 0u; m < sector_count(h); m++) {
        let next = theta_at(h, m + 1u, total);
        sane = sane && next > theta_at(h, m, total) && finite(next);
    }
    var out = FlatRing(0.0, 0.0, total, STATUS_OK);
    if (!sane) {
        out.status = STATUS_DEGENERATE;
        return out;
    }
    if (h.kind == KIND_DISK) {
        let a = 2.0 * PI / total;
        out.a = a;
        out.a2 = a;
        if (!check_sectors(h, 0u, k, 0u, 0u, a, total)) {
            out.status = STATUS_FLIPPED_FAN;
        }
        for (var m = 0u; m < k; m++) {
            let slot = h.first + m;
            points[slot].mu = polar(points[slot].radius, a, a * points[slot].theta);
        }
        points[h.first].mu = vec2<f32>(pow(points[h.first].radius, a), 0.0);
    } else if (h.kind == KIND_HALF_DISK) {
        let a = PI / total;
        out.a = a;
        out.a2 = a;
        if (!check_sectors(h, 0u, k - 1u, 0u, 0u, a, total)) {
            out.status = STATUS_FLIPPED_FAN;
        }
        for (var m = 1u; m < k - 1u; m++) {
            let slot = h.first + m;
            points[slot].mu = polar(points[slot].radius, a, a * points[slot].theta);
        }
        points[h.first].mu = vec2<f32>(pow(points[h.first].radius, a), 0.0);
        let last = h.first + k - 1u;
        points[last].mu = vec2<f32>(-pow(points[last].radius, a), 0.0);
    } else {
        // Feature line: the upper side s → t and the lower side t → s (wrapping past j_0).
        let s = h.s;
        let t = h.t;
        let theta_s = points[h.first + s].theta;
        let theta_t = points[h.first + t].theta;
        let upper = theta_t - theta_s;
        let lower = total - upper;
        let a1 = PI / upper;
        let a2 = PI / lower;
        out.a = a1;
        out.a2 = a2;
        if (!check_sectors(h, s, t, 0u, 0u, a1, total)
            || !check_sectors(h, t, k, 0u, s, a2, total)) {
            out.status = STATUS_FLIPPED_FAN;
        }
        for (var m = 0u; m < k; m++) {
            let slot = h.first + m;
            let theta = points[slot].theta;
            if (m > s && m < t) {
                points[slot].mu = polar(points[slot].radius, a1, a1 * (theta - theta_s));
            } else if (m != s && m != t) {
                // The lower side; the chord ends s and t are set below.
                var from_t = theta + total - theta_t;
                if (m > t) {
                    from_t = theta - theta_t;
                }
                points[slot].mu = polar(points[slot].radius, a2, PI + a2 * from_t);
            }
        }
        let a_mid = 0.5 * (a1 + a2);
        points[h.first + s].mu = vec2<f32>(pow(points[h.first + s].radius, a_mid), 0.0);
        points[h.first + t].mu = vec2<f32>(-pow(points[h.first + t].radius, a_mid), 0.0);
    }
    if (out.status == STATUS_OK) {
        for (var m = 0u; m < k; m++) {
            let mu = points[h.first + m].mu;
            if (!finite(mu.x) || !finite(mu.y)) {
                out.status = STATUS_DEGENERATE;
            }
        }
    }
    return out;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn maps_flatten(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(num_workgroups) workgroups: vec3<u32>,
) {
    let r = linear_index(gid, workgroups);
    if (r >= params.count) {
        return;
    }
    flat_rings[r] = flatten_ring(rings[r]);
}
