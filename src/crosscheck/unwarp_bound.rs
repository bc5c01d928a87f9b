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
use crate::unwarp::fixation::{pin_energy, pin_gradient, pin_root};
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
     within the evaluations' errors taken both ways) + 2|Δg| t_max + guard s + 1e-6 hi|g|; \
     where f64 finds no step: √(4ηF/λ_min) at a stationary node, else max_k |U_k|";

/// The relative error of one f32 evaluation of triangle T's energy E_T (and of its gradient
/// term) at UV edges U1, U2, whose components carry absolute errors e1, e2 (their own
/// rounding, o + rel_k):
///
/// η_T = η + c_a · δa/|a|, with δa = u(|U1x U2y| + |U2x U1y| + |a|) + e2|U1|₁ + e1|U2|₁ the
/// error of the UV area a = U1 × U2 (large where the cross product cancels: a nearly folded
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
    let delta_a = U32 * ((u1[0] * u2[1]).abs() + (u2[0] * u1[1]).abs() + a)
        + e2 * (u1[0].abs() + u1[1].abs())
        + e1 * (u2[0].abs() + u2[1].abs());
    let (r, big) = (a / t.area, t.area / a);
    let c_a = (-1.0 + theta * (r - big) / (r + big)).abs();
    ETA + c_a * delta_a / a
}

/// The relative error of one f32 evaluation of the pin barrier E_pin = ½/(1 − q) at offset p:
/// q = ‖w R⊙p‖² carries ≈ 6u relatively (its 4 roundings and the point's own, squared), which
/// 1 − q magnifies by q/(1 − q) near the barrier: η + 6u q/(1 − q). ∇E_pin ∝ 1/(1 − q)² doubles
/// it ([`gradient_error`]).
pub fn pin_relative_error(weight: f64, resolution: [f64; 2], p: [f64; 2]) -> f64 {
    let q = crate::unwarp::fixation::pin_q(weight, resolution, p);
    if q < 1.0 {
        ETA + 6.0 * U32 * q / (1.0 - q)
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
        let u = self.fan.uv_edges(p);
        let p_size = p[0].abs().max(p[1].abs());
        let e: Vec<f64> = (0..6)
            .map(|k| U32 * (p_size + self.fan.rel[k][0].abs().max(self.fan.rel[k][1].abs())))
            .collect();
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

/// The absolute error of the f32 bracket's end `end` (lo or hi, > 0): the end is the root
/// t0_k = a_k/den_k of a triangle k (den_k = U1×g + g×U2) or the pin barrier's root. For the
/// triangle whose root it is: |t0| (δa/|a| + δden/|den| + u), δa as in
/// [`triangle_relative_error`] and δden = 3u Σ|products| + 2(e1 + e2)|g|₁ + Δg(|U1|₁ + |U2|₁);
/// for the pin root, |t0| (20u + 2Δg/|g|) (α, β, γ, a square root and a quotient). 0 at 0.
fn bracket_end_error(line: &LineModel, end: f64) -> f64 {
    if end == 0.0 {
        return 0.0;
    }
    let u = line.fan.uv_edges(line.o);
    let o_size = line.o[0].abs().max(line.o[1].abs());
    let e = |k: usize| U32 * (o_size + line.fan.rel[k][0].abs().max(line.fan.rel[k][1].abs()));
    let g = line.g;
    let g1 = g[0].abs() + g[1].abs();
    let mut error = f64::INFINITY;
    for k in 0..6 {
        let j = (k + 5) % 6;
        let (u1, u2) = (u[j], u[k]);
        let a = uv_area(u1, u2);
        let den = (u1[0] * g[1] - g[0] * u1[1]) + (g[0] * u2[1] - u2[0] * g[1]);
        let t0 = a / den;
        if (t0 - end).abs() > 1e-9 * end {
            continue;
        }
        let delta_a = U32 * ((u1[0] * u2[1]).abs() + (u2[0] * u1[1]).abs() + a.abs())
            + e(k) * (u1[0].abs() + u1[1].abs())
            + e(j) * (u2[0].abs() + u2[1].abs());
        let products = (u1[0] * g[1]).abs()
            + (g[0] * u1[1]).abs()
            + (g[0] * u2[1]).abs()
            + (u2[0] * g[1]).abs();
        let delta_den = 3.0 * U32 * products
            + 2.0 * (e(j) + e(k)) * g1
            + line.dg * (u1[0].abs() + u1[1].abs() + u2[0].abs() + u2[1].abs());
        error = error.min(end * (delta_a / a.abs() + delta_den / den.abs() + U32));
    }
    if let Some(root) = pin_root(line.weight, line.resolution, line.o, g) {
        if (root - end).abs() <= 1e-9 * end {
            error = error.min(end * (20.0 * U32 + 2.0 * line.dg / line.gn));
        }
    }
    // An end that is neither (it cannot be: the bracket is made of these roots) counts whole.
    if error.is_finite() {
        error
    } else {
        end
    }
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
/// The final bracket width 1e-6·hi adds ≤ 1e-6 hi|g|. Where the reference finds no step (g
/// zero or not finite, or no bracket) the bound is [`no_step_bound`]'s.
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
}

impl StepBoundParts {
    /// The bound: the sum of the terms.
    pub fn total(&self) -> f64 {
        self.search + self.direction + self.guard + self.width + self.no_step
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
    let g = node_gradient(&fan, w, r, o, theta);
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
    line.dt0 = bracket_end_error(&line, lo).max(bracket_end_error(&line, hi));
    let t = step.search.t;
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
    let (t_min, t_max) = (near[0].min(reach[0]), near[1].max(reach[1]));
    let search = (t - t_min).max(t_max - t) * gn;
    let direction = 2.0 * line.dg * t_max;
    let f0 = line.energy(0.0);
    let margin = line.perturbation(0.0, 0) + line.perturbation(t, SEARCH_ITERATIONS);
    // Every reachable step lowers F by more than the errors iff the whole hull lies in the
    // interval around t* where F < F(0) − margin.
    let lower = sublevel_interval(&f, t, [0.0, hi], f0 - margin);
    let guard = if !step.moved || f(t) >= f0 - margin || t_min < lower[0] || t_max > lower[1] {
        t * gn
    } else {
        0.0
    };
    StepBoundParts {
        near: (t - near[0]).max(near[1] - t) * gn * texels,
        search: search * texels,
        direction: direction * texels,
        guard: guard * texels,
        width: 1e-6 * hi * gn * texels,
        no_step: 0.0,
    }
}

/// The absolute error of the f32 gradient at o: Σ_k η_{T_k}|∇E_{T_k}| + 2η_pin|∇E_pin|
/// ([`triangle_relative_error`] per term; the sum's own roundings are within η).
pub fn gradient_error(
    fan: &Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    theta: f64,
) -> f64 {
    let u = fan.uv_edges(o);
    let o_size = o[0].abs().max(o[1].abs());
    let e = |k: usize| U32 * (o_size + fan.rel[k][0].abs().max(fan.rel[k][1].abs()));
    let triangles: f64 = (0..6)
        .map(|k| {
            let j = (k + 5) % 6;
            let eta = triangle_relative_error(&fan.geometry[k], u[j], u[k], e(j), e(k), theta);
            let gk = triangle_gradient(&fan.geometry[k], u[j], u[k], theta);
            eta * gk[0].hypot(gk[1])
        })
        .sum();
    let p = pin_gradient(weight, resolution, o);
    triangles + 2.0 * pin_relative_error(weight, resolution, o) * p[0].hypot(p[1])
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
    let polygon = fan
        .uv_edges(o)
        .iter()
        .map(|u| u[0].hypot(u[1]))
        .fold(0.0, f64::max);
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
}
