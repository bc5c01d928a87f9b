// gridwarp_aa_cell: one invocation per grid cell, the cell's share of the axis-aligned energy
// and of its normal equations. Prepended by the host: dispatch.wgsl, gridwarp_field.wgsl (the
// bilinear lookup `axis`, `bilinear_formula`).
//
// Twin of the plain f64 path src/gridwarp/plain/aa.rs (`PlainAaEnergy`, the formula sample by
// sample) and src/gridwarp/field.rs (`Field::bilinear`, here `field_bilinear`), name for name:
// `rest_cell`, `slope`, `warped_point`, `stretch`, `residual`, `sample_residuals`,
// `line_derivatives` and `add_residual` are the plain path's functions, in the same order of
// operations per sample
// (bilinear as two lerps, fma where the plain path uses `mul_add`). The plain path's residuals
// are those of the fast path src/gridwarp/energy.rs bit for bit (tests/gridwarp_plain.rs).
//
// Where the kernel differs from the plain path, for the GPU's sake and not in the formula:
// - the plain path finds a sample's rest quantities (σ, o_s, o_t) once (`rest_samples`); the
//   host computes them the same way and uploads them (`samples`);
// - the plain path takes a cell's slopes a, b per sample (`sample_residuals`); the kernel once
//   per cell (`cell_lines`, shared with `gridwarp_aa_residuals`), the same values;
// - the plain path multiplies by 1/h_i, 1/k_j (`inv_h`, computed once per cell) where the
//   kernel divides by h_i, k_j (`line_derivatives`: σ/h, one division instead of a stored
//   reciprocal);
// - the plain path adds a residual's terms to F, Jᵀr and JᵀJ by a product and an addition
//   (`add_residual`); the kernel by fused multiply-adds, and it sums one cell per invocation
//   (all 16 entries of the cell's block) where the plain path adds straight into the whole
//   matrix: the host adds the cells' blocks in cell order, in f64.
//
// One invocation per cell, looping over the cell's K×L samples in the plain path's order
// (a outer, b inner): the simplest correct choice. It needs no workgroup memory or barriers,
// its f32 sums have a fixed order (results do not depend on the adapter's scheduling), and a
// cell's ≤ 2·K·L residuals are few. The cross-cell reduction is done by the host in f64, in cell
// order (deterministic; see gpu/src/gridwarp/aa.rs).
//
// Per sample (α, β, σ, o_s, o_t) of cell (i, j) with rest widths h = h_i, k = k_j, at the
// current lines s, t (src/gridwarp/plain/aa.rs, module docs):
//   a = (s_{i+1} − s_i)/h, b = (t_{j+1} − t_j)/k                          (`slope`)
//   p = (s_i + α(s_{i+1} − s_i), t_j + β(t_{j+1} − t_j))                   (`warped_point`)
//   c_s, c_t = ‖D_s‖, ‖D_t‖ bilinear at p                                  (`stretch`)
//   r^s = σ(c_s a − o_s), r^t = σ(c_t b − o_t)                              (`residual`)
// and their partial derivatives with respect to the cell's four lines, in slot order
// (s_i, s_{i+1}, t_j, t_{j+1}) (`line_derivatives`).

// Rest-pose data of one sample (20 bytes; `RestSample` in gpu/src/gridwarp/aa.rs).
struct RestSample {
    alpha: f32,
    beta: f32,
    sigma: f32,
    o_s: f32,
    o_t: f32,
}

// One cell's output (112 bytes; `CellContribution` in gpu/src/gridwarp/aa.rs). jtj is the
// row-major 4×4 block over the slots (s_i, s_{i+1}, t_j, t_{j+1}); unknowns are their indices
// in x (−1: a fixed boundary line, whose rows and columns the host drops).
struct CellContribution {
    jtj: array<f32, 16>,
    jtr: array<f32, 4>,
    unknowns: array<i32, 4>,
    energy: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

struct AaParams {
    cells: u32,        // (M − 1)(N − 1)
    columns: u32,      // M − 1
    rows: u32,         // N − 1
    per_cell: u32,     // K·L
    ds_width: u32,
    ds_height: u32,
    dt_width: u32,
    dt_height: u32,
    dt_offset: u32,    // D_t's first value in `fields` (D_s starts at 0)
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// `geometry` layout: current s lines (M), current t lines (N), rest widths h_i (M − 1), rest
// widths k_j (N − 1). `unknown_index` layout: s lines (M), then t lines (N).
@group(0) @binding(0) var<uniform> params: AaParams;
@group(0) @binding(1) var<storage, read> samples: array<RestSample>;
@group(0) @binding(2) var<storage, read> geometry: array<f32>;
@group(0) @binding(3) var<storage, read> unknown_index: array<i32>;
@group(0) @binding(4) var<storage, read> fields: array<f32>;
@group(0) @binding(5) var<storage, read_write> cells: array<CellContribution>;

fn field_at(offset: u32, width: u32, x: u32, y: u32) -> f32 {
    return fields[offset + y * width + x];
}

// `Field::bilinear`: interpolation between texel centres, clamped to the edge texels, with its
// gradient (0 along an axis where the sample is clamped): `axis` and `bilinear_formula` of
// gridwarp_field.wgsl on the four texels around (s, t). The field is `fields[offset ..]`,
// width × height, row-major, row 0 at t = 0.
fn field_bilinear(offset: u32, width: u32, height: u32, s: f32, t: f32) -> FieldSample {
    let ax = axis(s, width);
    let ay = axis(t, height);
    let x1 = min(ax.x0 + 1u, width - 1u);
    let y1 = min(ay.x0 + 1u, height - 1u);
    return bilinear_formula(
        ax.frac,
        ax.grad,
        ay.frac,
        ay.grad,
        field_at(offset, width, ax.x0, ay.x0),
        field_at(offset, width, x1, ay.x0),
        field_at(offset, width, ax.x0, y1),
        field_at(offset, width, x1, y1),
    );
}

// `rest_cell`: the rest size h_i × k_j of cell (i, j) (`geometry` holds h after the lines,
// then k).
struct RestCell {
    h: f32,
    k: f32,
}

fn rest_cell(i: u32, j: u32) -> RestCell {
    let m = params.columns + 1u;
    let n = params.rows + 1u;
    return RestCell(geometry[m + n + i], geometry[m + n + params.columns + j]);
}

// `slope`: a_i = (s_{i+1} − s_i)/h_i of the lines `near` = s_i, `far` = s_{i+1} (b_j likewise).
fn slope(near: f32, far: f32, rest_width: f32) -> f32 {
    return (far - near) / rest_width;
}

// `warped_point`: p = (s_i + α (s_{i+1} − s_i), t_j + β (t_{j+1} − t_j)).
fn warped_point(s0: f32, s1: f32, t0: f32, t1: f32, alpha: f32, beta: f32) -> vec2<f32> {
    return vec2<f32>(s0 + alpha * (s1 - s0), t0 + beta * (t1 - t0));
}

// `stretch`: c = ‖D_·‖ at p with its gradient, the field `fields[offset ..]` (width × height)
// sampled bilinearly.
fn stretch(offset: u32, width: u32, height: u32, p: vec2<f32>) -> FieldSample {
    return field_bilinear(offset, width, height, p.x, p.y);
}

// `residual`: r = σ (c a − o), c a − o rounded once (a = a_i or b_j, the cell's slope).
fn residual(sigma: f32, c: f32, a: f32, o: f32) -> f32 {
    return sigma * fma(c, a, -o);
}

// `line_derivatives`: the derivatives of r = σ (c a − o) with respect to the near and far
// lines along the residual's axis and across it, [near along, far along, near across, far
// across], from u = σ a ∂c/∂along, v = σ c/h, w = σ a ∂c/∂across (the kernel divides by h
// where the plain path multiplies by 1/h: header).
fn line_derivatives(
    sigma: f32,
    c: f32,
    dc_along: f32,
    dc_across: f32,
    a: f32,
    rest_width: f32,
    along: f32,
    across: f32,
) -> array<f32, 4> {
    let sigma_a = sigma * a;
    let u = sigma_a * dc_along;
    let v = (sigma / rest_width) * c;
    let w = sigma_a * dc_across;
    return array<f32, 4>(
        fma(u, 1.0 - along, -v),
        fma(u, along, v),
        w * (1.0 - across),
        w * across,
    );
}

// `add_residual`: F += r², Jᵀr += d r, JᵀJ += d dᵀ over the cell's four slots (fused
// multiply-adds: header).
fn add_residual(out: ptr<function, CellContribution>, r: f32, d: array<f32, 4>) {
    (*out).energy = fma(r, r, (*out).energy);
    for (var u = 0u; u < 4u; u++) {
        (*out).jtr[u] = fma(d[u], r, (*out).jtr[u]);
        for (var v = 0u; v < 4u; v++) {
            (*out).jtj[u * 4u + v] = fma(d[u], d[v], (*out).jtj[u * 4u + v]);
        }
    }
}

// What every sample of cell (i, j) shares: its four lines s_i, s_{i+1}, t_j, t_{j+1}, its rest
// widths and the slopes a, b (the plain path's `rest_cell` and `slope`, which the plain path
// takes per sample; the same values).
struct CellLines {
    s0: f32,
    s1: f32,
    t0: f32,
    t1: f32,
    cell: RestCell,
    a: f32,
    b: f32,
}

fn cell_lines(i: u32, j: u32) -> CellLines {
    let m = params.columns + 1u;
    let s0 = geometry[i];
    let s1 = geometry[i + 1u];
    let t0 = geometry[m + j];
    let t1 = geometry[m + j + 1u];
    let cell = rest_cell(i, j);
    return CellLines(s0, s1, t0, t1, cell, slope(s0, s1, cell.h), slope(t0, t1, cell.k));
}

// One sample's residuals r^s, r^t and the stretches their derivatives need (the plain path's
// `sample_residuals`, its derivatives left to the caller).
struct SampleResiduals {
    r_s: f32,
    r_t: f32,
    c_s: FieldSample,
    c_t: FieldSample,
}

fn sample_residuals(l: CellLines, sample: RestSample) -> SampleResiduals {
    let p = warped_point(l.s0, l.s1, l.t0, l.t1, sample.alpha, sample.beta);
    let c_s = stretch(0u, params.ds_width, params.ds_height, p);
    let c_t = stretch(params.dt_offset, params.dt_width, params.dt_height, p);
    return SampleResiduals(
        residual(sample.sigma, c_s.value, l.a, sample.o_s),
        residual(sample.sigma, c_t.value, l.b, sample.o_t),
        c_s,
        c_t,
    );
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gridwarp_aa_cell(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if index >= params.cells {
        return;
    }
    // Cell (i, j) = cell column i, row j, at i·rows + j (the plain path's cell order).
    let i = index / params.rows;
    let j = index % params.rows;
    let m = params.columns + 1u;
    let l = cell_lines(i, j);

    var out: CellContribution;
    // `cell_unknowns`: the unknowns of the slots (s_i, s_{i+1}, t_j, t_{j+1}).
    out.unknowns = array<i32, 4>(
        unknown_index[i],
        unknown_index[i + 1u],
        unknown_index[m + j],
        unknown_index[m + j + 1u],
    );
    let first = index * params.per_cell;
    for (var n = 0u; n < params.per_cell; n++) {
        let sample = samples[first + n];
        if sample.sigma == 0.0 {
            continue;
        }
        let alpha = sample.alpha;
        let beta = sample.beta;
        let sigma = sample.sigma;
        let r = sample_residuals(l, sample);
        // r^s stretches along s: its lines along are s_i, s_{i+1} (slots 0, 1).
        let d_s = line_derivatives(sigma, r.c_s.value, r.c_s.ds, r.c_s.dt, l.a, l.cell.h, alpha, beta);
        // r^t stretches along t: its lines along are t_j, t_{j+1} (slots 2, 3).
        let d_t = line_derivatives(sigma, r.c_t.value, r.c_t.dt, r.c_t.ds, l.b, l.cell.k, beta, alpha);
        add_residual(&out, r.r_s, d_s);
        add_residual(&out, r.r_t, array<f32, 4>(d_t[2], d_t[3], d_t[0], d_t[1]));
    }
    cells[index] = out;
}
