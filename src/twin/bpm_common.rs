//! Twin of `gpu/shaders/bpm_common.wgsl`: complex arithmetic, SL(2,C) maps, the two fits, exp
//! and log on sl(2,C), the per-triangle data and the evaluation — function for function, in
//! the WGSL's order of operations.
//!
//! Complex numbers are [`V2`] (re, im). A Möbius map z ↦ (a z + b)/(c z + d) is [`Mobius`]; an
//! element of sl(2,C) is [`Sl2`] = [[a, b], [c, −a]].
//!
//! Where the f32 kernel computes a function differently from the f64 reference
//! ([`crate::bpm::moebius`]), both forms are in the reference and a test shows why the kernel
//! uses its own, under the same name in all three places: [`cosh_sinhc_squaring`] (scaling
//! and squaring) and [`log_sl2_roots`] (inverse scaling and squaring) mirror
//! [`crate::bpm::moebius::cosh_sinhc_squaring`] and [`crate::bpm::moebius::log_sl2_roots`];
//! the reference's own `cosh_sinhc` (series or closed form) and `log_sl2` (closed form) have no
//! f32 twin. The kernel's forms need no `cos`, `sin`, `exp`, `log` or `atan2`, whose WGSL
//! accuracy (absolute 2⁻¹¹ for `cos`, 4096 ULP for `atan2`) would put the maps tens of texels
//! off on a GPU that uses all of its allowance. So `exp_sl2` (exp Y = C I + S Y) is one formula
//! everywhere, but its (C, S) come from `cosh_sinhc` in f64 and from `cosh_sinhc_squaring` in
//! the twin and the WGSL.

use super::real::{length, select, sqrt, sum, Real, V2, V3, V4};

/// A complex number (re, im).
pub type Complex<R> = V2<R>;

/// `FLAG_LINEAR_FALLBACK`: the face is evaluated linearly (degenerate, or a fit that failed).
pub const FLAG_LINEAR_FALLBACK: u32 = 1;
/// `FLAG_MIRRORED`: the face's UV triangle is clockwise and its layout was mirrored.
pub const FLAG_MIRRORED: u32 = 2;
/// `INTERP_BPM`.
pub const INTERP_BPM: u32 = 0;
/// `INTERP_LINEAR`.
pub const INTERP_LINEAR: u32 = 1;

/// The kernels' `interp` code of an interpolation.
pub fn interp_code(interp: crate::bpm::Interp) -> u32 {
    match interp {
        crate::bpm::Interp::Bpm => INTERP_BPM,
        crate::bpm::Interp::Linear => INTERP_LINEAR,
    }
}

fn c<R: Real>(re: f64, im: f64) -> Complex<R> {
    V2::new(R::lit(re), R::lit(im))
}

/// `C_ZERO`.
pub fn c_zero<R: Real>() -> Complex<R> {
    c(0.0, 0.0)
}

/// `C_ONE`.
pub fn c_one<R: Real>() -> Complex<R> {
    c(1.0, 0.0)
}

/// a b = (a.re b.re − a.im b.im, a.re b.im + a.im b.re)
pub fn c_mul<R: Real>(a: Complex<R>, b: Complex<R>) -> Complex<R> {
    V2::new(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x)
}

/// a / b = (a.re b.re + a.im b.im, a.im b.re − a.re b.im) / |b|²
pub fn c_div<R: Real>(a: Complex<R>, b: Complex<R>) -> Complex<R> {
    let norm_sqr = b.x * b.x + b.y * b.y;
    V2::new(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y) / norm_sqr
}

/// 1 / a = (a.re, −a.im) / |a|²
pub fn c_inv<R: Real>(a: Complex<R>) -> Complex<R> {
    let norm_sqr = a.x * a.x + a.y * a.y;
    V2::new(a.x / norm_sqr, -a.y / norm_sqr)
}

/// Principal square root, branch cut on the negative real axis, algebraic form:
///   re z ≥ 0: t = √((|z| + re z)/2), √z = (t, im z / (2t));
///   re z < 0: t = √((|z| − re z)/2), √z = (|im z| / (2t), ±t) with the sign of im z.
pub fn c_sqrt<R: Real>(z: Complex<R>) -> Complex<R> {
    let r = length(z.to_array());
    if r.value() == 0.0 {
        return c_zero();
    }
    let half = R::lit(0.5);
    let two = R::lit(2.0);
    if z.x.value() >= 0.0 {
        let t = sqrt((r + z.x) * half);
        return V2::new(t, z.y / (two * t));
    }
    let t = sqrt((r - z.x) * half);
    V2::new(
        z.y.abs() / (two * t),
        select(t, -t, super::real::sign_bit(z.y)),
    )
}

/// A Möbius map z ↦ (a z + b)/(c z + d) (WGSL `Mobius`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mobius<R> {
    pub a: Complex<R>,
    pub b: Complex<R>,
    pub c: Complex<R>,
    pub d: Complex<R>,
}

/// An element of sl(2,C), [[a, b], [c, −a]] (WGSL `Sl2`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sl2<R> {
    pub a: Complex<R>,
    pub b: Complex<R>,
    pub c: Complex<R>,
}

/// `mobius_identity()`.
pub fn mobius_identity<R: Real>() -> Mobius<R> {
    Mobius {
        a: c_one(),
        b: c_zero(),
        c: c_zero(),
        d: c_one(),
    }
}

/// det = a d − b c
pub fn mobius_det<R: Real>(m: Mobius<R>) -> Complex<R> {
    c_mul(m.a, m.d) - c_mul(m.b, m.c)
}

/// Every entry multiplied by s.
pub fn mobius_scale<R: Real>(m: Mobius<R>, s: Complex<R>) -> Mobius<R> {
    Mobius {
        a: c_mul(m.a, s),
        b: c_mul(m.b, s),
        c: c_mul(m.c, s),
        d: c_mul(m.d, s),
    }
}

/// The matrix divided by √det (principal root), so that det = 1.
pub fn mobius_normalized<R: Real>(m: Mobius<R>) -> Mobius<R> {
    mobius_scale(m, c_inv(c_sqrt(mobius_det(m))))
}

/// Whether every entry is finite.
pub fn mobius_is_finite<R: Real>(m: Mobius<R>) -> bool {
    [m.a, m.b, m.c, m.d]
        .iter()
        .all(|z| super::real::is_finite(z.x) && super::real::is_finite(z.y))
}

/// `sl2_zero()`.
pub fn sl2_zero<R: Real>() -> Sl2<R> {
    Sl2 {
        a: c_zero(),
        b: c_zero(),
        c: c_zero(),
    }
}

/// l · s for a complex scalar s
pub fn sl2_scale<R: Real>(l: Sl2<R>, s: Complex<R>) -> Sl2<R> {
    Sl2 {
        a: c_mul(l.a, s),
        b: c_mul(l.b, s),
        c: c_mul(l.c, s),
    }
}

/// l + m
pub fn sl2_add<R: Real>(l: Sl2<R>, m: Sl2<R>) -> Sl2<R> {
    Sl2 {
        a: l.a + m.a,
        b: l.b + m.b,
        c: l.c + m.c,
    }
}

/// Largest entry modulus.
pub fn sl2_max_abs<R: Real>(l: Sl2<R>) -> R {
    length(l.a.to_array())
        .max(length(l.b.to_array()))
        .max(length(l.c.to_array()))
}

/// f(z) = (a z + b)/(c z + d)
pub fn mobius_apply<R: Real>(m: Mobius<R>, z: Complex<R>) -> Complex<R> {
    c_div(c_mul(m.a, z) + m.b, c_mul(m.c, z) + m.d)
}

/// Matrix product m·n, i.e. the composition z ↦ m(n(z)).
pub fn mobius_mul<R: Real>(m: Mobius<R>, n: Mobius<R>) -> Mobius<R> {
    Mobius {
        a: c_mul(m.a, n.a) + c_mul(m.b, n.c),
        b: c_mul(m.a, n.b) + c_mul(m.b, n.d),
        c: c_mul(m.c, n.a) + c_mul(m.d, n.c),
        d: c_mul(m.c, n.b) + c_mul(m.d, n.d),
    }
}

/// Inverse of a det-1 matrix: [[d, −b], [−c, a]].
pub fn mobius_inverse<R: Real>(m: Mobius<R>) -> Mobius<R> {
    Mobius {
        a: m.d,
        b: -m.b,
        c: -m.c,
        d: m.a,
    }
}

/// The Möbius map through three points in a local frame (reference:
/// [`crate::bpm::moebius::fit_mobius_local`]): z' = z − z₀, w' = w − w₀,
///   d = (1/w'₁ − 1/w'₂) / (1/z'₁ − 1/z'₂),  c = 1/w'₁ − d/z'₁,  F = [[1, 0], [c, d]] / √d,
///   M = T(w₀) · F · T(−z₀).
pub fn fit_mobius_local<R: Real>(z: [Complex<R>; 3], w: [Complex<R>; 3]) -> Mobius<R> {
    let z1 = z[1] - z[0];
    let z2 = z[2] - z[0];
    let w1 = w[1] - w[0];
    let w2 = w[2] - w[0];
    let d = c_div(c_inv(w1) - c_inv(w2), c_inv(z1) - c_inv(z2));
    let c = c_inv(w1) - c_div(d, z1);
    let s = c_inv(c_sqrt(d));
    let cs = c_mul(c, s);
    let ds = c_mul(d, s);
    let row2 = [cs, ds - c_mul(cs, z[0])];
    Mobius {
        a: s + c_mul(w[0], row2[0]),
        b: -c_mul(s, z[0]) + c_mul(w[0], row2[1]),
        c: row2[0],
        d: row2[1],
    }
}

/// The Möbius map through three points by the seed's 3×3 determinants (reference:
/// [`crate::bpm::moebius::fit_mobius_det`]): a = det[z w, w, 1], b = det[z w, z, w],
/// c = det[z, w, 1], d = det[z w, z, 1], normalised by √(a d − b c).
pub fn fit_mobius_det<R: Real>(z: [Complex<R>; 3], w: [Complex<R>; 3]) -> Mobius<R> {
    let zw = [c_mul(z[0], w[0]), c_mul(z[1], w[1]), c_mul(z[2], w[2])];
    let one = [c_one(), c_one(), c_one()];
    let a = det3(zw, w, one);
    let b = det3(zw, z, w);
    let c = det3(z, w, one);
    let d = det3(zw, z, one);
    mobius_normalized(Mobius { a, b, c, d })
}

/// Determinant of the 3×3 matrix with columns c0, c1, c2 (cofactor expansion along c0).
pub fn det3<R: Real>(c0: [Complex<R>; 3], c1: [Complex<R>; 3], c2: [Complex<R>; 3]) -> Complex<R> {
    c_mul(c0[0], c_mul(c1[1], c2[2]) - c_mul(c1[2], c2[1]))
        - c_mul(c0[1], c_mul(c1[0], c2[2]) - c_mul(c1[2], c2[0]))
        + c_mul(c0[2], c_mul(c1[0], c2[1]) - c_mul(c1[1], c2[0]))
}

/// `EXP_SERIES_RADIUS`: the series of C and S is used for |p| < 1.
pub const EXP_SERIES_RADIUS: f64 = 1.0;
/// `EXP_SERIES_TERMS`: six terms leave a remainder below 1/12! ≈ 2e-9 for |p| < 1.
pub const EXP_SERIES_TERMS: usize = 6;
/// `EXP_MAX_QUARTERINGS`: p is quartered at most this often (|p| < 4⁶⁴ covers every finite
/// f32).
pub const EXP_MAX_QUARTERINGS: usize = 64;

/// (C, S) of [`cosh_sinhc_squaring`].
#[derive(Clone, Copy, Debug)]
pub struct CoshSinhc<R> {
    pub c: Complex<R>,
    pub s: Complex<R>,
}

/// (C(p), S(p)) = (cosh √p, sinh √p / √p) = (Σ pⁿ/(2n)!, Σ pⁿ/(2n+1)!) by scaling and
/// squaring (reference: [`crate::bpm::moebius::cosh_sinhc_squaring`]): p is quartered k
/// times until |p/4ᵏ| < 1, the series is summed there (Horner from the highest term), and
/// k doublings of √p follow: C(4p) = 2 C(p)² − 1, S(4p) = S(p) C(p)
/// (cosh 2r = 2 cosh² r − 1, sinh 2r / 2r = (sinh r / r) cosh r).
pub fn cosh_sinhc_squaring<R: Real>(p: Complex<R>) -> CoshSinhc<R> {
    let mut q = p;
    let mut k = 0;
    while length(q.to_array()).value() >= EXP_SERIES_RADIUS && k < EXP_MAX_QUARTERINGS {
        q = q * R::lit(0.25);
        k += 1;
    }
    let mut cs = cosh_sinhc_series(q);
    for _ in 0..k {
        cs = CoshSinhc {
            c: c_mul(cs.c, cs.c) * R::lit(2.0) - c_one(),
            s: c_mul(cs.s, cs.c),
        };
    }
    cs
}

/// 1/(2n)! for n < `EXP_SERIES_TERMS` (the WGSL's `inv_fact_even`).
const INV_FACT_EVEN: [f64; EXP_SERIES_TERMS] = [
    1.0,
    1.0 / 2.0,
    1.0 / 24.0,
    1.0 / 720.0,
    1.0 / 40320.0,
    1.0 / 3628800.0,
];
/// 1/(2n+1)! for n < `EXP_SERIES_TERMS` (the WGSL's `inv_fact_odd`).
const INV_FACT_ODD: [f64; EXP_SERIES_TERMS] = [
    1.0,
    1.0 / 6.0,
    1.0 / 120.0,
    1.0 / 5040.0,
    1.0 / 362880.0,
    1.0 / 39916800.0,
];

/// The series of C and S at |p| < 1, Horner from the highest term.
pub fn cosh_sinhc_series<R: Real>(p: Complex<R>) -> CoshSinhc<R> {
    let mut c = c_zero();
    let mut s = c_zero();
    for n in (0..EXP_SERIES_TERMS).rev() {
        c = c_mul(c, p) + V2::new(R::lit(INV_FACT_EVEN[n]), R::lit(0.0));
        s = c_mul(s, p) + V2::new(R::lit(INV_FACT_ODD[n]), R::lit(0.0));
    }
    CoshSinhc { c, s }
}

/// `LOG_SERIES_RADIUS`: the asinhc series is used for |q| < 0.1.
pub const LOG_SERIES_RADIUS: f64 = 0.1;
/// `LOG_SERIES_TERMS`: eight terms leave a remainder below 0.1⁸ · 0.013 ≈ 1.3e-10.
pub const LOG_SERIES_TERMS: usize = 8;
/// `LOG_MAX_ROOTS`: square roots taken at most (each at least halves |q|).
pub const LOG_MAX_ROOTS: usize = 160;

/// asinhc(q) = asinh(√q)/√q = Σ (−1)ⁿ (2n)! / (4ⁿ (n!)² (2n+1)) qⁿ for |q| < 0.1 (Horner).
pub fn asinhc_series<R: Real>(q: Complex<R>) -> Complex<R> {
    const COEFFICIENT: [f64; LOG_SERIES_TERMS] = [
        1.0,
        -1.0 / 6.0,
        3.0 / 40.0,
        -5.0 / 112.0,
        35.0 / 1152.0,
        -63.0 / 2816.0,
        231.0 / 13312.0,
        -143.0 / 10240.0,
    ];
    let mut h = c_zero();
    for n in (0..LOG_SERIES_TERMS).rev() {
        h = c_mul(h, q) + V2::new(R::lit(COEFFICIENT[n]), R::lit(0.0));
    }
    h
}

/// exp Y for Y = [[a, b], [c, −a]]: p = a² + b c, (C, S) = cosh_sinhc_squaring(p),
/// exp Y = [[C + S a, S b], [S c, C − S a]] (det 1).
pub fn exp_sl2<R: Real>(y: Sl2<R>) -> Mobius<R> {
    let p = c_mul(y.a, y.a) + c_mul(y.b, y.c);
    let cs = cosh_sinhc_squaring(p);
    Mobius {
        a: cs.c + c_mul(cs.s, y.a),
        b: c_mul(cs.s, y.b),
        c: c_mul(cs.s, y.c),
        d: cs.c - c_mul(cs.s, y.a),
    }
}

/// The principal log of A ∈ SL(2,C) after the sign fix, by inverse scaling and squaring
/// (reference: [`crate::bpm::moebius::log_sl2_roots`]). With t = Tr A / 2,
/// X = A − t I = [[(a−d)/2, b], [c, −(a−d)/2]] and q = ((a−d)/2)² + b c (= t² − 1),
/// log A = asinhc(q) X. While |q| ≥ 0.1, A is replaced by its principal square root
/// √A = (A + I)/s with s = √(2t + 2) (Re t ≥ 0 after the sign fix, so |2t + 2| ≥ 2): then
/// X ← X/s, t ← s/2, q ← ((a−d)/2)² + b c of the new X, and the log doubles:
/// log A = 2ᵏ asinhc(q_k) X_k.
pub fn log_sl2_roots<R: Real>(m: Mobius<R>) -> Sl2<R> {
    let n = sign_fix(m);
    let half = R::lit(0.5);
    let mut x = Sl2 {
        a: (n.a - n.d) * half,
        b: n.b,
        c: n.c,
    };
    let mut t = (n.a + n.d) * half;
    let mut q = c_mul(x.a, x.a) + c_mul(x.b, x.c);
    let mut scale = R::lit(1.0);
    let mut k = 0;
    while length(q.to_array()).value() >= LOG_SERIES_RADIUS && k < LOG_MAX_ROOTS {
        let s = c_sqrt(t * R::lit(2.0) + c(2.0, 0.0));
        let s_inv = c_inv(s);
        x = sl2_scale(x, s_inv);
        t = s * half;
        q = c_mul(x.a, x.a) + c_mul(x.b, x.c);
        scale = scale * R::lit(2.0);
        k += 1;
    }
    sl2_scale(x, asinhc_series(q) * scale)
}

/// A or −A, whichever has Re Tr ≥ 0 (a comparison, never a sign function that returns 0).
pub fn sign_fix<R: Real>(m: Mobius<R>) -> Mobius<R> {
    if (m.a.x + m.d.x).decides_lt(R::lit(0.0)) {
        return mobius_scale(m, c(-1.0, 0.0));
    }
    m
}

/// Per-triangle data (WGSL `TriangleMaps`, 192 bytes on the GPU).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleMaps<R> {
    /// (z_j, z_k): layout of corners j, k in t's frame; z_i = 0.
    pub z: V4<R>,
    /// (uv_i, uv_j).
    pub uv_ij: V4<R>,
    /// (uv_k, w_origin).
    pub uv_k_origin: V4<R>,
    /// M_t: (a, b), (c, d); f(z) = w_origin + M_t(z).
    pub m: [V4<R>; 2],
    /// Log ratio of edge e (ij, jk, ki): `logs[2e] = (a, b)`, `logs[2e + 1] = (c, 0)`.
    pub logs: [V4<R>; 6],
    /// FLAG_LINEAR_FALLBACK | FLAG_MIRRORED.
    pub flags: u32,
}

impl<R: Real> TriangleMaps<R> {
    /// From the 44 values of the `bpm_eval` kernel's `maps` row (z, uv_ij, uv_k_origin, m,
    /// logs, in that order) and the flags.
    pub fn from_values(v: &[R; 44], flags: u32) -> Self {
        let v4 = |k: usize| V4::new(v[k], v[k + 1], v[k + 2], v[k + 3]);
        TriangleMaps {
            z: v4(0),
            uv_ij: v4(4),
            uv_k_origin: v4(8),
            m: [v4(12), v4(16)],
            logs: std::array::from_fn(|e| v4(20 + 4 * e)),
            flags,
        }
    }

    /// The 44 values, in [`Self::from_values`]'s order.
    pub fn values(&self) -> [R; 44] {
        let mut out = [R::lit(0.0); 44];
        let all = [self.z, self.uv_ij, self.uv_k_origin]
            .into_iter()
            .chain(self.m)
            .chain(self.logs);
        for (k, v) in all.enumerate() {
            out[4 * k..4 * k + 4].copy_from_slice(&v.to_array());
        }
        out
    }
}

/// Layout of the corners in t's frame: (z_i = 0, z_j, z_k).
pub fn maps_z<R: Real>(t: &TriangleMaps<R>) -> [Complex<R>; 3] {
    [c_zero(), V2::new(t.z.x, t.z.y), V2::new(t.z.z, t.z.w)]
}

/// The corners' UVs (uv_i, uv_j, uv_k).
pub fn maps_uv<R: Real>(t: &TriangleMaps<R>) -> [Complex<R>; 3] {
    [
        V2::new(t.uv_ij.x, t.uv_ij.y),
        V2::new(t.uv_ij.z, t.uv_ij.w),
        V2::new(t.uv_k_origin.x, t.uv_k_origin.y),
    ]
}

/// `maps_w_origin`.
pub fn maps_w_origin<R: Real>(t: &TriangleMaps<R>) -> Complex<R> {
    V2::new(t.uv_k_origin.z, t.uv_k_origin.w)
}

/// `maps_m_t`.
pub fn maps_m_t<R: Real>(t: &TriangleMaps<R>) -> Mobius<R> {
    Mobius {
        a: V2::new(t.m[0].x, t.m[0].y),
        b: V2::new(t.m[0].z, t.m[0].w),
        c: V2::new(t.m[1].x, t.m[1].y),
        d: V2::new(t.m[1].z, t.m[1].w),
    }
}

/// Log ratios of the edges ij, jk, ki.
pub fn maps_logs<R: Real>(t: &TriangleMaps<R>) -> [Sl2<R>; 3] {
    std::array::from_fn(|e| Sl2 {
        a: V2::new(t.logs[2 * e].x, t.logs[2 * e].y),
        b: V2::new(t.logs[2 * e].z, t.logs[2 * e].w),
        c: V2::new(t.logs[2 * e + 1].x, t.logs[2 * e + 1].y),
    })
}

/// Inverse of the `maps_*` accessors.
pub fn pack_triangle_maps<R: Real>(
    z: [Complex<R>; 3],
    uv: [Complex<R>; 3],
    w_origin: Complex<R>,
    m_t: Mobius<R>,
    logs: [Sl2<R>; 3],
    flags: u32,
) -> TriangleMaps<R> {
    let zero = R::lit(0.0);
    let v4 = |a: Complex<R>, b: Complex<R>| V4::new(a.x, a.y, b.x, b.y);
    TriangleMaps {
        z: v4(z[1], z[2]),
        uv_ij: v4(uv[0], uv[1]),
        uv_k_origin: v4(uv[2], w_origin),
        m: [v4(m_t.a, m_t.b), v4(m_t.c, m_t.d)],
        logs: std::array::from_fn(|k| {
            let l = logs[k / 2];
            if k % 2 == 0 {
                v4(l.a, l.b)
            } else {
                V4::new(l.c.x, l.c.y, zero, zero)
            }
        }),
        flags,
    }
}

/// Edge-barycentric weights (γ_ij, γ_jk, γ_ki), product form:
///   γ_ij ∝ |ij| b_i b_j,  γ_jk ∝ |jk| b_j b_k,  γ_ki ∝ |ki| b_k b_i,  normalised to sum 1;
/// all 0 exactly at a vertex (0/0).
pub fn edge_weights<R: Real>(b: V3<R>, z: [Complex<R>; 3]) -> V3<R> {
    let l_ij = length((z[1] - z[0]).to_array());
    let l_jk = length((z[2] - z[1]).to_array());
    let l_ki = length((z[0] - z[2]).to_array());
    let g = V3::new(l_ij * b.x * b.y, l_jk * b.y * b.z, l_ki * b.z * b.x);
    let s = sum(&[g.x, g.y, g.z]);
    if s.value() > 0.0 {
        return V3::new(g.x / s, g.y / s, g.z / s);
    }
    V3::splat(R::lit(0.0))
}

/// Blended log ratio ℓ = γ_ij ℓ_ij + γ_jk ℓ_jk + γ_ki ℓ_ki.
pub fn blended_log<R: Real>(t: &TriangleMaps<R>, gamma: V3<R>) -> Sl2<R> {
    let logs = maps_logs(t);
    let gamma = gamma.to_array();
    let mut l = sl2_zero();
    for e in 0..3 {
        l = sl2_add(l, sl2_scale(logs[e], V2::new(gamma[e], R::lit(0.0))));
    }
    l
}

/// f(z) = w_origin + M_t(exp(½ ℓ)(z)) at barycentrics b = (b_i, b_j, b_k) of t, with
/// z = b_i z_i + b_j z_j + b_k z_k and ℓ = blended_log(edge_weights(b)) (right order).
pub fn eval_bpm<R: Real>(t: &TriangleMaps<R>, b: V3<R>) -> Complex<R> {
    let z_t = maps_z(t);
    let z = V2::sum(&[z_t[0] * b.x, z_t[1] * b.y, z_t[2] * b.z]);
    let gamma = edge_weights(b, z_t);
    let half_log = sl2_scale(blended_log(t, gamma), c(0.5, 0.0));
    let e = exp_sl2(half_log);
    let w = mobius_apply(maps_m_t(t), mobius_apply(e, z));
    maps_w_origin(t) + w
}

/// Piecewise-linear interpolation b_i uv_i + b_j uv_j + b_k uv_k.
pub fn eval_linear<R: Real>(t: &TriangleMaps<R>, b: V3<R>) -> Complex<R> {
    let uv = maps_uv(t);
    V2::sum(&[uv[0] * b.x, uv[1] * b.y, uv[2] * b.z])
}

/// The interpolated UV: linear when asked (interp == INTERP_LINEAR) or for a degenerate face
/// (FLAG_LINEAR_FALLBACK), BPM otherwise.
pub fn eval<R: Real>(t: &TriangleMaps<R>, b: V3<R>, interp: u32) -> Complex<R> {
    if interp == INTERP_LINEAR || (t.flags & FLAG_LINEAR_FALLBACK) != 0 {
        return eval_linear(t, b);
    }
    eval_bpm(t, b)
}
