//! Properties of the non-axis-aligned gridwarp energy and solve (notes "Formulation: NAA",
//! "Analytic Jacobian: NAA", "Bounds", "Oracles for tests").

mod common;

use nalgebra::{DVector, Vector3};
use reparam::gridwarp::energy_naa::{naa_bounds, VectorField};
use reparam::gridwarp::field::Field;
use reparam::gridwarp::grid::grid_from_rigidity;
use reparam::gridwarp::scene::{disc_rigidity, flat_rest, plane_partials};
use reparam::gridwarp::*;
use reparam::lm::{LmOptions, Residuals};

/// D_s = x̂·c_s(s, t), D_t = ŷ·c_t(s, t): the deformed lengths are c_s, c_t exactly.
fn axis_fields(
    n: usize,
    cs: impl Fn(f64, f64) -> f64,
    ct: impl Fn(f64, f64) -> f64,
) -> (DeformedFields, DeformedJacobian) {
    let aa = DeformedFields {
        d_s: Field::from_fn(n, n, &cs),
        d_t: Field::from_fn(n, n, &ct),
    };
    let naa = DeformedJacobian {
        d_s: VectorField::from_fn(n, n, |s, t| [cs(s, t), 0.0, 0.0]),
        d_t: VectorField::from_fn(n, n, |s, t| [0.0, ct(s, t), 0.0]),
    };
    (aa, naa)
}

/// All cells of `v` have positive determinants at all four corners.
fn assert_unfolded(v: &VertexGrid) {
    for i in 0..v.m - 1 {
        for j in 0..v.n - 1 {
            let d = v.corner_determinants(i, j);
            assert!(d.iter().all(|&d| d > 0.0), "cell ({i}, {j}): {d:?}");
        }
    }
}

#[test]
fn axis_aligned_vertices_give_the_aa_energy() {
    let n = 64;
    let rest = RestFields {
        o_s: Field::from_fn(n, n, |s, t| 1.0 + 0.2 * (3.0 * s).sin() * t),
        o_t: Field::from_fn(n, n, |s, t| 0.9 + 0.3 * t * t + 0.05 * s),
        rigidity: disc_rigidity(n, &[(0.4, 0.6, 0.2)], 0.2),
    };
    let (aa, naa) = axis_fields(
        n,
        |s, t| 1.3 + 0.5 * (2.0 * s + t).cos(),
        |s, t| 0.8 + 0.4 * s * t,
    );
    let grid = Grid::new(vec![0.0, 0.3, 0.55, 1.0], vec![0.0, 0.45, 0.7, 1.0]).unwrap();
    for x in [vec![0.3, 0.55, 0.45, 0.7], vec![0.27, 0.6, 0.4, 0.76]] {
        // Moving AA line s_i moves its border vertices along the border: sliding-border mode.
        let lines = VertexGrid::from_grid(&grid.with_unknowns(&x)).with_sliding_border(true);
        let vx = lines.to_unknowns();
        let mut aa_energy = AaEnergy::new(&rest, &grid, &aa, 4, 3);
        let mut naa_energy = NaaEnergy::new(&rest, &grid, &naa, 4, 3).with_sliding_border(true);
        let e_aa = aa_energy.energy(&x);
        let e_naa = naa_energy.energy(&vx);
        // Same samples, same sums; q_s = a_i·(c_s, 0, 0) so ‖q_s‖ = c_s a_i up to a few ulps in
        // the slope and sample point: relative difference ≈ 1e-15, 1e-12 leaves room.
        assert!(e_aa > 1e-3, "non-trivial energy: {e_aa}");
        assert!(
            (e_aa - e_naa).abs() <= 1e-12 * e_aa,
            "AA {e_aa} vs NAA {e_naa}"
        );
        // Chain rule: ∂F/∂s_i = Σ_b ∂F/∂P_ib.s and ∂F/∂t_j = Σ_a ∂F/∂P_aj.t. Same residuals,
        // gradients O(0.1): 1e-12 absolute is ~1e-11 relative, far above rounding (~1e-15).
        let (g_aa, g_naa) = (
            aa_energy.normal_equations(&x).jtr,
            naa_energy.normal_equations(&vx).jtr,
        );
        let m = grid.s.len();
        for i in 1..m - 1 {
            let sum: f64 = (0..lines.n)
                .map(|b| g_naa[lines.unknown_index(i, b)[0].unwrap()])
                .sum();
            assert!(
                (sum - g_aa[i - 1]).abs() < 1e-12,
                "s_{i}: {sum} vs {}",
                g_aa[i - 1]
            );
        }
        for j in 1..grid.t.len() - 1 {
            let sum: f64 = (0..lines.m)
                .map(|a| g_naa[lines.unknown_index(a, j)[1].unwrap()])
                .sum();
            let k = m - 2 + j - 1;
            assert!((sum - g_aa[k]).abs() < 1e-12, "t_{j}: {sum} vs {}", g_aa[k]);
        }
        assert!(g_aa.amax() > 1e-3, "non-trivial gradient {g_aa}");
    }
}

/// Rest fields, a frame and a 4×4-line grid for the derivative checks: every component
/// field linear in (s, t), hence reproduced exactly by bilinear interpolation inside the
/// texel-centre range (64 texels), with a zero mixed derivative ∂_s∂_t.
fn affine_problem() -> (RestFields, DeformedJacobian, Grid) {
    let n = 64;
    let rest = RestFields {
        o_s: Field::from_fn(n, n, |s, t| 1.0 + 0.2 * s - 0.1 * t),
        o_t: Field::from_fn(n, n, |s, t| 0.9 + 0.3 * t + 0.05 * s),
        rigidity: disc_rigidity(n, &[(0.5, 0.5, 0.3)], 0.3),
    };
    let frame = DeformedJacobian {
        d_s: VectorField::from_fn(n, n, |s, t| {
            [1.4 + 0.6 * s + 0.4 * t, 0.2 - 0.3 * t, 0.5 * s]
        }),
        d_t: VectorField::from_fn(n, n, |s, t| {
            [0.1 * s - 0.2 * t, 0.8 - 0.3 * s + 0.5 * t, 0.3 + 0.4 * t]
        }),
    };
    let grid = Grid::new(vec![0.0, 0.3, 0.55, 1.0], vec![0.0, 0.45, 0.7, 1.0]).unwrap();
    (rest, frame, grid)
}

#[test]
fn analytic_jacobian_matches_central_differences() {
    // Linear component fields are reproduced exactly by bilinear interpolation inside the
    // texel-centre range ([0.5/64, 1 − 0.5/64]; every sample below stays inside), so the residuals
    // are smooth in the vertices and central differences are exact up to rounding:
    // ≈ ε·|r|/step ≈ 1e-16/1e-6 = 1e-10, against a 1e-8 tolerance.
    let (rest, frame, grid) = affine_problem();
    let energy = NaaEnergy::new(&rest, &grid, &frame, 4, 3);
    // Interior vertices moved off the axis-aligned positions in both coordinates.
    let x = vec![0.32, 0.42, 0.28, 0.73, 0.57, 0.47, 0.52, 0.68];
    let jac = energy.jacobian(&x);
    let step = 1e-6;
    let mut largest = 0.0f64;
    for col in 0..x.len() {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[col] += step;
        xm[col] -= step;
        let (rp, rm) = (energy.residuals(&xp), energy.residuals(&xm));
        for row in 0..rp.len() {
            let fd = (rp[row] - rm[row]) / (2.0 * step);
            largest = largest.max(fd.abs());
            assert!(
                (fd - jac[(row, col)]).abs() < 1e-8 * (1.0 + fd.abs()),
                "row {row} col {col}: {fd} vs {}",
                jac[(row, col)]
            );
        }
    }
    assert!(largest > 0.1, "the Jacobian is not trivially zero");
    // The normal equations are JᵀJ and Jᵀr of that Jacobian (same products, other order: 1e-12).
    let mut e = NaaEnergy::new(&rest, &grid, &frame, 4, 3);
    let ne = e.normal_equations(&x);
    let r = DVector::from_vec(energy.residuals(&x));
    assert!((&ne.jtj - jac.transpose() * &jac).abs().max() < 1e-12);
    assert!((&ne.jtr - jac.transpose() * &r).abs().max() < 1e-12);
    assert!((ne.energy - r.norm_squared()).abs() < 1e-14);
}

#[test]
fn newton_model_is_the_derivative_of_the_gradient() {
    // NaaModel::Newton hands LM JᵀJ + S, S = Σ r∇²r = ½∇²F. With component fields linear in
    // (s, t) (reproduced exactly by bilinear interpolation inside the texel-centre range, and
    // with a zero mixed derivative ∂_s∂_t J_D, the one term the model leaves out), it must
    // equal the central difference of the exact gradient Jᵀr = ½∇F column by column.
    // Truncation error ≈ step²·|∂³F| ≈ 1e-10·O(10); rounding ≈ 1e-16·|Jᵀr|/step ≈ 1e-11:
    // 1e-7 (relative to 1 + |entry|) is far above both and far below the size of S (checked
    // ≥ 1e-2 below), so a missing or wrong term of S fails.
    let (rest, frame, grid) = affine_problem();
    let mut newton = NaaEnergy::new(&rest, &grid, &frame, 4, 3).with_model(NaaModel::Newton);
    let mut gauss_newton = NaaEnergy::new(&rest, &grid, &frame, 4, 3);
    let x = vec![0.32, 0.42, 0.28, 0.73, 0.57, 0.47, 0.52, 0.68];
    let model = newton.normal_equations(&x);
    let gn = gauss_newton.normal_equations(&x);
    // Same F and Jᵀr bit for bit: only the model Hessian differs.
    assert_eq!(model.energy, gn.energy);
    assert_eq!(model.jtr, gn.jtr);
    assert!(
        (&model.jtj - &model.jtj.transpose()).abs().max() == 0.0,
        "symmetric"
    );
    let step = 1e-5;
    for col in 0..x.len() {
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[col] += step;
        xm[col] -= step;
        let (gp, gm) = (
            gauss_newton.normal_equations(&xp).jtr,
            gauss_newton.normal_equations(&xm).jtr,
        );
        for row in 0..x.len() {
            let fd = (gp[row] - gm[row]) / (2.0 * step);
            assert!(
                (fd - model.jtj[(row, col)]).abs() < 1e-7 * (1.0 + fd.abs()),
                "row {row} col {col}: {fd} vs {} (Gauss–Newton {})",
                model.jtj[(row, col)],
                gn.jtj[(row, col)]
            );
        }
    }
    let s = (&model.jtj - &gn.jtj).abs().max();
    assert!(s > 1e-2, "S is not trivially small here: {s}");
    // The adaptive model hands LM JᵀJ and S apart: the same matrices, summed in another
    // order (per cell then over cells, against over cells then added): 1e-12 relative.
    let mut adaptive = NaaEnergy::new(&rest, &grid, &frame, 4, 3).with_model(NaaModel::Adaptive);
    let apart = adaptive.normal_equations(&x);
    assert_eq!(apart.jtj, gn.jtj);
    let curvature = adaptive
        .curvature(&x)
        .expect("S after the normal equations");
    let scale = model.jtj.abs().max();
    assert!((&apart.jtj + curvature - &model.jtj).abs().max() <= 1e-12 * scale);
    assert!(adaptive.curvature(&x).is_none(), "handed over once");
    assert!(gauss_newton.curvature(&x).is_none());
}

#[test]
fn the_notes_counterexample_is_inside_its_boxes_but_has_infinite_energy() {
    // The notes' cell P00=(−0.1,−0.1), P10=(1,−1), P01=(−1,0.1), P11=(1,1) on [−1, 1]², mapped
    // onto the cell (1, 1) = [0.25, 0.5]² of a uniform 5×5 grid: centre 0.375, half-width 0.125.
    let grid = Grid::uniform(5, 5);
    let rest = flat_rest(16, Field::constant(1.0));
    let frame = DeformedJacobian::from_partials(16, plane_partials);
    let map = |p: [f64; 2]| [0.375 + 0.125 * p[0], 0.375 + 0.125 * p[1]];
    let mut v = VertexGrid::from_grid(&grid);
    v.points[v.n + 1] = map([-0.1, -0.1]); // P_11 (moved)
    v.points[2 * v.n + 1] = map([1.0, -1.0]); // P_21
    v.points[v.n + 2] = map([-1.0, 0.1]); // P_12 (moved)
    v.points[2 * v.n + 2] = map([1.0, 1.0]); // P_22
    let d = v.corner_determinants(1, 1);
    // det = −0.59 on [−1, 1]², scaled by 0.125².
    assert!((d[0] + 0.59 * 0.125 * 0.125).abs() < 1e-15, "{d:?}");
    let x = v.to_unknowns();
    let bounds = naa_bounds(&VertexGrid::from_grid(&grid), None);
    for (i, xi) in x.iter().enumerate() {
        assert!(
            bounds.lower[i] <= *xi && *xi <= bounds.upper[i],
            "unknown {i} = {xi} outside [{}, {}]",
            bounds.lower[i],
            bounds.upper[i]
        );
    }
    let mut energy = NaaEnergy::new(&rest, &grid, &frame, 2, 2);
    assert!(!v.is_valid());
    assert_eq!(energy.energy(&x), f64::INFINITY);
    // The rest grid is fine (zero energy: identity deformation of the plane).
    assert_eq!(
        energy.energy(&VertexGrid::from_grid(&grid).to_unknowns()),
        0.0
    );
}

#[test]
fn identity_deformation_gives_zero_energy_zero_iterations_and_the_same_vertices() {
    let rest = flat_rest(32, disc_rigidity(32, &[(0.3, 0.4, 0.15)], 0.1));
    let frame = DeformedJacobian::from_partials(32, plane_partials);
    let grid = Grid::new(vec![0.0, 0.2, 0.55, 1.0], vec![0.0, 0.3, 0.6, 1.0]).unwrap();
    let v = VertexGrid::from_grid(&grid);
    let s = solve_naa_frame(
        &rest,
        &grid,
        &frame,
        &v,
        &v,
        (0, 1),
        &SolveOptions::default(),
    )
    .unwrap();
    assert_eq!(s.lm.energy, 0.0);
    assert_eq!(s.lm.iterations, 0);
    assert_eq!(s.vertices, v);
}

/// A plane_stretch-like frame with the stretch varying along t too (so the vertical lines want
/// to bend), built from analytic partials.
fn bent_stretch(size: usize, sigma: f64) -> DeformedJacobian {
    DeformedJacobian::from_partials(size, move |s: f64, t: f64| {
        let ramp = (3.0 * s * s - 2.0 * s * s * s).clamp(0.0, 1.0);
        (
            Vector3::x() * (1.0 + (sigma - 1.0) * ramp * (0.5 + t)),
            Vector3::y() + Vector3::z() * (0.3 * s),
        )
    })
}

fn naa_sequence(
    rest: &RestFields,
    grid: &Grid,
    frames: &[DeformedJacobian],
    options: &SolveOptions,
    sliding: bool,
) -> Vec<NaaFrameSolution> {
    let start = VertexGrid::from_grid(grid).with_sliding_border(sliding);
    let mut out: Vec<NaaFrameSolution> = Vec::new();
    for (j, f) in frames.iter().enumerate() {
        let previous = out.last().map_or(&start, |s| &s.vertices).clone();
        out.push(
            solve_naa_frame(rest, grid, f, &previous, &start, (j, frames.len()), options).unwrap(),
        );
    }
    out
}

#[test]
fn solves_keep_every_cell_unfolded_and_lower_the_energy() {
    let rigidity = disc_rigidity(64, &[(0.7, 0.5, 0.12), (0.25, 0.3, 0.1)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let rest = flat_rest(64, rigidity);
    let frames: Vec<_> = [1.8, 2.5].iter().map(|&s| bent_stretch(64, s)).collect();
    for sliding in [false, true] {
        for naa_model in [NaaModel::GaussNewton, NaaModel::Newton, NaaModel::Adaptive] {
            let options = SolveOptions {
                naa_model,
                ..Default::default()
            };
            unfolded_and_lower(&rest, &grid, &frames, &options, sliding);
        }
    }
}

fn unfolded_and_lower(
    rest: &RestFields,
    grid: &Grid,
    frames: &[DeformedJacobian],
    options: &SolveOptions,
    sliding: bool,
) {
    let solutions = naa_sequence(rest, grid, frames, options, sliding);
    for s in &solutions {
        assert_unfolded(&s.vertices);
        assert!(
            s.lm.energy < 0.5 * s.rest_energy,
            "{} vs {}",
            s.lm.energy,
            s.rest_energy
        );
        assert!(
            s.lm.accepted_energies.windows(2).all(|w| w[1] < w[0]),
            "{:?}",
            s.lm.accepted_energies
        );
        // Border vertices never move.
        let rest_v = VertexGrid::from_grid(grid);
        for a in 0..rest_v.m {
            for b in 0..rest_v.n {
                // Border vertices stay on their edge (and fixed unless sliding).
                let (p, q) = (s.vertices.at(a, b), rest_v.at(a, b));
                if a == 0 || a == rest_v.m - 1 {
                    assert_eq!(p[0], q[0]);
                }
                if b == 0 || b == rest_v.n - 1 {
                    assert_eq!(p[1], q[1]);
                }
                if !sliding && (a == 0 || b == 0 || a == rest_v.m - 1 || b == rest_v.n - 1) {
                    assert_eq!(p, q);
                }
            }
        }
    }
    // The grid really is non-axis-aligned: some vertical line bent (its interior vertices'
    // s coordinates differ by more than rounding).
    let v = &solutions.last().unwrap().vertices;
    let bent = (1..v.m - 1).any(|a| {
        let s: Vec<f64> = (1..v.n - 1).map(|b| v.at(a, b)[0]).collect();
        s.iter().any(|x| (x - s[0]).abs() > 1e-4)
    });
    assert!(bent, "{v:?}");
}

#[test]
fn results_are_bit_identical_with_one_and_two_threads() {
    let rigidity = disc_rigidity(64, &[(0.7, 0.5, 0.12)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let rest = flat_rest(64, rigidity);
    let frames = vec![bent_stretch(64, 2.0)];
    for naa_model in [NaaModel::GaussNewton, NaaModel::Newton, NaaModel::Adaptive] {
        let options = SolveOptions {
            samples: (4, 4),
            lm: LmOptions::default(),
            naa_model,
            ..Default::default()
        };
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| naa_sequence(&rest, &grid, &frames, &options, true))
        };
        let (a, b) = (run(1), run(2));
        for (x, y) in a.iter().zip(&b) {
            assert!(x.lm.iterations > 0);
            assert_eq!(x.vertices, y.vertices, "{naa_model:?}");
            assert_eq!(x.lm.energy.to_bits(), y.lm.energy.to_bits());
        }
    }
}

#[test]
fn second_order_models_reach_the_gauss_newton_minimum_in_fewer_iterations() {
    // The saddle (the paper's nonaa-saddle scene), 6×6 lines (32 unknowns), 4×4 samples. Both
    // models run LM to the default stop (relative energy change ≤ 1e-12); Gauss–Newton
    // converges linearly with a ratio ≲ 0.5 here, so it stops within ≈ 1e-12·F of the minimum,
    // and Newton closer: the final energies agree to 1e-9 relative (a different local
    // minimum would differ by far more), in fewer Jacobian evaluations.
    let scene = scene::analytic_scene("saddle", 2).unwrap();
    let fields = scene.fields(64);
    let surface = &scene.frames[1];
    let frame = DeformedJacobian::from_partials(64, |s, t| scene::partials_of(&**surface, s, t));
    let grid = Grid::uniform(6, 6);
    let start = VertexGrid::from_grid(&grid);
    let solve = |naa_model| {
        let options = SolveOptions {
            samples: (4, 4),
            naa_model,
            ..Default::default()
        };
        solve_naa_frame(
            &fields.rest,
            &grid,
            &frame,
            &start,
            &start,
            (0, 1),
            &options,
        )
        .unwrap()
    };
    let (gn, newton, adaptive) = (
        solve(NaaModel::GaussNewton),
        solve(NaaModel::Newton),
        solve(NaaModel::Adaptive),
    );
    for s in [&gn, &newton, &adaptive] {
        assert_eq!(s.lm.stop, reparam::lm::StopCode::RelativeEnergyChange);
        assert!(s.lm.energy < 0.5 * s.rest_energy);
        assert!(s.lm.accepted_energies.windows(2).all(|w| w[1] < w[0]));
        assert_unfolded(&s.vertices);
    }
    // The adaptive model switches to JᵀJ + S once it predicts better, as it does here.
    for (name, s) in [("Newton", &newton), ("adaptive", &adaptive)] {
        assert!(
            (gn.lm.energy - s.lm.energy).abs() <= 1e-9 * gn.lm.energy,
            "{name}: {} vs {}",
            gn.lm.energy,
            s.lm.energy
        );
        assert!(
            s.lm.jacobian_evaluations < gn.lm.jacobian_evaluations,
            "{name} {} vs Gauss–Newton {} Jacobians",
            s.lm.jacobian_evaluations,
            gn.lm.jacobian_evaluations
        );
    }
}

#[test]
fn residuals_equal_the_formula_with_components_of_one_or_several_resolutions() {
    // On the rest vertices W_s = (1, 0), W_t = (0, 1) exactly, so r^s = σ(‖D_s(p)‖ − o_s) and
    // r^t = σ(‖D_t(p)‖ − o_t) at the rest sample points, each component of D sampled
    // bilinearly on its own field. Six fields of one resolution take the interleaved path, a
    // component of another resolution the field-by-field one: both give the formula's values.
    let rigidity = disc_rigidity(32, &[(0.4, 0.6, 0.2)], 0.2);
    let rest = flat_rest(32, rigidity);
    let grid = Grid::new(vec![0.0, 0.3, 0.55, 1.0], vec![0.0, 0.45, 1.0]).unwrap();
    let component = |size: usize, f: fn(f64, f64) -> f64| Field::from_fn(size, size, f);
    let jacobian = |z_size: usize| DeformedJacobian {
        d_s: VectorField {
            x: component(24, |s, t| 1.0 + 0.3 * s * t),
            y: component(24, |s, t| 0.2 * (3.0 * s).sin() + 0.1 * t),
            z: component(z_size, |s, t| 0.4 * s - 0.2 * t * t),
        },
        d_t: VectorField {
            x: component(24, |s, t| 0.1 * s * s - 0.05 * t),
            y: component(24, |s, t| 1.2 - 0.4 * t * s),
            z: component(24, |s, t| 0.3 * (2.0 * t).cos() + 0.05 * s),
        },
    };
    let (k, l) = (3, 2);
    let samples = reparam::gridwarp::energy::rest_samples(&rest, &grid, k, l);
    for z_size in [24, 17] {
        let deformed = jacobian(z_size);
        let energy = NaaEnergy::new(&rest, &grid, &deformed, k, l);
        let residuals = energy.residuals(&energy.rest_vertices().to_unknowns());
        let mut expected = Vec::new();
        let rows = grid.t.len() - 1;
        for (cell, cell_samples) in samples.chunks(k * l).enumerate() {
            let (i, j) = (cell / rows, cell % rows);
            let (h, kj) = (grid.s[i + 1] - grid.s[i], grid.t[j + 1] - grid.t[j]);
            for p in cell_samples {
                let (s, t) = (grid.s[i] + p.alpha * h, grid.t[j] + p.beta * kj);
                let length = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                expected.push(p.sigma * (length(deformed.d_s.value(s, t)) - p.o_s));
                expected.push(p.sigma * (length(deformed.d_t.value(s, t)) - p.o_t));
            }
        }
        assert_eq!(residuals.len(), expected.len());
        for (n, (r, e)) in residuals.iter().zip(&expected).enumerate() {
            // The same operations on the same values: equal up to the last bit or two.
            assert!(
                (r - e).abs() <= 4.0 * f64::EPSILON * e.abs().max(1e-300),
                "z field {z_size}², residual {n}: {r:e} vs {e:e}"
            );
        }
    }
}

#[test]
fn energy_equals_the_normal_equations_energy_bit_for_bit() {
    // As for the axis-aligned energy (tests/gridwarp.rs): lm::Speculative takes a trial's F
    // from its normal equations or from energy(), so both must agree bit for bit, for every
    // model (Gauss–Newton sums F with JᵀJ; Newton and Adaptive with the moments of S), both
    // border modes, and at a folded grid (+∞ both ways). Saddle frame: J_D far from
    // axis-aligned, R varying.
    let size = 64;
    let scene = reparam::gridwarp::scene::analytic_scene("saddle", 2).unwrap();
    let fields = scene.fields(size);
    let deformed = DeformedJacobian::from_partials(size, |s, t| {
        reparam::gridwarp::scene::partials_of(&*scene.frames[1], s, t)
    });
    let grid = Grid::uniform(6, 8);
    let mut rng = common::Rng(11);
    for sliding in [false, true] {
        let rest_vertices = VertexGrid::from_grid(&grid).with_sliding_border(sliding);
        for model in [NaaModel::GaussNewton, NaaModel::Newton, NaaModel::Adaptive] {
            for (k, l) in [(8, 8), (3, 2)] {
                let mut energy = NaaEnergy::new(&fields.rest, &grid, &deformed, k, l)
                    .with_sliding_border(sliding)
                    .with_model(model);
                for _ in 0..3 {
                    // Every coordinate moved by at most 0.15 of the smallest rest cell side
                    // (1/7): each edge keeps ≥ 70% of its length along its axis and leans by
                    // ≤ 0.043, so every corner determinant stays > 0 (checked).
                    let x: Vec<f64> = rest_vertices
                        .to_unknowns()
                        .iter()
                        .map(|v| v + rng.uniform(-0.15, 0.15) / 7.0)
                        .collect();
                    assert!(rest_vertices.with_unknowns(&x).is_valid());
                    let (e, normal) = (energy.energy(&x), energy.normal_equations(&x));
                    assert!(e > 0.0, "a non-trivial energy");
                    assert_eq!(
                        e.to_bits(),
                        normal.energy.to_bits(),
                        "{model:?} {k}×{l} sliding {sliding}: {e} vs {}",
                        normal.energy
                    );
                }
                // P_11 pushed past P_21 along s: a folded cell.
                let mut folded = rest_vertices.to_unknowns();
                folded[0] += 0.3;
                assert!(!rest_vertices.with_unknowns(&folded).is_valid());
                assert_eq!(energy.energy(&folded), f64::INFINITY);
                assert_eq!(energy.normal_equations(&folded).energy, f64::INFINITY);
            }
        }
    }
}
