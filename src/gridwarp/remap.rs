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

/// Index of the cell of the increasing `lines` containing x (the last cell for x ≥ its start,
/// the first for x below).
pub fn cell_of(lines: &[f64], x: f64) -> usize {
    lines.partition_point(|&v| v <= x).clamp(1, lines.len() - 1) - 1
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

/// Solve W(α, β) = p for the bilinear quad `q` = [P00, P10, P01, P11] (closed form).
///
/// With e = P10 − P00, f = P01 − P00, g = P11 − P10 − P01 + P00 and d = p − P00,
/// d = α (e + β g) + β f. Crossing with e + β g eliminates α:
///
///   (f × g) β² + (f × e − d × g) β − d × e = 0,
///
/// a quadratic (linear when f × g = 0, e.g. for a parallelogram, where β = (d × e)/(f × e)).
/// The root in [0, 1] (the one nearest to it, for points outside) is taken, computed with the
/// cancellation-free pair β = 2c/(−b ∓ √Δ), (−b ∓ √Δ)/(2a); then
/// α = (d − β f)·(e + β g)/‖e + β g‖² (the least-squares solution of the 2-vector equation,
/// exact when p is in the quad). One Newton step on W(α, β) = p polishes the result to rounding.
/// On a valid (convex, positive corner determinants) quad the solution in [0, 1]² is unique.
/// Returns None for a degenerate quad (no finite solution).
pub fn inverse_bilinear(q: &[[f64; 2]; 4], p: [f64; 2]) -> Option<[f64; 2]> {
    let sub = |a: [f64; 2], b: [f64; 2]| [a[0] - b[0], a[1] - b[1]];
    let e = sub(q[1], q[0]);
    let f = sub(q[2], q[0]);
    let g = sub(sub(q[3], q[1]), f);
    let d = sub(p, q[0]);
    let (a, b, c) = (cross(f, g), cross(f, e) - cross(d, g), -cross(d, e));
    let scale = cross(e, f).abs().max(f64::MIN_POSITIVE);
    let beta = if a.abs() <= 1e-12 * scale {
        -c / b
    } else {
        let disc = (b * b - 4.0 * a * c).max(0.0).sqrt();
        let big = -b - b.signum() * disc;
        let roots = [big / (2.0 * a), 2.0 * c / big];
        let distance = |x: f64| {
            if x.is_finite() {
                (x - x.clamp(0.0, 1.0)).abs()
            } else {
                f64::INFINITY
            }
        };
        if distance(roots[0]) <= distance(roots[1]) {
            roots[0]
        } else {
            roots[1]
        }
    };
    let axis = [e[0] + beta * g[0], e[1] + beta * g[1]];
    let rhs = [d[0] - beta * f[0], d[1] - beta * f[1]];
    let n2 = axis[0] * axis[0] + axis[1] * axis[1];
    let alpha = (rhs[0] * axis[0] + rhs[1] * axis[1]) / n2;
    if !alpha.is_finite() || !beta.is_finite() {
        return None;
    }
    // Newton polish: J = [∂W/∂α ∂W/∂β] = [e + β g, f + α g].
    let w = bilinear(q, alpha, beta);
    let r = sub(p, w);
    let (ja, jb) = (axis, [f[0] + alpha * g[0], f[1] + alpha * g[1]]);
    let det = cross(ja, jb);
    if det.abs() > 0.0 && det.is_finite() {
        let da = cross(r, jb) / det;
        let db = cross(ja, r) / det;
        if da.is_finite() && db.is_finite() {
            return Some([alpha + da, beta + db]);
        }
    }
    Some([alpha, beta])
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
    /// rest point. AA: the cells of the lines. NAA: the first quad (column-major) whose edge
    /// functions accept p within a relative 1e-12 of its size, else the quad whose (α, β)
    /// is nearest to [0, 1]² (only for points on shared edges lost to rounding); None only for a
    /// degenerate vertex grid.
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
fn outside(ab: [f64; 2]) -> f64 {
    ab.iter()
        .map(|&x| (x - x.clamp(0.0, 1.0)).abs())
        .fold(0.0, f64::max)
}

/// The cell of a vertex grid containing `p` and (α, β) there (see [`Remap::locate`]).
fn locate_in_vertices(v: &VertexGrid, p: [f64; 2]) -> Option<(usize, usize, f64, f64)> {
    let mut best: Option<(f64, usize, usize, [f64; 2])> = None;
    for i in 0..v.m - 1 {
        for j in 0..v.n - 1 {
            let q = quad(v, i, j);
            let (lo, hi) = q.iter().fold(
                ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                |(lo, hi), c| {
                    (
                        [lo[0].min(c[0]), lo[1].min(c[1])],
                        [hi[0].max(c[0]), hi[1].max(c[1])],
                    )
                },
            );
            let slack = 1e-12 * (hi[0] - lo[0] + hi[1] - lo[1]);
            if p[0] < lo[0] - slack
                || p[0] > hi[0] + slack
                || p[1] < lo[1] - slack
                || p[1] > hi[1] + slack
            {
                continue;
            }
            let Some(ab) = inverse_bilinear(&q, p) else {
                continue;
            };
            let miss = outside(ab);
            if miss <= 1e-12 {
                return Some((i, j, ab[0].clamp(0.0, 1.0), ab[1].clamp(0.0, 1.0)));
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
