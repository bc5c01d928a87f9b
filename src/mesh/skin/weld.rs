//! Skin-weight clean-up and welding.
//!
//! glTF stores one vertex per distinct combination of attributes, and many exporters write
//! unindexed triangle soups (three vertices per triangle, like the Khronos "Fox"). Welding
//! restores the surface: corners with exactly the same position and the same joint influences
//! become one vertex, while texture coordinates are welded on their own (exactly equal UVs share
//! a UV index). A UV seam thus stays a seam in UV space and is no longer a cut in the surface.

use std::collections::HashMap;

use nalgebra::{Point2, Point3};

use super::Influence;

/// Weights summing to 1 within this are "normalised" (about 8 f32 rounding steps at 1.0); others
/// are counted in [`GltfReport::renormalised_vertices`](super::GltfReport). All are rescaled.
pub(crate) const WEIGHT_SUM_TOLERANCE: f64 = 1e-6;

/// The influences of one vertex after [`clean_influences`].
pub(crate) struct CleanInfluences {
    /// Weights > 0 summing to 1, by decreasing weight (ties: smaller joint first).
    pub influences: Vec<Influence>,
    /// The raw weights did not sum to 1 within [`WEIGHT_SUM_TOLERANCE`].
    pub renormalised: bool,
    /// A joint appeared twice with non-zero weight (the weights were added).
    pub repeated_joint: bool,
}

/// Clean the raw `(joint, weight)` pairs of one vertex (all `JOINTS_n`/`WEIGHTS_n` sets):
/// drop zero weights, add up the weights of a repeated joint, divide by the sum `Σ w` so the
/// weights sum to 1, and sort by decreasing weight.
///
/// `Err` gives the reason for a negative or non-finite weight, or when no weight is positive.
pub(crate) fn clean_influences(raw: &[(u32, f64)]) -> Result<CleanInfluences, String> {
    if let Some(&(joint, w)) = raw.iter().find(|(_, w)| !w.is_finite() || *w < 0.0) {
        return Err(format!(
            "weight {w} of joint {joint} is negative or not finite"
        ));
    }
    let mut influences: Vec<Influence> = Vec::with_capacity(raw.len());
    let mut repeated_joint = false;
    for &(joint, weight) in raw.iter().filter(|(_, w)| *w > 0.0) {
        match influences.iter_mut().find(|i| i.joint == joint) {
            Some(earlier) => {
                earlier.weight += weight;
                repeated_joint = true;
            }
            None => influences.push(Influence { joint, weight }),
        }
    }
    let sum: f64 = influences.iter().map(|i| i.weight).sum();
    if sum <= 0.0 {
        return Err("all skin weights are zero".to_string());
    }
    for influence in &mut influences {
        influence.weight /= sum;
    }
    influences.sort_by(|a, b| b.weight.total_cmp(&a.weight).then(a.joint.cmp(&b.joint)));
    Ok(CleanInfluences {
        influences,
        renormalised: (sum - 1.0).abs() > WEIGHT_SUM_TOLERANCE,
        repeated_joint,
    })
}

/// Triangles over per-vertex attributes, as read from glTF primitives (the vertices of all
/// primitives concatenated, triangle indices shifted accordingly).
#[derive(Default)]
pub(crate) struct Soup {
    pub positions: Vec<Point3<f64>>,
    /// One UV per vertex; `None` as soon as one primitive has no `TEXCOORD_0`.
    pub uvs: Option<Vec<Point2<f64>>>,
    /// One (cleaned) influence list per vertex; empty lists for an unskinned mesh.
    pub influences: Vec<Vec<Influence>>,
    pub triangles: Vec<[u32; 3]>,
}

impl Soup {
    /// Append the vertices and triangles of `other` (its indices shifted past ours).
    pub fn append(&mut self, other: Soup) {
        let first_append = self.positions.is_empty() && self.triangles.is_empty();
        let offset = self.positions.len() as u32;
        self.uvs = match (self.uvs.take(), other.uvs) {
            (Some(mut ours), Some(theirs)) => {
                ours.extend(theirs);
                Some(ours)
            }
            (None, theirs) if first_append => theirs,
            _ => None,
        };
        self.positions.extend(other.positions);
        self.influences.extend(other.influences);
        let shift = |t: [u32; 3]| t.map(|v| v + offset);
        self.triangles
            .extend(other.triangles.into_iter().map(shift));
    }
}

/// The mesh arrays after welding (or not).
pub(crate) struct Welded {
    pub positions: Vec<Point3<f64>>,
    pub influences: Vec<Vec<Influence>>,
    pub uvs: Vec<Point2<f64>>,
    pub faces: Vec<[u32; 3]>,
    /// Empty when the soup has no UVs.
    pub uv_faces: Vec<[u32; 3]>,
    /// Positions shared by several welded vertices because their influences differ.
    pub split_positions: usize,
    /// Faces with a repeated vertex index.
    pub degenerate_faces: usize,
}

/// A coordinate as an exact hash key; `+ 0.0` turns −0 into +0 so that the two compare equal,
/// as they do as numbers.
fn key(x: f64) -> u64 {
    (x + 0.0).to_bits()
}

fn position_key(p: &Point3<f64>) -> [u64; 3] {
    [key(p.x), key(p.y), key(p.z)]
}

/// What makes two corners one vertex: exact position and identical influences.
type VertexKey = ([u64; 3], Vec<(u32, u64)>);

fn influence_key(influences: &[Influence]) -> Vec<(u32, u64)> {
    influences
        .iter()
        .map(|i| (i.joint, key(i.weight)))
        .collect()
}

/// Weld the soup: corners with exactly equal position and identical influences share one
/// vertex, corners with exactly equal UVs share one UV index. Vertices and UVs are numbered in
/// the order the triangles first use them (vertices no triangle uses are dropped); triangles
/// keep their order.
pub(crate) fn weld(soup: &Soup) -> Welded {
    let mut vertex_index: HashMap<VertexKey, u32> = HashMap::new();
    let mut uv_index: HashMap<[u64; 2], u32> = HashMap::new();
    let (mut positions, mut influences, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
    let mut faces = Vec::with_capacity(soup.triangles.len());
    let mut uv_faces = Vec::new();
    for triangle in &soup.triangles {
        let face = triangle.map(|v| {
            let (p, inf) = (&soup.positions[v as usize], &soup.influences[v as usize]);
            *vertex_index
                .entry((position_key(p), influence_key(inf)))
                .or_insert_with(|| {
                    positions.push(*p);
                    influences.push(inf.clone());
                    positions.len() as u32 - 1
                })
        });
        faces.push(face);
        if let Some(soup_uvs) = &soup.uvs {
            uv_faces.push(triangle.map(|v| {
                let t = soup_uvs[v as usize];
                *uv_index.entry([key(t.x), key(t.y)]).or_insert_with(|| {
                    uvs.push(t);
                    uvs.len() as u32 - 1
                })
            }));
        }
    }
    Welded {
        split_positions: count_split_positions(&positions),
        degenerate_faces: count_degenerate(&faces),
        positions,
        influences,
        uvs,
        faces,
        uv_faces,
    }
}

/// The soup as it is: one vertex and one UV per glTF vertex, faces = triangles.
pub(crate) fn without_welding(soup: Soup) -> Welded {
    let uv_faces = match soup.uvs {
        Some(_) => soup.triangles.clone(),
        None => Vec::new(),
    };
    Welded {
        split_positions: 0,
        degenerate_faces: count_degenerate(&soup.triangles),
        positions: soup.positions,
        influences: soup.influences,
        uvs: soup.uvs.unwrap_or_default(),
        faces: soup.triangles,
        uv_faces,
    }
}

/// How many distinct positions appear more than once among the welded vertices.
fn count_split_positions(positions: &[Point3<f64>]) -> usize {
    let mut uses: HashMap<[u64; 3], usize> = HashMap::new();
    for p in positions {
        *uses.entry(position_key(p)).or_default() += 1;
    }
    uses.values().filter(|&&n| n > 1).count()
}

/// Faces whose three vertex indices are not all different.
fn count_degenerate(faces: &[[u32; 3]]) -> usize {
    let repeats = |[a, b, c]: &[u32; 3]| a == b || b == c || a == c;
    faces.iter().filter(|f| repeats(f)).count()
}
