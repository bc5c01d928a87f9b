//! The inner problem of each damped step of [`super::minimize`]: the exact minimiser of a
//! convex quadratic over a box (the primal active-set method, Nocedal & Wright Algorithm
//! 16.3), on a banded matrix's envelope.

use std::collections::HashSet;

use nalgebra::{DMatrix, DVector};

use super::problem::{check_box, clamp_to};
use crate::error::{Error, Result};

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
/// cheap when A is banded, as the grid energies' JᵀJ are. (Inside [`minimize`](super::minimize) the damped
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
pub(super) fn box_qp(
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
pub(super) struct RowSpans {
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
    pub(super) fn of(a: &DMatrix<f64>) -> RowSpans {
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
pub(super) struct Damped<'a> {
    pub(super) a: &'a DMatrix<f64>,
    pub(super) lambda: f64,
    pub(super) spans: &'a RowSpans,
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

    /// [`predicted_decrease`](super::predicted_decrease) with the undamped A: −hᵀ(2g + A h).
    pub(super) fn undamped_predicted_decrease(&self, jtr: &DVector<f64>, h: &DVector<f64>) -> f64 {
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
