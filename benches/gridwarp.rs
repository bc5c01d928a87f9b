//! gridwarp benchmarks (issue #3): per-frame axis-aligned solve time at the paper's problem
//! sizes (Table 1: 14, 24 and 38 unknowns), with evaluation and Jacobian counts printed once.
//! Non-axis-aligned: 48, 192 and 288 unknowns ((M−2)(N−2)·2 with fixed border vertices).
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

/// (M−2)(N−2)·2 unknowns: 6×8 → 48, 10×14 → 192, 14×14 → 288.
const NAA_SIZES: [(usize, usize); 3] = [(6, 8), (10, 14), (14, 14)];

fn bench_naa(c: &mut Criterion) {
    use reparam::gridwarp::energy_naa::{solve_naa_frame, DeformedJacobian, VertexGrid};
    use reparam::gridwarp::scene::{analytic_scene, partials_of};
    let scene = analytic_scene("saddle", 4).unwrap();
    let fields = scene.fields(128);
    let surface = &scene.frames[3];
    let deformed = DeformedJacobian::from_partials(128, &|s, t| partials_of(&**surface, s, t));
    let mut group = c.benchmark_group("gridwarp_naa_frame");
    group.sample_size(10);
    for (m, n) in NAA_SIZES {
        let grid = Grid::uniform(m, n);
        let vertices = VertexGrid::from_grid(&grid);
        let options = SolveOptions::default();
        let once = solve_naa_frame(
            &fields.rest,
            &grid,
            &deformed,
            &vertices,
            &vertices,
            (0, 1),
            &options,
        )
        .unwrap();
        println!(
            "naa {} unknowns: {} iterations, {} energy + {} Jacobian evaluations, stop {:?}, E {:.4e} → {:.4e}",
            once.lm.x.len(),
            once.lm.iterations,
            once.lm.energy_evaluations,
            once.lm.jacobian_evaluations,
            once.lm.stop,
            once.rest_energy,
            once.lm.energy
        );
        group.bench_function(format!("{}_unknowns_8x8_samples", once.lm.x.len()), |b| {
            b.iter(|| {
                black_box(
                    solve_naa_frame(
                        &fields.rest,
                        &grid,
                        &deformed,
                        &vertices,
                        &vertices,
                        (0, 1),
                        &options,
                    )
                    .unwrap(),
                )
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_aa, bench_naa);
criterion_main!(benches);
