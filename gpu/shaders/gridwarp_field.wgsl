// The bilinear lookup of a gridwarp field with its gradient, shared by gridwarp_aa.wgsl and
// gridwarp_naa.wgsl (the host prepends it after dispatch.wgsl: WGSL has no includes). Twin of
// src/gridwarp/field.rs: `Axis::new` (here `axis`) and `bilinear_formula`, in the same order of
// operations (bilinear as two lerps along s, then one along t). Each kernel fetches its four
// texels itself (its fields live in its own bindings) and hands them to `bilinear_formula`.

// A bilinear sample and its gradient (∂/∂s, ∂/∂t): `Sample` of field.rs.
struct FieldSample {
    value: f32,
    ds: f32,
    dt: f32,
}

// `Axis` of field.rs: (lower texel centre index, fraction, du/ds = n or 0 where clamped).
// `!(u > 0)` also sends NaN to the first texel, as the reference does.
struct Axis {
    x0: u32,
    frac: f32,
    grad: f32,
}

fn axis(s: f32, n: u32) -> Axis {
    let u = s * f32(n) - 0.5;
    if n == 1u || !(u > 0.0) {
        return Axis(0u, 0.0, 0.0);
    }
    if u >= f32(n - 1u) {
        return Axis(n - 1u, 0.0, 0.0);
    }
    let x0 = floor(u);
    return Axis(u32(x0), u - x0, f32(n));
}

// `bilinear_formula`: the four texels [f00, f10, f01, f11] around a point at axis fractions
// (alpha, beta) with scales (grad_s, grad_t) = (du/ds, dv/dt), interpolated along s on the two
// texel rows, then along t between them, with the gradient (0 along a clamped axis).
fn bilinear_formula(
    alpha: f32,
    grad_s: f32,
    beta: f32,
    grad_t: f32,
    f00: f32,
    f10: f32,
    f01: f32,
    f11: f32,
) -> FieldSample {
    let along_0 = f10 - f00;
    let along_1 = f11 - f01;
    let f0 = f00 + alpha * along_0;
    let f1 = f01 + alpha * along_1;
    let across = f1 - f0;
    return FieldSample(
        f0 + beta * across,
        grad_s * (along_0 + beta * (along_1 - along_0)),
        grad_t * across,
    );
}
