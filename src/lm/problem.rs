//! The problem [`super::minimize`] solves: a least-squares [`Residuals`](super::Residuals) given through its
//! [`NormalEquations`] (F, JᵀJ, Jᵀr at a point, assembled from per-part blocks by
//! [`AssemblyPlan`]), and the box l ≤ x ≤ u ([`Bounds`]).

use nalgebra::{DMatrix, DVector};

use serde::Serialize;

use crate::error::{Error, Result};

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
    /// F(x), JᵀJ (n×n) and Jᵀr (n) at x. [`minimize`](super::minimize) asks for them only at x₀ and at accepted
    /// points; [`Speculative`] also at trial points, so their F must be `energy(x)` bit for
    /// bit (+∞ where that is +∞).
    fn normal_equations(&mut self, x: &[f64]) -> NormalEquations;
    /// S = Σ_k r_k ∇²r_k at x (n×n, symmetric), if the problem offers it for an adaptive model
    /// (module docs, "Other model Hessians"); called right after
    /// [`Residuals::normal_equations`](super::Residuals::normal_equations) at the same x. The default: None (Gauss–Newton only).
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

/// A [`Residuals`](super::Residuals) problem whose trial points get their normal equations at once: a trial
/// that LM accepts then needs no second pass over the residuals for its JᵀJ and Jᵀr.
///
/// LM asks for F at every trial point and for the normal equations only at accepted ones
/// ([`Residuals`](super::Residuals)), so a rejected trial costs one pass (energy only) and an accepted one two.
/// Computing the normal equations at the trial already saves the energy-only pass whenever
/// the trial is accepted, as most are, and wastes the difference between the two passes
/// when it is rejected. So this adaptor speculates only while trials are being accepted:
/// after a rejected trial (e.g. the string of them of [`LmOptions::paper`](super::LmOptions::paper)) the next trial
/// asks for the energy alone, until one is accepted again. (Grid warp, 2 threads: a
/// normal-equations pass costs 1.7–4 energy passes, and aa 38 runs 10 passes instead of 15.)
///
/// F is taken from the normal equations; the problem must give the same F both ways, bit for
/// bit (the grid-warp energies sum the same terms in the same order), so the iterates, the
/// counts of [`LmReport`](super::LmReport) and the result are those of the plain problem.
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
    /// l ≤ x ≤ u (checked by [`minimize`](super::minimize), not here).
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
    pub(super) fn check(&self, n: usize) -> Result<()> {
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
pub(super) fn clamp_to(v: f64, lo: f64, hi: f64) -> f64 {
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

/// Every pair (l_i, u_i) is a non-empty interval: no NaN, l_i ≤ u_i, l_i ≠ +∞, u_i ≠ −∞.
pub(super) fn check_box(
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
