//! Pictures of a MAPS hierarchy (issue #5 "Pictures"), drawn with the CPU reference
//! rasteriser ([`crate::raster`]): levels side by side, the base domain with the input vertices
//! coloured by base triangle, iso-parameter lines of Π on the input, remeshes, and the input
//! coloured by the area distortion of Π (issue #23).

use nalgebra::{Matrix4, Vector3};

use nalgebra::Point3;

use super::smooth::{dyadic_net, smoothed_net, ParamNet, SmoothOptions};
use super::Maps;
use crate::error::Result;
use crate::mesh::TriMesh;
use crate::raster::{ndc_to_pixel, rasterize, shade, Camera, FrameBuffer};
use crate::texture::{side_by_side, Image, Rgba8};

/// The view direction of every picture (from upper front left).
pub const VIEW: [f64; 3] = [-0.45, -0.55, -0.7];
const BACKGROUND: Rgba8 = [255, 255, 255, 255];

/// A well-spread colour for index `i` (golden-ratio hue walk, fixed saturation and value).
pub fn palette(i: u32) -> Rgba8 {
    let h = (i as f64 * 0.618_033_988_749_895).fract() * 6.0;
    let (s, v) = (0.55, 0.95);
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [
        ((r + m) * 255.0) as u8,
        ((g + m) * 255.0) as u8,
        ((b + m) * 255.0) as u8,
        255,
    ]
}

/// Lambert factor of face `f` for a light along the view (two-sided, 0.35 ambient).
fn lambert(mesh: &TriMesh, f: usize, light: &Vector3<f64>) -> f64 {
    let [p, q, r] = mesh.face_positions(f);
    let n = (q - p)
        .cross(&(r - p))
        .try_normalize(1e-300)
        .unwrap_or(Vector3::z());
    0.35 + 0.65 * n.dot(light).abs()
}

fn scale(c: Rgba8, k: f64) -> Rgba8 {
    [
        (c[0] as f64 * k) as u8,
        (c[1] as f64 * k) as u8,
        (c[2] as f64 * k) as u8,
        255,
    ]
}

/// The camera of all pictures of `mesh` (square).
pub fn camera(mesh: &TriMesh) -> Matrix4<f64> {
    Camera::frame_mesh(mesh, Vector3::from(VIEW), 1.0).view_proj()
}

/// A shaded render of `mesh` with its edges drawn dark (a fragment is on an edge when its
/// smallest barycentric coordinate is below `edge_width`), faces coloured by `colour(face)`.
pub fn render_wire(
    mesh: &TriMesh,
    view_proj: &Matrix4<f64>,
    size: usize,
    colour: impl Fn(u32) -> Rgba8 + Sync,
    edge_width: f64,
) -> Image<Rgba8> {
    let fb = rasterize(mesh, view_proj, size, size);
    let light = -Vector3::from(VIEW).normalize();
    shade(&fb, BACKGROUND, |f, b| {
        let k = lambert(mesh, f as usize, &light);
        if b[0].min(b[1]).min(b[2]) < edge_width {
            [40, 40, 40, 255]
        } else {
            scale(colour(f), k)
        }
    })
}

/// Levels side by side: the input, evenly spaced intermediate levels, and the base domain
/// (`count` pictures in all, each `size` pixels), one camera for all.
pub fn hierarchy_levels(maps: &Maps, count: usize, size: usize) -> Vec<Image<Rgba8>> {
    let input = TriMesh::with_shared_indices(
        "input",
        maps.positions.clone(),
        Vec::new(),
        maps.input_faces.clone(),
    );
    let view_proj = camera(&input);
    let mut meshes: Vec<Vec<[u32; 3]>> = Vec::new();
    let n = maps.levels.len();
    let count = count.max(2);
    for k in 0..count - 1 {
        let l = k * n / (count - 1);
        if let Some(level) = maps.levels.get(l) {
            if !level.faces.is_empty() {
                meshes.push(level.faces.clone());
            }
        }
    }
    meshes.push(maps.base_faces.clone());
    meshes
        .into_iter()
        .map(|faces| {
            let m =
                TriMesh::with_shared_indices("level", maps.positions.clone(), Vec::new(), faces);
            let width = 0.9 / (m.faces.len() as f64).sqrt().max(1.0) + 0.01;
            render_wire(
                &m,
                &view_proj,
                size,
                |_| [200, 210, 230, 255],
                width.min(0.05),
            )
        })
        .collect()
}

/// The base domain (faces in their palette colours, lightened) with every input vertex drawn as
/// a dot at its base-domain point Π(p_v), in the colour of its base triangle.
pub fn base_domain_points(maps: &Maps, size: usize) -> Image<Rgba8> {
    let base = maps.base_mesh();
    let view_proj = camera(&TriMesh::with_shared_indices(
        "input",
        maps.positions.clone(),
        Vec::new(),
        maps.input_faces.clone(),
    ));
    let light = -Vector3::from(VIEW).normalize();
    let fb = rasterize(&base, &view_proj, size, size);
    let mut img = shade(&fb, BACKGROUND, |f, b| {
        if b[0].min(b[1]).min(b[2]) < 0.01 {
            [60, 60, 60, 255]
        } else {
            let c = palette(f);
            let k = lambert(&base, f as usize, &light);
            scale([c[0] / 2 + 127, c[1] / 2 + 127, c[2] / 2 + 127, 255], k)
        }
    });
    for v in 0..maps.positions.len() {
        let Some(p) = maps.base_position(v) else {
            continue;
        };
        let (face, _) = maps.location[v];
        let clip = view_proj * p.to_homogeneous();
        if clip.w <= 0.0 {
            continue;
        }
        let [x, y] = ndc_to_pixel(clip.x / clip.w, clip.y / clip.w, size, size);
        // A vertex far off the view (a coordinate of 1e308: w ≈ 0) is not drawn; the cast
        // saturates and the +1 below must not overflow.
        if !(x.is_finite() && y.is_finite()) {
            continue;
        }
        let (xi, yi) = (x as i64, y as i64);
        // Draw only where the dot is the visible surface (its depth close to the z-buffer's).
        let depth = clip.z / clip.w;
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let (px, py) = (xi.saturating_add(dx), yi.saturating_add(dy));
            if px < 0 || py < 0 || px as usize >= size || py as usize >= size {
                continue;
            }
            let idx = py as usize * size + px as usize;
            if depth <= fb.depth[idx] + 1e-3 {
                img.pixels[idx] = scale(palette(face), 0.8);
            }
        }
    }
    img
}

/// Iso-parameter lines of Π on the input surface: each pixel's input point is mapped to the
/// base domain (`Param::forward`) and drawn dark where a barycentric coordinate is within
/// `0.012` of a multiple of 1/`lines`, in the colour of its base triangle elsewhere.
pub fn iso_lines(maps: &Maps, lines: u32, size: usize) -> Image<Rgba8> {
    let input = TriMesh::with_shared_indices(
        "input",
        maps.positions.clone(),
        Vec::new(),
        maps.input_faces.clone(),
    );
    let view_proj = camera(&input);
    let light = -Vector3::from(VIEW).normalize();
    let fb = rasterize(&input, &view_proj, size, size);
    shade(&fb, BACKGROUND, |f, b| {
        let k = lambert(&input, f as usize, &light);
        match maps.param.forward(f, b) {
            Some(q) => {
                let on_line = q.bary.iter().any(|&x| {
                    let s = x * lines as f64;
                    (s - s.round()).abs() < 0.012 * lines as f64
                });
                if on_line {
                    [30, 30, 30, 255]
                } else {
                    scale(palette(q.face), k)
                }
            }
            None => [255, 0, 255, 255],
        }
    })
}

/// Iso-parameter lines of a parameter net drawn on the input surface: the input shaded plain,
/// and every net edge that lies on a line β_c = k/2^`lines_level` of its base triangle (both
/// ends with the same integer β_c, a multiple of 2^(depth − `lines_level`)) drawn as the 3D
/// segment between its vertices `positions` (Π⁻¹ of the net's parameters), dark, and red where
/// β_c = 0 (a base edge). A segment pixel is drawn where it is not behind the input surface
/// (its depth within 2·10⁻³ of the z-buffer's: a chord of the surface dips below it by its
/// sagitta). Nets coarser than `lines_level` draw their edges only.
pub fn net_iso_lines(
    maps: &Maps,
    net: &ParamNet,
    positions: &[Point3<f64>],
    lines_level: u32,
    size: usize,
) -> Image<Rgba8> {
    let input = input_mesh(maps);
    let view_proj = camera(&input);
    let light = -Vector3::from(VIEW).normalize();
    let fb = rasterize(&input, &view_proj, size, size);
    let mut img = shade(&fb, BACKGROUND, |f, _| {
        scale([235, 228, 210, 255], lambert(&input, f as usize, &light))
    });
    for (tri, face) in net.leaves.iter().zip(&net.faces) {
        let step = 1u32 << tri.depth.saturating_sub(lines_level);
        for e in 0..3 {
            let (p, q) = (tri.corners[e], tri.corners[(e + 1) % 3]);
            let Some(c) = (0..3).find(|&c| p[c] == q[c] && p[c] % step == 0) else {
                continue;
            };
            let colour = if p[c] == 0 {
                [200, 30, 30, 255]
            } else {
                [30, 30, 30, 255]
            };
            let (a, b) = (
                positions[face[e] as usize],
                positions[face[(e + 1) % 3] as usize],
            );
            draw_segment(&mut img, &fb, &view_proj, &a, &b, colour);
        }
    }
    img
}

/// Draw the 3D segment a–b with the depth test of [`net_iso_lines`], sampled every half pixel.
fn draw_segment(
    img: &mut Image<Rgba8>,
    fb: &FrameBuffer,
    view_proj: &Matrix4<f64>,
    a: &Point3<f64>,
    b: &Point3<f64>,
    colour: Rgba8,
) {
    let size = img.width;
    let project = |p: &Point3<f64>| {
        let clip = view_proj * p.to_homogeneous();
        (clip.w > 0.0).then(|| {
            let [x, y] = ndc_to_pixel(clip.x / clip.w, clip.y / clip.w, size, size);
            (x, y, clip.z / clip.w)
        })
    };
    let (Some(pa), Some(pb)) = (project(a), project(b)) else {
        return;
    };
    let steps = (2.0 * (pb.0 - pa.0).hypot(pb.1 - pa.1))
        .ceil()
        .clamp(1.0, 4.0 * size as f64);
    for k in 0..=steps as usize {
        let t = k as f64 / steps;
        let (x, y, z) = (
            pa.0 + t * (pb.0 - pa.0),
            pa.1 + t * (pb.1 - pa.1),
            pa.2 + t * (pb.2 - pa.2),
        );
        if x < 0.0 || y < 0.0 || x >= size as f64 || y >= img.height as f64 {
            continue;
        }
        let idx = y as usize * size + x as usize;
        if z <= fb.depth[idx] + 2e-3 {
            img.pixels[idx] = colour;
        }
    }
}

/// Iso-parameter lines of the unsmoothed (left) and the Loop-smoothed (right) parameterisation
/// on the input ([`net_iso_lines`] of [`dyadic_net`] and [`smoothed_net`] at level
/// `lines_level` + 2, so each drawn line is a polyline of 4 segments per base-triangle cell).
/// Errors: those of [`smoothed_net`].
pub fn iso_lines_smoothed(maps: &Maps, lines_level: u32, size: usize) -> Result<Image<Rgba8>> {
    let level = lines_level + 2;
    let plain = dyadic_net(maps, level)?;
    let (smooth, _) = smoothed_net(maps, level, &SmoothOptions::default())?;
    let images: Vec<Image<Rgba8>> = [plain, smooth]
        .iter()
        .map(|net| {
            let (positions, _) = net.positions(maps);
            net_iso_lines(maps, net, &positions, lines_level, size)
        })
        .collect();
    Ok(side_by_side(&[&images[0], &images[1]], 4))
}

/// The input as a mesh (shared indices, no UVs).
fn input_mesh(maps: &Maps) -> TriMesh {
    TriMesh::with_shared_indices(
        "input",
        maps.positions.clone(),
        Vec::new(),
        maps.input_faces.clone(),
    )
}

/// A remesh drawn with its edges, with the input's camera.
pub fn remesh_picture(maps: &Maps, remesh: &TriMesh, size: usize) -> Image<Rgba8> {
    let input = TriMesh::with_shared_indices(
        "input",
        maps.positions.clone(),
        Vec::new(),
        maps.input_faces.clone(),
    );
    let width = (0.9 / (remesh.faces.len() as f64).sqrt().max(1.0) + 0.01).min(0.05);
    render_wire(
        remesh,
        &camera(&input),
        size,
        |_| [225, 215, 190, 255],
        width,
    )
}

/// The colour of log r (area distortion, [`super::distortion`]): white at 0, towards blue where
/// Π shrinks a triangle (log r < 0), towards red where it grows one, saturated at |log r| =
/// `range`; grey for a folded image (`None`).
pub fn distortion_colour(log_r: Option<f64>, range: f64) -> Rgba8 {
    let Some(x) = log_r else {
        return [110, 110, 110, 255];
    };
    let t = (x / range).clamp(-1.0, 1.0);
    let fade = |k: f64| (255.0 * (1.0 - k)) as u8;
    if t >= 0.0 {
        [255, fade(t), fade(t), 255]
    } else {
        [fade(-t), fade(-t), 255, 255]
    }
}

/// The input mesh, each triangle t coloured by the area distortion log r_t of a map onto the
/// base domain (`log_area_ratio`: [`super::distortion::Distortion::log_area_ratio`] for the
/// final Π, or [`super::distortion::map_distortion`]'s for Π' = Φ ∘ Π; [`distortion_colour`], saturated at |log r| = ln 4: a triangle whose share of the base
/// domain is 4× or ¼ of its share of the surface).
pub fn area_distortion(maps: &Maps, log_area_ratio: &[Option<f64>], size: usize) -> Image<Rgba8> {
    let input = input_mesh(maps);
    let range = 4f64.ln();
    render_wire(
        &input,
        &camera(&input),
        size,
        |f| distortion_colour(log_area_ratio.get(f as usize).copied().flatten(), range),
        0.0,
    )
}
