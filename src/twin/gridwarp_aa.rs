//! Twin of `gpu/shaders/gridwarp_aa.wgsl`'s residuals (`gridwarp_aa_residuals.wgsl` shares
//! them), function for function: the axis-aligned energy's residuals r^s = σ(c_s a − o_s),
//! r^t = σ(c_t b − o_t) of one sample (seed 000 §5.1), the stretches c sampled bilinearly
//! from the fields ‖D_s‖, ‖D_t‖ at the warped point.

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

/// `field_bilinear`'s value (the gradient is not needed by the residuals): along s on the two
/// texel rows, then along t between them.
pub fn field_bilinear<R: Real>(f: &Field<R>, s: R, t: R) -> R {
    let ax = axis(s, f.width);
    let ay = axis(t, f.height);
    let x1 = (ax.x0 + 1).min(f.width - 1);
    let y1 = (ay.x0 + 1).min(f.height - 1);
    let at = |x: usize, y: usize| f.values[y * f.width + x];
    let along_0 = at(x1, ay.x0) - at(ax.x0, ay.x0);
    let along_1 = at(x1, y1) - at(ax.x0, y1);
    let f0 = at(ax.x0, ay.x0) + ax.frac * along_0;
    let f1 = at(ax.x0, y1) + ax.frac * along_1;
    f0 + ay.frac * (f1 - f0)
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
