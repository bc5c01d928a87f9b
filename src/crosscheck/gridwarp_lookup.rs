//! The bound of `gridwarp_lookup`'s looked-up UVs, per query, derived from the kernel's f32
//! twin ([`crate::twin::gridwarp_lookup`]) over `Lin`, and the cross-check rows that use it.
//!
//! Both sides look up the same f32 query uv through the same atlas rounded to f32
//! ([`crate::gridwarp::gpu_lookup::round_atlas`]); the f64 reference's result is `expected`.
//! The kernel's result differs by its arithmetic and by its choices:
//!
//! - **arithmetic**: along one path (a ROI, a cell, a root), every operation may err as the
//!   WGSL table allows; `first_order_bound2` sums ‖∂uv/∂eᵢ‖ aᵢ over them, and the bound takes
//!   `SECOND_ORDER` = 2 times that ([`crate::twin::lin`]: why 2 covers the neglected terms).
//!   The closed form's rounding is squared away by the Newton step, whose derivative there is
//!   0, so first order does not see it: for a bilinear W one step from an error δ leaves
//!   exactly J(x₀)⁻¹ g δα δβ, which is added as 2‖J⁻¹‖∞‖g‖∞ (2b_α₀)(2b_β₀) (b the first-order
//!   bounds of α and β before the step, 2 for J(x₀) against J at the solution, required to be
//!   within a factor ½: ‖J⁻¹‖‖g‖‖δ‖ ≤ ½), carried to UV by the lookup's Lipschitz constant
//!   (max(h_i, k_j) + 2) · max(u1 − u0, v1 − v0). Near a double root the discriminant's
//!   square root is Hölder (`Lin`'s √: a fresh value with allowance √(2·bound)), so b grows
//!   as √u there: the bound follows the cell's conditioning.
//! - **choices**: which ROI is exact (f32 comparisons of the f32 inputs). Which cell: AA, every
//!   cell of the lines within 2·(first-order bound) of p on each axis; NAA, every cell (and
//!   root) whose miss (how far its (α, β) lies outside [0, 1]²) is within its own bound of the
//!   smallest miss plus that one's bound (the kernel accepts the first in [0, 1]², else the
//!   nearest). Which root: the other one too where the two roots' distances to [0, 1] are
//!   within their bounds of each other. Every such path is followed over `Lin`:
//!
//!   bound = max over the reachable paths A of |uv_A − expected| + 2·b_A + n_A,
//!
//!   (b_A the path's first-order bound, n_A its Newton term). Neighbouring cells' maps agree on
//!   their shared edge and blending is continuous across it, so near an edge the paths differ
//!   by about their bounds. Where they differ by more than `DISAGREE` = 16 times the sum of
//!   their bounds (the cells disagree there), where a path's first-order analysis is not
//!   trusted (a divisor within 16× its bound of 0: det J at a near-double root, a degenerate
//!   cell; [`crate::twin::lin`]), or where ‖J⁻¹‖‖g‖‖δ‖ > ½, f32 cannot decide: the element is
//!   UNDECIDED, its bound `UNBOUNDED`, and it is counted (rows' notes, `verify`'s
//!   `undecided`), never a silent pass.
//!
//! A far root is followed only where |q| ≤ 4|a| ([`crate::gridwarp::remap::FAR_ROOT`]); a
//! root beyond is more than 3 from [0, 1], and a path through it has a miss of 3 or more, never
//! within reach of the containing cell's. A query in no ROI is returned unchanged; its bound
//! is one ULP of uv (u‖uv‖, so that no bound is exactly 0).
//!
//! Large UV coordinates (a ROI far from the origin, e.g. a UDIM tile) cost the kernel u·|uv| in
//! the final u0 + s (u1 − u0) alone, whatever its care: the bound counts it, because the twin
//! computes in UV as the kernel does. A kernel that looks up in UV instead of re-centring on
//! the ROI first pays u·|uv| at every line, times the cell's compression.

use rayon::prelude::*;

use super::bpm_bound::UNBOUNDED;
use super::{F32_FLUSH, WGSL_U};
use crate::twin::gridwarp_lookup::{clamp01, lookup_in_cell, outside, st, Tables, AA};
use crate::twin::lin::{first_order_bound, first_order_bound2, record, SECOND_ORDER, TRUST};
use crate::twin::{Lin, Real, V2};

/// UV errors are reported in texels of a texture this wide (4096², as BPM's).
pub const TEXELS: f64 = 4096.0;

/// Two paths whose UVs differ by more than this many times the sum of their bounds disagree:
/// f32 cannot decide between them ([`TRUST`], the factor first order is trusted by).
pub const DISAGREE: f64 = TRUST;

/// A query's bound (UV units) and whether f32 can decide its lookup.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QueryBound {
    /// `UNBOUNDED` when undecided.
    pub bound: f64,
    pub undecided: bool,
}

impl QueryBound {
    fn undecided() -> QueryBound {
        QueryBound {
            bound: UNBOUNDED,
            undecided: true,
        }
    }
}

/// One followed path: its UV (exact arithmetic on the f32 inputs), first-order bound, Newton
/// term, and for the NAA choices its miss and the root with their bounds.
#[derive(Clone, Copy, Debug)]
struct Path {
    out: [f64; 2],
    bound: f64,
    newton: f64,
    miss: f64,
    miss_bound: f64,
    root: f64,
    root_bound: f64,
    ambiguous: bool,
}

/// The query as exact inputs on the current tape.
fn query_lin(uv: [f32; 2]) -> V2<Lin> {
    V2::new(Lin::lit(f64::from(uv[0])), Lin::lit(f64::from(uv[1])))
}

/// ROI k's rectangle [u0, u1, v0, v1] (f64 of the f32 inputs).
fn rect(t: &Tables, k: usize) -> [f64; 4] {
    std::array::from_fn(|c| f64::from(t.rois[4 * k + c]))
}

/// Cell (i, j)'s corners [P00, P10, P01, P11] of ROI k's vertex grid (f64 of the f32 inputs).
fn corners(t: &Tables, k: usize, i: usize, j: usize) -> [[f64; 2]; 4] {
    let g = t.grid(k);
    let at = |a: usize, b: usize| {
        let o = g.warped + 2 * (a * g.n + b);
        [f64::from(t.warped[o]), f64::from(t.warped[o + 1])]
    };
    [at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]
}

/// The path through ROI k's cell (i, j) with `root`, over `Lin`; None where it does not
/// exist.
fn follow(t: &Tables, k: usize, cell: (usize, usize), root: usize, uv: [f32; 2]) -> Option<Path> {
    let (path, ambiguous) = record(|| {
        let path = lookup_in_cell(t, k, cell, root, query_lin(uv))?;
        let start = match (path.alpha0, path.root) {
            (Some(a), Some(b)) => first_order_bound(a).max(first_order_bound(b)),
            _ => 0.0,
        };
        let ab_bound = first_order_bound(path.ab.x).max(first_order_bound(path.ab.y));
        Some((
            path,
            first_order_bound2(path.out.x, path.out.y),
            start,
            ab_bound,
            path.root.map_or(0.0, first_order_bound),
        ))
    });
    let (path, bound, start, ab_bound, root_bound) = path?;
    let newton = newton_term(t, k, cell, path.ab.values(), SECOND_ORDER * start);
    let (newton_ab, newton_uv) = newton.unwrap_or((0.0, 0.0));
    Some(Path {
        out: path.out.values(),
        bound,
        newton: newton_uv,
        miss: outside(path.ab).value(),
        miss_bound: SECOND_ORDER * ab_bound + newton_ab,
        root: path.root.map_or(0.0, |r| r.value()),
        root_bound,
        ambiguous: ambiguous || newton.is_none(),
    })
}

/// The Newton step's second-order term at (α, β) of an NAA cell, for a start within `delta`
/// (max norm) of the solution: (in (α, β), in UV); None where ‖J⁻¹‖‖g‖δ > ½ (module docs).
/// (0, 0) for an AA cell.
fn newton_term(
    t: &Tables,
    k: usize,
    (i, j): (usize, usize),
    ab: [f64; 2],
    delta: f64,
) -> Option<(f64, f64)> {
    let g = t.grid(k);
    if g.variant == AA {
        return Some((0.0, 0.0));
    }
    let q = corners(t, k, i, j);
    let sub = |a: [f64; 2], b: [f64; 2]| [a[0] - b[0], a[1] - b[1]];
    let e = sub(q[1], q[0]);
    let f = sub(q[2], q[0]);
    let gg = [q[3][0] - q[1][0] - f[0], q[3][1] - q[1][1] - f[1]];
    let ja = [e[0] + ab[1] * gg[0], e[1] + ab[1] * gg[1]];
    let jb = [f[0] + ab[0] * gg[0], f[1] + ab[0] * gg[1]];
    let det = ja[0] * jb[1] - ja[1] * jb[0];
    let inverse = (jb[0].abs() + jb[1].abs()).max(ja[0].abs() + ja[1].abs()) / det.abs();
    let twist = gg[0].abs().max(gg[1].abs());
    if !(inverse * twist * delta <= 0.5) {
        return None;
    }
    let in_ab = 2.0 * inverse * twist * delta * delta;
    let rest = |o: usize| f64::from(t.rest_lines[o]);
    let h = rest(g.rest + i + 1) - rest(g.rest + i);
    let kk = rest(g.rest + g.m + j + 1) - rest(g.rest + g.m + j);
    let r = rect(t, k);
    let size = (r[1] - r[0]).max(r[3] - r[2]);
    Some((in_ab, 2.0 * (h.max(kk) + 2.0) * size * in_ab))
}

/// The cells (and roots) an f32 evaluation of ROI k's lookup of `uv` may take (module docs).
fn reachable(t: &Tables, k: usize, uv: [f32; 2]) -> Option<Vec<Path>> {
    let g = t.grid(k);
    if g.variant == AA {
        let ((p, bp), _) = record(|| {
            let p = clamp01(st(&t.roi::<Lin>(k), query_lin(uv)));
            (p.values(), [first_order_bound(p.x), first_order_bound(p.y)])
        });
        let lines = |o: usize, n: usize| -> Vec<f64> {
            t.warped[o..o + n].iter().map(|&x| f64::from(x)).collect()
        };
        let (s, tt) = (lines(g.warped, g.m), lines(g.warped + g.m, g.n));
        let range = |lines: &[f64], x: f64, b: f64| {
            let c = crate::gridwarp::remap::cell_of;
            c(lines, x - SECOND_ORDER * b)..=c(lines, x + SECOND_ORDER * b)
        };
        let mut paths = Vec::new();
        for i in range(&s, p[0], bp[0]) {
            for j in range(&tt, p[1], bp[1]) {
                paths.extend(follow(t, k, (i, j), 0, uv));
            }
        }
        return Some(paths);
    }
    // NAA: every cell whose box (twice the kernel's slack) holds p, each with the root the
    // exact values choose and the other where the choice is within the roots' bounds.
    let r = rect(t, k);
    let p = [
        ((f64::from(uv[0]) - r[0]) / (r[1] - r[0])).clamp(0.0, 1.0),
        ((f64::from(uv[1]) - r[2]) / (r[3] - r[2])).clamp(0.0, 1.0),
    ];
    let mut candidates: Vec<Vec<Path>> = Vec::new();
    for i in 0..g.m - 1 {
        for j in 0..g.n - 1 {
            if !in_wide_bbox(&corners(t, k, i, j), p) {
                continue;
            }
            let roots: Vec<Path> = (0..2).filter_map(|r| follow(t, k, (i, j), r, uv)).collect();
            let distance = |x: f64| (x - x.clamp(0.0, 1.0)).abs();
            let chosen = match roots.as_slice() {
                [near, far] if distance(far.root) < distance(near.root) => 1,
                _ => 0,
            };
            let Some(taken) = roots.get(chosen).copied() else {
                continue;
            };
            let mut cell = vec![taken];
            if let [near, far] = roots.as_slice() {
                let close = (distance(near.root) - distance(far.root)).abs()
                    <= SECOND_ORDER * (near.root_bound + far.root_bound);
                if close {
                    cell.push(roots[1 - chosen]);
                }
            }
            candidates.push(cell);
        }
    }
    let reach = candidates
        .iter()
        .map(|c| c[0].miss + c[0].miss_bound)
        .fold(f64::INFINITY, f64::min);
    if !reach.is_finite() {
        return None;
    }
    Some(
        candidates
            .into_iter()
            .flatten()
            .filter(|p| p.miss - p.miss_bound <= reach)
            .collect(),
    )
}

/// [`crate::gridwarp::remap::in_bbox`] with twice its slack: every cell the kernel's f32 box
/// test may admit (p's error is far below the slack).
fn in_wide_bbox(q: &[[f64; 2]; 4], p: [f64; 2]) -> bool {
    let (mut lo, mut hi) = (q[0], q[0]);
    for c in &q[1..] {
        lo = [lo[0].min(c[0]), lo[1].min(c[1])];
        hi = [hi[0].max(c[0]), hi[1].max(c[1])];
    }
    let slack = 2.0 * crate::gridwarp::remap::BBOX_SLACK * ((hi[0] - lo[0]) + (hi[1] - lo[1]));
    p[0] >= lo[0] - slack && p[0] <= hi[0] + slack && p[1] >= lo[1] - slack && p[1] <= hi[1] + slack
}

/// The bound of the kernel's lookup of `uv` through the atlas `t` (module docs), in UV units;
/// `expected` is the f64 reference's lookup of uv through the same (rounded) atlas.
pub fn query_bound(t: &Tables, uv: [f32; 2], expected: [f64; 2]) -> QueryBound {
    let q = [f64::from(uv[0]), f64::from(uv[1])];
    let inside = |r: [f64; 4]| q[0] >= r[0] && q[0] <= r[1] && q[1] >= r[2] && q[1] <= r[3];
    let Some(k) = (0..t.roi_count()).find(|&k| inside(rect(t, k))) else {
        return QueryBound {
            bound: WGSL_U * q[0].hypot(q[1]) + F32_FLUSH,
            undecided: false,
        };
    };
    let Some(paths) = reachable(t, k, uv) else {
        return QueryBound::undecided();
    };
    if paths.is_empty() || paths.iter().any(|p| p.ambiguous) {
        return QueryBound::undecided();
    }
    let gap = |p: &Path| (p.out[0] - expected[0]).hypot(p.out[1] - expected[1]);
    let closest = paths
        .iter()
        .min_by(|a, b| gap(a).total_cmp(&gap(b)))
        .map_or(0.0, |p| SECOND_ORDER * p.bound + p.newton);
    let mut bound: f64 = 0.0;
    for p in &paths {
        let own = SECOND_ORDER * p.bound + p.newton;
        if gap(p) > DISAGREE * (own + closest) {
            return QueryBound::undecided();
        }
        bound = bound.max(gap(p) + own);
    }
    QueryBound {
        bound: bound.max(F32_FLUSH),
        undecided: false,
    }
}

/// [`query_bound`] of every query (in parallel; each query's bound is its own, so the result
/// does not depend on the thread count).
pub fn lookup_bounds(t: &Tables, queries: &[[f32; 2]], expected: &[[f64; 2]]) -> Vec<QueryBound> {
    queries
        .par_iter()
        .zip(expected)
        .map(|(&q, &e)| query_bound(t, q, e))
        .collect()
}

/// The queries of a row: the centres of an n × n pixel grid over each ROI, and a pixel's
/// width beyond each side (outside the ROI, returned unchanged), rounded to f32.
pub fn roi_queries(atlas: &crate::gridwarp::AtlasRemap, n: usize) -> Vec<[f32; 2]> {
    let mut queries = Vec::new();
    for (roi, _) in &atlas.rois {
        let (w, h) = roi.size();
        for y in 0..n + 2 {
            for x in 0..n + 2 {
                let s = (x as f64 - 0.5) / n as f64;
                let t = (y as f64 - 0.5) / n as f64;
                queries.push([(roi.u0 + s * w) as f32, (roi.v0 + t * h) as f32]);
            }
        }
    }
    queries
}

/// What a comparison of the kernel with the reference found: per query its error and bound in
/// texels of a 4096² texture ([`TEXELS`]), and how many were undecided.
#[derive(Clone, Debug)]
pub struct LookupComparison {
    pub errors: Vec<f64>,
    pub bounds: Vec<f64>,
    pub undecided: usize,
}

/// The f64 reference's lookups of the f32 `queries` through the atlas (already rounded to f32:
/// [`crate::gridwarp::gpu_lookup::round_atlas`]).
pub fn reference_lookups(
    atlas: &crate::gridwarp::AtlasRemap,
    queries: &[[f32; 2]],
) -> Vec<[f64; 2]> {
    queries
        .par_iter()
        .map(|q| atlas.lookup_uv([f64::from(q[0]), f64::from(q[1])]))
        .collect()
}

/// Judge `got` (a candidate's looked-up UVs of `queries`) against `expected` (the reference's,
/// through `rounded`, the atlas rounded to f32) with the per-query bounds.
pub fn compare_lookups(
    rounded: &crate::gridwarp::AtlasRemap,
    queries: &[[f32; 2]],
    expected: &[[f64; 2]],
    got: &[[f32; 2]],
) -> crate::Result<LookupComparison> {
    use crate::gridwarp::gpu_lookup::{lookup_tables, FlatTables};
    let flat = FlatTables::of(&lookup_tables(rounded)?);
    let bounds = lookup_bounds(&flat.tables(), queries, expected);
    let errors = expected
        .iter()
        .zip(got)
        .map(|(e, g)| TEXELS * (f64::from(g[0]) - e[0]).hypot(f64::from(g[1]) - e[1]))
        .collect();
    Ok(LookupComparison {
        errors,
        undecided: bounds.iter().filter(|b| b.undecided).count(),
        bounds: bounds
            .iter()
            .map(|b| {
                if b.undecided {
                    UNBOUNDED
                } else {
                    TEXELS * b.bound
                }
            })
            .collect(),
    })
}

/// The bound's formula, as the rows and the manifest print it.
pub const BOUND_FORMULA: &str = "per query: max over the paths an f32 evaluation may take (the \
    cells within rounding of p, both roots where their distances to [0, 1] are within rounding) \
    of |uv_A − expected| + 2 b_A + n_A, b_A every operation's WGSL allowance to first order \
    along A (the twin over Lin), n_A the Newton step's second-order term 2‖J⁻¹‖‖g‖(2b_α)(2b_β) \
    carried to UV; undecided (unbounded, counted) where paths disagree by > 16× their bounds or \
    first order is not trusted";

/// The `gridwarp_lookup` row on `atlas` (solved grids, f64): the kernel's lookups of an n × n
/// pixel grid over each ROI ([`roi_queries`]) against the f64 reference's through the same
/// atlas rounded to f32, each held to its own bound; undecided queries counted in the note.
pub fn lookup_row(
    gpu: &reparam_gpu::Gpu,
    input: &str,
    what: &str,
    atlas: &crate::gridwarp::AtlasRemap,
    n: usize,
) -> crate::Result<super::Row> {
    use super::timing::{time_cpu, time_gpu_warm};
    use crate::gridwarp::gpu_lookup::{lookup_tables, round_atlas};
    use reparam_gpu::gridwarp::LookupKernel;
    let rounded = round_atlas(atlas)?;
    let queries = roi_queries(&rounded, n);
    let (expected, cpu_ms) = time_cpu(|| reference_lookups(&rounded, &queries));
    let kernel = LookupKernel::new(gpu, &lookup_tables(&rounded)?)
        .map_err(|e| crate::Error::Gpu(e.to_string()))?;
    let (got, timing) = time_gpu_warm(gpu, || {
        kernel
            .run(gpu, &queries)
            .map_err(|e| crate::Error::Gpu(e.to_string()))
    })?;
    let c = compare_lookups(&rounded, &queries, &expected, &got)?;
    let magnitudes: Vec<f64> = expected.iter().map(|e| TEXELS * e[0].hypot(e[1])).collect();
    let row = super::Row::compare(
        "gridwarp",
        &format!("gridwarp_lookup: looked-up UV ({what})"),
        input,
        "texels of a 4096² texture",
        &c.errors,
        &magnitudes,
        super::Bounds::PerElement(c.bounds),
        BOUND_FORMULA,
    );
    Ok(row
        .with_note(&format!(
            "{} queries over {} ROI(s) ({n}² pixels each and a pixel beyond each side); {} \
             undecided (f32 cannot decide: not judged)",
            queries.len(),
            atlas.rois.len(),
            c.undecided
        ))
        .with_timing(super::Timing {
            cpu_ms: Some(cpu_ms),
            ..timing
        }))
}
