//! Skin weights of a simplified vertex and the weight step of the alternating minimisation
//! (SPEC.md §§ 5 and 7, seed slides "Quadratic #2: Solve for
//! weights" and "Weight reduction").
//!
//! With the position `v` fixed, `E(α) = αᵀ H α`, `H = Σ_j B^{jT} Q^j B^j` (K×K, PSD),
//! `B^j = [M_1^j v̂ … M_K^j v̂]`. The weight QP is
//!
//! `min_α αᵀ(H + μI)α − 2μ α₀ᵀα   subject to  1ᵀα = 1, α ≥ 0`,
//!
//! i.e. `αᵀHα + μ‖α − α₀‖²` up to a constant: the small regulariser `μ` (relative to `H`'s
//! trace, [`regulariser`]) makes the optimum unique when `H` is singular and picks the one
//! closest to the starting weights `α₀`. In the standard form `½αᵀGα + cᵀα` used below,
//! `G = 2(H + μI)`, `c = −2μα₀`. Two exact solvers: [`solve_enumerate`] (every support `S`,
//! KKT system `[G_SS 1; 1ᵀ 0][α_S; λ] = [−c_S; 1]`) and [`solve_active_set`] (primal active
//! set, Nocedal–Wright Algorithm 16.3, the default). [`kkt_residual`] checks a solution.

/// Most influences a simplified vertex can keep (two glTF `JOINTS_n`/`WEIGHTS_n` sets).
pub const MAX_INFLUENCES: usize = 8;
/// Most candidate bones in one weight QP: the union of two endpoints' influences.
pub const MAX_CANDIDATES: usize = 2 * MAX_INFLUENCES;

/// A vertex's skin weights: up to [`MAX_INFLUENCES`] `(joint, weight)` pairs, weights > 0
/// summing to 1, sorted by joint index.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    len: u8,
    joints: [u32; MAX_INFLUENCES],
    values: [f64; MAX_INFLUENCES],
}

impl Weights {
    /// Weights from `(joint, weight)` pairs: zero weights dropped, sorted by joint. The caller
    /// guarantees at most [`MAX_INFLUENCES`] non-zero pairs, distinct joints, sum 1.
    pub fn from_pairs(pairs: &[(u32, f64)]) -> Weights {
        let mut sorted: Vec<(u32, f64)> = pairs.iter().copied().filter(|p| p.1 > 0.0).collect();
        sorted.sort_by_key(|p| p.0);
        let mut w = Weights {
            len: 0,
            joints: [0; MAX_INFLUENCES],
            values: [0.0; MAX_INFLUENCES],
        };
        for (k, (j, x)) in sorted.into_iter().take(MAX_INFLUENCES).enumerate() {
            w.joints[k] = j;
            w.values[k] = x;
            w.len = k as u8 + 1;
        }
        w
    }

    /// One joint with weight 1.
    pub fn single(joint: u32) -> Weights {
        Weights::from_pairs(&[(joint, 1.0)])
    }

    /// Number of influences.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// Whether there are no influences.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The `(joint, weight)` pairs, sorted by joint.
    pub fn pairs(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        (0..self.len()).map(|k| (self.joints[k], self.values[k]))
    }

    /// The weight of `joint` (0 when absent).
    pub fn weight_of(&self, joint: u32) -> f64 {
        self.pairs().find(|p| p.0 == joint).map_or(0.0, |p| p.1)
    }

    /// Sum of the weights.
    pub fn sum(&self) -> f64 {
        self.pairs().map(|p| p.1).sum()
    }
}

/// `μ = ratio · tr(H)/K` (or `ratio` when `H = 0`): the weight of `‖α − α₀‖²` in the QP,
/// small against the curvature of `E` so that it only breaks ties.
pub fn regulariser(h: &[f64], k: usize, ratio: f64) -> f64 {
    let trace: f64 = (0..k).map(|i| h[i * k + i]).sum();
    if trace > 0.0 && trace.is_finite() {
        ratio * trace / k as f64
    } else {
        ratio
    }
}

/// The QP in standard form `min ½αᵀGα + cᵀα` s.t. `1ᵀα = 1, α ≥ 0`, K ≤ [`MAX_CANDIDATES`]:
/// `g` row-major K×K.
#[derive(Clone, Debug)]
pub struct WeightQp {
    pub k: usize,
    pub g: Vec<f64>,
    pub c: Vec<f64>,
}

impl WeightQp {
    /// `G = 2(H + μI)`, `c = −2μα₀` (module docs).
    pub fn new(h: &[f64], k: usize, alpha0: &[f64], mu: f64) -> WeightQp {
        let mut g: Vec<f64> = h.iter().map(|x| 2.0 * x).collect();
        for i in 0..k {
            g[i * k + i] += 2.0 * mu;
        }
        let c = alpha0.iter().map(|a| -2.0 * mu * a).collect();
        WeightQp { k, g, c }
    }

    /// `½αᵀGα + cᵀα`.
    pub fn objective(&self, alpha: &[f64]) -> f64 {
        let k = self.k;
        let mut total = 0.0;
        for i in 0..k {
            let gi: f64 = (0..k).map(|j| self.g[i * k + j] * alpha[j]).sum();
            total += alpha[i] * (0.5 * gi + self.c[i]);
        }
        total
    }

    /// The gradient `Gα + c`.
    pub fn gradient(&self, alpha: &[f64]) -> Vec<f64> {
        (0..self.k).map(|i| self.gradient_entry(alpha, i)).collect()
    }

    /// Entry `i` of the gradient, `(Gα + c)_i`.
    fn gradient_entry(&self, alpha: &[f64], i: usize) -> f64 {
        let k = self.k;
        (0..k).map(|j| self.g[i * k + j] * alpha[j]).sum::<f64>() + self.c[i]
    }

    /// The minimiser on the support `free` (the others fixed at 0) under `1ᵀα = 1`: solve
    /// `[G_SS 1; 1ᵀ 0][α_S; λ] = [−c_S; 1]`. Returns `(α, λ)`, `None` if the system is
    /// singular.
    /// The system is at most 17×17 and lives on the stack (this runs for every queued edge).
    fn solve_on_support(&self, free: &[usize]) -> Option<([f64; MAX_CANDIDATES], f64)> {
        const N: usize = MAX_CANDIDATES + 1;
        let s = free.len();
        let n = s + 1;
        let mut a = [0.0; N * N];
        let mut b = [0.0; N];
        for (r, &i) in free.iter().enumerate() {
            for (c, &j) in free.iter().enumerate() {
                a[r * n + c] = self.g[i * self.k + j];
            }
            a[r * n + s] = 1.0;
            a[s * n + r] = 1.0;
            b[r] = -self.c[i];
        }
        b[s] = 1.0;
        let mut x = [0.0; N];
        if !solve_dense_into(n, &mut a[..n * n], &mut b[..n], &mut x[..n]) {
            return None;
        }
        let mut alpha = [0.0; MAX_CANDIDATES];
        for (r, &i) in free.iter().enumerate() {
            alpha[i] = x[r];
        }
        Some((alpha, x[s]))
    }
}

/// Exact solution by enumerating the `2^K − 1` supports: on each, the equality-constrained
/// minimiser; the feasible one (all α ≥ 0) of least objective wins (ties: first support in
/// bit order). `G` positive definite makes it the unique global minimiser. Cost O(2^K K³):
/// the reference for small K, used by the tests to check [`solve_active_set`].
pub fn solve_enumerate(qp: &WeightQp) -> Vec<f64> {
    let k = qp.k;
    let mut best: Option<(f64, Vec<f64>)> = None;
    for mask in 1u32..(1u32 << k) {
        let free: Vec<usize> = (0..k).filter(|&i| mask & (1 << i) != 0).collect();
        let Some((alpha, _)) = qp.solve_on_support(&free) else {
            continue;
        };
        let alpha = alpha[..k].to_vec();
        if alpha.iter().any(|&a| a < 0.0) {
            continue;
        }
        let f = qp.objective(&alpha);
        if best.as_ref().is_none_or(|(bf, _)| f < *bf) {
            best = Some((f, alpha));
        }
    }
    best.map_or_else(|| uniform(k), |(_, a)| a)
}

/// Primal active-set method (Nocedal–Wright Algorithm 16.3) from the feasible `start`
/// (α ≥ 0, Σα = 1). Working set `W` = indices held at 0. Each iteration solves the
/// equality-constrained problem on the free set; a full step is taken when it stays
/// non-negative, else the longest feasible step is taken and the blocking index joins `W`.
/// At a stationary point the bound multipliers `μ_i = (Gα + c)_i + λ`, `i ∈ W`, are checked:
/// all ≥ 0 means optimal, else the most negative leaves `W` (ties: lowest index). Finite
/// termination for positive definite `G`; capped at `10 (K + 1)` iterations.
pub fn solve_active_set(qp: &WeightQp, start: &[f64]) -> Vec<f64> {
    let k = qp.k;
    let mut alpha = start.to_vec();
    let mut held = [false; MAX_CANDIDATES];
    for (h, &a) in held.iter_mut().zip(&alpha) {
        *h = a <= 0.0;
    }
    for a in alpha.iter_mut() {
        *a = a.max(0.0);
    }
    let mut free_buffer = [0usize; MAX_CANDIDATES];
    for _ in 0..10 * (k + 1) {
        let mut count = 0;
        for i in (0..k).filter(|&i| !held[i]) {
            free_buffer[count] = i;
            count += 1;
        }
        let free = &free_buffer[..count];
        let Some((target, lambda)) = qp.solve_on_support(free) else {
            break;
        };
        if free.iter().all(|&i| target[i] >= 0.0) {
            alpha.copy_from_slice(&target[..k]);
            let leave = (0..k)
                .filter(|&i| held[i])
                .map(|i| (i, qp.gradient_entry(&alpha, i) + lambda))
                .filter(|&(_, m)| m < 0.0)
                .min_by(|x, y| x.1.total_cmp(&y.1));
            match leave {
                Some((i, _)) => held[i] = false,
                None => break,
            }
        } else {
            let mut step = 1.0;
            let mut blocking = None;
            for &i in free {
                if target[i] < alpha[i] {
                    let t = alpha[i] / (alpha[i] - target[i]);
                    if t < step {
                        step = t;
                        blocking = Some(i);
                    }
                }
            }
            for i in 0..k {
                alpha[i] += step * (target[i] - alpha[i]);
            }
            if let Some(i) = blocking {
                alpha[i] = 0.0;
                held[i] = true;
            }
        }
    }
    alpha
}

/// The largest violation of the QP's KKT conditions at `alpha`, relative to the problem's
/// scale `max|G| + max|c|`: primal (`|Σα − 1|`, `max(−α)`), stationarity on the support
/// (`|(Gα + c)_i − ν|`, `ν` the mean of `(Gα + c)` over the support), dual feasibility off
/// the support (`max(0, ν − (Gα + c)_i)`). Complementarity holds by construction (off the
/// support α = 0).
pub fn kkt_residual(qp: &WeightQp, alpha: &[f64]) -> f64 {
    let g = qp.gradient(alpha);
    let support: Vec<usize> = (0..qp.k).filter(|&i| alpha[i] > 0.0).collect();
    let nu = support.iter().map(|&i| g[i]).sum::<f64>() / support.len().max(1) as f64;
    let scale =
        qp.g.iter()
            .chain(&qp.c)
            .fold(0.0f64, |m, x| m.max(x.abs()))
            .max(1e-300);
    let primal = (alpha.iter().sum::<f64>() - 1.0)
        .abs()
        .max(alpha.iter().fold(0.0f64, |m, &a| m.max(-a)));
    let stationary = support
        .iter()
        .fold(0.0f64, |m, &i| m.max((g[i] - nu).abs()));
    let dual = (0..qp.k)
        .filter(|&i| alpha[i] <= 0.0)
        .fold(0.0f64, |m, i| m.max(nu - g[i]));
    primal.max(stationary / scale).max(dual / scale)
}

/// The `w_max` largest entries of `alpha` (ties: lower index), as a 0/1 mask: the support kept
/// by the seed's weight reduction ("prune down to n largest weights").
pub fn largest_support(alpha: &[f64], w_max: usize) -> Vec<bool> {
    let mut order: Vec<usize> = (0..alpha.len()).collect();
    order.sort_by(|&a, &b| alpha[b].total_cmp(&alpha[a]).then(a.cmp(&b)));
    let mut keep = vec![false; alpha.len()];
    for &i in order.iter().take(w_max) {
        keep[i] = alpha[i] > 0.0;
    }
    keep
}

/// The QP restricted to the indices of `keep` (the others fixed at 0), and the map back.
pub fn restrict(qp: &WeightQp, keep: &[bool]) -> (WeightQp, Vec<usize>) {
    let index: Vec<usize> = (0..qp.k).filter(|&i| keep[i]).collect();
    let s = index.len();
    let mut g = vec![0.0; s * s];
    for (r, &i) in index.iter().enumerate() {
        for (c, &j) in index.iter().enumerate() {
            g[r * s + c] = qp.g[i * qp.k + j];
        }
    }
    let c = index.iter().map(|&i| qp.c[i]).collect();
    (WeightQp { k: s, g, c }, index)
}

/// `1/K` in every entry.
fn uniform(k: usize) -> Vec<f64> {
    vec![1.0 / k as f64; k]
}

/// Solve the dense `n×n` system `A x = b` (row-major, overwritten) by Gaussian elimination with
/// partial pivoting; `None` when a pivot is zero or not finite.
pub fn solve_dense(n: usize, a: &mut [f64], b: &mut [f64]) -> Option<Vec<f64>> {
    let mut x = vec![0.0; n];
    solve_dense_into(n, a, b, &mut x).then_some(x)
}

/// [`solve_dense`] writing the solution into `x` (length `n`); `false` when it fails.
fn solve_dense_into(n: usize, a: &mut [f64], b: &mut [f64], x: &mut [f64]) -> bool {
    for col in 0..n {
        let Some(pivot) =
            (col..n).max_by(|&r, &s| a[r * n + col].abs().total_cmp(&a[s * n + col].abs()))
        else {
            return false;
        };
        let p = a[pivot * n + col];
        if p == 0.0 || !p.is_finite() {
            return false;
        }
        if pivot != col {
            for c in 0..n {
                a.swap(pivot * n + c, col * n + c);
            }
            b.swap(pivot, col);
        }
        for r in col + 1..n {
            let f = a[r * n + col] / p;
            if f != 0.0 {
                for c in col..n {
                    a[r * n + c] -= f * a[col * n + c];
                }
                b[r] -= f * b[col];
            }
        }
    }
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|c| a[r * n + c] * x[c]).sum();
        x[r] = (b[r] - s) / a[r * n + r];
    }
    x.iter().all(|v| v.is_finite())
}
