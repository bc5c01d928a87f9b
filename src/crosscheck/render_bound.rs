//! The bound of `bpm_render` against `render_cpu`, per pixel and colour channel: written once
//! here, used by `crosscheck bpm`'s render row and by the tests.
//!
//! A GPU render differs from the reference's by more than arithmetic: its fixed-function stages
//! (rasteriser, sampler, output conversion) have a precision the graphics APIs bound only from
//! below. The bound allows each stage the least precision Vulkan permits
//! ([`crate::twin::bpm_render`] models the same stages; `tests/twin_bpm_render.rs` draws with
//! them):
//!
//! 1. **Coverage.** The rasteriser snaps each projected corner to 2^−[`SUBPIXEL_BITS`] of a
//!    pixel (Vulkan `subPixelPrecisionBits` ≥ 4), after an f32 vertex stage that adds at most
//!    [`CLIP_ROUNDING_PX`]: every corner moves by at most e = 2⁻⁴ + 2⁻¹⁰ px per axis, so every
//!    edge by at most √2 e. A pixel is **contested**, and left unbounded, when some face's
//!    boundary passes within √2 e of its centre and that face is not hidden by more than the
//!    depth latitude δz, or when two faces cover it with depths within δz (δz: each face's
//!    depth slope × √2 e, plus [`DEPTH_ROUNDING`]). Elsewhere both renders draw the same face.
//! 2. **Where the face is sampled.** Moving the corners by at most e per axis moves the point of
//!    the face seen at the pixel centre by at most e per axis (the moved triangle's points are
//!    convex combinations of the moved corners), so the UV moves by at most
//!    δ_geom = 2 · (max± |uv(c ± e x̂) − uv(c)| + max± |uv(c ± e ŷ) − uv(c)|) per component,
//!    the factor 2 for the curvature of the projective map and of BPM's interpolant over e
//!    (as [`crate::twin::lin::SECOND_ORDER`]).
//! 3. **Arithmetic.** The GPU's maps (`bpm_precompute`) and UV (`bpm_eval`'s formula in the
//!    fragment stage) err by at most the pipeline bound
//!    ([`super::bpm_bound::pipeline_bounds_for`]), taken per face (twice its largest value at
//!    the face's cross-check samples: `face_pipeline_bounds` says why).
//! 4. **Filtering.** The sampler's weights have 2^−[`SUBTEXEL_BITS`] resolution (Vulkan
//!    `subTexelPrecisionBits` ≥ 4): another q = 2⁻⁴ texel per axis. With r = (δ_geom +
//!    δ_arith) · size + q texels per axis, the bilinear texture changes by at most
//!    Lx r_x + Ly r_y, L the largest difference of adjacent texels (per channel, along each
//!    axis) in the footprint of the box ±r around the reference's texel point.
//! 5. **Output.** The reference rounds to nearest (½ unit); a GPU's 8-bit conversion may round
//!    either way (1 unit): [`ROUNDING_UNITS`] = 1.5.
//!
//! Per channel: |c_gpu − c_ref| ≤ Lx r_x + Ly r_y + 1.5 for a covered, uncontested pixel; ≤ 1.5
//! for the background. The tightest term is where it matters: inside a texture cell (L = 0) the
//! bound is 1.5 units, so a UV off by a texel across any edge of the texture fails.

use num_complex::Complex64 as C;
use rayon::prelude::*;

use super::bpm_bound::{crosscheck_samples, pipeline_bounds_for, TEXTURE_SIZE, UNBOUNDED};
use crate::bpm::gpu::stars;
use crate::bpm::render::{camera_for, RenderOptions};
use crate::bpm::{Bpm, Fit};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::raster::{
    clip_positions, rasterize_clip, screen_triangles, FrameBuffer, ScreenTriangle,
};
use crate::texture::{texel_coordinates, Image, Rgba8};
use crate::twin::lin::SECOND_ORDER;

/// Sub-pixel bits of vertex snapping assumed: Vulkan's minimum `subPixelPrecisionBits`
/// (OpenGL's `SUBPIXEL_BITS` has the same minimum; D3D and most GPUs use 8).
pub const SUBPIXEL_BITS: u32 = 4;
/// Fraction bits of the bilinear weights assumed: Vulkan's minimum `subTexelPrecisionBits`.
pub const SUBTEXEL_BITS: u32 = 4;
/// What the f32 vertex stage adds to a projected corner (pixels): clip = view_proj · p is 4
/// products and 3 sums per coordinate, then a division by w and the viewport transform, each
/// rounded (2⁻²³ relative) on coordinates of at most a few thousand pixels: < 2⁻¹⁰.
pub const CLIP_ROUNDING_PX: f64 = 1.0 / 1024.0;
/// f32 depth interpolation and a 32-bit float depth buffer, on depths in [0, 1]: a few ULP of
/// 1, < 2⁻²⁰.
pub const DEPTH_ROUNDING: f64 = 1.0 / 1_048_576.0;
/// The reference's rounding to nearest (½) plus the GPU's 8-bit conversion either way (1).
pub const ROUNDING_UNITS: f64 = 1.5;

/// What the row says of its bound (one line for the table and the manifests).
pub const RENDER_BOUND_FORMULA: &str = "per pixel and channel: Lx·rx + Ly·ry + 1.5, r = UV \
    latitude of 4-bit sub-pixel snapping + the pipeline bound + 4-bit filter weights; contested \
    coverage unbounded (crosscheck::render_bound)";

/// The largest move of a projected corner, per axis (pixels).
pub fn corner_latitude() -> f64 {
    (-(SUBPIXEL_BITS as f64)).exp2() + CLIP_ROUNDING_PX
}

/// Per pixel and RGB channel (3 per pixel, row-major), the bound of `bpm_render`'s colour
/// against [`crate::bpm::render::render_cpu`]'s, in units of 1/255; [`UNBOUNDED`] where the
/// coverage is contested.
#[derive(Clone, Debug)]
pub struct RenderBound {
    pub bounds: Vec<f64>,
    /// Pixels whose coverage is contested (unbounded).
    pub contested: usize,
    /// Covered pixels whose pipeline bound is unbounded (a pole or a branch within rounding).
    pub unbounded_uv: usize,
}

impl RenderBound {
    /// Elements of `errors` ([`channel_errors`]) over their bound (a NaN counts as over), and
    /// the worst error / bound.
    pub fn judge(&self, errors: &[f64]) -> (usize, f64) {
        errors
            .iter()
            .zip(&self.bounds)
            .fold((0, 0.0f64), |(over, worst), (&e, &b)| {
                let within = e <= b;
                (over + usize::from(!within), worst.max(e / b))
            })
    }
}

/// The bound (module docs) for `mesh` (as the GPU receives it: f32 positions and UVs) drawn
/// with `reference`'s maps (local fit), `texture` and `options`.
pub fn render_bound(
    mesh: &TriMesh,
    reference: &Bpm,
    texture: &Image<Rgba8>,
    options: &RenderOptions,
) -> Result<RenderBound> {
    if reference.options.fit != Fit::Local {
        return Err(Error::InvalidArgument(format!(
            "{}: the render bound covers the local fit (the one `bpm_precompute`'s pipeline \
             bound covers), not {:?}",
            mesh.name, reference.options.fit
        )));
    }
    let (width, height) = (options.width as usize, options.height as usize);
    let clip = clip_positions(mesh, &camera_for(mesh, options).view_proj());
    let frame = rasterize_clip(mesh, &clip, width, height, |p| p);
    let edge_margin = std::f64::consts::SQRT_2 * corner_latitude();
    let triangles = screen_triangles(mesh, &clip, width, height, edge_margin);
    let contested = contested_pixels(&frame, &triangles, edge_margin);

    let mut by_face: Vec<Option<usize>> = vec![None; mesh.face_count()];
    for (t, tri) in triangles.iter().enumerate() {
        by_face[tri.face() as usize] = Some(t);
    }
    let judged: Vec<usize> = (0..width * height)
        .filter(|&i| !contested[i] && frame.fragments[i].is_some())
        .collect();
    let interp = options.interp;
    let arithmetic = face_pipeline_bounds(mesh, reference, interp)?;
    let mut bounds = vec![ROUNDING_UNITS; 3 * width * height];
    for (i, _) in contested.iter().enumerate().filter(|(_, &c)| c) {
        bounds[3 * i..3 * i + 3].fill(UNBOUNDED);
    }
    let per_pixel: Vec<[f64; 3]> = judged
        .par_iter()
        .map(|&i| {
            let Some(fragment) = frame.fragments[i] else {
                return [UNBOUNDED; 3];
            };
            let face = fragment.face as usize;
            let (Some(t), arith) = (by_face[face], arithmetic[face]) else {
                return [UNBOUNDED; 3];
            };
            if arith == UNBOUNDED {
                return [UNBOUNDED; 3];
            }
            let centre = [(i % width) as f64 + 0.5, (i / width) as f64 + 0.5];
            let uv = reference.eval(face, fragment.bary, interp);
            let geometric = uv_latitude(reference, &triangles[t], centre, uv, interp);
            let a = arith / TEXTURE_SIZE;
            let texels = [
                (geometric[0] + a) * texture.width as f64,
                (geometric[1] + a) * texture.height as f64,
            ];
            colour_latitude(texture, [uv.re, uv.im], texels)
        })
        .collect();
    let mut unbounded_uv = 0;
    for (&i, b) in judged.iter().zip(&per_pixel) {
        unbounded_uv += usize::from(b[0] == UNBOUNDED);
        bounds[3 * i..3 * i + 3].copy_from_slice(b);
    }
    Ok(RenderBound {
        bounds,
        contested: contested.iter().filter(|&&c| c).count(),
        unbounded_uv,
    })
}

/// Per face, the arithmetic term (module docs, 3), texels of [`TEXTURE_SIZE`]: twice the
/// largest pipeline bound at the face's cross-check samples (its corners and 8 interior
/// points), [`UNBOUNDED`] if any is. The bound is a smooth function of the barycentrics (the
/// first-order sensitivities of a smooth interpolant), so its maximum over the face is within
/// a small factor of its maximum over these points; and it is ~10⁻³ of the 2⁻⁴ texel the
/// filter weights alone add, so even a factor 10 more would move r by under 1 %. Bounding
/// every pixel instead costs a reverse sweep of the face's whole tape per pixel (45 s for
/// `crosscheck bpm`'s eight meshes here, against 6 s).
fn face_pipeline_bounds(
    mesh: &TriMesh,
    reference: &Bpm,
    interp: crate::bpm::Interp,
) -> Result<Vec<f64>> {
    let samples = crosscheck_samples(mesh.face_count());
    let expected: Vec<C> = samples
        .par_iter()
        .map(|s| reference.eval(s.face as usize, s.bary, interp))
        .collect();
    let bounds = pipeline_bounds_for(&stars(mesh)?, &samples, interp, &expected);
    let mut per_face = vec![0.0f64; mesh.face_count()];
    for (s, b) in samples.iter().zip(bounds) {
        let slot = &mut per_face[s.face as usize];
        *slot = if b == UNBOUNDED || *slot == UNBOUNDED {
            UNBOUNDED
        } else {
            slot.max(2.0 * b)
        };
    }
    Ok(per_face)
}

/// Per pixel: is its coverage contested (module docs, 1)? A face `t` whose boundary lies
/// within `margin` of the centre, or that covers it without being the reference's face, is a
/// contender when its depth there is within δz of the reference's (or nothing was drawn there).
/// Sequential over the faces: the mask does not depend on the thread count.
fn contested_pixels(frame: &FrameBuffer, triangles: &[ScreenTriangle], margin: f64) -> Vec<bool> {
    let width = frame.width;
    let faces = triangles
        .iter()
        .map(|t| t.face() as usize + 1)
        .max()
        .unwrap_or(0);
    let mut slope_of = vec![f64::INFINITY; faces];
    for t in triangles {
        slope_of[t.face() as usize] = t.depth_slope();
    }
    let winner_slope: Vec<f64> = frame
        .fragments
        .iter()
        .map(|f| {
            f.map_or(0.0, |f| {
                slope_of
                    .get(f.face as usize)
                    .copied()
                    .unwrap_or(f64::INFINITY)
            })
        })
        .collect();
    let mut contested = vec![false; frame.fragments.len()];
    for tri in triangles {
        let ((x0, x1), (y0, y1)) = tri.pixel_box();
        let own_slope = tri.depth_slope();
        for y in y0..=y1 {
            for x in x0..=x1 {
                let centre = [x as f64 + 0.5, y as f64 + 0.5];
                let distance = tri.signed_distance(centre);
                if distance < -margin {
                    continue;
                }
                let i = y * width + x;
                let winner = frame.fragments[i].map(|f| f.face);
                let near_edge = distance <= margin;
                if !near_edge && winner == Some(tri.face()) {
                    continue;
                }
                let dz = margin * (own_slope + winner_slope[i]) + DEPTH_ROUNDING;
                if tri.depth_at(centre) <= frame.depth[i] + dz {
                    contested[i] = true;
                }
            }
        }
    }
    contested
}

/// Per UV component, how far the UV seen at `centre` moves when the corners move by up to
/// [`corner_latitude`] per axis (module docs, 2).
fn uv_latitude(
    reference: &Bpm,
    tri: &ScreenTriangle,
    centre: [f64; 2],
    uv: C,
    interp: crate::bpm::Interp,
) -> [f64; 2] {
    let e = corner_latitude();
    let moved = |dx: f64, dy: f64| {
        let b = tri.barycentrics_at([centre[0] + dx, centre[1] + dy]);
        reference.eval(tri.face() as usize, b, interp) - uv
    };
    let along =
        |d: [C; 2]| [0, 1].map(|k| d.iter().map(|z| [z.re, z.im][k].abs()).fold(0.0, f64::max));
    let x = along([moved(e, 0.0), moved(-e, 0.0)]);
    let y = along([moved(0.0, e), moved(0.0, -e)]);
    [0, 1].map(|k| SECOND_ORDER * (x[k] + y[k]))
}

/// Largest footprint (texels per axis) worth scanning; beyond it a channel may take any value.
const MAX_FOOTPRINT: f64 = 64.0;

/// Per RGB channel, `Lx rx + Ly ry + 1.5` (module docs, 4 and 5), with `r` = `texels` + q.
fn colour_latitude(texture: &Image<Rgba8>, uv: [f64; 2], texels: [f64; 2]) -> [f64; 3] {
    let q = (-(SUBTEXEL_BITS as f64)).exp2();
    let r = texels.map(|t| t + q);
    if !(r[0] <= MAX_FOOTPRINT && r[1] <= MAX_FOOTPRINT) {
        return [255.0; 3];
    }
    let [x, y] = texel_coordinates(texture, uv);
    let (xs, ys) = (
        ((x - r[0]).floor() as i64, (x + r[0]).floor() as i64),
        ((y - r[1]).floor() as i64, (y + r[1]).floor() as i64),
    );
    let at = |i: i64, j: i64| {
        let w = texture.width as i64;
        let h = texture.height as i64;
        texture.get(i.rem_euclid(w) as usize, j.rem_euclid(h) as usize)
    };
    let mut lx = [0u8; 3];
    let mut ly = [0u8; 3];
    for j in ys.0..=ys.1 + 1 {
        for i in xs.0..=xs.1 + 1 {
            let (here, right, below) = (at(i, j), at(i + 1, j), at(i, j + 1));
            for c in 0..3 {
                if i <= xs.1 {
                    lx[c] = lx[c].max(here[c].abs_diff(right[c]));
                }
                if j <= ys.1 {
                    ly[c] = ly[c].max(here[c].abs_diff(below[c]));
                }
            }
        }
    }
    [0, 1, 2].map(|c| lx[c] as f64 * r[0] + ly[c] as f64 * r[1] + ROUNDING_UNITS)
}

/// Per pixel and RGB channel, |a − b| (3 per pixel, row-major): the errors the bound judges.
pub fn channel_errors(a: &Image<Rgba8>, b: &Image<Rgba8>) -> Result<Vec<f64>> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::InvalidArgument(format!(
            "cannot compare a {}x{} image with a {}x{} image",
            a.width, a.height, b.width, b.height
        )));
    }
    Ok(a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| [0, 1, 2].map(|c| p[c].abs_diff(q[c]) as f64))
        .collect())
}
