//! One pass of the per-texel descent (notes § One pass; seed: "massively parallel gradient
//! descent per texel — find the local optimum along the gradient line for each texel, ternary
//! line search; one thread per correction texel quad, split across four iterations").
//!
//! Per active texel c, with F = F_c the node energy ([`node_energy`]):
//! 1. g = ∇F(o_c) ([`node_gradient`]);
//! 2. the flip-free bracket [lo, hi] of the step t along −g ([`flip_free_bracket`]);
//! 3. the ternary search for the minimum of F(o_c − t g) on it ([`ternary_search`]), guarded:
//!    the step is taken only if it lowers F ([`descend_texel`]).
//!
//! A pass updates one phase (texels of one colour, see [`UnwarpMesh::phase_of`]); texels of a
//! phase share no triangle, so each update reads only nodes the pass does not change: the pass
//! is an exact block coordinate descent, its result independent of the update order and of
//! the thread count, and only the active texels are computed.

use rayon::prelude::*;

use super::energy::{node_energy, node_gradient, uv_area, Fan};
use super::fixation::pin_root;
use super::mesh::UnwarpMesh;
use super::Problem;

/// At most this many ternary-search iterations (notes: 31).
pub const SEARCH_ITERATIONS: usize = 31;
/// The search stops when hi − lo ≤ this × hi (notes: 1e−6).
pub const SEARCH_RELATIVE_WIDTH: f64 = 1e-6;

/// 2D cross product a.x b.y − b.x a.y.
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - b[0] * a[1]
}

/// The point o − t g of the search line.
pub fn line_point(o: [f64; 2], g: [f64; 2], t: f64) -> [f64; 2] {
    [o[0] - t * g[0], o[1] - t * g[1]]
}

/// The steps t ≥ 0 along −g that keep every triangle of the fan unfolded and the node inside
/// its pin barrier.
///
/// Each triangle's signed UV area is linear in t: a_k(t) = a_k − t·den_k with
/// den_k = U1×g + g×U2, zero at t0_k = a_k/den_k. From [lo, hi] = [0, ∞), for every t0_k > 0:
/// an unfolded triangle (a_k > 0) sets hi = min(hi, t0_k), a folded one lo = max(lo, t0_k).
/// The barrier's root ([`pin_root`]) also bounds hi. `None` (no move) when lo ≥ hi, when hi
/// stays infinite or anything is NaN.
pub fn flip_free_bracket(
    fan: &Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    g: [f64; 2],
) -> Option<[f64; 2]> {
    let u = fan.uv_edges(o);
    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
    for k in 0..6 {
        let (u1, u2) = (u[(k + 5) % 6], u[k]);
        let a = uv_area(u1, u2);
        let den = cross(u1, g) + cross(g, u2);
        let t0 = a / den;
        if t0 > 0.0 {
            if a > 0.0 {
                hi = hi.min(t0);
            } else {
                lo = lo.max(t0);
            }
        }
    }
    if let Some(root) = pin_root(weight, resolution, o, g) {
        hi = hi.min(root);
    }
    (lo < hi && hi.is_finite()).then_some([lo, hi])
}

/// The result of [`ternary_search`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Search {
    /// The step (lo + hi)/2 of the final bracket.
    pub t: f64,
    /// Which sub-bracket each iteration kept: bit i set when iteration i moved lo up (f(t1) >
    /// f(t2)). Compared with the GPU's to see where f32 chose differently.
    pub path: u32,
    /// Iterations done.
    pub steps: u32,
}

/// Ternary search for the minimum of `f` on [lo, hi]: at most [`SEARCH_ITERATIONS`] steps
/// while hi − lo > [`SEARCH_RELATIVE_WIDTH`]·hi; t1, t2 at the thirds; f(t1) > f(t2) → lo = t1,
/// else hi = t2 (ties and NaN shrink toward lo). Returns t = (lo + hi)/2.
pub fn ternary_search(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> Search {
    ternary_search_to(f, lo, hi, SEARCH_RELATIVE_WIDTH)
}

/// [`ternary_search`] stopping when hi − lo ≤ `relative_width`·hi (the coarse moves of
/// [`super::coarse_move`] search less finely).
pub fn ternary_search_to(
    f: impl Fn(f64) -> f64,
    mut lo: f64,
    mut hi: f64,
    relative_width: f64,
) -> Search {
    let (mut path, mut steps) = (0u32, 0u32);
    for i in 0..SEARCH_ITERATIONS {
        if hi - lo <= relative_width * hi {
            break;
        }
        let third = (hi - lo) / 3.0;
        let (t1, t2) = (lo + third, hi - third);
        if f(t1) > f(t2) {
            lo = t1;
            path |= 1 << i;
        } else {
            hi = t2;
        }
        steps += 1;
    }
    Search {
        t: 0.5 * (lo + hi),
        path,
        steps,
    }
}

/// The new offset of free texel (x, y) after one descent step, reading only the current
/// offsets of (x, y) and its six neighbours: gradient, bracket, search, then the monotonicity
/// guard — the step is taken only if F(o − t g) < F(o) (ties keep o, so a flat map stays
/// exactly at 0). No move when the gradient is zero or not finite or the bracket is empty.
pub fn descend_texel(problem: &Problem, offsets: &[[f64; 2]], x: usize, y: usize) -> [f64; 2] {
    descend_texel_traced(problem, offsets, x, y).offset
}

/// What [`descend_texel_traced`] did at one texel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexelStep {
    /// The new offset.
    pub offset: [f64; 2],
    /// The gradient g = ∇F(o).
    pub gradient: [f64; 2],
    /// The flip-free bracket, if any.
    pub bracket: Option<[f64; 2]>,
    /// The search (zero when there was no bracket).
    pub search: Search,
    /// Whether the guard accepted the step.
    pub moved: bool,
}

/// [`descend_texel`] with its intermediate results.
pub fn descend_texel_traced(
    problem: &Problem,
    offsets: &[[f64; 2]],
    x: usize,
    y: usize,
) -> TexelStep {
    let mesh = &problem.mesh;
    let i = mesh.index(x, y);
    let (o, weight, resolution, theta) = (
        offsets[i],
        problem.pins[i],
        problem.pin_resolution,
        problem.theta,
    );
    let fan = Fan::new(mesh, offsets, x, y);
    let g = node_gradient(&fan, weight, resolution, o, theta);
    let mut step = TexelStep {
        offset: o,
        gradient: g,
        ..Default::default()
    };
    if !(g[0].is_finite() && g[1].is_finite()) || g == [0.0, 0.0] {
        return step;
    }
    step.bracket = flip_free_bracket(&fan, weight, resolution, o, g);
    let Some([lo, hi]) = step.bracket else {
        return step;
    };
    let f = |t: f64| node_energy(&fan, weight, resolution, line_point(o, g, t), theta);
    step.search = ternary_search(f, lo, hi);
    if f(step.search.t) < f(0.0) {
        step.offset = line_point(o, g, step.search.t);
        step.moved = true;
    }
    step
}

/// What a pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct PassStats {
    /// Texels computed (the free texels of the phase).
    pub active: usize,
    /// Texels whose offset changed.
    pub moved: usize,
}

/// One pass of `phase`: [`descend_texel`] for every free texel of the phase, in parallel from
/// the same state, then written back.
pub fn pass(problem: &Problem, offsets: &mut [[f64; 2]], phase: usize) -> PassStats {
    let texels = problem.mesh.active_texels(phase);
    let updates: Vec<[f64; 2]> = texels
        .par_iter()
        .map(|&(x, y)| descend_texel(problem, offsets, x, y))
        .collect();
    let mut moved = 0;
    for (&(x, y), o) in texels.iter().zip(updates) {
        let i = problem.mesh.index(x, y);
        moved += usize::from(offsets[i] != o);
        offsets[i] = o;
    }
    PassStats {
        active: texels.len(),
        moved,
    }
}

/// The phases of one sweep in order 0, 1, …, [`UnwarpMesh::phase_count`] − 1.
pub fn sweep_phases(mesh: &UnwarpMesh) -> std::ops::Range<usize> {
    0..mesh.phase_count()
}
