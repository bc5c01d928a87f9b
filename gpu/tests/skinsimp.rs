//! The skinsimp kernels on hand-made inputs against closed forms: skinning in the identity
//! pose and by one rigid bone, the plane quadric of a triangle and of a constraint edge, the
//! vertex gather, and the position step at the corner of three planes (also seen by a rigid
//! bone in a second pose, and with coplanar or ill-conditioned quadrics). Skipped (printing
//! `skipped: no GPU adapter`) without an adapter unless REPARAM_REQUIRE_GPU=1.

use reparam_gpu::skinsimp::{
    CollapseCostKernel, CostInput, EdgeItem, Influences, JointMatrix, LbsInput, LbsKernel,
    PlaneSource, QuadricF32, QuadricInput, QuadricKernel, CHOICE_SOLUTION, SOURCE_FACE,
};
use reparam_gpu::{gpu_or_skip, GpuError};

#[test]
fn chained_skinning_and_quadrics_equal_the_separate_runs() {
    let Some(gpu) = gpu_or_skip() else { return };
    // The square of `square()` lifted to z = 0 and posed by the quarter turn in a second pose:
    // the quadrics read from the LBS buffer on the GPU must equal those from the read-back
    // positions bit for bit (same f32 inputs, same kernels).
    let (mut quadrics, _) = square();
    quadrics.pose_count = 2;
    let lbs_in = LbsInput {
        rest: vec![
            [0.0, 0.0, 0.5],
            [1.0, 0.0, 0.5],
            [1.0, 1.0, 0.5],
            [0.0, 1.0, 0.5],
        ],
        influences: vec![
            Influences {
                joints: [0, 1, 0, 0],
                weights: [0.75, 0.25, 0.0, 0.0],
            };
            4
        ],
        joint_count: 2,
        joints: vec![IDENTITY, IDENTITY, IDENTITY, quarter_turn(T)],
    };
    let lbs = LbsKernel::new(&gpu).unwrap();
    let kernel = QuadricKernel::new(&gpu).unwrap();
    let posed = lbs.skin(&gpu, &lbs_in).unwrap();
    let separate = kernel.quadrics(&gpu, &quadrics, &posed).unwrap();
    let (buffer, len) = lbs.skin_on_gpu(&gpu, &lbs_in).unwrap();
    assert_eq!(len, 8);
    let (plane, vertex) = kernel.quadrics_on_gpu(&gpu, &quadrics, &buffer).unwrap();
    let chained = (
        gpu.read_back(&plane, quadrics.sources.len() * 2).unwrap(),
        gpu.read_back(&vertex, 8).unwrap(),
    );
    assert_eq!(chained, separate);
}

/// f32 unit roundoff u = 2⁻²⁴.
const U32: f64 = 5.960_464_477_539_063e-8;

const IDENTITY: JointMatrix = [
    1.0, 0.0, 0.0, 0.0, //
    0.0, 1.0, 0.0, 0.0, //
    0.0, 0.0, 1.0, 0.0,
];

/// Rotation by 90° about z, `(x, y) ↦ (−y, x)`, then translation by `t` (entries exact in f32).
fn quarter_turn(t: [f32; 3]) -> JointMatrix {
    [
        0.0, -1.0, 0.0, t[0], //
        1.0, 0.0, 0.0, t[1], //
        0.0, 0.0, 1.0, t[2],
    ]
}

/// `w · q qᵀ` for `q = (n, d)`, upper triangle, in f32 (entries exact for the dyadic planes used
/// here).
fn plane(n: [f32; 3], d: f32, w: f32) -> QuadricF32 {
    let q = [n[0], n[1], n[2], d];
    let mut out = [0.0f32; 10];
    let mut k = 0;
    for r in 0..4 {
        for c in r..4 {
            out[k] = w * q[r] * q[c];
            k += 1;
        }
    }
    out
}

fn add(a: QuadricF32, b: QuadricF32) -> QuadricF32 {
    let mut out = a;
    out.iter_mut().zip(b).for_each(|(x, y)| *x += y);
    out
}

// ---------------------------------------------------------------------------------------------
// Linear blend skinning

/// Three vertices with one to three influences, P = 2 poses of J = 3 joints.
fn lbs_input(joints: Vec<JointMatrix>) -> LbsInput {
    LbsInput {
        rest: vec![[0.3, -1.7, 2.25], [10.0, 0.1, -0.7], [-3.3, 4.4, 0.001]],
        influences: vec![
            Influences {
                joints: [0, 0, 0, 0],
                weights: [1.0, 0.0, 0.0, 0.0],
            },
            Influences {
                joints: [2, 1, 0, 0],
                weights: [0.3, 0.7, 0.0, 0.0],
            },
            Influences {
                joints: [0, 1, 2, 0],
                weights: [0.2, 0.5, 0.3, 0.0],
            },
        ],
        joint_count: 3,
        joints,
    }
}

#[test]
fn identity_pose_gives_the_rest_positions_times_the_weight_sum() {
    let Some(gpu) = gpu_or_skip() else { return };
    let input = lbs_input(vec![IDENTITY; 6]);
    let posed = LbsKernel::new(&gpu).unwrap().skin(&gpu, &input).unwrap();
    assert_eq!(posed.len(), 6);
    for (x, p) in posed.iter().enumerate() {
        let (i, inf) = (x / 2, input.influences[x / 2]);
        // M h is exact for M = I (products by 0 and 1, sums with zeros). Each w·x rounds once
        // (≤ u w|x|) and the K-term sum K − 1 times (≤ u|partial sum| ≤ u Σw|x|): the result is
        // x·Σw (the f32 weights need not sum to exactly 1) within K·u·Σw·|x|, plus u² terms.
        let w: f64 = inf.weights.iter().map(|&w| w as f64).sum();
        let k = inf.weights.iter().filter(|&&w| w != 0.0).count() as f64;
        for (c, (&got, &rest)) in p.iter().zip(&input.rest[i]).enumerate() {
            let expected = rest as f64 * w;
            let bound = (k + 0.01) * U32 * w * (rest as f64).abs();
            let error = (got as f64 - expected).abs();
            assert!(
                error <= bound,
                "vertex {i}, coordinate {c}: {got} vs {expected} (bound {bound:e})"
            );
        }
    }
}

#[test]
fn one_rigid_bone_moves_every_vertex_rigidly() {
    let Some(gpu) = gpu_or_skip() else { return };
    // Pose 0: identity; pose 1: a rotation by 0.7 rad about (1, 2, 2)/3 and a translation, for
    // all three joints (so any weights give the same rigid motion).
    let (s, c) = (0.7f64.sin(), 0.7f64.cos());
    let a = [1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0];
    let t = [0.5, -2.0, 1.25];
    let mut m = [0.0f32; 12];
    for r in 0..3 {
        for k in 0..3 {
            // Rodrigues: R = c I + s [a]× + (1 − c) a aᵀ.
            let cross = match (r, k) {
                (0, 1) => -a[2],
                (0, 2) => a[1],
                (1, 0) => a[2],
                (1, 2) => -a[0],
                (2, 0) => -a[1],
                (2, 1) => a[0],
                _ => 0.0,
            };
            let id = if r == k { 1.0 } else { 0.0 };
            m[4 * r + k] = (c * id + s * cross + (1.0 - c) * a[r] * a[k]) as f32;
        }
        m[4 * r + 3] = t[r] as f32;
    }
    let mut joints = vec![IDENTITY; 3];
    joints.extend([m; 3]);
    let input = lbs_input(joints);
    let posed = LbsKernel::new(&gpu).unwrap().skin(&gpu, &input).unwrap();
    for (i, inf) in input.influences.iter().enumerate() {
        let h = [
            input.rest[i][0] as f64,
            input.rest[i][1] as f64,
            input.rest[i][2] as f64,
            1.0,
        ];
        let w: f64 = inf.weights.iter().map(|&w| w as f64).sum();
        let k = inf.weights.iter().filter(|&&w| w != 0.0).count() as f64;
        for r in 0..3 {
            // Expected: (M h)_r · Σw with the f32 matrix (identical inputs). Each M h is a
            // 4-term dot product, ≤ 4u Σ_c |M_rc h_c| (also with fused multiply-adds); then as
            // in the identity test, K·u·Σw·|M h| for the weighted sum.
            let dot: f64 = (0..4).map(|c| m[4 * r + c] as f64 * h[c]).sum();
            let size: f64 = (0..4).map(|c| (m[4 * r + c] as f64 * h[c]).abs()).sum();
            let bound = 4.01 * U32 * size * w + (k + 0.01) * U32 * w * size;
            let error = (posed[2 * i + 1][r] as f64 - dot * w).abs();
            assert!(
                error <= bound,
                "vertex {i}, row {r}: error {error:e} > {bound:e}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Quadrics

/// A unit square in the plane z = ½ split into two triangles (0, 1, 2), (0, 2, 3), one pose,
/// with the constraint plane of the boundary edge 0–1 (local edge 0 of face 0).
fn square() -> (QuadricInput, Vec<[f32; 3]>) {
    let posed = vec![
        [0.0, 0.0, 0.5],
        [1.0, 0.0, 0.5],
        [1.0, 1.0, 0.5],
        [0.0, 1.0, 0.5],
    ];
    let sources = vec![
        PlaneSource {
            corners: [0, 1, 2],
            kind: SOURCE_FACE,
        },
        PlaneSource {
            corners: [0, 2, 3],
            kind: SOURCE_FACE,
        },
        PlaneSource {
            corners: [0, 1, 2],
            kind: 0,
        },
    ];
    // Vertex 0: face 0, its constraint, face 1; 1: face 0, constraint; 2: faces 0, 1; 3: face 1.
    let lists = [vec![0, 2, 1], vec![0, 2], vec![0, 1], vec![1]];
    let mut vertex_offsets = vec![0];
    let mut vertex_sources = Vec::new();
    for l in lists {
        vertex_sources.extend(l);
        vertex_offsets.push(vertex_sources.len() as u32);
    }
    let input = QuadricInput {
        vertex_count: 4,
        pose_count: 1,
        sources,
        vertex_offsets,
        vertex_sources,
        boundary_weight: 10.0,
    };
    (input, posed)
}

#[test]
fn plane_quadrics_of_a_horizontal_square_are_exact() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (input, posed) = square();
    let (planes, vertices) = QuadricKernel::new(&gpu)
        .unwrap()
        .quadrics(&gpu, &input, &posed)
        .unwrap();
    // Each face: cross product (0, 0, 1), area ½, n = (0, 0, 1), d = −½, so K = ½ q qᵀ:
    // zz = ½, zw = −¼, ww = ⅛, every other entry 0. All dyadic: f32 is exact.
    let face = plane([0.0, 0.0, 1.0], -0.5, 0.5);
    assert_eq!(planes[0], face);
    assert_eq!(planes[1], face);
    // Edge (0,0,½)–(1,0,½) with face normal (0,0,1): e × n = (0, −1, 0), d = 0, weight 10·|e|²
    // = 10: yy = 10, every other entry 0.
    let constraint = plane([0.0, -1.0, 0.0], 0.0, 10.0);
    assert_eq!(planes[2], constraint);
    assert_eq!(vertices[0], add(add(face, constraint), face));
    assert_eq!(vertices[1], add(face, constraint));
    assert_eq!(vertices[2], add(face, face));
    assert_eq!(vertices[3], face);
    // The quadric is the area-weighted squared distance: v̂ᵀK v̂ = ½ (z − ½)² at (x, y, 2).
    let k = planes[0];
    let h = [0.25f32, 0.75, 2.0, 1.0];
    let m = |r: usize, c: usize| {
        let (r, c) = (r.min(c), r.max(c));
        k[[0, 4, 7, 9][r] + c - r]
    };
    let value: f32 = (0..4)
        .flat_map(|r| (0..4).map(move |c| (r, c)))
        .map(|(r, c)| h[r] * m(r, c) * h[c])
        .sum();
    assert_eq!(value, 0.5 * 1.5 * 1.5);
}

#[test]
fn tilted_triangle_quadric_matches_the_closed_form_within_the_f32_bound() {
    let Some(gpu) = gpu_or_skip() else { return };
    let posed: Vec<[f32; 3]> = vec![[0.1, 0.2, 0.3], [0.9, 0.35, 0.1], [0.3, 0.8, 0.7]];
    let input = QuadricInput {
        vertex_count: 3,
        pose_count: 1,
        sources: vec![PlaneSource {
            corners: [0, 1, 2],
            kind: SOURCE_FACE,
        }],
        vertex_offsets: vec![0, 1, 2, 3],
        vertex_sources: vec![0, 0, 0],
        boundary_weight: 1.0,
    };
    let (planes, vertices) = QuadricKernel::new(&gpu)
        .unwrap()
        .quadrics(&gpu, &input, &posed)
        .unwrap();
    let p: Vec<[f64; 3]> = posed
        .iter()
        .map(|p| p.map(|x| x as f64))
        .collect::<Vec<_>>();
    let e1 = [0, 1, 2].map(|c| p[1][c] - p[0][c]);
    let e2 = [0, 1, 2].map(|c| p[2][c] - p[0][c]);
    let cr = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let twice = norm(cr);
    let n = cr.map(|x| x / twice);
    let d = -(n[0] * p[0][0] + n[1] * p[0][1] + n[2] * p[0][2]);
    let q = [n[0], n[1], n[2], d];
    // Error propagation in f32 (first order, u = 2⁻²⁴): the edge vectors round once (≤ u per
    // component); each cross-product component is a 2-term difference of products, so
    // |Δc| ≤ 4u |e1||e2| (2 for the products and difference, 2 for the rounded edges) per
    // component, ≤ 4√3 u |e1||e2| as a vector. Dividing by |c| gives n and area with absolute /
    // relative errors ≤ δ = 4√3 κ u + 3u, κ = |e1||e2| / |e1 × e2| the triangle's conditioning
    // (norm and division add ≤ 3u). d = −n·p0 adds ≤ δ|p0|₁ + 3u|p0|₁. An entry w q_r q_c (2
    // products) then errs by ≤ w (Δq_r |q_c| + |q_r| Δq_c + |q_r q_c| (δ + 2u)).
    let kappa = norm(e1) * norm(e2) / twice;
    let delta = (4.0 * 3f64.sqrt() * kappa + 3.0) * U32;
    let p0 = p[0].iter().map(|x| x.abs()).sum::<f64>();
    let dq = [delta, delta, delta, (delta + 3.0 * U32) * p0];
    let w = 0.5 * twice;
    let mut k = 0;
    for r in 0..4 {
        for c in r..4 {
            let expected = w * q[r] * q[c];
            let bound = w
                * (dq[r] * q[c].abs()
                    + q[r].abs() * dq[c]
                    + (q[r] * q[c]).abs() * (delta + 2.0 * U32));
            let error = (planes[0][k] as f64 - expected).abs();
            assert!(
                error <= bound,
                "entry {k}: {} vs {expected} (error {error:e}, bound {bound:e})",
                planes[0][k]
            );
            k += 1;
        }
    }
    // A vertex with one source gets it unchanged.
    assert!(vertices.iter().all(|v| *v == planes[0]));
}

// ---------------------------------------------------------------------------------------------
// Position step and collapse cost

/// Q_a = planes x = 1 and y = 2, Q_b = plane z = 3 (unit weights), in `poses` poses of J = 2
/// joints; pose 1, if any, moves everything by the rigid `quarter_turn(T)`, and its quadrics
/// are the moved planes. Vertex a at (0, 0, 0), b at (2, 2, 2).
const T: [f32; 3] = [0.5, -0.25, 2.0];

fn corner(poses: usize) -> CostInput {
    let mut joints = vec![IDENTITY; 2];
    let mut quadrics = vec![[0.0; 10]; 2 * poses];
    let planes = |map: &dyn Fn([f32; 3], f32) -> ([f32; 3], f32)| {
        let p = |n, d| {
            let (n, d) = map(n, d);
            plane(n, d, 1.0)
        };
        (
            add(p([1.0, 0.0, 0.0], -1.0), p([0.0, 1.0, 0.0], -2.0)),
            p([0.0, 0.0, 1.0], -3.0),
        )
    };
    let (qa, qb) = planes(&|n, d| (n, d));
    quadrics[0] = qa;
    quadrics[poses] = qb;
    if poses == 2 {
        joints.extend([quarter_turn(T); 2]);
        // The plane n·x + d = 0 moved by x ↦ R x + t: n' = R n, d' = d − n'·t (dyadic: exact).
        let (qa, qb) = planes(&|n, d| {
            let rn = [-n[1], n[0], n[2]];
            (rn, d - (rn[0] * T[0] + rn[1] * T[1] + rn[2] * T[2]))
        });
        quadrics[1] = qa;
        quadrics[3] = qb;
    }
    CostInput {
        rest: vec![[0.0; 3], [2.0; 3]],
        pose_count: poses as u32,
        joint_count: 2,
        joints,
        vertex_quadrics: quadrics,
        max_condition: 1e10,
    }
}

fn item(alpha: [f32; 2]) -> EdgeItem {
    let mut item = EdgeItem {
        a: 0,
        b: 1,
        candidates: 2,
        ..EdgeItem::default()
    };
    item.joints[..2].copy_from_slice(&[0, 1]);
    item.alpha[..2].copy_from_slice(&alpha);
    item
}

#[test]
fn position_step_finds_the_corner_of_three_planes_in_every_rigid_pose() {
    let Some(gpu) = gpu_or_skip() else { return };
    let kernel = CollapseCostKernel::new(&gpu).unwrap();
    // Every number is a small dyadic: Q̃ = Σ_j A^{jT} Q^j A^j (A = one joint, or ½ + ½ of two
    // equal ones) is exact, B = Q̃[0:3,0:3] = P·I, its adjugate inverse exact, so the kernel
    // must return exactly v = (1, 2, 3), E = 0 and cond = ‖B‖_F ‖B⁻¹‖_F = √3·√3 (to one
    // rounding of each square root and the product: 3 within 4u·3).
    for poses in [1, 2] {
        let input = corner(poses);
        let items = [item([1.0, 0.0]), item([0.0, 1.0]), item([0.5, 0.5])];
        let out = kernel.position_given_weights(&gpu, &input, &items).unwrap();
        for (n, r) in out.iter().enumerate() {
            assert_eq!(r.choice, CHOICE_SOLUTION, "{poses} poses, item {n}");
            assert_eq!(r.position, [1.0, 2.0, 3.0], "{poses} poses, item {n}");
            assert_eq!(r.cost, 0.0, "{poses} poses, item {n}");
            assert_eq!(r.value, 0.0, "{poses} poses, item {n}");
            assert!(
                (r.condition as f64 - 3.0).abs() <= 12.0 * U32,
                "cond {}",
                r.condition
            );
            let p = poses as f32;
            // Q̃ = P · (I₃ | −(1,2,3); · | 14).
            assert_eq!(
                r.quadric,
                [p, 0.0, 0.0, -p, p, 0.0, -2.0 * p, p, -3.0 * p, 14.0 * p],
                "{poses} poses, item {n}"
            );
        }
    }
}

#[test]
fn singular_or_ill_conditioned_quadrics_fall_back_to_the_best_endpoint_or_midpoint() {
    let Some(gpu) = gpu_or_skip() else { return };
    let kernel = CollapseCostKernel::new(&gpu).unwrap();
    // Coplanar: both quadrics are the plane z = 3 (rank 1, det 0): no solution; a = (0,0,0) and
    // b = (2,2,2) are 3 and 1 from the plane, the midpoint (1,1,1) is 2: b wins with value
    // 2·1² = 2 (Q_a + Q_b = 2 planes), E the same at α = (1, 0).
    let mut input = corner(1);
    let z3 = plane([0.0, 0.0, 1.0], -3.0, 1.0);
    input.vertex_quadrics = vec![z3, z3];
    let out = kernel
        .position_given_weights(&gpu, &input, &[item([1.0, 0.0])])
        .unwrap();
    assert_eq!(out[0].choice, 2);
    assert_eq!(out[0].position, [2.0; 3]);
    assert_eq!(out[0].value, 2.0);
    assert_eq!(out[0].cost, 2.0);
    assert_eq!(out[0].condition, 0.0);
    // The corner with max_condition 2 < cond = 3: the solution is refused; values at a, b, mid:
    // 1 + 4 + 9 = 14, 1 + 0 + 1 = 2, 0 + 1 + 4 = 5: b again.
    let mut input = corner(1);
    input.max_condition = 2.0;
    let out = kernel
        .position_given_weights(&gpu, &input, &[item([1.0, 0.0])])
        .unwrap();
    assert_eq!(out[0].choice, 2);
    assert_eq!(out[0].value, 2.0);
    assert_eq!(out[0].cost, 2.0);
}

// ---------------------------------------------------------------------------------------------
// Input checks and determinism

#[test]
fn bad_inputs_are_errors() {
    let Some(gpu) = gpu_or_skip() else { return };
    let lbs = LbsKernel::new(&gpu).unwrap();
    let mut input = lbs_input(vec![IDENTITY; 6]);
    input.influences[1].joints[0] = 3;
    assert!(matches!(lbs.skin(&gpu, &input), Err(GpuError::Input(_))));
    let mut input = lbs_input(vec![IDENTITY; 6]);
    input.joints.pop();
    assert!(matches!(lbs.skin(&gpu, &input), Err(GpuError::Input(_))));

    let quadrics = QuadricKernel::new(&gpu).unwrap();
    let (mut input, posed) = square();
    input.vertex_sources[0] = 7;
    assert!(matches!(
        quadrics.quadrics(&gpu, &input, &posed),
        Err(GpuError::Input(_))
    ));
    let (mut input, posed) = square();
    input.vertex_offsets[2] = 1;
    assert!(matches!(
        quadrics.quadrics(&gpu, &input, &posed),
        Err(GpuError::Input(_))
    ));
    let (input, _) = square();
    assert!(matches!(
        quadrics.quadrics(&gpu, &input, &[[0.0; 3]; 3]),
        Err(GpuError::Input(_))
    ));

    let cost = CollapseCostKernel::new(&gpu).unwrap();
    let mut bad = item([1.0, 0.0]);
    bad.b = 2;
    assert!(matches!(
        cost.position_given_weights(&gpu, &corner(1), &[bad]),
        Err(GpuError::Input(_))
    ));
    let mut bad = item([1.0, 0.0]);
    bad.joints[1] = 2;
    assert!(matches!(
        cost.position_given_weights(&gpu, &corner(1), &[bad]),
        Err(GpuError::Input(_))
    ));
}

#[test]
fn repeated_runs_are_bitwise_identical() {
    let Some(gpu) = gpu_or_skip() else { return };
    // A fan of 40 thin triangles around vertex 0 in one pose: vertex 0 gathers 40 quadrics.
    let n = 40u32;
    let mut posed = vec![[0.0f32, 0.0, 0.0]];
    for k in 0..=n {
        let t = k as f32 * 0.05;
        posed.push([t.cos(), t.sin(), 0.1 * (3.0 * t).sin()]);
    }
    let sources: Vec<PlaneSource> = (0..n)
        .map(|k| PlaneSource {
            corners: [0, k + 1, k + 2],
            kind: SOURCE_FACE,
        })
        .collect();
    let mut lists: Vec<Vec<u32>> = vec![Vec::new(); posed.len()];
    for (f, s) in sources.iter().enumerate() {
        for &c in &s.corners {
            lists[c as usize].push(f as u32);
        }
    }
    let mut vertex_offsets = vec![0];
    let mut vertex_sources = Vec::new();
    for l in lists {
        vertex_sources.extend(l);
        vertex_offsets.push(vertex_sources.len() as u32);
    }
    let input = QuadricInput {
        vertex_count: posed.len() as u32,
        pose_count: 1,
        sources,
        vertex_offsets,
        vertex_sources,
        boundary_weight: 1.0,
    };
    let kernel = QuadricKernel::new(&gpu).unwrap();
    let first = kernel.quadrics(&gpu, &input, &posed).unwrap();
    for _ in 0..3 {
        assert_eq!(kernel.quadrics(&gpu, &input, &posed).unwrap(), first);
    }
}
