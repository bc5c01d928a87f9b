//! Reading PLY meshes (ASCII and binary, any scalar types) with the `ply-rs` crate.
//!
//! Used: element `vertex` with properties `x y z`, element `face` with a list property
//! `vertex_indices` (or `vertex_index`); polygons split into the fan `(i₀, iₖ, iₖ₊₁)`. Other
//! elements and properties (normals, colours, texture coordinates) are ignored.

use std::io::Cursor;
use std::path::Path;

use nalgebra::Point3;
use ply_rs::parser::Parser;
use ply_rs::ply::{DefaultElement, Property};

use super::trimesh::TriMesh;
use crate::error::{Error, Result};
use crate::input::{check_count, read_input};

/// Load a PLY file as a [`TriMesh`] named after `path` (no UVs).
///
/// The header is checked first (`check_header`) so that `ply-rs` never sees a number it
/// would overflow on (it panics) nor a declared count the file cannot hold (it would allocate
/// for it); of the crate's own multi-line errors the first line is kept.
///
/// Errors: [`Error::Io`] when unreadable, [`Error::NotAFile`] for a device, FIFO or directory;
/// [`Error::MeshParse`] when `ply-rs` rejects the file,
/// when `vertex`/`face` or `x y z`/`vertex_indices` are missing or of a wrong type (naming the
/// element number), or a face has fewer than 3 corners; [`Error::NonFinite`] /
/// [`Error::IndexOutOfRange`] / [`Error::EmptyMesh`] from [`TriMesh::validate`].
pub fn load_ply(path: &Path) -> Result<TriMesh> {
    let bytes = read_input(path)?;
    let err = |message: String| Error::MeshParse {
        path: path.to_path_buf(),
        message,
    };
    check_header(&bytes).map_err(err)?;
    let ply = Parser::<DefaultElement>::new()
        .read_ply(&mut Cursor::new(&bytes))
        .map_err(|e| err(format!("PLY: {}", one_line(&e.to_string()))))?;
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

/// Check the PLY header before `ply-rs` reads it, for the two things that crate does not survive:
///
/// - a version or element count above `u64::MAX` (its grammar unwraps the parse and panics);
/// - declared counts the data cannot hold: every element takes at least one byte in ASCII
///   (its line break) and the sum of its properties' fixed sizes in binary (a list at least its
///   count), counted as one byte when that is zero, so that an element without properties
///   cannot be "read" 10¹² times from nothing. The counts times those sizes must fit in the
///   bytes after the header.
///
/// A file not starting with `ply` is refused here too (with a plain message). Anything else (a
/// malformed line, a missing `end_header`) is left to `ply-rs`, whose message's first line is
/// kept.
/// Errors are one line naming the header line.
fn check_header(bytes: &[u8]) -> std::result::Result<(), String> {
    let mut offset = 0;
    let mut binary = false;
    // (element line, count, minimum bytes per element)
    let mut elements: Vec<(usize, u64, u64)> = Vec::new();
    let mut data_start = None;
    let first = bytes.split(|&b| b == b'\n').next().unwrap_or(&[]);
    if first.trim_ascii() != b"ply" {
        return Err("header line 1: the file does not start with `ply` (not a PLY file)".into());
    }
    for (number, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        offset += raw.len() + 1;
        let line = String::from_utf8_lossy(raw);
        let words: Vec<&str> = line.split_whitespace().collect();
        let at = |message: String| format!("header line {}: {message}", number + 1);
        match words.first().copied() {
            Some("format") => {
                binary = words.get(1).is_some_and(|w| w.starts_with("binary"));
                let version = words.get(2).copied().unwrap_or("");
                for part in version.splitn(2, '.') {
                    leading_u64(part).map_err(|digits| {
                        at(format!("version number {digits} does not fit in 64 bits"))
                    })?;
                }
            }
            Some("element") => {
                let count = leading_u64(words.get(2).copied().unwrap_or("")).map_err(|digits| {
                    at(format!("element count {digits} does not fit in 64 bits"))
                })?;
                elements.push((number + 1, count, u64::from(!binary)));
            }
            Some("property") => {
                if let Some(last) = elements.last_mut() {
                    if binary {
                        last.2 += property_min_bytes(&words);
                    }
                }
            }
            Some("end_header") => {
                data_start = Some(offset.min(bytes.len()));
                break;
            }
            _ => {}
        }
    }
    let Some(data_start) = data_start else {
        return Ok(());
    };
    // Cumulatively: each element's count must fit in what the elements before it left.
    let mut available = (bytes.len() - data_start) as u64;
    for &(line, count, min_bytes) in &elements {
        let unit = "bytes of data left after the header and the elements before it";
        check_count("the element count", count, min_bytes, available, unit)
            .map_err(|m| format!("header line {line}: {m}"))?;
        available -= count * min_bytes.max(1);
    }
    Ok(())
}

/// The leading run of ASCII digits of `word` as a u64 (0 when there is none); `Err(digits)`
/// when it does not fit.
fn leading_u64(word: &str) -> std::result::Result<u64, String> {
    let digits: String = word.chars().take_while(|c| c.is_ascii_digit()).collect();
    if digits.is_empty() {
        return Ok(0);
    }
    digits.parse().map_err(|_| digits)
}

/// Fewest bytes one binary value of a `property …` line takes: the scalar's size, or for a
/// `list` its count's size (an empty list). Unknown types count 0 (`ply-rs` rejects them).
fn property_min_bytes(words: &[&str]) -> u64 {
    let size = |t: &str| match t {
        "char" | "int8" | "uchar" | "uint8" => 1,
        "short" | "int16" | "ushort" | "uint16" => 2,
        "int" | "int32" | "uint" | "uint32" | "float" | "float32" => 4,
        "double" | "float64" => 8,
        _ => 0,
    };
    match words.get(1).copied() {
        Some("list") => words.get(2).map_or(0, |t| size(t)),
        Some(t) => size(t),
        None => 0,
    }
}

/// The first line of a `ply-rs` error: its message. The lines after it are the offending input
/// and a debug dump of the parser state, not for the user.
fn one_line(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty())
        .unwrap_or("unreadable file")
        .to_string()
}
