//! unwarp cross-check: the `unwarp_pass` kernel (f32) against the f64 per-texel descent
//! [`descend_texel_traced`], one pass per phase from the same state, and whole runs compared by
//! their energy per sweep and their area statistics.
//!
//! The bounds are derived here once ([`step_bound`], [`ETA`], [`run_energy_bound`],
//! [`area_cv_bound`]) and used by `tests/gpu_unwarp.rs` and `reparam crosscheck unwarp` alike.
//! Offsets are reported in texels of a 4096² texture: |Δo| (UV units) × 4096.

use reparam_gpu::Gpu;

use super::timing::{time_cpu, time_gpu};
use super::{Bounds, Row, Timing};
use crate::error::Result;
use crate::unwarp::energy::{node_energy, node_gradient, triangle_gradient, Fan};
use crate::unwarp::fixation::pin_gradient;
use crate::unwarp::gpu::{round_problem, GpuPass};
use crate::unwarp::pass::{descend_texel_traced, line_point, pass, sweep_phases};
use crate::unwarp::stats::{area_ratios, coefficient_of_variation};
use crate::unwarp::{solve, solve_with, HeightMap, Problem, UnwarpOptions};

/// The size u of one rounding: [`super::WGSL_U`] = 2⁻²³ (WGSL rounds up or down).
pub const U32: f64 = super::WGSL_U;

/// Relative error of one f32 evaluation of a node energy F (or of one triangle-gradient term):
/// each triangle is a chain of ≈ 30 roundings (edges, a, D, Y, Y^5 by 3 multiplications, the
/// quotient), the six are summed: η ≈ 30 u.
pub const ETA: f64 = 30.0 * U32;

/// Errors are reported in texels of a texture this wide.
pub const TEXTURE_SIZE: f64 = 4096.0;

/// [`step_bound`] in one line, for the cross-check's table and the conformance vectors'
/// manifest.
pub const STEP_BOUND_FORMULA: &str =
    "|Δt||g| (Δt: the interval where F ≤ F(t*) + 2ηF) + 2φs + guard s + 1e-6 hi|g|, η = 30 ε; \
     where f64 finds no step: √(4ηF/λ_min) at a stationary node, else max_k |U_k|";

/// The bound on |Δo| (texels of the map) between the f32 and f64 steps of texel (x, y), from
/// the reference's quantities at its step t* along −g:
///
/// 1. f32 cannot order F(t1), F(t2) once they differ by less than 2ηF, so the search may end
///    anywhere on the interval around t* where F(t) ≤ F(t*) + 2ηF (near a quadratic minimum
///    ½F''(t − t*)² ≤ 2ηF, |Δt| ≤ 2√(ηF/F''); measured on F itself by
///    [`indistinguishable_radius`], since a hostile height map's F need not be quadratic
///    there), |Δo| ≤ |Δt|·|g|;
/// 2. the f32 gradient's direction is off by φ ≤ η Σ|∇E_k|/|g| (the sum of the terms' sizes,
///    cancellation included), which moves the line's minimiser by ≤ 2φ·s, s = t*|g|;
/// 3. when the f64 guard's margin F(0) − F(t*) is below 2ηF, f32 may decide the other way:
///    |Δo| ≤ s.
///
/// The final bracket width 1e-6·hi adds ≤ 1e-6 hi|g|. Where the reference finds no step (g
/// zero or not finite, or no bracket) the bound is [`no_step_bound`]'s.
pub fn step_bound(problem: &Problem, offsets: &[[f64; 2]], x: usize, y: usize) -> f64 {
    let mesh = &problem.mesh;
    let i = mesh.index(x, y);
    // r: the pin barrier's R (the finest level's), as the reference's energy uses it; the
    // bound is reported in texels of this level's map.
    let (o, w, r, theta) = (
        offsets[i],
        problem.pins[i],
        problem.pin_resolution,
        problem.theta,
    );
    let fan = Fan::new(mesh, offsets, x, y);
    let step = descend_texel_traced(problem, offsets, x, y);
    let g = node_gradient(&fan, w, r, o, theta);
    let gn = g[0].hypot(g[1]);
    let texels = mesh.width.max(mesh.height) as f64;
    let Some([_, hi]) = step.bracket else {
        return no_step_bound(&fan, w, r, o, g, theta) * texels;
    };
    let f = |t: f64| node_energy(&fan, w, r, line_point(o, g, t), theta);
    let t = step.search.t;
    let ft = f(t);
    let search = indistinguishable_radius(&f, t, hi, ft + 2.0 * ETA * ft.abs()) * gn;
    let u = fan.uv_edges(o);
    let terms: f64 = (0..6)
        .map(|k| {
            let gk = triangle_gradient(&fan.geometry[k], u[(k + 5) % 6], u[k], theta);
            gk[0].hypot(gk[1])
        })
        .sum::<f64>()
        + {
            let p = pin_gradient(w, r, o);
            p[0].hypot(p[1])
        };
    let s = t * gn;
    let direction = 2.0 * (ETA * terms / gn) * s;
    let guard = if f(0.0) - ft <= 2.0 * ETA * f(0.0) {
        s
    } else {
        0.0
    };
    (search + direction + guard + 1e-6 * hi * gn) * texels
}

/// The bound on |Δo| (UV units) at a node where the f64 reference finds no step (g = 0 or not
/// finite, or an empty bracket), so that its offset stays o. A conforming f32 pass either stays
/// too (error 0) or, its decisions differing near a tie, takes a step p:
///
/// 1. the step stays inside its flip-free bracket, i.e. inside the fan's UV polygon around the
///    node: |p − o| ≤ max_k |U_k| (U_k the UV edges to the six neighbours, ≈ 1–1.5 texels);
/// 2. at a stationary node (g = 0, a minimum of F: the Hessian H of F at o positive definite,
///    smallest eigenvalue λ_min), the guard accepted p only if F_f32(p) < F_f32(o), so
///    F(p) ≤ (1 + 2η) F(o); with F(p) ≥ F(o) + ½ λ_min |p − o|² near the minimum,
///    |p − o| ≤ √(4ηF(o)/λ_min). H by central differences of the analytic gradient, step
///    10⁻⁵ texel (its error, O(10⁻¹⁰) relative, far below η).
///
/// The smaller of the two where both apply; never 0 (a flat map's nodes are stationary).
pub fn no_step_bound(
    fan: &Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    g: [f64; 2],
    theta: f64,
) -> f64 {
    let polygon = fan
        .uv_edges(o)
        .iter()
        .map(|u| u[0].hypot(u[1]))
        .fold(0.0, f64::max);
    if g != [0.0, 0.0] {
        return polygon;
    }
    let delta = 1e-5 / resolution[0].max(resolution[1]);
    let column = |j: usize| {
        let mut plus = o;
        let mut minus = o;
        plus[j] += delta;
        minus[j] -= delta;
        let (gp, gm) = (
            node_gradient(fan, weight, resolution, plus, theta),
            node_gradient(fan, weight, resolution, minus, theta),
        );
        [
            (gp[0] - gm[0]) / (2.0 * delta),
            (gp[1] - gm[1]) / (2.0 * delta),
        ]
    };
    let (c0, c1) = (column(0), column(1));
    let (a, b, d) = (c0[0], 0.5 * (c0[1] + c1[0]), c1[1]);
    let lambda_min = 0.5 * ((a + d) - (a - d).hypot(2.0 * b));
    let f = node_energy(fan, weight, resolution, o, theta);
    let stationary = (4.0 * ETA * f / lambda_min).sqrt();
    if lambda_min > 0.0 && stationary.is_finite() {
        stationary.min(polygon)
    } else {
        polygon
    }
}

/// The largest |t − t*| over the interval around t* within [0, hi] on which F(t) ≤ `level`
/// (bound 1 of [`step_bound`]): on each side, distances 2⁻⁴⁰·span … span are tried in doubling
/// steps until F exceeds the level, then bisection between the last point under it and the
/// first above, keeping the outer end (so the radius is never underestimated by more than the
/// first step, 2⁻⁴⁰ of the side's span).
pub fn indistinguishable_radius(f: &impl Fn(f64) -> f64, t: f64, hi: f64, level: f64) -> f64 {
    let side = |end: f64| -> f64 {
        let span = end - t;
        if span == 0.0 {
            return 0.0;
        }
        let mut inside = 0.0;
        let mut outside = None;
        for k in (0..=40).rev() {
            let d = span / f64::from(1u32 << (k / 2)) / f64::from(1u32 << (k - k / 2));
            if f(t + d) > level {
                outside = Some(d);
                break;
            }
            inside = d;
        }
        let Some(mut outside) = outside else {
            return span.abs();
        };
        for _ in 0..50 {
            let mid = 0.5 * (inside + outside);
            if f(t + mid) > level {
                outside = mid;
            } else {
                inside = mid;
            }
        }
        outside.abs()
    };
    side(0.0).max(side(hi))
}

/// The relative difference of the total energies after `p` passes, from the reference's totals
/// `energy[q]` before each pass q (index 0: the start): each f32 pass can leave every texel at
/// most 2ηF above (or below) where the f64 pass from the same state leaves it (the search's
/// resolution, bound 1 of [`step_bound`]), an absolute difference ≤ 2η E_q for pass q; later
/// passes descend from both states alike and do not amplify it (first order), so after p passes
/// |E_f32 − E_f64| ≤ 2η Σ_{q<p} E_q, and relatively that over E_p. (2ηp, the same sum with every
/// E_q = E_p, holds only while the energy barely falls: on a real height map the first sweep
/// lowers it ten-fold and the early passes' differences dominate.)
pub fn run_energy_bound(energy: &[f64], p: usize) -> f64 {
    let before: f64 = energy[..p].iter().sum();
    2.0 * ETA * before / energy[p]
}

/// The pass index at the end of every full sweep of `phases` passes, among `passes` recorded
/// energies (index 0: the start): phases, 2·phases, … (the figures a whole run is compared on).
pub fn sweep_ends(passes: usize, phases: usize) -> impl Iterator<Item = usize> {
    (phases.max(1)..passes).step_by(phases.max(1))
}

/// A triangle's area ratio a/A moves by ≤ 2|Δo| (texels) relatively when a corner moves by
/// |Δo| (edges are ≈ 1 texel); the CV of the ratios, a normalised RMS, then moves by
/// ≤ 2·rms|Δo|·(1 + CV).
pub fn area_cv_bound(rms_offset_texels: f64, cv: f64) -> f64 {
    2.0 * rms_offset_texels * (1.0 + cv)
}

/// The problem of `heights` rounded to f32 inputs, and a state after `sweeps` reference sweeps,
/// rounded: the common start of the pass comparison.
pub fn rounded_state(
    heights: &HeightMap,
    options: &UnwarpOptions,
    sweeps: usize,
) -> Result<(Problem, Vec<[f64; 2]>)> {
    let problem = round_problem(&Problem::new(heights, options)?);
    let mut offsets = vec![[0.0; 2]; problem.mesh.node_count()];
    for _ in 0..sweeps {
        for phase in sweep_phases(&problem.mesh) {
            pass(&problem, &mut offsets, phase);
        }
    }
    let offsets = offsets
        .iter()
        .map(|o| [o[0] as f32 as f64, o[1] as f32 as f64])
        .collect();
    Ok((problem, offsets))
}

/// Per texel of every phase: the GPU's and the reference's offsets after one pass from
/// `start`, and the texel's [`step_bound`] (both in texels of the map).
pub struct PassComparison {
    pub diffs: Vec<f64>,
    pub bounds: Vec<f64>,
    /// Texels whose search path (the sub-bracket kept at each iteration) matches.
    pub same_path: usize,
    /// Texels whose guard decision (moved or not) matches.
    pub same_moved: usize,
    /// Per iteration, how many searches first kept the other sub-bracket there (index 32:
    /// never).
    pub first_divergence: Vec<usize>,
    pub timing: Timing,
}

/// One pass of every phase on the GPU and the reference from `start`.
pub fn compare_pass(gpu: &Gpu, problem: &Problem, start: &[[f64; 2]]) -> Result<PassComparison> {
    use reparam_gpu::unwarp::{FLAG_MOVED, STEPS_MASK};
    let mesh = &problem.mesh;
    let res = mesh.resolution();
    let mut backend = GpuPass::new(gpu.clone());
    let mut out = PassComparison {
        diffs: vec![],
        bounds: vec![],
        same_path: 0,
        same_moved: 0,
        first_divergence: vec![0; 33],
        timing: Timing::default(),
    };
    let (mut gpu_kernel, mut gpu_total, mut cpu_total) = (0.0, 0.0, 0.0);
    // One untimed pass first: the times are those of a warm kernel.
    backend.run(problem, &mut start.to_vec(), 0)?;
    for phase in sweep_phases(mesh) {
        let mut gpu_offsets = start.to_vec();
        let (results, t) = time_gpu(gpu, || {
            Ok(backend.run(problem, &mut gpu_offsets, phase)?.to_vec())
        })?;
        gpu_kernel += t.gpu_kernel_ms.unwrap_or(0.0);
        gpu_total += t.gpu_total_ms.unwrap_or(0.0);
        let texels = mesh.active_texels(phase);
        let (steps, cpu_ms) = time_cpu(|| {
            use rayon::prelude::*;
            texels
                .par_iter()
                .map(|&(x, y)| descend_texel_traced(problem, start, x, y))
                .collect::<Vec<_>>()
        });
        cpu_total += cpu_ms;
        for ((&(x, y), r), cpu) in texels.iter().zip(&results).zip(&steps) {
            let i = mesh.index(x, y);
            out.diffs.push(
                ((cpu.offset[0] - gpu_offsets[i][0]) * res[0])
                    .hypot((cpu.offset[1] - gpu_offsets[i][1]) * res[1]),
            );
            out.bounds.push(step_bound(problem, start, x, y));
            out.same_moved += usize::from(cpu.moved == (r.flags & FLAG_MOVED != 0));
            let steps = (r.flags & STEPS_MASK).min(cpu.search.steps);
            let differ = (cpu.search.path ^ r.path) & ((1u64 << steps) - 1) as u32;
            if differ == 0 {
                out.same_path += 1;
                out.first_divergence[32] += 1;
            } else {
                out.first_divergence[differ.trailing_zeros() as usize] += 1;
            }
        }
    }
    out.timing = Timing {
        gpu_kernel_ms: Some(gpu_kernel),
        gpu_total_ms: Some(gpu_total),
        cpu_ms: Some(cpu_total),
    };
    Ok(out)
}

/// Whole runs of `sweeps` sweeps on the CPU and with the GPU passes: the relative difference of
/// the total energy after each sweep, and of the area-ratio CV at the end.
pub fn run_rows(
    gpu: &Gpu,
    input: &str,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<Vec<Row>> {
    let (cpu, cpu_ms) = time_cpu(|| solve(heights, options, |_| {}));
    let cpu = cpu?;
    let mut backend = GpuPass::new(gpu.clone());
    let (gpu_run, gpu_times) =
        time_gpu(gpu, || solve_with(&mut backend, heights, options, |_| {}))?;
    let phases = sweep_phases(&cpu.problem.mesh).len();
    let (ec, eg) = (&cpu.fine().energy_per_pass, &gpu_run.fine().energy_per_pass);
    let totals: Vec<f64> = ec.iter().map(|e| e.total()).collect();
    let (mut errors, mut bounds) = (vec![], vec![]);
    for p in sweep_ends(ec.len().min(eg.len()), phases) {
        errors.push((eg[p].total() - ec[p].total()).abs() / ec[p].total());
        bounds.push(run_energy_bound(&totals, p));
    }
    let res = cpu.problem.mesh.resolution();
    let rms = (cpu
        .offsets
        .iter()
        .zip(&gpu_run.offsets)
        .map(|(a, b)| ((a[0] - b[0]) * res[0]).powi(2) + ((a[1] - b[1]) * res[1]).powi(2))
        .sum::<f64>()
        / cpu.offsets.len() as f64)
        .sqrt();
    let cv_cpu = coefficient_of_variation(&area_ratios(&cpu.problem, &cpu.offsets));
    let cv_gpu = coefficient_of_variation(&area_ratios(&cpu.problem, &gpu_run.offsets));
    let timing = Timing {
        cpu_ms: Some(cpu_ms),
        ..gpu_times
    };
    let sweeps = format!(
        "{} sweeps of {phases} passes on the finest level",
        errors.len()
    );
    Ok(vec![
        Row::compare(
            "unwarp",
            "run: total energy per sweep",
            input,
            "relative",
            &errors,
            &[],
            Bounds::PerElement(bounds),
            "2η Σ_{q<p} E_q / E_p, η = 30 ε, over the passes q so far",
        )
        .with_note(&sweeps)
        .with_timing(timing),
        Row::compare(
            "unwarp",
            "run: area-ratio CV at the end",
            input,
            "absolute",
            &[(cv_cpu - cv_gpu).abs()],
            &[cv_cpu],
            Bounds::Uniform(area_cv_bound(rms, cv_cpu)),
            "2·rms|Δo|·(1 + CV)",
        )
        .with_note(&format!(
            "CV f64 {cv_cpu:.5}, f32 {cv_gpu:.5}; rms |Δo| {rms:.2e} texels"
        )),
    ])
}

/// The pass kernel from a state after two reference sweeps: every texel's offset after one pass
/// of each phase, in texels of a 4096² texture, against [`step_bound`].
pub fn pass_row(
    gpu: &Gpu,
    input: &str,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<Row> {
    let (problem, start) = rounded_state(heights, options, 2)?;
    let c = compare_pass(gpu, &problem, &start)?;
    let res = problem.mesh.resolution();
    let to_4096 = TEXTURE_SIZE / res[0].max(res[1]);
    let errors: Vec<f64> = c.diffs.iter().map(|d| d * to_4096).collect();
    let bounds: Vec<f64> = c.bounds.iter().map(|b| b * to_4096).collect();
    let total = errors.len();
    Ok(Row::compare(
        "unwarp",
        "unwarp_pass: offset after one pass",
        input,
        "texels of a 4096² texture",
        &errors,
        &[],
        Bounds::PerElement(bounds),
        &format!("per texel: {STEP_BOUND_FORMULA} (step_bound)"),
    )
    .with_note(&format!(
        "{total} texel updates, {} identical search paths, {} identical guard decisions",
        c.same_path, c.same_moved
    ))
    .with_timing(c.timing))
}

/// The full unwarp table for one height map: the pass kernel ([`pass_row`]), whole runs of
/// min(sweeps, 10) sweeps, and the computations without a GPU kernel.
pub fn crosscheck_unwarp(
    gpu: &Gpu,
    input: &str,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<Vec<Row>> {
    let run_options = UnwarpOptions {
        sweeps: options.sweeps.min(10),
        tolerance: None,
        coarse_moves: 0,
        ..options.clone()
    };
    let mut rows = vec![pass_row(gpu, input, heights, options)?];
    rows.extend(run_rows(gpu, input, heights, &run_options)?);
    rows.push(Row::missing(
        "unwarp",
        "coarse moves (hat-weighted block steps)",
        input,
        "coarse moves run in f64 on the CPU, also with --gpu; there is no WGSL kernel for them",
    ));
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::unwarp::{FixationOptions, HeightMap};

    /// A flat map without pins: every node is stationary (g = 0), the reference finds no step,
    /// and the bound is the guard's sublevel radius √(4ηF/λ_min): positive, and far inside the
    /// fan's polygon (≈ 1.4 texels).
    #[test]
    fn a_stationary_nodes_bound_is_the_sublevel_radius_not_zero() -> Result<()> {
        let heights = HeightMap::new("flat", 8, 8, vec![0.3; 64])?;
        let options = UnwarpOptions {
            fixation: FixationOptions {
                delta: 0.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let problem = Problem::new(&heights, &options)?;
        let offsets = vec![[0.0; 2]; 64];
        let step = descend_texel_traced(&problem, &offsets, 2, 2);
        assert_eq!((step.gradient, step.bracket), ([0.0; 2], None));
        let bound = step_bound(&problem, &offsets, 2, 2);
        assert!(bound > 0.0 && bound < 0.01, "{bound} texels");
        Ok(())
    }
}
