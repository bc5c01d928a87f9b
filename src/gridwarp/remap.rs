//! The remapping of the ROI's parameter space by the warped grid (seed §6, §8, §10.2).
//!
//! **Axis-aligned (§6).** F_s maps the rest lines ŝ to the warped lines s piecewise linearly
//! (F_t likewise); both are strictly increasing, hence invertible. Altering texture coordinates
//! uses the inverses: a surface point with ROI coordinates (s, t) shows the texture at
//! (F_s⁻¹(s), F_t⁻¹(t)).
//!
//! **Non-axis-aligned (§8).** Rest cell (i, j) = [ŝ_i, ŝ_{i+1}] × [t̂_j, t̂_{j+1}] is mapped onto
//! the warped quad P_ij, P_{i+1,j}, P_{i,j+1}, P_{i+1,j+1} by the bilinear map
//! W(α, β) = (1−α)(1−β) P00 + α(1−β) P10 + (1−α)β P01 + αβ P11 with (α, β) the fractional rest
//! position. The texture lookup is the inverse: find the warped quad containing (s, t), solve
//! W(α, β) = (s, t) for (α, β) ∈ [0, 1]² ([`inverse_bilinear`]), and return the rest point
//! (ŝ_i + α h_i, t̂_j + β k_j). On an axis-aligned vertex grid this is exactly F⁻¹.
//!
//! **Boundary blending (§10.2).** F⁻¹ fixes the ROI's outline as a set but not pointwise: along
//! a vertical edge s = 0 the AA lookup still moves t to F_t⁻¹(t), while outside the ROI the
//! parameterisation is the identity — a seam. [`Remap::with_boundary_blend`] blends, inside the
//! warped grid's boundary cells, the optimised lookup with the identity:
//!
//!   lookup(p) = (1 − w) F⁻¹(p) + w p,  w = 1 − (1 − w_s)(1 − w_t),
//!
//! w_s = 1 − α in the first cell column and α in the last (α the fractional position of p in its
//! warped cell), 0 elsewhere; w_t likewise with β and the cell rows. So approaching a vertical
//! edge (α → 0 in column 0) the lookup tends to p — both coordinates, which is what continuity
//! with the unwarped texture outside needs — approaching a horizontal edge likewise, and the
//! interior cells (w = 0) are unchanged. The blend is continuous across the inner sides of the
//! boundary cells (w → 0 there). As the seed says, the boundary cells should hold non-rigid
//! content: the blend gives up the optimisation there.

use super::energy_naa::VertexGrid;
use super::grid::Grid;
use super::rasterize::Roi;
use crate::error::{Error, Result};

/// Piecewise-linear map through the points (from_i, to_i) (both strictly increasing, from 0 to
/// 1), clamped outside [0, 1].
pub fn piecewise_linear(from: &[f64], to: &[f64], x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    let i = cell_of(from, x);
    let alpha = (x - from[i]) / (from[i + 1] - from[i]);
    to[i] + alpha * (to[i + 1] - to[i])
}

/// Index of the cell of the increasing `lines` containing x: the largest k in 1 … len − 2 with
/// lines\[k\] ≤ x, else 0 (so the last cell for x ≥ its start, the first for x below, and the
/// first for NaN). A plain count over the lines, as the WGSL kernel `gridwarp_lookup` does it
/// (the same index as a binary search over increasing lines).
pub fn cell_of(lines: &[f64], x: f64) -> usize {
    let mut cell = 0;
    for (k, &line) in lines
        .iter()
        .enumerate()
        .take(lines.len().saturating_sub(1))
        .skip(1)
    {
        if line <= x {
            cell = k;
        }
    }
    cell
}

/// F(s, t) = (F_s(s), F_t(t)): rest ROI coordinates to warped ones.
pub fn forward(rest: &Grid, warped: &Grid, st: [f64; 2]) -> [f64; 2] {
    [
        piecewise_linear(&rest.s, &warped.s, st[0]),
        piecewise_linear(&rest.t, &warped.t, st[1]),
    ]
}

/// F⁻¹(s, t) = (F_s⁻¹(s), F_t⁻¹(t)): warped ROI coordinates to rest ones (the texture lookup of
/// seed §6, "alter the texture coordinates").
pub fn inverse(rest: &Grid, warped: &Grid, st: [f64; 2]) -> [f64; 2] {
    [
        piecewise_linear(&warped.s, &rest.s, st[0]),
        piecewise_linear(&warped.t, &rest.t, st[1]),
    ]
}

/// 2-D cross product a × b = a_x b_y − a_y b_x.
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// The bilinear map of the quad `q` = [P00, P10, P01, P11] at (α, β).
pub fn bilinear(q: &[[f64; 2]; 4], alpha: f64, beta: f64) -> [f64; 2] {
    std::array::from_fn(|k| {
        (1.0 - alpha) * (1.0 - beta) * q[0][k]
            + alpha * (1.0 - beta) * q[1][k]
            + (1.0 - alpha) * beta * q[2][k]
            + alpha * beta * q[3][k]
    })
}

/// The quadratic of the inverse bilinear map of quad `q` = [P00, P10, P01, P11] at p: with
/// e = P10 − P00, f = P01 − P00, g = (P11 − P10) − f and d = p − P00 (everything re-centred on
/// P00), d = α (e + β g) + β f; crossing with e + β g eliminates α:
///
///   a β² + b β + c = 0,   a = f × g,   b = f × e − d × g,   c = −(d × e).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadratic {
    pub e: [f64; 2],
    pub f: [f64; 2],
    pub g: [f64; 2],
    pub d: [f64; 2],
    pub a: f64,
    pub b: f64,
    pub c: f64,
}

/// The [`Quadratic`] of quad `q` at p.
pub fn quadratic(q: &[[f64; 2]; 4], p: [f64; 2]) -> Quadratic {
    let sub = |a: [f64; 2], b: [f64; 2]| [a[0] - b[0], a[1] - b[1]];
    let e = sub(q[1], q[0]);
    let f = sub(q[2], q[0]);
    let g = sub(sub(q[3], q[1]), f);
    let d = sub(p, q[0]);
    Quadratic {
        e,
        f,
        g,
        d,
        a: cross(f, g),
        b: cross(f, e) - cross(d, g),
        c: -cross(d, e),
    }
}

/// A far root is considered only when |far| ≤ this (|q| ≤ FAR_ROOT·|a|); beyond, it is more
/// than 3 from [0, 1], farther than any root a located point can take (see [`roots`]).
pub const FAR_ROOT: f64 = 4.0;

/// The two roots of a β² + b β + c = 0 without cancellation: with
/// q = −½ (b + sgn(b) √max(b² − 4ac, 0)) (sgn(±0) = ±1), the near root c/q and the far root
/// q/a. The far root is `None` when |q| > [`FAR_ROOT`]·|a|, which includes a = 0 (a
/// parallelogram: the equation is linear and c/q = −c/b its root): then |q/a| > 4 and no point
/// located in the cell takes it. The near root may be non-finite (q = 0).
pub fn roots(k: &Quadratic) -> (f64, Option<f64>) {
    let disc = (k.b * k.b - 4.0 * k.a * k.c).max(0.0).sqrt();
    let q = -0.5 * (k.b + k.b.signum() * disc);
    let near = k.c / q;
    let far = (q.abs() <= FAR_ROOT * k.a.abs()).then(|| q / k.a);
    (near, far)
}

/// How far a root lies outside [0, 1] (+∞ for a non-finite one).
pub fn root_distance(x: f64) -> f64 {
    if x.is_finite() {
        (x - x.clamp(0.0, 1.0)).abs()
    } else {
        f64::INFINITY
    }
}

/// The root of [`roots`] taken: the near one unless the far one lies strictly nearer to
/// [0, 1] (index 0: near, 1: far).
pub fn choose_root(near: f64, far: Option<f64>) -> usize {
    match far {
        Some(far) if root_distance(far) < root_distance(near) => 1,
        _ => 0,
    }
}

/// α for a root β: the least-squares solution (d − β f)·(e + β g) / ‖e + β g‖² of
/// d − β f = α (e + β g) (exact when p lies on the line of that β).
pub fn alpha_of(k: &Quadratic, beta: f64) -> f64 {
    let axis = [k.e[0] + beta * k.g[0], k.e[1] + beta * k.g[1]];
    let rhs = [k.d[0] - beta * k.f[0], k.d[1] - beta * k.f[1]];
    let n2 = axis[0] * axis[0] + axis[1] * axis[1];
    (rhs[0] * axis[0] + rhs[1] * axis[1]) / n2
}

/// One Newton step on W(α, β) = p from (α, β): J = [∂W/∂α ∂W/∂β] = [e + β g, f + α g],
/// (α, β) + J⁻¹ (p − W(α, β)) by Cramer's rule; (α, β) unchanged where det J is 0 or a step
/// is not finite. W is bilinear, so one step from an error (δα, δβ) leaves exactly
/// J⁻¹ g δα δβ: the closed form's rounding is squared away.
pub fn newton_polish(q: &[[f64; 2]; 4], p: [f64; 2], k: &Quadratic, ab: [f64; 2]) -> [f64; 2] {
    let [alpha, beta] = ab;
    let w = bilinear(q, alpha, beta);
    let r = [p[0] - w[0], p[1] - w[1]];
    let ja = [k.e[0] + beta * k.g[0], k.e[1] + beta * k.g[1]];
    let jb = [k.f[0] + alpha * k.g[0], k.f[1] + alpha * k.g[1]];
    let det = cross(ja, jb);
    if det.abs() > 0.0 && det.is_finite() {
        let da = cross(r, jb) / det;
        let db = cross(ja, r) / det;
        if da.is_finite() && db.is_finite() {
            return [alpha + da, beta + db];
        }
    }
    [alpha, beta]
}

/// Solve W(α, β) = p for the bilinear quad `q` = [P00, P10, P01, P11] (closed form, seed §8).
///
/// The [`quadratic`] in β (re-centred on P00), its [`roots`] without cancellation, the root in
/// [0, 1] or nearest to it ([`choose_root`]), α by least squares ([`alpha_of`]), then one
/// Newton step ([`newton_polish`]) to rounding. On a valid (convex, positive corner
/// determinants) quad the solution in [0, 1]² is unique. Returns None for a degenerate quad
/// (no finite solution).
pub fn inverse_bilinear(q: &[[f64; 2]; 4], p: [f64; 2]) -> Option<[f64; 2]> {
    let k = quadratic(q, p);
    let (near, far) = roots(&k);
    let root = choose_root(near, far);
    inverse_bilinear_with_root(q, p, &k, [near, far.unwrap_or(f64::NAN)][root])
}

/// [`inverse_bilinear`] from a given root β of the quadratic `k` (what the bound of the f32
/// kernel follows for either root, `crosscheck::gridwarp_lookup`).
pub fn inverse_bilinear_with_root(
    q: &[[f64; 2]; 4],
    p: [f64; 2],
    k: &Quadratic,
    beta: f64,
) -> Option<[f64; 2]> {
    let alpha = alpha_of(k, beta);
    if !alpha.is_finite() || !beta.is_finite() {
        return None;
    }
    Some(newton_polish(q, p, k, [alpha, beta]))
}

/// The warped grid of a solve: lines (axis-aligned) or vertices (non-axis-aligned).
#[derive(Clone, Debug, PartialEq)]
pub enum Warped {
    Lines(Grid),
    Vertices(VertexGrid),
}

/// Options of a [`Remap`]. Default: no boundary blending (the plain F⁻¹ of seed §6).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RemapOptions {
    /// Blend towards the identity in the boundary cells (seed §10.2, module docs).
    pub boundary_blend: bool,
}

/// Where a point of the warped ROI lies: its warped cell (i, j), its fractional position
/// (α, β) in it, and the rest point it comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Located {
    pub cell: (usize, usize),
    pub alpha: f64,
    pub beta: f64,
    pub rest: [f64; 2],
}

/// The texture lookup of a solved ROI: warped ROI coordinates → rest ROI coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct Remap {
    pub rest: Grid,
    pub warped: Warped,
    pub options: RemapOptions,
}

impl Remap {
    /// The lookup of `warped` relative to `rest`, without boundary blending.
    pub fn new(rest: Grid, warped: Warped) -> Remap {
        Remap {
            rest,
            warped,
            options: RemapOptions::default(),
        }
    }

    /// The identity (warped = rest lines).
    pub fn identity(rest: Grid) -> Remap {
        Remap::new(rest.clone(), Warped::Lines(rest))
    }

    /// The same lookup with boundary blending on or off (seed §10.2).
    pub fn with_boundary_blend(mut self, blend: bool) -> Remap {
        self.options.boundary_blend = blend;
        self
    }

    /// Locate the warped point `p` (clamped to the unit square): its warped cell, (α, β) and
    /// rest point (ŝ_i + α h_i, t̂_j + β k_j). AA: the cells of the lines ([`cell_of`]),
    /// α = (p_s − s_i)/(s_{i+1} − s_i), β likewise. NAA: [`locate_in_vertices`] (the first quad,
    /// column-major, whose inverse bilinear (α, β) lies in [0, 1]², else the nearest); None only
    /// for a degenerate vertex grid.
    pub fn locate(&self, p: [f64; 2]) -> Option<Located> {
        let p = [p[0].clamp(0.0, 1.0), p[1].clamp(0.0, 1.0)];
        let rest = &self.rest;
        let (i, j, alpha, beta) = match &self.warped {
            Warped::Lines(w) => {
                let (i, j) = (cell_of(&w.s, p[0]), cell_of(&w.t, p[1]));
                (
                    i,
                    j,
                    (p[0] - w.s[i]) / (w.s[i + 1] - w.s[i]),
                    (p[1] - w.t[j]) / (w.t[j + 1] - w.t[j]),
                )
            }
            Warped::Vertices(v) => locate_in_vertices(v, p)?,
        };
        Some(Located {
            cell: (i, j),
            alpha,
            beta,
            rest: [
                rest.s[i] + alpha * (rest.s[i + 1] - rest.s[i]),
                rest.t[j] + beta * (rest.t[j + 1] - rest.t[j]),
            ],
        })
    }

    /// The blending weight w = 1 − (1 − w_s)(1 − w_t) of a located point (module docs); 0
    /// without boundary blending.
    pub fn blend_weight(&self, at: &Located) -> f64 {
        if !self.options.boundary_blend {
            return 0.0;
        }
        let (m, n) = (self.rest.s.len() - 1, self.rest.t.len() - 1);
        let edge = |k: usize, cells: usize, x: f64| -> f64 {
            let mut w: f64 = 0.0;
            if k == 0 {
                w = w.max(1.0 - x);
            }
            if k + 1 == cells {
                w = w.max(x);
            }
            w.clamp(0.0, 1.0)
        };
        let (ws, wt) = (edge(at.cell.0, m, at.alpha), edge(at.cell.1, n, at.beta));
        1.0 - (1.0 - ws) * (1.0 - wt)
    }

    /// The texture lookup of warped ROI point `p`: F⁻¹(p) (AA) or the inverse bilinear lookup
    /// (NAA), blended with p in the boundary cells when asked (module docs). Points outside the
    /// unit square are clamped onto it first.
    pub fn lookup(&self, p: [f64; 2]) -> [f64; 2] {
        let Some(at) = self.locate(p) else {
            return p;
        };
        let w = self.blend_weight(&at);
        if w == 0.0 {
            return at.rest;
        }
        let p = [p[0].clamp(0.0, 1.0), p[1].clamp(0.0, 1.0)];
        [
            (1.0 - w) * at.rest[0] + w * p[0],
            (1.0 - w) * at.rest[1] + w * p[1],
        ]
    }

    /// The warped image of the rest point `st` (forward map F, or W of its rest cell).
    pub fn forward(&self, st: [f64; 2]) -> [f64; 2] {
        match &self.warped {
            Warped::Lines(w) => forward(&self.rest, w, st),
            Warped::Vertices(v) => {
                let (s, t) = (st[0].clamp(0.0, 1.0), st[1].clamp(0.0, 1.0));
                let (i, j) = (cell_of(&self.rest.s, s), cell_of(&self.rest.t, t));
                let alpha = (s - self.rest.s[i]) / (self.rest.s[i + 1] - self.rest.s[i]);
                let beta = (t - self.rest.t[j]) / (self.rest.t[j + 1] - self.rest.t[j]);
                bilinear(&quad(v, i, j), alpha, beta)
            }
        }
    }
}

/// The corners [P00, P10, P01, P11] of cell (i, j).
pub fn quad(v: &VertexGrid, i: usize, j: usize) -> [[f64; 2]; 4] {
    [
        v.at(i, j),
        v.at(i + 1, j),
        v.at(i, j + 1),
        v.at(i + 1, j + 1),
    ]
}

/// How far (α, β) lies outside [0, 1]² (0 inside).
pub fn outside(ab: [f64; 2]) -> f64 {
    ab.iter()
        .map(|&x| (x - x.clamp(0.0, 1.0)).abs())
        .fold(0.0, f64::max)
}

/// The bounding-box test of [`locate_in_vertices`] admits points within this fraction of the
/// box's half-perimeter outside it (2⁻¹²: a prefilter only, wide enough for f32's rounding of
/// p, so that the f32 kernel never skips the cell that contains p).
pub const BBOX_SLACK: f64 = 1.0 / 4096.0;

/// The corners' bounding box of quad `q`, widened by [`BBOX_SLACK`] times its half-perimeter,
/// contains p.
pub fn in_bbox(q: &[[f64; 2]; 4], p: [f64; 2]) -> bool {
    let (mut lo, mut hi) = (q[0], q[0]);
    for c in &q[1..] {
        lo = [lo[0].min(c[0]), lo[1].min(c[1])];
        hi = [hi[0].max(c[0]), hi[1].max(c[1])];
    }
    let slack = BBOX_SLACK * ((hi[0] - lo[0]) + (hi[1] - lo[1]));
    !(p[0] < lo[0] - slack || p[0] > hi[0] + slack || p[1] < lo[1] - slack || p[1] > hi[1] + slack)
}

/// The cell of a vertex grid containing `p` and (α, β) there, clamped to [0, 1]: over the
/// cells in column-major order (i outer, j inner), those whose box holds p ([`in_bbox`]), the
/// first whose [`inverse_bilinear`] (α, β) lies in [0, 1]², else the one whose (α, β) is
/// nearest to it ([`outside`]; the first on ties): a point on a shared edge lost to rounding
/// goes to either neighbour, whose maps agree there. None when no cell has a finite solution.
pub fn locate_in_vertices(v: &VertexGrid, p: [f64; 2]) -> Option<(usize, usize, f64, f64)> {
    let mut best: Option<(f64, usize, usize, [f64; 2])> = None;
    for i in 0..v.m - 1 {
        for j in 0..v.n - 1 {
            let q = quad(v, i, j);
            if !in_bbox(&q, p) {
                continue;
            }
            let Some(ab) = inverse_bilinear(&q, p) else {
                continue;
            };
            let miss = outside(ab);
            if miss <= 0.0 {
                return Some((i, j, ab[0], ab[1]));
            }
            if best.is_none_or(|b| miss < b.0) {
                best = Some((miss, i, j, ab));
            }
        }
    }
    best.map(|(_, i, j, ab)| (i, j, ab[0].clamp(0.0, 1.0), ab[1].clamp(0.0, 1.0)))
}

/// The texture lookup of a whole UV atlas with several solved ROIs: a UV inside ROI k's
/// rectangle is looked up through ROI k's [`Remap`] (in its ROI coordinates), any other UV is
/// unchanged. The ROIs must not overlap ([`check_disjoint`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AtlasRemap {
    pub rois: Vec<(Roi, Remap)>,
}

impl AtlasRemap {
    /// The lookups of `rois`; errors if two rectangles overlap ([`check_disjoint`]).
    pub fn new(rois: Vec<(Roi, Remap)>) -> Result<AtlasRemap> {
        check_disjoint(&rois.iter().map(|(r, _)| *r).collect::<Vec<_>>())?;
        Ok(AtlasRemap { rois })
    }

    /// uv ↦ roi.uv(lookup(roi.st(uv))) for the ROI containing uv (closed rectangle), else uv.
    pub fn lookup_uv(&self, uv: [f64; 2]) -> [f64; 2] {
        for (roi, remap) in &self.rois {
            if roi.contains(uv) {
                let (s, t) = roi.st(nalgebra::Point2::new(uv[0], uv[1]));
                let [s2, t2] = remap.lookup([s, t]);
                let p = roi.uv(s2, t2);
                return [p.x, p.y];
            }
        }
        uv
    }
}

/// Errors ([`Error::InvalidArgument`], naming both ROIs) if two ROIs overlap in an area
/// (sharing an edge is allowed: the lookups agree there only with boundary blending).
pub fn check_disjoint(rois: &[Roi]) -> Result<()> {
    for (a, ra) in rois.iter().enumerate() {
        for (b, rb) in rois.iter().enumerate().skip(a + 1) {
            let overlap_u = ra.u1.min(rb.u1) - ra.u0.max(rb.u0);
            let overlap_v = ra.v1.min(rb.v1) - ra.v0.max(rb.v0);
            if overlap_u > 0.0 && overlap_v > 0.0 {
                return Err(Error::InvalidArgument(format!(
                    "ROI {a} (u [{}, {}] x v [{}, {}]) and ROI {b} (u [{}, {}] x v [{}, {}]) \
                     overlap; each texel may belong to one ROI only",
                    ra.u0, ra.u1, ra.v0, ra.v1, rb.u0, rb.u1, rb.v0, rb.v1
                )));
            }
        }
    }
    Ok(())
}
