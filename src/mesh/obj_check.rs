//! The OBJ parser: one pass over the text that checks every statement and builds the
//! [`TriMesh`] in file order.
//!
//! Nothing is renumbered or merged: vertex `i` of the mesh is the `i`-th `v` line of the file
//! and texture coordinate `j` the `j`-th `vt` line (both counted from 0), and face `f` in an
//! error is the `f`-th `f` statement (from 0; for a file of triangles, the triangle index). So a
//! vertex or face named in an error, here or in any algorithm downstream, can be found in the
//! file.
//!
//! Statements read:
//! - `v x y z [w]` and `v x y z r g b`: a position (the weight and the colour are ignored);
//! - `vt u v [w]`: a texture coordinate (`w` is ignored);
//! - `vn`: only counted, so that face corners referring to normals can be checked;
//! - `f c₁ c₂ c₃ …`: a polygon, split into the triangle fan `(c₁, cₖ, cₖ₊₁)`. A corner is `v`,
//!   `v/vt`, `v//vn` or `v/vt/vn`; an index is 1-based, or negative: relative to the elements
//!   read *so far* (`-1` is the last one). Positive indices may refer further down the file;
//! - `mtllib name`: a material library, for the texture lookup.
//!
//! Everything else (`o`, `g`, `s`, `usemtl`, `vp`, `l`, `p`, free-form geometry) is ignored: all
//! faces form one mesh. `#` starts a comment, and a line ending in `\` continues on the next.
//!
//! Problems become typed errors naming the file and the line (as `path:line`), the face and the
//! vertex: a `nan` or `inf` coordinate (Rust's `f64::from_str` accepts them), an index out of
//! range or reaching before the first element, a face with fewer than 3 corners, a face
//! without texture coordinates when other faces have them.

use std::borrow::Cow;
use std::path::Path;

use nalgebra::{Point2, Point3};

use super::trimesh::TriMesh;
use crate::error::{Error, Result};

/// A parsed OBJ file: the mesh (named after the file, without texture) and the material
/// libraries named by `mtllib` statements, in file order.
#[derive(Clone, Debug)]
pub(crate) struct ParsedObj {
    pub mesh: TriMesh,
    pub material_libraries: Vec<String>,
}

/// The three kinds of indexed element a face corner `v/vt/vn` refers to.
const ELEMENT_NAMES: [&str; 3] = ["vertex", "texture coordinate", "normal"];

/// Parse `text`, the contents of the OBJ file `path` (see the module documentation).
///
/// The mesh is not validated beyond what the statements themselves require: an empty mesh is
/// returned as such (the caller runs [`TriMesh::validate`]).
pub(crate) fn parse_obj(text: &str, path: &Path) -> Result<ParsedObj> {
    let mut parser = Parser::new(path);
    for (line_no, statement) in statements(text) {
        parser.line_no = line_no;
        parser.statement(&statement)?;
    }
    parser.finish()
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

/// The statements of `text`, each with the number (from 1) of the line it starts on: comments
/// removed, and a line ending in `\` joined with the next one.
fn statements(text: &str) -> impl Iterator<Item = (usize, Cow<'_, str>)> {
    let mut lines = text.lines().enumerate();
    std::iter::from_fn(move || {
        let (index, first) = lines.next()?;
        let mut statement = Cow::Borrowed(without_comment(first));
        while let Some(start) = statement.trim_end().strip_suffix('\\') {
            // Appending in place keeps a long run of continued lines linear (re-formatting the
            // whole statement at every line was quadratic).
            let keep = start.len();
            let next = lines.next().map_or("", |(_, line)| without_comment(line));
            let owned = statement.to_mut();
            owned.truncate(keep);
            owned.push(' ');
            owned.push_str(next);
        }
        Some((index + 1, statement))
    })
}

fn without_comment(line: &str) -> &str {
    line.find('#').map_or(line, |hash| &line[..hash])
}

/// One face corner: its position index and, when given, its texture-coordinate index.
#[derive(Clone, Copy)]
struct Corner {
    vertex: u32,
    uv: Option<u32>,
}

/// A positive index beyond the elements read so far, checked once the whole file is read.
struct ForwardReference {
    line_no: usize,
    face: usize,
    kind: usize,
    index: usize,
}

/// The state of the one pass over the statements.
struct Parser<'a> {
    path: &'a Path,
    /// Line (from 1) of the statement being read.
    line_no: usize,
    mesh: TriMesh,
    material_libraries: Vec<String>,
    normal_count: usize,
    /// Number of the `f` statement being read (= `f` statements read so far).
    face: usize,
    /// Whether face 0 has texture coordinates, and its line: every face must agree with it.
    first_face: Option<(bool, usize)>,
    forward_references: Vec<ForwardReference>,
}

impl<'a> Parser<'a> {
    fn new(path: &'a Path) -> Self {
        Parser {
            path,
            line_no: 0,
            mesh: TriMesh {
                name: path.display().to_string(),
                ..Default::default()
            },
            material_libraries: Vec::new(),
            normal_count: 0,
            face: 0,
            first_face: None,
            forward_references: Vec::new(),
        }
    }

    fn statement(&mut self, line: &str) -> Result<()> {
        match keyword(line) {
            Some("v") => self.vertex(line),
            Some("vt") => self.texture_coordinate(line),
            Some("vn") => {
                self.normal_count += 1;
                Ok(())
            }
            Some("f") => self.face(line),
            Some("mtllib") => {
                let library = statement_argument(line, "mtllib");
                self.material_libraries.push(library.to_string());
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// `v x y z`, optionally followed by a weight or a colour (ignored).
    fn vertex(&mut self, line: &str) -> Result<()> {
        let [x, y, z] = self.coordinates(line, "vertex", self.mesh.positions.len())?;
        self.mesh.positions.push(Point3::new(x, y, z));
        Ok(())
    }

    /// `vt u v`, optionally followed by a depth `w` (ignored).
    fn texture_coordinate(&mut self, line: &str) -> Result<()> {
        let [u, v] = self.coordinates(line, "texture coordinate", self.mesh.uvs.len())?;
        self.mesh.uvs.push(Point2::new(u, v));
        Ok(())
    }

    /// `f c₁ c₂ c₃ …`: fan-triangulated into `faces` (and `uv_faces` when it has UVs).
    fn face(&mut self, line: &str) -> Result<()> {
        let words: Vec<&str> = line.split_whitespace().skip(1).collect();
        if words.len() < 3 {
            return Err(Error::DegenerateFace {
                mesh: self.here(),
                face: self.face,
                reason: format!("{} corner(s), a face needs at least 3", words.len()),
            });
        }
        let corners = words
            .iter()
            .map(|word| self.corner(word))
            .collect::<Result<Vec<Corner>>>()?;
        // `Some` when every corner has a texture coordinate.
        let uvs: Option<Vec<u32>> = corners.iter().map(|c| c.uv).collect();
        let some_uvs = corners.iter().any(|c| c.uv.is_some());
        self.check_uvs_all_or_none(uvs.is_some(), some_uvs)?;
        for k in 1..corners.len() - 1 {
            let fan = [0, k, k + 1];
            self.mesh.faces.push(fan.map(|i| corners[i].vertex));
            if let Some(uvs) = &uvs {
                self.mesh.uv_faces.push(fan.map(|i| uvs[i]));
            }
        }
        self.face += 1;
        Ok(())
    }

    /// A corner is `v`, `v/vt`, `v//vn` or `v/vt/vn`.
    fn corner(&mut self, word: &str) -> Result<Corner> {
        let parts: Vec<&str> = word.split('/').collect();
        if parts.len() > 3 || parts[0].is_empty() {
            return Err(self.parse_error(format!("cannot read face corner `{word}`")));
        }
        let given = |k: usize| parts.get(k).filter(|part| !part.is_empty());
        let vertex = self.index(0, parts[0])?;
        let uv = match given(1) {
            Some(part) => Some(self.index(1, part)?),
            None => None,
        };
        if let Some(part) = given(2) {
            self.index(2, part)?;
        }
        Ok(Corner { vertex, uv })
    }

    /// Resolve one OBJ index of element `kind` (0 = v, 1 = vt, 2 = vn) to a 0-based index.
    /// Indices beyond the elements read so far are checked in [`finish`](Self::finish).
    fn index(&mut self, kind: usize, text: &str) -> Result<u32> {
        let raw: i64 = text
            .parse()
            .map_err(|_| self.parse_error(format!("`{text}` is not an index")))?;
        let seen = self.element_count(kind);
        let index = match raw {
            0 => return Err(self.parse_error("index 0 is invalid (OBJ indices start at 1)".into())),
            r if r > 0 => (r - 1) as usize,
            r => {
                let back = r.unsigned_abs() as usize;
                if back > seen {
                    return Err(self.parse_error(format!(
                        "relative index {r} reaches before the first {}",
                        ELEMENT_NAMES[kind]
                    )));
                }
                seen - back
            }
        };
        if index >= seen {
            self.forward_references.push(ForwardReference {
                line_no: self.line_no,
                face: self.face,
                kind,
                index,
            });
        }
        Ok(index as u32)
    }

    /// Every corner of every face has a texture coordinate, or none has. `all_uvs` / `some_uvs`:
    /// whether all / some corners of the face being read have one.
    fn check_uvs_all_or_none(&mut self, all_uvs: bool, some_uvs: bool) -> Result<()> {
        let partial_uvs = |mesh, face| Err(Error::PartialUvs { mesh, face });
        if some_uvs && !all_uvs {
            return partial_uvs(self.here(), self.face);
        }
        match self.first_face {
            None => self.first_face = Some((all_uvs, self.line_no)),
            Some((true, _)) if !all_uvs => return partial_uvs(self.here(), self.face),
            // Face 0 is the one without texture coordinates.
            Some((false, line_no)) if all_uvs => {
                return partial_uvs(location(self.path, line_no), 0)
            }
            _ => {}
        }
        Ok(())
    }

    /// The first `N` numbers after the keyword; they must parse and be finite.
    fn coordinates<const N: usize>(
        &self,
        line: &str,
        what: &'static str,
        index: usize,
    ) -> Result<[f64; N]> {
        let words: Vec<&str> = line.split_whitespace().skip(1).take(N).collect();
        let values: Vec<f64> = words.iter().map_while(|w| w.parse().ok()).collect();
        let Ok(values) = <[f64; N]>::try_from(values) else {
            return Err(self.parse_error_at_line(format!(
                "{what} {index} needs {N} numbers: `{}`",
                line.trim()
            )));
        };
        if !values.iter().all(|x| x.is_finite()) {
            return Err(Error::NonFinite {
                mesh: self.here(),
                what,
                index,
                value: words.join(" "),
            });
        }
        Ok(values)
    }

    /// Check the indices that referred further down the file, and return the mesh.
    fn finish(self) -> Result<ParsedObj> {
        for reference in &self.forward_references {
            let count = self.element_count(reference.kind);
            if reference.index >= count {
                return Err(Error::IndexOutOfRange {
                    mesh: location(self.path, reference.line_no),
                    face: reference.face,
                    what: ELEMENT_NAMES[reference.kind],
                    index: reference.index,
                    count,
                });
            }
        }
        Ok(ParsedObj {
            mesh: self.mesh,
            material_libraries: self.material_libraries,
        })
    }

    /// Number of elements of `kind` (0 = v, 1 = vt, 2 = vn) read so far.
    fn element_count(&self, kind: usize) -> usize {
        [
            self.mesh.positions.len(),
            self.mesh.uvs.len(),
            self.normal_count,
        ][kind]
    }

    /// `path:line` of the statement being read.
    fn here(&self) -> String {
        location(self.path, self.line_no)
    }

    /// A syntax error in the face being read.
    fn parse_error(&self, message: String) -> Error {
        self.syntax_error(format!(
            "line {}, face {}: {message}",
            self.line_no, self.face
        ))
    }

    /// A syntax error in the statement being read.
    fn parse_error_at_line(&self, message: String) -> Error {
        self.syntax_error(format!("line {}: {message}", self.line_no))
    }

    fn syntax_error(&self, message: String) -> Error {
        Error::MeshParse {
            path: self.path.to_path_buf(),
            message,
        }
    }
}
