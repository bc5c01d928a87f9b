//! Twin of `gpu/shaders/gridwarp_aa.wgsl` (and of the residuals `gridwarp_aa_residuals.wgsl`
//! shares, and of the bilinear lookup of `gridwarp_field.wgsl`, which `gridwarp_naa.wgsl`
//! shares too: [`axis`], [`bilinear_formula`]), function for function: the axis-aligned energy's residuals r^s = σ(c_s a − o_s),
//! r^t = σ(c_t b − o_t) of one sample (seed 000 §5.1), the stretches c sampled bilinearly
//! from the fields ‖D_s‖, ‖D_t‖ at the warped point, their derivatives with respect to the
//! cell's four lines, and each cell's share of F, Jᵀr and JᵀJ (the host adds the cells in f64).

use super::real::{floor, Real, V2};

/// `Axis`: the lower texel centre index, the fraction, and du/ds (n, or 0 where clamped).
#[derive(Clone, Copy, Debug)]
pub struct Axis<R> {
    pub x0: usize,
    pub frac: R,
    pub grad: R,
}

/// `axis`: u = s·n − ½ clamped to the texel centres; `!(u > 0)` also sends NaN to the first
/// texel.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(u > 0)` is meant: NaN goes to texel 0
pub fn axis<R: Real>(s: R, n: usize) -> Axis<R> {
    let u = s * R::lit(n as f64) - R::lit(0.5);
    let zero = R::lit(0.0);
    if n == 1 || !(u.value() > 0.0) {
        return Axis {
            x0: 0,
            frac: zero,
            grad: zero,
        };
    }
    if u.value() >= (n - 1) as f64 {
        return Axis {
            x0: n - 1,
            frac: zero,
            grad: zero,
        };
    }
    let x0 = floor(u);
    Axis {
        x0: x0.value() as usize,
        frac: u - x0,
        grad: R::lit(n as f64),
    }
}

/// A field of `width × height` values, row-major, row 0 at t = 0.
pub struct Field<'a, R> {
    pub values: &'a [R],
    pub width: usize,
    pub height: usize,
}

/// `FieldSample`: a bilinear sample and its gradient (∂/∂s, ∂/∂t).
#[derive(Clone, Copy, Debug)]
pub struct FieldSample<R> {
    pub value: R,
    pub ds: R,
    pub dt: R,
}

/// `bilinear_formula` (gridwarp_field.wgsl): the four texels [f00, f10, f01, f11] around a
/// point at the axes `ax`, `ay`, along s on the two texel rows, then along t between them,
/// with the gradient (0 along an axis where the lookup is clamped).
pub fn bilinear_formula<R: Real>(
    ax: &Axis<R>,
    ay: &Axis<R>,
    [f00, f10, f01, f11]: [R; 4],
) -> FieldSample<R> {
    let along_0 = f10 - f00;
    let along_1 = f11 - f01;
    let f0 = f00 + ax.frac * along_0;
    let f1 = f01 + ax.frac * along_1;
    let across = f1 - f0;
    FieldSample {
        value: f0 + ay.frac * across,
        ds: ax.grad * (along_0 + ay.frac * (along_1 - along_0)),
        dt: ay.grad * across,
    }
}

/// `field_bilinear`: [`bilinear_formula`] on the four texels of `f` around (s, t).
pub fn field_bilinear_sample<R: Real>(f: &Field<R>, s: R, t: R) -> FieldSample<R> {
    let ax = axis(s, f.width);
    let ay = axis(t, f.height);
    let x1 = (ax.x0 + 1).min(f.width - 1);
    let y1 = (ay.x0 + 1).min(f.height - 1);
    let at = |x: usize, y: usize| f.values[y * f.width + x];
    bilinear_formula(
        &ax,
        &ay,
        [at(ax.x0, ay.x0), at(x1, ay.x0), at(ax.x0, y1), at(x1, y1)],
    )
}

/// `field_bilinear`'s value.
pub fn field_bilinear<R: Real>(f: &Field<R>, s: R, t: R) -> R {
    field_bilinear_sample(f, s, t).value
}

/// `slope`: (far − near) / rest width.
pub fn slope<R: Real>(near: R, far: R, rest_width: R) -> R {
    (far - near) / rest_width
}

/// `warped_point`: p = (s_i + α(s_{i+1} − s_i), t_j + β(t_{j+1} − t_j)).
pub fn warped_point<R: Real>(s0: R, s1: R, t0: R, t1: R, alpha: R, beta: R) -> V2<R> {
    V2::new(s0 + alpha * (s1 - s0), t0 + beta * (t1 - t0))
}

/// `residual`: r = σ (c a − o), c a − o as one fused multiply-add in WGSL (a model without
/// fusion rounds twice: the bound covers both).
pub fn residual<R: Real>(sigma: R, c: R, a: R, o: R) -> R {
    sigma * (c * a - o)
}

/// One sample of a cell: its position in the cell, σ and the rest stretches.
#[derive(Clone, Copy, Debug)]
pub struct RestSample<R> {
    pub alpha: R,
    pub beta: R,
    pub sigma: R,
    pub o_s: R,
    pub o_t: R,
}

/// The cell's four lines and rest size.
#[derive(Clone, Copy, Debug)]
pub struct CellLines<R> {
    pub s0: R,
    pub s1: R,
    pub t0: R,
    pub t1: R,
    pub h: R,
    pub k: R,
}

/// `sample_residuals`: (r^s, r^t) of one sample.
pub fn sample_residuals<R: Real>(
    l: &CellLines<R>,
    sample: &RestSample<R>,
    d_s: &Field<R>,
    d_t: &Field<R>,
) -> [R; 2] {
    let a = slope(l.s0, l.s1, l.h);
    let b = slope(l.t0, l.t1, l.k);
    let p = warped_point(l.s0, l.s1, l.t0, l.t1, sample.alpha, sample.beta);
    let c_s = field_bilinear(d_s, p.x, p.y);
    let c_t = field_bilinear(d_t, p.x, p.y);
    [
        residual(sample.sigma, c_s, a, sample.o_s),
        residual(sample.sigma, c_t, b, sample.o_t),
    ]
}

/// `line_derivatives`: the derivatives of r = σ (c a − o) with respect to the near and far
/// lines along the residual's axis and across it, [near along, far along, near across, far
/// across], from u = σ a ∂c/∂along, v = σ c / h, w = σ a ∂c/∂across.
#[allow(clippy::too_many_arguments)] // the kernel's eight arguments, named as in the WGSL
pub fn line_derivatives<R: Real>(
    sigma: R,
    c: R,
    dc_along: R,
    dc_across: R,
    a: R,
    rest_width: R,
    along: R,
    across: R,
) -> [R; 4] {
    let one = R::lit(1.0);
    let sigma_a = sigma * a;
    let u = sigma_a * dc_along;
    let v = (sigma / rest_width) * c;
    let w = sigma_a * dc_across;
    [
        u * (one - along) - v,
        u * along + v,
        w * (one - across),
        w * across,
    ]
}

/// `CellContribution`: one cell's F, Jᵀr and JᵀJ over its four slots (s_i, s_{i+1}, t_j,
/// t_{j+1}), JᵀJ row-major 4 × 4.
#[derive(Clone, Copy, Debug)]
pub struct CellContribution<R> {
    pub jtj: [R; 16],
    pub jtr: [R; 4],
    pub energy: R,
}

/// `add_residual`: F += r², Jᵀr += d r, JᵀJ += d dᵀ.
pub fn add_residual<R: Real>(out: &mut CellContribution<R>, r: R, d: [R; 4]) {
    out.energy = r * r + out.energy;
    for u in 0..4 {
        out.jtr[u] = d[u] * r + out.jtr[u];
        for v in 0..4 {
            out.jtj[4 * u + v] = d[u] * d[v] + out.jtj[4 * u + v];
        }
    }
}

/// The body of `gridwarp_aa_cell`: the cell's contribution from its samples (σ = 0 skipped).
pub fn cell_contribution<R: Real>(
    l: &CellLines<R>,
    samples: &[RestSample<R>],
    d_s: &Field<R>,
    d_t: &Field<R>,
) -> CellContribution<R> {
    let zero = R::lit(0.0);
    let mut out = CellContribution {
        jtj: [zero; 16],
        jtr: [zero; 4],
        energy: zero,
    };
    let a = slope(l.s0, l.s1, l.h);
    let b = slope(l.t0, l.t1, l.k);
    for sample in samples {
        if sample.sigma.value() == 0.0 {
            continue;
        }
        let p = warped_point(l.s0, l.s1, l.t0, l.t1, sample.alpha, sample.beta);
        let c_s = field_bilinear_sample(d_s, p.x, p.y);
        let c_t = field_bilinear_sample(d_t, p.x, p.y);
        let r_s = residual(sample.sigma, c_s.value, a, sample.o_s);
        let r_t = residual(sample.sigma, c_t.value, b, sample.o_t);
        let (alpha, beta, sigma) = (sample.alpha, sample.beta, sample.sigma);
        // r^s stretches along s: its lines along are s_i, s_{i+1} (slots 0, 1).
        let d_s_lines = line_derivatives(sigma, c_s.value, c_s.ds, c_s.dt, a, l.h, alpha, beta);
        // r^t stretches along t: its lines along are t_j, t_{j+1} (slots 2, 3).
        let d_t_lines = line_derivatives(sigma, c_t.value, c_t.dt, c_t.ds, b, l.k, beta, alpha);
        add_residual(&mut out, r_s, d_s_lines);
        add_residual(
            &mut out,
            r_t,
            [d_t_lines[2], d_t_lines[3], d_t_lines[0], d_t_lines[1]],
        );
    }
    out
}
