//! unwarp benchmarks (issue #4):
//!
//! - `unwarp_pass`: one phase pass (active texel updates/s) at 256² and 1024², f64 CPU in rayon
//!   pools of 1 and 2 threads, and the f32 GPU kernel (offsets kept on the GPU, one sync per
//!   pass);
//! - time to a target energy on the 64² and 512² cones (s = 0.08, θ = 5), single level vs
//!   coarse-to-fine vs coarse moves vs both: printed once, not sampled by criterion (a whole
//!   solve is seconds). Targets: energy ratio 1.10 (the notes' figure) and the single-level
//!   240-pass energy.
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
/// clock includes the coarse levels, the coarse moves and the per-pass energy evaluations.
fn timed_solve(map: &reparam::unwarp::HeightMap, opts: &UnwarpOptions) -> Vec<(f64, f64)> {
    let start = Instant::now();
    let mut stamps = Vec::new();
    solve(map, opts, |p| {
        if p.level == 0 {
            stamps.push((start.elapsed().as_secs_f64(), p.energy_ratio));
        }
    })
    .unwrap();
    stamps
}

/// The first (time, finest-level sweeps) at which the ratio is ≤ `target`.
fn time_to(stamps: &[(f64, f64)], target: f64) -> Option<(f64, usize)> {
    stamps
        .iter()
        .enumerate()
        .find(|(_, s)| s.1 <= target)
        .map(|(i, s)| (s.0, i + 1))
}

/// The schemes compared at one size: the paper's single level; coarse-to-fine alone (nested
/// iteration: `levels` levels, `coarse_sweeps` sweeps on each coarse level); coarse moves alone
/// (`coarse_moves` scales at the end of every sweep); and both, with 2 sweeps per coarse level.
fn schemes(
    levels: usize,
    coarse_sweeps: usize,
    coarse_moves: usize,
) -> [(String, UnwarpOptions); 4] {
    let single = UnwarpOptions {
        sweeps: 60,
        ..options()
    };
    [
        ("single level".to_string(), single.clone()),
        (
            format!("coarse-to-fine {levels} levels × {coarse_sweeps} coarse sweeps"),
            UnwarpOptions {
                levels,
                coarse_sweeps,
                ..single.clone()
            },
        ),
        (
            format!("coarse moves r = 2…{}", 1 << coarse_moves),
            UnwarpOptions {
                coarse_moves,
                ..single.clone()
            },
        ),
        (
            format!(
                "coarse-to-fine {levels} levels × 2 coarse sweeps + coarse moves r = 2…{}",
                1 << coarse_moves
            ),
            UnwarpOptions {
                levels,
                coarse_sweeps: 2,
                coarse_moves,
                ..single
            },
        ),
    ]
}

fn report_time_to_energy(_: &mut Criterion) {
    for (size, levels, coarse_sweeps, coarse_moves) in [(64usize, 3, 15, 2), (512, 4, 10, 3)] {
        let map = procedural("cones", size).unwrap();
        let runs: Vec<(String, Vec<(f64, f64)>)> = schemes(levels, coarse_sweeps, coarse_moves)
            .into_iter()
            .map(|(name, opts)| {
                let stamps = timed_solve(&map, &opts);
                (name, stamps)
            })
            .collect();
        let single = &runs[0].1;
        let target240 = single[59].1;
        for (name, target) in [
            ("ratio 1.10", 1.10),
            ("single-level 240-pass ratio", target240),
        ] {
            let reference = time_to(single, target).map(|t| t.0);
            for (scheme, stamps) in &runs {
                let line = match time_to(stamps, target) {
                    Some((t, sweeps)) => format!(
                        "{t:.3} s, {sweeps} finest-level sweeps{}",
                        reference.map_or(String::new(), |r| format!(", speed-up {:.1}×", r / t))
                    ),
                    None => format!("not reached in 60 sweeps (ratio {:.4})", stamps[59].1),
                };
                println!("unwarp {size}² cones, target {name} ({target:.4}), {scheme}: {line}");
            }
        }
    }
}

criterion_group!(benches, bench_pass, report_time_to_energy);
criterion_main!(benches);
