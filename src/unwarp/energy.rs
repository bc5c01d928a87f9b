//! The energy (notes § Energy; seed: "controllable area preservation via energy exponent θ",
//! σ₁ longest and σ₂ shortest stretch): per triangle, per node, and in total.
//!
//! For a triangle with 3D edge vectors P1, P2 and UV edge vectors U1, U2 (centre minus
//! neighbour):
//!
//! - A = |P1 × P2| (twice the 3D area), a = U1.x U2.y − U2.x U1.y (twice the signed UV area),
//! - D = |U1 − U2|² (P1·P2) + |U1|² ((P2 − P1)·P2) + |U2|² (P1·(P1 − P2)) = A² ‖J‖²_F,
//! - E_T = D/(A a) · (A/a + a/A)^θ = (σ1/σ2 + σ2/σ1) · (σ1σ2 + 1/(σ1σ2))^θ,
//!
//! J the Jacobian of the affine map 3D triangle → UV triangle. The first factor is MIPS
//! (angles), the second area; E_T ≥ 2·2^θ with equality iff J is a rotation.

use rayon::prelude::*;

use super::fixation::{pin_energy, pin_gradient};
use super::mesh::{base_uv_edge, UnwarpMesh};
use super::Problem;

/// What a triangle's energy needs of its 3D edges P1, P2 (constant during the descent).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TriangleGeometry {
    /// A = |P1 × P2|.
    pub area: f64,
    /// P1·P2, the weight of |U1 − U2|² in D.
    pub c12: f64,
    /// (P2 − P1)·P2, the weight of |U1|².
    pub c11: f64,
    /// P1·(P1 − P2), the weight of |U2|².
    pub c22: f64,
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm2_2(v: [f64; 2]) -> f64 {
    v[0] * v[0] + v[1] * v[1]
}

/// A, P1·P2, (P2 − P1)·P2 and P1·(P1 − P2) of the 3D edges `p1`, `p2`.
pub fn triangle_geometry(p1: [f64; 3], p2: [f64; 3]) -> TriangleGeometry {
    let cross = [
        p1[1] * p2[2] - p1[2] * p2[1],
        p1[2] * p2[0] - p1[0] * p2[2],
        p1[0] * p2[1] - p1[1] * p2[0],
    ];
    TriangleGeometry {
        area: dot3(cross, cross).sqrt(),
        c12: dot3(p1, p2),
        c11: dot3(sub3(p2, p1), p2),
        c22: dot3(p1, sub3(p1, p2)),
    }
}

/// a = U1.x U2.y − U2.x U1.y: twice the signed UV area (positive = not folded).
pub fn uv_area(u1: [f64; 2], u2: [f64; 2]) -> f64 {
    u1[0] * u2[1] - u2[0] * u1[1]
}

/// D = |U1 − U2|² (P1·P2) + |U1|² ((P2 − P1)·P2) + |U2|² (P1·(P1 − P2)) = A² ‖J‖²_F (the
/// cotangent formula).
pub fn dirichlet(t: &TriangleGeometry, u1: [f64; 2], u2: [f64; 2]) -> f64 {
    let u12 = [u1[0] - u2[0], u1[1] - u2[1]];
    norm2_2(u12) * t.c12 + norm2_2(u1) * t.c11 + norm2_2(u2) * t.c22
}

/// y^θ: [`integer_power`] (repeated multiplication, exact order) when θ is an integer in
/// [−64, 64], else `powf`. The WGSL twin `theta_power` does the same.
#[inline]
pub fn theta_power(y: f64, theta: f64) -> f64 {
    // θ integral and |θ| ≤ 64 (the cast saturates and sends NaN to 0, so it never passes
    // for a non-finite θ); cheaper than `fract`, which is a libm call.
    let n = theta as i32;
    if n as f64 == theta && n.abs() <= 64 {
        integer_power(y, n)
    } else {
        y.powf(theta)
    }
}

/// yⁿ by binary powering, in the order of `f64::powi`'s runtime routine (libgcc/compiler-rt
/// `__powidf2`, so the same bits) but inlined: r = y or 1 by the lowest bit of |n|, then per
/// further bit y ← y², r ← r·y when the bit is set; 1/r for n < 0.
#[inline]
pub fn integer_power(y: f64, n: i32) -> f64 {
    let mut bits = n.unsigned_abs();
    let mut base = y;
    let mut result = if bits & 1 == 1 { y } else { 1.0 };
    loop {
        bits >>= 1;
        if bits == 0 {
            break;
        }
        base *= base;
        if bits & 1 == 1 {
            result *= base;
        }
    }
    if n < 0 {
        1.0 / result
    } else {
        result
    }
}

/// E_T = D/(A a) · (A/a + a/A)^θ; +∞ for a folded or degenerate UV triangle (a ≤ 0): the
/// objective's domain is the fold-free maps.
pub fn triangle_energy(t: &TriangleGeometry, u1: [f64; 2], u2: [f64; 2], theta: f64) -> f64 {
    let a = uv_area(u1, u2);
    if a.is_nan() || a <= 0.0 {
        return f64::INFINITY;
    }
    let d = dirichlet(t, u1, u2);
    let y = t.area / a + a / t.area;
    d / (t.area * a) * theta_power(y, theta)
}

/// ∇E_T with respect to the centre's texture coordinate (∂U1/∂u(c) = ∂U2/∂u(c) = I): with
/// r = ∇a = (U2.y − U1.y, U1.x − U2.x), ∇D = 2[U1 ((P2 − P1)·P2) + U2 (P1·(P1 − P2))] and
/// Y = A/a + a/A,
///
/// ∇E_T = Y^θ [−D/(A a²) r + ∇D/(A a)] + D/(A a) · θ Y^{θ−1} (1/A − A/a²) r.
///
/// NaN for a folded triangle (a ≤ 0), where the energy is not differentiable.
pub fn triangle_gradient(t: &TriangleGeometry, u1: [f64; 2], u2: [f64; 2], theta: f64) -> [f64; 2] {
    let a = uv_area(u1, u2);
    if a.is_nan() || a <= 0.0 {
        return [f64::NAN; 2];
    }
    let big_a = t.area;
    let r = [u2[1] - u1[1], u1[0] - u2[0]];
    let d = dirichlet(t, u1, u2);
    let grad_d = [
        2.0 * (u1[0] * t.c11 + u2[0] * t.c22),
        2.0 * (u1[1] * t.c11 + u2[1] * t.c22),
    ];
    let y = big_a / a + a / big_a;
    let y_theta_m1 = theta_power(y, theta - 1.0);
    let y_theta = y_theta_m1 * y;
    let mips = d / (big_a * a);
    let r_coef = -d / (big_a * a * a) * y_theta
        + mips * theta * y_theta_m1 * (1.0 / big_a - big_a / (a * a));
    let d_coef = y_theta / (big_a * a);
    [
        r_coef * r[0] + d_coef * grad_d[0],
        r_coef * r[1] + d_coef * grad_d[1],
    ]
}

/// The six triangles around a free node c: their geometry and, per neighbour n_k, the constant
/// part of the UV edge, U_k = o_c + rel_k with rel_k = −d_k/R − o_{n_k}.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fan {
    /// Geometry of T_k = (c, n_{k−1}, n_k): `triangle_geometry(P_{k−1}, P_k)`.
    pub geometry: [TriangleGeometry; 6],
    pub rel: [[f64; 2]; 6],
}

impl Fan {
    /// The fan of free node (x, y) for the current `offsets` (its own offset is not read).
    pub fn new(mesh: &UnwarpMesh, offsets: &[[f64; 2]], x: usize, y: usize) -> Fan {
        let resolution = mesh.resolution();
        let mut p = [[0.0; 3]; 6];
        let mut rel = [[0.0; 2]; 6];
        for k in 0..6 {
            let n = mesh
                .neighbour(x, y, k)
                .expect("a free node has all six neighbours");
            p[k] = mesh
                .edge_3d(x, y, k)
                .expect("a free node has all six neighbours");
            let base = base_uv_edge(k, resolution);
            rel[k] = [base[0] - offsets[n][0], base[1] - offsets[n][1]];
        }
        let geometry = std::array::from_fn(|k| triangle_geometry(p[(k + 5) % 6], p[k]));
        Fan { geometry, rel }
    }

    /// U_k = o_c + rel_k for the centre offset `o`.
    pub fn uv_edges(&self, o: [f64; 2]) -> [[f64; 2]; 6] {
        self.rel.map(|r| [o[0] + r[0], o[1] + r[1]])
    }

    /// Σ_k E_{T_k} with the centre at offset `o`, k = 0…5 in order.
    pub fn triangles_energy(&self, o: [f64; 2], theta: f64) -> f64 {
        let u = self.uv_edges(o);
        (0..6).fold(0.0, |sum, k| {
            sum + triangle_energy(&self.geometry[k], u[(k + 5) % 6], u[k], theta)
        })
    }

    /// Σ_k ∇E_{T_k} with the centre at offset `o`, k = 0…5 in order.
    pub fn triangles_gradient(&self, o: [f64; 2], theta: f64) -> [f64; 2] {
        let u = self.uv_edges(o);
        (0..6).fold([0.0; 2], |sum, k| {
            let g = triangle_gradient(&self.geometry[k], u[(k + 5) % 6], u[k], theta);
            [sum[0] + g[0], sum[1] + g[1]]
        })
    }
}

/// The node energy F_c(o) = Σ_k E_{T_k} + E_pin(o): the one objective of both the gradient
/// and the line search (notes § Defects: the demo scaled one but not the other).
pub fn node_energy(fan: &Fan, weight: f64, resolution: [f64; 2], o: [f64; 2], theta: f64) -> f64 {
    fan.triangles_energy(o, theta) + pin_energy(weight, resolution, o)
}

/// ∇F_c(o) = Σ_k ∇E_{T_k} + ∇E_pin(o).
pub fn node_gradient(
    fan: &Fan,
    weight: f64,
    resolution: [f64; 2],
    o: [f64; 2],
    theta: f64,
) -> [f64; 2] {
    let t = fan.triangles_gradient(o, theta);
    let p = pin_gradient(weight, resolution, o);
    [t[0] + p[0], t[1] + p[1]]
}

/// Triangle T_k of node (x, y) (which must exist): geometry and UV edges (U_{k−1}, U_k),
/// computed exactly as [`Fan`] does.
pub fn triangle_at(
    mesh: &UnwarpMesh,
    offsets: &[[f64; 2]],
    x: usize,
    y: usize,
    k: usize,
) -> (TriangleGeometry, [f64; 2], [f64; 2]) {
    let resolution = mesh.resolution();
    let c = offsets[mesh.index(x, y)];
    let edge = |k: usize| {
        let n = mesh.neighbour(x, y, k).expect("triangle inside the map");
        let base = base_uv_edge(k, resolution);
        let rel = [base[0] - offsets[n][0], base[1] - offsets[n][1]];
        let p = mesh.edge_3d(x, y, k).expect("triangle inside the map");
        ([c[0] + rel[0], c[1] + rel[1]], p)
    };
    let (u1, p1) = edge((k + 5) % 6);
    let (u2, p2) = edge(k);
    (triangle_geometry(p1, p2), u1, u2)
}

/// The total objective E = Σ_T E_T + Σ_c E_pin(c), split in its two parts.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Energy {
    /// Σ_T E_T over every triangle once.
    pub triangles: f64,
    /// Σ_c E_pin(c) over the free nodes.
    pub pins: f64,
    /// Number of triangles.
    pub triangle_count: usize,
}

impl Energy {
    /// triangles + pins: what the descent decreases.
    pub fn total(&self) -> f64 {
        self.triangles + self.pins
    }

    /// Σ_T E_T / (n_T · 2·2^θ): the triangle energy relative to the unreachable minimum (every
    /// triangle isometric), the notes' reference figure.
    pub fn ratio(&self, theta: f64) -> f64 {
        self.triangles / (self.triangle_count as f64 * 2.0 * 2f64.powf(theta))
    }
}

/// Neumaier-compensated sum in slice order (deterministic; rounding far below a pass's change).
pub fn compensated_sum(values: &[f64]) -> f64 {
    let (mut sum, mut c) = (0.0f64, 0.0f64);
    for &v in values {
        let t = sum + v;
        if sum.abs() >= v.abs() {
            c += (sum - t) + v;
        } else {
            c += (v - t) + sum;
        }
        sum = t;
    }
    sum + c
}

/// E of `offsets`: each cell's two triangles T_1, T_2 from its owner node (see
/// [`UnwarpMesh::cell_owners`]), each free node's pin energy; per-node values computed in
/// parallel, summed in node order ([`compensated_sum`]), so the result does not depend on the
/// thread count.
pub fn total_energy(problem: &Problem, offsets: &[[f64; 2]]) -> Energy {
    let mesh = &problem.mesh;
    let owners: Vec<(usize, usize)> = mesh.cell_owners().collect();
    let cells: Vec<f64> = owners
        .par_iter()
        .map(|&(x, y)| {
            [1, 2].iter().fold(0.0, |sum, &k| {
                let (t, u1, u2) = triangle_at(mesh, offsets, x, y, k);
                sum + triangle_energy(&t, u1, u2, problem.theta)
            })
        })
        .collect();
    let resolution = problem.pin_resolution;
    let pins: Vec<f64> = (0..mesh.node_count())
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % mesh.width, i / mesh.width);
            if mesh.is_free(x, y) {
                pin_energy(problem.pins[i], resolution, offsets[i])
            } else {
                0.0
            }
        })
        .collect();
    Energy {
        triangles: compensated_sum(&cells),
        pins: compensated_sum(&pins),
        triangle_count: 2 * owners.len(),
    }
}
