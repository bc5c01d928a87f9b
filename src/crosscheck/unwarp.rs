//! unwarp cross-check: the `unwarp_pass` kernel (f32) against the f64 per-texel descent
//! [`descend_texel_traced`], one pass per phase from the same state, and whole runs compared by
//! their energy per sweep and their area statistics.
//!
//! The bounds are derived here once ([`step_bound`], [`ETA`], [`run_energy_bound`],
//! [`area_cv_bound`]) and used by `tests/gpu_unwarp.rs` and `reparam crosscheck unwarp` alike.
//! Offsets are reported in texels of a 4096² texture: |Δo| (UV units) × 4096.

use reparam_gpu::Gpu;

use super::timing::{time_cpu, time_gpu};
pub use super::unwarp_bound::{
    indistinguishable_radius, no_step_bound, step_bound, sublevel_interval, ETA,
    STEP_BOUND_FORMULA, U32,
};
use super::{Bounds, Row, Timing};
use crate::error::Result;
use crate::unwarp::gpu::{round_problem, GpuPass};
/// Errors are reported in texels of a texture this wide.
pub const TEXTURE_SIZE: f64 = 4096.0;

use crate::unwarp::energy::{node_energy, Fan};
use crate::unwarp::pass::{descend_texel_traced, pass, sweep_phases};
use crate::unwarp::stats::{area_ratios, coefficient_of_variation};
use crate::unwarp::{solve, solve_with, HeightMap, Problem, UnwarpOptions};

/// Whether the step of texel (x, y) from `start` to `gpu` leaves its node energy F (f64, the
/// fan of `start`) within 2ηF of the reference's step to `cpu`: [`run_energy_bound`]'s premise.
pub fn within_run_premise(
    problem: &Problem,
    start: &[[f64; 2]],
    (x, y): (usize, usize),
    cpu: [f64; 2],
    gpu: [f64; 2],
) -> bool {
    let i = problem.mesh.index(x, y);
    let fan = Fan::new(&problem.mesh, start, x, y);
    let f = |o: [f64; 2]| {
        node_energy(
            &fan,
            problem.pins[i],
            problem.pin_resolution,
            o,
            problem.theta,
        )
    };
    let (fc, fg) = (f(cpu), f(gpu));
    (fg - fc).abs() <= 2.0 * ETA * fc.abs()
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
    /// Texels where the GPU's step leaves F (evaluated in f64 on the fan of the common start)
    /// more than 2ηF from the reference's: where [`run_energy_bound`]'s premise fails.
    pub premise_violations: usize,
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
        premise_violations: 0,
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
        // Per texel and independent of the others: in parallel (the reachable search paths make
        // the bound the comparison's most expensive part).
        let bounds: Vec<f64> = {
            use rayon::prelude::*;
            texels
                .par_iter()
                .map(|&(x, y)| step_bound(problem, start, x, y))
                .collect()
        };
        out.bounds.extend(bounds);
        for ((&(x, y), r), cpu) in texels.iter().zip(&results).zip(&steps) {
            let i = mesh.index(x, y);
            out.diffs.push(
                ((cpu.offset[0] - gpu_offsets[i][0]) * res[0])
                    .hypot((cpu.offset[1] - gpu_offsets[i][1]) * res[1]),
            );
            out.premise_violations += usize::from(!within_run_premise(
                problem,
                start,
                (x, y),
                cpu.offset,
                gpu_offsets[i],
            ));
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
///
/// The energy bound rests on a premise, that every f32 pass leaves each texel within 2ηF of
/// where the f64 pass from the same state leaves it ([`run_energy_bound`]). The pass comparison
/// measures it on the first pass: where it failed at `premise_violations` texels (a rough
/// height map, whose line functions have several minima near t*: the f32 search ended
/// measurably elsewhere, as the pass bound allows), the trajectories may part for good, the
/// spec bounds no run energy, and the row is shown, not judged.
pub fn run_rows(
    gpu: &Gpu,
    input: &str,
    heights: &HeightMap,
    options: &UnwarpOptions,
    premise_violations: usize,
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
        .with_timing(timing)
        .informative_if(
            premise_violations > 0,
            &format!(
                "the bound's premise (each pass within 2ηF per texel) failed at \
                 {premise_violations} texels of the first pass: on this rough map the f32 search \
                 ends measurably elsewhere (within the pass bound), whole runs may part for \
                 good, and the WGSL spec bounds no run energy; the pass row is the kernel's check"
            ),
        ),
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
    Ok(pass_comparison_row(gpu, input, heights, options)?.0)
}

/// [`pass_row`] and the number of texels where the run bound's premise failed
/// ([`PassComparison::premise_violations`]).
pub fn pass_comparison_row(
    gpu: &Gpu,
    input: &str,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<(Row, usize)> {
    let (problem, start) = rounded_state(heights, options, 2)?;
    let c = compare_pass(gpu, &problem, &start)?;
    let res = problem.mesh.resolution();
    let to_4096 = TEXTURE_SIZE / res[0].max(res[1]);
    let errors: Vec<f64> = c.diffs.iter().map(|d| d * to_4096).collect();
    let bounds: Vec<f64> = c.bounds.iter().map(|b| b * to_4096).collect();
    let total = errors.len();
    let row = Row::compare(
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
        "{total} texel updates, {} identical search paths, {} identical guard decisions; {} \
         texels' F more than 2ηF from the reference's",
        c.same_path, c.same_moved, c.premise_violations
    ))
    .with_timing(c.timing);
    Ok((row, c.premise_violations))
}

/// The full unwarp table for one height map: the pass kernel ([`pass_row`]), whole runs of
/// min(sweeps, 10) sweeps, the lookup through the offsets' mip chain
/// ([`super::unwarp_lookup::lookup_rows`]), and the computations without a GPU kernel.
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
    let (pass, premise_violations) = pass_comparison_row(gpu, input, heights, options)?;
    let mut rows = vec![pass];
    rows.extend(run_rows(
        gpu,
        input,
        heights,
        &run_options,
        premise_violations,
    )?);
    rows.extend(super::unwarp_lookup::lookup_rows(
        gpu, input, heights, options,
    )?);
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
