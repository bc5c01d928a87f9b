//! gridwarp cross-check: the `gridwarp_aa_cell` kernel (f32) against the axis-aligned f64
//! energy [`AaEnergy`] at one grid, and whole LM solves with the GPU objective against CPU
//! solves (the paper's hybrid solver, seed §7).
//!
//! The bounds are derived here once and used by `tests/gpu_gridwarp.rs` and by
//! `reparam crosscheck gridwarp` alike. ε = u = 2⁻²³ is one WGSL rounding (up or down: one ULP). For residual r_k
//! (sample k, one axis), m_k = σ(|c·a| + |o|) = |r_k + σo| + σ|o| is the size of the terms that
//! cancel in it:
//!
//! - **residuals**: r̃ = σ̃(c̃ã − õ) has |r̃ − r| ≤ C_r ε m, C_r = 10: σ, o rounded on upload (ε
//!   each), a = (s₁ − s₀)/h (3ε: difference, h's rounding, division), c̃ (bilinear, ≈ 4ε, plus
//!   the sample-position error, < 1ε of c when every sample is ≥ 1e-3 texel from a texel-centre
//!   boundary, see [`texel_margin`]), the product and difference (2ε);
//! - **energy**: |r̃² − r²| ≤ 2|r| C_r ε m + (C_r ε m)², and the kernel's f32 sum of 2KL squares
//!   per cell adds ≤ 2KL ε Σ r² (the cross-cell sum is f64): [`energy_bound`]
//!   |ΔF| ≤ 2 C_r ε Σ|r_k| m_k + 2KL ε F (per cell: the same over the cell's residuals);
//! - **JᵀJ and Jᵀr**: each derivative is ≈ 8 f32 operations, C_d ≈ 12 ε of the size M of its
//!   terms (the near line's u(1 − α) − v cancels where the two are alike: M = |u|(1 − α) + |v|,
//!   [`AaEnergy::jacobian_magnitudes`]; on Fox.glb an FMA-contracted edge-of-spec twin was 1.8×
//!   over a bound that used |J| instead), a product adds both factors' errors and ε, the
//!   per-cell f32 sum of 2KL products adds ≤ 2KL ε: |Δ(JᵀJ)_uv| ≤ (2·12 + 1 + 2KL) ε (MᵀM)_uv
//!   and |Δ(Jᵀr)_u| ≤ (12 + 10 + 1 + 2KL) ε (Mᵀ(|r| + m))_u; with KL = 16 both are ≤ 64 ε
//!   ([`normal_equations_factor`]).

use nalgebra::{DMatrix, DVector};
use reparam_gpu::Gpu;

use super::timing::{time_cpu, time_gpu, time_gpu_warm};
use super::{Bounds, Row, Timing};
use crate::error::{Error, Result};
use crate::gridwarp::energy::{AaEnergy, DeformedFields, RestFields};
use crate::gridwarp::gpu::{rest_samples, solve_sequence_gpu, GpuAaEnergy};
use crate::gridwarp::{solve_sequence, Field, Grid, SolveOptions};
use crate::lm::Residuals;

/// The size ε of one rounding: [`super::WGSL_U`] = 2⁻²³ (WGSL rounds up or down).
pub const EPS: f64 = super::WGSL_U;

/// C_r: a residual's f32 error in units of ε·m_k (module docs).
pub const RESIDUAL_FACTOR: f64 = 10.0;

/// The factor c in |Δ(JᵀJ)_uv| ≤ c ε (MᵀM)_uv and |Δ(Jᵀr)_u| ≤ c ε (Mᵀ(|r| + m))_u for
/// K×L samples per cell: 25 + 2KL (module docs), at least 64 (the value derived for K = L = 4
/// and used since).
pub fn normal_equations_factor(k: usize, l: usize) -> f64 {
    (25.0 + 2.0 * (k * l) as f64).max(64.0)
}

/// The f32 summation factor of the energy: 2KL squares per cell.
fn energy_sum_factor(k: usize, l: usize) -> f64 {
    (2 * k * l) as f64
}

/// `f` with every value rounded to f32 (what the GPU sees).
pub fn round_field(f: &Field) -> Field {
    Field {
        values: f.values.iter().map(|&v| v as f32 as f64).collect(),
        ..f.clone()
    }
}

/// Values rounded to f32.
pub fn round(v: &[f64]) -> Vec<f64> {
    v.iter().map(|&x| x as f32 as f64).collect()
}

/// Distance from the nearest integer of u = p·n − ½ over every sample point p of `grid` (the
/// current lines) along one axis of an n-texel field: how far each sample is from a texel-centre
/// boundary, where the bilinear gradient jumps (and from the clamping edges u = 0, n − 1).
pub fn texel_margin(lines: &[f64], k: usize, n: usize) -> f64 {
    let mut margin = f64::INFINITY;
    for w in lines.windows(2) {
        for a in 0..k {
            let alpha = (a as f64 + 0.5) / k as f64;
            let u = (w[0] + alpha * (w[1] - w[0])) * n as f64 - 0.5;
            margin = margin.min((u - u.round()).abs());
        }
    }
    margin
}

/// The reference's quantities the bounds need at x: residuals r, dense Jacobian J, and per
/// residual m_k = |r_k + σo| + σ|o| (module docs), in the reference's residual order (cell
/// column, row, sample, axis; σ = 0 samples have no residual).
pub struct Magnitudes {
    pub r: Vec<f64>,
    /// The sizes of the terms of each derivative (|J| where its terms do not cancel; more where
    /// they do): [`AaEnergy::jacobian_magnitudes`].
    pub jac: DMatrix<f64>,
    pub m: Vec<f64>,
    /// The cell of each residual (cell index i·(N−1) + j).
    pub cell: Vec<usize>,
}

/// [`Magnitudes`] of `cpu` at x.
pub fn magnitudes(
    cpu: &mut AaEnergy,
    rest: &RestFields,
    rest_grid: &Grid,
    (k, l): (usize, usize),
    x: &[f64],
) -> Magnitudes {
    let r = cpu.residuals(x);
    let jac = cpu.jacobian_magnitudes(x);
    let per_cell = k * l;
    let samples: Vec<(usize, _)> = rest_samples(rest, rest_grid, k, l)
        .into_iter()
        .enumerate()
        .filter(|(_, p)| p.sigma != 0.0)
        .map(|(n, p)| (n / per_cell, p))
        .collect();
    assert_eq!(r.len(), 2 * samples.len(), "two residuals per sample");
    let m = r
        .iter()
        .enumerate()
        .map(|(n, &rk)| {
            let p = samples[n / 2].1;
            let so = p.sigma as f64 * if n % 2 == 0 { p.o_s } else { p.o_t } as f64;
            (rk + so).abs() + so.abs()
        })
        .collect();
    let cell = (0..r.len()).map(|n| samples[n / 2].0).collect();
    Magnitudes { r, jac, m, cell }
}

/// The bound 2 C_r ε Σ|r_k| m_k + 2KL ε F on |F̃ − F| (module docs) over the residuals `r`
/// with magnitudes `m`.
pub fn energy_bound(r: &[f64], m: &[f64], (k, l): (usize, usize)) -> f64 {
    let f: f64 = r.iter().map(|v| v * v).sum();
    let scale: f64 = r.iter().zip(m).map(|(rk, mk)| rk.abs() * mk).sum();
    2.0 * RESIDUAL_FACTOR * EPS * scale + energy_sum_factor(k, l) * EPS * f
}

/// The bound c ε (Mᵀ(|r| + m))_u on |Δ(Jᵀr)_u| for every unknown u (module docs).
pub fn gradient_bound(mg: &Magnitudes, (k, l): (usize, usize)) -> Vec<f64> {
    let weights =
        DVector::from_iterator(mg.r.len(), mg.r.iter().zip(&mg.m).map(|(r, m)| r.abs() + m));
    let g = mg.jac.abs().transpose() * weights;
    g.iter()
        .map(|v| normal_equations_factor(k, l) * EPS * v)
        .collect()
}

/// The bound c ε (MᵀM)_uv on |Δ(JᵀJ)_uv| for every entry (module docs).
pub fn jtj_bound(mg: &Magnitudes, (k, l): (usize, usize)) -> DMatrix<f64> {
    let a = mg.jac.abs();
    (a.transpose() * &a) * (normal_equations_factor(k, l) * EPS)
}

/// A frame's inputs rounded to f32, as both sides see them.
pub struct RoundedInputs {
    pub rest: RestFields,
    pub rest_grid: Grid,
    pub deformed: DeformedFields,
}

/// `rest`, `rest_grid` and `deformed` with every value rounded to f32.
pub fn round_inputs(
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
) -> Result<RoundedInputs> {
    Ok(RoundedInputs {
        rest: RestFields {
            o_s: round_field(&rest.o_s),
            o_t: round_field(&rest.o_t),
            rigidity: round_field(&rest.rigidity),
        },
        rest_grid: Grid::new(round(&rest_grid.s), round(&rest_grid.t))?,
        deformed: DeformedFields {
            d_s: round_field(&deformed.d_s),
            d_t: round_field(&deformed.d_t),
        },
    })
}

/// The evaluation point: every interior line of `grid` moved by up to `amplitude` (a fixed
/// deterministic pattern, candidate c = 1, 2, …), rounded to f32; the first candidate whose
/// samples all lie ≥ 1e-3 texel from a texel-centre boundary of the n_s × n_t fields (then the
/// f32 sample position, off by ≲ 1e-5 texel, interpolates in the same texel as the f64 one).
/// `None` when 200 candidates all come closer.
pub fn evaluation_point(
    grid: &Grid,
    (k, l): (usize, usize),
    (n_s, n_t): (usize, usize),
    amplitude: f64,
) -> Option<Vec<f64>> {
    let x0 = grid.to_unknowns();
    // The smallest cell width bounds the move, so lines never cross.
    let widths = grid.s.windows(2).chain(grid.t.windows(2));
    let h_min = widths.map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min);
    let amplitude = amplitude.min(0.25 * h_min);
    (1..200)
        .map(|c| {
            let x: Vec<f64> = x0
                .iter()
                .enumerate()
                .map(|(n, &v)| v + amplitude * ((n * 7 + c * 3) as f64 * 0.61).sin())
                .collect();
            round(&x)
        })
        .find(|x| {
            let g = grid.with_unknowns(x);
            texel_margin(&g.s, k, n_s).min(texel_margin(&g.t, l, n_t)) >= 1e-3
        })
}

/// The inputs rounded to f32 ([`round_inputs`]) and the point x of [`evaluation_point`] (lines
/// moved by up to 0.013): what both sides of one kernel evaluation receive. A typed error naming
/// `input` when no point keeps the samples off the texel boundaries.
pub fn prepared_evaluation(
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
    kl: (usize, usize),
) -> Result<(RoundedInputs, Vec<f64>)> {
    let rounded = round_inputs(rest, rest_grid, deformed)?;
    let size = (rounded.deformed.d_s.width, rounded.deformed.d_s.height);
    let x = evaluation_point(&rounded.rest_grid, kl, size, 0.013).ok_or_else(|| {
        Error::InvalidArgument(format!(
            "{input}: no evaluation point keeps every sample 1e-3 texel away from a texel \
             boundary; try another --samples or --size"
        ))
    })?;
    Ok((rounded, x))
}

/// One evaluation of the kernel against the reference: per-cell energies, F, JᵀJ and Jᵀr of
/// frame `deformed` at a point near `rest_grid` ([`evaluation_point`]), with K×L samples.
pub fn kernel_rows(
    gpu: &Gpu,
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    deformed: &DeformedFields,
    (k, l): (usize, usize),
) -> Result<Vec<Row>> {
    let (
        RoundedInputs {
            rest,
            rest_grid,
            deformed,
        },
        x,
    ) = prepared_evaluation(input, rest, rest_grid, deformed, (k, l))?;
    let mut cpu = AaEnergy::new(&rest, &rest_grid, &deformed, k, l);
    let mut gpu_energy = GpuAaEnergy::new(gpu, &rest, &rest_grid, &deformed, k, l)?;
    let (reference, cpu_ms) = time_cpu(|| cpu.normal_equations(&x));
    let (cells, gpu_times) = time_gpu_warm(gpu, || gpu_energy.cells(&x))?;
    let measured = crate::gridwarp::gpu::assemble(&cells, x.len());
    let mg = magnitudes(&mut cpu, &rest, &rest_grid, (k, l), &x);
    let timing = Timing {
        cpu_ms: Some(cpu_ms),
        ..gpu_times
    };
    let kl = (k, l);
    let c = normal_equations_factor(k, l);
    let algorithm = "gridwarp";

    // Per-cell energies: the kernel's Σ r² of each cell (it returns no single residual).
    let cell_count = cells.len();
    let mut cell_r: Vec<Vec<f64>> = vec![Vec::new(); cell_count];
    let mut cell_m: Vec<Vec<f64>> = vec![Vec::new(); cell_count];
    for ((&r, &m), &c) in mg.r.iter().zip(&mg.m).zip(&mg.cell) {
        cell_r[c].push(r);
        cell_m[c].push(m);
    }
    let (mut cell_errors, mut cell_bounds) = (Vec::new(), Vec::new());
    for (c, cell) in cells.iter().enumerate() {
        let f: f64 = cell_r[c].iter().map(|r| r * r).sum();
        let d = (cell.energy as f64 - f).abs();
        let b = energy_bound(&cell_r[c], &cell_m[c], kl);
        let scale = if f > 0.0 { f } else { 1.0 };
        cell_errors.push(if d == 0.0 { 0.0 } else { d / scale });
        cell_bounds.push(b / scale);
    }
    let cells_row = Row::compare(
        algorithm,
        "gridwarp_aa: cell energy Σr²",
        input,
        "relative",
        &cell_errors,
        &[],
        Bounds::PerElement(cell_bounds),
        "(2·10 ε Σ|r_k| m_k + 2KL ε F_c) / F_c over the cell's residuals",
    )
    .with_note("the kernel returns each cell's Σ r², not single residuals")
    .with_timing(timing);

    let f = reference.energy;
    let e_bound = energy_bound(&mg.r, &mg.m, kl);
    let energy_row = Row::compare(
        algorithm,
        "gridwarp_aa: energy F",
        input,
        "relative",
        &[(measured.energy - f).abs() / f],
        &[],
        Bounds::Uniform(e_bound / f),
        "(2·10 ε Σ|r_k| m_k + 2KL ε F) / F",
    );

    let n = x.len();
    let a_max = reference.jtj.amax().max(f64::MIN_POSITIVE);
    let jtj_scale = jtj_bound(&mg, kl);
    let (mut jtj_errors, mut jtj_bounds) = (Vec::new(), Vec::new());
    for u in 0..n {
        for v in 0..n {
            jtj_errors.push((measured.jtj[(u, v)] - reference.jtj[(u, v)]).abs() / a_max);
            jtj_bounds.push(jtj_scale[(u, v)] / a_max);
        }
    }
    let jtj_row = Row::compare(
        algorithm,
        "gridwarp_aa: JᵀJ",
        input,
        "relative to max |JᵀJ|",
        &jtj_errors,
        &[],
        Bounds::PerElement(jtj_bounds),
        &format!("{c} ε (MᵀM)_uv / max|JᵀJ|, M the derivatives' term sizes"),
    );

    let g_max = reference.jtr.amax().max(f64::MIN_POSITIVE);
    let g_bound = gradient_bound(&mg, kl);
    let jtr_errors: Vec<f64> = (0..n)
        .map(|u| (measured.jtr[u] - reference.jtr[u]).abs() / g_max)
        .collect();
    let jtr_row = Row::compare(
        algorithm,
        "gridwarp_aa: Jᵀr",
        input,
        "relative to max |Jᵀr|",
        &jtr_errors,
        &[],
        Bounds::PerElement(g_bound.iter().map(|b| b / g_max).collect()),
        &format!("{c} ε (Mᵀ(|r| + m))_u / max|Jᵀr|, M the derivatives' term sizes"),
    );
    Ok(vec![cells_row, energy_row, jtj_row, jtr_row])
}

/// The bounds of a whole GPU-objective solve against the CPU solve, at the CPU's solution x*
/// (A = JᵀJ there, e = [`energy_bound`], b = [`gradient_bound`]):
///
/// - energy: the GPU run stops where its f32 evaluations no longer see a decrease, so its excess
///   is at most ≈ 2e, plus the excess of the point its f32 gradient (error ≤ b) makes look
///   stationary, ½ bᵀ|A⁻¹|b; the CPU run itself stops within 1e-12 relative:
///   |ΔF| ≤ 2e + ½ bᵀ|A⁻¹|b + 1e-12 F;
/// - lines: the displacements that give those excesses, ‖|A⁻¹| b‖∞ + √(4e / λ_min(A)).
///
/// Returns (energy bound, line bound); `None` when A is singular.
pub fn solve_bounds(
    cpu: &mut AaEnergy,
    rest: &RestFields,
    rest_grid: &Grid,
    kl: (usize, usize),
    x_star: &[f64],
    energy: f64,
) -> Option<(f64, f64)> {
    let mg = magnitudes(cpu, rest, rest_grid, kl, x_star);
    let e = energy_bound(&mg.r, &mg.m, kl);
    let b = DVector::from_vec(gradient_bound(&mg, kl));
    let a = cpu.normal_equations(x_star).jtj;
    solve_tolerances(e, &b, &a, energy)
}

/// The formula of [`solve_bounds`], shared with the non-axis-aligned solves
/// ([`super::gridwarp_naa::naa_solve_bounds`]): from the energy bound e, the gradient bound b
/// and A = JᵀJ at the CPU minimum (F = `energy`), (2e + ½ bᵀ|A⁻¹|b + 1e-12 F,
/// ‖|A⁻¹| b‖∞ + √(4e / λ_min(A))); `None` when A is singular.
pub fn solve_tolerances(
    e: f64,
    b: &DVector<f64>,
    a: &DMatrix<f64>,
    energy: f64,
) -> Option<(f64, f64)> {
    let a_inv_abs = a.clone().try_inverse()?.abs();
    let lambda_min = a.clone().symmetric_eigenvalues().min();
    if !(lambda_min > 0.0) {
        return None;
    }
    let e_tol = 2.0 * e + 0.5 * b.dot(&(&a_inv_abs * b)) + 1e-12 * energy;
    let x_tol = (&a_inv_abs * b).amax() + (4.0 * e / lambda_min).sqrt();
    Some((e_tol, x_tol))
}

/// The lattice of the rigid-stretch figures ([`crate::gridwarp::merit::rigid_stretch`]) in the
/// whole-run comparisons: the CLI's own.
pub const STRETCH_LATTICE: usize = 256;

/// The largest slope of a bilinear field, per texture width: the largest difference of two
/// neighbouring texels times the resolution.
fn field_slope(f: &Field) -> f64 {
    let (w, h) = (f.width, f.height);
    let mut g = 0.0f64;
    for y in 0..h {
        for x in 0..w {
            let v = f.values[y * w + x];
            if x + 1 < w {
                g = g.max((f.values[y * w + x + 1] - v).abs() * w as f64);
            }
            if y + 1 < h {
                g = g.max((f.values[(y + 1) * w + x] - v).abs() * h as f64);
            }
        }
    }
    g
}

/// How far the rigid-stretch figures (mean and max) can move when every line of `warped` moves
/// by at most δ (texture widths). A point's stretch is v = |‖D(p)‖ a / ‖O‖ − 1| with a = Δwarped
/// / Δrest its cell's slope and p its warped position: a moves by ≤ 2δ/h_min (h_min the smallest
/// rest cell) and p by ≤ δ, so ‖D(p)‖ by ≤ G δ (G the fields' largest slope, `field_slope`);
/// hence |Δv| ≤ (D_max · 2δ/h_min + (a_max + 2δ/h_min) G δ) / O_min, which bounds both the
/// R-weighted mean and the max. `None` where some ‖O‖ ≤ 0.
pub fn stretch_bound(
    rest: &RestFields,
    deformed: &DeformedFields,
    rest_grid: &Grid,
    warped: &Grid,
    delta: f64,
) -> Option<f64> {
    let widths = |g: &[f64]| g.windows(2).map(|w| w[1] - w[0]).collect::<Vec<f64>>();
    let (rs, rt) = (widths(&rest_grid.s), widths(&rest_grid.t));
    let (ws, wt) = (widths(&warped.s), widths(&warped.t));
    let h_min = rs.iter().chain(&rt).copied().fold(f64::INFINITY, f64::min);
    let a_max = ws
        .iter()
        .zip(&rs)
        .chain(wt.iter().zip(&rt))
        .map(|(w, r)| (w / r).abs())
        .fold(0.0, f64::max);
    let max_of = |f: &Field| f.values.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let min_of = |f: &Field| f.values.iter().copied().fold(f64::INFINITY, f64::min);
    let o_min = min_of(&rest.o_s).min(min_of(&rest.o_t));
    if !(o_min > 0.0) || !(h_min > 0.0) {
        return None;
    }
    let d_max = max_of(&deformed.d_s).max(max_of(&deformed.d_t));
    let g = field_slope(&deformed.d_s).max(field_slope(&deformed.d_t));
    let da = 2.0 * delta / h_min;
    Some((d_max * da + (a_max + da) * g * delta) / o_min)
}

/// Whole sequences solved with the GPU objective and with the CPU one: per frame, the
/// GPU-solved lines' f64 energy against the CPU minimum, and the lines, against
/// [`solve_bounds`].
pub fn solve_rows(
    gpu: &Gpu,
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<Vec<Row>> {
    let (cpu, cpu_ms) = time_cpu(|| solve_sequence(rest, rest_grid, frames, options));
    let cpu = cpu?;
    let (gpu_solutions, gpu_times) = time_gpu(gpu, || {
        solve_sequence_gpu(gpu, rest, rest_grid, frames, options)
    })?;
    let kl = options.samples_per_cell();
    let (mut f_err, mut f_bound, mut x_err, mut x_bound) = (vec![], vec![], vec![], vec![]);
    let mut singular = 0;
    for (j, (c, g)) in cpu.iter().zip(&gpu_solutions).enumerate() {
        let mut reference = AaEnergy::new(rest, rest_grid, &frames[j], kl.0, kl.1);
        let e_gpu = reference.energy(&g.lm.x);
        let Some((e_tol, x_tol)) =
            solve_bounds(&mut reference, rest, rest_grid, kl, &c.lm.x, c.lm.energy)
        else {
            singular += 1;
            continue;
        };
        let scale = c.lm.energy.max(f64::MIN_POSITIVE);
        f_err.push((e_gpu - c.lm.energy).abs() / scale);
        f_bound.push(e_tol / scale);
        x_err.push(
            c.lm.x
                .iter()
                .zip(&g.lm.x)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max),
        );
        x_bound.push(x_tol);
    }
    let timing = Timing {
        cpu_ms: Some(cpu_ms),
        ..gpu_times
    };
    let note = if singular > 0 {
        format!("{singular} frame(s) left out: JᵀJ singular at the CPU minimum (no bound)")
    } else {
        format!("{} frames", frames.len())
    };
    Ok(vec![
        Row::compare(
            "gridwarp",
            "run: LM solve, final F per frame",
            input,
            "relative",
            &f_err,
            &[],
            Bounds::PerElement(f_bound),
            "(2e + ½ bᵀ|A⁻¹|b + 1e-12 F) / F at the CPU minimum",
        )
        .with_note(&note)
        .with_timing(timing),
        Row::compare(
            "gridwarp",
            "run: LM solve, lines per frame",
            input,
            "texture width",
            &x_err,
            &[],
            Bounds::PerElement(x_bound),
            "‖|A⁻¹| b‖∞ + √(4e / λ_min(A))",
        )
        .with_note(&note),
    ])
}

/// The axis-aligned gridwarp table for one input: the kernel at the last (most deformed) frame
/// and whole solves (the non-axis-aligned table: [`super::gridwarp_naa::crosscheck_gridwarp_naa`]).
pub fn crosscheck_gridwarp(
    gpu: &Gpu,
    input: &str,
    rest: &RestFields,
    rest_grid: &Grid,
    frames: &[DeformedFields],
    options: &SolveOptions,
) -> Result<Vec<Row>> {
    let last = frames
        .last()
        .ok_or_else(|| Error::InvalidArgument(format!("{input}: no frame to cross-check")))?;
    if rest_grid.unknowns() == 0 {
        return Err(Error::InvalidArgument(format!(
            "{input}: the starting grid has no interior line, so there is nothing to evaluate; \
             give a rigidity map or --grid MxN"
        )));
    }
    let mut rows = kernel_rows(
        gpu,
        input,
        rest,
        rest_grid,
        last,
        options.samples_per_cell(),
    )?;
    rows.extend(solve_rows(gpu, input, rest, rest_grid, frames, options)?);
    Ok(rows)
}
