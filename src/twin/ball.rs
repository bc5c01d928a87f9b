//! [`Ball`]: a twin evaluated in f64 with, beside each value, a radius that bounds how far any
//! conforming f32 evaluation of the same WGSL expression can be from it. Running a twin over
//! `Ball` derives its bound, per element, from the WGSL accuracy table and the magnitudes at
//! hand: no constant, nothing tuned on one driver.
//!
//! # The rules (x̂ is any conforming f32 result, x the exact value, r its radius: |x̂ − x| ≤ r)
//! With u = 2⁻²³ (WGSL's "correctly rounded" is up *or* down: one ULP, |δ| < 2⁻²³), and each
//! result's own rounding `ρ(v, p, k) = p + k·u·(|v| + p) + t`, where p is the propagated part,
//! k the table's ULPs and t = 2⁻¹²⁶ + 2⁻⁵²|v| (a subnormal flushed to zero; the f64
//! evaluation of v itself):
//!
//! | operation | propagated p | k |
//! |---|---|---|
//! | a ± b | r_a + r_b | 1 |
//! | a · b | \|a\| r_b + \|b\| r_a + r_a r_b | 1 |
//! | a / b | (r_a + \|a/b\| r_b) / (\|b\| − r_b) | 2.5 (∞ unless \|b\| − r_b ≥ 2⁻¹²⁶) |
//! | Σ tᵢ (n terms, any order, any fusion) | Σ r_i | (n − 1), on Σ\|tᵢ\| + p |
//! | √a | min(√r_a, r_a/√a) | 4.5 (1/inverseSqrt: 2 + 2.5) |
//! | 1/√a | r_a / (2 (a − r_a)^{3/2}) | 2 |
//! | exp a, exp2 a | e^a (e^{r_a} − 1) (base 2: 2^a (2^{r_a} − 1)) | 3 + 2(\|a\| + r_a) |
//! | log a | −ln(1 − r_a/a) | absolute 2⁻²¹ where a ± r_a stays in [0.5, 2], else 3 |
//! | atan2(y, x) | (\|x\| r_y + \|y\| r_x + 2 r_x r_y) / (ρ_min)² | 4096 |
//! | cos a, sin a | r_a | absolute 2⁻¹¹ (∞ outside [−π, π]) |
//! | abs, min, max | the largest r | exact |
//!
//! A fused multiply-add skips a rounding and is at least as accurate (WGSL allows fusion only
//! then); a reordered sum is covered by the order-free sum rule. Where the table promises
//! nothing (a divisor or `atan2`'s x below 2⁻¹²⁶, `atan2` with y not normal, a ball around a
//! branch cut) the radius is ∞: the bound says the spec gives no bound there.
//!
//! A branch between formulas whose values differ ([`Real::decides_lt`]) taken with the two
//! sides closer than their radii marks the evaluation ambiguous ([`evaluate`]): a conforming
//! GPU may take the other branch, and no bound follows from the table.

// `!(x > y)` is meant throughout: a NaN must fail each check, as it would not with `x <= y`.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::cell::Cell;
use std::ops::{Add, Div, Mul, Neg, Sub};

use super::real::Real;

/// WGSL's rounding of `+ − ×`: up or down, |δ| < 2⁻²³.
pub const U: f64 = 1.0 / 8_388_608.0;
/// The smallest normal f32, 2⁻¹²⁶: what flushing a subnormal result to zero may lose.
const FLUSH: f64 = 1.175_494_350_822_287_5e-38;
/// f64's ε, 2⁻⁵²: the f64 evaluation of each value.
const EPS64: f64 = f64::EPSILON;

thread_local! {
    static AMBIGUOUS: Cell<bool> = const { Cell::new(false) };
}

/// Run `f` (a twin over [`Ball`]) and say whether a branch it took was ambiguous
/// ([`Real::decides_lt`]): its result and `true` when some conforming GPU could have taken
/// another branch.
pub fn evaluate<T>(f: impl FnOnce() -> T) -> (T, bool) {
    let previous = AMBIGUOUS.with(|a| a.replace(false));
    let result = f();
    let ambiguous = AMBIGUOUS.with(|a| a.replace(previous));
    (result, ambiguous)
}

/// A value and the radius of the ball that holds every conforming f32 evaluation of it.
#[derive(Clone, Copy, Debug)]
pub struct Ball {
    /// The value, evaluated in f64 from exact inputs.
    pub v: f64,
    /// The bound on |x̂ − v| for any conforming f32 evaluation x̂ (∞ where the spec gives
    /// none).
    pub r: f64,
}

impl Ball {
    /// An input the kernel receives as `given` (f32) where the exact value is `exact`: its
    /// radius is the rounding |exact − given|.
    pub fn input(exact: f64, given: f32) -> Ball {
        Ball::with(exact, (exact - f64::from(given)).abs())
    }

    /// An exact value (an input the kernel receives without rounding).
    pub fn exact(v: f64) -> Ball {
        Ball { v, r: 0.0 }
    }

    /// v with radius r (∞ when either is not finite).
    fn with(v: f64, r: f64) -> Ball {
        let r = if r.is_finite() && v.is_finite() {
            r
        } else {
            f64::INFINITY
        };
        Ball { v, r }
    }

    /// The result v of an operation whose propagated error is p, rounded within k units u.
    fn rounded(v: f64, p: f64, k: f64) -> Ball {
        Ball::with(v, p + k * U * (v.abs() + p) + EPS64 * v.abs() + FLUSH)
    }

    /// A builtin's result v with propagated error p and an absolute table error `table`.
    fn absolute(v: f64, p: f64, table: f64) -> Ball {
        Ball::with(v, p + table + EPS64 * v.abs() + FLUSH)
    }
}

impl PartialEq for Ball {
    fn eq(&self, other: &Ball) -> bool {
        self.v == other.v
    }
}

impl PartialOrd for Ball {
    fn partial_cmp(&self, other: &Ball) -> Option<std::cmp::Ordering> {
        self.v.partial_cmp(&other.v)
    }
}

impl Add for Ball {
    type Output = Ball;
    fn add(self, b: Ball) -> Ball {
        Ball::rounded(self.v + b.v, self.r + b.r, 1.0)
    }
}

impl Sub for Ball {
    type Output = Ball;
    fn sub(self, b: Ball) -> Ball {
        Ball::rounded(self.v - b.v, self.r + b.r, 1.0)
    }
}

impl Neg for Ball {
    type Output = Ball;
    fn neg(self) -> Ball {
        Ball {
            v: -self.v,
            r: self.r,
        }
    }
}

impl Mul for Ball {
    type Output = Ball;
    fn mul(self, b: Ball) -> Ball {
        let p = self.v.abs() * b.r + b.v.abs() * self.r + self.r * b.r;
        Ball::rounded(self.v * b.v, p, 1.0)
    }
}

impl Div for Ball {
    type Output = Ball;
    fn div(self, b: Ball) -> Ball {
        let q = self.v / b.v;
        let margin = b.v.abs() - b.r;
        if !(margin >= FLUSH && b.v.abs() + b.r <= 2f64.powi(126)) {
            return Ball::with(q, f64::INFINITY);
        }
        let p = (self.r + q.abs() * b.r) / margin;
        Ball::rounded(q, p, 2.5)
    }
}

impl Real for Ball {
    /// The literal's exact value, with the f32 rounding of the literal as its radius.
    fn lit(c: f64) -> Ball {
        Ball::input(c, c as f32)
    }

    fn value(self) -> f64 {
        self.v
    }

    fn sqrt(self) -> Ball {
        if self.v < 0.0 {
            return Ball::with(f64::NAN, f64::INFINITY);
        }
        let root = self.v.sqrt();
        let p = if root > 0.0 {
            self.r.sqrt().min(self.r / root)
        } else {
            self.r.sqrt()
        };
        Ball::rounded(root, p, 4.5 + 5.0 * U)
    }

    fn inverse_sqrt(self) -> Ball {
        let low = self.v - self.r;
        if !(low > 0.0) {
            return Ball::with(1.0 / self.v.sqrt(), f64::INFINITY);
        }
        // |d(a^{-1/2})/da| = ½ a^{-3/2}, largest at the low end of the ball.
        let p = self.r * 0.5 * low.powf(-1.5);
        Ball::rounded(1.0 / self.v.sqrt(), p, 2.0)
    }

    fn exp(self) -> Ball {
        let v = self.v.exp();
        let p = v * self.r.exp_m1();
        Ball::rounded(v, p, 3.0 + 2.0 * (self.v.abs() + self.r))
    }

    fn exp2(self) -> Ball {
        let v = self.v.exp2();
        let p = v * (self.r * std::f64::consts::LN_2).exp_m1();
        Ball::rounded(v, p, 3.0 + 2.0 * (self.v.abs() + self.r))
    }

    fn log(self) -> Ball {
        log_ball(self, self.v.ln(), 1.0)
    }

    fn log2(self) -> Ball {
        log_ball(self, self.v.log2(), std::f64::consts::LOG2_E)
    }

    fn atan2(self, x: Ball) -> Ball {
        let y = self;
        let v = y.v.atan2(x.v);
        let rho_min = y.v.hypot(x.v) - y.r.hypot(x.r);
        // The branch cut on the negative real axis: a ball that reaches it may jump by 2π.
        let on_cut = x.v - x.r <= 0.0 && y.v.abs() <= y.r;
        let in_table = x.v.abs() - x.r >= FLUSH
            && x.v.abs() + x.r <= 2f64.powi(126)
            && y.v.abs() - y.r >= FLUSH;
        if !(rho_min > 0.0) || on_cut || !in_table {
            return Ball::with(v, f64::INFINITY);
        }
        let p = (x.v.abs() * y.r + y.v.abs() * x.r + 2.0 * x.r * y.r) / (rho_min * rho_min);
        Ball::rounded(v, p, 4096.0)
    }

    fn cos(self) -> Ball {
        trig(self, self.v.cos())
    }

    fn sin(self) -> Ball {
        trig(self, self.v.sin())
    }

    fn abs(self) -> Ball {
        Ball {
            v: self.v.abs(),
            r: self.r,
        }
    }

    fn min(self, y: Ball) -> Ball {
        Ball {
            v: self.v.min(y.v),
            r: self.r.max(y.r),
        }
    }

    fn max(self, y: Ball) -> Ball {
        Ball {
            v: self.v.max(y.v),
            r: self.r.max(y.r),
        }
    }

    /// floor is exact, but a ball that spans an integer may land on either side of it.
    fn floor(self) -> Ball {
        Ball::with(
            self.v.floor(),
            (self.v + self.r).floor() - (self.v - self.r).floor(),
        )
    }

    /// Σ tᵢ in any order and with any fusion: |error| ≤ Σ rᵢ + (n − 1) u (Σ|tᵢ| + Σ rᵢ).
    fn sum(terms: &[Ball]) -> Ball {
        let v: f64 = terms.iter().map(|t| t.v).sum();
        let p: f64 = terms.iter().map(|t| t.r).sum();
        let magnitude: f64 = terms.iter().map(|t| t.v.abs()).sum();
        let steps = terms.len().saturating_sub(1) as f64;
        Ball::with(
            v,
            p + steps * (U * (magnitude + p) + EPS64 * magnitude + FLUSH),
        )
    }

    fn decides_lt(self, y: Ball) -> bool {
        if (self.v - y.v).abs() <= self.r + y.r {
            AMBIGUOUS.with(|a| a.set(true));
        }
        self.v < y.v
    }
}

/// `log` (scale 1) or `log2` (scale log₂e) of `a` with value `v`.
fn log_ball(a: Ball, v: f64, scale: f64) -> Ball {
    let low = a.v - a.r;
    if !(low > 0.0) {
        return Ball::with(v, f64::INFINITY);
    }
    let p = -scale * (-a.r / a.v).ln_1p();
    if low >= 0.5 && a.v + a.r <= 2.0 {
        Ball::absolute(v, p, 2f64.powi(-21))
    } else {
        // Outside [0.5, 2] 3 ULP; a ball that straddles 0.5 or 2 may be on either side.
        let absolute = 2f64.powi(-21);
        let relative = Ball::rounded(v, p, 3.0);
        Ball::with(v, relative.r.max(p + absolute))
    }
}

/// `cos` or `sin` of `a` with value `v`: 1-Lipschitz, absolute 2⁻¹¹ on [−π, π], nothing
/// promised beyond.
fn trig(a: Ball, v: f64) -> Ball {
    if a.v.abs() + a.r > std::f64::consts::PI {
        return Ball::with(v, f64::INFINITY);
    }
    Ball::absolute(v, a.r, 2f64.powi(-11))
}

#[cfg(test)]
mod tests {
    use super::super::model::{with_model, Model, F};
    use super::*;
    use crate::twin::real::{atan2, log};
    use crate::twin::test_support::{random_points, rational, root_of_length};

    /// f(x) evaluated over F under every checked model stays inside f(x) over Ball.
    fn holds(x: &[f64], f: impl Fn(&[F]) -> F, g: impl Fn(&[Ball]) -> Ball) {
        let given: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let balls: Vec<Ball> = x
            .iter()
            .zip(&given)
            .map(|(&v, &g)| Ball::input(v, g))
            .collect();
        let (bound, ambiguous) = evaluate(|| g(&balls));
        assert!(!ambiguous);
        for model in Model::CHECKED {
            let fs: Vec<F> = given.iter().map(|&v| F::new(v)).collect();
            let got = with_model(model, || f(&fs)).f64();
            assert!(
                (got - bound.v).abs() <= bound.r,
                "{model:?}: {got} vs {} ± {}",
                bound.v,
                bound.r
            );
        }
    }

    #[test]
    fn every_model_stays_inside_the_ball() {
        for x in random_points(1, 300) {
            holds(&x, rational, rational);
            holds(&x, root_of_length, root_of_length);
            holds(
                &x,
                |v| log(v[0] * v[0] + F::lit(0.75)) + atan2(v[1], v[2].abs() + F::lit(0.1)),
                |v| log(v[0] * v[0] + Ball::lit(0.75)) + atan2(v[1], v[2].abs() + Ball::lit(0.1)),
            );
        }
    }

    #[test]
    fn the_spec_promises_nothing_for_atan2_of_zero_or_near_its_cut() {
        let (b, _) = evaluate(|| Ball::exact(0.0).atan2(Ball::exact(1.0)));
        assert!(b.r.is_infinite());
        let (b, _) = evaluate(|| Ball::input(1e-9, 0.0).atan2(Ball::exact(-1.0)));
        assert!(b.r.is_infinite());
        let (b, _) = evaluate(|| Ball::exact(0.5).atan2(Ball::exact(1.0)));
        assert!(b.r.is_finite() && b.r > 4000.0 * U * 0.46);
    }

    #[test]
    fn a_branch_within_the_radii_is_ambiguous() {
        let (_, ambiguous) = evaluate(|| Ball::input(1e-8, 0.0).decides_lt(Ball::exact(0.0)));
        assert!(ambiguous);
        let (_, ambiguous) = evaluate(|| Ball::exact(1.0).decides_lt(Ball::exact(0.0)));
        assert!(!ambiguous);
    }
}
