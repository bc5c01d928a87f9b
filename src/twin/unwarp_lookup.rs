//! Twin of `gpu/shaders/unwarp_lookup.wgsl`, function for function: applying an unwarp
//! correction (seed 001, "two variants to apply this correction"; notes `unwarp.md`
//! § Application). The f64 reference is [`crate::unwarp::apply`], name for name and in the same
//! order of operations.
//!
//! - `main`, one invocation per query ([`lookup_invocation`]): the level of detail λ of the
//!   footprint ([`level_of_detail`]), the levels and blend weight ([`choose_levels`]), the
//!   offset bilinear on each level at the re-centred query ([`sample_level`]), blended
//!   ([`lookup_offset`]), and the lookup coordinate s + (o.x, −o.y) ([`lookup_coordinate`]);
//! - `bake`, one invocation per texel of the colour texture ([`bake_invocation`]): the texel's
//!   centre ([`texel_centre_uv`]), its coordinate through the level-0 offsets
//!   ([`bake_coordinate`]) and the colour there, bilinear and wrapping ([`sample_colour`]),
//!   before rounding to 8 bits.
//!
//! Integers (texel indices, level numbers) are taken from the f32 values exactly as the WGSL's
//! `i32(floor(x))` takes them.

use super::real::{floor, max, min, sqrt, Real, V2, V4};

/// `mode[0]`: 1 when the offset map is periodic (wrap), 0 at a fixed border (clamp).
pub const MODE_PERIODIC: usize = 0;
/// `mode[1]`: 1 for trilinear level selection, 0 for the nearest level.
pub const MODE_MIPMAP_LINEAR: usize = 1;

/// The `mode` binding: the sampler state of the offset chain.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mode {
    pub periodic: bool,
    pub mipmap_linear: bool,
}

/// One row of the `levels` binding: a level's size and the index of its first texel in
/// `offsets` (levels concatenated, level 0 first, each row-major, top row first).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub first: u32,
}

/// The bindings both entry points read: `mode`, `levels` and `offsets` (solver offsets, UV
/// units, node convention).
#[derive(Clone, Copy, Debug)]
pub struct Bindings<'a, R> {
    pub mode: Mode,
    pub levels: &'a [Level],
    pub offsets: &'a [V2<R>],
}

/// One row of `queries`: the coordinate (OBJ convention) and the footprint ∂u/∂x, ∂u/∂y in
/// texels of level 0.
#[derive(Clone, Copy, Debug)]
pub struct Query<R> {
    pub uv: V2<R>,
    pub dx: V2<R>,
    pub dy: V2<R>,
}

/// `level_of_detail`: ρ = max(√(dx.x² + dx.y²), √(dy.x² + dy.y²)); λ = log₂ ρ if ρ > 1, else 0.
pub fn level_of_detail<R: Real>(dx: V2<R>, dy: V2<R>) -> R {
    let rho = max(
        sqrt(dx.x * dx.x + dx.y * dx.y),
        sqrt(dy.x * dy.x + dy.y * dy.y),
    );
    if rho.value() > 1.0 {
        rho.log2()
    } else {
        R::lit(0.0)
    }
}

/// `MipChoice`: the two levels blended and the weight of `coarse`.
#[derive(Clone, Copy, Debug)]
pub struct MipChoice<R> {
    pub fine: u32,
    pub coarse: u32,
    pub weight: R,
}

/// `choose_levels`: λ_c = min(max(λ, 0), L − 1); trilinear: fine = ⌊λ_c⌋, coarse =
/// min(fine + 1, L − 1), weight λ_c − fine; nearest: fine = coarse = min(⌊λ_c + ½⌋, L − 1),
/// weight 0.
pub fn choose_levels<R: Real>(lambda: R, level_count: u32, mipmap_linear: bool) -> MipChoice<R> {
    let top = R::lit(f64::from(level_count.saturating_sub(1)));
    let clamped = min(max(lambda, R::lit(0.0)), top);
    if mipmap_linear {
        let fine = floor(clamped);
        return MipChoice {
            fine: fine.value() as u32,
            coarse: min(fine + R::lit(1.0), top).value() as u32,
            weight: clamped - fine,
        };
    }
    let level = min(floor(clamped + R::lit(0.5)), top).value() as u32;
    MipChoice {
        fine: level,
        coarse: level,
        weight: R::lit(0.0),
    }
}

/// `recentre`: uv − floor(uv) for a periodic map, uv at a fixed border.
pub fn recentre<R: Real>(uv: V2<R>, periodic: bool) -> V2<R> {
    if periodic {
        V2::new(uv.x - floor(uv.x), uv.y - floor(uv.y))
    } else {
        uv
    }
}

/// `texel_point`: (u W − ½, (1 − v) H − ½).
pub fn texel_point<R: Real>(uv: V2<R>, width: u32, height: u32) -> V2<R> {
    let half = R::lit(0.5);
    V2::new(
        uv.x * R::lit(f64::from(width)) - half,
        (R::lit(1.0) - uv.y) * R::lit(f64::from(height)) - half,
    )
}

/// `texel_pair`: the texels i = ⌊t⌋ and i + 1 and the fraction t − ⌊t⌋, wrapped mod n, or
/// clamped to [0, n − 1] with fraction 0 outside [0, n − 1].
pub fn texel_pair<R: Real>(t: R, n: u32, periodic: bool) -> (u32, u32, R) {
    let f = floor(t);
    let i = f.value() as i64;
    let n = i64::from(n);
    if periodic {
        return (i.rem_euclid(n) as u32, (i + 1).rem_euclid(n) as u32, t - f);
    }
    let last = n - 1;
    let frac = if i < 0 || i >= last {
        R::lit(0.0)
    } else {
        t - f
    };
    (i.clamp(0, last) as u32, (i + 1).clamp(0, last) as u32, frac)
}

/// `sample_level`: level `level`'s offset at `uv`, bilinear between texel centres at the
/// [`texel_point`] of the [`recentre`]d uv: top = o₀₀(1 − f_x) + o₁₀ f_x, bottom likewise,
/// top (1 − f_y) + bottom f_y.
pub fn sample_level<R: Real>(b: &Bindings<R>, level: u32, uv: V2<R>) -> V2<R> {
    let l = b.levels[level as usize];
    let periodic = b.mode.periodic;
    let p = texel_point(recentre(uv, periodic), l.width, l.height);
    let (x0, x1, fx) = texel_pair(p.x, l.width, periodic);
    let (y0, y1, fy) = texel_pair(p.y, l.height, periodic);
    let at = |x: u32, y: u32| b.offsets[(l.first + y * l.width + x) as usize];
    let one = R::lit(1.0);
    let top = at(x0, y0) * (one - fx) + at(x1, y0) * fx;
    let bottom = at(x0, y1) * (one - fx) + at(x1, y1) * fx;
    top * (one - fy) + bottom * fy
}

/// `lookup_offset`: the query's levels ([`choose_levels`] of [`level_of_detail`]), each
/// sampled at uv, blended fine (1 − w) + coarse w.
pub fn lookup_offset<R: Real>(b: &Bindings<R>, q: &Query<R>) -> V2<R> {
    let lambda = level_of_detail(q.dx, q.dy);
    let choice = choose_levels(lambda, b.levels.len() as u32, b.mode.mipmap_linear);
    let fine = sample_level(b, choice.fine, q.uv);
    let coarse = sample_level(b, choice.coarse, q.uv);
    let w = choice.weight;
    fine * (R::lit(1.0) - w) + coarse * w
}

/// `offset_to_uv`: (o.x, −o.y).
pub fn offset_to_uv<R: Real>(o: V2<R>) -> V2<R> {
    V2::new(o.x, -o.y)
}

/// `lookup_coordinate`: recentre(uv) + offset_to_uv(lookup_offset).
pub fn lookup_coordinate<R: Real>(b: &Bindings<R>, q: &Query<R>) -> V2<R> {
    recentre(q.uv, b.mode.periodic) + offset_to_uv(lookup_offset(b, q))
}

/// One invocation of `main`: query `index`'s lookup coordinate.
pub fn lookup_invocation<R: Real>(b: &Bindings<R>, queries: &[Query<R>], index: usize) -> V2<R> {
    lookup_coordinate(b, &queries[index])
}

/// `texel_centre_uv`: ((x + ½)/W, 1 − (y + ½)/H).
pub fn texel_centre_uv<R: Real>(x: u32, y: u32, width: u32, height: u32) -> V2<R> {
    let half = R::lit(0.5);
    V2::new(
        (R::lit(f64::from(x)) + half) / R::lit(f64::from(width)),
        R::lit(1.0) - (R::lit(f64::from(y)) + half) / R::lit(f64::from(height)),
    )
}

/// `bake_coordinate`: recentre(uv) + offset_to_uv(level 0's offset at uv).
pub fn bake_coordinate<R: Real>(b: &Bindings<R>, uv: V2<R>) -> V2<R> {
    recentre(uv, b.mode.periodic) + offset_to_uv(sample_level(b, 0, uv))
}

/// `texel_coordinates` (the reference's `texture::texel_coordinates`): s = u − ⌊u⌋,
/// t = 1 − (v − ⌊v⌋), (s W − ½, t H − ½).
pub fn texel_coordinates<R: Real>(uv: V2<R>, width: u32, height: u32) -> V2<R> {
    let half = R::lit(0.5);
    let s = uv.x - floor(uv.x);
    let t = R::lit(1.0) - (uv.y - floor(uv.y));
    V2::new(
        s * R::lit(f64::from(width)) - half,
        t * R::lit(f64::from(height)) - half,
    )
}

/// `texel_and_fraction`: (⌊x⌋ mod size, x − ⌊x⌋); texel 0, fraction 0 for a non-finite x.
pub fn texel_and_fraction<R: Real>(x: R, size: u32) -> (u32, R) {
    if !super::real::is_finite(x) {
        return (0, R::lit(0.0));
    }
    let f = floor(x);
    ((f.value() as i64).rem_euclid(i64::from(size)) as u32, x - f)
}

/// `texel_colour`: the 8-bit channels of a packed texel (R in the low byte), as f32 (exact).
pub fn texel_colour<R: Real>(packed: u32) -> V4<R> {
    let c = |k: u32| R::lit(f64::from((packed >> (8 * k)) & 0xff));
    V4::new(c(0), c(1), c(2), c(3))
}

/// `sample_colour` (the reference's `texture::sample_bilinear`): weights (1 − f_x)(1 − f_y),
/// f_x (1 − f_y), (1 − f_x) f_y, f_x f_y of the texels (x₀, y₀), (x₁, y₀), (x₀, y₁), (x₁, y₁),
/// x₁ = (x₀ + 1) mod W, y₁ = (y₀ + 1) mod H; the sum of the weighted texels in that order.
pub fn sample_colour<R: Real>(colour: &[u32], width: u32, height: u32, uv: V2<R>) -> V4<R> {
    let p = texel_coordinates(uv, width, height);
    let (x0, fx) = texel_and_fraction(p.x, width);
    let (y0, fy) = texel_and_fraction(p.y, height);
    let (x1, y1) = ((x0 + 1) % width, (y0 + 1) % height);
    let one = R::lit(1.0);
    let texel = |x: u32, y: u32| texel_colour::<R>(colour[(y * width + x) as usize]);
    let corners = [
        (texel(x0, y0), (one - fx) * (one - fy)),
        (texel(x1, y0), fx * (one - fy)),
        (texel(x0, y1), (one - fx) * fy),
        (texel(x1, y1), fx * fy),
    ];
    let terms: Vec<V4<R>> = corners.iter().map(|&(c, w)| c * w).collect();
    V4::sum(&terms)
}

/// One invocation of `bake`: texel `index` = y·W + x of the W × H colour texture, its
/// pre-warped colour C(bake_coordinate(texel centre)) before rounding (0–255 per channel).
pub fn bake_invocation<R: Real>(
    b: &Bindings<R>,
    colour: &[u32],
    width: u32,
    height: u32,
    index: usize,
) -> V4<R> {
    let (x, y) = (index as u32 % width, index as u32 / width);
    let uv = texel_centre_uv(x, y, width, height);
    sample_colour(colour, width, height, bake_coordinate(b, uv))
}
