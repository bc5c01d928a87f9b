//! The authors' unfolding (issue #26): `Unfold::Authors` against a literal transcription of the
//! authors' MATLAB layout, and against the correct unfolding on a star whose neighbour is
//! folded by an angle φ (`procedural::folded_star`).
//!
//! Tolerances: the layouts are a few dozen f64 operations on O(1) coordinates (the star is
//! about 2 units wide), each exact to ε ≈ 1.1e-16 relative, so two formulas for the same point
//! agree to ≈ 1e-15; 1e-12 leaves a thousandfold margin and is still ten orders of magnitude
//! below the differences the authors' layout makes (≥ 0.1 units past 90°, see below).

use nalgebra::{Point3, Vector3};
use num_complex::Complex64 as C;
use reparam::bpm::precompute::{fold_cosines, gather_stars, signed_area2, star_layout, Star};
use reparam::bpm::*;
use reparam::mesh::{procedural, Adjacency, TriMesh, EDGE_CORNERS};

const TOL: f64 = 1e-12;

/// Fold angles in degrees, both ways round (valley and mountain folds).
const NOT_PAST_90: [f64; 7] = [0.0, 30.0, -30.0, 60.0, -60.0, 89.0, -89.0];
const PAST_90: [f64; 8] = [100.0, -100.0, 120.0, -120.0, 150.0, -150.0, 170.0, -170.0];

fn star(fold_degrees: f64) -> TriMesh {
    procedural::folded_star(fold_degrees.to_radians())
}

/// The star of face 0 (t) of `mesh`.
fn star_of_t(mesh: &TriMesh) -> Star {
    gather_stars(mesh, &Adjacency::new(mesh))[0]
}

fn uv_t(star: &Star) -> [C; 3] {
    [star.w[0], star.w[1], star.w[2]]
}

/// Rotation of `q` about the line through `origin` with direction `axis` by `theta`,
/// right-handed about `axis` (Rodrigues).
fn rotate_about_line(
    q: Vector3<f64>,
    origin: Vector3<f64>,
    axis: Vector3<f64>,
    theta: f64,
) -> Vector3<f64> {
    let k = axis.normalize();
    let v = q - origin;
    let rotated = v * theta.cos() + k.cross(&v) * theta.sin() + k * k.dot(&v) * (1.0 - theta.cos());
    origin + rotated
}

/// The authors' layout of the apex across t's edge `e`, transcribed step by step from their
/// `IsometricEmbeddingFStar` (shirrorbe/BPM, BPMTransformPoints.m): t's frame (origin p_i, x
/// along p_j − p_i, z along t's normal), the neighbour's normal from its own corners (b, a,
/// apex), θ = atan2(‖v₁ × v₂‖, v₁·v₂) − π/2 with v₁ = edge × ẑ, rotation about the edge line by θ;
/// returns x + i y and the z left over.
fn authors_matlab_apex(p: &[Point3<f64>; 6], e: usize) -> (C, f64) {
    let ex = (p[1] - p[0]).normalize();
    let ez = (p[1] - p[0]).cross(&(p[2] - p[0])).normalize();
    let ey = ez.cross(&ex);
    let to_frame = |q: &Point3<f64>| {
        let r = q - p[0];
        Vector3::new(r.dot(&ex), r.dot(&ey), r.dot(&ez))
    };
    let [a, b] = EDGE_CORNERS[e];
    let (qa, qb, q_apex) = (to_frame(&p[a]), to_frame(&p[b]), to_frame(&p[3 + e]));
    let edge = qb - qa;
    let normal = (qa - qb).cross(&(q_apex - qb));
    let v1 = edge.cross(&Vector3::z());
    let theta = v1.cross(&normal).norm().atan2(v1.dot(&normal)) - std::f64::consts::FRAC_PI_2;
    let q = rotate_about_line(q_apex, qa, edge, theta);
    (C::new(q.x, q.y), q.z)
}

#[test]
fn the_authors_layout_is_the_authors_matlab_rotation() {
    for fold in NOT_PAST_90.iter().chain(&PAST_90) {
        let s = star_of_t(&star(*fold));
        let (z, mirrored) = star_layout(&s.p, uv_t(&s), Unfold::Authors);
        assert!(!mirrored, "the fixture's UVs are counter-clockwise");
        for e in 0..3 {
            let (expected, z_left) = authors_matlab_apex(&s.p, e);
            assert!(
                (z[3 + e] - expected).norm() < TOL,
                "fold {fold}°, edge {e}: {} vs the MATLAB steps' {expected}",
                z[3 + e]
            );
            // Up to 90° the authors' rotation lays the neighbour flat (this also pins the
            // rotation's handedness: the other one would double the fold instead); past 90° it
            // leaves the neighbour 2φ − π out of the plane.
            let rho = (2.0 * fold.abs().to_radians() - std::f64::consts::PI).max(0.0);
            let expected_height = if e == 0 { 0.7 * rho.sin() } else { 0.0 };
            assert!(
                (z_left.abs() - expected_height).abs() < TOL,
                "fold {fold}°, edge {e}: {z_left} left out of the plane, expected {expected_height}"
            );
        }
    }
}

fn logs_of(bpm: &Bpm) -> Vec<Sl2> {
    bpm.maps.iter().flat_map(|m| m.logs).collect()
}

fn max_log_difference(a: &Bpm, b: &Bpm) -> f64 {
    logs_of(a)
        .iter()
        .zip(logs_of(b))
        .map(|(x, y)| {
            (x.a - y.a)
                .norm()
                .max((x.b - y.b).norm())
                .max((x.c - y.c).norm())
        })
        .fold(0.0, f64::max)
}

fn both(mesh: &TriMesh) -> (Bpm, Bpm) {
    let correct = precompute(mesh, BpmOptions::default()).unwrap();
    let authors = precompute(
        mesh,
        BpmOptions {
            unfold: Unfold::Authors,
            ..Default::default()
        },
    )
    .unwrap();
    (correct, authors)
}

#[test]
fn the_unfoldings_agree_when_no_neighbour_is_folded_past_90_degrees() {
    for fold in NOT_PAST_90 {
        let mesh = star(fold);
        let (correct, authors) = both(&mesh);
        assert_eq!(correct.report.neighbours_folded_past_90, 0, "fold {fold}°");
        // Same operations on the same numbers (`place_apex_authors` scales perp by exactly 1):
        // bit-for-bit equal, so the figures are too.
        assert_eq!(logs_of(&correct), logs_of(&authors), "fold {fold}°");
        for interp in [Interp::Bpm, Interp::Linear] {
            assert_eq!(
                qc_protocol(&correct, interp, 3),
                qc_protocol(&authors, interp, 3),
                "fold {fold}°"
            );
        }
    }
}

#[test]
fn the_unfoldings_differ_when_a_neighbour_is_folded_past_90_degrees() {
    for fold in PAST_90 {
        let mesh = star(fold);
        let (correct, authors) = both(&mesh);
        // The fold is seen from both sides of the edge: from t and from the neighbour.
        assert_eq!(correct.report.neighbours_folded_past_90, 2, "fold {fold}°");
        assert_eq!(
            authors.report, correct.report,
            "the report is the mesh's, not the option's"
        );
        let past_135 = if fold.abs() > 135.0 { 2 } else { 0 };
        assert_eq!(
            correct.report.neighbours_folded_past_135, past_135,
            "fold {fold}°"
        );
        // The apex moves by perp (1 − cos ρ) = 0.7 · 2 cos²φ ≥ 0.7 · 2 cos²100° ≈ 0.042 in the
        // layout, an O(1) fraction of the neighbour: its Möbius map, hence the log ratio, changes
        // at that order, far above the 1e-12 roundoff.
        let d = max_log_difference(&correct, &authors);
        assert!(d > 1e-3, "fold {fold}°: logs differ by only {d:e}");
        // So the interpolant changes in the two faces of the folded edge (BPM only: linear
        // interpolation never reads the neighbours).
        assert_ne!(
            qc_protocol(&correct, Interp::Bpm, 3),
            qc_protocol(&authors, Interp::Bpm, 3),
            "fold {fold}°"
        );
        assert_eq!(
            qc_protocol(&correct, Interp::Linear, 3),
            qc_protocol(&authors, Interp::Linear, 3),
            "fold {fold}°"
        );
    }
}

/// Signed area of t's edge a→b with the apex across it: > 0 on t's side (t is counter-clockwise
/// in the layout), < 0 beyond the edge.
fn apex_side(z: &[C; 6], e: usize) -> f64 {
    let [a, b] = EDGE_CORNERS[e];
    signed_area2(z[a], z[b], z[3 + e])
}

#[test]
fn the_authors_layout_puts_a_neighbour_folded_back_over_t_on_ts_side() {
    for fold in PAST_90 {
        let s = star_of_t(&star(fold));
        let (correct, _) = star_layout(&s.p, uv_t(&s), Unfold::Correct);
        let (authors, _) = star_layout(&s.p, uv_t(&s), Unfold::Authors);
        assert!(signed_area2(correct[0], correct[1], correct[2]) > 0.0);
        // The correct unfolding always puts the apex beyond the edge, at its true distance 0.7.
        assert!(apex_side(&correct, 0) < 0.0, "fold {fold}°");
        assert!(
            (correct[3].im + 0.7).abs() < TOL,
            "fold {fold}°: {}",
            correct[3]
        );
        // The authors' at 0.7 cos ρ beyond it, ρ = 2|φ| − π: on t's side once |φ| > 135°.
        let rho = 2.0 * fold.abs().to_radians() - std::f64::consts::PI;
        assert!(
            (authors[3].im + 0.7 * rho.cos()).abs() < TOL,
            "fold {fold}°: {}",
            authors[3]
        );
        if fold.abs() > 135.0 {
            assert!(apex_side(&authors, 0) > 0.0, "fold {fold}°: {}", authors[3]);
        } else {
            assert!(apex_side(&authors, 0) < 0.0, "fold {fold}°: {}", authors[3]);
        }
        // The along-edge coordinate and the flat neighbours are untouched.
        assert!((authors[3].re - correct[3].re).abs() < TOL);
        assert_eq!(&authors[..3], &correct[..3]);
        assert_eq!(&authors[4..], &correct[4..]);
    }
}

#[test]
fn fold_cosines_measure_the_fold_angle() {
    for fold in NOT_PAST_90.iter().chain(&PAST_90) {
        let cos = fold_cosines(&star_of_t(&star(*fold)));
        assert!(
            (cos[0] - fold.to_radians().cos()).abs() < TOL,
            "fold {fold}°: {cos:?}"
        );
        // The other two neighbours are coplanar with t.
        assert!(
            (cos[1] - 1.0).abs() < TOL && (cos[2] - 1.0).abs() < TOL,
            "{cos:?}"
        );
    }
}

#[test]
fn the_default_unfolding_is_the_correct_one() {
    assert_eq!(BpmOptions::default().unfold, Unfold::Correct);
    // On a flat mesh there is nothing to unfold: both layouts are the same.
    let mesh = procedural::flat_star_affine(12);
    let (correct, authors) = both(&mesh);
    assert_eq!(correct.report.neighbours_folded_past_90, 0);
    assert_eq!(logs_of(&correct), logs_of(&authors));
}
