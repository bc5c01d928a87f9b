//! The `gridwarp_lookup` kernel (`shaders/gridwarp_lookup.wgsl`) on hand-made atlases: an AA
//! grid whose lookups are exact in f32, an outside query, and NAA cells whose inverse bilinear
//! takes the near root, the far root, a near-parallelogram (|A| ≈ 1e-6) and a near-degenerate
//! (100× compressed) cell, each queried at points W(α, β) whose (α, β) is known; and every
//! input error [`LookupTables::check`] names. Skipped without an adapter unless
//! REPARAM_REQUIRE_GPU=1. The cross-check against the f64 reference with the derived
//! per-query bound is `crosscheck::gridwarp_lookup` in the reparam crate.

use reparam_gpu::gridwarp::lookup::{lookup, AA, NAA};
use reparam_gpu::gridwarp::{LookupTables, RoiGrid, RoiRect};
use reparam_gpu::{gpu_or_skip, GpuError};

const UNIT: RoiRect = RoiRect {
    u0: 0.0,
    u1: 1.0,
    v0: 0.0,
    v1: 1.0,
};

/// One ROI over the unit square, NAA, 2 × 2 vertices `q` = [P00, P10, P01, P11], rest lines
/// 0 and 1 (so the looked-up point is (α, β) itself), no blending.
fn one_quad(q: [[f32; 2]; 4]) -> LookupTables {
    // Vertex P_ab at 2(a·N + b), N = 2: P00, P01, P10, P11.
    let warped = [q[0], q[2], q[1], q[3]].concat();
    LookupTables {
        rois: vec![UNIT],
        grids: vec![RoiGrid {
            variant: NAA,
            blend: 0,
            m: 2,
            n: 2,
            rest: 0,
            warped: 0,
        }],
        rest_lines: vec![0.0, 1.0, 0.0, 1.0],
        warped,
    }
}

/// W(α, β) in f64 (the query), rounded to f32.
fn bilinear(q: &[[f32; 2]; 4], alpha: f64, beta: f64) -> [f32; 2] {
    std::array::from_fn(|k| {
        let c = |i: usize| f64::from(q[i][k]);
        ((1.0 - alpha) * (1.0 - beta) * c(0)
            + alpha * (1.0 - beta) * c(1)
            + (1.0 - alpha) * beta * c(2)
            + alpha * beta * c(3)) as f32
    })
}

/// Each point W(α, β) of `q` looks up to (α, β) within `tol`.
fn assert_inverts(q: [[f32; 2]; 4], points: &[[f64; 2]], tol: f64, what: &str) {
    let Some(gpu) = gpu_or_skip() else { return };
    let queries: Vec<[f32; 2]> = points.iter().map(|p| bilinear(&q, p[0], p[1])).collect();
    let got = lookup(&gpu, &one_quad(q), &queries).unwrap();
    for (p, g) in points.iter().zip(&got) {
        let err = (f64::from(g[0]) - p[0]).hypot(f64::from(g[1]) - p[1]);
        assert!(
            err <= tol,
            "{what}: (α, β) = {p:?} looked up as {g:?}: error {err:e} > {tol:e}"
        );
    }
}

// The tolerance of a well-conditioned cell: the query W(α, β) is rounded to f32 (½ ULP of
// numbers ≤ 1, 2⁻²⁴), the kernel's ~40 operations each err by at most 2.5 ULP relative (WGSL's
// division; the rest 1 ULP), and the Newton step leaves the closed form's error squared: the
// result's error is at most a few tens of ULPs of 1 times ‖J⁻¹‖ (≤ 4 on these cells), under
// 2⁻¹⁶ (512 ULPs of 1). A cell compressed c× multiplies it by c (α = Δs / width).
const TOL: f64 = 1.0 / 65536.0;

/// `got` is `want` within [`AA_TOL`] on each coordinate.
fn assert_close(got: &[[f32; 2]], want: &[[f32; 2]]) {
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(want) {
        for c in 0..2 {
            let err = (f64::from(g[c]) - f64::from(w[c])).abs();
            assert!(err <= AA_TOL, "{g:?} for {w:?}: error {err:e}");
        }
    }
}

// The AA cases' values are exact in f32, and so is every operation but the division α =
// Δs / width, which WGSL allows 2.5 ULP: α ≤ 1 errs by ≤ 2.5·2⁻²⁴ and the rest point
// ŝ_i + α h_i and the blend (1 − w) ρ + w P (w from α, β) by a few ULPs more: 2⁻²⁰ (16 ULPs
// of 1) is above that, and far below the 1/32 that a wrong cell or weight moves the result.
const AA_TOL: f64 = 1.0 / 1048576.0;

/// AA: rest lines s = t = (0, ½, 1), warped (0, ¼, 1): s = ⅛ is α = ½ in cell 0 → ¼; s = ⅝ is
/// α = ½ in cell 1 → ¾. A query outside the ROI comes back unchanged, bit for bit.
#[test]
fn aa_lookup_by_hand_and_outside_unchanged() {
    let Some(gpu) = gpu_or_skip() else { return };
    let tables = LookupTables {
        rois: vec![UNIT],
        grids: vec![RoiGrid {
            variant: AA,
            blend: 0,
            m: 3,
            n: 3,
            rest: 0,
            warped: 0,
        }],
        rest_lines: vec![0.0, 0.5, 1.0, 0.0, 0.5, 1.0],
        warped: vec![0.0, 0.25, 1.0, 0.0, 0.25, 1.0],
    };
    let queries = [[0.125, 0.625], [0.625, 0.125], [1.5, 0.25], [-3.0e7, 7.0]];
    let got = lookup(&gpu, &tables, &queries).unwrap();
    assert_close(&got[..2], &[[0.25, 0.75], [0.75, 0.25]]);
    assert_eq!(got[2..], [[1.5, 0.25], [-3.0e7, 7.0]]);
}

/// Blending on the same AA grid (seed §10.2): (⅛, ⅝) is α = ½ in the first column (w_s =
/// 1 − α = ½) and β = ½ in the last row (w_t = β = ½), so w = 1 − ½·½ = ¾, and the rest point
/// (¼, ¾) is blended with p: (1 − w) ρ + w p.
#[test]
fn aa_blend_by_hand() {
    let Some(gpu) = gpu_or_skip() else { return };
    let tables = LookupTables {
        rois: vec![UNIT],
        grids: vec![RoiGrid {
            variant: AA,
            blend: 1,
            m: 3,
            n: 3,
            rest: 0,
            warped: 0,
        }],
        rest_lines: vec![0.0, 0.5, 1.0, 0.0, 0.5, 1.0],
        warped: vec![0.0, 0.25, 1.0, 0.0, 0.25, 1.0],
    };
    let got = lookup(&gpu, &tables, &[[0.125, 0.625]]).unwrap();
    // s = ¼·¼ + ¾·⅛ = 5/32, t = ¼·¾ + ¾·⅝ = 21/32 (without the blend: (¼, ¾)).
    assert_close(&got, &[[0.15625, 0.65625]]);
}

/// A convex quad on which the root of the quadratic in β that lies in [0, 1] is the far one
/// q/A at (α, β) = (½, ½) and (¼, ¾), the near one C/q at (¾, ⅛): computed in f64, A = −1.648,
/// (near, far) = (−0.341, 0.5), (−0.453, 0.75) and (0.125, −0.230) there. A kernel that always
/// takes C/q returns β < 0 (clamped to 0) at the first two.
#[test]
fn naa_both_roots() {
    let q = [
        [0.0, 0.0],
        [0.25, 0.09375],
        [0.046875, 0.25],
        [0.703125, 0.3125],
    ];
    assert_inverts(
        q,
        &[[0.5, 0.5], [0.25, 0.75], [0.75, 0.125]],
        TOL,
        "both roots",
    );
}

/// A near-parallelogram: the unit square with P11 moved by (1e-6, −1e-6), A ≈ −1e-6: the far
/// root q/A is beyond FAR_ROOT and left out, the near one is the linear equation's −C/B.
#[test]
fn naa_near_parallelogram() {
    let q = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.000001, 0.999999]];
    assert_inverts(
        q,
        &[
            [0.5, 0.5],
            [0.25, 0.75],
            [0.75, 0.125],
            [0.0, 0.0],
            [1.0, 1.0],
        ],
        TOL,
        "near-parallelogram",
    );
}

/// A near-degenerate cell, 0.01 wide at the bottom and 0.0125 at the top for a rest width of
/// 1 (compressed 80–100×): α's error is the point's error over the width, so the tolerance is
/// 100 × TOL.
#[test]
fn naa_near_degenerate() {
    let q = [[0.0, 0.0], [0.01, 0.0], [0.0, 1.0], [0.0125, 1.0]];
    assert_inverts(
        q,
        &[[0.5, 0.5], [0.25, 0.75], [0.75, 0.125]],
        100.0 * TOL,
        "near-degenerate",
    );
}

/// Every input error of [`LookupTables::check`] is a typed `GpuError::Input` naming the ROI,
/// before anything is dispatched.
#[test]
fn bad_tables_are_input_errors() {
    let Some(gpu) = gpu_or_skip() else { return };
    let good = one_quad([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]);
    assert!(lookup(&gpu, &good, &[[0.5, 0.5]]).is_ok());
    let mut cases: Vec<(&str, LookupTables)> = Vec::new();
    let mut t = good.clone();
    t.grids.clear();
    cases.push(("0 grids for 1 ROIs", t));
    let mut t = good.clone();
    t.rois[0].u1 = 0.0;
    cases.push(("ROI 0: u [0, 0]", t));
    let mut t = good.clone();
    t.rois[0].v1 = f32::NAN;
    cases.push(("ROI 0: u [0, 1] × v [0, NaN]", t));
    let mut t = good.clone();
    t.grids[0].variant = 2;
    cases.push(("ROI 0: variant 2", t));
    let mut t = good.clone();
    t.grids[0].blend = 7;
    cases.push(("blend 7", t));
    let mut t = good.clone();
    t.grids[0].m = 1;
    cases.push(("ROI 0: 1×2 lines", t));
    let mut t = good.clone();
    t.grids[0].rest = 1;
    cases.push(("ROI 0: rest lines 1..5 beyond the 4", t));
    let mut t = good.clone();
    t.warped.pop();
    cases.push(("ROI 0: warped values 0..8 beyond the 7", t));
    for (what, t) in cases {
        match lookup(&gpu, &t, &[[0.5, 0.5]]) {
            Err(GpuError::Input(msg)) => {
                assert!(msg.contains(what), "expected '{what}' in '{msg}'")
            }
            other => panic!("{what}: expected an input error, got {other:?}"),
        }
    }
}
