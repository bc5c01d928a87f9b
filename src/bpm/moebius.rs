//! Möbius maps as SL(2,C) matrices, the two fits through three points, and exp/log between
//! SL(2,C) and its Lie algebra sl(2,C).
//!
//! A Möbius map z ↦ (a z + b)/(c z + d) is the matrix [[a, b], [c, d]], defined up to a non-zero
//! scale; we normalise to det = 1 (SL(2,C), seed step 3), which leaves only a sign ambiguity.
//! The WGSL twin of this file is `gpu/shaders/bpm_common.wgsl` (same names, same order).

use num_complex::Complex64 as C;

const ZERO: C = C::new(0.0, 0.0);
const ONE: C = C::new(1.0, 0.0);

/// A 2×2 complex matrix [[a, b], [c, d]] read as the Möbius map z ↦ (a z + b)/(c z + d).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mobius {
    pub a: C,
    pub b: C,
    pub c: C,
    pub d: C,
}

/// A traceless 2×2 complex matrix [[a, b], [c, −a]]: an element of the Lie algebra sl(2,C).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Sl2 {
    pub a: C,
    pub b: C,
    pub c: C,
}

impl Mobius {
    /// The identity map.
    pub const IDENTITY: Mobius = Mobius {
        a: ONE,
        b: ZERO,
        c: ZERO,
        d: ONE,
    };

    /// Build from the four entries.
    pub fn new(a: C, b: C, c: C, d: C) -> Self {
        Mobius { a, b, c, d }
    }

    /// det = a d − b c.
    pub fn det(&self) -> C {
        self.a * self.d - self.b * self.c
    }

    /// Trace a + d.
    pub fn trace(&self) -> C {
        self.a + self.d
    }

    /// The matrix divided by √det (principal root), so that det = 1.
    pub fn normalized(&self) -> Mobius {
        self.scale(1.0 / c_sqrt(self.det()))
    }

    /// Every entry multiplied by `s` (the same Möbius map for s ≠ 0).
    pub fn scale(&self, s: C) -> Mobius {
        Mobius::new(self.a * s, self.b * s, self.c * s, self.d * s)
    }

    /// Entry-wise comparison up to the sign ambiguity of SL(2,C): min(‖A − B‖∞, ‖A + B‖∞).
    pub fn distance_up_to_sign(&self, other: &Mobius) -> f64 {
        let e = |s: f64| {
            [
                (self.a - other.a * s).norm(),
                (self.b - other.b * s).norm(),
                (self.c - other.c * s).norm(),
                (self.d - other.d * s).norm(),
            ]
            .into_iter()
            .fold(0.0, f64::max)
        };
        e(1.0).min(e(-1.0))
    }
}

impl Sl2 {
    /// The zero element (log of ±I).
    pub const ZERO: Sl2 = Sl2 {
        a: ZERO,
        b: ZERO,
        c: ZERO,
    };

    /// `self · s` for a complex scalar s.
    pub fn scale(&self, s: C) -> Sl2 {
        Sl2 {
            a: self.a * s,
            b: self.b * s,
            c: self.c * s,
        }
    }

    /// `self + other`.
    pub fn add(&self, other: &Sl2) -> Sl2 {
        Sl2 {
            a: self.a + other.a,
            b: self.b + other.b,
            c: self.c + other.c,
        }
    }

    /// As a full 2×2 matrix [[a, b], [c, −a]] (not a map: a sl(2) element is not invertible in
    /// general; this is only for matrix arithmetic such as Taylor series).
    pub fn to_matrix(&self) -> Mobius {
        Mobius::new(self.a, self.b, self.c, -self.a)
    }

    /// Largest entry modulus.
    pub fn max_abs(&self) -> f64 {
        c_abs(self.a).max(c_abs(self.b)).max(c_abs(self.c))
    }

    /// Whether every entry is finite.
    pub fn is_finite(&self) -> bool {
        [self.a, self.b, self.c]
            .iter()
            .all(|x| x.re.is_finite() && x.im.is_finite())
    }
}

/// f(z) = (a z + b)/(c z + d).
pub fn mobius_apply(m: &Mobius, z: C) -> C {
    (m.a * z + m.b) / (m.c * z + m.d)
}

/// Matrix product m·n, i.e. the composition z ↦ m(n(z)).
pub fn mobius_mul(m: &Mobius, n: &Mobius) -> Mobius {
    Mobius::new(
        m.a * n.a + m.b * n.c,
        m.a * n.b + m.b * n.d,
        m.c * n.a + m.d * n.c,
        m.c * n.b + m.d * n.d,
    )
}

/// Inverse of a det-1 matrix: [[d, −b], [−c, a]].
pub fn mobius_inverse(m: &Mobius) -> Mobius {
    Mobius::new(m.d, -m.b, -m.c, m.a)
}

/// The Möbius map through three points, fitted in a local frame (SPEC.md § 4).
///
/// Shift so that point 0 is the origin on both sides: z' = z − z₀, w' = w − w₀. The shifted map
/// F fixes 0, so F(z) = z / (c z + d) and 1/F(z) = c + d/z is affine in 1/z:
///
///   d = (1/w'₁ − 1/w'₂) / (1/z'₁ − 1/z'₂),  c = 1/w'₁ − d/z'₁,  F = [[1, 0], [c, d]] / √d,
///
/// and M = T(w₀) · F · T(−z₀) with T the translations. All arithmetic is on triangle-sized
/// differences, which is what keeps the f32 twin accurate where the determinant fit is not.
pub fn fit_mobius_local(z: [C; 3], w: [C; 3]) -> Mobius {
    let (z1, z2) = (z[1] - z[0], z[2] - z[0]);
    let (w1, w2) = (w[1] - w[0], w[2] - w[0]);
    let d = (w1.inv() - w2.inv()) / (z1.inv() - z2.inv());
    let c = w1.inv() - d / z1;
    let s = c_sqrt(d).inv();
    // F = [[s, 0], [c s, d s]]; M = T(w₀) · F · T(−z₀) multiplied out (the products with the
    // zeros and ones of the translations cost as much as the fit itself):
    //   F · T(−z₀) = [[s, −s z₀], [c s, d s − c s z₀]],  then add w₀ × the second row to the first.
    let (cs, ds) = (c * s, d * s);
    let row2 = [cs, ds - cs * z[0]];
    Mobius::new(
        s + w[0] * row2[0],
        -s * z[0] + w[0] * row2[1],
        row2[0],
        row2[1],
    )
}

/// The Möbius map through three points by the seed's 3×3 determinants (seed step 3):
///
///   a = det[z w, w, 1], b = det[z w, z, w], c = det[z, w, 1], d = det[z w, z, 1]
///
/// (rows n = 0, 1, 2), normalised by √(a d − b c). Exact in exact arithmetic, but the
/// determinants cancel catastrophically when the points are far from the origin compared with
/// their spacing: the source of the seed's "speckling" in f32.
pub fn fit_mobius_det(z: [C; 3], w: [C; 3]) -> Mobius {
    let zw = [z[0] * w[0], z[1] * w[1], z[2] * w[2]];
    let one = [ONE; 3];
    let a = det3(zw, w, one);
    let b = det3(zw, z, w);
    let c = det3(z, w, one);
    let d = det3(zw, z, one);
    Mobius::new(a, b, c, d).normalized()
}

/// Determinant of the 3×3 matrix whose columns are `c0`, `c1`, `c2` (cofactor expansion along
/// the first column, the same order in the WGSL twin).
fn det3(c0: [C; 3], c1: [C; 3], c2: [C; 3]) -> C {
    c0[0] * (c1[1] * c2[2] - c1[2] * c2[1]) - c0[1] * (c1[0] * c2[2] - c1[2] * c2[0])
        + c0[2] * (c1[0] * c2[1] - c1[1] * c2[0])
}

/// Which implementation of exp and log to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ExpLog {
    /// The entire-series / closed forms of SPEC.md § 6: exact to rounding everywhere, no branch
    /// trouble at the identity or at nilpotent arguments. The default.
    #[default]
    Entire,
    /// Truncated matrix Taylor series as in the seed ("the first three terms"): exp Y ≈ Σ_{n<N}
    /// Yⁿ/n!, log A ≈ Σ_{n=1..N} (−1)ⁿ⁺¹ (A − I)ⁿ/n. Kept for comparison only.
    Taylor { terms: usize },
}

/// Series threshold and length for C(p), S(p): for |p| < 1, ten terms leave a remainder below
/// 1/20! ≈ 4e-19 (f64). The f32 twin uses six (1/12! ≈ 2e-9).
const EXP_SERIES_RADIUS: f64 = 1.0;
const EXP_SERIES_TERMS: usize = 10;

/// (C(p), S(p)) = (cosh √p, sinh √p / √p) = (Σ pⁿ/(2n)!, Σ pⁿ/(2n+1)!).
///
/// Both are entire functions of p (no branch of √p survives), so there is nothing singular at
/// p = 0: the series is used for |p| < 1, the closed form with the principal √p beyond.
pub fn cosh_sinhc(p: C) -> (C, C) {
    if c_abs(p) < EXP_SERIES_RADIUS {
        cosh_sinhc_series(p)
    } else {
        cosh_sinhc_closed(p)
    }
}

/// The series branch of [`cosh_sinhc`]: Horner from the highest term of C = Σ pⁿ/(2n)! and
/// S = Σ pⁿ/(2n+1)!, `EXP_SERIES_TERMS` terms.
pub fn cosh_sinhc_series(p: C) -> (C, C) {
    let (mut c, mut s) = (ZERO, ZERO);
    for n in (0..EXP_SERIES_TERMS).rev() {
        c = c * p + INV_FACTORIAL[2 * n];
        s = s * p + INV_FACTORIAL[2 * n + 1];
    }
    (c, s)
}

/// 1/n! for n < 2·EXP_SERIES_TERMS, computed at compile time.
const INV_FACTORIAL: [f64; 2 * EXP_SERIES_TERMS] = {
    let mut t = [1.0; 2 * EXP_SERIES_TERMS];
    let mut n = 1;
    while n < t.len() {
        t[n] = t[n - 1] / n as f64;
        n += 1;
    }
    t
};

/// The closed branch of [`cosh_sinhc`]: r = √p (principal), (cosh r, sinh r / r).
pub fn cosh_sinhc_closed(p: C) -> (C, C) {
    let r = c_sqrt(p);
    (r.cosh(), r.sinh() / r)
}

/// (C(p), S(p)) of [`cosh_sinhc`] by scaling and squaring, the form the f32 kernel uses
/// (`cosh_sinhc_squaring` in `bpm_common.wgsl`, twin
/// [`crate::twin::bpm_common::cosh_sinhc_squaring`]):
/// p is quartered k times until |p/4ᵏ| < 1, the series is summed there, and k doublings of
/// r = √p follow: C(4p) = 2 C(p)² − 1, S(4p) = S(p) C(p) (cosh 2r = 2 cosh² r − 1,
/// sinh 2r / 2r = (sinh r / r) cosh r).
///
/// Only + − × are used. The closed form's `cos`, `sin` and `cosh` may each err by 2⁻¹¹ in
/// absolute terms under the WGSL accuracy table, which puts a map 1 unit from its corner
/// several texels off at 4096²; this form keeps the error a few units of f32 rounding per
/// doubling (`tests/twin.rs` shows both at the spec's edge).
pub fn cosh_sinhc_squaring(p: C) -> (C, C) {
    let mut q = p;
    let mut k = 0;
    while c_abs(q) >= EXP_SERIES_RADIUS && k < 64 {
        q *= 0.25;
        k += 1;
    }
    let (mut c, mut s) = cosh_sinhc_series(q);
    for _ in 0..k {
        (c, s) = (2.0 * c * c - 1.0, s * c);
    }
    (c, s)
}

/// The principal log of A ∈ SL(2,C) by inverse scaling and squaring, the form the f32 kernel
/// uses (`log_sl2_roots` in `bpm_common.wgsl`, twin
/// [`crate::twin::bpm_common::log_sl2_roots`]).
///
/// After the sign fix, with t = Tr A / 2, X = A − t I and q = t² − 1: while |q| ≥ 0.1, A is
/// replaced by its principal square root √A = (A + I)/s, s = √(2t + 2) (Re t ≥ 0, so
/// |2t + 2| ≥ 2 and √A's eigenvalues have positive real part), i.e. X ← X/s, t ← s/2; the
/// log doubles each time: log A = 2ᵏ asinhc(q_k) X_k with the series of asinhc. No `log` or
/// `atan2` (4096 ULP in WGSL: 1.5e-3 radians on a half turn) is needed.
pub fn log_sl2_roots(m: &Mobius) -> Sl2 {
    let m = sign_fix(m);
    let mut x = Sl2 {
        a: (m.a - m.d) * 0.5,
        b: m.b,
        c: m.c,
    };
    let mut t = (m.a + m.d) * 0.5;
    let mut q = x.a * x.a + x.b * x.c;
    let mut scale = 1.0;
    let mut k = 0;
    while c_abs(q) >= LOG_SERIES_RADIUS && k < 160 {
        let s = c_sqrt(2.0 * t + 2.0);
        x = x.scale(s.inv());
        t = s * 0.5;
        q = x.a * x.a + x.b * x.c;
        scale *= 2.0;
        k += 1;
    }
    x.scale(asinhc_series(q) * scale)
}

/// Series threshold and length for asinhc: for |q| < 0.1, sixteen terms leave a remainder
/// below 0.1¹⁶·0.02 ≈ 2e-18 (f64). The f32 twin uses eight.
const LOG_SERIES_RADIUS: f64 = 0.1;
const LOG_SERIES_TERMS: usize = 16;

/// asinhc(q) = asinh(√q)/√q = Σ (−1)ⁿ (2n)! / (4ⁿ (n!)² (2n+1)) qⁿ = 1 − q/6 + 3q²/40 − …
///
/// Even in √q, hence a function of q alone; the series is used for |q| < 0.1, the closed form
/// asinh(r)/r with r = √q and asinh(r) = ln(r + √(q + 1)) beyond (Re r ≥ 0, so the sum does not
/// cancel).
pub fn asinhc(q: C) -> C {
    if c_abs(q) < LOG_SERIES_RADIUS {
        asinhc_series(q)
    } else {
        asinhc_closed(q)
    }
}

/// The series branch of [`asinhc`] (Horner, `LOG_SERIES_TERMS` terms).
pub fn asinhc_series(q: C) -> C {
    let mut h = ZERO;
    for n in (0..LOG_SERIES_TERMS).rev() {
        h = h * q + ASINHC_COEFFICIENTS[n];
    }
    h
}

/// The closed branch of [`asinhc`]: r = √q, ln(r + √(q + 1)) / r.
pub fn asinhc_closed(q: C) -> C {
    let r = c_sqrt(q);
    c_ln(r + c_sqrt(q + 1.0)) / r
}

/// Coefficients of the asinhc series, (−1)ⁿ (2n)! / (4ⁿ (n!)² (2n+1)), built at compile time by
/// the ratio of consecutive terms (no huge factorials): c₀ = 1, cₙ/cₙ₋₁ = −(2n−1)²/(2n(2n+1)).
const ASINHC_COEFFICIENTS: [f64; LOG_SERIES_TERMS] = {
    let mut c = [1.0; LOG_SERIES_TERMS];
    let mut n = 1;
    while n < c.len() {
        let k = n as f64;
        c[n] = -c[n - 1] * (2.0 * k - 1.0) * (2.0 * k - 1.0) / (2.0 * k * (2.0 * k + 1.0));
        n += 1;
    }
    c
};

/// Modulus |z| = √(re² + im²), falling back to `hypot` only when re² + im² under- or
/// overflows (|z| outside ≈ [1e-154, 1e154]). `hypot`, which num-complex's `norm` calls, costs
/// several times more and was a quarter of the precompute time. The WGSL twin is `length`.
#[inline]
pub fn c_abs(z: C) -> f64 {
    let s = z.re * z.re + z.im * z.im;
    if s.is_normal() {
        s.sqrt()
    } else {
        z.re.hypot(z.im)
    }
}

/// Principal logarithm ln z = ln|z| + i arg z, with ln|z| = ½ ln(re² + im²) (the same range
/// guard as [`c_abs`]).
#[inline]
pub fn c_ln(z: C) -> C {
    let s = z.re * z.re + z.im * z.im;
    let ln_abs = if s.is_normal() {
        0.5 * s.ln()
    } else {
        z.re.hypot(z.im).ln()
    };
    C::new(ln_abs, z.im.atan2(z.re))
}

/// Principal square root, branch cut on the negative real axis, in algebraic form (no
/// trigonometry; the WGSL twin `c_sqrt` is the same formula):
///   Re z ≥ 0: t = √((|z| + Re z)/2), √z = (t, Im z / 2t);
///   Re z < 0: t = √((|z| − Re z)/2), √z = (|Im z| / 2t, ±t) with the sign of Im z.
/// Both branches avoid cancellation.
pub fn c_sqrt(z: C) -> C {
    let r = c_abs(z);
    if r == 0.0 {
        return ZERO;
    }
    if z.re >= 0.0 {
        let t = ((r + z.re) * 0.5).sqrt();
        C::new(t, z.im / (2.0 * t))
    } else {
        let t = ((r - z.re) * 0.5).sqrt();
        C::new(z.im.abs() / (2.0 * t), t.copysign(z.im))
    }
}

/// exp of a traceless matrix Y = [[a, b], [c, −a]] (SPEC.md § 6).
///
/// Y² = p I with p = −det Y = a² + b c, so exp Y = C(p) I + S(p) Y with (C, S) from
/// [`cosh_sinhc`]: exp Y = [[C + S a, S b], [S c, C − S a]]. The result has det 1.
pub fn exp_sl2(y: &Sl2) -> Mobius {
    let p = y.a * y.a + y.b * y.c;
    let (c, s) = cosh_sinhc(p);
    Mobius::new(c + s * y.a, s * y.b, s * y.c, c - s * y.a)
}

/// The principal log of A ∈ SL(2,C) after the sign fix (seed step 4, SPEC.md §§ 5–6):
///
/// if Re Tr A < 0, A := −A (SL(2,C) matrices are Möbius maps only up to sign); then with
/// X = A − (Tr A/2) I = [[(a−d)/2, b], [c, −(a−d)/2]] and q = ((a−d)/2)² + b c (= (Tr A/2)² − 1
/// without cancellation), log A = asinhc(q) · X. log(±I) = 0 exactly and log(I + εN) = εN.
pub fn log_sl2(m: &Mobius) -> Sl2 {
    let m = sign_fix(m);
    let x = Sl2 {
        a: (m.a - m.d) * 0.5,
        b: m.b,
        c: m.c,
    };
    let q = x.a * x.a + x.b * x.c;
    x.scale(asinhc(q))
}

/// A or −A, whichever has Re Tr ≥ 0 (a comparison, never a sign function that returns 0).
pub fn sign_fix(m: &Mobius) -> Mobius {
    if m.trace().re < 0.0 {
        m.scale(C::new(-1.0, 0.0))
    } else {
        *m
    }
}

/// exp with the chosen implementation (see [`ExpLog`]).
pub fn exp_with(y: &Sl2, method: ExpLog) -> Mobius {
    match method {
        ExpLog::Entire => exp_sl2(y),
        ExpLog::Taylor { terms } => exp_taylor(y, terms),
    }
}

/// log with the chosen implementation (see [`ExpLog`]).
pub fn log_with(m: &Mobius, method: ExpLog) -> Sl2 {
    match method {
        ExpLog::Entire => log_sl2(m),
        ExpLog::Taylor { terms } => log_taylor(m, terms),
    }
}

/// The seed's truncated series exp Y ≈ Σ_{n<N} Yⁿ/n! (N = `terms`, at least 1).
pub fn exp_taylor(y: &Sl2, terms: usize) -> Mobius {
    let ym = y.to_matrix();
    let mut term = Mobius::IDENTITY;
    let mut sum = Mobius::IDENTITY;
    for n in 1..terms.max(1) {
        term = mobius_mul(&term, &ym).scale(C::new(1.0 / n as f64, 0.0));
        sum = add(&sum, &term);
    }
    sum
}

/// Truncated series log A ≈ Σ_{n=1..N} (−1)ⁿ⁺¹ (A − I)ⁿ / n after the sign fix; the trace of
/// the result is removed so that it lies in sl(2,C).
pub fn log_taylor(m: &Mobius, terms: usize) -> Sl2 {
    let m = sign_fix(m);
    let x = Mobius::new(m.a - 1.0, m.b, m.c, m.d - 1.0);
    let mut power = Mobius::IDENTITY;
    let mut sum = Mobius::new(ZERO, ZERO, ZERO, ZERO);
    for n in 1..=terms.max(1) {
        power = mobius_mul(&power, &x);
        let sign = if n % 2 == 1 { 1.0 } else { -1.0 };
        sum = add(&sum, &power.scale(C::new(sign / n as f64, 0.0)));
    }
    Sl2 {
        a: (sum.a - sum.d) * 0.5,
        b: sum.b,
        c: sum.c,
    }
}

fn add(m: &Mobius, n: &Mobius) -> Mobius {
    Mobius::new(m.a + n.a, m.b + n.b, m.c + n.c, m.d + n.d)
}

/// Complex cross-ratio (z₀, z₁; z₂, z₃) = ((z₀ − z₂)(z₁ − z₃)) / ((z₀ − z₃)(z₁ − z₂)), invariant
/// under Möbius maps; used by the edge diagnostic Tr(δ)² = m + 2 + 1/m (SPEC.md §§ 10–11).
pub fn cross_ratio(z: [C; 4]) -> C {
    ((z[0] - z[2]) * (z[1] - z[3])) / ((z[0] - z[3]) * (z[1] - z[2]))
}
