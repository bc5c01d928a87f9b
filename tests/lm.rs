//! Properties of the bound-constrained Levenberg–Marquardt solver (src/lm/) and of its box QP.

mod common;

use common::Rng;
use nalgebra::{DMatrix, DVector};
use reparam::lm::*;
use reparam::Error;

const INF: f64 = f64::INFINITY;

// ------------------------------------------------------------------------------------------
// Box QP
// ------------------------------------------------------------------------------------------

/// q(h) = ½ hᵀA h + gᵀh.
fn q(a: &DMatrix<f64>, g: &DVector<f64>, h: &DVector<f64>) -> f64 {
    0.5 * h.dot(&(a * h)) + g.dot(h)
}

/// A = BᵀB + ½I with B uniform in [−1, 1]: SPD, eigenvalues in [½, n² + ½].
fn random_spd(rng: &mut Rng, n: usize) -> DMatrix<f64> {
    let b = DMatrix::from_fn(n, n, |_, _| rng.uniform(-1.0, 1.0));
    b.transpose() * &b + DMatrix::identity(n, n) * 0.5
}

/// Per variable one of: unbounded, only an upper side, only a lower side, fixed (l = u),
/// or a finite interval; values in [−1, 1] so that bounds are often active for g ~ ±3.
fn random_bounds(rng: &mut Rng, n: usize) -> (DVector<f64>, DVector<f64>) {
    let mut lower = DVector::zeros(n);
    let mut upper = DVector::zeros(n);
    for i in 0..n {
        let (l, u) = match rng.next_u64() % 6 {
            0 => (-INF, INF),
            1 => (-INF, rng.uniform(-1.0, 1.0)),
            2 => (rng.uniform(-1.0, 1.0), INF),
            3 => {
                let c = rng.uniform(-1.0, 1.0);
                (c, c)
            }
            _ => {
                let (a, b) = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
                (a.min(b), a.max(b))
            }
        };
        lower[i] = l;
        upper[i] = u;
    }
    (lower, upper)
}

/// The largest violation of the KKT conditions of the box QP at h, relative to the size of the
/// terms of the gradient Ah + g. h must be feasible (asserted exactly); at l_i < h_i < u_i the
/// gradient must vanish, at h_i = l_i be ≥ 0, at h_i = u_i be ≤ 0.
fn kkt_violation(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
    h: &DVector<f64>,
) -> f64 {
    let grad = a * h + g;
    let scale = 1.0 + g.amax() + a.abs().row_sum().amax() * h.amax();
    let mut worst = 0.0_f64;
    for i in 0..h.len() {
        assert!(
            lower[i] <= h[i] && h[i] <= upper[i],
            "infeasible: h[{i}] = {} outside [{}, {}]",
            h[i],
            lower[i],
            upper[i]
        );
        let v = if lower[i] == upper[i] {
            assert_eq!(h[i], lower[i], "fixed variable {i} moved");
            0.0
        } else if h[i] == lower[i] {
            (-grad[i]).max(0.0)
        } else if h[i] == upper[i] {
            grad[i].max(0.0)
        } else {
            grad[i].abs()
        };
        worst = worst.max(v / scale);
    }
    worst
}

/// Brute force: for each of the 3ⁿ assignments (lower / free / upper) of the variables, hold
/// the assigned ones at their bound, solve the reduced linear system for the free ones, keep
/// the feasible candidates and return the one with the least q.
fn brute_force_box_qp(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> DVector<f64> {
    let n = g.len();
    let mut best: Option<(f64, DVector<f64>)> = None;
    'assignment: for code in 0..3usize.pow(n as u32) {
        let mut h = DVector::zeros(n);
        let mut free = Vec::new();
        let mut c = code;
        for i in 0..n {
            let choice = c % 3;
            c /= 3;
            if lower[i] == upper[i] {
                if choice != 0 {
                    continue 'assignment; // a fixed variable is enumerated once
                }
                h[i] = lower[i];
                continue;
            }
            match choice {
                0 if lower[i].is_finite() => h[i] = lower[i],
                1 if upper[i].is_finite() => h[i] = upper[i],
                2 => free.push(i),
                _ => continue 'assignment, // an infinite side cannot be active
            }
        }
        if !free.is_empty() {
            let mut held = h.clone();
            for &i in &free {
                held[i] = 0.0;
            }
            let r = g + a * &held;
            let rhs = DVector::from_iterator(free.len(), free.iter().map(|&i| -r[i]));
            let a_ff = a.select_rows(&free).select_columns(&free);
            let x = a_ff
                .lu()
                .solve(&rhs)
                .expect("principal submatrix of an SPD matrix");
            for (k, &i) in free.iter().enumerate() {
                // Feasibility with slack 1e-12: the candidate of the true active set may touch
                // a bound only through rounding (values are O(1), rounding ~1e-15).
                if x[k] < lower[i] - 1e-12 || x[k] > upper[i] + 1e-12 {
                    continue 'assignment;
                }
                h[i] = x[k];
            }
        }
        let value = q(a, g, &h);
        if best.as_ref().is_none_or(|(b, _)| value < *b) {
            best = Some((value, h));
        }
    }
    best.expect("h = clamp(0) lies in some assignment").1
}

#[test]
fn box_qp_satisfies_kkt_on_random_spd_problems() {
    let mut rng = Rng(0x6c6d_0001);
    for trial in 0..400 {
        let n = 1 + trial % 12;
        let a = random_spd(&mut rng, n);
        let g = DVector::from_fn(n, |_, _| rng.uniform(-3.0, 3.0));
        let (lower, upper) = random_bounds(&mut rng, n);
        let h = solve_box_qp(&a, &g, &lower, &upper);
        // cond(A) ≤ (n² + ½)/½ < 300 for n ≤ 12: the reduced solve loses ≈ cond·ε ≈ 1e-13 in
        // h, the gradient a few ulps more. 1e-10 of the term size leaves 1000× room while any
        // wrong active set gives violations of order 1e-2..1.
        let v = kkt_violation(&a, &g, &lower, &upper, &h);
        assert!(v <= 1e-10, "trial {trial} (n = {n}): KKT violation {v:e}");
    }
}

#[test]
fn box_qp_equals_brute_force_enumeration() {
    let mut rng = Rng(0x6c6d_0002);
    for trial in 0..300 {
        let n = 1 + trial % 6;
        let a = random_spd(&mut rng, n);
        let g = DVector::from_fn(n, |_, _| rng.uniform(-3.0, 3.0));
        let (lower, upper) = random_bounds(&mut rng, n);
        let h = solve_box_qp(&a, &g, &lower, &upper);
        let expected = brute_force_box_qp(&a, &g, &lower, &upper);
        // Both solve the same reduced system (cond < 80 for n ≤ 6) for the same active set:
        // they agree to ~1e-14. 1e-9 is far below any difference between active sets, which
        // moves h by O(0.1). The objective check guards the comparison itself.
        let dh = (&h - &expected).amax();
        assert!(
            dh <= 1e-9,
            "trial {trial}: |h − h_bf| = {dh:e}\n{h}\n{expected}"
        );
        assert!(q(&a, &g, &h) <= q(&a, &g, &expected) + 1e-12);
    }
}

/// A = BᵀB + ½I with B banded (b_ij = 0 for |i − j| > w/2), so A has half-bandwidth ≤ w: the
/// pattern of the grid energies' JᵀJ, which the envelope Cholesky exploits.
fn random_banded_spd(rng: &mut Rng, n: usize, w: usize) -> DMatrix<f64> {
    let half = w / 2;
    let b = DMatrix::from_fn(n, n, |i, j| {
        if i.abs_diff(j) <= half {
            rng.uniform(-1.0, 1.0)
        } else {
            0.0
        }
    });
    b.transpose() * &b + DMatrix::identity(n, n) * 0.5
}

#[test]
fn envelope_cholesky_equals_dense_cholesky() {
    let mut rng = Rng(0x6c6d_0005);
    for trial in 0..60 {
        let n = 1 + trial % 20;
        let a = match trial % 3 {
            0 => random_spd(&mut rng, n),
            1 => random_banded_spd(&mut rng, n, 2),
            _ => {
                // An arrow: row i couples with 0 and i only, so the envelope holds zeros that
                // fill in (L_ij ≠ 0 inside it) and must be kept.
                let mut a = DMatrix::identity(n, n) * (n as f64 + 1.0);
                for i in 1..n {
                    a[(i, 0)] = rng.uniform(-1.0, 1.0);
                    a[(0, i)] = a[(i, 0)];
                }
                a
            }
        };
        let b = DVector::from_fn(n, |_, _| rng.uniform(-1.0, 1.0));
        let x = EnvelopeCholesky::factor(n, |i, j| a[(i, j)])
            .unwrap()
            .solve(&b);
        let expected = a.clone().cholesky().unwrap().solve(&b);
        // cond(A) < 2·(n² + ½)/½ ≈ 1600 for n ≤ 20: the two factorisations (same operations,
        // other summation order) agree to cond·n·ε ≈ 1e-11 relative; 1e-10 is far below the
        // O(1) error of a wrong entry in the factor.
        let err = (&x - &expected).amax() / expected.amax().max(1.0);
        assert!(err <= 1e-10, "trial {trial} (n = {n}): {err:e}");
        assert!((&a * &x - &b).amax() <= 1e-10 * a.amax() * x.amax().max(1.0));
    }
    // Not positive definite: no factor (never a NaN solution).
    let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    assert!(EnvelopeCholesky::factor(2, |i, j| indefinite[(i, j)]).is_none());
    let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]);
    assert!(EnvelopeCholesky::factor(2, |i, j| singular[(i, j)]).is_none());
}

#[test]
fn box_qp_equals_brute_force_enumeration_on_banded_problems() {
    let mut rng = Rng(0x6c6d_0006);
    for trial in 0..200 {
        let n = 2 + trial % 7;
        let a = random_banded_spd(&mut rng, n, 2);
        let g = DVector::from_fn(n, |_, _| rng.uniform(-3.0, 3.0));
        let (lower, upper) = random_bounds(&mut rng, n);
        let h = solve_box_qp(&a, &g, &lower, &upper);
        let expected = brute_force_box_qp(&a, &g, &lower, &upper);
        // B has ≤ 3 entries in [−1, 1] per row and column, so ‖B‖² ≤ 9 and cond(A) ≤ 9.5/0.5 =
        // 19: both solutions agree to ~1e-14; a wrong active set moves h by O(0.1).
        let dh = (&h - &expected).amax();
        assert!(dh <= 1e-9, "trial {trial}: |h − h_bf| = {dh:e}");
    }
}

#[test]
fn box_qp_edge_cases() {
    let a = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0]);
    let g = DVector::from_column_slice(&[1.0, -2.0, 0.5]);
    // Unbounded: the Newton point −A⁻¹g (agreement to a few ulps of a 3×3 solve, cond ≈ 3).
    let h = solve_box_qp(&a, &g, &DVector::repeat(3, -INF), &DVector::repeat(3, INF));
    let newton = -a.clone().lu().solve(&g).unwrap();
    assert!((&h - &newton).amax() <= 1e-14, "{h} vs {newton}");
    // Every variable fixed: h is the fixed point, bit for bit.
    let c = DVector::from_column_slice(&[0.1, -0.3, 0.7]);
    assert_eq!(solve_box_qp(&a, &g, &c, &c), c);
    // Box not containing 0, all of it above: the start clamp(0) is on the lower side.
    let lower = DVector::from_column_slice(&[1.0, 1.0, 1.0]);
    let upper = DVector::from_column_slice(&[2.0, 2.0, 2.0]);
    let h = solve_box_qp(&a, &g, &lower, &upper);
    assert!(kkt_violation(&a, &g, &lower, &upper, &h) <= 1e-14);
    assert_eq!(h, brute_force_box_qp(&a, &g, &lower, &upper));
    // Degenerate: minimiser of the unbounded problem exactly on the bounds, zero multipliers.
    let eye = DMatrix::identity(3, 3);
    let g = DVector::from_column_slice(&[-1.0, 0.0, 1.0]);
    let h = solve_box_qp(
        &eye,
        &g,
        &DVector::repeat(3, -1.0),
        &DVector::repeat(3, 1.0),
    );
    assert_eq!(h, DVector::from_column_slice(&[1.0, 0.0, -1.0]));
    // Ill-conditioned (cond ≈ 1e12): must still terminate with a feasible point satisfying
    // KKT to the accuracy the conditioning allows (ε·cond ≈ 1e-4 relative).
    let ill = DMatrix::from_row_slice(2, 2, &[1.0, 1.0 - 1e-12, 1.0 - 1e-12, 1.0]);
    let g = DVector::from_column_slice(&[1.0, -1.0]);
    let (lo, hi) = (DVector::repeat(2, -5.0), DVector::repeat(2, 5.0));
    let h = solve_box_qp(&ill, &g, &lo, &hi);
    assert!(kkt_violation(&ill, &g, &lo, &hi, &h) <= 1e-3, "{h}");
}

#[test]
fn box_qp_rejects_bad_input() {
    let a = DMatrix::identity(2, 2);
    let g = DVector::from_column_slice(&[1.0, 1.0]);
    let ok = DVector::from_column_slice(&[-1.0, -1.0]);
    let up = DVector::from_column_slice(&[1.0, 1.0]);
    let bad = |r: reparam::Result<DVector<f64>>| matches!(r, Err(Error::InvalidArgument(_)));
    assert!(bad(try_solve_box_qp(&a, &g, &up, &ok)), "lower > upper");
    assert!(
        bad(try_solve_box_qp(&a, &g, &DVector::repeat(3, 0.0), &up)),
        "sizes"
    );
    assert!(bad(try_solve_box_qp(
        &a,
        &g,
        &DVector::from_column_slice(&[f64::NAN, 0.0]),
        &up
    )));
    let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    assert!(
        bad(try_solve_box_qp(&indefinite, &g, &ok, &up)),
        "not positive definite"
    );
}

// ------------------------------------------------------------------------------------------
// Test problems
// ------------------------------------------------------------------------------------------

/// A closure x ↦ (r(x), J(x)).
trait Model: FnMut(&[f64]) -> (DVector<f64>, DMatrix<f64>) {}
impl<F: FnMut(&[f64]) -> (DVector<f64>, DMatrix<f64>)> Model for F {}

/// A problem given by a closure x ↦ (r(x), J(x)); normal equations formed densely.
struct Dense<F> {
    n: usize,
    f: F,
}

impl<F: Model> Residuals for Dense<F> {
    fn dim(&self) -> usize {
        self.n
    }
    fn energy(&mut self, x: &[f64]) -> f64 {
        (self.f)(x).0.norm_squared()
    }
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        let (r, j) = (self.f)(x);
        NormalEquations {
            energy: r.norm_squared(),
            jtj: j.transpose() * &j,
            jtr: j.transpose() * r,
        }
    }
}

/// Rosenbrock as residuals r = (10(y − x²), 1 − x): F = 100(y − x²)² + (1 − x)².
fn rosenbrock() -> Dense<impl Model> {
    Dense {
        n: 2,
        f: |x: &[f64]| {
            let r = DVector::from_column_slice(&[10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]);
            let j = DMatrix::from_row_slice(2, 2, &[-20.0 * x[0], 10.0, -1.0, 0.0]);
            (r, j)
        },
    }
}

/// Rosenbrock plus a third unknown z coupled to x by r₃ = z − x (used with z frozen).
fn rosenbrock_coupled() -> Dense<impl Model> {
    Dense {
        n: 3,
        f: |x: &[f64]| {
            let r =
                DVector::from_column_slice(&[10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0], x[2] - x[0]]);
            let j = DMatrix::from_row_slice(
                3,
                3,
                &[-20.0 * x[0], 10.0, 0.0, -1.0, 0.0, 0.0, -1.0, 0.0, 1.0],
            );
            (r, j)
        },
    }
}

/// Fit y ≈ a·exp(b t) to 11 samples of 2·exp(−1.3 t) + 0.05 sin(7k): a non-zero-residual
/// problem, so the paper preset cannot stop on F = 0.
fn exp_fit() -> Dense<impl Model> {
    let t: Vec<f64> = (0..11).map(|k| k as f64 / 10.0).collect();
    let y: Vec<f64> = (0..11)
        .map(|k| 2.0 * (-1.3 * t[k]).exp() + 0.05 * (7.0 * k as f64).sin())
        .collect();
    Dense {
        n: 2,
        f: move |x: &[f64]| {
            let e: Vec<f64> = t.iter().map(|&t| (x[1] * t).exp()).collect();
            let r = DVector::from_fn(11, |k, _| x[0] * e[k] - y[k]);
            let j = DMatrix::from_fn(11, 2, |k, c| if c == 0 { e[k] } else { x[0] * t[k] * e[k] });
            (r, j)
        },
    }
}

/// Linear least squares r = M x − b.
fn linear(m: DMatrix<f64>, b: DVector<f64>) -> Dense<impl Model> {
    Dense {
        n: m.ncols(),
        f: move |x: &[f64]| (&m * DVector::from_column_slice(x) - &b, m.clone()),
    }
}

/// Wraps a problem: records every point it is called at and whether it lay in the bounds, and
/// counts the calls.
struct Instrumented<P> {
    inner: P,
    bounds: Bounds,
    points: Vec<Vec<f64>>,
    out_of_bounds: usize,
    energy_calls: usize,
    jacobian_calls: usize,
}

impl<P> Instrumented<P> {
    fn new(inner: P, bounds: &Bounds) -> Self {
        Instrumented {
            inner,
            bounds: bounds.clone(),
            points: Vec::new(),
            out_of_bounds: 0,
            energy_calls: 0,
            jacobian_calls: 0,
        }
    }
    fn record(&mut self, x: &[f64]) {
        let inside =
            (0..x.len()).all(|i| self.bounds.lower[i] <= x[i] && x[i] <= self.bounds.upper[i]);
        if !inside {
            self.out_of_bounds += 1;
        }
        self.points.push(x.to_vec());
    }
}

impl<P: Residuals> Residuals for Instrumented<P> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn energy(&mut self, x: &[f64]) -> f64 {
        self.record(x);
        self.energy_calls += 1;
        self.inner.energy(x)
    }
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        self.record(x);
        self.jacobian_calls += 1;
        self.inner.normal_equations(x)
    }
}

/// Energy +∞ wherever x₀ > limit (an "invalid" region such as a folded cell), in the normal
/// equations too (as [`Residuals::normal_equations`] requires); counts normal equations
/// requested there (`minimize` must ask for none: it asks only at accepted points).
struct InvalidBeyond<P> {
    inner: P,
    limit: f64,
    jacobians_at_invalid: usize,
}

impl<P: Residuals> Residuals for InvalidBeyond<P> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn energy(&mut self, x: &[f64]) -> f64 {
        if x[0] > self.limit {
            INF
        } else {
            self.inner.energy(x)
        }
    }
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        let mut normal = self.inner.normal_equations(x);
        if x[0] > self.limit {
            self.jacobians_at_invalid += 1;
            normal.energy = INF;
        }
        normal
    }
}

/// Run `minimize` on an instrumented problem and check what every run must satisfy: all points
/// inside the bounds, the counters match the calls, F(x₀) then strictly decreasing accepted
/// energies ending at the reported one, no NaN.
fn run<P: Residuals>(
    problem: P,
    x0: &[f64],
    bounds: &Bounds,
    options: &LmOptions,
) -> (LmReport, Instrumented<P>) {
    let mut p = Instrumented::new(problem, bounds);
    let report = minimize(&mut p, x0, bounds, options).expect("valid input");
    assert_eq!(
        p.out_of_bounds, 0,
        "points outside the bounds were evaluated"
    );
    assert_eq!(report.energy_evaluations, p.energy_calls);
    assert_eq!(report.jacobian_evaluations, p.jacobian_calls);
    assert_eq!(report.accepted_energies.len(), report.iterations + 1);
    assert!(
        report.accepted_energies.windows(2).all(|w| w[1] < w[0]),
        "accepted energies not strictly decreasing: {:?}",
        report.accepted_energies
    );
    assert_eq!(*report.accepted_energies.last().unwrap(), report.energy);
    assert!(report.energy.is_finite() && report.x.iter().all(|v| v.is_finite()));
    (report, p)
}

// ------------------------------------------------------------------------------------------
// Levenberg–Marquardt
// ------------------------------------------------------------------------------------------

#[test]
fn rosenbrock_unconstrained_reaches_one_one() {
    let bounds = Bounds::unbounded(2);
    let (report, _) = run(rosenbrock(), &[-1.2, 1.0], &bounds, &LmOptions::default());
    // Zero-residual problem: Gauss–Newton converges quadratically, so stopping by any of the
    // 1e-12 tests leaves x within ~1e-12 of (1, 1); 1e-9 leaves room, a wrong minimiser or
    // a stall on the curved valley floor is ≥ 1e-3 off.
    assert!(
        (report.x[0] - 1.0).abs() <= 1e-9 && (report.x[1] - 1.0).abs() <= 1e-9,
        "{report:?}"
    );
    assert!(report.energy <= 1e-20, "{report:?}");
    assert!(matches!(
        report.stop,
        StopCode::SmallGradient | StopCode::SmallStep | StopCode::RelativeEnergyChange
    ));
}

#[test]
fn rosenbrock_with_upper_bound_on_x() {
    // x ≤ 0.5. For fixed x the valley y = x² zeroes the first residual, leaving (1 − x)²,
    // decreasing on x ≤ 0.5: the minimum is (0.5, 0.25) with F = 0.25. KKT: ∂F/∂x = −1 < 0
    // there (pushes against the upper bound), ∂F/∂y = 0.
    let bounds = Bounds::new(vec![-INF, -INF], vec![0.5, INF]);
    for options in [LmOptions::default(), LmOptions::paper()] {
        let (report, _) = run(rosenbrock(), &[-1.2, 1.0], &bounds, &options);
        // The step reaching a bound is snapped onto it: x = 0.5 exactly.
        assert_eq!(report.x[0], 0.5, "{report:?}");
        // Once x is held, y solves a linear problem (exact up to the damping, which decays by
        // 0.33 per step): y within 1e-9 and F within 1e-12 of the analytic minimum.
        assert!((report.x[1] - 0.25).abs() <= 1e-9, "{report:?}");
        assert!((report.energy - 0.25).abs() <= 1e-12, "{report:?}");
    }
}

#[test]
fn every_evaluated_point_is_inside_a_tight_box() {
    // A box that excludes both the start's neighbourhood and the unconstrained minimum: x₀ is
    // clamped in, and every trial lies in the box (checked by `run`).
    let bounds = Bounds::new(vec![-0.7, 0.1], vec![0.3, 0.2]);
    let (_, p) = run(rosenbrock(), &[-1.2, 1.0], &bounds, &LmOptions::default());
    assert_eq!(
        p.points[0],
        vec![-0.7, 0.2],
        "x₀ must be clamped before the first call"
    );
    assert!(p.points.len() > 2);
    // Along the lower side y = 0.1, F(x) = 100(0.1 − x²)² + (1 − x)² has a local minimum near
    // x = −0.277 (∂F/∂x = −400x(0.1 − x²) − 2(1 − x) changes sign there) and the global one at
    // the corner (0.3, 0.1). Starting from (−0.7, 0.2), LM finds the local one: check that it
    // is a KKT point, y held exactly on its bound (∂F/∂y = 200(0.1 − x²) > 0) and x interior.
    // Even the paper preset, run until no trial lowers F, resolves x only until the decrease
    // ½F''Δx² drowns in F's rounding εF: |∇F| = F''|Δx| ≈ √(2F''εF) ≈ 2e-7 (F ≈ 1.7,
    // F'' ≈ 54). 1e-6 allows for that; a point 1e-4 away from the minimum has ∇F ≈ 5e-3.
    let (report, _) = run(rosenbrock(), &[-1.2, 1.0], &bounds, &LmOptions::paper());
    assert_eq!(report.x[1], 0.1, "{report:?}");
    assert!(-0.7 < report.x[0] && report.x[0] < 0.3, "{report:?}");
    let mut ne_problem = rosenbrock();
    let ne = ne_problem.normal_equations(&report.x);
    let lower = DVector::from_column_slice(&bounds.lower);
    let upper = DVector::from_column_slice(&bounds.upper);
    let pg = projected_gradient(&ne.jtr, &report.x, &lower, &upper);
    assert!(pg.amax() <= 1e-6, "projected gradient {pg} at {report:?}");
}

#[test]
fn a_step_reaching_a_bound_lands_on_it_exactly() {
    // r = x − 10 with x ≤ 0.3: the first box step is h = 0.3 − x₀ exactly, but x₀ + h rounds
    // to 0.29999999999999993 for x₀ = −2/7 and to 0.30000000000000004 (outside) for x₀ = −4/7.
    // The trial point must still be 0.3 bit for bit, and the run ends there after one step.
    let bounds = Bounds::new(vec![-INF], vec![0.3]);
    for x0 in [-2.0 / 7.0, -4.0 / 7.0] {
        let m = DMatrix::from_element(1, 1, 1.0);
        let problem = linear(m, DVector::from_element(1, 10.0));
        let (report, p) = run(problem, &[x0], &bounds, &LmOptions::default());
        assert_eq!(p.points[1], vec![0.3], "first trial point from x₀ = {x0}");
        assert_eq!(
            (report.x.clone(), report.iterations),
            (vec![0.3], 1),
            "{report:?}"
        );
    }
}

#[test]
fn frozen_variable_never_moves() {
    // z is frozen at 0.3 (not a binary fraction) and coupled to x, so the unconstrained step
    // would move it: every evaluated point and the result must keep its bits.
    let z = 0.3_f64;
    let bounds = Bounds::new(vec![-INF, -INF, z], vec![INF, INF, z]);
    for options in [LmOptions::default(), LmOptions::paper()] {
        let (report, p) = run(rosenbrock_coupled(), &[-1.2, 1.0, z], &bounds, &options);
        assert!(p.points.iter().all(|x| x[2].to_bits() == z.to_bits()));
        assert_eq!(report.x[2].to_bits(), z.to_bits());
        assert!(
            report.iterations > 5,
            "must actually have iterated: {report:?}"
        );
    }
}

#[test]
fn zero_residual_start_stops_at_once_bit_identical() {
    // r = x − c with x₀ = c: F(x₀) = 0 exactly. Values chosen not to be binary fractions.
    let c = [0.1, 1.0 / 3.0, -2.7];
    let m = DMatrix::identity(3, 3);
    for options in [LmOptions::default(), LmOptions::paper()] {
        let problem = linear(m.clone(), DVector::from_column_slice(&c));
        let (report, _) = run(problem, &c, &Bounds::unbounded(3), &options);
        assert_eq!(report.iterations, 0);
        assert_eq!(report.energy_evaluations, 0);
        assert_eq!(report.jacobian_evaluations, 1);
        assert_eq!(report.stop, StopCode::SmallGradient);
        assert!(report
            .x
            .iter()
            .zip(&c)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        let (report, _) = run(rosenbrock(), &[1.0, 1.0], &Bounds::unbounded(2), &options);
        assert_eq!((report.iterations, report.x.clone()), (0, vec![1.0, 1.0]));
    }
}

#[test]
fn warm_start_from_converged_solution_takes_at_most_one_iteration() {
    let cases = [
        (Bounds::unbounded(2), [-1.2, 1.0]),
        (Bounds::new(vec![-INF, -INF], vec![0.5, INF]), [-1.2, 1.0]),
    ];
    for (bounds, x0) in cases {
        let options = LmOptions::default();
        let (first, _) = run(rosenbrock(), &x0, &bounds, &options);
        let (second, _) = run(rosenbrock(), &first.x, &bounds, &options);
        assert!(second.iterations <= 1, "{second:?}");
        let (third, _) = run(exp_fit(), &[1.0, 0.0], &Bounds::unbounded(2), &options);
        let (fourth, _) = run(exp_fit(), &third.x, &Bounds::unbounded(2), &options);
        assert!(fourth.iterations <= 1, "{fourth:?}");
    }
}

#[test]
fn paper_preset_runs_to_code_7_default_stops_earlier_at_the_same_energy() {
    // Two problems with F > 0 at the minimum (so neither run can stop on F = 0): the
    // exponential fit, unbounded, and Rosenbrock with x ≤ 0.5 (F* = 0.25).
    let cases = [
        (Bounds::unbounded(2), [1.0, 0.0], true),
        (
            Bounds::new(vec![-INF, -INF], vec![0.5, INF]),
            [-1.2, 1.0],
            false,
        ),
    ];
    for (bounds, x0, is_exp_fit) in cases {
        let go = |options: &LmOptions| {
            if is_exp_fit {
                run(exp_fit(), &x0, &bounds, options).0
            } else {
                run(rosenbrock(), &x0, &bounds, options).0
            }
        };
        let (paper, default) = (go(&LmOptions::paper()), go(&LmOptions::default()));
        assert!(
            matches!(paper.stop, StopCode::NoProgress | StopCode::MaxIterations),
            "{paper:?}"
        );
        assert!(
            matches!(
                default.stop,
                StopCode::RelativeEnergyChange | StopCode::SmallStep | StopCode::SmallGradient
            ),
            "{default:?}"
        );
        // Default stops when a step gains ≤ 1e-12·F or shrinks below 1e-12; what is left of
        // the (fast) convergence is of the same order: 1e-10 relative is ample while any stop
        // before convergence leaves ≥ 1e-6.
        assert!(
            (default.energy - paper.energy).abs() <= 1e-10 * paper.energy,
            "{default:?} vs {paper:?}"
        );
        // The paper preset ends with a string of rejected trials raising λ to overflow.
        let cost = |r: &LmReport| r.energy_evaluations + r.jacobian_evaluations;
        assert!(cost(&default) < cost(&paper), "{default:?} vs {paper:?}");
        assert!(default.iterations <= paper.iterations);
    }
}

#[test]
fn linear_least_squares_follows_damped_gauss_newton_exactly() {
    // M has orthogonal ±1 columns (3 columns of the 8×8 Sylvester–Hadamard matrix), so
    // A = MᵀM = 8I. A damped step from x is then h = −(A + λI)⁻¹g = −(x − x*)·8/(8 + λ):
    // the error shrinks by the factor f = λ/(8 + λ) and F − F* by f². With λ₀ = 1e-3·max
    // diag(2A) = 0.016·… = 0.016 and ρ = 1 (exact model) after each step, λ₁ = 0.33λ₀.
    let m = DMatrix::from_fn(8, 3, |i, j| if (i >> j) & 1 == 0 { 1.0 } else { -1.0 });
    let b = DVector::from_column_slice(&[1.0, -0.5, 2.0, 0.3, -1.2, 0.8, 0.1, -0.7]);
    let x_star = (m.transpose() * &b) / 8.0;
    let f_star = (&m * &x_star - &b).norm_squared();
    let (report, _) = run(
        linear(m, b),
        &[0.0; 3],
        &Bounds::unbounded(3),
        &LmOptions::default(),
    );
    let e = &report.accepted_energies;
    let lambda0 = 1e-3 * 16.0;
    let f1 = lambda0 / (8.0 + lambda0);
    let f2 = 0.33 * lambda0 / (8.0 + 0.33 * lambda0);
    // F₁ − F* ≈ 2.5e-5·(F₀ − F*) is computed from differences of O(1) energies: rounding
    // ≈ 1e-16/2.5e-5 ≈ 4e-12 relative; 1e-8 leaves room and still detects a λ₀ off by 1%.
    let gap0 = e[0] - f_star;
    assert!(
        ((e[1] - f_star) / gap0 / (f1 * f1) - 1.0).abs() <= 1e-8,
        "{e:?}"
    );
    // After two steps the gap is f₁²f₂² ≈ 2.8e-11 of the initial one: converged to the
    // energy's rounding level (1e-16/2.8e-11 ≈ 4e-6 relative error of the ratio; 1e-3 allowed).
    assert!(
        ((e[2] - f_star) / gap0 / (f1 * f1 * f2 * f2) - 1.0).abs() <= 1e-3,
        "{e:?}"
    );
    // The relative-change test needs one or two more (tiny) steps to fire.
    assert!(report.iterations <= 4, "{report:?}");
}

#[test]
fn bounded_linear_least_squares_equals_the_box_qp() {
    // F = ‖Mx − b‖² = 2(½ xᵀ(MᵀM)x − (Mᵀb)ᵀx) + ‖b‖²: its box-constrained minimiser is the box
    // QP's with A = MᵀM, g = −Mᵀb.
    let mut rng = Rng(0x6c6d_0003);
    for _ in 0..20 {
        let m = DMatrix::from_fn(8, 4, |_, _| rng.uniform(-1.0, 1.0));
        let b = DVector::from_fn(8, |_, _| rng.uniform(-2.0, 2.0));
        let (lower, upper) = random_bounds(&mut rng, 4);
        let expected = solve_box_qp(
            &(m.transpose() * &m),
            &(-(m.transpose() * &b)),
            &lower,
            &upper,
        );
        let bounds = Bounds::new(
            lower.iter().copied().collect(),
            upper.iter().copied().collect(),
        );
        let (report, _) = run(
            linear(m.clone(), b.clone()),
            &[0.0; 4],
            &bounds,
            &LmOptions::paper(),
        );
        // The same active set: where the QP sits on a bound, LM sits on it too, exactly (steps
        // reaching a bound are snapped onto it).
        for i in 0..4 {
            if expected[i] == lower[i] || expected[i] == upper[i] {
                assert_eq!(
                    report.x[i], expected[i],
                    "active set differs at {i}: {report:?}"
                );
            }
        }
        // Energy-based acceptance cannot resolve x below √(ε F / σ_min(MᵀM)): F − F* ≈
        // σ‖Δx‖² is lost in F's rounding (ε F ≈ 1e-15) once ‖Δx‖ ≈ 1e-8..1e-7. Hence F to
        // 1e-13 relative (a few hundred ulps of F) and x to 1e-6; a wrong minimiser is
        // off by O(0.1).
        let dx = (DVector::from_column_slice(&report.x) - &expected).amax();
        assert!(dx <= 1e-6, "LM {:?} vs QP {expected}", report.x);
        let f_qp = (&m * &expected - &b).norm_squared();
        assert!(
            report.energy <= f_qp * (1.0 + 1e-13),
            "{} vs {f_qp}",
            report.energy
        );
    }
}

#[test]
fn invalid_trial_points_are_rejected_without_nan() {
    // Energy +∞ for x > 0.9 although the box allows x ≤ 2: the reachable minimum is on the
    // edge of the valid region, (0.9, 0.81) with F = (1 − 0.9)² = 0.01, approached from below.
    let bounds = Bounds::new(vec![-2.0, -2.0], vec![2.0, 2.0]);
    let problem = InvalidBeyond {
        inner: rosenbrock(),
        limit: 0.9,
        jacobians_at_invalid: 0,
    };
    let (report, p) = run(problem, &[-1.2, 1.0], &bounds, &LmOptions::default());
    assert_eq!(p.inner.jacobians_at_invalid, 0);
    assert!(report.x[0] <= 0.9);
    // The invalid region is a wall the Gauss–Newton model does not see: trials into it are
    // rejected and λ grows until steps are short enough, so LM creeps along the wall
    // (x → 0.9 geometrically) while y still lags behind the valley y = x² = 0.81. It stops
    // (code 2 here) at F ≈ 0.01 + 2e-5: we require a finite result, x within 1e-6 of the
    // wall, and F within 1e-4 of the valid minimum (the start has F = 24.2; a solver stuck at
    // the first rejection stays ≥ 1e-2 away).
    assert!(0.9 - report.x[0] <= 1e-6, "{report:?}");
    assert!(
        report.energy >= 0.01 - 1e-15 && report.energy <= 0.01 + 1e-4,
        "{report:?}"
    );
    // Some trials must actually have hit the invalid region.
    assert!(
        p.points.iter().any(|x| x[0] > 0.9),
        "the test did not exercise rejections"
    );
}

#[test]
fn max_iterations_stops_with_code_5() {
    let options = LmOptions {
        max_iterations: 3,
        ..LmOptions::default()
    };
    let (report, _) = run(rosenbrock(), &[-1.2, 1.0], &Bounds::unbounded(2), &options);
    assert_eq!(
        (report.iterations, report.stop),
        (3, StopCode::MaxIterations)
    );
    let options = LmOptions {
        max_iterations: 0,
        ..LmOptions::default()
    };
    let (report, _) = run(rosenbrock(), &[-1.2, 1.0], &Bounds::unbounded(2), &options);
    assert_eq!(
        (report.iterations, report.x, report.stop),
        (0, vec![-1.2, 1.0], StopCode::MaxIterations)
    );
}

#[test]
fn deterministic_bit_for_bit() {
    let bounds = Bounds::new(vec![-2.0, -INF], vec![0.8, INF]);
    let (a, _) = run(rosenbrock(), &[-1.2, 1.0], &bounds, &LmOptions::paper());
    let (b, _) = run(rosenbrock(), &[-1.2, 1.0], &bounds, &LmOptions::paper());
    assert_eq!(
        serde_json::to_string(&a).unwrap(),
        serde_json::to_string(&b).unwrap()
    );
}

#[test]
fn bad_input_is_a_typed_error() {
    let invalid = |r: reparam::Result<LmReport>| matches!(r, Err(Error::InvalidArgument(_)));
    let free = Bounds::unbounded(2);
    let o = LmOptions::default();
    assert!(
        invalid(minimize(&mut rosenbrock(), &[0.0; 3], &free, &o)),
        "x₀ length"
    );
    assert!(
        invalid(minimize(
            &mut rosenbrock(),
            &[0.0; 2],
            &Bounds::unbounded(3),
            &o
        )),
        "bounds length"
    );
    let crossed = Bounds::new(vec![0.0, 1.0], vec![1.0, 0.0]);
    assert!(
        invalid(minimize(&mut rosenbrock(), &[0.0; 2], &crossed, &o)),
        "lower > upper"
    );
    let nan = Bounds::new(vec![f64::NAN, 0.0], vec![1.0, 1.0]);
    assert!(
        invalid(minimize(&mut rosenbrock(), &[0.0; 2], &nan, &o)),
        "NaN bound"
    );
    assert!(
        invalid(minimize(&mut rosenbrock(), &[f64::NAN, 0.0], &free, &o)),
        "NaN x₀"
    );
    let negative = LmOptions {
        epsf: -1.0,
        ..LmOptions::default()
    };
    assert!(
        invalid(minimize(&mut rosenbrock(), &[0.0; 2], &free, &negative)),
        "negative epsf"
    );
    let mut start_invalid = InvalidBeyond {
        inner: rosenbrock(),
        limit: 0.0,
        jacobians_at_invalid: 0,
    };
    // The starting energy comes with the normal equations; make it infinite there too.
    struct InfiniteAtStart;
    impl Residuals for InfiniteAtStart {
        fn dim(&self) -> usize {
            1
        }
        fn energy(&mut self, _: &[f64]) -> f64 {
            INF
        }
        fn normal_equations(&mut self, _: &[f64]) -> NormalEquations {
            NormalEquations {
                energy: INF,
                jtj: DMatrix::identity(1, 1),
                jtr: DVector::zeros(1),
            }
        }
    }
    assert!(
        invalid(minimize(
            &mut InfiniteAtStart,
            &[0.0],
            &Bounds::unbounded(1),
            &o
        )),
        "F(x₀) = ∞"
    );
    // A valid start inside the valid region is fine even though trials may be invalid.
    assert!(minimize(&mut start_invalid, &[-0.5, 0.0], &free, &o).is_ok());
}

#[test]
fn stop_codes_are_alglibs() {
    let codes = [
        (StopCode::RelativeEnergyChange, 1),
        (StopCode::SmallStep, 2),
        (StopCode::SmallGradient, 4),
        (StopCode::MaxIterations, 5),
        (StopCode::NoProgress, 7),
    ];
    for (stop, code) in codes {
        assert_eq!(stop.code(), code);
        assert!(stop.to_string().starts_with(&code.to_string()));
    }
    assert_eq!(
        LmOptions::paper(),
        LmOptions {
            epsg: 0.0,
            epsf: 0.0,
            epsx: 0.0,
            max_iterations: 100
        }
    );
}

// ------------------------------------------------------------------------------------------
// Speculative normal equations
// ------------------------------------------------------------------------------------------

/// One call to a problem: the energy alone (`'E'`) or the normal equations (`'N'`), and where.
type Call = (char, Vec<f64>);

/// Wraps a problem and logs its calls.
struct Logged<P> {
    inner: P,
    calls: Vec<Call>,
}

impl<P: Residuals> Residuals for Logged<P> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn energy(&mut self, x: &[f64]) -> f64 {
        self.calls.push(('E', x.to_vec()));
        self.inner.energy(x)
    }
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        self.calls.push(('N', x.to_vec()));
        self.inner.normal_equations(x)
    }
}

/// The calls [`Speculative`] must make, given those of the plain run (N at x₀, then per trial
/// E, followed by N there if it was accepted): each trial's normal equations at once if the
/// previous trial was accepted (or it is the first), and nothing more if it is accepted;
/// after a rejected trial its energy alone, then N if it is accepted.
fn speculative_calls(plain: &[Call]) -> Vec<Call> {
    assert_eq!(
        plain[0].0, 'N',
        "the plain run starts with the normal equations at x₀"
    );
    let mut trials = Vec::new(); // (point, accepted)
    for call in &plain[1..] {
        match call {
            ('E', x) => trials.push((x.clone(), false)),
            ('N', x) => {
                let last = trials.last_mut().expect("N only after a trial");
                assert_eq!(&last.0, x, "N at the trial just evaluated");
                last.1 = true;
            }
            _ => unreachable!(),
        }
    }
    let mut out = vec![plain[0].clone()];
    let mut previous_accepted = true;
    for (x, accepted) in trials {
        if previous_accepted {
            out.push(('N', x));
        } else {
            out.push(('E', x.clone()));
            if accepted {
                out.push(('N', x));
            }
        }
        previous_accepted = accepted;
    }
    out
}

/// Run `make()` plain and through [`Speculative`], and compare (see the test below).
fn check_speculative<P: Residuals>(
    make: impl Fn() -> P,
    bounds: &Bounds,
    x0: &[f64],
    options: &LmOptions,
) {
    let mut plain = Logged {
        inner: make(),
        calls: Vec::new(),
    };
    let expected = minimize(&mut plain, x0, bounds, options).unwrap();
    let mut logged = Logged {
        inner: make(),
        calls: Vec::new(),
    };
    let report = minimize(&mut Speculative::new(&mut logged), x0, bounds, options).unwrap();
    // The same run: iterates, energies, counts (LM's, per trial and accepted point) and
    // stop, bit for bit.
    assert_eq!(report.x, expected.x);
    assert_eq!(report.accepted_energies, expected.accepted_energies);
    assert_eq!(
        (report.energy_evaluations, report.jacobian_evaluations),
        (expected.energy_evaluations, expected.jacobian_evaluations)
    );
    assert_eq!(
        (report.iterations, report.stop),
        (expected.iterations, expected.stop)
    );
    // Each case has accepted and rejected trials, so both branches of the policy are taken.
    let rejected = expected.energy_evaluations - expected.iterations;
    assert!(expected.iterations >= 3 && rejected >= 1, "{expected:?}");
    assert_eq!(logged.calls, speculative_calls(&plain.calls));
    // Fewer passes: an accepted trial after an accepted one needs no second pass.
    assert!(logged.calls.len() < plain.calls.len());
}

#[test]
fn speculative_normal_equations_change_the_calls_not_the_run() {
    // The exponential fit with the paper preset (steps accepted, then a string of rejected
    // trials up to λ overflow).
    check_speculative(
        exp_fit,
        &Bounds::unbounded(2),
        &[1.0, 0.0],
        &LmOptions::paper(),
    );
    // Rosenbrock against the bound x ≤ 0.5 (accepted and rejected trials on the curved
    // valley).
    let bounds = Bounds::new(vec![-INF, -INF], vec![0.5, INF]);
    check_speculative(rosenbrock, &bounds, &[-1.2, 1.0], &LmOptions::default());
    // Trials beyond x₀ = 0.9 invalid (+∞, as a folded cell): normal equations asked there
    // return F = +∞ too, and the trial is rejected as in the plain run.
    let invalid = || InvalidBeyond {
        inner: rosenbrock(),
        limit: 0.9,
        jacobians_at_invalid: 0,
    };
    check_speculative(
        invalid,
        &Bounds::unbounded(2),
        &[-1.2, 1.0],
        &LmOptions::default(),
    );
}

#[test]
fn assembled_normal_equations_equal_the_local_parts_added_one_by_one() {
    // `NormalEquations::assemble` adds each part's upper triangle and mirrors it at the end;
    // `add_local` adds every entry. With distinct unknowns per part (every grid cell's case)
    // entry (p, q) receives the same local entries in the same order either way: equal bit
    // for bit. Parts with fixed slots (None) and with two slots of one unknown (equal up to
    // rounding: the order within the part differs) are covered too.
    let mut rng = Rng(5);
    let n = 7;
    let mut part = |slots: [Option<usize>; 4]| {
        let d: [[f64; 4]; 3] =
            std::array::from_fn(|_| std::array::from_fn(|_| rng.uniform(-1.0, 1.0)));
        let mut local = LocalNormalEquations::<4>::default();
        for row in &d {
            local.energy += 0.5 * row[0] * row[0];
            for a in 0..4 {
                local.jtr[a] += row[a] * 0.3;
                for b in 0..4 {
                    local.jtj[a][b] += row[a] * row[b];
                }
            }
        }
        (slots, local)
    };
    let distinct: Vec<_> = [
        [Some(0), Some(1), Some(4), Some(5)],
        [Some(1), Some(2), Some(5), Some(6)],
        [None, Some(0), Some(6), Some(3)],
        [Some(3), None, Some(2), None],
        [Some(6), Some(4), Some(1), Some(0)],
    ]
    .into_iter()
    .map(&mut part)
    .collect();
    let repeated: Vec<_> = [
        [Some(2), Some(2), Some(3), None],
        [Some(5), Some(1), Some(5), Some(0)],
    ]
    .into_iter()
    .map(&mut part)
    .collect();
    let one_by_one = |parts: &[([Option<usize>; 4], LocalNormalEquations<4>)]| {
        let mut total = NormalEquations::zeros(n);
        for (slots, local) in parts {
            total.add_local(slots, local);
        }
        total
    };
    let bits = |m: &[f64]| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let assembled = NormalEquations::assemble(n, distinct.iter().map(|(s, l)| (s, l)));
    let expected = one_by_one(&distinct);
    assert_eq!(assembled.energy.to_bits(), expected.energy.to_bits());
    assert_eq!(
        bits(assembled.jtr.as_slice()),
        bits(expected.jtr.as_slice())
    );
    assert_eq!(
        bits(assembled.jtj.as_slice()),
        bits(expected.jtj.as_slice())
    );
    let all: Vec<_> = distinct.iter().chain(&repeated).cloned().collect();
    let assembled = NormalEquations::assemble(n, all.iter().map(|(s, l)| (s, l)));
    let expected = one_by_one(&all);
    // Entries are sums of a few products of magnitude ≤ 3·1·1 per part (7 parts): a
    // different order of the additions changes them by a few ulps of ≈ 20.
    let close = (&assembled.jtj - &expected.jtj).abs().max();
    assert!(close <= 1e-13, "JᵀJ differs by {close}");
    assert_eq!(assembled.jtj, assembled.jtj.transpose(), "mirrored exactly");
    assert_eq!(
        bits(assembled.jtr.as_slice()),
        bits(expected.jtr.as_slice())
    );
}

#[test]
fn an_assembly_plan_gives_the_bits_of_assemble() {
    // `AssemblyPlan` sums entry by entry what `NormalEquations::assemble` scatters part by
    // part: the same terms in the same order, so the same bits, with fixed slots (None), a
    // slot used twice within a part, unknowns no part touches, and parts that share entries
    // in every pattern (diagonal, off-diagonal, both orders of two unknowns).
    let mut rng = Rng(11);
    let n = 9;
    let slots: Vec<[Option<usize>; 4]> = vec![
        [Some(0), Some(1), Some(4), Some(5)],
        [Some(1), Some(2), Some(5), Some(6)],
        [None, Some(0), Some(6), Some(3)],
        [Some(3), None, Some(2), None],
        [Some(6), Some(4), Some(1), Some(0)],
        [Some(2), Some(2), Some(3), None],
        [Some(5), Some(1), Some(5), Some(0)],
        [None, None, None, None],
        [Some(7), Some(0), Some(7), Some(7)],
    ];
    let parts: Vec<LocalNormalEquations<4>> = slots
        .iter()
        .map(|_| LocalNormalEquations {
            energy: rng.uniform(0.0, 2.0),
            jtj: std::array::from_fn(|_| std::array::from_fn(|_| rng.uniform(-3.0, 3.0))),
            jtr: std::array::from_fn(|_| rng.uniform(-1.0, 1.0)),
        })
        .collect();
    let bits = |m: &[f64]| m.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    let expected = NormalEquations::assemble(n, slots.iter().zip(&parts));
    let planned = AssemblyPlan::new(n, &slots).assemble(&parts);
    assert_eq!(planned.energy.to_bits(), expected.energy.to_bits());
    assert_eq!(bits(planned.jtr.as_slice()), bits(expected.jtr.as_slice()));
    assert_eq!(bits(planned.jtj.as_slice()), bits(expected.jtj.as_slice()));
    assert_eq!(planned.jtr[8], 0.0, "an unknown no part touches stays 0");
    // The plan is the slots' alone: other parts with the same slots, the same bits again.
    let other: Vec<_> = parts
        .iter()
        .map(|p| LocalNormalEquations {
            energy: p.energy * 0.5,
            jtj: p.jtj.map(|row| row.map(|v| v - 0.25)),
            jtr: p.jtr.map(|v| v * 3.0),
        })
        .collect();
    let expected = NormalEquations::assemble(n, slots.iter().zip(&other));
    let planned = AssemblyPlan::new(n, &slots).assemble(&other);
    assert_eq!(bits(planned.jtj.as_slice()), bits(expected.jtj.as_slice()));
    assert_eq!(bits(planned.jtr.as_slice()), bits(expected.jtr.as_slice()));
}

#[test]
#[should_panic(expected = "one local part per planned slot list")]
fn an_assembly_plan_refuses_parts_of_another_count() {
    let plan = AssemblyPlan::new(2, &[[Some(0), Some(1)]]);
    plan.assemble(&[LocalNormalEquations::<2>::default(); 2]);
}
