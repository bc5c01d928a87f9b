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

use std::collections::HashSet;
use std::fmt;

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::error::{Error, Result};

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
// The problem
// ------------------------------------------------------------------------------------------

/// A least-squares problem F(x) = Σ_k r_k(x)² given through its normal equations (J is never
/// stored).
pub trait Residuals {
    /// Number of unknowns n.
    fn dim(&self) -> usize;
    /// F(x) = Σ r_k(x)². May return `f64::INFINITY` for an invalid trial point (e.g. a folded
    /// grid cell): the solver treats it as a rejected step.
    fn energy(&mut self, x: &[f64]) -> f64;
    /// F(x), JᵀJ (n×n) and Jᵀr (n) at x. [`minimize`] asks for them only at x₀ and at accepted
    /// points; [`Speculative`] also at trial points, so their F must be `energy(x)` bit for
    /// bit (+∞ where that is +∞).
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations;
    /// S = Σ_k r_k ∇²r_k at x (n×n, symmetric), if the problem offers it for an adaptive model
    /// (module docs, "Other model Hessians"); called right after
    /// [`Residuals::normal_equations`] at the same x. The default: None (Gauss–Newton only).
    fn curvature(&mut self, _x: &[f64]) -> Option<DMatrix<f64>> {
        None
    }
}

/// A problem borrowed mutably is a problem (so that adaptors such as [`Speculative`] can wrap
/// a borrowed one).
impl<R: Residuals + ?Sized> Residuals for &mut R {
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn energy(&mut self, x: &[f64]) -> f64 {
        (**self).energy(x)
    }
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        (**self).normal_equations(x)
    }
    fn curvature(&mut self, x: &[f64]) -> Option<DMatrix<f64>> {
        (**self).curvature(x)
    }
}

/// F, JᵀJ and Jᵀr at one point.
#[derive(Clone, Debug)]
pub struct NormalEquations {
    /// F(x) = Σ r_k².
    pub energy: f64,
    /// JᵀJ, n×n, symmetric positive semi-definite; or, in its place, a symmetric model
    /// Hessian of ½F that may be indefinite (e.g. JᵀJ + Σ r∇²r,
    /// [`crate::gridwarp::NaaModel::Newton`]): a damped trial whose matrix is not positive
    /// definite fails its box QP or predicts no decrease, and counts as a rejected trial.
    pub jtj: DMatrix<f64>,
    /// Jᵀr, n (half the gradient of F).
    pub jtr: DVector<f64>,
}

impl NormalEquations {
    /// F = 0, JᵀJ = 0 (n×n), Jᵀr = 0 (n): the start of an accumulation.
    pub fn zeros(n: usize) -> Self {
        NormalEquations {
            energy: 0.0,
            jtj: DMatrix::zeros(n, n),
            jtr: DVector::zeros(n),
        }
    }

    /// Scatter the normal equations of a group of residuals over N local unknowns ("slots")
    /// into these: F += F_local, Jᵀr\[slot a\] += local Jᵀr\[a\], JᵀJ\[slot a, slot b\] += local
    /// JᵀJ\[a, b\]; slots with no unknown (a fixed variable) are dropped.
    pub fn add_local<const N: usize>(
        &mut self,
        slots: &[Option<usize>; N],
        local: &LocalNormalEquations<N>,
    ) {
        self.energy += local.energy;
        for (a, ca) in slots.iter().enumerate() {
            let Some(ca) = *ca else { continue };
            self.jtr[ca] += local.jtr[a];
            for (b, cb) in slots.iter().enumerate() {
                if let Some(cb) = *cb {
                    self.jtj[(ca, cb)] += local.jtj[a.min(b)][a.max(b)];
                }
            }
        }
    }

    /// The sum of local parts (slots, normal equations) taken in their order: a fixed-order
    /// reduction, so the result does not depend on how the parts were computed in parallel.
    /// Each part adds its terms to the entries they go to: for each slot a with an unknown
    /// c_a, Jᵀr\[c_a\] += Jᵀr_local\[a\], then for each slot b ≥ a with an unknown c_b,
    /// JᵀJ\[c_a, c_b\] += JᵀJ_local\[a\]\[b\] (upper triangle, mirrored at the end; twice when
    /// c_a = c_b, a ≠ b). An [`AssemblyPlan`] computes the same sums, bit for bit, entry by
    /// entry.
    pub fn assemble<'a, const N: usize>(
        n: usize,
        parts: impl IntoIterator<Item = (&'a [Option<usize>; N], &'a LocalNormalEquations<N>)>,
    ) -> Self {
        let mut total = NormalEquations::zeros(n);
        let jtj = total.jtj.as_mut_slice();
        for (slots, local) in parts {
            total.energy += local.energy;
            terms_of_part(n, slots, |target, term| match target {
                Target::Jtr(c) => total.jtr[c] += local.jtr[term.a],
                Target::Jtj(at) => jtj[at] += local.jtj[term.a][term.b],
            });
        }
        mirror_upper_triangle(&mut total.jtj);
        total
    }
}

/// Where a term of [`NormalEquations::assemble`] goes: Jᵀr\[c\], or the upper-triangle entry
/// (row, column), row ≤ column, of JᵀJ at `column·n + row` (column-major storage).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Jtr(usize),
    Jtj(usize),
}

/// Which entry of a part a term reads: its Jᵀr\[a\] (b unused) or its JᵀJ\[a\]\[b\], a ≤ b.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Term {
    a: usize,
    b: usize,
}

/// The terms of one part in the order they are added: for each slot a with an unknown c_a,
/// Jᵀr\[c_a\] += Jᵀr_local\[a\], then for each slot b ≥ a with an unknown c_b,
/// JᵀJ\[min, max of c_a, c_b\] += JᵀJ_local\[a\]\[b\] (the upper triangle only; it is mirrored
/// at the end). Two slots a ≠ b of one unknown add JᵀJ_local\[a\]\[b\] twice there, as
/// scattering the whole block ([`NormalEquations::add_local`]) adds \[a\]\[b\] and \[b\]\[a\].
#[inline(always)]
fn terms_of_part<const N: usize>(
    n: usize,
    slots: &[Option<usize>; N],
    mut add: impl FnMut(Target, Term),
) {
    for (a, ca) in slots.iter().enumerate() {
        let Some(ca) = *ca else { continue };
        add(Target::Jtr(ca), Term { a, b: a });
        for (b, cb) in slots.iter().enumerate().skip(a) {
            let Some(cb) = *cb else { continue };
            let at = ca.max(cb) * n + ca.min(cb);
            add(Target::Jtj(at), Term { a, b });
            if a != b && ca == cb {
                add(Target::Jtj(at), Term { a, b });
            }
        }
    }
}

/// JᵀJ's lower triangle set from its upper one (column-major n×n).
fn mirror_upper_triangle(jtj: &mut DMatrix<f64>) {
    let n = jtj.nrows();
    let jtj = jtj.as_mut_slice();
    for column in 0..n {
        for row in 0..column {
            jtj[row * n + column] = jtj[column * n + row];
        }
    }
}

/// [`NormalEquations::assemble`] for parts with fixed slots, planned once: for every entry of
/// Jᵀr and of JᵀJ's upper triangle, the list of the part entries that add up to it, in part
/// order. [`AssemblyPlan::assemble`] then sums entry by entry, each sum in a register,
/// instead of scattering part by part (where neighbouring parts add to the same entries, a
/// chain of reads and writes of memory): the same additions in the same order, so the same
/// bits. A problem whose parts keep their slots from one evaluation to the next (a grid's
/// cells) builds it once. It pays where many parts add to one entry: the axis-aligned
/// energy's lines are shared by a whole row or column of cells (at aa 38, the normal
/// equations' pass took 3 µs less); a vertex of the non-axis-aligned grid belongs to four
/// cells at most, and that energy keeps [`NormalEquations::assemble`].
#[derive(Clone, Debug, PartialEq)]
pub struct AssemblyPlan<const N: usize> {
    n: usize,
    parts: usize,
    /// The entries that receive terms, in the order Jᵀr\[0 … n−1\], then JᵀJ column by
    /// column: (target, end of its sources in `sources`; the start is the previous end).
    sums: Vec<(Target, usize)>,
    /// The terms, as positions in the parts read as one array of values
    /// ([`LocalNormalEquations::values`]).
    sources: Vec<usize>,
}

impl<const N: usize> AssemblyPlan<N> {
    /// The plan for parts with these slots (part k has `slots[k]`), unknowns 0 … n − 1
    /// (n + n² counters while it is made: O(n² + terms) time).
    pub fn new(n: usize, slots: &[[Option<usize>; N]]) -> Self {
        let stride = LocalNormalEquations::<N>::VALUES;
        // The terms bucketed by target (Jᵀr c → c, JᵀJ entry at → n + at) by a counting
        // sort: counted, then placed in the order `assemble` adds them, so that each
        // target's terms keep that order.
        let bucket = |target: Target| match target {
            Target::Jtr(c) => c,
            Target::Jtj(at) => n + at,
        };
        let mut starts = vec![0; n + n * n + 1];
        for s in slots {
            terms_of_part(n, s, |target, _| starts[bucket(target) + 1] += 1);
        }
        for b in 1..starts.len() {
            starts[b] += starts[b - 1];
        }
        let ends = starts[1..].to_vec();
        let mut sources = vec![0; starts[n + n * n]];
        for (k, s) in slots.iter().enumerate() {
            terms_of_part(n, s, |target, term| {
                let at = match target {
                    Target::Jtr(_) => LocalNormalEquations::<N>::jtr_value(term.a),
                    Target::Jtj(_) => LocalNormalEquations::<N>::jtj_value(term.a, term.b),
                };
                let next = &mut starts[bucket(target)];
                sources[*next] = k * stride + at;
                *next += 1;
            });
        }
        // The targets that receive terms, each with the end of its terms.
        let mut sums = Vec::new();
        let mut start = 0;
        for (b, &end) in ends.iter().enumerate() {
            if end > start {
                let target = if b < n {
                    Target::Jtr(b)
                } else {
                    Target::Jtj(b - n)
                };
                sums.push((target, end));
            }
            start = end;
        }
        AssemblyPlan {
            n,
            parts: slots.len(),
            sums,
            sources,
        }
    }

    /// [`NormalEquations::assemble`] of `parts` with the slots of the plan (the same bits).
    /// Panics if `parts` has another length than the slots the plan was made for.
    pub fn assemble(&self, parts: &[LocalNormalEquations<N>]) -> NormalEquations {
        assert_eq!(
            parts.len(),
            self.parts,
            "one local part per planned slot list"
        );
        let values = LocalNormalEquations::values(parts);
        let mut total = NormalEquations::zeros(self.n);
        total.energy = parts.iter().fold(0.0, |sum, part| sum + part.energy);
        let jtj = total.jtj.as_mut_slice();
        let mut start = 0;
        for &(target, end) in &self.sums {
            let sources = &self.sources[start..end];
            start = end;
            let sum = sources.iter().fold(0.0, |sum, &at| sum + values[at]);
            match target {
                Target::Jtr(c) => total.jtr[c] = sum,
                Target::Jtj(at) => jtj[at] = sum,
            }
        }
        mirror_upper_triangle(&mut total.jtj);
        total
    }
}

/// F, JᵀJ and Jᵀr of a group of residuals (a grid cell's) that depend on N unknowns only, in
/// the group's own slot order: fixed-size, so the per-residual update JᵀJ += d dᵀ, Jᵀr += d r
/// stays in registers, and the group is scattered once ([`NormalEquations::add_local`]).
/// Only the upper triangle a ≤ b of `jtj` is read when scattered (JᵀJ is symmetric, and
/// d_a d_b = d_b d_a exactly, so nothing is lost).
///
/// Laid out as 1 + N² + N consecutive f64 (`repr(C)`): F, JᵀJ row by row, Jᵀr (what
/// [`AssemblyPlan`] reads).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct LocalNormalEquations<const N: usize> {
    pub energy: f64,
    pub jtj: [[f64; N]; N],
    pub jtr: [f64; N],
}

impl<const N: usize> Default for LocalNormalEquations<N> {
    fn default() -> Self {
        LocalNormalEquations {
            energy: 0.0,
            jtj: [[0.0; N]; N],
            jtr: [0.0; N],
        }
    }
}

impl<const N: usize> LocalNormalEquations<N> {
    /// The number of values of one part: F, the N² entries of JᵀJ and the N of Jᵀr.
    pub const VALUES: usize = 1 + N * N + N;

    /// The position of JᵀJ\[a\]\[b\] among a part's values.
    const fn jtj_value(a: usize, b: usize) -> usize {
        1 + a * N + b
    }

    /// The position of Jᵀr\[a\] among a part's values.
    const fn jtr_value(a: usize) -> usize {
        1 + N * N + a
    }

    /// The values of `parts`, part k's from k·[`Self::VALUES`] on.
    fn values(parts: &[Self]) -> &[f64] {
        const { assert!(std::mem::size_of::<Self>() == Self::VALUES * std::mem::size_of::<f64>()) };
        // SAFETY: `repr(C)` with f64 fields only (an f64, an array of arrays of f64, an array
        // of f64): Self is exactly VALUES f64 with no padding, aligned as f64, so `parts` is
        // parts.len()·VALUES initialised f64, borrowed for as long as `parts`.
        unsafe {
            std::slice::from_raw_parts(parts.as_ptr().cast::<f64>(), parts.len() * Self::VALUES)
        }
    }

    /// Add one residual r with partial derivatives d (slot order): F += r², Jᵀr += d r,
    /// JᵀJ += d dᵀ. The whole N×N block is updated, row a by d_a·d: one vector operation
    /// per row on wide registers, and the lower triangle equals the upper one bit for bit
    /// (d_a d_b = d_b d_a).
    #[inline(always)]
    pub fn accumulate(&mut self, r: f64, d: &[f64; N]) {
        self.energy += r * r;
        for a in 0..N {
            self.jtr[a] += d[a] * r;
            for b in 0..N {
                self.jtj[a][b] += d[a] * d[b];
            }
        }
    }
}

/// A [`Residuals`] problem whose trial points get their normal equations at once: a trial
/// that LM accepts then needs no second pass over the residuals for its JᵀJ and Jᵀr.
///
/// LM asks for F at every trial point and for the normal equations only at accepted ones
/// ([`Residuals`]), so a rejected trial costs one pass (energy only) and an accepted one two.
/// Computing the normal equations at the trial already saves the energy-only pass whenever
/// the trial is accepted, as most are, and wastes the difference between the two passes
/// when it is rejected. So this adaptor speculates only while trials are being accepted:
/// after a rejected trial (e.g. the string of them of [`LmOptions::paper`]) the next trial
/// asks for the energy alone, until one is accepted again. (Grid warp, 2 threads: a
/// normal-equations pass costs 1.7–4 energy passes, and aa 38 runs 10 passes instead of 15.)
///
/// F is taken from the normal equations; the problem must give the same F both ways, bit for
/// bit (the grid-warp energies sum the same terms in the same order), so the iterates, the
/// counts of [`LmReport`] and the result are those of the plain problem.
pub struct Speculative<R> {
    inner: R,
    /// The normal equations at the last trial point, if they were computed with its energy.
    pending: Option<(Vec<f64>, NormalEquations)>,
    /// Whether the last trial point was accepted (LM asked for its normal equations).
    last_accepted: bool,
}

impl<R: Residuals> Speculative<R> {
    pub fn new(inner: R) -> Self {
        Speculative {
            inner,
            pending: None,
            last_accepted: true,
        }
    }
}

impl<R: Residuals> Residuals for Speculative<R> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }

    /// F(x) from the normal equations at x while trials are being accepted, else alone.
    fn energy(&mut self, x: &[f64]) -> f64 {
        if self.pending.take().is_some() {
            // The previous trial's normal equations were never asked for: it was rejected.
            self.last_accepted = false;
        }
        if !self.last_accepted {
            return self.inner.energy(x);
        }
        let normal = self.inner.normal_equations(x);
        let energy = normal.energy;
        self.pending = Some((x.to_vec(), normal));
        energy
    }

    /// The normal equations computed with the energy at x, if they were; else computed now.
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations {
        self.last_accepted = true;
        match self.pending.take() {
            Some((at, normal)) if at == x => normal,
            _ => self.inner.normal_equations(x),
        }
    }

    fn curvature(&mut self, x: &[f64]) -> Option<DMatrix<f64>> {
        self.inner.curvature(x)
    }
}

/// Box constraints l ≤ x ≤ u. Sides may be ±∞; `lower[i] == upper[i]` freezes x_i.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bounds {
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
}

impl Bounds {
    /// l ≤ x ≤ u (checked by [`minimize`], not here).
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Self {
        Bounds { lower, upper }
    }

    /// −∞ < x_i < ∞ for n unknowns.
    pub fn unbounded(n: usize) -> Self {
        Bounds {
            lower: vec![f64::NEG_INFINITY; n],
            upper: vec![f64::INFINITY; n],
        }
    }

    /// min(max(x_i, l_i), u_i) for every i; a point already inside is returned bit for bit.
    pub fn clamp(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.lower.iter().zip(&self.upper))
            .map(|(&v, (&l, &u))| clamp_to(v, l, u))
            .collect()
    }

    /// Both sides have n entries, none NaN, l_i ≤ u_i, l_i < +∞ and u_i > −∞.
    fn check(&self, n: usize) -> Result<()> {
        if self.lower.len() != n || self.upper.len() != n {
            return Err(Error::InvalidArgument(format!(
                "lm: bounds have {} lower and {} upper values for {n} unknowns",
                self.lower.len(),
                self.upper.len()
            )));
        }
        check_box(self.lower.iter().copied(), self.upper.iter().copied(), "lm")
    }
}

/// v clamped into [lo, hi] without `f64::clamp`'s panic (callers guarantee lo ≤ hi).
fn clamp_to(v: f64, lo: f64, hi: f64) -> f64 {
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

/// Every pair (l_i, u_i) is a non-empty interval: no NaN, l_i ≤ u_i, l_i ≠ +∞, u_i ≠ −∞.
fn check_box(
    lower: impl Iterator<Item = f64>,
    upper: impl Iterator<Item = f64>,
    who: &str,
) -> Result<()> {
    for (i, (l, u)) in lower.zip(upper).enumerate() {
        if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY {
            return Err(Error::InvalidArgument(format!(
                "{who}: bounds of unknown {i} are not an interval: lower {l}, upper {u}"
            )));
        }
    }
    Ok(())
}

// ------------------------------------------------------------------------------------------
// Options and report
// ------------------------------------------------------------------------------------------

/// Stopping tolerances. Each tolerance 0 turns its test off.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LmOptions {
    /// Stop (code 4) when the projected gradient ∇F = 2Jᵀr has max-norm ≤ epsg (absolute,
    /// units of F per unit of x). Default 1e-12.
    pub epsg: f64,
    /// Stop (code 1) when an accepted step changes F by (F − F_new)/F ≤ epsf (relative).
    /// Default 1e-12: about 4500 ulps, far below any visible difference in a warped texture.
    pub epsf: f64,
    /// Stop (code 2) when a proposed step has max_i |h_i| ≤ epsx (absolute, units of x),
    /// before evaluating it: it could not move x by more than epsx.
    /// Default 1e-12 (the grid-warp unknowns live in [0, 1]).
    pub epsx: f64,
    /// Stop (code 5) after this many accepted steps. Default 100 (the paper's). 0 = no step.
    pub max_iterations: usize,
}

impl LmOptions {
    /// The paper's ALGLIB settings (seed §9, "Results"): all tolerances 0, 100 iterations. Runs end by
    /// code 7 (λ overflow after a string of rejected trials) or 5.
    pub fn paper() -> Self {
        LmOptions {
            epsg: 0.0,
            epsf: 0.0,
            epsx: 0.0,
            max_iterations: 100,
        }
    }

    /// Tolerances finite and ≥ 0.
    fn check(&self) -> Result<()> {
        for (name, v) in [
            ("epsg", self.epsg),
            ("epsf", self.epsf),
            ("epsx", self.epsx),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidArgument(format!(
                    "lm: tolerance {name} = {v} must be finite and ≥ 0"
                )));
            }
        }
        Ok(())
    }
}

impl Default for LmOptions {
    /// epsg = epsf = epsx = 1e-12, 100 iterations: reaches the paper preset's energy (to about
    /// 1e-12 relative) without the paper preset's final string of rejected trials.
    fn default() -> Self {
        LmOptions {
            epsg: 1e-12,
            epsf: 1e-12,
            epsx: 1e-12,
            max_iterations: 100,
        }
    }
}

/// Why the solver stopped; the discriminants are ALGLIB's termination codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[repr(u8)]
pub enum StopCode {
    /// 1: the relative energy change of an accepted step was ≤ epsf.
    RelativeEnergyChange = 1,
    /// 2: a proposed step's max-norm was ≤ epsx (the run stops before evaluating it).
    SmallStep = 2,
    /// 4: the projected gradient's max-norm was ≤ epsg, or F = 0.
    SmallGradient = 4,
    /// 5: `max_iterations` steps were accepted.
    MaxIterations = 5,
    /// 7: no further decrease possible: zero box step, or λ overflow.
    NoProgress = 7,
}

impl StopCode {
    /// ALGLIB's numeric termination code.
    pub fn code(self) -> u8 {
        self as u8
    }
}

impl fmt::Display for StopCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let why = match self {
            StopCode::RelativeEnergyChange => "relative energy change ≤ epsf",
            StopCode::SmallStep => "step ≤ epsx",
            StopCode::SmallGradient => "projected gradient ≤ epsg (or zero energy)",
            StopCode::MaxIterations => "maximum number of iterations",
            StopCode::NoProgress => "no further progress possible (λ overflow or zero step)",
        };
        write!(f, "{} ({why})", self.code())
    }
}

/// The outcome of [`minimize`].
#[derive(Clone, Debug, Serialize)]
pub struct LmReport {
    /// The last accepted point (x₀ clamped into the bounds if no step was accepted).
    pub x: Vec<f64>,
    /// F(x).
    pub energy: f64,
    /// Accepted steps.
    pub iterations: usize,
    /// Calls to [`Residuals::energy`] (one per trial point).
    pub energy_evaluations: usize,
    /// Calls to [`Residuals::normal_equations`] (x₀ and accepted points).
    pub jacobian_evaluations: usize,
    /// Why it stopped.
    pub stop: StopCode,
    /// F(x₀) followed by the energy after each accepted step (length `iterations + 1`),
    /// strictly decreasing.
    pub accepted_energies: Vec<f64>,
}

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

// ------------------------------------------------------------------------------------------
// The box-constrained quadratic program
// ------------------------------------------------------------------------------------------

/// Exact minimiser of q(h) = ½ hᵀA h + gᵀh subject to lower ≤ h ≤ upper, A symmetric positive
/// definite, by the primal active-set method (Nocedal & Wright, Algorithm 16.3, for bounds):
///
/// - start from h = clamp(0) with every variable on a bound in the working set W (fixed at it);
/// - minimise q over the free variables F with W held: A_FF h_F = −(g + A h_W)_F (Cholesky);
///   if that point leaves the box, move toward it up to the first bound hit and add that bound
///   to W;
/// - otherwise h is the minimiser on W: the multiplier of a variable held at its lower bound is
///   ∂q/∂h_i = (A h + g)_i and must be ≥ 0 (≤ 0 at an upper bound). If all are, h satisfies
///   the KKT conditions and is the unique minimiser; else release the most negative one.
///
/// Variables with lower = upper are fixed and never released; sides may be ±∞. Terminates:
/// W's minimisers have strictly decreasing q, so no W repeats; a repeat caused by rounding
/// ends the method (cycle guard), as does a cap of 50 + 10n working-set changes. Multiplier
/// signs are tested with a rounding allowance of 8(n+1)ε(|g_i| + Σ_j|A_ij h_j|). The cost is
/// one Cholesky factorisation of A_FF per working-set change, done on A_FF's envelope
/// ([`EnvelopeCholesky`]), and products with A taken over its rows' non-zero spans only:
/// cheap when A is banded, as the grid energies' JᵀJ are. (Inside [`minimize`] the damped
/// matrix A + λI of each trial is never formed.)
///
/// # Panics
/// If the inputs break the preconditions (sizes, NaN, lower > upper, A not numerically
/// positive definite on the free variables). This is an inner kernel; callers with inputs
/// not valid by construction use [`try_solve_box_qp`].
pub fn solve_box_qp(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> DVector<f64> {
    match try_solve_box_qp(a, g, lower, upper) {
        Ok(h) => h,
        Err(e) => panic!("solve_box_qp: {e}"),
    }
}

/// [`solve_box_qp`] returning [`Error::InvalidArgument`] instead of panicking when the sizes
/// disagree, an entry of A or g is not finite, the bounds are not intervals, or A is not
/// numerically positive definite on the free variables.
pub fn try_solve_box_qp(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> Result<DVector<f64>> {
    check_box_qp(a, g, lower, upper)?;
    let spans = RowSpans::of(a);
    let matrix = Damped {
        a,
        lambda: 0.0,
        spans: &spans,
    };
    box_qp(&matrix, g, lower, upper)
}

/// The active-set method of [`solve_box_qp`] on A + λI (checked inputs).
fn box_qp(
    a: &Damped,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> Result<DVector<f64>> {
    let n = g.len();
    let mut h = DVector::from_fn(n, |i, _| clamp_to(0.0, lower[i], upper[i]));
    let mut status: Vec<Status> = (0..n)
        .map(|i| Status::at(h[i], lower[i], upper[i]))
        .collect();
    let mut visited: HashSet<Vec<Status>> = HashSet::new();

    for _ in 0..50 + 10 * n {
        let free: Vec<usize> = (0..n).filter(|&i| status[i] == Status::Free).collect();
        if !free.is_empty() {
            let target = subspace_minimiser(a, g, &h, &free)?;
            if let Some((alpha, blocking)) = first_bound_hit(&h, &target, &free, lower, upper) {
                move_toward(&mut h, &target, &free, alpha, lower, upper);
                let (i, side) = blocking;
                h[i] = if side == Status::Lower {
                    lower[i]
                } else {
                    upper[i]
                };
                status[i] = side;
                continue;
            }
            for (k, &i) in free.iter().enumerate() {
                h[i] = clamp_to(target[k], lower[i], upper[i]);
            }
        }
        // h minimises q on the working set: optimal unless a held bound has the wrong sign.
        if !visited.insert(status.clone()) {
            break; // cycle guard: only rounding can bring a working set back
        }
        match most_violated_bound(a, g, &h, &status) {
            Some(i) => status[i] = Status::Free,
            None => break,
        }
    }
    Ok(h)
}

/// Where each row of a symmetric matrix has its non-zeros: row i's entries outside
/// lo_i ..= hi_i are exactly 0, and the span contains the diagonal. A grid energy's JᵀJ is
/// banded (a line or vertex couples only with its neighbours), so products over the spans
/// cost O(n·band) instead of O(n²) and, taken in ascending column order, give exactly the
/// dense products' values (adding an exact 0 changes nothing).
struct RowSpans {
    lo: Vec<usize>,
    hi: Vec<usize>,
}

impl RowSpans {
    /// The spans of a symmetric matrix's rows from its columns' first non-zeros (columns are
    /// contiguous in memory, and each scan stops at the first non-zero, about half the
    /// matrix for a banded one): with top_j the first non-zero row of column j,
    ///   lo_i = top_i,   hi_i = max(i, max{ j : top_j ≤ i }).
    /// They hold every non-zero: A_ij ≠ 0 with j < i means A_ji ≠ 0, so top_i ≤ j; with
    /// j > i, column j has a non-zero in row i, so top_j ≤ i. Exact for a banded matrix; for
    /// another profile hi_i may be wider, which only adds exact zeros to the products.
    fn of(a: &DMatrix<f64>) -> RowSpans {
        let n = a.nrows();
        let top: Vec<usize> = a
            .column_iter()
            .enumerate()
            .map(|(j, column)| first_non_zero(column.as_slice()).unwrap_or(j))
            .collect();
        // reach[i]: the last column whose first non-zero is in row i (or i itself).
        let mut reach: Vec<usize> = (0..n).collect();
        for (j, &t) in top.iter().enumerate() {
            reach[t] = reach[t].max(j);
        }
        let mut hi = Vec::with_capacity(n);
        let mut furthest = 0;
        for (i, &r) in reach.iter().enumerate() {
            furthest = furthest.max(r).max(i);
            hi.push(furthest);
        }
        let lo = top.iter().enumerate().map(|(i, &t)| t.min(i)).collect();
        RowSpans { lo, hi }
    }
}

/// Values per block of the zero scans below: a block is tested as a whole (a comparison the
/// compiler vectorises), then searched.
const SCAN_BLOCK: usize = 16;

/// Index of the first non-zero of `values`.
fn first_non_zero(values: &[f64]) -> Option<usize> {
    let non_zero = |block: &[f64]| block.iter().fold(false, |any, &v| any | (v != 0.0));
    let (index, block) = values
        .chunks(SCAN_BLOCK)
        .enumerate()
        .find(|(_, block)| non_zero(block))?;
    block
        .iter()
        .position(|&v| v != 0.0)
        .map(|k| index * SCAN_BLOCK + k)
}

/// The matrix A + λI of one damped step (λ = 0: A itself), with A's [`RowSpans`]; never
/// formed, so a λ trial costs no n×n copy.
struct Damped<'a> {
    a: &'a DMatrix<f64>,
    lambda: f64,
    spans: &'a RowSpans,
}

impl Damped<'_> {
    /// Entry (i, j) of A + λI.
    ///
    /// Read as A_ji, the same value (A is symmetric): consecutive j of a row are then
    /// consecutive in A's column-major storage.
    #[inline]
    fn at(&self, i: usize, j: usize) -> f64 {
        if i == j {
            self.a[(j, i)] + self.lambda
        } else {
            self.a[(j, i)]
        }
    }

    /// Σ_j f(i, j, x_j) over row i's span in ascending j, f given the entry (A + λI)_ij.
    #[inline]
    fn row_sum(&self, i: usize, x: &DVector<f64>, f: impl Fn(f64, f64) -> f64) -> f64 {
        (self.spans.lo[i]..=self.spans.hi[i])
            .map(|j| f(self.at(i, j), x[j]))
            .sum()
    }

    /// ((A + λI) x)_i, summed as nalgebra's dense product sums it (ascending j).
    #[inline]
    fn row_times(&self, i: usize, x: &DVector<f64>) -> f64 {
        let (lo, hi) = (self.spans.lo[i], self.spans.hi[i]);
        let mut sum = self.at(i, lo) * x[lo];
        for j in lo + 1..=hi {
            sum += self.at(i, j) * x[j];
        }
        sum
    }

    /// ((A + λI) x)_i when x is 0 outside the ascending `columns`: the same sum as
    /// [`Damped::row_times`] without its exact-zero terms (which change nothing).
    fn row_times_at(&self, i: usize, x: &DVector<f64>, columns: &[usize]) -> f64 {
        let (lo, hi) = (self.spans.lo[i], self.spans.hi[i]);
        let from = columns.partition_point(|&j| j < lo);
        let mut terms = columns[from..]
            .iter()
            .take_while(|&&j| j <= hi)
            .map(|&j| self.at(i, j) * x[j]);
        match terms.next() {
            Some(first) => terms.fold(first, |sum, term| sum + term),
            None => 0.0,
        }
    }

    /// [`predicted_decrease`] with the undamped A: −hᵀ(2g + A h).
    fn undamped_predicted_decrease(&self, jtr: &DVector<f64>, h: &DVector<f64>) -> f64 {
        let undamped = Damped {
            lambda: 0.0,
            ..*self
        };
        let ah = DVector::from_fn(h.len(), |i, _| undamped.row_times(i, h));
        -h.dot(&(jtr * 2.0 + ah))
    }
}

/// Where a variable of the box QP stands in the working set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Status {
    Free,
    /// Held at its lower bound.
    Lower,
    /// Held at its upper bound.
    Upper,
    /// lower = upper: never released.
    Fixed,
}

impl Status {
    /// The initial status of a variable with value v in [l, u].
    fn at(v: f64, l: f64, u: f64) -> Status {
        if l == u {
            Status::Fixed
        } else if v == l {
            Status::Lower
        } else if v == u {
            Status::Upper
        } else {
            Status::Free
        }
    }
}

/// Sizes agree (A n×n, g, lower, upper n), A and g finite, bounds are intervals.
fn check_box_qp(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> Result<()> {
    let n = g.len();
    if a.shape() != (n, n) || lower.len() != n || upper.len() != n {
        return Err(Error::InvalidArgument(format!(
            "box QP: A is {:?}, g has {n}, lower {}, upper {} entries",
            a.shape(),
            lower.len(),
            upper.len()
        )));
    }
    if a.iter().chain(g.iter()).any(|v| !v.is_finite()) {
        return Err(Error::InvalidArgument(
            "box QP: A or g has non-finite entries".into(),
        ));
    }
    check_box(lower.iter().copied(), upper.iter().copied(), "box QP")
}

/// Minimiser of q over the free variables F with the others held at their current values:
/// A_FF h_F = −(g + A h_W)_F, where h_W is h with the free entries set to 0.
fn subspace_minimiser(
    a: &Damped,
    g: &DVector<f64>,
    h: &DVector<f64>,
    free: &[usize],
) -> Result<DVector<f64>> {
    let mut held = h.clone();
    for &i in free {
        held[i] = 0.0;
    }
    // Only the held variables away from 0 contribute to A h_W.
    let moved: Vec<usize> = (0..held.len()).filter(|&j| held[j] != 0.0).collect();
    let rhs = DVector::from_iterator(
        free.len(),
        free.iter()
            .map(|&i| -(g[i] + a.row_times_at(i, &held, &moved))),
    );
    // Row p of A_FF starts no earlier than the first free column in row free[p]'s span.
    let start = |p: usize| free.partition_point(|&f| f < a.spans.lo[free[p]]);
    EnvelopeCholesky::factor_from(free.len(), start, |p, q| a.at(free[p], free[q]))
        .map(|c| c.solve(&rhs))
        .filter(|t| t.iter().all(|v| v.is_finite()))
        .ok_or_else(|| {
            Error::InvalidArgument(
                "box QP: the matrix is not positive definite on the free variables".into(),
            )
        })
}

/// The Cholesky factor L Lᵀ = M of a symmetric positive definite n×n matrix, stored by M's
/// envelope: row i of L is kept from column first_i (M's first non-zero in row i) to the
/// diagonal, because L has exactly M's envelope (A. George, J. W. Liu, *Computer Solution of
/// Large Sparse Positive Definite Systems*, Prentice-Hall 1981, §4.2). With
/// b_i = i − first_i the cost is Σ b_i² instead of n³/3: the non-axis-aligned energy's JᵀJ
/// couples a vertex only with its grid neighbours, a band of ≈ 2N + 3 unknowns, so a 288-unknown
/// step costs ≈ 40× less than a dense factorisation; dense matrices cost the same as before.
///
///   L_ij = (M_ij − Σ_{k = max(first_i, first_j)}^{j−1} L_ik L_jk) / L_jj  (first_i ≤ j < i),
///   L_ii = √(M_ii − Σ_{k = first_i}^{i−1} L_ik²).
pub struct EnvelopeCholesky {
    first: Vec<usize>,
    /// Row i of L, L_{i, first_i ..= i}, at `values[offset_i ..= offset_i + i − first_i]`.
    offset: Vec<usize>,
    values: Vec<f64>,
}

impl EnvelopeCholesky {
    /// Factor M given by its entries m(i, j) (only j ≤ i is read); None if a pivot is not
    /// positive and finite (M not numerically positive definite).
    pub fn factor(n: usize, m: impl Fn(usize, usize) -> f64) -> Option<EnvelopeCholesky> {
        Self::factor_from(n, |_| 0, m)
    }

    /// [`EnvelopeCholesky::factor`] knowing that row i of M has no non-zero left of column
    /// start(i) (so the search for first_i starts there).
    pub fn factor_from(
        n: usize,
        start: impl Fn(usize) -> usize,
        m: impl Fn(usize, usize) -> f64,
    ) -> Option<EnvelopeCholesky> {
        let first: Vec<usize> = (0..n)
            .map(|i| (start(i).min(i)..i).find(|&j| m(i, j) != 0.0).unwrap_or(i))
            .collect();
        let mut offset = Vec::with_capacity(n + 1);
        offset.push(0);
        for i in 0..n {
            offset.push(offset[i] + i - first[i] + 1);
        }
        let mut l = EnvelopeCholesky {
            first,
            values: vec![0.0; offset[n]],
            offset,
        };
        for i in 0..n {
            let fi = l.first[i];
            let (done, row) = l.values.split_at_mut(l.offset[i]);
            for j in fi..i {
                let fj = l.first[j];
                let row_j = &done[l.offset[j]..l.offset[j + 1]];
                let start = fi.max(fj);
                let dot: f64 = row[start - fi..j - fi]
                    .iter()
                    .zip(&row_j[start - fj..j - fj])
                    .map(|(a, b)| a * b)
                    .sum();
                row[j - fi] = (m(i, j) - dot) / row_j[j - fj];
            }
            let pivot = m(i, i) - row[..i - fi].iter().map(|v| v * v).sum::<f64>();
            if !(pivot > 0.0 && pivot.is_finite()) {
                return None;
            }
            row[i - fi] = pivot.sqrt();
        }
        Some(l)
    }

    /// Row i of L from column first_i to the diagonal.
    fn row(&self, i: usize) -> &[f64] {
        &self.values[self.offset[i]..self.offset[i + 1]]
    }

    /// M⁻¹ b: L y = b forwards, then Lᵀ x = y backwards (column by column of L).
    pub fn solve(&self, b: &DVector<f64>) -> DVector<f64> {
        let n = self.first.len();
        let mut x = b.clone();
        for i in 0..n {
            let (row, fi) = (self.row(i), self.first[i]);
            let dot: f64 = row[..i - fi]
                .iter()
                .zip(&x.as_slice()[fi..i])
                .map(|(l, x)| l * x)
                .sum();
            x[i] = (x[i] - dot) / row[i - fi];
        }
        for i in (0..n).rev() {
            let (row, fi) = (self.row(i), self.first[i]);
            x[i] /= row[i - fi];
            let xi = x[i];
            for (xk, l) in x.as_mut_slice()[fi..i].iter_mut().zip(row) {
                *xk -= l * xi;
            }
        }
        x
    }
}

/// Ratio test along p = target − h_F: the smallest α = (bound − h_i)/p_i over free variables
/// moving toward a finite bound. Returns (α, (i, side)) if α < 1, i.e. the target leaves the box.
fn first_bound_hit(
    h: &DVector<f64>,
    target: &DVector<f64>,
    free: &[usize],
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) -> Option<(f64, (usize, Status))> {
    let mut best: Option<(f64, (usize, Status))> = None;
    for (k, &i) in free.iter().enumerate() {
        let p = target[k] - h[i];
        let hit = if p < 0.0 && lower[i].is_finite() {
            Some(((lower[i] - h[i]) / p, Status::Lower))
        } else if p > 0.0 && upper[i].is_finite() {
            Some(((upper[i] - h[i]) / p, Status::Upper))
        } else {
            None
        };
        if let Some((alpha, side)) = hit {
            if alpha < 1.0 && best.is_none_or(|(b, _)| alpha < b) {
                best = Some((alpha.max(0.0), (i, side)));
            }
        }
    }
    best
}

/// h_F ← h_F + α (target − h_F), kept inside the box.
fn move_toward(
    h: &mut DVector<f64>,
    target: &DVector<f64>,
    free: &[usize],
    alpha: f64,
    lower: &DVector<f64>,
    upper: &DVector<f64>,
) {
    for (k, &i) in free.iter().enumerate() {
        h[i] = clamp_to(h[i] + alpha * (target[k] - h[i]), lower[i], upper[i]);
    }
}

/// The held variable whose multiplier λ_i = (A h + g)_i has the wrong sign by the most
/// (λ_i < −tol_i at a lower bound, λ_i > tol_i at an upper bound), tol_i the rounding allowance
/// 8(n+1)ε(|g_i| + Σ_j |A_ij h_j|). None: h satisfies the KKT conditions.
fn most_violated_bound(
    a: &Damped,
    g: &DVector<f64>,
    h: &DVector<f64>,
    status: &[Status],
) -> Option<usize> {
    let n = g.len();
    let mut worst: Option<(f64, usize)> = None;
    for (i, &s) in status.iter().enumerate() {
        let violation = match s {
            Status::Lower => -1.0,
            Status::Upper => 1.0,
            Status::Free | Status::Fixed => continue,
        };
        let multiplier = g[i] + a.row_sum(i, h, |a, h| a * h);
        let scale = g[i].abs() + a.row_sum(i, h, |a, h| (a * h).abs());
        let tolerance = 8.0 * (n as f64 + 1.0) * f64::EPSILON * scale;
        let wrong = violation * multiplier; // > 0 when the bound holds h back from descent
        if wrong > tolerance && worst.is_none_or(|(w, _)| wrong > w) {
            worst = Some((wrong, i));
        }
    }
    worst.map(|(_, i)| i)
}
