// BPM — Blended Piecewise Möbius Maps, f32: functions shared by bpm_precompute, bpm_eval and
// bpm_render (the host concatenates this file before each kernel: WGSL has no includes).
//
// Twin of the f64 reference: src/bpm/moebius.rs (SL(2,C) maps, the two fits, exp/log) and
// src/bpm/eval.rs (edge weights, blending, evaluation). Same function names, same order of
// operations.
//
// Complex numbers are vec2<f32> (re, im). A Möbius map z ↦ (a z + b)/(c z + d) is the SL(2,C)
// matrix Mobius { a, b, c, d }; an element of sl(2,C) is Sl2 { a, b, c } = [[a, b], [c, −a]].

// ---------------------------------------------------------------------------------------------
// Per-triangle data (192 bytes; byte for byte `TriangleMaps` in gpu/src/bpm/mod.rs)

struct TriangleMaps {
    z: vec4<f32>,               // (z_j, z_k): layout of corners j, k in t's frame; z_i = 0
    uv_ij: vec4<f32>,           // (uv_i, uv_j)
    uv_k_origin: vec4<f32>,     // (uv_k, w_origin)
    m: array<vec4<f32>, 2>,     // M_t: (a, b), (c, d); f(z) = w_origin + M_t(z)
    logs: array<vec4<f32>, 6>,  // log ratio of edge e: logs[2e] = (a, b), logs[2e + 1] = (c, 0)
    flags: u32,                 // FLAG_LINEAR_FALLBACK | FLAG_MIRRORED
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

const FLAG_LINEAR_FALLBACK: u32 = 1u;
const FLAG_MIRRORED: u32 = 2u;
const INTERP_BPM: u32 = 0u;
const INTERP_LINEAR: u32 = 1u;

// ---------------------------------------------------------------------------------------------
// Complex arithmetic (num-complex's formulas)

const C_ZERO: vec2<f32> = vec2<f32>(0.0, 0.0);
const C_ONE: vec2<f32> = vec2<f32>(1.0, 0.0);

// a b = (a.re b.re − a.im b.im, a.re b.im + a.im b.re)
fn c_mul(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x);
}

// a / b = (a.re b.re + a.im b.im, a.im b.re − a.re b.im) / |b|²
fn c_div(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let norm_sqr = b.x * b.x + b.y * b.y;
    return vec2<f32>(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y) / norm_sqr;
}

// 1 / a = (a.re, −a.im) / |a|²
fn c_inv(a: vec2<f32>) -> vec2<f32> {
    let norm_sqr = a.x * a.x + a.y * a.y;
    return vec2<f32>(a.x / norm_sqr, -a.y / norm_sqr);
}

// Whether the sign bit of x is set (so −0 counts as negative, like Rust's is_sign_negative).
fn sign_bit(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x80000000u) != 0u;
}

// Whether x is neither infinite nor NaN (exponent bits not all ones; no reliance on NaN
// comparisons, which shader compilers may optimise away).
fn is_finite_f32(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// Principal square root, branch cut on the negative real axis (−0 imaginary part below it, as
// in num-complex). Algebraic form, no trigonometry (twin of `c_sqrt` in moebius.rs):
//   re z ≥ 0: t = √((|z| + re z)/2), √z = (t, im z / (2t));
//   re z < 0: t = √((|z| − re z)/2), √z = (|im z| / (2t), ±t) with the sign of im z.
fn c_sqrt(z: vec2<f32>) -> vec2<f32> {
    let r = length(z);
    if r == 0.0 {
        return C_ZERO;
    }
    if z.x >= 0.0 {
        let t = sqrt((r + z.x) * 0.5);
        return vec2<f32>(t, z.y / (2.0 * t));
    }
    let t = sqrt((r - z.x) * 0.5);
    return vec2<f32>(abs(z.y) / (2.0 * t), select(t, -t, sign_bit(z.y)));
}

// ---------------------------------------------------------------------------------------------
// SL(2,C) and sl(2,C) (reference: src/bpm/moebius.rs)

struct Mobius {
    a: vec2<f32>,
    b: vec2<f32>,
    c: vec2<f32>,
    d: vec2<f32>,
}

struct Sl2 {
    a: vec2<f32>,
    b: vec2<f32>,
    c: vec2<f32>,
}

fn mobius_identity() -> Mobius {
    return Mobius(C_ONE, C_ZERO, C_ZERO, C_ONE);
}

// det = a d − b c
fn mobius_det(m: Mobius) -> vec2<f32> {
    return c_mul(m.a, m.d) - c_mul(m.b, m.c);
}

// Every entry multiplied by s (the same Möbius map for s ≠ 0).
fn mobius_scale(m: Mobius, s: vec2<f32>) -> Mobius {
    return Mobius(c_mul(m.a, s), c_mul(m.b, s), c_mul(m.c, s), c_mul(m.d, s));
}

// The matrix divided by √det (principal root), so that det = 1.
fn mobius_normalized(m: Mobius) -> Mobius {
    return mobius_scale(m, c_inv(c_sqrt(mobius_det(m))));
}

fn mobius_is_finite(m: Mobius) -> bool {
    let v = vec4<f32>(m.a, m.b);
    let w = vec4<f32>(m.c, m.d);
    return is_finite_f32(v.x) && is_finite_f32(v.y) && is_finite_f32(v.z) && is_finite_f32(v.w)
        && is_finite_f32(w.x) && is_finite_f32(w.y) && is_finite_f32(w.z) && is_finite_f32(w.w);
}

fn sl2_zero() -> Sl2 {
    return Sl2(C_ZERO, C_ZERO, C_ZERO);
}

// l · s for a complex scalar s
fn sl2_scale(l: Sl2, s: vec2<f32>) -> Sl2 {
    return Sl2(c_mul(l.a, s), c_mul(l.b, s), c_mul(l.c, s));
}

// l + m
fn sl2_add(l: Sl2, m: Sl2) -> Sl2 {
    return Sl2(l.a + m.a, l.b + m.b, l.c + m.c);
}

// Largest entry modulus.
fn sl2_max_abs(l: Sl2) -> f32 {
    return max(max(length(l.a), length(l.b)), length(l.c));
}

// f(z) = (a z + b)/(c z + d)
fn mobius_apply(m: Mobius, z: vec2<f32>) -> vec2<f32> {
    return c_div(c_mul(m.a, z) + m.b, c_mul(m.c, z) + m.d);
}

// Matrix product m·n, i.e. the composition z ↦ m(n(z)).
fn mobius_mul(m: Mobius, n: Mobius) -> Mobius {
    return Mobius(
        c_mul(m.a, n.a) + c_mul(m.b, n.c),
        c_mul(m.a, n.b) + c_mul(m.b, n.d),
        c_mul(m.c, n.a) + c_mul(m.d, n.c),
        c_mul(m.c, n.b) + c_mul(m.d, n.d),
    );
}

// Inverse of a det-1 matrix: [[d, −b], [−c, a]].
fn mobius_inverse(m: Mobius) -> Mobius {
    return Mobius(m.d, -m.b, -m.c, m.a);
}

// The Möbius map through three points z_n ↦ w_n, fitted in a local frame: z' = z − z₀,
// w' = w − w₀; the shifted map fixes 0 and 1/F(z) = c + d/z is affine in 1/z:
//   d = (1/w'₁ − 1/w'₂) / (1/z'₁ − 1/z'₂),  c = 1/w'₁ − d/z'₁,  F = [[1, 0], [c, d]] / √d,
//   M = T(w₀) · F · T(−z₀).
fn fit_mobius_local(z: array<vec2<f32>, 3>, w: array<vec2<f32>, 3>) -> Mobius {
    let z1 = z[1] - z[0];
    let z2 = z[2] - z[0];
    let w1 = w[1] - w[0];
    let w2 = w[2] - w[0];
    let d = c_div(c_inv(w1) - c_inv(w2), c_inv(z1) - c_inv(z2));
    let c = c_inv(w1) - c_div(d, z1);
    let s = c_inv(c_sqrt(d));
    // F = [[s, 0], [c s, d s]]; M = T(w₀) · F · T(−z₀) multiplied out:
    //   F · T(−z₀) = [[s, −s z₀], [c s, d s − c s z₀]],  then add w₀ × the second row to the first.
    let cs = c_mul(c, s);
    let ds = c_mul(d, s);
    let row2 = array<vec2<f32>, 2>(cs, ds - c_mul(cs, z[0]));
    return Mobius(s + c_mul(w[0], row2[0]), -c_mul(s, z[0]) + c_mul(w[0], row2[1]), row2[0], row2[1]);
}

// The Möbius map through three points by the seed's 3×3 determinants (rows n = 0, 1, 2):
//   a = det[z w, w, 1], b = det[z w, z, w], c = det[z, w, 1], d = det[z w, z, 1],
// normalised by √(a d − b c). Cancels catastrophically in f32 far from the origin.
fn fit_mobius_det(z: array<vec2<f32>, 3>, w: array<vec2<f32>, 3>) -> Mobius {
    let zw = array<vec2<f32>, 3>(c_mul(z[0], w[0]), c_mul(z[1], w[1]), c_mul(z[2], w[2]));
    let one = array<vec2<f32>, 3>(C_ONE, C_ONE, C_ONE);
    let a = det3(zw, w, one);
    let b = det3(zw, z, w);
    let c = det3(z, w, one);
    let d = det3(zw, z, one);
    return mobius_normalized(Mobius(a, b, c, d));
}

// Determinant of the 3×3 matrix with columns c0, c1, c2 (cofactor expansion along c0).
fn det3(c0: array<vec2<f32>, 3>, c1: array<vec2<f32>, 3>, c2: array<vec2<f32>, 3>) -> vec2<f32> {
    return c_mul(c0[0], c_mul(c1[1], c2[2]) - c_mul(c1[2], c2[1]))
        - c_mul(c0[1], c_mul(c1[0], c2[2]) - c_mul(c1[2], c2[0]))
        + c_mul(c0[2], c_mul(c1[0], c2[1]) - c_mul(c1[1], c2[0]));
}

// Series threshold and length for C(p), S(p): for |p| < 1, six terms leave a remainder below
// 1/12! ≈ 2e-9 (the reference uses ten in f64). p is quartered at most 64 times (|p| < 4⁶⁴
// covers every finite f32).
const EXP_SERIES_RADIUS: f32 = 1.0;
const EXP_SERIES_TERMS: i32 = 6;
const EXP_MAX_QUARTERINGS: i32 = 64;

struct CoshSinhc {
    c: vec2<f32>,
    s: vec2<f32>,
}

// (C(p), S(p)) = (cosh √p, sinh √p / √p) = (Σ pⁿ/(2n)!, Σ pⁿ/(2n+1)!) by scaling and squaring
// (reference: cosh_sinhc_squaring): p is quartered k times until |p/4ᵏ| < 1, the series is
// summed there, then k doublings of √p: C(4p) = 2 C(p)² − 1, S(4p) = S(p) C(p). Only + − ×:
// WGSL's cos, sin and cosh may err by 2⁻¹¹ absolutely, which the closed form would pass on.
fn cosh_sinhc_squaring(p: vec2<f32>) -> CoshSinhc {
    var q = p;
    var k = 0;
    while length(q) >= EXP_SERIES_RADIUS && k < EXP_MAX_QUARTERINGS {
        q = q * 0.25;
        k++;
    }
    var cs = cosh_sinhc_series(q);
    for (var n = 0; n < k; n++) {
        cs = CoshSinhc(c_mul(cs.c, cs.c) * 2.0 - C_ONE, c_mul(cs.s, cs.c));
    }
    return cs;
}

// The series of C and S at |p| < 1, Horner from the highest term.
fn cosh_sinhc_series(p: vec2<f32>) -> CoshSinhc {
    var inv_fact_even = array<f32, 6>(1.0, 1.0 / 2.0, 1.0 / 24.0, 1.0 / 720.0, 1.0 / 40320.0, 1.0 / 3628800.0);
    var inv_fact_odd = array<f32, 6>(1.0, 1.0 / 6.0, 1.0 / 120.0, 1.0 / 5040.0, 1.0 / 362880.0, 1.0 / 39916800.0);
    var c = C_ZERO;
    var s = C_ZERO;
    for (var n = EXP_SERIES_TERMS - 1; n >= 0; n--) {
        c = c_mul(c, p) + vec2<f32>(inv_fact_even[n], 0.0);
        s = c_mul(s, p) + vec2<f32>(inv_fact_odd[n], 0.0);
    }
    return CoshSinhc(c, s);
}

// Series threshold and length for asinhc: for |q| < 0.1, eight terms leave a remainder below
// 0.1⁸ · 0.013 ≈ 1.3e-10 (the reference uses sixteen in f64). At most 160 square roots (each
// at least halves |q|).
const LOG_SERIES_RADIUS: f32 = 0.1;
const LOG_SERIES_TERMS: i32 = 8;
const LOG_MAX_ROOTS: i32 = 160;

// asinhc(q) = asinh(√q)/√q = Σ (−1)ⁿ (2n)! / (4ⁿ (n!)² (2n+1)) qⁿ = 1 − q/6 + 3q²/40 − …
// for |q| < 0.1 (Horner).
fn asinhc_series(q: vec2<f32>) -> vec2<f32> {
    var coefficient = array<f32, 8>(
        1.0, -1.0 / 6.0, 3.0 / 40.0, -5.0 / 112.0, 35.0 / 1152.0, -63.0 / 2816.0,
        231.0 / 13312.0, -143.0 / 10240.0,
    );
    var h = C_ZERO;
    for (var n = LOG_SERIES_TERMS - 1; n >= 0; n--) {
        h = c_mul(h, q) + vec2<f32>(coefficient[n], 0.0);
    }
    return h;
}

// exp Y for Y = [[a, b], [c, −a]]: p = a² + b c, (C, S) = cosh_sinhc_squaring(p),
// exp Y = [[C + S a, S b], [S c, C − S a]] (det 1).
fn exp_sl2(y: Sl2) -> Mobius {
    let p = c_mul(y.a, y.a) + c_mul(y.b, y.c);
    let cs = cosh_sinhc_squaring(p);
    return Mobius(cs.c + c_mul(cs.s, y.a), c_mul(cs.s, y.b), c_mul(cs.s, y.c), cs.c - c_mul(cs.s, y.a));
}

// Principal log of A ∈ SL(2,C) after the sign fix, by inverse scaling and squaring (reference:
// log_sl2_roots): t = Tr A / 2, X = [[(a−d)/2, b], [c, −(a−d)/2]], q = ((a−d)/2)² + b c
// (= t² − 1); while |q| ≥ 0.1, A ← √A = (A + I)/s with s = √(2t + 2) (X ← X/s, t ← s/2) and
// the log doubles: log A = 2ᵏ asinhc(q_k) X_k. No log or atan2 (4096 ULP in WGSL).
fn log_sl2_roots(m: Mobius) -> Sl2 {
    let n = sign_fix(m);
    var x = Sl2((n.a - n.d) * 0.5, n.b, n.c);
    var t = (n.a + n.d) * 0.5;
    var q = c_mul(x.a, x.a) + c_mul(x.b, x.c);
    var scale = 1.0;
    var k = 0;
    while length(q) >= LOG_SERIES_RADIUS && k < LOG_MAX_ROOTS {
        let s = c_sqrt(t * 2.0 + vec2<f32>(2.0, 0.0));
        x = sl2_scale(x, c_inv(s));
        t = s * 0.5;
        q = c_mul(x.a, x.a) + c_mul(x.b, x.c);
        scale = scale * 2.0;
        k++;
    }
    return sl2_scale(x, asinhc_series(q) * scale);
}

// A or −A, whichever has Re Tr ≥ 0 (a comparison, never a sign function that returns 0).
fn sign_fix(m: Mobius) -> Mobius {
    if m.a.x + m.d.x < 0.0 {
        return mobius_scale(m, vec2<f32>(-1.0, 0.0));
    }
    return m;
}

// ---------------------------------------------------------------------------------------------
// TriangleMaps packing (the reference's TriangleMaps fields, in the 192-byte layout)

// Layout of the corners in t's frame: (z_i = 0, z_j, z_k).
fn maps_z(t: TriangleMaps) -> array<vec2<f32>, 3> {
    return array<vec2<f32>, 3>(C_ZERO, t.z.xy, t.z.zw);
}

// The corners' UVs (uv_i, uv_j, uv_k).
fn maps_uv(t: TriangleMaps) -> array<vec2<f32>, 3> {
    return array<vec2<f32>, 3>(t.uv_ij.xy, t.uv_ij.zw, t.uv_k_origin.xy);
}

fn maps_w_origin(t: TriangleMaps) -> vec2<f32> {
    return t.uv_k_origin.zw;
}

fn maps_m_t(t: TriangleMaps) -> Mobius {
    return Mobius(t.m[0].xy, t.m[0].zw, t.m[1].xy, t.m[1].zw);
}

// Log ratios of the edges ij, jk, ki.
fn maps_logs(t: TriangleMaps) -> array<Sl2, 3> {
    return array<Sl2, 3>(
        Sl2(t.logs[0].xy, t.logs[0].zw, t.logs[1].xy),
        Sl2(t.logs[2].xy, t.logs[2].zw, t.logs[3].xy),
        Sl2(t.logs[4].xy, t.logs[4].zw, t.logs[5].xy),
    );
}

// Inverse of the maps_* accessors.
fn pack_triangle_maps(
    z: array<vec2<f32>, 3>,
    uv: array<vec2<f32>, 3>,
    w_origin: vec2<f32>,
    m_t: Mobius,
    logs: array<Sl2, 3>,
    flags: u32,
) -> TriangleMaps {
    var t: TriangleMaps;
    t.z = vec4<f32>(z[1], z[2]);
    t.uv_ij = vec4<f32>(uv[0], uv[1]);
    t.uv_k_origin = vec4<f32>(uv[2], w_origin);
    t.m = array<vec4<f32>, 2>(vec4<f32>(m_t.a, m_t.b), vec4<f32>(m_t.c, m_t.d));
    t.logs = array<vec4<f32>, 6>(
        vec4<f32>(logs[0].a, logs[0].b), vec4<f32>(logs[0].c, C_ZERO),
        vec4<f32>(logs[1].a, logs[1].b), vec4<f32>(logs[1].c, C_ZERO),
        vec4<f32>(logs[2].a, logs[2].b), vec4<f32>(logs[2].c, C_ZERO),
    );
    t.flags = flags;
    return t;
}

// ---------------------------------------------------------------------------------------------
// Evaluation (reference: src/bpm/eval.rs)

// Edge-barycentric weights (γ_ij, γ_jk, γ_ki), product form:
//   γ_ij ∝ |ij| b_i b_j,  γ_jk ∝ |jk| b_j b_k,  γ_ki ∝ |ki| b_k b_i,  normalised to sum 1;
// all 0 exactly at a vertex (0/0), where f equals the vertex's UV whatever the weights.
fn edge_weights(b: vec3<f32>, z: array<vec2<f32>, 3>) -> vec3<f32> {
    let l_ij = length(z[1] - z[0]);
    let l_jk = length(z[2] - z[1]);
    let l_ki = length(z[0] - z[2]);
    let g = vec3<f32>(l_ij * b[0] * b[1], l_jk * b[1] * b[2], l_ki * b[2] * b[0]);
    let s = g[0] + g[1] + g[2];
    if s > 0.0 {
        return vec3<f32>(g[0] / s, g[1] / s, g[2] / s);
    }
    return vec3<f32>(0.0);
}

// Blended log ratio ℓ = γ_ij ℓ_ij + γ_jk ℓ_jk + γ_ki ℓ_ki (linear combination in sl(2,C)).
fn blended_log(t: TriangleMaps, gamma: vec3<f32>) -> Sl2 {
    var logs = maps_logs(t);
    var l = sl2_zero();
    for (var e = 0u; e < 3u; e++) {
        l = sl2_add(l, sl2_scale(logs[e], vec2<f32>(gamma[e], 0.0)));
    }
    return l;
}

// f(z) = w_origin + M_t(exp(½ ℓ)(z)) at barycentrics b = (b_i, b_j, b_k) of t, with
// z = b_i z_i + b_j z_j + b_k z_k and ℓ = blended_log(edge_weights(b)) (right order).
fn eval_bpm(t: TriangleMaps, b: vec3<f32>) -> vec2<f32> {
    let z_t = maps_z(t);
    let z = z_t[0] * b[0] + z_t[1] * b[1] + z_t[2] * b[2];
    let gamma = edge_weights(b, z_t);
    let half_log = sl2_scale(blended_log(t, gamma), vec2<f32>(0.5, 0.0));
    let e = exp_sl2(half_log);
    let w = mobius_apply(maps_m_t(t), mobius_apply(e, z));
    return maps_w_origin(t) + w;
}

// Piecewise-linear interpolation b_i uv_i + b_j uv_j + b_k uv_k.
fn eval_linear(t: TriangleMaps, b: vec3<f32>) -> vec2<f32> {
    let uv = maps_uv(t);
    return uv[0] * b[0] + uv[1] * b[1] + uv[2] * b[2];
}

// The interpolated UV: linear when asked (interp == INTERP_LINEAR) or for a degenerate face
// (FLAG_LINEAR_FALLBACK), BPM otherwise.
fn eval(t: TriangleMaps, b: vec3<f32>, interp: u32) -> vec2<f32> {
    if interp == INTERP_LINEAR || (t.flags & FLAG_LINEAR_FALLBACK) != 0u {
        return eval_linear(t, b);
    }
    return eval_bpm(t, b);
}
