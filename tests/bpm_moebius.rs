//! Properties of the SL(2,C) layer of BPM (src/bpm/moebius.rs), f64.

mod common;

use common::Rng;
use num_complex::Complex64 as C;
use reparam::bpm::moebius::*;

/// Entry-wise max |A − B|.
fn dist(a: &Mobius, b: &Mobius) -> f64 {
    [a.a - b.a, a.b - b.b, a.c - b.c, a.d - b.d]
        .iter()
        .map(|x| x.norm())
        .fold(0.0, f64::max)
}

fn sl2_dist(a: &Sl2, b: &Sl2) -> f64 {
    a.add(&b.scale(C::new(-1.0, 0.0))).max_abs()
}

fn random_sl2(rng: &mut Rng, r: f64) -> Sl2 {
    Sl2 {
        a: rng.complex(r),
        b: rng.complex(r),
        c: rng.complex(r),
    }
}

#[test]
fn exp_log_at_identity_minus_identity_and_nilpotent() {
    // Exact cases: no rounding is involved beyond a handful of operations on 0 and 1.
    assert_eq!(log_sl2(&Mobius::IDENTITY), Sl2::ZERO);
    let minus_i = Mobius::IDENTITY.scale(C::new(-1.0, 0.0));
    assert_eq!(log_sl2(&minus_i), Sl2::ZERO);
    assert_eq!(exp_sl2(&Sl2::ZERO), Mobius::IDENTITY);
    // Nilpotent N = [[0, 1], [0, 0]]: exp(εN) = I + εN and log(I + εN) = εN exactly (p = q = 0,
    // where published closed forms divide 0 by 0).
    for eps in [1e-300, 1e-8, 1.0, 1e8] {
        let n = Sl2 {
            a: C::new(0.0, 0.0),
            b: C::new(eps, 0.0),
            c: C::new(0.0, 0.0),
        };
        let e = exp_sl2(&n);
        assert_eq!(
            e,
            Mobius::new(
                C::new(1.0, 0.0),
                C::new(eps, 0.0),
                C::new(0.0, 0.0),
                C::new(1.0, 0.0)
            )
        );
        assert_eq!(log_sl2(&e), n);
        // −(I + εN) has the same log after the sign fix.
        assert_eq!(
            log_sl2(&e.scale(C::new(-1.0, 0.0))),
            n.scale(C::new(-1.0, 0.0)).scale(C::new(-1.0, 0.0))
        );
    }
}

#[test]
fn exp_log_round_trip_on_random_arguments() {
    let mut rng = Rng(1);
    for radius in [1e-6, 1e-2, 0.3, 1.0, 1.4] {
        for _ in 0..2000 {
            let y = random_sl2(&mut rng, radius);
            let e = exp_sl2(&y);
            assert!((e.det() - 1.0).norm() < 1e-13, "det exp = {}", e.det());
            // log(exp Y) = Y holds when Y is in the principal domain: the eigenvalues ±μ of Y
            // (μ² = p) have |Im μ| < π/2 (then Re Tr exp Y = 2 Re cosh μ > 0 and no sign flip).
            let mu = (y.a * y.a + y.b * y.c).sqrt();
            if mu.im.abs() < 1.2 {
                let back = log_sl2(&e);
                // Conditioning: d log at exp Y scales errors by at most ~ |μ|/|sinh μ| ≤ ~ 4 here,
                // on entries of size ≤ |Y| ≈ 2: a few hundred ulps of the largest entry.
                let tol = 1e-13 * (1.0 + y.max_abs());
                assert!(sl2_dist(&back, &y) < tol, "Y={y:?} back={back:?}");
            }
        }
    }
}

#[test]
fn log_exp_round_trip_on_random_sl2_matrices() {
    let mut rng = Rng(2);
    for _ in 0..5000 {
        let m = Mobius::new(
            rng.complex(2.0),
            rng.complex(2.0),
            rng.complex(2.0),
            rng.complex(2.0),
        );
        if m.det().norm() < 1e-3 {
            continue;
        }
        let m = m.normalized();
        let l = log_sl2(&m);
        assert!(l.max_abs().is_finite());
        // exp(log A) = ±A; the sign is fixed so that Re Tr ≥ 0. Away from Tr ≈ 0 (rotation by π,
        // where log is ill-conditioned: dlog ~ 1/sqrt(q+1)) the error is a few ulps × |A|².
        if sign_fix(&m).trace().re > 0.05 {
            let back = exp_sl2(&l);
            let scale = [m.a, m.b, m.c, m.d]
                .iter()
                .map(|x| x.norm())
                .fold(1.0, f64::max);
            assert!(
                back.distance_up_to_sign(&m) < 1e-12 * scale * scale,
                "{m:?} -> {back:?}"
            );
        }
    }
}

#[test]
fn series_and_closed_forms_agree_at_the_switch_points() {
    // At the radius where each function switches from its series to its closed form, both
    // branches must agree to rounding: this pins the series coefficients and the number of terms
    // (one term fewer fails: the next term is ≈ 1/20! ≈ 4e-19 for exp but 0.1⁹·0.02 ≈ 2e-11 for log).
    for angle in 0..32 {
        let dir = C::from_polar(1.0, angle as f64 * std::f64::consts::PI / 16.0);
        let (cs, ss) = cosh_sinhc_series(dir);
        let (cc, sc) = cosh_sinhc_closed(dir);
        // |p| = 1: C, S are O(1); cosh, sinh of |r| = 1 are accurate to a few ε.
        assert!(
            (cs - cc).norm() < 1e-15 && (ss - sc).norm() < 1e-15,
            "exp at {dir}: {} {}",
            (cs - cc).norm(),
            (ss - sc).norm()
        );
        let q = dir * 0.1;
        // The closed form ln(r + √(q+1))/r has relative error ≈ ε/|ln(..)| ≈ 3ε at |q| = 0.1;
        // 16 series terms leave ≈ 0.1¹⁶·0.01 (below ε).
        let d = (asinhc_series(q) - asinhc_closed(q)).norm();
        assert!(d < 2e-15, "log at {q}: {d:e}");
    }
}

#[test]
fn taylor_variants_approximate_entire_forms_for_small_arguments() {
    let mut rng = Rng(3);
    for _ in 0..200 {
        let y = random_sl2(&mut rng, 0.05);
        // Three terms: I + Y + Y²/2; the remainder is ~ |Y|³/6 ≈ 3e-5 (entries ≤ 0.1 in size).
        let d3 = dist(&exp_taylor(&y, 3), &exp_sl2(&y));
        assert!(d3 < 1e-4 && d3 > 0.0);
        // Twenty terms converge to rounding.
        assert!(dist(&exp_taylor(&y, 20), &exp_sl2(&y)) < 1e-15);
        let a = exp_sl2(&y);
        assert!(sl2_dist(&log_taylor(&a, 40), &y) < 1e-14);
    }
}

#[test]
fn both_fits_pass_through_the_three_points() {
    let mut rng = Rng(4);
    for _ in 0..1000 {
        let z = [rng.complex(1.0), rng.complex(1.0), rng.complex(1.0)];
        let w = [rng.complex(1.0), rng.complex(1.0), rng.complex(1.0)];
        let min_gap = |p: &[C; 3]| {
            (p[0] - p[1])
                .norm()
                .min((p[1] - p[2]).norm())
                .min((p[2] - p[0]).norm())
        };
        if min_gap(&z) < 0.05 || min_gap(&w) < 0.05 {
            continue;
        }
        let local = fit_mobius_local(z, w);
        let det = fit_mobius_det(z, w);
        for m in [&local, &det] {
            assert!((m.det() - 1.0).norm() < 1e-10);
            for n in 0..3 {
                // Well-separated points (gap ≥ 0.05 in a unit box): conditioning ≲ 1e3.
                assert!((mobius_apply(m, z[n]) - w[n]).norm() < 1e-11);
            }
        }
        // The same map: equal up to the sign of SL(2,C).
        assert!(
            local.distance_up_to_sign(&det)
                < 1e-8 * (1.0 + local.a.norm().max(local.d.norm())).powi(2)
        );
    }
}

#[test]
fn cross_ratio_identity_for_the_ratio_of_two_fits() {
    // Two triangles sharing the edge (z0, z1): δ = M_t⁻¹ M_u satisfies Tr(δ)² = m + 2 + 1/m with
    // m = cr(w) / cr(z), the ratio of the quad's cross-ratios in UV and in the layout.
    let mut rng = Rng(5);
    let mut tested = 0;
    while tested < 500 {
        let z = [
            rng.complex(1.0),
            rng.complex(1.0),
            rng.complex(1.0),
            rng.complex(1.0),
        ];
        let w = [
            rng.complex(1.0),
            rng.complex(1.0),
            rng.complex(1.0),
            rng.complex(1.0),
        ];
        let m_t = fit_mobius_local([z[0], z[1], z[2]], [w[0], w[1], w[2]]);
        let m_u = fit_mobius_local([z[1], z[0], z[3]], [w[1], w[0], w[3]]);
        let delta = mobius_mul(&mobius_inverse(&m_t), &m_u);
        // quad (i, j; k, l) with the shared edge i j first.
        let m = cross_ratio(w) / cross_ratio(z);
        let lhs = delta.trace() * delta.trace();
        let rhs = m + 2.0 + 1.0 / m;
        if lhs.norm() > 1e3 || !rhs.norm().is_finite() {
            continue;
        }
        assert!(
            (lhs - rhs).norm() < 1e-8 * (1.0 + rhs.norm()),
            "lhs {lhs} rhs {rhs}"
        );
        tested += 1;
    }
}

#[test]
fn algebraic_square_root_matches_the_polar_one() {
    // c_sqrt (algebraic, as in the WGSL twin) against num-complex's polar √r·e^{iθ/2}: both are
    // accurate to a few ulps of |√z|, and they must pick the same branch, including on the cut.
    let mut rng = Rng(6);
    let mut cases: Vec<C> = (0..20_000)
        .map(|_| {
            let scale = 10f64.powf(rng.uniform(-8.0, 8.0));
            rng.complex(scale)
        })
        .collect();
    cases.extend([
        C::new(-4.0, 0.0),
        C::new(-4.0, -0.0),
        C::new(4.0, 0.0),
        C::new(0.0, 2.0),
        C::new(0.0, -2.0),
        C::new(1e-300, 0.0),
    ]);
    for z in cases {
        let (a, b) = (c_sqrt(z), z.sqrt());
        assert!(
            (a - b).norm() <= 4.0 * f64::EPSILON * b.norm(),
            "{z}: {a} vs {b}"
        );
        assert!(
            (a * a - z).norm() <= 8.0 * f64::EPSILON * z.norm(),
            "{z}: {a}² ≠ z"
        );
    }
    assert_eq!(c_sqrt(C::new(0.0, 0.0)), C::new(0.0, 0.0));
}
