//! Figures of a correction (notes § Reference figures): uniformity of the UV/3D area ratio,
//! the largest offset, and per-triangle / per-texel singular values of J.

use rayon::prelude::*;

use super::energy::{dirichlet, triangle_at, uv_area, TriangleGeometry};
use super::mesh::UnwarpMesh;
use super::Problem;

/// (σ1/σ2, σ1σ2) of a triangle's Jacobian J (3D → UV) from the closed forms
/// σ1σ2 = a/A and σ1/σ2 + σ2/σ1 = D/(A a) = m, so σ1/σ2 = (m + √(m² − 4))/2.
/// (NaN, a/A) for a folded triangle.
pub fn triangle_sigmas(t: &TriangleGeometry, u1: [f64; 2], u2: [f64; 2]) -> [f64; 2] {
    let a = uv_area(u1, u2);
    let m = dirichlet(t, u1, u2) / (t.area * a);
    let ratio = if a > 0.0 {
        0.5 * (m + (m * m - 4.0).max(0.0).sqrt())
    } else {
        f64::NAN
    };
    [ratio, a / t.area]
}

/// The area ratio a/A (= σ1σ2) of every triangle, each once (cells in
/// [`UnwarpMesh::cell_owners`] order, T_1 then T_2).
pub fn area_ratios(problem: &Problem, offsets: &[[f64; 2]]) -> Vec<f64> {
    let mesh = &problem.mesh;
    let owners: Vec<(usize, usize)> = mesh.cell_owners().collect();
    owners
        .par_iter()
        .flat_map_iter(|&(x, y)| {
            [1, 2].map(|k| {
                let (t, u1, u2) = triangle_at(mesh, offsets, x, y, k);
                uv_area(u1, u2) / t.area
            })
        })
        .collect()
}

/// Population coefficient of variation std/mean (in slice order; 0 for an empty slice).
pub fn coefficient_of_variation(values: &[f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    var.sqrt() / mean
}

/// max over texels of ‖R⊙o‖, the offset in texels.
pub fn max_offset_texels(mesh: &UnwarpMesh, offsets: &[[f64; 2]]) -> f64 {
    let r = mesh.resolution();
    offsets
        .iter()
        .map(|o| (r[0] * o[0]).hypot(r[1] * o[1]))
        .fold(0.0, f64::max)
}

/// The uniformity figures of a correction.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Uniformity {
    /// Coefficient of variation of a/A over the triangles (0 = every triangle scaled alike).
    pub area_ratio_cv: f64,
    /// Largest σ1/σ2 over the triangles (1 = conformal).
    pub max_sigma_ratio: f64,
    /// Largest offset in texels.
    pub max_offset_texels: f64,
}

/// [`Uniformity`] of `offsets`.
pub fn uniformity(problem: &Problem, offsets: &[[f64; 2]]) -> Uniformity {
    let distortion = texel_distortion(problem, offsets);
    Uniformity {
        area_ratio_cv: coefficient_of_variation(&area_ratios(problem, offsets)),
        max_sigma_ratio: distortion.max_ratio,
        max_offset_texels: max_offset_texels(&problem.mesh, offsets),
    }
}

/// Per-texel distortion: for each texel the mean over the two triangles of the cell it owns
/// (see [`UnwarpMesh::cell_owners`]) of σ1/σ2 and of σ1σ2; texels owning no cell (fixed
/// border: last column, first row) get 1, 1.
#[derive(Clone, Debug, PartialEq)]
pub struct TexelDistortion {
    pub ratio: Vec<f64>,
    pub product: Vec<f64>,
    /// Largest σ1/σ2 over all triangles.
    pub max_ratio: f64,
}

/// [`TexelDistortion`] of `offsets`.
pub fn texel_distortion(problem: &Problem, offsets: &[[f64; 2]]) -> TexelDistortion {
    let mesh = &problem.mesh;
    let n = mesh.node_count();
    let (mut ratio, mut product) = (vec![1.0; n], vec![1.0; n]);
    let mut max_ratio = 1.0f64;
    for (x, y) in mesh.cell_owners() {
        let s = [1, 2].map(|k| {
            let (t, u1, u2) = triangle_at(mesh, offsets, x, y, k);
            triangle_sigmas(&t, u1, u2)
        });
        let i = mesh.index(x, y);
        ratio[i] = 0.5 * (s[0][0] + s[1][0]);
        product[i] = 0.5 * (s[0][1] + s[1][1]);
        max_ratio = max_ratio.max(s[0][0]).max(s[1][0]);
    }
    TexelDistortion {
        ratio,
        product,
        max_ratio,
    }
}
