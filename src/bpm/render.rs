//! Pictures of a textured mesh under BPM or linear UVs, on the CPU f64 reference rasteriser.
//! The GPU twin is `reparam-gpu`'s `bpm_render` (the same evaluation in a fragment shader).

use nalgebra::Vector3;

use super::eval::Interp;
use super::precompute::Bpm;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::raster::{rasterize, shade, Camera};
use crate::texture::{self, sample_bilinear, Image};

/// How to frame and size a picture. Defaults: 768×768, viewed from (0.4, 0.3, 1) (in front,
/// slightly right and above), BPM, a light grey background.
#[derive(Clone, Copy, Debug)]
pub struct RenderOptions {
    pub width: u32,
    pub height: u32,
    /// Direction from the mesh's centre towards the eye.
    pub view_dir: Vector3<f64>,
    pub interp: Interp,
    pub background: [u8; 4],
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 768,
            height: 768,
            view_dir: Vector3::new(0.4, 0.3, 1.0),
            interp: Interp::Bpm,
            background: [235, 235, 235, 255],
        }
    }
}

/// The camera that frames `mesh` for `options` (shared by the CPU and GPU renders so their
/// pictures align pixel for pixel).
pub fn camera_for(mesh: &TriMesh, options: &RenderOptions) -> Camera {
    Camera::frame_mesh(
        mesh,
        options.view_dir,
        options.width as f64 / options.height as f64,
    )
}

/// Render `mesh` textured with `texture` under the interpolant `options.interp`: per pixel,
/// colour = bilinear(texture, f(face, barycentrics)) with f the BPM or linear UV. No lighting,
/// so the picture shows the parameterisation only.
pub fn render_cpu(
    mesh: &TriMesh,
    bpm: &Bpm,
    texture: &Image<[u8; 4]>,
    options: &RenderOptions,
) -> Image<[u8; 4]> {
    let view_proj = camera_for(mesh, options).view_proj();
    let frame = rasterize(
        mesh,
        &view_proj,
        options.width as usize,
        options.height as usize,
    );
    shade(&frame, options.background, |face, bary| {
        let uv = bpm.eval(face as usize, bary, options.interp);
        let c = sample_bilinear(texture, [uv.re, uv.im]);
        c.map(|x| x.round().clamp(0.0, 255.0) as u8)
    })
}

/// The texture to render `mesh` with: `override_path` if given, else the mesh's material texture
/// (an error naming both files if the material names one that does not exist), else a built-in
/// UV grid.
pub fn resolve_texture(
    mesh: &TriMesh,
    override_path: Option<&std::path::Path>,
) -> Result<Image<[u8; 4]>> {
    if let Some(path) = override_path {
        return texture::load_rgba8(path);
    }
    match &mesh.texture {
        Some(path) if !path.exists() => Err(Error::MissingTexture {
            mesh: mesh.name.clone(),
            texture: path.clone(),
        }),
        Some(path) => texture::load_rgba8(path),
        None => Ok(texture::uv_grid_texture(1024)),
    }
}
