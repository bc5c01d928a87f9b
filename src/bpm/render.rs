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

/// Where [`s_picture`] looks at the mesh from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum SView {
    /// The 3D surface from `RenderOptions::view_dir`, shaded by |n·v|. Default.
    #[default]
    Surface,
    /// The UV layout, seen from +w (u to the right, v up).
    Uv,
}

/// Colours of the five s bins ([`super::conformality::S_BIN_LABELS`]): green (near-conformal)
/// through yellow to dark red (ColorBrewer RdYlGn, reversed); grey for degenerate faces.
pub const S_BIN_COLOURS: [[u8; 4]; 5] = [
    [26, 152, 80, 255],
    [166, 217, 106, 255],
    [254, 224, 139, 255],
    [244, 109, 67, 255],
    [165, 0, 38, 255],
];

/// Colour of a face without s (degenerate: interpolated linearly by BPM).
pub const S_UNMEASURED_COLOUR: [u8; 4] = [150, 150, 150, 255];

/// A picture of `mesh` with every face coloured by its s bin ([`S_BIN_COLOURS`]), in the 3D
/// view (flat colour × (0.45 + 0.55 |n·v|), n the face normal, v the view direction) or in the
/// UV layout, with a legend panel on the right: one line per bin with its area share and, when
/// `by_bin` holds the bins' QC ([`super::conformality::conformality_report`] with per-face
/// figures), BPM's and linear's area-average QC in the bin.
pub fn s_picture(
    mesh: &TriMesh,
    conformality: &super::conformality::Conformality,
    view: SView,
    options: &RenderOptions,
    by_bin: &[super::conformality::BinQc],
) -> Result<Image<[u8; 4]>> {
    use super::conformality::{s_bin, s_distribution, S_BIN_LABELS};
    let face_colour = |f: usize| match s_bin(conformality.face_s[f]) {
        Some(bin) => S_BIN_COLOURS[bin],
        None => S_UNMEASURED_COLOUR,
    };
    let picture = match view {
        SView::Surface => {
            let dir = options.view_dir.normalize();
            let shading: Vec<f64> = (0..mesh.face_count())
                .map(|f| {
                    let [a, b, c] = mesh.face_positions(f);
                    let n = (b - a).cross(&(c - a));
                    let cos = (n.dot(&dir) / n.norm()).abs();
                    if cos.is_finite() {
                        0.45 + 0.55 * cos
                    } else {
                        0.45
                    }
                })
                .collect();
            flat_picture(mesh, options, |f| {
                let (c, k) = (face_colour(f), shading[f]);
                [0, 1, 2, 3].map(|i| match i {
                    3 => 255,
                    _ => (c[i] as f64 * k).round() as u8,
                })
            })
        }
        SView::Uv => {
            let flat = uv_layout_mesh(mesh);
            let uv_options = RenderOptions {
                view_dir: Vector3::new(0.0, 0.0, 1.0),
                ..*options
            };
            flat_picture(&flat, &uv_options, face_colour)
        }
    };
    let distribution = s_distribution(conformality);
    let qc_of = |bin: usize| match by_bin.get(bin) {
        Some(b) => match (b.bpm_mean, b.linear_mean) {
            (Some(bpm), Some(linear)) => format!(
                "  QC {} | {}",
                crate::report::sig(bpm, 3),
                crate::report::sig(linear, 3)
            ),
            _ => String::new(),
        },
        None => String::new(),
    };
    let mut entries: Vec<([u8; 4], String)> = (0..5)
        .map(|bin| {
            (
                S_BIN_COLOURS[bin],
                format!(
                    "{:<12} {:>5}%{}",
                    S_BIN_LABELS[bin],
                    crate::report::sig(100.0 * distribution.area_share[bin], 3),
                    qc_of(bin)
                ),
            )
        })
        .collect();
    if distribution.unmeasured_faces > 0 {
        entries.push((
            S_UNMEASURED_COLOUR,
            format!("degenerate: {} faces", distribution.unmeasured_faces),
        ));
    }
    let file_name = std::path::Path::new(&mesh.name)
        .file_name()
        .map_or(mesh.name.clone(), |n| n.to_string_lossy().into_owned());
    let notes = [
        format!(
            "{file_name}, {} view",
            match view {
                SView::Surface => "3D",
                SView::Uv => "UV",
            }
        ),
        "s = max over a face's edges of".to_string(),
        "    |log(cr_uv / cr_3d)|, the edge quad's".to_string(),
        "    cross-ratio mismatch (0: conformal)".to_string(),
        format!(
            "area-weighted mean s {}, max {}",
            crate::report::sig(distribution.mean, 3),
            crate::report::sig(distribution.max, 3)
        ),
        match by_bin.is_empty() {
            true => "per bin: % of the area".to_string(),
            false => "per bin: % of the area, QC bpm | linear".to_string(),
        },
    ];
    let legend = crate::plot::legend_panel(
        "cross-ratio mismatch s",
        &notes,
        &entries,
        (options.width as usize * 2 / 3).clamp(440, 800),
        options.height as usize,
    )?;
    Ok(texture::side_by_side(&[&picture, &legend], 0))
}

/// `mesh` drawn with one flat colour per face on the background.
fn flat_picture(
    mesh: &TriMesh,
    options: &RenderOptions,
    colour: impl Fn(usize) -> [u8; 4] + Sync,
) -> Image<[u8; 4]> {
    let view_proj = camera_for(mesh, options).view_proj();
    let frame = rasterize(
        mesh,
        &view_proj,
        options.width as usize,
        options.height as usize,
    );
    shade(&frame, options.background, |face, _| colour(face as usize))
}

/// The UV layout as a flat mesh: one vertex (u, v, 0) per texture coordinate, the UV faces.
fn uv_layout_mesh(mesh: &TriMesh) -> TriMesh {
    let positions = mesh
        .uvs
        .iter()
        .map(|t| nalgebra::Point3::new(t.x, t.y, 0.0))
        .collect();
    TriMesh {
        positions,
        uvs: Vec::new(),
        faces: mesh.uv_faces.clone(),
        uv_faces: Vec::new(),
        texture: None,
        name: format!("{} (UV layout)", mesh.name),
    }
}
