// gridwarp_aa_cell: one invocation per grid cell, the cell's share of the axis-aligned energy
// and of its normal equations. Prepended by the host: dispatch.wgsl.
//
// Twin of the f64 reference src/gridwarp/energy.rs (`AaEnergy::for_each_residual`) and
// src/gridwarp/field.rs (`Field::bilinear`, here `field_bilinear`), name for name and in the
// same order of operations per sample (bilinear as two lerps, the factored derivatives of
// `Chunk::residuals_and_derivatives`, fma where the reference uses `mul_add`). Differences of
// place, not of formula: the reference finds a sample's texel position (`Axis`, here `axis`)
// once per column and once per row of samples, since an axis-aligned grid's samples share them,
// where the kernel recomputes it per sample; it multiplies by a stored 1/h_i, 1/k_j where the
// kernel divides; and it sums 8 samples side by side (per-lane partial sums, upper triangle of
// JᵀJ) where the kernel sums one sample after another (all 16 entries).
//
// One invocation per cell, looping over the cell's K×L samples in the reference's order
// (a outer, b inner): the simplest correct choice. It needs no workgroup memory or barriers,
// its f32 sums have a fixed order (results do not depend on the adapter's scheduling), and a
// cell's ≤ 2·K·L residuals are few. The cross-cell reduction is done by the host in f64, in cell
// order (deterministic; see gpu/src/gridwarp/aa.rs).
//
// Per sample (α, β, σ, o_s, o_t) of cell (i, j) with rest widths h = h_i, kj = k_j, at the
// current lines s, t:
//   a = (s_{i+1} − s_i)/h, b = (t_{j+1} − t_j)/kj,
//   p = (s_i + α(s_{i+1} − s_i), t_j + β(t_{j+1} − t_j)), c_s, c_t = D_s, D_t bilinear at p,
//   r^s = σ(c_s a − o_s), r^t = σ(c_t b − o_t),
// and their partial derivatives with respect to the cell's four lines, in slot order
// (s_i, s_{i+1}, t_j, t_{j+1}).

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

// A bilinear sample and its gradient (∂/∂s, ∂/∂t): `Sample` of field.rs.
struct FieldSample {
    value: f32,
    ds: f32,
    dt: f32,
}

// `axis` of field.rs: (lower texel centre index, fraction, du/ds = n or 0 where clamped).
// `!(u > 0)` also sends NaN to the first texel, as the reference does.
struct Axis {
    x0: u32,
    frac: f32,
    grad: f32,
}

fn axis(s: f32, n: u32) -> Axis {
    let u = s * f32(n) - 0.5;
    if n == 1u || !(u > 0.0) {
        return Axis(0u, 0.0, 0.0);
    }
    if u >= f32(n - 1u) {
        return Axis(n - 1u, 0.0, 0.0);
    }
    let x0 = floor(u);
    return Axis(u32(x0), u - x0, f32(n));
}

fn field_at(offset: u32, width: u32, x: u32, y: u32) -> f32 {
    return fields[offset + y * width + x];
}

// `Field::bilinear`: interpolation between texel centres, clamped to the edge texels, with its
// gradient (0 along an axis where the sample is clamped). The field is `fields[offset ..]`,
// width × height, row-major, row 0 at t = 0.
fn field_bilinear(offset: u32, width: u32, height: u32, s: f32, t: f32) -> FieldSample {
    let ax = axis(s, width);
    let ay = axis(t, height);
    let x0 = ax.x0;
    let y0 = ay.x0;
    let alpha = ax.frac;
    let beta = ay.frac;
    let x1 = min(x0 + 1u, width - 1u);
    let y1 = min(y0 + 1u, height - 1u);
    let f00 = field_at(offset, width, x0, y0);
    let f10 = field_at(offset, width, x1, y0);
    let f01 = field_at(offset, width, x0, y1);
    let f11 = field_at(offset, width, x1, y1);
    // `bilinear_formula`: along s on the two texel rows, then along t between them.
    let along_0 = f10 - f00;
    let along_1 = f11 - f01;
    let f0 = f00 + alpha * along_0;
    let f1 = f01 + alpha * along_1;
    let across = f1 - f0;
    return FieldSample(
        f0 + beta * across,
        ax.grad * (along_0 + beta * (along_1 - along_0)),
        ay.grad * across,
    );
}

// Add residual r with partial derivatives d (slot order) to the cell's sums.
fn accumulate(out: ptr<function, CellContribution>, r: f32, d: array<f32, 4>) {
    (*out).energy = fma(r, r, (*out).energy);
    for (var u = 0u; u < 4u; u++) {
        (*out).jtr[u] = fma(d[u], r, (*out).jtr[u]);
        for (var v = 0u; v < 4u; v++) {
            (*out).jtj[u * 4u + v] = fma(d[u], d[v], (*out).jtj[u * 4u + v]);
        }
    }
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn gridwarp_aa_cell(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let cell = linear_index(gid, workgroups);
    if cell >= params.cells {
        return;
    }
    // Cell (i, j) = cell column i, row j, at i·rows + j (the reference's sample layout).
    let i = cell / params.rows;
    let j = cell % params.rows;
    let m = params.columns + 1u;
    let n = params.rows + 1u;
    let s0 = geometry[i];
    let s1 = geometry[i + 1u];
    let t0 = geometry[m + j];
    let t1 = geometry[m + j + 1u];
    let h = geometry[m + n + i];
    let kj = geometry[m + n + params.columns + j];
    let a = (s1 - s0) / h;
    let b = (t1 - t0) / kj;

    var out: CellContribution;
    out.unknowns = array<i32, 4>(
        unknown_index[i],
        unknown_index[i + 1u],
        unknown_index[m + j],
        unknown_index[m + j + 1u],
    );
    let first = cell * params.per_cell;
    for (var q = 0u; q < params.per_cell; q++) {
        let p = samples[first + q];
        if p.sigma == 0.0 {
            continue;
        }
        let f = s0 + p.alpha * (s1 - s0);
        let gt = t0 + p.beta * (t1 - t0);
        let cs = field_bilinear(0u, params.ds_width, params.ds_height, f, gt);
        let ct = field_bilinear(params.dt_offset, params.dt_width, params.dt_height, f, gt);
        let al = p.alpha;
        let be = p.beta;
        let sg = p.sigma;
        // `residuals_and_derivatives`: σ a, σ b, then σ a ∂c_s/∂s, σ c_s/h, σ a ∂c_s/∂t and
        // the same for c_t.
        let sa = sg * a;
        let sb = sg * b;
        let us = sa * cs.ds;
        let vs = (sg / h) * cs.value;
        let ws = sa * cs.dt;
        let ut = sb * ct.dt;
        let vt = (sg / kj) * ct.value;
        let wt = sb * ct.ds;
        // r^s = σ (c_s a − o_s) and its four partial derivatives.
        accumulate(&out, sg * fma(cs.value, a, -p.o_s), array<f32, 4>(
            fma(us, 1.0 - al, -vs),
            fma(us, al, vs),
            ws * (1.0 - be),
            ws * be,
        ));
        // r^t = σ (c_t b − o_t), symmetric (the reference lists t_j, t_{j+1} first).
        accumulate(&out, sg * fma(ct.value, b, -p.o_t), array<f32, 4>(
            wt * (1.0 - al),
            wt * al,
            fma(ut, 1.0 - be, -vt),
            fma(ut, be, vt),
        ));
    }
    cells[cell] = out;
}
