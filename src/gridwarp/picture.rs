//! Pictures of a warp: the detail texture with the rest and warped grid lines drawn over it, and
//! the deformed surface rendered with the original and with the warped parameterisation.

use nalgebra::{Point2, Vector3};

use super::field::Field;
use super::grid::Grid;
use super::remap::inverse;
use super::scene::SurfaceFn;
use crate::mesh::TriMesh;
use crate::raster::{rasterize, shade, Camera};
use crate::texture::{sample_bilinear, Image};

/// A detail texture whose rigid features (R ≥ ½) carry a fine checker of circles-in-squares, and
/// whose non-rigid background carries thin grid lines: stretch of the features is easy to see.
pub fn detail_texture(rigidity: &Field, size: usize) -> Image<[u8; 4]> {
    Image::from_fn(size, size, |x, y| {
        let (s, t) = (
            (x as f64 + 0.5) / size as f64,
            1.0 - (y as f64 + 0.5) / size as f64,
        );
        if rigidity.nearest(s, t) >= 0.5 {
            let (cs, ct) = ((s * 40.0).fract() - 0.5, (t * 40.0).fract() - 0.5);
            let ring = (cs * cs + ct * ct).sqrt();
            if ring < 0.32 && ring > 0.18 {
                [200, 40, 30, 255]
            } else {
                [250, 230, 120, 255]
            }
        } else if (s * 20.0).fract() < 0.06 || (t * 20.0).fract() < 0.06 {
            [90, 110, 140, 255]
        } else {
            [225, 230, 240, 255]
        }
    })
}

/// `texture` (covering the ROI) with the rest grid in grey and the warped grid in red.
pub fn grid_overlay(texture: &Image<[u8; 4]>, rest: &Grid, warped: &Grid) -> Image<[u8; 4]> {
    let mut img = texture.clone();
    let (w, h) = (img.width, img.height);
    let mut draw = |lines: &[f64], vertical: bool, colour: [u8; 4]| {
        for &v in lines {
            let k = ((v * if vertical { w } else { h } as f64) as usize)
                .min(if vertical { w } else { h } - 1);
            for q in 0..if vertical { h } else { w } {
                for d in 0..2 {
                    let k = (k + d).min(if vertical { w } else { h } - 1);
                    if vertical {
                        img.set(k, q, colour)
                    } else {
                        img.set(q, h - 1 - k, colour)
                    }
                }
            }
        }
    };
    draw(&rest.s, true, [120, 120, 120, 255]);
    draw(&rest.t, false, [120, 120, 120, 255]);
    draw(&warped.s, true, [220, 20, 20, 255]);
    draw(&warped.t, false, [220, 20, 20, 255]);
    img
}

/// The surface tessellated as an n×n grid with UV = (s, t) (the original parameterisation) or,
/// with `warp = Some((rest, warped))`, UV = F⁻¹(s, t) (seed §6: altered texture coordinates).
pub fn surface_mesh(surface: &SurfaceFn, n: usize, warp: Option<(&Grid, &Grid)>) -> TriMesh {
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for y in 0..=n {
        for x in 0..=n {
            let (s, t) = (x as f64 / n as f64, y as f64 / n as f64);
            positions.push(surface(s, t));
            let [u, v] = warp.map_or([s, t], |(rest, warped)| inverse(rest, warped, [s, t]));
            uvs.push(Point2::new(u, v));
        }
    }
    let idx = |x: usize, y: usize| (y * (n + 1) + x) as u32;
    let mut faces = Vec::new();
    for y in 0..n {
        for x in 0..n {
            faces.push([idx(x, y), idx(x + 1, y), idx(x + 1, y + 1)]);
            faces.push([idx(x, y), idx(x + 1, y + 1), idx(x, y + 1)]);
        }
    }
    TriMesh::with_shared_indices("gridwarp surface", positions, uvs, faces)
}

/// Render a UV-textured mesh (linear UV interpolation, no lighting) from `view_dir`.
pub fn render_textured(
    mesh: &TriMesh,
    texture: &Image<[u8; 4]>,
    view_dir: Vector3<f64>,
    size: usize,
) -> Image<[u8; 4]> {
    let camera = Camera::frame_mesh(mesh, view_dir, 1.0);
    let frame = rasterize(mesh, &camera.view_proj(), size, size);
    shade(&frame, [245, 245, 245, 255], |face, b| {
        let uv = mesh.face_uvs(face as usize);
        let (u, v) = (
            b[0] * uv[0].x + b[1] * uv[1].x + b[2] * uv[2].x,
            b[0] * uv[0].y + b[1] * uv[1].y + b[2] * uv[2].y,
        );
        sample_bilinear(texture, [u, v]).map(|c| c.round().clamp(0.0, 255.0) as u8)
    })
}

/// A texture for a whole UV atlas: inside the ROI the [`detail_texture`] of `rigidity` (which
/// lives in ROI coordinates), outside it a plain light grid.
pub fn atlas_texture(roi: &super::rasterize::Roi, rigidity: &Field, size: usize) -> Image<[u8; 4]> {
    let detail = detail_texture(rigidity, size);
    Image::from_fn(size, size, |x, y| {
        let (u, v) = (
            (x as f64 + 0.5) / size as f64,
            1.0 - (y as f64 + 0.5) / size as f64,
        );
        let (s, t) = roi.st(Point2::new(u, v));
        if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
            let (dx, dy) = (
                (s * size as f64) as usize,
                ((1.0 - t) * size as f64) as usize,
            );
            detail.get(dx.min(size - 1), dy.min(size - 1))
        } else if (u * 32.0).fract() < 0.05 || (v * 32.0).fract() < 0.05 {
            [170, 170, 170, 255]
        } else {
            [238, 238, 238, 255]
        }
    })
}

/// `mesh` with the texture coordinates inside the ROI remapped by the warp (seed §6, altered
/// texture coordinates): uv ↦ roi.uv(F⁻¹(roi.st(uv))); UVs outside the ROI are unchanged.
pub fn remap_mesh_uvs(
    mesh: &TriMesh,
    roi: &super::rasterize::Roi,
    rest: &Grid,
    warped: &Grid,
) -> TriMesh {
    let mut out = mesh.clone();
    for uv in &mut out.uvs {
        let (s, t) = roi.st(*uv);
        if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
            let [s2, t2] = inverse(rest, warped, [s, t]);
            *uv = roi.uv(s2, t2);
        }
    }
    out
}
