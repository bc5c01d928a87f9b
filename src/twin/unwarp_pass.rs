//! Twin of `gpu/shaders/unwarp_pass.wgsl`, function for function: one phase pass of the
//! per-texel descent of distortion-free displacement mapping (seed 001: "massively parallel
//! gradient descent per texel — find the local optimum along the gradient line for each texel,
//! ternary line search"; notes `unwarp.md` § Energy, § Fixation, § One pass). The f64
//! reference is `unwarp::energy`, `unwarp::fixation` and `unwarp::pass`.
//!
//! Per active texel c, with F = F_c the node energy ([`node_energy`]): g = ∇F(o_c)
//! ([`node_gradient`]), the flip-free bracket of the step t along −g ([`flip_free_bracket`]),
//! the ternary search for the minimum of F(o_c − t g) on it ([`ternary_search`]), and the guard:
//! the step is kept only if it lowers F ([`descend_texel`]).
//!
//! Multi-term sums the WGSL writes as `a + b + c` (or accumulates in a loop) are [`sum`]s here:
//! a compiler may reassociate them, and [`Model::Reordered`](super::Model::Reordered) does.

// `!(a > 0.0)` is meant, as in the WGSL: a NaN takes the "no" branch.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::coverage::{branches, hit, taken, Branch};
use super::real::{abs, floor, max, min, sqrt, sum, Real, V2, V3};

/// The kernel's branches ([`super::coverage`]): every decision of one invocation.
pub const BRANCHES: &[Branch] = branches![
    "unwarp_pass.neighbour.wrapped" => "a neighbour across the border, its index wrapped mod W or mod H (periodic border)",
    "unwarp_pass.neighbour.inside" => "a neighbour inside the grid (no wrap)",
    "unwarp_pass.theta.integer" => "y^θ by square and multiply (θ an integer in [−64, 64])",
    "unwarp_pass.theta.pow" => "y^θ by pow(y, θ) (θ not an integer, or |θ| > 64)",
    "unwarp_pass.theta.negative" => "a negative integer power: 1/y^|θ|",
    "unwarp_pass.triangle.unfolded" => "a triangle with a > 0: E_T and ∇E_T by the formula",
    "unwarp_pass.triangle.folded" => "a triangle with a ≤ 0 (or NaN): E_T = +∞, ∇E_T = (+∞, +∞)",
    "unwarp_pass.pin.inside" => "q < 1: E_pin = ½/(1 − q)",
    "unwarp_pass.pin.outside" => "q ≥ 1: E_pin = +∞",
    "unwarp_pass.gradient.not_finite" => "g not finite (a folded start triangle): no move",
    "unwarp_pass.gradient.zero" => "g = (0, 0): no move",
    "unwarp_pass.bracket.behind" => "a triangle whose zero t0 = a/den is not > 0 (behind the start, or NaN when den = 0): ignored",
    "unwarp_pass.bracket.hi_by_triangle" => "t0 > 0 of an unfolded triangle: hi = min(hi, t0)",
    "unwarp_pass.bracket.lo_by_folded" => "t0 > 0 of a folded triangle: lo = max(lo, t0)",
    "unwarp_pass.root.none" => "no barrier root (α ≤ 0: w = 0 or g = 0; or γ ≥ 1)",
    "unwarp_pass.root.beta_nonnegative" => "the barrier root as (β + √…)/α (β ≥ 0)",
    "unwarp_pass.root.beta_negative" => "the barrier root as (1 − γ)/(√… − β) (β < 0)",
    "unwarp_pass.bracket.hi_by_root" => "the barrier's root below every triangle's t0: it sets hi",
    "unwarp_pass.bracket.found" => "lo < hi < ∞: the search runs",
    "unwarp_pass.bracket.empty" => "no bracket (lo ≥ hi or hi = ∞): no move",
    "unwarp_pass.search.lo_up" => "F(t1) > F(t2): lo = t1",
    "unwarp_pass.search.hi_down" => "F(t1) ≤ F(t2) (ties, NaN): hi = t2",
    "unwarp_pass.search.converged" => "the search stopped at hi − lo ≤ 1e−6·hi",
    "unwarp_pass.search.exhausted" => "the search stopped after its 31 iterations",
    "unwarp_pass.guard.moved" => "F(o − t g) < F(o): the step is taken",
    "unwarp_pass.guard.refused" => "F(o − t g) ≥ F(o): the offset is kept",
];

/// `SEARCH_ITERATIONS`: at most this many ternary-search iterations.
pub const SEARCH_ITERATIONS: u32 = 31;
/// `SEARCH_RELATIVE_WIDTH`: the search stops when hi − lo ≤ this × hi (an f32 literal).
pub const SEARCH_RELATIVE_WIDTH: f64 = 1e-6;

/// `STENCIL`: the 6 neighbour steps (dx, dy), counter-clockwise.
pub const STENCIL: [[i32; 2]; 6] = [[0, -1], [1, -1], [1, 0], [0, 1], [-1, 1], [-1, 0]];

/// `UnwarpParams` (without `count`, the length of the active list).
#[derive(Clone, Copy, Debug)]
pub struct UnwarpParams<R> {
    pub width: u32,
    pub height: u32,
    /// Wrap across the border; else the border ring is fixed (never active).
    pub periodic: bool,
    pub theta: R,
    /// R of the pin barrier: the finest level's (W, H).
    pub pin_resolution: V2<R>,
}

/// The kernel's bindings an invocation reads: `params`, `z` (s·h per node), `pins` (weight
/// per node) and `offsets` (per node, UV units), all row-major.
#[derive(Clone, Copy, Debug)]
pub struct Bindings<'a, R> {
    pub params: UnwarpParams<R>,
    pub z: &'a [R],
    pub pins: &'a [R],
    pub offsets: &'a [V2<R>],
}

/// `infinity()`: +∞.
pub fn infinity<R: Real>() -> R {
    R::lit(f64::INFINITY)
}

/// `TriangleGeometry`: what a triangle's energy needs of its 3D edges P1, P2.
#[derive(Clone, Copy, Debug)]
pub struct TriangleGeometry<R> {
    /// A = |P1 × P2|.
    pub area: R,
    /// P1·P2.
    pub c12: R,
    /// (P2 − P1)·P2.
    pub c11: R,
    /// P1·(P1 − P2).
    pub c22: R,
}

/// `triangle_geometry`: A = |P1 × P2|, P1·P2, (P2 − P1)·P2, P1·(P1 − P2).
pub fn triangle_geometry<R: Real>(p1: V3<R>, p2: V3<R>) -> TriangleGeometry<R> {
    let c = V3::new(
        p1.y * p2.z - p1.z * p2.y,
        p1.z * p2.x - p1.x * p2.z,
        p1.x * p2.y - p1.y * p2.x,
    );
    TriangleGeometry {
        area: sqrt(sum(&[c.x * c.x, c.y * c.y, c.z * c.z])),
        c12: sum(&[p1.x * p2.x, p1.y * p2.y, p1.z * p2.z]),
        c11: sum(&[
            (p2.x - p1.x) * p2.x,
            (p2.y - p1.y) * p2.y,
            (p2.z - p1.z) * p2.z,
        ]),
        c22: sum(&[
            p1.x * (p1.x - p2.x),
            p1.y * (p1.y - p2.y),
            p1.z * (p1.z - p2.z),
        ]),
    }
}

/// `uv_area`: a = U1.x U2.y − U2.x U1.y, twice the signed UV area.
pub fn uv_area<R: Real>(u1: V2<R>, u2: V2<R>) -> R {
    u1.x * u2.y - u2.x * u1.y
}

/// `dirichlet`: D = |U1 − U2|² (P1·P2) + |U1|² ((P2 − P1)·P2) + |U2|² (P1·(P1 − P2)).
pub fn dirichlet<R: Real>(t: &TriangleGeometry<R>, u1: V2<R>, u2: V2<R>) -> R {
    let u12 = u1 - u2;
    sum(&[
        (u12.x * u12.x + u12.y * u12.y) * t.c12,
        (u1.x * u1.x + u1.y * u1.y) * t.c11,
        (u2.x * u2.x + u2.y * u2.y) * t.c22,
    ])
}

/// WGSL's `fract(x)` = x − floor(x).
fn fract<R: Real>(x: R) -> R {
    x - floor(x)
}

/// `theta_power`: y^θ by square-and-multiply when θ is an integer in [−64, 64] (result ← result
/// · base for each set bit of |θ|, base ← base², from the lowest bit; 1/result for θ < 0), else
/// `pow(y, θ)`.
pub fn theta_power<R: Real>(y: R, theta: R) -> R {
    if taken(
        fract(theta).value() == 0.0 && abs(theta).value() <= 64.0,
        "unwarp_pass.theta.integer",
        "unwarp_pass.theta.pow",
    ) {
        let mut n = abs(theta).value() as u32;
        let mut base = y;
        let mut result = R::lit(1.0);
        while n != 0 {
            if n & 1 == 1 {
                result = result * base;
            }
            base = base * base;
            n >>= 1;
        }
        if theta.value() < 0.0 {
            hit("unwarp_pass.theta.negative");
            return R::lit(1.0) / result;
        }
        return result;
    }
    super::real::pow(y, theta)
}

/// `triangle_energy`: E_T = D/(A a) · (A/a + a/A)^θ, +∞ when a ≤ 0 (or NaN).
pub fn triangle_energy<R: Real>(t: &TriangleGeometry<R>, u1: V2<R>, u2: V2<R>, theta: R) -> R {
    let a = uv_area(u1, u2);
    if !taken(
        a.value() > 0.0,
        "unwarp_pass.triangle.unfolded",
        "unwarp_pass.triangle.folded",
    ) {
        return infinity();
    }
    let d = dirichlet(t, u1, u2);
    let y = t.area / a + a / t.area;
    d / (t.area * a) * theta_power(y, theta)
}

/// `triangle_gradient`: with r = ∇a = (U2.y − U1.y, U1.x − U2.x),
/// ∇D = 2[U1 ((P2 − P1)·P2) + U2 (P1·(P1 − P2))] and Y = A/a + a/A,
/// ∇E_T = Y^θ [−D/(A a²) r + ∇D/(A a)] + D/(A a) · θ Y^{θ−1} (1/A − A/a²) r;
/// (+∞, +∞) when a ≤ 0 (or NaN).
pub fn triangle_gradient<R: Real>(
    t: &TriangleGeometry<R>,
    u1: V2<R>,
    u2: V2<R>,
    theta: R,
) -> V2<R> {
    let a = uv_area(u1, u2);
    if !taken(
        a.value() > 0.0,
        "unwarp_pass.triangle.unfolded",
        "unwarp_pass.triangle.folded",
    ) {
        return V2::splat(infinity());
    }
    let two = R::lit(2.0);
    let big_a = t.area;
    let r = V2::new(u2.y - u1.y, u1.x - u2.x);
    let d = dirichlet(t, u1, u2);
    let grad_d = V2::new(
        two * (u1.x * t.c11 + u2.x * t.c22),
        two * (u1.y * t.c11 + u2.y * t.c22),
    );
    let y = big_a / a + a / big_a;
    let y_theta_m1 = theta_power(y, theta - R::lit(1.0));
    let y_theta = y_theta_m1 * y;
    let mips = d / (big_a * a);
    let r_coef = -d / (big_a * a * a) * y_theta
        + mips * theta * y_theta_m1 * (R::lit(1.0) / big_a - big_a / (a * a));
    let d_coef = y_theta / (big_a * a);
    V2::new(
        r_coef * r.x + d_coef * grad_d.x,
        r_coef * r.y + d_coef * grad_d.y,
    )
}

/// `Fan`: the six triangles T_k = (c, n_{k−1}, n_k) around a node, their geometry and, per
/// neighbour n_k, the constant part of the UV edge: U_k = o_c + rel_k, rel_k = −d_k/R − o_{n_k}.
#[derive(Clone, Copy, Debug)]
pub struct Fan<R> {
    pub geometry: [TriangleGeometry<R>; 6],
    pub rel: [V2<R>; 6],
}

/// `neighbour`: the node one stencil step k from (x, y), wrapped across the border (with a
/// fixed border the active texels are interior, so the wrap never applies).
pub fn neighbour(params: &UnwarpParams<impl Real>, x: u32, y: u32, k: usize) -> usize {
    let (w, h) = (params.width as i64, params.height as i64);
    let (sx, sy) = (
        i64::from(x) + i64::from(STENCIL[k][0]),
        i64::from(y) + i64::from(STENCIL[k][1]),
    );
    taken(
        sx < 0 || sx >= w || sy < 0 || sy >= h,
        "unwarp_pass.neighbour.wrapped",
        "unwarp_pass.neighbour.inside",
    );
    let nx = sx.rem_euclid(w);
    let ny = sy.rem_euclid(h);
    (ny * w + nx) as usize
}

/// `fan_new`: P_k = (−d_k/R, z_c − z_{n_k}) with R = (W, H) of this grid, rel_k = −d_k/R −
/// o_{n_k}, geometry_k = `triangle_geometry(P_{k−1}, P_k)`.
pub fn fan_new<R: Real>(b: &Bindings<R>, x: u32, y: u32) -> Fan<R> {
    let p = &b.params;
    let resolution = V2::new(R::lit(f64::from(p.width)), R::lit(f64::from(p.height)));
    let c = (y * p.width + x) as usize;
    let mut edges = [V3::splat(R::lit(0.0)); 6];
    let mut rel = [V2::splat(R::lit(0.0)); 6];
    for k in 0..6 {
        let n = neighbour(p, x, y, k);
        let base = V2::new(
            -R::lit(f64::from(STENCIL[k][0])) / resolution.x,
            -R::lit(f64::from(STENCIL[k][1])) / resolution.y,
        );
        edges[k] = V3::new(base.x, base.y, b.z[c] - b.z[n]);
        rel[k] = base - b.offsets[n];
    }
    Fan {
        geometry: std::array::from_fn(|k| triangle_geometry(edges[(k + 5) % 6], edges[k])),
        rel,
    }
}

/// `triangles_energy`: Σ_k E_{T_k} with the centre at offset o (k = 0…5, reassociable).
pub fn triangles_energy<R: Real>(fan: &Fan<R>, o: V2<R>, theta: R) -> R {
    let u: [V2<R>; 6] = std::array::from_fn(|k| o + fan.rel[k]);
    let terms: [R; 6] =
        std::array::from_fn(|k| triangle_energy(&fan.geometry[k], u[(k + 5) % 6], u[k], theta));
    sum(&terms)
}

/// `triangles_gradient`: Σ_k ∇E_{T_k} with the centre at offset o (k = 0…5, reassociable).
pub fn triangles_gradient<R: Real>(fan: &Fan<R>, o: V2<R>, theta: R) -> V2<R> {
    let u: [V2<R>; 6] = std::array::from_fn(|k| o + fan.rel[k]);
    let terms: [V2<R>; 6] =
        std::array::from_fn(|k| triangle_gradient(&fan.geometry[k], u[(k + 5) % 6], u[k], theta));
    V2::sum(&terms)
}

/// `pin_q`: q = ‖w R⊙o‖² (R⊙o: the offset in texels of the finest level).
pub fn pin_q<R: Real>(weight: R, resolution: V2<R>, o: V2<R>) -> R {
    let t = resolution * weight * o;
    t.x * t.x + t.y * t.y
}

/// `pin_energy`: E_pin = ½ / (1 − q), +∞ when q ≥ 1 (seed: "fixation energy").
pub fn pin_energy<R: Real>(weight: R, resolution: V2<R>, o: V2<R>) -> R {
    let q = pin_q(weight, resolution, o);
    if taken(
        q.value() < 1.0,
        "unwarp_pass.pin.inside",
        "unwarp_pass.pin.outside",
    ) {
        return R::lit(0.5) / (R::lit(1.0) - q);
    }
    infinity()
}

/// `pin_gradient`: ∇E_pin = ½ ∇q / (1 − q)², ∇q = 2 w² (W² o.x, H² o.y).
pub fn pin_gradient<R: Real>(weight: R, resolution: V2<R>, o: V2<R>) -> V2<R> {
    let q = pin_q(weight, resolution, o);
    let one = R::lit(1.0);
    let s = R::lit(0.5) / ((one - q) * (one - q));
    let w2 = weight * weight;
    let two = R::lit(2.0);
    V2::new(
        s * two * w2 * resolution.x * resolution.x * o.x,
        s * two * w2 * resolution.y * resolution.y * o.y,
    )
}

/// `pin_root`: the positive root t of q(o − t g) = 1, i.e. of α t² − 2β t − (1 − γ) = 0 with
/// α = w² Σ Rᵢ² gᵢ², β = w² Σ Rᵢ² oᵢ gᵢ, γ = q(o): (β + √(β² + α(1 − γ)))/α, as
/// (1 − γ)/(√… − β) when β < 0 (no cancellation); −1 when there is none (w = 0, g = 0, or the
/// start outside the barrier).
pub fn pin_root<R: Real>(weight: R, resolution: V2<R>, o: V2<R>, g: V2<R>) -> R {
    let one = R::lit(1.0);
    let w2 = weight * weight;
    let rx2 = resolution.x * resolution.x;
    let ry2 = resolution.y * resolution.y;
    let alpha = w2 * (rx2 * g.x * g.x + ry2 * g.y * g.y);
    let beta = w2 * (rx2 * o.x * g.x + ry2 * o.y * g.y);
    let gamma = pin_q(weight, resolution, o);
    if !(alpha.value() > 0.0) || !(gamma.value() < 1.0) {
        hit("unwarp_pass.root.none");
        return -one;
    }
    let disc = sqrt(beta * beta + alpha * (one - gamma));
    if taken(
        beta.value() >= 0.0,
        "unwarp_pass.root.beta_nonnegative",
        "unwarp_pass.root.beta_negative",
    ) {
        return (beta + disc) / alpha;
    }
    (one - gamma) / (disc - beta)
}

/// `node_energy`: F_c(o) = Σ_k E_{T_k} + E_pin(o).
pub fn node_energy<R: Real>(fan: &Fan<R>, weight: R, resolution: V2<R>, o: V2<R>, theta: R) -> R {
    triangles_energy(fan, o, theta) + pin_energy(weight, resolution, o)
}

/// `node_gradient`: ∇F_c(o) = Σ_k ∇E_{T_k} + ∇E_pin(o).
pub fn node_gradient<R: Real>(
    fan: &Fan<R>,
    weight: R,
    resolution: V2<R>,
    o: V2<R>,
    theta: R,
) -> V2<R> {
    triangles_gradient(fan, o, theta) + pin_gradient(weight, resolution, o)
}

/// `line_point`: o − t g.
pub fn line_point<R: Real>(o: V2<R>, g: V2<R>, t: R) -> V2<R> {
    V2::new(o.x - t * g.x, o.y - t * g.y)
}

/// `cross2`: a.x b.y − b.x a.y.
pub fn cross2<R: Real>(a: V2<R>, b: V2<R>) -> R {
    a.x * b.y - b.x * a.y
}

/// `flip_free_bracket`: (lo, hi, found). Each triangle's signed UV area is linear in the step,
/// a_k(t) = a_k − t den_k with den_k = U1×g + g×U2, zero at t0_k = a_k/den_k; from [0, ∞), for
/// t0_k > 0 an unfolded triangle (a_k > 0) sets hi = min(hi, t0_k), a folded one lo = max(lo,
/// t0_k); the pin barrier's root ([`pin_root`]), when positive, bounds hi. found (1) when
/// lo < hi < ∞, else 0.
pub fn flip_free_bracket<R: Real>(
    fan: &Fan<R>,
    weight: R,
    resolution: V2<R>,
    o: V2<R>,
    g: V2<R>,
) -> V3<R> {
    let mut lo = R::lit(0.0);
    let mut hi = infinity();
    for k in 0..6 {
        let u1 = o + fan.rel[(k + 5) % 6];
        let u2 = o + fan.rel[k];
        let a = uv_area(u1, u2);
        let den = cross2(u1, g) + cross2(g, u2);
        let t0 = a / den;
        if t0.value() > 0.0 {
            if taken(
                a.value() > 0.0,
                "unwarp_pass.bracket.hi_by_triangle",
                "unwarp_pass.bracket.lo_by_folded",
            ) {
                hi = min(hi, t0);
            } else {
                lo = max(lo, t0);
            }
        } else {
            hit("unwarp_pass.bracket.behind");
        }
    }
    let root = pin_root(weight, resolution, o, g);
    if root.value() > 0.0 {
        if root.value() < hi.value() {
            hit("unwarp_pass.bracket.hi_by_root");
        }
        hi = min(hi, root);
    }
    let found = taken(
        lo.value() < hi.value() && hi.value() < f64::INFINITY,
        "unwarp_pass.bracket.found",
        "unwarp_pass.bracket.empty",
    );
    V3::new(lo, hi, R::lit(if found { 1.0 } else { 0.0 }))
}

/// `Search`: the step, the path (bit i: iteration i moved lo up) and the iterations done.
#[derive(Clone, Copy, Debug)]
pub struct Search<R> {
    pub t: R,
    pub path: u32,
    pub steps: u32,
}

/// `ternary_search` on [lo, hi] of F(t) = `energy(t)` (the WGSL passes the fan, weight, R, o,
/// g, θ and evaluates `node_energy(…, line_point(o, g, t), θ)`): at most
/// [`SEARCH_ITERATIONS`] iterations while hi − lo > 1e−6·hi; third = (hi − lo)/3, t1 = lo +
/// third, t2 = hi − third; F(t1) > F(t2) → lo = t1 (path bit i), else hi = t2 (ties and NaN
/// shrink toward lo); t = ½(lo + hi).
pub fn ternary_search<R: Real>(energy: impl Fn(R) -> R, lo_in: R, hi_in: R) -> Search<R> {
    let (mut lo, mut hi) = (lo_in, hi_in);
    let (mut path, mut steps) = (0u32, 0u32);
    let mut converged = false;
    for i in 0..SEARCH_ITERATIONS {
        if (hi - lo).value() <= (R::lit(SEARCH_RELATIVE_WIDTH) * hi).value() {
            converged = true;
            break;
        }
        let third = (hi - lo) / R::lit(3.0);
        let t1 = lo + third;
        let t2 = hi - third;
        if taken(
            energy(t1).value() > energy(t2).value(),
            "unwarp_pass.search.lo_up",
            "unwarp_pass.search.hi_down",
        ) {
            lo = t1;
            path |= 1 << i;
        } else {
            hi = t2;
        }
        steps += 1;
    }
    hit(if converged {
        "unwarp_pass.search.converged"
    } else {
        "unwarp_pass.search.exhausted"
    });
    Search {
        t: R::lit(0.5) * (lo + hi),
        path,
        steps,
    }
}

/// Bit of [`TexelResult::flags`]: the guard accepted the step.
pub const FLAG_MOVED: u32 = 1 << 8;
/// Bit of [`TexelResult::flags`]: a flip-free bracket was found.
pub const FLAG_BRACKET: u32 = 1 << 9;

/// `TexelResult`: the new offset, the search path, flags (bits 0–7: search steps;
/// [`FLAG_MOVED`]; [`FLAG_BRACKET`]).
#[derive(Clone, Copy, Debug)]
pub struct TexelResult<R> {
    pub offset: V2<R>,
    pub path: u32,
    pub flags: u32,
}

/// `descend_texel`: g = ∇F(o); no move when g is not finite or zero, or there is no bracket;
/// else the ternary search on the bracket and the guard: the step to o − t g is taken only if
/// F(o − t g) < F(o).
pub fn descend_texel<R: Real>(b: &Bindings<R>, x: u32, y: u32) -> TexelResult<R> {
    let p = &b.params;
    let c = (y * p.width + x) as usize;
    let o = b.offsets[c];
    let weight = b.pins[c];
    let resolution = p.pin_resolution;
    let theta = p.theta;
    let fan = fan_new(b, x, y);
    let g = node_gradient(&fan, weight, resolution, o, theta);
    let mut result = TexelResult {
        offset: o,
        path: 0,
        flags: 0,
    };
    let finite = abs(g.x).value() < f64::INFINITY && abs(g.y).value() < f64::INFINITY;
    if !finite {
        hit("unwarp_pass.gradient.not_finite");
        return result;
    }
    if g.x.value() == 0.0 && g.y.value() == 0.0 {
        hit("unwarp_pass.gradient.zero");
        return result;
    }
    let bracket = flip_free_bracket(&fan, weight, resolution, o, g);
    if bracket.z.value() == 0.0 {
        return result;
    }
    result.flags = FLAG_BRACKET;
    let energy = |t: R| node_energy(&fan, weight, resolution, line_point(o, g, t), theta);
    let search = ternary_search(energy, bracket.x, bracket.y);
    result.path = search.path;
    result.flags |= search.steps;
    if taken(
        energy(search.t).value() < energy(R::lit(0.0)).value(),
        "unwarp_pass.guard.moved",
        "unwarp_pass.guard.refused",
    ) {
        result.offset = line_point(o, g, search.t);
        result.flags |= FLAG_MOVED;
    }
    result
}

/// The body of the entry point `unwarp_pass` for active node c (row-major index): the texel
/// (c mod W, c div W) descends ([`descend_texel`]).
pub fn unwarp_pass_invocation<R: Real>(b: &Bindings<R>, c: usize) -> TexelResult<R> {
    let w = b.params.width;
    descend_texel(b, c as u32 % w, c as u32 / w)
}

/// The dispatch `unwarp_pass` over the active nodes in order, with `body` per invocation
/// ([`unwarp_pass_invocation`], or a port's): each writes its new offset in place and its
/// result (texels of one phase share no triangle, so the order does not matter).
pub fn unwarp_pass<R: Real>(
    params: UnwarpParams<R>,
    z: &[R],
    pins: &[R],
    active: &[usize],
    offsets: &mut [V2<R>],
    body: impl Fn(&Bindings<R>, usize) -> TexelResult<R>,
) -> Vec<TexelResult<R>> {
    let mut results = Vec::with_capacity(active.len());
    for &c in active {
        let b = Bindings {
            params,
            z,
            pins,
            offsets,
        };
        let r = super::coverage::invocation(|| body(&b, c));
        offsets[c] = r.offset;
        results.push(r);
    }
    results
}
