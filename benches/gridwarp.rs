//! gridwarp benchmarks (issue #3): per-frame axis-aligned solve time at the paper's problem
//! sizes (Table 1: 14, 24 and 38 unknowns), with evaluation and Jacobian counts printed once.
//! The non-axis-aligned variant and the GPU objective are not implemented yet.
//!
//! Run: `cargo bench --bench gridwarp`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use reparam::gridwarp::scene::{disc_rigidity, plane_stretch};
use reparam::gridwarp::{solve_frame, Grid, SolveOptions};

/// A uniform m×n-line grid has m + n − 4 unknowns: 9+9 → 14, 14+14 → 24, 21+21 → 38.
const SIZES: [(usize, usize); 3] = [(9, 9), (14, 14), (21, 21)];

fn bench_aa(c: &mut Criterion) {
    let rigidity = disc_rigidity(128, &[(0.3, 0.35, 0.12), (0.7, 0.6, 0.15)], 0.1);
    let scene = plane_stretch(128, 4, 2.0, rigidity);
    let frame = &scene.frames[3];
    let mut group = c.benchmark_group("gridwarp_aa_frame");
    group.sample_size(20);
    for (m, n) in SIZES {
        let grid = Grid::uniform(m, n);
        let options = SolveOptions::default();
        let once = solve_frame(&scene.rest, &grid, frame, &grid, &grid, (0, 1), &options).unwrap();
        println!(
            "aa {} unknowns: {} iterations, {} energy + {} Jacobian evaluations, stop {:?}, E {:.4e} → {:.4e}",
            grid.unknowns(),
            once.lm.iterations,
            once.lm.energy_evaluations,
            once.lm.jacobian_evaluations,
            once.lm.stop,
            once.rest_energy,
            once.lm.energy
        );
        group.bench_function(format!("{}_unknowns_8x8_samples", grid.unknowns()), |b| {
            b.iter(|| {
                black_box(
                    solve_frame(&scene.rest, &grid, frame, &grid, &grid, (0, 1), &options).unwrap(),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_aa);
criterion_main!(benches);
