//! Reading and writing Wavefront OBJ meshes (with the diffuse texture named by the MTL file).
//!
//! Loading keeps separate position and texture-coordinate indices (`tobj` with
//! `single_index: false`), so a UV seam stays one edge of the surface; see [`TriMesh`].

use std::borrow::Cow;
use std::collections::HashMap;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use nalgebra::{Point2, Point3};

use super::obj_check::{check_obj_text, keyword, statement_argument};
use super::trimesh::TriMesh;
use crate::error::{Error, Result};

/// Load an OBJ file as one [`TriMesh`] named after `path`.
///
/// - Polygons are triangulated as fans; `l` (polyline) statements are ignored.
/// - All objects, groups and material runs are merged into one mesh. `tobj` gives each of them
///   its own copy of the positions it uses; copies of the same position are joined again
///   (exact coordinate equality, across parts only), so faces of different parts stay connected.
/// - `uv_faces` is filled when the faces have `vt` indices (all faces must, or none).
/// - `texture` is the `map_Kd` of the first material that has one, in the first material
///   library that has one, resolved relative to the OBJ's directory. A missing MTL file means no
///   texture; whether the texture file itself exists is for the caller to check.
///
/// Errors name the file and the element: [`Error::Io`] when the file cannot be read,
/// [`Error::NonFinite`] for a `nan`/`inf` coordinate, [`Error::IndexOutOfRange`] /
/// [`Error::PartialUvs`] / [`Error::DegenerateFace`] for bad faces (mesh name `path:line`,
/// face = number of the `f` statement from 0, vertex = number of the `v` statement from 0),
/// [`Error::MeshParse`] for other syntax errors, [`Error::EmptyMesh`] when there is no face.
pub fn load_obj(path: &Path) -> Result<TriMesh> {
    let text = fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let summary = check_obj_text(&text, path)?;
    let models = parse_with_tobj(&without_polylines(&text), path)?;
    let mut mesh = merge_models(&models, path.display().to_string())?;
    mesh.texture = find_diffuse_texture(path, &summary.material_libraries);
    mesh.validate()?;
    Ok(mesh)
}

/// `tobj` reads `l` statements of three or more points as faces; a surface has no use for them.
fn without_polylines(text: &str) -> Cow<'_, str> {
    let is_polyline = |line: &str| keyword(line) == Some("l");
    if !text.lines().any(is_polyline) {
        return Cow::Borrowed(text);
    }
    let kept: Vec<&str> = text.lines().filter(|line| !is_polyline(line)).collect();
    Cow::Owned(kept.join("\n"))
}

/// Run `tobj` on already-checked text. Materials are not loaded here (see
/// [`find_diffuse_texture`]): `tobj`'s MTL parser panics on some malformed lines.
fn parse_with_tobj(text: &str, path: &Path) -> Result<Vec<tobj::Model>> {
    let options = tobj::LoadOptions {
        single_index: false,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let no_materials = |_: &Path| Ok((Vec::new(), Default::default()));
    let (models, _materials) =
        tobj::load_obj_buf(&mut text.as_bytes(), &options, no_materials).map_err(|e| {
            Error::MeshParse {
                path: path.to_path_buf(),
                message: e.to_string(),
            }
        })?;
    Ok(models)
}

/// Append all `tobj` models into one mesh, offsetting indices (see [`load_obj`] for the joining
/// of positions shared between models).
fn merge_models(models: &[tobj::Model], name: String) -> Result<TriMesh> {
    let mut mesh = TriMesh {
        name,
        ..Default::default()
    };
    let with_uvs = models.iter().any(|m| !m.mesh.texcoord_indices.is_empty());
    let mut earlier_positions: HashMap<[u64; 3], u32> = HashMap::new();
    for model in models {
        let part = &model.mesh;
        let position_ids = append_positions(&mut mesh.positions, &part.positions, &mut earlier_positions);
        let remap = |t: &[u32]| [0, 1, 2].map(|k| position_ids[t[k] as usize]);
        mesh.faces.extend(part.indices.chunks_exact(3).map(remap));
        if with_uvs {
            if part.texcoord_indices.len() != part.indices.len() {
                return Err(Error::PartialUvs {
                    mesh: mesh.name.clone(),
                    face: mesh.faces.len() - part.indices.len() / 3,
                });
            }
            let offset = mesh.uvs.len() as u32;
            let shift = |t: &[u32]| [t[0] + offset, t[1] + offset, t[2] + offset];
            mesh.uv_faces.extend(part.texcoord_indices.chunks_exact(3).map(shift));
            mesh.uvs.extend(part.texcoords.chunks_exact(2).map(|t| Point2::new(t[0], t[1])));
        }
    }
    Ok(mesh)
}

/// Append the flat `xyz` list of one model to `positions`, reusing a position of an *earlier*
/// model when the coordinates are bit-identical. Returns the new index of each model position.
fn append_positions(
    positions: &mut Vec<Point3<f64>>,
    flat_xyz: &[f64],
    earlier: &mut HashMap<[u64; 3], u32>,
) -> Vec<u32> {
    let key = |p: &[f64]| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
    let ids: Vec<u32> = flat_xyz
        .chunks_exact(3)
        .map(|p| match earlier.get(&key(p)) {
            Some(&id) => id,
            None => {
                positions.push(Point3::new(p[0], p[1], p[2]));
                (positions.len() - 1) as u32
            }
        })
        .collect();
    for (p, &id) in flat_xyz.chunks_exact(3).zip(&ids) {
        earlier.entry(key(p)).or_insert(id);
    }
    ids
}

/// The first `map_Kd` in the first readable material library that has one, resolved relative to
/// the OBJ's directory. A missing or unreadable library is skipped (no texture, not an error).
fn find_diffuse_texture(obj_path: &Path, libraries: &[String]) -> Option<PathBuf> {
    let dir = obj_path.parent().unwrap_or(Path::new(""));
    for library in libraries {
        let Ok(mtl_text) = fs::read_to_string(dir.join(library)) else {
            continue;
        };
        if let Some(texture) = first_map_kd(&mtl_text) {
            return Some(dir.join(texture));
        }
    }
    None
}

/// The file named by the first `map_Kd` statement. Options (`map_Kd -s 1 1 1 file.png`) are
/// skipped by taking the last word; otherwise the whole rest of the line (names may have spaces).
fn first_map_kd(mtl_text: &str) -> Option<&str> {
    let line = mtl_text.lines().find(|l| keyword(l) == Some("map_Kd"))?;
    let argument = statement_argument(line, "map_Kd");
    let name = if argument.starts_with('-') {
        argument.split_whitespace().last()?
    } else {
        argument
    };
    (!name.is_empty()).then_some(name)
}

/// Write `mesh` as OBJ: `v x y z`, `vt u v`, and `f v/vt ...` (1-based; `f v ...` without UVs).
/// When the mesh has a texture, also write `<stem>.mtl` next to it with one material whose
/// `map_Kd` is the texture (relative to the OBJ's directory when inside it, else absolute),
/// and reference it with `mtllib`/`usemtl`. Parent directories are created.
///
/// Numbers are written in Rust's shortest round-trip form, so loading gives the same `f64`s.
pub fn write_obj(mesh: &TriMesh, path: &Path) -> Result<()> {
    let io_error = |e| Error::io(path, e);
    create_parent_dir(path)?;
    let mut out = BufWriter::new(fs::File::create(path).map_err(io_error)?);
    writeln!(out, "# {} faces, written by reparam from {}", mesh.faces.len(), mesh.name).map_err(io_error)?;
    if let Some(texture) = &mesh.texture {
        let mtl_path = path.with_extension("mtl");
        write_mtl(&mtl_path, &texture_reference(texture, path))?;
        let mtl_name = mtl_path.file_name().unwrap_or_default().to_string_lossy();
        writeln!(out, "mtllib {mtl_name}\nusemtl {MATERIAL_NAME}").map_err(io_error)?;
    }
    write_obj_body(&mut out, mesh).map_err(io_error)?;
    out.flush().map_err(io_error)
}

/// Name of the single material written by [`write_obj`].
const MATERIAL_NAME: &str = "textured";

fn write_obj_body(out: &mut impl Write, mesh: &TriMesh) -> std::io::Result<()> {
    for p in &mesh.positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in &mesh.uvs {
        writeln!(out, "vt {} {}", t.x, t.y)?;
    }
    for (f, tri) in mesh.faces.iter().enumerate() {
        write!(out, "f")?;
        for k in 0..3 {
            match mesh.uv_faces.get(f) {
                Some(uv_tri) => write!(out, " {}/{}", tri[k] + 1, uv_tri[k] + 1)?,
                None => write!(out, " {}", tri[k] + 1)?,
            }
        }
        writeln!(out)?;
    }
    Ok(())
}

fn write_mtl(mtl_path: &Path, texture: &Path) -> Result<()> {
    let text = format!(
        "newmtl {MATERIAL_NAME}\nKa 0 0 0\nKd 1 1 1\nKs 0 0 0\nillum 1\nmap_Kd {}\n",
        texture.display()
    );
    fs::write(mtl_path, text).map_err(|e| Error::io(mtl_path, e))
}

/// How the MTL next to `obj_path` should name `texture`: relative when it lies in the OBJ's
/// directory (or below), absolute otherwise (falling back to the path as given).
fn texture_reference(texture: &Path, obj_path: &Path) -> PathBuf {
    let absolute = |p: &Path| std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let texture = absolute(texture);
    let dir = absolute(obj_path.parent().unwrap_or(Path::new("")));
    match texture.strip_prefix(&dir) {
        Ok(relative) => relative.to_path_buf(),
        Err(_) => texture,
    }
}

/// Create the directory that will hold `path`, if it has one.
pub(crate) fn create_parent_dir(path: &Path) -> Result<()> {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => {
            fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
        }
        _ => Ok(()),
    }
}
