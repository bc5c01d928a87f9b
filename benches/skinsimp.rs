//! skinsimp benchmarks (issue #6): simplification time of the bending tube
//! (`skinsimp::tube`) to 10 % of its vertices
//!
//! - vs training pose count (1, 8, 32; 10k triangles; full method), criterion;
//! - vs triangle count (100k and 1M triangles, 8 poses, full method) and against
//!   meshoptimizer's ≈ 1.7 M triangles/s (1 pose, weight optimisation off: the rest-pose
//!   method, single-threaded) at 100k and 1M triangles: single timed runs printed once (ten
//!   criterion samples of these take many minutes on this 2-core machine), the single-threaded
//!   rest-pose runs with both schedules (exact greedy, the default, and meshoptimizer-style
//!   passes, [`Schedule`]). The 1M full-method run only with `SKINSIMP_BENCH_1M_FULL=1`.
//!
//! With `--features meshopt-comparison`, the single-threaded rows are followed by meshoptimizer's
//! own `meshopt_simplify` (C++, the `meshopt` crate) on the same welded mesh, f32 positions, to
//! 10 % of the triangles, timed in the same way at the same moment: a ratio that does not
//! depend on how fast this (shared, noisy) machine happens to be.
//!
//! Run: `cargo bench --bench skinsimp` (`-- nothing` skips the criterion groups).

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use reparam::skinsimp::poses::{select_poses, skinned_input, PoseSelection};
use reparam::skinsimp::tube::skinned_tube;
use reparam::skinsimp::{simplify, Input, Method, Options, Schedule};

/// Single-threaded runs per schedule in the meshoptimizer comparison (the first is cold).
const WARM_RUNS: usize = 3;

/// (segments, rings): 2·s·(r + 1) = 10 000, 99 856, 1 000 000 triangles.
const SIZES: [(usize, usize); 3] = [(50, 99), (158, 315), (500, 999)];

/// The tube of `size` with `poses` training poses (uniform times of the clip).
fn input(size: (usize, usize), poses: usize) -> Input {
    let model = skinned_tube(size.0, size.1);
    let sets = select_poses(&model, &PoseSelection::Uniform(poses)).expect("poses");
    skinned_input(&model, &sets.training).expect("input")
}

fn options(input: &Input, method: Method) -> Options {
    Options {
        method,
        target_vertices: input.mesh.positions.len() / 10,
        ..Options::default()
    }
}

fn bench_poses(c: &mut Criterion) {
    let mut group = c.benchmark_group("skinsimp_full_10k_triangles");
    group.sample_size(10);
    for poses in [1, 8, 32] {
        let input = input(SIZES[0], poses);
        let o = options(&input, Method::Full);
        group.bench_function(format!("{poses}_poses"), |b| {
            b.iter(|| black_box(simplify(&input, &o).expect("simplify")))
        });
    }
    group.finish();
}

/// The wall times of [`WARM_RUNS`] calls of `run`: the first (cold) and the best.
fn first_and_best(mut run: impl FnMut()) -> (f64, f64) {
    let seconds: Vec<f64> = (0..WARM_RUNS)
        .map(|_| {
            let start = Instant::now();
            run();
            start.elapsed().as_secs_f64()
        })
        .collect();
    (seconds[0], seconds.iter().copied().fold(f64::MAX, f64::min))
}

/// Millions of input triangles per second.
fn rate(triangles: usize, seconds: f64) -> f64 {
    triangles as f64 / seconds / 1e6
}

/// Single timed runs of the large cases, printed with triangles per second.
fn single_runs(_: &mut Criterion) {
    let mut cases = vec![
        (SIZES[1], 8, Method::Full),
        (SIZES[1], 1, Method::Rest),
        (SIZES[2], 1, Method::Rest),
    ];
    if std::env::var_os("SKINSIMP_BENCH_1M_FULL").is_some() {
        cases.push((SIZES[2], 8, Method::Full));
    }
    for (size, poses, method) in cases {
        let input = input(size, poses);
        let o = options(&input, method);
        let threads = rayon::current_num_threads();
        let start = Instant::now();
        let h = simplify(&input, &o).expect("simplify");
        let s = start.elapsed().as_secs_f64();
        let triangles = input.mesh.faces.len();
        println!(
            "skinsimp single run: {triangles} triangles, {poses} pose(s), {} method, {} → {} vertices: {s:.2} s ({:.3} M triangles/s, {threads} rayon threads)",
            method.name(),
            h.input_vertices(),
            h.input_vertices() - h.records.len(),
            rate(triangles, s)
        );
        // Single-threaded, for the meshoptimizer comparison, with both schedules.
        if method == Method::Rest {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .expect("pool");
            // The first run pays the kernel's first touch of every page the simplifier
            // allocates; the next ones reuse the freed memory, as a benchmark loop (and
            // meshoptimizer's figure) does. Both are printed.
            for schedule in [Schedule::Greedy, Schedule::Passes] {
                let o = Options { schedule, ..o };
                let (first, best) = first_and_best(|| {
                    black_box(pool.install(|| simplify(&input, &o).expect("simplify")));
                });
                let rate = |s: f64| rate(triangles, s);
                println!(
                    "skinsimp single run, 1 thread: {triangles} triangles, rest method, {schedule:?} schedule: first run {first:.2} s ({:.3} M triangles/s), best of {WARM_RUNS} {best:.2} s ({:.3} M triangles/s); meshoptimizer ≈ 1.7, target ≥ 0.34",
                    rate(first),
                    rate(best)
                );
            }
            #[cfg(feature = "meshopt-comparison")]
            meshopt_runs(&input);
        }
    }
}

/// meshoptimizer's `meshopt_simplify` on the same mesh (positions rounded to f32, the UV seams'
/// split vertices as its index buffer has them) to 10 % of its triangles, no target error
/// (1.0: the whole extent), single-threaded as it is: first run and best of [`WARM_RUNS`].
#[cfg(feature = "meshopt-comparison")]
fn meshopt_runs(input: &Input) {
    let bytes: Vec<u8> = input
        .mesh
        .positions
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .flat_map(f32::to_le_bytes)
        .collect();
    let vertices = meshopt::VertexDataAdapter::new(&bytes, 12, 0).expect("vertex data");
    let indices: Vec<u32> = input.mesh.faces.iter().flatten().copied().collect();
    let triangles = input.mesh.faces.len();
    let mut kept = 0;
    let (first, best) = first_and_best(|| {
        let out = meshopt::simplify(
            &indices,
            &vertices,
            indices.len() / 10,
            1.0,
            meshopt::SimplifyOptions::empty(),
            None,
        );
        kept = out.len() / 3;
    });
    let rate = |s: f64| rate(triangles, s);
    println!(
        "meshoptimizer's meshopt_simplify (meshopt crate), 1 thread, same mesh: {triangles} → {kept} triangles: first run {first:.3} s ({:.3} M triangles/s), best of {WARM_RUNS} {best:.3} s ({:.3} M triangles/s)",
        rate(first),
        rate(best)
    );
}

/// GPU group (issue #6, GPU section): on the ≈ 100k-triangle tube with 8 training poses,
/// normalised to the unit box and rounded to f32, the three kernel steps against the f64 CPU
/// reference (rayon) of the same work: LBS of V × P positions; the per-pose source quadrics and
/// their per-vertex sums; the position step and cost of every candidate (each edge with each
/// endpoint's weights). GPU figures include the host-side conversion to the kernels' f32
/// layout, upload, dispatch and readback.
#[cfg(feature = "gpu")]
fn bench_gpu(c: &mut Criterion) {
    use rayon::prelude::*;
    use reparam::skinsimp::gpu::{
        endpoint_candidates, normalise, plane_quadrics_f64, position_given_weights_f64,
        quadric_input, round_input, skin_f64, vertex_quadrics_f64, CostData, SkinsimpKernels,
    };
    let Ok(gpu) = reparam_gpu::Gpu::new() else {
        println!("skinsimp GPU group skipped: no GPU adapter");
        return;
    };
    println!("skinsimp GPU group on {}", gpu.adapter_summary());
    let poses = 8;
    let input = round_input(&normalise(&input(SIZES[1], poses)).0);
    let kernels = SkinsimpKernels::new(gpu).expect("kernels");
    let (weight, max_condition) = (10.0, 1e10);
    let sources = quadric_input(&input.mesh, poses, weight).expect("sources");
    let posed = skin_f64(&input).expect("skin");
    let plane = plane_quadrics_f64(&posed, &sources, weight);
    let vertex = vertex_quadrics_f64(&plane, &sources);
    let data = CostData::new(&input, vertex)
        .expect("cost data")
        .rounded_quadrics();
    let candidates = endpoint_candidates(&input.mesh);
    println!(
        "skinsimp GPU group: {} triangles, {} vertices × {poses} poses, {} quadric sources, {} candidates",
        input.mesh.faces.len(),
        input.mesh.positions.len(),
        sources.sources.len(),
        candidates.len()
    );
    let mut group = c.benchmark_group("skinsimp_gpu_100k_triangles_8_poses");
    group.sample_size(10);
    group.bench_function("lbs_cpu_f64", |b| {
        b.iter(|| black_box(skin_f64(&input).expect("skin")))
    });
    group.bench_function("lbs_gpu_f32", |b| {
        b.iter(|| black_box(kernels.skin(&input).expect("skin")))
    });
    group.bench_function("quadrics_cpu_f64", |b| {
        b.iter(|| {
            let plane = plane_quadrics_f64(&posed, &sources, weight);
            black_box(vertex_quadrics_f64(&plane, &sources))
        })
    });
    group.bench_function("quadrics_gpu_f32", |b| {
        b.iter(|| black_box(kernels.quadrics(&sources, &posed).expect("quadrics")))
    });
    group.bench_function("costs_cpu_f64", |b| {
        b.iter(|| {
            black_box(
                candidates
                    .par_iter()
                    .map(|c| position_given_weights_f64(&data, c, max_condition))
                    .collect::<Vec<_>>(),
            )
        })
    });
    group.bench_function("costs_gpu_f32", |b| {
        b.iter(|| {
            black_box(
                kernels
                    .costs(&data, &candidates, max_condition)
                    .expect("costs"),
            )
        })
    });
    group.finish();
}

#[cfg(not(feature = "gpu"))]
fn bench_gpu(_: &mut Criterion) {}

criterion_group!(benches, bench_poses, single_runs, bench_gpu);
criterion_main!(benches);
