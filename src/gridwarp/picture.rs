//! Pictures of a warp: the detail texture with the rest and warped grid lines drawn over it, and
//! the deformed surface rendered with the original and with the warped parameterisation.

use nalgebra::{Point2, Vector3};

use super::energy_naa::VertexGrid;
use super::field::Field;
use super::rasterize::Roi;
use super::remap::{AtlasRemap, Remap, Warped};
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

/// `texture` (covering the ROI) with the rest grid in grey and the warped grid in red: straight
/// lines for an axis-aligned warp, the polylines through the warped vertices for a
/// non-axis-aligned one (seed figures 3, 5, 9).
pub fn grid_overlay(texture: &Image<[u8; 4]>, remap: &Remap) -> Image<[u8; 4]> {
    const GREY: [u8; 4] = [120, 120, 120, 255];
    const RED: [u8; 4] = [220, 20, 20, 255];
    let mut img = texture.clone();
    let rest = VertexGrid::from_grid(&remap.rest);
    draw_vertex_grid(&mut img, &rest, GREY);
    let warped = match &remap.warped {
        Warped::Lines(g) => VertexGrid::from_grid(g),
        Warped::Vertices(v) => v.clone(),
    };
    draw_vertex_grid(&mut img, &warped, RED);
    img
}

/// Draw the lines of a vertex grid (ROI coordinates, t = 0 at the bottom of the image).
fn draw_vertex_grid(img: &mut Image<[u8; 4]>, v: &VertexGrid, colour: [u8; 4]) {
    for a in 0..v.m {
        for b in 0..v.n {
            if a + 1 < v.m {
                draw_segment(img, v.at(a, b), v.at(a + 1, b), colour);
            }
            if b + 1 < v.n {
                draw_segment(img, v.at(a, b), v.at(a, b + 1), colour);
            }
        }
    }
}

/// A 2-pixel-wide segment between two ROI points (sampled every half pixel).
fn draw_segment(img: &mut Image<[u8; 4]>, p: [f64; 2], q: [f64; 2], colour: [u8; 4]) {
    let (w, h) = (img.width as f64, img.height as f64);
    let to_px = |x: [f64; 2]| [x[0] * w, (1.0 - x[1]) * h];
    let (p, q) = (to_px(p), to_px(q));
    let steps = (2.0 * (q[0] - p[0]).abs().max((q[1] - p[1]).abs())).ceil() as usize + 1;
    for k in 0..=steps {
        let f = k as f64 / steps as f64;
        let (x, y) = (p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1]));
        for (dx, dy) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
            let (px, py) = ((x + dx).floor(), (y + dy).floor());
            if px >= 0.0 && py >= 0.0 && px < w && py < h {
                img.set(px as usize, py as usize, colour);
            }
        }
    }
}

/// The surface tessellated as an n×n grid with UV = (s, t) (the original parameterisation);
/// the warped parameterisation is applied per pixel by [`render_remapped`].
pub fn surface_mesh(surface: &SurfaceFn, n: usize) -> TriMesh {
    crate::mesh::procedural::param_grid("gridwarp surface", n, n, surface)
}

/// Render a UV-textured mesh (linear UV interpolation, no lighting) from `view_dir`.
pub fn render_textured(
    mesh: &TriMesh,
    texture: &Image<[u8; 4]>,
    view_dir: Vector3<f64>,
    size: usize,
) -> Image<[u8; 4]> {
    render_remapped(mesh, texture, view_dir, size, &|uv| uv)
}

/// Render a UV-textured mesh whose interpolated UV is passed through `lookup` at every pixel
/// before sampling the texture: the altered texture coordinates of seed §6, evaluated per pixel
/// as the paper does by rendering the parameterisation to a texture (Table 1, "Render"), so
/// that a coarse mesh still shows the warp inside its triangles.
pub fn render_remapped(
    mesh: &TriMesh,
    texture: &Image<[u8; 4]>,
    view_dir: Vector3<f64>,
    size: usize,
    lookup: &(dyn Fn([f64; 2]) -> [f64; 2] + Sync),
) -> Image<[u8; 4]> {
    render_remapped_framed(mesh, mesh, texture, view_dir, size, lookup)
}

/// [`render_remapped`] with the camera framing `frame_on` (e.g. the faces of a ROI, to zoom on
/// them) instead of the whole mesh.
pub fn render_remapped_framed(
    mesh: &TriMesh,
    frame_on: &TriMesh,
    texture: &Image<[u8; 4]>,
    view_dir: Vector3<f64>,
    size: usize,
    lookup: &(dyn Fn([f64; 2]) -> [f64; 2] + Sync),
) -> Image<[u8; 4]> {
    let camera = Camera::frame_mesh(frame_on, view_dir, 1.0);
    let frame = rasterize(mesh, &camera.view_proj(), size, size);
    shade(&frame, [245, 245, 245, 255], |face, b| {
        let uv = mesh.face_uvs(face as usize);
        let (u, v) = (
            b[0] * uv[0].x + b[1] * uv[1].x + b[2] * uv[2].x,
            b[0] * uv[0].y + b[1] * uv[1].y + b[2] * uv[2].y,
        );
        sample_bilinear(texture, lookup([u, v])).map(|c| c.round().clamp(0.0, 255.0) as u8)
    })
}

/// A texture for a whole UV atlas: inside each ROI the [`detail_texture`] of its rigidity map
/// (which lives in ROI coordinates), outside them a plain light grid.
pub fn atlas_texture(rois: &[(Roi, &Field)], size: usize) -> Image<[u8; 4]> {
    let details: Vec<Image<[u8; 4]>> = rois.iter().map(|(_, r)| detail_texture(r, size)).collect();
    Image::from_fn(size, size, |x, y| {
        let (u, v) = (
            (x as f64 + 0.5) / size as f64,
            1.0 - (y as f64 + 0.5) / size as f64,
        );
        for ((roi, _), detail) in rois.iter().zip(&details) {
            if roi.contains([u, v]) {
                let (s, t) = roi.st(Point2::new(u, v));
                let (dx, dy) = (
                    (s * size as f64) as usize,
                    ((1.0 - t) * size as f64) as usize,
                );
                return detail.get(dx.min(size - 1), dy.min(size - 1));
            }
        }
        if (u * 32.0).fract() < 0.05 || (v * 32.0).fract() < 0.05 {
            [170, 170, 170, 255]
        } else {
            [238, 238, 238, 255]
        }
    })
}

/// The part of an atlas `texture` inside `roi`, resampled bilinearly to `width`×`height` (row 0
/// at the ROI's top, t = 1), to draw grids over.
pub fn roi_crop(
    texture: &Image<[u8; 4]>,
    roi: &Roi,
    width: usize,
    height: usize,
) -> Image<[u8; 4]> {
    Image::from_fn(width, height, |x, y| {
        let (s, t) = (
            (x as f64 + 0.5) / width as f64,
            1.0 - (y as f64 + 0.5) / height as f64,
        );
        let uv = roi.uv(s, t);
        sample_bilinear(texture, [uv.x, uv.y]).map(|c| c.round().clamp(0.0, 255.0) as u8)
    })
}

/// `mesh` with every texture coordinate passed through the atlas lookup (seed §6, altered
/// texture coordinates, per vertex — exact only where the mesh is fine compared with the grid;
/// [`render_remapped`] applies the lookup per pixel instead). UVs outside every ROI are
/// unchanged.
pub fn remap_mesh_uvs(mesh: &TriMesh, atlas: &AtlasRemap) -> TriMesh {
    let mut out = mesh.clone();
    for uv in &mut out.uvs {
        let [u, v] = atlas.lookup_uv([uv.x, uv.y]);
        *uv = Point2::new(u, v);
    }
    out
}

/// A map of how much the unwarped texture stretches over the ROI in one frame: at each texel
/// max(|‖D_s‖/‖O_s‖ − 1|, |‖D_t‖/‖O_t‖ − 1|), white (0) to red (≥ `full_scale`), with R ≥ ½
/// texels darkened — to choose a ROI and a rigidity map where the warp has work to do.
pub fn stretch_map(
    rest: &super::energy::RestFields,
    deformed: &super::energy::DeformedFields,
    full_scale: f64,
    size: usize,
) -> Image<[u8; 4]> {
    Image::from_fn(size, size, |x, y| {
        let (s, t) = (
            (x as f64 + 0.5) / size as f64,
            1.0 - (y as f64 + 0.5) / size as f64,
        );
        let v_s = deformed.d_s.bilinear(s, t).value / rest.o_s.bilinear(s, t).value - 1.0;
        let v_t = deformed.d_t.bilinear(s, t).value / rest.o_t.bilinear(s, t).value - 1.0;
        let v = (v_s.abs().max(v_t.abs()) / full_scale).clamp(0.0, 1.0);
        let shade = if rest.rigidity.nearest(s, t) >= 0.5 {
            0.7
        } else {
            1.0
        };
        let c = |base: f64| (base * shade).round() as u8;
        [c(255.0), c(255.0 * (1.0 - v)), c(255.0 * (1.0 - v)), 255]
    })
}

/// The faces of `mesh` with a UV corner inside one of `rois` (all faces if none has one), as a
/// mesh to frame a camera on.
pub fn faces_in_rois(mesh: &TriMesh, rois: &[Roi]) -> TriMesh {
    faces_where(mesh, |uv| rois.iter().any(|r| r.contains(uv)))
}

/// The faces of `mesh` under rigid content (R ≥ ½) of one of `rois` (with their rigidity
/// maps): the faces [`super::rasterize::texel_map`] assigns to the covered rigid texels of each
/// map (for an all-rigid map, the faces with a UV corner in its ROI). Else (no rigid texel on
/// the mesh, or the maps cannot be rasterised) the faces of the ROIs. The part of the surface whose texture the warp is for, to zoom on.
pub fn rigid_faces(mesh: &TriMesh, rois: &[(Roi, &Field)]) -> TriMesh {
    let mut keep = vec![false; mesh.faces.len()];
    for (roi, r) in rois {
        if r.values.iter().all(|&v| v >= 0.5) {
            // All rigid (e.g. the default R ≡ 1): the whole ROI.
            for (f, k) in keep.iter_mut().enumerate() {
                *k |= mesh.face_uvs(f).iter().any(|uv| roi.contains([uv.x, uv.y]));
            }
            continue;
        }
        let Ok(map) = super::rasterize::texel_map(mesh, roi, (r.width, r.height)) else {
            continue;
        };
        for (i, &f) in map.face.iter().enumerate() {
            if map.covered[i] && r.values[i] >= 0.5 {
                keep[f as usize] = true;
            }
        }
    }
    if !keep.iter().any(|&k| k) || keep.iter().all(|&k| k) {
        return faces_in_rois(mesh, &rois.iter().map(|(r, _)| *r).collect::<Vec<_>>());
    }
    let ids: Vec<usize> = (0..keep.len()).filter(|&f| keep[f]).collect();
    sub_mesh(mesh, &ids)
}

/// The faces `ids` of `mesh` with only the positions they use (so that its bounding sphere,
/// which frames a camera, is theirs); UVs are kept whole.
fn sub_mesh(mesh: &TriMesh, ids: &[usize]) -> TriMesh {
    let mut new_index = vec![u32::MAX; mesh.positions.len()];
    let mut positions = Vec::new();
    let faces = ids
        .iter()
        .map(|&f| {
            mesh.faces[f].map(|v| {
                if new_index[v as usize] == u32::MAX {
                    new_index[v as usize] = positions.len() as u32;
                    positions.push(mesh.positions[v as usize]);
                }
                new_index[v as usize]
            })
        })
        .collect();
    TriMesh {
        positions,
        faces,
        uv_faces: ids.iter().map(|&f| mesh.uv_faces[f]).collect(),
        ..mesh.clone()
    }
}

/// The faces with a UV corner where `keep` holds (all faces if none).
fn faces_where(mesh: &TriMesh, keep: impl Fn([f64; 2]) -> bool) -> TriMesh {
    let ids: Vec<usize> = (0..mesh.faces.len())
        .filter(|&f| mesh.face_uvs(f).iter().any(|uv| keep([uv.x, uv.y])))
        .collect();
    if ids.is_empty() {
        return mesh.clone();
    }
    sub_mesh(mesh, &ids)
}
