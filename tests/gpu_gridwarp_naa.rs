//! The gridwarp non-axis-aligned energy on the GPU (`gridwarp_naa_cell` and
//! `gridwarp_naa_residuals`, f32) against the f64 reference from identical f32-rounded inputs,
//! and whole Gauss–Newton solves with the GPU objective against CPU solves, each element
//! within the bound derived once in `reparam::crosscheck::gridwarp_naa` (shared with
//! `reparam crosscheck gridwarp --variant naa`). Without an adapter these tests print
//! `skipped: no GPU adapter` and pass; with REPARAM_REQUIRE_GPU=1 they fail instead.
#![cfg(feature = "gpu")]

use nalgebra::Vector3;
use reparam::crosscheck::gridwarp_naa::{naa_kernel_rows, naa_solve_rows};
use reparam::crosscheck::{Row, Verdict};
use reparam::gridwarp::scene::{disc_rigidity, flat_rest};
use reparam::gridwarp::{grid_from_rigidity, DeformedJacobian, SolveOptions};
use reparam_gpu::gpu_or_skip;

/// As `tests/twin_gridwarp_naa.rs`: a stretch ramp bent along t and lifted in z.
fn bent_stretch(size: usize, sigma: f64) -> DeformedJacobian {
    DeformedJacobian::from_partials(size, move |s: f64, t: f64| {
        let ramp = (3.0 * s * s - 2.0 * s * s * s).clamp(0.0, 1.0);
        (
            Vector3::x() * (1.0 + (sigma - 1.0) * ramp * (0.5 + t)),
            Vector3::y() + Vector3::z() * (0.3 * s),
        )
    })
}

fn print_and_check(rows: &[Row]) {
    for r in rows {
        println!(
            "| {} | {} | {:.3e} | {:.3e} | {:.3} | {} |",
            r.kernel, r.errors.count, r.errors.max_abs, r.bound_max, r.worst_ratio, r.note
        );
        assert_eq!(r.verdict, Verdict::Pass, "{r:?}");
        assert!(r.errors.count > 0, "{}", r.kernel);
    }
}

#[test]
fn the_kernel_rows_lie_within_the_derived_bound() {
    let Some(gpu) = gpu_or_skip() else { return };
    let rigidity = disc_rigidity(32, &[(0.7, 0.5, 0.15)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let rest = flat_rest(32, rigidity);
    for sliding in [false, true] {
        let frame = bent_stretch(32, 1.9);
        let rows = naa_kernel_rows(&gpu, "bent", &rest, &grid, &frame, (3, 3), sliding).unwrap();
        assert_eq!(rows.len(), 5);
        print_and_check(&rows);
    }
}

#[test]
fn solves_with_the_gpu_objective_match_the_cpu_solves() {
    let Some(gpu) = gpu_or_skip() else { return };
    let rigidity = disc_rigidity(32, &[(0.7, 0.5, 0.15)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let rest = flat_rest(32, rigidity);
    let frames: Vec<_> = [1.3, 1.6].iter().map(|&s| bent_stretch(32, s)).collect();
    let options = SolveOptions {
        samples: (3, 3),
        ..Default::default()
    };
    let rows = naa_solve_rows(&gpu, "bent", &rest, &grid, &frames, &options, false).unwrap();
    print_and_check(&rows);
}
