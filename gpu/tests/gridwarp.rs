//! Smoke tests of the `gridwarp_aa_cell` kernel on tiny hand-made inputs (lavapipe or any
//! adapter). Skipped (printing `skipped: no GPU adapter`) without an adapter unless
//! REPARAM_REQUIRE_GPU=1. The full cross-check against the f64 reference is
//! tests/gpu_gridwarp.rs in the reparam crate.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(u > 0)`, as the reference writes it (NaN too)

use reparam_gpu::gridwarp::{
    aa_cells, AaInput, CellContribution, FieldF32, RestSample, NO_UNKNOWN,
};
use reparam_gpu::{gpu_or_skip, GpuError};

fn constant(v: f32) -> FieldF32 {
    FieldF32 {
        width: 1,
        height: 1,
        values: vec![v],
    }
}

/// One cell, one sample, constant fields: everything by hand.
#[test]
fn one_cell_constant_fields_by_hand() {
    let Some(gpu) = gpu_or_skip() else { return };
    let input = AaInput {
        samples: vec![RestSample {
            alpha: 0.5,
            beta: 0.5,
            sigma: 1.0,
            o_s: 1.0,
            o_t: 1.0,
        }],
        per_cell: 1,
        rest_h: vec![1.0],
        rest_k: vec![1.0],
        s: vec![0.0, 1.0],
        t: vec![0.0, 1.0],
        s_index: vec![NO_UNKNOWN, NO_UNKNOWN],
        t_index: vec![NO_UNKNOWN, NO_UNKNOWN],
        d_s: constant(2.0),
        d_t: constant(3.0),
    };
    let cells = aa_cells(&gpu, &input).unwrap();
    assert_eq!(cells.len(), 1);
    let c = cells[0];
    // a = b = 1; r^s = 2·1 − 1 = 1, r^t = 3·1 − 1 = 2; a 1×1 field has zero gradient, so
    // ∂r^s = (−c_s/h, c_s/h, 0, 0) = (−2, 2, 0, 0), ∂r^t = (0, 0, −3, 3). All exact in f32.
    let ds = [-2.0f32, 2.0, 0.0, 0.0];
    let dt = [0.0f32, 0.0, -3.0, 3.0];
    assert_eq!(c.energy, 5.0);
    for u in 0..4 {
        assert_eq!(c.jtr[u], ds[u] * 1.0 + dt[u] * 2.0, "jtr[{u}]");
        for v in 0..4 {
            assert_eq!(
                c.jtj[u * 4 + v],
                ds[u] * ds[v] + dt[u] * dt[v],
                "jtj[{u}][{v}]"
            );
        }
    }
    assert_eq!(c.unknowns, [NO_UNKNOWN; 4]);
}

/// f64 twin of the kernel for the test below (same formulas as the reference's plain path
/// `PlainAaEnergy` and `Field::bilinear`).
fn bilinear(f: &FieldF32, s: f64, t: f64) -> (f64, f64, f64) {
    let axis = |s: f64, n: u32| {
        let u = s * n as f64 - 0.5;
        if n == 1 || !(u > 0.0) {
            (0usize, 0.0, 0.0)
        } else if u >= (n - 1) as f64 {
            ((n - 1) as usize, 0.0, 0.0)
        } else {
            (u.floor() as usize, u - u.floor(), n as f64)
        }
    };
    let (w, h) = (f.width as usize, f.height as usize);
    let (x0, a, gx) = axis(s, f.width);
    let (y0, b, gy) = axis(t, f.height);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let at = |x: usize, y: usize| f.values[y * w + x] as f64;
    let (f00, f10, f01, f11) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
    let (along_0, along_1) = (f10 - f00, f11 - f01);
    let (f0, f1) = (f00 + a * along_0, f01 + a * along_1);
    let across = f1 - f0;
    (
        f0 + b * across,
        gx * (along_0 + b * (along_1 - along_0)),
        gy * across,
    )
}

fn cells_f64(input: &AaInput) -> Vec<(f64, [f64; 16], [f64; 4])> {
    let rows = input.t.len() - 1;
    let mut out = Vec::new();
    for c in 0..input.cells() {
        let (i, j) = (c / rows, c % rows);
        let (s0, s1) = (input.s[i] as f64, input.s[i + 1] as f64);
        let (t0, t1) = (input.t[j] as f64, input.t[j + 1] as f64);
        let (h, kj) = (input.rest_h[i] as f64, input.rest_k[j] as f64);
        let (a, b) = ((s1 - s0) / h, (t1 - t0) / kj);
        let (mut e, mut jtj, mut jtr) = (0.0, [0.0; 16], [0.0; 4]);
        let per = input.per_cell as usize;
        for p in &input.samples[c * per..(c + 1) * per] {
            let (al, be, sg) = (p.alpha as f64, p.beta as f64, p.sigma as f64);
            let (f, g) = (s0 + al * (s1 - s0), t0 + be * (t1 - t0));
            let cs = bilinear(&input.d_s, f, g);
            let ct = bilinear(&input.d_t, f, g);
            let (sa, sb) = (sg * a, sg * b);
            let (us, vs, ws) = (sa * cs.1, (sg / h) * cs.0, sa * cs.2);
            let (ut, vt, wt) = (sb * ct.2, (sg / kj) * ct.0, sb * ct.1);
            let rs = (
                sg * cs.0.mul_add(a, -(p.o_s as f64)),
                [
                    us.mul_add(1.0 - al, -vs),
                    us.mul_add(al, vs),
                    ws * (1.0 - be),
                    ws * be,
                ],
            );
            let rt = (
                sg * ct.0.mul_add(b, -(p.o_t as f64)),
                [
                    wt * (1.0 - al),
                    wt * al,
                    ut.mul_add(1.0 - be, -vt),
                    ut.mul_add(be, vt),
                ],
            );
            for (r, d) in [rs, rt] {
                e = r.mul_add(r, e);
                for u in 0..4 {
                    jtr[u] = d[u].mul_add(r, jtr[u]);
                    for v in 0..4 {
                        jtj[u * 4 + v] = d[u].mul_add(d[v], jtj[u * 4 + v]);
                    }
                }
            }
        }
        out.push((e, jtj, jtr));
    }
    out
}

/// 2×2 cells, 2×3 samples each, linear-ish fields on 5×4 texels (samples both inside the
/// texel-centre range and clamped near the edges), a warped grid: the kernel against its f64
/// twin evaluated on the same f32 inputs.
#[test]
fn small_grid_matches_f64_twin() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (k, l) = (2usize, 3usize);
    let mut samples = Vec::new();
    for i in 0..2 {
        for j in 0..2 {
            for a in 0..k {
                for b in 0..l {
                    let (alpha, beta) = ((a as f32 + 0.5) / k as f32, (b as f32 + 0.5) / l as f32);
                    samples.push(RestSample {
                        alpha,
                        beta,
                        sigma: 0.1 + 0.2 * (i + 2 * j) as f32 + 0.05 * a as f32,
                        o_s: 1.0 + 0.1 * b as f32,
                        o_t: 0.9 + 0.05 * i as f32,
                    });
                }
            }
        }
    }
    let field = |w: u32, h: u32, f: &dyn Fn(f32, f32) -> f32| FieldF32 {
        width: w,
        height: h,
        values: (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| f(x as f32, y as f32))
            .collect(),
    };
    let input = AaInput {
        samples,
        per_cell: (k * l) as u32,
        rest_h: vec![0.45, 0.55],
        rest_k: vec![0.6, 0.4],
        s: vec![0.0, 0.52, 1.0],
        t: vec![0.0, 0.57, 1.0],
        s_index: vec![NO_UNKNOWN, 0, NO_UNKNOWN],
        t_index: vec![NO_UNKNOWN, 1, NO_UNKNOWN],
        d_s: field(5, 4, &|x, y| 1.0 + 0.3 * x + 0.1 * y * y),
        d_t: field(5, 4, &|x, y| 2.0 - 0.2 * x * y + 0.05 * y),
    };
    let gpu_cells = aa_cells(&gpu, &input).unwrap();
    let cpu_cells = cells_f64(&input);
    assert_eq!(gpu_cells.len(), 4);
    // Each entry is a sum of 2·K·L = 12 products of a handful of f32 operations (≈ 15 roundings
    // of ε = 6e-8 each along a residual's or derivative's path), so |error| ≤ ~30 ε ·
    // Σ|terms| ≈ 2e-6 · Σ|terms|; 1e-5 of the sum of magnitudes leaves a factor 5.
    let scale_of = |c: &(f64, [f64; 16], [f64; 4])| {
        c.0.abs()
            + c.1.iter().map(|v| v.abs()).sum::<f64>()
            + c.2.iter().map(|v| v.abs()).sum::<f64>()
    };
    for (n, (g, c)) in gpu_cells.iter().zip(&cpu_cells).enumerate() {
        let tol = 1e-5 * scale_of(c);
        assert!(
            (g.energy as f64 - c.0).abs() <= tol,
            "cell {n} energy {} vs {}",
            g.energy,
            c.0
        );
        for u in 0..16 {
            assert!(
                (g.jtj[u] as f64 - c.1[u]).abs() <= tol,
                "cell {n} jtj[{u}] {} vs {}",
                g.jtj[u],
                c.1[u]
            );
        }
        for u in 0..4 {
            assert!(
                (g.jtr[u] as f64 - c.2[u]).abs() <= tol,
                "cell {n} jtr[{u}] {} vs {}",
                g.jtr[u],
                c.2[u]
            );
        }
    }
    let expected_unknowns: [[i32; 4]; 4] = [
        [-1, 0, -1, 1],
        [-1, 0, 1, -1],
        [0, -1, -1, 1],
        [0, -1, 1, -1],
    ];
    for (g, u) in gpu_cells.iter().zip(expected_unknowns) {
        assert_eq!(g.unknowns, u);
    }
    // Non-trivial: the field gradients entered (the s-derivative of r^t is not zero).
    assert!(gpu_cells.iter().any(|c| c.jtj[0] != 0.0 || c.jtj[5] != 0.0));
    let _: &[CellContribution] = &gpu_cells;
}

#[test]
fn inconsistent_lengths_are_an_input_error() {
    let Some(gpu) = gpu_or_skip() else { return };
    let input = AaInput {
        samples: vec![RestSample::default(); 3],
        per_cell: 1,
        rest_h: vec![1.0],
        rest_k: vec![1.0],
        s: vec![0.0, 1.0],
        t: vec![0.0, 1.0],
        s_index: vec![NO_UNKNOWN; 2],
        t_index: vec![NO_UNKNOWN; 2],
        d_s: constant(1.0),
        d_t: constant(1.0),
    };
    assert!(matches!(aa_cells(&gpu, &input), Err(GpuError::Input(_))));
}

/// A binding (fixed data uploaded once) evaluated at new lines gives exactly what a fresh
/// upload of the same input gives: only the lines are rewritten, and the kernel reads them.
/// Wrong line counts are an input error.
#[test]
fn bound_kernel_rewrites_only_the_lines() {
    use reparam_gpu::gridwarp::AaKernel;
    let Some(gpu) = gpu_or_skip() else { return };
    let sample = |alpha: f32, beta: f32| RestSample {
        alpha,
        beta,
        sigma: 0.5,
        o_s: 1.0,
        o_t: 1.0,
    };
    let gradient = FieldF32 {
        width: 4,
        height: 4,
        values: (0..16).map(|v| 1.0 + 0.25 * v as f32).collect(),
    };
    let mut input = AaInput {
        samples: vec![
            sample(0.25, 0.5),
            sample(0.75, 0.5),
            sample(0.5, 0.25),
            sample(0.5, 0.75),
        ],
        per_cell: 1,
        rest_h: vec![0.5, 0.5],
        rest_k: vec![0.5, 0.5],
        s: vec![0.0, 0.5, 1.0],
        t: vec![0.0, 0.5, 1.0],
        s_index: vec![NO_UNKNOWN, 0, NO_UNKNOWN],
        t_index: vec![NO_UNKNOWN, 1, NO_UNKNOWN],
        d_s: gradient.clone(),
        d_t: gradient,
    };
    let kernel = AaKernel::new(&gpu).unwrap();
    let binding = kernel.bind(&gpu, &input).unwrap();
    let at_rest = binding.run(&gpu, &input.s, &input.t).unwrap();
    let (s, t) = (vec![0.0, 0.6, 1.0], vec![0.0, 0.35, 1.0]);
    let moved = binding.run(&gpu, &s, &t).unwrap();
    input.s = s;
    input.t = t;
    let fresh = aa_cells(&gpu, &input).unwrap();
    assert_eq!(moved, fresh);
    assert_ne!(moved, at_rest, "the kernel must see the new lines");
    assert!(matches!(
        binding.run(&gpu, &[0.0, 1.0], &input.t),
        Err(GpuError::Input(_))
    ));
}
