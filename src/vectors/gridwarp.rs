//! gridwarp vectors: the `gridwarp_aa_cell` kernel's inputs at one grid (the lines moved off the
//! rest grid, see [`evaluation_point`]) and the f64 per-cell energies, F, JᵀJ and Jᵀr of the
//! axis-aligned energy (seed §5.1), with the bounds of [`crate::crosscheck::gridwarp`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::gridwarp::{
    energy_bound, gradient_bound, jtj_bound, magnitudes, prepared_evaluation, RoundedInputs,
};
use crate::error::Result;
use crate::gridwarp::energy::{AaEnergy, DeformedFields, RestFields};
use crate::gridwarp::gpu::{aa_input, assemble, set_lines, GpuAaEnergy};
use crate::gridwarp::Grid;
use crate::lm::Residuals;

/// The four kernels' vectors (`gridwarp_aa.cell_energy`, `.energy`, `.jtj`, `.jtr`) and, with a
/// GPU, reparam's own kernel's outputs as candidates.
pub fn vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
    (k, l): (usize, usize),
) -> Result<VectorsAndCandidates> {
    let (
        RoundedInputs {
            rest,
            rest_grid,
            deformed,
        },
        x,
    ) = prepared_evaluation("gridwarp vectors", rest, rest_grid, deformed, (k, l))?;
    let mut cpu = AaEnergy::new(&rest, &rest_grid, &deformed, k, l);
    let reference = cpu.normal_equations(&x);
    let mg = magnitudes(&mut cpu, &rest, &rest_grid, (k, l), &x);
    let mut input = aa_input(&rest, &rest_grid, &deformed, k, l);
    set_lines(&mut input, &rest_grid.with_unknowns(&x));
    let n = x.len();
    let cells = input.cells();
    let field = |f: &reparam_gpu::gridwarp::FieldF32| {
        Array::f32(&[f.height as usize, f.width as usize], f.values.clone())
    };
    let inputs: Vec<(String, String, Array)> = vec![
        (
            "samples".into(),
            "per sample, f32: α, β (position in the cell), σ = √w R, ‖O_s‖, ‖O_t‖; K·L samples \
             per cell, cells in the order column i, row j"
                .into(),
            Array::f32(
                &[input.samples.len(), 5],
                input
                    .samples
                    .iter()
                    .flat_map(|p| [p.alpha, p.beta, p.sigma, p.o_s, p.o_t])
                    .collect(),
            ),
        ),
        (
            "per_cell".into(),
            "u32, one value: K·L".into(),
            Array::u32(&[1], vec![input.per_cell]),
        ),
        (
            "rest_h".into(),
            "f32: rest widths h_i of the columns".into(),
            Array::f32(&[input.rest_h.len()], input.rest_h.clone()),
        ),
        (
            "rest_k".into(),
            "f32: rest heights k_j of the rows".into(),
            Array::f32(&[input.rest_k.len()], input.rest_k.clone()),
        ),
        (
            "s".into(),
            "f32: the current vertical lines s_0 … s_{M−1} (texture widths)".into(),
            Array::f32(&[input.s.len()], input.s.clone()),
        ),
        (
            "t".into(),
            "f32: the current horizontal lines t_0 … t_{N−1}".into(),
            Array::f32(&[input.t.len()], input.t.clone()),
        ),
        (
            "s_index".into(),
            "i32: the unknown of each vertical line (−1: fixed)".into(),
            Array::i32(&[input.s_index.len()], input.s_index.clone()),
        ),
        (
            "t_index".into(),
            "i32: the unknown of each horizontal line (−1: fixed)".into(),
            Array::i32(&[input.t_index.len()], input.t_index.clone()),
        ),
        (
            "d_s".into(),
            "f32, rows × columns: ‖D_s‖ per texel (texel centres at (x + ½)/W)".into(),
            field(&input.d_s),
        ),
        (
            "d_t".into(),
            "f32, rows × columns: ‖D_t‖ per texel".into(),
            field(&input.d_t),
        ),
    ];
    // Per-cell energies from the reference's residuals.
    let mut cell_energy = vec![0.0; cells];
    let mut cell_r: Vec<Vec<f64>> = vec![Vec::new(); cells];
    let mut cell_m: Vec<Vec<f64>> = vec![Vec::new(); cells];
    for ((&r, &m), &c) in mg.r.iter().zip(&mg.m).zip(&mg.cell) {
        cell_energy[c] += r * r;
        cell_r[c].push(r);
        cell_m[c].push(m);
    }
    let cell_bound: Vec<f64> = (0..cells)
        .map(|c| energy_bound(&cell_r[c], &cell_m[c], (k, l)))
        .collect();
    let jtj_b = jtj_bound(&mg, (k, l));
    let kernel =
        |name: &str, what: &str, expected: Array, bound: Array, formula: &str| KernelData {
            name: format!("gridwarp_aa.{name}"),
            description: format!(
                "{what} of the axis-aligned energy F = Σ_cells Σ_samples (r^s)² + (r^t)², \
             r = σ(c·a − o) (seed §5.1), at the given lines"
            ),
            inputs: inputs.clone(),
            expected: (format!("f64: {what}"), expected),
            bound: ("per element, absolute (F's units)".into(), bound),
            metric: Metric::Absolute {
                unit: "absolute".into(),
            },
            bound_formula: formula.into(),
            derivation:
                "crosscheck::gridwarp: residuals ≤ 10 ε m_k each (m_k the cancelling terms' \
            size), f32 sums of 2KL terms per cell; cross-cell sums in f64"
                    .into(),
            per_element: Vec::new(),
        };
    let c = crate::crosscheck::gridwarp::normal_equations_factor(k, l);
    let kernels = vec![
        kernel(
            "cell_energy",
            "per cell (column i, row j), Σ r²",
            Array::f64(&[cells], cell_energy),
            Array::f64(&[cells], cell_bound),
            "2·10 ε Σ|r_k| m_k + 2KL ε F_c over the cell's residuals",
        ),
        kernel(
            "energy",
            "F, one value",
            Array::f64(&[1], vec![reference.energy]),
            Array::f64(&[1], vec![energy_bound(&mg.r, &mg.m, (k, l))]),
            "2·10 ε Σ|r_k| m_k + 2KL ε F",
        ),
        kernel(
            "jtj",
            "JᵀJ, unknowns × unknowns (s unknowns first, then t)",
            Array::f64(&[n, n], reference.jtj.transpose().iter().copied().collect()),
            Array::f64(&[n, n], jtj_b.transpose().iter().copied().collect()),
            &format!("{c} ε (|J|ᵀ|J|)_uv"),
        ),
        kernel(
            "jtr",
            "Jᵀr, per unknown",
            Array::f64(&[n], reference.jtr.iter().copied().collect()),
            Array::f64(&[n], gradient_bound(&mg, (k, l))),
            &format!("{c} ε (|J|ᵀ(|r| + m))_u"),
        ),
    ];
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let mut energy = GpuAaEnergy::new(gpu, &rest, &rest_grid, &deformed, k, l)?;
        let cells_gpu = energy.cells(&x)?;
        let ne = assemble(&cells_gpu, n);
        candidates = vec![
            (
                "gridwarp_aa.cell_energy".to_string(),
                Array::f32(&[cells], cells_gpu.iter().map(|c| c.energy).collect()),
            ),
            (
                "gridwarp_aa.energy".to_string(),
                Array::f64(&[1], vec![ne.energy]),
            ),
            (
                "gridwarp_aa.jtj".to_string(),
                Array::f64(&[n, n], ne.jtj.transpose().iter().copied().collect()),
            ),
            (
                "gridwarp_aa.jtr".to_string(),
                Array::f64(&[n], ne.jtr.iter().copied().collect()),
            ),
        ];
    }
    Ok((kernels, candidates))
}
