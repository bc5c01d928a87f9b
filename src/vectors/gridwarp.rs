//! gridwarp vectors: the `gridwarp_aa_cell` kernel's inputs at one grid (the lines moved off the
//! rest grid, see [`crate::crosscheck::gridwarp::evaluation_point`]) and the f64 per-cell energies, F, JᵀJ and Jᵀr of the
//! axis-aligned energy (seed §5.1), with the bounds of [`crate::crosscheck::gridwarp`].

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::gridwarp::{
    energy_bound, gradient_bound, jtj_bound, magnitudes, prepared_evaluation, solve_bounds,
    stretch_bound, RoundedInputs, EPS, RESIDUAL_FACTOR, STRETCH_LATTICE,
};
use crate::error::Result;
use crate::gridwarp::energy::{AaEnergy, DeformedFields, RestFields};
use crate::gridwarp::gpu::{aa_input, assemble, set_lines, solve_sequence_gpu, GpuAaEnergy};
use crate::gridwarp::merit::rigid_stretch;
use crate::gridwarp::{solve_sequence, Grid, SolveOptions};
use crate::lm::Residuals;

/// The formula of `gridwarp_aa` for the manifests, every symbol defined (issue #33).
const AA_FORMULA: &str = "the axis-aligned energy F = Σ_cells Σ_samples (r^s)² + (r^t)² \
    (seed 000 §5.1). Lines s_0 … s_{M−1} (vertical), t_0 … t_{N−1} (horizontal); cell \
    c = i·(N − 1) + j spans [s_i, s_{i+1}] × [t_j, t_{j+1}] with rest size h_i × k_j. Per \
    sample (α, β, σ, o_s, o_t) of cell c: slopes a = (s_{i+1} − s_i)/h_i, \
    b = (t_{j+1} − t_j)/k_j; warped point p = (s_i + α(s_{i+1} − s_i), t_j + β(t_{j+1} − t_j)); \
    stretches c_s = D_s(p), c_t = D_t(p) by bilinear lookup; residuals r^s = σ(c_s a − o_s), \
    r^t = σ(c_t b − o_t). Bilinear lookup of a W × H field at (s, t): u = s W − ½; if W = 1 \
    or not u > 0 then x0 = 0, f = 0; else if u ≥ W − 1 then x0 = W − 1, f = 0; else \
    x0 = ⌊u⌋, f = u − x0; x1 = min(x0 + 1, W − 1); likewise y0, y1, g from v = t H − ½; \
    value = (1 − g)(D[y0][x0] + f(D[y0][x1] − D[y0][x0])) + g(D[y1][x0] + f(D[y1][x1] − \
    D[y1][x0])) (clamped to the edge texels); ∂/∂s = W·((D[y0][x1] − D[y0][x0]) + \
    g((D[y1][x1] − D[y1][x0]) − (D[y0][x1] − D[y0][x0]))), ∂/∂t = H·(row1 − row0), each 0 \
    on an axis where the lookup is clamped. Derivatives of r^s with respect to \
    (s_i, s_{i+1}, t_j, t_{j+1}): (σ a ∂c_s/∂s (1 − α) − σ c_s/h_i, σ a ∂c_s/∂s α + \
    σ c_s/h_i, σ a ∂c_s/∂t (1 − β), σ a ∂c_s/∂t β); of r^t with respect to (t_j, t_{j+1}, \
    s_i, s_{i+1}): the same with (b, c_t, k_j, β, ∂/∂t) along and (α, ∂/∂s) across. J's \
    columns are the unknowns (s_index, t_index ≥ 0; −1 marks a fixed line, left out), s \
    unknowns first, then t";

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
            "per sample, f32: α, β (position in the cell, in [0, 1]), σ = √w R, o_s = ‖O_s‖, \
             o_t = ‖O_t‖; rows c·K·L … (c + 1)·K·L − 1 belong to cell c = i·(N − 1) + j \
             (column i of M − 1, row j of N − 1)"
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
            "f32, H rows × W columns: ‖D_s‖ per texel; row y, column x has its centre at \
             ((x + ½)/W, (y + ½)/H), row 0 at t = 0; sampled bilinearly as the description says"
                .into(),
            field(&input.d_s),
        ),
        (
            "d_t".into(),
            "f32, H rows × W columns: ‖D_t‖ per texel, laid out as d_s (its own W, H)".into(),
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
            description: format!("{what} of {AA_FORMULA}"),
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
            covers: Vec::new(),
        };
    let c = crate::crosscheck::gridwarp::normal_equations_factor(k, l);
    let (residuals, residual_bounds) = per_sample_residuals(&rest, &rest_grid, (k, l), &mg);
    let samples = residuals.len() / 2;
    let kernels = vec![
        kernel(
            "residuals",
            "per sample (the order of `samples`), r^s, r^t (0 where σ = 0)",
            Array::f64(&[samples, 2], residuals),
            Array::f64(&[samples, 2], residual_bounds),
            "10 ε m_k, m_k = |r_k + σo| + σ|o| (the terms that cancel in r_k)",
        ),
        kernel(
            "cell_energy",
            "per cell c = i·(N − 1) + j (column i, row j), Σ r² over its samples",
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
            &format!("{c} ε (MᵀM)_uv, M the derivatives' term sizes"),
        ),
        kernel(
            "jtr",
            "Jᵀr, per unknown",
            Array::f64(&[n], reference.jtr.iter().copied().collect()),
            Array::f64(&[n], gradient_bound(&mg, (k, l))),
            &format!("{c} ε (Mᵀ(|r| + m))_u"),
        ),
    ];
    // A residual's row in `samples` is its own first index.
    let mut kernels = kernels;
    kernels[0].per_element = vec!["samples".into()];
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let mut energy = GpuAaEnergy::new(gpu, &rest, &rest_grid, &deformed, k, l)?;
        let cells_gpu = energy.cells(&x)?;
        let ne = assemble(&cells_gpu, n);
        let residuals = reparam_gpu::gridwarp::aa_residuals(gpu, &input)
            .map_err(|e| crate::error::Error::Gpu(e.to_string()))?;
        candidates = vec![
            (
                "gridwarp_aa.residuals".to_string(),
                Array::f32(&[samples, 2], residuals.into_iter().flatten().collect()),
            ),
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

/// The reference's residuals r^s, r^t of every sample, in the order of the kernel's `samples`
/// input (0 for a sample of weight σ = 0, which has none), and their bounds C_r ε m_k
/// ([`RESIDUAL_FACTOR`], the module docs of [`crate::crosscheck::gridwarp`]).
fn per_sample_residuals(
    rest: &RestFields,
    rest_grid: &Grid,
    (k, l): (usize, usize),
    mg: &crate::crosscheck::gridwarp::Magnitudes,
) -> (Vec<f64>, Vec<f64>) {
    let all = crate::gridwarp::gpu::rest_samples(rest, rest_grid, k, l);
    let (mut r, mut b) = (
        Vec::with_capacity(2 * all.len()),
        Vec::with_capacity(2 * all.len()),
    );
    let mut next = 0;
    for p in &all {
        if p.sigma == 0.0 {
            r.extend([0.0, 0.0]);
            b.extend([0.0, 0.0]);
        } else {
            r.extend([mg.r[next], mg.r[next + 1]]);
            b.extend([mg.m[next], mg.m[next + 1]].map(|m| RESIDUAL_FACTOR * EPS * m));
            next += 2;
        }
    }
    (r, b)
}

/// A field as an f64 array (rows × columns, row 0 at t = 0).
fn field_f64(f: &crate::gridwarp::Field) -> Array {
    Array::f64(&[f.height, f.width], f.values.clone())
}

/// The whole run's vectors: the rest and deformed fields and the rest grid as the solve
/// receives them, and per frame the final energy F of the LM solve (seed §5.1, §7) and the
/// rigid-stretch figures (mean, max; [`crate::gridwarp::merit`]) of its lines. With a GPU, the
/// candidate is the sequence solved with reparam's own `gridwarp_aa_cell` objective (its f64
/// energy and stretch at the GPU-solved lines). Frames whose JᵀJ is singular at the CPU minimum
/// have no bound and are left out (the description counts them).
pub fn run_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<VectorsAndCandidates> {
    let kl = options.samples_per_cell();
    let cpu = solve_sequence(rest, rest_grid, frames, options)?;
    let figures = |j: usize, grid: &Grid, energy: f64| {
        let s = rigid_stretch(rest, &frames[j], rest_grid, grid, STRETCH_LATTICE);
        [energy, s.mean, s.max]
    };
    let (mut expected, mut bounds, mut kept) = (vec![], vec![], vec![]);
    for (j, c) in cpu.iter().enumerate() {
        let mut reference = AaEnergy::new(rest, rest_grid, &frames[j], kl.0, kl.1);
        let Some((e_tol, x_tol)) =
            solve_bounds(&mut reference, rest, rest_grid, kl, &c.lm.x, c.lm.energy)
        else {
            continue;
        };
        let f = figures(j, &c.grid, c.lm.energy);
        let Some(sb) = stretch_bound(rest, &frames[j], rest_grid, &c.grid, x_tol) else {
            continue;
        };
        expected.extend(f);
        // The metric is relative: each absolute bound over its figure.
        let rel = |b: f64, v: f64| if v == 0.0 { b } else { b / v.abs() };
        bounds.extend([rel(e_tol, f[0]), rel(sb, f[1]), rel(sb, f[2])]);
        kept.push(j);
    }
    let n = kept.len();
    let mut inputs = vec![
        (
            "o_s".into(),
            "f64, rows × columns (row 0 at t = 0): ‖O_s‖ of the rest frame".into(),
            field_f64(&rest.o_s),
        ),
        (
            "o_t".into(),
            "f64: ‖O_t‖ of the rest frame".into(),
            field_f64(&rest.o_t),
        ),
        (
            "rigidity".into(),
            "f64: the rigidity R ∈ [0, 1]".into(),
            field_f64(&rest.rigidity),
        ),
        (
            "rest_grid".into(),
            "f64: the rest lines s_0 … s_m, then t_0 … t_n (texture widths; first and last fixed)"
                .into(),
            Array::f64(
                &[rest_grid.s.len() + rest_grid.t.len()],
                rest_grid.s.iter().chain(&rest_grid.t).copied().collect(),
            ),
        ),
        (
            "params".into(),
            "f64: K, L (samples per cell), the number of s lines, looping (1) or not (0)".into(),
            Array::f64(
                &[4],
                vec![
                    kl.0 as f64,
                    kl.1 as f64,
                    rest_grid.s.len() as f64,
                    f64::from(u8::from(options.looping)),
                ],
            ),
        ),
        (
            "frames".into(),
            "u32: the frames compared (0-based); each has inputs d_s.<j>, d_t.<j>".into(),
            Array::u32(&[n], kept.iter().map(|&j| j as u32).collect()),
        ),
    ];
    for &j in &kept {
        inputs.push((
            format!("d_s.{j}"),
            format!("f64: ‖D_s‖ of frame {j}"),
            field_f64(&frames[j].d_s),
        ));
        inputs.push((
            format!("d_t.{j}"),
            format!("f64: ‖D_t‖ of frame {j}"),
            field_f64(&frames[j].d_t),
        ));
    }
    let kernel = KernelData {
        name: "gridwarp_run".into(),
        description: format!(
            "a whole sequence: per frame the LM solve's final F = Σ (r^s)² + (r^t)² (seed §5.1, \
             §7, each frame started from the previous one's lines) and the rigid stretch of its \
             lines (mean, max on a {STRETCH_LATTICE}² lattice); {} of {} frames (the others: JᵀJ \
             singular at the minimum, no bound)",
            n,
            frames.len()
        ),
        inputs,
        expected: (
            "per compared frame, f64: F, rigid-stretch mean, rigid-stretch max".into(),
            Array::f64(&[n, 3], expected),
        ),
        bound: ("per figure, relative".into(), Array::f64(&[n, 3], bounds)),
        metric: Metric::Relative {
            unit: "relative".into(),
        },
        bound_formula: "F: (2e + ½ bᵀ|A⁻¹|b + 1e-12 F) / F (crosscheck::gridwarp::solve_bounds); \
            stretch: stretch_bound at the lines' bound ‖|A⁻¹| b‖∞ + √(4e / λ_min(A)), over the \
            figure"
            .into(),
        derivation: "an f32 objective stops where its evaluations (error ≤ e, gradient error ≤ b) \
            no longer see a decrease: F's excess is ≤ 2e + ½ bᵀ|A⁻¹|b and the lines move by \
            ≤ ‖|A⁻¹|b‖∞ + √(4e/λ_min); the stretch then moves by ≤ (D_max 2δ/h_min + (a_max + \
            2δ/h_min) G δ)/O_min (crosscheck::gridwarp::stretch_bound)"
            .into(),
        per_element: vec![],
        covers: Vec::new(),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let solved = solve_sequence_gpu(gpu, rest, rest_grid, frames, options)?;
        let got: Vec<f64> = kept
            .iter()
            .flat_map(|&j| {
                let mut reference = AaEnergy::new(rest, rest_grid, &frames[j], kl.0, kl.1);
                let energy = reference.energy(&solved[j].lm.x);
                figures(j, &solved[j].grid, energy)
            })
            .collect();
        candidates.push(("gridwarp_run".to_string(), Array::f64(&[n, 3], got)));
    }
    Ok((vec![kernel], candidates))
}

/// Every gridwarp vector: the kernels at the last frame ([`vectors`]) and the whole run
/// ([`run_vectors`]).
pub fn all_vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<VectorsAndCandidates> {
    let last = frames.last().ok_or_else(|| {
        crate::error::Error::InvalidArgument("gridwarp vectors: no deformed frame".into())
    })?;
    let (mut kernels, mut candidates) =
        vectors(gpu, rest, rest_grid, last, options.samples_per_cell())?;
    let (run, run_candidates) = run_vectors(gpu, rest, rest_grid, frames, options)?;
    kernels.extend(run);
    candidates.extend(run_candidates);
    Ok((kernels, candidates))
}
