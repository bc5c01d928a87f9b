//! Properties of the f64 unwarp reference (the unwarp guide's properties: flat maps stay put, gradient = differences, monotone passes),
//! thread-count independence, coarse-to-fine, the reference figures, and bad input.

mod common;

use common::Rng;
use nalgebra::{Matrix2, Matrix3x2, Vector2, Vector3};
use reparam::unwarp::energy::{
    node_energy, node_gradient, total_energy, triangle_energy, triangle_geometry,
    triangle_gradient, Fan,
};
use reparam::unwarp::fixation::{pin_energy, pin_gradient, pin_q, pin_root};
use reparam::unwarp::mesh::{Colouring, STENCIL};
use reparam::unwarp::pass::{descend_texel, pass};
use reparam::unwarp::stats::{area_ratios, max_offset_texels, triangle_sigmas};
use reparam::unwarp::{procedural, solve, Border, HeightMap, Problem, UnwarpMesh, UnwarpOptions};
use reparam::Error;

const THETA: f64 = 5.0;

fn options(scale: f64) -> UnwarpOptions {
    UnwarpOptions {
        scale,
        theta: THETA,
        ..Default::default()
    }
}

/// Run `sweeps` sweeps of phases `order` on `offsets`; the total energy after every pass.
fn run(problem: &Problem, offsets: &mut [[f64; 2]], sweeps: usize, order: &[usize]) -> Vec<f64> {
    let mut energies = vec![total_energy(problem, offsets).total()];
    for _ in 0..sweeps {
        for &phase in order {
            pass(problem, offsets, phase);
            energies.push(total_energy(problem, offsets).total());
        }
    }
    energies
}

fn zeros(problem: &Problem) -> Vec<[f64; 2]> {
    vec![[0.0; 2]; problem.mesh.node_count()]
}

/// The cones map at `size`, its problem at s = 0.08, and the offsets after `sweeps` sweeps.
fn cones_state(size: usize, sweeps: usize) -> (Problem, Vec<[f64; 2]>) {
    let problem = Problem::new(&procedural("cones", size).unwrap(), &options(0.08)).unwrap();
    let mut offsets = zeros(&problem);
    run(&problem, &mut offsets, sweeps, &[0, 1, 2, 3]);
    (problem, offsets)
}

// ---------------------------------------------------------------------------------------------
// 1. Flat maps

#[test]
fn flat_and_constant_maps_keep_offsets_exactly_zero() {
    for (w, h, value, border) in [
        (8, 8, 0.0, Border::Periodic),
        (8, 6, 0.37, Border::Periodic),
        (9, 9, 0.5, Border::Periodic), // three colours
        (7, 5, 0.02, Border::Fixed),
    ] {
        let map = HeightMap::new("flat", w, h, vec![value; w * h]).unwrap();
        let opts = UnwarpOptions {
            border,
            ..options(0.1)
        };
        let problem = Problem::new(&map, &opts).unwrap();
        let mut offsets = zeros(&problem);
        let phases: Vec<usize> = (0..problem.mesh.phase_count()).collect();
        run(&problem, &mut offsets, 5, &phases);
        assert!(
            offsets.iter().all(|o| *o == [0.0, 0.0]),
            "{w}x{h}: offsets moved"
        );
        // E_T = 2·2^θ for every triangle: each E_T is a handful of roundings (≈ 20 operations,
        // relative error ≤ 20 ε ≈ 4.4e-15) away from the exact minimum.
        let energy = total_energy(&problem, &offsets);
        let per_triangle = energy.triangles / energy.triangle_count as f64;
        let minimum = 2.0 * 2f64.powf(THETA);
        assert!(
            (per_triangle / minimum - 1.0).abs() < 20.0 * f64::EPSILON,
            "{w}x{h}: E_T = {per_triangle}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Gradient

#[test]
fn analytic_gradient_matches_central_differences() {
    // A non-trivial state: the 16² cones after 2 sweeps, plus a pinned texel pushed off 0.
    let (problem, mut offsets) = cones_state(16, 2);
    let mesh = &problem.mesh;
    let r = mesh.resolution();
    let mut rng = Rng(7);
    for o in offsets.iter_mut() {
        o[0] += rng.uniform(-0.1, 0.1) / r[0];
        o[1] += rng.uniform(-0.1, 0.1) / r[1];
    }
    let pinned = (0..mesh.node_count())
        .find(|&i| problem.pins[i] > 0.5)
        .unwrap();
    let mut worst = 0.0f64;
    for i in (0..mesh.node_count()).step_by(7).chain([pinned]) {
        let (x, y) = (i % mesh.width, i / mesh.width);
        let fan = Fan::new(mesh, &offsets, x, y);
        let o = offsets[i];
        let f = |o: [f64; 2]| node_energy(&fan, problem.pins[i], r, o, THETA);
        let g = node_gradient(&fan, problem.pins[i], r, o, THETA);
        // Step h = 1e-4 texel; errors measured against the natural gradient scale F/texel
        // (F·W in UV units). Rounding: ε·F/h = 2.2e-16·F/(1e-4 texel) = 2.2e-12 F/texel.
        // Truncation: h²/6·|F‴| with |F‴| ≲ (θ + 1)³ F/texel³ ≈ 216 F/texel³ (the area
        // factor varies like a power θ of the local scale): 1e-8/6·216 ≈ 3.6e-7 F/texel.
        let h = 1e-4 / r[0];
        let fd = [
            (f([o[0] + h, o[1]]) - f([o[0] - h, o[1]])) / (2.0 * h),
            (f([o[0], o[1] + h]) - f([o[0], o[1] - h])) / (2.0 * h),
        ];
        let err = (fd[0] - g[0]).hypot(fd[1] - g[1]) / (f(o) * r[0]);
        worst = worst.max(err);
    }
    println!("worst gradient error {worst:e} F/texel");
    // Bound: the truncation estimate 3.6e-7, rounded up.
    assert!(worst < 4e-7, "worst gradient error {worst:e} F/texel");
}

#[test]
fn pin_gradient_and_root_are_consistent() {
    let r = [32.0, 16.0];
    let (w, o, g) = (0.8, [0.01, -0.02], [3.0, 1.5]);
    let h = 1e-9;
    let fd = [
        (pin_energy(w, r, [o[0] + h, o[1]]) - pin_energy(w, r, [o[0] - h, o[1]])) / (2.0 * h),
        (pin_energy(w, r, [o[0], o[1] + h]) - pin_energy(w, r, [o[0], o[1] - h])) / (2.0 * h),
    ];
    let an = pin_gradient(w, r, o);
    // E_pin ≈ 1.1, E'' ≈ 1e4: truncation h²·E'''/6 ≈ 1e-18·1e6 negligible; rounding
    // ε·E/h ≈ 2.2e-16·1.1/1e-9 ≈ 2.4e-7 absolute on gradients of ≈ 50 → 5e-9 relative.
    for c in 0..2 {
        assert!(
            (fd[c] - an[c]).abs() < 1e-8 * an[c].abs().max(1.0),
            "{fd:?} vs {an:?}"
        );
    }
    let t = pin_root(w, r, o, g).unwrap();
    let q = pin_q(w, r, [o[0] - t * g[0], o[1] - t * g[1]]);
    // q(t) = 1 up to the rounding of a quadratic's root: a few ε.
    assert!((q - 1.0).abs() < 1e-14, "q at the root = {q}");
    assert!(pin_root(0.0, r, o, g).is_none());
}

// ---------------------------------------------------------------------------------------------
// 3. SVD form, J → J⁻¹

/// J of the affine map 3D triangle (edges p1, p2) → UV triangle (edges u1, u2), in an
/// orthonormal basis of the 3D triangle's plane.
fn jacobian(p1: [f64; 3], p2: [f64; 3], u1: [f64; 2], u2: [f64; 2]) -> Matrix2<f64> {
    let (p1v, p2v) = (Vector3::from(p1), Vector3::from(p2));
    let e1 = p1v.normalize();
    let e2 = (p2v - e1 * p2v.dot(&e1)).normalize();
    let basis = Matrix3x2::from_columns(&[e1, e2]);
    let local = Matrix2::from_columns(&[basis.transpose() * p1v, basis.transpose() * p2v]);
    let uv = Matrix2::from_columns(&[Vector2::from(u1), Vector2::from(u2)]);
    uv * local.try_inverse().unwrap()
}

#[test]
fn triangle_energy_equals_the_svd_form_and_is_inversion_invariant() {
    let mut rng = Rng(11);
    for _ in 0..200 {
        let p1 = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        ];
        let p2 = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        ];
        let u1 = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
        let mut u2 = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
        if u1[0] * u2[1] - u2[0] * u1[1] < 0.0 {
            u2 = [-u2[0], -u2[1]];
        }
        let t = triangle_geometry(p1, p2);
        let e = triangle_energy(&t, u1, u2, THETA);
        let j = jacobian(p1, p2, u1, u2);
        let s = j.singular_values();
        let (s1, s2) = (s[0].max(s[1]), s[0].min(s[1]));
        let svd = (s1 / s2 + s2 / s1) * (s1 * s2 + 1.0 / (s1 * s2)).powf(THETA);
        // Ill-conditioned triangles amplify rounding: both sides are ~40 operations on data
        // whose condition number κ = σ1/σ2 enters through the ratio (and (σ1σ2)^θ through the
        // second factor): relative error ≲ 40 ε κ^(θ+1). Skip the rare κ > 30 draws.
        if s1 / s2 > 30.0 || s1 * s2 > 30.0 || s1 * s2 < 1.0 / 30.0 {
            continue;
        }
        let kappa = (s1 / s2).max(s1 * s2).max(1.0 / (s1 * s2));
        let tol = 40.0 * f64::EPSILON * kappa.powf(THETA + 1.0);
        assert!((e / svd - 1.0).abs() < tol, "E = {e}, SVD form {svd}");
        let [ratio, product] = triangle_sigmas(&t, u1, u2);
        assert!((ratio / (s1 / s2) - 1.0).abs() < tol && (product / (s1 * s2) - 1.0).abs() < tol);
        // J → J⁻¹: swap the roles. The UV triangle lifted to z = 0 as the "3D" triangle, the
        // 3D triangle in its plane basis as the "UV" one (same orientation, since a > 0).
        let e1 = Vector3::from(p1).normalize();
        let e2 = (Vector3::from(p2) - e1 * Vector3::from(p2).dot(&e1)).normalize();
        let local = |p: [f64; 3]| [Vector3::from(p).dot(&e1), Vector3::from(p).dot(&e2)];
        let inverse = triangle_energy(
            &triangle_geometry([u1[0], u1[1], 0.0], [u2[0], u2[1], 0.0]),
            local(p1),
            local(p2),
            THETA,
        );
        assert!(
            (inverse / e - 1.0).abs() < tol,
            "E(J⁻¹) = {inverse}, E(J) = {e}"
        );
    }
}

#[test]
fn triangle_gradient_matches_central_differences() {
    let mut rng = Rng(3);
    for _ in 0..100 {
        let p1 = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        ];
        let p2 = [
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
            rng.uniform(-1.0, 1.0),
        ];
        let t = triangle_geometry(p1, p2);
        // A UV triangle close to the 3D one (moderate energy): its plane coordinates, jittered.
        let u1 = [
            p1[0] + rng.uniform(-0.1, 0.1),
            p1[1] + rng.uniform(-0.1, 0.1),
        ];
        let u2 = [
            p2[0] + rng.uniform(-0.1, 0.1),
            p2[1] + rng.uniform(-0.1, 0.1),
        ];
        if u1[0] * u2[1] - u2[0] * u1[1] < 0.2 {
            continue;
        }
        let e = |d: [f64; 2]| {
            triangle_energy(
                &t,
                [u1[0] + d[0], u1[1] + d[1]],
                [u2[0] + d[0], u2[1] + d[1]],
                THETA,
            )
        };
        let g = triangle_gradient(&t, u1, u2, THETA);
        let h = 1e-6;
        let fd = [
            (e([h, 0.0]) - e([-h, 0.0])) / (2.0 * h),
            (e([0.0, h]) - e([0.0, -h])) / (2.0 * h),
        ];
        // a ≥ 0.2 keeps E, its derivatives and |g| ≤ ~1e4·E; rounding ε·E/h ≈ 2e-10·E and
        // truncation h²·E''' ≈ 1e-12·E relative to |g| ≳ E: bound 1e-8 relative.
        let scale = g[0].hypot(g[1]).max(e([0.0, 0.0]));
        assert!(
            (fd[0] - g[0]).hypot(fd[1] - g[1]) < 1e-8 * scale,
            "{fd:?} vs {g:?}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 4, 5. Monotone energy, no fold-overs

#[test]
fn energy_never_increases_and_nothing_folds() {
    // Steep: tiles at s = 0.15 on 24², periodic, and cones with a fixed border on 21×18.
    for (map, border, scale) in [
        (procedural("tiles", 24).unwrap(), Border::Periodic, 0.15),
        (procedural("cones", 21).unwrap(), Border::Fixed, 0.1),
    ] {
        let mut opts = options(scale);
        opts.border = border;
        let map = if map.width == 21 {
            HeightMap::new("cones 21x18", 21, 18, map.values[..21 * 18].to_vec()).unwrap()
        } else {
            map
        };
        let problem = Problem::new(&map, &opts).unwrap();
        let mut offsets = zeros(&problem);
        let energies = run(&problem, &mut offsets, 8, &[0, 1, 2, 3]);
        for (p, w) in energies.windows(2).enumerate() {
            assert!(
                w[1] <= w[0],
                "{}: pass {p} raised the energy {} → {}",
                map.name,
                w[0],
                w[1]
            );
        }
        assert!(
            energies.last().unwrap() < &(0.9 * energies[0]),
            "{}: {energies:?}",
            map.name
        );
        let ratios = area_ratios(&problem, &offsets);
        let min = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(
            min > 0.0,
            "{}: a triangle folded (min a/A = {min})",
            map.name
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 6, 7. Phases

#[test]
fn same_phase_updates_in_any_order_give_identical_results() {
    let (problem, start) = cones_state(16, 1);
    for phase in 0..4 {
        let mut parallel = start.clone();
        pass(&problem, &mut parallel, phase);
        let texels = problem.mesh.active_texels(phase);
        for order in [texels.clone(), texels.iter().rev().copied().collect()] {
            // Sequential, writing each result at once (Gauss–Seidel within the phase).
            let mut sequential = start.clone();
            for &(x, y) in &order {
                let o = descend_texel(&problem, &sequential, x, y);
                sequential[problem.mesh.index(x, y)] = o;
            }
            assert_eq!(sequential, parallel, "phase {phase}");
        }
        // Pass p changes only texels of phase p (and some of them).
        let mut changed = 0;
        for i in 0..start.len() {
            let (x, y) = (i % 16, i / 16);
            if parallel[i] != start[i] {
                assert_eq!(problem.mesh.phase_of(x, y), phase);
                changed += 1;
            }
        }
        assert!(changed > 0, "phase {phase} moved nothing");
    }
}

#[test]
fn phases_cover_every_free_texel_once_and_never_hold_neighbours() {
    for (w, h, border, colouring) in [
        (8, 6, Border::Periodic, Colouring::Quads),
        (9, 12, Border::Periodic, Colouring::Diagonal3),
        (7, 5, Border::Fixed, Colouring::Quads),
    ] {
        let map = HeightMap::new("m", w, h, vec![0.0; w * h]).unwrap();
        let mesh = UnwarpMesh::new(&map, 0.1, border).unwrap();
        assert_eq!(mesh.colouring, colouring);
        let mut count = vec![0; w * h];
        for phase in 0..mesh.phase_count() {
            for (x, y) in mesh.active_texels(phase) {
                count[mesh.index(x, y)] += 1;
                for k in 0..6 {
                    let n = mesh.neighbour(x, y, k).unwrap();
                    let (nx, ny) = (n % w, n / w);
                    assert_ne!(
                        mesh.phase_of(nx, ny),
                        phase,
                        "{w}x{h}: ({x},{y}) and its neighbour {k}"
                    );
                }
            }
        }
        for (i, &c) in count.iter().enumerate() {
            let free = mesh.is_free(i % w, i / w);
            assert_eq!(c, usize::from(free), "{w}x{h}: texel {i}");
        }
    }
    assert_eq!(STENCIL.len(), 6);
}

#[test]
fn rolling_by_even_texels_rolls_the_offsets_exactly() {
    let map = procedural("cobbles", 16).unwrap();
    let rolled = map.rolled(2, 4);
    let solve_map = |m: &HeightMap| {
        let problem = Problem::new(m, &options(0.1)).unwrap();
        let mut o = zeros(&problem);
        run(&problem, &mut o, 3, &[0, 1, 2, 3]);
        o
    };
    let (a, b) = (solve_map(&map), solve_map(&rolled));
    for y in 0..16 {
        for x in 0..16 {
            assert_eq!(
                b[((y + 4) % 16) * 16 + (x + 2) % 16],
                a[y * 16 + x],
                "texel ({x},{y})"
            );
        }
    }
}

#[test]
fn transposing_the_map_transposes_the_offsets() {
    let map = HeightMap::new(
        "cones 16x12",
        16,
        12,
        procedural("cones", 16).unwrap().values[..16 * 12].to_vec(),
    )
    .unwrap();
    let opts = options(0.08);
    let (p, pt) = (
        Problem::new(&map, &opts).unwrap(),
        Problem::new(&map.transposed(), &opts).unwrap(),
    );
    let (mut a, mut b) = (zeros(&p), zeros(&pt));
    // Transposing swaps phases 1 and 2.
    run(&p, &mut a, 3, &[0, 1, 2, 3]);
    run(&pt, &mut b, 3, &[0, 2, 1, 3]);
    // Not bit-exact: the transposed fan sums its six triangles and the three terms of D in
    // another order (rounding ~1e-16 relative). A flipped comparison in the ternary search moves
    // a texel by at most the final bracket width, 1e-6 of a bracket ≲ 1 texel, and the
    // descent is contractive, so after 12 passes the difference stays ≲ 12·1e-6 texel.
    let mut worst = 0.0f64;
    for y in 0..12 {
        for x in 0..16 {
            let (o, ot) = (a[y * 16 + x], b[x * 12 + y]);
            worst = worst
                .max(((o[0] - ot[1]) * 16.0).abs())
                .max(((o[1] - ot[0]) * 12.0).abs());
        }
    }
    assert!(worst < 12e-6, "worst difference {worst:e} texels");
    assert!(max_offset_texels(&p.mesh, &a) > 0.05, "nothing moved");
}

// ---------------------------------------------------------------------------------------------
// 8. Pins

#[test]
fn pinned_texels_stay_within_one_over_w_texels() {
    let map = procedural("cones", 48).unwrap();
    let mut opts = options(0.3);
    // Pin the middle of the cone flanks, where the unpinned offsets are largest.
    opts.fixation.h_fix = 0.5;
    opts.fixation.delta = 0.6;
    let problem = Problem::new(&map, &opts).unwrap();
    let mut offsets = zeros(&problem);
    run(&problem, &mut offsets, 15, &[0, 1, 2, 3]);
    let r = problem.mesh.resolution();
    let mut tested = 0;
    for (i, o) in offsets.iter().enumerate() {
        let w = problem.pins[i];
        if w > 0.0 {
            let texels = (r[0] * o[0]).hypot(r[1] * o[1]);
            assert!(
                texels * w < 1.0,
                "texel {i}: w = {w}, moved {texels} texels"
            );
            tested += 1;
        }
    }
    assert!(tested > 50);
    // Without pins the same texels move further than the strongest pins allow.
    let mut free_opts = opts.clone();
    free_opts.fixation.delta = 0.0;
    let free = Problem::new(&map, &free_opts).unwrap();
    let mut free_offsets = zeros(&free);
    run(&free, &mut free_offsets, 15, &[0, 1, 2, 3]);
    let escaped = (0..offsets.len())
        .filter(|&i| problem.pins[i] > 0.0)
        .map(|i| problem.pins[i] * (r[0] * free_offsets[i][0]).hypot(r[1] * free_offsets[i][1]))
        .fold(0.0, f64::max);
    println!("unpinned: max w·|o| = {escaped} texels");
    assert!(escaped > 1.0, "the pins never mattered on this map");
}

#[test]
fn a_painted_mask_pins_texels() {
    let map = procedural("bumps", 16).unwrap();
    let mut opts = options(0.1);
    opts.fixation.delta = 0.0;
    opts.fixation.mask = Some(reparam::texture::Image::from_fn(16, 16, |x, _| {
        if x < 8 {
            1.0
        } else {
            0.0
        }
    }));
    let problem = Problem::new(&map, &opts).unwrap();
    let mut offsets = zeros(&problem);
    run(&problem, &mut offsets, 4, &[0, 1, 2, 3]);
    for (i, o) in offsets.iter().enumerate() {
        if i % 16 < 8 {
            assert!(
                (16.0 * o[0]).hypot(16.0 * o[1]) < 1.0,
                "masked texel {i} moved {o:?}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 9. Jacobi

#[test]
fn jacobi_updates_raise_the_energy_where_phases_do_not() {
    // Steep cones: every texel updated at once from the same state (test-only Jacobi variant).
    let problem = Problem::new(&procedural("cones", 16).unwrap(), &options(0.25)).unwrap();
    let mesh = &problem.mesh;
    let mut jacobi = zeros(&problem);
    let start = total_energy(&problem, &jacobi).total();
    let mut jacobi_energy = vec![start];
    for _ in 0..6 {
        jacobi = (0..mesh.node_count())
            .map(|i| descend_texel(&problem, &jacobi, i % mesh.width, i / mesh.width))
            .collect();
        jacobi_energy.push(total_energy(&problem, &jacobi).total());
    }
    let raised = jacobi_energy
        .windows(2)
        .any(|w| w[1] > w[0] || w[1].is_nan());
    assert!(raised, "Jacobi stayed monotone: {jacobi_energy:?}");
    let mut phased = zeros(&problem);
    let energies = run(&problem, &mut phased, 6, &[0, 1, 2, 3]);
    assert!(energies.windows(2).all(|w| w[1] <= w[0]));
}

// ---------------------------------------------------------------------------------------------
// Determinism, coarse-to-fine, reference figures

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let map = procedural("cones", 32).unwrap();
    let opts = UnwarpOptions {
        scale: 0.08,
        sweeps: 3,
        levels: 2,
        coarse_sweeps: 3,
        ..Default::default()
    };
    let solve_in =
        |threads: usize| common::in_pool(threads, || solve(&map, &opts, |_| {}).unwrap());
    let (one, two) = (solve_in(1), solve_in(2));
    assert_eq!(one.offsets, two.offsets);
    for (a, b) in one.levels.iter().zip(&two.levels) {
        assert_eq!(a.energy_per_pass, b.energy_per_pass);
    }
}

#[test]
fn coarse_to_fine_is_never_worse_than_single_level_at_equal_fine_passes() {
    let map = procedural("cones", 32).unwrap();
    let single = UnwarpOptions {
        scale: 0.08,
        sweeps: 10,
        ..Default::default()
    };
    let c2f = UnwarpOptions {
        levels: 2,
        coarse_sweeps: 10,
        ..single.clone()
    };
    let (a, b) = (
        solve(&map, &single, |_| {}).unwrap(),
        solve(&map, &c2f, |_| {}).unwrap(),
    );
    assert_eq!(b.levels.len(), 2);
    let (ea, eb) = (&a.fine().energy_per_pass, &b.fine().energy_per_pass);
    assert_eq!(ea.len(), eb.len());
    for p in 0..ea.len() {
        assert!(
            eb[p].total() <= ea[p].total(),
            "pass {p}: c2f {} > single {}",
            eb[p].total(),
            ea[p].total()
        );
    }
}

#[test]
fn progress_is_reported_after_every_sweep() {
    let map = procedural("bumps", 16).unwrap();
    let opts = UnwarpOptions {
        sweeps: 3,
        levels: 2,
        coarse_sweeps: 2,
        ..Default::default()
    };
    let mut seen = Vec::new();
    let solution = solve(&map, &opts, |p| seen.push((p.level, p.sweep))).unwrap();
    assert_eq!(seen, vec![(1, 1), (1, 2), (0, 1), (0, 2), (0, 3)]);
    assert_eq!(solution.fine().passes, 12);
    // A tolerance stops early: with 1.0 (100 %) every level stops after its first sweep.
    let early = solve(
        &map,
        &UnwarpOptions {
            tolerance: Some(1.0),
            ..opts
        },
        |_| {},
    )
    .unwrap();
    assert_eq!(early.fine().passes, 4);
}

/// The notes' reference figures (NumPy re-statement, "six clipped cones", 64² periodic,
/// s = 0.08, θ = 5), reproduced on our reconstruction of their map (`procedural("cones")`,
/// see its doc: two parameters fitted to the two figures that depend on the map alone, the
/// pass-0 energy ratio and the sweep-0 CV).
///
/// The notes do not say whether their run pins texels; their figures match an unpinned run
/// (Δ = 0) and not a pinned one (with the default Δ = 0.04 the energy stalls at 1.092 after
/// 240 passes, notes 1.077, and the largest offset stays at 1.32 texels, notes 1.6), so the
/// run here is unpinned.
///
/// Tolerances: the reconstructed map reproduces the pass-0 figure to 1.2 % (the resolution of
/// the fit), so no later figure can be expected closer than that; 2 % on the energy ratios and
/// the early CVs allows that offset plus the notes' rounding to 3 digits. The notes give the
/// largest offset to 2 digits (1.6): ours must round to it. Two figures are NOT reproduced and
/// only printed: the CV after 30 and 120 sweeps (notes 0.101 and 0.070, ours ≈ 0.083 and
/// 0.059: a more uniform result than theirs at the same energy; the notes do not define
/// their CV's population precisely enough to say why). Ours are also pinned to 3 digits as a
/// regression check.
#[test]
fn reference_figures_on_the_six_clipped_cones() {
    let map = procedural("cones", 64).unwrap();
    let mut opts = options(0.08);
    opts.fixation.delta = 0.0;
    let problem = Problem::new(&map, &opts).unwrap();
    let mut offsets = vec![[0.0; 2]; 64 * 64];
    let ratio = |o: &[[f64; 2]]| total_energy(&problem, o).ratio(THETA);
    let cv = |o: &[[f64; 2]]| {
        reparam::unwarp::stats::coefficient_of_variation(&area_ratios(&problem, o))
    };
    let mut energy = vec![ratio(&offsets)];
    let (mut cvs, mut max_at_60) = (vec![(0, cv(&offsets))], 0.0);
    for sweep in 1..=120 {
        for phase in 0..4 {
            pass(&problem, &mut offsets, phase);
            if energy.len() <= 240 {
                energy.push(ratio(&offsets));
            }
        }
        if [5, 30, 120].contains(&sweep) {
            cvs.push((sweep, cv(&offsets)));
        }
        if sweep == 60 {
            max_at_60 = max_offset_texels(&problem.mesh, &offsets);
        }
    }
    let notes_energy = [
        (0, 2.577),
        (4, 1.336),
        (8, 1.219),
        (20, 1.139),
        (40, 1.109),
        (80, 1.093),
        (160, 1.082),
        (240, 1.077),
    ];
    let notes_cv = [0.178, 0.137, 0.101, 0.070];
    println!("pass | notes | ours");
    for &(p, n) in &notes_energy {
        println!("{p} | {n} | {:.4}", energy[p]);
    }
    for (&(sweep, ours), n) in cvs.iter().zip(notes_cv) {
        println!("CV sweep {sweep}: notes {n}, ours {ours:.4}");
    }
    println!("max |o| after 60 sweeps: notes 1.6, ours {max_at_60:.3} texels");
    for &(p, n) in &notes_energy {
        let rel = (energy[p] - n).abs() / n;
        assert!(rel < 0.02, "pass {p}: ours {} notes {n}", energy[p]);
    }
    for (&(sweep, ours), n) in cvs.iter().zip(notes_cv).take(2) {
        assert!(
            (ours - n).abs() / n < 0.02,
            "CV sweep {sweep}: ours {ours} notes {n}"
        );
    }
    assert!((1.55..1.65).contains(&max_at_60), "max offset {max_at_60}");
    let pinned: Vec<f64> = notes_energy
        .iter()
        .map(|&(p, _)| (energy[p] * 1000.0).round() / 1000.0)
        .chain(cvs.iter().map(|&(_, c)| (c * 1000.0).round() / 1000.0))
        .collect();
    assert_eq!(
        pinned,
        vec![2.607, 1.347, 1.224, 1.146, 1.117, 1.095, 1.084, 1.081, 0.177, 0.138, 0.083, 0.059]
    );
}

// ---------------------------------------------------------------------------------------------
// Bad input

#[test]
fn bad_sizes_and_values_are_typed_errors() {
    assert!(matches!(
        HeightMap::new("e", 0, 0, vec![]),
        Err(Error::HeightMapSize { .. })
    ));
    assert!(matches!(
        HeightMap::new("e", 3, 3, vec![0.0; 8]),
        Err(Error::HeightMapSize { .. })
    ));
    let nan = HeightMap::new("nan.png", 4, 4, {
        let mut v = vec![0.0; 16];
        v[6] = f64::NAN;
        v
    });
    assert!(
        matches!(nan, Err(Error::NonFiniteHeight { x: 2, y: 1, .. })),
        "{nan:?}"
    );
    let one = HeightMap::new("one", 1, 1, vec![0.5]).unwrap();
    for border in [Border::Periodic, Border::Fixed] {
        let opts = UnwarpOptions {
            border,
            ..Default::default()
        };
        assert!(matches!(
            solve(&one, &opts, |_| {}),
            Err(Error::HeightMapSize { .. })
        ));
    }
    // Odd, not a multiple of 3, periodic: no colouring. Fixed border: fine.
    let odd = HeightMap::new("odd", 5, 7, vec![0.1; 35]).unwrap();
    let err = solve(&odd, &UnwarpOptions::default(), |_| {}).unwrap_err();
    assert!(
        matches!(
            err,
            Error::HeightMapSize {
                width: 5,
                height: 7,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("odd"));
    let fixed = UnwarpOptions {
        border: Border::Fixed,
        sweeps: 1,
        ..Default::default()
    };
    assert!(solve(&odd, &fixed, |_| {}).is_ok());
    assert!(matches!(
        solve(
            &procedural("cones", 8).unwrap(),
            &UnwarpOptions {
                theta: f64::NAN,
                ..Default::default()
            },
            |_| {}
        ),
        Err(Error::InvalidArgument(_))
    ));
    assert!(matches!(
        procedural("nope", 8),
        Err(Error::InvalidArgument(_))
    ));
    let mut masked = UnwarpOptions::default();
    masked.fixation.mask = Some(reparam::texture::Image::new(4, 4, 1.0));
    assert!(matches!(
        solve(&procedural("cones", 8).unwrap(), &masked, |_| {}),
        Err(Error::HeightMapSize { .. })
    ));
    masked.fixation.mask = Some(reparam::texture::Image::new(8, 8, f32::NAN));
    assert!(matches!(
        solve(&procedural("cones", 8).unwrap(), &masked, |_| {}),
        Err(Error::NonFiniteHeight { .. })
    ));
}

#[test]
fn non_power_of_two_and_three_colour_sizes_descend() {
    for (w, h) in [(6, 10), (9, 9), (12, 9)] {
        let values = (0..w * h)
            .map(|i| (((i % w) as f64 * 0.9).sin() * ((i / w) as f64 * 0.7).cos()).abs())
            .collect();
        let map = HeightMap::new(format!("{w}x{h}"), w, h, values).unwrap();
        let problem = Problem::new(&map, &options(0.1)).unwrap();
        let mut offsets = zeros(&problem);
        let phases: Vec<usize> = (0..problem.mesh.phase_count()).collect();
        let energies = run(&problem, &mut offsets, 3, &phases);
        assert!(
            energies.windows(2).all(|e| e[1] <= e[0]) && energies.last() < energies.first(),
            "{w}x{h}"
        );
    }
}

#[test]
fn height_files_load_or_fail_with_typed_errors() {
    use reparam::unwarp::load_height_map;
    let dir = tempfile::tempdir().unwrap();
    // 16-bit PNG: values x/65535 exactly (as f32).
    let p16 = dir.path().join("h16.png");
    image::ImageBuffer::<image::Luma<u16>, _>::from_fn(6, 4, |x, y| {
        image::Luma([(x * 10000 + y * 7) as u16])
    })
    .save(&p16)
    .unwrap();
    let map = load_height_map(&p16).unwrap();
    assert_eq!((map.width, map.height), (6, 4));
    assert_eq!(map.get(3, 2), (30014.0f32 / 65535.0) as f64);
    // 8-bit PNG.
    let p8 = dir.path().join("h8.png");
    image::GrayImage::from_fn(4, 4, |x, _| image::Luma([(x * 50) as u8]))
        .save(&p8)
        .unwrap();
    assert_eq!(
        load_height_map(&p8).unwrap().get(2, 0),
        (100.0f32 / 255.0) as f64
    );
    // Float EXR (channel R), values kept raw, NaN rejected with its texel.
    let exr = dir.path().join("h.exr");
    reparam::texture::save_exr_rg(
        &exr,
        2,
        2,
        &[[0.25, 0.0], [2.5, 0.0], [-1.0, 0.0], [0.0, 0.0]],
    )
    .unwrap();
    assert_eq!(
        load_height_map(&exr).unwrap().values,
        vec![0.25, 2.5, -1.0, 0.0]
    );
    let nan = dir.path().join("nan.exr");
    reparam::texture::save_exr_rg(
        &nan,
        2,
        2,
        &[[0.0, 0.0], [0.0, 0.0], [0.0, 0.0], [f32::NAN, 0.0]],
    )
    .unwrap();
    assert!(matches!(
        load_height_map(&nan),
        Err(Error::NonFiniteHeight { x: 1, y: 1, .. })
    ));
    // Missing and unreadable files.
    assert!(matches!(
        load_height_map(&dir.path().join("missing.png")),
        Err(Error::Io { .. } | Error::Image { .. })
    ));
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"not a png").unwrap();
    assert!(matches!(
        load_height_map(&junk),
        Err(Error::Image { .. } | Error::Io { .. })
    ));
}

// ---------------------------------------------------------------------------------------------
// Outputs and the command line

#[test]
fn mip_chain_box_averages_and_zero_offsets_bake_the_identity() {
    use reparam::unwarp::output::{bake_prewarped, offset_mip_chain, offset_to_uv, sample_offset};
    let offsets: Vec<[f64; 2]> = (0..16).map(|i| [i as f64, -(i as f64) * 0.5]).collect();
    let chain = offset_mip_chain(4, 4, &offsets);
    assert_eq!(
        chain
            .iter()
            .map(|l| (l.width, l.height))
            .collect::<Vec<_>>(),
        vec![(4, 4), (2, 2), (1, 1)]
    );
    // Level 1 texel (1, 0) averages texels (2, 0), (3, 0), (2, 1), (3, 1) = 2, 3, 6, 7.
    assert_eq!(chain[1].offsets[1], [4.5, -2.25]);
    assert_eq!(chain[2].offsets[0], [7.5, -3.75]);
    assert_eq!(offset_to_uv([0.25, 0.5]), [0.25, -0.5]);
    // Sampling at a texel centre returns that texel (OBJ v: row y at v = 1 − (y + ½)/H).
    let map = HeightMap::new("m", 4, 4, vec![0.0; 16]).unwrap();
    let mesh = UnwarpMesh::new(&map, 0.1, Border::Periodic).unwrap();
    assert_eq!(
        sample_offset(
            &mesh,
            &offsets,
            [(2.0 + 0.5) / 4.0, 1.0 - (1.0 + 0.5) / 4.0]
        ),
        offsets[6]
    );
    let texture = reparam::texture::uv_grid_texture(64);
    assert_eq!(
        bake_prewarped(&texture, &mesh, &vec![[0.0; 2]; 16]),
        texture
    );
    // A uniform offset of one texture texel in u shifts the baked texture by one texel.
    let shifted = bake_prewarped(&texture, &mesh, &vec![[1.0 / 64.0, 0.0]; 16]);
    assert_eq!(shifted.get(10, 20), texture.get(11, 20));
}

#[test]
fn the_command_writes_outputs_and_json_for_procedural_and_png_maps() {
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_reparam"))
            .args(args)
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let out1 = dir.path().join("a");
    let (ok, stdout, stderr) = run(&[
        "unwarp",
        "--procedural",
        "bumps",
        "--size",
        "16",
        "--sweeps",
        "2",
        "--levels",
        "2",
        "--coarse-sweeps",
        "1",
        "--out",
        out1.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let per_sweep = v["energy_ratio_per_sweep"].as_array().unwrap();
    assert_eq!(per_sweep.len(), 3);
    assert!(
        v["final_energy_ratio"].as_f64().unwrap() < v["initial_energy_ratio"].as_f64().unwrap()
    );
    assert!(
        v["area_ratio_cv_after"].as_f64().unwrap() < v["area_ratio_cv_before"].as_f64().unwrap()
    );
    for file in [
        "offsets.exr",
        "offsets_mip1.exr",
        "prewarped.png",
        "surface_checker.png",
        "energy.png",
        "distortion_area.png",
    ] {
        assert!(out1.join(file).exists(), "{file}");
    }
    // A user PNG height map, fixed border, odd size, a pin mask.
    let png = dir.path().join("h.png");
    image::GrayImage::from_fn(13, 11, |x, y| {
        image::Luma([((x * 19 + y * 7) % 64 * 4) as u8])
    })
    .save(&png)
    .unwrap();
    let mask = dir.path().join("pin.png");
    image::GrayImage::from_fn(13, 11, |x, _| image::Luma([if x < 3 { 255 } else { 0 }]))
        .save(&mask)
        .unwrap();
    let out2 = dir.path().join("b");
    let (ok, stdout, stderr) = run(&[
        "unwarp",
        png.to_str().unwrap(),
        "--border",
        "fixed",
        "--sweeps",
        "2",
        "--pin",
        mask.to_str().unwrap(),
        "--coarse-moves",
        "2",
        "--out",
        out2.to_str().unwrap(),
        "--json",
    ]);
    assert!(ok, "{stderr}");
    // Coarse moves on an odd map with a fixed border: r = 2 and 4, four phases each, per sweep.
    let v: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(v["coarse_passes"].as_u64(), Some(2 * 2 * 4));
    let per_sweep: Vec<f64> = v["energy_ratio_per_sweep"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_f64().unwrap())
        .collect();
    assert!(per_sweep.windows(2).all(|w| w[1] <= w[0]), "{per_sweep:?}");
    // Bad input: a clear error, no panic.
    let (ok, _, stderr) = run(&[
        "unwarp",
        png.to_str().unwrap(),
        "--out",
        out2.to_str().unwrap(),
    ]);
    assert!(
        !ok && stderr.contains("13x11") && !stderr.contains("panicked"),
        "{stderr}"
    );
    let (ok, _, stderr) = run(&["unwarp", dir.path().join("missing.png").to_str().unwrap()]);
    assert!(
        !ok && stderr.contains("missing.png") && !stderr.contains("panicked"),
        "{stderr}"
    );
}

#[test]
fn a_folded_start_is_repaired_locally() {
    use reparam::unwarp::solve::repair_start;
    let problem = Problem::new(&procedural("bumps", 16).unwrap(), &options(0.05)).unwrap();
    let mut offsets = zeros(&problem);
    // Push texel (5, 5) three texels right: over its neighbour, folding its fan.
    offsets[problem.mesh.index(5, 5)] = [3.0 / 16.0, 0.0];
    assert!(area_ratios(&problem, &offsets).iter().any(|&r| r <= 0.0));
    let rounds = repair_start(&problem, &mut offsets);
    assert!((1..30).contains(&rounds), "{rounds} rounds");
    assert!(area_ratios(&problem, &offsets).iter().all(|&r| r > 0.0));
    // Only the folded corners moved: (5, 5) toward 0, far texels untouched (still 0).
    let o = offsets[problem.mesh.index(5, 5)][0] * 16.0;
    assert!(o > 0.0 && o < 3.0, "{o}");
    assert!(total_energy(&problem, &offsets).total().is_finite());
}
