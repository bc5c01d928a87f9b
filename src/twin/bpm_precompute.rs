//! Twin of `gpu/shaders/bpm_precompute.wgsl`: one invocation per triangle t = (i, j, k) turns
//! its star into [`TriangleMaps`] (reference: [`crate::bpm::precompute()`], seed 004 steps
//! 1–5).

use super::bpm_common::{
    c_mul, c_zero, fit_mobius_det, fit_mobius_local, log_sl2_roots, mobius_identity,
    mobius_inverse, mobius_is_finite, mobius_mul, pack_triangle_maps, sl2_max_abs, sl2_zero,
    Complex, Mobius, TriangleMaps, FLAG_LINEAR_FALLBACK, FLAG_MIRRORED,
};
use super::real::{cross, dot, is_finite, length, select, Real, V2, V3};

/// `MASK_DEGENERATE`: t is degenerate (linear fallback).
pub const MASK_DEGENERATE: u32 = 8;
/// `FIT_LOCAL`.
pub const FIT_LOCAL: u32 = 0;
/// `FIT_DETERMINANT`.
pub const FIT_DETERMINANT: u32 = 1;

/// One triangle's star (WGSL `StarInput`).
#[derive(Clone, Copy, Debug)]
pub struct StarInput<R> {
    /// Positions of i, j, k, then the apex across ij, jk, ki.
    pub p: [V3<R>; 6],
    /// UVs at the same six points.
    pub w: [Complex<R>; 6],
    /// Bit e: neighbour across edge e exists; `MASK_DEGENERATE`: t is degenerate.
    pub mask: u32,
}

/// The corners (a, b) of edge e in t's order: ij = (0, 1), jk = (1, 2), ki = (2, 0).
pub fn edge_corners(e: usize) -> [usize; 2] {
    [e, (e + 1) % 3]
}

/// Signed area (×2) of a triangle of complex points, counter-clockwise positive:
/// (b − a).re (c − a).im − (b − a).im (c − a).re.
pub fn signed_area2<R: Real>(a: Complex<R>, b: Complex<R>, c: Complex<R>) -> R {
    let u = b - a;
    let v = c - a;
    u.x * v.y - u.y * v.x
}

/// The star's layout in t's frame and whether it was mirrored (WGSL `StarLayout`).
#[derive(Clone, Copy, Debug)]
pub struct StarLayout<R> {
    pub z: [Complex<R>; 6],
    pub mirrored: bool,
}

/// Lay out the star in t's own frame: z_i = 0, z_j = |p_j − p_i| on the real axis,
/// z_k = ((p_k − p_i)·e₁) + i |e₁ × (p_k − p_i)|, each apex unfolded across its edge by
/// [`place_apex`]; if t's UV triangle w_t is clockwise, the whole star is mirrored (z ↦ z̄).
pub fn star_layout<R: Real>(p: [V3<R>; 6], w_t: [Complex<R>; 3]) -> StarLayout<R> {
    let zero = R::lit(0.0);
    let ej = p[1] - p[0];
    let edge_length = length(ej.to_array());
    let e1 = ej / edge_length;
    let pk = p[2] - p[0];
    let mut z = [V2::new(zero, zero); 6];
    z[1] = V2::new(edge_length, zero);
    z[2] = V2::new(
        dot(pk.to_array(), e1.to_array()),
        length(cross(e1, pk).to_array()),
    );
    for e in 0..3 {
        let [a, b] = edge_corners(e);
        z[3 + e] = place_apex(z[a], z[b], p[a], p[b], p[3 + e]);
    }
    let mirrored = signed_area2(w_t[0], w_t[1], w_t[2]).decides_lt(zero);
    if mirrored {
        for zn in &mut z {
            *zn = V2::new(zn.x, -zn.y);
        }
    }
    StarLayout { z, mirrored }
}

/// Unfold a neighbour's apex across the edge a→b of t (an isometric hinge rotation):
/// u = (p_b − p_a)/|p_b − p_a|, along = (p_apex − p_a)·u, perp = |u × (p_apex − p_a)|,
/// dir = (z_b − z_a)/|z_b − z_a|, z_apex = z_a + dir·(along − i·perp) (right of a→b).
pub fn place_apex<R: Real>(
    z_a: Complex<R>,
    z_b: Complex<R>,
    p_a: V3<R>,
    p_b: V3<R>,
    p_apex: V3<R>,
) -> Complex<R> {
    let u = (p_b - p_a) / length((p_b - p_a).to_array());
    let r = p_apex - p_a;
    let along = dot(r.to_array(), u.to_array());
    let perp = length(cross(u, r).to_array());
    let dir = (z_b - z_a) / length((z_b - z_a).to_array());
    z_a + c_mul(dir, V2::new(along, -perp))
}

/// The Möbius map through star points (n0, n1, n2): layout z ↦ shifted UVs big_w, by the
/// chosen fit.
pub fn fit_star<R: Real>(
    fit: u32,
    z: &[Complex<R>; 6],
    big_w: &[Complex<R>; 6],
    n: [usize; 3],
) -> Mobius<R> {
    let z3 = [z[n[0]], z[n[1]], z[n[2]]];
    let w3 = [big_w[n[0]], big_w[n[1]], big_w[n[2]]];
    if fit == FIT_DETERMINANT {
        return fit_mobius_det(z3, w3);
    }
    fit_mobius_local(z3, w3)
}

/// All per-triangle data of one star: with W = w − w_origin (w_origin = w_i for the local fit,
/// 0 for the determinant fit), M_t = fit(z_i, z_j, z_k → W_i, W_j, W_k); for each neighbour e
/// across edge (a, b): M_e = fit(z_a, z_b, z_apex → W_a, W_b, W_apex), δ_e = M_t⁻¹ M_e,
/// l_e = log_sl2_roots(δ_e); l_e = 0 without a neighbour (or when not finite). A degenerate t, or a
/// non-finite M_t, gives the linear fallback: M_t = I, logs 0, w_origin 0.
pub fn triangle_maps<R: Real>(star: &StarInput<R>, fit: u32) -> TriangleMaps<R> {
    let uv = [star.w[0], star.w[1], star.w[2]];
    let star_z = star_layout(star.p, uv);
    let z = star_z.z;
    let z_t = [z[0], z[1], z[2]];
    let mirrored = select(0, FLAG_MIRRORED, star_z.mirrored);
    let mut logs = [sl2_zero(), sl2_zero(), sl2_zero()];
    let fallback = pack_triangle_maps(
        z_t,
        uv,
        c_zero(),
        mobius_identity(),
        logs,
        FLAG_LINEAR_FALLBACK | mirrored,
    );
    if (star.mask & MASK_DEGENERATE) != 0 {
        return fallback;
    }
    let w_origin = select(c_zero(), star.w[0], fit == FIT_LOCAL);
    let big_w: [Complex<R>; 6] = std::array::from_fn(|n| star.w[n] - w_origin);
    let m_t = fit_star(fit, &z, &big_w, [0, 1, 2]);
    if !mobius_is_finite(m_t) {
        return fallback;
    }
    let m_t_inv = mobius_inverse(m_t);
    for (e, log) in logs.iter_mut().enumerate() {
        if (star.mask & (1 << e)) == 0 {
            continue;
        }
        let [a, b] = edge_corners(e);
        let m_e = fit_star(fit, &z, &big_w, [a, b, 3 + e]);
        let ratio = mobius_mul(m_t_inv, m_e);
        let l_e = log_sl2_roots(ratio);
        // A non-finite ratio (a neighbour whose fit blew up) is treated like a boundary edge.
        if is_finite(sl2_max_abs(l_e)) {
            *log = l_e;
        }
    }
    pack_triangle_maps(z_t, uv, w_origin, m_t, logs, mirrored)
}
