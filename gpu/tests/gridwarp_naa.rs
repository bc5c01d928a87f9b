//! Smoke tests of the `gridwarp_naa_cell` kernel on tiny hand-made inputs (lavapipe or any
//! adapter). Skipped (printing `skipped: no GPU adapter`) without an adapter unless
//! REPARAM_REQUIRE_GPU=1. The full cross-check against the f64 reference is
//! tests/gpu_gridwarp_naa.rs in the reparam crate.

use reparam_gpu::gridwarp::{
    naa_cells, naa_residuals, NaaInput, NaaKernel, RestSample, VectorFieldF32, NO_UNKNOWN,
};
use reparam_gpu::{gpu_or_skip, GpuError};

/// A 1×1 field of one vector.
fn constant(v: [f32; 3]) -> VectorFieldF32 {
    VectorFieldF32 {
        width: 1,
        height: 1,
        values: v.to_vec(),
    }
}

/// One unit cell with its corners at the rest positions, one sample at its centre.
fn unit_cell(d_s: VectorFieldF32, d_t: VectorFieldF32) -> NaaInput {
    NaaInput {
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
        // P_ab at a·N + b: P00, P01, P10, P11.
        vertices: vec![[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]],
        vertex_index: vec![[0, 1], [2, 3], [4, 5], [6, 7]],
        d_s,
        d_t,
    }
}

/// One cell, one sample, constant fields: everything by hand, exact in f32.
#[test]
fn one_cell_constant_fields_by_hand() {
    let Some(gpu) = gpu_or_skip() else { return };
    let input = unit_cell(constant([2.0, 0.0, 0.0]), constant([0.0, 4.0, 0.0]));
    let cells = naa_cells(&gpu, &input).unwrap();
    assert_eq!(cells.len(), 1);
    let c = cells[0];
    // W_s = e_α/h = (1, 0), W_t = (0, 1); q_s = D_s = (2, 0, 0), q_t = D_t = (0, 4, 0);
    // r^s = 2 − 1 = 1, r^t = 4 − 1 = 3. A 1×1 field has no gradient (g = 0), so
    // ∂r/∂P_c,k = φ'_c m_k with m = (σ/‖q‖) J_Dᵀ q: m^s = (2, 0), m^t = (0, 4);
    // φ'^s = [−½, ½, −½, ½] (β = ½, h = 1), φ'^t = [−½, −½, ½, ½] (α = ½, k = 1).
    // Slots (P00.s, P00.t, P10.s, P10.t, P01.s, P01.t, P11.s, P11.t).
    let ds = [-1.0f32, 0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0];
    let dt = [0.0f32, -2.0, 0.0, -2.0, 0.0, 2.0, 0.0, 2.0];
    assert_eq!(c.energy, 10.0);
    for u in 0..8 {
        assert_eq!(c.jtr[u], ds[u] * 1.0 + dt[u] * 3.0, "jtr[{u}]");
        for v in 0..8 {
            assert_eq!(
                c.jtj[u * 8 + v],
                ds[u] * ds[v] + dt[u] * dt[v],
                "jtj[{u}][{v}]"
            );
        }
    }
    // Corner 10 is vertex (1, 0) at 1·N + 0 = 2: its indices 4, 5 go to slots 2, 3.
    assert_eq!(c.unknowns, [0, 1, 4, 5, 2, 3, 6, 7]);
    let r = naa_residuals(&gpu, &input).unwrap();
    assert_eq!(r, vec![[1.0, 3.0]]);
}

/// A twisted cell (P11 moved off the parallelogram) on a 2×2 field with a gradient: the
/// residuals and the cell's energy agree, the residuals are finite and the twist and the
/// gradient reach the derivatives (the P11 slots and the cross terms are not zero).
#[test]
fn twisted_cell_on_a_field_with_gradient() {
    let Some(gpu) = gpu_or_skip() else { return };
    let field = |base: [f32; 3], step: f32| VectorFieldF32 {
        width: 2,
        height: 2,
        values: (0..4)
            .flat_map(|n| base.map(|b| b + step * n as f32))
            .collect(),
    };
    let mut input = unit_cell(
        field([1.5, 0.2, 0.1], 0.25),
        field([0.1, 1.2, -0.3], -0.125),
    );
    input.vertices[3] = [0.9, 1.05];
    input.samples = (0..4)
        .map(|n| RestSample {
            alpha: 0.25 + 0.5 * (n / 2) as f32,
            beta: 0.25 + 0.5 * (n % 2) as f32,
            sigma: 0.5,
            o_s: 1.0,
            o_t: 1.1,
        })
        .collect();
    input.per_cell = 4;
    let c = naa_cells(&gpu, &input).unwrap()[0];
    let r = naa_residuals(&gpu, &input).unwrap();
    let energy: f32 = r.iter().map(|[a, b]| a * a + b * b).sum();
    assert!(r.iter().flatten().all(|v| v.is_finite()));
    assert!(
        (c.energy - energy).abs() <= 1e-6 * energy,
        "{} vs {energy}",
        c.energy
    );
    assert!(c.jtj[6 * 8 + 6] > 0.0 && c.jtj[7 * 8 + 7] > 0.0);
    assert!(c.jtj[1] != 0.0, "the cross term of P00.s and P00.t");
}

#[test]
fn inconsistent_lengths_are_an_input_error() {
    let Some(gpu) = gpu_or_skip() else { return };
    let good = unit_cell(constant([1.0, 0.0, 0.0]), constant([0.0, 1.0, 0.0]));
    let mut samples = good.clone();
    samples.samples.push(RestSample::default());
    let mut vertices = good.clone();
    vertices.vertices.pop();
    let mut field = good.clone();
    field.d_t.values.pop();
    let mut empty = good.clone();
    empty.rest_h.clear();
    for (what, input) in [
        ("samples", samples),
        ("vertices", vertices),
        ("field", field),
        ("cells", empty),
    ] {
        assert!(
            matches!(naa_cells(&gpu, &input), Err(GpuError::Input(_))),
            "{what}"
        );
    }
    let mut fixed = good;
    fixed.vertex_index = vec![[NO_UNKNOWN; 2]; 4];
    assert_eq!(
        naa_cells(&gpu, &fixed).unwrap()[0].unknowns,
        [NO_UNKNOWN; 8]
    );
}

/// A binding (fixed data uploaded once) evaluated at new vertices gives exactly what a fresh
/// upload of the same input gives; a wrong vertex count is an input error.
#[test]
fn bound_kernel_rewrites_only_the_vertices() {
    let Some(gpu) = gpu_or_skip() else { return };
    let field = VectorFieldF32 {
        width: 2,
        height: 2,
        values: (0..12).map(|v| 1.0 + 0.125 * v as f32).collect(),
    };
    let mut input = unit_cell(field.clone(), field);
    let kernel = NaaKernel::new(&gpu).unwrap();
    let binding = kernel.bind(&gpu, &input).unwrap();
    let at_rest = binding.run(&gpu, &input.vertices).unwrap();
    let mut moved_vertices = input.vertices.clone();
    moved_vertices[3] = [0.8, 1.1];
    let moved = binding.run(&gpu, &moved_vertices).unwrap();
    input.vertices = moved_vertices;
    let fresh = naa_cells(&gpu, &input).unwrap();
    assert_eq!(moved, fresh);
    assert_ne!(moved, at_rest, "the kernel must see the new vertices");
    assert!(matches!(
        binding.run(&gpu, &input.vertices[..3]),
        Err(GpuError::Input(_))
    ));
}
