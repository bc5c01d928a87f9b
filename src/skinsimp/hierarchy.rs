//! The collapse-record hierarchy (SPEC.md § 9: a multiresolution hierarchy rather than
//! one level). [`Hierarchy::level`] replays the first `n` records on the input: vertex `removed`
//! of each record is merged into `kept`, which takes the record's position and weights; a face
//! survives exactly when its three corners still map to three different vertices; UV indices
//! follow the records' maps.

use nalgebra::{Matrix4, Point2, Point3};

use super::weights::Weights;
use super::Method;
use crate::mesh::TriMesh;

/// One edge collapse: `removed` merged into `kept`, which moves to `rest` with `weights`.
#[derive(Clone, Debug)]
pub struct CollapseRecord {
    pub kept: u32,
    pub removed: u32,
    /// Rest (bind) position of the merged vertex.
    pub rest: Point3<f64>,
    /// Its skin weights (empty for frame sequences).
    pub weights: Weights,
    /// Frame sequences: its position in every frame (empty for skinned meshes).
    pub frames: Vec<Point3<f64>>,
    /// UV index map of the collapse, old → new (new indices were appended to the UVs).
    pub uv_map: Vec<(u32, u32)>,
    /// The UVs it appended.
    pub new_uvs: Vec<Point2<f64>>,
    /// The collapse cost `E(v, α)`.
    pub cost: f64,
}

/// The input (cleaned: faces without repeated vertices, one UV index per vertex wedge, weights
/// reduced to `W_max`) and the collapses in order.
#[derive(Clone, Debug)]
pub struct Hierarchy {
    pub name: String,
    pub method: Method,
    pub faces: Vec<[u32; 3]>,
    pub uv_faces: Vec<[u32; 3]>,
    /// The input's UVs followed by those the records appended.
    pub uvs: Vec<Point2<f64>>,
    pub rest: Vec<Point3<f64>>,
    pub weights: Vec<Weights>,
    /// Frame sequences: `frames[j][i]` (empty for skinned meshes).
    pub frames: Vec<Vec<Point3<f64>>>,
    pub records: Vec<CollapseRecord>,
    pub texture: Option<std::path::PathBuf>,
}

/// One level of detail, compacted.
#[derive(Clone, Debug)]
pub struct Level {
    /// Rest mesh (frame sequences: frame 0) with UVs.
    pub mesh: TriMesh,
    /// Skin weights per vertex (empty lists for frame sequences).
    pub weights: Vec<Weights>,
    /// Frame sequences: `frames[j][i]`; empty for skinned meshes.
    pub frames: Vec<Vec<Point3<f64>>>,
    /// For each level vertex, the input vertex whose slot it occupies.
    pub input_vertex: Vec<u32>,
}

impl Level {
    /// The level's vertices in a pose given by its joint matrices (linear blend skinning with
    /// the level's weights).
    pub fn posed(&self, mats: &[Matrix4<f64>]) -> Vec<Point3<f64>> {
        super::skin_weights(&self.mesh.positions, &self.weights, mats)
    }
}

impl Hierarchy {
    /// Number of input vertices.
    pub fn input_vertices(&self) -> usize {
        self.rest.len()
    }

    /// The number of collapses that leaves at most `vertices` vertices (all of them when the
    /// simplification stopped earlier).
    pub fn collapses_for(&self, vertices: usize) -> usize {
        self.input_vertices()
            .saturating_sub(vertices)
            .min(self.records.len())
    }

    /// The mesh after the first `collapses` records (clamped to the number of records).
    pub fn level(&self, collapses: usize) -> Level {
        let n = self.rest.len();
        let collapses = collapses.min(self.records.len());
        let mut parent: Vec<u32> = (0..n as u32).collect();
        let mut rest = self.rest.clone();
        let mut weights = self.weights.clone();
        let mut frames = self.frames.clone();
        let mut uv_next: Vec<u32> = (0..self.uvs.len() as u32).collect();
        for r in &self.records[..collapses] {
            let (k, d) = (r.kept as usize, r.removed as usize);
            parent[d] = r.kept;
            rest[k] = r.rest;
            weights[k] = r.weights;
            for (j, p) in r.frames.iter().enumerate() {
                frames[j][k] = *p;
            }
            for &(old, new) in &r.uv_map {
                uv_next[old as usize] = new;
            }
        }
        let find = |mut v: u32, next: &[u32]| {
            while next[v as usize] != v {
                v = next[v as usize];
            }
            v
        };
        let mut faces = Vec::new();
        let mut uv_faces = Vec::new();
        for (f, t) in self.faces.iter().enumerate() {
            let m = t.map(|v| find(v, &parent));
            if m[0] == m[1] || m[1] == m[2] || m[2] == m[0] {
                continue;
            }
            faces.push(m);
            if !self.uv_faces.is_empty() {
                uv_faces.push(self.uv_faces[f].map(|u| find(u, &uv_next)));
            }
        }
        compact(self, faces, uv_faces, rest, weights, frames)
    }
}

/// Renumber the used vertices and UVs in increasing order of their old index.
fn compact(
    h: &Hierarchy,
    faces: Vec<[u32; 3]>,
    uv_faces: Vec<[u32; 3]>,
    rest: Vec<Point3<f64>>,
    weights: Vec<Weights>,
    frames: Vec<Vec<Point3<f64>>>,
) -> Level {
    let renumber = |used: &mut Vec<u32>, count: usize| -> Vec<u32> {
        let mut flag = vec![false; count];
        used.iter().for_each(|&i| flag[i as usize] = true);
        let mut map = vec![u32::MAX; count];
        let mut next = 0;
        for i in 0..count {
            if flag[i] {
                map[i] = next;
                next += 1;
            }
        }
        map
    };
    let mut used_v: Vec<u32> = faces.iter().flatten().copied().collect();
    let vmap = renumber(&mut used_v, rest.len());
    let mut used_u: Vec<u32> = uv_faces.iter().flatten().copied().collect();
    let umap = renumber(&mut used_u, h.uvs.len());
    let keep_v: Vec<usize> = (0..rest.len()).filter(|&i| vmap[i] != u32::MAX).collect();
    let keep_u: Vec<usize> = (0..h.uvs.len()).filter(|&i| umap[i] != u32::MAX).collect();
    let mesh = TriMesh {
        positions: keep_v.iter().map(|&i| rest[i]).collect(),
        uvs: keep_u.iter().map(|&i| h.uvs[i]).collect(),
        faces: faces.iter().map(|t| t.map(|v| vmap[v as usize])).collect(),
        uv_faces: uv_faces
            .iter()
            .map(|t| t.map(|u| umap[u as usize]))
            .collect(),
        texture: h.texture.clone(),
        name: format!("{} [{} simplified]", h.name, h.method.name()),
    };
    Level {
        mesh,
        weights: keep_v.iter().map(|&i| weights[i]).collect(),
        frames: frames
            .iter()
            .map(|f| keep_v.iter().map(|&i| f[i]).collect())
            .collect(),
        input_vertex: keep_v.iter().map(|&i| i as u32).collect(),
    }
}
