// gridwarp_naa_cell: one invocation per grid cell, the cell's share of the non-axis-aligned
// energy (seed 000 §8, §7: the objective and its Jacobian on the GPU, Table 1's ObjFunc column
// for the `nonaa-` rows) and of its normal equations. Prepended by the host: dispatch.wgsl,
// gridwarp_field.wgsl (the bilinear lookup `axis`, `bilinear_formula`).
//
// Twin of the plain f64 path src/gridwarp/plain/naa.rs (`PlainNaaEnergy`, the formula sample by
// sample, Gauss–Newton) and src/gridwarp/field.rs (`Field::bilinear`, here
// `component_bilinear`), name for name: `rest_cell`, `corners`, `bilinear_warp`, `partial_at`,
// `jacobian_at`, `image`, `norm`, `dot3` (the plain path's `dot`: WGSL has a builtin of that
// name), `residual`, `corner_weights`, `corner_weight_slopes`, `residual_derivatives`,
// `sample_residuals` and `add_residual` are the plain path's functions, in the same order of
// operations per sample. The plain path's residuals are those of the fast path
// src/gridwarp/energy_naa (tests/gridwarp_plain.rs).
//
// Where the kernel differs from the plain path, for the GPU's sake and not in the formula:
// - the plain path finds a sample's rest quantities (σ, o_s, o_t) once (`rest_samples`); the
//   host computes them the same way and uploads them (`samples`);
// - the plain path keeps D_s, D_t as six scalar fields (x, y, z of each), each with its own
//   size; the kernel reads each as one array of 3 values per texel (`d_s`, `d_t`: [H, W, 3],
//   one size per vector field), the host refusing components of different sizes;
// - the plain path adds a residual's terms to F, Jᵀr and JᵀJ by a product and an addition,
//   and only for the slots that are unknowns (`add_residual`); the kernel by fused
//   multiply-adds over all 8 slots of the cell (the 64 entries of its block), writing the
//   slots' unknowns beside them (−1: a fixed coordinate): the host adds the cells' blocks in
//   cell order, in f64, dropping the fixed ones;
// - the plain path returns F = +∞ for a folded vertex grid (`VertexGrid::is_valid`); the
//   kernel computes whatever the vertices give, and the host checks the grid (in f64) before
//   it dispatches;
// - the plain path's second-order terms (`residual_curvature`, for `NaaModel::Newton`) are not
//   computed: this is the Gauss–Newton objective, the paper's.
//
// One invocation per cell, looping over the cell's K×L samples in the plain path's order
// (a outer, b inner), as gridwarp_aa.wgsl: no workgroup memory or barriers, f32 sums in a fixed
// order (results do not depend on the adapter's scheduling); the cross-cell reduction is the
// host's, in f64, in cell order (gpu/src/gridwarp/naa.rs).
//
// Per sample (α, β, σ, o_s, o_t) of cell (i, j) with rest size h × k and corners P00 = P_ij,
// P10 = P_{i+1,j}, P01 = P_{i,j+1}, P11 = P_{i+1,j+1} (src/gridwarp/plain/naa.rs, module docs):
//   p = W(α, β),  W_s = (∂W/∂α)/h,  W_t = (∂W/∂β)/k                    (`bilinear_warp`)
//   J_D = [D_s D_t] at p, bilinear, with its derivatives along s and t (`jacobian_at`)
//   q_s = J_D W_s,  q_t = J_D W_t                                        (`image`)
//   r^s = σ (‖q_s‖ − o_s),  r^t = σ (‖q_t‖ − o_t)                        (`residual`)
// and the derivatives of each with respect to the cell's 8 corner coordinates, slot 2c + k =
// coordinate k (s, t) of corner c (`residual_derivatives`).

// Rest-pose data of one sample (20 bytes; `RestSample` in gpu/src/gridwarp/aa.rs).
struct RestSample {
    alpha: f32,
    beta: f32,
    sigma: f32,
    o_s: f32,
    o_t: f32,
}

// One cell's output (336 bytes; `NaaCellContribution` in gpu/src/gridwarp/naa.rs). jtj is the
// row-major 8×8 block over the slots (P00.s, P00.t, P10.s, P10.t, P01.s, P01.t, P11.s, P11.t);
// unknowns are their indices in x (−1: a fixed coordinate, whose row and column the host drops).
struct NaaCellContribution {
    jtj: array<f32, 64>,
    jtr: array<f32, 8>,
    unknowns: array<i32, 8>,
    energy: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

struct NaaParams {
    cells: u32,        // (M − 1)(N − 1)
    columns: u32,      // M − 1
    rows: u32,         // N − 1
    per_cell: u32,     // K·L
    ds_width: u32,
    ds_height: u32,
    dt_width: u32,
    dt_height: u32,
}

// Inputs in the manifest's order (src/vectors/gridwarp_naa.rs), one .npy each.
@group(0) @binding(0) var<uniform> params: NaaParams;
@group(0) @binding(1) var<storage, read> samples: array<RestSample>;     // [cells·K·L, 5]
@group(0) @binding(2) var<storage, read> rest_h: array<f32>;              // [M − 1]
@group(0) @binding(3) var<storage, read> rest_k: array<f32>;              // [N − 1]
@group(0) @binding(4) var<storage, read> vertices: array<vec2<f32>>;      // [M·N, 2], P_ab at a·N + b
@group(0) @binding(5) var<storage, read> vertex_index: array<vec2<i32>>;  // [M·N, 2]
@group(0) @binding(6) var<storage, read> d_s: array<f32>;                 // [H, W, 3]
@group(0) @binding(7) var<storage, read> d_t: array<f32>;                 // [H, W, 3]
@group(0) @binding(8) var<storage, read_write> cells: array<NaaCellContribution>;

// `rest_cell`: the rest size h_i × k_j of cell (i, j).
struct RestCell {
    h: f32,
    k: f32,
}

fn rest_cell(i: u32, j: u32) -> RestCell {
    return RestCell(rest_h[i], rest_k[j]);
}

// Vertex P_ab (a along s, b along t) of the current grid.
fn vertex(a: u32, b: u32) -> vec2<f32> {
    return vertices[a * (params.rows + 1u) + b];
}

// `corners`: [P00, P10, P01, P11] of cell (i, j).
struct Corners {
    p00: vec2<f32>,
    p10: vec2<f32>,
    p01: vec2<f32>,
    p11: vec2<f32>,
}

fn corners(i: u32, j: u32) -> Corners {
    return Corners(vertex(i, j), vertex(i + 1u, j), vertex(i, j + 1u), vertex(i + 1u, j + 1u));
}

// `Warp`: a sample's warped point p = W(α, β) and the slopes W_s = (∂W/∂α)/h, W_t = (∂W/∂β)/k.
struct Warp {
    p: vec2<f32>,
    w_s: vec2<f32>,
    w_t: vec2<f32>,
}

// `bilinear_warp`: W = P00 + α e_α + β e_β + αβ τ, e_α = P10 − P00, e_β = P01 − P00,
// τ = P11 − P10 − P01 + P00; W_s = e_α/h + β τ/h, W_t = e_β/k + α τ/k (τ = 0 on a rectangle).
fn bilinear_warp(c: Corners, cell: RestCell, alpha: f32, beta: f32) -> Warp {
    let e_alpha = c.p10 - c.p00;
    let e_beta = c.p01 - c.p00;
    let twist = (c.p11 - c.p10) - e_beta;
    let h = cell.h;
    let k = cell.k;
    return Warp(
        (c.p00 + alpha * e_alpha) + (beta * e_beta + (alpha * beta) * twist),
        e_alpha / h + beta * (twist / h),
        e_beta / k + alpha * (twist / k),
    );
}

// `Partial`: one column of J_D at a point (the vector D_s or D_t) and its derivatives along s
// and t.
struct Partial {
    value: vec3<f32>,
    ds: vec3<f32>,
    dt: vec3<f32>,
}

// Component c (x, y, z) of texel (x, y) of `field` (0: D_s, 1: D_t), [H, W, 3] row-major, row 0
// at t = 0.
fn texel(field: u32, x: u32, y: u32, c: u32) -> f32 {
    if field == 0u {
        return d_s[(y * params.ds_width + x) * 3u + c];
    }
    return d_t[(y * params.dt_width + x) * 3u + c];
}

// `Field::bilinear` of component c of `field` (width × height texels) at p.
fn component_bilinear(field: u32, width: u32, height: u32, c: u32, p: vec2<f32>) -> FieldSample {
    let ax = axis(p.x, width);
    let ay = axis(p.y, height);
    let x1 = min(ax.x0 + 1u, width - 1u);
    let y1 = min(ay.x0 + 1u, height - 1u);
    return bilinear_formula(
        ax.frac,
        ax.grad,
        ay.frac,
        ay.grad,
        texel(field, ax.x0, ay.x0, c),
        texel(field, x1, ay.x0, c),
        texel(field, ax.x0, y1, c),
        texel(field, x1, y1, c),
    );
}

// `partial_at`: one vector field (0: D_s, 1: D_t) at p, each component sampled bilinearly with
// its gradient.
fn partial_at(field: u32, p: vec2<f32>) -> Partial {
    var width = params.ds_width;
    var height = params.ds_height;
    if field == 1u {
        width = params.dt_width;
        height = params.dt_height;
    }
    let x = component_bilinear(field, width, height, 0u, p);
    let y = component_bilinear(field, width, height, 1u, p);
    let z = component_bilinear(field, width, height, 2u, p);
    return Partial(
        vec3<f32>(x.value, y.value, z.value),
        vec3<f32>(x.ds, y.ds, z.ds),
        vec3<f32>(x.dt, y.dt, z.dt),
    );
}

// `jacobian_at`: J_D = [D_s, D_t] at p with its derivatives.
struct Jacobian {
    d_s: Partial,
    d_t: Partial,
}

fn jacobian_at(p: vec2<f32>) -> Jacobian {
    return Jacobian(partial_at(0u, p), partial_at(1u, p));
}

// `image`: q = J_D w = D_s w.x + D_t w.y (also with J_D's derivatives in place of J_D).
fn image(d_s_k: vec3<f32>, d_t_k: vec3<f32>, w: vec2<f32>) -> vec3<f32> {
    return d_s_k * w.x + d_t_k * w.y;
}

// `norm`: ‖q‖ = sqrt(q.x² + q.y² + q.z²).
fn norm(q: vec3<f32>) -> f32 {
    return sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
}

// `dot`: x · y.
fn dot3(x: vec3<f32>, y: vec3<f32>) -> f32 {
    return x.x * y.x + x.y * y.y + x.z * y.z;
}

// `residual`: r = σ (‖q‖ − o).
fn residual(sigma: f32, q: vec3<f32>, o: f32) -> f32 {
    return sigma * (norm(q) - o);
}

// `corner_weights`: φ = [(1−α)(1−β), α(1−β), (1−α)β, αβ] of corners 00, 10, 01, 11.
fn corner_weights(alpha: f32, beta: f32) -> vec4<f32> {
    return vec4<f32>(
        (1.0 - alpha) * (1.0 - beta),
        alpha * (1.0 - beta),
        (1.0 - alpha) * beta,
        alpha * beta,
    );
}

// `corner_weight_slopes`: φ'_c = ∂φ_c/∂s for the s residual (`axis_index` 0):
// [−(1−β)/h, (1−β)/h, −β/h, β/h]; ∂φ_c/∂t for the t residual (1): [−(1−α)/k, −α/k, (1−α)/k, α/k].
fn corner_weight_slopes(axis_index: u32, cell: RestCell, alpha: f32, beta: f32) -> vec4<f32> {
    if axis_index == 0u {
        let near = (1.0 - beta) / cell.h;
        let far = beta / cell.h;
        return vec4<f32>(-near, near, -far, far);
    }
    let near = (1.0 - alpha) / cell.k;
    let far = alpha / cell.k;
    return vec4<f32>(-near, -far, near, far);
}

// `residual_derivatives`: ∂r/∂P_c,k = φ'_c m_k + φ_c g_k, m_k = (σ/‖q‖) D_k · q,
// g_k = (σ/‖q‖) q · (∂_k J_D) w, q = J_D w; σ/‖q‖ taken as 0 at q = 0.
fn residual_derivatives(
    sigma: f32,
    jacobian: Jacobian,
    w: vec2<f32>,
    phi: vec4<f32>,
    dphi: vec4<f32>,
) -> array<f32, 8> {
    let d_s_k = jacobian.d_s;
    let d_t_k = jacobian.d_t;
    let q = image(d_s_k.value, d_t_k.value, w);
    let q_length = norm(q);
    var factor = 0.0;
    if q_length > 0.0 {
        factor = sigma / q_length;
    }
    let m = vec2<f32>(factor * dot3(d_s_k.value, q), factor * dot3(d_t_k.value, q));
    let g = vec2<f32>(
        factor * dot3(q, image(d_s_k.ds, d_t_k.ds, w)),
        factor * dot3(q, image(d_s_k.dt, d_t_k.dt, w)),
    );
    var d: array<f32, 8>;
    for (var c = 0u; c < 4u; c++) {
        d[2u * c] = dphi[c] * m.x + phi[c] * g.x;
        d[2u * c + 1u] = dphi[c] * m.y + phi[c] * g.y;
    }
    return d;
}

// `add_residual`: F += r², Jᵀr += d r, JᵀJ += d dᵀ over the cell's 8 slots (fused
// multiply-adds: header).
fn add_residual(out: ptr<function, NaaCellContribution>, r: f32, d: array<f32, 8>) {
    (*out).energy = fma(r, r, (*out).energy);
    for (var u = 0u; u < 8u; u++) {
        (*out).jtr[u] = fma(d[u], r, (*out).jtr[u]);
        for (var v = 0u; v < 8u; v++) {
            (*out).jtj[u * 8u + v] = fma(d[u], d[v], (*out).jtj[u * 8u + v]);
        }
    }
}

// One sample's residuals r^s, r^t, and the warp and J_D their derivatives need (the plain
// path's `sample_residuals`, its derivatives left to the caller).
struct SampleResiduals {
    r_s: f32,
    r_t: f32,
    warp: Warp,
    jacobian: Jacobian,
}

fn sample_residuals(cell: RestCell, quad: Corners, sample: RestSample) -> SampleResiduals {
    let warp = bilinear_warp(quad, cell, sample.alpha, sample.beta);
    let jacobian = jacobian_at(warp.p);
    let q_s = image(jacobian.d_s.value, jacobian.d_t.value, warp.w_s);
    let q_t = image(jacobian.d_s.value, jacobian.d_t.value, warp.w_t);
    return SampleResiduals(
        residual(sample.sigma, q_s, sample.o_s),
        residual(sample.sigma, q_t, sample.o_t),
        warp,
        jacobian,
    );
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gridwarp_naa_cell(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.cells {
        return;
    }
    // Cell (i, j) = cell column i, row j, at i·rows + j (the plain path's cell order).
    let i = index / params.rows;
    let j = index % params.rows;
    let n = params.rows + 1u;
    let cell = rest_cell(i, j);
    let quad = corners(i, j);

    var out: NaaCellContribution;
    // `cell_unknowns`: slot 2c + k is coordinate k of corner c (00, 10, 01, 11).
    let u00 = vertex_index[i * n + j];
    let u10 = vertex_index[(i + 1u) * n + j];
    let u01 = vertex_index[i * n + j + 1u];
    let u11 = vertex_index[(i + 1u) * n + j + 1u];
    out.unknowns = array<i32, 8>(u00.x, u00.y, u10.x, u10.y, u01.x, u01.y, u11.x, u11.y);
    let first = index * params.per_cell;
    for (var s = 0u; s < params.per_cell; s++) {
        let sample = samples[first + s];
        if sample.sigma == 0.0 {
            continue;
        }
        let alpha = sample.alpha;
        let beta = sample.beta;
        let r = sample_residuals(cell, quad, sample);
        let phi = corner_weights(alpha, beta);
        let d_s_slots = residual_derivatives(
            sample.sigma,
            r.jacobian,
            r.warp.w_s,
            phi,
            corner_weight_slopes(0u, cell, alpha, beta),
        );
        let d_t_slots = residual_derivatives(
            sample.sigma,
            r.jacobian,
            r.warp.w_t,
            phi,
            corner_weight_slopes(1u, cell, alpha, beta),
        );
        add_residual(&out, r.r_s, d_s_slots);
        add_residual(&out, r.r_t, d_t_slots);
    }
    cells[index] = out;
}
