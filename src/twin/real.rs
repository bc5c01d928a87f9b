//! The number type a twin is written over: [`Real`], with WGSL's vectors ([`V2`], [`V3`],
//! [`V4`]) and builtins as free functions (`sqrt(x)`, `dot(a, b)`, …), so that a twin reads like
//! its WGSL line for line.
//!
//! Two types implement it:
//! - [`F`](super::model::F): an f32 as a conforming GPU computes it, under an arithmetic
//!   [`Model`](super::model::Model) (correctly rounded, fused, reordered, at the edge of the
//!   spec);
//! - [`Ball`](super::ball::Ball): the exact (f64) value with a radius that bounds how far any
//!   conforming f32 evaluation of the same expression can be from it — the bound, derived from
//!   the WGSL accuracy table operation by operation and from the magnitudes at hand.

use std::fmt::Debug;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// A number a WGSL f32 expression is evaluated in (module docs).
pub trait Real:
    Copy
    + Debug
    + PartialEq
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// A WGSL f32 literal with the exact value `c` (rounded to f32 as the shader compiler
    /// does: [`Ball`](super::ball::Ball) counts that rounding in its radius).
    fn lit(c: f64) -> Self;
    /// The value, in f64 (exact for [`F`](super::model::F)): for decisions and outputs.
    fn value(self) -> f64;
    /// `sqrt(x)`: inherited from `1.0 / inverseSqrt(x)`.
    fn sqrt(self) -> Self;
    /// `inverseSqrt(x)`: 2 ULP.
    fn inverse_sqrt(self) -> Self;
    /// `exp(x)`: 3 + 2|x| ULP.
    fn exp(self) -> Self;
    /// `exp2(x)`: 3 + 2|x| ULP.
    fn exp2(self) -> Self;
    /// `log(x)`: absolute 2⁻²¹ on [0.5, 2], 3 ULP outside.
    fn log(self) -> Self;
    /// `log2(x)`: as `log`.
    fn log2(self) -> Self;
    /// `atan2(self, x)`: 4096 ULP for |x| in [2⁻¹²⁶, 2¹²⁶] and y finite and normal.
    fn atan2(self, x: Self) -> Self;
    /// `cos(x)`: absolute 2⁻¹¹ on [−π, π].
    fn cos(self) -> Self;
    /// `sin(x)`: absolute 2⁻¹¹ on [−π, π].
    fn sin(self) -> Self;
    /// `abs(x)`: exact.
    fn abs(self) -> Self;
    /// `min(x, y)`: exact.
    fn min(self, y: Self) -> Self;
    /// `max(x, y)`: exact.
    fn max(self, y: Self) -> Self;
    /// `floor(x)`: exact.
    fn floor(self) -> Self;
    /// The sum t₀ + t₁ + … as WGSL writes it, left to right; a compiler may reassociate it.
    fn sum(terms: &[Self]) -> Self;
    /// A comparison `self < y` that chooses between formulas whose values differ (a sign fix,
    /// a clamp), unlike a choice between two forms of one function (a series or its closed
    /// form). [`Ball`](super::ball::Ball) marks its evaluation unbounded when the two sides
    /// are within each other's radius: a conforming GPU may then take the other branch.
    fn decides_lt(self, y: Self) -> bool;
}

/// `sqrt(x)`.
pub fn sqrt<R: Real>(x: R) -> R {
    x.sqrt()
}

/// `inverseSqrt(x)`.
pub fn inverse_sqrt<R: Real>(x: R) -> R {
    x.inverse_sqrt()
}

/// `exp(x)`.
pub fn exp<R: Real>(x: R) -> R {
    x.exp()
}

/// `exp2(x)`.
pub fn exp2<R: Real>(x: R) -> R {
    x.exp2()
}

/// `log(x)`.
pub fn log<R: Real>(x: R) -> R {
    x.log()
}

/// `log2(x)`.
pub fn log2<R: Real>(x: R) -> R {
    x.log2()
}

/// `atan2(y, x)`.
pub fn atan2<R: Real>(y: R, x: R) -> R {
    y.atan2(x)
}

/// `cos(x)`.
pub fn cos<R: Real>(x: R) -> R {
    x.cos()
}

/// `sin(x)`.
pub fn sin<R: Real>(x: R) -> R {
    x.sin()
}

/// `cosh(x)`: inherited from `(exp(x) + exp(−x)) * 0.5`.
pub fn cosh<R: Real>(x: R) -> R {
    (exp(x) + exp(-x)) * R::lit(0.5)
}

/// `sinh(x)`: inherited from `(exp(x) − exp(−x)) * 0.5`.
pub fn sinh<R: Real>(x: R) -> R {
    (exp(x) - exp(-x)) * R::lit(0.5)
}

/// `pow(x, y)`: inherited from `exp2(y * log2(x))`.
pub fn pow<R: Real>(x: R, y: R) -> R {
    exp2(y * log2(x))
}

/// `abs(x)`.
pub fn abs<R: Real>(x: R) -> R {
    x.abs()
}

/// `min(x, y)`.
pub fn min<R: Real>(x: R, y: R) -> R {
    x.min(y)
}

/// `max(x, y)`.
pub fn max<R: Real>(x: R, y: R) -> R {
    x.max(y)
}

/// `floor(x)`.
pub fn floor<R: Real>(x: R) -> R {
    x.floor()
}

/// `select(f, t, cond)`: `t` when `cond`, else `f`.
pub fn select<T>(f: T, t: T, cond: bool) -> T {
    if cond {
        t
    } else {
        f
    }
}

/// The sum of `terms` as WGSL's `t₀ + t₁ + …` (reassociable).
pub fn sum<R: Real>(terms: &[R]) -> R {
    R::sum(terms)
}

/// Whether the sign bit of x is set (`(bitcast<u32>(x) & 0x80000000u) != 0u`): −0 counts as
/// negative.
pub fn sign_bit<R: Real>(x: R) -> bool {
    (x.value() as f32).is_sign_negative()
}

/// Whether x is neither infinite nor NaN (`(bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u`).
pub fn is_finite<R: Real>(x: R) -> bool {
    (x.value() as f32).is_finite()
}

macro_rules! vector {
    ($name:ident, $n:literal, $($c:ident),+) => {
        /// A WGSL vector of f32.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct $name<R> { $(pub $c: R),+ }

        impl<R: Real> $name<R> {
            /// From its components.
            pub fn new($($c: R),+) -> Self {
                $name { $($c),+ }
            }

            /// The components as an array.
            pub fn to_array(self) -> [R; $n] {
                [$(self.$c),+]
            }

            /// From an array of components.
            pub fn from_array(a: [R; $n]) -> Self {
                let [$($c),+] = a;
                $name { $($c),+ }
            }

            /// The components' values (f64).
            pub fn values(self) -> [f64; $n] {
                [$(self.$c.value()),+]
            }

            /// Every component `s` (WGSL's `vecN<f32>(s)`).
            pub fn splat(s: R) -> Self {
                $name { $($c: s),+ }
            }

            /// The sum v₀ + v₁ + … of vectors as WGSL writes it (reassociable), component by
            /// component.
            pub fn sum(terms: &[Self]) -> Self {
                $name { $($c: R::sum(&terms.iter().map(|t| t.$c).collect::<Vec<R>>())),+ }
            }
        }

        impl<R: Real> Add for $name<R> {
            type Output = Self;
            fn add(self, b: Self) -> Self {
                $name { $($c: self.$c + b.$c),+ }
            }
        }

        impl<R: Real> Sub for $name<R> {
            type Output = Self;
            fn sub(self, b: Self) -> Self {
                $name { $($c: self.$c - b.$c),+ }
            }
        }

        impl<R: Real> Neg for $name<R> {
            type Output = Self;
            fn neg(self) -> Self {
                $name { $($c: -self.$c),+ }
            }
        }

        /// Component-wise product (WGSL's `v * w`).
        impl<R: Real> Mul for $name<R> {
            type Output = Self;
            fn mul(self, b: Self) -> Self {
                $name { $($c: self.$c * b.$c),+ }
            }
        }

        /// Scaling (WGSL's `v * s`).
        impl<R: Real> Mul<R> for $name<R> {
            type Output = Self;
            fn mul(self, s: R) -> Self {
                $name { $($c: self.$c * s),+ }
            }
        }

        /// Division by a scalar (WGSL's `v / s`).
        impl<R: Real> Div<R> for $name<R> {
            type Output = Self;
            fn div(self, s: R) -> Self {
                $name { $($c: self.$c / s),+ }
            }
        }
    };
}

vector!(V2, 2, x, y);
vector!(V3, 3, x, y, z);
vector!(V4, 4, x, y, z, w);

/// `dot(a, b)`: inherited from the sum of the products.
pub fn dot<R: Real, const N: usize>(a: [R; N], b: [R; N]) -> R {
    let products: [R; N] = std::array::from_fn(|n| a[n] * b[n]);
    sum(&products)
}

/// `length(v)`: inherited from `sqrt(dot(v, v))`.
pub fn length<R: Real, const N: usize>(v: [R; N]) -> R {
    sqrt(dot(v, v))
}

/// `cross(a, b)`: inherited from `a[i] * b[j] − a[j] * b[i]`.
pub fn cross<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    V3 {
        x: a.y * b.z - a.z * b.y,
        y: a.z * b.x - a.x * b.z,
        z: a.x * b.y - a.y * b.x,
    }
}

/// `normalize(v)`: inherited from `v / length(v)`.
pub fn normalize<R: Real>(v: V3<R>) -> V3<R> {
    v / length(v.to_array())
}
