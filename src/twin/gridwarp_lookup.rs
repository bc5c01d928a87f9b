//! Twin of `gpu/shaders/gridwarp_lookup.wgsl`, function for function: the warped texture lookup
//! of a UV atlas with several solved ROIs (seed 000 §6, §8, §10.2;
//! [`crate::gridwarp::remap`]). Per query uv: the first ROI containing it ([`contains`]), its
//! ROI coordinates ([`st`]), the warped cell and (α, β) there ([`locate`]: AA by the lines'
//! [`cell_of`], NAA by [`locate_in_vertices`] over [`inverse_bilinear`]), the rest point, the
//! border blend ([`blend_weight`], [`finish`]) and back to UV ([`uv`]).
//!
//! The kernel's choices (which cell, which root of the quadratic) are made on the values, as
//! the WGSL makes them. For the bound ([`crate::crosscheck::gridwarp_lookup`]) the same
//! functions are composed with a given cell and root ([`lookup_in_cell`]), so that every
//! choice a conforming GPU may make near a cell edge or between two close roots is followed.

use super::real::{sign_bit, sqrt, Real, V2};

/// `AA`: a grid of warped lines.
pub const AA: usize = 0;
/// `NAA`: a grid of warped vertices.
pub const NAA: usize = 1;
/// `FAR_ROOT`.
pub const FAR_ROOT: f64 = crate::gridwarp::remap::FAR_ROOT;
/// `BBOX_SLACK`.
pub const BBOX_SLACK: f64 = crate::gridwarp::remap::BBOX_SLACK;
/// `NO_DISTANCE`: f32::MAX, the distance of a non-finite root.
pub const NO_DISTANCE: f64 = f32::MAX as f64;

/// The buffers the kernel reads (bindings 1–4), as the vectors store them.
#[derive(Clone, Copy, Debug)]
pub struct Tables<'a> {
    /// `rois`: u0, u1, v0, v1 per ROI.
    pub rois: &'a [f32],
    /// `roi_grids`: variant, blend, M, N, rest offset, warped offset per ROI.
    pub grids: &'a [u32],
    pub rest_lines: &'a [f32],
    pub warped: &'a [f32],
}

/// `RoiGrid`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RoiGrid {
    pub variant: usize,
    pub blend: bool,
    pub m: usize,
    pub n: usize,
    pub rest: usize,
    pub warped: usize,
}

/// `Roi`.
#[derive(Clone, Copy, Debug)]
pub struct Roi<R> {
    pub u0: R,
    pub u1: R,
    pub v0: R,
    pub v1: R,
}

fn read<R: Real>(x: f32) -> R {
    R::lit(f64::from(x))
}

impl Tables<'_> {
    /// The number of ROIs.
    pub fn roi_count(&self) -> usize {
        self.rois.len() / 4
    }

    /// `rois[k]`.
    pub fn roi<R: Real>(&self, k: usize) -> Roi<R> {
        let r = &self.rois[4 * k..4 * k + 4];
        Roi {
            u0: read(r[0]),
            u1: read(r[1]),
            v0: read(r[2]),
            v1: read(r[3]),
        }
    }

    /// `roi_grids[k]`.
    pub fn grid(&self, k: usize) -> RoiGrid {
        let g = &self.grids[6 * k..6 * k + 6];
        RoiGrid {
            variant: g[0] as usize,
            blend: g[1] != 0,
            m: g[2] as usize,
            n: g[3] as usize,
            rest: g[4] as usize,
            warped: g[5] as usize,
        }
    }

    fn warped<R: Real>(&self, k: usize) -> R {
        read(self.warped[k])
    }

    fn rest<R: Real>(&self, k: usize) -> R {
        read(self.rest_lines[k])
    }
}

/// `clamp01`: both coordinates clamped to [0, 1] (`clamp(x, 0, 1)` = min(max(x, 0), 1)).
pub fn clamp01<R: Real>(p: V2<R>) -> V2<R> {
    V2::new(clamp(p.x), clamp(p.y))
}

fn clamp<R: Real>(x: R) -> R {
    x.max(R::lit(0.0)).min(R::lit(1.0))
}

fn is_finite<R: Real>(x: R) -> bool {
    super::real::is_finite(x)
}

/// `contains`: the closed rectangle [u0, u1] × [v0, v1] holds uv.
pub fn contains<R: Real>(r: &Roi<R>, q: V2<R>) -> bool {
    q.x >= r.u0 && q.x <= r.u1 && q.y >= r.v0 && q.y <= r.v1
}

/// `st`: ((u − u0)/(u1 − u0), (v − v0)/(v1 − v0)).
pub fn st<R: Real>(r: &Roi<R>, q: V2<R>) -> V2<R> {
    V2::new((q.x - r.u0) / (r.u1 - r.u0), (q.y - r.v0) / (r.v1 - r.v0))
}

/// `uv`: (u0 + s (u1 − u0), v0 + t (v1 − v0)).
pub fn uv<R: Real>(r: &Roi<R>, p: V2<R>) -> V2<R> {
    V2::new(r.u0 + p.x * (r.u1 - r.u0), r.v0 + p.y * (r.v1 - r.v0))
}

/// `cell_of`: the largest k in 1 … count − 2 with warped[offset + k] ≤ x, else 0.
pub fn cell_of<R: Real>(t: &Tables, offset: usize, count: usize, x: R) -> usize {
    let mut cell = 0;
    for k in 1..count.saturating_sub(1) {
        if t.warped::<R>(offset + k) <= x {
            cell = k;
        }
    }
    cell
}

/// `cross2`: a × b = a_x b_y − a_y b_x.
pub fn cross2<R: Real>(a: V2<R>, b: V2<R>) -> R {
    a.x * b.y - a.y * b.x
}

/// `vertex`: P_ab of an NAA grid.
pub fn vertex<R: Real>(t: &Tables, g: &RoiGrid, a: usize, b: usize) -> V2<R> {
    let o = g.warped + 2 * (a * g.n + b);
    V2::new(t.warped(o), t.warped(o + 1))
}

/// `quad`: [P00, P10, P01, P11] of cell (i, j).
pub fn quad<R: Real>(t: &Tables, g: &RoiGrid, i: usize, j: usize) -> [V2<R>; 4] {
    [
        vertex(t, g, i, j),
        vertex(t, g, i + 1, j),
        vertex(t, g, i, j + 1),
        vertex(t, g, i + 1, j + 1),
    ]
}

/// `bilinear`: (1−α)(1−β) P00 + α(1−β) P10 + (1−α)β P01 + αβ P11.
pub fn bilinear<R: Real>(q: &[V2<R>; 4], alpha: R, beta: R) -> V2<R> {
    let one = R::lit(1.0);
    V2::sum(&[
        q[0] * ((one - alpha) * (one - beta)),
        q[1] * (alpha * (one - beta)),
        q[2] * ((one - alpha) * beta),
        q[3] * (alpha * beta),
    ])
}

/// `Quadratic`.
#[derive(Clone, Copy, Debug)]
pub struct Quadratic<R> {
    pub e: V2<R>,
    pub f: V2<R>,
    pub g: V2<R>,
    pub d: V2<R>,
    pub a: R,
    pub b: R,
    pub c: R,
}

/// `quadratic`: e = P10 − P00, f = P01 − P00, g = (P11 − P10) − f, d = p − P00; a = f × g,
/// b = f × e − d × g, c = −(d × e).
pub fn quadratic<R: Real>(q: &[V2<R>; 4], p: V2<R>) -> Quadratic<R> {
    let e = q[1] - q[0];
    let f = q[2] - q[0];
    let g = (q[3] - q[1]) - f;
    let d = p - q[0];
    Quadratic {
        e,
        f,
        g,
        d,
        a: cross2(f, g),
        b: cross2(f, e) - cross2(d, g),
        c: -cross2(d, e),
    }
}

/// `Roots`: the near root c/q and, where |q| ≤ 4|a|, the far root q/a.
#[derive(Clone, Copy, Debug)]
pub struct Roots<R> {
    pub near: R,
    pub far: Option<R>,
}

/// `roots`: q = −½ (b + sgn(b) √max(b² − 4ac, 0)) (sgn from b's sign bit).
pub fn roots<R: Real>(k: &Quadratic<R>) -> Roots<R> {
    let disc = sqrt((k.b * k.b - R::lit(4.0) * k.a * k.c).max(R::lit(0.0)));
    let sgn = R::lit(if sign_bit(k.b) { -1.0 } else { 1.0 });
    let q = R::lit(-0.5) * (k.b + sgn * disc);
    let near = k.c / q;
    let far = (q.abs() <= R::lit(FAR_ROOT) * k.a.abs()).then(|| q / k.a);
    Roots { near, far }
}

/// `root_distance`: |x − clamp(x, 0, 1)|, [`NO_DISTANCE`] when x is not finite.
pub fn root_distance<R: Real>(x: R) -> R {
    if is_finite(x) {
        (x - clamp(x)).abs()
    } else {
        R::lit(NO_DISTANCE)
    }
}

/// Which root `choose_root` takes: 0 (near) unless the far one is strictly nearer to [0, 1].
pub fn choose_root_index<R: Real>(r: &Roots<R>) -> usize {
    match r.far {
        Some(far) if root_distance(far) < root_distance(r.near) => 1,
        _ => 0,
    }
}

/// `choose_root`.
pub fn choose_root<R: Real>(r: &Roots<R>) -> R {
    match (choose_root_index(r), r.far) {
        (1, Some(far)) => far,
        _ => r.near,
    }
}

/// `alpha_of`: (d − β f)·(e + β g) / ‖e + β g‖².
pub fn alpha_of<R: Real>(k: &Quadratic<R>, beta: R) -> R {
    let axis = k.e + k.g * beta;
    let rhs = k.d - k.f * beta;
    let n2 = axis.x * axis.x + axis.y * axis.y;
    (rhs.x * axis.x + rhs.y * axis.y) / n2
}

/// `newton_polish`: (α, β) + J⁻¹ (p − W(α, β)), J = [e + β g, f + α g], by Cramer's rule;
/// unchanged where det J is 0 or not finite, or a step is not finite.
pub fn newton_polish<R: Real>(q: &[V2<R>; 4], p: V2<R>, k: &Quadratic<R>, ab: V2<R>) -> V2<R> {
    let (alpha, beta) = (ab.x, ab.y);
    let w = bilinear(q, alpha, beta);
    let r = p - w;
    let ja = k.e + k.g * beta;
    let jb = k.f + k.g * alpha;
    let det = cross2(ja, jb);
    if det.abs().value() > 0.0 && is_finite(det) {
        let da = cross2(r, jb) / det;
        let db = cross2(ja, r) / det;
        if is_finite(da) && is_finite(db) {
            return V2::new(alpha + da, beta + db);
        }
    }
    V2::new(alpha, beta)
}

/// `inverse_bilinear_with_root`: α for the root β ([`alpha_of`]), then [`newton_polish`];
/// None where α or β is not finite.
pub fn inverse_bilinear_with_root<R: Real>(
    q: &[V2<R>; 4],
    p: V2<R>,
    k: &Quadratic<R>,
    beta: R,
) -> Option<V2<R>> {
    let alpha = alpha_of(k, beta);
    if !is_finite(alpha) || !is_finite(beta) {
        return None;
    }
    Some(newton_polish(q, p, k, V2::new(alpha, beta)))
}

/// `inverse_bilinear`: [`quadratic`], [`roots`], [`choose_root`], then
/// [`inverse_bilinear_with_root`].
pub fn inverse_bilinear<R: Real>(q: &[V2<R>; 4], p: V2<R>) -> Option<V2<R>> {
    let k = quadratic(q, p);
    inverse_bilinear_with_root(q, p, &k, choose_root(&roots(&k)))
}

/// `in_bbox`: the corners' box, widened by [`BBOX_SLACK`] times its half-perimeter, holds p.
pub fn in_bbox<R: Real>(q: &[V2<R>; 4], p: V2<R>) -> bool {
    let (mut lo, mut hi) = (q[0], q[0]);
    for c in &q[1..] {
        lo = V2::new(lo.x.min(c.x), lo.y.min(c.y));
        hi = V2::new(hi.x.max(c.x), hi.y.max(c.y));
    }
    let slack = R::lit(BBOX_SLACK) * ((hi.x - lo.x) + (hi.y - lo.y));
    !(p.x < lo.x - slack || p.x > hi.x + slack || p.y < lo.y - slack || p.y > hi.y + slack)
}

/// `outside`: max(0, |α − clamp(α)|, |β − clamp(β)|).
pub fn outside<R: Real>(ab: V2<R>) -> R {
    R::lit(0.0)
        .max((ab.x - clamp(ab.x)).abs())
        .max((ab.y - clamp(ab.y)).abs())
}

/// `Located`: the warped cell (i, j), (α, β) there and the rest point.
#[derive(Clone, Copy, Debug)]
pub struct Located<R> {
    pub i: usize,
    pub j: usize,
    pub alpha: R,
    pub beta: R,
    pub rest: V2<R>,
}

/// `locate_in_vertices`: column-major over the cells whose box holds p, the first whose
/// (α, β) lies in [0, 1]², else the nearest (the first on ties), clamped; the rest point is
/// left to [`locate`]. None when no cell has a finite solution.
pub fn locate_in_vertices<R: Real>(
    t: &Tables,
    g: &RoiGrid,
    p: V2<R>,
) -> Option<(usize, usize, V2<R>)> {
    let mut best: Option<(R, usize, usize, V2<R>)> = None;
    for i in 0..g.m - 1 {
        for j in 0..g.n - 1 {
            let q = quad(t, g, i, j);
            if !in_bbox(&q, p) {
                continue;
            }
            let Some(ab) = inverse_bilinear(&q, p) else {
                continue;
            };
            let miss = outside(ab);
            if miss.value() <= 0.0 {
                return Some((i, j, ab));
            }
            if best.is_none_or(|b| miss < b.0) {
                best = Some((miss, i, j, ab));
            }
        }
    }
    best.map(|(_, i, j, ab)| (i, j, clamp01(ab)))
}

/// The AA cell's (α, β) of p: ((p_s − s_i)/(s_{i+1} − s_i), (p_t − t_j)/(t_{j+1} − t_j)).
pub fn in_lines<R: Real>(t: &Tables, g: &RoiGrid, i: usize, j: usize, p: V2<R>) -> V2<R> {
    let s0 = t.warped::<R>(g.warped + i);
    let s1 = t.warped::<R>(g.warped + i + 1);
    let t0 = t.warped::<R>(g.warped + g.m + j);
    let t1 = t.warped::<R>(g.warped + g.m + j + 1);
    V2::new((p.x - s0) / (s1 - s0), (p.y - t0) / (t1 - t0))
}

/// The rest point (ŝ_i + α (ŝ_{i+1} − ŝ_i), t̂_j + β (t̂_{j+1} − t̂_j)) of cell (i, j).
pub fn located_at<R: Real>(t: &Tables, g: &RoiGrid, i: usize, j: usize, ab: V2<R>) -> Located<R> {
    let rs0 = t.rest::<R>(g.rest + i);
    let rs1 = t.rest::<R>(g.rest + i + 1);
    let rt0 = t.rest::<R>(g.rest + g.m + j);
    let rt1 = t.rest::<R>(g.rest + g.m + j + 1);
    Located {
        i,
        j,
        alpha: ab.x,
        beta: ab.y,
        rest: V2::new(rs0 + ab.x * (rs1 - rs0), rt0 + ab.y * (rt1 - rt0)),
    }
}

/// `locate`: p clamped, its cell and (α, β) (AA: [`cell_of`] on each axis and [`in_lines`];
/// NAA: [`locate_in_vertices`]), and the rest point ([`located_at`]).
pub fn locate<R: Real>(t: &Tables, g: &RoiGrid, p: V2<R>) -> Option<Located<R>> {
    let p = clamp01(p);
    let (i, j, ab) = if g.variant == AA {
        let i = cell_of(t, g.warped, g.m, p.x);
        let j = cell_of(t, g.warped + g.m, g.n, p.y);
        (i, j, in_lines(t, g, i, j, p))
    } else {
        locate_in_vertices(t, g, p)?
    };
    Some(located_at(t, g, i, j, ab))
}

/// `edge`: max(1 − x in the first cell, x in the last, 0), clamped to [0, 1].
pub fn edge<R: Real>(k: usize, cells: usize, x: R) -> R {
    let mut w = R::lit(0.0);
    if k == 0 {
        w = w.max(R::lit(1.0) - x);
    }
    if k + 1 == cells {
        w = w.max(x);
    }
    clamp(w)
}

/// `blend_weight`: w = 1 − (1 − w_s)(1 − w_t); 0 without blending.
pub fn blend_weight<R: Real>(g: &RoiGrid, at: &Located<R>) -> R {
    let one = R::lit(1.0);
    if !g.blend {
        return R::lit(0.0);
    }
    let ws = edge(at.i, g.m - 1, at.alpha);
    let wt = edge(at.j, g.n - 1, at.beta);
    one - (one - ws) * (one - wt)
}

/// What `lookup` does once p is located: the rest point, or (1 − w) rest + w clamp(p) where
/// the blend weight w is not 0.
pub fn finish<R: Real>(g: &RoiGrid, at: &Located<R>, p: V2<R>) -> V2<R> {
    let w = blend_weight(g, at);
    if w.value() == 0.0 {
        return at.rest;
    }
    let pc = clamp01(p);
    let one = R::lit(1.0);
    V2::new(
        (one - w) * at.rest.x + w * pc.x,
        (one - w) * at.rest.y + w * pc.y,
    )
}

/// `lookup`: [`locate`] then [`finish`]; p itself where no cell is found.
pub fn lookup<R: Real>(t: &Tables, g: &RoiGrid, p: V2<R>) -> V2<R> {
    match locate(t, g, p) {
        Some(at) => finish(g, &at, p),
        None => p,
    }
}

/// `lookup_uv`: through the first ROI containing uv ([`uv`] ∘ [`lookup`] ∘ [`st`]), else uv.
pub fn lookup_uv<R: Real>(t: &Tables, q: V2<R>) -> V2<R> {
    for k in 0..t.roi_count() {
        let r = t.roi::<R>(k);
        if contains(&r, q) {
            return uv(&r, lookup(t, &t.grid(k), st(&r, q)));
        }
    }
    q
}

/// One path through ROI k's lookup with its choices made: the root taken and α before the
/// Newton step (NAA only), (α, β) before clamping, and the looked-up UV.
#[derive(Clone, Copy, Debug)]
pub struct CellPath<R> {
    pub root: Option<R>,
    pub alpha0: Option<R>,
    pub ab: V2<R>,
    pub out: V2<R>,
}

/// One path through ROI k's lookup with its choices given: cell (i, j) and, for an NAA cell,
/// the root (0 near, 1 far) of its quadratic; p = clamp(st(uv)) located there (AA:
/// [`in_lines`]; NAA: [`inverse_bilinear_with_root`], clamped), [`finish`], [`uv`]. None where
/// that root does not exist or has no finite solution. What the bound follows for every
/// choice a conforming GPU may make.
pub fn lookup_in_cell<R: Real>(
    t: &Tables,
    k: usize,
    (i, j): (usize, usize),
    root: usize,
    q: V2<R>,
) -> Option<CellPath<R>> {
    let r = t.roi::<R>(k);
    let g = t.grid(k);
    let p_in = st(&r, q);
    let p = clamp01(p_in);
    let (ab, beta, alpha0) = if g.variant == AA {
        (in_lines(t, &g, i, j, p), None, None)
    } else {
        let corners = quad(t, &g, i, j);
        let kq = quadratic(&corners, p);
        let rs = roots(&kq);
        let beta = if root == 0 { Some(rs.near) } else { rs.far }?;
        let ab = inverse_bilinear_with_root(&corners, p, &kq, beta)?;
        (ab, Some(beta), Some(alpha_of(&kq, beta)))
    };
    let at = located_at(t, &g, i, j, clamp01(ab));
    Some(CellPath {
        root: beta,
        alpha0,
        ab,
        out: uv(&r, finish(&g, &at, p_in)),
    })
}
