//! skinsimp benchmarks (issue #6): simplification time of the bending tube
//! (`skinsimp::tube`) to 10 % of its vertices
//!
//! - vs training pose count (1, 8, 32; 10k triangles; full method), criterion;
//! - vs triangle count (100k and 1M triangles, 8 poses, full method) and against
//!   meshoptimizer's ≈ 1.7 M triangles/s (1 pose, weight optimisation off: the rest-pose
//!   method, single-threaded) at 100k and 1M triangles: single timed runs printed once (ten
//!   criterion samples of these take many minutes on this 2-core machine). The 1M full-method
//!   run only with `SKINSIMP_BENCH_1M_FULL=1`.
//!
//! Run: `cargo bench --bench skinsimp`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use reparam::skinsimp::poses::{select_poses, skinned_input, PoseSelection};
use reparam::skinsimp::tube::skinned_tube;
use reparam::skinsimp::{simplify, Input, Method, Options};

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
            triangles as f64 / s / 1e6
        );
        // Single-threaded, for the meshoptimizer comparison.
        if method == Method::Rest {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .expect("pool");
            let start = Instant::now();
            black_box(pool.install(|| simplify(&input, &o).expect("simplify")));
            let s = start.elapsed().as_secs_f64();
            println!(
                "skinsimp single run, 1 thread: {triangles} triangles, rest method: {s:.2} s ({:.3} M triangles/s; meshoptimizer ≈ 1.7)",
                triangles as f64 / s / 1e6
            );
        }
    }
}

criterion_group!(benches, bench_poses, single_runs);
criterion_main!(benches);
