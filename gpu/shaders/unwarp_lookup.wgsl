// unwarp_lookup: applying a distortion-free displacement correction (seed 001, "two variants to
// apply this correction"), in two entry points. Prepended by the host: dispatch.wgsl.
//
// Twin of the plain f64 path src/unwarp/apply.rs, name for name and in the same order of
// operations: level_of_detail, choose_levels, recentre, texel_point, texel_pair, sample_level,
// lookup_offset, offset_to_uv, lookup_coordinate; texel_centre_uv, bake_coordinate, and
// texel_coordinates, texel_and_fraction, sample_colour (src/texture.rs: sample_bilinear).
//
// 1. `main`, one invocation per query (the render-time lookup of a modified renderer): the
//    coordinate s + (o.x, −o.y), s the query's uv re-centred into its tile (periodic map), o the
//    offset chain sampled at the level(s) of the query's footprint (trilinear or nearest level),
//    bilinear on each level between texel centres, wrapping or clamped.
// 2. `bake`, one invocation per texel of the colour texture (the backward-compatible pre-warped
//    texture C'(u) = C(u + c(u))): the colour at the texel centre's coordinate through the
//    level-0 offsets, bilinear and wrapping, before rounding to 8 bits (0–255 per channel).
//    Its second entry point is named `bake`; a port of the bake on its own names it `main`.
//
// Bindings (docs/abi: one storage array per manifest input, in the manifest's order):
//   0 params; 1 mode (u32: periodic, mipmap linear); 2 levels (u32, 3 per level: width, height,
//   first texel in `offsets`); 3 offsets (vec2<f32> per texel, every level, level 0 first,
//   row-major, top row first, the solver's node convention o.y down);
//   main: 4 queries (6 f32: u, v, ∂u/∂x, ∂v/∂x, ∂u/∂y, ∂v/∂y, the derivatives in texels of
//   level 0), 5 lookups (vec2<f32>); bake: 4 colour (u32 per texel, R in the low byte,
//   row-major, top row first), 5 baked (vec4<f32> per texel).
//
// Where the kernel differs from the plain path, for the GPU's sake and not in the formula:
// - texel indices: the reference converts ⌊t⌋ to a 64-bit integer; WGSL's i32(f32) saturates and
//   i + 1 could wrap, so ⌊t⌋ is first clamped to [−1, n] (no index the reference uses changes:
//   a fixed border clamps indices to [0, n − 1] anyway, and a re-centred t lies in [−½, n − ½]);
// - the offsets are filtered in arithmetic, not by a hardware sampler: a sampler's fixed-point
//   filter weights and level of detail (Vulkan subTexelPrecisionBits, mipLodPrecisionBits, as
//   few as 4 bits) are outside the WGSL accuracy table, so a renderer that samples the chain with
//   textureSampleGrad adds their error to what this kernel's bound allows;
// - the chain is an input: the host builds it in f64 (offset_mip_chain) and uploads it rounded
//   to f32, as the offsets_mip*.exr files hold it;
// - the colour arrives packed (4 × 8 bits per u32), unpacked by shifts (exact).

struct LookupParams {
    count: u32,          // queries (main) or colour texels (bake)
    level_count: u32,    // rows of `levels`
    colour_width: u32,   // bake: the colour texture's size (main: 0)
    colour_height: u32,
}

struct Query {
    uv: vec2<f32>,
    dx: vec2<f32>,
    dy: vec2<f32>,
}

@group(0) @binding(0) var<uniform> params: LookupParams;
@group(0) @binding(1) var<storage, read> mode: array<u32>;
@group(0) @binding(2) var<storage, read> levels: array<u32>;
@group(0) @binding(3) var<storage, read> offsets: array<vec2<f32>>;
// main
@group(0) @binding(4) var<storage, read> queries: array<Query>;
@group(0) @binding(5) var<storage, read_write> lookups: array<vec2<f32>>;
// bake
@group(0) @binding(4) var<storage, read> colour: array<u32>;
@group(0) @binding(5) var<storage, read_write> baked: array<vec4<f32>>;

fn periodic() -> bool {
    return mode[0] == 1u;
}

fn mipmap_linear() -> bool {
    return mode[1] == 1u;
}

// ρ = max(√(dx.x² + dx.y²), √(dy.x² + dy.y²)); λ = log₂ ρ if ρ > 1, else 0.
fn level_of_detail(dx: vec2<f32>, dy: vec2<f32>) -> f32 {
    let rho = max(sqrt(dx.x * dx.x + dx.y * dx.y), sqrt(dy.x * dy.x + dy.y * dy.y));
    if (rho > 1.0) {
        return log2(rho);
    }
    return 0.0;
}

struct MipChoice {
    fine: u32,
    coarse: u32,
    weight: f32,
}

// λ_c = min(max(λ, 0), L − 1); trilinear: ⌊λ_c⌋, min(⌊λ_c⌋ + 1, L − 1), λ_c − ⌊λ_c⌋;
// nearest: min(⌊λ_c + ½⌋, L − 1) twice, weight 0.
fn choose_levels(lambda: f32, level_count: u32, linear: bool) -> MipChoice {
    let top = f32(level_count - 1u);
    let clamped = min(max(lambda, 0.0), top);
    if (linear) {
        let fine = floor(clamped);
        return MipChoice(u32(fine), u32(min(fine + 1.0, top)), clamped - fine);
    }
    let level = u32(min(floor(clamped + 0.5), top));
    return MipChoice(level, level, 0.0);
}

// uv − floor(uv) for a periodic map, uv at a fixed border.
fn recentre(uv: vec2<f32>, wrap: bool) -> vec2<f32> {
    if (wrap) {
        return vec2<f32>(uv.x - floor(uv.x), uv.y - floor(uv.y));
    }
    return uv;
}

// (u W − ½, (1 − v) H − ½).
fn texel_point(uv: vec2<f32>, width: u32, height: u32) -> vec2<f32> {
    return vec2<f32>(uv.x * f32(width) - 0.5, (1.0 - uv.y) * f32(height) - 0.5);
}

struct TexelPair {
    i0: u32,
    i1: u32,
    frac: f32,
}

// i = ⌊t⌋ and i + 1 with the fraction t − ⌊t⌋: wrapped mod n, or clamped to [0, n − 1] with
// fraction 0 outside [0, n − 1].
fn texel_pair(t: f32, count: u32, wrap: bool) -> TexelPair {
    let f = floor(t);
    let n = i32(count);
    let i = i32(clamp(f, -1.0, f32(count)));
    if (wrap) {
        return TexelPair(u32(((i % n) + n) % n), u32(((i + 1) % n + n) % n), t - f);
    }
    let last = n - 1;
    var frac = t - f;
    if (i < 0 || i >= last) {
        frac = 0.0;
    }
    return TexelPair(u32(clamp(i, 0, last)), u32(clamp(i + 1, 0, last)), frac);
}

// Level `level`'s offset at uv, bilinear between texel centres.
fn sample_level(level: u32, uv: vec2<f32>) -> vec2<f32> {
    let width = levels[3u * level];
    let height = levels[3u * level + 1u];
    let first = levels[3u * level + 2u];
    let wrap = periodic();
    let p = texel_point(recentre(uv, wrap), width, height);
    let x = texel_pair(p.x, width, wrap);
    let y = texel_pair(p.y, height, wrap);
    let o00 = offsets[first + y.i0 * width + x.i0];
    let o10 = offsets[first + y.i0 * width + x.i1];
    let o01 = offsets[first + y.i1 * width + x.i0];
    let o11 = offsets[first + y.i1 * width + x.i1];
    let top = o00 * (1.0 - x.frac) + o10 * x.frac;
    let bottom = o01 * (1.0 - x.frac) + o11 * x.frac;
    return top * (1.0 - y.frac) + bottom * y.frac;
}

// The query's levels, each sampled at uv, blended fine (1 − w) + coarse w.
fn lookup_offset(q: Query) -> vec2<f32> {
    let lambda = level_of_detail(q.dx, q.dy);
    let choice = choose_levels(lambda, params.level_count, mipmap_linear());
    let fine = sample_level(choice.fine, q.uv);
    let coarse = sample_level(choice.coarse, q.uv);
    let w = choice.weight;
    return fine * (1.0 - w) + coarse * w;
}

// (o.x, −o.y): a solver offset in texture coordinates.
fn offset_to_uv(o: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(o.x, -o.y);
}

fn lookup_coordinate(q: Query) -> vec2<f32> {
    return recentre(q.uv, periodic()) + offset_to_uv(lookup_offset(q));
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if (index >= params.count) {
        return;
    }
    lookups[index] = lookup_coordinate(queries[index]);
}

// ((x + ½)/W, 1 − (y + ½)/H).
fn texel_centre_uv(x: u32, y: u32, width: u32, height: u32) -> vec2<f32> {
    return vec2<f32>((f32(x) + 0.5) / f32(width), 1.0 - (f32(y) + 0.5) / f32(height));
}

fn bake_coordinate(uv: vec2<f32>) -> vec2<f32> {
    return recentre(uv, periodic()) + offset_to_uv(sample_level(0u, uv));
}

// s = u − ⌊u⌋, t = 1 − (v − ⌊v⌋): (s W − ½, t H − ½).
fn texel_coordinates(uv: vec2<f32>, width: u32, height: u32) -> vec2<f32> {
    let s = uv.x - floor(uv.x);
    let t = 1.0 - (uv.y - floor(uv.y));
    return vec2<f32>(s * f32(width) - 0.5, t * f32(height) - 0.5);
}

struct TexelFraction {
    texel: u32,
    frac: f32,
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// (⌊x⌋ mod size, x − ⌊x⌋); texel 0, fraction 0 for a non-finite x.
fn texel_and_fraction(x: f32, size: u32) -> TexelFraction {
    if (!is_finite(x)) {
        return TexelFraction(0u, 0.0);
    }
    let f = floor(x);
    let n = i32(size);
    let i = i32(clamp(f, -1.0, f32(size)));
    return TexelFraction(u32(((i % n) + n) % n), x - f);
}

fn texel_colour(packed: u32) -> vec4<f32> {
    return vec4<f32>(
        f32(packed & 0xffu), f32((packed >> 8u) & 0xffu),
        f32((packed >> 16u) & 0xffu), f32((packed >> 24u) & 0xffu),
    );
}

// Bilinear with wrapping: weights (1 − f_x)(1 − f_y), f_x (1 − f_y), (1 − f_x) f_y, f_x f_y.
fn sample_colour(width: u32, height: u32, uv: vec2<f32>) -> vec4<f32> {
    let p = texel_coordinates(uv, width, height);
    let x = texel_and_fraction(p.x, width);
    let y = texel_and_fraction(p.y, height);
    let x1 = (x.texel + 1u) % width;
    let y1 = (y.texel + 1u) % height;
    let c00 = texel_colour(colour[y.texel * width + x.texel]);
    let c10 = texel_colour(colour[y.texel * width + x1]);
    let c01 = texel_colour(colour[y1 * width + x.texel]);
    let c11 = texel_colour(colour[y1 * width + x1]);
    return c00 * ((1.0 - x.frac) * (1.0 - y.frac)) + c10 * (x.frac * (1.0 - y.frac))
        + c01 * ((1.0 - x.frac) * y.frac) + c11 * (x.frac * y.frac);
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn bake(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if (index >= params.count) {
        return;
    }
    let width = params.colour_width;
    let height = params.colour_height;
    let uv = texel_centre_uv(index % width, index / width, width, height);
    baked[index] = sample_colour(width, height, bake_coordinate(uv));
}
