//! Line-level checks of an OBJ text, run before `tobj` parses it.
//!
//! `tobj` does the real parsing, but it cannot tell *where* a problem is, and on some bad input
//! it misbehaves instead of failing:
//! - `nan` and `inf` parse as numbers (Rust's `f64::from_str` accepts them);
//! - a face corner without a `vt` index, in a file that has `vt` lines, silently reuses the
//!   previous corner's texture coordinate;
//! - a relative index reaching far before the first element overflows (a panic in debug
//!   builds); an out-of-range index is reported without the face.
//!
//! This pass reads every `v`, `vt`, `vn` and `f` statement once, so that these cases become
//! typed errors naming the file, the line (as `path:line`), the face and the vertex.

use std::path::Path;

use crate::error::{Error, Result};

/// What the checked text contains, for the loader.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct ObjSummary {
    /// Number of `v`, `vt` and `vn` statements, in that order.
    pub counts: [usize; 3],
    /// The material libraries named by `mtllib` statements, in file order.
    pub material_libraries: Vec<String>,
}

/// The three kinds of indexed element a face corner `v/vt/vn` refers to.
const ELEMENT_NAMES: [&str; 3] = ["vertex", "texture coordinate", "normal"];

/// Check `text` (the contents of the OBJ file `path`): finite vertex and texture coordinates,
/// face corners that parse and refer to existing elements, and either all or no face corners
/// with texture coordinates. Returns the element counts and material libraries.
///
/// Faces are numbered from 0 in the order of the `f` statements (for a file of triangles this
/// is the triangle index); vertices from 0 in the order of the `v` statements.
pub(crate) fn check_obj_text(text: &str, path: &Path) -> Result<ObjSummary> {
    let summary = check_element_lines(text, path)?;
    check_face_lines(text, path, &summary)?;
    Ok(summary)
}

/// `path:line` (1-based line), the location used as the mesh name in errors.
pub(crate) fn location(path: &Path, line: usize) -> String {
    format!("{}:{}", path.display(), line)
}

/// The statement keyword of a line (`v`, `vt`, `f`, ...), or `None` for a blank line.
pub(crate) fn keyword(line: &str) -> Option<&str> {
    line.split_whitespace().next()
}

/// The rest of a statement after its keyword, trimmed (file names may contain spaces).
pub(crate) fn statement_argument<'a>(line: &'a str, keyword: &str) -> &'a str {
    line.trim_start()[keyword.len()..].trim()
}

/// First pass: count `v`, `vt`, `vn`; require finite numbers in `v` (3) and `vt` (2).
fn check_element_lines(text: &str, path: &Path) -> Result<ObjSummary> {
    let mut summary = ObjSummary::default();
    for (line_index, line) in text.lines().enumerate() {
        let line_no = line_index + 1;
        match keyword(line) {
            Some("v") => {
                check_coordinates(line, 3, "vertex", summary.counts[0], path, line_no)?;
                summary.counts[0] += 1;
            }
            Some("vt") => {
                check_coordinates(line, 2, "texture coordinate", summary.counts[1], path, line_no)?;
                summary.counts[1] += 1;
            }
            Some("vn") => summary.counts[2] += 1,
            Some("mtllib") => summary
                .material_libraries
                .push(statement_argument(line, "mtllib").to_string()),
            _ => {}
        }
    }
    Ok(summary)
}

/// The first `needed` numbers after the keyword must parse and be finite.
fn check_coordinates(
    line: &str,
    needed: usize,
    what: &'static str,
    index: usize,
    path: &Path,
    line_no: usize,
) -> Result<()> {
    let words: Vec<&str> = line.split_whitespace().skip(1).take(needed).collect();
    let values: Option<Vec<f64>> = words.iter().map(|w| w.parse::<f64>().ok()).collect();
    let values = match values {
        Some(v) if v.len() == needed => v,
        _ => {
            return Err(Error::MeshParse {
                path: path.to_path_buf(),
                message: format!("line {line_no}: {what} {index} needs {needed} numbers: `{}`", line.trim()),
            })
        }
    };
    if values.iter().all(|x| x.is_finite()) {
        return Ok(());
    }
    Err(Error::NonFinite {
        mesh: location(path, line_no),
        what,
        index,
        value: words.join(" "),
    })
}

/// Second pass: every `f` statement has at least 3 corners, each corner's indices resolve to
/// existing elements, and corners have a `vt` index exactly when the file has `vt` lines.
fn check_face_lines(text: &str, path: &Path, summary: &ObjSummary) -> Result<()> {
    let mut seen = [0usize; 3]; // elements defined so far, for relative (negative) indices
    let mut face = 0;
    for (line_index, line) in text.lines().enumerate() {
        let line_no = line_index + 1;
        match keyword(line) {
            Some("v") => seen[0] += 1,
            Some("vt") => seen[1] += 1,
            Some("vn") => seen[2] += 1,
            Some("f") => {
                let face_check = FaceCheck { path, line_no, face, seen, totals: summary.counts };
                face_check.check(line)?;
                face += 1;
            }
            _ => {}
        }
    }
    Ok(())
}

/// Everything needed to check one `f` statement and to name it in an error.
struct FaceCheck<'a> {
    path: &'a Path,
    line_no: usize,
    face: usize,
    /// Elements defined before this line (relative indices count back from here).
    seen: [usize; 3],
    /// Elements in the whole file (positive indices may refer forward).
    totals: [usize; 3],
}

impl FaceCheck<'_> {
    fn check(&self, line: &str) -> Result<()> {
        let corners: Vec<&str> = line.split_whitespace().skip(1).collect();
        if corners.len() < 3 {
            return Err(Error::DegenerateFace {
                mesh: location(self.path, self.line_no),
                face: self.face,
                reason: format!("{} corner(s), a face needs at least 3", corners.len()),
            });
        }
        corners.iter().try_for_each(|corner| self.check_corner(corner))
    }

    /// A corner is `v`, `v/vt`, `v//vn` or `v/vt/vn`, each index 1-based or negative (relative).
    fn check_corner(&self, corner: &str) -> Result<()> {
        let parts: Vec<&str> = corner.split('/').collect();
        if parts.len() > 3 || parts[0].is_empty() {
            return Err(self.parse_error(format!("cannot read face corner `{corner}`")));
        }
        for (kind, part) in parts.iter().enumerate() {
            if !part.is_empty() {
                self.check_index(kind, part)?;
            }
        }
        let has_uv = parts.get(1).is_some_and(|p| !p.is_empty());
        if self.totals[1] > 0 && !has_uv {
            return Err(Error::PartialUvs {
                mesh: location(self.path, self.line_no),
                face: self.face,
            });
        }
        Ok(())
    }

    /// Resolve one OBJ index of element `kind` (0 = v, 1 = vt, 2 = vn) and check its range.
    fn check_index(&self, kind: usize, text: &str) -> Result<()> {
        let raw: i64 = text
            .parse()
            .map_err(|_| self.parse_error(format!("`{text}` is not an index")))?;
        let resolved = match raw {
            0 => return Err(self.parse_error("index 0 is invalid (OBJ indices start at 1)".into())),
            r if r > 0 => (r - 1) as u64,
            r => {
                let back = r.unsigned_abs();
                if back > self.seen[kind] as u64 {
                    return Err(self.parse_error(format!(
                        "relative index {r} reaches before the first {}",
                        ELEMENT_NAMES[kind]
                    )));
                }
                self.seen[kind] as u64 - back
            }
        };
        if resolved >= self.totals[kind] as u64 {
            return Err(Error::IndexOutOfRange {
                mesh: location(self.path, self.line_no),
                face: self.face,
                what: ELEMENT_NAMES[kind],
                index: resolved as usize,
                count: self.totals[kind],
            });
        }
        Ok(())
    }

    fn parse_error(&self, message: String) -> Error {
        Error::MeshParse {
            path: self.path.to_path_buf(),
            message: format!("line {}, face {}: {message}", self.line_no, self.face),
        }
    }
}
