//! Reading PLY meshes (ASCII and binary, any scalar types) with the `ply-rs` crate.
//!
//! Used: element `vertex` with properties `x y z`, element `face` with a list property
//! `vertex_indices` (or `vertex_index`); polygons split into the fan `(i₀, iₖ, iₖ₊₁)`. Other
//! elements and properties (normals, colours, texture coordinates) are ignored.

use std::fs::File;
use std::io::BufReader;
use std::path::Path;

use nalgebra::Point3;
use ply_rs::parser::Parser;
use ply_rs::ply::{DefaultElement, Property};

use super::trimesh::TriMesh;
use crate::error::{Error, Result};

/// Load a PLY file as a [`TriMesh`] named after `path` (no UVs).
///
/// Errors: [`Error::Io`] when unreadable; [`Error::MeshParse`] when `ply-rs` rejects the file,
/// when `vertex`/`face` or `x y z`/`vertex_indices` are missing or of a wrong type (naming the
/// element number), or a face has fewer than 3 corners; [`Error::NonFinite`] /
/// [`Error::IndexOutOfRange`] / [`Error::EmptyMesh`] from [`TriMesh::validate`].
pub fn load_ply(path: &Path) -> Result<TriMesh> {
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let mut reader = BufReader::new(file);
    let err = |message: String| Error::MeshParse {
        path: path.to_path_buf(),
        message,
    };
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut reader)
        .map_err(|e| err(format!("PLY: {e}")))?;
    let vertices = ply
        .payload
        .get("vertex")
        .ok_or_else(|| err("no `vertex` element".into()))?;
    let mut positions = Vec::with_capacity(vertices.len());
    for (i, v) in vertices.iter().enumerate() {
        let mut xyz = [0.0; 3];
        for (a, name) in ["x", "y", "z"].iter().enumerate() {
            xyz[a] = v
                .get(*name)
                .and_then(scalar)
                .ok_or_else(|| err(format!("vertex {i}: no numeric property `{name}`")))?;
        }
        positions.push(Point3::new(xyz[0], xyz[1], xyz[2]));
    }
    let empty = Vec::new();
    let face_elements = ply.payload.get("face").unwrap_or(&empty);
    let mut faces = Vec::with_capacity(face_elements.len());
    for (f, face) in face_elements.iter().enumerate() {
        let list = face
            .get("vertex_indices")
            .or_else(|| face.get("vertex_index"))
            .and_then(index_list)
            .ok_or_else(|| err(format!("face {f}: no integer list `vertex_indices`")))?;
        if list.len() < 3 {
            return Err(err(format!(
                "face {f}: {} corners, at least 3 needed",
                list.len()
            )));
        }
        for k in 1..list.len() - 1 {
            faces.push([list[0], list[k], list[k + 1]]);
        }
    }
    let mesh =
        TriMesh::with_shared_indices(path.display().to_string(), positions, Vec::new(), faces);
    mesh.validate()?;
    Ok(mesh)
}

/// A scalar property as f64 (lists are not scalars).
fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x as f64,
        Property::UChar(x) => x as f64,
        Property::Short(x) => x as f64,
        Property::UShort(x) => x as f64,
        Property::Int(x) => x as f64,
        Property::UInt(x) => x as f64,
        Property::Float(x) => x as f64,
        Property::Double(x) => x,
        _ => return None,
    })
}

/// An integer list property as u32 indices; `None` for a negative index or a non-integer list.
fn index_list(p: &Property) -> Option<Vec<u32>> {
    fn conv<T: Copy + TryInto<u32>>(v: &[T]) -> Option<Vec<u32>> {
        v.iter().map(|&x| x.try_into().ok()).collect()
    }
    match p {
        Property::ListChar(v) => conv(v),
        Property::ListUChar(v) => conv(v),
        Property::ListShort(v) => conv(v),
        Property::ListUShort(v) => conv(v),
        Property::ListInt(v) => conv(v),
        Property::ListUInt(v) => Some(v.clone()),
        _ => None,
    }
}
