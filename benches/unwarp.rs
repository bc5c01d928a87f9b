//! unwarp benchmarks (issue #4):
//!
//! - `unwarp_pass`: one phase pass (active texel updates/s) at 256² and 1024², f64 CPU in rayon
//!   pools of 1 and 2 threads, and the f32 GPU kernel (offsets kept on the GPU, one sync per
//!   pass);
//! - time to a target energy, single level vs coarse-to-fine, on the 64² and 512² cones
//!   (s = 0.08, θ = 5): printed once, not sampled by criterion (a whole solve is seconds).
//!   Targets: energy ratio 1.10 (the notes' figure) and the single-level 240-pass energy.
//!
//! Run: `cargo bench --bench unwarp`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use reparam::unwarp::pass::pass;
use reparam::unwarp::{procedural, solve, Problem, UnwarpOptions};

fn options() -> UnwarpOptions {
    UnwarpOptions {
        scale: 0.08,
        ..Default::default()
    }
}

fn bench_pass(c: &mut Criterion) {
    let mut group = c.benchmark_group("unwarp_pass");
    group.sample_size(10);
    for size in [256usize, 1024] {
        let problem = Problem::new(&procedural("cones", size).unwrap(), &options()).unwrap();
        let active = problem.mesh.active_texels(0).len();
        group.throughput(Throughput::Elements(active as u64));
        for threads in [1usize, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut offsets = vec![[0.0; 2]; problem.mesh.node_count()];
            let mut phase = 0;
            group.bench_function(format!("f64_{size}_{threads}_threads"), |b| {
                b.iter(|| {
                    pool.install(|| black_box(pass(&problem, &mut offsets, phase)));
                    phase = (phase + 1) % 4;
                })
            });
        }
        #[cfg(feature = "gpu")]
        bench_gpu_pass(&mut group, &problem, size);
    }
    group.finish();
}

#[cfg(feature = "gpu")]
fn bench_gpu_pass(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    problem: &Problem,
    size: usize,
) {
    use reparam::unwarp::gpu::grid_for;
    use reparam_gpu::unwarp::UnwarpPassKernel;
    let Ok(gpu) = reparam_gpu::Gpu::new() else {
        println!("unwarp_pass f32: skipped: no GPU adapter");
        return;
    };
    println!("unwarp_pass f32 on {}", gpu.adapter_summary());
    let kernel =
        UnwarpPassKernel::new(&gpu, grid_for(problem), &vec![[0.0f32; 2]; size * size]).unwrap();
    let mut phase = 0;
    group.bench_function(format!("f32_gpu_{size}"), |b| {
        b.iter(|| {
            kernel.passes(&gpu, &[phase]).unwrap();
            phase = (phase + 1) % 4;
        })
    });
}

/// Solve and time-stamp every finest-level sweep: (seconds since the start, energy ratio). The
/// clock includes the coarse levels and the per-pass energy evaluations. Also returns the
/// coarse levels' work in finest-pass equivalents (passes × texels / finest texels).
fn timed_solve(map: &reparam::unwarp::HeightMap, opts: &UnwarpOptions) -> (Vec<(f64, f64)>, f64) {
    let start = Instant::now();
    let mut stamps = Vec::new();
    let solution = solve(map, opts, |p| {
        if p.level == 0 {
            stamps.push((start.elapsed().as_secs_f64(), p.energy_ratio));
        }
    })
    .unwrap();
    let fine = solution.fine();
    let texels = (fine.width * fine.height) as f64;
    let coarse_work = solution.levels[..solution.levels.len() - 1]
        .iter()
        .map(|l| l.passes as f64 * (l.width * l.height) as f64 / texels)
        .sum();
    (stamps, coarse_work)
}

/// Finest-pass equivalents until the ratio is ≤ `target`: coarse work + 4 × sweeps.
fn work_to(stamps: &[(f64, f64)], coarse_work: f64, target: f64) -> Option<f64> {
    stamps
        .iter()
        .position(|s| s.1 <= target)
        .map(|i| coarse_work + 4.0 * (i + 1) as f64)
}

/// The first time-stamp at which the ratio is ≤ `target`.
fn time_to(stamps: &[(f64, f64)], target: f64) -> Option<f64> {
    stamps.iter().find(|s| s.1 <= target).map(|s| s.0)
}

fn report_time_to_energy(_: &mut Criterion) {
    for (size, c2f_levels, c2f_sweeps) in [(64usize, 3usize, 15usize), (512, 4, 10)] {
        let map = procedural("cones", size).unwrap();
        let single = UnwarpOptions {
            sweeps: 60,
            ..options()
        };
        let c2f = UnwarpOptions {
            levels: c2f_levels,
            coarse_sweeps: c2f_sweeps,
            ..single.clone()
        };
        let ((a, wa), (b, wb)) = (timed_solve(&map, &single), timed_solve(&map, &c2f));
        let target240 = a[59].1;
        for (name, target) in [
            ("ratio 1.10", 1.10),
            ("single-level 240-pass ratio", target240),
        ] {
            let (ta, tb) = (time_to(&a, target), time_to(&b, target));
            let work = |w: Option<f64>| w.map_or("never".to_string(), |w| format!("{w:.0}"));
            let show = |t: Option<f64>| t.map_or("never".to_string(), |t| format!("{t:.3} s"));
            let speedup = match (ta, tb) {
                (Some(x), Some(y)) => format!("{:.1}×", x / y),
                _ => "n/a".into(),
            };
            println!(
                "unwarp {size}² cones, target {name} ({target:.4}): single level {} (after 60 sweeps {:.4}), \
                 coarse-to-fine {c2f_levels} levels × {c2f_sweeps} coarse sweeps {} (after 60 sweeps {:.4}), speed-up {speedup}; \
                 work in finest-pass equivalents {} vs {}",
                show(ta),
                a[59].1,
                show(tb),
                b[59].1,
                work(work_to(&a, wa, target)),
                work(work_to(&b, wb, target)),
            );
        }
    }
}

criterion_group!(benches, bench_pass, report_time_to_energy);
criterion_main!(benches);
