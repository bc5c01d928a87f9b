//! The per-query bound of `unwarp_lookup` (entry `main`): how far a conforming f32 evaluation
//! of the lookup coordinate s + o(u) may lie from the f64 reference
//! ([`crate::unwarp::apply::lookup_coordinate`]) on the same (f32-rounded) inputs, per
//! component, in UV units; and which queries f32 cannot decide (the nearest level at a level
//! boundary). Written once here; the twin test and the crosscheck row use it.
//!
//! # Derivation (ε = [`WGSL_U`] = 2⁻²³, one WGSL rounding up or down; first order in ε)
//! 1. **Re-centring.** s = u − ⌊u⌋ is exact for u ≥ 0 (the difference has fewer bits than u);
//!    for u < 0 it is u + k, which may round: |δs| ≤ ε (s ≤ 1). This is what re-centring buys:
//!    without it a coordinate far from the origin keeps ε|u| of error (ε·2²⁰ ≈ 0.125 UV at
//!    u = 2²⁰), and the bound, which holds s's error to ε, rejects such a kernel. A fixed
//!    border does not re-centre: δs = 0.
//! 2. **Texel point.** ξ = sW − ½: the product and the difference round:
//!    |δξ| ≤ W|δs| + ε(|s|W + |ξ|) (a fused sW − ½ rounds once, less). η = (1 − v)H − ½:
//!    |δη| ≤ H(|δv| + ε|1 − v|) + ε(|1 − v|H + |η|).
//! 3. **The cell.** ⌊ξ⌋ is discontinuous, but the bilinear value is continuous across cell
//!    edges (and at the clamp, where the fraction goes to 0 as the value reaches the edge
//!    texel), and Lipschitz: |δo| ≤ D_x (|δξ| + ε) + D_y (|δη| + ε), D_x, D_y the largest
//!    difference between neighbouring texels of the level along x, y (with wrap for a
//!    periodic map), ε for the fraction t − ⌊t⌋ (exact for t ≥ 0, one rounding for t < 0).
//! 4. **Bilinear arithmetic.** a(1 − f) + b f with |a|, |b| ≤ M: (1 − f), both products and the
//!    sum round, ≤ 3εM; the second lerp adds its own 3εM: 6εM, M the largest |o| of the
//!    level (component by component).
//! 5. **Level of detail.** ρ² sums two squares (2 roundings: relative 2ε), the longer is kept
//!    exactly, √ is inherited from 1/inverseSqrt (4.5 ULP), so δρ/ρ ≤ (1 + 4.5 + 1)ε; λ = log₂ ρ
//!    then errs by (δρ/ρ)/ln 2 plus log₂'s own error (absolute 2⁻²¹ on ρ ∈ [½, 2], else 3 ULP
//!    ≤ 3ε|λ|): δλ.
//! 6. **Level choice.** Trilinear: the blend (1 − w) o_d + w o_{d+1} is continuous in λ (w → 1
//!    as λ → d + 1 from below, where the next choice starts at w = 0), so a δλ moves it by at
//!    most δλ · max |o_{k+1}(u) − o_k(u)| over the level pairs around λ (at most two; 0 once
//!    clamped to the coarsest), plus the blend's arithmetic 3ε max(|o_d|, |o_{d+1}|).
//!    **Nearest**: the choice ⌊λ_c + ½⌋ jumps by the whole o_{d+1} − o_d at λ_c = d + ½; a
//!    query with |λ_c − (d + ½)| ≤ δλ (+ the rounding of λ_c + ½, ε(d + 1)) is **undecided**:
//!    f32 may pick either level. Its bound is `f64::MAX` and it is counted, never a silent pass.
//! 7. **The coordinate.** s + (o.x, −o.y) rounds once: ε|s + o|, plus δs.
//!
//! Each figure is multiplied by `SAFETY` = 2 to cover the second-order terms and the flush
//! of subnormal products (|o| ≪ 1 keeps them far from 2⁻¹²⁶ except for o = 0, exact), and
//! [`F32_FLUSH`] is added per operation.

use super::{F32_FLUSH, WGSL_U};
use crate::unwarp::apply::{
    choose_levels, level_of_detail, recentre, texel_point, MipmapFilter, Query,
};
use crate::unwarp::mesh::Border;
use crate::unwarp::output::OffsetLevel;

/// The factor on the first-order bound (module docs, end).
pub const SAFETY: f64 = 2.0;

/// The bound's formula, as rows and the guide print it.
pub const LOOKUP_BOUND_FORMULA: &str = "2·[ε + ε|s+o| + D_x(|δξ|+ε) + D_y(|δη|+ε) + 6εM \
     + δλ·|o_{d+1} − o_d| + 3εM]; nearest within δλ of d+½: undecided";

/// One level's constants of the bound: D (largest neighbour difference along x and y) and M
/// (largest |o|), per component.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelConstants {
    pub dx: [f64; 2],
    pub dy: [f64; 2],
    pub max: [f64; 2],
}

/// [`LevelConstants`] of a level: neighbour differences with wrap for a periodic map (the last
/// column's neighbour is the first), without at a fixed border.
pub fn level_constants(level: &OffsetLevel, border: Border) -> LevelConstants {
    let (w, h) = (level.width, level.height);
    let at = |x: usize, y: usize| level.offsets[y * w + x];
    let wrap = border == Border::Periodic;
    let mut c = LevelConstants {
        dx: [0.0; 2],
        dy: [0.0; 2],
        max: [0.0; 2],
    };
    for y in 0..h {
        for x in 0..w {
            let o = at(x, y);
            let right = (x + 1 < w || wrap).then(|| at((x + 1) % w, y));
            let down = (y + 1 < h || wrap).then(|| at(x, (y + 1) % h));
            for k in 0..2 {
                c.max[k] = c.max[k].max(o[k].abs());
                if let Some(r) = right {
                    c.dx[k] = c.dx[k].max((r[k] - o[k]).abs());
                }
                if let Some(d) = down {
                    c.dy[k] = c.dy[k].max((d[k] - o[k]).abs());
                }
            }
        }
    }
    c
}

/// δλ of a footprint (module docs, step 5).
pub fn lod_error(query: &Query) -> f64 {
    let f = &query.footprint;
    let length = |d: [f64; 2]| d[0].hypot(d[1]);
    let rho = length(f.dx).max(length(f.dy));
    if rho <= 1.0 {
        // λ = 0 exactly unless ρ rounds past 1: then λ ≤ log₂(1 + 7ε) + 2⁻²¹.
        return 6.5 * WGSL_U / std::f64::consts::LN_2 + 2f64.powi(-21);
    }
    let lambda = rho.log2();
    let log_error = if rho <= 2.0 {
        2f64.powi(-21)
    } else {
        3.0 * WGSL_U * lambda.abs()
    };
    6.5 * WGSL_U / std::f64::consts::LN_2 + log_error
}

/// The per-component bound of one query's lookup coordinate (UV units), or `None` where f32
/// cannot decide the level (nearest filter within δλ of a boundary: undecided). `constants`
/// are [`level_constants`] of every level of `chain`.
pub fn lookup_bound(
    chain: &[OffsetLevel],
    constants: &[LevelConstants],
    border: Border,
    filter: MipmapFilter,
    query: &Query,
) -> Option<[f64; 2]> {
    let e = WGSL_U;
    let lambda = level_of_detail(&query.footprint);
    let d_lambda = lod_error(query);
    let top = chain.len().saturating_sub(1) as f64;
    let clamped = lambda.max(0.0).min(top);
    if filter == MipmapFilter::Nearest && top > 0.0 {
        // The boundary d + ½ nearest to λ_c (λ_c lies within ½ of it), below the coarsest.
        let boundary = clamped.floor() + 0.5;
        if boundary < top && (clamped - boundary).abs() <= d_lambda + e * (boundary + 1.0) {
            return None;
        }
    }
    let s = recentre(query.uv, border);
    let ds = if border == Border::Periodic { e } else { 0.0 };
    let choice = choose_levels(lambda, chain.len(), filter);
    let sample = |k: usize| crate::unwarp::apply::sample_chain_level(&chain[k], border, query.uv);
    // Steps 2–4 on each level the lookup (or a neighbouring λ) may use.
    let level_error = |k: usize| -> [f64; 2] {
        let l = &chain[k];
        let c = &constants[k];
        let (w, h) = (l.width as f64, l.height as f64);
        let p = texel_point(s, l.width, l.height);
        let dxi = w * ds + e * (s[0].abs() * w + p[0].abs());
        let one_v = (1.0 - s[1]).abs();
        let deta = h * (ds + e * one_v) + e * (one_v * h + p[1].abs());
        [0, 1].map(|i| {
            c.dx[i] * (dxi + e) + c.dy[i] * (deta + e) + 6.0 * e * c.max[i] + 8.0 * F32_FLUSH
        })
    };
    let mut levels = vec![choice.fine, choice.coarse];
    // Trilinear at an integer λ may take the pair below or above: both.
    if filter == MipmapFilter::Linear {
        let lo = (clamped - d_lambda).max(0.0).floor() as usize;
        let hi = ((clamped + d_lambda).min(top).floor() as usize + 1).min(chain.len() - 1);
        levels.extend(lo..=hi);
    }
    levels.sort_unstable();
    levels.dedup();
    let samples: Vec<[f64; 2]> = levels.iter().map(|&k| sample(k)).collect();
    let errors: Vec<[f64; 2]> = levels.iter().map(|&k| level_error(k)).collect();
    let coordinate = crate::unwarp::apply::lookup_coordinate(chain, border, filter, query);
    Some([0, 1].map(|i| {
        let sample_error = errors.iter().map(|x| x[i]).fold(0.0, f64::max);
        let magnitude = samples.iter().map(|x| x[i].abs()).fold(0.0, f64::max);
        let blend = match filter {
            MipmapFilter::Linear => {
                let jump = samples
                    .windows(2)
                    .map(|p| (p[1][i] - p[0][i]).abs())
                    .fold(0.0, f64::max);
                d_lambda * jump + 3.0 * e * magnitude + 3.0 * F32_FLUSH
            }
            MipmapFilter::Nearest => 0.0,
        };
        let sum = ds + e * coordinate[i].abs() + sample_error + blend + F32_FLUSH;
        SAFETY * sum
    }))
}

/// The bound of every query, and how many are undecided (their bound `f64::MAX`).
pub fn lookup_bounds(
    chain: &[OffsetLevel],
    border: Border,
    filter: MipmapFilter,
    queries: &[Query],
) -> (Vec<[f64; 2]>, usize) {
    let constants: Vec<LevelConstants> = chain.iter().map(|l| level_constants(l, border)).collect();
    let mut undecided = 0;
    let bounds = queries
        .iter()
        .map(|q| {
            lookup_bound(chain, &constants, border, filter, q).unwrap_or_else(|| {
                undecided += 1;
                [f64::MAX; 2]
            })
        })
        .collect();
    (bounds, undecided)
}
