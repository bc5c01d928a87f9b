//! Bridge between the f64 reference and the f32 kernels of `reparam-gpu`: gathers the same
//! inputs for both sides, converts per-triangle data between the two layouts, and runs the
//! kernels. The GPU crate itself knows nothing of the reference; this module is the only place
//! where the two meet.

use num_complex::Complex64 as C;
use rayon::prelude::*;
use reparam_gpu::bpm::{self as kernels, GpuFit, GpuInterp, GpuSample, GpuTriangleMaps, StarInput};
use reparam_gpu::Gpu;

use super::eval::{Interp, Sample};
use super::precompute::{gather_stars, Bpm, Fit, Star, TriangleMaps};
use super::render::{camera_for, RenderOptions};
use crate::error::{Error, Result};
use crate::mesh::{Adjacency, TriMesh};
use crate::texture::Image;

/// The GPU context, or a typed error that says how to get an adapter.
pub fn context() -> Result<Gpu> {
    Gpu::new().map_err(gpu_error)
}

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

fn f32x2(z: C) -> [f32; 2] {
    [z.re as f32, z.im as f32]
}

/// Every face's [`Star`], exactly as the CPU precompute gathers it.
pub fn stars(mesh: &TriMesh) -> Result<Vec<Star>> {
    mesh.validate_with_uvs()?;
    Ok(gather_stars(mesh, &Adjacency::new(mesh)))
}

/// A [`Star`] in the GPU layout (positions and UVs rounded to f32).
pub fn star_to_gpu(star: &Star) -> StarInput {
    let mut mask = 0u32;
    for e in 0..3 {
        if star.neighbour[e] {
            mask |= 1 << e;
        }
    }
    if star.degenerate {
        mask |= 1 << 3;
    }
    StarInput {
        p: star.p.map(|p| [p.x as f32, p.y as f32, p.z as f32, 0.0]),
        w: star.w.map(f32x2),
        mask,
        _pad: [0; 3],
    }
}

/// A face's per-triangle data as the 44 values of the kernels' `TriangleMaps` (f64, before
/// rounding): z_j, z_k; uv_i, uv_j; uv_k, w_origin; M_t's a, b, c, d; per edge ij, jk, ki its
/// log ratio's a, b, then c, 0 — each complex as (re, im).
pub fn triangle_values(t: &TriangleMaps) -> [f64; 44] {
    let m = &t.m_t;
    let complexes = [t.z[1], t.z[2], t.uv[0], t.uv[1], t.uv[2], t.w_origin]
        .into_iter()
        .chain([m.a, m.b, m.c, m.d])
        .chain(
            t.logs
                .iter()
                .flat_map(|l| [l.a, l.b, l.c, C::new(0.0, 0.0)]),
        );
    let mut v = [0.0; 44];
    for (k, z) in complexes.enumerate() {
        v[2 * k] = z.re;
        v[2 * k + 1] = z.im;
    }
    v
}

/// The kernels' flags of a face: [`kernels::FLAG_LINEAR_FALLBACK`] | [`kernels::FLAG_MIRRORED`].
pub fn triangle_flags(t: &TriangleMaps) -> u32 {
    (t.fallback_linear as u32) | ((t.mirrored as u32) << 1)
}

/// The reference's per-triangle data rounded to the GPU layout (input of `bpm_eval` when the
/// eval kernel is checked alone).
pub fn maps_to_gpu(bpm: &Bpm) -> Vec<GpuTriangleMaps> {
    bpm.maps
        .par_iter()
        .map(|t| {
            let v = triangle_values(t).map(|x| x as f32);
            let v4 = |k: usize| [v[k], v[k + 1], v[k + 2], v[k + 3]];
            GpuTriangleMaps {
                z: v4(0),
                uv_ij: v4(4),
                uv_k_origin: v4(8),
                m: [v4(12), v4(16)],
                logs: std::array::from_fn(|e| v4(20 + 4 * e)),
                flags: triangle_flags(t),
                _pad: [0; 3],
            }
        })
        .collect()
}

/// Samples in the GPU layout: face id and (b_j, b_k) in f32.
pub fn samples_to_gpu(samples: &[Sample]) -> Vec<GpuSample> {
    samples
        .iter()
        .map(|s| GpuSample {
            face: s.face,
            _pad: 0,
            b: [s.bary[1] as f32, s.bary[2] as f32],
        })
        .collect()
}

/// The f64 barycentrics the GPU actually evaluates for a sample: (1 − b_j − b_k, b_j, b_k) with
/// b_j, b_k rounded to f32 (the CPU reference is evaluated at exactly these points).
pub fn sample_as_gpu_sees_it(s: &Sample) -> Sample {
    let (bj, bk) = (s.bary[1] as f32 as f64, s.bary[2] as f32 as f64);
    Sample {
        face: s.face,
        bary: [1.0 - bj - bk, bj, bk],
    }
}

fn fit_to_gpu(fit: Fit) -> GpuFit {
    match fit {
        Fit::Local => GpuFit::Local,
        Fit::Determinant => GpuFit::Determinant,
    }
}

fn interp_to_gpu(interp: Interp) -> GpuInterp {
    match interp {
        Interp::Bpm => GpuInterp::Bpm,
        Interp::Linear => GpuInterp::Linear,
    }
}

/// Run the `bpm_precompute` kernel on every face of `mesh`.
pub fn precompute_gpu(gpu: &Gpu, mesh: &TriMesh, fit: Fit) -> Result<Vec<GpuTriangleMaps>> {
    let stars: Vec<StarInput> = stars(mesh)?.iter().map(star_to_gpu).collect();
    kernels::precompute(gpu, &stars, fit_to_gpu(fit)).map_err(gpu_error)
}

/// Run the `bpm_eval` kernel: UVs at `samples` from per-triangle data `maps`.
pub fn eval_gpu(
    gpu: &Gpu,
    maps: &[GpuTriangleMaps],
    samples: &[GpuSample],
    interp: Interp,
) -> Result<Vec<C>> {
    let uv = kernels::eval(gpu, maps, samples, interp_to_gpu(interp)).map_err(gpu_error)?;
    Ok(uv
        .into_iter()
        .map(|[u, v]| C::new(u as f64, v as f64))
        .collect())
}

/// Render `mesh` on the GPU: `bpm_precompute` with `fit`, then the `bpm_render` fragment shader
/// (the same evaluation as `bpm_eval`), with the camera of the CPU render.
pub fn render_gpu(
    gpu: &Gpu,
    mesh: &TriMesh,
    fit: Fit,
    texture: &Image<[u8; 4]>,
    options: &RenderOptions,
) -> Result<Image<[u8; 4]>> {
    let maps = precompute_gpu(gpu, mesh, fit)?;
    let view_proj = camera_for(mesh, options).view_proj();
    let corners: Vec<[f32; 4]> = mesh
        .faces
        .iter()
        .flat_map(|f| {
            f.map(|v| {
                let p = mesh.positions[v as usize];
                [p.x as f32, p.y as f32, p.z as f32, 1.0]
            })
        })
        .collect();
    let input = kernels::RenderInput {
        width: options.width,
        height: options.height,
        view_proj: std::array::from_fn(|i| view_proj.as_slice()[i] as f32),
        corners: &corners,
        maps: &maps,
        texture_width: texture.width as u32,
        texture_height: texture.height as u32,
        texture: texture.pixels.as_flattened(),
        interp: interp_to_gpu(options.interp),
        background: options.background,
    };
    let bytes = kernels::render(gpu, &input).map_err(gpu_error)?;
    let (w, h) = (options.width as usize, options.height as usize);
    Ok(Image::from_fn(w, h, |x, y| {
        let i = 4 * (y * w + x);
        [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]
    }))
}
