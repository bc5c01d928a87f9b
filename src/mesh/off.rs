//! Reading OFF meshes (Geomview "Object File Format"): a small own parser, in file order, with
//! typed `path:line` errors.
//!
//! Accepted: an optional `OFF` header line (also `COFF`/`NOFF`/`CNOFF`, whose extra per-vertex
//! values are ignored), then `V F E`, then `V` lines `x y z …`, then `F` lines `n i₀ … iₙ₋₁ …`
//! (0-based; polygons split into the fan `(i₀, iₖ, iₖ₊₁)`, trailing colour values ignored).
//! `#` starts a comment; blank lines are skipped.

use std::path::Path;

use nalgebra::Point3;

use super::trimesh::TriMesh;
use crate::error::{Error, Result};
use crate::input::{check_count, read_input_text};

/// Load an OFF file as a [`TriMesh`] named after `path` (no UVs).
///
/// Errors: [`Error::Io`] when unreadable, [`Error::NotAFile`] for a device, FIFO or directory;
/// [`Error::MeshParse`] naming `path:line` for syntax errors, for a face with fewer than 3
/// corners and for counts the file cannot hold ([`check_count`]); [`Error::NonFinite`] /
/// [`Error::IndexOutOfRange`] / [`Error::EmptyMesh`] from [`TriMesh::validate`].
pub fn load_off(path: &Path) -> Result<TriMesh> {
    let text = read_input_text(path)?;
    let mesh = parse_off(&text, path)?;
    mesh.validate()?;
    Ok(mesh)
}

/// The data lines of an OFF file: `(1-based line number, byte offset of the line's end,
/// words)`, comments and blanks removed.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, usize, Vec<&str>)> {
    let mut end = 0;
    text.split_inclusive('\n')
        .enumerate()
        .filter_map(move |(n, line)| {
            end += line.len();
            let line = line.split('#').next().unwrap_or("");
            let words: Vec<&str> = line.split_whitespace().collect();
            (!words.is_empty()).then_some((n + 1, end, words))
        })
}

/// Fewest bytes a vertex line takes (`0 0 0` and a newline): the declared vertex count must fit
/// in the bytes after the counts line.
const MIN_VERTEX_BYTES: u64 = 6;
/// Fewest bytes a face line takes (`3 0 1 2` and a newline), one triangle at least.
const MIN_FACE_BYTES: u64 = 8;

/// Parse OFF text (see the module docs); `path` is only used in error messages.
pub fn parse_off(text: &str, path: &Path) -> Result<TriMesh> {
    let err = |line: usize, message: String| Error::MeshParse {
        path: path.to_path_buf(),
        message: format!("line {line}: {message}"),
    };
    let mut lines = data_lines(text).peekable();
    if let Some((n, _, words)) = lines.next_if(|(_, _, words)| words[0].ends_with("OFF")) {
        if words[0] != "OFF" && words[0] != "COFF" && words[0] != "NOFF" && words[0] != "CNOFF" {
            return Err(err(1, format!("unsupported header {}", words[0])));
        }
        if words.len() > 1 {
            return Err(err(n, "the counts must be on their own line".into()));
        }
    }
    let (count_line, counts_end, counts) = lines
        .next()
        .ok_or_else(|| err(1, "missing the `V F E` counts line".into()))?;
    let parse_count = |w: Option<&&str>, what: &str| -> Result<u64> {
        w.and_then(|w| w.parse::<u64>().ok())
            .ok_or_else(|| err(count_line, format!("cannot read the {what} count")))
    };
    let (vertex_count, face_count) = (
        parse_count(counts.first(), "vertex")?,
        parse_count(counts.get(1), "face")?,
    );
    // The declared counts must fit in the text after the counts line (plus the newline the
    // last line may lack) before anything is reserved for them: a header claiming 10¹¹ vertices
    // in a 14-byte file is an error here, not an allocation.
    let after_counts = (text.len() - counts_end) as u64 + 1;
    let unit = "bytes after the counts line";
    let vertex_count = check_count(
        "the vertex count",
        vertex_count,
        MIN_VERTEX_BYTES,
        after_counts,
        unit,
    )
    .map_err(|m| err(count_line, m))?;
    let face_room = after_counts - vertex_count as u64 * MIN_VERTEX_BYTES;
    let face_count = check_count(
        "the face count",
        face_count,
        MIN_FACE_BYTES,
        face_room,
        unit,
    )
    .map_err(|m| err(count_line, m))?;
    let mut positions = Vec::with_capacity(vertex_count);
    let mut faces = Vec::with_capacity(face_count);
    for _ in 0..vertex_count {
        let (n, _, words) = lines
            .next()
            .ok_or_else(|| err(count_line, format!("expected {vertex_count} vertices")))?;
        if words.len() < 3 {
            return Err(err(n, "a vertex needs x y z".into()));
        }
        let mut xyz = [0.0; 3];
        for (a, w) in words[..3].iter().enumerate() {
            xyz[a] = w
                .parse::<f64>()
                .map_err(|_| err(n, format!("cannot read coordinate `{w}`")))?;
        }
        positions.push(Point3::new(xyz[0], xyz[1], xyz[2]));
    }
    for _ in 0..face_count {
        let (n, _, words) = lines
            .next()
            .ok_or_else(|| err(count_line, format!("expected {face_count} faces")))?;
        let corners: u64 = words[0]
            .parse()
            .map_err(|_| err(n, format!("cannot read the corner count `{}`", words[0])))?;
        if corners < 3 {
            return Err(err(
                n,
                format!("a face needs at least 3 corners, got {corners}"),
            ));
        }
        // One word per corner on this line: 2⁶⁴ − 1 corners was a `capacity overflow` panic.
        let unit = "words after it on the line";
        let corners = check_count("the corner count", corners, 1, words.len() as u64 - 1, unit)
            .map_err(|m| err(n, m))?;
        let mut idx = Vec::with_capacity(corners);
        for w in &words[1..=corners] {
            idx.push(
                w.parse::<u32>()
                    .map_err(|_| err(n, format!("cannot read vertex index `{w}`")))?,
            );
        }
        for k in 1..corners - 1 {
            faces.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    Ok(TriMesh::with_shared_indices(
        path.display().to_string(),
        positions,
        Vec::new(),
        faces,
    ))
}
