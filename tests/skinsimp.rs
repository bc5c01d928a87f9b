//! Properties of the skinsimp f64 reference (notes `skinsimp.md`, "Tests that pin it down"),
//! on meshes made here: the bending tube of `skinsimp::tube`, flat grids, a rigid bone.

use nalgebra::{Matrix4, Point3, Rotation3, Vector3};
use reparam::mesh::{load_gltf, Adjacency, SkinnedMesh};
use reparam::skinsimp::cost::{
    place_endpoint_weights, place_full, place_rest, solve_position, CostOptions, EdgeProblem,
    PoseGram,
};
use reparam::skinsimp::evaluate::compare;
use reparam::skinsimp::glb::{glb_bytes, level_model, write_glb};
use reparam::skinsimp::poses::{
    frames_input, select_poses, skinned_input, PoseSelection, PoseSets,
};
use reparam::skinsimp::quadric::Quadric;
use reparam::skinsimp::tube::skinned_tube;
use reparam::skinsimp::weights::{kkt_residual, solve_active_set, solve_enumerate, WeightQp};
use reparam::skinsimp::{
    simplify, Deformation, Hierarchy, Input, Method, Options, Schedule, Weights,
};

/// A small tube: 12 segments × 8 rings (216 triangles, 110 vertices).
fn small_tube() -> SkinnedMesh {
    skinned_tube(12, 8)
}

fn keyframes(model: &SkinnedMesh) -> PoseSets {
    select_poses(model, &PoseSelection::Keyframes(None)).unwrap()
}

/// A deterministic pseudo-random sequence in [0, 1) (64-bit LCG, top 53 bits).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Every edge (a < b) of `faces`, sorted.
fn edges(faces: &[[u32; 3]]) -> Vec<(usize, usize)> {
    let mut e: Vec<(usize, usize)> = faces
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b) as usize, a.max(b) as usize))
        .collect();
    e.sort_unstable();
    e.dedup();
    e
}

/// Per-vertex plane quadrics of `positions` (no constraint planes).
fn plain_quadrics(positions: &[Point3<f64>], faces: &[[u32; 3]]) -> Vec<Quadric> {
    let mut q = vec![Quadric::default(); positions.len()];
    for t in faces {
        let k = Quadric::from_triangle(
            &positions[t[0] as usize],
            &positions[t[1] as usize],
            &positions[t[2] as usize],
        );
        for &v in t {
            q[v as usize].add_assign(&k);
        }
    }
    q
}

/// Notes test 1: one pose with all M = I reduces to plain quadric simplification: on every
/// edge of the tube, the full method's cost and position equal the plain quadric optimum.
/// Tolerance: both solve the same 3×3 system from the same sums; the full method reaches it
/// through `Σ_j AᵀQA` with A = I (exact) and its alternation can only keep it; 1e-12 relative
/// covers the differing summation order of a 3×3 solve (cond ≲ 1e4 here, ε ≈ 1e-16).
#[test]
fn one_pose_identity_is_plain_quadric_simplification() {
    let model = small_tube();
    let mesh = &model.mesh;
    let q = plain_quadrics(&mesh.positions, &mesh.faces);
    let mats = vec![vec![Matrix4::identity(); 3]];
    let options = CostOptions::default();
    let mut solved = 0;
    for (a, b) in edges(&mesh.faces) {
        let sum = [q[a].add(&q[b])];
        let w = |i: usize| {
            Weights::from_pairs(
                &model.influences[i]
                    .iter()
                    .map(|x| (x.joint, x.weight))
                    .collect::<Vec<_>>(),
            )
        };
        let problem = EdgeProblem {
            quadrics: &sum,
            mats: &mats,
            ends: [mesh.positions[a], mesh.positions[b]],
            weights: [w(a), w(b)],
        };
        let (full, _) = place_full(&problem, &options);
        let rest = place_rest(&problem, &options);
        let scale = 1.0 + rest.cost.abs();
        assert!(
            (full.cost - rest.cost).abs() <= 1e-12 * scale,
            "edge {a}-{b}: {} vs {}",
            full.cost,
            rest.cost
        );
        if let Some(p) = solve_position(&sum[0].matrix(), options.max_condition) {
            solved += 1;
            assert!(
                (full.rest - p).norm() <= 1e-9,
                "edge {a}-{b}: {:?} vs {p:?}",
                full.rest
            );
        }
    }
    assert!(
        solved > 0,
        "no edge had a well-conditioned quadric: the position check did not run"
    );
}

/// Notes test 2: a single rigid bone. Posed quadrics are `M^{-T} Q M^{-1}`, so
/// `E(v) = Σ_j v̂ᵀ Q_rest v̂ = P · E_rest(v)`: same optimum, α one-hot. Tolerance 1e-9 of the
/// tube's size on positions: rotations and translations of size ≤ 3 carry ≈ 1e-16 relative
/// rounding into quadrics whose solve has cond ≲ 1e6.
#[test]
fn rigid_single_bone_matches_rest_pose() {
    let model = small_tube();
    let mesh = &model.mesh;
    let poses: Vec<Matrix4<f64>> = (0..4)
        .map(|j| {
            let r =
                Rotation3::from_euler_angles(0.3 * j as f64, -0.2 * j as f64, 0.5).to_homogeneous();
            Matrix4::new_translation(&Vector3::new(j as f64, 1.0, -2.0)) * r
        })
        .collect();
    let rest_q = plain_quadrics(&mesh.positions, &mesh.faces);
    let posed_q: Vec<Vec<Quadric>> = poses
        .iter()
        .map(|m| {
            let p: Vec<Point3<f64>> = mesh
                .positions
                .iter()
                .map(|x| m.transform_point(x))
                .collect();
            plain_quadrics(&p, &mesh.faces)
        })
        .collect();
    let mats: Vec<Vec<Matrix4<f64>>> = poses.iter().map(|m| vec![*m]).collect();
    let ident = vec![vec![Matrix4::identity()]];
    let one = Weights::single(0);
    let options = CostOptions::default();
    let mut solved = 0;
    for (a, b) in edges(&mesh.faces).into_iter().step_by(7) {
        let sums: Vec<Quadric> = posed_q.iter().map(|q| q[a].add(&q[b])).collect();
        let rest_sum = [rest_q[a].add(&rest_q[b])];
        let ends = [mesh.positions[a], mesh.positions[b]];
        let (full, _) = place_full(
            &EdgeProblem {
                quadrics: &sums,
                mats: &mats,
                ends,
                weights: [one, one],
            },
            &options,
        );
        let rest = place_rest(
            &EdgeProblem {
                quadrics: &rest_sum,
                mats: &ident,
                ends,
                weights: [one, one],
            },
            &options,
        );
        // Positions are unique only where the rest quadric is well conditioned (elsewhere
        // the fallback points tie up to rounding).
        if solve_position(&rest_sum[0].matrix(), 1e6).is_some() {
            assert!((full.rest - rest.rest).norm() <= 1e-9, "edge {a}-{b}");
            solved += 1;
        }
        assert!(
            (full.cost - 4.0 * rest.cost).abs() <= 1e-9 * (1.0 + rest.cost),
            "edge {a}-{b}: {} vs 4×{}",
            full.cost,
            rest.cost
        );
        assert_eq!(full.weights, one);
    }
    assert!(
        solved > 0,
        "no well-conditioned edge: the position check did not run"
    );
}

/// The training quadrics and matrices of the tube, for per-edge tests.
struct EdgeData {
    quadrics: Vec<Vec<Quadric>>,
    mats: Vec<Vec<Matrix4<f64>>>,
    model: SkinnedMesh,
}

fn edge_data(transform: Matrix4<f64>) -> EdgeData {
    let model = small_tube();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    let Deformation::Skinned { joints, .. } = &input.deformation else {
        unreachable!()
    };
    let mats: Vec<Vec<Matrix4<f64>>> = joints
        .iter()
        .map(|p| p.iter().map(|m| transform * m).collect())
        .collect();
    let quadrics = (0..input.pose_count())
        .map(|j| {
            let p: Vec<Point3<f64>> = input
                .posed(j)
                .iter()
                .map(|x| transform.transform_point(x))
                .collect();
            plain_quadrics(&p, &model.mesh.faces)
        })
        .collect();
    EdgeData {
        quadrics,
        mats,
        model,
    }
}

fn weights_of(model: &SkinnedMesh, i: usize) -> Weights {
    Weights::from_pairs(
        &model.influences[i]
            .iter()
            .map(|x| (x.joint, x.weight))
            .collect::<Vec<_>>(),
    )
}

/// Notes test 3: `E` never increases across half-steps; every weight QP meets KKT to 1e-10
/// (relative to the QP's scale); the full cost never exceeds Mohr–Gleicher's (it starts there).
/// Some edge must strictly improve, or the alternation would be untested.
#[test]
fn alternation_is_monotone_and_weight_steps_meet_kkt() {
    let d = edge_data(Matrix4::identity());
    let options = CostOptions::default();
    let mut improved = 0;
    for (a, b) in edges(&d.model.mesh.faces) {
        let sums: Vec<Quadric> = d.quadrics.iter().map(|q| q[a].add(&q[b])).collect();
        let problem = EdgeProblem {
            quadrics: &sums,
            mats: &d.mats,
            ends: [d.model.mesh.positions[a], d.model.mesh.positions[b]],
            weights: [weights_of(&d.model, a), weights_of(&d.model, b)],
        };
        let (full, trace) = place_full(&problem, &options);
        for w in trace.energies.windows(2) {
            assert!(w[1] <= w[0], "edge {a}-{b}: E rose {} → {}", w[0], w[1]);
        }
        for &r in &trace.kkt {
            assert!(r <= 1e-10, "edge {a}-{b}: KKT residual {r}");
        }
        let mohr = place_endpoint_weights(&problem, &options);
        assert!(full.cost <= mohr.cost, "edge {a}-{b}");
        if full.cost < 0.9 * mohr.cost {
            improved += 1;
        }
        assert!((full.weights.sum() - 1.0).abs() <= 1e-12);
    }
    assert!(
        improved > 0,
        "the weight optimisation never lowered a cost by 10%"
    );
}

/// The pose Gram matrices give the per-pose definitions back: `Σ_kl α_k α_l G_kl = Q̃(α)`,
/// `v̂ᵀ G_kl v̂ = H_kl(v)`, `αᵀHα = E(v, α)` ([`PoseGram`]), on every edge of the tube with
/// random simplex weights and random points near the edge.
///
/// Tolerance: both sides sum the same products in another order, each product of magnitude at
/// most `s = Σ_j ‖Q^j‖_F (Σ_k α_k ‖M_k^j‖_F)²` (times ‖v̂‖² for `E`), through ≲ 100 roundings
/// (4×4 products, K² ≤ 64 terms): |difference| ≤ 100 ε s ≈ 2e-14 s; asserted 1e-13 s.
#[test]
fn pose_gram_equals_the_per_pose_sums() {
    use reparam::skinsimp::cost::{energy, position_quadric, weight_matrix, Candidates};
    let d = edge_data(Matrix4::identity());
    let mut rng = Lcg(7);
    for (a, b) in edges(&d.model.mesh.faces) {
        let sums: Vec<Quadric> = d.quadrics.iter().map(|q| q[a].add(&q[b])).collect();
        let problem = EdgeProblem {
            quadrics: &sums,
            mats: &d.mats,
            ends: [d.model.mesh.positions[a], d.model.mesh.positions[b]],
            weights: [weights_of(&d.model, a), weights_of(&d.model, b)],
        };
        let cand = Candidates::of(&problem);
        let gram = PoseGram::new(&sums, &cand);
        let k = cand.joints.len();
        let raw: Vec<f64> = (0..k).map(|_| rng.next()).collect();
        let total: f64 = raw.iter().sum();
        let alpha: Vec<f64> = raw.iter().map(|x| x / total).collect();
        let t = rng.next();
        let v = Point3::from(
            problem.ends[0].coords * (1.0 - t)
                + problem.ends[1].coords * t
                + Vector3::new(rng.next(), rng.next(), rng.next()) * 0.05,
        );
        let vh = v.to_homogeneous().norm();
        // Σ_j ‖Q^j‖_F (Σ_k c_k ‖M_k^j‖_F)² for coefficients c.
        let scale = |c: &dyn Fn(usize) -> f64| -> f64 {
            sums.iter()
                .enumerate()
                .map(|(j, q)| {
                    let m: f64 = (0..k).map(|i| c(i) * cand.pose(j)[i].norm()).sum();
                    q.matrix().norm() * m * m
                })
                .sum()
        };
        let s_q = scale(&|i| alpha[i]);
        let e = energy(&sums, &cand, &v, &alpha);
        let eg = gram.energy(&v, &alpha);
        assert!(
            (eg - e).abs() <= 1e-13 * s_q * vh * vh,
            "edge {a}-{b}: E {eg} vs {e}"
        );
        let q = position_quadric(&sums, &cand, &alpha);
        let qg = gram.position_quadric(&alpha);
        assert!((qg - q).amax() <= 1e-13 * s_q, "edge {a}-{b}: Q̃");
        // H_kl carries no α: the same bound with every α_k replaced by 1.
        let s_h = scale(&|_| 1.0) * vh * vh;
        let h = weight_matrix(&sums, &cand, &v);
        for (x, y) in gram.weight_matrix(&v).iter().zip(&h) {
            assert!((x - y).abs() <= 1e-13 * s_h, "edge {a}-{b}: H {x} vs {y}");
        }
    }
}

/// Notes test 3: the two exact QP solvers agree on random PSD `H = LLᵀ` (some rank-deficient),
/// K = 1 … 8, and both meet KKT to 1e-10. Agreement 1e-9: the QP is strongly convex through the
/// regulariser only (μ = 1e-9 tr H / K), so the minimiser is determined to ≈ ε·cond ≈ 1e-16·1e9
/// in the worst (rank-deficient) direction; 1e-9 on the weights is the resulting bound.
#[test]
fn weight_qp_solvers_agree_and_meet_kkt() {
    let mut rng = Lcg(7);
    for trial in 0..200 {
        let k = 1 + trial % 8;
        let rank = 1 + (trial / 8) % k;
        let l: Vec<f64> = (0..k * rank).map(|_| rng.next() - 0.5).collect();
        let mut h = vec![0.0; k * k];
        for i in 0..k {
            for j in 0..k {
                h[i * k + j] = (0..rank).map(|r| l[i * rank + r] * l[j * rank + r]).sum();
            }
        }
        let mut alpha0: Vec<f64> = (0..k).map(|_| rng.next()).collect();
        let s: f64 = alpha0.iter().sum();
        alpha0.iter_mut().for_each(|a| *a /= s);
        let mu = reparam::skinsimp::weights::regulariser(&h, k, 1e-9);
        let qp = WeightQp::new(&h, k, &alpha0, mu);
        let x = solve_enumerate(&qp);
        let y = solve_active_set(&qp, &alpha0);
        assert!(
            kkt_residual(&qp, &x) <= 1e-10,
            "trial {trial}: enumerate KKT {}",
            kkt_residual(&qp, &x)
        );
        assert!(
            kkt_residual(&qp, &y) <= 1e-10,
            "trial {trial}: active set KKT {}",
            kkt_residual(&qp, &y)
        );
        for i in 0..k {
            assert!((x[i] - y[i]).abs() <= 1e-9, "trial {trial}: {x:?} vs {y:?}");
        }
    }
}

/// The tube with some vertices given six influences (two glTF sets' worth).
fn tube_with_six_influences() -> SkinnedMesh {
    let mut model = skinned_tube(12, 8);
    let mut rng = Lcg(3);
    for (i, list) in model.influences.iter_mut().enumerate() {
        if i % 3 != 0 {
            continue;
        }
        let mut w: Vec<(u32, f64)> = list.iter().map(|x| (x.joint, x.weight)).collect();
        for j in 0..3u32 {
            if !w.iter().any(|p| p.0 == j) {
                w.push((j, 0.05 * rng.next() + 0.01));
            }
        }
        // A fourth joint does not exist in the tube: split joint 0's share instead.
        let total: f64 = w.iter().map(|p| p.1).sum();
        *list = w
            .iter()
            .map(|&(joint, weight)| reparam::mesh::skin::Influence {
                joint,
                weight: weight / total,
            })
            .collect();
    }
    model
}

/// Notes test 4: Σα = 1, α ≥ 0, |supp α| ≤ W_max at every level; here W_max = 2 while the
/// tube's vertices have up to 3 influences, so reduction runs at the start and in collapses.
#[test]
fn weights_stay_on_the_simplex_with_at_most_w_max_at_every_level() {
    let model = tube_with_six_influences();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    let mut options = Options::default();
    options.cost.max_weights = 2;
    let h = simplify(&input, &options).unwrap();
    assert!(h.records.len() > 50, "only {} collapses", h.records.len());
    let mut reduced = false;
    for n in [
        0,
        h.records.len() / 3,
        2 * h.records.len() / 3,
        h.records.len(),
    ] {
        let level = h.level(n);
        for (i, w) in level.weights.iter().enumerate() {
            assert!(w.len() <= 2 && !w.is_empty(), "level {n} vertex {i}: {w:?}");
            assert!(w.pairs().all(|p| p.1 > 0.0));
            assert!(
                (w.sum() - 1.0).abs() <= 1e-12,
                "level {n} vertex {i}: sum {}",
                w.sum()
            );
            reduced |= w.len() == 2;
        }
    }
    assert!(reduced, "no vertex kept two influences");
}

/// Notes test 5: a rigid transform `T` of every pose (`M → T M`) leaves costs and rest
/// positions unchanged; a uniform scale `s` of the poses scales `E` by `s⁴` (squared distance
/// s² times area s²) and leaves the rest positions. Tolerance 1e-9 relative: the transformed
/// quadrics differ by rounding (≈ 1e-16) amplified by the position solve's conditioning.
#[test]
fn rigid_transform_invariance_and_scaling() {
    let rotation = Rotation3::from_euler_angles(0.7, -0.4, 1.1).to_homogeneous();
    let t = Matrix4::new_translation(&Vector3::new(5.0, -3.0, 2.0)) * rotation;
    let base = edge_data(Matrix4::identity());
    let moved = edge_data(t);
    let scaled = edge_data(Matrix4::new_scaling(2.0));
    let options = CostOptions::default();
    let mut checked = 0;
    for (a, b) in edges(&base.model.mesh.faces).into_iter().step_by(5) {
        let run = |d: &EdgeData| {
            let sums: Vec<Quadric> = d.quadrics.iter().map(|q| q[a].add(&q[b])).collect();
            let problem = EdgeProblem {
                quadrics: &sums,
                mats: &d.mats,
                ends: [d.model.mesh.positions[a], d.model.mesh.positions[b]],
                weights: [weights_of(&d.model, a), weights_of(&d.model, b)],
            };
            place_full(&problem, &options).0
        };
        let (p0, p1, p2) = (run(&base), run(&moved), run(&scaled));
        let tol = 1e-9 * (1.0 + p0.cost);
        assert!(
            (p0.cost - p1.cost).abs() <= tol,
            "edge {a}-{b}: {} vs {}",
            p0.cost,
            p1.cost
        );
        assert!(
            (p0.cost * 16.0 - p2.cost).abs() <= 16.0 * tol,
            "edge {a}-{b}: {} vs {}",
            p0.cost,
            p2.cost
        );
        if p0.cost > 1e-12 {
            assert!((p0.rest - p1.rest).norm() <= 1e-7, "edge {a}-{b}");
            assert!((p0.rest - p2.rest).norm() <= 1e-7, "edge {a}-{b}");
            checked += 1;
        }
    }
    assert!(checked > 10);
}

/// A flat n×n grid in z = 0 with every vertex weighted (0.3, 0.7) on joints 0 and 1, and
/// poses where the joints move differently (the blend of both is still affine, so the grid
/// stays planar in every pose).
fn flat_grid_input(n: usize) -> Input {
    let mut positions = Vec::new();
    for y in 0..n {
        for x in 0..n {
            positions.push(Point3::new(
                x as f64 / (n - 1) as f64,
                y as f64 / (n - 1) as f64,
                0.0,
            ));
        }
    }
    let mut faces = Vec::new();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let i = (y * n + x) as u32;
            let n32 = n as u32;
            faces.push([i, i + 1, i + n32 + 1]);
            faces.push([i, i + n32 + 1, i + n32]);
        }
    }
    let mesh =
        reparam::mesh::TriMesh::with_shared_indices("flat grid", positions, Vec::new(), faces);
    let joints = (0..3)
        .map(|j| {
            let a = Rotation3::from_euler_angles(0.2 * j as f64, 0.1, 0.0).to_homogeneous();
            let b = Matrix4::new_translation(&Vector3::new(0.0, j as f64, 1.0))
                * Rotation3::from_euler_angles(0.0, 0.3, -0.2 * j as f64).to_homogeneous();
            vec![a, b]
        })
        .collect();
    let influences = vec![vec![(0, 0.3), (1, 0.7)]; mesh.positions.len()];
    Input {
        mesh,
        deformation: Deformation::Skinned { influences, joints },
    }
}

/// Notes test 6: a coplanar neighbourhood with identical endpoint weights: E = 0 and α equals
/// those weights. "0": below 1e-24 (squared distances of points computed with ≈ 1e-16 rounding
/// on unit coordinates); α within 1e-12.
#[test]
fn flat_region_collapses_at_zero_cost_keeping_the_weights() {
    let input = flat_grid_input(6);
    let h = simplify(
        &input,
        &Options {
            target_vertices: 20,
            ..Options::default()
        },
    )
    .unwrap();
    assert_eq!(
        h.input_vertices() - h.records.len(),
        20,
        "the grid should reach 20 vertices"
    );
    let mut interior = 0;
    for r in &h.records {
        let w = r.weights;
        assert!(
            (w.weight_of(0) - 0.3).abs() <= 1e-12 && (w.weight_of(1) - 0.7).abs() <= 1e-12,
            "{w:?}"
        );
        if r.cost <= 1e-24 {
            interior += 1;
        }
        assert!(r.rest.z.abs() <= 1e-12);
    }
    assert!(interior > 0, "no zero-cost collapse");
    // The first collapses (interior vertices of the flat grid) cost 0.
    assert!(
        h.records[0].cost <= 1e-24,
        "first cost {}",
        h.records[0].cost
    );
}

/// Signed volume of a closed mesh, `Σ (p0 · (p1 × p2)) / 6`.
fn signed_volume(p: &[Point3<f64>], faces: &[[u32; 3]]) -> f64 {
    faces
        .iter()
        .map(|t| {
            p[t[0] as usize]
                .coords
                .dot(&p[t[1] as usize].coords.cross(&p[t[2] as usize].coords))
                / 6.0
        })
        .sum()
}

/// No collapse inverts a face in any training pose: for every record, each face around the
/// kept vertex after the collapse is compared with the same face before it (the kept vertex
/// at its old place, or the removed vertex in its stead): `n_before · n_after > 0` in every
/// pose.
fn check_no_collapse_flips(
    model: &SkinnedMesh,
    h: &Hierarchy,
    poses: &[reparam::skinsimp::poses::ExamplePose],
) {
    let mats: Vec<_> = poses
        .iter()
        .map(|p| reparam::skinsimp::poses::joint_matrices(model, *p).unwrap())
        .collect();
    let mut before = h.level(0);
    let mut checked = 0;
    for (n, r) in h.records.iter().enumerate() {
        let after = h.level(n + 1);
        let input_faces = |l: &reparam::skinsimp::Level| -> Vec<[u32; 3]> {
            l.mesh
                .faces
                .iter()
                .map(|t| t.map(|v| l.input_vertex[v as usize]))
                .collect()
        };
        let (fb, fa) = (input_faces(&before), input_faces(&after));
        for (j, m) in mats.iter().enumerate() {
            let (pb, pa) = (before.posed(m), after.posed(m));
            for (t, tl) in fa.iter().zip(&after.mesh.faces) {
                if !t.contains(&r.kept) {
                    continue;
                }
                let old = [r.kept, r.removed].iter().find_map(|&x| {
                    let want = t.map(|v| if v == r.kept { x } else { v });
                    fb.iter().position(|u| *u == want)
                });
                let Some(old) = old else {
                    panic!("record {n}: face {t:?} has no pre-image")
                };
                let normal = |p: &[Point3<f64>], tri: [u32; 3]| {
                    let [a, b, c] = tri.map(|v| p[v as usize]);
                    (b - a).cross(&(c - a))
                };
                let nb = normal(&pb, before.mesh.faces[old]);
                let na = normal(&pa, *tl);
                assert!(
                    nb.dot(&na) > 0.0,
                    "record {n}, pose {j}: face {t:?} flipped"
                );
                checked += 1;
            }
        }
        before = after;
    }
    assert!(checked > 0);
}

/// Notes test 7: at 25 % of the vertices the tube is still a closed, consistently oriented
/// 2-manifold with χ = 2; in every training pose its signed volume stays positive, between
/// half and 1.1 times the original's (a 12-gon ring reduced to a triangle keeps ≈ 40 % of its
/// area, hence the loose lower bound), and no collapse inverted a face in any training pose
/// ([`check_no_collapse_flips`]); UV seams are kept: no face
/// mixes the side chart (v ≤ 0.5) with a cap chart (v > 0.5) and seam edges remain. Both
/// schedules.
#[test]
fn simplified_tube_is_manifold_flip_free_and_keeps_seams() {
    let model = small_tube();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    let target = model.mesh.positions.len() / 4;
    let runs = [Schedule::Greedy, Schedule::Passes]
        .into_iter()
        .flat_map(|s| Method::ALL.map(|m| (s, m)));
    for (schedule, method) in runs {
        let h = simplify(
            &input,
            &Options {
                method,
                target_vertices: target,
                schedule,
                ..Options::default()
            },
        )
        .unwrap();
        let method = (schedule, method);
        let level = h.level(h.records.len());
        let m = &level.mesh;
        assert!(
            m.positions.len() <= target + 5,
            "{method:?}: stalled at {}",
            m.positions.len()
        );
        let adj = Adjacency::new(m);
        assert_eq!(adj.non_manifold_edges, 0, "{method:?}");
        assert_eq!(adj.misoriented_edges, 0, "{method:?}");
        assert_eq!(adj.boundary_edges, 0, "{method:?}");
        assert!(adj.seam_edges > 0, "{method:?}: seams disappeared");
        let edges = edges(&m.faces).len() as i64;
        let chi = m.positions.len() as i64 - edges + m.faces.len() as i64;
        assert_eq!(chi, 2, "{method:?}");
        for f in 0..m.faces.len() {
            let uv = m.face_uvs(f);
            let side = uv.iter().filter(|p| p.y <= 0.5 + 1e-12).count();
            assert!(
                side == 0 || side == 3,
                "{method:?}: face {f} mixes charts {uv:?}"
            );
        }
        check_no_collapse_flips(&model, &h, &sets.training);
        for pose in &sets.training {
            let original = model.pose(pose.animation, pose.time).unwrap();
            let mats = reparam::skinsimp::poses::joint_matrices(&model, *pose).unwrap();
            let v0 = signed_volume(&original, &model.mesh.faces);
            let v1 = signed_volume(&level.posed(&mats), &m.faces);
            assert!(
                v0 > 0.0 && v1 > 0.5 * v0 && v1 <= v0 * 1.1,
                "{method:?} at {pose:?}: {v1} vs {v0}"
            );
        }
    }
}

/// Notes test 8: quality on held-out poses at equal vertex counts.
///
/// One model at one size is not a fair judge: the three methods' equal-count levels come from
/// different greedy sequences, and on a single small tube a rounding-level change (summing the
/// poses per edge instead of per evaluation, [`PoseGram`]) moved full/mohr from 0.88 to 1.13.
/// So the methods are compared by the geometric mean of the held-out RMS ratio over 15 cases
/// (five tube shapes × three targets, 1/10, 1/5, 1/3 of the vertices). Measured: full/mohr
/// 0.969 (per-pose sums: 0.947), rest/mohr 4.57. The full method must not be worse than
/// either baseline on that mean (ratio ≤ 1): the margin, 3 %, is larger than the 2 % by which
/// the rounding change moved the mean.
#[test]
fn full_method_is_not_worse_than_the_baselines_on_held_out_poses() {
    let mut log_ratio = [0.0f64; 3];
    let mut cases = 0.0;
    for (segments, rings) in [(16, 16), (20, 24), (24, 20), (12, 30), (28, 28)] {
        let model = skinned_tube(segments, rings);
        let sets = keyframes(&model);
        for fraction in [10usize, 5, 3] {
            let options = Options {
                target_vertices: model.mesh.positions.len() / fraction,
                ..Options::default()
            };
            let q = compare(&model, &sets, &Method::ALL, &options).unwrap();
            let v: Vec<usize> = q.iter().map(|x| x.vertices).collect();
            assert!(v.iter().all(|&x| x == v[0]), "unequal vertex counts {v:?}");
            let rms = ["rest", "mohr", "full"]
                .map(|m| q.iter().find(|x| x.method == m).unwrap().held_out.rms_mean);
            println!(
                "{segments}×{rings} to 1/{fraction}: held-out RMS rest {:.4} mohr {:.4} full {:.4}",
                rms[0], rms[1], rms[2]
            );
            for (l, r) in log_ratio.iter_mut().zip(rms) {
                *l += (r / rms[1]).ln();
            }
            cases += 1.0;
        }
    }
    let [rest, _, full] = log_ratio.map(|l| (l / cases).exp());
    println!("geometric mean of the ratio to mohr: rest {rest:.3} full {full:.3}");
    assert!(full <= 1.0, "full/mohr {full}");
    assert!(full <= rest, "full/mohr {full} rest/mohr {rest}");
}

/// (kept, removed, rest bits, weight bits, cost bits) of one record.
type RecordBits = (u32, u32, [u64; 3], Vec<(u32, u64)>, u64);

fn records_bits(h: &Hierarchy) -> Vec<RecordBits> {
    h.records
        .iter()
        .map(|r| {
            (
                r.kept,
                r.removed,
                [r.rest.x.to_bits(), r.rest.y.to_bits(), r.rest.z.to_bits()],
                r.weights.pairs().map(|(j, w)| (j, w.to_bits())).collect(),
                r.cost.to_bits(),
            )
        })
        .collect()
}

/// Results do not depend on the number of threads: 1 and 2 rayon threads, bit-identical records
/// (both schedules).
#[test]
fn thread_count_does_not_change_the_result() {
    let model = small_tube();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    for schedule in [Schedule::Greedy, Schedule::Passes] {
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                simplify(
                    &input,
                    &Options {
                        target_vertices: 20,
                        schedule,
                        ..Options::default()
                    },
                )
                .unwrap()
            })
        };
        let (one, two) = (run(1), run(2));
        assert!(!one.records.is_empty());
        assert_eq!(records_bits(&one), records_bits(&two), "{schedule:?}");
    }
}

/// The collapse sequences are pinned: an FNV-1a hash of the records (kept, removed, rest
/// position, weights, cost, UV map and new UVs, bit for bit) of the 10k-triangle tube to 10 %
/// of its vertices. The greedy hashes were measured before the queue and the neighbourhood
/// scans were made faster, the passes hashes before the passes stopped copying their scores
/// and sorting every edge (issue #6 speed targets); the speed-ups must not change a single bit.
#[test]
fn collapse_sequences_are_unchanged() {
    let model = skinned_tube(50, 99);
    for (schedule, method, poses, want) in [
        (Schedule::Greedy, Method::Rest, 1, 0xdc85_58a1_d21b_130bu64),
        (Schedule::Greedy, Method::Full, 8, 0x916a_1978_ceb6_c7ef),
        (Schedule::Passes, Method::Rest, 1, 0xb793_5d3d_123e_c7d4),
        (Schedule::Passes, Method::Mohr, 8, 0xe8eb_525d_8e2d_8776),
        (Schedule::Passes, Method::Full, 8, 0xa8f2_4a3c_4745_3bcf),
    ] {
        let sets = select_poses(&model, &PoseSelection::Uniform(poses)).unwrap();
        let input = skinned_input(&model, &sets.training).unwrap();
        let options = Options {
            method,
            schedule,
            target_vertices: input.mesh.positions.len() / 10,
            ..Options::default()
        };
        let h = simplify(&input, &options).unwrap();
        let mut words: Vec<u64> = Vec::new();
        for r in &h.records {
            words.extend([u64::from(r.kept), u64::from(r.removed)]);
            words.extend(r.rest.iter().map(|x| x.to_bits()));
            for (j, w) in r.weights.pairs() {
                words.extend([u64::from(j), w.to_bits()]);
            }
            words.push(r.cost.to_bits());
            for &(from, to) in &r.uv_map {
                words.extend([u64::from(from), u64::from(to)]);
            }
            for u in &r.new_uvs {
                words.extend([u.x.to_bits(), u.y.to_bits()]);
            }
        }
        let hash = words.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, w| {
            w.to_le_bytes()
                .iter()
                .fold(h, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
        });
        let case = format!("{schedule:?} {method:?}: {} records", h.records.len());
        println!("{case}, hash {hash:#018x}");
        assert_eq!(hash, want, "{case}");
    }
}

/// The passes schedule against the exact greedy order: held-out RMS at equal vertex counts over
/// the 15 cases of the quality test, per method, as the geometric mean of passes / greedy.
/// Measured: rest 1.19, mohr 0.99, full 0.995. So passes are as good for the per-pose methods
/// (within 5 %) and worse for the rest-pose baseline (within 25 %), which is why the greedy
/// order stays the default.
#[test]
fn passes_schedule_quality_is_close_to_greedy() {
    let mut log_ratio = [0.0f64; 3];
    let mut cases = 0.0;
    for (segments, rings) in [(16, 16), (20, 24), (24, 20), (12, 30), (28, 28)] {
        let model = skinned_tube(segments, rings);
        let sets = keyframes(&model);
        for fraction in [10usize, 5, 3] {
            let rms = [Schedule::Greedy, Schedule::Passes].map(|schedule| {
                let options = Options {
                    target_vertices: model.mesh.positions.len() / fraction,
                    schedule,
                    ..Options::default()
                };
                let q = compare(&model, &sets, &Method::ALL, &options).unwrap();
                Method::ALL.map(|m| {
                    let x = q.iter().find(|x| x.method == m.name()).unwrap();
                    (x.vertices, x.held_out.rms_mean)
                })
            });
            for (k, l) in log_ratio.iter_mut().enumerate() {
                let ((vg, g), (vp, p)) = (rms[0][k], rms[1][k]);
                assert_eq!(vg, vp, "{segments}×{rings} to 1/{fraction}");
                *l += (p / g).ln();
            }
            cases += 1.0;
        }
    }
    let ratio = log_ratio.map(|l| (l / cases).exp());
    println!("geometric mean of passes / greedy held-out RMS (rest, mohr, full): {ratio:?}");
    let [rest, mohr, full] = ratio;
    assert!(rest <= 1.25, "{ratio:?}");
    assert!(mohr <= 1.05 && full <= 1.05, "{ratio:?}");
}

/// glTF round trip: write the simplified tube, read it back with the loader: same skeleton
/// (node names, parents, inverse bind matrices to f32 rounding), same clip, the same vertices
/// (to f32 rounding: 3 × 2⁻²⁴ relative of coordinates ≤ 3) with the same weights (f32: 1e-6).
#[test]
fn glb_round_trip_keeps_skeleton_animation_and_weights() {
    let model = small_tube();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    let h = simplify(
        &input,
        &Options {
            target_vertices: 40,
            ..Options::default()
        },
    )
    .unwrap();
    let level = h.level(h.records.len());
    let written = level_model(&model, &level);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tube.glb");
    write_glb(&path, &written).unwrap();
    let back = load_gltf(&path).unwrap();
    let (s0, s1) = (
        written.skeleton.as_ref().unwrap(),
        back.skeleton.as_ref().unwrap(),
    );
    assert_eq!(s0.nodes.len(), s1.nodes.len());
    for (a, b) in s0.nodes.iter().zip(&s1.nodes) {
        assert_eq!((a.name.as_str(), a.parent), (b.name.as_str(), b.parent));
    }
    for (a, b) in s0.joints.iter().zip(&s1.joints) {
        assert_eq!(a.node, b.node);
        assert!((a.inverse_bind - b.inverse_bind).abs().max() <= 1e-6);
    }
    assert_eq!(back.animations.len(), 1);
    assert_eq!(
        back.animations[0].channels.len(),
        written.animations[0].channels.len()
    );
    assert_eq!(back.mesh.positions.len(), level.mesh.positions.len());
    assert_eq!(back.mesh.faces.len(), level.mesh.faces.len());
    for (i, p) in back.mesh.positions.iter().enumerate() {
        let j = (0..level.mesh.positions.len())
            .min_by(|&x, &y| {
                (level.mesh.positions[x] - p)
                    .norm()
                    .total_cmp(&(level.mesh.positions[y] - p).norm())
            })
            .unwrap();
        assert!((level.mesh.positions[j] - p).norm() <= 1e-6, "vertex {i}");
        for inf in &back.influences[i] {
            assert!(
                (level.weights[j].weight_of(inf.joint) - inf.weight).abs() <= 1e-6,
                "vertex {i}"
            );
        }
        assert_eq!(
            back.influences[i].len(),
            level.weights[j].len(),
            "vertex {i}"
        );
    }
    // Posing the read-back model matches posing the level (f32 rounding of everything: 1e-5).
    let pose = sets.held_out[3];
    let a = back.pose(pose.animation, pose.time).unwrap();
    let b = written.pose(pose.animation, pose.time).unwrap();
    let box_a: f64 = a.iter().map(|p| p.coords.norm()).sum::<f64>();
    let box_b: f64 = b.iter().map(|p| p.coords.norm()).sum::<f64>();
    assert!((box_a - box_b).abs() <= 1e-5 * box_b);
}

/// More than four influences: with W_max = 8 the written file has a second JOINTS/WEIGHTS set
/// and the loader reads all six back; with W_max = 4 every level has at most four.
#[test]
fn more_than_four_influences_use_two_sets_or_are_reduced() {
    let model = tube_with_six_influences();
    assert!(model.influences.iter().any(|l| l.len() == 3));
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    // The tube has only 3 joints: make 6 influences by giving the model 6 joints (copies).
    let mut six = model.clone();
    let skel = six.skeleton.as_mut().unwrap();
    for k in 0..3 {
        let j = skel.joints[k].clone();
        skel.joints.push(j);
    }
    for list in six.influences.iter_mut().filter(|l| l.len() == 3) {
        let extra: Vec<_> = list
            .iter()
            .map(|i| reparam::mesh::skin::Influence {
                joint: i.joint + 3,
                weight: i.weight / 2.0,
            })
            .collect();
        list.iter_mut().for_each(|i| i.weight /= 2.0);
        list.extend(extra);
    }
    let bytes = glb_bytes(&six).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.contains("JOINTS_1") && text.contains("WEIGHTS_1"));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("six.glb");
    std::fs::write(&path, &bytes).unwrap();
    let back = load_gltf(&path).unwrap();
    assert_eq!(back.influences.iter().map(Vec::len).max(), Some(6));
    let six_input = skinned_input(&back, &sets.training).unwrap();
    let h = simplify(
        &six_input,
        &Options {
            target_vertices: 60,
            ..Options::default()
        },
    )
    .unwrap();
    for n in [0, h.records.len()] {
        assert!(h.level(n).weights.iter().all(|w| w.len() <= 4), "level {n}");
    }
    drop(input);
}

/// Bad input gives typed errors naming the problem: no skin, weights not summing to 1, bad
/// options, frames of different sizes, an unknown clip.
#[test]
fn bad_input_is_a_typed_error() {
    let model = small_tube();
    let mut unskinned = model.clone();
    unskinned.skeleton = None;
    unskinned.influences.clear();
    let e = select_poses(&unskinned, &PoseSelection::Keyframes(None))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no skinned mesh") && e.contains("--frames"),
        "{e}"
    );

    // A file without skin, read by the loader.
    let bytes = glb_bytes(&model).unwrap();
    let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
    let mut json: serde_json::Value = serde_json::from_slice(&glb.json).unwrap();
    json.as_object_mut().unwrap().remove("skins");
    for node in json["nodes"].as_array_mut().unwrap() {
        node.as_object_mut().unwrap().remove("skin");
    }
    let text = serde_json::to_vec(&json).unwrap();
    let out = gltf::binary::Glb {
        header: glb.header,
        json: text.into(),
        bin: glb.bin.clone(),
    }
    .to_vec()
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("noskin.glb");
    std::fs::write(&path, out).unwrap();
    let loaded = load_gltf(&path).unwrap();
    let e = select_poses(&loaded, &PoseSelection::Uniform(2))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("noskin.glb") && e.contains("no skinned mesh"),
        "{e}"
    );

    let sets = keyframes(&model);
    let mut input = skinned_input(&model, &sets.training).unwrap();
    if let Deformation::Skinned { influences, .. } = &mut input.deformation {
        influences[5] = vec![(0, 0.5), (1, 0.4)];
    }
    let e = simplify(&input, &Options::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertex 5") && e.contains("summing to 1"), "{e}");

    let input = skinned_input(&model, &sets.training).unwrap();
    let mut options = Options::default();
    options.cost.max_weights = 0;
    assert!(simplify(&input, &options)
        .unwrap_err()
        .to_string()
        .contains("max weights"));
    let e = select_poses(&model, &PoseSelection::Keyframes(Some(vec!["Walk".into()])))
        .unwrap_err()
        .to_string();
    assert!(e.contains("Walk") && e.contains("Bend"), "{e}");
    assert!(select_poses(&model, &PoseSelection::Uniform(0)).is_err());

    let mut short = model.mesh.clone();
    short.positions.pop();
    short
        .faces
        .retain(|t| t.iter().all(|&v| (v as usize) < short.positions.len()));
    let e = frames_input(&[model.mesh.clone(), short])
        .unwrap_err()
        .to_string();
    assert!(e.contains("connectivity differs"), "{e}");
}

/// The frame-sequence path: with one frame it is plain quadric simplification, i.e. the same
/// collapses as the rest-pose method on a skinned input whose only pose is the rest pose
/// (identical quadrics, identical placement rule; weights play no part in either cost).
#[test]
fn one_frame_sequence_equals_rest_pose_simplification() {
    let model = small_tube();
    let frames = frames_input(std::slice::from_ref(&model.mesh)).unwrap();
    let options = Options {
        target_vertices: 30,
        ..Options::default()
    };
    let hf = simplify(&frames, &options).unwrap();
    let influences = model
        .influences
        .iter()
        .map(|l| l.iter().map(|i| (i.joint, i.weight)).collect())
        .collect();
    let skinned = Input {
        mesh: model.mesh.clone(),
        deformation: Deformation::Skinned {
            influences,
            joints: vec![vec![Matrix4::identity(); 3]],
        },
    };
    let hr = simplify(
        &skinned,
        &Options {
            method: Method::Rest,
            ..options
        },
    )
    .unwrap();
    assert_eq!(hf.records.len(), hr.records.len());
    for (a, b) in hf.records.iter().zip(&hr.records) {
        assert_eq!((a.kept, a.removed), (b.kept, b.removed));
        assert!((a.rest - b.rest).norm() <= 1e-12);
        assert_eq!(a.frames.len(), 1);
    }
    // And a multi-frame sequence simplifies with each frame placed on its own.
    let sets = keyframes(&model);
    let meshes: Vec<_> = sets
        .training
        .iter()
        .map(|p| model.posed_mesh(p.animation, p.time).unwrap())
        .collect();
    let input = frames_input(&meshes).unwrap();
    let h = simplify(&input, &options).unwrap();
    let level = h.level(h.records.len());
    assert_eq!(level.frames.len(), meshes.len());
    assert!(level.mesh.positions.len() <= 35);
}

/// `reparam skinsimp tube.glb --target-ratio 0.3 --json <extra> -o tube_lod.glb` on the small
/// tube written to a temporary folder; asserts success. Returns the folder, the output path
/// and the printed JSON.
fn run_cli_on_small_tube(
    extra: &[&str],
) -> (tempfile::TempDir, std::path::PathBuf, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("tube.glb");
    write_glb(&input, &small_tube()).unwrap();
    let out = dir.path().join("tube_lod.glb");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args([
            "skinsimp",
            input.to_str().unwrap(),
            "--target-ratio",
            "0.3",
            "--json",
        ])
        .args(extra)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let json = serde_json::from_slice(&run.stdout).unwrap();
    (dir, out, json)
}

/// The command line on a file made here: `reparam skinsimp tube.glb --poses 3 --json -o out`
/// writes a GLB the loader reads back and prints the JSON summary with training and held-out
/// errors; a model without skin is refused with the typed message.
#[test]
fn cli_simplifies_a_written_tube_and_prints_json() {
    let (dir, out, json) = run_cli_on_small_tube(&["--poses", "3"]);
    assert_eq!(json["training_poses"], 3);
    assert_eq!(json["held_out_poses"], 3);
    assert_eq!(json["schedule"], "greedy");
    let result = &json["results"][0];
    assert_eq!(result["method"], "full");
    let vertices = result["vertices"].as_u64().unwrap();
    assert!(
        vertices < json["input_vertices"].as_u64().unwrap() / 2,
        "{vertices}"
    );
    assert!(result["held_out"]["rms_mean"].as_f64().unwrap() > 0.0);
    let back = load_gltf(&out).unwrap();
    assert_eq!(back.mesh.positions.len() as u64, vertices);

    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args(["skinsimp", "--target-ratio", "0", "-o"])
        .arg(&out)
        .arg(dir.path().join("tube.glb"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--target-ratio"));
}

/// `--schedule passes` runs the pass schedule (its quality is tested on the library side): the
/// summary names it, and the GLB it writes reads back with the reported vertex count.
#[test]
fn cli_runs_the_pass_schedule() {
    let (_dir, out, json) = run_cli_on_small_tube(&["--poses", "2", "--schedule", "passes"]);
    assert_eq!(json["schedule"], "passes");
    let vertices = json["results"][0]["vertices"].as_u64().unwrap();
    assert!(
        vertices < json["input_vertices"].as_u64().unwrap() / 2,
        "{vertices}"
    );
    assert_eq!(
        load_gltf(&out).unwrap().mesh.positions.len() as u64,
        vertices
    );
}

// ---------------------------------------------------------------------------------------------
// Pictures (issue #6): pose strip and error-vs-vertex-count plot.

/// Whether each pixel of the `w × h` cell at column `c`, row `r` of a pose strip shows a mesh.
fn strip_cell_mask(
    strip: &reparam::texture::Image<[u8; 4]>,
    c: usize,
    r: usize,
    w: usize,
    h: usize,
) -> Vec<bool> {
    use reparam::skinsimp::picture::{BACKGROUND, GAP};
    let (left, top) = (c * (w + GAP), r * (h + GAP));
    let mut mask = Vec::with_capacity(w * h);
    for y in top..top + h {
        for x in left..left + w {
            mask.push(strip.get(x, y) != BACKGROUND);
        }
    }
    mask
}

#[test]
fn pose_strip_shows_original_and_level_in_every_pose() {
    use reparam::skinsimp::picture::{pose_strip, spread_poses, PoseStripOptions, GAP};
    let model = small_tube();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    let h = simplify(&input, &Options::default()).unwrap();
    let n = model.mesh.positions.len();
    let coarse = h.level(h.collapses_for(n * 3 / 10));
    let full = h.level(0);
    assert!(coarse.mesh.positions.len() < n / 2);
    let poses = spread_poses(&model, &[], 4).unwrap();
    assert_eq!(poses.len(), 4);
    let times: Vec<f64> = poses.iter().map(|p| p.time).collect();
    assert_eq!(times, vec![0.25, 0.75, 1.25, 1.75]);
    let options = PoseStripOptions {
        cell_width: 96,
        cell_height: 64,
        view: None,
    };
    let (w, hh) = (options.cell_width, options.cell_height);
    let strip = pose_strip(&model, &coarse, &poses, &options).unwrap();
    let same = pose_strip(&model, &full, &poses, &options).unwrap();
    for s in [&strip, &same] {
        assert_eq!((s.width, s.height), (4 * w + 3 * GAP, 2 * hh + GAP));
    }
    let mut changed = 0;
    for c in 0..4 {
        let top = strip_cell_mask(&strip, c, 0, w, hh);
        let bottom = strip_cell_mask(&strip, c, 1, w, hh);
        let count = |m: &[bool]| m.iter().filter(|&&b| b).count();
        assert!(
            count(&top) > 100,
            "pose {c}: {} original pixels",
            count(&top)
        );
        assert!(
            count(&bottom) > 100,
            "pose {c}: {} level pixels",
            count(&bottom)
        );
        // The unsimplified level covers exactly the original's pixels in every pose …
        let unsimplified = strip_cell_mask(&same, c, 1, w, hh);
        assert_eq!(
            unsimplified,
            strip_cell_mask(&same, c, 0, w, hh),
            "pose {c}"
        );
        // … the simplified one does not draw the same picture.
        let left = c * (w + GAP);
        for y in hh + GAP..2 * hh + GAP {
            for x in left..left + w {
                changed += usize::from(strip.get(x, y) != same.get(x, y));
            }
        }
    }
    assert!(changed > 200, "{changed} pixels differ");
    // Pose cells differ from each other (the clip bends the tube).
    assert_ne!(
        strip_cell_mask(&strip, 0, 0, w, hh),
        strip_cell_mask(&strip, 2, 0, w, hh)
    );

    // Bad input: typed errors, no panic.
    assert!(pose_strip(&model, &coarse, &[], &options).is_err());
    assert!(spread_poses(&model, &[], 0).is_err());
    assert!(spread_poses(&model, &[7], 2).is_err());
    let mut empty = coarse.clone();
    empty.mesh.faces.clear();
    empty.mesh.uv_faces.clear();
    assert!(matches!(
        pose_strip(&model, &empty, &poses, &options),
        Err(reparam::Error::EmptyMesh { .. })
    ));
    let zero = PoseStripOptions {
        cell_width: 0,
        ..options.clone()
    };
    assert!(pose_strip(&model, &coarse, &poses, &zero).is_err());
    let mut bad_weights = coarse.clone();
    bad_weights.weights[0] = Weights::single(99);
    assert!(pose_strip(&model, &bad_weights, &poses, &options).is_err());
    bad_weights.weights.pop();
    assert!(pose_strip(&model, &bad_weights, &poses, &options).is_err());
}

#[test]
fn error_plot_has_one_point_per_level_and_method() {
    use reparam::skinsimp::picture::{
        draw_error_plot, error_plot, error_series, level_counts, METHOD_COLOURS,
    };
    let model = small_tube();
    let sets = keyframes(&model);
    let input = skinned_input(&model, &sets.training).unwrap();
    let n = model.mesh.positions.len();
    let hierarchies: Vec<Hierarchy> = Method::ALL
        .iter()
        .map(|&method| {
            simplify(
                &input,
                &Options {
                    method,
                    ..Options::default()
                },
            )
            .unwrap()
        })
        .collect();
    let reached = hierarchies
        .iter()
        .map(|h| h.input_vertices() - h.records.len())
        .max()
        .unwrap();
    let counts = level_counts(n, reached.max(n / 5), 5).unwrap();
    assert_eq!(counts.len(), 5);
    assert_eq!(counts[0], n);
    assert!(counts.windows(2).all(|p| p[0] > p[1]), "{counts:?}");
    let refs: Vec<&Hierarchy> = hierarchies.iter().collect();
    let plot = error_plot(&model, &refs, &sets.held_out, &counts, 320, 200).unwrap();
    assert_eq!(plot.series.len(), 3);
    for (s, method) in plot.series.iter().zip(Method::ALL) {
        assert_eq!(s.method, method.name());
        assert_eq!(s.points.len(), counts.len());
        let v: Vec<usize> = s.points.iter().map(|p| p.vertices).collect();
        assert_eq!(v[0], n);
        assert!(v.windows(2).all(|p| p[0] > p[1]), "{}: {v:?}", s.method);
        for p in &s.points {
            assert!(p.vertices <= p.target, "{p:?}");
            for x in [p.rms_mean, p.rms_max, p.hausdorff_max] {
                assert!(x.is_finite() && x >= 0.0, "{p:?}");
            }
        }
        // The unsimplified level: zero error up to rounding (the tube is 3 long).
        assert!(s.points[0].rms_mean <= 3e-12, "{:?}", s.points[0]);
        assert!(s.points.last().unwrap().rms_mean > 1e-4, "{:?}", s.points);
        println!(
            "{}: {:?}",
            s.method,
            s.points
                .iter()
                .map(|p| (p.vertices, p.rms_mean))
                .collect::<Vec<_>>()
        );
    }
    assert!(plot.axes.y_min > 0.0 && plot.axes.y_min < plot.axes.y_max);
    assert!(plot.axes.x_min < n as f64 && plot.axes.x_max > n as f64);
    let (header, rows) = plot.table();
    assert_eq!(header.len(), 1 + 2 * 3);
    assert_eq!(rows.len(), counts.len());
    assert!(rows.iter().all(|r| r.len() == header.len()));
    // The picture: its size, each method's colour drawn.
    assert_eq!((plot.image.width, plot.image.height), (320, 200));
    for (_, colour) in METHOD_COLOURS {
        let drawn = plot.image.pixels.iter().filter(|&&p| p == colour).count();
        assert!(drawn > 20, "{colour:?}: {drawn}");
    }
    // Bad input: typed errors.
    assert!(level_counts(n, 0, 5).is_err());
    assert!(level_counts(n, n, 5).is_err());
    assert!(level_counts(n, 10, 1).is_err());
    assert!(error_series(&model, &[], &sets.held_out, &counts).is_err());
    assert!(error_series(&model, &refs, &[], &counts).is_err());
    assert!(error_series(&model, &refs, &sets.held_out, &[]).is_err());
    assert!(draw_error_plot(&[], 320, 200).is_err());
    assert!(draw_error_plot(&plot.series, 10, 10).is_err());
    let mut nan = plot.series.clone();
    nan[0].points[1].rms_mean = f64::NAN;
    assert!(draw_error_plot(&nan, 320, 200).is_err());
}

#[test]
fn cli_writes_the_pose_strip_and_the_error_plot() {
    let plot_dir = tempfile::tempdir().unwrap();
    let plot = plot_dir.path().join("plot.png");
    let (dir, _, json) = run_cli_on_small_tube(&["--poses", "2", "--plot", plot.to_str().unwrap()]);
    let strip_path = dir.path().join("tube_lod_poses.png");
    assert_eq!(json["pictures"][0], strip_path.display().to_string());
    assert_eq!(json["pictures"][1], plot.display().to_string());
    let strip = reparam::texture::load_rgba8(&strip_path).unwrap();
    let gap = reparam::skinsimp::picture::GAP;
    assert_eq!(
        (strip.width, strip.height),
        (4 * 320 + 3 * gap, 2 * 240 + gap)
    );
    let image = reparam::texture::load_rgba8(&plot).unwrap();
    assert_eq!((image.width, image.height), (640, 400));
    let series = json["error_plot"]["series"].as_array().unwrap();
    assert_eq!(series.len(), 3);
    for s in series {
        assert_eq!(s["points"].as_array().unwrap().len(), 8, "{s}");
    }

    // --plot with --frames is refused.
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_reparam"))
        .args([
            "skinsimp", "--frames", "a.obj", "--plot", "p.png", "-o", "x",
        ])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--plot"));
}
