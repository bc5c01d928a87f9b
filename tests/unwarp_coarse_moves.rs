//! The coarse moves of `unwarp::coarse_move` (hat-weighted block steps on the finest level's
//! energy): their line polynomials and gradient against the direct formulas, monotone energy,
//! no folds, pins kept, phase independence, thread-count independence, flat maps, and the
//! convergence they buy.

mod common;

use common::Rng;
use reparam::unwarp::coarse_move::{
    block_centres, block_gradient, coarse_pass, coarse_scales, Block, LineTriangle, TriangleTable,
    COARSE_PHASES, COARSE_SEARCH_RELATIVE_WIDTH,
};
use reparam::unwarp::energy::{integer_power, total_energy, triangle_energy};
use reparam::unwarp::fixation::{pin_energy, pin_q};
use reparam::unwarp::pass::pass;
use reparam::unwarp::stats::area_ratios;
use reparam::unwarp::{procedural, solve, Border, HeightMap, Problem, UnwarpOptions};

fn options(scale: f64) -> UnwarpOptions {
    UnwarpOptions {
        scale,
        ..Default::default()
    }
}

/// The cones map at `size` (s = 0.08) and its offsets after `sweeps` texel sweeps: a state
/// with real, non-zero offsets.
fn cones_state(size: usize, sweeps: usize) -> (Problem, Vec<[f64; 2]>) {
    let problem = Problem::new(&procedural("cones", size).unwrap(), &options(0.08)).unwrap();
    let mut offsets = vec![[0.0; 2]; problem.mesh.node_count()];
    for _ in 0..sweeps {
        for phase in 0..4 {
            pass(&problem, &mut offsets, phase);
        }
    }
    (problem, offsets)
}

/// The cones cut to 21×18 with a fixed border at scale `scale`: odd sizes, border nodes fixed.
fn fixed_border_cones(scale: f64) -> Problem {
    let mut opts = options(scale);
    opts.border = Border::Fixed;
    let map = HeightMap::new(
        "cones 21x18",
        21,
        18,
        procedural("cones", 21).unwrap().values[..21 * 18].to_vec(),
    )
    .unwrap();
    Problem::new(&map, &opts).unwrap()
}

/// `offsets` with every node n of `block` moved by w_n δ.
fn moved(offsets: &[[f64; 2]], block: &Block, delta: [f64; 2]) -> Vec<[f64; 2]> {
    let mut out = offsets.to_vec();
    for &(n, w) in &block.nodes {
        out[n] = [out[n][0] + w * delta[0], out[n][1] + w * delta[1]];
    }
    out
}

/// Σ E_T over the block's triangles + Σ E_pin over its nodes, from the direct formulas.
fn block_energy(problem: &Problem, table: &TriangleTable, block: &Block, o: &[[f64; 2]]) -> f64 {
    let triangles: f64 = block
        .triangles
        .iter()
        .map(|&(i, _)| {
            let t = table.triangles[i].as_ref().unwrap();
            let (u1, u2) = t.uv_edges(o);
            triangle_energy(&t.geometry, u1, u2, problem.theta)
        })
        .sum();
    let pins: f64 = block
        .nodes
        .iter()
        .map(|&(n, _)| pin_energy(problem.pins[n], problem.pin_resolution, o[n]))
        .sum();
    triangles + pins
}

#[test]
fn integer_power_matches_powi_bit_for_bit() {
    let mut rng = Rng(11);
    for _ in 0..200 {
        let y = rng.uniform(0.01, 20.0);
        for n in -64..=64 {
            assert_eq!(
                integer_power(y, n).to_bits(),
                y.powi(n).to_bits(),
                "{y}^{n}"
            );
        }
    }
}

#[test]
fn line_triangles_equal_the_energies_of_the_moved_offsets() {
    let (problem, offsets) = cones_state(32, 2);
    let table = TriangleTable::new(&problem.mesh);
    let mut rng = Rng(5);
    for r in [2, 4, 8] {
        for centre in [(0, 0), (8, 16), (24, 8)] {
            let block = Block::new(&problem.mesh, &table, r, centre);
            let g = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
            // A step of at most a fifth of a texel: no triangle folds.
            let t = rng.uniform(0.0, 0.2) / 32.0 / g[0].hypot(g[1]);
            let after = moved(&offsets, &block, [-t * g[0], -t * g[1]]);
            for &(i, weights) in &block.triangles {
                let tri = table.triangles[i].as_ref().unwrap();
                let line = LineTriangle::new(&tri.geometry, tri.uv_edges(&offsets), weights, g);
                let (u1, u2) = tri.uv_edges(&after);
                let direct = triangle_energy(&tri.geometry, u1, u2, problem.theta);
                // D(t) expanded in powers of t and a(t) = a₀ − t a₁ against the moved edges:
                // the same products regrouped, a few ε of the terms |U|², |t e G|² ≲ |U|²
                // relative (no cancellation at a fifth of a texel); y^θ with θ = 5 multiplies
                // the relative error of a by at most ~θ + 2. Bound 1e−12 relative.
                let e = line.energy(t, problem.theta);
                assert!(
                    (e - direct).abs() <= 1e-12 * direct,
                    "r {r} triangle {i}: {e} vs {direct}"
                );
            }
        }
    }
}

#[test]
fn block_gradient_matches_central_differences() {
    let (problem, offsets) = cones_state(32, 3);
    let table = TriangleTable::new(&problem.mesh);
    for r in [2, 4, 8] {
        for centre in [(0, 0), (16, 8), (8, 24)] {
            let block = Block::new(&problem.mesh, &table, r, centre);
            let g = block_gradient(&problem, &table, &offsets, &block);
            // h = 1e−7 UV (1/300 000 of a texel at 32²): truncation h²·E''' and rounding
            // ε·E/h, E ≈ 8r²·64·(ratio ≈ 1.2) ≤ 8·10⁴ for r = 8: ε·E/h ≲ 2e−4, against
            // |G| ≳ 10² here: bound 1e−5 of |G| plus 1e−3 absolute.
            let h = 1e-7;
            let e =
                |d: [f64; 2]| block_energy(&problem, &table, &block, &moved(&offsets, &block, d));
            let fd = [
                (e([h, 0.0]) - e([-h, 0.0])) / (2.0 * h),
                (e([0.0, h]) - e([0.0, -h])) / (2.0 * h),
            ];
            let err = (fd[0] - g[0]).hypot(fd[1] - g[1]);
            assert!(
                err <= 1e-5 * g[0].hypot(g[1]) + 1e-3,
                "r {r} centre {centre:?}: G {g:?} vs differences {fd:?}"
            );
        }
    }
}

#[test]
fn blocks_of_one_phase_share_no_triangle_and_every_node_is_in_a_hat() {
    let periodic = Problem::new(&procedural("cones", 32).unwrap(), &options(0.08)).unwrap();
    let fixed = fixed_border_cones(0.08);
    for problem in [&periodic, &fixed] {
        let mesh = &problem.mesh;
        let table = TriangleTable::new(mesh);
        let scales = coarse_scales(mesh, 4);
        assert!(!scales.is_empty());
        for &r in &scales {
            let mut covered = vec![false; mesh.node_count()];
            for phase in 0..COARSE_PHASES {
                let mut owner = vec![usize::MAX; table.triangles.len()];
                for (b, &centre) in block_centres(mesh, r, phase).iter().enumerate() {
                    let block = Block::new(mesh, &table, r, centre);
                    for &(i, _) in &block.triangles {
                        assert!(
                            owner[i] == usize::MAX,
                            "{}×{} r {r} phase {phase}: triangle {i} in blocks {} and {b}",
                            mesh.width,
                            mesh.height,
                            owner[i]
                        );
                        owner[i] = b;
                    }
                    // Every triangle with a moving corner is listed.
                    for &(n, w) in &block.nodes {
                        assert!(w > 0.0 && w <= 1.0);
                        covered[n] = true;
                    }
                }
            }
            for (n, c) in covered.iter().enumerate() {
                let (x, y) = (n % mesh.width, n / mesh.width);
                assert_eq!(*c, mesh.is_free(x, y), "r {r}: node ({x}, {y})");
            }
        }
    }
}

#[test]
fn every_triangle_touching_a_moving_node_is_in_its_block() {
    let (problem, _) = cones_state(32, 0);
    let mesh = &problem.mesh;
    let table = TriangleTable::new(mesh);
    for r in [2, 4] {
        let block = Block::new(mesh, &table, r, (r, 3 * r));
        let listed: std::collections::HashSet<usize> =
            block.triangles.iter().map(|&(i, _)| i).collect();
        let moving: std::collections::HashSet<usize> =
            block.nodes.iter().map(|&(n, _)| n).collect();
        for (i, t) in table.triangles.iter().enumerate() {
            let t = t.as_ref().unwrap();
            let touches = t.corners.iter().any(|c| moving.contains(c));
            assert_eq!(touches, listed.contains(&i), "r {r}: triangle {i}");
        }
        // The listed corner weights are the nodes' hat weights (0 for the others).
        for &(i, weights) in &block.triangles {
            let t = table.triangles[i].as_ref().unwrap();
            for (c, w) in t.corners.iter().zip(weights) {
                let expected = block
                    .nodes
                    .iter()
                    .find(|(n, _)| n == c)
                    .map_or(0.0, |m| m.1);
                assert_eq!(w, expected);
            }
        }
    }
}

#[test]
fn coarse_passes_never_raise_the_energy_fold_nothing_and_keep_pins() {
    for problem in [
        Problem::new(&procedural("tiles", 24).unwrap(), &options(0.15)).unwrap(),
        Problem::new(&procedural("cones", 32).unwrap(), &options(0.08)).unwrap(),
        fixed_border_cones(0.1),
    ] {
        let mesh = &problem.mesh;
        let table = TriangleTable::new(mesh);
        let mut offsets = vec![[0.0; 2]; mesh.node_count()];
        let mut energy = total_energy(&problem, &offsets).total();
        let start = energy;
        let mut moved = 0;
        for _ in 0..4 {
            for phase in 0..mesh.phase_count() {
                pass(&problem, &mut offsets, phase);
            }
            energy = total_energy(&problem, &offsets).total();
            for r in coarse_scales(mesh, 3) {
                for phase in 0..COARSE_PHASES {
                    let stats = coarse_pass(
                        &problem,
                        &table,
                        &mut offsets,
                        r,
                        phase,
                        COARSE_SEARCH_RELATIVE_WIDTH,
                    );
                    moved += stats.moved;
                    let after = total_energy(&problem, &offsets).total();
                    assert!(after <= energy, "r {r} phase {phase}: {energy} → {after}");
                    energy = after;
                }
            }
        }
        assert!(moved > 0);
        assert!(energy < 0.9 * start);
        let min = area_ratios(&problem, &offsets)
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        assert!(min > 0.0, "a triangle folded (min a/A = {min})");
        for (n, o) in offsets.iter().enumerate() {
            assert!(pin_q(problem.pins[n], problem.pin_resolution, *o) < 1.0);
        }
    }
}

#[test]
fn flat_maps_keep_offsets_exactly_zero_with_coarse_moves() {
    for value in [0.0, 0.7] {
        let map = HeightMap::new("flat", 16, 16, vec![value; 256]).unwrap();
        let opts = UnwarpOptions {
            sweeps: 2,
            coarse_moves: 3,
            ..options(0.1)
        };
        let solution = solve(&map, &opts, |_| {}).unwrap();
        assert!(solution.fine().coarse_passes > 0);
        assert!(solution.offsets.iter().all(|o| *o == [0.0, 0.0]));
    }
}

#[test]
fn coarse_moves_do_not_depend_on_the_thread_count() {
    let map = procedural("cones", 32).unwrap();
    let opts = UnwarpOptions {
        sweeps: 2,
        levels: 2,
        coarse_sweeps: 2,
        coarse_moves: 3,
        ..options(0.08)
    };
    let solve_in =
        |threads: usize| common::in_pool(threads, || solve(&map, &opts, |_| {}).unwrap());
    let (one, two) = (solve_in(1), solve_in(2));
    assert_eq!(one.offsets, two.offsets);
    for (a, b) in one.levels.iter().zip(&two.levels) {
        assert_eq!(a.energy_per_pass, b.energy_per_pass);
        assert_eq!(a.energy_after_coarse_moves, b.energy_after_coarse_moves);
    }
}

#[test]
fn coarse_moves_reach_the_single_level_energy_in_far_fewer_sweeps() {
    // 32² cones: the energy of 20 texel sweeps (80 passes) without coarse moves is reached
    // within 5 sweeps with three scales of coarse moves (measured: after 4; 20 sweeps without
    // them end at 140 982, 4 with them at 140 976).
    let map = procedural("cones", 32).unwrap();
    let single = solve(
        &map,
        &UnwarpOptions {
            sweeps: 20,
            ..options(0.08)
        },
        |_| {},
    )
    .unwrap();
    let target = single.last.total();
    let with_moves = solve(
        &map,
        &UnwarpOptions {
            sweeps: 5,
            coarse_moves: 3,
            ..options(0.08)
        },
        |_| {},
    )
    .unwrap();
    let per_sweep = &with_moves.fine().energy_after_coarse_moves;
    let reached = per_sweep.iter().position(|e| e.total() <= target);
    eprintln!(
        "single level 20 sweeps: {target}; with coarse moves per sweep: {:?}",
        per_sweep.iter().map(|e| e.total()).collect::<Vec<_>>()
    );
    assert!(reached.is_some(), "not reached in 5 sweeps");
}
