//! Bound-constrained Levenberg–Marquardt with ALGLIB `minlm` semantics, generic over a
//! [`Residuals`] problem given through its normal equations.
//!
//! Koniaris et al. (CVMP 2013, seed 000 §5.3, §7) minimise their grid-warp energy with ALGLIB's
//! bound-constrained Levenberg–Marquardt optimiser ("all tolerances 0, 100 iterations"). No Rust
//! crate offers bounds with exact box-constrained steps, so this module is our own, written to
//! behave like `minlm`; its rules are restated below (§ One iteration, § Stopping).
//!
//! # The problem
//!
//! minimise F(x) = Σ_k r_k(x)²   subject to   l ≤ x ≤ u   (l_i = u_i freezes x_i).
//!
//! The problem is handed over through its normal equations at x: F, A = JᵀJ and g = Jᵀr
//! (J = ∂r/∂x is never stored). ∇F = 2g, and the Gauss–Newton model of F around x is
//!
//!   F(x + h) ≈ m(h) = ‖r + J h‖² = F + 2 gᵀh + hᵀA h.
//!
//! # One iteration (= one accepted step)
//!
//! 1. **Damped box step.** h_λ = argmin hᵀ(A + λI)h + 2gᵀh  subject to  l − x ≤ h ≤ u − x,
//!    solved *exactly* by [`solve_box_qp`] (an active-set method), not by projecting the
//!    unconstrained step onto the box. h_λ = 0 means no feasible descent direction exists:
//!    stop with [`StopCode::NoProgress`]; max_i |h_i| ≤ epsx: stop with [`StopCode::SmallStep`]
//!    at x, without evaluating x + h.
//! 2. **Predicted decrease** of the undamped model: pred = m(0) − m(h) = −hᵀ(2g + A h)
//!    (≥ λ‖h‖² > 0 in exact arithmetic for A ⪰ 0). If it is ≤ 0 the trial counts as rejected.
//! 3. **Trial point** x_t = x + h, snapped exactly onto every bound the step reaches (so bounds
//!    hold bit for bit); F_t = F(x_t) via [`Residuals::energy`].
//! 4. **Rejected** (F_t ≥ F or not finite, e.g. a folded grid cell): λ ← 2νλ, ν ← 2ν, back to 1.
//!    If 2νλ would exceed [`LAMBDA_MAX`] stop with [`StopCode::NoProgress`] (λ overflow).
//! 5. **Accepted** (F_t < F): gain ratio ρ = (F − F_t)/pred, then
//!    ρ > 0.5: λ ← 0.33λ, ν ← 1;  ρ < 0.1: λ ← 2νλ, ν ← 2ν (a poor model: damp more);
//!    otherwise λ, ν unchanged. Accepted energies therefore strictly decrease.
//!
//! Each trial point costs a call of [`Residuals::energy`], each accepted point one of
//! [`Residuals::normal_equations`]; wrapped in [`Speculative`], a problem computes a trial's
//! normal equations with its energy while trials are being accepted (same run, fewer passes).
//!
//! λ₀ = 10⁻³ · max_i (2JᵀJ)_ii (1 if that is 0), ν₀ = 1 (Madsen, Nielsen & Tingleff §3.2 use
//! τ = 10⁻³ on the diagonal of the Gauss–Newton Hessian; ALGLIB the same schedule with
//! λ_up = 2 and λ_down = 0.33).
//!
//! # Stopping ([`StopCode`], ALGLIB's termination codes)
//!
//! Tested in this order, a tolerance of 0 turning its test off:
//! - F = 0 (at x₀ or after a step): a sum of squares is at its global minimum and ∇F = 2Jᵀr = 0
//!   exactly: code 4, whatever the tolerances. At x₀ this returns x₀ bit for bit, 0 iterations.
//! - for every proposed step h (before it is evaluated): code 2 if max_i |h_i| ≤ epsx;
//! - after an accepted step: code 1 if (F − F_t)/max(F, tiny) ≤ epsf; code 5 once
//!   `max_iterations` steps were accepted;
//! - at every point where the normal equations are evaluated (x₀ and each accepted point):
//!   code 4 if the projected gradient has max-norm ≤ epsg. The projected gradient is ∇F with
//!   the components of frozen variables, and of variables on a bound that ∇F pushes against
//!   (x_i = l_i with ∂F/∂x_i > 0, x_i = u_i with ∂F/∂x_i < 0), set to 0;
//! - code 7 when no step can be found: the box step is zero, or λ overflows.
//!
//! With [`LmOptions::paper`] (all tolerances 0) a run therefore ends by code 7 (typically after
//! 20–35 rejected trials spent raising λ from ~10⁻¹⁰ to 10⁷⁷) or 5; [`LmOptions::default`]
//! stops at about the same energy after far fewer evaluations.
//!
//! Why code 2 looks at *proposed* steps: near a minimum with F > 0 the remaining decrease
//! ½hᵀ∇²F h falls below the rounding of F, so trials come back with F_t = F and are rejected;
//! without this test even tight tolerances would end by λ overflow (code 7) after a string of
//! wasted evaluations. As λ grows the proposed step shrinks below epsx instead, and the run
//! stops there.
//!
//! # Other model Hessians
//! A problem may hand over a symmetric A other than JᵀJ, e.g. JᵀJ + Σ r_k∇²r_k (the exact ½∇²F,
//! [`crate::gridwarp::NaaModel::Newton`]; ALGLIB's exact-Hessian protocol plays this role).
//! It may be indefinite, and nothing above changes: where A + λI is not positive definite the
//! box QP's factorisation fails or pred ≤ 0, which counts as a rejected trial (λ grows until
//! A + λI is positive definite on the free variables).
//!
//! A problem may instead offer S = Σ r_k∇²r_k apart ([`Residuals::curvature`]); LM then picks
//! the model per iteration by NL2SOL's rule (Dennis, Gay & Welsch, ACM TOMS 7(3), 1981, §3):
//! it starts with A = JᵀJ, and after each accepted step h (actual decrease F − F_t) it compares
//! the predicted decreases of both models for that h, pred_GN = −hᵀ(2g + JᵀJ h) and
//! pred_S = pred_GN − hᵀSh, and uses A = JᵀJ + S for the next step iff |F − F_t − pred_S| <
//! |F − F_t − pred_GN|. The gain ratio ρ stays that of the model the step was computed with.
//!
//! # Differences from ALGLIB `minlm`, on purpose
//! - Step and gradient tests use the max-norm, not the Euclidean norm; the energy test is
//!   relative to F alone, not to max(|F|, |F_t|, 1) (the grid-warp energies are ≪ 1).
//! - `max_iterations = 0` means "no step", not "unlimited".
//! - No variable scaling (`minlmsetscale`): λ multiplies the identity.
//!
//! # Sources
//! - S. Bochkanov, ALGLIB `minlm` (alglib.net): the λ schedule, termination codes, λ overflow.
//! - K. Madsen, H. B. Nielsen, O. Tingleff, *Methods for Non-Linear Least Squares Problems*,
//!   2nd ed., IMM DTU 2004, §3.2: the gain ratio ρ and λ₀.
//! - J. Nocedal, S. J. Wright, *Numerical Optimization*, 2nd ed., Springer 2006, §16.5
//!   (Algorithm 16.3): the primal active-set method of [`solve_box_qp`].
//! - P. Koniaris et al., *Real-time content-aware texturing for deformable surfaces*, CVMP 2013,
//!   §5.3 and §7 (seed 000).
//!
//! Everything is deterministic: no randomness, no threads, fixed loop orders.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};

mod box_qp;
mod options;
mod problem;

use box_qp::{box_qp, Damped, RowSpans};
pub use box_qp::{solve_box_qp, try_solve_box_qp, EnvelopeCholesky};
pub use options::{LmOptions, LmReport, StopCode};
use problem::clamp_to;
pub use problem::{
    AssemblyPlan, Bounds, LocalNormalEquations, NormalEquations, Residuals, Speculative,
};

/// Largest damping λ before the solver gives up with [`StopCode::NoProgress`]: (f64::MAX)^¼ ≈
/// 1.16·10⁷⁷, ALGLIB's limit (beyond it λI swamps A in any sum and squares of λ overflow).
pub const LAMBDA_MAX: f64 = 1.157_920_892_373_162e77;

/// λ ← λ_DOWN·λ after a very successful step (ρ > 0.5), ALGLIB's 0.33.
const LAMBDA_DOWN: f64 = 0.33;
/// λ ← λ_UP·ν·λ after a rejected or poor step, ALGLIB's 2.
const LAMBDA_UP: f64 = 2.0;
/// λ₀ = LAMBDA_INIT · max diag(2JᵀJ).
const LAMBDA_INIT: f64 = 1e-3;

// ------------------------------------------------------------------------------------------
// Levenberg–Marquardt
// ------------------------------------------------------------------------------------------

/// Minimise F(x) = Σ r_k(x)² subject to `bounds`, starting from x₀ clamped into the bounds.
///
/// Every point handed to `problem` lies inside the bounds. See the module documentation for
/// the iteration (damped box step h_λ = argmin_{l−x≤h≤u−x} hᵀ(JᵀJ + λI)h + 2(Jᵀr)ᵀh, gain
/// ratio, λ schedule) and the stopping codes.
///
/// Errors ([`Error::InvalidArgument`]): x₀ or the bounds do not have `problem.dim()` entries,
/// x₀ has a NaN, the bounds are not intervals, a tolerance is negative or not finite, F(x₀) is
/// not finite or negative, or the normal equations have the wrong size or non-finite entries.
pub fn minimize(
    problem: &mut impl Residuals,
    x0: &[f64],
    bounds: &Bounds,
    options: &LmOptions,
) -> Result<LmReport> {
    let n = problem.dim();
    check_inputs(n, x0, bounds, options)?;
    let lower = DVector::from_column_slice(&bounds.lower);
    let upper = DVector::from_column_slice(&bounds.upper);

    let x = bounds.clamp(x0);
    let ne = problem.normal_equations(&x);
    let energy = ne.energy;
    if !(energy.is_finite() && energy >= 0.0) {
        return Err(Error::InvalidArgument(format!(
            "lm: the energy at the starting point is {energy}; it must be finite and ≥ 0"
        )));
    }
    check_normal_equations(&ne, n, "the starting point")?;
    let mut run = Run {
        x,
        energy,
        iterations: 0,
        energy_evaluations: 0,
        jacobian_evaluations: 1,
        accepted_energies: vec![energy],
    };
    if energy == 0.0 {
        return Ok(run.finish(StopCode::SmallGradient));
    }
    if small_gradient(&ne.jtr, &run.x, &lower, &upper, options.epsg) {
        return Ok(run.finish(StopCode::SmallGradient));
    }
    if options.max_iterations == 0 {
        return Ok(run.finish(StopCode::MaxIterations));
    }

    let mut damping = Damping::initial(&ne.jtj);
    let mut ne = ne;
    let mut curvature = problem.curvature(&run.x);
    let mut second_order = false;
    loop {
        let model = model_hessian(&ne, curvature.as_ref().filter(|_| second_order));
        let (x_new, energy_new, rho) = match accepted_step(
            problem,
            &model,
            &mut run,
            &lower,
            &upper,
            options,
            &mut damping,
        ) {
            Trial::Accepted { x, energy, rho } => (x, energy, rho),
            Trial::SmallStep => return Ok(run.finish(StopCode::SmallStep)),
            Trial::NoProgress => return Ok(run.finish(StopCode::NoProgress)),
        };
        if let Some(s) = &curvature {
            second_order =
                second_order_predicts_better(&ne, s, &run.x, &x_new, run.energy - energy_new);
        }
        let relative_change = relative_energy_change(run.energy, energy_new);
        run.x = x_new;
        run.energy = energy_new;
        run.iterations += 1;
        run.accepted_energies.push(energy_new);
        let lambda_ok = damping.after_accepted(rho);

        if energy_new == 0.0 {
            return Ok(run.finish(StopCode::SmallGradient));
        }
        if options.epsf > 0.0 && relative_change <= options.epsf {
            return Ok(run.finish(StopCode::RelativeEnergyChange));
        }
        if run.iterations >= options.max_iterations {
            return Ok(run.finish(StopCode::MaxIterations));
        }
        if !lambda_ok {
            return Ok(run.finish(StopCode::NoProgress));
        }

        ne = problem.normal_equations(&run.x);
        curvature = problem.curvature(&run.x);
        run.jacobian_evaluations += 1;
        check_normal_equations(&ne, n, "an accepted point")?;
        if small_gradient(&ne.jtr, &run.x, &lower, &upper, options.epsg) {
            return Ok(run.finish(StopCode::SmallGradient));
        }
    }
}

/// The normal equations with the model Hessian A: JᵀJ, or JᵀJ + S given `curvature` S.
fn model_hessian<'a>(
    ne: &'a NormalEquations,
    curvature: Option<&DMatrix<f64>>,
) -> std::borrow::Cow<'a, NormalEquations> {
    match curvature {
        None => std::borrow::Cow::Borrowed(ne),
        Some(s) => std::borrow::Cow::Owned(NormalEquations {
            energy: ne.energy,
            jtj: &ne.jtj + s,
            jtr: ne.jtr.clone(),
        }),
    }
}

/// NL2SOL's model choice (module docs, "Other model Hessians"): whether JᵀJ + S predicted the
/// actual decrease of the step x → x_new better than JᵀJ did.
fn second_order_predicts_better(
    ne: &NormalEquations,
    s: &DMatrix<f64>,
    x: &[f64],
    x_new: &[f64],
    actual: f64,
) -> bool {
    let h = DVector::from_iterator(x.len(), x_new.iter().zip(x).map(|(a, b)| a - b));
    let gauss_newton = predicted_decrease(&ne.jtj, &ne.jtr, &h);
    let second_order = gauss_newton - h.dot(&(s * &h));
    (actual - second_order).abs() < (actual - gauss_newton).abs()
}

/// The state of a run, turned into an [`LmReport`] when it stops.
struct Run {
    x: Vec<f64>,
    energy: f64,
    iterations: usize,
    energy_evaluations: usize,
    jacobian_evaluations: usize,
    accepted_energies: Vec<f64>,
}

impl Run {
    fn finish(self, stop: StopCode) -> LmReport {
        LmReport {
            x: self.x,
            energy: self.energy,
            iterations: self.iterations,
            energy_evaluations: self.energy_evaluations,
            jacobian_evaluations: self.jacobian_evaluations,
            stop,
            accepted_energies: self.accepted_energies,
        }
    }
}

/// Sizes and finiteness of everything [`minimize`] is given before calling the problem.
fn check_inputs(n: usize, x0: &[f64], bounds: &Bounds, options: &LmOptions) -> Result<()> {
    if x0.len() != n {
        return Err(Error::InvalidArgument(format!(
            "lm: the starting point has {} values for {n} unknowns",
            x0.len()
        )));
    }
    if let Some(i) = x0.iter().position(|v| v.is_nan()) {
        return Err(Error::InvalidArgument(format!(
            "lm: unknown {i} of the starting point is NaN"
        )));
    }
    bounds.check(n)?;
    options.check()
}

/// JᵀJ is n×n, Jᵀr has n entries, all finite.
fn check_normal_equations(ne: &NormalEquations, n: usize, at: &str) -> Result<()> {
    if ne.jtj.shape() != (n, n) || ne.jtr.len() != n {
        return Err(Error::InvalidArgument(format!(
            "lm: normal equations at {at} have JᵀJ {:?} and Jᵀr of length {} for {n} unknowns",
            ne.jtj.shape(),
            ne.jtr.len()
        )));
    }
    let finite = |values: &[f64]| values.iter().fold(true, |ok, v| ok & v.is_finite());
    if !(finite(ne.jtj.as_slice()) && finite(ne.jtr.as_slice())) {
        return Err(Error::InvalidArgument(format!(
            "lm: normal equations at {at} have non-finite entries"
        )));
    }
    Ok(())
}

/// The damping λ and its growth factor ν (ALGLIB / Madsen–Nielsen–Tingleff schedule).
struct Damping {
    lambda: f64,
    nu: f64,
}

impl Damping {
    /// λ₀ = 10⁻³ · max_i (2JᵀJ)_ii, or 1 if that is 0; ν₀ = 1.
    fn initial(jtj: &DMatrix<f64>) -> Self {
        let max_diagonal = jtj.diagonal().iter().fold(0.0_f64, |m, &d| m.max(2.0 * d));
        let lambda = if max_diagonal > 0.0 {
            LAMBDA_INIT * max_diagonal
        } else {
            1.0
        };
        Damping { lambda, nu: 1.0 }
    }

    /// λ ← 2νλ, ν ← 2ν. Returns false (and leaves λ unchanged) if 2νλ would exceed
    /// [`LAMBDA_MAX`].
    fn raise(&mut self) -> bool {
        let lambda = LAMBDA_UP * self.nu * self.lambda;
        if lambda > LAMBDA_MAX {
            return false;
        }
        self.lambda = lambda;
        self.nu *= 2.0;
        true
    }

    /// λ ← max(0.33λ, smallest normal f64), ν ← 1.
    fn lower(&mut self) {
        self.lambda = (LAMBDA_DOWN * self.lambda).max(f64::MIN_POSITIVE);
        self.nu = 1.0;
    }

    /// After an accepted step with gain ratio ρ: ρ > 0.5 lowers λ, ρ < 0.1 raises it, else
    /// nothing. Returns false if raising overflowed.
    fn after_accepted(&mut self, rho: f64) -> bool {
        if rho > 0.5 {
            self.lower();
            true
        } else if rho < 0.1 {
            self.raise()
        } else {
            true
        }
    }
}

/// What the inner λ loop found.
enum Trial {
    /// A point with F_new < F, and the gain ratio of its step.
    Accepted { x: Vec<f64>, energy: f64, rho: f64 },
    /// A proposed step with max-norm ≤ epsx.
    SmallStep,
    /// Zero box step, or λ overflowed before any trial was accepted.
    NoProgress,
}

/// Try λ, 2νλ, … until a trial point lowers the energy (module doc steps 1–4).
fn accepted_step(
    problem: &mut impl Residuals,
    ne: &NormalEquations,
    run: &mut Run,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
    options: &LmOptions,
    damping: &mut Damping,
) -> Trial {
    let x = DVector::from_column_slice(&run.x);
    // The box of the step h: l − x ≤ h ≤ u − x (ordered because l ≤ u and rounding is monotone).
    let step_lower = lower - &x;
    let step_upper = upper - &x;
    let spans = RowSpans::of(&ne.jtj);
    loop {
        // A QP failure means A + λI is not numerically positive definite at this λ (JᵀJ
        // singular and λ tiny): treat it like a rejected trial and damp more.
        let damped = Damped {
            a: &ne.jtj,
            lambda: damping.lambda,
            spans: &spans,
        };
        if let Ok(h) = box_qp(&damped, &ne.jtr, &step_lower, &step_upper) {
            if h.iter().all(|&v| v == 0.0) {
                return Trial::NoProgress;
            }
            if options.epsx > 0.0 && h.amax() <= options.epsx {
                return Trial::SmallStep;
            }
            let pred = damped.undamped_predicted_decrease(&ne.jtr, &h);
            if pred > 0.0 {
                let x_trial = trial_point(&run.x, &h, &step_lower, &step_upper, lower, upper);
                let energy = problem.energy(&x_trial);
                run.energy_evaluations += 1;
                if energy.is_finite() && energy < run.energy {
                    let rho = (run.energy - energy) / pred;
                    return Trial::Accepted {
                        x: x_trial,
                        energy,
                        rho,
                    };
                }
            }
        }
        if !damping.raise() {
            return Trial::NoProgress;
        }
    }
}

/// Decrease of the Gauss–Newton model m(h) = F + 2gᵀh + hᵀAh from h = 0:
/// pred = m(0) − m(h) = −hᵀ(2g + A h), with g = Jᵀr and A = JᵀJ.
pub fn predicted_decrease(jtj: &DMatrix<f64>, jtr: &DVector<f64>, h: &DVector<f64>) -> f64 {
    let ah = jtj * h;
    -h.dot(&(jtr * 2.0 + ah))
}

/// x + h inside [l, u]: components where the box step sits on a side of its box
/// (h_i = l_i − x_i or u_i − x_i) are set to that bound exactly, h_i = 0 leaves x_i untouched
/// bit for bit, and the rest is clamped (x_i + h_i may round past a bound).
fn trial_point(
    x: &[f64],
    h: &DVector<f64>,
    step_lower: &DVector<f64>,
    step_upper: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> Vec<f64> {
    (0..x.len())
        .map(|i| {
            if h[i] == 0.0 {
                x[i]
            } else if h[i] == step_lower[i] {
                lower[i]
            } else if h[i] == step_upper[i] {
                upper[i]
            } else {
                clamp_to(x[i] + h[i], lower[i], upper[i])
            }
        })
        .collect()
}

/// Projected gradient of F at x, from g = Jᵀr: ∇F_i = 2g_i, set to 0 where x_i is frozen
/// (l_i = u_i) or sits on a bound that −∇F points out of (x_i ≤ l_i and ∇F_i > 0, or x_i ≥ u_i
/// and ∇F_i < 0). At a bound-constrained stationary point it is 0.
pub fn projected_gradient(
    jtr: &DVector<f64>,
    x: &[f64],
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> DVector<f64> {
    DVector::from_fn(x.len(), |i, _| {
        let grad = 2.0 * jtr[i];
        let frozen = lower[i] == upper[i];
        let held_low = x[i] <= lower[i] && grad > 0.0;
        let held_high = x[i] >= upper[i] && grad < 0.0;
        if frozen || held_low || held_high {
            0.0
        } else {
            grad
        }
    })
}

/// Stop test 4: max_i |projected ∇F_i| ≤ epsg (off when epsg = 0).
fn small_gradient(
    jtr: &DVector<f64>,
    x: &[f64],
    lower: &DVector<f64>,
    upper: &DVector<f64>,
    epsg: f64,
) -> bool {
    epsg > 0.0 && projected_gradient(jtr, x, lower, upper).amax() <= epsg
}

/// (F − F_new) / max(F, smallest normal f64).
fn relative_energy_change(energy: f64, energy_new: f64) -> f64 {
    (energy - energy_new) / energy.max(f64::MIN_POSITIVE)
}
