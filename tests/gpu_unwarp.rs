//! The unwarp pass on the GPU (`unwarp_pass`, f32) against the f64 reference
//! (`descend_texel`), from identical f32-rounded inputs, then whole runs compared by aggregate
//! figures. Without an adapter these tests print `skipped: no GPU adapter` and pass; with
//! REPARAM_REQUIRE_GPU=1 they fail instead.
#![cfg(feature = "gpu")]

use std::time::Instant;

use reparam::crosscheck::unwarp::{
    area_cv_bound, indistinguishable_radius, run_energy_bound, step_bound, ETA,
};
use reparam::unwarp::gpu::{grid_for, round_problem, GpuPass};
use reparam::unwarp::pass::{descend_texel_traced, pass};
use reparam::unwarp::stats::{area_ratios, coefficient_of_variation};
use reparam::unwarp::{procedural, solve, solve_with, Problem, UnwarpOptions};
use reparam_gpu::gpu_or_skip;
use reparam_gpu::unwarp::{UnwarpPassKernel, FLAG_MOVED, STEPS_MASK};

fn options() -> UnwarpOptions {
    UnwarpOptions {
        scale: 0.08,
        ..Default::default()
    }
}

/// The 32² cones problem rounded to f32 inputs and a state after 2 reference sweeps, rounded.
fn rounded_state() -> (Problem, Vec<[f64; 2]>) {
    let problem =
        round_problem(&Problem::new(&procedural("cones", 32).unwrap(), &options()).unwrap());
    let mut offsets = vec![[0.0; 2]; problem.mesh.node_count()];
    for _ in 0..2 {
        for phase in 0..4 {
            pass(&problem, &mut offsets, phase);
        }
    }
    let offsets = offsets
        .iter()
        .map(|o| [o[0] as f32 as f64, o[1] as f32 as f64])
        .collect();
    (problem, offsets)
}

#[test]
fn one_pass_matches_the_reference_within_the_f32_bound() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (problem, start) = rounded_state();
    let mesh = &problem.mesh;
    let mut backend = GpuPass::new(gpu);
    let (mut over, mut total, mut same_path, mut same_moved) = (0, 0, 0, 0);
    let mut first_divergence = vec![0usize; 33];
    let mut worst = 0.0f64;
    for phase in 0..4 {
        let mut gpu_offsets = start.clone();
        let results = backend
            .run(&problem, &mut gpu_offsets, phase)
            .unwrap()
            .to_vec();
        for (&(x, y), r) in mesh.active_texels(phase).iter().zip(&results) {
            let cpu = descend_texel_traced(&problem, &start, x, y);
            let i = mesh.index(x, y);
            let res = mesh.resolution();
            let diff = ((cpu.offset[0] - gpu_offsets[i][0]) * res[0])
                .hypot((cpu.offset[1] - gpu_offsets[i][1]) * res[1]);
            let bound = step_bound(&problem, &start, x, y);
            worst = worst.max(diff / bound.max(1e-30));
            total += 1;
            over += usize::from(diff > bound);
            same_moved += usize::from(cpu.moved == (r.flags & FLAG_MOVED != 0));
            let steps = (r.flags & STEPS_MASK).min(cpu.search.steps);
            let differ = (cpu.search.path ^ r.path) & ((1u64 << steps) - 1) as u32;
            if differ == 0 {
                same_path += 1;
                first_divergence[32] += 1;
            } else {
                first_divergence[differ.trailing_zeros() as usize] += 1;
            }
        }
    }
    println!(
        "unwarp_pass vs descend_texel, 32² cones, {total} texel updates: {same_path} identical search paths, \
         {same_moved} identical guard decisions, {over} over the derived bound (worst diff/bound {worst:.3})"
    );
    let histogram: Vec<String> = first_divergence
        .iter()
        .enumerate()
        .filter(|(_, &n)| n > 0)
        .map(|(i, n)| {
            if i == 32 {
                format!("never: {n}")
            } else {
                format!("iteration {i}: {n}")
            }
        })
        .collect();
    println!(
        "first iteration where f32 kept the other sub-bracket: {}",
        histogram.join(", ")
    );
    assert_eq!(
        over, 0,
        "{over} of {total} texels beyond the derived f32 bound"
    );
    // The first iterations compare energies far apart (bracket thirds of a texel): f32 must
    // agree there. Before iteration 10 the thirds are ≥ (2/3)^10 ≈ 1.7 % of the bracket apart,
    // where F differs by ≳ 1e-4 F ≫ 2ηF ≈ 3.6e-6 F unless the minimum sits within that distance
    // of the middle — a few texels at most.
    let early: usize = first_divergence[..10].iter().sum();
    assert!(
        early * 20 <= total,
        "{early} of {total} searches diverged before iteration 10"
    );
}

#[test]
fn whole_runs_agree_in_energy_per_sweep_and_area_statistics() {
    let Some(gpu) = gpu_or_skip() else { return };
    let map = procedural("cones", 32).unwrap();
    let opts = UnwarpOptions {
        sweeps: 10,
        ..options()
    };
    let cpu = solve(&map, &opts, |_| {}).unwrap();
    let mut backend = GpuPass::new(gpu);
    let gpu = solve_with(&mut backend, &map, &opts, |_| {}).unwrap();
    let (ec, eg) = (&cpu.fine().energy_per_pass, &gpu.fine().energy_per_pass);
    let passes = ec.len() - 1;
    let totals: Vec<f64> = ec.iter().map(|e| e.total()).collect();
    let mut rows = Vec::new();
    for p in (0..=passes).step_by(4) {
        let rel = (eg[p].total() - ec[p].total()).abs() / ec[p].total();
        rows.push(format!(
            "sweep {}: {:.6} vs {:.6} ({rel:.1e})",
            p / 4,
            ec[p].ratio(5.0),
            eg[p].ratio(5.0)
        ));
        // Each f32 pass q can leave the total at most 2ηE_q away from where f64 leaves it (the
        // search's resolution, bound 1 of `step_bound`): after p passes ≤ 2η Σ_{q<p} E_q
        // (`run_energy_bound`, shared with `reparam crosscheck unwarp`).
        assert!(
            rel <= run_energy_bound(&totals, p),
            "sweep {}: relative energy difference {rel:e}",
            p / 4
        );
    }
    println!("energy ratio per sweep, f64 vs f32:\n{}", rows.join("\n"));
    let res = cpu.problem.mesh.resolution();
    let rms = (cpu
        .offsets
        .iter()
        .zip(&gpu.offsets)
        .map(|(a, b)| ((a[0] - b[0]) * res[0]).powi(2) + ((a[1] - b[1]) * res[1]).powi(2))
        .sum::<f64>()
        / cpu.offsets.len() as f64)
        .sqrt();
    let cv_cpu = coefficient_of_variation(&area_ratios(&cpu.problem, &cpu.offsets));
    let cv_gpu = coefficient_of_variation(&area_ratios(&cpu.problem, &gpu.offsets));
    println!(
        "area-ratio CV f64 {cv_cpu:.5}, f32 {cv_gpu:.5}; rms offset difference {rms:.2e} texels"
    );
    // A triangle's area ratio a/A moves by ≤ 2|Δo| (texels) relatively when a corner moves by
    // |Δo| (edges are ≈ 1 texel); the CV, a normalised rms, then moves by ≤ 2·rms|Δo|·(1 + CV).
    assert!(
        (cv_cpu - cv_gpu).abs() <= area_cv_bound(rms, cv_cpu),
        "CV {cv_cpu} vs {cv_gpu}"
    );
}

#[test]
fn gpu_throughput_on_256_squared() {
    let Some(gpu) = gpu_or_skip() else { return };
    let problem = Problem::new(&procedural("cones", 256).unwrap(), &options()).unwrap();
    let grid = grid_for(&problem);
    let active: usize = grid.phases.iter().map(Vec::len).sum();
    let kernel = UnwarpPassKernel::new(&gpu, grid, &vec![[0.0f32; 2]; 256 * 256]).unwrap();
    kernel.passes(&gpu, &[0]).unwrap(); // warm-up
    let start = Instant::now();
    kernel.passes(&gpu, &[0, 1, 2, 3]).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "unwarp_pass on {}: one sweep of 256² in {:.1} ms, {:.2} M texel updates/s",
        gpu.adapter_summary(),
        seconds * 1e3,
        active as f64 / seconds / 1e6
    );
    let offsets = kernel.offsets(&gpu).unwrap();
    assert!(offsets.iter().all(|o| o[0].is_finite() && o[1].is_finite()));
    assert!(
        offsets.iter().any(|o| *o != [0.0, 0.0]),
        "the sweep moved nothing"
    );
}

/// Bound 1 of `step_bound` measured on F: on a quadratic line function it is the quadratic
/// model's 2√(ηF/F'') (to the bisection's 2⁻⁵⁰ and the doubling scan's 2⁻⁴⁰ of the span), and
/// where F is flat on one side of t* (no quadratic model holds) it reaches the end of the flat
/// part. CPU only.
#[test]
fn indistinguishable_radius_is_the_quadratic_models_on_a_parabola_and_wider_on_a_plateau() {
    let (f0, c, t_star, hi) = (2.5, 40.0, 0.3, 1.0);
    let parabola = |t: f64| f0 + 0.5 * c * (t - t_star) * (t - t_star);
    let level = f0 + 2.0 * ETA * f0;
    let radius = indistinguishable_radius(&parabola, t_star, hi, level);
    let model = 2.0 * (ETA * f0 / c).sqrt();
    assert!((radius / model - 1.0).abs() < 1e-6, "{radius} vs {model}");
    // Flat for 0.2 past t*, then steep: the radius is at least 0.2 (the quadratic model at t*,
    // F'' = c, would say 2√(ηF/c) ≈ 1.2e-4).
    let plateau = |t: f64| {
        if t < t_star {
            parabola(t)
        } else if t < t_star + 0.2 {
            f0
        } else {
            f0 + 1e3 * (t - t_star - 0.2)
        }
    };
    let radius = indistinguishable_radius(&plateau, t_star, hi, level);
    // The exact crossing: 1e3 (t − t* − 0.2) = 2ηF; the bisection ends within 2⁻⁵⁰ of its
    // bracket (≤ 0.7): 1e-15.
    let crossing = 0.2 + 2.0 * ETA * f0 / 1e3;
    assert!((radius - crossing).abs() < 1e-12, "{radius} vs {crossing}");
    // Under the level on the whole bracket: the wider side's span.
    assert_eq!(
        indistinguishable_radius(&|_| f0, t_star, hi, level),
        hi - t_star
    );
}

/// Found by the command fuzzer: a 16² height map (a mutated PNG) on which one texel's f32 step
/// fell 1.14× outside the quadratic model's bound 1; with the interval measured on F the pass
/// comparison passes (`crosscheck unwarp`, exit 0).
#[test]
fn a_line_function_far_from_quadratic_stays_within_the_pass_bound() {
    if gpu_or_skip().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().display().to_string();
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/hostile/unwarp_pass_flat_line.png"
    );
    let (result, stdout) = reparam::cli::run_captured([
        "reparam",
        "crosscheck",
        "unwarp",
        fixture,
        "--sweeps",
        "2",
        "--out",
        &out,
        "--plots",
        &out,
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_slice(&stdout).unwrap();
    let row = &report["adapters"][0]["rows"][0];
    assert_eq!(row["kernel"], "unwarp_pass: offset after one pass");
    assert_eq!(row["verdict"], "pass", "{row}");
    assert_eq!(result.unwrap(), std::process::ExitCode::SUCCESS);
}

/// The run-energy row is judged where the bound's premise held on the first pass (every
/// texel's F within 2ηF of the reference's) and shown, not judged, where it failed (36 of a
/// million texels of `spot_texture.png` as a height map, whose run was 1.6× over on both
/// adapters): the gate, on the cones; the premise itself below.
#[test]
fn the_run_energy_row_is_judged_only_where_its_premise_held() {
    use reparam::crosscheck::row::Verdict;
    use reparam::crosscheck::unwarp::run_rows;
    let Some(gpu) = gpu_or_skip() else { return };
    let options = UnwarpOptions {
        sweeps: 2,
        tolerance: None,
        coarse_moves: 0,
        ..Default::default()
    };
    let cones = procedural("cones", 16).unwrap();
    let verdict = |violations: usize| {
        let rows = run_rows(&gpu, "cones", &cones, &options, violations).unwrap();
        (rows[0].verdict, rows[0].note.clone())
    };
    let (held, note) = verdict(0);
    assert_eq!(held, Verdict::Pass, "{note}");
    let (failed, note) = verdict(36);
    assert_eq!(failed, Verdict::Info, "{note}");
    assert!(note.contains("premise") && note.contains("36"), "{note}");
}

/// `within_run_premise`: a step to the reference's own point holds it, one half a texel away
/// from it does not (F moves by far more than 2ηF). CPU only.
#[test]
fn the_run_premise_rejects_a_step_that_lands_elsewhere() {
    use reparam::crosscheck::unwarp::within_run_premise;
    let (problem, start) = rounded_state();
    let (x, y) = problem.mesh.active_texels(0)[5];
    let cpu = descend_texel_traced(&problem, &start, x, y).offset;
    assert!(within_run_premise(&problem, &start, (x, y), cpu, cpu));
    let half = 0.5 / problem.mesh.width as f64;
    let away = [cpu[0] + half, cpu[1]];
    assert!(!within_run_premise(&problem, &start, (x, y), cpu, away));
}
