//! The bound on one `unwarp_pass` step: how far a conforming f32 pass may land from the f64
//! reference's step at one texel ([`step_bound`](crate::crosscheck::unwarp_bound::step_bound)), from the same state.
//!
//! The f32 pass runs the reference's algorithm (gradient, flip-free bracket, ternary search,
//! guard: [`crate::unwarp::pass`]) on values that differ from the reference's by roundings. Its
//! comparisons F(t1) > F(t2) therefore agree with the reference's only where the two energies
//! differ by more than both evaluations' errors; where they do not, the f32 search may keep the
//! other sub-bracket. On a rough height map the line function is not unimodal, and a search that
//! once kept the other sub-bracket may end in another local minimum, far from the reference's
//! (seen on `spot_texture.png` used as a height map: the f32 step found a lower minimum
//! 3.3× the old bound away). The bound therefore follows every search path a conforming pass
//! can take ([`reachable_steps`](crate::crosscheck::unwarp_bound::reachable_steps)), not only the reference's.

use crate::unwarp::energy::{
    node_energy, node_gradient, triangle_energy, triangle_gradient, uv_area, Fan, TriangleGeometry,
};
use crate::unwarp::fixation::{pin_energy, pin_gradient};
use crate::unwarp::pass::{
    descend_texel_traced, line_point, SEARCH_ITERATIONS, SEARCH_RELATIVE_WIDTH,
};
use crate::unwarp::Problem;

/// The size u of one rounding: [`super::WGSL_U`] = 2⁻²³ (WGSL rounds up or down).
pub const U32: f64 = super::WGSL_U;

/// Relative error of one f32 evaluation of a triangle's energy or gradient term, its UV area's
/// cancellation aside ([`triangle_relative_error`] adds that): each triangle is a chain of
/// ≈ 30 roundings (edges, a, D, Y, Y^5 by 3 multiplications, the quotient): η ≈ 30 u.
pub const ETA: f64 = 30.0 * U32;

/// [`step_bound`] in one line, for the cross-check's table and the conformance vectors'
/// manifest.
pub const STEP_BOUND_FORMULA: &str =
    "max |t − t*| |g| over the steps t a conforming f32 search can reach (every comparison \
     within the evaluations' errors taken both ways, moved by the f32 bracket ends' error) + \
     2|Δg| t_max + guard s + 1e-6 hi|g|; where the f32 bracket's ends may move by more than \
     1/8 of it: min(max(t*, hi'_max − t*)|g| + hi'_max|Δg|, s + max_k |U_k|); where f64 finds \
     no step: √(4ηF/λ_min) at a stationary node, else max_k |U_k|";

/// The absolute rounding errors e_k of the fan's UV edges o + rel_k as f32 forms them:
/// e_k = u(|o|∞ + |rel_k|∞).
pub fn uv_edge_errors(fan: &Fan, o: [f64; 2]) -> [f64; 6] {
    let o_size = o[0].abs().max(o[1].abs());
    std::array::from_fn(|k| U32 * (o_size + fan.rel[k][0].abs().max(fan.rel[k][1].abs())))
}

/// The absolute error δa of the f32 UV area a = U1 × U2 of UV edges with errors e1, e2:
/// δa = u(|U1x U2y| + |U2x U1y| + |a|) + e2|U1|₁ + e1|U2|₁.
pub fn uv_area_error(u1: [f64; 2], u2: [f64; 2], e1: f64, e2: f64) -> f64 {
    U32 * ((u1[0] * u2[1]).abs() + (u2[0] * u1[1]).abs() + uv_area(u1, u2).abs())
        + e2 * (u1[0].abs() + u1[1].abs())
        + e1 * (u2[0].abs() + u2[1].abs())
}

/// The relative error of one f32 evaluation of triangle T's energy E_T (and of its gradient
/// term) at UV edges U1, U2, whose components carry absolute errors e1, e2 (their own
/// rounding, o + rel_k):
///
/// η_T = η + c_a · δa/|a|, with δa ([`uv_area_error`]) the error of the UV area a = U1 × U2 (large where the cross product cancels: a nearly folded
/// triangle), and c_a = |∂ln E/∂ln a| = |−1 + θ (a/A − A/a)/(a/A + A/a)| its effect on E
/// (1 at an undistorted triangle, θ + 1 near a fold). ∞ for a folded triangle (E = ∞).
pub fn triangle_relative_error(
    t: &TriangleGeometry,
    u1: [f64; 2],
    u2: [f64; 2],
    e1: f64,
    e2: f64,
    theta: f64,
) -> f64 {
    let a = uv_area(u1, u2);
    if !(a > 0.0) {
        return f64::INFINITY;
    }
    let delta_a = uv_area_error(u1, u2, e1, e2);
    let (r, big) = (a / t.area, t.area / a);
    let c_a = (-1.0 + theta * (r - big) / (r + big)).abs();
    ETA + c_a * delta_a / a
}

/// The relative error δ of 1 − q as f32 computes it at offset p: q = ‖w R⊙p‖² carries ≈ 6u
/// relatively (its 4 roundings and the point's own, squared), which 1 − q magnifies by
/// q/(1 − q) near the barrier: δ = 6u q/(1 − q); ∞ outside (q ≥ 1).
pub fn pin_cancellation(weight: f64, resolution: [f64; 2], p: [f64; 2]) -> f64 {
    let q = crate::unwarp::fixation::pin_q(weight, resolution, p);
    if q < 1.0 {
        6.0 * U32 * q / (1.0 - q)
    } else {
        f64::INFINITY
    }
}

/// The relative error of one f32 evaluation of the pin barrier E_pin = ½/(1 − q) at offset p:
/// with 1 − q off by a factor 1 ± δ ([`pin_cancellation`]), ½/(1 − q) is off by at most
/// 1/(1 − δ) − 1 = δ/(1 − δ), plus the quotient's own roundings: η + δ/(1 − δ); ∞ once δ ≥ 1
/// (f32 may find the point on or past the barrier).
pub fn pin_relative_error(weight: f64, resolution: [f64; 2], p: [f64; 2]) -> f64 {
    let delta = pin_cancellation(weight, resolution, p);
    if delta < 1.0 {
        ETA + delta / (1.0 - delta)
    } else {
        f64::INFINITY
    }
}

/// The relative error of one f32 evaluation of ∇E_pin = ½∇q/(1 − q)²: 1/(1 − δ)² − 1 from the
/// squared 1 − q ([`pin_cancellation`]; ≈ 2δ for small δ), plus η; ∞ once δ ≥ 1.
pub fn pin_gradient_relative_error(weight: f64, resolution: [f64; 2], p: [f64; 2]) -> f64 {
    let delta = pin_cancellation(weight, resolution, p);
    if delta < 1.0 {
        ETA + 1.0 / ((1.0 - delta) * (1.0 - delta)) - 1.0
    } else {
        f64::INFINITY
    }
}

/// The texel's line search as a conforming f32 pass runs it, with the error allowances of
/// [`step_bound`]: the fan and pin at offset o, the f64 gradient g (|g| = `gn`), the f32
/// gradient's absolute error `dg`, and the f32 bracket ends' absolute error `dt0`.
struct LineModel<'a> {
    fan: &'a Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    g: [f64; 2],
    gn: f64,
    theta: f64,
    dg: f64,
    dt0: f64,
    hi: f64,
}

impl LineModel<'_> {
    /// F(o − t g).
    fn energy(&self, t: f64) -> f64 {
        node_energy(
            self.fan,
            self.weight,
            self.resolution,
            line_point(self.o, self.g, t),
            self.theta,
        )
    }

    /// The absolute f32 evaluation error of F at p: Σ_k η_{T_k}|E_{T_k}| + η_pin E_pin, the UV
    /// edges o + rel_k rounded (e_k = u(|p|∞ + |rel_k|∞)).
    fn evaluation_error(&self, p: [f64; 2]) -> f64 {
        let (u, e) = (self.fan.uv_edges(p), uv_edge_errors(self.fan, p));
        let triangles: f64 = (0..6)
            .map(|k| {
                let (j, geometry) = ((k + 5) % 6, &self.fan.geometry[k]);
                let eta = triangle_relative_error(geometry, u[j], u[k], e[j], e[k], self.theta);
                eta * triangle_energy(geometry, u[j], u[k], self.theta).abs()
            })
            .sum();
        triangles
            + pin_relative_error(self.weight, self.resolution, p)
                * pin_energy(self.weight, self.resolution, p).abs()
    }

    /// How far the f32 value of F at the search's point t of iteration i may be from the f64
    /// F(t): the evaluation error, plus how far F moves as the f32 point o' − t' g' moves from
    /// o − t g: along the line |∇F·g|·Δt, with Δt the bracket ends' error dt0 plus 3u·hi per
    /// iteration (t1 = lo + (hi − lo)/3 is a convex combination of lo and hi, so earlier errors
    /// do not grow, and each iteration adds its own ≤ 3 roundings); across it |∇F| times the
    /// direction's t·|Δg| and the point's own rounding u(|o| + t|g|).
    fn perturbation(&self, t: f64, iteration: usize) -> f64 {
        let p = line_point(self.o, self.g, t);
        let grad = node_gradient(self.fan, self.weight, self.resolution, p, self.theta);
        let dt = self.dt0 + 3.0 * (iteration as f64 + 1.0) * U32 * self.hi;
        let along = (grad[0] * self.g[0] + grad[1] * self.g[1]).abs() * dt;
        let across = grad[0].hypot(grad[1])
            * (t * self.dg + U32 * (self.o[0].abs().max(self.o[1].abs()) + t * self.gn));
        self.evaluation_error(p) + along + across
    }
}

/// The steps a conforming f32 ternary search can end at, as their hull [t_min, t_max] (None if
/// every path stays inside `covered`): the search of [`crate::unwarp::pass::ternary_search`]
/// of F = `energy` from [lo, hi], except that at iteration i, where |F(t1) − F(t2)| is within
/// `perturbation(t1, i) + perturbation(t2, i)` (how far the f32 values may be from F's; or
/// either is not finite), both sub-brackets are followed. A
/// sub-bracket inside `covered` (the interval around t* that bound 1 already counts) is not
/// explored further; past `budget` iterations a sub-bracket counts whole (every step a search
/// can reach from it lies in it), so the hull is never too small.
pub fn reachable_steps(
    energy: impl Fn(f64) -> f64,
    perturbation: impl Fn(f64, usize) -> f64,
    lo: f64,
    hi: f64,
    covered: [f64; 2],
) -> Option<[f64; 2]> {
    let mut hull: Option<[f64; 2]> = None;
    let mut add = |a: f64, b: f64| {
        hull = Some(match hull {
            None => [a, b],
            Some([x, y]) => [x.min(a), y.max(b)],
        });
    };
    let mut budget = 4096usize;
    let mut stack = vec![(lo, hi, 0usize)];
    while let Some((lo, hi, i)) = stack.pop() {
        if lo >= covered[0] && hi <= covered[1] {
            continue;
        }
        if i == SEARCH_ITERATIONS || hi - lo <= SEARCH_RELATIVE_WIDTH * hi {
            add(0.5 * (lo + hi), 0.5 * (lo + hi));
            continue;
        }
        if budget == 0 {
            add(lo, hi);
            continue;
        }
        budget -= 1;
        let third = (hi - lo) / 3.0;
        let (t1, t2) = (lo + third, hi - third);
        let (f1, f2) = (energy(t1), energy(t2));
        let tolerance = perturbation(t1, i) + perturbation(t2, i);
        let tie = !((f1 - f2).abs() > tolerance);
        if tie || f1 > f2 {
            stack.push((t1, hi, i + 1));
        }
        if tie || !(f1 > f2) {
            stack.push((lo, t2, i + 1));
        }
    }
    hull
}

/// Where a conforming f32 pass's flip-free bracket [lo', hi'] can lie: lo' ∈ [lo.0, lo.1],
/// hi' ∈ [hi.0, hi.1] (hi.1 may be ∞).
#[derive(Clone, Copy, Debug, PartialEq)]
struct BracketRange {
    lo: [f64; 2],
    hi: [f64; 2],
}

impl BracketRange {
    /// How far either end may be from the f64 bracket's [lo, hi]: max |lo' − lo|, |hi' − hi|.
    fn end_error(&self, lo: f64, hi: f64) -> f64 {
        (lo - self.lo[0])
            .max(self.lo[1] - lo)
            .max(hi - self.hi[0])
            .max(self.hi[1] - hi)
            .max(0.0)
    }
}

/// The range of a'/d' over a' ∈ [a − δa, a + δa], d' ∈ [d − δd, d + δd]; `None` when the d'
/// interval holds 0 (the quotient is then unbounded both ways).
fn quotient_range(a: f64, da: f64, d: f64, dd: f64) -> Option<[f64; 2]> {
    if !(dd < d.abs()) {
        return None;
    }
    let q = [
        (a - da) / (d - dd),
        (a - da) / (d + dd),
        (a + da) / (d - dd),
        (a + da) / (d + dd),
    ];
    Some([
        q.iter().copied().fold(f64::INFINITY, f64::min),
        q.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    ])
}

/// The range of the pin barrier's root t₊(α, β, c) of α t² − 2β t − c = 0
/// ([`crate::unwarp::fixation::pin_root`], c = 1 − γ) over the f32 inputs. t₊ grows with β
/// and c and falls with α (∂t/∂β = t/√D, ∂t/∂c = 1/(2√D), ∂t/∂α = −t²/(2√D),
/// √D = αt − β > 0), so its range is [t₊(α_max, β − Δβ, c(1 − δ_c)),
/// t₊(α_min, β + Δβ, c(1 + δ_c))], each end widened by the root's own ≈ 20 roundings. With
/// |g' − g| ≤ Δg: α = w²|R⊙g|² lies in w²(|R⊙g| ∓ R_max Δg)²(1 ± 5u); β = w²(R²⊙o)·g moves
/// by ≤ w²|R²⊙o| Δg + 5u w² Σ R_i² |o_i g_i| (Cauchy–Schwarz, and the sums' roundings); c by
/// δ_c = [`pin_cancellation`] + u relatively. The root itself is `pin_root`'s formula, without
/// cancellation. `None` without a barrier (w = 0 or γ ≥ 1).
fn pin_root_range(line: &LineModel) -> Option<[f64; 2]> {
    let (w2, r, o, g, dg) = (
        line.weight * line.weight,
        line.resolution,
        line.o,
        line.g,
        line.dg,
    );
    let gamma = crate::unwarp::fixation::pin_q(line.weight, r, o);
    if !(line.weight > 0.0 && gamma < 1.0) {
        return None;
    }
    let r2 = [r[0] * r[0], r[1] * r[1]];
    let beta = w2 * (r2[0] * o[0] * g[0] + r2[1] * o[1] * g[1]);
    let (rg, r_max) = ((r[0] * g[0]).hypot(r[1] * g[1]), r[0].max(r[1]));
    let alpha_range = [
        w2 * (rg - r_max * dg).max(0.0).powi(2) * (1.0 - 5.0 * U32),
        w2 * (rg + r_max * dg).powi(2) * (1.0 + 5.0 * U32),
    ];
    let d_beta = w2 * (r2[0] * o[0]).hypot(r2[1] * o[1]) * dg
        + 5.0 * U32 * w2 * (0..2).map(|i| r2[i] * (o[i] * g[i]).abs()).sum::<f64>();
    let c = 1.0 - gamma;
    let dc = pin_cancellation(line.weight, r, o) + U32;
    let root = |alpha: f64, beta: f64, c: f64| -> f64 {
        if !(alpha > 0.0) {
            return f64::INFINITY;
        }
        if !(c > 0.0) {
            return 0.0;
        }
        let disc = (beta * beta + alpha * c).sqrt();
        if beta >= 0.0 {
            (beta + disc) / alpha
        } else {
            c / (disc - beta)
        }
    };
    let low = root(alpha_range[1], beta - d_beta, c * (1.0 - dc));
    let high = root(alpha_range[0], beta + d_beta, c * (1.0 + dc));
    Some([low * (1.0 - 20.0 * U32), high * (1.0 + 20.0 * U32)])
}

/// [`BracketRange`] of the texel's line: the f32 kernel's [`flip_free_bracket`] rule (triangle
/// k's root t0_k = a_k/den_k, den_k = U1×g + g×U2, when positive bounds hi if a_k > 0, else
/// lo; the pin barrier's root bounds hi) applied to every value each input can take. a_k is
/// off by δa ([`triangle_relative_error`]'s), den_k by
/// δden = 3u Σ|products| + 2(e1 + e2)|g|₁ + Δg(|U1|₁ + |U2|₁) (the UV edges' errors e and
/// the gradient's Δg), so t0_k ranges over
/// [`quotient_range`]: a constraint that may exist in f32 can lower hi' (raise lo') to its
/// smallest (largest) root; one that surely exists caps hi' at its largest root. The pin
/// root's range is [`pin_root_range`]'s.
///
/// [`flip_free_bracket`]: crate::unwarp::pass::flip_free_bracket
fn bracket_range(line: &LineModel) -> BracketRange {
    let (u, e) = (line.fan.uv_edges(line.o), uv_edge_errors(line.fan, line.o));
    let g = line.g;
    let g1 = g[0].abs() + g[1].abs();
    let (mut lo, mut hi) = ([0.0f64, 0.0f64], [f64::INFINITY, f64::INFINITY]);
    for k in 0..6 {
        let j = (k + 5) % 6;
        let (u1, u2) = (u[j], u[k]);
        let a = uv_area(u1, u2);
        let den = (u1[0] * g[1] - g[0] * u1[1]) + (g[0] * u2[1] - u2[0] * g[1]);
        let delta_a = uv_area_error(u1, u2, e[j], e[k]);
        let products = (u1[0] * g[1]).abs()
            + (g[0] * u1[1]).abs()
            + (g[0] * u2[1]).abs()
            + (u2[0] * g[1]).abs();
        let delta_den = 3.0 * U32 * products
            + 2.0 * (e[j] + e[k]) * g1
            + line.dg * (u1[0].abs() + u1[1].abs() + u2[0].abs() + u2[1].abs());
        // The quotient's own rounding: u relatively.
        let roots = quotient_range(a, delta_a, den, delta_den)
            .map(|[r0, r1]| [r0 - U32 * r0.abs(), r1 + U32 * r1.abs()]);
        let (low, high) = match roots {
            Some([r0, r1]) => (r0, r1),
            None => (f64::NEG_INFINITY, f64::INFINITY),
        };
        let (may_pos, sure_pos) = (high > 0.0, low > 0.0);
        let (may_unfolded, sure_unfolded) = (a + delta_a > 0.0, a - delta_a > 0.0);
        if may_unfolded && may_pos {
            hi[0] = hi[0].min(low.max(0.0));
        }
        if sure_unfolded && sure_pos {
            hi[1] = hi[1].min(high);
        }
        if !sure_unfolded && may_pos {
            lo[1] = lo[1].max(high);
        }
        if !may_unfolded && sure_pos {
            lo[0] = lo[0].max(low);
        }
    }
    if let Some([r0, r1]) = pin_root_range(line) {
        hi[0] = hi[0].min(r0);
        hi[1] = hi[1].min(r1);
    }
    BracketRange { lo, hi }
}

/// The largest distance from o to a corner of the fan's UV polygon, max_k |U_k|: a step that
/// turns no triangle over stays inside the polygon (the node stays in its kernel).
pub fn fan_radius(fan: &Fan, o: [f64; 2]) -> f64 {
    fan.uv_edges(o)
        .iter()
        .map(|u| u[0].hypot(u[1]))
        .fold(0.0, f64::max)
}

/// The bound on |Δo| (texels of the map) between a conforming f32 step and the f64 step of
/// texel (x, y), from the same state. With the reference's step t* along −g, s = t*|g|, and
/// the f32 gradient's error |Δg| ≤ Σ_k η_{T_k}|∇E_{T_k}| + η|∇E_pin| (cancellation included):
///
/// 1. **search**: f32 cannot order F(t1), F(t2) once they differ by less than both
///    evaluations' errors; near t* that leaves the interval where F(t) ≤ F(t*) + 2δF(t*)
///    ([`sublevel_interval`], measured on F itself since a rough height map's F is not
///    quadratic), and away from it a comparison within the errors may send the search into
///    another basin: [`reachable_steps`] follows both branches there. |Δo| ≤ max |t − t*|·|g|
///    over both;
/// 2. **direction**: the f32 line o − t g' is off by t|Δg|: ≤ 2|Δg| t_max (the line's
///    rotation also moves its minimiser);
/// 3. **guard**: when F(0) − F(t) is within the errors for some reachable t (or the
///    reference does not move), f32 may decide the other way: |Δo| ≤ s.
///
/// The f32 bracket's ends lie within `bracket_range` (every value its roots can take under
/// the inputs' errors, the gradient's included), at most dt0 from the f64 ends; the f32
/// search's points are the model's moved by ≤ dt0 (plus 3u·hi per iteration), which widens the
/// hull of bound 1 by as much, and where f32 may find no bracket at all bound 3 applies. The
/// final bracket width 1e-6·hi adds ≤ 1e-6 hi|g|.
///
/// This line model is first order in the ends' error: where dt0 exceeds 1/8 of the bracket
/// (seen on `blub_texture.png` at 2048²: a pinned texel 7·10⁻⁶ from its barrier, 1 − q
/// uncertain by 10% in f32 and the barrier's gradient 5× the net gradient, so the f32 line
/// points up to 35° away and its barrier root lies 4–8× further), the f32 search runs on
/// another interval, and the bound is where its step can land at all ([`wide_bound`]). Where
/// the reference finds no step (g zero or not finite, or no bracket) the bound is
/// [`no_step_bound`]'s.
pub fn step_bound(problem: &Problem, offsets: &[[f64; 2]], x: usize, y: usize) -> f64 {
    step_bound_parts(problem, offsets, x, y).total()
}

/// The terms of [`step_bound`], in texels of the map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepBoundParts {
    /// Bound 1 near t*: the sublevel interval's radius × |g|.
    pub near: f64,
    /// Bound 1: max |t − t*| |g| over the reachable steps and the sublevel interval.
    pub search: f64,
    /// Bound 2.
    pub direction: f64,
    /// Bound 3.
    pub guard: f64,
    /// The final bracket's width, 1e-6 hi|g|.
    pub width: f64,
    /// Where the reference finds no step: [`no_step_bound`]'s, else 0.
    pub no_step: f64,
    /// Where the f32 bracket may be far from the f64 one: [`wide_bound`]'s (the other terms
    /// are then 0), else 0.
    pub wide: f64,
}

impl StepBoundParts {
    /// The bound: the sum of the terms.
    pub fn total(&self) -> f64 {
        self.search + self.direction + self.guard + self.width + self.no_step + self.wide
    }
}

/// [`step_bound`] term by term.
pub fn step_bound_parts(
    problem: &Problem,
    offsets: &[[f64; 2]],
    x: usize,
    y: usize,
) -> StepBoundParts {
    let mesh = &problem.mesh;
    let i = mesh.index(x, y);
    // r: the pin barrier's R (the finest level's), as the reference's energy uses it; the
    // bound is reported in texels of this level's map.
    let (o, w, r, theta) = (
        offsets[i],
        problem.pins[i],
        problem.pin_resolution,
        problem.theta,
    );
    let fan = Fan::new(mesh, offsets, x, y);
    let step = descend_texel_traced(problem, offsets, x, y);
    let g = step.gradient;
    let gn = g[0].hypot(g[1]);
    let texels = mesh.width.max(mesh.height) as f64;
    let Some([lo, hi]) = step.bracket else {
        return StepBoundParts {
            no_step: no_step_bound(&fan, w, r, o, g, theta) * texels,
            ..Default::default()
        };
    };
    let mut line = LineModel {
        fan: &fan,
        weight: w,
        resolution: r,
        o,
        g,
        gn,
        theta,
        dg: gradient_error(&fan, w, r, o, theta),
        dt0: 0.0,
        hi,
    };
    let range = bracket_range(&line);
    line.dt0 = range.end_error(lo, hi);
    let t = step.search.t;
    let s = t * gn;
    // Where the f32 bracket's ends may move by more than an eighth of the bracket, the f32
    // search runs on another interval than the f64 one (a root whose denominator or 1 − q
    // cancels, or a gradient with a large error): bound the step by where it can land at all.
    if !(line.dt0 <= 0.125 * (hi - lo)) {
        return StepBoundParts {
            wide: wide_bound(&fan, o, t, gn, line.dg, range.hi[1]) * texels,
            ..Default::default()
        };
    }
    let ft = line.energy(t);
    let f = |t: f64| line.energy(t);
    let near = sublevel_interval(
        &f,
        t,
        [0.0, hi],
        ft + 2.0 * line.perturbation(t, SEARCH_ITERATIONS),
    );
    let reach = reachable_steps(
        |t| line.energy(t),
        |t, i| line.perturbation(t, i),
        lo,
        hi,
        near,
    )
    .unwrap_or(near);
    // The f32 search's points are the model's moved by at most dt0 + 3u·hi per iteration.
    let shift = line.dt0 + 3.0 * SEARCH_ITERATIONS as f64 * U32 * hi;
    let (t_min, t_max) = (near[0].min(reach[0]) - shift, near[1].max(reach[1]) + shift);
    let search = (t - t_min).max(t_max - t) * gn;
    let direction = 2.0 * line.dg * t_max;
    let f0 = line.energy(0.0);
    let margin = line.perturbation(0.0, 0) + line.perturbation(t, SEARCH_ITERATIONS);
    // Every reachable step lowers F by more than the errors iff the whole hull lies in the
    // interval around t* where F < F(0) − margin; and f32 finds a bracket at all iff lo' < hi'
    // surely.
    let lower = sublevel_interval(&f, t, [0.0, hi], f0 - margin);
    let no_bracket = !(range.lo[1] < range.hi[0]);
    let guard =
        if !step.moved || no_bracket || f(t) >= f0 - margin || t_min < lower[0] || t_max > lower[1]
        {
            s
        } else {
            0.0
        };
    StepBoundParts {
        near: (t - near[0]).max(near[1] - t) * gn * texels,
        search: search * texels,
        direction: direction * texels,
        guard: guard * texels,
        width: 1e-6 * hi * gn * texels,
        ..Default::default()
    }
}

/// The bound on |Δo| (UV units) where the f32 bracket may be far from the f64 one: the f32 step
/// is o − t'g' with t' ∈ [0, hi'] ⊂ [0, `hi_max`] and |g' − g| ≤ Δg, the reference's o − t*g,
/// so |Δo| ≤ |t* − t'||g| + t'Δg ≤ max(t*, hi_max − t*)|g| + hi_max Δg. Either way the step
/// turns no triangle over, so it stays in the fan's polygon: |Δo| ≤ t*|g| + [`fan_radius`]
/// (with 10⁻⁶ relative for the f32 areas' roundings near 0). The smaller of the two.
pub fn wide_bound(fan: &Fan, o: [f64; 2], t: f64, gn: f64, dg: f64, hi_max: f64) -> f64 {
    let along = (t.max(hi_max - t)) * gn + hi_max * dg;
    let polygon = t * gn + fan_radius(fan, o) * (1.0 + 1e-6);
    if along.is_finite() {
        along.min(polygon)
    } else {
        polygon
    }
}

/// The absolute error of the f32 gradient at o: Σ_k η_{T_k}|∇E_{T_k}| + η'_pin|∇E_pin|
/// ([`triangle_relative_error`] per term, [`pin_gradient_relative_error`]; the sum's own
/// roundings are within η).
pub fn gradient_error(
    fan: &Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    theta: f64,
) -> f64 {
    let (u, e) = (fan.uv_edges(o), uv_edge_errors(fan, o));
    let triangles: f64 = (0..6)
        .map(|k| {
            let j = (k + 5) % 6;
            let eta = triangle_relative_error(&fan.geometry[k], u[j], u[k], e[j], e[k], theta);
            let gk = triangle_gradient(&fan.geometry[k], u[j], u[k], theta);
            eta * gk[0].hypot(gk[1])
        })
        .sum();
    let p = pin_gradient(weight, resolution, o);
    triangles + pin_gradient_relative_error(weight, resolution, o) * p[0].hypot(p[1])
}
/// The bound on |Δo| (UV units) at a node where the f64 reference finds no step (g = 0 or not
/// finite, or an empty bracket), so that its offset stays o. A conforming f32 pass either stays
/// too (error 0) or, its decisions differing near a tie, takes a step p:
///
/// 1. the step stays inside its flip-free bracket, i.e. inside the fan's UV polygon around the
///    node: |p − o| ≤ max_k |U_k| (U_k the UV edges to the six neighbours, ≈ 1–1.5 texels);
/// 2. at a stationary node (g = 0, a minimum of F: the Hessian H of F at o positive definite,
///    smallest eigenvalue λ_min), the guard accepted p only if F_f32(p) < F_f32(o), so
///    F(p) ≤ (1 + 2η) F(o); with F(p) ≥ F(o) + ½ λ_min |p − o|² near the minimum,
///    |p − o| ≤ √(4ηF(o)/λ_min). H by central differences of the analytic gradient, step
///    10⁻⁵ texel (its error, O(10⁻¹⁰) relative, far below η).
///
/// The smaller of the two where both apply; never 0 (a flat map's nodes are stationary).
pub fn no_step_bound(
    fan: &Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    g: [f64; 2],
    theta: f64,
) -> f64 {
    let polygon = fan_radius(fan, o);
    if g != [0.0, 0.0] {
        return polygon;
    }
    let delta = 1e-5 / resolution[0].max(resolution[1]);
    let column = |j: usize| {
        let mut plus = o;
        let mut minus = o;
        plus[j] += delta;
        minus[j] -= delta;
        let (gp, gm) = (
            node_gradient(fan, weight, resolution, plus, theta),
            node_gradient(fan, weight, resolution, minus, theta),
        );
        [
            (gp[0] - gm[0]) / (2.0 * delta),
            (gp[1] - gm[1]) / (2.0 * delta),
        ]
    };
    let (c0, c1) = (column(0), column(1));
    let (a, b, d) = (c0[0], 0.5 * (c0[1] + c1[0]), c1[1]);
    let lambda_min = 0.5 * ((a + d) - (a - d).hypot(2.0 * b));
    let f = node_energy(fan, weight, resolution, o, theta);
    let stationary = (4.0 * ETA * f / lambda_min).sqrt();
    if lambda_min > 0.0 && stationary.is_finite() {
        stationary.min(polygon)
    } else {
        polygon
    }
}

/// The interval [a, b] ∋ t* within `ends` on which F(t) ≤ `level` around t* (the connected
/// part containing t*): on each side, distances 2⁻⁴⁰·span … span are tried in doubling steps
/// until F exceeds the level, then bisection between the last point under it and the first
/// above, keeping the outer end (so the interval is never too small by more than the first
/// step, 2⁻⁴⁰ of the side's span).
pub fn sublevel_interval(f: &impl Fn(f64) -> f64, t: f64, ends: [f64; 2], level: f64) -> [f64; 2] {
    let side = |end: f64| -> f64 {
        let span = end - t;
        if span == 0.0 {
            return t;
        }
        let mut inside = 0.0;
        let mut outside = None;
        for k in (0..=40).rev() {
            let d = span / f64::from(1u32 << (k / 2)) / f64::from(1u32 << (k - k / 2));
            if f(t + d) > level {
                outside = Some(d);
                break;
            }
            inside = d;
        }
        let Some(mut outside) = outside else {
            return end;
        };
        for _ in 0..50 {
            let mid = 0.5 * (inside + outside);
            if f(t + mid) > level {
                outside = mid;
            } else {
                inside = mid;
            }
        }
        t + outside
    };
    [side(ends[0]), side(ends[1])]
}

/// The largest |t − t*| over [`sublevel_interval`] within [0, hi] (bound 1 of [`step_bound`]
/// near t*).
pub fn indistinguishable_radius(f: &impl Fn(f64) -> f64, t: f64, hi: f64, level: f64) -> f64 {
    let [a, b] = sublevel_interval(f, t, [0.0, hi], level);
    (t - a).max(b - t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A double well whose minima differ by less than the evaluations' errors: the f64 search
    /// ends in one, a conforming f32 search may end in the other, and the reachable hull holds
    /// both. With exact evaluations (no perturbation) it is the f64 search's own step.
    #[test]
    fn a_tie_between_two_basins_reaches_both() -> Result<(), &'static str> {
        let well = |t: f64| (t - 0.2).powi(2) * (t - 0.8).powi(2) + 1e-9 * t;
        let reference = crate::unwarp::pass::ternary_search(well, 0.0, 1.0).t;
        let nothing = [f64::NAN; 2];
        let exact = reachable_steps(well, |_, _| 0.0, 0.0, 1.0, nothing).ok_or("no step")?;
        assert!((exact[0] - reference).abs() < 1e-6 && (exact[1] - reference).abs() < 1e-6);
        let noisy = reachable_steps(well, |_, _| 1e-8, 0.0, 1.0, nothing).ok_or("no step")?;
        assert!(
            noisy[0] < 0.21 && noisy[1] > 0.79,
            "{noisy:?}, f64 at {reference}"
        );
        Ok(())
    }

    /// [`bracket_range`] holds the bracket of every gradient within the error ball: on the 32²
    /// cones map after 2 sweeps, for every texel with a bracket, 24 gradients g' on the circle
    /// |g' − g| = Δg (and half way) give f64 brackets whose ends lie in the range; and the
    /// range is not vacuous: at most texels its ends' error is under 1% of the bracket.
    #[test]
    fn the_bracket_range_holds_every_bracket_of_a_gradient_within_its_error(
    ) -> crate::error::Result<()> {
        use crate::unwarp::pass::flip_free_bracket;
        use crate::unwarp::{procedural, UnwarpOptions};
        let options = UnwarpOptions {
            scale: 0.08,
            ..Default::default()
        };
        let heights = procedural("cones", 32)?;
        let (problem, offsets) = crate::crosscheck::unwarp::rounded_state(&heights, &options, 2)?;
        let (mut texels, mut tight) = (0, 0);
        for y in 0..32 {
            for x in 0..32 {
                let i = problem.mesh.index(x, y);
                let (o, w, r, theta) = (
                    offsets[i],
                    problem.pins[i],
                    problem.pin_resolution,
                    problem.theta,
                );
                let fan = Fan::new(&problem.mesh, &offsets, x, y);
                let g = node_gradient(&fan, w, r, o, theta);
                let Some([lo, hi]) = flip_free_bracket(&fan, w, r, o, g) else {
                    continue;
                };
                let line = LineModel {
                    fan: &fan,
                    weight: w,
                    resolution: r,
                    o,
                    g,
                    gn: g[0].hypot(g[1]),
                    theta,
                    dg: gradient_error(&fan, w, r, o, theta),
                    dt0: 0.0,
                    hi,
                };
                let range = bracket_range(&line);
                texels += 1;
                tight += usize::from(range.end_error(lo, hi) < 0.01 * (hi - lo));
                for k in 0..48 {
                    let phi = std::f64::consts::TAU * (k % 24) as f64 / 24.0;
                    let radius = line.dg * if k < 24 { 1.0 } else { 0.5 };
                    let g2 = [g[0] + radius * phi.cos(), g[1] + radius * phi.sin()];
                    let Some([lo2, hi2]) = flip_free_bracket(&fan, w, r, o, g2) else {
                        continue;
                    };
                    assert!(
                        range.lo[0] <= lo2 && lo2 <= range.lo[1],
                        "({x}, {y}) g' {g2:?}: lo' {lo2} outside {:?}",
                        range.lo
                    );
                    assert!(
                        range.hi[0] <= hi2 && hi2 <= range.hi[1],
                        "({x}, {y}) g' {g2:?}: hi' {hi2} outside {:?}",
                        range.hi
                    );
                }
            }
        }
        assert!(
            texels > 400 && tight * 10 > texels * 9,
            "{tight} of {texels}"
        );
        Ok(())
    }

    /// The pin barrier's root range near the barrier, where 1 − q = 7·10⁻⁶ and the gradient's
    /// error is 60% of it (the `blub_texture.png` texel that first failed the pass bound): the
    /// roots of every gradient within the error lie in it, and it reaches at least 4× the
    /// f64 root (the f32 kernel's was 8× there).
    #[test]
    fn the_pin_root_range_holds_near_the_barrier() -> Result<(), Box<dyn std::error::Error>> {
        let flat = crate::unwarp::HeightMap::new("flat", 8, 8, vec![0.0; 64])?;
        let mesh =
            crate::unwarp::mesh::UnwarpMesh::new(&flat, 0.05, crate::unwarp::Border::Periodic)?;
        let fan = Fan::new(&mesh, &[[0.0; 2]; 64], 2, 2);
        let (w, r) = (0.9, [2048.0, 2048.0]);
        let radius = (1.0 - 7e-6f64).sqrt() / (w * 2048.0);
        let o = [radius * 0.7f64.cos(), radius * 0.7f64.sin()];
        // Mostly tangential, slightly inward (β < 0: the root is c/(√D − β), small).
        let g = [-o[1] * 1e15 + o[0] * 2e13, o[0] * 1e15 + o[1] * 2e13];
        let gn = g[0].hypot(g[1]);
        let line = LineModel {
            fan: &fan,
            weight: w,
            resolution: r,
            o,
            g,
            gn,
            theta: 5.0,
            dg: 0.6 * gn,
            dt0: 0.0,
            hi: 0.0,
        };
        let [low, high] = pin_root_range(&line).ok_or("no barrier")?;
        let root = crate::unwarp::fixation::pin_root(w, r, o, g).ok_or("no root")?;
        assert!(
            low <= root && root <= high && high >= 4.0 * root,
            "{low} {root} {high}"
        );
        for k in 0..24 {
            let phi = std::f64::consts::TAU * k as f64 / 24.0;
            let g2 = [g[0] + line.dg * phi.cos(), g[1] + line.dg * phi.sin()];
            if let Some(t) = crate::unwarp::fixation::pin_root(w, r, o, g2) {
                assert!(
                    low <= t && t <= high,
                    "g' {g2:?}: {t} outside [{low}, {high}]"
                );
            }
        }
        Ok(())
    }
}
