//! The skinned collapse cost `E(v, α)` and where the merged vertex goes (SPEC.md §§ 3–8;
//! seed slides "Modify QEF equation", "Quadratic #1", "Quadratic
//! #2", "Alternating minimization", "Weight reduction").
//!
//! For an edge `(a, b)` with summed per-pose quadrics `Q^j = Q_a^j + Q_b^j` and candidate bones
//! `k ∈ C` (the union of the endpoints' joints), the merged vertex has a rest position `v` and
//! weights `α` over `C`, and
//!
//! `E(v, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂)`,  `A^j = Σ_k α_k M_k^j`.
//!
//! - Position step ([`position_step`], α fixed): `Q̃ = Σ_j A^{jT} Q^j A^j`; solve
//!   `Q̃[0:3,0:3] v = −Q̃[0:3,3]`; when that 3×3 block is ill-conditioned (or the solution is
//!   worse) the best of {current v, a, b, midpoint} is kept.
//! - Weight step ([`weight_matrix`] + [`super::weights`], v fixed): `E = αᵀHα`,
//!   `H_kl = Σ_j (M_k^j v̂)ᵀ Q^j (M_l^j v̂)`; the QP on the simplex.
//! - [`place_full`] alternates the two from the better endpoint's weights; each half-step is
//!   accepted only if `E` does not increase, so `E` is monotone. Then weight reduction to
//!   `W_max`: keep the largest, re-solve the QP on that support, re-solve `v`.
//! - Baselines: [`place_endpoint_weights`] (Mohr–Gleicher: the better endpoint's weights, the
//!   optimal position for them) and [`place_rest`] (plain quadrics of the rest pose, weights
//!   of the endpoint nearer to the new position).
//! - Shared-connectivity frame sequences without weights: [`place_frames`], each pose's
//!   position optimal for its own quadric.
//!
//! **Pose Gram matrices.** `E`, `Q̃` and `H` are quadratic forms in `α`, so summing over the
//! poses can be done once per edge: with `G_kl = Σ_j M_k^{jT} Q^j M_l^j` ([`PoseGram`]),
//! `Q̃(α) = Σ_kl α_k α_l G_kl`, `H_kl(v) = v̂ᵀ G_kl v̂` and `E(v, α) = αᵀ H(v) α`. The solvers
//! below use these (each half-step then costs O(K²), not O(P K)); [`energy`],
//! [`position_quadric`] and [`weight_matrix`] are the per-pose definitions, which the tests
//! and the GPU cross-check compare them with.

use nalgebra::{Matrix3, Matrix4, Point3, Vector3, Vector4};

use super::quadric::Quadric;
use super::weights::{
    kkt_residual, largest_support, regulariser, restrict, solve_active_set, solve_enumerate,
    WeightQp, Weights, MAX_CANDIDATES,
};

/// Which exact solver the weight step uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WeightSolver {
    /// Primal active set ([`super::weights::solve_active_set`]). Default.
    #[default]
    ActiveSet,
    /// Enumerate all supports ([`super::weights::solve_enumerate`]); O(2^K K³).
    Enumerate,
}

/// Parameters of the alternating minimisation.
#[derive(Clone, Copy, Debug)]
pub struct CostOptions {
    /// Most alternations (weight step + position step). Default 5 (SPEC.md § 6: ≈5 to converge).
    pub max_alternations: usize,
    /// Stop when an alternation lowers `E` by less than this fraction. Default 1e-9.
    pub relative_tolerance: f64,
    /// Most influences of the merged vertex, `W_max`. Default 4 (one glTF set).
    pub max_weights: usize,
    /// `μ / (tr H / K)`, the weight of `‖α − α₀‖²` in the QP. Default 1e-9.
    pub regularisation: f64,
    /// Largest `cond_F(Q̃[0:3,0:3])` at which the position is solved. Default 1e10.
    pub max_condition: f64,
    /// The weight-QP solver. Default [`WeightSolver::ActiveSet`].
    pub solver: WeightSolver,
}

impl Default for CostOptions {
    fn default() -> Self {
        CostOptions {
            max_alternations: 5,
            relative_tolerance: 1e-9,
            max_weights: 4,
            regularisation: 1e-9,
            max_condition: 1e10,
            solver: WeightSolver::ActiveSet,
        }
    }
}

/// One edge's data: summed quadrics per pose, the joint matrices `M_k^j`, the endpoints.
pub struct EdgeProblem<'a> {
    /// `Q^j = Q_a^j + Q_b^j`, one per pose.
    pub quadrics: &'a [Quadric],
    /// `mats[j][joint]`: the joint matrices of pose `j` (for the rest pose: identities).
    pub mats: &'a [Vec<Matrix4<f64>>],
    /// Rest positions of `a` and `b`.
    pub ends: [Point3<f64>; 2],
    /// Weights of `a` and `b`.
    pub weights: [Weights; 2],
}

/// Where the merged vertex goes and its cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Rest (bind-pose) position.
    pub rest: Point3<f64>,
    /// Skin weights (at most `W_max`).
    pub weights: Weights,
    /// `E(v, α)`.
    pub cost: f64,
}

/// The candidate bones `C` of an edge (union of the endpoints' joints, sorted) with their
/// per-pose matrices `cand[j][k] = M_{C_k}^j`.
pub struct Candidates {
    pub joints: Vec<u32>,
    /// The candidates' matrices pose by pose: `mats[j·K + k] = M_{C_k}^j` (one allocation per
    /// edge; see [`Candidates::pose`]).
    pub mats: Vec<Matrix4<f64>>,
}

impl Candidates {
    /// The union of the endpoints' joints of `problem`, at most [`MAX_CANDIDATES`].
    pub fn of(problem: &EdgeProblem) -> Candidates {
        let mut joints: Vec<u32> = Vec::with_capacity(MAX_CANDIDATES);
        joints.extend(
            problem.weights[0]
                .pairs()
                .chain(problem.weights[1].pairs())
                .map(|p| p.0),
        );
        joints.sort_unstable();
        joints.dedup();
        joints.truncate(MAX_CANDIDATES);
        // Sized once (a flattening iterator would grow the vector step by step).
        let mut mats = Vec::with_capacity(problem.mats.len() * joints.len());
        for pose in problem.mats {
            mats.extend(joints.iter().map(|&j| pose[j as usize]));
        }
        Candidates { joints, mats }
    }

    /// The candidates' matrices in pose `j`, `[M_{C_0}^j, …, M_{C_{K−1}}^j]`.
    pub fn pose(&self, j: usize) -> &[Matrix4<f64>] {
        let k = self.joints.len();
        &self.mats[j * k..(j + 1) * k]
    }

    /// `weights` as a vector over the candidates.
    pub fn vector(&self, weights: &Weights) -> Vec<f64> {
        self.joints.iter().map(|&j| weights.weight_of(j)).collect()
    }

    /// The vector `alpha` over the candidates as [`Weights`] (zeros dropped).
    pub fn weights(&self, alpha: &[f64]) -> Weights {
        let pairs: Vec<(u32, f64)> = self
            .joints
            .iter()
            .copied()
            .zip(alpha.iter().copied())
            .collect();
        Weights::from_pairs(&pairs)
    }

    /// `A^j = Σ_k α_k M_k^j`.
    fn blend(&self, pose: usize, alpha: &[f64]) -> Matrix4<f64> {
        let mut a = Matrix4::zeros();
        for (m, &w) in self.pose(pose).iter().zip(alpha) {
            if w != 0.0 {
                a += m * w;
            }
        }
        a
    }
}

/// `E(v, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂)` (module docs), summed over poses in order.
pub fn energy(quadrics: &[Quadric], cand: &Candidates, v: &Point3<f64>, alpha: &[f64]) -> f64 {
    let h = v.to_homogeneous();
    quadrics
        .iter()
        .enumerate()
        .map(|(j, q)| {
            let p = cand.blend(j, alpha) * h;
            p.dot(&(q.matrix() * p))
        })
        .sum()
}

/// `Q̃ = Σ_j A^{jT} Q^j A^j` for fixed weights `alpha`.
pub fn position_quadric(quadrics: &[Quadric], cand: &Candidates, alpha: &[f64]) -> Matrix4<f64> {
    let mut total = Matrix4::zeros();
    for (j, q) in quadrics.iter().enumerate() {
        let a = cand.blend(j, alpha);
        total += a.transpose() * q.matrix() * a;
    }
    total
}

/// The position step: the minimiser of `v̂ᵀ Q̃ v̂` (solve `Q̃[0:3,0:3] v = −Q̃[0:3,3]` when the
/// block's Frobenius condition number is at most `max_condition`), compared with the fallback
/// points `fallback` (current position, endpoints, midpoint); the least `v̂ᵀQ̃v̂` wins (ties:
/// the solution, then `fallback` in order). Returns the point and its value.
pub fn position_step(
    q: &Matrix4<f64>,
    fallback: &[Point3<f64>],
    max_condition: f64,
) -> (Point3<f64>, f64) {
    let value = |p: &Point3<f64>| {
        let h = p.to_homogeneous();
        h.dot(&(q * h))
    };
    let mut best: Option<(Point3<f64>, f64)> =
        solve_position(q, max_condition).map(|p| (p, value(&p)));
    for p in fallback {
        let e = value(p);
        if best.is_none_or(|(_, b)| e < b) {
            best = Some((*p, e));
        }
    }
    best.unwrap_or((Point3::origin(), f64::INFINITY))
}

/// `v = −Q̃[0:3,0:3]⁻¹ Q̃[0:3,3]`, `None` when the block is singular or its condition number
/// `‖A‖_F ‖A⁻¹‖_F` exceeds `max_condition`.
pub fn solve_position(q: &Matrix4<f64>, max_condition: f64) -> Option<Point3<f64>> {
    let a: Matrix3<f64> = q.fixed_view::<3, 3>(0, 0).into_owned();
    let b = Vector3::new(q[(0, 3)], q[(1, 3)], q[(2, 3)]);
    let inv = a.try_inverse()?;
    let cond = a.norm() * inv.norm();
    if cond.is_nan() || cond > max_condition {
        return None;
    }
    let v = -(inv * b);
    v.iter().all(|x| x.is_finite()).then_some(Point3::from(v))
}

/// `H_kl = Σ_j (M_k^j v̂)ᵀ Q^j (M_l^j v̂)` (K×K row-major), so that `E(v, α) = αᵀHα`.
pub fn weight_matrix(quadrics: &[Quadric], cand: &Candidates, v: &Point3<f64>) -> Vec<f64> {
    let k = cand.joints.len();
    let h = v.to_homogeneous();
    let mut out = vec![0.0; k * k];
    let mut columns: Vec<Vector4<f64>> = Vec::with_capacity(k);
    for (j, q) in quadrics.iter().enumerate() {
        let qm = q.matrix();
        columns.clear();
        columns.extend(cand.pose(j).iter().map(|m| m * h));
        for r in 0..k {
            let qr = qm * columns[r];
            for c in r..k {
                let x = qr.dot(&columns[c]);
                out[r * k + c] += x;
                if c != r {
                    out[c * k + r] += x;
                }
            }
        }
    }
    out
}

/// The pose Gram matrices of an edge, `G_kl = Σ_j M_k^{jT} Q^j M_l^j` for the candidate bones
/// `k, l` (module docs), summed over the poses in order. `G_lk = G_klᵀ`.
pub struct PoseGram {
    k: usize,
    /// `g[k * K + l] = G_kl`.
    g: Vec<Matrix4<f64>>,
}

impl PoseGram {
    /// `G_kl` from the summed per-pose quadrics and the candidates' per-pose matrices.
    pub fn new(quadrics: &[Quadric], cand: &Candidates) -> PoseGram {
        let k = cand.joints.len();
        let mut g = vec![Matrix4::zeros(); k * k];
        let mut q_m = [Matrix4::zeros(); MAX_CANDIDATES];
        for (j, q) in quadrics.iter().enumerate() {
            let qm = q.matrix();
            for (x, m) in q_m.iter_mut().zip(cand.pose(j)) {
                *x = qm * m;
            }
            for r in 0..k {
                let mt = cand.pose(j)[r].transpose();
                for c in r..k {
                    g[r * k + c] += mt * q_m[c];
                }
            }
        }
        for r in 0..k {
            for c in 0..r {
                g[r * k + c] = g[c * k + r].transpose();
            }
        }
        PoseGram { k, g }
    }

    /// `Q̃(α) = Σ_kl α_k α_l G_kl` (= [`position_quadric`]).
    pub fn position_quadric(&self, alpha: &[f64]) -> Matrix4<f64> {
        let mut total = Matrix4::zeros();
        for r in 0..self.k {
            if alpha[r] == 0.0 {
                continue;
            }
            for c in 0..self.k {
                if alpha[c] != 0.0 {
                    total += self.g[r * self.k + c] * (alpha[r] * alpha[c]);
                }
            }
        }
        total
    }

    /// `H_kl(v) = v̂ᵀ G_kl v̂` (K×K row-major; = [`weight_matrix`]).
    pub fn weight_matrix(&self, v: &Point3<f64>) -> Vec<f64> {
        let h = v.to_homogeneous();
        let k = self.k;
        let mut out = vec![0.0; k * k];
        for r in 0..k {
            for c in r..k {
                let x = h.dot(&(self.g[r * k + c] * h));
                out[r * k + c] = x;
                out[c * k + r] = x;
            }
        }
        out
    }

    /// `E(v, α) = αᵀ H(v) α` (= [`energy`]).
    pub fn energy(&self, v: &Point3<f64>, alpha: &[f64]) -> f64 {
        let h = v.to_homogeneous();
        let k = self.k;
        let mut total = 0.0;
        for r in 0..k {
            if alpha[r] == 0.0 {
                continue;
            }
            let mut row = 0.0;
            for (c, &a) in alpha.iter().enumerate().take(k) {
                if a != 0.0 {
                    row += a * h.dot(&(self.g[r * k + c] * h));
                }
            }
            total += alpha[r] * row;
        }
        total
    }
}

/// Solve the weight QP of `h` with anchor `alpha0`, starting (active set) from `start`.
pub fn weight_step(
    h: &[f64],
    k: usize,
    alpha0: &[f64],
    start: &[f64],
    options: &CostOptions,
) -> Vec<f64> {
    let mu = regulariser(h, k, options.regularisation);
    let qp = WeightQp::new(h, k, alpha0, mu);
    match options.solver {
        WeightSolver::ActiveSet => solve_active_set(&qp, start),
        WeightSolver::Enumerate => solve_enumerate(&qp),
    }
}

/// The fallback points of the position step: the endpoints `a`, `b` and their midpoint (the
/// alternation puts the current position before them).
fn fallbacks([a, b]: [Point3<f64>; 2]) -> [Point3<f64>; 3] {
    [a, b, Point3::from((a.coords + b.coords) * 0.5)]
}

/// Mohr–Gleicher baseline: for each endpoint's weights `α_e`, the optimal position for
/// `α_e`; the one of lower `E` (ties: `a`). Also the start of [`place_full`].
pub fn place_endpoint_weights(problem: &EdgeProblem, options: &CostOptions) -> Placement {
    let cand = Candidates::of(problem);
    let gram = PoseGram::new(problem.quadrics, &cand);
    endpoint_start(problem, &cand, &gram, options).0
}

/// [`place_endpoint_weights`] with the winning weight vector over `cand`.
fn endpoint_start(
    problem: &EdgeProblem,
    cand: &Candidates,
    gram: &PoseGram,
    options: &CostOptions,
) -> (Placement, Vec<f64>) {
    let mut best: Option<(Placement, Vec<f64>)> = None;
    for e in 0..2 {
        let alpha = cand.vector(&problem.weights[e]);
        let q = gram.position_quadric(&alpha);
        let (v, _) = position_step(&q, &fallbacks(problem.ends), options.max_condition);
        let cost = gram.energy(&v, &alpha);
        if best.as_ref().is_none_or(|(b, _)| cost < b.cost) {
            let placement = Placement {
                rest: v,
                weights: problem.weights[e],
                cost,
            };
            best = Some((placement, alpha));
        }
    }
    best.expect("two endpoints")
}

/// Rest-pose baseline: `problem.quadrics` holds the rest-pose quadric (`problem.mats` is not
/// used: the rest pose has identity joint matrices, so `Q̃ = Σ_j Q^j`); the optimal position
/// ([`rest_position`]), and the weights of the endpoint nearer to it (ties: `a`).
pub fn place_rest(problem: &EdgeProblem, options: &CostOptions) -> Placement {
    let (v, cost) = rest_position(problem.quadrics, problem.ends, options.max_condition);
    let [a, b] = problem.ends;
    let nearer = usize::from((v - b).norm_squared() < (v - a).norm_squared());
    Placement {
        rest: v,
        weights: problem.weights[nearer],
        cost,
    }
}

/// The position of the rest-pose baseline and its cost (plain Garland–Heckbert): the
/// [`position_step`] of `Q = Σ_j Q^j` with the fallbacks `a`, `b`, midpoint (`ends`); no weights
/// are involved, so the simplifier queues edges by this value alone.
pub fn rest_position(
    quadrics: &[Quadric],
    ends: [Point3<f64>; 2],
    max_condition: f64,
) -> (Point3<f64>, f64) {
    let q: Matrix4<f64> = quadrics.iter().map(Quadric::matrix).sum();
    position_step(&q, &fallbacks(ends), max_condition)
}

/// The rest-pose cost `Σ_j v̂ᵀQ^j v̂` of a given position `v` (a half-edge collapse).
pub fn rest_value(quadrics: &[Quadric], v: &Point3<f64>) -> f64 {
    quadrics.iter().map(|q| q.eval(v)).sum()
}

/// The record of one alternating minimisation: `E` after the start and after every half-step.
#[derive(Clone, Debug, Default)]
pub struct Alternation {
    pub energies: Vec<f64>,
    /// KKT residual of every weight step's QP solution.
    pub kkt: Vec<f64>,
}

/// The full method (SPEC.md § 6): from the better endpoint's weights ([`place_endpoint_weights`])
/// alternate weight step and position step (each accepted only if `E` does not grow) until
/// `E` drops by less than `relative_tolerance` or `max_alternations`; then reduce to
/// `max_weights` influences (largest kept, QP re-solved on that support, `v` re-solved). If the
/// reduced result is worse than the start, the start is returned (it already has ≤ W_max).
pub fn place_full(problem: &EdgeProblem, options: &CostOptions) -> (Placement, Alternation) {
    let mut trace = Alternation::default();
    let placement = place_full_traced(problem, options, Some(&mut trace));
    (placement, trace)
}

/// [`place_full`] without the record (what the simplifier calls for every queued edge: the
/// KKT residuals are diagnostics).
pub fn place_full_cost(problem: &EdgeProblem, options: &CostOptions) -> Placement {
    place_full_traced(problem, options, None)
}

/// [`place_full`], recording into `trace` when given.
fn place_full_traced(
    problem: &EdgeProblem,
    options: &CostOptions,
    mut trace: Option<&mut Alternation>,
) -> Placement {
    let cand = Candidates::of(problem);
    let gram = PoseGram::new(problem.quadrics, &cand);
    let (start, alpha0) = endpoint_start(problem, &cand, &gram, options);
    if let Some(t) = trace.as_deref_mut() {
        t.energies.push(start.cost);
    }
    let k = cand.joints.len();
    let (mut v, mut alpha, mut e) = (start.rest, alpha0.clone(), start.cost);
    for _ in 0..options.max_alternations {
        let before = e;
        // Weight step.
        let h = gram.weight_matrix(&v);
        let new_alpha = weight_step(&h, k, &alpha0, &alpha, options);
        if let Some(t) = trace.as_deref_mut() {
            t.kkt.push(kkt_of(&h, k, &alpha0, &new_alpha, options));
        }
        let e_w = gram.energy(&v, &new_alpha);
        if e_w <= e {
            alpha = new_alpha;
            e = e_w;
        }
        if let Some(t) = trace.as_deref_mut() {
            t.energies.push(e);
        }
        // Position step.
        let (nv, ne) = position_given_weights(problem, &gram, &alpha, v, options);
        if ne <= e {
            v = nv;
            e = ne;
        }
        if let Some(t) = trace.as_deref_mut() {
            t.energies.push(e);
        }
        if before - e <= options.relative_tolerance * before {
            break;
        }
    }
    if alpha.iter().filter(|&&a| a > 0.0).count() > options.max_weights {
        let (rv, ralpha, re) = reduce(problem, &gram, v, &alpha, &alpha0, options);
        if re <= start.cost {
            v = rv;
            alpha = ralpha;
            e = re;
        } else {
            return start;
        }
    }
    Placement {
        rest: v,
        weights: cand.weights(&alpha),
        cost: e,
    }
}

/// Position step for fixed `alpha`, with `current` among the fallbacks; returns `(v, E(v, α))`.
fn position_given_weights(
    problem: &EdgeProblem,
    gram: &PoseGram,
    alpha: &[f64],
    current: Point3<f64>,
    options: &CostOptions,
) -> (Point3<f64>, f64) {
    let q = gram.position_quadric(alpha);
    let [a, b, mid] = fallbacks(problem.ends);
    let (v, _) = position_step(&q, &[current, a, b, mid], options.max_condition);
    (v, gram.energy(&v, alpha))
}

/// Weight reduction (seed "Weight reduction"): keep the `W_max` largest weights, re-solve the
/// QP on that support at `v`, then re-solve `v`.
fn reduce(
    problem: &EdgeProblem,
    gram: &PoseGram,
    v: Point3<f64>,
    alpha: &[f64],
    alpha0: &[f64],
    options: &CostOptions,
) -> (Point3<f64>, Vec<f64>, f64) {
    let keep = largest_support(alpha, options.max_weights);
    let alpha_kept = reduce_weights_with(gram, &v, alpha, alpha0, &keep, options);
    let (nv, ne) = position_given_weights(problem, gram, &alpha_kept, v, options);
    (nv, alpha_kept, ne)
}

/// The weight QP at `v` restricted to `keep` (others 0), started from `alpha` rescaled onto the
/// kept support; the result over all candidates.
pub fn reduce_weights(
    quadrics: &[Quadric],
    cand: &Candidates,
    v: &Point3<f64>,
    alpha: &[f64],
    alpha0: &[f64],
    keep: &[bool],
    options: &CostOptions,
) -> Vec<f64> {
    let gram = PoseGram::new(quadrics, cand);
    reduce_weights_with(&gram, v, alpha, alpha0, keep, options)
}

/// [`reduce_weights`] with the edge's [`PoseGram`] already built.
fn reduce_weights_with(
    gram: &PoseGram,
    v: &Point3<f64>,
    alpha: &[f64],
    alpha0: &[f64],
    keep: &[bool],
    options: &CostOptions,
) -> Vec<f64> {
    let k = gram.k;
    let h = gram.weight_matrix(v);
    let mu = regulariser(&h, k, options.regularisation);
    let qp = WeightQp::new(&h, k, alpha0, mu);
    let (sub, index) = restrict(&qp, keep);
    let kept_sum: f64 = index.iter().map(|&i| alpha[i]).sum();
    let start: Vec<f64> = index.iter().map(|&i| alpha[i] / kept_sum).collect();
    let x = match options.solver {
        WeightSolver::ActiveSet => solve_active_set(&sub, &start),
        WeightSolver::Enumerate => solve_enumerate(&sub),
    };
    let mut out = vec![0.0; k];
    for (r, &i) in index.iter().enumerate() {
        out[i] = x[r];
    }
    out
}

/// KKT residual of the weight QP of `h` at `alpha` ([`kkt_residual`]).
fn kkt_of(h: &[f64], k: usize, alpha0: &[f64], alpha: &[f64], options: &CostOptions) -> f64 {
    let mu = regulariser(h, k, options.regularisation);
    kkt_residual(&WeightQp::new(h, k, alpha0, mu), alpha)
}

/// Frame sequences without weights: in each pose `j`, the minimiser of `v̂ᵀQ^j v̂` (fallbacks
/// `a^j`, `b^j`, midpoint). `ends[j]` = the endpoints' positions in pose `j`. Returns the
/// per-pose positions and `Σ_j` of the values.
pub fn place_frames(
    quadrics: &[Quadric],
    ends: &[[Point3<f64>; 2]],
    max_condition: f64,
) -> (Vec<Point3<f64>>, f64) {
    let mut total = 0.0;
    let positions = quadrics
        .iter()
        .zip(ends)
        .map(|(q, [a, b])| {
            let mid = Point3::from((a.coords + b.coords) * 0.5);
            let (p, e) = position_step(&q.matrix(), &[*a, *b, mid], max_condition);
            total += e;
            p
        })
        .collect();
    (positions, total)
}

/// A half-edge collapse onto endpoint `keep` (0 = a, 1 = b), used when the other endpoint
/// cannot move off a UV seam ([`super::collapse`]): the merged vertex stays at the kept
/// endpoint's rest position. Weights: the kept endpoint's for the baselines; for
/// [`Method::Full`](super::Method::Full) one exact weight step at that position from them
/// (accepted only if `E` drops), then reduction to `W_max` (kept only if still no worse).
/// For [`Method::Rest`](super::Method::Rest) `E = v̂ᵀ(Σ_j Q^j)v̂` as in [`place_rest`]
/// ([`rest_value`]).
pub fn place_at_endpoint(
    problem: &EdgeProblem,
    keep: usize,
    method: super::Method,
    options: &CostOptions,
) -> Placement {
    let v = problem.ends[keep];
    let own = problem.weights[keep];
    if method == super::Method::Rest {
        let cost = rest_value(problem.quadrics, &v);
        return Placement {
            rest: v,
            weights: own,
            cost,
        };
    }
    let cand = Candidates::of(problem);
    let gram = PoseGram::new(problem.quadrics, &cand);
    let alpha0 = cand.vector(&own);
    let start = Placement {
        rest: v,
        weights: own,
        cost: gram.energy(&v, &alpha0),
    };
    if method == super::Method::Mohr {
        return start;
    }
    let k = cand.joints.len();
    let h = gram.weight_matrix(&v);
    let mut alpha = weight_step(&h, k, &alpha0, &alpha0, options);
    if alpha.iter().filter(|&&a| a > 0.0).count() > options.max_weights {
        let keep_set = largest_support(&alpha, options.max_weights);
        alpha = reduce_weights_with(&gram, &v, &alpha, &alpha0, &keep_set, options);
    }
    let cost = gram.energy(&v, &alpha);
    if cost <= start.cost {
        Placement {
            rest: v,
            weights: cand.weights(&alpha),
            cost,
        }
    } else {
        start
    }
}
