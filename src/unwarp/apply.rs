//! Applying a correction at render time (seed 001: "two variants to apply this correction"; notes
//! § Application): the plain f64 lookup a modified renderer does per fragment, and the
//! pre-warped bake of the backward-compatible variant, texel by texel.
//!
//! **The render-time lookup** of a fragment with texture coordinate u (OBJ convention, v up) and
//! screen-space footprint ∂u/∂x, ∂u/∂y (in texels of level 0, as a fragment shader has them
//! after scaling `dpdx(uv)`, `dpdy(uv)` by the level-0 size):
//!
//! 1. the level of detail ([`level_of_detail`], Vulkan's rule, which WebGPU inherits):
//!    ρ = max(‖∂u/∂x‖, ‖∂u/∂y‖), λ = log₂ ρ (0 where ρ ≤ 1: magnification);
//! 2. the levels ([`choose_levels`]): λ_c = clamp(λ, 0, L − 1), trilinear by default — level
//!    d = ⌊λ_c⌋ and d + 1 (at most L − 1) blended with weight λ_c − d — or the nearest level
//!    ⌊λ_c + ½⌋;
//! 3. on each level, the offset bilinear between texel centres ([`sample_level`]), wrapping
//!    for a periodic map and clamped at a fixed border, at the query re-centred into its tile
//!    ([`recentre`]: s = u − ⌊u⌋ for a periodic map);
//! 4. the lookup coordinate ([`lookup_coordinate`]): s + (o.x, −o.y), the colour texture then
//!    being sampled there, C(s + o(u)).
//!
//! **Why trilinear.** A nearest-level lookup is discontinuous where λ crosses d + ½: the offset
//! jumps by o_{d+1} − o_d, a seam in the corrected texture along a screen-space contour (and a
//! choice f32 may make either way: [`MipmapFilter::Nearest`] exists for renderers that use it,
//! and its bound marks those queries undecided). The trilinear blend weight goes to 0 at a level
//! boundary, so the lookup is continuous in λ, and so is its f32 evaluation's error. The chain
//! itself is [`offset_mip_chain`]: box-averaging offsets equals box-averaging the
//! coordinates u + o.
//!
//! **Why re-centre.** A repeating sampler ignores the integer part of a coordinate; an f32 that
//! carries it loses those bits from the fraction (at u = 1000, 2⁻¹³ UV is left: half a texel of
//! a 4096² texture). Re-centring first (u − ⌊u⌋ is exact for u ≥ 0) keeps the lookup as precise
//! in the thousandth tile as in the first.
//!
//! **The pre-warped bake** ([`bake_colour`]): C'(u) = C(u + c(u)) at every texel centre of the
//! colour texture, c the level-0 offset sampled at u ([`bake_coordinate`]); rendering C' with the
//! original UVs shows what the modified renderer shows with C (bijective maps only).
//!
//! Coordinates: the offsets are the solver's (node convention, o.y along image rows, down);
//! [`offset_to_uv`] turns them into (Δu, Δv) = (o.x, −o.y).

use crate::error::{Error, Result};
use crate::texture::{sample_bilinear, Image, Rgba8};

use super::mesh::Border;

/// (Δu, Δv) = (o.x, −o.y): a solver offset in the OBJ convention.
pub fn offset_to_uv(o: [f64; 2]) -> [f64; 2] {
    [o[0], -o[1]]
}

/// A level of the offset mip chain.
#[derive(Clone, Debug, PartialEq)]
pub struct OffsetLevel {
    pub width: usize,
    pub height: usize,
    pub offsets: Vec<[f64; 2]>,
}

/// The mip chain of the offsets, level 0 first: each next level the 2×2 box average, while both
/// sizes are even. Box-averaging offsets equals box-averaging the coordinates u + o, since the
/// base coordinates of a 2×2 block average to the coarse texel's centre (notes § Application).
pub fn offset_mip_chain(width: usize, height: usize, offsets: &[[f64; 2]]) -> Vec<OffsetLevel> {
    let mut chain = vec![OffsetLevel {
        width,
        height,
        offsets: offsets.to_vec(),
    }];
    while let Some(last) = chain.last() {
        if last.width % 2 != 0 || last.height % 2 != 0 {
            break;
        }
        let (w, h) = (last.width / 2, last.height / 2);
        let at = |x: usize, y: usize| last.offsets[y * last.width + x];
        let offsets = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let q = [
                    at(2 * x, 2 * y),
                    at(2 * x + 1, 2 * y),
                    at(2 * x, 2 * y + 1),
                    at(2 * x + 1, 2 * y + 1),
                ];
                [0, 1].map(|c| 0.25 * ((q[0][c] + q[1][c]) + (q[2][c] + q[3][c])))
            })
            .collect();
        chain.push(OffsetLevel {
            width: w,
            height: h,
            offsets,
        });
    }
    chain
}

/// How the level (or levels) of the offset chain are chosen from λ (WebGPU's sampler
/// `mipmapFilter`, Vulkan's `mipmapMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum MipmapFilter {
    /// Trilinear: levels ⌊λ_c⌋ and ⌊λ_c⌋ + 1 blended by λ_c − ⌊λ_c⌋ (continuous in λ). Default.
    #[default]
    Linear,
    /// The nearest level ⌊λ_c + ½⌋ (Vulkan's allowed `floor(d + 0.5)`; its preferred
    /// `ceil(d + 0.5) − 1` differs only at d + ½ exactly, where f32 may choose either anyway).
    Nearest,
}

/// A fragment's screen-space footprint: ∂u/∂x and ∂u/∂y, each (u, v) components in texels of
/// level 0 (`dpdx(uv) · (W₀, H₀)`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Footprint {
    pub dx: [f64; 2],
    pub dy: [f64; 2],
}

/// One lookup: the fragment's texture coordinate (OBJ convention) and its footprint.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Query {
    pub uv: [f64; 2],
    pub footprint: Footprint,
}

/// The largest |u| or |v| a query may have: 2²² (an f32 keeps 1/2 of a unit there, so the
/// tile is still known; beyond, f32 does not know which tile the query is in).
pub const UV_LIMIT: f64 = 4_194_304.0;

/// [`Error::InvalidArgument`] naming the first query (by index, in `what`) with a non-finite
/// value or a coordinate beyond ±[`UV_LIMIT`].
pub fn check_queries(what: &str, queries: &[Query]) -> Result<()> {
    for (i, q) in queries.iter().enumerate() {
        let f = &q.footprint;
        let values = [q.uv[0], q.uv[1], f.dx[0], f.dx[1], f.dy[0], f.dy[1]];
        if values.iter().any(|v| !v.is_finite()) {
            return Err(Error::InvalidArgument(format!(
                "{what}: query {i} has a non-finite value {values:?}"
            )));
        }
        if q.uv.iter().any(|c| c.abs() > UV_LIMIT) {
            return Err(Error::InvalidArgument(format!(
                "{what}: query {i} has uv {:?}, beyond ±{UV_LIMIT} (2²²)",
                q.uv
            )));
        }
    }
    Ok(())
}

/// The level of detail (Vulkan § "Scale factor operation, level-of-detail operation", which
/// WebGPU's `textureSampleGrad` inherits): ρ = max(‖∂u/∂x‖, ‖∂u/∂y‖) in texels of level 0,
/// each length √(a² + b²) (the exact rule; Vulkan also allows max(|a|, |b|) approximations),
/// λ = log₂ ρ where ρ > 1, else 0 (magnification samples level 0; log₂ of 0 has no WGSL bound).
pub fn level_of_detail(f: &Footprint) -> f64 {
    let length = |d: [f64; 2]| (d[0] * d[0] + d[1] * d[1]).sqrt();
    let rho = length(f.dx).max(length(f.dy));
    if rho > 1.0 {
        rho.log2()
    } else {
        0.0
    }
}

/// The levels a lookup blends: `fine`, `coarse` (= `fine` + 1, or `fine` at the coarsest) and
/// the weight of `coarse`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MipChoice {
    pub fine: usize,
    pub coarse: usize,
    pub weight: f64,
}

/// The levels of λ among `level_count` (≥ 1): λ_c = clamp(λ, 0, L − 1); trilinear: fine =
/// ⌊λ_c⌋, coarse = min(fine + 1, L − 1), weight = λ_c − fine; nearest: fine = coarse =
/// ⌊λ_c + ½⌋, weight 0.
pub fn choose_levels(lambda: f64, level_count: usize, filter: MipmapFilter) -> MipChoice {
    let top = level_count.saturating_sub(1) as f64;
    let clamped = lambda.max(0.0).min(top);
    match filter {
        MipmapFilter::Linear => {
            let fine = clamped.floor();
            MipChoice {
                fine: fine as usize,
                coarse: (fine + 1.0).min(top) as usize,
                weight: clamped - fine,
            }
        }
        MipmapFilter::Nearest => {
            let level = (clamped + 0.5).floor().min(top) as usize;
            MipChoice {
                fine: level,
                coarse: level,
                weight: 0.0,
            }
        }
    }
}

/// The query's coordinate within its tile: (u − ⌊u⌋, v − ⌊v⌋) for a periodic map, whose
/// lookups repeat with period 1; `uv` itself at a fixed border (no tiling: a coordinate outside
/// [0, 1] samples the clamped edge).
pub fn recentre(uv: [f64; 2], border: Border) -> [f64; 2] {
    match border {
        Border::Periodic => [uv[0] - uv[0].floor(), uv[1] - uv[1].floor()],
        Border::Fixed => uv,
    }
}

/// The texel-space point of a (re-centred) coordinate on a W × H level, texel centres at
/// integers, row 0 at the top: (ξ, η) = (u W − ½, (1 − v) H − ½).
pub fn texel_point(uv: [f64; 2], width: usize, height: usize) -> [f64; 2] {
    [
        uv[0] * width as f64 - 0.5,
        (1.0 - uv[1]) * height as f64 - 0.5,
    ]
}

/// A texel-space coordinate t on an axis of n texels: the two texels it lies between and the
/// fraction towards the second, t − ⌊t⌋ (wrapping: indices mod n; clamped: the edge texel
/// with fraction 0 outside [0, n − 1]).
pub fn texel_pair(t: f64, n: usize, border: Border) -> (usize, usize, f64) {
    let f = t.floor();
    let i = f as i64;
    let n = n as i64;
    match border {
        Border::Periodic => (
            i.rem_euclid(n) as usize,
            (i + 1).rem_euclid(n) as usize,
            t - f,
        ),
        Border::Fixed => {
            let last = n - 1;
            let frac = if i < 0 || i >= last { 0.0 } else { t - f };
            (
                i.clamp(0, last) as usize,
                (i + 1).clamp(0, last) as usize,
                frac,
            )
        }
    }
}

/// The solver offset of a W × H level (row-major, top row first) at coordinate `uv`, bilinear
/// between texel centres: the point [`texel_point`] of [`recentre`]d `uv`, its cell
/// ([`texel_pair`]), then per component top = o₀₀(1 − f_x) + o₁₀ f_x, bottom = o₀₁(1 − f_x) +
/// o₁₁ f_x, top (1 − f_y) + bottom f_y.
pub fn sample_level(
    width: usize,
    height: usize,
    offsets: &[[f64; 2]],
    border: Border,
    uv: [f64; 2],
) -> [f64; 2] {
    let [xi, eta] = texel_point(recentre(uv, border), width, height);
    let (x0, x1, fx) = texel_pair(xi, width, border);
    let (y0, y1, fy) = texel_pair(eta, height, border);
    let at = |x: usize, y: usize| offsets[y * width + x];
    [0, 1].map(|c| {
        let top = at(x0, y0)[c] * (1.0 - fx) + at(x1, y0)[c] * fx;
        let bottom = at(x0, y1)[c] * (1.0 - fx) + at(x1, y1)[c] * fx;
        top * (1.0 - fy) + bottom * fy
    })
}

/// [`sample_level`] on a level of the chain.
pub fn sample_chain_level(level: &OffsetLevel, border: Border, uv: [f64; 2]) -> [f64; 2] {
    sample_level(level.width, level.height, &level.offsets, border, uv)
}

/// The solver offset of a query: the levels of its [`level_of_detail`] ([`choose_levels`]),
/// each sampled at uv ([`sample_chain_level`]), blended (1 − w) o_fine + w o_coarse.
pub fn lookup_offset(
    chain: &[OffsetLevel],
    border: Border,
    filter: MipmapFilter,
    query: &Query,
) -> [f64; 2] {
    let choice = choose_levels(level_of_detail(&query.footprint), chain.len(), filter);
    let fine = sample_chain_level(&chain[choice.fine], border, query.uv);
    let coarse = sample_chain_level(&chain[choice.coarse], border, query.uv);
    let w = choice.weight;
    [0, 1].map(|c| fine[c] * (1.0 - w) + coarse[c] * w)
}

/// The lookup coordinate of a query (OBJ convention): its [`recentre`]d uv plus the offset in
/// texture coordinates, s + (o.x, −o.y) with o = [`lookup_offset`]. The colour is then
/// C(lookup coordinate).
pub fn lookup_coordinate(
    chain: &[OffsetLevel],
    border: Border,
    filter: MipmapFilter,
    query: &Query,
) -> [f64; 2] {
    let s = recentre(query.uv, border);
    let d = offset_to_uv(lookup_offset(chain, border, filter, query));
    [s[0] + d[0], s[1] + d[1]]
}

/// The texture coordinate of texel (x, y)'s centre on a W × H image (OBJ convention, row 0 at
/// the top): ((x + ½)/W, 1 − (y + ½)/H).
pub fn texel_centre_uv(x: usize, y: usize, width: usize, height: usize) -> [f64; 2] {
    [
        (x as f64 + 0.5) / width as f64,
        1.0 - (y as f64 + 0.5) / height as f64,
    ]
}

/// Where the bake reads the colour for coordinate `uv`: [`recentre`]d uv + c(uv) in texture
/// coordinates, c the level-0 offset ([`sample_chain_level`]).
pub fn bake_coordinate(level: &OffsetLevel, border: Border, uv: [f64; 2]) -> [f64; 2] {
    let s = recentre(uv, border);
    let d = offset_to_uv(sample_chain_level(level, border, uv));
    [s[0] + d[0], s[1] + d[1]]
}

/// The pre-warped colour of texel (x, y) of `color`, before rounding to 8 bits (0–255 per
/// channel): C'(u) = C([`bake_coordinate`]), u the texel's centre ([`texel_centre_uv`]), C
/// sampled bilinearly with wrapping ([`sample_bilinear`]).
pub fn bake_colour(
    color: &Image<Rgba8>,
    level: &OffsetLevel,
    border: Border,
    x: usize,
    y: usize,
) -> [f64; 4] {
    let uv = texel_centre_uv(x, y, color.width, color.height);
    sample_bilinear(color, bake_coordinate(level, border, uv))
}

/// An 8-bit channel value: round half away from zero, clamped to 0–255.
pub fn to_rgba8(c: [f64; 4]) -> Rgba8 {
    c.map(|v| v.round().clamp(0.0, 255.0) as u8)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn level(width: usize, height: usize, f: impl Fn(usize, usize) -> [f64; 2]) -> OffsetLevel {
        OffsetLevel {
            width,
            height,
            offsets: (0..height)
                .flat_map(|y| (0..width).map(move |x| (x, y)))
                .map(|(x, y)| f(x, y))
                .collect(),
        }
    }

    #[test]
    fn the_level_of_detail_is_log2_of_the_longer_footprint_and_0_when_magnified() {
        let f = |dx: [f64; 2], dy: [f64; 2]| level_of_detail(&Footprint { dx, dy });
        assert_eq!(f([4.0, 0.0], [0.0, 1.0]), 2.0);
        assert_eq!(f([3.0, 4.0], [0.0, 2.0]), 5f64.log2());
        assert_eq!(f([0.5, 0.0], [0.0, 0.25]), 0.0);
        assert_eq!(f([0.0; 2], [0.0; 2]), 0.0);
    }

    #[test]
    fn trilinear_blends_neighbouring_levels_and_nearest_rounds() {
        let c = |l, f| choose_levels(l, 4, f);
        let linear = MipmapFilter::Linear;
        assert_eq!(
            c(1.25, linear),
            MipChoice {
                fine: 1,
                coarse: 2,
                weight: 0.25
            }
        );
        // Clamped to the coarsest level, and to level 0 below it.
        assert_eq!(
            c(7.0, linear),
            MipChoice {
                fine: 3,
                coarse: 3,
                weight: 0.0
            }
        );
        assert_eq!(c(-2.0, linear).fine, 0);
        assert_eq!(c(1.49, MipmapFilter::Nearest).fine, 1);
        assert_eq!(c(1.5, MipmapFilter::Nearest).fine, 2);
        assert_eq!(c(3.9, MipmapFilter::Nearest).fine, 3);
    }

    #[test]
    fn a_level_sampled_at_a_texel_centre_is_that_texel_and_wraps_or_clamps_past_the_edge() {
        let l = level(4, 2, |x, y| [x as f64, 10.0 * y as f64]);
        let centre = texel_centre_uv(2, 1, 4, 2);
        assert_eq!(
            sample_chain_level(&l, Border::Periodic, centre),
            [2.0, 10.0]
        );
        // Re-centring: the same point 1000 tiles away.
        let far = [centre[0] + 1000.0, centre[1] - 1000.0];
        assert_eq!(sample_chain_level(&l, Border::Periodic, far), [2.0, 10.0]);
        // Half-way between the last column and (wrapped) the first; clamped, the last.
        let edge = [1.0, centre[1]];
        assert_eq!(sample_chain_level(&l, Border::Periodic, edge), [1.5, 10.0]);
        assert_eq!(sample_chain_level(&l, Border::Fixed, edge), [3.0, 10.0]);
        assert_eq!(
            sample_chain_level(&l, Border::Fixed, [-3.0, 7.0]),
            [0.0, 0.0]
        );
    }

    #[test]
    fn the_lookup_adds_the_offset_with_v_flipped_and_the_bake_of_zero_offsets_is_the_texture() {
        let chain = super::offset_mip_chain(4, 4, &vec![[0.01, 0.02]; 16]);
        let q = Query {
            uv: [3.25, 0.5],
            footprint: Footprint {
                dx: [3.0, 0.0],
                dy: [0.0, 1.0],
            },
        };
        let c = lookup_coordinate(&chain, Border::Periodic, MipmapFilter::Linear, &q);
        assert!(
            (c[0] - 0.26).abs() < 1e-15 && (c[1] - 0.48).abs() < 1e-15,
            "{c:?}"
        );
        let texture = crate::texture::uv_grid_texture(16);
        let zero = level(4, 4, |_, _| [0.0; 2]);
        for (x, y) in [(0, 0), (5, 9), (15, 15)] {
            let baked = to_rgba8(bake_colour(&texture, &zero, Border::Periodic, x, y));
            assert_eq!(baked, texture.get(x, y));
        }
    }

    #[test]
    fn queries_that_are_not_finite_or_too_far_are_refused_by_index() {
        let good = Query::default();
        let far = Query {
            uv: [0.0, -5e6],
            ..good
        };
        let nan = Query {
            footprint: Footprint {
                dx: [f64::NAN, 0.0],
                dy: [0.0; 2],
            },
            ..good
        };
        assert!(check_queries("q", &[good, good]).is_ok());
        let e = check_queries("q", &[good, far]).unwrap_err().to_string();
        assert!(e.contains("query 1"), "{e}");
        let e = check_queries("q", &[nan]).unwrap_err().to_string();
        assert!(e.contains("query 0") && e.contains("non-finite"), "{e}");
    }
}
