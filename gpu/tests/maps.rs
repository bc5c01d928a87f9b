//! The MAPS kernels (`maps_priority`, `maps_flatten`, `maps_inverse`) on hand-made inputs
//! against closed forms: a regular flat hexagon (a = 1, μ rigid), a flat boundary half disk, a
//! regular cone (a = 2π/(Kφ)), a flat feature line (a₁ = a₂ = 1), a spherical cap (κ = 4/(R(1 +
//! cos β))), the rejections, input validation, and Π⁻¹ through one removal on a flat fan (the
//! flat-mesh oracle). Skipped (printing `skipped: no GPU adapter`) without an adapter unless
//! REPARAM_REQUIRE_GPU=1.
//!
//! Error budget used below, u = 2⁻²⁴ the f32 unit roundoff, assuming the adapter's sqrt, pow,
//! sin, cos are accurate to a few ulp (Mesa's llvmpipe; WGSL itself only promises 2⁻¹¹ absolute
//! for sin/cos). The kernel computes atan itself (Cephes' atanf, ≤ 2 ulp): llvmpipe's built-in
//! atan2 was off by ≈ 1e-6 rad, WGSL promises only 4096 ulp.
//! - one angle atan2(|a×b|, a·b): the cross product's components and the dot product carry ≤ 3u
//!   relative error each, the length ≤ 3u more, so (y, x) are off by ≤ 6u relative each, which
//!   moves atan2 by ≤ 6u·|sin 2φ| ≤ 6u; the kernel's atan adds ≤ 2 ulp of φ plus its range
//!   reduction's roundings, ≤ 4πu; the inputs (exact geometry rounded to f32) move each
//!   direction by ≤ u·√3 → ≤ 4u. ≤ 23u per angle;
//! - θ_k: k angles and k − 1 additions of sums ≤ 2π (≤ 2πu each): ≤ k(23u + 2πu) ≤ 30k u;
//! - a = c/θ_total: relative error ≤ 30Ku/θ_total + u;
//! - μ_k = r^a e^{i a θ_k}: angle error ≤ a·30ku + aθ_k·(relative error of a) + 2u; modulus
//!   error r^a·(a·u_r + |ln r|·Δa + 4u) (u_r ≤ 3u the radius's relative error, pow ≤ 4 ulp);
//!   sin/cos add ≤ 2u·r^a.

use std::f64::consts::{PI, TAU};

use reparam_gpu::maps::inverse::{self, NONE};
use reparam_gpu::maps::{
    flatten, priority, BaseQuery, DecimationFace, FaceCharts, InverseTables, RingHeader, Rings,
    KIND_DISK, KIND_FEATURE_LINE, KIND_HALF_DISK, STATUS_DEGENERATE, STATUS_FLIPPED_FAN, STATUS_OK,
};
use reparam_gpu::{gpu_or_skip, GpuError};

/// f32 unit roundoff 2⁻²⁴.
const U: f64 = 5.960_464_477_539_063e-8;

/// A batch of one ring around vertex 0 with the ring vertices 1..=K at `ring` (f64, rounded).
fn one_ring(centre: [f64; 3], ring: &[[f64; 3]], kind: u32, s: u32, t: u32) -> Rings {
    let mut positions = vec![[centre[0] as f32, centre[1] as f32, centre[2] as f32, 0.0]];
    positions.extend(
        ring.iter()
            .map(|p| [p[0] as f32, p[1] as f32, p[2] as f32, 0.0]),
    );
    Rings {
        positions,
        neighbours: (1..=ring.len() as u32).collect(),
        rings: vec![RingHeader {
            centre: 0,
            first: 0,
            count: ring.len() as u32,
            kind,
            s,
            t,
            _pad: [0; 2],
        }],
    }
}

/// Points at `radii[k]`, angles `angles[k]` in the plane z = 0.
fn planar(radii: &[f64], angles: &[f64]) -> Vec<[f64; 3]> {
    radii
        .iter()
        .zip(angles)
        .map(|(r, a)| [r * a.cos(), r * a.sin(), 0.0])
        .collect()
}

/// The error bound of μ_k (module docs) for a ring of K vertices, total angle `total`, scale
/// factor c (a = c/θ_total), at radius r, cumulative angle θ_k (k angles).
fn mu_bound(k_ring: usize, total: f64, c: f64, r: f64, theta: f64, k: usize) -> f64 {
    let a = c / total;
    let rel_a = 30.0 * k_ring as f64 * U / total + U;
    let angle = a * 30.0 * k as f64 * U + a * theta * rel_a + 2.0 * U;
    let modulus = a * 3.0 * U + r.ln().abs() * a * rel_a + 4.0 * U;
    r.powf(a) * (angle + modulus + 2.0 * U)
}

fn dist(p: [f32; 2], q: [f64; 2]) -> f64 {
    (p[0] as f64 - q[0]).hypot(p[1] as f64 - q[1])
}

#[test]
fn regular_hexagon_flattens_rigidly_with_a_equal_to_one() {
    let Some(gpu) = gpu_or_skip() else { return };
    let rho = 0.5;
    let angles: Vec<f64> = (0..6).map(|k| k as f64 * PI / 3.0).collect();
    let rings = one_ring([0.0; 3], &planar(&[rho; 6], &angles), KIND_DISK, 0, 0);
    let (flat, points) = flatten::run(&gpu, &rings).unwrap();
    assert_eq!(flat[0].status, STATUS_OK);
    // θ_K = 2π to 6 angles' budget; a = 1 to its relative bound.
    assert!((flat[0].theta_total as f64 - TAU).abs() <= 180.0 * U);
    assert!((flat[0].a as f64 - 1.0).abs() <= 30.0 * 6.0 * U / TAU + U);
    for (k, p) in points.iter().enumerate() {
        assert!(
            (p.theta as f64 - angles[k]).abs() <= 30.0 * k as f64 * U,
            "θ_{k} {p:?}"
        );
        let expected = [rho * angles[k].cos(), rho * angles[k].sin()];
        let bound = mu_bound(6, TAU, TAU, rho, angles[k], k);
        assert!(
            dist(p.mu, expected) <= bound,
            "μ_{k} {p:?} vs {expected:?}, bound {bound:e}"
        );
    }
    // μ_0 is placed exactly on the real axis.
    assert_eq!(points[0].mu[1], 0.0);
}

#[test]
fn boundary_half_disk_maps_the_ends_to_the_real_axis() {
    let Some(gpu) = gpu_or_skip() else { return };
    // A flat boundary vertex: the ring spans exactly π, so a = 1 and μ_k = r_k e^{iθ_k}.
    let radii = [0.7, 0.4, 0.9, 0.6];
    let angles = [0.0, 0.8, 2.0, PI];
    let rings = one_ring([0.0; 3], &planar(&radii, &angles), KIND_HALF_DISK, 0, 0);
    let (flat, points) = flatten::run(&gpu, &rings).unwrap();
    assert_eq!(flat[0].status, STATUS_OK);
    assert!((flat[0].theta_total as f64 - PI).abs() <= 90.0 * U);
    for (k, p) in points.iter().enumerate() {
        let expected = [radii[k] * angles[k].cos(), radii[k] * angles[k].sin()];
        let bound = mu_bound(4, PI, PI, radii[k], angles[k], k);
        assert!(dist(p.mu, expected) <= bound, "μ_{k} {p:?} vs {expected:?}");
    }
    // The chord ends are on the real axis exactly, on either side of 0.
    assert_eq!(points[0].mu[1], 0.0);
    assert_eq!(points[3].mu[1], 0.0);
    assert!(points[0].mu[0] > 0.0 && points[3].mu[0] < 0.0);
}

#[test]
fn regular_cone_opens_to_a_full_turn() {
    let Some(gpu) = gpu_or_skip() else { return };
    // K = 5 rim vertices at radius ρ, height −h below the apex: every sector has the angle φ
    // with cos φ = (ρ² cos(2π/K) + h²)/(ρ² + h²); a = 2π/(Kφ), μ_k = r^a e^{2πik/K}.
    let (k_ring, rho, h) = (5usize, 0.6, 0.45);
    let ring: Vec<[f64; 3]> = (0..k_ring)
        .map(|k| {
            let a = TAU * k as f64 / k_ring as f64;
            [rho * a.cos(), rho * a.sin(), -h]
        })
        .collect();
    let rings = one_ring([0.0; 3], &ring, KIND_DISK, 0, 0);
    let (flat, points) = flatten::run(&gpu, &rings).unwrap();
    let phi = ((rho * rho * (TAU / k_ring as f64).cos() + h * h) / (rho * rho + h * h)).acos();
    let total = k_ring as f64 * phi;
    let r = rho.hypot(h);
    assert_eq!(flat[0].status, STATUS_OK);
    let rel_a = 30.0 * k_ring as f64 * U / total + U;
    assert!((flat[0].a as f64 - TAU / total).abs() <= rel_a * TAU / total);
    for (k, p) in points.iter().enumerate() {
        let angle = TAU * k as f64 / k_ring as f64;
        let expected = [
            r.powf(TAU / total) * angle.cos(),
            r.powf(TAU / total) * angle.sin(),
        ];
        let bound = mu_bound(k_ring, total, TAU, r, k as f64 * phi, k);
        assert!(dist(p.mu, expected) <= bound, "μ_{k} {p:?} vs {expected:?}");
        assert!((p.radius as f64 - r).abs() <= 4.0 * U * r);
    }
}

#[test]
fn flat_feature_line_is_a_rotation() {
    let Some(gpu) = gpu_or_skip() else { return };
    // A flat irregular ring cut by a straight feature line through j_1 and j_4 (angles 1.0 and
    // 1.0 + π): both sides span π, a₁ = a₂ = 1, and μ is the rotation by −θ_1.
    let radii = [0.5, 0.8, 0.6, 0.7, 0.9, 0.55];
    let angles = [0.0, 1.0, 2.2, 3.4, 1.0 + PI, 5.3];
    let rings = one_ring([0.0; 3], &planar(&radii, &angles), KIND_FEATURE_LINE, 1, 4);
    let (flat, points) = flatten::run(&gpu, &rings).unwrap();
    assert_eq!(flat[0].status, STATUS_OK);
    let rel_a = 30.0 * 6.0 * U / PI + U;
    assert!((flat[0].a as f64 - 1.0).abs() <= rel_a);
    assert!((flat[0].a2 as f64 - 1.0).abs() <= rel_a);
    for (k, p) in points.iter().enumerate() {
        let angle = angles[k] - 1.0;
        let expected = [radii[k] * angle.cos(), radii[k] * angle.sin()];
        // The rotation offset θ_1 adds one more angle's error (≤ 30u) to every angle.
        let bound = mu_bound(6, PI, PI, radii[k], angles[k], k + 1);
        assert!(dist(p.mu, expected) <= bound, "μ_{k} {p:?} vs {expected:?}");
    }
    assert_eq!((points[1].mu[1], points[4].mu[1]), (0.0, 0.0));
}

#[test]
fn single_sector_sides_and_degenerate_rings_are_rejected() {
    let Some(gpu) = gpu_or_skip() else { return };
    let angles: Vec<f64> = (0..6).map(|k| k as f64 * PI / 3.0).collect();
    let hexagon = planar(&[1.0; 6], &angles);
    // A feature line between neighbouring ring vertices: the upper side is one sector, a₁φ = π.
    let rings = one_ring([0.0; 3], &hexagon, KIND_FEATURE_LINE, 2, 3);
    assert_eq!(
        flatten::run(&gpu, &rings).unwrap().0[0].status,
        STATUS_FLIPPED_FAN
    );
    // A ring vertex on the centre: r = 0.
    let mut collapsed = hexagon.clone();
    collapsed[3] = [0.0; 3];
    let rings = one_ring([0.0; 3], &collapsed, KIND_DISK, 0, 0);
    assert_eq!(
        flatten::run(&gpu, &rings).unwrap().0[0].status,
        STATUS_DEGENERATE
    );
    // Two ring vertices in the same direction: a zero sector angle.
    let mut doubled = hexagon;
    doubled[2] = [2.0 * doubled[1][0], 2.0 * doubled[1][1], 0.0];
    let rings = one_ring([0.0; 3], &doubled, KIND_DISK, 0, 0);
    assert_eq!(
        flatten::run(&gpu, &rings).unwrap().0[0].status,
        STATUS_DEGENERATE
    );
}

#[test]
fn hexagon_area_and_spherical_cap_curvature() {
    let Some(gpu) = gpu_or_skip() else { return };
    let angles: Vec<f64> = (0..6).map(|k| k as f64 * PI / 3.0).collect();
    let rho = 0.01;
    // Flat hexagon in z = 0: a = (3√3/2)ρ², κ = 0 exactly (every height is exactly 0).
    let flat = one_ring([0.0; 3], &planar(&[rho; 6], &angles), KIND_DISK, 0, 0);
    // Spherical cap: centre at the north pole of a sphere of radius R, ring at polar angle β.
    // The heights below the tangent plane are R(1 − cos β) at x² + y² = R² sin²β, fitted exactly
    // by z = A(x² + y²), A = −1/(R(1 + cos β)): κ₁ = κ₂ = 2A, κ = 4/(R(1 + cos β)).
    let (big_r, beta) = (0.2f64, 0.3f64);
    let cap: Vec<[f64; 3]> = angles
        .iter()
        .map(|a| {
            let s = big_r * beta.sin();
            [s * a.cos(), s * a.sin(), big_r * beta.cos() - big_r]
        })
        .collect();
    let cap = one_ring([0.0; 3], &cap, KIND_DISK, 0, 0);
    let mut both = flat.clone();
    both.positions.extend(&cap.positions);
    both.neighbours.extend(cap.neighbours.iter().map(|v| v + 7));
    both.rings.push(RingHeader {
        centre: 7,
        first: 6,
        ..cap.rings[0]
    });
    let terms = priority::run(&gpu, &both).unwrap();
    // Area: 6 triangles of ≈ 12 roundings each (differences, cross product, length, ½) plus 5
    // additions: relative error ≤ 20u, with the inputs' rounding (≤ 2u per edge) ≤ 24u.
    let area = 1.5 * 3f64.sqrt() * rho * rho;
    assert!(
        (terms[0].area as f64 - area).abs() <= 24.0 * U * area,
        "{:?}",
        terms[0]
    );
    assert_eq!(terms[0].kappa, 0.0);
    let kappa = 4.0 / (big_r * (1.0 + beta.cos()));
    // κ: in the scaled frame the heights z' ≈ sin(β/2) ≈ 0.15 carry ≈ 10u absolute error (the
    // normal's direction, from a sum of 6 cross products, is off by ≤ 10u), i.e. ≤ 70u relative;
    // the normal equations (K = 6 regular directions, condition number 6 of the scaled M) and
    // the adjugate (≈ 10 roundings) amplify the right-hand side's error by ≤ 6: ≤ 6·(70u + 10u)
    // = 480u relative.
    let rel = (terms[1].kappa as f64 - kappa).abs() / kappa;
    assert!(rel <= 480.0 * U, "κ {} vs {kappa}: {rel:e}", terms[1].kappa);
    println!(
        "hexagon area rel err {:e}, cap κ rel err {rel:e}",
        (terms[0].area as f64 - area).abs() / area
    );
}

#[test]
fn bad_ring_batches_are_input_errors() {
    let Some(gpu) = gpu_or_skip() else { return };
    let angles: Vec<f64> = (0..6).map(|k| k as f64 * PI / 3.0).collect();
    let good = one_ring([0.0; 3], &planar(&[1.0; 6], &angles), KIND_DISK, 0, 0);
    let mut short = good.clone();
    short.rings[0].count = 2;
    let mut outside = good.clone();
    outside.neighbours[2] = 99;
    let mut beyond = good.clone();
    beyond.rings[0].first = 3;
    let mut feature = good.clone();
    feature.rings[0].kind = KIND_FEATURE_LINE;
    feature.rings[0].s = 4;
    feature.rings[0].t = 2;
    let mut kind = good.clone();
    kind.rings[0].kind = 7;
    for bad in [short, outside, beyond, feature, kind] {
        assert!(matches!(priority::run(&gpu, &bad), Err(GpuError::Input(_))));
        assert!(matches!(flatten::run(&gpu, &bad), Err(GpuError::Input(_))));
    }
}

/// One removal on a flat fan: vertex 0 at the origin with six ring vertices in z = 0 (μ equals
/// the xy coordinates: a = 1, rigid), star faces 0..6 = (0, j_m, j_{m+1}), new faces 6..10 the
/// fan from j_0. Returns the tables (base faces 6..10) and the xy of every vertex.
fn flat_fan_tables() -> (InverseTables, Vec<[f64; 2]>) {
    let xy: Vec<[f64; 2]> = std::iter::once([0.0, 0.0])
        .chain((0..6).map(|k| {
            let a = k as f64 * PI / 3.0 + 0.2 * (k as f64).sin();
            let r = 1.0 + 0.25 * (k as f64).cos();
            [r * a.cos(), r * a.sin()]
        }))
        .collect();
    let mu = |v: u32| {
        let p = xy[v as usize];
        [p[0] as f32, p[1] as f32]
    };
    let mut faces = Vec::new();
    let mut charts = Vec::new();
    for m in 0..6u32 {
        let corners = [0, 1 + m, 1 + (m + 1) % 6];
        faces.push(DecimationFace {
            corners,
            created_by: NONE,
        });
        charts.push(FaceCharts {
            created: [[0.0; 2]; 3],
            removed: corners.map(mu),
        });
    }
    for m in 0..4u32 {
        let corners = [1, 2 + m, 3 + m];
        faces.push(DecimationFace {
            corners,
            created_by: 0,
        });
        charts.push(FaceCharts {
            created: corners.map(mu),
            removed: [[0.0; 2]; 3],
        });
    }
    let tables = InverseTables {
        positions: xy
            .iter()
            .map(|p| [p[0] as f32, p[1] as f32, 0.0, 0.0])
            .collect(),
        faces,
        charts,
        removals: vec![[0, 6]],
        old_faces: (0..6).collect(),
        base_to_face: (6..10).collect(),
    };
    (tables, xy)
}

#[test]
fn inverse_through_one_flat_removal_is_the_identity() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (tables, xy) = flat_fan_tables();
    let mut queries = Vec::new();
    for face in 0..4u32 {
        for (i, j) in [(1, 1), (3, 1), (1, 3), (2, 2), (5, 1), (0, 3), (6, 0)] {
            let b = [i as f64 / 8.0, j as f64 / 8.0, 1.0 - (i + j) as f64 / 8.0];
            queries.push((face, b));
        }
    }
    let batch: Vec<BaseQuery> = queries
        .iter()
        .map(|(face, b)| BaseQuery {
            bary: b.map(|x| x as f32),
            face: *face,
        })
        .collect();
    let results = inverse::run(&gpu, &tables, &batch).unwrap();
    for ((face, b), r) in queries.iter().zip(&results) {
        // Flat and rigid: Π⁻¹ of a base point is the point itself, Σ b_c P(corner_c).
        let corners = tables.faces[6 + *face as usize].corners;
        let expected: [f64; 2] = std::array::from_fn(|x| {
            (0..3)
                .map(|c| b[c] * xy[corners[c] as usize][x])
                .sum::<f64>()
        });
        // u = Σ b_c μ_c: 3 roundings of terms ≤ 1.25 (≤ 5u·1.25 with the rounded b and μ);
        // barycentrics in the star face, each orient2d ≈ 3 roundings of products ≤ 2.5² and the
        // division, ≈ 8u·(diameter²/(2·area)) ≈ 8u·6 relative; clamping and the final
        // interpolation ≈ 5u·1.25 more. ≤ 70u in all.
        let err = dist([r.position[0], r.position[1]], expected);
        assert!(
            err <= 70.0 * U,
            "{face} {b:?}: {r:?} vs {expected:?} ({err:e})"
        );
        assert!(r.face < 6, "ended on {}", r.face);
        assert!(r.min_bary >= -1e-6);
    }
}

#[test]
fn inverse_tables_are_validated() {
    let Some(gpu) = gpu_or_skip() else { return };
    let (good, _) = flat_fan_tables();
    let q = [BaseQuery {
        bary: [0.2, 0.3, 0.5],
        face: 0,
    }];
    assert!(inverse::run(&gpu, &good, &q).is_ok());
    let mut cycle = good.clone();
    cycle.old_faces[2] = 7; // an old face created by the same removal: the walk could loop
    let mut corner = good.clone();
    corner.faces[3].corners[1] = 42;
    let mut creator = good.clone();
    creator.faces[7].created_by = 5;
    let mut charts = good.clone();
    charts.charts.pop();
    for bad in [cycle, corner, creator, charts] {
        assert!(matches!(
            inverse::run(&gpu, &bad, &q),
            Err(GpuError::Input(_))
        ));
    }
    let far = [BaseQuery {
        bary: [0.2, 0.3, 0.5],
        face: 4,
    }];
    assert!(matches!(
        inverse::run(&gpu, &good, &far),
        Err(GpuError::Input(_))
    ));
}
