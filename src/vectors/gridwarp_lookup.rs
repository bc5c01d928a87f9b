//! `gridwarp_lookup` vectors: the warped texture lookup of a UV atlas with several ROIs (seed
//! 000 §6, §8, §10.2), its inputs exactly as the kernel's bindings 1–5 receive them, the f64
//! expected UVs ([`crate::gridwarp::AtlasRemap::lookup_uv`] through the atlas rounded to f32)
//! and the per-query bounds of [`crate::crosscheck::gridwarp_lookup`].
//!
//! The canonical atlas ([`canonical_atlas`]) has five ROIs chosen so that every branch is
//! taken: AA and NAA grids, blending on and off, a sliding border, both roots of the inverse
//! bilinear quadratic, a near-parallelogram cell, near-degenerate (25× compressed) cells, two
//! ROIs far from the UV origin (a UDIM-like tile at u ≈ 100) that share an edge; the queries
//! ([`canonical_queries`]) a pixel grid over each ROI and a pixel beyond, every warped vertex
//! (cell corners), the midpoint of every warped cell edge and every cell's centre.

use super::{Array, KernelData, Metric, VectorsAndCandidates};
use crate::crosscheck::gridwarp_lookup::{
    lookup_bounds, reference_lookups, roi_queries, BOUND_FORMULA, TEXELS,
};
use crate::error::{Error, Result};
use crate::gridwarp::energy_naa::VertexGrid;
use crate::gridwarp::gpu_lookup::{gpu_lookup_uv, lookup_tables, round_atlas, FlatTables};
use crate::gridwarp::rasterize::Roi;
use crate::gridwarp::remap::{choose_root, quad, quadratic, roots, Warped};
use crate::gridwarp::{AtlasRemap, Grid, Remap};

/// The kernel for the manifest, every symbol defined (issue #49).
pub const LOOKUP_FORMULA: &str = "the warped texture lookup of a UV atlas (seed 000 §6, §8, \
    §10.2), one output per query uv = (u, v). ROI k has the rectangle rois[k] = (u0, u1, v0, v1) \
    and the grid roi_grids[k] = (variant, blend, M, N, R, W): variant 0 = AA (warped lines), \
    1 = NAA (warped vertices); blend 1 = border blending on; M lines along s, N along t; rest \
    lines ŝ_a = rest_lines[R + a] (a < M), t̂_b = rest_lines[R + M + b] (b < N); AA warped lines \
    s_a = warped[W + a], t_b = warped[W + M + b]; NAA vertices P_ab = (warped[W + 2(a·N + b)], \
    warped[W + 2(a·N + b) + 1]), a < M, b < N. Take the first k (in order) with u0 ≤ u ≤ u1 and \
    v0 ≤ v ≤ v1; none: the output is uv. Else p = ((u − u0)/(u1 − u0), (v − v0)/(v1 − v0)), \
    P = p with each coordinate clamped to [0, 1]. Cell (i, j), position (α, β): AA: \
    i = cell(s, P_s), j = cell(t, P_t), cell(x, X) = the largest c in 1 … len − 2 with x_c ≤ X, \
    else 0; α = (P_s − s_i)/(s_{i+1} − s_i), β = (P_t − t_j)/(t_{j+1} − t_j). NAA: for i = 0 … \
    M − 2 (outer), j = 0 … N − 2 (inner), quad Q = (P00, P10, P01, P11) = (P_{i,j}, P_{i+1,j}, \
    P_{i,j+1}, P_{i+1,j+1}); skip it unless P lies in the corners' bounding box [lo, hi] widened \
    by σ = 2⁻¹²·((hi_s − lo_s) + (hi_t − lo_t)) on every side; solve W(α, β) = P, W(α, β) = \
    (1−α)(1−β) P00 + α(1−β) P10 + (1−α)β P01 + αβ P11: e = P10 − P00, f = P01 − P00, \
    g = P11 − P10 − f, d = P − P00, x × y = x_s y_t − x_t y_s, A = f × g, B = f × e − d × g, \
    C = −(d × e), q = −½(B + sgn(B)√max(B² − 4AC, 0)) (sgn(B) = −1 when B's sign bit is set, \
    else +1), near root C/q, far root q/A only where |q| ≤ 4|A|; distance(x) = |x − clamp(x, 0, \
    1)| (+∞ if x is not finite); β = the far root if it exists and its distance is strictly \
    smaller, else the near root; α = ((d − βf)·(e + βg)) / ‖e + βg‖²; skip the cell if α or β \
    is not finite; one Newton step: r = P − W(α, β), J = [e + βg, f + αg] (columns), \
    det = (e + βg) × (f + αg); where det ≠ 0 and finite, Δα = (r × (f + αg))/det, Δβ = \
    ((e + βg) × r)/det, and if both are finite (α, β) += (Δα, Δβ); miss = max(|α − clamp(α, 0, \
    1)|, |β − clamp(β, 0, 1)|); the first cell with miss = 0 is taken, else the one with the \
    smallest miss (the first on ties), with α, β clamped to [0, 1]; no cell at all: the ROI's \
    output is uv(p) below with p in place of the rest point. Rest point ρ = (ŝ_i + α(ŝ_{i+1} − \
    ŝ_i), t̂_j + β(t̂_{j+1} − t̂_j)). Blending (blend = 1): w_s = max of (1 − α if i = 0) and \
    (α if i = M − 2), else 0, clamped to [0, 1]; w_t likewise with j, β, N − 2; \
    w = 1 − (1 − w_s)(1 − w_t); blend = 0: w = 0. Looked-up ROI point ρ' = ρ if w = 0, else \
    (1 − w) ρ + w P. Output uv' = (u0 + ρ'_s (u1 − u0), v0 + ρ'_t (v1 − v0))";

/// The canonical atlas (module docs): five ROIs, two of them at u ≈ 100.
pub fn canonical_atlas() -> Result<AtlasRemap> {
    let grid = |s: &[f64], t: &[f64]| Grid::new(s.to_vec(), t.to_vec());
    let vertices = |rest: &Grid, moved: &[((usize, usize), [f64; 2])], sliding: bool| {
        let mut v = VertexGrid::from_grid(rest).with_sliding_border(sliding);
        for &((a, b), p) in moved {
            v.points[a * v.n + b] = p;
        }
        v
    };
    let roi = |u0, u1, v0, v1| Roi { u0, u1, v0, v1 };
    // ROI 0: AA, blending on.
    let rest0 = grid(&[0.0, 0.25, 0.6, 1.0], &[0.0, 0.3, 0.7, 1.0])?;
    let warped0 = grid(&[0.0, 0.32, 0.5, 1.0], &[0.0, 0.2, 0.75, 1.0])?;
    // ROI 1: NAA, fixed border, blending off; cell (1, 1) a near-parallelogram (its four
    // corners moved alike but for 1e-6), the others twisted one way or the other; its border
    // vertex (3, 1) moved in to s = 0.9, so that points near (1, 0.35) lie in no warped cell
    // (the nearest cell's (α, β) is clamped: the `no_clamp` mutant).
    let rest1 = grid(&[0.0, 0.3, 0.65, 1.0], &[0.0, 0.35, 0.7, 1.0])?;
    let v1 = vertices(
        &rest1,
        &[
            ((1, 1), [0.36, 0.38]),
            ((2, 1), [0.71, 0.38]),
            ((1, 2), [0.36, 0.73]),
            ((2, 2), [0.710001, 0.729999]),
            ((3, 1), [0.9, 0.35]),
        ],
        false,
    );
    // ROI 2: NAA, sliding border, blending on; column 1 squeezed to 0.01 (rest 0.25).
    let rest2 = grid(&[0.0, 0.2, 0.45, 0.7, 1.0], &[0.0, 0.3, 0.65, 1.0])?;
    let v2 = vertices(
        &rest2,
        &[
            ((1, 0), [0.3, 0.0]),
            ((2, 0), [0.31, 0.0]),
            ((1, 1), [0.3, 0.33]),
            ((2, 1), [0.31, 0.27]),
            ((3, 1), [0.72, 0.31]),
            ((1, 2), [0.29, 0.62]),
            ((2, 2), [0.3, 0.69]),
            ((3, 2), [0.68, 0.66]),
            ((0, 2), [0.0, 0.6]),
            ((1, 3), [0.3, 1.0]),
            ((2, 3), [0.31, 1.0]),
        ],
        true,
    );
    // ROI 3: AA at u ≈ 100, blending off, its cell 1 compressed 25× (0.01 for 0.25).
    let rest3 = grid(&[0.0, 0.25, 0.5, 0.75, 1.0], &[0.0, 0.5, 1.0])?;
    let warped3 = grid(&[0.0, 0.3, 0.31, 0.75, 1.0], &[0.0, 0.4, 1.0])?;
    // ROI 4: NAA at u ≈ 100 beside ROI 3 (sharing u = 100.5), blending on; column 1 twisted
    // in row 0 (where the far root is taken) and thin in row 1 (0.0035–0.004 wide for a rest
    // width of 0.35: about 90× compressed), so that a kernel solving in UV (u ≈ 100, ULP
    // 2⁻¹⁷) instead of in re-centred ROI coordinates loses more than the bound allows (the
    // `not_recentred` mutant).
    let rest4 = grid(&[0.0, 0.35, 0.7, 1.0], &[0.0, 0.5, 1.0])?;
    let v4 = vertices(
        &rest4,
        &[
            ((1, 1), [0.36, 0.52]),
            ((2, 1), [0.3635, 0.47]),
            ((1, 2), [0.36, 1.0]),
            ((2, 2), [0.364, 1.0]),
        ],
        false,
    );
    let remap = |rest: &Grid, warped: Warped, blend: bool| {
        Remap::new(rest.clone(), warped).with_boundary_blend(blend)
    };
    AtlasRemap::new(vec![
        (
            roi(0.05, 0.45, 0.1, 0.45),
            remap(&rest0, Warped::Lines(warped0), true),
        ),
        (
            roi(0.5, 0.95, 0.05, 0.4),
            remap(&rest1, Warped::Vertices(v1), false),
        ),
        (
            roi(0.05, 0.45, 0.55, 0.95),
            remap(&rest2, Warped::Vertices(v2), true),
        ),
        (
            roi(100.25, 100.5, 36.5, 36.625),
            remap(&rest3, Warped::Lines(warped3), false),
        ),
        (
            roi(100.5, 100.75, 36.5, 36.75),
            remap(&rest4, Warped::Vertices(v4), true),
        ),
    ])
}

/// The warped grid's vertices of ROI k, the midpoints of its cell edges and its cells' centres
/// (the mean of the four corners), in ROI coordinates
/// (AA: the lines' crossings and the midpoints between them).
fn grid_points(remap: &Remap) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
    let (m, n) = (remap.rest.s.len(), remap.rest.t.len());
    let at = |a: usize, b: usize| match &remap.warped {
        Warped::Lines(g) => [g.s[a], g.t[b]],
        Warped::Vertices(v) => v.at(a, b),
    };
    let mid = |x: [f64; 2], y: [f64; 2]| [(x[0] + y[0]) / 2.0, (x[1] + y[1]) / 2.0];
    let (mut corners, mut edges) = (Vec::new(), Vec::new());
    for a in 0..m {
        for b in 0..n {
            corners.push(at(a, b));
            if a + 1 < m {
                edges.push(mid(at(a, b), at(a + 1, b)));
            }
            if b + 1 < n {
                edges.push(mid(at(a, b), at(a, b + 1)));
            }
            if a + 1 < m && b + 1 < n {
                edges.push(mid(
                    mid(at(a, b), at(a + 1, b + 1)),
                    mid(at(a + 1, b), at(a, b + 1)),
                ));
            }
        }
    }
    (corners, edges)
}

/// Per-pixel queries of [`roi_queries`] (a 12 × 12 grid and a pixel beyond each side), then
/// every ROI's warped vertices and edge midpoints, as UV rounded to f32; with the number of
/// vertex and edge queries.
pub fn canonical_queries(atlas: &AtlasRemap) -> (Vec<[f32; 2]>, usize, usize) {
    let mut queries = roi_queries(atlas, 12);
    let (mut corners, mut edges) = (0, 0);
    for (roi, remap) in &atlas.rois {
        let (c, e) = grid_points(remap);
        let to_uv = |p: &[f64; 2]| {
            let q = roi.uv(p[0], p[1]);
            [q.x as f32, q.y as f32]
        };
        corners += c.len();
        edges += e.len();
        queries.extend(c.iter().map(to_uv));
        queries.extend(e.iter().map(to_uv));
    }
    (queries, corners, edges)
}

/// What the queries exercise, with counts (the manifest's `covers`).
fn covers(
    atlas: &AtlasRemap,
    queries: &[[f32; 2]],
    (corners, edges): (usize, usize),
    undecided: usize,
) -> Vec<String> {
    let mut per_roi = vec![0usize; atlas.rois.len()];
    let (mut outside, mut band, mut shared, mut large) = (0, 0, 0, 0);
    let (mut near, mut far, mut parallelogram, mut thin) = (0, 0, 0, 0);
    for q in queries {
        let uv = [f64::from(q[0]), f64::from(q[1])];
        let Some(k) = atlas.rois.iter().position(|(r, _)| r.contains(uv)) else {
            outside += 1;
            continue;
        };
        per_roi[k] += 1;
        shared += usize::from(atlas.rois.iter().filter(|(r, _)| r.contains(uv)).count() > 1);
        large += usize::from(uv[0].abs().max(uv[1].abs()) >= 100.0);
        let (roi, remap) = &atlas.rois[k];
        let (s, t) = roi.st(nalgebra::Point2::new(uv[0], uv[1]));
        let p = [s.clamp(0.0, 1.0), t.clamp(0.0, 1.0)];
        let Some(at) = remap.locate(p) else {
            continue;
        };
        band += usize::from(remap.blend_weight(&at) > 0.0);
        let (i, j) = at.cell;
        let (rest_w, rest_h) = (
            remap.rest.s[i + 1] - remap.rest.s[i],
            remap.rest.t[j + 1] - remap.rest.t[j],
        );
        match &remap.warped {
            Warped::Lines(g) => {
                let (w, h) = (g.s[i + 1] - g.s[i], g.t[j + 1] - g.t[j]);
                thin += usize::from(w * 20.0 <= rest_w || h * 20.0 <= rest_h);
            }
            Warped::Vertices(v) => {
                let corners = quad(v, i, j);
                let k = quadratic(&corners, p);
                let (n_root, f_root) = roots(&k);
                if choose_root(n_root, f_root) == 0 {
                    near += 1;
                } else {
                    far += 1;
                }
                let area = (k.e[0] * k.f[1] - k.e[1] * k.f[0]).abs();
                parallelogram += usize::from(k.a.abs() <= 1e-3 * area);
                let width = k.e[0].hypot(k.e[1]).min(k.f[0].hypot(k.f[1]));
                thin += usize::from(width * 20.0 <= rest_w.min(rest_h));
            }
        }
    }
    let mut covers: Vec<String> = atlas
        .rois
        .iter()
        .zip(&per_roi)
        .enumerate()
        .map(|(k, ((roi, remap), count))| {
            format!(
                "ROI {k} ({}, blending {}, u [{}, {}] × v [{}, {}]): {count} queries",
                if matches!(remap.warped, Warped::Lines(_)) {
                    "AA"
                } else {
                    "NAA"
                },
                if remap.options.boundary_blend {
                    "on"
                } else {
                    "off"
                },
                roi.u0,
                roi.u1,
                roi.v0,
                roi.v1
            )
        })
        .collect();
    covers.extend([
        format!("outside every ROI (returned unchanged): {outside} queries"),
        format!("in the blend band (w > 0): {band}"),
        format!("NAA near root C/q taken: {near}; far root q/A taken: {far}"),
        format!("in a near-parallelogram cell (|A| ≤ 1e-3 |e × f| at the point): {parallelogram}"),
        format!("in a near-degenerate cell (warped 20× or more narrower than at rest): {thin}"),
        format!("on a warped vertex (cell corner): {corners}; on a warped cell edge's midpoint or a cell's centre: {edges}"),
        format!("on the edge two ROIs share (the first takes it): {shared}"),
        format!("large UV coordinates (|u| or |v| ≥ 100, a ROI far from the origin): {large}"),
        format!("undecided (f32 cannot decide: bound unbounded, not judged): {undecided}"),
    ]);
    covers
}

/// The `gridwarp_lookup` vectors of `atlas` at `queries` (UV, f32) and, with a GPU, reparam's
/// own kernel's output as the candidate. `points` = (vertex queries, edge queries) for the
/// covers list.
pub fn vectors(
    gpu: Option<&reparam_gpu::Gpu>,
    atlas: &AtlasRemap,
    queries: &[[f32; 2]],
    points: (usize, usize),
) -> Result<VectorsAndCandidates> {
    let rounded = round_atlas(atlas)?;
    let tables = lookup_tables(&rounded)?;
    tables.check().map_err(|e| Error::Gpu(e.to_string()))?;
    let flat = FlatTables::of(&tables);
    let expected = reference_lookups(&rounded, queries);
    let bounds = lookup_bounds(&flat.tables(), queries, &expected);
    let undecided = bounds.iter().filter(|b| b.undecided).count();
    let r = rounded.rois.len();
    let q = queries.len();
    let inputs = vec![
        (
            "rois".into(),
            "f32, per ROI k (in order): u0, u1, v0, v1, its rectangle in UV".into(),
            Array::f32(&[r, 4], flat.rois.clone()),
        ),
        (
            "roi_grids".into(),
            "u32, per ROI k: variant (0 AA, 1 NAA), blend (0 off, 1 on), M, N, R (first rest \
             line in rest_lines), W (first warped value in warped)"
                .into(),
            Array::u32(&[r, 6], flat.grids.clone()),
        ),
        (
            "rest_lines".into(),
            "f32: per ROI its rest lines ŝ_0 … ŝ_{M−1}, then t̂_0 … t̂_{N−1} (from 0 to 1, \
             increasing), at R"
                .into(),
            Array::f32(&[flat.rest_lines.len()], flat.rest_lines.clone()),
        ),
        (
            "warped".into(),
            "f32: per ROI at W, AA: its warped lines s_0 … s_{M−1}, then t_0 … t_{N−1}; NAA: \
             its vertices P_ab = (s, t) at W + 2(a·N + b), a = 0 … M − 1 along s, b = 0 … N − 1 \
             along t"
                .into(),
            Array::f32(&[flat.warped.len()], flat.warped.clone()),
        ),
        (
            "queries".into(),
            "f32, per query: the UV (u, v) looked up".into(),
            Array::f32(&[q, 2], queries.iter().flatten().copied().collect()),
        ),
    ];
    let kernel = KernelData {
        name: "gridwarp_lookup".into(),
        description: format!("per query, {LOOKUP_FORMULA}"),
        inputs,
        expected: (
            "f64, per query: the looked-up UV (u', v') of the f64 reference on these f32 inputs"
                .into(),
            Array::f64(&[q, 2], expected.iter().flatten().copied().collect()),
        ),
        bound: (
            "per query, in texels of a 4096² texture (4096 × the UV distance); 1.8e308 where \
             f32 cannot decide (undecided: not judged, counted by verify)"
                .into(),
            Array::f64(
                &[q],
                bounds
                    .iter()
                    .map(|b| {
                        if b.undecided {
                            b.bound
                        } else {
                            TEXELS * b.bound
                        }
                    })
                    .collect(),
            ),
        ),
        metric: Metric::NormOfLastAxis {
            scale: TEXELS,
            unit: "texels of a 4096² texture".into(),
        },
        bound_formula: BOUND_FORMULA.into(),
        derivation: "crosscheck::gridwarp_lookup: the kernel's f32 twin over Lin along every \
            cell and root an f32 evaluation may choose; the Newton step's second-order term \
            J⁻¹g δα δβ exactly (W is bilinear); the gridwarp guide derives it"
            .into(),
        per_element: vec!["queries".into()],
        covers: covers(&rounded, queries, points, undecided),
    };
    let mut candidates = Vec::new();
    if let Some(gpu) = gpu {
        let got = gpu_lookup_uv(gpu, &rounded, queries)?;
        candidates.push((
            "gridwarp_lookup".to_string(),
            Array::f32(&[q, 2], got.into_iter().flatten().collect()),
        ));
    }
    Ok((vec![kernel], candidates))
}

/// The canonical `gridwarp_lookup` vectors ([`canonical_atlas`], [`canonical_queries`]).
pub fn canonical_vectors(gpu: Option<&reparam_gpu::Gpu>) -> Result<VectorsAndCandidates> {
    let atlas = canonical_atlas()?;
    let (queries, corners, edges) = canonical_queries(&atlas);
    vectors(gpu, &atlas, &queries, (corners, edges))
}
