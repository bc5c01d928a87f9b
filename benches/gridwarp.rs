//! gridwarp benchmarks (issue #3): per-frame solve time at the paper's problem sizes (seed
//! Table 1), with evaluation and Jacobian counts printed once per case.
//!
//! - Axis-aligned: 14, 24 and 38 unknowns (M + N − 4 with uniform 9×9, 14×14, 21×21 lines) on
//!   the fixed-plane stretch scene (two rigid discs, 128² fields), f64 CPU and f32 GPU objective.
//!   The CPU rows (`gridwarp_aa_frame`) measure what a sequence pays per frame: the solve on
//!   rest samples built beforehand ([`RestSamples`], once per sequence, as
//!   `solve_sequence` does; the paper's preprocessing). Their one-off cost is measured
//!   separately (`gridwarp_aa_rest_samples`), and the printed line also gives the time of one
//!   `solve_frame` that builds them itself.
//! - Non-axis-aligned: 48, 192 and 288 unknowns ((M−2)(N−2)·2, fixed border) on the saddle,
//!   likewise on rest samples built beforehand ([`NaaRestSamples`], once per sequence, as
//!   `solve_naa_sequence` does), their one-off cost measured separately
//!   (`gridwarp_naa_rest_samples`) and given with one `solve_naa_frame` in the printed line.
//!   The frame's own preparation (interleaving its six J_D fields) stays in the rows.
//! - Non-axis-aligned again with the second-order model JᵀJ + Σ r∇²r (`NaaModel::Newton`,
//!   `gridwarp_naa_frame_newton`) and with the per-iteration choice between the two models
//!   (`NaaModel::Adaptive`, `gridwarp_naa_frame_adaptive`), 8×8 samples.
//! - The plain path (`gridwarp::plain`, the formula sample by sample, no lanes, no SIMD, one
//!   thread) beside the fast one, at 8×8 samples, on the same frames and rest samples built
//!   beforehand likewise: `gridwarp_aa_frame_plain` (14, 24, 38 unknowns) and
//!   `gridwarp_naa_frame_plain` (Gauss–Newton, 48, 192, 288; Newton, 48): what the clarity
//!   costs. The solves reach the same minima (`tests/gridwarp_plain.rs`); at aa 38 the fast
//!   solve takes one more step than the plain one at the end (6 against 5, a change of F of
//!   1.6e-15 relative), elsewhere the same steps.
//! - Each at 8×8 midpoint samples per cell (the default) and 4×4. The paper does not give its
//!   sample count; the printed line gives the final energy re-evaluated with 8×8 samples so the
//!   two can be compared at equal quality.
//!
//! - The printed counts are LM's: energy evaluations (one per trial point) and Jacobian
//!   evaluations (x₀ and accepted points). The solves hand the energy to LM through
//!   `lm::Speculative` (a trial's normal equations computed with its energy while trials are
//!   being accepted), so the passes over the samples are fewer than their sum: at aa 38 3
//!   energy-only + 7 normal-equation passes for 9 + 6, at naa 48 Newton 1 + 9 for 9 + 8, at
//!   naa 48 Gauss–Newton 4 + 22 for 23 + 19.
//!
//! Run: `cargo bench --bench gridwarp`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use reparam::gridwarp::energy_naa::{
    DeformedJacobian, NaaEnergy, NaaModel, NaaRestSamples, VertexGrid,
};
use reparam::gridwarp::plain::{rest_samples, PlainAaEnergy, PlainNaaEnergy};
use reparam::gridwarp::scene::{analytic_scene, disc_rigidity, partials_of, plane_stretch};
use reparam::gridwarp::solve::{minimize_frame, minimize_naa_frame};
use reparam::gridwarp::{
    solve_frame, solve_frame_with_rest_samples, solve_naa_frame, solve_naa_frame_with_rest_samples,
    AaEnergy, Grid, RestSamples, SolveOptions,
};
use reparam::lm::{LmReport, Residuals};

/// A uniform m×n-line grid has m + n − 4 unknowns: 9+9 → 14, 14+14 → 24, 21+21 → 38.
const SIZES: [(usize, usize); 3] = [(9, 9), (14, 14), (21, 21)];
/// (M−2)(N−2)·2 unknowns: 6×8 → 48, 10×14 → 192, 14×14 → 288.
const NAA_SIZES: [(usize, usize); 3] = [(6, 8), (10, 14), (14, 14)];
/// Midpoint samples per cell and axis.
const SAMPLES: [usize; 2] = [8, 4];

fn options(samples: usize) -> SolveOptions {
    SolveOptions {
        samples: (samples, samples),
        ..SolveOptions::default()
    }
}

fn print_once(what: &str, lm: &LmReport, rest_energy: f64, energy_8x8: f64) {
    println!(
        "{what}: {} iterations, {} energy + {} Jacobian evaluations, stop {:?}, E {:.4e} → {:.4e} \
         (final lines judged with 8×8 samples: {:.4e})",
        lm.iterations,
        lm.energy_evaluations,
        lm.jacobian_evaluations,
        lm.stop,
        rest_energy,
        lm.energy,
        energy_8x8
    );
}

fn bench_aa(c: &mut Criterion) {
    let rigidity = disc_rigidity(128, &[(0.3, 0.35, 0.12), (0.7, 0.6, 0.15)], 0.1);
    let scene = plane_stretch(128, 4, 2.0, rigidity);
    let frame = &scene.frames[3];
    let mut group = c.benchmark_group("gridwarp_aa_frame");
    group.sample_size(20);
    for samples in SAMPLES {
        for (m, n) in SIZES {
            let grid = Grid::uniform(m, n);
            let options = options(samples);
            let rest_samples = RestSamples::new(&scene.rest, &grid, samples, samples);
            let solve = || {
                solve_frame_with_rest_samples(&rest_samples, frame, &grid, &grid, (0, 1), &options)
            };
            let once = solve().unwrap();
            let judged = AaEnergy::new(&scene.rest, &grid, frame, 8, 8).energy(&once.lm.x);
            let name = format!("{}_unknowns_{samples}x{samples}_samples", grid.unknowns());
            print_once(&format!("aa {name}"), &once.lm, once.rest_energy, judged);
            let alone = solve_frame(&scene.rest, &grid, frame, &grid, &grid, (0, 1), &options);
            println!(
                "  (one solve_frame building its rest samples itself: {:.3} ms)",
                alone.unwrap().seconds * 1e3
            );
            group.bench_function(name, |b| b.iter(|| black_box(solve().unwrap())));
        }
    }
    group.finish();
    // The same solves on the plain path (8×8 samples).
    let mut group = c.benchmark_group("gridwarp_aa_frame_plain");
    group.sample_size(10);
    for (m, n) in SIZES {
        let grid = Grid::uniform(m, n);
        let options = options(8);
        let samples = rest_samples(&scene.rest, &grid, 8, 8);
        let solve = || {
            let energy = PlainAaEnergy::from_rest_samples(&grid, (8, 8), &samples, frame)?;
            minimize_frame(
                energy,
                &grid,
                &grid,
                &grid,
                (0, 1),
                &options,
                Instant::now(),
            )
        };
        let once = solve().unwrap();
        let name = format!("{}_unknowns_8x8_samples", grid.unknowns());
        print_once(
            &format!("aa plain {name}"),
            &once.lm,
            once.rest_energy,
            once.lm.energy,
        );
        group.bench_function(name, |b| b.iter(|| black_box(solve().unwrap())));
    }
    group.finish();
    // The once-per-sequence precomputation the rows above leave out.
    let mut group = c.benchmark_group("gridwarp_aa_rest_samples");
    group.sample_size(20);
    for samples in SAMPLES {
        for (m, n) in SIZES {
            let grid = Grid::uniform(m, n);
            let name = format!("{}_unknowns_{samples}x{samples}_samples", grid.unknowns());
            group.bench_function(name, |b| {
                b.iter(|| black_box(RestSamples::new(&scene.rest, &grid, samples, samples)))
            });
        }
    }
    group.finish();
}

/// The same solves with the objective evaluated by the f32 `gridwarp_aa_cell` kernel (the
/// paper's hybrid: LM on the CPU in f64). The kernel is compiled once, as in a sequence; each
/// solve uploads its frame's data once.
#[cfg(feature = "gpu")]
fn bench_aa_gpu(c: &mut Criterion) {
    use reparam::gridwarp::gpu::solve_frame_gpu;
    use reparam_gpu::gridwarp::AaKernel;
    let Some(gpu) = reparam_gpu::gpu_or_skip() else {
        return;
    };
    println!("GPU: {}", gpu.adapter_summary());
    let kernel = AaKernel::new(&gpu).unwrap();
    let rigidity = disc_rigidity(128, &[(0.3, 0.35, 0.12), (0.7, 0.6, 0.15)], 0.1);
    let scene = plane_stretch(128, 4, 2.0, rigidity);
    let frame = &scene.frames[3];
    let mut group = c.benchmark_group("gridwarp_aa_frame_gpu_objective");
    group.sample_size(10);
    for (m, n) in SIZES {
        let grid = Grid::uniform(m, n);
        let options = options(8);
        let solve = || {
            solve_frame_gpu(
                &gpu,
                &kernel,
                &scene.rest,
                &grid,
                frame,
                &grid,
                &grid,
                (0, 1),
                &options,
            )
        };
        let once = solve().unwrap();
        let judged = AaEnergy::new(&scene.rest, &grid, frame, 8, 8).energy(&once.lm.x);
        let name = format!("{}_unknowns_8x8_samples", grid.unknowns());
        print_once(
            &format!("aa gpu {name}"),
            &once.lm,
            once.rest_energy,
            judged,
        );
        group.bench_function(name, |b| b.iter(|| black_box(solve().unwrap())));
    }
    group.finish();
}

#[cfg(not(feature = "gpu"))]
fn bench_aa_gpu(_: &mut Criterion) {}

fn bench_naa(c: &mut Criterion) {
    let scene = analytic_scene("saddle", 4).unwrap();
    let fields = scene.fields(128);
    let surface = &scene.frames[3];
    let deformed = DeformedJacobian::from_partials(128, |s, t| partials_of(&**surface, s, t));
    // Gauss–Newton (the paper's model) at both sample counts; the second-order model
    // JᵀJ + Σ r∇²r (`NaaModel::Newton`) and the per-iteration choice between the two
    // (`NaaModel::Adaptive`) at 8×8.
    let runs: [(&str, NaaModel, &[usize]); 3] = [
        ("gridwarp_naa_frame", NaaModel::GaussNewton, &SAMPLES),
        ("gridwarp_naa_frame_newton", NaaModel::Newton, &[8]),
        ("gridwarp_naa_frame_adaptive", NaaModel::Adaptive, &[8]),
    ];
    for (group_name, model, sample_counts) in runs {
        let mut group = c.benchmark_group(group_name);
        group.sample_size(10);
        for &samples in sample_counts {
            for (m, n) in NAA_SIZES {
                let grid = Grid::uniform(m, n);
                let vertices = VertexGrid::from_grid(&grid);
                let options = SolveOptions {
                    naa_model: model,
                    ..options(samples)
                };
                let rest_samples = NaaRestSamples::new(&fields.rest, &grid, samples, samples);
                let solve = || {
                    solve_naa_frame_with_rest_samples(
                        &rest_samples,
                        &deformed,
                        &vertices,
                        &vertices,
                        (0, 1),
                        &options,
                    )
                };
                let once = solve().unwrap();
                let judged =
                    NaaEnergy::new(&fields.rest, &grid, &deformed, 8, 8).energy(&once.lm.x);
                let name = format!("{}_unknowns_{samples}x{samples}_samples", once.lm.x.len());
                print_once(
                    &format!("naa {model:?} {name}"),
                    &once.lm,
                    once.rest_energy,
                    judged,
                );
                let alone = solve_naa_frame(
                    &fields.rest,
                    &grid,
                    &deformed,
                    &vertices,
                    &vertices,
                    (0, 1),
                    &options,
                );
                println!(
                    "  (one solve_naa_frame building its rest samples itself: {:.3} ms)",
                    alone.unwrap().seconds * 1e3
                );
                group.bench_function(name, |b| b.iter(|| black_box(solve().unwrap())));
            }
        }
        group.finish();
    }
    // The same solves on the plain path (8×8 samples): Gauss–Newton at every size, Newton at 48.
    let runs = [
        (
            "gridwarp_naa_frame_plain",
            NaaModel::GaussNewton,
            NAA_SIZES.len(),
        ),
        ("gridwarp_naa_frame_newton_plain", NaaModel::Newton, 1),
    ];
    for (group_name, model, sizes) in runs {
        let mut group = c.benchmark_group(group_name);
        group.sample_size(10);
        for &(m, n) in &NAA_SIZES[..sizes] {
            let grid = Grid::uniform(m, n);
            let vertices = VertexGrid::from_grid(&grid);
            let options = SolveOptions {
                naa_model: model,
                ..options(8)
            };
            let samples = rest_samples(&fields.rest, &grid, 8, 8);
            let solve = || {
                let energy = PlainNaaEnergy::from_rest_samples(&grid, (8, 8), &samples, &deformed)?
                    .with_model(model);
                let start = Instant::now();
                minimize_naa_frame(
                    energy,
                    &vertices,
                    &vertices,
                    &vertices,
                    (0, 1),
                    &options,
                    start,
                )
            };
            let once = solve().unwrap();
            let name = format!("{}_unknowns_8x8_samples", once.lm.x.len());
            print_once(
                &format!("naa plain {model:?} {name}"),
                &once.lm,
                once.rest_energy,
                once.lm.energy,
            );
            group.bench_function(name, |b| b.iter(|| black_box(solve().unwrap())));
        }
        group.finish();
    }
    // The once-per-sequence precomputation the rows above leave out.
    let mut group = c.benchmark_group("gridwarp_naa_rest_samples");
    group.sample_size(20);
    for samples in SAMPLES {
        for (m, n) in NAA_SIZES {
            let grid = Grid::uniform(m, n);
            let name = format!(
                "{}_unknowns_{samples}x{samples}_samples",
                (m - 2) * (n - 2) * 2
            );
            group.bench_function(name, |b| {
                b.iter(|| black_box(NaaRestSamples::new(&fields.rest, &grid, samples, samples)))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench_aa, bench_aa_gpu, bench_naa);
criterion_main!(benches);
