//! Properties of the f64 gridwarp reference, axis-aligned variant (notes "Oracles for tests").

mod common;

use reparam::gridwarp::bounds::{loop_distance, merge, Interval};
use reparam::gridwarp::field::Field;
use reparam::gridwarp::grid::{grid_from_rigidity, lines_from_profile};
use reparam::gridwarp::scene::{
    analytic_scene, disc_rigidity, flat_rest, plane_stretch, stretch_fields, uniform_stretch,
};
use reparam::gridwarp::*;
use reparam::lm::{LmOptions, Residuals};

fn solve_one(
    rest: &RestFields,
    grid: &Grid,
    frame: &DeformedFields,
    options: &SolveOptions,
) -> FrameSolution {
    solve_frame(rest, grid, frame, grid, grid, (0, 1), options).unwrap()
}

/// LM run to convergence: all tolerances tiny, so the answer is the minimiser to rounding.
fn tight() -> SolveOptions {
    SolveOptions {
        lm: LmOptions {
            epsf: 0.0,
            epsx: 1e-14,
            epsg: 1e-14,
            max_iterations: 200,
        },
        ..Default::default()
    }
}

#[test]
fn identity_deformation_gives_zero_energy_zero_iterations_and_the_same_grid() {
    let rest = flat_rest(32, disc_rigidity(32, &[(0.3, 0.4, 0.15)], 0.1));
    let (d_s, d_t) = (rest.o_s.clone(), rest.o_t.clone());
    let grid = Grid::new(vec![0.0, 0.2, 0.55, 1.0], vec![0.0, 0.3, 1.0]).unwrap();
    let s = solve_one(
        &rest,
        &grid,
        &DeformedFields { d_s, d_t },
        &SolveOptions::default(),
    );
    assert_eq!(s.lm.energy, 0.0);
    assert_eq!(s.lm.iterations, 0);
    assert_eq!(s.grid, grid);
}

#[test]
fn uniform_stretch_keeps_the_rest_grid_with_energy_sigma_minus_one_squared() {
    for sigma in [0.5, 1.3, 2.0] {
        let rest = flat_rest(16, Field::constant(1.0));
        let grid = Grid::new(vec![0.0, 0.25, 0.4, 0.7, 1.0], vec![0.0, 0.5, 1.0]).unwrap();
        let s = solve_one(&rest, &grid, &uniform_stretch(16, sigma), &tight());
        // Constant fields: the midpoint rule is exact and the energy is quadratic in the lines,
        // so the minimiser is found to rounding (≈1e-15 on O(1) quantities; 1e-12 leaves room).
        let expected = (sigma - 1.0) * (sigma - 1.0);
        assert!(
            (s.lm.energy - expected).abs() < 1e-12,
            "σ={sigma}: {} vs {expected}",
            s.lm.energy
        );
        for (a, b) in s.grid.s.iter().zip(&grid.s) {
            assert!((a - b).abs() < 1e-12, "σ={sigma}: {:?}", s.grid.s);
        }
    }
}

#[test]
fn per_column_rigidity_matches_the_closed_form() {
    // σ = 1.6, R = [.05, 1, .05] on three equal columns: minimising Σ R_i² h_i (σ a_i − 1)² with
    // Σ h_i a_i = 1 gives a_i = 1/σ + W (1 − 1/σ) / (R_i² Σ_k h_k / R_k²) (notes oracle 3).
    let sigma = 1.6;
    let r = [0.05, 1.0, 0.05];
    let rigidity = Field::from_fn(300, 1, |s, _| r[((s * 3.0) as usize).min(2)]);
    let rest = flat_rest(8, rigidity);
    let grid = Grid::new(vec![0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0], vec![0.0, 1.0]).unwrap();
    let s = solve_one(&rest, &grid, &uniform_stretch(8, sigma), &tight());
    let h = 1.0 / 3.0;
    let sum: f64 = r.iter().map(|ri| h / (ri * ri)).sum();
    for (i, ri) in r.iter().enumerate() {
        let expected = 1.0 / sigma + (1.0 - 1.0 / sigma) / (ri * ri * sum);
        let a = (s.grid.s[i + 1] - s.grid.s[i]) / h;
        // Quadratic problem solved to rounding; the constraint Σ h a = 1 is exact by construction.
        assert!(
            (a - expected).abs() < 1e-9,
            "column {i}: a = {a}, closed form {expected}"
        );
    }
    // (The notes' 0.6262 is for more .05 columns; three columns give 0.6264.)
}

#[test]
fn analytic_jacobian_matches_central_differences() {
    // Linear fields are reproduced exactly by bilinear interpolation inside the texel-centre
    // range, so c(p) is smooth (linear) there and central differences are exact up to rounding:
    // error ≈ ε·|r|/step ≈ 1e-16/1e-6 = 1e-10 relative.
    let n = 64;
    let rest = RestFields {
        o_s: Field::from_fn(n, n, |s, t| 1.0 + 0.2 * s - 0.1 * t),
        o_t: Field::from_fn(n, n, |s, t| 0.9 + 0.3 * t + 0.05 * s),
        rigidity: disc_rigidity(n, &[(0.5, 0.5, 0.3)], 0.3),
    };
    let frame = DeformedFields {
        d_s: Field::from_fn(n, n, |s, t| 1.4 + 0.6 * s + 0.4 * t),
        d_t: Field::from_fn(n, n, |s, t| 0.8 - 0.3 * s + 0.5 * t),
    };
    let grid = Grid::new(vec![0.0, 0.3, 0.55, 1.0], vec![0.0, 0.45, 0.7, 1.0]).unwrap();
    let energy = AaEnergy::new(&rest, &grid, &frame, 4, 3);
    let x = vec![0.32, 0.52, 0.43, 0.72];
    let jac = energy.jacobian(&x);
    let step = 1e-6;
    for col in 0..x.len() {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[col] += step;
        xm[col] -= step;
        let (rp, rm) = (energy.residuals(&xp), energy.residuals(&xm));
        for row in 0..rp.len() {
            let fd = (rp[row] - rm[row]) / (2.0 * step);
            assert!(
                (fd - jac[(row, col)]).abs() < 1e-8 * (1.0 + fd.abs()),
                "row {row} col {col}: {fd} vs {}",
                jac[(row, col)]
            );
        }
    }
    // The normal equations are JᵀJ and Jᵀr of that Jacobian.
    let mut e = AaEnergy::new(&rest, &grid, &frame, 4, 3);
    let ne = e.normal_equations(&x);
    let r = nalgebra::DVector::from_vec(energy.residuals(&x));
    assert!((&ne.jtj - jac.transpose() * &jac).abs().max() < 1e-12);
    assert!((&ne.jtr - jac.transpose() * &r).abs().max() < 1e-12);
    assert!((ne.energy - r.norm_squared()).abs() < 1e-14);
}

#[test]
fn sequences_decrease_energy_keep_lines_increasing_and_warm_starts_are_idempotent() {
    let rigidity = disc_rigidity(64, &[(0.7, 0.5, 0.12), (0.25, 0.3, 0.1)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let scene = plane_stretch(64, 4, 2.5, rigidity);
    let solutions =
        solve_sequence(&scene.rest, &grid, &scene.frames, &SolveOptions::default()).unwrap();
    for s in &solutions {
        assert!(
            s.lm.energy <= s.rest_energy,
            "{} > {}",
            s.lm.energy,
            s.rest_energy
        );
        assert!(
            s.lm.accepted_energies.windows(2).all(|w| w[1] < w[0]),
            "{:?}",
            s.lm.accepted_energies
        );
        assert!(
            s.grid.s.windows(2).all(|w| w[0] < w[1]) && s.grid.t.windows(2).all(|w| w[0] < w[1]),
            "{:?}",
            s.grid
        );
    }
    // The rigid columns moved: the stretch went to the non-rigid cells.
    let last = solutions.last().unwrap();
    assert!(
        last.lm.energy < 0.5 * last.rest_energy,
        "{} vs {}",
        last.lm.energy,
        last.rest_energy
    );
    // Warm start from a converged solution: at most one more iteration.
    let frame = scene.frames.last().unwrap();
    let again = solve_frame(
        &scene.rest,
        &grid,
        frame,
        &last.grid,
        &grid,
        (0, 1),
        &SolveOptions::default(),
    )
    .unwrap();
    assert!(again.lm.iterations <= 1, "{:?}", again.lm);
}

#[test]
fn mirror_symmetric_input_gives_a_mirror_symmetric_grid() {
    let rigidity = Field::from_fn(
        64,
        64,
        |s, _| if (s - 0.5).abs() < 0.15 { 1.0 } else { 0.1 },
    );
    let rest = flat_rest(64, rigidity.clone());
    let (d_s, d_t) = stretch_fields(64, |s: f64, _| {
        (
            nalgebra::Vector3::x() * (1.0 + (std::f64::consts::PI * s).sin()),
            nalgebra::Vector3::y(),
        )
    });
    let grid = Grid::new(vec![0.0, 0.2, 0.35, 0.65, 0.8, 1.0], vec![0.0, 1.0]).unwrap();
    let s = solve_one(&rest, &grid, &DeformedFields { d_s, d_t }, &tight());
    let m = s.grid.s.len();
    for i in 0..m {
        // Symmetric problem, converged to rounding: the texel samples are mirror images too.
        assert!(
            (s.grid.s[i] + s.grid.s[m - 1 - i] - 1.0).abs() < 1e-9,
            "{:?}",
            s.grid.s
        );
    }
    assert!(
        (s.grid.s[3] - s.grid.s[2]) < 0.3 * (1.0 - 0.0),
        "the rigid middle cell shrank back: {:?}",
        s.grid.s
    );
}

#[test]
fn midpoint_rule_error_shrinks_about_four_times_per_doubling() {
    let n = 512;
    let rest = RestFields {
        o_s: Field::from_fn(n, n, |s, t| 1.0 + 0.3 * (3.0 * s).sin() * t),
        o_t: Field::from_fn(n, n, |_, _| 1.0),
        rigidity: Field::constant(1.0),
    };
    let frame = DeformedFields {
        d_s: Field::from_fn(n, n, |s, t| 1.5 + 0.5 * (2.0 * s + t).cos()),
        d_t: Field::from_fn(n, n, |s, t| 1.0 + 0.2 * s * t),
    };
    let grid = Grid::new(vec![0.0, 0.5, 1.0], vec![0.0, 0.5, 1.0]).unwrap();
    let x = vec![0.45, 0.55];
    let e = |k: usize| AaEnergy::new(&rest, &grid, &frame, k, k).energy(&x);
    let (e2, e4, e8, e16) = (e(2), e(4), e(8), e(16));
    let ratios = [(e2 - e4) / (e4 - e8), (e4 - e8) / (e8 - e16)];
    // Midpoint rule: error = C h² + O(h⁴), so successive differences shrink by 4 (fields are
    // smooth at this resolution: 512 texels against at most 32 samples per axis).
    for r in ratios {
        assert!((3.5..4.5).contains(&r), "ratios {ratios:?}");
    }
}

#[test]
fn zero_rigidity_moves_nothing_and_makes_no_nan() {
    let rest = flat_rest(16, Field::constant(0.0));
    let grid = Grid::uniform(4, 3);
    let s = solve_one(
        &rest,
        &grid,
        &uniform_stretch(16, 3.0),
        &SolveOptions::default(),
    );
    assert_eq!(s.grid, grid);
    assert_eq!(s.lm.energy, 0.0);
    assert!(s.lm.x.iter().all(|v| v.is_finite()));
}

#[test]
fn zero_smoothness_freezes_every_line() {
    let rest = flat_rest(16, disc_rigidity(16, &[(0.5, 0.5, 0.2)], 0.1));
    let grid = Grid::uniform(5, 5);
    let options = SolveOptions {
        smoothness: Some(0.0),
        ..Default::default()
    };
    let s = solve_one(&rest, &grid, &uniform_stretch(16, 2.0), &options);
    assert_eq!(s.grid, grid);
}

#[test]
fn bounds_merge_by_priority_including_the_empty_case() {
    let a = Interval { lo: 0.0, hi: 1.0 };
    // Overlap: the intersection.
    assert_eq!(
        merge(a, Interval { lo: 0.5, hi: 2.0 }),
        Interval { lo: 0.5, hi: 1.0 }
    );
    // Lower priority inside: it (the intersection).
    assert_eq!(
        merge(a, Interval { lo: 0.2, hi: 0.3 }),
        Interval { lo: 0.2, hi: 0.3 }
    );
    // Lower priority containing: the higher one.
    assert_eq!(merge(a, Interval { lo: -1.0, hi: 2.0 }), a);
    // Disjoint (empty intersection): the higher priority wins.
    assert_eq!(merge(a, Interval { lo: 2.0, hi: 3.0 }), a);
    // A point interval freezes.
    assert_eq!(
        merge(Interval { lo: 0.4, hi: 0.4 }, a),
        Interval { lo: 0.4, hi: 0.4 }
    );
    // Looping distance: 0 at both ends of the loop, growing to the middle.
    assert_eq!(
        (0..7).map(|j| loop_distance(j, 7)).collect::<Vec<_>>(),
        vec![0.0, 1.0, 2.0, 3.0, 2.0, 1.0, 0.0]
    );
}

#[test]
fn looping_sequences_return_to_the_first_frame() {
    let rigidity = disc_rigidity(32, &[(0.6, 0.5, 0.15)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let mut scene = plane_stretch(32, 3, 2.0, rigidity);
    // A loop: stretch out and back, the last frame equal to the first.
    let back: Vec<_> = scene.frames.iter().rev().skip(1).cloned().collect();
    scene.frames.extend(back);
    let options = SolveOptions {
        smoothness: Some(0.02),
        looping: true,
        ..Default::default()
    };
    let solutions = solve_sequence(&scene.rest, &grid, &scene.frames, &options).unwrap();
    let (first, last) = (&solutions[0].grid, &solutions.last().unwrap().grid);
    for (a, b) in first
        .s
        .iter()
        .zip(&last.s)
        .chain(first.t.iter().zip(&last.t))
    {
        assert_eq!(
            a, b,
            "last frame must equal the first: {first:?} vs {last:?}"
        );
    }
}

#[test]
fn algorithm_1_puts_lines_on_the_rigid_columns_boundaries() {
    assert_eq!(
        lines_from_profile(&[0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0], 0.5),
        vec![0.0, 0.25, 0.5, 1.0]
    );
    assert_eq!(lines_from_profile(&[0.2; 5], 0.1), vec![0.0, 1.0]);
    let r = disc_rigidity(100, &[(0.5, 0.5, 0.1)], 0.0);
    let g = grid_from_rigidity(&r, 0.5);
    assert_eq!(g.s, vec![0.0, 0.4, 0.6, 1.0]);
    assert_eq!(g.t, vec![0.0, 0.4, 0.6, 1.0]);
}

#[test]
fn bad_grids_are_typed_errors() {
    assert!(Grid::new(vec![0.0, 0.5, 0.5, 1.0], vec![0.0, 1.0]).is_err());
    assert!(Grid::new(vec![0.1, 1.0], vec![0.0, 1.0]).is_err());
    assert!(Grid::new(vec![0.0, 1.0], vec![0.0]).is_err());
}

#[test]
fn results_are_bit_identical_with_one_and_two_threads() {
    let rigidity = disc_rigidity(64, &[(0.7, 0.5, 0.12)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let scene = plane_stretch(64, 2, 2.0, rigidity);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                solve_sequence(&scene.rest, &grid, &scene.frames, &SolveOptions::default()).unwrap()
            })
    };
    let (a, b) = (run(1), run(2));
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.grid, y.grid);
        assert_eq!(x.lm.energy.to_bits(), y.lm.energy.to_bits());
    }
}

/// The energy finds each sample's texel positions once per column and row of samples
/// (`field::Axis`), for D_s's resolution; a D_t of another resolution must still be sampled on
/// its own texels. Residuals equal the notes' formula evaluated sample by sample with
/// `Field::bilinear` (the same operations: bit for bit).
#[test]
fn residuals_equal_the_formula_with_fields_of_different_resolutions() {
    let rest = RestFields {
        o_s: Field::from_fn(8, 8, |s, t| 1.0 + 0.1 * s * t),
        o_t: Field::constant(1.0),
        rigidity: disc_rigidity(8, &[(0.5, 0.5, 0.3)], 0.2),
    };
    let frame = DeformedFields {
        d_s: Field::from_fn(16, 16, |s, t| 1.2 + (6.0 * s).sin() * 0.3 + t),
        d_t: Field::from_fn(7, 12, |s, t| 0.9 + (5.0 * t).cos() * 0.2 + 0.4 * s),
    };
    let grid = Grid::new(vec![0.0, 0.4, 1.0], vec![0.0, 0.3, 0.65, 1.0]).unwrap();
    let (k, l) = (3, 2);
    let energy = AaEnergy::new(&rest, &grid, &frame, k, l);
    let x = vec![0.45, 0.33, 0.6];
    let g = grid.with_unknowns(&x);
    let mut expected = Vec::new();
    for i in 0..2 {
        for j in 0..3 {
            let (h, kj) = (grid.s[i + 1] - grid.s[i], grid.t[j + 1] - grid.t[j]);
            let (a, b) = ((g.s[i + 1] - g.s[i]) / h, (g.t[j + 1] - g.t[j]) / kj);
            for ka in 0..k {
                for lb in 0..l {
                    let (al, be) = ((ka as f64 + 0.5) / k as f64, (lb as f64 + 0.5) / l as f64);
                    let (s, t) = (grid.s[i] + al * h, grid.t[j] + be * kj);
                    let sigma = (h * kj / (k * l) as f64).sqrt() * rest.rigidity.nearest(s, t);
                    let f = g.s[i] + al * (g.s[i + 1] - g.s[i]);
                    let gt = g.t[j] + be * (g.t[j + 1] - g.t[j]);
                    let (cs, ct) = (frame.d_s.bilinear(f, gt), frame.d_t.bilinear(f, gt));
                    // c a − o rounded once (a fused multiply-add), then times σ.
                    let (os, ot) = (rest.o_s.bilinear(s, t).value, rest.o_t.bilinear(s, t).value);
                    expected.push(sigma * cs.value.mul_add(a, -os));
                    expected.push(sigma * ct.value.mul_add(b, -ot));
                }
            }
        }
    }
    assert_eq!(energy.residuals(&x), expected);
}

#[test]
fn every_lane_code_gives_the_same_bits() {
    // The AA lane loops run as AVX-512 code reading each chunk's texels by permuting two
    // vector loads from fields stored column by column ("windows", where the chunk's texel
    // rows fit), as AVX-512 code or AVX2 + FMA code reading them by gathers, or as portable
    // code (each as far as the CPU has the instructions).
    // All read the same texels and do the same IEEE operations in the same order (a fused
    // multiply-add rounds once with or without the instruction), so F, JᵀJ and Jᵀr must be
    // equal bit for bit. Covered: both chunk layouts (L ≤ 4: two column samples per chunk,
    // windows of 8 rows; L > 4: one, windows of 16), two chunk rows per column sample
    // (L = 12), padded samples, and cells too tall for a window (3×3 lines) next to cells
    // that fit (16×16 lines); fields of 64² texels, of 61² (sides not multiples of the 8×8
    // tiles in which the fields are transposed), and ‖D_t‖ at 40² beside ‖D_s‖ at 64². The
    // saddle's ‖D_s‖ varies along t and ‖D_t‖ along s, so that reading a wrong texel row or
    // column changes the sums.
    let saddle = analytic_scene("saddle", 2).expect("built-in scene");
    let (fine, odd, coarse) = (saddle.fields(64), saddle.fields(61), saddle.fields(40));
    let mixed = DeformedFields {
        d_s: fine.frames[1].d_s.clone(),
        d_t: coarse.frames[1].d_t.clone(),
    };
    let cases = [
        (
            &fine.rest,
            &fine.frames[1],
            [(16, 16), (7, 6), (3, 3)].as_slice(),
        ),
        (&odd.rest, &odd.frames[1], &[(16, 16), (5, 9)]),
        (&fine.rest, &mixed, &[(16, 16), (7, 6)]),
    ];
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut rng = common::Rng(11);
    let mut windowed = 0;
    for (rest, frame, grids) in cases {
        for &(m, n) in grids {
            let grid = Grid::uniform(m, n);
            for (k, l) in [(8, 8), (4, 3), (3, 4), (5, 12), (1, 1)] {
                let energy = |code| AaEnergy::new(rest, &grid, frame, k, l).with_lane_code(code);
                let mut fastest = energy(LaneCode::Fastest);
                let mut others =
                    [LaneCode::Gathers, LaneCode::Avx2, LaneCode::Portable].map(energy);
                for _ in 0..2 {
                    // Lines moved by at most 0.4 of the rest spacing: still increasing.
                    let spacing = 1.0 / (m.max(n) - 1) as f64;
                    let x: Vec<f64> = grid
                        .to_unknowns()
                        .iter()
                        .map(|v| v + rng.uniform(-0.4, 0.4) * spacing)
                        .collect();
                    windowed += fastest.chunk_rows_read_by_windows(&x).0;
                    let a = fastest.normal_equations(&x);
                    let e = fastest.energy(&x);
                    for other in &mut others {
                        assert_eq!(other.chunk_rows_read_by_windows(&x).0, 0);
                        let b = other.normal_equations(&x);
                        let what =
                            format!("{m}×{n} lines, {k}×{l} samples, {} texels", frame.d_s.width);
                        assert_eq!(a.energy.to_bits(), b.energy.to_bits(), "F, {what}");
                        assert_eq!(
                            bits(a.jtr.as_slice()),
                            bits(b.jtr.as_slice()),
                            "Jᵀr, {what}"
                        );
                        assert_eq!(
                            bits(a.jtj.as_slice()),
                            bits(b.jtj.as_slice()),
                            "JᵀJ, {what}"
                        );
                        let f = other.energy(&x);
                        assert_eq!(e.to_bits(), f.to_bits(), "energy(), {what}");
                    }
                }
            }
        }
    }
    #[cfg(target_arch = "x86_64")]
    let avx512 = std::arch::is_x86_feature_detected!("avx512f");
    #[cfg(not(target_arch = "x86_64"))]
    let avx512 = false;
    if avx512 {
        assert!(
            windowed > 0,
            "with AVX-512, some chunk rows are read by windows"
        );
    } else {
        println!("no AVX-512: no texel read by windows");
    }
}

#[test]
fn energy_equals_the_normal_equations_energy_bit_for_bit() {
    // The solver hands the energy to LM through lm::Speculative, which takes a trial's F from
    // its normal equations while trials are being accepted and from energy() after a rejected
    // one: both must give the same F bit for bit, or a run would depend on which were
    // computed. They sum the same r² in the same order (per lane: axis s, then t, chunk by
    // chunk; then the lanes, then the cells in order). Both chunk layouts (L ≤ 4: two column
    // samples per chunk; L > 4: one), padded samples, and cells without any sample of R > 0
    // (R = 0 outside the discs) are covered.
    let size = 64;
    let rigidity = disc_rigidity(size, &[(0.3, 0.35, 0.12), (0.7, 0.6, 0.15)], 0.0);
    let scene = plane_stretch(size, 2, 1.8, rigidity);
    let grid = Grid::uniform(7, 6);
    let mut rng = common::Rng(7);
    for (k, l) in [(8, 8), (4, 3), (3, 5), (1, 1)] {
        for frame in &scene.frames {
            let mut energy = AaEnergy::new(&scene.rest, &grid, frame, k, l);
            for _ in 0..3 {
                // Each line moved by at most 0.4 of the smallest rest cell (1/6): still
                // strictly increasing.
                let x: Vec<f64> = grid
                    .to_unknowns()
                    .iter()
                    .map(|v| v + rng.uniform(-0.4, 0.4) / 6.0)
                    .collect();
                let (e, normal) = (energy.energy(&x), energy.normal_equations(&x));
                assert!(e > 0.0, "a non-trivial energy");
                assert_eq!(
                    e.to_bits(),
                    normal.energy.to_bits(),
                    "{k}×{l}: {e} vs {}",
                    normal.energy
                );
            }
        }
    }
}
