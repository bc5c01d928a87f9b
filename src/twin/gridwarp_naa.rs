//! Twin of `gpu/shaders/gridwarp_naa.wgsl` (and of the residuals `gridwarp_naa_residuals.wgsl`
//! shares), function for function: the non-axis-aligned energy's residuals
//! r^s = σ(‖J_D W_s‖ − o_s), r^t = σ(‖J_D W_t‖ − o_t) of one sample (seed 000 §8), J_D = [D_s D_t]
//! sampled bilinearly at the bilinearly warped point, their derivatives with respect to the
//! cell's 8 corner coordinates, and each cell's share of F, Jᵀr and JᵀJ (the host adds the
//! cells in f64). The bilinear lookup is `gridwarp_field.wgsl`'s, twinned in
//! [`super::gridwarp_aa`] ([`axis`], [`bilinear_formula`]).
//!
//! Over [`super::Ball`] the same lines derive the kernel's bound
//! ([`crate::crosscheck::gridwarp_naa`]); the one comparison that chooses between formulas,
//! `‖q‖ > 0` in [`residual_derivatives`], is a [`Real::decides_lt`].

use super::gridwarp_aa::{axis, bilinear_formula, FieldSample, RestSample};
use super::real::{sqrt, sum, Real, V2, V3};

/// A W×H field of 3-vectors, texel (x, y) component c at `values[(y·W + x)·3 + c]`, row 0 at
/// t = 0 (`d_s`, `d_t`).
#[derive(Clone, Copy, Debug)]
pub struct VectorField<'a, R> {
    pub values: &'a [R],
    pub width: usize,
    pub height: usize,
}

/// `RestCell`: the rest size h_i × k_j of a cell.
#[derive(Clone, Copy, Debug)]
pub struct RestCell<R> {
    pub h: R,
    pub k: R,
}

/// `Corners`: [P00, P10, P01, P11] of a cell.
#[derive(Clone, Copy, Debug)]
pub struct Corners<R> {
    pub p00: V2<R>,
    pub p10: V2<R>,
    pub p01: V2<R>,
    pub p11: V2<R>,
}

/// `Warp`: the warped point p and the slopes W_s, W_t.
#[derive(Clone, Copy, Debug)]
pub struct Warp<R> {
    pub p: V2<R>,
    pub w_s: V2<R>,
    pub w_t: V2<R>,
}

/// `bilinear_warp`: W = P00 + α e_α + β e_β + αβ τ; W_s = e_α/h + β τ/h, W_t = e_β/k + α τ/k.
pub fn bilinear_warp<R: Real>(c: &Corners<R>, cell: &RestCell<R>, alpha: R, beta: R) -> Warp<R> {
    let e_alpha = c.p10 - c.p00;
    let e_beta = c.p01 - c.p00;
    let twist = (c.p11 - c.p10) - e_beta;
    let (h, k) = (cell.h, cell.k);
    Warp {
        p: (c.p00 + e_alpha * alpha) + (e_beta * beta + twist * (alpha * beta)),
        w_s: e_alpha / h + (twist / h) * beta,
        w_t: e_beta / k + (twist / k) * alpha,
    }
}

/// `Partial`: one column of J_D (D_s or D_t) and its derivatives along s and t.
#[derive(Clone, Copy, Debug)]
pub struct Partial<R> {
    pub value: V3<R>,
    pub ds: V3<R>,
    pub dt: V3<R>,
}

/// `component_bilinear`: component c of `f` at p.
pub fn component_bilinear<R: Real>(f: &VectorField<R>, c: usize, p: V2<R>) -> FieldSample<R> {
    let ax = axis(p.x, f.width);
    let ay = axis(p.y, f.height);
    let x1 = (ax.x0 + 1).min(f.width - 1);
    let y1 = (ay.x0 + 1).min(f.height - 1);
    let texel = |x: usize, y: usize| f.values[(y * f.width + x) * 3 + c];
    bilinear_formula(
        &ax,
        &ay,
        [
            texel(ax.x0, ay.x0),
            texel(x1, ay.x0),
            texel(ax.x0, y1),
            texel(x1, y1),
        ],
    )
}

/// `partial_at`: the vector field `f` at p, each component with its gradient.
pub fn partial_at<R: Real>(f: &VectorField<R>, p: V2<R>) -> Partial<R> {
    let [x, y, z] = [0, 1, 2].map(|c| component_bilinear(f, c, p));
    Partial {
        value: V3::new(x.value, y.value, z.value),
        ds: V3::new(x.ds, y.ds, z.ds),
        dt: V3::new(x.dt, y.dt, z.dt),
    }
}

/// `Jacobian`: J_D = [D_s, D_t] at a point, with its derivatives.
#[derive(Clone, Copy, Debug)]
pub struct Jacobian<R> {
    pub d_s: Partial<R>,
    pub d_t: Partial<R>,
}

/// `jacobian_at`.
pub fn jacobian_at<R: Real>(d_s: &VectorField<R>, d_t: &VectorField<R>, p: V2<R>) -> Jacobian<R> {
    Jacobian {
        d_s: partial_at(d_s, p),
        d_t: partial_at(d_t, p),
    }
}

/// `image`: q = D_s w.x + D_t w.y.
pub fn image<R: Real>(d_s_k: V3<R>, d_t_k: V3<R>, w: V2<R>) -> V3<R> {
    d_s_k * w.x + d_t_k * w.y
}

/// `norm`: sqrt(q.x² + q.y² + q.z²).
pub fn norm<R: Real>(q: V3<R>) -> R {
    sqrt(sum(&[q.x * q.x, q.y * q.y, q.z * q.z]))
}

/// `dot3`: x · y.
pub fn dot3<R: Real>(x: V3<R>, y: V3<R>) -> R {
    sum(&[x.x * y.x, x.y * y.y, x.z * y.z])
}

/// `residual`: r = σ (‖q‖ − o).
pub fn residual<R: Real>(sigma: R, q: V3<R>, o: R) -> R {
    sigma * (norm(q) - o)
}

/// `corner_weights`: [(1−α)(1−β), α(1−β), (1−α)β, αβ].
pub fn corner_weights<R: Real>(alpha: R, beta: R) -> [R; 4] {
    let one = R::lit(1.0);
    [
        (one - alpha) * (one - beta),
        alpha * (one - beta),
        (one - alpha) * beta,
        alpha * beta,
    ]
}

/// `corner_weight_slopes`: for the s residual (`axis_index` 0) [−(1−β)/h, (1−β)/h, −β/h, β/h],
/// for the t residual [−(1−α)/k, −α/k, (1−α)/k, α/k].
pub fn corner_weight_slopes<R: Real>(
    axis_index: usize,
    cell: &RestCell<R>,
    alpha: R,
    beta: R,
) -> [R; 4] {
    let one = R::lit(1.0);
    if axis_index == 0 {
        let near = (one - beta) / cell.h;
        let far = beta / cell.h;
        return [-near, near, -far, far];
    }
    let near = (one - alpha) / cell.k;
    let far = alpha / cell.k;
    [-near, -far, near, far]
}

/// `residual_derivatives`: ∂r/∂P_c,k = φ'_c m_k + φ_c g_k, m_k = (σ/‖q‖) D_k · q,
/// g_k = (σ/‖q‖) q · (∂_k J_D) w; σ/‖q‖ = 0 unless ‖q‖ > 0 (decided: [`Real::decides_lt`]).
pub fn residual_derivatives<R: Real>(
    sigma: R,
    jacobian: &Jacobian<R>,
    w: V2<R>,
    phi: &[R; 4],
    dphi: &[R; 4],
) -> [R; 8] {
    let (d_s_k, d_t_k) = (jacobian.d_s, jacobian.d_t);
    let q = image(d_s_k.value, d_t_k.value, w);
    let q_length = norm(q);
    let zero = R::lit(0.0);
    let factor = if zero.decides_lt(q_length) {
        sigma / q_length
    } else {
        zero
    };
    let m = [factor * dot3(d_s_k.value, q), factor * dot3(d_t_k.value, q)];
    let g = [
        factor * dot3(q, image(d_s_k.ds, d_t_k.ds, w)),
        factor * dot3(q, image(d_s_k.dt, d_t_k.dt, w)),
    ];
    std::array::from_fn(|slot| {
        let (c, k) = (slot / 2, slot % 2);
        dphi[c] * m[k] + phi[c] * g[k]
    })
}

/// `NaaCellContribution`: one cell's F, Jᵀr and JᵀJ over its 8 slots, JᵀJ row-major 8 × 8.
#[derive(Clone, Copy, Debug)]
pub struct NaaCellContribution<R> {
    pub jtj: [R; 64],
    pub jtr: [R; 8],
    pub energy: R,
}

impl<R: Real> NaaCellContribution<R> {
    /// All zero (WGSL's `var out: NaaCellContribution;`).
    pub fn zero() -> Self {
        let zero = R::lit(0.0);
        NaaCellContribution {
            jtj: [zero; 64],
            jtr: [zero; 8],
            energy: zero,
        }
    }
}

/// `add_residual`: F += r², Jᵀr += d r, JᵀJ += d dᵀ over the 8 slots.
pub fn add_residual<R: Real>(out: &mut NaaCellContribution<R>, r: R, d: &[R; 8]) {
    out.energy = r * r + out.energy;
    for u in 0..8 {
        out.jtr[u] = d[u] * r + out.jtr[u];
        for v in 0..8 {
            out.jtj[8 * u + v] = d[u] * d[v] + out.jtj[8 * u + v];
        }
    }
}

/// `SampleResiduals`: r^s, r^t of one sample, and the warp and J_D their derivatives need.
#[derive(Clone, Copy, Debug)]
pub struct SampleResiduals<R> {
    pub r_s: R,
    pub r_t: R,
    pub warp: Warp<R>,
    pub jacobian: Jacobian<R>,
}

/// The deformed frame's fields D_s, D_t as the kernel reads them.
#[derive(Clone, Copy, Debug)]
pub struct Fields<'a, R> {
    pub d_s: VectorField<'a, R>,
    pub d_t: VectorField<'a, R>,
}

/// `sample_residuals`: (r^s, r^t) of one sample of `cell` warped onto `quad`.
pub fn sample_residuals<R: Real>(
    cell: &RestCell<R>,
    quad: &Corners<R>,
    sample: &RestSample<R>,
    fields: &Fields<R>,
) -> SampleResiduals<R> {
    let warp = bilinear_warp(quad, cell, sample.alpha, sample.beta);
    let jacobian = jacobian_at(&fields.d_s, &fields.d_t, warp.p);
    let q_s = image(jacobian.d_s.value, jacobian.d_t.value, warp.w_s);
    let q_t = image(jacobian.d_s.value, jacobian.d_t.value, warp.w_t);
    SampleResiduals {
        r_s: residual(sample.sigma, q_s, sample.o_s),
        r_t: residual(sample.sigma, q_t, sample.o_t),
        warp,
        jacobian,
    }
}

/// The body of `gridwarp_naa_cell`: the cell's contribution from its samples (σ = 0 skipped).
pub fn cell_contribution<R: Real>(
    cell: &RestCell<R>,
    quad: &Corners<R>,
    samples: &[RestSample<R>],
    fields: &Fields<R>,
) -> NaaCellContribution<R> {
    let mut out = NaaCellContribution::zero();
    for sample in samples {
        if sample.sigma.value() == 0.0 {
            continue;
        }
        let (alpha, beta) = (sample.alpha, sample.beta);
        let r = sample_residuals(cell, quad, sample, fields);
        let phi = corner_weights(alpha, beta);
        let d_s_slots = residual_derivatives(
            sample.sigma,
            &r.jacobian,
            r.warp.w_s,
            &phi,
            &corner_weight_slopes(0, cell, alpha, beta),
        );
        let d_t_slots = residual_derivatives(
            sample.sigma,
            &r.jacobian,
            r.warp.w_t,
            &phi,
            &corner_weight_slopes(1, cell, alpha, beta),
        );
        add_residual(&mut out, r.r_s, &d_s_slots);
        add_residual(&mut out, r.r_t, &d_t_slots);
    }
    out
}
