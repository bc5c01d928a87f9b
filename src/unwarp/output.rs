//! Using a correction (notes § Application; seed: "store per-texel offsets", "Mip Mapping",
//! the backward-compatible pre-warped texture) and picturing it.
//!
//! Coordinates: the solver's offset o is in the node convention u = ((x + ½)/W, (y + ½)/H)
//! with y the image row (top first). Files and textures use the OBJ convention of
//! [`crate::texture`] (v up, v = 1 − (y + ½)/H), so an offset is written as
//! (Δu, Δv) = (o.x, −o.y).

use std::path::Path;

use nalgebra::{Point2, Point3, Vector3};

use crate::error::Result;
use crate::mesh::TriMesh;
use crate::raster::{rasterize, shade, Camera};
use crate::texture::{sample_bilinear, save_exr_rg, Image, Rgba8};

use super::apply::{bake_colour, to_rgba8};
/// The offsets' mip chain and their UV convention live with the lookup that reads them
/// ([`super::apply`]); re-exported here, where the outputs are written.
pub use super::apply::{offset_mip_chain, offset_to_uv, OffsetLevel};
use super::mesh::{Border, UnwarpMesh};

/// Write the offset map as a two-channel (R = Δu, G = Δv) 32-bit float EXR, UV units.
pub fn save_offset_map(
    path: &Path,
    width: usize,
    height: usize,
    offsets: &[[f64; 2]],
) -> Result<()> {
    let values: Vec<[f32; 2]> = offsets
        .iter()
        .map(|&o| offset_to_uv(o).map(|c| c as f32))
        .collect();
    save_exr_rg(path, width, height, &values)
}

/// The solver offset at texture coordinate `uv` (OBJ convention), bilinear between texel
/// centres: wrapping (periodic) or clamped (fixed border); [`super::apply::sample_level`] on
/// the level-0 map.
pub fn sample_offset(mesh: &UnwarpMesh, offsets: &[[f64; 2]], uv: [f64; 2]) -> [f64; 2] {
    super::apply::sample_level(mesh.width, mesh.height, offsets, mesh.border, uv)
}

/// The backward-compatible variant: the pre-warped colour texture C'(u) = C(u + c(u)), c the
/// offset map sampled at u ([`sample_offset`]), same size as `color`
/// ([`super::apply::bake_colour`] per texel, rounded to 8 bits). Rendering C' with the
/// original UVs shows what the modified renderer shows with C (bijective maps only).
pub fn bake_prewarped(
    color: &Image<Rgba8>,
    mesh: &UnwarpMesh,
    offsets: &[[f64; 2]],
) -> Image<Rgba8> {
    let level = OffsetLevel {
        width: mesh.width,
        height: mesh.height,
        offsets: offsets.to_vec(),
    };
    Image::from_fn(color.width, color.height, |px, py| {
        to_rgba8(bake_colour(color, &level, mesh.border, px, py))
    })
}

/// The displaced surface as a triangle mesh, one vertex per node at (X.x, 1 − X.y, s·h) (image
/// top up), triangulated like the stencil, with texture coordinates u + o (OBJ convention), or
/// the original u when `offsets` is `None`. Periodic maps get one extra column and row (the
/// wrapped first ones, one period further) so the whole square is covered.
pub fn displaced_surface(mesh: &UnwarpMesh, offsets: Option<&[[f64; 2]]>) -> TriMesh {
    let (w, h) = (mesh.width, mesh.height);
    let extra = usize::from(mesh.border == Border::Periodic);
    let (nw, nh) = (w + extra, h + extra);
    let mut positions = Vec::with_capacity(nw * nh);
    let mut uvs = Vec::with_capacity(nw * nh);
    for y in 0..nh {
        for x in 0..nw {
            let i = mesh.index(x % w, y % h);
            let (px, py) = ((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
            positions.push(Point3::new(px, 1.0 - py, mesh.z[i]));
            let o = offsets.map_or([0.0; 2], |o| o[i]);
            uvs.push(Point2::new(px + o[0], 1.0 - (py + o[1])));
        }
    }
    let idx = |x: usize, y: usize| (y * nw + x) as u32;
    let mut faces = Vec::new();
    for y in 1..nh {
        for x in 0..nw - 1 {
            faces.push([idx(x, y), idx(x, y - 1), idx(x + 1, y - 1)]);
            faces.push([idx(x, y), idx(x + 1, y - 1), idx(x + 1, y)]);
        }
    }
    TriMesh::with_shared_indices("unwarp surface", positions, uvs, faces)
}

/// Render a textured surface mesh (no lighting: the texture alone shows the stretch) from an
/// oblique view, `size`² pixels.
pub fn render_surface(surface: &TriMesh, texture: &Image<Rgba8>, size: usize) -> Image<Rgba8> {
    let view = Vector3::new(0.0, 0.9, -1.0);
    let camera = Camera::frame_mesh(surface, view, 1.0);
    let frame = rasterize(surface, &camera.view_proj(), size, size);
    shade(&frame, [245, 245, 245, 255], |face, b| {
        let uv = surface.face_uvs(face as usize);
        let u = b[0] * uv[0].x + b[1] * uv[1].x + b[2] * uv[2].x;
        let v = b[0] * uv[0].y + b[1] * uv[1].y + b[2] * uv[2].y;
        to_rgba8(sample_bilinear(texture, [u, v]))
    })
}

/// A colour ramp from dark blue (t = 0) through teal and green to yellow (t = 1).
pub fn ramp(t: f64) -> Rgba8 {
    const STOPS: [[f64; 3]; 5] = [
        [20.0, 20.0, 90.0],
        [30.0, 100.0, 160.0],
        [40.0, 170.0, 130.0],
        [170.0, 210.0, 60.0],
        [250.0, 240.0, 40.0],
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * 4.0;
    let i = (t.floor() as usize).min(3);
    let f = t - i as f64;
    let c = [0, 1, 2].map(|k| STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f);
    [c[0] as u8, c[1] as u8, c[2] as u8, 255]
}

/// A diverging ramp for a ratio around 1: blue (≤ 1/2) – white (1) – red (≥ 2), by log₂.
pub fn diverging(ratio: f64) -> Rgba8 {
    let t = if ratio > 0.0 {
        ratio.log2().clamp(-1.0, 1.0)
    } else {
        -1.0
    };
    let (r, g, b) = if t < 0.0 {
        (1.0 + t, 1.0 + t, 1.0)
    } else {
        (1.0, 1.0 - t, 1.0 - t)
    };
    [(255.0 * r) as u8, (255.0 * g) as u8, (255.0 * b) as u8, 255]
}

/// A W×H per-texel picture, each texel `zoom`×`zoom` pixels, coloured by `colour`.
pub fn texel_picture(
    width: usize,
    height: usize,
    values: &[f64],
    zoom: usize,
    colour: impl Fn(f64) -> Rgba8,
) -> Image<Rgba8> {
    let zoom = zoom.max(1);
    Image::from_fn(width * zoom, height * zoom, |x, y| {
        colour(values[(y / zoom) * width + x / zoom])
    })
}

/// A line plot of `values` (e.g. the energy ratio per pass) on a white `width × height`
/// canvas, y from `y_min` (bottom) to the largest value (top), with a light grid line at
/// each quarter.
pub fn line_plot(values: &[f64], y_min: f64, width: usize, height: usize) -> Image<Rgba8> {
    let mut img = Image::new(width, height, [255, 255, 255, 255]);
    let margin = 8usize;
    let (pw, ph) = ((width - 2 * margin) as f64, (height - 2 * margin) as f64);
    for q in 0..=4 {
        let y = margin + (q as f64 * ph / 4.0) as usize;
        for x in margin..width - margin {
            img.set(x, y.min(height - 1), [220, 220, 220, 255]);
        }
    }
    let y_max = values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(y_min, f64::max);
    let span = (y_max - y_min).max(1e-12);
    let n = values.len().max(2) - 1;
    let point = |i: usize| {
        let x = margin as f64 + pw * i as f64 / n as f64;
        let y = margin as f64 + ph * (1.0 - (values[i] - y_min) / span);
        (x, y.clamp(margin as f64, (height - margin) as f64))
    };
    for i in 1..values.len() {
        let (a, b) = (point(i - 1), point(i));
        let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
        for s in 0..=steps {
            let f = s as f64 / steps as f64;
            let (x, y) = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
            let (x, y) = (x.round() as usize, y.round() as usize);
            for (dx, dy) in [(0, 0), (1, 0), (0, 1)] {
                if x + dx < width && y + dy < height {
                    img.set(x + dx, y + dy, [200, 40, 40, 255]);
                }
            }
        }
    }
    img
}

/// Size in pixels of the rendered surface pictures.
pub const RENDER_SIZE: usize = 512;

/// Write everything a correction gives to `dir` and return the file paths:
///
/// - `offsets.exr` (R = Δu, G = Δv, UV units) and `offsets_mip1.exr`, `offsets_mip2.exr`, … (the
///   [`offset_mip_chain`]),
/// - `prewarped.png`: [`bake_prewarped`] of `color` (or of the built-in UV grid texture),
/// - `surface_checker.png`, `surface_texture.png`: the displaced surface with the original UVs
///   (left) and the corrected ones (right), textured with a checker and with `color` (or the UV
///   grid),
/// - `offset_magnitude.png`: |R⊙o| in texels, [`ramp`] from 0 to the largest,
/// - `distortion_ratio.png`, `distortion_area.png`: per-texel σ1/σ2 ([`ramp`] over [1, 2]) and
///   σ1σ2 ([`diverging`]) before (left) and after (right),
/// - `energy.png`: the finest level's energy ratio per pass ([`line_plot`] from 1).
pub fn write_outputs(
    dir: &Path,
    solution: &super::Solution,
    color: Option<&Image<Rgba8>>,
) -> Result<Vec<std::path::PathBuf>> {
    use crate::texture::{checker, save_png, side_by_side, uv_grid_texture};

    let mesh = &solution.problem.mesh;
    let (w, h) = (mesh.width, mesh.height);
    let mut files = Vec::new();
    let mut save = |name: &str, image: &Image<Rgba8>| -> Result<()> {
        let path = dir.join(name);
        save_png(image, &path)?;
        files.push(path);
        Ok(())
    };

    let grid;
    let structured = match color {
        Some(c) => c,
        None => {
            grid = uv_grid_texture(512);
            &grid
        }
    };
    save(
        "prewarped.png",
        &bake_prewarped(structured, mesh, &solution.offsets),
    )?;
    let (original, corrected) = (
        displaced_surface(mesh, None),
        displaced_surface(mesh, Some(&solution.offsets)),
    );
    for (name, texture) in [
        ("surface_checker.png", &checker(512, 16)),
        ("surface_texture.png", structured),
    ] {
        let pair = [
            render_surface(&original, texture, RENDER_SIZE),
            render_surface(&corrected, texture, RENDER_SIZE),
        ];
        save(name, &side_by_side(&[&pair[0], &pair[1]], 8))?;
    }

    let zoom = (256 / w.max(h)).max(1);
    let r = mesh.resolution();
    let magnitude: Vec<f64> = solution
        .offsets
        .iter()
        .map(|o| (r[0] * o[0]).hypot(r[1] * o[1]))
        .collect();
    let largest = magnitude.iter().copied().fold(1e-12, f64::max);
    save(
        "offset_magnitude.png",
        &texel_picture(w, h, &magnitude, zoom, |m| ramp(m / largest)),
    )?;
    let before = super::stats::texel_distortion(&solution.problem, &vec![[0.0; 2]; w * h]);
    let after = super::stats::texel_distortion(&solution.problem, &solution.offsets);
    let ratio_picture =
        |d: &super::stats::TexelDistortion| texel_picture(w, h, &d.ratio, zoom, |v| ramp(v - 1.0));
    save(
        "distortion_ratio.png",
        &side_by_side(&[&ratio_picture(&before), &ratio_picture(&after)], 8),
    )?;
    let area_picture =
        |d: &super::stats::TexelDistortion| texel_picture(w, h, &d.product, zoom, diverging);
    save(
        "distortion_area.png",
        &side_by_side(&[&area_picture(&before), &area_picture(&after)], 8),
    )?;
    let theta = solution.problem.theta;
    let curve: Vec<f64> = solution
        .fine()
        .energy_per_pass
        .iter()
        .map(|e| e.ratio(theta))
        .collect();
    save("energy.png", &line_plot(&curve, 1.0, 512, 256))?;

    for (level, mip) in offset_mip_chain(w, h, &solution.offsets).iter().enumerate() {
        let name = if level == 0 {
            "offsets.exr".to_string()
        } else {
            format!("offsets_mip{level}.exr")
        };
        let path = dir.join(name);
        save_offset_map(&path, mip.width, mip.height, &mip.offsets)?;
        files.push(path);
    }
    Ok(files)
}
