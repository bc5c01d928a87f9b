//! Twin of `gpu/shaders/bpm_render.wgsl`: the vertex stage (clip = view_proj · (p, 1)), the
//! fragment stage (the interpolated UV, then the texture at (u, 1 − v)), and a model of the
//! fixed-function stages between and after them, which WGSL's accuracy table does not cover
//! and a conforming GPU may do at lower precision than the reference:
//!
//! - **rasterisation**: the projected corners are snapped to a grid of 2^−`subpixel_bits`
//!   pixels before coverage and barycentrics are computed (Vulkan 1.3 §"Limits",
//!   `subPixelPrecisionBits` ≥ 4; OpenGL's `SUBPIXEL_BITS` ≥ 4; D3D11 and later: 8);
//! - **filtering**: the bilinear filter's two fractions are quantised to 2^−`subtexel_bits`
//!   (Vulkan `subTexelPrecisionBits` ≥ 4; D3D: 8);
//! - **output**: the filtered colour is converted to 8 bits, rounded to nearest or (the edge
//!   of what we allow) down.
//!
//! [`render_twin`] draws a picture with these stages under an arithmetic [`Model`]; the bound
//! it is judged by is [`crate::crosscheck::render_bound`]. `tests/twin_bpm_render.rs` runs it
//! at the spec's minimum precision and rejects the porting mistakes built from its pieces.

use nalgebra::Vector4;

use super::bpm_common::{eval, interp_code, Complex, TriangleMaps};
use super::real::{dot, sum, Real, V2, V3, V4};
use super::{with_model, Model, F};
use crate::bpm::render::{camera_for, RenderOptions};
use crate::mesh::TriMesh;
use crate::raster::{rasterize_clip, shade};
use crate::texture::{sample_bilinear_with, Image, Rgba8};

/// `bpm_render_vertex`: `clip = view_proj · (p, 1)`, `view_proj` column-major (16 values).
pub fn bpm_render_vertex<R: Real>(view_proj: &[R; 16], p: V3<R>) -> V4<R> {
    let row = |r: usize| {
        dot(
            [
                view_proj[r],
                view_proj[4 + r],
                view_proj[8 + r],
                view_proj[12 + r],
            ],
            [p.x, p.y, p.z, R::lit(1.0)],
        )
    };
    V4::new(row(0), row(1), row(2), row(3))
}

/// `bpm_render_fragment` up to the texture fetch: `uv = eval(maps[face], b, interp)`, and the
/// texture coordinate `(u, 1 − v)` it samples at. `None` for a face beyond `maps`.
pub fn bpm_render_fragment<R: Real>(
    maps: &[TriangleMaps<R>],
    face: u32,
    bary: V3<R>,
    interp: u32,
) -> Option<V2<R>> {
    let uv: Complex<R> = eval(maps.get(face as usize)?, bary, interp);
    Some(V2::new(uv.x, sum(&[R::lit(1.0), -uv.y])))
}

/// How a quantisation or the 8-bit output conversion rounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rounding {
    Nearest,
    /// Toward −∞ (truncation): the far side of what a conforming GPU may do.
    Down,
}

impl Rounding {
    /// `x` rounded to a multiple of `step`.
    fn to_step(self, x: f64, step: f64) -> f64 {
        match self {
            Rounding::Nearest => (x / step).round() * step,
            Rounding::Down => (x / step).floor() * step,
        }
    }
}

/// The fixed-function stages' precision (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedFunction {
    /// Sub-pixel bits of the rasteriser's vertex snapping; `None`: exact.
    pub subpixel_bits: Option<u32>,
    /// Fraction bits of the bilinear filter's weights; `None`: exact.
    pub subtexel_bits: Option<u32>,
    /// How the snapping, the weights and the 8-bit output round.
    pub rounding: Rounding,
}

impl FixedFunction {
    /// No quantisation, output rounded to nearest: the reference's own stages.
    pub const EXACT: FixedFunction = FixedFunction {
        subpixel_bits: None,
        subtexel_bits: None,
        rounding: Rounding::Nearest,
    };
    /// 8 sub-pixel and 8 sub-texel bits, to nearest: what D3D requires and most desktop GPUs
    /// (NVIDIA, AMD) do.
    pub const TYPICAL: FixedFunction = FixedFunction {
        subpixel_bits: Some(8),
        subtexel_bits: Some(8),
        rounding: Rounding::Nearest,
    };
    /// Vulkan's minimum, 4 bits each, every quantisation and the output truncated.
    pub const SPEC_MINIMUM: FixedFunction = FixedFunction {
        subpixel_bits: Some(4),
        subtexel_bits: Some(4),
        rounding: Rounding::Down,
    };

    /// A pixel-space corner as the rasteriser snaps it.
    pub fn snap(self, p: [f64; 2]) -> [f64; 2] {
        match self.subpixel_bits {
            None => p,
            Some(bits) => p.map(|x| self.rounding.to_step(x, (-(bits as f64)).exp2())),
        }
    }

    /// A filter fraction in [0, 1) as the sampler quantises it.
    pub fn weight(self, f: f64) -> f64 {
        match self.subtexel_bits {
            None => f,
            Some(bits) => self.rounding.to_step(f, (-(bits as f64)).exp2()),
        }
    }

    /// A filtered channel value (0..=255 as f64) written to an 8-bit target.
    pub fn output(self, c: f64) -> u8 {
        self.rounding.to_step(c, 1.0).clamp(0.0, 255.0) as u8
    }
}

/// A fragment stage: the texture coordinate (u, 1 − v) of a face at barycentrics, as
/// [`bpm_render_fragment`] computes it (or a mutant of it, in the tests).
pub type FragmentStage<'a> =
    &'a (dyn Fn(&[TriangleMaps<F>], u32, V3<F>, u32) -> Option<V2<F>> + Sync);

/// The picture `bpm_render` draws, computed by its twin: `mesh` (as the GPU receives it, f32
/// positions) with the per-triangle data `maps` (f32, e.g. from the `bpm_precompute` twin),
/// `texture`, `options`' camera and interpolation; arithmetic under `model`, fixed-function
/// stages as `fixed` says.
pub fn render_twin(
    mesh: &TriMesh,
    maps: &[TriangleMaps<F>],
    texture: &Image<Rgba8>,
    options: &RenderOptions,
    model: Model,
    fixed: FixedFunction,
) -> Image<Rgba8> {
    render_twin_with(
        mesh,
        maps,
        texture,
        options,
        model,
        fixed,
        &bpm_render_fragment::<F>,
    )
}

/// [`render_twin`] with another fragment stage (the tests' mutants).
pub fn render_twin_with(
    mesh: &TriMesh,
    maps: &[TriangleMaps<F>],
    texture: &Image<Rgba8>,
    options: &RenderOptions,
    model: Model,
    fixed: FixedFunction,
    fragment: FragmentStage,
) -> Image<Rgba8> {
    let view_proj = camera_for(mesh, options).view_proj();
    let view_proj: [F; 16] = std::array::from_fn(|i| F::new(view_proj.as_slice()[i] as f32));
    let clip: Vec<Vector4<f64>> = mesh
        .positions
        .iter()
        .map(|p| {
            let p = V3::new(F::new(p.x as f32), F::new(p.y as f32), F::new(p.z as f32));
            let c = with_model(model, || bpm_render_vertex(&view_proj, p));
            Vector4::new(c.x.f64(), c.y.f64(), c.z.f64(), c.w.f64())
        })
        .collect();
    let (width, height) = (options.width as usize, options.height as usize);
    let frame = rasterize_clip(mesh, &clip, width, height, |p| fixed.snap(p));
    let interp = interp_code(options.interp);
    shade(&frame, options.background, |face, bary| {
        let b = V3::new(
            F::new(bary[0] as f32),
            F::new(bary[1] as f32),
            F::new(bary[2] as f32),
        );
        let Some(st) = with_model(model, || fragment(maps, face, b, interp)) else {
            return [0, 0, 0, 0];
        };
        // The sampler takes (s, t) = (u, 1 − v); `sample_bilinear_with` takes (u, v).
        let uv = [st.x.f64(), 1.0 - st.y.f64()];
        sample_bilinear_with(texture, uv, |f| fixed.weight(f)).map(|c| fixed.output(c))
    })
}
