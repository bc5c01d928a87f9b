//! f32 arithmetic as a conforming WGSL implementation may do it: the scalar [`F`] and the
//! [`Model`] under which it is evaluated.
//!
//! # What WGSL promises (WGSL §15.7 "Floating Point Evaluation", the accuracy table)
//! - `+ − ×` are "correctly rounded", which WGSL defines as rounded **up or down**: no rounding
//!   mode is specified, so one operation may err by a whole ULP (|δ| < 2⁻²³), not half of one.
//! - `x / y`: 2.5 ULP (|y| in [2⁻¹²⁶, 2¹²⁶]); `inverseSqrt`: 2 ULP; `sqrt` is inherited from
//!   `1.0 / inverseSqrt(x)`; `exp`, `exp2`: 3 + 2|x| ULP; `log`, `log2`: absolute 2⁻²¹ on
//!   [0.5, 2], 3 ULP outside; `atan2`: 4096 ULP (|x| in [2⁻¹²⁶, 2¹²⁶], y finite and normal);
//!   `cos`, `sin`: absolute 2⁻¹¹ on [−π, π]; `cosh`, `sinh` inherited from
//!   `(exp(x) ± exp(−x)) · 0.5`; `pow` from `exp2(y · log2(x))`; `length` from
//!   `sqrt(dot(x, x))`; `dot` from the sum of the products; `abs`, `min`, `max`, `floor`,
//!   `select`, `ldexp`, `frexp`: exact.
//! - An implementation may **fuse** (a·b + c in one rounding) and **reassociate**
//!   ((a + b) + c as a + (b + c)), and may flush subnormal inputs and outputs to zero.
//!
//! # The models
//! | model | + − × | a·b + c | multi-term sums | builtins | subnormals |
//! |---|---|---|---|---|---|
//! | [`Model::Nearest`] | to nearest | two roundings | left to right | correctly rounded | kept |
//! | [`Model::Fma`] | to nearest | fused | left to right | correctly rounded | kept |
//! | [`Model::Reordered`] | to nearest | two roundings | right to left | correctly rounded | kept |
//! | [`Model::EdgeOfSpec`] | up or down by seed | two roundings | left to right | pushed to the table's limit, sign by seed | flushed |
//! | [`Model::Worst`] | up or down by seed | fused | right to left | pushed to the table's limit | flushed |
//!
//! Lavapipe and llvmpipe (LLVM on a CPU) behave like `Nearest`; a GPU compiler may behave like
//! any of the others, and a bound that holds only for `Nearest` rejects correct kernels there.
//!
//! # How a model is chosen
//! [`with_model`] sets the model of the current thread while a closure runs; every operation on
//! [`F`] reads it. The twins run one element after another on one thread (they are checks,
//! not a fast path). Under a seeded model the rounding direction and the sign of a builtin's
//! error are a hash of the seed, the operation and its operands' bits: the same inputs give
//! the same result in any order and on any thread.
//!
//! # Exactness of the simulation
//! Each operation's exact result is formed in f64 (a product of two f32 is exact there; a sum
//! is carried as an f64 and its rounding error, by TwoSum, so that a tie or a directed rounding
//! is decided on the exact value) and then rounded to f32 as the model says. Division and the
//! builtins start from the f64 result (error ≤ 2⁻⁵³ relative, 2³⁰ times below an f32 ULP).

use std::cell::Cell;
use std::ops::{Add, Div, Mul, Neg, Sub};

use serde::Serialize;

use super::real::Real;

/// How a conforming WGSL implementation evaluates f32 expressions (module docs: the table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Model {
    /// Every operation correctly rounded to nearest (IEEE's default; lavapipe, llvmpipe).
    Nearest,
    /// Every a·b + c and a·b − c contracted into one fused multiply-add.
    Fma,
    /// Multi-term sums (`Real::sum`, hence `dot` and `length`) evaluated right to left.
    Reordered,
    /// Each `+ − ×` rounded up or down as the seed says, each builtin at the limit of the WGSL
    /// accuracy table with the sign the seed says, subnormals flushed to zero.
    EdgeOfSpec(u64),
    /// `EdgeOfSpec` with fused multiply-adds and right-to-left sums.
    Worst(u64),
}

impl Model {
    /// The models the checks run: the three deterministic ones and two seeds of each edge model.
    pub const CHECKED: [Model; 7] = [
        Model::Nearest,
        Model::Fma,
        Model::Reordered,
        Model::EdgeOfSpec(1),
        Model::EdgeOfSpec(2),
        Model::Worst(1),
        Model::Worst(2),
    ];

    /// A short name for tables: `nearest`, `fma`, `reordered`, `edge-of-spec#1`, `worst#1`.
    pub fn name(self) -> String {
        match self {
            Model::Nearest => "nearest".into(),
            Model::Fma => "fma".into(),
            Model::Reordered => "reordered".into(),
            Model::EdgeOfSpec(s) => format!("edge-of-spec#{s}"),
            Model::Worst(s) => format!("worst#{s}"),
        }
    }

    fn contracts(self) -> bool {
        matches!(self, Model::Fma | Model::Worst(_))
    }

    fn reorders(self) -> bool {
        matches!(self, Model::Reordered | Model::Worst(_))
    }

    /// The seed of the directed roundings and builtin errors, for the edge models.
    fn seed(self) -> Option<u64> {
        match self {
            Model::EdgeOfSpec(s) | Model::Worst(s) => Some(s),
            _ => None,
        }
    }
}

thread_local! {
    static MODEL: Cell<Model> = const { Cell::new(Model::Nearest) };
}

/// Run `f` with `model` as this thread's arithmetic model (restored afterwards, also when `f`
/// panics).
pub fn with_model<T>(model: Model, f: impl FnOnce() -> T) -> T {
    struct Restore(Model);
    impl Drop for Restore {
        fn drop(&mut self) {
            MODEL.with(|m| m.set(self.0));
        }
    }
    let _restore = Restore(MODEL.with(|m| m.replace(model)));
    f()
}

/// This thread's model.
pub fn model() -> Model {
    MODEL.with(|m| m.get())
}

// ---------------------------------------------------------------------------------------------
// Rounding

/// Operation codes mixed into the seeded choices, so that different operations on the same
/// operands choose independently.
#[derive(Clone, Copy)]
enum Op {
    Add = 1,
    Mul,
    Fma,
    Div,
    InverseSqrt,
    Exp,
    Log,
    Atan2,
    Cos,
    Sin,
    Exp2,
    Log2,
}

/// SplitMix64's finaliser: a well-mixed hash of `x`.
fn mix(mut x: u64) -> u64 {
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The seeded choice for an operation on operands with these bits: `true` or `false`, evenly.
fn choice(seed: u64, op: Op, operands: &[f32]) -> bool {
    let mut h = mix(seed ^ ((op as u64) << 56));
    for x in operands {
        h = mix(h ^ u64::from(x.to_bits()));
    }
    h & 1 == 1
}

/// Whether `x` is an f32 subnormal (non-zero, below the smallest normal).
fn is_subnormal(x: f32) -> bool {
    x != 0.0 && x.abs() < f32::MIN_POSITIVE
}

/// Subnormals flushed to zero (sign kept) under the edge models.
fn flush(x: f32, model: Model) -> f32 {
    if model.seed().is_some() && is_subnormal(x) {
        0.0f32.copysign(x)
    } else {
        x
    }
}

/// The exact value `s + e` (e the rounding error of the f64 `s`, |e| ≤ ½ ulp₆₄(s)) rounded to
/// f32 as `model` says: to nearest (ties to even, decided on the exact value), or up or down
/// by the seeded choice for `op` on `operands`. Overflow gives ±∞ to nearest and ±MAX or ±∞
/// under a directed choice, as WGSL allows.
fn round(s: f64, e: f64, model: Model, op: Op, operands: &[f32]) -> f32 {
    let n = s as f32;
    if !s.is_finite() {
        return n;
    }
    // The two f32 neighbours of the exact value (equal when it is an f32).
    let (lo, hi) = if f64::from(n) == s {
        match e.partial_cmp(&0.0) {
            Some(std::cmp::Ordering::Greater) => (n, n.next_up()),
            Some(std::cmp::Ordering::Less) => (n.next_down(), n),
            _ => (n, n),
        }
    } else if f64::from(n) < s {
        (n, n.next_up())
    } else {
        (n.next_down(), n)
    };
    let r = if lo == hi {
        lo
    } else {
        match model.seed() {
            Some(seed) => {
                if choice(seed, op, operands) {
                    hi
                } else {
                    lo
                }
            }
            None => {
                // To nearest on the exact value s + e; a tie (only possible when s is the
                // midpoint and e = 0) to the even neighbour.
                let (dl, dh) = ((s - f64::from(lo)) + e, (f64::from(hi) - s) - e);
                if dl < dh || (dl == dh && lo.to_bits() & 1 == 0) {
                    lo
                } else {
                    hi
                }
            }
        }
    };
    flush(r, model)
}

/// TwoSum (Knuth): s = fl(a + b) and the exact error e = a + b − s.
fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    let e = (a - (s - bb)) + (b - bb);
    (s, if e.is_finite() { e } else { 0.0 })
}

/// WGSL's ULP of x: the smallest gap between two f32 values a ≤ x ≤ b (WGSL §15.7.2), for a
/// finite x; f32::MAX's gap beyond the range.
pub fn ulp(x: f64) -> f64 {
    let a = x.abs();
    if a >= f64::from(f32::MAX) {
        return f64::from(f32::MAX) - f64::from(f32::MAX.next_down());
    }
    let n = a as f32;
    let below = if f64::from(n) > a { n.next_down() } else { n };
    if f64::from(below) == a {
        // x is an f32: the smaller of the gaps on either side.
        let up = f64::from(below.next_up()) - a;
        let down = if below > 0.0 {
            a - f64::from(below.next_down())
        } else {
            up
        };
        up.min(down)
    } else {
        f64::from(below.next_up()) - f64::from(below)
    }
}

/// A builtin's result: `exact` correctly rounded, or under an edge model pushed away from it by
/// `error` (an absolute error) with the seeded sign and rounded back towards `exact`, so that
/// the result is an f32 within `error` of `exact` — as far from it as the table allows.
fn builtin(exact: f64, error: f64, op: Op, operands: &[f32]) -> f32 {
    let model = model();
    let Some(seed) = model.seed() else {
        return flush(exact as f32, model);
    };
    if !exact.is_finite() || !error.is_finite() {
        return exact as f32;
    }
    let up = choice(seed, op, operands);
    let target = if up { exact + error } else { exact - error };
    let t = target as f32;
    // Round the target towards `exact`, so the result stays within the allowed error.
    let r = if up && f64::from(t) > target {
        t.next_down()
    } else if !up && f64::from(t) < target {
        t.next_up()
    } else {
        t
    };
    flush(r, model)
}

// ---------------------------------------------------------------------------------------------
// The scalar

/// An f32 value of a twin, with (under the [`Model::Fma`] and [`Model::Worst`] models) the
/// exact product it was rounded from, which a following `+` or `−` may fuse with.
#[derive(Clone, Copy, Debug)]
pub struct F {
    v: f32,
    /// The exact product a·b (in f64, where it is exact) when this value is `a * b` under a
    /// contracting model.
    product: Option<f64>,
}

impl F {
    /// An f32 value.
    pub const fn new(v: f32) -> F {
        F { v, product: None }
    }

    /// The value.
    pub fn get(self) -> f32 {
        self.v
    }

    /// The value as f64 (exact).
    pub fn f64(self) -> f64 {
        f64::from(self.v)
    }
}

impl From<f32> for F {
    fn from(v: f32) -> F {
        F::new(v)
    }
}

impl PartialEq for F {
    fn eq(&self, other: &F) -> bool {
        self.v == other.v
    }
}

impl PartialOrd for F {
    fn partial_cmp(&self, other: &F) -> Option<std::cmp::Ordering> {
        self.v.partial_cmp(&other.v)
    }
}

/// a + b, fusing a pending product of either operand under a contracting model (the left one
/// when both are products: a compiler fuses one of them).
fn add(a: F, b: F) -> F {
    let m = model();
    if m.contracts() {
        let fused = match (a.product, b.product) {
            (Some(p), _) => Some((p, b.v)),
            (None, Some(p)) => Some((p, a.v)),
            _ => None,
        };
        if let Some((p, c)) = fused {
            let (s, e) = two_sum(p, f64::from(c));
            return F::new(round(s, e, m, Op::Fma, &[a.v, b.v]));
        }
    }
    let (s, e) = two_sum(a.f64(), b.f64());
    F::new(round(s, e, m, Op::Add, &[a.v, b.v]))
}

impl Add for F {
    type Output = F;
    fn add(self, b: F) -> F {
        add(self, b)
    }
}

impl Sub for F {
    type Output = F;
    fn sub(self, b: F) -> F {
        add(self, -b)
    }
}

impl Neg for F {
    type Output = F;
    /// Exact; a pending product stays pending with its sign changed (−(a·b) + c fuses too).
    fn neg(self) -> F {
        F {
            v: -self.v,
            product: self.product.map(|p| -p),
        }
    }
}

impl Mul for F {
    type Output = F;
    fn mul(self, b: F) -> F {
        let m = model();
        let p = self.f64() * b.f64();
        let v = round(p, 0.0, m, Op::Mul, &[self.v, b.v]);
        F {
            v,
            product: m.contracts().then_some(p),
        }
    }
}

impl Div for F {
    type Output = F;
    /// x / y: 2.5 ULP (for |y| in [2⁻¹²⁶, 2¹²⁶]; outside that range the table promises nothing
    /// and the model divides correctly).
    fn div(self, y: F) -> F {
        let q = self.f64() / y.f64();
        let error = if in_table_range(y.f64()) {
            2.5 * ulp(q)
        } else {
            0.0
        };
        F::new(builtin(q, error, Op::Div, &[self.v, y.v]))
    }
}

/// The sum left to right, or right to left under a reordering model.
fn sum(terms: &[F]) -> F {
    let Some((&first, rest)) = terms.split_first() else {
        return F::new(0.0);
    };
    if model().reorders() {
        let (&last, init) = terms.split_last().unwrap_or((&first, &[]));
        init.iter().rev().fold(last, |acc, &t| t + acc)
    } else {
        rest.iter().fold(first, |acc, &t| acc + t)
    }
}

/// Whether the table's range for `x / y` and `atan2(y, x)` holds: |x| in [2⁻¹²⁶, 2¹²⁶].
fn in_table_range(x: f64) -> bool {
    (f64::from(f32::MIN_POSITIVE)..=2f64.powi(126)).contains(&x.abs())
}

/// The error `log` and `log2` may have at x: absolute 2⁻²¹ on [0.5, 2], else 3 ULP of r.
fn log_error(x: f64, r: f64) -> f64 {
    if (0.5..=2.0).contains(&x) {
        2f64.powi(-21)
    } else {
        3.0 * ulp(r)
    }
}

impl Real for F {
    fn lit(c: f64) -> F {
        F::new(c as f32)
    }

    fn value(self) -> f64 {
        self.f64()
    }

    /// Correctly rounded under the deterministic models; at the edge, `1.0 / inverseSqrt(x)`
    /// with both at their limits (≈ 4.5 ULP).
    fn sqrt(self) -> F {
        if model().seed().is_none() {
            return F::new(builtin(self.f64().sqrt(), 0.0, Op::InverseSqrt, &[self.v]));
        }
        F::new(1.0) / self.inverse_sqrt()
    }

    fn inverse_sqrt(self) -> F {
        let r = 1.0 / self.f64().sqrt();
        F::new(builtin(r, 2.0 * ulp(r), Op::InverseSqrt, &[self.v]))
    }

    fn exp(self) -> F {
        let r = self.f64().exp();
        let error = (3.0 + 2.0 * self.f64().abs()) * ulp(r);
        F::new(builtin(r, error, Op::Exp, &[self.v]))
    }

    fn exp2(self) -> F {
        let r = self.f64().exp2();
        let error = (3.0 + 2.0 * self.f64().abs()) * ulp(r);
        F::new(builtin(r, error, Op::Exp2, &[self.v]))
    }

    fn log(self) -> F {
        let r = self.f64().ln();
        F::new(builtin(r, log_error(self.f64(), r), Op::Log, &[self.v]))
    }

    fn log2(self) -> F {
        let r = self.f64().log2();
        F::new(builtin(r, log_error(self.f64(), r), Op::Log2, &[self.v]))
    }

    /// Outside the table's range (y = 0, x = 0 or tiny) the table promises nothing; the model
    /// returns the correctly rounded angle there.
    fn atan2(self, x: F) -> F {
        let r = self.f64().atan2(x.f64());
        let error = if in_table_range(x.f64()) && self.v.is_normal() {
            4096.0 * ulp(r)
        } else {
            0.0
        };
        F::new(builtin(r, error, Op::Atan2, &[self.v, x.v]))
    }

    /// The table's 2⁻¹¹ holds on [−π, π]; the model keeps it beyond.
    fn cos(self) -> F {
        F::new(builtin(
            self.f64().cos(),
            2f64.powi(-11),
            Op::Cos,
            &[self.v],
        ))
    }

    fn sin(self) -> F {
        F::new(builtin(
            self.f64().sin(),
            2f64.powi(-11),
            Op::Sin,
            &[self.v],
        ))
    }

    fn abs(self) -> F {
        F::new(self.v.abs())
    }

    fn min(self, y: F) -> F {
        F::new(self.v.min(y.v))
    }

    fn max(self, y: F) -> F {
        F::new(self.v.max(y.v))
    }

    fn floor(self) -> F {
        F::new(self.v.floor())
    }

    fn sum(terms: &[F]) -> F {
        sum(terms)
    }

    fn decides_lt(self, y: F) -> bool {
        self.v < y.v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::twin::real::{atan2, exp, log, sqrt, sum};

    fn f(x: f32) -> F {
        F::new(x)
    }

    #[test]
    fn nearest_is_ieee_round_to_nearest() {
        let a = f(1.0 / 3.0);
        let b = f(0.1);
        assert_eq!((a + b).get(), 1.0f32 / 3.0 + 0.1);
        assert_eq!((a * b).get(), (1.0f32 / 3.0) * 0.1);
        assert_eq!((a - b).get(), 1.0f32 / 3.0 - 0.1);
        assert_eq!((a / b).get(), (1.0f32 / 3.0) / 0.1);
        assert_eq!(sqrt(b).get(), 0.1f32.sqrt());
    }

    #[test]
    fn fma_contracts_one_product_into_the_add() {
        // a·b − c where a·b rounds: fused, the exact residual survives.
        let a = f(1.0 + f32::EPSILON);
        let fused = with_model(Model::Fma, || a * a - f(1.0 + 2.0 * f32::EPSILON));
        assert_eq!(fused.get(), f32::EPSILON * f32::EPSILON);
        let plain = with_model(Model::Nearest, || a * a - f(1.0 + 2.0 * f32::EPSILON));
        assert_eq!(plain.get(), 0.0);
        // A product used on its own is the rounded one.
        assert_eq!(with_model(Model::Fma, || a * a).get(), (a.get() * a.get()));
    }

    #[test]
    fn reordered_sums_run_right_to_left() {
        let t = [f(1.0), f(f32::EPSILON / 2.0), f(f32::EPSILON / 2.0)];
        assert_eq!(with_model(Model::Nearest, || sum(&t)).get(), 1.0);
        assert_eq!(
            with_model(Model::Reordered, || sum(&t)).get(),
            1.0 + f32::EPSILON
        );
    }

    #[test]
    fn directed_rounding_stays_within_one_ulp_and_uses_both_directions() {
        let (mut up, mut down) = (0, 0);
        for k in 1..200u32 {
            let a = f(1.0 / k as f32);
            let b = f(0.3 + k as f32);
            let exact = a.f64() * b.f64();
            let r = with_model(Model::EdgeOfSpec(7), || a * b).get();
            assert!((f64::from(r) - exact).abs() < ulp(exact), "{k}");
            if f64::from(r) > exact {
                up += 1;
            } else if f64::from(r) < exact {
                down += 1;
            }
        }
        assert!(up > 50 && down > 50, "{up} up, {down} down");
    }

    #[test]
    fn builtins_at_the_edge_reach_their_limit_and_not_beyond() {
        for k in 1..100u32 {
            let x = f(0.37 * k as f32);
            for seed in [1, 2] {
                let m = Model::EdgeOfSpec(seed);
                let e = with_model(m, || exp(x)).f64();
                let exact = x.f64().exp();
                let allowed = (3.0 + 2.0 * x.f64()) * ulp(exact);
                assert!((e - exact).abs() <= allowed, "exp {k}");
                // Rounding the target back towards the exact value loses at most one gap, twice
                // ulp(exact) when the target crossed into the next binade.
                assert!(
                    (e - exact).abs() >= allowed - 2.0 * ulp(exact),
                    "exp {k} at the edge"
                );
                let a = with_model(m, || atan2(x, f(1.5))).f64();
                let exact = x.f64().atan2(1.5);
                assert!((a - exact).abs() <= 4096.0 * ulp(exact), "atan2 {k}");
                assert!(
                    (a - exact).abs() >= 4094.0 * ulp(exact),
                    "atan2 {k} at the edge"
                );
                let l = with_model(m, || log(f(0.5 + 0.015 * k as f32))).f64();
                let exact = (0.5 + 0.015 * k as f32) as f64;
                assert!((l - exact.ln()).abs() <= 2f64.powi(-21), "log {k}");
            }
        }
    }

    #[test]
    fn sqrt_at_the_edge_is_inherited_from_inverse_sqrt() {
        let u = 2f64.powi(-23);
        let mut worst: f64 = 0.0;
        for k in 1..500u32 {
            let x = f(0.01 + k as f32 * 0.731);
            let exact = x.f64().sqrt();
            let r = with_model(Model::EdgeOfSpec(3), || sqrt(x)).f64();
            worst = worst.max((r - exact).abs() / exact / u);
        }
        // 2 ULP of 1/√x, then 2.5 ULP of the division: a relative error of at most
        // (2 + 2.5)·2⁻²³ (an ULP is at most 2⁻²³ of the value), and well over one rounding.
        assert!(worst > 1.0 && worst <= 4.5 + 1e-6, "{worst}");
    }

    #[test]
    fn edge_models_flush_subnormals() {
        let tiny = f(f32::MIN_POSITIVE);
        let half = f(0.5);
        assert!(is_subnormal(
            with_model(Model::Nearest, || tiny * half).get()
        ));
        assert_eq!(with_model(Model::EdgeOfSpec(1), || tiny * half).get(), 0.0);
    }

    #[test]
    fn wgsl_ulp_is_the_smaller_gap_at_a_power_of_two() {
        assert_eq!(ulp(1.0), f64::from(f32::EPSILON) / 2.0);
        assert_eq!(ulp(1.5), f64::from(f32::EPSILON));
        assert_eq!(ulp(1.0 + 1e-9), f64::from(f32::EPSILON));
    }
}
