//! Limited-memory BFGS with a backtracking line search over a barrier energy (Nocedal and
//! Wright, *Numerical Optimization*, 2nd ed., Algorithm 7.4 "L-BFGS two-loop recursion" and
//! Algorithm 3.1 "Backtracking line search"). Used by [`crate::maps::equalise`] to minimise the
//! L² stretch of a net of ~10⁵ parameters, whose energy is +∞ outside the fold-free set.
//!
//! Kept here rather than taken from a crate: `argmin`'s L-BFGS asks for a More–Thuente line
//! search, which evaluates the energy at trial points it does not first check for feasibility
//! (a folded net has a finite but meaningless energy here), and it would add its dependency
//! tree for one function of 100 lines. This one is sequential and deterministic: the same
//! input gives the same iterates bit for bit on any thread count (the energy's own sums must
//! be, too).
//!
//! One iteration, at x_k with gradient g_k:
//! 1. d = −H_k g_k by the two-loop recursion over the last m pairs s_i = x_{i+1} − x_i,
//!    y_i = g_{i+1} − g_i with sᵢᵀyᵢ > 0, H⁰ = γI, γ = sᵀy / yᵀy of the newest pair (the first
//!    iteration, with no pair: d = −g scaled so that max |d_i| = `first_step`);
//! 2. if gᵀd ≥ 0 (not a descent direction) the memory is dropped and d = −g as in 1;
//! 3. α = 1, halved until E(x + αd) is finite (the point is feasible) and
//!    E(x + αd) ≤ E(x) + c₁ α gᵀd (Armijo, c₁ = 10⁻⁴), at most `max_halvings` times;
//! 4. stop when no step is found, or when the decrease E(x_k) − E(x_{k+1}) is below
//!    `tolerance` · |E(x_{k+1})|, or after `max_iterations`.

use std::collections::VecDeque;

/// The kept pairs (s, y, sᵀy), oldest first.
type Pairs = VecDeque<(Vec<f64>, Vec<f64>, f64)>;

/// Options of [`minimise`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LbfgsOptions {
    /// m, the pairs kept. Default 8 (Nocedal and Wright: 3 to 20 are usual).
    pub memory: usize,
    /// Iterations at most. Default 300.
    pub max_iterations: usize,
    /// Stop when one iteration lowers E by less than this fraction of E. Default 1e-7.
    pub tolerance: f64,
    /// The largest coordinate change of the first step (the problem's length scale). Default 1.
    pub first_step: f64,
    /// Halvings of α before the line search gives up. Default 40.
    pub max_halvings: usize,
}

impl Default for LbfgsOptions {
    fn default() -> Self {
        LbfgsOptions {
            memory: 8,
            max_iterations: 300,
            tolerance: 1e-7,
            first_step: 1.0,
            max_halvings: 40,
        }
    }
}

/// Why [`minimise`] stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LbfgsStop {
    /// An iteration lowered E by less than the tolerance.
    Converged,
    /// `max_iterations` were run.
    MaxIterations,
    /// The line search found no acceptable step along −g either.
    NoStep,
    /// E or its gradient was not finite at the start.
    Infeasible,
}

/// What [`minimise`] did.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LbfgsReport {
    /// Accepted steps.
    pub iterations: usize,
    /// Energy evaluations (line-search trials included).
    pub evaluations: usize,
    /// E at the start and at the end.
    pub initial: f64,
    pub last: f64,
    /// Why it stopped.
    pub stop: LbfgsStop,
}

/// Minimise E from `x` (overwritten with the result). `energy(x)` returns E(x) and ∇E(x), or
/// `None` where x is infeasible (E = +∞). See the module docs for the iteration.
pub fn minimise(
    x: &mut [f64],
    mut energy: impl FnMut(&[f64]) -> Option<(f64, Vec<f64>)>,
    options: &LbfgsOptions,
) -> LbfgsReport {
    let mut evaluations = 1;
    let Some((mut e, mut g)) = energy(x) else {
        return LbfgsReport {
            iterations: 0,
            evaluations,
            initial: f64::INFINITY,
            last: f64::INFINITY,
            stop: LbfgsStop::Infeasible,
        };
    };
    let initial = e;
    let mut pairs: Pairs = VecDeque::new();
    let mut trial = vec![0.0; x.len()];
    for iteration in 0..options.max_iterations {
        let mut d = direction(&g, &pairs, options.first_step);
        let mut slope = dot(&g, &d);
        if slope >= 0.0 || !slope.is_finite() {
            pairs.clear();
            d = direction(&g, &pairs, options.first_step);
            slope = dot(&g, &d);
        }
        let mut alpha = 1.0;
        let mut accepted = None;
        for _ in 0..=options.max_halvings {
            for ((t, xi), di) in trial.iter_mut().zip(x.iter()).zip(&d) {
                *t = xi + alpha * di;
            }
            evaluations += 1;
            if let Some((et, gt)) = energy(&trial) {
                if et <= e + 1e-4 * alpha * slope {
                    accepted = Some((et, gt));
                    break;
                }
            }
            alpha *= 0.5;
        }
        let Some((e_new, g_new)) = accepted else {
            if pairs.is_empty() {
                return report(iteration, evaluations, initial, e, LbfgsStop::NoStep);
            }
            pairs.clear();
            continue;
        };
        let s: Vec<f64> = trial.iter().zip(x.iter()).map(|(t, xi)| t - xi).collect();
        let y: Vec<f64> = g_new.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 0.0 && sy.is_finite() {
            if pairs.len() == options.memory {
                pairs.pop_front();
            }
            pairs.push_back((s, y, sy));
        }
        x.copy_from_slice(&trial);
        let decrease = e - e_new;
        e = e_new;
        g = g_new;
        if decrease <= options.tolerance * e.abs() {
            return report(iteration + 1, evaluations, initial, e, LbfgsStop::Converged);
        }
    }
    report(
        options.max_iterations,
        evaluations,
        initial,
        e,
        LbfgsStop::MaxIterations,
    )
}

fn report(
    iterations: usize,
    evaluations: usize,
    initial: f64,
    last: f64,
    stop: LbfgsStop,
) -> LbfgsReport {
    LbfgsReport {
        iterations,
        evaluations,
        initial,
        last,
        stop,
    }
}

/// d = −H g by the two-loop recursion (module docs, step 1).
fn direction(g: &[f64], pairs: &Pairs, first_step: f64) -> Vec<f64> {
    let mut q: Vec<f64> = g.to_vec();
    let Some((_, y_new, sy_new)) = pairs.back() else {
        let largest = g.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let scale = if largest > 0.0 {
            first_step / largest
        } else {
            0.0
        };
        return g.iter().map(|x| -scale * x).collect();
    };
    let mut alphas = Vec::with_capacity(pairs.len());
    for (s, y, sy) in pairs.iter().rev() {
        let a = dot(s, &q) / sy;
        for (qi, yi) in q.iter_mut().zip(y) {
            *qi -= a * yi;
        }
        alphas.push(a);
    }
    let gamma = sy_new / dot(y_new, y_new);
    for qi in q.iter_mut() {
        *qi *= gamma;
    }
    for ((s, y, sy), a) in pairs.iter().zip(alphas.iter().rev()) {
        let b = dot(y, &q) / sy;
        for (qi, si) in q.iter_mut().zip(s) {
            *qi += (a - b) * si;
        }
    }
    q.iter().map(|x| -x).collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Rosenbrock function from (−1.2, 1): L-BFGS reaches the minimum (1, 1) to 1e-6 in
    /// well under 100 iterations (Nocedal and Wright report ~35 for BFGS).
    #[test]
    fn rosenbrock() {
        let mut x = vec![-1.2, 1.0];
        let options = LbfgsOptions {
            tolerance: 0.0,
            max_iterations: 200,
            ..LbfgsOptions::default()
        };
        let r = minimise(
            &mut x,
            |x| {
                let (a, b) = (1.0 - x[0], x[1] - x[0] * x[0]);
                let e = a * a + 100.0 * b * b;
                Some((e, vec![-2.0 * a - 400.0 * x[0] * b, 200.0 * b]))
            },
            &options,
        );
        assert!(
            (x[0] - 1.0).abs() < 1e-6 && (x[1] - 1.0).abs() < 1e-6,
            "{x:?} {r:?}"
        );
        assert!(r.last < 1e-12, "{r:?}");
    }

    /// A barrier: E = x − ln(x) is +∞ (None) for x ≤ 0; from x = 5 the line search must not
    /// step through the barrier, and the minimum is x = 1.
    #[test]
    fn barrier_is_respected() {
        let mut x = vec![5.0];
        let r = minimise(
            &mut x,
            |x| (x[0] > 0.0).then(|| (x[0] - x[0].ln(), vec![1.0 - 1.0 / x[0]])),
            &LbfgsOptions {
                first_step: 10.0,
                ..LbfgsOptions::default()
            },
        );
        assert!((x[0] - 1.0).abs() < 1e-3, "{x:?} {r:?}");
        assert_eq!(r.stop, LbfgsStop::Converged);
    }

    /// A start outside the feasible set is reported, not stepped from.
    #[test]
    fn infeasible_start() {
        let mut x = vec![-1.0];
        let r = minimise(
            &mut x,
            |x| (x[0] > 0.0).then(|| (x[0], vec![1.0])),
            &LbfgsOptions::default(),
        );
        assert_eq!(r.stop, LbfgsStop::Infeasible);
        assert_eq!(x, vec![-1.0]);
    }
}
