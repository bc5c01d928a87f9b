//! The gridwarp axis-aligned energy on the GPU (`gridwarp_aa_cell`, f32) against the f64
//! reference (`AaEnergy`), from identical f32-rounded inputs, and whole solves with the GPU
//! objective (the paper's hybrid solver, seed §7). Without an adapter these tests print
//! `skipped: no GPU adapter` and pass; with REPARAM_REQUIRE_GPU=1 they fail instead.
#![cfg(feature = "gpu")]

use std::time::Instant;

use reparam::crosscheck::gridwarp::{
    energy_bound, gradient_bound, jtj_bound, magnitudes, round, round_field, solve_bounds,
    texel_margin, Magnitudes, EPS,
};
use reparam::gridwarp::energy::{AaEnergy, DeformedFields, RestFields};
use reparam::gridwarp::gpu::{solve_sequence_gpu, GpuAaEnergy};
use reparam::gridwarp::scene::{disc_rigidity, plane_stretch};
use reparam::gridwarp::{grid_from_rigidity, solve_sequence, Grid, SolveOptions};
use reparam::lm::Residuals;
use reparam_gpu::gpu_or_skip;

/// The bounds of `reparam::crosscheck::gridwarp` at K = L = 4 (this test's samples) and 8 × 8
/// (the solves'), written once there and used by `reparam crosscheck gridwarp` too.
fn energy_tolerance(mg: &Magnitudes, kl: (usize, usize)) -> f64 {
    energy_bound(&mg.r, &mg.m, kl)
}

#[test]
fn one_evaluation_matches_the_reference_within_the_derived_tolerance() {
    let Some(gpu) = gpu_or_skip() else { return };
    let size = 64;
    let (k, l) = (4, 4);
    let rigidity = disc_rigidity(size, &[(0.7, 0.5, 0.12), (0.25, 0.3, 0.1)], 0.1);
    let scene = plane_stretch(size, 4, 2.0, rigidity);
    // Identical inputs for both sides: every field value and grid line rounded to f32 first.
    let rest = RestFields {
        o_s: round_field(&scene.rest.o_s),
        o_t: round_field(&scene.rest.o_t),
        rigidity: round_field(&scene.rest.rigidity),
    };
    let frame = &scene.frames[3];
    let deformed = DeformedFields {
        d_s: round_field(&frame.d_s),
        d_t: round_field(&frame.d_t),
    };
    let rest_grid = Grid::new(
        round(&[0.0, 0.181, 0.395, 0.62, 0.803, 1.0]),
        round(&[0.0, 0.27, 0.51, 0.77, 1.0]),
    )
    .unwrap();
    // The evaluation point: every interior line moved (not the rest grid, whose samples sit on
    // texel boundaries for dyadic lines), rounded to f32. Among a few deterministic candidates,
    // take the first whose samples are all ≥ 1e-3 texel from a texel-centre boundary: the f32
    // sample position p differs from the f64 one by ≲ 2ε·1 (two roundings of values ≤ 1), i.e.
    // ≲ 2ε·64 + ε/2·64 ≈ 1e-5 texel in u = p·W − ½, so both sides then interpolate in the same
    // texel and the bilinear gradient (discontinuous across texel boundaries) is the same one.
    let x0 = rest_grid.to_unknowns();
    let x = (1..50)
        .map(|c| {
            let x: Vec<f64> = x0
                .iter()
                .enumerate()
                .map(|(n, &v)| v + 0.013 * ((n * 7 + c * 3) as f64 * 0.61).sin())
                .collect();
            round(&x)
        })
        .find(|x| {
            let g = rest_grid.with_unknowns(x);
            texel_margin(&g.s, k, size).min(texel_margin(&g.t, l, size)) >= 1e-3
        })
        .expect("a candidate point with a texel margin");

    let mut cpu = AaEnergy::new(&rest, &rest_grid, &deformed, k, l);
    let mut gpu_energy = GpuAaEnergy::new(&gpu, &rest, &rest_grid, &deformed, k, l).unwrap();
    let reference = cpu.normal_equations(&x);
    let measured = gpu_energy.normal_equations(&x);
    let energy_only = gpu_energy.energy(&x);
    assert_eq!(
        energy_only, measured.energy,
        "energy() and normal_equations() use one kernel"
    );

    // Magnitudes for the tolerances, from the reference.
    let mg = magnitudes(&mut cpu, &rest, &rest_grid, (k, l), &x);

    // Energy. Each f32 residual r̃ = σ̃(c̃ã − õ) has |r̃ − r| ≤ C_r ε m with C_r ≈ 10: σ, o rounded
    // to f32 on upload (ε each), a = (s₁ − s₀)/h (3ε: the difference, h's rounding, the
    // division), c̃ (bilinear, ≈ 4ε, plus the sample-position error above: ≈ 1e-5 texel ×
    // |Δf| per texel ≤ 0.025 here, < 1ε of c ≥ 1), the product and difference (2ε). Then
    // |r̃² − r²| ≤ 2|r| C_r ε m + (C_r ε m)², and the kernel's f32 sum of 2KL = 32 squares per
    // cell adds ≤ 32ε Σ r² (the cross-cell sum is f64). Hence
    //   |ΔF| ≤ 2 C_r ε Σ|r_k| m_k + 32 ε F, with C_r = 10.
    let e_tol = energy_tolerance(&mg, (k, l));
    let e_err = (measured.energy - reference.energy).abs();

    // JᵀJ and Jᵀr, entry by entry, against |J|ᵀ|J| and |J|ᵀ(|r| + m): each derivative
    // σ(a c_s'(1 − α) − c/h) etc. is ≈ 8 f32 operations on inputs rounded as above
    // (C_d ≈ 12 ε relative to the magnitude of its terms, which here do not cancel: a c' ≤ 1.5
    // against c/h ≥ 4), a product adds its two factors' errors and ε, and the per-cell f32 sum
    // of 32 products adds ≤ 32ε of Σ|terms|:
    //   |Δ(JᵀJ)_uv| ≤ (2·12 + 1 + 32) ε (|J|ᵀ|J|)_uv ≈ 57 ε (|J|ᵀ|J|)_uv,
    //   |Δ(Jᵀr)_u| ≤ (12 + 10 + 1 + 32) ε (|J|ᵀ(|r| + m))_u ≈ 55 ε ….
    // Both rounded up to 64 ε.
    let n = x.len();
    let mut jtj_worst: f64 = 0.0; // max |Δ| / (ε·scale), to report
    let mut jtj_rel: f64 = 0.0; // max |Δ| / max |A|
    let a_max = reference.jtj.amax();
    let jtj_tol = jtj_bound(&mg, (k, l));
    for u in 0..n {
        for v in 0..n {
            let scale = jtj_tol[(u, v)] / (64.0 * EPS);
            let d = (measured.jtj[(u, v)] - reference.jtj[(u, v)]).abs();
            assert!(
                d <= jtj_tol[(u, v)],
                "JᵀJ[{u},{v}] {} vs {} (scale {scale:e})",
                measured.jtj[(u, v)],
                reference.jtj[(u, v)]
            );
            if scale > 0.0 {
                jtj_worst = jtj_worst.max(d / (EPS * scale));
            }
            jtj_rel = jtj_rel.max(d / a_max);
        }
    }
    let mut jtr_worst: f64 = 0.0;
    let mut jtr_rel: f64 = 0.0;
    let g_max = reference.jtr.amax();
    for u in 0..n {
        let tol = gradient_bound(&mg, (k, l))[u];
        let d = (measured.jtr[u] - reference.jtr[u]).abs();
        assert!(
            d <= tol,
            "Jᵀr[{u}] {} vs {} (tolerance {tol:e})",
            measured.jtr[u],
            reference.jtr[u]
        );
        jtr_worst = jtr_worst.max(64.0 * d / tol);
        jtr_rel = jtr_rel.max(d / g_max);
    }

    // Timing: one evaluation of the normal equations on each side.
    let reps = 20;
    let start = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(gpu_energy.normal_equations(&x));
    }
    let gpu_ms = start.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let start = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(cpu.normal_equations(&x));
    }
    let cpu_ms = start.elapsed().as_secs_f64() * 1e3 / reps as f64;
    println!(
        "F {:.6e}: |ΔF|/F = {:.2e} (tolerance {:.2e}); JᵀJ max|Δ|/max|A| = {jtj_rel:.2e}, \
         worst {jtj_worst:.1} ε of its scale; Jᵀr max|Δ|/max|g| = {jtr_rel:.2e}, worst \
         {jtr_worst:.1} ε; {} cells × {} samples: GPU {gpu_ms:.2} ms, CPU {cpu_ms:.2} ms per \
         evaluation on {}",
        reference.energy,
        e_err / reference.energy,
        e_tol / reference.energy,
        (rest_grid.s.len() - 1) * (rest_grid.t.len() - 1),
        k * l,
        gpu.adapter_summary()
    );
    // Timing at the size of the gridwarp benchmark's largest case: 21×21 lines (400 cells),
    // 8×8 samples per cell, 128² fields.
    let big = plane_stretch(128, 1, 2.0, disc_rigidity(128, &[(0.3, 0.35, 0.12)], 0.1));
    let big_grid = Grid::uniform(21, 21);
    let xb = big_grid.to_unknowns();
    let mut cpu_big = AaEnergy::new(&big.rest, &big_grid, &big.frames[0], 8, 8);
    let mut gpu_big = GpuAaEnergy::new(&gpu, &big.rest, &big_grid, &big.frames[0], 8, 8).unwrap();
    gpu_big.normal_equations(&xb);
    let start = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(gpu_big.normal_equations(&xb));
    }
    let gpu_big_ms = start.elapsed().as_secs_f64() * 1e3 / reps as f64;
    let start = Instant::now();
    for _ in 0..reps {
        std::hint::black_box(cpu_big.normal_equations(&xb));
    }
    let cpu_big_ms = start.elapsed().as_secs_f64() * 1e3 / reps as f64;
    println!(
        "400 cells × 64 samples: GPU {gpu_big_ms:.2} ms, CPU {cpu_big_ms:.2} ms per evaluation"
    );
    assert!(
        e_err <= e_tol,
        "F {} vs {} (tolerance {e_tol:e})",
        measured.energy,
        reference.energy
    );
    assert!(
        e_tol / reference.energy < 1e-4,
        "the tolerance is meaningful"
    );
}

#[test]
fn solves_with_the_gpu_objective_match_the_cpu_solves() {
    let Some(gpu) = gpu_or_skip() else { return };
    let rigidity = disc_rigidity(64, &[(0.7, 0.5, 0.12), (0.25, 0.3, 0.1)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let scene = plane_stretch(64, 4, 2.5, rigidity);
    let options = SolveOptions::default();
    let start = Instant::now();
    let cpu = solve_sequence(&scene.rest, &grid, &scene.frames, &options).unwrap();
    let cpu_s = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let gpu_solutions =
        solve_sequence_gpu(&gpu, &scene.rest, &grid, &scene.frames, &options).unwrap();
    let gpu_s = start.elapsed().as_secs_f64();
    for (j, (c, g)) in cpu.iter().zip(&gpu_solutions).enumerate() {
        // Judge the GPU's lines with the f64 energy.
        let mut reference = AaEnergy::new(&scene.rest, &grid, &scene.frames[j], 8, 8);
        let e_gpu = reference.energy(&g.lm.x);
        // The bounds derived in `crosscheck::gridwarp::solve_bounds` (energy and lines at the
        // CPU's minimum), shared with `reparam crosscheck gridwarp`.
        let (e_tol, x_tol) = solve_bounds(
            &mut reference,
            &scene.rest,
            &grid,
            (8, 8),
            &c.lm.x,
            c.lm.energy,
        )
        .expect("JᵀJ invertible at the CPU minimum");
        let rel = (e_gpu - c.lm.energy).abs() / c.lm.energy;
        let lines =
            c.lm.x
                .iter()
                .zip(&g.lm.x)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
        println!(
            "frame {j}: CPU F {:.6e} ({} it, {:?}), GPU-solved F (f64) {e_gpu:.6e} ({} it, {} + {} evals, {:?}); \
             rel ΔF {rel:.2e}, max |Δline| {lines:.2e}; rest F {:.4e}",
            c.lm.energy,
            c.lm.iterations,
            c.lm.stop,
            g.lm.iterations,
            g.lm.energy_evaluations,
            g.lm.jacobian_evaluations,
            g.lm.stop,
            c.rest_energy
        );
        assert!(
            (e_gpu - c.lm.energy).abs() <= e_tol,
            "frame {j}: F {e_gpu:e} vs {:e}, tolerance {e_tol:e}",
            c.lm.energy
        );
        assert!(
            lines <= x_tol,
            "frame {j}: lines differ by {lines:e}, tolerance {x_tol:e}"
        );
        println!(
            "  tolerances: |ΔF| ≤ {e_tol:.2e} ({:.2e} relative), lines ≤ {x_tol:.2e}",
            e_tol / c.lm.energy
        );
        assert!(
            g.lm.energy < g.rest_energy,
            "frame {j}: the GPU solve decreased the energy"
        );
    }
    println!("sequence: CPU {cpu_s:.2} s, GPU objective {gpu_s:.2} s");
}

/// The derivatives' term sizes M (the JᵀJ and Jᵀr bounds' magnitudes) cover |J| entry by
/// entry, and exceed it where the near line's two terms u(1 − α) − v partly cancel: the case the JᵀJ
/// bound missed when it used |J| (Fox.glb, an FMA-contracted twin at the edge of the WGSL
/// table, 1.8× over). CPU only.
#[test]
fn derivative_term_sizes_cover_the_jacobian_and_exceed_it_where_terms_cancel() {
    let size = 32;
    let rigidity = disc_rigidity(size, &[(0.5, 0.5, 0.2)], 0.1);
    let scene = plane_stretch(size, 4, 2.0, rigidity);
    let grid = Grid::new(vec![0.0, 0.3, 0.65, 1.0], vec![0.0, 0.5, 1.0]).unwrap();
    let cpu = AaEnergy::new(&scene.rest, &grid, &scene.frames[2], 4, 4);
    let x = grid.to_unknowns();
    let (j, m) = (cpu.jacobian(&x), cpu.jacobian_magnitudes(&x));
    assert_eq!(j.shape(), m.shape());
    assert!(j
        .iter()
        .zip(m.iter())
        .all(|(j, m)| j.abs() <= m * (1.0 + 1e-12)));
    let cancelling = j
        .iter()
        .zip(m.iter())
        .filter(|(j, m)| **m > 1.01 * j.abs())
        .count();
    assert!(cancelling > 0, "no derivative whose terms cancel");
}
