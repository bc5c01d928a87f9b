//! [`Lin`]: a twin evaluated in f64 on a tape, so that the error of any conforming f32
//! evaluation of its outputs can be bounded *to first order*, with the cancellations that the
//! running bounds of [`Ball`](super::ball::Ball) cannot see.
//!
//! # Why a second bound
//! [`Ball`](super::ball::Ball) bounds every intermediate on its own: rigorous, and tight for a
//! short kernel such as `bpm_eval`. A long one loses the correlations between intermediates.
//! `bpm_precompute` fits Möbius maps that are defined up to a scale (the projective gauge
//! M ~ λM): a rounding that scales a, b, c and d together leaves every map value unchanged, but
//! a ball around each coefficient counts it four times, and then once more at every division
//! by c z + d. On the canonical mesh the balls come out 20 to 20 000 times the error of the
//! worst conforming GPU, and on one face they reach 0 around c z + d (no bound at all).
//!
//! # The bound
//! Each operation i of the twin (an input rounded to f32, a literal, `+ − × /`, a builtin, a
//! sum) may perturb its result by at most its allowance aᵢ from the WGSL accuracy table, at
//! this element's magnitudes (`a ± b`, `a · b`: u|v|; `a / b`: 2.5u|v|; `sqrt`: 4.5u|v|;
//! `inverseSqrt`: 2u|v|; `exp`: (3 + 2|x|)u|v|; `log`: 2⁻²¹ on [0.5, 2], else 3u|v|; a sum of
//! n terms in any order and with any fusion: (n − 1)u Σ|tᵢ|; each plus 2⁻¹²⁶ for a flushed
//! subnormal; u = 2⁻²³). The output y then moves by
//!
//!   Δy = Σᵢ (∂y/∂eᵢ) eᵢ + O(u²),   |eᵢ| ≤ aᵢ,   so   |Δy| ≤ Σᵢ |∂y/∂eᵢ| aᵢ + O(u²),
//!
//! where ∂y/∂eᵢ is the derivative of the output with respect to a perturbation injected at
//! operation i, computed exactly (in f64) by one reverse sweep over the tape
//! ([`first_order_bound`]). A perturbation along the gauge has derivative 0, so it costs
//! nothing, as it should. For a UV output, [`first_order_bound2`] sums ‖(∂u/∂eᵢ, ∂v/∂eᵢ)‖ aᵢ.
//!
//! # Where first order is trusted
//! The neglected terms are products of two perturbations. They stay below the first-order ones
//! when every divisor, inverse square root and logarithm argument x moves by a
//! small fraction of itself: each such x is checked, |x| > [`TRUST`] · bound(x) (with
//! `TRUST` = 16, each neglected term is at most 1/15 of the first-order term it follows), and a
//! branch between different formulas ([`Real::decides_lt`]) must be decided by more than
//! [`TRUST`] times the bound of the difference of its sides. A square root near 0 (the length
//! of a vector near 0) is continuous but not differentiable: there its result starts afresh
//! with the allowance √(2 · bound) (Hölder). Where a check fails, the
//! evaluation is marked ambiguous and the kernels' bound is "unbounded": the spec gives no
//! useful promise there. The bounds the kernels use are [`SECOND_ORDER`] = 2 times the
//! first-order figure: a factor that covers neglected terms of 1/15 per operation along chains
//! of up to ten such operations ((16/15)¹⁰ < 2).
//!
//! This is an estimate correct to first order, not an enclosure: tests/twin_bpm.rs runs the
//! twins over every arithmetic [`Model`](super::model::Model), at the edge of the WGSL table,
//! on every face of six meshes, and checks that each stays inside.

// `!(x > y)` is meant throughout: a NaN must fail each check, as it would not with `x <= y`.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::cell::RefCell;
use std::ops::{Add, Div, Mul, Neg, Sub};

use super::real::Real;

/// WGSL's rounding of `+ − ×`: up or down, |δ| < 2⁻²³.
pub const U: f64 = 1.0 / 8_388_608.0;
/// The smallest normal f32, 2⁻¹²⁶: what flushing a subnormal result to zero may lose.
const FLUSH: f64 = 1.175_494_350_822_287_5e-38;
/// f64's ε, 2⁻⁵²: the f64 evaluation of each value.
const EPS64: f64 = f64::EPSILON;
/// A divisor, root or log argument is trusted to first order when it exceeds its own bound
/// `TRUST` times; a branch, when the difference of its sides does (module docs).
pub const TRUST: f64 = 16.0;
/// The factor between the first-order figure and the bound the kernels use (module docs).
pub const SECOND_ORDER: f64 = 2.0;
/// The end of the range [−π, π] where the table gives `cos` and `sin` their 2⁻¹¹, for f32
/// arguments: the f32 nearest π (3.14159274…, above π), which a kernel's `PI` literal is. An
/// angle a kernel has reduced with `if (x > PI) { x − 2π }` is at most that, also where its
/// exact value lies between π and it (a symmetric ring's opposite slot, at exactly π).
pub const TABLE_PI: f64 = std::f32::consts::PI as f64;

/// One operation on the tape: its allowance, its parents' range in `Tape::parents`, and a
/// cheap upper bound of its first-order bound (allowance + Σ |∂/∂parent| · the parent's, in
/// forward order, without cancellation) that spares [`product_remainder`] a reverse sweep
/// wherever a factor is clearly trusted.
struct Node {
    allowance: f64,
    parents_end: u32,
    forward: f64,
}

/// The operations of one evaluation, in order (a parent always precedes its child).
#[derive(Default)]
struct Tape {
    nodes: Vec<Node>,
    /// (parent, ∂child/∂parent), node after node.
    parents: Vec<(u32, f64)>,
    ambiguous: bool,
}

thread_local! {
    static TAPE: RefCell<Tape> = RefCell::new(Tape::default());
}

/// A value on the tape.
#[derive(Clone, Copy, Debug)]
pub struct Lin {
    /// The value, evaluated in f64 from exact inputs.
    pub v: f64,
    id: u32,
}

/// Run `f` (a twin over [`Lin`]) on a fresh tape: its result, and whether some check of the
/// first-order analysis failed (module docs: a conforming GPU may then be anywhere).
pub fn record<T>(f: impl FnOnce() -> T) -> (T, bool) {
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        t.nodes.clear();
        t.parents.clear();
        t.ambiguous = false;
    });
    let result = f();
    (result, TAPE.with(|t| t.borrow().ambiguous))
}

/// The tape's length now: [`record_after`] continues from it.
pub fn mark() -> usize {
    TAPE.with(|t| t.borrow().nodes.len())
}

/// Run `f` on the tape cut back to `mark` (the values recorded before it stay valid): for
/// evaluating many samples on one face's recorded precompute. Whether a check failed is
/// reported for `f`'s operations only.
pub fn record_after<T>(mark: usize, f: impl FnOnce() -> T) -> (T, bool) {
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        let end = if mark == 0 {
            0
        } else {
            t.nodes[mark - 1].parents_end as usize
        };
        t.nodes.truncate(mark);
        t.parents.truncate(end);
        t.ambiguous = false;
    });
    let result = f();
    (result, TAPE.with(|t| t.borrow().ambiguous))
}

/// Σᵢ ‖gᵢ‖ aᵢ over the operations, gᵢ the gradient of Σ_k c_k y_k (one component per seed
/// group) with respect to a perturbation at i: one reverse sweep.
fn sweep<const K: usize>(seeds: &[(Lin, [f64; K])]) -> f64 {
    TAPE.with(|t| {
        let t = t.borrow();
        let Some(top) = seeds.iter().map(|(x, _)| x.id as usize).max() else {
            return 0.0;
        };
        let mut adjoint = vec![[0.0; K]; top + 1];
        for (x, c) in seeds {
            for k in 0..K {
                adjoint[x.id as usize][k] += c[k];
            }
        }
        let mut total = 0.0;
        for i in (0..=top).rev() {
            let g = adjoint[i];
            if g.iter().all(|&g| g == 0.0) {
                continue;
            }
            let norm = g.iter().map(|g| g * g).sum::<f64>().sqrt();
            total += norm * t.nodes[i].allowance;
            let start = if i == 0 {
                0
            } else {
                t.nodes[i - 1].parents_end as usize
            };
            for &(p, d) in &t.parents[start..t.nodes[i].parents_end as usize] {
                for k in 0..K {
                    adjoint[p as usize][k] += g[k] * d;
                }
            }
        }
        total
    })
}

/// The first-order bound Σᵢ |∂y/∂eᵢ| aᵢ of y (module docs).
pub fn first_order_bound(y: Lin) -> f64 {
    sweep(&[(y, [1.0])])
}

/// The first-order bound Σᵢ ‖(∂x/∂eᵢ, ∂y/∂eᵢ)‖ aᵢ of the point (x, y) (module docs).
pub fn first_order_bound2(x: Lin, y: Lin) -> f64 {
    sweep(&[(x, [1.0, 0.0]), (y, [0.0, 1.0])])
}

/// Mark the evaluation ambiguous.
fn set_ambiguous() {
    TAPE.with(|t| t.borrow_mut().ambiguous = true);
}

/// Check that x is trusted to first order as a divisor, root or log argument (module docs).
fn guard(x: Lin) {
    let bound = first_order_bound(x);
    if !(x.v.abs() > TRUST * bound) {
        set_ambiguous();
    }
}

impl Lin {
    /// An input the kernel receives as `given` (f32) where the exact value is `exact`.
    pub fn input(exact: f64, given: f32) -> Lin {
        push(exact, (exact - f64::from(given)).abs(), &[])
    }

    /// An exact input.
    pub fn exact(v: f64) -> Lin {
        push(v, 0.0, &[])
    }
}

/// Record an operation with value v, allowance a and parents (parent, ∂v/∂parent).
fn push(v: f64, allowance: f64, parents: &[(Lin, f64)]) -> Lin {
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        let allowance = if v.is_finite() {
            allowance
        } else {
            t.ambiguous = true;
            0.0
        };
        let mut forward = allowance;
        for &(p, d) in parents {
            t.parents.push((p.id, d));
            forward += d.abs() * t.nodes[p.id as usize].forward;
        }
        let parents_end = t.parents.len() as u32;
        t.nodes.push(Node {
            allowance,
            parents_end,
            forward,
        });
        Lin {
            v,
            id: (t.nodes.len() - 1) as u32,
        }
    })
}

/// The allowance of a result v rounded within k units u.
fn rounding(v: f64, k: f64) -> f64 {
    k * U * v.abs() + EPS64 * v.abs() + FLUSH
}

impl PartialEq for Lin {
    fn eq(&self, other: &Lin) -> bool {
        self.v == other.v
    }
}

impl PartialOrd for Lin {
    fn partial_cmp(&self, other: &Lin) -> Option<std::cmp::Ordering> {
        self.v.partial_cmp(&other.v)
    }
}

impl Add for Lin {
    type Output = Lin;
    fn add(self, b: Lin) -> Lin {
        let v = self.v + b.v;
        push(v, rounding(v, 1.0), &[(self, 1.0), (b, 1.0)])
    }
}

impl Sub for Lin {
    type Output = Lin;
    fn sub(self, b: Lin) -> Lin {
        let v = self.v - b.v;
        push(v, rounding(v, 1.0), &[(self, 1.0), (b, -1.0)])
    }
}

impl Neg for Lin {
    type Output = Lin;
    fn neg(self) -> Lin {
        push(-self.v, 0.0, &[(self, -1.0)])
    }
}

impl Mul for Lin {
    type Output = Lin;
    fn mul(self, b: Lin) -> Lin {
        let v = self.v * b.v;
        let allowance = rounding(v, 1.0) + product_remainder(self, b);
        push(v, allowance, &[(self, b.v), (b, self.v)])
    }
}

/// The neglected term of a product a·b, |δa δb|, where first order does not cover it: when
/// neither factor is trusted (|x| ≤ [`TRUST`] · bound(x) for both; else δa δb is at most
/// 2/[`TRUST`] of the first-order term |a| δb or |b| δa), it is added as an allowance of the
/// product, (2 bound(a)) (2 bound(b)) with each δ at most [`SECOND_ORDER`] times its first-order
/// bound. Found on a real mesh (issue #34): a 4-ring's curvature fit z = A x² + B xy + C y²
/// with B = 0 but barely determined (bound 4.1); B² has derivative 0 there, so first order saw
/// no effect of B on κ, and a GPU at the edge of the WGSL table moved κ 49–107 times that
/// bound.
fn product_remainder(a: Lin, b: Lin) -> f64 {
    let forward = |x: Lin| TAPE.with(|t| t.borrow().nodes[x.id as usize].forward);
    let trusted = |x: Lin, bound: f64| x.v.abs() > TRUST * bound;
    if trusted(a, forward(a)) || trusted(b, forward(b)) {
        return 0.0;
    }
    let (ba, bb) = (first_order_bound(a), first_order_bound(b));
    if trusted(a, ba) || trusted(b, bb) {
        return 0.0;
    }
    SECOND_ORDER * ba * SECOND_ORDER * bb
}

impl Div for Lin {
    type Output = Lin;
    fn div(self, b: Lin) -> Lin {
        guard(b);
        let q = self.v / b.v;
        if !(b.v.abs() >= FLUSH && b.v.abs() <= 2f64.powi(126)) {
            set_ambiguous();
        }
        push(q, rounding(q, 2.5), &[(self, 1.0 / b.v), (b, -q / b.v)])
    }
}

/// `log` (scale 1) or `log2` (scale log₂e) of `a` with value `v`.
fn log_lin(a: Lin, v: f64, scale: f64) -> Lin {
    guard(a);
    let allowance = if (0.5..=2.0).contains(&a.v) {
        2f64.powi(-21) + EPS64 * v.abs() + FLUSH
    } else {
        rounding(v, 3.0)
    };
    push(v, allowance, &[(a, scale / a.v)])
}

impl Real for Lin {
    /// The literal's exact value, its f32 rounding as the allowance.
    fn lit(c: f64) -> Lin {
        Lin::input(c, c as f32)
    }

    fn value(self) -> f64 {
        self.v
    }

    /// Near 0 the root is Hölder, not Lipschitz: where its argument is not trusted to first
    /// order (|a| ≤ TRUST · bound(a)) the result is a fresh value with the allowance
    /// √(2 · bound(a)) ≥ |√(a + e) − √a| for |e| ≤ 2 · bound(a), and no parents.
    fn sqrt(self) -> Lin {
        let root = self.v.sqrt();
        let bound = first_order_bound(self);
        if !(self.v.abs() > TRUST * bound) {
            if self.v < 0.0 && self.v < -SECOND_ORDER * bound {
                set_ambiguous();
            }
            let allowance = (SECOND_ORDER * bound).sqrt() + rounding(root, 4.5);
            return push(root.max(0.0), allowance, &[]);
        }
        push(root, rounding(root, 4.5), &[(self, 0.5 / root)])
    }

    fn inverse_sqrt(self) -> Lin {
        guard(self);
        let v = 1.0 / self.v.sqrt();
        push(v, rounding(v, 2.0), &[(self, -0.5 * v / self.v)])
    }

    fn exp(self) -> Lin {
        let v = self.v.exp();
        push(v, rounding(v, 3.0 + 2.0 * self.v.abs()), &[(self, v)])
    }

    fn exp2(self) -> Lin {
        let v = self.v.exp2();
        push(
            v,
            rounding(v, 3.0 + 2.0 * self.v.abs()),
            &[(self, v * std::f64::consts::LN_2)],
        )
    }

    fn log(self) -> Lin {
        log_lin(self, self.v.ln(), 1.0)
    }

    fn log2(self) -> Lin {
        log_lin(self, self.v.log2(), std::f64::consts::LOG2_E)
    }

    fn atan2(self, x: Lin) -> Lin {
        let y = self;
        let v = y.v.atan2(x.v);
        let rho2 = x.v * x.v + y.v * y.v;
        // Trusted away from the origin and from the branch cut (x < 0, y = 0).
        let near = TRUST * (first_order_bound(x) + first_order_bound(y));
        if !(rho2.sqrt() > near) || (x.v < 0.0 && !(y.v.abs() > near)) {
            set_ambiguous();
        }
        if !(x.v.abs() >= FLUSH && y.v.abs() >= FLUSH) {
            set_ambiguous();
        }
        push(v, rounding(v, 4096.0), &[(y, x.v / rho2), (x, -y.v / rho2)])
    }

    fn cos(self) -> Lin {
        if self.v.abs() > TABLE_PI {
            set_ambiguous();
        }
        let v = self.v.cos();
        push(v, 2f64.powi(-11), &[(self, -self.v.sin())])
    }

    fn sin(self) -> Lin {
        if self.v.abs() > TABLE_PI {
            set_ambiguous();
        }
        let v = self.v.sin();
        push(v, 2f64.powi(-11), &[(self, self.v.cos())])
    }

    fn abs(self) -> Lin {
        let sign = if self.v < 0.0 { -1.0 } else { 1.0 };
        push(self.v.abs(), 0.0, &[(self, sign)])
    }

    fn min(self, y: Lin) -> Lin {
        if self.v <= y.v {
            self
        } else {
            y
        }
    }

    fn max(self, y: Lin) -> Lin {
        if self.v >= y.v {
            self
        } else {
            y
        }
    }

    /// floor is exact and flat; an argument within its bound of an integer may land on
    /// either side.
    fn floor(self) -> Lin {
        let v = self.v.floor();
        let bound = first_order_bound(self);
        if (self.v + TRUST * bound).floor() != (self.v - TRUST * bound).floor() {
            set_ambiguous();
        }
        push(v, 0.0, &[])
    }

    /// Σ tᵢ in any order and with any fusion: each of the n − 1 additions rounds a partial sum
    /// of magnitude at most Σ|tᵢ|.
    fn sum(terms: &[Lin]) -> Lin {
        let v: f64 = terms.iter().map(|t| t.v).sum();
        let magnitude: f64 = terms.iter().map(|t| t.v.abs()).sum();
        let steps = terms.len().saturating_sub(1) as f64;
        let parents: Vec<(Lin, f64)> = terms.iter().map(|&t| (t, 1.0)).collect();
        push(
            v,
            steps * (U * magnitude + EPS64 * magnitude + FLUSH),
            &parents,
        )
    }

    fn decides_lt(self, y: Lin) -> bool {
        let bound = sweep(&[(self, [1.0]), (y, [-1.0])]);
        if !((self.v - y.v).abs() > TRUST * bound) {
            set_ambiguous();
        }
        self.v < y.v
    }
}

#[cfg(test)]
mod tests {
    use super::super::model::{with_model, Model, F};
    use super::*;
    use crate::twin::test_support::{random_points, rational, root_of_length};

    /// f(x) over F under every checked model stays within SECOND_ORDER × the first-order
    /// bound of f(x) over Lin.
    fn holds(x: &[f64], f: impl Fn(&[F]) -> F, g: impl Fn(&[Lin]) -> Lin) {
        let given: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let ((v, bound), ambiguous) = record(|| {
            let lins: Vec<Lin> = x
                .iter()
                .zip(&given)
                .map(|(&v, &g)| Lin::input(v, g))
                .collect();
            let y = g(&lins);
            (y.v, first_order_bound(y))
        });
        assert!(!ambiguous);
        for model in Model::CHECKED {
            let fs: Vec<F> = given.iter().map(|&v| F::new(v)).collect();
            let got = with_model(model, || f(&fs)).f64();
            assert!(
                (got - v).abs() <= SECOND_ORDER * bound,
                "{model:?}: {got} vs {v} ± {bound}"
            );
        }
    }

    #[test]
    fn every_model_stays_inside_the_first_order_bound() {
        for x in random_points(7, 300) {
            holds(&x, rational, rational);
            holds(&x, root_of_length, root_of_length);
        }
    }

    /// The projective gauge: (λa)/(λb) is a/b whatever λ's rounding, so the bound of the
    /// quotient does not grow with λ's allowance, while a ball's radius does.
    #[test]
    fn a_common_scale_costs_nothing() {
        let ((q, bound), _) = record(|| {
            let lambda = Lin::input(1.0, 1.0 + 1e-3);
            let a = Lin::exact(3.0) * lambda;
            let b = Lin::exact(2.0) * lambda;
            let q = a / b;
            (q.v, first_order_bound(q))
        });
        assert!((q - 1.5).abs() < 1e-15);
        assert!(bound < 10.0 * U, "{bound}");
    }

    /// A divisor within its bound of zero, and a branch within its bound, are not trusted.
    #[test]
    fn a_product_of_two_untrusted_factors_carries_their_bounds_product() {
        // B = 0 ± 0.5: B² has derivative 0 at 0, but moves by up to (2 · 0.5)².
        let (bound, _) = record(|| {
            let b = Lin::input(0.0, 0.5);
            first_order_bound(b * b)
        });
        assert!(bound >= 1.0, "{bound}");
        // One trusted factor (3 ± 0.01): first order covers the product, nothing is added.
        let (bound, _) = record(|| {
            let (a, b) = (Lin::input(3.0, 3.01), Lin::input(0.0, 0.5));
            first_order_bound(a * b)
        });
        assert!((bound - 1.5).abs() < 1e-4, "{bound}");
    }

    #[test]
    fn a_pole_or_a_close_branch_is_ambiguous() {
        let (_, ambiguous) = record(|| Lin::exact(1.0) / Lin::input(1e-9, 0.0));
        assert!(ambiguous);
        let (_, ambiguous) = record(|| Lin::input(1e-8, 0.0).decides_lt(Lin::exact(0.0)));
        assert!(ambiguous);
        let (_, ambiguous) = record(|| Lin::exact(1.0).decides_lt(Lin::exact(0.0)));
        assert!(!ambiguous);
        let (_, ambiguous) = record(|| Lin::exact(1.0) / Lin::exact(3.0));
        assert!(!ambiguous);
    }

    /// A recorded prefix is reused: cutting back to a mark keeps its values and bounds.
    #[test]
    fn record_after_reuses_the_prefix() {
        let ((a, m), _) = record(|| {
            let a = Lin::input(0.1, 0.1f32) * Lin::exact(3.0);
            (a, mark())
        });
        let (b1, _) = record_after(m, || first_order_bound(a + Lin::exact(1.0)));
        let (b2, _) = record_after(m, || first_order_bound(a + Lin::exact(1.0)));
        assert_eq!(b1, b2);
        assert!(b1 > 3.0 * (0.1 - f64::from(0.1f32)).abs());
    }
}
