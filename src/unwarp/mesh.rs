//! The node mesh (notes § Discretisation; seed: "per-texel texture coordinates"): every texel
//! is a node, lifted by the height map, with a 6-neighbour stencil, and the colouring into
//! phases (notes § One pass, step 4).
//!
//! Node (x, y) sits at X = ((x + ½)/W, (y + ½)/H, s·h(x, y)); its texture coordinate is
//! u = X.xy + o with o the stored offset (UV units). Only differences of positions and of
//! texture coordinates enter the energy, so across a periodic border the neighbour's position
//! is taken unwrapped: edge vectors are P = X(c) − X(n) = (−dx/W, −dy/H, s(h_c − h_n)) and
//! U = u(c) − u(n) = (−dx/W, −dy/H) + o_c − o_n for the stencil step d = (dx, dy).

use crate::error::{Error, Result};

use super::height::HeightMap;

/// The 6 neighbour steps (dx, dy), counter-clockwise in (x, y): every grid cell split along its
/// anti-diagonal. Node c has the 6 triangles T_k = (c, n_{k−1}, n_k), k = 0…5 (n_{−1} = n_5).
pub const STENCIL: [[i64; 2]; 6] = [[0, -1], [1, -1], [1, 0], [0, 1], [-1, 1], [-1, 0]];

/// What happens at the map's edge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum Border {
    /// The map tiles: neighbours across the border wrap (the demo's and the paper's setting).
    #[default]
    Periodic,
    /// The outermost ring of texels keeps offset 0; triangles stop at the edge.
    Fixed,
}

/// How texels are split into phases whose members share no triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Colouring {
    /// Four phases, p = (x & 1) + 2 (y & 1). Needs even W and H with a periodic border.
    Quads,
    /// Three phases, p = (x − y) mod 3 (no stencil step has dx − dy ≡ 0 mod 3). Used for a
    /// periodic border when W or H is odd; needs W and H multiples of 3.
    Diagonal3,
}

/// The node mesh of one level: geometry (z = s·h per node), border and colouring.
#[derive(Clone, Debug, PartialEq)]
pub struct UnwarpMesh {
    pub width: usize,
    pub height: usize,
    /// Lifted heights z = s·h, row-major.
    pub z: Vec<f64>,
    pub border: Border,
    pub colouring: Colouring,
}

impl UnwarpMesh {
    /// The mesh of `heights` lifted by `scale`. [`Error::HeightMapSize`] when the map is too
    /// small (periodic: W, H ≥ 2; fixed: W, H ≥ 3, so that some texel is free) or, periodic,
    /// when neither colouring covers the size (W, H both even, or both multiples of 3);
    /// [`Error::InvalidArgument`] for a non-finite scale.
    pub fn new(heights: &HeightMap, scale: f64, border: Border) -> Result<Self> {
        let (w, h) = (heights.width, heights.height);
        let size_error = |reason: &str| Error::HeightMapSize {
            map: heights.name.clone(),
            width: w,
            height: h,
            reason: reason.into(),
        };
        if !scale.is_finite() {
            return Err(Error::InvalidArgument(format!(
                "displacement scale {scale} is not finite"
            )));
        }
        let colouring =
            match border {
                Border::Periodic if w < 2 || h < 2 => {
                    return Err(size_error("a periodic map needs at least 2×2 texels"))
                }
                Border::Fixed if w < 3 || h < 3 => {
                    return Err(size_error(
                        "a fixed border needs at least 3×3 texels (one free texel)",
                    ))
                }
                Border::Fixed => Colouring::Quads,
                Border::Periodic if w % 2 == 0 && h % 2 == 0 => Colouring::Quads,
                Border::Periodic if w % 3 == 0 && h % 3 == 0 => Colouring::Diagonal3,
                Border::Periodic => return Err(size_error(
                    "a periodic border needs even sizes (4 phases) or multiples of 3 (3 phases); \
                     use the fixed border for other sizes",
                )),
            };
        Ok(UnwarpMesh {
            width: w,
            height: h,
            z: heights.values.iter().map(|&v| scale * v).collect(),
            border,
            colouring,
        })
    }

    /// Number of nodes W·H.
    pub fn node_count(&self) -> usize {
        self.width * self.height
    }

    /// R = (W, H): multiplying an offset by R component-wise gives texels.
    pub fn resolution(&self) -> [f64; 2] {
        [self.width as f64, self.height as f64]
    }

    /// Index of node (x, y).
    pub fn index(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }

    /// The node one stencil step `k` from (x, y): wrapped (periodic) or `None` outside the map
    /// (fixed).
    pub fn neighbour(&self, x: usize, y: usize, k: usize) -> Option<usize> {
        let [dx, dy] = STENCIL[k];
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        let (w, h) = (self.width as i64, self.height as i64);
        match self.border {
            Border::Periodic => {
                Some(self.index(nx.rem_euclid(w) as usize, ny.rem_euclid(h) as usize))
            }
            Border::Fixed if nx < 0 || ny < 0 || nx >= w || ny >= h => None,
            Border::Fixed => Some(self.index(nx as usize, ny as usize)),
        }
    }

    /// Whether node (x, y) moves (every node when periodic; not the outer ring when fixed).
    pub fn is_free(&self, x: usize, y: usize) -> bool {
        match self.border {
            Border::Periodic => true,
            Border::Fixed => x > 0 && y > 0 && x + 1 < self.width && y + 1 < self.height,
        }
    }

    /// Number of phases of one sweep (4 or 3).
    pub fn phase_count(&self) -> usize {
        match self.colouring {
            Colouring::Quads => 4,
            Colouring::Diagonal3 => 3,
        }
    }

    /// The phase of texel (x, y): (x & 1) + 2 (y & 1), or (x − y) mod 3.
    pub fn phase_of(&self, x: usize, y: usize) -> usize {
        match self.colouring {
            Colouring::Quads => (x & 1) + 2 * (y & 1),
            Colouring::Diagonal3 => (x + 3 * self.height - y % 3) % 3,
        }
    }

    /// The free texels of `phase`, in row-major order: the only ones a pass computes.
    pub fn active_texels(&self, phase: usize) -> Vec<(usize, usize)> {
        let mut texels = Vec::new();
        for y in 0..self.height {
            for x in 0..self.width {
                if self.is_free(x, y) && self.phase_of(x, y) == phase {
                    texels.push((x, y));
                }
            }
        }
        texels
    }

    /// 3D edge P = X(c) − X(n_k) = (−dx/W, −dy/H, z_c − z_{n_k}); `None` outside a fixed border.
    pub fn edge_3d(&self, x: usize, y: usize, k: usize) -> Option<[f64; 3]> {
        let n = self.neighbour(x, y, k)?;
        let [du, dv] = base_uv_edge(k, self.resolution());
        Some([du, dv, self.z[self.index(x, y)] - self.z[n]])
    }

    /// The cells of the mesh as (node, k) pairs: triangles T_1 and T_2 of node (x, y) are the
    /// two halves of the cell [x, x+1]×[y−1, y], so each triangle is listed once. Fixed border:
    /// only cells inside the map.
    pub fn cell_owners(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (0..self.height)
            .flat_map(move |y| (0..self.width).map(move |x| (x, y)))
            .filter(move |&(x, y)| match self.border {
                Border::Periodic => true,
                Border::Fixed => x + 1 < self.width && y >= 1,
            })
    }

    /// Number of triangles (2 per cell).
    pub fn triangle_count(&self) -> usize {
        2 * self.cell_owners().count()
    }
}

/// The undeformed UV edge −d/R of stencil step k (R = (W, H)).
pub fn base_uv_edge(k: usize, resolution: [f64; 2]) -> [f64; 2] {
    let [dx, dy] = STENCIL[k];
    [-(dx as f64) / resolution[0], -(dy as f64) / resolution[1]]
}
