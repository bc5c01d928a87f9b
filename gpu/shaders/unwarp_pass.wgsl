// unwarp_pass: one phase pass of the per-texel descent of distortion-free displacement mapping,
// one invocation per active texel. Prepended by the host: dispatch.wgsl.
//
// Twin of the f64 reference src/unwarp/energy.rs, fixation.rs and pass.rs, function for
// function and in the same order of operations: triangle_geometry, uv_area, dirichlet,
// theta_power, triangle_energy, triangle_gradient, fan_new (Fan::new), triangles_energy,
// triangles_gradient, node_energy, node_gradient, pin_q, pin_energy, pin_gradient, pin_root,
// line_point, flip_free_bracket, ternary_search, descend_texel.
//
// Texels of one phase share no triangle: each invocation reads only its own offset and those of
// its six neighbours (which no invocation of this dispatch writes), so it updates `offsets` in
// place without races, and the result does not depend on scheduling.

const SEARCH_ITERATIONS: u32 = 31u;
const SEARCH_RELATIVE_WIDTH: f32 = 1e-6;

// The 6 neighbour steps (dx, dy), counter-clockwise (STENCIL in src/unwarp/mesh.rs).
const STENCIL = array<vec2<i32>, 6>(
    vec2<i32>(0, -1), vec2<i32>(1, -1), vec2<i32>(1, 0),
    vec2<i32>(0, 1), vec2<i32>(-1, 1), vec2<i32>(-1, 0),
);

struct UnwarpParams {
    width: u32,
    height: u32,
    periodic: u32,   // 1: wrap across the border; 0: fixed border (active texels are interior)
    count: u32,      // active texels of this phase
    theta: f32,
    pin_resolution_x: f32,   // R of the pin barrier: the finest level's (W, H)
    pin_resolution_y: f32,
    _pad0: f32,
}

// Per active texel (16 bytes; `TexelResult` in gpu/src/unwarp/pass.rs).
struct TexelResult {
    offset: vec2<f32>,
    path: u32,       // bit i: iteration i of the ternary search moved lo up
    flags: u32,      // bits 0–7: search steps; bit 8: moved; bit 9: bracket found
}

@group(0) @binding(0) var<uniform> params: UnwarpParams;
@group(0) @binding(1) var<storage, read> z: array<f32>;            // s·h per node
@group(0) @binding(2) var<storage, read> pins: array<f32>;         // pin weight per node
@group(0) @binding(3) var<storage, read> active_texels: array<u32>;     // node index per invocation
@group(0) @binding(4) var<storage, read_write> offsets: array<vec2<f32>>;
@group(0) @binding(5) var<storage, read_write> results: array<TexelResult>;

fn infinity() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

struct TriangleGeometry {
    area: f32,   // A = |P1 × P2|
    c12: f32,    // P1·P2
    c11: f32,    // (P2 − P1)·P2
    c22: f32,    // P1·(P1 − P2)
}

fn triangle_geometry(p1: vec3<f32>, p2: vec3<f32>) -> TriangleGeometry {
    let c = vec3<f32>(
        p1.y * p2.z - p1.z * p2.y,
        p1.z * p2.x - p1.x * p2.z,
        p1.x * p2.y - p1.y * p2.x,
    );
    return TriangleGeometry(
        sqrt(c.x * c.x + c.y * c.y + c.z * c.z),
        p1.x * p2.x + p1.y * p2.y + p1.z * p2.z,
        (p2.x - p1.x) * p2.x + (p2.y - p1.y) * p2.y + (p2.z - p1.z) * p2.z,
        p1.x * (p1.x - p2.x) + p1.y * (p1.y - p2.y) + p1.z * (p1.z - p2.z),
    );
}

// a = U1.x U2.y − U2.x U1.y
fn uv_area(u1: vec2<f32>, u2: vec2<f32>) -> f32 {
    return u1.x * u2.y - u2.x * u1.y;
}

// D = |U1 − U2|² (P1·P2) + |U1|² ((P2 − P1)·P2) + |U2|² (P1·(P1 − P2))
fn dirichlet(t: TriangleGeometry, u1: vec2<f32>, u2: vec2<f32>) -> f32 {
    let u12 = u1 - u2;
    return (u12.x * u12.x + u12.y * u12.y) * t.c12 + (u1.x * u1.x + u1.y * u1.y) * t.c11
        + (u2.x * u2.x + u2.y * u2.y) * t.c22;
}

// y^θ: square-and-multiply when θ is an integer in [−64, 64], else pow.
fn theta_power(y: f32, theta: f32) -> f32 {
    if (fract(theta) == 0.0 && abs(theta) <= 64.0) {
        var n = u32(abs(theta));
        var base = y;
        var result = 1.0;
        loop {
            if (n == 0u) { break; }
            if ((n & 1u) == 1u) { result = result * base; }
            base = base * base;
            n = n >> 1u;
        }
        if (theta < 0.0) { return 1.0 / result; }
        return result;
    }
    return pow(y, theta);
}

// E_T = D/(A a) · (A/a + a/A)^θ; +∞ when a ≤ 0.
fn triangle_energy(t: TriangleGeometry, u1: vec2<f32>, u2: vec2<f32>, theta: f32) -> f32 {
    let a = uv_area(u1, u2);
    if (!(a > 0.0)) { return infinity(); }
    let d = dirichlet(t, u1, u2);
    let y = t.area / a + a / t.area;
    return d / (t.area * a) * theta_power(y, theta);
}

// ∇E_T = Y^θ [−D/(A a²) r + ∇D/(A a)] + D/(A a) · θ Y^{θ−1} (1/A − A/a²) r
fn triangle_gradient(t: TriangleGeometry, u1: vec2<f32>, u2: vec2<f32>, theta: f32) -> vec2<f32> {
    let a = uv_area(u1, u2);
    if (!(a > 0.0)) { return vec2<f32>(infinity(), infinity()); }
    let big_a = t.area;
    let r = vec2<f32>(u2.y - u1.y, u1.x - u2.x);
    let d = dirichlet(t, u1, u2);
    let grad_d = vec2<f32>(
        2.0 * (u1.x * t.c11 + u2.x * t.c22),
        2.0 * (u1.y * t.c11 + u2.y * t.c22),
    );
    let y = big_a / a + a / big_a;
    let y_theta_m1 = theta_power(y, theta - 1.0);
    let y_theta = y_theta_m1 * y;
    let mips = d / (big_a * a);
    let r_coef = -d / (big_a * a * a) * y_theta + mips * theta * y_theta_m1 * (1.0 / big_a - big_a / (a * a));
    let d_coef = y_theta / (big_a * a);
    return vec2<f32>(r_coef * r.x + d_coef * grad_d.x, r_coef * r.y + d_coef * grad_d.y);
}

struct Fan {
    geometry: array<TriangleGeometry, 6>,   // T_k = (c, n_{k−1}, n_k)
    rel: array<vec2<f32>, 6>,               // U_k = o_c + rel_k, rel_k = −d_k/R − o_{n_k}
}

fn neighbour(x: u32, y: u32, k: u32) -> u32 {
    let w = i32(params.width);
    let h = i32(params.height);
    let n = vec2<i32>(i32(x), i32(y)) + STENCIL[k];
    // Periodic: wrap. Fixed: active texels are interior, so n is inside.
    let nx = ((n.x % w) + w) % w;
    let ny = ((n.y % h) + h) % h;
    return u32(ny * w + nx);
}

fn fan_new(x: u32, y: u32) -> Fan {
    let resolution = vec2<f32>(f32(params.width), f32(params.height));
    let c = y * params.width + x;
    var p: array<vec3<f32>, 6>;
    var fan: Fan;
    for (var k = 0u; k < 6u; k = k + 1u) {
        let n = neighbour(x, y, k);
        let base = vec2<f32>(-f32(STENCIL[k].x) / resolution.x, -f32(STENCIL[k].y) / resolution.y);
        p[k] = vec3<f32>(base.x, base.y, z[c] - z[n]);
        fan.rel[k] = base - offsets[n];
    }
    for (var k = 0u; k < 6u; k = k + 1u) {
        fan.geometry[k] = triangle_geometry(p[(k + 5u) % 6u], p[k]);
    }
    return fan;
}

fn triangles_energy(fan: Fan, o: vec2<f32>, theta: f32) -> f32 {
    var u: array<vec2<f32>, 6>;
    for (var k = 0u; k < 6u; k = k + 1u) { u[k] = o + fan.rel[k]; }
    var sum = 0.0;
    for (var k = 0u; k < 6u; k = k + 1u) {
        sum = sum + triangle_energy(fan.geometry[k], u[(k + 5u) % 6u], u[k], theta);
    }
    return sum;
}

fn triangles_gradient(fan: Fan, o: vec2<f32>, theta: f32) -> vec2<f32> {
    var u: array<vec2<f32>, 6>;
    for (var k = 0u; k < 6u; k = k + 1u) { u[k] = o + fan.rel[k]; }
    var sum = vec2<f32>(0.0, 0.0);
    for (var k = 0u; k < 6u; k = k + 1u) {
        sum = sum + triangle_gradient(fan.geometry[k], u[(k + 5u) % 6u], u[k], theta);
    }
    return sum;
}

// q = ‖w R⊙o‖²
fn pin_q(weight: f32, resolution: vec2<f32>, o: vec2<f32>) -> f32 {
    let t = weight * resolution * o;
    return t.x * t.x + t.y * t.y;
}

// E_pin = ½ / (1 − q), +∞ when q ≥ 1
fn pin_energy(weight: f32, resolution: vec2<f32>, o: vec2<f32>) -> f32 {
    let q = pin_q(weight, resolution, o);
    if (q < 1.0) { return 0.5 / (1.0 - q); }
    return infinity();
}

// ∇E_pin = ½ ∇q / (1 − q)², ∇q = 2 w² (W² o.x, H² o.y)
fn pin_gradient(weight: f32, resolution: vec2<f32>, o: vec2<f32>) -> vec2<f32> {
    let q = pin_q(weight, resolution, o);
    let s = 0.5 / ((1.0 - q) * (1.0 - q));
    let w2 = weight * weight;
    return vec2<f32>(
        s * 2.0 * w2 * resolution.x * resolution.x * o.x,
        s * 2.0 * w2 * resolution.y * resolution.y * o.y,
    );
}

// Positive root t of q(o − t g) = 1, or −1 when none (w = 0, g = 0, or outside).
fn pin_root(weight: f32, resolution: vec2<f32>, o: vec2<f32>, g: vec2<f32>) -> f32 {
    let w2 = weight * weight;
    let rx2 = resolution.x * resolution.x;
    let ry2 = resolution.y * resolution.y;
    let alpha = w2 * (rx2 * g.x * g.x + ry2 * g.y * g.y);
    let beta = w2 * (rx2 * o.x * g.x + ry2 * o.y * g.y);
    let gamma = pin_q(weight, resolution, o);
    if (!(alpha > 0.0) || !(gamma < 1.0)) { return -1.0; }
    let disc = sqrt(beta * beta + alpha * (1.0 - gamma));
    if (beta >= 0.0) { return (beta + disc) / alpha; }
    return (1.0 - gamma) / (disc - beta);
}

fn node_energy(fan: Fan, weight: f32, resolution: vec2<f32>, o: vec2<f32>, theta: f32) -> f32 {
    return triangles_energy(fan, o, theta) + pin_energy(weight, resolution, o);
}

fn node_gradient(fan: Fan, weight: f32, resolution: vec2<f32>, o: vec2<f32>, theta: f32) -> vec2<f32> {
    return triangles_gradient(fan, o, theta) + pin_gradient(weight, resolution, o);
}

fn line_point(o: vec2<f32>, g: vec2<f32>, t: f32) -> vec2<f32> {
    return vec2<f32>(o.x - t * g.x, o.y - t * g.y);
}

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - b.x * a.y;
}

// [lo, hi] as (lo, hi, found): every unfolded triangle's zero crossing bounds hi, a folded one's
// lo; the pin barrier's root bounds hi.
fn flip_free_bracket(fan: Fan, weight: f32, resolution: vec2<f32>, o: vec2<f32>, g: vec2<f32>) -> vec3<f32> {
    var lo = 0.0;
    var hi = infinity();
    for (var k = 0u; k < 6u; k = k + 1u) {
        let u1 = o + fan.rel[(k + 5u) % 6u];
        let u2 = o + fan.rel[k];
        let a = uv_area(u1, u2);
        let den = cross2(u1, g) + cross2(g, u2);
        let t0 = a / den;
        if (t0 > 0.0) {
            if (a > 0.0) { hi = min(hi, t0); } else { lo = max(lo, t0); }
        }
    }
    let root = pin_root(weight, resolution, o, g);
    if (root > 0.0) { hi = min(hi, root); }
    let found = lo < hi && hi < infinity();
    return vec3<f32>(lo, hi, select(0.0, 1.0, found));
}

struct Search {
    t: f32,
    path: u32,
    steps: u32,
}

fn ternary_search(fan: Fan, weight: f32, resolution: vec2<f32>, o: vec2<f32>, g: vec2<f32>, theta: f32, lo_in: f32, hi_in: f32) -> Search {
    var lo = lo_in;
    var hi = hi_in;
    var path = 0u;
    var steps = 0u;
    for (var i = 0u; i < SEARCH_ITERATIONS; i = i + 1u) {
        if (hi - lo <= SEARCH_RELATIVE_WIDTH * hi) { break; }
        let third = (hi - lo) / 3.0;
        let t1 = lo + third;
        let t2 = hi - third;
        if (node_energy(fan, weight, resolution, line_point(o, g, t1), theta)
            > node_energy(fan, weight, resolution, line_point(o, g, t2), theta)) {
            lo = t1;
            path = path | (1u << i);
        } else {
            hi = t2;
        }
        steps = steps + 1u;
    }
    return Search(0.5 * (lo + hi), path, steps);
}

fn descend_texel(x: u32, y: u32) -> TexelResult {
    let c = y * params.width + x;
    let o = offsets[c];
    let weight = pins[c];
    let resolution = vec2<f32>(params.pin_resolution_x, params.pin_resolution_y);
    let theta = params.theta;
    let fan = fan_new(x, y);
    let g = node_gradient(fan, weight, resolution, o, theta);
    var result = TexelResult(o, 0u, 0u);
    let finite = abs(g.x) < infinity() && abs(g.y) < infinity();
    if (!finite || (g.x == 0.0 && g.y == 0.0)) { return result; }
    let bracket = flip_free_bracket(fan, weight, resolution, o, g);
    if (bracket.z == 0.0) { return result; }
    result.flags = 1u << 9u;
    let search = ternary_search(fan, weight, resolution, o, g, theta, bracket.x, bracket.y);
    result.path = search.path;
    result.flags = result.flags | search.steps;
    if (node_energy(fan, weight, resolution, line_point(o, g, search.t), theta)
        < node_energy(fan, weight, resolution, o, theta)) {
        result.offset = line_point(o, g, search.t);
        result.flags = result.flags | (1u << 8u);
    }
    return result;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn unwarp_pass(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let i = linear_index(gid, workgroups);
    if (i >= params.count) { return; }
    let c = active_texels[i];
    let result = descend_texel(c % params.width, c / params.width);
    offsets[c] = result.offset;
    results[i] = result;
}
