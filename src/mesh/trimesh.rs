//! `TriMesh`: a triangle mesh whose position indices and UV indices are kept separate, as in an
//! OBJ file. Keeping them separate is what lets a UV seam (one position, two UVs) stay a single
//! edge of the surface: loading with one shared index per corner would cut the surface there.

use nalgebra::{Point2, Point3};

use crate::error::{Error, Result};

/// A triangle mesh with separate position and texture-coordinate indexing.
///
/// Invariants checked by [`TriMesh::validate`]: at least one face, every index in range, every
/// coordinate finite, `uv_faces` either empty (no UVs) or one entry per face.
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    /// 3D vertex positions.
    pub positions: Vec<Point3<f64>>,
    /// Texture coordinates (may be empty).
    pub uvs: Vec<Point2<f64>>,
    /// Triangles as indices into `positions`, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
    /// Triangles as indices into `uvs`, corner for corner with `faces` (empty when no UVs).
    pub uv_faces: Vec<[u32; 3]>,
    /// Diffuse texture named by the material file, resolved relative to the mesh file.
    pub texture: Option<std::path::PathBuf>,
    /// Where the mesh came from (a file path or the name of a built-in mesh), used in errors.
    pub name: String,
}

impl TriMesh {
    /// A mesh with one UV per position (`uv_faces == faces`), as procedural meshes usually are.
    pub fn with_shared_indices(
        name: impl Into<String>,
        positions: Vec<Point3<f64>>,
        uvs: Vec<Point2<f64>>,
        faces: Vec<[u32; 3]>,
    ) -> Self {
        let uv_faces = if uvs.is_empty() {
            Vec::new()
        } else {
            faces.clone()
        };
        TriMesh {
            positions,
            uvs,
            faces,
            uv_faces,
            texture: None,
            name: name.into(),
        }
    }

    /// Number of triangles.
    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// Whether the mesh carries texture coordinates.
    pub fn has_uvs(&self) -> bool {
        !self.uv_faces.is_empty()
    }

    /// The three corner positions of face `f`.
    pub fn face_positions(&self, f: usize) -> [Point3<f64>; 3] {
        let [a, b, c] = self.faces[f];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// The three corner UVs of face `f` (the mesh must have UVs).
    pub fn face_uvs(&self, f: usize) -> [Point2<f64>; 3] {
        let [a, b, c] = self.uv_faces[f];
        [
            self.uvs[a as usize],
            self.uvs[b as usize],
            self.uvs[c as usize],
        ]
    }

    /// Axis-aligned bounding box of the positions, `(min, max)`.
    pub fn bounding_box(&self) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut hi = Point3::new(f64::NEG_INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in &self.positions {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (lo, hi)
    }

    /// Check the invariants: non-empty, indices in range, finite coordinates, consistent UVs.
    /// Returns a typed error naming the first offending element.
    pub fn validate(&self) -> Result<()> {
        let mesh = || self.name.clone();
        if self.faces.is_empty() || self.positions.is_empty() {
            return Err(Error::EmptyMesh { mesh: mesh() });
        }
        for (i, p) in self.positions.iter().enumerate() {
            if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                return Err(Error::NonFinite {
                    mesh: mesh(),
                    what: "vertex",
                    index: i,
                    value: format!("{} {} {}", p.x, p.y, p.z),
                });
            }
        }
        for (i, t) in self.uvs.iter().enumerate() {
            if !(t.x.is_finite() && t.y.is_finite()) {
                return Err(Error::NonFinite {
                    mesh: mesh(),
                    what: "texture coordinate",
                    index: i,
                    value: format!("{} {}", t.x, t.y),
                });
            }
        }
        check_indices(&self.faces, self.positions.len(), "vertex", &self.name)?;
        if !self.uv_faces.is_empty() {
            if self.uv_faces.len() != self.faces.len() {
                return Err(Error::PartialUvs {
                    mesh: mesh(),
                    face: self.uv_faces.len().min(self.faces.len()),
                });
            }
            check_indices(
                &self.uv_faces,
                self.uvs.len(),
                "texture coordinate",
                &self.name,
            )?;
        }
        Ok(())
    }

    /// Like [`validate`](Self::validate), and also require texture coordinates.
    pub fn validate_with_uvs(&self) -> Result<()> {
        self.validate()?;
        if !self.has_uvs() {
            return Err(Error::MissingUvs {
                mesh: self.name.clone(),
            });
        }
        Ok(())
    }
}

fn check_indices(faces: &[[u32; 3]], count: usize, what: &'static str, name: &str) -> Result<()> {
    for (f, tri) in faces.iter().enumerate() {
        for &i in tri {
            if i as usize >= count {
                return Err(Error::IndexOutOfRange {
                    mesh: name.to_string(),
                    face: f,
                    what,
                    index: i as usize,
                    count,
                });
            }
        }
    }
    Ok(())
}
