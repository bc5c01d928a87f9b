//! Reading and writing Wavefront OBJ meshes (with the diffuse texture named by the MTL file).
//!
//! Loading builds the [`TriMesh`] straight from the file, in file order: vertex `i` is the
//! `i`-th `v` line, texture coordinate `j` the `j`-th `vt` line, and position and
//! texture-coordinate indices stay separate, so a UV seam stays one edge of the surface. The
//! parser is in `obj_check.rs`.

use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use super::obj_check::{keyword, parse_obj, statement_argument};
use super::trimesh::TriMesh;
use crate::error::{Error, Result};
use crate::input::{read_input_text, Length, Reference};

/// Load an OBJ file as one [`TriMesh`] named after `path`.
///
/// - `positions` are the `v` lines in file order (a weight or vertex colour after `x y z` is
///   ignored), `uvs` the `vt` lines in file order (`u v`; a `w` is ignored). Nothing is
///   renumbered, merged or welded: two `v` lines with the same coordinates stay two vertices.
/// - `faces` are the `f` statements in file order, polygons split into the triangle fan
///   `(c₀, cₖ, cₖ₊₁)`. Corners may be `v`, `v/vt`, `v//vn` or `v/vt/vn`, with 1-based or
///   negative (relative to the elements read so far) indices. `uv_faces` is filled when the
///   faces have `vt` indices (all faces must, or none).
/// - Objects, groups, smoothing groups and material runs are all one mesh; normals, `vp`, `l`
///   (polylines) and `p` (points) are ignored. `#` starts a comment; a line ending in `\`
///   continues on the next line.
/// - `texture` is the `map_Kd` of the first material that has one, in the first material
///   library that has one, resolved relative to the OBJ's directory. A missing MTL file means no
///   texture; whether the texture file itself exists is for the caller to check.
/// - Both references follow [`crate::input::Reference`]: by default they must stay in the OBJ's
///   folder, and an existing one must be a regular file (a device, a FIFO or a directory is
///   refused, not read); the library is read only up to [`MAX_MTL_BYTES`].
///
/// Errors name the file and the element: [`Error::Io`] when the file cannot be read,
/// [`Error::NotAFile`] when it is not a regular file, [`Error::Reference`] for a refused
/// `mtllib` or `map_Kd` (naming the OBJ, the statement, the name and why),
/// [`Error::NonFinite`] for a `nan`/`inf` coordinate, [`Error::IndexOutOfRange`] /
/// [`Error::PartialUvs`] / [`Error::DegenerateFace`] for bad faces (mesh name `path:line`,
/// face = number of the `f` statement from 0, vertex = number of the `v` statement from 0),
/// [`Error::MeshParse`] for other syntax errors, [`Error::EmptyMesh`] when there is no face.
/// For a file of triangles, face and vertex numbers in errors of later algorithms are the same
/// numbers.
pub fn load_obj(path: &Path) -> Result<TriMesh> {
    let text = read_input_text(path)?;
    let parsed = parse_obj(&text, path)?;
    let mut mesh = parsed.mesh;
    mesh.texture = find_diffuse_texture(path, &parsed.material_libraries)?;
    mesh.validate()?;
    Ok(mesh)
}

/// Largest material library read, in bytes: an MTL is a few hundred bytes of text, so a
/// larger one is almost surely a wrong `mtllib` (or a device file), refused rather than read.
pub const MAX_MTL_BYTES: u64 = 16 << 20;

/// The first `map_Kd` in the first readable material library that has one, resolved relative to
/// the OBJ's directory. A missing or unreadable library is skipped (no texture, not an error);
/// one outside the OBJ's folder (by default), not a regular file (`mtllib /dev/zero`) or larger
/// than [`MAX_MTL_BYTES`] is an error ([`Reference::read`]), since reading it would never end
/// or fill the memory. The texture is checked the same way, its reading left to the caller.
fn find_diffuse_texture(obj_path: &Path, libraries: &[String]) -> Result<Option<PathBuf>> {
    for library in libraries {
        let mtllib = Reference {
            model: obj_path,
            kind: "mtllib",
            written: library,
        };
        let Ok(bytes) = mtllib.read(Length::AtMost(MAX_MTL_BYTES))? else {
            continue;
        };
        let Ok(mtl_text) = String::from_utf8(bytes) else {
            continue;
        };
        if let Some(texture) = first_map_kd(&mtl_text) {
            let map_kd = Reference {
                model: obj_path,
                kind: "map_Kd (in the material library)",
                written: texture,
            };
            return map_kd.resolve_file().map(Some);
        }
    }
    Ok(None)
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
    writeln!(
        out,
        "# {} faces, written by reparam from {}",
        mesh.faces.len(),
        mesh.name
    )
    .map_err(io_error)?;
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
