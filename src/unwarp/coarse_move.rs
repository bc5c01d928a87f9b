//! Coarse moves: the per-texel descent of [`super::pass`] applied to smooth groups of texels,
//! on the finest level's own energy. Not in the paper or the demo (like coarse-to-fine, see
//! [`solve`](mod@super::solve)); it is what makes the fine level's slow, smooth error components converge.
//!
//! A texel step changes one offset; errors that are smooth over many texels shrink only a
//! little per pass. A coarse move of scale r ≥ 2 moves every node n near a block centre c by
//! the bilinear hat
//!
//!   w_n = (1 − |n.x − c.x|/r)(1 − |n.y − c.y|/r)   (|n.x − c.x|, |n.y − c.y| < r),
//!
//! all along one direction: o_n ← o_n − t w_n G with G = Σ_n w_n ∇_n E, the gradient of the
//! total energy E with respect to the block's displacement. Then, exactly as for one texel:
//!
//! 1. the flip-free bracket: every touched triangle's signed UV area stays linear in t (its
//!    corners move along the same G, so the t² term G × G vanishes),
//!    a(t) = a − t [(w_c − w_k) U_{k−1} × G + (w_c − w_{k−1}) G × U_k]; each pinned node's
//!    barrier root ([`pin_root`] of the step w_n G) bounds it too;
//! 2. a line search of E on the bracket — a golden-section search ([`golden_section_search`],
//!    one evaluation per step where the texel step's ternary search needs two, to a relative
//!    width of [`COARSE_SEARCH_RELATIVE_WIDTH`]); a touched triangle's D(t) is a quadratic in t
//!    and a(t) linear, so each evaluation sums polynomials ([`LineTriangle`]);
//! 3. the guard: the move is taken only if it lowers E.
//!
//! Blocks whose centres are 2r apart share no triangle (a hat's nodes lie within r − 1 of its
//! centre, a triangle spans one texel): the blocks of one phase ((c.x/r) mod 2, (c.y/r) mod 2)
//! are computed in parallel from the same state and their energy changes add, so every coarse
//! pass lowers E (or keeps it) and its result does not depend on the thread count.

use rayon::prelude::*;

use super::energy::{theta_power, triangle_geometry, TriangleGeometry};
use super::fixation::{pin_energy, pin_gradient, pin_root};
use super::mesh::{base_uv_edge, Border, UnwarpMesh};
use super::pass::{line_point, Search, SEARCH_ITERATIONS};
use super::Problem;

/// Phases of one coarse scale: block centres (c.x/r, c.y/r) mod 2.
pub const COARSE_PHASES: usize = 4;

/// A coarse move's search stops when hi − lo ≤ this × hi (a texel step searches to 1e−6: the
/// coarse moves only have to carry the smooth part of the error, and each evaluation sums
/// 8r² − 2 triangles; on the 64² cones 1e−6, 1e−3 and 1e−2 reach the same energies per sweep).
pub const COARSE_SEARCH_RELATIVE_WIDTH: f64 = 1e-2;

/// The scales r = 2, 4, 8, … usable on `mesh`, at most `count` of them: a periodic map needs
/// W and H multiples of 2r (phases must not meet across the wrap), and a hat must fit in the
/// map (2r ≤ min(W, H)).
pub fn coarse_scales(mesh: &UnwarpMesh, count: usize) -> Vec<usize> {
    (1..=count)
        .map(|level| 1usize << level)
        .take_while(|&r| 2 * r <= mesh.width.min(mesh.height))
        .filter(|&r| {
            mesh.border == Border::Fixed
                || (mesh.width.is_multiple_of(2 * r) && mesh.height.is_multiple_of(2 * r))
        })
        .collect()
}

/// The block centres of scale `r` and `phase` ∈ 0..[`COARSE_PHASES`]: (c.x, c.y) multiples of
/// r with (c.x/r) mod 2 + 2 ((c.y/r) mod 2) = phase, row-major.
pub fn block_centres(mesh: &UnwarpMesh, r: usize, phase: usize) -> Vec<(usize, usize)> {
    let (px, py) = (phase & 1, phase >> 1);
    let mut centres = Vec::new();
    for cy in (py * r..mesh.height).step_by(2 * r) {
        for cx in (px * r..mesh.width).step_by(2 * r) {
            centres.push((cx, cy));
        }
    }
    centres
}

/// The hat weight (1 − |dx|/r)(1 − |dy|/r) of a node (dx, dy) from the centre.
pub fn hat_weight(dx: i64, dy: i64, r: usize) -> f64 {
    let r = r as f64;
    (1.0 - dx.unsigned_abs() as f64 / r) * (1.0 - dy.unsigned_abs() as f64 / r)
}

/// The node (x + dx, y + dy): wrapped (periodic) or `None` outside the map (fixed).
fn node_at(mesh: &UnwarpMesh, x: usize, y: usize, dx: i64, dy: i64) -> Option<(usize, usize)> {
    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
    let (w, h) = (mesh.width as i64, mesh.height as i64);
    match mesh.border {
        Border::Periodic => Some((nx.rem_euclid(w) as usize, ny.rem_euclid(h) as usize)),
        Border::Fixed if nx < 0 || ny < 0 || nx >= w || ny >= h => None,
        Border::Fixed => Some((nx as usize, ny as usize)),
    }
}

/// One triangle of the mesh as its owner node c sees it (T_k = (c, n_{k−1}, n_k), k = 1, 2;
/// see [`super::energy::triangle_at`]): its constant geometry, its corners and the
/// undeformed UV edges −d/R of U1 = u(c) − u(n_{k−1}) and U2 = u(c) − u(n_k).
#[derive(Clone, Copy, Debug)]
pub struct TableTriangle {
    pub geometry: TriangleGeometry,
    pub corners: [usize; 3],
    pub base: [[f64; 2]; 2],
}

impl TableTriangle {
    /// The UV edges (U1, U2) at `offsets`.
    pub fn uv_edges(&self, offsets: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
        let [c, n1, n2] = self.corners.map(|n| offsets[n]);
        (
            [
                c[0] - n1[0] + self.base[0][0],
                c[1] - n1[1] + self.base[0][1],
            ],
            [
                c[0] - n2[0] + self.base[1][0],
                c[1] - n2[1] + self.base[1][1],
            ],
        )
    }
}

/// Every triangle of the mesh once: the two of each cell, `triangles[2 i + k − 1]` for the cell
/// owned by node i (`None` for cells outside a fixed border). The geometry depends on the
/// heights only: built once per level.
pub struct TriangleTable {
    pub triangles: Vec<Option<TableTriangle>>,
}

impl TriangleTable {
    pub fn new(mesh: &UnwarpMesh) -> TriangleTable {
        let resolution = mesh.resolution();
        let mut triangles = vec![None; 2 * mesh.node_count()];
        for (x, y) in mesh.cell_owners() {
            let c = mesh.index(x, y);
            let edge = |k: usize| {
                let n = mesh.neighbour(x, y, k).expect("cell inside the map");
                let p = mesh.edge_3d(x, y, k).expect("cell inside the map");
                (n, p, base_uv_edge(k, resolution))
            };
            for k in [1, 2] {
                let ((n1, p1, b1), (n2, p2, b2)) = (edge(k - 1), edge(k));
                triangles[2 * c + k - 1] = Some(TableTriangle {
                    geometry: triangle_geometry(p1, p2),
                    corners: [c, n1, n2],
                    base: [b1, b2],
                });
            }
        }
        TriangleTable { triangles }
    }
}

/// A block: its moving nodes (index, hat weight w_n > 0; free nodes only) and the triangles
/// they touch with the hat weights of their three corners (0 outside the hat and for fixed
/// border nodes).
pub struct Block {
    pub nodes: Vec<(usize, f64)>,
    pub triangles: Vec<(usize, [f64; 3])>,
}

impl Block {
    /// The block of scale `r` centred at (cx, cy).
    pub fn new(
        mesh: &UnwarpMesh,
        table: &TriangleTable,
        r: usize,
        (cx, cy): (usize, usize),
    ) -> Block {
        let reach = r as i64 - 1;
        // Hat weight of the node (dx, dy) from the centre, 0 outside the hat or when fixed.
        let weight = |dx: i64, dy: i64| match node_at(mesh, cx, cy, dx, dy) {
            Some((x, y)) if dx.abs() <= reach && dy.abs() <= reach && mesh.is_free(x, y) => {
                hat_weight(dx, dy, r)
            }
            _ => 0.0,
        };
        let mut nodes = Vec::new();
        for dy in -reach..=reach {
            for dx in -reach..=reach {
                let w = weight(dx, dy);
                if w > 0.0 {
                    let (x, y) = node_at(mesh, cx, cy, dx, dy).expect("weighted node exists");
                    nodes.push((mesh.index(x, y), w));
                }
            }
        }
        // The cell owned by (x, y) is [x, x+1]×[y−1, y]: it touches a node within `reach` of
        // the centre iff x ∈ [cx − reach − 1, cx + reach], y ∈ [cy − reach, cy + reach + 1].
        // Its triangles: T_1 = ((x, y), (x, y−1), (x+1, y−1)), T_2 = ((x, y), (x+1, y−1),
        // (x+1, y)) (the stencil steps 0, 1, 2); those with a moving corner are listed.
        let mut triangles = Vec::new();
        for dy in -reach..=reach + 1 {
            for dx in -reach - 1..=reach {
                let Some((x, y)) = node_at(mesh, cx, cy, dx, dy) else {
                    continue;
                };
                let owner = mesh.index(x, y);
                let [c, n0, n1, n2] = [
                    weight(dx, dy),
                    weight(dx, dy - 1),
                    weight(dx + 1, dy - 1),
                    weight(dx + 1, dy),
                ];
                for (k, corners) in [(1, [c, n0, n1]), (2, [c, n1, n2])] {
                    let moves = corners.iter().any(|&w| w > 0.0);
                    if moves && table.triangles[2 * owner + k - 1].is_some() {
                        triangles.push((2 * owner + k - 1, corners));
                    }
                }
            }
        }
        Block { nodes, triangles }
    }
}

/// One triangle along the line o_n − t w_n G: twice its signed UV area a(t) = a₀ − t a₁ and
/// D(t) = d₀ + t d₁ + t² d₂ (the terms of [`super::energy::dirichlet`] with U(t) = U − t e G),
/// its 3D area A = `geometry.area`.
#[derive(Clone, Copy, Debug)]
pub struct LineTriangle {
    pub area: f64,
    pub a0: f64,
    pub a1: f64,
    pub d: [f64; 3],
}

/// |V − t e G|² = |V|² − 2t e V·G + t² e² |G|² as [c₀, c₁, c₂].
fn moving_square(v: [f64; 2], e: f64, g: [f64; 2]) -> [f64; 3] {
    [
        v[0] * v[0] + v[1] * v[1],
        -2.0 * e * (v[0] * g[0] + v[1] * g[1]),
        e * e * (g[0] * g[0] + g[1] * g[1]),
    ]
}

fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - b[0] * a[1]
}

impl LineTriangle {
    /// The triangle with geometry `geometry`, UV edges U1 = u(c) − u(n₁), U2 = u(c) − u(n₂)
    /// and hat weights (w_c, w₁, w₂), moving along −G: U1 − t e₁ G, U2 − t e₂ G with
    /// e₁ = w_c − w₁, e₂ = w_c − w₂.
    pub fn new(
        geometry: &TriangleGeometry,
        (u1, u2): ([f64; 2], [f64; 2]),
        [wc, w1, w2]: [f64; 3],
        g: [f64; 2],
    ) -> LineTriangle {
        let (e1, e2) = (wc - w1, wc - w2);
        let u12 = [u1[0] - u2[0], u1[1] - u2[1]];
        let (s12, s1, s2) = (
            moving_square(u12, e1 - e2, g),
            moving_square(u1, e1, g),
            moving_square(u2, e2, g),
        );
        LineTriangle {
            area: geometry.area,
            a0: cross(u1, u2),
            a1: e2 * cross(u1, g) + e1 * cross(g, u2),
            d: std::array::from_fn(|i| {
                s12[i] * geometry.c12 + s1[i] * geometry.c11 + s2[i] * geometry.c22
            }),
        }
    }

    /// E_T(t) = D(t)/(A a(t)) · (A/a(t) + a(t)/A)^θ, +∞ once folded (a(t) ≤ 0), as
    /// [`super::energy::triangle_energy`].
    pub fn energy(&self, t: f64, theta: f64) -> f64 {
        let a = self.a0 - t * self.a1;
        if a.is_nan() || a <= 0.0 {
            return f64::INFINITY;
        }
        let d = self.d[0] + t * (self.d[1] + t * self.d[2]);
        let y = self.area / a + a / self.area;
        d / (self.area * a) * theta_power(y, theta)
    }

    /// The step at which a(t) reaches 0, if it ever does for t > 0.
    pub fn fold_step(&self) -> Option<f64> {
        let t0 = self.a0 / self.a1;
        (t0 > 0.0).then_some(t0)
    }
}

/// ∂E_T/∂δ when the corners (c, n₁, n₂) move by (w_c δ, w₁ δ, w₂ δ): with e₁ = w_c − w₁,
/// e₂ = w_c − w₂, U1 and U2 move by e₁ δ and e₂ δ, so
///
///   ∂E_T/∂δ = Y^θ/(A a) (e₁ ∂D/∂U1 + e₂ ∂D/∂U2) + c_a (e₁ ∂a/∂U1 + e₂ ∂a/∂U2),
///
/// ∂D/∂U1 = 2[(U1 − U2) P1·P2 + U1 (P2 − P1)·P2], ∂D/∂U2 = 2[(U2 − U1) P1·P2 + U2 P1·(P1 − P2)],
/// ∂a/∂U1 = (U2.y, −U2.x), ∂a/∂U2 = (−U1.y, U1.x) and c_a = −D Y^θ/(A a²) +
/// D/(A a) θ Y^{θ−1} (1/A − A/a²) — with e₁ = e₂ = 1 this is [`super::energy::triangle_gradient`].
/// NaN for a folded triangle.
pub fn triangle_block_gradient(
    geometry: &TriangleGeometry,
    (u1, u2): ([f64; 2], [f64; 2]),
    [wc, w1, w2]: [f64; 3],
    theta: f64,
) -> [f64; 2] {
    let a = cross(u1, u2);
    if a.is_nan() || a <= 0.0 {
        return [f64::NAN; 2];
    }
    let (e1, e2) = (wc - w1, wc - w2);
    let big_a = geometry.area;
    let u12 = [u1[0] - u2[0], u1[1] - u2[1]];
    let d = u12[0] * u12[0] * geometry.c12
        + u12[1] * u12[1] * geometry.c12
        + (u1[0] * u1[0] + u1[1] * u1[1]) * geometry.c11
        + (u2[0] * u2[0] + u2[1] * u2[1]) * geometry.c22;
    let y = big_a / a + a / big_a;
    let y_theta_m1 = theta_power(y, theta - 1.0);
    let y_theta = y_theta_m1 * y;
    let d_coef = y_theta / (big_a * a);
    let a_coef = -d / (big_a * a * a) * y_theta
        + d / (big_a * a) * theta * y_theta_m1 * (1.0 / big_a - big_a / (a * a));
    std::array::from_fn(|i| {
        let dd_u1 = 2.0 * (u12[i] * geometry.c12 + u1[i] * geometry.c11);
        let dd_u2 = 2.0 * (-u12[i] * geometry.c12 + u2[i] * geometry.c22);
        // ∂a/∂U1 = (U2.y, −U2.x), ∂a/∂U2 = (−U1.y, U1.x).
        let (da_u1, da_u2) = if i == 0 {
            (u2[1], -u1[1])
        } else {
            (-u2[0], u1[0])
        };
        d_coef * (e1 * dd_u1 + e2 * dd_u2) + a_coef * (e1 * da_u1 + e2 * da_u2)
    })
}

/// G = ∂E/∂δ when every node n of `block` moves by w_n δ: Σ_T [`triangle_block_gradient`] over
/// the block's triangles + Σ_n w_n ∇E_pin(o_n), in list order.
pub fn block_gradient(
    problem: &Problem,
    table: &TriangleTable,
    offsets: &[[f64; 2]],
    block: &Block,
) -> [f64; 2] {
    let mut g = [0.0; 2];
    for &(i, weights) in &block.triangles {
        let t = table.triangles[i].as_ref().expect("listed triangles exist");
        let d = triangle_block_gradient(&t.geometry, t.uv_edges(offsets), weights, problem.theta);
        g = [g[0] + d[0], g[1] + d[1]];
    }
    for &(n, w) in &block.nodes {
        let p = pin_gradient(problem.pins[n], problem.pin_resolution, offsets[n]);
        g = [g[0] + w * p[0], g[1] + w * p[1]];
    }
    g
}

/// The new offsets of `block`'s nodes after one coarse move, or `None` when it does not move
/// (zero or non-finite G, empty bracket, or the guard refuses).
pub fn move_block(
    problem: &Problem,
    table: &TriangleTable,
    offsets: &[[f64; 2]],
    block: &Block,
    search_width: f64,
) -> Option<Vec<[f64; 2]>> {
    let (resolution, theta) = (problem.pin_resolution, problem.theta);
    let triangle = |i: usize| table.triangles[i].as_ref().expect("listed triangles exist");
    let g = block_gradient(problem, table, offsets, block);
    if !(g[0].is_finite() && g[1].is_finite()) || g == [0.0, 0.0] {
        return None;
    }
    let triangles: Vec<LineTriangle> = block
        .triangles
        .iter()
        .map(|&(i, weights)| {
            let t = triangle(i);
            LineTriangle::new(&t.geometry, t.uv_edges(offsets), weights, g)
        })
        .collect();
    // The bracket: the first fold, the first barrier.
    let mut hi = f64::INFINITY;
    for t in &triangles {
        if let Some(t0) = t.fold_step() {
            hi = hi.min(t0);
        }
    }
    for &(n, w) in &block.nodes {
        let step = [w * g[0], w * g[1]];
        if let Some(root) = pin_root(problem.pins[n], resolution, offsets[n], step) {
            hi = hi.min(root);
        }
    }
    if !(hi > 0.0 && hi.is_finite()) {
        return None;
    }
    // Unpinned nodes' barrier term is the constant ½: it cancels in the guard's comparison.
    let pinned: Vec<(usize, f64)> = block
        .nodes
        .iter()
        .copied()
        .filter(|&(n, _)| problem.pins[n] > 0.0)
        .collect();
    let energy = |t: f64| {
        let triangles: f64 = triangles.iter().map(|tri| tri.energy(t, theta)).sum();
        let pins: f64 = pinned
            .iter()
            .map(|&(n, w)| {
                let o = line_point(offsets[n], [w * g[0], w * g[1]], t);
                pin_energy(problem.pins[n], resolution, o)
            })
            .sum();
        triangles + pins
    };
    let search = golden_section_search(energy, 0.0, hi, search_width);
    (energy(search.t) < energy(0.0)).then(|| {
        block
            .nodes
            .iter()
            .map(|&(n, w)| line_point(offsets[n], [w * g[0], w * g[1]], search.t))
            .collect()
    })
}

/// 1/φ = (√5 − 1)/2, the golden section.
const INVERSE_GOLDEN: f64 = 0.618_033_988_749_894_9;

/// Golden-section search for the minimum of `f` on [lo, hi]: at most [`SEARCH_ITERATIONS`]
/// steps while hi − lo > `relative_width`·hi, with the interior points
/// c = hi − (hi − lo)/φ, d = lo + (hi − lo)/φ; f(c) > f(d) → lo = c, else hi = d (ties and
/// NaN shrink toward lo, as in [`super::pass::ternary_search`]). One new evaluation per step
/// (the ternary search of a texel step needs two): a coarse move touches 8r² − 2 triangles, so
/// its search is what it costs. Returns t = (lo + hi)/2.
pub fn golden_section_search(
    f: impl Fn(f64) -> f64,
    mut lo: f64,
    mut hi: f64,
    relative_width: f64,
) -> Search {
    let (mut c, mut d) = (
        hi - INVERSE_GOLDEN * (hi - lo),
        lo + INVERSE_GOLDEN * (hi - lo),
    );
    let (mut fc, mut fd) = (f(c), f(d));
    let (mut path, mut steps) = (0u32, 0u32);
    for i in 0..SEARCH_ITERATIONS {
        if hi - lo <= relative_width * hi {
            break;
        }
        if fc > fd {
            lo = c;
            (c, fc) = (d, fd);
            d = lo + INVERSE_GOLDEN * (hi - lo);
            fd = f(d);
            path |= 1 << i;
        } else {
            hi = d;
            (d, fd) = (c, fc);
            c = hi - INVERSE_GOLDEN * (hi - lo);
            fc = f(c);
        }
        steps += 1;
    }
    Search {
        t: 0.5 * (lo + hi),
        path,
        steps,
    }
}

/// What a coarse pass did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CoarsePassStats {
    pub blocks: usize,
    pub moved: usize,
}

/// One coarse pass of scale `r` and `phase` ∈ 0..4: [`move_block`] for every block centre of
/// the phase, in parallel from the same state, then written back in centre order.
pub fn coarse_pass(
    problem: &Problem,
    table: &TriangleTable,
    offsets: &mut [[f64; 2]],
    r: usize,
    phase: usize,
    search_width: f64,
) -> CoarsePassStats {
    let mesh = &problem.mesh;
    let centres = block_centres(mesh, r, phase);
    let moves: Vec<Option<(Block, Vec<[f64; 2]>)>> = centres
        .par_iter()
        .map(|&c| {
            let block = Block::new(mesh, table, r, c);
            move_block(problem, table, offsets, &block, search_width).map(|new| (block, new))
        })
        .collect();
    let mut stats = CoarsePassStats {
        blocks: centres.len(),
        moved: 0,
    };
    for (block, new) in moves.into_iter().flatten() {
        stats.moved += 1;
        for (&(n, _), o) in block.nodes.iter().zip(new) {
            offsets[n] = o;
        }
    }
    stats
}
